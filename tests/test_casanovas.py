"""casanovas-2014 (TLP, surge energy capture): designs, finite-horizon LQR, table 3.1, closed loop.

Tolerances are stated with each check; the seed's table 3.1 is the published reference.
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import linalg

from controller.casanovas import (
    CASANOVAS_KINDS,
    CasanovasController,
    affine_solve,
    finite_horizon_solve,
    load_casanovas_design,
    riccati_trajectory,
)
from controller.design.casanovas import (
    PREVIEW_STEP_S,
    SEA_STATES,
    WIND_SPEEDS,
    CasanovasSettings,
    linear_model,
    steady_gain,
    steady_kernel,
    upper_bound,
)
from hil.runlog.mcap_io import read_run

SCENARIOS = Path(__file__).resolve().parents[1] / "hil" / "scenario" / "presets"


def _scalar_riccati(a: float, b: float, q: float, r: float, tau: np.ndarray) -> np.ndarray:
    """Closed form of dP/dτ = 2aP - (b²/r)P² + q, P(0) = 0 (τ = T - t)."""
    s = b * b / r
    beta = math.sqrt(a * a + s * q)
    p_plus, p_minus = (a + beta) / s, (a - beta) / s
    c = (p_plus / p_minus) * np.exp(-2 * beta * tau)
    out: np.ndarray = (p_plus - c * p_minus) / (1 - c)
    return out


def test_scalar_finite_horizon_gain_matches_closed_form_riccati() -> None:
    a, b, q, r = -0.5, 2.0, 3.0, 0.7
    horizon, h = 5.0, 0.05
    m = round(horizon / h)
    gains, ff = finite_horizon_solve(
        np.array([[a]]),
        np.array([[b]]),
        np.array([[q]]),
        np.array([[r]]),
        np.zeros((1, 1)),
        np.array([1.0]),
        np.zeros(2 * m + 1),
        h,
    )
    p = _scalar_riccati(a, b, q, r, horizon - h * np.arange(m + 1))
    np.testing.assert_allclose(gains[:, 0, 0], b * p / r, rtol=1e-4, atol=1e-9)
    assert gains[-1, 0, 0] == 0.0  # P(T) = G = 0
    np.testing.assert_array_equal(ff, 0.0)  # no forcing, no affine term


def test_scalar_affine_term_matches_closed_form_for_constant_forcing() -> None:
    """Steady state of φ̇ = -(a - s P∞) φ - P∞ e X: φ∞ = P∞ e X / (s P∞ - a) far from T."""
    a, b, q, r, x = -0.5, 2.0, 3.0, 0.7, 4.0
    h, m = 0.02, 1500  # T = 30 s, many time constants
    _gains, ff = finite_horizon_solve(
        np.array([[a]]),
        np.array([[b]]),
        np.array([[q]]),
        np.array([[r]]),
        np.zeros((1, 1)),
        np.array([1.0]),
        np.full(2 * m + 1, x),
        h,
    )
    s = b * b / r
    p_inf = (a + math.sqrt(a * a + s * q)) / s
    phi_inf = p_inf * x / (s * p_inf - a)
    assert ff[0, 0] == pytest.approx(b * phi_inf / r, rel=1e-6)


def test_affine_operator_equals_the_loop_solution() -> None:
    d = load_casanovas_design("nrel5mw_tlp_casanovas_u8_hs6")
    c = CasanovasController("lqr_finite", d, 0.1)
    rng = np.random.default_rng(3)
    force = rng.normal(0.0, 2e5, 2 * c.m_steps + 1)
    p_half = riccati_trajectory(c.a, c.b, c.q, c.r, c.n, c.m_steps, c.dt)
    gains, ff = finite_horizon_solve(c.a, c.b, c.q, c.r, c.n, c.e, force, c.dt, p_half)
    np.testing.assert_allclose(c._ff_operator @ force, ff, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c._gains_cached, gains, rtol=1e-12)
    phis = affine_solve(p_half, c.a, c.b, c.r, c.n, c.e, force, c.dt)
    assert phis.shape == (c.m_steps + 1, 7)


@pytest.mark.parametrize("hs", sorted(SEA_STATES))
@pytest.mark.parametrize("wind", WIND_SPEEDS)
def test_shipped_steady_design_is_closed_loop_stable_and_equals_the_long_horizon_limit(
    hs: float, wind: float
) -> None:
    d = load_casanovas_design(f"nrel5mw_tlp_casanovas_u{wind:g}_hs{hs:g}")
    a, b, k = d["a"], d["b"], d["steady_k"]
    eig = np.linalg.eigvals(a - b @ k)
    assert np.all(eig.real < -1e-3), eig
    # The indefinite cost is not positive: R > 0 but Q has a negative eigenvalue (the
    # reward for surge velocity), which is what makes this LQR unconventional.
    assert np.all(np.linalg.eigvalsh(d["r"]) > 0)
    assert np.min(np.linalg.eigvalsh(d["q"])) < 0
    # A 200 s finite horizon from P(T) = 0 converges to the stabilising ARE gain at t = 0.
    m = 2000
    gains, _ = finite_horizon_solve(a, b, d["q"], d["r"], d["n"], d["e"], np.zeros(2 * m + 1), 0.1)
    np.testing.assert_allclose(gains[0], k, rtol=1e-3, atol=1e-6 * np.abs(k).max())


def test_steady_kernel_equals_the_augmented_oscillator_design() -> None:
    """Section 4.5 with one wave component as a decaying oscillator state (x_R, x_I)."""
    settings = CasanovasSettings(wind_m_s=8.0, hs_m=6.0, t1_s=11.6)
    lm = linear_model("nrel5mw_tlp", settings)
    k, p = steady_gain(lm)
    gamma, omega = -0.25, 0.6
    n = lm.a.shape[0]
    a_aug = np.zeros((n + 2, n + 2))
    a_aug[:n, :n] = lm.a
    a_aug[:n, n] = lm.e  # X = x_R
    a_aug[n:, n:] = [[gamma, omega], [-omega, gamma]]
    b_aug = np.vstack([lm.b, np.zeros((2, 2))])
    q_aug = linalg.block_diag(lm.q, np.zeros((2, 2)))
    n_aug = np.vstack([lm.n, np.zeros((2, 2))])
    p_aug = linalg.solve_continuous_are(a_aug, b_aug, q_aug, lm.r, s=n_aug)
    k_aug = np.linalg.solve(lm.r, b_aug.T @ p_aug + n_aug.T)
    np.testing.assert_allclose(k_aug[:, :n], k, rtol=1e-6, atol=1e-12)
    w0 = np.array([1e5, 4e4])  # X(t) = Re((x_R + i x_I) e^{(γ - iω)τ}) ahead
    u_aug = -k_aug[:, n:] @ w0
    tau = PREVIEW_STEP_S * np.arange(81)
    undamped = w0[0] * np.cos(omega * tau) + w0[1] * np.sin(omega * tau)
    kern = steady_kernel(lm, k, p, gamma)
    u_kernel = -(kern.T @ undamped)
    # trapezoid at 0.25 s over 20 s of a kernel decaying with γ = -0.25 1/s: 1 %
    np.testing.assert_allclose(u_kernel, u_aug, rtol=0.01, atol=1e-3 * np.abs(u_aug).max())


#: Seed table 3.1, 100 m depth, 30 m draft: extracted power [kW].
SEED_T31_KW = {
    (6.0, 6.0): 29.3,
    (6.0, 8.0): 42.8,
    (6.0, 10.0): 67.1,
    (10.0, 6.0): 83.3,
    (10.0, 8.0): 120.1,
    (10.0, 10.0): 182.5,
}


@pytest.mark.parametrize(("hs", "wind"), sorted(SEED_T31_KW))
def test_table31_upper_bound_against_the_seed(hs: float, wind: float) -> None:
    """Extracted power within 5 % of the seed at 8 m/s and within 20 % at 6 and 10 m/s.

    The bound uses B_T = dF_T/dV at the optimal tip-speed ratio (linear in V); the seed's
    kW grow faster with wind (its thrust-curve slope), so 6 m/s comes out 11-14 % above
    and 10 m/s 18-19 % below it (docs/studies/casanovas-2014.md).
    """
    r = upper_bound("nrel5mw_tlp", wind, hs, SEA_STATES[hs])
    seed = SEED_T31_KW[(hs, wind)]
    tol = 0.05 if wind == 8.0 else 0.20
    assert r["p_ext_w"] / 1e3 == pytest.approx(seed, rel=tol)
    # Haskind's deep-water relation and the BEM excitation agree within 5 % here
    assert r["p_ext_haskind_w"] == pytest.approx(r["p_ext_w"], rel=0.05)


def test_bad_settings_are_refused_with_a_message() -> None:
    d = load_casanovas_design("nrel5mw_tlp_casanovas_u8_hs6")
    with pytest.raises(ValueError, match="overlap"):
        CasanovasController("lqr_finite", d, 0.1, overlap=1.0)
    with pytest.raises(ValueError, match="exceeds the preview"):
        CasanovasController("lqr_finite", d, 0.1, horizon_s=25.0)
    with pytest.raises(ValueError, match="unknown casanovas kind"):
        CasanovasController("lqr_magic", d, 0.1)
    with pytest.raises(ValueError, match="gauge_distance_m"):
        CasanovasController("lqr_finite", d, 0.1, preview="forecast")
    with pytest.raises(ValueError, match="no casanovas design"):
        load_casanovas_design("nrel5mw_tlp_casanovas_u99_hs6")


def _variant(tmp: Path, kind: str, preview: str = "perfect") -> Path:
    text = (SCENARIOS / "casanovas-tlp-hs6-u8.toml").read_text()
    text = re.sub(r'(?m)^kind = "lqr_overlaid"$', f'kind = "{kind}"', text)
    text = re.sub(r'(?m)^preview = "perfect"$', f'preview = "{preview}"', text)
    path = tmp / f"casanovas-{kind}-{preview}.toml"
    path.write_text(text)
    return path


@pytest.mark.e2e
@pytest.mark.parametrize("kind", CASANOVAS_KINDS)
def test_each_kind_runs_closed_loop_over_zenoh_in_lockstep(tmp_path: Path, kind: str) -> None:
    scenario = _variant(tmp_path, kind)
    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-m", "hil", "run", str(scenario), "--mode", "lockstep",
         "--duration", "3", "--out", str(out), "--no-plots"],
        capture_output=True, text=True, timeout=240, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout + proc.stderr
    run = read_run(out / "run.mcap")
    cycles = 30  # 3 s at 10 Hz
    assert [c["answered_seq"] for c in run.topic("command")] == list(range(cycles))
    # the bench oracle went over the bus, one preview per frame, before it
    assert len(run.topic("preview/wave_perfect")) == cycles
    status = run.topic("controller/status")
    assert len(status) == cycles
    if kind.startswith("lqr_"):
        # estimator_degraded = 1 marks a cycle without the preview of its own frame
        assert sum(s["estimator_degraded"] for s in status) == 0
        assert any(abs(s["feedforward_pitch_rad"]) > 0 for s in status)
    cmds = run.topic("command")
    torque = np.array([c["generator_torque_commanded_nm"] for c in cmds])
    assert np.all((torque > 5e3) & (torque < 4.8e4))  # region 2 at 8 m/s: about 20 kN m
    pitch = np.array([c["blade_pitch_commanded_rad"] for c in cmds])
    assert np.all((pitch >= 0.0) & (pitch < math.radians(10)))
    truth = run.topic("truth")
    assert np.std([t["platform_surge_m"] for t in truth]) > 0.01  # the waves move it


def test_a_missing_design_is_made_on_first_use(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A sea state without a shipped design: ``fowt run`` designs it into the user cache."""
    from rich.console import Console

    from hil.launch import RunRequest, launch

    cache = tmp_path / "designs"
    monkeypatch.setenv("FOWT_DESIGN_DIR", str(cache))
    text = (SCENARIOS / "casanovas-tlp-hs6-u8.toml").read_text()
    text = text.replace("hs_m = 6.0", "hs_m = 8.0").replace("t1_s = 11.6", "t1_s = 12.5")
    text = text.replace("_u8_hs6", "_u8_hs8").replace(
        'kind = "lqr_overlaid"', 'kind = "lqr_steady"'
    )
    path = tmp_path / "hs8.toml"
    path.write_text(text)
    summary = launch(
        RunRequest(str(path), mode="inprocess", duration_s=2.0, out_dir=tmp_path / "run",
                   plots=False),
        Console(file=None, quiet=True),
    )  # fmt: skip
    assert (cache / "nrel5mw_tlp_casanovas_u8_hs8.npz").is_file()
    meta = (cache / "nrel5mw_tlp_casanovas_u8_hs8.json").read_text()
    assert '"t1_s": 12.5' in meta and '"commit"' in meta and '"preset": "nrel5mw_tlp"' in meta
    assert summary["timing"]["cycles"] == 20
