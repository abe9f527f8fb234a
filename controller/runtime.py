"""The advanced controller's pure cycle: observers, wave forecast, regime logic, LQRI (+ FF).

:class:`AdvancedController` is a pure core with the bench's convention,
``initial_state()`` and ``step(state, frame, dt_s) -> (state, ControlOutput)``: it holds no
clock and does no I/O; the node measures the cycle's compute time. It loads only files
(its preset TOML, a ROSCO-format Cp table, the design artefacts) and never imports ``plant``.
The LQRI gains and wave-FF filters are discrete, so their artefacts are per control period
(``<design>_lqri_dt0p025.npz``, shipped for 0.025 s and 0.01 s); for another period the
launcher designs them into the user cache first (``hil.launch.ensure_designs``), and
:func:`missing_designs` tells which are absent. The observer artefact holds continuous
models, discretised here at the control period.

One cycle, from one validated :class:`bus_schemas.messages.SensorFrame`:

1. **Measurements** from the frame and its ``valid_mask``: rotor speed
   :math:`\\omega = \\omega_g / N` [rad/s], measured pitch :math:`\\theta` [rad] and torque
   :math:`T_g` [N m] (an invalid pitch or torque is replaced by the last command).
2. **Wind EKF** (:class:`controller.estimators.WindSpeedEKF`): predict with the measured
   :math:`(\\theta, T_g)`, update with :math:`\\omega` when its bit is set; gives
   :math:`\\hat U = u_m + u_t` [m/s] and the filtered :math:`\\hat\\omega`.
3. **Platform KF** (:class:`controller.estimators.PlatformKF`) of the design nearest to the
   mean-wind estimate :math:`u_m` (switching re-expresses the estimate about the new operating
   point, :math:`\\hat x_j = \\hat x_i + x_{op,i} - x_{op,j}`, covariance kept): inputs
   :math:`(\\hat\\omega - \\omega_{op}, \\theta - \\theta_{op})`, measurements IMU
   acceleration, gyro, attitude and GNSS surge minus their operating values. A channel whose
   bit is cleared, or whose value repeats the previous frame exactly (a sample-and-hold
   sensor slower than the control period), is not used this cycle.
   **Estimator guard.** The EKF's update is skipped when the innovation
   :math:`y = \\omega - \\hat\\omega^-` has :math:`y^2 > k^2 s` (:math:`s = P_{\\omega\\omega}
   + r`; the first valid sample is taken ungated, and an EKF started without one has a
   10 % rotor-speed standard deviation, :data:`UNMEASURED_SPEED_STD`), and the estimate
   is bounded to the EKF's range; a step is *bad* when the update was gated, the estimate
   left the physical range or the state is not finite. The figures are the below-rated
   baseline preset's (``wind_estimator_gate_sigma`` k = 5, ``wind_estimate_min_m_s`` /
   ``_max_m_s`` 1 and 37.5, ``wind_estimator_fault_s`` 5 s, ``wind_estimator_recover_s``
   10 s). ``wind_estimator_fault_s`` of bad steps, or a non-finite EKF, is a divergence; so
   is the platform KF (step 3) rejecting every valid channel at its gate for as long, or a
   non-finite KF. A divergence counts one estimator fault (``estimator_faults``, once per
   fallback; ``ControllerStatus`` v3, the run's outcome ``controller_fault``), restarts the
   EKF at the measured rotor speed and the last good mean wind with its initial covariance
   (a KF divergence restarts the KF at its design's operating point with its process
   covariance) and starts the **fallback: the below-rated baseline's law** (step 5, the
   measured generator speed only: its torque law and its pitch PI, which track the applied
   commands, so the hand-over is bumpless) is the command, ``estimator_degraded`` is 1;
   ``wind_estimator_recover_s`` without a bad step ends it, and the LQRI restarts
   bumplessly from the applied command.
4. **Wave forecast** (:func:`controller.forecast.make_forecaster`): called every
   :math:`T_f` = ``forecast.sample_period_s`` [s] with the gauge sample and its valid bit; the
   predictor's horizon is :math:`t_d + d_g` (the gauge's transport delay :math:`d_g` added) so
   that the forecast made at frame time :math:`t_c` is
   :math:`\\hat\\eta_0(t_c + t_d)`; it is held, with its target time :math:`t_c + t_d` [ns],
   until the next call.
5. **Below-rated laws**: the baseline controller of the preset's ``below_rated_baseline``
   (:class:`controller.baseline.BaselineController`, the IEA 15 MW DISCON figures) runs
   every cycle on the measured generator speed (the EKF's estimate when the sample is
   invalid). Its torque law (region 1 below cut-in, region 1.5 up to
   :math:`\\omega_2`, :math:`K\\omega^2` in region 2, the
   torque PI of region 2.5, constant torque in region 3 when the pitch is at or above
   ``VS_Rgn3MP``) is the advanced controller's torque law in every regime; below rated its
   pitch PI (at fine pitch, with its clamped integrator) gives the pitch. Its state tracks the
   applied commands (previous pitch, and previous torque less its feedforward part; while
   the LQRI acts, its pitch integrator is set so that its output equals the applied pitch),
   so its rate limits, its region-3 criterion and its integrators never wind up against
   commands it did not make.
6. **Regime logic and LQRI** (:class:`controller.lqri.LqriController`) on
   :math:`(u_m, \\hat\\omega, \\theta, \\hat x)`, plus the wave feedforward when the
   controller kind is ``"lqri_ff"``. The gains are scheduled (and the regime switched) on the
   EKF's *mean*-wind state :math:`u_m`, the filtered wind of disannio-2022 sect. 4.8, not on
   :math:`\\hat U = u_m + u_t`: scheduling on the turbulent estimate moves the operating
   pitch :math:`\\theta_{op}(U)` with every gust and doubled the rotor-speed standard
   deviation in the 15 m/s comparison (0.080 against 0.043 rad/s, 200 s). The published
   wind estimate is :math:`\\hat U`. The wave-FF filters of all design winds run on the
   same forecast and their outputs are blended in :math:`u_m` (:mod:`controller.lqri`), so a
   change of design never restarts a filter.

What the wave feedforward can do on this plant (al-2019 load cases 1 and 2, 600 s, same
seeds, statistics from 210 s, where the forecast is valid): it removes 37 % (LC1) and 20 %
(LC2) of the rotor-speed variance in the wave band :math:`f_{we}` = 0.05-0.333 Hz, i.e. 41 %
and 22 % of the *wave-induced* part (band variance with waves minus still water; al-2019:
41 %, 22 % of the total). The total variance changes by -0.04 % and -0.07 % only, because
on the IEA 15 MW (J = 3.1e8 kg m^2) the wave-induced rotor-speed variance is about 0.1 %
(LC1) and 0.3 % (LC2) of the total; the rest is turbulence below 0.05 Hz, which the FF
does not see (al-2019 Tab. 5-2, TripleSpar 10 MW: about 30 %, Weibull-averaged).

Bounded work per cycle (p = 4 KF channels, n = 6 KF states, m = 22 FF filters of 25
states): the EKF a few dozen floating-point operations; the KF a predict and a gated
update on 6x6 arrays with one at most 4x4 inverse; the LQRI an 8-term feedback; the FF one
(m, 25, 25) bank product. Steps 1-3, 5 and 6 are one compiled call
(:func:`controller._kernels.advanced_cycle`, numba, cached on disk), which calls the same
kernels as the classes above in the same order, so it computes what they compute to the
last bit (``tests/test_controller_fused.py`` runs both cycle by cycle). Why one call: with
a call per class the cycle cost ~38 us CPU on the LC2 replay, of which the arithmetic was a
few microseconds and the rest Python glue (NamedTuples and structs built and replaced, the
schedule look-up, the arguments and results of six calls); fused, ~9 us
(``bench/controller_compute.py``). The constants are packed once into one vector at
construction, and the state is two flat vectors (:class:`AdvancedState`) that each cycle
replaces. The forecaster (step 4, every ``sample_period_s``, not every cycle) stays in
Python: one ring-buffer write and one fixed-length dot product per call (AR/ESPRIT retrain
on a fixed window); nothing grows with time.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Literal, NamedTuple

import msgspec
import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from bus_schemas.messages import (
    EST_FEEDFORWARD,
    EST_PLATFORM_PITCH,
    EST_PLATFORM_PITCH_RATE,
    EST_PLATFORM_SURGE,
    EST_PLATFORM_SURGE_VELOCITY,
    EST_TOWER_TOP_VELOCITY,
    EST_WAVE_FORECAST,
    EST_WIND_SPEED,
    VALID_GENERATOR_SPEED,
    VALID_NACELLE_ACC,
    VALID_PITCH,
    VALID_PLATFORM_PITCH,
    VALID_PLATFORM_PITCH_RATE,
    VALID_PLATFORM_SURGE,
    VALID_TORQUE,
    VALID_WAVE_GAUGE,
    SensorFrame,
)
from controller import _kernels
from controller.baseline import BaselineController, load_baseline
from controller.estimators import (
    PlatformKF,
    PlatformKFConfig,
    PlatformKFState,
    WindEKFConfig,
    WindEKFMeasurement,
    WindEKFState,
    WindSpeedEKF,
    cp_table_from_rosco_text,
    encoder_rotor_speed_std,
)
from controller.forecast import (
    ArConfig,
    DispersionConfig,
    DispersionPredictor,
    EspritConfig,
    ForecasterState,
    make_forecaster,
)
from controller.interface import ActuatorLimits, ControlOutput, OperatingPoint
from controller.lqri import (
    DesignNotFoundError,
    LqriController,
    LqriMeasurement,
    find_design,
    load_design_artefact,
    load_lqri_design,
    load_wave_ff_design,
)

__all__ = [
    "AdvancedController",
    "AdvancedSettings",
    "AdvancedState",
    "ObserverDesign",
    "discretize",
    "forecast_fill_time_s",
    "load_advanced_settings",
    "load_observer_design",
    "missing_designs",
    "required_designs",
]

#: Relative standard deviation of the wind EKF's rotor speed when it starts without a valid
#: speed sample (at the design's rated speed): the first sample then moves it to the measured
#: speed instead of being gated as a 5-sigma outlier of an over-confident guess.
UNMEASURED_SPEED_STD = 0.1

FloatArray = npt.NDArray[np.float64]
ForecasterName = Literal["dispersion", "ar", "esprit"]
FeedforwardName = Literal["off", "balanced", "max_performance"]

#: Estimates every advanced-controller status holds.
_EST_ALWAYS = (
    EST_WIND_SPEED
    | EST_PLATFORM_PITCH
    | EST_PLATFORM_PITCH_RATE
    | EST_PLATFORM_SURGE
    | EST_PLATFORM_SURGE_VELOCITY
    | EST_TOWER_TOP_VELOCITY
)

_PRESET_PACKAGE = "controller.presets"
_DESIGN_PACKAGE = "controller.presets.designs"


# ------------------------------------------------------------------------------ settings
class EkfSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[ekf]`` of the preset (see :class:`controller.estimators.WindEKFConfig`)."""

    turbulence_intensity: float = 0.15
    turbulence_length_m: float = 340.2
    rotor_speed_process_psd: float = 1e-5
    generator_speed_noise_std_rad_s: float = 0.002
    generator_speed_resolution_rad_s: float = 0.001


class ForecastSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[forecast]`` of the preset: forecaster kind, horizon t_d (s), gauge figures."""

    kind: ForecasterName = "dispersion"
    horizon_s: float = 10.0
    sample_period_s: float = 0.2
    gauge_delay_s: float = 0.1
    gauge_distance_m: float = 450.0
    water_depth_m: float = 200.0
    n_taps: int = 1024


class AdvancedSettings(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The advanced controller's preset (``controller/presets/<name>.toml``), SI units.

    Attributes
    ----------
    cp_table_file : str
        ROSCO-format Cp table, relative to the preset file.
    rotor_radius_m, drivetrain_inertia_kg_m2, gearbox_ratio, air_density_kg_m3 : float
        Turbine figures of the EKF: R [m], J about the LSS [kg m^2], N [-], ρ [kg/m^3].
    lqri_design, observer_design : str
        Design names (the stem of the plant preset they were designed for; the LQRI and
        wave-FF artefacts of the control period in use are looked up with
        :func:`controller.lqri.find_design`), or paths to the ``.npz``.
    feedforward : {"off", "balanced", "max_performance"}
        Wave feedforward setting (set by the controller kind, ``"lqri_ff"``).
    below_rated_baseline : str
        Baseline preset (``controller/presets/<name>.toml``) whose torque law (regions 1,
        1.5, 2, 2.5, 3) and pitch PI act below rated (:class:`AdvancedController`, step 5).
    ekf, forecast : sections
    """

    cp_table_file: str
    rotor_radius_m: float
    drivetrain_inertia_kg_m2: float
    gearbox_ratio: float
    air_density_kg_m3: float = 1.225
    lqri_design: str = "iea15mw_volturnus"
    observer_design: str = "iea15mw_volturnus"
    feedforward: FeedforwardName = "off"
    below_rated_baseline: str = "iea15mw_baseline"
    ekf: EkfSection = msgspec.field(default_factory=EkfSection)
    forecast: ForecastSection = msgspec.field(default_factory=ForecastSection)
    preset_dir: str = ""


def load_advanced_settings(name_or_path: str = "iea15mw_advanced") -> AdvancedSettings:
    """Read a shipped preset name or a TOML path; unknown keys are an error naming the key.

    Raises
    ------
    ValueError
        If the file is missing or a key is unknown or of the wrong type.
    """
    path = Path(name_or_path)
    if path.suffix == ".toml":
        if not path.is_file():
            raise ValueError(f"advanced controller preset {path} does not exist")
        text, base = path.read_text(), str(path.parent)
    else:
        ref = resources.files(_PRESET_PACKAGE) / f"{name_or_path}.toml"
        if not ref.is_file():
            raise ValueError(
                f"no advanced controller preset {name_or_path!r} in controller/presets"
            )
        text, base = ref.read_text(), ""
    try:
        raw = tomllib.loads(text)
        raw["preset_dir"] = base
        return msgspec.convert(raw, AdvancedSettings)
    except (tomllib.TOMLDecodeError, msgspec.ValidationError) as exc:
        raise ValueError(f"advanced controller preset {name_or_path!r}: {exc}") from exc


def _read_text(settings: AdvancedSettings, name: str) -> str:
    if settings.preset_dir:
        return (Path(settings.preset_dir) / name).read_text()
    return (resources.files(_PRESET_PACKAGE) / name).read_text()


# ------------------------------------------------------------------------------ observer design
@dataclass(frozen=True, eq=False)
class ObserverDesign:
    """Continuous platform-KF models at scheduled winds (written by
    :func:`controller.design.observer.design_observer`); arrays indexed by wind first."""

    wind_m_s: FloatArray
    A: FloatArray
    Bu: FloatArray
    Qc: FloatArray
    H: FloatArray
    D: FloatArray
    R: FloatArray
    x_op: FloatArray
    u_op: FloatArray
    gate_probability: float
    degraded_after_s: float
    state_names: tuple[str, ...]


