"""The CAN database: generated from bus_schemas, shipped current, readable by cantools."""

from __future__ import annotations

import math

import cantools
import crccheck.crc  # type: ignore[import-untyped]
import pytest

from bus_schemas.can_codec import crc8_sae_j1850
from bus_schemas.can_db import (
    CAN_IDS,
    CAN_MESSAGES,
    CLASSIC_LENGTH,
    DBC_PATH,
    FLOAT_WIDTHS,
    WRAP,
    dbc_text,
    main,
    resolution,
)
from bus_schemas.registry import MessageType


@pytest.fixture(scope="module")
def db() -> cantools.database.can.Database:
    loaded = cantools.database.load_file(DBC_PATH)
    assert isinstance(loaded, cantools.database.can.Database)
    return loaded


def test_shipped_dbc_is_the_generated_one() -> None:
    """Regenerate with ``python -m bus_schemas.can_db --write`` when this fails."""
    assert DBC_PATH.read_text(encoding="utf-8") == dbc_text()
    assert main(["--check"]) == 0


def _parts(db: cantools.database.can.Database, mt: MessageType) -> list:
    return [m for m in db.messages if m.name.startswith(f"{mt.name}_P")]


@pytest.mark.parametrize("mt", CAN_MESSAGES, ids=lambda mt: mt.name)
@pytest.mark.parametrize("fd", [False, True], ids=["classic", "fd"])
def test_every_field_has_its_signal(
    db: cantools.database.can.Database, mt: MessageType, fd: bool
) -> None:
    classic_id, fd_id = CAN_IDS[mt.cls]
    if fd:
        messages = [db.get_message_by_frame_id(fd_id)]
        assert messages[0].is_fd
        assert messages[0].length in (8, 12, 16, 20, 24, 32, 48, 64)
    else:
        messages = _parts(db, mt)
        assert [m.frame_id for m in messages] == list(range(classic_id, classic_id + len(messages)))
        assert all(m.length == CLASSIC_LENGTH and not m.is_fd for m in messages)
    signals = {}
    for m in messages:
        names = [s.name for s in m.signals]
        assert {"crc", "alive", "part"} <= set(names)
        header = {s.name: s for s in m.signals if s.name in ("crc", "alive", "part")}
        assert (header["crc"].start, header["crc"].length) == (0, 8)
        assert (header["alive"].start, header["alive"].length) == (8, 4)
        assert (header["part"].start, header["part"].length) == (12, 4)
        for s in m.signals:
            assert s.start + s.length <= 8 * m.length
            if s.name not in header:
                assert s.name not in signals, f"{s.name} in two parts"
                signals[s.name] = s
    for f in mt.codec.fields:
        if f.name == "publish_time_ns":
            assert f.name not in signals  # receiver-side clock on CAN
            continue
        s = signals.pop(f.name)
        assert s.unit == f.unit
        assert not s.is_signed and s.byte_order == "little_endian"
        if f.wire == "f64":
            assert s.minimum == f.minimum and s.maximum == f.maximum
            assert s.offset == f.minimum
            assert s.length in FLOAT_WIDTHS
            assert s.scale <= resolution(mt, f)
            # the declared range fits below the reserved all-ones code
            assert (f.maximum - f.minimum) / s.scale <= 2**s.length - 2 + 1e-6
        elif f.wire == "u64":
            assert (s.length, s.scale, s.offset) == (32, 1, 0)
            assert (s.minimum, s.maximum) == (0, WRAP - 1)
        elif f.wire == "i64":
            assert (s.length, s.scale, s.offset, s.unit) == (32, 1000, 0, "ns")
        else:
            assert (s.minimum, s.maximum, s.scale) == (f.minimum, f.maximum, 1)
            assert 2**s.length - 1 >= f.maximum
    assert not signals, f"signals without a field: {sorted(signals)}"


def test_ids_are_standard_and_unique(db: cantools.database.can.Database) -> None:
    ids = [m.frame_id for m in db.messages]
    assert len(ids) == len(set(ids))
    assert all(
        0 <= i <= 0x7FF and not m.is_extended_frame for i, m in zip(ids, db.messages, strict=True)
    )
    # the command wins arbitration over the sensor frame
    assert max(m.frame_id for m in db.messages if m.name.startswith("ActuatorCommand_P")) < min(
        m.frame_id for m in db.messages if m.name.startswith("SensorFrame_P")
    )


def test_crc8_is_sae_j1850() -> None:
    assert crc8_sae_j1850(b"123456789") == 0x4B  # the catalogued check value
    for data in (b"", b"\x00", b"\xff" * 9, bytes(range(64))):
        assert crc8_sae_j1850(data) == crccheck.crc.Crc8SaeJ1850.calc(data)


def test_scales_are_round_numbers(db: cantools.database.can.Database) -> None:
    for m in db.messages:
        for s in m.signals:
            mantissa = s.scale / 10 ** math.floor(math.log10(s.scale))
            assert round(mantissa, 9) in (1.0, 2.0, 5.0), (m.name, s.name, s.scale)
