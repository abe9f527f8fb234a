"""Review of one run from its MCAP log alone: summary JSON, KPI tables and plots.

Summary keys (all numbers, ``null`` where a channel was missing)
----------------------------------------------------------------
``timing``
    ``latency_us.{p50,p99,p999,max}`` sensor-to-command latency [us], linear percentiles
    over every ``timing/cycle``: a missed cycle at the latency of its late command, one
    that got no command before the next tick as infinite (``null`` where a percentile
    falls among those; :func:`hil.review.kpi.latency_percentiles_us`); ``latency_cycles`` [1]
    cycles in them, ``unanswered_cycles`` [1] those without a command, ``deadline_us``
    [us] the control period over the speed factor;
    ``latency_source`` says which channel they came from (``"timing/cycle"``, or
    ``"timing/summary"`` when no cycle was logged); ``latency_us_plant`` the plant's own
    histogram percentiles (about 2 % bin width) from the last ``timing/summary``;
    ``cycles``, ``deadline_misses``, ``commands_held``, ``commands_rejected``,
    ``commands_late`` [1] and ``safe_state`` (0/1) from the final summary (``final`` = 1),
    else derived from ``timing/cycle``; ``cycles_logged`` [1] cycle messages in the file;
    ``sim_seconds_per_wall_second`` [1]; the plant watchdog's safe-state windows in
    ``timing/cycle``: ``watchdog_policy`` (``"latch"`` or ``"recover"``, the scenario's
    rule), ``watchdog_trips`` [1] (entries into the safe state), ``watchdog_recoveries``
    [1] (control handed back), ``safe_state_longest_cycles`` [1] and
    ``safe_state_longest_s`` [s] (the longest window; ``safe_state_cycles`` [1] their sum,
    from the final summary); ``controller_compute_us.{p50,p99,max}`` [us] of
    ``controller/status`` ``compute_time_ns``; ``complete`` False when the run has no
    final summary (crash), counts then come from the logged cycles.
``kpi``
    ``mean_power_w`` [W], ``rotor_speed_mean_rad_s``, ``rotor_speed_std_rad_s`` [rad/s],
    ``pitch_travel_deg_s`` [deg/s] (truth ``blade_pitch_rad`` vs ``sample_time_ns``),
    ``generator_torque_mean_nm`` [N m, HSS], ``thrust_mean_n``, ``thrust_max_n`` [N],
    ``shaft_del_nm`` [N m] damage-equivalent range of the low-speed-shaft torque
    ``shaft_torque_nm`` (truth), ``tower_base_del_nm`` [N m] the same for the tower-base
    fore-aft bending moment ``tower_base_moment_nm``, both by rainflow counting with Wöhler
    exponent m = ``shaft_del_wohler_m`` = 4 at f_eq = ``del_n_eq_hz`` = 1 Hz over the record:
    DEL = (Σ n_i S_i^m / (f_eq T))^(1/m), T the record length ("1 Hz equivalent,
    600 s" is this with T = 600 s for a 600 s load case; shorter records give the same
    damage rate, so DELs of runs of different lengths compare),
    ``thrust_del_n`` [N] the same for rotor thrust (m = 4),
    ``platform_pitch_mean_deg``, ``platform_pitch_std_deg`` [deg], ``surge_mean_m``,
    ``surge_std_m`` [m] of the true platform motion (truth; ``null`` for a bottom-fixed
    plant). Every KPI (and the estimator and forecast figures) covers only the samples from
    ``kpi_window.from_s`` on (:func:`kpi_window`).
``kpi_window``
    ``settle_s`` requested start-up settling time (scenario ``[review] settle_s``),
    ``from_s``/``to_s`` the window used [s], ``shortened`` when the run was too short.
``run``
    the ``"run"`` metadata record (strings) plus ``turbine``, ``duration_s`` [s] (span of
    ``sample_time_ns`` over all topics), ``messages`` (count per topic suffix),
    ``truncated`` (no footer and closing magic), ``truncated_at_s`` [s] the last sample
    time in a truncated file, ``statistics_ok`` (the summary's message counts equal the
    messages read; ``null`` without a summary) and ``error`` (what the reader stopped on).
``scenario``
    ``name`` and ``config`` (the record's ``json`` parsed), ``null`` fields when absent.
``estimator``
    Advanced controllers (``controller/status`` estimates against ``truth`` at the same
    sample time): ``wind_speed_error_mean_pct`` [%] 100 mean(Û − U)/mean(U),
    ``wind_speed_error_rms_m_s`` [m/s], ``platform_pitch_rate_error_rms_rad_s`` [rad/s],
    ``platform_surge_velocity_error_rms_m_s`` [m/s], ``degraded_fraction`` [-] of cycles with
    ``estimator_degraded``; ``null`` when no estimate was published.
``forecast``
    ``vaf_pct`` [%] of the published wave forecast against the true platform elevation at the
    time each forecast is for, 100 (1 − var(η − η̂)/var(η)); ``samples`` [1] distinct forecasts.
``controller``
    ``compute_us.{p50,p99,max}`` [us] of the status ``compute_time_ns`` (as in ``timing``);
    the controller's safe mode and rejected frames: ``source`` (``"controller/report"``, the
    controller's final :class:`~bus_schemas.messages.ControllerReport`, else ``"commands"``:
    derived from the ``command`` channel's ``mode`` flags), ``safe_mode_entered``,
    ``safe_mode_entries`` [1], ``safe_mode_first_entry_s`` [s], ``safe_mode_commands`` [1],
    ``safe_mode_at_end``, ``safe_mode_s`` [s] (commands sent with ``mode`` = safe times
    ``control_period_s``), ``commands`` [1] published, ``frames_missing``, ``frames_stale``
    [1] (``null`` from commands), ``frames_rejected`` ``{reason: count}`` (``null`` from
    commands) and ``frames_rejected_total`` [1]; the core's ``fault`` (``null``, or
    ``kind``, ``message``, ``t_s`` [s], ``cycle``, ``field``, ``phase``: numbers from the
    report, text from ``controller_fault.json`` beside the file,
    :mod:`hil.nodes.controller_fault`), ``fault_commands`` [1] (sent flagged ``mode`` = 3),
    ``cycles_stepped`` [1] (statuses) and ``overruns`` [1] (statuses whose
    ``compute_time_ns`` exceeds the control period); ``estimator_faults`` [1]: the estimator
    divergences the controller detected and fell back from (the largest running count of
    ``controller/status``; 0 in a log from before the count existed) and
    ``estimator_faults_first_s`` [s] (sample time of the first status counting one; null:
    none).
``plant``
    ``source`` (``"timing/report"``, the plant's final
    :class:`~bus_schemas.messages.PlantReport`, else ``"timing/summary"``),
    ``commands_applied`` [1], ``commands_rejected`` ``{reason: count}`` (``null`` without
    the report) and ``commands_rejected_total`` [1].
``recording``
    Whether the file holds every message the nodes published (:func:`hil.runlog.completeness.
    completeness`): ``complete`` (bool), ``topics`` (per topic suffix ``recorded`` and
    ``expected`` [1], the latter from the plant's ``timing/report`` and the controller's
    ``controller/report``, ``null`` where no report covers the topic), ``problems`` (one
    sentence per gap; a missing final summary or report is one), ``plant_report`` and
    ``controller_report`` (bool: present), ``level`` (``"full"`` or ``"soak"``, the file's
    ``recording`` metadata; ``"full"`` without it) and ``truth_every`` N (1 truth message in
    N recorded; the KPIs that need every cycle's truth are then ``null``:
    :func:`hil.runlog.completeness.soak_unavailable`).
"""

from __future__ import annotations

import contextlib
import json
import math
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from rich.markup import escape
from rich.table import Table

from bus_schemas.messages import (
    COMMAND_MODE_FAULT,
    CONTROLLER_REJECT_REASONS,
    EST_PLATFORM_PITCH_RATE,
    EST_PLATFORM_SURGE_VELOCITY,
    EST_WAVE_FORECAST,
    EST_WIND_SPEED,
    PLANT_REJECT_REASONS,
)
from bus_schemas.registry import WAVE_PREVIEW_PERFECT
from hil.nodes.controller_fault import FAULT_CODES, FAULT_FIELDS, fault_line, read_fault
from hil.review import kpi
from hil.review import stream as rs
from hil.review.kpi_names import REVIEW_KPIS
from hil.review.table_range import RotorTableRange, table_range_note
from hil.runlog.columns import ColumnBatch, ColumnReader, RunInfo, run_batches, run_info
from hil.runlog.completeness import (
    CONSECUTIVE_TOPICS,
    CYCLE_FIELDS,
    CycleOrder,
    completeness,
    describe,
    recording_level,
    soak_unavailable,
)
from hil.runlog.mcap_io import PROFILE, MessageList, RunData, read_run
from hil.scenario.schema import ReviewSection, watchdog_rule

