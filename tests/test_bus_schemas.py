"""Codec round trips and rejection of bad payloads, derived from the one declaration."""

from __future__ import annotations

import json
import math
import struct
import typing

import msgspec
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bus_schemas import (
    DecodeError,
    HeaderError,
    NonFiniteError,
    RangeError,
    SensorFrame,
    TruncatedError,
    VersionError,
)
from bus_schemas.codec import FieldSpec
from bus_schemas.messages import CONTROLLER_REJECT_REASONS, PLANT_REJECT_REASONS
from bus_schemas.registry import MESSAGES, SENSORS, MessageType, decode_any

_INT_MAX = {"u64": 2**64 - 1, "i64": 2**63 - 1, "u32": 2**32 - 1, "u8": 255}


def _field_strategy(f: FieldSpec) -> st.SearchStrategy[object]:
    if f.is_float:
        return st.floats(min_value=f.minimum, max_value=f.maximum, allow_nan=False)
    return st.integers(min_value=int(f.minimum), max_value=min(int(f.maximum), _INT_MAX[f.wire]))


def _message_strategy(mt: MessageType) -> st.SearchStrategy[msgspec.Struct]:
    return st.builds(mt.cls, **{f.name: _field_strategy(f) for f in mt.codec.fields})


@pytest.mark.parametrize("mt", MESSAGES, ids=lambda m: m.name)
@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_round_trip_is_exact(mt: MessageType, data: st.DataObject) -> None:
    msg = data.draw(_message_strategy(mt))
    payload = mt.codec.encode(msg)
    assert len(payload) == mt.codec.size
    assert mt.codec.decode(payload) == msg
    got_type, got = decode_any(payload)
    assert got_type is mt and got == msg


@pytest.mark.parametrize("mt", MESSAGES, ids=lambda m: m.name)
@settings(max_examples=300, deadline=None)
@given(data=st.data())
def test_truncated_or_padded_payloads_are_rejected(mt: MessageType, data: st.DataObject) -> None:
    payload = mt.codec.encode(data.draw(_message_strategy(mt)))
    cut = data.draw(st.integers(min_value=0, max_value=len(payload) - 1))
    with pytest.raises(DecodeError):
        mt.codec.decode(payload[:cut])
    with pytest.raises(TruncatedError):
        mt.codec.decode(payload + b"\x00")


@settings(max_examples=2000, deadline=None)
@given(blob=st.binary(max_size=300))
def test_random_bytes_never_crash_and_never_decode_silently(blob: bytes) -> None:
    for mt in MESSAGES:
        try:
            msg = mt.codec.decode(blob)
        except DecodeError:
            continue
        # Anything that decodes must re-encode to the same bytes: nothing was invented.
        assert mt.codec.encode(msg) == blob


def _frame(**over: float) -> SensorFrame:
    base = {
        f.name: (0 if not f.is_float else max(f.minimum, min(f.maximum, 1.0)))
        for f in SENSORS.codec.fields
    }
    base.update(over)
    return SensorFrame(**base)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_float_is_rejected_naming_the_field(bad: float) -> None:
    good = SENSORS.codec.encode(_frame())
    idx = [f.name for f in SENSORS.codec.fields].index("generator_speed_measured_rad_s")
    values = list(struct.unpack(SENSORS.codec._struct.format, good))
    values[3 + idx] = bad
    payload = struct.pack(SENSORS.codec._struct.format, *values)
    with pytest.raises(NonFiniteError) as err:
        SENSORS.codec.decode(payload)
    assert err.value.field == "generator_speed_measured_rad_s"
    assert err.value.reason == "non_finite"


def test_out_of_range_value_is_rejected_with_range_and_unit() -> None:
    payload = SENSORS.codec.encode(_frame(blade_pitch_measured_rad=3.0))
    with pytest.raises(RangeError) as err:
        SENSORS.codec.decode(payload)
    assert "blade_pitch_measured_rad" in str(err.value) and "rad" in str(err.value)


