"""HydroDyn strip-theory members (``PropPot = FALSE``) in the importer: analytic answers.

Buoyancy of a submerged horizontal cylinder, the waterplane stiffness of a column piercing the
still-water line (and of an inclined one), the transverse Morison added mass, the refusal of
coefficient models that are not read, and the members' terms in the assembled plant matrices.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from plant.openfast_import import morison_member, read_keyed_file, read_morison_members

RHO, G = 1025.0, 9.80665


def _hydrodyn(tmp_path: Path, joints: str, members: str, extra: str = "", coef: str = "") -> Path:
    """A HydroDyn fragment with a joint table, one property set (D 2 m) and member rows."""
    text = f"""------- HydroDyn Input File ------------------------------------------
Test fragment for the strip-theory members; figures chosen for the test.
---------------------- AXIAL COEFFICIENTS --------------------------------------
             1   NAxCoef        - Number of axial coefficients (-)
AxCoefID  AxCd     AxCa     AxCp
   (-)    (-)      (-)      (-)
    1     0.00     0.00     1.00
---------------------- MEMBER JOINTS -------------------------------------------
             4   NJoints        - Number of joints (-)
JointID   Jointxi     Jointyi     Jointzi  JointAxID   JointOvrlp
   (-)     (m)         (m)         (m)        (-)       (switch)
{joints}
---------------------- MEMBER CROSS-SECTION PROPERTIES -------------------------
             1   NPropSets      - Number of member property sets (-)
PropSetID    PropD         PropThck
   (-)        (m)            (m)
    1        2.00000        0.02000
---------------------- SIMPLE HYDRODYNAMIC COEFFICIENTS (model 1) --------------
     SimplCd    SimplCdMG    SimplCa    SimplCaMG    SimplCp    SimplCpMG
       (-)         (-)         (-)         (-)         (-)         (-)
       0.60        0.00        {coef or "1.00"}        0.00        1.00        1.00
-------------------- MEMBERS -------------------------------------------------
             2   NMembers       - Number of members (-)
