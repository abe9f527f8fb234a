"""Wave forecasting (controller.forecast) and its analysis core (hil.review.forecast).

Seeded; tolerances stated per test. Reference figures: al-2019 sect. 3-4-4 (VAF 95 % at
t_d = 10 s, L = 450 m, T_s = 0.1 s), casanovas-2014 sect. 7.2.2 (AR order 24, 40 training
samples at 2 Hz predicts about 5 s), christiansen-2013 sect. 2.11 (AR(2) wave frequency).
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from controller.forecast import (
    ArConfig,
    ArForecaster,
    DispersionConfig,
    DispersionPredictor,
    EspritConfig,
    EspritForecaster,
    WaveFrequencyConfig,
    WaveFrequencyEstimator,
    group_velocity_m_s,
    make_forecaster,
    wavenumber_rad_m,
)
from hil.review.forecast import forecast_report, vaf_percent


def _vafs(report: dict) -> dict[str, float]:
    return {k: v["vaf_percent"] for k, v in report["forecasters"].items()}


def test_controller_forecast_does_not_import_plant() -> None:
    src = Path(__file__).resolve().parents[1] / "controller" / "forecast.py"
    tree = ast.parse(src.read_text())
    names = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names] + [
        n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
    ]
    assert not [m for m in names if m.split(".")[0] == "plant"]


def test_dispersion_solver_matches_plant() -> None:
    from plant.waves import wavenumber

    w = np.linspace(0.0, 3.0, 301)
    for d in (math.inf, 100.0, 20.0):
        np.testing.assert_allclose(wavenumber_rad_m(w, d), wavenumber(w, d), rtol=1e-10)
    # deep water: c_g = g / (2 ω)
    np.testing.assert_allclose(group_velocity_m_s([0.5, 1.0]), 9.80665 / np.array([1.0, 2.0]))


def test_dispersion_vaf_deep_and_finite_depth() -> None:
    """al-2019 sect. 3-4-4: VAF >= 95 % at t_d 10 s, L 450 m, H_s 2.2 m, T_p 8 s, T_s 0.1 s."""
    deep = forecast_report(duration_s=300.0, seed=3, kinds=("dispersion",))
    assert deep["forecasters"]["dispersion"]["vaf_percent"] >= 95.0
    finite = forecast_report(duration_s=300.0, seed=3, depth_m=100.0, kinds=("dispersion",))
    assert finite["forecasters"]["dispersion"]["vaf_percent"] >= 95.0


def test_dispersion_with_n_1024_is_limited_by_group_delay() -> None:
    """With al-2019's n = 1024 the FIR cannot reach components above about 1.2 rad/s.

    Their group delay L/c_g - t_d exceeds 102.4 s; JONSWAP 2.2 m / 8 s has 12 % of its
    variance there, so the VAF stays below 90 % (measured about 84 %).
    """
    r = forecast_report(duration_s=300.0, seed=3, kinds=("dispersion",), n_taps=1024)
    d = r["forecasters"]["dispersion"]
    assert d["band_rad_s"][1] < 1.25
    assert 70.0 < d["vaf_percent"] < 90.0


def test_dispersion_causality_check() -> None:
    # L / c_g,max at the band's low edge 2π·0.05 rad/s, deep water: 2 ω L / g = 28.8 s
    with pytest.raises(ValueError, match="not causal"):
        DispersionPredictor(DispersionConfig(horizon_s=30.0))
    DispersionPredictor(DispersionConfig(horizon_s=28.0, n_taps=4096))


def test_dispersion_fir_matches_ideal_in_band() -> None:
    p = DispersionPredictor(DispersionConfig())
    lo, hi = p.band_rad_s
    # the Tukey tapers at both ends of the FIR cut the smallest and largest group delays, so the
    # error grows towards the band edges (0.10 at lo + 0.1, 0.16 at hi - 0.1 rad/s); in the
    # energetic part of the band it is below 5 % of |H_d| = 1
    w = np.linspace(lo + 0.3, hi - 0.5, 50)
    err = np.abs(p.frequency_response(w) - p.ideal_response(w))
    assert float(np.max(err)) < 0.05


def test_ar_casanovas_setup_band_limited_sea() -> None:
    """casanovas-2014 sect. 7.2.2: order 24, 40 samples at 2 Hz, 5 s ahead; VAF >= 90 %.

    Their record is noise-free and band-limited to 2 rad/s; with that synthesis the literal
    setup reaches it (measured 99.8 %).
    """
    r = forecast_report(
        duration_s=200.0, seed=1, kinds=("ar",), local_horizon_s=5.0, omega_max_rad_s=2.0
    )
    assert r["forecasters"]["ar"]["vaf_percent"] >= 90.0


def test_ar_literal_setup_fails_on_wider_band_or_noise() -> None:
    """Characterisation, not a target: the same AR fails on the plant's 3 rad/s band or 1 cm noise.

    The 40 x 24 least squares on an oversampled band-limited record is ill-conditioned (forecast
    weight norms 1e8-1e9), so energy near 3 rad/s or any sensor noise ruins the extrapolation.
    """
    wide = forecast_report(duration_s=200.0, seed=1, kinds=("ar",), local_horizon_s=5.0)
    noisy = forecast_report(
        duration_s=200.0,
        seed=1,
        kinds=("ar",),
        local_horizon_s=5.0,
        omega_max_rad_s=2.0,
        noise_m=0.01,
    )
    assert wide["forecasters"]["ar"]["vaf_percent"] < 90.0
    assert noisy["forecasters"]["ar"]["vaf_percent"] < 90.0


def test_esprit_sanity() -> None:
    """ESPRIT (casanovas sect. 7.3) as the seed has it (raw fit, ``stabilise=False``) on the
    2 rad/s band-limited noise-free sea: VAF >= 90 % at 5 s. The stabilised runtime default
    loses most of it there (measured 28 %: the seed's growing/decaying pairs describe the
    beating) but stays bounded, which is what the runtime needs on real seas."""
    kw = {"duration_s": 200.0, "seed": 1, "kinds": ("esprit",), "local_horizon_s": 5.0}
    r = forecast_report(omega_max_rad_s=2.0, stabilise=False, **kw)  # type: ignore[arg-type]
    e = r["forecasters"]["esprit"]
    assert e["vaf_percent"] >= 90.0
    assert math.isfinite(e["vaf_percent"])
    assert e["unstable_fits"] == 0  # the raw fit is not checked
    s = forecast_report(omega_max_rad_s=2.0, **kw)["forecasters"]["esprit"]  # type: ignore[arg-type]
    assert s["unstable_fits"] > 0
    assert s["vaf_percent"] > 0.0
    assert s["max_abs_forecast_m"] <= 1.5 * s["max_abs_truth_m"]


#: Sea states H_s 1-8 m, T_p 6-14 s: the corners and one inside.
_SEAS = [(1.0, 6.0), (8.0, 14.0), (4.3, 10.0)]


@pytest.mark.parametrize("kind", ["ar", "esprit"])
def test_ar_esprit_bounded_on_noisy_seas(kind: str) -> None:
    """AR and ESPRIT never return unbounded forecasts (gauge at the platform, own
    past, horizon 8 s, 0.02 m seeded sensor noise, 120 s evaluated).

    Before the stability check the measured VAF was -59 226 % (AR) and -414 % (ESPRIT) at
    H_s 4.3 m, T_p 10 s. Now: every forecast within 1.5x the largest true elevation (the
    guard's hard limit is 3x the window's), VAF above -60 % (an 8 s own-past forecast has
    little skill at T_p 6 s; measured on the full grid, ``bench/forecast_grid.py``: see
    docs/guide/controllers.md), and the stabilised fits are counted.
    """
    for hs, tp in _SEAS:
        r = forecast_report(
            hs_m=hs,
            tp_s=tp,
            distance_m=300.0,
            horizon_s=8.0,
            duration_s=120.0,
            kinds=(kind,),
            noise_m=0.02,
        )
        e = r["forecasters"][kind]
        msg = f"{kind} Hs {hs} Tp {tp}: {e}"
        assert math.isfinite(e["vaf_percent"]), msg
        assert e["vaf_percent"] > -60.0, msg
        assert e["max_abs_forecast_m"] <= 1.5 * e["max_abs_truth_m"], msg
        assert e["unstable_fits"] > 0, msg  # the check acted and was counted


def test_raw_ar_diverges_where_the_stabilised_one_does_not() -> None:
    """The seed's raw least-squares AR on a heavy sea (H_s 4.3 m, T_p 10 s, 8 s ahead)
    is unbounded (VAF far below -100 %); the same fits stabilised are not."""
    kw = {"hs_m": 4.3, "tp_s": 10.0, "distance_m": 300.0, "horizon_s": 8.0}
    raw = forecast_report(duration_s=120.0, kinds=("ar",), stabilise=False, **kw)  # type: ignore[arg-type]
    ok = forecast_report(duration_s=120.0, kinds=("ar",), **kw)  # type: ignore[arg-type]
    assert raw["forecasters"]["ar"]["vaf_percent"] < -100.0
    assert ok["forecasters"]["ar"]["vaf_percent"] > -60.0


def test_stability_check_reflects_growing_poles_and_guard_counts() -> None:
    """A growing sinusoid (|z| = 1.02 per 0.5 s sample) fits an AR/ESPRIT model with poles
    outside the unit circle: the check reflects them (counted), so the forecast decays instead
    of growing; a guard factor below the forecast's size replaces it by 0 m (counted)."""
    dt = 0.1
    t = np.arange(1200) * dt
    y = np.exp(0.04 * t) * np.cos(0.8 * t) * 0.01
    for cls, cfg_t in ((ArForecaster, ArConfig), (EspritForecaster, EspritConfig)):
        fc = cls(cfg_t(horizon_s=5.0))  # type: ignore[operator]
        st = fc.init_state()
        out = np.empty(y.size)
        for i in range(y.size):
            st, out[i] = fc.step(st, float(y[i]), True)
        assert st.unstable_fits > 0, cls
        # bounded: never above the newest amplitude (a growing model would forecast 1.22x it)
        assert float(np.max(np.abs(out[-200:]))) <= float(np.max(np.abs(y[-200:]))), cls
        raw = cls(cfg_t(horizon_s=5.0, stabilise=False))  # type: ignore[operator]
        st_r = raw.init_state()
        for i in range(y.size):
            st_r, _ = raw.step(st_r, float(y[i]), True)
        assert st_r.unstable_fits == 0
    guarded = ArForecaster(ArConfig(horizon_s=5.0, bound_factor=1e-3))
    st = guarded.init_state()
    outs = [guarded.step(st, float(v), True)[1] for v in y]
    assert st.guarded > 0
    assert outs[-1] == 0.0


