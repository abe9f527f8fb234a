"""LQRI gain schedule for collective pitch above rated (disannio-2022 ch. 4), offline.

Design model (per scheduled wind U)
-----------------------------------
From the radiation-reduced linear model (:mod:`controller.design.linear`) the states

    x = (surge m, pitch rad, tower-top s m, their rates, ω rad/s, θ rad)

are kept (heave is dropped: nearly decoupled, al-2019 sect. 2-2; the generator torque is held
at its region-3 value, disannio-2022 sect. 4.5 found torque feedback negligible). The input is
the pitch demand θ_c. disannio-2022 eq. (24)-(25) use (γ, γ̇, ω, s, ṡ) with θ as a direct
input; here the tower mode and the pitch actuator lag (θ a state) are added, which the
runtime measures (blade-pitch encoder) or estimates.

Integral action (disannio-2022 eq. (27)-(30)): z = ∫(ω − ω_ref) dt, ż = ω − ω_ref. Design is
in discrete time at the control period T_s: (A_d, B_d) = ZOH(A, B) and the integrator
z_{k+1} = z_k + T_s ω̃_k, so

.. math::

    A_i = \\begin{bmatrix} A_d & 0 \\\\ T_s e_\\omega^T & 1\\end{bmatrix},\\quad
    B_i = \\begin{bmatrix} B_d \\\\ 0 \\end{bmatrix},\\quad
    u_k = -K_x \\tilde x_k - K_i z_k,

with [K_x K_i] = (R + B_iᵀPB_i)⁻¹B_iᵀPA_i and P from the discrete algebraic Riccati equation
(:func:`scipy.linalg.solve_discrete_are`).

Weights (documented default, Bryson's rule): Q = diag(1/x_max,i²), R = 1/u_max², with the
largest acceptable deviations of :class:`LqriSettings` (disannio-2022 tuned Q, R by hand,
Tab. 11 and 13; Bryson's rule gives the same kind of weighting from physical limits).

Below rated the generator torque follows T = K ω² (optimal-TSR gain from the Cp table), and
the switch between regimes is made on the estimated wind (disannio-2022 sect. 4.8, switch at
10 m/s there; here at the rated wind of the model, with hysteresis in the runtime).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
from scipy.signal import cont2discrete

from controller.design.linear import LinearModel

__all__ = [
    "LQRI_STATE_NAMES",
    "LqriGains",
    "LqriSettings",
    "closed_loop_matrix",
    "closed_loop_poles",
    "design_lqri",
    "lqri_design_model",
]

FloatArray = npt.NDArray[np.float64]

#: States of the LQRI design model, in order (the integrator follows them).
LQRI_STATE_NAMES = (
    "surge_m",
    "pitch_rad",
    "tower_fore_aft_m",
    "surge_rate_m_s",
    "pitch_rate_rad_s",
    "tower_fore_aft_rate_m_s",
    "rotor_speed_rad_s",
    "blade_pitch_rad",
)


@dataclass(frozen=True)
class LqriSettings:
    """Settings of the LQRI design (SI units in the names).

    Bryson's rule: Q_ii = 1/x_max,i², R = 1/u_max². Defaults chosen for the IEA 15 MW on
    VolturnUS-S: a 0.5 rpm rotor-speed deviation weighs as much as 1 deg of platform pitch,
    0.5 deg/s of platform pitch rate, 10 m of surge and 1.5 deg of pitch demand.

    Attributes
    ----------
    control_period_s : float
        T_s (s), default 0.025 (40 Hz).
    wind_grid_m_s : tuple of float
        Scheduled winds (m/s); disannio-2022 sect. 4.6: 11..21 m/s, extended to 25.
    max_surge_m ... max_integral_rad : float
        Largest acceptable deviations of the states (Bryson).
    max_pitch_demand_rad : float
        u_max of Bryson's rule (rad).
    pitch_min_rad, pitch_max_rad, pitch_rate_max_rad_s : float
        Runtime saturation 0..90 deg (disannio-2022 Tab. 9) and rate limit. disannio-2022 used
        7 deg/s; the IEA 15 MW DISCON (PC_MaxRat) allows 2 deg/s = 0.0349 rad/s, used here.
    switch_hysteresis_m_s : float
        Width of the wind-speed hysteresis band of the regime switch (m/s).
    """

    control_period_s: float = 0.025
    wind_grid_m_s: tuple[float, ...] = tuple(float(v) for v in range(11, 26))
    max_surge_m: float = 10.0
    max_pitch_rad: float = math.radians(1.0)
    max_tower_m: float = 0.5
    max_surge_rate_m_s: float = 1.0
    max_pitch_rate_rad_s: float = math.radians(0.5)
    max_tower_rate_m_s: float = 0.5
    max_rotor_speed_rad_s: float = 0.5 * math.pi / 30.0
    max_blade_pitch_rad: float = math.radians(20.0)
    max_integral_rad: float = 0.5 * math.pi / 30.0 * 5.0
    max_pitch_demand_rad: float = math.radians(1.5)
    pitch_min_rad: float = 0.0
    pitch_max_rad: float = math.pi / 2.0
    pitch_rate_max_rad_s: float = 0.0349
    switch_hysteresis_m_s: float = 1.0
    extra: dict[str, float] = field(default_factory=dict)

    def q_diag(self) -> FloatArray:
        """diag(Q) of Bryson's rule, states then integrator."""
        m = np.array(
            [
                self.max_surge_m,
                self.max_pitch_rad,
                self.max_tower_m,
                self.max_surge_rate_m_s,
                self.max_pitch_rate_rad_s,
                self.max_tower_rate_m_s,
                self.max_rotor_speed_rad_s,
                self.max_blade_pitch_rad,
                self.max_integral_rad,
            ]
        )
        return 1.0 / m**2

    def as_dict(self) -> dict[str, object]:
        """JSON-ready dict."""
        d = asdict(self)
        d["wind_grid_m_s"] = list(self.wind_grid_m_s)
        return d


