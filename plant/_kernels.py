"""Compiled kernels of the plant's hot path (numba, cached on disk).

Why hand-written: the plant runs a few thousand small floating-point operations per control
cycle (a 45-state floating turbine, 200 wave components, a 2-D table look-up) and every
Python-level operation costs ~50 ns, every numpy call on a tiny array ~1 µs. No library
integrates this specific model, so the published equations of :mod:`plant.platform`,
:mod:`plant.turbine`, :mod:`plant.aero` and :mod:`plant.waves` are compiled here with
``numba.njit(cache=True)`` (no fastmath: IEEE results, the same operation order as the
Python expressions they replace where the order is written out). The public pure functions
(:func:`plant.platform.f`, :func:`plant.platform.step_floating`,
:meth:`plant.simulator.PlantSimulator.advance` ...) keep their signatures and call these.

Kernels
-------
* :func:`coefficients_clamped`: bilinear Cp/Ct/Cq of
  :meth:`plant.aero.PerformanceTable.coefficients`, C = c0 + a c_a + b (c_b + a c_ab),
  a = (λ − λ_i)/(λ_{i+1} − λ_i), inputs clamped to the grid.
* :func:`floating_f`: dx/dt of :func:`plant.platform.f` (equations in its docstring):
  (M_s + A_∞) q̈ = F_0 − K q + F_m(q) − D q̇ − B_q (v∘|v|) − C_r ξ + Q_T T + F_t + F^w,
  dξ/dt = A_r ξ + B_r v, rotor and actuators of :func:`plant.turbine.f`.
* :func:`floating_step`: one step of :func:`plant.platform.step_floating` (RK4 of the
  mechanical states with M⁻¹ folded into the constants, radiation exact for a first-order
  hold of the velocity: ξ1 = Φ ξ0 + Γ0 v0 + Γ1 (v1 − v0)).
* :func:`phasor_advance` / :func:`phasor_values`: the wave stepper of
  :class:`plant.waves.PhasorStepper`, p_i ← p_i e^{iω_i Δt} (exact p_i = z_i e^{iω_i t} every
  ``resync`` steps) and y_o = Re Σ_i C_oi p_i.
* :func:`advance_floating`: one control period of the floating plant (waves at h/2, the
  demand switching after ``switch`` steps, :func:`floating_step` per plant step).
* :func:`floating_truth`: the algebraic outputs of :meth:`plant.simulator.PlantSimulator.truth`
  (relative wind, rotor loads, tower-base moment, nacelle acceleration).
* :func:`turbine_advance`: RK4 of :func:`plant.turbine.f` (bottom-fixed plant) over a period.

Constant layouts (built by :mod:`plant.platform` and :mod:`plant.simulator`) are described at
the offsets below.
"""

from __future__ import annotations

import math

import numba
import numpy as np

WIND_MIN_M_S = 1.0e-3  # = plant.turbine.WIND_MIN_M_S (kept equal by tests/test_plant_kernels.py)

# ---------------------------------------------------------------- floating_f constants (FP)
# f0 4 | K 16 | D 16 | Bq 9 | jh 4 | jv 4 | rot 5 (τ, 1/cos τ, κ, arm_φ, arm_s) | c_t 4 |
# D_t 16 | M⁻¹ 16 | turbine 13 (R, k_thrust, k_torque, N, 1/J, θ_min, θ_max, 1/τ_θ, θ'_max,
# T_max, 1/τ_T, T'_max, aero on)
F_F0, F_K, F_D, F_BQ, F_JH, F_JV, F_ROT, F_TC, F_TD, F_MI, F_TB = (
    0,
    4,
    20,
    36,
    45,
    49,
    53,
    58,
    62,
    78,
    94,
)
F_SIZE = 107

