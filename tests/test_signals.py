"""SIGINT, SIGTERM and SIGHUP to a real ``fowt run`` (docs/exit-codes.md, "Signals").

The launcher is started as a subprocess on a 60 s scenario (real time, and lock-step over
Zenoh), a few simulated seconds in (the plant's log says it runs and its MCAP file grows)
its children are collected from ``/proc`` (their parent is the launcher) and the launcher
gets the signal. Then:

* it exits with the aborted code, and every child it had is gone;
* ``summary.json`` says ``run.aborted``, the signal and outcome ``aborted``, and the time
  reached is short of the run's length (the progress bar does not claim the whole run);
* the MCAP file is complete: ``mcap``'s reader reads it (summary, footer, every message)
  and ``fowt review`` reads it.

In process: SIGINT stops the loop, the file is closed complete and the summary says aborted.
A launcher killed with SIGKILL (no handler runs) still leaves no child: they get SIGTERM as
their parent dies, end their loop as on any stop and leave a complete file.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from _mcap_conformance import check_complete_mcap

from hil.review.outcome import ExitCode
from hil.review.plot_worker import PROCESS_NAME

ROOT = Path(__file__).resolve().parents[1]


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "200"}


def _children(pid: int) -> dict[int, str]:
    """Live processes whose parent is ``pid``: pid -> command line."""
    found = {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        with contextlib.suppress(OSError):
            stat = (d / "stat").read_text()
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
            if ppid == pid:
                found[int(d.name)] = (
                    (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
                )
    return found


def _kind(pid: int, cmd: str) -> str:
    """What a child of the launcher is: a node (``python -m hil <kind>``), the plot worker
    (process name ``fowt-plots``, :mod:`hil.review.plot_worker`), or its command line."""
    with contextlib.suppress(OSError):
        if Path(f"/proc/{pid}/comm").read_text().strip() == PROCESS_NAME.decode():
            return "plots"
    return cmd.split(" -m hil ")[1].split(maxsplit=1)[0] if " -m hil " in cmd else cmd


def _alive(pid: int) -> bool:
    """True while ``pid`` exists and is not a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def _wait_for(what: str, ready: object, proc: subprocess.Popen[str], limit_s: float) -> None:
    """Poll ``ready()`` until true; fail (with the launcher's output) if the launcher ends
    first or ``limit_s`` passes (a set-up limit, not an assertion on the timing)."""
    until = time.monotonic() + limit_s
    while not ready():  # type: ignore[operator]
        if proc.poll() is not None:
            out, err = proc.communicate()
            pytest.fail(f"fowt run ended ({proc.returncode}) before {what}:\n{out}\n{err}")
        if time.monotonic() > until:
            proc.kill()
            out, err = proc.communicate()
            pytest.fail(f"no {what} within {limit_s:g} s:\n{out}\n{err}")
        time.sleep(0.1)


def _start(args: list[str]) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "hil", "run", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
    )


def _check_aborted(
    out: Path, proc: subprocess.Popen[str], sig: signal.Signals, total_s: int
) -> dict[str, Any]:
    stdout, stderr = proc.communicate(timeout=240)
    assert proc.returncode == ExitCode.ABORTED, stdout[-3000:] + stderr[-3000:]
    assert "Traceback" not in stdout + stderr
    summary = json.loads((out / "summary.json").read_text())
    run = summary["run"]
    assert run["aborted"] is True and run["abort_signal"] == sig.name
    assert run["outcome"] == "aborted" and run["exit_code"] == ExitCode.ABORTED
    assert run["outcome_reasons"][0].startswith(f"aborted by {sig.name}")
    last = stdout.strip().splitlines()[-1]
    assert last.startswith("outcome: aborted (exit 3): aborted by " + sig.name), last
    # The bar shows how far the run got, not its whole length.
    bars = re.findall(rf"(\d+)/{total_s} s simulated", stdout)
    assert bars and int(bars[-1]) < total_s, stdout[-3000:]
    assert run["duration_s"] < total_s - 1
    # A complete file: the seeking and the streaming reader of the mcap package agree with
    # its statistics, and the review reads it.
    check_complete_mcap(out / "run.mcap", validate=False)
    assert run["truncated"] is False and run["statistics_ok"] is True
    review = subprocess.run(
        [sys.executable, "-m", "hil", "review", str(out / "run.mcap"), "--json", "--no-plots"],
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
        env=_env(),
    )
    assert review.returncode == 0, review.stderr
    assert json.loads(review.stdout)["timing"]["cycles"] > 0
    # The review wrote its summary over the launcher's and kept what only the launcher
    # knew; with --strict it exits with the run's code.
    again = json.loads((out / "summary.json").read_text())["run"]
    assert again["aborted"] is True and again["outcome"] == "aborted"
    strict = subprocess.run(
        [sys.executable, "-m", "hil", "review", str(out / "run.mcap"), "--strict", "--no-plots"],
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
        env=_env(),
    )
    assert strict.returncode == ExitCode.ABORTED, strict.stdout[-2000:] + strict.stderr
    assert strict.stderr.startswith("error: --strict: ") and "aborted by" in strict.stderr
    return summary


