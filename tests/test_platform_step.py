"""step_floating (exact radiation block + RK4 of the mechanics) against fine RK4 of f."""

from __future__ import annotations

import numpy as np
import pytest

from plant.integrate import rk4_step
from plant.modes import operating_point
from plant.platform import FloatingParams, f, step_floating


def _wave_inputs(t: float, base: tuple[float, ...]) -> tuple[float, ...]:
    """Irregular wave loads: 12 components 0.3..1.4 rad/s with fixed random phases (N, N m)."""
    rng = np.random.default_rng(7)
    w = np.linspace(0.3, 1.4, 12)
    ph = rng.uniform(0.0, 2.0 * np.pi, (3, 12))
    amp = np.array([4e5, 6e5, 2e7])[:, None] / np.sqrt(12)
    loads = (amp * np.cos(w * t + ph)).sum(axis=1)
    return (*base[:3], float(loads[0]), float(loads[1]), float(loads[2]))


def test_step_matches_fine_rk4_of_f_over_60_s_of_irregular_waves(params: FloatingParams) -> None:
    op = operating_point(params, 8.0)
    h, sub, n = 0.025, 10, 2400
    x_split = op.state
    x_ref = op.state
    worst = np.zeros(8)
    scale = np.zeros(8)
    for k in range(n):
        t = k * h
        u = _wave_inputs(t, op.inputs)
        x_split = step_floating(t, x_split, u, h, params)
        for j in range(sub):
            x_ref = rk4_step(f, t + j * h / sub, x_ref, u, h / sub, params)
        a, b = np.array(x_split[:8]), np.array(x_ref[:8]) - np.array(op.state[:8])
        worst = np.maximum(worst, np.abs(a - np.array(x_ref[:8])))
        scale = np.maximum(scale, np.abs(b))
    # Surge, heave, pitch, tower and their rates within 0.5 % of their motion amplitude.
    assert np.all(worst <= 5e-3 * scale), (worst, scale)
    assert abs(x_split[8] - x_ref[8]) < 1e-4 * abs(op.state[8])


def test_step_without_radiation_is_rk4_of_f(params: FloatingParams) -> None:
    from dataclasses import replace

    p = replace(
        params,
        radiation_a=np.zeros((0, 0)),
        radiation_b=np.zeros((0, 3)),
        radiation_c=np.zeros((3, 0)),
    )
    op = operating_point(p, 8.0)
    x = tuple(v + 1e-3 for v in op.state)
    a = step_floating(0.0, x, op.inputs, 0.025, p)
    b = rk4_step(f, 0.0, x, op.inputs, 0.025, p)
    assert np.allclose(a, b, rtol=1e-12, atol=1e-12)


def test_step_rejects_bad_step(params: FloatingParams) -> None:
    op = operating_point(params, 8.0)
    with pytest.raises(ValueError, match="h must be > 0 s"):
        step_floating(0.0, op.state, op.inputs, 0.0, params)


def test_step_reuses_its_radiation_output_only_for_the_same_state(params: FloatingParams) -> None:
    """Continuing from the returned tuple (cached μ0, μ̇0) equals starting from a copy of it."""
    op = operating_point(params, 8.0)
    u = _wave_inputs(3.0, op.inputs)
    x1 = step_floating(0.0, op.state, u, 0.0125, params)
    x1 = step_floating(0.0125, x1, u, 0.0125, params)
    cached = step_floating(0.025, x1, u, 0.0125, params)
    fresh = step_floating(0.025, tuple(list(x1)), u, 0.0125, params)
    assert np.allclose(cached, fresh, rtol=1e-12, atol=1e-9)
    # Another state in between (a second user of the same params) does not confuse the cache.
    other = tuple(v * 1.01 for v in x1)
    step_floating(0.0, other, u, 0.0125, params)
    again = step_floating(0.025, x1, u, 0.0125, params)
    assert np.allclose(again, fresh, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize(
    ("wind", "omega_scale", "pitch_rad"),
    [(3.0, 3.0, 0.0), (12.0, 0.1, 0.0), (12.0, 1.0, 0.7), (25.0, 1.0, -0.2)],
)
def test_step_outside_the_aero_grid_is_rk4_of_f(
    params: FloatingParams, wind: float, omega_scale: float, pitch_rad: float
) -> None:
    """Clamped Ct/Cq lookups (λ or θ off the table) and mooring segments match f exactly."""
    from dataclasses import replace

    p = replace(
        params,
        radiation_a=np.zeros((0, 0)),
        radiation_b=np.zeros((0, 3)),
        radiation_c=np.zeros((3, 0)),
    )
    op = operating_point(p, 8.0)
    x = list(op.state)
    x[0] = 7.999999  # next to a mooring-table knot
    x[8] *= omega_scale
    x[9] = pitch_rad
    u = (pitch_rad, op.inputs[1], wind, 1e5, -2e5, 3e6)
    for _ in range(3):
        a = step_floating(0.0, tuple(x), u, 0.0125, p)
        b = rk4_step(f, 0.0, tuple(x), u, 0.0125, p)
        assert np.allclose(a, b, rtol=1e-11, atol=1e-12)
        x = list(a)
