"""christiansen-2013 on the OC3-Hywind spar: preset, detuned baseline, lqr_wave design and run.

Published figures compared with (Jonkman 2010, NREL/TP-500-47535, "Definition of the Floating
System for Phase IV of OC3", and the OC3 Phase IV free-decay results): surge natural period
about 125 s (0.008 Hz), heave about 31.3 s (0.032 Hz), platform pitch about 29.4 s (0.034 Hz,
``../shared/reference/openfast/NREL-5MW-OC3Hywind/README.md``: confirmed by the definition's
author). Tolerance 6 % (our hull is the BEM of a 24-sided polygon hull and the tower is the
land-based NREL 5 MW tower, see ``plant/oc3_hywind.py``). The mooring surge stiffness at zero
offset is 41 180 N/m in the OC3 definition (section 5, mooring system properties); 2 %.

None of these tests needs capytaine or MoorPy: they read the shipped preset and designs. The
BEM script itself is checked against the preset's data (test skipped without capytaine).
"""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from controller.baseline import load_baseline
from controller.lqr_wave import LqrWaveController, load_lqr_wave_design, load_lqr_wave_preset
from plant.modes import natural_modes

PRESET = "nrel5mw_oc3_hywind"


@pytest.fixture(scope="module")
def modes_still() -> dict[str, float]:
    """Damped periods (s) at (nearly) zero wind: the platform's free decay."""
    return {m.name: m.period_s for m in natural_modes(PRESET, wind_m_s=0.1)}


@pytest.mark.parametrize(
    ("dof", "published_s"), [("surge", 125.0), ("heave", 31.3), ("pitch", 1.0 / 0.034)]
)
def test_natural_periods_match_oc3(
    modes_still: dict[str, float], dof: str, published_s: float
) -> None:
    got = modes_still[dof]
    assert abs(got - published_s) / published_s < 0.06, f"{dof}: {got:.2f} s vs {published_s:.2f} s"


def test_mooring_surge_stiffness_matches_oc3() -> None:
    from importlib import resources

    text = (resources.files("plant.presets.floating") / f"{PRESET}_mooring.json").read_text()
    k11 = json.loads(text)["stiffness_6x6_at_zero"][0][0]
    assert abs(k11 - 41180.0) / 41180.0 < 0.02, k11


def test_detuned_baseline_has_the_published_oc3_gains() -> None:
    p = load_baseline("nrel5mw_oc3_hywind_baseline")
    assert p.pitch_kp_s == pytest.approx(0.006275604)
    assert p.pitch_ki_dimensionless == pytest.approx(0.0008965149)
    assert p.region3_mode == "constant_torque"
    # pitch-loop natural frequency of the NREL/TP-500-38060 design method scales with sqrt(KI):
    # 0.6 rad/s * sqrt(0.0008965149 / 0.008068634) = 0.2 rad/s (Jonkman 2010's target)
    assert 0.6 * math.sqrt(0.0008965149 / 0.008068634) == pytest.approx(0.2, rel=1e-3)


@pytest.mark.parametrize("variant", ["lqr1", "lqr2"])
@pytest.mark.parametrize("dt", [0.1, 0.025])
def test_every_scheduled_design_point_is_stable(variant: str, dt: float) -> None:
    """Eigenvalues of every discrete closed loop (all winds x wave frequencies) inside |z| = 1.

    Recomputed from the design model (needs only the shipped preset), not read from the file.
    """
    from controller.design.lqr_wave import design_matrices, spar_model

    d = load_lqr_wave_design(PRESET, variant, dt)
    m = spar_model(PRESET)
    worst = 0.0
    for i, v in enumerate(d.wind_m_s):
        for j, w in enumerate(d.wave_omega_rad_s[::5]):
            a, b = design_matrices(m, float(v), float(w))
            from controller.design.lqr_wave import LqrWaveSettings, discrete_lqr, weights

            _, f, g = discrete_lqr(a, b, *weights(LqrWaveSettings(variant=variant)), dt)
            k = d.gains[i, 5 * j][None, :]
            worst = max(worst, float(np.max(np.abs(np.linalg.eigvals(f - g @ k)))))
    assert worst < 1.0, worst
    # the whole table (file): every point stable
    assert d.meta["max_closed_loop_spectral_radius"] < 1.0


