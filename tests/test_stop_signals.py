"""Stop signals reach a node's callback from a thread (hil.nodes.signals), never inside a handler.

The case that hung a controller: a signal arriving while the main thread holds the lock of
the event the stop callback sets (inside ``Event.wait``/``Event.set``, or a first signal's
handler still setting it). Here the main thread of a child process holds that lock when it
signals itself, twice: a handler that set the event in the main thread would deadlock at
once; the callback must run once the lock is free, for each signal, and the child exit 0.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

from _helpers import REPO

CHILD = textwrap.dedent(
    """
    import os, signal, threading, time
    from hil.nodes.signals import on_stop_signals

    done = threading.Event()
    seen = []
    main = threading.main_thread()

    def on_signal(signum):
        assert threading.current_thread() is not main
        seen.append(signum)
        done.set()

    on_stop_signals(on_signal)
    with done._cond:  # the event's own lock, held by the main thread
        os.kill(os.getpid(), signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.3)  # a handler taking this lock here would never return
        assert not done.is_set()
    assert done.wait(30.0)
    deadline = time.monotonic() + 30.0
    while len(seen) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert sorted(seen) == [signal.SIGINT, signal.SIGTERM], seen
    print("ok")
    """
)


def _child(code: str) -> str:
    """What ``code`` printed, run in a fresh interpreter that must exit 0."""
    proc = subprocess.run(
        [sys.executable, "-c", code],
        check=False,
        capture_output=True,
        text=True,
        timeout=240,  # a bound on a hung child, not a timing assertion
        cwd=REPO,
        env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"},
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


def test_a_signal_while_the_main_thread_holds_the_events_lock_still_stops_the_node() -> None:
    assert _child(CHILD).strip() == "ok"


LAUNCHER = textwrap.dedent(
    """
    import os, signal, subprocess, sys, threading, time
    from hil.launch import AbortSignals

    before = signal.getsignal(signal.SIGTERM)
    lock = threading.Lock()
    with AbortSignals() as abort:
        assert not abort.is_set() and not abort.wait(0.05)
        with lock:  # whatever the main thread holds, the handler takes nothing
            os.kill(os.getpid(), signal.SIGTERM)
            os.kill(os.getpid(), signal.SIGINT)  # a second one, inside or after the first
            time.sleep(0.2)
        assert abort.is_set() and abort.signum == signal.SIGTERM, abort.signum  # the first
        assert abort.wait(30.0)
        try:
            abort.check(sim_s=1.5)
        except Exception as exc:
            print(type(exc).__name__)
    # a waiting launcher is woken by a signal from another process, not at its timeout
    with AbortSignals() as abort:
        subprocess.Popen([sys.executable, "-c",
            f"import os, time; time.sleep(0.5); os.kill({os.getpid()}, {int(signal.SIGINT)})"])
        t0 = time.monotonic()
        woke = abort.wait(600.0)
        print(woke, abort.signum == signal.SIGINT, time.monotonic() - t0 < 300.0)
    assert signal.getsignal(signal.SIGTERM) is before  # the previous handlers are back
    print("ok")
    """
)


def test_the_launchers_abort_signals_keep_the_first_and_wake_its_waits() -> None:
    """The launcher's :class:`hil.launch.AbortSignals`: two signals while the main thread
    holds a lock are both handled (the first one kept), ``wait`` returns at a signal from
    another process (not at its 600 s timeout), and the previous handlers come back."""
    assert _child(LAUNCHER).split() == ["RunAbortedError", "True", "True", "True", "ok"]
