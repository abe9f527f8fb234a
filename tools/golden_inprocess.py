"""Regenerate the golden in-process KPIs (``tests/data/golden_inprocess_lc2.json``).

``tests/test_golden_inprocess.py`` compares every KPI, estimator and forecast figure of a
600 s in-process run of each scenario in that file against the recorded values (1e-6
relative). A change that is meant to change what a run computes (a model, a controller's
law, the initial condition) regenerates them deliberately with this one command, and says
so and why in its commit:

    python tools/golden_inprocess.py            # or: make golden

It runs each scenario as ``fowt run <scenario> --mode inprocess --duration 600`` does and
writes the file with the commit it was made at. ``--check`` only reports the figures that
would change (largest relative difference per section), writing nothing.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "data" / "golden_inprocess_lc2.json"
SCENARIOS = ("iea15mw-lc2-lqri-ff", "iea15mw-lc2")
sys.path.insert(0, str(ROOT / "bench"))
from _common import commit  # noqa: E402 - the benchmarks' commit stamp, one definition

SECTIONS = ("kpi", "estimator", "forecast")
DURATION_S = 600.0


def _flatten(prefix: str, value: Any) -> dict[str, Any]:
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for key, item in value.items():
            out.update(_flatten(f"{prefix}.{key}" if prefix else key, item))
        return out
    return {prefix: value}


def run(scenario: str) -> dict[str, Any]:
    """The golden sections of one 600 s in-process run's review summary."""
    from hil.launch import RunRequest, launch  # noqa: PLC0415

    with tempfile.TemporaryDirectory(prefix="fowt-golden-") as tmp:
        summary = launch(
            RunRequest(
                scenario,
                mode="inprocess",
                duration_s=DURATION_S,
                out_dir=Path(tmp) / "run",
                plots=False,
            )
        )
    return {k: summary.get(k) for k in SECTIONS}


def differences(old: dict[str, Any], new: dict[str, Any]) -> list[tuple[str, float, Any, Any]]:
    """(key, relative difference, old, new) of every figure that changed, largest first."""
    a, b = _flatten("", old), _flatten("", new)
    out = []
    for key in sorted(set(a) | set(b)):
        x, y = a.get(key), b.get(key)
        if x == y:
            continue
        if isinstance(x, int | float) and isinstance(y, int | float) and math.isfinite(x):
            rel = abs(y - x) / max(abs(x), 1e-12)
        else:
            rel = math.inf
        out.append((key, rel, x, y))
    return sorted(out, key=lambda r: -r[1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="report the changes, write nothing")
    args = ap.parse_args()
    old = json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {"runs": {}}
    runs = {name: run(name) for name in SCENARIOS}
    for name, new in runs.items():
        diff = differences(old["runs"].get(name, {}), new)
        print(f"{name}: {len(diff)} figures changed")
        for key, rel, x, y in diff:
            print(f"  {key}: {x!r} -> {y!r} ({rel:+.3%})" if math.isfinite(rel) else f"  {key}")
    if args.check:
        return 0
    data = {
        "source": (
            f"python tools/golden_inprocess.py (fowt run <scenario> --mode inprocess --duration "
            f"{DURATION_S:g}) at {commit()}"
        ),
        "duration_s": DURATION_S,
        "runs": runs,
    }
    GOLDEN.write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {GOLDEN.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