if TYPE_CHECKING:
    from rich.console import Console

    from hil.review.plot_worker import PlotWorker

FloatArray = npt.NDArray[np.float64]

#: Wöhler exponent used for the shaft (and thrust) DEL in the summary (the bench's one value).
SHAFT_WOHLER_M = kpi.DEL_WOHLER_M
#: Equivalent-load frequency of the DELs in the summary [Hz] (the bench's one value).
DEL_N_EQ_HZ = kpi.DEL_N_EQ_HZ

PLOT_FILES = ("timeseries.png", "timing.png", "psd.png")

#: Start-up settling time left out of the KPIs when the log's scenario has no ``[review]
#: settle_s`` [s] (see :func:`kpi_window`); the default of ``hil.scenario.schema.ReviewSection``.
DEFAULT_SETTLE_S = ReviewSection().settle_s


# --------------------------------------------------------------------------- helpers


def _col(msgs: Sequence[dict[str, Any]], name: str) -> FloatArray:
    """One field of a message list as a float array (missing values as nan; a
    :class:`hil.runlog.mcap_io.MessageList` gives it from its rows)."""
    if isinstance(msgs, MessageList):
        return msgs.column(name)
    return np.array([m.get(name, math.nan) for m in msgs], dtype=np.float64)


def _t_s(msgs: Sequence[dict[str, Any]]) -> FloatArray:
    """Simulated time of each message [s]."""
    return _col(msgs, "sample_time_ns") / 1e9


def _clean(obj: Any) -> Any:
    """Recursively replace non-finite floats by None and numpy scalars by Python ones."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        obj = float(obj)
    return kpi.finite_or_none(obj)


def _suffix(topic: str) -> str:
    """``fowt/<turbine>/controller/status`` -> ``controller/status``."""
    parts = topic.split("/", 2)
    return parts[2] if len(parts) == 3 else topic


def _turbine(topics: Iterable[str]) -> str | None:
    for topic in topics:
        parts = topic.split("/", 2)
        if len(parts) == 3 and parts[0] == "fowt":
            return parts[1]
    return None


class NotRunLogError(ValueError):
    """The file is an MCAP file, but not a run log of this bench (nothing to review)."""


def check_run_log(run: RunData | RunInfo, source: Path | str = "") -> None:
    """Raise :class:`NotRunLogError` unless ``run`` is a run log of this bench.

    A run log of this bench has the ``fowt-hil`` profile in its MCAP Header
    (:data:`hil.runlog.mcap_io.PROFILE`; every node and campaign log) or at least one channel
    under ``fowt/`` (a multi-turbine platform's log has an empty profile). Anything else (a
    robot's ``/robot/pose``, an empty MCAP file) has none of the channels the review reads:
    its summary would be all ``null`` and its plots empty, so it is refused before anything
    is written.

    Parameters
    ----------
    run : RunData or RunInfo
        What :func:`hil.runlog.mcap_io.read_run` (or :class:`hil.runlog.columns.ColumnReader`) read.
    source : Path or str
        The file, for the message.
    """
    names = list(run.messages) if isinstance(run, RunData) else run.topics
    if run.profile == PROFILE or any(t.startswith("fowt/") for t in names):
        return
    topics = sorted(names)
    shown = ", ".join(topics[:5]) + (f" and {len(topics) - 5} more" if len(topics) > 5 else "")
    where = f"{source}: " if str(source) else ""
    raise NotRunLogError(
        f"not a fowt-hil run log: {where}profile {run.profile or ''!r}, no fowt/ channel "
        f"(channels: {shown or 'none'})"
    )


def review_problems(summary: dict[str, Any]) -> list[str]:
    """What keeps a reviewed run log from being a complete record (``--strict`` fails on any).

    A truncated or damaged file (:func:`truncation_note`), summary statistics that differ
    from the messages read, and a bench run without the plant's final timing summary (the
    plant did not finish: its counts come from the logged cycles). Empty when complete.
    """
    out: list[str] = []
    run = summary.get("run", {})
    note = truncation_note(summary)
    if note:
        out.append(note)
    elif run.get("statistics_ok") is False:
        out.append(str(run.get("error")))
    if summary.get("kind") != "hexicon" and summary.get("timing", {}).get("complete") is False:
        out.append("no final timing summary: the plant did not finish the run")
    return out


def _int_or_none(v: Any) -> int | None:
    return None if v is None else int(v)


# --------------------------------------------------------------------------- summary


def _cycle_latency_ns(cycles: Sequence[dict[str, Any]]) -> tuple[FloatArray, int]:
    """Every cycle's sensor-to-command latency [ns] and the count of unanswered cycles.

    A cycle that met its deadline logs its latency; a missed one logs the latency of the
    command that came after the deadline (``hil.nodes.plant_node``, real-time mode), or 0 when
    none came before the next tick: that cycle counts as unanswered, latency ``inf``.
    """
    lat = _col(cycles, "latency_ns")
    missed = _col(cycles, "deadline_missed") > 0
    keep = np.isfinite(lat) & ((lat > 0) | missed)
    lat, missed = lat[keep], missed[keep]
    none = missed & (lat <= 0)
    lat = np.where(none, np.inf, lat)
    return lat, int(none.sum())


def _deadline_us(run: RunData | RunInfo) -> float:
    """The command deadline in wall time [us]: the control period / the speed factor."""
    cfg = _scenario(run).get("config") or {}
    timing = cfg.get("timing") if isinstance(cfg, dict) else None
    period = timing.get("control_period_s") if isinstance(timing, dict) else None
    if not isinstance(period, int | float):
        return math.nan
    try:
        speed = float(run.metadata.get("run", {}).get("speed", "1"))
    except ValueError:
        speed = 1.0
    return float(period) * 1e6 / (speed if speed > 0 else 1.0)


def _since(msgs: list[dict[str, Any]], t0_s: float) -> list[dict[str, Any]]:
    """The messages whose sample time is at or after ``t0_s`` [s]."""
    t0_ns = t0_s * 1e9
    if isinstance(msgs, MessageList):
        return msgs.since("sample_time_ns", t0_ns)
    return [m for m in msgs if m.get("sample_time_ns", -1) >= t0_ns]


def kpi_window(run: RunData) -> dict[str, Any]:
    """The part of the run the KPIs are computed over (the start-up transient left out).

    The scenario's ``[review] settle_s`` (:data:`DEFAULT_SETTLE_S` = 40 s when absent, e.g. in
    a log written before the key existed) is the requested settling time T_s. The KPIs use the
    truth samples with t >= t_0, t_0 = min(T_s, t_end / 2): a run shorter than 2 T_s keeps
    its second half (``shortened`` True), so short test and CI runs still review.

    Returns
    -------
    dict
        ``settle_s`` (requested T_s), ``from_s`` (t_0), ``to_s`` (last truth sample, None
        without one) [s] and ``shortened``.
    """
    cfg = _scenario(run).get("config") or {}
    rv = cfg.get("review") if isinstance(cfg, dict) else None
    settle = DEFAULT_SETTLE_S
    if isinstance(rv, dict) and isinstance(rv.get("settle_s"), int | float):
        settle = float(rv["settle_s"])
    t = _t_s(run.topic("truth"))
    t = t[np.isfinite(t)]
    end = float(t.max()) if t.size else math.nan
    start = kpi.window_start_s(end, settle)
    return {
        "settle_s": settle,
        "from_s": start,
        "to_s": end,
        "shortened": bool(start < settle),
    }


#: ``ActuatorCommand.mode`` of a command sent in the controller's safe mode
#: (:data:`hil.nodes.controller_node.MODE_SAFE`; not imported: that module loads the bus).
MODE_SAFE_COMMAND = 2
#: ``ActuatorCommand.mode`` of a command flagged as faulted (the core faulted; never applied).
MODE_FAULT_COMMAND = COMMAND_MODE_FAULT


def _fault_of(report: dict[str, Any] | None) -> dict[str, Any] | None:
    """The core's fault from the controller's report (its numbers; the text, if any, is
    beside the file: :func:`with_fault_text`), None when it reports none."""
    if report is None:
        return None
    code = int(report.get("core_fault", 0))
    if code <= 0:
        return None
    kinds = {v: k for k, v in FAULT_CODES.items()}
    field_index = int(report.get("core_fault_field", 0))
    field = FAULT_FIELDS[field_index] if 0 <= field_index < len(FAULT_FIELDS) else ""
    return {
        "kind": kinds.get(code, "raised"),
        "message": "",
        "t_s": int(report.get("core_fault_time_ns", 0)) / 1e9,
        "cycle": int(report.get("core_fault_seq", 0)),
        "field": field,
        "phase": "run",
    }


def with_fault_text(summary: dict[str, Any], fault: dict[str, Any] | None) -> None:
    """Complete ``summary["controller"]["fault"]`` with ``fault``'s text (the runtime's own
    record, :class:`hil.nodes.controller_fault.ControllerFault`), when the recorded report
    names the same fault (same cycle): a file left from another run in the folder adds
    nothing."""
    if not fault:
        return
    ctrl = summary.setdefault("controller", {})
    known = ctrl.get("fault")
    if isinstance(known, dict) and known.get("cycle") == fault.get("cycle"):
        ctrl["fault"] = {**known, **fault}


def _control_period_s(run: RunData, commands: Sequence[dict[str, Any]]) -> float:
    """The scenario's control period [s], else the median spacing of the commands' times."""
    period = _scenario_period_s(run)
    if math.isfinite(period):
        return period
    t = _t_s(commands)
    t = t[np.isfinite(t)]
    return float(np.median(np.diff(t))) if t.size >= 2 else math.nan


def _final_record(msgs: Sequence[dict[str, Any]]) -> dict[str, Any] | None:
    """The last message with ``final`` = 1, else the last one (None: no message)."""
    final = next((m for m in reversed(msgs) if int(m.get("final", 0)) == 1), None)
    return final if final is not None else (msgs[-1] if msgs else None)


def _reasons(record: dict[str, Any], prefix: str, reasons: tuple[str, ...]) -> dict[str, int]:
    """``{reason: count}`` of a report's ``<prefix>_<reason>`` fields."""
    return {r: int(record.get(f"{prefix}_{r}", 0)) for r in reasons}


