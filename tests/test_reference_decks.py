"""The OC3-Hywind and OC4-DeepCwind decks of :mod:`plant.reference_decks` import unedited.

Both format generations (FAST v8 / pre-3.5 and OpenFAST 4) are written into ``tmp_path`` and
read by :func:`plant.openfast_import.import_openfast` as written; the imported platform's
mass, centre of mass and pitch inertia are checked against the deck's own totals (OC3:
ElastoDyn ``PtfmMass``, ``PtfmCMzt``, ``PtfmPIner`` of Jonkman 2010; OC4: the definition's
totals with the fill-group ballast, Robertson et al. 2014). No capytaine needed: OC3 uses the
shipped spar data; the OC4 mass checks carry the shipped OC3 spar data as stand-in WAMIT files
(the hydrodynamic data do not enter the mass, CM, inertia or strip-theory member figures). The
capytaine test of the OC4 columns skips cleanly without the ``[hydro]`` extra.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from plant.hydro.semi_bem import OC4_COLUMNS, columns_hydrostatics
from plant.hydro.wamit import import_wamit, load_hydro_preset, write_wamit
from plant.openfast_import import import_openfast, write_preset
from plant.platform import load_floating
from plant.reference_decks import GENERATIONS, write_deck

RHO, G = 1025.0, 9.80665


@pytest.mark.parametrize("generation", GENERATIONS)
def test_oc3_deck_imports_with_the_deck_totals(tmp_path: Path, generation: str) -> None:
    deck = import_openfast(write_deck(tmp_path, "oc3", generation), turbine="nrel5mw")
    p = deck.preset
    assert p.platform_mass_kg == 7_466_330.0  # PtfmMass (incl. ballast)
    assert p.platform_cm_z_m == -89.9155
    assert p.platform_pitch_inertia_kg_m2 == 4.22923e9
    assert p.gravity_m_s2 == 9.80665 and p.water_depth_m == 320.0
    # the spar profile's volume; Jonkman (2010): 8029.21 m³
    assert p.displaced_volume_m3 == pytest.approx(8029.21, rel=2e-5)
    tower = dict(deck.mass_budget)["tower"]
    assert tower == pytest.approx(249_718.0, rel=1e-3)  # Jonkman (2010) tower mass
    assert p.additional_linear_stiffness[5][5] == 9.834e7  # the crowfoot's yaw spring
    assert deck.members is None  # the spar is all in the WAMIT model
    assert len(deck.mooring.lines) == 3
    assert deck.mooring.lines[0]["length_m"] == 902.2


@pytest.mark.parametrize("generation", GENERATIONS)
def test_oc4_deck_imports_with_the_definition_totals(tmp_path: Path, generation: str) -> None:
    """Platform 1.3473e7 kg with ballast, CM −13.46 m (Robertson 2014) within 0.05 % / 1 cm;
    pitch inertia within 5 % of the definition's 6.827e9 kg m² (the fill-group ballast as
    solid water cylinders gives 7.10e9: the definition's figure is not reproduced exactly);
    the WAMIT columns plus the strip-theory pontoons and braces displace the r-test's
    PtfmVol0 of 13917 m³ within 0.3 %."""
    stand_in = load_hydro_preset("nrel5mw_oc3_hywind")
    deck = import_openfast(
        write_deck(tmp_path, "oc4", generation, stand_in), turbine="nrel5mw", mooring=False
    )
    p = deck.preset
    assert p.platform_mass_kg == pytest.approx(1.3473e7, rel=5e-4)
    assert p.platform_cm_z_m == pytest.approx(-13.46, abs=0.01)
    assert p.platform_pitch_inertia_kg_m2 == pytest.approx(6.827e9, rel=0.05)
    m = deck.members
    assert m is not None and m.count == 15
    assert p.displaced_volume_m3 + m.volume_m3 == pytest.approx(13917.0, rel=3e-3)
    # pontoons D 1.6 m: the cross braces pierce the SWL (3 x π 0.8² / cos of their tilt)
    assert m.waterplane_area_m2 > 3 * math.pi * 0.8**2
    assert m.force_n[2] == pytest.approx(RHO * G * m.volume_m3, rel=1e-12)
    # tri-symmetric: the centre of buoyancy on the axis (to the joints' 5 decimals), so the
    # members' pitch moment is nil
    assert abs(m.cb_x_m) < 1e-3
    assert m.force_n[4] == pytest.approx(-m.force_n[2] * m.cb_x_m, rel=1e-9)
    assert p.member_force_n == m.force_n


def test_oc4_members_enter_the_plant_matrices(tmp_path: Path) -> None:
    """The assembled heave stiffness and mass hold the members' C_33 and added mass."""
    stand_in = load_hydro_preset("nrel5mw_oc3_hywind")
    deck = import_openfast(
        write_deck(tmp_path / "deck", "oc4", "openfast4", stand_in),
        turbine="nrel5mw",
        mooring=False,
    )
    toml = write_preset(deck, tmp_path / "preset", "oc4")
    with_members = load_floating(toml, radiation=False)
    text = toml.read_text(encoding="utf-8")
    for key in ("member_force_n", "member_stiffness", "member_added_mass"):
        text = "\n".join(ln for ln in text.splitlines() if not ln.startswith(f"{key} ="))
    bare = tmp_path / "preset" / "bare.toml"
    bare.write_text(text, encoding="utf-8")
    without = load_floating(bare, radiation=False)
    m = deck.members
    assert m is not None
    dk = with_members.stiffness - without.stiffness
    dm = with_members.mass_matrix - without.mass_matrix
    df = with_members.static_force - without.static_force
    assert dk[1, 1] == pytest.approx(m.stiffness[2][2], rel=1e-12)
    assert dk[2, 2] == pytest.approx(m.stiffness[4][4], rel=1e-12)
    assert dm[1, 1] == pytest.approx(m.added_mass[2][2], rel=1e-12)
    assert dm[0, 0] == pytest.approx(m.added_mass[0][0], rel=1e-12)
    assert df[1] == pytest.approx(m.force_n[2], rel=1e-12)


