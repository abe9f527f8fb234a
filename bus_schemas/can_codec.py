"""CAN frames <-> bus messages, through the generated DBC (:mod:`bus_schemas.can_db`).

:func:`encode` / :class:`Encoder` turn a :class:`~bus_schemas.messages.SensorFrame` or
:class:`~bus_schemas.messages.ActuatorCommand` into its CAN frames (7 resp. 4 classic frames
on consecutive ids, or one CAN FD frame), scaling every signal with ``cantools``
(``Message.encode(..., strict=False)``: the range check is done here first, and an
out-of-range or non-finite float is sent as the reserved all-ones raw code). Each frame
carries the message instance's 4-bit alive counter and a CRC-8.

:class:`Reassembler` is the receiving side. ``feed(frame)`` returns the decoded message once
every part of one instance has arrived, else None; it rejects and counts (in
:attr:`Reassembler.rejected`, keys :data:`REJECT_REASONS`):

* ``unknown_id``: an id not in the DBC (or an extended id);
* ``not_data_frame``: a remote or error frame;
* ``wrong_length``: a data length other than the DBC's;
* ``bad_checksum``: CRC mismatch;
* ``alive_repeated``: an instance with the alive counter of the previous one (a replay);
* ``alive_skipped``: an instance whose counter is not the previous one + 1 (mod 16): an
  instance was lost in between. The receiver resynchronises on it: the next one in sequence
  is accepted again (so one loss costs two instances, as a strict E2E check does);
* ``incomplete``: a new instance began before every part of the previous one arrived;
* ``inconsistent``: a part whose part index is not its id's, or a part repeated within one
  instance with different data;
* ``auth`` (with a key): an instance whose authenticator frame is missing (the next
  instance began first), does not match its alive counter, carries a wrong MAC, or a
  freshness value other than the low bits of the decoded ``seq``; or an authenticator
  frame without a complete instance before it;
* ``out_of_range``: a decoded float outside its declared [ge, le] by more than half a
  quantisation step s (including the reserved all-ones code the encoder sends for
  out-of-range values, which decodes at least s above le); a value within s/2 outside the
  range is the quantisation of an in-range value and is clamped to [ge, le].

Authentication (``auth_key``, the run's secret): the :class:`Encoder` sends the instance's
authenticator frame (:mod:`bus_schemas.can_db`, "Authenticator") after its data frames;
the :class:`Reassembler` holds a complete instance until that frame arrives and decodes it
only if the MAC over the base id, the freshness value and all the instance's data bytes
verifies (constant-time compare). Without a key the authenticator frames are neither sent
nor required (received ones are discarded).

Counts are per frame for the frame-level reasons (unknown id, not a data frame, length,
checksum) and per message instance for the others; further frames of an instance already
rejected are dropped silently and counted in :attr:`Reassembler.discarded_frames`.

Checksum: CRC-8 SAE J1850 (polynomial 0x1D, init 0xFF, final xor 0xFF, no reflection;
check value 0x4B for ``b"123456789"``), computed over the two bytes of the 11-bit CAN id
(little endian, as the data id of AUTOSAR E2E profile 2 is) followed by data bytes 1..n-1,
and stored in byte 0. Including the id makes a frame delivered under a wrong id fail the
check. It is computed with a 256-entry table (:func:`crc8_sae_j1850`), built at import from
the polynomial, because ``crccheck.crc.Crc8SaeJ1850`` (installed with cantools, same
algorithm, used by the tests as the reference) costs about 24 us per 9-byte call here; the
table version costs about 1 us.

Cost (this machine, DESIGN.md): cantools encodes an 8-byte message in about 1.7 us with
``strict=False`` and decodes one in 1.1 us, so a classic sensor frame (7 parts) costs
roughly 15-25 us to encode and 10-15 us to decode including the CRC; one CAN FD frame about
20/5 us.

Wrapped counters and times are unwrapped per message type and field by serial-number
arithmetic (RFC 1982): with w the wire value, v the previous full value and W = 2^32,

.. math:: v' = v + ((w - v) \\bmod W) - W \\, [((w - v) \\bmod W) \\ge W/2],

valid while consecutive values differ by less than W/2 (2^31 frames; 35.8 min of sample
time). ``publish_time_ns`` is not on CAN: it is set to the receiver's clock on completion.
"""

