"""KPI functions of :mod:`hil.review.kpi` against analytic values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.review import kpi


def test_latency_percentiles_match_numpy_on_seeded_sample() -> None:
    rng = np.random.default_rng(1234)
    lat_ns = rng.lognormal(mean=np.log(200e3), sigma=0.4, size=20_000)
    got = kpi.latency_percentiles_us(lat_ns)
    us = lat_ns / 1e3
    assert got["p50"] == pytest.approx(np.percentile(us, 50), rel=1e-12)
    assert got["p99"] == pytest.approx(np.percentile(us, 99), rel=1e-12)
    assert got["p999"] == pytest.approx(np.percentile(us, 99.9), rel=1e-12)
    assert got["max"] == pytest.approx(us.max(), rel=1e-12)
    assert got["p50"] < got["p99"] < got["p999"] <= got["max"]


def test_latency_percentiles_hand_computed() -> None:
    # 1..1001 us: linear percentile index q/100 * (n - 1) lands on whole samples.
    lat_ns = np.arange(1, 1002) * 1_000
    got = kpi.latency_percentiles_us(lat_ns)
    expected = {"p50": 501.0, "p99": 991.0, "p999": 1000.0, "max": 1001.0}
    assert got == pytest.approx(expected, rel=1e-12, abs=0.0)


def test_pitch_travel_of_triangle_wave_is_exact() -> None:
    slope_deg_s = 2.0
    half_period_s = 5.0
    # Triangle 0 -> 10 deg -> 0 repeated 6 times, sampled non-uniformly but at every corner.
    t_parts = []
    for k in range(12):
        seg = np.sort(np.random.default_rng(k).uniform(0.0, half_period_s, size=37)).tolist()
        t_parts.append(k * half_period_s + np.array([0.0, *seg]))
    t = np.concatenate([*t_parts, [12 * half_period_s]])
    phase = np.mod(t, 2 * half_period_s)
    pitch_deg = slope_deg_s * np.where(phase <= half_period_s, phase, 2 * half_period_s - phase)
    got = kpi.pitch_travel_deg_s(t, np.radians(pitch_deg))
    assert got == pytest.approx(slope_deg_s, rel=1e-12)


def test_pitch_travel_constant_is_zero() -> None:
    t = np.linspace(0.0, 10.0, 101)
    assert kpi.pitch_travel_deg_s(t, np.full_like(t, 0.1)) == 0.0


@pytest.mark.parametrize("wohler_m", [4.0, 10.0])
def test_del_of_pure_sine_matches_analytic(wohler_m: float) -> None:
    amplitude = 3.0e6
    n_cycles = 200
    f_hz = 0.5
    samples_per_cycle = 64
    t = np.arange(n_cycles * samples_per_cycle + 1) / (samples_per_cycle * f_hz)
    x = 5.0e6 + amplitude * np.sin(2 * np.pi * f_hz * t)
    duration = t[-1] - t[0]
    n_eq_hz = 1.0
    expected = 2 * amplitude * (n_cycles / (n_eq_hz * duration)) ** (1 / wohler_m)
    got = kpi.damage_equivalent_load(x, t, wohler_m=wohler_m, n_eq_hz=n_eq_hz)
    assert got == pytest.approx(expected, rel=0.01)


def test_del_scales_with_equivalent_frequency() -> None:
    t = np.linspace(0.0, 100.0, 10_001)
    x = np.sin(2 * np.pi * 0.2 * t)
    d1 = kpi.damage_equivalent_load(x, t, wohler_m=4.0, n_eq_hz=1.0)
    d2 = kpi.damage_equivalent_load(x, t, wohler_m=4.0, n_eq_hz=16.0)
    assert d2 == pytest.approx(d1 / 2.0, rel=1e-12)  # 16^(1/4) = 2


def test_del_constant_signal_is_zero() -> None:
    t = np.linspace(0.0, 10.0, 11)
    assert kpi.damage_equivalent_load(np.ones(11), t) == 0.0


def test_empty_inputs_return_nan() -> None:
    empty = np.array([])
    assert math.isnan(kpi.mean_power_w(empty))
    assert math.isnan(kpi.std(empty))
    assert math.isnan(kpi.mean([]))
    assert math.isnan(kpi.maximum([]))
    assert math.isnan(kpi.pitch_travel_deg_s(empty, empty))
    assert math.isnan(kpi.pitch_travel_deg_s([0.0], [0.1]))
    assert all(math.isnan(v) for v in kpi.latency_percentiles_us(empty).values())
    assert math.isnan(kpi.damage_equivalent_load(empty, empty))
    assert math.isnan(kpi.damage_equivalent_load([1.0], [0.0]))
    assert math.isnan(kpi.settling_time_s(empty, empty, 1.0, 0.1))
    assert all(math.isnan(v) for v in kpi.percentiles([], [50.0], ["p50", "max"]).values())
    assert kpi.finite_or_none(float("nan")) is None
    assert kpi.finite_or_none(1.5) == 1.5


def test_mean_and_std_values() -> None:
    x = np.array([1.0, 2.0, 3.0, 4.0])
    assert kpi.mean_power_w(x) == 2.5
    assert kpi.std(x) == pytest.approx(math.sqrt(1.25), rel=1e-15)


def test_settling_time_and_overshoot_of_second_order_step() -> None:
    zeta, wn = 0.3, 2.0
    t = np.linspace(0.0, 20.0, 200_001)
    wd = wn * math.sqrt(1 - zeta**2)
    y = 1 - np.exp(-zeta * wn * t) * (
        np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t)
    )
    # Overshoot exp(-pi zeta / sqrt(1 - zeta^2)).
    assert kpi.overshoot(y, 0.0, 1.0) == pytest.approx(
        math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)), rel=1e-4
    )
    ts = kpi.settling_time_s(t, y, 1.0, 0.02)
    # The envelope bound 4 / (zeta wn) is conservative; the true 2 % time lies below it
    # and after the first peak at pi / wd.
    assert math.pi / wd < ts < 4 / (zeta * wn)
    assert np.all(np.abs(y[t >= ts] - 1.0) <= 0.02)
    assert np.abs(y[t < ts][-1] - 1.0) > 0.02


def test_del_of_sine_at_1hz_equivalent_over_600_s() -> None:
    """The summary's DEL definition on an analytic signal.

    A sine of amplitude S_a at frequency f over T seconds has f T full cycles of range 2 S_a,
    so DEL = (f T (2 S_a)^m / (f_eq T))^(1/m) = 2 S_a (f / f_eq)^(1/m): with m = 4,
    f = 0.1 Hz, f_eq = 1 Hz, DEL = 2 S_a 0.1^(1/4) = 1.1247 S_a, whatever T (600 s here).
    Tolerance 0.5 %: the partial half cycles at the ends of the record.
    """
    s_a = 2.0e7  # N m
    f_hz = 0.1
    t = np.arange(0.0, 600.0 + 1e-9, 0.025)
    x = 3.0e8 + s_a * np.sin(2 * np.pi * f_hz * t)
    expected = 2.0 * s_a * (f_hz / 1.0) ** 0.25
    assert kpi.damage_equivalent_load(x, t, wohler_m=4.0, n_eq_hz=1.0) == pytest.approx(
        expected, rel=0.005
    )
