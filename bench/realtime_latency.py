"""Benchmark 1: real-time runs over Zenoh, plant, controller and recorder as separate processes.

For each configuration, prints and saves sensor-to-command latency p50/p99/p99.9/max,
deadline misses and the controller's compute time per cycle. Configurations:

* ``foundation-100hz``: the foundation's bottom-fixed NREL 5 MW ramp at 100 Hz (issue 2's
  target: 0 misses, p99 <= 2 ms);
* ``floating-40hz`` and ``floating-100hz``: the default floating scenario (IEA 15 MW on
  VolturnUS-S, load case 2) at the deck's 40 Hz and at 100 Hz.

    python bench/realtime_latency.py [--duration 60] [--only NAME]
"""

from __future__ import annotations

import argparse
from typing import Any

from _common import run_fowt, save, scenario_variant

CONFIGS: dict[str, tuple[str, float, float | None]] = {
    # name: (shipped scenario, control period s, plant step s or None = as shipped ratio)
    "foundation-100hz": ("nrel5mw-ramp", 0.01, 0.01),
    "floating-40hz": ("default", 0.025, 0.0125),
    "floating-100hz": ("default", 0.01, 0.01),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--only", choices=sorted(CONFIGS), default=None)
    ap.add_argument(
        "--realtime-priority", type=int, default=0, help="SCHED_FIFO for plant and controller"
    )
    args = ap.parse_args()
    rt = ["--realtime-priority", str(args.realtime_priority)] if args.realtime_priority else []
    results: dict[str, Any] = {}
    for name, (scenario, period, step) in CONFIGS.items():
        if args.only and name != args.only:
            continue
        path = scenario_variant(scenario, period, step)
        s = run_fowt(str(path), "realtime", args.duration, rt)
        t = s["timing"]
        results[name] = {
            "scenario": scenario,
            "control_rate_hz": round(1.0 / period),
            "duration_s": args.duration,
            "realtime_priority": args.realtime_priority,
            "latency_us": t["latency_us"],
            "deadline_misses": t["deadline_misses"],
            "cycles": t["cycles"],
            "controller_compute_us": t.get("controller_compute_us"),
            # p99 is null when over 1 % of the cycles got no command (unbounded latency)
            "met": t["deadline_misses"] == 0
            and t["latency_us"]["p99"] is not None
            and t["latency_us"]["p99"] <= 2000,
        }
        print(name, results[name])
    save(
        "realtime_latency",
        {"targets": {"deadline_misses": 0, "latency_p99_us_max": 2000}, "runs": results},
    )


if __name__ == "__main__":
    main()
