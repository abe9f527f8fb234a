"""Natural modes of the IEA 15 MW / VolturnUS-S preset against the OpenFAST linearisations."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from plant.modes import (
    PITCH_LENGTH_M,
    Mode,
    identify_modes,
    linearize,
    natural_modes,
    operating_point,
)
from plant.platform import FloatingParams, load_floating

REFERENCE = Path(__file__).resolve().parents[2] / "shared" / "reference"
LIN_DIR = REFERENCE / "openfast" / "IEA-15-240-RWT-UMaineSemi" / "linearizations"
LIN_FILES = {5.0: "00", 9.0: "04", 12.0: "07", 15.0: "10", 19.0: "14", 24.0: "19"}
LIN = LIN_DIR / "lin_00.1.lin"
# Damped periods at 5 m/s quoted in DESIGN.md from lin_00 (s).
OPENFAST_PERIODS_S = {"surge": 123.2, "heave": 20.4, "pitch": 27.3, "tower_fore_aft": 2.23}
WANTED = {
    "surge": "Platform horizontal surge",
    "heave": "Platform vertical heave",
    "pitch": "Platform pitch tilt",
    "tower_fore_aft": "1st tower fore-aft",
}
# Outside 5 % (measured; the reasons in plant/modes.py, "Against the OpenFAST linearisations").
KNOWN_GAPS = {
    (9.0, "pitch"): "-11.8 %: lin_04's A holds ServoDyn's generator-torque law (dw/dt per w "
    "-1.118 1/s against -0.069 aerodynamic here, a slope of about 3.3e8 N m s/rad); the bench "
    "analyses the open-loop case (torque held); with that slope in the loop, 2.4 % "
    "(test_below_rated_with_the_linearisations_torque_law_in_the_loop)",
    (15.0, "pitch"): "+5.8 %: the rotor-speed loop lengthens the pitch period 5.5 % here, 1.5 % "
    "in lin_10. Not the aerodynamic derivatives (lin_10's own AeroDyn Jacobians in this A: "
    "+5.2 %), not a frozen wake (lin_10 is equilibrium-wake: tests/test_rotor_bem.py; frozen "
    "derivatives here: +8.4 %); with all rigid-body and rotor-row entries of lin_10 in the "
    "condensed A still +3.4 %; rotor speed locked, +1.8 % (plant/modes.py)",
    (19.0, "pitch"): "+7.5 %: as at 15 m/s (lin_14's derivatives in this A: +6.1 %; all "
    "rigid-body and rotor-row entries: +4.4 %); rotor speed locked, +2.2 %",
}


def _read_lin(path: Path) -> tuple[np.ndarray, list[str], list[float]]:
    """A matrix, state names and operating-point values of an OpenFAST ``.lin`` file."""
    lines = path.read_text().splitlines()
    start = next(i for i, s in enumerate(lines) if s.startswith("Order of continuous states:"))
    names: list[str] = []
    values: list[float] = []
    for s in lines[start + 3 :]:
        if not s.strip():
            break
        names.append(s.split(None, 4)[4])
        values.append(float(s.split()[1]))
    row = next(i for i, s in enumerate(lines) if s.startswith("A:"))
    n = int(lines[row].split()[1])
    a = np.array([[float(v) for v in lines[row + 1 + r].split()] for r in range(n)])
    return a, names, values


def _lin_or_skip(path: Path) -> tuple[np.ndarray, list[str], list[float]]:
    if not path.is_file():
        pytest.skip(f"reference linearisation not available at {path} (../shared absent)")
    return _read_lin(path)


def _openfast_modes(path: Path) -> dict[str, Mode]:
    a, names, _ = _lin_or_skip(path)
    pos = [next(i for i, s in enumerate(names) if s.startswith("ED " + w)) for w in WANTED.values()]
    vel = [
        next(i for i, s in enumerate(names) if "First time derivative of " + w in s)
        for w in WANTED.values()
    ]
    found = identify_modes(a, pos, vel, list(WANTED), (1.0, 1.0, PITCH_LENGTH_M, 1.0))
    return {m.name: m for m in found}


@pytest.fixture(scope="module")
def params() -> FloatingParams:
    return load_floating("iea15mw_volturnus")


@pytest.fixture(scope="module")
def modes(params: FloatingParams) -> dict[str, Mode]:
    return {m.name: m for m in natural_modes(params, 5.0)}


@pytest.fixture(scope="module")
def openfast_modes() -> dict[str, Mode]:
    return _openfast_modes(LIN)


_BENCH_CACHE: dict[float, dict[str, Mode]] = {}


def _bench_modes(params: FloatingParams, wind: float) -> dict[str, Mode]:
    if wind not in _BENCH_CACHE:
        _BENCH_CACHE[wind] = {m.name: m for m in natural_modes(params, wind)}
    return _BENCH_CACHE[wind]


def test_openfast_linearisation_gives_the_quoted_periods(openfast_modes: dict[str, Mode]) -> None:
    for name, period in OPENFAST_PERIODS_S.items():
        assert openfast_modes[name].period_s == pytest.approx(period, rel=5e-3), name


@pytest.mark.parametrize("name", ["surge", "heave", "pitch"])
@pytest.mark.parametrize("wind", list(LIN_FILES))
def test_platform_periods_match_openfast_at_every_operating_point(
    params: FloatingParams, wind: float, name: str, request: pytest.FixtureRequest
) -> None:
    """Damped surge, heave and pitch periods within 5 % of the OpenFAST linearisation.

    Open loop in both (no controller; blade pitch and generator torque held; rotor speed free),
    except that the linearisations below rated hold ServoDyn's generator-torque law in A. The
    cases outside 5 % are expected failures with their measured reason (``KNOWN_GAPS``; strict,
    so that a fix shows up as a failure to be removed from the list).
    """
    if (wind, name) in KNOWN_GAPS:
        request.applymarker(pytest.mark.xfail(strict=True, reason=KNOWN_GAPS[(wind, name)]))
    ref = _openfast_modes(LIN_DIR / f"lin_{LIN_FILES[wind]}.1.lin")
    got = _bench_modes(params, wind)
    assert got[name].period_s == pytest.approx(ref[name].period_s, rel=0.05)


@pytest.mark.parametrize("wind", [5.0, 9.0])
def test_below_rated_with_the_linearisations_torque_law_in_the_loop(
    params: FloatingParams, wind: float
) -> None:
    """Below rated, with the generator-torque slope the linearisation holds: periods within 5 %.

    The slope k is read from the ``.lin`` A matrix: k = −(∂ω̇/∂ω|lin − ∂ω̇/∂ω|aero, here) J
    (about 1.9e7 N m s/rad at 5 m/s and 3.3e8 at 9 m/s), so that the rotor-speed dynamics
    are those of the linearisation; then pitch is within 0.4 % (5 m/s) and 2.4 % (9 m/s).
    """
    path = LIN_DIR / f"lin_{LIN_FILES[wind]}.1.lin"
    a_of, _, _ = _lin_or_skip(path)
    a = linearize(params, operating_point(params, wind))
    slope = -(a_of[9, 9] - a[8, 8]) * params.turbine.drivetrain_inertia_kg_m2
    assert slope > 0.0
    got = {m.name: m for m in natural_modes(params, wind, torque_slope_nm_s_rad=slope)}
    ref = _openfast_modes(path)
    for name in ("surge", "heave", "pitch"):
        assert got[name].period_s == pytest.approx(ref[name].period_s, rel=0.05), name


def test_trim_at_15_m_s_matches_openfast(params: FloatingParams) -> None:
    """Surge offset, platform pitch and blade pitch at 15 m/s within 5 % of lin_10's.

    lin_10: 14.59 m, 0.0390 rad, 0.1982 rad; here 14.57 m, 0.0377 rad, 0.1995 rad (the thrust
    along the tilted shaft, the tower drag and the rotor trim at the rotor-normal wind).
    """
    _, _, ref = _lin_or_skip(LIN_DIR / "lin_10.1.lin")
    op = operating_point(params, 15.0)
    assert op.state[0] == pytest.approx(ref[0], rel=0.05)
    assert op.state[2] == pytest.approx(ref[2], rel=0.05)
    assert op.state[9] == pytest.approx(0.1982, rel=0.05)  # lin_10 blade-pitch input


@pytest.mark.parametrize("wind", [15.0, 24.0])
def test_rotor_speed_responds_to_platform_pitch_through_the_shaft_tilt(
    params: FloatingParams, wind: float
) -> None:
    """∂ω̇/∂φ within 20 % of the linearisation's (0 without the tilt geometry).

    The rotor-normal wind U cos(τ + φ)/cos τ falls with the platform pitch φ (τ = 6°), so
    ∂ω̇/∂φ = −(∂Q/∂U) U sin(τ + φ₀)/(J cos τ): lin_10 −3.27e-2, lin_19 −6.82e-2 1/s².
    """
    a_of, _, _ = _lin_or_skip(LIN_DIR / f"lin_{LIN_FILES[wind]}.1.lin")
    a = linearize(params, operating_point(params, wind))
    assert a[8, 2] == pytest.approx(a_of[9, 2], rel=0.20)


def test_tower_period_matches_the_current_deck(modes: dict[str, Mode]) -> None:
    """First tower fore-aft period within 5 % of 1.99 s (0.5023 Hz).

    Reference: an OpenFAST linearisation of the current IEA-15-240-RWT deck gives 0.5023 Hz =
    1.99 s (IEAWindSystems/IEA-15-240-RWT issue #261); the v1.1 release notes give "around
    0.49 Hz". The six linearisations shipped in ``../shared`` reproduce the 2020 (v1.0) model
    with a 1,263 t tower (2.23 s); the deck this preset is imported from carries the redesigned
    1,466.5 t tower. This model has rigid blades (1.93 s); flexible blades lower the tower
    frequency a little through the coupling with their flapwise mode (plant/modes.py).
    """
    assert modes["tower_fore_aft"].period_s == pytest.approx(1.99, rel=0.05)


def test_modes_are_json_serialisable_and_damped(modes: dict[str, Mode]) -> None:
    text = json.dumps([m.as_dict() for m in modes.values()])
    back = json.loads(text)
    assert {d["name"] for d in back} == {"surge", "heave", "pitch", "tower_fore_aft"}
    for m in modes.values():
        assert 0.0 < m.damping_ratio < 0.5
        assert m.eigenvalue[0] < 0.0
