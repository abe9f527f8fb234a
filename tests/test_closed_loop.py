"""Baseline controller against the turbine plant, in process: published steady states."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from _helpers import run_closed_loop

from bus_schemas import PlantState
from hil.scenario.schema import load_scenario, parse_scenario, scenario_text
from plant.turbine import load_turbine


def _run(scenario_text: str) -> list[PlantState]:
    result, truth, _ = run_closed_loop(parse_scenario(scenario_text))
    assert result.deadline_misses == 0
    return truth


def _steady(wind: float, duration: float = 120.0) -> str:
    return f"""
name = "steady-{wind}"
turbine = "nrel5mw"
duration_s = {duration}
[wind]
kind = "steady"
speed_m_s = {wind}
[controller]
kind = "baseline"
preset = "nrel5mw_baseline"
"""


def test_region2_settles_within_2_percent_of_tsr_optimal_speed() -> None:
    """8 m/s: the K-omega^2 law holds the rotor near lambda_opt * U / R (tolerance 2 %)."""
    truth = _run(_steady(8.0))
    turbine = load_turbine("nrel5mw")
    omega_opt = turbine.table.optimal_tsr() * 8.0 / turbine.rotor_radius_m
    last = np.array([s.rotor_speed_rad_s for s in truth[-1000:]])  # last 10 s
    assert abs(last.mean() / omega_opt - 1.0) < 0.02
    assert last.std() < 1e-3 * omega_opt  # settled, not oscillating


def test_region3_holds_rated_power_and_rated_speed_within_1_percent() -> None:
    """18 m/s: 5 MW electrical and 12.1 rpm (tolerance 1 % each)."""
    truth = _run(_steady(18.0))
    last = truth[-1000:]
    power = np.mean([s.electrical_power_w for s in last])
    rpm = np.mean([s.rotor_speed_rad_s for s in last]) * 60 / (2 * np.pi)
    assert abs(power / 5.0e6 - 1.0) < 0.01
    assert abs(rpm / 12.1 - 1.0) < 0.01
    pitch_deg = np.degrees(np.mean([s.blade_pitch_rad for s in last]))
    assert 5.0 < pitch_deg < 25.0  # pitched to feather, as region 3 requires


def test_wind_step_through_rated_recovers_rated_speed() -> None:
    text = _steady(10.0, 90.0).replace(
        'kind = "steady"\nspeed_m_s = 10.0',
        'kind = "step"\ninitial_m_s = 10.0\nfinal_m_s = 16.0\ntime_s = 10.0',
    )
    truth = _run(text)
    rpm = np.array([s.rotor_speed_rad_s for s in truth]) * 60 / (2 * np.pi)
    assert rpm.max() < 12.1 * 1.2  # the PI pitch loop caps the overspeed
    assert abs(rpm[-500:].mean() / 12.1 - 1.0) < 0.01


def test_seeded_runs_are_identical() -> None:
    text = scenario_text("nrel5mw-ramp")[0].replace("duration_s = 60.0", "duration_s = 5.0")
    std = load_scenario("nrel5mw-ramp").sensors.generator_speed_std_rad_s
    assert std is not None and std > 0  # noise is on
    a = _run(text)
    b = _run(text)
    assert [s.rotor_speed_rad_s for s in a] == [s.rotor_speed_rad_s for s in b]


@pytest.mark.parametrize(
    "module", ["controller.baseline", "controller.registry", "hil.nodes.controller_node"]
)
def test_controller_runtime_never_imports_the_plant(module: str) -> None:
    code = (
        f"import sys, {module}\n"
        "bad = [m for m in sys.modules if m == 'plant' or m.startswith('plant.')]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_plant_never_imports_the_controller() -> None:
    code = (
        "import sys, plant.simulator, plant.turbine\n"
        "bad = [m for m in sys.modules if m == 'controller' or m.startswith('controller.')]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
