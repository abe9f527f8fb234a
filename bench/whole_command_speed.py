"""Whole-command speed of an in-process run, beside the loop's own, idle and loaded.

``fowt run <scenario> --mode inprocess --duration 600 --no-plots`` as a user types it (a fresh
interpreter each time; ``--plots both`` also times the default command, which writes the
plots, alternating with ``--no-plots``), for the lqri_ff controller (target: whole command >=
400x real time) and the baseline (>= 600x). Per run: the loop's speed (the plant's final
summary: simulated seconds per wall second of the cycle loop), the whole command's (600 s over
the command's wall time, measured outside the process: interpreter start to exit) and the
phases the command reports in ``summary["run"]["wall_phases_s"]`` (start-up to the loop's
first cycle, run, log writer finishing, review; :func:`hil.launch.speed_line`) and the CPU
seconds of the command and its children (the log writer), which a loaded machine inflates less
than the wall time. Medians of ``--repeat`` runs, first with the machine as it is, then with
``--hogs`` CPU hogs (busy-looping child processes started and stopped here). The load average
is saved with each figure: the machine is shared.

    python bench/whole_command_speed.py [--repeat 5] [--hogs 2] [--plots off|on|both]
        [--scenarios iea15mw-lc2-lqri-ff ...]

``--hogs 0`` measures the machine as it is only. With ``--plots on`` or ``both`` the result is
saved as ``whole_command_speed_plots`` (``_compare``).

With ``--compare-python PY --compare-root DIR`` (another checkout and its interpreter, e.g.
an older commit's worktree) the runs of the two alternate (ABBA, :func:`_common.alternate`)
and each side's medians and the ratio this / other of each median are saved: a ratio from one
run on the same machine, whatever its load did meanwhile.

Every side's bytecode is written first by its own set-up's code
(:meth:`_common.Code.write_bytecode`), as each checkout's ``make setup`` does: a fresh
worktree has none, and on a machine that sets ``PYTHONDONTWRITEBYTECODE`` every command
would otherwise compile the sources again. The result says which sides had it written.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import THIS, Code, add_compare_args, alternate, codes, load, save

SCENARIOS = ("iea15mw-lc2-lqri-ff", "iea15mw-lc2")
HOG = "while True:\n    pass\n"


def _one(scenario: str, duration: float, code: Code = THIS, plots: bool = False) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="fowt-whole-") as tmp:
        out = Path(tmp) / "run"
        cmd = [code.python, "-m", "hil", "run", scenario, "--mode", "inprocess",
               "--duration", str(duration), "--out", str(out),
               "--plots" if plots else "--no-plots"]  # fmt: skip
        env = {**os.environ, "PYTHONPATH": str(code.root)}
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.monotonic()
        subprocess.run(cmd, capture_output=True, check=True, cwd=code.root, env=env)
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
    ap.add_argument(
        "--plots",
        choices=("off", "on", "both"),
        default="off",
        help="time the command with --no-plots (off), with its plots (on) or both, alternating",
    )
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS))
    add_compare_args(ap)
    args = ap.parse_args()
    sides = codes(args)
    variants = {"off": [False], "on": [True], "both": [False, True]}[args.plots]
    result: dict[str, Any] = {
        "duration_s": args.duration,
        "repeat": args.repeat,
        "plots": args.plots,
    }
    if len(sides) > 1:
        result["code"] = {name: code.info() for name, code in sides.items()}
    # as each side's make setup does (a side whose set-up writes none is left so)
    result["bytecode_written"] = {name: code.write_bytecode() for name, code in sides.items()}
    conditions = [("as_is", 0)] + ([(f"with_{args.hogs}_hogs", args.hogs)] if args.hogs else [])
    for label, hogs in conditions:
        procs = [subprocess.Popen([sys.executable, "-c", HOG]) for _ in range(hogs)]
        try:
            time.sleep(1.0 if hogs else 0.0)
            cond: dict[str, Any] = {"load_before": load()}
            for scenario in args.scenarios:
                for code in sides.values():
                    _one(scenario, 10.0, code)  # warm the page cache and the kernels' cache
                keys = [(name, plots) for plots in variants for name in sides]
                runs: dict[tuple[str, bool], list[dict[str, Any]]] = {k: [] for k in keys}
                for _k, i in alternate(list(range(len(keys))), args.repeat):
                    name, plots = keys[i]
                    runs[(name, plots)].append(_one(scenario, args.duration, sides[name], plots))
                per: dict[str, Any] = {}
                for plots in variants:
                    tag = "plots" if plots else "no_plots"
                    med = {name: _median(runs[(name, plots)]) for name in sides}
                    entry: dict[str, Any] = {
                        name: {"median": med[name], "runs": runs[(name, plots)]} for name in sides
                    }
                    if len(sides) > 1:
                        entry["ratio_this_over_compare"] = {
                            k: med["this"][k] / med["compare"][k]
                            for k in ("loop_x", "whole_x", "wall_s", "cpu_s")
                        }
                    per[tag] = entry
                cond[scenario] = per if len(variants) > 1 else per[next(iter(per))]
            cond["load_after"] = load()
        finally:
            for p in procs:
                p.kill()
                p.wait()
        result[label] = cond
    # the command with its plots is another measurement: its own result file
    name = (
        "whole_command_speed"
        + ("" if args.plots == "off" else "_plots")
        + ("_compare" if len(sides) > 1 else "")
    )
    save(name, result)


if __name__ == "__main__":
    main()
