"""The watchdog's policy (``timing.watchdog_policy``): latch or recover, counted and judged.

* the scenario keys: ``"recover"`` needs ``watchdog_recover_cycles`` >= 1, ``"latch"`` refuses
  one; unset, the policy follows ``watchdog_recover_cycles``;
* the review counts every trip and recovery and the longest safe-state window from
  ``timing/cycle`` (batch by batch), and the verdict lets a recovered safe state pass under
  ``"recover"`` only while the misses are within the tolerance;
* real processes in real time (plant, controller, recorder started by hand): a controller
  stopped by SIGSTOP puts the plant in its safe state within ``watchdog_misses`` = 3
  periods of the last command it sent, under both policies; resumed by SIGCONT, it gets
  control back after K on-time periods under ``"recover"``, never under ``"latch"``. The
  assertions read the plant's cycle records (which cycle missed, which was in the safe
  state), not the wall clock, so a loaded host changes when things happen, not the rule.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest
from _helpers import NodeProcesses, key_file_args, two_endpoints

from bus_schemas import ActuatorCommand
from hil.nodes.plant_node import STARTUP_S, PlantLoop
from hil.review.core import _WatchdogWindows, summarize
from hil.review.outcome import ExitCode, run_outcome
from hil.runlog.mcap_io import read_run
from hil.scenario.schema import (
    ScenarioError,
    load_scenario,
    parse_scenario,
    scenario_text,
    watchdog_rule,
)

MISSES = 3  # the default scenario's watchdog_misses
RECOVER = 40  # its watchdog_recover_cycles (1 s at 40 Hz)


# --------------------------------------------------------------------------- scenario keys


def test_policy_keys_are_checked_and_the_unset_policy_follows_the_recover_count() -> None:
    base = scenario_text("nrel5mw-steady-18")[0]
    assert "[timing]" not in base  # the keys below go into a fresh [timing] table
    sc = parse_scenario(base + '\n[timing]\nwatchdog_policy = "latch"\n', "t.toml")
    assert sc.timing.watchdog_rule == "latch"
    text = base + '\n[timing]\nwatchdog_policy = "recover"\nwatchdog_recover_cycles = 5\n'
    assert parse_scenario(text, "t.toml").timing.watchdog_rule == "recover"
    with pytest.raises(ScenarioError, match="watchdog_recover_cycles >= 1"):
        parse_scenario(base + '\n[timing]\nwatchdog_policy = "recover"\n', "t.toml")
    with pytest.raises(ScenarioError, match='watchdog_policy = "recover"'):
        parse_scenario(
            base + '\n[timing]\nwatchdog_policy = "latch"\nwatchdog_recover_cycles = 5\n', "t.toml"
        )
    with pytest.raises(ScenarioError, match="watchdog_policy"):
        parse_scenario(base + '\n[timing]\nwatchdog_policy = "reset"\n', "t.toml")
    # unset: recover when a recovery count is given (older scenarios), else latch
    assert parse_scenario(base, "t.toml").timing.watchdog_rule == "latch"
    text = base + "\n[timing]\nwatchdog_recover_cycles = 5\n"
    assert parse_scenario(text, "t.toml").timing.watchdog_rule == "recover"
    assert watchdog_rule({}) == "latch"
    assert watchdog_rule({"watchdog_recover_cycles": 40}) == "recover"
    assert watchdog_rule({"watchdog_policy": "latch", "watchdog_recover_cycles": 0}) == "latch"


def test_the_default_scenario_recovers() -> None:
    t = load_scenario("default").timing
    assert (t.watchdog_rule, t.watchdog_misses, t.watchdog_recover_cycles) == (
        "recover",
        MISSES,
        RECOVER,
    )


# --------------------------------------------------------------------------- plant counters


def _loop(policy: str, recover: int) -> PlantLoop:
    base = load_scenario("nrel5mw-steady-18").with_duration(20.0)
    timing = msgspec.structs.replace(
        base.timing,
        watchdog_misses=MISSES,
        watchdog_policy=policy,
        watchdog_recover_cycles=recover,
    )
    return PlantLoop(msgspec.structs.replace(base, timing=timing), lambda _mt, _m: None)


def _cycle(loop: PlantLoop, answered: bool) -> int:
    loop.sample()
    pitch, torque = loop.applied
    command = ActuatorCommand(
        seq=loop.k,
        answered_seq=loop.k,
        sample_time_ns=loop.t_ns,
        publish_time_ns=0,
        mode=0,
        blade_pitch_commanded_rad=pitch,
        generator_torque_commanded_nm=torque,
    )
    loop.finish_cycle(command if answered else None, 500_000 if answered else 0)
    return int(loop.safe_state)


def test_the_plant_counts_trips_recoveries_and_the_longest_window() -> None:
    # two stalls (5 and 10 missed periods), each followed by on-time commands
    stalls = {*range(100, 105), *range(300, 310)}
    k_rec = 20
    loop = _loop("recover", k_rec)
    flags = [_cycle(loop, answered=k not in stalls) for k in range(600)]
    r = loop.result
    assert (r.safe_state_entries, r.safe_state_recoveries) == (2, 2)
    # safe from the third miss to the k_rec-th on-time period after the stall
    assert flags[100 + MISSES - 1] == 1 and flags[105 + k_rec - 1] == 0
    assert all(flags[100 + MISSES - 1 : 105 + k_rec - 1])
    assert r.safe_state_longest_cycles == (310 + k_rec - 1) - (300 + MISSES - 1)
    assert r.safe_state_cycles == sum(flags)
    latched = _loop("latch", 0)
    flags = [_cycle(latched, answered=k not in stalls) for k in range(600)]
    assert all(flags[100 + MISSES - 1 :])
    r = latched.result
    assert (r.safe_state_entries, r.safe_state_recoveries) == (1, 0)
    assert r.safe_state_longest_cycles == r.safe_state_cycles == 600 - (100 + MISSES - 1)


# --------------------------------------------------------------------------- review counts


def test_windows_are_counted_across_batches() -> None:
    rng = np.random.default_rng(7)
    flags = rng.random(2000) < 0.5
    flags = np.repeat(flags, rng.integers(1, 30, flags.size))  # windows of many lengths
    w = _WatchdogWindows()
    cuts = np.sort(rng.choice(flags.size, 40, replace=False))
    for part in np.split(flags, cuts):
        w.add(part)
    padded = np.concatenate(([False], flags, [False]))
    starts = np.flatnonzero(padded[1:] & ~padded[:-1])
    ends = np.flatnonzero(~padded[1:] & padded[:-1])
    assert w.trips == starts.size
    assert w.recoveries == ends.size - int(flags[-1])  # a window open at the end is no recovery
    assert w.longest == int((ends - starts).max())


def _summary(policy: str | None, **timing: Any) -> dict[str, Any]:
    config: dict[str, Any] = {"timing": {"watchdog_recover_cycles": 40 if policy else 0}}
    if policy is not None:
        config["timing"]["watchdog_policy"] = policy
    tm = {"cycles": 24_000, "deadline_misses": 9, "safe_state": 0, "safe_state_cycles": 43}
    return {
        "run": {"mode": "realtime"},
        "scenario": {"config": config},
        "timing": {**tm, **timing},
        "controller": {},
    }


def test_a_recovered_safe_state_passes_only_under_recover_within_the_tolerance() -> None:
    assert run_outcome(_summary("recover")) == (ExitCode.OK, [])
    # held at the end: not recovered
    code, reasons = run_outcome(_summary("recover", safe_state=1))
    assert code == ExitCode.SAFE_STATE and "safe state" in reasons[0]
    # misses over the 1 % tolerated: the safe state is the verdict, as under latch
    code, reasons = run_outcome(_summary("recover", deadline_misses=900))
    assert code == ExitCode.SAFE_STATE and len(reasons) == 2
    # latch (explicit, or unset without a recovery count): any safe state fails the run
    assert run_outcome(_summary("latch"))[0] == ExitCode.SAFE_STATE
    assert run_outcome(_summary(None))[0] == ExitCode.SAFE_STATE
    # the controller's safe mode follows the same rule
    ctrl = {"safe_mode_entries": 2, "safe_mode_at_end": False}
    s = {**_summary("recover"), "controller": ctrl}
    assert run_outcome(s)[0] == ExitCode.OK
    s["controller"] = {**ctrl, "safe_mode_at_end": True}
    assert run_outcome(s)[0] == ExitCode.SAFE_STATE
    s = {**_summary("latch", safe_state_cycles=0), "controller": ctrl}
    assert run_outcome(s)[0] == ExitCode.SAFE_STATE


# --------------------------------------------------------------------------- real processes

DURATION_S = 10.0
STOP_AFTER_S = 3.0  # wall seconds after the plant starts its cycles
STOPPED_S = 1.5  # wall seconds the controller stays stopped (60 periods at 40 Hz)


def _wait_for_line(path: Path, text: str, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if path.exists() and text in path.read_text():
            return
        time.sleep(0.05)
    raise AssertionError(f"{path.name}: no {text!r} within {timeout_s} s")


def _scenario_file(folder: Path, policy: str) -> Path:
    text = scenario_text("default")[0]
    text = text.replace("duration_s = 60.0", f"duration_s = {DURATION_S}")
    if policy == "latch":
        text = text.replace('watchdog_policy = "recover"', 'watchdog_policy = "latch"')
        text = text.replace(f"watchdog_recover_cycles = {RECOVER}", "watchdog_recover_cycles = 0")
    path = folder / f"watchdog-{policy}.toml"
    path.write_text(text)
    assert parse_scenario(text, str(path)).timing.watchdog_rule == policy
    return path


def _run_with_a_stopped_controller(
    folder: Path, policy: str
) -> tuple[np.ndarray, np.ndarray, dict[str, Any], dict[str, str]]:
    """A real-time run whose controller is SIGSTOPped for a while: the plant's
    ``timing/cycle`` (``deadline_missed``, ``safe_state`` by seq) and the run's summary."""
    scenario = str(_scenario_file(folder, policy))
    plant_ep, ctrl_ep = two_endpoints()
    key = key_file_args(folder)

    def node(sub: str, *args: str) -> list[str]:
        return [sys.executable, "-m", "hil", sub, scenario, *args, *key]

    cmds = {
        "recorder": node(
            "record", "--out", str(folder / "run.mcap"), "--connect", plant_ep,
            "--connect", ctrl_ep,
        ),
        "controller": node(
            "controller", "--listen", ctrl_ep, "--connect", plant_ep, "--await-recorder", "60"
        ),
        "plant": node("plant", "--listen", plant_ep, "--mode", "realtime"),
    }  # fmt: skip
    with NodeProcesses(folder) as nodes:
        nodes.start("plant", cmds["plant"])
        nodes.start("recorder", cmds["recorder"])
        controller = nodes.start("controller", cmds["controller"])
        _wait_for_line(folder / "plant.log", "plant running", 180.0)
        time.sleep(STOP_AFTER_S)
        os.kill(controller.pid, signal.SIGSTOP)
        try:
            time.sleep(STOPPED_S)
        finally:
            os.kill(controller.pid, signal.SIGCONT)
        codes = nodes.wait(timeout=180)
    logs = nodes.logs()
    assert codes == dict.fromkeys(codes, 0), logs
    run = read_run(folder / "run.mcap")
    cycles = sorted(run.topic("timing/cycle"), key=lambda c: c["seq"])
    assert [c["seq"] for c in cycles] == list(range(len(cycles))), logs["recorder"]
    missed = np.array([c["deadline_missed"] for c in cycles], bool)
    safe = np.array([c["safe_state"] for c in cycles], bool)
    return missed, safe, summarize(run), logs


