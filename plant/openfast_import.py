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

Versions: the environment (``Gravity``, ``WtrDens``, ``WtrDpth``) is read from the ``.fst``
(OpenFAST ≥ 3.5) or from ElastoDyn/HydroDyn/SeaState (older decks); tables (blade, tower,
AeroDyn tower drag, HydroDyn members and fill groups, MoorDyn v1 and v2) are found by their
header names, never by column position; HydroDyn's filled member groups add their ballast to
the platform (:func:`read_fill_groups`) and :attr:`ImportedDeck.mass_budget` says where the
mass comes from. See docs/openfast-import.md.

Strip-theory members (HydroDyn ``PropPot = FALSE``, :func:`read_morison_members`): members
outside the WAMIT model add their submerged volume's buoyancy ρ g V_m (and its moment), their
hydrostatic restoring (waterplane area and second moment where they pierce the still-water
line, V_m z_B in roll and pitch) and their transverse Morison added mass Ca ρ π r² per length
(:func:`morison_member`); the preset carries them as ``member_force_n``,
``member_stiffness`` and ``member_added_mass``. Their **structural mass is not added**: in
OpenFAST the whole platform structure (steel of every member, and permanent ballast) is
ElastoDyn's ``PtfmMass``/``PtfmCM*``/``Ptfm*Iner``; HydroDyn adds only hydrodynamic loads
(buoyancy, added mass, drag, wave loads), the water of filled members (fill groups) and marine
growth (HydroDyn documentation; since OpenFAST 2.6 HydroDyn computes the strip-theory
members' hydrostatics itself, so ``AddCLin`` no longer carries them). Not modelled, and said
so in the notes: the members' drag and wave excitation, the axial (end-plate) added mass of
``AxCa`` and marine growth; refused by file and line: rectangular strip-theory members and
depth-based coefficients (``MCoefMod = 2``).

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
from plant.platform import FloatingPreset, MooringFile, RadiationFitOptions, tower_modal

__all__ = [
    "DEFAULT_RADIATION_OMEGA_MAX_RAD_S",
    "DUPLICATE_STIFFNESS_REL_TOL",
    "Ballast",
    "DuplicateStiffness",
    "ImportedDeck",
    "KeyedValues",
    "MooringLine",
    "MorisonMembers",
    "blade_properties",
    "compute_mooring",
    "duplicate_add_stiffness",
    "flooded_member",
    "import_openfast",
    "morison_member",
    "radiation_report",
    "read_fill_groups",
    "read_keyed_file",
    "read_moordyn",
    "read_morison_members",
    "write_preset",
    "write_radiation",
]

_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eEdD][-+]?\d+)?$")


class KeyedValues(dict[str, str]):
    """Values of an OpenFAST input file by upper-case key, with the 1-based line of each key."""

    line_of: dict[str, int]

    def __init__(self) -> None:
        super().__init__()
        self.line_of = {}


def read_keyed_file(path: Path) -> tuple[KeyedValues, list[str]]:
    """Values of an OpenFAST input file by key (first token = value, second = key) and its lines.

    Keys are case-insensitive (stored upper case); ``Key(1)`` is stored as ``KEY(1)``. Quotes
    are stripped from values. ``values.line_of[key]`` is the key's 1-based line number.
    """
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as exc:
        raise OSError(f"{path}: cannot read ({exc})") from exc
    values = KeyedValues()
    for number, line in enumerate(lines, start=1):
        tok = line.split()
        if len(tok) >= 2 and not tok[0].startswith(("--", "!", "#")):
            key = tok[1].upper()
            if key not in values:
                values[key] = tok[0].strip('"').strip("'")
                values.line_of[key] = number
    return values, lines


def _where(values: dict[str, str], key: str, source: Path) -> str:
    """``file:line`` of ``key`` (``file`` alone when the key is absent)."""
    line = getattr(values, "line_of", {}).get(key.upper())
    return f"{source}:{line}" if line else str(source)


def _to_float(raw: str) -> float:
    return float(raw.replace("d", "e").replace("D", "E"))


def _num(values: dict[str, str], key: str, source: Path, default: float | None = None) -> float:
    raw = values.get(key.upper())
    if raw is None or raw.upper() == "DEFAULT":
        if default is not None:
            return default
        if raw is None:
            raise ValueError(f"{source}: key {key!r} not found (expected a number)")
        raise ValueError(
            f"{_where(values, key, source)}: key {key!r} is DEFAULT; expected a number"
        )
    try:
        return _to_float(raw)
    except ValueError:
        raise ValueError(
            f"{_where(values, key, source)}: key {key!r} = {raw!r}; expected a number"
        ) from None


def _text(values: dict[str, str], key: str, source: Path) -> str:
    raw = values.get(key.upper())
    if raw is None:
        raise ValueError(f"{source}: key {key!r} not found")
    return raw


def _first_text(values: dict[str, str], keys: tuple[str, ...], source: Path) -> str:
    """The value of the first of ``keys`` present (spellings of one key across versions)."""
    for key in keys:
        if key.upper() in values:
            return values[key.upper()]
    raise ValueError(f"{source}: none of the keys {', '.join(keys)} found")


def _row_floats(tokens: list[str], source: Path, line: int, what: str) -> list[float]:
    try:
        return [_to_float(t) for t in tokens]
    except ValueError:
        raise ValueError(
            f"{source}:{line}: {what}: expected numbers, got {' '.join(tokens)!r}"
        ) from None


def _header_table(
    lines: list[str],
    required: tuple[str, ...],
    source: Path,
    what: str,
    start: int = 0,
) -> tuple[dict[str, int], list[tuple[int, list[str]]], int]:
    """A table located by its header row (the first row naming every column in ``required``).

    Returns the column index of every header name (upper case), the data rows as
    ``(1-based line, tokens)`` (after the units row, up to the first row that does not start
    with a number) and the header's 1-based line. Columns are found by name, never by
    position: the layouts of the OpenFAST versions differ in which columns they hold.
    """
    want = {r.upper() for r in required}
    for i in range(start, len(lines)):
        # "!" starts a comment (AeroDyn's tower header carries one): not column names.
        tok = [t.upper() for t in lines[i].split("!", 1)[0].split()]
        if want <= set(tok):
            cols: dict[str, int] = {}
            for k, name in enumerate(tok):
                cols.setdefault(name, k)
            rows: list[tuple[int, list[str]]] = []
            for j in range(i + 1, len(lines)):
                row = lines[j].split()
                if not row:
                    if rows:
                        break
                    continue
                if row[0].startswith("("):  # units row
                    continue
                if not _NUMBER.match(row[0]):
                    break
                need = max(cols[r.upper()] for r in required) + 1
                if len(row) < need:
                    raise ValueError(
                        f"{source}:{j + 1}: {what}: expected at least {need} columns "
                        f"({' '.join(lines[i].split()[:need])}), got {len(row)}"
                    )
                rows.append((j + 1, row))
            return cols, rows, i + 1
    raise ValueError(f"{source}: {what}: no table header naming {', '.join(required)}")


def _matrix_rows(lines: list[str], key: str, source: Path) -> list[list[float]]:
    """The 6x6 matrix of ``key`` (e.g. ``AddBQuad``): the row holding the key and the next five."""
    for i, line in enumerate(lines):
        tok = line.split()
        if len(tok) > 6 and tok[6].upper() == key.upper():
            rows = []
            for r in range(6):
                row = lines[i + r].split()[:6] if i + r < len(lines) else []
                if len(row) < 6:
                    raise ValueError(f"{source}:{i + r + 1}: {key} row {r + 1}: expected 6 numbers")
                rows.append(_row_floats(row, source, i + r + 1, f"{key} row {r + 1}"))
            return rows
    raise ValueError(f"{source}: 6x6 matrix {key!r} not found")


