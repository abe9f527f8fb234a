"""MCAP run logs: one file per run, JSON Schema channels that Foxglove can plot.

Writing
-------
:class:`RunLog` registers one channel per bus key with the JSON Schema derived from the
message declaration (:meth:`bus_schemas.registry.MessageType.json_schema`) and writes each
message as JSON. ``log_time`` is the run's wall-clock start plus the message's simulated
``sample_time_ns``, so Foxglove's timeline is simulated time; ``publish_time`` is when the
recorder received it. Chunks are flushed to the OS every ``flush_interval_s`` (default
0.25 s of wall time), so a SIGKILL of any process loses at most that much of the log.

Reading
-------
:func:`read_run` reads a file front to back with mcap's stream reader and stops cleanly at
the first truncated or corrupt record, so a run whose recorder was killed still reviews up
to its last flushed chunk.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import msgspec
import orjson
from mcap.exceptions import McapError
from mcap.records import Channel, DataEnd, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from bus_schemas.registry import MESSAGES, MessageType

PROFILE = "fowt-hil"
RAW_SCHEMA_NAME = "fowt.RawPayload"


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
        # Unbuffered: a finished chunk goes to the OS at once, so SIGKILL cannot strand it
        # in a Python buffer.
        self._stream: IO[bytes] = open(path, "wb", buffering=0)  # noqa: SIM115 - closed in close()
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
        """Add a metadata record (scenario, run information, counters)."""
        self._writer.add_metadata(name, data)

    def maybe_flush(self) -> None:
        """Flush the chunk in progress if the flush interval has passed."""
        now = time.monotonic_ns()
        if now - self._last_flush_ns >= self._flush_interval_ns:
            self._writer.flush()
            self._last_flush_ns = now

    def close(self) -> None:
        """Write the summary section and close the file (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._writer.finish()
        self._stream.close()


@dataclass
class RunData:
    """Messages of one run, grouped by topic, as plain dicts in file order."""

    messages: dict[str, list[dict[str, Any]]] = field(default_factory=dict)
    schemas: dict[str, str] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    truncated: bool = False
    error: str = ""

    def topic(self, suffix: str) -> list[dict[str, Any]]:
        """Messages of the first topic ending in ``/<suffix>`` (any turbine)."""
        for name, msgs in self.messages.items():
            if name.endswith("/" + suffix):
                return msgs
        return []


def iter_records(path: Path) -> Iterator[Any]:
    """Yield MCAP records, stopping (not raising) at a truncated or corrupt tail."""
    with open(path, "rb") as stream:
        reader = StreamReader(stream, skip_magic=False)
        yield from reader.records


def read_run(path: Path) -> RunData:
    """Read every message of a run log, tolerating a truncated file.

    Returns
    -------
    RunData
        ``truncated`` is True when the file ended before its data-end record (a killed process);
        ``error`` then says what the reader stopped on.
    """
    run = RunData()
    channels: dict[int, str] = {}
    schema_names: dict[int, str] = {}
    saw_footer = False
    try:
        for rec in iter_records(path):
            if isinstance(rec, Schema):
                schema_names[rec.id] = rec.name
            elif isinstance(rec, Channel):
                channels[rec.id] = rec.topic
                run.schemas[rec.topic] = schema_names.get(rec.schema_id, "")
                run.messages.setdefault(rec.topic, [])
            elif isinstance(rec, Message):
                topic = channels.get(rec.channel_id)
                if topic is not None:
                    run.messages[topic].append(orjson.loads(rec.data))
            elif isinstance(rec, Metadata):
                run.metadata[rec.name] = dict(rec.metadata)
            elif isinstance(rec, DataEnd):
                # The data section is complete; what follows is the summary, not needed.
                saw_footer = True
                break
    except (McapError, EOFError, ValueError, OSError) as exc:
        run.error = f"{type(exc).__name__}: {exc}"
    except Exception as exc:
        run.error = f"{type(exc).__name__}: {exc}"
    run.truncated = not saw_footer
    return run
