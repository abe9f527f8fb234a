"""casanovas-2014 controllers for the TLP below rated: energy capture from surge (section 4).

Kinds (``[controller] kind``), all pure cores ``step(state, frame, dt_s) -> (state, output)``:

* ``no_control``: pitch θ̄ = 0, torque the constant mean T̄_g (section 5.2).
* ``base_torque``: pitch 0, the NREL region-2 law T_g = K ω_g² on the measured generator speed
  (section 4.3; the seed applies it at every wind speed, so region 1.5 is not modelled).
* ``lqr_steady``: u = -K x̂ - Σ_j W_j X(t + jΔ), the ARE of the indefinite energy-maximising
  cost with its cross term and the sea state as decaying oscillator states (section 4.5, the
  oscillator block written as a kernel on the excitation preview: see
  :mod:`controller.design.casanovas`, item 4).
* ``lqr_finite``: finite-horizon LQR (section 4.6, appendix III): at every reset the backward
  Riccati equation and the affine equation (forced by the excitation over the horizon) are
  integrated (RK4, step = control period) from P(T) = 0, φ(T) = 0. The model and the horizon
  are time-invariant, so P(t) over the horizon is the same at every reset, and φ is linear in
  the excitation: by default (``riccati = "cached"``) P and the linear operator X ↦ φ (the
  same RK4 applied to unit pulses) are computed once at construction and a reset is one
  matrix product; ``riccati = "every_reset"`` re-integrates both equations at every reset as
  the seed does (same result to rounding, cost in ``bench/casanovas_table52.py``). Between
  resets
  u = -R⁻¹[(BᵀP(t) + Nᵀ) x̂ + Bᵀφ(t)]. Horizon T (default T₁), overlap δ (default 0.5), reset
  period T_R = (1 - δ) T.
* ``lqr_overlaid``: section 4.7: the same on the model with the linearised region-2 law folded
  into A; pitch = ψ, torque = K ω_g² + τ.

Deviations from the design, for table 5.2's "which deviation matters" runs (scenario keys of
the same names): ``pitch_limits_rad`` (:func:`make_casanovas`: ``symmetric_pitch_limit_deg``
θ_s gives [-θ_s, θ_s]; default [0°, 90°], the NREL 5 MW's, which clips the negative half of
the linear design's pitch); ``torque_weight_factor`` (r_τ / (½ρπR²), default the design's
0.1, which leaves the torque all but inert: the steady gain on ϖ is ~2e-6 of the region-2
law's slope); ``gamma_1_s`` (``lqr_steady``: the oscillator decay γ of the preview kernel,
default -1/T₁; -inf is the no-preview limit, kernel ≡ 0, u = -K x̂). A changed r_τ or γ
re-solves the steady ARE and kernel (:func:`controller.design.casanovas.are_gain`,
:func:`~controller.design.casanovas.preview_kernel`) and, for the finite-horizon kinds, the
Riccati trajectory, at construction.

The state x̂ = [ϖ, ξ - ξ̄, ξ̇, r₁..r₄] comes from a steady-state Kalman filter (designed offline)
on the measured rotor speed and surge, driven by the commands and by the current excitation
(preview sample 0). The seed assumes the full state known; the observer is the bench's price.

Observer guard: a correction whose innovation exceeds the physical gate
(:data:`INNOVATION_GATE_ROTOR` x the design's rotor speed, :data:`INNOVATION_GATE_SURGE_M`;
the steady-state filter has no innovation covariance at run time) is skipped and the step
is bad, as is a non-finite estimate; 5 s of bad steps (or a non-finite estimate) is an
estimator fault (``estimator_faults``, :func:`controller.estimators.guard_step`): the
observer restarts from the measurement, and the fallback, the region-2 law
T = K ω_g² (``base_torque``) at the design's pitch, commands until 10 s pass without a bad
step.

Preview (``preview``):

* ``"perfect"``: the excitation force X(t + jΔ), j < 81, Δ = 0.25 s, computed by the plant from
  its own wave field and sent as :class:`bus_schemas.messages.WavePreviewPerfect` (a bench
  oracle, as the seed's table 5.2 assumes); the node hands it to :meth:`accept_preview`.
* ``"forecast"``: a bank of causal FIR filters from the up-wave gauge to X(t + jΔ), designed at
  construction by frequency sampling of B(ω) X(ω) exp(i(ωjΔ - k(ω)L)) (the dispersion
  predictor of :mod:`controller.forecast` with the excitation transfer function X(ω) the
  design ships multiplied in); needs ``[waves] gauge_distance_m``.

Finite-horizon compute: the node measures each step (``ControllerStatus.compute_time_ns``);
the reset steps are every ``reset_steps`` cycles. A reset whose solve takes longer than the
control period (measured with the injected ``clock``) is discarded: the previous solution is
used (continued past its reset window, zero feed-forward beyond its horizon) and the reset
is retried next cycle; discarded resets are counted (``ControlOutput.gain_schedule_factor``
carries that count for these kinds).

This module never imports ``plant``.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from bus_schemas.messages import SensorFrame
from controller.estimators import GuardConfig, GuardState, guard_step
from controller.interface import REGIME_REGION_2, ActuatorLimits, ControlOutput

FloatArray = npt.NDArray[np.float64]

__all__ = [
    "CASANOVAS_KINDS",
    "CasanovasController",
    "CasanovasDesign",
    "ExcitationPreviewPredictor",
    "affine_solve",
    "finite_horizon_solve",
    "load_casanovas_design",
    "make_casanovas",
    "riccati_trajectory",
]

#: The observer's innovation gates (module docstring): rotor speed as a fraction of the
#: design's rotor speed [-] and surge [m], far beyond the filter's steady innovations.
INNOVATION_GATE_ROTOR = 0.2
INNOVATION_GATE_SURGE_M = 10.0

CASANOVAS_KINDS = ("no_control", "base_torque", "lqr_steady", "lqr_finite", "lqr_overlaid")
Preview = Literal["perfect", "forecast"]


@dataclass(frozen=True, eq=False)
class CasanovasDesign:
    """A design artefact of :mod:`controller.design.casanovas` (arrays + scalars + metadata)."""

    name: str
    arrays: dict[str, FloatArray]
    scalars: dict[str, float]
    meta: dict[str, Any]

    def __getitem__(self, key: str) -> FloatArray:
        return self.arrays[key]


def load_casanovas_design(name: str, design_dir: str | Path | None = None) -> CasanovasDesign:
    """Load design ``<name>.npz`` + ``.json`` (``design_dir``, ``$FOWT_DESIGN_DIR``, shipped).

    Raises
    ------
    ValueError
        If no such artefact exists (the message names ``python -m controller.design.casanovas``).
    """
    dirs: list[Path] = []
    if design_dir is not None:
        dirs.append(Path(design_dir))
    from controller.lqri import user_design_dir  # noqa: PLC0415

    dirs.append(user_design_dir())  # $FOWT_DESIGN_DIR or ~/.cache/fowt-hil/designs
    shipped = resources.files("controller.presets").joinpath("designs")
    for d in dirs:
        npz, js = d / f"{name}.npz", d / f"{name}.json"
        if npz.is_file() and js.is_file():
            return _load(name, npz.read_bytes(), js.read_text())
    npz_t, js_t = shipped.joinpath(f"{name}.npz"), shipped.joinpath(f"{name}.json")
    if npz_t.is_file() and js_t.is_file():
        return _load(name, npz_t.read_bytes(), js_t.read_text())
    raise ValueError(
        f"no casanovas design {name!r} (looked in {[str(d) for d in dirs]} and the shipped "
        "designs); create it with: python -m controller.design.casanovas --out DIR"
    )


def _load(name: str, npz_bytes: bytes, js: str) -> CasanovasDesign:
    import io  # noqa: PLC0415

    with np.load(io.BytesIO(npz_bytes)) as z:
        arrays = {k: np.asarray(z[k], dtype=np.float64) for k in z.files}
    meta = json.loads(js)
    if meta.get("kind") != "casanovas":
        raise ValueError(f"design {name!r}: kind {meta.get('kind')!r}, expected 'casanovas'")
    return CasanovasDesign(name, arrays, {k: float(v) for k, v in meta["scalars"].items()}, meta)


def riccati_trajectory(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray, n: FloatArray, m: int, h: float
) -> FloatArray:
    """P(t) of the finite-horizon Riccati equation at t = k h/2, k = 0 … 2m (RK4, step h/2).

    Ṗ = P B R⁻¹ Bᵀ P - Q_s - P A_s - A_sᵀ P, P(T = m h) = 0 (the seed's G = 0), with
    A_s = A - B R⁻¹ Nᵀ, Q_s = Q - N R⁻¹ Nᵀ (appendix III with S = Nᵀ). Shape (2m + 1, n_x, n_x).
    """
    rinv = np.linalg.inv(r)
    a_s = a - b @ rinv @ n.T
    a_t = a_s.T
    q_s = q - n @ rinv @ n.T
    s_m = b @ rinv @ b.T
    nx = a.shape[0]
    out = np.empty((2 * m + 1, nx, nx))
    p = np.zeros((nx, nx))
    out[2 * m] = p
    hh = 0.5 * h

    def deriv(pm: FloatArray) -> FloatArray:  # d/dτ, τ = T - t
        d: FloatArray = -(pm @ s_m @ pm) + q_s + pm @ a_s + a_t @ pm
        return d

    for k in range(2 * m, 0, -1):
        k1 = deriv(p)
        k2 = deriv(p + 0.5 * hh * k1)
        k3 = deriv(p + 0.5 * hh * k2)
        k4 = deriv(p + hh * k3)
        p = p + hh / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        p = 0.5 * (p + p.T)
        out[k - 1] = p
    return out


def affine_solve(
    p_half: FloatArray,
    a: FloatArray,
    b: FloatArray,
    r: FloatArray,
    n: FloatArray,
    e: FloatArray,
    force: FloatArray,
    h: float,
) -> FloatArray:
    """φ(t_k), k = 0 … m, of φ̇ = (P B R⁻¹ Bᵀ - A_sᵀ) φ - P E X(t), φ(T) = 0 (backward RK4).

    ``p_half`` from :func:`riccati_trajectory`; ``force`` X at t = k h/2, k = 0 … 2m [N], shape
    (2m + 1,) (result (m + 1, n_x)) or (2m + 1, F) for F histories at once (result
    (m + 1, n_x, F)). φ is linear in X, so ``force = I`` gives the operator X ↦ φ.
    """
    rinv = np.linalg.inv(r)
    a_t = (a - b @ rinv @ n.T).T
    s_m = b @ rinv @ b.T
    f2 = force.reshape(force.shape[0], -1)  # (2m + 1, F): F forcing histories at once
    m = (f2.shape[0] - 1) // 2
    pe = p_half @ e  # (2m + 1, n_x)
    ps = p_half @ s_m  # (2m + 1, n_x, n_x)
    mats = a_t[None] - ps
    nx = a.shape[0]
    phis = np.empty((m + 1, nx, f2.shape[1]))
    phi = np.zeros((nx, f2.shape[1]))
    phis[m] = phi
    for k in range(m, 0, -1):
        i0, i1, i2 = 2 * k, 2 * k - 1, 2 * k - 2
        g1 = np.outer(pe[i1], f2[i1])
        k1 = mats[i0] @ phi + np.outer(pe[i0], f2[i0])
        k2 = mats[i1] @ (phi + 0.5 * h * k1) + g1
        k3 = mats[i1] @ (phi + 0.5 * h * k2) + g1
        k4 = mats[i2] @ (phi + h * k3) + np.outer(pe[i2], f2[i2])
        phi = phi + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        phis[k - 1] = phi
    out: FloatArray = phis[:, :, 0] if force.ndim == 1 else phis
    return out


def finite_horizon_solve(
    a: FloatArray,
    b: FloatArray,
    q: FloatArray,
    r: FloatArray,
    n: FloatArray,
    e: FloatArray,
    force: FloatArray,
    h: float,
    p_half: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Finite-horizon LQR with affine forcing (appendix III), backward from P(T) = φ(T) = 0.

    u = -R⁻¹[(BᵀP + Nᵀ) x + Bᵀ φ] with P from :func:`riccati_trajectory` (or ``p_half``, the
    same trajectory computed before: it depends on neither the state nor the forcing) and φ
    from :func:`affine_solve`.

    Parameters
    ----------
    a, b, q, r, n : ndarray
        Model (n_x, n_x), (n_x, n_u) and cost Q (n_x, n_x), R (n_u, n_u), N (n_x, n_u).
    e : ndarray, shape (n_x,)
        Forcing column (state derivative per N of X).
    force : ndarray, shape (2 M + 1,)
        X at t = k h/2, k = 0 … 2M (horizon T = M h) [N].
    h : float
        Step [s].
    p_half : ndarray or None
        A precomputed :func:`riccati_trajectory` for this (a, b, q, r, n, M, h).

    Returns
    -------
    gains : ndarray, shape (M + 1, n_u, n_x)
        K(t_k) = R⁻¹(BᵀP(t_k) + Nᵀ).
    feedforward : ndarray, shape (M + 1, n_u)
        v(t_k) = R⁻¹Bᵀφ(t_k); u_k = -K_k x - v_k.
    """
    m = (force.size - 1) // 2
    if p_half is None:
        p_half = riccati_trajectory(a, b, q, r, n, m, h)
    phis = affine_solve(p_half, a, b, r, n, e, force, h)
    rinv_bt = np.linalg.solve(r, b.T)
    gains = np.einsum("ij,kjl->kil", rinv_bt, p_half[::2]) + np.linalg.solve(r, n.T)[None]
    ff = phis @ rinv_bt.T
    return gains, ff


class ExcitationPreviewPredictor:
    """Causal FIR bank from the up-wave gauge elevation to X̂(t + jΔ), j < n_preview [N].

    H_j(ω) = B(ω) X(ω) exp(i(ω jΔ - k(ω) L)), realised as in
    :class:`controller.forecast.DispersionPredictor` (frequency sampling, causal truncation,
    Tukey window); X(ω) interpolated from the design's table, zero outside it. Default length:
    1.1 L / c_g(ω_max) + 64 samples (the group delay of the shortest waves of the band); the
    forecast is complete once that much gauge history has arrived.
    """

    def __init__(
        self,
        omega_tf: FloatArray,
        x_tf: npt.NDArray[np.complex128],
        distance_m: float,
        depth_m: float,
        dt_s: float,
        preview_step_s: float,
        n_preview: int,
        n_taps: int | None = None,
        omega_band_rad_s: tuple[float, float] = (0.3, 2.0),
    ) -> None:
        from controller.forecast import (  # noqa: PLC0415
            _raised_cosine_band,
            _tukey,
            group_velocity_m_s,
            wavenumber_rad_m,
        )

        if not distance_m > 0:
            raise ValueError(
                f"forecast preview: gauge distance {distance_m!r} m, expected > 0 m up-wave"
            )
        if n_taps is None:  # the slowest component's group delay L/c_g(ω_max), + 10 %
            cg = float(group_velocity_m_s(np.array([omega_band_rad_s[1]]), depth_m)[0])
            n_taps = math.ceil(1.1 * distance_m / cg / dt_s) + 64
        self.n_taps = n_taps
        mm = 8 * n_taps
        omega = np.asarray(2 * math.pi * np.fft.rfftfreq(mm, d=dt_s), np.float64)
        band = _raised_cosine_band(omega, omega_band_rad_s[0], omega_band_rad_s[1], 0.05)
        k = wavenumber_rad_m(omega, depth_m)
        xr = np.interp(omega, omega_tf, x_tf.real, left=0.0, right=0.0)
        xi = np.interp(omega, omega_tf, x_tf.imag, left=0.0, right=0.0)
        base = band * (xr + 1j * xi) * np.exp(-1j * k * distance_m)
        taps = np.empty((n_preview, n_taps))
        win = _tukey(n_taps, 0.05)
        for j in range(n_preview):
            hj = np.fft.irfft(base * np.exp(1j * omega * j * preview_step_s), mm)
            taps[j] = (hj[:n_taps] * win)[::-1]  # oldest-first
        self.taps = taps

    def init_state(self) -> FloatArray:
        """The gauge window, oldest first (zeros)."""
        return np.zeros(self.n_taps)

    def step(self, window: FloatArray, sample_m: float) -> tuple[FloatArray, FloatArray]:
        """Push η_gauge(t) [m]; return (new window, X̂(t + jΔ) [N])."""
        w = np.empty_like(window)
        w[:-1] = window[1:]
        w[-1] = sample_m
        return w, self.taps @ w


@dataclass(frozen=True, eq=False)
class CasanovasState:
    """State of a :class:`CasanovasController` (treated as immutable: each step makes a new one)."""

    started: bool = False
    x_hat: FloatArray = field(default_factory=lambda: np.zeros(0))
    u_prev: FloatArray = field(default_factory=lambda: np.zeros(2))
    force_prev_n: float = 0.0
    preview: FloatArray | None = None  # X(t + jΔ) [N] for the current cycle
    preview_seq: int = -1
    preview_stale: int = 0  # cycles run without the preview of their own frame (total)
    stale_now: bool = False  # this cycle did
    gauge_window: FloatArray | None = None
    gains: FloatArray | None = None
    feedforward: FloatArray | None = None
    since_reset: int = 0
    resets: int = 0
    overruns: int = 0
    guard: GuardState = field(default_factory=GuardState)


class CasanovasController:
    """One of :data:`CASANOVAS_KINDS` on a loaded design (module docstring)."""

    def __init__(
        self,
        kind: str,
        design: CasanovasDesign,
        control_period_s: float,
        *,
        preview: Preview = "perfect",
        horizon_s: float | None = None,
        overlap: float = 0.5,
        gauge_distance_m: float | None = None,
        pitch_limits_rad: tuple[float, float] = (0.0, math.radians(90.0)),
        riccati: Literal["cached", "every_reset"] = "cached",
        torque_weight_factor: float | None = None,
        gamma_1_s: float | None = None,
        clock: Callable[[], int] = time.perf_counter_ns,
    ) -> None:
        if kind not in CASANOVAS_KINDS:
            raise ValueError(f"unknown casanovas kind {kind!r}; expected one of {CASANOVAS_KINDS}")
        if preview not in ("perfect", "forecast"):
            raise ValueError(f"preview = {preview!r}, expected 'perfect' or 'forecast'")
        if not 0.0 <= overlap < 1.0:
            raise ValueError(f"overlap = {overlap!r}, expected 0 <= overlap < 1")
        if not (control_period_s > 0 and math.isfinite(control_period_s)):
            raise ValueError(f"control_period_s = {control_period_s!r}, expected > 0 s")
        self.kind = kind
        self.design = design
        self.dt = float(control_period_s)
        self.preview_mode: Preview = preview
        s = design.scalars
        self.t1_s = float(design.meta["settings"]["t1_s"])
        self.horizon_s = float(horizon_s) if horizon_s is not None else self.t1_s
        if not self.horizon_s > 0:
            raise ValueError(f"horizon_s = {horizon_s!r}, expected > 0 s")
        self.overlap = float(overlap)
        self.preview_step = s["preview_step_s"]
        self.n_preview = int(s["preview_samples"])
        max_h = self.preview_step * (self.n_preview - 1)
        if self.horizon_s > max_h + 1e-9:
            raise ValueError(f"horizon_s = {self.horizon_s} s exceeds the preview of {max_h} s")
        self.m_steps = max(1, round(self.horizon_s / self.dt))
        self.reset_steps = max(1, round((1.0 - self.overlap) * self.m_steps))
        if riccati not in ("cached", "every_reset"):
            raise ValueError(f"riccati = {riccati!r}, expected 'cached' or 'every_reset'")
        self.riccati = riccati
        self.clock = clock
        self.budget_ns = round(self.dt * 1e9)
        self.omega0 = s["rotor_speed_rad_s"]
        #: The observer's guard (module docstring, "Observer guard"): physical innovation
        #: gates [rad/s, m] and the divergence detector's times.
        self.innovation_gate = np.array(
            [INNOVATION_GATE_ROTOR * self.omega0, INNOVATION_GATE_SURGE_M]
        )
        self.guard_config = GuardConfig()
        self.t_bar = s["generator_torque_nm"]
        self.k_gen = s["torque_gain_nm_s2"]
        self.gear = s["gearbox_ratio"]
        self.surge_bar = s["surge_mean_m"]
        lo, hi = (float(v) for v in pitch_limits_rad)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(f"pitch_limits_rad = {pitch_limits_rad!r}, expected finite lo < hi")
        self.pitch_limits = (lo, hi)
        ar = design.arrays
        self.a = ar["a_base"] if kind == "lqr_overlaid" else ar["a"]
        self.b, self.e = ar["b"], ar["e"]
        self.q, self.r, self.n = ar["q"], ar["r"], ar["n"]
        self.k_steady = ar["steady_k"]
        self.w_steady = ar["steady_kernel"]
        lqr = kind in ("lqr_steady", "lqr_finite", "lqr_overlaid")
        if torque_weight_factor is not None:
            f = float(torque_weight_factor)
            if not lqr:
                raise ValueError(
                    f"torque_weight_factor is used only by the LQR kinds, not {kind!r}"
                )
            if not (math.isfinite(f) and f > 0):
                raise ValueError(f"torque_weight_factor = {torque_weight_factor!r}, expected > 0")
            # r_τ = ½ρπR² · factor (design item 2): rescale the design's entry
            self.r = self.r.copy()
            self.r[0, 0] *= f / float(design.meta["settings"]["torque_weight_factor"])
        self.gamma = s["gamma_1_s"]
        if gamma_1_s is not None:
            g = float(gamma_1_s)
            if kind != "lqr_steady":
                raise ValueError(f"gamma_1_s is used only by kind 'lqr_steady', not {kind!r}")
            if math.isnan(g) or g >= 0:
                raise ValueError(f"gamma_1_s = {gamma_1_s!r} 1/s, expected < 0 (-inf: no preview)")
            self.gamma = g
        if kind == "lqr_steady" and (torque_weight_factor is not None or gamma_1_s is not None):
            # the steady gain and its preview kernel for these weights (design module, item 4)
            from controller.design.casanovas import are_gain, preview_kernel  # noqa: PLC0415

            self.k_steady, p_are = are_gain(self.a, self.b, self.q, self.r, self.n)
            self.w_steady = preview_kernel(
                self.a, self.b, self.r, self.e, self.k_steady, p_are, self.gamma
            )
        self.obs = (ar["obs_ad"], ar["obs_bd"], ar["obs_ed"], ar["obs_c"], ar["obs_l"])
        # sample times of the finite-horizon forcing (half steps) on the preview grid
        self._t_half = 0.5 * self.dt * np.arange(2 * self.m_steps + 1)
        self._t_prev = self.preview_step * np.arange(self.n_preview)
        self._p_half = (
            riccati_trajectory(self.a, self.b, self.q, self.r, self.n, self.m_steps, self.dt)
            if kind in ("lqr_finite", "lqr_overlaid")
            else np.zeros((0, 0, 0))
        )
        # φ is linear in the forcing: with P cached, the whole affine solve of a reset is one
        # product with this (m + 1, n_u, 2m + 1) operator (the RK4 solution for X = unit pulses).
        self._ff_operator = np.zeros((0, 2, 0))
        self._gains_cached = np.zeros((0, 2, self.a.shape[0]))
        if kind in ("lqr_finite", "lqr_overlaid"):
            eye = np.eye(2 * self.m_steps + 1)
            phis = affine_solve(self._p_half, self.a, self.b, self.r, self.n, self.e, eye, self.dt)
            rinv_bt = np.linalg.solve(self.r, self.b.T)
            self._ff_operator = np.einsum("uk,jkf->juf", rinv_bt, phis)
            self._gains_cached = (
                np.einsum("ij,kjl->kil", rinv_bt, self._p_half[::2])
                + (np.linalg.solve(self.r, self.n.T)[None])
            )
        self.predictor: ExcitationPreviewPredictor | None = None
        if preview == "forecast" and kind in ("lqr_steady", "lqr_finite", "lqr_overlaid"):
            if gauge_distance_m is None:
                raise ValueError("preview = 'forecast' needs [waves] gauge_distance_m")
            x_tf = ar["excitation_re_n_m"] + 1j * ar["excitation_im_n_m"]
            self.predictor = ExcitationPreviewPredictor(
                ar["excitation_omega_rad_s"],
                x_tf,
                gauge_distance_m,
                s["water_depth_m"],
                self.dt,
                self.preview_step,
                self.n_preview,
            )

    # -------------------------------------------------------------- interface
    def initial_state(self) -> CasanovasState:
        """Not started: the first step initialises the observer from the measurement."""
        return CasanovasState()

    def actuator_limits(self) -> ActuatorLimits:
        """Pitch range and rates these cores respect (the NREL 5 MW's)."""
        return ActuatorLimits(
            self.pitch_limits[0], self.pitch_limits[1], math.radians(8.0), 15000.0
        )

    def accept_preview(
        self, state: CasanovasState, seq: int, force_n: FloatArray
    ) -> CasanovasState:
        """Take the perfect preview X(t + jΔ) [N] published with sensor frame ``seq``."""
        f = np.asarray(force_n, dtype=np.float64)
        if f.shape != (self.n_preview,) or not np.all(np.isfinite(f)):
            return state
        return replace(state, preview=f, preview_seq=int(seq))

    def step(
        self, state: CasanovasState, measurement: SensorFrame, dt_s: float
    ) -> tuple[CasanovasState, ControlOutput]:
        """One control cycle (module docstring)."""
        m = measurement
        gen_speed = m.generator_speed_measured_rad_s
        if self.kind == "no_control":
            return state, self._out(0.0, self.t_bar, gen_speed)
        if self.kind == "base_torque":
            return state, self._out(0.0, self.k_gen * gen_speed * gen_speed, gen_speed)
        # -- excitation over the horizon
        st = state
        preview: FloatArray
        if self.predictor is not None:
            window = st.gauge_window if st.gauge_window is not None else self.predictor.init_state()
            window, preview = self.predictor.step(window, m.wave_elevation_gauge_measured_m)
            st = replace(st, gauge_window=window)
        elif st.preview is not None and st.preview_seq == m.seq:
            preview = st.preview
            st = replace(st, stale_now=False)
        elif st.preview is not None:  # stale: shift the last one by the elapsed samples
            shift = (m.seq - st.preview_seq) * self.dt
            preview = np.interp(self._t_prev + shift, self._t_prev, st.preview, right=0.0)
            st = replace(st, preview_stale=st.preview_stale + 1, stale_now=True)
        else:
            preview = np.zeros(self.n_preview)
            st = replace(st, preview_stale=st.preview_stale + 1, stale_now=True)
        # -- observer
        y = np.array(
            [
                m.rotor_speed_measured_rad_s - self.omega0,
                m.platform_surge_measured_m - self.surge_bar,
            ]
        )
        ad, bd, ed, c, gain = self.obs
        bad = False
        if not st.started:
            x = np.zeros(self.a.shape[0])
            x[0], x[1] = y
        else:
            x = ad @ st.x_hat + bd @ st.u_prev + ed * st.force_prev_n
            innovation = y - c @ x
            # the guard's gate: an innovation beyond the physical gate is not corrected on
            if np.all(np.abs(innovation) <= self.innovation_gate):  # False for a NaN
                x = x + gain @ innovation
            else:
                bad = True
        if not np.all(np.isfinite(x)):
            bad = True
        guard, diverged = guard_step(st.guard, bad, self.dt, self.guard_config, math.nan)
        if diverged or not np.all(np.isfinite(x)):
            # divergence: the observer restarts from the measurement (as on the first step)
            x = np.zeros(self.a.shape[0])
            x[0], x[1] = np.nan_to_num(y)
            if not guard.fallback:
                guard = guard._replace(faults=guard.faults + 1, fallback=True, good_s=0.0)
        st = replace(st, started=True, x_hat=x, force_prev_n=float(preview[0]), guard=guard)
        if guard.fallback:  # the fallback: the region-2 law (base_torque), design pitch
            return st, self._out(
                self.design.scalars["pitch_rad"],
                self.k_gen * gen_speed * gen_speed,
                gen_speed,
                st,
                x,
            )
        # -- control
        if self.kind == "lqr_steady":
            u_fb = -self.k_steady @ x
            u_ff = -(self.w_steady.T @ preview)
        else:
            st = self._maybe_reset(st, preview)
            assert st.gains is not None and st.feedforward is not None
            j = st.since_reset
            if j < st.gains.shape[0]:
                u_fb = -st.gains[j] @ x
                u_ff = -st.feedforward[j]
            else:  # beyond the old horizon (only after overruns): last gain, no forcing
                u_fb = -st.gains[-1] @ x
                u_ff = np.zeros(2)
            st = replace(st, since_reset=j + 1)
        u = u_fb + u_ff
        st = replace(st, u_prev=u.copy())
        pitch = self.design.scalars["pitch_rad"] + float(u[1])
        if self.kind == "lqr_overlaid":
            torque = self.k_gen * gen_speed * gen_speed + float(u[0])
        else:
            torque = self.t_bar + float(u[0])
        return st, self._out(pitch, torque, gen_speed, st, x, float(u_ff[1]), float(u_ff[0]))

    # -------------------------------------------------------------- helpers
    def _maybe_reset(self, st: CasanovasState, preview: FloatArray) -> CasanovasState:
        if st.gains is not None and st.since_reset < self.reset_steps:
            return st
        t0 = self.clock()
        force = np.interp(self._t_half, self._t_prev, preview)
        if self.riccati == "every_reset":
            gains, ff = finite_horizon_solve(
                self.a, self.b, self.q, self.r, self.n, self.e, force, self.dt
            )
        else:
            gains, ff = self._gains_cached, self._ff_operator @ force
        elapsed = self.clock() - t0
        if st.gains is not None and elapsed > self.budget_ns:
            return replace(st, overruns=st.overruns + 1)
        return replace(st, gains=gains, feedforward=ff, since_reset=0, resets=st.resets + 1)

    def _out(
        self,
        pitch: float,
        torque: float,
        gen_speed: float,
        st: CasanovasState | None = None,
        x: FloatArray | None = None,
        ff_pitch: float = 0.0,
        ff_torque: float = 0.0,
    ) -> ControlOutput:
        lo, hi = self.pitch_limits
        pitch = min(max(pitch, lo), hi)
        torque = min(max(torque, 0.0), 47402.91)
        extra: dict[str, Any] = {}
        if x is not None and st is not None:
            from bus_schemas.messages import (  # noqa: PLC0415
                EST_FEEDFORWARD,
                EST_PLATFORM_SURGE,
                EST_PLATFORM_SURGE_VELOCITY,
            )

            extra = {
                "estimates_valid_mask": EST_PLATFORM_SURGE
                | EST_PLATFORM_SURGE_VELOCITY
                | EST_FEEDFORWARD,
                "platform_surge_estimated_m": float(x[1]) + self.surge_bar,
                "platform_surge_velocity_estimated_m_s": float(x[2]),
                "feedforward_pitch_rad": max(-2.0, min(2.0, ff_pitch)),
                "feedforward_torque_nm": ff_torque,
                "estimator_degraded": 1 if (st.stale_now or st.guard.fallback) else 0,
                "estimator_faults": st.guard.faults,
            }
        return ControlOutput(
            blade_pitch_commanded_rad=pitch,
            generator_torque_commanded_nm=torque,
            regime=REGIME_REGION_2,
            generator_speed_filtered_rad_s=gen_speed,
            pitch_integrator_rad=0.0,
            gain_schedule_factor=float(min(st.overruns, 100)) if st is not None else 0.0,
            **extra,
        )


def make_casanovas(
    kind: str,
    preset: str,
    *,
    control_period_s: float,
    preview: str | None = None,
    horizon_s: float | None = None,
    overlap: float | None = None,
    gauge_distance_m: float | None = None,
    design_dir: str | None = None,
    symmetric_pitch_limit_deg: float | None = None,
    torque_weight_factor: float | None = None,
    gamma_1_s: float | None = None,
) -> CasanovasController:
    """Build a casanovas core; ``preset`` names the design (``nrel5mw_tlp_casanovas_u8_hs6``).

    ``symmetric_pitch_limit_deg`` θ_s: pitch range [-θ_s, θ_s] about the design's θ̄ = 0
    (None: the NREL 5 MW's [0°, 90°]); ``torque_weight_factor``: r_τ / (½ρπR²) (None: the
    design's, 0.1 as the seed); ``gamma_1_s``: the steady LQR's oscillator decay γ [1/s]
    (None: the design's -1/T₁; ``-inf``: no preview, u = -K x̂).
    """
    design = load_casanovas_design(preset, design_dir)
    limits = (0.0, math.radians(90.0))
    if symmetric_pitch_limit_deg is not None:
        th = float(symmetric_pitch_limit_deg)
        if not (math.isfinite(th) and 0.0 < th <= 90.0):
            raise ValueError(
                f"symmetric_pitch_limit_deg = {symmetric_pitch_limit_deg!r}, expected 0 < θ <= 90"
            )
        limits = (-math.radians(th), math.radians(th))
    return CasanovasController(
        kind,
        design,
        control_period_s,
        preview=(preview or "perfect"),  # type: ignore[arg-type]
        horizon_s=horizon_s,
        overlap=0.5 if overlap is None else overlap,
        gauge_distance_m=gauge_distance_m,
        pitch_limits_rad=limits,
        torque_weight_factor=torque_weight_factor,
        gamma_1_s=gamma_1_s,
    )
