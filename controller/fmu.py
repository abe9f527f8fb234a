"""An FMI 2.0 or 3.0 co-simulation FMU as a bench controller (``[controller] kind = "fmu"``).

Industrial controllers are often delivered as Functional Mock-up Units exported from
Simulink, Dymola, OpenModelica and similar tools. :class:`FmuController` runs one through
``fmpy``: every control period the mapped sensor-frame fields are set on the FMU's inputs,
``fmi2DoStep`` (``fmi3DoStep``) advances it by one control period, and the mapped outputs
become the command (and, optionally, status internals).

FMI 3.0 FMUs map the same way, with ``Float64`` where FMI 2.0 has ``Real`` and ``Int32``
where it has ``Integer`` (start values also take ``Boolean`` and ``String``); array
variables, clocks, other integer widths, event mode and early return are not used.

Settings (``[controller.settings]``, :class:`FmuSettings`)
----------------------------------------------------------
``fmu``
    Path to the ``.fmu`` file; a relative path is taken from the scenario file's folder.
``inputs``
    ``<SensorFrame field> = "<FMU input variable>"``: e.g.
    ``generator_speed_measured_rad_s = "GenSpeed"``. Float fields feed ``Real`` inputs,
    ``valid_mask`` and ``seq`` feed ``Integer`` inputs.
``outputs``
    ``<command or status field> = "<FMU output variable>"``: ``blade_pitch_commanded_rad``
    and ``generator_torque_commanded_nm`` are required; ``regime`` (an ``Integer`` output),
    ``generator_speed_filtered_rad_s``, ``pitch_integrator_rad``, ``gain_schedule_factor``
    and the estimates of :data:`STATUS_OUTPUTS` are optional.
``start_values``
    ``"<FMU variable>" = value``: parameters and start values set before the FMU's
    initialisation (variables of causality ``parameter`` or ``input``, or local ones with
    ``initial = "exact"``/``"approx"``).
``units``
    ``"<FMU variable>" = "<unit>"``: the unit of a mapped variable that declares none in its
    modelDescription.xml (a declared unit must agree with it).
``pitch_min_rad``, ``pitch_max_rad``, ``pitch_rate_max_rad_s``, ``torque_rate_max_nm_s``
    The actuator limits the bench's safe mode uses (the FMU does not declare them); the pitch
    demand is clamped to the pitch range and the torque demand to >= 0.

Units
-----
Each mapped variable's unit (declared in modelDescription.xml, on the variable or its
declared type, else stated in ``units``) is checked against the bench field's unit (the unit
in the field's name) and converted when the pair is known (:data:`UNIT_FACTORS`: rad and
deg, rad/s and rpm, N.m and kN.m, W and kW/MW, ...); any other pair is refused before the run.

Timing and state
----------------
The FMU is instantiated once per core (its binary loaded by ``fmpy``, its archive extracted
into a temporary folder). :meth:`FmuController.initial_state` resets it (``fmi2Reset``,
``fmi3Reset``), so
a core stepped in a trimmed start's settling run and then in the run starts both from the
same state; the first step after it sets up the experiment at the frame's sample time,
applies the start values, sets the first frame's inputs in initialisation mode and leaves
it, then steps. Each step is ``DoStep(t_k, dt)`` with ``t_k = t_0 + k dt`` (k: frames
stepped since the reset), so the FMU's communication points never jump, whatever frames
the bus lost. Like :mod:`controller.rosco`, the state is a handle on the one instance
(:class:`FmuState`): stepping it advances the FMU, and an older state cannot be stepped
again.

A mapped input whose ``valid_mask`` bit is cleared (dropout) is held at its last valid
value (0 before any) and the step reports ``estimator_degraded`` = 1.

This module imports ``fmpy`` only when a core is checked or built, and never imports
``plant``.
"""

from __future__ import annotations

import contextlib
import difflib
import math
import os
import shutil
import tempfile
import typing
import weakref
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import msgspec

