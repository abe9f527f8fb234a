"""Golden runs: 600 s of load case 2 in process, KPIs equal to the recorded ones.

The in-process loop is fast (compiled plant, sensors and controller cores,
batched logging); none of it may change what a run computes. The reference KPIs in
``tests/data/golden_inprocess_lc2.json`` say which commit recorded them; every KPI,
estimator and forecast figure of the review must agree to 1e-6 relative (absolute 1e-9 for
figures that are zero). A change meant to change what a run computes regenerates them with
one command, ``python tools/golden_inprocess.py`` (``make golden``; ``--check`` lists what
would change).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from hil.launch import RunRequest, launch

GOLDEN = json.loads((Path(__file__).parent / "data" / "golden_inprocess_lc2.json").read_text())
RTOL = 1e-6
ATOL = 1e-9


def _flatten(prefix: str, value: Any) -> dict[str, Any]:
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for key, item in value.items():
            out.update(_flatten(f"{prefix}.{key}" if prefix else key, item))
        return out
    return {prefix: value}


@pytest.mark.parametrize("scenario", sorted(GOLDEN["runs"]))
def test_inprocess_run_reproduces_golden_kpis(scenario: str, tmp_path: Path) -> None:
    summary = launch(
        RunRequest(
            scenario,
            mode="inprocess",
            duration_s=GOLDEN["duration_s"],
            out_dir=tmp_path / "run",
            plots=False,
        )
    )
    expected = _flatten("", GOLDEN["runs"][scenario])
    got = _flatten("", {k: summary.get(k) for k in GOLDEN["runs"][scenario]})
    assert set(got) == set(expected), f"summary keys changed: {set(got) ^ set(expected)}"
    bad = []
    for key, want in expected.items():
        have = got[key]
        if isinstance(want, float) and isinstance(have, int | float):
            if not math.isclose(have, want, rel_tol=RTOL, abs_tol=ATOL):
                bad.append(f"{key}: {have!r} != {want!r}")
        elif have != want:
            bad.append(f"{key}: {have!r} != {want!r}")
    assert not bad, "golden KPIs changed:\n" + "\n".join(bad)
