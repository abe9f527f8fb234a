"""Deterministic wind-speed histories for the rotor (steady, step, ramp).

Specs are frozen, validated value objects; :func:`wind_speed` is a pure function of time, so a
plant can be re-run, paced or not, with the same inputs. Hand-written because these are three
one-line formulas; turbulent wind (a spectral generator) is a separate concern.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["RampWind", "SteadyWind", "StepWind", "WindSpec", "wind_speed"]

#: Upper bound accepted for a wind speed (m/s): beyond any turbine's survival speed.
MAX_WIND_M_S = 100.0


def _check_speed(owner: str, name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{owner}.{name}: expected a number in m/s, got {type(value).__name__}")
    v = float(value)
    if not (math.isfinite(v) and 0.0 <= v <= MAX_WIND_M_S):
        raise ValueError(f"{owner}.{name} = {value!r}: expected m/s in [0, {MAX_WIND_M_S:g}]")
    return v


def _check_time(owner: str, name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{owner}.{name}: expected a time in s, got {type(value).__name__}")
    v = float(value)
    if not (math.isfinite(v) and v >= 0.0):
        raise ValueError(f"{owner}.{name} = {value!r}: expected a finite time >= 0 s")
    return v


@dataclass(frozen=True, slots=True)
class SteadyWind:
    """Constant wind U(t) = U0.

    Parameters
    ----------
    speed_m_s : float
        U0 (m/s), in [0, 100].
    """

    speed_m_s: float

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "speed_m_s", _check_speed("SteadyWind", "speed_m_s", self.speed_m_s)
        )


@dataclass(frozen=True, slots=True)
class StepWind:
    """Step from U0 to U1 at t_s: U(t) = U0 for t < t_s, U1 for t >= t_s.

    Parameters
    ----------
    initial_m_s, final_m_s : float
        U0 and U1 (m/s), in [0, 100].
    time_s : float
        Step time t_s (s), >= 0.
    """

    initial_m_s: float
    final_m_s: float
    time_s: float

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "initial_m_s", _check_speed("StepWind", "initial_m_s", self.initial_m_s))
        set_(self, "final_m_s", _check_speed("StepWind", "final_m_s", self.final_m_s))
        set_(self, "time_s", _check_time("StepWind", "time_s", self.time_s))


@dataclass(frozen=True, slots=True)
class RampWind:
    """Linear ramp from U0 (until t0) to U1 (from t1): U = U0 + (U1 - U0)(t - t0)/(t1 - t0).

    Parameters
    ----------
    initial_m_s, final_m_s : float
        U0 and U1 (m/s), in [0, 100].
    start_s, end_s : float
        Ramp start t0 and end t1 (s), 0 <= t0 < t1.
    """

    initial_m_s: float
    final_m_s: float
    start_s: float
    end_s: float

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "initial_m_s", _check_speed("RampWind", "initial_m_s", self.initial_m_s))
        set_(self, "final_m_s", _check_speed("RampWind", "final_m_s", self.final_m_s))
        set_(self, "start_s", _check_time("RampWind", "start_s", self.start_s))
        set_(self, "end_s", _check_time("RampWind", "end_s", self.end_s))
        if not self.end_s > self.start_s:
            raise ValueError(
                f"RampWind.end_s ({self.end_s} s) must be after start_s ({self.start_s} s)"
            )


WindSpec = SteadyWind | StepWind | RampWind


def wind_speed(t: float, spec: WindSpec) -> float:
    """Wind speed of ``spec`` at time ``t``.

    Steady: U0. Step: U0 if t < t_s else U1. Ramp: U0 for t <= t0, U1 for t >= t1, linear
    U0 + (U1 − U0)(t − t0)/(t1 − t0) in between.

    Parameters
    ----------
    t : float
        Time (s).
    spec : SteadyWind or StepWind or RampWind

    Returns
    -------
    float
        Wind speed (m/s).
    """
    if isinstance(spec, SteadyWind):
        return spec.speed_m_s
    if isinstance(spec, StepWind):
        return spec.initial_m_s if t < spec.time_s else spec.final_m_s
    if isinstance(spec, RampWind):
        if t <= spec.start_s:
            return spec.initial_m_s
        if t >= spec.end_s:
            return spec.final_m_s
        frac = (t - spec.start_s) / (spec.end_s - spec.start_s)
        return spec.initial_m_s + (spec.final_m_s - spec.initial_m_s) * frac
    raise TypeError(f"wind_speed: unknown wind spec {type(spec).__name__}")
