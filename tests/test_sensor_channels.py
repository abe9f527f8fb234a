"""Tests of sensors.channel: noise, bias, quantization, delay, sample-and-hold, dropout, seeding.

Statistical tolerances are 4 sigma of the estimator for the stated sample size, so a seeded
run sits well inside them and a wrong model (a factor, a missing term) falls well outside.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from sensors import ChannelSuite, NoiseSpec, SensorSuite
from sensors.channel import (
    ChannelSpec,
    ChannelState,
    channel_init,
    channel_step,
    default_floating_suite,
)

STEP_NS = 10_000_000  # 100 Hz caller
N_STAT = 100_000


def run(
    spec: ChannelSpec,
    truth: np.ndarray,
    seed: int = 1,
    step_ns: int = STEP_NS,
    times_ns: list[int] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Values and valid flags of one channel fed ``truth`` at ``times_ns`` (default k step)."""
    state = channel_init(spec, seed)
    times = times_ns if times_ns is not None else [k * step_ns for k in range(len(truth))]
    ys = np.empty(len(truth))
    ok = np.empty(len(truth), dtype=bool)
    for k, (t, x) in enumerate(zip(times, truth.tolist(), strict=True)):
        _, ys[k], ok[k] = channel_step(spec, state, t, x)
    return ys, ok


def test_noise_std_and_bias_over_100k_samples() -> None:
    std, bias, x = 0.5, 0.2, 3.0
    y, ok = run(ChannelSpec(name="n", std=std, bias=bias), np.full(N_STAT, x))
    assert ok.all()
    err = y - x
    # 4 sigma: mean error sigma/sqrt(N); sample std relative error 1/sqrt(2N).
    assert abs(err.mean() - bias) < 4 * std / math.sqrt(N_STAT)
    assert abs(err.std() / std - 1) < 4 / math.sqrt(2 * N_STAT)


def test_quantization_output_is_a_multiple_of_the_resolution() -> None:
    r = 2 * math.pi / 4096
    truth = np.linspace(-3.0, 7.0, 5000)
    y, ok = run(ChannelSpec(name="q", resolution=r), truth)
    assert ok.all()
    assert np.max(np.abs(y / r - np.round(y / r))) < 1e-9
    assert np.max(np.abs(y - truth)) <= r / 2 * (1 + 1e-12)
    y2, _ = run(ChannelSpec(name="q", resolution=r, std=0.3, bias=0.05), truth)
    assert np.max(np.abs(y2 / r - np.round(y2 / r))) < 1e-9


def test_saturation_clips_and_stays_valid() -> None:
    truth = np.linspace(-10.0, 10.0, 201)
    y, ok = run(ChannelSpec(name="s", range_min=-2.0, range_max=3.0), truth)
    assert ok.all()
    np.testing.assert_array_equal(y, np.clip(truth, -2.0, 3.0))


@pytest.mark.parametrize("delay_s", [0.0, 0.01, 0.03, 0.025, 0.1234567])
def test_delay_shifts_a_ramp_by_exactly_delay_s(delay_s: float) -> None:
    """Ramp x = 1 + 3 t: y(t) = x(t - d) for t >= d (interpolated, tol 1e-9), x(0) before."""
    times = [k * STEP_NS for k in range(300)]
    t_s = np.array(times) * 1e-9
    truth = 1.0 + 3.0 * t_s
    y, ok = run(ChannelSpec(name="d", delay_s=delay_s), truth, times_ns=times)
    assert ok.all()
    expected = np.where(t_s >= delay_s, 1.0 + 3.0 * (t_s - delay_s), 1.0)
    np.testing.assert_allclose(y, expected, rtol=0, atol=1e-9)


def test_delay_is_exact_on_an_irregular_calling_step() -> None:
    rng = np.random.default_rng(5)
    steps = rng.integers(3_000_000, 17_000_000, 400)  # 3..17 ms jittered calls
    times = np.cumsum(steps).tolist()
    t_s = np.array(times) * 1e-9
    truth = -2.0 + 0.7 * t_s
    d = 0.0421
    y, _ = run(ChannelSpec(name="d", delay_s=d), truth, times_ns=times)
    late = t_s >= t_s[0] + d
    np.testing.assert_allclose(y[late], -2.0 + 0.7 * (t_s[late] - d), rtol=0, atol=1e-9)
    # The history stays small: about delay / step + 2 entries.
    state = channel_init(ChannelSpec(name="d", delay_s=d), 1)
    for t, x in zip(times, truth.tolist(), strict=True):
        channel_step(ChannelSpec(name="d", delay_s=d), state, t, x)
    assert len(state.times_ns) <= math.ceil(d / 3e-3) + 2


def test_sample_and_hold_10_hz_fed_at_100_hz_changes_every_10_calls() -> None:
    n = 1000
    spec = ChannelSpec(name="sh", std=0.1, sample_period_s=0.1)
    truth = np.linspace(0.0, 5.0, n)
    y, ok = run(spec, truth)
    assert ok.all()
    changes = np.flatnonzero(np.diff(y) != 0) + 1
    np.testing.assert_array_equal(changes, np.arange(10, n, 10))
    # Without noise, each held value is the truth at its own sample instant t_k = k * 0.1 s.
    y0, _ = run(ChannelSpec(name="sh", sample_period_s=0.1), truth)
    np.testing.assert_array_equal(y0, np.repeat(truth[::10], 10))


