"""A run log written by a child process, for the in-process mode (and a campaign's runs).

The simulation loop hands its messages over in one of two ways, freely mixed:

* :meth:`BackgroundRunLog.publish` (one Struct): the message goes into its type's list of
  the batch being filled and its message id into the batch's order (two list appends,
  about 0.15 us); the batch's Structs are encoded as msgpack in one msgspec call when it
  is sent (floats copied as 8 bytes, not formatted; 0.1 to 0.35 us a message);
* :meth:`BackgroundRunLog.publish_block` (many messages as rows of
  :attr:`bus_schemas.registry.MessageType.row_dtype`, e.g. several control cycles
  written by a compiled loop): the rows' bytes are appended to their type's buffer in the
  batch and the ids to its order with :data:`ROW_FLAG` set; no Struct and no Python work
  per message.

A full batch goes through a pipe to a child process, on the other core, that writes it
(:class:`_BatchFramer`): per message type, its Structs (msgpack decoded, turned into rows)
and its rows, in publish order, become one rows array, handed to
:meth:`hil.runlog.mcap_io.RunLog.write_rows`; the batch is then one Chunk
(:meth:`~hil.runlog.mcap_io.RunLog.flush`). The writer is the one every run uses
(:class:`hil.runlog.mcap_io.RunLog`): CDR payloads built column by column with numpy
(:func:`bus_schemas.ros2.encode_rows`), the 31-byte Message record headers with it, zstd
and the CRC of the chunk; nothing is compiled. The MCAP ``publish_time`` of a message is
its own ``publish_time_ns`` (the host's monotonic clock) moved to the unix epoch: in
process, publishing and logging are the same moment; ``log_time`` is the run's start plus
``sample_time_ns``. If the parent dies, the child sees the pipe close and finishes the
file, so nothing handed over is lost. The child's CPU a message: 0.78 us for a 600 s LC2
stream, zstd and CRC 0.34 us of it (bench/runlog_encoding.py; docs/recording.md).

Data in flight (what a SIGKILL of the run's process loses): a batch goes to the writer when
it holds :data:`BATCH_MESSAGES` messages, and whatever went into the pipe survives the
parent (the kernel keeps it for the child). A killed run therefore loses at most the batch
being filled: at most 1023 messages, about 200 control cycles of 5 messages (5 s of
simulated time at 40 Hz, 2 s at 100 Hz; at 1000x real time about 5 ms of wall time),
whether they came one by one or in blocks (a block is split at the batch's end, so every
batch holds exactly :data:`BATCH_MESSAGES`). The batch is cut by count only, so what
survives a kill does not depend on the machine's load.
The lock-step and real-time modes do not use this path: their recorder writes the same
:class:`~hil.runlog.mcap_io.RunLog` message by message and flushes a chunk every 0.15 s of wall
time (:mod:`hil.nodes.recorder`).

A ``soak`` recording level (scenario ``[recording]``; ``truth_every`` N > 1) drops, before
the batch, the truth of the cycles whose ``seq`` is not a multiple of N
(:func:`hil.runlog.completeness.truth_kept`, as the bus recorder does);
:meth:`MessageBatcher.published` still counts them (what the plant published, for its
report). Nothing here holds more than the batch being filled: the writer's memory does not
grow with the run (the file's chunk index aside, about 100 bytes a chunk).
"""

from __future__ import annotations

import abc
import contextlib
import fcntl
import multiprocessing
import multiprocessing.util
import os
import signal
import sys
import time
import typing
from collections.abc import Mapping
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

from bus_schemas.registry import MESSAGES, TRUTH, MessageType
from hil.runlog.completeness import truth_kept
from hil.runlog.mcap_io import RunLog

_BY_ID = {mt.message_id: mt for mt in MESSAGES}
_TRUTH_ID = TRUTH.message_id

#: Messages per batch (one MCAP chunk each); bench/inprocess_speed.py measured the choice.
BATCH_MESSAGES = 1024
#: Pipe buffer asked for (Linux F_SETPIPE_SZ; capped by /proc/sys/fs/pipe-max-size) [bytes]:
#: a few batches fit, so the loop does not wait whenever the writer is briefly descheduled.
PIPE_BYTES = 1 << 20


