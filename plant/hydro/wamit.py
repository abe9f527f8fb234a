"""WAMIT-format hydrodynamic data: readers, dimensional SI containers, npz storage.

WAMIT writes its first-order results non-dimensionally (WAMIT User Manual, "Definitions of
nondimensional quantities"). With ``L`` the length scale ``ULEN``, ``ρ`` the water density and
``g`` the gravitational acceleration, and with ``k = 3 + r``, ``m = 2 + r`` where ``r`` is the
number of rotational indices (4, 5, 6 in WAMIT's 1-based numbering) among the subscripts:

* added mass ``A_ij = Ā_ij ρ L^k`` (kg, kg m, kg m^2),
* radiation damping ``B_ij = B̄_ij ρ ω L^k`` (N s/m, N s, N m s/rad),
* excitation ``X_i = X̄_i ρ g L^m`` per unit wave amplitude (N/m, N m/m), ``m = 2 + r_i``,
* hydrostatic stiffness ``C_ij = C̄_ij ρ g L^m`` (N/m, N, N m/rad), ``m = 2 + r``.

File layouts read here (whitespace-separated, one record a line):

* ``.1``: ``PER I J Ā B̄``; the rows with ``PER = 0`` (zero period, infinite frequency) and
  ``PER < 0`` (WAMIT writes -1: infinite period, zero frequency) carry only ``PER I J Ā``.
  This is the convention of WAMIT and of OpenFAST HydroDyn's WAMIT reader; the VolturnUS-S deck
  confirms it (its ``PER = -1`` surge added mass equals A(0.05 rad/s) within 0.2 %, its
  ``PER = 0`` value the high-frequency plateau).
* ``.3``: ``PER BETA I |X̄| phase Re(X̄) Im(X̄)``, heading ``BETA`` in degrees.
* ``.hst``: ``I J C̄``.

``PER`` is the wave period in seconds, ``ω = 2π/PER``. Entries WAMIT omits are zero.

Phase convention: WAMIT's complex amplitudes multiply ``exp(+iωt)``: the incident wave elevation
at the origin is ``η(t) = Re{a exp(iωt)}`` and the excitation force is
``F_i(t) = Re{a X_i exp(iωt)}``. :class:`ExcitationData` keeps that convention. Data from a
solver that uses ``exp(-iωt)`` (Capytaine, NEMOH) must be conjugated before it is stored here.

DOF indices in this module are 0-based WAMIT modes: 0 surge, 1 sway, 2 heave, 3 roll, 4 pitch,
5 yaw, about the WAMIT body origin.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

ALL_DOFS: tuple[int, ...] = (0, 1, 2, 3, 4, 5)
DOF_NAMES: tuple[str, ...] = ("surge", "sway", "heave", "roll", "pitch", "yaw")
NPZ_FORMAT_VERSION = 1


# ------------------------------------------------------------------------------ validation
def _check_dofs(dofs: tuple[int, ...], what: str) -> None:
    if len(dofs) == 0:
        raise ValueError(f"{what}: dofs must not be empty")
    if len(set(dofs)) != len(dofs):
        raise ValueError(f"{what}: dofs {dofs} repeat an index")
    if any(d not in ALL_DOFS for d in dofs):
        raise ValueError(f"{what}: dofs {dofs} must be 0-based WAMIT modes 0..5")


def _check_array(
    name: str, value: np.ndarray, shape: tuple[int, ...], *, complex_ok: bool = False
) -> None:
    if value.shape != shape:
        raise ValueError(f"{name} has shape {value.shape}, expected {shape}")
    if not complex_ok and np.iscomplexobj(value):
        raise ValueError(f"{name} must be real")
    if not np.all(np.isfinite(value)):
        raise ValueError(f"{name} contains non-finite values")


def _check_omega(name: str, omega: np.ndarray) -> None:
    if omega.ndim != 1 or omega.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D array, got shape {omega.shape}")
    if not np.all(np.isfinite(omega)) or np.any(omega <= 0.0):
        raise ValueError(f"{name} must be finite and > 0 rad/s")
    if np.any(np.diff(omega) <= 0.0):
        raise ValueError(f"{name} must be strictly increasing")


# ------------------------------------------------------------------------------ containers
@dataclass(frozen=True)
class RadiationData:
    """Frequency-dependent radiation coefficients, dimensional SI.

    Parameters
    ----------
    omega_rad_s : (n,) float
        Wave frequencies ω in rad/s, strictly increasing, > 0.
    added_mass : (n, d, d) float
        Added mass A_ij(ω): kg (translation-translation), kg m (mixed), kg m^2 (rotation).
    damping : (n, d, d) float
        Radiation damping B_ij(ω): N s/m, N s (mixed), N m s/rad.
    added_mass_inf : (d, d) float
        Infinite-frequency added mass A_∞, same units as ``added_mass``.
    added_mass_zero : (d, d) float or None
        Zero-frequency added mass A(0), if the data carry it.
    dofs : tuple of int
        0-based WAMIT modes of the rows/columns (default all six).

    Notes
    -----
    The radiation force on the body for velocity ``v`` is, in the frequency domain,
    ``F = -(A(ω) jω + B(ω)) V``; in the time domain (Cummins)
    ``F(t) = -A_∞ v̇(t) - ∫_0^t k(t - τ) v(τ) dτ``.
    """

    omega_rad_s: FloatArray
    added_mass: FloatArray
    damping: FloatArray
    added_mass_inf: FloatArray
    added_mass_zero: FloatArray | None = None
    dofs: tuple[int, ...] = ALL_DOFS

    def __post_init__(self) -> None:
        _check_dofs(self.dofs, "RadiationData")
        _check_omega("RadiationData.omega_rad_s", self.omega_rad_s)
        n, d = self.omega_rad_s.size, len(self.dofs)
        _check_array("RadiationData.added_mass", self.added_mass, (n, d, d))
        _check_array("RadiationData.damping", self.damping, (n, d, d))
        _check_array("RadiationData.added_mass_inf", self.added_mass_inf, (d, d))
        if self.added_mass_zero is not None:
            _check_array("RadiationData.added_mass_zero", self.added_mass_zero, (d, d))

    def select(self, dofs: Sequence[int]) -> RadiationData:
        """Restrict to the given 0-based WAMIT modes (a subset of ``self.dofs``, any order)."""
        idx = _dof_positions(self.dofs, dofs, "RadiationData.select")
        sub = np.ix_(idx, idx)
        return RadiationData(
            omega_rad_s=self.omega_rad_s.copy(),
            added_mass=self.added_mass[:, idx][:, :, idx].copy(),
            damping=self.damping[:, idx][:, :, idx].copy(),
            added_mass_inf=self.added_mass_inf[sub].copy(),
            added_mass_zero=None if self.added_mass_zero is None else self.added_mass_zero[sub],
            dofs=tuple(int(d) for d in dofs),
        )


@dataclass(frozen=True)
class ExcitationData:
    """First-order wave excitation per unit wave amplitude, dimensional SI.

    Parameters
    ----------
    omega_rad_s : (n,) float
        Wave frequencies ω in rad/s, strictly increasing, > 0.
    heading_deg : (m,) float
        Wave headings β in degrees (direction of propagation, WAMIT convention), increasing.
    force : (n, m, d) complex
        Excitation X_i(ω, β) per unit wave amplitude: N/m (forces), N m/m (moments). Convention
        ``exp(+iωt)``: for the wave ``η(t) = Re{a e^{iωt}}`` at the origin,
        ``F_i(t) = Re{a X_i e^{iωt}}``.
    dofs : tuple of int
        0-based WAMIT modes of the last axis.
    """

    omega_rad_s: FloatArray
    heading_deg: FloatArray
    force: ComplexArray
    dofs: tuple[int, ...] = ALL_DOFS

    def __post_init__(self) -> None:
        _check_dofs(self.dofs, "ExcitationData")
        _check_omega("ExcitationData.omega_rad_s", self.omega_rad_s)
        h = self.heading_deg
        if h.ndim != 1 or h.size == 0 or not np.all(np.isfinite(h)):
            raise ValueError("ExcitationData.heading_deg must be a finite non-empty 1-D array")
        if np.any(np.diff(h) <= 0.0):
            raise ValueError("ExcitationData.heading_deg must be strictly increasing")
        shape = (self.omega_rad_s.size, h.size, len(self.dofs))
        _check_array("ExcitationData.force", self.force, shape, complex_ok=True)

    def select(self, dofs: Sequence[int], heading_deg: float | None = None) -> ExcitationData:
        """Restrict to the given modes and, if ``heading_deg`` is given, the nearest heading.

        The heading distance is measured on the circle (350° is 10° from 0°).
        """
        idx = _dof_positions(self.dofs, dofs, "ExcitationData.select")
        if heading_deg is None:
            hsel = np.arange(self.heading_deg.size)
        else:
            diff = np.abs((self.heading_deg - heading_deg + 180.0) % 360.0 - 180.0)
            hsel = np.array([int(np.argmin(diff))])
        return ExcitationData(
            omega_rad_s=self.omega_rad_s.copy(),
            heading_deg=self.heading_deg[hsel].copy(),
            force=self.force[:, hsel][:, :, idx].copy(),
            dofs=tuple(int(d) for d in dofs),
        )


def _dof_positions(have: tuple[int, ...], want: Sequence[int], what: str) -> list[int]:
    want_t = tuple(int(d) for d in want)
    _check_dofs(want_t, what)
    missing = [d for d in want_t if d not in have]
    if missing:
        raise ValueError(f"{what}: dofs {missing} not in the data (has {have})")
    return [have.index(d) for d in want_t]


@dataclass(frozen=True)
class HydroData:
    """Radiation, excitation and hydrostatics of one body, dimensional SI.

    Parameters
    ----------
    radiation : RadiationData
    excitation : ExcitationData
    hydrostatic_stiffness : (d, d) float
        Hydrostatic restoring C_ij: N/m, N (mixed), N m/rad. As WAMIT writes it (buoyancy and
        waterplane only unless the WAMIT run included the body's weight).
    rho_kg_m3 : float
        Water density used to dimensionalise the data.
    g_m_s2 : float
        Gravitational acceleration used to dimensionalise the data.
    """

    radiation: RadiationData
    excitation: ExcitationData
    hydrostatic_stiffness: FloatArray
    rho_kg_m3: float
    g_m_s2: float
    dofs: tuple[int, ...] = field(init=False)

    def __post_init__(self) -> None:
        if self.radiation.dofs != self.excitation.dofs:
            raise ValueError(
                f"HydroData: radiation dofs {self.radiation.dofs} differ from "
                f"excitation dofs {self.excitation.dofs}"
            )
        d = len(self.radiation.dofs)
        _check_array("HydroData.hydrostatic_stiffness", self.hydrostatic_stiffness, (d, d))
        for name, val in (("rho_kg_m3", self.rho_kg_m3), ("g_m_s2", self.g_m_s2)):
            if not (np.isfinite(val) and val > 0.0):
                raise ValueError(f"HydroData.{name} must be finite and > 0, got {val}")
        object.__setattr__(self, "dofs", self.radiation.dofs)

    def select(self, dofs: Sequence[int], heading_deg: float | None = 0.0) -> HydroData:
        """Restrict to 0-based WAMIT modes ``dofs`` (e.g. ``(0, 2, 4)`` surge, heave, pitch).

        Parameters
        ----------
        dofs : sequence of int
            Subset of ``self.dofs``, in the order wanted.
        heading_deg : float or None
            Keep only the excitation heading nearest to this (degrees); None keeps all.
        """
        idx = _dof_positions(self.dofs, dofs, "HydroData.select")
        return HydroData(
            radiation=self.radiation.select(dofs),
            excitation=self.excitation.select(dofs, heading_deg),
            hydrostatic_stiffness=self.hydrostatic_stiffness[np.ix_(idx, idx)].copy(),
            rho_kg_m3=self.rho_kg_m3,
            g_m_s2=self.g_m_s2,
        )

    # -------------------------------------------------------------------------- npz I/O
    def save_npz(self, path: str | Path) -> None:
        """Write plain numeric arrays to ``path`` (``np.savez_compressed``, no pickles)."""
        rad, exc = self.radiation, self.excitation
        arrays: dict[str, np.ndarray] = {
            "format_version": np.array(NPZ_FORMAT_VERSION),
            "dofs": np.array(self.dofs, dtype=np.int64),
            "rho_kg_m3": np.array(self.rho_kg_m3),
            "g_m_s2": np.array(self.g_m_s2),
            "radiation_omega_rad_s": rad.omega_rad_s,
            "added_mass": rad.added_mass,
            "damping": rad.damping,
            "added_mass_inf": rad.added_mass_inf,
            "excitation_omega_rad_s": exc.omega_rad_s,
            "heading_deg": exc.heading_deg,
            "excitation_re": exc.force.real,
            "excitation_im": exc.force.imag,
            "hydrostatic_stiffness": self.hydrostatic_stiffness,
        }
        if rad.added_mass_zero is not None:
            arrays["added_mass_zero"] = rad.added_mass_zero
        np.savez_compressed(Path(path), **arrays)  # type: ignore[arg-type]

    @classmethod
    def load_npz(cls, path: str | Path) -> HydroData:
        """Read a file written by :meth:`save_npz` (``allow_pickle=False``)."""
        with np.load(Path(path), allow_pickle=False) as z:
            return _hydro_from_npz(dict(z.items()), str(path))


def _hydro_from_npz(z: dict[str, np.ndarray], source: str) -> HydroData:
    try:
        version = int(z["format_version"])
        if version != NPZ_FORMAT_VERSION:
            raise ValueError(f"{source}: npz format_version {version} not supported")
        dofs = tuple(int(d) for d in z["dofs"])
        f64 = np.float64
        radiation = RadiationData(
            omega_rad_s=np.asarray(z["radiation_omega_rad_s"], f64),
            added_mass=np.asarray(z["added_mass"], f64),
            damping=np.asarray(z["damping"], f64),
            added_mass_inf=np.asarray(z["added_mass_inf"], f64),
            added_mass_zero=(
                np.asarray(z["added_mass_zero"], f64) if "added_mass_zero" in z else None
            ),
            dofs=dofs,
        )
        excitation = ExcitationData(
            omega_rad_s=np.asarray(z["excitation_omega_rad_s"], f64),
            heading_deg=np.asarray(z["heading_deg"], f64),
            force=np.asarray(z["excitation_re"], f64) + 1j * np.asarray(z["excitation_im"], f64),
            dofs=dofs,
        )
        return HydroData(
            radiation=radiation,
            excitation=excitation,
            hydrostatic_stiffness=np.asarray(z["hydrostatic_stiffness"], f64),
            rho_kg_m3=float(z["rho_kg_m3"]),
            g_m_s2=float(z["g_m_s2"]),
        )
    except KeyError as exc:
        raise ValueError(f"{source}: npz lacks array {exc}") from None


def load_hydro_preset(name: str) -> HydroData:
    """Load a shipped data set from ``plant/presets/hydro/<name>.npz``.

    Shipped: ``"iea15mw_volturnus"`` (IEA 15 MW on UMaine VolturnUS-S, 6 DOF, all headings) and
    ``"nrel5mw_tlp_buoy"`` (the R 4.75 m, T 30 m TLP buoy at 100 m depth, surge only, from the
    reference CSV) and ``"nrel5mw_tlp_buoy_bem"`` (the same buoy computed by
    :mod:`plant.hydro.bem`, the data of the ``nrel5mw_tlp`` floating preset). Sources:
    ``plant/presets/hydro/README.md``.
    """
    ref = resources.files("plant.presets.hydro") / f"{name}.npz"
    if not ref.is_file():
        raise ValueError(f"no shipped hydrodynamic preset {name!r}")
    with resources.as_file(ref) as path:
        return HydroData.load_npz(path)


# ------------------------------------------------------------------------------ readers
def _numeric_rows(path: Path, ncols: tuple[int, ...]) -> list[tuple[int, list[float]]]:
    """Parse ``path`` into ``(line number, values)``, each line having a count in ``ncols``."""
    try:
        text = path.read_text(encoding="ascii", errors="strict")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not an ASCII WAMIT file ({exc})") from None
    rows: list[tuple[int, list[float]]] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        tokens = line.split()
        if not tokens:
            continue
        if len(tokens) not in ncols:
            raise ValueError(
                f"{path}:{lineno}: expected {' or '.join(map(str, ncols))} columns, "
                f"got {len(tokens)}: {line.strip()!r}"
            )
        try:
            values = [float(t.replace("D", "E").replace("d", "e")) for t in tokens]
        except ValueError:
            raise ValueError(f"{path}:{lineno}: non-numeric field in {line.strip()!r}") from None
        if not all(np.isfinite(values)):
            raise ValueError(f"{path}:{lineno}: non-finite value in {line.strip()!r}")
        rows.append((lineno, values))
    if not rows:
        raise ValueError(f"{path}: no data lines")
    return rows


def _mode(path: Path, lineno: int, value: float) -> int:
    """0-based mode from a 1-based WAMIT index field."""
    if value != round(value) or not 1 <= value <= 6:
        raise ValueError(
            f"{path}:{lineno}: mode index {value:g} not in 1..6 (multi-body files unsupported)"
        )
    return round(value) - 1


def _n_rot(*modes: int) -> int:
    return sum(1 for m in modes if m >= 3)


def read_wamit_1(path: str | Path, rho: float = 1025.0, ulen: float = 1.0) -> RadiationData:
    """Read a WAMIT ``.1`` file (added mass and radiation damping) into SI units.

    Parameters
    ----------
    path : str or Path
        The ``.1`` file.
    rho : float
        Water density ρ in kg/m^3.
    ulen : float
        WAMIT length scale ``ULEN`` in m.

    Returns
    -------
    RadiationData
        ``A_ij = Ā_ij ρ L^k``, ``B_ij = B̄_ij ρ ω L^k`` with ``k = 3 + (number of rotational
        indices)``, frequencies ``ω = 2π/PER`` sorted increasing. ``PER = 0`` rows (zero period,
        infinite frequency) give ``added_mass_inf`` (required), ``PER < 0`` rows (infinite
        period, zero frequency) ``added_mass_zero`` (optional).

    Raises
    ------
    ValueError
        On a malformed line (file and line named), a duplicate entry, or missing ``PER = 0``.
    """
    path = Path(path)
    _check_scales(rho, 1.0, ulen)
    rows = _numeric_rows(path, (4, 5))
    inf = np.zeros((6, 6))
    zero = np.zeros((6, 6))
    have_inf = have_zero = False
    per_entries: dict[float, dict[tuple[int, int], tuple[float, float]]] = {}
    seen: set[tuple[float, int, int]] = set()
    for lineno, vals in rows:
        per = vals[0]
        i, j = _mode(path, lineno, vals[1]), _mode(path, lineno, vals[2])
        key = (per, i, j)
        if key in seen:
            raise ValueError(f"{path}:{lineno}: duplicate entry PER={per:g} I={i + 1} J={j + 1}")
        seen.add(key)
        scale = rho * ulen ** (3 + _n_rot(i, j))
        if per == 0.0:  # zero period: infinite frequency
            inf[i, j], have_inf = vals[3] * scale, True
        elif per < 0.0:  # negative period: infinite period, zero frequency
            zero[i, j], have_zero = vals[3] * scale, True
        else:
            if len(vals) != 5:
                raise ValueError(f"{path}:{lineno}: period {per:g} s row needs 5 columns")
            per_entries.setdefault(per, {})[(i, j)] = (vals[3], vals[4])
    if not have_inf:
        raise ValueError(f"{path}: no PER = 0 rows (infinite-frequency added mass)")
    if not per_entries:
        raise ValueError(f"{path}: no finite-period rows")
    periods = sorted(per_entries, reverse=True)  # increasing frequency
    omega = 2.0 * np.pi / np.array(periods)
    n = len(periods)
    added = np.zeros((n, 6, 6))
    damping = np.zeros((n, 6, 6))
    for k, per in enumerate(periods):
        for (i, j), (a_nd, b_nd) in per_entries[per].items():
            scale = rho * ulen ** (3 + _n_rot(i, j))
            added[k, i, j] = a_nd * scale
            damping[k, i, j] = b_nd * scale * omega[k]
    return RadiationData(
        omega_rad_s=omega,
        added_mass=added,
        damping=damping,
        added_mass_inf=inf,
        added_mass_zero=zero if have_zero else None,
    )


def read_wamit_3(
    path: str | Path, rho: float = 1025.0, g: float = 9.81, ulen: float = 1.0
) -> ExcitationData:
    """Read a WAMIT ``.3`` file (first-order excitation, Haskind or diffraction) into SI units.

    Parameters
    ----------
    path : str or Path
        The ``.3`` file.
    rho, g, ulen : float
        Water density (kg/m^3), gravity (m/s^2), WAMIT length scale (m).

    Returns
    -------
    ExcitationData
        ``X_i = (Re X̄_i + i Im X̄_i) ρ g L^m`` per unit wave amplitude, ``m = 2`` for forces and
        3 for moments, convention ``exp(+iωt)``. Rows with ``PER <= 0`` are skipped (no
        excitation is defined there). Modes WAMIT omits are zero.

    Raises
    ------
    ValueError
        On a malformed line, a duplicate entry, or a (period, heading) grid with holes.
    """
    path = Path(path)
    _check_scales(rho, g, ulen)
    rows = _numeric_rows(path, (7,))
    entries: dict[tuple[float, float], dict[int, complex]] = {}
    for lineno, vals in rows:
        per, beta = vals[0], vals[1]
        i = _mode(path, lineno, vals[2])
        if per <= 0.0:
            continue
        slot = entries.setdefault((per, beta), {})
        if i in slot:
            raise ValueError(
                f"{path}:{lineno}: duplicate entry PER={per:g} BETA={beta:g} I={i + 1}"
            )
        slot[i] = complex(vals[5], vals[6]) * rho * g * ulen ** (2 + _n_rot(i))
    if not entries:
        raise ValueError(f"{path}: no finite-period rows")
    periods = sorted({p for p, _ in entries}, reverse=True)
    headings = sorted({b for _, b in entries})
    force = np.zeros((len(periods), len(headings), 6), dtype=np.complex128)
    for a, per in enumerate(periods):
        for b, beta in enumerate(headings):
            found = entries.get((per, beta))
            if found is None:
                raise ValueError(f"{path}: no rows for PER={per:g} s, BETA={beta:g} deg")
            for i, x in found.items():
                force[a, b, i] = x
    return ExcitationData(
        omega_rad_s=2.0 * np.pi / np.array(periods),
        heading_deg=np.array(headings, dtype=np.float64),
        force=force,
    )


def read_wamit_hst(
    path: str | Path, rho: float = 1025.0, g: float = 9.81, ulen: float = 1.0
) -> FloatArray:
    """Read a WAMIT ``.hst`` file into the (6, 6) hydrostatic stiffness in SI units.

    ``C_ij = C̄_ij ρ g L^m``, ``m = 2 + (number of rotational indices)``: N/m (heave), N (mixed),
    N m/rad (roll, pitch). For a free-floating body ``C_33 = ρ g A_wp``.

    Raises
    ------
    ValueError
        On a malformed line or a duplicate entry.
    """
    path = Path(path)
    _check_scales(rho, g, ulen)
    rows = _numeric_rows(path, (3,))
    stiffness = np.zeros((6, 6))
    seen: set[tuple[int, int]] = set()
    for lineno, vals in rows:
        i, j = _mode(path, lineno, vals[0]), _mode(path, lineno, vals[1])
        if (i, j) in seen:
            raise ValueError(f"{path}:{lineno}: duplicate entry I={i + 1} J={j + 1}")
        seen.add((i, j))
        stiffness[i, j] = vals[2] * rho * g * ulen ** (2 + _n_rot(i, j))
    return stiffness


def _check_scales(rho: float, g: float, ulen: float) -> None:
    for name, val in (("rho", rho), ("g", g), ("ulen", ulen)):
        if not (np.isfinite(val) and val > 0.0):
            raise ValueError(f"{name} must be finite and > 0, got {val}")


def import_wamit(
    prefix: str | Path, rho: float = 1025.0, g: float = 9.81, ulen: float = 1.0
) -> HydroData:
    """Read ``<prefix>.1``, ``<prefix>.3`` and ``<prefix>.hst`` into one :class:`HydroData`.

    This is how ``plant/presets/hydro/iea15mw_volturnus.npz`` was made::

        import_wamit(".../HydroData/IEA-15-240-RWT-UMaineSemi", 1025.0, 9.81, 1.0).save_npz(...)
    """
    prefix = Path(prefix)
    base = str(prefix)
    return HydroData(
        radiation=read_wamit_1(base + ".1", rho, ulen),
        excitation=read_wamit_3(base + ".3", rho, g, ulen),
        hydrostatic_stiffness=read_wamit_hst(base + ".hst", rho, g, ulen),
        rho_kg_m3=float(rho),
        g_m_s2=float(g),
    )


def write_wamit(hydro: HydroData, prefix: str | Path, ulen: float = 1.0) -> None:
    """Write ``<prefix>.1``, ``<prefix>.3`` and ``<prefix>.hst`` from SI data (WAMIT layouts).

    The inverse of :func:`import_wamit` with the data's own ρ and g: every figure is made
    non-dimensional by the scales of the module docstring (``Ā = A / (ρ L^k)``,
    ``B̄ = B / (ρ ω L^k)``, ``X̄ = X / (ρ g L^m)``, ``C̄ = C / (ρ g L^m)``); the ``.1`` file gets
    the ``PER = 0`` rows of ``added_mass_inf`` (and ``PER = -1`` rows of ``added_mass_zero`` when
    present), then one block per period, longest period first; the ``.3`` file the excitation
    per heading, in WAMIT's ``exp(+iωt)`` convention (as stored). Only the data's DOFs are
    written; WAMIT mode indices are 1-based.
    """
    base = str(prefix)
    rho, g = hydro.rho_kg_m3, hydro.g_m_s2
    _check_scales(rho, g, ulen)
    dofs = hydro.dofs
    rad = hydro.radiation

    def rscale(i: int, j: int) -> float:
        return float(rho * ulen ** (3 + _n_rot(i, j)))

    lines: list[str] = []
    if rad.added_mass_zero is not None:
        for a, i in enumerate(dofs):
            for b, j in enumerate(dofs):
                lines.append(
                    f"{-1.0: .6E} {i + 1:5d} {j + 1:5d} "
                    f"{rad.added_mass_zero[a, b] / rscale(i, j): .6E}"
                )
    for a, i in enumerate(dofs):
        for b, j in enumerate(dofs):
            lines.append(
                f"{0.0: .6E} {i + 1:5d} {j + 1:5d} {rad.added_mass_inf[a, b] / rscale(i, j): .6E}"
            )
    for k in range(rad.omega_rad_s.size):
        w = float(rad.omega_rad_s[k])
        per = 2.0 * np.pi / w
        for a, i in enumerate(dofs):
            for b, j in enumerate(dofs):
                s = rscale(i, j)
                lines.append(
                    f"{per: .6E} {i + 1:5d} {j + 1:5d} {rad.added_mass[k, a, b] / s: .6E} "
                    f"{rad.damping[k, a, b] / (s * w): .6E}"
                )
    Path(base + ".1").write_text("\n".join(lines) + "\n", encoding="ascii")
    exc = hydro.excitation
    lines = []
    for k in range(exc.omega_rad_s.size):
        per = 2.0 * np.pi / float(exc.omega_rad_s[k])
        for h, beta in enumerate(exc.heading_deg):
            for a, i in enumerate(dofs):
                x = complex(exc.force[k, h, a]) / (rho * g * ulen ** (2 + _n_rot(i)))
                lines.append(
                    f"{per: .6E} {float(beta): .6E} {i + 1:5d} {abs(x): .6E} "
                    f"{np.degrees(np.angle(x)): .6E} {x.real: .6E} {x.imag: .6E}"
                )
    Path(base + ".3").write_text("\n".join(lines) + "\n", encoding="ascii")
    lines = []
    for a, i in enumerate(dofs):
        for b, j in enumerate(dofs):
            c = hydro.hydrostatic_stiffness[a, b] / (rho * g * ulen ** (2 + _n_rot(i, j)))
            lines.append(f"{i + 1:5d} {j + 1:5d} {c: .6E}")
    Path(base + ".hst").write_text("\n".join(lines) + "\n", encoding="ascii")