def test_sample_and_hold_with_delay_samples_the_delayed_signal() -> None:
    times = [k * STEP_NS for k in range(200)]
    t_s = np.array(times) * 1e-9
    spec = ChannelSpec(name="shd", sample_period_s=0.05, delay_s=0.02)
    y, _ = run(spec, 4.0 * t_s, times_ns=times)
    t_k = np.floor(t_s / 0.05 + 1e-9) * 0.05
    np.testing.assert_allclose(y, np.maximum(4.0 * (t_k - 0.02), 0.0), rtol=0, atol=1e-9)


def test_dropout_fraction_and_missing_samples_are_flagged() -> None:
    p = 0.05
    truth = np.arange(N_STAT, dtype=float)  # every true value distinct: staleness shows
    y, ok = run(ChannelSpec(name="drop", dropout_probability=p), truth)
    dropped = int((~ok).sum())
    sigma = math.sqrt(N_STAT * p * (1 - p))
    assert abs(dropped - N_STAT * p) < 4 * sigma
    assert np.isnan(y[~ok]).all()  # a dropped sample is missing, never a stale value
    np.testing.assert_array_equal(y[ok], truth[ok])  # a valid sample is the fresh one


def test_dropout_with_sample_and_hold_stays_missing_until_the_next_sample() -> None:
    n = 20_000
    truth = np.arange(n, dtype=float)
    spec = ChannelSpec(name="dsh", sample_period_s=0.05, dropout_probability=0.2)
    y, ok = run(spec, truth)
    assert 0 < (~ok).sum() < n
    # Validity and value change only at sample instants (every 5 calls).
    blocks_ok = ok.reshape(-1, 5)
    assert (blocks_ok == blocks_ok[:, :1]).all()
    assert np.isnan(y[~ok]).all()
    # A valid reading is the truth at its own sample instant, never an older sample.
    np.testing.assert_array_equal(y[ok], np.repeat(truth[::5], 5)[ok])


def test_dropout_does_not_change_the_noise_of_surviving_samples() -> None:
    truth = np.zeros(5000)
    clean, _ = run(ChannelSpec(name="c", std=1.0), truth)
    lossy, ok = run(ChannelSpec(name="c", std=1.0, dropout_probability=0.3), truth)
    np.testing.assert_array_equal(lossy[ok], clean[ok])


def test_same_seed_identical_series_and_state_copies_continue_identically() -> None:
    spec = ChannelSpec(
        name="rep", std=0.3, bias=0.1, resolution=0.01, delay_s=0.013, dropout_probability=0.1
    )
    truth = np.sin(np.linspace(0, 20, 3000))
    a, oka = run(spec, truth, seed=42)
    b, okb = run(spec, truth, seed=42)
    np.testing.assert_array_equal(a, b)  # NaN == NaN for array_equal on identical series
    np.testing.assert_array_equal(oka, okb)
    c, _ = run(spec, truth, seed=43)
    assert not np.array_equal(a, c, equal_nan=True)

    state = channel_init(spec, 42)
    for k in range(1000):
        channel_step(spec, state, k * STEP_NS, float(truth[k]))
    twin: ChannelState = copy.deepcopy(state)
    for k in range(1000, 3000):
        _, y1, v1 = channel_step(spec, state, k * STEP_NS, float(truth[k]))
        _, y2, v2 = channel_step(spec, twin, k * STEP_NS, float(truth[k]))
        assert (y1 == y2 or (math.isnan(y1) and math.isnan(y2))) and v1 == v2


def test_different_channel_names_give_independent_streams() -> None:
    truth = np.zeros(N_STAT)
    a, _ = run(ChannelSpec(name="alpha", std=1.0), truth)
    b, _ = run(ChannelSpec(name="beta", std=1.0), truth)
    # Correlation of independent normals has sigma 1/sqrt(N).
    assert abs(np.corrcoef(a, b)[0, 1]) < 4 / math.sqrt(N_STAT)


def test_adding_a_channel_does_not_change_another_channels_noise() -> None:
    one = ChannelSuite({"a": ChannelSpec(std=1.0, dropout_probability=0.1)}, seed=9)
    two = ChannelSuite(
        {
            "z": ChannelSpec(std=2.0, dropout_probability=0.5),
            "a": ChannelSpec(std=1.0, dropout_probability=0.1),
        },
        seed=9,
    )
    for k in range(3000):
        r1 = one.step(k * STEP_NS, {"a": 0.0})
        r2 = two.step(k * STEP_NS, {"a": 0.0, "z": 0.0})
        assert r1["a"][1] == r2["a"][1]
        assert r1["a"][0] == r2["a"][0] or not r1["a"][1]


