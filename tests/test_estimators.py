"""Tests of the controller's observers (controller.estimators) against the plant's truth.

The truth comes from the plant models (allowed in tests, never in the controller runtime):
``plant.turbine`` (rotor + drivetrain, RK4) run by the baseline controller for the wind EKF,
and ``plant.platform`` / ``plant.modes`` for the platform Kalman filter. Sensor noise follows
``sensors.channel.default_floating_suite`` (generator encoder σ = 0.05 rad/s plus its
quantisation 2π/(4096 h); pitch σ = 2e-4 rad; torque σ = 100 N m; IMU, gyro, attitude and
GNSS with their σ and biases). Every random stream is seeded; tolerances are stated at each
assertion.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from functools import lru_cache

import numpy as np
import numpy.typing as npt
import pytest
from _helpers import sensor_frame
from scipy.linalg import expm, solve_discrete_are

from controller.baseline import BaselineController, load_baseline
from controller.estimators import (
    CpTable,
    PlatformKF,
    PlatformKFConfig,
    PlatformKFState,
    PlatformMeasurement,
    WindEKFConfig,
    WindEKFMeasurement,
    WindSpeedEKF,
    chi2_gate,
    cp_table_from_rosco_text,
    encoder_rotor_speed_std,
)
from plant import turbine as plant_turbine
from plant.aero import PerformanceTable
from plant.integrate import rk4_step
from plant.platform import FloatingParams

FloatArray = npt.NDArray[np.float64]
GRAVITY = 9.81
DT = 0.01  # controller period of the EKF runs (s), 100 Hz
ENCODER_STD = 0.05  # generator-speed encoder noise (rad/s, HSS), default sensor suite
ENCODER_RES = 2.0 * math.pi / (4096 * DT)  # quantisation (rad/s, HSS) at 100 Hz


# ============================================================================ wind EKF
@lru_cache(maxsize=1)
def _nrel() -> plant_turbine.TurbineParams:
    return plant_turbine.load_turbine("nrel5mw")


def _ekf(tp: plant_turbine.TurbineParams) -> WindSpeedEKF:
    """The EKF as the controller knows the turbine: its own copy of the (unscaled) Cp table."""
    table = CpTable(tp.table.pitch_rad, tp.table.tsr, tp.table.cp)
    sigma = encoder_rotor_speed_std(ENCODER_STD, ENCODER_RES, tp.gearbox_ratio)
    return WindSpeedEKF(
        WindEKFConfig(
            table,
            tp.rotor_radius_m,
            tp.drivetrain_inertia_kg_m2,
            tp.gearbox_ratio,
            rotor_speed_noise_std_rad_s=sigma,
        )
    )


def _run_ekf(
    wind: Callable[[float], float], duration_s: float, cp_scale: float = 1.0, seed: int = 0
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Baseline-controlled NREL 5 MW (plant Cp/Cq scaled by ``cp_scale``) with the EKF.

    Returns time (s), true rotor-effective wind (m/s) and the EKF estimate (m/s) per cycle.
    """
    model = _nrel()
    ekf = _ekf(model)  # controller's model: always the unscaled table
    tb = model.table
    plant = dataclasses.replace(
        model,
        table=PerformanceTable(tb.pitch_rad, tb.tsr, tb.cp * cp_scale, tb.ct, tb.cq * cp_scale),
    )
    n_gear = plant.gearbox_ratio
    ctrl = BaselineController(load_baseline("nrel5mw_baseline"))
    rng = np.random.default_rng(seed)
    omega0 = min(plant.rated_rotor_speed_rad_s, tb.optimal_tsr() * wind(0.0) / plant.rotor_radius_m)
    x = (omega0, 0.0, 0.0)
    cstate = ctrl.initial_state()
    estate = None
    n = round(duration_s / DT)
    t_out, u_out, e_out = np.empty(n), np.empty(n), np.empty(n)
    for k in range(n):
        t = k * DT
        u = wind(t)
        gen = ENCODER_RES * round(
            (x[0] * n_gear + ENCODER_STD * rng.standard_normal()) / ENCODER_RES
        )
        pitch = x[1] + 2e-4 * rng.standard_normal()
        torque = x[2] + 100.0 * rng.standard_normal()
        cstate, cmd = ctrl.step(
            cstate, sensor_frame(gen, pitch, torque, seq=k, valid_mask=0xFFFF), DT
        )
        meas = WindEKFMeasurement(gen / n_gear, pitch, torque)
        if estate is None:
            estate = ekf.initial_state(meas.rotor_speed_rad_s, pitch, torque)
        estate, est = ekf.step(estate, meas, DT)
        t_out[k], u_out[k], e_out[k] = t, u, est.wind_m_s
        x = rk4_step(
            plant_turbine.f,
            t,
            x,
            (cmd.blade_pitch_commanded_rad, cmd.generator_torque_commanded_nm, u),
            DT,
            plant,
        )
    return t_out, u_out, e_out


