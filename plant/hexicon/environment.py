"""Free-stream wind speed and direction over time for the multi-turbine platform.

speed(t)     = V_0 + (V_1 - V_0) ramp(t; t_0, t_1) + u'(t)
direction(t) = β_0 + Δβ_step H(t - t_s) + (β_1 - β_0') ramp(t; t_2, t_3)

with ramp(t; a, b) = clip((t - a)/(b - a), 0, 1) (a step when b = a), H the unit step and u'(t)
seeded Kaimal turbulence of standard deviation σ (:func:`plant.turbulence.synthesize_turbulence`,
rotor-averaged for the 154 m rotor). Directions are degrees in the file, radians in the API,
counter-clockwise from above, the direction the wind comes from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from plant.turbulence import synthesize_turbulence

__all__ = ["WindProfile"]


def _ramp(t: float, a: float, b: float) -> float:
    if t <= a:
        return 0.0
    if t >= b:
        return 1.0
    return (t - a) / (b - a)


@dataclass(frozen=True, slots=True)
class WindProfile:
    """Wind speed and direction history (table 6 of ayotte-2015 and PRBS experiments).

    Parameters
    ----------
    speed_start_m_s, speed_end_m_s : float
        V_0 and V_1 (m/s), 0..40.
    speed_ramp_start_s, speed_ramp_end_s : float
        Ramp of speed from V_0 to V_1 over [t_0, t_1] (s).
    direction_start_deg : float
        β_0 (deg).
    direction_step_deg, direction_step_time_s : float
        Step of direction Δβ (deg) at t_s (s).
    direction_ramp_deg, direction_ramp_start_s, direction_ramp_end_s : float
        Linear change of direction by this much (deg) over [t_2, t_3] (s).
    turbulence_sigma_m_s : float
        Standard deviation of the turbulent speed (m/s), 0 = none.
    turbulence_seed : int
    duration_s : float
        Length of the turbulence record (s); it repeats after that.
    """

    speed_start_m_s: float = 15.0
    speed_end_m_s: float = 15.0
    speed_ramp_start_s: float = 0.0
    speed_ramp_end_s: float = 0.0
    direction_start_deg: float = 0.0
    direction_step_deg: float = 0.0
    direction_step_time_s: float = 0.0
    direction_ramp_deg: float = 0.0
    direction_ramp_start_s: float = 0.0
    direction_ramp_end_s: float = 0.0
    turbulence_sigma_m_s: float = 0.0
    turbulence_seed: int = 0
    duration_s: float = 600.0
    _turb: tuple[float, ...] = field(init=False, repr=False, compare=False, default=())
    _turb_dt: float = field(init=False, repr=False, compare=False, default=0.25)

    def __post_init__(self) -> None:
        for name in ("speed_start_m_s", "speed_end_m_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0.0 <= v <= 40.0):
                raise ValueError(f"WindProfile.{name} = {v!r}: expected 0..40 m/s")
        for a, b in (
            ("speed_ramp_start_s", "speed_ramp_end_s"),
            ("direction_ramp_start_s", "direction_ramp_end_s"),
        ):
            if not (0.0 <= getattr(self, a) <= getattr(self, b)):
                raise ValueError(f"WindProfile.{a}/{b}: expected 0 <= start <= end (s)")
        if not (math.isfinite(self.turbulence_sigma_m_s) and self.turbulence_sigma_m_s >= 0.0):
            raise ValueError("WindProfile.turbulence_sigma_m_s: expected >= 0 m/s")
        if not self.duration_s > 0.0:
            raise ValueError("WindProfile.duration_s: expected > 0 s")
        if self.turbulence_sigma_m_s > 0.0:
            mean = max(self.speed_start_m_s, 1.0)  # spectrum shape at the starting speed
            series = synthesize_turbulence(
                mean,
                self.turbulence_sigma_m_s,
                110.0,
                77.0,
                self.duration_s,
                0.25,
                self.turbulence_seed,
            )
            object.__setattr__(self, "_turb", tuple(float(v) - mean for v in series))

    def speed_m_s(self, t: float) -> float:
        """Free-stream speed V(t) (m/s), >= 0."""
        v = self.speed_start_m_s + (self.speed_end_m_s - self.speed_start_m_s) * _ramp(
            t, self.speed_ramp_start_s, self.speed_ramp_end_s
        )
        if self._turb:
            n = len(self._turb)
            x = t / self._turb_dt
            i = math.floor(x)
            fr = x - i
            i %= n
            v += self._turb[i] + (self._turb[(i + 1) % n] - self._turb[i]) * fr
        return max(v, 0.0)

    def direction_rad(self, t: float) -> float:
        """Direction β(t) the wind comes from (rad)."""
        deg = self.direction_start_deg
        if t >= self.direction_step_time_s:
            deg += self.direction_step_deg
        deg += self.direction_ramp_deg * _ramp(
            t, self.direction_ramp_start_s, self.direction_ramp_end_s
        )
        return math.radians(deg)


@dataclass(frozen=True)
class SampledWind:
    """Wind speed and direction given as samples every ``period_s``, each held over its period
    (zero-order hold; the last sample past the end): the PRBS wind of the identification
    experiments (ayotte-2015 table 5).

    Parameters
    ----------
    speeds_m_s, directions_deg : tuple of float
        Samples (m/s, deg from), of one length >= 1.
    period_s : float
        Sample period (s), > 0.
    """

    speeds_m_s: tuple[float, ...]
    directions_deg: tuple[float, ...]
    period_s: float = 1.0

    def __post_init__(self) -> None:
        if not (len(self.speeds_m_s) == len(self.directions_deg) >= 1 and self.period_s > 0):
            raise ValueError(
                "SampledWind: expected speeds and directions of one length >= 1 and period_s > 0"
            )

    def _k(self, t: float) -> int:
        return min(max(math.floor(t / self.period_s + 1e-9), 0), len(self.speeds_m_s) - 1)

    def speed_m_s(self, t: float) -> float:
        """V(t) (m/s)."""
        return self.speeds_m_s[self._k(t)]

    def direction_rad(self, t: float) -> float:
        """β(t) (rad)."""
        return math.radians(self.directions_deg[self._k(t)])
