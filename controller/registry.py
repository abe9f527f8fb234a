"""The controller kinds of the bench: the shipped table, installed plug-ins and ``core`` paths.

:data:`CONTROLLER_KINDS` maps each shipped ``[controller] kind`` of a scenario to a
:class:`ControllerKind`: the function that builds the core from :class:`ControllerOptions`
(:func:`make_controller` looks it up), for a kind that loads design artefacts the function
that makes a missing one before the run (:func:`ensure_design`, called by the launcher,
which knows no kind), and for a kind with a ``[controller.settings]`` table the msgspec
Struct that table is validated against.

A user's controller lives in the user's own package and is found without any file of the
bench being edited (:func:`find_kind`), in this order:

1. the shipped table, :data:`CONTROLLER_KINDS`;
2. the entry points of the group :data:`ENTRY_POINT_GROUP` (``fowt_hil.controllers``) of the
   installed distributions: the entry point's name is the kind, its object a
   :class:`ControllerKind` (an entry point named like a shipped kind, or ``python``, or two
   distributions registering one name, are refused: the kind cannot be used until renamed);
3. ``kind = "python"`` with ``core = "package.module:attribute"``: the attribute is the
   :class:`ControllerKind` (imported from the interpreter's path, e.g. ``PYTHONPATH``).

A plug-in is one :class:`ControllerKind` object: ``build`` (options -> core), optionally
``settings`` (its settings schema), ``design`` (its design hook) and ``description``. A
plain function taking :class:`ControllerOptions` is accepted as the shorthand of
``ControllerKind(build=function)``. Every error of finding or loading a kind, and every bad
setting, is a :class:`ControllerKindError`: one line naming the key at fault.

The shipped cores are imported inside their constructors, so building a baseline core never
imports numpy/scipy of the advanced one; the design functions import
:mod:`controller.design.on_demand` inside them, so the runtime never imports design code.
This module imports the cores; the cores import only :mod:`controller.interface`, never
this module (a plug-in imports it for :class:`ControllerKind` and :class:`ControllerOptions`).
"""

from __future__ import annotations

import difflib
import functools
import importlib
import importlib.metadata
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import msgspec

from controller.fmu_settings import FmuSettings
from controller.interface import ActuatorLimits, Controller

__all__ = [
    "CONTROLLER_KINDS",
    "ENTRY_POINT_GROUP",
    "PYTHON_KIND",
    "ControllerKind",
    "ControllerKindError",
    "ControllerOptions",
    "DesignRequest",
    "FoundKind",
    "KindInfo",
    "actuator_limits",
    "available_controllers",
    "ensure_design",
    "find_kind",
    "known_kinds",
    "list_kinds",
    "make_controller",
    "settings_for",
    "validate_settings",
]

#: The entry-point group an installed distribution registers its controller kinds in.
ENTRY_POINT_GROUP = "fowt_hil.controllers"
#: The kind whose core is named by ``[controller] core = "package.module:attribute"``.
PYTHON_KIND = "python"


