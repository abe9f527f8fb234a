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
from plant.platform import FloatingParams

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
# Below rated the linearisations hold ServoDyn's generator-torque law in A (the rotor-speed row
# ∂ω̇/∂ω is -0.098 and -1.118 1/s at 5 and 9 m/s against an aerodynamic -0.039 and -0.069 here);
# above rated the torque is constant (ServoDyn region 3), the open-loop case of the bench.
BELOW_RATED = (5.0, 9.0)


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


def _openfast_modes(path: Path, azimuth_averaged: bool = True) -> dict[str, Mode]:
    """Natural modes of a ``.lin`` file's A matrix.

    ``azimuth_averaged``: drop the generator-azimuth state ψ (its row and column). Each file is
    one linearisation at one rotor azimuth (ψ = 0.014 rad), and its A carries ∂F/∂ψ, the slope
    of the 3P-periodic rotor loads (shear 0.12, tilt, the tower's potential-flow influence) at
    that azimuth: 0.27 m/s² per rad in the tower row and 0.017 1/s² in the rotor-speed row at
    15 m/s. Averaged over a revolution, the derivative of a periodic load is zero, so the
    azimuth-averaged (MBC) model that a rotor-disc model like the bench's stands for has no ψ
    column; the usual practice removes the state. Kept, the slope at ψ = 0 shortens the pitch
    period by 3.4 % (15 m/s) and 4.3 % (19 m/s) and changes nothing at 5 m/s.
    """
    a, names, _ = _lin_or_skip(path)
    if azimuth_averaged:
        az = next(i for i, s in enumerate(names) if s.startswith("ED Variable speed generator"))
        keep = [i for i in range(len(names)) if i != az]
        a = a[np.ix_(keep, keep)]
        names = [names[i] for i in keep]
    pos = [next(i for i, s in enumerate(names) if s.startswith("ED " + w)) for w in WANTED.values()]
    vel = [
        next(i for i, s in enumerate(names) if "First time derivative of " + w in s)
        for w in WANTED.values()
    ]
    found = identify_modes(a, pos, vel, list(WANTED), (1.0, 1.0, PITCH_LENGTH_M, 1.0))
    return {m.name: m for m in found}


def _lin_torque_slope(params: FloatingParams, wind: float, path: Path) -> float:
    """Generator-torque slope k (N m s/rad) of the linearisation's rotor-speed row.

    k = −(∂ω̇/∂ω|lin − ∂ω̇/∂ω|aero, here) J: the part of the linearisation's ∂ω̇/∂ω that is not
    aerodynamic, ServoDyn's torque law (about 1.9e7 at 5 m/s, 3.3e8 at 9 m/s).
    """
    a_of, names, _ = _lin_or_skip(path)
    w = next(i for i, s in enumerate(names) if "First time derivative of Variable speed" in s)
    a = linearize(params, operating_point(params, wind))
    return float(-(a_of[w, w] - a[8, 8]) * params.turbine.drivetrain_inertia_kg_m2)


@pytest.fixture(scope="module")
def modes(params: FloatingParams) -> dict[str, Mode]:
    return {m.name: m for m in natural_modes(params, 5.0)}


@pytest.fixture(scope="module")
def openfast_modes() -> dict[str, Mode]:
    return _openfast_modes(LIN, azimuth_averaged=False)


_BENCH_CACHE: dict[float, dict[str, Mode]] = {}


def _bench_modes(params: FloatingParams, wind: float) -> dict[str, Mode]:
    """The bench's modes in the linearisation's case (torque law below rated, held above)."""
    if wind not in _BENCH_CACHE:
        path = LIN_DIR / f"lin_{LIN_FILES[wind]}.1.lin"
        slope = _lin_torque_slope(params, wind, path) if wind in BELOW_RATED else 0.0
        modes = natural_modes(params, wind, torque_slope_nm_s_rad=slope)
        _BENCH_CACHE[wind] = {m.name: m for m in modes}
    return _BENCH_CACHE[wind]


