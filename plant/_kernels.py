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
  (relative wind, rotor loads, tower-base moment, nacelle acceleration);
  :func:`floating_truth_into` writes them with the state as the truth message's record and
  the sensor channels' true values (one call per cycle for both).
* :func:`turbine_advance`: RK4 of :func:`plant.turbine.f` (bottom-fixed plant) over a period.

Constant layouts (built by :mod:`plant.platform` and :mod:`plant.simulator`) are described at
the offsets below.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from bus_schemas.jit import njit

WIND_MIN_M_S = 1.0e-3  # = plant.turbine.WIND_MIN_M_S (kept equal by tests/test_plant_kernels.py)


class PlantBundle(NamedTuple):
    """The floating plant's arrays as the compiled loop takes them (one argument).

    Owned by :class:`plant.simulator.PlantSimulator` (:meth:`~plant.simulator.PlantSimulator.
    state_bundle`): these are its storage, not copies; a kernel that advances ``x`` in
    place hands the periods back with :meth:`~plant.simulator.PlantSimulator.adopt_periods`.

    Attributes
    ----------
    x : ndarray
        The plant state of :func:`plant.platform.f` (float64, advanced in place).
    s : ndarray
        The kernels' running state (layout ``S_*``: demands, step winds, wave clock and
        values, radiation accelerations).
    wc : ndarray
        The wave stepper's arrays (rows ``W_*``).
    c, o : ndarray
        The packed constants and their block offsets (:func:`pack`).
    wind_table : ndarray
        The sampled wind record (m/s).
    truth_rec : ndarray
        The truth message's record, then the sensor channels' true values
        (:func:`floating_truth_into`).
    channel_fields : ndarray
        Per sensor channel, its field's index in ``TRUTH_FIELDS`` (int64).
    """

    x: np.ndarray
    s: np.ndarray
    wc: np.ndarray
    c: np.ndarray
    o: np.ndarray
    wind_table: np.ndarray
    truth_rec: np.ndarray
    channel_fields: np.ndarray