def test_schedule_interpolation_at_grid_points_equals_the_point_design(tmp_path: Path) -> None:
    """K(v_i, w_j) of the table (bilinear look-up at the grid point) equals a fresh point design
    at (v_i, w_j)."""
    from controller.design.lqr_wave import (
        LqrWaveSettings,
        design_matrices,
        discrete_lqr,
        spar_model,
        weights,
    )

    d = load_lqr_wave_design(PRESET, "lqr2", 0.1)
    m = spar_model(PRESET)
    s = LqrWaveSettings(variant="lqr2")
    for v, w in [(11.5, 0.0), (18.0, 0.6), (25.0, 5.0), (14.5, 1.3)]:
        a, b = design_matrices(m, v, w)
        k, _, _ = discrete_lqr(a, b, *weights(s), 0.1)
        np.testing.assert_allclose(d.gain(v, w), k[0], rtol=1e-6, atol=1e-9)
    # between grid points the look-up is the bilinear mean of the corners
    mid = d.gain(18.25, 0.65)
    corners = [d.gain(v, w) for v in (18.0, 18.5) for w in (0.6, 0.7)]
    np.testing.assert_allclose(mid, np.mean(corners, axis=0), rtol=1e-9)


def test_wave_frequency_enters_through_added_mass_and_damping() -> None:
    """The model at w differs from the one at another w only in the q̈ rows (hydro)."""
    from controller.design.lqr_wave import design_matrices, spar_model

    m = spar_model(PRESET)
    a1, _ = design_matrices(m, 18.0, 0.3)
    a2, _ = design_matrices(m, 18.0, 1.5)
    diff = np.abs(a1 - a2) > 1e-12 * (1.0 + np.abs(a1))
    assert diff[4:8].any()
    assert not diff[:4].any() and not diff[8:].any()


def test_controller_core_runs_without_plant() -> None:
    """The runtime builds from files only (no plant import in a fresh interpreter)."""
    code = (
        "import sys; from controller.registry import make_controller; "
        "c = make_controller('lqr_wave', 'nrel5mw_oc3_hywind_lqr2', control_period_s=0.1); "
        "c.initial_state(); "
        "assert not any(m == 'plant' or m.startswith('plant.') for m in sys.modules), "
        "[m for m in sys.modules if m.startswith('plant')]"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    assert isinstance(
        LqrWaveController(load_lqr_wave_preset("nrel5mw_oc3_hywind_lqr1"), 0.025), LqrWaveController
    )


def test_missing_design_names_the_command(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="fowt design"):
        LqrWaveController(load_lqr_wave_preset("nrel5mw_oc3_hywind_lqr2"), 0.05, tmp_path)


@pytest.mark.e2e
def test_lqr_wave_closed_loop_over_zenoh_in_lockstep(tmp_path: Path) -> None:
    """lqr_wave against the spar over real Zenoh sessions in lock-step, 40 s at 10 Hz."""
    from hil.runlog.mcap_io import read_run

    out = tmp_path / "run"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "hil",
            "run",
            "oc3-hywind-tp10-lqr2",
            "--mode",
            "lockstep",
            "--duration",
            "40",
            "--out",
            str(out),
            "--no-plots",
        ],
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    run = read_run(out / "run.mcap")
    assert not run.truncated, run.error
    cycles = 400
    for suffix in ("sensors", "command", "truth", "controller/status"):
        assert len(run.topic(suffix)) == cycles, suffix
    truth = run.topic("truth")
    omega = np.array([m["rotor_speed_rad_s"] for m in truth])
    pitch = np.array([m["platform_pitch_rad"] for m in truth])
    # regulates in 14.9 % turbulence: mean rotor speed within 10 % of rated 1.2671 rad/s after
    # 10 s and every sample within 30 % (a 30 s window of 14.9 % turbulence: with the seed's
    # published weights alone it measured mean -8.5 %, -20 % .. +7 %); platform pitch within
    # 0..8 deg (mean about 2.7 deg at 18 m/s)
    rel = omega[100:] / 1.2671 - 1.0
    assert abs(rel.mean()) < 0.10 and np.all(np.abs(rel) < 0.30), (rel.mean(), rel.min(), rel.max())
    assert np.all((pitch > 0.0) & (pitch < math.radians(8.0)))
    status = run.topic("controller/status")
    assert all(s["regime"] == 4 for s in status)
    cmd = np.array([c["blade_pitch_commanded_rad"] for c in run.topic("command")])
    assert np.all(np.abs(np.diff(cmd)) <= math.radians(8.0) * 0.1 + 1e-9)