class ControllerKindError(ValueError):
    """A controller kind that cannot be found or loaded, or settings it refuses (one line)."""


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
    settings : object or None
        The kind's ``[controller.settings]`` table validated: an instance of its
        :attr:`ControllerKind.settings` schema, or None for a kind without one.
    base_dir : str or None
        The folder that relative paths in the settings resolve against: the scenario file's
        folder, or the working directory for a shipped scenario (None: the working
        directory).
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
    settings: Any = None
    base_dir: str | None = None

    def path(self, value: str | Path) -> Path:
        """A path of the settings made absolute: relative ones against :attr:`base_dir`."""
        p = Path(value).expanduser()
        return p if p.is_absolute() else Path(self.base_dir or Path.cwd()) / p


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
    core : str or None
        ``[controller] core`` (kind ``python`` only).
    settings : mapping or None
        ``[controller.settings]`` as written; the design function of a kind with a settings
        schema receives it validated (an instance of the schema).
    base_dir : str or None
        As :attr:`ControllerOptions.base_dir`.
    """

    kind: str
    preset: str
    control_period_s: float
    feedforward: str | None = None
    platform: str | None = None
    wind_speed_m_s: float | None = None
    hs_m: float | None = None
    t1_s: float | None = None
    core: str | None = None
    settings: Any = None
    base_dir: str | None = None


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


def _fmu(o: ControllerOptions) -> Controller[Any]:
    from controller.fmu import make_fmu_controller  # noqa: PLC0415

    if o.settings is None:
        raise ValueError("kind 'fmu' needs [controller.settings] (fmu, inputs, outputs)")
    return make_fmu_controller(o.settings, o.control_period_s, o.base_dir)


def _rosco(o: ControllerOptions) -> Controller[Any]:
    from controller.rosco import make_rosco_controller  # noqa: PLC0415

    return make_rosco_controller(
        o.preset,
        library=o.library,
        parameter_file=o.parameter_file,
        output_dir=o.output_dir,
        control_period_s=o.control_period_s,
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
    """A controller kind: an entry of :data:`CONTROLLER_KINDS`, or a plug-in.

    A plug-in (an entry point of :data:`ENTRY_POINT_GROUP`, or the attribute named by
    ``[controller] core``) is one object of this class, defined in the user's package.

    Attributes
    ----------
    build : callable
        ``build(options) -> core``: the core (:class:`controller.interface.Controller`) from
        :class:`ControllerOptions`; ``options.settings`` is the validated settings object.
    design : callable or None
        ``design(request, say) -> Path | None``: makes the kind's missing design artefacts
        for a :class:`DesignRequest` before the run (progress messages through ``say``) and
        returns the folder designed into, or None when nothing was missing or nothing can be
        designed; None for a kind that loads no design artefact. It runs in the launcher
        (and once per campaign, in its client), before any process of the run starts.
    settings : msgspec Struct type or None
        The schema of the kind's ``[controller.settings]`` table: the table is converted to
        it (``msgspec.convert``) when the scenario is read, so a bad setting is an error
        before the run. Declare it ``forbid_unknown_fields=True`` (a misspelt key is then an
        error) with units in the field names. None: the kind takes no settings.
    description : str
        One line for ``fowt controllers``.
    """

    build: Callable[[ControllerOptions], Controller[Any]]
    design: Callable[[DesignRequest, Say], Path | None] | None = None
    settings: type[msgspec.Struct] | None = None
    description: str = ""


_CASANOVAS = ControllerKind(
    _casanovas,
    _design_casanovas,
    description="casanovas-2014 TLP controllers (preview LQRs, region-2 law)",
)

CONTROLLER_KINDS: dict[str, ControllerKind] = {
    "baseline": ControllerKind(
        _baseline, description="reference baseline (NREL 5 MW DISCON, IEA 15 MW ROSCO schedule)"
    ),
    "lqri": ControllerKind(
        _advanced, _design_advanced, description="observers + gain-scheduled LQRI (disannio-2022)"
    ),
    "lqri_ff": ControllerKind(
        _advanced, _design_advanced, description="LQRI plus the wave feedforward (al-2019)"
    ),
    "rosco": ControllerKind(_rosco, description="a Bladed-style DISCON library (ROSCO's)"),
    "fmu": ControllerKind(
        _fmu,
        settings=FmuSettings,
        description="an FMI 2.0 or 3.0 co-simulation FMU run through fmpy (controller/fmu.py)",
    ),
    "lqr_wave": ControllerKind(
        _lqr_wave, _design_lqr_wave, description="wave-scheduled LQR (christiansen-2013)"
    ),
    "no_control": _CASANOVAS,
    "base_torque": _CASANOVAS,
    "lqr_steady": _CASANOVAS,
    "lqr_finite": _CASANOVAS,
    "lqr_overlaid": _CASANOVAS,
}
"""Shipped ``kind`` -> constructor, design, settings schema (module docstring for plug-ins)."""


@dataclass(frozen=True)
class FoundKind:
    """A controller kind as :func:`find_kind` found it.

    Attributes
    ----------
    name : str
        The kind (``python`` for a ``core`` path).
    kind : ControllerKind
        What builds it.
    source : str
        ``shipped``, ``entry point DIST==VERSION`` or ``python`` (a ``core`` path).
    target : str
        Where it was loaded from: ``module:attribute`` ("" for a shipped kind).
    """

    name: str
    kind: ControllerKind
    source: str
    target: str = ""


@dataclass(frozen=True)
class _EntryPoint:
    name: str
    value: str
    dist: str
    entry_point: Any  # importlib.metadata.EntryPoint


@functools.cache
def _entry_points() -> dict[str, tuple[_EntryPoint, ...]]:
    """The installed entry points of :data:`ENTRY_POINT_GROUP`, by name (read once)."""
    out: dict[str, list[_EntryPoint]] = {}
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        dist = getattr(ep, "dist", None)
        label = f"{dist.name}=={dist.version}" if dist is not None else "unknown distribution"
        # module:attribute without extras ("mod:obj [extra]" names the same object)
        value = f"{ep.module}:{ep.attr}" if ep.attr else ep.value
        out.setdefault(ep.name, []).append(_EntryPoint(ep.name, value, label, ep))
    # one distribution found twice on the path (an editable install beside a copy) is one
    return {name: tuple({(e.value, e.dist): e for e in eps}.values()) for name, eps in out.items()}


def known_kinds() -> tuple[str, ...]:
    """Every kind name a scenario may give: shipped, installed (entry points), ``python``."""
    return (*CONTROLLER_KINDS, *(n for n in _entry_points() if n not in CONTROLLER_KINDS))


def available_controllers() -> tuple[str, ...]:
    """Names accepted by :func:`make_controller` as ``kind`` (:func:`known_kinds` and
    ``python``)."""
    return (*known_kinds(), PYTHON_KIND)


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}".rstrip(": ")


def _as_kind(obj: Any, where: str) -> ControllerKind:
    """A loaded plug-in object as a :class:`ControllerKind` (a function: its ``build``)."""
    if isinstance(obj, ControllerKind):
        schema = obj.settings
        if schema is not None and not (
            isinstance(schema, type) and issubclass(schema, msgspec.Struct)
        ):
            raise ControllerKindError(
                f"{where}: ControllerKind.settings must be a msgspec.Struct class (the settings "
                f"schema), got {type(schema).__name__}"
            )
        if not callable(obj.build) or (obj.design is not None and not callable(obj.design)):
            raise ControllerKindError(f"{where}: ControllerKind.build and design must be callable")
        return obj
    if callable(obj) and not isinstance(obj, type):
        doc = (getattr(obj, "__doc__", None) or "").strip().splitlines()
        return ControllerKind(build=obj, description=doc[0] if doc else "")
    raise ControllerKindError(
        f"{where}: expected a controller.registry.ControllerKind (or a function taking "
        f"ControllerOptions), got {type(obj).__name__}"
    )


_TARGET = re.compile(r"^[A-Za-z_][\w]*(\.[A-Za-z_][\w]*)*:[A-Za-z_][\w]*(\.[A-Za-z_][\w]*)*$")


@functools.cache
def _load_target(target: str, where: str) -> ControllerKind:
    """Import ``module:attribute`` (module docstring, step 3) as a :class:`ControllerKind`."""
    if not _TARGET.match(target):
        raise ControllerKindError(
            f"{where} = {target!r}: expected 'package.module:attribute' (a module on the "
            "Python path and the ControllerKind in it)"
        )
    module_name, attr = target.split(":", 1)
    try:
        obj: Any = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        missing = exc.name or module_name
        raise ControllerKindError(
            f"{where} = {target!r}: no module named {missing!r} in this environment (install "
            "the package into the interpreter that runs fowt, or put its folder on PYTHONPATH)"
        ) from exc
    except Exception as exc:  # the user's import raised: say what, in one line
        raise ControllerKindError(
            f"{where} = {target!r}: importing {module_name!r} raised {_one_line(exc)}"
        ) from exc
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ControllerKindError(
                f"{where} = {target!r}: module {module_name!r} has no attribute {attr!r}"
            )
        obj = getattr(obj, part)
    return _as_kind(obj, f"{where} = {target!r}")


def _entry_point(name: str) -> FoundKind | None:
    eps = _entry_points().get(name)
    if not eps:
        return None
    what = ", ".join(f"'{e.name} = {e.value}' of {e.dist}" for e in eps)
    if name in CONTROLLER_KINDS or name == PYTHON_KIND:
        raise ControllerKindError(
            f"controller.kind = {name!r}: the entry point {what} (group {ENTRY_POINT_GROUP}) "
            f"has the name of a shipped kind; it is refused: rename it in its pyproject.toml"
        )
    if len(eps) > 1:
        raise ControllerKindError(
            f"controller.kind = {name!r}: registered by more than one distribution ({what}, "
            f"group {ENTRY_POINT_GROUP}); uninstall or rename one"
        )
    ep = eps[0]
    return FoundKind(
        name,
        _load_target(ep.value, f"controller.kind = {name!r}: entry point of {ep.dist}"),
        f"entry point {ep.dist}",
        ep.value,
    )


def _unknown(kind: str) -> ControllerKindError:
    close = difflib.get_close_matches(kind, available_controllers(), n=3, cutoff=0.6)
    if close:
        hint = "did you mean " + " or ".join(repr(c) for c in close) + "?"
    else:
        hint = (
            "`fowt controllers` lists the kinds found; your own core: kind = 'python' with "
            "core = 'package.module:attribute', or an installed plug-in"
        )
    return ControllerKindError(f"controller.kind = {kind!r}: unknown controller kind; {hint}")


def find_kind(kind: str, core: str | None = None) -> FoundKind:
    """The controller kind a scenario names (module docstring: the order it is searched in).

    Parameters
    ----------
    kind : str
        ``[controller] kind``.
    core : str or None
        ``[controller] core``: ``package.module:attribute``, with ``kind = "python"`` only.

    Raises
    ------
    ControllerKindError
        One line: an unknown kind (with the closest names), a refused entry point, a
        ``core`` missing or misplaced, or a plug-in that cannot be imported or is not a
        :class:`ControllerKind`.
    """
    if kind == PYTHON_KIND:
        if not core:
            raise ControllerKindError(
                "controller.kind = 'python' needs controller.core = 'package.module:attribute' "
                "(the ControllerKind of your core)"
            )
        return FoundKind(PYTHON_KIND, _load_target(core, "controller.core"), "python", core)
    if core is not None:
        raise ControllerKindError(
            f"controller.core is used only by kind = 'python' (kind is {kind!r}: an installed "
            "or shipped kind names its core itself)"
        )
    shipped = CONTROLLER_KINDS.get(kind)
    found = _entry_point(kind)  # also for a shipped name: a clash is refused, not shadowed
    if shipped is not None:
        return FoundKind(kind, shipped, "shipped")
    if found is not None:
        return found
    raise _unknown(kind)


_UNKNOWN_FIELD = re.compile(r"Object contains unknown field `([^`]+)`")
_MISSING_FIELD = re.compile(r"Object missing required field `([^`]+)`")
_AT = re.compile(r" - at `\$\.?([^`]*)`$")


def validate_settings(found: FoundKind, settings: Mapping[str, Any] | None) -> Any:
    """``[controller.settings]`` converted to the kind's schema (None for a kind without one).

    Raises
    ------
    ControllerKindError
        One line naming the setting at fault (``controller.settings.KEY``) and what was
        expected; settings given to a kind that declares no schema.
    """
    schema = found.kind.settings
    if schema is None:
        if settings:
            raise ControllerKindError(
                f"controller.settings: kind {found.name!r} takes no settings (its "
                f"ControllerKind declares no settings schema); got {', '.join(settings)}"
            )
        return None
    if isinstance(settings, schema):
        return settings
    try:
        return msgspec.convert(dict(settings or {}), schema)
    except msgspec.ValidationError as exc:
        msg = str(exc)
        fields = list(schema.__struct_fields__)
        m = _UNKNOWN_FIELD.match(msg)
        if m is not None:
            key = m.group(1)
            close = difflib.get_close_matches(key, fields, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else f" (keys: {', '.join(fields)})"
            raise ControllerKindError(f"controller.settings: unknown key {key!r}{hint}") from exc
        m = _MISSING_FIELD.match(msg)
        if m is not None:
            raise ControllerKindError(
                f"controller.settings: missing key {m.group(1)!r} (kind {found.name!r})"
            ) from exc
        at = _AT.search(msg)
        where = "controller.settings" + (f".{at.group(1)}" if at and at.group(1) else "")
        text = msg[: at.start()] if at else msg
        raise ControllerKindError(f"{where}: {text}") from exc


def settings_for(kind: str, settings: Mapping[str, Any] | None, core: str | None = None) -> Any:
    """``[controller.settings]`` of ``kind`` validated (:func:`validate_settings`)."""
    return validate_settings(find_kind(kind, core), settings)


@dataclass(frozen=True)
class KindInfo:
    """One row of ``fowt controllers`` (:func:`list_kinds`)."""

    name: str
    source: str
    description: str = ""
    settings: str = ""  # the schema's qualified name, "" without one
    design: bool = False
    error: str = ""  # why the kind cannot be used ("" when it can)


def _info(name: str, core: str | None, source: str) -> KindInfo:
    try:
        # an entry point named "python" is refused (find_kind never looks it up)
        ep = _entry_point(name) if name == PYTHON_KIND and core is None else None
        found = ep or find_kind(name, core)
    except ControllerKindError as exc:
        return KindInfo(name, source, error=str(exc))
    k = found.kind
    schema = "" if k.settings is None else f"{k.settings.__module__}.{k.settings.__qualname__}"
    return KindInfo(name, found.source, k.description, schema, k.design is not None)


def list_kinds(core: str | None = None) -> list[KindInfo]:
    """Every kind found, shipped then installed (loaded, so a broken one says why), then
    ``python``: the core ``core`` names when given (loaded), else the kind's one line."""
    rows = [_info(n, None, "shipped") for n in CONTROLLER_KINDS]
    for name, eps in _entry_points().items():
        rows.append(_info(name, None, "entry point " + ", ".join(e.dist for e in eps)))
    if core is not None:
        rows.append(_info(PYTHON_KIND, core, "python"))
    else:
        what = "your core by its import path: core = 'package.module:attribute'"
        rows.append(KindInfo(PYTHON_KIND, "python", what))
    return rows


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
        If the kind is unknown (:class:`ControllerKindError`) or its preset cannot be loaded.
    controller.design.on_demand.DesignFailedError
        If a design fails (its output is in the message).
    """
    found = find_kind(request.kind, request.core)
    design = found.kind.design
    if design is None:
        return None
    if found.kind.settings is not None:
        settings = validate_settings(found, request.settings)
        request = DesignRequest(**{**request.__dict__, "settings": settings})
    return design(request, say)


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
    settings: Any = None,
    base_dir: str | None = None,
) -> Controller[Any]:
    """Build a controller of ``kind`` from a shipped preset name or a preset file path.

    Parameters
    ----------
    kind : str
        A shipped kind of :data:`CONTROLLER_KINDS`: ``"baseline"`` (NREL-style baseline,
        :mod:`controller.baseline`), ``"lqri"`` (observers + wave forecast + LQRI,
        :mod:`controller.runtime`), ``"lqri_ff"`` (the same plus the wave feedforward), ...;
        an installed plug-in's kind, or ``"python"`` with ``core`` (:func:`find_kind`).
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
        ``"package.module:attribute"`` of kind ``"python"``.
    settings : mapping, settings object or None
        ``[controller.settings]``: validated against the kind's schema
        (:func:`validate_settings`) and handed over as ``options.settings``.
    base_dir : str or None
        The folder relative paths in the settings resolve against (None: the working
        directory).

    Returns
    -------
    Controller
        A pure controller core.

    Raises
    ------
    ValueError
        If ``kind`` is unknown or cannot be loaded, a setting is refused
        (:class:`ControllerKindError`) or the preset cannot be loaded;
        :class:`controller.lqri.DesignNotFoundError` (a ValueError) if a design artefact for
        ``control_period_s`` is missing.
    """
    found = find_kind(kind, core)
    options = ControllerOptions(
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
        settings=validate_settings(found, settings),
        base_dir=base_dir,
    )
    if found.source == "shipped":
        return found.kind.build(options)
    try:
        return found.kind.build(options)
    except ValueError:
        raise
    except Exception as exc:  # a plug-in's constructor: one line, naming the kind
        raise ControllerKindError(
            f"controller.kind = {kind!r} ({found.source}): building its core raised "
            f"{_one_line(exc)}"
        ) from exc


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