@pytest.mark.parametrize("cp_scale", [1.0, 0.95])
@pytest.mark.parametrize("wind_m_s", [8.0, 14.0, 20.0])
def test_ekf_mean_wind_error_within_2_percent(wind_m_s: float, cp_scale: float) -> None:
    """Steady wind, encoder noise: mean of the estimate over 30..80 s within 2 % of the truth.

    Measured (seed 0): model-matched -0.01 / +0.08 / +0.04 % at 8 / 14 / 20 m/s; plant Cp
    scaled by 0.95: -1.73 / -1.50 / -0.83 % (below rated the bias approaches the
    (0.95)^(1/3) - 1 = -1.7 % of a Cp-based estimator; above rated the steeper dT_a/dv of the
    pitched rotor shrinks it).
    """
    t, _truth, est = _run_ekf(lambda _t: wind_m_s, 80.0, cp_scale)
    window = t >= 30.0
    err = est[window].mean() / wind_m_s - 1.0
    assert abs(err) < 0.02, f"mean error {100 * err:.2f} %"
    if cp_scale == 1.0:
        assert abs(err) < 0.005  # model-matched: only the Cq vs Cp/λ rounding of the table
    assert est[window].std() < 0.02 * wind_m_s  # noise on the estimate, 1 sigma


@pytest.mark.parametrize(("before", "after"), [(8.0, 10.0), (14.0, 16.0), (16.0, 14.0)])
def test_ekf_settles_within_10_s_after_a_2_m_s_step(before: float, after: float) -> None:
    """2 m/s step at t = 20 s, model-matched, encoder noise.

    Settling time: the last instant at which the 1 s trailing mean of the estimate lies
    outside ±2 % of the final wind, minus the step time. (The raw 100 Hz estimate has a noise
    of 0.04-0.12 m/s, 1 sigma, so single samples touch a ±2 % band now and then.) Measured:
    about 0.5-1.5 s.
    """
    t, _, est = _run_ekf(lambda tt: before if tt < 20.0 else after, 50.0)
    smooth = np.convolve(est, np.ones(100) / 100.0)[: est.size]  # causal 1 s mean
    outside = (np.abs(smooth / after - 1.0) > 0.02) & (t >= 20.0)
    settle = float(t[outside][-1] - 20.0) if outside.any() else 0.0
    assert settle < 10.0, f"settling {settle:.2f} s"


def test_ekf_aero_torque_matches_the_plant_and_its_partials_are_exact() -> None:
    """T_a = ½ρπR³v²Cp/λ agrees with the plant's Cq model within 0.5 % at three operating
    points (the table's Cq equals Cp/λ to its 6-digit rounding). On a smooth analytic
    Cp(λ, θ) = 0.48 − 0.012 (λ − 7.5)² − 0.8 θ² tabulated on a fine grid, ∂T_a/∂v and
    ∂T_a/∂ω equal the analytic derivatives within 0.5 %."""
    tp = _nrel()
    ekf = _ekf(tp)
    for omega, v, pitch in ((0.9, 8.0, 0.0), (1.267, 14.0, 0.15), (1.267, 20.0, 0.30)):
        ta = ekf.aero_torque(omega, v, pitch)[0]
        ref = plant_turbine.outputs(0.0, (omega, pitch, 0.0), (pitch, 0.0, v), tp).aero_torque_nm
        assert ta == pytest.approx(ref, rel=5e-3)

    tsr = np.linspace(2.0, 14.0, 241)
    pitch_grid = np.linspace(-0.1, 0.5, 61)
    cp = 0.48 - 0.012 * (tsr[:, None] - 7.5) ** 2 - 0.8 * pitch_grid[None, :] ** 2
    radius, rho = 63.0, 1.225
    smooth = WindSpeedEKF(WindEKFConfig(CpTable(pitch_grid, tsr, cp), radius, 4e7, 97.0))
    k = 0.5 * rho * math.pi * radius**3
    for omega, v, pitch in ((0.9, 8.0, 0.0), (1.2, 14.0, 0.2), (1.2, 20.0, 0.3)):
        lam = omega * radius / v
        c = 0.48 - 0.012 * (lam - 7.5) ** 2 - 0.8 * pitch**2
        dc = -0.024 * (lam - 7.5)
        ta, dw, dv = smooth.aero_torque(omega, v, pitch)
        assert ta == pytest.approx(k * v * v * c / lam, rel=5e-3)
        # T_a = k v² C(λ)/λ: ∂/∂v = k v (3C/λ − C'), ∂/∂ω = k v R (C' − C/λ)/λ
        assert dv == pytest.approx(k * v * (3.0 * c / lam - dc), rel=5e-3)
        assert dw == pytest.approx(k * v * radius * (dc - c / lam) / lam, rel=5e-3)


