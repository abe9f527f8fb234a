"""The controller's sensor-frame watchdog (hil.nodes.controller_node): missing, stale, silent.

Frames come from a seeded in-process closed-loop run of ``nrel5mw-steady-18`` (region 3,
T = 10 ms); a fresh :class:`ControllerRuntime` is then fed chosen subsets of them, with
chosen publish times and an injected clock. After ``watchdog_misses`` consecutive missing
or stale frames the runtime must answer with the safe command (``mode`` = 2, status
``regime`` = 5): pitch towards the core's feathered pitch at its pitch rate limit, torque
to 0 at its torque rate limit, from the last published command. Recovery follows the
plant's rule (latched by default, K healthy frames otherwise, then a rate-limited
transfer). One two-process lock-step run over Zenoh checks the status in the MCAP file
while the plant's link drops every sensor frame for half a second.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import msgspec
import pytest

from bus_schemas import ActuatorCommand, ControllerStatus, SensorFrame
from bus_schemas.registry import SENSORS, MessageType
from controller.interface import REGIME_SAFE
from hil.inprocess.run import run_inprocess
from hil.nodes.controller_node import MODE_NORMAL, MODE_RESUMING, MODE_SAFE, ControllerRuntime
from hil.review.outcome import ExitCode
from hil.runlog.mcap_io import read_run
from hil.scenario.schema import Scenario, load_scenario, scenario_text

BASE = "nrel5mw-steady-18"
PERIOD_NS = 10_000_000  # the base scenario's control period
LATENCY_NS = 200_000  # a healthy frame's age when it reaches the controller


def _scenario(misses: int = 3, recover: int = 0) -> Scenario:
    base = load_scenario(BASE).with_duration(3.0)
    timing = msgspec.structs.replace(
        base.timing, watchdog_misses=misses, watchdog_recover_cycles=recover
    )
    return msgspec.structs.replace(base, timing=timing)


class Clock:
    """Injected monotonic clock [ns]: returns ``now``, set by the test before each frame."""

    def __init__(self) -> None:
        self.now = 0

    def __call__(self) -> int:
        return self.now


@pytest.fixture(scope="module")
def frames() -> list[SensorFrame]:
    """The 300 frames of a 3 s closed-loop run (publish time = sample time, 1 s offset)."""
    scenario = _scenario()
    out: list[SensorFrame] = []
    runtime = ControllerRuntime(scenario)
    modes: list[int] = []

    def publish(mt: MessageType, msg: msgspec.Struct) -> None:
        if mt is SENSORS:
            assert isinstance(msg, SensorFrame)
            out.append(msgspec.structs.replace(msg, publish_time_ns=msg.sample_time_ns + 10**9))

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        result = runtime.handle_frame(frame)
        if result is None:
            return None
        modes.append(result[0].mode)
        return result[0]

    run_inprocess(scenario, publish, step)
    # A healthy in-process stream never trips the watchdog.
    assert len(out) == 300
    assert set(modes) == {MODE_NORMAL}
    assert runtime.safe_entries == runtime.frames_missing == runtime.frames_stale == 0
    return out


Answer = tuple[ActuatorCommand, ControllerStatus]


def _feed(
    rt: ControllerRuntime, clock: Clock, frames: list[SensorFrame], age_ns: int = LATENCY_NS
) -> list[Answer]:
    """Hand ``frames`` to ``rt``, each received ``age_ns`` after its publish time."""
    answers = []
    for f in frames:
        clock.now = f.publish_time_ns + age_ns
        result = rt.handle_frame(f)
        assert result is not None
        answers.append(result)
    return answers


def _runtime(
    misses: int = 3, recover: int = 0, paced: bool | None = None
) -> tuple[ControllerRuntime, Clock, list[str]]:
    clock = Clock()
    log: list[str] = []
    return (
        ControllerRuntime(_scenario(misses, recover), clock, paced=paced, log=log.append),
        clock,
        log,
    )


def _assert_feathering(rt: ControllerRuntime, before: ActuatorCommand, safe: list[Answer]) -> None:
    """Every safe answer moves pitch up and torque down at the core's rate limits."""
    lim = rt.limits
    prev_p, prev_q, prev_t = (
        before.blade_pitch_commanded_rad,
        before.generator_torque_commanded_nm,
        before.sample_time_ns,
    )
    for cmd, status in safe:
        assert cmd.mode == MODE_SAFE
        assert status.regime == REGIME_SAFE
        dt = (cmd.sample_time_ns - prev_t) * 1e-9
        assert cmd.blade_pitch_commanded_rad == pytest.approx(
            min(prev_p + lim.pitch_rate_max_rad_s * dt, lim.pitch_max_rad)
        )
        assert cmd.generator_torque_commanded_nm == pytest.approx(
            max(prev_q - lim.torque_rate_max_nm_s * dt, 0.0)
        )
        prev_p, prev_q, prev_t = (
            cmd.blade_pitch_commanded_rad,
            cmd.generator_torque_commanded_nm,
            cmd.sample_time_ns,
        )


