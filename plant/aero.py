"""Rotor performance tables (Cp, Ct, Cq over tip-speed ratio and blade pitch).

A :class:`PerformanceTable` holds the power, thrust and torque coefficients of a rotor on a
rectangular grid of tip-speed ratio (TSR, rows) and collective blade pitch (columns), as the
ROSCO toolbox and OpenFAST decks publish them. The quasi-steady rotor loads follow from

    P = ½ ρ π R² U³ Cp(λ, θ),   T = ½ ρ π R² U² Ct(λ, θ),   Q = ½ ρ π R³ U² Cq(λ, θ),

with λ = ω R / U.

What is hand-written here and why
---------------------------------
* The ROSCO text-format reader and writer (:func:`read_rosco_table`, :func:`write_rosco_table`):
  the only published reader lives inside the ``rosco`` toolbox, which is far too heavy a
  dependency for a file format of six number blocks, and it reads fixed line numbers. Ours
  locates the number blocks between ``#`` comment lines, so any header wording, extra blank lines
  or wrapped rows are accepted, and every inconsistency is a ``ValueError`` naming the file.
* The scalar bilinear lookup (:meth:`PerformanceTable.coefficients`): it runs several times per
  integration step in the real-time loop. ``scipy.interpolate.RegularGridInterpolator`` and
  numpy-based interpolation cost 10-50 us per scalar call in array set-up alone, so the lookup is
  done on plain Python floats with :mod:`bisect` over lists precomputed at construction, with the
  four bilinear coefficients of every grid cell stored ready to use.
* The vectorized helpers (:meth:`PerformanceTable.evaluate`, :meth:`PerformanceTable.cp_max`,
  :meth:`PerformanceTable.optimal_tsr`) are for offline work and use numpy.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

__all__ = [
    "PerformanceTable",
    "format_rosco_table",
    "parse_rosco_table",
    "read_rosco_table",
    "write_rosco_table",
]

FloatArray = npt.NDArray[np.float64]

#: Number of numeric blocks of a complete ROSCO file: pitch, TSR, wind speed, Cp, Ct, Cq.
_N_BLOCKS = 6


def _as_float_array(name: str, value: object, ndim: int) -> FloatArray:
    try:
        arr = np.array(value, dtype=np.float64)  # always a copy: the caller keeps its array
    except (TypeError, ValueError) as exc:
        raise ValueError(f"PerformanceTable.{name}: expected an array of floats ({exc})") from exc
    if arr.ndim != ndim:
        raise ValueError(
            f"PerformanceTable.{name}: expected a {ndim}-D array, got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"PerformanceTable.{name}: contains non-finite values (NaN or inf)")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class PerformanceTable:
    """Rotor power, thrust and torque coefficients on a (TSR, pitch) grid.

    Parameters
    ----------
    pitch_rad : array_like, shape (m,)
        Collective blade pitch angles θ of the matrix columns (rad), strictly increasing,
        at least 2 entries.
    tsr : array_like, shape (n,)
        Tip-speed ratios λ = ω R / U of the matrix rows (-), strictly increasing, at least
        2 entries.
    cp, ct, cq : array_like, shape (n, m)
        Power, thrust and torque coefficients (-): row i is ``tsr[i]``, column j is
        ``pitch_rad[j]``.
    wind_speeds_m_s : tuple of float, optional
        Wind speeds at which the table was computed (m/s); informational only, written back to
        file by :func:`write_rosco_table`.

    Notes
    -----
    All arrays are copied to float64 and made read-only. Equality compares the arrays exactly.
    """

    pitch_rad: FloatArray
    tsr: FloatArray
    cp: FloatArray
    ct: FloatArray
    cq: FloatArray
    wind_speeds_m_s: tuple[float, ...] = ()
    # Precomputed for the hot-path scalar lookup (plain Python objects, see module docstring).
    _tsr_list: list[float] = field(init=False, repr=False, compare=False)
    _pitch_list: list[float] = field(init=False, repr=False, compare=False)
    _cells: list[tuple[float, ...]] = field(init=False, repr=False, compare=False)
    _cq_cells: list[tuple[float, ...]] = field(init=False, repr=False, compare=False)
    #: The same cells as a (cells, 12) array for the compiled kernels (plant._kernels), with the
    #: grids as writable copies (numba compiles read-only arrays as another type).
    _cell_array: FloatArray = field(init=False, repr=False, compare=False)
    _tsr_array: FloatArray = field(init=False, repr=False, compare=False)
    _pitch_array: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        pitch = _as_float_array("pitch_rad", self.pitch_rad, 1)
        tsr = _as_float_array("tsr", self.tsr, 1)
        for name, vec, what in (("pitch_rad", pitch, "pitch angles (rad)"), ("tsr", tsr, "TSR")):
            if vec.size < 2:
                raise ValueError(
                    f"PerformanceTable.{name}: expected at least 2 {what}, got {vec.size}"
                )
            if not np.all(np.diff(vec) > 0.0):
                bad = int(np.argmax(np.diff(vec) <= 0.0))
                raise ValueError(
                    f"PerformanceTable.{name}: expected strictly increasing {what}; "
                    f"entry {bad + 1} ({vec[bad + 1]!r}) does not exceed entry {bad} "
                    f"({vec[bad]!r})"
                )
        if np.max(np.abs(pitch)) > math.pi:
            raise ValueError(
                "PerformanceTable.pitch_rad: values beyond ±π rad; expected radians "
                "(were degrees given?)"
            )
        if tsr[0] < 0.0:
            raise ValueError(f"PerformanceTable.tsr: expected TSR >= 0, got {tsr[0]!r}")
        expected = (tsr.size, pitch.size)
        mats = {}
        for name in ("cp", "ct", "cq"):
            mat = _as_float_array(name, getattr(self, name), 2)
            if mat.shape != expected:
                raise ValueError(
                    f"PerformanceTable.{name}: expected shape {expected} "
                    f"(len(tsr) rows x len(pitch_rad) columns), got {mat.shape}"
                )
            mats[name] = mat
        winds = tuple(float(w) for w in self.wind_speeds_m_s)
        if not all(math.isfinite(w) and w >= 0.0 for w in winds):
            raise ValueError(
                f"PerformanceTable.wind_speeds_m_s: expected finite speeds >= 0 m/s, got {winds}"
            )
        set_ = object.__setattr__
        set_(self, "pitch_rad", pitch)
        set_(self, "tsr", tsr)
        for name, mat in mats.items():
            set_(self, name, mat)
        set_(self, "wind_speeds_m_s", winds)
        set_(self, "_tsr_list", [float(v) for v in tsr])
        set_(self, "_pitch_list", [float(v) for v in pitch])
        cells = _bilinear_cells(tsr, pitch, mats["cp"], mats["ct"], mats["cq"])
        set_(self, "_cells", cells)
        set_(self, "_cq_cells", [c[8:] for c in cells])
        cell_array = np.array(cells, dtype=np.float64).reshape(len(cells), 12)
        set_(self, "_cell_array", cell_array)
        set_(self, "_tsr_array", np.array(tsr, dtype=np.float64))
        set_(self, "_pitch_array", np.array(pitch, dtype=np.float64))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PerformanceTable):
            return NotImplemented
        return (
            self.wind_speeds_m_s == other.wind_speeds_m_s
            and np.array_equal(self.pitch_rad, other.pitch_rad)
            and np.array_equal(self.tsr, other.tsr)
            and np.array_equal(self.cp, other.cp)
            and np.array_equal(self.ct, other.ct)
            and np.array_equal(self.cq, other.cq)
        )

    __hash__ = None  # type: ignore[assignment]  # holds arrays: equal-by-value, not hashable

    # ------------------------------------------------------------------ hot path
    def _cell(self, tsr: float, pitch_rad: float) -> tuple[int, float, float]:
        """Index of the grid cell holding (λ, θ) and the fractions (a, b) inside it, clamped."""
        xs = self._tsr_list
        ys = self._pitch_list
        if tsr <= xs[0]:
            i = 0
            a = 0.0
        elif tsr >= xs[-1]:
            i = len(xs) - 2
            a = 1.0
        else:
            i = bisect_right(xs, tsr) - 1
            x0 = xs[i]
            a = (tsr - x0) / (xs[i + 1] - x0)
        if pitch_rad <= ys[0]:
            j = 0
            b = 0.0
        elif pitch_rad >= ys[-1]:
            j = len(ys) - 2
            b = 1.0
        else:
            j = bisect_right(ys, pitch_rad) - 1
            y0 = ys[j]
            b = (pitch_rad - y0) / (ys[j + 1] - y0)
        return i * (len(ys) - 1) + j, a, b

    def coefficients(self, tsr: float, pitch_rad: float) -> tuple[float, float, float]:
        """Bilinear lookup of (Cp, Ct, Cq) at one operating point, for the real-time loop.

        For λ in cell [λ_i, λ_{i+1}] and θ in [θ_j, θ_{j+1}], with a = (λ - λ_i)/(λ_{i+1} - λ_i)
        and b = (θ - θ_j)/(θ_{j+1} - θ_j),

            C = C_ij (1-a)(1-b) + C_{i+1,j} a (1-b) + C_{i,j+1} (1-a) b + C_{i+1,j+1} a b.

        Inputs outside the grid are clamped to its edge (no extrapolation).

        Parameters
        ----------
        tsr : float
            Tip-speed ratio λ = ω R / U (-).
        pitch_rad : float
            Collective blade pitch θ (rad).

        Returns
        -------
        tuple of float
            (Cp, Ct, Cq), all dimensionless.
        """
        cell, a, b = self._cell(tsr, pitch_rad)
        p0, p1, p2, p3, t0, t1, t2, t3, q0, q1, q2, q3 = self._cells[cell]
        return (
            p0 + a * p1 + b * (p2 + a * p3),
            t0 + a * t1 + b * (t2 + a * t3),
            q0 + a * q1 + b * (q2 + a * q3),
        )

    def torque_coefficient(self, tsr: float, pitch_rad: float) -> float:
        """Bilinear lookup of Cq alone (same interpolation and clamping as :meth:`coefficients`).

        Parameters
        ----------
        tsr : float
            Tip-speed ratio λ (-).
        pitch_rad : float
            Collective blade pitch θ (rad).

        Returns
        -------
        float
            Cq(λ, θ) (-); the aerodynamic torque is Q = ½ ρ π R³ U² Cq.
        """
        cell, a, b = self._cell(tsr, pitch_rad)
        q0, q1, q2, q3 = self._cq_cells[cell]
        return q0 + a * q1 + b * (q2 + a * q3)

    # ------------------------------------------------------------------ offline helpers
    def evaluate(
        self, tsr: npt.ArrayLike, pitch_rad: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Vectorized bilinear lookup of (Cp, Ct, Cq), clamped at the table edges.

        Same interpolation as :meth:`coefficients` (see there for the equation), on broadcast
        numpy arrays; for offline use.

        Parameters
        ----------
        tsr : array_like
            Tip-speed ratios λ (-).
        pitch_rad : array_like
            Blade pitch angles θ (rad), broadcast against ``tsr``.

        Returns
        -------
        tuple of ndarray
            (Cp, Ct, Cq) with the broadcast shape of the inputs (-).
        """
        lam, th = np.broadcast_arrays(
            np.asarray(tsr, dtype=np.float64), np.asarray(pitch_rad, dtype=np.float64)
        )
        i, a = _locate(self.tsr, lam)
        j, b = _locate(self.pitch_rad, th)

        def interp(mat: FloatArray) -> FloatArray:
            out: FloatArray = (
                mat[i, j] * (1.0 - a) * (1.0 - b)
                + mat[i + 1, j] * a * (1.0 - b)
                + mat[i, j + 1] * (1.0 - a) * b
                + mat[i + 1, j + 1] * a * b
            )
            return out

        return interp(self.cp), interp(self.ct), interp(self.cq)

    def cp_max(self) -> tuple[float, float, float]:
        """Largest power coefficient over the grid nodes.

        Returns
        -------
        tuple of float
            (Cp_max (-), λ at Cp_max (-), θ at Cp_max (rad)).
        """
        i, j = np.unravel_index(int(np.argmax(self.cp)), self.cp.shape)
        return float(self.cp[i, j]), float(self.tsr[i]), float(self.pitch_rad[j])

    def optimal_tsr(self, pitch_rad: float = 0.0, resolution: int = 2001) -> float:
        """Tip-speed ratio that maximizes the interpolated power coefficient at a fixed pitch.

        λ* = argmax_λ Cp(λ, θ), searched on ``resolution`` evenly spaced λ over the table range
        (bilinear interpolation, so the maximum lies on a grid row unless θ is between columns).
        ``coefficients(λ*, θ)[0]`` gives the corresponding Cp.

        Parameters
        ----------
        pitch_rad : float, optional
            Blade pitch θ (rad), default 0.
        resolution : int, optional
            Number of λ samples, default 2001.

        Returns
        -------
        float
            λ* (-).
        """
        lam = np.linspace(self.tsr[0], self.tsr[-1], resolution)
        cp, _, _ = self.evaluate(lam, pitch_rad)
        return float(lam[int(np.argmax(cp))])