def test_esprit_recovers_sinusoids_exactly() -> None:
    dt = 0.5
    t = np.arange(80) * dt
    w = np.array([0.4, 0.9, 1.5])
    y = np.cos(np.outer(t, w) + np.arange(3)).sum(axis=1)
    z = EspritForecaster(EspritConfig(dt_s=dt)).exponentials(y)
    np.testing.assert_allclose(np.sort(np.abs(np.angle(z))) / dt, np.repeat(w, 2), atol=1e-8)


def test_wave_frequency_pure_sinusoid_within_1_percent() -> None:
    est = WaveFrequencyEstimator(WaveFrequencyConfig(dt_s=0.1, sample_period_s=0.5))
    st = est.init_state()
    w0 = 0.7
    omega = 0.0
    for i in range(3000):
        st, omega = est.step(st, 1.3 * math.cos(w0 * i * 0.1 + 0.4))
    assert abs(omega - w0) / w0 < 0.01


def test_wave_frequency_irregular_sea_near_zero_crossing_frequency() -> None:
    """AR(2) LS on an irregular sea tracks about √(m2/m0), 1.2-1.3 ω_p for JONSWAP γ 3.3.

    Tolerance: within 15 % of √(m2/m0) of the synthesised components, and within
    [ω_p, 1.6 ω_p].
    """
    from plant.waves import JonswapSpectrum, synthesize

    field = synthesize(JonswapSpectrum(2.2, 8.0), seed=2)
    a2, w = field.amplitude_m**2, field.omega_rad_s
    w_z = math.sqrt(float(np.sum(a2 * w**2) / np.sum(a2)))
    y = field.series(0.0, 0.1, 12000)
    est = WaveFrequencyEstimator()
    st = est.init_state()
    tail = []
    for i, v in enumerate(y):
        st, omega = est.step(st, float(v))
        if i > 6000:
            tail.append(omega)
    mean = float(np.mean(tail))
    wp = 2.0 * math.pi / 8.0
    assert abs(mean - w_z) / w_z < 0.15
    assert wp <= mean <= 1.6 * wp