#: Bytes of the writer's last error text shared with the parent (:class:`LogWriteError`).
_ERROR_BYTES = 1024


class LogWriteError(RuntimeError):
    """The log writer could not write the file (disk full, file too large, I/O error).

    The message names the file and the system's reason; what the writer had written before
    stays in the file (it is readable up to the failure, as a truncated file).
    """


#: Set in a batch's order byte for a message given as a row (:meth:`publish_block`); the low
#: seven bits are its message id.
ROW_FLAG = 0x80

if any(not 0 <= mt.message_id < ROW_FLAG for mt in MESSAGES):  # one byte each, with ROW_FLAG
    raise ImportError("hil.runlog.writer: message ids must be 0..127 (one byte in a batch)")


def _loose_struct(mt: MessageType) -> type[msgspec.Struct]:
    """A Struct with ``mt``'s fields in order, without their constraints, for decoding.

    msgspec's decoders refuse the registry types' integer bounds beyond int64; this twin
    decodes the msgpack the parent wrote (a float field keeps an int it was given).
    """
    hints = typing.get_type_hints(mt.cls)
    fields = [(f, int if hints[f] is int else int | float) for f in mt.cls.__struct_fields__]
    return msgspec.defstruct(f"_Loose{mt.name}", fields, array_like=False)


def _decoders() -> dict[int, Any]:
    """Per message id: the decoder of a msgpack array of that message (one call a batch)."""
    return {
        mt.message_id: msgspec.msgpack.Decoder(list.__class_getitem__(_loose_struct(mt))).decode
        for mt in MESSAGES
    }


#: A batch on the pipe: the order (per message one byte: its message id, with
#: :data:`ROW_FLAG` set for a message given as a row), per message id the msgpack array of
#: its messages given as Structs, and per message id the bytes of its rows (``row_dtype``),
#: each in publish order.
_decode_batch = msgspec.msgpack.Decoder(
    tuple[bytes, dict[int, msgspec.Raw], dict[int, bytes]]
).decode
_encode_batch_payload = msgspec.msgpack.Encoder().encode


class _BatchFramer:
    """Writes the batches from the pipe to a :class:`~hil.runlog.mcap_io.RunLog`, one Chunk each.

    Per batch and message type: its rows (the bytes of ``row_dtype`` records) and its
    Structs (decoded from msgpack, each made a row) are put in publish order (the batch's
    order says which came as which) and queued with
    :meth:`~hil.runlog.mcap_io.RunLog.write_rows`, their publish times moved from the monotonic
    clock to the unix epoch by ``unix_minus_monotonic_ns``; then the chunk is written.
    A batch whose parts do not agree raises ``ValueError`` before anything of it is queued.
    """

    def __init__(
        self, log: RunLog, decoders: dict[int, Any], unix_minus_monotonic_ns: int = 0
    ) -> None:
        self.log = log
        self.decoders = decoders
        self.unix_minus_monotonic_ns = unix_minus_monotonic_ns

    def rows(self, blob: bytes | memoryview) -> list[tuple[int, np.ndarray]]:
        """A batch's messages as ``(channel id, rows in publish order)`` per message type."""
        ids_bytes, by_id, by_rows = _decode_batch(blob)
        flags = np.frombuffer(ids_bytes, np.uint8)
        per_flag = np.bincount(flags, minlength=256)
        out = []
        seen = 0
        for mid in sorted(set(by_id) | set(by_rows)):
            mt = _BY_ID.get(mid) if 0 <= mid < ROW_FLAG else None
            decode = self.decoders.get(mid)
            if mt is None or decode is None:
                raise ValueError(f"batch: unknown message id {mid}")
            dtype = mt.row_dtype
            raw = by_rows.get(mid, b"")
            if len(raw) % dtype.itemsize:
                raise ValueError(f"batch: rows of message id {mid} do not fit its type")
            block = np.frombuffer(raw, dtype)
            if len(block) != per_flag[mid | ROW_FLAG]:
                raise ValueError(f"batch: message id {mid} does not match its rows")
            msgs = decode(by_id[mid]) if mid in by_id else []
            if len(msgs) != per_flag[mid]:
                raise ValueError(f"batch: message id {mid} does not match its messages")
            if not msgs:
                rows = block
            else:
                structs = np.array([msgspec.structs.astuple(m) for m in msgs], dtype)
                if not len(block):
                    rows = structs
                else:  # both kinds: in publish order
                    kinds = flags[(flags & (ROW_FLAG - 1)) == mid]
                    rows = np.empty(len(kinds), dtype)
                    as_row = kinds >= ROW_FLAG
                    rows[as_row] = block
                    rows[~as_row] = structs
            seen += len(rows)
            cid = (
                int(self.log.channel_of_message_id[mid])
                if mid < len(self.log.channel_of_message_id)
                else 0
            )
            if not cid:
                raise ValueError(f"batch: message id {mid} has no channel")
            out.append((cid, rows))
        if seen != len(flags):
            raise ValueError(f"batch: {len(flags)} message ids for {seen} messages")
        return out

    def frame(self, blob: bytes | memoryview) -> None:
        """Write one batch from the pipe as a Chunk with its MessageIndexes."""
        shift = self.unix_minus_monotonic_ns
        for cid, rows in self.rows(blob):
            self.log.write_rows(cid, rows, rows["publish_time_ns"] + shift)
        self.log.flush()


