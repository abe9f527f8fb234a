"""A drawing process started with the command, so matplotlib is imported while the run goes.

Importing matplotlib costs about half a second of one core and drawing the three figures
about as much again: in a default ``fowt run`` they were a third of the whole command.
:meth:`PlotWorker.start` forks, at the command's start, a child that imports the drawing
code (:mod:`hil.review.plots` and matplotlib's figure) on the core the start-up leaves free
(the model, the numba cache and the run itself take one), says it is ready and waits on a
pipe for one job, which comes in one of two ways:

* **It reads the file too** (:meth:`PlotWorker.gather`, then :meth:`PlotWorker.finish`):
  when the child is ready by the time the review starts (a ``fowt run``: the run took
  longer than the import), the review hands it the run log's path and goes on with its own
  pass over the file for the summary, which then leaves the plots' fields out; the child
  gathers the plots' data (:func:`hil.review.plots.gather_file`) in a pass of its own on
  the other core at the same time, then waits for the summary (the KPI window and the
  latency percentiles drawn with the samples: nothing is written before it comes, so a file
  the review refuses gets no plots), and draws. The two passes overlap instead of following
  each other, and no gathered data is pickled across.
* **It is handed the data** (:meth:`PlotWorker.draw`): when the child is still importing
  (a ``fowt review`` of a file: the import is the longer), the review gathers the plots'
  data in its own pass as well and hands it over (one pickle of a few MB) when the summary
  is known, while the import goes on.

Either way the child draws the three figures (the time series itself, the other two in its
own forked child: :func:`plots.write_plots`) and answers with the files written or the
exception the drawing raised, which the review raises as it would have drawing itself (an
``OSError`` of a full disk stays one).

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
import select
import signal
import struct
import threading
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Mapping

    from hil.review.plots import PlotData

__all__ = ["PlotWorker", "PlotWorkerGoneError"]

#: The worker's process name (``/proc/<pid>/comm``, what ``ps`` and ``top`` show): its command
#: line is its parent's, as a fork's is.
PROCESS_NAME = b"fowt-plots"


class PlotWorkerGoneError(RuntimeError):
    """The worker ended before answering (killed from outside): draw in this process."""


_LEN = struct.Struct("<Q")
#: What the child writes once it has imported the drawing code (:meth:`PlotWorker.ready`).
_READY = b"R"


class PlotWorker:
    """The forked drawing child of one command (module docstring); a context manager."""

    def __init__(self, pid: int, to_child: int, from_child: int) -> None:
        self._pid = pid
        self._to_child = to_child
        self._from_child = from_child
        self._closed = False
        self._ready = False  # the child's ready byte was read
        self._sent = False  # a whole job was written (else close() kills the child at once)
        self._gathering = False  # the child was given a file to read (finish() follows)
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

    def ready(self) -> bool:
        """Whether the child has imported the drawing code (it said so), without waiting."""
        if not self._ready and not self._closed:
            waiting, _, _ = select.select([self._from_child], [], [], 0.0)
            if waiting and os.read(self._from_child, len(_READY)) == _READY:
                self._ready = True
        return self._ready

    def gather(self, mcap_path: Path, counts: Mapping[str, int]) -> bool:
        """Have the child read the plots' data from the complete run log ``mcap_path``
        (``counts``: messages per topic suffix, :func:`hil.review.plots.logged_counts`) while
        the caller reads it for the summary; :meth:`finish` follows. False when the child is
        gone (the caller gathers the data itself)."""
        if self._closed or self._sent or self._gathering:
            raise RuntimeError("the plot worker has its job already")
        try:
            _send(self._to_child, ("gather", Path(mcap_path), dict(counts)))
        except BrokenPipeError:
            return False
        self._gathering = True
        return True

    def finish(self, summary: Mapping[str, Any], out_dir: Path) -> list[Path]:
        """After :meth:`gather`: hand the child the run's summary and have it draw into
        ``out_dir``; the files written (raises as :meth:`draw` does)."""
        if not self._gathering:
            raise RuntimeError("the plot worker was given no file to read")
        return self._job(("summary", dict(summary), Path(out_dir)))

    def draw(self, data: PlotData, out_dir: Path) -> list[Path]:
        """Have the child draw ``data`` (gathered here) into ``out_dir``; the files written.

        Raises
        ------
        PlotWorkerGoneError
            When the child ended before answering (the caller draws itself).
        Exception
            What the drawing raised in the child, raised again here (an ``OSError`` of a
            full disk stays one).
        """
        if self._gathering:
            raise RuntimeError("the plot worker reads the file itself: finish() it")
        return self._job(("draw", data, Path(out_dir)))

    def _job(self, message: tuple[Any, ...]) -> list[Path]:
        """Send the job's last message, read the answer, close."""
        if self._closed:
            raise RuntimeError("the plot worker was closed")
        self._sent = True
        # a child that left: an answer it wrote before (an error) is still in the pipe
        with contextlib.suppress(BrokenPipeError):
            _send(self._to_child, message)
        reply = _read_all(self._from_child)
        if not self._ready and reply.startswith(_READY):
            reply = reply[len(_READY) :]
        self.close()
        if reply.startswith(b"error\n"):
            raise pickle.loads(reply[6:])  # the drawing's own exception (an OSError: disk full)
        if not reply.startswith(b"ok\n"):
            raise PlotWorkerGoneError(f"the plot worker ended before answering ({self._status})")
        return [Path(p) for p in reply[3:].decode().splitlines()]

    def close(self) -> None:
        """Close the pipe and reap the child: it leaves at end-of-file, or at once (SIGKILL)
        when it was given no whole job (a run that failed first, a file the review refused,
        a family whose plots are drawn elsewhere): its work is of no use then, and an error
        is not kept waiting."""
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
    """The child's whole life: import, say so, take one job, draw it, answer, leave."""
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
        _write_all(res_w, _READY)
        blank = plots.blank_figures()  # while the run goes (a job waits in the pipe)
        job = _job_of(_receive(job_r), job_r)
        if isinstance(job, Exception):
            _write_all(res_w, b"error\n" + _picklable(job))
        elif job is not None:
            data, out_dir = job
            try:
                files = plots.write_plots(data, out_dir, blank)
                _write_all(res_w, b"ok\n" + "\n".join(str(f) for f in files).encode())
            except Exception as exc:  # raised again in the parent, as it was here
                _write_all(res_w, b"error\n" + _picklable(exc))
    except BaseException:  # the parent sees the exit status
        code = 1
    finally:
        os._exit(code)


