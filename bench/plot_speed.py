"""How long a review's plots take: the three figures in one process against two, same run.

Writes a 600 s log of ``iea15mw-lc2-lqri-ff`` in process (``fowt run ... --no-plots``),
then per round, in one fresh child process: a review without plots (the warm-up: imports,
file cache), then alternately ``review(plots=True)`` with the figures drawn in two processes
(:func:`hil.review.plots.write_plots`: the time series here, timing and spectra in a forked
child) and drawn serially (``_in_two_processes`` replaced by a plain call of both), each
minus a review without plots right after it. Per variant: wall seconds and this process's
CPU seconds (the child's CPU is not in it), medians over the rounds and the ratio. Target:
a 600 s run's plots in <= 1.0 s wall on this machine idle. ``--hogs K`` runs K CPU hogs
beside it (the loaded figure).

    python bench/plot_speed.py [--rounds 5] [--hogs 0]

Prints and saves ``bench/results/plot_speed.json`` (``runs["hogs<K>"]``, other keys kept).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS, load, save
from realtime_watchdog import start_hogs, stop_hogs

NAME = "plot_speed"

CHILD = r"""
import json, sys, time
from pathlib import Path
from hil.review import core, plots

path, out, rounds = Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3])
two = plots._in_two_processes

def serial(first, second):
    first()
    second()

core.review(path, out / "warm", plots=True)  # imports, matplotlib's font cache, file cache
rows = {"two_processes": [], "serial": []}
for k in range(rounds):
    for name, fn in (("two_processes", two), ("serial", serial))[:: 1 if k % 2 == 0 else -1]:
        plots._in_two_processes = fn
        t0, c0 = time.perf_counter(), time.process_time()
        core.review(path, out / name, plots=True)
        t1, c1 = time.perf_counter(), time.process_time()
        core.review(path, out / "none", plots=False)
        t2, c2 = time.perf_counter(), time.process_time()
        rows[name].append({"wall_s": (t1 - t0) - (t2 - t1), "cpu_s": (c1 - c0) - (c2 - c1)})
print(json.dumps(rows))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--hogs", type=int, default=0)
    ap.add_argument("--scenario", default="iea15mw-lc2-lqri-ff")
    ap.add_argument("--duration", type=float, default=600.0)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="fowt-bench-") as tmp:
        run = Path(tmp) / "run"
        cmd = [sys.executable, "-m", "hil", "run", a.scenario, "--mode", "inprocess",
               "--duration", str(a.duration), "--out", str(run), "--no-plots"]  # fmt: skip
        subprocess.run(cmd, check=True, capture_output=True)
        load_before = load()
        hogs = start_hogs(a.hogs)
        try:
            proc = subprocess.run(
                [sys.executable, "-c", CHILD, str(run / "run.mcap"), tmp, str(a.rounds)],
                capture_output=True,
                text=True,
                check=True,
            )
        finally:
            stop_hogs(hogs)
        rows: dict[str, list[dict[str, float]]] = json.loads(proc.stdout)
    medians = {
        name: {k: round(statistics.median(r[k] for r in rs), 3) for k in ("wall_s", "cpu_s")}
        for name, rs in rows.items()
    }
    key = f"hogs{a.hogs}"
    entry: dict[str, Any] = {
        "scenario": a.scenario,
        "duration_s": a.duration,
        "rounds": a.rounds,
        "load_before": load_before,
        "load_after": load(),
        "median": medians,
        "serial_over_two_processes_wall": round(
            medians["serial"]["wall_s"] / medians["two_processes"]["wall_s"], 2
        ),
        "rounds_s": rows,
    }
    path = RESULTS / f"{NAME}.json"
    runs: dict[str, Any] = {}
    if path.exists():
        runs = json.loads(path.read_text()).get("runs", {})
    runs[key] = entry
    save(NAME, {"command": "python bench/plot_speed.py [--hogs K]", "runs": runs})


if __name__ == "__main__":
    main()