def _locate(grid: FloatArray, v: FloatArray) -> tuple[npt.NDArray[np.intp], FloatArray]:
    """Cell index and fractional position of each ``v`` in ``grid``, clamped to the grid."""
    vc = np.clip(v, grid[0], grid[-1])
    idx = np.clip(np.searchsorted(grid, vc, side="right") - 1, 0, grid.size - 2)
    frac = (vc - grid[idx]) / (grid[idx + 1] - grid[idx])
    return idx, frac


def _bilinear_cells(
    tsr: FloatArray, pitch: FloatArray, cp: FloatArray, ct: FloatArray, cq: FloatArray
) -> list[tuple[float, ...]]:
    """Per-cell bilinear coefficients (c0, c_a, c_b, c_ab) of Cp, Ct, Cq as Python floats.

    C(a, b) = c0 + a c_a + b (c_b + a c_ab), with c0 = C00, c_a = C10 - C00, c_b = C01 - C00,
    c_ab = C11 - C10 - C01 + C00, cell (i, j) stored at index i (m - 1) + j.
    """
    cells: list[tuple[float, ...]] = []
    for i in range(tsr.size - 1):
        for j in range(pitch.size - 1):
            coeffs: list[float] = []
            for mat in (cp, ct, cq):
                c00 = float(mat[i, j])
                c10 = float(mat[i + 1, j])
                c01 = float(mat[i, j + 1])
                c11 = float(mat[i + 1, j + 1])
                coeffs += [c00, c10 - c00, c01 - c00, c11 - c10 - c01 + c00]
            cells.append(tuple(coeffs))
    return cells


