"""The plant side of one control cycle: truth + sensor frame + one period's integration.

What an in-process cycle costs on the plant's side, without the controller and the logging:
:meth:`plant.simulator.PlantSimulator.truth`, :meth:`~plant.simulator.PlantSimulator.sensor_frame`
(the sensor channels and faults) and :meth:`~plant.simulator.PlantSimulator.advance` (the plant
steps of one control period, waves and wind included), as :class:`hil.plant_node.PlantLoop`
calls them, with the command held at the initial actuator positions. Two configurations:

* ``floating-40hz``: ``iea15mw-lc2-lqri-ff`` (IEA 15 MW VolturnUS-S, LC2 sea state and
  turbulent wind, 10 sensor channels), 25 ms cycle, 12.5 ms plant step;
* ``fixed-100hz``: ``nrel5mw-ramp`` (NREL 5 MW bottom-fixed), 10 ms cycle and step.

Usage::

    .venv/bin/python bench/plant_cycle_speed.py [--cycles 4000] [--reps 7] [--rounds 3]
        [--compare-python REF/.venv/bin/python --compare-root REF]

Per configuration: ``reps`` repetitions of ``cycles`` consecutive cycles (after 200 warm-up
cycles), each cycle timed (wall clock): its percentiles (p50 is the figure least disturbed by
the other processes of a shared machine), the mean of the best and of the median batch of
100 cycles, and the process CPU time per cycle. With ``--compare-python`` the same
measurement runs in a child process with that interpreter in ``--compare-root`` (e.g. the
main checkout, read only), alternating with this one for ``--rounds`` rounds; each side's
least disturbed round (lowest p50) is reported and every round's p50 saved, so both figures
and their ratio come from one run on the same (shared, loaded) machine; the load average is
saved beside them.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

BATCH = 100  # cycles per timed batch

CONFIGS: dict[str, tuple[str, float, float]] = {
    "floating-40hz": ("iea15mw-lc2-lqri-ff", 0.025, 0.0125),
    "fixed-100hz": ("nrel5mw-ramp", 0.01, 0.01),
}


def measure(scenario_name: str, cycles: int, reps: int) -> dict[str, Any]:
    """Time ``reps`` x ``cycles`` plant cycles of one scenario in this process."""
    from hil.plant_node import plant_config
    from hil.scenario import load_scenario
    from plant.simulator import PlantSimulator

    t_build = time.perf_counter()
    sim = PlantSimulator(plant_config(load_scenario(scenario_name)))
    x = sim.initial_state()
    applied = sim.initial_applied(x)
    period_ns = round(sim.h * sim.n * 1e9)
    build_s = time.perf_counter() - t_build
    k = 0

    def cycle() -> None:
        nonlocal x, k
        t_ns = k * period_ns
        truth = sim.truth(k, t_ns, x, applied, 0)
        sim.sensor_frame(k, truth, 0)
        x = sim.advance(t_ns * 1e-9, x, applied, applied, 0)
        k += 1

    t_first = time.perf_counter()
    cycle()
    first_s = time.perf_counter() - t_first
    for _ in range(200):
        cycle()
    samples: list[int] = []
    clock = time.perf_counter_ns
    cpu = time.process_time_ns
    batch_means = []
    cpu_total = 0
    for _ in range(reps):
        c0 = cpu()
        for _ in range(cycles // BATCH):
            b0 = clock()
            for _ in range(BATCH):
                a = clock()
                cycle()
                samples.append(clock() - a)
            batch_means.append((clock() - b0) / BATCH / 1e3)
        cpu_total += cpu() - c0
    batch_means.sort()
    samples.sort()

    def pct(q: float) -> float:
        return samples[min(len(samples) - 1, int(q * len(samples)))] / 1e3

    return {
        "scenario": scenario_name,
        "cycle_s": sim.h * sim.n,
        "plant_steps_per_cycle": sim.n,
        "cycles_timed": len(samples),
        "us_per_cycle_best_batch": batch_means[0],
        "us_per_cycle_median_batch": batch_means[len(batch_means) // 2],
        "cpu_us_per_cycle": cpu_total / len(samples) / 1e3,
        "p10_us": pct(0.1),
        "p50_us": pct(0.5),
        "p99_us": pct(0.99),
        "max_us": samples[-1] / 1e3,
        "build_s": build_s,
        "first_cycle_s": first_s,
        "final_state_head": [float(v) for v in x[:4]],
    }


def measure_all(cycles: int, reps: int, only: str | None) -> dict[str, Any]:
    return {
        name: measure(scenario, cycles, reps)
        for name, (scenario, _period, _step) in CONFIGS.items()
        if only is None or name == only
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=4000)
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--only", choices=sorted(CONFIGS), default=None)
    ap.add_argument("--child", action="store_true", help="print the figures as JSON only")
    ap.add_argument("--compare-python", type=Path, default=None)
    ap.add_argument("--compare-root", type=Path, default=None)
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds; best p50 kept")
    args = ap.parse_args()
    if args.child:
        print(json.dumps(measure_all(args.cycles, args.reps, args.only)))
        return 0
    result: dict[str, Any] = {"load_before": os.getloadavg(), "rounds": args.rounds}
    ref_rounds: list[dict[str, Any]] = []
    this_rounds: list[dict[str, Any]] = []
    for _ in range(args.rounds):  # reference and this, alternating
        if args.compare_python is not None:
            cmd = [str(args.compare_python), str(Path(__file__).resolve()), "--child"]
            cmd += ["--cycles", str(args.cycles), "--reps", str(args.reps)]
            if args.only:
                cmd += ["--only", args.only]
            proc = subprocess.run(
                cmd, cwd=args.compare_root, capture_output=True, text=True, check=False
            )
            if proc.returncode != 0:
                raise SystemExit(f"comparison run failed:\n{proc.stderr}")
            ref_rounds.append(json.loads(proc.stdout.strip().splitlines()[-1]))
        this_rounds.append(measure_all(args.cycles, args.reps, args.only))

    def best(rounds: list[dict[str, Any]]) -> dict[str, Any]:
        """Per configuration, the round with the lowest p50 (the least disturbed one)."""
        return {
            name: min((r[name] for r in rounds), key=lambda f: f["p50_us"]) for name in rounds[0]
        }

    if ref_rounds:
        result["reference"] = {
            "python": str(args.compare_python),
            "root": str(args.compare_root),
            "runs": best(ref_rounds),
            "p50_us_every_round": {n: [r[n]["p50_us"] for r in ref_rounds] for n in ref_rounds[0]},
        }
    result["this"] = best(this_rounds)
    result["this_p50_us_every_round"] = {
        n: [r[n]["p50_us"] for r in this_rounds] for n in this_rounds[0]
    }
    result["load_after"] = os.getloadavg()
    for name, fig in result["this"].items():
        line = (
            f"{name}: per cycle p50 {fig['p50_us']:.1f} us, p10 {fig['p10_us']:.1f}, "
            f"p99 {fig['p99_us']:.1f}, best batch {fig['us_per_cycle_best_batch']:.1f}, "
            f"CPU {fig['cpu_us_per_cycle']:.1f}"
        )
        ref = result.get("reference", {}).get("runs", {}).get(name)
        if ref is not None:
            ratio = ref["p50_us"] / fig["p50_us"]
            fig["speedup_vs_reference_p50"] = ratio
            fig["speedup_vs_reference_best_batch"] = (
                ref["us_per_cycle_best_batch"] / fig["us_per_cycle_best_batch"]
            )
            line += (
                f" | reference p50 {ref['p50_us']:.1f} us, best batch "
                f"{ref['us_per_cycle_best_batch']:.1f} ({ratio:.1f}x faster at p50)"
            )
        print(line)
    print(f"load average before/after: {result['load_before']} / {result['load_after']}")
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from _common import machine, save

    result["machine"] = machine()
    save("plant_cycle_speed", result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
