"""A drawing process started with the command, so matplotlib is imported while the run goes.

Importing matplotlib costs about half a second of one core and drawing the three figures
about as much again: in a default ``fowt run`` they were a third of the whole command.
:meth:`PlotWorker.start` forks, at the command's start, a child that imports the drawing
code (:mod:`hil.review.plots` and matplotlib's figure) on the core the start-up leaves free
(the model, the numba cache and the run itself take one) and then waits on a pipe. The
review gathers the plots' data in its own pass over the run log as before and hands it to
the child (:meth:`PlotWorker.draw`, one pickle of a few MB), which draws the three figures
(the time series itself, the other two in its own forked child: :func:`plots.write_plots`)
and answers with the files written or the exception the drawing raised, which the review
raises as it would have drawing itself (an ``OSError`` of a full disk stays one).

Why a hand-written fork and not :mod:`multiprocessing` or :mod:`concurrent.futures`: the
child must exist *before* the start-up does its work (a pool's worker is started at its
first task, and a ``spawn`` or ``forkserver`` worker starts a fresh interpreter that imports
the bench again: the cost this removes), it serves exactly one job, and it must never run
the parent's exit handlers or signal handlers (it leaves by ``os._exit``; it ignores SIGINT,
SIGTERM and SIGHUP, which the launcher handles by stopping the run, reviewing it and closing
the pipe: the child reads end-of-file and leaves). A parent that dies closes the pipe too. A
worker that ended without answering (killed from outside) raises :class:`PlotWorkerGoneError` and
the review draws in its own process. Its process name is ``fowt-plots``.

Nothing is forked where fork does not exist, on one core (nothing to overlap), or with
other Python threads running (a fork copies only the calling thread: a lock another thread
held would stay held in the child); :meth:`start` then returns None and the review draws in
its own process, as :func:`plots.write_plots` does anyway.
"""

from __future__ import annotations

import contextlib
import gc
import os
import pickle
import signal
import struct
import threading
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hil.review.plots import PlotData

__all__ = ["PlotWorker", "PlotWorkerGoneError"]

#: The worker's process name (``/proc/<pid>/comm``, what ``ps`` and ``top`` show): its command
#: line is its parent's, as a fork's is.
PROCESS_NAME = b"fowt-plots"


class PlotWorkerGoneError(RuntimeError):
    """The worker ended before answering (killed from outside): draw in this process."""


_LEN = struct.Struct("<Q")


