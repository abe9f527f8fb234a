"""The advanced controller's cycle composed from its public classes (the test oracle).

This is ``AdvancedController.step`` as it was before the cycle became one compiled call
(:func:`controller._kernels.advanced_cycle`): the wind EKF (:class:`WindSpeedEKF`), the
scheduled platform KFs (:class:`PlatformKF`), the baseline's laws
(:class:`BaselineController`) and the LQRI with its wave FF (:class:`LqriController`),
each called through its own public ``step``/``predict_update``, glued in Python.
``tests/test_controller_fused.py`` runs it beside the fused cycle frame by frame; it uses
the controller's own components (the same designs), so any difference is the fused code's.
"""

from __future__ import annotations

import math
from typing import Any

import msgspec
from _baseline_oracle import ORACLE_INITIAL, OracleState, oracle_pitch_gains, oracle_step

from bus_schemas.messages import (
    EST_FEEDFORWARD,
    EST_PLATFORM_PITCH,
    EST_PLATFORM_PITCH_RATE,
    EST_PLATFORM_SURGE,
    EST_PLATFORM_SURGE_VELOCITY,
    EST_TOWER_TOP_VELOCITY,
    EST_WAVE_FORECAST,
    EST_WIND_SPEED,
    VALID_GENERATOR_SPEED,
    VALID_NACELLE_ACC,
    VALID_PITCH,
    VALID_PLATFORM_PITCH,
    VALID_PLATFORM_PITCH_RATE,
    VALID_PLATFORM_SURGE,
    VALID_TORQUE,
    VALID_WAVE_GAUGE,
    SensorFrame,
)
from controller.estimators import PlatformKFState, WindEKFMeasurement, WindEKFState
from controller.interface import ControlOutput
from controller.lqri import LqriMeasurement, LqriState
from controller.runtime import UNMEASURED_SPEED_STD, AdvancedController


class ComposedState(msgspec.Struct, gc=False):
    """The composed cycle's state (the former ``AdvancedState``)."""

    ekf: WindEKFState | None
    kf: PlatformKFState
    kf_index: int
    lqri: LqriState
    forecaster: Any
    next_forecast_ns: int = 0
    forecast_m: float = math.nan
    forecast_time_ns: int = 0
    last_z: tuple[float, float, float, float] = (math.nan,) * 4
    last_pitch_cmd_rad: float = 0.0
    last_torque_cmd_nm: float = 0.0
    speed_misses: int = 0
    baseline: OracleState | None = None