def test_noise_only_channel_reproduces_sensors_models_bit_for_bit() -> None:
    old = SensorSuite({"gen": NoiseSpec(std=0.5, bias=0.1, resolution=0.01)}, seed=7)
    spec = ChannelSpec(name="gen", std=0.5, bias=0.1, resolution=0.01)
    state = channel_init(spec, 7)
    for k in range(5000):
        x = 100.0 + 0.001 * k
        assert channel_step(spec, state, k * STEP_NS, x)[1] == old.measure("gen", x)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"std": -0.1}, "std"),
        ({"std": math.nan}, "std"),
        ({"bias": math.nan}, "bias"),
        ({"bias": math.inf}, "bias"),
        ({"resolution": -1.0}, "resolution"),
        ({"delay_s": -0.01}, "delay_s"),
        ({"sample_period_s": -1.0}, "sample_period_s"),
        ({"sample_period_s": 1e-12}, "sample_period_s"),
        ({"dropout_probability": 1.0}, "dropout_probability"),
        ({"dropout_probability": -0.1}, "dropout_probability"),
        ({"dropout_probability": math.nan}, "dropout_probability"),
        ({"range_min": 1.0, "range_max": 0.0}, "range_min"),
        ({"range_max": math.nan}, "range_max"),
        ({"std": True}, "std"),
        ({"std": "0.5"}, "std"),
    ],
)
def test_bad_specs_raise_naming_the_field(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ValueError, match=field):
        ChannelSpec(name="bad", **kwargs)  # type: ignore[arg-type]


def test_unknown_key_in_a_table_names_the_key_and_the_allowed_ones() -> None:
    with pytest.raises(ValueError, match=r"'std_rad_s'.*allowed keys: std, bias"):
        ChannelSuite.from_table({"generator_speed": {"std_rad_s": 0.5}}, seed=1)
    with pytest.raises(ValueError, match="'name'"):
        ChannelSuite.from_table({"generator_speed": {"name": "x"}}, seed=1)
    with pytest.raises(ValueError, match="dropout_probability"):
        ChannelSuite.from_table({"g": {"dropout_probability": 1.0}}, seed=1)


def test_suite_from_table_and_step() -> None:
    table = {"generator_speed": {"std": 0.5, "delay_s": 0.01, "dropout_probability": 0.01}}
    suite = ChannelSuite.from_table(table, seed=3)
    assert list(suite) == ["generator_speed"]
    assert suite["generator_speed"] == ChannelSpec(
        name="generator_speed", std=0.5, delay_s=0.01, dropout_probability=0.01
    )
    out = suite.step(0, {"generator_speed": 100.0, "unrelated": 1.0})
    assert set(out) == {"generator_speed"}
    with pytest.raises(KeyError, match="generator_speed"):
        suite.step(STEP_NS, {"other": 1.0})
    with pytest.raises(ValueError, match="increase"):
        suite.step_channel("generator_speed", 0, 1.0)


def test_table_overrides_defaults_field_by_field() -> None:
    defaults = default_floating_suite()
    suite = ChannelSuite.from_table(
        {"wind_speed_measured_m_s": {"std": 0.1}, "extra_m": {"bias": 1.0}},
        seed=1,
        defaults=defaults,
    )
    assert set(suite) == {*defaults, "extra_m"}
    wind = suite["wind_speed_measured_m_s"]
    assert wind.std == 0.1
    assert wind.bias == defaults["wind_speed_measured_m_s"].bias
    assert wind.sample_period_s == defaults["wind_speed_measured_m_s"].sample_period_s


def test_default_floating_suite_is_valid_and_runs() -> None:
    specs = default_floating_suite()
    assert len(specs) == 10
    assert all(name == spec.name for name, spec in specs.items())
    gen = specs["generator_speed_measured_rad_s"]
    assert gen.resolution == pytest.approx(2 * math.pi / (2**12 * 0.01))
    suite = ChannelSuite(specs, seed=7)
    truth = {
        "generator_speed_measured_rad_s": 122.9,
        "blade_pitch_measured_rad": 0.1,
        "nacelle_acc_fore_aft_measured_m_s2": 0.3,
        "platform_pitch_rate_measured_rad_s": 0.01,
        "platform_pitch_measured_rad": 0.05,
        "platform_surge_measured_m": 8.0,
        "wave_elevation_gauge_measured_m": 1.2,
        "wind_speed_measured_m_s": 11.4,
        "generator_torque_measured_nm": 43094.0,
        "electrical_power_measured_w": 5.0e6,
    }
    seen: dict[str, list[float]] = {k: [] for k in specs}
    for k in range(2000):
        for name, (y, ok) in suite.step(k * STEP_NS, truth).items():
            assert ok == math.isfinite(y)
            if ok:
                seen[name].append(y)
    for name, ys in seen.items():
        spec = specs[name]
        # Mean within bias +- 6 std / sqrt(independent samples) + resolution.
        n_samples = len(ys) * 0.01 / max(spec.sample_period_s, 0.01)
        tol = 6 * spec.std / math.sqrt(n_samples) + spec.resolution
        assert abs(np.mean(ys) - truth[name] - spec.bias) < tol + 1e-12, name
