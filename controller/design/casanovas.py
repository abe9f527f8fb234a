"""casanovas-2014: surge + rotor model of the NREL 5 MW TLP, energy-maximising LQR designs.

Offline (may import ``plant``). Writes one artefact per (plant preset, wind speed, sea state),
``<preset>_casanovas_u<U>_hs<Hs>.npz`` + ``.json`` (json: preset, settings, creation time,
commit), read by :mod:`controller.casanovas` (which never imports ``plant``). Also computes
the frequency-domain upper bound of casanovas-2014 table 3.1 (:func:`upper_bound`).

Model (derived from section 2 of the seed, every figure from the shipped preset)
--------------------------------------------------------------------------------
States x = [ϖ rad/s, ξ - ξ̄ m, ξ̇ m/s, r₁..r₄], inputs u = [ΔT_g N m (HSS), ψ rad]::

    I ϖ̇        = ∂T_a/∂Ω ϖ - ∂T_a/∂V_r ξ̇ + ∂T_a/∂θ ψ - N ΔT_g
    (M + A_∞) ξ̈ = -C ξ - D ξ̇ - C_r r + ∂F_T/∂Ω ϖ - ∂F_T/∂V_r ξ̇ + ∂F_T/∂θ ψ + X(t)
    ṙ           = A_r r + B_r ξ̇

with V_r = V - ξ̇ the relative wind, T_a = ½ρπR²C_p(λ,θ)V_r³/Ω and F_T = ½ρπR²C_T(λ,θ)V_r²
(the seed's quasi-steady aerodynamics), linearised numerically about λ̄ = λ* (the table's
optimal tip-speed ratio), θ̄ = 0, Ω̄ = λ*V/R, T̄_g = K(NΩ̄)² (the region-2 law, so the
base-torque steady state and the design point coincide). C_p and C_T come from a local
least-squares quadratic surface fitted to the rotor table the plant uses (points within
±1.5 in λ and ±4° in θ), which also gives the second derivatives of the cost.

Choices where the seed's printed equations slip (stated)
---------------------------------------------------------------------------
1. *Row 3 of A_s and B_s*: every entry of the surge-acceleration row is divided by M + A_∞
   (the seed divides only the memory term and puts M + A_∞ into B_s row 4); this is the
   Cummins equation of section 2.1 solved for ξ̈.
2. *Torque weight*: R = diag(r_τ, r_ψ) with r_τ = +½ρπR² · 0.1 W/(N m)² (the seed's 0.1 with
   its overall factor, but positive: its printed R = -½ρS diag(0.1, ...) would reward torque
   activity without bound and make the problem ill-posed), torque on the HSS in N m;
   r_ψ = -½ · ½ρπR² ∂²C_p/∂θ² V³ > 0 exactly as the seed. The factor is a scenario key of
   the controller (``torque_weight_factor``), which rescales r_τ at construction.
3. *Cost*: Q, N from the exact Hessian of P = ½ρπR² C_p(λ, θ) V_r³ in (ϖ, ξ̇, ψ) (equal to
   the seed's Q₀* with ∂C_p/∂λ = 0), with the sign changed (minimise -P), factor ½ as in
   J = ∫ (xᵀQx + uᵀRu + 2xᵀNu) dt with Q = -½ H.
4. *Oscillator decay γ* (section 4.5, never given): γ = -1/T₁ (the wave knowledge of the
   steady design fades over one mean period). With the oscillator states the x-block of the
   Riccati solution is the ARE of the plant alone and the wave block gives
   u_ff(t) = -R⁻¹Bᵀ ∫₀^∞ e^{A_clᵀτ} P E e^{γτ} X(t+τ) dτ, a kernel on the excitation over the
   preview; :func:`steady_kernel` tabulates it on the preview grid (exactly the oscillator
   design when every wave component is an oscillator state). The controller's
   ``gamma_1_s`` changes γ; ``"no_preview"`` is γ → -∞ (:func:`preview_kernel`).
5. *Overlap*: δ is the fraction of the horizon shared by consecutive solutions, so the reset
   period is T_R = (1 - δ) T (the seed's text: "high overlap requires more frequent control
   resets"; its formula δ = T_R/T says the opposite). δ = 0.5 gives T_R = T/2 either way.
6. *ISSC exponent*: exp(-0.44 (ωT₁/2π)^-4) (the printed +4 is a slip; see plant.waves.issc).
7. *Viscous damping*: D = B_q √(8/π) σ_ξ̇ (appendix II) with B_q = ½ρ (2R) L C_D, C_D = 1, from
   the preset (the seed's F_vis prints R where Morison has the diameter), σ_ξ̇ iterated to
   convergence in the frequency domain for the sea state.
8. *B_T and (1 - a)* of section 3.2: B_T = dF_T/dV at fixed λ* (= ρπR² C_T* V), a from
   C_T* = 4a(1 - a). Table 3.1 uses the BEM excitation X(ω) of the preset (the seed uses the
   deep-water Haskind relation; :func:`upper_bound` reports both).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import linalg

FloatArray = npt.NDArray[np.float64]

__all__ = [
    "CasanovasSettings",
    "LinearModel",
    "artefact_stem",
    "design_casanovas",
    "linear_model",
    "steady_gain",
    "steady_kernel",
    "upper_bound",
    "write_design",
]

#: Preview sample spacing [s] and count of the excitation preview (bus_schemas WavePreviewPerfect).
PREVIEW_STEP_S = 0.25
PREVIEW_SAMPLES = 81


@dataclass(frozen=True)
class CasanovasSettings:
    """Design settings.

    Attributes
    ----------
    wind_m_s : float
        Steady wind speed V [m/s] (below rated).
    hs_m, t1_s : float
        ISSC sea state: significant height [m], mean period T₁ [s] (for the drag linearisation
        and the oscillator decay).
    torque_weight_factor : float
        r_τ / (½ρπR²) [1/(N m)² · m³/s³ ...]: 0.1 as the seed.
    drag_cd : float
        Drag coefficient of the buoy (1, as the seed).
    gamma_1_s : float or None
        Oscillator decay γ [1/s] (< 0); None: -1/T₁.
    control_period_s : float
        Control period [s] of the discrete observer.
    surge_std_m, rotor_speed_std_rad_s : float
        Measurement noise assumed by the observer [m], [rad/s].
    force_std_n : float
        Process noise on the surge force (model and excitation error) [N].
    """

    wind_m_s: float = 8.0
    hs_m: float = 6.0
    t1_s: float = 11.6
    torque_weight_factor: float = 0.1
    drag_cd: float = 1.0
    gamma_1_s: float | None = None
    control_period_s: float = 0.1
    surge_std_m: float = 0.05
    rotor_speed_std_rad_s: float = 0.01
    force_std_n: float = 5.0e4

    def __post_init__(self) -> None:
        for name in ("wind_m_s", "hs_m", "t1_s", "torque_weight_factor", "control_period_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"CasanovasSettings: {name} = {v!r}, expected a number > 0")
        if self.gamma_1_s is not None and not self.gamma_1_s < 0:
            raise ValueError(f"CasanovasSettings: gamma_1_s = {self.gamma_1_s!r}, expected < 0")

    @property
    def gamma(self) -> float:
        """γ [1/s]."""
        return self.gamma_1_s if self.gamma_1_s is not None else -1.0 / self.t1_s


@dataclass(frozen=True)
class LinearModel:
    """The linear surge + rotor model, its cost and operating point (module docstring)."""

    a: FloatArray  # (7, 7)
    b: FloatArray  # (7, 2)
    e: FloatArray  # (7,) forcing column per N of X(t)
    q: FloatArray  # (7, 7)
    r: FloatArray  # (2, 2)
    n: FloatArray  # (7, 2)
    a_base: FloatArray  # A with the linearised region-2 torque law folded in (section 4.3)
    rotor_speed_rad_s: float
    generator_torque_nm: float
    pitch_rad: float
    surge_mean_m: float
    torque_gain_nm_s2: float
    gearbox_ratio: float
    aero_power_w: float
    thrust_n: float
    thrust_slope_n_s_m: float
    induction: float
    mass_kg: float
    added_mass_inf_kg: float
    stiffness_n_m: float
    drag_linear_n_s_m: float
    quadratic_drag_n_s2_m2: float
    hessian: FloatArray  # (3, 3) of P in (ϖ, ξ̇, ψ) [W per unit²]
    power_gradient: FloatArray  # (3,) of P in (ϖ, ξ̇, ψ) [W per unit]


def _quadratic_surface(table: Any, which: str, tsr: float, pitch: float) -> FloatArray:
    """Coefficients c of f ≈ c0 + c1 dλ + c2 dθ + c3 dλ² + c4 dλdθ + c5 dθ² near (λ, θ)."""
    lam = np.asarray(table.tsr)
    th = np.asarray(table.pitch_rad)
    mat = np.asarray(getattr(table, which))
    li = np.abs(lam - tsr) <= 1.5 + 1e-9
    ti = np.abs(th - pitch) <= math.radians(4.0) + 1e-9
    L, T = np.meshgrid(lam[li] - tsr, th[ti] - pitch, indexing="ij")
    f = mat[np.ix_(li, ti)]
    x, y = L.ravel(), T.ravel()
    basis = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=1)
    c, *_ = np.linalg.lstsq(basis, f.ravel(), rcond=None)
    return np.asarray(c, dtype=np.float64)


def _surf(c: FloatArray, dl: float, dt: float) -> float:
    return float(c[0] + c[1] * dl + c[2] * dt + c[3] * dl * dl + c[4] * dl * dt + c[5] * dt * dt)


def _issc(omega: FloatArray, hs: float, t1: float) -> FloatArray:
    x = np.maximum(omega, 1e-9) * t1 / (2 * math.pi)
    out: FloatArray = hs**2 * t1 * (0.11 / (2 * math.pi)) * x**-5 * np.exp(-0.44 * x**-4)
    return out


def _hydro(preset: str) -> tuple[Any, Any, Any]:
    from plant.hydro.wamit import HydroData  # noqa: PLC0415
    from plant.platform import load_floating, read_floating_preset  # noqa: PLC0415

    params = load_floating(preset)
    fp, base, _ = read_floating_preset(preset)
    ref = fp.hydro_file
    if ref.startswith("preset:"):
        import importlib.resources  # noqa: PLC0415

        res = importlib.resources.files("plant.presets").joinpath(
            *ref.removeprefix("preset:").split("/")
        )
        with importlib.resources.as_file(res) as path:
            hydro = HydroData.load_npz(path)
    else:
        hydro = HydroData.load_npz((base or Path(".")) / ref)
    return params, fp, hydro


def _surge_rao_std(
    omega: FloatArray,
    spec: FloatArray,
    x_abs: FloatArray,
    mass_total: FloatArray,
    damping: FloatArray,
    stiffness: float,
) -> tuple[FloatArray, float]:
    """|U/A| over ω and σ_ξ̇ for a spectrum (frequency-domain surge)."""
    den = stiffness - omega**2 * mass_total + 1j * omega * damping
    u = np.abs(1j * omega * x_abs / den)
    dw = float(omega[1] - omega[0])
    return u, float(math.sqrt(np.sum(u**2 * spec) * dw))


def _frequency_data(hydro: Any, omega: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    rad = hydro.radiation
    a = np.interp(omega, rad.omega_rad_s, rad.added_mass[:, 0, 0])
    b = np.interp(omega, rad.omega_rad_s, rad.damping[:, 0, 0])
    exc = hydro.excitation
    xf = exc.force[:, 0, 0]
    xr = np.interp(omega, exc.omega_rad_s, xf.real, left=0.0, right=0.0)
    xi = np.interp(omega, exc.omega_rad_s, xf.imag, left=0.0, right=0.0)
    return a, b, np.abs(xr + 1j * xi)


def linear_model(preset: str, settings: CasanovasSettings) -> LinearModel:
    """Linearise the preset's surge + rotor plant at the settings' wind (module docstring)."""
    from plant.platform import mooring_force  # noqa: PLC0415
    from plant.turbine import optimal_torque_gain  # noqa: PLC0415

    params, _fp, hydro = _hydro(preset)
    tp = params.turbine
    rho_s = 0.5 * tp.air_density_kg_m3 * math.pi * tp.rotor_radius_m**2  # ½ρπR²
    rr = tp.rotor_radius_m
    v = float(settings.wind_m_s)
    lam = tp.table.optimal_tsr(0.0)
    cp_c = _quadratic_surface(tp.table, "cp", lam, 0.0)
    ct_c = _quadratic_surface(tp.table, "ct", lam, 0.0)
    omega0 = lam * v / rr

    def cp(om: float, vr: float, th: float) -> float:
        return _surf(cp_c, om * rr / vr - lam, th)

    def power(om: float, vr: float, th: float) -> float:
        return rho_s * cp(om, vr, th) * vr**3

    def torque(om: float, vr: float, th: float) -> float:
        return power(om, vr, th) / om

    def thrust(om: float, vr: float, th: float) -> float:
        return rho_s * _surf(ct_c, om * rr / vr - lam, th) * vr**2

    h_om, h_v, h_th = 1e-4 * omega0, 1e-4 * v, 1e-5

    def grad(fn: Any) -> tuple[float, float, float]:
        return (
            (fn(omega0 + h_om, v, 0.0) - fn(omega0 - h_om, v, 0.0)) / (2 * h_om),
            (fn(omega0, v + h_v, 0.0) - fn(omega0, v - h_v, 0.0)) / (2 * h_v),
            (fn(omega0, v, h_th) - fn(omega0, v, -h_th)) / (2 * h_th),
        )

    dt_om, dt_v, dt_th = grad(torque)
    df_om, df_v, df_th = grad(thrust)
    # Hessian of P in z = (ϖ, ξ̇, ψ); V_r = V - ξ̇.
    steps = (10 * h_om, 10 * h_v, 10 * h_th)

    def p_of(z: FloatArray) -> float:
        return power(omega0 + z[0], v - z[1], z[2])

    hess = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            ei = np.zeros(3)
            ej = np.zeros(3)
            ei[i] = steps[i]
            ej[j] = steps[j]
            hess[i, j] = (p_of(ei + ej) - p_of(ei - ej) - p_of(-ei + ej) + p_of(-ei - ej)) / (
                4 * steps[i] * steps[j]
            )
    hess = 0.5 * (hess + hess.T)
    grad_p = np.array(
        [(p_of(e) - p_of(-e)) / (2 * h) for e, h in zip(np.diag(steps), steps, strict=True)]
    )

    inertia = tp.drivetrain_inertia_kg_m2
    gear = tp.gearbox_ratio
    m_tot = float(params.mass_matrix[0, 0])
    a_inf = float(hydro.radiation.added_mass_inf[0, 0])
    mass = m_tot - a_inf
    c_moor = -(
        mooring_force(params.mooring, 0.5, 0.0, 0.0)[0]
        - mooring_force(params.mooring, -0.5, 0.0, 0.0)[0]
    )
    stiff = c_moor + float(params.stiffness[0, 0])
    bq = float(params.quadratic_damping[0, 0]) * settings.drag_cd
    t_bar = thrust(omega0, v, 0.0)
    ct_star = float(ct_c[0])
    b_t = 2 * rho_s * ct_star * v
    sigma_v = _sigma_surge_velocity(hydro, mass, stiff, b_t, bq, settings.hs_m, settings.t1_s)
    d_lin = bq * math.sqrt(8 / math.pi) * sigma_v + float(params.linear_damping[0, 0])

    ar = np.asarray(params.radiation_a, dtype=np.float64)
    br = np.asarray(params.radiation_b, dtype=np.float64)[:, 0]
    cr = np.asarray(params.radiation_c, dtype=np.float64)[0]
    nr = ar.shape[0]
    n = 3 + nr
    a = np.zeros((n, n))
    b = np.zeros((n, 2))
    e = np.zeros(n)
    a[0, 0] = dt_om / inertia
    a[0, 2] = -dt_v / inertia
    b[0, 0] = -gear / inertia
    b[0, 1] = dt_th / inertia
    a[1, 2] = 1.0
    a[2, 0] = df_om / m_tot
    a[2, 1] = -stiff / m_tot
    a[2, 2] = (-d_lin - df_v) / m_tot
    a[2, 3:] = -cr / m_tot
    b[2, 1] = df_th / m_tot
    e[2] = 1.0 / m_tot
    a[3:, 3:] = ar
    a[3:, 2] = br
    # cost: minimise -P ≈ -(½ zᵀ H z); z = (ϖ, ξ̇, ψ) -> x[0], x[2], u[1]
    q = np.zeros((n, n))
    q[np.ix_([0, 2], [0, 2])] = -0.5 * hess[np.ix_([0, 1], [0, 1])]
    nn = np.zeros((n, 2))
    nn[0, 1] = -0.5 * hess[0, 2]
    nn[2, 1] = -0.5 * hess[1, 2]
    r = np.diag([rho_s * settings.torque_weight_factor, -0.5 * hess[2, 2]])
    k_gain = optimal_torque_gain(tp, 0.0)
    a_base = a.copy()
    a_base[0, 0] -= gear / inertia * 2.0 * k_gain * gear * omega0 * gear
    p_bar = power(omega0, v, 0.0)
    induction = 0.5 * (1 - math.sqrt(max(0.0, 1 - ct_star)))
    return LinearModel(
        a=a,
        b=b,
        e=e,
        q=q,
        r=r,
        n=nn,
        a_base=a_base,
        rotor_speed_rad_s=omega0,
        generator_torque_nm=k_gain * (gear * omega0) ** 2,
        pitch_rad=0.0,
        surge_mean_m=t_bar / stiff,
        torque_gain_nm_s2=k_gain,
        gearbox_ratio=gear,
        aero_power_w=p_bar,
        thrust_n=t_bar,
        thrust_slope_n_s_m=b_t,
        induction=induction,
        mass_kg=mass,
        added_mass_inf_kg=a_inf,
        stiffness_n_m=stiff,
        drag_linear_n_s_m=d_lin,
        quadratic_drag_n_s2_m2=bq,
        hessian=hess,
        power_gradient=grad_p,
    )


def _sigma_surge_velocity(
    hydro: Any, mass: float, stiff: float, b_t: float, bq: float, hs: float, t1: float
) -> float:
    """σ_ξ̇ [m/s] with the stochastic drag linearisation iterated to a fixed point."""
    omega = np.linspace(0.02, 2.0, 100)
    spec = _issc(omega, hs, t1)
    a_w, b_w, x_abs = _frequency_data(hydro, omega)
    sigma = 0.1
    for _ in range(200):
        d = bq * math.sqrt(8 / math.pi) * sigma
        _, new = _surge_rao_std(omega, spec, x_abs, mass + a_w, b_w + d + b_t, stiff)
        if abs(new - sigma) < 1e-9:
            break
        sigma = 0.5 * (sigma + new)
    return sigma


def upper_bound(
    preset: str, wind_m_s: float, hs_m: float, t1_s: float, n_bins: int = 100
) -> dict[str, float]:
    """casanovas-2014 section 3.2: mean power the turbine's thrust damping takes from surge.

    P̄_ext = B_T (1 - a) Σ_j |U_j/A_j|² S(ω_j) Δω,  U/A = iωX / (C - ω²(M + A(ω)) + iω(B_T + B_W)),

    with B_W = B(ω) + D (potential + linearised viscous, appendix II, iterated), ω_j = jΔω,
    Δω = 2/N rad/s (N = 100 bins up to 2 rad/s, as the seed). ``"haskind"`` gives the seed's
    deep-water Haskind form |X/A|² = 4ρg³B/ω³ in place of the BEM excitation.

    Returns
    -------
    dict
        ``p_ext_w`` (BEM excitation), ``p_ext_haskind_w``, ``p_aero_w`` (½ρπR²C_p*V³),
        ``percent`` (= 100 p_ext/p_aero), ``percent_haskind``, ``b_t_n_s_m``, ``induction``,
        ``sigma_surge_velocity_m_s``, ``drag_linear_n_s_m``.
    """
    settings = CasanovasSettings(wind_m_s=wind_m_s, hs_m=hs_m, t1_s=t1_s)
    lm = linear_model(preset, settings)
    _, _, hydro = _hydro(preset)
    dw = 2.0 / n_bins
    omega: FloatArray = dw * np.arange(1, n_bins + 1, dtype=np.float64)
    spec = _issc(omega, hs_m, t1_s)
    a_w, b_w, x_abs = _frequency_data(hydro, omega)
    rho, g = float(hydro_rho(hydro)), 9.81
    bw = b_w + lm.drag_linear_n_s_m
    den = (lm.stiffness_n_m - omega**2 * (lm.mass_kg + a_w)) ** 2 + omega**2 * (
        lm.thrust_slope_n_s_m + bw
    ) ** 2
    u2 = omega**2 * x_abs**2 / den
    fac = lm.thrust_slope_n_s_m * (1 - lm.induction)
    p = fac * float(np.sum(u2 * spec) * dw)
    x2_h = 4 * rho * g**3 * b_w / omega**3
    p_h = fac * float(np.sum(omega**2 * x2_h / den * spec) * dw)
    return {
        "p_ext_w": p,
        "p_ext_haskind_w": p_h,
        "p_aero_w": lm.aero_power_w,
        "percent": 100 * p / lm.aero_power_w,
        "percent_haskind": 100 * p_h / lm.aero_power_w,
        "b_t_n_s_m": lm.thrust_slope_n_s_m,
        "induction": lm.induction,
        "sigma_surge_velocity_m_s": math.sqrt(float(np.sum(u2 * spec) * dw)),
        "drag_linear_n_s_m": lm.drag_linear_n_s_m,
    }


def hydro_rho(hydro: Any) -> float:
    """Water density of the hydro data [kg/m³] (1025 when not recorded)."""
    return float(getattr(hydro, "rho_kg_m3", 1025.0) or 1025.0)


def steady_gain(lm: LinearModel, a: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """ARE of the indefinite cost: (K (2, 7), P (7, 7)); u = -K x. Raises if not stabilising."""
    return are_gain(lm.a if a is None else a, lm.b, lm.q, lm.r, lm.n)


def are_gain(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray, n: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """K = R⁻¹(BᵀP + Nᵀ) and P of AᵀP + PA - (PB + N)R⁻¹(BᵀP + Nᵀ) + Q = 0 (section 4.5).

    Raises
    ------
    ValueError
        If the solver fails or A - BK is not stable (e.g. a torque weight so small that the
        indefinite cost has no stabilising solution).
    """
    try:
        p = linalg.solve_continuous_are(a, b, q, r, s=n)
    except (linalg.LinAlgError, ValueError) as exc:
        raise ValueError(f"steady LQR: no stabilising ARE solution ({exc})") from exc
    k = np.linalg.solve(r, b.T @ p + n.T)
    eig = np.linalg.eigvals(a - b @ k)
    if not np.all(eig.real < 0):
        raise ValueError(f"steady LQR: closed loop not stable, eigenvalues {eig}")
    return k, p


def steady_kernel(
    lm: LinearModel, k: FloatArray, p: FloatArray, gamma: float, a: FloatArray | None = None
) -> FloatArray:
    """Feed-forward kernel W (PREVIEW_SAMPLES, 2) of :func:`preview_kernel` for ``lm``."""
    return preview_kernel(lm.a if a is None else a, lm.b, lm.r, lm.e, k, p, gamma)


def preview_kernel(
    a: FloatArray,
    b: FloatArray,
    r: FloatArray,
    e: FloatArray,
    k: FloatArray,
    p: FloatArray,
    gamma: float,
) -> FloatArray:
    """Feed-forward kernel W (PREVIEW_SAMPLES, 2): u_ff = -Σ_j W_j X(t + jΔ) Δ (trapezoid).

    W(τ) = R⁻¹ Bᵀ e^{A_clᵀ τ} P E e^{γτ}, A_cl = A - BK (module docstring, item 4). γ = -∞
    is the no-preview limit: W ≡ 0, u = -K x (the continuous kernel's weight,
    ∫₀^∞ W dτ = -R⁻¹Bᵀ(A_clᵀ + γI)⁻¹ P E, vanishes like 1/|γ|; the trapezoid's first
    sample would not, so the limit is taken exactly).
    """
    if math.isnan(gamma) or gamma >= 0:
        raise ValueError(f"preview kernel: gamma = {gamma!r} 1/s, expected < 0 (or -inf)")
    if math.isinf(gamma):
        return np.zeros((PREVIEW_SAMPLES, 2))
    acl = a - b @ k
    rinv_bt = np.linalg.solve(r, b.T)
    out = np.zeros((PREVIEW_SAMPLES, 2))
    step = linalg.expm(acl.T * PREVIEW_STEP_S)
    vec = p @ e
    for j in range(PREVIEW_SAMPLES):
        out[j] = rinv_bt @ vec * math.exp(gamma * PREVIEW_STEP_S * j)
        vec = step @ vec
    w = np.full(PREVIEW_SAMPLES, PREVIEW_STEP_S)
    w[0] = w[-1] = 0.5 * PREVIEW_STEP_S
    return out * w[:, None]


def _observer(lm: LinearModel, s: CasanovasSettings) -> dict[str, FloatArray]:
    """Discrete steady-state Kalman filter on (ϖ, ξ) measurements, ZOH at the control period."""
    n = lm.a.shape[0]
    dt = s.control_period_s
    big = np.zeros((n + 3, n + 3))
    big[:n, :n] = lm.a
    big[:n, n : n + 2] = lm.b
    big[:n, n + 2] = lm.e
    ex = linalg.expm(big * dt)
    ad, bd, ed = ex[:n, :n], ex[:n, n : n + 2], ex[:n, n + 2]
    c = np.zeros((2, n))
    c[0, 0] = 1.0
    c[1, 1] = 1.0
    gq = ed[:, None] * s.force_std_n
    qn = gq @ gq.T + np.diag([(1e-3 * dt) ** 2] + [0.0] * (n - 1))
    rn = np.diag([s.rotor_speed_std_rad_s**2, s.surge_std_m**2])
    pp = linalg.solve_discrete_are(ad.T, c.T, qn, rn)
    gain = pp @ c.T @ np.linalg.inv(c @ pp @ c.T + rn)
    return {"obs_ad": ad, "obs_bd": bd, "obs_ed": ed, "obs_c": c, "obs_l": gain}


def artefact_stem(preset: str, wind_m_s: float, hs_m: float) -> str:
    """``<preset>_casanovas_u<U>_hs<Hs>`` with '.' -> 'p' (e.g. nrel5mw_tlp_casanovas_u8_hs6)."""
    return f"{Path(preset).stem}_casanovas_u{wind_m_s:g}_hs{hs_m:g}".replace(".", "p")


def design_casanovas(preset: str, settings: CasanovasSettings) -> dict[str, Any]:
    """Everything the runtime needs, as arrays and scalars (see :func:`write_design`)."""
    lm = linear_model(preset, settings)
    k, p = steady_gain(lm)
    kern = steady_kernel(lm, k, p, settings.gamma)
    _params, _fp, hydro = _hydro(preset)
    exc = hydro.excitation
    out: dict[str, Any] = {
        "a": lm.a,
        "b": lm.b,
        "e": lm.e,
        "q": lm.q,
        "r": lm.r,
        "n": lm.n,
        "a_base": lm.a_base,
        "steady_k": k,
        "steady_p": p,
        "steady_kernel": kern,
        "excitation_omega_rad_s": np.asarray(exc.omega_rad_s, dtype=np.float64),
        "excitation_re_n_m": np.asarray(exc.force[:, 0, 0].real, dtype=np.float64),
        "excitation_im_n_m": np.asarray(exc.force[:, 0, 0].imag, dtype=np.float64),
        **_observer(lm, settings),
    }
    scalars = {
        "rotor_speed_rad_s": lm.rotor_speed_rad_s,
        "generator_torque_nm": lm.generator_torque_nm,
        "pitch_rad": lm.pitch_rad,
        "surge_mean_m": lm.surge_mean_m,
        "torque_gain_nm_s2": lm.torque_gain_nm_s2,
        "gearbox_ratio": lm.gearbox_ratio,
        "aero_power_w": lm.aero_power_w,
        "thrust_n": lm.thrust_n,
        "drag_linear_n_s_m": lm.drag_linear_n_s_m,
        "gamma_1_s": settings.gamma,
        "control_period_s": settings.control_period_s,
        "water_depth_m": 100.0,
        "preview_step_s": PREVIEW_STEP_S,
        "preview_samples": PREVIEW_SAMPLES,
    }
    out["scalars"] = scalars
    return out


def write_design(
    preset: str, settings: CasanovasSettings, out_dir: str | Path, commit: str | None = None
) -> Path:
    """Design and write ``<stem>.npz`` + ``<stem>.json`` into ``out_dir``; return the npz path."""
    from controller.design import _commit  # noqa: PLC0415
    from plant.platform import read_floating_preset  # noqa: PLC0415

    d = design_casanovas(preset, settings)
    fp, _, _ = read_floating_preset(preset)
    d["scalars"]["water_depth_m"] = float(fp.water_depth_m)
    stem = artefact_stem(preset, settings.wind_m_s, settings.hs_m)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    arrays = {k: v for k, v in d.items() if k != "scalars"}
    np.savez(out / f"{stem}.npz", **arrays)
    meta = {
        "kind": "casanovas",
        "preset": preset,
        "settings": asdict(settings),
        "scalars": d["scalars"],
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "commit": commit or _commit(),
    }
    (out / f"{stem}.json").write_text(json.dumps(meta, indent=2))
    return out / f"{stem}.npz"


#: The seed's sea states (table 3.1 / 5.2): H_s [m] -> mean period T₁ [s].
SEA_STATES: dict[float, float] = {6.0: 11.6, 10.0: 13.6}
#: The seed's wind speeds [m/s].
WIND_SPEEDS: tuple[float, ...] = (6.0, 8.0, 10.0)


def main(argv: list[str] | None = None) -> int:
    """``python -m controller.design.casanovas [--out DIR]``: the six shipped designs."""
    import argparse  # noqa: PLC0415

    from controller.design import DEFAULT_DESIGN_DIR  # noqa: PLC0415

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="nrel5mw_tlp")
    ap.add_argument("--out", default=str(DEFAULT_DESIGN_DIR))
    ap.add_argument("--control-period", type=float, default=0.1)
    ap.add_argument("--wind", type=float, help="one design: wind speed [m/s] (with --hs, --t1)")
    ap.add_argument("--hs", type=float, help="one design: significant wave height [m]")
    ap.add_argument("--t1", type=float, help="one design: ISSC mean period T1 [s]")
    args = ap.parse_args(argv)
    cases = [(hs, t1, u) for hs, t1 in SEA_STATES.items() for u in WIND_SPEEDS]
    if args.wind is not None or args.hs is not None or args.t1 is not None:
        if args.wind is None or args.hs is None or args.t1 is None:
            ap.error("--wind, --hs and --t1 go together")
        cases = [(args.hs, args.t1, args.wind)]
    for hs, t1, u in cases:
        s = CasanovasSettings(wind_m_s=u, hs_m=hs, t1_s=t1, control_period_s=args.control_period)
        print(f"wrote {write_design(args.preset, s, args.out)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
