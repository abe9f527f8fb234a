"""Rigid-drivetrain wind turbine with quasi-steady rotor aerodynamics and lagged actuators.

State, input and dynamics (all SI, angles in rad)::

    x = (ω, θ, T_g)     rotor speed (rad/s, LSS), collective blade pitch (rad),
                        generator torque (N m, HSS)
    u = (θ_c, T_c, U)   pitch demand (rad), generator-torque demand (N m, HSS),
                        rotor-effective wind speed relative to the rotor (m/s)

    J dω/dt   = T_a − N T_g,          T_a = ½ ρ π R³ U² Cq(λ, θ),  λ = ω R / U
    dθ/dt     = clip((clip(θ_c, θ_min, θ_max) − θ) / τ_θ, −θ'_max, θ'_max)
    dT_g/dt   = clip((clip(T_c, 0, T_max) − T_g) / τ_T, −T'_max, T'_max)

with J the drivetrain inertia about the low-speed shaft and N the gearbox ratio. For U below
``WIND_MIN_M_S`` the aerodynamic torque and thrust are taken as zero (their limit as U → 0),
and a negative rotor speed is treated as zero in λ, so ``f`` never divides by zero and never
returns NaN for finite inputs.

What is hand-written here and why
---------------------------------
The right-hand side ``f`` is evaluated four times per RK4 step inside the real-time loop, so it
is written on plain Python floats (no numpy: one numpy scalar operation costs more than the
whole function) with the constant products precomputed once in :class:`TurbineParams`. The
preset loader is a thin layer over ``msgspec.toml`` (strict schema, unknown keys rejected);
``python-control`` style ``f(t, x, u, params)`` keeps the model usable by offline tools.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import NamedTuple

import msgspec

from plant.aero import PerformanceTable, parse_rosco_table, read_rosco_table

__all__ = [
    "WIND_MIN_M_S",
    "TurbineOutputs",
    "TurbineParams",
    "available_presets",
    "f",
    "load_turbine",
    "optimal_torque_gain",
    "outputs",
    "steady_rotor_speed",
]

#: Below this rotor-effective wind speed (m/s) the rotor loads are taken as zero.
WIND_MIN_M_S = 1.0e-3

State = tuple[float, float, float]
Input = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class TurbineParams:
    """Rotor, drivetrain, generator and actuator parameters of one turbine (SI units).

    Parameters
    ----------
    name : str
        Human-readable name.
    rotor_radius_m : float
        Rotor radius R (m), 1..300.
    hub_height_m : float
        Hub height above the still water level or ground (m), > 0.
    air_density_kg_m3 : float
        Air density ρ (kg/m³), 0.5..2.
    drivetrain_inertia_kg_m2 : float
        Drivetrain inertia J about the low-speed shaft, rotor + generator·N² (kg m²), > 0.
    gearbox_ratio : float
        Gearbox ratio N = generator speed / rotor speed (-), >= 1.
    generator_efficiency : float
        Electrical / mechanical power η (fraction, not %), in (0, 1].
    rated_power_w : float
        Rated electrical power (W), > 0.
    rated_rotor_speed_rad_s : float
        Rated rotor (LSS) speed (rad/s), in (0, 10).
    pitch_min_rad, pitch_max_rad : float
        Blade pitch position limits (rad), within ±π/2, min < max.
    pitch_rate_max_rad_s : float
        Pitch rate limit (rad/s), in (0, π].
    pitch_time_constant_s : float
        First-order pitch actuator time constant τ_θ (s), > 0.
    torque_max_nm : float
        Generator torque limit on the high-speed shaft (N m), > 0.
    torque_rate_max_nm_s : float
        Generator torque rate limit (N m/s), > 0.
    torque_time_constant_s : float
        First-order torque actuator time constant τ_T (s), > 0.
    table : PerformanceTable
        Cp, Ct, Cq of the rotor.
    """

    name: str
    rotor_radius_m: float
    hub_height_m: float
    air_density_kg_m3: float
    drivetrain_inertia_kg_m2: float
    gearbox_ratio: float
    generator_efficiency: float
    rated_power_w: float
    rated_rotor_speed_rad_s: float
    pitch_min_rad: float
    pitch_max_rad: float
    pitch_rate_max_rad_s: float
    pitch_time_constant_s: float
    torque_max_nm: float
    torque_rate_max_nm_s: float
    torque_time_constant_s: float
    table: PerformanceTable
    # Precomputed for f(): ½ρπR³, ½ρπR², 1/J, 1/τ_θ, 1/τ_T.
    k_torque: float = field(init=False, repr=False, compare=False)
    k_thrust: float = field(init=False, repr=False, compare=False)
    inv_inertia: float = field(init=False, repr=False, compare=False)
    inv_pitch_tau: float = field(init=False, repr=False, compare=False)
    inv_torque_tau: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        checks: list[tuple[str, str, float, float, bool]] = [
            # field, unit text, lower bound, upper bound, lower bound inclusive
            ("rotor_radius_m", "m", 1.0, 300.0, True),
            ("hub_height_m", "m", 0.0, 1000.0, False),
            ("air_density_kg_m3", "kg/m^3", 0.5, 2.0, True),
            ("drivetrain_inertia_kg_m2", "kg m^2 about the LSS", 0.0, math.inf, False),
            ("gearbox_ratio", "- (generator speed / rotor speed)", 1.0, 1000.0, True),
            ("generator_efficiency", "fraction in (0, 1], not %", 0.0, 1.0, False),
            ("rated_power_w", "W (electrical)", 0.0, 1e9, False),
            ("rated_rotor_speed_rad_s", "rad/s (not rpm)", 0.0, 10.0, False),
            ("pitch_min_rad", "rad (not deg)", -math.pi / 2, math.pi / 2, True),
            ("pitch_max_rad", "rad (not deg)", -math.pi / 2, math.pi / 2, True),
            ("pitch_rate_max_rad_s", "rad/s (not deg/s)", 0.0, math.pi, False),
            ("pitch_time_constant_s", "s", 0.0, 100.0, False),
            ("torque_max_nm", "N m on the HSS", 0.0, math.inf, False),
            ("torque_rate_max_nm_s", "N m/s on the HSS", 0.0, math.inf, False),
            ("torque_time_constant_s", "s", 0.0, 100.0, False),
        ]
        set_ = object.__setattr__
        for name, unit, lo, hi, lo_inclusive in checks:
            raw = getattr(self, name)
            if isinstance(raw, bool) or not isinstance(raw, int | float):
                raise ValueError(
                    f"TurbineParams.{name}: expected a number in {unit}, got {type(raw).__name__}"
                )
            value = float(raw)
            ok_lo = value >= lo if lo_inclusive else value > lo
            if not (math.isfinite(value) and ok_lo and value <= hi):
                lo_txt = f"{'>=' if lo_inclusive else '>'} {lo:g}"
                hi_txt = "" if math.isinf(hi) else f" and <= {hi:g}"
                raise ValueError(
                    f"TurbineParams.{name} = {raw!r}: expected a finite value in {unit}, "
                    f"{lo_txt}{hi_txt}"
                )
            set_(self, name, value)
        if self.pitch_min_rad >= self.pitch_max_rad:
            raise ValueError(
                f"TurbineParams.pitch_min_rad ({self.pitch_min_rad}) must be below "
                f"pitch_max_rad ({self.pitch_max_rad}) (both rad)"
            )
        if not isinstance(self.table, PerformanceTable):
            raise ValueError(
                f"TurbineParams.table: expected a PerformanceTable, got {type(self.table).__name__}"
            )
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError("TurbineParams.name: expected a non-empty string")
        half_rho_pi = 0.5 * self.air_density_kg_m3 * math.pi
        set_(self, "k_torque", half_rho_pi * self.rotor_radius_m**3)
        set_(self, "k_thrust", half_rho_pi * self.rotor_radius_m**2)
        set_(self, "inv_inertia", 1.0 / self.drivetrain_inertia_kg_m2)
        set_(self, "inv_pitch_tau", 1.0 / self.pitch_time_constant_s)
        set_(self, "inv_torque_tau", 1.0 / self.torque_time_constant_s)


class TurbineOutputs(NamedTuple):
    """Algebraic outputs of the turbine at one instant (SI units).

    Attributes
    ----------
    aero_torque_nm : float
        Aerodynamic rotor torque T_a = ½ ρ π R³ U² Cq (N m, LSS).
    rotor_thrust_n : float
        Rotor thrust F = ½ ρ π R² U² Ct (N).
    electrical_power_w : float
        P_e = η T_g ω N (W).
    generator_speed_rad_s : float
        ω_g = N ω (rad/s, HSS).
    tip_speed_ratio : float
        λ = ω R / U (-), 0 when U < ``WIND_MIN_M_S``.
    cp, ct : float
        Power and thrust coefficients at (λ, θ) (-), 0 when U < ``WIND_MIN_M_S``.
    aero_power_w : float
        Aerodynamic power T_a ω (W).
    """

    aero_torque_nm: float
    rotor_thrust_n: float
    electrical_power_w: float
    generator_speed_rad_s: float
    tip_speed_ratio: float
    cp: float
    ct: float
    aero_power_w: float


def f(t: float, x: State, u: Input, params: TurbineParams) -> State:
    """Time derivative of the turbine state (see the module docstring for the equations).

    J dω/dt = ½ρπR³U²Cq(ωR/U, θ) − N T_g;
    dθ/dt = clip((clip(θ_c, θ_min, θ_max) − θ)/τ_θ, ±θ'_max);
    dT_g/dt = clip((clip(T_c, 0, T_max) − T_g)/τ_T, ±T'_max).

    Parameters
    ----------
    t : float
        Time (s); unused (the model is time-invariant), kept for the ``f(t, x, u, p)`` form.
    x : tuple of float
        (rotor speed ω rad/s, blade pitch θ rad, generator torque T_g N m HSS).
    u : tuple of float
        (pitch demand θ_c rad, torque demand T_c N m HSS, rotor-effective wind U m/s).
    params : TurbineParams

    Returns
    -------
    tuple of float
        (dω/dt rad/s², dθ/dt rad/s, dT_g/dt N m/s).
    """
    omega, theta, torque = x
    theta_cmd, torque_cmd, wind = u
    p = params
    if wind > WIND_MIN_M_S:
        tsr = (omega if omega > 0.0 else 0.0) * p.rotor_radius_m / wind
        t_aero = p.k_torque * wind * wind * p.table.torque_coefficient(tsr, theta)
    else:
        t_aero = 0.0
    d_omega = (t_aero - p.gearbox_ratio * torque) * p.inv_inertia

    d_theta = _actuator_rate(
        theta_cmd, theta, p.pitch_min_rad, p.pitch_max_rad, p.inv_pitch_tau, p.pitch_rate_max_rad_s
    )
    d_torque = _actuator_rate(
        torque_cmd, torque, 0.0, p.torque_max_nm, p.inv_torque_tau, p.torque_rate_max_nm_s
    )
    return (d_omega, d_theta, d_torque)


def _actuator_rate(
    demand: float, position: float, lo: float, hi: float, inv_tau: float, rate_max: float
) -> float:
    """First-order actuator with position and rate limits.

    dy/dt = clip((clip(y_d, lo, hi) - y) / tau, -r_max, r_max), in the actuator's unit per s.
    """
    if demand < lo:
        demand = lo
    elif demand > hi:
        demand = hi
    rate = (demand - position) * inv_tau
    if rate > rate_max:
        return rate_max
    if rate < -rate_max:
        return -rate_max
    return rate


def outputs(t: float, x: State, u: Input, params: TurbineParams) -> TurbineOutputs:
    """Rotor loads, power and operating point at one instant.

    T_a = ½ρπR³U²Cq, F = ½ρπR²U²Ct, P_e = η T_g ω N, ω_g = N ω, λ = ωR/U (ω < 0 taken as 0).

    Parameters
    ----------
    t : float
        Time (s); unused.
    x : tuple of float
        (ω rad/s, θ rad, T_g N m HSS).
    u : tuple of float
        (θ_c rad, T_c N m, U m/s); only U is used.
    params : TurbineParams

    Returns
    -------
    TurbineOutputs
    """
    omega, theta, torque = x
    wind = u[2]
    p = params
    if wind > WIND_MIN_M_S:
        tsr = (omega if omega > 0.0 else 0.0) * p.rotor_radius_m / wind
        cp, ct, cq = p.table.coefficients(tsr, theta)
        u2 = wind * wind
        t_aero = p.k_torque * u2 * cq
        thrust = p.k_thrust * u2 * ct
    else:
        tsr = cp = ct = t_aero = thrust = 0.0
    n = p.gearbox_ratio
    return TurbineOutputs(
        aero_torque_nm=t_aero,
        rotor_thrust_n=thrust,
        electrical_power_w=p.generator_efficiency * torque * omega * n,
        generator_speed_rad_s=omega * n,
        tip_speed_ratio=tsr,
        cp=cp,
        ct=ct,
        aero_power_w=t_aero * omega,
    )


# ---------------------------------------------------------------------- offline helpers
def optimal_torque_gain(params: TurbineParams, pitch_rad: float = 0.0) -> float:
    """Region-2 gain K of the torque law T_g = K ω_g² that holds the optimal tip-speed ratio.

    K = ½ ρ π R⁵ Cp(λ*, θ) / (λ*³ N³)   (N m / (rad/s)², HSS), λ* from
    :meth:`PerformanceTable.optimal_tsr`.

    Parameters
    ----------
    params : TurbineParams
    pitch_rad : float, optional
        Fine pitch θ (rad), default 0.

    Returns
    -------
    float
        K in N m s²/rad² on the high-speed shaft.
    """
    tsr = params.table.optimal_tsr(pitch_rad)
    cp = params.table.coefficients(tsr, pitch_rad)[0]
    r = params.rotor_radius_m
    return params.k_torque * r * r * cp / (tsr**3 * params.gearbox_ratio**3)


def steady_rotor_speed(
    params: TurbineParams,
    wind_m_s: float,
    pitch_rad: float,
    torque_law: Callable[[float], float],
) -> float:
    """Rotor speed at which aerodynamic and generator torque balance (offline use).

    Solves T_a(ω) − N T_g(N ω) = 0 for ω on λ ∈ [λ_min, λ_max] of the table with Brent's
    method, where ``torque_law`` maps generator speed (rad/s, HSS) to generator torque (N m,
    HSS).

    Parameters
    ----------
    params : TurbineParams
    wind_m_s : float
        Steady rotor-effective wind speed U (m/s), > 0.
    pitch_rad : float
        Blade pitch θ (rad).
    torque_law : callable
        T_g = torque_law(ω_g), N m as a function of rad/s.

    Returns
    -------
    float
        Rotor speed ω (rad/s).

    Raises
    ------
    ValueError
        If no balance exists within the table's TSR range.
    """
    from scipy.optimize import brentq  # noqa: PLC0415  offline only: keep plant import light

    if not wind_m_s > WIND_MIN_M_S:
        raise ValueError(f"wind_m_s: expected a positive wind speed in m/s, got {wind_m_s}")
    r, n = params.rotor_radius_m, params.gearbox_ratio
    u = (pitch_rad, 0.0, wind_m_s)

    def residual(omega: float) -> float:
        t_aero = outputs(0.0, (omega, pitch_rad, 0.0), u, params).aero_torque_nm
        return t_aero - n * torque_law(n * omega)

    lo = float(params.table.tsr[0]) * wind_m_s / r
    hi = float(params.table.tsr[-1]) * wind_m_s / r
    r_lo, r_hi = residual(lo), residual(hi)
    if r_lo * r_hi > 0.0:
        raise ValueError(
            f"no torque balance for U = {wind_m_s} m/s, pitch = {pitch_rad} rad within the "
            f"table's TSR range ({lo:.4g}..{hi:.4g} rad/s rotor speed)"
        )
    return float(brentq(residual, lo, hi, xtol=1e-12, rtol=1e-12))


# ---------------------------------------------------------------------- presets
class _TurbineFile(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """Schema of a turbine TOML file: keys carry their units; one of each *_deg/*_rad pair."""

    name: str
    table_file: str
    rotor_radius_m: float
    hub_height_m: float
    air_density_kg_m3: float
    drivetrain_inertia_kg_m2: float
    gearbox_ratio: float
    generator_efficiency: float
    rated_power_w: float
    torque_max_nm: float
    torque_rate_max_nm_s: float
    torque_time_constant_s: float
    pitch_time_constant_s: float
    rated_rotor_speed_rad_s: float | None = None
    rated_rotor_speed_rpm: float | None = None
    pitch_min_rad: float | None = None
    pitch_min_deg: float | None = None
    pitch_max_rad: float | None = None
    pitch_max_deg: float | None = None
    pitch_rate_max_rad_s: float | None = None
    pitch_rate_max_deg_s: float | None = None


_PRESET_PACKAGE = "plant.presets"
_PRESET_PREFIX = "preset:"


def _pick(spec: _TurbineFile, si_key: str, alt_key: str, scale: float, source: str) -> float:
    si = getattr(spec, si_key)
    alt = getattr(spec, alt_key)
    if (si is None) == (alt is None):
        raise ValueError(
            f"{source}: give exactly one of `{si_key}` and `{alt_key}` "
            f"({'both' if si is not None else 'neither'} given)"
        )
    return float(si) if si is not None else float(alt) * scale


def _normalize(name: str) -> str:
    return "".join(ch for ch in name.lower() if ch.isalnum())


def available_presets() -> list[str]:
    """Names of the turbine presets shipped with the package (e.g. ``nrel5mw``).

    Returns
    -------
    list of str
    """
    root = resources.files(_PRESET_PACKAGE)
    return sorted(p.name[: -len(".toml")] for p in root.iterdir() if p.name.endswith(".toml"))


def load_turbine(name_or_path: str | Path) -> TurbineParams:
    """Load a turbine from a shipped preset name or from a user's TOML file.

    A preset name (``"nrel5mw"``, ``"iea15mw"``; case, ``-``, ``_`` and spaces ignored) is read
    from the package data. Any other string or path is a TOML file whose ``table_file`` is
    resolved relative to the TOML's folder, or taken from the shipped presets when written as
    ``"preset:<file>"``. Keys carry their units; angles are given as ``*_deg`` or ``*_rad``,
    the rated speed as ``*_rpm`` or ``*_rad_s`` (converted: rad = deg π/180, rad/s = rpm π/30).

    Parameters
    ----------
    name_or_path : str or Path
        Preset name or path to a ``.toml`` file.

    Returns
    -------
    TurbineParams

    Raises
    ------
    ValueError
        On an unknown preset, an unknown/misspelled/missing key (named in the message), a value
        out of range, or an unreadable table.
    FileNotFoundError
        If the TOML or table file does not exist.
    """
    presets = {_normalize(n): n for n in available_presets()}
    key = _normalize(str(name_or_path))
    is_path = isinstance(name_or_path, Path) or any(
        s in str(name_or_path) for s in ("/", "\\", ".toml")
    )
    root = resources.files(_PRESET_PACKAGE)
    if not is_path and key in presets:
        source = f"preset {presets[key]!r}"
        data = (root / f"{presets[key]}.toml").read_bytes()
        base: Path | None = None
    elif not is_path:
        raise ValueError(
            f"unknown turbine preset {str(name_or_path)!r}; shipped presets: "
            f"{', '.join(available_presets())} (or give a path to a .toml file)"
        )
    else:
        path = Path(name_or_path)
        source = str(path)
        data = path.read_bytes()
        base = path.parent
    try:
        spec = msgspec.toml.decode(data, type=_TurbineFile)
    except msgspec.ValidationError as exc:
        raise ValueError(f"{source}: {exc}") from exc
    except msgspec.DecodeError as exc:
        raise ValueError(f"{source}: not valid TOML ({exc})") from exc

    if base is None or spec.table_file.startswith(_PRESET_PREFIX):
        table_name = spec.table_file.removeprefix(_PRESET_PREFIX)
        resource = root / table_name
        if not resource.is_file():
            raise FileNotFoundError(f"{source}: shipped table {table_name!r} not found")
        table = parse_rosco_table(resource.read_text(encoding="utf-8"), f"preset {table_name}")
    else:
        table = read_rosco_table(base / spec.table_file)

    deg = math.pi / 180.0
    try:
        return TurbineParams(
            name=spec.name,
            rotor_radius_m=spec.rotor_radius_m,
            hub_height_m=spec.hub_height_m,
            air_density_kg_m3=spec.air_density_kg_m3,
            drivetrain_inertia_kg_m2=spec.drivetrain_inertia_kg_m2,
            gearbox_ratio=spec.gearbox_ratio,
            generator_efficiency=spec.generator_efficiency,
            rated_power_w=spec.rated_power_w,
            rated_rotor_speed_rad_s=_pick(
                spec, "rated_rotor_speed_rad_s", "rated_rotor_speed_rpm", math.pi / 30.0, source
            ),
            pitch_min_rad=_pick(spec, "pitch_min_rad", "pitch_min_deg", deg, source),
            pitch_max_rad=_pick(spec, "pitch_max_rad", "pitch_max_deg", deg, source),
            pitch_rate_max_rad_s=_pick(
                spec, "pitch_rate_max_rad_s", "pitch_rate_max_deg_s", deg, source
            ),
            pitch_time_constant_s=spec.pitch_time_constant_s,
            torque_max_nm=spec.torque_max_nm,
            torque_rate_max_nm_s=spec.torque_rate_max_nm_s,
            torque_time_constant_s=spec.torque_time_constant_s,
            table=table,
        )
    except ValueError as exc:
        if str(exc).startswith(source):
            raise
        raise ValueError(f"{source}: {exc}") from exc
