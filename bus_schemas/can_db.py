"""The CAN database (DBC) of the bench, generated from the :mod:`bus_schemas` declarations.

Nothing here is declared per field by hand: every signal comes from the ``msgspec.Meta`` of a
field of :mod:`bus_schemas.messages` (range ``[ge, le]``, unit, description) through the
rules below, and the shipped ``bus_schemas/fowt.dbc`` is this module's output
(``python -m bus_schemas.can_db --write`` regenerates it; a test checks it is current).

Which messages travel on CAN
----------------------------
A turbine's CAN bus carries what the controller needs and what it commands:
:class:`~bus_schemas.messages.SensorFrame` and :class:`~bus_schemas.messages.ActuatorCommand`
(:data:`CAN_MESSAGES`). The true plant state, the controller status and the timing records
are bench instrumentation and stay on Zenoh (or in process).

CAN id map (11-bit standard ids; a lower id wins arbitration, so the command goes first)
-------------------------------------------------------------------------------------------
======================  ==========================  ===========================
message                 classic CAN (8-byte parts)  CAN FD (one frame)
======================  ==========================  ===========================
ActuatorCommand (v1)    0x100 + part (4 parts)       0x500 (24 bytes)
TurbineCommand (v1)     0x110 + part (4 parts)       0x510 (20 bytes)
SensorFrame (v1)        0x120 + part (7 parts)       0x520 (48 bytes)
TurbineFrame (v1)       0x140 + part (4 parts)       0x540 (24 bytes)
PlatformFrame (v1)      0x160 + part (4 parts)       0x560 (32 bytes)
======================  ==========================  ===========================

Frame layout (every frame, classic or FD), little-endian (Intel) bit numbering::

    byte 0      crc    CRC-8 SAE J1850 (see bus_schemas.can_codec), over the CAN id and bytes 1..
    bits 8-11   alive  4-bit alive counter, +1 (mod 16) per message instance, same in every part
    bits 12-15  part   index of this part (= CAN id - base id; 0 on CAN FD)
    bytes 2..   the signals of this part, byte aligned

Authenticator (in the spirit of AUTOSAR SecOC): every message instance is followed by one
companion frame, ``<Name>_Auth`` (classic: the id after the last part) or ``<Name>_FDAuth``
(CAN FD: the FD id + 1), with the same crc/alive header, ``part`` = the number of data
parts (1 on CAN FD), a freshness value (the low 16 bits of the message's ``seq`` classic,
32 bits on CAN FD) and the truncated MAC of :func:`bus_schemas.auth.can_mac` over the base
id, the freshness value and every data byte of the instance's frames:

============  =====================================  ================================
format        authenticator frame                    security margin
============  =====================================  ================================
classic       8 bytes: header 2, freshness 2, MAC 4  32-bit MAC: 2^-32 per forged try
CAN FD        24 bytes: header 2, freshness 4,       128-bit MAC: 2^-128 per try
              MAC 16 (``mac_lo``, ``mac_hi``)
============  =====================================  ================================

A 32-bit MAC is what SecOC profiles use on classic CAN (24-32 bits): at the 1 kHz of a
lock-step run's command stream an attacker who tries one forgery per instance succeeds
once in 2^32 / 1000 s = 50 days on average, and every failure is counted (``auth``). The
data frames' own 8 bytes stay as they were (no room for a MAC in a full classic frame);
the companion costs one frame per instance (a sensor frame 7 + 1 frames, a command 4 + 1).

A message larger than one classic frame is split over consecutive CAN ids, one per part
(``<Name>_P<k>``, 48 payload bits each); its signals are packed first-fit-decreasing by
width (ties in declaration order) so no signal straddles two frames. With CAN FD configured
the whole message is one frame ``<Name>_FD`` whose length is the smallest CAN FD data length
(8, 12, 16, 20, 24, 32, 48, 64) that holds it.

Signal rules
------------
* Float field with declared range [lo, hi] and unit resolution r (:data:`RESOLUTION_BY_UNIT`,
  overridden per field by :data:`FIELD_RESOLUTION`): unsigned integer of the smallest width
  n in (16, 24, 32) whose scale fits the resolution,

  .. math:: s = \\operatorname{nice}\\left(\\frac{hi - lo}{2^n - 2}\\right) \\le r,
            \\qquad x = lo + s \\, q, \\quad q = \\operatorname{round}((x - lo) / s),

  where nice(v) is the smallest number 1, 2 or 5 x 10^k not below v (a readable DBC), offset
  lo, DBC min/max = [lo, hi], unit the declared unit. The quantisation error is at most s/2.
  The raw code 2^n - 1 (all ones, as in SAE J1939 "not available") is never a valid value: it
  decodes above hi; the encoder sends it for a value outside [lo, hi] or non-finite, so the
  receiver rejects it as out of range.
* Sequence numbers (``u64``): 32-bit counter, seq mod 2^32; the receiver unwraps it to the
  nearest value of its last one (serial-number arithmetic, RFC 1982).
* Sample times (``i64`` ns, ``*_time_ns`` except the publish time): 32-bit counter of whole
  microseconds mod 2^32 with DBC scale 1000, so the DBC value is in ns; it wraps every
  2^32 us = 71.6 min and is unwrapped like the sequence number. Quantisation: 1 us (sample
  times of the shipped scenarios are whole microseconds: exact).
* ``publish_time_ns`` is not on CAN: it is the publisher's clock, meaningless to another
  node; the receiver sets it to its own ``time.monotonic_ns()`` when the message completes.
* ``u32`` counts and masks: 32 bits; ``u8`` flags: 8 bits; scale 1, declared range.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import OrderedDict
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import cantools
import msgspec
from cantools.database.can import Database, Message, Node, Signal
from cantools.database.can.formats.dbc import (
    DbcAttribute,
    DbcAttributeDefinition,
    DbcSpecifics,
)
from cantools.database.conversion import BaseConversion

from bus_schemas.codec import FieldSpec
from bus_schemas.messages import (
    ActuatorCommand,
    PlatformFrame,
    SensorFrame,
    TurbineCommand,
    TurbineFrame,
)
from bus_schemas.registry import BY_CLASS, MessageType

#: The DBC file shipped with the package (equal to :func:`dbc_text`).
DBC_PATH = Path(__file__).with_name("fowt.dbc")

#: Message types carried on CAN, with their classic (part 0) and CAN FD base ids.
CAN_IDS: dict[type[msgspec.Struct], tuple[int, int]] = {
    ActuatorCommand: (0x100, 0x500),
    SensorFrame: (0x120, 0x520),
    # Multi-turbine platform (Hexicon H3 family): one id per message type; the turbine is the
    # message's ``turbine_index`` signal. (The family runs over Zenoh today; on one shared CAN
    # bus the three turbines' multi-part frames would need per-turbine id offsets.)
    TurbineCommand: (0x110, 0x510),
    TurbineFrame: (0x140, 0x540),
    PlatformFrame: (0x160, 0x560),
}
CAN_MESSAGES: tuple[MessageType, ...] = tuple(BY_CLASS[cls] for cls in CAN_IDS)

#: Required resolution of a float signal per unit [unit]: the quantisation step may not exceed
#: it. Chosen well below the sensor noise and resolution of the shipped sensor models (1 mrad/s
#: speed encoder) and the actuator precision.
RESOLUTION_BY_UNIT: dict[str, float] = {
    "rad/s": 1e-3,
    "rad": 1e-4,
    "N m": 10.0,
    "N": 10.0,
    "W": 100.0,
    "m/s": 1e-2,
    "m/s^2": 1e-2,
    "m": 1e-2,
    "1": 1e-4,
    "us": 1.0,
}
#: Per-field overrides of :data:`RESOLUTION_BY_UNIT`, keyed ``(message name, field)``.
FIELD_RESOLUTION: dict[tuple[str, str], float] = {}

#: Widths a float signal may take [bit], smallest first.
FLOAT_WIDTHS = (16, 24, 32)
#: Payload bits of one classic frame after the crc, alive and part header (2 bytes).
PART_PAYLOAD_BITS = 48
#: Header bits of every frame: crc (8), alive (4), part (4).
HEADER_BITS = 16
CLASSIC_LENGTH = 8
#: CAN FD data lengths [byte].
FD_LENGTHS = (8, 12, 16, 20, 24, 32, 48, 64)
#: Wrap period of the 32-bit counters.
WRAP = 2**32
#: Unit of a time signal's raw count [ns].
TIME_SCALE_NS = 1000

PLANT_NODE = "Plant"
CONTROLLER_NODE = "Controller"
_SENDER = {
    SensorFrame: PLANT_NODE,
    ActuatorCommand: CONTROLLER_NODE,
    TurbineFrame: PLANT_NODE,
    PlatformFrame: PLANT_NODE,
    TurbineCommand: CONTROLLER_NODE,
}
_RECEIVER = {
    SensorFrame: CONTROLLER_NODE,
    ActuatorCommand: PLANT_NODE,
    TurbineFrame: CONTROLLER_NODE,
    PlatformFrame: CONTROLLER_NODE,
    TurbineCommand: PLANT_NODE,
}


@dataclass(frozen=True)
class SignalSpec:
    """How one message field travels on CAN.

    Attributes
    ----------
    field : FieldSpec
        The declaration (name, wire type, unit, range, description).
    kind : str
        ``"float"`` (scaled), ``"int"`` (scale 1, declared range), ``"seq"`` (32-bit wrapped
        sequence number) or ``"time"`` (32-bit wrapped microseconds, DBC value in ns).
    width : int
        Raw width [bit].
    scale, offset : float
        DBC conversion, physical = offset + scale * raw.
    minimum, maximum : float
        DBC min/max (the declared range; for wrapped counters the raw range).
    """

    field: FieldSpec
    kind: str
    width: int
    scale: float
    offset: float
    minimum: float
    maximum: float

    @property
    def name(self) -> str:
        return self.field.name

    @property
    def invalid_raw(self) -> int:
        """Raw code of an out-of-range or non-finite value (all ones) of a float signal."""
        return (1 << self.width) - 1


def nice_step(value: float) -> float:
    """Smallest number 1, 2 or 5 x 10^k not below ``value`` (> 0).

    The DBC stores the scale as text; a round step reads well in CAN tools and prints exactly.
    """
    exp = math.floor(math.log10(value))
    for k in (exp, exp + 1):
        for m in (1, 2, 5):
            step = float(f"{m}e{k}")
            if step >= value * (1 - 1e-12):
                return step
    raise AssertionError(value)  # pragma: no cover - 10^(exp+1) >= value always


def resolution(mt: MessageType, f: FieldSpec) -> float:
    """Required resolution of a float field (per-field override, else per unit)."""
    override = FIELD_RESOLUTION.get((mt.name, f.name))
    if override is not None:
        return override
    try:
        return RESOLUTION_BY_UNIT[f.unit]
    except KeyError:
        raise KeyError(
            f"{mt.name}.{f.name}: no CAN resolution for unit {f.unit!r}; add it to "
            "RESOLUTION_BY_UNIT or FIELD_RESOLUTION in bus_schemas/can_db.py"
        ) from None


def signal_spec(mt: MessageType, f: FieldSpec) -> SignalSpec | None:
    """The CAN signal of a field by the rules of this module (None: not on CAN)."""
    if f.wire == "f64":
        span = f.maximum - f.minimum
        res = resolution(mt, f)
        for width in FLOAT_WIDTHS:
            scale = nice_step(span / ((1 << width) - 2))
            if scale <= res:
                return SignalSpec(f, "float", width, scale, f.minimum, f.minimum, f.maximum)
        raise ValueError(
            f"{mt.name}.{f.name}: range {span:g} {f.unit} needs a step of at most {res:g}, "
            f"more than {FLOAT_WIDTHS[-1]} bits; narrow the range or coarsen the resolution"
        )
    if f.wire == "u64":
        return SignalSpec(f, "seq", 32, 1, 0, 0, WRAP - 1)
    if f.wire == "i64":
        if f.name == "publish_time_ns":
            return None
        if not f.name.endswith("_time_ns"):
            raise ValueError(f"{mt.name}.{f.name}: only absolute *_time_ns times go on CAN")
        return SignalSpec(f, "time", 32, TIME_SCALE_NS, 0, 0, (WRAP - 1) * TIME_SCALE_NS)
    width = {"u32": 32, "u8": 8}[f.wire]
    return SignalSpec(f, "int", width, 1, 0, int(f.minimum), int(f.maximum))


def message_signals(mt: MessageType) -> tuple[SignalSpec, ...]:
    """The CAN signals of a message, in declaration order."""
    specs = (signal_spec(mt, f) for f in mt.codec.fields)
    return tuple(s for s in specs if s is not None)


def pack_parts(signals: tuple[SignalSpec, ...]) -> list[list[SignalSpec]]:
    """Split signals over classic frames: first-fit decreasing into 48-bit parts.

    Ties in width keep declaration order; each part lists its signals in declaration order.
    """
    order = {s.name: i for i, s in enumerate(signals)}
    parts: list[list[SignalSpec]] = []
    used: list[int] = []
    for s in sorted(signals, key=lambda s: (-s.width, order[s.name])):
        for k, bits in enumerate(used):
            if bits + s.width <= PART_PAYLOAD_BITS:
                parts[k].append(s)
                used[k] += s.width
                break
        else:
            parts.append([s])
            used.append(s.width)
    return [sorted(p, key=lambda s: order[s.name]) for p in parts]


#: Freshness bits of the authenticator frame (classic, CAN FD).
AUTH_FRESHNESS_BITS = {False: 16, True: 32}
#: MAC bytes of the authenticator frame (classic, CAN FD).
AUTH_MAC_BYTES = {False: 4, True: 16}
#: CAN FD data length of the authenticator frame [byte] (2 + 4 + 16 = 22, rounded up).
AUTH_FD_LENGTH = 24


def auth_frame_id(mt: MessageType, fd: bool) -> int:
    """CAN id of the authenticator frame of ``mt`` (classic: after the last part; FD: + 1)."""
    classic_id, fd_id = CAN_IDS[mt.cls]
    return fd_id + 1 if fd else classic_id + len(pack_parts(message_signals(mt)))


def fd_length(signals: tuple[SignalSpec, ...]) -> int:
    """Smallest CAN FD data length [byte] holding the header and every signal."""
    bits = HEADER_BITS + sum(s.width for s in signals)
    need = (bits + 7) // 8
    for n in FD_LENGTHS:
        if n >= need:
            return n
    raise ValueError(f"{bits} bits do not fit one CAN FD frame")


def _signal(s: SignalSpec, start: int, receiver: str) -> Signal:
    f = s.field
    notes = {
        "float": f"raw {s.invalid_raw} (all ones) = out of range / not available",
        "int": "",
        "seq": "sequence number mod 2^32, unwrapped by the receiver (RFC 1982)",
        "time": "whole microseconds mod 2^32 (scale 1000 gives ns), unwrapped by the receiver",
    }[s.kind]
    comment = f.description + (f"; {notes}" if notes else "")
    return Signal(
        name=f.name,
        start=start,
        length=s.width,
        byte_order="little_endian",
        is_signed=False,
        conversion=BaseConversion.factory(scale=s.scale, offset=s.offset),
        minimum=s.minimum,
        maximum=s.maximum,
        unit=f.unit,
        comment=comment,
        receivers=[receiver],
    )


def _header(receiver: str) -> list[Signal]:
    return [
        Signal(
            "crc",
            0,
            8,
            comment="CRC-8 SAE J1850 (poly 0x1D, init 0xFF, xorout 0xFF) over the two bytes "
            "of the CAN id (little endian) and data bytes 1..",
            receivers=[receiver],
        ),
        Signal(
            "alive",
            8,
            4,
            minimum=0,
            maximum=15,
            comment="alive counter, +1 mod 16 per message instance",
            receivers=[receiver],
        ),
        Signal("part", 12, 4, minimum=0, maximum=15, comment="part index", receivers=[receiver]),
    ]


def _messages(mt: MessageType) -> list[Message]:
    classic_id, fd_id = CAN_IDS[mt.cls]
    sender, receiver = _SENDER[mt.cls], _RECEIVER[mt.cls]
    signals = message_signals(mt)
    parts = pack_parts(signals)
    about = f"{mt.name} schema v{mt.version}"
    out = []
    for k, part in enumerate(parts):
        sigs = _header(receiver)
        start = HEADER_BITS
        for s in part:
            sigs.append(_signal(s, start, receiver))
            start += s.width
        out.append(
            Message(
                frame_id=classic_id + k,
                name=f"{mt.name}_P{k}",
                length=CLASSIC_LENGTH,
                signals=sigs,
                comment=f"{about}, part {k} of {len(parts)}",
                senders=[sender],
            )
        )
    out.append(_auth_message(mt, False, len(parts), sender, receiver))
    sigs = _header(receiver)
    start = HEADER_BITS
    for s in signals:
        sigs.append(_signal(s, start, receiver))
        start += s.width
    out.append(
        Message(
            frame_id=fd_id,
            name=f"{mt.name}_FD",
            length=fd_length(signals),
            signals=sigs,
            comment=f"{about}, whole message in one CAN FD frame",
            senders=[sender],
            is_fd=True,
        )
    )
    out.append(_auth_message(mt, True, 1, sender, receiver))
    return out


def _auth_message(mt: MessageType, fd: bool, parts: int, sender: str, receiver: str) -> Message:
    """The authenticator frame of ``mt`` (module docstring, "Authenticator")."""
    fresh = AUTH_FRESHNESS_BITS[fd]
    sigs = _header(receiver)
    sigs.append(
        Signal(
            "freshness",
            HEADER_BITS,
            fresh,
            minimum=0,
            maximum=(1 << fresh) - 1,
            comment=f"freshness value: seq mod 2^{fresh} of the instance it authenticates",
            receivers=[receiver],
        )
    )
    start = HEADER_BITS + fresh
    mac_bits = 8 * AUTH_MAC_BYTES[fd]
    names = ["mac"] if mac_bits <= 64 else ["mac_lo", "mac_hi"]
    for name in names:
        width = mac_bits // len(names)
        sigs.append(
            Signal(
                name,
                start,
                width,
                comment="truncated HMAC-SHA256 over the base id, the freshness value and the "
                "instance's data bytes (bus_schemas.auth.can_mac)",
                receivers=[receiver],
            )
        )
        start += width
    kind = "CAN FD" if fd else "classic"
    return Message(
        frame_id=auth_frame_id(mt, fd),
        name=f"{mt.name}_{'FDAuth' if fd else 'Auth'}",
        length=AUTH_FD_LENGTH if fd else CLASSIC_LENGTH,
        signals=sigs,
        comment=f"{mt.name} authenticator ({kind}; part = {parts}), sent after each instance",
        senders=[sender],
        is_fd=fd,
    )


def build_database() -> Database:
    """The CAN database of :data:`CAN_MESSAGES` as ``cantools`` objects."""
    bus_type = DbcAttributeDefinition("BusType", default_value="CAN", type_name="STRING")
    specifics = DbcSpecifics(
        attributes=OrderedDict(BusType=DbcAttribute("CAN FD", bus_type)),
        attribute_definitions=OrderedDict(BusType=bus_type),
    )
    messages = [m for mt in CAN_MESSAGES for m in _messages(mt)]
    nodes = [
        Node(PLANT_NODE, comment="plant process: sends sensor frames, receives commands"),
        Node(CONTROLLER_NODE, comment="controller process: sends commands"),
    ]
    versions = " ".join(f"{mt.name}=v{mt.version}" for mt in CAN_MESSAGES)
    return Database(
        messages=messages, nodes=nodes, version=f"fowt-hil {versions}", dbc_specifics=specifics
    )


def dbc_text() -> str:
    """The DBC file text, written by ``cantools``' DBC writer (line ends normalised to LF)."""
    return build_database().as_dbc_string().replace("\r\n", "\n")


