"""Tests of the IEC turbulence (plant.turbulence) and the TurbulentWind / GustWind specs of
plant.wind: statistics, spectrum shape, rotor averaging, determinism, EOG values, lookups."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import minimize_scalar
from scipy.signal import welch

from plant.turbulence import (
    eog_gust_amplitude,
    kaimal_length_m,
    kaimal_spectrum,
    ntm_sigma,
    rotor_average_factor,
    turbulence_fft_length,
)
from plant.wind import (
    GustWind,
    RampWind,
    SteadyWind,
    StepWind,
    TurbulentWind,
    WindSpec,
    make_wind_function,
    wind_speed,
)

U, HUB, R = 11.4, 90.0, 63.0  # NREL 5 MW at rated wind


def _turbulent(seed: int = 1, radius: float = 0.0, duration: float = 10_800.0) -> TurbulentWind:
    return TurbulentWind(U, "B", seed, HUB, radius, duration, 0.1)


# ---------------------------------------------------------------------- models
def test_ntm_sigma_and_lengths() -> None:
    assert ntm_sigma(U, "A") == pytest.approx(0.16 * (0.75 * U + 5.6), rel=1e-15)
    assert ntm_sigma(10.0, "B") == pytest.approx(0.14 * 13.1, rel=1e-15)
    assert ntm_sigma(10.0, "C") == pytest.approx(0.12 * 13.1, rel=1e-15)
    assert ntm_sigma(10.0, "A+") == pytest.approx(0.18 * 13.1, rel=1e-15)
    assert kaimal_length_m(90.0) == pytest.approx(8.1 * 42.0, rel=1e-15)  # Λ1 = 0.7 · 60 m
    assert kaimal_length_m(40.0) == pytest.approx(8.1 * 28.0, rel=1e-15)  # Λ1 = 0.7 z_hub
    with pytest.raises(ValueError, match=r"turbulence_class = 'D': expected one of"):
        ntm_sigma(10.0, "D")


def test_kaimal_integrates_to_sigma_squared() -> None:
    sigma = ntm_sigma(U, "B")
    total = sum(
        quad(lambda f: float(kaimal_spectrum(f, U, sigma, HUB)), a, b, limit=200)[0]
        for a, b in itertools.pairwise((0.0, 0.01, 0.1, 1.0, 10.0, math.inf))
    )
    assert total == pytest.approx(sigma**2, rel=1e-6)


def test_rotor_average_factor_against_monte_carlo() -> None:
    # independent check of the disc-distance quadrature: draw point pairs in the disc
    rng = np.random.default_rng(0)
    n = 200_000
    rad = R * np.sqrt(rng.uniform(size=(2, n)))
    ang = rng.uniform(0, 2 * math.pi, size=(2, n))
    x, y = rad * np.cos(ang), rad * np.sin(ang)
    d = np.hypot(x[0] - x[1], y[0] - y[1])
    lc = kaimal_length_m(HUB)
    f = np.array([0.0, 0.01, 0.05, 0.2])
    factor = rotor_average_factor(f, U, R, HUB)
    for fi, fac in zip(f, factor, strict=True):
        coh = np.exp(-12 * np.sqrt((fi * d / U) ** 2 + (0.12 * d / lc) ** 2))
        # Monte Carlo: within 4 standard errors (0.2 % at f = 0, 1.1 % at 0.2 Hz)
        assert abs(fac - float(coh.mean())) < 4 * float(coh.std()) / math.sqrt(n)

        # adaptive quadrature of the textbook disc-distance density: within 1e-8
        def integrand(r: float, fi: float = float(fi)) -> float:
            s = r / (2 * R)
            density = 4 * r / (math.pi * R**2) * (math.acos(s) - s * math.sqrt(1 - s * s))
            return density * math.exp(-12 * math.hypot(fi * r / U, 0.12 * r / lc))

        assert fac == pytest.approx(quad(integrand, 0, 2 * R, epsabs=1e-14)[0], rel=1e-8)
    assert np.all(np.diff(factor) < 0) and 0 < factor[-1] < factor[0] < 1
    np.testing.assert_array_equal(rotor_average_factor(f, U, 0.0, HUB), np.ones(4))


def test_fft_length_is_even_5_smooth_and_covers_duration() -> None:
    for duration, dt in [(600.0, 0.05), (1234.5, 0.1), (3.0, 1.0), (10_800.0, 0.1)]:
        n = turbulence_fft_length(duration, dt)
        assert n * dt >= duration - 1e-9 and n % 2 == 0
        m = n
        for p in (2, 3, 5):
            while m % p == 0:
                m //= p
        assert m == 1
    assert turbulence_fft_length(10_800.0, 0.1) == 108_000


# ---------------------------------------------------------------------- turbulent wind
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_point_turbulence_statistics(seed: int) -> None:
    wind = _turbulent(seed)  # 3 h at 0.1 s, point wind
    u = wind.samples_m_s
    assert wind.sigma_m_s == pytest.approx(ntm_sigma(U, "B"), rel=1e-15)
    assert float(np.mean(u)) == pytest.approx(U, rel=0.01)
    # measured -0.8 %: the Kaimal variance below 1/(3 h) and above 5 Hz is not synthesised
    assert float(np.std(u)) == pytest.approx(wind.sigma_m_s, rel=0.05)


@pytest.mark.parametrize("radius", [0.0, R])
def test_turbulence_psd_follows_kaimal_times_rotor_filter(radius: float) -> None:
    wind = _turbulent(seed=4, radius=radius)
    f, p = welch(wind.samples_m_s, fs=10.0, nperseg=8192)
    s = kaimal_spectrum(f, U, wind.sigma_m_s, HUB) * rotor_average_factor(f, U, radius, HUB)
    # 8 log-spaced bands over 0.005-2 Hz: each band's energy within 15 % (measured <= 8 %)
    for lo, hi in itertools.pairwise(np.geomspace(0.005, 2.0, 9)):
        band = (f >= lo) & (f < hi)
        assert p[band].sum() == pytest.approx(s[band].sum(), rel=0.15)


def test_rotor_averaging_reduces_the_variance_as_predicted() -> None:
    point, rotor = _turbulent(radius=0.0), _turbulent(radius=R)
    fk = np.fft.rfftfreq(rotor.samples_m_s.size, rotor.dt_s)[1:-1]
    predicted = np.sum(
        kaimal_spectrum(fk, U, rotor.sigma_m_s, HUB) * rotor_average_factor(fk, U, R, HUB)
    ) * (fk[1] - fk[0])
    assert float(np.var(rotor.samples_m_s)) == pytest.approx(predicted, rel=1e-9)
    ratio = float(np.std(rotor.samples_m_s) / np.std(point.samples_m_s))
    assert 0.6 < ratio < 0.75  # measured 0.68 for a 126 m rotor at 11.4 m/s


def test_same_seed_same_series_different_seed_different() -> None:
    a, b, c = _turbulent(7, duration=600.0), _turbulent(7, duration=600.0), _turbulent(8, 0, 600.0)
    np.testing.assert_array_equal(a.samples_m_s, b.samples_m_s)
    assert a == b and hash(a) == hash(b) and a != c
    assert float(np.max(np.abs(a.samples_m_s - c.samples_m_s))) > 1.0
    assert np.corrcoef(a.samples_m_s, c.samples_m_s)[0, 1] < 0.5


def test_lookup_interpolates_and_wraps() -> None:
    wind = _turbulent(5, duration=600.0)
    u, dt, period = wind.samples_m_s, wind.dt_s, wind.period_s
    assert period == pytest.approx(600.0, rel=1e-12)
    for j in (0, 1, 17, 5999):
        assert wind_speed(j * dt, wind) == pytest.approx(u[j], rel=1e-12)
    assert wind_speed(17.5 * dt, wind) == pytest.approx(0.5 * (u[17] + u[18]), rel=1e-12)
    # periodic: continuous across the end, and t outside [0, N Δt) wraps
    assert wind_speed(period - 0.5 * dt, wind) == pytest.approx(0.5 * (u[-1] + u[0]), rel=1e-12)
    assert wind_speed(period + 3.3, wind) == pytest.approx(wind_speed(3.3, wind), rel=1e-9)
    assert wind_speed(-0.2, wind) == pytest.approx(u[-2], rel=1e-9)
    with pytest.raises(ValueError, match="read-only"):
        wind.samples_m_s[0] = 0.0


def test_low_mean_turbulence_is_clipped_at_zero() -> None:
    wind = TurbulentWind(0.5, "A", 1, HUB, 0.0, 600.0, 0.1)
    assert float(np.min(wind.samples_m_s)) == 0.0


def test_turbulent_wind_validation() -> None:
    with pytest.raises(ValueError, match=r"mean_m_s = 0.0: expected m/s in \(0, 100\]"):
        TurbulentWind(0.0, "B", 1, HUB, 0.0, 600.0, 0.1)
    with pytest.raises(ValueError, match=r"turbulence_class = 'E': expected one of"):
        TurbulentWind(U, "E", 1, HUB, 0.0, 600.0, 0.1)
    with pytest.raises(ValueError, match=r"seed = -3: expected an integer >= 0"):
        TurbulentWind(U, "B", -3, HUB, 0.0, 600.0, 0.1)
    with pytest.raises(ValueError, match=r"rotor_radius_m = 100.0: expected m in \[0, hub"):
        TurbulentWind(U, "B", 1, HUB, 100.0, 600.0, 0.1)
    with pytest.raises(ValueError, match=r"dt_s = 0: expected a finite value > 0 s"):
        TurbulentWind(U, "B", 1, HUB, 0.0, 600.0, 0)
    with pytest.raises(ValueError, match="expected at most"):
        TurbulentWind(U, "B", 1, HUB, 0.0, 1e9, 0.01)


# ---------------------------------------------------------------------- gust
def test_eog_amplitude_both_branches() -> None:
    # NREL 5 MW, class I B: σ1 = 0.14 (0.75·11.4 + 5.6), Λ1 = 42 m, D = 126 m
    sigma = 0.14 * (0.75 * U + 5.6)
    expected = min(1.35 * (0.8 * 1.4 * 50.0 - U), 3.3 * sigma / (1 + 0.1 * 126.0 / 42.0))
    assert eog_gust_amplitude(U, "I", "B", 126.0, 90.0) == pytest.approx(expected, rel=1e-14)
    assert expected == pytest.approx(5.0287, abs=1e-4)
    # near V_e1 the first branch binds: class III, V_e1 = 42 m/s
    assert eog_gust_amplitude(40.0, "III", "A", 126.0, 90.0) == pytest.approx(2.7, rel=1e-12)
    with pytest.raises(ValueError, match=r"turbine_class = 'IV': expected one of"):
        eog_gust_amplitude(U, "IV", "B", 126.0, 90.0)


def test_eog_extremes_and_duration() -> None:
    gust = GustWind(U, start_s=20.0)
    vg, period = gust.gust_m_s, gust.period_s
    assert period == 10.5
    # maximum V_hub + 0.74 V_gust at t0 + T/2 (shape minimum -2: sin = -1, 1 - cos = 2)
    assert wind_speed(20.0 + period / 2, gust) == pytest.approx(U + 0.74 * vg, rel=1e-14)
    # dips: maximise the shape independently with scipy on (0, T/3)
    res = minimize_scalar(
        lambda t: -math.sin(3 * math.pi * t / period) * (1 - math.cos(2 * math.pi * t / period)),
        bounds=(0.0, period / 3),
        method="bounded",
        options={"xatol": 1e-10},
    )
    g_max = -float(res.fun)
    assert g_max == pytest.approx(0.72449, abs=1e-5)
    assert res.x / period == pytest.approx(0.23406, abs=1e-5)
    t = np.linspace(0.0, 60.0, 120_001)  # 0.5 ms grid
    v = np.array([wind_speed(ti, gust) for ti in t])
    assert v.max() == pytest.approx(U + 0.74 * vg, rel=1e-12)
    assert v.min() == pytest.approx(U - 0.37 * vg * g_max, rel=1e-6)
    first_half = t < 20.0 + period / 2  # two symmetric dips; look at the first
    assert t[first_half][np.argmin(v[first_half])] == pytest.approx(20.0 + res.x, abs=1e-3)
    # V_hub outside [t0, t0 + T]: the disturbance lasts exactly T
    moving = t[np.abs(v - U) > 1e-12]
    assert moving.min() == pytest.approx(20.0, abs=1e-3)
    assert moving.max() == pytest.approx(20.0 + period, abs=1e-3)


def test_gust_validation() -> None:
    with pytest.raises(ValueError, match=r"GustWind.turbine_class = 'X': expected one of"):
        GustWind(U, 0.0, turbine_class="X")
    with pytest.raises(ValueError, match=r"GustWind.start_s = -1.0: expected a finite time"):
        GustWind(U, -1.0)


# ---------------------------------------------------------------------- wind function
def test_make_wind_function_matches_wind_speed() -> None:
    specs: list[WindSpec] = [
        SteadyWind(8.0),
        StepWind(8.0, 12.0, 5.0),
        RampWind(8.0, 12.0, 10.0, 20.0),
        _turbulent(9, duration=120.0),
        GustWind(U, 3.0),
    ]
    times = np.linspace(-1.0, 130.0, 2001)
    for spec in specs:
        fn = make_wind_function(spec)
        assert [fn(float(t)) for t in times] == [wind_speed(float(t), spec) for t in times]
