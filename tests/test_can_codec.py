"""CAN codec: round trip over a python-can ``virtual`` bus, and every rejection counted."""

from __future__ import annotations

import math
import time
import uuid
from collections.abc import Iterator
from typing import Any

import can
import msgspec
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bus_schemas import ActuatorCommand, SensorFrame
from bus_schemas.can_codec import (
    Encoder,
    Reassembler,
    encode,
    frame_crc,
    layouts,
    unwrap,
)
from bus_schemas.can_db import CAN_MESSAGES, WRAP, message_signals
from bus_schemas.registry import MessageType
from hil.nodes.can_bus import CanBus, CanBusConfig


@pytest.fixture(scope="module")
def vbus() -> Iterator[tuple[can.BusABC, can.BusABC]]:
    """Two ends of one python-can virtual channel (CAN FD capable)."""
    channel = f"test-codec-{uuid.uuid4()}"
    tx = can.Bus(interface="virtual", channel=channel, fd=True)
    rx = can.Bus(interface="virtual", channel=channel, fd=True)
    yield tx, rx
    tx.shutdown()
    rx.shutdown()


def _strategy(mt: MessageType) -> st.SearchStrategy[Any]:
    fields: dict[str, st.SearchStrategy[Any]] = {}
    for f in mt.codec.fields:
        if f.wire == "f64":
            fields[f.name] = st.floats(f.minimum, f.maximum, allow_nan=False)
        else:
            fields[f.name] = st.integers(int(f.minimum), int(f.maximum))
    return st.builds(mt.cls, **fields)


def _over_bus(vbus: tuple[can.BusABC, can.BusABC], frames: list[can.Message]) -> list:
    tx, rx = vbus
    for frame in frames:
        tx.send(frame)
    received = []
    for _ in frames:
        got = rx.recv(timeout=2.0)
        assert got is not None
        received.append(got)
    return received


def _check_round_trip(mt: MessageType, sent: msgspec.Struct, got: msgspec.Struct) -> None:
    for s in message_signals(mt):
        a, b = getattr(sent, s.name), getattr(got, s.name)
        if s.kind == "float":
            tol = 0.5 * s.scale * (1 + 1e-9) + 1e-12 * max(abs(s.minimum), abs(s.maximum))
            assert abs(b - a) <= tol, (s.name, a, b, s.scale)
            assert s.minimum <= b <= s.maximum
        elif s.kind == "seq":
            assert b == a % WRAP  # first message of a fresh receiver: no unwrapping history
        elif s.kind == "time":
            assert b == ((a + 500) // 1000 % WRAP) * 1000
        else:
            assert b == a


@pytest.mark.parametrize("fd", [False, True], ids=["classic", "fd"])
@pytest.mark.parametrize("mt", CAN_MESSAGES, ids=lambda mt: mt.name)
def test_round_trip_over_virtual_bus(
    vbus: tuple[can.BusABC, can.BusABC], mt: MessageType, fd: bool
) -> None:
    @settings(
        max_examples=60,
        deadline=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture],
    )
    @given(_strategy(mt), st.integers(0, 15))
    def check(msg: msgspec.Struct, alive: int) -> None:
        frames = encode(msg, alive, fd=fd)
        assert len(frames) == len(layouts(fd)[mt.cls].parts)
        rx = Reassembler(clock=lambda: 42, fd=fd)
        out = None
        for i, frame in enumerate(_over_bus(vbus, frames)):
            out = rx.feed(frame)
            assert (out is None) == (i < len(frames) - 1)
        assert out is not None, rx.rejected
        assert type(out) is mt.cls
        assert not rx.rejected
        _check_round_trip(mt, msg, out)
        assert out.publish_time_ns == 42  # type: ignore[attr-defined]

    check()


def _command(seq: int, **kw: Any) -> ActuatorCommand:
    values: dict[str, Any] = {
        "seq": seq,
        "answered_seq": seq,
        "sample_time_ns": seq * 10_000_000,
        "publish_time_ns": 0,
        "mode": 0,
        "blade_pitch_commanded_rad": 0.1,
        "generator_torque_commanded_nm": 40_000.0,
    }
    values.update(kw)
    return ActuatorCommand(**values)


