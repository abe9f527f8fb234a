"""Tests of plant.aero: ROSCO table I/O, validation and the scalar/vector lookups."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from plant.aero import (
    PerformanceTable,
    format_rosco_table,
    parse_rosco_table,
    read_rosco_table,
    write_rosco_table,
)

REFERENCE = Path(__file__).resolve().parents[2] / "shared" / "reference"
REFERENCE_TABLES = {
    "nrel5mw_cp_ct_cq.txt": REFERENCE / "openfast" / "NREL-5MW" / "Cp_Ct_Cq.NREL5MW.txt",
    "iea15mw_cp_ct_cq.txt": REFERENCE / "openfast" / "IEA-15-240-RWT" / "Cp_Ct_Cq.IEA15MW.txt",
}


def shipped(name: str) -> PerformanceTable:
    text = (resources.files("plant.presets") / name).read_text(encoding="utf-8")
    return parse_rosco_table(text, name)


def random_table(seed: int, n: int = 7, m: int = 5) -> PerformanceTable:
    rng = np.random.default_rng(seed)
    pitch = np.sort(rng.uniform(-0.1, 0.5, m))
    tsr = np.sort(rng.uniform(1.0, 15.0, n))
    return PerformanceTable(
        pitch_rad=pitch,
        tsr=tsr,
        cp=rng.uniform(-0.2, 0.6, (n, m)),
        ct=rng.uniform(0.0, 1.2, (n, m)),
        cq=rng.uniform(-0.02, 0.1, (n, m)),
        wind_speeds_m_s=(11.4,),
    )


# ---------------------------------------------------------------------- shipped data
@pytest.mark.parametrize("name", sorted(REFERENCE_TABLES))
def test_shipped_table_equals_reference(name: str) -> None:
    ref_path = REFERENCE_TABLES[name]
    if not ref_path.is_file():
        pytest.skip(f"reference table {ref_path} absent (../shared/reference not checked out)")
    ours, ref = shipped(name), read_rosco_table(ref_path)
    # Exact: the shipped files carry the published numbers unchanged.
    assert ours == ref
    assert ours.wind_speeds_m_s == ref.wind_speeds_m_s
    assert ours.cp.shape == (26, 36)


@pytest.mark.parametrize("name", sorted(REFERENCE_TABLES))
def test_shipped_table_is_our_writer_output_with_own_header(name: str) -> None:
    text = (resources.files("plant.presets") / name).read_text(encoding="utf-8")
    title = text.splitlines()[0].removeprefix("# Rotor performance (Cp, Ct, Cq) of ")
    assert format_rosco_table(shipped(name), title) == text
    assert "ROSCO toolbox" not in text  # the header wording is ours


def test_nrel5mw_cp_max_matches_reference_figure() -> None:
    cp, tsr, pitch = shipped("nrel5mw_cp_ct_cq.txt").cp_max()
    assert cp == pytest.approx(0.466, abs=0.002)
    assert tsr == pytest.approx(7.5, abs=1e-12)
    assert pitch == pytest.approx(0.0, abs=1e-12)
    assert shipped("nrel5mw_cp_ct_cq.txt").optimal_tsr(0.0) == pytest.approx(7.5, abs=0.01)


# ---------------------------------------------------------------------- round trip
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_writer_reader_round_trip(tmp_path: Path, seed: int) -> None:
    table = random_table(seed)
    path = tmp_path / "t.txt"
    write_rosco_table(table, path, "a random rotor\nwith a newline in the title")
    back = read_rosco_table(path)
    np.testing.assert_allclose(back.pitch_rad, table.pitch_rad, rtol=0, atol=1e-10)
    for name in ("tsr", "cp", "ct", "cq"):
        np.testing.assert_array_equal(getattr(back, name), getattr(table, name))
    assert back.wind_speeds_m_s == (11.4,)


def test_round_trip_exact_for_whole_degree_pitch(tmp_path: Path) -> None:
    t = random_table(3)
    table = PerformanceTable(np.deg2rad(np.arange(-2.0, 3.0)), t.tsr, t.cp, t.ct, t.cq)
    write_rosco_table(table, tmp_path / "t.txt", "whole degrees")
    assert read_rosco_table(tmp_path / "t.txt") == table


def test_reader_tolerates_other_header_wording_blank_lines_crlf_and_wrapping() -> None:
    table = random_table(4, n=4, m=6)

    def rows(mat: np.ndarray) -> str:
        # each matrix row wrapped over two lines, with tabs and trailing spaces
        return "\n".join(
            "\t".join(map(repr, r[:3].tolist())) + "  \n" + " ".join(map(repr, r[3:].tolist()))
            for r in mat
        )

    text = "\r\n".join(
        [
            "#some tool, any wording",
            "",
            "",
            "#  pitch",
            " ".join(repr(v) for v in np.rad2deg(table.pitch_rad).tolist()),
            "#tsr",
            "",
            " ".join(repr(v) for v in table.tsr.tolist()),
            "# U",
            "8.0 9.0",
            "# A",
            rows(table.cp),
            "#B",
            "",
            rows(table.ct),
            "# C",
            rows(table.cq),
            "",
        ]
    )
    back = parse_rosco_table(text, "wrapped.txt")
    np.testing.assert_allclose(back.pitch_rad, table.pitch_rad, atol=1e-12)
    np.testing.assert_array_equal(back.cq, table.cq)
    assert back.wind_speeds_m_s == (8.0, 9.0)


def test_reader_accepts_missing_wind_vector() -> None:
    table = random_table(5, n=3, m=4)
    text = format_rosco_table(table, "x").replace("\n11.4\n", "\n\n")
    assert parse_rosco_table(text).wind_speeds_m_s == ()


# ---------------------------------------------------------------------- malformed files
def _good_text() -> str:
    return format_rosco_table(random_table(6, n=4, m=3), "malformed-test rotor")


def test_truncated_file_names_file_and_block(tmp_path: Path) -> None:
    lines = _good_text().splitlines()
    path = tmp_path / "truncated.txt"
    path.write_text("\n".join(lines[:-3]) + "\n")  # Cq loses its last rows
    with pytest.raises(ValueError, match=r"truncated\.txt.*Cq matrix.*expected 4 rows") as exc:
        read_rosco_table(path)
    assert "4 rows (TSR entries) x 3 columns" in str(exc.value)


def test_file_cut_after_ct_reports_missing_blocks(tmp_path: Path) -> None:
    text = _good_text()
    path = tmp_path / "cut.txt"
    path.write_text(text[: text.index("# Torque coefficient")])
    with pytest.raises(ValueError, match=r"cut\.txt: expected 6 blocks.*found 5"):
        read_rosco_table(path)


def test_non_numeric_token_names_line(tmp_path: Path) -> None:
    lines = _good_text().splitlines()
    lines[6] = lines[6] + " abc"  # the TSR line
    path = tmp_path / "bad.txt"
    path.write_text("\n".join(lines))
    with pytest.raises(ValueError, match=r"bad\.txt, line 7: expected numbers"):
        read_rosco_table(path)


def test_row_with_wrong_count_is_reported() -> None:
    lines = _good_text().splitlines()
    k = lines.index(next(ln for ln in lines if ln.startswith("# Thrust"))) + 2
    values = lines[k].split()
    lines[k] = "  ".join(values[:-1])
    lines[k + 1] = lines[k + 1] + "  " + values[-1]  # same total, one value moved down a row
    with pytest.raises(ValueError, match=r"Ct matrix row 1 .* has 2 values; expected 3"):
        parse_rosco_table("\n".join(lines), "moved.txt")


def test_decreasing_pitch_is_reported() -> None:
    lines = _good_text().splitlines()
    lines[4] = " ".join(reversed(lines[4].split()))
    with pytest.raises(ValueError, match=r"rev\.txt: .*pitch_rad: expected strictly increasing"):
        parse_rosco_table("\n".join(lines), "rev.txt")


def test_nan_in_file_is_rejected() -> None:
    text = _good_text().replace("\n11.4\n", "\nnan\n")
    with pytest.raises(ValueError, match="non-finite"):
        parse_rosco_table(text)


def test_empty_and_binary_files(tmp_path: Path) -> None:
    empty = tmp_path / "empty.txt"
    empty.write_text("# nothing here\n")
    with pytest.raises(ValueError, match=r"empty\.txt: .*found 0"):
        read_rosco_table(empty)
    binary = tmp_path / "bin.txt"
    binary.write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(ValueError, match=r"bin\.txt: not a text file"):
        read_rosco_table(binary)


# ---------------------------------------------------------------------- validation
def test_table_validation_messages() -> None:
    t = random_table(7, n=4, m=3)
    with pytest.raises(ValueError, match=r"cp: expected shape \(4, 3\) \(len\(tsr\) rows"):
        PerformanceTable(t.pitch_rad, t.tsr, t.cp.T, t.ct, t.cq)
    with pytest.raises(ValueError, match="tsr: expected strictly increasing"):
        PerformanceTable(t.pitch_rad, t.tsr[::-1], t.cp, t.ct, t.cq)
    with pytest.raises(ValueError, match="were degrees given"):
        PerformanceTable(np.array([0.0, 5.0, 10.0]), t.tsr, t.cp, t.ct, t.cq)
    with pytest.raises(ValueError, match="pitch_rad: expected a 1-D array"):
        PerformanceTable(t.cp, t.tsr, t.cp, t.ct, t.cq)
    with pytest.raises(ValueError, match="at least 2"):
        PerformanceTable(t.pitch_rad[:1], t.tsr, t.cp[:, :1], t.ct[:, :1], t.cq[:, :1])


def test_arrays_are_read_only_copies() -> None:
    cp = random_table(8).cp.copy()
    t = random_table(8)
    table = PerformanceTable(t.pitch_rad, t.tsr, cp, t.ct, t.cq)
    cp[0, 0] = 99.0
    assert table.cp[0, 0] != 99.0
    with pytest.raises(ValueError):
        table.cp[0, 0] = 1.0


# ---------------------------------------------------------------------- lookups
def test_lookup_equals_table_at_grid_nodes() -> None:
    table = shipped("nrel5mw_cp_ct_cq.txt")
    for i, lam in enumerate(table.tsr.tolist()):
        for j, th in enumerate(table.pitch_rad.tolist()):
            cp, ct, cq = table.coefficients(lam, th)
            # exact up to the rounding of c0 + a c_a + b (...) with a, b in {0, 1}
            assert cp == pytest.approx(table.cp[i, j], abs=1e-15)
            assert ct == pytest.approx(table.ct[i, j], abs=1e-15)
            assert cq == pytest.approx(table.cq[i, j], abs=1e-15)


@pytest.mark.parametrize("name", ["nrel5mw_cp_ct_cq.txt", "iea15mw_cp_ct_cq.txt"])
def test_lookup_is_bilinear_between_nodes(name: str) -> None:
    from scipy.interpolate import RegularGridInterpolator

    table = shipped(name)
    rng = np.random.default_rng(42)
    lam = rng.uniform(table.tsr[0], table.tsr[-1], 500)
    th = rng.uniform(table.pitch_rad[0], table.pitch_rad[-1], 500)
    pts = np.column_stack([lam, th])
    got = np.array([table.coefficients(a, b) for a, b in zip(lam, th, strict=True)])
    got_vec = np.column_stack(table.evaluate(lam, th))
    for k, mat in enumerate((table.cp, table.ct, table.cq)):
        ref = RegularGridInterpolator((table.tsr, table.pitch_rad), mat, method="linear")(pts)
        np.testing.assert_allclose(got[:, k], ref, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got_vec[:, k], ref, rtol=0, atol=1e-12)
    q = np.array([table.torque_coefficient(a, b) for a, b in zip(lam, th, strict=True)])
    np.testing.assert_array_equal(q, got[:, 2])


def test_lookup_clamps_outside_the_grid() -> None:
    table = shipped("nrel5mw_cp_ct_cq.txt")
    lo_lam, hi_lam = float(table.tsr[0]), float(table.tsr[-1])
    lo_th, hi_th = float(table.pitch_rad[0]), float(table.pitch_rad[-1])
    assert table.coefficients(-3.0, -1.0) == table.coefficients(lo_lam, lo_th)
    assert table.coefficients(100.0, 2.0) == table.coefficients(hi_lam, hi_th)
    assert table.coefficients(0.0, 0.0) == table.coefficients(lo_lam, 0.0)
    assert table.coefficients(7.3, 1.5) == table.coefficients(7.3, hi_th)
    cp, _, _ = table.evaluate([0.0, 100.0], [-1.0, 2.0])
    np.testing.assert_array_equal(cp, [table.cp[0, 0], table.cp[-1, -1]])