def could_have(topic: str, config: Any) -> bool:
    """Whether a run of the scenario ``config`` (the recorded scenario, parsed; None: not
    known) could publish on ``topic`` (a key suffix). The run's ``messages`` list an empty
    topic only then: a writer declares every channel of the bench, and an empty channel the
    run could never have (``preview/wave_perfect`` without a perfect wave preview) is not a
    loss worth a line."""
    if not isinstance(config, dict):
        return True
    if topic == WAVE_PREVIEW_PERFECT.key_suffix:  # the plant's bench oracle (plant_node)
        controller = config.get("controller")
        preview = controller.get("preview") if isinstance(controller, dict) else None
        return preview == "perfect" and config.get("platform") is not None
    return True


def _scenario(run: RunData | RunInfo) -> dict[str, Any]:
    return _scenario_of(run.metadata)


def _scenario_of(metadata: Mapping[str, Mapping[str, str]]) -> dict[str, Any]:
    """The scenario recorded in a log's metadata: its name and its config (parsed JSON)."""
    rec = metadata.get("scenario", {})
    out: dict[str, Any] = {"name": rec.get("name"), "config": None}
    raw = rec.get("json")
    if raw:
        try:
            out["config"] = json.loads(raw)
        except ValueError as exc:
            out["config_error"] = f"{type(exc).__name__}: {exc}"
    return out


class _WatchdogWindows:
    """The plant watchdog's safe-state windows in ``timing/cycle`` ``safe_state``, fed in
    seq order batch by batch: trips (0 -> 1), recoveries (1 -> 0), the longest window."""

    def __init__(self) -> None:
        self.prev = False  # the last cycle's flag
        self.open = 0  # cycles of the window still open at the last cycle fed
        self.trips = 0
        self.recoveries = 0
        self.longest = 0

    def add(self, flags: np.ndarray) -> None:
        if not flags.size:
            return
        before = np.concatenate(([self.prev], flags[:-1]))
        self.trips += int((flags & ~before).sum())
        self.recoveries += int((before & ~flags).sum())
        edges = np.diff(np.concatenate(([False], flags, [False])).astype(np.int8))
        lengths = np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)
        if lengths.size:
            if flags[0]:  # the first window continues the one open at the last batch's end
                lengths[0] += self.open
            self.longest = max(self.longest, int(lengths.max()))
        self.open = int(lengths[-1]) if flags[-1] else 0
        self.prev = bool(flags[-1])

    def result(self, config: Any, period_s: float) -> dict[str, Any]:
        """``watchdog_policy`` (the scenario's rule), ``watchdog_trips``,
        ``watchdog_recoveries``, ``safe_state_longest_cycles`` and ``safe_state_longest_s``."""
        timing = config.get("timing") if isinstance(config, dict) else None
        policy = watchdog_rule(timing) if isinstance(timing, dict) else None
        return {
            "watchdog_policy": policy,
            "watchdog_trips": self.trips,
            "watchdog_recoveries": self.recoveries,
            "safe_state_longest_cycles": self.longest,
            "safe_state_longest_s": self.longest * period_s if math.isfinite(period_s) else None,
        }


def _period_s(run: RunData | RunInfo) -> float:
    """The control period [s] of the recorded scenario (nan when absent)."""
    cfg = _scenario(run).get("config") or {}
    timing = cfg.get("timing") if isinstance(cfg, dict) else None
    period = timing.get("control_period_s") if isinstance(timing, dict) else None
    return float(period) if isinstance(period, int | float) and period > 0 else math.nan