from bus_schemas.messages import (
    EST_PLATFORM_PITCH,
    EST_PLATFORM_PITCH_RATE,
    EST_PLATFORM_SURGE,
    EST_PLATFORM_SURGE_VELOCITY,
    EST_TOWER_TOP_VELOCITY,
    EST_WIND_SPEED,
    VALID_BITS,
    SensorFrame,
)
from controller.fmu_settings import FmuSettings, StartValue
from controller.interface import (
    REGIME_REGION_1,
    REGIME_REGION_2,
    REGIME_REGION_3,
    ActuatorLimits,
    ControlOutput,
)

__all__ = [
    "COMMAND_OUTPUTS",
    "STATUS_OUTPUTS",
    "UNIT_FACTORS",
    "FmuController",
    "FmuError",
    "FmuSettings",
    "FmuState",
    "FmuStepError",
    "make_fmu_controller",
]


class FmuError(ValueError):
    """An FMU or its mapping that cannot be used; one line naming what was expected."""


class FmuStepError(RuntimeError):
    """The FMU failed during the run (an FMI call returned error, fatal or discard).

    Raised from the core's ``step`` like any exception of a core, so the run's verdict is a
    controller fault (``controller_fault``, exit 7) in every mode, naming this message.
    ``library`` is the FMU's path and ``status`` the FMI status code.
    """

    def __init__(self, message: str, library: str = "", status: int = 0) -> None:
        super().__init__(message)
        self.library = library
        self.status = status


#: Bench unit -> {FMU unit (spaces removed, ``*`` written ``.``): factor}; the bench value
#: is the FMU value times the factor.
UNIT_FACTORS: dict[str, dict[str, float]] = {
    "rad": {"rad": 1.0, "deg": math.pi / 180.0},
    "rad/s": {
        "rad/s": 1.0,
        "rpm": math.pi / 30.0,
        "1/min": math.pi / 30.0,
        "r/min": math.pi / 30.0,
        "rev/min": math.pi / 30.0,
        "deg/s": math.pi / 180.0,
    },
    "N m": {
        "N.m": 1.0,
        "Nm": 1.0,
        "kN.m": 1e3,
        "kNm": 1e3,
        "MN.m": 1e6,
        "MNm": 1e6,
    },
    "W": {"W": 1.0, "kW": 1e3, "MW": 1e6},
    "m/s": {"m/s": 1.0, "km/h": 1.0 / 3.6},
    "m/s^2": {"m/s^2": 1.0, "m/s2": 1.0, "m/(s2)": 1.0, "m/(s^2)": 1.0},
    "m": {"m": 1.0},
    "1": {"1": 1.0, "-": 1.0, "": 1.0},
}

#: The command outputs every FMU must provide, with their bench units.
COMMAND_OUTPUTS: dict[str, str] = {
    "blade_pitch_commanded_rad": "rad",
    "generator_torque_commanded_nm": "N m",
}
#: Optional status outputs: field -> (bench unit, estimate bit of ``estimates_valid_mask``).
STATUS_OUTPUTS: dict[str, tuple[str, int]] = {
    "generator_speed_filtered_rad_s": ("rad/s", 0),
    "pitch_integrator_rad": ("rad", 0),
    "gain_schedule_factor": ("1", 0),
    "wind_speed_estimated_m_s": ("m/s", EST_WIND_SPEED),
    "platform_pitch_estimated_rad": ("rad", EST_PLATFORM_PITCH),
    "platform_pitch_rate_estimated_rad_s": ("rad/s", EST_PLATFORM_PITCH_RATE),
    "platform_surge_estimated_m": ("m", EST_PLATFORM_SURGE),
    "platform_surge_velocity_estimated_m_s": ("m/s", EST_PLATFORM_SURGE_VELOCITY),
    "tower_top_velocity_estimated_m_s": ("m/s", EST_TOWER_TOP_VELOCITY),
}
#: Integer SensorFrame fields an FMU may take (as ``Integer`` inputs).
_INT_INPUTS = ("seq", "valid_mask")
_STATUS_NAMES = ("FMI_OK", "warning", "discard", "error", "fatal", "pending")
#: Pitch above the minimum [rad] from which the command counts as region 3 (no regime output).
_REGION_3_MARGIN_RAD = math.radians(1.0)


