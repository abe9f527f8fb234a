"""The advanced controller's fused cycle against the composed classes, cycle by cycle.

``AdvancedController.step`` runs its per-cycle path as one compiled call
(:func:`controller._kernels.advanced_cycle`), which re-states the glue between the wind EKF,
the scheduled platform KFs, the baseline's laws and the LQRI with its wave FF. The oracle is
that cycle composed from the public classes, each through its own ``step``
(``tests/_advanced_reference.py``, the controller's former code). Both run the same frames:
the sensor frames of two short closed-loop in-process runs of the IEA 15 MW on VolturnUS-S
(a wind ramp through rated, which switches the KF design and enters the pitch regime;
turbulence around rated, which leaves and re-enters it), with seeded faults added: on the
ramp, the first frame with speed, pitch and torque invalid (the EKF's start), random
invalid bits on every channel the cycle reads, sample-and-hold windows (a value repeated
exactly, which the KF must skip), an IMU dropout and a speed dropout longer than the
degraded threshold, and cycles of twice the period (two KF model steps). A shorter
forecaster window (256 taps, filled at 51 s) makes the forecast go from not filled to
filled inside the run, so the wave FF switches on.

Every output field and every state part must agree to 1e-12 relative (the kernels are the
same functions in the same order; in practice they agree to the last bit). The baseline's
re-stated law is also checked on its own against :class:`BaselineController` for both
shipped presets (the IEA 15 MW's second-order filter, torque PI, constant torque and
gain table; the NREL 5 MW's first-order filter, slip line, constant power and
θ_K schedule).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest
from _advanced_reference import ComposedAdvanced, ComposedState
from _baseline_oracle import ORACLE_INITIAL, oracle_pitch_gains, oracle_step
from _helpers import sensor_frame

from bus_schemas import SensorFrame
from bus_schemas.messages import (
    EST_FEEDFORWARD,
    EST_WAVE_FORECAST,
    VALID_GENERATOR_SPEED,
    VALID_NACELLE_ACC,
    VALID_PITCH,
    VALID_PLATFORM_PITCH,
    VALID_PLATFORM_PITCH_RATE,
    VALID_PLATFORM_SURGE,
    VALID_TORQUE,
    VALID_WAVE_GAUGE,
)
from controller import _kernels
from controller.baseline import BaselineController, load_baseline
from controller.interface import ControlOutput
from controller.runtime import AdvancedController, load_advanced_settings
from hil.inprocess.run import run_inprocess
from hil.nodes.controller_node import ControllerRuntime
from hil.scenario.schema import load_scenario

DT = 0.025
RTOL = 1e-12

_SCENARIO = """
name = "{name}"
description = "IEA 15 MW on VolturnUS-S, lqri_ff, fused-cycle check"
turbine = "iea15mw"
platform = "iea15mw_volturnus"
turbine_id = "t1"
duration_s = {duration}

[wind]
{wind}

[waves]
kind = "jonswap"
hs_m = 1.7
tp_s = 8.0
gamma = 3.3
seed = 102
gauge_distance_m = 450.0
n_components = 60

[timing]
control_period_s = 0.025
plant_step_s = 0.0125

[sensors]
seed = 5
[sensors.channels.generator_speed_measured_rad_s]
std = 0.002
resolution = 0.001

[controller]
kind = "lqri_ff"
preset = "iea15mw_advanced"
feedforward = "balanced"

