"""MCAP conformance checks with the mcap package's own readers, ``mcap-ros2-support`` and
``jsonschema``.

Imported as ``from _mcap_conformance import ...`` (``tests/`` is on ``sys.path``). The bench's
reader (:func:`hil.runlog.mcap_io.read_run`) is not used here: these checks read the file the way
any other MCAP tool does.
"""

from __future__ import annotations

import io
import json
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jsonschema
from mcap.reader import NonSeekingReader, SeekingReader, make_reader
from mcap_ros2.decoder import DecoderFactory

from bus_schemas.registry import ALL_MESSAGES

MAGIC = b"\x89MCAP0\r\n"


class _NoSeek(io.RawIOBase):
    """A forward-only view of bytes (``seekable()`` False), as a pipe would be."""

    def __init__(self, data: bytes) -> None:
        self._buf = io.BytesIO(data)

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return False

    def readinto(self, b: Any) -> int:
        chunk = self._buf.read(len(b))
        b[: len(chunk)] = chunk
        return len(chunk)


@dataclass
class Conformance:
    """What the checks found: messages per topic and the summary's figures."""

    per_topic: dict[str, int]
    message_count: int
    chunk_count: int
    profile: str
    metadata: list[str]


def check_complete_mcap(path: Path, validate: bool = True) -> Conformance:
    """Assert that ``path`` is a complete, conformant MCAP file; return its counts.

    * starts and ends with the magic; the seeking reader (:func:`mcap.reader.make_reader` on
      the file) finds the summary with a Statistics record and one ChunkIndex per chunk;
    * the messages read by the seeking reader and by the non-seeking reader (a forward-only
      stream, :class:`_NoSeek`) agree, per channel, with ``Statistics.channel_message_counts``
      and in total with ``message_count``;
    * every channel is either ``cdr`` with a ``ros2msg`` schema, every message decoded by
      mcap-ros2-support (an independent CDR decoder) from the file's own schema text, or JSON
      with a ``jsonschema`` schema; and (``validate``) every message validates against its
      channel's JSON Schema (Draft 2020-12 validator), for a CDR channel the JSON Schema of
      the registered message of the same name (its physical ranges), the decoded fields as
      the object.
    """
    data = path.read_bytes()
    assert data[:8] == MAGIC, f"{path}: no opening magic"
    assert data[-8:] == MAGIC, f"{path}: no closing magic (file ends {data[-8:]!r})"
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        assert isinstance(reader, SeekingReader)
        header = reader.get_header()
        summary = reader.get_summary()
        assert summary is not None, f"{path}: no summary section"
        stats = summary.statistics
        assert stats is not None, f"{path}: no Statistics record"
        assert stats.chunk_count == len(summary.chunk_indexes) > 0
        validators: dict[int, jsonschema.protocols.Validator] = {}
        decoders: dict[int, Any] = {}
        registered = {f"fowt_hil/msg/{mt.name}": mt for mt in ALL_MESSAGES}
        for cid, ch in summary.channels.items():
            schema = summary.schemas[ch.schema_id]
            if ch.message_encoding == "cdr":
                assert schema.encoding == "ros2msg", schema
                decoder = DecoderFactory().decoder_for("cdr", schema)
                assert decoder is not None, schema
                decoders[cid] = decoder
                doc = registered[schema.name].json_schema()
            else:
                assert ch.message_encoding == "json", ch
                assert schema.encoding == "jsonschema", schema
                doc = json.loads(schema.data)
            cls = jsonschema.validators.validator_for(doc, default=jsonschema.Draft202012Validator)
            cls.check_schema(doc)
            validators[cid] = cls(doc)
        seeking: Counter[str] = Counter()
        for _schema, channel, message in reader.iter_messages(log_time_order=False):
            seeking[channel.topic] += 1
            decode = decoders.get(channel.id)
            if decode is not None:
                decoded = decode(message.data)
                value = {k: getattr(decoded, k) for k in decoded.__slots__}
            else:
                value = json.loads(message.data)
            if validate:
                validators[channel.id].validate(value)
        metadata = [m.name for m in reader.iter_metadata()]
    nonseeking: Counter[str] = Counter()
    ns = make_reader(io.BufferedReader(_NoSeek(data)))
    assert isinstance(ns, NonSeekingReader)
    for _schema, channel, _message in ns.iter_messages(log_time_order=False):
        nonseeking[channel.topic] += 1
    by_stats = {
        summary.channels[cid].topic: n for cid, n in stats.channel_message_counts.items() if n
    }
    assert dict(seeking) == by_stats, (dict(seeking), by_stats)
    assert dict(nonseeking) == by_stats, (dict(nonseeking), by_stats)
    assert sum(seeking.values()) == stats.message_count
    return Conformance(
        per_topic=by_stats,
        message_count=stats.message_count,
        chunk_count=stats.chunk_count,
        profile=header.profile,
        metadata=metadata,
    )