def test_ekf_steady_inversion_and_covariance_stay_consistent() -> None:
    """steady_wind inverts T_a = N T_g (within 1e-6 m/s); P stays symmetric positive
    definite with a missing update and a non-finite measurement leaves the state unchanged."""
    tp = _nrel()
    ekf = _ekf(tp)
    omega, pitch, v = 1.2, 0.1, 15.0
    tg = ekf.aero_torque(omega, v, pitch)[0] / tp.gearbox_ratio
    assert ekf.steady_wind(omega, pitch, tg) == pytest.approx(v, abs=1e-6)
    s = ekf.initial_state(omega, pitch, tg)
    assert s.x[2] == pytest.approx(v, abs=1e-6)
    for k in range(500):
        s, _ = ekf.step(s, WindEKFMeasurement(omega, pitch, tg, valid=k % 7 != 0), DT)
        P = s.covariance()
        assert np.min(np.linalg.eigvalsh(P)) > 0.0
    assert ekf.update(s, math.nan) is s
    assert s.updates == 500 - len(range(0, 500, 7))


def test_cp_table_parser_reads_the_rosco_file_layout() -> None:
    """The minimal ROSCO reader gives the same grid and Cp matrix as the plant's reader."""
    from importlib import resources

    text = (resources.files("plant.presets") / "nrel5mw_cp_ct_cq.txt").read_text()
    table = cp_table_from_rosco_text(text)
    ref = _nrel().table
    np.testing.assert_allclose(table.pitch_rad, ref.pitch_rad, rtol=1e-12)
    np.testing.assert_array_equal(table.tsr, ref.tsr)
    np.testing.assert_array_equal(table.cp, ref.cp)
    with pytest.raises(ValueError, match="blocks"):
        cp_table_from_rosco_text("# only a header\n1 2 3\n")


# ============================================================================ platform KF
IDX = [0, 2, 3, 4, 6, 7]  # KF states: surge, pitch, tower-top and their rates (no heave)
NAMES = (
    "surge_m",
    "pitch_rad",
    "tower_top_m",
    "surge_rate_m_s",
    "pitch_rate_rad_s",
    "tower_top_rate_m_s",
)
# Sensor noise of the default floating suite: σ and bias per channel.
ACC_STD, ACC_BIAS = 0.01, 0.02  # nacelle IMU fore-aft (m/s²)
GYRO_STD, GYRO_BIAS = 6e-4, 1e-3  # pitch rate (rad/s)
ATT_STD, ATT_BIAS = math.radians(0.05), math.radians(0.1)  # pitch (rad)
GNSS_STD = 0.02  # surge (m), 10 Hz


@dataclasses.dataclass(frozen=True)
class _Design:
    """Continuous and discrete KF design model at one operating point (test-side design)."""

    op_state: tuple[float, ...]
    op_inputs: tuple[float, ...]
    A: FloatArray  # continuous, KF states
    Bu: FloatArray  # continuous, inputs (Δω rad/s, Δθ rad)
    Gw: FloatArray  # continuous, wave forces (surge N, pitch N m)
    config: PlatformKFConfig


def _input_jacobian(
    params: FloatingParams,
    op_state: tuple[float, ...],
    op_inputs: tuple[float, ...],
    cols: list[int],
    steps: list[float],
) -> FloatArray:
    from plant.platform import f

    out = []
    for c, h in zip(cols, steps, strict=True):
        up, um = list(op_inputs), list(op_inputs)
        up[c] += h
        um[c] -= h
        fp: FloatArray = np.array(f(0.0, op_state, tuple(up), params))
        fm: FloatArray = np.array(f(0.0, op_state, tuple(um), params))
        out.append((fp - fm) / (2.0 * h))
    return np.array(out).T


