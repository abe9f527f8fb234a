"""The review counts the samples in which the rotor ran outside its Cp/Ct table.

The IEA 15 MW table ends at tip-speed ratio 14.5; at 4 m/s below rated the rotor turns at
its minimum speed of 5 rpm (VS_MinOMSpd), λ = 0.5236 · 120.97 / 4 = 15.83 > 14.5, so every sample
is clamped to the table's edge; at 8 m/s it runs near λ* ≈ 9, inside. In-process runs of the
bottom-fixed plant with steady wind, 30 s: the summary (``summary.json``) carries the count,
the largest λ reached and the table's range, and the console says so in a note.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hil.review.table_range import table_range_note
from tests._helpers import fowt

SCENARIO = """
name = "iea15mw-steady-{speed}"
turbine = "iea15mw"
duration_s = 30.0

[wind]
kind = "steady"
speed_m_s = {speed}

[controller]
kind = "baseline"
preset = "iea15mw_baseline"
"""


def _run(tmp_path: Path, speed: float) -> tuple[dict[str, object], str]:
    path = tmp_path / f"steady-{speed:g}.toml"
    path.write_text(SCENARIO.format(speed=speed))
    out = tmp_path / f"run-{speed:g}"
    proc = fowt(
        "run", str(path), "--mode", "inprocess", "--out", str(out), "--no-plots", columns=400
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    return summary["rotor_table"], proc.stdout


def test_rotor_below_rated_at_minimum_speed_leaves_the_table(tmp_path: Path) -> None:
    table, stdout = _run(tmp_path, 4.0)
    assert table["table_tsr"] == [pytest.approx(2.0), pytest.approx(14.5)]
    assert table["samples"] > 0
    assert table["outside"] > 0.9 * table["samples"]  # held at 5 rpm: λ ≈ 15.7
    assert table["tsr_above"] == table["outside"]
    assert 15.0 < table["tsr_max"] < 16.5
    note = table_range_note(table)
    assert note is not None and "table 2..14.5" in note
    assert "rotor outside its Cp/Ct table" in " ".join(stdout.split())


def test_rotor_at_8_m_s_stays_inside_the_table(tmp_path: Path) -> None:
    table, stdout = _run(tmp_path, 8.0)
    assert table["samples"] > 0
    assert table["outside"] == 0
    assert table["tsr_max"] < 14.5
    assert table_range_note(table) is None
    assert "outside its Cp/Ct table" not in stdout