def test_write_wamit_round_trip(tmp_path: Path) -> None:
    """The shipped spar data written as WAMIT files and read back (6 significant digits)."""
    hydro = load_hydro_preset("nrel5mw_oc3_hywind")
    write_wamit(hydro, tmp_path / "spar")
    back = import_wamit(tmp_path / "spar", hydro.rho_kg_m3, hydro.g_m_s2).select((0, 2, 4))
    r, b = hydro.radiation, back.radiation
    np.testing.assert_allclose(b.omega_rad_s, r.omega_rad_s, rtol=1e-6)
    np.testing.assert_allclose(
        b.added_mass, r.added_mass, rtol=1e-5, atol=1e-6 * np.abs(r.added_mass).max()
    )
    np.testing.assert_allclose(b.damping, r.damping, rtol=1e-5, atol=1e-6 * np.abs(r.damping).max())
    np.testing.assert_allclose(b.added_mass_inf, r.added_mass_inf, rtol=1e-5, atol=1.0)
    np.testing.assert_allclose(
        back.excitation.force,
        hydro.excitation.force,
        rtol=1e-5,
        atol=1e-6 * np.abs(hydro.excitation.force).max(),
    )
    np.testing.assert_allclose(back.hydrostatic_stiffness, hydro.hydrostatic_stiffness, rtol=1e-5)


def test_oc4_columns_hydrostatics_analytic() -> None:
    """Columns of the OC4 semi: V = π (3.25² 20 + 3 (6² 14 + 12² 6)) m³; C_33 = ρ g π
    (3.25² + 3 · 6²); no heave-pitch coupling (tri-symmetric)."""
    vol, xb, _, c = columns_hydrostatics(OC4_COLUMNS, RHO, G)
    assert vol == pytest.approx(math.pi * (3.25**2 * 20 + 3 * (36 * 14 + 144 * 6)), rel=1e-9)
    assert abs(xb) < 1e-4
    assert c[1, 1] == pytest.approx(RHO * G * math.pi * (3.25**2 + 3 * 36.0), rel=1e-12)
    assert abs(c[1, 2]) < 1e-3 * c[1, 1]


