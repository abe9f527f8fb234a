"""Tests of plant.hydro.wamit: WAMIT readers, dimensionalisation, npz storage, shipped presets."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from plant.hydro.wamit import (
    ExcitationData,
    HydroData,
    RadiationData,
    import_wamit,
    load_hydro_preset,
    read_wamit_1,
    read_wamit_3,
    read_wamit_hst,
)

REFERENCE = Path(__file__).resolve().parents[2] / "shared" / "reference"
HYDRO_DIR = REFERENCE / "openfast" / "IEA-15-240-RWT-UMaineSemi" / "HydroData"
PREFIX = HYDRO_DIR / "IEA-15-240-RWT-UMaineSemi"
TLP_CSV = REFERENCE / "nrel-5mw-tlp-buoy" / "cylinder_R4.75_T30_h100_surge.csv"
RHO, G = 1025.0, 9.81  # the deck's WtrDens and Gravity (.fst)


def need(path: Path) -> Path:
    if not path.is_file():
        pytest.skip(f"reference file {path} absent (../shared/reference not checked out)")
    return path


def raw_rows(path: Path) -> list[list[str]]:
    return [line.split() for line in path.read_text().splitlines() if line.strip()]


# ------------------------------------------------------------------------------ readers
def test_read_wamit_1_dimensional_values() -> None:
    path = need(PREFIX.with_suffix(".1"))
    rad = read_wamit_1(path, rho=RHO, ulen=1.0)
    assert rad.omega_rad_s.shape == (100,)
    # 0.05..5 rad/s every 0.05 rad/s (periods printed to 7 digits: 1e-6 relative).
    np.testing.assert_allclose(rad.omega_rad_s, 0.05 * np.arange(1, 101), rtol=1e-6)
    rows = raw_rows(path)
    # PER = 0: infinite frequency. Surge A_inf = 9407.236 * 1025 kg = 9.642e6 kg (exact scaling).
    a11_inf = next(float(r[3]) for r in rows if float(r[0]) == 0.0 and r[1:3] == ["1", "1"])
    assert a11_inf == pytest.approx(9407.236)
    assert rad.added_mass_inf[0, 0] == pytest.approx(a11_inf * RHO, rel=1e-12)
    assert rad.added_mass_inf[0, 0] == pytest.approx(9.642e6, rel=1e-3)
    # PER = -1: zero frequency; consistent with the lowest computed frequency (0.05 rad/s).
    assert rad.added_mass_zero is not None
    assert rad.added_mass_zero[0, 0] == pytest.approx(rad.added_mass[0, 0, 0], rel=3e-3)
    # Pitch-pitch (k = 5, ULEN = 1) and surge-pitch (k = 4) scale with rho only.
    a55 = next(float(r[3]) for r in rows if float(r[0]) == 0.0 and r[1:3] == ["5", "5"])
    assert rad.added_mass_inf[4, 4] == pytest.approx(a55 * RHO, rel=1e-12)
    # Damping: B = B̄ rho omega at the first line with T = 125.6637 s (heave-heave).
    row = next(r for r in rows if len(r) == 5 and r[1:3] == ["3", "3"])
    omega = 2 * np.pi / float(row[0])
    assert rad.damping[0, 2, 2] == pytest.approx(float(row[4]) * RHO * omega, rel=1e-12)
    assert rad.added_mass[0, 2, 2] == pytest.approx(float(row[3]) * RHO, rel=1e-12)


def test_ulen_scaling_exponents(tmp_path: Path) -> None:
    f = tmp_path / "x.1"
    f.write_text(
        "0.0 1 1 1.0\n0.0 1 5 1.0\n0.0 5 5 1.0\n"
        "6.283185307179586 1 1 1.0 2.0\n6.283185307179586 5 5 1.0 2.0\n"
    )
    rad = read_wamit_1(f, rho=1000.0, ulen=2.0)
    np.testing.assert_allclose(
        [rad.added_mass_inf[0, 0], rad.added_mass_inf[0, 4], rad.added_mass_inf[4, 4]],
        [1000.0 * 8, 1000.0 * 16, 1000.0 * 32],
    )
    assert rad.damping[0, 4, 4] == pytest.approx(2.0 * 1000.0 * 1.0 * 32)
    h = tmp_path / "x.hst"
    h.write_text("3 3 1.0\n3 5 1.0\n5 5 1.0\n")
    c = read_wamit_hst(h, rho=1000.0, g=10.0, ulen=2.0)
    np.testing.assert_allclose([c[2, 2], c[2, 4], c[4, 4]], [1e4 * 4, 1e4 * 8, 1e4 * 16])


def test_read_wamit_hst_heave_stiffness_is_rho_g_awp() -> None:
    c = read_wamit_hst(need(PREFIX.with_suffix(".hst")), rho=RHO, g=G, ulen=1.0)
    assert c.shape == (6, 6)
    assert c[2, 2] == pytest.approx(443.0486 * RHO * G, rel=1e-12)  # 4.455e6 N/m
    # Independent: three 12.5 m columns + one 10 m column give A_wp = 446.7 m^2 (geometry of
    # VolturnUS-S); WAMIT's panelled waterplane is 0.8 % smaller. Tolerance 1 %.
    awp = 3 * np.pi * 6.25**2 + np.pi * 5.0**2
    assert c[2, 2] == pytest.approx(RHO * G * awp, rel=0.01)
    assert c[0, 0] == 0.0
    assert c[4, 4] == pytest.approx(2.182166e5 * RHO * G, rel=1e-12)


def test_read_wamit_3_values_and_convention() -> None:
    path = need(PREFIX.with_suffix(".3"))
    exc = read_wamit_3(path, rho=RHO, g=G, ulen=1.0)
    assert exc.force.shape == (100, 37, 6)
    np.testing.assert_allclose(exc.heading_deg, np.arange(-180.0, 181.0, 10.0))
    rows = raw_rows(path)
    # First frequency (T = 125.66 s), heading 0, surge (force: m = 2) and pitch (moment: m = 3).
    for mode, idx in (("1", 0), ("5", 4)):
        r = next(r for r in rows if float(r[1]) == 0.0 and r[2] == mode)
        assert float(r[0]) == pytest.approx(125.6637)
        expected = complex(float(r[5]), float(r[6])) * RHO * G
        assert exc.force[0, 18, idx] == pytest.approx(expected, rel=1e-12)
        # |X| column agrees with Re/Im (file consistency, 1e-6 from printing).
        assert abs(exc.force[0, 18, idx]) == pytest.approx(float(r[3]) * RHO * G, rel=1e-5)
    # Head seas (0 deg) excite surge, heave, pitch; sway/roll/yaw are ~0 by symmetry.
    x = np.abs(exc.force[:, 18, :])
    assert np.max(x[:, 1]) < 1e-3 * np.max(x[:, 0])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("0.0 1 1 1.0\n6.0 1 1 1.0\n", "x.1:2: period 6 s row needs 5 columns"),
        ("0.0 1 1 1.0\n6.0 1 1 1.0 2.0 3.0\n", "x.1:2: expected 4 or 5 columns"),
        ("0.0 1 1 1.0\n6.0 1 1 abc 2.0\n", "x.1:2: non-numeric"),
        ("0.0 1 7 1.0\n6.0 1 1 1.0 2.0\n", "x.1:1: mode index 7"),
        ("-1.0 1 1 1.0\n6.0 1 1 1.0 2.0\n", "no PER = 0 rows"),
        ("0.0 1 1 1.0\n0.0 1 1 1.0\n6.0 1 1 1.0 2.0\n", "x.1:2: duplicate"),
        ("", "no data lines"),
        ("0.0 1 1 1.0\n6.0 1 1 nan 2.0\n", "x.1:2: non-finite"),
    ],
)
def test_read_wamit_1_malformed(tmp_path: Path, text: str, message: str) -> None:
    f = tmp_path / "x.1"
    f.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_wamit_1(f)


def test_truncated_real_files_raise(tmp_path: Path) -> None:
    src1 = need(PREFIX.with_suffix(".1")).read_text()
    cut = src1[: len(src1) // 2].rsplit(" ", 2)[0]  # cut mid-line
    f = tmp_path / "t.1"
    f.write_text(cut)
    with pytest.raises(ValueError, match=r"t\.1:\d+:"):
        read_wamit_1(f)
    lines3 = need(PREFIX.with_suffix(".3")).read_text().splitlines()
    g3 = tmp_path / "t.3"
    # Drop whole records of the last period: the (period, heading) grid has holes.
    g3.write_text("\n".join(lines3[: len(lines3) - 6 * 10]) + "\n")
    with pytest.raises(ValueError, match="no rows for PER="):
        read_wamit_3(g3)
    h = tmp_path / "t.hst"
    h.write_text("1 1\n")
    with pytest.raises(ValueError, match=r"t\.hst:1: expected 3 columns"):
        read_wamit_hst(h)


def test_dataclass_validation() -> None:
    w = np.array([0.5, 1.0])
    ok = {
        "omega_rad_s": w,
        "added_mass": np.ones((2, 1, 1)),
        "damping": np.ones((2, 1, 1)),
        "added_mass_inf": np.ones((1, 1)),
        "dofs": (0,),
    }
    RadiationData(**ok)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="damping has shape"):
        RadiationData(**{**ok, "damping": np.ones((2, 2, 2))})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="strictly increasing"):
        RadiationData(**{**ok, "omega_rad_s": w[::-1]})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="non-finite"):
        RadiationData(**{**ok, "added_mass_inf": np.full((1, 1), np.nan)})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="0-based WAMIT modes"):
        RadiationData(**{**ok, "dofs": (6,)})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="force has shape"):
        ExcitationData(w, np.array([0.0]), np.ones((2, 2, 1), complex), dofs=(0,))


# ------------------------------------------------------------------------------ HydroData
def test_import_select_and_npz_roundtrip(tmp_path: Path) -> None:
    need(PREFIX.with_suffix(".1"))
    data = import_wamit(PREFIX, RHO, G, 1.0)
    sub = data.select((0, 2, 4), heading_deg=7.0)
    assert sub.dofs == (0, 2, 4)
    assert sub.excitation.heading_deg.tolist() == [10.0]
    assert sub.radiation.added_mass.shape == (100, 3, 3)
    assert sub.radiation.added_mass[5, 2, 1] == data.radiation.added_mass[5, 4, 2]
    assert sub.hydrostatic_stiffness[1, 1] == data.hydrostatic_stiffness[2, 2]
    np.testing.assert_array_equal(sub.excitation.force[:, 0, 2], data.excitation.force[:, 19, 4])
    # Nearest heading on the circle: 357 deg is 3 deg from 0 (and 13 from -10).
    assert data.select((0,), heading_deg=357.0).excitation.heading_deg.tolist() == [0.0]
    with pytest.raises(ValueError, match=r"dofs \[6\]|0-based"):
        data.select((0, 6))
    f = tmp_path / "h.npz"
    sub.save_npz(f)
    back = HydroData.load_npz(f)
    np.testing.assert_array_equal(back.radiation.damping, sub.radiation.damping)
    np.testing.assert_array_equal(back.excitation.force, sub.excitation.force)
    assert back.radiation.added_mass_zero is not None
    assert back.dofs == (0, 2, 4)
    assert (back.rho_kg_m3, back.g_m_s2) == (RHO, G)
    np.savez(tmp_path / "bad.npz", dofs=np.arange(3))
    with pytest.raises(ValueError, match="lacks array"):
        HydroData.load_npz(tmp_path / "bad.npz")


def test_shipped_volturnus_equals_reference() -> None:
    need(PREFIX.with_suffix(".1"))
    ours, ref = load_hydro_preset("iea15mw_volturnus"), import_wamit(PREFIX, RHO, G, 1.0)
    assert ours.dofs == (0, 1, 2, 3, 4, 5)
    np.testing.assert_array_equal(ours.radiation.added_mass, ref.radiation.added_mass)
    np.testing.assert_array_equal(ours.radiation.damping, ref.radiation.damping)
    np.testing.assert_array_equal(ours.radiation.added_mass_inf, ref.radiation.added_mass_inf)
    np.testing.assert_array_equal(ours.excitation.force, ref.excitation.force)
    np.testing.assert_array_equal(ours.hydrostatic_stiffness, ref.hydrostatic_stiffness)


def test_shipped_tlp_buoy_equals_csv() -> None:
    d = np.loadtxt(need(TLP_CSV), delimiter=",", comments="#", skiprows=2)
    ours = load_hydro_preset("nrel5mw_tlp_buoy")
    assert ours.dofs == (0,)
    np.testing.assert_array_equal(ours.radiation.omega_rad_s, d[:, 0])
    np.testing.assert_array_equal(ours.radiation.added_mass[:, 0, 0], d[:, 1])
    np.testing.assert_array_equal(ours.radiation.damping[:, 0, 0], d[:, 2])
    assert ours.radiation.added_mass_inf[0, 0] == 1.665472e6
    # Capytaine exp(-iwt) -> exp(+iwt): complex conjugate.
    np.testing.assert_array_equal(ours.excitation.force[:, 0, 0], d[:, 3] - 1j * d[:, 4])
    # Reference README: |X| = 7.64e5 N/m at 0.5 rad/s, 1.369e6 N/m at 1.0 rad/s (interpolated
    # between the 0.06 rad/s spaced points: 1 %).
    absx = np.abs(ours.excitation.force[:, 0, 0])
    assert np.interp(0.5, d[:, 0], absx) == pytest.approx(7.64e5, rel=0.01)
    assert np.interp(1.0, d[:, 0], absx) == pytest.approx(1.369e6, rel=0.01)


def test_unknown_preset() -> None:
    with pytest.raises(ValueError, match="no shipped hydrodynamic preset"):
        load_hydro_preset("nope")
