"""Ratios of KPIs with their noise, and the rule that calls a ratio "not meaningful".

Pure functions on numpy arrays, no I/O. The campaign's relative performance, normalised
performance (al-2019 eq. 5-1) and wave-induced increment, and ``fowt compare``'s
differences, are ratios R = A / D of KPI values; each comes here with a standard error and
a status, which the tables, plots and JSON of ``fowt campaign``, ``fowt compare`` and the
campaign report show.

Ratios
------
=====================  ==================  ===================  ======================
figure                 A (numerator)       D (denominator)      shown
=====================  ==================  ===================  ======================
relative               X_ctrl              X_base               R − 1
normalised P_n         X_ctrl − X_still    X_base − X_still     R
wave increment         X_waves             X_still              R
=====================  ==================  ===================  ======================

X_still is the still-water twin of the controller the figures are taken against. The
*change* of every figure is R − 1 (for P_n: its distance from the baseline in waves).

Not meaningful (``n/m``)
------------------------
A ratio whose denominator is near zero says nothing: a baseline shaft DEL of a few N m
(constant torque above rated) turns any controller's shaft DEL into a change of millions of
per cent, and a wave-induced part of 0.4 % of var(Ω) turns a change of −0.3 % into
P_n = 170 %. The denominator D (in the KPI's unit; Weibull-weighted: Σ p_c D_c / Σ p_c) is
near zero when

.. math:: |D| < \\max(k\\,\\mathrm{SE}(D),\\ f\\,S)

- SE(D): its standard error between seeds (below); k = :data:`NOISE_K` = 2, so D lies within
  its noise band (about 95 % for a normal error); left out when not estimable.
- S: the KPI's scale, the largest |X| of that KPI among the configurations compared (a
  campaign's load case: the means of its waves/still and controller configurations; the
  Weibull-weighted figures: the configurations' Weibull-weighted X_W; ``fowt compare``: the
  runs); f = :data:`NEAR_ZERO_FRACTION` = 1 %. A denominator under 1 % of the scale makes
  a difference of 1 % of the scale a ratio above 100 %, which the scale of the quantity does not
  support however small the noise (a constant baseline torque has a DEL with almost no
  seed-to-seed noise and still no meaning as a reference).

The figure is then shown as ``n/m``; aggregates.json keeps the number with its status.

Standard errors (between seeds)
-------------------------------
Seeds pair the configurations (seed i has the same wind and waves in all of them). For a
ratio of means R = ā / d̄ over n paired seeds, the linearised (delta-method) standard error
is

.. math:: \\mathrm{SE}(R) = \\frac{s_e}{\\sqrt{n}\\,|\\bar d|}, \\quad e_i = a_i - R\\,d_i

(s_e the sample standard deviation, ddof = 1), which keeps the pairing: noise common to
both configurations cancels in e_i. Weibull-weighted, R_W = Σ p_c ā_c / Σ p_c d̄_c and
SE(R_W) = sqrt(Σ p_c² s²_{e,c} / n_c) / |Σ p_c d̄_c| with e_{c,i} = a_{c,i} − R_W d_{c,i};
the weighted mean of per-case figures (Σp·) has SE sqrt(Σ w_c² SE_c²), w_c = p_c / Σ p.
SE(D) of the n/m rule is s_d / sqrt(n) the same way. With fewer than two paired seeds in a
case that counts (p_c > 0) the standard error is not estimable (``nan``), said so in the
tables; the n/m rule then uses the scale alone.

Status
------
``ok``; ``n/m`` (denominator near zero); ``noise``: |R − 1| < k SE, the change lies within
its noise (shown with a warning); ``n/a``: no value (a missing run, 0 / 0).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
NAN = float("nan")

#: Fraction f of the KPI's scale below which a denominator is near zero (module docstring).
NEAR_ZERO_FRACTION = 0.01
#: Multiple k of the standard error: a denominator within k SE of 0 is near zero, a change
#: within k SE of 0 is "within its noise".
NOISE_K = 2.0

OK = "ok"
NOT_MEANINGFUL = "n/m"
NOISE = "noise"
NO_VALUE = "n/a"


@dataclass(frozen=True)
class Ratio:
    """A figure derived from a ratio of KPIs, with its standard error and status.

    Attributes
    ----------
    value : float
        The figure (R − 1 for a relative change, R otherwise) [-]; ``nan`` when missing.
    se : float
        Its standard error [-]; ``nan`` when not estimable.
    status : str
        ``ok``, ``n/m``, ``noise`` or ``n/a`` (module docstring).
    denominator : float
        D in the KPI's unit (Weibull-weighted for a weighted ratio).
    """

    value: float
    se: float
    status: str
    denominator: float = NAN

    def as_dict(self) -> dict[str, float | str]:
        """``{"value", "se", "status"}`` for the aggregates."""
        return {"value": self.value, "se": self.se, "status": self.status}


def near_zero(denominator: float, scale: float, se: float = NAN) -> bool:
    """Whether a ratio's denominator is near zero: |D| < max(k SE(D), f S).

    Parameters
    ----------
    denominator : float
        D (KPI unit).
    scale : float
        S, the KPI's scale (KPI unit, >= 0); ``nan`` or 0: only D = 0 and the noise count.
    se : float
        SE(D) (KPI unit); ``nan`` when not estimable (then the scale alone decides).

    Returns
    -------
    bool
        True when D is near zero (``n/m``); False for a non-finite D (that is ``n/a``).
    """
    if not math.isfinite(denominator):
        return False
    bound = 0.0
    if math.isfinite(scale):
        bound = NEAR_ZERO_FRACTION * abs(scale)
    if math.isfinite(se):
        bound = max(bound, NOISE_K * se)
    return abs(denominator) < bound or denominator == 0.0


def scale_of(values: Sequence[float]) -> float:
    """S = max |x| over the finite values (``nan`` when there is none)."""
    a = np.asarray(values, dtype=np.float64).reshape(-1)
    a = a[np.isfinite(a)]
    return float(np.max(np.abs(a))) if a.size else NAN


def _sample_var(x: FloatArray) -> float:
    return float(np.var(x, ddof=1)) if x.size > 1 else NAN


def weighted_ratio(
    num_means: Sequence[float],
    den_means: Sequence[float],
    weights: Sequence[float],
    num_seeds: Sequence[npt.ArrayLike],
    den_seeds: Sequence[npt.ArrayLike],
    scale: float,
    offset: float = 0.0,
) -> Ratio:
    """R = Σ w_c a_c / Σ w_c d_c − offset with its paired between-seed standard error.

    One case (``weights = [1]``) gives a plain ratio of means.

    Parameters
    ----------
    num_means, den_means : sequence of float
        ā_c and d̄_c per case (means over each configuration's successful seeds; they make
        the value).
    weights : sequence of float
        p_c >= 0 per case (cases with p_c = 0 are left out).
    num_seeds, den_seeds : sequence of array_like
        Per case, a_{c,i} and d_{c,i} of the seeds present in every configuration involved
        (paired, same length); they make the standard error.
    scale : float
        The KPI's scale S for the n/m rule (:func:`near_zero`).
    offset : float
        Subtracted from R (1 for a relative change).

    Returns
    -------
    Ratio
        Value, standard error, status, and D = Σ w d̄ / Σ w.
    """
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    a = np.asarray(num_means, dtype=np.float64).reshape(-1)
    d = np.asarray(den_means, dtype=np.float64).reshape(-1)
    used = w > 0
    if not used.any() or not (np.isfinite(a[used]).all() and np.isfinite(d[used]).all()):
        return Ratio(NAN, NAN, NO_VALUE)
    wsum = float(w[used].sum())
    den = float(np.sum(w[used] * d[used]))
    num = float(np.sum(w[used] * a[used]))
    d_mean = den / wsum
    r = num / den if den != 0.0 else NAN
    var_e = 0.0
    var_d = 0.0
    estimable = True
    for c in (int(i) for i in np.flatnonzero(used)):
        ai = np.asarray(num_seeds[c], dtype=np.float64).reshape(-1)
        di = np.asarray(den_seeds[c], dtype=np.float64).reshape(-1)
        ok = np.isfinite(ai) & np.isfinite(di)
        ai, di = ai[ok], di[ok]
        if ai.size < 2:
            estimable = False
            break
        wc = float(w[c])
        var_d += wc**2 * _sample_var(di) / di.size
        if math.isfinite(r):
            var_e += wc**2 * _sample_var(ai - r * di) / ai.size
    se_d = math.sqrt(var_d) / wsum if estimable else NAN
    if near_zero(d_mean, scale, se_d):
        return Ratio(r - offset if math.isfinite(r) else NAN, NAN, NOT_MEANINGFUL, d_mean)
    se = math.sqrt(var_e) / abs(den) if estimable else NAN
    return _with_status(r - offset, se, r - 1.0, d_mean)


def _with_status(value: float, se: float, change: float, denominator: float) -> Ratio:
    if not math.isfinite(value):
        return Ratio(NAN, se, NO_VALUE, denominator)
    if math.isfinite(se) and abs(change) < NOISE_K * se:
        return Ratio(value, se, NOISE, denominator)
    return Ratio(value, se, OK, denominator)


def weighted_mean_of(ratios: Sequence[Ratio], weights: Sequence[float], offset: float) -> Ratio:
    """Σ w_c x_c / Σ w_c of per-case figures (the "Σp·" columns) with SE sqrt(Σ ŵ_c² SE_c²).

    ``n/m`` when a case with w_c > 0 is ``n/m`` (its figure would dominate the mean);
    ``n/a`` when one has no value. ``offset``: what the figure adds to R − 1 (1 for a
    relative change, 0 for P_n and the increment), for the noise test on the change.
    """
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    used = [i for i in range(w.size) if w[i] > 0]
    if not used:
        return Ratio(NAN, NAN, NO_VALUE)
    wsum = float(sum(w[i] for i in used))
    vals = [ratios[i].value for i in used]
    if any(ratios[i].status == NOT_MEANINGFUL for i in used):
        return Ratio(NAN, NAN, NOT_MEANINGFUL)
    if not all(math.isfinite(v) for v in vals):
        return Ratio(NAN, NAN, NO_VALUE)
    value = sum(w[i] * ratios[i].value for i in used) / wsum
    ses = [ratios[i].se for i in used]
    se = (
        math.sqrt(sum((w[i] / wsum) ** 2 * ratios[i].se ** 2 for i in used))
        if all(math.isfinite(s) for s in ses)
        else NAN
    )
    return _with_status(value, se, value + offset - 1.0, NAN)


def simple_ratio_status(value: float, denominator: float, scale: float) -> str:
    """Status of a ratio without a standard error (``fowt compare``: single runs).

    ``n/a`` for a missing value, ``n/m`` when the denominator is near zero against the
    scale (:func:`near_zero` without SE), ``ok`` otherwise.
    """
    if not math.isfinite(denominator):
        return NO_VALUE
    if near_zero(denominator, scale):
        return NOT_MEANINGFUL
    if not math.isfinite(value):
        return NO_VALUE
    return OK


def percent_text(r: dict[str, float | str] | Ratio | None, signed: bool = True) -> str:
    """A figure as table text: ``n/m``, ``-``, or ``+1.2 % ± 0.3 %`` (``!`` when within noise).

    The ± part is one standard error; ``± ?`` says it is not estimable (one seed).
    """
    if r is None:
        return "-"
    d = r.as_dict() if isinstance(r, Ratio) else r
    status = str(d.get("status", OK))
    value = d.get("value")
    if status == NOT_MEANINGFUL:
        return NOT_MEANINGFUL
    if value is None or not isinstance(value, int | float) or not math.isfinite(value):
        return "-"
    se = d.get("se")
    text = f"{100 * value:+.2f} %" if signed else f"{100 * value:.3g} %"
    if isinstance(se, int | float) and math.isfinite(se):
        text += f" ± {100 * se:.2g} %"
    else:
        text += " ± ?"
    if status == NOISE:
        text += " !"
    return text


__all__ = [
    "NEAR_ZERO_FRACTION",
    "NOISE",
    "NOISE_K",
    "NOT_MEANINGFUL",
    "NO_VALUE",
    "OK",
    "Ratio",
    "near_zero",
    "percent_text",
    "scale_of",
    "simple_ratio_status",
    "weighted_mean_of",
    "weighted_ratio",
]