MemberID  MJointID1  MJointID2  MPropSetID1  MPropSetID2  MDivSize   MCoefMod  PropPot
  (-)        (-)        (-)         (-)          (-)        (m)      (switch)   (flag)
{members}
---------------------- MARINE GROWTH -------------------------------------------
{extra or "             0   NMGDepths      - Number of marine-growth depths specified (-)"}
END of file
"""
    path = tmp_path / "hydrodyn.dat"
    path.write_text(text, encoding="utf-8")
    return path


def _read(path: Path):  # type: ignore[no-untyped-def]
    values, lines = read_keyed_file(path)
    return read_morison_members(path, lines, values, RHO, G)


def test_submerged_horizontal_cylinder_buoyancy_and_added_mass(tmp_path: Path) -> None:
    """A horizontal cylinder (r 1 m, L 10 m, axis at z = −10 m) along x: V = π r² L, the
    buoyancy ρ g V up at its centre, restoring only from V z_B in pitch and roll (no
    waterplane); transverse added mass Ca ρ V in heave and sway, none along the axis (surge);
    in pitch only the heave velocity −x θ̇ carries added mass (the axial z θ̇ does not):
    A_55 = Ca ρ π r² L³/12."""
    path = _hydrodyn(
        tmp_path,
        "    1  -5.0  0.0  -10.0  1  0\n    2   5.0  0.0  -10.0  1  0\n"
        "    3   0.0  0.0  -30.0  1  0\n    4   0.0  0.0  -29.0  1  0",
        "    1   1   2   1   1   1.0   1   FALSE\n    2   3   4   1   1   1.0   1   TRUE",
    )
    m = _read(path)
    assert m is not None and m.count == 1
    vol = math.pi * 1.0**2 * 10.0
    assert m.volume_m3 == pytest.approx(vol, rel=1e-12)
    assert m.force_n[2] == pytest.approx(RHO * G * vol, rel=1e-12)
    assert m.force_n[4] == pytest.approx(0.0, abs=1e-6)  # centred: no pitch moment
    assert m.cb_z_m == pytest.approx(-10.0, rel=1e-12)
    assert m.waterplane_area_m2 == 0.0
    c = np.array(m.stiffness)
    assert c[2, 2] == 0.0
    assert c[4, 4] == pytest.approx(RHO * G * vol * -10.0, rel=1e-12)
    a = np.array(m.added_mass)
    assert a[0, 0] == pytest.approx(0.0, abs=1e-6)  # axial
    assert a[2, 2] == pytest.approx(RHO * vol, rel=1e-12)
    assert a[1, 1] == pytest.approx(RHO * vol, rel=1e-12)
    assert a[4, 4] == pytest.approx(RHO * math.pi * 10.0**3 / 12.0, rel=1e-12)


def test_offset_cylinder_moment_and_half_submerged_depth(tmp_path: Path) -> None:
    """Offset along x by 20 m: the buoyancy's pitch moment −ρ g V x_B; the Ca of the simple
    table scales the added mass (Ca 0.5)."""
    path = _hydrodyn(
        tmp_path,
        "    1  15.0  0.0  -10.0  1  0\n    2  25.0  0.0  -10.0  1  0\n"
        "    3   0.0  0.0  -30.0  1  0\n    4   0.0  0.0  -29.0  1  0",
        "    1   1   2   1   1   1.0   1   FALSE\n    2   3   4   1   1   1.0   1   TRUE",
        coef="0.50",
    )
    m = _read(path)
    assert m is not None
    vol = math.pi * 10.0
    assert m.force_n[4] == pytest.approx(-RHO * G * vol * 20.0, rel=1e-12)
    assert np.array(m.added_mass)[2, 2] == pytest.approx(0.5 * RHO * vol, rel=1e-12)


def test_swl_piercing_column_waterplane_stiffness(tmp_path: Path) -> None:
    """A vertical column (r 1 m) at x_c = 10 m from z = −8 m to +5 m: V = π r² 8, z_B = −4 m;
    C_33 = ρ g π r², C_35 = −ρ g π r² x_c, C_55 = ρ g (π r⁴/4 + π r² x_c² + V z_B)."""
    path = _hydrodyn(
        tmp_path,
        "    1  10.0  0.0  -8.0  1  0\n    2  10.0  0.0   5.0  1  0\n"
        "    3   0.0  0.0 -30.0  1  0\n    4   0.0  0.0 -29.0  1  0",
        "    1   1   2   1   1   1.0   1   FALSE\n    2   3   4   1   1   1.0   1   TRUE",
    )
    m = _read(path)
    assert m is not None
    area = math.pi
    vol = area * 8.0
    c = np.array(m.stiffness)
    rg = RHO * G
    assert m.volume_m3 == pytest.approx(vol, rel=1e-12)
    assert m.waterplane_area_m2 == pytest.approx(area, rel=1e-12)
    assert c[2, 2] == pytest.approx(rg * area, rel=1e-12)
    assert c[2, 4] == pytest.approx(-rg * area * 10.0, rel=1e-12)
    assert c[4, 2] == c[2, 4]
    assert c[4, 4] == pytest.approx(rg * (math.pi / 4 + area * 100.0 + vol * -4.0), rel=1e-12)
    assert c[3, 3] == pytest.approx(rg * (math.pi / 4 + vol * -4.0), rel=1e-12)


def test_inclined_piercing_member_cuts_an_ellipse() -> None:
    """A member tilted 30° from the vertical cuts the waterplane in an ellipse of area
    π r²/cos 30°; its submerged volume is π r² times the submerged axis length."""
    tilt = math.radians(30.0)
    end1 = (0.0, 0.0, -10.0)
    end2 = (20.0 * math.sin(tilt), 0.0, -10.0 + 20.0 * math.cos(tilt))
    vol, _, wp, awp, _, _ = morison_member(end1, end2, 1.0, 1.0, (1.0, 1.0))
    assert awp == pytest.approx(math.pi / math.cos(tilt), rel=1e-12)
    assert vol == pytest.approx(math.pi * 10.0 / math.cos(tilt), rel=1e-12)
    x_p = 10.0 * math.tan(tilt)
    # ∫x² dA of the ellipse (semi-axes 1/cos along x, 1 along y) about its centre: A a²/4
    assert wp[2] == pytest.approx(awp * x_p**2 + awp / 4.0 / math.cos(tilt) ** 2, rel=1e-12)


def test_depth_based_coefficients_refused_by_name(tmp_path: Path) -> None:
    path = _hydrodyn(
        tmp_path,
        "    1  -5.0  0.0  -10.0  1  0\n    2   5.0  0.0  -10.0  1  0\n"
        "    3   0.0  0.0  -30.0  1  0\n    4   0.0  0.0  -29.0  1  0",
        "    1   1   2   1   1   1.0   2   FALSE\n    2   3   4   1   1   1.0   1   TRUE",
    )
    with pytest.raises(ValueError, match=r"hydrodyn\.dat:\d+: member 1 .*MCoefMod = 2"):
        _read(path)


def test_marine_growth_is_stated_not_silent(tmp_path: Path) -> None:
    path = _hydrodyn(
        tmp_path,
        "    1  -5.0  0.0  -10.0  1  0\n    2   5.0  0.0  -10.0  1  0\n"
        "    3   0.0  0.0  -30.0  1  0\n    4   0.0  0.0  -29.0  1  0",
        "    1   1   2   1   1   1.0   1   FALSE\n    2   3   4   1   1   1.0   1   TRUE",
        extra="             2   NMGDepths      - Number of marine-growth depths specified (-)",
    )
    m = _read(path)
    assert m is not None
    assert any("marine-growth" in n for n in m.notes)
    assert any("drag and wave excitation are not" in n for n in m.notes)


def test_all_potential_flow_members_give_none(tmp_path: Path) -> None:
    path = _hydrodyn(
        tmp_path,
        "    1  -5.0  0.0  -10.0  1  0\n    2   5.0  0.0  -10.0  1  0\n"
        "    3   0.0  0.0  -30.0  1  0\n    4   0.0  0.0  -29.0  1  0",
        "    1   1   2   1   1   1.0   1   TRUE\n    2   3   4   1   1   1.0   1   TRUE",
    )
    assert _read(path) is None


def test_rectangular_strip_theory_member_refused_by_name(tmp_path: Path) -> None:
    path = _hydrodyn(
        tmp_path,
        "    1  -5.0  0.0  -10.0  1  0\n    2   5.0  0.0  -10.0  1  0\n"
        "    3   0.0  0.0  -30.0  1  0\n    4   0.0  0.0  -29.0  1  0",
        "    1   1   2   1   1   2   1.0   1   FALSE\n    2   3   4   1   1   1   1.0   1   TRUE",
    )
    text = path.read_text(encoding="utf-8").replace(
        "MPropSetID2  MDivSize", "MPropSetID2  MSecGeom  MDivSize"
    )
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=r"hydrodyn\.dat:\d+: member 1 .*rectangular"):
        _read(path)
