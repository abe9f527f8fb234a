"""Plant and controller in one process, no bus: the fastest mode (campaigns, in-process runs).

:func:`run_inprocess` drives a :class:`hil.nodes.plant_node.PlantLoop` and a controller's cycle in
the lock-step order, so a seeded in-process run reproduces a lock-step run exactly. The
cycles run in batches in compiled code (:mod:`hil.inprocess.loop`) when the scenario allows it,
else in the Python loop below. Kept out of :mod:`hil.nodes.plant_node` so that the bus node does
not depend on the compiled in-process loop (and the loop only on the node's plant side).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Mapping
from typing import Any, Literal

import numpy as np

from bus_schemas import ActuatorCommand, SensorFrame
from bus_schemas.registry import PLANT_REPORT
from hil.nodes.plant_node import (
    PlantLoop,
    PlantRunResult,
    Publish,
    fault_counts_text,
    faulted_sim_cycle,
    plant_report,
)
from hil.scenario.schema import Scenario
from plant.initial import InitialCondition


def run_inprocess(
    scenario: Scenario,
    publish: Publish,
    step_controller: Callable[[SensorFrame], ActuatorCommand | None],
    log: Callable[[str], None] | None = None,
    before_loop: Callable[[], None] | None = None,
    *,
    runtime: Any = None,
    loop: Literal["auto", "compiled", "python"] = "auto",
    publish_block: Callable[[np.ndarray, dict[int, np.ndarray]], None] | None = None,
    published: Callable[[], Mapping[str, int]] | None = None,
    stop: threading.Event | None = None,
    initial: InitialCondition | None = None,
) -> PlantRunResult:
    """Run plant and controller in one process, no bus: the fastest mode (campaigns).

    ``step_controller`` is the controller runtime's cycle; the order of operations is the
    lock-step order, so a seeded in-process run reproduces a lock-step run exactly (bus
    faults included: both take :func:`faulted_sim_cycle`). ``log`` gets the fault windows
    and the final fault counts. ``before_loop`` is called once the plant is built, before
    the first cycle (the in-process launcher waits there for its log writer to start); the
    run's wall time starts after it.

    ``loop``: ``"compiled"`` runs the cycles in batches in compiled code
    (:mod:`hil.inprocess.loop`; needs ``runtime``, the :class:`hil.nodes.controller_node.
    ControllerRuntime` that ``step_controller`` drives, and a scenario it supports, else
    ValueError naming why), handing back to ``step_controller`` and this module's loop every
    cycle that needs Python; ``"python"`` the loop below; ``"auto"`` the compiled one when
    it can. The same messages either way (wall-clock stamps aside). ``publish_block``
    (``BackgroundRunLog.publish_block``) takes the compiled loop's messages as rows; without
    it they go to ``publish`` as Structs. ``PlantRunResult.loop`` says which loop ran.

    ``published``: the messages handed to the log so far per key suffix (e.g.
    ``BackgroundRunLog.published``, which counts the rows of either loop too); when given,
    the :class:`PlantReport` (:func:`plant_report`) follows the final summary, as a plant
    process publishes it.

    ``stop`` (set by a signal handler) ends the run early, before the next cycle (the
    compiled loop: before its next batch); the final summary is still published and
    ``PlantRunResult.aborted`` says "stopped by signal".

    ``initial``: where the run starts (None: the scenario's ``[initial]``, trimmed by a
    settling run when ``trim = true``: :func:`hil.inprocess.trim.initial_condition`).
    """
    if initial is None:
        from hil.inprocess.trim import initial_condition  # noqa: PLC0415 - the trim runs this module

        initial = initial_condition(scenario)
    plant = PlantLoop(scenario, publish, initial=initial)
    if log is not None:
        plant.log = log
    from hil.inprocess.loop import CompiledLoop, compiled_unsupported  # noqa: PLC0415

    why = compiled_unsupported(plant, runtime) if loop != "python" else "loop='python'"
    if loop == "compiled" and why is not None:
        raise ValueError(f"loop='compiled': not supported here ({why})")
    plant.result.loop = "python" if why is not None else "compiled"
    plant.log(f"in-process loop: {plant.result.loop}" + (f" ({why})" if why is not None else ""))
    fast = None if why is not None else CompiledLoop(plant, runtime, step_controller, publish_block)
    if before_loop is not None:
        before_loop()
        plant.start_wall_ns = time.monotonic_ns()

    def exchange(frame: SensorFrame, _sent_ns: int) -> tuple[ActuatorCommand | None, int]:
        t0 = time.monotonic_ns()
        command = step_controller(frame)
        return command, time.monotonic_ns() - t0

    stopped = stop.is_set if stop is not None else None
    if fast is not None:
        fast.run(scenario.cycles, stopped)
    else:
        faulted = plant.bus_faults
        sample, finish, clock = plant.sample, plant.finish_cycle, time.monotonic_ns
        for _ in range(scenario.cycles):
            if stopped is not None and stopped():
                break
            frame = sample()
            if faulted:
                faulted_sim_cycle(plant, frame, exchange)
                continue
            t0 = clock()
            command = step_controller(frame)
            finish(command, clock() - t0, at_arrival=False)
    if stopped is not None and stopped() and plant.k < scenario.cycles:
        plant.result.aborted = "stopped by signal"
    plant.count_faults()
    final = plant.publish_summary(final=True)
    if published is not None:
        report = plant_report(
            plant.result,
            published(),
            sample_time_ns=final.sample_time_ns,
            aborted=bool(plant.result.aborted),
        )
        publish(PLANT_REPORT, report)
    if plant.result.faults_injected:
        plant.log(f"plant faults injected: {fault_counts_text(plant.result.faults_injected)}")
    return plant.result
