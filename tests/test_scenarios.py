"""Scenario validation: the floating sections, new wind kinds and sensor channel tables."""

from __future__ import annotations

import pytest
from _helpers import STEADY_FLOATING_SCENARIO

from hil.scenario.schema import (
    JonswapWavesSpec,
    ScenarioError,
    StillWavesSpec,
    TurbulentWindSpec,
    load_scenario,
    parse_scenario,
    shipped_scenarios,
)

BASE = STEADY_FLOATING_SCENARIO  # the smallest floating scenario (TOML)


def test_every_shipped_scenario_loads() -> None:
    names = shipped_scenarios()
    for required in (
        "default",
        "nrel5mw-ramp",
        "nrel5mw-steady-8",
        "nrel5mw-steady-18",
        "iea15mw-still-water",
        *(f"iea15mw-lc{i}" for i in range(1, 8)),
    ):
        assert required in names
    for name in names:
        load_scenario(name)


def test_default_is_load_case_2_of_al_2019() -> None:
    sc = load_scenario("default")
    assert sc.platform == "iea15mw_volturnus" and sc.turbine == "iea15mw"
    assert isinstance(sc.wind, TurbulentWindSpec) and sc.wind.mean_m_s == 7.1
    assert isinstance(sc.waves, JonswapWavesSpec)
    assert (sc.waves.hs_m, sc.waves.tp_s, sc.waves.gauge_distance_m) == (1.7, 8.0, 450.0)
    assert sc.timing.control_period_s == 0.025 and sc.duration_s == 60.0
    assert sc.controller.preset == "iea15mw_baseline"
    assert isinstance(load_scenario("iea15mw-still-water").waves, StillWavesSpec)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            '[waves]\nkind = "jonswap"\nhs_m = 1.7\ntp_ms = 8.0\n',
            "'waves.tp_ms'; did you mean 'tp_s'",
        ),
        ('[waves]\nkind = "jonswap"\nhs_m = 1.7\n', "tp_s"),
        ('[waves]\nkind = "tsunami"\n', "kind"),
        (
            '[waves]\nkind = "issc"\nhs_m = 2.0\nt1_s = 7.0\nomega_min_rad_s = 2.0\n'
            "omega_max_rad_s = 1.0\n",
            "omega_max_rad_s",
        ),
        ("[sensors.channels.platform_surge]\nstd = 0.1\n", "unknown channel 'platform_surge'"),
        (
            "[sensors.channels.platform_surge_measured_m]\nstd_m = 0.1\n",
            "unknown key 'std_m'",
        ),
        (
            "[sensors.channels.platform_surge_measured_m]\ndropout_probability = 1.5\n",
            "dropout_probability",
        ),
    ],
)
def test_bad_floating_sections_name_the_key(extra: str, message: str) -> None:
    with pytest.raises(ScenarioError, match=None) as exc:
        parse_scenario(BASE + extra)
    assert message in str(exc.value)


def test_waves_need_a_platform_and_the_platform_must_exist() -> None:
    text = BASE.replace('platform = "iea15mw_volturnus"\n', "")
    with pytest.raises(ScenarioError, match="needs a floating plant"):
        parse_scenario(text + '[waves]\nkind = "still"\n')
    with pytest.raises(ScenarioError, match="platform = 'nowhere'"):
        parse_scenario(BASE.replace("iea15mw_volturnus", "nowhere"))


def test_new_wind_kinds_validate() -> None:
    text = BASE.replace('kind = "steady"\nspeed_m_s = 10.0', 'kind = "turbulent"\nmean_m_s = 9.0')
    sc = parse_scenario(text)
    assert isinstance(sc.wind, TurbulentWindSpec) and sc.wind.turbulence_class == "B"
    with pytest.raises(ScenarioError, match="turbulence_class"):
        parse_scenario(text + 'turbulence_class = "D"\n')
    gust = BASE.replace('kind = "steady"\nspeed_m_s = 10.0', 'kind = "gust"\nhub_speed_m_s = 12.0')
    assert parse_scenario(gust).wind.hub_speed_m_s == 12.0  # type: ignore[union-attr]
    with pytest.raises(ScenarioError, match="speed_m_s"):
        parse_scenario(
            BASE.replace('kind = "steady"\nspeed_m_s = 10.0', 'kind = "gust"\nhub_speed_ms = 12.0')
        )


def test_old_bottom_fixed_keys_still_work() -> None:
    sc = load_scenario("nrel5mw-ramp")
    assert sc.platform is None and sc.waves is None
    assert sc.sensors.generator_speed_std_rad_s == 0.5
