r"""Gain-scheduled LQRI pitch controller with torque look-up below rated (runtime core).

Loads the design artefact written by :func:`controller.design.design` (npz + json in
``controller/presets/designs/``); never imports ``plant``.

Per step (dt = T_s), with U the estimated wind speed used for scheduling:

1. Regime (hysteresis, disannio-2022 sect. 4.8 switches on the filtered wind): enter the
   pitch regime when U ≥ U_sw + h/2 or ω ≥ 1.02 ω_ref; leave it when U ≤ U_sw − h/2 and the
   previous pitch command is at the minimum. U_sw is the rated wind of the design model,
   h = ``switch_hysteresis_m_s`` of the design settings.
2. Below rated: T_g = min(K ω², T_rated) (disannio-2022 Tab. 10 look-up; optimal-TSR K),
   pitch to θ_min; the integrator is held bumpless for the switch (step 4).
3. Above rated: gains K_x(U), K_i(U) and the operating point x_op(U), θ_op(U) interpolated
   linearly on the wind grid (end values held):
   θ_c = θ_op − K_x (x − x_op) − K_i z,  z ← z + T_s (ω − ω_ref);  T_g = T_rated.
4. θ_c saturated to [θ_min, θ_max] and rate limited |Δθ_c| ≤ θ'_max T_s; anti-windup by
   back-calculation: when the limited command differs from the LQRI output, z is reset so
   that the LQRI output equals the applied command (also on entering the pitch regime).
5. Optional wave feedforward (al-2019 ch. 4; artefact ``<preset>_waveff.npz`` written by
   :func:`controller.design.wave_ff.write_wave_ff_artefact`), kind ∈ {"off", "balanced",
   "max_performance"}: a discrete filter per scheduled wind driven by the forecast
   η̂₀(t + t_d) (m),

   .. math::

       u_{ff,k} = g(U)\,(c\,z_k + d\,\hat\eta_k),\qquad z_{k+1} = A_d z_k + b\,\hat\eta_k,

   with g(U) of al-2019 Tab. 5-1 interpolated linearly in U. All designs' filters run every
   step on the same forecast (one batched product) and the output is interpolated linearly in
   U between the two bracketing designs (the nearest one where they differ in kind), so a
   change of U never restarts a filter: restarting from zero lost the filters' memory (their
   impulse responses keep 5-12 % of their energy beyond 30 s) and left the FF 30-50 % wrong
   for tens of seconds after each switch. Below
   ``torque_below_m_s`` (17 m/s) u_ff (N m) is added to the torque before its saturation and
   rate limit; above, u_ff (rad) is added to the LQRI pitch before saturation and rate limit
   and the anti-windup back-calculation uses the total command. A NaN forecast gives
   u_ff = 0 and holds the filter state. The filter must run at the design period T_s.
"""

from __future__ import annotations

import json
import math
from bisect import bisect_right
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

from controller.core import REGIME_REGION_2, REGIME_REGION_3, ControlOutput

__all__ = [
    "FEEDFORWARD_KINDS",
    "LqriController",
    "LqriDesign",
    "LqriMeasurement",
    "LqriState",
    "WaveFfDesign",
    "load_lqri_design",
    "load_wave_ff_design",
]

#: Accepted wave-feedforward settings (per scenario).
FEEDFORWARD_KINDS = ("off", "balanced", "max_performance")

_DESIGN_PACKAGE = "controller.presets.designs"