class _Summary:
    """The review's figures accumulated over batches of columns (:mod:`hil.review.stream`).

    Feed every :class:`hil.runlog.columns.ColumnBatch` of the run to :meth:`add` in file
    order, then :meth:`result` with the run's :class:`hil.runlog.columns.RunInfo` gives
    :func:`summarize`'s dict. The figures are those of the module docstring, computed as
    over whole series (see :mod:`hil.review.stream` for how each is kept).
    """

    def __init__(self, info: RunInfo) -> None:
        self.info = info
        self.t_min, self.t_max = math.inf, -math.inf
        # timing/cycle
        self.latency = rs.Store()
        self.unanswered = 0
        self.cycles = 0
        self.cycle_sums = {"deadline_missed": 0, "command_held": 0}
        self.cycle_safe = 0
        self.watchdog = _WatchdogWindows()
        self.cycle_first: tuple[float, float] | None = None
        self.cycle_last: tuple[float, float] = (math.nan, math.nan)
        # timing/summary
        self.last_summary: dict[str, Any] | None = None
        self.final_summary: dict[str, Any] | None = None
        # controller/status
        self.compute = rs.Store()
        # the figures of the two whole columns (_whole_columns, at the end)
        self.latency_cycles = 0
        self.latency_us: dict[str, float] = {}
        self.cycles_stepped = 0
        self.overruns = 0
        self.compute_us: dict[str, float] = {}
        self.status_count = 0
        self.last_rejected = math.nan
        # command
        self.commands = 0
        self.safe_prev = False
        self.safe_entries = 0
        self.safe_first_s: float | None = None
        self.safe_count = 0
        self.fault_count = 0  # commands flagged as faulted (mode 3)
        self.safe_last: bool | None = None
        self.cmd_last_t = math.nan
        self.cmd_diffs: Counter[float] = Counter()
        self.rows: dict[str, list[dict[str, Any]]] = {t: [] for t in rs.ROW_TOPICS}
        self.order = {t: CycleOrder(t in CONSECUTIVE_TOPICS) for t in CYCLE_FIELDS}
        # windowed (KPI window): truth, sensors, joined status
        self.window: rs.Window | None = None
        self.truth_any = False
        self.k = {
            n: rs.Moments()
            for n in (
                "electrical_power_w",
                "rotor_speed_rad_s",
                "generator_torque_nm",
                "rotor_thrust_n",
                "platform_pitch_rad",
                "platform_surge_m",
                "tower_base_moment_nm",
                "platform_pitch_measured_rad",
            )
        }
        self.floating_sum = 0.0
        self.window_truth = 0
        self.pitch_finite = True
        self.travel = rs.Travel()
        self.dels = {
            n: rs.Reversals() for n in ("shaft_torque_nm", "tower_base_moment_nm", "rotor_thrust_n")
        }
        self.join = rs.TruthJoin(lambda cols: self._window().feed("status", cols))
        self.w_status = 0
        self.w_mask_finite = True
        self.w_degraded = 0
        self.wind = rs.Sums(3)  # Σe, Σu, Σe²
        self.rms = {"pr": rs.Sums(1), "sv": rs.Sums(1)}  # Σe²
        self.f_prev = math.nan
        self.f_started = False
        self.f_ok = 0
        self.f_eta = rs.Moments()
        self.f_err = rs.Moments()
        self.f_max = {"forecast_unstable_fits": -math.inf, "forecast_guarded": -math.inf}
        self.estimator_faults = -math.inf  # the status's running count: its largest value
        self.estimator_fault_first_s: float | None = None  # sample time of the first [s]
        self.rotor_table = RotorTableRange(info.metadata)  # samples outside the Cp/Ct table

    def _window(self) -> rs.Window:
        if self.window is None:  # the scenario's metadata comes before the messages
            self.window = rs.Window(_settle_s(self.info), self._windowed)
        return self.window

    def add(self, b: ColumnBatch) -> None:
        c = b.columns
        t = c["sample_time_ns"]
        fin = t[np.isfinite(t)]
        if fin.size:
            self.t_min = min(self.t_min, float(fin.min()))
            self.t_max = max(self.t_max, float(fin.max()))
        if not b.first:
            return
        s = b.suffix
        order = self.order.get(s)
        if order is not None and CYCLE_FIELDS[s] in c:
            order.feed(c[CYCLE_FIELDS[s]])
        if s == "truth":
            self.truth_any = True
            self._window().truth_times(t / 1e9)
            self._window().feed("truth", {"t_ns": t, **c})
            self.join.add_truth(c)
            self.rotor_table.add(c)
        elif s == "sensors":
            self._window().feed("sensors", {"t_ns": t, **c})
        elif s == "controller/status":
            self.compute.add(c["compute_time_ns"])
            self.status_count += b.size
            self.last_rejected = float(c["rejected_frames"][-1])
            # the whole run (not the review window): a fault in the first seconds counts
            faults = c.get("estimator_faults")
            if faults is not None and np.isfinite(faults).any():
                self.estimator_faults = max(self.estimator_faults, float(np.nanmax(faults)))
                first = np.flatnonzero(faults > 0)
                if first.size and self.estimator_fault_first_s is None:
                    self.estimator_fault_first_s = float(t[first[0]]) / 1e9
            self.join.add_status(c)
        elif s == "timing/cycle":
            self._cycles(c, b.size)
        elif s == "timing/summary":
            self.last_summary = b.row(b.size - 1)
            final = np.flatnonzero(c["final"] == 1)
            if final.size:
                self.final_summary = b.row(int(final[-1]))
        elif s == "command":
            self._commands(c, b.size)
        elif s in self.rows:
            self.rows[s].extend(b.row(i) for i in range(b.size))

    def _cycles(self, c: dict[str, np.ndarray], n: int) -> None:
        lat = c["latency_ns"]
        missed = c["deadline_missed"] > 0
        keep = np.isfinite(lat) & ((lat > 0) | missed)
        none = missed & (lat <= 0) & keep
        self.latency.add(np.where(none, np.inf, lat)[keep])
        self.unanswered += int(none.sum())
        self.cycles += n
        for name in self.cycle_sums:
            self.cycle_sums[name] += int(np.nansum(c[name]))
        self.cycle_safe = max(self.cycle_safe, int(np.nanmax(np.nan_to_num(c["safe_state"]))))
        self.watchdog.add(np.nan_to_num(c["safe_state"]) > 0)
        t, w = c["sample_time_ns"], c["publish_time_ns"]
        if self.cycle_first is None:
            self.cycle_first = (float(t[0]), float(w[0]))
        self.cycle_last = (float(t[-1]), float(w[-1]))

    def _commands(self, c: dict[str, np.ndarray], n: int) -> None:
        t = c["sample_time_ns"] / 1e9
        safe = c["mode"] == MODE_SAFE_COMMAND
        before = np.concatenate(([self.safe_prev], safe[:-1]))
        entries = np.flatnonzero(safe & ~before)
        if entries.size and self.safe_first_s is None:
            self.safe_first_s = float(t[entries[0]])
        self.safe_entries += int(entries.size)
        self.safe_count += int(safe.sum())
        self.fault_count += int(np.count_nonzero(c["mode"] == MODE_FAULT_COMMAND))
        self.safe_prev = bool(safe[-1])
        self.safe_last = bool(safe[-1])
        self.commands += n
        tf = t[np.isfinite(t)]
        if tf.size:
            self.cmd_diffs.update(np.diff(np.concatenate(([self.cmd_last_t], tf))).tolist())
            if math.isnan(self.cmd_last_t):
                del self.cmd_diffs[next(k for k in self.cmd_diffs if math.isnan(k))]
            self.cmd_last_t = float(tf[-1])

    def _windowed(self, kind: str, c: dict[str, np.ndarray]) -> None:
        """A batch inside the KPI window (t >= t_0)."""
        if kind == "truth":
            self.window_truth += c["t_ns"].size
            t = c["sample_time_ns"] / 1e9
            for name in (
                "electrical_power_w",
                "rotor_speed_rad_s",
                "generator_torque_nm",
                "rotor_thrust_n",
                "platform_pitch_rad",
                "platform_surge_m",
                "tower_base_moment_nm",
            ):
                self.k[name].add(c[name])
            self.pitch_finite = self.pitch_finite and bool(
                np.isfinite(c["platform_pitch_rad"]).all()
            )
            self.floating_sum += float(np.nansum(np.abs(c["floating"])))
            self.travel.add(c["blade_pitch_rad"], t)
            for name, acc in self.dels.items():
                acc.add(c[name], t)
        elif kind == "sensors":
            self.k["platform_pitch_measured_rad"].add(c["platform_pitch_measured_rad"])
        else:
            self._window_status(c)

    def _window_status(self, c: dict[str, np.ndarray]) -> None:
        n = c["t_ns"].size
        self.w_status += n
        mask = c["estimates_valid_mask"]
        self.w_mask_finite = self.w_mask_finite and bool(np.isfinite(mask).all())
        m = np.where(np.isfinite(mask), mask, 0).astype(np.int64)
        self.w_degraded += int(np.count_nonzero(c["estimator_degraded"] > 0))
        inside = c["inside"]
        sel = inside & ((m & EST_WIND_SPEED) != 0)
        if sel.any():
            u = c["truth_wind_speed_m_s"][sel]
            e = c["wind_speed_estimated_m_s"][sel] - u
            self.wind.add(e, u, e * e)
        for key, bit, est, tru in (
            (
                "pr",
                EST_PLATFORM_PITCH_RATE,
                "platform_pitch_rate_estimated_rad_s",
                "truth_platform_pitch_rate_rad_s",
            ),
            (
                "sv",
                EST_PLATFORM_SURGE_VELOCITY,
                "platform_surge_velocity_estimated_m_s",
                "truth_platform_surge_velocity_m_s",
            ),
        ):
            sel = inside & ((m & bit) != 0)
            if sel.any():
                e = c[est][sel] - c[tru][sel]
                self.rms[key].add(e * e)
        f_sel = (m & EST_WAVE_FORECAST) != 0
        if f_sel.any():
            f_t = c["wave_forecast_time_ns"][f_sel]
            keep = np.empty(f_t.size, bool)
            keep[0] = not self.f_started or f_t[0] != self.f_prev
            keep[1:] = f_t[1:] != f_t[:-1]  # a forecast is held between forecaster calls
            self.f_started, self.f_prev = True, float(f_t[-1])
            ok = c["f_ok"][f_sel] & keep
            if ok.any():
                eta = c["truth_eta_at_forecast"][f_sel][ok]
                self.f_ok += int(ok.sum())
                self.f_eta.add(eta)
                self.f_err.add(eta - c["wave_elevation_forecast_m"][f_sel][ok])
        for name in self.f_max:
            col = c[name]
            if np.isfinite(col).any():
                self.f_max[name] = max(self.f_max[name], float(np.nanmax(col)))

    def result(self) -> dict[str, Any]:
        """:func:`summarize`'s dict (call once, after the last batch)."""
        self._whole_columns()
        self.join.finish()
        window = self._window().finish()
        summary = {
            "timing": self._timing(),
            "kpi": self._kpis(),
            "kpi_window": window,
            "run": self._run_info(),
            "scenario": _scenario(self.info),
            **self._estimates(),
            "recording": self._recording(),
            "plant": self._plant_account(),
            "rotor_table": self.rotor_table.result(),
        }
        summary["controller"].update(self._controller_account())
        soak_unavailable(summary, summary["recording"]["truth_every"])
        return summary

    def _whole_columns(self) -> None:
        """The figures of the two columns kept whole (latency, compute time), each computed
        in its own array (sorted in place, no copy: 28 MB each for a day at 40 Hz), which is
        then let go."""
        period = _scenario_period_s(self.info)
        if not math.isfinite(period):
            period = rs.median_of_counts(self.cmd_diffs)
        compute = self.compute.array()
        self.compute = rs.Store()
        self.cycles_stepped = int(compute.size)
        self.overruns = (
            int(np.count_nonzero(compute > period * 1e9)) if math.isfinite(period) else 0
        )
        np.divide(compute, 1e3, out=compute)  # the same figures as compute / 1e3
        self.compute_us = kpi.percentiles(compute, [50.0, 99.0], ["p50", "p99", "max"], True)
        del compute
        lat_ns = self.latency.array()
        self.latency = rs.Store()
        self.latency_cycles = int(lat_ns.size)
        self.latency_us = kpi.latency_percentiles_us(lat_ns, overwrite=True)

    def _timing(self) -> dict[str, Any]:
        final, last_summary = self.final_summary, self.final_summary or self.last_summary
        plant_lat = (
            {
                "p50": last_summary.get("latency_p50_us"),
                "p99": last_summary.get("latency_p99_us"),
                "p999": last_summary.get("latency_p999_us"),
                "max": last_summary.get("latency_max_us"),
            }
            if last_summary is not None
            else {"p50": None, "p99": None, "p999": None, "max": None}
        )
        if self.latency_cycles or last_summary is None:
            latency: dict[str, Any] = dict(self.latency_us)
            latency_source = "timing/cycle"
        else:
            latency = dict(plant_lat)
            latency_source = "timing/summary"
        out: dict[str, Any] = {
            "complete": final is not None,
            "latency_us": latency,
            "latency_cycles": self.latency_cycles,
            "unanswered_cycles": self.unanswered,
            "deadline_us": _deadline_us(self.info),
            "latency_source": latency_source,
            "latency_us_plant": plant_lat,
            "cycles_logged": self.cycles,
        }
        if final is not None:
            out.update(
                cycles=int(final["cycles"]),
                deadline_misses=int(final["deadline_misses"]),
                commands_held=int(final["commands_held"]),
                commands_rejected=int(final["commands_rejected"]),
                commands_late=int(final["commands_late"]),
                safe_state=int(final["safe_state"]),
                safe_state_cycles=int(final.get("safe_state_cycles", 0)),
                faults_injected=int(final.get("faults_injected", 0)),
                sim_seconds_per_wall_second=float(final["sim_seconds_per_wall_second"]),
            )
        else:
            # Crashed run: count what the logged cycles show. Rejected and late commands are
            # not in the cycle record; the last running summary (if any) gives a lower bound.
            speed = math.nan
            if self.cycles >= 2 and self.cycle_first is not None:
                (s0, w0), (s1, w1) = self.cycle_first, self.cycle_last
                if w1 > w0:
                    speed = float((s1 - s0) / (w1 - w0))
            out.update(
                cycles=self.cycles,
                deadline_misses=self.cycle_sums["deadline_missed"],
                commands_held=self.cycle_sums["command_held"],
                commands_rejected=_int_or_none(
                    last_summary.get("commands_rejected") if last_summary else None
                ),
                commands_late=_int_or_none(
                    last_summary.get("commands_late") if last_summary else None
                ),
                safe_state=self.cycle_safe,
                sim_seconds_per_wall_second=speed,
            )
        out["controller_compute_us"] = dict(self.compute_us)
        out.update(self.watchdog.result(_scenario(self.info).get("config"), _period_s(self.info)))
        return out

    def _kpis(self) -> dict[str, Any]:
        k = self.k
        pitch, surge = k["platform_pitch_rad"], k["platform_surge_m"]
        if self.window_truth and not self.pitch_finite:  # a log of PlantState version 1
            pitch = k["platform_pitch_measured_rad"]
        floating = bool(self.window_truth) and self.floating_sum > 0
        pitch_mean = math.degrees(pitch.mean()) if floating else math.nan
        pitch_std = math.degrees(pitch.std()) if floating else math.nan
        dels = {
            n: acc.damage_equivalent_load(SHAFT_WOHLER_M, DEL_N_EQ_HZ)
            for n, acc in self.dels.items()
        }
        return {
            "mean_power_w": k["electrical_power_w"].mean(),
            "rotor_speed_mean_rad_s": k["rotor_speed_rad_s"].mean(),
            "rotor_speed_std_rad_s": k["rotor_speed_rad_s"].std(),
            "pitch_travel_deg_s": self.travel.per_second(),
            "generator_torque_mean_nm": k["generator_torque_nm"].mean(),
            "thrust_mean_n": k["rotor_thrust_n"].mean(),
            "thrust_max_n": k["rotor_thrust_n"].max(),
            "shaft_del_nm": dels["shaft_torque_nm"],
            "tower_base_del_nm": dels["tower_base_moment_nm"],
            "thrust_del_n": dels["rotor_thrust_n"],
            "shaft_del_wohler_m": SHAFT_WOHLER_M,
            "del_n_eq_hz": DEL_N_EQ_HZ,
            "platform_pitch_mean_deg": pitch_mean,
            "platform_pitch_std_deg": pitch_std,
            "surge_mean_m": surge.mean() if floating else math.nan,
            "surge_std_m": surge.std() if floating else math.nan,
            "tower_base_moment_mean_nm": k["tower_base_moment_nm"].mean(),
        }

    def _estimates(self) -> dict[str, Any]:
        nan = math.nan
        est: dict[str, Any] = {
            "wind_speed_error_mean_pct": nan,
            "wind_speed_error_rms_m_s": nan,
            "platform_pitch_rate_error_rms_rad_s": nan,
            "platform_surge_velocity_error_rms_m_s": nan,
            "degraded_fraction": nan,
        }
        fc: dict[str, Any] = {"vaf_pct": nan, "samples": 0}
        faults = self.estimator_faults
        out = {
            "estimator": est,
            "forecast": fc,
            "controller": {
                "compute_us": dict(self.compute_us),
                # estimator divergences the controller detected (ControllerStatus v3; 0 in
                # an older log, which has no such count)
                "estimator_faults": int(faults) if math.isfinite(faults) else 0,
                "estimator_faults_first_s": self.estimator_fault_first_s,
            },
        }
        if not self.w_status or not self.truth_any or not self.w_mask_finite:
            return out  # no estimate, or a log of ControllerStatus version 1
        est["degraded_fraction"] = self.w_degraded / self.w_status
        n, (se, su, see) = self.wind.totals()
        if n:
            est["wind_speed_error_mean_pct"] = float(100.0 * (se / n) / (su / n))
            est["wind_speed_error_rms_m_s"] = math.sqrt(see / n)
        for key, name in (
            ("pr", "platform_pitch_rate_error_rms_rad_s"),
            ("sv", "platform_surge_velocity_error_rms_m_s"),
        ):
            k, (s2,) = self.rms[key].totals()
            if k:
                est[name] = math.sqrt(s2 / k)
        if self.f_ok >= 2:
            fc["samples"] = self.f_ok
            var = self.f_eta.var()
            if var > 0.0:
                fc["vaf_pct"] = float(100.0 * (1.0 - self.f_err.var() / var))
        for key, name in (
            ("unstable_fits", "forecast_unstable_fits"),
            ("guarded", "forecast_guarded"),
        ):
            v = self.f_max[name]
            fc[key] = int(v) if math.isfinite(v) else 0
        return out

    def _run_info(self) -> dict[str, Any]:
        info = self.info
        t_min, t_max = self.t_min, self.t_max
        duration = (t_max - t_min) / 1e9 if t_max >= t_min else math.nan
        out: dict[str, Any] = dict(info.metadata.get("run", {}))
        config = _scenario(info).get("config")
        out.update(
            turbine=_turbine(info.topics),
            duration_s=duration,
            messages={
                _suffix(k): info.counts[k]
                for k in info.topics
                if info.counts[k] or could_have(_suffix(k), config)
            },
            truncated=info.truncated,
            truncated_at_s=(t_max / 1e9 if t_max >= t_min else None) if info.truncated else None,
            statistics_ok=info.statistics_ok,
            error=info.error,
            skipped_ranges=[r.as_dict() for r in info.skipped],
        )
        # The recorder says whether the run's bus was authenticated ("true"/"false"); a file
        # from before that record says nothing (None).
        auth = info.metadata.get("recorder", {}).get("authenticated")
        out["authenticated"] = None if auth is None else auth == "true"
        return out

    def _recording(self) -> dict[str, Any]:
        info = self.info
        recorded = {_suffix(k): info.counts[k] for k in info.topics}
        plant = self.rows["timing/report"]
        level, every = recording_level(info.metadata)
        return completeness(
            recorded,
            plant[-1] if plant else None,
            self.rows["controller/report"],
            self.final_summary is not None,
            order={t: o.as_dict() for t, o in self.order.items() if o.last is not None},
            truth_every=every,
        ) | {"level": level, "truth_every": every}

    def _plant_account(self) -> dict[str, Any]:
        report = _final_record(self.rows["timing/report"])
        if report is not None:
            rejected = _reasons(report, "commands_rejected", PLANT_REJECT_REASONS)
            return {
                "source": "timing/report",
                "report_final": bool(int(report.get("final", 0))),
                "commands_applied": int(report.get("commands_applied", 0)),
                "commands_rejected": rejected,
                "commands_rejected_total": sum(rejected.values()),
            }
        summary = self.final_summary or self.last_summary
        if summary is None:
            return {
                "source": None,
                "commands_applied": None,
                "commands_rejected": None,
                "commands_rejected_total": None,
            }
        return {
            "source": "timing/summary",
            "commands_applied": int(summary.get("cycles", 0))
            - int(summary.get("commands_held", 0)),
            "commands_rejected": None,
            "commands_rejected_total": int(summary.get("commands_rejected", 0)),
        }

    def _controller_account(self) -> dict[str, Any]:
        report = _final_record(self.rows["controller/report"])
        period = _scenario_period_s(self.info)
        if not math.isfinite(period):
            period = rs.median_of_counts(self.cmd_diffs)
        out: dict[str, Any] = {
            "source": "commands",
            "commands": self.commands,
            "safe_mode_entries": self.safe_entries,
            "safe_mode_first_entry_s": self.safe_first_s,
            "safe_mode_commands": self.safe_count,
            "safe_mode_at_end": self.safe_last,
            "frames_missing": None,
            "frames_stale": None,
            "frames_rejected": None,
            "frames_rejected_total": None,
        }
        if self.status_count:
            last = self.last_rejected
            out["frames_rejected_total"] = int(last) if math.isfinite(last) else None
        if report is not None:
            rejected = _reasons(report, "frames_rejected", CONTROLLER_REJECT_REASONS)
            first_ns = int(report.get("safe_mode_first_entry_ns", 0))
            out.update(
                source="controller/report",
                report_final=bool(int(report.get("final", 0))),
                commands=int(report.get("commands_published", self.commands)),
                safe_mode_entries=int(report.get("safe_mode_entries", 0)),
                safe_mode_first_entry_s=first_ns / 1e9
                if int(report.get("safe_mode_entries", 0))
                else None,
                safe_mode_commands=int(report.get("safe_mode_commands", 0)),
                safe_mode_at_end=bool(int(report.get("safe_mode", 0))),
                frames_missing=int(report.get("frames_missing", 0)),
                frames_stale=int(report.get("frames_stale", 0)),
                frames_rejected=rejected,
                frames_rejected_total=sum(rejected.values()),
            )
        out["fault"] = _fault_of(report)
        out["fault_commands"] = self.fault_count
        if report is not None:
            out["fault_commands"] = int(report.get("core_fault_commands", self.fault_count))
        out["cycles_stepped"] = self.cycles_stepped
        out["overruns"] = self.overruns
        n_safe = self.safe_count if self.commands else int(out["safe_mode_commands"])
        out["safe_mode_s"] = n_safe * period if math.isfinite(period) else None
        out["safe_mode_entered"] = bool(out["safe_mode_entries"])
        out["control_period_s"] = period
        return out


