"""Scenarios: TOML files that say what a run is, validated on load.

A scenario names the turbine preset, the controller and its preset, the wind, the sensor
noise, the timing (control period, plant step) and the run length. Every key carries its
unit in its name (``duration_s``, ``speed_m_s``); a misspelt key or a key with another unit
is an error naming the key and, where it looks like a known key with another unit, the key
that was meant. Shipped scenarios live in ``hil/scenario/presets/*.toml``.

``[[faults]]`` tables (:class:`FaultSection`) inject sensor and bus faults in time windows,
and process faults (:class:`ProcessFault`: the controller or the plant process killed) that
``fowt run`` acts on (:mod:`hil.launch`).
"""

from __future__ import annotations

import difflib
import importlib.resources
import importlib.util
import math
import os
import re
import tomllib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal, get_args

import msgspec

if TYPE_CHECKING:
    from sensors.faults import FaultSpec

Positive = Annotated[float, msgspec.Meta(gt=0.0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0.0)]
WindSpeed = Annotated[float, msgspec.Meta(ge=0.0, le=70.0)]
Cycles = Annotated[int, msgspec.Meta(ge=0, le=1_000_000)]
#: Longest run a scenario may ask for [s] (one week: far beyond any soak or load case).
MAX_DURATION_S = 604_800.0
Duration = Annotated[float, msgspec.Meta(gt=0.0, le=MAX_DURATION_S)]
Seed = Annotated[int, msgspec.Meta(ge=0, le=2**63 - 1)]
#: Significant wave height [m]: the largest ever measured is about 20 m.
WaveHeight = Annotated[float, msgspec.Meta(gt=0.0, le=30.0)]
#: Spectral peak or mean period [s].
WavePeriod = Annotated[float, msgspec.Meta(gt=0.0, le=40.0)]
#: Angular frequency bound of the wave components [rad/s].
WaveFrequency = Annotated[float, msgspec.Meta(gt=0.0, le=20.0)]


class ScenarioError(ValueError):
    """A scenario file that cannot be used, with the key at fault in the message."""


#: Whether a scenario's controller kind is looked up (and its plug-in imported, its settings
#: validated) when the scenario is read: on, except in :func:`recorded_scenarios`.
_CHECK_CONTROLLER: ContextVar[bool] = ContextVar("check_controller", default=True)


@contextmanager
def recorded_scenarios() -> Iterator[None]:
    """Read scenarios without looking up their controller kind (a run's log, reviewed).

    The scenario recorded in a run log describes a run that happened: its review (KPIs,
    reports, comparisons) needs the turbine, wind and review keys, not the controller, whose
    plug-in may not be installed where the log is read.
    """
    token = _CHECK_CONTROLLER.set(False)
    try:
        yield
    finally:
        _CHECK_CONTROLLER.reset(token)


