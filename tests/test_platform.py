"""Floating platform + tower + rotor dynamics: free decay, energy, steady thrust, validation."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from plant.integrate import rk4_step
from plant.modes import natural_modes, operating_point
from plant.platform import (
    FloatingParams,
    conservative,
    energy,
    f,
    relative_wind,
    rotor_thrust,
)


def _run(
    p: FloatingParams, x0: tuple[float, ...], u: tuple[float, ...], h: float, n: int
) -> np.ndarray:
    out = np.empty((n + 1, len(x0)))
    x = x0
    out[0] = x
    for k in range(n):
        x = rk4_step(f, k * h, x, u, h, p)
        out[k + 1] = x
    return out


def _upcrossing_period(t: np.ndarray, y: np.ndarray) -> float:
    s = np.sign(y)
    idx = np.nonzero((s[:-1] < 0) & (s[1:] >= 0))[0]
    tc = t[idx] - y[idx] * (t[idx + 1] - t[idx]) / (y[idx + 1] - y[idx])
    assert tc.size >= 2, "fewer than two up-crossings"
    return float(np.mean(np.diff(tc)))


@pytest.mark.parametrize(
    ("dof", "name", "offset", "t_end", "h"),
    [(0, "surge", 2.0, 260.0, 0.1), (1, "heave", 0.3, 65.0, 0.05), (2, "pitch", 0.01, 85.0, 0.05)],
)
def test_free_decay_period_matches_linear_modes(
    params: FloatingParams, dof: int, name: str, offset: float, t_end: float, h: float
) -> None:
    """RK4 free decay at 5 m/s from an offset: zero-crossing period within 2 % of natural_modes."""
    modes = {m.name: m for m in natural_modes(params, 5.0)}
    op = operating_point(params, 5.0)
    x0 = list(op.state)
    x0[dof] += offset
    n = round(t_end / h)
    xs = _run(params, tuple(x0), op.inputs, h, n)
    t = np.arange(n + 1) * h
    period = _upcrossing_period(t, xs[:, dof] - op.state[dof])
    assert period == pytest.approx(modes[name].period_s, rel=0.02)


def test_energy_is_conserved_without_damping(params: FloatingParams) -> None:
    """Damping, drag, radiation, aero, torque and waves off: energy within 0.1 % over 600 s."""
    p = conservative(params)
    x0 = (3.0, 0.5, 0.03, 0.2, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0)
    u = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    e0 = energy(x0, p)
    h, n = 0.025, 24000
    x = x0
    worst = 0.0
    for k in range(n):
        x = rk4_step(f, k * h, x, u, h, p)
        if k % 200 == 0:
            worst = max(worst, abs(energy(x, p) - e0))
    worst = max(worst, abs(energy(x, p) - e0))
    # Energy relative to the static equilibrium's energy scale: compare the oscillation energy.
    x_eq = operating_point_free(p)
    e_osc = e0 - energy(x_eq, p)
    assert e_osc > 0.0
    assert worst < 1e-3 * e_osc


def operating_point_free(p: FloatingParams) -> tuple[float, ...]:
    """Static equilibrium with no wind (q where the generalised force vanishes)."""
    from scipy.optimize import fsolve

    def res(q: np.ndarray) -> np.ndarray:
        x = (*q, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0)
        return np.array(f(0.0, x, (0.0,) * 6, p)[4:8]) * np.array([1, 1, 100, 1])

    q = fsolve(res, np.zeros(4), xtol=1e-13)
    return (*(float(v) for v in q), 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0)


def test_steady_thrust_at_rated_equals_actuator_disc_formula(params: FloatingParams) -> None:
    """At rated wind the mean thrust equals ½ρπR²U_rel²Ct(λ, θ) within 1 %, and balances mooring."""
    tp = params.turbine
    u_rated = 10.59
    op = operating_point(params, u_rated)
    n = 400
    xs = _run(params, op.state, op.inputs, 0.05, n)
    thrusts = []
    for x in xs[n // 2 :]:
        thrusts.append(rotor_thrust(x[8], x[9], relative_wind(x, u_rated, params), tp))
    mean_thrust = float(np.mean(thrusts))
    omega, pitch = op.state[8], op.state[9]
    # Rotor-normal wind at the static point: U cos ψ / cos τ, shaft at ψ = τ + φ + κ s (mean
    # platform pitch φ and tower-top slope κ s).
    tilt = params.shaft_tilt_rad
    psi = tilt + op.state[2] + params.tower_slope_per_m * op.state[3]
    u_n = u_rated * math.cos(psi) / math.cos(tilt)
    assert relative_wind(op.state, u_rated, params) == pytest.approx(u_n, rel=1e-12)
    _, ct, _ = tp.table.evaluate(omega * tp.rotor_radius_m / u_n, pitch)
    expected = 0.5 * tp.air_density_kg_m3 * np.pi * tp.rotor_radius_m**2 * u_n**2 * float(ct)
    assert mean_thrust == pytest.approx(expected, rel=0.01)
    assert mean_thrust > 1.5e6  # IEA 15 MW near rated: about 2.5 MN
    # The platform drifts downwind to balance the thrust with the mooring.
    assert op.state[0] > 10.0


def test_f_is_fast_enough(params: FloatingParams) -> None:
    op = operating_point(params, 8.0)
    x, u = op.state, op.inputs
    n = 2000
    t0 = time.perf_counter()
    for _ in range(n):
        f(0.0, x, u, params)
    per_call = (time.perf_counter() - t0) / n
    assert per_call < 200e-6  # target < 50 us on an idle core; loose bound for shared CI


def test_params_validation_names_key_and_unit(params: FloatingParams) -> None:
    from dataclasses import replace

    with pytest.raises(ValueError, match=r"mass_matrix.*kg"):
        replace(params, mass_matrix=np.eye(3))
    with pytest.raises(ValueError, match=r"mass_matrix.*positive definite"):
        replace(params, mass_matrix=-np.eye(4))
    with pytest.raises(ValueError, match=r"hub_lever.*\(4,\)"):
        replace(params, hub_lever=np.ones(3))
    with pytest.raises(ValueError, match=r"radiation_b"):
        replace(params, radiation_b=np.zeros((params.n_radiation, 2)))
