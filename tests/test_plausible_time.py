"""Plausible sample times: a key holder's far-future frame cannot wedge the controller.

Before, a signed frame a few seq ahead with a far-future sample time was accepted and made
every genuine frame after it "stale" (its sample time went backwards), so a lock-step run
stalled. Now the controller refuses a frame whose sample time lies past the run's window or
further ahead of the last accepted frame's than its seq is (``implausible_time``); the
recorder refuses such times too (``tests/test_exact_recording.py``).
"""

from __future__ import annotations

import msgspec
from _helpers import sensor_frame

from bus_schemas import SensorFrame
from hil.nodes.bus import sample_time_limit_ns
from hil.nodes.controller_node import ControllerRuntime
from hil.scenario.schema import load_scenario

PERIOD_NS = 10_000_000


def _frame(seq: int, sample_time_ns: int | None = None) -> SensorFrame:
    frame = sensor_frame(100.0, 0.01, 20_000.0, seq=seq, valid_mask=0b11111)
    t = seq * PERIOD_NS if sample_time_ns is None else sample_time_ns
    return msgspec.structs.replace(frame, sample_time_ns=t)


def test_a_far_future_frame_does_not_wedge_the_controller() -> None:
    scenario = load_scenario("nrel5mw-ramp").with_duration(20.0)
    runtime = ControllerRuntime(scenario)
    for k in range(10):
        assert runtime.handle_frame(_frame(k)) is not None
    forged = [
        _frame(12, 2**63 - 1),  # past the run's window
        _frame(11, sample_time_limit_ns(20.0) - 1),  # inside it, far ahead of its seq
        _frame(10, 12 * PERIOD_NS),  # one seq ahead, two periods too far
    ]
    for frame in forged:
        assert runtime.handle_frame(frame) is None
    assert runtime.rejected == {"implausible_time": 3}
    for k in range(10, 2000):  # every genuine frame after them is stepped on
        assert runtime.handle_frame(_frame(k)) is not None, k
    assert runtime.rejected == {"implausible_time": 3} and not runtime.safe_mode
    assert runtime.frames_missing == 0 and runtime.frames_stale == 0


def test_the_plant_refuses_a_command_with_an_implausible_time() -> None:
    from bus_schemas import ActuatorCommand
    from bus_schemas.registry import COMMAND
    from hil.nodes.plant_node import CommandInbox

    def command(answered: int, sample_time_ns: int) -> bytes:
        return COMMAND.codec.encode(
            ActuatorCommand(
                seq=answered,
                answered_seq=answered,
                sample_time_ns=sample_time_ns,
                publish_time_ns=answered,
                mode=0,
                blade_pitch_commanded_rad=0.02,
                generator_torque_commanded_nm=30_000.0,
            )
        )

    inbox = CommandInbox()
    inbox.published_seq = 10
    inbox.period_ns = PERIOD_NS
    inbox.on_payload("", command(5, 2**63 - 1))
    inbox.on_payload("", command(6, 9 * PERIOD_NS))
    assert inbox.rejected == {"implausible_time": 2} and inbox.latest is None
    inbox.on_payload("", command(5, 5 * PERIOD_NS))  # the genuine answer still counts
    got = inbox.take(5)
    assert got is not None and got[0].answered_seq == 5
