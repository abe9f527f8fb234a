"""Benchmark 3: in-process runs (no bus), 600 simulated seconds.

Prints and saves simulated seconds per wall second of the plant-controller loop (issue 2's
target: >= 500x on a 2-core machine) and the wall time of the whole command (MCAP writing
and review included), for the foundation's bottom-fixed NREL 5 MW at 100 Hz and for the
default floating scenario at the deck's 40 Hz.

    python bench/inprocess_speed.py [--duration 600] [--only NAME]
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
        s = run_fowt(str(scenario_variant(scenario, period, step)), "inprocess", args.duration)
        speed = s["timing"]["sim_seconds_per_wall_second"]
        results[name] = {
            "scenario": scenario,
            "control_rate_hz": round(1.0 / period),
            "duration_s": args.duration,
            "sim_seconds_per_wall_second": speed,
            "cycle_wall_us": 1e6 * period / speed if speed else None,
            "whole_command_wall_s": s["bench_command_wall_s"],
            "met": speed is not None and speed >= 500,
        }
        print(name, results[name])
    save("inprocess_speed", {"target": 500, "runs": results})


if __name__ == "__main__":
    main()
