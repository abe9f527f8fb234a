"""The compiled in-process loop's kernel: cold compile, warm load, and its clock's cost.

:func:`hil.inprocess.kernels.run_cycles` is compiled by numba on first use and cached on disk
(``make setup`` pays it in ``python -m hil.warmup``). This script measures, each in a fresh
child process with ``NUMBA_CACHE_DIR`` set to an empty temporary folder:

* ``cold_compile_s``: building the loop (its first, limit-0 kernel call) after the plant,
  sensor and controller kernels it calls were compiled into that folder by a 1 s Python-loop
  run of ``iea15mw-lc2-lqri-ff`` (so the figure is the loop kernel's own compile, the
  callees' typing included);
* ``cold_all_s``: the same with nothing compiled before (every kernel the run needs);
* ``warm_load_s``: the same call in a new process once the cache holds it;
* ``clock_read_ns``: the kernel's ``clock_gettime(CLOCK_MONOTONIC)`` per read (10^6 reads in
  one call) beside ``time.monotonic_ns()`` from Python.

    python bench/loop_compile_time.py
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import save

_CHILD = r"""
import json, sys, time
from hil.scenario.schema import load_scenario
from hil.nodes.controller_node import ControllerRuntime
from hil.nodes.plant_node import PlantLoop
from hil.inprocess.run import run_inprocess
out = {}
scn = load_scenario("iea15mw-lc2-lqri-ff").with_duration(1.0)
if sys.argv[1] == "callees":
    t0 = time.perf_counter()
    rt = ControllerRuntime(scn)
    def step(frame):
        r = rt.handle_frame(frame)
        return None if r is None else r[0]
    run_inprocess(scn, lambda *a: None, step, runtime=rt, loop="python")
    out["callees_s"] = time.perf_counter() - t0
t0 = time.perf_counter()
from hil.inprocess.loop import CompiledLoop
rt = ControllerRuntime(scn)
loop = PlantLoop(scn, lambda *a: None)
t1 = time.perf_counter()
CompiledLoop(loop, rt, rt.handle_frame)
out["loop_kernel_s"] = time.perf_counter() - t1
out["setup_s"] = t1 - t0
print("RESULT " + json.dumps(out))
"""


def _child(mode: str, cache: str) -> dict[str, float]:
    env = {**os.environ, "NUMBA_CACHE_DIR": cache}
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, mode], env=env, capture_output=True, text=True, check=False
    )
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    if proc.returncode != 0 or not line:
        raise SystemExit(f"child failed:\n{proc.stdout}\n{proc.stderr}")
    return dict(json.loads(line[-1][7:]))


def main() -> None:
    from hil.inprocess import kernels as lk

    result: dict[str, object] = {"load_average_start": os.getloadavg()}
    with tempfile.TemporaryDirectory(prefix="fowt-numba-") as cache:
        first = _child("callees", cache)
        result["callee_kernels_compile_and_run_s"] = round(first["callees_s"], 2)
        result["cold_compile_s"] = round(first["loop_kernel_s"], 2)
        warm = _child("warm", cache)
        result["warm_load_s"] = round(warm["loop_kernel_s"], 3)
    with tempfile.TemporaryDirectory(prefix="fowt-numba-") as cache:
        result["cold_all_s"] = round(_child("all", cache)["loop_kernel_s"], 2)
    n = 1_000_000
    lk.clock_reads(10)
    t0 = time.perf_counter_ns()
    lk.clock_reads(n)
    result["clock_read_ns_in_kernel"] = round((time.perf_counter_ns() - t0) / n, 1)
    clock = time.monotonic_ns
    t0 = time.perf_counter_ns()
    for _ in range(n):
        clock()
    result["monotonic_ns_from_python_ns"] = round((time.perf_counter_ns() - t0) / n, 1)
    result["clock_reads_per_kernel_cycle"] = 6
    result["load_average_end"] = os.getloadavg()
    result["code"] = str(Path(lk.__file__).resolve().parent.parent)
    save("loop_compile_time", result)


if __name__ == "__main__":
    sys.exit(main())
