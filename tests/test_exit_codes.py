"""Exit codes a script can trust (docs/exit-codes.md).

* :func:`hil.review.outcome.run_outcome` on summaries: each condition alone gives its code, several
  give the first in precedence order and every reason, missing keys count as healthy, the
  deadline-miss tolerance comes from the scenario or the mode;
* ``[timing] max_deadline_miss_fraction`` is validated (exit 2, one line);
* ``fowt run`` with a duration shorter than one control period: exit 2, one ``error:`` line,
  nothing written;
* a run whose controller is killed for good (real time): the plant's safe state, exit 5, and
  ``summary.json`` says so; ``fowt review --strict`` gives the same code from the file;
* disk full (a 300 KiB tmpfs) in ``--mode inprocess`` and in the recorder process (lock-step):
  exit 1, one ``error:`` line naming the file and "No space left on device", no traceback,
  no process left, and the MCAP file reads up to the failure;
* ``--out`` in a read-only file system: exit 2, one line, before anything starts;
* errors of ``review``, ``recover``, ``campaign``, ``compare``, ``report`` go to stderr as one
  line, brackets kept.
"""

from __future__ import annotations

import contextlib
import functools
import json
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from _helpers import fowt

from hil.review.outcome import (
    DEFAULT_MAX_DEADLINE_MISS_FRACTION,
    DEFAULT_MAX_DEADLINE_MISSES,
    ExitCode,
    deadline_miss_count_tolerance,
    deadline_miss_tolerance,
    outcome_line,
    record_outcome,
    run_outcome,
)
from hil.runlog.mcap_io import read_run
from hil.scenario.schema import ScenarioError, load_scenario, parse_scenario, scenario_text

#: A scenario without a [timing] table (steady wind, bottom-fixed: quick to run in process).
BASE = """
name = "t"
turbine = "iea15mw"
duration_s = 1.0
[wind]
kind = "steady"
speed_m_s = 10.0
"""

# --------------------------------------------------------------------------- the function


def _healthy(mode: str = "realtime") -> dict[str, Any]:
    """A summary of a complete, healthy run (the keys run_outcome reads)."""
    return {
        "timing": {"cycles": 1000, "deadline_misses": 0, "safe_state": 0, "safe_state_cycles": 0},
        "run": {"mode": mode, "truncated": False, "statistics_ok": True},
        "scenario": {"config": {"timing": {"max_deadline_miss_fraction": None}}},
        "recording": {"complete": True, "problems": []},
        "controller": {"safe_mode_entries": 0},
    }


def test_a_healthy_run_is_ok() -> None:
    assert run_outcome(_healthy()) == (ExitCode.OK, [])
    assert run_outcome({}) == (ExitCode.OK, [])  # nothing known: nothing wrong


def test_codes_are_distinct_and_keep_1_and_2() -> None:
    assert len({int(c) for c in ExitCode}) == len(ExitCode)
    assert ExitCode.FAILED == 1 and ExitCode.USAGE == 2 and ExitCode.OK == 0
    assert [c.word for c in ExitCode][3:] == [
        "aborted",
        "recording_incomplete",
        "safe_state",
        "deadline_misses",
        "controller_fault",
    ]


