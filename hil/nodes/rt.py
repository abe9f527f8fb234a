"""Real-time scheduling for the bench's processes (``--realtime-priority``).

On the shared 2-vCPU machines the bench runs on, a node that is ready to run can wait
milliseconds for the CPU behind other processes; that is where the multi-millisecond latency
tails and the occasional missed deadline come from (DESIGN.md: Zenoh round trip p99.9 2.3 ms
plain, 0.76 ms with both processes under ``SCHED_FIFO`` even with two CPU hogs running).
Linux's ``SCHED_FIFO`` policy lets a process run ahead of every normal process; it needs
root or ``CAP_SYS_NICE`` (or an ``RLIMIT_RTPRIO`` grant).

The policy must be set before the Zenoh session is opened: threads inherit the policy of
the thread that creates them, so Zenoh's runtime threads (which receive the samples and
call the callbacks) are real-time only if they are created afterwards.

Hand-written because it is two standard-library calls (``os.sched_setscheduler``); the
kernel's real-time throttling (by default 95 % of each second) keeps a runaway real-time
process from locking the machine.
"""

from __future__ import annotations

import gc
import os

__all__ = [
    "MAX_PRIORITY",
    "STARTUP_GC_THRESHOLD",
    "RealtimeError",
    "freeze_heap",
    "set_realtime_priority",
    "startup_gc",
    "steady_gc",
]

#: Highest priority the bench asks for: well below the kernel's own threads (which use 50
#: and 99), so interrupts and migration threads keep running.
MAX_PRIORITY = 40


#: The collector's young-generation threshold while a command starts (:func:`startup_gc`).
STARTUP_GC_THRESHOLD = 100_000
#: The thresholds :func:`startup_gc` found (None: it has not run in this process).
_steady_threshold: tuple[int, int, int] | None = None


def startup_gc() -> None:
    """Collect rarely while the process starts; :func:`steady_gc` (or :func:`freeze_heap`)
    puts the collector back when its steady work begins.

    Start-up (imports, numba's typing tables and cached kernels, the plant's tables) makes
    hundreds of thousands of objects and almost no garbage. With the default young-generation
    threshold (700 allocations) the collector walks them again and again as they age:
    measured in ``fowt run iea15mw-lc2-lqri-ff --mode inprocess``, 295 young, 27 middle and
    2 full collections before the loop, 0.15 s of a 3.5 s command. With 100 000 it collects
    four times (0.06 s). Until :func:`steady_gc` the young generation holds at most that
    many objects, a few megabytes of unreclaimed cycles at worst. The loops a deadline
    paces put the default back (the plant and controller nodes through
    :func:`freeze_heap`, the in-process loop); the processes that only log, show or route
    (recorder, live view, router) keep the start-up's threshold, bounded as above.
    """
    global _steady_threshold  # noqa: PLW0603 - one process-wide setting, like gc's own
    if _steady_threshold is None:
        _steady_threshold = gc.get_threshold()
    gc.set_threshold(STARTUP_GC_THRESHOLD, *_steady_threshold[1:])


def steady_gc() -> None:
    """The collector's thresholds as :func:`startup_gc` found them (nothing if it did not
    run): short, frequent young collections, no pause a real-time cycle would notice."""
    if _steady_threshold is not None:
        gc.set_threshold(*_steady_threshold)


class RealtimeError(RuntimeError):
    """Real-time scheduling was asked for and cannot be granted, with the reason."""


def set_realtime_priority(priority: int) -> str:
    """Put the calling process under ``SCHED_FIFO`` at ``priority`` (1..MAX_PRIORITY).

    Parameters
    ----------
    priority : int
        ``SCHED_FIFO`` priority, 1 (lowest) to :data:`MAX_PRIORITY`; 0 leaves the process
        under the normal policy and returns ``"normal"``.

    Returns
    -------
    str
        A description of the policy now in force, for the node's log line.

    Raises
    ------
    RealtimeError
        If the priority is out of range, the platform has no ``SCHED_FIFO``, or the process
        may not use it (not root, no ``CAP_SYS_NICE``).
    """
    if isinstance(priority, bool) or not isinstance(priority, int):
        raise RealtimeError(f"realtime priority: expected an integer, got {priority!r}")
    if priority == 0:
        return "normal"
    if not 1 <= priority <= MAX_PRIORITY:
        raise RealtimeError(
            f"realtime priority {priority}: expected 1..{MAX_PRIORITY} (0 = normal scheduling)"
        )
    if not hasattr(os, "sched_setscheduler"):
        raise RealtimeError("realtime priority: this platform has no SCHED_FIFO (Linux only)")
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError as exc:
        raise RealtimeError(
            f"realtime priority {priority}: not permitted ({exc.strerror}); run as root, "
            "grant CAP_SYS_NICE, or raise RLIMIT_RTPRIO"
        ) from exc
    return f"SCHED_FIFO priority {priority}"


def freeze_heap() -> int:
    """Collect once, then move every object alive now out of the garbage collector's scans.

    A node's set-up leaves ~50 000-65 000 long-lived objects (numpy, scipy, cantools, the
    plant's tables); a full (generation 2) collection walks them all, which took 72 ms in
    the controller and 99 ms in the plant on the 2-core bench machine, and comes at moments
    the loop does not choose: a real-time cycle that meets one misses its deadline. After
    ``gc.freeze()`` the full collections only walk the objects made since (measured:
    0.002 ms), while the per-cycle garbage is still collected as before (the start-up's
    threshold put back, :func:`steady_gc`). Call it when the set-up is done, right before
    the control loop.

    Returns
    -------
    int
        The number of objects frozen.
    """
    gc.collect()
    gc.freeze()
    steady_gc()
    return gc.get_freeze_count()
