"""Closed loop over CAN: plant and controller in one process on a python-can ``virtual`` bus.

The sensor frame goes plant -> CAN encode -> virtual bus -> reassemble -> decode ->
controller, the command back the same way (each side a :class:`hil.nodes.can_bus.CanBus` with its
own receive thread), in lock-step order. The KPIs must match the in-process run without CAN
within 1 %: the only difference is the DBC quantisation of the signals.
"""

from __future__ import annotations

import uuid
from typing import Any

import msgspec
import numpy as np
import pytest
from _helpers import run_closed_loop

from bus_schemas import ActuatorCommand, PlantState, SensorFrame
from bus_schemas.registry import COMMAND, SENSORS, TRUTH, MessageType
from hil.inprocess.trim import initial_condition
from hil.nodes.can_bus import CanBus, CanBusConfig, socketcan_available
from hil.nodes.controller_node import ControllerRuntime
from hil.nodes.plant_node import CommandInbox, PlantLoop
from hil.scenario.schema import Scenario, load_scenario


def run_over_can(
    scenario: Scenario, *, fd: bool = False, socketcan: str | None = None
) -> tuple[list[PlantState], dict[str, Any]]:
    """Lock-step closed loop over CAN; the truth and the buses' counters.

    The bus is a fresh ``virtual`` channel, or the socketcan device ``socketcan``.
    """
    tid = scenario.turbine_id
    if socketcan is None:
        cfg = CanBusConfig(channel=f"loopback-{uuid.uuid4()}", fd=fd, turbine_id=tid)
    else:
        cfg = CanBusConfig(interface="socketcan", channel=socketcan, fd=fd, turbine_id=tid)
    truth: list[PlantState] = []
    with CanBus(cfg) as plant_bus, CanBus(cfg) as controller_bus:
        runtime = ControllerRuntime(scenario)

        def on_frame(frame: SensorFrame) -> None:
            result = runtime.handle_frame(frame)
            if result is not None:
                controller_bus.publish(COMMAND, result[0])

        controller_bus.subscribe_message(SENSORS, on_frame)
        inbox = CommandInbox()
        plant_bus.subscribe(COMMAND.key(tid), inbox.on_payload)

        def publish(mt: MessageType, msg: msgspec.Struct) -> None:
            if mt is SENSORS:
                plant_bus.publish(SENSORS, msg)
            elif mt is TRUTH:
                assert isinstance(msg, PlantState)
                truth.append(msg)

        # the start the in-process run takes (the trim is the caller's: hil.inprocess.trim)
        loop = PlantLoop(scenario, publish, initial=initial_condition(scenario))
        for _ in range(scenario.cycles):
            frame = loop.sample()
            got = inbox.wait_for(frame.seq, 5.0)
            assert got is not None, f"no command for frame {frame.seq}"
            command, arrival = got
            assert isinstance(command, ActuatorCommand)
            loop.finish_cycle(command, arrival - loop.frame_sent_ns, at_arrival=False)
        counters = {
            "plant_rejected": dict(plant_bus.rejected),
            "controller_rejected": dict(controller_bus.rejected),
            "runtime_rejected": dict(runtime.rejected),
            "inbox_rejected": dict(inbox.rejected),
            "frames": controller_bus.frames_received + plant_bus.frames_received,
        }
    return truth, counters


def _kpis(truth: list[PlantState]) -> tuple[float, float]:
    power = np.array([m.electrical_power_w for m in truth])
    speed = np.array([m.rotor_speed_rad_s for m in truth])
    return float(power.mean()), float(speed.std())


@pytest.mark.parametrize(
    ("name", "fd"),
    [("nrel5mw-ramp", False), ("default", False), ("nrel5mw-ramp", True)],
    ids=["bottom-fixed", "floating", "bottom-fixed-fd"],
)
def test_closed_loop_over_virtual_can_matches_inprocess(name: str, fd: bool) -> None:
    scenario = load_scenario(name).with_duration(20.0)
    _, reference, _ = run_closed_loop(scenario)
    truth, counters = run_over_can(scenario, fd=fd)
    assert len(truth) == len(reference) == scenario.cycles
    assert not any(counters[k] for k in counters if k.endswith("rejected")), counters
    frames_per_cycle = 2 if fd else 7 + 4  # sensor frame + command
    assert counters["frames"] == frames_per_cycle * scenario.cycles
    p_can, s_can = _kpis(truth)
    p_ref, s_ref = _kpis(reference)
    assert p_can == pytest.approx(p_ref, rel=0.01)
    assert s_can == pytest.approx(s_ref, rel=0.01)
    print(
        f"{name} fd={fd}: power {p_can:.7g} vs {p_ref:.7g} W, "
        f"rotor-speed std {s_can:.7g} vs {s_ref:.7g} rad/s"
    )


@pytest.mark.skipif(
    not socketcan_available("vcan0"),
    reason="no vcan0: this kernel has no CAN support (`ip link add vcan0 type vcan` fails)",
)
def test_closed_loop_over_socketcan_vcan0() -> None:
    scenario = load_scenario("nrel5mw-ramp").with_duration(5.0)
    truth, counters = run_over_can(scenario, socketcan="vcan0")
    assert len(truth) == scenario.cycles
    assert not any(counters[k] for k in counters if k.endswith("rejected")), counters
