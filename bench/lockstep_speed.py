"""Benchmark 2: lock-step runs over Zenoh (separate processes), 600 simulated seconds.

Prints and saves simulated seconds per wall second (issue 2's target: >= 50x on a 2-core
machine) for the foundation's bottom-fixed NREL 5 MW at 100 Hz and for the default floating
scenario at the deck's 40 Hz. A lock-step cycle costs one Zenoh round trip between two Python
processes plus both sides' work, so the figure scales with the control rate.

    python bench/lockstep_speed.py [--duration 600] [--only NAME]
"""

from __future__ import annotations

import argparse
from typing import Any

from _common import run_fowt, save, scenario_variant

CONFIGS: dict[str, tuple[str, float, float]] = {
    "foundation-100hz": ("nrel5mw-ramp", 0.01, 0.01),
    "floating-40hz": ("default", 0.025, 0.0125),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--only", choices=sorted(CONFIGS), default=None)
    args = ap.parse_args()
    results: dict[str, Any] = {}
    for name, (scenario, period, step) in CONFIGS.items():
        if args.only and name != args.only:
            continue
        s = run_fowt(str(scenario_variant(scenario, period, step)), "lockstep", args.duration)
        t = s["timing"]
        speed = t["sim_seconds_per_wall_second"]
        results[name] = {
            "scenario": scenario,
            "control_rate_hz": round(1.0 / period),
            "duration_s": args.duration,
            "sim_seconds_per_wall_second": speed,
            "cycle_wall_us": 1e6 * period / speed if speed else None,
            "round_trip_us": t["latency_us"],
            "whole_command_wall_s": s["bench_command_wall_s"],
            "met": speed is not None and speed >= 50,
        }
        print(name, results[name])
    save("lockstep_speed", {"target": 50, "runs": results})


if __name__ == "__main__":
    main()
