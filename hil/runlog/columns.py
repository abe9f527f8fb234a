"""A run log read as columns, chunk by chunk: the review's streaming reader.

:func:`hil.runlog.mcap_io.read_run` keeps every message as a dict, about 0.25 MB per simulated
second of an LC2 run. The review needs a few fields of a few channels, most of them only
as running statistics, so :class:`ColumnReader` hands them over one MCAP chunk at a time
as float64 columns (:class:`ColumnBatch`) and keeps nothing itself but counts: its
memory does not grow with the run's length.

Records come from :class:`hil.runlog.mcap_io.RecordScan` in its ``raw_messages`` mode (damaged
chunks skipped and listed as for ``read_run``; each chunk's message payloads grouped by
channel without a record object per message). A channel's payloads are decoded by its
message encoding:

``json``
    msgspec decodes the chunk's messages of the channel as one JSON array into a Struct
    holding only the wanted fields (each ``float | None``, default nan; other keys are
    skipped by the decoder), and numpy turns the Structs' tuples into an ``(n, k)`` float64
    array. A field that is missing, ``null`` (msgspec writes a non-finite float so) reads as
    nan, as :func:`hil.review.core._col` gives it from dicts.
``cdr``
    The payloads are fixed-size records (:func:`bus_schemas.ros2.cdr_dtype` of the
    channel's registered message type): one ``np.frombuffer`` of their concatenation.

A :class:`ColumnBatch` also gives any of its messages as a dict (:meth:`ColumnBatch.row`),
for the few records the review reads whole (final summaries and reports).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import orjson
from mcap.records import Channel, DataEnd, Footer, Header, Metadata, Schema, Statistics

from hil.runlog.mcap_io import (
    MessageBatch,
    RecordScan,
    RunData,
    SkippedRange,
    _summary_of,
    _why,
    check_magic,
    finish_read,
)

#: Field every channel is read for (the run's duration and the KPI window).
TIME_FIELD = "sample_time_ns"


def suffix_of(topic: str) -> str:
    """``fowt/<turbine>/controller/status`` -> ``controller/status``."""
    parts = topic.split("/", 2)
    return parts[2] if len(parts) == 3 else topic


@dataclass
class ColumnBatch:
    """Some consecutive messages of one topic as float64 columns.

    ``columns[name]`` is field ``name`` of each message (nan where missing or not finite);
    :meth:`row` is message ``i`` as a dict (as :func:`hil.runlog.mcap_io.read_run` has it).
    """

    suffix: str
    topic: str
    #: The first topic of its suffix (the one :meth:`hil.runlog.mcap_io.RunData.topic` gives).
    first: bool
    columns: dict[str, np.ndarray]
    size: int
    _row: Callable[[int], dict[str, Any]]

    def row(self, i: int) -> dict[str, Any]:
        """Message ``i`` of the batch as a dict."""
        return self._row(i)


@dataclass
class RunInfo:
    """What a run log says besides its per-cycle columns (filled while reading).

    ``topics`` are the channels' topics in the order their Channel records came (as the keys
    of :attr:`hil.runlog.mcap_io.RunData.messages`), ``counts`` their messages read; the other
    fields mean what :class:`hil.runlog.mcap_io.RunData`'s do.
    """

    topics: list[str] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    schemas: dict[str, str] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    profile: str | None = None
    truncated: bool = False
    complete: bool = False
    error: str = ""
    statistics: dict[str, int] | None = None
    statistics_ok: bool | None = None
    skipped: list[SkippedRange] = field(default_factory=list)
    first_log_ns: int | None = None


def _struct_decoder(fields: Sequence[str]) -> Any:
    """A msgspec JSON decoder of a list of objects into Structs of ``fields`` only."""
    spec = [(name, float | None, math.nan) for name in fields]
    cls = msgspec.defstruct("Columns", spec)
    return msgspec.json.Decoder(list[cls])  # type: ignore[valid-type]


def _json_columns(
    payloads: list[bytes], fields: Sequence[str], decoder: Any
) -> tuple[dict[str, np.ndarray], int]:
    """Columns of ``payloads`` (JSON objects) and how many decoded; a bad message ends it."""
    try:
        structs = decoder.decode(b"[" + b",".join(payloads) + b"]")
        n = len(structs)
    except (msgspec.DecodeError, msgspec.ValidationError):
        structs = []  # find the first bad one: everything before it is kept
        one = msgspec.json.Decoder(decoder.type.__args__[0])
        for p in payloads:
            try:
                structs.append(one.decode(p))
            except (msgspec.DecodeError, msgspec.ValidationError):
                break
        n = len(structs)
    rows = np.array([msgspec.structs.astuple(s) for s in structs], np.float64)
    rows = rows.reshape(n, len(fields))
    rows[~np.isfinite(rows)] = math.nan
    return {name: rows[:, k] for k, name in enumerate(fields)}, n


class ColumnReader:
    """Read a run log chunk by chunk as columns (module docstring).

    Parameters
    ----------
    path : Path
        The MCAP file (may be truncated or damaged).
    fields : mapping of str to sequence of str
        Topic suffix (``"truth"``, ``"controller/status"``) to the fields wanted as columns.
        Every other topic is read for ``sample_time_ns`` only.

    Raises
    ------
    NotMcapError
        From the constructor, if the file does not start with the MCAP magic.
    """

    def __init__(self, path: Path, fields: Mapping[str, Sequence[str]]) -> None:
        check_magic(path)
        self.path = path
        self.fields = {k: tuple(dict.fromkeys((TIME_FIELD, *v))) for k, v in fields.items()}
        self.info = RunInfo()
        self._decoders: dict[tuple[str, ...], Any] = {}

    def _decoder(self, fields: tuple[str, ...]) -> Any:
        dec = self._decoders.get(fields)
        if dec is None:
            dec = self._decoders[fields] = _struct_decoder(fields)
        return dec

    def batches(self) -> Iterator[ColumnBatch]:
        """Yield every chunk's messages per topic as a :class:`ColumnBatch`, in file order.

        :attr:`ColumnBatch.first` marks the first topic of each suffix (any turbine), the
        one :meth:`hil.runlog.mcap_io.RunData.topic` picks. :attr:`info` is complete once the
        iteration ends.
        """
        info = self.info
        channels: dict[int, tuple[str, str, str]] = {}  # id: topic, encoding, schema name
        schemas: dict[int, Schema] = {}
        first_of: dict[str, str] = {}
        in_summary = False
        stats: Statistics | None = None
        summary: Any = None
        scan = RecordScan(self.path, raw_messages=True)
        records = scan.records()
        try:
            for rec in records:
                if isinstance(rec, MessageBatch):
                    for cid, payloads in rec.payloads.items():
                        ch = channels.get(cid)
                        if ch is None and scan.skipped:  # its Channel record was lost
                            if summary is None:
                                summary = _summary_of(self.path) or False
                            sch = summary.channels.get(cid) if summary else None
                            if sch is not None:
                                schema = summary.schemas.get(sch.schema_id)
                                name = schema.name if schema is not None else ""
                                ch = self._add_channel(channels, cid, sch, name, first_of)
                        if ch is None:
                            continue
                        topic, encoding, schema_name = ch
                        sfx = suffix_of(topic)
                        first = first_of.get(sfx) == topic
                        batch = self._decode(sfx, topic, first, encoding, schema_name, payloads)
                        n = batch.size
                        info.counts[topic] += n
                        if n:
                            yield batch
                        if n < len(payloads):
                            raise ValueError(f"message {info.counts[topic]} of {topic} unreadable")
                elif isinstance(rec, Header):
                    info.profile = rec.profile
                elif isinstance(rec, Schema):
                    schemas[rec.id] = rec
                elif isinstance(rec, Channel):
                    if not in_summary and rec.id not in channels:
                        sch = schemas.get(rec.schema_id)
                        name = sch.name if sch is not None else ""
                        self._add_channel(channels, rec.id, rec, name, first_of)
                elif isinstance(rec, Metadata):
                    info.metadata[rec.name] = dict(rec.metadata)
                elif isinstance(rec, DataEnd):
                    in_summary = True
                elif isinstance(rec, Statistics):
                    stats = rec
                elif isinstance(rec, Footer):
                    in_summary = True
            info.complete = in_summary and scan.footer
        except Exception as exc:  # e.g. a message that is not JSON
            info.error = _why(exc)
        finally:
            records.close()
        self._finish(scan, stats, channels)

    def _add_channel(
        self,
        channels: dict[int, tuple[str, str, str]],
        cid: int,
        rec: Channel,
        schema_name: str,
        first_of: dict[str, str],
    ) -> tuple[str, str, str]:
        info = self.info
        ch = channels[cid] = (rec.topic, rec.message_encoding, schema_name)
        if rec.topic not in info.counts:
            info.topics.append(rec.topic)
            info.counts[rec.topic] = 0
            info.schemas[rec.topic] = schema_name
        first_of.setdefault(suffix_of(rec.topic), rec.topic)
        return ch

    def _decode(
        self,
        sfx: str,
        topic: str,
        first: bool,
        encoding: str,
        schema_name: str,
        payloads: list[bytes],
    ) -> ColumnBatch:
        """The batch of one channel's payloads (fewer when one does not decode)."""
        fields = self.fields.get(sfx, (TIME_FIELD,)) if first else (TIME_FIELD,)
        if encoding == "cdr":
            records = _cdr_records(sfx, schema_name, payloads)
            cols = {}
            for name in fields:
                if name in (records.dtype.names or ()):
                    col = records[name].astype(np.float64)
                    col[~np.isfinite(col)] = math.nan
                else:
                    col = np.full(len(records), math.nan)
                cols[name] = col
            names = [n for n in records.dtype.names or () if not n.startswith("_")]

            def cdr_row(i: int) -> dict[str, Any]:
                r = records[i]
                return {n: r[n].item() for n in names}

            return ColumnBatch(sfx, topic, first, cols, len(records), cdr_row)
        cols, n = _json_columns(payloads, fields, self._decoder(fields))

        def json_row(i: int) -> dict[str, Any]:
            out: dict[str, Any] = orjson.loads(payloads[i])
            return out

        return ColumnBatch(sfx, topic, first, cols, n, json_row)

    def _finish(
        self, scan: RecordScan, stats: Statistics | None, channels: dict[int, tuple[str, str, str]]
    ) -> None:
        """Truncation, damage and summary statistics, as :func:`hil.runlog.mcap_io.read_run`
        says (:func:`hil.runlog.mcap_io.finish_read`)."""
        topics = {cid: ch[0] for cid, ch in channels.items()}
        finish_read(self.info, scan, stats, topics, self.info.counts)


