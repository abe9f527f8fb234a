"""The controller process: sensor frames in, actuator commands out, every cycle.

:class:`ControllerRuntime` is the thin shell around a pure controller core
(``step(state, measurement, dt) -> (state, output)``): it decodes and validates each payload,
rejects and counts anything malformed, of another version, non-finite, out of range,
duplicated, reordered or stale, steps the core, and builds the command (echoing the frame's
``seq``) and the status message. It owns no clock of its own (one is injected) and does no
I/O, so the in-process runner uses the very same object as the Zenoh node and the two give
identical results.

:func:`run_controller_node` is the process: one Zenoh session, a subscriber on
``fowt/<turbine>/sensors`` whose callback runs the cycle and publishes at once (lowest
latency: no hand-off to another thread), a liveliness token announcing readiness, and an
exit when the plant publishes its final timing summary or on SIGINT/SIGTERM.

This module never imports ``plant``: the controller speaks only ``bus_schemas``.
"""

from __future__ import annotations

import math
import operator
import signal
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from bus_schemas import ActuatorCommand, ControllerStatus, DecodeError, SensorFrame
from bus_schemas.registry import COMMAND, CONTROLLER_STATUS, SENSORS, TIMING_SUMMARY
from controller.core import make_controller
from hil.bus import Bus, BusConfig
from hil.scenario import Scenario

#: Float fields of a sensor frame (checked finite before a frame may reach the core).
_FLOAT_FIELDS = tuple(
    name
    for name, typ in zip(
        SensorFrame.__struct_fields__, SensorFrame.__annotations__.values(), strict=True
    )
    if "float" in str(typ)
)
_float_values = operator.attrgetter(*_FLOAT_FIELDS)


class ControllerRuntime:
    """Validation, sequencing and message building around a controller core.

    Parameters
    ----------
    scenario : Scenario
        Gives the controller kind, its preset and the control period (the core's dt).
    clock : callable
        Monotonic clock in ns (``time.monotonic_ns`` in a node).
    """

    def __init__(self, scenario: Scenario, clock: Callable[[], int] = time.monotonic_ns) -> None:
        c = scenario.controller
        waves = scenario.waves
        self.controller = make_controller(
            c.kind,
            c.preset,
            control_period_s=scenario.timing.control_period_s,
            forecaster=c.forecaster,
            feedforward=c.feedforward,
            gauge_distance_m=waves.gauge_distance_m if waves is not None else None,
        )
        self.state: Any = self.controller.initial_state()
        self.dt_s = scenario.timing.control_period_s
        self.clock = clock
        self.last_seq = -1
        self.last_sample_time_ns = -1
        self.command_seq = 0
        self.rejected: Counter[str] = Counter()
        self.accepted = 0

    @property
    def rejected_total(self) -> int:
        """All rejected frames so far."""
        return sum(self.rejected.values())

    def handle_payload(self, payload: bytes) -> tuple[ActuatorCommand, ControllerStatus] | None:
        """Decode one payload and run a cycle; None (and a counted rejection) if unusable."""
        try:
            frame = SENSORS.codec.decode(payload)
        except DecodeError as exc:
            self.rejected[exc.reason] += 1
            return None
        return self.handle_frame(frame)

    def handle_frame(self, frame: SensorFrame) -> tuple[ActuatorCommand, ControllerStatus] | None:
        """Run one control cycle on a decoded, range-checked frame.

        A frame whose ``seq`` is not newer than the last one (duplicate, replay, reordered)
        or whose sample time goes backwards is rejected: a controller must never step twice
        on one sample or on an older one. A frame with a non-finite value is rejected too
        (the bus codec already refuses them; this guards the in-process path). The status
        carries the core's estimates and ``compute_time_ns``, the injected clock's time
        around the core's step [ns].
        """
        if frame.seq <= self.last_seq:
            self.rejected["duplicate_or_reordered"] += 1
            return None
        if frame.sample_time_ns <= self.last_sample_time_ns:
            self.rejected["stale"] += 1
            return None
        # One C-level sum instead of a check per field: a sum of finite floats of at most
        # ~1e8 each is finite, and any NaN or infinity makes it NaN or infinite.
        if not math.isfinite(sum(_float_values(frame))):
            self.rejected["non_finite"] += 1  # the codec refuses these; in-process frames too
            return None
        t0 = self.clock()
        self.state, out = self.controller.step(self.state, frame, self.dt_s)
        self.last_seq = frame.seq
        self.last_sample_time_ns = frame.sample_time_ns
        self.accepted += 1
        now = self.clock()
        command = ActuatorCommand(
            seq=self.command_seq,
            answered_seq=frame.seq,
            sample_time_ns=frame.sample_time_ns,
            publish_time_ns=now,
            mode=0,
            blade_pitch_commanded_rad=out.blade_pitch_commanded_rad,
            generator_torque_commanded_nm=out.generator_torque_commanded_nm,
        )
        status = ControllerStatus(
            seq=self.command_seq,
            answered_seq=frame.seq,
            sample_time_ns=frame.sample_time_ns,
            publish_time_ns=now,
            compute_time_ns=now - t0,
            regime=out.regime,
            rejected_frames=self.rejected_total,
            generator_speed_filtered_rad_s=out.generator_speed_filtered_rad_s,
            pitch_integrator_rad=out.pitch_integrator_rad,
            gain_schedule_factor=out.gain_schedule_factor,
            estimates_valid_mask=out.estimates_valid_mask,
            estimator_degraded=out.estimator_degraded,
            wind_speed_estimated_m_s=out.wind_speed_estimated_m_s,
            platform_pitch_estimated_rad=out.platform_pitch_estimated_rad,
            platform_pitch_rate_estimated_rad_s=out.platform_pitch_rate_estimated_rad_s,
            platform_surge_estimated_m=out.platform_surge_estimated_m,
            platform_surge_velocity_estimated_m_s=out.platform_surge_velocity_estimated_m_s,
            tower_top_velocity_estimated_m_s=out.tower_top_velocity_estimated_m_s,
            wave_elevation_forecast_m=out.wave_elevation_forecast_m,
            wave_forecast_time_ns=out.wave_forecast_time_ns,
            feedforward_pitch_rad=out.feedforward_pitch_rad,
            feedforward_torque_nm=out.feedforward_torque_nm,
        )
        self.command_seq += 1
        return command, status


