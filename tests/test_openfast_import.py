"""OpenFAST deck importer: figures equal the deck's, round trip through write_preset/load."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from plant.platform import load_floating, read_floating_preset

REFERENCE = Path(__file__).resolve().parents[2] / "shared" / "reference"
FST = REFERENCE / "openfast" / "IEA-15-240-RWT-UMaineSemi" / "IEA-15-240-RWT-UMaineSemi.fst"


@pytest.fixture(scope="module")
def deck():  # type: ignore[no-untyped-def]
    if not FST.is_file():
        pytest.skip(f"OpenFAST deck not available at {FST} (../shared absent)")
    pytest.importorskip("moorpy", reason="moorpy (extra [mooring]) needed to solve the mooring")
    from plant.openfast_import import import_openfast

    return import_openfast(FST, name="IEA 15 MW on UMaine VolturnUS-S")


def test_masses_and_geometry_equal_the_deck(deck) -> None:  # type: ignore[no-untyped-def]
    p = deck.preset
    assert p.platform_mass_kg == 1.7838e7  # ElastoDyn PtfmMass
    assert p.platform_pitch_inertia_kg_m2 == 1.2507e10  # PtfmPIner
    assert p.platform_cm_z_m == -14.4  # PtfmCMzt
    assert (p.hub_mass_kg, p.nacelle_mass_kg, p.yaw_bearing_mass_kg) == (69131, 644857, 28249)
    assert (p.tower_top_height_m, p.tower_base_height_m) == (144.386, 15.0)
    assert p.tower_damping_ratio == pytest.approx(0.01)  # TwrFADmp(1) = 1 %
    assert p.tower_mode_shape_coefficients[0] == pytest.approx(0.9406819250212723)
    assert p.displaced_volume_m3 == pytest.approx(20206.34889)
    assert p.tower_top_height_m + p.rotor_apex_z_m == pytest.approx(150.0, abs=1e-3)
    assert p.additional_quadratic_damping[0][0] == 9.23e5
    assert p.additional_quadratic_damping[4][4] == 1.68e10
    assert (p.water_density_kg_m3, p.water_depth_m) == (1025.0, 200.0)


def test_mooring_surge_stiffness_is_plausible(deck) -> None:  # type: ignore[no-untyped-def]
    m = deck.mooring
    i0 = m.surge_m.index(0.0)
    k11 = -(m.force_surge_n[i0 + 1] - m.force_surge_n[i0 - 1]) / 2.0
    assert 6e4 < k11 < 1e5  # N/m, VolturnUS-S
    assert m.force_heave_n[i0] < 0.0  # lines pull the platform down
    # Stiffening with offset: the catenary hardens downwind.
    assert -(m.force_surge_n[-1] - m.force_surge_n[-2]) > k11


def test_round_trip_gives_the_shipped_figures(deck, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from plant.openfast_import import write_preset

    toml = write_preset(deck, tmp_path, "volturnus")
    back, _, _ = read_floating_preset(toml)
    assert back == deck.preset.__class__(
        **{
            **{k: getattr(deck.preset, k) for k in deck.preset.__struct_fields__},
            "hydro_file": "volturnus_hydro.npz",
            "mooring_file": "volturnus_mooring.json",
            "radiation_file": "volturnus_radiation.npz",
        }
    )
    loaded = load_floating(toml, radiation=False)
    shipped = load_floating("iea15mw_volturnus", radiation=False)
    for name in ("mass_matrix", "stiffness", "static_force", "linear_damping", "hub_lever"):
        np.testing.assert_allclose(getattr(loaded, name), getattr(shipped, name), rtol=1e-9)
    np.testing.assert_allclose(
        loaded.mooring.force_surge_n, shipped.mooring.force_surge_n, rtol=1e-6, atol=1.0
    )
