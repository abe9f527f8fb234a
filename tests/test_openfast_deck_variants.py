"""OpenFAST importer on decks of other versions: hand-written fragments of each layout.

The fragments (tests/data/openfast_decks, README there) cover the FAST v8 and OpenFAST blade
tables, MoorDyn v1 and v2, HydroDyn before and after 3.5 (environment, AddF0 rows, member
tables) with filled member groups, and the ``BldFile(1)`` spelling. Analytic answers: the
blade mass is the trapezoidal integral of the density column; the ballast of a cylinder
flooded to a level is m = ρ π r² h with I_yy = m (r²/4 + h²/12) about its centre.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from plant.openfast_import import (
    Ballast,
    blade_properties,
    flooded_member,
    read_fill_groups,
    read_keyed_file,
    read_moordyn,
)

DECKS = Path(__file__).resolve().parent / "data" / "openfast_decks"
REFERENCE = Path(__file__).resolve().parents[2] / "shared" / "reference" / "openfast"
WAMIT_ROOT = REFERENCE / "IEA-15-240-RWT-UMaineSemi" / "HydroData" / "IEA-15-240-RWT-UMaineSemi"

#: Blade table of the fragments (BlFract, BMassDen in kg/m) and their AdjBlMs.
BLADE_FRACTION = np.array([0.0, 0.1, 0.3, 0.5, 0.8, 1.0])
BLADE_DENSITY = np.array([680.0, 450.0, 390.0, 320.0, 180.0, 10.0])
ADJ_BLADE_MASS = 1.02


def _trapezoid_mass(tip: float, hub: float) -> float:
    r = hub + BLADE_FRACTION * (tip - hub)
    mu = ADJ_BLADE_MASS * BLADE_DENSITY
    return float(np.sum(0.5 * (mu[1:] + mu[:-1]) * np.diff(r)))


@pytest.mark.parametrize("name", ["blade_fast_v8.dat", "blade_openfast.dat"])
def test_blade_mass_is_the_integral_of_the_density_column(name: str) -> None:
    # FAST v8 puts PitchAxis before StrcTwst; a reader by position took twist as density.
    mass, r_cm, _ = blade_properties(DECKS / name, 63.0, 1.5)
    assert mass == pytest.approx(_trapezoid_mass(63.0, 1.5), rel=1e-6)
    assert 1.5 < r_cm < 63.0


def test_unknown_blade_layout_is_refused_with_file_and_line() -> None:
    path = DECKS / "blade_unknown_layout.dat"
    with pytest.raises(ValueError, match="unknown table layout") as err:
        blade_properties(path, 63.0, 1.5)
    line = next(
        i + 1 for i, text in enumerate(path.read_text().splitlines()) if "DISTRIBUTED BLADE" in text
    )
    assert f"{path}:{line}" in str(err.value)
    assert "BMassDen" in str(err.value)


def test_moordyn_v1_and_v2_read_the_same_lines() -> None:
    v1 = read_moordyn(DECKS / "moordyn_v1.dat")
    v2 = read_moordyn(DECKS / "moordyn_v2.dat")
    assert v1 == v2
    assert len(v1) == 3
    assert v1[0].anchor_m == (800.0, 0.0, -180.0)
    assert v1[0].fairlead_m == (40.0, 0.0, -15.0)
    assert (v1[0].length_m, v1[0].diameter_m, v1[0].mass_density_kg_m) == (790.0, 0.09, 110.0)
    assert v1[0].axial_stiffness_n == 7.0e8


def test_moordyn_bad_number_names_file_and_line(tmp_path: Path) -> None:
    text = (DECKS / "moordyn_v1.dat").read_text().splitlines()
    bad = next(i for i, t in enumerate(text) if t.startswith("2       Fixed"))
    text[bad] = text[bad].replace("692.8", "-")
    path = tmp_path / "md.dat"
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(ValueError, match=rf"md\.dat:{bad + 1}: point X Y Z: expected numbers"):
        read_moordyn(path)


def test_flooded_vertical_cylinder_mass_and_inertia_are_analytic() -> None:
    r, z_bottom, level, rho = 4.0, -20.0, -7.5, 1025.0
    h = level - z_bottom
    m, v, mx, mz, i_origin = flooded_member(
        (10.0, 0.0, z_bottom), (10.0, 0.0, 12.0), r, r, level, rho
    )
    assert v == pytest.approx(math.pi * r**2 * h, rel=1e-12)
    assert m == pytest.approx(rho * math.pi * r**2 * h, rel=1e-12)
    assert mx / m == pytest.approx(10.0, rel=1e-12)
    assert mz / m == pytest.approx(z_bottom + h / 2.0, rel=1e-12)
    z_c = z_bottom + h / 2.0
    i_cm = m * (r**2 / 4.0 + h**2 / 12.0)
    assert i_origin == pytest.approx(i_cm + m * (10.0**2 + z_c**2), rel=1e-12)
    # The same member given top-down, and one wholly above the level (no ballast).
    assert flooded_member((10.0, 0.0, 12.0), (10.0, 0.0, z_bottom), r, r, level, rho)[0] == (
        pytest.approx(m, rel=1e-12)
    )
    assert flooded_member((0.0, 0.0, 0.0), (0.0, 0.0, 10.0), r, r, level, rho)[0] == 0.0


def test_flooded_horizontal_member_inertia_is_analytic() -> None:
    # A horizontal tube of length L along x: I_yy about its centre = m (r²/4 + L²/12).
    r, length, z, rho = 1.5, 30.0, -18.0, 1000.0
    m, _, mx, _, i_origin = flooded_member((-15.0, 0.0, z), (15.0, 0.0, z), r, r, -10.0, rho)
    assert m == pytest.approx(rho * math.pi * r**2 * length, rel=1e-12)
    assert mx == pytest.approx(0.0, abs=1e-6 * m)
    assert i_origin == pytest.approx(m * (r**2 / 4.0 + length**2 / 12.0) + m * z**2, rel=1e-12)


def _expected_ballast() -> tuple[float, float]:
    """Mass and volume of the fragments' fill groups, by hand (kg, m³)."""
    column = math.pi * (6.25 - 0.05) ** 2 * (-6.0 + 20.0)  # three columns, -20 m to -6 m
    pontoon = math.pi * (2.0 - 0.04) ** 2 * 35.0  # axis at -18 m < -15 m: wholly flooded
    return 3 * column * 1900.0 + pontoon * 1025.0, 3 * column + pontoon