def _settle_s(info: RunInfo) -> float:
    """The scenario's ``[review] settle_s`` [s] (:data:`DEFAULT_SETTLE_S` when absent)."""
    return settle_s_of(info.metadata)


def settle_s_of(metadata: Mapping[str, Mapping[str, str]]) -> float:
    """The ``[review] settle_s`` [s] of the scenario in a log's metadata (default when absent)."""
    cfg = _scenario_of(metadata).get("config") or {}
    rv = cfg.get("review") if isinstance(cfg, dict) else None
    if isinstance(rv, dict) and isinstance(rv.get("settle_s"), int | float):
        return float(rv["settle_s"])
    return DEFAULT_SETTLE_S


def _scenario_period_s(info: RunInfo | RunData) -> float:
    """The scenario's control period [s] (nan when absent)."""
    return scenario_period_s(info.metadata)


def summarize_batches(
    batches: Iterable[ColumnBatch],
    info: RunInfo,
    also: Callable[[ColumnBatch], None] | None = None,
) -> dict[str, Any]:
    """The summary of a run given as batches of columns (filled into ``info`` meanwhile).

    Parameters
    ----------
    batches : iterable of ColumnBatch
        :meth:`hil.runlog.columns.ColumnReader.batches` (a file, chunk by chunk) or
        :func:`hil.runlog.columns.run_batches` (a run in memory).
    info : RunInfo
        The run's counts, metadata and reading state; complete once ``batches`` is.
    also : callable, optional
        Gets every batch too (the plots' data, gathered in the same pass).
    """
    acc = _Summary(info)
    for b in batches:
        acc.add(b)
        if also is not None:
            also(b)
    cleaned: dict[str, Any] = _clean(acc.result())
    return cleaned


