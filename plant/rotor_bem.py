"""Steady blade-element momentum (BEM) rotor with equilibrium-wake and frozen-wake derivatives.

Offline analysis, no part of the time-domain plant (which uses the Cp/Ct/Cq table of
:mod:`plant.aero`) nor of the product's run time: it reads an OpenFAST deck's AeroDyn blade and
polars. Used by ``bench/modes_vs_openfast.py`` and ``tests/test_rotor_bem.py`` to find which
wake model the OpenFAST linearisations hold (the equilibrium wake; ``plant/modes.py``).

Blade element (station at span s, radius r = s cos β_c with precone β_c, B blades):

    V_x = U cos β_c,  V_y = Ω r,  tan φ = V_x (1 − a) / (V_y (1 + a')),  α = φ − (θ_t + θ)

    c_n = C_l cos φ + C_d sin φ,   c_t = C_l sin φ − C_d cos φ,   W² = V_x²(1 − a)² + V_y²(1 + a')²

    dT = B ½ρW² c c_n cos β_c ds,   dQ = B ½ρW² c c_t r ds

Induction (equilibrium wake): a and a' solve the momentum balance with Prandtl tip and hub
losses F and Buhl's high-induction correction, in the one-variable form of Ning (2014), whose
residual in φ,

    R(φ) = sin φ / (1 − a(φ)) − (V_x / V_y) cos φ / (1 + a'(φ)),

    k = σ' c_n / (4 F sin²φ),  a = k / (1 + k) (k ≤ 2/3, else Buhl),
    k' = σ' c_t / (4 F sin φ cos φ),  a' = k' / (1 − k'),  σ' = B c / (2π r),

has a bracketed root in (0, π/2] for the attached-flow states of a pitched rotor. Drag is in
both inductions (AeroDyn's ``AIDrag``/``TIDrag``).

Frozen wake (OpenFAST's linearisation of AeroDyn with ``FrozenWake``): the induced velocities
u_a = a V_x and u_t = a' V_y of the operating point are held while Ω, U or θ are perturbed,
so that W and φ follow the perturbation directly and the circulation is not re-balanced with
the momentum of the wake. The equilibrium-wake derivatives re-converge a and a' (steady BEM,
the physics of a Cp/Ct/Cq table, the limit of motions slower than the wake's time constant
τ ≈ 1.1 R / (U (1 − 1.3 a)), about 10 s at 15 m/s and 30 s at 5 m/s for the IEA 15 MW).
OpenFAST's linearisations of the IEA 15 MW VolturnUS-S hold the equilibrium wake
(``tests/test_rotor_bem.py``).

Reference: Ning, S. A. (2014), "A simple solution method for the blade element momentum
equations with guaranteed convergence", Wind Energy 17, 1327-1345 (the formulation; this is
an independent implementation). Loads and derivatives are quasi-steady; no unsteady airfoil,
no skew, no shear.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

__all__ = [
    "BladeGeometry",
    "RotorLoads",
    "derivatives",
    "load_aerodyn_blade",
    "rotor_loads",
]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class BladeGeometry:
    """Blade stations and their polars.

    Attributes
    ----------
    span_m : (n,) array
        Station distance from the rotor apex along the blade (m), hub radius included.
    chord_m, twist_rad : (n,) arrays
        Chord (m) and aerodynamic twist (rad, positive towards feather).
    polars : sequence of (alpha_rad, cl, cd) arrays, one per station.
    n_blades : int
    hub_radius_m, tip_radius_m : float
        Along the blade (m).
    precone_rad : float
        Cone angle β_c (rad); the sign does not matter here (cos β_c).
    air_density_kg_m3 : float
    """

    span_m: FloatArray
    chord_m: FloatArray
    twist_rad: FloatArray
    polars: tuple[tuple[FloatArray, FloatArray, FloatArray], ...]
    n_blades: int
    hub_radius_m: float
    tip_radius_m: float
    precone_rad: float
    air_density_kg_m3: float


@dataclass(frozen=True)
class RotorLoads:
    """Rotor thrust T (N), aerodynamic torque Q (N m) and the induced velocities of each station
    (axial u_a and tangential u_t, m/s) at which they were found."""

    thrust_n: float
    torque_nm: float
    induced_axial_m_s: FloatArray
    induced_tangential_m_s: FloatArray


def _read_polar(path: Path) -> tuple[FloatArray, FloatArray, FloatArray]:
    lines = path.read_text().splitlines()
    i = next(k for k, s in enumerate(lines) if "NumAlf" in s)
    n = int(lines[i].split()[0])
    rows: list[list[float]] = []
    for s in lines[i + 1 :]:
        t = s.split()
        if not t or t[0].startswith("!"):
            continue
        rows.append([float(v) for v in t[:3]])
        if len(rows) == n:
            break
    d = np.array(rows)
    return np.radians(d[:, 0]), d[:, 1], d[:, 2]


def load_aerodyn_blade(
    blade_file: str | Path,
    polar_files: Sequence[str | Path],
    hub_radius_m: float,
    precone_deg: float,
    n_blades: int = 3,
    air_density_kg_m3: float = 1.225,
) -> BladeGeometry:
    """Read an AeroDyn 15 blade file and its airfoil polars (first table of each file).

    Offline only (the files of an OpenFAST deck). ``polar_files[k]`` is the file of
    airfoil ID k + 1 (the deck's ``AFNames`` order).
    """
    lines = Path(blade_file).read_text().splitlines()
    i = next(k for k, s in enumerate(lines) if "NumBlNds" in s)
    n = int(lines[i].split()[0])
    d = np.array([[float(v) for v in lines[i + 3 + k].split()[:7]] for k in range(n)])
    polars = tuple(_read_polar(Path(polar_files[int(idx) - 1])) for idx in d[:, 6])
    span = hub_radius_m + d[:, 0]
    return BladeGeometry(
        span_m=span,
        chord_m=d[:, 5],
        twist_rad=np.radians(d[:, 4]),
        polars=polars,
        n_blades=n_blades,
        hub_radius_m=hub_radius_m,
        tip_radius_m=float(span[-1]),
        precone_rad=math.radians(precone_deg),
        air_density_kg_m3=air_density_kg_m3,
    )


def _coefficients(
    polar: tuple[FloatArray, FloatArray, FloatArray], alpha: float
) -> tuple[float, float]:
    a, cl, cd = polar
    return float(np.interp(alpha, a, cl)), float(np.interp(alpha, a, cd))


def _loss(b: int, r: float, hub: float, tip: float, sphi: float) -> float:
    s = max(abs(sphi), 1e-9)
    ft = b / 2.0 * (tip - r) / (r * s)
    fh = b / 2.0 * (r - hub) / (hub * s)
    f_tip = 2.0 / math.pi * math.acos(min(1.0, math.exp(-ft)))
    f_hub = 2.0 / math.pi * math.acos(min(1.0, math.exp(-fh)))
    return max(f_tip * f_hub, 1e-6)


def _inductions(
    phi: float, sigma: float, cn: float, ct: float, f_loss: float
) -> tuple[float, float]:
    sphi, cphi = math.sin(phi), math.cos(phi)
    k = sigma * cn / (4.0 * f_loss * sphi * sphi)
    if k <= 2.0 / 3.0:
        a = k / (1.0 + k)
    else:  # Buhl's empirical thrust for high induction
        g1 = 2.0 * f_loss * k - (10.0 / 9.0 - f_loss)
        g2 = max(2.0 * f_loss * k - f_loss * (4.0 / 3.0 - f_loss), 0.0)
        g3 = 2.0 * f_loss * k - (25.0 / 9.0 - 2.0 * f_loss)
        a = 1.0 - 0.5 / math.sqrt(g2) if abs(g3) < 1e-6 else (g1 - math.sqrt(g2)) / g3
    kp = sigma * ct / (4.0 * f_loss * sphi * max(cphi, 1e-12))
    return a, kp


def _station(
    g: BladeGeometry, j: int, omega: float, wind: float, pitch: float
) -> tuple[float, float]:
    """Equilibrium induced velocities (u_a, u_t) at station j (m/s)."""
    from scipy.optimize import brentq  # noqa: PLC0415  offline only

    s = float(g.span_m[j])
    cb = math.cos(g.precone_rad)
    r = s * cb
    vx, vy = wind * cb, omega * r
    c = float(g.chord_m[j])
    sigma = g.n_blades * c / (2.0 * math.pi * r)
    twist = float(g.twist_rad[j])
    polar = g.polars[j]

    def terms(phi: float) -> tuple[float, float]:
        cl, cd = _coefficients(polar, phi - twist - pitch)
        cn = cl * math.cos(phi) + cd * math.sin(phi)
        ct = cl * math.sin(phi) - cd * math.cos(phi)
        fl = _loss(g.n_blades, s, g.hub_radius_m, g.tip_radius_m, math.sin(phi))
        return _inductions(phi, sigma, cn, ct, fl)

    def residual(phi: float) -> float:
        a, kp = terms(phi)
        # 1/(1 + a') = 1 − k' (finite at φ = π/2)
        return math.sin(phi) / (1.0 - a) - vx / vy * math.cos(phi) * (1.0 - kp)

    eps = 1e-6
    if residual(eps) * residual(math.pi / 2) < 0.0:
        phi = brentq(residual, eps, math.pi / 2, xtol=1e-12)
    else:  # pragma: no cover  (propeller brake or negative inflow: not the operating range)
        raise ValueError(f"BEM: no inflow-angle root at station {j} (r = {r:.2f} m)")
    a, kp = terms(phi)
    return a * vx, kp / (1.0 - kp) * vy


def rotor_loads(
    g: BladeGeometry,
    omega_rad_s: float,
    wind_m_s: float,
    pitch_rad: float,
    induced: tuple[FloatArray, FloatArray] | None = None,
) -> RotorLoads:
    """Thrust and torque; induction solved (equilibrium) or given (``induced``: frozen wake)."""
    n = g.span_m.size
    if induced is None:
        ua = np.zeros(n)
        ut = np.zeros(n)
        for j in range(1, n - 1):  # root and tip stations carry no load (F = 0)
            ua[j], ut[j] = _station(g, j, omega_rad_s, wind_m_s, pitch_rad)
    else:
        ua, ut = induced
    cb = math.cos(g.precone_rad)
    r = g.span_m * cb
    wx = wind_m_s * cb - ua
    wy = omega_rad_s * r + ut
    phi = np.arctan2(wx, wy)
    alpha = phi - g.twist_rad - pitch_rad
    cl = np.array([np.interp(alpha[j], *g.polars[j][:2]) for j in range(n)])
    cd = np.array([np.interp(alpha[j], g.polars[j][0], g.polars[j][2]) for j in range(n)])
    cn = cl * np.cos(phi) + cd * np.sin(phi)
    ct = cl * np.sin(phi) - cd * np.cos(phi)
    q = 0.5 * g.air_density_kg_m3 * (wx * wx + wy * wy) * g.chord_m
    fn = q * cn
    ft = q * ct
    fn[[0, -1]] = 0.0
    ft[[0, -1]] = 0.0
    thrust = g.n_blades * float(np.trapezoid(fn * cb, g.span_m))
    torque = g.n_blades * float(np.trapezoid(ft * r, g.span_m))
    return RotorLoads(thrust, torque, ua, ut)


def derivatives(
    g: BladeGeometry, omega_rad_s: float, wind_m_s: float, pitch_rad: float, wake: str
) -> dict[str, float]:
    """∂T/∂Ω (N s), ∂T/∂U (N s/m), ∂Q/∂Ω (N m s), ∂Q/∂U (N s) by central differences.

    ``wake``: ``"frozen"`` (induced velocities of the operating point held) or
    ``"equilibrium"`` (induction re-converged at each perturbed point).
    """
    if wake not in ("frozen", "equilibrium"):
        raise ValueError(f"wake: expected 'frozen' or 'equilibrium', got {wake!r}")
    op = rotor_loads(g, omega_rad_s, wind_m_s, pitch_rad)
    ind = (op.induced_axial_m_s, op.induced_tangential_m_s) if wake == "frozen" else None
    dw = 1e-3 * omega_rad_s
    du = 1e-3 * wind_m_s

    def at(w: float, u: float) -> RotorLoads:
        return rotor_loads(g, w, u, pitch_rad, ind)

    wp, wm = at(omega_rad_s + dw, wind_m_s), at(omega_rad_s - dw, wind_m_s)
    up, um = at(omega_rad_s, wind_m_s + du), at(omega_rad_s, wind_m_s - du)
    return {
        "thrust_n": op.thrust_n,
        "torque_nm": op.torque_nm,
        "dT_dOmega_N_s": (wp.thrust_n - wm.thrust_n) / (2 * dw),
        "dT_dU_N_s_m": (up.thrust_n - um.thrust_n) / (2 * du),
        "dQ_dOmega_N_m_s": (wp.torque_nm - wm.torque_nm) / (2 * dw),
        "dQ_dU_N_s": (up.torque_nm - um.torque_nm) / (2 * du),
    }