_MODEL_INDEX = (0, 2, 3, 4, 6, 7, 8, 9)  # in the 11-state reduced model


def lqri_design_model(model: LinearModel) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Continuous (A, B_θ, B_U) of the LQRI design states :data:`LQRI_STATE_NAMES`.

    Heave and its rate and the generator torque are removed by truncation.
    """
    idx = list(_MODEL_INDEX)
    a = model.a[np.ix_(idx, idx)]
    b = model.b[idx, 0:1]
    bu = model.b_wind[idx, :]
    return a, b, bu


@dataclass(frozen=True, eq=False)
class LqriGains:
    """Gain schedule: per wind U_k, u = u_op − K_x (x − x_op) − K_i z.

    Attributes
    ----------
    wind_m_s : (m,) array
    k_x : (m, 8) array
        State gains (rad per state unit) in :data:`LQRI_STATE_NAMES` order.
    k_i : (m,) array
        Integral gain (rad per rad of ∫ω̃ dt).
    x_op : (m, 8) array
        Operating-point states (θ_op in the last column).
    u_op : (m, 2) array
        Operating-point (pitch rad, generator torque N m).
    closed_loop_radius : (m,) array
        Spectral radius of the discrete closed loop A_i − B_i K (-), < 1.
    """

    wind_m_s: FloatArray
    k_x: FloatArray
    k_i: FloatArray
    x_op: FloatArray
    u_op: FloatArray
    closed_loop_radius: FloatArray


def _discrete_augmented(
    model: LinearModel, ts: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    a, b, _ = lqri_design_model(model)
    n = a.shape[0]
    ad, bd, *_ = cont2discrete((a, b, np.eye(n), np.zeros((n, 1))), ts, method="zoh")
    ai = np.zeros((n + 1, n + 1))
    ai[:n, :n] = ad
    ai[n, 6] = ts
    ai[n, n] = 1.0
    bi = np.zeros((n + 1, 1))
    bi[:n] = bd
    return ai, bi, ad, bd


def gains_at(model: LinearModel, settings: LqriSettings) -> tuple[FloatArray, float, float]:
    """LQRI gains (K_x (8,), K_i) at one operating point and the closed-loop spectral radius."""
    ai, bi, _, _ = _discrete_augmented(model, settings.control_period_s)
    q = np.diag(settings.q_diag())
    r = np.array([[1.0 / settings.max_pitch_demand_rad**2]])
    p = sla.solve_discrete_are(ai, bi, q, r)
    k = np.linalg.solve(r + bi.T @ p @ bi, bi.T @ p @ ai)
    radius = float(np.max(np.abs(np.linalg.eigvals(ai - bi @ k))))
    return k[0, :-1].copy(), float(k[0, -1]), radius


def closed_loop_matrix(model: LinearModel, k_x: FloatArray, k_i: float, ts: float) -> FloatArray:
    """Discrete closed loop A_i − B_i K of the augmented design model with the given gains
    (states :data:`LQRI_STATE_NAMES`, then the integrator)."""
    ai, bi, _, _ = _discrete_augmented(model, ts)
    k = np.concatenate([k_x, [k_i]])[None, :]
    out: FloatArray = ai - bi @ k
    return out


def closed_loop_poles(
    model: LinearModel, k_x: FloatArray, k_i: float, ts: float
) -> npt.NDArray[np.complex128]:
    """Discrete closed-loop poles z of the augmented design model with the given gains."""
    poles: npt.NDArray[np.complex128] = np.linalg.eigvals(
        closed_loop_matrix(model, k_x, k_i, ts)
    ).astype(np.complex128)
    return poles


def design_lqri(models: list[LinearModel], settings: LqriSettings) -> LqriGains:
    """Gain schedule over the given linear models (one per scheduled wind).

    Parameters
    ----------
    models : list of LinearModel
        Radiation-reduced models (:func:`controller.design.linear.reduce_radiation`) at
        ``settings.wind_grid_m_s``.
    settings : LqriSettings

    Returns
    -------
    LqriGains
    """
    idx = list(_MODEL_INDEX)
    kx, ki, xo, uo, rad = [], [], [], [], []
    for m in models:
        k_x, k_i, radius = gains_at(m, settings)
        kx.append(k_x)
        ki.append(k_i)
        xo.append(m.x_op[idx])
        uo.append(m.u_op)
        rad.append(radius)
    return LqriGains(
        wind_m_s=np.array([m.wind_m_s for m in models]),
        k_x=np.array(kx),
        k_i=np.array(ki),
        x_op=np.array(xo),
        u_op=np.array(uo),
        closed_loop_radius=np.array(rad),
    )