def pack(blocks: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(C, off): the blocks flattened into one float64 array and their offsets."""
    flat = [np.ascontiguousarray(b, dtype=np.float64).ravel() for b in blocks]
    offsets = np.zeros(len(flat) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([f.size for f in flat])
    return np.concatenate(flat) if flat else np.zeros(0), offsets


@njit
def _b1(C: np.ndarray, off: np.ndarray, b: int) -> np.ndarray:
    return C[off[b] : off[b + 1]]


@njit
def _b2(C: np.ndarray, off: np.ndarray, b: int, cols: int) -> np.ndarray:
    blk = C[off[b] : off[b + 1]]
    return blk.reshape((blk.size // cols, cols))


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

# ---------------------------------------------------------------- packed constants (C, off)
# All constants of one floating plant in one flat float64 array C, block b at C[off[b]:off[b+1]]
# (one array argument instead of a dozen: a numba call costs ~0.13 µs per array argument).
# Matrices are stored transposed where the kernels accumulate column by column.
B_SP = 0  # floating_step scalars and folded matrices (S_SIZE)
B_KNOTS = 1  # mooring table knots (n)
B_SEG26 = 2  # floating_step mooring segments (n - 1, 26)
B_XS = 3  # Cp/Ct/Cq TSR grid
B_YS = 4  # Cp/Ct/Cq pitch grid
B_CELLS = 5  # Cp/Ct/Cq cells (cells, 12)
B_ENDT = 6  # radiation ``end`` transposed (n_r + 6, n_r + 8)
B_STARTT = 7  # radiation ``start`` transposed (11 + n_r, 8)
B_FP = 8  # floating_f constants (F_SIZE)
B_SEG14 = 9  # mooring table segments of mooring_force (n - 1, 14)
B_RADT = 10  # radiation block [[A, B], [C, 0]] transposed (n_r + 3, n_r + 3)
B_LOADS = 11  # tower-base moment constants (8)
N_BLOCKS = 12

# ---------------------------------------------------------------- floating state S (float64)
# (unused) 4 | has z | wave clock 4 (n, resync, t₀, Δt) |
# wave values 5 (F_x, F_z, M_φ, η platform, η gauge) | Δt of the wind record | z (n_r + 8) |
# winds (steps)
S_DEMAND, S_HAVE_Z, S_CLOCK, S_WAVE, S_WIND_DT, S_Z = 0, 4, 5, 9, 14, 15
# Wave arrays Wc (float64, 17 rows x N, real and imaginary parts apart so that the loops
# vectorise): Re p, Im p, Re r, Im r (r = e^{iωΔt}), Re z₀, Im z₀, ω, Re C (5 rows), Im C (5).
W_PR, W_PI, W_RR, W_RI, W_ZR, W_ZI, W_OMEGA, W_CR, W_CI = 0, 1, 2, 3, 4, 5, 6, 7, 12
W_ROWS = 17


@njit
def turbulent_speed(table: np.ndarray, dt: float, t: float) -> float:
    """:meth:`plant.wind.TurbulentWind.speed_at`: U(t) linear in the record, periodic."""
    n = table.size
    x = t / dt
    i = math.floor(x)
    frac = x - i
    i %= n
    lo = table[i]
    return lo + (table[i + 1 if i + 1 < n else 0] - lo) * frac


@njit
def _clamped_cell(grid: np.ndarray, v: float) -> tuple[int, float]:
    """Cell i and weight w of v on an ascending grid (at least 2 points), ends held."""
    n = grid.size
    if math.isnan(v):  # NaN passes every comparison below: cell 0, NaN weight (not grid[n])
        return 0, v
    if v <= grid[0]:
        return 0, 0.0
    if v >= grid[n - 1]:
        return n - 2, 1.0
    i = int(np.searchsorted(grid, v, side="right")) - 1
    x0 = grid[i]
    return i, (v - x0) / (grid[i + 1] - x0)


@njit
def coefficients_clamped(
    tsr: float, pitch: float, xs: np.ndarray, ys: np.ndarray, cells: np.ndarray
) -> tuple[float, float, float]:
    """(Cp, Ct, Cq) bilinear in the cell of (λ, θ), clamped to the grid (PerformanceTable)."""
    nx = xs.size
    ny = ys.size
    i, a = _clamped_cell(xs, tsr)
    j, b = _clamped_cell(ys, pitch)
    # _clamped_cell keeps a NaN's cell at 0 (the result is NaN); the clamp guards the cells
    # array against any other index out of range.
    i = 0 if i < 0 else (nx - 2 if i > nx - 2 else i)
    j = 0 if j < 0 else (ny - 2 if j > ny - 2 else j)
    c = cells[i * (ny - 1) + j]
    return (
        c[0] + a * c[1] + b * (c[2] + a * c[3]),
        c[4] + a * c[5] + b * (c[6] + a * c[7]),
        c[8] + a * c[9] + b * (c[10] + a * c[11]),
    )


@njit
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


@njit
def _mooring(
    knots: np.ndarray, segs: np.ndarray, q0: float, q1: float, q2: float
) -> tuple[float, float, float]:
    """:func:`plant.platform.mooring_force` on the table's segments (rows of 14)."""
    n = segs.shape[0]
    i = int(np.searchsorted(knots, q0, side="right")) - 1
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


@njit
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


@njit
def _radiation_mu(x: np.ndarray, radt: np.ndarray, nr: int) -> tuple[float, float, float]:
    """μ = C_r ξ (the last three rows of the radiation block), summed over columns."""
    mu0 = mu1 = mu2 = 0.0
    for j in range(nr + 3):
        vj = x[11 + j] if j < nr else x[4 + j - nr]
        mu0 += radt[j, nr] * vj
        mu1 += radt[j, nr + 1] * vj
        mu2 += radt[j, nr + 2] * vj
    return mu0, mu1, mu2


@njit
def floating_f(
    x: np.ndarray, u: np.ndarray, C: np.ndarray, off: np.ndarray, out: np.ndarray
) -> None:
    """dx/dt of :func:`plant.platform.f` into ``out`` (radiation block [[A, B], [C, 0]])."""
    nr = x.size - 11
    radt = _b2(C, off, B_RADT, nr + 3)
    mu0 = mu1 = mu2 = 0.0
    if nr > 0:
        acc = np.zeros(nr + 3)
        for j in range(nr + 3):
            vj = x[11 + j] if j < nr else x[4 + j - nr]
            for r in range(nr + 3):
                acc[r] += radt[j, r] * vj
        for r in range(nr):
            out[11 + r] = acc[r]
        mu0, mu1, mu2 = acc[nr], acc[nr + 1], acc[nr + 2]
    _mech(
        x, u, mu0, mu1, mu2, _b1(C, off, B_FP), _b1(C, off, B_KNOTS), _b2(C, off, B_SEG14, 14),
        _b1(C, off, B_XS), _b1(C, off, B_YS), _b2(C, off, B_CELLS, 12), out,
    )  # fmt: skip


@njit
def floating_step(
    x: np.ndarray,
    u: np.ndarray,
    out: np.ndarray,
    z: np.ndarray,
    use_last: bool,
    C: np.ndarray,
    off: np.ndarray,
    wk: np.ndarray,
) -> None:
    """One step of :func:`plant.platform.step_floating` from ``x`` into ``out``.

    ``z`` (n_r + 8) holds (ξ1, a_μ, a_r) of the previous step's end (used when ``use_last``)
    and receives this step's; ``wk`` (>= 56) is scratch. Stage order, constants and sums as
    the step's docstring.
    """
    m = 11
    nr = x.size - m
    sp = _b1(C, off, B_SP)
    knots = _b1(C, off, B_KNOTS)
    segs = _b2(C, off, B_SEG26, 26)
    xs = _b1(C, off, B_XS)
    ys = _b1(C, off, B_YS)
    cells = _b2(C, off, B_CELLS, 12)
    h = sp[0]
    tilt, ict, kap, radius = sp[1], sp[2], sp[3], sp[4]
    k_thrust, k_dom, g_dom = sp[5], sp[6], sp[7]
    p_lo, p_hi, p_itau, p_rate = sp[8], sp[9], sp[10], sp[11]
    t_hi, t_itau, t_rate = sp[12], sp[13], sp[14]
    jh2, jh3, jv2, jv3 = sp[15], sp[16], sp[17], sp[18]
    aero = sp[19] != 0.0
    h2 = 0.5 * h
    h6 = h / 6.0
    om, th, tg = x[8], x[9], x[10]
    wind = u[2] if aero else 0.0
    dem = u[0]
    pd = p_lo if dem < p_lo else (p_hi if dem > p_hi else dem)
    dem = u[1]
    td = 0.0 if dem < 0.0 else (t_hi if dem > t_hi else dem)
    f0, f1, f2 = u[3], u[4], u[5]
    am = wk[0:4]
    ar = wk[4:8]
    am[:] = 0.0
    ar[:] = 0.0
    if nr:
        if use_last:
            for i in range(4):
                am[i] = z[nr + i]
                ar[i] = z[nr + 4 + i]
        else:
            startt = _b2(C, off, B_STARTT, 8)
            acc8 = wk[48:56]
            acc8[:] = 0.0
            for j in range(m + nr):
                xj = x[j]
                for r in range(8):
                    acc8[r] += startt[j, r] * xj
            for i in range(4):
                am[i] = acc8[i]
                ar[i] = acc8[4 + i]
    au = wind if wind > 0.0 else -wind
    uw = wind * au
    b = wk[8:12]
    xd = wk[12:28]
    for i in range(4):
        w = S_W + 3 * i
        b[i] = sp[w] * f0 + sp[w + 1] * f1 + sp[w + 2] * f2 + am[i] + sp[S_TC + i] * uw
        for j in range(4):
            xd[4 * i + j] = sp[S_D + 4 * i + j] + au * sp[S_TD + 4 * i + j]
    nseg = segs.shape[0]
    sq = wk[28:32]
    sv = wk[32:36]
    a = wk[36:40]
    kq = wk[40:44]
    kv = wk[44:48]
    kq[:] = 0.0
    kv[:] = 0.0
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
        endt = _b2(C, off, B_ENDT, nr + 8)
        nv = nr + 6
        vec = np.empty(nv)
        for j in range(nr):
            vec[j] = x[m + j]
        vec[nr] = x[4]
        vec[nr + 1] = x[5]
        vec[nr + 2] = x[6]
        vec[nr + 3] = out[4]
        vec[nr + 4] = out[5]
        vec[nr + 5] = out[6]
        # z = end @ vec, each row summed over j in order, eight rows at a time (independent
        # accumulators, so the additions of different rows overlap).
        nz = nr + 8
        r0 = 0
        while r0 + 8 <= nz:
            a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = 0.0
            for j in range(nv):
                vj = vec[j]
                row = endt[j]
                a0 += row[r0] * vj
                a1 += row[r0 + 1] * vj
                a2 += row[r0 + 2] * vj
                a3 += row[r0 + 3] * vj
                a4 += row[r0 + 4] * vj
                a5 += row[r0 + 5] * vj
                a6 += row[r0 + 6] * vj
                a7 += row[r0 + 7] * vj
            z[r0] = a0
            z[r0 + 1] = a1
            z[r0 + 2] = a2
            z[r0 + 3] = a3
            z[r0 + 4] = a4
            z[r0 + 5] = a5
            z[r0 + 6] = a6
            z[r0 + 7] = a7
            r0 += 8
        for r in range(r0, nz):
            acc = 0.0
            for j in range(nv):
                acc += endt[j, r] * vec[j]
            z[r] = acc
        for r in range(nr):
            out[m + r] = z[r]


@njit
def phasor_step(wc: np.ndarray, s: np.ndarray, out: np.ndarray, n_out: int) -> None:
    """Advance the wave phasors one Δt and write the first ``n_out`` outputs (0, 3 or 5).

    p_i ← p_i e^{iω_iΔt} (:meth:`plant.waves.PhasorStepper.advance`, the complex product
    (a + ib)(c + id) = (ac − bd) + i(ad + bc); every ``resync`` steps exactly
    p_i = z_i e^{iω_i(t₀ + nΔt)}), then out_o = Re Σ_i C_oi p_i summed over i in order
    (:meth:`~plant.waves.PhasorStepper.values`). ``s`` holds the clock at S_CLOCK.
    """
    n = s[S_CLOCK] + 1.0
    s[S_CLOCK] = n
    resync = s[S_CLOCK + 1]
    nc = wc.shape[1]
    pr = wc[W_PR]
    pim = wc[W_PI]
    if resync > 0.0 and n % resync == 0.0:
        t = s[S_CLOCK + 2] + n * s[S_CLOCK + 3]
        for i in range(nc):
            p = complex(wc[W_ZR, i], wc[W_ZI, i]) * np.exp(1j * (wc[W_OMEGA, i] * t))
            pr[i] = p.real
            pim[i] = p.imag
    else:
        rr = wc[W_RR]
        ri = wc[W_RI]
        for i in range(nc):
            a = pr[i]
            b = pim[i]
            pr[i] = a * rr[i] - b * ri[i]
            pim[i] = a * ri[i] + b * rr[i]
    if n_out == 0:
        return
    c0r, c1r, c2r = wc[W_CR], wc[W_CR + 1], wc[W_CR + 2]
    c0i, c1i, c2i = wc[W_CI], wc[W_CI + 1], wc[W_CI + 2]
    a0 = a1 = a2 = a3 = a4 = 0.0
    if n_out == 3:
        for i in range(nc):
            a = pr[i]
            b = pim[i]
            a0 += c0r[i] * a - c0i[i] * b
            a1 += c1r[i] * a - c1i[i] * b
            a2 += c2r[i] * a - c2i[i] * b
    else:
        c3r, c4r, c3i, c4i = wc[W_CR + 3], wc[W_CR + 4], wc[W_CI + 3], wc[W_CI + 4]
        for i in range(nc):
            a = pr[i]
            b = pim[i]
            a0 += c0r[i] * a - c0i[i] * b
            a1 += c1r[i] * a - c1i[i] * b
            a2 += c2r[i] * a - c2i[i] * b
            a3 += c3r[i] * a - c3i[i] * b
            a4 += c4r[i] * a - c4i[i] * b
        out[3] = a3
        out[4] = a4
    out[0] = a0
    out[1] = a1
    out[2] = a2


@njit
def phasor_values(wc: np.ndarray, out: np.ndarray) -> None:
    """out_o = Re Σ_i C_oi p_i for the five outputs, without advancing."""
    for o in range(5):
        acc = 0.0
        for i in range(wc.shape[1]):
            acc += wc[W_CR + o, i] * wc[W_PR, i] - wc[W_CI + o, i] * wc[W_PI, i]
        out[o] = acc


@njit
def advance_floating(
    x: np.ndarray,
    s: np.ndarray,
    wc: np.ndarray,
    C: np.ndarray,
    off: np.ndarray,
    n_steps: int,
    switch: int,
    wind_table: np.ndarray,
    t_s: float,
    h: float,
    pitch0: float,
    torque0: float,
    pitch1: float,
    torque1: float,
) -> None:
    """One control period in place: ``n_steps`` steps of :func:`floating_step`.

    The demand (θ_c rad, T_c N m) is (pitch0, torque0) for the first ``switch`` steps, then
    (pitch1, torque1). ``s`` (layout S_*): the wind at each step's middle (from
    ``wind_table`` when it is not empty: a turbulent record, :func:`turbulent_speed`), the
    wave clock and values, z. The wave stepper ``wc``
    (no columns: still water, the values held) is advanced twice per step (Δt = h/2), the
    mid-step forces going into the step's input and the end values of the last step into
    the wave values.
    """
    nr = x.size - 11
    z = s[S_Z : S_Z + nr + 8]
    winds = s[S_Z + nr + 8 : S_Z + nr + 8 + n_steps]
    out = np.empty_like(x)
    wk = np.empty(67)
    u = wk[56:62]
    wm = wk[62:67]
    wave = s[S_WAVE : S_WAVE + 5]
    waves = wc.shape[1] > 0
    if wind_table.size:
        for i in range(n_steps):
            winds[i] = turbulent_speed(wind_table, s[S_WIND_DT], t_s + i * h + 0.5 * h)
    for i in range(n_steps):
        if i < switch:
            u[0] = pitch0
            u[1] = torque0
        else:
            u[0] = pitch1
            u[1] = torque1
        if waves:
            phasor_step(wc, s, wm, 3)
            u[3] = wm[0]
            u[4] = wm[1]
            u[5] = wm[2]
            phasor_step(wc, s, wave, 5 if i == n_steps - 1 else 0)
        else:
            u[3] = wave[0]
            u[4] = wave[1]
            u[5] = wave[2]
        u[2] = winds[i]
        floating_step(x, u, out, z, s[S_HAVE_Z] != 0.0, C, off, wk)
        x[:] = out
        s[S_HAVE_Z] = 1.0


@njit
def floating_truth(
    x: np.ndarray,
    s: np.ndarray,
    C: np.ndarray,
    off: np.ndarray,
    wind_table: np.ndarray,
    t: float,
    wind: float,
    pitch: float,
    torque_demand: float,
    eff: float,
) -> tuple[float, ...]:
    """Outputs of :meth:`plant.simulator.PlantSimulator.truth` for the floating plant.

    Returns (U, U_rel, T_a, T, P_e, ω_g, λ, Cp, Ct, M_tb, a_nacelle, F_x^w, F_z^w, M_φ^w,
    η platform, η gauge): U the wind at ``t`` (``wind`` unless ``wind_table`` holds a
    turbulent record), U_rel of :func:`plant.platform.relative_wind`, rotor loads of
    :func:`plant.turbine.outputs`, M_tb of :meth:`plant.simulator.TowerBaseLoads.moment_nm`
    with the accelerations of :func:`floating_f` at the applied (θ, T_g) demands and the
    waves of ``s``; block B_LOADS = (hub arm, overhang moment, c_φ, c_s, c_φφ, c_ss, nacelle
    height, g).
    """
    if wind_table.size:
        wind = turbulent_speed(wind_table, s[S_WIND_DT], t)
    u = np.empty(6)
    u[0] = pitch
    u[1] = torque_demand
    u[2] = wind
    u[3] = s[S_WAVE]
    u[4] = s[S_WAVE + 1]
    u[5] = s[S_WAVE + 2]
    nr = x.size - 11
    mu0 = mu1 = mu2 = 0.0
    if nr > 0:
        mu0, mu1, mu2 = _radiation_mu(x, _b2(C, off, B_RADT, nr + 3), nr)
    fp = _b1(C, off, B_FP)
    xs = _b1(C, off, B_XS)
    ys = _b1(C, off, B_YS)
    cells = _b2(C, off, B_CELLS, 12)
    dx = np.empty(11)
    knots = _b1(C, off, B_KNOTS)
    _mech(x, u, mu0, mu1, mu2, fp, knots, _b2(C, off, B_SEG14, 14), xs, ys, cells, dx)
    loads = _b1(C, off, B_LOADS)
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
    return (
        wind,
        u_rel,
        t_aero,
        thrust,
        eff * torque * omega * gear,
        omega * gear,
        tsr,
        cp,
        ct,
        tbm,
        dx[4] + loads[6] * dx[6] + dx[7],
        s[S_WAVE],
        s[S_WAVE + 1],
        s[S_WAVE + 2],
        s[S_WAVE + 3],
        s[S_WAVE + 4],
    )


#: :func:`floating_truth_into`'s record: PlantState's fields after ``publish_time_ns``, in
#: their declared order, ``floating`` (at :data:`TRUTH_FLOATING`) held as 1.0.
TRUTH_FIELDS = (
    "rotor_speed_rad_s", "generator_speed_rad_s", "blade_pitch_rad", "generator_torque_nm",
    "aero_torque_nm", "rotor_thrust_n", "wind_speed_m_s", "relative_wind_speed_m_s",
    "electrical_power_w", "tip_speed_ratio", "power_coefficient", "thrust_coefficient",
    "blade_pitch_applied_rad", "generator_torque_applied_nm", "floating", "platform_surge_m",
    "platform_heave_m", "platform_pitch_rad", "platform_surge_velocity_m_s",
    "platform_heave_velocity_m_s", "platform_pitch_rate_rad_s", "tower_top_displacement_m",
    "tower_top_velocity_m_s", "nacelle_acc_fore_aft_m_s2", "wave_elevation_platform_m",
    "wave_elevation_gauge_m", "wave_force_surge_n", "wave_moment_pitch_nm",
    "tower_base_moment_nm", "shaft_torque_nm",
)  # fmt: skip
TRUTH_FLOATING = TRUTH_FIELDS.index("floating")


@njit
def floating_truth_into(
    rec: np.ndarray,
    channel_fields: np.ndarray,
    x: np.ndarray,
    s: np.ndarray,
    C: np.ndarray,
    off: np.ndarray,
    wind_table: np.ndarray,
    t: float,
    wind: float,
    pitch: float,
    torque_demand: float,
    eff: float,
    gear: float,
) -> None:
    """:func:`floating_truth` and the state written as one record, for the truth message
    and the sensor channels without a Python step between them.

    ``rec[:n]`` (n = len(:data:`TRUTH_FIELDS`)) gets PlantState's values after
    ``publish_time_ns`` in field order (the states of ``x``, the outputs of
    :func:`floating_truth`, the applied demands, the shaft torque N T_g); ``rec[n + j]``
    then gets ``rec[channel_fields[j]]``, the true value of sensor channel j (the suite's
    order), so ``rec[n:]`` is the ``truths`` of :func:`sensors._kernels.suite_step`. Copies
    only: the values are :func:`floating_truth`'s.
    """
    (
        u_wind, u_rel, t_aero, thrust, p_el, w_gen, tsr, cp, ct, tbm, acc,
        wx, _wz, wp, eta_p, eta_g,
    ) = floating_truth(x, s, C, off, wind_table, t, wind, pitch, torque_demand, eff)  # fmt: skip
    rec[0] = x[8]
    rec[1] = w_gen
    rec[2] = x[9]
    rec[3] = x[10]
    rec[4] = t_aero
    rec[5] = thrust
    rec[6] = u_wind
    rec[7] = u_rel
    rec[8] = p_el
    rec[9] = tsr
    rec[10] = cp
    rec[11] = ct
    rec[12] = pitch
    rec[13] = torque_demand
    rec[14] = 1.0
    rec[15] = x[0]
    rec[16] = x[1]
    rec[17] = x[2]
    rec[18] = x[4]
    rec[19] = x[5]
    rec[20] = x[6]
    rec[21] = x[3]
    rec[22] = x[7]
    rec[23] = acc
    rec[24] = eta_p
    rec[25] = eta_g
    rec[26] = wx
    rec[27] = wp
    rec[28] = tbm
    rec[29] = gear * x[10]
    n = 30
    for j in range(channel_fields.size):
        rec[n + j] = rec[channel_fields[j]]


@njit
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


@njit
def turbine_advance(
    x: np.ndarray, s: np.ndarray, C: np.ndarray, off: np.ndarray, h: float, n_steps: int,
    switch: int, wind_table: np.ndarray, t_s: float,
) -> None:  # fmt: skip
    """Classic RK4 of :func:`plant.turbine.f` (as :func:`plant.integrate.rk4_step`), in place
    on x = (ω, θ, T_g), the wind held at each step's middle.

    ``s`` = (previous θ_c, T_c, new θ_c, T_c, Δt of the wind record, then the wind of each
    step, computed here from ``wind_table`` when it is not empty); C, off blocks: tp (12,
    :func:`_turbine_f`, then k_thrust), TSR grid, pitch grid, Cp/Ct/Cq cells.
    """
    tp = _b1(C, off, 0)
    xs = _b1(C, off, 1)
    ys = _b1(C, off, 2)
    cells = _b2(C, off, 3, 12)
    h2 = 0.5 * h
    h6 = h / 6.0
    if wind_table.size:
        for i in range(n_steps):
            s[5 + i] = turbulent_speed(wind_table, s[4], t_s + i * h + 0.5 * h)
    for i in range(n_steps):
        pc = s[0] if i < switch else s[2]
        tc = s[1] if i < switch else s[3]
        w = s[5 + i]
        om, th, tg = x[0], x[1], x[2]
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
        x[0] = om + h6 * (k1[0] + 2.0 * (k2[0] + k3[0]) + k4[0])
        x[1] = th + h6 * (k1[1] + 2.0 * (k2[1] + k3[1]) + k4[1])
        x[2] = tg + h6 * (k1[2] + 2.0 * (k2[2] + k3[2]) + k4[2])


@njit
def turbine_outputs(
    x: np.ndarray, s: np.ndarray, C: np.ndarray, off: np.ndarray, wind_table: np.ndarray,
    t: float, wind: float, eff: float,
) -> tuple[float, ...]:  # fmt: skip
    """:func:`plant.turbine.outputs` at x = (ω, θ, T_g) and the wind at ``t`` (``wind``
    unless ``wind_table`` holds a turbulent record): (U, T_a, T, P_e, ω_g, λ, Cp, Ct, T_a ω)
    (blocks of :func:`turbine_advance`)."""
    if wind_table.size:
        wind = turbulent_speed(wind_table, s[4], t)
    tp = _b1(C, off, 0)
    omega, theta, torque = x[0], x[1], x[2]
    if wind > WIND_MIN_M_S:
        tsr = (omega if omega > 0.0 else 0.0) * tp[0] / wind
        cp, ct, cq = coefficients_clamped(
            tsr, theta, _b1(C, off, 1), _b1(C, off, 2), _b2(C, off, 3, 12)
        )
        u2 = wind * wind
        t_aero = tp[1] * u2 * cq
        thrust = tp[11] * u2 * ct
    else:
        tsr = cp = ct = t_aero = thrust = 0.0
    n = tp[2]
    return (wind, t_aero, thrust, eff * torque * omega * n, omega * n, tsr, cp, ct, t_aero * omega)
