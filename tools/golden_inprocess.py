"""Regenerate the golden in-process KPIs (``tests/data/golden_inprocess_lc2.json``).

``tests/test_golden_inprocess.py`` compares every KPI, estimator and forecast figure of a
600 s in-process run of each scenario in the file with the recorded ones. When a change is
meant to change what a run computes (a controller's law, the plant's start), rerun this and
say in the commit which KPIs moved, by how much and why; otherwise the file must not change.
Prints the old and new figures side by side.

    python tools/golden_inprocess.py [--scenarios iea15mw-lc2 iea15mw-lc2-lqri-ff]
"""

from __future__ import annotations

import argparse
import datetime
import io
import json
import subprocess
import tempfile
from pathlib import Path
from typing import Any

from rich.console import Console

from hil.launch import RunRequest, launch

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "data" / "golden_inprocess_lc2.json"
SECTIONS = ("kpi", "estimator", "forecast")


def _commit() -> str:
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short=7", "HEAD"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")


def _flat(prefix: str, value: Any) -> dict[str, Any]:
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for key, item in value.items():
            out.update(_flat(f"{prefix}.{key}" if prefix else key, item))
        return out
    return {prefix: value}


def main() -> None:
    old = json.loads(GOLDEN.read_text())
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenarios", nargs="+", default=sorted(old["runs"]))
    args = ap.parse_args()
    duration = float(old["duration_s"])
    runs: dict[str, Any] = dict(old["runs"])
    quiet = Console(file=io.StringIO())
    for name in args.scenarios:
        with tempfile.TemporaryDirectory(prefix="fowt-golden-") as tmp:
            summary = launch(
                RunRequest(
                    name,
                    mode="inprocess",
                    duration_s=duration,
                    out_dir=Path(tmp) / "run",
                    plots=False,
                ),
                quiet,
            )
        runs[name] = {k: summary.get(k) for k in SECTIONS}
        before = _flat("", old["runs"].get(name, {}))
        for key, value in _flat("", runs[name]).items():
            was = before.get(key)
            if was != value:
                rel = ""
                if isinstance(was, float) and isinstance(value, float) and was:
                    rel = f" ({100.0 * (value / was - 1.0):+.2f} %)"
                print(f"{name} {key}: {was!r} -> {value!r}{rel}")
    day = datetime.datetime.now(datetime.UTC).date().isoformat()
    out = {
        "source": (
            f"python tools/golden_inprocess.py (fowt run <scenario> --mode inprocess "
            f"--duration {duration:g}) on {_commit()} ({day})"
        ),
        "duration_s": duration,
        "runs": runs,
    }
    GOLDEN.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {GOLDEN.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
