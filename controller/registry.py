"""The controller kinds of the bench: one table mapping ``kind`` to a constructor.

:data:`CONTROLLER_KINDS` maps each ``[controller] kind`` of a scenario to a function that builds
the core from :class:`ControllerOptions`; :func:`make_controller` looks the kind up there.
Adding a kind is one constructor function and one entry in that table (the core implements
:class:`controller.interface.Controller`, including ``actuator_limits()``).

The cores are imported inside their constructors, so building a baseline core never imports
numpy/scipy of the advanced one. This module imports the cores; the cores import only
:mod:`controller.interface`, never this module.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from controller.interface import ActuatorLimits, Controller

__all__ = [
    "CONTROLLER_KINDS",
    "ControllerOptions",
    "actuator_limits",
    "available_controllers",
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


def _baseline(o: ControllerOptions) -> Controller[Any]:
    from controller.baseline import BaselineController, load_baseline  # noqa: PLC0415

    return BaselineController(load_baseline(o.preset))


def _advanced(o: ControllerOptions) -> Controller[Any]:
    from controller.runtime import AdvancedController, load_advanced_settings  # noqa: PLC0415

    ff = "off" if o.kind == "lqri" else (o.feedforward or "balanced")
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


CONTROLLER_KINDS: dict[str, Callable[[ControllerOptions], Controller[Any]]] = {
    "baseline": _baseline,
    "lqri": _advanced,
    "lqri_ff": _advanced,
    "rosco": _rosco,
    "lqr_wave": _lqr_wave,  # christiansen-2013, controller/lqr_wave.py
    # casanovas-2014 (controller/casanovas.py)
    "no_control": _casanovas,
    "base_torque": _casanovas,
    "lqr_steady": _casanovas,
    "lqr_finite": _casanovas,
    "lqr_overlaid": _casanovas,
}
"""``kind`` -> constructor: the one place a controller kind is registered."""


def available_controllers() -> tuple[str, ...]:
    """Names accepted by :func:`make_controller` as ``kind``."""
    return tuple(CONTROLLER_KINDS)


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
    build = CONTROLLER_KINDS.get(kind)
    if build is None:
        raise ValueError(
            f"unknown controller kind {kind!r}; known kinds: {', '.join(available_controllers())}"
        )
    return build(
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