def summarize(run: RunData) -> dict[str, Any]:
    """Summary of one run from the MCAP contents alone (JSON-ready, nan as None).

    Parameters
    ----------
    run : RunData
        Output of :func:`hil.runlog.mcap_io.read_run` (possibly truncated), or a run in memory.

    Returns
    -------
    dict
        ``{"timing", "kpi", "run", "scenario", ...}``; keys and units in the module
        docstring. The same figures as :func:`review` computes from the file by streaming.
    """
    # The status before the truth of the same cycles: the join keeps the truth from the
    # last status it resolved on (hil.review.stream.TruthJoin).
    batches = run_batches(run, rs.FIELDS, lead=("controller/status",))
    return summarize_batches(batches, run_info(run))


# --------------------------------------------------------------------------- plots


def scenario_period_s(metadata: Mapping[str, Mapping[str, str]]) -> float:
    """The control period [s] of the scenario recorded in a log's metadata (nan when absent)."""
    cfg = _scenario_of(metadata).get("config") or {}
    timing = cfg.get("timing") if isinstance(cfg, dict) else None
    period = timing.get("control_period_s") if isinstance(timing, dict) else None
    return float(period) if isinstance(period, int | float) and period > 0 else math.nan


def run_events(run: RunData) -> dict[str, Any]:
    """What the time-series plot marks: the plant's safe-state and the controller's
    safe-mode windows [s] and the times the feedforward started acting [s].

    The plant's windows come from ``timing/cycle`` ``safe_state``, the controller's from the
    ``command`` channel's ``mode`` (= :data:`MODE_SAFE_COMMAND`). The feedforward acts from
    the first ``controller/status`` whose ``estimates_valid_mask`` has ``EST_FEEDFORWARD``
    and ``EST_WAVE_FORECAST``: the advanced controller sets ``EST_FEEDFORWARD`` from its
    first cycle (its feedforward fields hold a value, 0 until the forecast is valid), so the
    bit alone would put the start at t = 0. It starts again after each gap (a forecaster
    restarted after the safe mode): ``feedforward_starts_s`` lists every start,
    ``feedforward_start_s`` is the first (None: it never acted). Each window runs to its
    last sample plus the control period (:class:`hil.review.plots.Spans`).
    """
    from hil.review import plots  # noqa: PLC0415 - plots import this module

    info = run_info(run)
    return plots.collect(
        run_batches(run, plots.PLOT_FIELDS), info.counts, {}, run.metadata
    ).events()


def write_plots(
    run: RunData, out_dir: Path, summary: Mapping[str, Any] | None = None
) -> list[Path]:
    """The plots of a run in memory (:func:`hil.review.plots.write_plots`); ``summary``
    (None: :func:`summarize`) gives the KPI window and the latency percentiles."""
    from hil.review import plots  # noqa: PLC0415 - plots import this module

    info = run_info(run)
    data = plots.collect(
        run_batches(run, plots.PLOT_FIELDS),
        info.counts,
        summary if summary is not None else summarize(run),
        run.metadata,
    )
    return plots.write_plots(data, out_dir)


def write_plots_of_file(
    mcap_path: Path, info: RunInfo, summary: Mapping[str, Any], out_dir: Path
) -> list[Path]:
    """The plots of a run log read again chunk by chunk (memory bounded: plots module);
    ``info`` and ``summary`` are those of the review's own pass over the file."""
    from hil.review import plots  # noqa: PLC0415 - plots import this module

    reader = ColumnReader(mcap_path, plots.PLOT_FIELDS)
    data = plots.collect(reader.batches(), info.counts, summary, info.metadata)
    return plots.write_plots(data, out_dir)


# --------------------------------------------------------------------------- entry points


