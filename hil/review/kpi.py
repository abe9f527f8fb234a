"""Key performance indicators of a run: pure functions on numpy arrays, no I/O.

Every function accepts empty (or too short) input and returns ``nan`` (or a dict of
``nan``) instead of raising, so a crashed run with a channel missing still reviews;
:func:`hil.review.core.summarize` maps ``nan`` to JSON ``null``.

Units are SI unless a function name says otherwise (``_deg_s``, ``_us``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import rainflow

ArrayLike = npt.ArrayLike
NAN = float("nan")

#: Default Wöhler (S-N curve) exponent for the shaft: m = 4 (welded/forged steel, as in
#: the usual wind-turbine load post-processing; composite blades use m = 10).
WOHLER_M_STEEL = 4.0
#: Default equivalent-load frequency f_eq in Hz (one equivalent cycle per second).
N_EQ_HZ = 1.0
#: Wöhler exponent m of every DEL the bench reports (shaft, tower base, thrust): one value
#: for ``fowt review``/``report``/``compare`` and campaigns, so their DELs agree.
DEL_WOHLER_M = WOHLER_M_STEEL
#: Equivalent-load frequency f_eq [Hz] of every DEL the bench reports.
DEL_N_EQ_HZ = N_EQ_HZ


def _as_1d(x: ArrayLike) -> npt.NDArray[np.float64]:
    """``x`` as a flat float64 array (copy-free when already one)."""
    return np.asarray(x, dtype=np.float64).reshape(-1)


def window_start_s(end_s: float, settle_s: float) -> float:
    """Start t_0 of the KPI window: the start-up transient left out of every KPI.

    .. math:: t_0 = \\min(T_s,\\ t_{end} / 2)

    with T_s the requested settling time (scenario ``[review] settle_s``) and t_end the last
    sample time: a run shorter than 2 T_s keeps its second half. ``fowt review``, ``fowt
    report``, ``fowt compare`` and campaign runs all take their KPIs over [t_0, t_end] with
    this t_0, so one run gives one set of KPIs whichever command computes them.

    Parameters
    ----------
    end_s : float
        Last sample time t_end [s] (``nan`` when the run has no sample).
    settle_s : float
        Requested settling time T_s [s].

    Returns
    -------
    float
        t_0 [s]; T_s when t_end is not finite.
    """
    return min(settle_s, 0.5 * end_s) if math.isfinite(end_s) else settle_s


def mean_power_w(power_w: ArrayLike) -> float:
    """Mean electrical power.

    .. math:: \\bar P = \\frac{1}{N} \\sum_{k=1}^{N} P_k

    Parameters
    ----------
    power_w : array_like
        Electrical power samples [W], uniformly sampled.

    Returns
    -------
    float
        Mean power [W]; ``nan`` for empty input.
    """
    p = _as_1d(power_w)
    return float(np.mean(p)) if p.size else NAN


def mean(x: ArrayLike) -> float:
    """Arithmetic mean of uniformly sampled ``x`` (unit of ``x``); ``nan`` when empty."""
    a = _as_1d(x)
    return float(np.mean(a)) if a.size else NAN


def std(x: ArrayLike) -> float:
    """Population standard deviation (ddof = 0).

    .. math:: \\sigma = \\sqrt{\\frac{1}{N} \\sum_k (x_k - \\bar x)^2}

    Parameters
    ----------
    x : array_like
        Uniformly sampled signal (any unit).

    Returns
    -------
    float
        Standard deviation in the unit of ``x``; ``nan`` for empty input.
    """
    a = _as_1d(x)
    return float(np.std(a)) if a.size else NAN


def maximum(x: ArrayLike) -> float:
    """Largest sample of ``x`` (unit of ``x``); ``nan`` when empty."""
    a = _as_1d(x)
    return float(np.max(a)) if a.size else NAN


def pitch_travel_deg_s(t_s: ArrayLike, pitch_rad: ArrayLike) -> float:
    """Mean absolute blade-pitch rate (pitch actuator duty), time weighted.

    .. math::

        \\overline{|\\dot\\theta|} = \\frac{1}{t_N - t_0} \\int_{t_0}^{t_N} |\\dot\\theta|\\,dt
        = \\frac{180}{\\pi} \\frac{\\sum_k |\\theta_{k+1} - \\theta_k|}{t_N - t_0}

    i.e. total pitch travel over the duration, exact for a piecewise-linear pitch sampled at
    its corners and independent of non-uniform sampling.

    Parameters
    ----------
    t_s : array_like
        Sample times [s], increasing.
    pitch_rad : array_like
        Collective blade pitch [rad], same length as ``t_s``.

    Returns
    -------
    float
        Mean |dθ/dt| [deg/s]; ``nan`` with fewer than two samples or zero duration.
    """
    t = _as_1d(t_s)
    th = _as_1d(pitch_rad)
    n = min(t.size, th.size)
    if n < 2:
        return NAN
    duration = float(t[n - 1] - t[0])
    if not duration > 0.0:
        return NAN
    travel_rad = float(np.sum(np.abs(np.diff(th[:n]))))
    return math.degrees(travel_rad) / duration


def latency_percentiles_us(latency_ns: ArrayLike, overwrite: bool = False) -> dict[str, float]:
    """Latency percentiles from raw samples (linear interpolation, numpy's default).

    A sample may be ``inf``: a cycle whose command never came (its latency is beyond any
    measured one). Percentile q is then taken on the sorted samples x_(0) <= ... <= x_(N-1)
    at the rank h = (N - 1) q / 100 as x_(floor h) + (h - floor h)(x_(ceil h) - x_(floor h))
    when both are finite, and ``inf`` otherwise (numpy's ``linear`` method without its
    inf - inf = nan), so a run with 2 % unanswered cycles has an infinite p99.

    Parameters
    ----------
    latency_ns : array_like
        Latency samples [ns], ``inf`` for an unanswered cycle.
    overwrite : bool
        A float64 array given may be overwritten (turned into sorted microseconds) instead of
        copied: a day of cycles at 40 Hz is 28 MB a copy. The figures are the same.

    Returns
    -------
    dict
        ``{"p50", "p99", "p999", "max"}`` in microseconds [us] (p999 = 99.9th percentile);
        all ``nan`` for empty input.
    """
    a = _as_1d(latency_ns)
    if a.size == 0:
        return {"p50": NAN, "p99": NAN, "p999": NAN, "max": NAN}
    if overwrite and (a is latency_ns or a.base is latency_ns):
        us = np.divide(a, 1e3, out=a)  # the same figures as a / 1e3, in place
    else:
        us = a / 1e3
    us.sort()
    out: dict[str, float] = {}
    n = us.size
    for name, q in (("p50", 50.0), ("p99", 99.0), ("p999", 99.9)):
        h = (n - 1) * q / 100.0
        lo, hi = math.floor(h), math.ceil(h)
        if math.isfinite(us[hi]):
            out[name] = float(us[lo] + (h - lo) * (us[hi] - us[lo]))
        else:
            out[name] = math.inf
    out["max"] = float(us[-1])
    return out


def percentiles(
    x: ArrayLike, qs: Sequence[float], names: Sequence[str], overwrite: bool = False
) -> dict[str, float]:
    """Named percentiles of ``x`` (linear); ``"max"`` in ``names`` without a q is the max.

    Parameters
    ----------
    x : array_like
        Samples (any unit; returned in the same unit).
    qs : sequence of float
        Percentiles in [0, 100], one per leading name.
    names : sequence of str
        Keys of the result; names beyond ``len(qs)`` must be ``"max"``.
    overwrite : bool
        ``x`` may be reordered in place (numpy's ``overwrite_input``) instead of copied; the
        figures are the same.

    Returns
    -------
    dict
        Name to value; all ``nan`` for empty input.
    """
    a = _as_1d(x)
    out: dict[str, float] = {}
    if a.size == 0:
        return {n: NAN for n in names}
    vals: list[float] = (
        [float(v) for v in np.percentile(a, list(qs), method="linear", overwrite_input=overwrite)]
        if qs
        else []
    )
    for name, v in zip(names, vals, strict=False):
        out[name] = v
    if "max" in names[len(qs) :]:
        out["max"] = float(a.max())
    return out


def damage_equivalent_load(
    series: ArrayLike,
    t_s: ArrayLike,
    wohler_m: float = WOHLER_M_STEEL,
    n_eq_hz: float = N_EQ_HZ,
) -> float:
    """Damage-equivalent load (DEL) by rainflow counting (ASTM E1049, ``rainflow`` package).

    .. math::

        \\mathrm{DEL} = \\left( \\frac{\\sum_i n_i S_i^{m}}{f_{eq} T} \\right)^{1/m}

    with :math:`S_i` the rainflow ranges (peak to valley), :math:`n_i` their counts (half
    cycles count 0.5), :math:`m` the Wöhler exponent, :math:`f_{eq}` the equivalent-load
    frequency and :math:`T = t_N - t_0` the duration. The DEL is the range of a constant
    amplitude load at :math:`f_{eq}` doing the same Palmgren-Miner damage in :math:`T`.

    Parameters
    ----------
    series : array_like
        Load signal (e.g. shaft torque [N m]); the DEL has its unit.
    t_s : array_like
        Sample times [s]; only the first and last are used (duration T).
    wohler_m : float
        Wöhler (S-N) exponent m [-]; 4 for steel shafts and towers, 10 for composites.
    n_eq_hz : float
        Equivalent-load frequency f_eq [Hz].

    Returns
    -------
    float
        DEL as a range in the unit of ``series``; ``nan`` with fewer than two samples or a
        non-positive duration, 0.0 for a constant signal.
    """
    x = _as_1d(series)
    t = _as_1d(t_s)
    if x.size < 2 or t.size < 2 or not np.all(np.isfinite(x)):
        return NAN
    duration = float(t[-1] - t[0])
    if not duration > 0.0 or not n_eq_hz > 0.0 or not wohler_m > 0.0:
        return NAN
    damage = 0.0
    for rng, _mean, count, _i0, _i1 in rainflow.extract_cycles(x):
        damage += float(count) * float(rng) ** wohler_m
    return float((damage / (n_eq_hz * duration)) ** (1.0 / wohler_m))


def settling_time_s(
    t_s: ArrayLike, x: ArrayLike, target: float, band: float, t_step_s: float = 0.0
) -> float:
    """Time after a step until ``x`` enters and stays within ``target ± band``.

    .. math:: t_s = \\min\\{\\tau \\ge t_{step} : |x(t) - x^*| \\le b\\ \\forall t \\ge \\tau\\}
              - t_{step}

    Parameters
    ----------
    t_s : array_like
        Sample times [s], increasing.
    x : array_like
        Response (any unit).
    target : float
        Final value x* (unit of ``x``).
    band : float
        Half-width b of the tolerance band (unit of ``x``), e.g. 2 % of the step.
    t_step_s : float
        Time of the step [s]; samples before it are ignored.

    Returns
    -------
    float
        Settling time [s]; 0.0 if inside the band from the step on, ``nan`` if it never
        settles (last sample outside the band) or there are no samples after the step.
    """
    t = _as_1d(t_s)
    a = _as_1d(x)
    n = min(t.size, a.size)
    t, a = t[:n], a[:n]
    sel = t >= t_step_s
    t, a = t[sel], a[sel]
    if t.size == 0:
        return NAN
    outside = np.abs(a - target) > band
    if outside[-1]:
        return NAN
    if not outside.any():
        return 0.0
    last_out = int(np.flatnonzero(outside)[-1])
    return float(t[last_out + 1] - t_step_s)


def overshoot(x: ArrayLike, initial: float, target: float) -> float:
    """Peak overshoot beyond ``target`` as a fraction of the step ``target - initial``.

    .. math:: M_p = \\max\\left(0, \\max_k \\frac{x_k - x^*}{x^* - x_0}\\right)

    Returns ``nan`` for empty input or a zero step (dimensionless, multiply by 100 for %).
    """
    a = _as_1d(x)
    step = target - initial
    if a.size == 0 or step == 0.0:
        return NAN
    return float(max(0.0, float(np.max((a - target) / step))))


def finite_or_none(v: Any) -> Any:
    """``None`` for a non-finite float, the value otherwise (for JSON output)."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


__all__ = [
    "DEL_N_EQ_HZ",
    "DEL_WOHLER_M",
    "N_EQ_HZ",
    "WOHLER_M_STEEL",
    "damage_equivalent_load",
    "finite_or_none",
    "latency_percentiles_us",
    "maximum",
    "mean",
    "mean_power_w",
    "overshoot",
    "percentiles",
    "pitch_travel_deg_s",
    "settling_time_s",
    "std",
    "window_start_s",
]
