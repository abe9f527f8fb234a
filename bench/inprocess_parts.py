"""The in-process loop's parts one at a time, this code against another checkout in one run.

Each part of a control cycle is called on its own in a tight loop, 24 000 times (600 s of
LC2 at 40 Hz, the floating IEA 15 MW with its sensor suite, the baseline controller), and
timed on this thread's CPU clock: ``truth`` (:meth:`PlantSimulator.truth`),
``sensor_frame``, ``advance`` (one control period), ``handle_frame``
(:meth:`ControllerRuntime.handle_frame` with the baseline core, its checks, watchdog and the
command and status Structs) and ``publish`` (:meth:`BackgroundRunLog.publish` of the cycle's
five messages, the batch encoding included, the writer child running). A tight loop keeps
the caches warm (truth, sensor frame and period are called in the loop's order, each timed
on the wall clock), so these are lower bounds of the same parts inside the run
(bench/inprocess_speed.py times them there). With ``--compare-python PY --compare-root DIR``
the same script runs alternately with DIR's code (``--rounds``), and the least-CPU round of
each part is kept.

    python bench/inprocess_parts.py --compare-python REF/.venv/bin/python \\
        --compare-root REF --rounds 3
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import save

SCENARIO = "iea15mw-lc2"
CYCLES = 24_000


def measure() -> dict[str, float]:
    """CPU us per call of each part (module docstring)."""
    from bus_schemas.registry import COMMAND, CONTROLLER_STATUS, CYCLE_TIMING, SENSORS, TRUTH
    from hil.controller_node import ControllerRuntime
    from hil.log_writer import BackgroundRunLog
    from hil.plant_node import plant_config
    from hil.scenario import load_scenario
    from plant.simulator import PlantSimulator

    scenario = load_scenario(SCENARIO).with_duration(CYCLES * 0.025)
    sim = PlantSimulator(plant_config(scenario))
    x = sim.initial_state()
    applied = sim.initial_applied(x)
    period_ns = 25_000_000
    clock = time.perf_counter_ns  # (a CPU clock read costs ~2 us on this VM)
    out: dict[str, float] = {}
    truths, frames = [], []
    t_truth = t_frame = t_adv = 0
    for k in range(CYCLES):  # the loop's order: truth, its sensor frame, the period
        c0 = clock()
        tr = sim.truth(k, k * period_ns, x, applied, 0)
        c1 = clock()
        frames.append(sim.sensor_frame(k, tr, k))
        c2 = clock()
        x = sim.advance(k * 0.025, x, applied, applied, 0)
        c3 = clock()
        truths.append(tr)
        t_truth += c1 - c0
        t_frame += c2 - c1
        t_adv += c3 - c2
    out["truth"] = t_truth / CYCLES / 1e3
    out["sensor_frame"] = t_frame / CYCLES / 1e3
    out["advance"] = t_adv / CYCLES / 1e3
    clock = time.thread_time_ns
    with tempfile.TemporaryDirectory() as tmp:
        runtime = ControllerRuntime(scenario, run_dir=Path(tmp))
        results = []
        c0 = clock()
        for f in frames:
            results.append(runtime.handle_frame(f))
        out["handle_frame"] = (clock() - c0) / CYCLES / 1e3
        log = BackgroundRunLog(Path(tmp) / "parts.mcap", "t1", {"run": {"mode": "parts"}})
        log.wait_ready()
        publish = log.publish
        timing = _timing_messages(CYCLES)
        c0 = clock()
        for f, tr, r, ct in zip(frames, truths, results, timing, strict=True):
            publish(SENSORS, f)
            publish(TRUTH, tr)
            publish(CYCLE_TIMING, ct)
            if r is not None:
                publish(COMMAND, r[0])
                publish(CONTROLLER_STATUS, r[1])
        out["publish_5"] = (clock() - c0) / CYCLES / 1e3
        log.close()
        out["writer_us_per_message"] = log.writer_cpu_s / max(1, log.writer_messages) * 1e6
    return {k: round(v, 3) for k, v in out.items()}


def _timing_messages(n: int) -> list[Any]:
    from bus_schemas import CycleTiming

    return [
        CycleTiming(
            seq=k,
            sample_time_ns=k * 25_000_000,
            publish_time_ns=k,
            latency_ns=40_000,
            deadline_missed=0,
            command_held=0,
            safe_state=0,
            plant_compute_ns=20_000,
            tick_lateness_ns=0,
        )
        for k in range(n)
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--compare-python", type=Path, default=None)
    ap.add_argument("--compare-root", type=Path, default=None)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--save-as", default="inprocess_parts")
    args = ap.parse_args()
    if args.child:
        print("PARTS " + json.dumps(measure()), flush=True)
        return
    here = Path(__file__).resolve()
    codes = {"this": (sys.executable, here.parent.parent)}
    if args.compare_python is not None:
        if args.compare_root is None:
            raise SystemExit("--compare-python needs --compare-root")
        codes["compare"] = (str(args.compare_python), args.compare_root.resolve())
    rounds: dict[str, list[dict[str, float]]] = {c: [] for c in codes}
    loads = []
    for _ in range(args.rounds):
        for code, (python, root) in codes.items():
            env = {**os.environ, "PYTHONPATH": str(root)}
            proc = subprocess.run(
                [python, str(here), "--child"],
                cwd=root,
                env=env,
                capture_output=True,
                text=True,
                check=False,
            )
            line = [ln for ln in proc.stdout.splitlines() if ln.startswith("PARTS ")]
            if proc.returncode != 0 or not line:
                raise SystemExit(f"{code} failed:\n{proc.stdout}\n{proc.stderr}")
            rounds[code].append(json.loads(line[-1][6:]))
            loads.append(os.getloadavg()[0])
    best = {code: {k: min(r[k] for r in runs) for k in runs[0]} for code, runs in rounds.items()}
    result: dict[str, Any] = {
        "scenario": SCENARIO,
        "calls": CYCLES,
        "cpu_us_per_call_best": best,
        "rounds": rounds,
        "load_averages": loads,
        "compare_root": str(args.compare_root) if args.compare_root else None,
    }
    for code, parts in best.items():
        print(code, parts, flush=True)
    save(args.save_as, result)


if __name__ == "__main__":
    main()
