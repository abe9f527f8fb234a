"""The outcome of a run, and the exit code of ``fowt run`` and ``fowt review --strict``.

One pure function, :func:`run_outcome`, judges a run from its summary (the dict of
:func:`hil.review.core.review`, as in ``summary.json``), so the launcher and the review of a file
give the same verdict. The codes (docs/exit-codes.md):

* 0 ``ok``: the run completed, healthy and fully recorded;
* 1 ``failed``: a process of the run failed, or writing failed (disk full);
* 2 ``usage``: bad input, refused before anything started;
* 3 ``aborted``: stopped by SIGINT, SIGTERM or SIGHUP (the summary written says so);
* 4 ``recording_incomplete``: the recording lost messages, or the file is truncated;
* 5 ``safe_state``: the plant entered its safe state, or the controller its safe mode, at
  any time; except under ``timing.watchdog_policy = "recover"``, where a safe state (safe
  mode) that was left before the end does not count by itself when the missed deadlines
  are within the tolerance (:func:`recovered_watchdog_tolerated`);
* 6 ``deadline_misses``: more missed deadlines than ``timing.max_deadline_misses`` and
  than ``timing.max_deadline_miss_fraction`` of the cycles (:func:`deadline_misses_over`);
* 7 ``controller_fault``: the controller's core raised, or returned a non-finite or
  out-of-range command (:mod:`hil.nodes.controller_fault`), its estimator diverged, or its
  step took longer than the control period in more than :data:`OVERRUN_FRACTION` of its
  cycles (:func:`controller_overrun`): the same code in every mode, whatever the plant did
  about it (a safe state in real time, waiting in lock-step and in process).

When several apply, the first in :data:`PRECEDENCE` wins: failed, usage, aborted,
controller fault, recording incomplete, safe state, deadline misses. A failure or an abort
makes the rest of the verdict moot; a controller fault is the controller's own account of
what went wrong and usually causes the rest (the plant's safe state, misses, a shortened
recording), so it is the more telling verdict; a recording that is not whole cannot vouch
for the figures the last two are judged on; and missed deadlines are how a safe state is
usually reached, so the safe state is the more telling of the two. Every condition that
applies is listed in the reasons, in that order.
"""

from __future__ import annotations

import enum
import math
from typing import Any

from hil.nodes.controller_fault import fault_line
from hil.scenario.schema import watchdog_rule

__all__ = [
    "DEFAULT_MAX_DEADLINE_MISSES",
    "DEFAULT_MAX_DEADLINE_MISS_FRACTION",
    "PRECEDENCE",
    "ExitCode",
    "deadline_miss_count_tolerance",
    "deadline_miss_tolerance",
    "deadline_misses_over",
    "outcome_line",
    "record_outcome",
    "recovered_watchdog_tolerated",
    "run_outcome",
]


class ExitCode(enum.IntEnum):
    """Exit codes of ``fowt run`` (and ``fowt review --strict``); precedence:
    :data:`PRECEDENCE`."""

    OK = 0
    FAILED = 1
    USAGE = 2
    ABORTED = 3
    RECORDING_INCOMPLETE = 4
    SAFE_STATE = 5
    DEADLINE_MISSES = 6
    CONTROLLER_FAULT = 7

    @property
    def word(self) -> str:
        """The outcome as one word (``summary["run"]["outcome"]``), e.g. ``safe_state``."""
        return self.name.lower()


#: The order in which the verdicts win when several apply (module docstring).
PRECEDENCE: tuple[ExitCode, ...] = (
    ExitCode.FAILED,
    ExitCode.USAGE,
    ExitCode.ABORTED,
    ExitCode.CONTROLLER_FAULT,
    ExitCode.RECORDING_INCOMPLETE,
    ExitCode.SAFE_STATE,
    ExitCode.DEADLINE_MISSES,
)
_RANK = {code: i for i, code in enumerate(PRECEDENCE)}

#: The fraction of a controller's steps that may take longer than the control period
#: before the run is judged on it (:func:`controller_overrun`): a busy host stretches a few
#: steps (2.9 % of a ROSCO run's 10 ms steps in process at load average 14 on 2 cores), a
#: core slower than its period most of them.
OVERRUN_FRACTION = 0.25

