"""Surge, heave and pitch hydrodynamics of a multi-column semi-submersible by BEM (Capytaine).

Offline, like :mod:`plant.hydro.spar_bem`: it needs the optional ``[hydro]`` extra
(``capytaine``); the plant never imports it at run time. The hull is a set of vertical
columns, each an axisymmetric surface of revolution of a piecewise-linear radius profile
``r(z)`` (keel up to the waterline, steps allowed: the base column's top ring of a
heave-plate column) placed at its axis position ``(x, y)``; all columns are one rigid body,
meshed with ``n_theta`` panels around and panels of about ``panel_m`` along each profile, with
an interior waterline lid in each column against irregular frequencies. Slender members
(pontoons, braces) are not meshed: a deck carries them as Morison members (HydroDyn
``PropPot = FALSE``), which :mod:`plant.openfast_import` adds in buoyancy, restoring and added
mass.

Computed (linear potential flow, SI, DOFs surge 0, heave 2, pitch 4 about the still-water
line at x = y = 0): ``A_ij(ω)``, ``B_ij(ω)``, ``A_∞`` and the excitation ``X_i(ω)`` for waves
along +x, conjugated to the product's ``exp(+iωt)``; and the WAMIT ``.hst`` stiffness of the
columns (buoyancy and waterplane, no weight), summed over the columns with the parallel-axis
theorem: C_33 = ρ g Σ A_wp, C_35 = −ρ g Σ A_wp x_c, C_55 = ρ g Σ (I_wp + A_wp x_c² + V z_B).

Default geometry: the OC4-DeepCwind columns (Robertson et al. 2014, NREL/TP-5000-60601, as in
the OpenFAST r-test deck ``5MW_OC4Semi_WSt_WavesWN``, HydroDyn member table): main column
D 6.5 m from z = −20 m to the waterline at (0, 0); three offset columns at radius 28.8675 m
(x = −28.86751 m and x = 14.43376 m, y = ±25 m), upper part D 12 m from −14 m up, base
column (heave plate) D 24 m from −20 m to −14 m; water depth 200 m.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from plant.hydro.bem import _import_capytaine
from plant.hydro.spar_bem import profile_hydrostatics, solve_three_dofs
from plant.hydro.wamit import HydroData

FloatArray = NDArray[np.float64]

_DOFS = ("Surge", "Heave", "Pitch")


@dataclass(frozen=True)
class Column:
    """One vertical column: axis position (m) and radius profile (z m, r m), keel to waterline."""

    x_m: float
    y_m: float
    profile: tuple[tuple[float, float], ...]


_OFFSET = ((-20.0, 12.0), (-14.0, 12.0), (-14.0, 6.0), (0.0, 6.0))
#: OC4-DeepCwind columns (joints of the r-test HydroDyn member table, PropD of its property
#: sets 1-3): main column at the origin, offset columns at 120° spacing.
OC4_COLUMNS: tuple[Column, ...] = (
    Column(0.0, 0.0, ((-20.0, 3.25), (0.0, 3.25))),
    Column(14.43376, 25.0, _OFFSET),
    Column(-28.86751, 0.0, _OFFSET),
    Column(14.43376, -25.0, _OFFSET),
)
OC4_DEPTH_M = 200.0


def columns_hydrostatics(
    columns: Sequence[Column], rho_kg_m3: float = 1025.0, g_m_s2: float = 9.81
) -> tuple[float, float, float, FloatArray]:
    """Volume (m³), centre of buoyancy x, z (m) and (3, 3) surge/heave/pitch ``.hst`` stiffness.

    Each column by :func:`plant.hydro.spar_bem.profile_hydrostatics` (exact for frusta), moved
    to its axis with the parallel-axis theorem (see the module docstring).
    """
    vol = mx = mz = 0.0
    c = np.zeros((3, 3))
    rg = rho_kg_m3 * g_m_s2
    for col in columns:
        v, zb, ci = profile_hydrostatics(col.profile, rho_kg_m3, g_m_s2)
        awp = ci[1, 1] / rg
        vol += v
        mx += v * col.x_m
        mz += v * zb
        c[1, 1] += ci[1, 1]
        c[1, 2] -= rg * awp * col.x_m
        c[2, 2] += ci[2, 2] + rg * awp * col.x_m**2
    c[2, 1] = c[1, 2]
    return vol, mx / vol, mz / vol, c


def _column_mesh(cpt: object, col: Column, panel_m: float, n_theta: int):  # type: ignore[no-untyped-def]
    """Hull of revolution (keel disk, side, steps) and waterline lid of one column, in place."""
    pts: list[tuple[float, float]] = []
    z_keel, r_keel = col.profile[0]
    n_r = max(2, math.ceil(r_keel / panel_m))
    for k in range(n_r):
        pts.append((k * r_keel / n_r, z_keel))
    for (z0, r0), (z1, r1) in itertools.pairwise(col.profile):
        n = max(1, math.ceil(math.hypot(z1 - z0, r1 - r0) / panel_m))
        for k in range(n):
            s = k / n
            pts.append((r0 + s * (r1 - r0), z0 + s * (z1 - z0)))
    pts.append((col.profile[-1][1], col.profile[-1][0]))
    xyz = np.array([(r, 0.0, z) for r, z in pts])
    # Capytaine sorts the meridian by z with a stable sort: rings of equal z (keel, steps)
    # keep the order given here, so the meridian stays one continuous curve.
    hull = cpt.RotationSymmetricMesh.from_profile_points(xyz, n=n_theta)  # type: ignore[attr-defined]
    rw = col.profile[-1][1]
    lid = cpt.mesh_disk(  # type: ignore[attr-defined]
        radius=rw,
        center=(0.0, 0.0, 0.0),
        normal=(0.0, 0.0, 1.0),
        resolution=(max(2, math.ceil(rw / panel_m)), n_theta),
    )
    shift = np.array([col.x_m, col.y_m, 0.0])
    return hull.translated(shift), lid.translated(shift)


def semi_bem(
    omega_rad_s: Sequence[float] | FloatArray,
    columns: Sequence[Column] = OC4_COLUMNS,
    depth_m: float = OC4_DEPTH_M,
    panel_m: float = 2.0,
    n_theta: int = 16,
    rho_kg_m3: float = 1025.0,
    g_m_s2: float = 9.81,
) -> tuple[HydroData, str]:
    """Solve the radiation and diffraction problems of a set of vertical columns (Capytaine).

    Parameters
    ----------
    omega_rad_s : sequence of float
        Wave frequencies (rad/s), > 0, strictly increasing.
    columns : sequence of Column
        The columns (one rigid body).
    depth_m : float
        Water depth (m), > the deepest keel.
    panel_m, n_theta : float, int
        Target panel length along each profile (m) and panels around each column.
    rho_kg_m3, g_m_s2 : float
        Water density and gravity.

    Returns
    -------
    HydroData, str
        DOFs (0, 2, 4), heading 0; and a one-line description (mesh, solver, wall time).
    """
    w = np.asarray(omega_rad_s, dtype=np.float64)
    if w.ndim != 1 or w.size == 0 or np.any(w <= 0.0) or np.any(np.diff(w) <= 0.0):
        raise ValueError("semi_bem: omega must be > 0 rad/s and strictly increasing")
    for col in columns:
        if abs(col.profile[-1][0]) > 1e-9 or any(r <= 0 for _, r in col.profile):
            raise ValueError("semi_bem: each profile must end at z = 0 with radii > 0 m")
        if not depth_m > -col.profile[0][0]:
            raise ValueError("semi_bem: the depth must exceed every column's draft")
    cpt = _import_capytaine()
    parts = [_column_mesh(cpt, col, panel_m, n_theta) for col in columns]
    hull = cpt.Mesh.join_meshes(*[h for h, _ in parts])
    lid = cpt.Mesh.join_meshes(*[lid for _, lid in parts])
    vol, _, _, c_hst = columns_hydrostatics(columns, rho_kg_m3, g_m_s2)
    hydro, elapsed = solve_three_dofs(cpt, hull, lid, "semi", w, depth_m, rho_kg_m3, g_m_s2, c_hst)
    omega = hydro.radiation.omega_rad_s
    desc = (
        f"{len(columns)} columns, {vol:.1f} m^3, depth {depth_m:g} m; "
        f"{int(getattr(hull, 'nb_faces', 0))} hull panels (panel {panel_m:g} m, {n_theta} "
        f"around) + lids; {omega.size} frequencies "
        f"{omega.min():g}..{omega.max():g} rad/s; "
        f"capytaine {getattr(cpt, '__version__', '?')}; {elapsed:.1f} s"
    )
    return hydro, desc