@pytest.mark.parametrize("kind", ["dispersion", "ar", "esprit"])
def test_dropouts_do_not_crash_or_blow_up(kind: str) -> None:
    from plant.waves import JonswapSpectrum, synthesize

    field = synthesize(JonswapSpectrum(2.2, 8.0), seed=4, omega_max_rad_s=2.0)
    y = field.series(0.0, 0.1, 3000)
    rng = np.random.default_rng(0)
    valid = rng.random(y.size) > 0.2
    y_in = np.where(valid, y, np.nan)
    cfg = {
        "dispersion": DispersionConfig(),
        "ar": ArConfig(horizon_s=5.0),
        "esprit": EspritConfig(horizon_s=5.0),
    }[kind]
    fc = make_forecaster(kind, cfg)
    st = fc.init_state()
    out = np.empty(y.size)
    for i in range(y.size):
        st, out[i] = fc.step(st, float(y_in[i]), bool(valid[i]))
    assert np.all(np.isfinite(out))
    assert float(np.max(np.abs(out))) < 10.0 * 2.2
    assert st.dropped == int(np.count_nonzero(~valid))


def test_same_seed_same_result() -> None:
    a = forecast_report(duration_s=100.0, seed=7, local_horizon_s=5.0, n_taps=1024)
    b = forecast_report(duration_s=100.0, seed=7, local_horizon_s=5.0, n_taps=1024)
    assert _vafs(a) == _vafs(b)