@pytest.mark.parametrize(
    ("change", "code", "said"),
    [
        (lambda s: s["run"].update(failed="plant exited with 1"), ExitCode.FAILED, "plant exited"),
        (
            lambda s: s["run"].update(process_fault_problems=["recorder did not exit"]),
            ExitCode.FAILED,
            "recorder did not exit",
        ),
        (
            lambda s: s["run"].update(aborted=True, abort_signal="SIGTERM", aborted_at_s=4.5),
            ExitCode.ABORTED,
            "aborted by SIGTERM at 4.50 s",
        ),
        (
            lambda s: s["recording"].update(complete=False, problems=["12 messages dropped"]),
            ExitCode.RECORDING_INCOMPLETE,
            "12 messages dropped",
        ),
        (lambda s: s["run"].update(truncated=True), ExitCode.RECORDING_INCOMPLETE, "truncated"),
        (
            lambda s: s["run"].update(statistics_ok=False),
            ExitCode.RECORDING_INCOMPLETE,
            "statistics",
        ),
        (
            lambda s: s["timing"].update(safe_state_cycles=950, safe_state=1),
            ExitCode.SAFE_STATE,
            "950 cycles (95.0 % of the run)",
        ),
        (  # left the safe state again before the end: still entered
            lambda s: s["timing"].update(safe_state_cycles=3, safe_state=0),
            ExitCode.SAFE_STATE,
            "safe state",
        ),
        (  # a crashed run's summary has the state from its cycles, no count
            lambda s: s["timing"].update(safe_state=1, safe_state_cycles=None),
            ExitCode.SAFE_STATE,
            "safe state",
        ),
        (
            lambda s: s["controller"].update(safe_mode_entries=2),
            ExitCode.SAFE_STATE,
            "safe mode 2 time(s)",
        ),
        (
            lambda s: s["timing"].update(deadline_misses=11),
            ExitCode.DEADLINE_MISSES,
            "11 missed deadlines in 1000 cycles (1.10 %), over the 1 % tolerated",
        ),
    ],
)
def test_each_condition_alone(change: Any, code: ExitCode, said: str) -> None:
    summary = _healthy()
    change(summary)
    got, reasons = run_outcome(summary)
    assert got == code
    assert len(reasons) == 1 and said in reasons[0], reasons


def test_precedence_first_code_and_every_reason_in_order() -> None:
    summary = _healthy()
    summary["timing"].update(deadline_misses=500, safe_state_cycles=400)
    summary["recording"].update(complete=False)
    summary["run"].update(aborted=True, abort_signal="SIGINT")
    code, reasons = run_outcome(summary)
    assert code == ExitCode.ABORTED
    assert [r.split()[0] for r in reasons] == ["aborted", "the", "the", "500"]
    assert "recording" in reasons[1] and "safe state" in reasons[2]
    summary["run"]["aborted"] = False
    assert run_outcome(summary)[0] == ExitCode.RECORDING_INCOMPLETE
    summary["recording"]["complete"] = True
    assert run_outcome(summary)[0] == ExitCode.SAFE_STATE  # before deadline misses
    summary["timing"]["safe_state_cycles"] = 0
    assert run_outcome(summary)[0] == ExitCode.DEADLINE_MISSES
    summary["run"]["failed"] = "controller exited with 1"
    assert run_outcome(summary)[0] == ExitCode.FAILED  # over everything


def test_a_report_missing_because_a_fault_killed_its_node_is_not_a_recording_gap() -> None:
    """A SIGKILLed controller publishes no report: that alone does not make the recording
    incomplete; a gap in a topic, or the report of a node nobody killed, still does."""
    missing = "no controller report (controller/report): what the controller published is unknown"
    summary = _healthy()
    summary["recording"] = {"complete": False, "problems": [missing]}
    assert run_outcome(summary)[0] == ExitCode.RECORDING_INCOMPLETE  # nobody killed it
    summary["run"]["process_faults"] = [{"kind": "controller_kill", "killed": {"pid": 1}}]
    assert run_outcome(summary) == (ExitCode.OK, [])
    summary["recording"]["problems"] = [missing, "truth: 990 of 1000 recorded"]
    code, reasons = run_outcome(summary)
    assert code == ExitCode.RECORDING_INCOMPLETE and "truth: 990" in reasons[0]
    assert missing not in reasons[0]
    # A plant kill excuses the plant's final summary and report, not the controller's.
    summary["run"]["process_faults"] = [{"kind": "plant_kill", "killed": {"pid": 2}}]
    summary["recording"]["problems"] = [
        "no final timing summary: the plant did not finish the run (killed?)",
        "no plant report (timing/report): what the plant published is unknown",
    ]
    assert run_outcome(summary) == (ExitCode.OK, [])
    summary["recording"]["problems"].append(missing)
    assert run_outcome(summary)[0] == ExitCode.RECORDING_INCOMPLETE


