"""Surge, heave and pitch hydrodynamics of an axisymmetric spar by BEM (Capytaine), as shipped data.

Script-like module of the product, run offline once per geometry (the OC3-Hywind spar)::

    python -m plant.hydro.spar_bem --out plant/presets/hydro/nrel5mw_oc3_hywind.npz

It needs the optional ``[hydro]`` extra (``capytaine``, see :mod:`plant.hydro.bem`); the plant
never imports it at run time, it reads the npz.

What is computed (linear potential flow, SI units, water density ρ, gravity g, depth h), for the
rigid-body DOFs surge (WAMIT index 0), heave (2) and pitch (4) about the still-water line on the
spar axis (the platform reference point of :mod:`plant.platform`):

* added mass ``A_ij(ω)`` (kg, kg m, kg m²) and radiation damping ``B_ij(ω)`` and ``A_∞``;
* excitation per unit wave amplitude ``X_i(ω)`` (N/m, N m/m) for waves along +x, conjugated
  from Capytaine's ``exp(-iωt)`` to the product's ``exp(+iωt)`` (see :mod:`plant.hydro.bem`);
* the hydrostatic stiffness in WAMIT's ``.hst`` convention (buoyancy only, no gravity of the
  body): C_33 = ρ g A_wp, C_55 = ρ g (I_wp + V z_B), with A_wp and I_wp the waterplane area and
  second moment and z_B (< 0) the height of the centre of buoyancy, from the profile.

The hull is the surface of revolution of a piecewise-linear radius profile ``r(z)`` (a list of
(z, r) points from the keel up to the waterline) plus its flat keel disk, meshed with
``n_theta`` panels around and panels of about ``panel_m`` along the profile; an interior lid at
z = 0 suppresses the irregular frequencies.

Default geometry: the OC3-Hywind spar (Jonkman 2010, NREL/TP-500-47535; figures of the OpenFAST
r-test deck ``5MW_OC3Spar_DLL_WTurb_WavesIrr``): D = 9.4 m from z = −120 m to −12 m, linear taper
to 6.5 m at −4 m, D = 6.5 m up to the waterline; depth 320 m.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from plant.hydro.bem import _import_capytaine
from plant.hydro.wamit import ExcitationData, HydroData, RadiationData

FloatArray = NDArray[np.float64]

#: OC3-Hywind spar profile (z m, radius m) from the keel to the waterline.
OC3_HYWIND_PROFILE: tuple[tuple[float, float], ...] = (
    (-120.0, 4.7),
    (-12.0, 4.7),
    (-4.0, 3.25),
    (0.0, 3.25),
)
OC3_HYWIND_DEPTH_M = 320.0

_DOFS = ("Surge", "Heave", "Pitch")


def profile_hydrostatics(
    profile: Sequence[tuple[float, float]], rho_kg_m3: float = 1025.0, g_m_s2: float = 9.81
) -> tuple[float, float, FloatArray]:
    """Displaced volume, centre of buoyancy and WAMIT hydrostatic stiffness of a profile.

    V = ∫ π r(z)² dz, z_B = ∫ z π r² dz / V over the linear segments (exact for each frustum by
    Simpson's rule, the integrands being polynomials of degree <= 3); A_wp = π r(0)²,
    I_wp = π r(0)⁴ / 4.

    Returns
    -------
    volume_m3, z_b_m, C : float, float, (3, 3) array
        C over (surge, heave, pitch): diag(0, ρ g A_wp, ρ g (I_wp + V z_B)).
    """
    vol = 0.0
    mom = 0.0
    for (z0, r0), (z1, r1) in itertools.pairwise(profile):
        zm, rm = 0.5 * (z0 + z1), 0.5 * (r0 + r1)
        a0, am, a1 = math.pi * r0 * r0, math.pi * rm * rm, math.pi * r1 * r1
        dz = z1 - z0
        vol += dz / 6.0 * (a0 + 4.0 * am + a1)
        mom += dz / 6.0 * (z0 * a0 + 4.0 * zm * am + z1 * a1)
    zb = mom / vol
    rw = profile[-1][1]
    awp = math.pi * rw * rw
    iwp = math.pi * rw**4 / 4.0
    c = np.zeros((3, 3))
    c[1, 1] = rho_kg_m3 * g_m_s2 * awp
    c[2, 2] = rho_kg_m3 * g_m_s2 * (iwp + vol * zb)
    return vol, zb, c


def _hull_mesh(cpt: object, profile: Sequence[tuple[float, float]], panel_m: float, n_theta: int):  # type: ignore[no-untyped-def]
    """Axisymmetric hull (side of revolution + keel disk) and a waterline lid, Capytaine meshes."""
    pts: list[tuple[float, float]] = []
    # keel disk: radial points from the axis to the keel radius at the keel depth
    z_keel, r_keel = profile[0]
    n_r = max(2, math.ceil(r_keel / panel_m))
    for k in range(n_r):
        pts.append((k * r_keel / n_r, z_keel))
    for (z0, r0), (z1, r1) in itertools.pairwise(profile):
        n = max(1, math.ceil(math.hypot(z1 - z0, r1 - r0) / panel_m))
        for k in range(n):
            s = k / n
            pts.append((r0 + s * (r1 - r0), z0 + s * (z1 - z0)))
    pts.append((profile[-1][1], profile[-1][0]))
    profile_xyz = np.array([(r, 0.0, z) for r, z in pts])
    # Capytaine sorts the points by z with a stable sort: the keel ring (equal z, increasing r)
    # keeps its order, so the meridian is one continuous curve from the axis up to the waterline.
    hull = cpt.RotationSymmetricMesh.from_profile_points(profile_xyz, n=n_theta)  # type: ignore[attr-defined]
    rw = profile[-1][1]
    n_lid = max(2, math.ceil(rw / panel_m))
    lid = cpt.mesh_disk(  # type: ignore[attr-defined]
        radius=rw,
        center=(0.0, 0.0, 0.0),
        normal=(0.0, 0.0, 1.0),
        resolution=(n_lid, n_theta),
        axial_symmetry=True,
    )
    return hull, lid


def solve_three_dofs(
    cpt: Any,
    hull: Any,
    lid: Any,
    name: str,
    w: NDArray[np.float64],
    depth_m: float,
    rho_kg_m3: float,
    g_m_s2: float,
    hydrostatic_stiffness: NDArray[np.float64],
) -> tuple[HydroData, float]:
    """Radiation (finite and infinite frequency) and diffraction of a hull in surge, heave
    and pitch (module docstring) as :class:`HydroData` with the given ``.hst`` stiffness:
    A(ω), B(ω) and A_∞ symmetrised, X(ω) for waves along +x conjugated to exp(+iωt),
    frequencies ascending; and the solver's wall time [s]."""
    dofs = cpt.rigid_body_dofs(only=list(_DOFS), rotation_center=(0.0, 0.0, 0.0))
    body = cpt.FloatingBody(mesh=hull, dofs=dofs, lid_mesh=lid, name=name)
    depth = None if math.isinf(depth_m) else float(depth_m)
    common = {"body": body, "water_depth": depth, "rho": rho_kg_m3, "g": g_m_s2}
    problems = [
        cpt.RadiationProblem(omega=float(x), radiating_dof=d, **common) for x in w for d in _DOFS
    ]
    problems += [cpt.DiffractionProblem(omega=float(x), wave_direction=0.0, **common) for x in w]
    inf_problems = [cpt.RadiationProblem(omega=np.inf, radiating_dof=d, **common) for d in _DOFS]
    solver = cpt.BEMSolver()
    t0 = time.perf_counter()
    results = solver.solve_all(problems + inf_problems, progress_bar=False)
    elapsed = time.perf_counter() - t0
    finite = results[: len(problems)]
    inf_results = results[len(problems) :]
    ds = cpt.assemble_dataset(finite, hydrostatics=False)
    omega_ds = np.asarray(ds["omega"].values, dtype=np.float64)
    order = np.argsort(omega_ds)
    n = omega_ds.size
    added = np.zeros((n, 3, 3))
    damp = np.zeros((n, 3, 3))
    exc = np.zeros((n, 1, 3), dtype=np.complex128)
    for i, di in enumerate(_DOFS):
        for j, dj in enumerate(_DOFS):
            sel = {"radiating_dof": dj, "influenced_dof": di}
            added[:, i, j] = np.asarray(ds["added_mass"].sel(**sel).values)[order]
            damp[:, i, j] = np.asarray(ds["radiation_damping"].sel(**sel).values)[order]
        x = ds["excitation_force"].sel(influenced_dof=di, wave_direction=0.0)
        exc[:, 0, i] = np.conj(np.asarray(x.values, dtype=np.complex128).reshape(-1)[order])
    a_inf = np.zeros((3, 3))
    for j, res in enumerate(inf_results):
        for i, di in enumerate(_DOFS):
            a_inf[i, j] = float(res.added_mass[di])
    a_inf = 0.5 * (a_inf + a_inf.T)
    added = 0.5 * (added + added.transpose(0, 2, 1))
    damp = 0.5 * (damp + damp.transpose(0, 2, 1))
    omega = omega_ds[order]
    hydro = HydroData(
        radiation=RadiationData(
            omega_rad_s=omega.copy(),
            added_mass=added,
            damping=damp,
            added_mass_inf=a_inf,
            dofs=(0, 2, 4),
        ),
        excitation=ExcitationData(
            omega_rad_s=omega.copy(),
            heading_deg=np.array([0.0]),
            force=exc,
            dofs=(0, 2, 4),
        ),
        hydrostatic_stiffness=hydrostatic_stiffness,
        rho_kg_m3=rho_kg_m3,
        g_m_s2=g_m_s2,
    )
    return hydro, elapsed


def spar_bem(
    omega_rad_s: Sequence[float] | FloatArray,
    profile: Sequence[tuple[float, float]] = OC3_HYWIND_PROFILE,
    depth_m: float = OC3_HYWIND_DEPTH_M,
    panel_m: float = 2.0,
    n_theta: int = 24,
    rho_kg_m3: float = 1025.0,
    g_m_s2: float = 9.81,
) -> tuple[HydroData, str]:
    """Solve the radiation and diffraction problems of an axisymmetric spar (Capytaine).

    Parameters
    ----------
    omega_rad_s : sequence of float
        Wave frequencies (rad/s), > 0, strictly increasing.
    profile : sequence of (z, r)
        Radius profile (m) from the keel (first) to the waterline z = 0 (last), r > 0.
    depth_m : float
        Water depth (m), > draft; ``math.inf``: deep water.
    panel_m : float
        Target panel length along the profile (m).
    n_theta : int
        Panels around.
    rho_kg_m3, g_m_s2 : float
        Water density and gravity.

    Returns
    -------
    HydroData, str
        DOFs (0, 2, 4), heading 0; and a one-line description (mesh, solver, wall time).
    """
    w = np.asarray(omega_rad_s, dtype=np.float64)
    if w.ndim != 1 or w.size == 0 or np.any(w <= 0.0) or np.any(np.diff(w) <= 0.0):
        raise ValueError("spar_bem: omega must be > 0 rad/s and strictly increasing")
    if len(profile) < 2 or abs(profile[-1][0]) > 1e-9 or any(r <= 0 for _, r in profile):
        raise ValueError("spar_bem: profile must run from the keel to z = 0 with radii > 0 m")
    if not depth_m > -profile[0][0]:
        raise ValueError("spar_bem: the depth must exceed the draft")
    cpt = _import_capytaine()
    hull, lid = _hull_mesh(cpt, profile, panel_m, n_theta)
    _, _, c_hst = profile_hydrostatics(profile, rho_kg_m3, g_m_s2)
    hydro, elapsed = solve_three_dofs(cpt, hull, lid, "spar", w, depth_m, rho_kg_m3, g_m_s2, c_hst)
    omega = hydro.radiation.omega_rad_s
    panels = int(getattr(hull, "nb_faces", 0))
    desc = (
        f"spar profile {list(profile)}, depth {depth_m:g} m; {panels} hull panels "
        f"(panel {panel_m:g} m, {n_theta} around) + lid; {omega.size} frequencies "
        f"{omega.min():g}..{omega.max():g} rad/s; capytaine "
        f"{getattr(cpt, '__version__', '?')}; {elapsed:.1f} s"
    )
    return hydro, desc


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: compute and write the npz; prints one summary line."""
    p = argparse.ArgumentParser(
        prog="python -m plant.hydro.spar_bem",
        description="Surge/heave/pitch A(w), B(w), X(w) and hydrostatics of the OC3-Hywind spar "
        "by BEM (needs the [hydro] extra); writes a HydroData npz (exp(+iwt)).",
    )
    p.add_argument("--out", type=Path, required=True, help="npz to write")
    p.add_argument("--omega-min", type=float, default=0.02, help="rad/s (default 0.02)")
    p.add_argument("--omega-max", type=float, default=3.0, help="rad/s (default 3)")
    p.add_argument("--n-omega", type=int, default=60, help="frequencies (default 60)")
    p.add_argument("--panel", type=float, default=2.0, help="panel length (m), default 2")
    p.add_argument("--n-theta", type=int, default=24, help="panels around (default 24)")
    args = p.parse_args(argv)
    omega = np.linspace(args.omega_min, args.omega_max, args.n_omega)
    try:
        hydro, desc = spar_bem(omega, panel_m=args.panel, n_theta=args.n_theta)
    except ImportError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    hydro.save_npz(args.out)
    print(f"{args.out}: {desc}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