def _vector6(lines: list[str], key: str, source: Path) -> list[float]:
    """The 6-vector of ``key`` (``AddF0``): one value per line (the key on the first), or
    the six values on the key's line (both layouts appear in HydroDyn files)."""
    for i, line in enumerate(lines):
        tok = line.split()
        if len(tok) >= 7 and tok[6].upper() == key.upper():
            return _row_floats(tok[:6], source, i + 1, key)
        if len(tok) >= 2 and tok[1].upper() == key.upper():
            out = _row_floats(tok[:1], source, i + 1, key)
            for r in range(1, 6):
                row = lines[i + r].split()[:1] if i + r < len(lines) else []
                if not row:
                    raise ValueError(
                        f"{source}:{i + r + 1}: {key}: expected value {r + 1} of 6 on this line"
                    )
                out += _row_floats(row, source, i + r + 1, f"{key} value {r + 1}")
            return out
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


def _first_table(
    lines: list[str], layouts: tuple[tuple[str, ...], ...], source: Path, what: str
) -> tuple[dict[str, int], list[tuple[int, list[str]]], int]:
    """The first table whose header names every column of one of ``layouts``."""
    for required in layouts:
        try:
            return _header_table(lines, required, source, what)
        except ValueError as exc:
            if "no table header" not in str(exc):
                raise  # a malformed row of a table that was found
            continue
    expected = " or ".join("(" + ", ".join(r) + ")" for r in layouts)
    raise ValueError(f"{source}: {what}: no table header naming {expected}")


