"""Review of a Hexicon H3 recording (``fowt review runs/<run>/run.mcap``).

:func:`hil.review.core.review` hands a file to :func:`summarize` when the file's plant family
is ``hexicon`` (:func:`hil.review.core.run_family`: the ``family`` the launcher recorded in
the ``hexicon_run`` metadata; for older files that record or a ``fowt/<platform>/platform``
channel). Everything comes from the MCAP file alone, through
the same reader (:func:`hil.runlog.mcap_io.read_run`, truncated files included) as a turbine run.

Summary keys (``kind`` = ``"hexicon"``; ``null`` where a channel was missing)
--------------------------------------------------------------------------------
``run``: the recorder's metadata (``kind`` run or identification, scenario, controller,
mode, transport, sensor seed) plus ``duration_s``, ``messages`` per topic, ``truncated``.
``kpi`` (:func:`hil.hexicon.model.compute_kpis` on the truth keys): ``heading_rms_deg``,
``overshoot_deg``, ``settling_time_s`` (|e| <= 1° from then on), ``final_error_deg``,
``energy_ratio`` (∫P / ∫P_wake-free), ``power_mean_w``, ``wake_free_power_mean_w``,
``pitch_travel_deg`` (Σ|Δθ| of the true pitch), ``constraint_violations`` (commanded pitch
outside [θ_r(V), 25°]), ``solve_p99_ms`` and ``overruns`` (MPC).
``timing``: ``latency_us.{p50,p99,max}`` [us] from the measured platform frame's publish
time to the last of the three commands answering it (one clock: CLOCK_MONOTONIC is
system-wide), ``cycles``, ``deadline_misses``, ``commands_held``, ``commands_late``,
``commands_rejected`` (plant summary; in real time a miss is a cycle whose three commands
were not all in within the period of the frame's publication, the latency above:
:func:`hil.hexicon.nodes.gather_commands`), ``controller_compute_us.{p50,p99,max}`` (status
``compute_time_ns``), ``deadline_us`` (the control period).
``recording``: ``complete`` and ``problems`` (:func:`recording_check`), which the run's
exit code is judged on (:func:`hil.review.outcome.run_outcome`, docs/exit-codes.md).
Plots (``hexicon.png``): heading and wind direction, heading error, per-turbine pitch
(commanded and true) with the pitch floor, platform power against the wake-free power.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from hil.hexicon.model import RunLog, compute_kpis, load_scenarios, wake_free_power_w
from hil.runlog.mcap_io import RunData

PLOT_FILE = "hexicon.png"
TURBINES = ("t1", "t2", "t3")


def platform_of(run: RunData) -> str | None:
    """The platform id of a platform recording (None: not one)."""
    meta = run.metadata.get("hexicon_run")
    if meta and meta.get("platform"):
        return meta["platform"]
    for topic in run.messages:
        parts = topic.split("/")
        if len(parts) == 3 and parts[2] == "platform":
            return parts[1]
    return None


def is_platform_run(run: RunData) -> bool:
    """Whether ``run`` is a recording of the multi-turbine platform family."""
    return platform_of(run) is not None


def run_log(messages: dict[str, list[dict[str, Any]]], platform: str = "h3") -> RunLog:
    """The per-period record of the truth keys and the commands (as the in-process run's).

    Falls back to the measured keys for a recording without truth twins.
    """
    pre = f"fowt/{platform}"
    frames = messages.get(f"{pre}/platform/truth") or messages.get(f"{pre}/platform", [])
    frames = [f for f in frames if not f.get("final")]
    measured = {f["seq"]: f for f in messages.get(f"{pre}/platform", [])}
    rot = [
        messages.get(f"{pre}/{t}/rotor/truth") or messages.get(f"{pre}/{t}/rotor", [])
        for t in TURBINES
    ]
    cmds = [
        {c["answered_seq"]: c for c in messages.get(f"{pre}/{t}/rotor/command", [])}
        for t in TURBINES
    ]
    rot_by = [{r["seq"]: r for r in rr} for rr in rot]
    status = {s["answered_seq"]: s for s in messages.get(f"{pre}/platform/status", [])}
    log = RunLog()
    for f in frames:
        k = f["seq"]
        if not all(k in c for c in cmds) or not all(k in r for r in rot_by):
            continue
        log.t.append(f["sample_time_ns"] / 1e9)
        log.heading.append(f["platform_heading_measured_rad"])
        log.yaw_rate.append(f["platform_yaw_rate_measured_rad_s"])
        log.direction.append(f["wind_direction_measured_rad"])
        log.speed.append(f["wind_speed_measured_m_s"])
        if k in measured:
            log.speed_measured.append(measured[k]["wind_speed_measured_m_s"])
        log.power.append(f["platform_power_w"])
        log.pitch_cmd.append(tuple(c[k]["blade_pitch_commanded_rad"] for c in cmds))
        log.pitch.append(tuple(r[k]["blade_pitch_measured_rad"] for r in rot_by))
        log.solve_s.append(status[k]["solve_time_s"] if k in status else 0.0)
    if status:
        log.overruns = int(max(s["overruns"] for s in status.values()))
    return log


def _pct(x: list[float]) -> dict[str, float | None]:
    if not x:
        return {"p50": None, "p99": None, "max": None}
    a = np.asarray(x, dtype=float)
    return {
        "p50": float(np.percentile(a, 50)),
        "p99": float(np.percentile(a, 99)),
        "max": float(np.max(a)),
    }


def _num(meta: dict[str, str], key: str) -> int | None:
    try:
        return int(meta[key])
    except (KeyError, ValueError):
        return None


def summarize(run: RunData) -> dict[str, Any]:
    """The review summary of a platform recording (module docstring)."""
    platform = platform_of(run) or "h3"
    meta = dict(run.metadata.get("hexicon_run", {}))
    pre = f"fowt/{platform}"
    log = run_log(run.messages, platform)
    scen_name = meta.get("scenario", "")
    scenarios = load_scenarios()
    kpi: dict[str, Any] = {}
    if log.t and scen_name in scenarios:
        scn = scenarios[scen_name]
        kpi = compute_kpis(log, scn)
        p = scn.params()
        kpi["power_mean_w"] = float(np.mean(log.power))
        kpi["wake_free_power_mean_w"] = float(np.mean([wake_free_power_w(p, v) for v in log.speed]))
    frames = {f["seq"]: f for f in run.messages.get(f"{pre}/platform", [])}
    cmds = [run.messages.get(f"{pre}/{t}/rotor/command", []) for t in TURBINES]
    last_cmd: dict[int, int] = {}
    for cc in cmds:
        for c in cc:
            k = c["answered_seq"]
            last_cmd[k] = max(last_cmd.get(k, 0), int(c["publish_time_ns"]))
    lat = [
        (t_cmd - int(frames[k]["publish_time_ns"])) / 1e3
        for k, t_cmd in last_cmd.items()
        if k in frames
    ]
    status = run.messages.get(f"{pre}/platform/status", [])
    period = float(meta.get("control_period_s", "1.0"))
    timing = {
        "latency_us": _pct(lat),
        "latency_cycles": len(lat),
        "cycles": _num(meta, "plant_cycles"),
        "deadline_misses": _num(meta, "deadline_misses"),
        "commands_held": _num(meta, "commands_held"),
        "commands_late": _num(meta, "commands_late"),
        "commands_rejected": _num(meta, "commands_rejected"),
        "deadline_us": period * 1e6,
        "controller_compute_us": _pct([s["compute_time_ns"] / 1e3 for s in status]),
    }
    recording = recording_check(meta, len(log.t))
    times = [m["sample_time_ns"] for msgs in run.messages.values() for m in msgs if m]
    info: dict[str, Any] = dict(meta)
    info.update(
        {
            "platform": platform,
            "duration_s": (max(times) - min(times)) / 1e9 if times else None,
            "messages": {t: len(m) for t, m in run.messages.items() if m},
            "truncated": run.truncated,
            "error": run.error,
            "statistics_ok": run.statistics_ok,
        }
    )
    return {
        "kind": "hexicon",
        "run": info,
        "scenario": {"name": scen_name or None},
        "kpi": {
            k: (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in kpi.items()
        },
        "timing": timing,
        "recording": recording,
    }


def recording_check(meta: dict[str, str], cycles_recorded: int) -> dict[str, Any]:
    """Whether the recording holds the whole run (``recording`` of the summary).

    ``complete`` is false, with one sentence per problem in ``problems``, when the plant's
    final frame was not recorded (``final_seen``), the plant's account is missing (it did
    not finish: killed or stopped), fewer cycles have their frames and three commands than
    the plant ran (``plant_cycles``), or the recorder rejected messages. A file from before
    these keys were recorded is judged on those it has.
    """
    problems: list[str] = []
    if meta.get("final_seen", "True") != "True":
        problems.append("no final platform frame: the plant did not finish the run")
    if "plant_cycles" not in meta:
        problems.append("no plant account: the plant did not finish the run")
    else:
        cycles = _num(meta, "plant_cycles") or 0
        if cycles_recorded < cycles:
            problems.append(
                f"{cycles - cycles_recorded} of {cycles} cycles lack a frame or a command"
            )
    if meta.get("stopped") == "True":
        problems.append("the plant was stopped before the run's end")
    rejected = _num(meta, "recorder_rejected") or 0
    if rejected:
        problems.append(f"the recorder rejected {rejected} messages")
    return {"complete": not problems, "problems": problems}


def write_plots(run: RunData, out_dir: Path) -> list[Path]:
    """``hexicon.png``: heading/wind direction, heading error, per-turbine pitch, power."""
    import matplotlib  # noqa: PLC0415 - plotting only

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    platform = platform_of(run) or "h3"
    log = run_log(run.messages, platform)
    meta = run.metadata.get("hexicon_run", {})
    scenarios = load_scenarios()
    fig, axes = plt.subplots(4, 1, figsize=(10, 11), sharex=True)
    t = np.asarray(log.t)
    path = out_dir / PLOT_FILE
    if t.size:
        hd, wd = np.degrees(log.heading), np.degrees(log.direction)
        axes[0].plot(t, wd, label="wind direction (met, true)")
        axes[0].plot(t, hd, label="platform heading (true)")
        axes[0].set_ylabel("[deg]")
        axes[0].legend(loc="best", fontsize="small")
        err = np.degrees(
            np.arctan2(
                np.sin(np.subtract(log.direction, log.heading)),
                np.cos(np.subtract(log.direction, log.heading)),
            )
        )
        axes[1].plot(t, err, color="k")
        axes[1].axhspan(-1.0, 1.0, color="g", alpha=0.15, label="±1° (settling band)")
        axes[1].set_ylabel("heading error\n[deg]")
        axes[1].legend(loc="best", fontsize="small")
        pc, pt = np.degrees(np.asarray(log.pitch_cmd)), np.degrees(np.asarray(log.pitch))
        for i in range(3):
            (line,) = axes[2].plot(t, pt[:, i], label=f"turbine {i + 1}")
            axes[2].plot(t, pc[:, i], ls=":", color=line.get_color())
        scn = scenarios.get(meta.get("scenario", ""))
        if scn is not None:
            from controller.hexicon import load_design  # noqa: PLC0415

            d = load_design()
            axes[2].plot(
                t,
                [math.degrees(d.rated_pitch_rad(v)) for v in log.speed],
                "k--",
                lw=0.8,
                label="floor θ_r(V)",
            )
            p = scn.params()
            axes[3].plot(
                t, [wake_free_power_w(p, v) / 1e6 for v in log.speed], "k--", label="wake-free"
            )
        axes[2].set_ylabel("pitch (true; dotted: demand)\n[deg]")
        axes[2].legend(loc="best", fontsize="small")
        axes[3].plot(t, np.asarray(log.power) / 1e6, label="platform (true)")
        axes[3].set_ylabel("power [MW]")
        axes[3].legend(loc="best", fontsize="small")
    else:
        for ax in axes:
            ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(
        f"{meta.get('kind', 'run')} {meta.get('scenario', '')} {meta.get('controller', '')} "
        f"({meta.get('mode', '')}, {meta.get('transport', 'zenoh')})",
        fontsize="medium",
    )
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return [path]


def render(summary: dict[str, Any], console: Any) -> None:
    """Print a platform review as rich tables."""
    from rich.markup import escape  # noqa: PLC0415
    from rich.table import Table  # noqa: PLC0415

    run = summary["run"]
    head = Table(title="Platform run", show_header=False)
    head.add_column("item")
    head.add_column("value")
    for k in (
        "family",
        "kind",
        "scenario",
        "controller",
        "mode",
        "transport",
        "experiment",
        "sensor_seed",
    ):
        if k in run:
            head.add_row(k, str(run[k]))
    head.add_row("duration", f"{run.get('duration_s')} s")
    head.add_row("truncated", "yes" if run.get("truncated") else "no")
    rec = summary.get("recording", {})
    head.add_row(
        "recording", "complete" if rec.get("complete", True) else "; ".join(rec["problems"])
    )
    console.print(head)
    kpi = summary.get("kpi") or {}
    t = Table(title="KPIs")
    t.add_column("KPI")
    t.add_column("value", justify="right")
    t.add_column("unit")
    listed = set()
    for key, label, scale, unit in KPI_ROWS:
        if key in kpi:
            listed.add(key)
            t.add_row(label, _value(kpi[key], scale), unit)
    for key, value in kpi.items():  # a KPI this table does not know yet: as it is
        if key not in listed:
            t.add_row(key, _value(value, 1.0), "")
    console.print(t)
    timing = summary.get("timing") or {}
    tm = Table(title="Timing")
    tm.add_column("quantity")
    for col in ("p50", "p99", "max"):
        tm.add_column(col, justify="right")
    tm.add_column("unit")
    for key, label in (
        ("latency_us", "latency (frame to the last of 3 commands)"),
        ("controller_compute_us", "controller compute"),
    ):
        stats = timing.get(key) or {}
        tm.add_row(label, *(_value(stats.get(c), 1e-3) for c in ("p50", "p99", "max")), "ms")
    console.print(tm)
    counts = Table(title="Cycle counts")
    counts.add_column("counter")
    counts.add_column("value", justify="right")
    for key, label in (
        ("cycles", "cycles"),
        ("latency_cycles", "cycles with a latency"),
        ("deadline_misses", "deadline misses"),
        ("commands_held", "commands held"),
        ("commands_late", "commands late"),
        ("commands_rejected", "commands rejected"),
    ):
        if key in timing:
            counts.add_row(label, "-" if timing[key] is None else str(timing[key]))
    deadline = timing.get("deadline_us")
    if isinstance(deadline, int | float):
        counts.add_row(escape("deadline [s]"), f"{deadline / 1e6:g}")
    console.print(counts)


#: The KPI table's rows: (summary key, label, scale to the unit shown, unit).
KPI_ROWS: tuple[tuple[str, str, float, str], ...] = (
    ("heading_rms_deg", "heading error RMS", 1.0, "deg"),
    ("heading_max_abs_deg", "heading error max |e|", 1.0, "deg"),
    ("overshoot_deg", "overshoot", 1.0, "deg"),
    ("settling_time_s", "settling time (|e| <= 1 deg)", 1.0, "s"),
    ("final_error_deg", "final heading error", 1.0, "deg"),
    ("energy_ratio", "energy / wake-free energy", 1.0, "[1]"),
    ("power_mean_w", "platform power mean", 1e-6, "MW"),
    ("wake_free_power_mean_w", "wake-free power mean", 1e-6, "MW"),
    ("pitch_travel_deg", "pitch travel Σ|Δθ|", 1.0, "deg"),
    ("constraint_violations", "pitch constraint violations", 1.0, "cycles"),
    ("solve_p99_ms", "MPC solve time p99", 1.0, "ms"),
    ("overruns", "MPC overruns", 1.0, "[1]"),
)


def _value(value: Any, scale: float) -> str:
    """A KPI's value in its unit (``-``: not available)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return "-"
    return f"{value * scale:.4g}"
