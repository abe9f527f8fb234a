"""A misbehaving controller core gets one honest verdict, the same in every mode.

Three cores (a baseline wrapped in a module this file writes into ``tmp_path``, reached
through ``[controller] kind = "python"``, ``core = "module:function"``) misbehave: from
t = :data:`FAULT_AT_S` one raises, one returns a NaN pitch; from :data:`SLOW_FROM_S` one
sleeps longer than the control period. Each runs in process, lock-step and real time
(``fowt run``, real processes), and in process through the campaign runner's
:func:`execute_run`:

* raise / NaN: exit 7 (``controller_fault``) everywhere, the same reason line (numbers
  aside), ``controller.fault`` with kind, message, t_s and cycle; the faulted commands are
  recorded flagged (mode 3) and never applied: the plant enters its safe state, its state
  stays finite; no traceback on the console or in any node's log;
* slow: exit 7 and the reason "controller exceeded its deadline in N of M cycles (p99 ...
  ms)" in every mode, whether the plant waits for each command (lock-step, in process) or
  its watchdog takes it to its safe state (real time); the run ends within its duration
  plus a few seconds of wall time past the plant;
* a core that raises in the trim's settling run: exit 7, the controller named, not the plant.

Plus :func:`hil.review.outcome.run_outcome`'s precedence for the new code.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest
from _helpers import REPO

from hil.review.outcome import ExitCode, run_outcome

#: Simulated time from which the cores misbehave [s] (cycle 120 at 25 ms).
FAULT_AT_S = 3.0
DURATION_S = 6.0
#: The slow core sleeps 2.5 control periods a step from here on [s] (most of the run: a
#: core slow in a quarter of its steps or fewer is not judged on it).
SLOW_FROM_S = 1.0
PERIOD_S = 0.025

CORES = """
import time

import msgspec

from controller.registry import make_controller

FAULT_AT_S = {at}
SLOW_FROM_S = {slow_from}


class Misbehaving:
    '''The baseline, misbehaving from FAULT_AT_S on (how: raise, nan, slow).'''

    def __init__(self, options, how):
        self.inner = make_controller("baseline", "iea15mw_baseline",
                                     control_period_s=options.control_period_s)
        self.how = how

    def initial_state(self):
        return self.inner.initial_state()

    def actuator_limits(self):
        return self.inner.actuator_limits()

    def step(self, state, frame, dt):
        state, out = self.inner.step(state, frame, dt)
        if frame.sample_time_ns * 1e-9 >= FAULT_AT_S:
            if self.how == "raise":
                raise ValueError("gain table index out of range")
            if self.how == "nan":
                out = msgspec.structs.replace(out, blade_pitch_commanded_rad=float("nan"))
        if self.how == "slow" and frame.sample_time_ns * 1e-9 >= SLOW_FROM_S:
            time.sleep(2.5 * dt)
        return state, out


def raising(options):
    return Misbehaving(options, "raise")


def nan(options):
    return Misbehaving(options, "nan")


def slow(options):
    return Misbehaving(options, "slow")
"""


def _scenario(folder: Path, how: str, *, trim: bool = False) -> Path:
    text = f"""
name = "misbehaving-{how}"
turbine = "iea15mw"
duration_s = {DURATION_S}
[wind]
kind = "steady"
speed_m_s = 10.0
[timing]
control_period_s = {PERIOD_S}
plant_step_s = {PERIOD_S / 2}
[initial]
trim = {"true" if trim else "false"}
[controller]
kind = "python"
core = "misbehaving_cores:{"raising" if how == "raise" else how}"
"""
    path = folder / f"{how}{'-trim' if trim else ''}.toml"
    path.write_text(textwrap.dedent(text))
    return path


@pytest.fixture(scope="module")
def cores(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding ``misbehaving_cores.py`` (importable by every process of a run)."""
    folder = tmp_path_factory.mktemp("cores")
    (folder / "misbehaving_cores.py").write_text(CORES.format(at=FAULT_AT_S, slow_from=SLOW_FROM_S))
    return folder


