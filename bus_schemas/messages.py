"""Every message on the bench's bus, each declared exactly once.

A message is a frozen ``msgspec.Struct``. Each field carries its unit in its name
(``rotor_speed_rad_s``), a source suffix where it is a signal (``_measured``,
``_commanded``, ``_estimated``), and a ``msgspec.Meta`` with its physical range, unit and
description. Everything else — the binary Zenoh payload codec, the JSON Schema of the MCAP
channels, and (later) the CAN database — is derived from these declarations by
:mod:`bus_schemas.codec` and :mod:`bus_schemas.registry`, so nothing is declared twice.

Conventions
-----------
* ``seq``: per-publisher sequence number, strictly increasing from 0.
* ``sample_time_ns``: simulated time of the sample, integer nanoseconds since run start.
* ``publish_time_ns``: ``time.monotonic_ns()`` of the publishing process at publish time
  (only comparable between processes on one host; deadlines use the plant's own clock).
* ``version``: not a field; it is in the payload header and in :data:`SCHEMA_VERSIONS`.
"""

from __future__ import annotations

from typing import Annotated

import msgspec

_U64_MAX = 2**64 - 1
_I64_MAX = 2**63 - 1


Seq = Annotated[
    int,
    msgspec.Meta(
        ge=0, le=_U64_MAX, description="sequence number", extra={"unit": "1", "wire": "u64"}
    ),
]
TimeNs = Annotated[
    int, msgspec.Meta(ge=0, le=_I64_MAX, description="time", extra={"unit": "ns", "wire": "i64"})
]
Count = Annotated[
    int, msgspec.Meta(ge=0, le=2**32 - 1, description="count", extra={"unit": "1", "wire": "u32"})
]
Flag = Annotated[
    int,
    msgspec.Meta(
        ge=0, le=255, description="flag or enumeration", extra={"unit": "1", "wire": "u8"}
    ),
]


def M(unit: str, lo: float, hi: float, doc: str) -> msgspec.Meta:  # noqa: N802 - reads as a type
    """Metadata of a float field: unit, physical range [lo, hi] and description."""
    return msgspec.Meta(ge=lo, le=hi, description=doc, extra={"unit": unit, "wire": "f64"})


class SensorFrame(msgspec.Struct, frozen=True, kw_only=True):
    """Noisy sensor readings published by the plant every control period.

    Only measured values travel here; the true plant state has its own channel
    (:class:`PlantState`). Signals a plant does not have (a bottom-fixed turbine has no
    platform motion) are reported as 0 with the matching bit of ``valid_mask`` cleared.
    """

    seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    valid_mask: Count
    generator_speed_measured_rad_s: Annotated[
        float, M("rad/s", -50.0, 500.0, "generator (HSS) speed encoder")
    ]
    rotor_speed_measured_rad_s: Annotated[float, M("rad/s", -5.0, 10.0, "rotor (LSS) speed")]
    blade_pitch_measured_rad: Annotated[
        float, M("rad", -0.5, 1.8, "collective blade pitch encoder")
    ]
    generator_torque_measured_nm: Annotated[float, M("N m", -1e6, 1e8, "generator torque (HSS)")]
    electrical_power_measured_w: Annotated[float, M("W", -1e8, 1e8, "electrical power")]
    wind_speed_measured_m_s: Annotated[float, M("m/s", -80.0, 80.0, "nacelle anemometer")]
    nacelle_acc_fore_aft_measured_m_s2: Annotated[
        float, M("m/s^2", -50.0, 50.0, "nacelle IMU fore-aft acceleration")
    ]
    platform_pitch_measured_rad: Annotated[float, M("rad", -1.0, 1.0, "platform pitch angle")]
    platform_pitch_rate_measured_rad_s: Annotated[
        float, M("rad/s", -2.0, 2.0, "platform pitch rate (IMU)")
    ]
    platform_surge_measured_m: Annotated[float, M("m", -200.0, 200.0, "platform surge position")]
    wave_elevation_gauge_measured_m: Annotated[
        float, M("m", -40.0, 40.0, "upstream wave gauge elevation")
    ]