# ---------------------------------------------------------------- floating_step constants (SP)
# h, τ, 1/cos τ (0 if aero off), κ, R, k_thrust, k_dom, g_dom, θ_min, θ_max, 1/τ_θ, θ'_max,
# T_max, 1/τ_T, T'_max, jh2, jh3, jv2, jv3, aero | W 12 (M⁻¹[:, :3]) | −M⁻¹D 16 | M⁻¹c_t 4 |
# −M⁻¹D_t 16 | −M⁻¹[:, :3]B_q 12 | J 4 (M⁻¹ Q_T's pitch/tower part)
S_W, S_D, S_TC, S_TD, S_E, S_J = 20, 32, 48, 52, 68, 80
S_SIZE = 84
# Mooring segment rows of floating_step: lo, hi, M⁻¹(L_m − K) 16, M⁻¹(F_0 + F_m,c) 4, x_i,
# k_zz', k_zφ', k_φφ' (26).


@numba.njit(cache=True)
def coefficients_clamped(
    tsr: float, pitch: float, xs: np.ndarray, ys: np.ndarray, cells: np.ndarray
) -> tuple[float, float, float]:
    """(Cp, Ct, Cq) bilinear in the cell of (λ, θ), clamped to the grid (PerformanceTable)."""
    nx = xs.size
    ny = ys.size
    if tsr <= xs[0]:
        i = 0
        a = 0.0
    elif tsr >= xs[nx - 1]:
        i = nx - 2
        a = 1.0
    else:
        i = np.searchsorted(xs, tsr, side="right") - 1
        x0 = xs[i]
        a = (tsr - x0) / (xs[i + 1] - x0)
    if pitch <= ys[0]:
        j = 0
        b = 0.0
    elif pitch >= ys[ny - 1]:
        j = ny - 2
        b = 1.0
    else:
        j = np.searchsorted(ys, pitch, side="right") - 1
        y0 = ys[j]
        b = (pitch - y0) / (ys[j + 1] - y0)
    c = cells[i * (ny - 1) + j]
    return (
        c[0] + a * c[1] + b * (c[2] + a * c[3]),
        c[4] + a * c[5] + b * (c[6] + a * c[7]),
        c[8] + a * c[9] + b * (c[10] + a * c[11]),
    )


@numba.njit(cache=True)
def _ct_cq_cell(
    tsr: float, pitch: float, xs: np.ndarray, ys: np.ndarray, cells: np.ndarray
) -> tuple[float, float]:
    """(Ct, Cq) with the cell's reciprocal widths (the step's cached-cell formula), clamped
    look-up of :func:`coefficients_clamped` outside the grid."""
    nx = xs.size - 1
    ny = ys.size - 1
    i = np.searchsorted(xs, tsr, side="right") - 1
    j = np.searchsorted(ys, pitch, side="right") - 1
    if 0 <= i < nx and 0 <= j < ny:
        x0 = xs[i]
        y0 = ys[j]
        ilx = 1.0 / (xs[i + 1] - x0)
        ily = 1.0 / (ys[j + 1] - y0)
        c = cells[i * ny + j]
        fa = (tsr - x0) * ilx
        fb = (pitch - y0) * ily
        return c[4] + fa * c[5] + fb * (c[6] + fa * c[7]), c[8] + fa * c[9] + fb * (
            c[10] + fa * c[11]
        )
    _, ct, cq = coefficients_clamped(tsr, pitch, xs, ys, cells)
    return ct, cq


@numba.njit(cache=True)
def _mooring(
    knots: np.ndarray, segs: np.ndarray, q0: float, q1: float, q2: float
) -> tuple[float, float, float]:
    """:func:`plant.platform.mooring_force` on the table's segments (rows of 14)."""
    n = segs.shape[0]
    i = np.searchsorted(knots, q0, side="right") - 1
    i = 0 if i < 0 else (n - 1 if i > n - 1 else i)
    s = segs[i]
    x0, fx0, dfx, fz0, dfz, my0, dmy = s[0], s[1], s[2], s[3], s[4], s[5], s[6]
    dkzz, kzz, kzp, dkzp, kpp, dkpp = s[9], s[8], s[10], s[11], s[12], s[13]
    d = q0 - x0
    z = q1
    r = q2
    return (
        fx0
        + dfx * d
        + z * dfz
        + r * dmy
        - 0.5 * (dkzz * z * z + 2.0 * dkzp * z * r + dkpp * r * r),
        fz0 + dfz * d - (kzz + dkzz * d) * z - (kzp + dkzp * d) * r,
        my0 + dmy * d - (kzp + dkzp * d) * z - (kpp + dkpp * d) * r,
    )


