"""Benchmark 2: lock-step runs over Zenoh (separate processes) against raw zenoh-python.

For each configuration, in one run of this script: a raw zenoh-python ping-pong between two
processes (``bench/_zenoh_pingpong.py``: the bench's Zenoh config, the encoded SensorFrame's
size one way and the ActuatorCommand's back, no bench code in the loop), then ``fowt run
SCENARIO --mode lockstep`` (plant, controller and recorder as separate processes), then the
ping-pong again (the reference is the mean of the two, so a change of the machine's load
during the run shows as their spread). Prints and saves:

* ``sim_seconds_per_wall_second`` (target >= 50 at 40 Hz) and the cycle's wall time;
* ``cycle_over_raw_rtt``: the lock-step cycle's mean wall time / the raw round trip's mean
  (the target <= 1.25);
* the plant's own profile of its cycles (its log line ``plant lock-step cycle profile``):
  ``sample`` (truth and sensor frame, their encoding, the frame's put), ``wait`` (until the
  command is in the plant's hands: round trip plus the controller's turn), ``finish``
  (applying the command and integrating), and the controller's compute per cycle (from the
  MCAP's controller status, mean), so the exchange can be told from the compute:
  ``exchange_us`` = wait + sensor put - controller compute, and
  ``exchange_over_raw_rtt`` = exchange / raw round trip (means).

Beside the plain ping-pong, a raw ping-pong with a passive third peer subscribed to both
keys (as the recorder is; ``_zenoh_pingpong.measure(observer=True)``) is measured before
and after too, and the cycle and exchange are also given over it (``..._with_observer``):
an additional reference, not the target's.

``--rounds N`` runs each configuration N times (figures: means over the rounds, each
round under ``runs``); ``--compare-python PY --compare-root DIR`` runs another checkout
(e.g. main) alternating with this checkout's runs (``_common.alternate``), so both meet the
same load, and
reports its figures under ``compare`` and ``speedup_over_compare``.

The machine's load average is saved beside the figures (the bench machine is shared).

    python bench/lockstep_speed.py [--duration 600] [--only NAME] [--count 20000]
                                   [--realtime-priority 20] [--rounds 1]
                                   [--compare-python PY --compare-root DIR]
"""

from __future__ import annotations

import argparse
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
from _common import add_compare_args, alternate, codes, run_fowt, save
from _zenoh_pingpong import measure

CONFIGS: dict[str, str] = {
    "lc2-baseline-40hz": "iea15mw-lc2",
    "lc2-lqri-ff-40hz": "iea15mw-lc2-lqri-ff",
}

_PROFILE = re.compile(
    r"plant lock-step cycle profile \((\d+) cycles, mean us per cycle\): sample ([\d.]+) "
    r"\(of which sensor put ([\d.]+)\), wait ([\d.]+), finish ([\d.]+)"
)


def _inspect(run_dir: Path) -> dict[str, Any]:
    """The plant's cycle profile (its log) and the controller's compute (the MCAP)."""
    from hil.runlog.mcap_io import read_run

    out: dict[str, Any] = {}
    m = _PROFILE.search((run_dir / "logs" / "plant.log").read_text(errors="replace"))
    if m:
        out["plant_profile_us"] = {
            "cycles": int(m.group(1)),
            "sample": float(m.group(2)),
            "sensor_put": float(m.group(3)),
            "wait": float(m.group(4)),
            "finish": float(m.group(5)),
        }
    run = read_run(run_dir / "run.mcap")
    status = run.topic("controller/status")
    cycles = run.topic("timing/cycle")
    if status:
        c = np.array([m["compute_time_ns"] for m in status], dtype=float) / 1e3
        out["controller_compute_us"] = {"mean": float(c.mean()), "p50": float(np.median(c))}
    if cycles:
        p = np.array([m["plant_compute_ns"] for m in cycles], dtype=float) / 1e3
        out["plant_finish_compute_us"] = {"mean": float(p.mean()), "p50": float(np.median(p))}
    return out


def _figures(s: dict[str, Any], raw_mean: float, raw_obs_mean: float) -> dict[str, Any]:
    """One lock-step run's figures against the raw round trips (means)."""
    t = s["timing"]
    speed = t["sim_seconds_per_wall_second"]
    period = s["scenario"]["config"]["timing"]["control_period_s"]
    cycle_us = 1e6 * period / speed if speed else None
    insp = s.get("bench_inspect", {})
    prof = insp.get("plant_profile_us")
    ctrl = insp.get("controller_compute_us", {}).get("mean")
    exchange = None
    if prof and ctrl is not None:
        exchange = prof["wait"] + prof["sensor_put"] - ctrl
    return {
        "control_rate_hz": round(1.0 / period),
        "sim_seconds_per_wall_second": speed,
        "met_speed_50x": speed is not None and speed >= 50,
        "cycle_wall_us": cycle_us,
        "cycle_over_raw_rtt": cycle_us / raw_mean if cycle_us else None,
        "cycle_over_raw_rtt_with_observer": cycle_us / raw_obs_mean if cycle_us else None,
        "met_cycle_1_25": cycle_us is not None and cycle_us / raw_mean <= 1.25,
        "plant_profile_us": prof,
        "controller_compute_us": insp.get("controller_compute_us"),
        "plant_finish_compute_us": insp.get("plant_finish_compute_us"),
        "exchange_us": exchange,
        "exchange_over_raw_rtt": exchange / raw_mean if exchange is not None else None,
        "exchange_over_raw_rtt_with_observer": (
            exchange / raw_obs_mean if exchange is not None else None
        ),
        "latency_us": t["latency_us"],
        "whole_command_wall_s": s["bench_command_wall_s"],
    }