#: FMI version -> {variable type: how the bench sets it}: the scalar types it maps (FMI 3.0:
#: 64-bit floats and 32-bit integers, as FMI 2.0's Real and Integer).
_TYPES: dict[str, dict[str, str]] = {
    "2.0": {
        "Real": "real",
        "Integer": "integer",
        "Enumeration": "integer",
        "Boolean": "boolean",
        "String": "string",
    },
    "3.0": {"Float64": "real", "Int32": "integer", "Boolean": "boolean", "String": "string"},
}


def _check_type(what: str, var: Any, types: dict[str, str], integer: bool) -> None:
    """FmuError unless ``var`` is a scalar of the bench's float (or integer) type."""
    want = next(t for t, k in types.items() if k == ("integer" if integer else "real"))
    if var.type != want:
        raise FmuError(f"{what}: FMU variable {var.name!r} is {var.type}, expected {want}")
    if list(getattr(var, "dimensions", None) or []):
        raise FmuError(f"{what}: FMU variable {var.name!r} is an array, expected a scalar")


def _sensor_units() -> dict[str, str]:
    """SensorFrame float field -> its unit (from the message's declarations)."""
    out: dict[str, str] = {}
    for name, hint in typing.get_type_hints(SensorFrame, include_extras=True).items():
        if typing.get_origin(hint) is typing.Annotated and typing.get_args(hint)[0] is float:
            for meta in typing.get_args(hint)[1:]:
                if isinstance(meta, msgspec.Meta) and meta.extra and "unit" in meta.extra:
                    out[name] = str(meta.extra["unit"])
    return out


def _norm_unit(unit: str) -> str:
    return unit.strip().replace(" ", "").replace("*", ".").replace("\u00b7", ".")


def _close(name: str, known: list[str]) -> str:
    hit = difflib.get_close_matches(name, known, n=1)
    return f"; did you mean {hit[0]!r}?" if hit else ""


@dataclass(frozen=True)
class _Binding:
    """One mapped variable: bench field, FMU variable, value reference, unit factor."""

    field: str
    variable: str
    vr: int
    factor: float
    integer: bool
    held_bit: int = 0


@dataclass(frozen=True)
class _Start:
    variable: str
    vr: int
    kind: str  # "real", "integer", "boolean", "string"
    value: StartValue


@dataclass(frozen=True)
class FmuModel:
    """What :func:`check_fmu` found: the FMU's identity and the resolved mapping.

    Attributes
    ----------
    path : Path
        The ``.fmu`` file (resolved).
    model_description : Any
        fmpy's ``ModelDescription``.
    model_identifier : str
        The co-simulation ``modelIdentifier`` (the binary's name).
    inputs, outputs : tuple of _Binding
        Mapped inputs and outputs with their value references and unit factors.
    starts : tuple of _Start
        Start values to set before initialisation.
    fmi_version : str
        ``"2.0"`` or ``"3.0"``.
    """

    path: Path
    model_description: Any
    model_identifier: str
    inputs: tuple[_Binding, ...]
    outputs: tuple[_Binding, ...]
    starts: tuple[_Start, ...]
    fmi_version: str = "2.0"


def resolve_fmu_path(settings: FmuSettings, base_dir: str | os.PathLike[str] | None) -> Path:
    """``settings.fmu`` as an absolute path (a relative one from ``base_dir``, else the cwd)."""
    p = Path(settings.fmu).expanduser()
    if not p.is_absolute() and base_dir is not None:
        p = Path(base_dir) / p
    return p.resolve()


def _variable_unit(var: Any) -> str | None:
    unit = getattr(var, "unit", None)
    if not unit and getattr(var, "declaredType", None) is not None:
        unit = getattr(var.declaredType, "unit", None)
    return unit or None


