"""Core of ``fowt analyze forecast``: VAF of the wave forecasters on a seeded wave field.

A seeded JONSWAP field (``plant.waves.synthesize``) gives the gauge elevation L metres up-wave
and the platform elevation; each forecaster of :mod:`controller.forecast` is run sample by
sample through its runtime ``step`` (the code the controller runs), and its forecast for
t + horizon is compared with the true platform elevation at t + horizon by the variance
accounted for (al-2019 eq. 3-24),

    VAF = (1 - var(y - ŷ)/var(y)) · 100 %,

over the samples after the forecaster has filled (dispersion: n_taps samples; AR/ESPRIT:
the first fit) plus a settling margin.

What each forecaster sees:

* ``dispersion`` (al-2019 sect. 3-4): the up-wave **gauge** at ``dt_s``;
* ``ar`` and ``esprit`` (casanovas-2014 ch. 7): the **platform** elevation's own past (the
  local wave elevation, as in the seed), called at ``dt_s`` and modelled at 2 Hz
  (``model_period_s`` = 0.5 s, casanovas sect. 7.2.2).

Everything returned is plain JSON (floats, ints, strings, lists, dicts).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from controller.forecast import (
    ArConfig,
    DispersionConfig,
    DispersionPredictor,
    EspritConfig,
    make_forecaster,
)
from plant.waves import JonswapSpectrum, synthesize

__all__ = ["GRID_HS_M", "GRID_TP_S", "forecast_grid", "forecast_report", "vaf_percent"]

_KINDS = ("dispersion", "ar", "esprit")


def vaf_percent(y: Any, y_hat: Any) -> float:
    """Variance accounted for (%), al-2019 eq. (3-24): (1 - var(y - ŷ)/var(y)) · 100."""
    ya = np.asarray(y, dtype=np.float64)
    yh = np.asarray(y_hat, dtype=np.float64)
    v = float(np.var(ya))
    if ya.size == 0 or v == 0.0:
        return math.nan
    return (1.0 - float(np.var(ya - yh)) / v) * 100.0


def forecast_report(
    hs_m: float = 2.2,
    tp_s: float = 8.0,
    distance_m: float = 450.0,
    horizon_s: float = 10.0,
    dt_s: float = 0.1,
    duration_s: float = 600.0,
    seed: int = 1,
    depth_m: float = math.inf,
    kinds: Sequence[str] = _KINDS,
    *,
    n_taps: int = 2048,
    local_horizon_s: float | None = None,
    model_period_s: float = 0.5,
    noise_m: float = 0.0,
    gamma: float = 3.3,
    omega_max_rad_s: float = 3.0,
    stabilise: bool = True,
) -> dict[str, Any]:
    """Simulate a seeded sea and return each forecaster's VAF at its horizon.

    Parameters
    ----------
    hs_m, tp_s : float
        JONSWAP H_s (m) and T_p (s) (al-2019 load case 3: 2.2 m, 8 s).
    distance_m : float
        Gauge distance L up-wave (m).
    horizon_s : float
        Prediction horizon t_d (s) of the dispersion predictor.
    dt_s : float
        Sample and call period (s).
    duration_s : float
        Evaluated duration (s) after the dispersion filter has filled (al-2019: 600 s).
    seed : int
        Wave-field seed (>= 0); the noise uses ``seed + 1``.
    depth_m : float
        Water depth (m), ``math.inf`` for deep water; the field and the design use it.
    kinds : sequence of str
        Forecasters to run, from ``("dispersion", "ar", "esprit")``.
    n_taps : int, keyword-only
        Dispersion FIR length (samples).
    local_horizon_s : float, optional, keyword-only
        Horizon (s) of the AR and ESPRIT forecasters; default ``horizon_s``
        (casanovas-2014's AR reaches about 5 s).
    model_period_s : float, keyword-only
        AR/ESPRIT model sample period (s); 0.5 s is casanovas' 2 Hz.
    noise_m : float, keyword-only
        Standard deviation (m) of white noise added to the measured elevations (0: none).
    gamma : float, keyword-only
        JONSWAP peak factor (-).
    omega_max_rad_s : float, keyword-only
        Upper edge (rad/s) of the synthesised wave band (the plant's default 3 rad/s).
    stabilise : bool, keyword-only
        AR/ESPRIT stability check (poles outside the unit circle reflected, the runtime's
        default); False runs the seeds' raw fits.

    Returns
    -------
    dict
        ``{"sea_state": {...}, "forecasters": {kind: {"vaf_percent", "horizon_s", "input",
        "sample_period_s", "evaluated_samples", "mean_step_us", ...}}}``.
    """
    bad = [k for k in kinds if k not in _KINDS]
    if bad:
        raise ValueError(f"forecast_report: unknown kinds {bad}, expected some of {_KINDS}")
    if not (math.isfinite(duration_s) and duration_s > 0.0):
        raise ValueError(f"forecast_report: duration_s = {duration_s!r}, expected > 0 s")
    if noise_m < 0.0 or not math.isfinite(noise_m):
        raise ValueError(f"forecast_report: noise_m = {noise_m!r}, expected >= 0 m")
    local_h = horizon_s if local_horizon_s is None else float(local_horizon_s)

    field = synthesize(
        JonswapSpectrum(hs_m, tp_s, gamma),
        depth_m=depth_m,
        seed=seed,
        omega_max_rad_s=omega_max_rad_s,
    )
    fill_s = n_taps * dt_s
    n = round((fill_s + duration_s) / dt_s)
    lead = round(max(horizon_s, local_h) / dt_s) + 1
    xg, yg = field.up_wave_point(distance_m)
    gauge = field.series(0.0, dt_s, n, xg, yg)
    platform = field.series(0.0, dt_s, n + lead)
    rng = np.random.default_rng(seed + 1)
    gauge_meas = gauge + noise_m * rng.standard_normal(n) if noise_m > 0.0 else gauge
    plat_meas = platform[:n] + noise_m * rng.standard_normal(n) if noise_m > 0.0 else platform[:n]

    out: dict[str, Any] = {
        "sea_state": {
            "spectrum": "JONSWAP",
            "hs_m": float(hs_m),
            "tp_s": float(tp_s),
            "gamma": float(gamma),
            "depth_m": "inf" if math.isinf(depth_m) else float(depth_m),
            "seed": int(seed),
            "omega_band_rad_s": [0.1, float(omega_max_rad_s)],
            "noise_m": float(noise_m),
            "stabilise": bool(stabilise),
            "distance_m": float(distance_m),
            "dt_s": float(dt_s),
            "duration_s": float(duration_s),
            "evaluation_starts_s": float(fill_s),
        },
        "forecasters": {},
    }
    start = round(fill_s / dt_s)
    for kind in kinds:
        entry: dict[str, Any]
        if kind == "dispersion":
            cfg_d = DispersionConfig(
                distance_m=distance_m,
                horizon_s=horizon_s,
                dt_s=dt_s,
                n_taps=n_taps,
                depth_m=depth_m,
            )
            fc: Any = DispersionPredictor(cfg_d)
            series, h = gauge_meas, horizon_s
            entry = {
                "input": "up-wave gauge",
                "sample_period_s": float(dt_s),
                "n_taps": int(n_taps),
                "band_rad_s": [float(b) for b in fc.band_rad_s],
                "truncated_energy_fraction": float(fc.truncated_energy_fraction),
            }
        else:  # "ar" or "esprit": the platform elevation from its own past
            config_type = ArConfig if kind == "ar" else EspritConfig
            cfg = config_type(
                sample_period_s=model_period_s, dt_s=dt_s, horizon_s=local_h, stabilise=stabilise
            )
            fc = make_forecaster(kind, cfg)
            series, h = plat_meas, local_h
            entry = {
                "input": "platform elevation, own past",
                "sample_period_s": float(model_period_s),
            }
            if isinstance(cfg, ArConfig):
                entry.update(order=cfg.order, n_train=cfg.n_train)
            else:
                entry.update(n_half=cfg.n_half, pencil=cfg.pencil)
        state = fc.init_state()
        forecast = np.empty(n)
        t0 = time.perf_counter()
        for i in range(n):
            state, forecast[i] = fc.step(state, float(series[i]), True)
        elapsed = time.perf_counter() - t0
        k = round(h / dt_s)
        truth = platform[start + k : n + k]
        entry.update(
            {
                "horizon_s": float(h),
                "vaf_percent": vaf_percent(truth, forecast[start:n]),
                "evaluated_samples": int(n - start),
                "mean_step_us": elapsed / n * 1e6,
                "trainings": int(state.trainings),
                "rejected_fits": int(state.rejected),
                "unstable_fits": int(getattr(state, "unstable_fits", 0)),
                "guarded_forecasts": int(getattr(state, "guarded", 0)),
                "max_abs_forecast_m": float(np.max(np.abs(forecast[start:n]))),
                "max_abs_truth_m": float(np.max(np.abs(truth))),
            }
        )
        out["forecasters"][kind] = entry
    return out


#: Sea states of :func:`forecast_grid` (H_s 1-8 m, T_p 6-14 s).
GRID_HS_M = (1.0, 2.0, 4.0, 6.0, 8.0)
GRID_TP_S = (6.0, 8.0, 10.0, 12.0, 14.0)


def forecast_grid(
    hs_m: Sequence[float] = GRID_HS_M,
    tp_s: Sequence[float] = GRID_TP_S,
    distance_m: float = 300.0,
    horizon_s: float = 8.0,
    duration_s: float = 300.0,
    noise_m: float = 0.02,
    seed: int = 1,
    kinds: Sequence[str] = _KINDS,
) -> dict[str, Any]:
    """VAF (%) of each forecaster over a grid of JONSWAP sea states, with sensor noise.

    Runs :func:`forecast_report` for every (H_s, T_p) (same seed, noise seeded ``seed + 1``;
    the gauge channel's noise of the shipped scenarios is σ = 0.02 m) and tabulates the VAF,
    the stabilised fits and guarded forecasts of AR and ESPRIT, and the largest |forecast|
    against the largest |truth| (a bounded forecaster keeps their ratio near 1).

    Returns
    -------
    dict
        ``{"settings": {...}, "rows": [{"hs_m", "tp_s", kind: {"vaf_percent",
        "unstable_fits", "guarded_forecasts", "trainings", "max_ratio"}}...],
        "min_vaf_percent": {kind: float}}``.
    """
    rows: list[dict[str, Any]] = []
    for hs in hs_m:
        for tp in tp_s:
            r = forecast_report(
                hs_m=hs,
                tp_s=tp,
                distance_m=distance_m,
                horizon_s=horizon_s,
                duration_s=duration_s,
                seed=seed,
                kinds=kinds,
                noise_m=noise_m,
            )
            row: dict[str, Any] = {"hs_m": float(hs), "tp_s": float(tp)}
            for kind, e in r["forecasters"].items():
                row[kind] = {
                    "vaf_percent": e["vaf_percent"],
                    "trainings": e.get("trainings", 0),
                    "unstable_fits": e.get("unstable_fits", 0),
                    "guarded_forecasts": e.get("guarded_forecasts", 0),
                    "max_ratio": e["max_abs_forecast_m"] / e["max_abs_truth_m"],
                }
            rows.append(row)
    return {
        "settings": {
            "distance_m": float(distance_m),
            "horizon_s": float(horizon_s),
            "duration_s": float(duration_s),
            "noise_m": float(noise_m),
            "seed": int(seed),
            "spectrum": "JONSWAP gamma 3.3, deep water",
        },
        "rows": rows,
        "min_vaf_percent": {k: min(row[k]["vaf_percent"] for row in rows) for k in kinds},
    }