@numba.njit(cache=True)
def _mech(
    x: np.ndarray,
    u: np.ndarray,
    mu0: float,
    mu1: float,
    mu2: float,
    fp: np.ndarray,
    knots: np.ndarray,
    segs: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
    cells: np.ndarray,
    out: np.ndarray,
) -> None:
    """Derivative of the 11 mechanical + rotor states (``plant.platform.f``) into out[:11]."""
    q0, q1, q2, q3 = x[0], x[1], x[2], x[3]
    v0, v1, v2, v3 = x[4], x[5], x[6], x[7]
    omega, theta, torque = x[8], x[9], x[10]
    tb = F_TB
    radius, k_thrust, k_torque = fp[tb], fp[tb + 1], fp[tb + 2]
    gear, inv_inertia = fp[tb + 3], fp[tb + 4]
    aero = fp[tb + 12] != 0.0
    tilt, ict, kap, arm_p, arm_s = (
        fp[F_ROT],
        fp[F_ROT + 1],
        fp[F_ROT + 2],
        fp[F_ROT + 3],
        fp[F_ROT + 4],
    )
    jh2, jh3 = fp[F_JH + 2], fp[F_JH + 3]
    jv2, jv3 = fp[F_JV + 2], fp[F_JV + 3]
    psi = tilt + q2 + kap * q3
    cpsi = math.cos(psi)
    spsi = math.sin(psi)
    if aero:
        u_rel = (
            (u[2] - (v0 + jh2 * v2 + jh3 * v3)) * cpsi + (v1 + jv2 * v2 + jv3 * v3) * spsi
        ) * ict
    else:
        u_rel = 0.0
    if u_rel > WIND_MIN_M_S:
        tsr = (omega if omega > 0.0 else 0.0) * radius / u_rel
        _, ct, cq = coefficients_clamped(tsr, theta, xs, ys, cells)
        uu = u_rel * u_rel
        thrust = k_thrust * uu * ct
        t_aero = k_torque * uu * cq
    else:
        thrust = 0.0
        t_aero = 0.0
    d_omega = (t_aero - gear * torque) * inv_inertia
    p_lo, p_hi, p_itau, p_rate = fp[tb + 5], fp[tb + 6], fp[tb + 7], fp[tb + 8]
    t_hi, t_itau, t_rate = fp[tb + 9], fp[tb + 10], fp[tb + 11]
    dem = u[0]
    dem = p_lo if dem < p_lo else dem
    dem = p_hi if dem > p_hi else dem
    d_theta = (dem - theta) * p_itau
    d_theta = p_rate if d_theta > p_rate else (-p_rate if d_theta < -p_rate else d_theta)
    dem = u[1]
    dem = 0.0 if dem < 0.0 else dem
    dem = t_hi if dem > t_hi else dem
    d_torque = (dem - torque) * t_itau
    d_torque = t_rate if d_torque > t_rate else (-t_rate if d_torque < -t_rate else d_torque)

    fmx, fmz, fmp = _mooring(knots, segs, q0, q1, q2)
    a0 = v0 * abs(v0)
    a1 = v1 * abs(v1)
    a2 = v2 * abs(v2)
    uw = u[2] if aero else 0.0
    au = abs(uw)
    uw *= au
    ft = np.empty(4)
    kq = np.empty(4)
    dv = np.empty(4)
    bq = np.zeros(4)
    for i in range(4):
        t = F_TD + 4 * i
        ft[i] = fp[F_TC + i] * uw - au * (
            fp[t] * v0 + fp[t + 1] * v1 + fp[t + 2] * v2 + fp[t + 3] * v3
        )
        k = F_K + 4 * i
        kq[i] = fp[k] * q0 + fp[k + 1] * q1 + fp[k + 2] * q2 + fp[k + 3] * q3
        d = F_D + 4 * i
        dv[i] = fp[d] * v0 + fp[d + 1] * v1 + fp[d + 2] * v2 + fp[d + 3] * v3
        if i < 3:
            b = F_BQ + 3 * i
            bq[i] = fp[b] * a0 + fp[b + 1] * a1 + fp[b + 2] * a2
    g0 = fp[F_F0] + fmx + u[3] + thrust * cpsi + ft[0] - mu0 - kq[0] - dv[0] - bq[0]
    g1 = fp[F_F0 + 1] + fmz + u[4] - thrust * spsi + ft[1] - mu1 - kq[1] - dv[1] - bq[1]
    g2 = fp[F_F0 + 2] + fmp + u[5] + arm_p * thrust + ft[2] - mu2 - kq[2] - dv[2] - bq[2]
    g3 = fp[F_F0 + 3] + arm_s * thrust + ft[3] - kq[3] - dv[3]
    g = (g0, g1, g2, g3)
    out[0] = v0
    out[1] = v1
    out[2] = v2
    out[3] = v3
    for i in range(4):
        m = F_MI + 4 * i
        out[4 + i] = fp[m] * g[0] + fp[m + 1] * g[1] + fp[m + 2] * g[2] + fp[m + 3] * g[3]
    out[8] = d_omega
    out[9] = d_theta
    out[10] = d_torque


