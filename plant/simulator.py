"""The plant process's core: turbine dynamics, wind and sensors, one control period at a time.

:class:`PlantSimulator` advances the pure dynamics ``f(t, x, u, params)`` of
:mod:`plant.turbine` with fixed-step RK4 over one control period, with the demand switching
from the previous command to the new one after ``switch_step`` internal steps (so a
real-time run applies a command when it arrived, at the plant step's resolution), and turns
the state into the messages of :mod:`bus_schemas`: the noisy :class:`SensorFrame` a
controller sees and the true :class:`PlantState` for the log. It holds no clock and does no
I/O; the node layer (``hil.plant_node``) owns time and the bus.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bus_schemas import PlantState, SensorFrame
from plant.integrate import rk4_step
from plant.turbine import TurbineParams, f, outputs
from plant.wind import WindSpec, wind_speed
from sensors import NoiseSpec, SensorSuite

State = tuple[float, float, float]

# Bits of SensorFrame.valid_mask for the channels a bottom-fixed turbine has.
VALID_GENERATOR_SPEED = 1 << 0
VALID_ROTOR_SPEED = 1 << 1
VALID_PITCH = 1 << 2
VALID_TORQUE = 1 << 3
VALID_POWER = 1 << 4
VALID_WIND = 1 << 5
TURBINE_ONLY_MASK = (
    VALID_GENERATOR_SPEED
    | VALID_ROTOR_SPEED
    | VALID_PITCH
    | VALID_TORQUE
    | VALID_POWER
    | VALID_WIND
)


@dataclass(frozen=True)
class PlantConfig:
    """What the plant process simulates.

    Parameters
    ----------
    turbine : TurbineParams
        Rotor, drivetrain, generator and actuators.
    wind : WindSpec
        Hub-height wind over time.
    plant_step_s : float
        Fixed RK4 step, s.
    steps_per_cycle : int
        Plant steps per control period.
    sensor_noise : dict of str to NoiseSpec
        Noise of the measured channels (keys: SensorFrame field names).
    sensor_seed : int
        Seed of the sensor noise streams.
    """

    turbine: TurbineParams
    wind: WindSpec
    plant_step_s: float
    steps_per_cycle: int
    sensor_noise: dict[str, NoiseSpec]
    sensor_seed: int = 1

    def __post_init__(self) -> None:
        if not (self.plant_step_s > 0 and math.isfinite(self.plant_step_s)):
            raise ValueError(
                f"plant_step_s must be a positive number of seconds, got {self.plant_step_s}"
            )
        if self.steps_per_cycle < 1:
            raise ValueError(f"steps_per_cycle must be >= 1, got {self.steps_per_cycle}")


class PlantSimulator:
    """Integrates the plant over control periods and produces its messages."""

    def __init__(self, config: PlantConfig) -> None:
        self.config = config
        self.params = config.turbine
        self.h = config.plant_step_s
        self.n = config.steps_per_cycle
        self.sensors = SensorSuite(config.sensor_noise, config.sensor_seed)

    def initial_state(self) -> State:
        """Operating point at t = 0: the steady state the baseline would settle to.

        Rotor speed at the optimal tip-speed ratio, capped at rated; above rated, the pitch
        at which aerodynamic power equals rated mechanical power at rated speed; generator
        torque balancing the aerodynamic torque, so the run starts without a transient.
        """
        p = self.params
        u = wind_speed(0.0, self.config.wind)
        tsr_opt = p.table.optimal_tsr()
        omega = p.rated_rotor_speed_rad_s
        if u > 0:
            omega = min(omega, tsr_opt * u / p.rotor_radius_m)
        pitch = p.pitch_min_rad
        rated_mech_w = p.rated_power_w / p.generator_efficiency

        def aero_power(theta: float) -> float:
            out = outputs(0.0, (omega, theta, 0.0), (theta, 0.0, u), p)
            return out.aero_torque_nm * omega

        if aero_power(pitch) > rated_mech_w:
            lo, hi = p.pitch_min_rad, min(p.pitch_max_rad, math.radians(45.0))
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if aero_power(mid) > rated_mech_w:
                    lo = mid
                else:
                    hi = mid
            pitch = 0.5 * (lo + hi)
        out = outputs(0.0, (omega, pitch, 0.0), (pitch, 0.0, u), p)
        torque = max(0.0, min(p.torque_max_nm, out.aero_torque_nm / p.gearbox_ratio))
        return (omega, pitch, torque)

    def advance(
        self,
        t_s: float,
        x: State,
        previous: tuple[float, float],
        command: tuple[float, float],
        switch_step: int = 0,
    ) -> State:
        """Integrate one control period from ``t_s``.

        Parameters
        ----------
        t_s : float
            Simulated time at the start of the period, s.
        x : State
            (rotor speed rad/s, blade pitch rad, generator torque N m).
        previous, command : (pitch rad, torque N m)
            Demand held before the new command arrived, and the new command.
        switch_step : int
            Plant steps during which ``previous`` still applies (0: ``command`` at once).
        """
        h, p, wind = self.h, self.params, self.config.wind
        for i in range(self.n):
            t = t_s + i * h
            demand = previous if i < switch_step else command
            u = (demand[0], demand[1], wind_speed(t + 0.5 * h, wind))
            x = rk4_step(f, t, x, u, h, p)
        return x

    def truth(
        self, seq: int, t_ns: int, x: State, applied: tuple[float, float], publish_ns: int
    ) -> PlantState:
        """The true state and loads at ``t_ns`` (for the log, never for a controller)."""
        t = t_ns * 1e-9
        u_wind = wind_speed(t, self.config.wind)
        out = outputs(t, x, (applied[0], applied[1], u_wind), self.params)
        return PlantState(
            seq=seq,
            sample_time_ns=t_ns,
            publish_time_ns=publish_ns,
            rotor_speed_rad_s=x[0],
            generator_speed_rad_s=out.generator_speed_rad_s,
            blade_pitch_rad=x[1],
            generator_torque_nm=x[2],
            aero_torque_nm=out.aero_torque_nm,
            rotor_thrust_n=out.rotor_thrust_n,
            wind_speed_m_s=u_wind,
            relative_wind_speed_m_s=u_wind,
            electrical_power_w=out.electrical_power_w,
            tip_speed_ratio=out.tip_speed_ratio,
            power_coefficient=out.cp,
            thrust_coefficient=out.ct,
            blade_pitch_applied_rad=applied[0],
            generator_torque_applied_nm=applied[1],
        )

    def sensor_frame(self, seq: int, truth: PlantState, publish_ns: int) -> SensorFrame:
        """Noisy measurements of ``truth`` (each channel with its own seeded stream)."""
        m = self.sensors.measure
        gen_speed = m("generator_speed_measured_rad_s", truth.generator_speed_rad_s)
        return SensorFrame(
            seq=seq,
            sample_time_ns=truth.sample_time_ns,
            publish_time_ns=publish_ns,
            valid_mask=TURBINE_ONLY_MASK,
            generator_speed_measured_rad_s=gen_speed,
            rotor_speed_measured_rad_s=gen_speed / self.params.gearbox_ratio,
            blade_pitch_measured_rad=m("blade_pitch_measured_rad", truth.blade_pitch_rad),
            generator_torque_measured_nm=m(
                "generator_torque_measured_nm", truth.generator_torque_nm
            ),
            electrical_power_measured_w=m("electrical_power_measured_w", truth.electrical_power_w),
            wind_speed_measured_m_s=m("wind_speed_measured_m_s", truth.wind_speed_m_s),
            nacelle_acc_fore_aft_measured_m_s2=0.0,
            platform_pitch_measured_rad=0.0,
            platform_pitch_rate_measured_rad_s=0.0,
            platform_surge_measured_m=0.0,
            wave_elevation_gauge_measured_m=0.0,
        )
