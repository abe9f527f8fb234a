"""Scenario validation of bad input (in process) and the shipped ``nrel5mw-tlp`` scenario."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest
from _helpers import run_closed_loop

from hil.scenario.schema import (
    MAX_DURATION_S,
    ScenarioError,
    load_scenario,
    non_finite_key,
    parse_scenario,
    scenario_text,
)

#: Tendon surge stiffness of the nrel5mw_tlp preset, T/L = 6 x 1800 kN / 115 m
#: (casanovas-2014 App. I; the preset's mooring table is linear in surge).
TLP_SURGE_STIFFNESS_N_M = 6 * 1.8e6 / 115.0


def test_non_finite_key_names_the_nested_key() -> None:
    raw = {
        "a": 1.0,
        "sensors": {"channels": {"x": {"std": 0.1, "bias": -math.inf}}},
        "faults": [{"start_s": 0.0}, {"start_s": math.nan}],
    }
    assert non_finite_key(raw) == ("sensors.channels.x.bias", -math.inf)
    del raw["sensors"]
    found = non_finite_key(raw)
    assert found is not None and found[0] == "faults[1].start_s" and math.isnan(found[1])
    assert non_finite_key({"a": [1.0, 2, "inf", {"b": 1e308}]}) is None  # strings are not numbers


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, 0.0, -5.0, 1e12])
def test_with_duration_refuses_what_the_file_would(value: float) -> None:
    sc = load_scenario("nrel5mw-ramp")
    with pytest.raises(ScenarioError, match="--duration: expected"):
        sc.with_duration(value)
    assert sc.with_duration(MAX_DURATION_S).duration_s == MAX_DURATION_S


def test_a_shipped_name_wins_over_a_local_file_of_that_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    local = _tlp_text().replace('name = "nrel5mw-tlp"', 'name = "local"')
    Path("nrel5mw-ramp").write_text(local)
    assert load_scenario("nrel5mw-ramp").name == "nrel5mw-ramp"  # the shipped one
    assert load_scenario(f".{os.sep}nrel5mw-ramp").name == "local"  # a path is a path
    Path("nrel5mw-steady-8").mkdir()
    assert load_scenario("nrel5mw-steady-8").name == "nrel5mw-steady-8"
    Path("mine").mkdir()
    with pytest.raises(ScenarioError, match=r"is a directory.*no shipped scenario"):
        load_scenario("mine")


def test_binary_and_unreadable_scenario_files(tmp_path: Path) -> None:
    path = tmp_path / "b.toml"
    path.write_bytes(b"name = \xff\xfe\n")
    with pytest.raises(ScenarioError, match="UTF-8 TOML text file, found binary data"):
        load_scenario(str(path))


def test_nan_is_reported_as_not_finite_not_as_a_failed_bound() -> None:
    text = _tlp_text().replace("hs_m = 6.0", "hs_m = nan")
    with pytest.raises(
        ScenarioError, match=r"key 'waves\.hs_m': expected a finite number, got nan"
    ):
        parse_scenario(text, "x.toml")


def _tlp_text() -> str:
    return scenario_text("nrel5mw-tlp")[0]


def test_tlp_in_still_water_sits_at_thrust_over_tendon_stiffness() -> None:
    """Static balance of the surge-only TLP: x = T_thrust / (T/L), heave and pitch locked."""
    text = (
        _tlp_text()
        .replace('kind = "issc"', 'kind = "still"')
        .replace("hs_m = 6.0\n", "")
        .replace("t1_s = 10.3\n", "")
        .replace("duration_s = 300.0", "duration_s = 20.0")
    )
    _, truth, _ = run_closed_loop(parse_scenario(text, "tlp-still"))
    last = truth[-1000:]  # the last 10 s
    surge = np.mean([t.platform_surge_m for t in last])
    thrust = np.mean([t.rotor_thrust_n for t in last])
    assert thrust > 3e5  # region 2 at 10 m/s: several hundred kN
    assert surge == pytest.approx(thrust / TLP_SURGE_STIFFNESS_N_M, rel=1e-3)
    assert all(t.platform_heave_m == 0.0 and t.platform_pitch_rad == 0.0 for t in truth)


def test_shipped_tlp_scenario_runs_in_waves() -> None:
    """The shipped scenario (5 s of it): surge excited by the waves, locked modes stay 0."""
    sc = load_scenario("nrel5mw-tlp").with_duration(5.0)
    result, truth, frames = run_closed_loop(sc)
    assert result.cycles == 500
    force = np.array([t.wave_force_surge_n for t in truth])
    assert np.std(force) > 1e4  # Hs 6 m on the R 4.75 m buoy: a force of order 100 kN
    assert all(t.platform_heave_m == 0.0 and t.platform_pitch_rad == 0.0 for t in truth)
    assert all(np.isfinite(t.platform_surge_m) for t in truth)
    assert len(frames) == 500
