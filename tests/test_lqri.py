"""LQRI runtime core: import boundary, regimes, limits, anti-windup."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from controller.lqri import LqriController, LqriMeasurement, load_lqri_design


@pytest.fixture(scope="module")
def ctrl() -> LqriController:
    return LqriController(load_lqri_design("iea15mw_volturnus"))


def _meas(wind: float, omega: float, pitch: float = 0.0) -> LqriMeasurement:
    return LqriMeasurement(
        wind_speed_estimate_m_s=wind, rotor_speed_rad_s=omega, blade_pitch_rad=pitch
    )


def test_runtime_never_imports_plant() -> None:
    code = "import sys, controller.lqri as m; m.load_lqri_design(); print('plant' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_below_rated_uses_the_torque_law(ctrl: LqriController) -> None:
    d = ctrl.design
    st = ctrl.initial_state()
    for _ in range(10):
        st, out = ctrl.step(st, _meas(7.0, 0.5), 0.025)
    assert out.regime == 2
    assert out.blade_pitch_commanded_rad == pytest.approx(d.pitch_min_rad)
    assert out.generator_torque_commanded_nm == pytest.approx(d.torque_gain_nm_s2 * 0.25, rel=1e-6)


def test_above_rated_limits_and_hysteresis(ctrl: LqriController) -> None:
    d = ctrl.design
    st = ctrl.initial_state()
    prev = 0.0
    for _ in range(400):  # large overspeed: pitch rises at the rate limit, never beyond
        st, out = ctrl.step(st, _meas(18.0, 1.2 * d.rated_rotor_speed_rad_s, prev), 0.025)
        assert out.regime == 4
        assert out.blade_pitch_commanded_rad - prev <= d.pitch_rate_max_rad_s * 0.025 + 1e-12
        assert d.pitch_min_rad <= out.blade_pitch_commanded_rad <= d.pitch_max_rad
        prev = out.blade_pitch_commanded_rad
    # Anti-windup: the integrator held while the rate limit acted, so it recovers at once.
    st, out = ctrl.step(st, _meas(18.0, d.rated_rotor_speed_rad_s, prev), 0.025)
    assert abs(out.blade_pitch_commanded_rad - prev) <= d.pitch_rate_max_rad_s * 0.025 + 1e-12
    # Inside the hysteresis band the regime holds.
    st, out = ctrl.step(st, _meas(d.switch_wind_m_s - 0.4 * d.hysteresis_m_s, 0.79, prev), 0.025)
    assert out.regime == 4
    assert math.isfinite(out.pitch_integrator_rad)


def test_steady_rated_point_holds_the_operating_pitch(ctrl: LqriController) -> None:
    d = ctrl.design
    i = d.wind_m_s.index(15.0)
    x = d.x_op[i]
    m = LqriMeasurement(
        wind_speed_estimate_m_s=15.0,
        rotor_speed_rad_s=d.rated_rotor_speed_rad_s,
        blade_pitch_rad=d.theta_op[i],
        platform_surge_m=x[0],
        platform_pitch_rad=x[1],
        tower_top_deflection_m=x[2],
    )
    st = ctrl.initial_state()
    for _ in range(200):
        st, out = ctrl.step(st, m, 0.025)
    assert out.blade_pitch_commanded_rad == pytest.approx(d.theta_op[i], abs=1e-6)
    assert out.generator_torque_commanded_nm == pytest.approx(d.rated_torque_nm, rel=1e-6)


def test_wave_feedforward_enters_torque_below_and_pitch_above() -> None:
    from controller.lqri import load_wave_ff_design

    d = load_lqri_design("iea15mw_volturnus")
    ff = load_wave_ff_design("iea15mw_volturnus")
    off = LqriController(d)
    on = LqriController(d, ff, "balanced")
    with pytest.raises(ValueError):
        LqriController(d, None, "balanced")
    # Below 17 m/s: torque = K w^2 + u_ff (before the limits), pitch untouched.
    s_off, s_on = off.initial_state(), on.initial_state()
    for k in range(200):
        eta = math.sin(0.8 * k * 0.025)
        m = LqriMeasurement(
            wind_speed_estimate_m_s=7.0,
            rotor_speed_rad_s=0.5,
            blade_pitch_rad=0.0,
            wave_elevation_forecast_m=eta,
        )
        s_off, o_off = off.step(s_off, m, 0.025)
        s_on, o_on = on.step(s_on, m, 0.025)
    assert s_on.feedforward_pitch_rad == 0.0
    assert s_on.feedforward_torque_nm != 0.0
    assert o_on.blade_pitch_commanded_rad == o_off.blade_pitch_commanded_rad
    assert o_on.generator_torque_commanded_nm == pytest.approx(
        o_off.generator_torque_commanded_nm + s_on.feedforward_torque_nm, rel=1e-9
    )
    # Above 17 m/s: pitch FF, within the pitch limits; NaN forecast gives no FF.
    st = on.initial_state()
    prev = d.theta_op[d.wind_m_s.index(20.0)]
    for k in range(200):
        m = LqriMeasurement(
            wind_speed_estimate_m_s=20.0,
            rotor_speed_rad_s=d.rated_rotor_speed_rad_s,
            blade_pitch_rad=prev,
            wave_elevation_forecast_m=2.0 * math.sin(0.8 * k * 0.025),
        )
        st, out = on.step(st, m, 0.025)
        assert abs(out.blade_pitch_commanded_rad - prev) <= d.pitch_rate_max_rad_s * 0.025 + 1e-12
        prev = out.blade_pitch_commanded_rad
    assert st.feedforward_torque_nm == 0.0
    assert st.feedforward_pitch_rad != 0.0
    st, out = on.step(st, _meas(20.0, d.rated_rotor_speed_rad_s, prev), 0.025)
    assert st.feedforward_pitch_rad == 0.0


def test_below_rated_laws_are_passed_through_and_the_integrator_rests(
    ctrl: LqriController,
) -> None:
    """Below rated the torque and pitch of the below-rated laws (the baseline's, given
    by the runtime) are applied, rate limited; the LQRI integrator stays at 0 (no wind-up while
    the pitch sits at fine pitch) and the regime is the law's (here region 1.5)."""
    d = ctrl.design
    st = ctrl.initial_state()
    law = 5.0e6
    for _ in range(400):  # 10 s at fine pitch, rotor slow (5 rpm), wind 7 m/s
        m = LqriMeasurement(
            wind_speed_estimate_m_s=7.0,
            rotor_speed_rad_s=0.53,
            blade_pitch_rad=0.0,
            torque_law_nm=law,
            pitch_below_rated_rad=d.pitch_min_rad,
            regime_below_rated=1,
        )
        st, out = ctrl.step(st, m, 0.025)
        assert st.integrator_rad == 0.0
        assert out.pitch_integrator_rad == 0.0
    assert out.regime == 1
    assert out.generator_torque_commanded_nm == pytest.approx(law, rel=1e-12)
    assert out.blade_pitch_commanded_rad == d.pitch_min_rad


