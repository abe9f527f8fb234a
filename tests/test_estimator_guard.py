"""The baseline's wind-speed estimator cannot run away, and its faults are reported.

* ``trimmed_state`` starts the EKF at the mean wind, the kernel as the oracle;
* the wind EKF's step (every controller's) keeps its estimate in range on a wild speed;
* the guarded kernel equals the plain-Python oracle (tests/_baseline_oracle.py) through a
  forced divergence (a generator speed that jumps by 60 % of rated), the fault is counted
  once, the fallback flagged as ``estimator_degraded`` and the estimate stays in range;
* an IEA 15 MW scenario written as a user would from docs/guide/scenarios.md (14 m/s
  turbulent, JONSWAP Hs 3.5 m Tp 10 s, no sensor tables) gets the IEA 15 MW encoder and
  runs with a bounded estimate and no fault (in process, 60 s);
* a wildly biased speed sensor (``bias_step`` +0.5 rad/s) makes an estimator fault that
  ``summary.json`` counts (``controller.estimator_faults``) and the outcome reports (never
  ``ok``), the same in process and in lock-step.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import msgspec
import numpy as np
import pytest
from _baseline_oracle import ORACLE_INITIAL, oracle_step
from _helpers import fowt, sensor_frame

from bus_schemas.messages import VALID_GENERATOR_SPEED, VALID_PITCH, VALID_TORQUE
from controller.baseline import BaselineController, load_baseline
from controller.estimators import WindEKFMeasurement
from controller.interface import OperatingPoint
from controller.runtime import AdvancedController, load_advanced_settings
from hil.review.outcome import ExitCode
from hil.scenario.schema import parse_scenario

#: The user's scenario: docs/guide/scenarios.md's example with the IEA 15 MW at 14 m/s and
#: a rougher sea, no [sensors] table.
USER = """
name = "user-iea15-14"
turbine = "iea15mw"
platform = "iea15mw_volturnus"
duration_s = {duration}
[wind]
kind = "turbulent"
mean_m_s = 14.0
turbulence_class = "B"
seed = 2
[waves]
kind = "jonswap"
hs_m = 3.5
tp_s = 10.0
gamma = 3.3
seed = 102
[controller]
kind = "baseline"
preset = "iea15mw_baseline"
"""

#: A generator-speed sensor biased by +0.5 rad/s (60 % of the IEA 15 MW's rated speed).
BIAS = """
[[faults]]
kind = "bias_step"
channel = "generator_speed_measured_rad_s"
start_s = 20.0
bias = 0.5
"""


def _close(a: float, b: float) -> bool:
    return a == b or math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)


def test_the_iea15mw_gets_its_encoder_unless_the_scenario_sets_it() -> None:
    sc = parse_scenario(USER.format(duration=60.0))
    assert sc.sensors.channels["generator_speed_measured_rad_s"] == {
        "std": 0.002,
        "resolution": 0.001,
    }
    own = parse_scenario(
        USER.format(duration=60.0)
        + "[sensors.channels.generator_speed_measured_rad_s]\nstd = 0.01\n"
    )
    # key by key: the scenario's std, the preset's resolution
    assert own.sensors.channels["generator_speed_measured_rad_s"] == {
        "std": 0.01,
        "resolution": 0.001,
    }
    # the NREL 5 MW keeps the default suite's encoder (no preset)
    nrel = parse_scenario(
        USER.format(duration=60.0)
        .replace('"iea15mw"', '"nrel5mw"')
        .replace('platform = "iea15mw_volturnus"', 'platform = "nrel5mw_oc3_hywind"')
    )
    assert "generator_speed_measured_rad_s" not in nrel.sensors.channels


def test_a_diverging_estimate_is_a_fault_and_the_kernel_equals_the_oracle() -> None:
    ctrl = BaselineController(load_baseline("iea15mw_baseline"))
    p = ctrl.params
    state, bstate = ORACLE_INITIAL, ctrl.initial_state()
    rated = p.region25_end_generator_speed_rad_s
    dt = 0.025
    faults, degraded, winds = [], [], []
    for k in range(int(60.0 / dt)):
        t = k * dt
        # steady near rated, then the speed reading jumps by 0.5 rad/s at 10 s
        speed = 0.95 * rated + (0.5 if t >= 10.0 else 0.0)
        frame = msgspec.structs.replace(
            sensor_frame(speed, 0.02, 0.9 * p.rated_torque_nm), wind_speed_measured_m_s=10.0
        )
        state, want = oracle_step(ctrl, state, frame, dt)
        bstate, got = ctrl.step(bstate, frame, dt)
        for name in got.__struct_fields__:
            g, w = getattr(got, name), getattr(want, name)
            assert _close(g, w) if isinstance(w, float) else g == w, (k, name, g, w)
        faults.append(got.estimator_faults)
        degraded.append(got.estimator_degraded)
        winds.append(got.wind_speed_estimated_m_s)
    assert faults[int(9.9 / dt)] == 0  # healthy before the jump
    assert faults[-1] >= 1
    first = faults.index(1) * dt
    # gated from the jump on: the fault after wind_estimator_fault_s of it
    assert 10.0 + p.wind_estimator_fault_s - 0.1 <= first <= 10.0 + p.wind_estimator_fault_s + 0.1
    assert degraded[faults.index(1)] == 1
    assert all(p.wind_estimate_min_m_s <= v <= p.wind_estimate_max_m_s for v in winds)


def test_trimmed_state_starts_the_ekf_at_the_mean_wind_as_the_oracle() -> None:
    """trimmed_state: the kernel's trimmed start (the converged EKF, then one step on the
    point's steady frame) and its steps equal the oracle's, and the estimate starts at the
    mean wind (not the anemometer's 6.8 m/s) and stays there."""
    ctrl = BaselineController(load_baseline("iea15mw_baseline"))
    p = ctrl.params
    omega = 5.65 * math.pi / 30.0
    op = OperatingPoint(wind_m_s=8.0, rotor_speed_rad_s=omega, blade_pitch_rad=0.0)
    start, warm = ctrl.trimmed_estimator_state(op)
    assert start.first_call and start.trimmed
    assert start.wind_filtered_m_s == pytest.approx(8.0, abs=0.05)
    v = start.values
    state = msgspec.structs.replace(
        ORACLE_INITIAL,
        wind_filtered_m_s=float(v[7]),
        wind_ekf_x=tuple(v[10:13].tolist()),
        wind_ekf_p=tuple(v[13:19].tolist()),
        trimmed=True,
    )
    assert ctrl.ekf is not None
    torque = ctrl.ekf.aero_torque(omega, 8.0, 0.0)[0] / p.gearbox_ratio
    # trimmed_state: that state after one step on the point's steady frame
    assert warm.generator_torque_measured_nm == pytest.approx(torque, rel=1e-12)
    state, _ = oracle_step(ctrl, state, warm, 0.025)
    bstate = ctrl.trimmed_state(op)
    assert not bstate.first_call
    for k in range(400):
        frame = msgspec.structs.replace(
            sensor_frame(omega * p.gearbox_ratio, 0.0, torque), wind_speed_measured_m_s=6.8
        )
        state, want = oracle_step(ctrl, state, frame, 0.025)
        bstate, got = ctrl.step(bstate, frame, 0.025)
        for name in got.__struct_fields__:
            g, w = getattr(got, name), getattr(want, name)
            assert _close(g, w) if isinstance(w, float) else g == w, (k, name, g, w)
        assert got.wind_speed_estimated_m_s == pytest.approx(8.0, abs=0.1)
        assert got.estimator_faults == 0


def test_the_wind_ekf_step_stays_in_its_range_on_a_wild_speed() -> None:
    """WindSpeedEKF.step (the advanced controllers' EKF): a rotor speed with noise 0.3 rad/s
    (40 % of rated) and a model assuming 1 mrad/s leaves the estimate inside its range."""
    ekf = BaselineController(load_baseline("iea15mw_baseline")).ekf
    assert ekf is not None
    c = ekf.config
    rng = np.random.default_rng(5)
    st = ekf.initial_state(0.75, 0.05, 1.5e7, 10.0)
    for _ in range(4000):
        z = 0.75 + 0.3 * float(rng.normal())
        st, est = ekf.step(st, WindEKFMeasurement(z, 0.05, 1.5e7, True), 0.025)
        assert c.wind_min_m_s - 1e-9 <= est.wind_m_s <= c.wind_max_m_s + 1e-9
        assert math.isfinite(est.rotor_speed_rad_s)


def _run(tmp_path: Path, text: str, mode: str) -> tuple[int, dict]:
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    out = tmp_path / f"run-{mode}"
    proc = fowt("run", str(path), "--mode", mode, "--out", str(out), "--no-plots", timeout=900)
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    return proc.returncode, summary


def test_the_users_iea15mw_scenario_runs_with_a_bounded_estimate(tmp_path: Path) -> None:
    code, summary = _run(tmp_path, USER.format(duration=60.0), "inprocess")
    assert summary["controller"]["estimator_faults"] == 0
    assert summary["controller"]["estimator_faults_first_s"] is None
    est = summary["estimator"]
    assert abs(est["wind_speed_error_mean_pct"]) < 5.0  # (it ran away to -3404 %)
    assert est["wind_speed_error_rms_m_s"] < 2.0
    assert code == 0, summary["run"].get("outcome_reasons")


@pytest.mark.parametrize("mode", ["inprocess", "lockstep"])
def test_a_biased_speed_sensor_is_an_estimator_fault_in_every_mode(
    tmp_path: Path, mode: str
) -> None:
    code, summary = _run(tmp_path, USER.format(duration=60.0) + BIAS, mode)
    assert summary["controller"]["estimator_faults"] >= 1
    # the bias from 20 s, gated until the fault 5 s later
    assert 24.9 <= summary["controller"]["estimator_faults_first_s"] <= 30.0
    assert code != ExitCode.OK
    assert summary["run"]["outcome"] != "ok"
    assert any("estimator" in r for r in summary["run"]["outcome_reasons"])


# ------------------------------------------------------------- the advanced controllers
#: The user's scenario with the advanced controller (LQRI with the wave feedforward).
ADVANCED = USER.replace(
    'kind = "baseline"\npreset = "iea15mw_baseline"',
    'kind = "lqri_ff"\npreset = "iea15mw_advanced"',
)


#: The valid bits of the unit tests' frames: speed, pitch and torque (no platform channels).
_TURBINE = VALID_GENERATOR_SPEED | VALID_PITCH | VALID_TORQUE


def _advanced() -> AdvancedController:
    return AdvancedController(
        load_advanced_settings("iea15mw_advanced"), control_period_s=0.025, feedforward="off"
    )


def test_the_advanced_observers_fault_on_a_jump_and_fall_back_to_the_baseline_law() -> None:
    """lqri: a generator-speed reading that jumps by 0.5 rad/s (60 % of rated) at 10 s is
    gated from then on; 5 s later the guard counts one fault, flags the step degraded and
    commands the below-rated baseline's law; the estimate stays in its physical range."""
    ctrl = _advanced()
    p = load_baseline("iea15mw_baseline")
    state = ctrl.initial_state()
    rated = p.region25_end_generator_speed_rad_s
    dt = 0.025
    faults, degraded, winds, fallback = [], [], [], []
    for k in range(int(40.0 / dt)):
        t = k * dt
        speed = 0.95 * rated + (0.5 if t >= 10.0 else 0.0)
        frame = msgspec.structs.replace(
            sensor_frame(speed, 0.02, 0.9 * p.rated_torque_nm, valid_mask=_TURBINE),
            wind_speed_measured_m_s=10.0,
        )
        state, out = ctrl.step(state, frame, dt)
        faults.append(out.estimator_faults)
        degraded.append(out.estimator_degraded)
        winds.append(out.wind_speed_estimated_m_s)
        parts = ctrl.state_parts(state)
        fallback.append(bool(parts["fallback"]))
        assert math.isfinite(out.blade_pitch_commanded_rad)
        assert math.isfinite(out.generator_torque_commanded_nm)
    assert faults[int(9.9 / dt)] == 0  # healthy before the jump
    first = faults.index(1) * dt
    assert 14.9 <= first <= 15.1  # gated from the jump, the fault 5 s later
    assert faults[-1] == 1  # counted once per fallback
    k1 = faults.index(1)
    assert degraded[k1] == 1 and fallback[k1]
    assert all(1.0 - 1e-9 <= v <= 37.5 + 1e-9 for v in winds)


def test_the_advanced_fallback_commands_the_baseline_law() -> None:
    """In the fallback the command is the below-rated baseline's law (the kernel's own
    baseline state, which tracks the applied commands): pitch and torque equal the
    ``bl_pitch``/``bl_torque`` state parts the cycle stored."""
    ctrl = _advanced()
    state = ctrl.initial_state()
    p = load_baseline("iea15mw_baseline")
    rated = p.region25_end_generator_speed_rad_s
    dt = 0.025
    seen = 0
    for k in range(int(25.0 / dt)):
        speed = 0.95 * rated + (0.5 if k * dt >= 5.0 else 0.0)
        frame = msgspec.structs.replace(
            sensor_frame(speed, 0.02, 0.9 * p.rated_torque_nm, valid_mask=_TURBINE),
            wind_speed_measured_m_s=10.0,
        )
        state, out = ctrl.step(state, frame, dt)
        parts = ctrl.state_parts(state)
        if parts["fallback"]:
            seen += 1
            assert out.blade_pitch_commanded_rad == parts["bl_pitch"]
            assert out.generator_torque_commanded_nm == parts["bl_torque"]
            assert out.estimator_degraded == 1
    assert seen > 0


def test_lqr_wave_observers_fault_on_a_jump_and_hold_the_last_good_wind() -> None:
    """lqr_wave (OC3 Hywind): the same jump; one fault 5 s after it, the scheduling wind
    (reported as ``gain_schedule_factor``) held at the last good estimate until the
    restarted observers have been healthy for 10 s."""
    from controller.lqr_wave import LqrWaveController, load_lqr_wave_preset

    ctrl = LqrWaveController(load_lqr_wave_preset("nrel5mw_oc3_hywind_lqr2"), 0.025)
    state = ctrl.initial_state()
    rated = ctrl.omega_rated * ctrl.preset.gearbox_ratio
    dt = 0.025
    faults, sched = [], []
    for k in range(int(30.0 / dt)):
        t = k * dt
        speed = rated + (0.6 * rated if t >= 10.0 else 0.0)
        frame = msgspec.structs.replace(
            sensor_frame(speed, 0.1, ctrl.torque_nm, valid_mask=_TURBINE),
            wind_speed_measured_m_s=15.0,
        )
        state, out = ctrl.step(state, frame, dt)
        faults.append(out.estimator_faults)
        sched.append(out.gain_schedule_factor)
        assert math.isfinite(out.blade_pitch_commanded_rad)
        assert 1.0 - 1e-9 <= out.wind_speed_estimated_m_s <= 37.5 + 1e-9
    assert faults[int(9.9 / dt)] == 0
    k1 = faults.index(1)
    assert 14.9 <= k1 * dt <= 15.1
    assert faults[-1] == 1
    # held for the recovery time (10 s without a bad step after the restart), then released
    held = sched[k1]
    assert all(v == held for v in sched[k1 : k1 + int(9.9 / dt)])
    assert not state.guard.fallback


@pytest.mark.parametrize("mode", ["inprocess", "lockstep"])
def test_a_biased_speed_sensor_is_an_advanced_estimator_fault_in_every_mode(
    tmp_path: Path, mode: str
) -> None:
    """lqri_ff on the IEA 15 MW with the +0.5 rad/s speed bias from 20 s: the advanced
    controller's observers diverge, the run counts the fault and ends as the controller's
    fault (exit 7), in process and in lock-step."""
    code, summary = _run(tmp_path, ADVANCED.format(duration=40.0) + BIAS, mode)
    assert summary["controller"]["estimator_faults"] >= 1
    assert 24.9 <= summary["controller"]["estimator_faults_first_s"] <= 30.0
    assert code == ExitCode.CONTROLLER_FAULT
    assert summary["run"]["outcome"] == "controller_fault"
    assert any("estimator" in r for r in summary["run"]["outcome_reasons"])


def test_casanovas_observer_faults_on_a_jump_and_falls_back_to_the_region_2_law() -> None:
    """lqr_steady (casanovas-2014, NREL 5 MW TLP): a surge reading that jumps by 30 m at
    10 s is beyond the observer's innovation gate from then on; 5 s later one fault, the
    observer restarted and the command the region-2 law K ω_g² at the design's pitch."""
    from controller.casanovas import CasanovasController, load_casanovas_design

    ctrl = CasanovasController(
        "lqr_steady", load_casanovas_design("nrel5mw_tlp_casanovas_u8_hs6"), 0.1
    )
    state = ctrl.initial_state()
    dt = 0.1
    omega = ctrl.omega0
    gear = 97.0
    faults = []
    for k in range(int(25.0 / dt)):
        t = k * dt
        frame = msgspec.structs.replace(
            sensor_frame(omega * gear, 0.0, ctrl.t_bar, seq=k, valid_mask=_TURBINE),
            rotor_speed_measured_rad_s=omega,
            platform_surge_measured_m=ctrl.surge_bar + (30.0 if t >= 10.0 else 0.0),
        )
        state, out = ctrl.step(state, frame, dt)
        faults.append(out.estimator_faults)
        if out.estimator_faults:
            assert out.estimator_degraded == 1
            assert out.generator_torque_commanded_nm == pytest.approx(
                min(ctrl.k_gen * (omega * gear) ** 2, 47402.91)
            )
    assert faults[int(9.9 / dt)] == 0
    assert 14.9 <= faults.index(1) * dt <= 15.1
    assert faults[-1] == 1
