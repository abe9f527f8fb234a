"""Scenario-driven fault injection: sensor faults, bus faults, watchdog, observers.

Sensor faults are checked open loop: the controller never answers (``watchdog_misses`` = 0,
so the plant holds its initial actuators), which makes the plant's truth the same with and
without the fault; the sensor frames must then be identical except the named channel in
exactly its window, where each kind does what :mod:`sensors.faults` says. Bus faults and
observers run closed loop, in process (the same simulated-time cycle as lock-step), except
one test that checks lock-step over real Zenoh gives the in-process figures.
"""

from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys
import zlib
from pathlib import Path
from typing import Any

import msgspec
import pytest

from bus_schemas import ActuatorCommand, ControllerStatus, CycleTiming, PlantState, SensorFrame
from bus_schemas.messages import VALID_BITS
from bus_schemas.registry import CYCLE_TIMING, SENSORS, TRUTH, MessageType
from hil.inprocess.run import run_inprocess
from hil.nodes.controller_node import ControllerRuntime
from hil.nodes.plant_node import PlantRunResult
from hil.review.outcome import ExitCode
from hil.scenario.schema import Scenario, ScenarioError, parse_scenario, scenario_text
from sensors import ChannelSpec, default_floating_suite
from sensors.faults import BusFaultPlan, FaultSchedule, FaultSpec, counter_uniform

IMU = (
    "platform_pitch_measured_rad",
    "platform_pitch_rate_measured_rad_s",
    "nacelle_acc_fore_aft_measured_m_s2",
)


def _toml_value(v: object) -> str:
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, tuple | list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(v)


def _faults_toml(*faults: dict[str, object]) -> str:
    out = ""
    for f in faults:
        out += "\n[[faults]]\n" + "".join(f"{k} = {_toml_value(v)}\n" for k, v in f.items())
    return out


def _scenario(base: str, duration_s: float, *faults: dict[str, object], **timing: int) -> Scenario:
    sc = parse_scenario(scenario_text(base)[0] + _faults_toml(*faults), f"{base}+faults")
    sc = sc.with_duration(duration_s)
    if timing:
        sc = msgspec.structs.replace(sc, timing=msgspec.structs.replace(sc.timing, **timing))
    return sc


def _plain(msg: msgspec.Struct) -> dict[str, Any]:
    """A message's fields without its wall-clock ``publish_time_ns``."""
    out = msgspec.structs.asdict(msg)
    out.pop("publish_time_ns", None)
    return out


def _same(a: list[PlantState] | list[SensorFrame], b: list[PlantState] | list[SensorFrame]) -> bool:
    return [_plain(m) for m in a] == [_plain(m) for m in b]


class Run:
    """What one in-process run published, and its result."""

    def __init__(self, scenario: Scenario, open_loop: bool = False) -> None:
        self.frames: list[SensorFrame] = []
        self.truth: list[PlantState] = []
        self.cycles: list[CycleTiming] = []
        self.status: dict[int, ControllerStatus] = {}
        self.answered: list[int] = []
        runtime = None if open_loop else ControllerRuntime(scenario)

        def publish(mt: MessageType, msg: msgspec.Struct) -> None:
            if mt is SENSORS:
                assert isinstance(msg, SensorFrame)
                self.frames.append(msg)
            elif mt is TRUTH:
                assert isinstance(msg, PlantState)
                self.truth.append(msg)
            elif mt is CYCLE_TIMING:
                assert isinstance(msg, CycleTiming)
                self.cycles.append(msg)

        def step(frame: SensorFrame) -> ActuatorCommand | None:
            if runtime is None:
                return None  # open loop: the plant holds its initial actuators
            result = runtime.handle_frame(frame)
            if result is None:
                return None
            self.status[frame.seq] = result[1]
            self.answered.append(frame.seq)
            return result[0]

        self.log: list[str] = []
        self.result: PlantRunResult = run_inprocess(scenario, publish, step, log=self.log.append)


# --------------------------------------------------------------------------- pure model


