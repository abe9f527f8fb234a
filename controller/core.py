"""Common interface of the bench's controllers: the command record, the protocol, a registry.

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
      the safe command (:mod:`hil.controller_node`)
====  =========================================================================

:func:`actuator_limits` gives the node a core's pitch range and rate limits, from which it
builds its safe command without reaching into the core.

The controller package never imports ``plant``: it speaks only ``bus_schemas``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import msgspec

from bus_schemas.messages import SensorFrame

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
    "actuator_limits",
    "available_controllers",
    "make_controller",
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


def available_controllers() -> tuple[str, ...]:
    """Names accepted by :func:`make_controller` as ``kind``."""
    return ("baseline", "lqri", "lqri_ff", *_CASANOVAS_KINDS)


#: casanovas-2014 kinds (:mod:`controller.casanovas`), registered in :func:`make_controller`.
_CASANOVAS_KINDS = ("no_control", "base_torque", "lqr_steady", "lqr_finite", "lqr_overlaid")


def make_controller(
    kind: str,
    preset: str,
    *,
    control_period_s: float = 0.025,
    forecaster: str | None = None,
    feedforward: str | None = None,
    gauge_distance_m: float | None = None,
    design_dir: str | None = None,
    preview: str | None = None,
    horizon_s: float | None = None,
    overlap: float | None = None,
) -> Controller[Any]:
    """Build a controller of ``kind`` from a shipped preset name or a preset file path.

    Parameters
    ----------
    kind : str
        ``"baseline"`` (NREL-style baseline, :mod:`controller.baseline`), ``"lqri"`` (observers
        + wave forecast + LQRI, :mod:`controller.runtime`) or ``"lqri_ff"`` (the same plus the
        wave feedforward).
    preset : str
        Shipped preset name (e.g. ``"nrel5mw_baseline"``, ``"iea15mw_advanced"``) or path to a
        TOML preset.
    control_period_s : float
        Control period [s] (the advanced controller discretises its observer at it).
    forecaster : str or None
        ``"dispersion"``, ``"ar"`` or ``"esprit"`` (advanced kinds; None: the preset's).
    feedforward : str or None
        ``"balanced"`` or ``"max_performance"`` for ``"lqri_ff"`` (None: ``"balanced"``).
    gauge_distance_m : float or None
        Distance of the wave gauge up-wave of the platform [m] (None: the preset's).
    design_dir : str or None
        Folder of design artefacts searched after the shipped ones (advanced kinds; None:
        only the shipped designs and the user design cache, ``$FOWT_DESIGN_DIR``).
    preview, horizon_s, overlap : optional
        casanovas-2014 kinds only (:func:`controller.casanovas.make_casanovas`).

    Returns
    -------
    Controller
        A pure controller core.

    Raises
    ------
    ValueError
        If ``kind`` is unknown or the preset cannot be loaded;
        :class:`controller.lqri.DesignNotFoundError` (a ValueError) if a design artefact for
        ``control_period_s`` is missing.
    """
    if kind == "baseline":
        from controller.baseline import BaselineController, load_baseline  # noqa: PLC0415

        return BaselineController(load_baseline(preset))
    if kind in ("lqri", "lqri_ff"):
        from controller.runtime import AdvancedController, load_advanced_settings  # noqa: PLC0415

        ff = "off" if kind == "lqri" else (feedforward or "balanced")
        return AdvancedController(
            load_advanced_settings(preset),
            control_period_s,
            forecaster=forecaster,  # type: ignore[arg-type]
            gauge_distance_m=gauge_distance_m,
            feedforward=ff,  # type: ignore[arg-type]
            design_dir=design_dir,
        )
    if kind in _CASANOVAS_KINDS:
        from controller.casanovas import make_casanovas  # noqa: PLC0415

        return make_casanovas(
            kind,
            preset,
            control_period_s=control_period_s,
            preview=preview,
            horizon_s=horizon_s,
            overlap=overlap,
            gauge_distance_m=gauge_distance_m,
            design_dir=design_dir,
        )
    raise ValueError(
        f"unknown controller kind {kind!r}; known kinds: {', '.join(available_controllers())}"
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


def actuator_limits(controller: Controller[Any]) -> ActuatorLimits:
    """The pitch range and the rate limits of a core built by :func:`make_controller`.

    Parameters
    ----------
    controller : Controller
        A baseline (:class:`controller.baseline.BaselineController`) or advanced
        (:class:`controller.runtime.AdvancedController`) core.

    Returns
    -------
    ActuatorLimits
        Baseline: its preset's ``min_pitch_rad``, ``max_pitch_rad``, ``max_pitch_rate_rad_s``
        and ``max_generator_torque_rate_nm_s``; advanced: its LQRI design's limits.

    Raises
    ------
    TypeError
        For a controller of another type.
    """
    from controller.baseline import BaselineController  # noqa: PLC0415

    if isinstance(controller, BaselineController):
        p = controller.params
        return ActuatorLimits(
            p.min_pitch_rad,
            p.max_pitch_rad,
            p.max_pitch_rate_rad_s,
            p.max_generator_torque_rate_nm_s,
        )
    from controller.runtime import AdvancedController  # noqa: PLC0415

    if isinstance(controller, AdvancedController):
        d = controller.lqri.design
        return ActuatorLimits(
            d.pitch_min_rad, d.pitch_max_rad, d.pitch_rate_max_rad_s, d.torque_rate_max_nm_s
        )
    own = getattr(controller, "actuator_limits", None)  # cores that report their own
    if callable(own):
        result = own()
        if isinstance(result, ActuatorLimits):
            return result
    raise TypeError(f"no actuator limits known for {type(controller).__name__}")
