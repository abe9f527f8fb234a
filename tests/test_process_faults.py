"""Process faults: ``controller_kill`` and ``plant_kill`` from a scenario.

Validation: the two kinds take no ``channel`` (nor any other channel-fault key), only
``controller_kill`` takes ``restart_after_s`` (> 0 wall-clock seconds), and every error
names the table and the key. The launcher refuses a ``controller_kill`` in lock-step (the
plant would wait for the dead controller until its lock-step timeout) and any process fault
in an in-process run. :class:`hil.launch.ProcessFaultDriver` is checked against stand-in
processes fed with ``timing/cycle`` payloads: it kills when the simulated time reaches
``start_s``, restarts after ``restart_after_s`` and counts a laggard after a plant kill as
a failure.

End to end (real time, real processes over Zenoh):

* ``fowt run faults-processes --duration 20``: the controller is killed at 10 s and
  restarted 2 s later; the plant enters its safe state at most ``watchdog_misses`` cycles
  after the last command of the killed controller, leaves it on the K-th consecutive
  on-time command of the new one, and the run completes (exit status 5, the safe-state code
  of :mod:`hil.review.outcome`);
* a plant killed at 5 s: the controller and the recorder exit by themselves within a few
  seconds, the MCAP file reviews, the summary says the plant was killed (exit status 0, or
  in real time on a loaded host the safe-state or deadline-misses code of :mod:`hil.review.outcome`
  when the plant's watchdog tripped before the kill).
"""

from __future__ import annotations

import functools
import io
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from _helpers import STEADY_FLOATING_SCENARIO, cycle_timing, fowt
from _mcap_conformance import check_complete_mcap
from rich.console import Console

from bus_schemas.registry import CYCLE_TIMING
from hil import launch
from hil.launch import ProcessFaultDriver, ProcessFaultError, check_process_faults
from hil.review.outcome import ExitCode
from hil.runlog.mcap_io import read_run
from hil.scenario.schema import (
    ProcessFault,
    Scenario,
    ScenarioError,
    load_scenario,
    parse_scenario,
    scenario_text,
)

BASE = STEADY_FLOATING_SCENARIO  # the smallest floating scenario (TOML)


def _with_faults(*tables: str, base: str = BASE) -> str:
    return base + "".join(f"\n[[faults]]\n{t}\n" for t in tables)


_fowt = functools.partial(fowt, timeout=240.0)


# --------------------------------------------------------------------------- validation


def test_process_faults_parse_and_stay_out_of_the_channel_faults() -> None:
    sc = parse_scenario(
        _with_faults(
            'kind = "plant_kill"\nstart_s = 20.0',
            'kind = "stuck"\nchannel = "platform_pitch_measured_rad"\nstart_s = 1.0',
            'kind = "controller_kill"\nstart_s = 5.0\nrestart_after_s = 2',
        )
    )
    assert sc.process_faults() == (
        ProcessFault(index=2, kind="controller_kill", start_s=5.0, restart_after_s=2.0),
        ProcessFault(index=0, kind="plant_kill", start_s=20.0),
    )
    assert [f.kind for f in sc.fault_specs()] == ["stuck"]  # the plant never sees them
    assert sc.process_faults()[0].process == "controller"
    assert "faults[2]" in sc.process_faults()[0].describe()


@pytest.mark.parametrize(
    ("table", "message"),
    [
        (
            'kind = "controller_kill"\nchannel = "sensors"\nstart_s = 5.0',
            r"faults\[0\]: key 'channel' is not used by kind 'controller_kill'",
        ),
        (
            'kind = "plant_kill"\nchannel = ["command"]\nstart_s = 5.0',
            r"faults\[0\]: key 'channel' is not used by kind 'plant_kill'",
        ),
        (
            'kind = "controller_kill"\nstart_s = 5.0\nend_s = 6.0',
            r"faults\[0\]: key 'end_s' is not used by kind 'controller_kill'",
        ),
        (
            'kind = "controller_kill"\nstart_s = 5.0\nprobability = 0.5',
            r"faults\[0\]: key 'probability' is not used",
        ),
        (
            'kind = "plant_kill"\nstart_s = 5.0\nrestart_after_s = 1.0',
            r"faults\[0\]: key 'restart_after_s' is not used by kind 'plant_kill'",
        ),
        (
            'kind = "controller_kill"\nstart_s = 5.0\nrestart_after_s = 0.0',
            r"faults\[0\]: key 'restart_after_s' expected a wall-clock delay > 0 s",
        ),
        (
            'kind = "controller_kill"\nstart_s = 5.0\nrestart_after_s = nan',
            r"key 'faults\[0\]\.restart_after_s': expected a finite number, got nan",
        ),
        (
            'kind = "controller_kill"\nstart_s = -1.0',
            r"faults\[0\]: key 'start_s' expected a simulated time >= 0 s",
        ),
        (
            'kind = "stuck"\nchannel = "platform_pitch_measured_rad"\nrestart_after_s = 1.0',
            r"faults\[0\]: key 'restart_after_s' is used only by kind 'controller_kill'",
        ),
        ('kind = "stuck"\nstart_s = 1.0', r"faults\[0\]: fault stuck: channel is required"),
        ('kind = "controler_kill"\nstart_s = 1.0', r"did you mean 'controller_kill'\?"),
        (
            'kind = "plant_kill"\nrestart_after_ms = 1.0',
            r"unknown key 'faults\[0\].restart_after_ms",
        ),
    ],
)
def test_bad_process_faults_name_the_key(table: str, message: str) -> None:
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(_with_faults(table), "bad.toml")