def load_observer_design(
    name_or_path: str = "iea15mw_volturnus", design_dir: str | Path | None = None
) -> ObserverDesign:
    """Load ``<name>_observer.npz`` + ``.json`` (design name or a path to the npz).

    The observer artefact holds continuous models, discretised at the runtime's control
    period (:func:`discretize`), so one file serves every period and its name carries none.

    Parameters
    ----------
    name_or_path : str
        Design name (looked up with :func:`controller.lqri.find_design`) or a path to the npz.
    design_dir : str or Path, optional
        Extra folder searched after the shipped designs.

    Returns
    -------
    ObserverDesign
    """
    arr, meta = load_design_artefact(name_or_path, "observer", None, design_dir)
    arr = {k: np.asarray(v, dtype=np.float64) for k, v in arr.items()}
    s = meta["settings"]
    return ObserverDesign(
        wind_m_s=arr["wind_m_s"],
        A=arr["A"],
        Bu=arr["Bu"],
        Qc=arr["Qc"],
        H=arr["H"],
        D=arr["D"],
        R=arr["R"],
        x_op=arr["x_op"],
        u_op=arr["u_op"],
        gate_probability=float(s["gate_probability"]),
        degraded_after_s=float(s["degraded_after_s"]),
        state_names=tuple(meta["state_names"]),
    )


def required_designs(
    settings: AdvancedSettings, feedforward: FeedforwardName | None = None
) -> list[tuple[str, str]]:
    """The (design name, artefact kind) pairs a controller with these settings loads.

    Parameters
    ----------
    settings : AdvancedSettings
        Preset (:func:`load_advanced_settings`).
    feedforward : {"off", "balanced", "max_performance"}, optional
        Overrides ``settings.feedforward`` (the controller kind's setting).

    Returns
    -------
    list of (str, str)
        ``(name_or_path, kind)`` with kind ``"observer"``, ``"lqri"`` and, with feedforward
        on, ``"waveff"``.
    """
    ff = settings.feedforward if feedforward is None else feedforward
    out = [(settings.observer_design, "observer"), (settings.lqri_design, "lqri")]
    if ff != "off":
        out.append((settings.lqri_design, "waveff"))
    return out


def missing_designs(
    settings: AdvancedSettings,
    control_period_s: float,
    feedforward: FeedforwardName | None = None,
    design_dir: str | Path | None = None,
) -> list[DesignNotFoundError]:
    """The artefacts of :func:`required_designs` that no searched folder holds for the period.

    Artefacts given as paths to an npz are not looked up (loading reports them).

    Returns
    -------
    list of DesignNotFoundError
        One per missing artefact (``name``, ``kind``, ``control_period_s``, ``searched``).
    """
    out = []
    for name, kind in required_designs(settings, feedforward):
        if name.endswith(".npz"):
            continue
        try:
            find_design(name, kind, control_period_s, design_dir)
        except DesignNotFoundError as exc:
            out.append(exc)
    return out