@pytest.mark.parametrize("name", ["hydrodyn_pre35.dat", "hydrodyn_v35.dat"])
def test_fill_groups_of_both_layouts_give_the_hand_ballast(name: str) -> None:
    values, lines = read_keyed_file(DECKS / name)
    ballast = read_fill_groups(DECKS / name, lines, values, 1025.0)
    assert isinstance(ballast, Ballast)
    mass, volume = _expected_ballast()
    assert ballast.mass_kg == pytest.approx(mass, rel=1e-10)
    assert ballast.volume_m3 == pytest.approx(volume, rel=1e-10)
    assert -20.0 < ballast.cm_z_m < -6.0


def test_fill_group_naming_an_unknown_member_names_file_and_line(tmp_path: Path) -> None:
    text = (DECKS / "hydrodyn_pre35.dat").read_text().splitlines()
    row = next(i for i, t in enumerate(text) if t.strip().startswith("1   4   "))
    text[row] = text[row].replace("1   4", "1   9", 1)
    path = tmp_path / "hd.dat"
    path.write_text("\n".join(text) + "\n")
    values, lines = read_keyed_file(path)
    with pytest.raises(ValueError, match=rf"hd\.dat:{row + 1}: fill group names member 9"):
        read_fill_groups(path, lines, values, 1025.0)


def _deck(tmp_path: Path, hydrodyn: str = "hydrodyn_pre35.dat", fill: bool = True) -> Path:
    """The pre-3.5 deck in ``tmp_path`` with PotFile at the reference WAMIT files."""
    if not WAMIT_ROOT.with_suffix(".1").is_file():
        pytest.skip(f"WAMIT files not available at {WAMIT_ROOT} (../shared absent)")
    for f in DECKS.iterdir():
        shutil.copy(f, tmp_path / f.name)
    hd = (tmp_path / hydrodyn).read_text().replace("HydroData/placeholder", str(WAMIT_ROOT))
    if not fill:
        hd = hd.replace("             2   NFillGroups", "             0   NFillGroups")
    (tmp_path / "hydrodyn_pre35.dat").write_text(hd)
    return tmp_path / "floating_pre35.fst"