from __future__ import annotations

import hmac
import math
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import can
import msgspec
from cantools.database.can import Message as DbcMessage

from bus_schemas.auth import can_mac
from bus_schemas.can_db import (
    AUTH_FD_LENGTH,
    AUTH_FRESHNESS_BITS,
    AUTH_MAC_BYTES,
    CAN_IDS,
    CAN_MESSAGES,
    CLASSIC_LENGTH,
    TIME_SCALE_NS,
    WRAP,
    SignalSpec,
    auth_frame_id,
    load_database,
    message_signals,
)
from bus_schemas.registry import BY_CLASS, MessageType

#: Counter keys of :attr:`Reassembler.rejected`.
REJECT_REASONS = (
    "unknown_id",
    "not_data_frame",
    "wrong_length",
    "bad_checksum",
    "alive_repeated",
    "alive_skipped",
    "incomplete",
    "inconsistent",
    "auth",
    "out_of_range",
)

ALIVE_MODULO = 16
#: Part index of an authenticator frame in :attr:`Reassembler._by_id`.
_AUTH = -1
_CRC8_POLY = 0x1D


def _crc8_table(poly: int) -> bytes:
    table = []
    for byte in range(256):
        c = byte
        for _ in range(8):
            c = ((c << 1) ^ poly) & 0xFF if c & 0x80 else (c << 1) & 0xFF
        table.append(c)
    return bytes(table)


_CRC8_TABLE = _crc8_table(_CRC8_POLY)


def crc8_sae_j1850(data: bytes | bytearray | memoryview, crc: int = 0xFF) -> int:
    """CRC-8 SAE J1850 of ``data`` (poly 0x1D, init 0xFF, xorout 0xFF), table driven.

    ``crc`` is the register to start from (0xFF for a fresh checksum).
    """
    table = _CRC8_TABLE
    for b in data:
        crc = table[crc ^ b]
    return crc ^ 0xFF


def frame_crc(arbitration_id: int, data: bytes | bytearray) -> int:
    """The checksum byte of a frame: CRC-8 SAE J1850 over the id (2 bytes LE) and data[1:]."""
    table = _CRC8_TABLE
    crc = table[0xFF ^ (arbitration_id & 0xFF)]
    crc = table[crc ^ ((arbitration_id >> 8) & 0xFF)]
    for b in memoryview(data)[1:]:
        crc = table[crc ^ b]
    return crc ^ 0xFF


def unwrap(previous: int | None, wire: int, modulo: int = WRAP) -> int:
    """Full value of a counter sent mod ``modulo``, nearest to ``previous`` (RFC 1982)."""
    if previous is None:
        return wire
    delta = (wire - previous) % modulo
    if delta >= modulo // 2:
        delta -= modulo
    full = previous + delta
    return full if full >= 0 else wire