def test_other_version_and_other_message_are_rejected() -> None:
    payload = bytearray(SENSORS.codec.encode(_frame()))
    struct.pack_into("<H", payload, 2, SENSORS.version + 1)
    with pytest.raises(VersionError):
        SENSORS.codec.decode(bytes(payload))
    other = MESSAGES[1].codec.encode(
        MESSAGES[1].cls(
            **{f.name: (0 if not f.is_float else 0.0) for f in MESSAGES[1].codec.fields}
        )
    )
    with pytest.raises((HeaderError, TruncatedError)):
        SENSORS.codec.decode(other)


def test_json_schema_is_flat_and_names_units_and_ranges() -> None:
    for mt in MESSAGES:
        schema = mt.json_schema()
        json.dumps(schema)  # serialisable
        assert "$ref" not in json.dumps(schema)
        assert set(schema["required"]) == set(mt.cls.__struct_fields__)
        for f in mt.codec.fields:
            prop = schema["properties"][f.name]
            assert prop["type"] == ("number" if f.is_float else "integer")
            assert f"[{f.unit}]" in prop["description"]
            assert prop["minimum"] == f.minimum and prop["maximum"] == f.maximum


def test_every_field_names_its_unit_or_is_a_counter() -> None:
    unit_suffixes = ("_rad_s", "_rad", "_nm", "_n", "_w", "_m_s", "_m_s2", "_m", "_ns", "_us", "_s")
    dimensionless = {
        "seq",
        "answered_seq",
        "valid_mask",
        "mode",
        "regime",
        "rejected_frames",
        "deadline_missed",
        "command_held",
        "safe_state",
        "cycles",
        "deadline_misses",
        "commands_held",
        "commands_rejected",
        "commands_late",
        "safe_state_cycles",
        "faults_injected",
        "final",
        "tip_speed_ratio",
        "power_coefficient",
        "thrust_coefficient",
        "gain_schedule_factor",
        "sim_seconds_per_wall_second",
        "floating",
        "estimates_valid_mask",
        "estimator_degraded",
        "forecast_unstable_fits",
        "forecast_guarded",
        "estimator_faults",
        # the end-of-run reports (PlantReport, ControllerReport): flags and counts
        "aborted",
        "sensor_frames_published",
        "truth_published",
        "cycle_records_published",
        "summaries_published",
        "previews_published",
        "commands_applied",
        "frames_accepted",
        "commands_published",
        "statuses_published",
        "safe_mode",
        "safe_mode_entries",
        "safe_mode_commands",
        "frames_missing",
        "frames_stale",
        "core_fault",
        "core_fault_seq",
        "core_fault_field",
        "core_fault_commands",
        *(f"commands_rejected_{r}" for r in PLANT_REJECT_REASONS),
        *(f"frames_rejected_{r}" for r in CONTROLLER_REJECT_REASONS),
    }
    for mt in MESSAGES:
        for f in mt.codec.fields:
            assert f.name in dimensionless or f.name.endswith(unit_suffixes), (mt.name, f.name)


def test_ids_keys_and_sizes_are_unique() -> None:
    assert len({m.message_id for m in MESSAGES}) == len(MESSAGES)
    assert len({m.key_suffix for m in MESSAGES}) == len(MESSAGES)