def test_gap_of_three_missing_frames_trips_the_safe_mode(frames: list[SensorFrame]) -> None:
    rt, clock, log = _runtime()
    head = _feed(rt, clock, frames[:100])
    # A gap of 2 is not enough: the next frame is healthy and resets the count.
    mid = _feed(rt, clock, frames[102:120])
    assert {a[0].mode for a in head + mid} == {MODE_NORMAL}
    assert rt.frames_missing == 2 and not rt.safe_mode
    # A gap of 3 (seqs 120, 121, 122): the next frame that arrives is answered safely.
    safe = _feed(rt, clock, frames[123:300])
    assert rt.safe_mode and rt.safe_entries == 1 and rt.frames_missing == 5
    _assert_feathering(rt, mid[-1][0], safe)
    lim = rt.limits
    # First safe command: four periods of feathering since the last command (frame 119).
    assert safe[0][0].blade_pitch_commanded_rad == pytest.approx(
        mid[-1][0].blade_pitch_commanded_rad + 4 * 0.01 * lim.pitch_rate_max_rad_s
    )
    # 1.77 s of ramps (the torque ramps at 15 kN m/s from ~43 kN m: not yet at 0).
    first, last = mid[-1][0], safe[-1][0]
    assert last.generator_torque_commanded_nm == pytest.approx(
        first.generator_torque_commanded_nm - 1.8 * lim.torque_rate_max_nm_s
    )
    assert safe[-1][0].blade_pitch_commanded_rad < lim.pitch_max_rad
    assert any("controller SAFE MODE after 3 consecutive" in line for line in log)
    # The core kept stepping: the status still carries its filtered speed.
    assert safe[-1][1].generator_speed_filtered_rad_s > 100.0


def test_stale_frames_trip_the_safe_mode_in_a_paced_stream(frames: list[SensorFrame]) -> None:
    rt, clock, log = _runtime()
    _feed(rt, clock, frames[:50])  # publish times one period apart: paced
    assert rt.wall_checks
    old = 3 * PERIOD_NS  # three periods old when received
    answers = _feed(rt, clock, frames[50:53], age_ns=old)
    assert [a[0].mode for a in answers] == [MODE_NORMAL, MODE_NORMAL, MODE_SAFE]
    assert rt.frames_stale == 3 and rt.safe_entries == 1
    assert any("stale sensor frame (30.0 ms old)" in line for line in log)
    # A healthy stream again does not recover by default (latched).
    later = _feed(rt, clock, frames[53:200])
    assert {a[0].mode for a in later} == {MODE_SAFE}
    # Two stale frames then a fresh one: no trip (a fresh runtime).
    rt2, clock2, _ = _runtime()
    _feed(rt2, clock2, frames[:50])
    _feed(rt2, clock2, frames[50:52], age_ns=old)
    _feed(rt2, clock2, frames[52:100])
    assert not rt2.safe_mode and rt2.frames_stale == 2