def test_deadline_miss_tolerance_from_scenario_else_mode() -> None:
    summary = _healthy("realtime")
    summary["timing"]["deadline_misses"] = 10  # exactly 1 %: tolerated in real time
    assert deadline_miss_tolerance(summary) == DEFAULT_MAX_DEADLINE_MISS_FRACTION["realtime"]
    assert run_outcome(summary)[0] == ExitCode.OK
    for mode in ("lockstep", "inprocess"):
        summary["run"]["mode"] = mode
        assert deadline_miss_tolerance(summary) == 0.0
        assert run_outcome(summary)[0] == ExitCode.DEADLINE_MISSES
    summary["scenario"]["config"]["timing"]["max_deadline_miss_fraction"] = 0.05
    assert run_outcome(summary)[0] == ExitCode.OK
    summary["scenario"]["config"]["timing"]["max_deadline_miss_fraction"] = 0.0
    summary["run"]["mode"] = "realtime"
    code, reasons = run_outcome(summary)
    assert code == ExitCode.DEADLINE_MISSES and "over the 0 % tolerated" in reasons[0]


def test_a_short_run_fails_on_misses_only_over_the_count_and_the_fraction() -> None:
    """A 60-cycle real-time run (a Hexicon minute): one miss is 1.67 % of it, over the
    fraction but not over the count tolerated; two are over both. A long run is judged by
    the fraction (the count is passed at once), and the scenario sets either key."""
    summary = _healthy("realtime")
    summary["timing"].update(cycles=60, deadline_misses=1)
    assert deadline_miss_count_tolerance(summary) == DEFAULT_MAX_DEADLINE_MISSES["realtime"] == 1
    assert run_outcome(summary) == (ExitCode.OK, [])
    summary["timing"]["deadline_misses"] = 2
    code, reasons = run_outcome(summary)
    assert code == ExitCode.DEADLINE_MISSES
    assert "2 missed deadlines in 60 cycles (3.33 %)" in reasons[0]
    assert "more than the 1 tolerated (timing.max_deadline_misses)" in reasons[0]
    summary["scenario"]["config"]["timing"]["max_deadline_misses"] = 2
    assert run_outcome(summary)[0] == ExitCode.OK
    summary["timing"].update(cycles=6000, deadline_misses=60)  # 1 %: within the fraction
    assert run_outcome(summary)[0] == ExitCode.OK
    summary["timing"]["deadline_misses"] = 61
    assert run_outcome(summary)[0] == ExitCode.DEADLINE_MISSES
    # lock-step and in process: any miss (both defaults 0)
    summary = _healthy("lockstep")
    summary["timing"].update(cycles=60, deadline_misses=1)
    assert deadline_miss_count_tolerance(summary) == 0
    assert run_outcome(summary)[0] == ExitCode.DEADLINE_MISSES
    # both keys 0 in real time: any miss fails the run
    summary = _healthy("realtime")
    summary["timing"].update(cycles=60, deadline_misses=1)
    summary["scenario"]["config"]["timing"].update(
        max_deadline_misses=0, max_deadline_miss_fraction=0.0
    )
    assert run_outcome(summary)[0] == ExitCode.DEADLINE_MISSES


def test_max_deadline_misses_is_a_validated_timing_key() -> None:
    text = BASE + "\n[timing]\nmax_deadline_misses = 3\n"
    assert parse_scenario(text).timing.max_deadline_misses == 3
    assert load_scenario("nrel5mw-ramp").timing.max_deadline_misses is None
    for bad in ("-1", "1.5", '"3"'):
        with pytest.raises(ScenarioError, match="max_deadline_misses"):
            parse_scenario(BASE + f"\n[timing]\nmax_deadline_misses = {bad}\n")


def test_record_outcome_writes_the_verdict_into_the_summary() -> None:
    summary = _healthy()
    summary["timing"]["safe_state_cycles"] = 5
    assert record_outcome(summary) == ExitCode.SAFE_STATE
    assert summary["run"]["outcome"] == "safe_state"
    assert summary["run"]["exit_code"] == 5
    assert summary["run"]["outcome_reasons"] == run_outcome(summary)[1]
    line = outcome_line(ExitCode.SAFE_STATE, summary["run"]["outcome_reasons"])
    assert line.startswith("outcome: safe_state (exit 5): the plant") and "\n" not in line
    assert outcome_line(ExitCode.OK, []) == "outcome: ok (exit 0)"


