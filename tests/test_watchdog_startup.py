"""Start-up misses do not latch the real-time plant's safe state for the whole run.

The plant is driven cycle by cycle as its real-time loop does (``finish_cycle`` with the
command, or None for a missed deadline). Misses in the first second trip the safe state as
ever, but with the start-up rule it is handed back after a second of on-time commands even
though the scenario latches it; the same misses later in the run still latch it; a
controller that never answers keeps the plant safe; and without the rule (lock-step,
in-process) nothing changes.
"""

from __future__ import annotations

import msgspec

from bus_schemas import ActuatorCommand
from hil.nodes.plant_node import STARTUP_S, PlantLoop
from hil.scenario.schema import load_scenario

MISSES = 3  # the scenario's watchdog_misses


def _loop(startup: bool) -> PlantLoop:
    base = load_scenario("nrel5mw-steady-18").with_duration(10.0)
    timing = msgspec.structs.replace(base.timing, watchdog_misses=MISSES, watchdog_recover_cycles=0)
    loop = PlantLoop(msgspec.structs.replace(base, timing=timing), lambda _mt, _m: None)
    if startup:  # what run_plant_node sets in real time
        loop.startup_cycles = round(STARTUP_S * 1e9 / loop.period_ns)
        loop.startup_recover_cycles = loop.startup_cycles
    return loop


def _cycle(loop: PlantLoop, answered: bool) -> int:
    loop.sample()
    pitch, torque = loop.applied
    command = ActuatorCommand(
        seq=loop.k,
        answered_seq=loop.k,
        sample_time_ns=loop.t_ns,
        publish_time_ns=0,
        mode=0,
        blade_pitch_commanded_rad=pitch,
        generator_torque_commanded_nm=torque,
    )
    loop.finish_cycle(command if answered else None, 500_000 if answered else 0)
    return int(loop.safe_state)


def test_start_up_misses_trip_the_safe_state_then_hand_back() -> None:
    loop = _loop(startup=True)
    n = loop.startup_cycles
    flags = [_cycle(loop, answered=k >= 20) for k in range(20 + n + 50)]
    assert flags[MISSES - 1] == 1  # the watchdog still acts at once
    assert loop.result.safe_state_entries == 1
    assert all(flags[MISSES - 1 : 20 + n - 1])  # safe until n on-time commands ...
    assert not any(flags[20 + n - 1 :])  # ... then the controller's commands apply
    assert loop.result.safe_state_cycles == 20 + n - MISSES


def test_the_same_misses_later_in_the_run_still_latch() -> None:
    loop = _loop(startup=True)
    late = 2 * loop.startup_cycles
    flags = [_cycle(loop, answered=not late <= k < late + 20) for k in range(late + 300)]
    assert flags[late + MISSES - 1] == 1
    assert all(flags[late + MISSES - 1 :])  # latched, as the scenario says


def test_a_controller_that_never_answers_keeps_the_plant_safe() -> None:
    loop = _loop(startup=True)
    flags = [_cycle(loop, answered=False) for _k in range(3 * loop.startup_cycles)]
    assert all(flags[MISSES - 1 :])


def test_without_the_start_up_rule_start_up_misses_latch() -> None:
    loop = _loop(startup=False)
    flags = [_cycle(loop, answered=k >= 20) for k in range(400)]
    assert all(flags[MISSES - 1 :])
