"""First-run compile time and warm start of the advanced controller's compiled kernels.

The kernels of :mod:`controller._kernels` are compiled by numba on a machine's first run
and cached on disk. This benchmark starts two fresh Python processes with an empty,
private ``NUMBA_CACHE_DIR``: the first compiles (cold), the second loads the cache (warm).
Each process times the import of the controller stack, the construction of the
``iea15mw-lc2-lqri-ff`` core (which warms every kernel up, see
``AdvancedController._warm_up``) and its first ``step``; the process's total wall time is
measured from outside. ``--repeats`` pairs are run (the machine is shared: the load average
is saved beside the figures).

With ``--compare-python`` and ``--compare-root`` (e.g. ``REF/.venv/bin/python`` and
``REF``, another checkout) each repeat also runs that checkout's cold/warm pair (its
interpreter and code, its own private cache), the two sides' order alternating
(``_common.order``), so both are measured in one run under the same load.

Usage: ``python bench/controller_compile.py [--repeats 2] [--compare-python PY
--compare-root DIR]``; saves ``bench/results/controller_compile.json``.
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

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import THIS, Code, add_compare_args, codes, machine, order, save

CHILD = """
import json, time
t0 = time.perf_counter()
from hil.nodes.controller_node import ControllerRuntime
from hil.scenario.schema import load_scenario
from bus_schemas import SensorFrame
t1 = time.perf_counter()
scenario = load_scenario("iea15mw-lc2-lqri-ff")
core = ControllerRuntime(scenario).controller
t2 = time.perf_counter()
frame = SensorFrame(seq=0, sample_time_ns=25_000_000, publish_time_ns=0, valid_mask=0xFFFF,
                    generator_speed_measured_rad_s=0.75, rotor_speed_measured_rad_s=0.75,
                    blade_pitch_measured_rad=0.0, generator_torque_measured_nm=1.5e7,
                    electrical_power_measured_w=1.0e7, wind_speed_measured_m_s=10.0,
                    nacelle_acc_fore_aft_measured_m_s2=0.0, platform_pitch_measured_rad=0.05,
                    platform_pitch_rate_measured_rad_s=0.0, platform_surge_measured_m=10.0,
                    wave_elevation_gauge_measured_m=0.0)
state = core.initial_state()
t3 = time.perf_counter()
core.step(state, frame, scenario.timing.control_period_s)
t4 = time.perf_counter()
print(json.dumps({"import_s": t1 - t0, "construct_with_warm_up_s": t2 - t1,
                  "first_step_ms": (t4 - t3) * 1e3}))
"""


def child(cache_dir: str, code: Code = THIS) -> dict[str, Any]:
    """One fresh process (``code``'s interpreter on its checkout) with ``cache_dir`` as
    numba's cache."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir, PYTHONPATH=str(code.root))
    t0 = time.perf_counter()
    proc = subprocess.run(
        [code.python, "-c", CHILD],
        cwd=code.root,
        env=env,
        capture_output=True,
        text=True,
        check=True,
        timeout=900,
    )
    wall = time.perf_counter() - t0
    out: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    out["process_wall_s"] = wall
    return {k: round(v, 3) for k, v in out.items()}


def main() -> None:
    """Run the cold/warm pairs, print and save."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=2, help="cold/warm pairs")
    add_compare_args(ap)
    args = ap.parse_args()
    sides = codes(args)
    pairs: dict[str, list[dict[str, Any]]] = {side: [] for side in sides}
    load_before = os.getloadavg()
    for k in range(args.repeats):
        for side in order(list(sides), k):
            with tempfile.TemporaryDirectory(prefix="fowt-numba-cache-") as cache:
                cold = child(cache, sides[side])
                warm = child(cache, sides[side])
            pairs[side].append({"cold": cold, "warm": warm})
            print(side, "cold", cold, "warm", warm)
    runs, reference = pairs["this"], pairs.get("compare", [])
    result: dict[str, Any] = {
        "machine": machine(),
        "load_average_before": list(load_before),
        "load_average_after": list(os.getloadavg()),
        "runs": runs,
    }
    if reference:
        result["reference"] = {**sides["compare"].info(), "runs": reference}
    save("controller_compile", result)


if __name__ == "__main__":
    main()