def test_pre35_deck_reads_environment_bldfile1_and_ballast(tmp_path: Path) -> None:
    from plant.openfast_import import import_openfast

    deck = import_openfast(_deck(tmp_path), mooring=False)
    p = deck.preset
    assert p.gravity_m_s2 == 9.80665  # ElastoDyn Gravity (not in this .fst)
    assert (p.water_density_kg_m3, p.water_depth_m) == (1025.0, 200.0)  # HydroDyn
    assert p.additional_force_n == [0.0, 0.0, -1.5e6, 0.0, 0.0, 0.0]  # AddF0 on one row
    assert p.blade_mass_kg == pytest.approx(_trapezoid_mass(120.97, 3.97), rel=1e-6)
    mass, _ = _expected_ballast()
    assert p.platform_mass_kg == pytest.approx(8.2e6 + mass, rel=1e-10)
    budget = dict(deck.mass_budget)
    assert budget["ballast (HydroDyn filled members)"] == pytest.approx(mass, rel=1e-10)
    assert budget["total"] == pytest.approx(sum(v for k, v in budget.items() if k != "total"))
    assert any("imported without mooring" in n for n in deck.notes)


def test_newer_hydrodyn_takes_the_environment_from_the_fst(tmp_path: Path) -> None:
    from plant.openfast_import import import_openfast

    old = import_openfast(_deck(_sub(tmp_path, True)), mooring=False)
    fst = _deck(_sub(tmp_path, False), "hydrodyn_v35.dat")
    # Newer HydroDyn files hold no WtrDens/WtrDpth: with none in the .fst either, refused.
    with pytest.raises(ValueError, match=r"WtrDens: expected a number in one of .*\.fst"):
        import_openfast(fst, mooring=False)
    text = fst.read_text().replace(
        "---------------------- INPUT FILES",
        "       1025   WtrDens    - Water density (kg/m^3)\n"
        "        200   WtrDpth    - Water depth (meters)\n"
        "---------------------- INPUT FILES",
    )
    fst.write_text(text)
    new = import_openfast(fst, mooring=False)
    assert new.preset.additional_force_n == old.preset.additional_force_n  # AddF0 a line each
    assert new.preset.platform_mass_kg == old.preset.platform_mass_kg
    assert new.preset.platform_pitch_inertia_kg_m2 == pytest.approx(
        old.preset.platform_pitch_inertia_kg_m2, rel=1e-12
    )


def test_ballast_lengthens_the_heave_period_as_the_mass_ratio_says(tmp_path: Path) -> None:
    """Heave: T = 2π √((M + A₃₃)/C₃₃); the ballast adds to M only (C₃₃ hydrostatic)."""
    from plant.modes import natural_modes
    from plant.openfast_import import import_openfast
    from plant.platform import build_floating_params, load_turbine

    periods = {}
    masses = {}
    a33 = 0.0
    for fill in (True, False):
        deck = import_openfast(_deck(_sub(tmp_path, fill), fill=fill), mooring=False)
        params = build_floating_params(
            deck.preset, load_turbine("iea15mw"), deck.hydro, deck.mooring, None
        )
        modes = {m.name: m.period_s for m in natural_modes(params, 0.0)}
        periods[fill] = modes
        masses[fill] = dict(deck.mass_budget)["total"]
        a33 = float(deck.hydro.radiation.added_mass_inf[2, 2])
    assert periods[True]["heave"] > periods[False]["heave"]
    expected = math.sqrt((masses[True] + a33) / (masses[False] + a33))
    assert periods[True]["heave"] / periods[False]["heave"] == pytest.approx(expected, rel=1e-3)
    # Pitch: the ballast lies below the platform CM, so it adds more restoring moment
    # (−m g z_b) than inertia: the period shortens (32.5 s against 43.2 s when measured).
    assert periods[True]["pitch"] < 0.9 * periods[False]["pitch"]