@pytest.mark.e2e
@pytest.mark.parametrize(
    ("mode", "sig"),
    [
        ("realtime", signal.SIGTERM),
        ("realtime", signal.SIGINT),
        ("lockstep", signal.SIGTERM),
        ("lockstep", signal.SIGHUP),  # the terminal went away
    ],
    ids=lambda v: v.name if isinstance(v, signal.Signals) else str(v),
)
def test_signal_stops_every_child_and_the_run_is_reviewed_as_aborted(
    tmp_path: Path, mode: str, sig: signal.Signals
) -> None:
    out = tmp_path / "run"
    # Lock-step runs faster than real time: a longer scenario keeps it going past the signal.
    total_s = 60 if mode == "realtime" else 600
    proc = _start(["default", "--mode", mode, "--duration", str(total_s), "--out", str(out)])
    plant_log = out / "logs" / "plant.log"
    mcap = out / "run.mcap"

    def running() -> bool:
        with contextlib.suppress(OSError):
            # ~24 kB of schemas and channels open the file; data beyond them: it grows
            return "plant running" in plant_log.read_text() and mcap.stat().st_size > 45_000
        return False

    _wait_for("the plant running and a file growing", running, proc, 180)
    children = _children(proc.pid)
    kinds = {_kind(pid, cmd) for pid, cmd in children.items()}
    # the nodes, and the plot worker (a fork of the launcher: its own process name)
    assert kinds == {"record", "controller", "plant", "plots"}, children
    proc.send_signal(sig)
    summary = _check_aborted(out, proc, sig, total_s)
    gone = {pid: cmd for pid, cmd in children.items() if _alive(pid)}
    assert not gone, f"children left running: {gone}"
    # The plant ended its loop on the launcher's SIGTERM, with its final summary.
    assert "aborted: stopped by signal" in plant_log.read_text()
    assert summary["timing"]["complete"] is True


@pytest.mark.e2e
def test_sigint_stops_an_inprocess_run_with_a_complete_file(tmp_path: Path) -> None:
    out = tmp_path / "run"
    # Steady wind (no turbulence box to build): a long run, at thousands of times real time.
    proc = _start(
        ["nrel5mw-steady-8", "--mode", "inprocess", "--duration", "200000", "--out", str(out)]
    )
    mcap = out / "run.mcap"

    def growing() -> bool:
        with contextlib.suppress(OSError):
            return mcap.stat().st_size > 200_000
        return False

    _wait_for("a growing file", growing, proc, 180)
    children = _children(proc.pid)  # the log writer (multiprocessing's spawn child)
    assert children
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=240)
    assert proc.returncode == ExitCode.ABORTED, stdout[-3000:] + stderr[-3000:]
    assert "Traceback" not in stdout + stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["run"]["aborted"] is True and summary["run"]["abort_signal"] == "SIGINT"
    assert summary["run"]["outcome"] == "aborted"
    assert 0 < summary["run"]["duration_s"] < 200000
    assert summary["timing"]["complete"] is True  # the plant's final summary was written
    check_complete_mcap(mcap, validate=False)
    gone = {pid: cmd for pid, cmd in children.items() if _alive(pid)}
    assert not gone, f"the log writer outlived the run: {gone}"


@pytest.mark.e2e
def test_a_killed_launcher_leaves_no_child_and_a_complete_file(tmp_path: Path) -> None:
    """SIGKILL, which no handler sees: the children's parent-death signal stops them."""
    out = tmp_path / "run"
    proc = _start(["default", "--duration", "60", "--out", str(out), "--no-plots"])
    plant_log = out / "logs" / "plant.log"

    def running() -> bool:
        with contextlib.suppress(OSError):
            return "plant running" in plant_log.read_text()
        return False

    _wait_for("the plant running", running, proc, 180)
    children = _children(proc.pid)
    assert len(children) == 3, children
    proc.kill()
    proc.communicate(timeout=60)

    def all_gone() -> bool:
        return not any(_alive(pid) for pid in children)

    until = time.monotonic() + 120  # a bound on the set-up, not a timing assertion
    while not all_gone() and time.monotonic() < until:
        time.sleep(0.1)
    assert all_gone(), {pid: cmd for pid, cmd in children.items() if _alive(pid)}
    assert "aborted: stopped by signal" in plant_log.read_text()
    check_complete_mcap(out / "run.mcap", validate=False)
