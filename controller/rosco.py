"""ROSCO's compiled controller (or any Bladed-style DISCON library) as a bench controller.

``[controller] kind = "rosco"`` runs :class:`RoscoController`: every control period the
sensor frame fills the swap array the way OpenFAST's ServoDyn fills it
(``Fill_avrSWAP``), the library is called once (:class:`controller.discon.DisconLibrary`)
and its collective pitch and generator torque demands are read back.

Swap array records written (Bladed numbering, 1-based; SI units)
-----------------------------------------------------------------
====  ==========================================================================
rec   value
====  ==========================================================================
1     status: 0 on the first call of an instance, 1 after (ServoDyn's ``SimStatus``)
2     simulated time of the frame [s]; 3: control period [s]
4     blade pitch, measured [rad] (also records 33, 34: collective, three blades)
5-9   below-rated pitch set-point ``PC_FinePit``, pitch range ``PC_MinPit``..
      ``PC_MaxPit`` [rad], pitch-rate range ``PC_MinRat``..``PC_MaxRat`` [rad/s] (from
      DISCON.IN, where ServoDyn takes its own input file); 10: 0 (position actuator)
11    previous pitch demand [rad]; 13: demanded power ``VS_RtPwr`` [W]
14    shaft power [W]: measured generator torque x measured generator speed (the bench
      has no shaft-power sensor; ROSCO 2.10 reads but does not use it)
15    electrical power, measured [W]
20    generator speed, measured [rad/s]; 21: rotor speed, measured [rad/s]
23    generator torque, measured [N m] (ServoDyn: its previous torque demand)
27    hub-height wind speed: the nacelle anemometer [m/s]
28    0: collective pitch; 35: 1 (generator contactor on); 61: 3 blades
49-51 string lengths (module :mod:`controller.discon`); 129: array length
53    tower-top fore-aft acceleration: the nacelle IMU [m/s^2] (ROSCO ``FA_Acc_TT``:
      tower damper, ``Fl_Mode`` = 1)
60    rotor azimuth [rad]: the measured rotor speed integrated over the control period
      (the bench has no azimuth sensor; only IPC uses it, which the collective command
      discards)
66    1001: start of the platform block (OpenFAST's extended interface)
83    nacelle nodding acceleration [rad/s^2] (ROSCO ``NacIMU_FA_RAcc``, ``Fl_Mode`` = 2):
      the backward difference of the platform pitch-rate gyro,
      :math:`(q_k - q_{k-1})/\\Delta t` (0 on the first call). ROSCO low-pass filters
      this and integrates it back to a rate, so the difference loses nothing: the
      integral of the differences is the filtered rate itself. The bench's gyro sees the
      platform's pitch rate; ServoDyn's IMU also sees the tower-top rotation.
1001  platform surge [m]; 1005: platform pitch [rad]; 1011: platform pitch rate [rad/s]
      (``Ext_Interface`` = 1; ROSCO 2.10 only logs them)
====  ==========================================================================

A channel whose ``valid_mask`` bit is cleared (dropout; a bottom-fixed plant's platform
channels) is held at its last valid value (0 before any) and the step reports
``estimator_degraded`` = 1 when a held value fed the library; the platform channels of a
bottom-fixed plant stay 0.

Records read back: 45 (collective pitch demand [rad]), 47 (generator torque demand [N m]),
35 (generator contactor: 0 means the torque demand is 0). A non-finite demand is a
:class:`controller.discon.DisconError`; the pitch demand is clamped to ``PC_MinPit``..
``PC_MaxPit`` and the torque to >= 0 (ROSCO already respects both).

Status: ROSCO's regime and wind-speed estimate
----------------------------------------------
ROSCO keeps both inside; it writes them to its debug files when DISCON.IN's
``LoggingLevel`` asks for them, and this core reads the newest line after every call:

* ``LoggingLevel`` >= 1, ``<root>.RO.dbg``: ``WE_Vw`` (the wind-speed estimate of
  ``WE_Mode``: 0 filtered anemometer, 1 I&I, 2 EKF) ->
  ``wind_speed_estimated_m_s`` with :data:`bus_schemas.messages.EST_WIND_SPEED`;
  ``GenSpeedF`` -> ``generator_speed_filtered_rad_s``; ``PC_MinPit`` for the rule below.
* ``LoggingLevel`` >= 2, ``<root>.RO.dbg2``: ROSCO's state machine ``VS_State`` ->
  ``regime`` (1 region 1.5 -> 1, 2 region 2 -> 2, 3 region 2.5 -> 3, 4/5/6 region 3
  -> 4, 7 TSR-tracking PI -> 2, 0 error state -> 0).
* ``LoggingLevel`` = 1: ``regime`` by ROSCO's own region-3 rule applied by the bench:
  4 when the previous pitch demand >= ``PC_MinPit`` (its current minimum pitch, from
  the .dbg) + ``PC_Switch``, else 2. ``LoggingLevel`` = 0: the same with DISCON.IN's
  ``PC_MinPit``; no wind estimate; ``generator_speed_filtered_rad_s`` is then the
  measured speed.

``pitch_integrator_rad`` is 0 and ``gain_schedule_factor`` 1 (not reported by ROSCO).

Start-up phase
--------------
ROSCO's first call (status 0) reads DISCON.IN and its Cp table: 60-230 ms on this machine,
several control periods. So on an instance's first frame the core fills the swap array and
lets that call run in a thread started with the instance (ctypes releases the GIL; the
thread runs under the normal scheduling policy), and answers the first
``ceil(STARTUP_HOLD_S / dt)`` frames (1 s) with the actuators where they are (the measured
pitch and torque; regime by ROSCO's region-3 rule from the DISCON.IN); the next frame joins
the thread (in real time long finished; in lock-step it may wait) and is ROSCO's second call
(status 1). The count is fixed, whatever the thread's duration, so lock-step and in-process
runs stay identical. ROSCO was initialised from the first frame and sees the time jump by
1 s to the second; its filters and integrators step with the period of record 3.

Trimmed start
-------------
A trimmed run (:mod:`hil.inprocess.trim`) hands the core its operating point (mean wind U,
rotor speed ω0, pitch θ0, the plant's generator torque T0 when known):
:meth:`RoscoController.trimmed_state` loads the instance and warms the library up on the
trimmed plant before cycle 0, so that its filters, wind-speed estimator, setpoint smoother
and PI integrators hold their steady values when the run starts. The first call (status 0,
made in the calling thread) and :data:`WARMUP_S` = 600 s of calls (status 1) at the
control period, on frames at sample times -600 s .. -dt: anemometer U, platform at rest,
blade pitch and generator torque the library's previous demands (ideal actuators, as
ServoDyn feeds back its torque demand), rotor speed and generator speed N ω of a rigid
rotor :math:`J\\dot\\omega = Q(\\omega, \\theta) - N T_g` started at ω0 (J =
``WE_Jtot``; :math:`Q = N T_0 + Q_{C_p}(\\omega, \\theta, U) - Q_{C_p}(\\omega_0, \\theta_0,
U)`, the DISCON.IN's own Cp table (``PerfFileName``, ``WE_BladeRadius``, ``WE_RhoAir``)
shifted to balance T0 at the trim, T0 that table's balance when the operating point has
none). Without a Cp table or those figures the rotor speed is held at ω0. Every channel
reads its instrument's constant bias on top
(:attr:`~controller.interface.OperatingPoint.measurement_offsets`), and the gyro's
difference (swap 83) goes on from the warm-up's last frame into the run: started afresh,
or from an unbiased warm-up, the run's first sample (the gyro's 1e-3 rad/s bias, or its
noise) stayed in ROSCO's integrated platform rate for its high pass's 100 s and pitched the
IEA 15 MW's blades by 0.3° at 8 m/s (a 10 cm surge transient). The warm-up is
not the run: nothing of it is published or recorded, the run's first frame is the
library's next call (status 1) and the start-up hold does not apply. It costs 24 000
library calls at 40 Hz (about 0.6 s idle). With 120 s of warm-up a slow state of the
library was still moving when the run started: on the NREL 5 MW OC3 spar the rotor crept
from 9.081 to 9.085 rpm over 800 s at 8 m/s and the blades by 0.01° at 11 m/s, and the
quiet start's surge std over the first 60 s was 1.4 and 4.6 mm; with 300 s 0.4 and
1.6 mm, with 600 s 0.04 and 0.25 mm. Without the warm-up the library's first call came on
cycle 0 and its torque demand (8.99 MN m at 5 m/s on the IEA 15 MW against the rotor's
2.75) moved the rotor 17.6 % in the first 60 s; with it 0.13 %
(``bench/trimmed_start.py --table``). ROSCO's debug files (``LoggingLevel`` >= 1) hold
the warm-up's lines too, at negative times.

Not a pure core
---------------
A DISCON library keeps its state in its own static memory, so the state this core hands
back is a handle (:class:`RoscoState`) on one loaded private copy of the library, not a
value: stepping it advances that library, and an old state cannot be stepped again.
:meth:`RoscoController.initial_state` loads a new copy each time (the controller node's
watchdog restart gets a fresh ROSCO, first call with status 0 from the current
measurement), so instances never share memory, in one process or several. The files of
instance ``n`` (``n`` = 1, 2, ...) are ``<output_dir>/rosco[-n].RO.dbg*``.

Output folder
-------------
The library's root name is ``<output_dir>/rosco.SrvD`` (ROSCO strips the extension, as
it does for ServoDyn's root name), so everything it writes goes to ``output_dir``: the
run's folder (the launcher passes it, to a controller process through
:data:`RUN_DIR_ENV`); without one, a new temporary folder, logged. The working directory
is never used and never changed.

This module never imports ``plant``.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib.metadata
import importlib.util
import logging
import math
import os
import tempfile
import threading
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import IO

from bus_schemas.messages import (
    EST_WIND_SPEED,
    VALID_GENERATOR_SPEED,
    VALID_NACELLE_ACC,
    VALID_PITCH,
    VALID_PLATFORM_PITCH,
    VALID_PLATFORM_PITCH_RATE,
    VALID_PLATFORM_SURGE,
    VALID_POWER,
    VALID_ROTOR_SPEED,
    VALID_TORQUE,
    VALID_WIND,
    SensorFrame,
)
from controller.discon import DisconError, DisconLibrary, DisconLoadError
from controller.estimators import cp_table_from_rosco_text
from controller.interface import (
    REGIME_REGION_1,
    REGIME_REGION_1_5,
    REGIME_REGION_2,
    REGIME_REGION_2_5,
    REGIME_REGION_3,
    ActuatorLimits,
    ControlOutput,
    OperatingPoint,
)

__all__ = [
    "RUN_DIR_ENV",
    "DisconParameters",
    "RoscoController",
    "RoscoSettings",
    "RoscoState",
    "default_library",
    "make_rosco_controller",
    "read_discon_in",
    "shipped_parameter_files",
]

#: Environment variable through which the launcher gives a controller process its run folder.
RUN_DIR_ENV = "FOWT_RUN_DIR"
_PRESET_PACKAGE = "controller.presets.rosco"
_log = logging.getLogger("fowt.rosco")
#: Root names in use by the instances of this process (see RoscoController.root_name).
_ROOT_NAMES: set[str] = set()
_NAMES_LOCK = threading.Lock()
#: Start-up phase [s]: how long the actuators are held while the first call runs.
STARTUP_HOLD_S = 1.0
#: A trimmed start's warm-up [s] of simulated time on the trimmed plant before cycle 0
#: (:meth:`RoscoController.trimmed_state`): the wind-speed EKF's mean-wind state and the
#: setpoint smoother settle in about 60 s from the first call, but a slower state of the
#: library still moved the rotor by 0.004 rpm over the next 800 s (module docstring).
WARMUP_S = 600.0

#: ROSCO ``VS_State`` -> bench regime code (module docstring).
VS_STATE_REGIME = {
    0: REGIME_REGION_1,
    1: REGIME_REGION_1_5,
    2: REGIME_REGION_2,
    3: REGIME_REGION_2_5,
    4: REGIME_REGION_3,
    5: REGIME_REGION_3,
    6: REGIME_REGION_3,
    7: REGIME_REGION_2,
}

# SensorFrame fields held while their valid bit is cleared, with their bits.
_HELD = (
    ("generator_speed_measured_rad_s", VALID_GENERATOR_SPEED),
    ("rotor_speed_measured_rad_s", VALID_ROTOR_SPEED),
    ("blade_pitch_measured_rad", VALID_PITCH),
    ("generator_torque_measured_nm", VALID_TORQUE),
    ("electrical_power_measured_w", VALID_POWER),
    ("wind_speed_measured_m_s", VALID_WIND),
    ("nacelle_acc_fore_aft_measured_m_s2", VALID_NACELLE_ACC),
    ("platform_pitch_measured_rad", VALID_PLATFORM_PITCH),
    ("platform_pitch_rate_measured_rad_s", VALID_PLATFORM_PITCH_RATE),
    ("platform_surge_measured_m", VALID_PLATFORM_SURGE),
)
# Channels the library needs on every plant (a missing one degrades the step).
_CORE_BITS = VALID_GENERATOR_SPEED | VALID_ROTOR_SPEED | VALID_PITCH | VALID_TORQUE
_CORE_BITS |= VALID_POWER | VALID_WIND
#: SensorFrame valid bits of a trimmed start's warm-up frames (every channel the library reads).
_WARMUP_MASK = (
    _CORE_BITS
    | VALID_NACELLE_ACC
    | VALID_PLATFORM_PITCH
    | VALID_PLATFORM_PITCH_RATE
    | VALID_PLATFORM_SURGE
)


# --------------------------------------------------------------------------- parameters
@dataclass(frozen=True)
class DisconParameters:
    """The DISCON.IN figures the bench itself needs (SI units, as in the file).

    Attributes
    ----------
    path : Path
        The parameter file.
    logging_level : int
        ``LoggingLevel`` (0: no debug files, 1: .dbg, 2: + .dbg2, 3: + .dbg3).
    we_mode : int
        ``WE_Mode`` (wind-speed estimator: 0 filtered anemometer, 1 I&I, 2 EKF).
    pc_min_pit_rad, pc_max_pit_rad : float
        ``PC_MinPit``, ``PC_MaxPit``: pitch range [rad].
    pc_min_rat_rad_s, pc_max_rat_rad_s : float
        ``PC_MinRat`` (negative), ``PC_MaxRat``: pitch-rate range [rad/s].
    pc_fine_pit_rad : float
        ``PC_FinePit``: below-rated pitch [rad].
    pc_switch_rad : float
        ``PC_Switch``: pitch above the minimum at which ROSCO's torque law is region 3 [rad].
    vs_max_rat_nm_s : float
        ``VS_MaxRat``: generator torque rate limit [N m/s].
    vs_rt_pwr_w : float
        ``VS_RtPwr``: rated electrical power [W].
    gearbox_ratio : float
        ``WE_GearboxRatio`` (generator over rotor speed; 1 when the file has none).
    generator_efficiency : float
        ``VS_GenEff`` as a fraction (the file's percent / 100; 1 when the file has none).
    blade_radius_m, air_density_kg_m3, drivetrain_inertia_kg_m2 : float
        ``WE_BladeRadius`` [m], ``WE_RhoAir`` [kg/m^3], ``WE_Jtot`` [kg m^2, low-speed
        shaft]; NaN when the file has none (a trimmed start's warm-up then holds the rotor
        speed instead of turning its rotor model).
    perf_file : Path or None
        ``PerfFileName`` resolved against the file's folder (None if ``WE_Mode`` = 0 and
        it is not given).
    """

    path: Path
    logging_level: int
    we_mode: int
    pc_min_pit_rad: float
    pc_max_pit_rad: float
    pc_min_rat_rad_s: float
    pc_max_rat_rad_s: float
    pc_fine_pit_rad: float
    pc_switch_rad: float
    vs_max_rat_nm_s: float
    vs_rt_pwr_w: float
    perf_file: Path | None
    gearbox_ratio: float = 1.0
    generator_efficiency: float = 1.0
    blade_radius_m: float = math.nan
    air_density_kg_m3: float = math.nan
    drivetrain_inertia_kg_m2: float = math.nan


def read_discon_in(path: str | Path) -> DisconParameters:
    """Read and check the DISCON.IN figures the bench needs.

    The file is ROSCO's layout: one parameter per line, ``value(s) ! Name - description``.
    The library reads the file again itself on its first call (and reports its own
    errors); this check catches a missing or malformed file before anything runs.

    Raises
    ------
    ValueError
        Naming the file and the parameter: file missing, parameter missing or not a number,
        pitch range empty, rate limits not positive, the performance table missing.
    """
    p = Path(path).expanduser().resolve()
    if not p.is_file():
        raise ValueError(f"ROSCO parameter file (DISCON.IN) not found: {p}")
    try:
        text = p.read_text(errors="replace")
    except OSError as exc:
        raise ValueError(f"ROSCO parameter file {p} cannot be read: {exc}") from exc
    values: dict[str, list[str]] = {}
    for line in text.splitlines():
        body, sep, rest = line.partition("!")
        if not sep or not body.strip() or not rest.split():
            continue
        values.setdefault(rest.split()[0], body.split())

    def number(key: str, kind: type = float) -> float:
        toks = values.get(key)
        if not toks:
            raise ValueError(f"DISCON.IN {p}: parameter {key!r} missing (expected a number)")
        try:
            v = float(toks[0]) if kind is float else int(toks[0])
        except ValueError:
            raise ValueError(
                f"DISCON.IN {p}: parameter {key!r} = {toks[0]!r} is not a"
                f"{'n integer' if kind is int else ' number'}"
            ) from None
        if not math.isfinite(v):
            raise ValueError(f"DISCON.IN {p}: parameter {key!r} = {toks[0]!r} is not finite")
        return v

    def optional(key: str, default: float) -> float:
        return number(key) if values.get(key) else default

    gearbox = optional("WE_GearboxRatio", 1.0)
    efficiency = optional("VS_GenEff", 100.0) / 100.0
    if not (gearbox > 0.0 and 0.0 < efficiency <= 1.0):
        raise ValueError(
            f"DISCON.IN {p}: expected WE_GearboxRatio > 0 and 0 < VS_GenEff <= 100 "
            f"(got {gearbox}, {efficiency * 100.0})"
        )
    we_mode = int(number("WE_Mode", int))
    pmin, pmax = number("PC_MinPit"), number("PC_MaxPit")
    if not pmin < pmax:
        raise ValueError(f"DISCON.IN {p}: PC_MinPit = {pmin} must be < PC_MaxPit = {pmax}")
    rmin, rmax, qrate = number("PC_MinRat"), number("PC_MaxRat"), number("VS_MaxRat")
    if not (rmax > 0 and rmin < 0 and qrate > 0):
        raise ValueError(
            f"DISCON.IN {p}: expected PC_MaxRat > 0, PC_MinRat < 0 and VS_MaxRat > 0 "
            f"(got {rmax}, {rmin}, {qrate})"
        )
    perf: Path | None = None
    toks = values.get("PerfFileName")
    if toks:
        name = " ".join(toks).strip().strip('"').strip("'")
        perf = Path(name) if Path(name).is_absolute() else p.parent / name
        if we_mode > 0 and not perf.is_file():
            raise ValueError(
                f"DISCON.IN {p}: PerfFileName {name!r} (the Cp table WE_Mode = {we_mode} "
                f"needs) not found at {perf}"
            )
    elif we_mode > 0:
        raise ValueError(f"DISCON.IN {p}: parameter 'PerfFileName' missing (WE_Mode = {we_mode})")
    return DisconParameters(
        path=p,
        logging_level=int(number("LoggingLevel", int)),
        we_mode=we_mode,
        pc_min_pit_rad=pmin,
        pc_max_pit_rad=pmax,
        pc_min_rat_rad_s=rmin,
        pc_max_rat_rad_s=rmax,
        pc_fine_pit_rad=number("PC_FinePit"),
        pc_switch_rad=number("PC_Switch"),
        vs_max_rat_nm_s=qrate,
        vs_rt_pwr_w=number("VS_RtPwr"),
        perf_file=perf,
        gearbox_ratio=gearbox,
        generator_efficiency=efficiency,
        blade_radius_m=optional("WE_BladeRadius", math.nan),
        air_density_kg_m3=optional("WE_RhoAir", math.nan),
        drivetrain_inertia_kg_m2=optional("WE_Jtot", math.nan),
    )


def shipped_parameter_files() -> dict[str, Path]:
    """The shipped DISCON.IN files by preset name (``controller/presets/rosco``)."""
    root = resources.files(_PRESET_PACKAGE)
    out = {}
    for entry in root.iterdir():
        if entry.name.endswith("_DISCON.IN"):
            out[entry.name.removesuffix("_DISCON.IN")] = Path(str(entry))
    return dict(sorted(out.items()))


def default_library() -> Path:
    """The ``libdiscon`` of the installed ``rosco`` package (PyPI wheel), found unimported.

    Raises
    ------
    DisconLoadError
        If the ``rosco`` package is not installed or ships no library; the message says how
        to install it (``pip install --no-deps 'rosco==2.10.*'``, which ``make setup`` runs).
    """
    hint = (
        "install ROSCO's compiled controller with `pip install --no-deps 'rosco==2.10.*'` "
        '(make setup does), or name a library with [controller] library = "path/to/'
        'libdiscon.so"'
    )
    # The installed distribution's files (a script named rosco.py on sys.path cannot hide it),
    # then the import system's view of a `rosco` package.
    roots: list[Path] = []
    with contextlib.suppress(importlib.metadata.PackageNotFoundError):
        roots.append(Path(str(importlib.metadata.distribution("rosco").locate_file("rosco"))))
    spec = importlib.util.find_spec("rosco")
    if spec is not None and spec.submodule_search_locations:
        roots.append(Path(next(iter(spec.submodule_search_locations))))
    if not roots:
        raise DisconLoadError(f"no ROSCO library: the `rosco` package is not installed; {hint}")
    for root in roots:
        for name in ("libdiscon.so", "libdiscon.dylib", "libdiscon.dll"):
            lib = root / "lib" / name
            if lib.is_file():
                return lib
    raise DisconLoadError(f"the `rosco` package at {roots[0]} has no lib/libdiscon; {hint}")


# --------------------------------------------------------------------------- settings
@dataclass(frozen=True)
class RoscoSettings:
    """What a :class:`RoscoController` runs.

    Attributes
    ----------
    library : Path
        The DISCON shared library.
    parameters : DisconParameters
        The checked parameter file (passed to the library as ``accINFILE``).
    output_dir : Path
        Where the library writes its files (module docstring).
    control_period_s : float
        The control period [s] a trimmed start's warm-up calls the library with
        (:meth:`RoscoController.trimmed_state`).
    """

    library: Path
    parameters: DisconParameters
    output_dir: Path
    control_period_s: float = 0.025


def make_rosco_controller(
    preset: str,
    *,
    library: str | None = None,
    parameter_file: str | None = None,
    output_dir: str | Path | None = None,
    control_period_s: float = 0.025,
) -> RoscoController:
    """Build the ROSCO core from a shipped preset or a parameter file.

    Parameters
    ----------
    preset : str
        A shipped DISCON.IN (:func:`shipped_parameter_files`: ``"nrel5mw"``,
        ``"iea15mw_volturnus"``), used when ``parameter_file`` is None.
    library : str or None
        DISCON library path (None: :func:`default_library`).
    parameter_file : str or None
        A DISCON.IN path (its Cp table resolved against its own folder, as ROSCO does).
    output_dir : str, Path or None
        The run's folder (None: ``$FOWT_RUN_DIR``, else a new temporary folder).
    control_period_s : float
        The run's control period [s] (a trimmed start's warm-up steps with it).

    Raises
    ------
    ValueError
        Unknown preset, malformed parameter file (:func:`read_discon_in`), or the library
        missing or unusable (:class:`controller.discon.DisconLoadError`, a ValueError).
    """
    if parameter_file is None:
        shipped = shipped_parameter_files()
        if preset not in shipped:
            raise ValueError(
                f"controller.kind = 'rosco': preset {preset!r} is not a shipped DISCON.IN "
                f"({', '.join(shipped)}); give one of them or [controller] parameter_file"
            )
        params = read_discon_in(shipped[preset])
    else:
        params = read_discon_in(parameter_file)
    lib = default_library() if library is None else Path(library).expanduser().resolve()
    if not lib.is_file():
        raise DisconLoadError(f"DISCON library not found: {lib}", library=str(lib))
    if output_dir is None:
        env = os.environ.get(RUN_DIR_ENV)
        if env:
            out = Path(env)
        else:
            out = Path(tempfile.mkdtemp(prefix="fowt-rosco-"))
            _log.warning("ROSCO's files go to %s (no run folder given)", out)
    else:
        out = Path(output_dir)
    out = out.expanduser().resolve()
    out.mkdir(parents=True, exist_ok=True)
    if not 0.0 < control_period_s < math.inf:
        raise ValueError(f"control_period_s must be finite and > 0 s, got {control_period_s!r}")
    return RoscoController(RoscoSettings(lib, params, out, control_period_s))


# --------------------------------------------------------------------------- debug files
class _DebugTail:
    """The newest data line of one of ROSCO's debug files, by column name."""

    def __init__(self, path: Path, wanted: tuple[str, ...]) -> None:
        self.path = path
        self.wanted = wanted
        self.fh: IO[str] | None = None
        self.index: dict[str, int] = {}
        self.values: dict[str, float] = {}
        self._partial = ""

    def _open(self) -> bool:
        if not self.path.is_file():
            return False
        fh = self.path.open("r", errors="replace")
        header = [fh.readline() for _ in range(3)]
        if not all(h.endswith("\n") for h in header):
            fh.close()
            return False
        names = header[1].split()
        self.index = {n: names.index(n) for n in self.wanted if n in names}
        self.fh = fh
        return True

    def poll(self) -> bool:
        """Read what ROSCO appended; True when a new complete line was parsed."""
        if self.fh is None and not self._open():
            return False
        assert self.fh is not None
        chunk = self.fh.read()
        if not chunk:
            return False
        data = self._partial + chunk
        end = data.rfind("\n")
        if end < 0:
            self._partial = data
            return False
        self._partial = data[end + 1 :]
        start = data.rfind("\n", 0, end) + 1
        line = data[start:end]
        try:  # ROSCO's fixed layout: column i at [25 i, 25 i + 20) (F20.5 / ES20.5, TR5)
            self.values = {n: float(line[25 * i : 25 * i + 20]) for n, i in self.index.items()}
        except ValueError:
            toks = line.split()  # another layout: whitespace-separated columns
            try:
                self.values = {n: float(toks[i]) for n, i in self.index.items()}
            except (IndexError, ValueError):
                return False
        return True

    def close(self) -> None:
        if self.fh is not None:
            self.fh.close()
            self.fh = None


