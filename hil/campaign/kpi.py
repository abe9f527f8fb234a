"""Campaign KPIs and their aggregation: al-2019 table 2-3, Weibull weighting, eq. (5-1).

Pure functions on numpy arrays and plain numbers, no I/O. Kept apart from :mod:`hil.review.kpi`
(which the single-run review uses; a quantity in both is computed by the one function in
:mod:`hil.review.kpi`, so the two agree).

KPIs of one run (:func:`run_kpis`, al-2019 table 2-3 plus the bench's own)
---------------------------------------------------------------------------
All over the run's KPI window (the start-up left out, :func:`hil.review.kpi.window_start_s`), the
window of ``fowt review``, ``report`` and ``compare`` (:func:`hil.campaign.runner.run_kpis_of`
cuts it); the functions shared with the review come from :mod:`hil.review.kpi`.

``mean_power_w``
    mean(P) [W] of the electrical power (1.1, maximise).
``rotor_speed_error_var_rpm2``
    var(Ω − Ω_opt) [rpm²] (1.2, minimise), Ω the true rotor speed and Ω_opt the optimal
    rotor speed for maximum power at the rotor-effective wind U (al-2019 section 2-4,
    nomenclature "optimal rotor speed for maximum power production"), see
    :func:`optimal_rotor_speed_rad_s`; λ* from scenario ``[review] tsr_opt`` (default: the
    argmax of the plant's Cp(λ, 0), a table grid point).
``rotor_speed_var_rpm2``
    var(Ω) [rpm²], the quantity of al-2019 table 2-5.
``tower_base_del_nm``, ``shaft_del_nm``
    DEL(M_y,T) and DEL(M_LSS) [N m] (2.1, 2.2), rainflow, Wöhler m = 4, 1 Hz equivalent
    (:func:`hil.review.kpi.damage_equivalent_load`).
``pitch_rate_mean_abs_deg_s``
    mean |dθ_c/dt| [deg/s] (2.4), total pitch travel over the window.
``platform_pitch_std_deg``, ``platform_surge_std_m``
    standard deviations of the true platform pitch [deg] and surge [m].
``deadline_misses``
    control periods without a command [1].

al-2019's KPI 2.3, the blade-root out-of-plane DEL DEL(M_b,oop), is not computed: the plant
has rigid blades and no blade-root load channel (:data:`NOT_AVAILABLE`).

Aggregates (al-2019 sections 2-5 and 5)
---------------------------------------
Weibull weighting (:func:`weibull_mean`): X_W = Σ_i p_i X_i / Σ_i p_i over the load cases i
with occurrence probabilities p_i (table 2-2; they sum to 99.54 %, hence the division).
Relative performance (:func:`relative`): X_ctrl / X_base − 1 (figure 5-1, 5-3/5-5 top).
Standard errors and the n/m rule for near-zero denominators: :mod:`hil.review.kpi_stats`.
Normalised performance (:func:`normalised`, eq. 5-1): P_n = (X_ctrl − X_still) /
(X_base − X_still); 1 = baseline with waves, 0 = baseline in still water (figure 5-2, 5-3/5-5
bottom). Wave-induced increment (:func:`increment_ratio`, table 2-5, figure 2-5):
X_waves / X_still with the baseline. P_n is defined only where the waves change the
baseline's KPI measurably (:func:`baseline_within_noise`): its denominator
D = X_base − X_still must exceed k SE(D) (k = 2, paired seeds) and
:data:`WAVE_EFFECT_FRACTION` (5 %) of the KPI's scale S; otherwise the figure is
:data:`BASELINE_NOISE` ("n/a: baseline within noise") and no number is shown. The general n/m
floor of :mod:`hil.review.kpi_stats` (1 % of S) let D = 1.2 % of S through: a controller that
changes the KPI by 40 % of its scale then reads P_n = −3500 %, a number that says nothing.
At D = 5 % S, a change of 5 % of the scale moves P_n by 100 %.

The Weibull-weighted relative and normalised figures are taken on the Weibull-weighted KPIs
(X_W per configuration, then the ratio: the way al-2019 table 5-2 relates to its quoted -11 %
and +0.10 %); :func:`weibull_mean` of the per-case ratios is given beside them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from hil.review import kpi, kpi_stats

FloatArray = npt.NDArray[np.float64]
NAN = float("nan")
RPM_PER_RAD_S = 30.0 / math.pi

#: KPI columns of a campaign run: name -> (unit, direction, label). Direction +1: larger
#: is better (power), -1: smaller is better.
KPIS: dict[str, tuple[str, int, str]] = {
    "mean_power_w": ("W", +1, "mean(P)"),
    "rotor_speed_error_var_rpm2": ("rpm²", -1, "var(Ω − Ω_opt)"),
    "rotor_speed_var_rpm2": ("rpm²", -1, "var(Ω)"),
    "tower_base_del_nm": ("N m", -1, "DEL(M_y,T)"),
    "shaft_del_nm": ("N m", -1, "DEL(M_LSS)"),
    "pitch_rate_mean_abs_deg_s": ("deg/s", -1, "mean|dθ/dt|"),
    "platform_pitch_std_deg": ("deg", -1, "std(β_p)"),
    "platform_surge_std_m": ("m", -1, "std(x_p)"),
    "deadline_misses": ("1", -1, "deadline misses"),
}

#: al-2019 table 2-3 KPIs this plant cannot give, with the reason (printed and reported).
NOT_AVAILABLE: dict[str, str] = {
    "blade_oop_del_nm": (
        "blade-root out-of-plane DEL (al-2019 KPI 2.3) not computed: the plant's blades are "
        "rigid and it has no blade-root load channel"
    ),
}

#: Remarks on how this plant's KPIs differ from al-2019's (printed and reported).
NOTES: dict[str, str] = {
    "shaft_del_nm": (
        "DEL(M_LSS) is the DEL of the low-speed-shaft torque N·T_g: the plant's drivetrain is "
        "rigid, so the shaft carries the generator torque only, and a controller holding "
        "constant torque above rated gives a DEL near 0 there; ratios to it are then not "
        "meaningful and shown as n/m (hil.review.kpi_stats)"
    ),
    "pitch_rate_mean_abs_deg_s": (
        "mean|dθ/dt| is 0 below rated where only the torque acts (al-2019 footnote 3): its "
        "ratios are undefined there (n/m)"
    ),
}

#: Fraction of the KPI's scale S the baseline's wave-induced change D = X_base − X_still
#: must reach for the normalised performance P_n = (X_ctrl − X_still) / D to be defined.
WAVE_EFFECT_FRACTION = 0.05
#: Status (and table text) of a P_n whose denominator is within its noise or under
#: :data:`WAVE_EFFECT_FRACTION` of the scale.
BASELINE_NOISE = "n/a: baseline within noise"


def baseline_within_noise(
    den_means: Sequence[float],
    den_seeds: Sequence[npt.ArrayLike],
    weights: Sequence[float],
    scale: float,
    k: float = kpi_stats.NOISE_K,
    fraction: float = WAVE_EFFECT_FRACTION,
) -> bool:
    """Whether P_n's denominator D = Σ w_c d̄_c / Σ w_c is too small to divide by.

    True when |D| < max(k SE(D), fraction · S): SE(D) = sqrt(Σ w_c² s²_{d,c} / n_c) / Σ w_c
    over the paired seeds' d_{c,i} (left out when a weighted case has fewer than two seeds),
    S the KPI's scale (left out when not finite). False when D is not finite (no value).

    Parameters
    ----------
    den_means : sequence of float
        d̄_c per case (KPI unit).
    den_seeds : sequence of array_like
        d_{c,i} per case, the seeds every configuration has.
    weights : sequence of float
        p_c (cases with p_c = 0 left out); ``[1.0]`` for one case.
    scale : float
        S (KPI unit).
    k, fraction : float
        Multiple of SE(D) and fraction of S.
    """
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    d = np.asarray(den_means, dtype=np.float64).reshape(-1)
    used = [int(i) for i in np.flatnonzero(w > 0)]
    if not used or not np.isfinite(d[used]).all():
        return False
    wsum = float(w[used].sum())
    dw = float(np.sum(w[used] * d[used])) / wsum
    bound = fraction * abs(scale) if math.isfinite(scale) else 0.0
    var = 0.0
    for c in used:
        seeds = np.asarray(den_seeds[c], dtype=np.float64).reshape(-1)
        seeds = seeds[np.isfinite(seeds)]
        if seeds.size < 2:
            var = NAN
            break
        var += float(w[c]) ** 2 * float(np.var(seeds, ddof=1)) / seeds.size
    if math.isfinite(var):
        bound = max(bound, k * math.sqrt(var) / wsum)
    return abs(dw) < bound or dw == 0.0


def figure_text(d: Mapping[str, Any] | None, signed: bool = True) -> str:
    """A ratio figure as table text (:func:`hil.review.kpi_stats.percent_text`), or
    :data:`BASELINE_NOISE` for a P_n without a denominator to divide by."""
    if d is not None and d.get("status") == BASELINE_NOISE:
        return BASELINE_NOISE
    return kpi_stats.percent_text(dict(d) if d is not None else None, signed=signed)


#: Minimum rotor speed Ω_min [rad/s] of the shipped turbines for Ω_opt (below it the
#: optimal-TSR speed is not reachable): IEA 15 MW DISCON VS_MinOMSpd = 0.5236 rad/s (5 rpm);
#: NREL 5 MW cut-in rotor speed 6.9 rpm = 0.7226 rad/s (jonkman-2009 table 1-1).
MIN_ROTOR_SPEED_RAD_S: dict[str, float] = {"iea15mw": 0.5236, "nrel5mw": 0.7226}


def optimal_rotor_speed_rad_s(
    wind_m_s: npt.ArrayLike,
    tsr_opt: float,
    radius_m: float,
    rated_rad_s: float,
    min_rad_s: float = 0.0,
) -> FloatArray:
    """Optimal rotor speed for maximum power at the wind ``wind_m_s``.

    .. math:: \\Omega_{opt}(U) = \\min(\\max(\\lambda^* U / R,\\ \\Omega_{min}),\\ \\Omega_{rated})

    Below rated the rotor should run at the Cp-maximising tip-speed ratio λ*; the generator's
    minimum and rated speeds bound it (above rated the optimum is the rated speed).

    Parameters
    ----------
    wind_m_s : array_like
        Rotor-effective wind speed U [m/s].
    tsr_opt : float
        Tip-speed ratio λ* of maximum Cp at fine pitch [-].
    radius_m : float
        Rotor radius R [m].
    rated_rad_s : float
        Rated rotor speed Ω_rated [rad/s].
    min_rad_s : float
        Minimum rotor speed Ω_min [rad/s].

    Returns
    -------
    ndarray
        Ω_opt [rad/s], one per wind sample.
    """
    u = np.asarray(wind_m_s, dtype=np.float64).reshape(-1)
    out: FloatArray = np.minimum(np.maximum(tsr_opt * u / radius_m, min_rad_s), rated_rad_s)
    return out


def rotor_speed_error_var_rpm2(rotor_rad_s: npt.ArrayLike, optimal_rad_s: npt.ArrayLike) -> float:
    """Variance of the rotor-speed tracking error in rpm² (al-2019 table 2-3, KPI 1.2).

    .. math:: \\mathrm{var}(\\Omega - \\Omega_{opt}) = \\frac{1}{N}\\sum_k (e_k - \\bar e)^2,
              \\quad e_k = (30/\\pi)(\\Omega_k - \\Omega_{opt,k})

    Returns ``nan`` for empty input or unequal lengths.
    """
    w = np.asarray(rotor_rad_s, dtype=np.float64).reshape(-1)
    o = np.asarray(optimal_rad_s, dtype=np.float64).reshape(-1)
    if w.size == 0 or w.size != o.size:
        return NAN
    return float(np.var((w - o) * RPM_PER_RAD_S))


def run_kpis(
    t_s: npt.ArrayLike,
    truth: Mapping[str, npt.ArrayLike],
    deadline_misses: int | None,
    tsr_opt: float,
    radius_m: float,
    rated_rad_s: float,
    min_rad_s: float,
) -> dict[str, float]:
    """The campaign KPIs (:data:`KPIS`) of one run from its truth channel.

    Parameters
    ----------
    t_s : array_like
        Sample times of the truth channel [s].
    truth : mapping
        Truth columns: ``electrical_power_w``, ``rotor_speed_rad_s``, ``wind_speed_m_s``,
        ``blade_pitch_rad``, ``tower_base_moment_nm``, ``shaft_torque_nm``,
        ``platform_pitch_rad``, ``platform_surge_m`` (SI units).
    deadline_misses : int or None
        The run's missed control periods (None: unknown -> nan).
    tsr_opt, radius_m, rated_rad_s, min_rad_s : float
        Parameters of :func:`optimal_rotor_speed_rad_s`.

    Returns
    -------
    dict
        KPI name -> value in the unit of :data:`KPIS`; ``nan`` where a channel is missing.
    """
    t = np.asarray(t_s, dtype=np.float64).reshape(-1)

    def col(name: str) -> FloatArray:
        v = truth.get(name)
        return np.asarray([] if v is None else v, dtype=np.float64).reshape(-1)

    rotor = col("rotor_speed_rad_s")
    omega_opt = optimal_rotor_speed_rad_s(
        col("wind_speed_m_s"), tsr_opt, radius_m, rated_rad_s, min_rad_s
    )
    return {
        "mean_power_w": kpi.mean_power_w(col("electrical_power_w")),
        "rotor_speed_error_var_rpm2": rotor_speed_error_var_rpm2(rotor, omega_opt),
        "rotor_speed_var_rpm2": float(np.var(rotor * RPM_PER_RAD_S)) if rotor.size else NAN,
        "tower_base_del_nm": kpi.damage_equivalent_load(
            col("tower_base_moment_nm"), t, kpi.DEL_WOHLER_M, kpi.DEL_N_EQ_HZ
        ),
        "shaft_del_nm": kpi.damage_equivalent_load(
            col("shaft_torque_nm"), t, kpi.DEL_WOHLER_M, kpi.DEL_N_EQ_HZ
        ),
        "pitch_rate_mean_abs_deg_s": kpi.pitch_travel_deg_s(t, col("blade_pitch_rad")),
        "platform_pitch_std_deg": math.degrees(kpi.std(col("platform_pitch_rad"))),
        "platform_surge_std_m": kpi.std(col("platform_surge_m")),
        "deadline_misses": NAN if deadline_misses is None else float(deadline_misses),
    }


# --------------------------------------------------------------------------- aggregation


def weibull_mean(values: Sequence[float], probabilities: Sequence[float]) -> float:
    """Occurrence-weighted mean over load cases (al-2019 section 2-3, "Weibull average").

    .. math:: X_W = \\frac{\\sum_i p_i X_i}{\\sum_i p_i}

    Parameters
    ----------
    values : sequence of float
        X_i, one per load case (any unit).
    probabilities : sequence of float
        p_i >= 0, same length, not all 0 (fractions or percent: only ratios matter).

    Returns
    -------
    float
        X_W in the unit of ``values``; ``nan`` when any X_i with p_i > 0 is not finite.

    Raises
    ------
    ValueError
        On different lengths, a negative p_i or Σ p_i = 0.
    """
    x = np.asarray(values, dtype=np.float64).reshape(-1)
    p = np.asarray(probabilities, dtype=np.float64).reshape(-1)
    if x.size != p.size:
        raise ValueError(f"{x.size} values but {p.size} probabilities")
    if (p < 0).any() or not np.isfinite(p).all():
        raise ValueError(f"probabilities must be finite and >= 0, got {p.tolist()}")
    total = float(p.sum())
    if not total > 0.0:
        raise ValueError("probabilities sum to 0")
    used = p > 0
    if not np.isfinite(x[used]).all():
        return NAN
    return float(np.sum(p[used] * x[used]) / total)


def relative(ctrl: float, base: float) -> float:
    """Relative performance X_ctrl / X_base − 1 (al-2019 figure 5-1); ``nan`` if X_base = 0."""
    if not (math.isfinite(ctrl) and math.isfinite(base)) or base == 0.0:
        return NAN
    return ctrl / base - 1.0


def normalised(ctrl: float, base: float, still: float) -> float:
    """Normalised performance, al-2019 eq. (5-1).

    .. math:: P_n = \\frac{X_{ctrl} - X_{still}}{X_{base} - X_{still}}

    1 (100 %): the baseline's performance in waves; 0: the baseline's in still water, i.e.
    the fraction of the wave-induced effect that remains. ``nan`` when the waves change
    nothing (X_base = X_still) or an input is not finite.
    """
    vals = (ctrl, base, still)
    if not all(math.isfinite(v) for v in vals) or base == still:
        return NAN
    return (ctrl - still) / (base - still)


def increment_ratio(waves: float, still: float) -> float:
    """Wave-induced increment X_waves / X_still (al-2019 table 2-5); ``nan`` if X_still = 0."""
    if not (math.isfinite(waves) and math.isfinite(still)) or still == 0.0:
        return NAN
    return waves / still


def mean_and_spread(values: Sequence[float]) -> tuple[float, float, int]:
    """Mean, sample standard deviation (ddof = 1; 0 for one value) and count of the finite
    values (``nan``, ``nan``, 0 when there are none)."""
    a = np.asarray(values, dtype=np.float64).reshape(-1)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return NAN, NAN, 0
    spread = float(np.std(a, ddof=1)) if a.size > 1 else 0.0
    return float(np.mean(a)), spread, int(a.size)


def finite_or_none(v: Any) -> Any:
    """``None`` for a non-finite float (JSON), the value otherwise."""
    return kpi.finite_or_none(v)