@lru_cache(maxsize=2)
def _design(dt: float, wave_scale: float = 1.0) -> _Design:
    """Offline design as the controller's design step would do it, from the plant's model.

    Linearise the radiation-free IEA 15 MW / VolturnUS-S model at 14 m/s
    (``plant.modes.linearize``), keep surge, pitch, tower-top and their rates (heave is
    nearly decoupled and unobservable here), inputs = measured rotor-speed and blade-pitch
    deviations (their A columns), wave forces as white process noise of intensity
    q = π|X(ω_p)|² S_η(ω_p) (JONSWAP Hs 3 m, Tp 9.5 s) times ``wave_scale``; ZOH
    discretisation by the block matrix exponential, Q by Van Loan's method; the accelerometer
    row is h_hub·q̈ + g φ (tilted accelerometer) with its feedthrough; P0 from the DARE.
    """
    from plant.hydro.wamit import load_hydro_preset
    from plant.modes import linearize, operating_point
    from plant.platform import load_floating
    from plant.waves import JonswapSpectrum, spectral_density

    params = load_floating("iea15mw_volturnus", radiation=False)
    op = operating_point(params, 14.0)
    a_full = linearize(params, op)
    vel = [i + 4 for i in (0, 2, 3)]
    A = a_full[np.ix_(IDX, IDX)]
    Bu = a_full[np.ix_(IDX, [8, 9])]
    Gw = _input_jacobian(params, op.state, op.inputs, [3, 5], [1e5, 1e7])[IDX]
    exc = load_hydro_preset("iea15mw_volturnus").excitation.select((0, 4), 0.0)
    wp = 2.0 * math.pi / 9.5
    mag = np.array([np.interp(wp, exc.omega_rad_s, np.abs(exc.force[:, 0, j])) for j in range(2)])
    s_eta = float(spectral_density(JonswapSpectrum(3.0, 9.5), np.array([wp]))[0])
    Qc = wave_scale * Gw @ np.diag(math.pi * mag**2 * s_eta) @ Gw.T
    Qc += np.diag([0.0, 0.0, 0.0, 1e-4, 1e-7, 1e-3])  # model error on the rates
    jh = params.hub_lever[[0, 2, 3]]
    n, m = A.shape[0], Bu.shape[1]
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, Bu
    E = expm(M * dt)
    F, B = E[:n, :n], E[:n, n:]
    V = np.zeros((2 * n, 2 * n))
    V[:n, :n], V[:n, n:], V[n:, n:] = -A, Qc, A.T
    EV = expm(V * dt)
    Q = EV[n:, n:].T @ EV[:n, n:]
    Q = 0.5 * (Q + Q.T)
    H = np.zeros((4, n))
    D = np.zeros((4, m))
    H[0] = jh @ A[3:6]
    H[0, 1] += GRAVITY
    D[0] = jh @ Bu[3:6]
    H[1, 4] = H[2, 1] = H[3, 0] = 1.0
    # The wave force also accelerates the nacelle directly (F^w is not a KF state): its part
    # of the accelerometer, g_a F^w with g_a = h_hub·(rows of G_w), has the covariance
    # g_a C_F g_aᵀ, C_F = ∫ Re(X Xᴴ) S_η dω, added to the accelerometer's R.
    w = exc.omega_rad_s
    X = exc.force[:, 0, :]
    s_w = spectral_density(JonswapSpectrum(3.0, 9.5), w)
    C_F = np.trapezoid((X[:, :, None] * X[:, None, :].conj()).real * s_w[:, None, None], w, axis=0)
    g_a = jh @ Gw[3:6]
    R = np.diag(
        [
            ACC_STD**2 + ACC_BIAS**2 + wave_scale * float(g_a @ C_F @ g_a),
            GYRO_STD**2 + GYRO_BIAS**2,
            ATT_STD**2 + ATT_BIAS**2,
            GNSS_STD**2,
        ]
    )
    P0 = solve_discrete_are(F.T, H.T, Q, R)
    assert vel == [4, 6, 7]
    config = PlatformKFConfig(
        F=F,
        B=B,
        H=H,
        D=D,
        Q=Q,
        R=R,
        dt_s=dt,
        P0=0.5 * (P0 + P0.T),
        state_names=NAMES,
        input_names=("rotor_speed_dev_rad_s", "blade_pitch_dev_rad"),
        measurement_names=("nacelle_acc_m_s2", "pitch_rate_rad_s", "pitch_rad", "surge_m"),
        gate_probability=0.999,
        max_consecutive_misses=5,
    )
    return _Design(op.state, op.inputs, A, Bu, Gw, config)


