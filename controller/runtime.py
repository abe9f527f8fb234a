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
(m, 25, 25) bank product; each one compiled call (:mod:`controller._kernels`, numba, cached
on disk). The forecaster is one ring-buffer write and one fixed-length dot product per call
(AR/ESPRIT retrain on a fixed window); nothing grows with time.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Literal

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
from controller.baseline import BaselineController, BaselineState, load_baseline
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
from controller.forecast import ArConfig, DispersionConfig, EspritConfig, make_forecaster
from controller.interface import ActuatorLimits, ControlOutput
from controller.lqri import (
    DesignNotFoundError,
    LqriController,
    LqriMeasurement,
    LqriState,
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

FloatArray = npt.NDArray[np.float64]
ForecasterName = Literal["dispersion", "ar", "esprit"]
FeedforwardName = Literal["off", "balanced", "max_performance"]

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
class AdvancedState(msgspec.Struct, gc=False):
    """Everything the advanced controller carries between cycles (owned by the caller).

    ``forecaster`` is the forecaster's preallocated state, updated in place.
    """

    ekf: WindEKFState | None
    kf: PlatformKFState
    kf_index: int
    lqri: LqriState
    forecaster: Any
    next_forecast_ns: int = 0
    forecast_m: float = math.nan
    forecast_time_ns: int = 0
    last_z: tuple[float, float, float, float] = (math.nan,) * 4
    last_pitch_cmd_rad: float = 0.0
    last_torque_cmd_nm: float = 0.0
    speed_misses: int = 0
    baseline: BaselineState | None = None


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
        self.baseline = BaselineController(base)
        kind = forecaster or fc.kind
        distance = fc.gauge_distance_m if gauge_distance_m is None else gauge_distance_m
        self.forecast_kind = kind
        self.forecast_horizon_s = fc.horizon_s
        self.forecaster = make_forecaster(kind, _forecaster_config(fc, kind, distance))
        self._forecast_period_ns = round(fc.sample_period_s * 1e9)
        self._horizon_ns = round(fc.horizon_s * 1e9)
        self._warm_up()

    def _warm_up(self) -> None:
        """Run every compiled kernel once on a throw-away state (results discarded).

        The kernels (:mod:`controller._kernels`) are compiled on a machine's first run and
        loaded from numba's on-disk cache afterwards; either happens on a kernel's first
        call (about 1 s to load all of them from the cache, tens of seconds to compile).
        Doing it here, while the node starts, keeps that cost out of the first control
        cycle. Nothing is kept: the cores are pure.
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
        """State before the first cycle (the EKF initialises from the first frame)."""
        i = len(self.kfs) // 2
        return AdvancedState(
            ekf=None,
            kf=self.kfs[i].initial_state(),
            kf_index=i,
            lqri=self.lqri.initial_state(),
            forecaster=self.forecaster.init_state(),
        )

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

    def _nearest(self, wind_m_s: float, current: int) -> int:
        g = self._wind_grid
        best = current
        for j, w in enumerate(g):
            if abs(w - wind_m_s) < abs(g[best] - wind_m_s) - 0.25:  # 0.25 m/s hysteresis
                best = j
        return best

    def step(
        self, state: AdvancedState, frame: SensorFrame, dt_s: float
    ) -> tuple[AdvancedState, ControlOutput]:
        """One control cycle on a validated frame (module docstring, steps 1-5).

        Parameters
        ----------
        state : AdvancedState
        frame : SensorFrame
            Decoded, range-checked, finite frame.
        dt_s : float
            Control period [s].

        Returns
        -------
        state : AdvancedState
        output : ControlOutput
            Command, regime and every estimate for the status message.
        """
        mask = frame.valid_mask
        s = self.settings
        speed_ok = bool(mask & VALID_GENERATOR_SPEED)
        omega_meas = frame.generator_speed_measured_rad_s / s.gearbox_ratio
        pitch = frame.blade_pitch_measured_rad if mask & VALID_PITCH else state.last_pitch_cmd_rad
        torque = (
            frame.generator_torque_measured_nm if mask & VALID_TORQUE else state.last_torque_cmd_nm
        )
        # 2. wind EKF
        ekf_state = state.ekf
        i = state.kf_index
        kf_state = state.kf
        if ekf_state is None:  # first frame: start both filters from the measurements
            w0 = omega_meas if speed_ok else self.lqri.design.rated_rotor_speed_rad_s
            ekf_state = self.ekf.initial_state(w0, pitch, torque)
            u0 = ekf_state.x[2]
            i = min(range(len(self._wind_grid)), key=lambda k: abs(self._wind_grid[k] - u0))
            kf_state = self._first_kf_state(i, frame)
        ekf_state, west = self.ekf.step(
            ekf_state, WindEKFMeasurement(omega_meas, pitch, torque, speed_ok), dt_s
        )
        speed_misses = 0 if speed_ok else state.speed_misses + 1
        omega = west.rotor_speed_rad_s
        # 3. platform KF, scheduled on the mean wind
        j = self._nearest(west.mean_wind_m_s, i)
        if j != i:
            kf_state = kf_state._replace(x=kf_state.x + self._x_op[i] - self._x_op[j])
            i = j
        kf = self.kfs[i]
        xo = self._x_op_f[i]
        u_op = self._u_op[i]
        u = (omega - u_op[0], pitch - u_op[1])
        raw = (
            frame.nacelle_acc_fore_aft_measured_m_s2,
            frame.platform_pitch_rate_measured_rad_s,
            frame.platform_pitch_measured_rad,
            frame.platform_surge_measured_m,
        )
        z = (raw[0], raw[1], raw[2] - xo[1], raw[3] - xo[0])
        last = state.last_z
        valid = (
            bool(mask & VALID_NACELLE_ACC) and raw[0] != last[0],
            bool(mask & VALID_PLATFORM_PITCH_RATE) and raw[1] != last[1],
            bool(mask & VALID_PLATFORM_PITCH) and raw[2] != last[2],
            bool(mask & VALID_PLATFORM_SURGE) and raw[3] != last[3],
        )
        kf_state = kf.predict_update(kf_state, u, z, valid, dt_s)
        xd = kf_state.x.tolist()
        x = [a + b for a, b in zip(xd, xo, strict=True)]
        degraded = kf_state.degraded or speed_misses > self._k_miss
        # 4. wave forecast on the gauge channel
        fstate = state.forecaster
        forecast_m, forecast_ns = state.forecast_m, state.forecast_time_ns
        next_ns = state.next_forecast_ns
        t_ns = frame.sample_time_ns
        if t_ns >= next_ns:
            fstate, forecast_m = self.forecaster.step(
                fstate,
                frame.wave_elevation_gauge_measured_m,
                bool(mask & VALID_WAVE_GAUGE),
            )
            forecast_ns = t_ns + self._horizon_ns
            period = self._forecast_period_ns
            next_ns = (t_ns // period + 1) * period
        forecast_ok = bool(fstate.filled) and math.isfinite(forecast_m)
        # 5. below-rated laws (the baseline's torque law and pitch PI on the measured speed,
        # the EKF's when the speed sample is invalid), tracking the applied commands so that
        # their rate limits, region-3 criterion and integrators follow what the turbine got
        bst = state.baseline
        if bst is not None:
            # the law's own part of the applied torque: tracking the total (FF included)
            # would let its rate limit ratchet the FF up against it cycle after cycle
            bst = msgspec.structs.replace(
                bst,
                blade_pitch_commanded_rad=state.last_pitch_cmd_rad,
                generator_torque_commanded_nm=state.last_torque_cmd_nm
                - state.lqri.feedforward_torque_nm,
            )
        else:
            bst = self.baseline.initial_state()
        bframe = (
            frame
            if speed_ok
            else msgspec.structs.replace(
                frame, generator_speed_measured_rad_s=omega * s.gearbox_ratio
            )
        )
        bst, bout = self.baseline.step(bst, bframe, dt_s)
        # 6. regime logic + LQRI
        meas = LqriMeasurement(
            wind_speed_estimate_m_s=west.mean_wind_m_s,
            rotor_speed_rad_s=omega,
            blade_pitch_rad=pitch,
            platform_surge_m=x[0],
            platform_pitch_rad=x[1],
            tower_top_deflection_m=x[2],
            platform_surge_rate_m_s=x[3],
            platform_pitch_rate_rad_s=x[4],
            tower_top_deflection_rate_m_s=x[5],
            wave_elevation_forecast_m=forecast_m if forecast_ok else math.nan,
            torque_law_nm=bout.generator_torque_commanded_nm,
            pitch_below_rated_rad=bout.blade_pitch_commanded_rad,
            regime_below_rated=bout.regime,
        )
        lqri_state, out = self.lqri.step(state.lqri, meas, dt_s)
        integrator_rad = out.pitch_integrator_rad
        if lqri_state.above_rated:
            # the baseline pitch PI tracks the LQRI's command (bumpless hand-back at θ_min)
            ki_eff = self.baseline.pitch_gains(out.blade_pitch_commanded_rad)[1]
            bst = msgspec.structs.replace(
                bst, pitch_speed_error_integral_rad=out.blade_pitch_commanded_rad / ki_eff
            )
        else:
            integrator_rad = bout.pitch_integrator_rad
        est_mask = (
            EST_WIND_SPEED
            | EST_PLATFORM_PITCH
            | EST_PLATFORM_PITCH_RATE
            | EST_PLATFORM_SURGE
            | EST_PLATFORM_SURGE_VELOCITY
            | EST_TOWER_TOP_VELOCITY
        )
        if forecast_ok:
            est_mask |= EST_WAVE_FORECAST
        if s.feedforward != "off":
            est_mask |= EST_FEEDFORWARD
        new = AdvancedState(
            ekf=ekf_state,
            kf=kf_state,
            kf_index=i,
            lqri=lqri_state,
            forecaster=fstate,
            next_forecast_ns=next_ns,
            forecast_m=forecast_m,
            forecast_time_ns=forecast_ns,
            last_z=raw,
            last_pitch_cmd_rad=out.blade_pitch_commanded_rad,
            last_torque_cmd_nm=out.generator_torque_commanded_nm,
            speed_misses=speed_misses,
            baseline=bst,
        )
        result = ControlOutput(
            blade_pitch_commanded_rad=out.blade_pitch_commanded_rad,
            generator_torque_commanded_nm=out.generator_torque_commanded_nm,
            regime=out.regime,
            generator_speed_filtered_rad_s=omega * s.gearbox_ratio,
            pitch_integrator_rad=integrator_rad,
            gain_schedule_factor=max(out.gain_schedule_factor, 0.0),
            estimates_valid_mask=est_mask,
            estimator_degraded=int(degraded),
            wind_speed_estimated_m_s=west.wind_m_s,
            platform_surge_estimated_m=x[0],
            platform_pitch_estimated_rad=x[1],
            platform_surge_velocity_estimated_m_s=x[3],
            platform_pitch_rate_estimated_rad_s=x[4],
            tower_top_velocity_estimated_m_s=x[5],
            wave_elevation_forecast_m=forecast_m if forecast_ok else 0.0,
            wave_forecast_time_ns=forecast_ns if forecast_ok else 0,
            feedforward_pitch_rad=lqri_state.feedforward_pitch_rad,
            feedforward_torque_nm=lqri_state.feedforward_torque_nm,
            forecast_unstable_fits=int(getattr(fstate, "unstable_fits", 0)),
            forecast_guarded=int(getattr(fstate, "guarded", 0)),
        )
        return new, result
