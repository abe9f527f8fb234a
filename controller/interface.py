"""Types shared by the bench's controllers: the command record, the protocol, regime codes, limits.

Every controller of the bench is a *pure core*: an immutable object built from its
parameters, with

``initial_state() -> state`` and ``step(state, measurement, dt_s) -> (state, output)``,

holding no clock, no I/O and no globals. The node layer (bus, clock, deadlines) owns the
state between calls and turns :class:`ControlOutput` into a
:class:`bus_schemas.messages.ActuatorCommand` plus a
:class:`bus_schemas.messages.ControllerStatus`.

Regime codes (``ControlOutput.regime``), after the NREL 5 MW baseline (Jonkman et al. 2009,
NREL/TP-500-38060, section 7):

====  =========================================================================
code  meaning
====  =========================================================================
0     region 1: below cut-in (or non-positive) generator speed, zero torque
1     region 1.5: linear torque ramp from cut-in to the start of region 2
2     region 2: optimal-tip-speed-ratio torque, :math:`T = K\\,\\omega^2`
3     region 2.5: transition to rated torque (induction-generator-like slope,
      or torque PI on generator speed)
4     region 3: rated power/torque, speed regulated by blade pitch
5     safe mode: set by the node (never by a core) while its sensor-frame watchdog holds
      the safe command (:mod:`hil.nodes.controller_node`)
====  =========================================================================

:class:`ActuatorLimits` is what a core's ``actuator_limits()`` returns: its pitch range and
rate limits, from which the node builds its safe command without reaching into the core.

A core may also offer ``trimmed_state(operating_point) -> state`` (optional, not part of
:class:`Controller`): the state it holds in steady operation at an
:class:`OperatingPoint` (filters at the trimmed speeds, estimators at the mean wind,
integrators at the trimmed torque and pitch), so that a run started at that point (a
trimmed plant) meets a controller already in its steady state and nothing jumps at t = 0.
The runner calls it, when present, instead of ``initial_state()`` for a trimmed run
(:mod:`hil.inprocess.trim`); a core without it starts from ``initial_state()`` and its
first measurement. A watchdog restart always uses ``initial_state()``. A core whose state
is not a value (a DISCON library's static memory) may warm itself up in it on a model of
the trimmed plant (:mod:`controller.rosco`): it is called once, before cycle 0, where the
core is built (in process, or in the controller process of a bus run).

This module imports no controller implementation; the cores import it, and
:mod:`controller.registry` (the kind -> constructor table) imports the cores.

The controller package never imports ``plant``: it speaks only ``bus_schemas``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, TypeVar

import msgspec

from bus_schemas.messages import VALID_BITS, SensorFrame

__all__ = [
    "REGIME_REGION_1",
    "REGIME_REGION_1_5",
    "REGIME_REGION_2",
    "REGIME_REGION_2_5",
    "REGIME_REGION_3",
    "REGIME_SAFE",
    "ActuatorLimits",
    "ControlOutput",
    "Controller",
    "OperatingPoint",
]

REGIME_REGION_1 = 0
REGIME_REGION_1_5 = 1
REGIME_REGION_2 = 2
REGIME_REGION_2_5 = 3
REGIME_REGION_3 = 4
REGIME_SAFE = 5


class ControlOutput(msgspec.Struct, frozen=True, gc=False):
    """Command and internals produced by one controller step.

    Attributes
    ----------
    blade_pitch_commanded_rad : float
        Collective blade pitch demand [rad].
    generator_torque_commanded_nm : float
        Generator torque demand on the high-speed shaft [N m].
    regime : int
        Operating region code (0 = region 1/stopped, 1 = region 1.5, 2 = region 2,
        3 = region 2.5, 4 = region 3); see the module docstring.
    generator_speed_filtered_rad_s : float
        Low-pass filtered generator (HSS) speed :math:`\\omega_f` [rad/s].
    pitch_integrator_rad : float
        Integral term of the pitch PI, :math:`G_K K_I \\int e\\,dt` [rad].
    gain_schedule_factor : float
        Pitch gain-schedule factor :math:`G_K` [-] (1 at the reference pitch); the LQRI
        reports its scheduling wind [m/s] here.
    estimates_valid_mask : int
        Which of the optional estimates below hold a value (``EST_*`` bits of
        :mod:`bus_schemas.messages`); 0 for the baseline.
    estimator_degraded : int
        1 when an estimator runs on missing or rejected measurements.
    wind_speed_estimated_m_s : float
        Rotor-effective wind estimate [m/s].
    platform_pitch_estimated_rad, platform_pitch_rate_estimated_rad_s : float
        Platform pitch [rad] and pitch rate [rad/s] estimates.
    platform_surge_estimated_m, platform_surge_velocity_estimated_m_s : float
        Platform surge [m] and surge velocity [m/s] estimates.
    tower_top_velocity_estimated_m_s : float
        Tower-top fore-aft (first-mode) velocity estimate [m/s].
    wave_elevation_forecast_m : float
        Forecast wave elevation at the platform [m] for ``wave_forecast_time_ns``.
    wave_forecast_time_ns : int
        Sample time the forecast is for [ns] (sample time + horizon).
    feedforward_pitch_rad, feedforward_torque_nm : float
        Feedforward parts of the pitch [rad] and torque [N m, HSS] demands.
    forecast_unstable_fits, forecast_guarded : int
        AR/ESPRIT wave forecaster: fits so far with poles outside the unit circle (stabilised)
        and forecasts so far replaced by the fallback 0 m by the bound guard
        (:mod:`controller.forecast`); 0 for the dispersion forecaster.
    estimator_faults : int
        Estimator faults so far: divergences detected by an estimator's guard (sustained
        innovation gating or clamping to the physical range, or a non-finite state), each
        starting a fallback (the baseline's TSR-tracking law: :mod:`controller.baseline`);
        0 for a core without such a guard.
    """

    blade_pitch_commanded_rad: float
    generator_torque_commanded_nm: float
    regime: int
    generator_speed_filtered_rad_s: float
    pitch_integrator_rad: float
    gain_schedule_factor: float
    estimates_valid_mask: int = 0
    estimator_degraded: int = 0
    wind_speed_estimated_m_s: float = 0.0
    platform_pitch_estimated_rad: float = 0.0
    platform_pitch_rate_estimated_rad_s: float = 0.0
    platform_surge_estimated_m: float = 0.0
    platform_surge_velocity_estimated_m_s: float = 0.0
    tower_top_velocity_estimated_m_s: float = 0.0
    wave_elevation_forecast_m: float = 0.0
    wave_forecast_time_ns: int = 0
    feedforward_pitch_rad: float = 0.0
    feedforward_torque_nm: float = 0.0
    forecast_unstable_fits: int = 0
    forecast_guarded: int = 0
    estimator_faults: int = 0


@dataclass(frozen=True)
class OperatingPoint:
    """A steady operating point, as a trimmed run starts at it (``trimmed_state``).

    The bench finds it by a settling run of the plant and the scenario's controller at the
    run's mean wind (:mod:`hil.inprocess.trim`); it reaches the core as these numbers only
    (the controller never sees the plant).

    Attributes
    ----------
    wind_m_s : float
        Mean (rotor-effective) wind speed [m/s].
    rotor_speed_rad_s : float
        Rotor (low-speed shaft) speed [rad/s]; a core multiplies by its own gearbox ratio.
    blade_pitch_rad : float
        Collective blade pitch [rad].
    generator_torque_nm : float or None
        Generator torque [N m, high-speed shaft]; None: not known to the runner (the core
        derives it, e.g. from its own torque law or its estimator's aerodynamic model).
    platform_surge_m, platform_pitch_rad : float or None
        Where the trimmed platform stands: mean surge [m] and pitch [rad] at the point, in
        the plant's frame as its sensors report them (without their offsets); None: not
        known or no platform (a core with platform observers then starts them from its
        first frame).
    measurement_offsets : tuple of (str, float)
        The instruments' constant offsets (biases) as (:class:`SensorFrame` field, offset
        in that field's unit) pairs: what the steady plant's frames read on average beyond
        the true value (the gyro's 1e-3 rad/s, the anemometer's wake deficit). A core that
        warms up on model frames adds them, as a controller running for hours has seen
        them (e.g. a high-pass filter then starts at its steady state for the biased
        reading). Empty: none known.
    control_period_s : float or None
        The period [s] the run steps the core at: a core that steps itself on steady frames
        before the run (``trimmed_state``) steps at it, so that its discrete filters hold
        their steady state at the run's period. None: not known (the core's own default).
    """

    wind_m_s: float
    rotor_speed_rad_s: float
    blade_pitch_rad: float
    generator_torque_nm: float | None = None
    measurement_offsets: tuple[tuple[str, float], ...] = ()
    platform_surge_m: float | None = None
    platform_pitch_rad: float | None = None
    control_period_s: float | None = None

    def __post_init__(self) -> None:
        for name in ("wind_m_s", "rotor_speed_rad_s", "blade_pitch_rad"):
            v = getattr(self, name)
            if not isinstance(v, int | float) or not math.isfinite(v):
                raise ValueError(f"OperatingPoint.{name} must be a finite number, got {v!r}")
        if self.wind_m_s < 0.0 or self.rotor_speed_rad_s < 0.0:
            raise ValueError(
                "OperatingPoint: wind_m_s [m/s] and rotor_speed_rad_s [rad/s] must be >= 0, "
                f"got {self.wind_m_s!r} and {self.rotor_speed_rad_s!r}"
            )
        for name in ("generator_torque_nm", "platform_surge_m", "platform_pitch_rad"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, int | float) and math.isfinite(v)):
                raise ValueError(f"OperatingPoint.{name} must be finite or None, got {v!r}")
        h = self.control_period_s
        if h is not None and not (isinstance(h, int | float) and math.isfinite(h) and h > 0.0):
            raise ValueError(
                f"OperatingPoint.control_period_s [s] must be a positive number or None, got {h!r}"
            )
        fields = set(SensorFrame.__struct_fields__)
        for entry in self.measurement_offsets:
            if not (
                isinstance(entry, tuple)
                and len(entry) == 2
                and entry[0] in fields
                and isinstance(entry[1], int | float)
                and math.isfinite(entry[1])
            ):
                raise ValueError(
                    "OperatingPoint.measurement_offsets expected (SensorFrame field, finite "
                    f"offset in its unit) pairs, got {entry!r}"
                )

    def measurement_offset(self, field: str) -> float:
        """The constant offset of ``field``'s instrument [its unit]; 0 if none is known."""
        for name, value in self.measurement_offsets:
            if name == field:
                return float(value)
        return 0.0

    def steady_frame(
        self,
        *,
        gearbox_ratio: float,
        generator_torque_nm: float,
        generator_efficiency: float = 1.0,
        sample_time_ns: int = 0,
    ) -> SensorFrame:
        """The frame a steady plant at this point gives on average: no noise or
        quantisation, each channel with its instrument's offset (a core's warm-up frame).

        Generator speed N ω, electrical power η T_g N ω, the anemometer at the mean wind;
        the platform's channels (and the wave gauge: still water) valid only where the point
        says where the platform stands (``platform_surge_m`` or ``platform_pitch_rad`` set),
        there at rest.

        Parameters
        ----------
        gearbox_ratio : float
            N [-] of the core's drivetrain (the generator speed is N ω).
        generator_torque_nm : float
            T_g [N m, high-speed shaft] the core holds at the point (``generator_torque_nm``
            where known, else the core's own).
        generator_efficiency : float
            η [-] for the electrical power.
        sample_time_ns : int
            The frame's sample time [ns].
        """
        off = self.measurement_offset
        w, n = self.rotor_speed_rad_s, gearbox_ratio
        power = generator_efficiency * generator_torque_nm * n * w
        floating = self.platform_surge_m is not None or self.platform_pitch_rad is not None
        mask = 0
        for name, bit in VALID_BITS.items():
            if floating or not name.startswith(("platform_", "wave_")):
                mask |= bit
        return SensorFrame(
            seq=0,
            sample_time_ns=sample_time_ns,
            publish_time_ns=0,
            valid_mask=mask,
            generator_speed_measured_rad_s=n * w + off("generator_speed_measured_rad_s"),
            rotor_speed_measured_rad_s=w + off("rotor_speed_measured_rad_s"),
            blade_pitch_measured_rad=self.blade_pitch_rad + off("blade_pitch_measured_rad"),
            generator_torque_measured_nm=generator_torque_nm + off("generator_torque_measured_nm"),
            electrical_power_measured_w=power + off("electrical_power_measured_w"),
            wind_speed_measured_m_s=self.wind_m_s + off("wind_speed_measured_m_s"),
            nacelle_acc_fore_aft_measured_m_s2=off("nacelle_acc_fore_aft_measured_m_s2"),
            platform_pitch_measured_rad=(self.platform_pitch_rad or 0.0)
            + off("platform_pitch_measured_rad"),
            platform_pitch_rate_measured_rad_s=off("platform_pitch_rate_measured_rad_s"),
            platform_surge_measured_m=(self.platform_surge_m or 0.0)
            + off("platform_surge_measured_m"),
            wave_elevation_gauge_measured_m=off("wave_elevation_gauge_measured_m"),
        )


@dataclass(frozen=True)
class ActuatorLimits:
    """A controller's own actuator limits (the ones its commands respect).

    Attributes
    ----------
    pitch_min_rad, pitch_max_rad : float
        Blade pitch command range [rad]; ``pitch_max_rad`` is the feathered position.
    pitch_rate_max_rad_s : float
        Pitch command rate limit [rad/s].
    torque_rate_max_nm_s : float
        Generator torque command rate limit [N m/s] (high-speed shaft).
    """

    pitch_min_rad: float
    pitch_max_rad: float
    pitch_rate_max_rad_s: float
    torque_rate_max_nm_s: float


StateT = TypeVar("StateT")


class Controller(Protocol[StateT]):
    """A pure controller core: ``step(state, measurement, dt_s) -> (state, output)``."""

    def initial_state(self) -> StateT:
        """Return the state before the first call (the first step initialises from data)."""
        ...

    def step(
        self, state: StateT, measurement: SensorFrame, dt_s: float
    ) -> tuple[StateT, ControlOutput]:
        """Advance by ``dt_s`` seconds [s] given one sensor frame; return state and output."""
        ...

    def actuator_limits(self) -> ActuatorLimits:
        """The pitch range [rad] and the pitch [rad/s] and torque [N m/s] rate limits."""
        ...