def _mean(runs: list[dict[str, Any]], key: str) -> float | None:
    vals = [r[key] for r in runs if r.get(key) is not None]
    return float(np.mean(vals)) if vals else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--only", choices=sorted(CONFIGS), default=None)
    ap.add_argument("--count", type=int, default=20000, help="raw ping-pong round trips")
    ap.add_argument(
        "--realtime-priority",
        type=int,
        default=0,
        help="SCHED_FIFO for plant and controller, and for both ping-pong processes",
    )
    ap.add_argument("--rounds", type=int, default=1, help="lock-step runs per configuration")
    add_compare_args(ap)
    args = ap.parse_args()
    sides = codes(args)
    prio = args.realtime_priority
    rt = ["--realtime-priority", str(prio)] if prio else []
    results: dict[str, Any] = {}
    for name, scenario in CONFIGS.items():
        if args.only and name != args.only:
            continue
        load_before = os.getloadavg()
        raw_before = measure(count=args.count, priority=prio)
        obs_before = measure(count=args.count, priority=prio, observer=True)
        summaries: dict[str, list[dict[str, Any]]] = {side: [] for side in sides}
        for _k, side in alternate(list(sides), args.rounds):
            code = sides[side]
            summary = run_fowt(
                scenario, "lockstep", args.duration, rt, _inspect, code.python, code.root
            )
            summaries[side].append(summary)
        this, other = summaries["this"], summaries.get("compare", [])
        raw_after = measure(count=args.count, priority=prio)
        obs_after = measure(count=args.count, priority=prio, observer=True)
        raw_mean = 0.5 * (raw_before["round_trip_us"]["mean"] + raw_after["round_trip_us"]["mean"])
        raw_p50 = 0.5 * (raw_before["round_trip_us"]["p50"] + raw_after["round_trip_us"]["p50"])
        obs_mean = 0.5 * (obs_before["round_trip_us"]["mean"] + obs_after["round_trip_us"]["mean"])
        runs = [_figures(s, raw_mean, obs_mean) for s in this]
        res: dict[str, Any] = {
            "scenario": scenario,
            "duration_s": args.duration,
            "realtime_priority": prio,
            "rounds": args.rounds,
            **{k: _mean(runs, k) for k in runs[0] if isinstance(runs[0][k], float)},
            "met_speed_50x": all(r["met_speed_50x"] for r in runs),
            "met_cycle_1_25": all(r["met_cycle_1_25"] for r in runs),
            "raw_round_trip_us_mean": raw_mean,
            "raw_round_trip_us_p50": raw_p50,
            "raw_with_observer_round_trip_us_mean": obs_mean,
            "runs": runs,
        }
        if other:
            cmp_runs = [_figures(s, raw_mean, obs_mean) for s in other]
            res["compare"] = {
                **sides["compare"].info(),
                "sim_seconds_per_wall_second": _mean(cmp_runs, "sim_seconds_per_wall_second"),
                "cycle_wall_us": _mean(cmp_runs, "cycle_wall_us"),
                "cycle_over_raw_rtt": _mean(cmp_runs, "cycle_over_raw_rtt"),
                "exchange_us": _mean(cmp_runs, "exchange_us"),
                "runs": cmp_runs,
            }
            res["speedup_over_compare"] = (
                res["sim_seconds_per_wall_second"] / res["compare"]["sim_seconds_per_wall_second"]
            )
        res.update(
            raw_before=raw_before,
            raw_after=raw_after,
            raw_with_observer_before=obs_before,
            raw_with_observer_after=obs_after,
            loadavg_before=load_before,
            loadavg_after=os.getloadavg(),
        )
        results[name] = res
        print(
            name,
            {k: v for k, v in res.items() if not k.startswith("raw_") and k != "runs"},
            flush=True,
        )
    save(
        "lockstep_speed" + (f"_rt{prio}" if prio else ""),
        {
            "targets": {"sim_seconds_per_wall_second": 50, "cycle_over_raw_rtt": 1.25},
            "runs": results,
        },
    )


if __name__ == "__main__":
    main()
