"""The plant's watchdog: consecutive missed deadlines put the plant in its safe state.

The controller is the real baseline; "missing a deadline" is simulated by the in-process
cycle returning no command from a chosen time on (what the plant sees when the controller
process dies or stalls). The safe state must (1) start after exactly ``watchdog_misses``
consecutive misses, (2) move the blade pitch towards feather at the pitch actuator's rate
limit and ramp the generator torque down at its rate limit, (3) say so in every cycle's
timing record and in the summary, and (4) follow the stated recovery rule: latched by
default, handed back after K on-time commands when ``watchdog_recover_cycles`` = K.
"""

from __future__ import annotations

import math

import msgspec
import pytest
from _helpers import run_collecting

from bus_schemas import ActuatorCommand, CycleTiming, PlantState, SensorFrame, TimingSummary
from bus_schemas.registry import CYCLE_TIMING, TIMING_SUMMARY, TRUTH
from hil.scenario.schema import ScenarioError, load_scenario, parse_scenario, scenario_text
from plant.turbine import load_turbine

STALL_S = 5.0  # the controller stops answering here


def _run(
    misses: int, recover: int = 0, answer_again_s: float = math.inf, duration_s: float = 12.0
) -> tuple[list[PlantState], list[CycleTiming], list[TimingSummary], float]:
    base = load_scenario("nrel5mw-steady-18").with_duration(duration_s)
    timing = msgspec.structs.replace(
        base.timing, watchdog_misses=misses, watchdog_recover_cycles=recover
    )
    scenario = msgspec.structs.replace(base, timing=timing)

    def answer(frame: SensorFrame, command: ActuatorCommand | None) -> ActuatorCommand | None:
        # From STALL_S until answer_again_s the command never comes: a missed deadline.
        return None if STALL_S <= frame.sample_time_ns * 1e-9 < answer_again_s else command

    _result, log = run_collecting(scenario, answer)
    return (
        log[TRUTH.key_suffix],
        log[CYCLE_TIMING.key_suffix],
        log[TIMING_SUMMARY.key_suffix],
        scenario.timing.control_period_s,
    )


def test_safe_state_after_n_misses_feathers_at_the_rate_limit() -> None:
    truth, cycles, summaries, period = _run(misses=3)
    stall_k = round(STALL_S / period)
    flags = [c.safe_state for c in cycles]
    # Cycles stall_k and stall_k + 1 are misses 1 and 2; miss 3 (cycle stall_k + 2) trips it.
    assert not any(flags[: stall_k + 2])
    assert all(flags[stall_k + 2 :])
    assert summaries[-1].safe_state == 1
    assert summaries[-1].deadline_misses == len(cycles) - stall_k

    turbine = load_turbine("nrel5mw")
    by_t = {s.sample_time_ns: s for s in truth}
    t0 = round((STALL_S + 3 * period) * 1e9)
    t1 = t0 + round(3.0 * 1e9)
    p0, p1 = by_t[t0].blade_pitch_rad, by_t[t1].blade_pitch_rad
    # Feathering: pitch rises at the rate limit (8 deg/s) within 5 % over 3 s (the
    # first-order actuator saturates at its rate limit for a demand this far away).
    rate = (p1 - p0) / 3.0
    assert rate == pytest.approx(turbine.pitch_rate_max_rad_s, rel=0.05)
    # Torque ramp-down: the generator torque falls at its rate limit (15 kN m/s) or reaches 0.
    q0, q1 = by_t[t0].generator_torque_nm, by_t[t1].generator_torque_nm
    expected = max(0.0, q0 - turbine.torque_rate_max_nm_s * 3.0)
    assert q1 == pytest.approx(expected, abs=0.05 * turbine.torque_rate_max_nm_s * 3.0)
    # The demand applied is the safe demand, not the controller's.
    assert by_t[t1].blade_pitch_applied_rad == pytest.approx(turbine.pitch_max_rad)
    assert by_t[t1].generator_torque_applied_nm == 0.0


def test_safe_state_is_latched_by_default() -> None:
    _truth, cycles, summaries, _period = _run(misses=3, answer_again_s=STALL_S + 1.0)
    assert cycles[-1].safe_state == 1
    assert summaries[-1].safe_state == 1


def test_safe_state_recovers_after_k_on_time_commands() -> None:
    truth, cycles, _summaries, period = _run(misses=3, recover=50, answer_again_s=STALL_S + 1.0)
    back_k = round((STALL_S + 1.0) / period)
    flags = [c.safe_state for c in cycles]
    assert flags[back_k - 1] == 1
    # 50 on-time commands (cycles back_k .. back_k + 49) hand control back at cycle back_k + 49.
    assert flags[back_k + 48] == 1
    assert not any(flags[back_k + 49 :])
    # The controller's demands apply again: at the end the rotor is regulated near rated.
    assert truth[-1].blade_pitch_applied_rad < 0.5


def test_watchdog_can_be_disabled() -> None:
    _truth, cycles, summaries, _period = _run(misses=0)
    assert not any(c.safe_state for c in cycles)
    assert summaries[-1].deadline_misses > 0


def test_watchdog_keys_are_validated() -> None:
    text = scenario_text("nrel5mw-steady-18")[0] + "\n[timing]\nwatchdog_misses = -1\n"
    with pytest.raises(ScenarioError, match="watchdog_misses"):
        parse_scenario(text, "bad.toml")
    text = scenario_text("nrel5mw-steady-18")[0] + "\n[timing]\nwatchdog_miss = 3\n"
    with pytest.raises(ScenarioError, match="watchdog_miss"):
        parse_scenario(text, "bad.toml")
