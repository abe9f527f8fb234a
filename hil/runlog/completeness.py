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

Recording levels (scenario ``[recording]``, :class:`hil.scenario.schema.RecordingSection`):
at ``soak`` the writers keep the truth of the cycles ``seq`` that are a multiple of N
(:func:`truth_kept`) and say so in the file's ``recording`` metadata record
(:func:`recording_metadata`, read back by :func:`recording_level`); the reports still count
what the plant published, and :func:`expected_counts` expects the kept share of it.
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
#: The topic a ``soak`` recording decimates (the plant's truth, one message a cycle).
DECIMATED_TOPIC = "truth"
#: The metadata record naming a file's recording level.
RECORDING_RECORD = "recording"


def truth_kept(seq: np.ndarray | int, truth_every: int) -> np.ndarray | bool:
    """Whether the truth of cycle(s) ``seq`` is kept at one in ``truth_every``: seq % N == 0.

    The cycle number, not the arrival, decides, so the in-process writer and the bus
    recorder keep the same cycles of a run.
    """
    if truth_every <= 1:
        return np.ones(np.shape(seq), bool) if isinstance(seq, np.ndarray) else True
    if isinstance(seq, np.ndarray):
        kept: np.ndarray = (seq % truth_every) == 0
        return kept
    return int(seq) % truth_every == 0


def kept_count(published: int, truth_every: int) -> int:
    """Truth messages kept of ``published`` consecutive cycles from 0 (the plant's ``seq``)."""
    n = max(1, truth_every)
    return (max(0, published) + n - 1) // n


def recording_metadata(level: str, truth_every: int, truth_period_s: float) -> dict[str, str]:
    """The ``recording`` metadata record of a file (strings, as every MCAP metadata)."""
    return {
        "level": level,
        "truth_every": str(truth_every if level != "full" else 1),
        "truth_period_s": f"{truth_period_s:g}" if level != "full" else "",
    }


def recording_level(metadata: Mapping[str, Mapping[str, str]]) -> tuple[str, int]:
    """(level, N) of a file from its metadata: ``("full", 1)`` without the record (a file
    from before recording levels) or with a record that does not parse."""
    rec = metadata.get(RECORDING_RECORD) or {}
    level = str(rec.get("level", "full"))
    try:
        every = int(rec.get("truth_every", "1"))
    except ValueError:
        return ("full", 1)
    return (level, every) if every >= 1 else ("full", 1)


def expected_counts(
    plant: Mapping[str, Any] | None,
    controllers: Sequence[Mapping[str, Any]],
    truth_every: int = 1,
) -> dict[str, int]:
    """Messages a complete recording holds per topic, as far as the reports tell.

    Parameters
    ----------
    plant : mapping or None
        The plant's report (its fields), None when there is none.
    controllers : sequence of mappings
        Every controller report of the run (a restarted controller process sends one per
        process that stopped by itself; a killed one sends none).
    truth_every : int
        N of a ``soak`` recording: one truth message in N is recorded (1: every one).

    Returns
    -------
    dict of str to int
        Topic suffix -> count; topics the reports do not cover are left out.
    """
    out: dict[str, int] = {}
    if plant is not None:
        for topic, name in PLANT_TOPICS.items():
            out[topic] = int(plant.get(name, 0))
        out[DECIMATED_TOPIC] = kept_count(out[DECIMATED_TOPIC], truth_every)
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
    truth_every: int = 1,
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
    truth_every : int
        N of a ``soak`` recording (:func:`recording_level`): the truth expected is the
        kept share of what the plant published (:func:`kept_count`), and the cycles a
        decimated truth skips on purpose are not gaps (its count still must match).

    Returns
    -------
    dict
        ``complete`` (bool: no gap, the final summary and both reports present),
        ``topics`` (suffix -> ``{"recorded": n, "expected": m}``; ``m`` None where no
        report covers the topic), ``problems`` (one sentence each), ``plant_report`` and
        ``controller_report`` (bool: present), ``order`` (as given, or empty). A plant
        topic must hold exactly what the plant published, no more (:func:`excess`).
    """
    expected = expected_counts(plant, controllers, truth_every)
    if truth_every > 1 and order and DECIMATED_TOPIC in order:
        order = {**order, DECIMATED_TOPIC: {**order[DECIMATED_TOPIC], "skipped": 0}}
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


#: Review figures that need the truth of every cycle, per summary section: under a soak
#: recording (1 truth message in N) they are ``null`` (unavailable), never estimated from
#: the kept samples: a maximum and rainflow cycles (DELs) miss the peaks between them, the
#: pitch travel the motion between them, and the estimator and forecast errors are taken
#: against the truth interpolated to each status's time (at 1 Hz, the interpolation error
#: of an 8 s wave or of 12.5 ms turbulence would be counted as the estimator's).
SOAK_UNAVAILABLE: dict[str, tuple[str, ...]] = {
    "kpi": (
        "thrust_max_n",
        "pitch_travel_deg_s",
        "shaft_del_nm",
        "tower_base_del_nm",
        "thrust_del_n",
    ),
    "estimator": (
        "wind_speed_error_mean_pct",
        "wind_speed_error_rms_m_s",
        "platform_pitch_rate_error_rms_rad_s",
        "platform_surge_velocity_error_rms_m_s",
    ),
    "forecast": ("vaf_pct",),
}


def soak_unavailable(summary: dict[str, Any], truth_every: int) -> list[str]:
    """Set the figures of :data:`SOAK_UNAVAILABLE` to None in a review summary whose truth
    was recorded at 1 in ``truth_every`` (> 1); list them (``section.key``) under
    ``summary["recording"]["unavailable"]``. The other truth KPIs (means, standard
    deviations) are computed from the kept samples, a regular 1:N subsample."""
    if truth_every <= 1:
        return []
    gone = []
    for section, keys in SOAK_UNAVAILABLE.items():
        part = summary.get(section)
        if not isinstance(part, dict):
            continue
        for key in keys:
            if key in part:
                part[key] = None
                gone.append(f"{section}.{key}")
    rec = summary.get("recording")
    if isinstance(rec, dict):
        rec["unavailable"] = gone
    return gone