# --------------------------------------------------------------------------- the core
@dataclass(eq=False)
class RoscoState:
    """Handle on one running library instance (mutable; see the module docstring).

    Attributes
    ----------
    library : DisconLibrary
        The loaded private copy.
    instance : int
        1 for the first instance of a controller, 2 after one restart, ...
    held : dict
        Last valid value of each held SensorFrame field.
    azimuth_rad : float
        Integrated rotor azimuth [rad].
    last_pitch_rate_rad_s : float or None
        Previous platform pitch-rate reading (for record 83).
    last_pitch_command_rad : float or None
        Previous pitch demand [rad].
    warnings : Counter
        Library warnings (``aviFAIL`` > 0) by message.
    """

    library: DisconLibrary
    instance: int
    held: dict[str, float] = field(default_factory=dict)
    azimuth_rad: float = 0.0
    last_pitch_rate_rad_s: float | None = None
    last_pitch_command_rad: float | None = None
    warnings: Counter[str] = field(default_factory=Counter)
    dbg: _DebugTail | None = None
    dbg2: _DebugTail | None = None
    init_thread: threading.Thread | None = None
    init_go: threading.Event = field(default_factory=threading.Event)
    init_started: bool = False
    init_result: tuple[int, str] | None = None
    held_frames: int = 0
    init_checked: bool = False
    degraded: bool = False

    def close(self) -> None:
        """Final call (status -1, as ServoDyn's last call) and close the debug files."""
        if self.init_thread is not None:
            if not self.init_started:  # never stepped: let the waiting thread end
                self.init_result = (0, "")
                self.init_go.set()
            self.init_thread.join()
        if self.library.calls > 0:
            self.library.swap[0] = -1.0
            self.library.call()
        for tail in (self.dbg, self.dbg2):
            if tail is not None:
                tail.close()