@lru_cache(maxsize=1)
def load_database() -> Database:
    """The database as every CAN tool reads it: :func:`dbc_text` parsed back by ``cantools``.

    Parsing the text (rather than using :func:`build_database` directly) makes the codec use
    exactly what the DBC file says, scales included, as printed.
    """
    db = cantools.database.load_string(dbc_text(), database_format="dbc")
    assert isinstance(db, Database)
    return db


def main(argv: list[str] | None = None) -> int:
    """``python -m bus_schemas.can_db [--write | --check]``: print, write or check the DBC."""
    parser = argparse.ArgumentParser(prog="python -m bus_schemas.can_db", description=__doc__)
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--write", action="store_true", help=f"write {DBC_PATH}")
    group.add_argument("--check", action="store_true", help=f"exit 1 if {DBC_PATH} is stale")
    args = parser.parse_args(argv)
    text = dbc_text()
    if args.write:
        DBC_PATH.write_text(text, encoding="utf-8", newline="\n")
        print(f"wrote {DBC_PATH}", file=sys.stderr)
    elif args.check:
        current = DBC_PATH.read_text(encoding="utf-8") if DBC_PATH.exists() else ""
        if current != text:
            print(f"{DBC_PATH} is stale: python -m bus_schemas.can_db --write", file=sys.stderr)
            return 1
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