# --------------------------------------------------------------------------- the scenario key


def test_max_deadline_miss_fraction_is_a_validated_timing_key() -> None:
    text = BASE
    sc = parse_scenario(text + "\n[timing]\nmax_deadline_miss_fraction = 0.002\n")
    assert sc.timing.max_deadline_miss_fraction == 0.002
    assert load_scenario("nrel5mw-ramp").timing.max_deadline_miss_fraction is None
    for bad in ("1.5", "-0.1", "nan", '"a lot"'):
        with pytest.raises(ScenarioError, match="max_deadline_miss_fraction"):
            parse_scenario(text + f"\n[timing]\nmax_deadline_miss_fraction = {bad}\n")


def test_a_duration_under_one_control_period_is_refused() -> None:
    sc = load_scenario("default")  # T = 25 ms
    with pytest.raises(ScenarioError, match="shorter than one control period"):
        sc.with_duration(0.01)
    assert sc.with_duration(0.025).cycles == 1
    with pytest.raises(ScenarioError, match=r"duration_s = 0\.001 s is shorter"):
        parse_scenario(
            scenario_text("default")[0].replace("duration_s = 60.0", "duration_s = 1e-3")
        )


# --------------------------------------------------------------------------- the CLI


_fowt = functools.partial(fowt, timeout=300.0, columns=200)


def _one_error_line(proc: subprocess.CompletedProcess[str]) -> str:
    """The stderr of ``proc``: exactly one line, ``error: ...``, and no traceback."""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert "Traceback" not in proc.stdout + proc.stderr
    return lines[0]


def _our_processes(marker: str) -> list[str]:
    """Command lines of live processes that mention ``marker`` (an output folder)."""
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        with contextlib.suppress(OSError):
            cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            if marker in cmd:
                found.append(f"{d.name}: {cmd}")
    return found


def test_too_short_duration_exits_2_with_one_line_before_anything(tmp_path: Path) -> None:
    out = tmp_path / "run"
    proc = _fowt("run", "default", "--mode", "inprocess", "--duration", "1e-9", "--out", str(out))
    assert proc.returncode == ExitCode.USAGE, proc.stdout + proc.stderr
    line = _one_error_line(proc)
    assert "shorter than one control period" in line and "0.025 s" in line
    assert not out.exists()


