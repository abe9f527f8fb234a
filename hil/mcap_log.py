"""MCAP run logs: one file per run, JSON Schema channels that Foxglove can plot.

Writing
-------
:class:`RunLog` registers one channel per bus key with the JSON Schema derived from the
message declaration (:meth:`bus_schemas.registry.MessageType.json_schema`) and writes each
message as JSON. ``log_time`` is the run's wall-clock start plus the message's simulated
``sample_time_ns``, so Foxglove's timeline is simulated time; ``publish_time`` is when the
recorder took it from its subscriber's queue (at most about 20 ms after it arrived, see
:mod:`hil.recorder`; for a message that came in a log batch, when the batch was taken).

In-process runs and campaign workers write through :class:`BatchRunLog` instead: many
messages at once (one chunk per batch, the message records and indexes built with numpy),
about 2.8 times cheaper per message than :meth:`RunLog.write_json` (5.5 against 15 us
CPU on the loaded 2-core machine, the same JSON messages, zstd both), same channels,
schemas, sequence numbering and summary (see its docstring and :mod:`hil.log_writer`).

File layout and crash safety
----------------------------
A file closed by :meth:`RunLog.close` is a complete MCAP file: magic, Header, Schemas,
Channels and Metadata, zstd Chunks each followed by its MessageIndex records, DataEnd,
then the summary section (Schemas, Channels, Statistics, ChunkIndexes, MetadataIndexes,
SummaryOffsets), the Footer and the closing magic, so any MCAP reader opens it (the mcap
package's seeking and non-seeking readers, ``@mcap/core``, Foxglove).

The file is opened *buffered*: mcap's :class:`~mcap.writer.Writer` uses a buffered stream
as it is, whereas it wraps a raw (unbuffered) one in a buffer of its own that
:meth:`~mcap.writer.Writer.finish` does not flush, so closing the raw file under it loses
the end of the summary, the Footer and the closing magic. Crash safety comes from
:meth:`RunLog.maybe_flush` instead: every ``flush_interval_s`` (default 0.25 s of wall time)
the chunk in progress is closed and written with its message indexes, and the stream is
flushed to the OS. A SIGKILL of the writing process therefore loses at most the messages
of the last ``flush_interval_s`` (plus whatever the caller had not handed over yet); the
file then ends after its last flushed chunk (or inside a chunk the buffer had started to
write) without a summary. Such a file is read by any sequential reader up to the cut
(:func:`read_run`, mcap's ``NonSeekingReader``) and :func:`recover` rewrites it as a
complete file (``fowt recover``; with mcap's Go CLI: ``mcap recover``).

Reading
-------
:func:`read_run` reads a file front to back with mcap's stream reader through its summary,
Footer and closing magic (:class:`RecordScan`). It stops cleanly at a cut (a run whose
recorder was killed still reviews up to its last flushed chunk), skips a damaged chunk in the
middle (bad zstd data, a CRC that does not match, an unreadable record) and reads the chunks
after it, and says so (``truncated``, ``error``, ``skipped``); a file that does not start
with the MCAP magic raises :class:`NotMcapError`. :func:`recover` writes what it reads into
a complete file.
"""

from __future__ import annotations

import dataclasses
import json
import math
import mmap
import os
import struct
import time
import zlib
from array import array
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import IO, Any

import msgspec
import numpy as np
import orjson
from mcap.data_stream import ReadDataStream, RecordBuilder
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import CompressionType, Writer

from bus_schemas.registry import MESSAGES, MessageType

PROFILE = "fowt-hil"
RAW_SCHEMA_NAME = "fowt.RawPayload"
#: zstd level of :class:`BatchRunLog`. bench/inprocess_speed.py measured levels 1 and 3 on
#: a 600 s LC2 run's chunks (1024 messages, ~370 kB of JSON each): level 1 is both faster
#: (~540 against ~320 MB/s) and smaller (ratio 7.4 against 6.5) on these small chunks.
ZSTD_LEVEL = 1
#: zstd window and hash table of :class:`BatchRunLog` [log2 bytes / entries; 0 and 0: the
#: level's own, chosen by zstd for the chunk's size]. 18 and 12 (a 256 kB window, a 16 kB
#: hash table that stays in the core's caches) compress a real LC2 run's chunks faster than
#: level 1's own at the same ratio (bench/log_writer_speed.py, ``stages.compression``:
#: ``zstd1`` against ``zstd1_level_tables``). Any zstd decoder reads it (a smaller window
#: than level 1's own 512 kB).
ZSTD_WINDOW_LOG = 18
ZSTD_HASH_LOG = 12

#: The 8 bytes every MCAP file starts and ends with.
MCAP_MAGIC = b"\x89MCAP0\r\n"


class NotMcapError(ValueError):
    """The file is not an MCAP file (it does not start with the MCAP magic)."""