class PlotWorker:
    """The forked drawing child of one command (module docstring); a context manager."""

    def __init__(self, pid: int, to_child: int, from_child: int) -> None:
        self._pid = pid
        self._to_child = to_child
        self._from_child = from_child
        self._closed = False
        self._sent = False  # a job was written (else close() kills the child at once)
        self._status: int | str = "not reaped"

    @classmethod
    def start(cls) -> PlotWorker | None:
        """Fork the child; None where that cannot help (module docstring)."""
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
        if not hasattr(os, "fork") or cores < 2 or threading.active_count() > 1:
            return None
        job_r, job_w = os.pipe()
        res_r, res_w = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child: never returns
            os.close(job_w)
            os.close(res_r)
            _serve(job_r, res_w)
        os.close(job_r)
        os.close(res_w)
        return cls(pid, job_w, res_r)

    def draw(self, data: PlotData, out_dir: Path) -> list[Path]:
        """Have the child draw ``data`` into ``out_dir``; the files written.

        Raises
        ------
        PlotWorkerGoneError
            When the child ended before answering (the caller draws itself).
        Exception
            What the drawing raised in the child, raised again here (an ``OSError`` of a
            full disk stays one).
        """
        if self._closed:
            raise RuntimeError("the plot worker was closed")
        blob = pickle.dumps((data, Path(out_dir)), protocol=pickle.HIGHEST_PROTOCOL)
        self._sent = True
        try:
            _write_all(self._to_child, _LEN.pack(len(blob)) + blob)
        except BrokenPipeError:
            reply = b""
        else:
            reply = _read_all(self._from_child)
        self.close()
        if reply.startswith(b"error\n"):
            raise pickle.loads(reply[6:])  # the drawing's own exception (an OSError: disk full)
        if not reply.startswith(b"ok\n"):
            raise PlotWorkerGoneError(f"the plot worker ended before answering ({self._status})")
        return [Path(p) for p in reply[3:].decode().splitlines()]

    def close(self) -> None:
        """Close the pipe and reap the child: it leaves at end-of-file, or at once (SIGKILL)
        when it was given nothing to draw (a run that failed first, a family whose plots are
        drawn elsewhere): its import is of no use then, and an error is not kept waiting."""
        if self._closed:
            return
        self._closed = True
        if not self._sent:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self._pid, signal.SIGKILL)
        os.close(self._to_child)
        os.close(self._from_child)
        _, status = os.waitpid(self._pid, 0)
        self._status = os.waitstatus_to_exitcode(status)

    def __enter__(self) -> PlotWorker:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def _serve(job_r: int, res_w: int) -> None:
    """The child's whole life: import, wait for one job, draw it, answer, leave."""
    code = 0
    try:
        # the launcher handles these (a terminal's Ctrl-C or hang-up reaches the whole
        # process group) and then still wants its plots; it closes the pipe when done, and a
        # launcher that dies closes it too: end-of-file is this child's only way out
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, signal.SIG_IGN)
        _name_process(PROCESS_NAME)
        import matplotlib.figure  # noqa: F401, PLC0415 - the cost moved off the critical path

        from hil.review import plots  # noqa: PLC0415

        # One job, then os._exit: what the imports made is never garbage and the drawing's
        # few cycles die with the process, so the collector has nothing to do here (its
        # passes over the imported modules cost the drawing tens of milliseconds).
        gc.disable()
        head = _read_exact(job_r, _LEN.size)
        if head is not None:
            blob = _read_exact(job_r, _LEN.unpack(head)[0])
            if blob is not None:
                data, out_dir = pickle.loads(blob)  # our own parent's pickle
                try:
                    files = plots.write_plots(data, out_dir)
                    _write_all(res_w, b"ok\n" + "\n".join(str(f) for f in files).encode())
                except Exception as exc:  # raised again in the parent, as it was here
                    _write_all(res_w, b"error\n" + _picklable(exc))
    except BaseException:  # the parent sees the exit status
        code = 1
    finally:
        os._exit(code)


def _name_process(name: bytes) -> None:
    """Set this process's name (Linux ``prctl(PR_SET_NAME)``; elsewhere nothing)."""
    with contextlib.suppress(Exception):  # a name is a courtesy: never fail the drawing
        import ctypes  # noqa: PLC0415

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(15, ctypes.c_char_p(name[:15]), 0, 0, 0)  # 15: PR_SET_NAME


def _picklable(exc: Exception) -> bytes:
    """``exc`` pickled; a RuntimeError with its text where it does not pickle."""
    try:
        blob = pickle.dumps(exc)
        pickle.loads(blob)  # some exceptions pickle but cannot be rebuilt
    except Exception:  # any failure: its text instead
        return pickle.dumps(RuntimeError(f"drawing the plots failed: {type(exc).__name__}: {exc}"))
    return blob


def _read_exact(fd: int, n: int) -> bytes | None:
    """``n`` bytes from ``fd``; None at end-of-file before them."""
    parts: list[bytes] = []
    left = n
    while left:
        chunk = os.read(fd, min(left, 1 << 20))
        if not chunk:
            return None
        parts.append(chunk)
        left -= len(chunk)
    return b"".join(parts)


def _read_all(fd: int) -> bytes:
    """Everything until end-of-file."""
    parts = []
    while chunk := os.read(fd, 65536):
        parts.append(chunk)
    return b"".join(parts)


def _write_all(fd: int, payload: bytes) -> None:
    """All of ``payload`` to ``fd``."""
    view = memoryview(payload)
    while view:
        view = view[os.write(fd, view) :]
