"""MCAP run logs: one file per run, one writer for every kind of run.

Writing
-------
:class:`RunLog` is the only writer: the real-time and lock-step recorder
(:mod:`hil.nodes.recorder`), the in-process mode's writer child and a campaign worker's
(:mod:`hil.runlog.writer`) and a Hexicon platform's recorder all write through it. Every bus
message goes to a ``cdr`` channel whose schema is the ``ros2msg`` definition generated from
the message's declaration (:mod:`bus_schemas.ros2`): fixed-size binary payloads that
Foxglove and any ROS 2 tool decode, a third of the bytes of the JSON the older files hold
and cheaper to write (docs/recording.md, bench/runlog_encoding.py). ``log_time`` is the
run's wall-clock start plus the message's simulated ``sample_time_ns``, so Foxglove's
timeline is simulated time; ``publish_time`` is when the recorder took it from its
subscriber's queue (at most about 20 ms after it arrived, see :mod:`hil.nodes.recorder`; for a
message that came in a log batch, when the batch was taken), or in process the message's
own publish time. Sequence numbers count per channel.

File layout and crash safety
----------------------------
A file closed by :meth:`RunLog.close` is a complete MCAP file: magic, Header, Schemas,
Channels and Metadata, zstd Chunks each followed by its MessageIndex records, DataEnd,
then the summary section (Schemas, Channels, Statistics, ChunkIndexes, MetadataIndexes,
SummaryOffsets), the Footer and the closing magic, so any MCAP reader opens it (the mcap
package's seeking and non-seeking readers, ``@mcap/core``, Foxglove).

Crash safety comes from :meth:`RunLog.maybe_flush`: every ``flush_interval_s`` (default 0.25
s of wall time; the recorder's 0.15 s) the queued messages are written as a chunk with its
message indexes, and the stream is flushed to the OS. A SIGKILL of the writing process
therefore loses at most the messages of the last ``flush_interval_s`` (plus whatever the
caller had not handed over yet); the file then ends after its last flushed chunk (or inside
a chunk the buffer had started to write) without a summary. Such a file is read by any
sequential reader up to the cut (:func:`read_run`, mcap's ``NonSeekingReader``) and
:func:`recover` rewrites it as a complete file (``fowt recover``; with mcap's Go CLI: ``mcap
recover``).

Reading
-------
:func:`read_run` reads a file front to back with mcap's stream reader through its summary,
Footer and closing magic (:class:`RecordScan`); a ``cdr`` channel's payloads are decoded
with the layout of its own ``ros2msg`` schema (so a file of an older schema version still
reads), a ``json`` channel's (files written before the CDR channels) as JSON. It stops
cleanly at a cut (a run whose recorder was killed still reviews up to its last flushed
chunk), skips a damaged chunk in the middle (bad zstd data, a CRC that does not match, an
unreadable record) and reads the chunks after it, and says so (``truncated``, ``error``,
``skipped``); a file that does not start with the MCAP magic raises :class:`NotMcapError`.
:func:`recover` writes what it reads into
a complete file.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import mmap
import os
import struct
import time
import zlib
from collections.abc import Callable, Generator, Iterator, Mapping
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
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import CompressionType, Writer

from bus_schemas import ros2
from bus_schemas.registry import MESSAGES, MessageType

PROFILE = "fowt-hil"
RAW_SCHEMA_NAME = "fowt.RawPayload"
#: zstd level of :class:`RunLog`. bench/inprocess_speed.py measured levels 1 and 3 on a
#: 600 s LC2 run's chunks (1024 messages, then ~370 kB of JSON each): level 1 was both faster
#: (~540 against ~320 MB/s) and smaller (ratio 7.4 against 6.5) on these small chunks.
ZSTD_LEVEL = 1
#: zstd window and hash table of :class:`RunLog` [log2 bytes / entries]. 18 and 12 (a
#: 256 kB window, a 16 kB hash table that stays in the core's caches) compressed a real LC2
#: run's JSON chunks faster than level 1's own tables at the same ratio (measured with the
#: JSON writer); a CDR chunk (~170 kB) fits the window whole. Any zstd decoder reads it.
ZSTD_WINDOW_LOG = 18
ZSTD_HASH_LOG = 12

#: The 8 bytes every MCAP file starts and ends with.
MCAP_MAGIC = b"\x89MCAP0\r\n"


class NotMcapError(ValueError):
    """The file is not an MCAP file (it does not start with the MCAP magic)."""


@dataclass
class _Channel:
    """A channel of :class:`RunLog`: its record, message type (None: a JSON channel) and the
    messages queued for the next chunk (parts in publish order)."""

    record: Channel
    mt: MessageType | None
    #: Queued parts: ``("rows", rows, publish_unix_ns)``, ``("structs", [tuple], [int])`` or
    #: ``("json", [(data, log_time, publish_time)], None)``.
    parts: list[tuple[str, Any, Any]] = field(default_factory=list)
    queued: int = 0


class RunLog:
    """The writer of every run log: real-time recorder, in-process writer, campaigns, Hexicon.

    A message of a registered type goes to a ``cdr`` channel with a ``ros2msg`` schema
    (:mod:`bus_schemas.ros2`; schema and channel metadata carry the schema version and
    message id); a few records that are not bus messages (the raw CAN frames) go to a
    ``json`` channel with a JSON Schema (:meth:`add_json_channel`). Messages are queued per
    channel, one by one (:meth:`write`: a Struct, kept as a tuple) or many at once
    (:meth:`write_rows`: rows of ``row_dtype``), and written as one Chunk per :meth:`flush`:
    per channel its queued messages become one numpy record array (the 31-byte MCAP
    Message record header, then the CDR payload, :func:`bus_schemas.ros2.encode_rows`),
    the channels' arrays one after the other (a channel's messages in publish order;
    channels in ascending id), followed by one MessageIndex per channel. Sequence numbers
    count per channel from 0 (MCAP ``sequence``); ``log_time`` is the run's wall-clock
    start plus the message's simulated ``sample_time_ns`` (Foxglove's timeline is
    simulated time); ``publish_time`` is what the caller gives (the recorder: when it took
    the message from its queue; in process: the message's own publish time on the unix
    epoch).

    The structural records (Header, Schemas, Channels, Metadata, DataEnd, the summary
    section, Footer) are written with the mcap package's record classes; only the message
    records and their indexes are built here, with numpy (no per-message Python work for
    rows; 0.78 us of CPU a message in the in-process writer child, zstd included,
    bench/runlog_encoding.py).

    Crash safety: :meth:`write` flushes a chunk every ``flush_interval_s`` of wall time or
    ``batch_messages`` messages (:meth:`maybe_flush`), and every chunk is handed to the OS
    as it is written, so a SIGKILL loses at most what was queued since the last one; the
    file then reads up to its last chunk and :func:`recover` closes it.

    Parameters
    ----------
    path : Path
        Output file (created, parent directories made).
    turbine : str or None
        Turbine id: registers one channel per :data:`~bus_schemas.registry.MESSAGES` type
        under ``fowt/<turbine>/<suffix>``. None: no channel (add them with
        :meth:`add_channel`, e.g. a platform's).
    start_unix_ns : int, optional
        Wall-clock time of simulated t = 0 (default: now).
    flush_interval_s : float
        Wall seconds between the chunks :meth:`write` flushes.
    compression : str
        ``"zstd"`` (default), ``"lz4"`` or ``""`` (none).
    batch_messages : int
        Queued messages that make :meth:`write` flush a chunk whatever the time.
    profile, library : str
        The Header's profile and library.
    """

    def __init__(
        self,
        path: Path,
        turbine: str | None,
        start_unix_ns: int | None = None,
        flush_interval_s: float = 0.25,
        *,
        compression: str = "zstd",
        batch_messages: int = 1024,
        profile: str = PROFILE,
        library: str = "fowt-hil",
    ) -> None:
        if compression not in COMPRESSIONS:
            raise ValueError(f"compression {compression!r}: expected one of {COMPRESSIONS}")
        if batch_messages < 1:
            raise ValueError(f"batch_messages: expected an integer >= 1, got {batch_messages}")
        self._compress = _compressor(compression)
        self.compression = compression
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self.turbine = turbine or ""
        self.start_unix_ns = time.time_ns() if start_unix_ns is None else start_unix_ns
        self._stream: IO[bytes] = open(path, "wb")  # noqa: SIM115 - closed in close()
        self._stream.write(MCAP_MAGIC)
        self._builder = RecordBuilder()
        Header(profile=profile, library=library).write(self._builder)
        self._schemas: list[Schema] = []
        self._schema_of: dict[str, int] = {}
        self._channels: list[_Channel] = []
        self._by_topic: dict[str, int] = {}
        self._seq: list[int] = [0]  # per channel id (0: none)
        self._counts: list[int] = [0]
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._start_time: int | None = None
        self._end_time = 0
        #: Messages handed to the log (written, or queued for the next chunk).
        self.count = 0
        self._queued = 0
        self._closed = False
        self.batch_messages = batch_messages
        self._flush_interval_ns = int(flush_interval_s * 1e9)
        self._last_flush_ns = time.monotonic_ns()
        #: Channel id per message id of the turbine's own channels (0: none).
        self.channel_of_message_id = np.zeros(max(mt.message_id for mt in MESSAGES) + 1, np.int64)
        if turbine is not None:
            for mt in MESSAGES:
                self.channel_of_message_id[mt.message_id] = self.add_channel(mt.key(turbine), mt)
        self._write_records()

    # ------------------------------------------------------------------ channels
    def _schema(self, name: str, encoding: str, data: bytes) -> int:
        sid = self._schema_of.get(name)
        if sid is None:
            schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
            self._schemas.append(schema)
            schema.write(self._builder)
            sid = self._schema_of[name] = schema.id
        return sid

    def _channel(
        self, topic: str, encoding: str, sid: int, mt: MessageType | None, meta: dict[str, str]
    ) -> int:
        if topic in self._by_topic:
            raise ValueError(f"channel {topic!r} is registered already")
        rec = Channel(
            id=len(self._channels) + 1,
            topic=topic,
            message_encoding=encoding,
            schema_id=sid,
            metadata=meta,
        )
        rec.write(self._builder)
        self._write_records()
        self._channels.append(_Channel(rec, mt))
        self._by_topic[topic] = rec.id
        self._seq.append(0)
        self._counts.append(0)
        return rec.id

    def add_channel(self, topic: str, mt: MessageType) -> int:
        """Register a ``cdr`` channel of a registered message type; return its id.

        Its schema is ``mt``'s ros2msg (:func:`bus_schemas.ros2.msgdef`, one Schema record
        per type); the channel's metadata give the schema version, message id and
        encoding version (:data:`CDR_ENCODING_VERSION`).
        """
        sid = self._schema(ros2.schema_name(mt), "ros2msg", ros2.msgdef(mt).encode())
        meta = {
            "version": str(mt.version),
            "message_id": str(mt.message_id),
            "encoding_version": CDR_ENCODING_VERSION,
        }
        return self._channel(topic, "cdr", sid, mt, meta)

    def add_json_channel(self, topic: str, schema_name: str, json_schema: dict[str, Any]) -> int:
        """Register a ``json`` channel with a JSON Schema (records that are not bus
        messages, e.g. raw CAN frames); return its id."""
        sid = self._schema(schema_name, "jsonschema", json.dumps(json_schema).encode())
        return self._channel(topic, "json", sid, None, {})

    def channel_for(self, key: str) -> tuple[int, MessageType | None] | None:
        """The channel id and message type (None: a JSON channel) registered for a topic."""
        cid = self._by_topic.get(key)
        return None if cid is None else (cid, self._channels[cid - 1].mt)

    # ------------------------------------------------------------------ messages
    def _queue(self, ch: _Channel, kind: str, item: Any, publish: Any) -> None:
        parts = ch.parts
        if parts and parts[-1][0] == kind and kind != "rows":
            parts[-1][1].append(item)
            if publish is not None:
                parts[-1][2].append(publish)
        else:
            parts.append((kind, [item], None if publish is None else [publish]))

    def write(self, key: str, msg: Any, receive_unix_ns: int | None = None) -> None:
        """Queue one message (a registered Struct) under its topic; flush a chunk when due
        (:meth:`maybe_flush`). ``receive_unix_ns``: its ``publish_time`` (default: now).

        Raises ``KeyError`` for a topic of no channel and ``ValueError`` (nothing queued)
        for a ``uint64`` field above ``2**63 - 1`` (the rows are int64; no run counts so far)
        or a ``sample_time_ns`` whose log time (the run's start plus it) would pass it.
        """
        cid = self._by_topic.get(key)
        if cid is None:
            raise KeyError(f"no channel registered for key {key!r}")
        ch = self._channels[cid - 1]
        if ch.mt is None:
            raise KeyError(f"channel {key!r} is a JSON channel: use write_json")
        recv = time.time_ns() if receive_unix_ns is None else receive_unix_ns
        values = msgspec.structs.astuple(msg)
        for i in _wide_fields(ch.mt):
            if values[i] > _I64_MAX:  # a row holds int64 (the codec allows up to 2**64 - 1)
                name = ch.mt.cls.__struct_fields__[i]
                raise ValueError(f"{ch.mt.name}.{name} = {values[i]} does not fit the run log")
        sample_ns = getattr(msg, "sample_time_ns", 0)
        if sample_ns > _I64_MAX - self.start_unix_ns:  # the log time (start + it) is int64
            raise ValueError(
                f"{ch.mt.name}.sample_time_ns = {sample_ns} puts its log time past 2**63 - 1"
            )
        self._queue(ch, "structs", values, recv)
        ch.queued += 1
        self._queued += 1
        self.count += 1
        self.maybe_flush()

    def write_json(self, cid: int, data: bytes, sample_time_ns: int, receive_unix_ns: int) -> None:
        """Queue one JSON message on a channel of :meth:`add_json_channel` (then as
        :meth:`write`)."""
        ch = self._channels[cid - 1]
        if ch.mt is not None:
            raise ValueError(f"channel {ch.record.topic!r} is not a JSON channel")
        self._queue(ch, "json", (data, self.start_unix_ns + sample_time_ns, receive_unix_ns), None)
        ch.queued += 1
        self._queued += 1
        self.count += 1
        self.maybe_flush()

    def write_rows(self, cid: int, rows: np.ndarray, publish_unix_ns: np.ndarray | int) -> None:
        """Queue many messages of a ``cdr`` channel as rows (its type's ``row_dtype``, in
        publish order) with their publish times [ns, unix]; written by the next
        :meth:`flush` (no flush here: the caller decides where a chunk ends)."""
        ch = self._channels[cid - 1]
        if ch.mt is None:
            raise ValueError(f"channel {ch.record.topic!r} is not a CDR channel")
        if rows.ndim != 1 or rows.dtype.names != ch.mt.row_dtype.names:
            raise ValueError(f"write_rows: {ch.mt.name} rows must be 1-D {ch.mt.row_dtype}")
        if len(rows):
            ch.parts.append(("rows", rows, publish_unix_ns))
            ch.queued += len(rows)
            self._queued += len(rows)
            self.count += len(rows)

    def _records(self, cid: int, ch: _Channel, at: int) -> tuple[list[Any], np.ndarray, np.ndarray]:
        """A channel's queued messages as Message records; their log times and offsets."""
        out: list[Any] = []
        logs: list[np.ndarray] = []
        offs: list[np.ndarray] = []
        seq = self._seq[cid]
        for kind, items, publish in ch.parts:
            if kind == "json":
                hdr = struct.Struct("<BQHIQQ")
                for data, log_time, pub in items:
                    rec = hdr.pack(
                        _OP_MESSAGE, 22 + len(data), cid, seq & 0xFFFFFFFF, log_time, pub
                    )
                    logs.append(np.array([log_time], np.int64))
                    offs.append(np.array([at], np.int64))
                    out.append(rec + data)
                    at += len(rec) + len(data)
                    seq += 1
                continue
            mt = ch.mt
            assert mt is not None
            rows = items if kind == "rows" else np.array(items, mt.row_dtype)
            n = len(rows)
            recs = np.empty(n, _record_dtype(mt))
            size = recs.dtype.itemsize
            log_time = self.start_unix_ns + rows["sample_time_ns"].astype(np.int64)
            recs["opcode"] = _OP_MESSAGE
            recs["length"] = size - 9
            recs["channel_id"] = cid
            recs["sequence"] = (seq + np.arange(n, dtype=np.int64)) & 0xFFFFFFFF
            recs["log_time"] = log_time
            recs["publish_time"] = publish
            payload = ros2.encode_rows(mt, rows)
            recs["payload"] = payload.view(recs.dtype["payload"])
            logs.append(log_time)
            offs.append(at + size * np.arange(n, dtype=np.int64))
            out.append(recs)
            at += size * n
            seq += n
        self._seq[cid] = seq
        return out, np.concatenate(logs), np.concatenate(offs)

    def flush(self) -> None:
        """Write the queued messages as one Chunk with its MessageIndexes and hand the file
        to the OS."""
        if self._queued:
            self._write_chunk()
        self._stream.flush()
        self._last_flush_ns = time.monotonic_ns()

    def maybe_flush(self) -> None:
        """Flush if ``flush_interval_s`` has passed since the last chunk, or ``batch_messages``
        are queued."""
        if (
            self._queued >= self.batch_messages
            or time.monotonic_ns() - self._last_flush_ns >= self._flush_interval_ns
        ):
            self.flush()

    def _write_chunk(self) -> None:
        parts: list[Any] = []
        index: list[tuple[int, np.ndarray, np.ndarray]] = []
        at = 0
        for cid, ch in enumerate(self._channels, start=1):
            if not ch.queued:
                continue
            recs, logs, offs = self._records(cid, ch, at)
            parts.extend(recs)
            index.append((cid, logs, offs))
            self._counts[cid] += ch.queued
            ch.parts = []
            ch.queued = 0
            at += sum(p.nbytes if isinstance(p, np.ndarray) else len(p) for p in recs)
        records = b"".join(p.tobytes() if isinstance(p, np.ndarray) else p for p in parts)
        self._queued = 0
        start = min(int(lg.min()) for _, lg, _ in index)
        end = max(int(lg.max()) for _, lg, _ in index)
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
        out = []
        pos = index_start
        for cid, logs, offs in index:
            k = len(logs)
            entries = np.empty((k, 2), np.int64)
            entries[:, 0] = logs
            entries[:, 1] = offs
            part = (
                struct.pack("<BQHI", _OP_MESSAGE_INDEX, 6 + 16 * k, cid, 16 * k) + entries.tobytes()
            )
            index_offsets[cid] = pos
            pos += len(part)
            out.append(part)
        stream.write(b"".join(out))
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

    def _write_records(self) -> None:
        self._stream.write(self._builder.end())

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Add a metadata record (scenario, run information, counters) and flush it."""
        offset = self._stream.tell()
        Metadata(name=name, metadata=data).write(self._builder)
        self._metadata_indexes.append(
            MetadataIndex(offset=offset, length=self._builder.count, name=name)
        )
        self._write_records()
        self._stream.flush()

    def close(self) -> None:
        """Flush, write DataEnd, the summary section, Footer and closing magic, close the file
        (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            if self._queued:
                self._write_chunk()
            self._finish()
        finally:
            self._stream.close()

    def _finish(self) -> None:
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

        counts = {cid: n for cid, n in enumerate(self._counts) if n}
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
        group(Opcode.CHANNEL, [c.record for c in self._channels])
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


#: Bytes of an MCAP Message record before its data: opcode (1), record length (8),
#: channel id (2), sequence (4), log time (8), publish time (8).
MESSAGE_HEADER_BYTES = 31
_OP_MESSAGE, _OP_CHUNK, _OP_MESSAGE_INDEX = 0x05, 0x06, 0x07
#: Compressions :class:`RunLog` can write ("" = none).
COMPRESSIONS = ("zstd", "lz4", "")
#: The ``encoding_version`` in a CDR channel's metadata: 2 since the per-cycle channels
#: became ros2msg + CDR (1: the JSON channels of older files, which had none).
CDR_ENCODING_VERSION = "2"


_I64_MAX = 2**63 - 1


@functools.cache
def _wide_fields(mt: MessageType) -> tuple[int, ...]:
    """Indices of ``mt``'s ``u64`` fields (the only ones whose range exceeds int64)."""
    return tuple(i for i, f in enumerate(mt.codec.fields) if f.wire == "u64")


@functools.cache
def _record_dtype(mt: MessageType) -> np.dtype[np.void]:
    """A whole MCAP Message record of ``mt``: the packed 31-byte header, then the payload."""
    return np.dtype(
        [
            ("opcode", "u1"),
            ("length", "<u8"),
            ("channel_id", "<u2"),
            ("sequence", "<u4"),
            ("log_time", "<u8"),
            ("publish_time", "<u8"),
            ("payload", f"V{ros2.cdr_dtype(mt).itemsize}"),  # raw bytes: padding copied too
        ]
    )


def _compressor(compression: str) -> Callable[[bytes], bytes]:
    """The chunk compressor of ``compression`` (:data:`COMPRESSIONS`)."""
    if compression == "zstd":
        import zstandard  # noqa: PLC0415

        params = zstandard.ZstdCompressionParameters.from_level(
            ZSTD_LEVEL, window_log=ZSTD_WINDOW_LOG, hash_log=ZSTD_HASH_LOG
        )
        return zstandard.ZstdCompressor(compression_params=params).compress
    if compression == "lz4":
        try:
            import lz4.frame  # type: ignore[import-untyped]  # noqa: PLC0415
        except ImportError as exc:  # not a dependency: mcap's writer makes it optional too
            raise ValueError("compression 'lz4': the lz4 package is not installed") from exc
        return lz4.frame.compress
    return bytes


class MessageList(list[dict[str, Any]]):
    """A topic's messages (dicts, a plain list's contents) that also know their fields as
    columns, for messages that came as rows (a campaign's in-process run).

    ``parts`` are ``(start, stop, rows)``: messages ``start:stop`` of the list are the
    dicts of ``rows`` (a ``row_dtype`` array), or ``rows`` is None for dicts from anywhere
    else. :meth:`column` is ``np.array([m.get(name, nan) for m in self], float64)``
    (:func:`hil.review.core._col`'s value: a missing field, None, NaN or an infinity gives nan)
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
    #: Messages lost with the range: from the file's own indexes (the summary's chunk
    #: indexes, or the MessageIndex records after a damaged chunk); None when not known.
    messages: int | None = None

    def lost_line(self) -> str:
        """``100 messages lost in bytes 1234-5678 (...)`` (or ``unknown number lost in ...``)."""
        count = "unknown number" if self.messages is None else f"{self.messages} messages"
        return f"{count} lost in {self.describe()}"

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
        #: Byte offsets of the Chunk records that opened (their messages were yielded).
        self.opened_chunks: set[int] = set()

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
                lost: int | None = None  # a damaged chunk's range, while its indexes follow
                try:
                    for rec in reader.records:
                        end = fh.tell()
                        if isinstance(rec, MessageIndex) and lost is not None:
                            # The damaged chunk's MessageIndex records say how many it held.
                            r = self.skipped[lost]
                            got = (r.messages or 0) + len(rec.records)
                            self.skipped[lost] = dataclasses.replace(r, messages=got)
                            start = end
                            continue
                        lost = None
                        if isinstance(rec, Chunk):
                            before = len(self.skipped)
                            inner, resume = self._open_chunk(fh, rec, start, end, size)
                            if resume is not None:
                                break
                            if len(self.skipped) > before:
                                lost = before
                            else:
                                self.opened_chunks.add(start)
                            yield from inner
                        elif rec is None:
                            # mcap's reader passes over a record of an unknown opcode; this
                            # bench's writer never writes one, so it is damage (a chunk's
                            # opcode byte, say) and its content is not known.
                            (op,) = os.pread(fh.fileno(), 1, start) or b"\0"
                            why = f"record of unknown opcode 0x{op:02x}"
                            self.skipped.append(SkippedRange(start, end, why))
                        else:
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
    schemas: dict[int, Schema] = {}
    # Per CDR channel id: its payload layout and its payloads so far (decoded at the end,
    # all at once: _cdr_messages).
    cdr: dict[int, tuple[np.dtype[np.void], bytearray]] = {}
    in_summary = False
    stats: Statistics | None = None
    scan = RecordScan(path)
    summary: Any = None

    def add_channel(rec: Channel, schema: Schema | None) -> None:
        channels[rec.id] = rec.topic
        run.schemas[rec.topic] = schema.name if schema is not None else ""
        run.messages.setdefault(rec.topic, [])
        if rec.message_encoding == "cdr":
            if schema is None or schema.encoding != "ros2msg":
                raise ValueError(f"channel {rec.topic}: cdr without a ros2msg schema")
            cdr[rec.id] = (ros2.dtype_of_msgdef(schema.data.decode()), bytearray())

    try:
        for rec in scan.records():
            if isinstance(rec, Header):
                run.profile = rec.profile
            elif isinstance(rec, Schema):
                schemas[rec.id] = rec
            elif isinstance(rec, Channel):
                if not in_summary and rec.id not in channels:
                    add_channel(rec, schemas.get(rec.schema_id))
            elif isinstance(rec, Message):
                cid = rec.channel_id
                if cid not in channels and scan.skipped:  # its Channel was in a lost chunk
                    if summary is None:
                        summary = _summary_of(path) or False
                    ch = summary.channels.get(cid) if summary else None
                    if ch is not None:
                        add_channel(ch, summary.schemas.get(ch.schema_id))
                topic = channels.get(cid)
                if topic is None:
                    continue
                layout = cdr.get(cid)
                if layout is None:
                    run.messages[topic].append(orjson.loads(rec.data))
                elif len(rec.data) != layout[0].itemsize:
                    raise ros2.CdrLengthError(
                        f"{topic}: a {len(rec.data)}-byte payload, its schema's is "
                        f"{layout[0].itemsize} bytes"
                    )
                else:
                    layout[1].extend(rec.data)
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
    except Exception as exc:  # e.g. a message that is not JSON, a payload of another size
        run.error = _why(exc)
    for cid, (dtype, data) in cdr.items():
        run.messages[channels[cid]] = _cdr_messages(dtype, data)
    finish_read(run, scan, stats, channels, {t: len(m) for t, m in run.messages.items()})
    return run


def finish_read(
    target: Any,
    scan: RecordScan,
    stats: Statistics | None,
    topics: Mapping[int, str],
    counts: Mapping[str, int],
) -> None:
    """The end of a read (:func:`read_run`, :class:`hil.runlog.columns.ColumnReader`).

    Sets on ``target`` (a :class:`RunData` or a column reader's info) the skipped ranges,
    the first log time, the error (the scan's, and the damage), ``complete`` and
    ``truncated``, and checks the messages read (``counts`` per topic) against the summary
    ``stats`` (``topics``: channel id to topic).
    """
    target.skipped = list(scan.skipped)
    target.first_log_ns = scan.first_log_ns
    if scan.error and not target.error:
        target.error = scan.error
    if target.skipped:
        lost = "; ".join(r.describe() for r in target.skipped)
        target.error = f"skipped {len(target.skipped)} damaged range(s): {lost}" + (
            f" (reader: {target.error})" if target.error else ""
        )
    target.complete = target.complete and not target.error
    target.truncated = not target.complete
    if stats is not None:
        target.statistics = {
            topics.get(cid, str(cid)): int(n) for cid, n in stats.channel_message_counts.items()
        }
        read = {t: n for t, n in counts.items() if n}
        target.statistics_ok = read == {t: n for t, n in target.statistics.items() if n}
        if not target.statistics_ok and not target.error:
            target.error = (
                f"summary statistics {target.statistics} differ from the messages read {read}"
            )


def _cdr_messages(dtype: np.dtype[np.void], data: bytearray) -> MessageList:
    """A CDR channel's payloads as the dicts a JSON channel's give: field name to Python int
    or float in declaration order, a non-finite float None (as the JSON channels wrote it),
    their columns kept (:class:`MessageList`)."""
    recs = ros2.decode_as(dtype, bytes(data))
    names = list(dtype.names or ())[1:]  # without the encapsulation header
    rows = recs[names]
    messages = [dict(zip(names, t, strict=True)) for t in rows.tolist()]
    for name in names:
        if rows.dtype[name].kind == "f":
            for i in np.flatnonzero(~np.isfinite(rows[name])).tolist():
                messages[i][name] = None
    return MessageList(messages, [(0, len(messages), rows)])


@dataclass(frozen=True)
class Recovery:
    """What :func:`recover_report` kept and lost.

    ``kept`` messages were written; ``expected`` is the input's own count (its Statistics
    record) when it has a readable summary, else None; ``lost`` lists the ranges whose
    messages are missing from the output, each with its count (None: not known).
    """

    kept: int
    expected: int | None
    lost: tuple[SkippedRange, ...]

    @property
    def complete(self) -> bool:
        """Every message of the input is in the output (known, not assumed)."""
        if any(r.messages is None for r in self.lost):
            return False
        if self.expected is not None and self.kept < self.expected:
            return False
        return sum(r.messages or 0 for r in self.lost) == 0

    @property
    def lost_count(self) -> int | None:
        """Messages lost in all; None when a range's count is not known."""
        if any(r.messages is None for r in self.lost):
            return None
        return sum(r.messages or 0 for r in self.lost)


def recover(path: Path, out: Path, skipped: list[SkippedRange] | None = None) -> int:
    """Rewrite a truncated or damaged run log as a complete MCAP file; return the messages kept.

    See :func:`recover_report`; ``skipped`` (give a list to learn them) gets its lost ranges.
    """
    rec = recover_report(path, out)
    if skipped is not None:
        skipped.extend(rec.lost)
    return rec.kept


def recover_report(path: Path, out: Path) -> Recovery:
    """Rewrite a truncated or damaged run log as a complete MCAP file; say what was lost.

    Every record that :class:`RecordScan` reads (mcap's stream reader; a damaged chunk in the
    middle skipped, the chunks after it kept) is written again with mcap's
    :class:`~mcap.writer.Writer`: the Header's profile, schemas, channels (topic, encodings,
    metadata), messages (log and publish time, sequence, data) and metadata, then a fresh
    summary, Footer and closing magic. A channel or schema whose record was in a lost chunk
    is taken from the file's summary section when it has one, and so is metadata that is
    only listed there. This is what ``mcap recover`` of mcap's Go CLI does for a file cut
    inside its data, with damaged chunks skipped instead of ending the recovery.

    What was lost is counted from the input's own indexes, never assumed to be nothing:

    * with a readable summary section, every chunk its chunk indexes list that did not open
      where they say is lost, with the messages its MessageIndex records count (a damaged
      chunk header, whatever the reader made of it, is counted there); the Statistics
      record's total checks the sum (a single chunk of unreadable indexes gets the rest);
    * without one (a cut file, a damaged footer or summary), each skipped range counts the
      MessageIndex records that follow its chunk, else its count is unknown; a file that
      ends before its DataEnd record has lost an unknown number at its end.

    Parameters
    ----------
    path, out : Path
        The damaged file and the file to write.

    Returns
    -------
    Recovery
        The messages kept, the input's total when known, and the lost ranges.

    Raises
    ------
    NotMcapError
        If ``path`` does not start with the MCAP magic.
    """
    check_magic(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    n = 0
    ended = False  # the DataEnd (or Footer) record was read: the data section is whole
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
                    ended = True
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
    return _account(path, scan, ended, n)


def _account(path: Path, scan: RecordScan, ended: bool, kept: int) -> Recovery:
    """The ranges whose messages :func:`recover_report` did not keep, each counted."""
    size = path.stat().st_size
    summary = _summary_of(path)
    chunks = list(summary.chunk_indexes) if summary is not None else []
    if not chunks:  # no summary (a cut file) or no chunk in it: what the scan counted
        lost = list(scan.skipped)
        if not ended and not any(r.to_end for r in lost):
            # Cut between two records: whatever the writer had not yet written is gone.
            at = max((r.end for r in lost), default=size)
            why = "the file ends before its DataEnd record (its writer did not finish)"
            lost.append(SkippedRange(min(at, size), size, why, to_end=True))
        expected = None
        if summary is not None and summary.statistics is not None:
            expected = summary.statistics.message_count
        return Recovery(kept, expected, tuple(lost))
    lost = []
    with open(path, "rb") as fh:
        for ci in chunks:
            if ci.chunk_start_offset in scan.opened_chunks:
                continue
            a, b = ci.chunk_start_offset, ci.chunk_start_offset + ci.chunk_length
            why = next(
                (r.reason for r in scan.skipped if r.start < b and a < r.end),
                "chunk not read where its chunk index says it is",
            )
            r = SkippedRange(a, b, why, ci.message_start_time, ci.message_end_time)
            lost.append(
                dataclasses.replace(
                    r, first_log_ns=scan.first_log_ns, messages=_index_count(fh, ci)
                )
            )
    # Damage outside every lost chunk (between records, in the indexes) lost no message
    # the summary knows of; it is listed all the same.
    for r in scan.skipped:
        if not any(x.start < r.end and r.start < x.end for x in lost):
            lost.append(dataclasses.replace(r, messages=0))
    expected = summary.statistics.message_count if summary.statistics is not None else None
    if expected is not None:
        unknown = [i for i, r in enumerate(lost) if r.messages is None]
        deficit = expected - kept - sum(r.messages or 0 for r in lost)
        if len(unknown) == 1 and deficit >= 0:
            lost[unknown[0]] = dataclasses.replace(lost[unknown[0]], messages=deficit)
        elif deficit > 0 and not unknown:
            why = "messages the Statistics record counts that no readable chunk holds"
            lost.append(SkippedRange(0, size, why, messages=deficit))
    lost.sort(key=lambda r: r.start)
    return Recovery(kept, expected, tuple(lost))


def _index_count(fh: IO[bytes], ci: ChunkIndex) -> int | None:
    """Messages of the chunk ``ci`` indexes, from its MessageIndex records (None: damaged)."""
    total = 0
    for channel_id, offset in ci.message_index_offsets.items():
        fh.seek(offset)
        head = fh.read(15)
        if len(head) < 15:
            return None
        op, length, channel, n_bytes = struct.unpack("<BQHI", head)
        # An entry is a log time and an offset (16 B); the record is its channel id and
        # the entries' byte length.
        if op != _OP_MESSAGE_INDEX or channel != channel_id or length != 6 + n_bytes:
            return None
        if n_bytes % 16:
            return None
        total += n_bytes // 16
    return total


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
