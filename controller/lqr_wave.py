"""``lqr_wave``: LQR scheduled on wind speed and wave frequency (christiansen-2013), pure core.

Runtime half of :mod:`controller.design.lqr_wave` (the design, its model and weights are
documented there). Never imports ``plant``: it loads its preset TOML, a ROSCO-format Cp table
and the design artefact ``<design>_lqr_wave_<variant>_dt<T>.npz`` (+ ``.json``) from the
shipped designs, ``design_dir`` or the user design cache (``$FOWT_DESIGN_DIR``).

One cycle (period T, one validated :class:`bus_schemas.messages.SensorFrame`):

1. rotor speed Ω = ω_g/N, measured pitch β and torque (held last command when invalid);
2. wind EKF (:class:`controller.estimators.WindSpeedEKF`): mean-wind estimate v_m, the
   scheduling variable (as the seed, sect. 2.10: "the slow varying mean wind speed"),
   its update gated at 5 sigma and its estimate bounded to 1-37.5 m/s
   (:func:`controller.estimators.guarded_wind_step`). The guard
   (:func:`controller.estimators.guard_step`): a step with the EKF gated, clamped or not
   finite, or with the KF of step 4 rejecting every valid channel, is bad; 5 s of bad
   steps, or a non-finite KF, is an estimator fault (``estimator_faults`` + 1, once per
   fallback): both observers restart (the EKF at the measured speed and the last good
   mean wind, the KF at the operating point) and the fallback holds the last good mean
   wind as the scheduling variable until 10 s pass without a bad step;
3. wave frequency ω_w from the AR(2) RLS estimator on the wave-gauge channel
   (:class:`controller.forecast.WaveFrequencyEstimator`, seed sect. 2.11);
4. platform and tower states (surge, heave, pitch, tower fore-aft and their rates) from the
   Kalman filter (:class:`controller.estimators.PlatformKF`) of the design wind nearest to
   v_m (0.25 m/s hysteresis; switching re-expresses the estimate about the new point),
   measurements GNSS surge, platform pitch, pitch rate and nacelle acceleration (a channel
   that repeats its previous value exactly, a slower sample-and-hold sensor, is skipped);
5. the deviation z̃ = (x̂ + x_op,i − x_op(v_m), Ω − Ω_op, β − β_op(v_m), ψ, β_c − β_op(v_m)) with
   ψ = ∫(Ω − Ω_op)dt (held within ±2 ψ_max as anti-windup) and β_c the pitch demand;
   x_op, β_op interpolated linearly in v_m, the gain K(v_m, ω_w) bilinearly on the table
   (clamped at the grid edges);
6. pitch rate u = −K z̃ limited to the design's rate limit; β_c ← β_c + u T within the pitch
   range; generator torque constant (the design's operating torque, sect. 2.13).

Bounded work per cycle: the EKF on floats, one 8-state KF step (4 channels), one 12-element
dot product and a bilinear look-up; nothing grows with time.
"""

from __future__ import annotations

import json
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
    EST_PLATFORM_PITCH,
    EST_PLATFORM_PITCH_RATE,
    EST_PLATFORM_SURGE,
    EST_PLATFORM_SURGE_VELOCITY,
    EST_TOWER_TOP_VELOCITY,
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
from controller.estimators import (
    GuardConfig,
    GuardState,
    PlatformKF,
    PlatformKFConfig,
    PlatformKFState,
    WindEKFConfig,
    WindEKFMeasurement,
    WindEKFState,
    WindSpeedEKF,
    cp_table_from_rosco_text,
    encoder_rotor_speed_std,
    guard_step,
    guarded_wind_step,
)
from controller.forecast import WaveFrequencyConfig, WaveFrequencyEstimator, WaveFrequencyState
from controller.interface import REGIME_REGION_3, ActuatorLimits, ControlOutput
from controller.lqri import design_search_path, period_tag, user_design_dir
from controller.runtime import UNMEASURED_SPEED_STD, EkfSection, discretize