def review(
    mcap_path: Path,
    out_dir: Path | None = None,
    plots: bool = True,
    write_summary: bool = True,
    written: list[Path] | None = None,
    worker: PlotWorker | None = None,
) -> dict[str, Any]:
    """Read a run log, write ``summary.json`` (and plots) and return the summary.

    The file is read first: a file that is not an MCAP file raises
    :class:`hil.runlog.mcap_io.NotMcapError`, and an MCAP file that is not a run log of this bench
    :class:`NotRunLogError` (:func:`check_run_log`), before anything is written.

    Parameters
    ----------
    mcap_path : Path
        The run's MCAP file (may be truncated).
    out_dir : Path, optional
        Output folder; defaults to the MCAP file's folder.
    plots : bool
        Also write the PNG plots (:func:`write_plots`).
    write_summary : bool
        Write ``summary.json`` (False: only return the summary).
    written : list of Path, optional
        Gets the path of every file written, in order (all inside ``out_dir``).
    worker : PlotWorker, optional
        A drawing process started with the command
        (:class:`hil.review.plot_worker.PlotWorker`): the turbine plots are drawn there,
        matplotlib already imported. None: drawn here.
    """
    mcap_path = Path(mcap_path)
    out = Path(out_dir) if out_dir is not None else mcap_path.parent
    # One pass over the file chunk by chunk (hil.runlog.columns), the plots' data gathered in
    # it (a second pass for a file cut short); memory does not grow with the run. A platform
    # recording (small) is read whole.
    data = None
    gathering = False  # the plot worker reads the file for the plots' data meanwhile
    if plots:
        from hil.review import plots as plots_mod  # noqa: PLC0415 - plots import this module

        # A complete file says how many messages each topic has (its summary section): the
        # plots' data is gathered beside the review's pass, by the plot worker in a pass of
        # its own when it is ready (hil.review.plot_worker), else in this one. Else a second
        # pass draws them once the summary is known.
        counts = plots_mod.logged_counts(mcap_path)
        if counts is not None and worker is not None and worker.ready():
            gathering = worker.gather(mcap_path, counts)
        if counts is not None and not gathering:
            reader = ColumnReader(mcap_path, plots_mod.with_plot_fields(rs.FIELDS))
            data = plots_mod.PlotData(counts, None, reader.info.metadata)
    if data is None:
        reader = ColumnReader(mcap_path, rs.FIELDS)
    summary = summarize_batches(
        reader.batches(), reader.info, data.feed if data is not None else None
    )
    check_run_log(reader.info, mcap_path)
    family = run_family(reader.info)
    if family not in ("turbine", "hexicon"):
        raise NotRunLogError(
            f"{mcap_path}: a run of plant family {family!r}; this bench reviews the turbine "
            "and hexicon families"
        )
    platform = family == "hexicon"
    run = read_run(mcap_path) if platform else None
    if run is not None:
        from hil.hexicon import review as hexicon_review  # noqa: PLC0415 - platform recordings only

        summary = hexicon_review.summarize(run)
    summary["run"]["source"] = str(mcap_path)
    # A core fault's text, written beside the file by whoever ran the core.
    with_fault_text(summary, read_fault(mcap_path.parent))
    if write_summary or plots:
        out.mkdir(parents=True, exist_ok=True)
    files: list[Path] = []
    if write_summary:
        (out / "summary.json").write_text(
            json.dumps(_clean(summary), indent=2, allow_nan=False) + "\n"
        )
        files.append(out / "summary.json")
    if plots:
        if run is not None:
            from hil.hexicon import review as hexicon_review  # noqa: PLC0415

            files += hexicon_review.write_plots(run, out)
        elif gathering and worker is not None:  # by the plot worker, in its own pass
            files += _finish(worker, summary, out, mcap_path, reader.info)
        elif data is not None:  # gathered in the review's pass
            data.finish(summary)
            files += _draw(data, out, worker)
        else:  # a second pass over the file, chunk by chunk, knowing the summary
            files += write_plots_of_file(mcap_path, reader.info, summary, out)
    if written is not None:
        written.extend(files)
    return summary


def _finish(
    worker: PlotWorker, summary: Mapping[str, Any], out: Path, mcap_path: Path, info: RunInfo
) -> list[Path]:
    """The plots the worker gathered, drawn into ``out`` once it has ``summary``; where it
    is gone (killed from outside), read again and drawn here."""
    from hil.review.plot_worker import PlotWorkerGoneError  # noqa: PLC0415

    with contextlib.suppress(PlotWorkerGoneError):
        return worker.finish(summary, out)
    return write_plots_of_file(mcap_path, info, summary, out)


def _draw(data: Any, out: Path, worker: PlotWorker | None) -> list[Path]:
    """The plots of ``data`` into ``out``: by ``worker`` when there is one and it answers,
    else here (:func:`hil.review.plots.write_plots`)."""
    from hil.review import plots as plots_mod  # noqa: PLC0415
    from hil.review.plot_worker import PlotWorkerGoneError  # noqa: PLC0415

    if worker is not None:
        with contextlib.suppress(PlotWorkerGoneError):
            return worker.draw(data, out)
    return plots_mod.write_plots(data, out)


def run_family(info: RunInfo) -> str:
    """The plant family of a run log (:mod:`hil.families`), which picks its review.

    The ``family`` its launcher recorded in the ``run`` (single turbine) or ``hexicon_run``
    (Hexicon H3) metadata record; for a file from before that key, ``hexicon`` when it has
    a ``hexicon_run`` record naming a platform or a ``fowt/<platform>/platform`` channel
    (:func:`hil.hexicon.review.platform_of`), else ``turbine``.
    """
    for record in ("run", "hexicon_run"):
        family = info.metadata.get(record, {}).get("family")
        if family:
            return str(family)
    meta = info.metadata.get("hexicon_run")
    if meta and meta.get("platform"):
        return "hexicon"
    if any(len(p) == 3 and p[2] == "platform" for p in (t.split("/") for t in info.topics)):
        return "hexicon"
    return "turbine"


def truncation_note(summary: dict[str, Any]) -> str | None:
    """``"truncated at t = 3.27 s (...)"`` for a truncated run log, None for a complete one."""
    run = summary.get("run", {})
    if not run.get("truncated"):
        return None
    damaged = [r for r in run.get("skipped_ranges") or [] if not r.get("to_end")]
    if damaged:
        return _damage_note(damaged, run)
    at = run.get("truncated_at_s")
    where = f"t = {at:.2f} s" if isinstance(at, int | float) else "t = - (no message)"
    why = f" ({run['error']})" if run.get("error") else ""
    return f"truncated at {where}{why}"


def _damage_note(skipped: list[dict[str, Any]], run: dict[str, Any]) -> str:
    """``"damaged: 1 range skipped (bytes 1200-5400, t = 3.10-4.20 s: ...)"``."""
    parts = []
    for r in skipped:
        text = f"bytes {r.get('start')}-{r.get('end')}"
        a, b = r.get("log_start_s"), r.get("log_end_s")
        if isinstance(a, int | float) and isinstance(b, int | float):
            text += f", t = {a:.2f}-{b:.2f} s"
        parts.append(f"{text}: {r.get('reason')}")
    at = run.get("truncated_at_s")
    last = f"; last message at t = {at:.2f} s" if isinstance(at, int | float) else ""
    return f"damaged: {len(skipped)} range(s) skipped ({'; '.join(parts)}){last}"


def _fmt(v: Any, scale: float = 1.0, digits: int = 3) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, int):
        return f"{v}"
    if isinstance(v, float):
        return f"{v * scale:.{digits}g}" if abs(v * scale) < 1e-3 else f"{v * scale:,.{digits}f}"
    return str(v)


