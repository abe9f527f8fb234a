"""Natural modes of the IEA 15 MW / VolturnUS-S preset against the OpenFAST linearisation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from plant.modes import PITCH_LENGTH_M, Mode, identify_modes, natural_modes
from plant.platform import load_floating

REFERENCE = Path(__file__).resolve().parents[2] / "shared" / "reference"
LIN = REFERENCE / "openfast" / "IEA-15-240-RWT-UMaineSemi" / "linearizations" / "lin_00.1.lin"
# Damped periods at 5 m/s quoted in DESIGN.md from lin_00 (s).
OPENFAST_PERIODS_S = {"surge": 123.2, "heave": 20.4, "pitch": 27.3, "tower_fore_aft": 2.23}


def _read_lin_a(path: Path) -> tuple[np.ndarray, list[str]]:
    lines = path.read_text().splitlines()
    start = next(i for i, s in enumerate(lines) if s.startswith("Order of continuous states:"))
    names: list[str] = []
    for s in lines[start + 3 :]:
        if not s.strip():
            break
        names.append(s.split(None, 4)[4])
    row = next(i for i, s in enumerate(lines) if s.startswith("A:"))
    n = int(lines[row].split()[1])
    a = np.array([[float(v) for v in lines[row + 1 + r].split()] for r in range(n)])
    return a, names


@pytest.fixture(scope="module")
def modes() -> dict[str, Mode]:
    return {m.name: m for m in natural_modes(load_floating("iea15mw_volturnus"), 5.0)}


@pytest.fixture(scope="module")
def openfast_modes() -> dict[str, Mode]:
    if not LIN.is_file():
        pytest.skip(f"reference linearisation not available at {LIN} (../shared absent)")
    a, names = _read_lin_a(LIN)
    wanted = {
        "surge": "Platform horizontal surge",
        "heave": "Platform vertical heave",
        "pitch": "Platform pitch tilt",
        "tower_fore_aft": "1st tower fore-aft",
    }
    pos = [next(i for i, s in enumerate(names) if s.startswith("ED " + w)) for w in wanted.values()]
    vel = [
        next(i for i, s in enumerate(names) if "First time derivative of " + w in s)
        for w in wanted.values()
    ]
    found = identify_modes(a, pos, vel, list(wanted), (1.0, 1.0, PITCH_LENGTH_M, 1.0))
    return {m.name: m for m in found}


def test_openfast_linearisation_gives_the_quoted_periods(openfast_modes: dict[str, Mode]) -> None:
    for name, period in OPENFAST_PERIODS_S.items():
        assert openfast_modes[name].period_s == pytest.approx(period, rel=5e-3), name


@pytest.mark.parametrize(("name", "rel"), [("surge", 0.10), ("heave", 0.05), ("pitch", 0.05)])
def test_platform_periods_match_openfast(
    modes: dict[str, Mode], openfast_modes: dict[str, Mode], name: str, rel: float
) -> None:
    assert modes[name].period_s == pytest.approx(openfast_modes[name].period_s, rel=rel)


@pytest.mark.xfail(
    strict=False,
    reason="tower fore-aft mode: 1.93 s here vs 2.23 s in lin_00. lin_00's tower column of A is "
    "0.745 of ours (sqrt(1/0.745) x 1.93 s = 2.23 s); its static heave -0.021 m vs ours -0.356 m "
    "means about 150 t less weight; lin_00 came from a Feb 2021 WEIS deck, while our deck's "
    "tower weighs 1467 t (rosco 2.10.6) vs 1263 t in the VolturnUS-S report: the linearisation "
    "was made with another tower. Not tuned by hand (see plant/modes.py)",
)
def test_tower_period_matches_openfast(
    modes: dict[str, Mode], openfast_modes: dict[str, Mode]
) -> None:
    got = modes["tower_fore_aft"].period_s
    assert got == pytest.approx(openfast_modes["tower_fore_aft"].period_s, rel=0.05)


def test_modes_are_json_serialisable_and_damped(modes: dict[str, Mode]) -> None:
    text = json.dumps([m.as_dict() for m in modes.values()])
    back = json.loads(text)
    assert {d["name"] for d in back} == {"surge", "heave", "pitch", "tower_fore_aft"}
    for m in modes.values():
        assert 0.0 < m.damping_ratio < 0.5
        assert m.eigenvalue[0] < 0.0
