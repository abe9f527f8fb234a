"""First-run (cold numba cache) and cached (warm) start of the plant's compiled kernels.

Usage::

    .venv/bin/python bench/plant_compile_time.py

Runs a child process twice with the same fresh ``NUMBA_CACHE_DIR``: the first compiles every
kernel of ``plant._kernels`` and ``sensors._kernels`` that a floating (``iea15mw-lc2-lqri-ff``)
and a bottom-fixed (``nrel5mw-ramp``) plant use, the second loads them from the cache. Each
child reports its import time, and per scenario the time to build the simulator (the initial
state calls the compiled ``f``) and to run its first cycle (truth, sensor frame, one period).
Prints and saves the wall times of both children (``bench/results/plant_compile_time.json``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHILD = """
import json, time
t0 = time.perf_counter()
from hil.nodes.plant_node import plant_config
from hil.scenario.schema import load_scenario
from plant.simulator import PlantSimulator
out = {"import_s": time.perf_counter() - t0}
for name in ("iea15mw-lc2-lqri-ff", "nrel5mw-ramp"):
    a = time.perf_counter()
    sim = PlantSimulator(plant_config(load_scenario(name)))
    x = sim.initial_state()
    ap = sim.initial_applied(x)
    b = time.perf_counter()
    truth = sim.truth(0, 0, x, ap, 0)
    sim.sensor_frame(0, truth, 0)
    sim.advance(0.0, x, ap, ap, 0)
    out[name] = {"build_s": b - a, "first_cycle_s": time.perf_counter() - b}
print(json.dumps(out))
"""


def main() -> int:
    result: dict[str, object] = {"load_before": os.getloadavg()}
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for label in ("cold", "warm"):
            t0 = time.perf_counter()
            proc = subprocess.run(
                [sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, check=False
            )
            wall = time.perf_counter() - t0
            if proc.returncode != 0:
                raise SystemExit(f"{label} run failed:\n{proc.stderr}")
            figures = json.loads(proc.stdout.strip().splitlines()[-1])
            result[label] = {"process_wall_s": wall, **figures}
            print(f"{label}: process {wall:.1f} s, {json.dumps(figures)}")
    result["load_after"] = os.getloadavg()
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from _common import save

    save("plant_compile_time", result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
