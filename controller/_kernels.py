"""Compiled kernels of the controller's cycle: wind EKF, platform KF, wave-FF filter bank.

Why hand-written: the observers' public pure functions (:mod:`controller.estimators`) and the
LQRI's wave feedforward (:mod:`controller.lqri`) each do a few dozen floating-point operations
on 3-, 6- and 25-element states, where numpy's per-call overhead (about 1 us per operation on
a tiny array) and Python's per-bytecode cost made up most of the advanced controller's
~160 us cycle. No library offers these specific steps (a Kalman update with per-channel
chi-square gating, validity and subset selection; Knudsen's wind EKF on a Cp table; a bank of
discrete filters stepped together), so they are written here once, compiled with numba
(``cache=True``: compiled once per machine into ``__pycache__``, loaded from there by later
processes; no fastmath, so IEEE operation order is kept) and called by those public functions,
which keep their signatures. The equations are those of :mod:`controller.estimators` and
:mod:`controller.lqri`; in summary:

* Cp table (:func:`cp_lookup`): bilinear :math:`C = c_0 + a c_1 + b (c_2 + a c_3)` on the cell
  of :math:`(\\lambda, \\theta)` with precomputed coefficients, clamped to the grid; the same for
  :math:`\\partial C_p/\\partial\\lambda` (0 outside the TSR range).
* Aerodynamic torque (:func:`aero_torque`): :math:`T_a = k v^2 C_p/\\lambda`,
  :math:`k = \\tfrac12\\rho\\pi R^3`, :math:`\\partial T_a/\\partial v = k v (3 C_p/\\lambda -
  C_{p,\\lambda})`, :math:`\\partial T_a/\\partial\\omega = k v R (C_{p,\\lambda} - C_p/\\lambda)
  /\\lambda`.
* Wind EKF (:func:`ekf_predict`, :func:`ekf_update`, :func:`ekf_step`): first-order predict
  :math:`\\hat x^- = \\hat x + \\Delta t f`, :math:`P^- = F P F^T + \\Delta t\\,\\mathrm{diag}(q)`
  unrolled on the upper triangle; scalar Joseph update with :math:`h = e_1`,
  :math:`P_{ij} - k_i P_{1j} - P_{i1} k_j + s k_i k_j`.
* Platform KF (:func:`kf_predict`, :func:`kf_update`): :math:`x \\leftarrow F x + B u`,
  :math:`P \\leftarrow F P F^T + Q` (k steps); gated update of the accepted subset a,
  :math:`K = P H_a^T S_{aa}^{-1}` (Gauss-Jordan inverse with partial pivoting, k <= p),
  Joseph form :math:`P \\leftarrow A P A^T + K R_{aa} K^T`, :math:`A = I - K H_a`, symmetrised.
* Wave-FF bank (:func:`ff_step`): :math:`u_i = c_i z_i + d_i \\hat\\eta`,
  :math:`z \\leftarrow A_d z + b \\hat\\eta` for every filter (A_d stored transposed so that the
  inner loop runs over contiguous memory).

Every kernel allocates its outputs (no argument is modified), so the callers stay pure.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = [
    "EKF_PARAMS",
    "LQRI_LIMITS",
    "aero_torque",
    "cp_lookup",
    "ekf_predict",
    "ekf_step",
    "ekf_update",
    "ff_cycle",
    "ff_step",
    "kf_cycle",
    "kf_predict",
    "kf_update",
    "lqri_law",
    "lqri_schedule",
]

#: Layout of the EKF's constant vector (``WindSpeedEKF._prm``).
EKF_PARAMS = (
    "k",  # ½ ρ π R³ [kg/m]
    "inv_j",  # 1/J [1/(kg m²)]
    "pi_2l",  # π/(2L) [1/m]
    "q_m",  # mean-wind drift intensity [(m/s)²/s]
    "r",  # rotor-speed noise variance [(rad/s)²]
    "tsr_min",  # lowest TSR of the table [-]
    "radius",  # R [m]
    "gearbox",  # N [-]
    "wind_min",  # [m/s]
    "wind_max",  # [m/s]
    "ti",  # turbulence intensity [-]
    "q_omega",  # rotor-speed process PSD [(rad/s)²/s]
)

_jit = numba.njit(cache=True, nogil=True)
# Element loops rather than slice assignments (``a[:] = b``) throughout: numba compiles the
# array-expression machinery of a slice assignment about ten times slower (18 s against 2 s
# for the KF predict on this machine), and a first run pays that compile once.


@_jit
def _copy1(src: np.ndarray, dst: np.ndarray) -> None:
    for i in range(src.shape[0]):
        dst[i] = src[i]


@_jit
def _copy2(src: np.ndarray, dst: np.ndarray) -> None:
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]


@_jit
def _interp(grid: np.ndarray, v: float) -> tuple[int, float]:
    """Cell i and weight w of v on a grid, value = (1 − w) y_i + w y_{i+1}; ends held."""
    n = grid.size
    if n == 1 or v <= grid[0]:
        return 0, 0.0
    if v >= grid[n - 1]:
        return n - 2, 1.0
    i = int(np.searchsorted(grid, v, side="right")) - 1
    return i, (v - grid[i]) / (grid[i + 1] - grid[i])


@_jit
def cp_lookup(
    tsr_grid: np.ndarray, pitch_grid: np.ndarray, cells: np.ndarray, tsr: float, pitch: float
) -> tuple[float, float]:
    """:math:`(C_p, \\partial C_p/\\partial\\lambda)` at (tsr, pitch) from the cell table."""
    i, a = _interp(tsr_grid, tsr)
    j, b = _interp(pitch_grid, pitch)
    c = cells[i * (pitch_grid.size - 1) + j]
    cp = c[0] + a * c[1] + b * (c[2] + a * c[3])
    if tsr <= tsr_grid[0] or tsr >= tsr_grid[tsr_grid.size - 1]:
        return cp, 0.0
    return cp, c[4] + a * c[5] + b * (c[6] + a * c[7])


@_jit
def aero_torque(
    prm: np.ndarray,
    tsr_grid: np.ndarray,
    pitch_grid: np.ndarray,
    cells: np.ndarray,
    omega: float,
    wind: float,
    pitch: float,
) -> tuple[float, float, float]:
    """:math:`T_a` and its partials in :math:`\\omega` and :math:`v` (module docstring)."""
    radius = prm[6]
    v = min(max(wind, prm[8]), prm[9])
    lam = max(omega * radius / v, 0.5 * prm[5])
    cp, dcp = cp_lookup(tsr_grid, pitch_grid, cells, lam, pitch)
    kv = prm[0] * v
    cq = cp / lam
    ta = kv * v * cq
    dta_dv = kv * (3.0 * cq - dcp)
    dta_dw = kv * radius * (dcp - cq) / lam
    return ta, dta_dw, dta_dv


@_jit
def ekf_predict(
    prm: np.ndarray,
    tsr_grid: np.ndarray,
    pitch_grid: np.ndarray,
    cells: np.ndarray,
    x: tuple[float, float, float],
    p: tuple[float, float, float, float, float, float],
    pitch: float,
    torque: float,
    dt_s: float,
) -> tuple[tuple[float, float, float], tuple[float, float, float, float, float, float]]:
    """EKF time update (``WindSpeedEKF.predict``): the new (x, upper triangle of P)."""
    omega, u_t, u_m = x
    ta, dta_dw, dta_dv = aero_torque(prm, tsr_grid, pitch_grid, cells, omega, u_t + u_m, pitch)
    pi_2l = prm[2]
    a = pi_2l * u_m
    inv_j = prm[1]
    xn = (omega + dt_s * (ta - prm[7] * torque) * inv_j, u_t - dt_s * a * u_t, u_m)
    f00 = 1.0 + dt_s * dta_dw * inv_j
    g = dt_s * dta_dv * inv_j
    f11 = 1.0 - dt_s * a
    f12 = -dt_s * pi_2l * u_t
    p00, p01, p02, p11, p12, p22 = p
    m00 = f00 * p00 + g * (p01 + p02)
    m01 = f00 * p01 + g * (p11 + p12)
    m02 = f00 * p02 + g * (p12 + p22)
    m11 = f11 * p11 + f12 * p12
    m12 = f11 * p12 + f12 * p22
    tu = prm[10] * u_m
    q_t = 2.0 * a * (tu * tu)
    pn = (
        f00 * m00 + g * (m01 + m02) + dt_s * prm[11],
        f11 * m01 + f12 * m02,
        m02,
        f11 * m11 + f12 * m12 + dt_s * q_t,
        m12,
        p22 + dt_s * prm[3],
    )
    return xn, pn


@_jit
def ekf_update(
    prm: np.ndarray,
    x: tuple[float, float, float],
    p: tuple[float, float, float, float, float, float],
    z: float,
) -> tuple[tuple[float, float, float], tuple[float, float, float, float, float, float], float]:
    """EKF measurement update with a finite rotor speed z: (x, P upper triangle, innovation)."""
    p00, p01, p02, p11, p12, p22 = p
    omega, u_t, u_m = x
    y = z - omega
    s = p00 + prm[4]
    k0, k1, k2 = p00 / s, p01 / s, p02 / s
    u_m = min(max(u_m + k2 * y, prm[8]), prm[9])
    xn = (omega + k0 * y, u_t + k1 * y, u_m)
    pn = (
        p00 - 2.0 * k0 * p00 + s * k0 * k0,
        p01 - k0 * p01 - p00 * k1 + s * k0 * k1,
        p02 - k0 * p02 - p00 * k2 + s * k0 * k2,
        p11 - 2.0 * k1 * p01 + s * k1 * k1,
        p12 - k1 * p02 - p01 * k2 + s * k1 * k2,
        p22 - 2.0 * k2 * p02 + s * k2 * k2,
    )
    return xn, pn, y


@_jit
def ekf_step(
    prm: np.ndarray,
    tsr_grid: np.ndarray,
    pitch_grid: np.ndarray,
    cells: np.ndarray,
    x: tuple[float, float, float],
    p: tuple[float, float, float, float, float, float],
    z: float,
    valid: bool,
    pitch: float,
    torque: float,
    dt_s: float,
) -> tuple[
    tuple[float, float, float],
    tuple[float, float, float, float, float, float],
    float,
    bool,
    float,
]:
    """Predict, update when ``valid`` and z is finite, and the model torque at the estimate.

    Returns (x, P upper triangle, innovation (NaN: no update), updated, T_a [N m]).
    """
    x, p = ekf_predict(prm, tsr_grid, pitch_grid, cells, x, p, pitch, torque, dt_s)
    y = math.nan
    updated = False
    if valid and math.isfinite(z):
        x, p, y = ekf_update(prm, x, p, z)
        updated = True
    ta = aero_torque(prm, tsr_grid, pitch_grid, cells, x[0], x[1] + x[2], pitch)[0]
    return x, p, y, updated, ta


@_jit
def kf_predict(
    F: np.ndarray,
    B: np.ndarray,
    Q: np.ndarray,
    x: np.ndarray,
    P: np.ndarray,
    u: np.ndarray,
    steps: int,
    x_out: np.ndarray,
    P_out: np.ndarray,
) -> None:
    """``steps`` KF time updates :math:`x \\leftarrow Fx + Bu`, :math:`P \\leftarrow FPF^T + Q`.

    Writes the result into ``x_out`` and ``P_out`` (which may not alias ``x``, ``P``).
    """
    n = x.size
    bu = np.zeros(n)
    for i in range(n):
        acc = 0.0
        for k in range(u.size):
            acc += B[i, k] * u[k]
        bu[i] = acc
    _copy1(x, x_out)
    _copy2(P, P_out)
    xn = np.empty(n)
    FP = np.empty((n, n))
    for _ in range(steps):
        for i in range(n):
            acc = 0.0
            for k in range(n):
                acc += F[i, k] * x_out[k]
            xn[i] = acc + bu[i]
            for j in range(n):
                acc = 0.0
                for k in range(n):
                    acc += F[i, k] * P_out[k, j]
                FP[i, j] = acc
        for i in range(n):
            for j in range(n):
                acc = 0.0
                for k in range(n):
                    acc += FP[i, k] * F[j, k]
                P_out[i, j] = acc + Q[i, j]
        _copy1(xn, x_out)


@_jit
def _inverse(S: np.ndarray) -> np.ndarray:
    """Inverse of a small non-singular matrix, Gauss-Jordan with partial pivoting."""
    k = S.shape[0]
    a = S.copy()
    inv = np.eye(k)
    for c in range(k):
        piv = c
        big = abs(a[c, c])
        for r in range(c + 1, k):
            if abs(a[r, c]) > big:
                big = abs(a[r, c])
                piv = r
        if piv != c:
            for q in range(k):
                t = a[c, q]
                a[c, q] = a[piv, q]
                a[piv, q] = t
                t = inv[c, q]
                inv[c, q] = inv[piv, q]
                inv[piv, q] = t
        d = a[c, c]
        for q in range(k):
            a[c, q] /= d
            inv[c, q] /= d
        for r in range(k):
            if r != c:
                f = a[r, c]
                if f != 0.0:
                    for q in range(k):
                        a[r, q] -= f * a[c, q]
                        inv[r, q] -= f * inv[c, q]
    return inv


@_jit
def kf_update(
    H: np.ndarray,
    D: np.ndarray,
    R: np.ndarray,
    gate: np.ndarray,
    x: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    valid: np.ndarray,
    u: np.ndarray,
    counts: np.ndarray,
    max_misses: int,
    x_out: np.ndarray,
    P_out: np.ndarray,
    counts_out: np.ndarray,
    nis_out: np.ndarray,
) -> bool:
    """Gated KF measurement update (``PlatformKF.update``); returns ``degraded``.

    ``counts`` rows: consecutive misses, skipped, rejected, accepted (per channel); ``u`` of
    size 0 means no feedthrough. The new x, P, counts and NIS are written into the ``*_out``
    arrays (which may not alias the inputs).
    """
    p, n = H.shape
    y = np.empty(p)
    for i in range(p):
        acc = 0.0
        for k in range(n):
            acc += H[i, k] * x[k]
        y[i] = z[i] - acc
    if u.size:
        for i in range(p):
            acc = 0.0
            for k in range(u.size):
                acc += D[i, k] * u[k]
            y[i] -= acc
    PHt = np.empty((n, p))
    for i in range(n):
        for j in range(p):
            acc = 0.0
            for k in range(n):
                acc += P[i, k] * H[j, k]
            PHt[i, j] = acc
    S = np.empty((p, p))
    for i in range(p):
        for j in range(p):
            acc = 0.0
            for k in range(n):
                acc += H[i, k] * PHt[k, j]
            S[i, j] = acc + R[i, j]
    cnt = counts_out
    _copy2(counts, cnt)
    nis = nis_out
    for i in range(p):
        nis[i] = math.nan
    idx = np.empty(p, dtype=np.int64)
    na = 0
    for i in range(p):
        e = y[i] * y[i] / S[i, i]
        if not (valid[i] and math.isfinite(e)):
            cnt[1, i] += 1
            cnt[0, i] += 1
        elif e > gate[i]:
            nis[i] = e
            cnt[2, i] += 1
            cnt[0, i] += 1
        else:
            nis[i] = e
            cnt[3, i] += 1
            cnt[0, i] = 0
            idx[na] = i
            na += 1
    xn = x_out
    _copy1(x, xn)
    Pn = P_out
    _copy2(P, Pn)
    if na:
        Sa = np.empty((na, na))
        for a in range(na):
            for b in range(na):
                Sa[a, b] = S[idx[a], idx[b]]
        Si = _inverse(Sa)
        K = np.empty((n, na))
        for i in range(n):
            for b in range(na):
                acc = 0.0
                for a in range(na):
                    acc += PHt[i, idx[a]] * Si[a, b]
                K[i, b] = acc
        for i in range(n):
            acc = 0.0
            for a in range(na):
                acc += K[i, a] * y[idx[a]]
            xn[i] = x[i] + acc
        A = np.empty((n, n))
        for i in range(n):
            for j in range(n):
                acc = 0.0
                for a in range(na):
                    acc += K[i, a] * H[idx[a], j]
                A[i, j] = (1.0 if i == j else 0.0) - acc
        AP = np.empty((n, n))
        for i in range(n):
            for j in range(n):
                acc = 0.0
                for k in range(n):
                    acc += A[i, k] * P[k, j]
                AP[i, j] = acc
        KR = np.empty((n, na))
        for i in range(n):
            for b in range(na):
                acc = 0.0
                for a in range(na):
                    acc += K[i, a] * R[idx[a], idx[b]]
                KR[i, b] = acc
        for i in range(n):
            for j in range(n):
                acc = 0.0
                for k in range(n):
                    acc += AP[i, k] * A[j, k]
                acc2 = 0.0
                for b in range(na):
                    acc2 += KR[i, b] * K[j, b]
                Pn[i, j] = acc + acc2
    for i in range(n):
        for j in range(i, n):
            s = 0.5 * (Pn[i, j] + Pn[j, i])
            Pn[i, j] = s
            Pn[j, i] = s
    degraded = False
    for i in range(p):
        if cnt[0, i] > max_misses:
            degraded = True
    return degraded


@_jit
def kf_cycle(
    F: np.ndarray,
    B: np.ndarray,
    Q: np.ndarray,
    H: np.ndarray,
    D: np.ndarray,
    R: np.ndarray,
    gate: np.ndarray,
    x: np.ndarray,
    P: np.ndarray,
    u: np.ndarray,
    steps: int,
    z: np.ndarray,
    valid: np.ndarray,
    counts: np.ndarray,
    max_misses: int,
    x_out: np.ndarray,
    P_out: np.ndarray,
    counts_out: np.ndarray,
    nis_out: np.ndarray,
) -> bool:
    """:func:`kf_predict` then :func:`kf_update` (feedthrough of the same ``u``) in one call."""
    n = x.size
    xp = np.empty(n)
    Pp = np.empty((n, n))
    kf_predict(F, B, Q, x, P, u, steps, xp, Pp)
    return kf_update(
        H, D, R, gate, xp, Pp, z, valid, u, counts, max_misses, x_out, P_out, counts_out, nis_out
    )


@_jit
def ff_step(
    a_t: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    d: np.ndarray,
    zs: np.ndarray,
    i: int,
    j: int,
    eta: float,
    zn: np.ndarray,
) -> tuple[float, float]:
    """Outputs of filters i and j, :math:`c z + d\\hat\\eta`; every filter's next state into zn.

    ``a_t[f]`` is :math:`A_{d,f}^T` (row-major transpose of filter f's matrix); ``zn`` (m, n)
    may not alias ``zs``.
    """
    m, n = b.shape
    out_i = 0.0
    out_j = 0.0
    for k in range(n):
        out_i += c[i, k] * zs[i, k]
        out_j += c[j, k] * zs[j, k]
    out_i += d[i] * eta
    out_j += d[j] * eta
    for f in range(m):
        row = zn[f]
        for r in range(n):
            row[r] = 0.0
        for k in range(n):
            zk = zs[f, k]
            col = a_t[f, k]
            for r in range(n):
                row[r] += col[r] * zk
        for r in range(n):
            row[r] += b[f, r] * eta
    return out_i, out_j


@_jit
def ff_cycle(
    grid: np.ndarray,
    is_pitch: np.ndarray,
    gain_wind: np.ndarray,
    gain: np.ndarray,
    a_t: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    d: np.ndarray,
    zs: np.ndarray,
    wind: float,
    eta: float,
    zn: np.ndarray,
) -> tuple[float, bool, int]:
    """The wave feedforward of one cycle (``LqriController._feedforward``).

    (i, w) the cell of U on the design grid (the nearer design alone where the two differ in
    kind: a torque filter is never blended with a pitch filter);
    :math:`u_{ff} = g(U)\\,[(1 - w)(c_i z_i + d_i\\hat\\eta) + w (c_j z_j + d_j\\hat\\eta)]`,
    g(U) interpolated in U; every filter stepped into ``zn`` (:func:`ff_step`). A NaN
    forecast gives 0 and holds every filter (``zn`` = ``zs``). Returns (u_ff, whether the
    nearest design's output is pitch, its index).
    """
    n = grid.size
    i, w = _interp(grid, wind)
    j = min(i + 1, n - 1)
    if is_pitch[i] != is_pitch[j]:  # never blend a torque with a pitch filter
        i = j if w >= 0.5 else i
        j, w = i, 0.0
    near = j if w >= 0.5 else i
    if not math.isfinite(eta):
        _copy2(zs, zn)
        return 0.0, is_pitch[near], near
    out_i, out_j = ff_step(a_t, b, c, d, zs, i, j, eta, zn)
    out = (1.0 - w) * out_i + w * out_j
    gi, gw = _interp(gain_wind, wind)
    g = (1.0 - gw) * gain[gi] + gw * gain[min(gi + 1, gain.size - 1)]
    return g * out, is_pitch[near], near


@_jit
def lqri_schedule(
    grid: np.ndarray,
    k_x: np.ndarray,
    x_op: np.ndarray,
    k_i: np.ndarray,
    theta_op: np.ndarray,
    rated_speed: float,
    wind: float,
    x: np.ndarray,
) -> tuple[float, float, float]:
    """LQRI gains at the scheduling wind and the state feedback (``LqriController.step``).

    Linear interpolation on the wind grid (ends held): :math:`K_x(U)`, :math:`x_{op}(U)`,
    :math:`K_i(U)`, :math:`\\theta_{op}(U)`; the rotor-speed and pitch entries of the
    operating point are :math:`\\omega_{ref}` and :math:`\\theta_{op}(U)`. Returns
    :math:`(K_x (x - x_{op}), K_i, \\theta_{op})`.
    """
    n = grid.size
    i, a = _interp(grid, wind)
    i1 = i + 1 if n > 1 else i
    j = min(i + 1, n - 1)
    ki = (1.0 - a) * k_i[i] + a * k_i[j]
    th_op = (1.0 - a) * theta_op[i] + a * theta_op[j]
    fb = 0.0
    for k in range(x.size):
        kxk = (1.0 - a) * k_x[i, k] + a * k_x[i1, k]
        xok = (1.0 - a) * x_op[i, k] + a * x_op[i1, k]
        if k == 6:
            xok = rated_speed
        elif k == 7:
            xok = th_op
        fb += kxk * (x[k] - xok)
    return fb, ki, th_op


#: Layout of the LQRI's constant vector (``LqriController._limits``).
LQRI_LIMITS = (
    "pitch_min",  # θ_min [rad]
    "pitch_max",  # θ_max [rad]
    "pitch_rate_max",  # [rad/s]
    "torque_max",  # [N m]
    "torque_rate_max",  # [N m/s]
    "rated_torque",  # [N m]
    "torque_gain",  # K of K ω² [N m s²]
    "rated_speed",  # ω_ref [rad/s]
    "regime_3",  # code of region 3 (pitch regime)
    "regime_2",  # code of region 2 (fallback law)
)


@_jit
def lqri_law(
    lim: np.ndarray,
    above: bool,
    entering: bool,
    z: float,
    th_prev: float,
    tq_prev: float,
    fb: float,
    ki: float,
    th_op: float,
    ff_th: float,
    ff_tq: float,
    w: float,
    law: float,
    pb: float,
    regime_below: int,
    dt_s: float,
) -> tuple[float, float, float, int]:
    """LQRI pitch law, torque law, limits and anti-windup (``LqriController.step``, 2-4).

    Above rated: :math:`z \\leftarrow z + T_s(\\omega - \\omega_{ref})` (re-initialised so that
    the output equals the previous command when ``entering``), :math:`\\theta_c = \\theta_{op}
    - K_x(x - x_{op}) - K_i z + u_{ff,\\theta}`, saturated and rate limited, z back-calculated
    when limited; torque the law's (or :math:`T_{rated}`) plus the torque FF. Below rated:
    the below-rated pitch (or θ_min) and torque law (or min(K ω², T_rated)), z = 0. Then the
    torque saturation and rate limit. Returns (θ_c [rad], T_g [N m], z [rad s], regime).
    """
    pmin, pmax = lim[0], lim[1]
    rate = lim[2] * dt_s
    if above:
        if entering:  # bumpless: LQRI output equals the previous command
            z = (th_op - fb + ff_th - th_prev) / ki
        z += dt_s * (w - lim[7])
        th_raw = th_op - fb - ki * z + ff_th
        th = min(max(th_raw, pmin), pmax)
        th = min(max(th, th_prev - rate), th_prev + rate)
        if th != th_raw:  # anti-windup by back-calculation on the total command
            z = (th_op - fb + ff_th - th) / ki
        # region 3 of the torque law is T_rated; at fine pitch (a lull) it is the
        # region-2.5 law, so the rotor is not braked below its minimum speed
        tq = (law if math.isfinite(law) else lim[5]) + ff_tq
        regime = int(lim[8])
    else:
        th = pb if math.isfinite(pb) else pmin
        th = min(max(th, pmin), pmax)
        th = min(max(th, th_prev - rate), th_prev + rate)
        if math.isfinite(law):
            tq = law + ff_tq
            regime = regime_below
        else:
            tq = min(lim[6] * w * w, lim[5]) + ff_tq
            regime = int(lim[9])
        z = 0.0  # the LQRI integrator rests; entering the pitch regime re-initialises it
    tq = min(max(tq, 0.0), lim[3])
    tlim = lim[4] * dt_s
    tq = min(max(tq, tq_prev - tlim), tq_prev + tlim)
    return th, tq, z, regime
