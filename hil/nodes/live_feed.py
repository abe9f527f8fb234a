"""The recorder's feed of the live view: what it writes, a few times a second, on one key.

``fowt run --live`` does not add a subscriber to the run's own keys: the plant's sensor
frames and the controller's commands, which pace the run, would then go to one more
session each cycle, and the live view's process would wake with each of them on the two
cores plant and controller need. The recorder, which takes every message anyway, hands
what it has just written (its 20 ms drains) to :class:`LiveForward`, which puts it as one
*live batch* on ``fowt/<turbine>/recorder/live`` (:data:`LIVE_SUFFIX`), signed with the
run's key like every payload of the run, with congestion control ``DROP``: a live view that
does not keep up loses batches, never slows the recorder.

A live batch is a 24-byte header, the stream (a random number drawn by each recorder
process: a restarted recorder starts a new stream), the batch number and the stream-wide
index of its first message (three little-endian unsigned 64-bit integers), followed by the
messages in the log batch format (:func:`hil.nodes.bus.split_batch`: encoded messages back
to back). The receiver (:func:`open_live_batch`) counts what a dropped batch held from the
gap in the indices, so the live view's counts say how many messages its viewers never got.

Hand-written because it is the bench's own framing of its own codec's messages; it does not
import the Foxglove sdk (the recorder loads it).
"""

from __future__ import annotations

import os
import struct
from collections.abc import Callable
from typing import Any, NamedTuple

from bus_schemas.codec import TruncatedError
from bus_schemas.registry import MessageType
from hil.nodes.bus import split_batch

__all__ = [
    "LIVE_SUFFIX",
    "LiveBatch",
    "LiveForward",
    "open_live_batch",
]

#: Key suffix of the live batches (inside the recorder's own key space).
LIVE_SUFFIX = "recorder/live"
#: Messages per live batch at most (a lock-step run's 20 ms can hold thousands).
MAX_MESSAGES = 512
_HEADER = struct.Struct("<QQQ")


class LiveForward:
    """Collects the recorder's written messages and puts them as live batches.

    Parameters
    ----------
    put : callable
        ``put(payload)``: signs and puts one live batch (never blocks: ``DROP``).
    max_messages : int
        Messages per batch at most.
    """

    def __init__(self, put: Callable[[bytes], None], max_messages: int = MAX_MESSAGES) -> None:
        if max_messages < 1:
            raise ValueError(f"LiveForward: expected max_messages >= 1, got {max_messages}")
        self._put = put
        self.max_messages = max_messages
        self._parts: list[bytes] = []
        self._first = 0  # stream-wide index of the first message held
        #: This process's stream (module docstring).
        self.stream = int.from_bytes(os.urandom(8), "little")
        #: Batches put so far (the next batch's number).
        self.batches = 0

    def add(self, mt: MessageType, msg: Any) -> None:
        """Hold one written message (encoded again: the recorder keeps decoded ones)."""
        self._parts.append(mt.codec.encode(msg))
        if len(self._parts) >= self.max_messages:
            self.flush()

    def flush(self) -> None:
        """Put what is held as one live batch (nothing when empty)."""
        if not self._parts:
            return
        n = len(self._parts)
        payload = _HEADER.pack(self.stream, self.batches, self._first) + b"".join(self._parts)
        self._parts.clear()
        self._first += n
        self.batches += 1
        self._put(payload)


class LiveBatch(NamedTuple):
    """One received live batch: its stream, number, first message index and messages.

    Attributes
    ----------
    stream : int
        The sending recorder process's stream.
    number : int
        Batch number (0, 1, ...).
    first_index : int
        Stream-wide index of its first message.
    parts : list of (MessageType, memoryview)
        Its encoded messages, each with its registered type (not yet decoded).
    """

    stream: int
    number: int
    first_index: int
    parts: list[tuple[MessageType, Any]]


def open_live_batch(payload: bytes | memoryview) -> LiveBatch:
    """Split a live batch (module docstring).

    Raises
    ------
    bus_schemas.DecodeError
        A payload shorter than the header, or messages that do not split
        (:func:`hil.nodes.bus.split_batch`).
    """
    view = memoryview(payload)
    if len(view) < _HEADER.size:
        raise TruncatedError(f"live batch: {len(view)} bytes, the header alone is {_HEADER.size}")
    stream, number, first = _HEADER.unpack_from(view)
    return LiveBatch(stream, number, first, split_batch(view[_HEADER.size :]))