def _factor(what: str, var: Any, bench_unit: str, stated: str | None) -> float:
    """The factor bench = FMU x factor of one mapped variable, or FmuError."""
    declared = _variable_unit(var)
    if declared is not None and stated is not None and _norm_unit(declared) != _norm_unit(stated):
        raise FmuError(
            f"{what}: FMU variable {var.name!r} declares unit {declared!r}, but "
            f"[controller.settings.units] states {stated!r}"
        )
    unit = declared if declared is not None else stated
    table = UNIT_FACTORS.get(bench_unit, {})
    if unit is None:
        if bench_unit == "1":
            return 1.0
        raise FmuError(
            f"{what}: FMU variable {var.name!r} declares no unit; expected {bench_unit!r} "
            f"or a known conversion ({', '.join(k for k in table if k)}): state it in "
            "[controller.settings.units]"
        )
    factor = table.get(_norm_unit(unit))
    if factor is None:
        raise FmuError(
            f"{what}: FMU variable {var.name!r} has unit {unit!r}, the bench field's is "
            f"{bench_unit!r}; known units for it: {', '.join(k for k in table if k)}"
        )
    return factor


def check_fmu(settings: FmuSettings, base_dir: str | os.PathLike[str] | None = None) -> FmuModel:
    """Check an FMU and its mapping without loading its binary; return the resolved model.

    Parameters
    ----------
    settings : FmuSettings
        The scenario's ``[controller.settings]``.
    base_dir : path-like or None
        Folder a relative ``settings.fmu`` is taken from (the scenario file's folder).

    Returns
    -------
    FmuModel
        The model description and the mapping with value references and unit factors.

    Raises
    ------
    FmuError
        One line naming what was expected: the file missing or not a zip archive,
        modelDescription.xml missing or malformed, an FMI version other than 2.0 and 3.0, no
        co-simulation interface, no binary for this platform, a mapped field or variable
        that does not exist or has the wrong causality or type, a missing command output,
        a start value of the wrong type, a unit that does not match.
    """
    import fmpy  # noqa: PLC0415  # only where an FMU is used
    from fmpy.model_description import read_model_description  # noqa: PLC0415

    path = resolve_fmu_path(settings, base_dir)
    name = f"FMU {path.name}"
    if not path.is_file():
        raise FmuError(f"FMU file not found: {path} (expected an FMI co-simulation .fmu)")
    if not zipfile.is_zipfile(path):
        raise FmuError(f"{name}: not a zip archive (an .fmu is a zip with modelDescription.xml)")
    try:
        with zipfile.ZipFile(path) as zf:
            names = set(zf.namelist())
    except (zipfile.BadZipFile, OSError) as exc:
        raise FmuError(f"{name}: cannot read the archive ({exc})") from exc
    if "modelDescription.xml" not in names:
        raise FmuError(f"{name}: no modelDescription.xml at the archive's root")
    # The FMI version first (fmpy's schema check would call a newer version malformed).
    try:
        with zipfile.ZipFile(path) as zf:
            root = ElementTree.fromstring(zf.read("modelDescription.xml"))
    except ElementTree.ParseError as exc:
        raise FmuError(f"{name}: malformed modelDescription.xml: {exc}") from exc
    version = root.get("fmiVersion")
    if root.tag != "fmiModelDescription" or version is None:
        raise FmuError(
            f"{name}: malformed modelDescription.xml: expected an fmiModelDescription element "
            "with an fmiVersion attribute"
        )
    if version not in _TYPES:
        raise FmuError(
            f"{name}: FMI version {version!r} is not supported (expected an FMI 2.0 or 3.0 "
            "co-simulation FMU)"
        )
    try:
        md = read_model_description(str(path), validate=True)
    except Exception as exc:  # lxml, schema and fmpy's own checks
        text = " ".join(str(exc).split())
        raise FmuError(f"{name}: malformed modelDescription.xml: {text[:300]}") from exc
    if md.coSimulation is None:
        raise FmuError(
            f"{name}: no co-simulation interface (model exchange only); expected an FMI "
            f"{version} co-simulation FMU"
        )
    ident = md.coSimulation.modelIdentifier
    folder = fmpy.platform if version == "2.0" else fmpy.platform_tuple
    binary = f"binaries/{folder}/{ident}{fmpy.sharedLibraryExtension}"
    if binary not in names:
        shipped = sorted(
            {n.split("/")[1] for n in names if n.startswith("binaries/") and n.count("/") >= 2}
        )
        raise FmuError(
            f"{name}: no binary for this platform: expected {binary} "
            f"(platforms in the FMU: {', '.join(shipped) or 'none'})"
        )
    types = _TYPES[version]
    variables = {v.name: v for v in md.modelVariables}
    known = sorted(variables)

    def variable(what: str, vname: str) -> Any:
        var = variables.get(vname)
        if var is None:
            raise FmuError(f"{what}: FMU has no variable {vname!r}{_close(vname, known)}")
        return var

    sensor_units = _sensor_units()
    inputs: list[_Binding] = []
    for fld, vname in settings.inputs.items():
        what = f"{name}: inputs.{fld}"
        if fld not in sensor_units and fld not in _INT_INPUTS:
            fields = [*sensor_units, *_INT_INPUTS]
            raise FmuError(f"{what}: no such SensorFrame field{_close(fld, fields)}")
        var = variable(what, vname)
        if var.causality != "input":
            raise FmuError(
                f"{what}: FMU variable {vname!r} has causality {var.causality!r}, expected 'input'"
            )
        integer = fld in _INT_INPUTS
        _check_type(what, var, types, integer)
        factor = (
            1.0 if integer else _factor(what, var, sensor_units[fld], settings.units.get(vname))
        )
        # FMU value = bench value / factor (the factor is FMU -> bench).
        inputs.append(
            _Binding(fld, vname, var.valueReference, factor, integer, VALID_BITS.get(fld, 0))
        )
    outputs: list[_Binding] = []
    optional = {k: v[0] for k, v in STATUS_OUTPUTS.items()}
    for fld, vname in settings.outputs.items():
        what = f"{name}: outputs.{fld}"
        if fld not in COMMAND_OUTPUTS and fld not in optional and fld != "regime":
            fields = [*COMMAND_OUTPUTS, "regime", *optional]
            raise FmuError(
                f"{what}: not a command or status field (expected one of {', '.join(fields)})"
            )
        var = variable(what, vname)
        if var.causality != "output":
            raise FmuError(
                f"{what}: FMU variable {vname!r} has causality {var.causality!r}, expected 'output'"
            )
        integer = fld == "regime"
        _check_type(what, var, types, integer)
        unit = COMMAND_OUTPUTS.get(fld) or optional.get(fld, "1")
        factor = 1.0 if integer else _factor(what, var, unit, settings.units.get(vname))
        outputs.append(_Binding(fld, vname, var.valueReference, factor, integer))
    for fld in COMMAND_OUTPUTS:
        if fld not in settings.outputs:
            raise FmuError(
                f"{name}: outputs.{fld} missing: map it to the FMU output that gives it "
                f"(the FMU's outputs: "
                f"{', '.join(v.name for v in md.modelVariables if v.causality == 'output')})"
            )
    for vname in settings.units:
        if vname not in settings.inputs.values() and vname not in settings.outputs.values():
            raise FmuError(f"{name}: units.{vname}: not a mapped input or output variable")
    starts: list[_Start] = []
    for vname, value in settings.start_values.items():
        what = f"{name}: start_values.{vname}"
        var = variable(what, vname)
        settable = var.causality in ("parameter", "input") or (
            var.causality == "local" and var.initial in ("exact", "approx")
        )
        if var.variability == "constant" or not settable:
            raise FmuError(
                f"{what}: FMU variable {vname!r} (causality {var.causality!r}, variability "
                f"{var.variability!r}) cannot be set; expected a parameter, an input or a "
                "local variable with an exact or approximate start value"
            )
        kind = types.get(var.type)
        if kind is None or list(getattr(var, "dimensions", None) or []):
            raise FmuError(
                f"{what}: FMU variable {vname!r} is {'an array of ' if kind else ''}"
                f"{var.type}; start values are taken for scalar "
                f"{', '.join(sorted(types))} variables"
            )
        ok = {
            "real": isinstance(value, int | float) and not isinstance(value, bool),
            "integer": isinstance(value, int) and not isinstance(value, bool),
            "boolean": isinstance(value, bool),
            "string": isinstance(value, str),
        }[kind]
        if not ok:
            raise FmuError(
                f"{what} = {value!r}: FMU variable {vname!r} is {var.type}, expected a value "
                "of that type"
            )
        starts.append(_Start(vname, var.valueReference, kind, value))
    return FmuModel(path, md, ident, tuple(inputs), tuple(outputs), tuple(starts), version)