@numba.njit(cache=True)
def floating_f(
    x: np.ndarray,
    u: np.ndarray,
    fp: np.ndarray,
    knots: np.ndarray,
    segs: np.ndarray,
    rad: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
    cells: np.ndarray,
    out: np.ndarray,
) -> None:
    """dx/dt of :func:`plant.platform.f` into ``out`` (radiation block [[A, B], [C, 0]])."""
    nr = rad.shape[0] - 3
    mu0 = mu1 = mu2 = 0.0
    if nr > 0:
        for r in range(nr + 3):
            acc = 0.0
            for j in range(nr):
                acc += rad[r, j] * x[11 + j]
            acc += rad[r, nr] * x[4] + rad[r, nr + 1] * x[5] + rad[r, nr + 2] * x[6]
            if r < nr:
                out[11 + r] = acc
            elif r == nr:
                mu0 = acc
            elif r == nr + 1:
                mu1 = acc
            else:
                mu2 = acc
    _mech(x, u, mu0, mu1, mu2, fp, knots, segs, xs, ys, cells, out)


@numba.njit(cache=True)
def floating_step(
    x: np.ndarray,
    u: np.ndarray,
    out: np.ndarray,
    z: np.ndarray,
    use_last: bool,
    sp: np.ndarray,
    knots: np.ndarray,
    segs: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
    cells: np.ndarray,
    end: np.ndarray,
    start: np.ndarray,
) -> None:
    """One step of :func:`plant.platform.step_floating` from ``x`` into ``out``.

    ``z`` (n_r + 8) holds (ξ1, a_μ, a_r) of the previous step's end (used when ``use_last``)
    and receives this step's. Stage order, constants and sums as the step's docstring.
    """
    m = 11
    nr = x.size - m
    h = sp[0]
    tilt, ict, kap, radius = sp[1], sp[2], sp[3], sp[4]
    k_thrust, k_dom, g_dom = sp[5], sp[6], sp[7]
    p_lo, p_hi, p_itau, p_rate = sp[8], sp[9], sp[10], sp[11]
    t_hi, t_itau, t_rate = sp[12], sp[13], sp[14]
    jh2, jh3, jv2, jv3 = sp[15], sp[16], sp[17], sp[18]
    aero = sp[19] != 0.0
    h2 = 0.5 * h
    h6 = h / 6.0
    v0, v1, v2 = x[4], x[5], x[6]
    om, th, tg = x[8], x[9], x[10]
    wind = u[2] if aero else 0.0
    dem = u[0]
    pd = p_lo if dem < p_lo else (p_hi if dem > p_hi else dem)
    dem = u[1]
    td = 0.0 if dem < 0.0 else (t_hi if dem > t_hi else dem)
    f0, f1, f2 = u[3], u[4], u[5]
    am = np.zeros(4)
    ar = np.zeros(4)
    if nr:
        if use_last:
            for i in range(4):
                am[i] = z[nr + i]
                ar[i] = z[nr + 4 + i]
        else:
            for r in range(8):
                acc = 0.0
                for j in range(m + nr):
                    acc += start[r, j] * x[j]
                if r < 4:
                    am[r] = acc
                else:
                    ar[r - 4] = acc
    au = wind if wind > 0.0 else -wind
    uw = wind * au
    b = np.empty(4)
    xd = np.empty(16)
    for i in range(4):
        w = S_W + 3 * i
        b[i] = sp[w] * f0 + sp[w + 1] * f1 + sp[w + 2] * f2 + am[i] + sp[S_TC + i] * uw
        for j in range(4):
            xd[4 * i + j] = sp[S_D + 4 * i + j] + au * sp[S_TD + 4 * i + j]
    nseg = segs.shape[0]
    sq = np.empty(4)
    sv = np.empty(4)
    a = np.empty(4)
    kq = np.zeros(4)
    kv = np.zeros(4)
    for i in range(4):
        sq[i] = x[i]
        sv[i] = x[4 + i]
    som, sth, stg = om, th, tg
    kom = kth = ktg = 0.0
    for stage in range(4):
        if stage == 0:
            tau, wgt, nxt = 0.0, 1.0, h2
        elif stage == 1:
            tau, wgt, nxt = h2, 2.0, h2
        elif stage == 2:
            tau, wgt, nxt = h2, 2.0, h
        else:
            tau, wgt, nxt = h, 1.0, 0.0
        psi = tilt + sq[2] + kap * sq[3]
        cps = math.cos(psi)
        sps = math.sin(psi)
        ur = (
            (wind - (sv[0] + jh2 * sv[2] + jh3 * sv[3])) * cps
            + (sv[1] + jv2 * sv[2] + jv3 * sv[3]) * sps
        ) * ict
        if ur > WIND_MIN_M_S:
            tsr = (som if som > 0.0 else 0.0) * radius / ur
            ct, cq = _ct_cq_cell(tsr, sth, xs, ys, cells)
            uu = ur * ur
            thrust = k_thrust * uu * ct
            dom = k_dom * uu * cq - g_dom * stg
        else:
            thrust = 0.0
            dom = -g_dom * stg
        fx = thrust * cps
        fz = thrust * sps
        dth = (pd - sth) * p_itau
        dth = p_rate if dth > p_rate else (-p_rate if dth < -p_rate else dth)
        dtg = (td - stg) * t_itau
        dtg = t_rate if dtg > t_rate else (-t_rate if dtg < -t_rate else dtg)
        k = np.searchsorted(knots, sq[0], side="right") - 1
        seg = segs[0 if k < 0 else (nseg - 1 if k >= nseg else k)]
        mz = seg[23] * sq[1] + seg[24] * sq[2]
        mp = seg[24] * sq[1] + seg[25] * sq[2]
        dxs = sq[0] - seg[22]
        mfx = fx - 0.5 * (sq[1] * mz + sq[2] * mp)
        mfz = fz + dxs * mz
        mfp = -dxs * mp
        qa0 = sv[0] * (sv[0] if sv[0] > 0.0 else -sv[0])
        qa1 = sv[1] * (sv[1] if sv[1] > 0.0 else -sv[1])
        qa2 = sv[2] * (sv[2] if sv[2] > 0.0 else -sv[2])
        for i in range(4):
            w = S_W + 3 * i
            kk = 2 + 4 * i
            e = S_E + 3 * i
            a[i] = (
                seg[18 + i] + b[i] + tau * ar[i] + sp[S_J + i] * thrust
                + sp[w] * mfx - sp[w + 1] * mfz + sp[w + 2] * mfp
                + seg[kk] * sq[0] + seg[kk + 1] * sq[1] + seg[kk + 2] * sq[2] + seg[kk + 3] * sq[3]
                + xd[4 * i] * sv[0] + xd[4 * i + 1] * sv[1] + xd[4 * i + 2] * sv[2]
                + xd[4 * i + 3] * sv[3]
                + sp[e] * qa0 + sp[e + 1] * qa1 + sp[e + 2] * qa2
            )  # fmt: skip
        for i in range(4):
            kq[i] += wgt * sv[i]
            kv[i] += wgt * a[i]
        kom += wgt * dom
        kth += wgt * dth
        ktg += wgt * dtg
        for i in range(4):
            sq[i] = x[i] + nxt * sv[i]
            sv[i] = x[4 + i] + nxt * a[i]
        som = om + nxt * dom
        sth = th + nxt * dth
        stg = tg + nxt * dtg
    for i in range(4):
        out[i] = x[i] + h6 * kq[i]
        out[4 + i] = x[4 + i] + h6 * kv[i]
    out[8] = om + h6 * kom
    out[9] = th + h6 * kth
    out[10] = tg + h6 * ktg
    if nr:
        nc = nr + 6
        for r in range(nr + 8):
            acc = 0.0
            for j in range(nr):
                acc += end[r, j] * x[m + j]
            acc += end[r, nr] * v0 + end[r, nr + 1] * v1 + end[r, nr + 2] * v2
            acc += end[r, nr + 3] * out[4] + end[r, nr + 4] * out[5] + end[r, nc - 1] * out[6]
            z[r] = acc
        for r in range(nr):
            out[m + r] = z[r]