def test_schedule_models_on_synthetic_readings() -> None:
    """Half-open windows, stuck latching the last valid value, dropout, bias on invalid."""
    ch = "platform_pitch_measured_rad"
    faults = [
        FaultSpec(kind="stuck", channels=(ch,), start_s=1.0, end_s=2.0),
        FaultSpec(kind="dropout", channels=("wind_speed_measured_m_s",), start_s=0.5, end_s=1.0),
        FaultSpec(kind="bias_step", channels=("blade_pitch_measured_rad",), bias=0.1, start_s=0),
    ]
    sched = FaultSchedule(faults, seed=3)
    out = []
    for i in range(30):
        t_ns = i * 100_000_000
        valid = i != 10  # the reading at the stuck fault's start (1.0 s) is missing
        readings = {
            ch: (0.01 * i if valid else math.nan, valid),
            "wind_speed_measured_m_s": (8.0, True),
            "blade_pitch_measured_rad": (math.nan, False) if i == 3 else (0.2, True),
        }
        out.append(sched.apply(t_ns, readings))
    # stuck from frame 10 (1.0 s) to frame 19: the last valid reading before it (frame 9)
    assert [o[ch] for o in out[10:20]] == [(0.09, True)] * 10
    assert out[9][ch] == (0.09, True) and out[20][ch] == (0.2, True)
    # dropout from 0.5 s (frame 5) to 1.0 s (frame 10 excluded)
    assert all(not o["wind_speed_measured_m_s"][1] for o in out[5:10])
    assert out[4]["wind_speed_measured_m_s"] == (8.0, True) == out[10]["wind_speed_measured_m_s"]
    # bias to the end; a missing sample stays missing
    assert out[3]["blade_pitch_measured_rad"][1] is False
    assert out[29]["blade_pitch_measured_rad"] == pytest.approx((0.3, True))
    assert sched.injected == {"stuck": 10, "dropout": 5, "bias_step": 30}


def test_stuck_with_no_valid_reading_stays_invalid_and_bus_plan_is_a_pure_function() -> None:
    sched = FaultSchedule([FaultSpec(kind="stuck", channels=("platform_surge_measured_m",))], 1)
    assert sched.apply(0, {})["platform_surge_measured_m"][1] is False
    spec = FaultSpec(kind="bus_loss", channels=("command",), probability=0.5, seed=9)
    plan = BusFaultPlan([spec], "command", seed=1)
    fates = [plan.effect(k, k).lost for k in range(2000)]
    assert fates == [plan.effect(k, k).lost for k in reversed(range(2000))][::-1]
    assert 0.45 < sum(fates) / 2000 < 0.55  # 2000 draws: 4.5 sigma
    crc = zlib.crc32(b"command")
    assert fates[:50] == [counter_uniform(9, crc, 0, k) < 0.5 for k in range(50)]


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"kind": "stuk", "channel": IMU[0]}, "did you mean 'stuck'"),
        ({"kind": "stuck", "channel": "platform_pitch_rad"}, "'platform_pitch_measured_rad'"),
        ({"kind": "stuck", "channel": "command"}, "not a measured SensorFrame field"),
        ({"kind": "bus_loss", "channel": IMU[0], "probability": 0.1}, "not a bus channel"),
        ({"kind": "bias_step", "channel": IMU[0]}, r"bias is required.*\(rad\)"),
        ({"kind": "noise_burst", "channel": "wind_speed_measured_m_s", "std": -1.0}, r"m/s"),
        ({"kind": "stuck", "channel": IMU[0], "bias": 1.0}, "'bias' is not used by kind"),
        ({"kind": "bus_loss", "channel": "command", "probability": 1.5}, r"probability.*\[0, 1\]"),
        ({"kind": "bus_delay", "channel": "sensors", "delay_ms": 5}, r"delay_ms.*delay_s"),
        ({"kind": "bus_jitter", "channel": "command", "std_s": 0.01}, "distribution = 'normal'"),
        ({"kind": "dropout", "channel": IMU[0], "start_s": 5.0, "end_s": 4.0}, "end_s"),
    ],
)  # fmt: skip
def test_bad_fault_tables_name_the_key(table: dict[str, object], message: str) -> None:
    text = scenario_text("default")[0] + _faults_toml(table)
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(text, "bad.toml")


def test_sensor_fault_on_a_channel_a_fixed_plant_lacks_is_an_error() -> None:
    text = scenario_text("nrel5mw-steady-18")[0] + _faults_toml(
        {"kind": "dropout", "channel": IMU[0]}
    )
    with pytest.raises(ScenarioError, match="bottom-fixed"):
        parse_scenario(text, "bad.toml")


def test_shipped_fault_scenarios_load() -> None:
    for name in ("faults-sensors", "faults-bus"):
        sc = parse_scenario(*scenario_text(name))
        kinds = {f.kind for f in sc.fault_specs()}
        assert kinds == (
            {"stuck", "dropout", "bias_step", "noise_burst"}
            if name == "faults-sensors"
            else {"bus_delay", "bus_jitter", "bus_loss"}
        )


# --------------------------------------------------------------------------- sensor faults

