"""A controller core's fault: what it is, the one line that names it, where it is written.

A core *faults* when its ``step`` raises, or returns a command that is non-finite or out of
range (a blade pitch outside its own actuator limits' pitch range, a negative generator
torque or one above :data:`TORQUE_MAX_NM`). :class:`hil.nodes.controller_node.ControllerRuntime`
checks every step's output in every mode (in process, lock-step, real time, a campaign run,
the trim's settling run) and keeps the first fault as a :class:`ControllerFault`; the run's
verdict is then ``controller_fault`` (exit 7, :mod:`hil.review.outcome`).

The fault travels two ways, so a run's file can be judged alone and its summary still names
the exception:

* as numbers in the controller's :class:`bus_schemas.messages.ControllerReport`
  (``core_fault``: :data:`FAULT_CODES`, ``core_fault_seq``, ``core_fault_time_ns``,
  ``core_fault_field``: :data:`FAULT_FIELDS`), recorded in the MCAP file;
* as text in ``controller_fault.json`` beside the run's MCAP file (:data:`FAULT_FILE`,
  :func:`write_fault`), written by whoever ran the core (the controller process in its run
  folder ``$FOWT_RUN_DIR``, the in-process launcher), which the review reads when present
  (:func:`read_fault`).

This module imports nothing of the bus, so the review can use it.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

__all__ = [
    "FAULT_CODES",
    "FAULT_FIELDS",
    "FAULT_FILE",
    "TORQUE_MAX_NM",
    "ControllerFault",
    "ControllerFaultError",
    "fault_line",
    "read_fault",
    "write_fault",
]

#: ``ControllerReport.core_fault``: 0 none, then these kinds.
FAULT_CODES: dict[str, int] = {"raised": 1, "non_finite": 2, "out_of_range": 3}
#: ``ControllerReport.core_fault_field``: the command field at fault (0: none, an exception).
FAULT_FIELDS: tuple[str, ...] = (
    "",
    "blade_pitch_commanded_rad",
    "generator_torque_commanded_nm",
)
#: The largest generator torque demand taken as plausible [N m, high-speed shaft]: the wire's
#: own bound (``ActuatorCommand.generator_torque_commanded_nm``, 5e7 N m), far above any
#: turbine's rated torque; above it a demand is absurd, not a control action.
TORQUE_MAX_NM = 5e7
#: The fault's text beside the run's MCAP file.
FAULT_FILE = "controller_fault.json"


@dataclass(frozen=True)
class ControllerFault:
    """The first fault of a controller core in a run.

    Attributes
    ----------
    kind : str
        ``"raised"``, ``"non_finite"`` or ``"out_of_range"`` (:data:`FAULT_CODES`).
    message : str
        ``raised``: the exception's ``repr`` (``"ValueError('bad gain')"``); otherwise the
        command at fault (``"blade_pitch_commanded_rad = nan"``).
    t_s : float
        Simulated time of the frame the core was stepping on [s].
    cycle : int
        That frame's ``seq`` (the plant's cycle).
    field : str
        The command field at fault ("" for an exception).
    phase : str
        ``"run"``, or ``"trim"`` when it happened in the trim's settling run
        (:mod:`hil.inprocess.trim`).
    """

    kind: str
    message: str
    t_s: float
    cycle: int
    field: str = ""
    phase: str = "run"

    def line(self) -> str:
        """The one line naming the fault (:func:`fault_line`)."""
        return fault_line(asdict(self))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (``summary["controller"]["fault"]``)."""
        return asdict(self)


class ControllerFaultError(RuntimeError):
    """A controller core faulted where the run cannot go on (the trim's settling run).

    ``fault``: the :class:`ControllerFault`; ``str(exc)`` is its line.
    """

    def __init__(self, fault: ControllerFault) -> None:
        super().__init__(fault.line())
        self.fault = fault


def fault_line(fault: dict[str, Any]) -> str:
    """One line naming a fault given as a dict (:meth:`ControllerFault.to_dict`, or the
    review's from the report alone, whose ``message`` may be empty).

    ``controller raised ValueError('x') at t = 20.00 s (cycle 2000)``,
    ``controller output non-finite (blade_pitch_commanded_rad = nan) at t = ...``.
    """
    kind = str(fault.get("kind", ""))
    message = str(fault.get("message") or "")
    field = str(fault.get("field") or "")
    if kind == "raised":
        what = f"raised {message}" if message else "raised an exception"
    else:
        label = "non-finite" if kind == "non_finite" else "out of range"
        detail = message or field
        what = f"output {label}" + (f" ({detail})" if detail else "")
    t = fault.get("t_s")
    when = ""
    if isinstance(t, int | float) and math.isfinite(t):
        when = f" at t = {t:.2f} s"
    cycle = fault.get("cycle")
    if isinstance(cycle, int):
        when += f" (cycle {cycle})"
    where = " in the trim's settling run" if fault.get("phase") == "trim" else ""
    return f"controller {what}{when}{where}"


def write_fault(folder: str | Path, fault: ControllerFault) -> Path | None:
    """Write ``fault`` to ``folder``/:data:`FAULT_FILE`; the path, or None if it failed
    (the report in the MCAP file still carries the fault's numbers)."""
    path = Path(folder) / FAULT_FILE
    try:
        path.write_text(json.dumps(fault.to_dict(), indent=2) + "\n")
    except OSError:
        return None
    return path


def read_fault(folder: str | Path) -> dict[str, Any] | None:
    """The fault written beside a run's MCAP file (None: none, or unreadable)."""
    try:
        data = json.loads((Path(folder) / FAULT_FILE).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and "kind" in data else None