#: A batch's length before its bytes on the pipe (0: the end).
_LENGTH_BYTES = 8


def _write_message(fd: int, payload: bytes) -> None:
    """Put one batch on the pipe: its length (8 bytes, little-endian), then its bytes, in
    one ``writev`` (the rest again after a partial write); read by :class:`_PipeReader`.
    The pipe's own framing instead of ``Connection.send_bytes``, whose reader copies each
    batch twice more (about 0.08 us of the writer's CPU a message)."""
    parts = [memoryview(len(payload).to_bytes(_LENGTH_BYTES, "little")), memoryview(payload)]
    while parts:
        n = os.writev(fd, parts)
        while parts and n >= len(parts[0]):
            n -= len(parts[0])
            parts.pop(0)
        if parts and n:
            parts[0] = parts[0][n:]


class _PipeReader:
    """Reads the batches :func:`_write_message` puts on a pipe into one reused buffer."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.head = bytearray(_LENGTH_BYTES)
        self.buf = bytearray(1 << 20)

    def _fill(self, view: memoryview) -> bool:
        got = 0
        while got < len(view):
            n = os.readv(self.fd, [view[got:]])
            if n == 0:
                return False
            got += n
        return True

    def read(self) -> memoryview | None:
        """The next batch (valid until the next call), or None at the end marker or when
        the pipe closes (the parent gone; a batch cut by it is dropped)."""
        if not self._fill(memoryview(self.head)):
            return None
        size = int.from_bytes(self.head, "little")
        if size == 0:
            return None
        if size > len(self.buf):
            self.buf = bytearray(size)  # a new one: views of the old may still be alive
        view = memoryview(self.buf)[:size]
        return view if self._fill(view) else None


def _writer_main(
    conn: Connection,
    path: str,
    turbine: str,
    metadata: dict[str, dict[str, str]],
    compression: str,
    ready: Any,
    unix_minus_monotonic_ns: int,
    stats: Any,
    error: Any = None,
) -> bool:
    """Write the file from the pipe's batches; False (the reason in ``error``) when a write
    failed: the writer then stops reading, so the parent's next batch finds the pipe closed."""

    def failed(exc: OSError) -> bool:
        if error is not None and not error.value:
            error.value = f"writing {path}: {exc.strerror or exc}".encode()[: _ERROR_BYTES - 1]
        return False

    try:
        log = RunLog(Path(path), turbine, compression=compression)
    except OSError as exc:
        return failed(exc)
    framer = _BatchFramer(log, _decoders(), unix_minus_monotonic_ns)
    cpu0 = time.process_time()
    pipe = _PipeReader(conn.fileno())
    ok = True
    try:
        for name, data in metadata.items():
            log.add_metadata(name, data)
        ready.set()
        while True:
            blob = pipe.read()
            if blob is None:  # the end, or the parent is gone
                break
            framer.frame(blob)
    except OSError as exc:
        ok = failed(exc)
    finally:
        try:
            log.close()
        except OSError as exc:  # the summary section and footer did not fit either
            ok = failed(exc)
        stats[0] = time.process_time() - cpu0
        stats[1] = log.count
    return ok