def _fowt(cores: Path, *args: str, timeout: float = 300.0) -> subprocess.CompletedProcess[str]:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO), str(cores), os.environ.get("PYTHONPATH", "")]),
    }
    return subprocess.run(
        [sys.executable, "-m", "hil", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
        env=env,
    )


def _shape(line: str) -> str:
    """A reason line with its numbers replaced (modes differ in counts and times)."""
    return re.sub(r"\d+(\.\d+)?", "#", line)


def _no_tracebacks(proc: subprocess.CompletedProcess[str], out: Path) -> None:
    assert "Traceback" not in proc.stdout + proc.stderr, proc.stdout + proc.stderr
    for log in (out / "logs").glob("*.log") if (out / "logs").is_dir() else ():
        text = log.read_text(errors="replace")
        assert "Traceback" not in text, f"{log.name}:\n{text[-3000:]}"
        assert "ZError" not in text, f"{log.name}:\n{text[-3000:]}"


def _run(cores: Path, tmp: Path, how: str, mode: str) -> tuple[dict[str, Any], str]:
    out = tmp / f"{how}-{mode}"
    proc = _fowt(cores, "run", str(_scenario(tmp, how)), "--mode", mode, "--out", str(out),
                 "--no-plots")  # fmt: skip
    _no_tracebacks(proc, out)
    summary = json.loads((out / "summary.json").read_text())
    assert proc.returncode == summary["run"]["exit_code"], proc.stdout + proc.stderr
    last = proc.stdout.strip().splitlines()[-1]
    assert last.startswith(f"outcome: {summary['run']['outcome']}"), proc.stdout
    return summary, last


# --------------------------------------------------------------------------- the verdict


def _faulted(fault: dict[str, Any]) -> dict[str, Any]:
    return {
        "run": {"mode": "lockstep"},
        "timing": {"cycles": 400, "safe_state_cycles": 280, "deadline_misses": 3},
        "recording": {"complete": False, "problems": ["commands: 3 lost"]},
        "controller": {"fault": fault},
    }


def test_a_controller_fault_wins_over_what_it_causes() -> None:
    fault = {"kind": "raised", "message": "ValueError('x')", "t_s": 20.0, "cycle": 2000}
    code, reasons = run_outcome(_faulted(fault))
    assert code == ExitCode.CONTROLLER_FAULT == 7
    assert reasons[0] == "controller raised ValueError('x') at t = 20.00 s (cycle 2000)"
    assert len(reasons) == 4  # the recording, the safe state, the misses follow


def test_a_failed_or_aborted_run_stays_so() -> None:
    fault = {"kind": "non_finite", "message": "blade_pitch_commanded_rad = nan", "t_s": 1.0}
    summary = _faulted(fault)
    summary["run"]["failed"] = "recorder exited with 1"
    assert run_outcome(summary)[0] == ExitCode.FAILED
    del summary["run"]["failed"]
    summary["run"]["aborted"] = True
    code, reasons = run_outcome(summary)
    assert code == ExitCode.ABORTED
    assert reasons[1] == (
        "controller output non-finite (blade_pitch_commanded_rad = nan) at t = 1.00 s"
    )


def test_a_slow_controller_is_named() -> None:
    summary = {
        "run": {"mode": "lockstep"},
        "controller": {"overruns": 150, "cycles_stepped": 400, "compute_us": {"p99": 62_500.0}},
    }
    code, reasons = run_outcome(summary)
    assert code == ExitCode.CONTROLLER_FAULT
    assert reasons == ["controller exceeded its deadline in 150 of 400 cycles (p99 62.5 ms)"]
    summary["controller"]["overruns"] = 40  # 10 %: a busy host, not a slow core
    assert run_outcome(summary) == (ExitCode.OK, [])


# --------------------------------------------------------------------------- real runs

MODES = ("inprocess", "lockstep", "realtime")


@pytest.mark.parametrize("how", ["raise", "nan"])
def test_a_faulting_core_gets_the_same_verdict_in_every_mode(
    cores: Path, tmp_path: Path, how: str
) -> None:
    lines = {}
    for mode in MODES:
        summary, last = _run(cores, tmp_path, how, mode)
        assert summary["run"]["exit_code"] == 7, (mode, last)
        assert summary["run"]["outcome"] == "controller_fault"
        fault = summary["controller"]["fault"]
        assert fault["kind"] == ("raised" if how == "raise" else "non_finite")
        assert fault["t_s"] == pytest.approx(FAULT_AT_S, abs=PERIOD_S)
        assert fault["cycle"] == pytest.approx(FAULT_AT_S / PERIOD_S, abs=1)
        first = summary["run"]["outcome_reasons"][0]
        if how == "raise":
            assert first.startswith(
                "controller raised ValueError('gain table index out of range') at t = 3.0"
            ), first
        else:
            assert first.startswith(
                "controller output non-finite (blade_pitch_commanded_rad = nan) at t = 3.0"
            ), first
        assert first in last  # printed by fowt run
        # the faulted commands are recorded, flagged, and never applied: the safe state
        assert summary["controller"]["fault_commands"] > 0, mode
        assert summary["timing"]["safe_state_cycles"] > 0, mode
        assert summary["recording"]["complete"], (mode, summary["recording"]["problems"])
        # nothing non-finite reached the plant: its state, hence the KPIs, stay numbers
        assert summary["kpi"]["mean_power_w"] is not None, mode
        assert summary["kpi"]["rotor_speed_mean_rad_s"] is not None, mode
        lines[mode] = _shape(first)
        if mode == "lockstep":  # the file and what is beside it give the same verdict
            out = tmp_path / f"{how}-{mode}"
            review = _fowt(cores, "review", str(out / "run.mcap"), "--strict", "--no-plots")
            assert review.returncode == 7, review.stdout + review.stderr
            assert first in review.stderr, review.stderr
    assert len(set(lines.values())) == 1, lines


def test_a_slow_core_is_named_in_every_mode(cores: Path, tmp_path: Path) -> None:
    lines = {}
    for mode in MODES:
        summary, last = _run(cores, tmp_path, "slow", mode)
        # the same verdict in every mode, though the plant waits for each command in lock-step
        # and in process (no safe state there) and takes its safe state in real time
        assert summary["run"]["exit_code"] == 7, (mode, last)
        assert summary["run"]["outcome"] == "controller_fault", (mode, last)
        slow = [r for r in summary["run"]["outcome_reasons"] if r.startswith("controller exc")]
        assert slow, (mode, summary["run"]["outcome_reasons"])
        assert summary["run"]["outcome_reasons"][0] == slow[0], summary["run"]
        assert slow[0] in last
        lines[mode] = _shape(slow[0])
        if mode == "realtime":  # no long wait for the recorder behind a slow controller
            assert summary["run"]["launcher_wall_s"] < DURATION_S + 30.0, summary["run"]
    assert len(set(lines.values())) == 1, lines


@pytest.mark.parametrize("mode", ["inprocess", "lockstep"])
def test_a_fault_in_the_trims_settling_run_is_the_controllers(
    cores: Path, tmp_path: Path, mode: str
) -> None:
    out = tmp_path / "trim"
    proc = _fowt(cores, "run", str(_scenario(tmp_path, "raise", trim=True)), "--mode",
                 mode, "--out", str(out), "--no-plots")  # fmt: skip
    _no_tracebacks(proc, out)
    assert proc.returncode == 7, proc.stdout + proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["run"]["failed_process"] == "controller"
    assert summary["controller"]["fault"]["phase"] == "trim"
    assert "in the trim's settling run" in proc.stdout.strip().splitlines()[-1]
    assert "plant" not in proc.stdout.strip().splitlines()[-1]


@pytest.mark.parametrize("how", ["raise", "nan"])
def test_a_campaign_run_records_the_same_verdict(
    cores: Path, tmp_path: Path, how: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    import msgspec

    from hil.campaign.runner import execute_run, row_of
    from hil.scenario.schema import load_scenario

    monkeypatch.syspath_prepend(str(cores))
    scenario = load_scenario(str(_scenario(tmp_path, how)))
    result = execute_run(
        {
            "scenario": msgspec.to_builtins(scenario),
            "mode": "inprocess",
            "run_dir": str(tmp_path / "run"),
            "record": "mcap",
            "design_dir": None,
        }
    )
    assert result["status"] == "ok", result["error"]
    assert (result["outcome"], result["exit_code"]) == ("controller_fault", 7)
    reasons = result["summary"]["run"]["outcome_reasons"]
    word = "raised ValueError" if how == "raise" else "output non-finite"
    assert reasons[0].startswith(f"controller {word}"), reasons
    assert "Traceback" not in result["traceback"] + result["error"]

    class _Spec:  # the identity row_of reads
        case, probability, controller, waves, seed, scenario_hash = "c", 1.0, "x", "w", 1, "h"

    row = row_of(_Spec(), result)  # type: ignore[arg-type]
    assert (row["outcome"], row["exit_code"]) == ("controller_fault", 7)
