"""Free decay of the parked platform and the closed-loop damping command.

* :func:`plant.decay.decay_cycles` recovers the period and damping ratio of an analytic
  damped oscillation.
* :func:`plant.decay.free_decay` on the shipped OC3-Hywind spar, released from a small
  offset, gives the linear model's damped periods (:func:`plant.modes.natural_modes` at
  0 m/s: the same plant linearised about the still-air equilibrium, radiation states and
  the mooring's tangent stiffness included); without radiation memory its heave period is
  that of the one-DOF spring-mass 2π √((m + A₃₃(∞)) / (k₃₃ + k_zz,moor)).
* ``fowt analyze decay`` and ``fowt analyze closed-loop`` run as a user would run them.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from plant.decay import decay_cycles, free_decay
from plant.modes import natural_modes
from plant.platform import load_floating

ROOT = Path(__file__).resolve().parent.parent
OC3 = "nrel5mw_oc3_hywind"


def test_decay_cycles_recover_an_analytic_damped_oscillation() -> None:
    """y = a e^{−ζωt}(cos ω_d t + ζ/√(1−ζ²) sin ω_d t), released at rest from a: every
    cycle's period is 2π/ω_d and its damping ratio ζ, to 1e-4 relative (10 ms sampling)."""
    zeta, omega, a = 0.05, 2.0 * math.pi / 30.0, 2.0
    wd = omega * math.sqrt(1.0 - zeta**2)
    t = np.arange(0.0, 200.0, 0.01)
    env = a * np.exp(-zeta * omega * t)
    y = env * (np.cos(wd * t) + zeta / math.sqrt(1.0 - zeta**2) * np.sin(wd * t))
    rate = -a * omega / math.sqrt(1.0 - zeta**2) * np.exp(-zeta * omega * t) * np.sin(wd * t)
    cycles = decay_cycles(t, y, rate, 1.0)
    assert len(cycles) == 6
    for c in cycles:
        assert c.period_s == pytest.approx(2.0 * math.pi / wd, rel=1e-4)
        assert c.damping_ratio == pytest.approx(zeta, rel=1e-4)
    assert cycles[0].amplitude == a
    # the other side: released from −a, minima counted
    down = decay_cycles(t, -y, -rate, -1.0)
    assert [c.period_s for c in down] == pytest.approx([c.period_s for c in cycles])


@pytest.fixture(scope="module")
def oc3_linear() -> dict[str, float]:
    return {m.name: m.period_s for m in natural_modes(OC3, 0.0)}


@pytest.mark.parametrize(("dof", "offset", "rel"), [("heave", 0.5, 0.002), ("pitch", 0.5, 0.01)])
def test_small_decay_recovers_the_linear_period(
    oc3_linear: dict[str, float], dof: str, offset: float, rel: float
) -> None:
    """Small offsets: the decay's mean period within ``rel`` of the damped linear period
    (pitch 1 %: its cycles beat with the slow surge it drives)."""
    res = free_decay(OC3, dof, offset)
    assert len(res.cycles) >= 4
    assert res.mean_period_s == pytest.approx(oc3_linear[dof], rel=rel)
    assert all(0.0 < c.damping_ratio < 0.2 for c in res.cycles)
    assert res.displacement[0] == pytest.approx(offset)


def test_small_surge_decay_ends_at_the_linear_period(oc3_linear: dict[str, float]) -> None:
    """Surge from 1 m: every cycle within 2.5 % of the linear period, and the cycles below
    6 cm of amplitude within 0.3 %. The difference at larger amplitude is the mooring table:
    its knots are 1 m apart, so the stiffness is piecewise constant (41.6 kN/m on [−1, 0] m,
    40.8 kN/m on [0, 1] m); the linearisation about the equilibrium (−0.086 m) sees the
    first, a release from 1 m spends half of each cycle on the softer second."""
    res = free_decay(OC3, "surge", 1.0, 1200.0)
    linear = oc3_linear["surge"]
    assert all(c.period_s == pytest.approx(linear, rel=0.025) for c in res.cycles)
    small = [c for c in res.cycles if c.amplitude < 0.06]
    assert small
    assert all(c.period_s == pytest.approx(linear, rel=3e-3) for c in small)


def test_heave_without_memory_is_the_spring_mass_period() -> None:
    """No radiation memory: the heave decay's period is the one-DOF spring-mass period with
    the infinite-frequency added mass, T = 2π √(M₂₂ / (K₂₂ + k_zz)), M and K of the preset
    (structure + A∞, hydrostatics + gravity terms), k_zz the mooring's heave stiffness;
    within 0.3 % (the spar's heave is nearly uncoupled; the drag damps it by ζ ≈ 0.01)."""
    p = load_floating(OC3, radiation=False)
    k = float(p.stiffness[1, 1]) + float(p.mooring.stiffness_heave_pitch[0, 0])
    analytic = 2.0 * math.pi * math.sqrt(float(p.mass_matrix[1, 1]) / k)
    res = free_decay(OC3, "heave", 0.5, radiation=False)
    assert res.mean_period_s == pytest.approx(analytic, rel=3e-3)


def _fowt(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "hil", *args], cwd=ROOT, capture_output=True, text=True, check=False
    )


def test_decay_command_json_and_bad_input() -> None:
    done = _fowt("analyze", "decay", OC3, "--dof", "heave", "--offset", "0.5", "--json")
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert out["dof"] == "heave" and out["unit"] == "m" and out["radiation_memory"]
    assert out["period_s"] == pytest.approx(30.92, abs=0.1)
    assert "rotor aerodynamics off" in out["case"]
    bad = _fowt("analyze", "decay", OC3, "--dof", "heave", "--offset", "0")
    assert bad.returncode == 2 and bad.stderr.startswith("error: --offset")
    missing = _fowt("analyze", "decay", "no/such/preset.toml")
    assert missing.returncode == 2 and "expected an existing file" in missing.stderr
    both = _fowt("analyze", "closed-loop", "iea15mw-still-water", "--controller", "baseline")
    assert both.returncode == 2 and "not both" in both.stderr


def test_closed_loop_command_gives_finite_damping_for_the_baseline_at_8() -> None:
    """Baseline controller, 8 m/s, surge released 2 m: a finite, positive damping ratio and a
    period near the open-loop one (the surge mode is the mooring's, 100-110 s)."""
    done = _fowt(
        "analyze", "closed-loop", "--controller", "baseline", "--winds", "8", "--dof", "surge",
        "--duration", "400", "--json",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert out["controller"] == "baseline"
    (row,) = out["modes"]
    assert row["dof"] == "surge" and row["wind_m_s"] == 8.0
    assert math.isfinite(row["damping_ratio"]) and 0.0 < row["damping_ratio"] < 0.3
    assert row["period_s"] == pytest.approx(row["open_loop_period_s"], rel=0.1)
