"""Heading controllers of the Hexicon H3 platform: the seed's bang-bang and an OSQP MPC.

Both are pure cores ``step(state, measurement, dt) -> (state, command)`` commanding the three
turbines' pitch and generator torque from one measurement of the platform. The heading error
is e = wrap(β - ψ) (β: met-mast wind direction, ψ: platform heading; e > 0: the platform lags
the wind). The pitch floor is the rated pitch θ_r(V) at the met wind speed (power limit:
P_i <= P_rated holds for θ_i >= θ_r(V)); the ceiling is 25°. Torque: K ω_g² below rated speed,
P_rated/(η ω_g) above (the same law on every turbine).

bang_bang (ayotte-2015 section 5.3): e > 0 -> θ_1 = θ_3 = 25°, θ_2 = θ_r(V); otherwise
θ_1 = θ_3 = θ_r(V), θ_2 = 25°.

mpc: linear model about e = 0 sampled at the control period T_s, with inputs w_i = g(V)
(θ_i - θ_r(V)) (the thrust each turbine sheds, N, g the secant thrust-per-pitch slope of the
design data) and the measured wind-direction rate β' as a disturbance::

    e_{k+1} = e_k - T_s r_k + T_s β'_k
    r_{k+1} = (1 - T_s d / I) r_k - (T_s / I) Σ_i y_i w_{i,k}

(d = 2 c r_n: the quadratic drag c r|r| linearised at r_n; Σ y_i T_0 = 0 by the layout's
symmetry). Cost Σ q_e e_k² + q_r r_k² + r_w |w_k|² + ρ Σ w (the linear term charges the shed
thrust, a proxy of lost power); constraints 0 <= w <= g (25° - θ_r), |w_k - w_{k-1}| <= g θ'_max
T_s. One sparse QP per period, set up once and warm-started (OSQP); a solve that fails or
exceeds its time budget holds the previous input and is counted as an overrun.
"""

from __future__ import annotations

import json
import math
import time
from bisect import bisect_right
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import osqp
import scipy.sparse as sp

__all__ = [
    "BangBangState",
    "HexiconCommand",
    "HexiconDesign",
    "HexiconMeasurement",
    "IdMpcConfig",
    "IdMpcState",
    "IdentifiedModel",
    "MpcConfig",
    "MpcState",
    "PrbsExcitation",
    "PrbsState",
    "bang_bang_step",
    "id_mpc_step",
    "load_design",
    "load_identified",
    "make_id_mpc",
    "make_mpc",
    "make_prbs",
    "mpc_step",
    "prbs",
    "prbs_step",
]


class HexiconMeasurement(NamedTuple):
    """One control-period measurement (SI, rad)."""

    heading_rad: float
    yaw_rate_rad_s: float
    wind_direction_rad: float
    wind_speed_m_s: float
    rotor_speeds_rad_s: tuple[float, float, float]


class HexiconCommand(NamedTuple):
    """Per-turbine pitch (rad) and HSS generator torque (N m) demands."""

    pitch_rad: tuple[float, float, float]
    torque_nm: tuple[float, float, float]