def _writer_process(*args: Any) -> None:
    """The writer child's target: :func:`_writer_main`, then an immediate exit.

    Once the file is finished (the summary section and footer written, the file closed)
    nothing is left to do, but the interpreter's teardown with numpy, zstandard and mcap loaded
    takes a while, which :meth:`BackgroundRunLog.close` would wait for (measured: the
    file done 0.3 ms after the end marker, the child gone 0.25-0.33 s later). ``os._exit``
    skips it. An exception in :func:`_writer_main` still ends the child the usual way (its
    traceback printed, exit code 1). A write that failed (:class:`LogWriteError`) is said
    by the parent, from the text left in the shared error buffer: exit code 1, no traceback.

    SIGINT is ignored: a terminal's Ctrl-C reaches the whole process group, and the parent
    decides how the run ends (it closes the pipe, and the file is finished).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    ok = _writer_main(*args)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0 if ok else 1)


#: bytes.translate table setting :data:`ROW_FLAG` (the ids are < ROW_FLAG once checked).
_FLAG_ROWS = bytes((b | ROW_FLAG) & 0xFF for b in range(256))


def _row_dtype_ok(mt: MessageType, block: np.ndarray) -> bool:
    """Whether ``block``'s dtype is ``mt``'s row dtype: the same object (``row_dtype`` is
    built once; views and arrays made with it keep it), else compared (a structured
    dtype's ``==`` takes ~3 us)."""
    dtype = block.dtype
    expected = mt.row_dtype
    return dtype is expected or bool(dtype == expected)


class MessageBatcher(abc.ABC):
    """The batch being filled: messages given one by one (:meth:`publish`) or as rows
    (:meth:`publish_block`), cut by count into batches of ``batch_messages``, each handed
    to :meth:`_send` as it fills (:meth:`_payload`: the batch's bytes, as the writer reads
    them). :class:`BackgroundRunLog` sends a batch through a pipe to its writer child; a
    campaign worker (a daemon process, which may not start children) frames it in its own
    process (:class:`hil.campaign.runner`'s run log).

    Parameters
    ----------
    batch_messages : int
        Messages per batch (module docstring).
    truth_every : int
        Keep the truth of one cycle in N (a ``soak`` recording; 1: every message).
    """

    def __init__(self, batch_messages: int = BATCH_MESSAGES, truth_every: int = 1) -> None:
        if batch_messages < 1:
            raise ValueError(f"batch_messages: expected an integer >= 1, got {batch_messages}")
        if truth_every < 1:
            raise ValueError(f"truth_every: expected an integer >= 1, got {truth_every}")
        self._batch_messages = batch_messages
        self.truth_every = truth_every
        #: Truth messages published and not recorded (a soak recording's decimation).
        self.decimated = 0
        # Messages per message id in the batches sent so far (counted per batch, from its
        # order, so publishing costs nothing more): published() adds the batch being filled.
        self._sent_counts = np.zeros(ROW_FLAG, np.int64)
        self._ids = bytearray()
        self._new_batch()

    @abc.abstractmethod
    def _send(self) -> None:
        """Hand the full (or, at the end, last) batch on and start a new one."""

    def _new_batch(self) -> None:
        # The batch being filled: the message ids in publish order and, per message id,
        # its messages given to publish (the Structs themselves; encoded when the batch is
        # sent) and the bytes of its rows given to publish_block. The batch before (sent,
        # or empty at the start) is counted first.
        if self._ids:
            self._sent_counts += self._id_counts(self._ids)
        self._ids = bytearray()
        self._by_id: dict[int, list[msgspec.Struct]] = {}
        self._rows: dict[int, bytearray] = {}

    @staticmethod
    def _id_counts(ids: bytearray) -> np.ndarray:
        flags = np.frombuffer(bytes(ids), np.uint8) & (ROW_FLAG - 1)
        return np.bincount(flags, minlength=ROW_FLAG).astype(np.int64)

    def published(self) -> dict[str, int]:
        """Messages handed to the log so far per key suffix (Structs and rows alike; a
        soak recording's decimated truth included: what was published, not recorded)."""
        counts = self._sent_counts + self._id_counts(self._ids)
        counts[TRUTH.message_id] += self.decimated
        return {mt.key_suffix: int(counts[mid]) for mid, mt in _BY_ID.items()}

    def publish(self, mt: MessageType, msg: msgspec.Struct) -> None:
        """Queue one message for the log (the simulation loop's only logging cost)."""
        mid = mt.message_id
        if (
            mid == _TRUTH_ID and self.truth_every > 1 and not truth_kept(msg.seq, self.truth_every)  # type: ignore[attr-defined]
        ):
            self.decimated += 1
            return
        ids = self._ids
        ids.append(mid)
        lst = self._by_id.get(mid)
        if lst is None:
            self._by_id[mid] = [msg]
        else:
            lst.append(msg)
        if len(ids) >= self._batch_messages:
            self._send()

    def publish_block(self, order: np.ndarray, rows: Mapping[int, np.ndarray]) -> None:
        """Queue many messages given as rows (:attr:`MessageType.row_dtype`) at once.

        Parameters
        ----------
        order : ndarray of uint8
            The block's message ids in publish order.
        rows : mapping of message id to structured ndarray
            Per message id, its messages in publish order as a 1-D array of that type's
            ``row_dtype``; as many rows as the id occurs in ``order``. The rows are used
            before this call returns (the caller may reuse its buffers).

        Raises
        ------
        ValueError
            If a message id is unknown, or the rows do not match ``order`` or the dtype.

        Notes
        -----
        The rows' bytes are appended to the batch being filled, per message id, and the ids
        to its order with :data:`ROW_FLAG` set (no Struct, no Python work per message); the
        writer encodes them as CDR payloads (:class:`_BatchFramer`). A block that
        does not fit the batch is split at the batch's end (batches are cut by count).
        """
        ids = np.asarray(order, np.uint8)
        if ids.ndim != 1:
            raise ValueError(f"publish_block: order must be 1-D, got shape {ids.shape}")
        if self.truth_every > 1 and _TRUTH_ID in rows:
            ids, rows = self._decimate(ids, rows)
        counts = np.bincount(ids, minlength=256)
        total = 0
        for mid, block in rows.items():
            mt = _BY_ID.get(mid)
            if mt is None:
                raise ValueError(f"publish_block: unknown message id {mid}")
            if not isinstance(block, np.ndarray) or block.ndim != 1 or not _row_dtype_ok(mt, block):
                raise ValueError(f"publish_block: {mt.name} rows must be 1-D {mt.row_dtype}")
            if len(block) != counts[mid]:
                raise ValueError(f"publish_block: {len(block)} {mt.name} rows for its ids")
            total += len(block)
        if total != len(ids):
            raise ValueError("publish_block: an id in order has no rows")
        if len(ids) <= self._batch_messages - len(self._ids):  # the block fits the batch
            self._ids += ids.tobytes().translate(_FLAG_ROWS)
            for mid, block in rows.items():
                buf = self._rows.get(mid)
                if buf is None:
                    self._rows[mid] = bytearray(block.tobytes())
                else:
                    buf += block.tobytes()
            if len(self._ids) >= self._batch_messages:
                self._send()
            return
        done = {mid: 0 for mid in rows}
        while len(ids):
            room = self._batch_messages - len(self._ids)
            part = ids if len(ids) <= room else ids[:room]  # a batch is cut by count
            self._ids += part.tobytes().translate(_FLAG_ROWS)
            whole = part is ids
            for mid, block in rows.items():
                a = done[mid]
                b = len(block) if whole else a + int(np.count_nonzero(part == mid))
                if b > a:
                    buf = self._rows.get(mid)
                    if buf is None:
                        self._rows[mid] = bytearray(block[a:b].tobytes())
                    else:
                        buf += block[a:b].tobytes()
                    done[mid] = b
            ids = ids[len(part) :]
            if len(self._ids) >= self._batch_messages:
                self._send()

    def _decimate(
        self, ids: np.ndarray, rows: Mapping[int, np.ndarray]
    ) -> tuple[np.ndarray, Mapping[int, np.ndarray]]:
        """A block without the truth rows a soak recording drops (and their ids in order)."""
        truth = rows[_TRUTH_ID]
        keep = truth_kept(truth["seq"], self.truth_every)
        assert isinstance(keep, np.ndarray)
        dropped = int(truth.size - np.count_nonzero(keep))
        if not dropped:
            return ids, rows
        at = np.flatnonzero(ids == _TRUTH_ID)
        if at.size != truth.size:  # publish_block's own checks say what is wrong
            return ids, rows
        self.decimated += dropped
        out = dict(rows)
        out[_TRUTH_ID] = truth[keep]
        return np.delete(ids, at[~keep]), out

    def _payload(self) -> bytes:
        """The batch as it goes to the writer: one msgpack call for all its messages."""
        return _encode_batch_payload((self._ids, self._by_id, self._rows))


class BackgroundRunLog(MessageBatcher):
    """Publish sink whose MCAP writing happens in a child process.

    Parameters
    ----------
    path : Path
        MCAP file to write.
    turbine : str
        Turbine id of the keys.
    metadata : dict
        Metadata records (name -> string map) written first.
    compression : str
        Chunk compression of the file (:data:`hil.runlog.mcap_io.COMPRESSIONS`).
    batch_messages : int
        Messages per batch (module docstring).
    truth_every : int
        Keep the truth of one cycle in N (a ``soak`` recording, module docstring).
    """

    def __init__(
        self,
        path: Path,
        turbine: str,
        metadata: dict[str, dict[str, str]],
        compression: str = "zstd",
        batch_messages: int = BATCH_MESSAGES,
        truth_every: int = 1,
    ) -> None:
        super().__init__(batch_messages, truth_every)
        ctx = multiprocessing.get_context("spawn")
        recv_end, send_end = ctx.Pipe(duplex=False)
        setpipe = getattr(fcntl, "F_SETPIPE_SZ", None)
        if setpipe is not None:
            with contextlib.suppress(OSError):  # a smaller pipe only costs waiting
                fcntl.fcntl(send_end.fileno(), setpipe, PIPE_BYTES)
        self._conn = send_end
        self._fd = send_end.fileno()
        self._ready = ctx.Event()
        self._stats = ctx.Array("d", 2)  # the writer's CPU seconds after start-up, messages
        self._error = ctx.Array("c", _ERROR_BYTES)  # why a write failed (LogWriteError)
        self._path = path
        self._proc = ctx.Process(
            target=_writer_process,
            args=(
                recv_end,
                str(path),
                turbine,
                metadata,
                compression,
                self._ready,
                time.time_ns() - time.monotonic_ns(),
                self._stats,
                self._error,
            ),
            name="fowt-log-writer",
            daemon=False,
        )
        self._proc.start()
        recv_end.close()
        # A log never closed (an exception before close(), a failing test) would keep the
        # interpreter from exiting: multiprocessing joins its non-daemon children at exit,
        # and the child waits on the pipe. Closing our end first (multiprocessing runs its
        # finalizers before that join) lets the child see EOF and finish the file.
        multiprocessing.util.Finalize(self, send_end.close, exitpriority=10)
        #: Messages and batches handed to the writer so far, and the time spent sending [ns].
        self.messages = 0
        self.batches = 0
        self.send_ns = 0
        #: Wall time :meth:`close` waited for the writer to finish the file [ns].
        self.close_wait_ns = 0
        #: After :meth:`close`: the writer's CPU time from its start-up's end to the file's
        #: end [s] and the messages it wrote (its throughput, bench/inprocess_speed.py).
        self.writer_cpu_s = 0.0
        self.writer_messages = 0

    def wait_ready(self, timeout_s: float = 120.0) -> None:
        """Wait until the writer has started (its imports take ~0.5 s) and opened the file.

        Called before the loop's first cycle, so the loop never waits on a writer that is
        still starting; the messages published meanwhile wait in the pipe and the batch.

        Raises
        ------
        RuntimeError
            If the writer exited or did not start within ``timeout_s``.
        """
        deadline = time.monotonic() + timeout_s
        while not self._ready.wait(0.05):
            if not self._proc.is_alive():
                raise self._failure()
            if time.monotonic() > deadline:
                raise RuntimeError(f"log writer did not start within {timeout_s:g} s")

    def _failure(self) -> LogWriteError | RuntimeError:
        """Why the writer stopped: its write error, else its exit status."""
        self._proc.join(5.0)
        why = bytes(self._error.value).decode(errors="replace")  # type: ignore[attr-defined]
        if why:
            return LogWriteError(why)
        return RuntimeError(f"log writer exited with {self._proc.exitcode}")

    def _send(self) -> None:
        n = len(self._ids)
        if n:
            payload = self._payload()
            t0 = time.perf_counter_ns()
            try:  # blocks while the pipe is full (writer behind)
                _write_message(self._fd, payload)
            except BrokenPipeError:  # the writer has stopped: say why, not "broken pipe"
                raise self._failure() from None
            self.send_ns += time.perf_counter_ns() - t0
            self.messages += n
            self.batches += 1
            self._new_batch()

    def close(self, timeout_s: float = 120.0) -> None:
        """Send what is left, wait for the child to finish the file."""
        t0 = time.perf_counter_ns()
        if self._conn.closed:  # closed before, after a failure that was raised then
            return
        try:
            self._send()
            with contextlib.suppress(BrokenPipeError):  # a writer that stopped says why below
                _write_message(self._fd, b"")
        finally:
            self._conn.close()
        self._proc.join(timeout_s)
        self.close_wait_ns = time.perf_counter_ns() - t0
        if self._proc.exitcode != 0:
            raise self._failure()
        self.writer_cpu_s, self.writer_messages = self._stats[0], int(self._stats[1])


class InProcessRunLog(MessageBatcher):
    """Publish sink writing its MCAP file in the caller's process, batch by batch.

    :class:`BackgroundRunLog`'s batching, each full batch framed here by the writer child's
    :class:`_BatchFramer` (one Chunk a batch) instead of going through a pipe to a child:
    for a process that may not start children (a Dask worker is a daemon process: a
    campaign's runs). The file is what :class:`BackgroundRunLog` writes for the same
    messages. A killed process loses the batch being filled, as there. Parameters: those
    of :class:`BackgroundRunLog`.
    """

    def __init__(
        self,
        path: Path,
        turbine: str,
        metadata: dict[str, dict[str, str]],
        compression: str = "zstd",
        batch_messages: int = BATCH_MESSAGES,
        truth_every: int = 1,
    ) -> None:
        super().__init__(batch_messages, truth_every)
        self.log = RunLog(path, turbine, compression=compression)
        for name, data in metadata.items():
            self.log.add_metadata(name, data)
        self._framer = _BatchFramer(self.log, _decoders(), time.time_ns() - time.monotonic_ns())

    def _send(self) -> None:
        if self._ids:
            self._framer.frame(self._payload())
            self._new_batch()

    def close(self) -> None:
        """Frame what is left, write the summary section and the footer."""
        try:
            self._send()
        finally:
            self.log.close()
