"""Compiled kernels of the controller's cycle: wind EKF, platform KF, wave-FF filter bank.

The advanced controller's whole cycle is :func:`advanced_cycle` (one call per control
period, see its section at the end of this module); the kernels before it are its parts,
also called one by one by the public classes.

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
  :math:`P_{ij} - k_i P_{1j} - P_{i1} k_j + s k_i k_j`; the step bounds the estimate
  :math:`u_t + u_m` to the mean-wind range, and :func:`ekf_guarded_step` (the baseline's)
  also gates the innovation at :math:`k\\sqrt{s}` and says when it gated or clamped.
* Platform KF (:func:`kf_predict`, :func:`kf_update`): :math:`x \\leftarrow F x + B u`,
  :math:`P \\leftarrow F P F^T + Q` (k steps); gated update of the accepted subset a,
  :math:`K = P H_a^T S_{aa}^{-1}` (Gauss-Jordan inverse with partial pivoting, k <= p),
  Joseph form :math:`P \\leftarrow A P A^T + K R_{aa} K^T`, :math:`A = I - K H_a`, symmetrised.
* Wave-FF bank (:func:`ff_step`): :math:`u_i = c_i z_i + d_i \\hat\\eta`,
  :math:`z \\leftarrow A_d z + b \\hat\\eta` for every filter (A_d stored transposed so that the
  inner loop runs over contiguous memory).

* Baseline law (:func:`baseline_step`, :func:`baseline_gains`): the law of
  :mod:`controller.baseline` (its module docstring has the equations), the implementation
  of ``BaselineController.step`` and ``pitch_gains`` and of the advanced controller's
  below-rated laws; the tests hold a plain-Python oracle of both.
* The compiled loop's bundles (:class:`CoreBundle`, :class:`ForecastBundle`) and the
  dispersion forecaster's step on its bundle (:func:`dispersion_forecast`).

Every kernel writes only its outputs (no input argument is modified), so the callers stay
pure; :func:`dispersion_forecast` is the exception: it steps its bundle in place.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from bus_schemas.jit import njit_nogil as _jit

__all__ = [
    "EKF_PARAMS",
    "LQRI_LIMITS",
    "aero_torque",
    "cp_lookup",
    "ekf_guarded_step",
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

    The estimate :math:`u_t + u_m` is bounded to the mean-wind range
    ``[wind_min, wind_max]`` (:math:`u_t` set at an end; :math:`u_m` already is): an EKF
    fed a speed far noisier than its model cannot run off the physical range.

    Returns (x, P upper triangle, innovation (NaN: no update), updated, T_a [N m]).
    """
    x, p = ekf_predict(prm, tsr_grid, pitch_grid, cells, x, p, pitch, torque, dt_s)
    y = math.nan
    updated = False
    if valid and math.isfinite(z):
        x, p, y = ekf_update(prm, x, p, z)
        updated = True
    v = x[1] + x[2]
    if v < prm[8]:
        x = (x[0], prm[8] - x[2], x[2])
    elif v > prm[9]:
        x = (x[0], prm[9] - x[2], x[2])
    ta = aero_torque(prm, tsr_grid, pitch_grid, cells, x[0], x[1] + x[2], pitch)[0]
    return x, p, y, updated, ta