def _assert_pd(P: FloatArray) -> None:
    assert np.array_equal(P, P.T)
    assert np.min(np.linalg.eigvalsh(P)) > 0.0


def test_kf_linear_600_s_with_dropout_beats_the_raw_sensors() -> None:
    """600 s at 20 Hz of the same discrete model plus process noise (seeded), white sensor
    noise at the variances of R, each channel dropped with probability 5 %, surge (GNSS) only
    every 2nd cycle (10 Hz).

    Checks: P symmetric positive definite at every step; RMS error of the pitch-rate
    estimate below the gyro noise and of the surge-velocity estimate below the differentiated
    10 Hz surge; mean NEES within 15 % of the state dimension (the filter is consistent).
    """
    dt = 0.05
    design = _design(dt, 0.05)
    kf = PlatformKF(design.config)
    c = design.config
    rng = np.random.default_rng(1)
    n_steps = round(600.0 / dt)
    Lq = np.linalg.cholesky(c.Q + 1e-30 * np.eye(6))
    r_std = np.sqrt(np.diag(c.R))
    x = rng.multivariate_normal(np.zeros(6), c.P0)
    state = kf.initial_state()
    err_rate, err_vel, raw_rate, raw_vel, nees = [], [], [], [], []
    last_surge: tuple[float, float] | None = None
    for k in range(n_steps):
        t = k * dt
        u = np.array([0.01 * math.sin(0.3 * t), 0.005 * math.sin(0.11 * t)])
        x = c.F @ x + c.B @ u + Lq @ rng.standard_normal(6)
        z = c.H @ x + c.D @ u + r_std * rng.standard_normal(4)
        valid = rng.random(4) >= 0.05
        valid[3] &= k % 2 == 0
        state, est = kf.step(state, PlatformMeasurement(u, z, valid), dt)
        _assert_pd(state.P)
        if t < 60.0:
            continue
        e = est.x - x
        err_rate.append(e[4])
        err_vel.append(e[3])
        raw_rate.append(z[1] - x[4])
        nees.append(float(e @ np.linalg.solve(state.P, e)))
        if valid[3]:
            if last_surge is not None:
                raw_vel.append((z[3] - last_surge[1]) / (t - last_surge[0]) - x[3])
            last_surge = (t, float(z[3]))
    rms = {
        name: float(np.sqrt(np.mean(np.square(v))))
        for name, v in (
            ("rate", err_rate),
            ("vel", err_vel),
            ("raw_rate", raw_rate),
            ("raw_vel", raw_vel),
        )
    }
    # measured (seed 1): pitch rate 0.52 x the gyro error, surge velocity 0.17 x the
    # differentiated-GNSS error
    assert rms["rate"] < 0.75 * rms["raw_rate"], rms
    assert rms["vel"] < 0.5 * rms["raw_vel"], rms
    assert abs(np.mean(nees) / 6.0 - 1.0) < 0.15, np.mean(nees)
    assert sum(state.skipped) > 0.04 * n_steps  # the dropouts really happened