@dataclass(frozen=True)
class Layout:
    """The frames of one message type in one frame format (classic parts or one CAN FD)."""

    mt: MessageType
    fd: bool
    base_id: int
    parts: tuple[DbcMessage, ...]
    signals: tuple[SignalSpec, ...]
    auth_id: int  # the authenticator frame's id (bus_schemas.can_db.auth_frame_id)

    @property
    def ids(self) -> tuple[int, ...]:
        return tuple(p.frame_id for p in self.parts)

    def physical(self, msg: msgspec.Struct) -> dict[str, Any]:
        """Signal values to hand to cantools (physical units; wrapped counters reduced)."""
        out: dict[str, Any] = {}
        for s in self.signals:
            v = getattr(msg, s.name)
            if s.kind == "float":
                if not (math.isfinite(v) and s.minimum <= v <= s.maximum):
                    v = s.offset + s.invalid_raw * s.scale  # the reserved all-ones code
                out[s.name] = v
            elif s.kind == "seq":
                out[s.name] = v % WRAP
            elif s.kind == "time":
                out[s.name] = ((v + TIME_SCALE_NS // 2) // TIME_SCALE_NS % WRAP) * TIME_SCALE_NS
            else:
                if not s.minimum <= v <= s.maximum:
                    raise ValueError(
                        f"{self.mt.name}.{s.name} = {v!r} outside [{s.minimum:g}, {s.maximum:g}]"
                    )
                out[s.name] = v
        return out


@lru_cache(maxsize=2)
def layouts(fd: bool) -> dict[type[msgspec.Struct], Layout]:
    """Frame layouts of every CAN message type, classic (``fd=False``) or CAN FD."""
    db = load_database()
    out = {}
    for mt in CAN_MESSAGES:
        classic_id, fd_id = CAN_IDS[mt.cls]
        if fd:
            parts: tuple[DbcMessage, ...] = (db.get_message_by_frame_id(fd_id),)
        else:
            parts = tuple(
                db.get_message_by_name(m.name)
                for m in db.messages
                if m.name.startswith(f"{mt.name}_P")
            )
        out[mt.cls] = Layout(
            mt, fd, fd_id if fd else classic_id, parts, message_signals(mt), auth_frame_id(mt, fd)
        )
    return out


def auth_frame(
    layout: Layout, frames: list[can.Message], seq: int, alive: int, secret: bytes
) -> can.Message:
    """The authenticator frame of one instance (``frames``: its data frames, in part order)."""
    fd = layout.fd
    fresh_bytes = AUTH_FRESHNESS_BITS[fd] // 8
    freshness = seq % (1 << AUTH_FRESHNESS_BITS[fd])
    body = b"".join(bytes(f.data) for f in frames)
    mac = can_mac(secret, layout.base_id, freshness, body, AUTH_MAC_BYTES[fd])
    part = 1 if fd else len(layout.parts)
    data = bytearray(AUTH_FD_LENGTH if fd else CLASSIC_LENGTH)
    data[1] = (alive & 0x0F) | (part << 4)
    data[2 : 2 + fresh_bytes] = freshness.to_bytes(fresh_bytes, "little")
    data[2 + fresh_bytes : 2 + fresh_bytes + len(mac)] = mac
    fid = layout.auth_id
    data[0] = frame_crc(fid, data)
    return can.Message(
        arbitration_id=fid, data=data, is_extended_id=False, is_fd=fd, bitrate_switch=fd
    )


def encode(message: msgspec.Struct, alive: int, *, fd: bool = False) -> list[can.Message]:
    """The CAN frames of one message instance with alive counter ``alive`` (0..15).

    Parameters
    ----------
    message : SensorFrame or ActuatorCommand
        The message; a float outside its declared range or non-finite is sent as the
        reserved all-ones code (the receiver rejects it as out of range).
    alive : int
        Alive counter of this instance, the same in every part.
    fd : bool
        One CAN FD frame instead of classic 8-byte parts.

    Raises
    ------
    KeyError
        For a message type that is not carried on CAN.
    ValueError
        For an integer field outside its declared range.
    """
    layout = layouts(fd)[type(message)]
    values = layout.physical(message)
    values["crc"] = 0
    values["alive"] = alive & 0x0F
    frames = []
    for k, part in enumerate(layout.parts):
        values["part"] = k
        data = bytearray(part.encode(values, scaling=True, padding=False, strict=False))
        data[0] = frame_crc(part.frame_id, data)
        frames.append(
            can.Message(
                arbitration_id=part.frame_id,
                data=data,
                is_extended_id=False,
                is_fd=fd,
                bitrate_switch=fd,
            )
        )
    return frames


class Encoder:
    """Stateful encoder: one alive counter per message type, +1 mod 16 per instance.

    With ``auth_key`` (the run's secret) each instance's frames end with its authenticator
    frame (:func:`auth_frame`).
    """

    def __init__(self, *, fd: bool = False, auth_key: bytes | None = None) -> None:
        self.fd = fd
        self.auth_key = auth_key
        self._alive: dict[type[msgspec.Struct], int] = {}

    def encode(self, message: msgspec.Struct) -> list[can.Message]:
        """The frames of ``message`` with the next alive counter of its type."""
        cls = type(message)
        alive = self._alive.get(cls, -1) + 1
        self._alive[cls] = alive % ALIVE_MODULO
        frames = encode(message, alive % ALIVE_MODULO, fd=self.fd)
        if self.auth_key is not None:
            layout = layouts(self.fd)[cls]
            seq = int(getattr(message, "seq", 0))
            frames.append(auth_frame(layout, frames, seq, alive % ALIVE_MODULO, self.auth_key))
        return frames


@dataclass
class _Stream:
    """Receive state of one message type (in one frame format)."""

    layout: Layout
    last_alive: int | None = None
    buf_alive: int | None = None
    discard_alive: int | None = None
    buf: dict[int, bytes] = field(default_factory=dict)
    unwrapped: dict[str, int] = field(default_factory=dict)
    #: A complete instance waiting for its authenticator frame: (alive, parts).
    await_auth: tuple[int, dict[int, bytes]] | None = None


class Reassembler:
    """Receives CAN frames, checks them, reassembles and decodes whole messages.

    Parameters
    ----------
    clock : callable
        Monotonic clock in ns for the reconstructed ``publish_time_ns``.
    fd : bool or None
        Accept classic parts only (False), CAN FD frames only (True) or both (None).
    auth_key : bytes or None
        The run's secret: every instance must be followed by its valid authenticator frame
        (module docstring); None: authenticator frames are discarded, none is required.

    Attributes
    ----------
    rejected : collections.Counter
        Rejections by reason (:data:`REJECT_REASONS`).
    accepted : collections.Counter
        Decoded messages by type name.
    discarded_frames : int
        Frames dropped silently because their instance was already rejected, or exact
        duplicates of a part already held.
    """

    def __init__(
        self,
        *,
        clock: Callable[[], int] = time.monotonic_ns,
        fd: bool | None = None,
        auth_key: bytes | None = None,
    ) -> None:
        self.clock = clock
        self.auth_key = auth_key
        self.rejected: Counter[str] = Counter()
        self.accepted: Counter[str] = Counter()
        self.discarded_frames = 0
        self._by_id: dict[int, tuple[_Stream, int, int]] = {}
        for flag in (False, True):
            if fd is not None and fd != flag:
                continue
            for layout in layouts(flag).values():
                stream = _Stream(layout)
                for k, part in enumerate(layout.parts):
                    self._by_id[part.frame_id] = (stream, k, part.length)
                auth_length = AUTH_FD_LENGTH if flag else CLASSIC_LENGTH
                self._by_id[layout.auth_id] = (stream, _AUTH, auth_length)

    @property
    def rejected_total(self) -> int:
        """All rejections so far."""
        return sum(self.rejected.values())

    def known_ids(self) -> frozenset[int]:
        """CAN ids this reassembler decodes."""
        return frozenset(self._by_id)

    def message_type_of(self, arbitration_id: int) -> MessageType | None:
        """The message type an id belongs to (None: unknown id)."""
        entry = self._by_id.get(arbitration_id)
        return None if entry is None else entry[0].layout.mt

    def _reject(self, reason: str) -> None:
        self.rejected[reason] += 1

    def feed(self, frame: can.Message) -> msgspec.Struct | None:
        """Take one frame; return the message it completes, or None."""
        entry = self._by_id.get(frame.arbitration_id)
        if entry is None or frame.is_extended_id:
            self._reject("unknown_id")
            return None
        if frame.is_remote_frame or frame.is_error_frame:
            self._reject("not_data_frame")
            return None
        stream, k, length = entry
        data = bytes(frame.data)
        if len(data) != length:
            self._reject("wrong_length")
            return None
        if data[0] != frame_crc(frame.arbitration_id, data):
            self._reject("bad_checksum")
            return None
        alive, part = data[1] & 0x0F, data[1] >> 4
        if k == _AUTH:
            return self._authenticate(stream, alive, part, data)
        if stream.await_auth is not None:  # the next instance began: no authenticator came
            stream.await_auth = None
            self._reject("auth")
        if part != k:
            self._reject("inconsistent")
            return None
        if stream.buf_alive is not None and alive == stream.buf_alive:
            held = stream.buf.get(k)
            if held is not None:
                if held == data:
                    self.discarded_frames += 1
                    return None
                self._reject("inconsistent")
                stream.buf.clear()
                stream.buf_alive = None
                stream.discard_alive = alive
                return None
            stream.buf[k] = data
        elif stream.buf_alive is None and alive == stream.discard_alive:
            self.discarded_frames += 1
            return None
        else:  # the first frame of a new instance
            if stream.buf_alive is not None:
                self._reject("incomplete")
                stream.buf.clear()
                stream.buf_alive = None
            stream.discard_alive = None
            last = stream.last_alive
            if last is not None and alive == last:
                self._reject("alive_repeated")
                stream.discard_alive = alive
                return None
            stream.last_alive = alive
            if last is not None and alive != (last + 1) % ALIVE_MODULO:
                self._reject("alive_skipped")
                stream.discard_alive = alive
                return None
            stream.buf_alive = alive
            stream.buf[k] = data
        if len(stream.buf) < len(stream.layout.parts):
            return None
        parts, stream.buf = stream.buf, {}
        stream.buf_alive = None
        if self.auth_key is not None:  # held until its authenticator frame
            stream.await_auth = (alive, parts)
            return None
        return self._decode(stream, parts)

    def _authenticate(
        self, stream: _Stream, alive: int, part: int, data: bytes
    ) -> msgspec.Struct | None:
        """Check an authenticator frame against the instance it follows; decode it if good."""
        secret = self.auth_key
        if secret is None:  # an unauthenticated receiver ignores authenticators
            self.discarded_frames += 1
            return None
        pending, stream.await_auth = stream.await_auth, None
        layout = stream.layout
        if (
            pending is None
            or pending[0] != alive
            or part != (1 if layout.fd else len(layout.parts))
        ):
            self._reject("auth")
            return None
        parts = pending[1]
        fd = layout.fd
        fresh_bytes = AUTH_FRESHNESS_BITS[fd] // 8
        freshness = int.from_bytes(data[2 : 2 + fresh_bytes], "little")
        size = AUTH_MAC_BYTES[fd]
        body = b"".join(parts[i] for i in range(len(layout.parts)))
        mac = can_mac(secret, layout.base_id, freshness, body, size)
        if not hmac.compare_digest(mac, data[2 + fresh_bytes : 2 + fresh_bytes + size]):
            self._reject("auth")
            return None
        msg = self._decode(stream, parts)
        if msg is None:
            return None
        seq = getattr(msg, "seq", None)
        if seq is not None and seq % (1 << AUTH_FRESHNESS_BITS[fd]) != freshness:
            self.accepted[layout.mt.name] -= 1
            self._reject("auth")
            return None
        return msg

    def _decode(self, stream: _Stream, parts: dict[int, bytes]) -> msgspec.Struct | None:
        layout = stream.layout
        decoded: dict[str, Any] = {}
        for k, part in enumerate(layout.parts):
            values_k = part.decode(parts[k], decode_choices=False, scaling=True)
            assert isinstance(values_k, dict)  # a plain (non-container) message
            decoded.update(values_k)
        values: dict[str, Any] = {}
        wrapped: dict[str, int] = {}
        for s in layout.signals:
            v = decoded[s.name]
            if s.kind == "float":
                # Half a step of slack: the quantisation of an in-range value may land just
                # outside it when the range is not a whole number of steps; clamp those.
                half = 0.5 * s.scale
                if not s.minimum - half <= v <= s.maximum + half:
                    self._reject("out_of_range")
                    return None
                values[s.name] = min(max(float(v), s.minimum), s.maximum)
            elif s.kind == "seq":
                full = unwrap(stream.unwrapped.get(s.name), int(v))
                wrapped[s.name] = full
                values[s.name] = full
            elif s.kind == "time":
                full = unwrap(stream.unwrapped.get(s.name), round(v) // TIME_SCALE_NS)
                wrapped[s.name] = full
                values[s.name] = full * TIME_SCALE_NS
            else:
                values[s.name] = int(v)
        stream.unwrapped.update(wrapped)
        if "publish_time_ns" in layout.mt.cls.__struct_fields__:
            values["publish_time_ns"] = self.clock()
        self.accepted[layout.mt.name] += 1
        return layout.mt.cls(**values)


def can_message_type(cls: type[msgspec.Struct]) -> MessageType:
    """The registry entry of a CAN-carried message class (KeyError if not on CAN)."""
    mt = BY_CLASS[cls]
    if mt not in CAN_MESSAGES:
        raise KeyError(f"{cls.__name__} is not carried on CAN (Zenoh only)")
    return mt


__all__ = [
    "ALIVE_MODULO",
    "REJECT_REASONS",
    "Encoder",
    "Layout",
    "Reassembler",
    "can_message_type",
    "crc8_sae_j1850",
    "encode",
    "frame_crc",
    "layouts",
    "unwrap",
]
