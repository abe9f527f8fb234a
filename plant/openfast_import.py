"""Import a floating turbine from an OpenFAST deck into a preset (offline, explicit file reading).

:func:`import_openfast` reads the ``.fst`` file and the ElastoDyn (+ tower, blade), HydroDyn,
SeaState and MoorDyn files it names, and returns an :class:`ImportedDeck`: the physical figures
as a :class:`plant.platform.FloatingPreset`, the WAMIT data (read with
:func:`plant.hydro.wamit.import_wamit`) and the quasi-static mooring tables. :func:`write_preset`
writes the preset TOML and its data files, which :func:`plant.platform.load_floating` reads back.

Mooring: the MoorDyn lines (anchors, fairleads, line type) are solved as quasi-static elastic
catenaries with MoorPy (optional dependency ``moorpy``) on a grid of surge offsets, plus central
differences in heave and pitch at zero offset; the run time never needs MoorPy.

Tower: the first fore-aft modal mass and stiffness follow from the ElastoDyn mode-shape
polynomial and the distributed mass and stiffness (:func:`plant.platform.tower_modal`); the
deck's adjustment factors (``AdjTwMa``, ``AdjFASt``, ``FAStTunr(1)``) are applied to the tables.

What is hand-written here and why: OpenFAST input files are "value  Key  - description" lines
plus tables; no maintained lightweight reader exists outside the heavy ``openfast_toolbox`` /
``weis`` stacks, so the few keys needed are read by a small tolerant parser that names the file
and key in every error.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import msgspec
import numpy as np

from plant.hydro.radiation import RadiationModel, fit_reduced_radiation
from plant.hydro.wamit import HydroData, import_wamit
from plant.platform import FloatingPreset, MooringFile, tower_modal

__all__ = [
    "ImportedDeck",
    "MooringLine",
    "compute_mooring",
    "import_openfast",
    "read_keyed_file",
    "write_preset",
    "write_radiation",
]

_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eEdD][-+]?\d+)?$")


def read_keyed_file(path: Path) -> tuple[dict[str, str], list[str]]:
    """Values of an OpenFAST input file by key (first token = value, second = key) and its lines.

    Keys are case-insensitive (stored upper case); ``Key(1)`` is stored as ``KEY(1)``. Quotes
    are stripped from values.
    """
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as exc:
        raise OSError(f"{path}: cannot read ({exc})") from exc
    values: dict[str, str] = {}
    for line in lines:
        tok = line.split()
        if len(tok) >= 2 and not tok[0].startswith(("--", "!", "#")):
            key = tok[1].upper()
            if key not in values:
                values[key] = tok[0].strip('"').strip("'")
    return values, lines


def _num(values: dict[str, str], key: str, source: Path, default: float | None = None) -> float:
    raw = values.get(key.upper())
    if raw is None or raw.upper() == "DEFAULT":
        if default is not None:
            return default
        raise ValueError(f"{source}: key {key!r} not found (or DEFAULT without a fallback)")
    try:
        return float(raw.replace("d", "e").replace("D", "E"))
    except ValueError:
        raise ValueError(f"{source}: key {key!r} = {raw!r} is not a number") from None


def _text(values: dict[str, str], key: str, source: Path) -> str:
    raw = values.get(key.upper())
    if raw is None:
        raise ValueError(f"{source}: key {key!r} not found")
    return raw


def _table_after(lines: list[str], marker: str, ncols: int, source: Path) -> list[list[float]]:
    """Numeric rows (at least ``ncols`` numbers) following the line containing ``marker``."""
    for i, line in enumerate(lines):
        if marker.upper() in line.upper():
            rows: list[list[float]] = []
            for nxt in lines[i + 1 :]:
                tok = nxt.split()
                if len(tok) >= ncols and all(_NUMBER.match(t) for t in tok[:ncols]):
                    rows.append([float(t) for t in tok[:ncols]])
                elif rows:
                    break
            if rows:
                return rows
    raise ValueError(f"{source}: no numeric table after a line containing {marker!r}")


def _matrix_rows(lines: list[str], key: str, source: Path) -> list[list[float]]:
    """The 6x6 matrix of ``key`` (e.g. ``AddBQuad``): the row holding the key and the next five."""
    for i, line in enumerate(lines):
        tok = line.split()
        if len(tok) > 6 and tok[6].upper() == key.upper():
            rows = [[float(v) for v in lines[i + r].split()[:6]] for r in range(6)]
            return rows
    raise ValueError(f"{source}: 6x6 matrix {key!r} not found")


def _vector6(lines: list[str], key: str, source: Path) -> list[float]:
    for i, line in enumerate(lines):
        tok = line.split()
        if len(tok) >= 2 and tok[1].upper() == key.upper():
            first = [float(tok[0])]
            rest = [float(lines[i + r].split()[0]) for r in range(1, 6)]
            return first + rest
    raise ValueError(f"{source}: vector {key!r} not found")


@dataclass(frozen=True)
class MooringLine:
    """One MoorDyn line between an anchor and a fairlead (SI, positions in the platform frame).

    Attributes
    ----------
    anchor_m, fairlead_m : tuple of 3 float
        Anchor (earth-fixed) and fairlead (body-fixed, relative to the reference point) (m).
    length_m : float
        Unstretched length (m).
    diameter_m : float
        Volume-equivalent diameter (m).
    mass_density_kg_m : float
        Mass per length in air (kg/m).
    axial_stiffness_n : float
        EA (N).
    """

    anchor_m: tuple[float, float, float]
    fairlead_m: tuple[float, float, float]
    length_m: float
    diameter_m: float
    mass_density_kg_m: float
    axial_stiffness_n: float


def read_moordyn(path: Path) -> list[MooringLine]:
    """Anchor-to-fairlead lines of a MoorDyn (v1 or v2) input file; free points are rejected."""
    lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    section = ""
    types: dict[str, tuple[float, float, float]] = {}
    points: dict[int, tuple[str, tuple[float, float, float]]] = {}
    raw_lines: list[tuple[str, int, int, float]] = []
    for line in lines:
        up = line.upper()
        if line.lstrip().startswith("--"):
            if "LINE TYPES" in up or "LINE DICTIONARY" in up:
                section = "types"
            elif "POINTS" in up or "CONNECTION" in up or "NODE PROPERTIES" in up:
                section = "points"
            elif "LINES" in up or "LINE PROPERTIES" in up:
                section = "lines"
            else:
                section = ""
            continue
        tok = line.split()
        if not tok or not _NUMBER.match(tok[-1] if section == "types" else tok[0]):
            if section == "types" and len(tok) >= 5 and _NUMBER.match(tok[1]):
                pass
            else:
                continue
        if section == "types" and len(tok) >= 4 and _NUMBER.match(tok[1]):
            types[tok[0]] = (float(tok[1]), float(tok[2]), float(tok[3]))
        elif section == "points" and len(tok) >= 5 and _NUMBER.match(tok[0]):
            points[int(tok[0])] = (tok[1].lower(), (float(tok[2]), float(tok[3]), float(tok[4])))
        elif section == "lines" and len(tok) >= 5 and _NUMBER.match(tok[0]):
            raw_lines.append((tok[1], int(tok[2]), int(tok[3]), float(tok[4])))
    if not raw_lines:
        raise ValueError(f"{path}: no mooring lines found")
    out: list[MooringLine] = []
    for type_name, a, b, length in raw_lines:
        if type_name not in types:
            raise ValueError(f"{path}: line type {type_name!r} not defined")
        ends = {points[a][0]: points[a][1], points[b][0]: points[b][1]}
        anchor = ends.get("fixed") or ends.get("fix")
        fair = ends.get("vessel") or ends.get("coupled")
        if anchor is None or fair is None:
            raise ValueError(
                f"{path}: line between points {a} and {b} is not anchor-to-fairlead "
                "(free connection points are not supported)"
            )
        d, m, ea = types[type_name]
        out.append(MooringLine(anchor, fair, length, d, m, ea))
    return out


def compute_mooring(
    lines: list[MooringLine],
    depth_m: float,
    rho_kg_m3: float,
    g_m_s2: float,
    surge_grid_m: np.ndarray | None = None,
    source: str = "",
) -> MooringFile:
    """Quasi-static mooring tables with MoorPy (elastic catenaries with seabed contact).

    F_x(x), F_z(x), M_φ(x) on ``surge_grid_m`` (default −40..60 m, 1 m) at zero heave and pitch;
    K_zφ by central differences (±0.1 m, ±0.002 rad) at zero offset and at every offset of the
    grid (K_zφ(x)); the 6x6 coupled stiffness at zero offset (MoorPy ``getCoupledStiffnessA``)
    for reference.
    """
    import moorpy  # noqa: PLC0415  optional, import time only

    grid = np.arange(-40.0, 60.0 + 0.5, 1.0) if surge_grid_m is None else surge_grid_m
    ms = moorpy.System(depth=depth_m, rho=rho_kg_m3, g=g_m_s2)
    body = ms.addBody(-1, np.zeros(6))
    for k, ln in enumerate(lines):
        name = f"type{k}"
        wet = (ln.mass_density_kg_m - rho_kg_m3 * math.pi / 4.0 * ln.diameter_m**2) * g_m_s2
        ms.lineTypes[name] = {
            "name": name,
            "d_vol": ln.diameter_m,
            "m": ln.mass_density_kg_m,
            "w": wet,
            "EA": ln.axial_stiffness_n,
            "material": name,
        }
        anchor = ms.addPoint(1, list(ln.anchor_m))
        fair = ms.addPoint(1, list(ln.fairlead_m), body=1)
        ms.addLine(ln.length_m, name, nSegs=40, pointA=anchor.number, pointB=fair.number)
    ms.initialize()

    def force(r6: list[float]) -> np.ndarray:
        body.setPosition(np.array(r6, dtype=float))
        for line in ms.lineList:
            line.staticSolve()
        return np.asarray(body.getForces(lines_only=True), dtype=float)

    fx, fz, my = [], [], []
    for x in grid:
        f6 = force([float(x), 0, 0, 0, 0, 0])
        fx.append(float(f6[0]))
        fz.append(float(f6[2]))
        my.append(float(f6[4]))
    dz, dp = 0.1, 0.002

    def k_heave_pitch(x: float) -> np.ndarray:
        fzp, fzm = force([x, 0, dz, 0, 0, 0]), force([x, 0, -dz, 0, 0, 0])
        fpp, fpm = force([x, 0, 0, 0, dp, 0]), force([x, 0, 0, 0, -dp, 0])
        k = np.array(
            [
                [-(fzp[2] - fzm[2]) / (2 * dz), -(fpp[2] - fpm[2]) / (2 * dp)],
                [-(fzp[4] - fzm[4]) / (2 * dz), -(fpp[4] - fpm[4]) / (2 * dp)],
            ]
        )
        return 0.5 * (k + k.T)

    k_zp = k_heave_pitch(0.0)
    k_by_surge = [k_heave_pitch(float(x)).tolist() for x in grid]
    force([0, 0, 0, 0, 0, 0])
    k6 = np.asarray(ms.getCoupledStiffnessA(lines_only=True), dtype=float)
    return MooringFile(
        source=source or "MoorPy quasi-static solution",
        surge_m=[float(v) for v in grid],
        force_surge_n=fx,
        force_heave_n=fz,
        moment_pitch_nm=my,
        stiffness_heave_pitch=k_zp.tolist(),
        stiffness_6x6_at_zero=k6.tolist(),
        stiffness_heave_pitch_by_surge=k_by_surge,
        lines=[
            {
                "anchor_x_m": ln.anchor_m[0],
                "anchor_y_m": ln.anchor_m[1],
                "anchor_z_m": ln.anchor_m[2],
                "fairlead_x_m": ln.fairlead_m[0],
                "fairlead_y_m": ln.fairlead_m[1],
                "fairlead_z_m": ln.fairlead_m[2],
                "length_m": ln.length_m,
                "diameter_m": ln.diameter_m,
                "mass_density_kg_m": ln.mass_density_kg_m,
                "axial_stiffness_n": ln.axial_stiffness_n,
            }
            for ln in lines
        ],
    )


@dataclass(frozen=True)
class ImportedDeck:
    """What :func:`import_openfast` read: the preset figures, WAMIT data and mooring tables.

    ``notes`` lists derived figures and checks (e.g. the tower fixed-base frequency).
    """

    preset: FloatingPreset
    hydro: HydroData
    mooring: MooringFile
    notes: tuple[str, ...]


def _blade_properties(
    path: Path, tip_radius_m: float, hub_radius_m: float
) -> tuple[float, float, float]:
    """(mass kg, CM radius from the apex m, ∫ r² dm about the apex kg m²) of one blade."""
    values, lines = read_keyed_file(path)
    rows = np.array(_table_after(lines, "(kg/m)", 3, path))
    adj = _num(values, "AdjBlMs", path, 1.0)
    length = tip_radius_m - hub_radius_m
    r = hub_radius_m + rows[:, 0] * length
    mu = rows[:, 2] * adj
    mass = float(np.trapezoid(mu, r))
    return mass, float(np.trapezoid(mu * r, r)) / mass, float(np.trapezoid(mu * r * r, r))


def import_openfast(
    fst_path: Path, turbine: str = "iea15mw", name: str | None = None, mooring: bool = True
) -> ImportedDeck:
    """Read a floating OpenFAST deck into preset figures (see the module docstring).

    Parameters
    ----------
    fst_path : Path
        The ``.fst`` file; the module files are resolved relative to it, as OpenFAST does.
    turbine : str, optional
        Turbine preset (name or path) the floating preset refers to for the rotor, default
        ``"iea15mw"``.
    name : str, optional
        Preset name; default: the second line (title) of the ``.fst``.
    mooring : bool, optional
        Solve the mooring tables with MoorPy (default True; False leaves them empty).

    Returns
    -------
    ImportedDeck

    Raises
    ------
    ValueError
        On a missing key or an unsupported deck (message names the file and key).
    """
    fst_path = Path(fst_path)
    fst, fst_lines = read_keyed_file(fst_path)
    root = fst_path.parent
    g = _num(fst, "Gravity", fst_path)
    rho = _num(fst, "WtrDens", fst_path)
    depth = _num(fst, "WtrDpth", fst_path)
    ed_path = root / _text(fst, "EDFile", fst_path)
    hd_path = root / _text(fst, "HydroFile", fst_path)
    md_path = root / _text(fst, "MooringFile", fst_path)
    if int(_num(fst, "CompMooring", fst_path)) != 3:
        raise ValueError(f"{fst_path}: CompMooring must be 3 (MoorDyn) for the mooring import")

    ed, _ = read_keyed_file(ed_path)
    twr_path = ed_path.parent / _text(ed, "TwrFile", ed_path)
    bld_path = ed_path.parent / _text(ed, "BldFile1", ed_path)
    for key in ("PtfmRefxt", "PtfmRefzt"):
        if abs(_num(ed, key, ed_path, 0.0)) > 0.0:
            raise ValueError(
                f"{ed_path}: {key} must be 0 (reference point at the still-water line)"
            )
    tw, tw_lines = read_keyed_file(twr_path)
    rows = np.array(_table_after(tw_lines, "(kg/m)", 3, twr_path))
    adj_mass = _num(tw, "AdjTwMa", twr_path, 1.0)
    adj_stiff = _num(tw, "AdjFASt", twr_path, 1.0) * _num(tw, "FAStTunr(1)", twr_path, 1.0)
    shape = [_num(tw, f"TwFAM1Sh({k})", twr_path) for k in range(2, 7)]
    if abs(sum(shape) - 1.0) > 1e-3:
        raise ValueError(f"{twr_path}: TwFAM1Sh coefficients sum to {sum(shape)}, expected 1")

    tip = _num(ed, "TipRad", ed_path)
    hub_r = _num(ed, "HubRad", ed_path)
    blade_mass, blade_r_cm, blade_i = _blade_properties(bld_path, tip, hub_r)
    precone = math.radians(_num(ed, "PreCone(1)", ed_path))
    tilt = math.radians(_num(ed, "ShftTilt", ed_path))
    overhang = _num(ed, "OverHang", ed_path)
    twr2shft = _num(ed, "Twr2Shft", ed_path)
    hub_cm = _num(ed, "HubCM", ed_path, 0.0)
    if abs(hub_cm) > 0.0:
        raise ValueError(f"{ed_path}: HubCM != 0 is not supported")

    # Tower aerodynamic drag (AeroDyn TwrAero) and the wind's shear exponent (InflowWind).
    twr_h: list[float] = []
    twr_d: list[float] = []
    twr_cd: list[float] = []
    shear = 0.0
    if int(_num(fst, "CompAero", fst_path, 0.0)) == 2:
        ad_path = root / _text(fst, "AeroFile", fst_path)
        ad, ad_lines = read_keyed_file(ad_path)
        if ad.get("TWRAERO", "false").strip().lower() == "true":
            trows = _table_after(ad_lines, "TwrElev", 3, ad_path)
            twr_h = [r[0] for r in trows]
            twr_d = [r[1] for r in trows]
            twr_cd = [r[2] for r in trows]
        if int(_num(fst, "CompInflow", fst_path, 0.0)) == 1:
            ifw_path = root / _text(fst, "InflowFile", fst_path)
            ifw, _ = read_keyed_file(ifw_path)
            shear = _num(ifw, "PLexp", ifw_path, 0.0)

    hd, hd_lines = read_keyed_file(hd_path)
    pot_root = hd_path.parent / _text(hd, "PotFile", hd_path)
    ulen = _num(hd, "WAMITULEN", hd_path, 1.0)
    hydro = import_wamit(pot_root, rho, g, ulen)
    volume = _num(hd, "PtfmVol0", hd_path)
    add_f0 = _vector6(hd_lines, "AddF0", hd_path)
    add_c = _matrix_rows(hd_lines, "AddCLin", hd_path)
    add_b = _matrix_rows(hd_lines, "AddBLin", hd_path)
    add_bq = _matrix_rows(hd_lines, "AddBQuad", hd_path)
    n_members = int(_num(hd, "NMembers", hd_path, 0.0))

    preset = FloatingPreset(
        name=name or (fst_lines[1].strip() if len(fst_lines) > 1 else fst_path.stem),
        turbine=turbine,
        hydro_file="hydro.npz",
        mooring_file="mooring.json",
        gravity_m_s2=g,
        water_density_kg_m3=rho,
        water_depth_m=depth,
        displaced_volume_m3=volume,
        platform_mass_kg=_num(ed, "PtfmMass", ed_path),
        platform_pitch_inertia_kg_m2=_num(ed, "PtfmPIner", ed_path),
        platform_cm_x_m=_num(ed, "PtfmCMxt", ed_path, 0.0),
        platform_cm_z_m=_num(ed, "PtfmCMzt", ed_path),
        tower_base_height_m=_num(ed, "TowerBsHt", ed_path),
        tower_top_height_m=_num(ed, "TowerHt", ed_path),
        tower_height_fraction=[float(v) for v in rows[:, 0]],
        tower_mass_density_kg_m=[float(v) * adj_mass for v in rows[:, 1]],
        tower_fore_aft_stiffness_n_m2=[float(v) * adj_stiff for v in rows[:, 2]],
        tower_mode_shape_coefficients=shape,
        tower_damping_ratio=_num(tw, "TwrFADmp(1)", twr_path) / 100.0,
        yaw_bearing_mass_kg=_num(ed, "YawBrMass", ed_path, 0.0),
        nacelle_mass_kg=_num(ed, "NacMass", ed_path),
        nacelle_cm_x_m=_num(ed, "NacCMxn", ed_path),
        nacelle_cm_z_m=_num(ed, "NacCMzn", ed_path),
        hub_mass_kg=_num(ed, "HubMass", ed_path),
        rotor_apex_x_m=overhang * math.cos(tilt),
        rotor_apex_z_m=twr2shft + overhang * math.sin(tilt),
        blade_count=int(_num(ed, "NumBl", ed_path)),
        blade_mass_kg=blade_mass,
        blade_cm_axial_m=blade_r_cm * math.sin(precone),
        blade_second_moment_kg_m2=blade_i,
        shaft_tilt_rad=-tilt,  # ElastoDyn ShftTilt < 0: upwind end up
        tower_drag_height_m=twr_h,
        tower_drag_diameter_m=twr_d,
        tower_drag_coefficient=twr_cd,
        wind_shear_exponent=shear,
        additional_force_n=add_f0,
        additional_linear_stiffness=add_c,
        additional_linear_damping=add_b,
        additional_quadratic_damping=add_bq,
        # Radiation fit (write_radiation): orders up to 12 over 0..2 rad/s, below the
        # high-frequency ripple of semi-submersible data that no low order follows.
        radiation_max_order=12,
        radiation_omega_max_rad_s=2.0,
    )
    tm = tower_modal(preset)
    notes = [
        f"tower mass {tm.tower_mass_kg:.6g} kg, RNA mass {tm.rna_mass_kg:.6g} kg",
        f"tower 1st fore-aft modal mass {tm.modal_mass_kg:.6g} kg (incl. RNA), stiffness "
        f"{tm.modal_stiffness_elastic_n_m:.6g} N/m elastic {tm.modal_stiffness_gravity_n_m:+.6g} "
        f"N/m gravity, fixed-base frequency {tm.fixed_base_frequency_hz:.4f} Hz",
        f"hub height {preset.tower_top_height_m + preset.rotor_apex_z_m:.4f} m above SWL",
        f"blade mass {blade_mass:.6g} kg, CM {blade_r_cm:.4g} m from the apex",
    ]
    if n_members:
        notes.append(f"{hd_path}: {n_members} Morison members ignored (only AddBQuad drag used)")
    if mooring:
        moor = compute_mooring(
            read_moordyn(md_path), depth, rho, g, source=f"MoorPy from {md_path.name}"
        )
        i0 = moor.surge_m.index(0.0) if 0.0 in moor.surge_m else 0
        k11 = -(moor.force_surge_n[i0 + 1] - moor.force_surge_n[i0 - 1]) / 2.0
        notes.append(f"mooring surge stiffness at zero offset {k11:.4g} N/m")
    else:
        moor = MooringFile(
            source="none",
            surge_m=[-1.0, 1.0],
            force_surge_n=[0.0, 0.0],
            force_heave_n=[0.0, 0.0],
            moment_pitch_nm=[0.0, 0.0],
            stiffness_heave_pitch=[[0.0, 0.0], [0.0, 0.0]],
            stiffness_6x6_at_zero=[[0.0] * 6 for _ in range(6)],
        )
    return ImportedDeck(preset=preset, hydro=hydro, mooring=moor, notes=tuple(notes))


def _toml_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value) if isinstance(value, int) else repr(float(value))
    if isinstance(value, str):
        return msgspec.json.encode(value).decode("utf-8")  # a JSON string is a TOML basic string
    if isinstance(value, list):
        inner = ", ".join(_toml_value(v) for v in value)
        return f"[{inner}]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def _toml_lines(data: dict[str, object]) -> str:
    """Flat TOML (keys = scalars or arrays) of a preset; msgspec only reads TOML."""
    return "".join(f"{key} = {_toml_value(value)}\n" for key, value in data.items())


def write_radiation(preset: FloatingPreset, hydro: HydroData, path: Path) -> RadiationModel:
    """Fit, stack and reduce the radiation memory of surge, heave and pitch once; write its npz.

    Uses :func:`plant.hydro.radiation.fit_reduced_radiation` with the preset's
    ``radiation_max_order``, ``radiation_tolerance`` and ``radiation_omega_max_rad_s`` (0: the
    whole band of the data; :meth:`plant.platform.FloatingPreset.radiation_fit_options`);
    heave and pitch decide the reduced order.

    Parameters
    ----------
    preset : FloatingPreset
    hydro : HydroData
    path : Path
        The ``.npz`` to write (:meth:`plant.hydro.radiation.RadiationModel.save_npz`).

    Returns
    -------
    RadiationModel
    """
    model = fit_reduced_radiation(
        hydro.radiation,
        **preset.radiation_fit_options(),
        checked_dofs=(2, 4),
        source=f"Perez-Fossen fits of the WAMIT data of {preset.name!r}, stacked, "
        "reduced by balanced truncation, diagonal kernels made passive with Re K >= 0.5 B at "
        "the data (plant.openfast_import.write_radiation)",
    )
    model.save_npz(path)
    return model


def write_preset(deck: ImportedDeck, out_dir: Path, stem: str | None = None) -> Path:
    """Write ``<stem>.toml``, ``<stem>_hydro.npz``, ``<stem>_mooring.json`` and
    ``<stem>_radiation.npz`` (:func:`write_radiation`) into ``out_dir``.

    The TOML's ``hydro_file``, ``mooring_file`` and ``radiation_file`` name the data files
    relative to it, so
    ``plant.platform.load_floating(out_dir / f"{stem}.toml")`` reads the preset back.

    Parameters
    ----------
    deck : ImportedDeck
    out_dir : Path
        Created if missing; existing files of the same names are overwritten.
    stem : str, optional
        File name stem; default: the preset name reduced to ``[a-z0-9_]``.

    Returns
    -------
    Path
        The TOML file written.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = stem or re.sub(r"[^a-z0-9]+", "_", deck.preset.name.lower()).strip("_")[:40]
    hydro_name = f"{stem}_hydro.npz"
    moor_name = f"{stem}_mooring.json"
    rad_name = f"{stem}_radiation.npz"
    deck.hydro.save_npz(out_dir / hydro_name)
    (out_dir / moor_name).write_bytes(msgspec.json.format(msgspec.json.encode(deck.mooring)))
    model = write_radiation(deck.preset, deck.hydro, out_dir / rad_name)
    preset = msgspec.structs.replace(
        deck.preset, hydro_file=hydro_name, mooring_file=moor_name, radiation_file=rad_name
    )
    notes = [*deck.notes, *(f"radiation {line}" for line in model.describe())]
    header = "".join(f"# {n}\n" for n in notes)
    body = _toml_lines(msgspec.structs.asdict(preset))
    path = out_dir / f"{stem}.toml"
    path.write_text(
        f"# Floating turbine preset written by plant.openfast_import.write_preset\n"
        f"{header}\n{body}",
        encoding="utf-8",
    )
    return path