@dataclass
class ControllerNodeResult:
    """What the controller process did, for its exit report."""

    cycles: int
    rejected: dict[str, int]
    reason: str


def run_controller_node(
    scenario: Scenario,
    bus_config: BusConfig,
    timeout_s: float | None = None,
    log: Callable[[str], None] = print,
) -> ControllerNodeResult:
    """Serve commands until the plant's final summary, a signal, or ``timeout_s``."""
    runtime = ControllerRuntime(scenario)
    bus = Bus(bus_config)
    tid = scenario.turbine_id
    cmd_key, status_key = COMMAND.key(tid), CONTROLLER_STATUS.key(tid)
    cmd_pub, status_pub = bus.publisher(cmd_key), bus.publisher(status_key)
    done = threading.Event()
    reason = ["timeout"]
    lock = threading.Lock()

    def on_frame(_key: str, payload: bytes) -> None:
        with lock:  # one cycle at a time, whatever thread Zenoh calls us from
            result = runtime.handle_payload(payload)
            if result is None:
                return
            command, status = result
            cmd_pub.put(COMMAND.codec.encode(command))
            status_pub.put(CONTROLLER_STATUS.codec.encode(status))

    def on_summary(_key: str, payload: bytes) -> None:
        try:
            summary = TIMING_SUMMARY.codec.decode(payload)
        except DecodeError:
            return
        if summary.final:
            reason[0] = "plant finished"
            done.set()

    def on_signal(signum: int, _frame: Any) -> None:
        reason[0] = f"signal {signal.Signals(signum).name}"
        done.set()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    bus.subscribe(SENSORS.key(tid), on_frame)
    bus.subscribe(TIMING_SUMMARY.key(tid), on_summary)
    token = bus.session.liveliness().declare_token(f"fowt/{tid}/alive/controller")
    log(
        f"controller {scenario.controller.kind}/{scenario.controller.preset} ready on "
        f"{SENSORS.key(tid)} (listen {list(bus_config.listen)}, connect {list(bus_config.connect)})"
    )
    try:
        done.wait(timeout_s)
    finally:
        token.undeclare()
        bus.close()
    log(
        f"controller stopped ({reason[0]}): {runtime.accepted} cycles, "
        f"rejected {dict(runtime.rejected)}"
    )
    return ControllerNodeResult(runtime.accepted, dict(runtime.rejected), reason[0])