class ComposedAdvanced:
    """``initial_state`` / ``step`` of the advanced controller over its public classes."""

    def __init__(self, ctrl: AdvancedController) -> None:
        self.c = ctrl

    def initial_state(self) -> ComposedState:
        c = self.c
        i = len(c.kfs) // 2
        return ComposedState(
            ekf=None,
            kf=c.kfs[i].initial_state(),
            kf_index=i,
            lqri=c.lqri.initial_state(),
            forecaster=c.forecaster.init_state(),
        )

    def _nearest(self, wind_m_s: float, current: int) -> int:
        g = self.c._wind_grid
        best = current
        for j, w in enumerate(g):
            if abs(w - wind_m_s) < abs(g[best] - wind_m_s) - 0.25:  # 0.25 m/s hysteresis
                best = j
        return best

    def step(
        self, state: ComposedState, frame: SensorFrame, dt_s: float
    ) -> tuple[ComposedState, ControlOutput]:
        c = self.c
        mask = frame.valid_mask
        s = c.settings
        speed_ok = bool(mask & VALID_GENERATOR_SPEED)
        omega_meas = frame.generator_speed_measured_rad_s / s.gearbox_ratio
        pitch = frame.blade_pitch_measured_rad if mask & VALID_PITCH else state.last_pitch_cmd_rad
        torque = (
            frame.generator_torque_measured_nm if mask & VALID_TORQUE else state.last_torque_cmd_nm
        )
        # 2. wind EKF
        ekf_state = state.ekf
        i = state.kf_index
        kf_state = state.kf
        if ekf_state is None:
            w0 = omega_meas if speed_ok else c.lqri.design.rated_rotor_speed_rad_s
            ekf_state = c.ekf.initial_state(w0, pitch, torque)
            if not speed_ok:  # the rated-speed guess's variance (AdvancedController._start)
                p0 = (UNMEASURED_SPEED_STD * w0) ** 2
                ekf_state = ekf_state._replace(p=(p0, *ekf_state.p[1:]))
            u0 = ekf_state.x[2]
            i = min(range(len(c._wind_grid)), key=lambda k: abs(c._wind_grid[k] - u0))
            kf_state = c._first_kf_state(i, frame)
        ekf_state, west = c.ekf.step(
            ekf_state, WindEKFMeasurement(omega_meas, pitch, torque, speed_ok), dt_s
        )
        speed_misses = 0 if speed_ok else state.speed_misses + 1
        omega = west.rotor_speed_rad_s
        # 3. platform KF, scheduled on the mean wind
        j = self._nearest(west.mean_wind_m_s, i)
        if j != i:
            kf_state = kf_state._replace(x=kf_state.x + c._x_op[i] - c._x_op[j])
            i = j
        kf = c.kfs[i]
        xo = c._x_op_f[i]
        u_op = c._u_op[i]
        u = (omega - u_op[0], pitch - u_op[1])
        raw = (
            frame.nacelle_acc_fore_aft_measured_m_s2,
            frame.platform_pitch_rate_measured_rad_s,
            frame.platform_pitch_measured_rad,
            frame.platform_surge_measured_m,
        )
        z = (raw[0], raw[1], raw[2] - xo[1], raw[3] - xo[0])
        last = state.last_z
        valid = (
            bool(mask & VALID_NACELLE_ACC) and raw[0] != last[0],
            bool(mask & VALID_PLATFORM_PITCH_RATE) and raw[1] != last[1],
            bool(mask & VALID_PLATFORM_PITCH) and raw[2] != last[2],
            bool(mask & VALID_PLATFORM_SURGE) and raw[3] != last[3],
        )
        kf_state = kf.predict_update(kf_state, u, z, valid, dt_s)
        xd = kf_state.x.tolist()
        x = [a + b for a, b in zip(xd, xo, strict=True)]
        degraded = kf_state.degraded or speed_misses > c._k_miss
        # 4. wave forecast on the gauge channel
        fstate = state.forecaster
        forecast_m, forecast_ns = state.forecast_m, state.forecast_time_ns
        next_ns = state.next_forecast_ns
        t_ns = frame.sample_time_ns
        if t_ns >= next_ns:
            fstate, forecast_m = c.forecaster.step(
                fstate,
                frame.wave_elevation_gauge_measured_m,
                bool(mask & VALID_WAVE_GAUGE),
            )
            forecast_ns = t_ns + c._horizon_ns
            period = c._forecast_period_ns
            next_ns = (t_ns // period + 1) * period
        forecast_ok = bool(fstate.filled) and math.isfinite(forecast_m)
        # 5. below-rated laws
        bst = state.baseline
        if bst is not None:
            bst = msgspec.structs.replace(
                bst,
                blade_pitch_commanded_rad=state.last_pitch_cmd_rad,
                generator_torque_commanded_nm=state.last_torque_cmd_nm
                - state.lqri.feedforward_torque_nm,
            )
        else:
            bst = ORACLE_INITIAL
        bframe = (
            frame
            if speed_ok
            else msgspec.structs.replace(
                frame, generator_speed_measured_rad_s=omega * s.gearbox_ratio
            )
        )
        bst, bout = oracle_step(c.baseline, bst, bframe, dt_s)
        # 6. regime logic + LQRI
        meas = LqriMeasurement(
            wind_speed_estimate_m_s=west.mean_wind_m_s,
            rotor_speed_rad_s=omega,
            blade_pitch_rad=pitch,
            platform_surge_m=x[0],
            platform_pitch_rad=x[1],
            tower_top_deflection_m=x[2],
            platform_surge_rate_m_s=x[3],
            platform_pitch_rate_rad_s=x[4],
            tower_top_deflection_rate_m_s=x[5],
            wave_elevation_forecast_m=forecast_m if forecast_ok else math.nan,
            torque_law_nm=bout.generator_torque_commanded_nm,
            pitch_below_rated_rad=bout.blade_pitch_commanded_rad,
            regime_below_rated=bout.regime,
        )
        lqri_state, out = c.lqri.step(state.lqri, meas, dt_s)
        integrator_rad = out.pitch_integrator_rad
        if lqri_state.above_rated:
            ki_eff = oracle_pitch_gains(c.baseline, out.blade_pitch_commanded_rad)[1]
            bst = msgspec.structs.replace(
                bst, pitch_speed_error_integral_rad=out.blade_pitch_commanded_rad / ki_eff
            )
        else:
            integrator_rad = bout.pitch_integrator_rad
        est_mask = (
            EST_WIND_SPEED
            | EST_PLATFORM_PITCH
            | EST_PLATFORM_PITCH_RATE
            | EST_PLATFORM_SURGE
            | EST_PLATFORM_SURGE_VELOCITY
            | EST_TOWER_TOP_VELOCITY
        )
        if forecast_ok:
            est_mask |= EST_WAVE_FORECAST
        if s.feedforward != "off":
            est_mask |= EST_FEEDFORWARD
        new = ComposedState(
            ekf=ekf_state,
            kf=kf_state,
            kf_index=i,
            lqri=lqri_state,
            forecaster=fstate,
            next_forecast_ns=next_ns,
            forecast_m=forecast_m,
            forecast_time_ns=forecast_ns,
            last_z=raw,
            last_pitch_cmd_rad=out.blade_pitch_commanded_rad,
            last_torque_cmd_nm=out.generator_torque_commanded_nm,
            speed_misses=speed_misses,
            baseline=bst,
        )
        result = ControlOutput(
            blade_pitch_commanded_rad=out.blade_pitch_commanded_rad,
            generator_torque_commanded_nm=out.generator_torque_commanded_nm,
            regime=out.regime,
            generator_speed_filtered_rad_s=omega * s.gearbox_ratio,
            pitch_integrator_rad=integrator_rad,
            gain_schedule_factor=max(out.gain_schedule_factor, 0.0),
            estimates_valid_mask=est_mask,
            estimator_degraded=int(degraded),
            wind_speed_estimated_m_s=west.wind_m_s,
            platform_surge_estimated_m=x[0],
            platform_pitch_estimated_rad=x[1],
            platform_surge_velocity_estimated_m_s=x[3],
            platform_pitch_rate_estimated_rad_s=x[4],
            tower_top_velocity_estimated_m_s=x[5],
            wave_elevation_forecast_m=forecast_m if forecast_ok else 0.0,
            wave_forecast_time_ns=forecast_ns if forecast_ok else 0,
            feedforward_pitch_rad=lqri_state.feedforward_pitch_rad,
            feedforward_torque_nm=lqri_state.feedforward_torque_nm,
            forecast_unstable_fits=int(getattr(fstate, "unstable_fits", 0)),
            forecast_guarded=int(getattr(fstate, "guarded", 0)),
        )
        return new, result
