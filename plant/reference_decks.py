"""Write OpenFAST decks of the OC3-Hywind spar and the OC4-DeepCwind semi from published figures.

Offline, for users and for the importer's benchmark (``bench/openfast_import_periods.py``)::

    python -m plant.reference_decks --out DIR [--platform oc3|oc4] [--generation fast8|openfast4]

(the OC4 hydrodynamics need the ``[hydro]`` extra, capytaine). The OpenFAST r-test decks
``5MW_OC3Spar_DLL_WTurb_WavesIrr`` and ``5MW_OC4Semi_WSt_WavesWN`` cannot be shipped (their
text and WAMIT files are not ours), so :func:`write_deck` writes decks in their style, in two
format generations, from figures whose source is named beside each:

* ``fast8``: FAST v8 / OpenFAST < 3.5 layout: ``Gravity`` in ElastoDyn, ``WtrDens`` and
  ``WtrDpth`` in HydroDyn, ``AddF0`` on one row, ``NPropSets``, member table without
  ``MSecGeom``, FAST v8 blade table (with ``PitchAxis``), MoorDyn v1 (``CONNECTION
  PROPERTIES``, ``NodeAnch``/``NodeFair``), ``BldFile(1)``.
* ``openfast4``: OpenFAST 4 layout: environment in the ``.fst``, a SeaState file,
  ``AddF0`` one value a line, ``NPropSetsCyl``/``NPropSetsRec``, members with ``MSecGeom``,
  ``MSpinOrient``, ``MHstLMod``, the five-column blade table, MoorDyn v2 (``POINTS``,
  ``AttachA``/``AttachB``), ``BldFile1``.

Aerodynamics, inflow and control are off (``CompAero = CompInflow = CompServo = 0``): the decks
describe the parked turbine, which is what the periods benchmark needs.

Hydrodynamics (WAMIT ``.1``, ``.3``, ``.hst`` by :func:`plant.hydro.wamit.write_wamit`) come
from the caller's :class:`plant.hydro.wamit.HydroData`: for OC3 the shipped
``preset:hydro/nrel5mw_oc3_hywind.npz`` (:mod:`plant.hydro.spar_bem`, capytaine), for OC4
:func:`plant.hydro.semi_bem.semi_bem` of the columns (capytaine). ``PtfmVol0`` is the volume of
the hull the hydro data were computed for, as HydroDyn asks ("the same value computed by
WAMIT").

Choices that differ from the r-test decks, each deliberate:

* OC4: the r-test's WAMIT model (MARIN) includes the pontoons and braces (all members
  ``PropPot = TRUE``, ``PtfmVol0`` 13917 m³); here the BEM meshes the columns only and the 15
  pontoons and cross braces (D 1.6 m) are strip-theory members, ``PropPot = FALSE``, with the
  r-test's Cd 0.63 and **Ca 1.0** (the potential-flow transverse added-mass coefficient of a
  circular cylinder; the r-test has Ca 0 because WAMIT carries their added mass).
* OC3: MoorDyn instead of MAP++ (the importer reads MoorDyn; the r-test deck ships a MoorDyn
  file of the same lines, whose figures are used), no delta crowfoot (its yaw stiffness is the
  deck's ``AddCLin(6,6)``, as in the r-test).
* Tower (both): the OC3 tower of Jonkman (2010), NREL/TP-500-47535 (also OC4's, Robertson et
  al. 2014, NREL/TP-5000-60601): steel tube, D 6.5 m and wall 0.027 m at its base (10 m above
  SWL), D 3.87 m and 0.019 m at its top (87.6 m), linear in between, density 8500 kg/m³, E 210
  GPa: μ = ρ π (D − t) t, EI = E π (D − t)³ t / 8 at 11 stations (249.6 t, the report's
  249 718 kg within 0.03 %). Its mode-shape polynomial is not published in the reports:
  **assumption**, that of the land-based NREL 5 MW tower (``nrel5mw`` presets).
* Blade (both): the NREL 5 MW blade (Jonkman et al. 2009, NREL/TP-500-38060, Table 2-1, as in
  the OpenFAST ``NRELOffshrBsline5MW_Blade.dat``): ``BlFract``, ``StrcTwst``, ``BMassDen``,
  ``FlpStff``, ``EdgStff`` and ``AdjBlMs`` = 1.04536. The FAST v8 layout's ``PitchAxis`` column is
  written as 0.5 everywhere: **not a published figure** (the importer does not read it).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plant.hydro.wamit import HydroData, load_hydro_preset, write_wamit

__all__ = [
    "GENERATIONS",
    "OC3",
    "OC4",
    "PLATFORMS",
    "DeckFigures",
    "oc4_hydro",
    "write_deck",
]

GENERATIONS = ("fast8", "openfast4")

#: NREL 5 MW blade, Jonkman et al. (2009) Table 2-1 (the OpenFAST NRELOffshrBsline5MW_Blade.dat
#: figures): (BlFract, StrcTwst deg, BMassDen kg/m, FlpStff N m², EdgStff N m²).
_BLADE = (
    (0.0, 13.308, 678.935, 18110000000.0, 18113600000.0),
    (0.00325, 13.308, 678.935, 18110000000.0, 18113600000.0),
    (0.01951, 13.308, 773.363, 19424900000.0, 19558600000.0),
    (0.03577, 13.308, 740.55, 17455900000.0, 19497800000.0),
    (0.05203, 13.308, 740.042, 15287400000.0, 19788800000.0),
    (0.06829, 13.308, 592.496, 10782400000.0, 14858500000.0),
    (0.08455, 13.308, 450.275, 7229720000.0, 10220600000.0),
    (0.10081, 13.308, 424.054, 6309540000.0, 9144700000.0),
    (0.11707, 13.308, 400.638, 5528360000.0, 8063160000.0),
    (0.13335, 13.308, 382.062, 4980060000.0, 6884440000.0),
    (0.14959, 13.308, 399.655, 4936840000.0, 7009180000.0),
    (0.16585, 13.308, 426.321, 4691660000.0, 7167680000.0),
    (0.18211, 13.181, 416.82, 3949460000.0, 7271660000.0),
    (0.19837, 12.848, 406.186, 3386520000.0, 7081700000.0),
    (0.21465, 12.192, 381.42, 2933740000.0, 6244530000.0),
    (0.23089, 11.561, 352.822, 2568960000.0, 5048960000.0),
    (0.24715, 11.072, 349.477, 2388650000.0, 4948490000.0),
    (0.26341, 10.792, 346.538, 2271990000.0, 4808020000.0),
    (0.29595, 10.232, 339.333, 2050050000.0, 4501400000.0),
    (0.32846, 9.672, 330.004, 1828250000.0, 4244070000.0),
    (0.36098, 9.11, 321.99, 1588710000.0, 3995280000.0),
    (0.3935, 8.534, 313.82, 1361930000.0, 3750760000.0),
    (0.42602, 7.932, 294.734, 1102380000.0, 3447140000.0),
    (0.45855, 7.321, 287.12, 875800000.0, 3139070000.0),
    (0.49106, 6.711, 263.343, 681300000.0, 2734240000.0),
    (0.52358, 6.122, 253.207, 534720000.0, 2554870000.0),
    (0.5561, 5.546, 241.666, 408900000.0, 2334030000.0),
    (0.58862, 4.971, 220.638, 314540000.0, 1828730000.0),
    (0.62115, 4.401, 200.293, 238630000.0, 1584100000.0),
    (0.65366, 3.834, 179.404, 175880000.0, 1323360000.0),
    (0.68618, 3.332, 165.094, 126010000.0, 1183680000.0),
    (0.7187, 2.89, 154.411, 107260000.0, 1020160000.0),
    (0.75122, 2.503, 138.935, 90880000.0, 797810000.0),
    (0.78376, 2.116, 129.555, 76310000.0, 709610000.0),
    (0.81626, 1.73, 107.264, 61050000.0, 518190000.0),
    (0.84878, 1.342, 98.776, 49480000.0, 454870000.0),
    (0.8813, 0.954, 90.248, 39360000.0, 395120000.0),
    (0.89756, 0.76, 83.001, 34670000.0, 353720000.0),
    (0.91382, 0.574, 72.906, 30410000.0, 304730000.0),
    (0.93008, 0.404, 68.772, 26520000.0, 281420000.0),
    (0.93821, 0.319, 66.264, 23840000.0, 261710000.0),
    (0.94636, 0.253, 59.34, 19630000.0, 158810000.0),
    (0.95447, 0.216, 55.914, 16000000.0, 137880000.0),
    (0.9626, 0.178, 52.484, 12830000.0, 118790000.0),
    (0.97073, 0.14, 49.114, 10080000.0, 101630000.0),
    (0.97886, 0.101, 45.818, 7550000.0, 85070000.0),
    (0.98699, 0.062, 41.669, 4600000.0, 64260000.0),
    (0.99512, 0.023, 11.453, 250000.0, 6610000.0),
    (1.0, 0.0, 10.319, 170000.0, 5010000.0),
)
_ADJ_BL_MS = 1.04536  # AdjBlMs of the same file
#: Tower first fore-aft mode polynomial (x² .. x⁶) of the land-based NREL 5 MW tower (the
#: shipped ``nrel5mw`` presets); an assumption for the OC3 tower (see the module docstring).
_TOWER_SHAPE = (0.7004, 2.1963, -5.6202, 6.2275, -2.504)


@dataclass(frozen=True)
class DeckFigures:
    """The published figures of one platform that the deck writes (SI).

    ``members``: HydroDyn joints ``(id, x, y, z, JointAxID)``, property sets ``(id, D, t)``
    and members ``(id, joint1, joint2, prop1, prop2, Cd, Ca, PropPot)``; ``fill_groups``:
    ``(member ids, FillFSLoc, FillDens)``; mooring: anchors and fairleads (x, y, z) and one
    line type.
    """

    key: str
    title: str
    depth_m: float
    ptfm_mass_kg: float
    ptfm_cm_z_m: float
    ptfm_roll_pitch_inertia_kg_m2: float
    ptfm_yaw_inertia_kg_m2: float
    add_c_lin: tuple[tuple[float, ...], ...]
    add_b_lin: tuple[tuple[float, ...], ...]
    joints: tuple[tuple[int, float, float, float, int], ...]
    props: tuple[tuple[int, float, float], ...]
    members: tuple[tuple[int, int, int, int, int, float, float, bool], ...]
    fill_groups: tuple[tuple[tuple[int, ...], float, float], ...]
    axial_coefs: tuple[tuple[int, float, float], ...]
    anchors: tuple[tuple[float, float, float], ...]
    fairleads: tuple[tuple[float, float, float], ...]
    line_diameter_m: float
    line_mass_kg_m: float
    line_ea_n: float
    line_length_m: float
    sources: tuple[str, ...]


def _diag6(**entries: float) -> tuple[tuple[float, ...], ...]:
    idx = {"surge": 0, "sway": 1, "heave": 2, "roll": 3, "pitch": 4, "yaw": 5}
    m = [[0.0] * 6 for _ in range(6)]
    for name, v in entries.items():
        m[idx[name]][idx[name]] = v
    return tuple(tuple(r) for r in m)


def _ring(
    radius: float, z: float, first_deg: float = 0.0
) -> tuple[tuple[float, float, float], ...]:
    return tuple(
        (
            round(radius * math.cos(math.radians(first_deg + k * 120.0)), 5),
            round(radius * math.sin(math.radians(first_deg + k * 120.0)), 5),
            z,
        )
        for k in range(3)
    )


OC3 = DeckFigures(
    key="oc3",
    title="NREL 5 MW on the OC3-Hywind spar (figures of Jonkman 2010, NREL/TP-500-47535)",
    depth_m=320.0,  # TP-500-47535 Table 4-1 (the r-test HydroDyn WtrDpth)
    ptfm_mass_kg=7_466_330.0,  # incl. ballast, Table 4-1 / r-test ElastoDyn PtfmMass
    ptfm_cm_z_m=-89.9155,  # CM below SWL, same
    ptfm_roll_pitch_inertia_kg_m2=4.22923e9,  # about the CM, same
    ptfm_yaw_inertia_kg_m2=1.6423e8,  # same
    add_c_lin=_diag6(yaw=9.834e7),  # delta-line yaw spring, Table 5-1 / r-test AddCLin(6,6)
    add_b_lin=_diag6(surge=1.0e5, sway=1.0e5, heave=1.3e5, yaw=1.3e7),  # Sect. 4 / AddBLin
    # Hull: D 9.4 m from -120 to -12 m, taper to 6.5 m at -4 m, D 6.5 m to +10 m (Table 4-1)
    joints=(
        (1, 0.0, 0.0, -120.0, 1),
        (2, 0.0, 0.0, -12.0, 1),
        (3, 0.0, 0.0, -4.0, 1),
        (4, 0.0, 0.0, 10.0, 1),
    ),
    props=((1, 9.4, 0.0027), (2, 6.5, 0.0027)),  # wall: not used for an unfilled member
    members=(
        (1, 1, 2, 1, 1, 0.6, 0.0, True),
        (2, 2, 3, 1, 2, 0.6, 0.0, True),
        (3, 3, 4, 2, 2, 0.6, 0.0, True),
    ),  # Cd 0.6 (Sect. 4.2), in WAMIT (PropPot)
    fill_groups=(),  # the ballast is in PtfmMass
    axial_coefs=((1, 0.0, 0.0),),
    # r-test NRELOffshrBsline5MW_OC3Hywind_MoorDyn.dat (TP-500-47535 Table 5-1)
    anchors=((853.87, 0.0, -320.0), (-426.94, 739.47, -320.0), (-426.94, -739.47, -320.0)),
    fairleads=((5.2, 0.0, -70.0), (-2.6, 4.5, -70.0), (-2.6, -4.5, -70.0)),
    line_diameter_m=0.09,
    line_mass_kg_m=77.7066,
    line_ea_n=384.243e6,
    line_length_m=902.2,
    sources=(
        "Jonkman (2010), Definition of the Floating System for Phase IV of OC3, NREL/TP-500-47535",
        "OpenFAST r-test 5MW_OC3Spar_DLL_WTurb_WavesIrr (ElastoDyn, HydroDyn, MoorDyn figures)",
    ),
)

# OC4-DeepCwind: the r-test HydroDyn member table of 5MW_OC4Semi_WSt_WavesWN (joints, property
# sets, members, fill groups; Robertson et al. 2014, NREL/TP-5000-60601, Tables 3-1, 3-3).
_OC4_JOINTS = (
    (1, 0.0, 0.0, -20.0, 1),
    (2, 0.0, 0.0, 10.0, 1),
    (3, 14.43376, 25.0, -14.0, 1),
    (4, 14.43376, 25.0, 12.0, 1),
    (5, -28.86751, 0.0, -14.0, 1),
    (6, -28.86751, 0.0, 12.0, 1),
    (7, 14.43376, -25.0, -14.0, 1),
    (8, 14.43376, -25.0, 12.0, 1),
    (9, 14.43375, 25.0, -20.0, 2),
    (10, -28.8675, 0.0, -20.0, 2),
    (11, 14.43375, -25.0, -20.0, 2),
    (12, 9.2376, 22.0, 10.0, 1),
    (13, -23.6713, 3.0, 10.0, 1),
    (14, -23.6713, -3.0, 10.0, 1),
    (15, 9.2376, -22.0, 10.0, 1),
    (16, 14.43375, -19.0, 10.0, 1),
    (17, 14.43375, 19.0, 10.0, 1),
    (18, 4.04145, 19.0, -17.0, 1),
    (19, -18.4752, 6.0, -17.0, 1),
    (20, -18.4752, -6.0, -17.0, 1),
    (21, 4.04145, -19.0, -17.0, 1),
    (22, 14.43375, -13.0, -17.0, 1),
    (23, 14.43375, 13.0, -17.0, 1),
    (24, 1.625, 2.815, 10.0, 1),
    (25, 11.43376, 19.80385, 10.0, 1),
    (26, -3.25, 0.0, 10.0, 1),
    (27, -22.87, 0.0, 10.0, 1),
    (28, 1.625, -2.815, 10.0, 1),
    (29, 11.43376, -19.80385, 10.0, 1),
    (30, 1.625, 2.815, -17.0, 1),
    (31, 8.43376, 14.6077, -17.0, 1),
    (32, -3.25, 0.0, -17.0, 1),
    (33, -16.87, 0.0, -17.0, 1),
    (34, 1.625, -2.815, -17.0, 1),
    (35, 8.43376, -14.6077, -17.0, 1),
    (36, 1.625, 2.815, -16.2, 1),
    (37, 11.43376, 19.80385, 9.13, 1),
    (38, -3.25, 0.0, -16.2, 1),
    (39, -22.87, 0.0, 9.13, 1),
    (40, 1.625, -2.815, -16.2, 1),
    (41, 11.43376, -19.80385, 9.13, 1),
    (42, 14.43376, 25.0, -19.94, 1),
    (43, -28.86751, 0.0, -19.94, 1),
    (44, 14.43376, -25.0, -19.94, 1),
)
_PONTOON_CD, _PONTOON_CA = 0.63, 1.0  # Cd: r-test; Ca: potential-flow value (a choice)
_OC4_COLUMN_MEMBERS = (
    (1, 1, 2, 1, 1, 0.56, 0.0, True),  # main column
    (2, 3, 4, 2, 2, 0.61, 0.0, True),  # upper columns
    (3, 5, 6, 2, 2, 0.61, 0.0, True),
    (4, 7, 8, 2, 2, 0.61, 0.0, True),
    (5, 42, 3, 3, 3, 0.68, 0.0, True),  # base columns
    (6, 43, 5, 3, 3, 0.68, 0.0, True),
    (7, 44, 7, 3, 3, 0.68, 0.0, True),
    (23, 9, 42, 3, 3, 0.68, 0.0, True),  # base column caps
    (24, 10, 43, 3, 3, 0.68, 0.0, True),
    (25, 11, 44, 3, 3, 0.68, 0.0, True),
)
_OC4_MEMBERS = _OC4_COLUMN_MEMBERS + tuple(
    (mid, j1, j2, 4, 4, _PONTOON_CD, _PONTOON_CA, False)
    for mid, j1, j2 in (
        (8, 12, 13),
        (9, 14, 15),
        (10, 16, 17),  # delta pontoons, upper
        (11, 18, 19),
        (12, 20, 21),
        (13, 22, 23),  # delta pontoons, lower
        (14, 24, 25),
        (15, 26, 27),
        (16, 28, 29),  # Y pontoons, upper
        (17, 30, 31),
        (18, 32, 33),
        (19, 34, 35),  # Y pontoons, lower
        (20, 36, 37),
        (21, 38, 39),
        (22, 40, 41),  # cross braces
    )
)

OC4 = DeckFigures(
    key="oc4",
    title="NREL 5 MW on the OC4-DeepCwind semi (figures of Robertson et al. 2014, "
    "NREL/TP-5000-60601)",
    depth_m=200.0,  # r-test HydroDyn WtrDpth
    ptfm_mass_kg=3_852_180.0,  # r-test ElastoDyn PtfmMass (structure; ballast = fill groups)
    ptfm_cm_z_m=-8.6588,  # r-test ElastoDyn PtfmCMzt
    ptfm_roll_pitch_inertia_kg_m2=2.56193e9,  # r-test ElastoDyn PtfmPIner
    ptfm_yaw_inertia_kg_m2=4.24265e9,  # r-test ElastoDyn PtfmYIner
    add_c_lin=_diag6(),  # r-test: all zero
    add_b_lin=_diag6(),
    joints=_OC4_JOINTS,
    props=((1, 6.5, 0.03), (2, 12.0, 0.06), (3, 24.0, 0.06), (4, 1.6, 0.0175)),  # r-test
    members=_OC4_MEMBERS,
    fill_groups=(((2, 3, 4), -6.17, 1025.0), ((5, 6, 7), -14.89, 1025.0)),  # r-test
    axial_coefs=((1, 0.0, 0.0), (2, 9.6, 0.0)),  # r-test (AxCd, AxCa): heave plates AxCa 0
    # r-test NRELOffshrBsline5MW_OC4DeepCwindSemi_MoorDyn.dat (Robertson 2014 Table 3-4)
    anchors=((418.8, 725.383, -200.0), (-837.6, 0.0, -200.0), (418.8, -725.383, -200.0)),
    fairleads=((20.434, 35.393, -14.0), (-40.868, 0.0, -14.0), (20.434, -35.393, -14.0)),
    line_diameter_m=0.0766,
    line_mass_kg_m=113.35,
    line_ea_n=7.536e8,
    line_length_m=835.35,
    sources=(
        "Robertson et al. (2014), Definition of the Semisubmersible Floating System for "
        "Phase II of OC4, NREL/TP-5000-60601",
        "OpenFAST r-test 5MW_OC4Semi_WSt_WavesWN (ElastoDyn, HydroDyn, MoorDyn figures)",
    ),
)

PLATFORMS = {"oc3": OC3, "oc4": OC4}


def oc4_hydro(n_omega: int = 40, panel_m: float = 2.0, n_theta: int = 16) -> tuple[HydroData, str]:
    """Capytaine hydrodynamics of the OC4 columns over 0.05..3 rad/s (needs ``[hydro]``)."""
    from plant.hydro.semi_bem import semi_bem  # noqa: PLC0415  optional extra

    return semi_bem(np.linspace(0.05, 3.0, n_omega), panel_m=panel_m, n_theta=n_theta)


def _hydro_volume(figures: DeckFigures) -> float:
    """Displaced volume of the hull the hydro data describe (``PtfmVol0``)."""
    if figures.key == "oc3":
        from plant.hydro.spar_bem import OC3_HYWIND_PROFILE, profile_hydrostatics  # noqa: PLC0415

        return profile_hydrostatics(OC3_HYWIND_PROFILE)[0]
    from plant.hydro.semi_bem import OC4_COLUMNS, columns_hydrostatics  # noqa: PLC0415

    return columns_hydrostatics(OC4_COLUMNS)[0]


def _line(value: object, key: str, text: str = "") -> str:
    v = f'"{value}"' if isinstance(value, str) else f"{value}"
    return f"{v:>14}   {key:<12} - {text}\n"


def _matrix(rows: Sequence[Sequence[float]], key: str, text: str) -> str:
    out = ""
    for k, row in enumerate(rows):
        cells = "".join(f"{v:>14.6g}" for v in row)
        out += f"{cells}   {key} - {text}\n" if k == 0 else f"{cells}\n"
    return out


def _tower_rows() -> list[tuple[float, float, float]]:
    rows = []
    for k in range(11):
        s = k / 10.0
        d = 6.5 + (3.87 - 6.5) * s
        t = 0.027 + (0.019 - 0.027) * s
        mu = 8500.0 * math.pi * (d - t) * t
        ei = 210e9 * math.pi / 8.0 * (d - t) ** 3 * t
        rows.append((s, mu, ei))
    return rows


def _write_tower(path: Path) -> None:
    text = "------- ELASTODYN TOWER INPUT FILE -------------------------------------------\n"
    text += (
        "OC3 tower (Jonkman 2010, NREL/TP-500-47535): D 6.5 m / t 0.027 m at the base, 3.87 m "
        "/ 0.019 m at the top, 8500 kg/m^3, E 210 GPa; written by plant.reference_decks\n"
    )
    text += "---------------------- TOWER PARAMETERS ----------------------------------------\n"
    text += _line(11, "NTwInpSt", "Number of input stations to specify tower geometry")
    text += _line(1.0, "TwrFADmp(1)", "Tower 1st fore-aft mode structural damping ratio (%)")
    text += _line(1.0, "TwrFADmp(2)", "Tower 2nd fore-aft mode structural damping ratio (%)")
    text += _line(1.0, "TwrSSDmp(1)", "Tower 1st side-to-side mode structural damping ratio (%)")
    text += "---------------------- TOWER ADJUSTMUNT FACTORS --------------------------------\n"
    text += _line(1.0, "FAStTunr(1)", "Tower fore-aft modal stiffness tuner, 1st mode (-)")
    text += _line(1.0, "AdjTwMa", "Factor to adjust tower mass density (-)")
    text += _line(1.0, "AdjFASt", "Factor to adjust tower fore-aft stiffness (-)")
    text += _line(1.0, "AdjSSSt", "Factor to adjust tower side-to-side stiffness (-)")
    text += "---------------------- DISTRIBUTED TOWER PROPERTIES ----------------------------\n"
    text += "  HtFract       TMassDen         TwFAStif       TwSSStif\n"
    text += "   (-)           (kg/m)           (Nm^2)         (Nm^2)\n"
    for s, mu, ei in _tower_rows():
        text += f"  {s:.3f}   {mu:14.6E}   {ei:14.6E}   {ei:14.6E}\n"
    text += "---------------------- TOWER FORE-AFT MODE SHAPES ------------------------------\n"
    for k, c in enumerate(_TOWER_SHAPE, start=2):
        text += _line(c, f"TwFAM1Sh({k})", f"Mode 1, coefficient of x^{k} term")
    path.write_text(text, encoding="utf-8")


def _write_blade(path: Path, generation: str) -> None:
    text = "------- ELASTODYN INDIVIDUAL BLADE INPUT FILE --------------------------\n"
    text += (
        "NREL 5 MW blade (Jonkman et al. 2009, NREL/TP-500-38060, Table 2-1); written by "
        f"plant.reference_decks ({generation} layout)\n"
    )
    text += "---------------------- BLADE PARAMETERS ----------------------------------------\n"
    text += _line(len(_BLADE), "NBlInpSt", "Number of blade input stations (-)")
    text += "---------------------- BLADE ADJUSTMENT FACTORS --------------------------------\n"
    text += _line(1.0, "FlStTunr(1)", "Blade flapwise modal stiffness tuner, 1st mode (-)")
    text += _line(_ADJ_BL_MS, "AdjBlMs", "Factor to adjust blade mass density (-)")
    text += "---------------------- DISTRIBUTED BLADE PROPERTIES ----------------------------\n"
    if generation == "fast8":
        text += "    BlFract  PitchAxis   StrcTwst   BMassDen      FlpStff      EdgStff\n"
        text += "      (-)       (-)        (deg)     (kg/m)       (Nm^2)       (Nm^2)\n"
        for f, tw, m, fl, ed in _BLADE:
            text += f"  {f:.5f}   0.500   {tw:8.3f}   {m:9.3f}   {fl:12.5E}   {ed:12.5E}\n"
    else:
        text += "    BlFract   StrcTwst   BMassDen      FlpStff      EdgStff\n"
        text += "      (-)        (deg)     (kg/m)       (Nm^2)       (Nm^2)\n"
        for f, tw, m, fl, ed in _BLADE:
            text += f"  {f:.5f}   {tw:8.3f}   {m:9.3f}   {fl:12.5E}   {ed:12.5E}\n"
    path.write_text(text, encoding="utf-8")


def _write_elastodyn(path: Path, fig: DeckFigures, generation: str) -> None:
    text = "------- ELASTODYN INPUT FILE -------------------------------------------\n"
    text += f"{fig.title}; written by plant.reference_decks ({generation} layout)\n"
    text += "---------------------- SIMULATION CONTROL --------------------------------------\n"
    text += _line("False", "Echo", "Echo input data (flag)")
    text += "---------------------- ENVIRONMENTAL CONDITION ---------------------------------\n"
    if generation == "fast8":
        text += _line(9.80665, "Gravity", "Gravitational acceleration (m/s^2)")
    text += "---------------------- TURBINE CONFIGURATION -----------------------------------\n"
    # NREL 5 MW (NREL/TP-500-38060; the r-test ElastoDyn files of both platforms)
    for value, key, what in (
        (3, "NumBl", "Number of blades (-)"),
        (63.0, "TipRad", "The distance from the rotor apex to the blade tip (meters)"),
        (1.5, "HubRad", "The distance from the rotor apex to the blade root (meters)"),
        (-2.5, "PreCone(1)", "Blade 1 cone angle (degrees)"),
        (0.0, "HubCM", "Distance from rotor apex to hub mass (meters)"),
        (-5.0191, "OverHang", "Distance from yaw axis to rotor apex (meters)"),
        (-5.0, "ShftTilt", "Rotor shaft tilt angle (degrees)"),
        (1.9, "NacCMxn", "Downwind distance from the tower-top to the nacelle CM (meters)"),
        (1.75, "NacCMzn", "Vertical distance from the tower-top to the nacelle CM (meters)"),
        (1.96256, "Twr2Shft", "Vertical distance from the tower-top to the rotor shaft (m)"),
        (87.6, "TowerHt", "Height of tower above MSL (meters)"),
        (10.0, "TowerBsHt", "Height of tower base above MSL (meters)"),
        (0.0, "PtfmCMxt", "Downwind distance from MSL to the platform CM (meters)"),
        (0.0, "PtfmCMyt", "Lateral distance from MSL to the platform CM (meters)"),
        (fig.ptfm_cm_z_m, "PtfmCMzt", "Vertical distance from MSL to the platform CM (m)"),
        (0.0, "PtfmRefzt", "Vertical distance from MSL to the platform reference point (m)"),
    ):
        text += _line(value, key, what)
    text += "---------------------- MASS AND INERTIA ----------------------------------------\n"
    for value, key, what in (
        (56780.0, "HubMass", "Hub mass (kg)"),
        (115926.0, "HubIner", "Hub inertia about rotor axis (kg m^2)"),
        (534.116, "GenIner", "Generator inertia about HSS (kg m^2)"),
        (240000.0, "NacMass", "Nacelle mass (kg)"),
        (2607890.0, "NacYIner", "Nacelle inertia about yaw axis (kg m^2)"),
        (0.0, "YawBrMass", "Yaw bearing mass (kg)"),
        (fig.ptfm_mass_kg, "PtfmMass", "Platform mass (kg)"),
        (fig.ptfm_roll_pitch_inertia_kg_m2, "PtfmRIner", "Platform roll inertia about CM"),
        (fig.ptfm_roll_pitch_inertia_kg_m2, "PtfmPIner", "Platform pitch inertia about CM"),
        (fig.ptfm_yaw_inertia_kg_m2, "PtfmYIner", "Platform yaw inertia about CM (kg m^2)"),
    ):
        text += _line(value, key, what)
    text += "---------------------- BLADE ---------------------------------------------------\n"
    text += _line(17, "BldNodes", "Number of blade nodes (per blade) used for analysis (-)")
    for k in (1, 2, 3):
        key = f"BldFile({k})" if generation == "fast8" else f"BldFile{k}"
        text += _line("blade.dat", key, f"Name of file containing properties for blade {k}")
    text += "---------------------- TOWER ---------------------------------------------------\n"
    text += _line(20, "TwrNodes", "Number of tower nodes used for analysis (-)")
    text += _line("tower.dat", "TwrFile", "Name of file containing tower properties")
    path.write_text(text, encoding="utf-8")


def _write_hydrodyn(path: Path, fig: DeckFigures, generation: str, volume: float) -> None:
    new = generation != "fast8"
    text = "------- HydroDyn Input File ----------------------------------------------------\n"
    text += f"{fig.title}; written by plant.reference_decks ({generation} layout)\n"
    text += _line("False", "Echo", "Echo the input file data (flag)")
    if not new:
        text += "---------------------- ENVIRONMENTAL CONDITIONS --------------------------------\n"
        text += _line(1025.0, "WtrDens", "Water density (kg/m^3)")
        text += _line(fig.depth_m, "WtrDpth", "Water depth (meters)")
        text += _line(0.0, "MSL2SWL", "Offset between still-water level and mean sea level (m)")
    text += "---------------------- FLOATING PLATFORM ---------------------------------------\n"
    text += _line(1, "PotMod", "Potential-flow model {1: WAMIT} (switch)")
    text += _line(1, "NBody", "Number of WAMIT bodies (-)")
    text += _line("HydroData/platform", "PotFile", "Root name of potential-flow model data")
    text += _line(1.0, "WAMITULEN", "Characteristic body length scale (meters)")
    text += _line(0.0, "PtfmRefxt", "The xt offset of the body reference point (meters)")
    text += _line(0.0, "PtfmRefzt", "The zt offset of the body reference point (meters)")
    text += _line(round(volume, 3), "PtfmVol0", "Displaced volume of the WAMIT body (m^3)")
    text += "---------------------- PLATFORM ADDITIONAL STIFFNESS AND DAMPING  --------------\n"
    if new:
        text += f"{0.0:>14}   AddF0    - Additional preload (N, N-m)\n" + f"{0.0:>14}\n" * 5
    else:
        text += "".join(f"{0.0:>14}" for _ in range(6)) + "   AddF0    - Additional preload\n"
    text += _matrix(fig.add_c_lin, "AddCLin", "Additional linear stiffness")
    text += _matrix(fig.add_b_lin, "AddBLin", "Additional linear damping")
    text += _matrix(_diag6(), "AddBQuad", "Additional quadratic drag")
    text += "---------------------- AXIAL COEFFICIENTS --------------------------------------\n"
    text += _line(len(fig.axial_coefs), "NAxCoef", "Number of axial coefficients (-)")
    text += "AxCoefID  AxCd     AxCa     AxCp\n   (-)    (-)      (-)      (-)\n"
    for aid, cd, ca in fig.axial_coefs:
        text += f"   {aid:3d}   {cd:6.2f}   {ca:6.2f}     1.00\n"
    text += "---------------------- MEMBER JOINTS -------------------------------------------\n"
    text += _line(len(fig.joints), "NJoints", "Number of joints (-)")
    text += "JointID   Jointxi     Jointyi     Jointzi  JointAxID   JointOvrlp\n"
    text += "   (-)     (m)         (m)         (m)        (-)       (switch)\n"
    for jid, x, y, z, ax in fig.joints:
        text += f"  {jid:4d}  {x:11.5f} {y:11.5f} {z:11.5f}   {ax:4d}          0\n"
    if new:
        text += "---------------------- CYLINDRICAL MEMBER CROSS-SECTION PROPERTIES ------------\n"
        text += _line(len(fig.props), "NPropSetsCyl", "Number of cylindrical property sets")
    else:
        text += "---------------------- MEMBER CROSS-SECTION PROPERTIES -------------------------\n"
        text += _line(len(fig.props), "NPropSets", "Number of member property sets (-)")
    text += "PropSetID    PropD         PropThck\n   (-)        (m)            (m)\n"
    for pid, d, t in fig.props:
        text += f"  {pid:4d}     {d:10.5f}     {t:10.5f}\n"
    if new:
        text += "---------------------- RECTANGULAR MEMBER CROSS-SECTION PROPERTIES ------------\n"
        text += _line(0, "NPropSetsRec", "Number of rectangular property sets")
        text += (
            "PropSetID    PropA     PropB      PropThck\n   (-)        (m)       (m)         (m)\n"
        )
    text += "---------------------- MEMBER-BASED HYDRODYNAMIC COEFFICIENTS (model 3) --------\n"
    text += _line(len(fig.members), "NCoefMembers", "Number of member-based coefficients (-)")
    text += "MemberID    MemberCd1     MemberCd2    MemberCa1     MemberCa2\n"
    text += "   (-)         (-)           (-)          (-)           (-)\n"
    for mid, _, _, _, _, cd, ca, _ in fig.members:
        text += f"  {mid:4d}      {cd:6.2f}        {cd:6.2f}       {ca:6.2f}        {ca:6.2f}\n"
    text += "-------------------- MEMBERS -------------------------------------------------\n"
    text += _line(len(fig.members), "NMembers", "Number of members (-)")
    if new:
        text += (
            "MemberID  MJointID1  MJointID2  MPropSetID1  MPropSetID2  MSecGeom  MSpinOrient  "
            "MDivSize   MCoefMod  MHstLMod  PropPot\n"
            "  (-)        (-)        (-)         (-)          (-)       (switch)    (deg)       "
            "(m)      (switch)  (switch)  (flag)\n"
        )
    else:
        text += (
            "MemberID  MJointID1  MJointID2  MPropSetID1  MPropSetID2  MDivSize   MCoefMod  "
            "PropPot\n  (-)        (-)        (-)         (-)          (-)        (m)      "
            "(switch)   (flag)\n"
        )
    for mid, j1, j2, p1, p2, _, _, pot in fig.members:
        flag = "TRUE" if pot else "FALSE"
        mid_cols = "     1          0        " if new else "   "
        hst = "     1    " if new else "   "
        text += (
            f"  {mid:4d}     {j1:4d}       {j2:4d}       {p1:4d}         {p2:4d}  {mid_cols}"
            f"1.0000      3  {hst}   {flag}\n"
        )
    text += "---------------------- FILLED MEMBERS ------------------------------------------\n"
    text += _line(len(fig.fill_groups), "NFillGroups", "Number of filled member groups (-)")
    text += "FillNumM FillMList             FillFSLoc     FillDens\n"
    text += "(-)      (-)                   (m)           (kg/m^3)\n"
    for ids, level, dens in fig.fill_groups:
        text += f"    {len(ids)}   {'   '.join(map(str, ids))}    {level:.2f}    {dens:g}\n"
    text += "---------------------- MARINE GROWTH -------------------------------------------\n"
    text += _line(0, "NMGDepths", "Number of marine-growth depths specified (-)")
    text += "MGDpth     MGThck       MGDens\n(m)        (m)         (kg/m^3)\n"
    text += "---------------------- OUTPUT --------------------------------------------------\n"
    text += _line("True", "HDSum", "Output a summary file [flag]")
    text += "END of output channels and end of file.\n"
    path.write_text(text, encoding="utf-8")


def _write_moordyn(path: Path, fig: DeckFigures, generation: str) -> None:
    text = "--------------------- MoorDyn Input File ------------------------------------\n"
    text += f"Mooring of {fig.title}; written by plant.reference_decks ({generation} layout)\n"
    text += "FALSE    Echo      - echo the input file data (flag)\n"
    text += "----------------------- LINE TYPES ------------------------------------------\n"
    line_type = (
        f"main     {fig.line_diameter_m}    {fig.line_mass_kg_m}    {fig.line_ea_n:.6E}    "
        "-0.8      0.8   0.25  2.0   0.4\n"
    )
    n = len(fig.anchors)
    if generation == "fast8":
        text += "1        NTypes    - number of LineTypes\n"
        text += "Name     Diam      MassDen      EA    BA/-zeta   Can   Cat   Cdn   Cdt\n"
        text += "(-)       (m)      (kg/m)       (N)   (N-s/-)    (-)   (-)   (-)   (-)\n"
        text += line_type
        text += "---------------------- CONNECTION PROPERTIES --------------------------------\n"
        text += f"{2 * n}        NConnects - number of connections\n"
        text += "Node  Type  X  Y  Z  M  V  FX  FY  FZ  CdA  CA\n"
        text += "(-)  (-)  (m)  (m)  (m)  (kg)  (m^3)  (kN)  (kN)  (kN)  (m^2)  (-)\n"
        for k, (x, y, z) in enumerate(fig.anchors + fig.fairleads, start=1):
            kind = "Fixed" if k <= n else "Vessel"
            text += (
                f"{k}       {kind:<8} {x:10.4f} {y:10.4f} {z:9.2f}   0   0   0   0   0   0   0\n"
            )
        text += "---------------------- LINE PROPERTIES --------------------------------------\n"
        text += f"{n}        NLines    - number of line objects\n"
        text += "Line    LineType  UnstrLen  NumSegs  NodeAnch  NodeFair  Flags/Outputs\n"
        text += "(-)      (-)       (m)        (-)      (-)       (-)       (-)\n"
        for k in range(1, n + 1):
            text += f"{k}   main   {fig.line_length_m}   20   {k}   {k + n}   -\n"
    else:
        text += "Name     Diam      MassDen      EA    BA/-zeta   Can   Cat   Cdn   Cdt\n"
        text += "(-)       (m)      (kg/m)       (N)   (N-s/-)    (-)   (-)   (-)   (-)\n"
        text += line_type
        text += "---------------------- POINTS --------------------------------\n"
        text += "ID     Attachment  X        Y         Z      M      V    CdA   CA\n"
        text += "(-)     (-)      (m)      (m)      (m)     (kg)  (m^3) (m^2)  (-)\n"
        for k, (x, y, z) in enumerate(fig.anchors + fig.fairleads, start=1):
            kind = "Fixed" if k <= n else "Vessel"
            text += f"{k}      {kind:<8} {x:10.4f} {y:10.4f} {z:9.2f}   0   0   0   0\n"
        text += "---------------------- LINES --------------------------------------\n"
        text += "ID      LineType   AttachA   AttachB  UnstrLen  NumSegs   LineOutputs\n"
        text += "(-)       (-)        (-)       (-)       (m)       (-)      (-)\n"
        for k in range(1, n + 1):
            text += f"{k}   main   {k}   {k + n}   {fig.line_length_m}   20   -\n"
    text += "---------------------- SOLVER OPTIONS ---------------------------------------\n"
    text += "0.001    dtM       - time step to use in mooring integration (s)\n"
    text += "3.0e6    kbot      - bottom stiffness (Pa/m)\n"
    text += "------------------------ OUTPUTS --------------------------------------------\n"
    text += "FairTen1\nEND\n------------------------- need this line ---------------------\n"
    path.write_text(text, encoding="utf-8")


def _write_fst(path: Path, fig: DeckFigures, generation: str) -> None:
    text = "------- OpenFAST INPUT FILE -------------------------------------------\n"
    text += f"{fig.title} ({generation} layout)\n"
    text += "---------------------- SIMULATION CONTROL --------------------------------------\n"
    text += _line("False", "Echo", "Echo input data to <RootName>.ech (flag)")
    text += _line("FATAL", "AbortLevel", "Error level when simulation should abort (string)")
    text += _line(600, "TMax", "Total run time (s)")
    text += _line(0.0125, "DT", "Recommended module time step (s)")
    if generation != "fast8":
        text += "---------------------- ENVIRONMENTAL CONDITIONS --------------------------------\n"
        text += _line(9.80665, "Gravity", "Gravitational acceleration (m/s^2)")
        text += _line(1.225, "AirDens", "Air density (kg/m^3)")
        text += _line(1025.0, "WtrDens", "Water density (kg/m^3)")
        text += _line(fig.depth_m, "WtrDpth", "Water depth (m)")
        text += _line(0.0, "MSL2SWL", "Offset between still-water level and mean sea level (m)")
    text += "---------------------- FEATURE SWITCHES AND FLAGS ------------------------------\n"
    for value, key in (
        (1, "CompElast"),
        (0, "CompInflow"),
        (0, "CompAero"),
        (0, "CompServo"),
    ):
        text += _line(value, key, "switch")
    if generation != "fast8":
        text += _line(1, "CompSeaSt", "Compute sea state information (switch)")
    for value, key in ((1, "CompHydro"), (0, "CompSub"), (3, "CompMooring"), (0, "CompIce")):
        text += _line(value, key, "switch")
    text += "---------------------- INPUT FILES ---------------------------------------------\n"
    text += _line("elastodyn.dat", "EDFile", "Name of file containing ElastoDyn input parameters")
    text += _line("unused", "InflowFile", "Name of file containing inflow wind input parameters")
    text += _line("unused", "AeroFile", "Name of file containing aerodynamic input parameters")
    text += _line("unused", "ServoFile", "Name of file containing control input parameters")
    if generation != "fast8":
        text += _line("seastate.dat", "SeaStFile", "Name of file containing sea state inputs")
    text += _line("hydrodyn.dat", "HydroFile", "Name of file containing hydrodynamic inputs")
    text += _line("unused", "SubFile", "Name of file containing sub-structural inputs")
    text += _line("moordyn.dat", "MooringFile", "Name of file containing mooring inputs")
    text += _line("unused", "IceFile", "Name of file containing ice input parameters")
    path.write_text(text, encoding="utf-8")


def _write_seastate(path: Path, fig: DeckFigures) -> None:
    text = "------- SeaState Input File ----------------------------------------------------\n"
    text += f"Still water for {fig.title}; written by plant.reference_decks\n"
    text += "---------------------- ENVIRONMENTAL CONDITIONS --------------------------------\n"
    text += _line("default", "WtrDens", "Water density (kg/m^3)")
    text += _line("default", "WtrDpth", "Water depth (meters)")
    text += _line("default", "MSL2SWL", "Offset between still-water level and mean sea level (m)")
    text += "---------------------- WAVES ---------------------------------------------------\n"
    text += _line(0, "WaveMod", "Incident wave kinematics model {0: none=still water}")
    path.write_text(text, encoding="utf-8")


def write_deck(
    out_dir: Path, platform: str, generation: str, hydro: HydroData | None = None
) -> Path:
    """Write one deck (``deck.fst`` and the files it names) into ``out_dir``; return the ``.fst``.

    Parameters
    ----------
    out_dir : Path
        Created if missing.
    platform : str
        ``"oc3"`` or ``"oc4"``.
    generation : str
        ``"fast8"`` or ``"openfast4"`` (see the module docstring).
    hydro : HydroData, optional
        The WAMIT data to write; default for OC3 the shipped spar data, for OC4 required
        (:func:`oc4_hydro`).
    """
    if platform not in PLATFORMS:
        raise ValueError(f"platform: expected one of {', '.join(PLATFORMS)}, got {platform!r}")
    if generation not in GENERATIONS:
        raise ValueError(
            f"generation: expected one of {', '.join(GENERATIONS)}, got {generation!r}"
        )
    fig = PLATFORMS[platform]
    if hydro is None:
        if platform != "oc3":
            raise ValueError(
                "the OC4 deck needs its hydrodynamic data (plant.reference_decks.oc4_hydro)"
            )
        hydro = load_hydro_preset("nrel5mw_oc3_hywind")
    out_dir = Path(out_dir)
    (out_dir / "HydroData").mkdir(parents=True, exist_ok=True)
    write_wamit(hydro, out_dir / "HydroData" / "platform")
    _write_tower(out_dir / "tower.dat")
    _write_blade(out_dir / "blade.dat", generation)
    _write_elastodyn(out_dir / "elastodyn.dat", fig, generation)
    _write_hydrodyn(out_dir / "hydrodyn.dat", fig, generation, _hydro_volume(fig))
    _write_moordyn(out_dir / "moordyn.dat", fig, generation)
    if generation != "fast8":
        _write_seastate(out_dir / "seastate.dat", fig)
    fst = out_dir / "deck.fst"
    _write_fst(fst, fig, generation)
    return fst


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: write the decks (all platforms and generations by default)."""
    p = argparse.ArgumentParser(
        prog="python -m plant.reference_decks",
        description="Write OpenFAST decks of the OC3-Hywind spar and the OC4-DeepCwind semi "
        "from published figures (OC4 needs the [hydro] extra).",
    )
    p.add_argument("--out", type=Path, required=True, help="folder; one subfolder per deck")
    p.add_argument("--platform", choices=sorted(PLATFORMS), action="append")
    p.add_argument("--generation", choices=GENERATIONS, action="append")
    args = p.parse_args(argv)
    oc4: HydroData | None = None
    for platform in args.platform or sorted(PLATFORMS):
        hydro = None
        if platform == "oc4":
            if oc4 is None:
                try:
                    oc4, desc = oc4_hydro()
                except ImportError as exc:
                    print(f"error: {exc}", file=sys.stderr)
                    return 2
                print(f"OC4 hydrodynamics: {desc}")
            hydro = oc4
        for generation in args.generation or GENERATIONS:
            fst = write_deck(args.out / f"{platform}_{generation}", platform, generation, hydro)
            print(fst)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