def _sub(tmp_path: Path, fill: bool) -> Path:
    path = tmp_path / ("fill" if fill else "empty")
    path.mkdir()
    return path


def test_cli_imports_without_mooring_and_analyses_parked(tmp_path: Path) -> None:
    import json

    from typer.testing import CliRunner

    from hil.cli.fowt import app

    fst = _deck(_sub(tmp_path, True))
    out = tmp_path / "preset"
    runner = CliRunner()
    result = runner.invoke(
        app,
        [
            *("preset", "import-openfast", str(fst), "--out", str(out), "--name", "semi"),
            *("--no-mooring", "--radiation-omega-max", "1.8"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "mass ballast (HydroDyn filled members)" in result.output
    assert "imported without mooring" in result.output
    toml = out / "semi.toml"
    assert "radiation_omega_max_rad_s = 1.8" in toml.read_text()
    parked = runner.invoke(app, ["analyze", "modes", str(toml), "--wind", "0", "--json"])
    assert parked.exit_code == 0, parked.output
    report = json.loads(parked.output)
    assert report["case"].startswith("parked in still air")
    modes = {m["name"]: m for m in report["modes"]}
    assert modes["heave"]["damping_ratio"] < 0.01  # no aerodynamic damping when parked
    refused = runner.invoke(app, ["analyze", "modes", str(toml), "--wind", "-1"])
    assert refused.exit_code != 0


def test_oc4_ballast_volume_equals_openfasts() -> None:
    # OpenFAST's HydroDyn summary of the r-test case 5MW_OC4Semi_WSt_WavesWN:
    # "Ballasted Volume : 9.38912E+03" m³ (upper columns to -6.17 m, base columns to -14.89 m).
    path = DECKS / "hydrodyn_oc4_columns.dat"
    values, lines = read_keyed_file(path)
    ballast = read_fill_groups(path, lines, values, 1025.0)
    assert ballast is not None
    assert ballast.volume_m3 == pytest.approx(9389.12, abs=0.01)
    assert ballast.mass_kg == pytest.approx(9389.12 * 1025.0, rel=2e-6)
    assert ballast.cm_x_m == pytest.approx(0.0, abs=1e-4)  # three columns at 120 deg (5 digits)


def test_elastodyn_value_that_is_not_a_number_names_file_and_line(tmp_path: Path) -> None:
    from plant.openfast_import import _num

    text = (DECKS / "elastodyn_pre35.dat").read_text().replace("8.2E+06   PtfmMass", "-   PtfmMass")
    path = tmp_path / "ed.dat"
    path.write_text(text)
    values, lines = read_keyed_file(path)
    line = next(i + 1 for i, t in enumerate(lines) if "PtfmMass" in t)
    with pytest.raises(
        ValueError, match=rf"ed\.dat:{line}: key 'PtfmMass' = '-'; expected a number"
    ):
        _num(values, "PtfmMass", path)


def test_unstable_radiation_fit_names_the_kernels_and_a_remedy(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import plant.openfast_import as imp

    deck = imp.import_openfast(_deck(tmp_path), mooring=False)

    def fake_fit(radiation, *, dofs=(0, 2, 4), **kwargs):  # type: ignore[no-untyped-def]
        if 0 in dofs and 4 in dofs:  # only the surge-pitch coupling fails
            raise ValueError("RadiationModel.A: expected stable poles (Re < 0 1/s)")

    monkeypatch.setattr(imp, "fit_reduced_radiation", fake_fit)
    with pytest.raises(ValueError) as err:
        imp.write_radiation(deck.preset, deck.hydro, tmp_path / "r.npz")
    text = str(err.value)
    assert "surge-pitch kernels" in text
    assert "band 0..2 rad/s" in text
    assert "--radiation-omega-max" in text


def test_fewer_fill_group_rows_than_nfillgroups_is_refused(tmp_path: Path) -> None:
    text = (DECKS / "hydrodyn_pre35.dat").read_text()
    path = tmp_path / "hd.dat"
    path.write_text(text.replace("             2   NFillGroups", "             3   NFillGroups"))
    values, lines = read_keyed_file(path)
    with pytest.raises(ValueError, match=r"hd\.dat:\d+: NFillGroups = 3 but 2 fill-group rows"):
        read_fill_groups(path, lines, values, 1025.0)


def test_short_joint_row_names_file_and_line(tmp_path: Path) -> None:
    text = (DECKS / "hydrodyn_pre35.dat").read_text().splitlines()
    row = next(i for i, t in enumerate(text) if t.startswith("    3    -25.87500    44.81681"))
    text[row] = "    3    -25.87500"
    path = tmp_path / "hd.dat"
    path.write_text("\n".join(text) + "\n")
    values, lines = read_keyed_file(path)
    with pytest.raises(ValueError, match=rf"hd\.dat:{row + 1}: member joints: expected at least 4"):
        read_fill_groups(path, lines, values, 1025.0)


#: The tower table of aerodyn_tower.dat: elevation [m], diameter [m], drag coefficient [-].
TOWER_AERO = ([15.0, 50.0, 100.0, 144.4], [10.0, 8.5, 7.0, 6.5], [0.5, 0.55, 0.6, 0.6])


def _with_aerodyn(deck: Path, aerodyn: str) -> Path:
    """The deck with CompAero = 2 and AeroFile naming ``aerodyn`` (next to it)."""
    fst = deck.read_text()
    fst = fst.replace("          0   CompAero", "          2   CompAero")
    fst = fst.replace('"unused"      AeroFile', f'"{aerodyn}"      AeroFile')
    deck.write_text(fst)
    return deck


def test_tower_drag_table_is_read_by_header_in_any_column_order(tmp_path: Path) -> None:
    from plant.openfast_import import import_openfast

    deck = _with_aerodyn(_deck(tmp_path), "aerodyn_tower.dat")
    p = import_openfast(deck, mooring=False).preset
    assert (p.tower_drag_height_m, p.tower_drag_diameter_m, p.tower_drag_coefficient) == (
        TOWER_AERO
    )
    # OpenFAST 4's layout: more columns, TwrCd before TwrDiam. The same values must be read.
    text = (tmp_path / "aerodyn_tower.dat").read_text().splitlines()
    head = text.index(next(ln for ln in text if ln.startswith("TwrElev")))
    rows = [ln.split() for ln in text[head + 2 : head + 6]]
    text[head] = "TwrElev  TwrCd  TwrTI  TwrDiam  TwrCb  TwrCp  TwrCa"
    text[head + 1] = "(m)      (-)    (-)    (m)      (-)    (-)    (-)"
    for i, (z, d, cd, ti) in enumerate(rows):
        text[head + 2 + i] = f"{z}  {cd}  {ti}  {d}  0.0  0.0  0.0"
    (tmp_path / "aerodyn_v4.dat").write_text("\n".join(text) + "\n")
    deck.write_text(deck.read_text().replace('"aerodyn_tower.dat"', '"aerodyn_v4.dat"'))
    q = import_openfast(deck, mooring=False).preset
    assert (q.tower_drag_height_m, q.tower_drag_diameter_m, q.tower_drag_coefficient) == (
        TOWER_AERO
    )


def test_tower_drag_table_without_a_diameter_column_is_refused(tmp_path: Path) -> None:
    from plant.openfast_import import import_openfast

    deck = _with_aerodyn(_deck(tmp_path), "aerodyn_tower.dat")
    ad = tmp_path / "aerodyn_tower.dat"
    ad.write_text(ad.read_text().replace("TwrDiam", "TwrWidth"))
    with pytest.raises(ValueError, match=r"aerodyn_tower\.dat.*tower aerodynamics.*TwrDiam"):
        import_openfast(deck, mooring=False)


def _repeat_ballast_gravity_in_addclin(hd: Path) -> float:
    """Write the fill groups' own gravity restoring −m_b g z_b into AddCLin(4,4) and (5,5),
    as FAST v8-era decks did (5 significant digits); returns that value (N m/rad)."""
    values, lines = read_keyed_file(hd)
    ballast = read_fill_groups(hd, lines, values, 1025.0)
    assert ballast is not None
    k = float(f"{-ballast.mass_kg * 9.80665 * ballast.cm_z_m:.5g}")
    text = hd.read_text().splitlines()
    row = next(i for i, t in enumerate(text) if "AddCLin" in t)
    text[row + 3] = f"     0      0      0      {k:.5E}      0      0"
    text[row + 4] = f"     0      0      0      0      {k:.5E}      0"
    hd.write_text("\n".join(text) + "\n")
    return k


def test_addclin_repeating_the_ballast_gravity_is_warned_and_can_be_dropped(
    tmp_path: Path,
) -> None:
    """The restoring of the ballast enters twice when AddCLin also holds it: the import
    warns with both figures and their ratio; ``drop_duplicate_addclin`` zeroes the entries,
    and the pitch period grows back by √((C + K_b)/C) with C the rest of the restoring."""
    from plant.modes import natural_modes
    from plant.openfast_import import import_openfast
    from plant.platform import build_floating_params, load_turbine

    fst = _deck(tmp_path)
    k = _repeat_ballast_gravity_in_addclin(tmp_path / "hydrodyn_pre35.dat")
    kept = import_openfast(fst, mooring=False)
    assert len(kept.warnings) == 1
    w = kept.warnings[0]
    assert w.startswith(f"AddCLin(4,4) and AddCLin(5,5) = {k:.5g} equals the fill groups'")
    assert "ratio 1.0000" in w and "--drop-duplicate-addclin" in w
    assert f"warning: {w}" in kept.notes
    assert kept.preset.additional_linear_stiffness[4][4] == k
    assert any(n.startswith("stiffness budget pitch (N m/rad)") for n in kept.notes)
    dropped = import_openfast(fst, mooring=False, drop_duplicate_addclin=True)
    c = dropped.preset.additional_linear_stiffness
    assert c[3][3] == 0.0 and c[4][4] == 0.0
    assert dropped.warnings[0].startswith("dropped AddCLin(4,4) and AddCLin(5,5)")
    periods = []
    for deck in (kept, dropped):
        params = build_floating_params(
            deck.preset, load_turbine("iea15mw"), deck.hydro, deck.mooring, None
        )
        periods.append({m.name: m.period_s for m in natural_modes(params, 0.0)}["pitch"])
    assert periods[1] > 1.1 * periods[0]
    # the deck without the repeat imports without a warning
    assert import_openfast(_deck(_sub(tmp_path, True)), mooring=False).warnings == ()


def test_default_import_prints_the_fit_and_modes_say_no_restoring_in_surge(
    tmp_path: Path,
) -> None:
    """The reference semi's WAMIT data imported with no band option: the radiation fit's
    order, band and errors per DOF and per DOF pair are printed, with the AddCLin warning;
    imported without mooring, ``fowt analyze modes`` says there is no restoring in surge and
    reports no surge mode (it did: 19.2 s at damping ratio 0.62, drift and radiation)."""
    import json

    from typer.testing import CliRunner

    from hil.cli.fowt import app

    fst = _deck(tmp_path)
    _repeat_ballast_gravity_in_addclin(tmp_path / "hydrodyn_pre35.dat")
    out = tmp_path / "preset"
    runner = CliRunner()
    args = ["preset", "import-openfast", str(fst), "--out", str(out), "--name", "semi"]
    result = runner.invoke(app, [*args, "--no-mooring"])
    assert result.exit_code == 0, result.output
    printed = " ".join(result.output.split())
    assert "radiation order" in printed and "band 0.05..2 rad/s" in printed
    for pair in ("surge-heave", "surge-pitch", "heave-pitch"):
        assert f"radiation {pair}: error A" in printed
    assert "warning: AddCLin(4,4) and AddCLin(5,5) =" in printed
    assert "stiffness budget pitch (N m/rad)" in printed
    toml = out / "semi.toml"
    parked = runner.invoke(app, ["analyze", "modes", str(toml), "--wind", "0", "--json"])
    assert parked.exit_code == 0, parked.output
    report = json.loads(parked.output)
    assert report["no_restoring"] == ["surge"]
    assert "surge" not in {m["name"] for m in report["modes"]}
    assert {"heave", "pitch"} <= {m["name"] for m in report["modes"]}
    text = runner.invoke(app, ["analyze", "modes", str(toml), "--wind", "0"])
    assert text.exit_code == 0, text.output
    assert "no restoring in surge" in " ".join(text.output.split())
