"""What a complete recording of a run holds, from the nodes' end-of-run reports.

The plant ends a run with its final :class:`bus_schemas.messages.TimingSummary` and then
its :class:`bus_schemas.messages.PlantReport`; the controller, when it stops, with its
:class:`bus_schemas.messages.ControllerReport`. Each report counts the messages its node
published per channel, so a recording is complete when it holds, per topic, as many
messages as the reports say (:func:`expected_counts`), plus the final summary and the
reports themselves. The recorder (:mod:`hil.nodes.recorder`) records until that holds and the
review (:mod:`hil.review.core`, summary key ``recording``) checks it (:func:`completeness`).
Pure functions on plain mappings: the recorder hands them decoded Structs' fields, the
review the MCAP file's JSON.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

#: Topic (key suffix) -> the :class:`PlantReport` field counting its published messages.
PLANT_TOPICS: dict[str, str] = {
    "sensors": "sensor_frames_published",
    "truth": "truth_published",
    "timing/cycle": "cycle_records_published",
    "timing/summary": "summaries_published",
    "preview/wave_perfect": "previews_published",
}
#: Topic -> the :class:`ControllerReport` field counting its published messages.
CONTROLLER_TOPICS: dict[str, str] = {
    "command": "commands_published",
    "controller/status": "statuses_published",
}
PLANT_REPORT_TOPIC = "timing/report"
CONTROLLER_REPORT_TOPIC = "controller/report"


def expected_counts(
    plant: Mapping[str, Any] | None, controllers: Sequence[Mapping[str, Any]]
) -> dict[str, int]:
    """Messages a complete recording holds per topic, as far as the reports tell.

    Parameters
    ----------
    plant : mapping or None
        The plant's report (its fields), None when there is none.
    controllers : sequence of mappings
        Every controller report of the run (a restarted controller process sends one per
        process that stopped by itself; a killed one sends none).

    Returns
    -------
    dict of str to int
        Topic suffix -> count; topics the reports do not cover are left out.
    """
    out: dict[str, int] = {}
    if plant is not None:
        for topic, name in PLANT_TOPICS.items():
            out[topic] = int(plant.get(name, 0))
        out[PLANT_REPORT_TOPIC] = 1
    if controllers:
        for topic, name in CONTROLLER_TOPICS.items():
            out[topic] = sum(int(c.get(name, 0)) for c in controllers)
        out[CONTROLLER_REPORT_TOPIC] = len(controllers)
    return out


#: Per-cycle topics and the field naming their cycle (the controller's own ``seq`` starts
#: again when it is restarted; the cycle it answers does not go back).
CYCLE_FIELDS: dict[str, str] = {
    "sensors": "seq",
    "truth": "seq",
    "timing/cycle": "seq",
    "command": "answered_seq",
    "controller/status": "answered_seq",
}
#: Per-cycle topics whose cycles are consecutive (the plant publishes every cycle once;
#: a controller answers only the frames it got, so its cycles may skip).
CONSECUTIVE_TOPICS = frozenset({"sensors", "truth", "timing/cycle"})


class CycleOrder:
    """The order of one per-cycle topic's cycles, as the file holds them (streamed).

    Counts, against the highest cycle before each one, ``repeated`` (equal to it),
    ``reordered`` (lower) and, when ``consecutive``, ``skipped`` (cycles jumped over).
    An exact recording has none of them.
    """

    def __init__(self, consecutive: bool) -> None:
        self.consecutive = consecutive
        self.last: int | None = None
        self.repeated = 0
        self.reordered = 0
        self.skipped = 0

    def feed(self, cycles: np.ndarray) -> None:
        """Take the next cycles of the topic, in file order."""
        c = np.asarray(cycles).astype(np.int64, copy=False)
        if not c.size:
            return
        # Against the highest cycle before each one: a late cycle counts once, as reordered.
        seen = np.maximum.accumulate(c if self.last is None else np.concatenate(([self.last], c)))
        step = (c[1:] if self.last is None else c) - seen[:-1]
        self.repeated += int(np.count_nonzero(step == 0))
        self.reordered += int(np.count_nonzero(step < 0))
        if self.consecutive:
            self.skipped += int(np.sum(step[step > 1] - 1))
        self.last = int(seen[-1])

    def as_dict(self) -> dict[str, int]:
        """``repeated``, ``reordered`` and ``skipped``."""
        return {"repeated": self.repeated, "reordered": self.reordered, "skipped": self.skipped}


def order_problems(order: Mapping[str, Mapping[str, int]]) -> list[str]:
    """One sentence per per-cycle topic whose cycles repeat, go back or skip."""
    out = []
    for topic, o in order.items():
        parts = [
            f"{o[k]} {what}"
            for k, what in (
                ("repeated", "cycles recorded again"),
                ("reordered", "cycles out of order"),
                ("skipped", "cycles missing between recorded ones"),
            )
            if o.get(k, 0)
        ]
        if parts:
            out.append(f"{topic}: {', '.join(parts)}")
    return out


def excess(recorded: Mapping[str, int], expected: Mapping[str, int]) -> list[str]:
    """One line per plant topic with more messages recorded than the plant published.

    Only the plant's topics: the plant always reports, while a controller killed and
    restarted during a run leaves no report of what it published before; its topics are
    held to one message per cycle by :class:`CycleOrder` instead.
    """
    return [
        f"{topic}: {recorded.get(topic, 0)} recorded, {n} published "
        f"({recorded.get(topic, 0) - n} more than the plant put)"
        for topic, n in expected.items()
        if topic in PLANT_TOPICS and recorded.get(topic, 0) > n
    ]


def shortfall(recorded: Mapping[str, int], expected: Mapping[str, int]) -> list[str]:
    """One line per topic with fewer messages recorded than expected (empty: none short)."""
    return [
        f"{topic}: {recorded.get(topic, 0)} of {n} recorded ({n - recorded.get(topic, 0)} missing)"
        for topic, n in expected.items()
        if recorded.get(topic, 0) < n
    ]


def completeness(
    recorded: Mapping[str, int],
    plant: Mapping[str, Any] | None,
    controllers: Sequence[Mapping[str, Any]],
    final_summary: bool,
    order: Mapping[str, Mapping[str, int]] | None = None,
) -> dict[str, Any]:
    """The review's ``recording`` section: is every published message in the file?

    Parameters
    ----------
    recorded : mapping of str to int
        Messages in the file per topic suffix.
    plant : mapping or None
        The plant's report (the last one in the file), None when there is none.
    controllers : sequence of mappings
        The controller reports in the file.
    final_summary : bool
        Whether the file holds the plant's final timing summary (``final`` = 1).
    order : mapping or None
        Per per-cycle topic, :meth:`CycleOrder.as_dict` of its cycles in the file: any
        repeat, reorder or skip is a problem (exact recording: each cycle once, in order).

    Returns
    -------
    dict
        ``complete`` (bool: no gap, the final summary and both reports present),
        ``topics`` (suffix -> ``{"recorded": n, "expected": m}``; ``m`` None where no
        report covers the topic), ``problems`` (one sentence each), ``plant_report`` and
        ``controller_report`` (bool: present), ``order`` (as given, or empty). A plant
        topic must hold exactly what the plant published, no more (:func:`excess`).
    """
    expected = expected_counts(plant, controllers)
    problems: list[str] = []
    if not final_summary:
        problems.append("no final timing summary: the plant did not finish the run (killed?)")
    if plant is None:
        problems.append("no plant report (timing/report): what the plant published is unknown")
    if not controllers:
        problems.append(
            "no controller report (controller/report): what the controller published is unknown"
        )
    problems += shortfall(recorded, expected)
    problems += excess(recorded, expected)
    problems += order_problems(order or {})
    topics = {
        t: {"recorded": int(recorded.get(t, 0)), "expected": expected.get(t)}
        for t in (*PLANT_TOPICS, *CONTROLLER_TOPICS, PLANT_REPORT_TOPIC, CONTROLLER_REPORT_TOPIC)
        if t in expected or recorded.get(t, 0)
    }
    return {
        "complete": not problems,
        "topics": topics,
        "problems": problems,
        "plant_report": plant is not None,
        "controller_report": bool(controllers),
        "order": {t: dict(o) for t, o in (order or {}).items()},
    }


def describe(section: Mapping[str, Any]) -> str:
    """``"complete"`` or ``"INCOMPLETE (<problems>)"`` for the review's one-line render."""
    if section.get("complete"):
        return "complete"
    return f"INCOMPLETE ({'; '.join(section.get('problems') or ['unknown'])})"