@dataclass(frozen=True)
class HexiconDesign:
    """Design data of ``controller/presets/hexicon_h3_control.json`` (see controller.design)."""

    wind_grid_m_s: tuple[float, ...]
    rated_pitch_deg: tuple[float, ...]
    thrust_slope_n_per_rad: tuple[float, ...]
    pitch_max_deg: float
    turbine_x_m: tuple[float, ...]
    turbine_y_m: tuple[float, ...]
    yaw_inertia_kg_m2: float
    drag_constant_kg_m2: float
    torque_gain_nm_s2: float
    rated_rotor_speed_rad_s: float
    rated_power_w: float
    generator_efficiency: float
    gearbox_ratio: float
    torque_max_nm: float

    def __post_init__(self) -> None:
        n = len(self.wind_grid_m_s)
        if n < 2 or len(self.rated_pitch_deg) != n or len(self.thrust_slope_n_per_rad) != n:
            raise ValueError(
                "HexiconDesign: expected wind_grid_m_s, rated_pitch_deg and "
                "thrust_slope_n_per_rad of one length >= 2"
            )
        if len(self.turbine_x_m) != 3 or len(self.turbine_y_m) != 3:
            raise ValueError("HexiconDesign: expected 3 turbine positions (m)")
        if not (self.yaw_inertia_kg_m2 > 0 and self.drag_constant_kg_m2 > 0):
            raise ValueError("HexiconDesign: expected yaw inertia and drag constant > 0 (kg m^2)")

    def _interp(self, table: tuple[float, ...], v: float) -> float:
        xs = self.wind_grid_m_s
        if v <= xs[0]:
            return table[0]
        if v >= xs[-1]:
            return table[-1]
        i = bisect_right(xs, v) - 1
        a = (v - xs[i]) / (xs[i + 1] - xs[i])
        return table[i] + (table[i + 1] - table[i]) * a

    def rated_pitch_rad(self, wind_m_s: float) -> float:
        """θ_r(V) (rad), linear in the design table."""
        return math.radians(self._interp(self.rated_pitch_deg, wind_m_s))

    def thrust_slope(self, wind_m_s: float) -> float:
        """g(V) (N/rad)."""
        return self._interp(self.thrust_slope_n_per_rad, wind_m_s)

    def torque_nm(self, omega_rad_s: float) -> float:
        """K ω_g² below rated speed (blended over the last 5 %), P/(η ω_g) above, <= T_max."""
        wg = max(omega_rad_s, 0.0) * self.gearbox_ratio
        wr = self.rated_rotor_speed_rad_s * self.gearbox_ratio
        q_rated = self.rated_power_w / (self.generator_efficiency * wr)
        if wg < wr:
            q = self.torque_gain_nm_s2 * wg * wg
            blend = 0.95 * wr
            if wg > blend:
                q0 = self.torque_gain_nm_s2 * blend * blend
                q = q0 + (q_rated - q0) * (wg - blend) / (wr - blend)
        else:
            q = self.rated_power_w / (self.generator_efficiency * wg)
        return min(max(q, 0.0), self.torque_max_nm)


def load_design(path: str | Path | None = None) -> HexiconDesign:
    """Load the shipped design data (or a JSON file of the same keys)."""
    if path is None:
        text = (resources.files("controller.presets") / "hexicon_h3_control.json").read_text()
    else:
        text = Path(path).read_text(encoding="utf-8")
    raw: dict[str, Any] = json.loads(text)
    keys = HexiconDesign.__dataclass_fields__.keys()
    missing = [k for k in keys if k not in raw]
    if missing:
        raise ValueError(f"hexicon design data: missing keys {missing}")
    vals = {k: tuple(raw[k]) if isinstance(raw[k], list) else raw[k] for k in keys}
    return HexiconDesign(**vals)  # type: ignore[arg-type]  # checked in __post_init__


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def _filter_direction(prev: float | None, beta: float, dt: float, tau: float) -> float:
    """First-order low-pass of the wind direction (rad): β_f += min(1, dt/τ) wrap(β - β_f)."""
    if prev is None or tau <= 0:
        return beta
    return prev + min(1.0, dt / tau) * _wrap(beta - prev)


def _torques(design: HexiconDesign, m: HexiconMeasurement) -> tuple[float, float, float]:
    t = tuple(design.torque_nm(w) for w in m.rotor_speeds_rad_s)
    return (t[0], t[1], t[2])


# ---------------------------------------------------------------------- bang-bang
@dataclass(frozen=True)
class BangBangState:
    """Counts of the bang-bang core (no memory is needed by the law itself)."""

    steps: int = 0
    switches: int = 0
    last_sign: int = 0


def bang_bang_step(
    state: BangBangState, m: HexiconMeasurement, dt: float, design: HexiconDesign
) -> tuple[BangBangState, HexiconCommand]:
    """The seed's bang-bang heading law (module docstring); ``dt`` unused."""
    e = _wrap(m.wind_direction_rad - m.heading_rad)
    lo = design.rated_pitch_rad(m.wind_speed_m_s)
    hi = math.radians(design.pitch_max_deg)
    lo = min(lo, hi)
    sign = 1 if e > 0.0 else -1
    pitch = (hi, lo, hi) if sign > 0 else (lo, hi, lo)
    switches = state.switches + (1 if state.last_sign and sign != state.last_sign else 0)
    return BangBangState(state.steps + 1, switches, sign), HexiconCommand(
        pitch, _torques(design, m)
    )