def test_openfast_linearisation_gives_the_quoted_periods(openfast_modes: dict[str, Mode]) -> None:
    """DESIGN.md's periods of lin_00 as written in the file (generator azimuth kept)."""
    for name, period in OPENFAST_PERIODS_S.items():
        assert openfast_modes[name].period_s == pytest.approx(period, rel=5e-3), name


@pytest.mark.parametrize("name", ["surge", "heave", "pitch"])
@pytest.mark.parametrize("wind", list(LIN_FILES))
def test_platform_periods_match_openfast_at_every_operating_point(
    params: FloatingParams, wind: float, name: str
) -> None:
    """Damped surge, heave and pitch periods within 5 % of the OpenFAST linearisation.

    The case compared is the linearisations': no pitch controller (blade pitch held); generator
    torque held above rated (ServoDyn's region 3, the bench's open-loop case) and, below rated
    (5, 9 m/s), ServoDyn's torque law, which the linearisations hold in A, put in the bench's
    loop with the slope read from the file (``_lin_torque_slope``; ``fowt analyze modes
    --torque-slope``). The linearisation is azimuth-averaged (``_openfast_modes``). Measured:
    surge -0.8..+2.7 %, heave +0.3 %, pitch +0.3..+3.5 % (12 m/s +3.5, 15 +2.2, 19 +2.8,
    24 +1.1); the locked-rotor offset of about +2 % is the 2020 turbine of the linearisations
    (plant/modes.py). Open loop at 9 m/s would be -5.2 % in surge and -12.5 % in pitch.
    """
    ref = _openfast_modes(LIN_DIR / f"lin_{LIN_FILES[wind]}.1.lin")
    got = _bench_modes(params, wind)
    assert got[name].period_s == pytest.approx(ref[name].period_s, rel=0.05)


def test_single_azimuth_slope_is_what_shortened_the_linearisations_pitch(
    params: FloatingParams,
) -> None:
    """With the azimuth state kept, lin_10's pitch is 28.43 s; azimuth-averaged 29.44 s.

    The bench (30.09 s open loop at 15 m/s) is 5.8 % longer than the former and 2.2 % longer
    than the latter; the azimuth column is the only difference between the two references.
    """
    path = LIN_DIR / "lin_10.1.lin"
    raw = _openfast_modes(path, azimuth_averaged=False)["pitch"].period_s
    avg = _openfast_modes(path)["pitch"].period_s
    assert raw == pytest.approx(28.43, abs=0.02)
    assert avg == pytest.approx(29.44, abs=0.02)
    got = _bench_modes(params, 15.0)["pitch"].period_s
    assert got / raw - 1.0 > 0.05
    assert abs(got / avg - 1.0) < 0.03


@pytest.mark.parametrize("wind", [5.0, 9.0])
def test_below_rated_open_loop_differs_from_the_torque_law_case(
    params: FloatingParams, wind: float
) -> None:
    """Below rated the torque law is what the comparison needs: open loop, pitch is 12 % short
    at 9 m/s (24.69 s against 28.23 s); with the linearisation's slope, 1.6 % long."""
    ref = _openfast_modes(LIN_DIR / f"lin_{LIN_FILES[wind]}.1.lin")
    open_loop = {m.name: m for m in natural_modes(params, wind)}
    closed = _bench_modes(params, wind)
    assert _lin_torque_slope(params, wind, LIN_DIR / f"lin_{LIN_FILES[wind]}.1.lin") > 0.0
    assert abs(closed["pitch"].period_s / ref["pitch"].period_s - 1.0) < 0.05
    if wind == 9.0:
        assert open_loop["pitch"].period_s / ref["pitch"].period_s - 1.0 < -0.10


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