def test_oc4_columns_bem_coarse() -> None:
    """Capytaine on a coarse mesh of the OC4 columns: symmetric A_∞, heave within 10 % of the
    definition's 14.7e6 kg less the pontoons' share (columns alone: about 13.6e6 kg)."""
    pytest.importorskip("capytaine")
    from plant.hydro.semi_bem import semi_bem

    hydro, _ = semi_bem(np.array([0.5]), panel_m=4.0, n_theta=8)
    a = hydro.radiation.added_mass_inf
    np.testing.assert_allclose(a, a.T)
    assert a[1, 1] == pytest.approx(13.6e6, rel=0.10)


def test_oc3_deck_periods_through_the_command_line(tmp_path: Path) -> None:
    """The OC3 deck (FAST v8 layout) imported unedited with ``fowt preset import-openfast``
    prints the platform's totals, and ``fowt analyze modes --wind 0`` gives the published
    full-system periods of Jonkman (2010): surge 1/0.0080 Hz and heave 1/0.0324 Hz within 1 %,
    pitch 1/0.0343 Hz within 5 % (bench/openfast_import_periods.py: +3.6 %)."""
    import json

    from typer.testing import CliRunner

    from hil.cli.fowt import app

    fst = write_deck(tmp_path / "deck", "oc3", "fast8")
    runner = CliRunner()
    out = tmp_path / "preset"
    args = ["preset", "import-openfast", str(fst), "--out", str(out), "--name", "oc3"]
    result = runner.invoke(app, [*args, "--turbine", "nrel5mw"])
    assert result.exit_code == 0, result.output
    printed = " ".join(result.output.split())  # the console wraps long lines
    assert "platform (structure and ballast): mass 7.46633e+06 kg" in printed
    assert "z -89.9155 m, pitch inertia about its CM 4.22923e+09 kg m^2" in printed
    result = runner.invoke(
        app, ["analyze", "modes", str(out / "oc3.toml"), "--wind", "0", "--json"]
    )
    assert result.exit_code == 0, result.output
    periods = {m["name"]: m["period_s"] for m in json.loads(result.output)["modes"]}
    assert periods["surge"] == pytest.approx(1 / 0.0080, rel=0.01)
    assert periods["heave"] == pytest.approx(1 / 0.0324, rel=0.01)
    assert periods["pitch"] == pytest.approx(1 / 0.0343, rel=0.05)


def test_oc4_deck_imports_with_no_option_when_every_truncation_is_unstable(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The OC4 deck's default import (no ``--radiation-omega-max``) stopped at "the fitted
    state space has unstable poles" with the MARIN WAMIT data. With every balanced
    truncation made unstable here (the stand-in spar data give stable ones), the import
    succeeds, says how the fit was made stable, and the preset loads with a stable model."""
    from typer.testing import CliRunner

    import plant.hydro.radiation as rad
    from hil.cli.fowt import app
    from plant.hydro.radiation import RadiationModel

    exact = rad.balanced_truncation

    def flipped(a, b, c, order):  # type: ignore[no-untyped-def]
        a_r, b_r, c_r, hsv = exact(a, b, c, order)
        lam, vec = np.linalg.eig(a_r)
        moved = np.where(lam.real == lam.real.max(), -lam, lam)
        return (vec @ np.diag(moved) @ np.linalg.inv(vec)).real, b_r, c_r, hsv

    monkeypatch.setattr(rad, "balanced_truncation", flipped)
    stand_in = load_hydro_preset("nrel5mw_oc3_hywind")
    fst = write_deck(tmp_path / "deck", "oc4", "fast8", stand_in)
    out = tmp_path / "preset"
    result = CliRunner().invoke(
        app,
        [
            *("preset", "import-openfast", str(fst), "--out", str(out), "--name", "oc4"),
            *("--turbine", "nrel5mw", "--no-mooring"),
        ],
    )
    assert result.exit_code == 0, result.output
    printed = " ".join(result.output.split())
    assert "radiation fit: the order-" in printed and "truncation stabilised" in printed
    assert "radiation surge-pitch: error A" in printed
    model = RadiationModel.load_npz(out / "oc4_radiation.npz")
    assert np.max(np.linalg.eigvals(model.A).real) < 0.0
    assert load_floating(out / "oc4.toml").radiation_a.shape == model.A.shape
