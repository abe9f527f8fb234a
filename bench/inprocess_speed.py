"""Benchmark 3: in-process run (no bus) of 600 simulated seconds.

Prints and saves simulated seconds per wall second of the plant-controller loop (target
>= 500x on a 2-core machine), and the same for the whole command (MCAP writing included).

    python bench/inprocess_speed.py [--duration 600]
"""

from __future__ import annotations

import argparse

from _common import run_fowt, save


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--scenario", default="default")
    args = ap.parse_args()
    s = run_fowt(args.scenario, "inprocess", args.duration)
    speed = s["timing"]["sim_seconds_per_wall_second"]
    save(
        "inprocess_speed",
        {
            "scenario": args.scenario,
            "duration_s": args.duration,
            "sim_seconds_per_wall_second": speed,
            "whole_command_wall_s": s["bench_command_wall_s"],
            "target": 500,
            "met": speed is not None and speed >= 500,
        },
    )


if __name__ == "__main__":
    main()
