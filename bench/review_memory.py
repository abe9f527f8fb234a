"""Review of long runs: wall time, CPU time and peak memory of `fowt review` (with plots) by length.

For LC2 runs of the lqri_ff controller in process (1 h, 6 h and 24 h of simulated time by
default, ``fowt run iea15mw-lc2-lqri-ff --mode inprocess --no-plots --duration D``, each file
deleted once measured), the whole command ``fowt review run.mcap --out DIR`` (summary and the
three plots) runs in a child process, ``--repeat`` times a length. Per run: the wall time,
the child's CPU time (user + system) and its peak resident set, both from ``os.wait4`` on
that child alone (``ru_maxrss``, the same figure ``/usr/bin/time -v`` prints); the medians a
length, the file's size, and per length the CPU seconds and peak per hour of simulated time
(the CPU must grow linearly with the log, the peak not at all). The machine's load is saved
with them.

    python bench/review_memory.py [--durations 3600 21600 86400] [--repeat 1]
        [--log DURATION=PATH ...]

``--log 86400=day/run.mcap`` reviews a log made beforehand by that command for that
duration instead of running it again (kept afterwards).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import load, save

SCENARIO = "iea15mw-lc2-lqri-ff"


def _review(path: Path, out: Path) -> dict[str, float]:
    """``fowt review`` of ``path`` (plots into ``out``) in a child: wall [s], CPU [s], peak [MB]."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "hil", "review", str(path), "--out", str(out), "--plots"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    _pid, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    err = proc.stderr.read().decode() if proc.stderr else ""
    if proc.stderr:
        proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"fowt review exited {proc.returncode}: {err[-2000:]}")
    return {
        "wall_s": wall,
        "cpu_s": usage.ru_utime + usage.ru_stime,
        "peak_rss_mb": usage.ru_maxrss / 1024.0,  # ru_maxrss is in KiB on Linux
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--durations", type=float, nargs="+", default=[3600.0, 21600.0, 86400.0])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--log", nargs="*", default=[], metavar="DURATION=PATH")
    args = ap.parse_args()
    made: dict[float, Path] = {}
    for item in args.log:
        dur, _, where = item.partition("=")
        made[float(dur)] = Path(where)
    result: dict[str, Any] = {"load_before": load(), "scenario": SCENARIO, "runs": {}}
    with tempfile.TemporaryDirectory(prefix="fowt-review-memory-") as tmp:
        for dur in args.durations:
            run_dir = Path(tmp) / f"run{int(dur)}"
            if dur in made:
                path = made[dur]
            else:
                subprocess.run(
                    [sys.executable, "-m", "hil", "run", SCENARIO, "--mode", "inprocess",
                     "--duration", str(dur), "--out", str(run_dir), "--no-plots"],
                    capture_output=True, check=True,
                )  # fmt: skip
                path = run_dir / "run.mcap"
            size_mb = path.stat().st_size / 1e6
            rounds = [_review(path, Path(tmp) / f"review{int(dur)}") for _ in range(args.repeat)]
            med = {k: statistics.median(r[k] for r in rounds) for k in rounds[0]}
            hours = dur / 3600.0
            result["runs"][f"{hours:g}h"] = {
                "simulated_s": dur,
                "log_made_beforehand": dur in made,
                "file_mb": size_mb,
                "median": med,
                "cpu_s_per_simulated_hour": med["cpu_s"] / hours,
                "rounds": rounds,
            }
            print(f"{hours:5g} h  file {size_mb:7.0f} MB  wall {med['wall_s']:7.1f} s  "
                  f"CPU {med['cpu_s']:7.1f} s  peak {med['peak_rss_mb']:6.0f} MB")  # fmt: skip
            shutil.rmtree(run_dir, ignore_errors=True)
    result["load_after"] = load()
    save("review_memory", result)


if __name__ == "__main__":
    main()
