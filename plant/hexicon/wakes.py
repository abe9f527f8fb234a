"""Jensen (top-hat) wakes between the rotors of one platform, with rotor-overlap weighting.

A rotor of diameter D with thrust coefficient Ct leaves a top-hat wake of diameter
D + 2 k X at the downwind distance X > 0, in which the speed is (ayotte-2015, eq. 8-9)

    U_wake = U_inf [1 - alpha (D / (D + 2 k X))^2],   alpha = 1 - sqrt(1 - Ct).

The rotor-averaged deficit of a downwind rotor j from the wake of rotor i is that deficit
times the fraction of rotor j's disc the wake covers (area of the intersection of two circles
over pi R^2). Several wakes on one rotor combine point by point as the root of the sum of
squares of the deficits relative to the free stream (FLORIS' ``sosfs`` superposition):

    U(p) = U_inf (1 - sqrt(sum_i delta_i(p)^2)),   delta_i(p) = alpha_i (D / (D + 2 k X_ij))^2
                                                   inside wake i, else 0,

averaged over the disc: exactly (lens area) for one wake, and on a fixed equal-area polar
grid of 512 points when two or more wakes overlap the rotor.

All rotors share one hub height (no vertical offset). Written on plain floats: three rotors,
evaluated every plant step. FLORIS' ``jensen`` model (the field's reference) evaluates the same
top-hat deficit on a grid of points over each rotor; ``tests/test_hexicon.py`` checks this
against it.
"""

from __future__ import annotations

import math

__all__ = ["circle_overlap_fraction", "jensen_speed_factors"]

_RINGS, _SECTORS = 16, 32
#: Equal-area polar quadrature points of the unit disc (ring centres at sqrt((k + ½)/K)).
_DISC = tuple(
    (
        math.sqrt((k + 0.5) / _RINGS) * math.cos(2 * math.pi * (s + 0.5 * (k % 2)) / _SECTORS),
        math.sqrt((k + 0.5) / _RINGS) * math.sin(2 * math.pi * (s + 0.5 * (k % 2)) / _SECTORS),
    )
    for k in range(_RINGS)
    for s in range(_SECTORS)
)


def circle_overlap_fraction(rotor_radius_m: float, wake_radius_m: float, offset_m: float) -> float:
    """Fraction of a rotor disc (radius R) covered by a wake disc (radius R_w) at offset d.

    Lens area of two circles, A = R^2 acos(c1) + R_w^2 acos(c2) - ½ sqrt((-d+R+R_w)(d+R-R_w)
    (d-R+R_w)(d+R+R_w)), c1 = (d² + R² - R_w²)/(2 d R), c2 = (d² + R_w² - R²)/(2 d R_w);
    returns A / (π R²) in [0, 1].
    """
    r, rw, d = rotor_radius_m, wake_radius_m, abs(offset_m)
    if d >= r + rw:
        return 0.0
    if d <= abs(rw - r):
        return 1.0 if rw >= r else (rw * rw) / (r * r)
    c1 = (d * d + r * r - rw * rw) / (2.0 * d * r)
    c2 = (d * d + rw * rw - r * r) / (2.0 * d * rw)
    k = (-d + r + rw) * (d + r - rw) * (d - r + rw) * (d + r + rw)
    area = (
        r * r * math.acos(max(-1.0, min(1.0, c1)))
        + rw * rw * math.acos(max(-1.0, min(1.0, c2)))
        - 0.5 * math.sqrt(max(0.0, k))
    )
    return area / (math.pi * r * r)


def jensen_speed_factors(
    xs_m: tuple[float, ...],
    ys_m: tuple[float, ...],
    wind_from_rad: float,
    thrust_coefficients: tuple[float, ...],
    rotor_diameter_m: float,
    wake_decay: float,
) -> tuple[float, ...]:
    """Rotor-averaged wind speed of each rotor over the free-stream speed, U_j / U_inf.

    Parameters
    ----------
    xs_m, ys_m : tuple of float
        Rotor positions in the horizontal plane (m, world frame).
    wind_from_rad : float
        Direction the wind comes from (rad, counter-clockwise from the x axis); the wind
        blows towards -(cos β, sin β).
    thrust_coefficients : tuple of float
        Ct of each rotor (-); clipped to [0, 0.9999] inside alpha = 1 - sqrt(1 - Ct).
    rotor_diameter_m : float
        D (m), the same for every rotor.
    wake_decay : float
        Jensen k (-).

    Returns
    -------
    tuple of float
        U_j / U_inf in [0, 1] for each rotor.
    """
    dx = -math.cos(wind_from_rad)
    dy = -math.sin(wind_from_rad)
    n = len(xs_m)
    radius = 0.5 * rotor_diameter_m
    out = []
    for j in range(n):
        total = 0.0
        wakes: list[tuple[float, float, float]] = []  # (deficit, wake radius, lateral offset)
        for i in range(n):
            if i == j:
                continue
            rx = xs_m[j] - xs_m[i]
            ry = ys_m[j] - ys_m[i]
            down = rx * dx + ry * dy
            if down <= 0.0:
                continue
            cross = rx * dy - ry * dx
            ct = min(max(thrust_coefficients[i], 0.0), 0.9999)
            alpha = 1.0 - math.sqrt(1.0 - ct)
            grow = rotor_diameter_m / (rotor_diameter_m + 2.0 * wake_decay * down)
            frac = circle_overlap_fraction(radius, radius + wake_decay * down, cross)
            if frac <= 0.0:
                continue
            deficit = alpha * grow * grow
            wakes.append((deficit, radius + wake_decay * down, cross))
            total += deficit * frac
        if len(wakes) > 1:
            total = _disc_average(wakes, radius)
        out.append(max(0.0, 1.0 - total))
    return tuple(out)


def _disc_average(wakes: list[tuple[float, float, float]], radius: float) -> float:
    """Disc-averaged sosfs deficit mean_p sqrt(sum_i delta_i(p)^2) on the polar grid; wakes
    are circles in the rotor plane at lateral offsets (hub heights are equal)."""
    acc = 0.0
    for py, pz in _DISC:
        y, z = py * radius, pz * radius
        s2 = 0.0
        for deficit, rw, off in wakes:
            if (y - off) * (y - off) + z * z < rw * rw:
                s2 += deficit * deficit
        acc += math.sqrt(s2)
    return acc / len(_DISC)
