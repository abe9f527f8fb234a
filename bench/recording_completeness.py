"""Does a lock-step run record every message of every cycle? Counts per topic vs cycles.

Runs ``fowt run SCENARIO --mode lockstep --duration D`` (plant, controller and recorder as
separate processes, the recorder niced as the launcher starts it) for each scenario and
duration, optionally beside N CPU hogs (``python -c 'while True: pass'``, started before
the run and killed after it) to load the 2-core machine, and tabulates, per run, the
cycles run (the plant's final summary) and per topic the messages recorded and expected
(the review's ``recording`` section: expected from the plant's and controller's reports).
Every topic of the five per-cycle ones (sensors, command, truth, controller/status,
timing/cycle) must hold exactly ``cycles`` messages.

Results are merged into ``bench/results/recording_completeness.json`` under
``runs["<scenario>/<duration>s/hogs<N>"]`` (a later run of the same key replaces it), each
with the commit and the load averages before and after.

    python bench/recording_completeness.py [--duration 600 3600]
        [--scenario nrel5mw-ramp iea15mw-lc2] [--hogs 2]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from typing import Any

from _common import RESULTS, commit, load, run_fowt, save

NAME = "recording_completeness"
PER_CYCLE = ("sensors", "command", "truth", "controller/status", "timing/cycle")


def start_hogs(n: int) -> list[subprocess.Popen[bytes]]:
    """``n`` busy-looping Python processes (each takes a core while it can)."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


def stop_hogs(hogs: list[subprocess.Popen[bytes]]) -> None:
    for h in hogs:
        h.kill()
        h.wait()


def one_run(scenario: str, duration_s: float, hogs: int) -> dict[str, Any]:
    """One lock-step run beside ``hogs`` CPU hogs: its cycles and per-topic counts."""
    load_before = load()
    procs = start_hogs(hogs)
    try:
        t0 = time.monotonic()
        summary = run_fowt(scenario, "lockstep", duration_s)
        wall = time.monotonic() - t0
    finally:
        stop_hogs(procs)
    rec = summary["recording"]
    cycles = summary["timing"]["cycles"]
    topics = {t: v for t, v in rec["topics"].items()}
    per_cycle_ok = all(topics.get(t, {}).get("recorded") == cycles for t in PER_CYCLE)
    row = {
        "scenario": scenario,
        "duration_s": duration_s,
        "hogs": hogs,
        "commit": commit(),
        "load_before": load_before,
        "load_after": load(),
        "wall_s": round(wall, 1),
        "sim_seconds_per_wall_second": summary["timing"].get("sim_seconds_per_wall_second"),
        "cycles": cycles,
        "per_cycle_topics_equal_cycles": per_cycle_ok,
        "recording_complete": rec["complete"],
        "problems": rec["problems"],
        "topics": topics,
    }
    print(
        f"{scenario} {duration_s:g} s, {hogs} hogs: {cycles} cycles, "
        + ", ".join(f"{t} {topics.get(t, {}).get('recorded')}" for t in PER_CYCLE)
        + f"; complete {rec['complete']}; {wall:.0f} s wall",
        flush=True,
    )
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, nargs="+", default=[600.0, 3600.0])
    ap.add_argument("--scenario", nargs="+", default=["nrel5mw-ramp", "iea15mw-lc2"])
    ap.add_argument("--hogs", type=int, default=0, help="CPU hog processes beside the run")
    a = ap.parse_args()
    path = RESULTS / f"{NAME}.json"
    runs: dict[str, Any] = {}
    if path.is_file():
        runs = json.loads(path.read_text()).get("runs", {})
    for duration in a.duration:
        for scenario in a.scenario:
            row = one_run(scenario, duration, a.hogs)
            runs[f"{scenario}/{duration:g}s/hogs{a.hogs}"] = row
            save(NAME, {"per_cycle_topics": list(PER_CYCLE), "runs": runs})


if __name__ == "__main__":
    main()