@pytest.mark.skipif(
    importlib.util.find_spec("capytaine") is None, reason="needs capytaine ([hydro])"
)
def test_bem_script_reproduces_the_shipped_data() -> None:
    """The product's spar BEM at two frequencies equals the shipped npz (same mesh)."""
    from plant.hydro.spar_bem import spar_bem
    from plant.hydro.wamit import load_hydro_preset

    shipped = load_hydro_preset(PRESET)
    w = shipped.radiation.omega_rad_s[[10, 20]]
    hydro, _ = spar_bem(w)
    ref = shipped.radiation.added_mass[[10, 20]]
    np.testing.assert_allclose(
        hydro.radiation.added_mass, ref, rtol=1e-6, atol=1e-9 * float(np.abs(ref).max())
    )


def test_open_loop_pitch_damping_peaks_near_rated_wind() -> None:
    """christiansen-2013 sect. 2.9: the open-loop platform-pitch damping peaks near 10.4 m/s.

    Ours peaks at 11 m/s (grid 0.5 m/s; rated is 11.4 m/s) on every wave frequency, 1 m/s
    tolerance. The seed's wave frequency of the maximum (0.09 Hz) is not reproduced: B55 peaks
    at 0.59 rad/s (0.093 Hz), but the coupled surge-pitch mode's damping follows the surge
    radiation damping (peak 1.39 rad/s) and the map peaks at 1.5 rad/s (0.24 Hz)
    (``bench/results/christiansen_damping_map.json``).
    """
    from controller.design.lqr_wave import damping_map

    rep = damping_map(PRESET, np.arange(8.0, 14.01, 0.5), np.array([0.3, 0.6, 1.5]))
    assert abs(rep["max_at_wind_m_s"] - 10.4) <= 1.0, rep["max_at_wind_m_s"]
    zeta = np.array(rep["pitch_damping_ratio"])
    winds = np.array(rep["wind_m_s"])
    for j in range(zeta.shape[1]):
        assert abs(winds[int(np.nanargmax(zeta[:, j]))] - 10.4) <= 1.0
    assert np.all(zeta[np.isfinite(zeta)] > 0.0)  # open loop: positively damped


def test_run_at_an_unshipped_period_designs_lqr_wave_on_first_use(tmp_path: Path) -> None:
    """``fowt run`` at 20 Hz (not shipped) designs the gain table into $FOWT_DESIGN_DIR first,
    with the preset, settings and commit recorded beside it."""
    import os

    text = (
        Path(__file__).parents[1] / "hil/scenario/presets/oc3-hywind-tp10-lqr1.toml"
    ).read_text()
    text = text.replace("control_period_s = 0.1 ", "control_period_s = 0.05 ")
    scen = tmp_path / "s.toml"
    scen.write_text(text.replace('name = "oc3-hywind-tp10-lqr1"', 'name = "first-use"'))
    cache = tmp_path / "designs"
    env = {**os.environ, "FOWT_DESIGN_DIR": str(cache)}
    cmd = [sys.executable, "-m", "hil", "run", str(scen), "--mode", "inprocess"]
    cmd += ["--duration", "3", "--out", str(tmp_path / "run"), "--no-plots"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "designed lqr_wave lqr1 at 0.05 s" in proc.stdout
    meta = json.loads((cache / "nrel5mw_oc3_hywind_lqr_wave_lqr1_dt0p05.json").read_text())
    assert meta["preset"] == PRESET and meta["control_period_s"] == 0.05
    assert meta["settings"]["variant"] == "lqr1" and len(meta["commit"]) >= 7
    assert meta["max_closed_loop_spectral_radius"] < 1.0
