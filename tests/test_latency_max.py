"""The plant's latency summary keeps the true maximum, however late a command came.

A late command is a deadline miss; its latency must still reach the summary's maximum (a
command 458 ms late shows 458 ms, not the deadline), both when it came before the next tick
(the cycle's own latency) and when it came after it (the frame's send time is kept).
"""

from __future__ import annotations

import time

from bus_schemas import ActuatorCommand, TimingSummary
from bus_schemas.registry import COMMAND, TIMING_SUMMARY
from hil.nodes.plant_node import CommandInbox, PlantLoop
from hil.nodes.timing import LatencyHistogram
from hil.scenario.schema import load_scenario

LATE_NS = 458_000_000  # 458 ms, far beyond the 10 ms deadline


def _loop() -> tuple[PlantLoop, list[TimingSummary]]:
    summaries: list[TimingSummary] = []

    def publish(mt: object, msg: object) -> None:
        if mt is TIMING_SUMMARY:
            assert isinstance(msg, TimingSummary)
            summaries.append(msg)

    return PlantLoop(load_scenario("nrel5mw-steady-18").with_duration(1.0), publish), summaries


def test_histogram_keeps_the_exact_maximum_beyond_its_bins() -> None:
    h = LatencyHistogram()
    for ns in (300_000, 400_000, LATE_NS):
        h.record(ns)
    h.observe_max(200_000)  # below the maximum: no change
    assert h.max_ns == LATE_NS
    assert h.percentiles_us(100.0)[0] == LATE_NS / 1e3
    h.observe_max(10 * LATE_NS)
    assert h.max_ns == 10 * LATE_NS
    assert h.n == 3  # observe_max adds no sample


def test_a_late_command_before_the_next_tick_sets_the_maximum() -> None:
    loop, summaries = _loop()
    loop.sample()
    loop.finish_cycle(None, LATE_NS)  # the real-time loop's late command: a miss with latency
    loop.sample()
    loop.finish_cycle(None, 0)  # no command at all: not a latency
    final = loop.publish_summary(final=True)
    assert final.deadline_misses == 2
    assert final.latency_max_us == LATE_NS / 1e3
    assert summaries[-1] is final


def test_a_command_after_its_cycle_ended_sets_the_maximum() -> None:
    loop, _summaries = _loop()
    inbox = CommandInbox()
    loop._inbox = inbox
    sent = time.monotonic_ns() - LATE_NS  # frame 0 went out 458 ms ago
    inbox.note_sent(0, sent)
    loop.sample()
    loop.finish_cycle(None, 0)  # cycle 0 ended without its command
    command = ActuatorCommand(
        seq=0,
        answered_seq=0,
        sample_time_ns=0,
        publish_time_ns=0,
        mode=0,
        blade_pitch_commanded_rad=0.0,
        generator_torque_commanded_nm=1000.0,
    )
    inbox.on_payload("command", COMMAND.codec.encode(command))  # arrives now
    assert inbox.take(1) is None  # the loop waits for frame 1's: frame 0's is dropped as late
    assert inbox.late == 1
    assert inbox.late_max_ns >= LATE_NS
    final = loop.publish_summary(final=True)
    assert final.latency_max_us >= LATE_NS / 1e3
    assert final.latency_max_us == inbox.late_max_ns / 1e3


def test_a_late_command_without_a_known_send_time_is_counted_only() -> None:
    inbox = CommandInbox()
    command = ActuatorCommand(
        seq=0,
        answered_seq=5,
        sample_time_ns=0,
        publish_time_ns=0,
        mode=0,
        blade_pitch_commanded_rad=0.0,
        generator_torque_commanded_nm=0.0,
    )
    inbox.on_payload("command", COMMAND.codec.encode(command))
    assert inbox.take(6) is None
    assert (inbox.late, inbox.late_max_ns) == (1, 0)
