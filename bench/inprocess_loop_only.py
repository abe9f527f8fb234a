"""The in-process loop alone: 600 s of LC2 with the messages dropped (no log writer).

What the compiled loop (:mod:`hil._loop_kernels`) and the Python loop cost per 25 ms cycle
without the logging, which the log writer's side (``BackgroundRunLog.publish_block``) adds:
each configuration runs :func:`hil.inprocess_run.run_inprocess` in a child process (own
interpreter, kernels loaded before the loop starts) with a ``publish`` and a
``publish_block`` that drop everything, alternating the two loops ``--rounds`` times in one
run; the loop's CPU time (this thread's clock from the first cycle to the final summary)
and wall time per cycle, the least-CPU round of each, every round's figure and the load.
With ``--compare-python PY --compare-root DIR`` (e.g. main's venv and checkout) DIR's
compiled loop runs in the same alternation (this script, DIR's code), as ``compare``.

    python bench/inprocess_loop_only.py [--rounds 3] [--duration 600] [--save-as NAME]
    python bench/inprocess_loop_only.py --compare-python REF/.venv/bin/python \
        --compare-root REF --rounds 3 --save-as inprocess_loop_only_glue4
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

from _common import save

SCENARIOS = {"lc2-lqri-ff": "iea15mw-lc2-lqri-ff", "lc2-baseline": "iea15mw-lc2"}


def _child(scenario: str, loop: str, duration_s: float) -> None:
    import time

    from hil.controller_node import ControllerRuntime, publishing_step
    from hil.inprocess_run import run_inprocess
    from hil.scenario import load_scenario

    scn = load_scenario(scenario).with_duration(duration_s)
    rt = ControllerRuntime(scn)

    def publish(_mt: Any, _msg: Any) -> None:
        return None

    def block(_order: Any, _rows: Any) -> None:
        return None

    step = publishing_step(rt, publish)

    marks: dict[str, int] = {}

    def start() -> None:
        marks["cpu0"] = time.thread_time_ns()

    res = run_inprocess(
        scn, publish, step, before_loop=start, runtime=rt, loop=loop, publish_block=block
    )
    cpu = time.thread_time_ns() - marks["cpu0"]
    out = {
        "loop": res.loop,
        "cpu_us_per_cycle": round(cpu / res.cycles / 1e3, 2),
        "wall_us_per_cycle": round(res.wall_s / res.cycles * 1e6, 2),
        "sim_s_per_wall_s": round(res.speed, 1),
        "load_average": os.getloadavg()[0],
    }
    print("RESULT " + json.dumps(out), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--child", nargs=2, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--compare-python", type=Path, default=None, help="e.g. main's venv python")
    ap.add_argument(
        "--compare-root", type=Path, default=None, help="another checkout's root folder"
    )
    ap.add_argument("--save-as", default="inprocess_loop_only", help="name of the JSON")
    args = ap.parse_args()
    if args.child:
        _child(args.child[0], args.child[1], args.duration)
        return
    if (args.compare_python is None) != (args.compare_root is None):
        raise SystemExit("--compare-python and --compare-root go together")
    here = Path(__file__).resolve()
    # (interpreter, code root, loop) of each configuration, run in this order every round
    codes = {
        "compiled": (sys.executable, here.parent.parent, "compiled"),
        "python": (sys.executable, here.parent.parent, "python"),
    }
    if args.compare_python is not None:
        codes["compare"] = (str(args.compare_python), args.compare_root.resolve(), "compiled")
    result: dict[str, Any] = {"load_average_start": os.getloadavg(), "rounds": args.rounds}
    if args.compare_root is not None:
        result["compare_root"] = str(args.compare_root)
    for name, scenario in SCENARIOS.items():
        per: dict[str, list[dict[str, Any]]] = {code: [] for code in codes}
        for _ in range(args.rounds):
            for code, runs in per.items():
                python, root, loop = codes[code]
                cmd = [python, str(here), "--child", scenario, loop]
                cmd += ["--duration", str(args.duration)]
                env = {**os.environ, "PYTHONPATH": str(root)}
                proc = subprocess.run(
                    cmd, cwd=root, env=env, capture_output=True, text=True, check=False
                )
                line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
                if proc.returncode != 0 or not line:
                    raise SystemExit(f"{name} {code} failed:\n{proc.stdout}\n{proc.stderr}")
                runs.append(json.loads(line[-1][7:]))
        entry: dict[str, Any] = {"scenario": scenario, "duration_s": args.duration}
        for loop, runs in per.items():
            best = min(runs, key=lambda r: r["cpu_us_per_cycle"])
            entry[loop] = {
                **best,
                "cycle_s_per_cpu_s": round(0.025 / (best["cpu_us_per_cycle"] * 1e-6), 1),
                "rounds_cpu_us_per_cycle": [r["cpu_us_per_cycle"] for r in runs],
                "rounds_load_average": [r["load_average"] for r in runs],
            }
        entry["python_over_compiled_cpu"] = round(
            entry["python"]["cpu_us_per_cycle"] / entry["compiled"]["cpu_us_per_cycle"], 2
        )
        if "compare" in entry:
            entry["compare_over_compiled_cpu"] = round(
                entry["compare"]["cpu_us_per_cycle"] / entry["compiled"]["cpu_us_per_cycle"], 2
            )
        result[name] = entry
        print(name, entry, flush=True)
    result["load_average_end"] = os.getloadavg()
    save(args.save_as, result)


if __name__ == "__main__":
    sys.exit(main())