def test_bad_scenario_key_exits_2_and_keeps_brackets(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(BASE + "\n[timing]\nmax_deadline_miss_fraction = 2\n")
    proc = _fowt("run", str(path), "--mode", "inprocess", "--out", str(tmp_path / "run"))
    assert proc.returncode == ExitCode.USAGE
    assert "max_deadline_miss_fraction" in _one_error_line(proc)


@pytest.mark.e2e
def test_controller_killed_for_good_exits_with_the_safe_state_code(tmp_path: Path) -> None:
    """Real time: the controller SIGKILLed at 1 s and never restarted; the plant's watchdog
    latches the safe state for the rest of the run."""
    text = scenario_text("default")[0].replace("duration_s = 60.0", "duration_s = 3.0")
    scenario = tmp_path / "controller-kill.toml"
    scenario.write_text(text + '\n[[faults]]\nkind = "controller_kill"\nstart_s = 1.0\n')
    out = tmp_path / "run"
    proc = _fowt("run", str(scenario), "--out", str(out), "--no-plots")
    assert proc.returncode == ExitCode.SAFE_STATE, proc.stdout + proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    run = summary["run"]
    assert run["outcome"] == "safe_state" and run["exit_code"] == ExitCode.SAFE_STATE
    assert summary["timing"]["safe_state_cycles"] > 0
    assert any("safe state" in r for r in run["outcome_reasons"])
    assert "outcome: safe_state (exit 5)" in proc.stdout.strip().splitlines()[-1]
    # The review of the file alone gives the same verdict with --strict, 0 without.
    review = _fowt("review", str(out / "run.mcap"), "--no-plots", "--out", str(tmp_path / "rv"))
    assert review.returncode == 0, review.stderr
    strict = _fowt("review", str(out / "run.mcap"), "--strict", "--no-plots", "--json")
    assert strict.returncode == ExitCode.SAFE_STATE, strict.stderr
    assert "safe_state" in _one_error_line(strict)


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A 300 KiB tmpfs: the run's file fills it within seconds."""
    mnt = tmp_path / "disk"
    mnt.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", str(mnt)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here: {done.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


@pytest.mark.e2e
@pytest.mark.parametrize("mode", ["inprocess", "lockstep"])
def test_disk_full_is_one_line_exit_1_and_a_readable_file(small_disk: Path, mode: str) -> None:
    """In process the log writer child, in lock-step the recorder process runs out of space."""
    out = small_disk / "run"
    proc = _fowt("run", "default", "--mode", mode, "--duration", "600", "--out", str(out))
    assert proc.returncode == ExitCode.FAILED, proc.stdout + proc.stderr
    line = _one_error_line(proc)
    assert "No space left on device" in line and str(out / "run.mcap") in line, line
    assert not _our_processes(str(out)), "a process of the run outlived it"
    run = read_run(out / "run.mcap")  # readable up to the failure, as a truncated file
    assert run.truncated
    cycles = run.topic("timing/cycle")
    assert len(cycles) > 100
    assert [c["seq"] for c in cycles] == list(range(len(cycles)))  # no hole before the cut


def test_out_in_a_read_only_file_system_exits_2(tmp_path: Path) -> None:
    mnt = tmp_path / "ro"
    mnt.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(mnt)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a read-only tmpfs here: {done.stderr.strip()}")
    try:
        proc = _fowt("run", "nrel5mw-ramp", "--mode", "inprocess", "--out", str(mnt / "run"))
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)
    assert proc.returncode == ExitCode.USAGE, proc.stdout + proc.stderr
    assert "Read-only file system" in _one_error_line(proc)


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["review", "{d}/no [such] file.mcap"], "no [such] file.mcap is not a file"),
        (["review", "{d}/not-mcap [x].mcap"], "not-mcap [x].mcap is not an MCAP file"),
        (["recover", "{d}/not-mcap [x].mcap"], "not-mcap [x].mcap is not an MCAP file"),
        (["report", "{d}/not-mcap [x].mcap"], "not-mcap [x].mcap is not an MCAP file"),
        (["compare", "{d}/not-mcap [x].mcap"], "give at least two MCAP files"),
        (["campaign", "{d}/[no]-campaign.toml"], "[no]-campaign.toml does not exist"),
    ],
)
def test_errors_of_other_commands_are_one_stderr_line_with_brackets(
    args: list[str], said: str, tmp_path: Path
) -> None:
    (tmp_path / "not-mcap [x].mcap").write_text("hello [bold]world[/bold]\n")
    proc = _fowt(*(a.format(d=tmp_path) for a in args), "--out", str(tmp_path / "o"))
    assert proc.returncode == ExitCode.USAGE, proc.stdout + proc.stderr
    assert said in _one_error_line(proc)  # rich markup would have eaten the brackets
    assert proc.stdout.strip() == ""


def test_a_healthy_run_exits_0_and_prints_paths_with_brackets(tmp_path: Path) -> None:
    out = tmp_path / "run [b] x"
    proc = _fowt(
        "run",
        "nrel5mw-ramp",
        "--mode",
        "inprocess",
        "--duration",
        "1",
        "--out",
        str(out),
        "--no-plots",
    )
    assert proc.returncode == ExitCode.OK, proc.stdout + proc.stderr
    assert f"summary: {out / 'summary.json'}" in proc.stdout  # rich markup kept "[b]"
    assert proc.stdout.strip().splitlines()[-1] == "outcome: ok (exit 0)"
    run = json.loads((out / "summary.json").read_text())["run"]
    assert (run["outcome"], run["exit_code"], run["outcome_reasons"]) == ("ok", 0, [])
    assert run["aborted"] is False
