"""Benchmark 2: lock-step run of 600 simulated seconds over Zenoh, separate processes.

Prints and saves simulated seconds per wall second (target >= 50x on a 2-core machine).

    python bench/lockstep_speed.py [--duration 600]
"""

from __future__ import annotations

import argparse

from _common import run_fowt, save


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--scenario", default="default")
    args = ap.parse_args()
    s = run_fowt(args.scenario, "lockstep", args.duration)
    t = s["timing"]
    speed = t["sim_seconds_per_wall_second"]
    save(
        "lockstep_speed",
        {
            "scenario": args.scenario,
            "duration_s": args.duration,
            "sim_seconds_per_wall_second": speed,
            "round_trip_us": t["latency_us"],
            "whole_command_wall_s": s["bench_command_wall_s"],
            "target": 50,
            "met": speed is not None and speed >= 50,
        },
    )


if __name__ == "__main__":
    main()
