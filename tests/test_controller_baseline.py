"""Tests of the baseline controller core against the published NREL 5 MW / IEA 15 MW figures.

Expected values are computed here from the published figures (DESIGN.md "Reference figures",
Jonkman et al. 2009, and the IEA 15 MW DISCON.IN), independently of the controller's own
derived quantities. Tolerances are stated at each assertion.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
from _helpers import sensor_frame
from hypothesis import given, settings
from hypothesis import strategies as st

from controller.baseline import (
    BaselineController,
    BaselineParams,
    BaselineState,
    available_presets,
    load_baseline,
)
from controller.interface import ControlOutput
from controller.registry import make_controller

REPO = Path(__file__).resolve().parents[1]
IEA_DISCON = (
    REPO.parent
    / "shared/reference/openfast/IEA-15-240-RWT-UMaineSemi/IEA-15-240-RWT-UMaineSemi_DISCON.IN"
)

RPM = math.pi / 30.0
DEG = math.pi / 180.0

# Published NREL 5 MW baseline figures (DESIGN.md; Jonkman et al. 2009).
CUT_IN = 670.0 * RPM
RGN2_START = 871.0 * RPM
K_RPM2 = 0.0255764  # N m/rpm^2
K = K_RPM2 * (30.0 / math.pi) ** 2  # N m/(rad/s)^2
RT_GN_SP = 1161.963 * RPM
SLIP = 10.0
RATED_SPEED = 1173.7 * RPM
RATED_POWER = 5_296_610.0
RGN3_MIN_PITCH = 1.0 * DEG
MAX_TORQUE = 47_402.91
MAX_TORQUE_RATE = 15_000.0
KP = 0.01882681
KI = 0.008068634
THETA_K = 6.302336 * DEG
MAX_PITCH_RATE = 8.0 * DEG


@pytest.fixture(scope="module")
def nrel() -> BaselineParams:
    return load_baseline("nrel5mw_baseline")


def first_torque(params: BaselineParams, speed: float, pitch: float = 0.0) -> ControlOutput:
    """Torque law at a filtered speed: first call (filter = measurement), no rate limit."""
    ctrl = BaselineController(replace(params, max_generator_torque_rate_nm_s=1e15))
    _, out = ctrl.step(ctrl.initial_state(), sensor_frame(speed, pitch), 0.01)
    assert out.generator_speed_filtered_rad_s == pytest.approx(speed, rel=1e-15)
    return out


# --- constants ------------------------------------------------------------------------------


def test_region2_gain_conversion_rpm2_to_rad_s2() -> None:
    # 0.0255764 N m/rpm^2 is the published 2.332287 N m/(rad/s)^2 within 1e-6 relative.
    k_rad = K_RPM2 * (30.0 / math.pi) ** 2
    assert k_rad == pytest.approx(2.332287, rel=1e-6)
    assert k_rad != pytest.approx(2.332287, rel=1e-8)  # the check is sensitive at this level


def test_nrel_preset_holds_published_figures(nrel: BaselineParams) -> None:
    rel = 1e-12
    assert nrel.generator_speed_lpf_order == 1
    assert nrel.generator_speed_lpf_corner_rad_s == pytest.approx(2 * math.pi * 0.25, rel=rel)
    assert nrel.cut_in_generator_speed_rad_s == pytest.approx(CUT_IN, rel=rel)
    assert nrel.region2_start_generator_speed_rad_s == pytest.approx(RGN2_START, rel=rel)
    assert nrel.region2_gain_nm_per_rad_s2 == pytest.approx(K, rel=rel)
    assert nrel.region25_end_generator_speed_rad_s == pytest.approx(RT_GN_SP, rel=rel)
    assert nrel.region25_slip_percent == SLIP
    assert nrel.pitch_reference_generator_speed_rad_s == pytest.approx(RATED_SPEED, rel=rel)
    assert nrel.rated_mechanical_power_w == RATED_POWER
    assert nrel.region3_mode == "constant_power"
    assert nrel.region3_min_pitch_rad == pytest.approx(RGN3_MIN_PITCH, rel=rel)
    assert nrel.max_generator_torque_nm == MAX_TORQUE
    assert nrel.max_generator_torque_rate_nm_s == MAX_TORQUE_RATE
    assert nrel.pitch_kp_s == KP
    assert nrel.pitch_ki_dimensionless == KI
    assert nrel.pitch_gain_schedule_theta_k_rad == pytest.approx(THETA_K, rel=rel)
    assert nrel.min_pitch_rad == 0.0
    assert nrel.max_pitch_rad == pytest.approx(math.pi / 2, rel=rel)
    assert nrel.max_pitch_rate_rad_s == pytest.approx(MAX_PITCH_RATE, rel=rel)
    assert nrel.gearbox_ratio == 97.0
    # Derived DISCON constants (published to 7 significant figures).
    assert nrel.synchronous_generator_speed_rad_s == pytest.approx(RT_GN_SP / 1.1, rel=1e-12)
    assert nrel.rated_torque_nm == pytest.approx(43_528.84, rel=1e-6)


# --- torque law -----------------------------------------------------------------------------


def _sync() -> float:
    return RT_GN_SP / (1.0 + SLIP / 100.0)


def _slope25() -> float:
    return (RATED_POWER / RT_GN_SP) / (RT_GN_SP - _sync())


def _tr_gn_sp() -> float:
    s = _slope25()
    return (s - math.sqrt(s * (s - 4.0 * K * _sync()))) / (2.0 * K)


@pytest.mark.parametrize(
    ("rpm", "regime", "expected"),
    [
        (600.0, 0, lambda w: 0.0),
        (670.0, 0, lambda w: 0.0),
        (770.0, 1, lambda w: K * RGN2_START**2 / (RGN2_START - CUT_IN) * (w - CUT_IN)),
        (1000.0, 2, lambda w: K * w * w),
        (1150.0, 3, lambda w: _slope25() * (w - _sync())),
        (1165.0, 4, lambda w: RATED_POWER / w),
        (1300.0, 4, lambda w: RATED_POWER / w),
    ],
)
def test_torque_law_regions(nrel: BaselineParams, rpm: float, regime: int, expected) -> None:  # type: ignore[no-untyped-def]
    w = rpm * RPM
    out = first_torque(nrel, w)
    assert out.regime == regime
    # Closed-form published expression, 1e-9 relative (plus 1e-9 N m absolute for zero).
    assert out.generator_torque_commanded_nm == pytest.approx(expected(w), rel=1e-9, abs=1e-9)


def test_transition_speed_lies_in_region_2_5(nrel: BaselineParams) -> None:
    # VS_TrGnSp of the published figures is about 119.01 rad/s (1136.5 rpm).
    assert _tr_gn_sp() == pytest.approx(119.0138, rel=1e-5)
    assert nrel.transition_generator_speed_rad_s == pytest.approx(_tr_gn_sp(), rel=1e-12)
    assert RGN2_START < _tr_gn_sp() < RT_GN_SP


def test_region3_by_pitch_constant_power(nrel: BaselineParams) -> None:
    w = 1120.0 * RPM  # region 2 by speed; P/w = 45 158 N m < max torque
    below = first_torque(nrel, w, pitch=0.999 * RGN3_MIN_PITCH)
    above = first_torque(nrel, w, pitch=RGN3_MIN_PITCH)
    assert below.regime == 2
    assert above.regime == 4
    assert above.generator_torque_commanded_nm == pytest.approx(RATED_POWER / w, rel=1e-12)


def test_max_torque_saturation(nrel: BaselineParams) -> None:
    # Region 3 at 100 rad/s asks P/w = 52 966 N m > 47 402.91 N m.
    out = first_torque(nrel, 100.0, pitch=5.0 * DEG)
    assert out.generator_torque_commanded_nm == MAX_TORQUE


@pytest.mark.parametrize(
    ("boundary", "lo_regime", "hi_regime"),
    [(RGN2_START, 1, 2), (_tr_gn_sp(), 2, 3), (RT_GN_SP, 3, 4)],
    ids=["1.5-2 at 871 rpm", "2-2.5 at VS_TrGnSp", "2.5-3 at VS_RtGnSp"],
)
def test_torque_law_continuity(
    nrel: BaselineParams, boundary: float, lo_regime: int, hi_regime: int
) -> None:
    eps = 1e-9
    lo = first_torque(nrel, boundary * (1.0 - eps))
    hi = first_torque(nrel, boundary * (1.0 + eps))
    assert (lo.regime, hi.regime) == (lo_regime, hi_regime)
    # Continuous within 1e-6 relative across the boundary (jump << 1 N m).
    assert lo.generator_torque_commanded_nm == pytest.approx(
        hi.generator_torque_commanded_nm, rel=1e-6
    )


def test_region_1_5_to_2_value_at_871_rpm(nrel: BaselineParams) -> None:
    out = first_torque(nrel, RGN2_START * (1.0 - 1e-12))
    assert out.generator_torque_commanded_nm == pytest.approx(K * RGN2_START**2, rel=1e-9)


def test_torque_rate_limit_acts(nrel: BaselineParams) -> None:
    ctrl = BaselineController(nrel)
    dt = 0.01
    s, out = ctrl.step(ctrl.initial_state(), sensor_frame(1000 * RPM, 0.0, 0.0), dt)
    # From 0 N m measured, one sample may move at most 15 000 N m/s * 0.01 s = 150 N m.
    assert out.generator_torque_commanded_nm == pytest.approx(150.0, rel=1e-12)
    s, out = ctrl.step(s, sensor_frame(1000 * RPM), dt)
    assert out.generator_torque_commanded_nm == pytest.approx(300.0, rel=1e-12)


# --- generator-speed filter -----------------------------------------------------------------


def _run_filter(params: BaselineParams, signal, n: int, dt: float) -> list[float]:  # type: ignore[no-untyped-def]
    ctrl = BaselineController(params)
    s = ctrl.initial_state()
    out = []
    for k in range(n):
        s, o = ctrl.step(s, sensor_frame(signal(k * dt)), dt)
        out.append(o.generator_speed_filtered_rad_s)
    return out


def test_lpf_initialised_to_first_measurement_and_unit_dc_gain(nrel: BaselineParams) -> None:
    y = _run_filter(nrel, lambda t: 50.0 if t < 1.0 else 100.0, 3000, 0.01)
    assert y[0] == 50.0  # exact: initialised to the first measurement
    assert y[50] == pytest.approx(50.0, rel=1e-12)
    assert y[-1] == pytest.approx(100.0, rel=1e-9)  # 29 s = 45 time constants later


@pytest.mark.parametrize("preset", ["nrel5mw_baseline", "iea15mw_baseline"])
def test_lpf_minus_3db_at_corner(preset: str) -> None:
    params = load_baseline(preset)
    w_c = params.generator_speed_lpf_corner_rad_s
    dt = 0.01
    period = 2 * math.pi / w_c
    n = int(12 * period / dt)
    y = _run_filter(params, lambda t: 100.0 + math.sin(w_c * t), n, dt)
    tail = y[-int(2 * period / dt) :]
    ratio = (max(tail) - min(tail)) / 2.0
    # NREL: first order at 0.25 Hz -> 1/sqrt(2). IEA: second order, zeta 0.7 -> 1/(2 zeta) = 0.714.
    assert ratio == pytest.approx(0.707, abs=0.02)


# --- pitch PI -------------------------------------------------------------------------------


def test_gain_factor_half_at_theta_k(nrel: BaselineParams) -> None:
    ctrl = BaselineController(nrel)
    kp, ki, gk = ctrl.pitch_gains(THETA_K)
    assert gk == pytest.approx(0.5, rel=1e-12)
    assert kp == pytest.approx(0.5 * KP, rel=1e-12)
    assert ki == pytest.approx(0.5 * KI, rel=1e-12)
    assert ctrl.pitch_gains(0.0)[2] == 1.0


def test_first_call_pi_output_equals_measured_pitch(nrel: BaselineParams) -> None:
    ctrl = BaselineController(nrel)
    theta = 0.2
    _, out = ctrl.step(ctrl.initial_state(), sensor_frame(RATED_SPEED, theta, 40_000.0), 0.01)
    # Zero speed error: the PI output is the measured pitch (1e-12 relative).
    assert out.blade_pitch_commanded_rad == pytest.approx(theta, rel=1e-12)
    assert out.pitch_integrator_rad == pytest.approx(theta, rel=1e-12)
    assert out.gain_schedule_factor == pytest.approx(1 / (1 + theta / THETA_K), rel=1e-12)


def test_pitch_pi_one_step_closed_form(nrel: BaselineParams) -> None:
    """Second step: theta = GK (KP e + KI I) with GK of the previous command."""
    ctrl = BaselineController(nrel)
    dt = 0.01
    th0 = 0.1
    w = RATED_SPEED + 1.0
    s, o1 = ctrl.step(ctrl.initial_state(), sensor_frame(w, th0, 40_000.0), dt)
    gk0 = 1 / (1 + th0 / THETA_K)
    integ = th0 / (gk0 * KI) + 1.0 * dt
    expected1 = min(gk0 * (KP * 1.0 + KI * integ), th0 + MAX_PITCH_RATE * dt)
    assert o1.blade_pitch_commanded_rad == pytest.approx(expected1, rel=1e-12)
    s, o2 = ctrl.step(s, sensor_frame(w), dt)
    gk1 = 1 / (1 + expected1 / THETA_K)
    integ += 1.0 * dt
    expected2 = min(gk1 * (KP * 1.0 + KI * integ), expected1 + MAX_PITCH_RATE * dt)
    assert o2.gain_schedule_factor == pytest.approx(gk1, rel=1e-12)
    assert o2.blade_pitch_commanded_rad == pytest.approx(expected2, rel=1e-12)


def test_anti_windup_leaves_min_pitch_within_one_sample(nrel: BaselineParams) -> None:
    ctrl = BaselineController(nrel)
    dt = 0.01
    s = ctrl.initial_state()
    low, high = RATED_SPEED - 15.0, RATED_SPEED + 5.0
    for _ in range(60_000):  # 600 s saturated at minimum pitch
        s, o = ctrl.step(s, sensor_frame(low), dt)
        assert o.blade_pitch_commanded_rad == 0.0
        assert o.pitch_integrator_rad >= -1e-12  # integrator held at PC_MinPit / (GK KI)
    errors, pitches = [], []
    for _ in range(500):
        s, o = ctrl.step(s, sensor_frame(high), dt)
        errors.append(o.generator_speed_filtered_rad_s - RATED_SPEED)
        pitches.append(o.blade_pitch_commanded_rad)
    k = next(i for i, e in enumerate(errors) if e > 0.0)
    assert k > 0  # the filter delays the sign change; the test needs the history
    assert all(p == 0.0 for p in pitches[:k])
    assert pitches[k] > 0.0 or pitches[k + 1] > 0.0


# --- properties over random measurement sequences ---------------------------------------------

_measurements = st.lists(
    st.tuples(
        st.floats(-50.0, 500.0),  # generator speed [rad/s] (schema range)
        st.floats(-0.5, 1.8),  # measured pitch [rad]
        st.floats(-1e6, 1e8),  # measured torque [N m]
        st.floats(1e-3, 0.2),  # dt [s]
    ),
    min_size=1,
    max_size=60,
)


@pytest.mark.parametrize("preset", ["nrel5mw_baseline", "iea15mw_baseline"])
@settings(max_examples=150, deadline=None)
@given(seq=_measurements)
def test_rate_limits_bounds_and_finiteness(
    preset: str, seq: list[tuple[float, float, float, float]]
) -> None:
    params = load_baseline(preset)
    ctrl = BaselineController(params)
    s = ctrl.initial_state()
    th_prev = min(max(seq[0][1], params.min_pitch_rad), params.max_pitch_rad)
    t_prev = min(max(seq[0][2], 0.0), params.max_generator_torque_nm)
    for speed, pitch, torque, dt in seq:
        s, o = ctrl.step(s, sensor_frame(speed, pitch, torque), dt)
        values = [
            o.blade_pitch_commanded_rad,
            o.generator_torque_commanded_nm,
            o.generator_speed_filtered_rad_s,
            o.pitch_integrator_rad,
            o.gain_schedule_factor,
        ]
        assert all(math.isfinite(v) for v in values)
        assert 0 <= o.regime <= 4
        th, tq = o.blade_pitch_commanded_rad, o.generator_torque_commanded_nm
        # Rate limits: 8 deg/s (NREL) / PC_MaxRat (IEA), VS_MaxRat; 1e-12 relative slack.
        assert abs(th - th_prev) <= params.max_pitch_rate_rad_s * dt * (1 + 1e-12) + 1e-15
        assert abs(tq - t_prev) <= params.max_generator_torque_rate_nm_s * dt * (1 + 1e-12) + 1e-9
        assert params.min_pitch_rad <= th <= params.max_pitch_rad
        assert 0.0 <= tq <= params.max_generator_torque_nm
        th_prev, t_prev = th, tq


# --- IEA 15 MW preset -------------------------------------------------------------------------


def _discon(path: Path) -> dict[str, list[float]]:
    values: dict[str, list[float]] = {}
    for line in path.read_text().splitlines():
        if "!" not in line:
            continue
        data, comment = line.split("!", 1)
        parts = comment.split()
        if not parts or not data.split():
            continue
        try:
            values[parts[0]] = [float(x) for x in data.split()]
        except ValueError:
            continue
    return values


def test_iea_preset_loads_with_discon_figures() -> None:
    if not IEA_DISCON.is_file():
        pytest.skip(f"reference deck not present: {IEA_DISCON}")
    d = _discon(IEA_DISCON)
    p = load_baseline("iea15mw_baseline")
    exact = 1e-12
    assert p.generator_speed_lpf_order == d["F_LPFType"][0] == 2
    assert p.generator_speed_lpf_corner_rad_s == pytest.approx(d["F_LPFCornerFreq"][0], rel=exact)
    assert p.generator_speed_lpf_damping == pytest.approx(d["F_LPFDamping"][0], rel=exact)
    assert p.region2_gain_nm_per_rad_s2 == pytest.approx(d["VS_Rgn2K"][0], rel=exact)
    assert p.rated_generator_torque_nm == pytest.approx(d["VS_RtTq"][0], rel=exact)
    assert p.rated_torque_nm == pytest.approx(d["VS_RtTq"][0], rel=exact)
    assert p.region25_end_generator_speed_rad_s == pytest.approx(d["VS_RefSpd"][0], rel=exact)
    assert p.cut_in_generator_speed_rad_s == pytest.approx(d["VS_MinOMSpd"][0], rel=exact)
    assert p.max_generator_torque_rate_nm_s == pytest.approx(d["VS_MaxRat"][0], rel=exact)
    assert p.max_generator_torque_nm == pytest.approx(d["VS_MaxTq"][0], rel=exact)
    assert p.generator_efficiency_percent == pytest.approx(d["VS_GenEff"][0], rel=exact)
    # Mechanical rated power = VS_RtPwr / VS_GenEff; consistent with VS_RtTq * VS_RefSpd (1e-4).
    p_mech = d["VS_RtPwr"][0] / (d["VS_GenEff"][0] / 100.0)
    assert p.rated_mechanical_power_w == pytest.approx(p_mech, rel=1e-9)
    assert p_mech == pytest.approx(d["VS_RtTq"][0] * d["VS_RefSpd"][0], rel=1e-4)
    assert d["VS_ConstPower"][0] == 0 and p.region3_mode == "constant_torque"
    assert p.torque_pi_kp_nm_s_per_rad == pytest.approx(-d["VS_KP"][0], rel=exact)
    assert p.torque_pi_ki_nm_per_rad == pytest.approx(-d["VS_KI"][0], rel=exact)
    assert p.pitch_reference_generator_speed_rad_s == pytest.approx(d["PC_RefSpd"][0], rel=exact)
    assert p.max_pitch_rate_rad_s == pytest.approx(d["PC_MaxRat"][0], rel=exact)
    assert p.min_pitch_rad == d["PC_MinPit"][0]
    assert p.max_pitch_rad == pytest.approx(d["PC_MaxPit"][0], rel=exact)
    assert p.region3_min_pitch_rad == pytest.approx(
        d["PC_MinPit"][0] + d["PC_Switch"][0], rel=exact
    )
    n = int(d["PC_GS_n"][0])
    assert len(p.pitch_gs_angles_rad) == n
    assert p.pitch_gs_angles_rad == pytest.approx(d["PC_GS_angles"], rel=exact)
    # Sign convention: ROSCO's negative gains (error = ref - speed) are stored negated.
    assert p.pitch_gs_kp_s == pytest.approx([-v for v in d["PC_GS_KP"]], rel=exact)
    assert p.pitch_gs_ki_dimensionless == pytest.approx([-v for v in d["PC_GS_KI"]], rel=exact)


def test_iea_gain_table_interpolation() -> None:
    p = load_baseline("iea15mw_baseline")
    ctrl = BaselineController(p)
    a, kp, ki = p.pitch_gs_angles_rad, p.pitch_gs_kp_s, p.pitch_gs_ki_dimensionless
    mid = 0.5 * (a[3] + a[4])
    got_kp, got_ki, factor = ctrl.pitch_gains(mid)
    assert got_kp == pytest.approx(0.5 * (kp[3] + kp[4]), rel=1e-12)
    assert got_ki == pytest.approx(0.5 * (ki[3] + ki[4]), rel=1e-12)
    assert factor == pytest.approx(got_ki / ki[0], rel=1e-12)
    assert ctrl.pitch_gains(0.0)[:2] == (kp[0], ki[0])  # held below the table
    assert ctrl.pitch_gains(1.0)[:2] == (kp[-1], ki[-1])  # held above the table


def test_iea_torque_pi_region_2_5() -> None:
    # the K omega^2 law with the region-2.5 torque PI that the advanced controller keeps
    # below rated (the preset itself tracks the optimal TSR: tests/test_iea15_schedule.py)
    p = load_baseline("iea15mw_baseline").without_wind_schedule()
    ctrl = BaselineController(replace(p, max_generator_torque_rate_nm_s=1e15))
    # Region 2 well below rated speed: K w^2 (the PI sits on the floor).
    w = 0.7
    _, o = ctrl.step(ctrl.initial_state(), sensor_frame(w, 0.0, 0.0), 0.01)
    assert o.regime == 2
    assert o.generator_torque_commanded_nm == pytest.approx(p.region2_gain_nm_per_rad_s2 * w * w)
    # Above VS_RefSpd with pitch at fine pitch: PI drives torque to VS_RtTq, never beyond.
    s = ctrl.initial_state()
    for _ in range(200):
        s, o = ctrl.step(s, sensor_frame(0.80, 0.0, 1.5e7), 0.01)
        assert o.generator_torque_commanded_nm <= p.rated_torque_nm * (1 + 1e-12)
    assert o.generator_torque_commanded_nm == pytest.approx(p.rated_torque_nm, rel=1e-12)


# --- loader and validation --------------------------------------------------------------------


def test_presets_shipped() -> None:
    assert {"nrel5mw_baseline", "iea15mw_baseline"} <= set(available_presets())
    assert load_baseline("nrel5mw_baseline.toml").name == "nrel5mw_baseline"


def test_loader_rejects_unknown_key_naming_it(tmp_path: Path) -> None:
    from importlib import resources

    text = (resources.files("controller.presets") / "nrel5mw_baseline.toml").read_text()
    path = tmp_path / "mine.toml"
    path.write_text(text + "\nregion2_gain_typo = 1.0\n")
    with pytest.raises(ValueError, match="region2_gain_typo"):
        load_baseline(path)
    path.write_text(text)
    assert load_baseline(path) == load_baseline("nrel5mw_baseline")
    assert load_baseline(str(path)).name == "nrel5mw_baseline"


def test_loader_rejects_same_quantity_twice(tmp_path: Path) -> None:
    from importlib import resources

    text = (resources.files("controller.presets") / "nrel5mw_baseline.toml").read_text()
    path = tmp_path / "twice.toml"
    path.write_text(text + "\nmin_pitch_rad = 0.0\n")
    with pytest.raises(ValueError, match="min_pitch_rad and min_pitch_deg"):
        load_baseline(path)


def test_loader_unknown_preset() -> None:
    with pytest.raises(ValueError, match="unknown baseline preset"):
        load_baseline("no_such_turbine")


def test_params_validation_names_field_and_unit(nrel: BaselineParams) -> None:
    with pytest.raises(ValueError, match=r"region2_gain_nm_per_rad_s2.*N m/\(rad/s\)\^2"):
        replace(nrel, region2_gain_nm_per_rad_s2=-1.0)
    with pytest.raises(ValueError, match=r"max_pitch_rate_rad_s.*rad/s"):
        replace(nrel, max_pitch_rate_rad_s=0.0)
    with pytest.raises(ValueError, match="max_pitch_rad"):
        replace(nrel, max_pitch_rad=-0.1)
    with pytest.raises(ValueError, match="generator_speed_lpf_corner_rad_s"):
        replace(nrel, generator_speed_lpf_corner_rad_s=math.nan)
    with pytest.raises(ValueError, match="exactly one pitch gain schedule"):
        replace(
            nrel, pitch_gs_angles_rad=(0.0,), pitch_gs_kp_s=(0.1,), pitch_gs_ki_dimensionless=(0.1,)
        )


def test_step_rejects_bad_dt(nrel: BaselineParams) -> None:
    ctrl = BaselineController(nrel)
    for dt in (0.0, -0.01, math.nan, math.inf):
        with pytest.raises(ValueError, match="dt_s"):
            ctrl.step(ctrl.initial_state(), sensor_frame(100.0), dt)


def test_controller_and_state_are_immutable(nrel: BaselineParams) -> None:
    ctrl = BaselineController(nrel)
    with pytest.raises(AttributeError):
        ctrl.params = nrel  # type: ignore[misc]
    s = ctrl.initial_state()
    assert isinstance(s, BaselineState) and s.first_call
    with pytest.raises(AttributeError):
        s.first_call = False  # type: ignore[misc]


@pytest.mark.parametrize("preset", ["nrel5mw_baseline", "iea15mw_baseline"])
def test_step_never_modifies_its_state(preset: str) -> None:
    """The state is the kernel's array: a step returns a new one and leaves the old one
    (and the initial state) as it was; the same state and frame give the same result."""
    ctrl = BaselineController(load_baseline(preset))
    s0 = ctrl.initial_state()
    s1, _ = ctrl.step(s0, sensor_frame(800.0 * RPM, 0.05, 1.0e6), 0.01)
    assert s0.first_call and not s0.values.any()
    kept = s1.values.copy()
    s2, o2 = ctrl.step(s1, sensor_frame(1300.0 * RPM, 0.05, 1.0e6), 0.01)
    assert (s1.values == kept).all() and not s1.first_call
    assert s2.values is not s1.values
    s2b, o2b = ctrl.step(s1, sensor_frame(1300.0 * RPM, 0.05, 1.0e6), 0.01)
    assert (s2b.values == s2.values).all() and o2b == o2
    assert s2.generator_speed_filtered_rad_s == float(s2.values[2])
    assert s2.blade_pitch_commanded_rad == o2.blade_pitch_commanded_rad


def test_make_controller_registry() -> None:
    ctrl = make_controller("baseline", "nrel5mw_baseline")
    _, out = ctrl.step(ctrl.initial_state(), sensor_frame(100.0), 0.01)
    assert isinstance(out, ControlOutput)
    with pytest.raises(ValueError, match="unknown controller kind"):
        make_controller("no-such-kind", "nrel5mw_baseline")


def test_controller_does_not_import_plant() -> None:
    code = (
        "import controller.baseline, controller.registry, sys; "
        "assert not any(m == 'plant' or m.startswith('plant.') for m in sys.modules), "
        "sorted(m for m in sys.modules if m.startswith('plant'))"
    )
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
    }
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, result.stderr