# --------------------------------------------------------------------------- the core
@dataclass(eq=False)
class FmuState:
    """Handle on the core's FMU instance after a reset (mutable; module docstring).

    Attributes
    ----------
    generation : int
        Which reset of the instance this state belongs to (a newer one makes it stale).
    steps : int
        Frames stepped since the reset.
    start_ns : int
        Sample time of the first frame [ns] (the experiment's start time).
    held : dict
        Last valid value of each mapped input (bench units).
    """

    generation: int
    steps: int = 0
    start_ns: int = 0
    held: dict[str, float] = field(default_factory=dict)


class FmuController:
    """An FMI 2.0 or 3.0 co-simulation FMU as a bench controller (module docstring).

    Parameters
    ----------
    settings : FmuSettings
        The FMU, its mapping, start values and actuator limits.
    control_period_s : float
        Control period [s]: the communication step of every ``DoStep``.
    base_dir : path-like or None
        Folder a relative ``settings.fmu`` is taken from.

    Raises
    ------
    FmuError
        From :func:`check_fmu` (nothing is loaded before that passed).
    """

    def __init__(
        self,
        settings: FmuSettings,
        control_period_s: float,
        base_dir: str | os.PathLike[str] | None = None,
    ) -> None:
        self.settings = settings
        self.model = check_fmu(settings, base_dir)
        self.control_period_s = control_period_s
        self.period_ns = round(control_period_s * 1e9)
        self.name = f"FMU {self.model.path.name}"
        self._fmi = "fmi3" if self.model.fmi_version == "3.0" else "fmi2"
        self._slave: Any = None
        self._set: dict[str, Any] = {}
        self._get_real: Any = None
        self._get_int: Any = None
        self._generation = 0
        self._cleanup: Any = None
        self._in_real = [b for b in self.model.inputs if not b.integer]
        self._in_int = [b for b in self.model.inputs if b.integer]
        self._out_real = [b for b in self.model.outputs if not b.integer]
        self._out_int = [b for b in self.model.outputs if b.integer]
        self._vr_in_real = [b.vr for b in self._in_real]
        self._vr_in_int = [b.vr for b in self._in_int]
        self._vr_out_real = [b.vr for b in self._out_real]
        self._vr_out_int = [b.vr for b in self._out_int]
        self._est_mask = 0
        for b in self.model.outputs:
            self._est_mask |= STATUS_OUTPUTS.get(b.field, ("", 0))[1]

    def actuator_limits(self) -> ActuatorLimits:
        """The pitch range and rate limits of the settings (the node's safe command)."""
        s = self.settings
        return ActuatorLimits(
            s.pitch_min_rad, s.pitch_max_rad, s.pitch_rate_max_rad_s, s.torque_rate_max_nm_s
        )

    def _fail(self, what: str, exc: BaseException, t_s: float | None) -> FmuStepError:
        status = int(getattr(exc, "status", 0) or 0)
        label = _STATUS_NAMES[status] if 0 <= status < len(_STATUS_NAMES) else "unknown"
        when = f" at t = {t_s:.3f} s" if t_s is not None else ""
        detail = f"status {status} ({label})" if status else " ".join(str(exc).split())
        return FmuStepError(
            f"{self.name}: {what} failed{when}: {detail}",
            library=str(self.model.path),
            status=status,
        )

    def _load(self) -> None:
        """Extract the archive, load the binary, instantiate (once per core)."""
        from fmpy import extract  # noqa: PLC0415
        from fmpy.fmi2 import FMU2Slave  # noqa: PLC0415
        from fmpy.fmi3 import FMU3Slave  # noqa: PLC0415

        folder = tempfile.mkdtemp(prefix="fowt-fmu-")
        self._cleanup = weakref.finalize(self, shutil.rmtree, folder, True)
        extract(str(self.model.path), folder)
        md = self.model.model_description
        v3 = self.model.fmi_version == "3.0"
        try:
            slave = (FMU3Slave if v3 else FMU2Slave)(
                guid=md.instantiationToken if v3 else md.guid,
                unzipDirectory=folder,
                modelIdentifier=self.model.model_identifier,
                instanceName="fowt_controller",
            )
            slave.instantiate(loggingOn=False)
        except Exception as exc:  # fmpy raises bare Exceptions here
            raise self._fail("loading and instantiating", exc, None) from exc
        self._slave = slave
        # The typed calls of the version (FMI 3.0: Float64 and Int32 for Real and Integer).
        self._set = {
            "real": slave.setFloat64 if v3 else slave.setReal,
            "integer": slave.setInt32 if v3 else slave.setInteger,
            "boolean": slave.setBoolean,
            "string": slave.setString,
        }
        self._get_real = slave.getFloat64 if v3 else slave.getReal
        self._get_int = slave.getInt32 if v3 else slave.getInteger

    def initial_state(self) -> FmuState:
        """Reset the FMU instance (loaded on the first call); its set-up comes with the
        next step.

        Raises
        ------
        FmuStepError
            If the binary cannot be loaded, the instance not created, or the reset fails.
        """
        if self._slave is None:
            self._load()
        else:
            try:
                self._slave.reset()
            except Exception as exc:
                raise self._fail(f"{self._fmi}Reset", exc, None) from exc
        self._generation += 1
        return FmuState(generation=self._generation)

    def close(self) -> None:
        """Terminate and free the instance, and delete the extracted archive."""
        if self._slave is not None:
            slave, self._slave = self._slave, None
            with contextlib.suppress(Exception):  # already failed: freeing is what is left
                slave.terminate()
            slave.freeInstance()
        if self._cleanup is not None:
            self._cleanup()

    def _set_inputs(self, state: FmuState, frame: SensorFrame) -> bool:
        """Set the mapped inputs (held when invalid); True when one was held."""
        held = state.held
        mask = frame.valid_mask
        degraded = False
        if self._in_real:
            values = []
            for b in self._in_real:
                if not b.held_bit or mask & b.held_bit:
                    v = getattr(frame, b.field)
                    held[b.field] = v
                else:
                    v = held.get(b.field, 0.0)
                    degraded = True
                values.append(v / b.factor)
            self._set["real"](self._vr_in_real, values)
        if self._in_int:
            ints = [int(getattr(frame, b.field)) for b in self._in_int]
            self._set["integer"](self._vr_in_int, ints)
        return degraded

    def _initialise(self, state: FmuState, frame: SensorFrame) -> None:
        slave = self._slave
        t0 = frame.sample_time_ns * 1e-9
        v3 = self.model.fmi_version == "3.0"
        if not v3:
            slave.setupExperiment(startTime=t0)
        convert = {"real": float, "integer": int, "boolean": bool, "string": str}
        for s in self.model.starts:
            self._set[s.kind]([s.vr], [convert[s.kind](s.value)])
        if v3:
            slave.enterInitializationMode(startTime=t0)
        else:
            slave.enterInitializationMode()
        self._set_inputs(state, frame)
        slave.exitInitializationMode()

    def step(
        self, state: FmuState, measurement: SensorFrame, dt_s: float
    ) -> tuple[FmuState, ControlOutput]:
        """Set the inputs, ``DoStep`` one control period, read the outputs.

        Raises
        ------
        FmuStepError
            When an FMI call returns error, fatal or discard, or an output is not finite
            (the message names the FMU, the time and the status).
        """
        if state.generation != self._generation:
            raise FmuStepError(
                f"{self.name}: a state from before the instance's last reset was stepped",
                library=str(self.model.path),
            )
        slave = self._slave
        if state.steps == 0:
            state.start_ns = measurement.sample_time_ns
            try:
                self._initialise(state, measurement)
            except Exception as exc:
                raise self._fail("initialisation", exc, state.start_ns * 1e-9) from exc
        t_ns = state.start_ns + state.steps * self.period_ns
        t = t_ns * 1e-9
        try:
            degraded = self._set_inputs(state, measurement)
        except Exception as exc:
            raise self._fail("setting the inputs", exc, t) from exc
        try:
            result = slave.doStep(currentCommunicationPoint=t, communicationStepSize=dt_s)
        except Exception as exc:
            raise self._fail(f"{self._fmi}DoStep", exc, t) from exc
        if result is not None and result[1]:  # FMI 3.0: terminateSimulation
            raise FmuStepError(
                f"{self.name}: fmi3DoStep asked to terminate the simulation at t = {t:.3f} s",
                library=str(self.model.path),
            )
        try:
            reals = self._get_real(self._vr_out_real) if self._vr_out_real else []
            ints = self._get_int(self._vr_out_int) if self._vr_out_int else []
        except Exception as exc:
            raise self._fail("reading the outputs", exc, t) from exc
        state.steps += 1
        out: dict[str, float] = {}
        for b, v in zip(self._out_real, reals, strict=True):
            value = v * b.factor
            if not math.isfinite(value):
                raise FmuStepError(
                    f"{self.name}: output {b.variable!r} ({b.field}) is {value} at "
                    f"t = {t:.3f} s (expected a finite number)",
                    library=str(self.model.path),
                )
            out[b.field] = value
        s = self.settings
        pitch = min(max(out.pop("blade_pitch_commanded_rad"), s.pitch_min_rad), s.pitch_max_rad)
        torque = max(out.pop("generator_torque_commanded_nm"), 0.0)
        if ints:
            regime = int(ints[0])
            if not REGIME_REGION_1 <= regime <= REGIME_REGION_3:
                raise FmuStepError(
                    f"{self.name}: output {self._out_int[0].variable!r} (regime) is {regime} "
                    f"at t = {t:.3f} s (expected a regime code 0-4)",
                    library=str(self.model.path),
                )
        else:
            above = pitch >= s.pitch_min_rad + _REGION_3_MARGIN_RAD
            regime = REGIME_REGION_3 if above else REGIME_REGION_2
        out.setdefault("generator_speed_filtered_rad_s", measurement.generator_speed_measured_rad_s)
        out.setdefault("pitch_integrator_rad", 0.0)
        out.setdefault("gain_schedule_factor", 1.0)
        return state, ControlOutput(
            blade_pitch_commanded_rad=pitch,
            generator_torque_commanded_nm=torque,
            regime=regime,
            estimates_valid_mask=self._est_mask,
            estimator_degraded=int(degraded),
            **out,  # type: ignore[arg-type]
        )


def make_fmu_controller(
    settings: FmuSettings | dict[str, Any],
    control_period_s: float,
    base_dir: str | os.PathLike[str] | None = None,
) -> FmuController:
    """An :class:`FmuController` from settings (a dict is validated as :class:`FmuSettings`).

    Raises
    ------
    FmuError
        For settings that do not validate or an FMU or mapping that cannot be used.
    """
    if not isinstance(settings, FmuSettings):
        try:
            settings = msgspec.convert(settings, FmuSettings)
        except (msgspec.ValidationError, ValueError) as exc:
            raise FmuError(f"controller.settings: {exc}") from exc
    return FmuController(settings, control_period_s, base_dir)