def test_a_second_plant_kill_is_refused() -> None:
    text = _with_faults('kind = "plant_kill"\nstart_s = 5.0', 'kind = "plant_kill"\nstart_s = 6.0')
    with pytest.raises(ScenarioError, match=r"faults\[1\]: a second plant_kill"):
        parse_scenario(text, "bad.toml")


def test_shipped_process_fault_scenario() -> None:
    sc = load_scenario("faults-processes")
    default = load_scenario("default")
    assert sc.process_faults() == (
        ProcessFault(index=0, kind="controller_kill", start_s=10.0, restart_after_s=2.0),
    )
    assert sc.fault_specs() == ()
    assert sc.duration_s == 30.0
    assert sc.timing.control_period_s == 0.025 and sc.timing.watchdog_recover_cycles == 40
    assert (sc.platform, sc.wind, sc.waves, sc.controller) == (
        default.platform,
        default.wind,
        default.waves,
        default.controller,
    )


def test_modes_that_cannot_act_are_refused_before_anything_starts(tmp_path: Path) -> None:
    kill_ctrl = parse_scenario(_with_faults('kind = "controller_kill"\nstart_s = 1.0'))
    kill_plant = parse_scenario(_with_faults('kind = "plant_kill"\nstart_s = 1.0'))
    with pytest.raises(ProcessFaultError, match=r"controller_kill.*--mode realtime.*lock-step"):
        check_process_faults(kill_ctrl, "lockstep")
    with pytest.raises(ProcessFaultError, match="in-process run has none"):
        check_process_faults(kill_plant, "inprocess")
    assert len(check_process_faults(kill_ctrl, "realtime")) == 1
    assert len(check_process_faults(kill_plant, "lockstep")) == 1
    out = tmp_path / "run"
    proc = _fowt("run", "faults-processes", "--mode", "lockstep", "--out", str(out))
    assert proc.returncode == 2, proc.stdout + proc.stderr  # bad input: refused before it starts
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert "controller_kill" in lines[0] and "lock-step" in lines[0], proc.stderr
    assert not out.exists()


# --------------------------------------------------------------------------- the driver


def _cycle(k: int, period_ns: int, safe: int = 0) -> bytes:
    return CYCLE_TIMING.codec.encode(
        cycle_timing(
            k,
            k * period_ns,
            publish_time_ns=0,
            deadline_missed=safe,
            command_held=safe,
            safe_state=safe,
        )
    )


def _sleeper() -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])


def _reap(procs: list[subprocess.Popen[bytes]]) -> None:
    for p in procs:
        if p.poll() is None:
            p.kill()
        p.wait(10)


def test_driver_kills_at_start_s_and_restarts_after_the_delay() -> None:
    period_ns = 25_000_000
    fault = ProcessFault(index=0, kind="controller_kill", start_s=1.0, restart_after_s=0.3)
    driver = ProcessFaultDriver([fault], 0.025)
    console = Console(file=io.StringIO(), width=200)
    procs = {name: _sleeper() for name in ("plant", "controller", "recorder")}
    started: list[subprocess.Popen[bytes]] = list(procs.values())

    def start(name: str) -> subprocess.Popen[bytes]:
        proc = _sleeper()
        started.append(proc)
        procs[name] = proc
        return proc

    try:
        first = procs["controller"]
        driver.on_cycle("", _cycle(38, period_ns))  # simulated time 0.975 s: not yet
        driver.step(procs, start, console)
        assert first.poll() is None and not driver.due.is_set()
        driver.on_cycle("", _cycle(39, period_ns))  # cycle 39 ends at 1.0 s: kill
        assert driver.due.is_set()
        driver.step(procs, start, console)
        assert first.poll() == -9 and driver.expected(first)
        driver.on_cycle("", _cycle(42, period_ns, safe=1))
        assert 0.0 < driver.wait_s(1.0) <= 0.3
        driver.step(procs, start, console)
        assert procs["controller"] is first  # the restart is not due yet
        time.sleep(0.35)
        driver.step(procs, start, console)
        assert procs["controller"] is not first and procs["controller"].poll() is None
        driver.on_cycle("", _cycle(200, period_ns, safe=0))
        driver.finish(console)
    finally:
        _reap(started)
    (rec,) = driver.records
    assert rec["outcome"] == "controller killed and restarted"
    assert rec["killed"]["sim_s"] == 1.0 and rec["killed"]["pid"] == first.pid
    # Never before its delay; late only by the step cadence, which a loaded host stretches.
    assert 0.3 - 0.05 <= rec["restarted"]["wall_s"] - rec["killed"]["wall_s"] <= 0.3 + 1.0
    assert rec["plant_safe_state"] == {"entered_sim_s": 1.05, "left_sim_s": 5.0}
    assert not driver.problems and not driver.plant_killed
    driver.render(console)