def _cdr_records(sfx: str, schema_name: str, payloads: list[bytes]) -> np.ndarray:
    """The CDR payloads of a registered message type as records (its :func:`cdr_dtype`)."""
    from bus_schemas import ros2  # noqa: PLC0415
    from bus_schemas.registry import MESSAGES  # noqa: PLC0415

    for mt in MESSAGES:
        if mt.key_suffix == sfx or ros2.schema_name(mt) == schema_name:
            return np.frombuffer(b"".join(payloads), dtype=ros2.cdr_dtype(mt))
    raise ValueError(f"cdr channel {sfx!r} (schema {schema_name!r}) is no registered message")


def run_batches(
    run: RunData,
    fields: Mapping[str, Sequence[str]],
    block: int = 4096,
    lead: Sequence[str] = (),
) -> Iterator[ColumnBatch]:
    """A :class:`hil.runlog.mcap_io.RunData` (messages in memory) as batches of ``block`` messages,
    the topics taken in turn (as a file's chunks interleave them), those whose suffix is in
    ``lead`` first in each turn.

    The columns are :func:`hil.review.core._col`'s (a :class:`hil.runlog.mcap_io.MessageList`'s own
    columns where it has them), so a run summarised from memory and from its file agree.
    """
    from hil.runlog.mcap_io import MessageList  # noqa: PLC0415

    seen: set[str] = set()
    whole: list[tuple[str, str, bool, dict[str, np.ndarray], list[dict[str, Any]]]] = []
    for topic, msgs in run.messages.items():
        sfx = suffix_of(topic)
        first = sfx not in seen
        seen.add(sfx)
        if not msgs:
            continue
        cols = {}
        wanted = fields.get(sfx, ()) if first else ()
        for name in dict.fromkeys((TIME_FIELD, *wanted)):
            if isinstance(msgs, MessageList):
                cols[name] = msgs.column(name)
            else:
                cols[name] = np.array([m.get(name, math.nan) for m in msgs], dtype=np.float64)
        whole.append((sfx, topic, first, cols, msgs))
    whole.sort(key=lambda w: w[0] not in lead)  # stable: file order otherwise
    longest = max((len(w[4]) for w in whole), default=0)
    for a in range(0, longest, block):
        for sfx, topic, first, cols, msgs in whole:
            part = msgs[a : a + block]
            if part:
                sub = {k: v[a : a + block] for k, v in cols.items()}
                yield ColumnBatch(sfx, topic, first, sub, len(part), part.__getitem__)


def run_info(run: RunData) -> RunInfo:
    """The :class:`RunInfo` of a run in memory."""
    return RunInfo(
        topics=list(run.messages),
        counts={t: len(m) for t, m in run.messages.items()},
        schemas=dict(run.schemas),
        metadata=run.metadata,
        profile=run.profile,
        truncated=run.truncated,
        complete=run.complete,
        error=run.error,
        statistics=run.statistics,
        statistics_ok=run.statistics_ok,
        skipped=list(run.skipped),
        first_log_ns=run.first_log_ns,
    )