def test_report_is_json_serialisable() -> None:
    import json

    r = forecast_report(duration_s=50.0, seed=1, kinds=("dispersion",), n_taps=512, horizon_s=5.0)
    json.dumps(r, allow_nan=True)


def test_configs_validate_with_units() -> None:
    with pytest.raises(ValueError, match=r"distance_m.*m"):
        DispersionConfig(distance_m=-1.0)
    with pytest.raises(ValueError, match="integer multiple"):
        ArConfig(sample_period_s=0.25, dt_s=0.1)
    with pytest.raises(ValueError, match="n_train"):
        ArConfig(order=24, n_train=10)
    with pytest.raises(ValueError, match="pencil"):
        EspritConfig(n_half=10, pencil=30)
    with pytest.raises(ValueError, match="forgetting_factor"):
        WaveFrequencyConfig(forgetting_factor=1.5)
    with pytest.raises(ValueError, match="kind"):
        make_forecaster("kalman")
    with pytest.raises(ValueError, match="ArConfig"):
        make_forecaster("ar", EspritConfig())
    with pytest.raises(ValueError, match="bound_factor"):
        ArConfig(bound_factor=0.0)
    with pytest.raises(ValueError, match="stabilise"):
        EspritConfig(stabilise="yes")  # type: ignore[arg-type]


def test_vaf_definition() -> None:
    y = np.sin(np.linspace(0, 20, 500))
    assert vaf_percent(y, y) == pytest.approx(100.0)
    assert vaf_percent(y, np.zeros_like(y)) == pytest.approx(0.0, abs=1e-9)
    assert isinstance(ArForecaster(ArConfig()).horizon_s, float)