START_S, END_S = 2.0, 10.0
OPEN_LOOP_S = 12.0


@pytest.fixture(scope="module")
def fault_free() -> Run:
    return Run(_scenario("default", OPEN_LOOP_S, watchdog_misses=0), open_loop=True)


def _faulted(kind: str, channel: str, **params: object) -> Run:
    fault = {"kind": kind, "channel": channel, "start_s": START_S, "end_s": END_S, **params}
    return Run(_scenario("default", OPEN_LOOP_S, fault, watchdog_misses=0), open_loop=True)


def _split(run: Run, free: Run, channel: str) -> tuple[list[int], list[int]]:
    """Frame indices in and out of the window; asserts every other field is identical."""
    assert [t.blade_pitch_rad for t in run.truth] == [t.blade_pitch_rad for t in free.truth]
    assert len(run.frames) == len(free.frames) == round(OPEN_LOOP_S / 0.025)
    bit = VALID_BITS[channel]
    inside, outside = [], []
    for i, (a, b) in enumerate(zip(run.frames, free.frames, strict=True)):
        t = a.sample_time_ns * 1e-9
        if START_S <= t < END_S:
            inside.append(i)
            others = {k: v for k, v in _plain(a).items() if k != channel}
            expected = {k: v for k, v in _plain(b).items() if k != channel}
            others["valid_mask"] &= ~bit
            expected["valid_mask"] &= ~bit
            assert others == expected, f"frame {i}: a field other than {channel} changed"
        else:
            outside.append(i)
            assert _plain(a) == _plain(b), f"frame {i} at {t:.3f} s differs outside the window"
    return inside, outside


def test_stuck_holds_the_value_at_the_start_with_valid_bit_set(fault_free: Run) -> None:
    ch = "platform_pitch_rate_measured_rad_s"
    run = _faulted("stuck", ch)
    inside, _ = _split(run, fault_free, ch)
    values = {getattr(run.frames[i], ch) for i in inside}
    first = fault_free.frames[inside[0]]
    assert first.valid_mask & VALID_BITS[ch]
    assert values == {getattr(first, ch)}  # constant: the reading at the start
    assert all(run.frames[i].valid_mask & VALID_BITS[ch] for i in inside)
    # ... while the healthy sensor kept moving (the platform pitches in the waves)
    assert len({getattr(fault_free.frames[i], ch) for i in inside}) > 10
    assert run.result.faults_injected == {"stuck": len(inside)}
    assert any("fault ON  stuck" in line for line in run.log)


def test_dropout_clears_the_valid_bit_and_sends_zero(fault_free: Run) -> None:
    ch = "platform_pitch_measured_rad"
    run = _faulted("dropout", ch)
    inside, _ = _split(run, fault_free, ch)
    for i in inside:
        assert not run.frames[i].valid_mask & VALID_BITS[ch]
        assert getattr(run.frames[i], ch) == 0.0


def test_bias_step_adds_the_bias_within_the_quantisation_step(fault_free: Run) -> None:
    ch, bias = "blade_pitch_measured_rad", 0.008727  # 0.5 deg
    r = default_floating_suite(0.025)[ch].resolution  # 14-bit encoder step, rad
    run = _faulted("bias_step", ch, bias=bias)
    inside, _ = _split(run, fault_free, ch)
    for i in inside:
        a, b = run.frames[i], fault_free.frames[i]
        assert a.valid_mask == b.valid_mask
        assert abs(getattr(a, ch) - getattr(b, ch) - bias) <= r / 2 + 1e-12


def test_noise_burst_has_the_given_std(fault_free: Run) -> None:
    ch, std = "generator_torque_measured_nm", 5.0e4  # sampled every frame, r = 1 N m
    run = _faulted("noise_burst", ch, std=std, seed=4)
    inside, _ = _split(run, fault_free, ch)
    diff = [getattr(run.frames[i], ch) - getattr(fault_free.frames[i], ch) for i in inside]
    n = len(diff)  # 320 samples: std error of the std ~ 1/sqrt(2n) = 4 %; test at 4 sigma
    assert statistics.pstdev(diff) == pytest.approx(std, rel=4 / math.sqrt(2 * n))
    assert abs(statistics.fmean(diff)) < 4 * std / math.sqrt(n)
    # seeded: a second run gives the same frames
    assert _same(_faulted("noise_burst", ch, std=std, seed=4).frames, run.frames)


