"""Review speed and memory: the streaming review against the review of dicts, same run.

For LC2 runs of the lqri_ff controller in process (600 s and 3600 s of simulated time,
``fowt run iea15mw-lc2-lqri-ff --mode inprocess --no-plots``, the file kept), each file is
reviewed in a fresh child process, alternately:

* ``streaming``: :func:`hil.review.core.review` without plots (the column reader, one MCAP chunk
  at a time, :mod:`hil.review.stream`);
* ``dicts``: :func:`hil.runlog.mcap_io.read_run` (every message as a dict, the review's reader
  before the streaming one) then :func:`hil.review.core.summarize` of it.

Per child: CPU seconds of the call (``time.process_time``), the child's peak resident set
(``ru_maxrss``) and its resident set after the imports (so the growth with the file is
visible); the medians over ``--repeat`` rounds and the ratio dicts/streaming. The two
summaries must agree (checked, relative 1e-9). The machine's load is saved with them.

    python bench/review_speed.py [--durations 600 3600] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import load, save

CHILD = r"""
import json, sys, time
from pathlib import Path
def hwm():
    # VmHWM: this process's peak resident set [MB]; ru_maxrss would keep the parent's
    # peak across fork and exec.
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
from hil.runlog.mcap_io import read_run
from hil.review.core import review, summarize
how, path = sys.argv[1], Path(sys.argv[2])
base = hwm()
t0 = time.process_time()
if how == "streaming":
    s = review(path, plots=False, write_summary=False)
else:
    s = summarize(read_run(path))
cpu = time.process_time() - t0
peak = hwm()
print(json.dumps({"cpu_s": cpu, "peak_rss_mb": peak, "import_rss_mb": base,
                  "kpi": s["kpi"]}))
"""


def _child(how: str, path: Path) -> dict[str, Any]:
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, how, str(path)], capture_output=True, text=True, check=True
    )
    out: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


def _same(a: dict[str, Any], b: dict[str, Any]) -> bool:
    for k, v in a.items():
        w = b.get(k)
        if isinstance(v, float) and isinstance(w, float):
            if not math.isclose(v, w, rel_tol=1e-9, abs_tol=1e-12):
                return False
        elif v != w:
            return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--durations", type=float, nargs="+", default=[600.0, 3600.0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    result: dict[str, Any] = {"load_before": load(), "runs": {}}
    with tempfile.TemporaryDirectory(prefix="fowt-review-bench-") as tmp:
        for dur in args.durations:
            out = Path(tmp) / f"run{int(dur)}"
            subprocess.run(
                [sys.executable, "-m", "hil", "run", "iea15mw-lc2-lqri-ff", "--mode", "inprocess",
                 "--duration", str(dur), "--out", str(out), "--no-plots"],
                capture_output=True, check=True,
            )  # fmt: skip
            path = out / "run.mcap"
            rounds: dict[str, list[dict[str, Any]]] = {"streaming": [], "dicts": []}
            for _ in range(args.repeat):
                for how, got in rounds.items():
                    got.append(_child(how, path))
            med = {
                how: {
                    k: statistics.median(r[k] for r in rs)
                    for k in ("cpu_s", "peak_rss_mb", "import_rss_mb")
                }
                for how, rs in rounds.items()
            }
            result["runs"][f"{int(dur)}s"] = {
                "file_mb": path.stat().st_size / 1e6,
                "median": med,
                "cpu_ratio_dicts_over_streaming": med["dicts"]["cpu_s"] / med["streaming"]["cpu_s"],
                "peak_rss_ratio": med["dicts"]["peak_rss_mb"] / med["streaming"]["peak_rss_mb"],
                "kpis_equal": all(
                    _same(a["kpi"], b["kpi"])
                    for a, b in zip(rounds["streaming"], rounds["dicts"], strict=True)
                ),
                "cpu_s_rounds": {how: [r["cpu_s"] for r in rs] for how, rs in rounds.items()},
            }
    result["load_after"] = load()
    save("review_speed", result)


if __name__ == "__main__":
    main()
