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

__all__ = ["MAX_PRIORITY", "RealtimeError", "freeze_heap", "set_realtime_priority"]

#: Highest priority the bench asks for: well below the kernel's own threads (which use 50
#: and 99), so interrupts and migration threads keep running.
MAX_PRIORITY = 40


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
    0.002 ms), while the per-cycle garbage is still collected as before. Call it when the
    set-up is done, right before the control loop.

    Returns
    -------
    int
        The number of objects frozen.
    """
    gc.collect()
    gc.freeze()
    return gc.get_freeze_count()