def test_noise_burst_on_a_sample_and_hold_channel_keeps_holding(fault_free: Run) -> None:
    ch = "wind_speed_measured_m_s"  # sampled at 4 Hz, held in between
    run = _faulted("noise_burst", ch, std=1.5)
    inside, _ = _split(run, fault_free, ch)
    changes = [
        run.frames[i].sample_time_ns
        for i in inside[1:]
        if getattr(run.frames[i], ch) != getattr(run.frames[i - 1], ch)
    ]
    assert changes and all(t % 250_000_000 == 0 for t in changes)
    assert len(changes) >= 0.9 * (END_S - START_S) * 4


# --------------------------------------------------------------------------- bus faults

BUS_BASE = "nrel5mw-steady-18"  # bottom-fixed, 100 Hz: the cheapest closed loop


def test_command_loss_holds_exactly_the_lost_commands() -> None:
    p, seed = 0.2, 11
    loss = {"kind": "bus_loss", "channel": "command", "start_s": 2.0, "end_s": 6.0}
    sc = _scenario(BUS_BASE, 8.0, {**loss, "probability": p, "seed": seed}, watchdog_misses=0)
    run = Run(sc)
    r = run.result
    lost = r.faults_injected["bus_loss"]
    n = 400  # commands in the window
    assert abs(lost - p * n) < 4 * math.sqrt(n * p * (1 - p))
    assert r.commands_held == r.deadline_misses == lost
    crc = zlib.crc32(b"command")
    expected = [200 <= k < 600 and counter_uniform(seed, crc, 0, k) < p for k in range(800)]
    assert [bool(c.command_held) for c in run.cycles] == expected
    assert not any(c.safe_state for c in run.cycles)


@pytest.mark.parametrize("lost_cycles", [2, 3, 5])
def test_three_consecutive_command_losses_trip_the_watchdog(lost_cycles: int) -> None:
    t0 = 3.0
    window = {"start_s": t0, "end_s": t0 + (lost_cycles - 0.5) * 0.01}
    fault = {"kind": "bus_loss", "channel": "command", "probability": 1.0, **window}
    run = Run(_scenario(BUS_BASE, 4.0, fault))  # watchdog_misses = 3 (default), latched
    flags = [c.safe_state for c in run.cycles]
    assert run.result.faults_injected == {"bus_loss": lost_cycles}
    assert run.result.commands_held >= lost_cycles
    if lost_cycles < 3:
        assert not any(flags)
    else:
        k = round(t0 / 0.01)
        assert not any(flags[: k + 2]) and all(flags[k + 2 :])  # the third loss trips it
        assert run.result.safe_state_entries == 1


def test_command_delay_shifts_the_command_in_the_period_and_late_ones_miss() -> None:
    """Floating default: T = 25 ms, plant step 12.5 ms; a 10 ms delay switches after 1 step."""
    delay = {"kind": "bus_delay", "channel": "command", "start_s": 1.0, "end_s": 2.0}
    short = Run(_scenario("default", 3.0, {**delay, "delay_s": 0.010}))
    free = Run(_scenario("default", 3.0))
    assert short.result.deadline_misses == 0
    assert short.result.faults_injected == {"bus_delay": 40}
    k1 = 40  # first cycle of the window
    assert _same(short.truth[: k1 + 1], free.truth[: k1 + 1])
    assert _plain(short.truth[k1 + 1]) != _plain(free.truth[k1 + 1])
    late = Run(_scenario("default", 3.0, {**delay, "delay_s": 0.025}, watchdog_misses=0))
    assert late.result.deadline_misses == late.result.commands_late == 40
    assert [c.deadline_missed for c in late.cycles] == [int(40 <= k < 80) for k in range(120)]


def test_sensor_bus_delay_in_simulated_time_is_deterministic() -> None:
    """Delayed and jittered frames: the controller answers older frames, the plant holds."""
    faults = (
        {"kind": "bus_delay", "channel": "sensors", "start_s": 1.0, "end_s": 1.5, "delay_s": 0.015},
        {"kind": "bus_jitter", "channel": "sensors", "start_s": 2.0, "end_s": 3.0,
         "max_s": 0.012, "seed": 5},
    )  # fmt: skip
    sc = _scenario(BUS_BASE, 4.0, *faults, watchdog_misses=0)
    a, b = Run(sc), Run(sc)
    assert _same(a.truth, b.truth) and a.answered == b.answered
    assert a.result.deadline_misses == b.result.deadline_misses > 0
    assert a.result.commands_late > 0
    assert a.answered == sorted(a.answered)  # FIFO: frames never overtake one another
    # 15 ms > T = 10 ms: every frame of the delay window misses its own cycle
    assert all(c.deadline_missed for c in a.cycles[100:150])
    free = Run(_scenario(BUS_BASE, 4.0))
    assert _same(a.truth[:101], free.truth[:101])