def _frame(seq: int, **kw: Any) -> SensorFrame:
    values: dict[str, Any] = {
        name: 0.0 for name, typ in SensorFrame.__annotations__.items() if "float" in str(typ)
    }
    values.update(seq=seq, sample_time_ns=seq * 25_000_000, publish_time_ns=0, valid_mask=3)
    values.update(kw)
    return SensorFrame(**values)


def _feed(rx: Reassembler, frames: list[can.Message]) -> list[Any]:
    return [m for m in (rx.feed(f) for f in frames) if m is not None]


def _with_data(frame: can.Message, data: bytes | bytearray, fix_crc: bool = True) -> can.Message:
    data = bytearray(data)
    if fix_crc:
        data[0] = frame_crc(frame.arbitration_id, data)
    return can.Message(
        arbitration_id=frame.arbitration_id, data=data, is_extended_id=False, is_fd=frame.is_fd
    )


def test_sequence_and_time_unwrap_across_the_32_bit_wrap() -> None:
    enc, rx = Encoder(), Reassembler()
    start = WRAP - 2
    got = []
    for seq in range(start, start + 5):
        got += _feed(rx, enc.encode(_frame(seq, sample_time_ns=seq * 1000)))
    # the first one is taken as sent (< 2^32 here); every later one continues past the wrap
    assert [m.seq for m in got] == list(range(start, start + 5))
    assert [m.sample_time_ns - got[0].sample_time_ns for m in got] == [0, 1000, 2000, 3000, 4000]
    assert unwrap(WRAP - 1, 0) == WRAP
    assert unwrap(WRAP + 5, 3) == WRAP + 3
    assert unwrap(10, 5) == 5


def test_bad_checksum_rejected_and_counted() -> None:
    enc, rx = Encoder(), Reassembler()
    frames = enc.encode(_frame(0))
    bad = bytearray(frames[2].data)
    bad[4] ^= 0x01
    frames[2] = _with_data(frames[2], bad, fix_crc=False)
    assert _feed(rx, frames) == []
    assert rx.rejected["bad_checksum"] == 1
    # the instance lacks that part: counted incomplete when the next one starts, which is kept
    assert [m.seq for m in _feed(rx, enc.encode(_frame(1)))] == [1]
    assert rx.rejected["incomplete"] == 1


def test_crc_covers_the_can_id() -> None:
    rx = Reassembler()
    frames = encode(_command(0), 0)
    moved = can.Message(arbitration_id=frames[1].arbitration_id, data=frames[0].data)
    moved.is_extended_id = False
    assert rx.feed(moved) is None
    assert rx.rejected["bad_checksum"] == 1


def test_repeated_alive_counter_rejected_and_counted() -> None:
    enc, rx = Encoder(), Reassembler()
    frames = enc.encode(_command(0))
    assert len(_feed(rx, frames)) == 1
    assert _feed(rx, frames) == []  # a replay of the same instance
    assert rx.rejected["alive_repeated"] == 1
    assert rx.discarded_frames == len(frames) - 1
    assert [m.seq for m in _feed(rx, enc.encode(_command(1)))] == [1]


def test_skipped_alive_counter_rejected_and_counted() -> None:
    rx = Reassembler()
    assert len(_feed(rx, encode(_command(0), 0))) == 1
    assert _feed(rx, encode(_command(2), 2)) == []  # instance with alive 1 was lost
    assert rx.rejected["alive_skipped"] == 1
    assert [m.seq for m in _feed(rx, encode(_command(3), 3))] == [3]  # resynchronised
    # the counter wraps 15 -> 0 without complaint
    for k in range(4, 20):
        assert len(_feed(rx, encode(_command(k), k % 16))) == 1
    assert rx.rejected["alive_skipped"] == 1


def test_unknown_id_and_wrong_length_rejected_and_counted() -> None:
    rx = Reassembler()
    assert rx.feed(can.Message(arbitration_id=0x7FF, data=bytes(8), is_extended_id=False)) is None
    assert rx.feed(can.Message(arbitration_id=0x120, data=bytes(8), is_extended_id=True)) is None
    assert rx.rejected["unknown_id"] == 2
    frames = encode(_frame(0), 0)
    short = can.Message(arbitration_id=frames[0].arbitration_id, data=frames[0].data[:7])
    short.is_extended_id = False
    assert rx.feed(short) is None
    assert rx.rejected["wrong_length"] == 1