def test_driver_after_a_plant_kill_fails_a_process_that_stays(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(launch, "PLANT_KILL_EXIT_TIMEOUT_S", {"controller": 0.5, "recorder": 0.5})
    faults = [
        ProcessFault(index=0, kind="plant_kill", start_s=0.5),
        ProcessFault(index=1, kind="controller_kill", start_s=9.0),
    ]
    driver = ProcessFaultDriver(faults, 0.01)
    console = Console(file=io.StringIO(), width=200)
    procs = {"plant": _sleeper(), "controller": _sleeper()}
    procs["recorder"] = subprocess.Popen([sys.executable, "-c", "pass"])  # exits at once
    try:
        driver.on_cycle("", _cycle(60, 10_000_000))
        driver.step(procs, lambda name: procs[name], console)
        assert procs["plant"].poll() == -9 and driver.plant_killed
        driver.wait_for_others(procs, console)
        driver.finish(console)
    finally:
        _reap(list(procs.values()))
    plant, ctrl = driver.records
    assert plant["outcome"] == "plant killed" and plant["killed"]["sim_s"] == 0.61
    assert plant["others"]["recorder"]["by_itself"] is True
    assert plant["others"]["recorder"]["exit_code"] == 0
    assert plant["others"]["controller"]["by_itself"] is False
    assert ctrl["killed"] is None and ctrl["outcome"].startswith("not injected")
    assert driver.problems == [
        "controller did not exit by itself within 0.5 s of the plant's kill (terminated)"
    ]


# --------------------------------------------------------------------------- end to end


def _cycles(mcap: Path) -> tuple[list[dict[str, Any]], list[dict[str, Any]], Any]:
    run = read_run(mcap)
    assert not run.truncated, run.error
    check_complete_mcap(mcap)  # whichever process was killed, the recorder's file is complete
    return run.topic("timing/cycle"), run.topic("command"), run


@pytest.mark.e2e
def test_controller_killed_and_restarted(tmp_path: Path) -> None:
    """The shipped scenario, 20 s: kill at 10 s, restart 2 s later, watchdog K = 40."""
    sc: Scenario = load_scenario("faults-processes")
    n_miss, k_rec = sc.timing.watchdog_misses, sc.timing.watchdog_recover_cycles
    period = sc.timing.control_period_s
    out = tmp_path / "run"
    proc = _fowt("run", "faults-processes", "--duration", "20", "--out", str(out), "--no-plots")
    logs = {p.name: p.read_text() for p in (out / "logs").glob("*.log")}
    # The plant did enter its safe state: a run that did is not a healthy one (hil.review.outcome).
    assert proc.returncode == ExitCode.SAFE_STATE, proc.stdout + proc.stderr + json.dumps(logs)
    assert "process fault" in proc.stdout and "restarted" in proc.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["run"]["outcome"] == "safe_state"
    assert summary["run"]["exit_code"] == ExitCode.SAFE_STATE
    (rec,) = summary["run"]["process_faults"]
    assert summary["run"]["plant_killed"] is False
    assert rec["kind"] == "controller_kill" and rec["outcome"] == "controller killed and restarted"
    kill, restart = rec["killed"], rec["restarted"]
    # Bounds that hold beside two CPU hogs: the kill is never early and follows the plant's
    # cycle records within a second; the restart is never before its 2 s delay and late
    # only by the follow loop's cadence on a loaded host.
    assert 10.0 <= kill["sim_s"] < 11.0, rec
    assert 2.0 - 0.05 <= restart["wall_s"] - kill["wall_s"] < 3.5, rec
    assert restart["pid"] != kill["pid"]

    cycles, commands, _ = _cycles(out / "run.mcap")
    assert [c["seq"] for c in cycles] == list(range(round(20 / period)))  # the run completed
    assert summary["timing"]["complete"] is True
    assert summary["timing"]["cycles"] == round(20 / period)
    safe = [c["safe_state"] for c in cycles]
    entered = safe.index(1)
    left = entered + safe[entered:].index(0)
    assert all(s == 0 for s in safe[left:]), "the plant went back to the safe state"
    # Safe watchdog_misses cycles after the killed controller's last on-time command, which
    # answered a frame of the cycle the kill came in (the launcher kills at the end of the
    # newest cycle the plant has reported; the plant is then one cycle further) ...
    last_ok = max(i for i in range(entered) if cycles[i]["deadline_missed"] == 0)
    killed_last = max(c["answered_seq"] for c in commands if c["sample_time_ns"] < 10.6e9)
    assert entered - last_ok == n_miss, (last_ok, entered)
    assert last_ok <= killed_last + 1, (last_ok, killed_last)
    assert abs((last_ok + 1) * period - kill["sim_s"]) <= 2 * period + 1e-9, (last_ok, kill)
    assert entered * period <= kill["sim_s"] + (n_miss + 1) * period + 1e-9
    # ... and back on the K-th consecutive on-time command of the new controller.
    assert left * period > restart["sim_s"]
    assert all(c["deadline_missed"] == 0 for c in cycles[left - k_rec + 1 : left + 1])
    assert cycles[left - k_rec]["deadline_missed"] == 1
    after = [c for c in commands if c["sample_time_ns"] > restart["sim_s"] * 1e9]
    assert rec["plant_safe_state"] == {
        "entered_sim_s": round(entered * period, 3),
        "left_sim_s": round(left * period, 3),
    }
    print(
        f"\ncontroller killed at {kill['sim_s']} s (last command for cycle {killed_last}, "
        f"last on time {last_ok}; {len(after)} commands of the new controller recorded), "
        f"safe state cycles {entered}..{left - 1} ({entered * period:.3f} s to "
        f"{left * period:.3f} s), restarted at {restart['sim_s']} s simulated"
    )


@pytest.mark.e2e
@pytest.mark.parametrize("mode", ["realtime", "lockstep"])
def test_plant_killed(mode: str, tmp_path: Path) -> None:
    """Real time, and lock-step (faster than real time: the kill may come a little later)."""
    text = scenario_text("default")[0].replace("duration_s = 60.0", "duration_s = 20.0")
    scenario = tmp_path / "plant-kill.toml"
    scenario.write_text(text + '\n[[faults]]\nkind = "plant_kill"\nstart_s = 5.0\n')
    out = tmp_path / "run"
    t0 = time.monotonic()
    proc = _fowt("run", str(scenario), "--mode", mode, "--out", str(out), "--no-plots")
    logs = {p.name: p.read_text() for p in (out / "logs").glob("*.log")}
    summary = json.loads((out / "summary.json").read_text())
    # The kill is no failure (the others ended by themselves): the run is judged on its
    # health alone, which in real time on a loaded host may include the plant's watchdog
    # tripping before the kill (missed deadlines, then the safe state), never more.
    judged = summary["run"]["exit_code"]
    assert proc.returncode == judged, proc.stdout + proc.stderr + json.dumps(logs)
    allowed = {ExitCode.OK} | (
        {ExitCode.SAFE_STATE, ExitCode.DEADLINE_MISSES} if mode == "realtime" else set()
    )
    assert judged in allowed, proc.stdout + proc.stderr + json.dumps(logs)
    assert time.monotonic() - t0 < 180  # a 20 s run: hung waits would take far longer
    assert summary["run"]["plant_killed"] is True
    (rec,) = summary["run"]["process_faults"]
    assert rec["kind"] == "plant_kill" and rec["outcome"] == "plant killed"
    slack = 1.0 if mode == "realtime" else 5.0  # the launcher follows the cycles over Zenoh
    assert 5.0 <= rec["killed"]["sim_s"] < 5.0 + slack
    for name in ("controller", "recorder"):
        other = rec["others"][name]
        assert other["by_itself"] is True and other["exit_code"] == 0, rec
        assert other["exited_after_s"] < 10.0, rec  # their plant-gone timeouts, with load
    assert "plant gone" in logs["controller.log"]
    assert "the plant went away" in logs["recorder.log"]
    # The file is closed by the recorder and reviews; its timing stops at the kill.
    assert summary["run"]["truncated"] is False
    assert summary["timing"]["complete"] is False
    assert summary["kpi"]["mean_power_w"] is not None
    cycles, _, _ = _cycles(out / "run.mcap")
    assert 4.5 <= cycles[-1]["sample_time_ns"] / 1e9 <= rec["killed"]["sim_s"] + slack
    review = _fowt("review", str(out / "run.mcap"), "--json", "--no-plots")
    assert review.returncode == 0, review.stdout + review.stderr
    assert json.loads(review.stdout)["timing"]["complete"] is False
