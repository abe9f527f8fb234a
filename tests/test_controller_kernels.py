"""The controller's compiled kernels (controller._kernels) against numpy's own algebra.

The observers' behaviour is tested in test_estimators.py (against filterpy and the plant),
the LQRI and wave FF in test_lqri.py and test_wave_ff.py; here the pieces that have no
counterpart left in Python are checked against the textbook numpy expressions they replace:
the small-matrix inverse, the fused KF predict + update, and the wave-FF filter bank.
Random inputs are seeded; tolerances are stated at each assertion.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller import _kernels
from controller.estimators import PlatformKF, PlatformKFConfig
from controller.lqri import LqriController, load_lqri_design, load_wave_ff_design


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_inverse_matches_numpy_on_innovation_covariances(k: int) -> None:
    rng = np.random.default_rng(15 + k)
    for _ in range(50):
        a = rng.normal(size=(k, k)) * 10.0 ** rng.uniform(-4, 2, size=k)
        s = a @ a.T + np.diag(10.0 ** rng.uniform(-6, 0, size=k))  # SPD like H P H^T + R
        got = _kernels._inverse(s)
        want = np.linalg.inv(s)
        # two backward-stable eliminations (partial pivoting) differ by at most a small
        # multiple of eps cond(S) relative to the inverse's size
        tol = 100.0 * np.finfo(np.float64).eps * np.linalg.cond(s)
        assert np.max(np.abs(got - want)) <= tol * np.max(np.abs(want))
        assert np.max(np.abs(got @ s - np.eye(k))) <= tol


def _filter(rng: np.random.Generator) -> PlatformKF:
    n, m, p = 6, 2, 4
    f = np.eye(n) + 0.02 * rng.normal(size=(n, n))
    q = np.diag(rng.uniform(1e-6, 1e-4, n))
    r = np.diag(rng.uniform(1e-4, 1e-2, p))
    return PlatformKF(
        PlatformKFConfig(
            F=f,
            B=0.1 * rng.normal(size=(n, m)),
            H=rng.normal(size=(p, n)),
            D=0.1 * rng.normal(size=(p, m)),
            Q=q,
            R=r,
            dt_s=0.025,
            gate_probability=0.999,
            max_consecutive_misses=3,
        )
    )


def test_fused_predict_update_equals_predict_then_update() -> None:
    rng = np.random.default_rng(2026)
    kf = _filter(rng)
    a = b = kf.initial_state()
    for k in range(400):
        u = tuple(rng.normal(size=2))
        z = rng.normal(size=4) * 0.1
        if k % 37 == 5:
            z[2] = 1e3  # an outlier the gate rejects
        valid = tuple(bool(v) for v in rng.random(4) > 0.15)
        dt = 0.025 * (2 if k % 50 == 7 else 1)  # a late cycle: two model steps
        a = kf.update(kf.predict(a, u, dt), z, valid, u)
        b = kf.predict_update(b, u, z, valid, dt)
        # the same kernels in the same order: identical to the last bit
        assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)
        assert np.array_equal(a.counts, b.counts) and a.degraded == b.degraded
        assert np.array_equal(a.nis, b.nis, equal_nan=True)
    assert sum(b.rejected) > 0 and sum(b.skipped) > 0 and sum(b.accepted) > 0


def test_wave_ff_bank_matches_the_dense_product() -> None:
    design = load_lqri_design("iea15mw_volturnus", 0.025)
    ff = load_wave_ff_design("iea15mw_volturnus", 0.025)
    ctrl = LqriController(design, ff, feedforward="balanced")
    rng = np.random.default_rng(7)
    zs = rng.normal(size=ff.b.shape)
    for wind in (5.0, 9.3, 12.0, 16.9, 17.1, 24.0):
        for eta in (0.7, -1.2):
            zn = np.empty_like(zs)
            u_ff, is_pitch, near = _kernels.ff_cycle(*ctrl._ff, zs, wind, eta, zn)
            want_zn = np.matmul(ff.a, zs[:, :, None])[:, :, 0] + ff.b * eta
            # 25-term sums in another order: within 1e-13 of the largest state
            assert np.max(np.abs(zn - want_zn)) <= 1e-13 * max(1.0, np.max(np.abs(want_zn)))
            grid = np.array(ff.wind_m_s)
            i = int(np.clip(np.searchsorted(grid, wind, side="right") - 1, 0, grid.size - 2))
            w = float(np.clip((wind - grid[i]) / (grid[i + 1] - grid[i]), 0.0, 1.0))
            j = i + 1
            if ff.is_pitch[i] != ff.is_pitch[j]:
                i = j if w >= 0.5 else i
                j, w = i, 0.0
            out = (1 - w) * (ff.c[i] @ zs[i] + ff.d[i] * eta) + w * (
                ff.c[j] @ zs[j] + ff.d[j] * eta
            )
            want = ff.gain("balanced", wind) * out
            assert u_ff == pytest.approx(want, rel=1e-12, abs=1e-15)
            assert near == (j if w >= 0.5 else i) and is_pitch == ff.is_pitch[near]
    # a NaN forecast: no feedforward, every filter held
    zn = np.empty_like(zs)
    u_ff, _, _ = _kernels.ff_cycle(*ctrl._ff, zs, 12.0, math.nan, zn)
    assert u_ff == 0.0 and np.array_equal(zn, zs)
