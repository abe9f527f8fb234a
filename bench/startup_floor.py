"""The least a command that runs numba kernels takes here, beside the whole command's phases.

A fresh interpreter each time, the steps alternating (round robin, so that the machine's
load meets each alike), medians of ``--repeat``:

- ``python -c pass``: the interpreter;
- ``import numpy``;
- ``import numba``;
- ``numba first call``: a one-line ``@njit(cache=True)`` kernel already in numba's on-disk
  cache, called once: numba's import, its CPU target's initialisation (type registries,
  numba's ``arraymath`` importing ``scipy.linalg.cython_blas`` for its BLAS check) and one
  cached kernel loaded. Every ``fowt run`` pays this before its first compiled cycle;
- ``fowt run <scenario> --mode inprocess --duration 600 --no-plots`` for ``lqri_ff`` and the
  baseline: the wall time from start to exit and the phases the command reports (start-up,
  run, log, review; ``summary["run"]["wall_phases_s"]``).

From these, per scenario: the floor of the whole command, ``numba first call + run + log +
review`` (a start-up that did nothing but numba's own), against the whole-command target
(600 s / 400 = 1.5 s for ``lqri_ff``, 600 s / 600 = 1.0 s for the baseline). A floor
above the target means no start-up work of the bench's can meet it while numba initialises
in the command's own process. Saved with the load before and after.

    python bench/startup_floor.py [--repeat 10]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import ROOT, load, run_fowt, save

TARGETS = {"iea15mw-lc2-lqri-ff": 400.0, "iea15mw-lc2": 600.0}
DURATION_S = 600.0
KERNEL = "import numba\n\n\n@numba.njit(cache=True)\ndef one_more(x):\n    return x + 1\n"


def _wall(cmd: list[str], cwd: Path, env: dict[str, str]) -> float:
    t0 = time.monotonic()
    subprocess.run(cmd, cwd=cwd, env=env, check=True, capture_output=True)
    return time.monotonic() - t0


def _run(scenario: str) -> dict[str, Any]:
    summary = run_fowt(scenario, "inprocess", DURATION_S, cwd=ROOT)
    phases = summary["run"]["wall_phases_s"]
    wall = {"wall_s": summary["bench_command_wall_s"]}
    return wall | {k: float(v) for k, v in phases.items() if k != "whole"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=10)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="fowt-floor-kernel-") as tmp:
        kdir = Path(tmp)
        (kdir / "floor_kernel.py").write_text(KERNEL)
        steps: dict[str, list[str]] = {
            "python -c pass": [sys.executable, "-c", "pass"],
            "import numpy": [sys.executable, "-c", "import numpy"],
            "import numba": [sys.executable, "-c", "import numba"],
            "numba first call": [
                sys.executable,
                "-c",
                "from floor_kernel import one_more; one_more(1)",
            ],
        }
        kenv = {**os.environ, "PYTHONPATH": f"{kdir}{os.pathsep}{ROOT}"}
        _wall(steps["numba first call"], kdir, kenv)  # compile it into numba's cache once
        for scenario in TARGETS:
            _run(scenario)  # warm the page cache, the kernels' cache and the trim store
        result: dict[str, Any] = {"repeat": args.repeat, "load_before": load()}
        walls: dict[str, list[float]] = {name: [] for name in steps}
        runs: dict[str, list[dict[str, Any]]] = {s: [] for s in TARGETS}
        for _ in range(args.repeat):
            for name, cmd in steps.items():
                walls[name].append(_wall(cmd, kdir, kenv))
            for scenario in TARGETS:
                runs[scenario].append(_run(scenario))
        result["load_after"] = load()
    result["steps_s"] = {name: statistics.median(w) for name, w in walls.items()}
    floor = result["steps_s"]["numba first call"]
    for scenario, target_x in TARGETS.items():
        med = {k: statistics.median(r[k] for r in runs[scenario]) for k in runs[scenario][0]}
        least = floor + med["run"] + med["log"] + med["review"]
        result[scenario] = {
            "median_s": med,
            "whole_x": DURATION_S / med["wall_s"],
            "target_x": target_x,
            "target_wall_s": DURATION_S / target_x,
            "floor_wall_s": least,
            "floor_x": DURATION_S / least,
            "runs": runs[scenario],
        }
    print(json.dumps(result["steps_s"], indent=1))
    for scenario in TARGETS:
        r = result[scenario]
        print(
            f"{scenario}: whole {r['median_s']['wall_s']:.2f} s ({r['whole_x']:.0f}x); "
            f"numba's floor + run + log + review {r['floor_wall_s']:.2f} s "
            f"({r['floor_x']:.0f}x); target {r['target_wall_s']:.2f} s ({r['target_x']:.0f}x)"
        )
    save("startup_floor", result)


if __name__ == "__main__":
    main()