@numba.njit(cache=True)
def phasor_advance(
    p: np.ndarray, r: np.ndarray, z0: np.ndarray, omega: np.ndarray, clock: np.ndarray
) -> None:
    """p ← p e^{iωΔt}; every ``resync`` steps p = z0 e^{iω(t0 + nΔt)} (PhasorStepper.advance).

    ``clock`` = (n, resync, t0, Δt) as float64 (n counts the steps taken).
    """
    n = clock[0] + 1.0
    clock[0] = n
    resync = clock[1]
    if resync > 0.0 and n % resync == 0.0:
        t = clock[2] + n * clock[3]
        for i in range(p.size):
            p[i] = z0[i] * np.exp(1j * (omega[i] * t))
    else:
        for i in range(p.size):
            p[i] = p[i] * r[i]


@numba.njit(cache=True)
def phasor_values(c: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """out_o = Re Σ_i C_oi p_i (PhasorStepper.values)."""
    for o in range(c.shape[0]):
        acc = 0.0
        for i in range(p.size):
            cc = c[o, i]
            pp = p[i]
            acc += cc.real * pp.real - cc.imag * pp.imag
        out[o] = acc


@numba.njit(cache=True)
def advance_floating(
    x: np.ndarray,
    switch: int,
    demand: np.ndarray,
    winds: np.ndarray,
    wave_now: np.ndarray,
    wp: np.ndarray,
    wr: np.ndarray,
    wz0: np.ndarray,
    womega: np.ndarray,
    wc: np.ndarray,
    wclock: np.ndarray,
    z: np.ndarray,
    use_last: bool,
    sp: np.ndarray,
    knots: np.ndarray,
    segs: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
    cells: np.ndarray,
    end: np.ndarray,
    start: np.ndarray,
) -> None:
    """One control period in place: ``winds.size`` steps of :func:`floating_step`.

    ``demand`` = (previous pitch, previous torque, new pitch, new torque), the previous one
    held for the first ``switch`` steps; ``winds`` the wind at each step's middle; the wave
    stepper (p, r, z0, ω, C, clock; empty p: still water, ``wave_now`` held) is advanced
    twice per step (Δt = h/2), the mid-step values going into the step's input.
    """
    n = winds.size
    out = np.empty_like(x)
    u = np.empty(6)
    wm = np.empty(wave_now.size)
    w1 = np.empty(wave_now.size)
    waves = wp.size > 0
    for i in range(n):
        if i < switch:
            u[0] = demand[0]
            u[1] = demand[1]
        else:
            u[0] = demand[2]
            u[1] = demand[3]
        if waves:
            phasor_advance(wp, wr, wz0, womega, wclock)
            phasor_values(wc, wp, wm)
            phasor_advance(wp, wr, wz0, womega, wclock)
            phasor_values(wc, wp, w1)
        else:
            wm[:] = wave_now
            w1[:] = wave_now
        u[2] = winds[i]
        u[3] = wm[0]
        u[4] = wm[1]
        u[5] = wm[2]
        floating_step(x, u, out, z, use_last, sp, knots, segs, xs, ys, cells, end, start)
        x[:] = out
        use_last = True
        wave_now[:] = w1


@numba.njit(cache=True)
def floating_truth(
    x: np.ndarray,
    applied_pitch: float,
    applied_torque: float,
    wind: float,
    wave: np.ndarray,
    fp: np.ndarray,
    knots: np.ndarray,
    segs: np.ndarray,
    rad: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
    cells: np.ndarray,
    loads: np.ndarray,
    eff: float,
    out: np.ndarray,
) -> None:
    """Outputs of :meth:`plant.simulator.PlantSimulator.truth` for the floating plant.

    out = (U_rel, T_a, T, P_e, ω_g, λ, Cp, Ct, M_tb, a_nacelle): U_rel of
    :func:`plant.platform.relative_wind`, rotor loads of :func:`plant.turbine.outputs`,
    M_tb of :meth:`plant.simulator.TowerBaseLoads.moment_nm` with the accelerations of
    :func:`floating_f`; ``loads`` = (hub arm, overhang moment, c_φ, c_s, c_φφ, c_ss, nacelle
    height, g).
    """
    u = np.empty(6)
    u[0] = applied_pitch
    u[1] = applied_torque
    u[2] = wind
    u[3] = wave[0]
    u[4] = wave[1]
    u[5] = wave[2]
    dx = np.empty(x.size)
    floating_f(x, u, fp, knots, segs, rad, xs, ys, cells, dx)
    tilt, ict, kap = fp[F_ROT], fp[F_ROT + 1], fp[F_ROT + 2]
    jh2, jh3 = fp[F_JH + 2], fp[F_JH + 3]
    jv2, jv3 = fp[F_JV + 2], fp[F_JV + 3]
    psi = tilt + x[2] + kap * x[3]
    vx = x[4] + jh2 * x[6] + jh3 * x[7]
    vz = x[5] + jv2 * x[6] + jv3 * x[7]
    u_rel = ((wind - vx) * math.cos(psi) + vz * math.sin(psi)) * ict
    omega, theta, torque = x[8], x[9], x[10]
    tb = F_TB
    radius, k_thrust, k_torque, gear = fp[tb], fp[tb + 1], fp[tb + 2], fp[tb + 3]
    if u_rel > WIND_MIN_M_S:
        tsr = (omega if omega > 0.0 else 0.0) * radius / u_rel
        cp, ct, cq = coefficients_clamped(tsr, theta, xs, ys, cells)
        u2 = u_rel * u_rel
        t_aero = k_torque * u2 * cq
        thrust = k_thrust * u2 * ct
    else:
        tsr = cp = ct = t_aero = thrust = 0.0
    g = loads[7]
    tbm = (
        thrust * loads[0]
        + g * (loads[1] + x[2] * loads[2] + x[3] * loads[3])
        - dx[4] * loads[2]
        - dx[6] * loads[4]
        - dx[7] * loads[5]
    )
    out[0] = u_rel
    out[1] = t_aero
    out[2] = thrust
    out[3] = eff * torque * omega * gear
    out[4] = omega * gear
    out[5] = tsr
    out[6] = cp
    out[7] = ct
    out[8] = tbm
    out[9] = dx[4] + loads[6] * dx[6] + dx[7]


@numba.njit(cache=True)
def _turbine_f(
    om: float, th: float, tg: float, pc: float, tc: float, wind: float, tp: np.ndarray,
    xs: np.ndarray, ys: np.ndarray, cells: np.ndarray,
) -> tuple[float, float, float]:  # fmt: skip
    """dx/dt of :func:`plant.turbine.f`; tp = (R, k_torque, N, 1/J, θ_min, θ_max, 1/τ_θ,
    θ'_max, T_max, 1/τ_T, T'_max)."""
    if wind > WIND_MIN_M_S:
        tsr = (om if om > 0.0 else 0.0) * tp[0] / wind
        _, _, cq = coefficients_clamped(tsr, th, xs, ys, cells)
        t_aero = tp[1] * wind * wind * cq
    else:
        t_aero = 0.0
    d_omega = (t_aero - tp[2] * tg) * tp[3]
    dem = pc
    if dem < tp[4]:
        dem = tp[4]
    elif dem > tp[5]:
        dem = tp[5]
    rate = (dem - th) * tp[6]
    d_theta = tp[7] if rate > tp[7] else (-tp[7] if rate < -tp[7] else rate)
    dem = tc
    if dem < 0.0:
        dem = 0.0
    elif dem > tp[8]:
        dem = tp[8]
    rate = (dem - tg) * tp[9]
    d_torque = tp[10] if rate > tp[10] else (-tp[10] if rate < -tp[10] else rate)
    return d_omega, d_theta, d_torque


@numba.njit(cache=True)
def turbine_advance(
    x: np.ndarray,
    h: float,
    switch: int,
    demand: np.ndarray,
    winds: np.ndarray,
    tp: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
    cells: np.ndarray,
) -> None:
    """Classic RK4 of :func:`plant.turbine.f` (as :func:`plant.integrate.rk4_step`), one
    step per entry of ``winds`` (the wind held at mid-step), in place on x = (ω, θ, T_g)."""
    for i in range(winds.size):
        pc = demand[0] if i < switch else demand[2]
        tc = demand[1] if i < switch else demand[3]
        w = winds[i]
        om, th, tg = x[0], x[1], x[2]
        h2 = 0.5 * h
        k1 = _turbine_f(om, th, tg, pc, tc, w, tp, xs, ys, cells)
        k2 = _turbine_f(
            om + h2 * k1[0], th + h2 * k1[1], tg + h2 * k1[2], pc, tc, w, tp, xs, ys, cells
        )
        k3 = _turbine_f(
            om + h2 * k2[0], th + h2 * k2[1], tg + h2 * k2[2], pc, tc, w, tp, xs, ys, cells
        )
        k4 = _turbine_f(
            om + h * k3[0], th + h * k3[1], tg + h * k3[2], pc, tc, w, tp, xs, ys, cells
        )
        h6 = h / 6.0
        x[0] = om + h6 * (k1[0] + 2.0 * (k2[0] + k3[0]) + k4[0])
        x[1] = th + h6 * (k1[1] + 2.0 * (k2[1] + k3[1]) + k4[1])
        x[2] = tg + h6 * (k1[2] + 2.0 * (k2[2] + k3[2]) + k4[2])
