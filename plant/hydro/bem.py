"""Surge hydrodynamics of a vertical circular cylinder by BEM (Capytaine), as shipped data.

Script-like module of the product, run offline once per geometry::

    python -m plant.hydro.bem --radius 4.75 --draft 30 --depth 100 \\
        --out plant/presets/hydro/nrel5mw_tlp_buoy_bem.npz

It needs the optional ``[hydro]`` extra, i.e. ``capytaine>=2.2`` (tested with 3.0.0; install
with ``pip install capytaine``); the plant never imports it at run time, it reads the npz.

What is computed (linear potential flow, SI units, water density ρ, gravity g, depth h):

* surge added mass ``A(ω)`` (kg) and radiation damping ``B(ω)`` (N s/m) of the radiation
  problem, and the infinite-frequency added mass ``A_∞`` (kg, the ω → ∞ problem);
* surge excitation per unit wave amplitude ``X(ω)`` (N/m, Froude-Krylov plus diffraction) for
  waves travelling along +x (heading 0).

The body is the wetted surface of a cylinder of radius ``R`` and draft ``T`` (side and flat
bottom), meshed with ``n_θ`` panels around, ``n_z`` along the draft and ``n_r`` rings on the
bottom; with the lid option (default) an internal free-surface lid of ``n_r x n_θ`` panels
suppresses the irregular frequencies (the first lies near ``ω² = g k tanh(k T)``-like values
of the interior sloshing problem, about 2.2 rad/s for R = 4.75 m without a lid).

Phase convention: Capytaine writes complex amplitudes for ``exp(-iωt)``
(``η(t) = Re{a e^{-iωt}}``); the product (:mod:`plant.hydro.wamit`) uses WAMIT's ``exp(+iωt)``.
Since ``Re{z e^{-iωt}} = Re{z̄ e^{+iωt}}``, the stored excitation is the complex conjugate of
Capytaine's: ``X_+ = conj(X_-)``. ``A`` and ``B`` are real and unchanged.

The result is written as :class:`plant.hydro.wamit.HydroData` (``dofs = (0,)``, surge only,
heading 0, hydrostatic surge stiffness 0) with :meth:`~plant.hydro.wamit.HydroData.save_npz`.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from plant.hydro.wamit import ExcitationData, HydroData, RadiationData

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: Requirement string of the optional extra that provides the BEM solver.
HYDRO_EXTRA_REQUIREMENT = "capytaine>=2.2"


def _import_capytaine() -> Any:
    """Import Capytaine lazily; a clear error naming the extra when it is missing."""
    try:
        import capytaine  # noqa: PLC0415  optional extra, offline only
    except ImportError as exc:
        raise ImportError(
            "plant.hydro.bem needs the optional [hydro] extra "
            f"({HYDRO_EXTRA_REQUIREMENT}): pip install 'fowt-hil[hydro]' or "
            "pip install capytaine"
        ) from exc
    return capytaine


@dataclass(frozen=True)
class CylinderMesh:
    """Panel counts of the cylinder mesh.

    Attributes
    ----------
    n_radial : int
        Rings of panels on the flat bottom (and on the lid).
    n_theta : int
        Panels around the circumference.
    n_z : int
        Panels along the draft on the side.
    """

    n_radial: int
    n_theta: int
    n_z: int

    @classmethod
    def from_panel_size(cls, radius_m: float, draft_m: float, panel_m: float) -> CylinderMesh:
        """Counts for panels of about ``panel_m`` metres (circumference, draft, radius)."""
        if not panel_m > 0.0:
            raise ValueError(f"CylinderMesh: panel size must be > 0 m, got {panel_m}")
        return cls(
            n_radial=max(2, math.ceil(radius_m / panel_m)),
            n_theta=max(8, math.ceil(2.0 * math.pi * radius_m / panel_m)),
            n_z=max(2, math.ceil(draft_m / panel_m)),
        )

    @property
    def hull_panels(self) -> int:
        """Panels on the wetted hull: ``n_θ (n_z + n_r)``."""
        return self.n_theta * (self.n_z + self.n_radial)

    @property
    def lid_panels(self) -> int:
        """Panels of the interior lid: ``n_θ n_r``."""
        return self.n_theta * self.n_radial


@dataclass(frozen=True)
class SurgeBEM:
    """Surge hydrodynamic coefficients of the cylinder (SI, ``exp(+iωt)``).

    Attributes
    ----------
    omega_rad_s : (n,) array
        Wave frequencies (rad/s).
    added_mass_kg : (n,) array
        ``A_11(ω)`` (kg).
    damping_n_s_m : (n,) array
        ``B_11(ω)`` (N s/m).
    excitation_n_m : (n,) complex array
        ``X_1(ω)`` per unit wave amplitude (N/m), heading 0, convention ``exp(+iωt)``.
    added_mass_inf_kg : float
        ``A_11(∞)`` (kg).
    radius_m, draft_m : float
        Geometry (m).
    depth_m : float
        Water depth (m); ``inf`` for deep water.
    rho_kg_m3, g_m_s2 : float
    mesh : CylinderMesh
    lid : bool
        Whether an irregular-frequency lid was used.
    elapsed_s : float
        Wall time of the BEM solves (s).
    solver : str
        Solver name and version.
    """

    omega_rad_s: FloatArray
    added_mass_kg: FloatArray
    damping_n_s_m: FloatArray
    excitation_n_m: ComplexArray
    added_mass_inf_kg: float
    radius_m: float
    draft_m: float
    depth_m: float
    rho_kg_m3: float
    g_m_s2: float
    mesh: CylinderMesh
    lid: bool
    elapsed_s: float
    solver: str

    def to_hydro_data(self) -> HydroData:
        """As :class:`~plant.hydro.wamit.HydroData` (``dofs = (0,)``, heading 0, C_11 = 0)."""
        n = self.omega_rad_s.size
        return HydroData(
            radiation=RadiationData(
                omega_rad_s=self.omega_rad_s.copy(),
                added_mass=self.added_mass_kg.reshape(n, 1, 1).copy(),
                damping=self.damping_n_s_m.reshape(n, 1, 1).copy(),
                added_mass_inf=np.array([[self.added_mass_inf_kg]]),
                dofs=(0,),
            ),
            excitation=ExcitationData(
                omega_rad_s=self.omega_rad_s.copy(),
                heading_deg=np.array([0.0]),
                force=self.excitation_n_m.reshape(n, 1, 1).copy(),
                dofs=(0,),
            ),
            hydrostatic_stiffness=np.zeros((1, 1)),
            rho_kg_m3=self.rho_kg_m3,
            g_m_s2=self.g_m_s2,
        )

    def describe(self) -> str:
        """One line: geometry, mesh, solver and wall time."""
        depth = "deep water" if math.isinf(self.depth_m) else f"depth {self.depth_m:g} m"
        lid = f" + {self.mesh.lid_panels} lid" if self.lid else ""
        return (
            f"cylinder R {self.radius_m:g} m, draft {self.draft_m:g} m, {depth}; "
            f"{self.mesh.hull_panels} hull{lid} panels (n_r, n_theta, n_z) = "
            f"({self.mesh.n_radial}, {self.mesh.n_theta}, {self.mesh.n_z}); "
            f"{self.omega_rad_s.size} frequencies {self.omega_rad_s[0]:g}..."
            f"{self.omega_rad_s[-1]:g} rad/s; rho {self.rho_kg_m3:g}, g {self.g_m_s2:g}; "
            f"{self.solver}; {self.elapsed_s:.1f} s"
        )


def cylinder_surge_bem(
    radius_m: float,
    draft_m: float,
    depth_m: float,
    omega_rad_s: Sequence[float] | FloatArray,
    mesh: CylinderMesh | None = None,
    panel_m: float = 1.0,
    lid: bool = True,
    rho_kg_m3: float = 1025.0,
    g_m_s2: float = 9.81,
) -> SurgeBEM:
    """Solve the surge radiation and diffraction problems of a vertical cylinder (Capytaine).

    Parameters
    ----------
    radius_m, draft_m : float
        Cylinder radius ``R`` and draft ``T`` (m), > 0.
    depth_m : float
        Water depth ``h`` (m) > draft; ``math.inf`` for deep water.
    omega_rad_s : sequence of float
        Wave frequencies (rad/s), > 0, increasing.
    mesh : CylinderMesh or None
        Panel counts; None: :meth:`CylinderMesh.from_panel_size` with ``panel_m``.
    panel_m : float
        Target panel size (m) when ``mesh`` is None.
    lid : bool
        Add an interior free-surface lid (irregular-frequency removal).
    rho_kg_m3, g_m_s2 : float
        Water density and gravity.

    Returns
    -------
    SurgeBEM
        ``A(ω)``, ``B(ω)``, ``A_∞`` and ``X(ω)`` (conjugated to ``exp(+iωt)``).

    Raises
    ------
    ImportError
        Without the ``[hydro]`` extra (Capytaine).
    """
    w = np.asarray(omega_rad_s, dtype=np.float64)
    if w.ndim != 1 or w.size == 0 or np.any(w <= 0.0) or np.any(np.diff(w) <= 0.0):
        raise ValueError("cylinder_surge_bem: omega must be > 0 rad/s and strictly increasing")
    if not (radius_m > 0.0 and draft_m > 0.0):
        raise ValueError("cylinder_surge_bem: radius and draft must be > 0 m")
    if not depth_m > draft_m:
        raise ValueError("cylinder_surge_bem: the depth must exceed the draft")
    cpt = _import_capytaine()
    m = mesh or CylinderMesh.from_panel_size(radius_m, draft_m, panel_m)
    # A cylinder from z = −T to +T with 2 n_z side rings, clipped at z = 0: the waterline is a
    # ring boundary and no panel lies on the free surface.
    full = cpt.mesh_vertical_cylinder(
        length=2.0 * draft_m,
        radius=radius_m,
        center=(0.0, 0.0, 0.0),
        resolution=(m.n_radial, m.n_theta, 2 * m.n_z),
        axial_symmetry=True,
    )
    hull = full.immersed_part()
    # The lid: a rotation-symmetric disk of n_r x n_θ panels in the waterplane (Capytaine's
    # generate_lid leaves gaps on rotation-symmetric meshes; Capytaine orients the lid's normals
    # itself, and a symmetric lid keeps the cheap rotation-symmetric solve).
    lid_mesh = (
        cpt.mesh_disk(
            radius=radius_m,
            center=(0.0, 0.0, 0.0),
            normal=(0.0, 0.0, 1.0),
            resolution=(m.n_radial, m.n_theta),
            axial_symmetry=True,
        )
        if lid
        else None
    )
    body = cpt.FloatingBody(
        mesh=hull, dofs=cpt.rigid_body_dofs(only=["Surge"]), lid_mesh=lid_mesh, name="cylinder"
    )
    depth = None if math.isinf(depth_m) else float(depth_m)
    common = {"body": body, "water_depth": depth, "rho": rho_kg_m3, "g": g_m_s2}
    problems = [cpt.RadiationProblem(omega=float(x), radiating_dof="Surge", **common) for x in w]
    problems += [cpt.DiffractionProblem(omega=float(x), wave_direction=0.0, **common) for x in w]
    problems.append(cpt.RadiationProblem(omega=np.inf, radiating_dof="Surge", **common))
    solver = cpt.BEMSolver()
    t0 = time.perf_counter()
    results = solver.solve_all(problems, progress_bar=False)
    elapsed = time.perf_counter() - t0
    *finite, inf_result = results
    ds = cpt.assemble_dataset(finite, hydrostatics=False)
    sel = {"radiating_dof": "Surge", "influenced_dof": "Surge"}
    omega_ds = np.asarray(ds["omega"].values, dtype=np.float64)
    order = np.argsort(omega_ds)
    added = np.asarray(ds["added_mass"].sel(**sel).values, dtype=np.float64)[order]
    damping = np.asarray(ds["radiation_damping"].sel(**sel).values, dtype=np.float64)[order]
    exc = ds["excitation_force"].sel(influenced_dof="Surge", wave_direction=0.0)
    x_minus = np.asarray(exc.values, dtype=np.complex128).reshape(-1)[order]
    a_inf = float(inf_result.added_mass["Surge"])
    return SurgeBEM(
        omega_rad_s=omega_ds[order],
        added_mass_kg=added,
        damping_n_s_m=damping,
        excitation_n_m=np.conj(x_minus),  # exp(-iωt) -> exp(+iωt)
        added_mass_inf_kg=a_inf,
        radius_m=float(radius_m),
        draft_m=float(draft_m),
        depth_m=float(depth_m),
        rho_kg_m3=float(rho_kg_m3),
        g_m_s2=float(g_m_s2),
        mesh=m,
        lid=lid,
        elapsed_s=elapsed,
        solver=f"capytaine {getattr(cpt, '__version__', '?')}",
    )


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m plant.hydro.bem",
        description="Surge A(w), B(w), X(w) of a vertical cylinder by BEM (needs [hydro]: "
        f"{HYDRO_EXTRA_REQUIREMENT}); writes a HydroData npz (exp(+iwt), surge only).",
    )
    p.add_argument("--radius", type=float, required=True, help="cylinder radius (m)")
    p.add_argument("--draft", type=float, required=True, help="draft (m)")
    p.add_argument("--depth", type=float, default=math.inf, help="water depth (m), default deep")
    p.add_argument("--out", type=Path, required=True, help="npz to write")
    p.add_argument("--omega-min", type=float, default=0.05, help="rad/s (default 0.05)")
    p.add_argument("--omega-max", type=float, default=3.0, help="rad/s (default 3)")
    p.add_argument("--n-omega", type=int, default=50, help="frequencies (default 50)")
    p.add_argument("--panel", type=float, default=1.0, help="target panel size (m), default 1")
    p.add_argument(
        "--resolution",
        type=int,
        nargs=3,
        metavar=("N_R", "N_THETA", "N_Z"),
        help="panel counts (bottom rings, around, along the draft); overrides --panel",
    )
    p.add_argument("--no-lid", action="store_true", help="no irregular-frequency lid")
    p.add_argument("--rho", type=float, default=1025.0, help="water density (kg/m^3)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (m/s^2)")
    p.add_argument(
        "--radiation-out",
        type=Path,
        help="also write the surge radiation state space (RadiationModel npz) fitted to the result",
    )
    p.add_argument("--radiation-order", type=int, default=4, help="its order (default 4)")
    p.add_argument(
        "--radiation-omega-max", type=float, default=2.0, help="its fit band top (rad/s)"
    )
    return p


def write_radiation_fit(
    hydro: HydroData, path: Path, order: int = 4, omega_max_rad_s: float = 2.0
) -> str:
    """Fit the surge kernel at a fixed order over ``0..omega_max`` and write the npz.

    :func:`plant.hydro.radiation.fixed_order_radiation` (Perez-Fossen, passivity constrained),
    saved with :meth:`plant.hydro.radiation.RadiationModel.save_npz`. Returns a summary line.
    """
    from plant.hydro.radiation import fixed_order_radiation  # noqa: PLC0415

    model = fixed_order_radiation(
        hydro.radiation,
        dofs=(0,),
        order=order,
        omega_range_rad_s=(0.0, omega_max_rad_s),
        source=f"Perez-Fossen fit of order {order} of the surge kernel of the BEM data "
        f"(plant.hydro.bem), 0..{omega_max_rad_s:g} rad/s",
    )
    model.save_npz(path)
    return f"{path}: " + "; ".join(model.describe())


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: compute and write the npz; prints one summary line."""
    args = _parser().parse_args(argv)
    omega = np.linspace(args.omega_min, args.omega_max, args.n_omega)
    mesh = CylinderMesh(*args.resolution) if args.resolution else None
    try:
        res = cylinder_surge_bem(
            args.radius,
            args.draft,
            args.depth,
            omega,
            mesh=mesh,
            panel_m=args.panel,
            lid=not args.no_lid,
            rho_kg_m3=args.rho,
            g_m_s2=args.g,
        )
    except ImportError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    hydro = res.to_hydro_data()
    hydro.save_npz(args.out)
    print(f"{args.out}: {res.describe()}; A_inf {res.added_mass_inf_kg:.6e} kg")
    if args.radiation_out is not None:
        print(
            write_radiation_fit(
                hydro, args.radiation_out, args.radiation_order, args.radiation_omega_max
            )
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