def _load_artefact(
    name_or_path: str | Path, suffix: str, what: str
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Arrays of ``<name>_<suffix>.npz`` and the parsed ``.json`` beside it.

    ``name_or_path``: a shipped design name (in :data:`_DESIGN_PACKAGE`) or a path to the npz.
    """
    if isinstance(name_or_path, Path) or str(name_or_path).endswith(".npz"):
        npz = Path(name_or_path)
        meta_text = npz.with_suffix(".json").read_text()
        with np.load(npz, allow_pickle=False) as z:
            arrays = {k: np.array(v) for k, v in z.items()}
    else:
        base = resources.files(_DESIGN_PACKAGE)
        ref = base / f"{name_or_path}_{suffix}.npz"
        if not ref.is_file():
            raise ValueError(f"no {what} {name_or_path!r} in {_DESIGN_PACKAGE}; run `fowt design`")
        with resources.as_file(ref) as path, np.load(path, allow_pickle=False) as z:
            arrays = {k: np.array(v) for k, v in z.items()}
        meta_text = (base / f"{name_or_path}_{suffix}.json").read_text()
    return arrays, json.loads(meta_text)


class LqriMeasurement(msgspec.Struct, frozen=True, kw_only=True):
    """What the observers give the LQRI each cycle (SI units).

    Attributes
    ----------
    wind_speed_estimate_m_s : float
        Rotor-effective wind estimate for scheduling and the regime switch (m/s).
    rotor_speed_rad_s : float
        Rotor (LSS) speed (rad/s).
    blade_pitch_rad : float
        Measured collective pitch (rad).
    platform_surge_m, platform_pitch_rad, tower_top_deflection_m : float
        Estimated positions (m, rad, m): tower-top deflection is the tower mode coordinate s.
    platform_surge_rate_m_s, platform_pitch_rate_rad_s, tower_top_deflection_rate_m_s : float
        Estimated rates.
    wave_elevation_forecast_m : float
        Predicted elevation η̂₀(t + t_d) at the platform (m); NaN when no forecast.
    """

    wind_speed_estimate_m_s: float
    rotor_speed_rad_s: float
    blade_pitch_rad: float
    platform_surge_m: float = 0.0
    platform_pitch_rad: float = 0.0
    tower_top_deflection_m: float = 0.0
    platform_surge_rate_m_s: float = 0.0
    platform_pitch_rate_rad_s: float = 0.0
    tower_top_deflection_rate_m_s: float = 0.0
    wave_elevation_forecast_m: float = math.nan


class LqriState(msgspec.Struct, frozen=True, gc=False):
    """Controller state between calls (all SI).

    ``integrator_rad`` is z = ∫(ω − ω_ref) dt (rad s); ``ff_state`` the states of all FF
    filters, an (m, n) array (None before the first FF step), ``ff_index`` the FF design
    nearest to the scheduling wind (−1: none); ``feedforward`` g·(c z + d η̂) in the unit of
    its input, also split into ``feedforward_pitch_rad`` and ``feedforward_torque_nm`` (the
    part applied to each command before limits; published for the log).
    """

    first_call: bool = True
    above_rated: bool = False
    integrator_rad: float = 0.0
    blade_pitch_commanded_rad: float = 0.0
    generator_torque_commanded_nm: float = 0.0
    feedforward: float = 0.0
    ff_index: int = -1
    ff_state: np.ndarray | None = None
    feedforward_pitch_rad: float = 0.0
    feedforward_torque_nm: float = 0.0


@dataclass(frozen=True, eq=False)
class LqriDesign:
    """Gain schedule and limits read from the artefact (see :func:`load_lqri_design`)."""

    wind_m_s: tuple[float, ...]
    k_x: tuple[tuple[float, ...], ...]
    k_i: tuple[float, ...]
    x_op: tuple[tuple[float, ...], ...]
    theta_op: tuple[float, ...]
    rated_torque_nm: float
    rated_rotor_speed_rad_s: float
    torque_gain_nm_s2: float
    torque_max_nm: float
    torque_rate_max_nm_s: float
    switch_wind_m_s: float
    hysteresis_m_s: float
    pitch_min_rad: float
    pitch_max_rad: float
    pitch_rate_max_rad_s: float
    control_period_s: float
    metadata: dict[str, object]


def load_lqri_design(name_or_path: str | Path = "iea15mw_volturnus") -> LqriDesign:
    """Load ``<name>_lqri.npz`` + ``.json`` (shipped name or a path to the npz)."""
    arrays, meta = _load_artefact(name_or_path, "lqri", "LQRI design")
    s = meta["settings"]
    sc = meta["scalars"]
    return LqriDesign(
        wind_m_s=tuple(float(v) for v in arrays["wind_m_s"]),
        k_x=tuple(tuple(float(v) for v in row) for row in arrays["k_x"]),
        k_i=tuple(float(v) for v in arrays["k_i"]),
        x_op=tuple(tuple(float(v) for v in row) for row in arrays["x_op"]),
        theta_op=tuple(float(v) for v in arrays["u_op"][:, 0]),
        rated_torque_nm=float(sc["rated_torque_nm"]),
        rated_rotor_speed_rad_s=float(sc["rated_rotor_speed_rad_s"]),
        torque_gain_nm_s2=float(sc["torque_gain_nm_s2"]),
        torque_max_nm=float(sc["torque_max_nm"]),
        torque_rate_max_nm_s=float(sc["torque_rate_max_nm_s"]),
        switch_wind_m_s=float(sc["rated_wind_m_s"]),
        hysteresis_m_s=float(s["switch_hysteresis_m_s"]),
        pitch_min_rad=float(s["pitch_min_rad"]),
        pitch_max_rad=float(s["pitch_max_rad"]),
        pitch_rate_max_rad_s=float(s["pitch_rate_max_rad_s"]),
        control_period_s=float(s["control_period_s"]),
        metadata=meta,
    )


@dataclass(frozen=True, eq=False)
class WaveFfDesign:
    """Wave-FF filters per scheduled wind, read from the artefact (:func:`load_wave_ff_design`).

    Attributes
    ----------
    wind_m_s : tuple of float
        Design winds (m/s), increasing.
    is_pitch : tuple of bool
        True where the filter output is pitch (rad), False for torque (N m).
    a : (m, n, n) array; b, c : (m, n) arrays; d : (m,) array
        Discrete filters at ``control_period_s``.
    control_period_s, delay_s : float
        T_s and the forecast preview t_d the filters expect (s).
    gain_table : dict
        ``{kind: (winds m/s, g)}`` of al-2019 Tab. 5-1.
    metadata : dict
        The json.
    """

    wind_m_s: tuple[float, ...]
    is_pitch: tuple[bool, ...]
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    control_period_s: float
    delay_s: float
    gain_table: dict[str, tuple[tuple[float, ...], tuple[float, ...]]]
    metadata: dict[str, object]

    def gain(self, kind: str, wind_m_s: float) -> float:
        """g(U) of ``kind`` (linear in U, ends held); 0 for ``"off"``."""
        if kind == "off":
            return 0.0
        winds, g = self.gain_table[kind]
        i, w = _interp(winds, wind_m_s)
        return (1.0 - w) * g[i] + w * g[min(i + 1, len(g) - 1)]


def load_wave_ff_design(name_or_path: str | Path = "iea15mw_volturnus") -> WaveFfDesign:
    """Load ``<name>_waveff.npz`` + ``.json`` (shipped name or a path to the npz)."""
    arrays, meta = _load_artefact(name_or_path, "waveff", "wave-FF design")
    st = meta["settings"]
    table = {
        k: (tuple(float(x) for x in v["wind_m_s"]), tuple(float(x) for x in v["g"]))
        for k, v in meta["gain_table"].items()
    }
    return WaveFfDesign(
        wind_m_s=tuple(float(v) for v in arrays["wind_m_s"]),
        is_pitch=tuple(bool(v) for v in arrays["is_pitch"]),
        a=arrays["a"].astype(np.float64),
        b=arrays["b"].astype(np.float64),
        c=arrays["c"].astype(np.float64),
        d=arrays["d"].astype(np.float64),
        control_period_s=float(st["control_period_s"]),
        delay_s=float(st["delay_s"]),
        gain_table=table,
        metadata=meta,
    )


def _interp(grid: tuple[float, ...], u: float) -> tuple[int, float]:
    """Cell index i and weight w so that value = (1 − w) v_i + w v_{i+1} (ends held)."""
    n = len(grid)
    if n == 1 or u <= grid[0]:
        return 0, 0.0
    if u >= grid[-1]:
        return n - 2, 1.0
    i = bisect_right(grid, u) - 1
    return i, (u - grid[i]) / (grid[i + 1] - grid[i])


class LqriController:
    """Pure core: ``step(state, measurement, dt_s) -> (state, ControlOutput)``.

    Parameters
    ----------
    design : LqriDesign
        Gain schedule (:func:`load_lqri_design`).
    wave_ff : WaveFfDesign, optional
        Wave-FF filters (:func:`load_wave_ff_design`); required unless ``feedforward="off"``.
    feedforward : str
        One of :data:`FEEDFORWARD_KINDS` (per scenario), default ``"off"``.
    """

    def __init__(
        self, design: LqriDesign, wave_ff: WaveFfDesign | None = None, feedforward: str = "off"
    ) -> None:
        if feedforward not in FEEDFORWARD_KINDS:
            raise ValueError(f"feedforward = {feedforward!r}, expected one of {FEEDFORWARD_KINDS}")
        if feedforward != "off" and wave_ff is None:
            raise ValueError(f"feedforward = {feedforward!r} needs a wave-FF design")
        self.design = design
        self.wave_ff = wave_ff
        self.feedforward = feedforward

    def _feedforward(
        self, state: LqriState, u: float, eta: float
    ) -> tuple[float, bool, int, np.ndarray | None]:
        """One step of every FF filter: (g·u_ff, is_pitch, nearest design, new filter states).

        :math:`u_{ff} = (1 - w)(c_i z_i + d_i \\hat\\eta) + w (c_{i+1} z_{i+1} + d_{i+1}
        \\hat\\eta)` with (i, w) the cell of U on the design grid; a NaN forecast holds all
        states and gives 0.
        """
        ff = self.wave_ff
        if ff is None or self.feedforward == "off":
            return 0.0, False, -1, None
        grid = ff.wind_m_s
        i, w = _interp(grid, u)
        j = min(i + 1, len(grid) - 1)
        if ff.is_pitch[i] != ff.is_pitch[j]:  # never blend a torque with a pitch filter
            i = j if w >= 0.5 else i
            j, w = i, 0.0
        near = j if w >= 0.5 else i
        zs = state.ff_state if state.ff_state is not None else np.zeros(ff.b.shape)
        if not math.isfinite(eta):
            return 0.0, ff.is_pitch[near], near, zs
        out_i = float(ff.c[i] @ zs[i]) + float(ff.d[i]) * eta
        out_j = float(ff.c[j] @ zs[j]) + float(ff.d[j]) * eta
        zn = np.matmul(ff.a, zs[:, :, None])[:, :, 0] + ff.b * eta
        out = (1.0 - w) * out_i + w * out_j
        return ff.gain(self.feedforward, u) * out, ff.is_pitch[near], near, zn

    def initial_state(self) -> LqriState:
        """State before the first call."""
        return LqriState()

    def step(
        self, state: LqriState, m: LqriMeasurement, dt_s: float
    ) -> tuple[LqriState, ControlOutput]:
        """Advance one control period (module docstring, steps 1-4).

        Parameters
        ----------
        state : LqriState
        m : LqriMeasurement
        dt_s : float
            Time since the previous call (s), > 0.

        Returns
        -------
        state : LqriState
        output : ControlOutput
            ``pitch_integrator_rad`` carries K_i z (rad), ``gain_schedule_factor`` the
            scheduling wind (m/s), ``generator_speed_filtered_rad_s`` the rotor speed used.
        """
        if not 0.0 < dt_s < math.inf:
            raise ValueError(f"dt_s must be finite and > 0 s, got {dt_s!r}")
        d = self.design
        u = m.wind_speed_estimate_m_s
        w = m.rotor_speed_rad_s
        if state.first_call:
            th_prev = min(max(m.blade_pitch_rad, d.pitch_min_rad), d.pitch_max_rad)
            tq_prev = d.torque_gain_nm_s2 * w * w
            above = u >= d.switch_wind_m_s
        else:
            th_prev = state.blade_pitch_commanded_rad
            tq_prev = state.generator_torque_commanded_nm
            above = state.above_rated
        h = 0.5 * d.hysteresis_m_s
        if not above and (u >= d.switch_wind_m_s + h or w >= 1.02 * d.rated_rotor_speed_rad_s):
            above = True
            entering = True
        else:
            entering = state.first_call
            if above and u <= d.switch_wind_m_s - h and th_prev <= d.pitch_min_rad + 1e-4:
                above = False

        i, a = _interp(d.wind_m_s, u)
        kx0, kx1 = d.k_x[i], d.k_x[i + 1] if len(d.k_x) > 1 else d.k_x[i]
        xo0, xo1 = d.x_op[i], d.x_op[i + 1] if len(d.x_op) > 1 else d.x_op[i]
        j = min(i + 1, len(d.k_i) - 1)
        ki = (1.0 - a) * d.k_i[i] + a * d.k_i[j]
        th_op = (1.0 - a) * d.theta_op[i] + a * d.theta_op[j]
        x = (
            m.platform_surge_m,
            m.platform_pitch_rad,
            m.tower_top_deflection_m,
            m.platform_surge_rate_m_s,
            m.platform_pitch_rate_rad_s,
            m.tower_top_deflection_rate_m_s,
            w,
            m.blade_pitch_rad,
        )
        fb = 0.0
        for k in range(8):
            kxk = (1.0 - a) * kx0[k] + a * kx1[k]
            xok = (1.0 - a) * xo0[k] + a * xo1[k]
            if k == 6:
                xok = d.rated_rotor_speed_rad_s
            elif k == 7:
                xok = th_op
            fb += kxk * (x[k] - xok)
        u_ff, ff_pitch, ff_idx, ff_z = self._feedforward(state, u, m.wave_elevation_forecast_m)
        ff_th = u_ff if (ff_pitch and above) else 0.0
        ff_tq = 0.0 if ff_pitch else u_ff
        z = state.integrator_rad
        lim = d.pitch_rate_max_rad_s * dt_s
        if above:
            if entering:  # bumpless: LQRI output equals the previous command
                z = (th_op - fb + ff_th - th_prev) / ki
            z += dt_s * (w - d.rated_rotor_speed_rad_s)
            th_raw = th_op - fb - ki * z + ff_th
            th = min(max(th_raw, d.pitch_min_rad), d.pitch_max_rad)
            th = min(max(th, th_prev - lim), th_prev + lim)
            if th != th_raw:  # anti-windup by back-calculation on the total command
                z = (th_op - fb + ff_th - th) / ki
            tq = d.rated_torque_nm + ff_tq
            regime = REGIME_REGION_3
        else:
            th = max(d.pitch_min_rad, th_prev - lim)
            tq = min(d.torque_gain_nm_s2 * w * w, d.rated_torque_nm) + ff_tq
            z = (th_op - fb - th) / ki
            regime = REGIME_REGION_2
        tq = min(max(tq, 0.0), d.torque_max_nm)
        tlim = d.torque_rate_max_nm_s * dt_s
        tq = min(max(tq, tq_prev - tlim), tq_prev + tlim)
        new = LqriState(
            first_call=False,
            above_rated=above,
            integrator_rad=z,
            blade_pitch_commanded_rad=th,
            generator_torque_commanded_nm=tq,
            feedforward=u_ff,
            ff_index=ff_idx,
            ff_state=ff_z,
            feedforward_pitch_rad=ff_th,
            feedforward_torque_nm=ff_tq,
        )
        out = ControlOutput(
            blade_pitch_commanded_rad=th,
            generator_torque_commanded_nm=tq,
            regime=regime,
            generator_speed_filtered_rad_s=w,
            pitch_integrator_rad=ki * z,
            gain_schedule_factor=u,
        )
        return new, out
