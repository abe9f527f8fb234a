"""Benchmark: how fast a `fowt plant` that waits for its peers ends on SIGINT / SIGTERM.

Starts `fowt plant nrel5mw-ramp` (which waits for the controller and the recorder), waits
for its "plant waiting for" line plus 0.5 s, sends the signal and measures the wall time
to the "nothing ran" line and to the process's exit, `--repeat` times per signal. Prints and
saves the figures (bench/results/plant_wait_signal.json).

    python bench/plant_wait_signal.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import time
from typing import Any

from _common import save


def _one(sig: signal.Signals) -> tuple[float, float, int]:
    from hil.nodes.bus import free_tcp_endpoint

    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    cmd = [sys.executable, "-m", "hil", "plant", "nrel5mw-ramp", "--insecure"]
    cmd += ["--listen", free_tcp_endpoint()]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env
    )
    assert proc.stdout is not None
    for line in proc.stdout:
        if "plant waiting for" in line:
            break
    time.sleep(0.5)
    t0 = time.monotonic()
    proc.send_signal(sig)
    message = float("nan")
    for line in proc.stdout:
        if "nothing ran" in line:
            message = time.monotonic() - t0
            break
    code = proc.wait(60)
    return message, time.monotonic() - t0, code


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    results: dict[str, Any] = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        runs = [_one(sig) for _ in range(args.repeat)]
        exits = [r[1] for r in runs]
        results[sig.name] = {
            "exit_codes": sorted({r[2] for r in runs}),
            "message_s": [round(r[0], 4) for r in runs],
            "exit_s": [round(x, 4) for x in exits],
            "exit_median_s": round(statistics.median(exits), 4),
            "exit_max_s": round(max(exits), 4),
        }
    save("plant_wait_signal", {"repeat": args.repeat, "results": results})


if __name__ == "__main__":
    main()
