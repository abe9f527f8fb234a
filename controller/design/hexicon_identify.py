"""PRBS system identification of the Hexicon H3 platform (ayotte-2015 sections 3.4, 4.2, 5.2).

The seed's table-5 experiments: wind speed, wind direction and the three blade pitches are
pseudo-random binary signals (each held for a random multiple of the 10 s base period, i.e.
content between ~1e-3 and 1e-1 Hz) over 3000 s, the pitch floored at the rated pitch of the
wind speed. The plant (:mod:`plant.hexicon`) is run in process (offline design code may use
``plant``); its torque follows the turbines' torque law. The experiments are merged
(concatenated, means removed) and a discrete state-space model

    x_{k+1} = A x_k + B u_k,   y_k = C x_k + D u_k,
    u = (V m/s, β deg, θ_1, θ_2, θ_3 deg),   y = (yaw rate deg/s, platform power MW)

is fitted by N4SID (the maintained ``nfoursid`` package), order = the number of singular values
of the projected block-Hankel matrix above 1e-3 of the largest (the N4SID counterpart of the
seed's Hankel-singular-value reduction). Fit = 100 (1 - ||y - ŷ|| / ||y - ȳ||) % of the free-run
simulation, on the estimation experiments and on a held-out one. Run::

    python -m controller.design.hexicon_identify [--duration 3000]
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd
from nfoursid.nfoursid import NFourSID

from controller.hexicon import prbs
from plant.hexicon.environment import WindProfile  # noqa: F401  (documented input model)
from plant.hexicon.model import load_hexicon, outputs, rated_pitch_rad, step_rk4, torque_law_nm

FloatArray = npt.NDArray[np.float64]

#: Table 5 of the seed: (wind speed range m/s, wind angle range deg, pitch range deg).
#: Wind speeds below 4 m/s are raised to 4 m/s (cut-in region: no thrust to identify).
TABLE5: tuple[tuple[tuple[float, float], tuple[float, float], tuple[float, float]], ...] = (
    ((4.0, 16.0), (0.0, 5.0), (0.0, 25.0)),
    ((4.0, 16.0), (0.0, 5.0), (0.0, 25.0)),
    ((4.0, 10.0), (0.0, 10.0), (0.0, 25.0)),
    ((4.0, 22.0), (0.0, 0.01), (0.0, 25.0)),
    ((4.0, 12.0), (0.0, 5.0), (0.0, 25.0)),
    ((4.0, 10.0), (0.0, 15.0), (0.0, 25.0)),
)
INPUTS = ("wind_m_s", "direction_deg", "pitch1_deg", "pitch2_deg", "pitch3_deg")
OUTPUTS = ("yaw_rate_deg_s", "power_mw")


#: Hold times of every PRBS (samples at 1 s): 1e-3 .. 1e-1 Hz content.
HOLD = (10, 100)


def experiment_wind(test: int, n: int, seed: int = 0) -> tuple[list[float], list[float]]:
    """Wind speed (m/s) and direction (deg) samples of table-5 experiment ``test`` (0-based)
    for the bus runs: PRBS streams ``[seed, test, 0]`` (speed) and ``[seed, test, 1]``
    (direction); the pitches are :class:`controller.hexicon.PrbsExcitation` (streams 2-4)."""
    if not 0 <= test < len(TABLE5):
        raise ValueError(f"table-5 experiment {test + 1}: expected 1..{len(TABLE5)}")
    (v_lo, v_hi), (a_lo, a_hi), _ = TABLE5[test]
    v = v_lo + (v_hi - v_lo) * prbs(n, *HOLD, np.random.default_rng([seed, test, 0]))
    a = a_lo + (a_hi - a_lo) * prbs(n, *HOLD, np.random.default_rng([seed, test, 1]))
    return [float(x) for x in v], [float(x) for x in a]


def scaled_ranges(
    test: int, amplitude: float = 1.0
) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]:
    """Table-5 ranges of experiment ``test`` (0-based) shrunk about their centres.

    ``amplitude`` in (0, 1]: each (lo, hi) becomes c ± amplitude (hi − lo)/2, c = (lo + hi)/2
    (1: the seed's table). A small amplitude keeps the plant near one operating point, where
    a linear model fits it better (the amplitude study of ``bench/hexicon_identify.py``).
    """
    if not 0.0 < amplitude <= 1.0:
        raise ValueError(f"amplitude = {amplitude!r}: expected (0, 1]")
    out = []
    for lo, hi in TABLE5[test]:
        c, h = 0.5 * (lo + hi), 0.5 * (hi - lo) * amplitude
        out.append((c - h, c + h))
    return out[0], out[1], out[2]


def run_experiment(
    test: int,
    duration_s: float = 3000.0,
    seed: int = 0,
    dt: float = 0.05,
    ts: float = 1.0,
    amplitude: float = 1.0,
) -> pd.DataFrame:
    """One table-5 experiment on the plant, sampled every ``ts`` s (inputs held over a sample);
    ``amplitude``: the ranges shrunk about their centres (:func:`scaled_ranges`)."""
    (v_lo, v_hi), (a_lo, a_hi), (p_lo, p_hi) = scaled_ranges(test, amplitude)
    p = load_hexicon()
    tp = p.turbine
    n = round(duration_s / ts)
    rng = np.random.default_rng(seed * 100 + test)
    hold = (10, 100)  # samples: 1e-3 .. 1e-1 Hz content at ts = 1 s
    v = v_lo + (v_hi - v_lo) * prbs(n, *hold, rng)
    a = a_lo + (a_hi - a_lo) * prbs(n, *hold, rng)
    pitch = [p_lo + (p_hi - p_lo) * prbs(n, *hold, rng) for _ in range(3)]
    th0 = rated_pitch_rad(tp, v[0])
    w0 = tp.rated_rotor_speed_rad_s * 0.8
    x: tuple[float, ...] = (0.0, 0.0) + (w0, th0, torque_law_nm(tp, w0)) * 3
    rows = []
    for k in range(n):
        floor = math.degrees(rated_pitch_rad(tp, float(v[k])))
        th = [math.radians(max(float(pi[k]), floor)) for pi in pitch]
        beta = math.radians(float(a[k]))
        q = [torque_law_nm(tp, x[2 + 3 * i]) for i in range(3)]
        u = (th[0], q[0], th[1], q[1], th[2], q[2], float(v[k]), beta)
        power = sum(outputs(0.0, x, u, p).powers_w)
        rows.append(
            (
                float(v[k]),
                float(a[k]),
                *(math.degrees(t) for t in th),
                math.degrees(x[1]),
                power / 1e6,
            )
        )
        for _ in range(round(ts / dt)):
            x = step_rk4(x, u, dt, p)
    return pd.DataFrame(rows, columns=[*INPUTS, *OUTPUTS])


@dataclass
class Identified:
    """An identified model and its figures of merit."""

    a: FloatArray
    b: FloatArray
    c: FloatArray
    d: FloatArray
    order: int
    singular_values: list[float]
    u_mean: FloatArray
    y_mean: FloatArray
    #: N4SID's estimate of the noise covariance [[R, Sᵀ], [S, Q]] (outputs first), or None.
    noise_covariance: FloatArray | None = None


def choose_order(singular_values: list[float], rel_tol: float = 1e-3, max_order: int = 15) -> int:
    """Number of singular values above ``rel_tol`` times the largest, within [1, max_order].

    (The residual of the output-mean removal over a finite record shows as a small extra
    singular value near 1e-3 sigma_1 even on noise-free data; the threshold skips it.)
    """
    sv = np.asarray(singular_values, dtype=float)
    n = int(np.sum(sv > rel_tol * sv[0]))
    return max(1, min(n, max_order))


def n4sid(
    data: pd.DataFrame,
    inputs: tuple[str, ...] | list[str],
    outputs_: tuple[str, ...] | list[str],
    block_rows: int = 10,
    order: int | None = None,
    remove_means: bool = True,
) -> Identified:
    """Fit (A, B, C, D) with ``nfoursid``; order by :func:`choose_order`.

    ``remove_means``: identify deviations from the record's mean input and output (an
    operating point); off for data of a linear system started at rest (x_0 = 0, u raw).
    """
    u_mean = data[list(inputs)].mean().to_numpy() * remove_means
    y_mean = data[list(outputs_)].mean().to_numpy() * remove_means
    df = data.copy()
    df[list(inputs)] -= u_mean
    df[list(outputs_)] -= y_mean
    model = NFourSID(
        df, output_columns=list(outputs_), input_columns=list(inputs), num_block_rows=block_rows
    )
    model.subspace_identification()
    sv = [float(s) for s in np.diag(model.R32_decomposition.eigenvalues)]
    n = order if order is not None else choose_order(sv)
    ss, cov = model.system_identification(rank=n)
    return Identified(ss.a, ss.b, ss.c, ss.d, n, sv, u_mean, y_mean, np.asarray(cov))


def simulate(m: Identified, u: FloatArray) -> FloatArray:
    """Free-run output of the model from x_0 = 0 for inputs u (samples x inputs)."""
    x = np.zeros(m.a.shape[0])
    ys = np.empty((u.shape[0], m.c.shape[0]))
    du = u - m.u_mean
    for k in range(u.shape[0]):
        ys[k] = m.c @ x + m.d @ du[k] + m.y_mean
        x = m.a @ x + m.b @ du[k]
    return ys


def predictor_gain(m: Identified) -> FloatArray:
    """Steady-state one-step predictor gain K of the identified noise model.

    With N4SID's covariance [[R, Sᵀ], [S, Q]] of the measurement noise v and process noise w
    (x⁺ = A x + B u + w, y = C x + D u + v), P solves the filter Riccati equation
    P = A P Aᵀ + Q − (A P Cᵀ + S)(C P Cᵀ + R)⁻¹(A P Cᵀ + S)ᵀ and K = (A P Cᵀ + S)(C P Cᵀ + R)⁻¹
    (the innovations form: what a toolbox's one-step-ahead comparison uses).

    Raises
    ------
    ValueError
        When the model carries no noise covariance.
    """
    import scipy.linalg  # noqa: PLC0415

    if m.noise_covariance is None:
        raise ValueError("predictor_gain: the model has no noise covariance")
    ny = m.c.shape[0]
    cov = 0.5 * (m.noise_covariance + m.noise_covariance.T)
    r, s_, q = cov[:ny, :ny], cov[ny:, :ny], cov[ny:, ny:]
    p = scipy.linalg.solve_discrete_are(m.a.T, m.c.T, q, r, s=s_)
    gain: FloatArray = (m.a @ p @ m.c.T + s_) @ np.linalg.inv(m.c @ p @ m.c.T + r)
    return gain


def predict_one_step(m: Identified, gain: FloatArray, u: FloatArray, y: FloatArray) -> FloatArray:
    """One-step-ahead prediction ŷ_{k|k-1} of the model with a predictor gain K.

    From x̂_0 = 0: ŷ_k = C x̂_k + D (u_k − ū) + ȳ, x̂_{k+1} = A x̂_k + B (u_k − ū) + K (y_k − ŷ_k)
    (K from :func:`predictor_gain`; a filter-form gain L gives K = A L). With K = 0 it is the
    free-run simulation (:func:`simulate`). The measured y_k corrects the state, so the fit of
    this prediction measures how well the model predicts one sample ahead, not how well it
    reproduces the outputs from the inputs alone.
    """
    x = np.zeros(m.a.shape[0])
    ys = np.empty((u.shape[0], m.c.shape[0]))
    du = u - m.u_mean
    for k in range(u.shape[0]):
        ys[k] = m.c @ x + m.d @ du[k] + m.y_mean
        x = m.a @ x + m.b @ du[k] + gain @ (y[k] - ys[k])
    return ys


def fit_percent(y: FloatArray, y_hat: FloatArray) -> list[float]:
    """NRMSE fit per output: 100 (1 - ||y - ŷ|| / ||y - ȳ||) (%)."""
    out = []
    for j in range(y.shape[1]):
        den = float(np.linalg.norm(y[:, j] - y[:, j].mean()))
        out.append(100.0 * (1.0 - float(np.linalg.norm(y[:, j] - y_hat[:, j])) / max(den, 1e-300)))
    return out


def identify(duration_s: float = 3000.0, block_rows: int = 10) -> dict[str, Any]:
    """Run the six experiments, fit on tests 1-5 merged, validate on test 6."""
    runs = [run_experiment(i, duration_s) for i in range(len(TABLE5))]
    est = pd.concat(runs[:-1], ignore_index=True)
    val = runs[-1]
    m = n4sid(est, INPUTS, OUTPUTS, block_rows)
    fit_est = fit_percent(est[list(OUTPUTS)].to_numpy(), simulate(m, est[list(INPUTS)].to_numpy()))
    fit_val = fit_percent(val[list(OUTPUTS)].to_numpy(), simulate(m, val[list(INPUTS)].to_numpy()))
    return {
        "order": m.order,
        "singular_values": m.singular_values[:20],
        "fit_estimation_percent": dict(zip(OUTPUTS, fit_est, strict=True)),
        "fit_validation_percent": dict(zip(OUTPUTS, fit_val, strict=True)),
        "eigenvalues_abs": sorted(float(abs(e)) for e in np.linalg.eigvals(m.a)),
        "duration_s_per_test": duration_s,
        "block_rows": block_rows,
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--duration", type=float, default=3000.0, help="seconds per experiment")
    ap.add_argument("--block-rows", type=int, default=10)
    a = ap.parse_args()
    print(json.dumps(identify(a.duration, a.block_rows), indent=1))


if __name__ == "__main__":
    main()
