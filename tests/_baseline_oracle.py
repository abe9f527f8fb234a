"""The baseline controller's step in plain Python: the oracle of its compiled kernel.

:meth:`controller.baseline.BaselineController.step` runs
:func:`controller._kernels.baseline_step` on its state array; this module keeps the same law
written statement by statement in Python floats on a named state (:class:`OracleState`),
from the equations of :mod:`controller.baseline`'s docstring, so that tests check the
kernel (and everything built on it) against an independent implementation.
"""

from __future__ import annotations

import math
from bisect import bisect_right

import msgspec

from bus_schemas.messages import EST_WIND_SPEED, VALID_PLATFORM_PITCH_RATE, SensorFrame
from controller.baseline import BaselineController, _min_pitch
from controller.estimators import WindEKFState
from controller.interface import (
    REGIME_REGION_1,
    REGIME_REGION_1_5,
    REGIME_REGION_2,
    REGIME_REGION_2_5,
    REGIME_REGION_3,
    ControlOutput,
)


class OracleState(msgspec.Struct, frozen=True, gc=False):
    """The baseline's state by name (the former ``BaselineState``), for :func:`oracle_step`.

    Attributes
    ----------
    first_call : bool
        True before the first step; the first step initialises from the measurement.
    lpf_z1, lpf_z2 : float
        Generator-speed filter states [rad/s] (order 1: ``lpf_z1`` is the last output).
    generator_speed_filtered_rad_s : float
        Last filtered generator speed [rad/s].
    pitch_speed_error_integral_rad : float
        :math:`I = \\int (\\omega_f-\\omega_{ref})\\,dt` of the pitch PI [rad].
    torque_speed_error_integral_rad : float
        :math:`\\int (\\omega_f-\\omega_{rt})\\,dt` of the torque PI [rad] (``"pi"`` mode).
    blade_pitch_commanded_rad : float
        Last pitch command [rad].
    generator_torque_commanded_nm : float
        Last torque command [N m].
    wind_filtered_m_s : float
        ``"tsr_tracking"``: low-pass filtered wind estimate :math:`\\hat v_f` [m/s].
    setpoint_shift_rad_s : float
        ``"tsr_tracking"``: filtered setpoint-smoother shift :math:`\\Delta\\omega_f` [rad/s].
    min_pitch_rad : float
        ``"tsr_tracking"``: the last minimum pitch :math:`\\theta_{lo}` [rad].
    wind_ekf_x, wind_ekf_p : tuple of float
        ``"tsr_tracking"``: the wind EKF's state and covariance
        (:class:`controller.estimators.WindEKFState`).
    fl_hpf_lp, fl_lpf_z1, fl_lpf_z2 : float
        ``"tsr_tracking"``: states of the platform-pitch-rate filters [rad/s] (the high
        pass's low-pass part, the second-order low pass).
    platform_pitch_rate_rad_s : float
        ``"tsr_tracking"``: the last valid platform pitch rate [rad/s] (held on dropout).
    estimator_faults, wind_bad_s, wind_good_s, wind_fallback, wind_last_good_m_s
        ``"tsr_tracking"``: the wind guard's faults so far, current bad and healthy runs
        [s], fallback flag and last good filtered estimate [m/s].
    fl_samples : float
        Valid platform-pitch-rate samples so far (the high pass's running-mean start).
    trimmed : bool
        With ``first_call``: a trimmed start, the EKF and the wind filter start from the
        values here (``BaselineController.trimmed_state``).
    """

    first_call: bool
    lpf_z1: float
    lpf_z2: float
    generator_speed_filtered_rad_s: float
    pitch_speed_error_integral_rad: float
    torque_speed_error_integral_rad: float
    blade_pitch_commanded_rad: float
    generator_torque_commanded_nm: float
    wind_filtered_m_s: float = 0.0
    setpoint_shift_rad_s: float = 0.0
    min_pitch_rad: float = 0.0
    wind_ekf_x: tuple[float, float, float] = (0.0, 0.0, 0.0)
    wind_ekf_p: tuple[float, float, float, float, float, float] = (0.0,) * 6
    fl_hpf_lp: float = 0.0
    fl_lpf_z1: float = 0.0
    fl_lpf_z2: float = 0.0
    platform_pitch_rate_rad_s: float = 0.0
    estimator_faults: int = 0
    wind_bad_s: float = 0.0
    wind_good_s: float = 0.0
    wind_fallback: bool = False
    wind_last_good_m_s: float = 0.0
    trimmed: bool = False
    fl_samples: float = 0.0