# ---------------------------------------------------------------------- MPC
@dataclass(frozen=True)
class MpcConfig:
    """MPC tuning.

    Parameters
    ----------
    period_s : float
        Control period T_s (s), > 0.
    horizon : int
        Prediction steps N, 2..400.
    q_error, q_rate : float
        Weights on e² (1/rad²) and r² (s²/rad²).
    r_input : float
        Weight on (w / 1e5 N)².
    rho_power : float
        Linear weight on w / 1e5 N (the shed-thrust/power penalty).
    pitch_rate_max_deg_s : float
        Rate limit of the pitch demand (deg/s), > 0.
    drag_linearisation_rate_deg_s : float
        r_n of the drag linearisation (deg/s), > 0.
    time_budget_s : float
        A solve longer than this is an overrun (s), > 0.
    direction_filter_s : float
        Time constant τ of the first-order low-pass on the measured wind direction (s),
        >= 0 (0: none): β_f += min(1, T_s/τ) (β_m - β_f); the vane's noise would otherwise
        enter e and β' at every period.
    rate_filter_s : float
        Time constant of the low-pass on the direction rate β' (s), > 0.
    estimator : bool
        Estimate (e, r) with the steady-state Kalman filter of the linear model (measured
        e and r with standard deviations ``sigma_error_rad``, ``sigma_rate_rad_s``; process
        noise ``q_error_rad``, ``q_rate_rad_s`` per period) instead of using the noisy
        measurement directly.
    """

    period_s: float = 1.0
    horizon: int = 60
    q_error: float = 5000.0
    q_rate: float = 50000.0
    r_input: float = 0.01
    rho_power: float = 0.02
    pitch_rate_max_deg_s: float = 2.0
    drag_linearisation_rate_deg_s: float = 0.2
    time_budget_s: float = 0.5
    direction_filter_s: float = 10.0
    rate_filter_s: float = 60.0
    estimator: bool = True
    sigma_error_rad: float = 2.6e-3
    sigma_rate_rad_s: float = 5e-5
    q_error_rad: float = 2e-4
    q_rate_rad_s: float = 5e-5

    def __post_init__(self) -> None:
        if not (self.period_s > 0 and 2 <= self.horizon <= 400):
            raise ValueError("MpcConfig: expected period_s > 0 s and 2 <= horizon <= 400 steps")
        for name in ("q_error", "q_rate", "r_input", "rho_power"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"MpcConfig.{name}: expected >= 0")
        for name in ("pitch_rate_max_deg_s", "drag_linearisation_rate_deg_s", "time_budget_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"MpcConfig.{name}: expected > 0")


_W_SCALE = 1.0e5  # N per unit of the QP's input variable


@dataclass
class MpcState:
    """Solver, previous input and counters (the solver object is the warm-start memory)."""

    config: MpcConfig
    design: HexiconDesign
    solver: Any
    n_x: int
    n_u: int
    l_vec: np.ndarray
    u_vec: np.ndarray
    prev_w: np.ndarray = field(default_factory=lambda: np.zeros(3))
    prev_dir: float | None = None
    dir_filt: float | None = None
    rate_filt: float = 0.0
    steps: int = 0
    overruns: int = 0
    solve_times_s: list[float] = field(default_factory=list)
    kalman_gain: np.ndarray | None = None
    x_hat: np.ndarray | None = None
    prev_pitch: np.ndarray | None = None


def _matrices(cfg: MpcConfig, d: HexiconDesign) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ts = cfg.period_s
    inertia = d.yaw_inertia_kg_m2
    lin_drag = 2.0 * d.drag_constant_kg_m2 * math.radians(cfg.drag_linearisation_rate_deg_s)
    a = np.array([[1.0, -ts], [0.0, 1.0 - ts * lin_drag / inertia]])
    b = np.zeros((2, 3))
    for i in range(3):
        b[1, i] = -ts * d.turbine_y_m[i] * _W_SCALE / inertia
    e = np.array([ts, 0.0])
    return a, b, e


def make_mpc(design: HexiconDesign, config: MpcConfig | None = None) -> MpcState:
    """Build and set up the sparse QP once (variables z = [x_0..x_N, w_0..w_{N-1}])."""
    cfg = config or MpcConfig()
    a, b, _ = _matrices(cfg, design)
    n = cfg.horizon
    nx, nu = 2, 3
    q = sp.diags([float(cfg.q_error), float(cfg.q_rate)])
    p_mat = sp.block_diag(
        [sp.kron(sp.eye(n + 1), q), sp.kron(sp.eye(n), cfg.r_input * sp.eye(nu))], format="csc"
    )
    q_vec = np.hstack([np.zeros((n + 1) * nx), cfg.rho_power * np.ones(n * nu)])
    ax = sp.kron(sp.eye(n + 1), -sp.eye(nx)) + sp.kron(sp.eye(n + 1, k=-1), sp.csc_matrix(a))
    bu = sp.kron(sp.vstack([sp.csc_matrix((1, n)), sp.eye(n)]), sp.csc_matrix(b))
    a_eq = sp.hstack([ax, bu])
    a_box = sp.hstack([sp.csc_matrix((n * nu, (n + 1) * nx)), sp.eye(n * nu)])
    diff = sp.eye(n) - sp.eye(n, k=-1)
    a_rate = sp.hstack([sp.csc_matrix((n * nu, (n + 1) * nx)), sp.kron(diff, sp.eye(nu))])
    a_all = sp.vstack([a_eq, a_box, a_rate], format="csc")
    n_eq = (n + 1) * nx
    l_vec = np.zeros(n_eq + 2 * n * nu)
    u_vec = np.zeros(n_eq + 2 * n * nu)
    solver = osqp.OSQP()
    solver.setup(
        p_mat,
        q_vec,
        a_all,
        l_vec,
        u_vec,
        verbose=False,
        warm_starting=True,
        eps_abs=1e-5,
        eps_rel=1e-5,
        max_iter=4000,
        polishing=True,
        time_limit=cfg.time_budget_s,
    )
    gain = None
    if cfg.estimator:
        import scipy.linalg  # noqa: PLC0415 - design-time only

        qn = np.diag([cfg.q_error_rad**2, cfg.q_rate_rad_s**2])
        rn = np.diag([cfg.sigma_error_rad**2, cfg.sigma_rate_rad_s**2])
        pn = scipy.linalg.solve_discrete_are(a.T, np.eye(2), qn, rn)
        gain = pn @ np.linalg.inv(pn + rn)
    return MpcState(cfg, design, solver, nx, nu, l_vec, u_vec, kalman_gain=gain)


def _bounds(st: MpcState, e0: float, r0: float, dbeta: float, wmax: float, dwmax: float) -> None:
    cfg = st.config
    n, nx, nu = cfg.horizon, st.n_x, st.n_u
    _, _, evec = _matrices(cfg, st.design)
    n_eq = (n + 1) * nx
    beq = np.tile(-evec * dbeta, n + 1)
    beq[:nx] = [-e0, -r0]
    st.l_vec[:n_eq] = beq
    st.u_vec[:n_eq] = beq
    st.l_vec[n_eq : n_eq + n * nu] = 0.0
    st.u_vec[n_eq : n_eq + n * nu] = wmax
    r0_ = n_eq + n * nu
    st.l_vec[r0_:] = -dwmax
    st.u_vec[r0_:] = dwmax
    st.l_vec[r0_ : r0_ + nu] = st.prev_w - dwmax
    st.u_vec[r0_ : r0_ + nu] = st.prev_w + dwmax


def mpc_step(
    st: MpcState, m: HexiconMeasurement, dt: float
) -> tuple[MpcState, HexiconCommand, dict[str, float]]:
    """One MPC period: update bounds (state, β', V), warm-started solve, apply w_0.

    Returns the (mutated) state, the command and info {solve_s, overrun, status}.
    """
    d = st.design
    cfg = st.config
    st.dir_filt = _filter_direction(st.dir_filt, m.wind_direction_rad, dt, cfg.direction_filter_s)
    e0 = _wrap(st.dir_filt - m.heading_rad)
    r0 = m.yaw_rate_rad_s
    dbeta = 0.0
    if st.prev_dir is not None and dt > 0:
        step = _wrap(st.dir_filt - st.prev_dir)
        raw = max(-0.01, min(0.01, step / dt))  # not a step
        st.rate_filt += min(1.0, dt / cfg.rate_filter_s) * (raw - st.rate_filt)
        dbeta = st.rate_filt
        if st.kalman_gain is not None and st.x_hat is not None:
            # predict with the last input and the direction change, correct with (e, r)
            a_m, b_m, _ = _matrices(cfg, d)
            pred = a_m @ st.x_hat + b_m @ st.prev_w + np.array([step, 0.0])
            z = np.array([e0, r0])
            st.x_hat = pred + st.kalman_gain @ (z - pred)
            e0, r0 = float(st.x_hat[0]), float(st.x_hat[1])
    if st.kalman_gain is not None and st.x_hat is None:
        st.x_hat = np.array([e0, r0])
    st.prev_dir = st.dir_filt
    lo = d.rated_pitch_rad(m.wind_speed_m_s)
    hi = math.radians(d.pitch_max_deg)
    lo = min(lo, hi)
    g = d.thrust_slope(m.wind_speed_m_s)
    wmax = g * (hi - lo) / _W_SCALE
    dwmax = g * math.radians(cfg.pitch_rate_max_deg_s) * cfg.period_s / _W_SCALE
    st.prev_w = np.clip(st.prev_w, 0.0, wmax)
    _bounds(st, e0, r0, dbeta, wmax, dwmax)
    st.solver.update(l=st.l_vec, u=st.u_vec)
    t0 = time.perf_counter()
    res = st.solver.solve(raise_error=False)
    solve_s = time.perf_counter() - t0
    st.solve_times_s.append(solve_s)
    status = str(res.info.status)
    ok = status == "solved" and solve_s <= cfg.time_budget_s
    n_state = (cfg.horizon + 1) * st.n_x
    if ok:
        w = np.clip(np.asarray(res.x[n_state : n_state + st.n_u]), 0.0, wmax)
    else:
        st.overruns += 1
        w = st.prev_w.copy()
    # the actuator's limit is on the pitch: hold it to θ_prev ± θ'_max T_s (the floor θ_r(V)
    # and g(V) move with the measured wind), then the floor and ceiling
    th = lo + w * _W_SCALE / g
    if st.prev_pitch is not None:
        step = math.radians(cfg.pitch_rate_max_deg_s) * cfg.period_s
        th = np.clip(th, st.prev_pitch - step, st.prev_pitch + step)
    th = np.clip(th, lo, hi)
    w = g * (th - lo) / _W_SCALE
    st.prev_pitch = th
    st.prev_w = w
    st.steps += 1
    pitch = tuple(float(v) for v in th)
    cmd = HexiconCommand((pitch[0], pitch[1], pitch[2]), _torques(d, m))
    return st, cmd, {"solve_s": solve_s, "overrun": float(not ok), "status_solved": float(ok)}


# ---------------------------------------------------------------------- PRBS excitation
def prbs(n: int, hold_min: int, hold_max: int, rng: np.random.Generator) -> np.ndarray:
    """A binary (0/1) signal of n samples switching after random holds in [hold_min, hold_max].

    The identification input of ayotte-2015 section 3.4 (a pseudo-random binary sequence
    whose hold times set its band: 1/(hold_max T_s) .. 1/(hold_min T_s)).
    """
    if not (n >= 1 and 1 <= hold_min <= hold_max):
        raise ValueError(
            f"prbs: expected n >= 1 and 1 <= hold_min <= hold_max, got {n, hold_min, hold_max}"
        )
    out = np.zeros(n)
    level, k = float(rng.integers(0, 2)), 0
    while k < n:
        h = int(rng.integers(hold_min, hold_max + 1))
        out[k : k + h] = level
        level = 1.0 - level
        k += h
    return out


@dataclass(frozen=True)
class PrbsExcitation:
    """The pitch side of one table-5 experiment, as a controller core.

    θ_i(k) = max(θ_lo + (θ_hi - θ_lo) s_i(k), θ_r(V_k)) with s_i three independent PRBS
    (:func:`prbs`, streams ``[seed, experiment, 2 + i]``), V_k the measured met wind speed;
    torque by the turbines' law. ``step(k, measurement)`` answers cycle k.
    """

    pitch_lo_deg: float
    pitch_hi_deg: float
    n_samples: int
    experiment: int
    seed: int = 0
    hold_min: int = 10
    hold_max: int = 100

    def signals(self) -> np.ndarray:
        """The three 0/1 sequences (3 x n)."""
        return np.vstack(
            [
                prbs(
                    self.n_samples,
                    self.hold_min,
                    self.hold_max,
                    np.random.default_rng([self.seed, self.experiment, 2 + i]),
                )
                for i in range(3)
            ]
        )


@dataclass
class PrbsState:
    """The excitation's sequences and cycle counter."""

    spec: PrbsExcitation
    levels: np.ndarray
    steps: int = 0


def make_prbs(spec: PrbsExcitation) -> PrbsState:
    return PrbsState(spec, spec.signals())


def prbs_step(
    st: PrbsState, m: HexiconMeasurement, design: HexiconDesign
) -> tuple[PrbsState, HexiconCommand]:
    """Pitches of the current cycle (held at the last value past the sequence's end)."""
    s = st.spec
    k = min(st.steps, st.levels.shape[1] - 1)
    floor = design.rated_pitch_rad(m.wind_speed_m_s)
    pitch = tuple(
        max(
            math.radians(s.pitch_lo_deg + (s.pitch_hi_deg - s.pitch_lo_deg) * st.levels[i, k]),
            floor,
        )
        for i in range(3)
    )
    st.steps += 1
    return st, HexiconCommand((pitch[0], pitch[1], pitch[2]), _torques(design, m))


# ---------------------------------------------------------------------- MPC on the identified model
@dataclass(frozen=True)
class IdentifiedModel:
    """An identified discrete model (``controller/presets/hexicon_h3_identified.json``).

    x_{k+1} = A x_k + B (u_k - ū), y_k = C x_k + D (u_k - ū) + ȳ with u = (V m/s, β deg,
    θ_1, θ_2, θ_3 deg), y = (yaw rate deg/s, platform power MW), sampled every
    ``sample_time_s``; ``kalman_gain`` L (n x 2) of the steady-state filter
    x̂ += L (y - ŷ). Written by ``fowt hexicon identify`` (:mod:`hil.hexicon.identify`).
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    u_mean: np.ndarray
    y_mean: np.ndarray
    kalman_gain: np.ndarray
    sample_time_s: float

    def __post_init__(self) -> None:
        n = self.a.shape[0]
        shapes = {
            "a": (n, n),
            "b": (n, 5),
            "c": (2, n),
            "d": (2, 5),
            "u_mean": (5,),
            "y_mean": (2,),
            "kalman_gain": (n, 2),
        }
        for name, shape in shapes.items():
            got = getattr(self, name).shape
            if got != shape:
                raise ValueError(f"IdentifiedModel.{name}: expected shape {shape}, got {got}")
        if not self.sample_time_s > 0:
            raise ValueError("IdentifiedModel.sample_time_s: expected > 0 s")


def load_identified(path: str | Path | None = None) -> IdentifiedModel:
    """Load the identified-model artefact (default: the shipped one in controller/presets)."""
    if path is None:
        text = (resources.files("controller.presets") / "hexicon_h3_identified.json").read_text()
    else:
        text = Path(path).read_text(encoding="utf-8")
    raw = json.loads(text)
    try:
        return IdentifiedModel(
            a=np.asarray(raw["a"], dtype=float),
            b=np.asarray(raw["b"], dtype=float),
            c=np.asarray(raw["c"], dtype=float),
            d=np.asarray(raw["d"], dtype=float),
            u_mean=np.asarray(raw["u_mean"], dtype=float),
            y_mean=np.asarray(raw["y_mean"], dtype=float),
            kalman_gain=np.asarray(raw["kalman_gain"], dtype=float),
            sample_time_s=float(raw["sample_time_s"]),
        )
    except KeyError as exc:
        raise ValueError(
            f"identified model {path or 'hexicon_h3_identified.json'}: missing key {exc}"
        ) from exc


@dataclass(frozen=True)
class IdMpcConfig:
    """Tuning of the MPC on the identified model (units: deg, MW; see :func:`make_id_mpc`)."""

    horizon: int = 30
    q_error: float = 1.0
    r_input: float = 1e-3
    r_rate: float = 1e-2
    rho_power: float = 0.05
    pitch_rate_max_deg_s: float = 2.0
    time_budget_s: float = 0.5
    direction_filter_s: float = 10.0
    rate_filter_s: float = 60.0

    def __post_init__(self) -> None:
        if not 2 <= self.horizon <= 400:
            raise ValueError("IdMpcConfig.horizon: expected 2..400 steps")
        if not self.direction_filter_s >= 0:
            raise ValueError("IdMpcConfig.direction_filter_s: expected >= 0 s")
        for name in ("q_error", "r_input", "r_rate", "rho_power"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"IdMpcConfig.{name}: expected >= 0")
        for name in ("pitch_rate_max_deg_s", "time_budget_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"IdMpcConfig.{name}: expected > 0")


@dataclass
class IdMpcState:
    """Solver, observer state x̂ and counters of the identified-model MPC."""

    config: IdMpcConfig
    design: HexiconDesign
    model: IdentifiedModel
    solver: Any
    l_vec: np.ndarray
    u_vec: np.ndarray
    q_vec: np.ndarray
    x_hat: np.ndarray
    statuses: dict[str, int] = field(default_factory=dict)
    prev_pitch_deg: np.ndarray | None = None
    prev_dir: float | None = None
    dir_filt: float | None = None
    rate_filt: float = 0.0
    steps: int = 0
    overruns: int = 0
    solve_times_s: list[float] = field(default_factory=list)


def make_id_mpc(
    design: HexiconDesign, model: IdentifiedModel, config: IdMpcConfig | None = None
) -> IdMpcState:
    """The QP of the MPC on the identified model, set up once (OSQP, warm-started).

    Variables z = [x_0..x_N, e_0..e_N, θ_0..θ_{N-1}] (x: identified state, e heading error
    deg, θ absolute pitch deg)::

        x_{k+1} = A x_k + B_θ θ_k + [B_d (d - d̄) - B_θ θ̄]
        e_{k+1} = e_k - T_s (C_r x_k + D_rθ θ_k) + T_s [β' - r̄ - D_rd (d - d̄) + D_rθ θ̄]

    with d = (V, β) measured and held over the horizon. Cost Σ q_e e_k² + r_θ |θ_k|²
    + r_Δ |θ_k - θ_{k-1}|² - ρ Σ P̂_k (P̂ = C_P x + D_Pθ θ, MW: the power the model predicts).
    Constraints θ_r(V) <= θ <= 25°, |θ_k - θ_{k-1}| <= θ'_max T_s.
    """
    cfg = config or IdMpcConfig()
    m = model
    n, nn = cfg.horizon, m.a.shape[0]
    ts = m.sample_time_s
    bth = m.b[:, 2:]
    nx = (n + 1) * nn
    ne = n + 1
    nu = 3 * n
    nz = nx + ne + nu
    # cost
    diff = sp.eye(n) - sp.eye(n, k=-1)
    dd = sp.kron(diff.T @ diff, sp.eye(3))
    p_u = cfg.r_input * sp.eye(nu) + cfg.r_rate * dd
    p_mat = sp.block_diag([sp.csc_matrix((nx, nx)), cfg.q_error * sp.eye(ne), p_u], format="csc")
    q_vec = np.zeros(nz)
    cp, dpth = m.c[1], m.d[1, 2:]
    for k in range(n):
        q_vec[k * nn : (k + 1) * nn] -= cfg.rho_power * cp
        q_vec[nx + ne + 3 * k : nx + ne + 3 * k + 3] -= cfg.rho_power * dpth
    # dynamics: rows (n+1) nn for x, (n+1) for e
    ax = sp.kron(sp.eye(n + 1), -sp.eye(nn)) + sp.kron(sp.eye(n + 1, k=-1), sp.csc_matrix(m.a))
    bu = sp.kron(sp.vstack([sp.csc_matrix((1, n)), sp.eye(n)]), sp.csc_matrix(bth))
    row_x = sp.hstack([ax, sp.csc_matrix((nx, ne)), bu])
    cr, drth = m.c[0:1], m.d[0:1, 2:]
    ex = sp.kron(sp.eye(n + 1, k=-1), sp.csc_matrix(-ts * cr))
    ee = -sp.eye(n + 1) + sp.eye(n + 1, k=-1)
    eu = sp.kron(sp.vstack([sp.csc_matrix((1, n)), sp.eye(n)]), sp.csc_matrix(-ts * drth))
    row_e = sp.hstack([ex, ee, eu])
    a_box = sp.hstack([sp.csc_matrix((nu, nx + ne)), sp.eye(nu)])
    a_rate = sp.hstack([sp.csc_matrix((nu, nx + ne)), sp.kron(diff, sp.eye(3))])
    a_all = sp.vstack([row_x, row_e, a_box, a_rate], format="csc")
    n_rows = a_all.shape[0]
    l_vec = np.zeros(n_rows)
    u_vec = np.zeros(n_rows)
    solver = osqp.OSQP()
    solver.setup(
        p_mat,
        q_vec,
        a_all,
        l_vec,
        u_vec,
        verbose=False,
        warm_starting=True,
        eps_abs=1e-3,
        eps_rel=1e-3,
        max_iter=8000,
        polishing=False,
        adaptive_rho=True,
        time_limit=cfg.time_budget_s,
    )
    return IdMpcState(cfg, design, m, solver, l_vec, u_vec, q_vec, np.zeros(nn))


def id_mpc_step(
    st: IdMpcState, meas: HexiconMeasurement, power_w: float, dt: float
) -> tuple[IdMpcState, HexiconCommand, dict[str, float]]:
    """One period: observer correction with (r, P), QP, apply θ_0, observer prediction.

    ``power_w`` is the measured platform power (sum of the turbines' transducers).
    """
    cfg, m, d = st.config, st.model, st.design
    n, nn = cfg.horizon, m.a.shape[0]
    ts = m.sample_time_s
    st.dir_filt = _filter_direction(
        st.dir_filt, meas.wind_direction_rad, dt, cfg.direction_filter_s
    )
    beta_deg = math.degrees(st.dir_filt)
    dvec = np.array([meas.wind_speed_m_s, beta_deg])
    dev_d = dvec - m.u_mean[:2]
    lo = math.degrees(min(d.rated_pitch_rad(meas.wind_speed_m_s), math.radians(d.pitch_max_deg)))
    hi = d.pitch_max_deg
    prev = st.prev_pitch_deg if st.prev_pitch_deg is not None else np.full(3, lo)
    # observer correction (the pitch acting now is the previous demand)
    u_now = np.concatenate([dvec, prev]) - m.u_mean
    y = np.array([math.degrees(meas.yaw_rate_rad_s), power_w / 1e6])
    y_hat = m.c @ st.x_hat + m.d @ u_now + m.y_mean
    x0 = st.x_hat + m.kalman_gain @ (y - y_hat)
    e0 = math.degrees(_wrap(st.dir_filt - meas.heading_rad))
    dbeta = 0.0
    if st.prev_dir is not None and dt > 0:
        raw = max(-0.5, min(0.5, math.degrees(_wrap(st.dir_filt - st.prev_dir)) / dt))
        st.rate_filt += min(1.0, dt / cfg.rate_filter_s) * (raw - st.rate_filt)
        dbeta = st.rate_filt
    st.prev_dir = st.dir_filt
    bth, bd = m.b[:, 2:], m.b[:, :2]
    th_bar = m.u_mean[2:]
    cx = bd @ dev_d - bth @ th_bar
    ce = ts * (dbeta - m.y_mean[0] - float(m.d[0, :2] @ dev_d) + float(m.d[0, 2:] @ th_bar))
    nx, ne, nu = (n + 1) * nn, n + 1, 3 * n
    lv, uv = st.l_vec, st.u_vec
    beq = np.concatenate([-x0, np.tile(-cx, n)])
    lv[:nx] = beq
    uv[:nx] = beq
    eeq = np.full(ne, -ce)
    eeq[0] = -e0
    lv[nx : nx + ne] = eeq
    uv[nx : nx + ne] = eeq
    o = nx + ne
    lv[o : o + nu] = lo
    uv[o : o + nu] = hi
    o += nu
    dmax = cfg.pitch_rate_max_deg_s * dt
    lv[o : o + nu] = -dmax
    uv[o : o + nu] = dmax
    lv[o : o + 3] = prev - dmax
    uv[o : o + 3] = prev + dmax
    st.solver.update(l=lv, u=uv)
    t0 = time.perf_counter()
    res = st.solver.solve(raise_error=False)
    solve_s = time.perf_counter() - t0
    st.solve_times_s.append(solve_s)
    st.statuses[str(res.info.status)] = st.statuses.get(str(res.info.status), 0) + 1
    ok = str(res.info.status) == "solved" and solve_s <= cfg.time_budget_s
    if ok:
        # OSQP's tolerance (1e-3) may leave the rate limit by a hair: clip to it too
        th = np.clip(np.asarray(res.x[nx + ne : nx + ne + 3]), prev - dmax, prev + dmax)
        th = np.clip(th, lo, hi)
    else:
        st.overruns += 1
        th = np.clip(prev, lo, hi)
    st.prev_pitch_deg = th
    st.steps += 1
    st.x_hat = m.a @ x0 + m.b @ (np.concatenate([dvec, th]) - m.u_mean)
    pitch = tuple(math.radians(float(v)) for v in th)
    cmd = HexiconCommand((pitch[0], pitch[1], pitch[2]), _torques(d, meas))
    return st, cmd, {"solve_s": solve_s, "overrun": float(not ok), "status_solved": float(ok)}