def test_lockstep_like_stream_ignores_wall_clock_age(frames: list[SensorFrame]) -> None:
    """Publish times 0.3 ms apart (a lock-step plant): old frames and silence never count."""
    fast = [
        msgspec.structs.replace(f, publish_time_ns=10**9 + 300_000 * i)
        for i, f in enumerate(frames)
    ]
    rt, clock, _ = _runtime()
    answers = _feed(rt, clock, fast[:200], age_ns=5 * PERIOD_NS)
    assert not rt.wall_checks
    assert rt.check_silence(clock.now + 100 * PERIOD_NS) is False
    answers += _feed(rt, clock, fast[200:], age_ns=5 * PERIOD_NS)
    assert {a[0].mode for a in answers} == {MODE_NORMAL}
    assert rt.frames_stale == rt.silent_periods == 0
    # ... but forced on (paced=True) the same stream trips on the third old frame.
    rt2, clock2, _ = _runtime(paced=True)
    forced = _feed(rt2, clock2, fast[:3], age_ns=5 * PERIOD_NS)
    assert [a[0].mode for a in forced] == [MODE_NORMAL, MODE_NORMAL, MODE_SAFE]


def test_silence_timer_trips_and_the_gap_is_not_counted_twice(frames: list[SensorFrame]) -> None:
    rt, clock, log = _runtime()
    _feed(rt, clock, frames[:50])
    last_rx = clock.now
    # Frames 50.. expected every 10 ms; half a period of grace each.
    assert rt.check_silence(last_rx + 14 * PERIOD_NS // 10) is False  # 1.4 T: none missed yet
    assert rt.check_silence(last_rx + 16 * PERIOD_NS // 10) is False  # 1.6 T: one missed
    assert rt.consecutive_misses == 1
    assert rt.check_silence(last_rx + 36 * PERIOD_NS // 10) is True  # 3.6 T: three missed
    assert rt.safe_mode and rt.silent_periods == 3
    assert any("no sensor frame for 3 control period(s)" in line for line in log)
    # The stream comes back after a gap of 3: those three are not counted again.
    back = _feed(rt, clock, frames[53:60])
    assert {a[0].mode for a in back} == {MODE_SAFE}
    assert rt.frames_missing == 3 and rt.safe_entries == 1


def test_rejected_payloads_are_not_misses_until_the_valid_stream_stops(
    frames: list[SensorFrame],
) -> None:
    rt, clock, _ = _runtime()
    _feed(rt, clock, frames[:50])
    for f in frames[50:100]:  # garbage and a replay between the good frames: no misses
        assert rt.handle_payload(b"\x00garbage") is None
        assert rt.handle_frame(frames[10]) is None
        clock.now = f.publish_time_ns + LATENCY_NS
        assert rt.handle_frame(f) is not None
    assert rt.rejected_total == 100 and rt.consecutive_misses == 0 and not rt.safe_mode
    # Frames 100-109 all arrive corrupted (CRC broken): the timer sees the valid stream
    # stop, and the seq gap confirms it when a good frame comes again.
    for f in frames[100:110]:
        payload = bytearray(SENSORS.codec.encode(f))
        payload[-1] ^= 0xFF
        clock.now = f.publish_time_ns + LATENCY_NS
        assert rt.handle_payload(bytes(payload)) is None
        rt.check_silence()
    assert rt.safe_mode and rt.safe_entries == 1
    answer = _feed(rt, clock, frames[110:111])[0]
    assert answer[0].mode == MODE_SAFE and rt.frames_missing == 10


def test_recovery_after_k_healthy_frames_is_bumpless(frames: list[SensorFrame]) -> None:
    rt, clock, log = _runtime(recover=20)
    before = _feed(rt, clock, frames[:100])[-1][0]
    # Frame 104 reveals the gap (answered safely, not counted as healthy); 105-123 are 19
    # healthy frames: still safe.
    safe = _feed(rt, clock, frames[104:124])
    _assert_feathering(rt, before, safe)
    answers = _feed(rt, clock, frames[124:300])
    assert answers[0][0].mode == MODE_RESUMING  # the 20th healthy frame
    assert any("controller leaves its safe mode" in line for line in log)
    lim = rt.limits
    prev = safe[-1][0]
    modes = [a[0].mode for a in answers]
    n_resuming = modes.count(MODE_RESUMING)
    assert modes == [MODE_RESUMING] * n_resuming + [MODE_NORMAL] * (len(modes) - n_resuming)
    assert 1 <= n_resuming < len(modes)
    for cmd, status in answers[:n_resuming]:  # rate limited against the last command
        assert status.regime != REGIME_SAFE
        dp = abs(cmd.blade_pitch_commanded_rad - prev.blade_pitch_commanded_rad)
        dq = abs(cmd.generator_torque_commanded_nm - prev.generator_torque_commanded_nm)
        assert dp <= lim.pitch_rate_max_rad_s * 0.01 + 1e-12
        assert dq <= lim.torque_rate_max_nm_s * 0.01 + 1e-6
        prev = cmd
    assert not rt.safe_mode and not rt.resuming


def test_latched_by_default_and_disabled_with_zero(frames: list[SensorFrame]) -> None:
    rt, clock, _ = _runtime()
    _feed(rt, clock, frames[:100])
    answers = _feed(rt, clock, frames[110:300])
    assert {a[0].mode for a in answers} == {MODE_SAFE}
    assert rt.safe_commands == 190
    off, clock_off, _ = _runtime(misses=0)
    _feed(off, clock_off, frames[:100])
    answers = _feed(off, clock_off, frames[110:300])
    assert {a[0].mode for a in answers} == {MODE_NORMAL} and off.frames_missing == 10


@pytest.mark.e2e
def test_lockstep_sensor_loss_puts_the_controller_in_safe_mode(tmp_path: Path) -> None:
    """Two processes over Zenoh: the plant's link drops every frame from 1.0 s to 1.5 s."""
    path = tmp_path / "sensor-loss.toml"
    path.write_text(
        scenario_text(BASE)[0]
        + '\n[[faults]]\nkind = "bus_loss"\nchannel = "sensors"\n'
        + "start_s = 1.0\nend_s = 1.5\nprobability = 1.0\n"
    )
    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-m", "hil", "run", str(path), "--mode", "lockstep",
         "--duration", "2.5", "--out", str(out), "--no-plots"],
        capture_output=True, text=True, timeout=180, check=False,
    )  # fmt: skip
    # Frames lost for 0.5 s: the plant misses those deadlines and enters its safe state, so
    # the run is judged unhealthy (hil.review.outcome), with the safe-state code.
    assert proc.returncode == ExitCode.SAFE_STATE, proc.stdout + proc.stderr
    assert json.loads((out / "summary.json").read_text())["run"]["outcome"] == "safe_state"
    run = read_run(out / "run.mcap")
    status = run.topic("controller/status")
    commands = run.topic("command")
    assert status and commands
    # Frames 100-149 never reach the controller; frame 150 reveals the gap of 50.
    assert [s["answered_seq"] for s in status] == list(range(100)) + list(range(150, 250))
    assert all(s["regime"] != REGIME_SAFE for s in status[:100])
    assert all(s["regime"] == REGIME_SAFE for s in status[100:])  # latched
    assert all(c["mode"] == MODE_SAFE for c in commands[100:])
    assert all(c["mode"] == MODE_NORMAL for c in commands[:100])
    log = (out / "logs" / "controller.log").read_text()
    assert "controller SAFE MODE after 50 consecutive" in log
    summary = json.loads((out / "summary.json").read_text())
    assert summary["timing"]["deadline_misses"] >= 50
