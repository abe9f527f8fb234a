"""Hexicon H3-18MW: three turbines on one platform that yaws freely about its turret.

State, input and dynamics (SI, angles rad, counter-clockwise from above)::

    x = (ψ, r, ω_1, θ_1, T_g1, ω_2, θ_2, T_g2, ω_3, θ_3, T_g3)
        platform heading ψ (rad), yaw rate r = ψ' (rad/s), and per turbine the rotor speed,
        blade pitch and generator torque of :mod:`plant.turbine`
    u = (θ_c1, T_c1, θ_c2, T_c2, θ_c3, T_c3, V, β)
        per-turbine pitch (rad) and HSS torque (N m) demands, free-stream wind speed V (m/s)
        and the direction β the wind comes from (rad)

    I r' + c r |r| = Σ_i T_i (y_i cos e - x_i sin e),   e = β - ψ,   c = ½ ρ_w C_d A r_d³
    turbine i: plant.turbine.f with its rotor-effective wind V_i = V · U_i/U_inf (Jensen)

(ayotte-2015 eq. 5 with the drag written as a moment of the drag force ½ ρ_w C_d A (r_d ψ')²
acting at the lever r_d; no mooring yaw stiffness). The rotors yaw with the wind (the seed's
nacelles track it), so thrust T_i acts along the wind; (x_i, y_i) is turbine i in the
platform frame, x forward. ``e > 0``: the platform lags the wind.

Wakes are quasi-static: the Jensen speed factors are evaluated from the current heading,
direction and each rotor's Ct (upstream rotors first: two passes make a three-rotor chain
exact). One evaluation costs ~20 us (see ``bench/bench_hexicon.py``); FLORIS costs ~ms per
call, so the plant uses our own Jensen code, checked against FLORIS in the tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from plant import turbine as tb
from plant.hexicon.wakes import jensen_speed_factors

__all__ = [
    "N_TURBINES",
    "HexiconOutputs",
    "HexiconParams",
    "f",
    "load_hexicon",
    "outputs",
    "rated_pitch_rad",
    "steady_operating_point",
]

N_TURBINES = 3


@dataclass(frozen=True, slots=True)
class HexiconParams:
    """Platform, layout and wake parameters (SI units).

    Parameters
    ----------
    name : str
    yaw_inertia_kg_m2 : float
        I about the turret (kg m²), > 0.
    drag_coefficient : float
        C_d (-), > 0.
    water_density_kg_m3 : float
        ρ_w (kg/m³), 500..2000.
    drag_area_m2, drag_lever_m : float
        Projected wetted area A (m²) and its lever r_d (m), > 0.
    turbine_x_m, turbine_y_m : tuple of 3 floats
        Turbine positions in the platform frame (m), x forward, y to port.
    wake_decay : float
        Jensen k (-), in (0, 1).
    turbine : TurbineParams
        The (identical) turbines.
    """

    name: str
    yaw_inertia_kg_m2: float
    drag_coefficient: float
    water_density_kg_m3: float
    drag_area_m2: float
    drag_lever_m: float
    turbine_x_m: tuple[float, float, float]
    turbine_y_m: tuple[float, float, float]
    wake_decay: float
    turbine: tb.TurbineParams

    def __post_init__(self) -> None:
        for name, lo, hi in (
            ("yaw_inertia_kg_m2", 0.0, math.inf),
            ("drag_coefficient", 0.0, 10.0),
            ("water_density_kg_m3", 500.0, 2000.0),
            ("drag_area_m2", 0.0, 1e6),
            ("drag_lever_m", 0.0, 1e4),
            ("wake_decay", 0.0, 1.0),
        ):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise ValueError(f"HexiconParams.{name}: expected a number, got {v!r}")
            if not (math.isfinite(v) and lo < v <= hi):
                raise ValueError(f"HexiconParams.{name} = {v!r}: expected a value in ({lo}, {hi}]")
        for name in ("turbine_x_m", "turbine_y_m"):
            v = getattr(self, name)
            if len(v) != N_TURBINES or not all(math.isfinite(float(e)) for e in v):
                raise ValueError(
                    f"HexiconParams.{name}: expected {N_TURBINES} finite positions in m, got {v!r}"
                )

    @property
    def drag_constant(self) -> float:
        """c = ½ ρ_w C_d A r_d³ (kg m²), the coefficient of r|r| in the yaw equation."""
        return (
            0.5
            * self.water_density_kg_m3
            * self.drag_coefficient
            * self.drag_area_m2
            * self.drag_lever_m**3
        )

    def scaled(self, inertia: float = 1.0, drag: float = 1.0) -> HexiconParams:
        """A copy with I and C_d multiplied (the seed's sensitivity cases, section 6)."""
        return HexiconParams(
            name=f"{self.name} (I x{inertia:g}, Cd x{drag:g})",
            yaw_inertia_kg_m2=self.yaw_inertia_kg_m2 * inertia,
            drag_coefficient=self.drag_coefficient * drag,
            water_density_kg_m3=self.water_density_kg_m3,
            drag_area_m2=self.drag_area_m2,
            drag_lever_m=self.drag_lever_m,
            turbine_x_m=self.turbine_x_m,
            turbine_y_m=self.turbine_y_m,
            wake_decay=self.wake_decay,
            turbine=self.turbine,
        )


class _HexiconFile(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    name: str
    turbine_file: str
    yaw_inertia_kg_m2: float
    drag_coefficient: float
    water_density_kg_m3: float
    drag_area_m2: float
    drag_lever_m: float
    turbine_x_m: list[float]
    turbine_y_m: list[float]
    wake_decay: float
    # the sensor channels (plant/hexicon/sensors.py reads and checks them)
    sensors: dict[str, Any] = msgspec.field(default_factory=dict)


def load_hexicon(name_or_path: str | Path = "hexicon_h3") -> HexiconParams:
    """Load the shipped preset ``hexicon_h3`` or a platform TOML file (keys carry units).

    Raises
    ------
    ValueError
        Unknown preset, unknown or missing key, or a value out of range (named).
    """
    text = str(name_or_path)
    if text in ("hexicon_h3", "hexicon-h3"):
        root = resources.files("plant.hexicon")
        data = (root / "hexicon_h3.toml").read_bytes()
        base = Path(str(root))
        source = "preset 'hexicon_h3'"
    elif text.endswith(".toml") or "/" in text:
        path = Path(text)
        data = path.read_bytes()
        base = path.parent
        source = str(path)
    else:
        raise ValueError(f"unknown platform preset {text!r}; shipped: hexicon_h3 (or a .toml)")
    try:
        spec = msgspec.toml.decode(data, type=_HexiconFile)
    except (msgspec.ValidationError, msgspec.DecodeError) as exc:
        raise ValueError(f"{source}: {exc}") from exc
    turbine = tb.load_turbine(base / spec.turbine_file)
    try:
        return HexiconParams(
            name=spec.name,
            yaw_inertia_kg_m2=spec.yaw_inertia_kg_m2,
            drag_coefficient=spec.drag_coefficient,
            water_density_kg_m3=spec.water_density_kg_m3,
            drag_area_m2=spec.drag_area_m2,
            drag_lever_m=spec.drag_lever_m,
            turbine_x_m=tuple(spec.turbine_x_m),  # type: ignore[arg-type]
            turbine_y_m=tuple(spec.turbine_y_m),  # type: ignore[arg-type]
            wake_decay=spec.wake_decay,
            turbine=turbine,
        )
    except ValueError as exc:
        raise ValueError(f"{source}: {exc}") from exc


class HexiconOutputs(NamedTuple):
    """Algebraic outputs at one instant.

    Attributes
    ----------
    wind_factors : tuple of 3 floats
        U_i / U_inf from the wakes (-).
    rotor_winds_m_s : tuple of 3 floats
        Rotor-effective wind V_i (m/s).
    thrusts_n, powers_w, cts : tuple of 3 floats
        Rotor thrust (N), electrical power (W), Ct (-).
    yaw_moment_nm : float
        Σ_i T_i (y_i cos e - x_i sin e) (N m).
    drag_moment_nm : float
        c r |r| (N m).
    misalignment_rad : float
        e = β - ψ wrapped to (-π, π] (rad).
    """

    wind_factors: tuple[float, ...]
    rotor_winds_m_s: tuple[float, ...]
    thrusts_n: tuple[float, ...]
    powers_w: tuple[float, ...]
    cts: tuple[float, ...]
    yaw_moment_nm: float
    drag_moment_nm: float
    misalignment_rad: float


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def _ct(tp: tb.TurbineParams, omega: float, theta: float, wind: float) -> float:
    if wind <= tb.WIND_MIN_M_S:
        return 0.0
    tsr = max(omega, 0.0) * tp.rotor_radius_m / wind
    return tp.table.coefficients(tsr, theta)[1]


def _rotor_winds(x: tuple[float, ...], u: tuple[float, ...], p: HexiconParams) -> tuple[float, ...]:
    """Wake factors U_i/U_inf with the Ct of each rotor at its own waked inflow (two passes)."""
    psi = x[0]
    speed, beta = u[6], u[7]
    c, s = math.cos(psi), math.sin(psi)
    xs = tuple(c * xi - s * yi for xi, yi in zip(p.turbine_x_m, p.turbine_y_m, strict=True))
    ys = tuple(s * xi + c * yi for xi, yi in zip(p.turbine_x_m, p.turbine_y_m, strict=True))
    tp = p.turbine
    diameter = 2.0 * tp.rotor_radius_m
    factors: tuple[float, ...] = (1.0, 1.0, 1.0)
    for _ in range(2):
        cts = tuple(_ct(tp, x[2 + 3 * i], x[3 + 3 * i], speed * factors[i]) for i in range(3))
        factors = jensen_speed_factors(xs, ys, beta, cts, diameter, p.wake_decay)
    return factors


def f(
    t: float, x: tuple[float, ...], u: tuple[float, ...], params: HexiconParams
) -> tuple[float, ...]:
    """Time derivative of the platform state (equations in the module docstring).

    Parameters
    ----------
    t : float
        Time (s), unused.
    x : tuple of 11 floats
        (ψ rad, r rad/s, then (ω rad/s, θ rad, T_g N m) per turbine).
    u : tuple of 8 floats
        ((θ_c rad, T_c N m) per turbine, V m/s, β rad).
    params : HexiconParams

    Returns
    -------
    tuple of 11 floats
        (r, r', then (ω', θ', T_g') per turbine).
    """
    return _f_with_factors(x, u, params, _rotor_winds(x, u, params))


def _f_with_factors(
    x: tuple[float, ...], u: tuple[float, ...], p: HexiconParams, factors: tuple[float, ...]
) -> tuple[float, ...]:
    tp = p.turbine
    speed, beta = u[6], u[7]
    e = beta - x[0]
    ce, se = math.cos(e), math.sin(e)
    moment = 0.0
    out: list[float] = [x[1], 0.0]
    for i in range(3):
        xi = (x[2 + 3 * i], x[3 + 3 * i], x[4 + 3 * i])
        wind = speed * factors[i]
        d = tb.f(0.0, xi, (u[2 * i], u[2 * i + 1], wind), tp)
        out.extend(d)
        if wind > tb.WIND_MIN_M_S:
            thrust = tp.k_thrust * wind * wind * _ct(tp, xi[0], xi[1], wind)
            moment += thrust * (p.turbine_y_m[i] * ce - p.turbine_x_m[i] * se)
    r = x[1]
    out[1] = (moment - p.drag_constant * r * abs(r)) / p.yaw_inertia_kg_m2
    return tuple(out)


def step_rk4(
    x: tuple[float, ...], u: tuple[float, ...], dt: float, params: HexiconParams
) -> tuple[float, ...]:
    """One classical RK4 step of ``f`` with the wake factors held over the step (quasi-static).

    Returns the state at t + dt.
    """
    fac = _rotor_winds(x, u, params)

    def g(xx: tuple[float, ...]) -> tuple[float, ...]:
        return _f_with_factors(xx, u, params, fac)

    k1 = g(x)
    k2 = g(tuple(a + 0.5 * dt * b for a, b in zip(x, k1, strict=True)))
    k3 = g(tuple(a + 0.5 * dt * b for a, b in zip(x, k2, strict=True)))
    k4 = g(tuple(a + dt * b for a, b in zip(x, k3, strict=True)))
    return tuple(
        a + dt / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
        for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4, strict=True)
    )


def outputs(
    t: float, x: tuple[float, ...], u: tuple[float, ...], params: HexiconParams
) -> HexiconOutputs:
    """Wakes, rotor winds, thrusts, powers and yaw moments at one instant (see module docs)."""
    p = params
    tp = p.turbine
    fac = _rotor_winds(x, u, p)
    speed, beta = u[6], u[7]
    e = _wrap(beta - x[0])
    winds, thrusts, powers, cts = [], [], [], []
    moment = 0.0
    for i in range(3):
        xi = (x[2 + 3 * i], x[3 + 3 * i], x[4 + 3 * i])
        wind = speed * fac[i]
        o = tb.outputs(0.0, xi, (0.0, 0.0, wind), tp)
        winds.append(wind)
        thrusts.append(o.rotor_thrust_n)
        powers.append(o.electrical_power_w)
        cts.append(o.ct)
        moment += o.rotor_thrust_n * (
            p.turbine_y_m[i] * math.cos(e) - p.turbine_x_m[i] * math.sin(e)
        )
    r = x[1]
    return HexiconOutputs(
        wind_factors=fac,
        rotor_winds_m_s=tuple(winds),
        thrusts_n=tuple(thrusts),
        powers_w=tuple(powers),
        cts=tuple(cts),
        yaw_moment_nm=moment,
        drag_moment_nm=p.drag_constant * r * abs(r),
        misalignment_rad=e,
    )


# ---------------------------------------------------------------------- offline helpers
def rated_pitch_rad(tp: tb.TurbineParams, wind_m_s: float) -> float:
    """The seed's lower pitch limit (figure 18): the pitch at which the rotor, at rated speed,
    takes rated power from wind V (0 below rated wind).

    Solves η ½ ρ π R² V³ Cp(ω_r R / V, θ) = P_rated for θ in [0, 30°] by bisection
    (Cp falls with θ above fine pitch).
    """
    if wind_m_s <= 0.0:
        return 0.0
    area_term = tp.generator_efficiency * tp.k_thrust * wind_m_s**3
    tsr = tp.rated_rotor_speed_rad_s * tp.rotor_radius_m / wind_m_s

    def excess(theta: float) -> float:
        return area_term * tp.table.coefficients(tsr, theta)[0] - tp.rated_power_w

    if excess(0.0) <= 0.0:
        return 0.0
    lo, hi = 0.0, math.radians(30.0)
    if excess(hi) > 0.0:
        return hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if excess(mid) > 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def torque_law_nm(tp: tb.TurbineParams, omega_rad_s: float) -> float:
    """Generator torque demand (HSS) of a plain variable-speed turbine: K ω_g² below rated
    speed, constant power P_rated/(η ω_g) at and above it, within [0, T_max].
    """
    k = tb.optimal_torque_gain(tp)
    wg = max(omega_rad_s, 0.0) * tp.gearbox_ratio
    wg_rated = tp.rated_rotor_speed_rad_s * tp.gearbox_ratio
    if wg < wg_rated:
        q = k * wg * wg
        q_rated = tp.rated_power_w / (tp.generator_efficiency * wg_rated)
        # linear blend over the last 5 % below rated speed avoids a torque jump
        blend = 0.95 * wg_rated
        if wg > blend:
            q0 = k * blend * blend
            q = q0 + (q_rated - q0) * (wg - blend) / (wg_rated - blend)
    else:
        q = tp.rated_power_w / (tp.generator_efficiency * wg)
    return min(max(q, 0.0), tp.torque_max_nm)


def steady_operating_point(
    tp: tb.TurbineParams, wind_m_s: float, pitch_rad: float
) -> tuple[float, float, float, float]:
    """Steady rotor speed (rad/s), thrust (N), power (W) and Ct under :func:`torque_law_nm`.

    Solves ½ρπR³V²Cq(ωR/V, θ) = N T_law(ω) for ω by bisection on [0.05, 2 ω_r].
    """

    def resid(w: float) -> float:
        o = tb.outputs(0.0, (w, pitch_rad, 0.0), (0.0, 0.0, wind_m_s), tp)
        return o.aero_torque_nm - tp.gearbox_ratio * torque_law_nm(tp, w)

    lo, hi = 0.05, 2.0 * tp.rated_rotor_speed_rad_s
    if resid(lo) <= 0.0:
        w = lo
    elif resid(hi) >= 0.0:
        w = hi
    else:
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if resid(mid) > 0.0:
                lo = mid
            else:
                hi = mid
        w = 0.5 * (lo + hi)
    q = torque_law_nm(tp, w)
    o = tb.outputs(0.0, (w, pitch_rad, q), (0.0, 0.0, wind_m_s), tp)
    return w, o.rotor_thrust_n, o.electrical_power_w, o.ct
