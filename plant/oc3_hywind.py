"""Build the ``nrel5mw_oc3_hywind`` preset (NREL 5 MW on the OC3-Hywind spar), offline.

Run once; writes the preset TOML and its data files into ``plant/presets/floating`` and
``plant/presets/hydro``::

    python -m plant.oc3_hywind            # needs the [hydro] extra (capytaine) and MoorPy

Sources (figures, not text): Jonkman (2010), *Definition of the Floating System for Phase IV of
OC3*, NREL/TP-500-47535, as carried by the OpenFAST r-test deck ``5MW_OC3Spar_DLL_WTurb_WavesIrr``
(ElastoDyn, HydroDyn, MAP inputs); rotor-nacelle figures of the NREL 5 MW (NREL/TP-500-38060), as
in the shipped ``nrel5mw_tlp`` preset. Every figure and choice:

* platform: mass 7 466 330 kg, CM 89.9155 m below SWL, pitch inertia about its CM 4.22923e9
  kg m²; displaced volume 8029.21 m³ (the profile gives 8029.3 m³);
* hydrodynamics: :func:`plant.hydro.spar_bem.spar_bem` (Capytaine) of the hull profile, depth
  320 m; radiation memory fitted and reduced once by
  :func:`plant.openfast_import.write_radiation`;
* additional linear damping (HydroDyn ``AddBLin``): surge and sway 1.0e5 N/(m/s), heave 1.3e5
  N/(m/s), yaw 1.3e7 N m/(rad/s); additional yaw stiffness (``AddCLin``, the delta-line
  crowfoot) 9.834e7 N m/rad (yaw is not a DOF of this 2-D model; kept for completeness);
* viscous drag: the deck's strip-theory drag (Cd 0.6 on the hull diameter) reduced to the
  quadratic-damping matrix B_q of :mod:`plant.platform` about the SWL, **a choice**:
  B_q,11 = ½ρ Cd ∫D dz, B_q,15 = ½ρ Cd ∫D z|z| dz, B_q,51 = ½ρ Cd ∫D z dz,
  B_q,55 = ½ρ Cd ∫D |z|³ dz (each term exact when only one of surge or pitch moves);
* mooring: three catenary lines at 0, 120, 240 deg (diameter 0.09 m, 77.7066 kg/m, EA
  384.243e6 N, unstretched 902.2 m, fairleads at radius 5.2 m, z = −70 m, anchors at radius
  853.87 m on the 320 m seabed), solved quasi-statically by
  :func:`plant.openfast_import.compute_mooring` (MoorPy; seabed friction not modelled);
* tower: the OC3-Hywind tower (base at 10 m, top at 87.6 m) is not among the reference
  figures; **assumption**: the NREL 5 MW land-based tower's distributed mass, stiffness and
  mode shape (as in ``nrel5mw_tlp``) over 10..87.6 m: 286.7 t (the OC3 tower is 249.7 t
  per Jonkman 2010), tower fore-aft period 2.09 s;
* rotor-nacelle assembly: as ``nrel5mw_tlp`` (NREL/TP-500-38060: hub 56 780 kg, nacelle
  240 000 kg at 1.9 m downwind and 1.75 m up, three blades of 17 608.8 kg; 349.6 t in all).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from pathlib import Path

import msgspec
import numpy as np

from plant.hydro.spar_bem import OC3_HYWIND_DEPTH_M, OC3_HYWIND_PROFILE, spar_bem
from plant.platform import read_floating_preset

PRESET_NAME = "nrel5mw_oc3_hywind"
RHO = 1025.0
G = 9.81
CD = 0.6


def drag_matrix(profile: Sequence[tuple[float, float]] = OC3_HYWIND_PROFILE) -> list[list[float]]:
    """Quadratic-drag matrix B_q (6x6, WAMIT DOF order) of the strip-theory hull drag.

    Integrals over the wetted length by the trapezoidal rule on 0.05 m strips (see the module
    docstring for the terms).
    """
    zs = np.linspace(profile[0][0], profile[-1][0], 2401)
    zp = [z for z, _ in profile]
    rp = [r for _, r in profile]
    d = 2.0 * np.interp(zs, zp, rp)
    c = 0.5 * RHO * CD
    b = np.zeros((6, 6))
    b[0, 0] = c * np.trapezoid(d, zs)
    b[0, 4] = c * np.trapezoid(d * zs * np.abs(zs), zs)
    b[4, 0] = c * np.trapezoid(d * zs, zs)
    b[4, 4] = c * np.trapezoid(d * np.abs(zs) ** 3, zs)
    return b.tolist()


def build(out_root: Path, n_omega: int = 45, panel_m: float = 2.0) -> Path:
    """Compute the hydrodynamics and the mooring, write the preset; return the TOML path."""
    from plant.openfast_import import MooringLine, compute_mooring, write_radiation  # noqa: PLC0415

    tlp, _, _ = read_floating_preset("nrel5mw_tlp")
    omega = np.linspace(
        0.05, 3.0, n_omega
    )  # below ~0.05 rad/s capytaine 3.0 fails at 320 m (kh < 0.2)
    hydro, desc = spar_bem(omega, panel_m=panel_m)
    hydro_dir = out_root / "hydro"
    float_dir = out_root / "floating"
    hydro.save_npz(hydro_dir / f"{PRESET_NAME}.npz")
    lines = []
    for k in range(3):
        a = math.radians(120.0 * k)
        lines.append(
            MooringLine(
                anchor_m=(853.87 * math.cos(a), 853.87 * math.sin(a), -320.0),
                fairlead_m=(5.2 * math.cos(a), 5.2 * math.sin(a), -70.0),
                length_m=902.2,
                diameter_m=0.09,
                mass_density_kg_m=77.7066,
                axial_stiffness_n=384.243e6,
            )
        )
    moor = compute_mooring(
        lines,
        OC3_HYWIND_DEPTH_M,
        RHO,
        G,
        surge_grid_m=np.arange(-30.0, 40.0 + 0.5, 1.0),
        source="MoorPy quasi-static catenaries of the OC3-Hywind lines (Jonkman 2010; OpenFAST "
        "r-test MAP input), written by plant.oc3_hywind",
    )
    (float_dir / f"{PRESET_NAME}_mooring.json").write_bytes(
        msgspec.json.format(msgspec.json.encode(moor))
    )
    zero6 = [[0.0] * 6 for _ in range(6)]
    add_b = [row[:] for row in zero6]
    add_b[0][0] = add_b[1][1] = 1.0e5
    add_b[2][2] = 1.3e5
    add_b[5][5] = 1.3e7
    add_c = [row[:] for row in zero6]
    add_c[5][5] = 9.834e7
    preset = msgspec.structs.replace(
        tlp,
        name="NREL 5 MW on the OC3-Hywind spar (surge, heave, pitch, tower fore-aft, rotor)",
        hydro_file=f"preset:hydro/{PRESET_NAME}.npz",
        mooring_file=f"preset:floating/{PRESET_NAME}_mooring.json",
        water_depth_m=OC3_HYWIND_DEPTH_M,
        displaced_volume_m3=8029.21,
        platform_mass_kg=7466330.0,
        platform_pitch_inertia_kg_m2=4.22923e9,
        platform_cm_x_m=0.0,
        platform_cm_z_m=-89.9155,
        tower_base_height_m=10.0,
        tower_top_height_m=87.6,
        additional_linear_damping=add_b,
        additional_linear_stiffness=add_c,
        additional_quadratic_damping=drag_matrix(),
        radiation_max_order=8,
        radiation_tolerance=0.02,
        radiation_omega_max_rad_s=2.0,
        radiation_file=f"preset:hydro/{PRESET_NAME}_radiation.npz",
        locked_dofs=[],
    )
    model = write_radiation(preset, hydro, hydro_dir / f"{PRESET_NAME}_radiation.npz")
    from plant.openfast_import import _toml_lines  # noqa: PLC0415

    header = [
        "NREL 5 MW on the OC3-Hywind spar (christiansen-2013): surge, heave, pitch, tower "
        "fore-aft, rotor.",
        "Written by `python -m plant.oc3_hywind`; sources and choices in plant/oc3_hywind.py "
        "and plant/presets/README.md.",
        f"hydrodynamics: {desc}",
        *(f"radiation {line}" for line in model.describe()),
        f"mooring surge stiffness at zero offset {moor.stiffness_6x6_at_zero[0][0]:.4e} N/m",
    ]
    path = float_dir / f"{PRESET_NAME}.toml"
    path.write_text(
        "".join(f"# {h}\n" for h in header) + "\n" + _toml_lines(msgspec.structs.asdict(preset)),
        encoding="utf-8",
    )
    return path


def main(argv: Sequence[str] | None = None) -> int:
    """Write the preset into the package's preset folder (or ``argv[0]``)."""
    args = list(sys.argv[1:] if argv is None else argv)
    root = Path(args[0]) if args else Path(__file__).parent / "presets"
    print(build(root))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