@_jit
def ekf_guarded_step(
    prm: np.ndarray,
    tsr_grid: np.ndarray,
    pitch_grid: np.ndarray,
    cells: np.ndarray,
    x: tuple[float, float, float],
    p: tuple[float, float, float, float, float, float],
    z: float,
    pitch: float,
    torque: float,
    dt_s: float,
    gate2: float,
    v_lo: float,
    v_hi: float,
) -> tuple[tuple[float, float, float], tuple[float, float, float, float, float, float], bool]:
    """Predict, a gated update and the estimate bounded to ``[v_lo, v_hi]``.

    The update is skipped when the innovation :math:`y = z - \\hat\\omega^-` is not finite
    or :math:`y^2 > k^2 s` (``gate2`` = :math:`k^2`, :math:`s = P_{\\omega\\omega} + r`);
    then :math:`u_t` is set so that :math:`\\hat v = u_t + u_m` lies in ``[v_lo, v_hi]``.
    Returns (x, P upper triangle, bad): ``bad`` when the update was gated or the estimate
    clamped (the divergence detector's input, :func:`baseline_step`).
    """
    x, p = ekf_predict(prm, tsr_grid, pitch_grid, cells, x, p, pitch, torque, dt_s)
    y = z - x[0]
    s = p[0] + prm[4]
    bad = False
    if y * y <= gate2 * s:  # False for a non-finite y
        x, p, _y = ekf_update(prm, x, p, z)
    else:
        bad = True
    omega, u_t, u_m = x
    v = u_t + u_m
    if not v >= v_lo:  # (also a NaN)
        u_t = v_lo - u_m
        bad = True
    elif v > v_hi:
        u_t = v_hi - u_m
        bad = True
    return (omega, u_t, u_m), p, bad


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
    - K_x(x - x_{op}) - K_i z + u_{ff,\\theta}`, saturated and rate limited; z back-calculated
    at the pitch limits, held at its previous value when only the rate limit acts
    (conditional integration); torque the law's (or :math:`T_{rated}`) plus the torque FF.
    Below rated: the below-rated pitch (or θ_min) and torque law (or min(K ω², T_rated)),
    z = 0. Then the torque saturation and rate limit. Returns (θ_c [rad], T_g [N m],
    z [rad s], regime).
    """
    pmin, pmax = lim[0], lim[1]
    rate = lim[2] * dt_s
    if above:
        if entering:  # bumpless: LQRI output equals the previous command
            z = (th_op - fb + ff_th - th_prev) / ki
        z_held = z
        z += dt_s * (w - lim[7])
        th_raw = th_op - fb - ki * z + ff_th
        th = min(max(th_raw, pmin), pmax)
        if th != th_raw:  # at a position limit: back-calculation on the total command
            z = (th_op - fb + ff_th - th) / ki
        th_lim = min(max(th, th_prev - rate), th_prev + rate)
        if th_lim != th and th == th_raw:
            # rate limited only: the integrator holds (conditional integration). Set
            # from the rate-limited command instead, z followed every noisy estimate in
            # fb whenever the command rode the rate limit (two cycles in three at 15 m/s
            # with the scenarios' sensors) and the loop lost its integral action
            z = z_held
        th = th_lim
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


# ------------------------------------------------------------------------------ fused cycle
# The advanced controller's whole per-cycle path (``controller.runtime.AdvancedController``)
# in one compiled call. Measured on the 300 s LC2 replay (bench/controller_compute.py): the
# cycle made of the separate kernels above cost ~38 us CPU of which ~28 us were Python glue
# (building NamedTuples and msgspec structs, ``structs.replace`` of the baseline state twice,
# tuple arithmetic, the schedule look-up) and numba's argument/result boxing of six calls;
# the arithmetic itself is a few microseconds. So the per-cycle path is one kernel that
# calls the kernels above (same functions, same operation order: the composed classes'
# results to the last bit, ``tests/test_controller_fused.py``) with every constant packed
# once into one float64 vector ``c`` (+ an int64 layout ``lay``: offsets, sizes, bits) and
# the state in two flat vectors (float64 ``sf``, int64 ``si``): one array argument costs
# ~80 ns to dispatch, a tuple of twenty ~1.9 us.

#: Entries of the layout vector ``lay`` (offsets into ``c`` unless the name says a size,
#: a count or a bit) of :func:`advanced_cycle`, in order; built by ``AdvancedController``.
ADV_LAYOUT = (
    "scalars",  # offset of the scalar block (ADV_SCALARS)
    "ekf_prm",  # EKF constants (EKF_PARAMS)
    "tsr",  # Cp table TSR grid
    "n_tsr",
    "pitch",  # Cp table pitch grid
    "n_pitch",
    "cells",  # Cp cell coefficients, (n_cells, 8)
    "n_cells",
    "n_kf",  # number of platform-KF designs
    "kf_n",  # KF states n
    "kf_p",  # KF channels p
    "kf_m",  # KF inputs m
    "kf_grid",  # design winds [m/s]
    "kf_F",  # (n_kf, n, n)
    "kf_B",  # (n_kf, n, m)
    "kf_Q",  # (n_kf, n, n)
    "kf_H",  # (n_kf, p, n)
    "kf_D",  # (n_kf, p, m)
    "kf_R",  # (n_kf, p, p)
    "kf_gate",  # (n_kf, p)
    "kf_xop",  # (n_kf, n)
    "kf_uop",  # (n_kf, 2)
    "kf_max_misses",  # K of the KF's degraded flag
    "k_miss",  # consecutive invalid speed samples before "degraded"
    "lq_grid",  # LQRI design winds
    "n_lq",
    "lq_nx",  # LQRI state size (8)
    "lq_kx",  # (n_lq, nx)
    "lq_xop",  # (n_lq, nx)
    "lq_ki",
    "lq_thop",
    "lq_lim",  # LQRI_LIMITS
    "ff_on",  # 1: wave feedforward on
    "ff_grid",  # FF design winds
    "n_ff",
    "ff_is_pitch",  # offset into ``lay`` (!) of the n_ff is-pitch flags
    "ff_gwind",  # gain table winds
    "n_ffg",
    "ff_gain",  # gain table g
    "ff_n",  # FF filter order
    "ff_at",  # (n_ff, ff_n, ff_n), A_d transposed
    "ff_b",  # (n_ff, ff_n)
    "ff_c",  # (n_ff, ff_n)
    "ff_d",  # (n_ff,)
    "bl",  # baseline constants (BL_CONSTANTS)
    "bl_gs",  # baseline pitch gain table: angles, K_P, K_I (3 x n_gs)
    "n_gs",
    "bit_speed",  # valid_mask bits of the channels the cycle reads
    "bit_pitch",
    "bit_torque",
    "bit_acc",
    "bit_pitch_rate",
    "bit_platform_pitch",
    "bit_surge",
    "st_kf_x",  # offsets into the float state sf: KF x (n), P (n x n), NIS (p), FF (n_ff, ff_n)
    "st_kf_P",
    "st_kf_nis",
    "st_ff",
    "st_size",  # size of sf
    "st_counts",  # offset into the int state si of the KF counters (4, p)
    "st_isize",  # size of si
)
(
    _L_SCALARS,
    _L_EKF_PRM,
    _L_TSR,
    _L_N_TSR,
    _L_PITCH,
    _L_N_PITCH,
    _L_CELLS,
    _L_N_CELLS,
    _L_N_KF,
    _L_KF_N,
    _L_KF_P,
    _L_KF_M,
    _L_KF_GRID,
    _L_KF_F,
    _L_KF_B,
    _L_KF_Q,
    _L_KF_H,
    _L_KF_D,
    _L_KF_R,
    _L_KF_GATE,
    _L_KF_XOP,
    _L_KF_UOP,
    _L_KF_MAX_MISSES,
    _L_K_MISS,
    _L_LQ_GRID,
    _L_N_LQ,
    _L_LQ_NX,
    _L_LQ_KX,
    _L_LQ_XOP,
    _L_LQ_KI,
    _L_LQ_THOP,
    _L_LQ_LIM,
    _L_FF_ON,
    _L_FF_GRID,
    _L_N_FF,
    _L_FF_IS_PITCH,
    _L_FF_GWIND,
    _L_N_FFG,
    _L_FF_GAIN,
    _L_FF_N,
    _L_FF_AT,
    _L_FF_B,
    _L_FF_C,
    _L_FF_D,
    _L_BL,
    _L_BL_GS,
    _L_N_GS,
    _L_BIT_SPEED,
    _L_BIT_PITCH,
    _L_BIT_TORQUE,
    _L_BIT_ACC,
    _L_BIT_PITCH_RATE,
    _L_BIT_PLATFORM_PITCH,
    _L_BIT_SURGE,
    _L_ST_KF_X,
    _L_ST_KF_P,
    _L_ST_KF_NIS,
    _L_ST_FF,
    _L_ST_SIZE,
    _L_ST_COUNTS,
    _L_ST_ISIZE,
) = range(len(ADV_LAYOUT))

#: The scalar block of ``c`` (at ``lay[scalars]``).
ADV_SCALARS = (
    "gearbox",  # N [-]
    "switch_wind",  # U_sw of the LQRI regime switch [m/s]
    "hysteresis",  # h of the switch [m/s]
)

#: Fixed part of the float state ``sf`` (the KF and FF parts follow at ``lay[st_*]``).
ADV_FLOAT_STATE = (
    "ekf_omega",  # EKF x: ω [rad/s], u_t, u_m [m/s]
    "ekf_u_t",
    "ekf_u_m",
    "ekf_p00",  # EKF P, upper triangle
    "ekf_p01",
    "ekf_p02",
    "ekf_p11",
    "ekf_p12",
    "ekf_p22",
    "ekf_innovation",  # last rotor-speed innovation [rad/s]
    "lq_integrator",  # LQRI z [rad s]
    "lq_pitch",  # LQRI's last pitch command [rad]
    "lq_torque",  # LQRI's last torque command [N m]
    "lq_feedforward",  # g (c z + d η̂), unit of its input
    "lq_ff_pitch",  # FF part of the pitch [rad]
    "lq_ff_torque",  # FF part of the torque [N m]
    "bl_lpf_z1",  # baseline state (BaselineState without first_call)
    "bl_lpf_z2",
    "bl_speed_filtered",
    "bl_pitch_integral",
    "bl_torque_integral",
    "bl_pitch",
    "bl_torque",
    "last_z_acc",  # last raw KF measurements (repeat detection)
    "last_z_pitch_rate",
    "last_z_pitch",
    "last_z_surge",
    "last_pitch_cmd",  # applied commands
    "last_torque_cmd",
    # the wind EKF's guard (advanced_cycle): sustained bad and good time [s], the last good
    # mean-wind estimate [m/s], the EKF's initial mean-wind variance [(m/s)^2] (its restart)
    "guard_t_bad",
    "guard_t_good",
    "guard_v_hold",
    "guard_p22_0",
    "guard_kf_bad",  # the platform KF's sustained time with every valid channel rejected [s]
)
#: The int state ``si`` (the KF counters (4, p) follow at ``lay[st_counts]``).
ADV_INT_STATE = (
    "started",  # the EKF and KF were initialised from a frame
    "ekf_updates",
    "kf_index",  # KF design in use
    "kf_degraded",
    "lq_first_call",
    "lq_above_rated",
    "ff_index",  # FF design nearest to the scheduling wind (-1: none)
    "ff_started",  # the FF filter states hold values
    "bl_present",  # the baseline state holds values
    "bl_first_call",
    "speed_misses",  # consecutive invalid speed samples
    "estimator_faults",  # the guard's divergences (each entering the fallback once)
    "fallback",  # 1: the guard's fallback, the baseline law, is on
)
(
    _F_EKF_X,
    _,
    _,
    _F_EKF_P,
    _,
    _,
    _,
    _,
    _,
    _F_EKF_Y,
    _F_LQ_Z,
    _F_LQ_TH,
    _F_LQ_TQ,
    _F_LQ_FF,
    _F_LQ_FF_TH,
    _F_LQ_FF_TQ,
    _F_BL,
    _,
    _,
    _,
    _,
    _,
    _,
    _F_LAST_Z,
    _,
    _,
    _,
    _F_LAST_TH,
    _F_LAST_TQ,
    _F_G_BAD,
    _F_G_GOOD,
    _F_G_HOLD,
    _F_G_P22,
    _F_G_KF_BAD,
) = range(len(ADV_FLOAT_STATE))
(
    _I_STARTED,
    _I_EKF_UPDATES,
    _I_KF_INDEX,
    _I_KF_DEGRADED,
    _I_LQ_FIRST,
    _I_LQ_ABOVE,
    _I_FF_INDEX,
    _I_FF_STARTED,
    _I_BL_PRESENT,
    _I_BL_FIRST,
    _I_SPEED_MISSES,
    _I_EST_FAULTS,
    _I_FALLBACK,
) = range(len(ADV_INT_STATE))

#: The baseline constants (``BaselineController._k`` in its order, flags as 0/1, the pitch
#: gain table apart at ``lay[bl_gs]``).
BL_CONSTANTS = (
    "order2",
    "w_c",
    "zeta",
    "w_ci",
    "w_2",
    "K",
    "slope15",
    "w_rt",
    "w_tr",
    "slope25",
    "w_sy",
    "pi_mode",
    "w_tq_ref",
    "kp_t",
    "ki_t",
    "const_torque",
    "power_rated",
    "tq_rated",
    "theta_3",
    "tq_max",
    "tq_rate",
    "w_ref",
    "th_min",
    "th_max",
    "th_rate",
    "table",
    "kp0",
    "ki0",
    "theta_k",
    "inv_ki_ref",
    "w_pmax",
    "tsr",  # 1: TSR-tracking torque law, wind EKF, minimum-pitch schedule, setpoint smoother
    "tsr_gain",  # lambda* N / R [rad/m]
    "w_we",  # wind-estimate filter corner [rad/s]
    "ss_vs",  # setpoint-smoother gains [-] and corner [rad/s]
    "ss_pc",
    "w_ss",
    "eta",  # generator efficiency [-]
    "p_rt_e",  # rated electrical power [W]
    "th_switch",  # region-3 pitch margin above the minimum pitch [rad]
    "gear",  # gearbox ratio [-]
    "p22_0",  # initial mean-wind standard deviation of the EKF [m/s]
    "n_ps",  # length of the minimum-pitch schedule (after the gain table in ``gs``)
    "k_fl",  # platform-pitch-rate feedback gain [s]
    "w_fl",  # its second-order low pass: corner [rad/s], damping [-]
    "zeta_fl",
    "w_hp",  # its high pass corner [rad/s]
    # the wind estimate's guard (module docstring of controller.baseline, step 2c)
    "gate2",  # innovation gate: k^2 of |y| <= k sqrt(s) [-]
    "v_lo",  # physical range of the estimate [m/s]
    "v_hi",
    "t_fault",  # sustained gating/clamping before a fault [s]
    "t_recover",  # healthy time in the fallback before the estimate is used again [s]
    "k_opt",  # the fallback's region-2 gain K (HSS) [N m/(rad/s)^2]
)
#: Length of the baseline's float state array (``baseline_step``'s ``st``).
BL_STATE_SIZE = 30


@_jit
def _pmax(a: float, b: float) -> float:
    """Python's ``max(a, b)`` (the first argument unless the second is larger)."""
    return b if b > a else a


@_jit
def _pmin(a: float, b: float) -> float:
    """Python's ``min(a, b)`` (the first argument unless the second is smaller)."""
    return b if b < a else a


@_jit
def baseline_gains(
    bl: np.ndarray, gs: np.ndarray, n_gs: int, theta: float
) -> tuple[float, float, float]:
    """The pitch gains of ``BaselineController.pitch_gains``: (G_K K_P, G_K K_I, G_K) at
    pitch θ [rad]."""
    if bl[25] != 0.0:  # table: linear interpolation of (K_P, K_I), ends held
        n = n_gs
        if theta <= gs[0]:
            kp, ki = gs[n], gs[2 * n]
        elif theta >= gs[n - 1]:
            kp, ki = gs[2 * n - 1], gs[3 * n - 1]
        else:
            j = int(np.searchsorted(gs[:n], theta, side="right"))
            a0 = gs[j - 1]
            f = (theta - a0) / (gs[j] - a0)
            kp = gs[n + j - 1] + f * (gs[n + j] - gs[n + j - 1])
            ki = gs[2 * n + j - 1] + f * (gs[2 * n + j] - gs[2 * n + j - 1])
        return kp, ki, ki * bl[29]
    gk = 1.0 / (1.0 + theta / bl[28])
    return gk * bl[26], gk * bl[27], gk


@_jit
def lowpass2_step(
    u: float, w_c: float, zeta: float, dt_s: float, z1: float, z2: float, first_call: bool
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """:func:`controller.baseline.lowpass2_step`, compiled (the same statements)."""
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


@_jit
def baseline_step(
    bl: np.ndarray,
    gs: np.ndarray,
    n_gs: int,
    first_call: bool,
    st: np.ndarray,
    w: float,
    pitch_meas: float,
    torque_meas: float,
    dt_s: float,
    st_out: np.ndarray,
    wind_meas: float,
    prm: np.ndarray,
    tsr_grid: np.ndarray,
    pitch_grid: np.ndarray,
    cells: np.ndarray,
    prate: float,
    prate_valid: bool,
) -> tuple[float, float, int, float, float, float, float, int, int]:
    """The law of ``BaselineController.step`` (:mod:`controller.baseline`; its plain-Python
    oracle: tests/_baseline_oracle.py).

    ``st`` holds (lpf_z1, lpf_z2, ω_f, I_pitch, I_torque, θ_prev, T_prev) and, for the
    TSR-tracking law only (``bl[tsr]`` = 1; the array then has :data:`BL_STATE_SIZE`
    entries), (v_f, Δω_f, θ_lo, EKF x (3), EKF P (6), the platform-pitch-rate filters (3),
    the last valid rate, the wind guard's fault count, bad and good times [s], fallback
    flag and last good filtered estimate [m/s], and the trimmed-start flag: on the first
    call, 1 starts the EKF and the wind filter from the state's values instead of the
    anemometer); the new state goes to ``st_out``;
    ``w`` is the generator speed [rad/s], ``pitch_meas`` and ``torque_meas`` the measured
    pitch [rad] and torque [N m], ``wind_meas`` the anemometer [m/s] (the EKF's start);
    ``prm``, ``tsr_grid``, ``pitch_grid``, ``cells``: the wind EKF's constants and Cp table
    (:class:`controller.estimators.WindSpeedEKF`; unused by the K ω² law); ``prate`` the
    platform pitch rate [rad/s] and ``prate_valid`` its valid bit. Returns the
    :class:`ControlOutput` fields (θ, T, regime, ω_f, K_I I, G_K) and the wind estimate
    (0 for the K ω² law), the estimator faults so far and the fallback flag (both 0 for
    the K ω² law).
    """
    order2 = bl[0] != 0.0
    w_c, zeta, w_ci, w_2, K, slope15 = bl[1], bl[2], bl[3], bl[4], bl[5], bl[6]
    w_rt, w_tr, slope25, w_sy = bl[7], bl[8], bl[9], bl[10]
    pi_mode = bl[11] != 0.0
    w_tq_ref, kp_t, ki_t = bl[12], bl[13], bl[14]
    const_torque = bl[15] != 0.0
    power_rated, tq_rated, theta_3, tq_max, tq_rate = bl[16], bl[17], bl[18], bl[19], bl[20]
    w_ref, th_min, th_max, th_rate = bl[21], bl[22], bl[23], bl[24]
    w_pmax = bl[30]
    # generator-speed low-pass filter
    if order2:
        w_f, z1, z2 = lowpass2_step(w, w_c, zeta, dt_s, st[0], st[1], first_call)
    else:
        alpha = math.exp(-dt_s * w_c)
        prev = w if first_call else st[0]
        w_f = (1.0 - alpha) * w + alpha * prev
        z1 = w_f
        z2 = 0.0
    # previous commands
    if first_call:
        th_prev = _pmin(_pmax(pitch_meas, th_min), th_max)
        tq_prev = _pmin(_pmax(torque_meas, 0.0), tq_max)
    else:
        th_prev = st[5]
        tq_prev = st[6]
    kp_eff, ki_eff, gk = baseline_gains(bl, gs, n_gs, th_prev)
    # wind estimate, minimum pitch, setpoint smoother, TSR-tracking torque
    th_lo = th_min
    w_pc = w_ref
    i_t = st[4]
    tsr = bl[31] != 0.0
    v = 0.0
    v_f = 0.0
    ss = 0.0
    n_faults = 0
    degraded = 0
    if tsr:
        tsr_gain, w_we, ss_vs, ss_pc, w_ss = bl[32], bl[33], bl[34], bl[35], bl[36]
        eta, p_rt_e, th_switch, gear, p22_0 = bl[37], bl[38], bl[39], bl[40], bl[41]
        n_ps = int(bl[42])
        omega_r = w / gear
        gate2, v_lo, v_hi, t_fault, t_recover = bl[47], bl[48], bl[49], bl[50], bl[51]
        trim_start = first_call and st[28] != 0.0
        if trim_start:
            # a trimmed start (BaselineController.trimmed_state): the EKF and the wind
            # filter as the state holds them, at the operating point's mean wind
            x_e = (st[10], st[11], st[12])
            p_e = (st[13], st[14], st[15], st[16], st[17], st[18])
            faults, t_bad, t_good, fallback, v_hold = 0.0, 0.0, 0.0, False, st[7]
        elif first_call:
            u_m = _pmin(_pmax(_pmax(wind_meas, 3.0), prm[8]), prm[9])
            sigma_t = prm[10] * u_m
            x_e = (omega_r, 0.0, u_m)
            p_e = (prm[4], 0.0, 0.0, sigma_t * sigma_t, 0.0, p22_0 * p22_0)
            faults, t_bad, t_good, fallback, v_hold = 0.0, 0.0, 0.0, False, u_m
        else:
            x_e = (st[10], st[11], st[12])
            p_e = (st[13], st[14], st[15], st[16], st[17], st[18])
            faults, t_bad, t_good, fallback, v_hold = st[23], st[24], st[25], st[26] != 0.0, st[27]
        x_e, p_e, bad = ekf_guarded_step(
            prm, tsr_grid, pitch_grid, cells, x_e, p_e, omega_r, pitch_meas, torque_meas,
            dt_s, gate2, v_lo, v_hi,
        )  # fmt: skip
        finite = True
        for k in range(3):
            if not math.isfinite(x_e[k]):
                finite = False
        for k in range(6):
            if not math.isfinite(p_e[k]):
                finite = False
        if bad:
            t_bad += dt_s
            t_good = 0.0
        else:
            t_good += dt_s
            t_bad = 0.0
        if not finite or t_bad >= t_fault:
            # divergence: an estimator fault; the EKF restarts at the measured rotor speed
            # and the last good estimate, the torque falls back to the K omega^2 law
            if not fallback:
                faults += 1.0
                fallback = True
            u_m = _pmin(_pmax(v_hold, prm[8]), prm[9])
            sigma_t = prm[10] * u_m
            om0 = omega_r if math.isfinite(omega_r) else 0.0
            x_e = (om0, 0.0, u_m)
            p_e = (prm[4], 0.0, 0.0, sigma_t * sigma_t, 0.0, p22_0 * p22_0)
            t_bad = 0.0
            t_good = 0.0
        elif fallback and t_good >= t_recover:
            fallback = False
        v = x_e[1] + x_e[2]
        if fallback:
            v_f = v_hold
        elif first_call and not trim_start:
            v_f = v
        else:
            a_w = math.exp(-dt_s * w_we)
            v_f = (1.0 - a_w) * v + a_w * st[7]
        if not fallback and t_bad == 0.0:
            v_hold = v_f
        o = 3 * n_gs
        if n_ps == 0:
            th_lo = th_min
        else:
            if v_f <= gs[o]:
                th_s = gs[o + n_ps]
            elif v_f >= gs[o + n_ps - 1]:
                th_s = gs[o + 2 * n_ps - 1]
            else:
                j = int(np.searchsorted(gs[o : o + n_ps], v_f, side="right"))
                w0 = gs[o + j - 1]
                jq = o + n_ps + j
                th_s = gs[jq - 1] + (v_f - w0) / (gs[o + j] - w0) * (gs[jq] - gs[jq - 1])
            th_lo = th_s if th_s > th_min else th_min
        th_lo_prev = th_lo if first_call else st[9]
        p_el = eta * tq_prev * w_f
        d_om = ((th_prev - th_lo_prev) / 0.524 * ss_vs - (p_rt_e - p_el) / p_rt_e * ss_pc) * w_ref
        if first_call:
            ss = d_om
        else:
            a_s = math.exp(-dt_s * w_ss)
            ss = (1.0 - a_s) * d_om + a_s * st[8]
        if ss < 0.0:
            w_pc = w_ref - ss
        w_vs = _pmin(_pmax(tsr_gain * v_f, w_ci), w_tq_ref)
        if ss > 0.0:
            w_vs = w_vs - ss
        w_vs = _pmax(w_vs, w_ci)
        e_t = w_f - w_vs
        if first_call:
            i_t = tq_prev / ki_t
        if fallback:
            # the anemometer-free region-2 law (rated torque on the region-3 pitch
            # criterion); the PI's integral tracks it for a bumpless return
            k_opt = bl[52]
            tq = tq_rated if th_prev >= th_lo + th_switch else _pmin(k_opt * w_f * w_f, tq_rated)
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
        if th_prev >= th_lo + th_switch:
            regime = 4
        elif tq >= tq_rated:
            regime = 3
        elif w_vs <= w_ci:
            regime = 1
        else:
            regime = 2
        if fallback:
            v = v_f  # the estimate in use: the last good one, held
        st_out[23] = faults
        st_out[24] = t_bad
        st_out[25] = t_good
        st_out[26] = 1.0 if fallback else 0.0
        st_out[27] = v_hold
        st_out[28] = 0.0
        n_faults = int(faults)
        degraded = 1 if fallback else 0
        st_out[7] = v_f
        st_out[8] = ss
        st_out[9] = th_lo
        for k in range(3):
            st_out[10 + k] = x_e[k]
        for k in range(6):
            st_out[13 + k] = p_e[k]
    # generator torque (K omega^2 law)
    elif w_f >= w_rt or th_prev >= theta_3:
        if const_torque:
            tq = tq_rated
            regime = 4
        elif w_f > w_pmax:
            tq = power_rated / w_f
            regime = 4
        elif w_f > 0.0:
            tq = tq_max
            regime = 4
        else:
            tq = 0.0
            regime = 0
        if pi_mode:
            i_t = (tq - kp_t * (w_f - w_tq_ref)) / ki_t
    else:
        if w_f <= w_ci:
            tq = 0.0
            regime = 0
        elif w_f < w_2:
            tq = slope15 * (w_f - w_ci)
            regime = 1
        elif w_f < w_tr:
            tq = K * w_f * w_f
            regime = 2
        else:
            tq = slope25 * (w_f - w_sy)
            regime = 3
        if pi_mode:
            if tq > tq_rated:
                tq = tq_rated
                regime = 3
            e_t = w_f - w_tq_ref
            if first_call:
                i_t = tq_prev / ki_t
            i_t += e_t * dt_s
            u = kp_t * e_t + ki_t * i_t
            if u <= tq:
                i_t = (tq - kp_t * e_t) / ki_t
            elif u >= tq_rated:
                tq = tq_rated
                regime = 3
                i_t = (tq_rated - kp_t * e_t) / ki_t
            else:
                tq = u
                regime = 3
    tq = _pmin(tq, tq_max)
    d_tq = tq - tq_prev
    lim = tq_rate * dt_s
    if d_tq > lim:
        tq = tq_prev + lim
    elif d_tq < -lim:
        tq = tq_prev - lim
    # blade pitch
    err = w_f - w_pc
    integ = th_prev / ki_eff if first_call else st[3]
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
    if tsr:  # platform-pitch-rate feedback, outside the PI
        k_fl, w_fl, zeta_fl, w_hp = bl[43], bl[44], bl[45], bl[46]
        q = prate if prate_valid else (0.0 if first_call else st[22])  # held on dropout
        # the high pass's low-pass part starts as the running mean of the valid samples
        # (gain 1/n until 1/n falls to the filter's own gain): from the first sample alone
        # that sample's noise stayed in it for 1/w_hp (about 100 s of pitch offset)
        n_q = (0.0 if first_call else st[29]) + (1.0 if prate_valid else 0.0)
        g_h = 1.0 - math.exp(-dt_s * w_hp)
        if n_q >= 1.0 and 1.0 / n_q > g_h:
            g_h = 1.0 / n_q
        hp_lp = q if first_call else g_h * q + (1.0 - g_h) * st[19]
        u_f = q - hp_lp
        q_f, f1, f2 = lowpass2_step(u_f, w_fl, zeta_fl, dt_s, st[20], st[21], first_call)
        th = th + k_fl * q_f
        if th < th_lo:
            th = th_lo
        elif th > th_max:
            th = th_max
        st_out[19] = hp_lp
        st_out[20] = f1
        st_out[21] = f2
        st_out[22] = q
        st_out[29] = min(n_q, 1e9)
    dth = th - th_prev
    lim = th_rate * dt_s
    if dth > lim:
        th = th_prev + lim
    elif dth < -lim:
        th = th_prev - lim
    st_out[0] = z1
    st_out[1] = z2
    st_out[2] = w_f
    st_out[3] = integ
    st_out[4] = i_t
    st_out[5] = th
    st_out[6] = tq
    return th, tq, regime, w_f, i_term, gk, v, n_faults, degraded


@_jit
def advanced_cycle(
    c: np.ndarray,
    lay: np.ndarray,
    sf: np.ndarray,
    si: np.ndarray,
    gen_speed: float,
    pitch_meas: float,
    torque_meas: float,
    acc: float,
    pitch_rate: float,
    platform_pitch: float,
    surge: float,
    mask: int,
    eta: float,
    dt_s: float,
    steps: int,
    sf_out: np.ndarray,
    si_out: np.ndarray,
) -> tuple[
    float,
    float,
    int,
    float,
    float,
    float,
    int,
    float,
    float,
    float,
    float,
    float,
    float,
    float,
    float,
    int,
]:
    """One cycle of the advanced controller (``controller.runtime``, steps 1-3, 5, 6).

    Measurements from the frame's fields and ``mask``; wind EKF (:func:`ekf_step`); the
    platform KF of the design nearest to :math:`u_m` with 0.25 m/s hysteresis (switching
    re-expresses :math:`\\hat x_j = \\hat x_i + x_{op,i} - x_{op,j}`), its predict + gated
    update (:func:`kf_cycle`) on the channels valid and not repeated; the baseline's torque
    law and pitch PI on the commands applied (:func:`baseline_step`); the LQRI regime logic,
    schedule (:func:`lqri_schedule`), wave FF (:func:`ff_cycle`, on the forecast ``eta``, NaN
    when there is none) and limits (:func:`lqri_law`); the baseline's pitch integrator set to
    follow the LQRI above rated. The state (``sf``, ``si``, read only) is copied into
    ``sf_out``, ``si_out`` and updated there; the EKF and KF must have been started
    (``si[started]``, done by the caller from the first frame).

    The wind EKF's update is gated at :math:`k\\sqrt{s}` and its estimate bounded, and a
    divergence detector watches it and the KF (the guard: ``controller.runtime``'s module
    docstring, "Estimator guard"); in the guard's fallback the baseline's law is the
    command.

    Returns the :class:`ControlOutput` fields (θ_c, T_g, regime, ω_f N, integrator,
    scheduling wind, degraded, Û, pitch, pitch rate, surge, surge velocity, tower-top
    velocity, FF pitch, FF torque, estimator faults) in that order.
    """
    for k in range(sf.size):
        sf_out[k] = sf[k]
    for k in range(si.size):
        si_out[k] = si[k]
    sc = lay[_L_SCALARS]
    gear = c[sc]
    # 1. measurements
    speed_ok = (mask & lay[_L_BIT_SPEED]) != 0
    omega_meas = gen_speed / gear
    pitch = pitch_meas if (mask & lay[_L_BIT_PITCH]) != 0 else sf[_F_LAST_TH]
    torque = torque_meas if (mask & lay[_L_BIT_TORQUE]) != 0 else sf[_F_LAST_TQ]
    # 2. wind EKF
    o = lay[_L_EKF_PRM]
    prm = c[o : o + len(EKF_PARAMS)]
    o, n = lay[_L_TSR], lay[_L_N_TSR]
    tsr = c[o : o + n]
    o, n = lay[_L_PITCH], lay[_L_N_PITCH]
    pgrid = c[o : o + n]
    o, n = lay[_L_CELLS], lay[_L_N_CELLS]
    cells = c[o : o + 8 * n].reshape((n, 8))
    e = _F_EKF_X
    p = _F_EKF_P
    ob = lay[_L_BL]
    bl = c[ob : ob + len(BL_CONSTANTS)]
    # the guard (the below-rated baseline's figures): gate, physical range, fault times
    gate2, v_lo, v_hi, t_fault, t_recover = bl[47], bl[48], bl[49], bl[50], bl[51]
    xe, pe = ekf_predict(
        prm,
        tsr,
        pgrid,
        cells,
        (sf[e], sf[e + 1], sf[e + 2]),
        (sf[p], sf[p + 1], sf[p + 2], sf[p + 3], sf[p + 4], sf[p + 5]),
        pitch,
        torque,
        dt_s,
    )
    y = math.nan
    updated = False
    bad = False
    if speed_ok and math.isfinite(omega_meas):
        y_pre = omega_meas - xe[0]
        # the first valid sample is taken ungated: an EKF started without one (the rated
        # speed) would otherwise gate every sample until the detector restarted it
        first_speed = si[_I_EKF_UPDATES] == 0
        if first_speed or y_pre * y_pre <= gate2 * (pe[0] + prm[4]):  # False for a NaN y
            xe, pe, y = ekf_update(prm, xe, pe, omega_meas)
            updated = True
        else:
            bad = True  # gated: the rotor speed is not the model's
    v_est = xe[1] + xe[2]
    if not (v_est >= v_lo and v_est <= v_hi):  # beyond the physical range (or NaN)
        bad = True
    if v_est < prm[8]:
        xe = (xe[0], prm[8] - xe[2], xe[2])
    elif v_est > prm[9]:
        xe = (xe[0], prm[9] - xe[2], xe[2])
    finite = True
    for k in range(3):
        if not math.isfinite(xe[k]):
            finite = False
    for k in range(6):
        if not math.isfinite(pe[k]):
            finite = False
    t_bad = sf[_F_G_BAD]
    t_good = sf[_F_G_GOOD]
    v_hold = sf[_F_G_HOLD]
    faults = si[_I_EST_FAULTS]
    fallback = si[_I_FALLBACK] != 0
    if bad or not finite:
        t_bad += dt_s
        t_good = 0.0
    else:
        t_good += dt_s
        t_bad = 0.0
    if not finite or t_bad >= t_fault:
        # divergence: an estimator fault; the baseline law takes over and the EKF restarts
        # at the measured rotor speed and the last good mean wind, its initial covariance
        if not fallback:
            faults += 1
            fallback = True
        u0 = _pmin(_pmax(v_hold, prm[8]), prm[9])
        om0 = omega_meas if speed_ok and math.isfinite(omega_meas) else xe[0]
        if not math.isfinite(om0):
            om0 = 0.0
        sigma_t = prm[10] * u0
        xe = (om0, 0.0, u0)
        pe = (prm[4], 0.0, 0.0, sigma_t * sigma_t, 0.0, sf[_F_G_P22])
        y = math.nan
        updated = False
        t_bad = 0.0
        t_good = 0.0
    elif fallback and t_good >= t_recover:
        fallback = False
    if not fallback and t_bad == 0.0:
        v_hold = xe[2]
    sf_out[_F_G_BAD] = t_bad
    sf_out[_F_G_GOOD] = t_good
    sf_out[_F_G_HOLD] = v_hold
    si_out[_I_EST_FAULTS] = faults
    si_out[_I_FALLBACK] = 1 if fallback else 0
    for k in range(3):
        sf_out[e + k] = xe[k]
    for k in range(6):
        sf_out[p + k] = pe[k]
    if updated:
        sf_out[_F_EKF_Y] = y
        si_out[_I_EKF_UPDATES] = si[_I_EKF_UPDATES] + 1
    speed_misses = 0 if speed_ok else si[_I_SPEED_MISSES] + 1
    si_out[_I_SPEED_MISSES] = speed_misses
    omega = xe[0]
    u_m = xe[2]
    wind = xe[1] + xe[2]
    # 3. platform KF of the nearest design (0.25 m/s hysteresis)
    n_kf, n, pch, m = lay[_L_N_KF], lay[_L_KF_N], lay[_L_KF_P], lay[_L_KF_M]
    kg = lay[_L_KF_GRID]
    i = si[_I_KF_INDEX]
    best = i
    for j in range(n_kf):
        if abs(c[kg + j] - u_m) < abs(c[kg + best] - u_m) - 0.25:
            best = j
    ox, oP, onis = lay[_L_ST_KF_X], lay[_L_ST_KF_P], lay[_L_ST_KF_NIS]
    oxop = lay[_L_KF_XOP]
    x_in = sf[ox : ox + n]
    if best != i:
        xs = np.empty(n)
        for k in range(n):
            xs[k] = x_in[k] + c[oxop + i * n + k] - c[oxop + best * n + k]
        x_in = xs
        i = best
    si_out[_I_KF_INDEX] = i
    xo = c[oxop + i * n : oxop + (i + 1) * n]
    ou = lay[_L_KF_UOP] + 2 * i
    u = np.empty(2)
    u[0] = omega - c[ou]
    u[1] = pitch - c[ou + 1]
    z = np.empty(4)
    z[0] = acc
    z[1] = pitch_rate
    z[2] = platform_pitch - xo[1]
    z[3] = surge - xo[0]
    lz = _F_LAST_Z
    valid = np.empty(4, dtype=np.bool_)
    valid[0] = (mask & lay[_L_BIT_ACC]) != 0 and acc != sf[lz]
    valid[1] = (mask & lay[_L_BIT_PITCH_RATE]) != 0 and pitch_rate != sf[lz + 1]
    valid[2] = (mask & lay[_L_BIT_PLATFORM_PITCH]) != 0 and platform_pitch != sf[lz + 2]
    valid[3] = (mask & lay[_L_BIT_SURGE]) != 0 and surge != sf[lz + 3]
    nn, nm, pn, pp, pm = n * n, n * m, pch * n, pch * pch, pch * m
    oc = lay[_L_ST_COUNTS]
    x_out = sf_out[ox : ox + n]
    kf_degraded = kf_cycle(
        c[lay[_L_KF_F] + i * nn : lay[_L_KF_F] + (i + 1) * nn].reshape((n, n)),
        c[lay[_L_KF_B] + i * nm : lay[_L_KF_B] + (i + 1) * nm].reshape((n, m)),
        c[lay[_L_KF_Q] + i * nn : lay[_L_KF_Q] + (i + 1) * nn].reshape((n, n)),
        c[lay[_L_KF_H] + i * pn : lay[_L_KF_H] + (i + 1) * pn].reshape((pch, n)),
        c[lay[_L_KF_D] + i * pm : lay[_L_KF_D] + (i + 1) * pm].reshape((pch, m)),
        c[lay[_L_KF_R] + i * pp : lay[_L_KF_R] + (i + 1) * pp].reshape((pch, pch)),
        c[lay[_L_KF_GATE] + i * pch : lay[_L_KF_GATE] + (i + 1) * pch],
        x_in,
        sf[oP : oP + nn].reshape((n, n)),
        u,
        steps,
        z,
        valid,
        si[oc : oc + 4 * pch].reshape((4, pch)),
        lay[_L_KF_MAX_MISSES],
        x_out,
        sf_out[oP : oP + nn].reshape((n, n)),
        si_out[oc : oc + 4 * pch].reshape((4, pch)),
        sf_out[onis : onis + pch],
    )
    si_out[_I_KF_DEGRADED] = 1 if kf_degraded else 0
    # the KF's guard: a non-finite state, or every valid channel rejected by its gate for
    # the fault time, is an estimator fault too (the fallback above); the KF restarts at
    # the operating point (x = 0) with its process covariance
    n_valid = 0
    n_acc = 0
    for k in range(pch):
        if valid[k]:
            n_valid += 1
        n_acc += si_out[oc + 3 * pch + k] - si[oc + 3 * pch + k]
    t_kf = sf[_F_G_KF_BAD] + dt_s if (n_valid > 0 and n_acc == 0) else 0.0
    kf_finite = True
    for k in range(n):
        if not math.isfinite(x_out[k]):
            kf_finite = False
    for k in range(nn):
        if not math.isfinite(sf_out[oP + k]):
            kf_finite = False
    if not kf_finite or t_kf >= t_fault:
        if not fallback:
            faults += 1
            fallback = True
            si_out[_I_EST_FAULTS] = faults
            si_out[_I_FALLBACK] = 1
        oq = lay[_L_KF_Q] + i * nn
        for k in range(n):
            x_out[k] = 0.0
        for k in range(nn):
            sf_out[oP + k] = c[oq + k]
        t_kf = 0.0
        sf_out[_F_G_GOOD] = 0.0
    sf_out[_F_G_KF_BAD] = t_kf
    degraded = kf_degraded or speed_misses > lay[_L_K_MISS]
    xa = np.empty(n)
    for k in range(n):
        xa[k] = x_out[k] + xo[k]
    # 5. the baseline's laws on the commands applied
    bst = sf_out[_F_BL : _F_BL + 7]
    if si[_I_BL_PRESENT] != 0:
        first_bl = si[_I_BL_FIRST] != 0
        bst_in = sf[_F_BL : _F_BL + 7].copy()
        # its own part of the applied torque (not the FF's: its rate limit would ratchet)
        bst_in[5] = sf[_F_LAST_TH]
        bst_in[6] = sf[_F_LAST_TQ] - sf[_F_LQ_FF_TQ]
    else:
        first_bl = True
        bst_in = np.zeros(7)
    n_gs = lay[_L_N_GS]
    gs = c[lay[_L_BL_GS] : lay[_L_BL_GS] + 3 * n_gs]
    w_b = gen_speed if speed_ok else omega * gear
    # (a K omega^2 baseline: the TSR-tracking part and its state are not used)
    th_b, tq_b, regime_b, _wf_b, iterm_b, _gk_b, _v_b, _nf_b, _dg_b = baseline_step(
        bl, gs, n_gs, first_bl, bst_in, w_b, pitch_meas, torque_meas, dt_s, bst,
        0.0, prm, tsr, pgrid, cells, 0.0, False,
    )  # fmt: skip
    si_out[_I_BL_PRESENT] = 1
    si_out[_I_BL_FIRST] = 0
    # 6. regime logic + LQRI (+ wave FF)
    lim = c[lay[_L_LQ_LIM] : lay[_L_LQ_LIM] + len(LQRI_LIMITS)]
    pmin, pmax, rated = lim[0], lim[1], lim[7]
    sw, hyst = c[sc + 1], c[sc + 2]
    first_lq = si[_I_LQ_FIRST] != 0
    w = omega
    if first_lq:
        th_prev = _pmin(_pmax(pitch, pmin), pmax)
        tq_prev = tq_b if math.isfinite(tq_b) else lim[6] * w * w
        above = u_m >= sw
    else:
        th_prev = sf[_F_LQ_TH]
        tq_prev = sf[_F_LQ_TQ]
        above = si[_I_LQ_ABOVE] != 0
    h = 0.5 * hyst
    if not above and (u_m >= sw + h or w >= 1.02 * rated):
        above = True
        entering = True
    else:
        entering = first_lq
        if above and u_m <= sw - h and th_prev <= pmin + 1e-4:
            above = False
    nx = lay[_L_LQ_NX]
    xl = np.empty(nx)
    for k in range(6):
        xl[k] = xa[k]
    xl[6] = w
    xl[7] = pitch
    n_lq = lay[_L_N_LQ]
    fb, ki, th_op = lqri_schedule(
        c[lay[_L_LQ_GRID] : lay[_L_LQ_GRID] + n_lq],
        c[lay[_L_LQ_KX] : lay[_L_LQ_KX] + n_lq * nx].reshape((n_lq, nx)),
        c[lay[_L_LQ_XOP] : lay[_L_LQ_XOP] + n_lq * nx].reshape((n_lq, nx)),
        c[lay[_L_LQ_KI] : lay[_L_LQ_KI] + n_lq],
        c[lay[_L_LQ_THOP] : lay[_L_LQ_THOP] + n_lq],
        rated,
        u_m,
        xl,
    )
    u_ff = 0.0
    ff_pitch = False
    if lay[_L_FF_ON] != 0:
        n_ff, fn, n_g = lay[_L_N_FF], lay[_L_FF_N], lay[_L_N_FFG]
        off = lay[_L_ST_FF]
        zn = sf_out[off : off + n_ff * fn].reshape((n_ff, fn))
        if si[_I_FF_STARTED] != 0:
            zs = sf[off : off + n_ff * fn].reshape((n_ff, fn))
        else:
            zs = np.zeros((n_ff, fn))
        oa = lay[_L_FF_AT]
        u_ff, isp, near = ff_cycle(
            c[lay[_L_FF_GRID] : lay[_L_FF_GRID] + n_ff],
            lay[lay[_L_FF_IS_PITCH] : lay[_L_FF_IS_PITCH] + n_ff],
            c[lay[_L_FF_GWIND] : lay[_L_FF_GWIND] + n_g],
            c[lay[_L_FF_GAIN] : lay[_L_FF_GAIN] + n_g],
            c[oa : oa + n_ff * fn * fn].reshape((n_ff, fn, fn)),
            c[lay[_L_FF_B] : lay[_L_FF_B] + n_ff * fn].reshape((n_ff, fn)),
            c[lay[_L_FF_C] : lay[_L_FF_C] + n_ff * fn].reshape((n_ff, fn)),
            c[lay[_L_FF_D] : lay[_L_FF_D] + n_ff],
            zs,
            u_m,
            eta,
            zn,
        )
        ff_pitch = isp != 0
        si_out[_I_FF_INDEX] = near
        si_out[_I_FF_STARTED] = 1
    ff_th = u_ff if (ff_pitch and above) else 0.0
    ff_tq = 0.0 if ff_pitch else u_ff
    th, tq, zi, regime = lqri_law(
        lim,
        above,
        entering,
        sf[_F_LQ_Z],
        th_prev,
        tq_prev,
        fb,
        ki,
        th_op,
        ff_th,
        ff_tq,
        w,
        tq_b,
        th_b,
        regime_b,
        dt_s,
    )
    if fallback:
        # the guard's fallback: the baseline law (measured generator speed only, no
        # estimate); the LQRI restarts bumplessly from the applied command when it ends
        th = th_b
        tq = tq_b
        regime = regime_b
        zi = sf[_F_LQ_Z]
        above = False
        degraded = True
        si_out[_I_LQ_FIRST] = 1
    else:
        si_out[_I_LQ_FIRST] = 0
    si_out[_I_LQ_ABOVE] = 1 if above else 0
    sf_out[_F_LQ_Z] = zi
    sf_out[_F_LQ_TH] = th
    sf_out[_F_LQ_TQ] = tq
    sf_out[_F_LQ_FF] = u_ff
    sf_out[_F_LQ_FF_TH] = ff_th
    sf_out[_F_LQ_FF_TQ] = ff_tq
    if above:
        integrator = ki * zi
        # the baseline pitch PI tracks the LQRI's command (bumpless hand-back at θ_min)
        bst[3] = th / baseline_gains(bl, gs, n_gs, th)[1]
    else:
        integrator = iterm_b
    sf_out[lz] = acc
    sf_out[lz + 1] = pitch_rate
    sf_out[lz + 2] = platform_pitch
    sf_out[lz + 3] = surge
    sf_out[_F_LAST_TH] = th
    sf_out[_F_LAST_TQ] = tq
    return (
        th,
        tq,
        regime,
        omega * gear,
        integrator,
        0.0 if u_m < 0.0 else u_m,  # max(u, 0.0)
        1 if degraded else 0,
        wind,
        xa[1],
        xa[4],
        xa[0],
        xa[3],
        xa[5],
        ff_th,
        ff_tq,
        faults,
    )


# ---------------------------------------------------------------- bundles of a compiled loop
#: ``CoreBundle.ci`` (int64): the core's kind (0 baseline, 1 advanced), the advanced core's
#: KF predict steps per period, the baseline's first-call flag, the baseline gain table's length.
CI_KIND, CI_STEPS, CI_FIRST, CI_N_GS, CI_SIZE = range(5)


class CoreBundle(NamedTuple):
    """A controller core's constants and state as a compiled loop takes them (one argument).

    Built by the core (``BaselineController.kernel_bundle``, ``AdvancedController.
    kernel_bundle``), which alone knows its layout, and read back by it
    (``state_from_bundle``). The kernel steps the state from ``v``/``f`` into ``v2``/``f2``,
    swaps them, and leaves the last state in ``v``/``f``.

    Attributes
    ----------
    ci : ndarray of int64
        ``CI_*`` above.
    cc, lay : ndarray
        Advanced: the packed constants and layout of :func:`advanced_cycle`. Baseline with
        the TSR-tracking law: the wind EKF's constants and Cp table, and in ``lay`` the
        status's estimate bit, the four lengths (constants, TSR, pitch, cells) and the
        platform pitch rate's valid bit (else empty, and zeros).
    bl, gs : ndarray
        Baseline: :data:`BL_CONSTANTS`, the gain table and minimum-pitch schedule (empty
        for the advanced core).
    v, v2 : ndarray of float64
        The float state (advanced ``values``; baseline :data:`BL_STATE_SIZE` entries) and
        its scratch twin.
    f, f2 : ndarray of int64
        The int state (advanced ``flags``; baseline empty) and its scratch twin.
    """

    ci: np.ndarray
    cc: np.ndarray
    lay: np.ndarray
    bl: np.ndarray
    gs: np.ndarray
    v: np.ndarray
    v2: np.ndarray
    f: np.ndarray
    f2: np.ndarray


#: ``ForecastBundle.fi`` (int64): 1 when the dispersion forecaster runs in the kernel; the
#: core state's next call time, the status's forecast time and estimator mask, the
#: forecaster's unstable fits and guarded forecasts; its ring's head, count, calls, dropped
#: and dropped-in-window counts; the call period and horizon (ns); the core state's
#: forecast time; the estimator masks with and without a forecast.
(
    FI_KIND,
    FI_NEXT_NS,
    FI_STATUS_NS,
    FI_EST_MASK,
    FI_UNSTABLE,
    FI_GUARDED,
    FI_HEAD,
    FI_COUNT,
    FI_CALLS,
    FI_DROPPED,
    FI_DROPPED_WIN,
    FI_PERIOD_NS,
    FI_HORIZON_NS,
    FI_TIME_NS,
    FI_MASK_FC,
    FI_MASK_NO_FC,
    FI_SIZE,
) = range(17)
#: ``ForecastBundle.ff`` (float64): the forecast handed to :func:`advanced_cycle` (NaN: none),
#: the status's forecast, the forecaster's held sample, the FIR's last output (valid or not).
FF_ETA, FF_STATUS_M, FF_HELD, FF_RAW, FF_SIZE = range(5)


class ForecastBundle(NamedTuple):
    """The advanced core's wave-forecast part as a compiled loop takes it (one argument).

    Built by ``AdvancedController.forecast_bundle``; ``buf`` and ``drop`` are the
    dispersion forecaster's own ring buffer and drop flags (its storage, written in place
    by :func:`dispersion_forecast`), empty for the other forecasters and kinds.
    """

    buf: np.ndarray
    drop: np.ndarray
    fir: np.ndarray
    fi: np.ndarray
    ff: np.ndarray


@_jit
def dispersion_forecast(fb: ForecastBundle, t_ns: int, sample_m: float, valid: bool) -> None:
    r"""The wave forecast of ``AdvancedController.step`` with a ``DispersionPredictor``.

    :meth:`controller.forecast.DispersionPredictor.step` on ``fb`` in place (the hold rule,
    the ring buffer, then :math:`\hat\eta_B = \sum_j h_j\,w_j` as ``np.dot(fir, window)``,
    which numba also computes with BLAS ``ddot`` on the contiguous window), the core
    state's next call time :math:`(\lfloor t/T_f \rfloor + 1)\,T_f` and forecast time
    :math:`t + t_d` (ns), then the forecast handed to the core (NaN until the window has
    filled or when not finite), the status's forecast fields and the estimator mask.
    """
    fi, ff, buf, drop = fb.fi, fb.ff, fb.buf, fb.drop
    fi[FI_CALLS] += 1
    ok = valid and math.isfinite(sample_m)
    if ok:
        ff[FF_HELD] = sample_m
    else:
        fi[FI_DROPPED] += 1
    n = drop.size
    i = fi[FI_HEAD]
    held = ff[FF_HELD]
    buf[i] = held
    buf[i + n] = held
    fi[FI_DROPPED_WIN] += (0 if ok else 1) - (1 if drop[i] else 0)
    drop[i] = not ok
    head = i + 1 if i + 1 < n else 0
    fi[FI_HEAD] = head
    fi[FI_COUNT] += 1
    forecast_m = np.dot(fb.fir, buf[head : head + n])
    ff[FF_RAW] = forecast_m
    fi[FI_TIME_NS] = t_ns + fi[FI_HORIZON_NS]
    period = fi[FI_PERIOD_NS]
    fi[FI_NEXT_NS] = (t_ns // period + 1) * period
    if fi[FI_COUNT] >= n and math.isfinite(forecast_m):
        ff[FF_ETA] = forecast_m
        fi[FI_EST_MASK] = fi[FI_MASK_FC]
        ff[FF_STATUS_M] = forecast_m
        fi[FI_STATUS_NS] = fi[FI_TIME_NS]
    else:
        ff[FF_ETA] = math.nan
        fi[FI_EST_MASK] = fi[FI_MASK_NO_FC]
        ff[FF_STATUS_M] = 0.0
        fi[FI_STATUS_NS] = 0