def render_summary(summary: dict[str, Any], console: Console) -> None:
    """Print the summary as rich tables: run, KPIs with units, timing."""
    if summary.get("kind") == "hexicon":
        from hil.hexicon.review import render  # noqa: PLC0415

        render(summary, console)
        return
    run = summary.get("run", {})
    scen = summary.get("scenario", {})
    head = Table(title="Run", show_header=False)
    head.add_column("item")
    head.add_column("value")
    head.add_row("scenario", str(scen.get("name") or "-"))
    for k in ("mode", "transport", "turbine"):
        if k in run:
            head.add_row(k, str(run[k]))
    head.add_row("duration", f"{_fmt(run.get('duration_s'), digits=2)} s")
    note = truncation_note(summary)
    head.add_row("truncated", f"[red]yes: {escape(note)}[/red]" if note else "no")
    if run.get("error") and not note:
        head.add_row("reader", f"[yellow]{run['error']}[/yellow]")
    msgs = run.get("messages", {})
    head.add_row("messages", ", ".join(f"{k}: {v}" for k, v in msgs.items()) or "-")
    console.print(head)
    if table_note := table_range_note(summary.get("rotor_table")):
        console.print(f"note: {table_note}", markup=False)
    if run.get("authenticated") is False:
        console.print(
            "[bold yellow]unauthenticated run (--insecure): any local process could join "
            "its bus, command the turbine and write to this recording[/bold yellow]"
        )
    rec = summary.get("recording")
    if isinstance(rec, dict):
        if rec.get("level", "full") != "full":
            console.print(
                f"recording level: {rec['level']} (truth decimated 1:{rec.get('truth_every')})"
            )
        line = escape(f"recording: {describe(rec)}")
        console.print(line if rec.get("complete") else f"[bold red]{line}[/bold red]")

    k = summary.get("kpi", {})
    win = summary.get("kpi_window") or {}
    caption = None
    if isinstance(win.get("from_s"), int | float):
        caption = (
            f"KPIs over t = {_fmt(win['from_s'], digits=1)}-{_fmt(win.get('to_s'), digits=1)} s: "
            f"the first {_fmt(win['from_s'], digits=1)} s (start-up settling, review.settle_s "
            f"= {_fmt(win.get('settle_s'), digits=1)} s"
            + (", shortened to half the run" if win.get("shortened") else "")
            + ") left out; '-': not available (e.g. no platform)"
        )
    t = Table(title="KPIs")
    t.add_column("KPI")
    t.add_column("value", justify="right")
    t.add_column("unit")
    for row in REVIEW_KPIS:  # the one naming of the KPIs (fowt compare and report too)
        if row.console:
            t.add_row(row.label, _fmt(k.get(row.key), row.scale), row.unit)
    console.print(t)
    if caption:
        console.print(caption)

    _render_estimates(summary, console)

    tm = summary.get("timing", {})
    tt = Table(title="Timing" + ("" if tm.get("complete", True) else " (incomplete run)"))
    tt.add_column("quantity")
    tt.add_column("p50", justify="right")
    tt.add_column("p99", justify="right")
    tt.add_column("p99.9", justify="right")
    tt.add_column("max", justify="right")
    tt.add_column("unit")
    lat = tm.get("latency_us", {})
    tt.add_row(
        f"latency ({tm.get('latency_source', '-')})",
        *(_fmt(lat.get(q), digits=1) for q in ("p50", "p99", "p999", "max")),
        "us",
    )
    plat = tm.get("latency_us_plant", {})
    if any(v is not None for v in plat.values()):
        tt.add_row(
            "latency (plant histogram)",
            *(_fmt(plat.get(q), digits=1) for q in ("p50", "p99", "p999", "max")),
            "us",
        )
    cc = tm.get("controller_compute_us", {})
    tt.add_row(
        "controller compute",
        _fmt(cc.get("p50"), digits=1),
        _fmt(cc.get("p99"), digits=1),
        "-",
        _fmt(cc.get("max"), digits=1),
        "us",
    )
    console.print(tt)

    ct = Table(title="Cycle counts")
    ct.add_column("counter")
    ct.add_column("value", justify="right")
    misses = tm.get("deadline_misses")
    ct.add_row("cycles", _fmt(tm.get("cycles")))
    ct.add_row(
        "deadline misses",
        f"[bold red]{misses}[/bold red]" if misses else _fmt(misses),
    )
    for name in (
        "commands_held",
        "commands_rejected",
        "commands_late",
        "safe_state_cycles",
        "faults_injected",
    ):
        v = tm.get(name)
        ct.add_row(name.replace("_", " "), f"[yellow]{v}[/yellow]" if v else _fmt(v))
    trips = tm.get("watchdog_trips")
    if trips:
        ct.add_row("watchdog trips", f"[yellow]{watchdog_text(tm)}[/yellow]")
    safe = safe_state_text(summary)
    ct.add_row("safe state", f"[bold red]{safe}[/bold red]" if safe != "no" else safe)
    ct.add_row("sim s / wall s", _fmt(tm.get("sim_seconds_per_wall_second"), digits=3))
    console.print(ct)
    _render_accounts(summary, console)


def watchdog_text(tm: dict[str, Any]) -> str:
    """The plant watchdog's trips in words: ``"2 (2 recovered, longest 0.15 s; recover)"``."""
    longest = tm.get("safe_state_longest_s")
    span = (
        f"{longest:.3g} s"
        if isinstance(longest, int | float)
        else f"{_fmt(tm.get('safe_state_longest_cycles'))} cycles"
    )
    policy = tm.get("watchdog_policy") or "latch"
    return (
        f"{_fmt(tm.get('watchdog_trips'))} ({_fmt(tm.get('watchdog_recoveries'))} recovered, "
        f"longest {span}; policy {policy})"
    )


def safe_state_text(summary: dict[str, Any]) -> str:
    """``"no"``, or ``"yes: ..."`` naming who entered it: the plant's safe state (its
    watchdog) and/or the controller's safe mode (with its time and first entry)."""
    tm = summary.get("timing") or {}
    ctrl = summary.get("controller") or {}
    parts = []
    if tm.get("safe_state") or tm.get("safe_state_cycles"):
        held = (
            ", held at the end"
            if tm.get("safe_state")
            else (", recovered" if tm.get("watchdog_recoveries") else "")
        )
        parts.append(f"plant safe state ({_fmt(tm.get('safe_state_cycles'))} cycles{held})")
    if ctrl.get("safe_mode_entered"):
        first = ctrl.get("safe_mode_first_entry_s")
        text = f"controller safe mode {_fmt(ctrl.get('safe_mode_s'), digits=2)} s"
        if isinstance(first, int | float):
            text += f" from t = {first:.2f} s"
        if ctrl.get("safe_mode_at_end"):
            text += ", still at the end"
        parts.append(text)
    return "yes: " + "; ".join(parts) if parts else "no"


def _render_accounts(summary: dict[str, Any], console: Console) -> None:
    """The controller's safe mode and rejections, and the plant's commands (nonzero reasons)."""
    ctrl = summary.get("controller") or {}
    plant = summary.get("plant") or {}
    if "source" not in ctrl and "source" not in plant:
        return
    t = Table(title="Controller and plant accounts")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    t.add_column("source")
    src = str(ctrl.get("source") or "-")
    rows: list[tuple[str, Any, str]] = [
        ("controller commands", ctrl.get("commands"), src),
        ("safe mode entries", ctrl.get("safe_mode_entries"), src),
        ("safe mode first entry [s]", ctrl.get("safe_mode_first_entry_s"), src),
        ("safe mode commands", ctrl.get("safe_mode_commands"), src),
        ("time in safe mode [s]", ctrl.get("safe_mode_s"), "commands"),
        ("in safe mode at the end", ctrl.get("safe_mode_at_end"), src),
        ("frames missing", ctrl.get("frames_missing"), src),
        ("frames stale", ctrl.get("frames_stale"), src),
        ("frames rejected", ctrl.get("frames_rejected_total"), src),
        ("estimator faults", ctrl.get("estimator_faults"), "controller/status"),
        ("estimator fault first [s]", ctrl.get("estimator_faults_first_s"), "controller/status"),
    ]
    for reason, n in (ctrl.get("frames_rejected") or {}).items():
        if n:
            rows.append((f"  frames rejected: {reason}", n, src))
    fault = ctrl.get("fault")
    if isinstance(fault, dict) and fault.get("kind"):
        rows.append(("core fault", fault_line(fault).removeprefix("controller "), src))
        rows.append(("commands flagged as faulted", ctrl.get("fault_commands"), src))
    if ctrl.get("overruns"):
        rows.append(("steps over the control period", ctrl.get("overruns"), "controller/status"))
    psrc = str(plant.get("source") or "-")
    rows += [
        ("plant commands applied", plant.get("commands_applied"), psrc),
        ("plant commands rejected", plant.get("commands_rejected_total"), psrc),
    ]
    for reason, n in (plant.get("commands_rejected") or {}).items():
        if n:
            rows.append((f"  commands rejected: {reason}", n, psrc))
    for name, v, where in rows:
        text = _fmt(v, digits=2)
        if v and ("safe mode" in name or "rejected" in name or "fault" in name or "over" in name):
            text = f"[yellow]{text}[/yellow]"
        t.add_row(escape(name), text, where)
    console.print(t)


def _render_estimates(summary: dict[str, Any], console: Console) -> None:
    """The estimator and forecast tables (advanced controllers; nothing for the baseline)."""
    est = summary.get("estimator") or {}
    fc = summary.get("forecast") or {}
    errors = [v for k, v in est.items() if k != "degraded_fraction"]
    if all(v is None for v in errors) and not fc.get("samples"):
        return  # no estimate published (the baseline controller)
    t = Table(title="Estimator and wave forecast (against the truth, KPI window)")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    t.add_column("unit")
    for name, key, unit in (
        ("wind speed error, mean", "wind_speed_error_mean_pct", "%"),
        ("wind speed error, RMS", "wind_speed_error_rms_m_s", "m/s"),
        ("platform pitch rate error, RMS", "platform_pitch_rate_error_rms_rad_s", "rad/s"),
        ("platform surge velocity error, RMS", "platform_surge_velocity_error_rms_m_s", "m/s"),
        ("estimator degraded", "degraded_fraction", "fraction of cycles"),
    ):
        t.add_row(name, _fmt(est.get(key)), unit)
    vaf = fc.get("vaf_pct")
    t.add_row(
        "wave forecast VAF",
        _fmt(vaf, digits=1) if fc.get("samples") else "- (no valid forecast)",
        "%",
    )
    t.add_row("wave forecasts compared", _fmt(fc.get("samples")), "[1]")
    console.print(t)


__all__ = [
    "PLOT_FILES",
    "NotRunLogError",
    "check_run_log",
    "render_summary",
    "review",
    "review_problems",
    "summarize",
    "write_plots",
]