def _job_of(message: tuple[Any, ...] | None, job_r: int) -> Any:
    """The data to draw and the folder, from the parent's message(s); None: nothing to do
    (end-of-file: the parent stopped); an exception: reading the file failed (answered once
    the summary comes, as the drawing's own error would be)."""
    if message is None:
        return None
    if message[0] == "draw":
        return message[1], message[2]
    from hil.review import plots  # noqa: PLC0415 - imported by the child already (_serve)

    _, mcap_path, counts = message  # "gather": read the file now, draw once the summary comes
    try:
        data = plots.gather_file(mcap_path, counts)
    except Exception as exc:  # the parent raises it after its own pass
        failed: Exception | None = exc
    else:
        failed = None
    summary = _receive(job_r)
    if summary is None:  # the review refused the file or stopped: nothing is written
        return None
    if failed is not None:
        return failed
    data.finish(summary[1])
    return data, summary[2]


def _send(fd: int, message: tuple[Any, ...]) -> None:
    """One message: its length, then its pickle."""
    blob = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    _write_all(fd, _LEN.pack(len(blob)) + blob)


def _receive(fd: int) -> tuple[Any, ...] | None:
    """One message (:func:`_send`) from our own parent; None at end-of-file."""
    head = _read_exact(fd, _LEN.size)
    if head is None:
        return None
    blob = _read_exact(fd, _LEN.unpack(head)[0])
    return None if blob is None else pickle.loads(blob)  # our own parent's pickle


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
