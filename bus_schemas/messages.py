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
* The five messages of every control cycle (:class:`SensorFrame`, :class:`ActuatorCommand`,
  :class:`PlantState`, :class:`ControllerStatus`, :class:`CycleTiming`) take their fields
  positionally too (in declaration order, which is also the codec's): the in-process loop
  builds the large ones from kernel records that way (a 33-field keyword call costs about
  1.4 us more). They hold numbers only, so they can never be in a reference cycle and are
  declared ``gc=False`` (not tracked by Python's cycle collector: cheaper to create).
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


#: Bits of :attr:`SensorFrame.valid_mask`: bit set = the field holds a fresh, valid sample.
#: A channel that is absent (a bottom-fixed plant has no platform motion) or whose sample
#: was lost (dropout) has its bit cleared and its field set to 0.0, never to an older value.
VALID_GENERATOR_SPEED = 1 << 0
VALID_ROTOR_SPEED = 1 << 1
VALID_PITCH = 1 << 2
VALID_TORQUE = 1 << 3
VALID_POWER = 1 << 4
VALID_WIND = 1 << 5
VALID_NACELLE_ACC = 1 << 6
VALID_PLATFORM_PITCH = 1 << 7
VALID_PLATFORM_PITCH_RATE = 1 << 8
VALID_PLATFORM_SURGE = 1 << 9
VALID_WAVE_GAUGE = 1 << 10
#: SensorFrame field of each valid bit.
VALID_BITS: dict[str, int] = {
    "generator_speed_measured_rad_s": VALID_GENERATOR_SPEED,
    "rotor_speed_measured_rad_s": VALID_ROTOR_SPEED,
    "blade_pitch_measured_rad": VALID_PITCH,
    "generator_torque_measured_nm": VALID_TORQUE,
    "electrical_power_measured_w": VALID_POWER,
    "wind_speed_measured_m_s": VALID_WIND,
    "nacelle_acc_fore_aft_measured_m_s2": VALID_NACELLE_ACC,
    "platform_pitch_measured_rad": VALID_PLATFORM_PITCH,
    "platform_pitch_rate_measured_rad_s": VALID_PLATFORM_PITCH_RATE,
    "platform_surge_measured_m": VALID_PLATFORM_SURGE,
    "wave_elevation_gauge_measured_m": VALID_WAVE_GAUGE,
}

#: Bits of :attr:`ControllerStatus.estimates_valid_mask` (which optional estimates are set).
EST_WIND_SPEED = 1 << 0
EST_PLATFORM_PITCH = 1 << 1
EST_PLATFORM_PITCH_RATE = 1 << 2
EST_PLATFORM_SURGE = 1 << 3
EST_PLATFORM_SURGE_VELOCITY = 1 << 4
EST_TOWER_TOP_VELOCITY = 1 << 5
EST_WAVE_FORECAST = 1 << 6
EST_FEEDFORWARD = 1 << 7


class SensorFrame(msgspec.Struct, frozen=True, gc=False):
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


#: ``ActuatorCommand.mode`` values: the core's command; rate limited after the safe mode;
#: the safe command (the controller's watchdog); the core faulted (:data:`COMMAND_MODE_FAULT`).
COMMAND_MODE_NORMAL = 0
COMMAND_MODE_RESUMING = 1
COMMAND_MODE_SAFE = 2
#: The controller's core raised or gave a non-finite or out-of-range command on this frame
#: or an earlier one: the command's values are the controller's safe command, never the
#: core's, and a plant never applies it (it goes to its safe state).
COMMAND_MODE_FAULT = 3


class ActuatorCommand(msgspec.Struct, frozen=True, gc=False):
    """Pitch and torque demand answering one :class:`SensorFrame`.

    ``answered_seq`` echoes the ``seq`` of the frame this command answers, so the plant
    can measure sensor-to-command latency on its own clock and discard stale commands.
    ``mode``: 0 the core's command, 1 resuming after the safe mode, 2 the safe command,
    3 the core faulted (not to be applied; :data:`COMMAND_MODE_FAULT`).
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


class PlantState(msgspec.Struct, frozen=True, gc=False):
    """True plant state and loads, for logging and review only (never to a controller).

    Version 2 adds the floating platform (all 0 for a bottom-fixed plant), the wave
    elevations and the loads. Sign conventions: x downwind, z up, platform pitch positive
    when the tower top moves downwind; displacements about the platform reference point at
    the still-water line.

    Tower-base fore-aft bending moment (about the lateral axis through the tower base at
    height h_b above the still-water line, in the platform frame, small angles; positive
    bending the tower downwind), from the rotor thrust T at the hub lever h_hub and the
    gravity and d'Alembert inertia forces of every mass above the base:

        M_tb = T (h_hub - h_b) + Σ_j m_j [g d_j - a_j (h_j - h_b)] - Σ_j I_j (φ̈ + κ_j s̈)

    with d_j the fore-aft offset of mass j from the tower axis at the base (its overhang
    plus (h_j - h_b) φ plus its tower-mode displacement ψ_j s), a_j = ẍ + h_j φ̈ + ψ_j s̈
    its fore-aft acceleration, I_j its pitch inertia (the rotor) and κ_j its slope per
    metre of s; the tower's own masses enter through the integrals ∫(h - h_b) dm,
    ∫h (h - h_b) dm, ∫ψ dm and ∫ψ (h - h_b) dm of the mode shape ψ (vertical accelerations
    neglected). Bottom-fixed plant: M_tb = T (h_hub - 0) (no tower model, base at 0).

    Low-speed-shaft torque: rigid drivetrain with the inertia lumped on the rotor side,
    T_lss = N T_g (the generator reaction referred to the LSS; generator inertia neglected).
    """

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
    floating: Flag = 0
    platform_surge_m: Annotated[float, M("m", -500.0, 500.0, "platform surge")] = 0.0
    platform_heave_m: Annotated[float, M("m", -100.0, 100.0, "platform heave")] = 0.0
    platform_pitch_rad: Annotated[float, M("rad", -1.5, 1.5, "platform pitch")] = 0.0
    platform_surge_velocity_m_s: Annotated[
        float, M("m/s", -50.0, 50.0, "platform surge velocity")
    ] = 0.0
    platform_heave_velocity_m_s: Annotated[
        float, M("m/s", -50.0, 50.0, "platform heave velocity")
    ] = 0.0
    platform_pitch_rate_rad_s: Annotated[float, M("rad/s", -5.0, 5.0, "platform pitch rate")] = 0.0
    tower_top_displacement_m: Annotated[
        float, M("m", -50.0, 50.0, "tower-top fore-aft deflection (first mode)")
    ] = 0.0
    tower_top_velocity_m_s: Annotated[
        float, M("m/s", -50.0, 50.0, "tower-top fore-aft deflection rate")
    ] = 0.0
    nacelle_acc_fore_aft_m_s2: Annotated[
        float, M("m/s^2", -100.0, 100.0, "nacelle fore-aft kinematic acceleration")
    ] = 0.0
    wave_elevation_platform_m: Annotated[
        float, M("m", -50.0, 50.0, "wave elevation at the platform")
    ] = 0.0
    wave_elevation_gauge_m: Annotated[
        float, M("m", -50.0, 50.0, "wave elevation at the upstream gauge")
    ] = 0.0
    wave_force_surge_n: Annotated[float, M("N", -1e10, 1e10, "wave excitation surge force")] = 0.0
    wave_moment_pitch_nm: Annotated[
        float, M("N m", -1e12, 1e12, "wave excitation pitch moment")
    ] = 0.0
    tower_base_moment_nm: Annotated[
        float, M("N m", -1e11, 1e11, "tower-base fore-aft bending moment")
    ] = 0.0
    shaft_torque_nm: Annotated[float, M("N m", -1e9, 1e9, "low-speed-shaft torque")] = 0.0


class ControllerStatus(msgspec.Struct, frozen=True, gc=False):
    """Controller internals published every cycle beside the command.

    Version 2 adds the estimates, forecast and feedforward of an advanced controller. They
    default to 0; ``estimates_valid_mask`` says which hold a value (bits ``EST_*`` of this
    module); the baseline sets none. ``estimator_degraded`` = 1 when an estimator runs on
    missing or invalid measurements. ``forecast_unstable_fits`` and ``forecast_guarded`` count
    (since the start) the AR/ESPRIT wave-forecaster fits stabilised for poles outside the unit
    circle and the forecasts the bound guard replaced by 0 m (``controller.forecast``).
    Version 3 adds ``estimator_faults``: the estimator divergences the controller detected
    since the start, each one starting its fallback (``controller.interface.ControlOutput``).
    """

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
    estimates_valid_mask: Count = 0
    estimator_degraded: Flag = 0
    wind_speed_estimated_m_s: Annotated[
        float, M("m/s", -80.0, 80.0, "rotor-effective wind speed estimate")
    ] = 0.0
    platform_pitch_estimated_rad: Annotated[
        float, M("rad", -1.5, 1.5, "platform pitch estimate")
    ] = 0.0
    platform_pitch_rate_estimated_rad_s: Annotated[
        float, M("rad/s", -5.0, 5.0, "platform pitch rate estimate")
    ] = 0.0
    platform_surge_estimated_m: Annotated[
        float, M("m", -500.0, 500.0, "platform surge estimate")
    ] = 0.0
    platform_surge_velocity_estimated_m_s: Annotated[
        float, M("m/s", -50.0, 50.0, "platform surge velocity estimate")
    ] = 0.0
    tower_top_velocity_estimated_m_s: Annotated[
        float, M("m/s", -50.0, 50.0, "tower-top fore-aft velocity estimate")
    ] = 0.0
    wave_elevation_forecast_m: Annotated[
        float, M("m", -50.0, 50.0, "forecast wave elevation at the platform")
    ] = 0.0
    wave_forecast_time_ns: TimeNs = 0
    feedforward_pitch_rad: Annotated[
        float, M("rad", -2.0, 2.0, "feedforward part of the pitch demand")
    ] = 0.0
    feedforward_torque_nm: Annotated[
        float, M("N m", -1e8, 1e8, "feedforward part of the torque demand (HSS)")
    ] = 0.0
    forecast_unstable_fits: Count = 0
    forecast_guarded: Count = 0
    estimator_faults: Count = 0


class CycleTiming(msgspec.Struct, frozen=True, gc=False):
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
    """Running latency histogram summary; ``final`` = 1 on the last one of a run.

    ``safe_state`` is the watchdog's state now, ``safe_state_cycles`` the cycles spent in it
    so far; ``faults_injected`` counts every fault the scenario's ``[[faults]]`` applied
    (all kinds; the per-kind counts are in the plant's log line).
    """

    seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    cycles: Count
    deadline_misses: Count
    commands_held: Count
    commands_rejected: Count
    commands_late: Count
    safe_state: Flag
    safe_state_cycles: Count
    faults_injected: Count
    final: Flag
    latency_p50_us: Annotated[float, M("us", 0.0, 1e12, "latency median")]
    latency_p99_us: Annotated[float, M("us", 0.0, 1e12, "latency 99th percentile")]
    latency_p999_us: Annotated[float, M("us", 0.0, 1e12, "latency 99.9th percentile")]
    latency_max_us: Annotated[float, M("us", 0.0, 1e12, "latency maximum")]
    sim_seconds_per_wall_second: Annotated[float, M("1", 0.0, 1e9, "achieved speed over real time")]


#: Why the plant refused a command payload: the codec's reasons (:mod:`bus_schemas.codec`),
#: then the plant's own checks. Each is a ``commands_rejected_<reason>`` field of
#: :class:`PlantReport`; a reason not listed is counted under ``other``.
PLANT_REJECT_REASONS: tuple[str, ...] = (
    "length",
    "header",
    "version",
    "non_finite",
    "range",
    "auth",
    "duplicate_or_reordered",
    "unpublished_seq",
    "other",
)

#: Why the controller refused a sensor frame (each a ``frames_rejected_<reason>`` field of
#: :class:`ControllerReport`; a reason not listed is counted under ``other``).
CONTROLLER_REJECT_REASONS: tuple[str, ...] = (
    "length",
    "header",
    "version",
    "non_finite",
    "range",
    "auth",
    "duplicate_or_reordered",
    "implausible_seq",
    "stale",
    "other",
)


def _counts(prefix: str, reasons: tuple[str, ...]) -> list[tuple[str, object]]:
    return [(f"{prefix}_{r}", Count) for r in reasons]


#: The plant's account of a run, published once when the run ends (``final`` = 1), after the
#: final :class:`TimingSummary`: how many messages of each per-cycle channel it published
#: (what a complete recording must hold), how many commands it applied, and every rejected
#: command payload by reason. ``aborted`` = 1 when a signal stopped the run early.
PlantReport: type[msgspec.Struct] = msgspec.defstruct(
    "PlantReport",
    [
        ("seq", Seq),
        ("sample_time_ns", TimeNs),
        ("publish_time_ns", TimeNs),
        ("final", Flag),
        ("aborted", Flag),
        ("cycles", Count),
        ("sensor_frames_published", Count),
        ("truth_published", Count),
        ("cycle_records_published", Count),
        ("summaries_published", Count),
        ("previews_published", Count),
        ("commands_applied", Count),
        *_counts("commands_rejected", PLANT_REJECT_REASONS),
    ],
    frozen=True,
    kw_only=True,
    module=__name__,
)
PlantReport.__doc__ = "The plant's end-of-run account: messages published, commands rejected."

#: The controller's account of a run, published once when it stops (``final`` = 1): frames
#: it stepped on, commands and status messages it published, its safe mode (entries, the
#: commands it sent in it, the sample time of its first entry: 0 when ``safe_mode_entries``
#: is 0), the frames its watchdog found missing or stale, and every rejected sensor-frame
#: payload by reason. ``aborted`` = 1 when a signal stopped it before the plant's end.
#: Version 2 adds the core's first fault (``core_fault``: 0 none, 1 it raised, 2 a
#: non-finite command, 3 an out-of-range one; the frame ``seq`` and sample time it happened
#: on; ``core_fault_field``: 0 none, 1 the pitch, 2 the torque) and how many commands it
#: sent flagged :data:`COMMAND_MODE_FAULT` (:mod:`hil.nodes.controller_fault`).
ControllerReport: type[msgspec.Struct] = msgspec.defstruct(
    "ControllerReport",
    [
        ("seq", Seq),
        ("sample_time_ns", TimeNs),
        ("publish_time_ns", TimeNs),
        ("final", Flag),
        ("aborted", Flag),
        ("frames_accepted", Count),
        ("commands_published", Count),
        ("statuses_published", Count),
        ("safe_mode", Flag),
        ("safe_mode_entries", Count),
        ("safe_mode_commands", Count),
        ("safe_mode_first_entry_ns", TimeNs),
        ("frames_missing", Count),
        ("frames_stale", Count),
        *_counts("frames_rejected", CONTROLLER_REJECT_REASONS),
        # (defaults 0: a report without a fault need not name these)
        ("core_fault", Flag, 0),
        ("core_fault_seq", Seq, 0),
        ("core_fault_time_ns", TimeNs, 0),
        ("core_fault_field", Flag, 0),
        ("core_fault_commands", Count, 0),
    ],
    frozen=True,
    kw_only=True,
    module=__name__,
)
ControllerReport.__doc__ = (
    "The controller's end-of-run account: frames stepped on, safe mode, frames rejected."
)


def rejection_fields(
    counts: dict[str, int], prefix: str, reasons: tuple[str, ...]
) -> dict[str, int]:
    """Keyword arguments ``{prefix}_{reason}: count`` of a report from a reason counter.

    A reason not in ``reasons`` is added to ``{prefix}_other`` (``reasons`` ends with it).
    """
    out = {f"{prefix}_{r}": 0 for r in reasons}
    for reason, n in counts.items():
        key = f"{prefix}_{reason}" if reason in reasons else f"{prefix}_other"
        out[key] += int(n)
    return out


#: Number of samples and their spacing [s] in :data:`WavePreviewPerfect` (horizon 20 s).
WAVE_PREVIEW_SAMPLES = 81
WAVE_PREVIEW_STEP_S = 0.25
#: Field names of the preview samples, X(t + j Δ) for j = 0 … WAVE_PREVIEW_SAMPLES - 1.
WAVE_PREVIEW_FIELDS: tuple[str, ...] = tuple(
    f"excitation_force_surge_ahead_{j:02d}_n" for j in range(WAVE_PREVIEW_SAMPLES)
)

#: Bench oracle (casanovas-2014 table 5.2 assumes it): the surge wave-excitation force at the
#: platform over the next 20 s, X(t + jΔ), j = 0 … 80, Δ = 0.25 s, computed by the plant from
#: its own wave field and published just before the :class:`SensorFrame` with the same
#: ``seq``. Only scenarios with ``[controller] preview = "perfect"`` publish it; it is not a
#: measurement (no real turbine has it): the ``_perfect`` suffix says so. It never travels on
#: CAN. Declared with ``msgspec.defstruct`` so that its 81 sample fields are written once.
WavePreviewPerfect: type[msgspec.Struct] = msgspec.defstruct(
    "WavePreviewPerfect",
    [
        ("seq", Seq),
        ("sample_time_ns", TimeNs),
        ("publish_time_ns", TimeNs),
        ("preview_step_s", Annotated[float, M("s", 0.0, 10.0, "spacing of the preview samples")]),
        *(
            (
                name,
                Annotated[
                    float,
                    M("N", -1e10, 1e10, f"surge wave excitation force {j * 0.25:g} s ahead"),
                ],
            )
            for j, name in enumerate(WAVE_PREVIEW_FIELDS)
        ),
    ],
    frozen=True,
    kw_only=True,
    module=__name__,
)
WavePreviewPerfect.__doc__ = (
    "Perfect preview of the surge wave-excitation force over 20 s (bench oracle; see above)."
)


# ------------------------------------------------------------------ multi-turbine platform
#: Multi-turbine platforms (the Hexicon H3 family) publish under
#: ``fowt/<platform>/<turbine>/<suffix>`` (per turbine) and ``fowt/<platform>/<suffix>``
#: (platform-wide): :meth:`bus_schemas.registry.MessageType.key` with ``"<platform>/<turbine>"``.


class TurbineFrame(msgspec.Struct, frozen=True, kw_only=True):
    """One turbine's sensor sample on a multi-turbine platform (every control period).

    ``seq`` is the platform's cycle number (the same for the three turbines and the
    :class:`PlatformFrame` of the cycle).
    """

    seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    turbine_index: Flag
    rotor_speed_measured_rad_s: Annotated[float, M("rad/s", -5.0, 10.0, "rotor (LSS) speed")]
    blade_pitch_measured_rad: Annotated[float, M("rad", -0.5, 1.8, "collective blade pitch")]
    generator_torque_measured_nm: Annotated[float, M("N m", -1e6, 1e8, "generator torque (HSS)")]
    electrical_power_measured_w: Annotated[float, M("W", -1e8, 1e8, "electrical power")]
    wind_speed_measured_m_s: Annotated[
        float, M("m/s", -80.0, 80.0, "nacelle anemometer (waked inflow)")
    ]


class PlatformFrame(msgspec.Struct, frozen=True, kw_only=True):
    """Platform heading and yaw rate, and the met mast's free-stream wind (every period).

    Angles counter-clockwise from above; the wind direction is where the wind comes from.
    ``final`` = 1 on the plant's last frame of a run.
    """

    seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    final: Flag
    platform_heading_measured_rad: Annotated[
        float, M("rad", -100.0, 100.0, "platform heading (gyrocompass), unwrapped")
    ]
    platform_yaw_rate_measured_rad_s: Annotated[
        float, M("rad/s", -1.0, 1.0, "platform yaw rate (gyro)")
    ]
    wind_direction_measured_rad: Annotated[
        float, M("rad", -100.0, 100.0, "met-mast wind direction (from), unwrapped")
    ]
    wind_speed_measured_m_s: Annotated[float, M("m/s", 0.0, 80.0, "met-mast wind speed")]
    platform_power_w: Annotated[
        float, M("W", -1e9, 1e9, "platform electrical power (sum of the turbine transducers)")
    ]


class TurbineCommand(msgspec.Struct, frozen=True, kw_only=True):
    """Pitch and torque demand of one turbine of a platform, answering cycle ``answered_seq``."""

    seq: Seq
    answered_seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    turbine_index: Flag
    blade_pitch_commanded_rad: Annotated[
        float, M("rad", -0.2, 1.6, "collective blade pitch demand")
    ]
    generator_torque_commanded_nm: Annotated[
        float, M("N m", 0.0, 5e7, "generator torque demand (HSS)")
    ]


class PlatformControllerStatus(msgspec.Struct, frozen=True, kw_only=True):
    """The heading controller's internals every period (one per platform).

    ``controller``: 0 bang-bang, 1 MPC, 2 MPC on the identified model, 3 PRBS excitation
    (identification). ``overruns``: QP solves that failed or exceeded their budget so far
    (the previous input was held).
    """

    seq: Seq
    answered_seq: Seq
    sample_time_ns: TimeNs
    publish_time_ns: TimeNs
    compute_time_ns: TimeNs
    controller: Flag
    overruns: Count
    heading_error_rad: Annotated[float, M("rad", -4.0, 4.0, "wrap(wind direction - heading)")]
    solve_time_s: Annotated[float, M("s", 0.0, 100.0, "QP solve time of this period")]
