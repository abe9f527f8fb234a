"""Fixed-step explicit Runge-Kutta integration for ``f(t, x, u, params)`` models.

What is hand-written here and why: ``scipy.integrate.solve_ivp`` is adaptive, allocates numpy
arrays on every call and costs hundreds of microseconds per step, while a real-time plant needs
one deterministic, fixed-cost step per tick on a few floats. The classic four-stage RK4 on tuples
of Python floats is a dozen lines and costs a few microseconds beyond the four ``f`` calls.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, TypeVar, cast

import numpy as np
import numpy.typing as npt

__all__ = ["rk4_step", "simulate"]

P = TypeVar("P")
X = TypeVar("X", bound=tuple[float, ...])


def rk4_step(
    f: Callable[[float, Any, Any, P], Sequence[float]],
    t: float,
    x: X,
    u: Any,
    h: float,
    params: P,
) -> X:
    """Advance ``x`` by one classic fourth-order Runge-Kutta step with the input held.

    k1 = f(t, x), k2 = f(t + h/2, x + h/2 k1), k3 = f(t + h/2, x + h/2 k2),
    k4 = f(t + h, x + h k3);  x(t + h) = x + h/6 (k1 + 2 k2 + 2 k3 + k4).

    The input ``u`` is held constant over the step (zero-order hold). Local error O(h⁵),
    global error O(h⁴) for smooth ``f``.

    Parameters
    ----------
    f : callable
        Dynamics ``f(t, x, u, params)`` returning dx/dt as a sequence of floats (units of x per s).
    t : float
        Time at the start of the step (s).
    x : tuple of float
        State at ``t``.
    u : object
        Input passed unchanged to ``f``.
    h : float
        Step (s).
    params : object
        Model parameters passed unchanged to ``f``.

    Returns
    -------
    tuple of float
        State at ``t + h``, same length as ``x``.
    """
    h2 = 0.5 * h
    if len(x) == 3:
        # Unrolled for the 3-state turbine: saves ~3 us of generator overhead per step.
        a0, a1, a2 = x
        k1 = f(t, x, u, params)
        k2 = f(t + h2, (a0 + h2 * k1[0], a1 + h2 * k1[1], a2 + h2 * k1[2]), u, params)
        k3 = f(t + h2, (a0 + h2 * k2[0], a1 + h2 * k2[1], a2 + h2 * k2[2]), u, params)
        k4 = f(t + h, (a0 + h * k3[0], a1 + h * k3[1], a2 + h * k3[2]), u, params)
        h6 = h / 6.0
        return cast(
            X,
            (
                a0 + h6 * (k1[0] + 2.0 * (k2[0] + k3[0]) + k4[0]),
                a1 + h6 * (k1[1] + 2.0 * (k2[1] + k3[1]) + k4[1]),
                a2 + h6 * (k1[2] + 2.0 * (k2[2] + k3[2]) + k4[2]),
            ),
        )
    k1 = f(t, x, u, params)
    k2 = f(t + h2, tuple([a + h2 * b for a, b in zip(x, k1, strict=True)]), u, params)
    k3 = f(t + h2, tuple([a + h2 * b for a, b in zip(x, k2, strict=True)]), u, params)
    k4 = f(t + h, tuple([a + h * b for a, b in zip(x, k3, strict=True)]), u, params)
    h6 = h / 6.0
    return cast(
        X,
        tuple(
            [
                a + h6 * (b1 + 2.0 * (b2 + b3) + b4)
                for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4, strict=True)
            ]
        ),
    )


def simulate(
    f: Callable[[float, Any, Any, P], Sequence[float]],
    x0: Sequence[float],
    u_of_t: Callable[[float], Sequence[float]],
    t_end: float,
    h: float,
    params: P,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Integrate from t = 0 to ``t_end`` with fixed RK4 steps (offline convenience).

    x_{k+1} = rk4_step(f, t_k, x_k, u(t_k), h, params), t_k = k h, k = 0..K-1,
    K = round(t_end / h); the input is sampled at the start of each step and held.

    Parameters
    ----------
    f : callable
        Dynamics ``f(t, x, u, params)``.
    x0 : sequence of float
        Initial state.
    u_of_t : callable
        Input as a function of time (s), returning a sequence of floats.
    t_end : float
        End time (s), >= 0; must be a whole number of steps to within 1e-9 h.
    h : float
        Step (s), > 0.
    params : object
        Model parameters.

    Returns
    -------
    t : ndarray, shape (K + 1,)
        Times (s).
    x : ndarray, shape (K + 1, n_x)
        States; ``x[k]`` at ``t[k]``.
    u : ndarray, shape (K + 1, n_u)
        Inputs applied over the step starting at ``t[k]`` (last row: input at ``t_end``).
    """
    if not h > 0.0:
        raise ValueError(f"h: expected a positive step in s, got {h}")
    if not t_end >= 0.0:
        raise ValueError(f"t_end: expected a time >= 0 s, got {t_end}")
    n_steps = round(t_end / h)
    if abs(n_steps * h - t_end) > 1e-9 * h:
        raise ValueError(f"t_end = {t_end} s is not a whole number of steps h = {h} s")
    x = tuple(float(v) for v in x0)
    ts = np.arange(n_steps + 1, dtype=np.float64) * h
    xs = np.empty((n_steps + 1, len(x)), dtype=np.float64)
    u0 = tuple(u_of_t(0.0))
    us = np.empty((n_steps + 1, len(u0)), dtype=np.float64)
    for k in range(n_steps):
        t = float(ts[k])
        u = tuple(u_of_t(t))
        xs[k] = x
        us[k] = u
        x = rk4_step(f, t, x, u, h, params)
    xs[n_steps] = x
    us[n_steps] = tuple(u_of_t(float(ts[n_steps])))
    return ts, xs, us