# ---------------------------------------------------------------------- file format
def _numeric_blocks(text: str, source: str) -> list[tuple[int, list[list[float]]]]:
    """Split a ROSCO-format text into number blocks separated by ``#`` comment lines.

    Returns a list of (first line number, rows of floats). Blank lines are ignored.
    """
    blocks: list[tuple[int, list[list[float]]]] = []
    current: list[list[float]] = []
    start = 0
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            if current:
                blocks.append((start, current))
                current = []
            continue
        content = line.split("#", 1)[0].replace(",", " ")
        try:
            row = [float(tok) for tok in content.split()]
        except ValueError:
            raise ValueError(
                f"{source}, line {lineno}: expected numbers or a '#' comment line, "
                f"got {line[:60]!r}"
            ) from None
        if not all(math.isfinite(v) for v in row):
            raise ValueError(f"{source}, line {lineno}: non-finite number (NaN or inf)")
        if not current:
            start = lineno
        current.append(row)
    if current:
        blocks.append((start, current))
    return blocks


def parse_rosco_table(text: str, source: str = "<string>") -> PerformanceTable:
    """Parse the text of a ROSCO-format Cp/Ct/Cq file into a :class:`PerformanceTable`.

    The format is six blocks of numbers, each after one or more ``#`` comment lines: blade
    pitch vector (deg, matrix columns), TSR vector (-, matrix rows), wind speed vector (m/s),
    then the Cp, Ct and Cq matrices (one row per TSR). Header wording, blank lines and line
    breaks inside a block do not matter; a file without the wind-speed vector is accepted.
    Pitch is converted to radians: θ_rad = θ_deg π / 180.

    Parameters
    ----------
    text : str
        File contents.
    source : str, optional
        Name used in error messages (the file path).

    Returns
    -------
    PerformanceTable

    Raises
    ------
    ValueError
        If the text is truncated or inconsistent; the message names ``source``, the block and
        what was expected.
    """
    blocks = _numeric_blocks(text, source)
    names = ["pitch vector", "TSR vector", "wind speed vector", "Cp matrix", "Ct matrix"]
    names.append("Cq matrix")
    if len(blocks) < 2:
        raise ValueError(
            f"{source}: expected {_N_BLOCKS} blocks of numbers separated by '#' comment lines "
            f"(pitch, TSR, wind speed, Cp, Ct, Cq); found {len(blocks)}: not a ROSCO Cp/Ct/Cq "
            f"table, or truncated"
        )
    pitch_deg = [v for row in blocks[0][1] for v in row]
    tsr = [v for row in blocks[1][1] for v in row]
    n_rows, n_cols = len(tsr), len(pitch_deg)
    n_values = n_rows * n_cols

    def count(block: tuple[int, list[list[float]]]) -> int:
        return sum(len(row) for row in block[1])

    if len(blocks) == _N_BLOCKS - 1 and count(blocks[2]) == n_values:
        blocks.insert(2, (0, [[]]))  # no wind-speed vector: the third block is already Cp
    if len(blocks) != _N_BLOCKS:
        found = ", ".join(
            f"{names[k] if k < _N_BLOCKS else 'extra block'} at line {b[0]}"
            for k, b in enumerate(blocks)
        )
        raise ValueError(
            f"{source}: expected {_N_BLOCKS} blocks of numbers separated by '#' comment lines "
            f"(pitch, TSR, wind speed, Cp, Ct, Cq); found {len(blocks)} ({found}) - "
            f"truncated file or a missing/extra comment line?"
        )
    winds = tuple(v for row in blocks[2][1] for v in row)
    mats: list[FloatArray] = []
    for name, (line, rows) in zip(names[3:], blocks[3:], strict=True):
        got = sum(len(r) for r in rows)
        if got != n_values:
            raise ValueError(
                f"{source}: {name} starting at line {line} has {got} values in {len(rows)} "
                f"lines; expected {n_rows} rows (TSR entries) x {n_cols} columns (pitch "
                f"entries) = {n_values} - truncated or inconsistent file?"
            )
        if len(rows) == n_rows:
            for k, r in enumerate(rows):
                if len(r) != n_cols:
                    raise ValueError(
                        f"{source}: {name} row {k + 1} (line {line + k} if no blank lines "
                        f"intervene) has {len(r)} values; expected {n_cols} (one per pitch "
                        f"entry)"
                    )
        mats.append(np.array([v for r in rows for v in r], dtype=np.float64).reshape(n_rows, -1))
    try:
        return PerformanceTable(
            pitch_rad=np.deg2rad(np.array(pitch_deg, dtype=np.float64)),
            tsr=np.array(tsr, dtype=np.float64),
            cp=mats[0],
            ct=mats[1],
            cq=mats[2],
            wind_speeds_m_s=winds,
        )
    except ValueError as exc:
        raise ValueError(f"{source}: {exc}") from exc