class RunLog:
    """Writer of one run's MCAP file.

    Parameters
    ----------
    path : Path
        Output file (created, parent directories made).
    turbine : str
        Turbine id in the key expressions (``fowt/<turbine>/...``).
    start_unix_ns : int
        Wall-clock time of simulated t = 0, used to place ``log_time``.
    flush_interval_s : float
        Wall seconds between chunk flushes (bounds the data lost on SIGKILL).
    """

    def __init__(
        self,
        path: Path,
        turbine: str,
        start_unix_ns: int | None = None,
        flush_interval_s: float = 0.25,
    ) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self.turbine = turbine
        self.start_unix_ns = time.time_ns() if start_unix_ns is None else start_unix_ns
        # Buffered, so the Writer writes to this stream itself (module docstring: a raw
        # stream would get a private buffer that finish() never flushes). maybe_flush()
        # pushes finished chunks to the OS.
        self._stream: IO[bytes] = open(path, "wb")  # noqa: SIM115 - closed in close()
        self._writer = Writer(self._stream, chunk_size=256 * 1024, compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library="fowt-hil")
        self._channels: dict[str, tuple[int, MessageType]] = {}
        self._seq: dict[int, int] = {}
        for mt in MESSAGES:
            schema_id = self._writer.register_schema(
                name=f"fowt.{mt.name}",
                encoding="jsonschema",
                data=json.dumps(mt.json_schema()).encode(),
            )
            key = mt.key(turbine)
            channel_id = self._writer.register_channel(
                topic=key,
                message_encoding="json",
                schema_id=schema_id,
                metadata={"version": str(mt.version), "message_id": str(mt.message_id)},
            )
            self._channels[key] = (channel_id, mt)
        self._flush_interval_ns = int(flush_interval_s * 1e9)
        self._last_flush_ns = time.monotonic_ns()
        self.count = 0
        self._closed = False

    def channel_for(self, key: str) -> tuple[int, MessageType] | None:
        """The channel id and message type registered for a key expression."""
        return self._channels.get(key)

    def write(self, key: str, msg: Any, receive_unix_ns: int | None = None) -> None:
        """Write one decoded message (a registered Struct) under its key."""
        entry = self._channels.get(key)
        if entry is None:
            raise KeyError(f"no channel registered for key {key!r}")
        channel_id, _mt = entry
        data = msgspec.json.encode(msg)
        seq = self._seq.get(channel_id, 0)
        self._seq[channel_id] = seq + 1
        log_time = self.start_unix_ns + int(msg.sample_time_ns)
        self._writer.add_message(
            channel_id=channel_id,
            log_time=log_time,
            data=data,
            publish_time=receive_unix_ns if receive_unix_ns is not None else time.time_ns(),
            sequence=seq,
        )
        self.count += 1
        self.maybe_flush()

    def write_json(self, key: str, sample_time_ns: int, data: bytes, receive_unix_ns: int) -> None:
        """Write one message already encoded as JSON (the background writer's path)."""
        entry = self._channels.get(key)
        if entry is None:
            raise KeyError(f"no channel registered for key {key!r}")
        channel_id = entry[0]
        seq = self._seq.get(channel_id, 0)
        self._seq[channel_id] = seq + 1
        self._writer.add_message(
            channel_id=channel_id,
            log_time=self.start_unix_ns + sample_time_ns,
            data=data,
            publish_time=receive_unix_ns,
            sequence=seq,
        )
        self.count += 1
        self.maybe_flush()

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Add a metadata record (scenario, run information, counters) and flush it."""
        self._writer.add_metadata(name, data)
        self.flush()

    def flush(self) -> None:
        """Close the chunk in progress and hand everything written so far to the OS."""
        self._writer.flush()
        self._last_flush_ns = time.monotonic_ns()

    def maybe_flush(self) -> None:
        """Flush the chunk in progress if the flush interval has passed."""
        if time.monotonic_ns() - self._last_flush_ns >= self._flush_interval_ns:
            self.flush()

    def close(self) -> None:
        """Write the summary section, Footer and closing magic; close the file (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.finish()
            self._stream.flush()
        finally:
            self._stream.close()


#: Bytes of an MCAP Message record before its data: opcode (1), record length (8),
#: channel id (2), sequence (4), log time (8), publish time (8).
MESSAGE_HEADER_BYTES = 31
_MESSAGE_HEADER = np.dtype(
    [
        ("opcode", "u1"),
        ("length", "<u8"),
        ("channel_id", "<u2"),
        ("sequence", "<u4"),
        ("log_time", "<u8"),
        ("publish_time", "<u8"),
    ]
)  # packed (no alignment): 31 bytes, the record's layout
_OP_MESSAGE, _OP_CHUNK, _OP_MESSAGE_INDEX = 0x05, 0x06, 0x07
_GAP = bytes(MESSAGE_HEADER_BYTES)
#: Compressions :class:`BatchRunLog` can write ("" = none).
COMPRESSIONS = ("zstd", "lz4", "")


class BatchRunLog:
    """Writer of one run's MCAP file from whole batches of pre-encoded messages.

    The in-process mode's log writer (:mod:`hil.log_writer`) receives the messages of many
    cycles at once. Writing them one by one through ``mcap.Writer.add_message`` costs
    several us each in Python (a record object, struct packs into a BytesIO, an index
    tuple): the writer before this class managed 53 000 to 68 000 messages per CPU second
    on the loaded 2-core machine (bench/inprocess_speed.py). Here a batch is one buffer that
    already holds the messages' JSON with a 31-byte gap before each
    (:data:`MESSAGE_HEADER_BYTES`); the headers of the MCAP Message records (opcode 0x05,
    record length 22 + len(data), channel id, per-channel sequence, log time = run start +
    ``sample_time_ns``, publish time) are filled into the gaps with one numpy assignment,
    and the buffer is then exactly the records of one Chunk. Each batch is written as one
    Chunk (compressed), followed by one MessageIndex record per channel in it (log time,
    offset of the record in the chunk), and handed to the OS at once
    (:meth:`write_chunk`). :mod:`hil.log_writer`'s child builds the whole records itself
    (headers included, sequence numbers from :attr:`channel_seq`) and calls
    :meth:`write_chunk` directly; :meth:`write_batch` is the reference it is tested against.

    The file is laid out as :class:`RunLog`'s (same channels, schemas, ids and sequence
    numbering): magic, Header, Schemas and Channels (here in the data section, outside
    the chunks), Metadata, Chunks with their MessageIndexes, DataEnd, then the summary
    section (Schemas, Channels, Statistics, ChunkIndexes, MetadataIndexes,
    SummaryOffsets), the Footer (with the summary's CRC-32) and the closing magic. The
    structural records are written with the mcap package's record classes; only the
    message records and their indexes are built here.

    Parameters
    ----------
    path : Path
        Output file (created, parent directories made).
    turbine : str
        Turbine id in the key expressions.
    compression : str
        ``"zstd"`` (default), ``"lz4"`` or ``""`` (none).
    start_unix_ns : int, optional
        Wall-clock time of simulated t = 0 (default: now).
    batch_messages, flush_interval_s : int, float
        For :meth:`add_json` (one message at a time, e.g. a campaign worker's run): a chunk
        is written every ``batch_messages`` messages or ``flush_interval_s`` of wall time,
        which bounds what a SIGKILL of the writing process loses.
    place_headers : callable, optional
        ``place_headers(buf, offsets, headers)`` writes row ``i`` of the ``(n, 31)`` uint8
        ``headers`` to ``buf[offsets[i]:offsets[i] + 31]``; default: one numpy assignment
        (about 0.5 us a message). :mod:`hil.log_writer` passes a compiled loop (~0.03 us).
    """

    def __init__(
        self,
        path: Path,
        turbine: str,
        compression: str = "zstd",
        start_unix_ns: int | None = None,
        batch_messages: int = 1024,
        flush_interval_s: float = 0.25,
        place_headers: Callable[[np.ndarray, np.ndarray, np.ndarray], None] | None = None,
    ) -> None:
        self._place_headers = place_headers
        if compression not in COMPRESSIONS:
            raise ValueError(f"compression {compression!r}: expected one of {COMPRESSIONS}")
        self._compress: Callable[[bytearray], bytes]
        if compression == "zstd":
            import zstandard  # noqa: PLC0415

            if ZSTD_WINDOW_LOG or ZSTD_HASH_LOG:
                params = zstandard.ZstdCompressionParameters.from_level(
                    ZSTD_LEVEL, window_log=ZSTD_WINDOW_LOG, hash_log=ZSTD_HASH_LOG
                )
                self._compress = zstandard.ZstdCompressor(compression_params=params).compress
            else:
                self._compress = zstandard.ZstdCompressor(level=ZSTD_LEVEL).compress
        elif compression == "lz4":
            try:
                import lz4.frame  # type: ignore[import-untyped]  # noqa: PLC0415
            except ImportError as exc:  # not a dependency: mcap's writer makes it optional too
                raise ValueError("compression 'lz4': the lz4 package is not installed") from exc
            self._compress = lz4.frame.compress
        else:
            self._compress = bytes
        self.compression = compression
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self.start_unix_ns = time.time_ns() if start_unix_ns is None else start_unix_ns
        self._stream: IO[bytes] = open(path, "wb")  # noqa: SIM115 - closed in close()
        self._stream.write(MCAP_MAGIC)
        self._builder = RecordBuilder()
        Header(profile=PROFILE, library="fowt-hil").write(self._builder)
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self.channel_of_message_id = np.zeros(max(mt.message_id for mt in MESSAGES) + 1, np.int64)
        for mt in MESSAGES:
            schema = Schema(
                id=len(self._schemas) + 1,
                name=f"fowt.{mt.name}",
                encoding="jsonschema",
                data=json.dumps(mt.json_schema()).encode(),
            )
            self._schemas.append(schema)
            schema.write(self._builder)
            channel = Channel(
                id=len(self._channels) + 1,
                topic=mt.key(turbine),
                message_encoding="json",
                schema_id=schema.id,
                metadata={"version": str(mt.version), "message_id": str(mt.message_id)},
            )
            self._channels.append(channel)
            channel.write(self._builder)
            self.channel_of_message_id[mt.message_id] = channel.id
        self._write_records()
        self._seq = np.zeros(len(self._channels) + 1, np.int64)
        self._counts = np.zeros(len(self._channels) + 1, np.int64)
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._start_time: int | None = None
        self._end_time = 0
        self.count = 0
        self._closed = False
        self.batch_messages = batch_messages
        self._flush_interval_ns = int(flush_interval_s * 1e9)
        self._last_flush_ns = time.monotonic_ns()
        self._pending = bytearray()
        self._pending_meta = array("q")

    def _write_records(self) -> None:
        self._stream.write(self._builder.end())

    def add_json(
        self, message_id: int, data: bytes, sample_time_ns: int, publish_unix_ns: int
    ) -> None:
        """Queue one message already encoded as JSON; the batch is written (one chunk) when
        it holds ``batch_messages`` messages or ``flush_interval_s`` of wall time has passed
        since the last one (the clock read every 32 messages), and by :meth:`close`."""
        records = self._pending
        offset = len(records)
        records += _GAP
        records += data
        self._pending_meta.extend((message_id, sample_time_ns, publish_unix_ns, offset))
        n = len(self._pending_meta) >> 2
        if n >= self.batch_messages or (
            not n & 31 and time.monotonic_ns() - self._last_flush_ns >= self._flush_interval_ns
        ):
            self.flush_pending()

    def flush_pending(self) -> None:
        """Write the messages queued by :meth:`add_json` as one chunk."""
        if self._pending_meta:
            meta = np.frombuffer(self._pending_meta, np.int64).reshape(-1, 4)
            self.write_batch(meta, self._pending)
            self._pending = bytearray()
            self._pending_meta = array("q")
        self._last_flush_ns = time.monotonic_ns()

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Add a metadata record and hand it to the OS."""
        offset = self._stream.tell()
        Metadata(name=name, metadata=data).write(self._builder)
        self._metadata_indexes.append(
            MetadataIndex(offset=offset, length=self._builder.count, name=name)
        )
        self._write_records()
        self._stream.flush()

    def write_batch(self, meta: np.ndarray, records: bytearray) -> None:
        """Write one batch as a Chunk with its MessageIndexes and flush it to the OS.

        Parameters
        ----------
        meta : ndarray, shape (n, 4), int64
            Per message: message id, ``sample_time_ns``, publish (receive) time [ns, unix],
            offset of its record in ``records`` (the 31-byte gap before its JSON).
        records : bytearray
            The messages' JSON, each after its 31-byte gap, in order; modified in place.
        """
        n = len(meta)
        if n == 0:
            return
        offsets = meta[:, 3]
        ends = np.empty(n, np.int64)
        ends[:-1] = offsets[1:]
        ends[-1] = len(records)
        data_len = ends - offsets - MESSAGE_HEADER_BYTES
        if offsets[0] != 0 or np.any(data_len < 0):
            raise ValueError("batch offsets do not describe the record buffer")
        channel = self.channel_of_message_id[meta[:, 0]]
        if np.any(channel == 0):
            raise ValueError("batch holds an unregistered message id")
        log_time = self.start_unix_ns + meta[:, 1]
        sequence = np.empty(n, np.int64)
        counts = np.zeros(len(self._seq), np.int64)
        entries = np.empty((n, 2), np.int64)
        k0 = 0
        for cid in np.unique(channel).tolist():
            mask = channel == cid
            k = int(np.count_nonzero(mask))
            sequence[mask] = self._seq[cid] + np.arange(k)
            counts[cid] = k
            entries[k0 : k0 + k, 0] = log_time[mask]
            entries[k0 : k0 + k, 1] = offsets[mask]
            k0 += k
        header = np.empty(n, _MESSAGE_HEADER)
        header["opcode"] = _OP_MESSAGE
        header["length"] = data_len + (MESSAGE_HEADER_BYTES - 9)
        header["channel_id"] = channel
        header["sequence"] = sequence
        header["log_time"] = log_time
        header["publish_time"] = meta[:, 2]
        buf = np.frombuffer(records, np.uint8)
        headers = header.view(np.uint8).reshape(n, MESSAGE_HEADER_BYTES)
        if self._place_headers is not None:
            self._place_headers(buf, offsets, headers)
        else:
            buf[offsets[:, None] + np.arange(MESSAGE_HEADER_BYTES)] = headers
        self.write_chunk(records, counts, entries, int(log_time.min()), int(log_time.max()))

    @property
    def channel_seq(self) -> np.ndarray:
        """Per channel id, the sequence number of its next message (read only; advanced by
        :meth:`write_chunk`)."""
        return self._seq

    def write_chunk(
        self, records: Any, counts: np.ndarray, entries: np.ndarray, start: int, end: int
    ) -> None:
        """Write finished Message records as one Chunk with its MessageIndexes, flush it.

        Parameters
        ----------
        records : bytes-like
            The chunk's records (each Message record's header filled, sequence numbers
            continuing from :attr:`channel_seq`).
        counts : ndarray of int64, shape (channels + 1,)
            The chunk's messages per channel id.
        entries : ndarray of int64, shape (n, 2)
            Per message its log time [ns] and record offset in ``records``, grouped by
            channel in ascending channel id (publish order within one).
        start, end : int
            The first and last log time [ns].
        """
        n = len(entries)
        compressed = self._compress(records)
        stream = self._stream
        chunk_start = stream.tell()
        comp = self.compression.encode()
        body = 8 + 8 + 8 + 4 + 4 + len(comp) + 8 + len(compressed)
        stream.write(
            struct.pack("<BQQQQI", _OP_CHUNK, body, start, end, len(records), zlib.crc32(records))
            + struct.pack("<I", len(comp))
            + comp
            + struct.pack("<Q", len(compressed))
        )
        stream.write(compressed)
        index_start = stream.tell()
        index_offsets: dict[int, int] = {}
        parts = []
        pos = index_start
        k0 = 0
        for cid in np.flatnonzero(counts).tolist():
            k = int(counts[cid])
            part = (
                struct.pack("<BQHI", _OP_MESSAGE_INDEX, 6 + 16 * k, cid, 16 * k)
                + entries[k0 : k0 + k].tobytes()
            )
            k0 += k
            index_offsets[cid] = pos
            pos += len(part)
            parts.append(part)
        if k0 != n:
            raise ValueError(f"write_chunk: {n} index entries for {k0} messages")
        stream.write(b"".join(parts))
        stream.flush()
        self._seq += counts
        self._counts += counts
        self._chunk_indexes.append(
            ChunkIndex(
                message_start_time=start,
                message_end_time=end,
                chunk_start_offset=chunk_start,
                chunk_length=index_start - chunk_start,
                message_index_offsets=index_offsets,
                message_index_length=pos - index_start,
                compression=self.compression,
                compressed_size=len(compressed),
                uncompressed_size=len(records),
            )
        )
        self._start_time = start if self._start_time is None else min(self._start_time, start)
        self._end_time = max(self._end_time, end)
        self.count += n

    def close(self) -> None:
        """Write DataEnd, the summary section, Footer and closing magic (idempotent)."""
        if self._closed:
            return
        try:
            self.flush_pending()
        finally:
            self._closed = True
        try:
            stream = self._stream
            DataEnd(data_section_crc=0).write(self._builder)
            self._write_records()
            summary_start = stream.tell()
            b = RecordBuilder()
            offsets: list[SummaryOffset] = []

            def group(opcode: Opcode, records: list[Any]) -> None:
                begin = b.count
                for rec in records:
                    rec.write(b)
                if records:
                    offsets.append(
                        SummaryOffset(
                            group_opcode=opcode,
                            group_start=summary_start + begin,
                            group_length=b.count - begin,
                        )
                    )

            counts = {cid: int(n) for cid, n in enumerate(self._counts.tolist()) if n}
            stats = Statistics(
                attachment_count=0,
                channel_count=len(self._channels),
                channel_message_counts=counts,
                chunk_count=len(self._chunk_indexes),
                message_count=self.count,
                metadata_count=len(self._metadata_indexes),
                message_start_time=self._start_time or 0,
                message_end_time=self._end_time,
                schema_count=len(self._schemas),
            )
            group(Opcode.SCHEMA, list(self._schemas))
            group(Opcode.CHANNEL, list(self._channels))
            group(Opcode.STATISTICS, [stats])
            group(Opcode.CHUNK_INDEX, list(self._chunk_indexes))
            group(Opcode.METADATA_INDEX, list(self._metadata_indexes))
            summary_offset_start = summary_start + b.count
            for off in offsets:
                off.write(b)
            summary = b.end()
            crc = zlib.crc32(summary)
            crc = zlib.crc32(
                struct.pack("<BQQQ", Opcode.FOOTER, 20, summary_start, summary_offset_start), crc
            )
            stream.write(summary)
            Footer(
                summary_start=summary_start,
                summary_offset_start=summary_offset_start,
                summary_crc=crc,
            ).write(self._builder)
            self._write_records()
            stream.write(MCAP_MAGIC)
            stream.flush()
        finally:
            self._stream.close()


class MessageList(list[dict[str, Any]]):
    """A topic's messages (dicts, a plain list's contents) that also know their fields as
    columns, for messages that came as rows (a campaign's in-process run).

    ``parts`` are ``(start, stop, rows)``: messages ``start:stop`` of the list are the
    dicts of ``rows`` (a ``row_dtype`` array), or ``rows`` is None for dicts from anywhere
    else. :meth:`column` is ``np.array([m.get(name, nan) for m in self], float64)``
    (:func:`hil.review._col`'s value: a missing field, None, NaN or an infinity gives nan)
    taken from the rows' arrays where there are rows; computed once per field.
    """

    def __init__(
        self, messages: list[dict[str, Any]], parts: list[tuple[int, int, np.ndarray | None]]
    ) -> None:
        super().__init__(messages)
        self.parts = parts
        self._columns: dict[str, np.ndarray] = {}

    def column(self, name: str) -> np.ndarray:
        """Field ``name`` of every message as float64 (class docstring); a copy."""
        col = self._columns.get(name)
        if col is None:
            col = np.empty(len(self), np.float64)
            for start, stop, rows in self.parts:
                if rows is None:
                    col[start:stop] = [m.get(name, math.nan) for m in self[start:stop]]
                elif name in (rows.dtype.names or ()):
                    col[start:stop] = rows[name]
                else:
                    col[start:stop] = math.nan
            col[~np.isfinite(col)] = math.nan
            self._columns[name] = col
        return col.copy()

    def since(self, name: str, t0: float, default: float = -1.0) -> MessageList:
        """``[m for m in self if m.get(name, default) >= t0]`` with the rows' parts kept
        (a row's field compared as stored, int or float, as its dict's value would be)."""
        keep = np.zeros(len(self), np.bool_)
        parts: list[tuple[int, int, np.ndarray | None]] = []
        at = 0
        for start, stop, rows in self.parts:
            if rows is None or name not in (rows.dtype.names or ()):
                sel = np.array(
                    [m.get(name, default) >= t0 for m in self[start:stop]], np.bool_
                ).reshape(-1)
            else:
                sel = rows[name] >= t0
            keep[start:stop] = sel
            k = int(np.count_nonzero(sel))
            if k:
                parts.append((at, at + k, None if rows is None else rows[sel]))
                at += k
        messages = [self[i] for i in np.flatnonzero(keep).tolist()]
        return MessageList(messages, parts)


@dataclass
class RunData:
    """Messages of one run, grouped by topic, as plain dicts in file order.

    ``complete`` is True when the file ran through its summary section, Footer and closing
    magic; ``truncated`` is its negation (a killed writer, a cut copy); ``error`` says what
    the reader stopped on. ``statistics`` is the message count per topic of the summary's
    Statistics record (None without one) and ``statistics_ok`` whether it equals the
    messages read.
    """

    messages: dict[str, list[dict[str, Any]]] = field(default_factory=dict)
    schemas: dict[str, str] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    truncated: bool = False
    error: str = ""
    complete: bool = False
    statistics: dict[str, int] | None = None
    statistics_ok: bool | None = None
    #: Damaged parts of the file that were skipped (:class:`RecordScan`), and the log time of
    #: its first message [ns] that their log times are given against.
    skipped: list[SkippedRange] = field(default_factory=list)
    first_log_ns: int | None = None
    #: The Header's profile (``"fowt-hil"`` for this bench's run logs; None: no Header read).
    profile: str | None = None

    def topic(self, suffix: str) -> list[dict[str, Any]]:
        """Messages of the first topic ending in ``/<suffix>`` (any turbine)."""
        for name, msgs in self.messages.items():
            if name.endswith("/" + suffix):
                return msgs
        return []


def check_magic(path: Path) -> None:
    """Raise :class:`NotMcapError` unless ``path`` starts with the MCAP magic."""
    with open(path, "rb") as fh:
        head = fh.read(len(MCAP_MAGIC))
    if head != MCAP_MAGIC:
        what = "an empty file" if not head else f"starts with {head[:8]!r}"
        raise NotMcapError(f"{path} is not an MCAP file ({what}, expected the MCAP magic)")


def iter_records(path: Path) -> Iterator[Any]:
    """Yield MCAP records through the Footer and closing magic (raises at a cut or bad tail)."""
    with open(path, "rb") as stream:
        reader = StreamReader(stream, skip_magic=False)
        yield from reader.records


@dataclass(frozen=True)
class SkippedRange:
    """Bytes of a run log that could not be read and were skipped.

    ``start``/``end`` are byte offsets (end exclusive), ``reason`` what was wrong (a chunk's
    zstd data or CRC, a record cut by the end of the file, an unreadable record), and
    ``log_start_ns``/``log_end_ns`` the log times of the messages lost (a chunk's own
    header says them; None when not known).
    """

    start: int
    end: int
    reason: str
    log_start_ns: int | None = None
    log_end_ns: int | None = None
    first_log_ns: int | None = None
    #: The range runs to the end of the file (a cut file), rather than damage in its middle.
    to_end: bool = False

    def describe(self) -> str:
        """``bytes 1234-5678 (4444 B): reason; log time 1.250-2.500 s``, one line.

        The log times are given in seconds since ``first_log_ns`` (the earliest message
        start time of the file's chunks: about the simulated time for a bench run log) when
        it is known, else in ns.
        """
        first_log_ns = self.first_log_ns
        text = f"bytes {self.start}-{self.end} ({self.end - self.start} B): {self.reason}"
        if self.log_start_ns is not None and self.log_end_ns is not None:
            if first_log_ns is not None:
                a = (self.log_start_ns - first_log_ns) / 1e9
                b = (self.log_end_ns - first_log_ns) / 1e9
                text += f"; log time {a:.3f}-{b:.3f} s"
            else:
                text += f"; log time {self.log_start_ns}-{self.log_end_ns} ns"
        return text

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: the byte range, reason and log times [s since ``first_log_ns``]."""
        out: dict[str, Any] = {
            "start": self.start,
            "end": self.end,
            "to_end": self.to_end,
            "reason": self.reason,
        }
        base = self.first_log_ns
        for key, ns in (("log_start_s", self.log_start_ns), ("log_end_s", self.log_end_ns)):
            out[key] = None if ns is None or base is None else (ns - base) / 1e9
        return out


#: What mcap's stream reader raises on a damaged record: its own errors (a cut: EndOfFile),
#: struct.error inside fixed-size fields, UnicodeDecodeError (a ValueError) in strings.
_RECORD_ERRORS = (McapError, EOFError, ValueError, struct.error, OSError, MemoryError)


def _why(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


class RecordScan:
    """Every readable record of an MCAP file, the damaged parts skipped and listed.

    mcap's :class:`~mcap.stream_reader.StreamReader` reads the file front to back with its
    Chunks emitted whole; each Chunk is then opened with mcap's
    :func:`~mcap.stream_reader.breakup_chunk` with its CRC checked. A chunk that does not
    open (bad zstd data, a CRC that does not match, cut by the end of the file) is skipped
    and listed in :attr:`skipped` with its byte range and its messages' log times, and the
    records after it are read as usual. A record that the stream reader cannot frame (a
    damaged opcode or length) is skipped by looking for the next intact Chunk
    (:func:`_next_chunk`); without one the rest of the file is listed as skipped.

    After the iteration, :attr:`footer` is True when the Footer and closing magic were
    read and :attr:`error` says what the reader stopped on (empty when it did not).
    """

    def __init__(self, path: Path, raw_messages: bool = False) -> None:
        self.path = path
        #: Yield each chunk's messages as one :class:`MessageBatch` (payloads grouped by
        #: channel, no record object per message: the column reader's path) instead of
        #: mcap Message records.
        self.raw_messages = raw_messages
        self.skipped: list[SkippedRange] = []
        self.error = ""
        self.footer = False
        self.first_log_ns: int | None = None

    def _note_times(self, start_ns: int) -> None:
        if self.first_log_ns is None or start_ns < self.first_log_ns:
            self.first_log_ns = start_ns

    def records(self) -> Generator[Any, None, None]:
        """Yield the records (those inside chunks unpacked) in file order."""
        size = self.path.stat().st_size
        try:
            yield from self._records(size)
        finally:  # the log times of the skipped ranges against the file's first message
            self.skipped = [
                dataclasses.replace(r, first_log_ns=self.first_log_ns, to_end=r.end >= size)
                for r in self.skipped
            ]

    def _records(self, size: int) -> Iterator[Any]:
        with open(self.path, "rb") as fh:
            pos, skip_magic = 0, False
            while True:
                fh.seek(pos)
                reader = (_NoIndexStreamReader if self.raw_messages else StreamReader)(
                    fh, skip_magic=skip_magic, emit_chunks=True
                )
                start = pos if skip_magic else pos + len(MCAP_MAGIC)
                resume: int | None = None  # where to read on after a damaged chunk
                try:
                    for rec in reader.records:
                        end = fh.tell()
                        if isinstance(rec, Chunk):
                            inner, resume = self._open_chunk(fh, rec, start, end, size)
                            if resume is not None:
                                break
                            yield from inner
                        elif rec is not None:
                            yield rec
                        start = end
                    else:
                        self.footer = True
                        return
                except _RECORD_ERRORS as exc:
                    self.error = _why(exc)
                    nxt = _next_chunk(fh, start + 1, size) if start < size else None
                    if nxt is None:
                        if start < size:
                            why = f"no readable record from here to the end ({self.error})"
                            self.skipped.append(SkippedRange(start, size, why))
                        return
                    why = f"unreadable record ({self.error})"
                    self.skipped.append(SkippedRange(start, nxt, why))
                    resume = nxt
                pos, skip_magic = resume, True

    def _open_chunk(
        self, fh: IO[bytes], rec: Chunk, start: int, end: int, size: int
    ) -> tuple[list[Any], int | None]:
        """The records of a Chunk read at ``start``-``end``, or none for a damaged one.

        Returns the records and None, or for a damaged chunk (listed in :attr:`skipped`) no
        records and, where the reader took more bytes for it than its record length says (a
        damaged compressed size swallows the records after it), the offset to read on from:
        the end of its record, or an intact chunk that starts inside the bytes taken.
        """
        # The record length (read by hand: mcap's Chunk record does not keep it) must agree
        # with the sizes inside the chunk; the reader trusts the latter, so a damaged
        # compressed size takes the records after the chunk with it.
        (length,) = struct.unpack("<Q", os.pread(fh.fileno(), 8, start + 1))
        if start + 9 + length < end:
            self.skipped.append(
                SkippedRange(
                    start,
                    start + 9 + length,
                    "chunk whose sizes disagree with its record length",
                    rec.message_start_time,
                    rec.message_end_time,
                )
            )
            return [], start + 9 + length
        try:
            inner = (
                open_chunk_batch(rec)
                if self.raw_messages
                else breakup_chunk(rec, validate_crc=True)
            )
        except Exception as exc:  # zstd raises its own
            if 0 < rec.message_end_time >= rec.message_start_time:
                self._note_times(rec.message_start_time)
            why = _why(exc)
            nxt = _next_chunk(fh, start + 1, size, before=end)
            if nxt is None and end >= size:
                why = f"chunk cut by the end of the file ({why})"
            self.skipped.append(
                SkippedRange(
                    start,
                    end if nxt is None else nxt,
                    why,
                    rec.message_start_time,
                    rec.message_end_time,
                )
            )
            return [], nxt
        if any(isinstance(r, Message | MessageBatch) for r in inner):
            # (a chunk of schemas and channels only has times 0)
            self._note_times(rec.message_start_time)
        return inner, None


class _NoIndexStreamReader(StreamReader):
    """mcap's stream reader that passes over MessageIndex records unparsed.

    A chunk's message indexes (one entry per message, each read with its own 8-byte reads
    by the mcap package: about 40 % of the column reader's time) say nothing the chunk
    itself does not; their bytes are skipped by the record length.
    """

    def _read_record(self, opcode: int, length: int) -> Any:
        if opcode == Opcode.MESSAGE_INDEX:
            return SKIPPED_INDEX  # (a record all the same: RecordScan counts its bytes)
        return super()._read_record(opcode, length)


class _SkippedIndex:
    """Stands for a MessageIndex record passed over by :class:`_NoIndexStreamReader`."""


SKIPPED_INDEX = _SkippedIndex()


@dataclass
class MessageBatch:
    """The Message records of one chunk, their payloads grouped by channel id in file order.

    ``payloads[channel_id]`` is the list of that channel's message data (bytes) in the
    chunk; :class:`RecordScan` yields one after the chunk's other records (schemas and
    channels, which precede their messages) when built with ``raw_messages``.
    """

    payloads: dict[int, list[bytes]]


_RECORD_HEAD = struct.Struct("<BQH")  # opcode, record length, (a message's) channel id


def open_chunk_batch(rec: Chunk) -> list[Any]:
    """A chunk's Schema and Channel records and one :class:`MessageBatch` of its messages.

    The chunk is decompressed and its CRC checked as :func:`~mcap.stream_reader.breakup_chunk`
    does; its records are then framed by their lengths with one ``struct`` unpack each,
    and a message's data is sliced out without building a record object (about a third
    of the cost per message). Raises like ``breakup_chunk`` on a damaged chunk (bad
    compressed data, CRC, a record that does not fit).
    """
    if rec.compression == "zstd":
        import zstandard  # noqa: PLC0415

        data = zstandard.ZstdDecompressor().decompress(
            rec.data, max_output_size=rec.uncompressed_size
        )
    elif rec.compression == "lz4":
        import lz4.frame  # noqa: PLC0415

        data = lz4.frame.decompress(rec.data)
    elif rec.compression == "":
        data = bytes(rec.data)
    else:
        raise McapError(f"unsupported chunk compression {rec.compression!r}")
    if rec.uncompressed_crc != 0 and zlib.crc32(data) != rec.uncompressed_crc:
        raise McapError("chunk CRC does not match its data")
    payloads: dict[int, list[bytes]] = {}
    other = bytearray()
    unpack = _RECORD_HEAD.unpack_from
    off, n = 0, len(data)
    while off < n:
        if off + 11 > n:
            raise McapError(f"record cut at {off} of a {n}-byte chunk")
        op, length, channel = unpack(data, off)
        end = off + 9 + length
        if end > n:
            raise McapError(f"record of {length} bytes at {off} overruns the {n}-byte chunk")
        if op == _OP_MESSAGE:
            if length < MESSAGE_HEADER_BYTES - 9:
                raise McapError(f"message record of {length} bytes at {off}")
            got = payloads.get(channel)
            if got is None:
                got = payloads[channel] = []
            got.append(data[off + MESSAGE_HEADER_BYTES : end])
        elif op in (Opcode.SCHEMA, Opcode.CHANNEL):
            other += data[off:end]
        off = end
    out: list[Any] = []
    if other:
        stream = ReadDataStream(BytesIO(bytes(other)))
        while stream.count < len(other):
            op = stream.read1()
            stream.read8()
            out.append(Channel.read(stream) if op == Opcode.CHANNEL else Schema.read(stream))
    if payloads:
        out.append(MessageBatch(payloads))
    return out


def _next_chunk(fh: IO[bytes], begin: int, size: int, before: int | None = None) -> int | None:
    """Offset of the next intact Chunk record at or after ``begin`` and before ``before``
    (default: anywhere in the ``size`` bytes of the file); None: there is none.

    mcap's readers follow the record lengths, so after a damaged length they have no
    position to go on from; nor does its API search for a record. This looks for a Chunk
    record by hand: an opcode 0x06 byte whose record length agrees with its own header
    (start and end time, uncompressed size and CRC, a compression of ``zstd``, ``lz4`` or
    none, the compressed size), that fits in the file, and that mcap's reader then reads and
    :func:`~mcap.stream_reader.breakup_chunk` opens with a matching CRC.
    """
    head = struct.Struct("<BQQQQII")  # opcode, length, start, end, size, crc, len(comp)
    with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        stop = size if before is None else before
        at = mm.find(bytes([_OP_CHUNK]), begin, stop)
        while at >= 0:
            if at + head.size <= size:
                _op, length, t0, t1, _usize, _crc, n_comp = head.unpack_from(mm, at)
                comp = mm[at + head.size : at + head.size + n_comp] if n_comp <= 4 else b"?"
                if (
                    comp in (b"zstd", b"lz4", b"")
                    and t0 <= t1
                    and at + 9 + length <= size
                    and at + head.size + n_comp + 8 <= size
                ):
                    (n_data,) = struct.unpack_from("<Q", mm, at + head.size + n_comp)
                    if length == 8 + 8 + 8 + 4 + 4 + n_comp + 8 + n_data and _chunk_opens(
                        mm[at : at + 9 + length]
                    ):
                        return at
            at = mm.find(bytes([_OP_CHUNK]), at + 1, stop)
    return None


def _chunk_opens(record: bytes) -> bool:
    """Whether ``record`` (one Chunk record) reads and opens with a matching CRC."""
    try:
        rec = next(iter(StreamReader(BytesIO(record), skip_magic=True, emit_chunks=True).records))
        if not isinstance(rec, Chunk):
            return False
        breakup_chunk(rec, validate_crc=True)
        return True
    except Exception:  # any failure: not an intact chunk
        return False


def _summary_of(path: Path) -> Any:
    """The file's summary section by mcap's seeking reader (None: no summary, or damaged)."""
    try:
        with open(path, "rb") as fh:
            return SeekingReader(fh).get_summary()
    except Exception:  # a cut or damaged tail: no summary to fall back on
        return None


def read_run(path: Path) -> RunData:
    """Read every message of a run log, tolerating a truncated or damaged file.

    The records come from :class:`RecordScan`: a damaged chunk in the middle is skipped and
    the chunks after it are read. Channels and schemas that were in a lost chunk are taken
    from the summary section when the file still has one (mcap's seeking reader).

    Raises
    ------
    NotMcapError
        If the file does not start with the MCAP magic (empty, random, another format).

    Returns
    -------
    RunData
        ``truncated`` is True when the file ended before its Footer and closing magic (a
        killed process) or a part of it was skipped (``skipped``); ``error`` then says what
        the reader stopped on or what it skipped.
    """
    check_magic(path)
    run = RunData()
    channels: dict[int, str] = {}
    schema_names: dict[int, str] = {}
    in_summary = False
    stats: Statistics | None = None
    scan = RecordScan(path)
    summary: Any = None
    try:
        for rec in scan.records():
            if isinstance(rec, Header):
                run.profile = rec.profile
            elif isinstance(rec, Schema):
                schema_names[rec.id] = rec.name
            elif isinstance(rec, Channel):
                if not in_summary:
                    channels[rec.id] = rec.topic
                    run.schemas[rec.topic] = schema_names.get(rec.schema_id, "")
                    run.messages.setdefault(rec.topic, [])
            elif isinstance(rec, Message):
                topic = channels.get(rec.channel_id)
                if topic is None and scan.skipped:  # its Channel record was in a lost chunk
                    if summary is None:
                        summary = _summary_of(path) or False
                    ch = summary.channels.get(rec.channel_id) if summary else None
                    if ch is not None:
                        topic = channels[rec.channel_id] = ch.topic
                        schema = summary.schemas.get(ch.schema_id)
                        run.schemas[topic] = schema.name if schema is not None else ""
                        run.messages.setdefault(topic, [])
                if topic is not None:
                    run.messages[topic].append(orjson.loads(rec.data))
            elif isinstance(rec, Metadata):
                run.metadata[rec.name] = dict(rec.metadata)
            elif isinstance(rec, DataEnd):
                in_summary = True
            elif isinstance(rec, Statistics):
                stats = rec
            elif isinstance(rec, Footer):
                # The stream reader checks the closing magic right after this record.
                in_summary = True
        run.complete = in_summary and scan.footer
    except Exception as exc:  # e.g. a message that is not JSON
        run.error = _why(exc)
    run.skipped = list(scan.skipped)
    run.first_log_ns = scan.first_log_ns
    if scan.error and not run.error:
        run.error = scan.error
    if run.skipped:
        lost = "; ".join(r.describe() for r in run.skipped)
        run.error = f"skipped {len(run.skipped)} damaged range(s): {lost}" + (
            f" (reader: {run.error})" if run.error else ""
        )
    run.complete = run.complete and not run.error
    run.truncated = not run.complete
    if stats is not None:
        run.statistics = {
            channels.get(cid, str(cid)): int(n) for cid, n in stats.channel_message_counts.items()
        }
        read = {t: len(m) for t, m in run.messages.items() if m}
        run.statistics_ok = read == {t: n for t, n in run.statistics.items() if n}
        if not run.statistics_ok and not run.error:
            run.error = f"summary statistics {run.statistics} differ from the messages read {read}"
    return run


def recover(path: Path, out: Path, skipped: list[SkippedRange] | None = None) -> int:
    """Rewrite a truncated or damaged run log as a complete MCAP file; return the messages kept.

    Every record that :class:`RecordScan` reads (mcap's stream reader; a damaged chunk in the
    middle skipped, the chunks after it kept) is written again with mcap's
    :class:`~mcap.writer.Writer`: the Header's profile, schemas, channels (topic, encodings,
    metadata), messages (log and publish time, sequence, data) and metadata, then a fresh
    summary, Footer and closing magic. A channel or schema whose record was in a lost chunk
    is taken from the file's summary section when it has one, and so is metadata that is
    only listed there. This is what ``mcap recover`` of mcap's Go CLI does for a file cut
    inside its data, with damaged chunks skipped instead of ending the recovery.

    Parameters
    ----------
    path, out : Path
        The damaged file and the file to write.
    skipped : list of SkippedRange, optional
        Gets the byte ranges that were skipped (give a list to learn them).

    Raises
    ------
    NotMcapError
        If ``path`` does not start with the MCAP magic.
    """
    check_magic(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    n = 0
    scan = RecordScan(path)
    summary: Any = None
    with open(out, "wb") as stream:
        writer = Writer(stream, chunk_size=256 * 1024, compression=CompressionType.ZSTD)
        schema_ids: dict[int, int] = {}
        channel_ids: dict[int, int] = {}
        metadata_names: set[str] = set()
        started = False

        def add_schema(rec: Schema) -> None:
            schema_ids[rec.id] = writer.register_schema(rec.name, rec.encoding, rec.data)

        def add_channel(rec: Channel) -> None:
            channel_ids[rec.id] = writer.register_channel(
                topic=rec.topic,
                message_encoding=rec.message_encoding,
                schema_id=schema_ids.get(rec.schema_id, 0),
                metadata=dict(rec.metadata),
            )

        records = scan.records()
        try:
            for rec in records:
                if isinstance(rec, Header):
                    writer.start(profile=rec.profile, library=rec.library or "fowt-hil")
                    started = True
                elif isinstance(rec, DataEnd | Footer):
                    break
                elif not started:
                    continue
                elif isinstance(rec, Schema) and rec.id not in schema_ids:
                    add_schema(rec)
                elif isinstance(rec, Channel) and rec.id not in channel_ids:
                    add_channel(rec)
                elif isinstance(rec, Message):
                    if rec.channel_id not in channel_ids and scan.skipped:
                        # Its Channel record was in a lost chunk: the summary's, if any.
                        if summary is None:
                            summary = _summary_of(path) or False
                        ch = summary.channels.get(rec.channel_id) if summary else None
                        if ch is not None:
                            sch = summary.schemas.get(ch.schema_id)
                            if sch is not None and sch.id not in schema_ids:
                                add_schema(sch)
                            add_channel(ch)
                    if rec.channel_id in channel_ids:
                        writer.add_message(
                            channel_id=channel_ids[rec.channel_id],
                            log_time=rec.log_time,
                            data=rec.data,
                            publish_time=rec.publish_time,
                            sequence=rec.sequence,
                        )
                        n += 1
                elif isinstance(rec, Metadata):
                    writer.add_metadata(rec.name, dict(rec.metadata))
                    metadata_names.add(rec.name)
        except Exception:  # a record the scan let through but that does
            pass  # not rewrite: everything before it is kept, and the file is still closed
        finally:
            records.close()  # the scan's skipped ranges are final once it is closed
        if not started:
            writer.start(profile=PROFILE, library="fowt-hil")
        if scan.skipped:
            _add_indexed_metadata(path, writer, metadata_names)
        writer.finish()
    if skipped is not None:
        skipped.extend(scan.skipped)
    return n


def _add_indexed_metadata(path: Path, writer: Writer, have: set[str]) -> None:
    """Metadata records listed in the file's summary but not read (lost with the damage)."""
    try:
        with open(path, "rb") as fh:
            reader = SeekingReader(fh)
            if reader.get_summary() is None:
                return
            for rec in reader.iter_metadata():
                if rec.name not in have:
                    writer.add_metadata(rec.name, dict(rec.metadata))
                    have.add(rec.name)
    except Exception:  # no readable summary: nothing more to add
        pass