def discretize(
    a: FloatArray, b: FloatArray, qc: FloatArray, dt_s: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Zero-order-hold discretisation with Van Loan's process-noise integral.

    .. math::

        \\exp\\Big(\\begin{bmatrix}A & B\\\\ 0 & 0\\end{bmatrix}\\Delta t\\Big)
        = \\begin{bmatrix}F & B_d\\\\ 0 & I\\end{bmatrix},\\qquad
        \\exp\\Big(\\begin{bmatrix}-A & Q_c\\\\ 0 & A^T\\end{bmatrix}\\Delta t\\Big)
        = \\begin{bmatrix}\\cdot & G\\\\ 0 & F^T\\end{bmatrix},\\quad Q_d = F G.

    Parameters
    ----------
    a : ndarray (n, n)
        Continuous A [1/s].
    b : ndarray (n, m)
        Continuous input matrix.
    qc : ndarray (n, n)
        White process-noise intensity (units of x squared per second).
    dt_s : float
        Sample time [s].

    Returns
    -------
    tuple of ndarray
        F, B_d, Q_d (symmetrised).
    """
    n, m = b.shape
    blk = np.zeros((n + m, n + m))
    blk[:n, :n], blk[:n, n:] = a, b
    e = sla.expm(blk * dt_s)
    v = np.zeros((2 * n, 2 * n))
    v[:n, :n], v[:n, n:], v[n:, n:] = -a, qc, a.T
    ev = sla.expm(v * dt_s)
    q = ev[n:, n:].T @ ev[:n, n:]
    return e[:n, :n], e[:n, n:], 0.5 * (q + q.T)


# ------------------------------------------------------------------------------ state
class AdvancedState(NamedTuple):
    """Everything the advanced controller carries between cycles (owned by the caller).

    The per-cycle part is two flat vectors, read by the compiled cycle
    (:func:`controller._kernels.advanced_cycle`) and replaced by new ones every cycle (never
    modified): ``values`` (float64: the wind EKF's x, P and innovation, the LQRI's integrator,
    last commands and FF parts, the baseline's filter, integrators and commands, the last
    raw KF measurements, the applied commands, then the platform KF's x, P and NIS and the
    wave-FF filter states; names in :data:`controller._kernels.ADV_FLOAT_STATE` and
    ``lay[st_*]``) and ``flags`` (int64: started, EKF updates, KF design index and degraded
    flag, LQRI first call / above rated / FF index, baseline first call, speed misses, then
    the KF's per-channel counters; :data:`controller._kernels.ADV_INT_STATE`).
    :meth:`AdvancedController.state_parts` names their parts. ``forecaster`` is the
    forecaster's preallocated state, updated in place; the forecast call times are ints.
    """

    values: FloatArray
    flags: npt.NDArray[np.int64]
    forecaster: Any
    next_forecast_ns: int = 0
    forecast_m: float = math.nan
    forecast_time_ns: int = 0

    @property
    def kf_index(self) -> int:
        """The platform-KF design in use."""
        return int(self.flags[_kernels.ADV_INT_STATE.index("kf_index")])


def _forecaster_config(
    fc: ForecastSection, kind: str, distance_m: float
) -> DispersionConfig | ArConfig | EspritConfig:
    """The forecaster configuration of the ``[forecast]`` section for ``kind``."""
    horizon = fc.horizon_s + fc.gauge_delay_s
    if kind == "dispersion":
        return DispersionConfig(
            distance_m=max(distance_m, 1e-3),
            horizon_s=horizon,
            dt_s=fc.sample_period_s,
            n_taps=fc.n_taps,
            depth_m=fc.water_depth_m,
        )
    if distance_m > 1.0:
        raise ValueError(
            f"forecaster {kind!r} predicts the elevation where it is measured from its "
            f"own past; the gauge is {distance_m:g} m up-wave, not at the platform. Set "
            "[waves] gauge_distance_m = 0 or use forecaster = 'dispersion'"
        )
    cls = ArConfig if kind == "ar" else EspritConfig
    # the model samples at about casanovas' 2 Hz, on a multiple of the call period
    model_period = max(1, round(0.5 / fc.sample_period_s)) * fc.sample_period_s
    return cls(sample_period_s=model_period, dt_s=fc.sample_period_s, horizon_s=horizon)


def forecast_fill_time_s(
    settings: AdvancedSettings,
    forecaster: ForecasterName | None = None,
    gauge_distance_m: float | None = None,
) -> float:
    """Simulated time from the first frame until the wave forecast is valid [s].

    The forecaster is called every ``sample_period_s`` (T_f) from t = 0 and is valid once its
    window holds its n model samples, taken every D calls (D = 1 for the dispersion filter,
    the decimation for AR/ESPRIT): t_fill = (n − 1) D T_f. Until then the controller
    status clears ``EST_WAVE_FORECAST`` and ``lqri_ff`` applies no feedforward. Built from
    the preset alone (no design artefact; the window does not depend on the horizon), so it
    equals :attr:`AdvancedController.forecast_fill_time_s`.
    """
    fc = settings.forecast
    kind = forecaster or fc.kind
    distance = fc.gauge_distance_m if gauge_distance_m is None else gauge_distance_m
    st = make_forecaster(kind, _forecaster_config(fc, kind, distance)).init_state()
    return (st.n - 1) * st.weights.shape[0] * fc.sample_period_s


class AdvancedController:
    """LQRI (optionally plus wave feedforward) on observer estimates (module docstring).

    Parameters
    ----------
    settings : AdvancedSettings
        Preset (:func:`load_advanced_settings`).
    control_period_s : float
        The node's control period [s]; the KF models are discretised at it.
    forecaster : {"dispersion", "ar", "esprit"} or None
        Overrides ``settings.forecast.kind``.
    gauge_distance_m : float or None
        Overrides ``settings.forecast.gauge_distance_m`` (the scenario's gauge position).
    feedforward : {"off", "balanced", "max_performance"} or None
        Overrides ``settings.feedforward``.
    design_dir : str or Path, optional
        Folder searched for the design artefacts after the shipped ones and before the user
        design cache (:func:`controller.lqri.design_search_path`).

    Raises
    ------
    DesignNotFoundError
        If the LQRI (or wave-FF) artefact for ``control_period_s`` or the observer artefact
        is missing (the message names the ``fowt design`` command that writes it).
    ValueError
        For an AR/ESPRIT forecaster with a gauge that is not at the platform, or an
        artefact designed for another control period. With feedforward on, the forecast
        horizon is the wave-FF design's preview :math:`t_d` (``delay_s`` of its artefact).
    """

    def __init__(
        self,
        settings: AdvancedSettings,
        control_period_s: float,
        forecaster: ForecasterName | None = None,
        gauge_distance_m: float | None = None,
        feedforward: FeedforwardName | None = None,
        design_dir: str | Path | None = None,
    ) -> None:
        if not 0.0 < control_period_s <= 1.0:
            raise ValueError(f"control_period_s = {control_period_s!r}: expected (0, 1] s")
        if feedforward is not None:
            settings = msgspec.structs.replace(settings, feedforward=feedforward)
        self.settings = settings
        self.dt_s = control_period_s
        s = settings
        table = cp_table_from_rosco_text(_read_text(s, s.cp_table_file))
        h = control_period_s
        sigma = encoder_rotor_speed_std(
            s.ekf.generator_speed_noise_std_rad_s,
            s.ekf.generator_speed_resolution_rad_s,
            s.gearbox_ratio,
        )
        self.ekf = WindSpeedEKF(
            WindEKFConfig(
                table,
                s.rotor_radius_m,
                s.drivetrain_inertia_kg_m2,
                s.gearbox_ratio,
                air_density_kg_m3=s.air_density_kg_m3,
                turbulence_intensity=s.ekf.turbulence_intensity,
                turbulence_length_m=s.ekf.turbulence_length_m,
                rotor_speed_process_psd=s.ekf.rotor_speed_process_psd,
                rotor_speed_noise_std_rad_s=sigma,
            )
        )
        obs = load_observer_design(s.observer_design, design_dir)
        self.observer = obs
        k_miss = max(1, math.ceil(obs.degraded_after_s / h))
        self.kfs: list[PlatformKF] = []
        for i in range(obs.wind_m_s.size):
            F, B, Q = discretize(obs.A[i], obs.Bu[i], obs.Qc[i], h)
            P0 = sla.solve_discrete_are(F.T, obs.H[i].T, Q, obs.R[i])
            self.kfs.append(
                PlatformKF(
                    PlatformKFConfig(
                        F=F,
                        B=B,
                        H=obs.H[i],
                        D=obs.D[i],
                        Q=Q,
                        R=obs.R[i],
                        dt_s=h,
                        P0=0.5 * (P0 + P0.T),
                        state_names=obs.state_names,
                        gate_probability=obs.gate_probability,
                        max_consecutive_misses=k_miss,
                    )
                )
            )
        self._x_op = [obs.x_op[i].copy() for i in range(obs.wind_m_s.size)]
        self._x_op_f = [tuple(float(v) for v in xo) for xo in self._x_op]
        self._u_op = [
            (float(obs.u_op[i, 0]), float(obs.u_op[i, 1])) for i in range(obs.wind_m_s.size)
        ]
        self._wind_grid = [float(v) for v in obs.wind_m_s]
        self._k_miss = k_miss
        fc = s.forecast
        lqri_design = load_lqri_design(s.lqri_design, control_period_s, design_dir)
        if s.feedforward == "off":
            self.lqri = LqriController(lqri_design)
        else:
            wave_ff = load_wave_ff_design(s.lqri_design, control_period_s, design_dir)
            self.lqri = LqriController(lqri_design, wave_ff, feedforward=s.feedforward)
            # the FF filters expect the forecast t_d ahead that they were designed for
            fc = msgspec.structs.replace(fc, horizon_s=wave_ff.delay_s)
        # the baseline's torque law (every regime) and pitch PI (below rated)
        base = load_baseline(s.below_rated_baseline)
        if abs(base.gearbox_ratio - s.gearbox_ratio) > 1e-9 * s.gearbox_ratio:
            raise ValueError(
                f"below_rated_baseline {s.below_rated_baseline!r} has gearbox_ratio "
                f"{base.gearbox_ratio}, the advanced preset {s.gearbox_ratio}: expected the same"
            )
        # its K omega^2 law and fine-pitch PI (the TSR tracking and minimum-pitch schedule of
        # a "tsr_tracking" preset need a wind estimate the advanced controller has its own
        # regime logic for)
        self.baseline = BaselineController(base.without_wind_schedule())
        kind = forecaster or fc.kind
        distance = fc.gauge_distance_m if gauge_distance_m is None else gauge_distance_m
        self.forecast_kind = kind
        self.forecast_horizon_s = fc.horizon_s
        self.forecaster = make_forecaster(kind, _forecaster_config(fc, kind, distance))
        self._forecast_period_ns = round(fc.sample_period_s * 1e9)
        self._horizon_ns = round(fc.horizon_s * 1e9)
        self._pack()
        self._warm_up()

    def _pack(self) -> None:
        """Pack every constant of the cycle into one float64 vector and its layout.

        ``self._c`` holds, at the offsets ``self._lay`` names (:data:`controller._kernels.
        ADV_LAYOUT`): the EKF's constants and Cp table, every KF design's F, B, Q, H, D, R,
        gate and operating point, the LQRI schedule and limits, the wave-FF filters and gain
        table, the baseline's constants and pitch-gain table: the same arrays the classes
        pass to their kernels. One array argument instead of about thirty keeps the cycle's
        call cheap (numba type-checks every argument on every call).
        """
        L = _kernels.ADV_LAYOUT
        lay = np.zeros(len(L), dtype=np.int64)
        parts: list[FloatArray] = []
        size = 0

        def put(name: str, value: Any) -> None:
            nonlocal size
            a = np.ascontiguousarray(value, dtype=np.float64).ravel()
            lay[L.index(name)] = size
            parts.append(a)
            size += a.size

        def setv(name: str, value: int) -> None:
            lay[L.index(name)] = value

        s = self.settings
        d = self.lqri.design
        put("scalars", [s.gearbox_ratio, d.switch_wind_m_s, d.hysteresis_m_s])
        prm, tsr, pitch, cells = self.ekf._tables
        put("ekf_prm", prm)
        put("tsr", tsr)
        setv("n_tsr", tsr.size)
        put("pitch", pitch)
        setv("n_pitch", pitch.size)
        put("cells", cells)
        setv("n_cells", cells.shape[0])
        kfs = self.kfs
        n, m = kfs[0]._pred[1].shape
        p = kfs[0]._upd[0].shape[0]
        if p != 4 or n < 6 or m != 2:
            raise ValueError(
                f"observer design {s.observer_design!r}: expected 4 channels (IMU acceleration, "
                f"gyro, attitude, GNSS surge), 2 inputs and at least 6 states; got {p}, {m}, {n}"
            )
        setv("n_kf", len(kfs))
        setv("kf_n", n)
        setv("kf_p", p)
        setv("kf_m", m)
        put("kf_grid", self._wind_grid)
        for k, name in enumerate(("kf_F", "kf_B", "kf_Q")):
            put(name, np.stack([kf._pred[k] for kf in kfs]))
        for k, name in enumerate(("kf_H", "kf_D", "kf_R", "kf_gate")):
            put(name, np.stack([kf._upd[k] for kf in kfs]))
        put("kf_xop", np.stack(self._x_op))
        put("kf_uop", self._u_op)
        setv("kf_max_misses", kfs[0].config.max_consecutive_misses)
        if any(kf.config.max_consecutive_misses != lay[L.index("kf_max_misses")] for kf in kfs):
            raise ValueError("observer designs: expected one max_consecutive_misses for all")
        setv("k_miss", self._k_miss)
        grid, k_x, x_op, k_i, theta_op, _rated = self.lqri._schedule
        put("lq_grid", grid)
        setv("n_lq", grid.size)
        setv("lq_nx", k_x.shape[1])
        if k_x.shape[1] != 8:
            raise ValueError(f"LQRI design: expected 8 states in k_x, got {k_x.shape[1]}")
        put("lq_kx", k_x)
        put("lq_xop", x_op)
        put("lq_ki", k_i)
        put("lq_thop", theta_op)
        put("lq_lim", self.lqri._limits)
        extra: list[int] = []
        ff_on = self.lqri.wave_ff is not None and self.lqri.feedforward != "off"
        setv("ff_on", int(ff_on))
        n_ff = ff_n = 0
        if ff_on:
            g_grid, is_pitch, g_wind, gain, a_t, b, c, dd = self.lqri._ff
            n_ff, ff_n = b.shape
            put("ff_grid", g_grid)
            setv("n_ff", n_ff)
            setv("ff_is_pitch", len(L))
            extra.extend(int(v) for v in is_pitch)
            put("ff_gwind", g_wind)
            setv("n_ffg", g_wind.size)
            put("ff_gain", gain)
            setv("ff_n", ff_n)
            put("ff_at", a_t)
            put("ff_b", b)
            put("ff_c", c)
            put("ff_d", dd)
        bl, gs, n_gs = self.baseline.kernel_arrays()
        put("bl", bl)
        put("bl_gs", gs)
        setv("n_gs", n_gs)
        for name, bit in (
            ("bit_speed", VALID_GENERATOR_SPEED),
            ("bit_pitch", VALID_PITCH),
            ("bit_torque", VALID_TORQUE),
            ("bit_acc", VALID_NACELLE_ACC),
            ("bit_pitch_rate", VALID_PLATFORM_PITCH_RATE),
            ("bit_platform_pitch", VALID_PLATFORM_PITCH),
            ("bit_surge", VALID_PLATFORM_SURGE),
        ):
            setv(name, bit)
        fs = len(_kernels.ADV_FLOAT_STATE)
        setv("st_kf_x", fs)
        setv("st_kf_P", fs + n)
        setv("st_kf_nis", fs + n + n * n)
        setv("st_ff", fs + n + n * n + p)
        setv("st_size", fs + n + n * n + p + n_ff * ff_n)
        setv("st_counts", len(_kernels.ADV_INT_STATE))
        setv("st_isize", len(_kernels.ADV_INT_STATE) + 4 * p)
        self._c = np.concatenate(parts)
        self._lay = np.concatenate([lay, np.array(extra, dtype=np.int64)])
        self._n, self._p = n, p
        self._st = {name: int(lay[L.index(name)]) for name in L if name.startswith("st_")}
        self._fi = {name: k for k, name in enumerate(_kernels.ADV_FLOAT_STATE)}
        self._ii = {name: k for k, name in enumerate(_kernels.ADV_INT_STATE)}
        kf = self.kfs[0].config
        self._steps_at_dt = min(max(round(self.dt_s / kf.dt_s), 1), kf.max_predict_steps)
        self._mask_no_forecast = _EST_ALWAYS | (EST_FEEDFORWARD if s.feedforward != "off" else 0)
        self._mask_forecast = self._mask_no_forecast | EST_WAVE_FORECAST

    def state_parts(self, state: AdvancedState) -> dict[str, Any]:
        """The parts of a state by name (views of its vectors; for tests and inspection).

        Keys: the names of :data:`controller._kernels.ADV_FLOAT_STATE` and ``ADV_INT_STATE``
        (scalars), ``ekf_x`` (3), ``ekf_p`` (upper triangle, 6), ``kf_x`` (n), ``kf_P``
        (n, n), ``kf_nis`` (p), ``kf_counts`` (4, p), ``ff_state`` (filters, order) or None.
        """
        v, f, st = state.values, state.flags, self._st
        n, p = self._n, self._p
        out: dict[str, Any] = {k: float(v[i]) for k, i in self._fi.items()}
        out.update({k: int(f[i]) for k, i in self._ii.items()})
        out["ekf_x"] = v[0:3]
        out["ekf_p"] = v[3:9]
        out["kf_x"] = v[st["st_kf_x"] : st["st_kf_x"] + n]
        out["kf_P"] = v[st["st_kf_P"] : st["st_kf_P"] + n * n].reshape(n, n)
        out["kf_nis"] = v[st["st_kf_nis"] : st["st_kf_nis"] + p]
        out["kf_counts"] = f[st["st_counts"] : st["st_counts"] + 4 * p].reshape(4, p)
        ff = self.lqri._ff[5].shape if self._lay[_kernels.ADV_LAYOUT.index("ff_on")] else None
        out["ff_state"] = (
            None
            if ff is None or not out["ff_started"]
            else v[st["st_ff"] : st["st_ff"] + ff[0] * ff[1]].reshape(ff)
        )
        return out

    def _warm_up(self) -> None:
        """Run the compiled cycle once on a throw-away state (results discarded).

        The kernels (:mod:`controller._kernels`) are compiled on a machine's first run and
        loaded from numba's on-disk cache afterwards; either happens on a kernel's first
        call (about 1 s to load them from the cache, tens of seconds to compile). Doing it
        here, while the node starts, keeps that cost out of the first control cycle. The
        classes' own kernels are warmed too (tests and tools call them). Nothing is kept:
        the cores are pure.
        """
        d = self.lqri.design
        h = self.dt_s
        ekf0 = self.ekf.initial_state(d.rated_rotor_speed_rad_s, 0.0, d.rated_torque_nm)
        self.ekf.step(ekf0, WindEKFMeasurement(d.rated_rotor_speed_rad_s, 0.0, 0.0, True), h)
        kf = self.kfs[0]
        m, p = kf.config.B.shape[1], kf.config.H.shape[0]
        kf.predict_update(kf.initial_state(), (0.0,) * m, (0.0,) * p, (True,) * p, h)
        meas = LqriMeasurement(
            wind_speed_estimate_m_s=d.switch_wind_m_s,
            rotor_speed_rad_s=d.rated_rotor_speed_rad_s,
            blade_pitch_rad=d.pitch_min_rad,
            wave_elevation_forecast_m=0.0,
        )
        self.lqri.step(self.lqri.initial_state(), meas, h)
        st = self.initial_state()
        values = st.values.copy()
        flags = st.flags.copy()
        flags[self._ii["started"]] = 1
        _kernels.advanced_cycle(
            self._c,
            self._lay,
            values,
            flags,
            d.rated_rotor_speed_rad_s * self.settings.gearbox_ratio,
            d.pitch_min_rad,
            d.rated_torque_nm,
            0.0,
            0.0,
            0.0,
            0.0,
            (1 << 62) - 1,
            0.0,
            h,
            self._steps_at_dt,
            np.empty_like(values),
            np.empty_like(flags),
        )

    def actuator_limits(self) -> ActuatorLimits:
        """The LQRI design's pitch range [rad] and pitch [rad/s] and torque [N m/s] rate limits."""
        d = self.lqri.design
        return ActuatorLimits(
            d.pitch_min_rad, d.pitch_max_rad, d.pitch_rate_max_rad_s, d.torque_rate_max_nm_s
        )

    @property
    def forecast_fill_time_s(self) -> float:
        """Simulated time from the first frame until the wave forecast is valid [s].

        The forecaster is called every ``sample_period_s`` (T_f) from t = 0 and is valid once
        its window holds its n model samples, taken every D calls (D = 1 for the dispersion
        filter, the decimation for AR/ESPRIT): t_fill = (n − 1) D T_f. Until then the status
        clears ``EST_WAVE_FORECAST`` and ``lqri_ff`` applies no feedforward.
        """
        st = self.forecaster.init_state()
        return (st.n - 1) * st.weights.shape[0] * self._forecast_period_ns * 1e-9

    # -------------------------------------------------------------- cycle
    def initial_state(self) -> AdvancedState:
        """State before the first cycle (the EKF and KF initialise from the first frame)."""
        i = len(self.kfs) // 2
        kf0 = self.kfs[i].initial_state()
        st, fi, ii = self._st, self._fi, self._ii
        n, p = self._n, self._p
        values = np.zeros(st["st_size"])
        values[fi["last_z_acc"] : fi["last_z_acc"] + 4] = math.nan
        values[st["st_kf_x"] : st["st_kf_x"] + n] = kf0.x
        values[st["st_kf_P"] : st["st_kf_P"] + n * n] = kf0.P.ravel()
        values[st["st_kf_nis"] : st["st_kf_nis"] + p] = kf0.nis
        flags = np.zeros(st["st_isize"], dtype=np.int64)
        flags[ii["kf_index"]] = i
        flags[ii["lq_first_call"]] = 1
        flags[ii["ff_index"]] = -1
        return AdvancedState(values, flags, self.forecaster.init_state())

    def _first_kf_state(self, i: int, frame: SensorFrame) -> PlatformKFState:
        """KF state of design ``i`` with surge and pitch taken from the first frame (if valid)."""
        st = self.kfs[i].initial_state()
        x = st.x.copy()
        xo = self._x_op[i]
        if frame.valid_mask & VALID_PLATFORM_SURGE:
            x[0] = frame.platform_surge_measured_m - float(xo[0])
        if frame.valid_mask & VALID_PLATFORM_PITCH:
            x[1] = frame.platform_pitch_measured_rad - float(xo[1])
        return st._replace(x=x)

    def trimmed_state(self, operating_point: OperatingPoint) -> AdvancedState:
        """The state of steady operation at ``operating_point`` (a trimmed run's start).

        The observers started as from a first frame at the operating point
        (:meth:`_start`): the wind EKF at the trimmed rotor speed and the wind its model
        balances against the operating point's generator torque (the plant's, from the
        trim; the EKF converges there, not at the nominal mean wind, when the rotor sees
        the wind tilted with the platform), at the mean wind when the operating point has
        no torque (then the EKF model's aerodynamic torque over N stands for it); the
        platform KF of the design nearest to that wind with the platform's surge and pitch
        where the trimmed plant stands (``platform_surge_m``, ``platform_pitch_rad``; at
        the design's operating point where they are None), at rest; the last commands the
        operating point's pitch and torque. The below-rated baseline and
        the LQRI start from the first frame of the run, which a trimmed plant makes the
        operating point: the
        baseline's filter at the measured speed, its pitch integrator at the measured pitch,
        the LQRI's integrator bumpless at the measured pitch (:mod:`controller.lqri`).
        """
        op = operating_point
        n = self.settings.gearbox_ratio
        torque = op.generator_torque_nm
        if torque is None:
            torque = self.ekf.aero_torque(op.rotor_speed_rad_s, op.wind_m_s, op.blade_pitch_rad)[0]
            torque /= n
        mask = VALID_GENERATOR_SPEED | VALID_PITCH | VALID_TORQUE
        # the platform where the trimmed plant stands, at rest (else the KF design's point)
        if op.platform_surge_m is not None:
            mask |= VALID_PLATFORM_SURGE
        if op.platform_pitch_rad is not None:
            mask |= VALID_PLATFORM_PITCH
        frame = SensorFrame(
            seq=0,
            sample_time_ns=0,
            publish_time_ns=0,
            valid_mask=mask,
            generator_speed_measured_rad_s=op.rotor_speed_rad_s * n,
            rotor_speed_measured_rad_s=op.rotor_speed_rad_s,
            blade_pitch_measured_rad=op.blade_pitch_rad,
            generator_torque_measured_nm=torque,
            electrical_power_measured_w=0.0,
            wind_speed_measured_m_s=op.wind_m_s,
            nacelle_acc_fore_aft_measured_m_s2=0.0,
            platform_pitch_measured_rad=op.platform_pitch_rad or 0.0,
            platform_pitch_rate_measured_rad_s=0.0,
            platform_surge_measured_m=op.platform_surge_m or 0.0,
            wave_elevation_gauge_measured_m=0.0,
        )
        state = self.initial_state()
        values, flags = self._start(state.values, state.flags, frame)
        values[self._fi["last_pitch_cmd"]] = op.blade_pitch_rad
        values[self._fi["last_torque_cmd"]] = torque
        self._settle_ekf(values, op, torque)
        if op.platform_surge_m is not None and op.platform_pitch_rad is not None:
            self._settle_kf(values, flags, op, op.platform_surge_m, op.platform_pitch_rad)
        return state._replace(values=values, flags=flags)

    def _settle_ekf(self, values: FloatArray, op: OperatingPoint, torque_nm: float) -> None:
        """The wind EKF (``values[0:9]``) run on the steady point's measurements for
        :data:`KF_SETTLE_S`, in place: its covariance at its steady value, not its initial
        one (the turbulence's variance on the wind states, which makes the first seconds'
        updates move the wind estimate with every noisy speed sample; the noise then drove
        a 1.6 % rotor-speed excursion in the first 60 s of a trimmed 15 m/s start that a
        quiet start does not have). The inputs are the point's pitch and torque, the
        measurement its rotor speed with the encoder's offset; the state stays where the
        model balances them."""
        n = self.settings.gearbox_ratio
        z = op.rotor_speed_rad_s + op.measurement_offset("generator_speed_measured_rad_s") / n
        u = (op.blade_pitch_rad, torque_nm)
        x = (float(values[0]), float(values[1]), float(values[2]))
        p6 = tuple(float(v) for v in values[3:9])
        est = WindEKFState(x, p6)  # type: ignore[arg-type]  # six floats, as the kernel keeps them
        dt = self.dt_s
        for _ in range(max(1, round(self.KF_SETTLE_S / dt))):
            est = self.ekf.update(self.ekf.predict(est, u, dt), z)
        values[0:3] = est.x
        values[3:9] = est.p
        values[self._fi["guard_v_hold"]] = est.x[2]

    #: Length of the platform KF's warm-up on the steady frame (:meth:`_settle_kf`) [s]: its
    #: estimate is steady to the last printed digit after 30 s (15 m/s, IEA 15 MW).
    KF_SETTLE_S = 60.0

    def _settle_kf(
        self,
        values: FloatArray,
        flags: npt.NDArray[np.int64],
        op: OperatingPoint,
        surge_m: float,
        pitch_rad: float,
    ) -> None:
        """The platform KF (in ``values``, ``flags``) run to its own steady state on the
        frames the trimmed plant gives, in place: surge and pitch where the plant stands,
        no acceleration or pitch rate, each with its instrument's offset
        (``op.measurement_offsets``), the rotor speed and blade pitch of the point as its
        known inputs; every channel valid each cycle, :data:`KF_SETTLE_S` of the design's
        period.

        Why: the KF of the nearest design wind is linear about that design's point; at
        another wind its model's equilibrium for the trimmed inputs is not where the plant
        stands (it knows the blade pitch, not the wind that pitch answers), so its estimate
        settles where model and measurements balance. Started anywhere else (the design's
        point, or the plant's true position) it moves there over the first tens of seconds
        and the LQRI follows it (a 0.3-0.7 % rotor-speed excursion at 15-20 m/s in a
        quiet, trimmed start); started there, nothing moves.
        """
        st, ii = self._st, self._ii
        i = int(flags[ii["kf_index"]])
        kf = self.kfs[i]
        n, p = self._n, self._p
        xo, (w_op, th_op) = self._x_op_f[i], self._u_op[i]
        off = op.measurement_offset
        u = np.array([op.rotor_speed_rad_s - w_op, op.blade_pitch_rad - th_op])
        z = np.array(
            [
                off("nacelle_acc_fore_aft_measured_m_s2"),
                off("platform_pitch_rate_measured_rad_s"),
                pitch_rad + off("platform_pitch_measured_rad") - xo[1],
                surge_m + off("platform_surge_measured_m") - xo[0],
            ]
        )
        kst = PlatformKFState(
            values[st["st_kf_x"] : st["st_kf_x"] + n].copy(),
            values[st["st_kf_P"] : st["st_kf_P"] + n * n].reshape((n, n)).copy(),
            np.zeros((4, p), dtype=np.int64),
            np.full(p, math.nan),
        )
        dt = kf.config.dt_s
        for _ in range(max(1, round(self.KF_SETTLE_S / dt))):
            kst = kf.predict_update(kst, u, z, None, dt)
        values[st["st_kf_x"] : st["st_kf_x"] + n] = kst.x
        values[st["st_kf_P"] : st["st_kf_P"] + n * n] = kst.P.ravel()

    def _start(
        self,
        values: FloatArray,
        flags: npt.NDArray[np.int64],
        frame: SensorFrame,
        wind_m_s: float | None = None,
    ) -> tuple[FloatArray, npt.NDArray[np.int64]]:
        """New state vectors with the EKF and KF started from the first frame.

        The EKF from the measured rotor speed (the design's rated speed if invalid, with a
        standard deviation of :data:`UNMEASURED_SPEED_STD` of it), pitch
        and torque (the last commands if invalid) at ``wind_m_s`` (None: the steady wind of
        the measurements, :meth:`WindSpeedEKF.initial_state`); the KF of the design nearest
        to that wind, surge and pitch from the frame (:meth:`_first_kf_state`).
        """
        v, f = values.copy(), flags.copy()
        fi, ii, st = self._fi, self._ii, self._st
        mask = frame.valid_mask
        omega_meas = frame.generator_speed_measured_rad_s / self.settings.gearbox_ratio
        pitch = frame.blade_pitch_measured_rad if mask & VALID_PITCH else v[fi["last_pitch_cmd"]]
        torque = (
            frame.generator_torque_measured_nm if mask & VALID_TORQUE else v[fi["last_torque_cmd"]]
        )
        speed_ok = bool(mask & VALID_GENERATOR_SPEED)
        w0 = omega_meas if speed_ok else self.lqri.design.rated_rotor_speed_rad_s
        ekf0 = self.ekf.initial_state(w0, float(pitch), float(torque), wind_m_s)
        if not speed_ok:  # a guess, not a sample: its variance says so (the gate's scale)
            ekf0 = ekf0._replace(p=((UNMEASURED_SPEED_STD * w0) ** 2, *ekf0.p[1:]))
        u0 = ekf0.x[2]
        i = min(range(len(self._wind_grid)), key=lambda k: abs(self._wind_grid[k] - u0))
        kf0 = self._first_kf_state(i, frame)
        n, p = self._n, self._p
        v[0:3] = ekf0.x
        v[3:9] = ekf0.p
        v[fi["ekf_innovation"]] = ekf0.innovation_rad_s
        v[fi["guard_v_hold"]] = ekf0.x[2]
        v[fi["guard_p22_0"]] = ekf0.p[5]
        v[st["st_kf_x"] : st["st_kf_x"] + n] = kf0.x
        v[st["st_kf_P"] : st["st_kf_P"] + n * n] = kf0.P.ravel()
        v[st["st_kf_nis"] : st["st_kf_nis"] + p] = kf0.nis
        f[st["st_counts"] : st["st_counts"] + 4 * p] = kf0.counts.ravel()
        f[ii["ekf_updates"]] = ekf0.updates
        f[ii["kf_index"]] = i
        f[ii["started"]] = 1
        return v, f

    # -------------------------------------------------------------- compiled loop
    def predict_steps(self, dt_s: float) -> int:
        """The platform KF's predict steps in a cycle of ``dt_s`` [s]: the period over the
        KF design's step, rounded, at least 1, at most its ``max_predict_steps``."""
        if dt_s == self.dt_s:
            return self._steps_at_dt
        kf = self.kfs[0].config
        return int(min(max(round(dt_s / kf.dt_s), 1), kf.max_predict_steps))

    def kernel_bundle(self, state: AdvancedState, dt_s: float | None = None) -> _kernels.CoreBundle:
        """This core's constants and a copy of ``state``'s vectors for a compiled loop.

        ``cc``/``lay`` are the packed constants of :func:`controller._kernels.advanced_cycle`
        (this controller's, read only), ``v``/``f`` copies of ``state.values``/``flags``
        (:meth:`step` never modifies a state's vectors; the kernel steps the copies; a
        new state gets copies of them back), and ``ci`` the KF predict steps of a cycle of
        ``dt_s`` [s] (None: the design period :attr:`dt_s`; :meth:`predict_steps`). The
        cycles' end state: :meth:`state_from_bundles`.
        """
        ci = np.zeros(_kernels.CI_SIZE, dtype=np.int64)
        ci[_kernels.CI_KIND] = 1
        ci[_kernels.CI_STEPS] = self.predict_steps(self.dt_s if dt_s is None else dt_s)
        v, f = state.values.copy(), state.flags.copy()
        empty = np.zeros(0)
        return _kernels.CoreBundle(
            ci, self._c, self._lay, empty, empty, v, np.empty_like(v), f, np.empty_like(f)
        )

    @staticmethod
    def load_bundle(bundle: _kernels.CoreBundle, state: AdvancedState) -> None:
        """Copy ``state``'s vectors into ``bundle`` (of :meth:`kernel_bundle`)."""
        bundle.v[:] = state.values
        bundle.f[:] = state.flags

    @property
    def forecast_in_kernel(self) -> bool:
        """True when a compiled loop runs this core's forecaster
        (:func:`controller._kernels.dispersion_forecast`: the dispersion forecaster); the
        AR and ESPRIT forecasters run in Python (:meth:`forecast_update`)."""
        return type(self.forecaster) is DispersionPredictor

    def forecast_bundle(self, state: AdvancedState) -> _kernels.ForecastBundle:
        """The forecast part of ``state`` as :meth:`step` hands it to the cycle.

        ``fi``/``ff`` (layouts ``FI_*``, ``FF_*`` of :mod:`controller._kernels`): the
        forecast given to the core (NaN until the window has filled or when not finite),
        the status's forecast fields and estimator mask, the next call and forecast times;
        with :attr:`forecast_in_kernel`, also the forecaster's own ring buffer and drop
        flags (its storage, written in place), its counters and FIR taps oldest first.
        """
        fi = np.zeros(_kernels.FI_SIZE, dtype=np.int64)
        ff = np.zeros(_kernels.FF_SIZE)
        fstate = state.forecaster
        ok = fstate.filled and math.isfinite(state.forecast_m)
        fi[_kernels.FI_NEXT_NS] = state.next_forecast_ns
        fi[_kernels.FI_PERIOD_NS] = self._forecast_period_ns
        fi[_kernels.FI_HORIZON_NS] = self._horizon_ns
        fi[_kernels.FI_MASK_FC] = self._mask_forecast
        fi[_kernels.FI_MASK_NO_FC] = self._mask_no_forecast
        ff[_kernels.FF_ETA] = float(state.forecast_m) if ok else math.nan
        if ok:
            fi[_kernels.FI_EST_MASK] = self._mask_forecast
            ff[_kernels.FF_STATUS_M] = state.forecast_m
            fi[_kernels.FI_STATUS_NS] = state.forecast_time_ns
        else:
            fi[_kernels.FI_EST_MASK] = self._mask_no_forecast
        fi[_kernels.FI_UNSTABLE] = fstate.unstable_fits
        fi[_kernels.FI_GUARDED] = fstate.guarded
        fc = self.forecaster
        if isinstance(fc, DispersionPredictor) and self.forecast_in_kernel:
            fi[_kernels.FI_KIND] = 1
            fi[_kernels.FI_HEAD] = fstate.head
            fi[_kernels.FI_COUNT] = fstate.count
            fi[_kernels.FI_CALLS] = fstate.calls
            fi[_kernels.FI_DROPPED] = fstate.dropped
            fi[_kernels.FI_DROPPED_WIN] = fstate.dropped_in_window
            fi[_kernels.FI_TIME_NS] = state.forecast_time_ns
            ff[_kernels.FF_HELD] = fstate.held_m
            ff[_kernels.FF_RAW] = state.forecast_m
            # the taps oldest first, as step dots them; a writeable copy (the kernel's
            # argument types then do not depend on the forecaster)
            fir = np.array(fc.fir[::-1], dtype=np.float64, order="C")
            return _kernels.ForecastBundle(fstate.buffer, fstate.drop_flags, fir, fi, ff)
        return _kernels.ForecastBundle(
            np.zeros(0), np.zeros(0, dtype=np.bool_), np.zeros(0), fi, ff
        )

    @staticmethod
    def state_from_bundles(
        state: AdvancedState, core: _kernels.CoreBundle, forecast: _kernels.ForecastBundle
    ) -> AdvancedState:
        """The state a compiled loop's cycles left in ``core`` and ``forecast`` (the bundles
        of :meth:`kernel_bundle` and :meth:`forecast_bundle` for ``state``); ``state``'s
        forecaster state takes the kernel forecaster's counters."""
        fi, ff = forecast.fi, forecast.ff
        fstate = state.forecaster
        if fi[_kernels.FI_KIND] and int(fi[_kernels.FI_CALLS]) != fstate.calls:
            # the kernel's forecaster calls (buffer and drop flags changed in place)
            fstate.head = int(fi[_kernels.FI_HEAD])
            fstate.count = int(fi[_kernels.FI_COUNT])
            fstate.calls = int(fi[_kernels.FI_CALLS])
            fstate.held_m = float(ff[_kernels.FF_HELD])
            fstate.dropped = int(fi[_kernels.FI_DROPPED])
            fstate.dropped_in_window = int(fi[_kernels.FI_DROPPED_WIN])
            return state._replace(
                values=core.v.copy(),
                flags=core.f.copy(),
                next_forecast_ns=int(fi[_kernels.FI_NEXT_NS]),
                forecast_m=float(ff[_kernels.FF_RAW]),
                forecast_time_ns=int(fi[_kernels.FI_TIME_NS]),
            )
        return state._replace(values=core.v.copy(), flags=core.f.copy())

    def forecast_update(
        self, state: AdvancedState, t_ns: int, gauge_m: float, gauge_valid: bool
    ) -> tuple[ForecasterState, int, float, int]:
        """The wave forecaster's part of a cycle: its step when the sample time is due.

        Every ``sample_period_s``: once ``t_ns`` reaches ``state.next_forecast_ns``, the
        forecaster takes the gauge sample (held if not ``gauge_valid``), the forecast
        η̂(t + horizon) [m] is for ``t_ns + horizon`` [ns], and the next call is the next
        multiple of the period. Otherwise the state's values, unchanged.

        Returns
        -------
        tuple
            (forecaster state, next call time [ns], forecast [m], forecast time [ns]).
        """
        if t_ns < state.next_forecast_ns:
            return (
                state.forecaster,
                state.next_forecast_ns,
                state.forecast_m,
                state.forecast_time_ns,
            )
        fstate, forecast_m = self.forecaster.step(state.forecaster, gauge_m, gauge_valid)
        period = self._forecast_period_ns
        return fstate, (t_ns // period + 1) * period, forecast_m, t_ns + self._horizon_ns

    def with_forecast(
        self, state: AdvancedState, t_ns: int, gauge_m: float, gauge_valid: bool
    ) -> AdvancedState:
        """``state`` with :meth:`forecast_update`'s result (the forecaster's part of a cycle
        run on its own, before the rest of the cycle: a compiled loop's forecast stop)."""
        fstate, next_ns, forecast_m, forecast_ns = self.forecast_update(
            state, t_ns, gauge_m, gauge_valid
        )
        return state._replace(
            forecaster=fstate,
            next_forecast_ns=next_ns,
            forecast_m=forecast_m,
            forecast_time_ns=forecast_ns,
        )

    def step(
        self, state: AdvancedState, frame: SensorFrame, dt_s: float
    ) -> tuple[AdvancedState, ControlOutput]:
        """One control cycle on a validated frame (module docstring, steps 1-6).

        The wave forecaster (step 4) runs here, every ``sample_period_s``; the rest of the
        cycle is one compiled call (:func:`controller._kernels.advanced_cycle`), the same
        arithmetic as the classes it is made of (:class:`WindSpeedEKF`,
        :class:`PlatformKF`, :class:`BaselineController`, :class:`LqriController`).

        Parameters
        ----------
        state : AdvancedState
        frame : SensorFrame
            Decoded, range-checked, finite frame.
        dt_s : float
            Control period [s], finite and > 0.

        Returns
        -------
        state : AdvancedState
            New state (the old one is not modified, except its forecaster's state, which
            the forecaster updates in place).
        output : ControlOutput
            Command, regime and every estimate for the status message.

        Raises
        ------
        ValueError
            If ``dt_s`` is not finite and > 0.
        """
        if not 0.0 < dt_s < math.inf:
            raise ValueError(f"dt_s must be finite and > 0 s, got {dt_s!r}")
        steps = self.predict_steps(dt_s)
        values, flags = state.values, state.flags
        if not flags[0]:  # first frame: start both filters from the measurements
            values, flags = self._start(values, flags, frame)
        mask = frame.valid_mask
        # 4. wave forecast on the gauge channel, every sample_period_s
        fstate, next_ns, forecast_m, forecast_ns = self.forecast_update(
            state,
            frame.sample_time_ns,
            frame.wave_elevation_gauge_measured_m,
            bool(mask & VALID_WAVE_GAUGE),
        )
        forecast_ok = fstate.filled and math.isfinite(forecast_m)
        # 1-3, 5, 6 in one compiled call (float() and int(): a frame built in Python may hold
        # an int where a float belongs, and numba would compile another signature for it)
        new_values = np.empty_like(values)
        new_flags = np.empty_like(flags)
        r = _kernels.advanced_cycle(
            self._c,
            self._lay,
            values,
            flags,
            float(frame.generator_speed_measured_rad_s),
            float(frame.blade_pitch_measured_rad),
            float(frame.generator_torque_measured_nm),
            float(frame.nacelle_acc_fore_aft_measured_m_s2),
            float(frame.platform_pitch_rate_measured_rad_s),
            float(frame.platform_pitch_measured_rad),
            float(frame.platform_surge_measured_m),
            int(mask),
            float(forecast_m) if forecast_ok else math.nan,
            float(dt_s),
            steps,
            new_values,
            new_flags,
        )
        new = AdvancedState(new_values, new_flags, fstate, next_ns, forecast_m, forecast_ns)
        if forecast_ok:
            est_mask, fc_m, fc_ns = self._mask_forecast, forecast_m, forecast_ns
        else:
            est_mask, fc_m, fc_ns = self._mask_no_forecast, 0.0, 0
        return new, ControlOutput(
            r[0],
            r[1],
            r[2],
            r[3],
            r[4],
            r[5],
            est_mask,
            r[6],
            r[7],
            r[8],
            r[9],
            r[10],
            r[11],
            r[12],
            fc_m,
            fc_ns,
            r[13],
            r[14],
            fstate.unstable_fits,
            fstate.guarded,
            r[15],
        )