def read_rosco_table(path: str | Path) -> PerformanceTable:
    """Read a ROSCO-format Cp/Ct/Cq text file (e.g. ``Cp_Ct_Cq.NREL5MW.txt``).

    See :func:`parse_rosco_table` for the format. Pitch in the file is in degrees; the
    returned table holds radians.

    Parameters
    ----------
    path : str or Path
        File to read (UTF-8 or ASCII text).

    Returns
    -------
    PerformanceTable

    Raises
    ------
    ValueError
        If the file is not a consistent ROSCO table; the message names the file.
    OSError
        If the file cannot be read.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{p}: not a text file ({exc})") from exc
    return parse_rosco_table(text, str(p))


def _fmt(v: float) -> str:
    return repr(float(v))


def format_rosco_table(table: PerformanceTable, title: str) -> str:
    """Render a table in the ROSCO Cp/Ct/Cq text layout with this project's header wording.

    The line layout (two title lines, blank, then comment/number pairs, matrices after a
    comment and a blank line) matches the files ROSCO writes, so tools that read fixed line
    numbers also accept it. Numbers are written with the shortest repr that round-trips;
    pitch is written in degrees, rounded to 1e-9 deg.

    Parameters
    ----------
    table : PerformanceTable
    title : str
        One-line description placed in the first comment line.

    Returns
    -------
    str
    """
    title = " ".join(title.split())
    pitch_deg = [round(float(v), 9) for v in np.rad2deg(table.pitch_rad)]
    m, n = table.pitch_rad.size, table.tsr.size

    def row(values: npt.ArrayLike) -> str:
        return "  ".join(_fmt(v) for v in np.asarray(values, dtype=np.float64).ravel())

    lines = [
        f"# Rotor performance (Cp, Ct, Cq) of {title}",
        "# File written by fowt-hil (plant.aero.write_rosco_table); ROSCO text layout",
        "",
        f"# Blade pitch angle (deg), {m} values: the columns of each matrix below",
        row(pitch_deg),
        f"# Tip-speed ratio (-), {n} values: the rows of each matrix below",
        row(table.tsr),
        "# Wind speed(s) at which the coefficients were computed (m/s)",
        row(table.wind_speeds_m_s),
        "",
    ]
    matrices = (
        ("Power coefficient Cp", table.cp),
        ("Thrust coefficient Ct", table.ct),
        ("Torque coefficient Cq", table.cq),
    )
    for what, data in matrices:
        lines += [f"# {what} (-), {n} rows (TSR) x {m} columns (pitch)", ""]
        lines += [row(r) for r in data]
        lines += ["", ""]
    return "\n".join(lines[:-1])


def write_rosco_table(table: PerformanceTable, path: str | Path, title: str) -> None:
    """Write a table as a ROSCO-format Cp/Ct/Cq text file (see :func:`format_rosco_table`).

    ``read_rosco_table(path)`` returns a table equal to ``table`` (matrices and TSR exactly;
    pitch to within the 1e-9 deg rounding of the degree column).

    Parameters
    ----------
    table : PerformanceTable
    path : str or Path
        Destination file, overwritten.
    title : str
        One-line description of the rotor for the header.
    """
    Path(path).write_text(format_rosco_table(table, title), encoding="utf-8")
