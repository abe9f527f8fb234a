"""SIGTERM and SIGINT handed to a node's callback from a thread, never run inside a handler.

A Python signal handler runs in the main thread between two bytecodes, wherever that thread
is. One that sets a :class:`threading.Event` takes the event's lock, so it deadlocks when
the main thread already holds that lock: inside ``Event.wait`` or ``Event.set``, or inside
the handler itself when a second signal comes while the first is being handled (a launcher
killed with SIGKILL sends its nodes SIGTERM as their parent-death signal, and its process
group may get another). Seen: a controller that never exited after its launcher was
killed, its main thread waiting on the lock its own interrupted handler held.

So the handler here does nothing; :func:`signal.set_wakeup_fd` makes the interpreter's C-level
handler write each signal's number to a pipe, and a thread of its own reads the pipe and
calls the node's callback in an ordinary thread context, where taking a lock is safe. The
main thread may be anywhere (even in a call into Zenoh that does not return to Python): the
callback still runs. One callback per process (the disposition of a signal is per process):
the latest :func:`on_stop_signals` replaces the earlier one.

Hand-written: the standard library offers the mechanism (``set_wakeup_fd``), not the
thread that turns it into a callback outside an event loop.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable, Iterable

__all__ = ["on_stop_signals"]

#: The signals a node stops on.
STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT)

_lock = threading.Lock()
_callback: list[Callable[[int], None]] = []  # the current callback (at most one)
_watched: set[int] = set()
_reader: list[int] = []  # the pipe's read end once the watcher runs


def _ignore(_signum: int, _frame: object) -> None:
    """The Python-level handler: nothing (the watcher thread does the work)."""


def _watch(fd: int) -> None:
    while True:
        try:
            data = os.read(fd, 64)
        except OSError:
            return
        if not data:
            return
        for signum in data:
            with _lock:
                callback = _callback[0] if _callback and signum in _watched else None
            if callback is not None:
                callback(signum)


def on_stop_signals(callback: Callable[[int], None], signals: Iterable[int] = STOP_SIGNALS) -> None:
    """Call ``callback(signum)`` from a watcher thread on each of ``signals``.

    Must be called from the main thread (as :func:`signal.signal`).
    """
    with _lock:
        _callback[:] = [callback]
        _watched.update(int(s) for s in signals)
        start = not _reader
        if start:
            r, w = os.pipe()
            os.set_blocking(w, False)  # the C handler must never block on a full pipe
            _reader.append(r)
    for s in signals:
        signal.signal(s, _ignore)
    if start:
        signal.set_wakeup_fd(w, warn_on_full_buffer=False)
        threading.Thread(target=_watch, args=(r,), name="stop-signals", daemon=True).start()