class _Section(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    pass


class SteadyWindSpec(
    _Section, frozen=True, forbid_unknown_fields=True, kw_only=True, tag="steady", tag_field="kind"
):
    """Constant hub-height wind."""

    speed_m_s: WindSpeed


class StepWindSpec(
    _Section, frozen=True, forbid_unknown_fields=True, kw_only=True, tag="step", tag_field="kind"
):
    """A step from ``initial_m_s`` to ``final_m_s`` at ``time_s``."""

    initial_m_s: WindSpeed
    final_m_s: WindSpeed
    time_s: NonNegative


class RampWindSpec(
    _Section, frozen=True, forbid_unknown_fields=True, kw_only=True, tag="ramp", tag_field="kind"
):
    """A linear ramp from ``initial_m_s`` at ``start_s`` to ``final_m_s`` at ``end_s``."""

    initial_m_s: WindSpeed
    final_m_s: WindSpeed
    start_s: NonNegative
    end_s: NonNegative


TurbulenceClass = Literal["A+", "A", "B", "C"]


class TurbulentWindSpec(
    _Section,
    frozen=True,
    forbid_unknown_fields=True,
    kw_only=True,
    tag="turbulent",
    tag_field="kind",
):
    """Rotor-effective turbulent wind: mean ``mean_m_s`` plus IEC Kaimal turbulence.

    σ₁ = I_ref (0.75 U + 5.6) of the IEC ``turbulence_class`` (A: I_ref = 0.16, B: 0.14,
    C: 0.12), rotor-averaged over the turbine's rotor, seeded (:class:`plant.wind.TurbulentWind`).
    """

    mean_m_s: Annotated[float, msgspec.Meta(gt=0.0, le=70.0)]
    turbulence_class: TurbulenceClass = "B"
    seed: Seed = 0


class GustWindSpec(
    _Section, frozen=True, forbid_unknown_fields=True, kw_only=True, tag="gust", tag_field="kind"
):
    """IEC 61400-1 extreme operating gust of period ``period_s`` starting at ``start_s``."""

    hub_speed_m_s: WindSpeed
    start_s: NonNegative = 10.0
    turbine_class: Literal["I", "II", "III"] = "I"
    turbulence_class: TurbulenceClass = "B"
    period_s: Positive = 10.5


WindSpecSection = SteadyWindSpec | StepWindSpec | RampWindSpec | TurbulentWindSpec | GustWindSpec


class _WavesCommon(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Keys every irregular sea state takes (see :func:`plant.waves.synthesize`)."""

    seed: Seed = 0
    gauge_distance_m: Annotated[float, msgspec.Meta(ge=0.0, le=10_000.0)] = 450.0
    n_components: Annotated[int, msgspec.Meta(ge=1, le=5000)] = 200
    omega_min_rad_s: WaveFrequency = 0.1
    omega_max_rad_s: WaveFrequency = 3.0
    depth_m: Annotated[float, msgspec.Meta(gt=0.0, le=12_000.0)] | None = None

    def check(self) -> None:
        """Cross-field checks (frequency band)."""
        if not self.omega_max_rad_s > self.omega_min_rad_s:
            raise ValueError(
                f"waves.omega_max_rad_s = {self.omega_max_rad_s} rad/s must be > "
                f"waves.omega_min_rad_s = {self.omega_min_rad_s} rad/s"
            )


class JonswapWavesSpec(_WavesCommon, frozen=True, kw_only=True, tag="jonswap", tag_field="kind"):
    """JONSWAP spectrum: height ``hs_m``, peak period ``tp_s``, peak factor ``gamma``."""

    hs_m: WaveHeight
    tp_s: WavePeriod
    gamma: Annotated[float, msgspec.Meta(ge=1.0, le=10.0)] = 3.3


class PiersonMoskowitzWavesSpec(
    _WavesCommon, frozen=True, kw_only=True, tag="pierson_moskowitz", tag_field="kind"
):
    """Pierson-Moskowitz spectrum (JONSWAP with γ = 1): ``hs_m``, peak period ``tp_s``."""

    hs_m: WaveHeight
    tp_s: WavePeriod


class IsscWavesSpec(_WavesCommon, frozen=True, kw_only=True, tag="issc", tag_field="kind"):
    """ISSC spectrum (casanovas-2014 eq. 3.1): ``hs_m``, mean period ``t1_s``."""

    hs_m: WaveHeight
    t1_s: WavePeriod


class StillWavesSpec(_WavesCommon, frozen=True, kw_only=True, tag="still", tag_field="kind"):
    """Still water: no waves (the gauge reads 0)."""


WavesSection = JonswapWavesSpec | PiersonMoskowitzWavesSpec | IsscWavesSpec | StillWavesSpec

#: Sensor channels a scenario may configure (SensorFrame measured fields;
#: ``rotor_speed_measured_rad_s`` is derived from the generator speed).
SENSOR_CHANNELS = (
    "generator_speed_measured_rad_s",
    "blade_pitch_measured_rad",
    "generator_torque_measured_nm",
    "electrical_power_measured_w",
    "wind_speed_measured_m_s",
    "nacelle_acc_fore_aft_measured_m_s2",
    "platform_pitch_measured_rad",
    "platform_pitch_rate_measured_rad_s",
    "platform_surge_measured_m",
    "wave_elevation_gauge_measured_m",
)


#: What the watchdogs do after a trip (:class:`TimingSection`).
WatchdogPolicy = Literal["latch", "recover"]


def watchdog_rule(timing: dict[str, object]) -> WatchdogPolicy:
    """The watchdog policy in force for a ``[timing]`` table given as a plain dict (a
    scenario recorded in a run's summary): ``watchdog_policy`` if set, else ``"recover"``
    when ``watchdog_recover_cycles`` > 0, else ``"latch"``."""
    given = timing.get("watchdog_policy")
    if given in ("latch", "recover"):
        return "recover" if given == "recover" else "latch"
    k = timing.get("watchdog_recover_cycles")
    return "recover" if isinstance(k, int) and not isinstance(k, bool) and k > 0 else "latch"


class TimingSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Rates of the loop.

    ``control_period_s`` is both the sensor frame period and the command deadline;
    ``plant_step_s`` is the fixed internal integration step and must divide it.

    The plant's watchdog: after ``watchdog_misses`` consecutive missed deadlines (0: never)
    the plant enters its safe state (pitch demand to feather, moved at the pitch actuator's
    rate limit; generator-torque demand to zero, ramped down at the torque rate limit),
    ignores the controller's commands and says so (``safe_state`` = 1 in ``timing/cycle``
    and ``timing/summary``). What follows a trip is ``watchdog_policy``:

    * ``"latch"``: the safe state holds for the rest of the run, as a turbine's would
      (``watchdog_recover_cycles`` must be 0);
    * ``"recover"``: control is handed back after ``watchdog_recover_cycles`` = K (>= 1)
      consecutive periods whose commands each met their deadline; every trip and every
      recovery is counted (``fowt review``: ``timing.watchdog_trips``,
      ``timing.watchdog_recoveries``).

    Unset, the policy follows ``watchdog_recover_cycles``: ``"recover"`` when it is > 0,
    ``"latch"`` when it is 0 (the default). The controller's sensor-frame watchdog follows
    the same keys (its safe mode). A safe state recovered from under ``"recover"`` does not
    by itself fail a run whose missed deadlines are within the tolerance; a safe state
    still held at the end, or any under ``"latch"``, does (:mod:`hil.review.outcome`). In
    real time, a safe state tripped in the run's first second
    (:data:`hil.nodes.plant_node.STARTUP_S`: misses of a slow start) is handed back after
    a second's worth of on-time commands (or K, if more) even when latched: a slow start
    does not make the whole run a safe-state run.

    ``max_deadline_miss_fraction`` (0 to 1) and ``max_deadline_misses`` (a count): missed
    deadlines tolerated. ``fowt run`` exits with its deadline-misses code
    (:mod:`hil.review.outcome`) only when the run's misses are more than
    ``max_deadline_misses`` and more than ``max_deadline_miss_fraction`` of its cycles, so a
    single miss in a short run is not a failed run, nor a handful in a long one. Unset:
    1 miss and 0.01 in real time, 0 and 0 in lock-step and in process (there the plant waits
    for every command, so any miss is a fault); both 0: any miss fails the run.
    """

    control_period_s: Annotated[float, msgspec.Meta(ge=0.001, le=1.0)] = 0.01
    plant_step_s: Annotated[float, msgspec.Meta(ge=0.0001, le=1.0)] = 0.01
    watchdog_misses: Cycles = 3
    watchdog_policy: WatchdogPolicy | None = None
    watchdog_recover_cycles: Cycles = 0
    max_deadline_miss_fraction: Annotated[float, msgspec.Meta(ge=0.0, le=1.0)] | None = None
    max_deadline_misses: Cycles | None = None

    def __post_init__(self) -> None:
        k = self.watchdog_recover_cycles
        if self.watchdog_policy == "recover" and k == 0:
            raise ValueError(
                'timing.watchdog_policy = "recover" hands control back after '
                "timing.watchdog_recover_cycles on-time periods: expected "
                "watchdog_recover_cycles >= 1 (e.g. 40: one second at 40 Hz)"
            )
        if self.watchdog_policy == "latch" and k > 0:
            raise ValueError(
                f'timing.watchdog_policy = "latch" holds the safe state to the end, but '
                f"timing.watchdog_recover_cycles = {k} would hand control back: expected "
                'watchdog_recover_cycles = 0, or watchdog_policy = "recover"'
            )

    @property
    def watchdog_rule(self) -> WatchdogPolicy:
        """The watchdog's policy in force: ``watchdog_policy``, or when unset ``"recover"``
        if ``watchdog_recover_cycles`` > 0, else ``"latch"``."""
        if self.watchdog_policy is not None:
            return self.watchdog_policy
        return "recover" if self.watchdog_recover_cycles > 0 else "latch"


#: Sensor presets per turbine preset: the channel tables a floating scenario naming the
#: turbine gets beneath its own ``[sensors.channels]`` (which override them key by key).
#: :func:`sensors.default_floating_suite` models an NREL 5 MW-class drivetrain: a 4096-count
#: encoder on a geared high-speed shaft, σ = 0.05 rad/s and a 2π/(4096 h) quantization
#: (0.061 rad/s at h = 0.025 s). The IEA 15 MW is direct drive: its generator turns at the
#: rotor's 5-7.56 rpm (0.52-0.79 rad/s), where those figures are 7-12 % of the speed and
#: drive its wind-speed estimator off any physical range; it gets a high-resolution absolute
#: encoder (ASSUMPTION: 1 mrad/s resolution, 2 mrad/s noise, as the shipped iea15mw-*
#: scenarios).
TURBINE_SENSOR_PRESETS: dict[str, dict[str, dict[str, float]]] = {
    "iea15mw": {"generator_speed_measured_rad_s": {"std": 0.002, "resolution": 0.001}},
}


class SensorSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Sensor models and their seed.

    ``*_std_*``: white noise standard deviations (the foundation's keys; unset = 0 for a
    bottom-fixed plant, the channel default for a floating one). ``channels``: per-channel
    tables ``[sensors.channels.<name>]`` with any of ``std``, ``bias``, ``resolution``,
    ``delay_s``, ``sample_period_s``, ``dropout_probability``, ``range_min``, ``range_max``
    (units of the channel), applied on top of :func:`sensors.default_floating_suite` for a
    floating plant, on top of the noise-only channels for a bottom-fixed one. A floating
    scenario naming a turbine of :data:`TURBINE_SENSOR_PRESETS` gets that turbine's tables
    beneath its own (the IEA 15 MW: a direct-drive encoder, 2 mrad/s noise, 1 mrad/s
    resolution).
    """

    seed: Seed = 1
    generator_speed_std_rad_s: NonNegative | None = None
    blade_pitch_std_rad: NonNegative | None = None
    generator_torque_std_nm: NonNegative | None = None
    electrical_power_std_w: NonNegative | None = None
    wind_speed_std_m_s: NonNegative | None = None
    channels: dict[str, dict[str, float]] = msgspec.field(default_factory=dict)

    def std_overrides(self) -> dict[str, float]:
        """Channel name -> noise std of the ``*_std_*`` keys that are set."""
        keys = {
            "generator_speed_measured_rad_s": self.generator_speed_std_rad_s,
            "blade_pitch_measured_rad": self.blade_pitch_std_rad,
            "generator_torque_measured_nm": self.generator_torque_std_nm,
            "electrical_power_measured_w": self.electrical_power_std_w,
            "wind_speed_measured_m_s": self.wind_speed_std_m_s,
        }
        return {k: v for k, v in keys.items() if v is not None}

    def check(self, control_period_s: float) -> None:
        """Validate the channel tables (names and keys) by building their specs."""
        from sensors import ChannelSpec, default_floating_suite  # noqa: PLC0415

        base = default_floating_suite(control_period_s)
        for name, table in self.channels.items():
            if name not in SENSOR_CHANNELS:
                close = difflib.get_close_matches(name, SENSOR_CHANNELS, n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise ValueError(
                    f"sensors.channels: unknown channel {name!r}{hint} "
                    f"(channels: {', '.join(SENSOR_CHANNELS)})"
                )
            try:
                ChannelSpec.from_table(name, table, base.get(name))
            except ValueError as exc:
                raise ValueError(f"sensors.channels.{name}: {exc}") from exc


FaultKind = Literal[
    "stuck",
    "dropout",
    "bias_step",
    "noise_burst",
    "bus_delay",
    "bus_jitter",
    "bus_loss",
    "controller_kill",
    "plant_kill",
]
ProcessFaultKind = Literal["controller_kill", "plant_kill"]
#: Fault kinds that act on a process of the run, not on a channel (:class:`ProcessFault`).
PROCESS_FAULT_KINDS: tuple[str, ...] = get_args(ProcessFaultKind)
#: ``[[faults]]`` keys a process fault never takes (they describe a channel's fault).
_CHANNEL_FAULT_KEYS = (
    "channel",
    "end_s",
    "bias",
    "std",
    "delay_s",
    "distribution",
    "std_s",
    "max_s",
    "probability",
    "seed",
)


@dataclass(frozen=True)
class ProcessFault:
    """A process fault of a ``fowt run`` process run, validated.

    The launcher (:mod:`hil.launch`), which owns the processes, follows the plant's
    simulated time and acts when it passes ``start_s``:

    * ``controller_kill``: SIGKILL the controller process; with ``restart_after_s`` the
      launcher starts a new controller process (the same command line: it listens on the
      same port and connects to the plant again) that many wall-clock seconds after the
      kill. Real-time runs only: in lock-step the plant waits for every command and would
      abort on its lock-step timeout, so ``fowt run --mode lockstep`` refuses the scenario.
    * ``plant_kill``: SIGKILL the plant process; the controller and the recorder end on
      their own (the plant's liveliness token goes) and the recorder closes its file.

    Attributes
    ----------
    index : int
        The table's index in ``[[faults]]`` (``faults[index]`` in messages).
    kind : str
        ``"controller_kill"`` or ``"plant_kill"``.
    start_s : float
        Simulated time of the kill [s], >= 0.
    restart_after_s : float or None
        ``controller_kill`` only: wall-clock seconds from the kill to the restart, > 0;
        None: the controller stays dead (the plant runs on its watchdog to the end).
    """

    index: int
    kind: ProcessFaultKind
    start_s: float
    restart_after_s: float | None = None

    @property
    def label(self) -> str:
        """``faults[i]``: where the fault is in the scenario file."""
        return f"faults[{self.index}]"

    @property
    def process(self) -> str:
        """The process the fault kills: ``"controller"`` or ``"plant"``."""
        return "controller" if self.kind == "controller_kill" else "plant"

    def describe(self) -> str:
        """One line for the console: kind, time and restart."""
        text = f"{self.label} {self.kind} at {self.start_s:g} s simulated"
        if self.restart_after_s is not None:
            text += f", restart {self.restart_after_s:g} s (wall) later"
        return text


class FaultSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One ``[[faults]]`` table: a fault acting on a channel from ``start_s`` to ``end_s``.

    ``kind``: ``stuck`` | ``dropout`` | ``bias_step`` (``bias``, the channel's unit) |
    ``noise_burst`` (``std``, the channel's unit; ``seed``) on ``channel``, a measured
    SensorFrame field (or a list of them); ``bus_delay`` (``delay_s``) | ``bus_jitter``
    (``distribution`` = ``"uniform"`` with ``max_s``, or ``"normal"`` with ``std_s`` and an
    optional ``max_s``; ``seed``) | ``bus_loss`` (``probability``; ``seed``) on
    ``channel = "sensors"`` (the frame to the controller) or ``"command"`` (the command back
    to the plant). Times are simulated seconds; ``end_s`` absent: to the end of the run.
    The models and their randomness: :mod:`sensors.faults`; how the plant applies the bus
    faults in each mode: :mod:`hil.nodes.plant_node`.

    Process faults (:class:`ProcessFault`, acted on by ``fowt run``) take no ``channel``:
    ``controller_kill`` (``start_s``, optional ``restart_after_s`` in wall-clock seconds)
    and ``plant_kill`` (``start_s``).
    """

    kind: FaultKind
    channel: str | list[str] | None = None
    start_s: float = 0.0
    end_s: float | None = None
    bias: float | None = None
    std: float | None = None
    delay_s: float | None = None
    distribution: Literal["uniform", "normal"] | None = None
    std_s: float | None = None
    max_s: float | None = None
    probability: float | None = None
    seed: Seed | None = None
    restart_after_s: float | None = None

    @property
    def is_process(self) -> bool:
        """True for the process kinds (``controller_kill``, ``plant_kill``)."""
        return self.kind in PROCESS_FAULT_KINDS

    def spec(self) -> FaultSpec:
        """The validated :class:`sensors.faults.FaultSpec` of a sensor or bus fault table.

        Raises
        ------
        ValueError
            For a process fault (see :meth:`process_fault`), a ``restart_after_s`` on
            another kind, or anything :meth:`sensors.faults.FaultSpec.from_table` refuses.
        """
        from sensors.faults import FaultSpec  # noqa: PLC0415

        if self.is_process:
            raise ValueError(f"kind {self.kind!r} is a process fault, not a channel fault")
        if self.restart_after_s is not None:
            raise ValueError(
                f"key 'restart_after_s' is used only by kind 'controller_kill', "
                f"not by kind {self.kind!r}"
            )
        table = {k: v for k, v in msgspec.structs.asdict(self).items() if v is not None}
        return FaultSpec.from_table(table)

    def process_fault(self, index: int) -> ProcessFault:
        """The validated :class:`ProcessFault` of a process fault table.

        Parameters
        ----------
        index : int
            The table's index in ``[[faults]]``.

        Returns
        -------
        ProcessFault
            Kind, start time and restart delay.

        Raises
        ------
        ValueError
            Naming the key at fault: a channel-fault key (``channel``, ``end_s``, ...), a
            ``restart_after_s`` on ``plant_kill``, a negative or non-finite ``start_s``, a
            ``restart_after_s`` that is not > 0 s.
        """
        kind = self.kind
        if kind not in PROCESS_FAULT_KINDS:
            raise ValueError(f"kind {kind!r} is not a process fault")
        takes = "start_s, restart_after_s" if kind == "controller_kill" else "start_s"
        for key in _CHANNEL_FAULT_KEYS:
            if getattr(self, key) is not None:
                if key == "end_s":
                    why = "the kill is an instant"
                    if kind == "controller_kill":
                        why += "; the controller comes back with restart_after_s"
                else:
                    why = "a process fault acts on a whole process, not on a channel"
                raise ValueError(
                    f"key {key!r} is not used by kind {kind!r} ({why}; {kind} takes: {takes})"
                )
        if kind == "plant_kill" and self.restart_after_s is not None:
            raise ValueError(
                "key 'restart_after_s' is not used by kind 'plant_kill' (a killed plant ends "
                "the run; plant_kill takes: start_s)"
            )
        start = float(self.start_s)
        if not (math.isfinite(start) and start >= 0.0):
            raise ValueError(f"key 'start_s' expected a simulated time >= 0 s, got {start!r}")
        restart = self.restart_after_s
        if restart is not None:
            restart = float(restart)
            if not (math.isfinite(restart) and restart > 0.0):
                raise ValueError(
                    f"key 'restart_after_s' expected a wall-clock delay > 0 s, got {restart!r}"
                )
        pk: ProcessFaultKind = "controller_kill" if kind == "controller_kill" else "plant_kill"
        return ProcessFault(index=index, kind=pk, start_s=start, restart_after_s=restart)


class ControllerSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Which controller runs and with which parameter preset.

    ``kind``: ``"baseline"`` (preset e.g. ``"nrel5mw_baseline"``), ``"lqri"`` (observers, wave
    forecast and LQRI; preset e.g. ``"iea15mw_advanced"``) or ``"lqri_ff"`` (the same plus
    the wave feedforward) or ``"lqr_wave"`` (christiansen-2013, preset e.g.
    ``"nrel5mw_oc3_hywind_lqr2"``), or a casanovas-2014 kind (``"no_control"``,
    ``"base_torque"``, ``"lqr_steady"``, ``"lqr_finite"``, ``"lqr_overlaid"``,
    :mod:`controller.casanovas`; preset = design artefact e.g.
    ``"nrel5mw_tlp_casanovas_u8_hs6"``; ``preview`` = ``"perfect"`` (default: the plant
    publishes the excitation force over 20 s, a bench oracle) or ``"forecast"`` (from the
    up-wave gauge); ``horizon_s`` (default T₁ of the design) and ``overlap`` (default 0.5) of
    the finite-horizon LQR; ``symmetric_pitch_limit_deg`` θ_s: pitch allowed in [-θ_s, θ_s]
    by the controller and by the plant's pitch actuator, as the seed's linear design, which
    has no pitch limit (default: the turbine's range, [0°, 90°] for the NREL 5 MW; θ_s must
    stay within the rotor table, -5° for the NREL 5 MW); ``torque_weight_factor``:
    r_τ / (½ρπR²) of the LQR kinds (default 0.1, the seed's; smaller = more torque activity);
    ``gamma_1_s``: the steady LQR's oscillator decay γ [1/s] (< 0; default -1/T₁;
    ``"no_preview"`` = the limit γ → -∞, u = -K x̂)). For the advanced kinds: ``forecaster``
    (``"dispersion"`` | ``"ar"`` | ``"esprit"``, default: the preset's), ``feedforward``
    (``"balanced"`` | ``"max_performance"``, used by ``"lqri_ff"``); the gauge distance comes
    from ``[waves] gauge_distance_m``.

    ``"rosco"``: a Bladed-style DISCON library (:mod:`controller.rosco`); ``preset`` names
    a shipped DISCON.IN (``"nrel5mw"``, ``"iea15mw_volturnus"``) unless ``parameter_file``
    gives one; ``library`` a user's build (default: the ``rosco`` wheel's ``libdiscon``).
    A relative ``library`` or ``parameter_file`` (or a ``preset`` path) is taken from the
    scenario file's folder.

    A kind of your own (docs/guide/own-controller.md): the name an installed distribution
    registers in the entry-point group ``fowt_hil.controllers``, or ``kind = "python"`` with
    ``core = "package.module:attribute"`` (a :class:`controller.registry.ControllerKind` on
    the Python path). ``[controller.settings]``: the kind's own table, validated against the
    settings schema the kind declares when the scenario is read. ``base_dir``: the folder
    relative paths in the settings resolve against (default: the scenario file's folder; the
    shipped scenarios' folder for a shipped scenario). Every kind found is accepted
    (``fowt controllers`` lists them); an unknown one is refused with the closest names.

    ``"fmu"``: an FMI 2.0 or 3.0 co-simulation FMU (:mod:`controller.fmu`);
    ``[controller.settings]`` names the ``.fmu`` file and maps sensor-frame fields to its
    inputs and its outputs to the command (:class:`controller.fmu.FmuSettings`).
    """

    kind: Annotated[str, msgspec.Meta(min_length=1, max_length=128)] = "baseline"
    preset: str = "nrel5mw_baseline"
    forecaster: Literal["dispersion", "ar", "esprit"] | None = None
    feedforward: Literal["balanced", "max_performance"] = "balanced"
    library: str | None = None
    parameter_file: str | None = None
    # casanovas-2014 kinds (controller.casanovas): preset = the design artefact's name.
    preview: Literal["perfect", "forecast"] | None = None
    horizon_s: Annotated[float, msgspec.Meta(gt=0.0, le=20.0)] | None = None
    overlap: Annotated[float, msgspec.Meta(ge=0.0, lt=1.0)] | None = None
    symmetric_pitch_limit_deg: Annotated[float, msgspec.Meta(gt=0.0, le=90.0)] | None = None
    torque_weight_factor: Annotated[float, msgspec.Meta(gt=0.0)] | None = None
    gamma_1_s: float | Literal["no_preview"] | None = None
    # a plug-in's core (controller.registry.find_kind) and its settings
    core: str | None = None
    settings: dict[str, Any] = msgspec.field(default_factory=dict)
    base_dir: str | None = None

    def __post_init__(self) -> None:
        if _CHECK_CONTROLLER.get():
            from controller.registry import (  # noqa: PLC0415
                ControllerKindError,
                find_kind,
                validate_settings,
            )

            try:
                validate_settings(find_kind(self.kind, self.core), self.settings)
            except ControllerKindError as exc:
                raise ValueError(str(exc)) from exc
        if self.kind != "rosco" and (self.library is not None or self.parameter_file is not None):
            raise ValueError(
                "controller.library and controller.parameter_file are used only by "
                f"kind = 'rosco' (kind is {self.kind!r})"
            )
        casanovas = ("no_control", "base_torque", "lqr_steady", "lqr_finite", "lqr_overlaid")
        if self.symmetric_pitch_limit_deg is not None and self.kind not in casanovas:
            raise ValueError(
                "controller.symmetric_pitch_limit_deg is used only by the casanovas-2014 kinds "
                f"{casanovas} (kind is {self.kind!r})"
            )
        if self.torque_weight_factor is not None and self.kind not in casanovas[2:]:
            raise ValueError(
                "controller.torque_weight_factor is used only by kinds 'lqr_steady', "
                f"'lqr_finite', 'lqr_overlaid' (kind is {self.kind!r})"
            )
        if self.gamma_1_s is not None:
            if self.kind != "lqr_steady":
                raise ValueError(
                    "controller.gamma_1_s is used only by kind 'lqr_steady' "
                    f"(kind is {self.kind!r})"
                )
            if self.gamma_1_s != "no_preview" and not self.gamma_1_s < 0.0:
                raise ValueError(
                    f"controller.gamma_1_s = {self.gamma_1_s!r} 1/s: expected < 0 "
                    "(the oscillator decay) or 'no_preview'"
                )

    @property
    def gamma_value(self) -> float | None:
        """``gamma_1_s`` as a number [1/s]: ``"no_preview"`` is -inf (None: the design's)."""
        if self.gamma_1_s == "no_preview":
            return -math.inf
        return self.gamma_1_s


class CanSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The CAN bus of a ``--transport can`` run (``fowt run`` options override each key).

    ``interface``: ``"udp_multicast"`` (two processes on one host, only inside a private
    network namespace, which ``fowt run`` creates as root), ``"socketcan"`` (a Linux CAN
    netdevice, ``vcan0`` / ``can0``) or ``"virtual"`` (python-can's in-process bus: loopback
    tests only); ``channel``: the multicast group or netdevice (empty: the interface's
    default, ``239.74.163.2`` / ``vcan0``); ``fd``: CAN FD, one frame per message instead of
    classic 8-byte parts. Only the sensor frame and the command travel on CAN.
    """

    interface: Literal["udp_multicast", "socketcan", "virtual"] = "udp_multicast"
    channel: str = ""
    fd: bool = False


class ReviewSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """How ``fowt review`` computes the KPIs of this scenario's runs.

    ``settle_s``: start-up settling time [s] left out of the KPIs (al-2019 discards the
    first 600 s of its 1200 s runs as transient). Default 40 s, measured with trimmed starts
    (``[initial] trim = true``) on the IEA 15 MW on VolturnUS-S, baseline controller
    (``bench/trimmed_start.py``, docs/review.md): in steady wind and still water at 5, 7.1,
    10.3 and 15 m/s the 20 s moving means of rotor speed, platform surge and platform pitch
    are within 2 % of their final values from the first window (t = 20 s; the platform
    pitch at 5 m/s, a 0.09° mean whose 20 s means wander by 0.003°, excepted); in turbulent
    wind the trim is for the mean wind, so the rotor starts up to 5 % off the wind at
    t = 0, and a start error of that size (3 % of rotor speed) falls below a tenth of the
    signal's own standard deviation in the run within 28 s (rotor speed) and 35 s
    (platform pitch) at 15 m/s, 36 s and at once at 5 m/s, at once for surge. An untrimmed
    start took 148-586 s for the surge mean. A run shorter than 2 ``settle_s`` keeps its
    second half (``hil.review.core.kpi_window``). The same window serves ``fowt report``,
    ``fowt compare`` and the campaign KPIs.

    ``tsr_opt``: the tip-speed ratio λ* [-] of the optimal rotor speed
    Ω_opt = λ* U / R in the KPI var(Ω − Ω_opt). Unset: derived from the turbine's Cp
    table as the argmax over λ of Cp(λ, θ = 0) as the plant evaluates it (bilinear between
    the table's rows, so the maximum is a grid point: 8.5 for the IEA 15 MW, whose table steps
    λ by 0.5); a cubic spline through the same column peaks at 8.71. var(Ω − Ω_opt) depends
    on it (docs/guide/campaigns.md, "λ* of Ω_opt"). A campaign's ``tsr_opt`` overrides it.

    ``power_metric``: ``"electrical"`` (default: the KPIs' electrical power of the plant) or
    ``"quadratic_linear"`` (casanovas-2014 kinds with the perfect preview): ``fowt run`` also
    runs the scenario's controller on the seed's linear surge + rotor model and reports the
    quadratic aerodynamic power of its section 4.4, the figure of its table 5.2
    (``casanovas_quadratic_linear`` in the run summary, :mod:`hil.review.casanovas_linear`).
    """

    settle_s: NonNegative = 40.0
    tsr_opt: Positive | None = None
    power_metric: Literal["electrical", "quadratic_linear"] = "electrical"


class RecordingSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """What the run log keeps (in every mode that records: the in-process log writer and
    the bus recorder).

    ``level = "full"`` (default): every message. ``level = "soak"``, for long runs (a day's
    soak of a controller): the plant's truth (``fowt/<id>/truth``, the largest topic: 61 %
    of a full log's bytes) is kept once every ``truth_period_s`` [s], the cycles ``seq``
    that are a multiple of N = ``truth_period_s`` / ``timing.control_period_s`` (a whole
    number of control periods), and every per-cycle control channel is kept whole (sensor
    frames, commands, controller statuses, cycle timing), so timing, latency, the verdict
    and the control figures are those of a full recording. The level and N are in the
    file's ``recording`` metadata record; the review says ``recording level: soak (truth
    decimated 1:N)``, expects 1 truth message in N, computes the truth means and standard
    deviations from the kept samples (a regular 1:N subsample) and marks unavailable
    (``null``) what needs every cycle's truth: the thrust maximum, pitch travel,
    damage-equivalent loads, the estimator errors and the forecast VAF
    (docs/guide/run-log.md).
    """

    level: Literal["full", "soak"] = "full"
    truth_period_s: Positive = 1.0

    def truth_every(self, control_period_s: float) -> int:
        """N: one truth message in N is kept (1 at ``level = "full"``)."""
        if self.level == "full":
            return 1
        return max(1, round(self.truth_period_s / control_period_s))

    def check(self, control_period_s: float) -> None:
        """ValueError unless ``truth_period_s`` is a whole number of control periods."""
        ratio = self.truth_period_s / control_period_s
        if self.level == "soak" and (round(ratio) < 1 or abs(ratio - round(ratio)) > 1e-9):
            raise ValueError(
                f"recording.truth_period_s = {self.truth_period_s:g} s: expected a whole "
                f"number of control periods ({control_period_s:g} s)"
            )


class InitialSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Where the run starts (as OpenFAST's ``RotSpeed``, ``BlPitch``, ``PtfmSurge``, ...).

    ``trim = true`` (default): trimmed at the controller's steady state for the mean wind
    (steady: its speed; step and ramp: the initial speed; turbulent: the mean; gust: the hub
    speed): rotor speed, blade pitch and generator torque where the scenario's controller
    settles in that steady wind (a short settling run of plant and controller, still water,
    no noise: :mod:`hil.inprocess.trim`), and the platform's surge, heave and pitch at the static
    equilibrium of that point's mean thrust with the mooring and hydrostatic stiffness
    (:mod:`plant.build`). Without it a run starts where the plant alone would put it (the
    optimal tip-speed ratio capped at rated, at the wind at t = 0), which a controller with
    a minimum rotor speed or a minimum-pitch schedule leaves at once, kicking the lightly
    damped platform modes: at 5 m/s the IEA 15 MW started at 3.84 rpm, its baseline holds
    5.1 rpm, and the surge mean took 413 s to settle (``bench/trimmed_start.py``).

    ``trim = false``: the plant's own start. Either way the keys below, where set, replace
    the value: ``rotor_speed_rpm`` [rpm], ``pitch_deg`` (collective blade pitch) [deg],
    ``generator_torque_nm`` [N m, high-speed shaft; unset: balancing the aerodynamic
    torque], ``platform_surge_m``, ``platform_heave_m`` [m], ``platform_pitch_deg`` [deg]
    (platform keys unset: the static equilibrium).
    """

    trim: bool = True
    rotor_speed_rpm: Annotated[float, msgspec.Meta(ge=0.0, le=100.0)] | None = None
    pitch_deg: Annotated[float, msgspec.Meta(ge=-10.0, le=90.0)] | None = None
    generator_torque_nm: Annotated[float, msgspec.Meta(ge=0.0, le=1e9)] | None = None
    platform_surge_m: Annotated[float, msgspec.Meta(ge=-200.0, le=200.0)] | None = None
    platform_heave_m: Annotated[float, msgspec.Meta(ge=-50.0, le=50.0)] | None = None
    platform_pitch_deg: Annotated[float, msgspec.Meta(ge=-30.0, le=30.0)] | None = None


class Scenario(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One run of the bench.

    Keys that name a file (:data:`FILE_KEYS`: ``turbine``, ``platform`` and
    ``controller.preset`` when given as a path rather than a shipped name, which holds a ``/``
    or ends in ``.toml``; ``controller.library``, ``controller.parameter_file``) take a
    relative path from the scenario file's folder, wherever ``fowt`` runs from, as a campaign
    file's ``scenario`` does; a file that is not there is refused with the path it was looked
    for at.
    """

    name: str
    turbine: str
    wind: WindSpecSection
    platform: str | None = None
    waves: WavesSection | None = None
    description: str = ""
    turbine_id: Annotated[str, msgspec.Meta(pattern=r"^[A-Za-z0-9_-]+$")] = "t1"
    duration_s: Duration = 60.0
    timing: TimingSection = msgspec.field(default_factory=TimingSection)
    sensors: SensorSection = msgspec.field(default_factory=SensorSection)
    controller: ControllerSection = msgspec.field(default_factory=ControllerSection)
    faults: list[FaultSection] = msgspec.field(default_factory=list)
    can: CanSection = msgspec.field(default_factory=CanSection)
    review: ReviewSection = msgspec.field(default_factory=ReviewSection)
    initial: InitialSection = msgspec.field(default_factory=InitialSection)
    recording: RecordingSection = msgspec.field(default_factory=RecordingSection)

    def __post_init__(self) -> None:
        ratio = self.timing.control_period_s / self.timing.plant_step_s
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"timing.plant_step_s = {self.timing.plant_step_s} must divide "
                f"timing.control_period_s = {self.timing.control_period_s}"
            )
        if self.timing.control_period_s > 1.0:
            raise ValueError(
                f"timing.control_period_s = {self.timing.control_period_s} s: expected <= 1 s"
            )
        _check_cycles(self.duration_s, self.timing.control_period_s, "duration_s")
        if isinstance(self.wind, RampWindSpec) and self.wind.end_s < self.wind.start_s:
            raise ValueError("wind.end_s must be >= wind.start_s")
        _check_preset("turbine", self.turbine, shipped_turbines(), "a turbine preset")
        if self.controller.kind == "rosco":
            # ROSCO's presets are the shipped DISCON.IN files (controller/presets/rosco); a
            # scenario's own parameter_file is checked when the controller loads it
            if self.controller.parameter_file is None:
                _check_preset(
                    "controller.preset",
                    self.controller.preset,
                    package_presets("controller", "presets", "rosco", suffix="_DISCON.IN"),
                    "a shipped DISCON.IN",
                )
        elif self.controller.kind in ("baseline", "lqri", "lqri_ff", "lqr_wave"):
            _check_preset(
                "controller.preset",
                self.controller.preset,
                package_presets("controller", "presets"),
                "a controller preset",
            )
        # casanovas-2014 kinds name a design artefact, designed on first use when missing:
        # their controller checks it when it is built
        if self.platform is not None:
            _check_preset("platform", self.platform, shipped_platforms(), "a floating preset")
        if self.waves is not None:
            if self.platform is None:
                raise ValueError(
                    "waves: a [waves] section needs a floating plant (platform = "
                    '"iea15mw_volturnus"); a bottom-fixed turbine has no platform'
                )
            self.waves.check()
        preset = TURBINE_SENSOR_PRESETS.get(self.turbine) if self.platform is not None else None
        if preset:
            # the turbine's sensor preset under the scenario's own channel tables (key by
            # key: a scenario that sets only a channel's std keeps the preset's resolution)
            merged = {name: dict(table) for name, table in preset.items()}
            for name, table in self.sensors.channels.items():
                merged[name] = {**merged.get(name, {}), **table}
            msgspec.structs.force_setattr(self.sensors, "channels", merged)
        self.sensors.check(self.timing.control_period_s)
        self.recording.check(self.timing.control_period_s)
        if self.review.power_metric == "quadratic_linear":
            casanovas = ("no_control", "base_torque", "lqr_steady", "lqr_finite", "lqr_overlaid")
            if self.controller.kind not in casanovas or self.waves is None:
                raise ValueError(
                    "review.power_metric = 'quadratic_linear' is the casanovas-2014 metric: it "
                    f"needs a casanovas-2014 controller kind {casanovas} and [waves] "
                    f"(kind is {self.controller.kind!r})"
                )
            if self.controller.preview == "forecast":
                raise ValueError(
                    "review.power_metric = 'quadratic_linear' needs [controller] preview = "
                    "'perfect' (the seed's table 5.2 assumes a perfect preview)"
                )
        if self.platform is None:
            for key in ("platform_surge_m", "platform_heave_m", "platform_pitch_deg"):
                if getattr(self.initial, key) is not None:
                    raise ValueError(
                        f"initial.{key}: a bottom-fixed turbine has no platform (set platform "
                        "for a floating plant)"
                    )
        if self.controller.kind in ("lqri", "lqri_ff", "lqr_wave") and self.platform is None:
            raise ValueError(
                f"controller.kind = {self.controller.kind!r} needs a floating plant "
                '(platform = "iea15mw_volturnus"): its observers estimate the platform motion'
            )
        self.fault_specs()
        self.process_faults()

    def fault_specs(self) -> tuple[FaultSpec, ...]:
        """The validated sensor and bus faults, in file order (process faults left out).

        Raises
        ------
        ValueError
            Naming the table (``faults[i]``) and the key at fault; also for a sensor fault on
            a channel a bottom-fixed plant does not measure.
        """
        specs = []
        turbine_channels = SENSOR_CHANNELS[:5]
        for i, section in enumerate(self.faults):
            if section.is_process:
                continue
            try:
                spec = section.spec()
            except ValueError as exc:
                raise ValueError(f"faults[{i}]: {exc}") from exc
            if not spec.is_bus and not self.floating:
                for ch in spec.channels:
                    if ch not in turbine_channels and ch not in self.sensors.channels:
                        raise ValueError(
                            f"faults[{i}]: channel {ch!r} is not measured by a bottom-fixed "
                            f"plant (its channels: {', '.join(turbine_channels)}, and any "
                            "[sensors.channels] table)"
                        )
            specs.append(spec)
        return tuple(specs)

    def process_faults(self) -> tuple[ProcessFault, ...]:
        """The validated process faults (``controller_kill``, ``plant_kill``), by start time.

        Raises
        ------
        ValueError
            Naming the table (``faults[i]``) and the key at fault, or a second
            ``plant_kill`` (the first one ends the run).
        """
        out: list[ProcessFault] = []
        for i, section in enumerate(self.faults):
            if not section.is_process:
                continue
            try:
                out.append(section.process_fault(i))
            except ValueError as exc:
                raise ValueError(f"faults[{i}]: {exc}") from exc
        plant_kills = [f for f in out if f.kind == "plant_kill"]
        if len(plant_kills) > 1:
            raise ValueError(
                f"{plant_kills[1].label}: a second plant_kill (kind 'plant_kill'); the first "
                f"one, {plant_kills[0].label}, already ends the run"
            )
        return tuple(sorted(out, key=lambda f: (f.start_s, f.index)))

    @property
    def floating(self) -> bool:
        """True when the plant is a floating turbine (``platform`` given)."""
        return self.platform is not None

    @property
    def steps_per_cycle(self) -> int:
        """Plant integration steps per control period."""
        return round(self.timing.control_period_s / self.timing.plant_step_s)

    @property
    def cycles(self) -> int:
        """Control cycles in the run."""
        return round(self.duration_s / self.timing.control_period_s)

    def with_duration(self, duration_s: float | None) -> Scenario:
        """A copy with another run length (None keeps this one).

        Raises
        ------
        ScenarioError
            Unless ``duration_s`` is a finite number of seconds in (0, MAX_DURATION_S].
        """
        if duration_s is None:
            return self
        check_duration(duration_s, "--duration")
        try:
            _check_cycles(float(duration_s), self.timing.control_period_s, "--duration")
        except ValueError as exc:
            raise ScenarioError(str(exc)) from exc
        return msgspec.structs.replace(self, duration_s=float(duration_s))

    def to_toml_dict(self) -> dict[str, object]:
        """Plain dict of the scenario (JSON-able), tags included."""
        return msgspec.to_builtins(self)


_UNIT_SUFFIX = re.compile(r"_(s|ms|us|ns|m_s|km_h|rad|deg|rad_s|rpm|nm|n|w|kw|mw|m|hz)$")


_UNKNOWN_FIELD = re.compile(r"Object contains unknown field `([^`]+)`(?: - at `([^`]*)`)?")
_AT_PATH = re.compile(r" - at `\$\.?([^`]*)`")


def unknown_key_text(msg: str, known: Callable[[str], list[str]]) -> str | None:
    """``'section.key'; did you mean ...`` for msgspec's unknown-field message, else None.

    ``known(path)`` gives the keys known at msgspec's error path (``"$"``, ``"$.timing"``).
    Shared by the scenario and campaign loaders, so both name a wrong key the same way.
    """
    m = _UNKNOWN_FIELD.match(msg)
    if m is None:
        return None
    key, path = m.group(1), m.group(2) or "$"
    where = path.lstrip("$").lstrip(".")
    full = f"{where}.{key}" if where else key
    return f"{full!r}{_hint_for_unknown(key, known(path))}"


def key_at_text(msg: str, suffix: str = "") -> str:
    """msgspec's ``... - at `$.a.b``` as ``key 'a.b': ...`` (``suffix`` appended), else msg."""
    at = _AT_PATH.search(msg)
    if at is None:
        return msg
    text = msg[: at.start()]
    if text.startswith(f"{at.group(1)}."):  # the message names its key already
        return f"{text}{suffix}"
    return f"key {at.group(1)!r}: {text}{suffix}"


def _hint_for_unknown(key: str, known: list[str]) -> str:
    stem = _UNIT_SUFFIX.sub("", key)
    same_stem = [k for k in known if _UNIT_SUFFIX.sub("", k) == stem]
    if same_stem:
        return f"; did you mean {same_stem[0]!r} (units are part of the key name)?"
    close = difflib.get_close_matches(key, known, n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def _known_fields(path: str) -> list[str]:
    """Known keys at a msgspec error path like ``$.timing``."""
    parts = [p for p in path.lstrip("$").split(".") if p]
    cls: type[msgspec.Struct] = Scenario
    sections: dict[str, type[msgspec.Struct]] = {
        "timing": TimingSection,
        "sensors": SensorSection,
        "controller": ControllerSection,
        "can": CanSection,
        "review": ReviewSection,
        "recording": RecordingSection,
    }
    if parts:
        if parts[0].startswith("faults["):
            return list(FaultSection.__struct_fields__)
        if parts[0] in ("wind", "waves"):
            classes: tuple[type[msgspec.Struct], ...] = (
                (SteadyWindSpec, StepWindSpec, RampWindSpec, TurbulentWindSpec, GustWindSpec)
                if parts[0] == "wind"
                else (JonswapWavesSpec, PiersonMoskowitzWavesSpec, IsscWavesSpec, StillWavesSpec)
            )
            return sorted({f for c in classes for f in c.__struct_fields__} | {"kind"})
        cls = sections.get(parts[0], Scenario)
    return list(cls.__struct_fields__)


def _check_cycles(duration_s: float, control_period_s: float, name: str) -> None:
    """ValueError unless ``duration_s`` holds at least one control period (one cycle)."""
    if duration_s < control_period_s * (1.0 - 1e-9):  # the tolerance: a float's last bits
        raise ValueError(
            f"{name} = {duration_s:g} s is shorter than one control period "
            f"(timing.control_period_s = {control_period_s:g} s): the run would have no cycle"
        )


def check_duration(duration_s: object, name: str = "duration_s") -> float:
    """``duration_s`` as a float, or a :class:`ScenarioError` naming ``name``.

    Expected: a finite number of seconds, > 0 and <= :data:`MAX_DURATION_S`.
    """
    if isinstance(duration_s, bool) or not isinstance(duration_s, int | float):
        raise ScenarioError(
            f"{name}: expected a number of seconds, got {type(duration_s).__name__}"
        )
    value = float(duration_s)
    if not math.isfinite(value):
        raise ScenarioError(f"{name}: expected a finite number of seconds, got {value}")
    if not 0.0 < value <= MAX_DURATION_S:
        raise ScenarioError(
            f"{name}: expected seconds > 0 and <= {MAX_DURATION_S:g}, got {value:g}"
        )
    return value


def non_finite_key(raw: object, path: str = "") -> tuple[str, float] | None:
    """The first key (dotted path, ``faults[i]`` for list items) holding NaN or +-inf.

    Every number of a scenario is a physical quantity, so none may be non-finite; checked on
    the parsed TOML before the typed validation so the message says "not finite" rather
    than a failed bound (NaN fails every comparison).
    """
    if isinstance(raw, float):
        return None if math.isfinite(raw) else (path, raw)
    if isinstance(raw, dict):
        for key, value in raw.items():
            found = non_finite_key(value, f"{path}.{key}" if path else str(key))
            if found:
                return found
    elif isinstance(raw, list):
        for i, value in enumerate(raw):
            found = non_finite_key(value, f"{path}[{i}]")
            if found:
                return found
    return None


def settings_base_dir(raw: dict[str, Any], base_dir: str | Path | None) -> None:
    """Fill ``[controller] base_dir`` of a parsed scenario that has settings (in place).

    Unset: ``base_dir`` (the scenario file's folder, or the working directory); relative:
    taken from ``base_dir``. Absolute, so every process of a run (and every campaign worker)
    resolves the settings' relative paths alike. A scenario without settings is left as it
    is (its controller has no path to resolve).
    """
    c = raw.get("controller")
    if base_dir is None or not isinstance(c, dict) or not c.get("settings"):
        return
    given = c.get("base_dir")
    if given is None:
        c["base_dir"] = str(Path(base_dir).resolve())
    elif isinstance(given, str) and not Path(given).expanduser().is_absolute():
        c["base_dir"] = str((Path(base_dir) / given).resolve())


#: Scenario keys that name a file, as (section, key, how): ``"file"`` is always a path,
#: ``"preset"`` a shipped name or, when it holds a ``/`` or ends in ``.toml``, a path.
#: :func:`resolve_paths` takes the relative ones from the scenario file's folder.
FILE_KEYS: tuple[tuple[str, str, Literal["file", "preset"]], ...] = (
    ("", "turbine", "preset"),
    ("", "platform", "preset"),
    ("controller", "preset", "preset"),
    ("controller", "library", "file"),
    ("controller", "parameter_file", "file"),
)


def _is_path(value: str, how: str) -> bool:
    return how == "file" or "/" in value or value.endswith(".toml")


def resolve_paths(raw: dict[str, object], base_dir: Path, source: str = "") -> dict[str, object]:
    """``raw`` (a parsed scenario) with its relative file paths taken from ``base_dir``.

    Every key of :data:`FILE_KEYS` that holds a path (a shipped preset name stays as it is)
    becomes an absolute path: ``~`` expanded, a relative path joined to ``base_dir`` (the
    scenario file's folder). The processes of a run load the same file and so resolve the
    same paths, whatever their working directory; a campaign's runs carry them absolute.

    Parameters
    ----------
    raw : dict
        The scenario's TOML, parsed (not changed: the sections touched are copied).
    base_dir : Path
        The folder relative paths are taken from.
    source : str
        The scenario's file, for the message.

    Returns
    -------
    dict
        The scenario with absolute paths.

    Raises
    ------
    ScenarioError
        When a path names no file (a ``.toml`` preset, a library, a parameter file): the
        message gives the key, the value and the path it was looked for at.
    """
    out = dict(raw)
    base = base_dir.expanduser().absolute()
    for section, key, how in FILE_KEYS:
        table = out.get(section) if section else out
        if not isinstance(table, dict):
            continue
        value = table.get(key)
        if not isinstance(value, str) or not value or not _is_path(value, how):
            continue
        path = Path(value).expanduser()
        if not path.is_absolute():
            path = Path(os.path.normpath(base / path))  # "../x" without a "dir/.." left in
        if not path.is_file():
            name = f"{section}.{key}" if section else key
            where = f"{source}: " if source else ""
            relative = (
                ""
                if Path(value).expanduser().is_absolute()
                else (" (a relative path is taken from the scenario file's folder)")
            )
            raise ScenarioError(f"{where}{name} = {value!r}: file not found: {path}{relative}")
        if section:
            table = dict(table)
            out[section] = table
        else:
            table = out
        table[key] = str(path)
    return out


def _literal_values(tp: msgspec.inspect.Type) -> list[str]:
    """The string values a type allows (its ``Literal`` parts), or []."""
    if isinstance(tp, msgspec.inspect.LiteralType):
        return [str(v) for v in tp.values]
    if isinstance(tp, msgspec.inspect.UnionType):
        return [v for t in tp.types for v in _literal_values(t)]
    return []


def allowed_values(path: str) -> list[str]:
    """The values the scenario key at ``path`` (``controller.kind``, ``wind.kind``,
    ``faults[0].kind``) allows when it is one of a fixed set (a ``Literal``, or the ``kind``
    of a tagged table), else []."""
    tp: msgspec.inspect.Type = msgspec.inspect.type_info(Scenario)
    for part in path.split("."):
        name = re.sub(r"\[\d+\]$", "", part)
        structs = [tp] if isinstance(tp, msgspec.inspect.StructType) else []
        if isinstance(tp, msgspec.inspect.UnionType):
            structs = [t for t in tp.types if isinstance(t, msgspec.inspect.StructType)]
            tags = [str(t.tag) for t in structs if t.tag_field == name and t.tag is not None]
            if tags:
                return tags
        fields = [f for s in structs for f in s.fields if f.encode_name == name]
        if not fields:
            return []
        tp = fields[0].type
        if part != name:  # a list item: faults[i]
            if not isinstance(tp, msgspec.inspect.ListType):
                return []
            tp = tp.item_type
    return _literal_values(tp)


_BAD_VALUE = re.compile(r"Invalid (?:enum )?value '([^']*)'")


def _enum_hint(msg: str) -> str:
    """``; did you mean 'x'?`` (or the values expected, when none is close) for msgspec's
    ``Invalid enum value`` / ``Invalid value`` of a key with a fixed set of values, else ""."""
    bad, at = _BAD_VALUE.match(msg), _AT_PATH.search(msg)
    if bad is None or at is None:
        return ""
    known = allowed_values(at.group(1))
    if not known:
        return ""
    hint = suggestion(bad.group(1), known)
    return f"; {hint}" if hint else f"; expected one of {', '.join(known)}"


def parse_scenario(
    text: str, source: str = "<string>", base_dir: str | Path | None = None
) -> Scenario:
    """Parse and validate scenario TOML text.

    Parameters
    ----------
    text : str
        The scenario's TOML.
    source : str
        Where it came from (its file), for the messages.
    base_dir : Path, optional
        The folder the scenario's relative file paths are taken from (the scenario file's:
        :func:`resolve_paths`), and the default of ``[controller] base_dir``, which the
        controller settings' relative paths resolve against (:func:`settings_base_dir`);
        None leaves them as they are (relative to the working directory of the process that
        opens them).

    Raises
    ------
    ScenarioError
        naming the file and the key at fault.
    """
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from exc
    bad = non_finite_key(raw)
    if bad is not None:
        raise ScenarioError(f"{source}: key {bad[0]!r}: expected a finite number, got {bad[1]}")
    if base_dir is not None:
        raw = resolve_paths(raw, Path(base_dir), source)
    settings_base_dir(raw, base_dir)
    try:
        return msgspec.convert(raw, Scenario)
    except msgspec.ValidationError as exc:
        msg = str(exc)
        unknown = unknown_key_text(msg, _known_fields)
        if unknown is not None:
            raise ScenarioError(f"{source}: unknown key {unknown}") from exc
        raise ScenarioError(f"{source}: {key_at_text(msg, _enum_hint(msg))}") from exc


def package_presets(package: str, *folder: str, suffix: str = ".toml") -> list[str]:
    """Names of the ``*<suffix>`` presets in ``package``/``folder``, without importing it.

    The folder is found with ``importlib.util.find_spec`` on the top-level package, which
    locates it without importing it: the controller process validates the same scenario
    file and must never import ``plant`` (the two sides speak only ``bus_schemas``).
    """
    spec = importlib.util.find_spec(package)
    locations = list(spec.submodule_search_locations or []) if spec is not None else []
    if not locations:
        return []
    root = Path(locations[0]).joinpath(*folder)
    return sorted(p.name.removesuffix(suffix) for p in root.glob(f"*{suffix}"))


def suggestion(value: str, known: list[str] | tuple[str, ...], n: int = 3) -> str:
    """``"did you mean 'a'?"`` / ``"did you mean 'a', 'b' or 'c'?"``: the names of ``known``
    closest to ``value`` (at most ``n``, :func:`difflib.get_close_matches`), or "" when none
    is close."""
    close = difflib.get_close_matches(value, list(known), n=n, cutoff=0.6)
    if not close:
        return ""
    # Only those about as close as the closest: 'iea15mw_baselin' is 'iea15mw_baseline', not
    # also 'nrel5mw_baseline'.
    best = difflib.SequenceMatcher(None, value, close[0]).ratio()
    close = [c for c in close if difflib.SequenceMatcher(None, value, c).ratio() >= best - 0.1]
    quoted = [repr(c) for c in close]
    if len(quoted) == 1:
        return f"did you mean {quoted[0]}?"
    return f"did you mean {', '.join(quoted[:-1])} or {quoted[-1]}?"


def _check_preset(key: str, ref: str, shipped: list[str], what: str) -> None:
    """A preset reference: a shipped name, or a path to an existing ``.toml`` file."""
    if ref in shipped:
        return
    if ref.endswith(".toml"):
        if not Path(ref).is_file():
            raise ValueError(f"{key} = {ref!r}: preset file not found ({Path(ref).absolute()})")
        return
    hint = suggestion(ref, shipped) or "'fowt presets' lists them"
    raise ValueError(f"{key} = {ref!r}: expected {what} or a path to a preset .toml; {hint}")


def shipped_turbines() -> list[str]:
    """Names of the turbine presets shipped with the plant (found without importing it)."""
    return package_presets("plant", "presets")


def shipped_platforms() -> list[str]:
    """Names of the floating platform presets shipped with the plant (found without
    importing it: :func:`package_presets`)."""
    return package_presets("plant", "presets", "floating")


def shipped_scenarios() -> list[str]:
    """Names of the scenarios shipped with the package."""
    root = importlib.resources.files("hil.scenario") / "presets"
    return sorted(p.name.removesuffix(".toml") for p in root.iterdir() if p.name.endswith(".toml"))


def scenario_text(name_or_path: str) -> tuple[str, str]:
    """The TOML text and its source for a shipped name or a file path.

    A bare name (no ``/``, no ``.toml``) of a shipped scenario is the shipped scenario, even
    when the working directory holds a file or folder of that name (write ``./name`` for
    that one).

    Raises
    ------
    ScenarioError
        For an unknown name, a path that is not a readable UTF-8 text file.
    """
    res = importlib.resources.files("hil.scenario") / "presets" / f"{name_or_path}.toml"
    bare = "/" not in name_or_path and not name_or_path.endswith(".toml")
    if bare and name_or_path and res.is_file():
        return res.read_text(), f"hil/scenario/presets/{name_or_path}.toml"
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists() or not bare:
        if path.is_dir():
            hint = suggestion(name_or_path, shipped_scenarios())
            raise ScenarioError(
                f"scenario {name_or_path!r}: {path} is a directory, not a scenario file, and "
                "no shipped scenario has that name"
                + (f"; {hint}" if hint else " ('fowt scenarios' lists them)")
            )
        if not path.is_file():
            raise ScenarioError(f"scenario file {path} does not exist")
        try:
            return path.read_bytes().decode("utf-8"), str(path)
        except UnicodeDecodeError as exc:
            raise ScenarioError(
                f"scenario file {path}: expected a UTF-8 TOML text file, found binary data "
                f"(byte {exc.start})"
            ) from exc
        except OSError as exc:
            raise ScenarioError(
                f"scenario file {path}: cannot read it ({exc.strerror or exc})"
            ) from exc
    hint = suggestion(name_or_path, shipped_scenarios())
    raise ScenarioError(
        f"no scenario {name_or_path!r}: expected a shipped scenario's name or a .toml path; "
        + (hint or "'fowt scenarios' lists the shipped ones")
    )


def scenario_folder(name_or_path: str) -> Path:
    """The folder a scenario's relative file paths are taken from: its file's folder (for a
    shipped scenario, the shipped scenarios' folder)."""
    bare = "/" not in name_or_path and not name_or_path.endswith(".toml")
    res = importlib.resources.files("hil.scenario") / "presets" / f"{name_or_path}.toml"
    if bare and name_or_path and res.is_file():
        return Path(str(importlib.resources.files("hil.scenario") / "presets"))
    return Path(os.path.normpath(Path(name_or_path).expanduser().absolute())).parent


def load_scenario(name_or_path: str = "default") -> Scenario:
    """Load a shipped scenario by name or a scenario file by path.

    Its relative file paths are taken from its folder (:func:`resolve_paths`), and so is
    ``[controller] base_dir`` of a scenario with ``[controller.settings]`` (the folder
    relative paths in the settings are taken from), so every process that loads the file
    finds the same files whatever its working directory.
    """
    text, source = scenario_text(name_or_path)
    return parse_scenario(text, source, scenario_folder(name_or_path))
