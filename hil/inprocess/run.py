"""Plant and controller in one process, no bus: the fastest mode (campaigns, in-process runs).

:func:`run_inprocess` drives a :class:`hil.nodes.plant_node.PlantLoop` and a controller's cycle in
the lock-step order, so a seeded in-process run reproduces a lock-step run exactly. The
cycles run in batches in compiled code (:mod:`hil.inprocess.loop`) when the scenario allows it,
else in the Python loop below. Kept out of :mod:`hil.nodes.plant_node` so that the bus node does
not depend on the compiled in-process loop (and the loop only on the node's plant side).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any, Literal, Protocol

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

#: Wall seconds between two progress lines of a long run (a 600 s load case, about two
#: seconds of loop, prints none; a day's soak about one every ten seconds).
PROGRESS_EVERY_S = 10.0
#: Cycles between two looks at the clock for the progress line in the Python loop.
_PROGRESS_CYCLES = 1024


class Progress:
    """Says how far a long run is, at most every :data:`PROGRESS_EVERY_S` of wall time:
    ``in-process: 3.1 h of 24 h simulated (13 %), 270x real time``. Holds three numbers:
    nothing grows with the run."""

    def __init__(
        self,
        plant: PlantLoop,
        cycles: int,
        say: Callable[[str], None],
        every_s: float = PROGRESS_EVERY_S,
    ) -> None:
        self.plant = plant
        self.say = say
        self.total_s = cycles * plant.period_ns * 1e-9
        self.every_s = every_s
        self.start = time.monotonic()
        self.next = self.start + every_s

    def __call__(self) -> None:
        now = time.monotonic()
        if now < self.next:
            return
        self.next = now + self.every_s
        sim_s = self.plant.k * self.plant.period_ns * 1e-9
        unit, scale = ("h", 3600.0) if self.total_s >= 7200.0 else ("s", 1.0)
        pct = 100.0 * sim_s / self.total_s if self.total_s else 100.0
        self.say(
            f"in-process: {sim_s / scale:.{1 if unit == 'h' else 0}f} {unit} of "
            f"{self.total_s / scale:g} {unit} simulated ({pct:.0f} %), "
            f"{sim_s / max(now - self.start, 1e-9):.0f}x real time"
        )


class StopFlag(Protocol):
    """What ends a run early when set: a :class:`threading.Event`, or the launcher's
    :class:`hil.launch.AbortSignals` (set by a signal handler that takes no lock)."""

    def is_set(self) -> bool:
        """Whether the run should stop before its next cycle."""
        ...


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
    stop: StopFlag | None = None,
    initial: InitialCondition | None = None,
    progress: Callable[[str], None] | None = None,
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

    ``progress`` (e.g. the console's print): a long run says how far it is every
    :data:`PROGRESS_EVERY_S` of wall time (:class:`Progress`). Nothing of the run's length
    is built before the loop: the waves are stepped, the turbulent wind is a record of at
    most an hour (:data:`plant.wind.TURBULENCE_BOX_S`), the sensor noise is drawn in blocks
    and the messages leave in batches (:mod:`hil.runlog.writer`), so memory and start-up do
    not grow with the duration.
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
    reporter = Progress(plant, scenario.cycles, progress) if progress is not None else None
    if fast is not None:
        fast.run(scenario.cycles, stopped, reporter)
    else:
        faulted = plant.bus_faults
        sample, finish, clock = plant.sample, plant.finish_cycle, time.monotonic_ns
        for k in range(scenario.cycles):
            if stopped is not None and stopped():
                break
            if reporter is not None and k % _PROGRESS_CYCLES == 0:
                reporter()
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
