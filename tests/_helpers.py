"""Helpers shared by several test modules.

Imported as ``from _helpers import ...``: pytest puts ``tests/`` on ``sys.path`` (no package).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgspec

from bus_schemas import ActuatorCommand, PlantState, SensorFrame
from bus_schemas.auth import KEY_FILE_NAME, create_key_file
from bus_schemas.registry import SENSORS, TRUTH, MessageType
from hil.controller_node import ControllerRuntime
from hil.inprocess_run import run_inprocess
from hil.plant_node import PlantRunResult
from hil.scenario import Scenario


def key_file_args(folder: Path) -> list[str]:
    """``--key-file <folder>/run.key`` for nodes started by hand (the file made once, 0600)."""
    path = folder / KEY_FILE_NAME
    if not path.exists():
        create_key_file(path)
    return ["--key-file", str(path)]


def run_collecting(
    scenario: Scenario,
    answer: Callable[[SensorFrame, ActuatorCommand | None], ActuatorCommand | None] | None = None,
) -> tuple[PlantRunResult, dict[str, list[Any]]]:
    """Run ``scenario`` in process with its controller; collect every message by key suffix.

    ``answer(frame, command)`` may replace the controller's command (e.g. return None to
    simulate a missed deadline). Returns the run result and ``{suffix: [messages]}``.
    """
    log: dict[str, list[Any]] = defaultdict(list)

    def publish(mt: MessageType, msg: msgspec.Struct) -> None:
        log[mt.key_suffix].append(msg)

    runtime = ControllerRuntime(scenario)

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        result = runtime.handle_frame(frame)
        command = None if result is None else result[0]
        return command if answer is None else answer(frame, command)

    return run_inprocess(scenario, publish, step), log


def run_closed_loop(
    scenario: Scenario,
) -> tuple[PlantRunResult, list[PlantState], list[SensorFrame]]:
    """Run ``scenario`` in process with its controller; collect the truth and the sensor frames.

    Checks that every cycle ran; returns the run result (for its timing) and the messages.
    """
    result, log = run_collecting(scenario)
    assert result.cycles == scenario.cycles
    truth, frames = log[TRUTH.key_suffix], log[SENSORS.key_suffix]
    assert all(isinstance(m, PlantState) for m in truth)
    assert all(isinstance(m, SensorFrame) for m in frames)
    return result, truth, frames


def sensor_frame(
    generator_speed_rad_s: float,
    blade_pitch_rad: float = 0.0,
    generator_torque_nm: float = 0.0,
    *,
    seq: int = 0,
    valid_mask: int = 0,
) -> SensorFrame:
    """A sensor frame with the turbine readings given and every other reading 0.

    ``seq`` is also the frame's sample and publish time (ns).
    """
    return SensorFrame(
        seq=seq,
        sample_time_ns=seq,
        publish_time_ns=seq,
        valid_mask=valid_mask,
        generator_speed_measured_rad_s=generator_speed_rad_s,
        rotor_speed_measured_rad_s=0.0,
        blade_pitch_measured_rad=blade_pitch_rad,
        generator_torque_measured_nm=generator_torque_nm,
        electrical_power_measured_w=0.0,
        wind_speed_measured_m_s=0.0,
        nacelle_acc_fore_aft_measured_m_s2=0.0,
        platform_pitch_measured_rad=0.0,
        platform_pitch_rate_measured_rad_s=0.0,
        platform_surge_measured_m=0.0,
        wave_elevation_gauge_measured_m=0.0,
    )


def plant_report(cycles: int, sample_time_ns: int, **published: int) -> Any:
    """A plant's final :class:`~bus_schemas.messages.PlantReport` of a clean run of ``cycles``.

    Every per-cycle channel counts ``cycles``, one final summary, no rejection; ``published``
    overrides a count (e.g. ``cycle_records_published=0`` for a log without cycle records).
    """
    from bus_schemas.messages import PLANT_REJECT_REASONS, PlantReport, rejection_fields

    counts = {
        "sensor_frames_published": cycles,
        "truth_published": cycles,
        "cycle_records_published": cycles,
        "summaries_published": 1,
        "previews_published": 0,
        "commands_applied": cycles,
        **published,
    }
    return PlantReport(
        seq=0,
        sample_time_ns=sample_time_ns,
        publish_time_ns=0,
        final=1,
        aborted=0,
        cycles=cycles,
        **counts,
        **rejection_fields({}, "commands_rejected", PLANT_REJECT_REASONS),
    )


def controller_report(cycles: int, sample_time_ns: int, **published: int) -> Any:
    """A controller's final :class:`~bus_schemas.messages.ControllerReport` of a clean run:
    ``cycles`` frames stepped on, as many commands and statuses (``published`` overrides)."""
    from bus_schemas.messages import CONTROLLER_REJECT_REASONS, ControllerReport, rejection_fields

    counts = {"commands_published": cycles, "statuses_published": cycles, **published}
    return ControllerReport(
        seq=0,
        sample_time_ns=sample_time_ns,
        publish_time_ns=0,
        final=1,
        aborted=0,
        frames_accepted=cycles,
        safe_mode=0,
        safe_mode_entries=0,
        safe_mode_commands=0,
        safe_mode_first_entry_ns=0,
        frames_missing=0,
        frames_stale=0,
        **counts,
        **rejection_fields({}, "frames_rejected", CONTROLLER_REJECT_REASONS),
    )
