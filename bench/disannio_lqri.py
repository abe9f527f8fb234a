"""disannio-2022 above rated: the gain-scheduled LQRI against the baseline PI at 15 m/s.

Runs the shipped scenarios ``iea15mw-baseline-15`` and ``iea15mw-lqri-15`` (IEA 15 MW on
VolturnUS-S, 15 m/s turbulent IEC B, JONSWAP Hs 3 m Tp 9.5 s, same seeds) in process for
``--duration`` (600 s) as ``fowt run --mode inprocess --no-plots`` does, and computes from
each MCAP file, after ``--settle`` (60 s), the measures the thesis discusses (its section 4:
power within ±1 MW of 15 MW, rotor speed within 7-8 rpm against the PI's 6.5-8.5 rpm):

* electrical power: mean, standard deviation, 1st and 99th percentiles [MW];
* rotor speed: mean, standard deviation, 1st and 99th percentiles [rpm];
* platform pitch std [deg], tower-base DEL [MN m] and pitch travel [deg/s] from the review.

Prints the table and saves ``bench/results/disannio_lqri.json``.

    python bench/disannio_lqri.py [--duration 600] [--settle 60]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np
from _common import run_fowt, save

from hil.runlog.mcap_io import read_run

SCENARIOS = {"baseline": "iea15mw-baseline-15", "lqri": "iea15mw-lqri-15"}


def _measures(settle_s: float) -> Any:
    def inspect(run_dir: Path) -> dict[str, float]:
        truth = read_run(run_dir / "run.mcap").topic("truth")
        t = np.array([m["sample_time_ns"] for m in truth]) / 1e9
        keep = t >= settle_s
        p_mw = np.array([m["electrical_power_w"] for m in truth])[keep] / 1e6
        rpm = np.array([m["rotor_speed_rad_s"] for m in truth])[keep] * 30.0 / math.pi
        return {
            "power_mean_mw": float(p_mw.mean()),
            "power_std_mw": float(p_mw.std()),
            "power_p1_mw": float(np.percentile(p_mw, 1)),
            "power_p99_mw": float(np.percentile(p_mw, 99)),
            "rotor_speed_mean_rpm": float(rpm.mean()),
            "rotor_speed_std_rpm": float(rpm.std()),
            "rotor_speed_p1_rpm": float(np.percentile(rpm, 1)),
            "rotor_speed_p99_rpm": float(np.percentile(rpm, 99)),
        }

    return inspect


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--settle", type=float, default=60.0)
    args = ap.parse_args()
    runs: dict[str, Any] = {}
    for controller, scenario in SCENARIOS.items():
        summary = run_fowt(scenario, "inprocess", args.duration, inspect=_measures(args.settle))
        k = summary["kpi"]
        runs[controller] = {
            "scenario": scenario,
            **summary["bench_inspect"],
            "platform_pitch_std_deg": k["platform_pitch_std_deg"],
            "tower_base_del_mnm": k["tower_base_del_nm"] / 1e6,
            "pitch_travel_deg_s": k["pitch_travel_deg_s"],
        }
    print(f"{'measure':28s} {'baseline':>10s} {'lqri':>10s}")
    for key in runs["baseline"]:
        if key != "scenario":
            print(f"{key:28s} {runs['baseline'][key]:10.3f} {runs['lqri'][key]:10.3f}")
    save(
        "disannio_lqri",
        {"duration_s": args.duration, "settle_s": args.settle, "runs": runs},
    )


if __name__ == "__main__":
    main()
