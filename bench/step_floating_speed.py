"""CPU time per :func:`plant.platform.step_floating` call (IEA 15 MW VolturnUS-S, 15 m/s).

Usage::

    .venv/bin/python bench/step_floating_speed.py [--out bench/results/step_floating_speed.json]

Steady operating point at 15 m/s, h = 0.01 s, 7 repetitions of 20 000 chained calls; prints
the minimum and the median in µs per call (process CPU time) and saves them as JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from plant.modes import operating_point
from plant.platform import load_floating, step_floating


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("bench/results/step_floating_speed.json"))
    args = ap.parse_args()
    params = load_floating("iea15mw_volturnus")
    op = operating_point(params, 15.0)
    per_call = []
    for _ in range(7):
        x = op.state
        t0 = time.process_time()
        for _ in range(20000):
            x = step_floating(0.0, x, op.inputs, 0.01, params)
        per_call.append((time.process_time() - t0) / 20000 * 1e6)
    per_call.sort()
    out = {
        "radiation_states": params.n_radiation,
        "us_per_call_min": per_call[0],
        "us_per_call_median": per_call[3],
    }
    print(
        f"step_floating: {per_call[0]:.2f} us/call min, {per_call[3]:.2f} median "
        f"({params.n_radiation} radiation states, 7 x 20000 calls)"
    )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
