"""Whole-command speed of an in-process run, beside the loop's own, idle and loaded.

``fowt run <scenario> --mode inprocess --duration 600 --no-plots`` as a user types it (a
fresh interpreter each time), for the lqri_ff controller (target: whole command >= 400x real
time) and the baseline (>= 600x). Per run: the loop's speed (the plant's final summary:
simulated seconds per wall second of the cycle loop), the whole command's (600 s over the
command's wall time, measured outside the process: interpreter start to exit) and the
phases the command reports in ``summary["run"]["wall_phases_s"]`` (start-up to the loop's
first cycle, run, log writer finishing, review; :func:`hil.launch.speed_line`) and the CPU
seconds of the command and its children (the log writer), which a loaded machine inflates
less than the wall time. Medians of
``--repeat`` runs, first with the machine as it is, then with ``--hogs`` CPU hogs
(busy-looping child processes started and stopped here). The load average is saved with
each figure: the machine is shared.

    python bench/whole_command_speed.py [--repeat 5] [--hogs 2]
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import load, save

SCENARIOS = ("iea15mw-lc2-lqri-ff", "iea15mw-lc2")
HOG = "while True:\n    pass\n"


def _one(scenario: str, duration: float) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="fowt-whole-") as tmp:
        out = Path(tmp) / "run"
        cmd = [sys.executable, "-m", "hil", "run", scenario, "--mode", "inprocess",
               "--duration", str(duration), "--out", str(out), "--no-plots"]  # fmt: skip
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.monotonic()
        subprocess.run(cmd, capture_output=True, check=True)
        wall = time.monotonic() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        summary = json.loads((out / "summary.json").read_text())
    phases = summary["run"].get("wall_phases_s", {})
    return {
        "loop_x": summary["timing"]["sim_seconds_per_wall_second"],
        "whole_x": duration / wall,
        "wall_s": wall,
        "cpu_s": cpu,
        "phases_s": phases,
    }


def _median(runs: list[dict[str, Any]]) -> dict[str, Any]:
    keys = runs[0]["phases_s"].keys()
    return {
        "loop_x": statistics.median(r["loop_x"] for r in runs),
        "whole_x": statistics.median(r["whole_x"] for r in runs),
        "wall_s": statistics.median(r["wall_s"] for r in runs),
        "cpu_s": statistics.median(r["cpu_s"] for r in runs),
        "phases_s": {k: statistics.median(r["phases_s"][k] for r in runs) for k in keys},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--hogs", type=int, default=2)
    ap.add_argument("--duration", type=float, default=600.0)
    args = ap.parse_args()
    result: dict[str, Any] = {"duration_s": args.duration, "repeat": args.repeat}
    for label, hogs in (("as_is", 0), (f"with_{args.hogs}_hogs", args.hogs)):
        procs = [subprocess.Popen([sys.executable, "-c", HOG]) for _ in range(hogs)]
        try:
            time.sleep(1.0 if hogs else 0.0)
            cond: dict[str, Any] = {"load_before": load()}
            for scenario in SCENARIOS:
                _one(scenario, 10.0)  # warm the page cache and the compiled kernels' cache
                runs = [_one(scenario, args.duration) for _ in range(args.repeat)]
                cond[scenario] = {"median": _median(runs), "runs": runs}
            cond["load_after"] = load()
        finally:
            for p in procs:
                p.kill()
                p.wait()
        result[label] = cond
    save("whole_command_speed", result)


if __name__ == "__main__":
    main()
