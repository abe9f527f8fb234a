"""The controller kinds of the bench: one table mapping ``kind`` to what the kind needs.

:data:`CONTROLLER_KINDS` maps each ``[controller] kind`` of a scenario to a
:class:`ControllerKind`: the function that builds the core from :class:`ControllerOptions`
(:func:`make_controller` looks it up) and, for a kind that loads design artefacts, the
function that makes a missing one before the run (:func:`ensure_design`, called by the
launcher, which knows no kind). Adding a kind is one constructor function and one entry in
that table (the core implements :class:`controller.interface.Controller`, including
``actuator_limits()``).

The cores are imported inside their constructors, so building a baseline core never imports
numpy/scipy of the advanced one; the design functions import :mod:`controller.design.on_demand`
inside them, so the runtime never imports design code. This module imports the cores; the
cores import only :mod:`controller.interface`, never this module.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from controller.interface import ActuatorLimits, Controller

__all__ = [
    "CONTROLLER_KINDS",
    "ControllerKind",
    "ControllerOptions",
    "DesignRequest",
    "actuator_limits",
    "available_controllers",
    "ensure_design",
    "make_controller",
]


@dataclass(frozen=True)
class ControllerOptions:
    """What a constructor of :data:`CONTROLLER_KINDS` receives.

    Attributes
    ----------
    kind : str
        The controller kind (the key it was looked up by).
    preset : str
        Shipped preset name or path to a TOML preset.
    control_period_s : float
        Control period [s].
    forecaster : str or None
        Wave forecaster name (advanced kinds; None: the preset's).
    feedforward : str or None
        Wave feedforward setting (``"lqri_ff"``; None: ``"balanced"``).
    gauge_distance_m : float or None
        Distance of the wave gauge up-wave of the platform [m] (None: the preset's).
    design_dir : str or None
        Extra folder of design artefacts (advanced kinds).
    library, parameter_file, output_dir : str or None
        ``"rosco"`` only: the DISCON library (None: the ``rosco`` wheel's), its DISCON.IN
        (None: the shipped one named by ``preset``) and the folder for its files.
    preview, horizon_s, overlap, symmetric_pitch_limit_deg, torque_weight_factor, gamma_1_s
        casanovas-2014 kinds only (:func:`controller.casanovas.make_casanovas`).
    core : str or None
        ``"python"`` only: ``"package.module:function"``, a function of these options
        returning the core (:func:`_python`).
    """

    kind: str
    preset: str
    control_period_s: float = 0.025
    forecaster: str | None = None
    feedforward: str | None = None
    gauge_distance_m: float | None = None
    design_dir: str | None = None
    library: str | None = None
    parameter_file: str | None = None
    output_dir: str | None = None
    preview: str | None = None
    horizon_s: float | None = None
    overlap: float | None = None
    symmetric_pitch_limit_deg: float | None = None
    torque_weight_factor: float | None = None
    gamma_1_s: float | None = None
    core: str | None = None


@dataclass(frozen=True)
class DesignRequest:
    """What a kind's design function receives: the scenario's data a design may start from.

    Attributes
    ----------
    kind, preset : str
        ``[controller] kind`` and ``preset``.
    control_period_s : float
        Control period [s] (discrete designs are made for it).
    feedforward : str or None
        ``[controller] feedforward`` (``"lqri_ff"``; None: ``"balanced"``).
    platform : str or None
        The scenario's platform: a shipped preset name or a preset file (None: bottom-fixed).
    wind_speed_m_s, hs_m, t1_s : float or None
        Mean wind speed [m/s], significant wave height [m] and mean wave period T1 [s] of
        the scenario's wind and sea, when it has them (design for one load case).
    """

    kind: str
    preset: str
    control_period_s: float
    feedforward: str | None = None
    platform: str | None = None
    wind_speed_m_s: float | None = None
    hs_m: float | None = None
    t1_s: float | None = None


def _feedforward(kind: str, feedforward: str | None) -> str:
    """The advanced controller's wave-FF setting of a kind: ``lqri`` has none."""
    return "off" if kind == "lqri" else (feedforward or "balanced")


def _baseline(o: ControllerOptions) -> Controller[Any]:
    from controller.baseline import BaselineController, load_baseline  # noqa: PLC0415

    return BaselineController(load_baseline(o.preset))


def _advanced(o: ControllerOptions) -> Controller[Any]:
    from controller.runtime import AdvancedController, load_advanced_settings  # noqa: PLC0415

    ff = _feedforward(o.kind, o.feedforward)
    return AdvancedController(
        load_advanced_settings(o.preset),
        o.control_period_s,
        forecaster=o.forecaster,  # type: ignore[arg-type]
        gauge_distance_m=o.gauge_distance_m,
        feedforward=ff,  # type: ignore[arg-type]
        design_dir=o.design_dir,
    )


def _rosco(o: ControllerOptions) -> Controller[Any]:
    from controller.rosco import make_rosco_controller  # noqa: PLC0415

    return make_rosco_controller(
        o.preset, library=o.library, parameter_file=o.parameter_file, output_dir=o.output_dir
    )


def _lqr_wave(o: ControllerOptions) -> Controller[Any]:
    from controller.lqr_wave import LqrWaveController, load_lqr_wave_preset  # noqa: PLC0415

    return LqrWaveController(load_lqr_wave_preset(o.preset), o.control_period_s, o.design_dir)


def _casanovas(o: ControllerOptions) -> Controller[Any]:
    from controller.casanovas import make_casanovas  # noqa: PLC0415

    return make_casanovas(
        o.kind,
        o.preset,
        control_period_s=o.control_period_s,
        preview=o.preview,
        horizon_s=o.horizon_s,
        overlap=o.overlap,
        gauge_distance_m=o.gauge_distance_m,
        design_dir=o.design_dir,
        symmetric_pitch_limit_deg=o.symmetric_pitch_limit_deg,
        torque_weight_factor=o.torque_weight_factor,
        gamma_1_s=o.gamma_1_s,
    )


Say = Callable[[str], None]


def _python(o: ControllerOptions) -> Controller[Any]:
    """A user's core: ``o.core`` = ``"package.module:function"``, the function called with
    the options (minimal form: the module is imported, the function looked up and called)."""
    import importlib  # noqa: PLC0415 - only this kind imports a user's module

    ref = o.core or ""
    module, sep, attr = ref.partition(":")
    if not sep or not module or not attr:
        raise ValueError(f"controller.core = {ref!r}: expected 'package.module:function'")
    try:
        factory = getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"controller.core = {ref!r}: {exc}") from exc
    if not callable(factory):
        raise ValueError(f"controller.core = {ref!r}: not a function")
    core: Controller[Any] = factory(o)
    return core


def _design_advanced(r: DesignRequest, say: Say) -> Path | None:
    from controller.design.on_demand import ensure_advanced  # noqa: PLC0415

    ff = _feedforward(r.kind, r.feedforward)
    return ensure_advanced(r.preset, r.control_period_s, ff, r.platform, say)


def _design_lqr_wave(r: DesignRequest, say: Say) -> Path | None:
    from controller.design.on_demand import ensure_lqr_wave  # noqa: PLC0415

    return ensure_lqr_wave(r.preset, r.control_period_s, say)


def _design_casanovas(r: DesignRequest, say: Say) -> Path | None:
    from controller.design.on_demand import ensure_casanovas  # noqa: PLC0415

    return ensure_casanovas(
        r.preset, r.control_period_s, r.platform, r.wind_speed_m_s, r.hs_m, r.t1_s, say
    )


@dataclass(frozen=True)
class ControllerKind:
    """One entry of :data:`CONTROLLER_KINDS`.

    Attributes
    ----------
    build : callable
        ``build(options) -> core``: the core from :class:`ControllerOptions`.
    design : callable or None
        ``design(request, say) -> Path | None``: makes the kind's missing design artefacts
        for a :class:`DesignRequest` before the run (progress messages through ``say``) and
        returns the folder designed into, or None when nothing was missing or nothing can be
        designed; None for a kind that loads no design artefact.
    """

    build: Callable[[ControllerOptions], Controller[Any]]
    design: Callable[[DesignRequest, Say], Path | None] | None = None


_CASANOVAS = ControllerKind(
    _casanovas, _design_casanovas
)  # casanovas-2014, controller/casanovas.py

CONTROLLER_KINDS: dict[str, ControllerKind] = {
    "baseline": ControllerKind(_baseline),
    "lqri": ControllerKind(_advanced, _design_advanced),
    "lqri_ff": ControllerKind(_advanced, _design_advanced),
    "rosco": ControllerKind(_rosco),
    "lqr_wave": ControllerKind(_lqr_wave, _design_lqr_wave),  # christiansen-2013
    "no_control": _CASANOVAS,
    "base_torque": _CASANOVAS,
    "lqr_steady": _CASANOVAS,
    "lqr_finite": _CASANOVAS,
    "lqr_overlaid": _CASANOVAS,
    "python": ControllerKind(_python),  # a user's core, controller.core = "module:function"
}
"""``kind`` -> constructor and design: the one place a controller kind is registered."""


def available_controllers() -> tuple[str, ...]:
    """Names accepted by :func:`make_controller` as ``kind``."""
    return tuple(CONTROLLER_KINDS)


def _kind(kind: str) -> ControllerKind:
    entry = CONTROLLER_KINDS.get(kind)
    if entry is None:
        raise ValueError(
            f"unknown controller kind {kind!r}; known kinds: {', '.join(available_controllers())}"
        )
    return entry


def ensure_design(request: DesignRequest, say: Say = print) -> Path | None:
    """Make the design artefacts a run of ``request.kind`` needs, if missing.

    Parameters
    ----------
    request : DesignRequest
        The scenario's controller, period, platform, wind and sea.
    say : callable
        Where the progress messages go (what is designed, how long it took).

    Returns
    -------
    Path or None
        The folder designed into (to hand to the controller as ``$FOWT_DESIGN_DIR`` or
        ``design_dir``), or None when nothing was missing, nothing can be designed or the
        kind loads no design.

    Raises
    ------
    ValueError
        If the kind is unknown or its preset cannot be loaded.
    controller.design.on_demand.DesignFailedError
        If a design fails (its output is in the message).
    """
    design = _kind(request.kind).design
    return None if design is None else design(request, say)


def make_controller(
    kind: str,
    preset: str,
    *,
    control_period_s: float = 0.025,
    forecaster: str | None = None,
    feedforward: str | None = None,
    gauge_distance_m: float | None = None,
    design_dir: str | None = None,
    library: str | None = None,
    parameter_file: str | None = None,
    output_dir: str | None = None,
    preview: str | None = None,
    horizon_s: float | None = None,
    overlap: float | None = None,
    symmetric_pitch_limit_deg: float | None = None,
    torque_weight_factor: float | None = None,
    gamma_1_s: float | None = None,
    core: str | None = None,
) -> Controller[Any]:
    """Build a controller of ``kind`` from a shipped preset name or a preset file path.

    Parameters
    ----------
    kind : str
        A key of :data:`CONTROLLER_KINDS`: ``"baseline"`` (NREL-style baseline,
        :mod:`controller.baseline`), ``"lqri"`` (observers + wave forecast + LQRI,
        :mod:`controller.runtime`) or ``"lqri_ff"`` (the same plus the wave feedforward).
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
    library, parameter_file, output_dir : str or None
        ``"rosco"`` only: the DISCON library (None: the ``rosco`` wheel's), its DISCON.IN
        (None: the shipped one named by ``preset``) and the folder for its files
        (:func:`controller.rosco.make_rosco_controller`).
    preview, horizon_s, overlap, symmetric_pitch_limit_deg, torque_weight_factor, gamma_1_s
        casanovas-2014 kinds only (:func:`controller.casanovas.make_casanovas`).
    core : str or None
        ``"python"`` only: ``"package.module:function"`` (:class:`ControllerOptions`).

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
    return _kind(kind).build(
        ControllerOptions(
            kind=kind,
            preset=preset,
            control_period_s=control_period_s,
            forecaster=forecaster,
            feedforward=feedforward,
            gauge_distance_m=gauge_distance_m,
            design_dir=design_dir,
            library=library,
            parameter_file=parameter_file,
            output_dir=output_dir,
            preview=preview,
            horizon_s=horizon_s,
            overlap=overlap,
            symmetric_pitch_limit_deg=symmetric_pitch_limit_deg,
            torque_weight_factor=torque_weight_factor,
            gamma_1_s=gamma_1_s,
            core=core,
        )
    )


def actuator_limits(controller: Controller[Any]) -> ActuatorLimits:
    """The pitch range and the rate limits of a core built by :func:`make_controller`.

    Parameters
    ----------
    controller : Controller
        Any core; it reports its own limits (``controller.actuator_limits()``).

    Returns
    -------
    ActuatorLimits
        Baseline: its preset's ``min_pitch_rad``, ``max_pitch_rad``, ``max_pitch_rate_rad_s``
        and ``max_generator_torque_rate_nm_s``; advanced: its LQRI design's limits.

    Raises
    ------
    TypeError
        For an object without ``actuator_limits()``.
    """
    limits = getattr(controller, "actuator_limits", None)
    if not callable(limits):
        raise TypeError(f"no actuator limits known for {type(controller).__name__}")
    result = limits()
    if not isinstance(result, ActuatorLimits):
        raise TypeError(
            f"{type(controller).__name__}.actuator_limits() returned "
            f"{type(result).__name__}, expected ActuatorLimits"
        )
    return result
