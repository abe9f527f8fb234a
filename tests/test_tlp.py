"""The ``nrel5mw_tlp`` preset (casanovas-2014): surge + rotor, locked DOFs, order-4 radiation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from plant.hydro.radiation import RadiationModel
from plant.hydro.wamit import load_hydro_preset
from plant.modes import natural_modes, operating_point
from plant.platform import (
    FloatingParams,
    inverse_mass_matrix,
    load_floating,
    read_floating_preset,
    step_floating,
)

# casanovas-2014 App. I: 3 arms x 2 tendons x 1800 kN; tendon length 100 m depth + 15 m arms.
TENSION_N = 6 * 1.8e6
TENDON_M = 115.0


@pytest.fixture(scope="module")
def tlp() -> FloatingParams:
    return load_floating("nrel5mw_tlp")


def test_preset_loads_as_surge_plus_rotor(tlp: FloatingParams) -> None:
    preset, _, _ = read_floating_preset("nrel5mw_tlp")
    assert preset.turbine == "nrel5mw"
    assert preset.locked_dofs == ["heave", "pitch", "tower_fore_aft"]
    assert tlp.locked_dofs == (1, 2, 3)
    assert tlp.n_radiation == 4
    # Buoyancy balance of the seed: ρ g V = m g + T (V of the R 4.75 m, draft 30 m buoy).
    volume = math.pi * 4.75**2 * 30.0
    assert preset.displaced_volume_m3 == pytest.approx(volume, rel=1e-6)
    total = (
        tlp.mass_matrix[0, 0]
        - load_hydro_preset("nrel5mw_tlp_buoy_bem").radiation.added_mass_inf[0, 0]
    )
    assert total * 9.81 + TENSION_N == pytest.approx(1025.0 * 9.81 * volume, rel=1e-6)
    # Tendon surge stiffness T/L (mooring table).
    assert tlp.mooring.stiffness_at(0.0) == pytest.approx(TENSION_N / TENDON_M, rel=1e-9)


def test_inverse_mass_matrix_of_locked_dofs() -> None:
    rng = np.random.default_rng(3)
    a = rng.normal(size=(4, 4))
    m = a @ a.T + 4.0 * np.eye(4)
    inv = inverse_mass_matrix(m, (1, 3))
    free = [0, 2]
    np.testing.assert_allclose(inv[np.ix_(free, free)], np.linalg.inv(m[np.ix_(free, free)]))
    assert not inv[[1, 3], :].any() and not inv[:, [1, 3]].any()
    np.testing.assert_allclose(inverse_mass_matrix(m), np.linalg.inv(m))


def test_surge_natural_period_matches_the_hand_formula(tlp: FloatingParams) -> None:
    """The seed gives no surge period; check T = 2π √((m + A(ω_n)) / (T/L)) within 5 %.

    m is the total mass (structure), A(ω_n) the BEM added mass at the natural frequency, T/L the
    tendon stiffness; ``natural_modes`` (5 m/s, with aero and radiation damping) gives the damped
    period, within 1 % of this for the few % damping here.
    """
    hydro = load_hydro_preset("nrel5mw_tlp_buoy_bem").radiation
    mass = tlp.mass_matrix[0, 0] - hydro.added_mass_inf[0, 0]
    stiffness = TENSION_N / TENDON_M
    wn = 0.2
    for _ in range(100):
        a = float(np.interp(wn, hydro.omega_rad_s, hydro.added_mass[:, 0, 0]))
        wn = math.sqrt(stiffness / (mass + a))
    hand = 2.0 * math.pi / wn
    modes = {m.name: m for m in natural_modes(tlp)}
    assert set(modes) == {"surge"}  # heave, pitch and tower are locked
    assert modes["surge"].period_s == pytest.approx(hand, rel=0.05)
    assert 30.0 < hand < 40.0


def test_radiation_fit_is_order_4_within_2_percent() -> None:
    from importlib import resources

    ref = resources.files("plant.presets").joinpath("hydro", "nrel5mw_tlp_radiation.npz")
    with resources.as_file(ref) as path:
        model = RadiationModel.load_npz(path)
    assert model.order == 4 and model.dofs == (0,)
    assert np.max(np.linalg.eigvals(model.A).real) < 0.0
    rad = load_hydro_preset("nrel5mw_tlp_buoy_bem").radiation
    band = rad.omega_rad_s <= 2.0
    w = rad.omega_rad_s[band]
    a, b, a_inf = rad.added_mass[band, 0, 0], rad.damping[band, 0, 0], rad.added_mass_inf[0, 0]
    k = model.frequency_response(w)[:, 0, 0]
    err_a = np.max(np.abs(a_inf + k.imag / w - a)) / np.max(np.abs(a - a_inf))
    err_b = np.max(np.abs(k.real - b)) / np.max(b)
    assert err_a < 0.02 and err_b < 0.02
    # Passive: Re K̂ ≥ 0 everywhere.
    wide = np.logspace(-4, 3, 4000)
    assert np.min(model.frequency_response(wide)[:, 0, 0].real) >= 0.0


def test_locked_dofs_never_move_under_waves_and_thrust(tlp: FloatingParams) -> None:
    op = operating_point(tlp, 8.0)
    x = tuple(op.state)
    theta, torque = op.inputs[0], op.inputs[1]
    surge = []
    for k in range(4000):
        t = 0.01 * k
        u = (
            theta,
            torque,
            8.0 + 3.0 * math.sin(0.3 * t),
            6e5 * math.sin(0.8 * t),
            4e5 * math.sin(0.8 * t + 1.0),
            5e6 * math.sin(0.8 * t + 2.0),
        )
        x = step_floating(t, x, u, 0.01, tlp)
        surge.append(x[0])
        assert x[1] == 0.0 and x[2] == 0.0 and x[3] == 0.0  # heave, pitch, tower
        assert x[5] == 0.0 and x[6] == 0.0 and x[7] == 0.0
    assert np.ptp(surge) > 0.1  # surge does respond
    assert all(math.isfinite(v) for v in x)