#: Missed deadlines tolerated, as a fraction of the run's cycles, when the scenario's
#: ``timing.max_deadline_miss_fraction`` is not set. A lock-step or in-process plant waits
#: for every command, so any miss there is a fault; a real-time run shares the host with
#: everything else, and one cycle in a hundred (a few at a time, under the watchdog's
#: ``timing.watchdog_misses``) is what a loaded 2-core bench may see without the loop
#: being at fault.
DEFAULT_MAX_DEADLINE_MISS_FRACTION: dict[str, float] = {
    "realtime": 0.01,
    "lockstep": 0.0,
    "inprocess": 0.0,
}


#: Missed deadlines tolerated as a count, when the scenario's ``timing.max_deadline_misses`` is
#: not set: a run fails on its misses only when they are over both this and the fraction
#: above, so one miss in a real-time run shorter than 100 cycles (a Hexicon run's 1 s
#: period: 60 cycles a minute) does not fail it; in lock-step and in process none.
DEFAULT_MAX_DEADLINE_MISSES: dict[str, int] = {"realtime": 1, "lockstep": 0, "inprocess": 0}


def _dict(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}


def _number(value: Any) -> float | None:
    """``value`` as a finite float, or None (missing, null, not a number)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


def deadline_miss_tolerance(summary: dict[str, Any]) -> float:
    """The fraction of cycles allowed to miss their deadline in this run.

    The scenario's ``timing.max_deadline_miss_fraction`` (from the recorded scenario), else
    :data:`DEFAULT_MAX_DEADLINE_MISS_FRACTION` for the run's mode (real time for a run whose
    mode is not recorded: the most tolerant, so an old file is not failed for want of it).
    """
    config = _dict(_dict(summary.get("scenario")).get("config"))
    given = _number(_dict(config.get("timing")).get("max_deadline_miss_fraction"))
    if given is not None:
        return given
    mode = str(_dict(summary.get("run")).get("mode", "realtime"))
    return DEFAULT_MAX_DEADLINE_MISS_FRACTION.get(
        mode, DEFAULT_MAX_DEADLINE_MISS_FRACTION["realtime"]
    )


def deadline_miss_count_tolerance(summary: dict[str, Any]) -> int:
    """The missed deadlines tolerated as a count in this run: the scenario's
    ``timing.max_deadline_misses``, else :data:`DEFAULT_MAX_DEADLINE_MISSES` for the run's
    mode (as :func:`deadline_miss_tolerance`)."""
    config = _dict(_dict(summary.get("scenario")).get("config"))
    given = _number(_dict(config.get("timing")).get("max_deadline_misses"))
    if given is not None:
        return int(given)
    mode = str(_dict(summary.get("run")).get("mode", "realtime"))
    return DEFAULT_MAX_DEADLINE_MISSES.get(mode, DEFAULT_MAX_DEADLINE_MISSES["realtime"])


def deadline_misses_over(summary: dict[str, Any]) -> str | None:
    """Why the run's missed deadlines fail it, or None when they are tolerated.

    They fail it when they are more than the count tolerated
    (:func:`deadline_miss_count_tolerance`) and more than the fraction of the cycles
    tolerated (:func:`deadline_miss_tolerance`).
    """
    timing = _dict(summary.get("timing"))
    misses = _number(timing.get("deadline_misses")) or 0.0
    if misses <= 0:
        return None
    cycles = _number(timing.get("cycles"))
    count = deadline_miss_count_tolerance(summary)
    tolerated = deadline_miss_tolerance(summary)
    fraction = misses / cycles if cycles else math.inf
    if misses <= count or fraction <= tolerated:
        return None
    return (
        f"{misses:.0f} missed deadlines in {cycles or 0:.0f} cycles ({100 * fraction:.2f} %), "
        f"over the {100 * tolerated:g} % tolerated (timing.max_deadline_miss_fraction) and "
        f"more than the {count} tolerated (timing.max_deadline_misses)"
    )


def run_outcome(summary: dict[str, Any]) -> tuple[ExitCode, list[str]]:
    """Judge a run from its summary: the exit code and why (module docstring).

    Parameters
    ----------
    summary : dict
        A run's summary (:func:`hil.review.core.review`, plus what the launcher adds under
        ``run``: ``aborted`` and ``abort_signal``, ``failed`` (why), and
        ``process_fault_problems``). Missing keys count as healthy: a summary from before
        a key existed is judged on what it has.

    Returns
    -------
    code : ExitCode
        The code of the first condition that applies, in precedence order; ``OK`` if none.
    reasons : list of str
        One sentence per condition that applies, in precedence order (empty when ``OK``).
    """
    found: list[tuple[ExitCode, str]] = []
    run = _dict(summary.get("run"))
    timing = _dict(summary.get("timing"))

    failed = run.get("failed")
    if failed:
        found.append((ExitCode.FAILED, str(failed)))
    for problem in run.get("process_fault_problems") or ():
        found.append((ExitCode.FAILED, f"process fault: {problem}"))

    controller = _dict(summary.get("controller"))
    fault = controller.get("fault")
    if isinstance(fault, dict) and fault.get("kind"):
        found.append((ExitCode.CONTROLLER_FAULT, fault_line(fault)))

    if run.get("aborted"):
        by = run.get("abort_signal") or "a signal"
        at = _number(run.get("aborted_at_s"))
        when = f" at {at:.2f} s simulated" if at is not None else ""
        found.append((ExitCode.ABORTED, f"aborted by {by}{when}"))

    recording = _dict(summary.get("recording"))
    if recording.get("complete", True) is False:
        problems = _recording_problems(recording, _killed_by_faults(run))
        if problems is None or problems:
            detail = f": {'; '.join(str(p) for p in problems)}" if problems else ""
            found.append((ExitCode.RECORDING_INCOMPLETE, f"the recording is incomplete{detail}"))
    if run.get("truncated"):
        error = f" ({run['error']})" if run.get("error") else ""
        found.append((ExitCode.RECORDING_INCOMPLETE, f"the MCAP file is truncated{error}"))
    elif run.get("statistics_ok") is False:
        found.append(
            (ExitCode.RECORDING_INCOMPLETE, "the MCAP file's statistics disagree with its messages")
        )

    cycles = _number(timing.get("cycles"))
    safe_cycles = _number(timing.get("safe_state_cycles")) or 0.0
    held = (_number(timing.get("safe_state")) or 0.0) > 0
    if (safe_cycles > 0 or held) and not recovered_watchdog_tolerated(summary, held):
        share = f" ({100 * safe_cycles / cycles:.1f} % of the run)" if cycles else ""
        count = f" for {safe_cycles:.0f} cycles{share}" if safe_cycles > 0 else ""
        found.append((ExitCode.SAFE_STATE, f"the plant entered its safe state{count}"))
    controller = _dict(summary.get("controller"))
    entries = _number(controller.get("safe_mode_entries")) or 0.0
    if entries > 0 and not recovered_watchdog_tolerated(
        summary, bool(controller.get("safe_mode_at_end"))
    ):
        found.append(
            (ExitCode.SAFE_STATE, f"the controller entered its safe mode {entries:.0f} time(s)")
        )

    # the controller's estimator diverged (its guard's count, ControllerStatus v3): a
    # controller fault, the run is not healthy whatever else it did
    est_faults = _number(_dict(summary.get("controller")).get("estimator_faults")) or 0.0
    if est_faults > 0:
        found.append(
            (
                ExitCode.CONTROLLER_FAULT,
                f"the controller's estimator diverged {est_faults:.0f} time(s) and it ran "
                "on its fallback (controller.estimator_faults)",
            )
        )

    over = deadline_misses_over(summary)
    if over is not None:
        found.append((ExitCode.DEADLINE_MISSES, over))

    overrun = controller_overrun(summary)
    if overrun is not None:  # a slow core: the controller's fault in every mode
        found.append((ExitCode.CONTROLLER_FAULT, overrun))

    if not found:
        return ExitCode.OK, []
    found.sort(key=lambda item: _RANK[item[0]])  # stable: within a code, the order above
    return found[0][0], [reason for _, reason in found]


def recovered_watchdog_tolerated(summary: dict[str, Any], held_at_end: bool) -> bool:
    """True when a watchdog's safe state (the plant's) or safe mode (the controller's) needs
    no verdict of its own: the recorded scenario's watchdog policy is ``"recover"``
    (:func:`hil.scenario.schema.watchdog_rule`), control was handed back before the end
    (``held_at_end`` False), and the missed deadlines are within the tolerance
    (:func:`deadline_misses_over` finds none over it). A trip is how a stall the tolerance
    allows shows itself under that policy; a run whose misses exceed it still gets the
    safe-state code, the more telling of the two. Under ``"latch"`` (or a safe state held
    to the end) it is never tolerated.
    """
    if held_at_end:
        return False
    config = _dict(_dict(summary.get("scenario")).get("config"))
    if watchdog_rule(_dict(config.get("timing"))) != "recover":
        return False
    timing = _dict(summary.get("timing"))
    cycles = _number(timing.get("cycles"))
    misses = _number(timing.get("deadline_misses")) or 0.0
    if misses <= 0:
        return True
    return bool(cycles) and deadline_misses_over(summary) is None


def controller_overrun(summary: dict[str, Any]) -> str | None:
    """``"controller exceeded its deadline in N of M cycles (p99 X ms)"`` when the core's
    step took longer than the control period in more than :data:`OVERRUN_FRACTION` of its
    cycles (``controller.overruns`` of ``controller.cycles_stepped``), else None.

    A step's compute time is wall-clock time, which a loaded host stretches in every mode
    (lock-step and in process too), so only a core slow in a good part of its cycles is
    judged on it: a slow core, not a busy host.
    """
    controller = _dict(summary.get("controller"))
    overruns = _number(controller.get("overruns")) or 0.0
    stepped = _number(controller.get("cycles_stepped")) or 0.0
    if overruns <= 0 or stepped <= 0 or overruns / stepped <= OVERRUN_FRACTION:
        return None
    p99 = _number(_dict(controller.get("compute_us")).get("p99"))
    detail = f" (p99 {p99 / 1e3:.1f} ms)" if p99 is not None else ""
    return f"controller exceeded its deadline in {overruns:.0f} of {stepped:.0f} cycles{detail}"


def record_outcome(summary: dict[str, Any]) -> ExitCode:
    """Judge the run and store the verdict in ``summary["run"]``: ``outcome`` (a word),
    ``exit_code`` and ``outcome_reasons``; return the code."""
    code, reasons = run_outcome(summary)
    run = summary.setdefault("run", {})
    run["outcome"] = code.word
    run["exit_code"] = int(code)
    run["outcome_reasons"] = reasons
    return code


def outcome_line(code: ExitCode, reasons: list[str]) -> str:
    """One line for the end of a run: ``outcome: safe_state (exit 5): <reasons>``."""
    text = f"outcome: {code.word} (exit {int(code)})"
    return f"{text}: {'; '.join(reasons)}" if reasons else text


#: Recording problems that a process killed on purpose (a scenario's process fault) causes by
#: itself: a SIGKILLed node publishes no end-of-run report, a killed plant no final summary.
_EXCUSED_BY_KILL: dict[str, tuple[str, ...]] = {
    "controller": ("no controller report",),
    "plant": ("no final timing summary", "no plant report"),
}


def _killed_by_faults(run: dict[str, Any]) -> set[str]:
    """The processes a scenario's process faults killed (``run.process_faults``)."""
    killed: set[str] = set()
    for rec in run.get("process_faults") or ():
        if isinstance(rec, dict) and rec.get("killed"):
            kind = str(rec.get("kind", ""))
            killed.add("plant" if kind == "plant_kill" else "controller")
    return killed


def _recording_problems(recording: dict[str, Any], killed: set[str]) -> list[str] | None:
    """The recording's problems less those a deliberate kill explains (None: none listed).

    A missing report of a process the scenario killed says nothing about the recorder: the
    process never published one. Every other problem (a gap in a topic, a missing report of
    a process that was not killed) still makes the recording incomplete.
    """
    problems = recording.get("problems")
    if not problems:
        return None
    excused = tuple(p for name in killed for p in _EXCUSED_BY_KILL.get(name, ()))
    return [str(p) for p in problems if not str(p).startswith(excused)]