def test_floating_fields_round_trip_and_appear_in_the_json_schema() -> None:
    from bus_schemas import ControllerStatus, PlantState
    from bus_schemas.messages import EST_WAVE_FORECAST, EST_WIND_SPEED
    from bus_schemas.registry import CONTROLLER_STATUS, TRUTH

    truth = PlantState(
        seq=3,
        sample_time_ns=75_000_000,
        publish_time_ns=1,
        rotor_speed_rad_s=0.7,
        generator_speed_rad_s=0.7,
        blade_pitch_rad=0.1,
        generator_torque_nm=1.9e7,
        aero_torque_nm=1.9e7,
        rotor_thrust_n=2.0e6,
        wind_speed_m_s=12.0,
        relative_wind_speed_m_s=11.8,
        electrical_power_w=1.5e7,
        tip_speed_ratio=9.0,
        power_coefficient=0.45,
        thrust_coefficient=0.7,
        blade_pitch_applied_rad=0.1,
        generator_torque_applied_nm=1.9e7,
        floating=1,
        platform_surge_m=18.5,
        platform_heave_m=-0.4,
        platform_pitch_rad=0.07,
        platform_surge_velocity_m_s=0.3,
        platform_heave_velocity_m_s=-0.01,
        platform_pitch_rate_rad_s=0.004,
        tower_top_displacement_m=0.3,
        tower_top_velocity_m_s=0.05,
        nacelle_acc_fore_aft_m_s2=0.2,
        wave_elevation_platform_m=1.1,
        wave_elevation_gauge_m=-0.8,
        wave_force_surge_n=3.0e6,
        wave_moment_pitch_nm=-4.0e7,
        tower_base_moment_nm=3.1e8,
        shaft_torque_nm=1.9e7,
    )
    assert TRUTH.version == 2
    assert TRUTH.codec.decode(TRUTH.codec.encode(truth)) == truth
    status = ControllerStatus(
        seq=1,
        answered_seq=1,
        sample_time_ns=25_000_000,
        publish_time_ns=2,
        compute_time_ns=10_000,
        regime=2,
        rejected_frames=0,
        generator_speed_filtered_rad_s=0.7,
        pitch_integrator_rad=0.0,
        gain_schedule_factor=1.0,
        estimates_valid_mask=EST_WIND_SPEED | EST_WAVE_FORECAST,
        wind_speed_estimated_m_s=11.9,
        wave_elevation_forecast_m=0.6,
        wave_forecast_time_ns=10_025_000_000,
        feedforward_torque_nm=-1.0e5,
    )
    assert CONTROLLER_STATUS.version == 3
    assert CONTROLLER_STATUS.codec.decode(CONTROLLER_STATUS.codec.encode(status)) == status
    # Baseline defaults: every optional estimate 0 and flagged invalid.
    bare = msgspec.structs.replace(status, estimates_valid_mask=0)
    assert bare.platform_pitch_estimated_rad == 0.0 and bare.estimator_degraded == 0
    props = TRUTH.json_schema()["properties"]
    for name in ("platform_surge_m", "tower_base_moment_nm", "wave_elevation_gauge_m"):
        assert name in props
    assert "N m" in json.dumps(props["tower_base_moment_nm"])
    sprops = CONTROLLER_STATUS.json_schema()["properties"]
    assert "wave_forecast_time_ns" in sprops and "feedforward_pitch_rad" in sprops


@pytest.mark.parametrize("mt", MESSAGES, ids=lambda mt: mt.name)
def test_row_dtype_is_the_struct_field_for_field_in_8_byte_columns(mt: MessageType) -> None:
    """A row buffer (float64, int columns through an int64 view) reads back as the Struct."""
    dtype = mt.row_dtype
    hints = typing.get_type_hints(mt.cls)
    assert dtype.names == mt.cls.__struct_fields__
    assert dtype.itemsize == 8 * len(dtype.names)  # packed: the 2-D buffer view holds
    for name in dtype.names:
        assert dtype[name] == (np.int64 if hints[name] is int else np.float64), name
    buf = np.zeros((3, len(dtype.names)))
    ints = buf.view(np.int64)
    for j, name in enumerate(dtype.names):
        if hints[name] is int:
            ints[:, j] = [1, 2, 3 + j]
        else:
            buf[:, j] = [0.5, -1.25, 2.0**40 + j]
    rows = buf.view(dtype).ravel()
    assert len(rows) == 3
    msg = mt.cls(**dict(zip(dtype.names, rows[2].tolist(), strict=True)))
    for j, name in enumerate(dtype.names):
        assert getattr(msg, name) == (3 + j if hints[name] is int else 2.0**40 + j), name