class RoscoController:
    """A DISCON library as a bench controller: ``step(state, frame, dt) -> (state, output)``.

    Parameters
    ----------
    settings : RoscoSettings
        Library, parameter file and output folder.
    """

    def __init__(self, settings: RoscoSettings) -> None:
        self.settings = settings
        self.params = settings.parameters
        self._instances = 0

    def actuator_limits(self) -> ActuatorLimits:
        """Pitch range and rate limits of the parameter file (the node's safe command)."""
        p = self.params
        return ActuatorLimits(
            p.pc_min_pit_rad,
            p.pc_max_pit_rad,
            min(p.pc_max_rat_rad_s, -p.pc_min_rat_rad_s),
            p.vs_max_rat_nm_s,
        )

    def root_name(self, instance: int) -> Path:
        """``avcOUTNAME`` of instance ``instance`` (its files: ``<stem>.RO.dbg`` ...).

        ``rosco.SrvD`` for the first, ``rosco-<n>.SrvD`` after; a name another instance of
        this process already holds (two controllers writing to one folder) takes the next
        free number, since libgfortran stops the whole process when two units open one file.
        """
        n = instance
        while True:
            stem = "rosco" if n == 1 else f"rosco-{n}"
            path = self.settings.output_dir / f"{stem}.SrvD"
            with _NAMES_LOCK:
                if str(path) not in _ROOT_NAMES:
                    _ROOT_NAMES.add(str(path))
                    return path
            n += 1

    def initial_state(self) -> RoscoState:
        """Load a fresh private copy of the library (its first call comes with the next step).

        Raises
        ------
        controller.discon.DisconLoadError
            If the library cannot be loaded or has no ``DISCON``.
        """
        self._instances += 1
        n = self._instances
        root = self.root_name(n)
        lib = DisconLibrary(self.settings.library, self.params.path, root)
        state = RoscoState(library=lib, instance=n)
        state.init_thread = threading.Thread(
            target=self._first_call, args=(state,), name=f"rosco-first-call-{n}", daemon=True
        )
        state.init_thread.start()
        stem = root.with_suffix("")
        if self.params.logging_level >= 1:
            state.dbg = _DebugTail(
                stem.with_name(stem.name + ".RO.dbg"), ("WE_Vw", "GenSpeedF", "PC_MinPit")
            )
        if self.params.logging_level >= 2:
            state.dbg2 = _DebugTail(stem.with_name(stem.name + ".RO.dbg2"), ("VS_State",))
        return state

    def _rotor_model(self) -> Callable[[float, float, float], float] | None:
        """The aerodynamic torque ``Q(ω rad/s, θ rad, v m/s)`` [N m, low-speed shaft] of the
        parameter file's Cp table (``PerfFileName``, ``WE_BladeRadius``, ``WE_RhoAir``), or
        None when the file lacks one of them."""
        p = self.params
        figures = (p.blade_radius_m, p.air_density_kg_m3, p.drivetrain_inertia_kg_m2)
        if p.perf_file is None or not all(math.isfinite(v) and v > 0.0 for v in figures):
            return None
        try:
            table = cp_table_from_rosco_text(p.perf_file.read_text(errors="replace"))
        except (OSError, ValueError):
            return None
        r, rho = p.blade_radius_m, p.air_density_kg_m3

        def torque(omega: float, pitch: float, wind: float) -> float:
            if omega <= 0.0 or wind <= 0.0:
                return 0.0
            cp = table.lookup(omega * r / wind, pitch)[0]
            return 0.5 * rho * math.pi * r * r * wind**3 * cp / omega

        return torque

    def trimmed_state(self, operating_point: OperatingPoint) -> RoscoState:
        """A fresh instance warmed up on the trimmed plant (module docstring, "Trimmed start").

        The library's first call (status 0) and :data:`WARMUP_S` of calls (status 1) at the
        control period on frames at sample times -WARMUP_S .. -dt [s] of a rotor started at
        the operating point (module docstring). None of it is a run's cycle: the run's
        first frame is the library's next call (status 1), without the start-up hold.

        Raises
        ------
        controller.discon.DisconError
            When the library fails (``aviFAIL`` < 0) or gives a non-finite demand.
        """
        p = self.params
        dt = self.settings.control_period_s
        n = p.gearbox_ratio
        wind = operating_point.wind_m_s
        omega0 = omega = operating_point.rotor_speed_rad_s
        theta0 = pitch = min(
            max(operating_point.blade_pitch_rad, p.pc_min_pit_rad), p.pc_max_pit_rad
        )
        aero = self._rotor_model()
        q0 = 0.0 if aero is None else aero(omega0, theta0, wind)
        given = operating_point.generator_torque_nm
        # without the plant's torque: the one that balances the model's aerodynamic torque
        torque: float = q0 / n if given is None else given
        q_trim = n * torque  # the model's torque offset to the trim point: Q(ω0, θ0) = N T
        n_calls = max(1, math.ceil(WARMUP_S / dt - 1e-9))
        offsets = dict(operating_point.measurement_offsets)  # looked up once per channel

        def off(field: str) -> float:
            return offsets.get(field, 0.0)

        period_ns = round(dt * 1e9)
        state = self.initial_state()

        def frame(k: int) -> SensorFrame:
            return SensorFrame(
                seq=k,
                sample_time_ns=(k - n_calls) * period_ns,
                publish_time_ns=0,
                valid_mask=_WARMUP_MASK,
                generator_speed_measured_rad_s=omega * n + off("generator_speed_measured_rad_s"),
                rotor_speed_measured_rad_s=omega + off("rotor_speed_measured_rad_s"),
                blade_pitch_measured_rad=pitch + off("blade_pitch_measured_rad"),
                generator_torque_measured_nm=torque + off("generator_torque_measured_nm"),
                electrical_power_measured_w=torque * omega * n * p.generator_efficiency
                + off("electrical_power_measured_w"),
                wind_speed_measured_m_s=wind + off("wind_speed_measured_m_s"),
                nacelle_acc_fore_aft_measured_m_s2=off("nacelle_acc_fore_aft_measured_m_s2"),
                platform_pitch_measured_rad=off("platform_pitch_measured_rad"),
                platform_pitch_rate_measured_rad_s=off("platform_pitch_rate_measured_rad_s"),
                platform_surge_measured_m=off("platform_surge_measured_m"),
                wave_elevation_gauge_measured_m=off("wave_elevation_gauge_measured_m"),
            )

        first = frame(0)
        try:
            self._fill(state, first, dt, first=True)
            state.init_started = True
            state.init_go.set()
            assert state.init_thread is not None
            state.init_thread.join()
            state.init_checked = True
            assert state.init_result is not None
            self._check(state, *state.init_result, first)
            # the library is initialised: the run needs no start-up hold
            state.held_frames = max(1, math.ceil(STARTUP_HOLD_S / dt - 1e-9))
            sw = state.library.swap
            for k in range(1, n_calls):
                f = frame(k)
                self._fill(state, f, dt, first=False)
                status, msg = state.library.call()
                self._check(state, status, msg, f)
                pitch_cmd = float(sw[44])
                torque_cmd = float(sw[46]) if sw[34] != 0.0 else 0.0
                if not (math.isfinite(pitch_cmd) and math.isfinite(torque_cmd)):
                    raise DisconError(
                        f"DISCON library {state.library.path} returned a non-finite demand "
                        f"in the trimmed start's warm-up (pitch {pitch_cmd}, torque "
                        f"{torque_cmd})",
                        library=str(state.library.path),
                    )
                pitch_cmd = min(max(pitch_cmd, p.pc_min_pit_rad), p.pc_max_pit_rad)
                torque_cmd = max(torque_cmd, 0.0)
                state.last_pitch_command_rad = pitch_cmd
                if aero is not None:  # the rotor: J dω/dt = Q(ω, θ) - N T_g
                    q = q_trim + aero(omega, pitch, wind) - q0
                    omega = max(omega + dt * (q - n * torque_cmd) / p.drivetrain_inertia_kg_m2, 0.0)
                pitch, torque = pitch_cmd, torque_cmd  # ideal actuators
        except BaseException:
            state.close()
            raise
        # the run's frames start the rotor azimuth afresh; the gyro difference goes on from
        # the warm-up's biased reading (restarted, the run's first sample's noise stayed in
        # ROSCO's integrated rate: a 0.3° pitch offset for the high pass's 100 s)
        state.azimuth_rad = 0.0
        return state

    def _held(self, state: RoscoState, frame: SensorFrame) -> tuple[list[float], bool]:
        """The frame's values with invalid ones replaced by their last valid value."""
        mask = frame.valid_mask
        held = state.held
        out: list[float] = []
        for name, bit in _HELD:
            if mask & bit:
                v = getattr(frame, name)
                held[name] = v
            else:
                v = held.get(name, 0.0)
            out.append(v)
        return out, (mask & _CORE_BITS) != _CORE_BITS

    def _fill(
        self, state: RoscoState, frame: SensorFrame, dt_s: float, *, first: bool
    ) -> ctypes.Array[ctypes.c_float]:
        """Write the frame into the swap array (module docstring's table); return it."""
        p = self.params
        sw = state.library.swap
        (gen, rot, pitch, torque, power, wind, acc, ptfm_pitch, ptfm_rate, surge), degraded = (
            self._held(state, frame)
        )
        state.degraded = degraded
        sw[0] = 0.0 if first else 1.0
        sw[1] = frame.sample_time_ns * 1e-9
        sw[2] = dt_s
        sw[3] = sw[32] = sw[33] = pitch
        sw[4] = p.pc_fine_pit_rad
        sw[5] = p.pc_min_pit_rad
        sw[6] = p.pc_max_pit_rad
        sw[7] = p.pc_min_rat_rad_s
        sw[8] = p.pc_max_rat_rad_s
        sw[9] = 0.0
        last_cmd = state.last_pitch_command_rad
        sw[10] = pitch if last_cmd is None else last_cmd
        sw[12] = p.vs_rt_pwr_w
        sw[13] = torque * gen
        sw[14] = power
        sw[19] = gen
        sw[20] = rot
        sw[22] = torque
        sw[26] = wind
        if first:
            sw[34] = 1.0
        sw[52] = acc
        state.azimuth_rad = (state.azimuth_rad + rot * dt_s) % (2.0 * math.pi)
        sw[59] = state.azimuth_rad
        sw[60] = 3.0
        sw[65] = 1001.0
        prev_rate = state.last_pitch_rate_rad_s
        sw[82] = 0.0 if prev_rate is None or dt_s <= 0 else (ptfm_rate - prev_rate) / dt_s
        state.last_pitch_rate_rad_s = ptfm_rate
        sw[1000] = surge
        sw[1004] = ptfm_pitch
        sw[1010] = ptfm_rate
        return sw

    @staticmethod
    def _first_call(state: RoscoState) -> None:
        """The start-up thread: wait for the first frame, then make the first call (status 0).

        Started with the instance, before any frame, so the first frame only sets an event
        (no thread start and no wait on the control path). A controller process under
        ``SCHED_FIFO`` (``--realtime-priority``) passes its policy to this thread; the thread
        drops to the normal policy (Linux applies ``sched_setscheduler(0, ...)`` to the
        calling thread only), so its 0.1-0.5 s of parsing neither competes with the control
        loop at real-time priority nor uses up the real-time CPU budget
        (``sched_rt_runtime_us``) that the loop's threads share.
        """
        with contextlib.suppress(AttributeError, OSError):
            if os.sched_getscheduler(0) in (os.SCHED_FIFO, os.SCHED_RR):
                os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        state.init_go.wait()
        if state.init_result is None:  # None unless closed before the first frame
            state.init_result = state.library.call()

    def _check(self, state: RoscoState, status: int, msg: str, frame: SensorFrame) -> None:
        """Raise on ``aviFAIL`` < 0; log each distinct warning (``aviFAIL`` > 0) once."""
        t = frame.sample_time_ns * 1e-9
        if status < 0:
            raise DisconError(
                f"DISCON library {state.library.path} failed at t = {t:.3f} s "
                f"(aviFAIL = {status}): {msg or '(no message)'}",
                library=str(state.library.path),
                status=status,
                msg=msg,
            )
        if status > 0:
            state.warnings[msg] += 1
            if state.warnings[msg] == 1:
                _log.warning("DISCON warning at t = %.3f s (aviFAIL = %d): %s", t, status, msg)

    def _hold(self, state: RoscoState, frame: SensorFrame) -> ControlOutput:
        """Start-up command: the actuators where they are (measured, held when invalid)."""
        p = self.params
        values, degraded = self._held(state, frame)
        pitch = min(max(values[2], p.pc_min_pit_rad), p.pc_max_pit_rad)
        torque = max(values[3], 0.0)
        state.last_pitch_command_rad = pitch
        regime = REGIME_REGION_3 if pitch >= p.pc_min_pit_rad + p.pc_switch_rad else REGIME_REGION_2
        return ControlOutput(
            blade_pitch_commanded_rad=pitch,
            generator_torque_commanded_nm=torque,
            regime=regime,
            generator_speed_filtered_rad_s=values[0],
            pitch_integrator_rad=0.0,
            gain_schedule_factor=1.0,
            estimator_degraded=int(degraded),
        )

    def step(
        self, state: RoscoState, measurement: SensorFrame, dt_s: float
    ) -> tuple[RoscoState, ControlOutput]:
        """Fill the swap array, call the library once, read the demands back.

        Raises
        ------
        controller.discon.DisconError
            When the library returns ``aviFAIL`` < 0 (with its message) or a non-finite
            demand.
        """
        p = self.params
        lib = state.library
        if not state.init_started:  # first frame: the start-up thread makes the first call
            self._fill(state, measurement, dt_s, first=True)
            state.init_started = True
            state.init_go.set()
        if state.held_frames < max(1, math.ceil(STARTUP_HOLD_S / dt_s - 1e-9)):
            state.held_frames += 1  # a fixed count, whenever the thread ends: deterministic
            return state, self._hold(state, measurement)
        if not state.init_checked:
            assert state.init_thread is not None
            state.init_thread.join()  # due now (in real time, usually long done)
            state.init_checked = True
            assert state.init_result is not None
            self._check(state, *state.init_result, measurement)
        sw = self._fill(state, measurement, dt_s, first=False)
        last_cmd = state.last_pitch_command_rad
        pitch = sw[3]
        t = measurement.sample_time_ns * 1e-9
        status, msg = lib.call()
        self._check(state, status, msg, measurement)
        pitch_cmd = float(sw[44])
        torque_cmd = float(sw[46]) if sw[34] != 0.0 else 0.0
        if not (math.isfinite(pitch_cmd) and math.isfinite(torque_cmd)):
            raise DisconError(
                f"DISCON library {lib.path} returned a non-finite demand at t = {t:.3f} s "
                f"(pitch {pitch_cmd}, torque {torque_cmd})",
                library=str(lib.path),
            )
        pitch_cmd = min(max(pitch_cmd, p.pc_min_pit_rad), p.pc_max_pit_rad)
        torque_cmd = max(torque_cmd, 0.0)
        # ROSCO's internals from its debug files (module docstring).
        est_mask = 0
        wind_est = 0.0
        gen = float(sw[19])
        gen_f = gen
        min_pitch = p.pc_min_pit_rad
        if state.dbg is not None and state.dbg.poll():
            v = state.dbg.values
            we = v.get("WE_Vw", math.nan)
            if math.isfinite(we) and abs(we) <= 80.0:  # the status field's range
                wind_est = we
                est_mask |= EST_WIND_SPEED
            gen_f = v.get("GenSpeedF", gen)
            if not (math.isfinite(gen_f) and -50.0 <= gen_f <= 500.0):
                gen_f = gen
            min_pitch = v.get("PC_MinPit", min_pitch)
        regime = -1
        if state.dbg2 is not None and state.dbg2.poll() and "VS_State" in state.dbg2.values:
            regime = VS_STATE_REGIME.get(round(state.dbg2.values["VS_State"]), REGIME_REGION_1)
        if regime < 0:
            ref = pitch if last_cmd is None else last_cmd
            regime = REGIME_REGION_3 if ref >= min_pitch + p.pc_switch_rad else REGIME_REGION_2
        state.last_pitch_command_rad = pitch_cmd
        return state, ControlOutput(
            blade_pitch_commanded_rad=pitch_cmd,
            generator_torque_commanded_nm=torque_cmd,
            regime=regime,
            generator_speed_filtered_rad_s=gen_f,
            pitch_integrator_rad=0.0,
            gain_schedule_factor=1.0,
            estimates_valid_mask=est_mask,
            estimator_degraded=int(state.degraded),
            wind_speed_estimated_m_s=wind_est,
        )
