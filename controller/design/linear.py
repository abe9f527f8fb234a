"""Linear design models of the floating turbine at steady operating points (offline only).

The plant model (:func:`plant.platform.f`) is linearised numerically about the steady state
that the same model gives at a steady hub-height wind (:func:`plant.modes.operating_point`):

.. math::

    \\dot{\\tilde x} = A\\tilde x + B\\tilde u + B_U \\tilde U + B_F F^w,\\qquad
    y = C\\tilde x

with :math:`\\tilde x = x - x_{op}` and :math:`\\tilde u = (\\tilde\\theta_c, \\tilde T_c)` the
pitch (rad) and generator-torque (N m) demands, :math:`\\tilde U` the hub-height wind (m/s) and
:math:`F^w = (F_x, F_z, M_\\varphi)` the first-order wave excitation (N, N, N m). A, B, B_U and
B_F are central differences of ``f`` (inputs are exact: ``f`` is affine in :math:`F^w`).

Radiation memory (design reduction)
-----------------------------------
The full model carries the radiation states ξ of the Perez-Fossen fit (dξ/dt = A_r ξ + B_r v,
μ = C_r ξ, v the platform velocities), about 50 states. For design they are replaced by the
frequency-matched equivalent that disannio-2022 (sect. 3.4, Tab. 6) uses: a constant damping
and added-mass correction evaluated at each platform DOF's own natural frequency ω_j,

.. math::

    \\mu \\approx D_{eq} v + \\Delta M \\dot v,\\qquad
    D_{eq}[:, j] = \\operatorname{Re} K(j\\omega_j)[:, j],\\quad
    \\Delta M[:, j] = \\operatorname{Im} K(j\\omega_j)[:, j] / \\omega_j,

with :math:`K(s) = C_r (sI - A_r)^{-1} B_r` the radiation kernel. The natural frequencies are
found by fixed-point iteration on the reduced model itself (disannio-2022 iterated four times,
sect. 3.4; here until the frequencies change by < 0.1 %). The reduced model has the eleven
mechanical states of :func:`plant.platform.state_names`; its platform periods stay within a few
per cent of the full model's (see :func:`reduce_radiation`).

Wave input
----------
For the wave feedforward the elevation η₀ at the platform origin is the input. The excitation
transfer :math:`X(\\omega)` (N/m, N m/m, WAMIT data, heading 0) is non-causal; as in al-2019
sect. 3-3 the output is delayed by :math:`t_d` (10 s) so that
:math:`X(\\omega)e^{-j\\omega t_d}` is causal and driven by the *predicted* elevation
η₀(t + t_d). It is realised as a state-space model by the eigensystem realisation algorithm
(ERA, a Hankel SVD of the impulse response obtained by inverse Fourier transform), i.e. the
time-domain identification on the impulse response of al-2019 sect. 3-3-2 ([32] there), see
:func:`excitation_model`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from plant import turbine as _turbine
from plant.hydro.wamit import load_hydro_preset
from plant.modes import (
    PITCH_LENGTH_M,
    OperatingPoint,
    identify_modes,
    linearize,
    operating_point,
)
from plant.platform import DOF_NAMES, N_MECH_STATES, FloatingParams, f, state_names

__all__ = [
    "INPUT_NAMES",
    "OUTPUT_NAMES",
    "ExcitationModel",
    "LinearModel",
    "excitation_model",
    "linear_model",
    "rated_wind_speed",
    "reduce_radiation",
]

FloatArray = npt.NDArray[np.float64]

#: Control inputs of B, in column order.
INPUT_NAMES = ("blade_pitch_demand_rad", "generator_torque_demand_nm")
#: Wave-force inputs of B_F, in column order.
WAVE_FORCE_NAMES = ("wave_force_surge_n", "wave_force_heave_n", "wave_moment_pitch_nm")
#: Outputs of C: rotor speed, platform pitch, tower-top fore-aft displacement (m).
OUTPUT_NAMES = ("rotor_speed_rad_s", "platform_pitch_rad", "tower_top_displacement_m")

_IDX_OMEGA = 8
_IDX_PITCH = 9
_IDX_TORQUE = 10


@dataclass(frozen=True, eq=False)
class LinearModel:
    """Linear model about one operating point (deviation variables, SI units).

    Attributes
    ----------
    wind_m_s : float
        Steady hub-height wind U (m/s).
    a, b, b_wind, b_wave, c : arrays
        A (n, n) 1/s; B (n, 2) for (pitch demand rad, torque demand N m); B_U (n, 1) per m/s;
        B_F (n, 3) per (N, N, N m) of wave excitation; C (3, n) for :data:`OUTPUT_NAMES`.
    state_names : tuple of str
        Names (with units) of the states.
    x_op : array (n,)
        Operating-point state.
    u_op : array (2,)
        Operating-point pitch (rad) and generator torque (N m).
    thrust_n : float
        Steady rotor thrust (N).
    """

    wind_m_s: float
    a: FloatArray
    b: FloatArray
    b_wind: FloatArray
    b_wave: FloatArray
    c: FloatArray
    state_names: tuple[str, ...]
    x_op: FloatArray
    u_op: FloatArray
    thrust_n: float
    notes: dict[str, object] = field(default_factory=dict)

    @property
    def n_states(self) -> int:
        """Number of states n."""
        return int(self.a.shape[0])

    def index(self, name: str) -> int:
        """Position of the state ``name`` (e.g. ``"rotor_speed_rad_s"``)."""
        return self.state_names.index(name)


def _jacobian_u(params: FloatingParams, x0: FloatArray, u0: tuple[float, ...]) -> FloatArray:
    """∂f/∂u (n, 6) by central differences; steps scaled per input unit."""
    steps = (1e-4, 1e2, 1e-3, 1.0, 1.0, 1.0)
    xs = tuple(x0.tolist())
    cols = []
    for i, h in enumerate(steps):
        up = list(u0)
        um = list(u0)
        up[i] += h
        um[i] -= h
        fp = np.array(f(0.0, xs, tuple(up), params))
        fm = np.array(f(0.0, xs, tuple(um), params))
        cols.append((fp - fm) / (2.0 * h))
    return np.stack(cols, axis=1)


def _output_matrix(params: FloatingParams, n: int) -> FloatArray:
    c = np.zeros((3, n))
    c[0, _IDX_OMEGA] = 1.0
    c[1, 2] = 1.0
    # Tower-top displacement along x: surge + h_t·pitch + s (hub lever without the apex offset).
    jh = params.hub_lever
    c[2, 0] = 1.0
    c[2, 2] = float(jh[2])
    c[2, 3] = 1.0
    return c


def _operating_point_at_speed(
    params: FloatingParams, op: OperatingPoint, omega_rad_s: float
) -> OperatingPoint:
    """The steady point at ``omega_rad_s`` (fine pitch, torque = aerodynamic torque / N).

    Below the wind where the optimal tip-speed ratio would take the rotor under its minimum
    speed, the torque law (region 1.5) holds the rotor at that minimum; the platform
    equilibrium is solved again for the thrust there (as :func:`plant.modes.operating_point`).
    """
    from scipy.optimize import fsolve  # noqa: PLC0415  offline only

    tp = params.turbine
    u_w = op.wind_m_s
    theta = tp.pitch_min_rad
    aero = _turbine.outputs(0.0, (omega_rad_s, theta, 0.0), (theta, 0.0, u_w), tp)
    torque = aero.aero_torque_nm / tp.gearbox_ratio
    nr = params.n_radiation
    u = (theta, torque, u_w, 0.0, 0.0, 0.0)

    def state(q: FloatArray) -> tuple[float, ...]:
        return (
            *(float(v) for v in q),
            0.0,
            0.0,
            0.0,
            0.0,
            omega_rad_s,
            theta,
            torque,
            *([0.0] * nr),
        )

    def residual(q: FloatArray) -> FloatArray:
        dx = f(0.0, state(q), u, params)
        return np.array(dx[4:8]) * np.array([1.0, 1.0, PITCH_LENGTH_M, 1.0])

    q_eq, _, ier, msg = fsolve(residual, np.array(op.state[:4]), full_output=True, xtol=1e-12)
    if ier != 1:
        raise ValueError(f"no static equilibrium at U = {u_w} m/s, omega = {omega_rad_s}: {msg}")
    ct = _turbine.outputs(0.0, (omega_rad_s, theta, torque), u[:3], tp).ct
    return OperatingPoint(u_w, state(q_eq), u, float(tp.k_thrust * u_w**2 * ct))


def linear_model(
    params: FloatingParams, wind_m_s: float, min_rotor_speed_rad_s: float = 0.0
) -> LinearModel:
    """Full linear model (with radiation states) at a steady wind.

    Parameters
    ----------
    params : FloatingParams
        Plant parameters (:func:`plant.platform.load_floating`).
    wind_m_s : float
        Steady hub-height wind U (m/s), > 0.
    min_rotor_speed_rad_s : float, optional
        Minimum rotor speed (rad/s) of the torque law (region 1.5): where the optimal
        tip-speed ratio would run the rotor slower, the model is taken at this speed, fine
        pitch and the aerodynamic torque there (the turbine's real operating point below
        about 7 m/s for the IEA 15 MW). Default 0: the optimal-TSR point.

    Returns
    -------
    LinearModel
        States as :func:`plant.platform.state_names`; the actuators' first-order lags are part
        of A (pitch and torque are states driven by their demands).
    """
    op = operating_point(params, wind_m_s)
    if op.state[_IDX_OMEGA] < min_rotor_speed_rad_s:
        op = _operating_point_at_speed(params, op, min_rotor_speed_rad_s)
    a = linearize(params, op)
    x0 = np.array(op.state, dtype=np.float64)
    bu = _jacobian_u(params, x0, op.inputs)
    n = a.shape[0]
    return LinearModel(
        wind_m_s=float(wind_m_s),
        a=a,
        b=bu[:, 0:2].copy(),
        b_wind=bu[:, 2:3].copy(),
        b_wave=bu[:, 3:6].copy(),
        c=_output_matrix(params, n),
        state_names=tuple(state_names(params)),
        x_op=x0,
        u_op=np.array(op.inputs[:2], dtype=np.float64),
        thrust_n=op.thrust_n,
    )


def _platform_frequencies(a: FloatArray) -> FloatArray:
    """Damped natural frequencies (rad/s) of surge, heave, pitch from a state matrix."""
    modes = identify_modes(a, range(4), range(4, 8), DOF_NAMES, (1.0, 1.0, PITCH_LENGTH_M, 1.0))
    found = {m.name: m.eigenvalue[1] for m in modes}
    return np.array([found.get(name, 0.2) for name in DOF_NAMES[:3]])


def reduce_radiation(
    full: LinearModel, params: FloatingParams, iterations: int = 10
) -> LinearModel:
    """Replace the radiation states by the frequency-matched damping and added mass.

    With M the mass matrix (M_s + A_∞) and the acceleration rows of the full model
    :math:`\\ddot q = M^{-1}(g(x_m) - C_r\\xi)`, the reduced rows are
    :math:`\\ddot q = (M + \\Delta M)^{-1} M\\,[A_{acc,m} x_m - M^{-1} D_{eq} v]` (module
    docstring); B rows likewise. Iterated until the surge, heave and pitch frequencies used in
    :math:`K(j\\omega_j)` move by less than 0.1 %.

    Parameters
    ----------
    full : LinearModel
        From :func:`linear_model`.
    params : FloatingParams
        The same parameters (for M and the radiation fit A_r, B_r, C_r).
    iterations : int, optional
        Maximum fixed-point iterations (default 10).

    Returns
    -------
    LinearModel
        Eleven states (:data:`plant.platform.N_MECH_STATES`), ``notes["radiation_omega_rad_s"]``
        holds the matching frequencies.
    """
    nm = N_MECH_STATES
    nr = params.n_radiation
    acc = slice(4, 8)
    mech = slice(0, nm)
    a_m = full.a[mech, mech].copy()
    b_m = full.b[mech].copy()
    bw_m = full.b_wind[mech].copy()
    bf_m = full.b_wave[mech].copy()
    m = np.array(params.mass_matrix)
    if nr == 0:
        omega = np.zeros(3)
        a_red = a_m
    else:
        ar, br, cr = params.radiation_a, params.radiation_b, params.radiation_c
        omega = _platform_frequencies(full.a)
        a_red = a_m
        for _ in range(max(1, iterations)):
            d_eq = np.zeros((4, 4))
            dm = np.zeros((4, 4))
            for j in range(3):
                w = float(omega[j])
                k = cr @ np.linalg.solve(1j * w * np.eye(nr) - ar, br)
                d_eq[:3, j] = k[:, j].real
                dm[:3, j] = k[:, j].imag / w
            t = np.linalg.solve(m + dm, m)
            minv_d = np.linalg.solve(m, d_eq)
            a_red = a_m.copy()
            a_red[acc, :] = t @ a_m[acc, :]
            a_red[acc, 4:8] -= t @ minv_d
            new = _platform_frequencies(a_red)
            done = bool(np.all(np.abs(new - omega) <= 1e-3 * np.abs(omega)))
            omega = new
            if done:
                break
        t = np.linalg.solve(m + dm, m)
        for arr in (b_m, bw_m, bf_m):
            arr[acc, :] = t @ arr[acc, :]
    return LinearModel(
        wind_m_s=full.wind_m_s,
        a=a_red,
        b=b_m,
        b_wind=bw_m,
        b_wave=bf_m,
        c=full.c[:, mech].copy(),
        state_names=full.state_names[:nm],
        x_op=full.x_op[mech].copy(),
        u_op=full.u_op.copy(),
        thrust_n=full.thrust_n,
        notes={"radiation_omega_rad_s": [float(v) for v in omega]},
    )


def rated_wind_speed(params: FloatingParams, lo: float = 6.0, hi: float = 16.0) -> float:
    """Lowest steady wind (m/s) at which the aerodynamic power at rated speed reaches rated.

    Bisection on U of P_a(ω_rated, θ_min, U) = P_rated/η (0.01 m/s).
    """
    tp = params.turbine
    omega = tp.rated_rotor_speed_rad_s
    target = tp.rated_power_w / tp.generator_efficiency

    def excess(u: float) -> float:
        out = _turbine.outputs(0.0, (omega, tp.pitch_min_rad, 0.0), (0.0, 0.0, u), tp)
        return out.aero_power_w - target

    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if excess(mid) > 0.0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


# ---------------------------------------------------------------------- wave excitation
@dataclass(frozen=True, eq=False)
class ExcitationModel:
    """Causal state-space model of the delayed wave excitation, η₀(t + t_d) → F^w(t).

    ``dz/dt = a z + b η, F = c z + d η`` (F in N, N, N m; η in m), fitted to
    :math:`X(\\omega) e^{-j\\omega t_d}`.

    Attributes
    ----------
    a, b, c, d : arrays
        Continuous-time realisation (order r).
    delay_s : float
        t_d (s).
    fit_error : float
        Max over the three outputs of the relative error ‖X̂ − X e^{-jωt_d}‖₂ / ‖X‖₂ over the
        wave band (-).
    """

    a: FloatArray
    b: FloatArray
    c: FloatArray
    d: FloatArray
    delay_s: float
    fit_error: float

    def response(self, omega_rad_s: FloatArray) -> npt.NDArray[np.complex128]:
        """X̂(jω) (len(ω), 3)."""
        n = self.a.shape[0]
        out = np.empty((omega_rad_s.size, 3), dtype=np.complex128)
        for i, w in enumerate(omega_rad_s):
            out[i] = (self.c @ np.linalg.solve(1j * w * np.eye(n) - self.a, self.b)).ravel()
            out[i] += self.d.ravel()
        return out


def excitation_transfer(
    hydro_preset: str = "iea15mw_volturnus", heading_deg: float = 0.0
) -> tuple[FloatArray, npt.NDArray[np.complex128]]:
    """WAMIT excitation X(ω) of surge, heave, pitch (N/m, N/m, N m/m) at ``heading_deg``."""
    hydro = load_hydro_preset(hydro_preset)
    exc = hydro.excitation.select((0, 2, 4), heading_deg)
    return exc.omega_rad_s.copy(), exc.force[:, 0, :].copy()


def excitation_model(
    omega_rad_s: FloatArray,
    x_tf: npt.NDArray[np.complex128],
    delay_s: float = 10.0,
    order: int = 16,
    dt_s: float = 0.5,
    duration_s: float = 40.0,
    band_rad_s: tuple[float, float] = (2.0 * math.pi * 0.05, 2.0 * math.pi / 3.0),
    taper_rad_s: tuple[float, float] = (2.2, 3.2),
) -> ExcitationModel:
    """Realise X(ω)e^{-jωt_d} as a causal state-space model (ERA on its impulse response).

    1. X is extended to ω = 0 (real part extrapolated linearly, imaginary part 0) and tapered
       to zero by a half-cosine window over ``taper_rad_s`` (al-2019 sect. 3-3-2 trusts the
       panel data up to 2.2 rad/s and fits 0.01..2.2 rad/s).
    2. Impulse response h(t) = (1/π) ∫₀^∞ Re{X(ω) e^{jω(t - t_d)}} dω sampled at ``dt_s``.
    3. ERA: Hankel matrix of the Markov parameters h(kΔ)Δ, SVD, rank ``order`` realisation
       (A_d, B_d, C_d), D = 0; continuous form A = log(A_d)/Δ, B = A_d⁻¹B_d/Δ, C = C_d.

    Parameters
    ----------
    omega_rad_s, x_tf : arrays
        Frequencies (rad/s, increasing) and X (n_ω, 3) per metre of wave amplitude,
        convention e^{+jωt}.
    delay_s : float
        t_d (s), al-2019 sect. 3-4-1 (10 s).
    order : int
        Realisation order r.
    dt_s, duration_s : float
        Impulse-response sampling (s) and length (s).
    band_rad_s : (float, float)
        Wave band for the fit error (al-2019 eq. 4-3: 0.05..0.333 Hz).
    taper_rad_s : (float, float)
        Start and end of the high-frequency taper (rad/s).

    Returns
    -------
    ExcitationModel
    """
    w = np.concatenate([[0.0], np.asarray(omega_rad_s, dtype=np.float64)])
    x0 = x_tf[0] - (x_tf[1] - x_tf[0]) * omega_rad_s[0] / (omega_rad_s[1] - omega_rad_s[0])
    x = np.concatenate([x0.real[None, :] + 0j, x_tf], axis=0)
    w0, w1 = taper_rad_s
    wmax = min(float(w[-1]), w1)
    taper = np.clip(0.5 * (1.0 + np.cos(math.pi * (w - w0) / (w1 - w0))), 0.0, 1.0)
    taper = np.where(w <= w0, 1.0, np.where(w >= w1, 0.0, taper))
    wf = np.linspace(0.0, wmax, 2001)
    xf = np.stack(
        [
            np.interp(wf, w, (x[:, j] * taper).real) + 1j * np.interp(wf, w, (x[:, j] * taper).imag)
            for j in range(3)
        ],
        axis=1,
    )
    nt = round(duration_s / dt_s)
    t = np.arange(nt + 1) * dt_s
    ph = np.exp(1j * np.outer(t - delay_s, wf))  # (nt, nw)
    h = np.trapezoid((ph[:, :, None] * xf[None, :, :]).real, wf, axis=1) / math.pi  # (nt, 3)
    markov = h * dt_s  # Markov parameters of the ZOH-equivalent (impulse-invariant) system
    rows = nt // 2
    hank = np.zeros((3 * rows, rows))
    hank1 = np.zeros((3 * rows, rows))
    for i in range(rows):
        for j in range(rows):
            hank[3 * i : 3 * i + 3, j] = markov[1 + i + j]
            hank1[3 * i : 3 * i + 3, j] = markov[2 + i + j]
    u, s, vt = np.linalg.svd(hank, full_matrices=False)
    r = order
    s_half = np.sqrt(s[:r])
    obs = u[:, :r] * s_half
    con = (vt[:r, :].T * s_half).T
    ad = np.diag(1.0 / s_half) @ u[:, :r].T @ hank1 @ vt[:r, :].T @ np.diag(1.0 / s_half)
    bd = con[:, :1]
    cd = obs[:3, :]
    # Continuous equivalent: impulse response of (A, B, C) sampled ≈ C A_d^k B_d / dt.
    ac = sla.logm(ad).real / dt_s
    bc = np.linalg.solve(ad, bd) / dt_s  # h(kΔ)Δ = C_d A_d^(k-1) B_d = C A_d^k B Δ
    # Realness and stability guard: reflect any unstable eigenvalue (numerical ERA artefact).
    lam, vec = np.linalg.eig(ac)
    if np.any(lam.real >= 0.0):
        lam = np.where(lam.real >= 0.0, -np.abs(lam.real) - 1e-3 + 1j * lam.imag, lam)
        ac = (vec @ np.diag(lam) @ np.linalg.inv(vec)).real
    dc = np.zeros((3, 1))  # the causalised response starts at zero (h(0) ≈ 0)
    model = ExcitationModel(ac, bc, cd, dc, float(delay_s), 0.0)
    band = (omega_rad_s >= band_rad_s[0]) & (omega_rad_s <= band_rad_s[1])
    target = x_tf[band] * np.exp(-1j * omega_rad_s[band, None] * delay_s)
    fit = model.response(omega_rad_s[band])
    err = np.linalg.norm(fit - target, axis=0) / np.linalg.norm(target, axis=0)
    return ExcitationModel(ac, bc, cd, dc, float(delay_s), float(np.max(err)))
