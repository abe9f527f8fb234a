"""Deterministic wind-speed histories for the rotor: steady, step, ramp, turbulent, gust.

Specs are frozen, validated value objects; :func:`wind_speed` is a pure function of time, so a
plant can be re-run, paced or not, with the same inputs. Hand-written because these are
one-line formulas. The turbulent wind is synthesised once, when its spec is built, by
:mod:`plant.turbulence` (IEC Kaimal spectrum, rotor-averaged, seeded random phases, inverse
FFT) and then only looked up (linear interpolation, O(1)); the extreme operating gust is the
IEC 61400-1 closed form.

A plant's turbulent record is a periodic box of bounded length (:data:`TURBULENCE_BOX_S`,
:func:`plant.build.make_wind`): a run up to that long gets a record of its own length (the
bits of a record synthesised for the run's whole duration), a longer run the box, repeated.
So a day-long run's memory and start-up are those of a one-hour run.
:func:`make_wind_function` returns a closure specialised to one spec for loops that call the
wind several times per step.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from plant.turbulence import (
    EOG_PERIOD_S,
    REFERENCE_INTENSITY,
    REFERENCE_SPEED_M_S,
    eog_gust_amplitude,
    eog_shape,
    ntm_sigma,
    synthesize_turbulence,
)

__all__ = [
    "GustWind",
    "RampWind",
    "SteadyWind",
    "StepWind",
    "TurbulentWind",
    "WindSpec",
    "make_wind_function",
    "wind_speed",
]

#: Largest turbulence record accepted (samples): 2**23 floats, 64 MiB.
MAX_TURBULENCE_SAMPLES = 2**23

#: Longest turbulent record a plant synthesises (s): a longer run repeats it (its period).
#: One hour: a run shorter than that sees a record that never repeats within it and is bit
#: for bit the one synthesised for its whole duration; a run of an hour or more gets this
#: box, so its memory (288 k samples at 12.5 ms, 2.3 MB) and synthesis time (the rotor
#: average over 144 k frequencies, the longest part of it) are those of an hour whatever
#: the duration (a 24 h record: 6.9 M samples, 55 MB, and a start-up ten times longer).
TURBULENCE_BOX_S = 3600.0

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


def _check_positive(owner: str, name: str, value: float, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{owner}.{name}: expected a number in {unit}, got {type(value).__name__}")
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{owner}.{name} = {value!r}: expected a finite value > 0 {unit}")
    return v


def _check_choice(owner: str, name: str, value: str, choices: dict[str, float]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"{owner}.{name} = {value!r}: expected one of {sorted(choices)}")
    return value


@dataclass(frozen=True, slots=True)
class TurbulentWind:
    """Rotor-effective turbulent wind: U + IEC Kaimal turbulence, precomputed and looked up.

    The record is one period of a seeded random-phase Fourier series
    (:func:`plant.turbulence.synthesize_turbulence`): Kaimal spectrum with the normal
    turbulence model σ₁ = I_ref (0.75 U + 5.6), filtered by the disc average of the IEC
    coherence for a rotor of radius R (R = 0: point wind at the hub). It is sampled every
    ``dt_s`` over N Δt ≥ ``duration_s`` (N 5-smooth) and is periodic: times outside
    [0, N Δt) wrap around, continuously. Between samples the speed is interpolated linearly.
    Speeds are clipped at 0 m/s (only matters for U below about 2σ₁).

    Parameters
    ----------
    mean_m_s : float
        Mean hub wind U (m/s), in (0, 100].
    turbulence_class : {'A+', 'A', 'B', 'C'}
        IEC turbulence category (I_ref = 0.18, 0.16, 0.14, 0.12).
    seed : int
        Seed of the random phases (>= 0); same seed, same record.
    hub_height_m : float
        Hub height (m), > 0; sets the Kaimal length L_u = 8.1 · 0.7 min(z_hub, 60 m).
    rotor_radius_m : float
        Rotor radius R (m), >= 0.
    duration_s : float
        Length of the record before it repeats (s), > 0.
    dt_s : float
        Sample step (s), > 0; at most 2**23 samples.

    Attributes
    ----------
    sigma_m_s : float
        σ₁ of the normal turbulence model at U (m/s), for the point wind.
    samples_m_s : ndarray
        The record u(j Δt), j = 0 … N-1 (read-only).

    Notes
    -----
    Only the array is kept (8 bytes a sample): a Python list of the samples, faster for a
    scalar lookup, cost 32 bytes a sample (220 MB for a day at 12.5 ms), and the lookups
    that remain in Python (the initial state, an analytic path) are a handful a run.
    """

    mean_m_s: float
    turbulence_class: str
    seed: int
    hub_height_m: float
    rotor_radius_m: float
    duration_s: float
    dt_s: float
    sigma_m_s: float = field(init=False, compare=False)
    samples_m_s: npt.NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        owner = "TurbulentWind"
        mean = _check_speed(owner, "mean_m_s", self.mean_m_s)
        if mean <= 0.0:
            raise ValueError(f"{owner}.mean_m_s = {self.mean_m_s!r}: expected m/s in (0, 100]")
        set_(self, "mean_m_s", mean)
        _check_choice(owner, "turbulence_class", self.turbulence_class, REFERENCE_INTENSITY)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"{owner}.seed = {self.seed!r}: expected an integer >= 0")
        set_(self, "hub_height_m", _check_positive(owner, "hub_height_m", self.hub_height_m, "m"))
        radius = self.rotor_radius_m
        if isinstance(radius, bool) or not isinstance(radius, int | float):
            raise ValueError(f"{owner}.rotor_radius_m: expected a number in m")
        if not (math.isfinite(radius) and 0.0 <= radius < self.hub_height_m):
            raise ValueError(
                f"{owner}.rotor_radius_m = {radius!r}: expected m in [0, hub_height_m)"
            )
        set_(self, "rotor_radius_m", float(radius))
        set_(self, "duration_s", _check_positive(owner, "duration_s", self.duration_s, "s"))
        set_(self, "dt_s", _check_positive(owner, "dt_s", self.dt_s, "s"))
        if self.duration_s / self.dt_s > MAX_TURBULENCE_SAMPLES:
            raise ValueError(
                f"{owner}: duration_s / dt_s = {self.duration_s / self.dt_s:.3g} samples: "
                f"expected at most {MAX_TURBULENCE_SAMPLES}"
            )
        sigma = ntm_sigma(mean, self.turbulence_class)
        samples = synthesize_turbulence(
            mean,
            sigma,
            self.hub_height_m,
            self.rotor_radius_m,
            self.duration_s,
            self.dt_s,
            self.seed,
        )
        np.maximum(samples, 0.0, out=samples)
        samples.setflags(write=False)
        set_(self, "sigma_m_s", sigma)
        set_(self, "samples_m_s", samples)

    @property
    def period_s(self) -> float:
        """Repeat period N Δt of the record (s), >= ``duration_s``."""
        return len(self.samples_m_s) * self.dt_s

    def speed_at(self, t: float) -> float:
        """Wind speed (m/s) at time ``t`` (s): linear interpolation, periodic wrap-around."""
        table = self.samples_m_s
        n = len(table)
        x = t / self.dt_s
        i = math.floor(x)
        frac = x - i
        i %= n
        lo = float(table[i])
        return lo + (float(table[i + 1 if i + 1 < n else 0]) - lo) * frac


@dataclass(frozen=True, slots=True)
class GustWind:
    """IEC 61400-1 ed. 3 extreme operating gust (EOG) starting at ``start_s``.

    U(t) = V_hub - 0.37 V_gust sin(3π τ/T)(1 - cos(2π τ/T)) for τ = t - t₀ ∈ [0, T], V_hub
    otherwise, with V_gust = min(1.35 (V_e1 - V_hub), 3.3 σ₁ / (1 + 0.1 D/Λ₁)), V_e1 =
    0.8 · 1.4 V_ref, σ₁ = I_ref (0.75 V_hub + 5.6), Λ₁ = 0.7 min(z_hub, 60 m). The gust peaks
    at V_hub + 0.74 V_gust at τ = T/2 and dips to V_hub - 0.268 V_gust at τ ≈ 0.234 T and
    0.766 T. Clipped at 0 m/s.

    Parameters
    ----------
    hub_speed_m_s : float
        V_hub (m/s), in [0, 100].
    start_s : float
        Gust start t₀ (s), >= 0.
    turbine_class : {'I', 'II', 'III'}
        Sets V_ref = 50, 42.5, 37.5 m/s.
    turbulence_class : {'A+', 'A', 'B', 'C'}
        Sets I_ref.
    rotor_diameter_m : float
        D (m), > 0.
    hub_height_m : float
        z_hub (m), > 0.
    period_s : float
        Gust duration T (s), > 0; IEC: 10.5 s.

    Attributes
    ----------
    gust_m_s : float
        V_gust (m/s).
    """

    hub_speed_m_s: float
    start_s: float
    turbine_class: str = "I"
    turbulence_class: str = "B"
    rotor_diameter_m: float = 126.0
    hub_height_m: float = 90.0
    period_s: float = EOG_PERIOD_S
    gust_m_s: float = field(init=False, compare=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        owner = "GustWind"
        set_(self, "hub_speed_m_s", _check_speed(owner, "hub_speed_m_s", self.hub_speed_m_s))
        set_(self, "start_s", _check_time(owner, "start_s", self.start_s))
        _check_choice(owner, "turbine_class", self.turbine_class, REFERENCE_SPEED_M_S)
        _check_choice(owner, "turbulence_class", self.turbulence_class, REFERENCE_INTENSITY)
        set_(
            self,
            "rotor_diameter_m",
            _check_positive(owner, "rotor_diameter_m", self.rotor_diameter_m, "m"),
        )
        set_(self, "hub_height_m", _check_positive(owner, "hub_height_m", self.hub_height_m, "m"))
        set_(self, "period_s", _check_positive(owner, "period_s", self.period_s, "s"))
        gust = eog_gust_amplitude(
            self.hub_speed_m_s,
            self.turbine_class,
            self.turbulence_class,
            self.rotor_diameter_m,
            self.hub_height_m,
        )
        set_(self, "gust_m_s", gust)

    def speed_at(self, t: float) -> float:
        """Wind speed (m/s) at time ``t`` (s)."""
        g = eog_shape(t - self.start_s, self.period_s)
        return max(0.0, self.hub_speed_m_s - 0.37 * self.gust_m_s * g)


WindSpec = SteadyWind | StepWind | RampWind | TurbulentWind | GustWind


def wind_speed(t: float, spec: WindSpec) -> float:
    """Wind speed of ``spec`` at time ``t``.

    Steady: U0. Step: U0 if t < t_s else U1. Ramp: U0 for t <= t0, U1 for t >= t1, linear
    U0 + (U1 − U0)(t − t0)/(t1 − t0) in between. Turbulent: the precomputed record,
    interpolated (:meth:`TurbulentWind.speed_at`). Gust: the IEC EOG (:meth:`GustWind.speed_at`).

    Parameters
    ----------
    t : float
        Time (s).
    spec : SteadyWind or StepWind or RampWind or TurbulentWind or GustWind

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
    if isinstance(spec, TurbulentWind | GustWind):
        return spec.speed_at(t)
    raise TypeError(f"wind_speed: unknown wind spec {type(spec).__name__}")


def make_wind_function(spec: WindSpec) -> Callable[[float], float]:
    """A function t ↦ :func:`wind_speed` (t, spec), specialised so each call is O(1).

    Parameters
    ----------
    spec : WindSpec

    Returns
    -------
    callable
        ``u(t: float) -> float`` (m/s); equal to ``wind_speed(t, spec)`` for every t.
    """
    if isinstance(spec, TurbulentWind | GustWind):
        return spec.speed_at
    if isinstance(spec, SteadyWind):
        speed = spec.speed_m_s
        return lambda _t: speed
    if not isinstance(spec, StepWind | RampWind):
        raise TypeError(f"make_wind_function: unknown wind spec {type(spec).__name__}")
    return lambda t: wind_speed(t, spec)