__all__ = [
    "LqrWaveController",
    "LqrWaveDesign",
    "LqrWaveDesignNotFoundError",
    "LqrWavePreset",
    "LqrWaveState",
    "find_lqr_wave_design",
    "load_lqr_wave_design",
    "load_lqr_wave_preset",
]

FloatArray = npt.NDArray[np.float64]
_PRESET_PACKAGE = "controller.presets"


class LqrWavePreset(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The controller preset (``controller/presets/<name>.toml``), SI units.

    Attributes
    ----------
    name : str
    design : str
        Design name (the plant preset stem the gains were designed for).
    variant : {"lqr1", "lqr2"}
        Pitch-rate weight of the design (5 or 8 deg/s).
    cp_table_file : str
        ROSCO-format Cp table (relative to the preset) for the wind EKF.
    rotor_radius_m, drivetrain_inertia_kg_m2, gearbox_ratio, air_density_kg_m3 : float
        Turbine figures of the EKF.
    wave_sample_period_s, wave_forgetting_factor : float
        AR(2) estimator settings (:class:`controller.forecast.WaveFrequencyConfig`).
    kf_degraded_after_s : float
        A KF channel missing longer than this marks the estimate degraded.
    platform_states : {"observer", "measured"}
        ``"measured"``: the LQR takes platform surge, pitch and pitch rate straight from their
        sensor channels (when valid) instead of the KF (the other five states, not measured,
        stay the KF's): the comparison that tells what the observer costs.
    ekf : EkfSection
    """

    name: str
    design: str
    variant: str
    cp_table_file: str
    rotor_radius_m: float
    drivetrain_inertia_kg_m2: float
    gearbox_ratio: float
    air_density_kg_m3: float = 1.225
    wave_sample_period_s: float = 0.5
    wave_forgetting_factor: float = 0.995
    kf_degraded_after_s: float = 2.0
    platform_states: Literal["observer", "measured"] = "observer"
    ekf: EkfSection = msgspec.field(default_factory=EkfSection)
    preset_dir: str = ""


def load_lqr_wave_preset(name_or_path: str) -> LqrWavePreset:
    """Read a shipped preset name or a TOML path; unknown keys are an error naming the key."""
    try:
        if name_or_path.endswith(".toml"):
            path = Path(name_or_path)
            data = tomllib.loads(path.read_text(encoding="utf-8"))
            data.setdefault("preset_dir", str(path.resolve().parent))
        else:
            ref = resources.files(_PRESET_PACKAGE) / f"{name_or_path}.toml"
            data = tomllib.loads(ref.read_text(encoding="utf-8"))
        return msgspec.convert(data, LqrWavePreset)
    except (OSError, tomllib.TOMLDecodeError, msgspec.ValidationError) as exc:
        raise ValueError(f"lqr_wave preset {name_or_path!r}: {exc}") from exc


def _stem(name: str, variant: str, control_period_s: float) -> str:
    return f"{name}_lqr_wave_{variant}_{period_tag(control_period_s)}"


def find_lqr_wave_design(
    name: str, variant: str, control_period_s: float, design_dir: str | Path | None = None
) -> Any:
    """The npz of a design (shipped, ``design_dir``, user cache); DesignNotFoundError if none."""
    stem = _stem(name, variant, control_period_s)
    folders = design_search_path(design_dir)
    for folder in folders:
        npz, js = folder / f"{stem}.npz", folder / f"{stem}.json"
        if npz.is_file() and js.is_file():
            return npz
    raise LqrWaveDesignNotFoundError(
        f"no lqr_wave design {stem}.npz for control period {control_period_s:.9g} s (looked in "
        f"{', '.join(str(f) for f in folders)}); run `fowt design {name} --lqr-wave {variant} "
        f"--control-period {control_period_s:.9g} --out {user_design_dir()}`"
    )


class LqrWaveDesignNotFoundError(ValueError):
    """No searched folder holds the ``lqr_wave`` design for the control period (message: the
    ``fowt design`` command that writes it)."""


@dataclass(frozen=True, eq=False)
class LqrWaveDesign:
    """Arrays of a design artefact (see :mod:`controller.design.lqr_wave`)."""

    wind_m_s: FloatArray
    wave_omega_rad_s: FloatArray
    gains: FloatArray  # (nv, nw, 12)
    x_op: FloatArray  # (nv, 11): q, q̇, Ω, β, T_g
    obs: dict[str, FloatArray]
    meta: dict[str, Any]

    def gain(self, wind_m_s: float, omega_rad_s: float) -> FloatArray:
        """Bilinear interpolation of K on the (wind, wave) grid, clamped at the edges."""
        v, w = self.wind_m_s, self.wave_omega_rad_s
        fi = float(np.clip(np.interp(wind_m_s, v, np.arange(v.size)), 0, v.size - 1))
        fj = float(np.clip(np.interp(omega_rad_s, w, np.arange(w.size)), 0, w.size - 1))
        i0, j0 = min(int(fi), v.size - 2), min(int(fj), w.size - 2)
        a, b = fi - i0, fj - j0
        k = self.gains
        return (
            (1 - a) * (1 - b) * k[i0, j0]
            + a * (1 - b) * k[i0 + 1, j0]
            + (1 - a) * b * k[i0, j0 + 1]
            + a * b * k[i0 + 1, j0 + 1]
        )

    def operating_point(self, wind_m_s: float) -> FloatArray:
        """x_op(v) (11,) interpolated linearly in v (held at the ends)."""
        v = self.wind_m_s
        f = float(np.clip(np.interp(wind_m_s, v, np.arange(v.size)), 0, v.size - 1))
        i0 = min(int(f), v.size - 2)
        a = f - i0
        return np.asarray((1.0 - a) * self.x_op[i0] + a * self.x_op[i0 + 1], dtype=np.float64)


def load_lqr_wave_design(
    name_or_path: str | Path,
    variant: str = "lqr2",
    control_period_s: float = 0.1,
    design_dir: str | Path | None = None,
) -> LqrWaveDesign:
    """Load a design by name (looked up for the period) or by the path to its npz."""
    npz: Any
    if str(name_or_path).endswith(".npz"):
        npz = Path(name_or_path)
    else:
        npz = find_lqr_wave_design(str(name_or_path), variant, control_period_s, design_dir)
    js: Any = npz.parent / (npz.name[:-4] + ".json")
    with resources.as_file(npz) as p, np.load(p) as data:
        arrays = {k: np.array(data[k]) for k in data.files}
    meta = json.loads(js.read_text(encoding="utf-8"))
    period = float(meta["control_period_s"])
    if abs(period - control_period_s) > 1e-12:
        raise ValueError(
            f"{npz}: designed for {period} s, the controller runs at {control_period_s} s"
        )
    return LqrWaveDesign(
        wind_m_s=arrays["wind_m_s"],
        wave_omega_rad_s=arrays["wave_omega_rad_s"],
        gains=arrays["gains"],
        x_op=arrays["x_op"],
        obs={k[4:]: v for k, v in arrays.items() if k.startswith("obs_")},
        meta=meta,
    )


class LqrWaveState(msgspec.Struct, gc=False):
    """Controller state between cycles."""

    ekf: WindEKFState | None
    kf: PlatformKFState
    kf_index: int
    wave: WaveFrequencyState
    rotor_angle_rad: float = 0.0
    pitch_demand_rad: float = math.nan
    last_z: tuple[float, float, float, float] = (math.nan, math.nan, math.nan, math.nan)
    last_pitch_cmd_rad: float = 0.0
    speed_misses: int = 0
    guard: GuardState = GuardState()


class LqrWaveController:
    """The pure core (module docstring)."""

    def __init__(
        self, preset: LqrWavePreset, control_period_s: float, design_dir: str | Path | None = None
    ) -> None:
        if not 0.0 < control_period_s <= 1.0:
            raise ValueError(f"control_period_s = {control_period_s!r}: expected (0, 1] s")
        self.preset = preset
        self.dt_s = control_period_s
        s = preset
        if s.preset_dir:
            text = (Path(s.preset_dir) / s.cp_table_file).read_text()
        else:
            text = (resources.files(_PRESET_PACKAGE) / s.cp_table_file).read_text()
        sigma = encoder_rotor_speed_std(
            s.ekf.generator_speed_noise_std_rad_s,
            s.ekf.generator_speed_resolution_rad_s,
            s.gearbox_ratio,
        )
        self.ekf = WindSpeedEKF(
            WindEKFConfig(
                cp_table_from_rosco_text(text),
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
        #: The observers' guard (the baseline's figures: 5-sigma gate, 1-37.5 m/s, 5 s, 10 s).
        self.guard_config = GuardConfig()
        self.design = load_lqr_wave_design(s.design, s.variant, control_period_s, design_dir)
        d = self.design
        ratio = s.wave_sample_period_s / control_period_s
        wave_period = s.wave_sample_period_s
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            wave_period = control_period_s * max(1, round(ratio))  # nearest multiple
        self.wave = WaveFrequencyEstimator(
            WaveFrequencyConfig(
                dt_s=control_period_s,
                sample_period_s=wave_period,
                forgetting_factor=s.wave_forgetting_factor,
            )
        )
        k_miss = max(1, math.ceil(s.kf_degraded_after_s / control_period_s))
        self._k_miss = k_miss
        self.kfs: list[PlatformKF] = []
        o = d.obs
        for i in range(d.wind_m_s.size):
            F, B, Q = discretize(o["A"][i], o["Bu"][i], o["Qc"][i], control_period_s)
            P0 = sla.solve_discrete_are(F.T, o["H"][i].T, Q, o["R"][i])
            self.kfs.append(
                PlatformKF(
                    PlatformKFConfig(
                        F=F,
                        B=B,
                        H=o["H"][i],
                        D=o["D"][i],
                        Q=Q,
                        R=o["R"][i],
                        dt_s=control_period_s,
                        P0=0.5 * (P0 + P0.T),
                        max_consecutive_misses=k_miss,
                    )
                )
            )
        self._grid = [float(v) for v in d.wind_m_s]
        m = d.meta
        self.omega_rated = float(m["rated_rotor_speed_rad_s"])
        self.torque_nm = float(m["generator_torque_nm"])
        self.pitch_min = float(m["pitch_min_rad"])
        self.pitch_max = float(m["pitch_max_rad"])
        self.rate_max = float(m["pitch_rate_max_rad_s"])
        self.torque_rate_max = float(m["torque_rate_max_nm_s"])
        self.psi_max = 2.0 * float(m["settings"]["rotor_angle_max_rad"])
        #: hub velocity = J_h · q̇ (surge, heave, pitch, tower), J_h of the design's plant
        self.hub_lever = tuple(float(v) for v in m["hub_lever"])
        self._warm_up()

    def _warm_up(self) -> None:
        """Call the compiled estimator kernels once on throw-away states (results discarded).

        The wind-speed EKF's and the platform KF's kernels (:mod:`controller._kernels`) are
        loaded from numba's on-disk cache on their first call in a process (about 70 ms on
        the 2-core machine), compiled on a machine's first run: without this the real-time
        controller paid it in its first cycle. The arguments have the types of
        :meth:`step`'s calls (floats, and bools for the validity flags), so the signatures
        loaded here are the ones the cycles use. Nothing is kept: the estimators are pure.
        """
        omega, pitch, torque = self.omega_rated, self.pitch_min, self.torque_nm
        ekf0 = self.ekf.initial_state(omega, pitch, torque)
        # the cycles' path: the guarded step (its predict and update kernels)
        guarded_wind_step(
            self.ekf,
            ekf0,
            WindEKFMeasurement(omega, pitch, torque, True),
            self.dt_s,
            self.guard_config,
        )
        st = self.initial_state()
        kf = self.kfs[st.kf_index]
        kf_state = kf.predict(st.kf, (0.0, 0.0), self.dt_s)
        kf.update(kf_state, (0.0, 0.0, 0.0, 0.0), (True, True, True, True), (0.0, 0.0))

    def actuator_limits(self) -> ActuatorLimits:
        """The design's pitch range [rad] and pitch [rad/s] and torque [N m/s] rate limits."""
        return ActuatorLimits(self.pitch_min, self.pitch_max, self.rate_max, self.torque_rate_max)

    def initial_state(self) -> LqrWaveState:
        """State before the first cycle (the EKF and KF start from the first frame)."""
        i = len(self.kfs) // 2
        return LqrWaveState(
            ekf=None, kf=self.kfs[i].initial_state(), kf_index=i, wave=self.wave.init_state()
        )

    def _nearest(self, wind_m_s: float, current: int) -> int:
        g = self._grid
        best = current
        for j, w in enumerate(g):
            if abs(w - wind_m_s) < abs(g[best] - wind_m_s) - 0.25:
                best = j
        return best

    def step(
        self, state: LqrWaveState, frame: SensorFrame, dt_s: float
    ) -> tuple[LqrWaveState, ControlOutput]:
        """One control cycle (module docstring, steps 1-6)."""
        mask = frame.valid_mask
        s = self.preset
        d = self.design
        speed_ok = bool(mask & VALID_GENERATOR_SPEED)
        omega_meas = frame.generator_speed_measured_rad_s / s.gearbox_ratio
        pitch = frame.blade_pitch_measured_rad if mask & VALID_PITCH else state.last_pitch_cmd_rad
        torque = frame.generator_torque_measured_nm if mask & VALID_TORQUE else self.torque_nm
        ekf_state = state.ekf
        i = state.kf_index
        kf_state = state.kf
        beta_c = state.pitch_demand_rad
        if ekf_state is None:
            ekf_state = self.ekf.initial_state(
                omega_meas if speed_ok else self.omega_rated, pitch, torque
            )
            if not speed_ok:  # a guess, not a sample (AdvancedController._start)
                p0 = (UNMEASURED_SPEED_STD * self.omega_rated) ** 2
                ekf_state = ekf_state._replace(p=(p0, *ekf_state.p[1:]))
            u0 = float(ekf_state.x[2])
            i = min(range(len(self._grid)), key=lambda k: abs(self._grid[k] - u0))
            x = kf_state.x.copy()
            xo = d.x_op[i]
            if mask & VALID_PLATFORM_SURGE:
                x[0] = frame.platform_surge_measured_m - xo[0]
            if mask & VALID_PLATFORM_PITCH:
                x[2] = frame.platform_pitch_measured_rad - xo[2]
            kf_state = self.kfs[i].initial_state()._replace(x=x)
            beta_c = pitch
        ekf_state, west, bad = guarded_wind_step(
            self.ekf,
            ekf_state,
            WindEKFMeasurement(omega_meas, pitch, torque, speed_ok),
            dt_s,
            self.guard_config,
        )
        speed_misses = 0 if speed_ok else state.speed_misses + 1
        omega = omega_meas if speed_ok else west.rotor_speed_rad_s
        guard = state.guard
        v = west.mean_wind_m_s
        # wave frequency (AR(2) on the gauge)
        wstate, w_wave = self.wave.step(
            state.wave, frame.wave_elevation_gauge_measured_m, bool(mask & VALID_WAVE_GAUGE)
        )
        # platform KF at the nearest design wind
        j = self._nearest(v, i)
        if j != i:
            kf_state = kf_state._replace(x=kf_state.x + d.x_op[i, :8] - d.x_op[j, :8])
            i = j
        xo_i = d.x_op[i]
        u_kf = (omega - float(xo_i[8]), pitch - float(xo_i[9]))
        raw = (
            frame.platform_surge_measured_m,
            frame.platform_pitch_measured_rad,
            frame.platform_pitch_rate_measured_rad_s,
            frame.nacelle_acc_fore_aft_measured_m_s2,
        )
        z = (raw[0] - float(xo_i[0]), raw[1] - float(xo_i[2]), raw[2], raw[3])
        last = state.last_z
        valid = (
            bool(mask & VALID_PLATFORM_SURGE) and raw[0] != last[0],
            bool(mask & VALID_PLATFORM_PITCH) and raw[1] != last[1],
            bool(mask & VALID_PLATFORM_PITCH_RATE) and raw[2] != last[2],
            bool(mask & VALID_NACELLE_ACC) and raw[3] != last[3],
        )
        kf = self.kfs[i]
        accepted = sum(kf_state.accepted)
        kf_state = kf.predict(kf_state, u_kf, dt_s)
        kf_state = kf.update(kf_state, z, valid, u_kf)
        # the guard (module docstring, step 2): the EKF gated, clamped or not finite, or the
        # KF rejecting every valid channel or not finite, is a bad step
        kf_finite = bool(np.isfinite(kf_state.x).all() and np.isfinite(kf_state.P).all())
        kf_bad = any(valid) and sum(kf_state.accepted) == accepted
        guard, diverged = guard_step(
            guard, bad or kf_bad or not kf_finite, dt_s, self.guard_config, v
        )
        if diverged or not kf_finite:
            # restart both observers at the measured speed and the last good mean wind
            held = guard.held_wind_m_s if math.isfinite(guard.held_wind_m_s) else v
            ekf_state = self.ekf.initial_state(
                omega_meas if speed_ok else self.omega_rated, pitch, torque, held
            )
            kf_state = kf.initial_state()
            if not kf_finite and not guard.fallback:
                guard = guard._replace(faults=guard.faults + 1, fallback=True, good_s=0.0)
        if guard.fallback and math.isfinite(guard.held_wind_m_s):
            v = guard.held_wind_m_s  # the fallback: the last good estimate, held
        x_abs = kf_state.x + xo_i[:8]
        x_lqr = x_abs.copy()
        if s.platform_states == "measured":
            if mask & VALID_PLATFORM_SURGE:
                x_lqr[0] = raw[0]
            if mask & VALID_PLATFORM_PITCH:
                x_lqr[2] = raw[1]
            if mask & VALID_PLATFORM_PITCH_RATE:
                x_lqr[6] = raw[2]
        # LQR on the deviation from the operating point at the scheduling wind
        xop = d.operating_point(v)
        psi = state.rotor_angle_rad + (omega - self.omega_rated) * dt_s
        psi = min(max(psi, -self.psi_max), self.psi_max)
        zt = np.empty(12)
        zt[:8] = x_lqr - xop[:8]
        zt[8] = omega - self.omega_rated
        zt[9] = pitch - xop[9]
        zt[10] = psi
        zt[11] = beta_c - xop[9]
        k = d.gain(v, w_wave)
        rate = -float(k @ zt)
        rate = min(max(rate, -self.rate_max), self.rate_max)
        beta_c = min(max(beta_c + rate * dt_s, self.pitch_min), self.pitch_max)
        degraded = kf_state.degraded or speed_misses > self._k_miss or guard.fallback
        new = LqrWaveState(
            ekf=ekf_state,
            kf=kf_state,
            kf_index=i,
            wave=wstate,
            rotor_angle_rad=psi,
            pitch_demand_rad=beta_c,
            last_z=raw,
            last_pitch_cmd_rad=beta_c,
            speed_misses=speed_misses,
            guard=guard,
        )
        out = ControlOutput(
            blade_pitch_commanded_rad=beta_c,
            generator_torque_commanded_nm=self.torque_nm,
            regime=REGIME_REGION_3,
            generator_speed_filtered_rad_s=omega * s.gearbox_ratio,
            pitch_integrator_rad=psi,
            gain_schedule_factor=max(v, 0.0),
            estimates_valid_mask=EST_WIND_SPEED
            | EST_PLATFORM_PITCH
            | EST_PLATFORM_PITCH_RATE
            | EST_PLATFORM_SURGE
            | EST_PLATFORM_SURGE_VELOCITY
            | EST_TOWER_TOP_VELOCITY,
            estimator_degraded=int(degraded),
            wind_speed_estimated_m_s=west.wind_m_s,
            platform_surge_estimated_m=float(x_abs[0]),
            platform_pitch_estimated_rad=float(x_abs[2]),
            platform_surge_velocity_estimated_m_s=float(x_abs[4]),
            platform_pitch_rate_estimated_rad_s=float(x_abs[6]),
            tower_top_velocity_estimated_m_s=float(
                sum(j * v for j, v in zip(self.hub_lever, x_abs[4:8], strict=True))
            ),
            estimator_faults=guard.faults,
        )
        return new, out