def test_lqri_integrator_back_calculated_at_fine_pitch(ctrl: LqriController) -> None:
    """In the pitch regime with the rotor below rated (a lull) the pitch saturates at
    fine pitch for 30 s; the integrator is back-calculated, so the pitch leaves fine pitch on
    the first cycles of overspeed (a wound-up integrator would hold it there for seconds)."""
    d = ctrl.design
    st = ctrl.initial_state()
    for _ in range(1200):
        m = LqriMeasurement(
            wind_speed_estimate_m_s=14.0,
            rotor_speed_rad_s=0.9 * d.rated_rotor_speed_rad_s,
            blade_pitch_rad=d.pitch_min_rad,
            torque_law_nm=d.rated_torque_nm,
        )
        st, out = ctrl.step(st, m, 0.025)
        assert out.regime == 4
        assert out.blade_pitch_commanded_rad == d.pitch_min_rad
    z_sat = st.integrator_rad
    pitches = []
    for _ in range(8):  # 0.2 s of 5 % overspeed
        m = LqriMeasurement(
            wind_speed_estimate_m_s=14.0,
            rotor_speed_rad_s=1.05 * d.rated_rotor_speed_rad_s,
            blade_pitch_rad=d.pitch_min_rad,
            torque_law_nm=d.rated_torque_nm,
        )
        st, out = ctrl.step(st, m, 0.025)
        pitches.append(out.blade_pitch_commanded_rad)
    assert math.isfinite(z_sat)
    assert pitches[-1] > d.pitch_min_rad, pitches


def test_lqri_integrator_holds_while_only_the_rate_limit_acts(ctrl: LqriController) -> None:
    """Conditional integration: at the rated point, a 2 % overspeed asks for more pitch than
    the rate limit gives in one cycle; while the command rides the rate limit the
    integrator keeps its value (it neither integrates the overspeed nor is reset to follow
    the command, which made it follow every noisy estimate), and once the command reaches
    the law's it integrates again."""
    d = ctrl.design
    i = d.wind_m_s.index(15.0)
    x = d.x_op[i]

    def meas(omega: float, pitch: float) -> LqriMeasurement:
        return LqriMeasurement(
            wind_speed_estimate_m_s=15.0,
            rotor_speed_rad_s=omega,
            blade_pitch_rad=pitch,
            platform_surge_m=x[0],
            platform_pitch_rad=x[1],
            tower_top_deflection_m=x[2],
        )

    st = ctrl.initial_state()
    for _ in range(200):
        st, out = ctrl.step(st, meas(d.rated_rotor_speed_rad_s, d.theta_op[i]), 0.025)
    z0, prev = st.integrator_rad, out.blade_pitch_commanded_rad
    step = d.pitch_rate_max_rad_s * 0.025
    limited = 0
    for _ in range(80):
        z_before = st.integrator_rad
        st, out = ctrl.step(st, meas(1.02 * d.rated_rotor_speed_rad_s, prev), 0.025)
        rate_limited = out.blade_pitch_commanded_rad - prev == pytest.approx(step, rel=1e-9)
        if rate_limited:
            limited += 1
            assert st.integrator_rad == z_before  # held: not integrated, not reset
        prev = out.blade_pitch_commanded_rad
    assert limited >= 3  # the case happened
    assert st.integrator_rad > z0  # integrating again once the command caught up