class ActuatorCommand(msgspec.Struct, frozen=True, kw_only=True):
    """Pitch and torque demand answering one :class:`SensorFrame`.

    ``answered_seq`` echoes the ``seq`` of the frame this command answers, so the plant
    can measure sensor-to-command latency on its own clock and discard stale commands.
    """

    seq: Seq
    answered_seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    mode: Flag
    blade_pitch_commanded_rad: Annotated[
        float, M("rad", -0.2, 1.6, "collective blade pitch demand")
    ]
    generator_torque_commanded_nm: Annotated[
        float, M("N m", 0.0, 5e7, "generator torque demand (HSS)")
    ]


class PlantState(msgspec.Struct, frozen=True, kw_only=True):
    """True plant state and loads, for logging and review only (never to a controller)."""

    seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    rotor_speed_rad_s: Annotated[float, M("rad/s", -5.0, 10.0, "rotor (LSS) speed")]
    generator_speed_rad_s: Annotated[float, M("rad/s", -50.0, 500.0, "generator (HSS) speed")]
    blade_pitch_rad: Annotated[float, M("rad", -0.5, 1.8, "collective blade pitch")]
    generator_torque_nm: Annotated[float, M("N m", -1e6, 1e8, "generator torque (HSS)")]
    aero_torque_nm: Annotated[float, M("N m", -1e9, 1e9, "aerodynamic torque on the rotor (LSS)")]
    rotor_thrust_n: Annotated[float, M("N", -1e8, 1e8, "rotor thrust")]
    wind_speed_m_s: Annotated[float, M("m/s", -80.0, 80.0, "rotor-effective (hub) wind speed")]
    relative_wind_speed_m_s: Annotated[
        float, M("m/s", -80.0, 80.0, "wind speed relative to the moving rotor")
    ]
    electrical_power_w: Annotated[float, M("W", -1e8, 1e8, "electrical power")]
    tip_speed_ratio: Annotated[float, M("1", -50.0, 50.0, "tip-speed ratio")]
    power_coefficient: Annotated[float, M("1", -5.0, 5.0, "Cp at the operating point")]
    thrust_coefficient: Annotated[float, M("1", -5.0, 5.0, "Ct at the operating point")]
    blade_pitch_applied_rad: Annotated[
        float, M("rad", -0.5, 1.8, "pitch demand applied this cycle")
    ]
    generator_torque_applied_nm: Annotated[
        float, M("N m", -1e6, 1e8, "torque demand applied this cycle")
    ]


class ControllerStatus(msgspec.Struct, frozen=True, kw_only=True):
    """Controller internals published every cycle beside the command."""

    seq: Seq
    answered_seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    compute_time_ns: TimeNs
    regime: Flag
    rejected_frames: Count
    generator_speed_filtered_rad_s: Annotated[
        float, M("rad/s", -50.0, 500.0, "low-pass filtered generator speed")
    ]
    pitch_integrator_rad: Annotated[float, M("rad", -10.0, 10.0, "pitch PI integral term")]
    gain_schedule_factor: Annotated[float, M("1", 0.0, 100.0, "pitch gain-schedule factor")]


class CycleTiming(msgspec.Struct, frozen=True, kw_only=True):
    """The plant's measurement of one control cycle, on its own clock."""

    seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    latency_ns: TimeNs
    deadline_missed: Flag
    command_held: Flag
    safe_state: Flag
    plant_compute_ns: TimeNs
    tick_lateness_ns: TimeNs


class TimingSummary(msgspec.Struct, frozen=True, kw_only=True):
    """Running latency histogram summary; ``final`` = 1 on the last one of a run."""

    seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    cycles: Count
    deadline_misses: Count
    commands_held: Count
    commands_rejected: Count
    commands_late: Count
    safe_state: Flag
    final: Flag
    latency_p50_us: Annotated[float, M("us", 0.0, 1e12, "latency median")]
    latency_p99_us: Annotated[float, M("us", 0.0, 1e12, "latency 99th percentile")]
    latency_p999_us: Annotated[float, M("us", 0.0, 1e12, "latency 99.9th percentile")]
    latency_max_us: Annotated[float, M("us", 0.0, 1e12, "latency maximum")]
    sim_seconds_per_wall_second: Annotated[float, M("1", 0.0, 1e9, "achieved speed over real time")]