@pytest.mark.parametrize(
    "value", [math.nan, math.inf, 600.0, -51.0], ids=["nan", "inf", "above", "below"]
)
def test_out_of_range_value_rejected_and_counted(value: float) -> None:
    rx = Reassembler()
    assert _feed(rx, encode(_frame(0, generator_speed_measured_rad_s=value), 0)) == []
    assert rx.rejected["out_of_range"] == 1
    assert len(_feed(rx, encode(_frame(1), 1))) == 1  # the stream goes on


def test_raw_value_beyond_the_range_rejected() -> None:
    """A frame crafted by another sender: raw code just above le (valid checksum)."""
    rx = Reassembler()
    layout = layouts(False)[ActuatorCommand]
    frames = encode(_command(0), 0)
    k, part = next(
        (k, p)
        for k, p in enumerate(layout.parts)
        if "blade_pitch_commanded_rad" in [s.name for s in p.signals]
    )
    values = part.decode(bytes(frames[k].data), decode_choices=False, scaling=False)
    assert isinstance(values, dict)
    sig = part.get_signal_by_name("blade_pitch_commanded_rad")
    values["blade_pitch_commanded_rad"] = round((1.6 + 0.2) / sig.scale) + 3  # 3 steps above le
    frames[k] = _with_data(frames[k], part.encode(values, scaling=False, strict=False))
    assert _feed(rx, frames) == []
    assert rx.rejected["out_of_range"] == 1


def test_missing_part_rejected_and_counted() -> None:
    enc, rx = Encoder(), Reassembler()
    frames = enc.encode(_frame(0))
    del frames[3]
    assert _feed(rx, frames) == []
    assert [m.seq for m in _feed(rx, enc.encode(_frame(1)))] == [1]
    assert rx.rejected["incomplete"] == 1
    assert rx.rejected_total == 1


def test_inconsistent_parts_rejected_and_counted() -> None:
    enc, rx = Encoder(), Reassembler()
    frames = enc.encode(_frame(0))
    other = encode(_frame(0, wind_speed_measured_m_s=12.0), frames[0].data[1] & 0x0F)
    changed = next(
        i for i, (a, b) in enumerate(zip(frames, other, strict=True)) if a.data != b.data
    )
    # part `changed` twice within one instance, with different data
    assert _feed(rx, [*frames[: changed + 1], other[changed], *frames[changed + 1 :]]) == []
    assert rx.rejected["inconsistent"] == 1
    # a part whose part index is not its id's
    rx2 = Reassembler()
    wrong = bytearray(frames[1].data)
    wrong[1] = (wrong[1] & 0x0F) | (5 << 4)
    assert rx2.feed(_with_data(frames[1], wrong)) is None
    assert rx2.rejected["inconsistent"] == 1
    # an exact duplicate of a part is harmless
    rx3 = Reassembler()
    assert len(_feed(rx3, [frames[0], *frames])) == 1
    assert not rx3.rejected and rx3.discarded_frames == 1


def test_can_bus_counts_rejections_and_delivers_payloads() -> None:
    """The transport on a virtual bus: a corrupt instance counted, the good ones delivered."""
    from bus_schemas.registry import SENSORS

    channel = f"test-canbus-{uuid.uuid4()}"
    raw = can.Bus(interface="virtual", channel=channel)
    with CanBus(CanBusConfig(channel=channel)) as tx, CanBus(CanBusConfig(channel=channel)) as rx:
        payloads: list[bytes] = []
        rx.subscribe(SENSORS.key("t1"), lambda _k, p: payloads.append(p))
        tx.publish(SENSORS, _frame(0))
        raw.send(can.Message(arbitration_id=0x7F0, data=bytes(8), is_extended_id=False))
        tx.put(SENSORS.key("t1"), SENSORS.codec.encode(_frame(1)))
        deadline = time.monotonic() + 2.0
        while len(payloads) < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert [SENSORS.codec.decode(p).seq for p in payloads] == [0, 1]
        assert rx.rejected["unknown_id"] == 1
        assert tx.frames_sent == 14
    raw.shutdown()