ORACLE_INITIAL = OracleState(True, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def lowpass2_step(
    u: float, w_c: float, zeta: float, dt_s: float, z1: float, z2: float, first_call: bool
) -> tuple[float, float, float]:
    """One step of a second-order low pass, (y, z1, z2).

    Tustin discretisation of :math:`\\omega_c^2 / (s^2 + 2\\zeta\\omega_c s + \\omega_c^2)`
    [rad/s, -, s], direct form II transposed; on the first call the states start at the
    steady state of ``u`` (no start transient). The oracle of
    :func:`controller._kernels.lowpass2_step`.
    """
    c = 2.0 / dt_s
    c2 = c * c
    wc2 = w_c * w_c
    cz = 2.0 * zeta * w_c * c
    inv_a0 = 1.0 / (c2 + cz + wc2)
    b0 = wc2 * inv_a0
    a1 = 2.0 * (wc2 - c2) * inv_a0
    a2 = (c2 - cz + wc2) * inv_a0
    if first_call:
        z1 = (1.0 - b0) * u
        z2 = (b0 - a2) * u
    y = b0 * u + z1
    z1 = 2.0 * b0 * u - a1 * y + z2
    z2 = b0 * u - a2 * y
    return y, z1, z2


def _table_gains(
    angles: tuple[float, ...],
    kps: tuple[float, ...],
    kis: tuple[float, ...],
    theta: float,
    inv_ki_ref: float,
) -> tuple[float, float, float]:
    """Linear interpolation of (K_P, K_I) in a pitch table, end values held."""
    n = len(angles)
    if theta <= angles[0]:
        kp, ki = kps[0], kis[0]
    elif theta >= angles[n - 1]:
        kp, ki = kps[n - 1], kis[n - 1]
    else:
        j = bisect_right(angles, theta)
        a0 = angles[j - 1]
        f = (theta - a0) / (angles[j] - a0)
        kp = kps[j - 1] + f * (kps[j] - kps[j - 1])
        ki = kis[j - 1] + f * (kis[j] - kis[j - 1])
    return kp, ki, ki * inv_ki_ref


def oracle_pitch_gains(ctrl: BaselineController, pitch_rad: float) -> tuple[float, float, float]:
    """:meth:`BaselineController.pitch_gains` in Python: (G_K K_P, G_K K_I, G_K)."""
    k = ctrl._k
    if k[25]:
        return _table_gains(k[29], k[30], k[31], pitch_rad, k[32])
    gk = 1.0 / (1.0 + pitch_rad / k[28])
    return gk * k[26], gk * k[27], gk


def oracle_step(
    ctrl: BaselineController, state: OracleState, measurement: SensorFrame, dt_s: float
) -> tuple[OracleState, ControlOutput]:
    """:meth:`BaselineController.step` in Python (module docstring), on a named state."""
    if not 0.0 < dt_s < math.inf:
        raise ValueError(f"dt_s must be finite and > 0 s, got {dt_s!r}")
    (
        order2,
        w_c,
        zeta,
        w_ci,
        w_2,
        K,
        slope15,
        w_rt,
        w_tr,
        slope25,
        w_sy,
        pi_mode,
        w_tq_ref,
        kp_t,
        ki_t,
        const_torque,
        power_rated,
        tq_rated,
        theta_3,
        tq_max,
        tq_rate,
        w_ref,
        th_min,
        th_max,
        th_rate,
        table,
        kp0,
        ki0,
        theta_k,
        gs_ang,
        gs_kp,
        gs_ki,
        inv_ki_ref,
        w_pmax,
        tsr,
        tsr_gain,
        w_we,
        ss_vs,
        ss_pc,
        w_ss,
        eta,
        p_rt_e,
        th_switch,
        gear,
        _p22_0,
        _n_ps,
        k_fl,
        w_fl,
        zeta_fl,
        w_hp,
        ps_wind,
        ps_pitch,
        gate2,
        v_lo,
        v_hi,
        t_fault,
        t_recover,
        k_opt,
    ) = ctrl._k
    w = measurement.generator_speed_measured_rad_s

    # --- generator-speed low-pass filter --------------------------------------------
    if order2:
        w_f, z1, z2 = lowpass2_step(
            w, w_c, zeta, dt_s, state.lpf_z1, state.lpf_z2, state.first_call
        )
    else:
        alpha = math.exp(-dt_s * w_c)
        prev = w if state.first_call else state.lpf_z1
        w_f = (1.0 - alpha) * w + alpha * prev
        z1 = w_f
        z2 = 0.0

    # --- previous commands (first call: from the actuator measurements) ----------------
    if state.first_call:
        th_prev = min(max(measurement.blade_pitch_measured_rad, th_min), th_max)
        tq_prev = min(max(measurement.generator_torque_measured_nm, 0.0), tq_max)
    else:
        th_prev = state.blade_pitch_commanded_rad
        tq_prev = state.generator_torque_commanded_nm

    # --- pitch gain schedule (from the previous pitch command) ------------------------
    if table:
        kp_eff, ki_eff, gk = _table_gains(gs_ang, gs_kp, gs_ki, th_prev, inv_ki_ref)
    else:
        gk = 1.0 / (1.0 + th_prev / theta_k)
        kp_eff = gk * kp0
        ki_eff = gk * ki0

    # --- wind estimate, minimum pitch, setpoint smoother, TSR-tracking torque -----------
    th_lo = th_min
    w_pc = w_ref
    i_t = state.torque_speed_error_integral_rad
    if tsr:
        ekf = ctrl.ekf
        assert ekf is not None
        omega_r = w / gear
        trim_start = state.first_call and state.trimmed
        if trim_start:  # BaselineController.trimmed_state: the EKF and filter as held
            x_e, p_e = state.wind_ekf_x, state.wind_ekf_p
            faults, t_bad, t_good, fallback = 0, 0.0, 0.0, False
            v_hold = state.wind_filtered_m_s
        elif state.first_call:  # ROSCO: the anemometer, at least 3 m/s
            est0 = ekf.initial_state(
                omega_r,
                measurement.blade_pitch_measured_rad,
                measurement.generator_torque_measured_nm,
                max(measurement.wind_speed_measured_m_s, 3.0),
            )
            x_e, p_e = est0.x, est0.p
            faults, t_bad, t_good, fallback = 0, 0.0, 0.0, False
            v_hold = est0.x[2]
        else:
            x_e, p_e = state.wind_ekf_x, state.wind_ekf_p
            faults, t_bad, t_good = state.estimator_faults, state.wind_bad_s, state.wind_good_s
            fallback, v_hold = state.wind_fallback, state.wind_last_good_m_s
        # the guard: predict, gate the innovation at k sigma, bound the estimate
        pred = ekf.predict(
            WindEKFState(x_e, p_e),
            (measurement.blade_pitch_measured_rad, measurement.generator_torque_measured_nm),
            dt_s,
        )
        y = omega_r - pred.x[0]
        s_y = pred.p[0] + ekf.config.rotor_speed_noise_std_rad_s**2
        bad = not (y * y <= gate2 * s_y)
        upd = pred if bad else ekf.update(pred, omega_r)
        om_e, u_t, u_m = upd.x
        if not (u_t + u_m >= v_lo):
            u_t, bad = v_lo - u_m, True
        elif u_t + u_m > v_hi:
            u_t, bad = v_hi - u_m, True
        x_e, p_e = (om_e, u_t, u_m), upd.p
        finite = all(math.isfinite(a) for a in (*x_e, *p_e))
        if bad:
            t_bad, t_good = t_bad + dt_s, 0.0
        else:
            t_bad, t_good = 0.0, t_good + dt_s
        if not finite or t_bad >= t_fault:  # a fault: restart at the last good estimate
            if not fallback:
                faults, fallback = faults + 1, True
            restart = ekf.initial_state(
                omega_r if math.isfinite(omega_r) else 0.0,
                measurement.blade_pitch_measured_rad,
                measurement.generator_torque_measured_nm,
                v_hold,
            )
            x_e, p_e = restart.x, restart.p
            t_bad, t_good = 0.0, 0.0
        elif fallback and t_good >= t_recover:
            fallback = False
        v = x_e[1] + x_e[2]
        if fallback:
            v_f = v_hold
        elif state.first_call and not trim_start:
            v_f = v
        else:
            a_w = math.exp(-dt_s * w_we)
            v_f = (1.0 - a_w) * v + a_w * state.wind_filtered_m_s
        if not fallback and t_bad == 0.0:
            v_hold = v_f
        th_lo = _min_pitch(ps_wind, ps_pitch, v_f, th_min)
        # setpoint smoother: the shift from the previous pitch over the last minimum
        # pitch and from the power deficit (electrical power eta * T * w_f)
        th_lo_prev = th_lo if state.first_call else state.min_pitch_rad
        p_el = eta * tq_prev * w_f
        d_om = ((th_prev - th_lo_prev) / 0.524 * ss_vs - (p_rt_e - p_el) / p_rt_e * ss_pc) * w_ref
        if state.first_call:
            ss = d_om
        else:
            a_s = math.exp(-dt_s * w_ss)
            ss = (1.0 - a_s) * d_om + a_s * state.setpoint_shift_rad_s
        if ss < 0.0:
            w_pc = w_ref - ss
        w_vs = min(max(tsr_gain * v_f, w_ci), w_tq_ref)
        if ss > 0.0:
            w_vs = w_vs - ss
        w_vs = max(w_vs, w_ci)
        e_t = w_f - w_vs
        if state.first_call:
            i_t = tq_prev / ki_t
        if fallback:  # K omega^2 (rated torque on the pitch criterion); the PI tracks it
            tq = tq_rated if th_prev >= th_lo + th_switch else min(k_opt * w_f * w_f, tq_rated)
            i_t = tq / ki_t
        else:
            i_t += e_t * dt_s
            if i_t < 0.0:
                i_t = 0.0
            elif i_t > tq_rated / ki_t:
                i_t = tq_rated / ki_t
            tq = kp_t * e_t + ki_t * i_t
            if tq < 0.0:
                tq = 0.0
            elif tq > tq_rated:
                tq = tq_rated
        if fallback:
            v = v_f
        if th_prev >= th_lo + th_switch:
            regime = REGIME_REGION_3
        elif tq >= tq_rated:
            regime = REGIME_REGION_2_5
        elif w_vs <= w_ci:
            regime = REGIME_REGION_1_5
        else:
            regime = REGIME_REGION_2
    # --- generator torque (K omega^2 law) -----------------------------------------------
    elif w_f >= w_rt or th_prev >= theta_3:
        if const_torque:
            tq = tq_rated
            regime = REGIME_REGION_3
        elif w_f > w_pmax:
            tq = power_rated / w_f
            regime = REGIME_REGION_3
        elif w_f > 0.0:
            tq = tq_max
            regime = REGIME_REGION_3
        else:
            tq = 0.0
            regime = REGIME_REGION_1
        if pi_mode:  # keep the torque PI bumpless for the way back
            i_t = (tq - kp_t * (w_f - w_tq_ref)) / ki_t
    else:
        if w_f <= w_ci:
            tq = 0.0
            regime = REGIME_REGION_1
        elif w_f < w_2:
            tq = slope15 * (w_f - w_ci)
            regime = REGIME_REGION_1_5
        elif w_f < w_tr:
            tq = K * w_f * w_f
            regime = REGIME_REGION_2
        else:
            tq = slope25 * (w_f - w_sy)
            regime = REGIME_REGION_2_5
        if pi_mode:
            if tq > tq_rated:  # the region-2 law never exceeds the rated torque here
                tq = tq_rated
                regime = REGIME_REGION_2_5
            e_t = w_f - w_tq_ref
            if state.first_call:
                i_t = tq_prev / ki_t
            i_t += e_t * dt_s
            u = kp_t * e_t + ki_t * i_t
            if u <= tq:  # floor: region 1 / 1.5 / 2 law
                i_t = (tq - kp_t * e_t) / ki_t
            elif u >= tq_rated:
                tq = tq_rated
                regime = REGIME_REGION_2_5
                i_t = (tq_rated - kp_t * e_t) / ki_t
            else:
                tq = u
                regime = REGIME_REGION_2_5
    tq = min(tq, tq_max)
    d_tq = tq - tq_prev
    lim = tq_rate * dt_s
    if d_tq > lim:
        tq = tq_prev + lim
    elif d_tq < -lim:
        tq = tq_prev - lim

    # --- blade pitch --------------------------------------------------------------------
    err = w_f - w_pc
    integ = th_prev / ki_eff if state.first_call else state.pitch_speed_error_integral_rad
    integ += err * dt_s
    lo = th_lo / ki_eff
    hi = th_max / ki_eff
    if integ < lo:
        integ = lo
    elif integ > hi:
        integ = hi
    i_term = ki_eff * integ
    th = kp_eff * err + i_term
    if th < th_lo:
        th = th_lo
    elif th > th_max:
        th = th_max
    if tsr:  # platform-pitch-rate feedback (ROSCO Fl_Mode = 2), outside the PI
        if measurement.valid_mask & VALID_PLATFORM_PITCH_RATE:
            q = measurement.platform_pitch_rate_measured_rad_s
        else:  # held (0 before any valid sample)
            q = 0.0 if state.first_call else state.platform_pitch_rate_rad_s
        valid = bool(measurement.valid_mask & VALID_PLATFORM_PITCH_RATE)
        n_q = (0.0 if state.first_call else state.fl_samples) + (1.0 if valid else 0.0)
        g_h = 1.0 - math.exp(-dt_s * w_hp)
        if n_q >= 1.0 and 1.0 / n_q > g_h:  # the running mean of the first samples
            g_h = 1.0 / n_q
        hp_lp = q if state.first_call else g_h * q + (1.0 - g_h) * state.fl_hpf_lp
        u_f = q - hp_lp
        q_f, f1, f2 = lowpass2_step(
            u_f, w_fl, zeta_fl, dt_s, state.fl_lpf_z1, state.fl_lpf_z2, state.first_call
        )
        th = th + k_fl * q_f
        if th < th_lo:
            th = th_lo
        elif th > th_max:
            th = th_max
    dth = th - th_prev
    lim = th_rate * dt_s
    if dth > lim:
        th = th_prev + lim
    elif dth < -lim:
        th = th_prev - lim

    if tsr:
        return (
            OracleState(
                False,
                z1,
                z2,
                w_f,
                integ,
                i_t,
                th,
                tq,
                v_f,
                ss,
                th_lo,
                x_e,
                p_e,
                hp_lp,
                f1,
                f2,
                q,
                faults,
                t_bad,
                t_good,
                fallback,
                v_hold,
                fl_samples=min(n_q, 1e9),
            ),
            ControlOutput(
                th, tq, regime, w_f, i_term, gk, EST_WIND_SPEED, int(fallback), v,
                estimator_faults=faults,
            ),
        )  # fmt: skip
    return (
        OracleState(False, z1, z2, w_f, integ, i_t, th, tq),
        ControlOutput(th, tq, regime, w_f, i_term, gk),
    )