# The recorded sequences are chosen for the transitions they cover (regime switches, KF
# designs); they were found with the plant's own start, so they keep it.
[initial]
trim = false
"""

RUNS = {
    # through rated: u_m crosses 9.5 m/s (KF designs 8 and 11 m/s) and the switch wind
    "ramp": (
        80.0,
        'kind = "ramp"\ninitial_m_s = 9.0\nfinal_m_s = 14.0\nstart_s = 5.0\nend_s = 50.0',
    ),
    # around rated: the pitch regime is left and entered again
    "turbulent": (120.0, 'kind = "turbulent"\nmean_m_s = 10.8\nturbulence_class = "A"\nseed = 4'),
}

_BITS = (
    VALID_GENERATOR_SPEED,
    VALID_PITCH,
    VALID_TORQUE,
    VALID_NACELLE_ACC,
    VALID_PLATFORM_PITCH_RATE,
    VALID_PLATFORM_PITCH,
    VALID_PLATFORM_SURGE,
    VALID_WAVE_GAUGE,
)


def _record(tmp: Path, run: str) -> list[SensorFrame]:
    duration, wind = RUNS[run]
    path = tmp / f"{run}.toml"
    path.write_text(_SCENARIO.format(name=f"fused-{run}", duration=duration, wind=wind))
    scenario = load_scenario(str(path))
    runtime = ControllerRuntime(scenario)
    frames: list[SensorFrame] = []

    def step(frame: SensorFrame) -> Any:
        frames.append(frame)
        result = runtime.handle_frame(frame)
        return None if result is None else result[0]

    run_inprocess(scenario, lambda _mt, _msg: None, step)
    return frames


def _with_faults(frames: list[SensorFrame], seed: int, first_invalid: int) -> list[SensorFrame]:
    """Seeded faults on recorded frames (module docstring); ``first_invalid``: the bits
    cleared on the first frame."""
    rng = np.random.default_rng(seed)
    out: list[SensorFrame] = []
    hold: dict[str, float] = {}
    for k, f in enumerate(frames):
        mask = f.valid_mask
        if k == 0:
            mask &= ~first_invalid
        for bit in _BITS:
            if rng.random() < 0.02:
                mask &= ~bit
        if 600 <= k < 640:  # IMU dropout, longer than the 0.5 s degraded threshold
            mask &= ~VALID_NACELLE_ACC
        if 900 <= k < 930:  # speed dropout, longer than the threshold
            mask &= ~VALID_GENERATOR_SPEED
        changes: dict[str, Any] = {"valid_mask": mask}
        if 300 <= k < 500:  # GNSS and attitude sampled at a quarter of the control rate
            for name in ("platform_surge_measured_m", "platform_pitch_measured_rad"):
                if k % 4 == 0:
                    hold[name] = getattr(f, name)
                changes[name] = hold[name]
        out.append(msgspec.structs.replace(f, **changes))
    return out


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[SensorFrame]]:
    tmp = tmp_path_factory.mktemp("fused")
    # on the ramp the EKF starts from the rated speed and the last commands (0) for pitch
    # and torque (speed, pitch and torque invalid): its mean wind starts at the lowest wind
    # of its range and climbs back; the turbulent run starts from a valid frame
    first = {"ramp": VALID_GENERATOR_SPEED | VALID_PITCH | VALID_TORQUE, "turbulent": 0}
    return {run: _with_faults(_record(tmp, run), 15, first[run]) for run in RUNS}


def _controller(feedforward: str) -> AdvancedController:
    settings = load_advanced_settings("iea15mw_advanced")
    short = msgspec.structs.replace(settings.forecast, n_taps=256)
    settings = msgspec.structs.replace(settings, forecast=short)
    return AdvancedController(settings, DT, gauge_distance_m=450.0, feedforward=feedforward)  # type: ignore[arg-type]


def _close(a: float, b: float) -> bool:
    return a == b or math.isclose(a, b, rel_tol=RTOL, abs_tol=0.0)


def _same_outputs(k: int, got: ControlOutput, want: ControlOutput) -> None:
    for name in ControlOutput.__struct_fields__:
        g, w = getattr(got, name), getattr(want, name)
        if isinstance(w, float):
            assert _close(g, w), f"cycle {k}: {name} {g!r} != {w!r}"
        else:
            assert g == w, f"cycle {k}: {name} {g!r} != {w!r}"


def _same_arrays(k: int, name: str, got: Any, want: Any) -> None:
    g, w = np.asarray(got, dtype=np.float64), np.asarray(want, dtype=np.float64)
    assert g.shape == w.shape, f"cycle {k}: {name} shape"
    ok = np.isclose(g, w, rtol=RTOL, atol=0.0, equal_nan=True) | (g == w)
    assert ok.all(), f"cycle {k}: {name} {g} != {w}"


def _same_state(k: int, ctrl: AdvancedController, fused: Any, ref: ComposedState) -> None:
    s = ctrl.state_parts(fused)
    assert ref.ekf is not None
    _same_arrays(k, "ekf x", s["ekf_x"], ref.ekf.x)
    _same_arrays(k, "ekf P", s["ekf_p"], ref.ekf.p)
    assert s["ekf_updates"] == ref.ekf.updates
    assert _close(s["ekf_innovation"], ref.ekf.innovation_rad_s)
    assert s["kf_index"] == ref.kf_index == fused.kf_index
    _same_arrays(k, "kf x", s["kf_x"], ref.kf.x)
    _same_arrays(k, "kf P", s["kf_P"], ref.kf.P)
    _same_arrays(k, "kf NIS", s["kf_nis"], ref.kf.nis)
    assert np.array_equal(s["kf_counts"], ref.kf.counts), f"cycle {k}: KF counters"
    assert bool(s["kf_degraded"]) == ref.kf.degraded
    lq = ref.lqri
    assert bool(s["lq_first_call"]) == lq.first_call
    assert bool(s["lq_above_rated"]) == lq.above_rated
    assert s["ff_index"] == lq.ff_index
    for part, value in (
        ("lq_integrator", lq.integrator_rad),
        ("lq_pitch", lq.blade_pitch_commanded_rad),
        ("lq_torque", lq.generator_torque_commanded_nm),
        ("lq_feedforward", lq.feedforward),
        ("lq_ff_pitch", lq.feedforward_pitch_rad),
        ("lq_ff_torque", lq.feedforward_torque_nm),
        ("last_pitch_cmd", ref.last_pitch_cmd_rad),
        ("last_torque_cmd", ref.last_torque_cmd_nm),
    ):
        assert _close(s[part], value), f"cycle {k}: {part} {s[part]!r} != {value!r}"
    if lq.ff_state is None:
        assert s["ff_state"] is None
    else:
        _same_arrays(k, "FF filter states", s["ff_state"], lq.ff_state)
    b = ref.baseline
    assert b is not None and not b.first_call and s["bl_first_call"] == 0
    _same_arrays(
        k,
        "baseline state",
        [s[n] for n in _kernels.ADV_FLOAT_STATE if n.startswith("bl_")],
        [
            b.lpf_z1,
            b.lpf_z2,
            b.generator_speed_filtered_rad_s,
            b.pitch_speed_error_integral_rad,
            b.torque_speed_error_integral_rad,
            b.blade_pitch_commanded_rad,
            b.generator_torque_commanded_nm,
        ],
    )
    _same_arrays(
        k,
        "last raw KF measurements",
        [s["last_z_acc"], s["last_z_pitch_rate"], s["last_z_pitch"], s["last_z_surge"]],
        ref.last_z,
    )
    assert s["speed_misses"] == ref.speed_misses
    assert fused.next_forecast_ns == ref.next_forecast_ns
    assert fused.forecast_time_ns == ref.forecast_time_ns
    assert _close(fused.forecast_m, ref.forecast_m) or (
        math.isnan(fused.forecast_m) and math.isnan(ref.forecast_m)
    )


@pytest.mark.parametrize("feedforward", ["balanced", "off"])
@pytest.mark.parametrize("run", sorted(RUNS))
def test_fused_cycle_equals_the_composed_classes(
    recorded: dict[str, list[SensorFrame]], run: str, feedforward: str
) -> None:
    frames = recorded[run]
    ctrl = _controller(feedforward)
    ref = ComposedAdvanced(ctrl)
    fused_state, ref_state = ctrl.initial_state(), ref.initial_state()
    seen = {"kf": set(), "above": set(), "forecast": set(), "degraded": set(), "regime": set()}
    switches = 0
    last_above = None
    for k, frame in enumerate(frames):
        dt = 2.0 * DT if k % 250 == 125 else DT  # a late cycle now and then: two model steps
        old = fused_state
        before = old.values.copy(), old.flags.copy()
        fused_state, got = ctrl.step(fused_state, frame, dt)
        ref_state, want = ref.step(ref_state, frame, dt)
        _same_outputs(k, got, want)
        _same_state(k, ctrl, fused_state, ref_state)
        # pure: the old state's vectors are not modified, the new ones are new arrays
        assert np.array_equal(old.values, before[0], equal_nan=True)
        assert np.array_equal(old.flags, before[1])
        assert fused_state.values is not old.values and fused_state.flags is not old.flags
        seen["kf"].add(ref_state.kf_index)
        seen["forecast"].add(bool(got.estimates_valid_mask & EST_WAVE_FORECAST))
        seen["degraded"].add(got.estimator_degraded)
        seen["regime"].add(got.regime)
        above = ref_state.lqri.above_rated
        switches += last_above is not None and above != last_above
        last_above = above
        assert bool(got.estimates_valid_mask & EST_FEEDFORWARD) == (feedforward != "off")
    # the faults and transitions the sequence is meant to cover did happen
    counts = ref_state.kf.counts
    assert counts[1].min() > 0, "every KF channel skipped at least once"
    assert seen["forecast"] == {False, True}, "forecast not filled, then filled"
    assert seen["degraded"] == {0, 1}
    assert ref_state.ekf is not None and ref_state.ekf.updates < len(frames)
    if run == "ramp":
        assert len(seen["kf"]) >= 2, "the KF design switched"
        assert switches >= 1, "the pitch regime was entered"
    else:
        assert switches >= 2, "the pitch regime was left and entered again"
    if feedforward != "off":
        assert ref_state.lqri.ff_state is not None and np.any(ref_state.lqri.ff_state != 0.0)


@pytest.mark.parametrize("preset", ["iea15mw_baseline", "nrel5mw_baseline"])
def test_baseline_kernel_equals_baseline_controller(preset: str) -> None:
    """``baseline_step`` (and ``BaselineController.step``, which calls it) against the
    plain-Python oracle (tests/_baseline_oracle.py) on a seeded speed sequence that
    crosses every torque region and drives the pitch from fine to feathered and back (the
    IEA 15 MW preset: TSR tracking on the wind EKF, minimum-pitch schedule, smoother)."""
    params = load_baseline(preset)
    ctrl = BaselineController(params)
    bl, gs, n_gs = ctrl.kernel_arrays()
    assert bl.size == len(_kernels.BL_CONSTANTS)
    tsr = params.torque_law == "tsr_tracking"
    assert tsr == (preset == "iea15mw_baseline")
    if ctrl.ekf is not None:
        prm, tsr_grid, pitch_grid, cells = ctrl.ekf.kernel_tables
    else:
        prm, tsr_grid, pitch_grid, cells = np.zeros(0), np.zeros(0), np.zeros(0), np.zeros((0, 8))
    rng = np.random.default_rng(3)
    w_rt = params.region25_end_generator_speed_rad_s
    n = 4000
    t = np.arange(n) * 0.01
    # generator speed from below cut-in to 1.3 x rated and back, with noise
    speed = w_rt * (0.3 + 1.0 * np.sin(np.pi * t / t[-1])) + 0.01 * w_rt * rng.normal(size=n)
    # measured torque following the speed (the wind estimate then sweeps the schedule)
    state = ORACLE_INITIAL
    bstate = ctrl.initial_state()
    st = np.zeros(_kernels.BL_STATE_SIZE)
    first = True
    regimes = set()
    winds = []
    for k in range(n):
        dt = 0.01 if k % 97 else 0.02
        frame_pitch = 0.05 * rng.random() + (0.2 * max(0.0, speed[k] / w_rt - 1.0))
        frame_torque = params.rated_torque_nm * min(1.0, (speed[k] / w_rt) ** 2) * rng.random()
        # platform pitch rate with dropouts (held by the feedback's filter input)
        rate = 0.01 * math.sin(2.0 * math.pi * t[k] / 30.0) + 0.002 * rng.normal()
        rate_ok = k % 53 != 7
        frame = msgspec.structs.replace(
            sensor_frame(float(speed[k]), frame_pitch, frame_torque),
            wind_speed_measured_m_s=7.5,
            platform_pitch_rate_measured_rad_s=rate,
            valid_mask=VALID_PLATFORM_PITCH_RATE if rate_ok else 0,
        )
        state, want = oracle_step(ctrl, state, frame, dt)
        bstate, via_step = ctrl.step(bstate, frame, dt)
        _same_outputs(k, via_step, want)
        st_out = np.empty(_kernels.BL_STATE_SIZE)
        got = _kernels.baseline_step(
            bl, gs, n_gs, first, st, float(speed[k]), frame_pitch, frame_torque, dt, st_out,
            7.5, prm, tsr_grid, pitch_grid, cells, rate, rate_ok,
        )  # fmt: skip
        first = False
        st = st_out
        w = (
            want.blade_pitch_commanded_rad,
            want.generator_torque_commanded_nm,
            want.regime,
            want.generator_speed_filtered_rad_s,
            want.pitch_integrator_rad,
            want.gain_schedule_factor,
            want.wind_speed_estimated_m_s,
            want.estimator_faults,
            want.estimator_degraded,
        )
        for a, b in zip(got, w, strict=True):
            assert _close(a, b), f"{preset} cycle {k}: {got} != {w}"
        want_st = [
            state.lpf_z1,
            state.lpf_z2,
            state.generator_speed_filtered_rad_s,
            state.pitch_speed_error_integral_rad,
            state.torque_speed_error_integral_rad,
            state.blade_pitch_commanded_rad,
            state.generator_torque_commanded_nm,
        ]
        if tsr:
            want_st += [
                state.wind_filtered_m_s,
                state.setpoint_shift_rad_s,
                state.min_pitch_rad,
                *state.wind_ekf_x,
                *state.wind_ekf_p,
                state.fl_hpf_lp,
                state.fl_lpf_z1,
                state.fl_lpf_z2,
                state.platform_pitch_rate_rad_s,
                state.estimator_faults,
                state.wind_bad_s,
                state.wind_good_s,
                float(state.wind_fallback),
                state.wind_last_good_m_s,
            ]
        _same_arrays(k, "baseline state", st[: len(want_st)], want_st)
        _same_arrays(k, "BaselineController state", bstate.values[: len(want_st)], want_st)
        if tsr:  # after the trimmed-start flag: the high pass's valid-sample count
            assert st[29] == state.fl_samples == bstate.fl_samples, f"cycle {k}"
        for theta in (-0.01, 0.0, 0.07, 0.2, 0.5):
            g = _kernels.baseline_gains(bl, gs, n_gs, theta)
            assert ctrl.pitch_gains(theta) == g
            assert all(
                _close(a, b) for a, b in zip(g, oracle_pitch_gains(ctrl, theta), strict=True)
            )
        regimes.add(want.regime)
        winds.append(want.wind_speed_estimated_m_s)
    if tsr:
        assert {1, 2, 4} <= regimes, f"{preset}: regions covered {sorted(regimes)}"
        assert min(winds) < 5.0 and max(winds) > 12.0, "the schedule was swept"
    else:
        assert {0, 2, 3, 4} <= regimes, f"{preset}: regions covered {sorted(regimes)}"


def test_int_fields_reuse_the_compiled_cycle(recorded: dict[str, list[SensorFrame]]) -> None:
    """A frame built in Python with ints where floats belong (msgspec does not convert on
    construction) gives the same command and does not make numba compile another signature
    of the cycle (a compile stall of tens of seconds in a real-time loop)."""
    ctrl = _controller("balanced")
    frames = recorded["turbulent"][:50]
    st_a, st_b = ctrl.initial_state(), ctrl.initial_state()
    for f in frames:
        ints = msgspec.structs.replace(
            f,
            platform_pitch_rate_measured_rad_s=round(f.platform_pitch_rate_measured_rad_s),
            nacelle_acc_fore_aft_measured_m_s2=round(f.nacelle_acc_fore_aft_measured_m_s2),
            generator_torque_measured_nm=round(f.generator_torque_measured_nm),
        )
        floats = msgspec.structs.replace(
            ints,
            platform_pitch_rate_measured_rad_s=float(ints.platform_pitch_rate_measured_rad_s),
            nacelle_acc_fore_aft_measured_m_s2=float(ints.nacelle_acc_fore_aft_measured_m_s2),
            generator_torque_measured_nm=float(ints.generator_torque_measured_nm),
        )
        assert isinstance(ints.generator_torque_measured_nm, int)
        st_a, out_a = ctrl.step(st_a, ints, DT)
        st_b, out_b = ctrl.step(st_b, floats, DT)
        assert out_a == out_b
    assert len(_kernels.advanced_cycle.signatures) == 1