def read_moordyn(path: Path) -> list[MooringLine]:
    """Anchor-to-fairlead lines of a MoorDyn input file (v1 or v2); free points are rejected.

    Tables are found by their header names, so both layouts read: v1 (``LINE TYPES`` with a
    ``NTypes`` count line, ``CONNECTION PROPERTIES`` ``Node Type X Y Z``, ``LINE PROPERTIES``
    ``Line LineType UnstrLen NumSegs NodeAnch NodeFair``) and v2 (``POINTS`` ``ID/Node
    Attachment/Type X Y Z``, ``LINES`` ``Line LineType AttachA AttachB UnstrLen NumSegs``).
    Count lines (``3  NTypes``) are not table rows: a row must start with a number (points,
    lines) or follow the header (types).
    """
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as exc:
        raise OSError(f"{path}: cannot read ({exc})") from exc
    # Line types: rows start with a name, so they are read up to the next section line.
    types: dict[str, tuple[float, float, float]] = {}
    for mass_key in ("MASSDEN", "MASSDENINAIR"):
        head = next(
            (
                i
                for i, ln in enumerate(lines)
                if {"DIAM", mass_key, "EA"} <= {t.upper() for t in ln.split()}
            ),
            None,
        )
        if head is not None:
            break
    if head is None:
        raise ValueError(f"{path}: line types: no table header naming Diam, MassDen, EA")
    hdr = [t.upper() for t in lines[head].split()]
    i_d, i_m, i_ea = hdr.index("DIAM"), hdr.index(mass_key), hdr.index("EA")
    for j in range(head + 1, len(lines)):
        tok = lines[j].split()
        if not tok or tok[0].startswith("("):
            continue
        if tok[0].startswith("--") or len(tok) <= max(i_d, i_m, i_ea):
            break
        d, m, ea = _row_floats([tok[i_d], tok[i_m], tok[i_ea]], path, j + 1, "line type")
        types[tok[0]] = (d, m, ea)
    pcols, prow, _ = _first_table(
        lines, (("X", "Y", "Z", "ATTACHMENT"), ("X", "Y", "Z", "TYPE")), path, "points"
    )
    kind = pcols.get("ATTACHMENT", pcols.get("TYPE", 1))
    points: dict[int, tuple[str, tuple[float, float, float], int]] = {}
    for number, tok in prow:
        if len(tok) <= max(pcols["X"], pcols["Y"], pcols["Z"], kind):
            raise ValueError(f"{path}:{number}: point: expected columns up to Z, got {tok}")
        xyz = _row_floats([tok[pcols[c]] for c in ("X", "Y", "Z")], path, number, "point X Y Z")
        points[int(float(tok[0]))] = (tok[kind].lower(), (xyz[0], xyz[1], xyz[2]), number)
    lcols, lrow, _ = _first_table(
        lines,
        (
            ("LINETYPE", "ATTACHA", "ATTACHB", "UNSTRLEN"),
            ("LINETYPE", "NODEANCH", "NODEFAIR", "UNSTRLEN"),
        ),
        path,
        "lines",
    )
    end_a = lcols.get("ATTACHA", lcols.get("NODEANCH", 0))
    end_b = lcols.get("ATTACHB", lcols.get("NODEFAIR", 0))
    if not lrow:
        raise ValueError(f"{path}: no mooring lines found")
    out: list[MooringLine] = []
    for number, tok in lrow:
        if len(tok) <= max(end_a, end_b, lcols["UNSTRLEN"], lcols["LINETYPE"]):
            raise ValueError(f"{path}:{number}: line: too few columns ({tok})")
        type_name = tok[lcols["LINETYPE"]]
        if type_name not in types:
            raise ValueError(
                f"{path}:{number}: line type {type_name!r} not defined "
                f"(defined: {', '.join(types) or 'none'})"
            )
        a_id, b_id, length = _row_floats(
            [tok[end_a], tok[end_b], tok[lcols["UNSTRLEN"]]], path, number, "line"
        )
        ends: dict[str, tuple[float, float, float]] = {}
        for pid in (int(a_id), int(b_id)):
            if pid not in points:
                raise ValueError(f"{path}:{number}: line refers to point {pid}, not defined")
            ends[points[pid][0]] = points[pid][1]
        anchor = ends.get("fixed") or ends.get("fix")
        fair = ends.get("vessel") or ends.get("coupled")
        if anchor is None or fair is None:
            raise ValueError(
                f"{path}:{number}: line between points {int(a_id)} and {int(b_id)} is not "
                "anchor (Fixed) to fairlead (Vessel/Coupled); free connection points are not "
                "supported"
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
class Ballast:
    """Mass properties of the water ballast of HydroDyn's filled member groups.

    Attributes
    ----------
    mass_kg : float
        m_b = Σ ρ_f V_f over the filled members (kg).
    volume_m3 : float
        Flooded volume V_f (m³).
    cm_x_m, cm_z_m : float
        Centre of mass in the platform frame (downwind, up from the still-water line) (m).
    pitch_inertia_origin_kg_m2 : float
        I_yy about the platform reference point (0, 0, 0) (kg m²).
    """

    mass_kg: float
    volume_m3: float
    cm_x_m: float
    cm_z_m: float
    pitch_inertia_origin_kg_m2: float

    @property
    def pitch_inertia_cm_kg_m2(self) -> float:
        """I_yy about the ballast's own centre of mass: I_O − m (x_c² + z_c²) (kg m²)."""
        return self.pitch_inertia_origin_kg_m2 - self.mass_kg * (self.cm_x_m**2 + self.cm_z_m**2)


_GAUSS_S, _GAUSS_W = np.polynomial.legendre.leggauss(16)


def flooded_member(
    end1_m: tuple[float, float, float],
    end2_m: tuple[float, float, float],
    inner_radius1_m: float,
    inner_radius2_m: float,
    fill_level_m: float,
    density_kg_m3: float,
) -> tuple[float, float, float, float, float]:
    """Mass, volume, first moments and pitch inertia of a member flooded up to a level.

    The member is a (possibly tapered) circular tube between ``end1_m`` and ``end2_m`` with
    inner radius r(s) varying linearly along the axis; it holds fluid of density ρ_f wherever
    its axis is below the fill free surface z_f (``fill_level_m``, HydroDyn ``FillFSLoc``).
    For a member that is not horizontal the flooded length is cut exactly at z(s) = z_f; a
    horizontal member is flooded wholly when its axis is below z_f (and not otherwise).
    Each slice ds is a disc of mass dm = ρ_f π r(s)² ds with axis ê; its inertia about its
    centre is dm r²/4 (I + ê êᵀ), so about the y axis through the origin

        I_yy = ∫ (x² + z²) dm + ∫ r²/4 (1 + ê_y²) dm.

    The integrals are 16-point Gauss-Legendre over the flooded length (exact for the
    polynomial integrands of a tapered member). For a vertical cylinder of inner radius r
    flooded over a height h: m = ρ_f π r² h and I_yy about its centre = m (r²/4 + h²/12).

    Returns
    -------
    tuple of float
        (mass kg, volume m³, ∫ x dm kg m, ∫ z dm kg m, I_yy about the origin kg m²).
    """
    p1 = np.asarray(end1_m, dtype=float)
    p2 = np.asarray(end2_m, dtype=float)
    length = float(np.linalg.norm(p2 - p1))
    if length == 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    e = (p2 - p1) / length
    z1, z2 = p1[2], p2[2]
    if z1 == z2:
        lo, hi = (0.0, length) if z1 <= fill_level_m else (0.0, 0.0)
    else:
        cut = min(max((fill_level_m - z1) / (z2 - z1) * length, 0.0), length)
        lo, hi = (0.0, cut) if z1 < z2 else (cut, length)
    if hi <= lo:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    s = 0.5 * (hi - lo) * _GAUSS_S + 0.5 * (hi + lo)
    w = 0.5 * (hi - lo) * _GAUSS_W
    r = inner_radius1_m + (inner_radius2_m - inner_radius1_m) * s / length
    area = math.pi * r**2
    pos = p1[None, :] + s[:, None] * e[None, :]
    x, z = pos[:, 0], pos[:, 2]
    vol = float(np.sum(w * area))
    dm = density_kg_m3 * w * area
    inertia = float(np.sum(dm * (x**2 + z**2)) + np.sum(dm * r**2 / 4.0) * (1.0 + e[1] ** 2))
    return float(np.sum(dm)), vol, float(np.sum(dm * x)), float(np.sum(dm * z)), inertia


def read_fill_groups(
    hd_path: Path, hd_lines: list[str], hd: dict[str, str], water_density_kg_m3: float
) -> Ballast | None:
    """The ballast of HydroDyn's filled member groups (``NFillGroups``), None if there is none.

    Reads the joints (``JointID Jointxi Jointyi Jointzi``), the cylindrical property sets
    (``PropSetID PropD PropThck``; inner radius D/2 − t), the members (``MemberID MJointID1
    MJointID2 MPropSetID1 MPropSetID2`` [``MSecGeom``]) and the fill groups (``FillNumM
    FillMList FillFSLoc FillDens``; ``FillDens = DEFAULT`` is the water density), each table
    by its header names. Every member of a group is flooded up to ``FillFSLoc``
    (:func:`flooded_member`).

    Raises
    ------
    ValueError
        A fill group naming an unknown member, a rectangular member or malformed rows
        (message with file and line).
    """
    n_groups = int(_num(hd, "NFillGroups", hd_path, 0.0))
    if n_groups <= 0:
        return None
    jc, jrows, _ = _header_table(
        hd_lines, ("JointID", "Jointxi", "Jointyi", "Jointzi"), hd_path, "member joints"
    )
    joints: dict[int, tuple[float, float, float]] = {}
    for number, tok in jrows:
        xyz = _row_floats(
            [tok[jc["JOINTXI"]], tok[jc["JOINTYI"]], tok[jc["JOINTZI"]]], hd_path, number, "joint"
        )
        joints[int(float(tok[jc["JOINTID"]]))] = (xyz[0], xyz[1], xyz[2])
    pc, prows, _ = _header_table(
        hd_lines, ("PropSetID", "PropD", "PropThck"), hd_path, "member properties"
    )
    props: dict[int, float] = {}
    for number, tok in prows:
        d, t = _row_floats([tok[pc["PROPD"]], tok[pc["PROPTHCK"]]], hd_path, number, "property")
        props[int(float(tok[pc["PROPSETID"]]))] = 0.5 * d - t
    mc, mrows, _ = _header_table(
        hd_lines,
        ("MemberID", "MJointID1", "MJointID2", "MPropSetID1", "MPropSetID2"),
        hd_path,
        "members",
    )
    members: dict[int, tuple[int, int, int, int, int]] = {}
    for number, tok in mrows:
        ids = _row_floats(
            [tok[mc[k]] for k in ("MJOINTID1", "MJOINTID2", "MPROPSETID1", "MPROPSETID2")],
            hd_path,
            number,
            "member",
        )
        geom = tok[mc["MSECGEOM"]] if "MSECGEOM" in mc and len(tok) > mc["MSECGEOM"] else "1"
        if _NUMBER.match(geom) is None or int(float(geom)) != 1:
            ids.append(-1.0)  # rectangular: refused only if a fill group names it
        members[int(float(tok[mc["MEMBERID"]]))] = (
            int(ids[0]),
            int(ids[1]),
            int(ids[2]),
            int(ids[3]),
            number if len(ids) == 4 else -number,
        )
    _, _, head = _header_table(
        hd_lines, ("FillNumM", "FillMList", "FillFSLoc", "FillDens"), hd_path, "filled members"
    )
    rows: list[tuple[int, list[str]]] = []
    for j in range(head, len(hd_lines)):
        tok = hd_lines[j].split()
        if (tok and tok[0].startswith("--")) or len(rows) == n_groups:
            break  # the next section: no more fill-group rows
        if tok and _NUMBER.match(tok[0]):
            rows.append((j + 1, tok))
    if len(rows) < n_groups:
        raise ValueError(
            f"{hd_path}:{head}: NFillGroups = {n_groups} but {len(rows)} fill-group rows follow"
        )
    mass = vol = mx = mz = inertia = 0.0
    for number, tok in rows:
        count = int(_row_floats(tok[:1], hd_path, number, "FillNumM")[0])
        if len(tok) < count + 3:
            raise ValueError(
                f"{hd_path}:{number}: fill group: expected FillNumM = {count} member IDs, "
                "FillFSLoc and FillDens"
            )
        member_ids = [int(v) for v in _row_floats(tok[1 : 1 + count], hd_path, number, "FillMList")]
        level = _row_floats([tok[1 + count]], hd_path, number, "FillFSLoc")[0]
        raw = tok[2 + count].strip('"')
        dens = (
            water_density_kg_m3
            if raw.upper() == "DEFAULT"
            else _row_floats([raw], hd_path, number, "FillDens")[0]
        )
        for mid in member_ids:
            if mid not in members:
                raise ValueError(f"{hd_path}:{number}: fill group names member {mid}, not defined")
            j1, j2, p1, p2, mline = members[mid]
            if mline < 0:
                raise ValueError(
                    f"{hd_path}:{-mline}: member {mid} is filled but rectangular; only "
                    "cylindrical filled members are supported"
                )
            for jid in (j1, j2):
                if jid not in joints:
                    raise ValueError(f"{hd_path}:{mline}: member {mid}: joint {jid} not defined")
            for pid in (p1, p2):
                if pid not in props:
                    raise ValueError(
                        f"{hd_path}:{mline}: member {mid}: property set {pid} not defined"
                    )
            m, v, fx, fz, iy = flooded_member(
                joints[j1], joints[j2], props[p1], props[p2], level, dens
            )
            mass, vol, mx, mz, inertia = mass + m, vol + v, mx + fx, mz + fz, inertia + iy
    if mass <= 0.0:
        return Ballast(0.0, 0.0, 0.0, 0.0, 0.0)
    return Ballast(mass, vol, mx / mass, mz / mass, inertia)


@dataclass(frozen=True)
class MorisonMembers:
    """Buoyancy, hydrostatic restoring and added mass of HydroDyn's strip-theory members.

    The members with ``PropPot = FALSE`` (not in the WAMIT model), submerged part only
    (clipped at the still-water line z = 0), about the platform reference point, 6x6 in WAMIT
    DOF order (surge, sway, heave, roll, pitch, yaw).

    Attributes
    ----------
    count : int
        Members with ``PropPot = FALSE``.
    volume_m3 : float
        Submerged volume V_m (m³); buoyancy ρ g V_m.
    cb_x_m, cb_z_m : float
        Centre of buoyancy of V_m (m).
    waterplane_area_m2 : float
        Waterplane area of the members piercing the still-water line (m²).
    force_n : list of 6 float
        Static load at rest: (0, 0, ρ g V_m, ρ g V_m y_B, −ρ g V_m x_B, 0) (N, N m).
    stiffness : 6x6 list
        Hydrostatic restoring (WAMIT ``.hst`` convention, no weight): C_33 = ρ g A_wp,
        C_35 = C_53 = −ρ g ∫x dA, C_55 = ρ g (∫x² dA + V_m z_B), and the roll terms alike.
    added_mass : 6x6 list
        Transverse Morison added mass ∫ Jᵀ Ca ρ π r² (I − ê êᵀ) J ds, J = [I, −[r]×].
    notes : tuple of str
        What of these members is not modelled (axial added mass, marine growth, ...).
    """

    count: int
    volume_m3: float
    cb_x_m: float
    cb_z_m: float
    waterplane_area_m2: float
    force_n: list[float]
    stiffness: list[list[float]]
    added_mass: list[list[float]]
    notes: tuple[str, ...] = ()


def _skew(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def morison_member(
    end1_m: tuple[float, float, float],
    end2_m: tuple[float, float, float],
    radius1_m: float,
    radius2_m: float,
    ca: tuple[float, float],
) -> tuple[float, np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]:
    """Submerged volume, its first moments, waterplane figures and added mass of one member.

    A (possibly tapered) circular member between ``end1_m`` and ``end2_m`` (outer radius
    linear along the axis), clipped where its axis crosses the still-water line z = 0 (a
    horizontal member counts wholly when its axis is below the SWL, not at all otherwise).
    Volume V = ∫ π r² ds and first moments ∫ (x, y, z) dV by 16-point Gauss-Legendre
    (exact for tapered members); a member piercing the SWL with axis ê cuts an ellipse of area
    A = π r₀²/|ê_z| and semi-axes r₀/|ê_z| (along the horizontal projection of ê) and r₀,
    centred at the piercing point p (r₀ the radius there): ∫x dA = A p_x,
    ∫x² dA = A p_x² + A/4 (a² u_x² + b² w_x²) for semi-axes a along u and b along w.
    Transverse added mass per length m_a = Ca(s) ρ π r² (Ca linear between ``ca``),
    generalised over the six rigid-body DOFs with the point's Jacobian J = [I, −[r]×].

    Returns
    -------
    tuple
        (V m³, ∫ r dV (3,) m⁴, (∫ x dA, ∫ y dA, ∫ x² dA, ∫ y² dA) m³ / m⁴ as (4,) array,
        A_wp m², added mass (6, 6) for ρ = 1 (multiply by ρ), unit axis ê (3,)).
    """
    p1 = np.asarray(end1_m, dtype=float)
    p2 = np.asarray(end2_m, dtype=float)
    length = float(np.linalg.norm(p2 - p1))
    zero6 = np.zeros((6, 6))
    if length == 0.0:
        return 0.0, np.zeros(3), np.zeros(4), 0.0, zero6, np.zeros(3)
    e = (p2 - p1) / length
    z1, z2 = p1[2], p2[2]
    wp = np.zeros(4)
    awp = 0.0
    if z1 == z2:
        lo, hi = (0.0, length) if z1 < 0.0 else (0.0, 0.0)
    else:
        cut = min(max((0.0 - z1) / (z2 - z1) * length, 0.0), length)
        lo, hi = (0.0, cut) if z1 < z2 else (cut, length)
        if 0.0 < cut < length:  # pierces the still-water line
            r0 = radius1_m + (radius2_m - radius1_m) * cut / length
            p = p1 + cut * e
            ez = abs(e[2])
            awp = math.pi * r0 * r0 / ez
            h = math.hypot(e[0], e[1])
            u = np.array([e[0], e[1]]) / h if h > 1e-12 else np.array([1.0, 0.0])
            w = np.array([-u[1], u[0]])
            a, b = r0 / ez, r0
            wp = np.array(
                [
                    awp * p[0],
                    awp * p[1],
                    awp * p[0] ** 2 + awp / 4.0 * (a * a * u[0] ** 2 + b * b * w[0] ** 2),
                    awp * p[1] ** 2 + awp / 4.0 * (a * a * u[1] ** 2 + b * b * w[1] ** 2),
                ]
            )
    if hi <= lo:
        return 0.0, np.zeros(3), wp, awp, zero6, e
    s = 0.5 * (hi - lo) * _GAUSS_S + 0.5 * (hi + lo)
    wts = 0.5 * (hi - lo) * _GAUSS_W
    r = radius1_m + (radius2_m - radius1_m) * s / length
    area = math.pi * r**2
    pos = p1[None, :] + s[:, None] * e[None, :]
    dv = wts * area
    vol = float(np.sum(dv))
    first = np.sum(dv[:, None] * pos, axis=0)
    ca_s = ca[0] + (ca[1] - ca[0]) * s / length
    transverse = np.eye(3) - np.outer(e, e)
    added = np.zeros((6, 6))
    for k in range(s.size):
        jac = np.hstack([np.eye(3), -_skew(pos[k])])
        added += ca_s[k] * dv[k] * (jac.T @ transverse @ jac)
    return vol, first, wp, awp, added, e


def read_morison_members(
    hd_path: Path,
    hd_lines: list[str],
    hd: dict[str, str],
    rho_kg_m3: float,
    g_m_s2: float,
) -> MorisonMembers | None:
    """The strip-theory members of a HydroDyn file (``PropPot = FALSE``), None if none.

    Reads the joints, the cylindrical property sets (``PropD``), the members (``PropPot``,
    ``MCoefMod``, [``MSecGeom``]) and the transverse added-mass coefficients of the
    coefficient model each member names: 1 simple (``SimplCa``), 3 member-based
    (``MemberCa1``, ``MemberCa2``); each table by its header names. Sums
    :func:`morison_member` over the members (see :class:`MorisonMembers`).

    Raises
    ------
    ValueError
        A strip-theory member that is rectangular, names an unknown joint or property set,
        or uses depth-based coefficients (``MCoefMod = 2``), by file and line.
    """
    try:
        mc, mrows, _ = _header_table(
            hd_lines,
            ("MemberID", "MJointID1", "MJointID2", "MPropSetID1", "MPropSetID2", "PropPot"),
            hd_path,
            "members",
        )
    except ValueError as exc:
        if "no table header" in str(exc):
            return None  # no member table: nothing to model
        raise
    strip = [
        (n, t)
        for n, t in mrows
        if len(t) > mc["PROPPOT"] and t[mc["PROPPOT"]].strip('"').upper() in ("FALSE", "F", "0")
    ]
    if not strip:
        return None
    jc, jrows, _ = _header_table(
        hd_lines, ("JointID", "Jointxi", "Jointyi", "Jointzi"), hd_path, "member joints"
    )
    joints: dict[int, tuple[tuple[float, float, float], int]] = {}
    for number, tok in jrows:
        xyz = _row_floats(
            [tok[jc["JOINTXI"]], tok[jc["JOINTYI"]], tok[jc["JOINTZI"]]], hd_path, number, "joint"
        )
        ax = 0
        if "JOINTAXID" in jc and len(tok) > jc["JOINTAXID"]:
            ax = int(_row_floats([tok[jc["JOINTAXID"]]], hd_path, number, "JointAxID")[0])
        joints[int(float(tok[jc["JOINTID"]]))] = ((xyz[0], xyz[1], xyz[2]), ax)
    pc, prows, _ = _header_table(hd_lines, ("PropSetID", "PropD"), hd_path, "member properties")
    props = {
        int(float(tok[pc["PROPSETID"]])): _row_floats(
            [tok[pc["PROPD"]]], hd_path, number, "property"
        )[0]
        for number, tok in prows
    }
    simple_ca: float | None = None
    member_ca: dict[int, tuple[float, float]] = {}
    axial_ca: dict[int, float] = {}
    notes: list[str] = []
    mg = int(_num(hd, "NMGDepths", hd_path, 0.0))
    if mg > 0:
        notes.append(
            f"{hd_path}: {mg} marine-growth depths ignored (their mass, buoyancy and added "
            "mass are not modelled)"
        )
    vol = 0.0
    first = np.zeros(3)
    wp = np.zeros(4)
    awp = 0.0
    added = np.zeros((6, 6))
    for number, tok in strip:
        mid = int(float(tok[mc["MEMBERID"]]))
        geom = tok[mc["MSECGEOM"]] if "MSECGEOM" in mc and len(tok) > mc["MSECGEOM"] else "1"
        if _NUMBER.match(geom) is None or float(geom) != 1.0:
            raise ValueError(
                f"{hd_path}:{number}: member {mid} (PropPot = FALSE) is rectangular "
                f"(MSecGeom = {geom}); only cylindrical strip-theory members "
                "are modelled"
            )
        ids = [
            int(v)
            for v in _row_floats(
                [tok[mc[k]] for k in ("MJOINTID1", "MJOINTID2", "MPROPSETID1", "MPROPSETID2")],
                hd_path,
                number,
                "member",
            )
        ]
        for jid in ids[:2]:
            if jid not in joints:
                raise ValueError(f"{hd_path}:{number}: member {mid}: joint {jid} not defined")
        for pid in ids[2:]:
            if pid not in props:
                raise ValueError(
                    f"{hd_path}:{number}: member {mid}: property set {pid} not defined"
                )
        model = 1
        if "MCOEFMOD" in mc and len(tok) > mc["MCOEFMOD"]:
            model = int(_row_floats([tok[mc["MCOEFMOD"]]], hd_path, number, "MCoefMod")[0])
        if model == 1:
            if simple_ca is None:
                sc, srows, _ = _header_table(
                    hd_lines, ("SimplCa",), hd_path, "simple hydrodynamic coefficients"
                )
                if not srows:
                    raise ValueError(f"{hd_path}: simple hydrodynamic coefficients: no row")
                n0, t0 = srows[0]
                simple_ca = _row_floats([t0[sc["SIMPLCA"]]], hd_path, n0, "SimplCa")[0]
            ca = (simple_ca, simple_ca)
        elif model == 3:
            if not member_ca:
                cc, crows, _ = _header_table(
                    hd_lines,
                    ("MemberID", "MemberCa1", "MemberCa2"),
                    hd_path,
                    "member-based hydrodynamic coefficients",
                )
                for n0, t0 in crows:
                    a1, a2 = _row_floats(
                        [t0[cc["MEMBERCA1"]], t0[cc["MEMBERCA2"]]], hd_path, n0, "MemberCa"
                    )
                    member_ca[int(float(t0[cc["MEMBERID"]]))] = (a1, a2)
            if mid not in member_ca:
                raise ValueError(
                    f"{hd_path}:{number}: member {mid} uses member-based coefficients "
                    "(MCoefMod = 3) but the coefficient table has no row for it"
                )
            ca = member_ca[mid]
        else:
            raise ValueError(
                f"{hd_path}:{number}: member {mid} (PropPot = FALSE) uses MCoefMod = {model}; "
                "only simple (1) and member-based (3) coefficients are read (depth-based "
                "coefficients are not supported)"
            )
        (e1, ax1), (e2, ax2) = joints[ids[0]], joints[ids[1]]
        v, f1, w1, a1, m1, _ = morison_member(e1, e2, 0.5 * props[ids[2]], 0.5 * props[ids[3]], ca)
        vol, first, wp, awp, added = vol + v, first + f1, wp + w1, awp + a1, added + m1
        for ax in (ax1, ax2):
            if ax and ax not in axial_ca:
                axial_ca[ax] = _axial_ca(hd_path, hd_lines, ax)
    nonzero = sorted(k for k, v in axial_ca.items() if v != 0.0)
    if nonzero:
        notes.append(
            f"{hd_path}: axial added-mass coefficients AxCa of joints' AxCoefID "
            f"{', '.join(map(str, nonzero))} not modelled (end-plate added mass ignored)"
        )
    notes.append(
        f"{hd_path}: {len(strip)} strip-theory members (PropPot = FALSE): buoyancy, "
        "hydrostatic restoring and transverse added mass modelled; their drag and wave "
        "excitation are not (only AddBQuad drag is used)"
    )
    rg = rho_kg_m3 * g_m_s2
    xb, _, zb = (first / vol) if vol > 0.0 else (0.0, 0.0, 0.0)
    c = np.zeros((6, 6))
    c[2, 2] = rg * awp
    c[2, 3] = c[3, 2] = rg * wp[1]
    c[2, 4] = c[4, 2] = -rg * wp[0]
    c[3, 3] = rg * (wp[3] + first[2])
    c[4, 4] = rg * (wp[2] + first[2])
    c[3, 5] = -rg * first[0]
    c[4, 5] = -rg * first[1]
    force = [0.0, 0.0, rg * vol, rg * first[1], -rg * first[0], 0.0]
    return MorisonMembers(
        count=len(strip),
        volume_m3=vol,
        cb_x_m=float(xb),
        cb_z_m=float(zb),
        waterplane_area_m2=awp,
        force_n=[float(v) for v in force],
        stiffness=c.tolist(),
        added_mass=(rho_kg_m3 * 0.5 * (added + added.T)).tolist(),
        notes=tuple(notes),
    )


def _axial_ca(hd_path: Path, hd_lines: list[str], ax_id: int) -> float:
    """``AxCa`` of the axial-coefficient set ``ax_id`` (HydroDyn ``AxCoefID`` table)."""
    ac, arows, _ = _header_table(hd_lines, ("AxCoefID", "AxCa"), hd_path, "axial coefficients")
    for number, tok in arows:
        if int(float(tok[ac["AXCOEFID"]])) == ax_id:
            return _row_floats([tok[ac["AXCA"]]], hd_path, number, "AxCa")[0]
    raise ValueError(f"{hd_path}: axial coefficient set {ax_id} (JointAxID) not defined")


@dataclass(frozen=True)
class ImportedDeck:
    """What :func:`import_openfast` read: the preset figures, WAMIT data and mooring tables.

    ``notes`` lists derived figures and checks (e.g. the tower fixed-base frequency).
    """

    preset: FloatingPreset
    hydro: HydroData
    mooring: MooringFile
    notes: tuple[str, ...]
    #: Where the mass comes from: (item, kg) rows, platform structure (ElastoDyn
    #: ``PtfmMass``), ballast (HydroDyn fill groups), tower, rotor-nacelle assembly, total.
    mass_budget: tuple[tuple[str, float], ...] = ()
    #: The filled-member ballast added to the platform (None: the deck has none).
    ballast: Ballast | None = None
    #: The strip-theory members' buoyancy, restoring and added mass (None: the deck has none).
    members: MorisonMembers | None = None
    #: Warnings the user must read, e.g. ``AddCLin`` entries that repeat a restoring the
    #: importer already models (:func:`duplicate_add_stiffness`).
    warnings: tuple[str, ...] = ()


def _distributed_table(
    path: Path,
    lines: list[str],
    fraction: str,
    columns: tuple[str, ...],
    units: dict[str, str],
    what: str,
) -> np.ndarray:
    """Columns ``(fraction, *columns)`` of an ElastoDyn distributed-properties table, by name.

    The layout differs across versions (FAST v8 blade files: ``BlFract PitchAxis StrcTwst
    BMassDen FlpStff EdgStff``; OpenFAST: ``BlFract StrcTwst BMassDen FlpStff EdgStff``), so
    columns are found by their header names and their units row is checked (e.g. ``(kg/m)``
    under ``BMassDen``); a table without such a header is refused, never read by position.
    """
    required = (fraction, *columns)
    try:
        cols, rows, head = _header_table(lines, required, path, what)
    except ValueError as exc:
        if "no table header" not in str(exc):
            raise  # a malformed row of a table that was found
        marker = next((i + 1 for i, ln in enumerate(lines) if "DISTRIBUTED" in ln.upper()), None)
        where = f"{path}:{marker}" if marker else str(path)
        raise ValueError(
            f"{where}: {what}: unknown table layout; expected a header row naming "
            f"{', '.join(required)} (any order, other columns allowed) and a units row"
        ) from None
    unit_tok = lines[head].split() if head < len(lines) else []
    for name, unit in units.items():
        k = cols[name.upper()]
        got = unit_tok[k] if k < len(unit_tok) else ""
        if got.lower().strip("()[]") != unit.lower().strip("()[]"):
            raise ValueError(
                f"{path}:{head + 1}: {what}: column {name} has units {got or 'none'!r}; "
                f"expected {unit!r}"
            )
    if not rows:
        raise ValueError(f"{path}:{head}: {what}: no numeric rows after the header")
    out = []
    for number, tok in rows:
        if len(tok) < len(cols):
            raise ValueError(
                f"{path}:{number}: {what}: expected {len(cols)} columns, got {len(tok)}"
            )
        out.append(_row_floats([tok[cols[c.upper()]] for c in required], path, number, what))
    return np.array(out)


def blade_properties(
    path: Path, tip_radius_m: float, hub_radius_m: float
) -> tuple[float, float, float]:
    """(mass kg, CM radius from the apex m, ∫ r² dm about the apex kg m²) of one blade.

    With the ElastoDyn blade table (``BlFract``, ``BMassDen`` found by name,
    :func:`_distributed_table`) and ``AdjBlMs``: r = R_hub + BlFract (R_tip − R_hub),
    μ(r) = AdjBlMs · BMassDen, m = ∫ μ dr (trapezoidal over the stations, as the table is
    piecewise linear), r_cm = ∫ μ r dr / m, J = ∫ μ r² dr.
    """
    values, lines = read_keyed_file(path)
    rows = _distributed_table(
        path, lines, "BlFract", ("BMassDen",), {"BMassDen": "(kg/m)"}, "blade properties"
    )
    adj = _num(values, "AdjBlMs", path, 1.0)
    length = tip_radius_m - hub_radius_m
    r = hub_radius_m + rows[:, 0] * length
    mu = rows[:, 1] * adj
    mass = float(np.trapezoid(mu, r))
    return mass, float(np.trapezoid(mu * r, r)) / mass, float(np.trapezoid(mu * r * r, r))


def _environment(
    key: str, fst: KeyedValues, fst_path: Path, others: list[tuple[KeyedValues, Path]]
) -> float:
    """``Gravity``, ``WtrDens`` or ``WtrDpth`` from wherever the deck's version keeps it.

    OpenFAST ≥ 3.5 keeps them in the ``.fst`` (SeaState's may say ``default``); older decks
    keep ``Gravity`` in ElastoDyn and ``WtrDens``/``WtrDpth`` in HydroDyn. The first numeric
    value in the ``.fst``, then in ``others`` (in order), is used.
    """
    for values, path in [(fst, fst_path), *others]:
        raw = values.get(key.upper())
        if raw is not None and raw.upper() != "DEFAULT":
            return _num(values, key, path)
    places = ", ".join(str(p) for _, p in [(fst, fst_path), *others])
    raise ValueError(f"{key}: expected a number in one of {places}; found none")


#: Default upper end of the radiation fit band (rad/s): below the high-frequency ripple of
#: semi-submersible WAMIT data that no low order follows, above the wave band of interest.
DEFAULT_RADIATION_OMEGA_MAX_RAD_S = 2.0


def import_openfast(
    fst_path: Path,
    turbine: str = "iea15mw",
    name: str | None = None,
    mooring: bool = True,
    radiation_omega_max_rad_s: float = DEFAULT_RADIATION_OMEGA_MAX_RAD_S,
    drop_duplicate_addclin: bool = False,
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
        Solve the mooring tables with MoorPy (default True). False leaves them empty (zero
        mooring force and stiffness): surge and sway then have no restoring stiffness, and
        a note says so; the deck need not have a MoorDyn file (``CompMooring`` any value).
    radiation_omega_max_rad_s : float, optional
        Upper end of the radiation fit band ω_max (rad/s), default
        :data:`DEFAULT_RADIATION_OMEGA_MAX_RAD_S`; 0: the whole band of the WAMIT data.
    drop_duplicate_addclin : bool, optional
        Set to zero the diagonal ``AddCLin`` entries that repeat a restoring the import models
        (:func:`duplicate_add_stiffness`); default False: keep them, with a warning in
        :attr:`ImportedDeck.warnings` and the notes.

    Returns
    -------
    ImportedDeck

    Raises
    ------
    ValueError
        On a missing key or an unsupported deck (message names the file and key).
    """
    fst_path = Path(fst_path)
    if not (radiation_omega_max_rad_s >= 0.0 and math.isfinite(radiation_omega_max_rad_s)):
        raise ValueError(
            f"radiation_omega_max_rad_s: expected >= 0 rad/s, got {radiation_omega_max_rad_s}"
        )
    fst, fst_lines = read_keyed_file(fst_path)
    root = fst_path.parent
    ed_path = root / _text(fst, "EDFile", fst_path)
    hd_path = root / _text(fst, "HydroFile", fst_path)
    md_path = root / _text(fst, "MooringFile", fst_path)
    if mooring and int(_num(fst, "CompMooring", fst_path)) != 3:
        raise ValueError(
            f"{_where(fst, 'CompMooring', fst_path)}: CompMooring = "
            f"{fst.get('COMPMOORING')}; expected 3 (MoorDyn) for the mooring import "
            "(or import without mooring: --no-mooring)"
        )

    ed, _ = read_keyed_file(ed_path)
    hd, hd_lines = read_keyed_file(hd_path)
    others: list[tuple[KeyedValues, Path]] = [(ed, ed_path), (hd, hd_path)]
    sea_name = fst.get("SEASTFILE", "").strip()
    if sea_name and int(_num(fst, "CompSeaSt", fst_path, 0.0)) == 1:
        sea_path = root / sea_name
        others.append((read_keyed_file(sea_path)[0], sea_path))
    g = _environment("Gravity", fst, fst_path, others)
    rho = _environment("WtrDens", fst, fst_path, others)
    depth = _environment("WtrDpth", fst, fst_path, others)
    twr_path = ed_path.parent / _text(ed, "TwrFile", ed_path)
    bld_path = ed_path.parent / _first_text(ed, ("BldFile1", "BldFile(1)"), ed_path)
    for key in ("PtfmRefxt", "PtfmRefzt"):
        if abs(_num(ed, key, ed_path, 0.0)) > 0.0:
            raise ValueError(
                f"{ed_path}: {key} must be 0 (reference point at the still-water line)"
            )
    tw, tw_lines = read_keyed_file(twr_path)
    rows = _distributed_table(
        twr_path,
        tw_lines,
        "HtFract",
        ("TMassDen", "TwFAStif"),
        {"TMassDen": "(kg/m)"},
        "tower properties",
    )
    adj_mass = _num(tw, "AdjTwMa", twr_path, 1.0)
    adj_stiff = _num(tw, "AdjFASt", twr_path, 1.0) * _num(tw, "FAStTunr(1)", twr_path, 1.0)
    shape = [_num(tw, f"TwFAM1Sh({k})", twr_path) for k in range(2, 7)]
    if abs(sum(shape) - 1.0) > 1e-3:
        raise ValueError(f"{twr_path}: TwFAM1Sh coefficients sum to {sum(shape)}, expected 1")

    tip = _num(ed, "TipRad", ed_path)
    hub_r = _num(ed, "HubRad", ed_path)
    blade_mass, blade_r_cm, blade_i = blade_properties(bld_path, tip, hub_r)
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
            # By header name (and units): AeroDyn's tower table gained TwrTI, TwrCb, TwrCp and
            # TwrCa columns over the versions, so its column order is not fixed.
            trows = _distributed_table(
                ad_path,
                ad_lines,
                "TwrElev",
                ("TwrDiam", "TwrCd"),
                {"TwrElev": "(m)", "TwrDiam": "(m)"},
                "tower aerodynamics",
            )
            twr_h = [float(v) for v in trows[:, 0]]
            twr_d = [float(v) for v in trows[:, 1]]
            twr_cd = [float(v) for v in trows[:, 2]]
        if int(_num(fst, "CompInflow", fst_path, 0.0)) == 1:
            ifw_path = root / _text(fst, "InflowFile", fst_path)
            ifw, _ = read_keyed_file(ifw_path)
            shear = _num(ifw, "PLexp", ifw_path, 0.0)

    pot_root = hd_path.parent / _text(hd, "PotFile", hd_path)
    ulen = _num(hd, "WAMITULEN", hd_path, 1.0)
    hydro = import_wamit(pot_root, rho, g, ulen)
    volume = _num(hd, "PtfmVol0", hd_path)
    add_f0 = _vector6(hd_lines, "AddF0", hd_path)
    add_c = _matrix_rows(hd_lines, "AddCLin", hd_path)
    add_b = _matrix_rows(hd_lines, "AddBLin", hd_path)
    add_bq = _matrix_rows(hd_lines, "AddBQuad", hd_path)
    n_members = int(_num(hd, "NMembers", hd_path, 0.0))

    # Platform = ElastoDyn structure + HydroDyn filled-member ballast (OpenFAST adds the
    # ballast's weight and inertia in HydroDyn; ElastoDyn's PtfmMass does not hold it).
    m_s = _num(ed, "PtfmMass", ed_path)
    x_s = _num(ed, "PtfmCMxt", ed_path, 0.0)
    z_s = _num(ed, "PtfmCMzt", ed_path)
    i_s = _num(ed, "PtfmPIner", ed_path)
    ballast = read_fill_groups(hd_path, hd_lines, hd, rho)
    members = read_morison_members(hd_path, hd_lines, hd, rho, g)
    m_p, x_p, z_p, i_p = m_s, x_s, z_s, i_s
    if ballast is not None and ballast.mass_kg > 0.0:
        m_b = ballast.mass_kg
        m_p = m_s + m_b
        x_p = (m_s * x_s + m_b * ballast.cm_x_m) / m_p
        z_p = (m_s * z_s + m_b * ballast.cm_z_m) / m_p
        # Parallel-axis theorem about the combined centre of mass (x_p, z_p).
        i_p = (
            i_s
            + m_s * ((x_s - x_p) ** 2 + (z_s - z_p) ** 2)
            + ballast.pitch_inertia_cm_kg_m2
            + m_b * ((ballast.cm_x_m - x_p) ** 2 + (ballast.cm_z_m - z_p) ** 2)
        )

    duplicates = duplicate_add_stiffness(add_c, ballast, members, g)
    warnings = [d.warning() for d in duplicates]
    stiffness_notes = [_stiffness_budget(i, hydro, members, ballast, add_c, g) for i in (2, 3, 4)]
    if drop_duplicate_addclin and duplicates:
        add_c = [list(row) for row in add_c]
        for d in duplicates:
            for i in d.index:
                add_c[i][i] = 0.0
        warnings = [
            f"dropped {' and '.join(d.entries)} = {d.add_value:.5g} (repeats {d.what} "
            f"{d.modelled_value:.5g}, ratio {d.ratio:.4f}; --drop-duplicate-addclin)"
            for d in duplicates
        ]

    preset = FloatingPreset(
        name=name or (fst_lines[1].strip() if len(fst_lines) > 1 else fst_path.stem),
        turbine=turbine,
        hydro_file="hydro.npz",
        mooring_file="mooring.json",
        gravity_m_s2=g,
        water_density_kg_m3=rho,
        water_depth_m=depth,
        displaced_volume_m3=volume,
        platform_mass_kg=m_p,
        platform_pitch_inertia_kg_m2=i_p,
        platform_cm_x_m=x_p,
        platform_cm_z_m=z_p,
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
        # Radiation fit (write_radiation): orders up to 12 over 0..ω_max.
        member_force_n=members.force_n if members else [],
        member_stiffness=members.stiffness if members else [],
        member_added_mass=members.added_mass if members else [],
        radiation_max_order=12,
        radiation_omega_max_rad_s=radiation_omega_max_rad_s,
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
    budget: list[tuple[str, float]] = [("platform structure (ElastoDyn PtfmMass)", m_s)]
    if ballast is not None:
        budget.append(("ballast (HydroDyn filled members)", ballast.mass_kg))
        notes.append(
            f"ballast {ballast.mass_kg:.6g} kg ({ballast.volume_m3:.6g} m^3 flooded) at "
            f"x {ballast.cm_x_m:.4g} m, z {ballast.cm_z_m:.4g} m; platform with ballast "
            f"{m_p:.6g} kg, CM z {z_p:.4g} m, pitch inertia {i_p:.6g} kg m^2 about its CM"
        )
    budget += [("tower", tm.tower_mass_kg), ("rotor-nacelle assembly", tm.rna_mass_kg)]
    total = sum(v for _, v in budget)
    budget.append(("total", total))
    v_members = members.volume_m3 if members else 0.0
    buoyancy = rho * (volume + v_members)
    notes.append(
        "mass budget: "
        + ", ".join(f"{k} {v:.6g} kg" for k, v in budget)
        + f"; displaced water rho (V0 + V_members) = {rho * volume:.6g} + "
        f"{rho * v_members:.6g} kg, so the mooring and AddF0 must pull down "
        f"{(buoyancy - total) * g:.6g} N at rest"
    )
    notes += stiffness_notes
    notes += [f"warning: {w}" for w in warnings]
    if members is not None:
        a = np.array(members.added_mass)
        notes.append(
            f"strip-theory members: {members.count}, submerged volume {members.volume_m3:.6g} "
            f"m^3 at x {members.cb_x_m:.4g} m, z {members.cb_z_m:.4g} m, waterplane "
            f"{members.waterplane_area_m2:.6g} m^2; restoring C33 "
            f"{members.stiffness[2][2]:.6g} N/m, C55 {members.stiffness[4][4]:.6g} N m/rad; "
            f"added mass surge {a[0, 0]:.6g} kg, heave {a[2, 2]:.6g} kg, pitch "
            f"{a[4, 4]:.6g} kg m^2"
        )
        notes += members.notes
    elif n_members:
        notes.append(
            f"{hd_path}: {n_members} members, all in the potential-flow model (PropPot = TRUE) "
            "or filled; their drag is not modelled (only AddBQuad drag is used)"
        )
    if mooring:
        moor = compute_mooring(
            read_moordyn(md_path), depth, rho, g, source=f"MoorPy from {md_path.name}"
        )
        i0 = moor.surge_m.index(0.0) if 0.0 in moor.surge_m else 0
        k11 = -(moor.force_surge_n[i0 + 1] - moor.force_surge_n[i0 - 1]) / 2.0
        notes.append(f"mooring surge stiffness at zero offset {k11:.4g} N/m")
    else:
        notes.append(
            "imported without mooring: zero mooring force and stiffness (surge has no "
            "restoring stiffness, heave and pitch only the hydrostatic and AddCLin ones)"
        )
        moor = MooringFile(
            source="none",
            surge_m=[-1.0, 1.0],
            force_surge_n=[0.0, 0.0],
            force_heave_n=[0.0, 0.0],
            moment_pitch_nm=[0.0, 0.0],
            stiffness_heave_pitch=[[0.0, 0.0], [0.0, 0.0]],
            stiffness_6x6_at_zero=[[0.0] * 6 for _ in range(6)],
        )
    return ImportedDeck(
        preset=preset,
        hydro=hydro,
        mooring=moor,
        notes=tuple(notes),
        mass_budget=tuple(budget),
        ballast=ballast,
        members=members,
        warnings=tuple(warnings),
    )


#: Relative difference under which an ``AddCLin`` diagonal entry is taken for a repeat of a
#: restoring the importer models (hand-entered decks carry 4-5 significant digits).
DUPLICATE_STIFFNESS_REL_TOL = 0.02


@dataclass(frozen=True)
class DuplicateStiffness:
    """``AddCLin`` diagonal entries that equal a restoring the importer already models.

    ``entries``: OpenFAST's 1-based names (e.g. ``("AddCLin(4,4)", "AddCLin(5,5)")``);
    ``index``: their 0-based DOFs; ``add_value`` and ``modelled_value`` in N/m or N m/rad
    (the first entry's); ``what``: the modelled term.
    """

    entries: tuple[str, ...]
    index: tuple[int, ...]
    add_value: float
    modelled_value: float
    what: str

    @property
    def ratio(self) -> float:
        """``add_value / modelled_value``."""
        return self.add_value / self.modelled_value

    def warning(self) -> str:
        """One line: the entries, both figures, their ratio and the remedy."""
        return (
            f"{' and '.join(self.entries)} = {self.add_value:.5g} equals {self.what} "
            f"{self.modelled_value:.5g} that the import already models (ratio "
            f"{self.ratio:.4f}): that restoring is counted twice; import with "
            "--drop-duplicate-addclin to drop the AddCLin entries"
        )


def duplicate_add_stiffness(
    add_c: list[list[float]],
    ballast: Ballast | None,
    members: MorisonMembers | None,
    g: float,
    rel_tol: float = DUPLICATE_STIFFNESS_REL_TOL,
) -> list[DuplicateStiffness]:
    """Which diagonal ``AddCLin`` entries repeat a restoring the import models (heave, roll, pitch).

    FAST v8-era decks put into ``AddCLin`` what HydroDyn did not compute then: the gravity
    restoring of the ballast water, ``−m_b g z_b`` in roll and pitch, and the strip-theory
    members' hydrostatics. The import models both (the fill groups' ballast enters the
    platform's mass and centre of mass; the members' ``member_stiffness``), so an entry within
    ``rel_tol`` of one of those terms, or of their sum, is a repeat.

    Parameters
    ----------
    add_c : 6x6 list
        ``AddCLin`` (N/m, N m/rad).
    ballast, members
        What the import read (None: none).
    g : float
        Gravity (m/s²).
    rel_tol : float
        Relative tolerance of "equal".

    Returns
    -------
    list of DuplicateStiffness
        One per modelled term found (rows of equal entries grouped).
    """
    terms: dict[int, list[tuple[str, float]]] = {2: [], 3: [], 4: []}
    ballast_k = 0.0
    if ballast is not None and ballast.mass_kg > 0.0:
        ballast_k = -ballast.mass_kg * g * ballast.cm_z_m
        if ballast_k > 0.0:
            for i in (3, 4):
                terms[i].append(("the fill groups' gravity restoring m_b g (-z_b)", ballast_k))
    if members is not None:
        for i in (2, 3, 4):
            k = members.stiffness[i][i]
            if k > 0.0:
                terms[i].append(("the strip-theory members' hydrostatic restoring", k))
                if i in (3, 4) and ballast_k > 0.0:
                    terms[i].append(
                        (
                            "the fill groups' gravity and the members' hydrostatic restoring",
                            ballast_k + k,
                        )
                    )
    found: dict[tuple[str, float], DuplicateStiffness] = {}
    for i, candidates in terms.items():
        value = add_c[i][i]
        for what, k in candidates:
            if value != 0.0 and abs(value - k) <= rel_tol * abs(k):
                key = (what, round(value, 6))
                name = f"AddCLin({i + 1},{i + 1})"
                prev = found.get(key)
                if prev is None:
                    found[key] = DuplicateStiffness((name,), (i,), value, k, what)
                else:
                    found[key] = DuplicateStiffness(
                        (*prev.entries, name), (*prev.index, i), prev.add_value, k, what
                    )
                break
    return list(found.values())


def _stiffness_budget(
    i: int,
    hydro: HydroData,
    members: MorisonMembers | None,
    ballast: Ballast | None,
    add_c: list[list[float]],
    g: float,
) -> str:
    """One note: the restoring terms of DOF ``i`` (0-based) the import adds up, by source."""
    dofs = list(hydro.dofs)
    hst = float(hydro.hydrostatic_stiffness[dofs.index(i), dofs.index(i)]) if i in dofs else 0.0
    gravity = -ballast.mass_kg * g * ballast.cm_z_m if ballast is not None and i > 2 else 0.0
    unit = "N/m" if i < 3 else "N m/rad"
    return (
        f"stiffness budget {('surge', 'sway', 'heave', 'roll', 'pitch', 'yaw')[i]} ({unit}): "
        f"hydrostatic (WAMIT .hst) {hst:.6g}, strip-theory members "
        f"{members.stiffness[i][i] if members is not None else 0.0:.6g}, fill groups' gravity "
        f"m_b g (-z_b) {gravity:.6g}, AddCLin({i + 1},{i + 1}) {add_c[i][i]:.6g}"
    )


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
    options = preset.radiation_fit_options()
    try:
        model = fit_reduced_radiation(
            hydro.radiation,
            **options,
            checked_dofs=(2, 4),
            source=f"Perez-Fossen fits of the WAMIT data of {preset.name!r}, stacked, "
            "reduced by balanced truncation, diagonal kernels made passive with Re K >= 0.5 B "
            "at the data (plant.openfast_import.write_radiation)",
        )
    except ValueError as exc:
        if "stable" not in str(exc):
            raise
        raise ValueError(_radiation_failure(hydro, options, preset)) from exc
    model.save_npz(path)
    return model


_DOF_NAME = {0: "surge", 2: "heave", 4: "pitch"}


def radiation_report(model: RadiationModel) -> list[str]:
    """What the radiation fit chose: order and band, the error of every kernel (each DOF, then
    each DOF pair), and how it was made stable when the plain reduction was not."""
    lines = [f"radiation {line}" for line in (*model.describe(), *model.describe_pairs())]
    how = model.source.partition("; fit: ")[2]
    if how:
        lines.append(f"radiation fit: {how}")
    return lines


def _radiation_failure(
    hydro: HydroData, options: RadiationFitOptions, preset: FloatingPreset
) -> str:
    """Which kernels' fit has unstable poles (each DOF, then each pair), and the remedy."""
    band = options["omega_range_rad_s"]
    band_text = f"0..{band[1]:g} rad/s" if band else "the whole band of the data"
    culprit = "the stacked surge-heave-pitch model"
    candidates: list[tuple[int, ...]] = [(d,) for d in options["dofs"]]
    candidates += [(a, b) for i, a in enumerate(options["dofs"]) for b in options["dofs"][i + 1 :]]
    for dofs in candidates:
        try:
            fit_reduced_radiation(
                hydro.radiation,
                dofs=dofs,
                max_order=options["max_order"],
                tol=options["tol"],
                omega_range_rad_s=options["omega_range_rad_s"],
                checked_dofs=dofs,
            )
        except ValueError:
            culprit = (
                "the "
                + "-".join(_DOF_NAME.get(d, str(d)) for d in dofs)
                + " kernel"
                + ("s" if len(dofs) > 1 else "")
            )
            break
    return (
        f"radiation fit of {preset.name!r} ({culprit}, band {band_text}, orders up to "
        f"{options['max_order']}): the fitted state space has unstable poles; expected stable "
        "poles (Re < 0 1/s). Remedy: narrow the fit band (import with a lower "
        "--radiation-omega-max, e.g. 1.5 rad/s, below the data's high-frequency ripple or "
        "irregular frequencies) or lower radiation_max_order in the preset"
    )


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
    notes = [*deck.notes, *radiation_report(model)]
    header = "".join(f"# {n}\n" for n in notes)
    body = _toml_lines(msgspec.structs.asdict(preset))
    path = out_dir / f"{stem}.toml"
    path.write_text(
        f"# Floating turbine preset written by plant.openfast_import.write_preset\n"
        f"{header}\n{body}",
        encoding="utf-8",
    )
    return path