@pytest.mark.e2e
def test_lockstep_over_zenoh_with_sensor_delay_equals_inprocess(tmp_path: Path) -> None:
    """Lock-step with a delayed/jittered sensor frame is deterministic: it equals in-process."""
    faults = (
        {"kind": "bus_jitter", "channel": "sensors", "start_s": 1.0, "end_s": 2.0,
         "max_s": 0.015, "seed": 5},
        {"kind": "bus_loss", "channel": "command", "start_s": 2.5, "end_s": 3.0,
         "probability": 0.3},
    )  # fmt: skip
    path = tmp_path / "faulted.toml"
    path.write_text(
        scenario_text(BUS_BASE)[0] + "\n[timing]\nwatchdog_misses = 0\n" + _faults_toml(*faults)
    )
    summaries = []
    for mode in ("lockstep", "inprocess"):
        out = tmp_path / mode
        proc = subprocess.run(
            [sys.executable, "-m", "hil", "run", str(path), "--mode", mode,
             "--duration", "4", "--out", str(out), "--no-plots"],
            capture_output=True, text=True, timeout=180, check=False,
        )  # fmt: skip
        # Commands lost with the watchdog off: missed deadlines, none tolerated in these
        # modes, so both runs exit with the deadline-misses code (hil.review.outcome).
        assert proc.returncode == ExitCode.DEADLINE_MISSES, proc.stdout + proc.stderr
        summaries.append(json.loads((out / "summary.json").read_text()))
    assert summaries[0]["run"]["outcome"] == summaries[1]["run"]["outcome"] == "deadline_misses"
    assert summaries[0]["kpi"] == summaries[1]["kpi"]
    assert summaries[0]["timing"]["deadline_misses"] == summaries[1]["timing"]["deadline_misses"]
    assert summaries[0]["timing"]["deadline_misses"] > 0
    plant_log = (tmp_path / "lockstep" / "logs" / "plant.log").read_text()
    assert "plant faults injected: bus_jitter 100" in plant_log


# --------------------------------------------------------------------------- observers


def test_observers_ride_through_a_5_s_imu_dropout_and_report_degraded() -> None:
    fault = {"kind": "dropout", "channel": list(IMU), "start_s": 15.0, "end_s": 20.0}
    run = Run(_scenario("iea15mw-lqri-15", 40.0, fault))
    free = Run(_scenario("iea15mw-lqri-15", 40.0))
    assert run.result.deadline_misses == 0 and run.result.safe_state_cycles == 0
    f = 40  # frames per second
    degraded = [k for k, s in run.status.items() if s.estimator_degraded]
    assert not any(s.estimator_degraded for s in free.status.values())
    # degraded within 1 s of the dropout's start, and only until its end (+ 1 s)
    assert degraded and 15 * f <= degraded[0] < 16 * f and degraded[-1] < 21 * f
    assert all(run.status[k].estimator_degraded for k in range(16 * f, 20 * f))
    # the platform-pitch estimate never diverges: within 1.5 deg of the truth during the
    # dropout (dead reckoning on the model), back within 0.5 deg after 21 s
    err = {
        k: abs(s.platform_pitch_estimated_rad - run.truth[k].platform_pitch_rad)
        for k, s in run.status.items()
    }
    assert max(err.values()) < math.radians(1.5)
    assert max(e for k, e in err.items() if k >= 21 * f) < math.radians(0.5)
    # and the turbine keeps running as well as without the fault (rotor speed within 5 %)
    speed = max(t.rotor_speed_rad_s for t in run.truth)
    assert speed == pytest.approx(max(t.rotor_speed_rad_s for t in free.truth), rel=0.05)
    assert all(s.estimates_valid_mask == free.status[k].estimates_valid_mask
               for k, s in run.status.items())  # fmt: skip


def test_channel_spec_import_stays_available() -> None:
    """The fault schedule re-quantises with the channel's own spec."""
    spec = ChannelSpec(name="x", resolution=0.5, range_min=-1.0, range_max=1.0)
    sched = FaultSchedule(
        [FaultSpec(kind="bias_step", channels=("platform_surge_measured_m",), bias=0.7)],
        seed=1,
        channels={"platform_surge_measured_m": spec},
    )
    assert sched.apply(0, {"platform_surge_measured_m": (0.5, True)}) == {
        "platform_surge_measured_m": (1.0, True)  # 1.2 saturates at 1.0 (range_max)
    }