@pytest.mark.parametrize(
    ("preset", "wind_m_s"),
    [
        ("iea15mw_volturnus", 0.0),
        ("iea15mw_volturnus", 8.0),
        ("iea15mw_volturnus", 15.0),
        ("nrel5mw_oc3_hywind", 9.5),  # the root 19.26 m lies beside the mooring table's 19 m knot
        ("nrel5mw_oc3_hywind", 18.0),
    ],
)
def test_newton_equilibrium_is_fsolves(preset: str, wind_m_s: float) -> None:
    """The static equilibrium by the module's Newton iterations (no scipy.optimize import at
    a run's start) equals scipy's fsolve (with the surge bracket where fsolve stalls) to
    1e-9 m and 1e-12 rad; both leave a residual below 1e-9."""
    from scipy.optimize import fsolve

    from plant import modes
    from plant.platform import load_floating

    params = load_floating(preset)
    op = modes.operating_point(params, wind_m_s)
    q_newton = np.array(op.state[:4])
    omega, theta, torque = op.state[8], op.state[9], op.state[10]
    nr = params.n_radiation

    def residual(q: np.ndarray) -> np.ndarray:
        x = (*(float(v) for v in q), 0.0, 0.0, 0.0, 0.0, omega, theta, torque, *([0.0] * nr))
        dx = modes.f(0.0, x, op.inputs, params)
        return np.array(dx[4:8]) * np.array([1.0, 1.0, modes.PITCH_LENGTH_M, 1.0])

    q_f, _, ier, msg = fsolve(residual, np.zeros(4), full_output=True, xtol=1e-12)
    if ier != 1 and float(np.max(np.abs(residual(q_f)))) > 1e-9:
        q_f = modes._bracketed_equilibrium(residual, q_f, wind_m_s, msg)
    assert float(np.max(np.abs(residual(q_newton)))) < 1e-9
    assert float(np.max(np.abs(residual(q_f)))) < 1e-9
    np.testing.assert_allclose(q_newton[[0, 1, 3]], q_f[[0, 1, 3]], rtol=0, atol=1e-9)
    assert abs(q_newton[2] - q_f[2]) < 1e-12


def test_an_equilibrium_on_a_mooring_table_knot_is_found() -> None:
    """A rotor point whose thrust puts the platform on a knot of the mooring table.

    The IEA 15 MW at 11 m/s held at 7.508 rpm and 2.29° pitch (a baseline without peak
    shaving settles there): the table's heave/pitch slope changes at its 21 m knot, so the
    surge force steps there and the surge residual changes sign without a zero. The
    equilibrium is the knot (1e-6 m) with heave, pitch and tower solved (residual < 1e-9) and
    the surge residual no larger than the step; its surge lies between those of the
    neighbouring pitch angles' equilibria (3.23° and 1.5°: less and more thrust).
    """
    import math

    from plant import modes
    from plant import turbine as turbine_model
    from plant.platform import load_floating

    params = load_floating("iea15mw_volturnus")
    omega = 7.508 * math.pi / 30.0

    def held(theta_deg: float) -> modes.OperatingPoint:
        theta = math.radians(theta_deg)

        def rotor(u_n: float) -> tuple[float, float, float]:
            out = turbine_model.outputs(0.0, (omega, theta, 0.0), (theta, 0.0, u_n), params.turbine)
            return omega, theta, max(0.0, out.aero_torque_nm / params.turbine.gearbox_ratio)

        return modes.operating_point(params, 11.0, rotor=rotor)

    op = held(2.29)
    assert abs(op.state[0] - 21.0) < 1e-6
    nr = params.n_radiation

    def residual(q: np.ndarray) -> np.ndarray:
        x = (*(float(v) for v in q), 0.0, 0.0, 0.0, 0.0, *op.state[8:11], *([0.0] * nr))
        dx = modes.f(0.0, x, op.inputs, params)
        return np.array(dx[4:8]) * np.array([1.0, 1.0, modes.PITCH_LENGTH_M, 1.0])

    q = np.array(op.state[:4])
    r = residual(q)
    assert float(np.max(np.abs(r[1:]))) < 1e-9
    assert 0.0 < abs(float(r[0])) < 1e-4  # the step: tens of newtons on a 2e7 kg platform
    assert held(3.23).state[0] < op.state[0] < held(1.5).state[0]