def test_kf_matches_filterpy_without_gating() -> None:
    """With the gate off and all channels valid, predict/update equal filterpy's functional
    ``predict``/``update`` (Joseph form) within 1e-9 relative over 50 cycles."""
    kalman = pytest.importorskip("filterpy.kalman")
    design = _design(0.025, 0.05)
    cfg = dataclasses.replace(design.config, gate_probability=1.0)
    kf = PlatformKF(cfg)
    rng = np.random.default_rng(2)
    state = kf.initial_state()
    x_ref, P_ref = cfg.x0.copy(), cfg.P0.copy()
    for _ in range(50):
        u = rng.standard_normal(2) * 0.01
        z = rng.standard_normal(4) * np.sqrt(np.diag(cfg.R))
        state, _ = kf.step(state, PlatformMeasurement(u, z), cfg.dt_s)
        x_ref, P_ref = kalman.predict(x_ref, P_ref, cfg.F, cfg.Q, u, cfg.B)
        x_ref, P_ref = kalman.update(x_ref, P_ref, z - cfg.D @ u, cfg.R, cfg.H)
    np.testing.assert_allclose(state.x, x_ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(state.P, P_ref, rtol=1e-9, atol=1e-15)


def _steady_kf(design: _Design) -> tuple[PlatformKF, PlatformKFState]:
    kf = PlatformKF(design.config)
    state = kf.initial_state()
    zero_u = np.zeros(2)
    for _ in range(200):  # converge at rest
        state = kf.predict(state, zero_u, design.config.dt_s)
        state = kf.update(state, np.zeros(4), None, zero_u)
    return kf, state


def test_kf_gates_an_outlier_and_counts_it() -> None:
    """A +5 m surge spike is rejected (NIS far above χ²₁(0.999) = 10.83) and counted; the
    surge estimate moves by less than 1 cm."""
    design = _design(0.025, 0.05)
    kf, state = _steady_kf(design)
    assert chi2_gate(0.999) == pytest.approx(10.828, abs=1e-3)
    before = float(state.x[0])
    state = kf.predict(state, np.zeros(2), 0.025)
    state = kf.update(state, np.array([0.0, 0.0, 0.0, 5.0]), None, np.zeros(2))
    assert state.rejected == (0, 0, 0, 1)
    assert state.nis[3] > 1e3
    assert abs(float(state.x[0]) - before) < 0.01
    assert not state.degraded


def test_kf_degraded_after_k_misses_and_clears_after_good_updates() -> None:
    """K = 5: five consecutive pitch-channel misses are tolerated, the sixth raises
    ``degraded``; one accepted pitch update clears it. Skipped and rejected both count."""
    design = _design(0.025, 0.05)
    kf, state = _steady_kf(design)
    zero_u = np.zeros(2)
    z0 = np.zeros(4)
    for k in range(6):
        state = kf.predict(state, zero_u, 0.025)
        if k % 2:
            state = kf.update(state, z0, [True, True, False, True], zero_u)  # missing
        else:
            state = kf.update(state, np.array([0, 0, 0.5, 0]), None, zero_u)  # outlier
        assert state.degraded == (k == 5), k
    assert state.consecutive_misses[2] == 6
    assert state.skipped[2] == 3 and state.rejected[2] == 3
    state = kf.predict(state, zero_u, 0.025)
    state = kf.update(state, z0, None, zero_u)
    assert not state.degraded
    assert state.consecutive_misses == (0, 0, 0, 0)


def test_kf_against_the_nonlinear_plant_with_waves() -> None:
    """60 s of the nonlinear IEA 15 MW / VolturnUS-S model WITH radiation memory, quadratic
    drag and nonlinear mooring (the KF model has none of these), JONSWAP Hs 3 m, Tp 9.5 s
    wave excitation, steady 14 m/s wind, actuator demands held at the operating point.
    Sensors with noise AND bias (gyro 1e-3 rad/s, attitude 0.1°, IMU 0.02 m/s²), GNSS surge
    at 10 Hz, 5 % dropout, 40 Hz filter.

    The RMS error of the pitch-rate and surge-velocity estimates (after 10 s) is below the
    raw gyro error and the differentiated-GNSS error; P stays positive definite.
    """
    from plant.hydro.wamit import load_hydro_preset
    from plant.platform import f, load_floating
    from plant.waves import JonswapSpectrum, excitation_force, synthesize

    dt = 0.025
    design = _design(dt)
    kf = PlatformKF(design.config)
    params = load_floating("iea15mw_volturnus", radiation=True)
    nr = params.n_radiation
    exc = load_hydro_preset("iea15mw_volturnus").excitation.select((0, 2, 4), 0.0)
    field = synthesize(JonswapSpectrum(3.0, 9.5), depth_m=200.0, seed=3)
    n_steps = round(60.0 / dt)
    force = excitation_force(field, exc.omega_rad_s, exc.force[:, 0, :]).series(0.0, dt, n_steps)
    x = tuple(design.op_state[:11]) + (0.0,) * nr
    x0 = np.array(design.op_state)[IDX]
    omega0, theta0 = design.op_state[8], design.op_state[9]
    jh = params.hub_lever
    rng = np.random.default_rng(4)
    state = kf.initial_state()
    errs: dict[str, list[float]] = {"rate": [], "vel": [], "raw_rate": [], "raw_vel": []}
    last_surge: tuple[float, float] | None = None
    for k in range(n_steps):
        t = k * dt
        u_plant = (*design.op_inputs[:3], *force[k])
        dx = f(t, x, u_plant, params)
        acc = float(jh @ np.array(dx[4:8])) + GRAVITY * (x[2] - x0[1])  # deviation
        truth = np.array(x)[IDX] - x0
        z = np.array(
            [
                acc + ACC_BIAS + ACC_STD * rng.standard_normal(),
                x[6] + GYRO_BIAS + GYRO_STD * rng.standard_normal(),
                x[2] - x0[1] + ATT_BIAS + ATT_STD * rng.standard_normal(),
                x[0] - x0[0] + GNSS_STD * rng.standard_normal(),
            ]
        )
        valid = rng.random(4) >= 0.05
        valid[3] &= k % 4 == 0
        u = np.array([x[8] - omega0 + 1e-4 * rng.standard_normal(), x[9] - theta0])
        state, est = kf.step(state, PlatformMeasurement(u, z, valid), dt)
        _assert_pd(state.P)
        if t >= 10.0:
            errs["rate"].append(est.x[4] - truth[4])
            errs["vel"].append(est.x[3] - truth[3])
            errs["raw_rate"].append(z[1] - truth[4])
            if valid[3] and last_surge is not None:
                errs["raw_vel"].append((z[3] - last_surge[1]) / (t - last_surge[0]) - truth[3])
        if valid[3]:
            last_surge = (t, float(z[3]))
        x = rk4_step(f, t, x, u_plant, dt, params)
    rms = {name: float(np.sqrt(np.mean(np.square(v)))) for name, v in errs.items()}
    assert rms["rate"] < rms["raw_rate"], rms
    assert rms["vel"] < rms["raw_vel"], rms
    assert not state.degraded


def test_config_validation_names_the_problem() -> None:
    """Singular R, wrong shapes and degrees instead of radians are refused."""
    cfg = _design(0.025, 0.05).config
    with pytest.raises(ValueError, match="positive definite"):
        dataclasses.replace(cfg, R=np.ones((4, 4)))
    with pytest.raises(ValueError, match="shape"):
        dataclasses.replace(cfg, H=np.ones((4, 5)))
    with pytest.raises(ValueError, match="radians"):
        CpTable(np.array([0.0, 90.0]), np.array([1.0, 2.0]), np.ones((2, 2)))
    with pytest.raises(ValueError, match="probability"):
        chi2_gate(0.0)


def test_kf_subset_updates_match_the_textbook_joint_update() -> None:
    """For every subset a of the 4 channels (the others invalid), the update with the
    precomputed subset matrices equals the textbook joint update
    :math:`K = P H_a^T (H_a P H_a^T + R_a)^{-1}`, :math:`\\hat x + K y_a`, Joseph form
    (rtol 1e-9); a NaN in a channel counts as invalid."""
    design = _design(0.025, 0.05)
    kf, state = _steady_kf(design)
    cfg = design.config
    rng = np.random.default_rng(7)
    u = np.array([0.01, -0.002])
    prior = kf.predict(state, u, cfg.dt_s)
    for key in range(16):
        use = [i for i in range(4) if key >> i & 1]
        z = 0.3 * rng.standard_normal(4) * np.sqrt(np.diag(cfg.R))
        valid = [bool(key >> i & 1) for i in range(4)]
        z_nan = np.where(valid, z, np.nan)
        got = kf.update(prior, z_nan, None, u)
        x, P = prior.x, prior.P
        if use:
            H, R = cfg.H[use], cfg.R[np.ix_(use, use)]
            y = (z - cfg.H @ x - cfg.D @ u)[use]
            K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
            A = np.eye(x.size) - K @ H
            x, P = x + K @ y, A @ P @ A.T + K @ R @ K.T
        np.testing.assert_allclose(got.x, x, rtol=1e-9, atol=1e-14)
        np.testing.assert_allclose(got.P, 0.5 * (P + P.T), rtol=1e-9, atol=1e-18)
        assert [a - b for a, b in zip(got.accepted, prior.accepted, strict=True)] == valid
        assert [a - b for a, b in zip(got.skipped, prior.skipped, strict=True)] == [
            not v for v in valid
        ]