def _the_stall(missed: np.ndarray) -> tuple[int, int]:
    """The longest run of consecutive missed cycles: (its first cycle, one past its last)."""
    padded = np.concatenate(([False], missed, [False]))
    starts = np.flatnonzero(padded[1:] & ~padded[:-1])
    ends = np.flatnonzero(~padded[1:] & padded[:-1])
    i = int(np.argmax(ends - starts))
    return int(starts[i]), int(ends[i])


@pytest.mark.e2e
@pytest.mark.parametrize("policy", ["latch", "recover"])
def test_a_stopped_controller_brings_the_safe_state_within_three_periods(
    tmp_path: Path, policy: str
) -> None:
    missed, safe, summary, logs = _run_with_a_stopped_controller(tmp_path, policy)
    start, end = _the_stall(missed)
    period_s = 0.025
    # the stop lasted STOPPED_S of wall time: far more periods missed than the watchdog needs
    assert end - start > 10 * MISSES, (start, end, logs["plant"])
    startup = round(STARTUP_S / period_s)
    assert start >= startup, "the stop fell in the start-up second: the test's timing failed"
    # the last command came in cycle start - 1; from the MISSES-th missed period on (cycle
    # start + MISSES - 1) the plant is in its safe state for the whole stall
    assert safe[start + MISSES - 1 : end].all(), safe[start - 1 : end].astype(int)
    assert not safe[start : start + MISSES - 1].any() or safe[start - 1]
    tm = summary["timing"]
    assert tm["watchdog_policy"] == policy and tm["watchdog_trips"] >= 1
    if policy == "latch":
        # never handed back: safe from the trip to the last cycle
        assert safe[start + MISSES - 1 :].all()
        # (a slow start's safe state is handed back even when latched: those are the only
        # recoveries there may be, all before the stop)
        handed_back = int((safe[: start - 1] & ~safe[1:start]).sum())
        assert tm["safe_state"] == 1 and tm["watchdog_recoveries"] == handed_back
        assert run_outcome(summary)[0] == ExitCode.SAFE_STATE
        return
    # recover: control comes back in the first cycle that ends RECOVER on-time periods in a
    # row after the stall (a loaded host may add misses that restart the count)
    on_time = ~missed
    back = next(
        c for c in range(end + RECOVER - 1, len(safe)) if on_time[c - RECOVER + 1 : c + 1].all()
    )
    assert safe[end:back].all() and not safe[back], (end, back, safe[end:].astype(int))
    assert tm["watchdog_recoveries"] >= 1
    assert tm["watchdog_trips"] - tm["watchdog_recoveries"] == int(safe[-1])
    assert tm["safe_state_longest_cycles"] >= back - (start + MISSES - 1)
