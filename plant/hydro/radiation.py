"""Radiation memory as a state space: Perez-Fossen frequency-domain identification.

Cummins' equation gives the radiation force on a body moving with velocity ``v`` (SI units):

.. math::

    F_{rad}(t) = -A_∞ \\dot v(t) - μ(t), \\qquad μ(t) = \\int_0^t k(t-τ) v(τ) dτ,

with the retardation kernel ``k(t) = (2/π) ∫_0^∞ B(ω) cos(ωt) dω`` (N/m, N m/rad per second
per unit velocity). Its Fourier transform is known from the hydrodynamic coefficients (Ogilvie):

.. math::

    K(jω) = B(ω) + jω (A(ω) - A_∞).

Each kernel ``K_ij`` is approximated by a rational transfer function of order ``n`` with a zero
at ``s = 0`` and relative degree exactly 1 (Perez & Fossen 2011, "Practical aspects of
frequency-domain identification of dynamic models of marine structures from hydrodynamic
data", Ocean Engineering; the method as summarised in section 2.2 of the seed document):

.. math::

    \\hat K(s) = \\frac{s P'(s)}{Q(s)}, \\quad \\deg Q = n, \\ \\deg P' = n - 2.

Identification, per kernel:

1. ``H(jω) = α K(jω) / (jω) = α ((A - A_∞) - jB/ω)`` with ``α = 1 / max|K|`` and the frequency
   normalised by the frequency of the peak of ``|K|`` (conditioning).
2. Linearised least squares (Levy) on ``Q H - P' = 0``, refined by Sanathanan-Koerner
   iterations (weights ``1/|Q_prev(jω)|``), which converge to the output-error fit.
3. Roots of ``Q`` with positive real part are reflected into the left half plane; the numerator
   is then re-fitted with ``Q`` fixed (linear least squares), so the model is stable by
   construction.
4. Realisation in controllable canonical form (``D = 0``).

When no order is given, the lowest ``n ≥ 2`` whose fit error is below the tolerance is chosen.
Passivity (``Re K̂(jω) ≥ 0``) is checked on a wide frequency grid and reported; with
``passive_floor`` it is enforced on the diagonal kernels (step 3b: the numerator re-fit becomes
a least-squares problem with linear inequality constraints, :func:`_lsi`), and after a model
reduction :func:`enforce_passivity` restores it by the smallest correction of ``C``.

No maintained Python package fits radiation kernels (the reference implementations are the
MATLAB FDI toolbox and OpenFAST's SS_Fitting, also MATLAB), so this module is written by hand on
numpy/scipy. DOF indices are 0-based WAMIT modes (0 surge ... 5 yaw), as in
:mod:`plant.hydro.wamit`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from plant.hydro.wamit import DOF_NAMES, RadiationData

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

MIN_ORDER = 2
PASSIVITY_SLACK = 1e-9  # relative to max|K|: rounding, not a physical tolerance
NPZ_FORMAT_VERSION = 1


# ------------------------------------------------------------------------------ one kernel
@dataclass(frozen=True)
class KernelFit:
    """A fitted radiation kernel ``K̂(s) = N(s)/Q(s)`` (force per unit velocity).

    Parameters
    ----------
    numerator : (n,) float
        Coefficients of ``N(s)`` in descending powers ``s^{n-1} ... s^0``; the last is 0 (zero
        at ``s = 0``). The coefficient of ``s^k`` has units of ``B`` (N s/m, N s, N m s/rad)
        times (rad/s)^(n-k), so that ``N/Q`` has the units of ``B``.
    denominator : (n + 1,) float
        Monic ``Q(s)`` in descending powers, all roots in the open left half plane.
    added_mass_inf : float
        ``A_∞`` of this kernel (kg, kg m, kg m^2), to rebuild ``A(ω)`` from the fit.
    error_k : float
        ``max_i |K̂(jω_i) - K(jω_i)| / max_i |K(jω_i)|`` over the fitted frequencies.
    error_added_mass : float
        ``max_i |Â(ω_i) - A(ω_i)| / max_i |A(ω_i) - A_∞|``.
    error_damping : float
        ``max_i |B̂(ω_i) - B(ω_i)| / max_i |B(ω_i)|``.
    error_rms : float
        ``sqrt(mean_i |K̂(jω_i) - K(jω_i)|^2) / max_i |K(jω_i)|`` (for information; bumpy
        data, e.g. column-interference ripples of a semi-submersible, keep the max errors high
        while this stays small).
    omega_min_rad_s, omega_max_rad_s : float
        Range of the fitted frequencies.
    real_part_min : float
        ``min Re K̂(jω) / max|K|`` on a log grid from ``ω_min/100`` to ``100 ω_max``.
    reflected_poles : int
        Number of unstable roots of the least-squares ``Q`` that were reflected.
    meets_tol : bool
        Whether ``fit_error`` was below the requested tolerance.

    Notes
    -----
    ``fit_error = max(error_k, error_added_mass, error_damping)`` is what order selection uses.
    The reconstructed coefficients are ``B̂(ω) = Re K̂(jω)`` and
    ``Â(ω) = A_∞ + Im K̂(jω) / ω``.
    """

    numerator: FloatArray
    denominator: FloatArray
    added_mass_inf: float
    error_k: float
    error_added_mass: float
    error_damping: float
    error_rms: float
    omega_min_rad_s: float
    omega_max_rad_s: float
    real_part_min: float
    reflected_poles: int = 0
    meets_tol: bool = True

    def __post_init__(self) -> None:
        n = self.numerator.size
        if n < 1 or self.numerator.ndim != 1:
            raise ValueError("KernelFit.numerator must be a non-empty 1-D array")
        if self.denominator.shape != (n + 1,):
            raise ValueError(
                f"KernelFit: denominator has shape {self.denominator.shape}, expected ({n + 1},) "
                "(relative degree 1)"
            )
        if not (np.all(np.isfinite(self.numerator)) and np.all(np.isfinite(self.denominator))):
            raise ValueError("KernelFit: non-finite coefficients")
        if self.denominator[0] != 1.0:
            raise ValueError("KernelFit: denominator must be monic")
        if self.numerator[-1] != 0.0:
            raise ValueError("KernelFit: numerator must vanish at s = 0")
        if np.any(np.roots(self.denominator).real >= 0.0):
            raise ValueError("KernelFit: poles must lie in the open left half plane")

    @property
    def order(self) -> int:
        """Model order ``n = deg Q`` (number of states)."""
        return int(self.numerator.size)

    @property
    def fit_error(self) -> float:
        """``max(error_k, error_added_mass, error_damping)``."""
        return max(self.error_k, self.error_added_mass, self.error_damping)

    @property
    def passive(self) -> bool:
        """``Re K̂(jω) ≥ 0`` on the check grid (meaningful for diagonal kernels)."""
        return self.real_part_min >= -PASSIVITY_SLACK

    @property
    def poles(self) -> ComplexArray:
        """Roots of ``Q(s)`` in rad/s."""
        return np.asarray(np.roots(self.denominator), dtype=np.complex128)

    def response(self, omega_rad_s: FloatArray) -> ComplexArray:
        """``K̂(jω)``, same units as ``B``."""
        s = 1j * np.asarray(omega_rad_s, dtype=np.float64)
        return np.asarray(
            np.polyval(self.numerator, s) / np.polyval(self.denominator, s), dtype=np.complex128
        )

    def added_mass(self, omega_rad_s: FloatArray) -> FloatArray:
        """``Â(ω) = A_∞ + Im K̂(jω) / ω`` (ω > 0)."""
        w = np.asarray(omega_rad_s, dtype=np.float64)
        return np.asarray(self.added_mass_inf + self.response(w).imag / w, dtype=np.float64)

    def damping(self, omega_rad_s: FloatArray) -> FloatArray:
        """``B̂(ω) = Re K̂(jω)``."""
        return np.asarray(self.response(omega_rad_s).real, dtype=np.float64)

    def state_space(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Controllable canonical realisation ``(A, B, C, D)`` of ``K̂(s)``.

        For ``Q = s^n + a_{n-1} s^{n-1} + … + a_0`` and ``N = b_{n-1} s^{n-1} + … + b_1 s``:
        ``A`` has ones on the superdiagonal and last row ``[-a_0 … -a_{n-1}]``,
        ``B = e_n`` (n × 1), ``C = [b_0 … b_{n-1}]`` (1 × n), ``D = 0``; then
        ``C (sI - A)^{-1} B = N(s)/Q(s)``. State units: velocity × s^k; ``C x`` in N or N m.
        """
        n = self.order
        A = np.zeros((n, n))
        A[:-1, 1:] = np.eye(n - 1)
        A[-1, :] = -self.denominator[1:][::-1]
        B = np.zeros((n, 1))
        B[-1, 0] = 1.0
        C = self.numerator[::-1].reshape(1, n).copy()
        return A, B, C, np.zeros((1, 1))


def kernel_response(
    omega_rad_s: FloatArray, added_mass: FloatArray, damping: FloatArray, added_mass_inf: float
) -> ComplexArray:
    """``K(jω) = B(ω) + jω (A(ω) - A_∞)`` from hydrodynamic coefficients (units of ``B``)."""
    w = np.asarray(omega_rad_s, dtype=np.float64)
    return np.asarray(
        damping + 1j * w * (np.asarray(added_mass) - added_mass_inf), dtype=np.complex128
    )


def retardation_kernel(t_s: FloatArray, omega_rad_s: FloatArray, damping: FloatArray) -> FloatArray:
    """``k(t) = (2/π) ∫ B(ω) cos(ωt) dω`` by the trapezoidal rule over the given frequencies.

    ``B`` is taken as 0 below and above the data (no tail correction), so the result is only
    as good as the data decay; units of ``B`` per second.
    """
    w = np.asarray(omega_rad_s, dtype=np.float64)
    t = np.asarray(t_s, dtype=np.float64)
    integrand = np.asarray(damping)[None, :] * np.cos(np.outer(t, w))
    return np.asarray((2.0 / np.pi) * np.trapezoid(integrand, w, axis=1), dtype=np.float64)


def _weighted_lstsq(M: ComplexArray, rhs: ComplexArray, w: FloatArray) -> FloatArray:
    """Real least squares ``min Σ w_i^2 |M_i θ - rhs_i|^2`` over real θ (columns scaled)."""
    Mr = np.vstack([(w[:, None] * M).real, (w[:, None] * M).imag])
    r = np.concatenate([(w * rhs).real, (w * rhs).imag])
    col = np.linalg.norm(Mr, axis=0)
    col[col == 0.0] = 1.0
    theta, *_ = np.linalg.lstsq(Mr / col, r, rcond=None)
    return np.asarray(theta / col, dtype=np.float64)


def _fit_normalised(
    x: FloatArray,
    H: ComplexArray,
    w: FloatArray,
    n: int,
    iterations: int = 40,
    real_floor: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, int]:
    """Fit ``H(jx) ≈ P(jx)/Q(jx)``, ``deg P = n-2``, ``Q`` monic of degree ``n``, stable.

    With ``real_floor`` (one value per data point), the final numerator fit is constrained to
    ``Re(jx P(jx)/Q(jx)) ≥ real_floor`` at the data and ``≥ 0`` on a log grid from
    ``x_min/100`` to ``100 x_max`` and asymptotically (the passivity of a diagonal kernel,
    :func:`_lsi`). Returns ``(p, q, reflected)`` with coefficients in descending powers.
    """
    jx = 1j * x
    # Vandermonde columns, descending powers.
    Vp = np.vander(jx, n - 1)  # x^{n-2} .. x^0
    Vq = np.vander(jx, n)  # x^{n-1} .. x^0
    lead = jx**n
    q = np.concatenate([[1.0], np.zeros(n)])
    weight = w.copy()
    for _ in range(iterations):
        # P(jx) - H (Q(jx) - (jx)^n) = H (jx)^n, unknowns [p, q_{n-1..0}]
        M = np.hstack([Vp, -H[:, None] * Vq])
        theta = _weighted_lstsq(M, H * lead, weight)
        q_new = np.concatenate([[1.0], theta[n - 1 :]])
        change = np.max(np.abs(q_new - q)) / max(1.0, float(np.max(np.abs(q_new))))
        q = q_new
        weight = w / np.maximum(np.abs(np.polyval(q, jx)), 1e-300)
        if change < 1e-12:
            break
    roots = np.roots(q)
    unstable = roots.real >= 0.0
    reflected = int(np.count_nonzero(unstable))
    # Reflect into the left half plane; a root on the axis is nudged to a small damping.
    roots = np.where(
        unstable, -np.maximum(np.abs(roots.real), 1e-3 * np.abs(roots)) + 1j * roots.imag, roots
    )
    q = np.real(np.poly(roots))
    # Re-fit the numerator with Q fixed: min Σ w^2 |P/Q - H|^2.
    Qv = np.polyval(q, jx)
    p = _weighted_lstsq(Vp / Qv[:, None], H, w)
    if real_floor is None:
        return p, q, reflected
    m = (w[:, None] * Vp) / Qv[:, None]
    m_real = np.vstack([m.real, m.imag])
    rhs = np.concatenate([(w * H).real, (w * H).imag])
    grid = np.logspace(np.log10(x[0] / 100.0), np.log10(x[-1] * 100.0), 2000)
    jg = 1j * np.concatenate([x, grid])
    rows = (jg[:, None] * np.vander(jg, n - 1) / np.polyval(q, jg)[:, None]).real
    lower = np.concatenate([real_floor, np.zeros(grid.size)])
    # Re K̂(jx) → −(p_0 q_1 − p_1)/x² as x → ∞ (P = p_0 s^{n-2} + p_1 s^{n-3} + …, Q monic).
    tail = np.zeros(n - 1)
    tail[0] = q[1]
    if n > 2:
        tail[1] = -1.0
    rows = np.vstack([rows, tail])
    lower = np.concatenate([lower, [0.0]])
    ok = rows @ p >= lower
    if np.all(ok):
        return p, q, reflected
    active = ~ok
    for _ in range(10):
        p_new, feasible = _lsi(m_real, rhs, rows[active], lower[active])
        if not feasible:
            break
        p = p_new
        ok = rows @ p >= lower - 1e-12 * float(np.max(np.abs(rhs)))
        if np.all(ok):
            break
        active |= ~ok
    return p, q, reflected


def _single_fit(
    omega: FloatArray,
    K: ComplexArray,
    added_mass_inf: float,
    n: int,
    weights: FloatArray,
    tol: float,
    passive_floor: float | None = None,
) -> KernelFit:
    k_max = float(np.max(np.abs(K)))
    alpha = 1.0 / k_max
    w_scale = float(omega[int(np.argmax(np.abs(K)))])
    x = omega / w_scale
    H = alpha * K / (1j * x)
    floor = None if passive_floor is None else alpha * passive_floor * K.real.clip(0.0)
    p, q, reflected = _fit_normalised(x, H, weights, n, real_floor=floor)
    # Back to s = w_scale σ:  K̂(s) = (1/α) σ P(σ) / Q(σ),  σ = s / w_scale.
    # Q_s(s) = w_scale^n Q(s / w_scale) is monic with coefficient of s^k equal to q_k w_scale^{n-k}.
    powers_q = w_scale ** np.arange(0, n + 1)  # descending index i -> power s^{n-i}: w_scale^i
    den = q * powers_q
    # N(s) = (1/α) w_scale^n (s/w_scale) P(s/w_scale); P coefficient p_i multiplies σ^{n-2-i}.
    # Term: (1/α) w_scale^n w_scale^{-(n-1-i)} s^{n-1-i} p_i = (1/α) w_scale^{1+i} p_i s^{n-1-i}.
    num = np.concatenate([p * w_scale ** (1.0 + np.arange(n - 1)) / alpha, [0.0]])
    K_fit = np.polyval(num, 1j * omega) / np.polyval(den, 1j * omega)
    B = K.real
    dA = K.imag / omega
    err_k = float(np.max(np.abs(K_fit - K)) / k_max)
    err_b = float(np.max(np.abs(K_fit.real - B)) / max(float(np.max(np.abs(B))), 1e-300))
    err_a = float(np.max(np.abs(K_fit.imag / omega - dA)) / max(float(np.max(np.abs(dA))), 1e-300))
    grid = np.logspace(np.log10(omega[0] / 100.0), np.log10(omega[-1] * 100.0), 4000)
    re_min = float(np.min((np.polyval(num, 1j * grid) / np.polyval(den, 1j * grid)).real))
    return KernelFit(
        numerator=num,
        denominator=den,
        added_mass_inf=float(added_mass_inf),
        error_k=err_k,
        error_added_mass=err_a,
        error_damping=err_b,
        error_rms=float(np.sqrt(np.mean(np.abs(K_fit - K) ** 2)) / k_max),
        omega_min_rad_s=float(omega[0]),
        omega_max_rad_s=float(omega[-1]),
        real_part_min=re_min / k_max,
        reflected_poles=reflected,
        meets_tol=max(err_k, err_a, err_b) <= tol,
    )


def fit_kernel(
    omega_rad_s: FloatArray,
    added_mass: FloatArray,
    damping: FloatArray,
    added_mass_inf: float,
    order: int | None = None,
    max_order: int = 8,
    tol: float = 0.02,
    weights: FloatArray | None = None,
    passive_floor: float | None = None,
    orders: Sequence[int] | None = None,
) -> KernelFit:
    """Fit ``K̂(s) = s P'(s)/Q(s)`` to ``K(jω) = B(ω) + jω (A(ω) - A_∞)`` (Perez-Fossen).

    Parameters
    ----------
    omega_rad_s : (m,) float
        Frequencies in rad/s, > 0, increasing. Pass only the band to fit (e.g. leave out
        frequencies polluted by irregular-frequency spikes).
    added_mass : (m,) float
        ``A(ω)`` in kg, kg m or kg m^2.
    damping : (m,) float
        ``B(ω)`` in N s/m, N s or N m s/rad.
    added_mass_inf : float
        ``A_∞`` in the units of ``added_mass``.
    order : int or None
        Model order ``n ≥ 2``; None chooses the lowest order in ``2..max_order`` whose
        ``fit_error`` is ≤ ``tol`` (or the best one, with ``meets_tol`` False, if none is).
    max_order : int
        Highest order tried when ``order`` is None.
    tol : float
        Tolerance on ``fit_error = max(error_k, error_added_mass, error_damping)``, the
        relative errors defined in :class:`KernelFit`.
    weights : (m,) float or None
        Non-negative least-squares weights per frequency (default 1).
    passive_floor : float or None
        For a diagonal kernel: constrain the final numerator fit (``Q`` fixed) to
        ``Re K̂(jω) ≥ passive_floor · B(ω)`` at the data and ``Re K̂ ≥ 0`` on a log grid
        ``ω_min/100 .. 100 ω_max`` and as ω → ∞ (linear inequalities on the numerator, solved
        exactly as a least-squares problem with inequality constraints). None: unconstrained.
    orders : sequence of int or None
        With ``order`` None: the orders to try, in this sequence, instead of
        ``2..max_order`` (the first that meets ``tol`` is returned, else the best).

    Returns
    -------
    KernelFit
        Stable by construction (unstable roots reflected), passivity reported.
    """
    w = np.asarray(omega_rad_s, dtype=np.float64)
    a = np.asarray(added_mass, dtype=np.float64)
    b = np.asarray(damping, dtype=np.float64)
    if w.ndim != 1 or a.shape != w.shape or b.shape != w.shape:
        raise ValueError("fit_kernel: omega, added_mass and damping must be 1-D of equal length")
    if not (np.all(np.isfinite(w)) and np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("fit_kernel: non-finite input")
    if np.any(w <= 0.0) or np.any(np.diff(w) <= 0.0):
        raise ValueError("fit_kernel: omega must be > 0 and strictly increasing")
    if not np.isfinite(added_mass_inf):
        raise ValueError("fit_kernel: added_mass_inf must be finite")
    if weights is None:
        wt = np.ones_like(w)
    else:
        wt = np.asarray(weights, dtype=np.float64)
        if wt.shape != w.shape or np.any(wt < 0.0) or not np.all(np.isfinite(wt)):
            raise ValueError("fit_kernel: weights must be finite, >= 0, one per frequency")
    K = kernel_response(w, a, b, added_mass_inf)
    if not np.any(np.abs(K) > 0.0):
        raise ValueError("fit_kernel: the kernel is identically zero; nothing to fit")
    if order is not None:
        tried = [order]
    elif orders is not None:
        tried = [int(n) for n in orders]
    else:
        tried = list(range(MIN_ORDER, max_order + 1))
    if not tried or min(tried) < MIN_ORDER:
        raise ValueError(f"fit_kernel: order must be >= {MIN_ORDER} (relative degree 1, zero at 0)")
    n_params = 2 * max(tried) - 1
    if 2 * w.size < n_params:
        raise ValueError(f"fit_kernel: {w.size} frequencies are too few for order {max(tried)}")
    best: KernelFit | None = None
    for n in tried:
        fit = _single_fit(w, K, added_mass_inf, n, wt, tol, passive_floor)
        if fit.meets_tol:
            return fit
        if best is None or fit.fit_error < best.fit_error:
            best = fit
    assert best is not None
    return best


# ------------------------------------------------------------------------------ all kernels
@dataclass(frozen=True)
class RadiationSS:
    """Block state space of the radiation memory of the chosen DOFs.

    ``dx/dt = A x + B v``, ``μ = C x`` with ``v`` the body velocities of ``dofs`` (m/s, rad/s)
    and ``μ`` the memory force (N, N m); the radiation force on the body is
    ``F_rad = -A_∞ v̇ - μ``. Each fitted kernel ``K_ij`` contributes its own states (force row
    ``i``, velocity column ``j``, positions in ``dofs``).

    Parameters
    ----------
    dofs : tuple of int
        0-based WAMIT modes.
    added_mass_inf : (d, d) float
        ``A_∞`` of these DOFs.
    pairs : tuple of (int, int)
        Positions ``(i, j)`` in ``dofs`` of the fitted kernels, one per entry of ``fits``.
    fits : tuple of KernelFit
    skipped : tuple of (int, int)
        Positions of kernels left out as negligible (their ``μ_ij`` is 0).
    """

    dofs: tuple[int, ...]
    added_mass_inf: FloatArray
    pairs: tuple[tuple[int, int], ...]
    fits: tuple[KernelFit, ...]
    skipped: tuple[tuple[int, int], ...] = ()
    A: FloatArray = field(init=False, repr=False)
    B: FloatArray = field(init=False, repr=False)
    C: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        d = len(self.dofs)
        if self.added_mass_inf.shape != (d, d) or not np.all(np.isfinite(self.added_mass_inf)):
            raise ValueError(f"RadiationSS.added_mass_inf must be finite with shape ({d}, {d})")
        if len(self.pairs) != len(self.fits):
            raise ValueError("RadiationSS: one pair per fit")
        every = list(self.pairs) + list(self.skipped)
        if len(set(every)) != len(every):
            raise ValueError("RadiationSS: a kernel is listed twice")
        if any(not (0 <= i < d and 0 <= j < d) for i, j in every):
            raise ValueError(f"RadiationSS: kernel positions must be in 0..{d - 1}")
        n = sum(f.order for f in self.fits)
        A = np.zeros((n, n))
        B = np.zeros((n, d))
        C = np.zeros((d, n))
        k = 0
        for (i, j), fit in zip(self.pairs, self.fits, strict=True):
            a, b, c, _ = fit.state_space()
            sl = slice(k, k + fit.order)
            A[sl, sl] = a
            B[sl, j] = b[:, 0]
            C[i, sl] = c[0]
            k += fit.order
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "B", B)
        object.__setattr__(self, "C", C)

    @property
    def n_states(self) -> int:
        """Total number of radiation states."""
        return int(self.A.shape[0])

    def derivative(self, x: FloatArray, velocity: FloatArray) -> FloatArray:
        """``dx/dt = A x + B v`` (v in m/s, rad/s, ordered as ``dofs``)."""
        return np.asarray(self.A @ x + self.B @ velocity, dtype=np.float64)

    def memory_force(self, x: FloatArray) -> FloatArray:
        """``μ = C x`` (N, N m); the force on the body is ``-μ``."""
        return np.asarray(self.C @ x, dtype=np.float64)

    def frequency_response(self, omega_rad_s: FloatArray) -> ComplexArray:
        """``K̂(jω) = C (jωI - A)^{-1} B`` as (m, d, d), evaluated kernel by kernel."""
        w = np.atleast_1d(np.asarray(omega_rad_s, dtype=np.float64))
        d = len(self.dofs)
        out = np.zeros((w.size, d, d), dtype=np.complex128)
        for (i, j), fit in zip(self.pairs, self.fits, strict=True):
            out[:, i, j] = fit.response(w)
        return out

    def added_mass(self, omega_rad_s: FloatArray) -> FloatArray:
        """``Â(ω) = A_∞ + Im K̂(jω)/ω`` as (m, d, d)."""
        w = np.atleast_1d(np.asarray(omega_rad_s, dtype=np.float64))
        K = self.frequency_response(w)
        return np.asarray(self.added_mass_inf + K.imag / w[:, None, None], dtype=np.float64)

    def damping(self, omega_rad_s: FloatArray) -> FloatArray:
        """``B̂(ω) = Re K̂(jω)`` as (m, d, d)."""
        return np.asarray(self.frequency_response(omega_rad_s).real, dtype=np.float64)

    def impulse_response(self, dt_s: float, n_steps: int) -> tuple[FloatArray, FloatArray]:
        """``k̂(t) = C exp(A t) B`` at ``t = 0, dt, …`` as ``(t (n_steps,), k (n_steps, d, d))``.

        Exact sampling through ``Φ = exp(A dt)`` (scipy.linalg.expm).
        """
        if not (dt_s > 0.0 and n_steps >= 1):
            raise ValueError("impulse_response: dt_s must be > 0 and n_steps >= 1")
        phi = scipy.linalg.expm(self.A * dt_s)
        X = self.B.copy()
        out = np.empty((n_steps, len(self.dofs), len(self.dofs)))
        for k in range(n_steps):
            out[k] = self.C @ X
            X = phi @ X
        return np.asarray(dt_s * np.arange(n_steps), dtype=np.float64), out

    def passivity_margin(self, omega_rad_s: FloatArray) -> FloatArray:
        """Smallest eigenvalue of the Hermitian part ``(K̂ + K̂^H)/2`` at each ω.

        A passive radiation model has all values ≥ 0 (units of ``B`` mixed across DOFs, so
        compare the sign only).
        """
        K = self.frequency_response(omega_rad_s)
        herm = 0.5 * (K + np.conj(np.swapaxes(K, 1, 2)))
        return np.asarray(np.linalg.eigvalsh(herm)[:, 0], dtype=np.float64)

    def describe(self) -> list[str]:
        """One line per kernel: DOF names, order, errors, passivity (diagonal kernels)."""
        lines = []
        for (i, j), f in zip(self.pairs, self.fits, strict=True):
            name = f"{DOF_NAMES[self.dofs[i]]}-{DOF_NAMES[self.dofs[j]]}"
            passive = f", passive={f.passive}" if i == j else ""
            lines.append(
                f"{name}: order {f.order}, error K {f.error_k:.3%}, A {f.error_added_mass:.3%}, "
                f"B {f.error_damping:.3%}, reflected {f.reflected_poles}{passive}"
            )
        for i, j in self.skipped:
            lines.append(
                f"{DOF_NAMES[self.dofs[i]]}-{DOF_NAMES[self.dofs[j]]}: negligible, skipped"
            )
        return lines

    # -------------------------------------------------------------------------- npz I/O
    def save_npz(self, path: str | Path) -> None:
        """Write plain numeric arrays (no pickles); :meth:`load_npz` rebuilds the object."""
        orders = np.array([f.order for f in self.fits], dtype=np.int64)
        arrays: dict[str, np.ndarray] = {
            "format_version": np.array(NPZ_FORMAT_VERSION),
            "dofs": np.array(self.dofs, dtype=np.int64),
            "added_mass_inf": self.added_mass_inf,
            "pairs": np.array(self.pairs, dtype=np.int64).reshape(-1, 2),
            "skipped": np.array(self.skipped, dtype=np.int64).reshape(-1, 2),
            "orders": orders,
            "numerators": np.concatenate([f.numerator for f in self.fits] or [np.zeros(0)]),
            "denominators": np.concatenate([f.denominator for f in self.fits] or [np.zeros(0)]),
            "fit_scalars": np.array(
                [
                    [
                        f.added_mass_inf,
                        f.error_k,
                        f.error_added_mass,
                        f.error_damping,
                        f.error_rms,
                        f.omega_min_rad_s,
                        f.omega_max_rad_s,
                        f.real_part_min,
                        f.reflected_poles,
                        float(f.meets_tol),
                    ]
                    for f in self.fits
                ]
            ).reshape(-1, 10),
            "A": self.A,
            "B": self.B,
            "C": self.C,
        }
        np.savez_compressed(Path(path), **arrays)  # type: ignore[arg-type]

    @classmethod
    def load_npz(cls, path: str | Path) -> RadiationSS:
        """Read a file written by :meth:`save_npz` (``allow_pickle=False``)."""
        with np.load(Path(path), allow_pickle=False) as z:
            try:
                if int(z["format_version"]) != NPZ_FORMAT_VERSION:
                    raise ValueError(f"{path}: unsupported format_version")
                orders = [int(o) for o in z["orders"]]
                nums, dens, scal = z["numerators"], z["denominators"], z["fit_scalars"]
                fits = []
                a = b = 0
                for k, n in enumerate(orders):
                    s = scal[k]
                    fits.append(
                        KernelFit(
                            numerator=np.asarray(nums[a : a + n], dtype=np.float64),
                            denominator=np.asarray(dens[b : b + n + 1], dtype=np.float64),
                            added_mass_inf=float(s[0]),
                            error_k=float(s[1]),
                            error_added_mass=float(s[2]),
                            error_damping=float(s[3]),
                            error_rms=float(s[4]),
                            omega_min_rad_s=float(s[5]),
                            omega_max_rad_s=float(s[6]),
                            real_part_min=float(s[7]),
                            reflected_poles=int(s[8]),
                            meets_tol=bool(s[9]),
                        )
                    )
                    a += n
                    b += n + 1
                return cls(
                    dofs=tuple(int(d) for d in z["dofs"]),
                    added_mass_inf=np.asarray(z["added_mass_inf"], dtype=np.float64),
                    pairs=tuple((int(i), int(j)) for i, j in z["pairs"]),
                    fits=tuple(fits),
                    skipped=tuple((int(i), int(j)) for i, j in z["skipped"]),
                )
            except KeyError as exc:
                raise ValueError(f"{path}: npz lacks array {exc}") from None


def fit_radiation(
    radiation: RadiationData,
    dofs: Sequence[int] = (0, 2, 4),
    order: int | None = None,
    max_order: int = 8,
    tol: float = 0.02,
    omega_range_rad_s: tuple[float, float] | None = None,
    negligible: float = 1e-3,
    weights: FloatArray | None = None,
    passive_floor: float | None = None,
    diagonal_max_order: int | None = None,
) -> RadiationSS:
    """Fit every kernel ``K_ij`` of ``dofs`` and stack them into one :class:`RadiationSS`.

    Parameters
    ----------
    radiation : RadiationData
        Dimensional coefficients (e.g. from :func:`plant.hydro.wamit.read_wamit_1`).
    dofs : sequence of int
        0-based WAMIT modes, default ``(0, 2, 4)`` surge, heave, pitch.
    order, max_order, tol, weights
        As in :func:`fit_kernel`, applied to every kernel (``weights`` over the band used).
    passive_floor : float or None
        As in :func:`fit_kernel`, applied to the diagonal kernels.
    diagonal_max_order : int or None
        With ``order`` None: a diagonal kernel ``K_ii`` whose fit misses ``tol`` at
        ``max_order`` is fitted again with orders up to ``diagonal_max_order`` (> ``max_order``;
        for bumpy data such as the surge kernel of a semi-submersible, whose A(ω), B(ω) ripple
        with the column interference). Off-diagonal kernels keep ``max_order``. None: no retry.
    omega_range_rad_s : (lo, hi) or None
        Fit only frequencies in ``[lo, hi]`` (e.g. below the irregular frequencies).
    negligible : float
        Kernel ``(i, j)`` is skipped when ``max|K_ij| < negligible · sqrt(max|K_ii| max|K_jj|)``
        (the geometric mean keeps the test dimensionally consistent across DOF types); it is
        listed in ``RadiationSS.skipped``.
    """
    rad = radiation.select(dofs)
    w = rad.omega_rad_s
    mask = np.ones(w.size, dtype=bool)
    if omega_range_rad_s is not None:
        lo, hi = omega_range_rad_s
        mask = (w >= lo) & (w <= hi)
        if np.count_nonzero(mask) < 4:
            raise ValueError(f"fit_radiation: fewer than 4 frequencies in {omega_range_rad_s}")
    w = w[mask]
    d = len(rad.dofs)
    K = np.stack(
        [
            np.stack(
                [
                    kernel_response(
                        w,
                        rad.added_mass[mask, i, j],
                        rad.damping[mask, i, j],
                        float(rad.added_mass_inf[i, j]),
                    )
                    for j in range(d)
                ],
                axis=-1,
            )
            for i in range(d)
        ],
        axis=-2,
    )
    peak = np.max(np.abs(K), axis=0)
    pairs: list[tuple[int, int]] = []
    fits: list[KernelFit] = []
    skipped: list[tuple[int, int]] = []
    for i in range(d):
        for j in range(d):
            scale = np.sqrt(peak[i, i] * peak[j, j])
            if peak[i, j] == 0.0 or peak[i, j] < negligible * scale:
                skipped.append((i, j))
                continue
            args = (
                w,
                rad.added_mass[mask, i, j],
                rad.damping[mask, i, j],
                float(rad.added_mass_inf[i, j]),
            )
            floor = passive_floor if i == j else None
            fit = fit_kernel(
                *args,
                order=order,
                max_order=max_order,
                tol=tol,
                weights=weights,
                passive_floor=floor,
            )
            if (
                order is None
                and i == j
                and not fit.meets_tol
                and diagonal_max_order is not None
                and diagonal_max_order > max_order
            ):
                higher = fit_kernel(
                    *args,
                    order=None,
                    orders=range(max_order + 1, diagonal_max_order + 1),
                    tol=tol,
                    weights=weights,
                    passive_floor=floor,
                )
                if higher.fit_error < fit.fit_error:
                    fit = higher
            fits.append(fit)
            pairs.append((i, j))
    return RadiationSS(
        dofs=rad.dofs,
        added_mass_inf=rad.added_mass_inf.copy(),
        pairs=tuple(pairs),
        fits=tuple(fits),
        skipped=tuple(skipped),
    )


# ------------------------------------------------------------------ reduced, shipped model
RADIATION_NPZ_FORMAT_VERSION = 1


def _real_modal_form(
    a: FloatArray, b: FloatArray, c: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Similar realisation with A in real block-diagonal (modal) form.

    The stacked Perez-Fossen fits are controllable canonical forms whose coefficients span many
    decades; the Lyapunov equations of balanced truncation are well conditioned only in a
    modal basis. With ``A V = V Λ`` (distinct poles), a complex pair ``λ = σ ± jω`` with
    eigenvector ``v`` contributes the real columns ``(Re v, Im v)`` of ``T``, and
    ``(T⁻¹ A T, T⁻¹ B, C T)`` is the same system.
    """
    lam, vec = np.linalg.eig(a)
    cols: list[FloatArray] = []
    done = np.zeros(lam.size, dtype=bool)
    for k in np.argsort(-lam.real, kind="stable"):
        if done[k]:
            continue
        done[k] = True
        v = vec[:, k]
        if abs(lam[k].imag) > 1e-12 * max(abs(lam[k]), 1.0):
            mate = int(np.argmin(np.where(done, np.inf, np.abs(lam - np.conj(lam[k])))))
            done[mate] = True
            cols += [v.real, v.imag]
        else:
            cols.append(v.real)
    t = np.column_stack(cols)
    ti = np.linalg.inv(t)
    return ti @ a @ t, ti @ b, c @ t


def balanced_truncation(
    a: FloatArray, b: FloatArray, c: FloatArray, order: int
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Reduce a stable state space ``(A, B, C)`` to ``order`` states (square-root method).

    Gramians ``A W_c + W_c Aᵀ + B Bᵀ = 0`` and ``Aᵀ W_o + W_o A + Cᵀ C = 0`` with factors
    ``W_c = L_c L_cᵀ``, ``W_o = L_o L_oᵀ``; ``L_oᵀ L_c = U Σ Vᵀ`` gives the Hankel singular
    values ``σ_i`` (diagonal of Σ) and the balancing projections ``T = L_c V_r Σ_r^{-1/2}``,
    ``T_i = Σ_r^{-1/2} U_rᵀ L_oᵀ`` (first ``r`` columns). The reduced ``(T_i A T, T_i B, C T)``
    is stable and ``‖G − G_r‖_∞ ≤ 2 Σ_{i>r} σ_i`` (Moore 1981; Antoulas 2005, ch. 7).

    Parameters
    ----------
    a, b, c : arrays (n, n), (n, m), (p, n)
        Stable system (units: 1/s, state per input, output per state).
    order : int
        Reduced order r, 1 <= r <= n.

    Returns
    -------
    a_r, b_r, c_r : arrays (r, r), (r, m), (p, r)
    hankel_singular_values : array (n,)
        All σ_i, descending (units of the output per input).
    """
    n = a.shape[0]
    if not 1 <= order <= n:
        raise ValueError(f"balanced_truncation: order must be in 1..{n}, got {order}")
    am, bm, cm = _real_modal_form(a, b, c)
    wc = scipy.linalg.solve_continuous_lyapunov(am, -bm @ bm.T)
    wo = scipy.linalg.solve_continuous_lyapunov(am.T, -cm.T @ cm)

    def factor(w: FloatArray) -> FloatArray:
        s, u = np.linalg.eigh(0.5 * (w + w.T))
        return np.asarray(u * np.sqrt(np.clip(s, 0.0, None)), dtype=np.float64)

    lc, lo = factor(wc), factor(wo)
    u, hsv, vt = np.linalg.svd(lo.T @ lc)
    r = order
    s_half = 1.0 / np.sqrt(hsv[:r])
    t = lc @ vt[:r].T * s_half
    ti = (u[:, :r] * s_half).T @ lo.T
    return ti @ am @ t, ti @ bm, cm @ t, np.asarray(hsv, dtype=np.float64)


def _kernel_errors(
    a: FloatArray,
    b: FloatArray,
    c: FloatArray,
    omega: FloatArray,
    added_mass: FloatArray,
    damping: FloatArray,
    added_mass_inf: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Relative errors (d, d) of ``Â(ω)`` and ``B̂(ω)`` of ``C (jωI − A)⁻¹ B`` (as KernelFit)."""
    n = a.shape[0]
    eye = np.eye(n)
    k_hat = np.stack([c @ np.linalg.solve(1j * w * eye - a, b) for w in omega])
    a_hat = added_mass_inf + k_hat.imag / omega[:, None, None]
    da = added_mass - added_mass_inf
    err_a = np.max(np.abs(a_hat - added_mass), axis=0) / np.maximum(
        np.max(np.abs(da), axis=0), 1e-300
    )
    err_b = np.max(np.abs(k_hat.real - damping), axis=0) / np.maximum(
        np.max(np.abs(damping), axis=0), 1e-300
    )
    return np.asarray(err_a, dtype=np.float64), np.asarray(err_b, dtype=np.float64)


@dataclass(frozen=True)
class RadiationModel:
    """The radiation memory a preset ships: one (reduced) state space for all DOFs.

    ``dξ/dt = A ξ + B v``, ``μ = C ξ`` (v: body velocities of ``dofs`` in m/s, rad/s; μ: memory
    force in N, N m; the force on the body is −μ). Built once, offline, by
    :func:`fit_reduced_radiation` and stored with :meth:`save_npz`, so loading a preset does no
    fitting.

    Parameters
    ----------
    dofs : tuple of int
        0-based WAMIT modes.
    A, B, C : arrays (n, n), (n, d), (d, n)
        State space (1/s; state per m/s; N or N m per state).
    error_added_mass, error_damping : arrays (d, d)
        ``max_ω |Â − A| / max_ω |A − A_∞|`` and ``max_ω |B̂ − B| / max_ω |B|`` of every kernel
        against the hydrodynamic data over ``omega_range_rad_s``.
    omega_range_rad_s : (float, float)
        Band of the fit and of the errors (rad/s).
    fitted_order : int
        Number of states of the stacked per-kernel fits before reduction.
    hankel_singular_values : array (fitted_order,)
        Of the scaled stacked system (dimensionless, see :func:`fit_reduced_radiation`).
    source : str
        Where the hydrodynamic data came from and how the model was made.
    """

    dofs: tuple[int, ...]
    A: FloatArray
    B: FloatArray
    C: FloatArray
    error_added_mass: FloatArray
    error_damping: FloatArray
    omega_range_rad_s: tuple[float, float]
    fitted_order: int
    hankel_singular_values: FloatArray
    source: str

    def __post_init__(self) -> None:
        d = len(self.dofs)
        n = self.A.shape[0] if self.A.ndim == 2 else -1
        for name, arr, shape in (
            ("A", self.A, (n, n)),
            ("B", self.B, (n, d)),
            ("C", self.C, (d, n)),
            ("error_added_mass", self.error_added_mass, (d, d)),
            ("error_damping", self.error_damping, (d, d)),
        ):
            if arr.shape != shape or not np.all(np.isfinite(arr)):
                raise ValueError(f"RadiationModel.{name}: expected finite shape {shape}")
        if n and np.max(np.linalg.eigvals(self.A).real) >= 0.0:
            raise ValueError("RadiationModel.A: expected stable poles (Re < 0 1/s)")

    @property
    def order(self) -> int:
        """Number of states."""
        return int(self.A.shape[0])

    def frequency_response(self, omega_rad_s: FloatArray) -> ComplexArray:
        """``K̂(jω) = C (jωI − A)⁻¹ B`` as (m, d, d) (N s/m, N s, N m s/rad)."""
        w = np.atleast_1d(np.asarray(omega_rad_s, dtype=np.float64))
        eye = np.eye(self.order)
        return np.stack([self.C @ np.linalg.solve(1j * x * eye - self.A, self.B) for x in w])

    def describe(self) -> list[str]:
        """One line per diagonal kernel (errors) and the orders."""
        lines = [
            f"order {self.order} (stacked fits {self.fitted_order}), band "
            f"{self.omega_range_rad_s[0]:g}..{self.omega_range_rad_s[1]:g} rad/s"
        ]
        for i, dof in enumerate(self.dofs):
            lines.append(
                f"{DOF_NAMES[dof]}: error A {self.error_added_mass[i, i]:.3%}, "
                f"B {self.error_damping[i, i]:.3%}"
            )
        return lines

    def describe_pairs(self) -> list[str]:
        """One line per coupling kernel ``(i, j)``, ``i < j`` (errors of ``Â``, ``B̂``).

        The error of ``K_ji`` is listed with ``K_ij`` when it is larger (the larger of the two).
        """
        lines = []
        for i, a in enumerate(self.dofs):
            for j in range(i + 1, len(self.dofs)):
                ea = max(self.error_added_mass[i, j], self.error_added_mass[j, i])
                eb = max(self.error_damping[i, j], self.error_damping[j, i])
                lines.append(
                    f"{DOF_NAMES[a]}-{DOF_NAMES[self.dofs[j]]}: error A {ea:.3%}, B {eb:.3%}"
                )
        return lines

    def save_npz(self, path: str | Path) -> None:
        """Write plain arrays (no pickles); :meth:`load_npz` reads them back."""
        np.savez_compressed(
            Path(path),
            format_version=np.array(RADIATION_NPZ_FORMAT_VERSION),
            dofs=np.array(self.dofs, dtype=np.int64),
            A=self.A,
            B=self.B,
            C=self.C,
            error_added_mass=self.error_added_mass,
            error_damping=self.error_damping,
            omega_range_rad_s=np.array(self.omega_range_rad_s, dtype=np.float64),
            fitted_order=np.array(self.fitted_order),
            hankel_singular_values=self.hankel_singular_values,
            source=np.array(self.source),
        )

    @classmethod
    def load_npz(cls, path: str | Path) -> RadiationModel:
        """Read a file written by :meth:`save_npz` (``allow_pickle=False``)."""
        with np.load(Path(path), allow_pickle=False) as z:
            try:
                if int(z["format_version"]) != RADIATION_NPZ_FORMAT_VERSION:
                    raise ValueError(f"{path}: unsupported format_version")
                lo, hi = (float(v) for v in z["omega_range_rad_s"])
                return cls(
                    dofs=tuple(int(d) for d in z["dofs"]),
                    A=np.asarray(z["A"], dtype=np.float64),
                    B=np.asarray(z["B"], dtype=np.float64),
                    C=np.asarray(z["C"], dtype=np.float64),
                    error_added_mass=np.asarray(z["error_added_mass"], dtype=np.float64),
                    error_damping=np.asarray(z["error_damping"], dtype=np.float64),
                    omega_range_rad_s=(lo, hi),
                    fitted_order=int(z["fitted_order"]),
                    hankel_singular_values=np.asarray(
                        z["hankel_singular_values"], dtype=np.float64
                    ),
                    source=str(z["source"]),
                )
            except KeyError as exc:
                raise ValueError(f"{path}: npz lacks array {exc}") from None


# ---------------------------------------------------------------- passivity enforcement
@dataclass(frozen=True)
class PassivityReport:
    """What :func:`enforce_passivity` did (per DOF of the model, in ``dofs`` order).

    Attributes
    ----------
    real_part_min_before, real_part_min_after : arrays (d,)
        ``min_ω Re K̂_ii(jω) / max_ω |K_ii|`` on the dense check grid (dimensionless).
    floor_ratio_min_after : arrays (d,)
        ``min Re K̂_ii(ω_k) / B_ii(ω_k)`` over the data frequencies where ``B_ii > 0``.
    change_rms : float
        RMS over the band of ``|ΔK̂_ij| / √(p_i p_j)`` (response change, relative to the
        kernel peaks ``p_i = max|K_ii|``).
    constraints : int
        Number of constraint points that ended up in the final least-squares problem.
    """

    real_part_min_before: FloatArray
    real_part_min_after: FloatArray
    floor_ratio_min_after: FloatArray
    change_rms: float
    constraints: int


def _lsi(m: FloatArray, r: FloatArray, g: FloatArray, h: FloatArray) -> tuple[FloatArray, bool]:
    """``min ‖M c − r‖`` subject to ``G c ≥ h`` (Lawson & Hanson 1974, ch. 23: LSI → LDP → NNLS).

    With ``M = Q R`` (R invertible), ``z = R c − Qᵀ r``: ``min ‖z‖`` s.t. ``E z ≥ f``,
    ``E = G R⁻¹``, ``f = h − E Qᵀ r``; the least-distance problem is solved through the
    non-negative least squares ``min ‖[Eᵀ; fᵀ] u − e‖, u ≥ 0`` (``e`` the last unit vector):
    ``z = −ρ_{1..n} / ρ_{n+1}`` with ``ρ`` its residual. Returns ``(c, feasible)``.
    """
    from scipy.optimize import nnls  # noqa: PLC0415  offline only

    q, rr = np.linalg.qr(m)
    d = q.T @ r
    e = np.linalg.solve(rr.T, g.T).T  # G R⁻¹
    fvec = h - e @ d
    n = m.shape[1]
    big = np.vstack([e.T, fvec[None, :]])
    rhs = np.zeros(n + 1)
    rhs[-1] = 1.0
    u, _ = nnls(big, rhs, maxiter=50 * big.shape[1])
    rho = big @ u - rhs
    if abs(rho[-1]) < 1e-12:
        return np.linalg.solve(rr, d), False
    z = -rho[:n] / rho[-1]
    return np.asarray(np.linalg.solve(rr, z + d), dtype=np.float64), True


def enforce_passivity(
    a: FloatArray,
    b: FloatArray,
    c: FloatArray,
    omega: FloatArray,
    damping: FloatArray,
    peaks: FloatArray,
    floor: float = 0.5,
    grid: tuple[float, float, int] = (1e-4, 1e3, 1200),
    max_rounds: int = 8,
) -> tuple[FloatArray, PassivityReport]:
    """Correct ``C`` so that every diagonal kernel is passive, changing the response least.

    The poles (``A``) and input map (``B``) are kept; the response ``K̂(jω) = C G(jω)``,
    ``G = (jωI − A)⁻¹ B``, is linear in ``C`` and each output row ``i`` only depends on row
    ``c_i`` of ``C``. Per row, a least-squares problem with linear inequality constraints
    (solved exactly by :func:`_lsi`):

    .. math::

        \\min_{Δc_i} \\sum_j \\sum_k \\frac{|Δc_i G_{·j}(jω_k)|^2}{p_i p_j}
        \\quad\\text{s.t.}\\quad
        \\operatorname{Re} (c_i + Δc_i) G_{·i}(jω) \\ge
        \\begin{cases} β B_{ii}(ω) & ω \\text{ a data frequency} \\\\
        0 & ω \\text{ on a log grid } 10^{-4}..10^{3} \\text{ rad/s} \\end{cases}

    and ``−(c_i + Δc_i) A B_{·i} ≥ 0`` (the sign of ``Re K̂_ii ≈ −C A B / ω²`` as ω → ∞),
    i.e. the smallest change of all kernels of row ``i`` over the data band ``ω_k`` (relative
    to the kernel peaks ``p``) that makes the diagonal kernel passive (``Re K̂_ii ≥ 0``,
    Ogilvie: ``B_ii(ω) ≥ 0`` for a body radiating energy) and keeps at least the fraction
    β (``floor``) of the data's own damping ``B_ii(ω_k)`` at the data frequencies, where the
    platform's natural frequencies lie. The floor matters where ``B_ii`` is tiny next to its
    peak (the heave resonance of a semi-submersible: ``B_33`` there is 0.14 % of its peak,
    well inside a 1 % fit error, and a sign flip makes the heave mode unstable). The
    constraints are imposed where they are violated on ``grid`` or on a 16x denser check
    grid, and re-checked (``max_rounds``); the realisation stays stable (``A``
    is unchanged).

    Parameters
    ----------
    a, b, c : arrays (n, n), (n, d), (d, n)
        Stable radiation state space (1/s; state per m/s; N per state).
    omega : (m,) array
        Data frequencies of the band (rad/s).
    damping : (m, d, d) array
        ``B(ω)`` of the data (N s/m, N s, N m s/rad).
    peaks : (d,) array
        ``p_i = max_ω |K_ii(jω)|`` (units of ``B_ii``).
    floor : float
        β in [0, 1).
    grid : (lo rad/s, hi rad/s, points)
        Log grid of the passivity constraint outside the data.
    max_rounds : int
        Constraint-refinement rounds.

    Returns
    -------
    c_new : array (d, n)
    report : PassivityReport
    """
    if not 0.0 <= floor < 1.0:
        raise ValueError(f"enforce_passivity: floor must be in [0, 1), got {floor}")
    n, d = b.shape
    eye = np.eye(n)

    def transfer(w: FloatArray) -> ComplexArray:
        return np.stack([np.linalg.solve(1j * x * eye - a, b) for x in w])  # (m, n, d)

    g_band = transfer(omega)
    lo, hi, npts = grid
    check = np.logspace(np.log10(lo), np.log10(hi), 16 * npts)
    g_check = transfer(check)
    g_grid = g_check[::16]
    cab = -(a @ b)  # (n, d): −A B, so −c A b_i = c · cab[:, i]
    c_new = c.copy()
    before = np.zeros(d)
    after = np.zeros(d)
    ratio = np.zeros(d)
    used = 0
    for i in range(d):
        before[i] = float(np.min((g_check[:, :, i] @ c[i]).real)) / peaks[i]
        # Objective: response change of row i over the band, all columns, scaled.
        # A small ridge on Δc (scaled by the column norms, 1e-6) keeps it well conditioned.
        mc = np.vstack([g_band[:, :, j] / np.sqrt(peaks[i] * peaks[j]) for j in range(d)])
        m_real = np.vstack([mc.real, mc.imag])
        m_real = np.vstack([m_real, 1e-6 * np.diag(np.linalg.norm(m_real, axis=0))])
        rhs = np.zeros(m_real.shape[0])
        # Candidate constraint rows: data frequencies (floor), log grid (0), asymptote (0).
        b_ii = damping[:, i, i]
        rows = np.vstack([g_band[:, :, i].real, g_grid[:, :, i].real, cab[:, i][None, :]])
        lower = np.concatenate([floor * np.maximum(b_ii, 0.0), np.zeros(len(g_grid) + 1)])
        scale = peaks[i]
        active = np.zeros(rows.shape[0], dtype=bool)
        ci = c[i].copy()
        for _ in range(max_rounds):
            viol = rows @ ci < lower - PASSIVITY_SLACK * scale
            dense_bad = float(np.min((g_check[:, :, i] @ ci).real)) < -PASSIVITY_SLACK * scale
            if not viol.any() and not dense_bad:
                break
            if dense_bad:
                k = int(np.argmin((g_check[:, :, i] @ ci).real))
                rows = np.vstack([rows, g_check[k, :, i].real[None, :]])
                lower = np.concatenate([lower, [0.0]])
                active = np.concatenate([active, [False]])
                viol = np.concatenate([viol, [True]])
            active |= viol
            gmat = rows[active] / scale
            target = lower[active] / scale
            # Unknown Δc (scaled by the kernel peak for conditioning): c = c_i + Δc.
            dc, ok = _lsi(m_real, rhs, gmat, target - gmat @ c[i])
            if not ok:
                raise ValueError(f"enforce_passivity: constraints of DOF {i} are infeasible")
            ci = c[i] + dc
        c_new[i] = ci
        used += int(np.count_nonzero(active))
        after[i] = float(np.min((g_check[:, :, i] @ ci).real)) / peaks[i]
        pos = b_ii > 0.0
        ratio[i] = float(np.min((g_band[pos, :, i] @ ci).real / b_ii[pos])) if pos.any() else 0.0
    dk = np.einsum("in,mnj->mij", c_new - c, g_band)
    norm = np.sqrt(np.outer(peaks, peaks))
    change = float(np.sqrt(np.mean(np.abs(dk / norm) ** 2)))
    return c_new, PassivityReport(before, after, ratio, change, used)


def fit_reduced_radiation(
    radiation: RadiationData,
    dofs: Sequence[int] = (0, 2, 4),
    max_order: int = 10,
    tol: float = 0.02,
    omega_range_rad_s: tuple[float, float] | None = None,
    checked_dofs: Sequence[int] = (2, 4),
    source: str = "",
    passive_floor: float | None = 0.5,
    diagonal_max_order: int | None = 30,
    check_all_diagonal: bool = True,
) -> RadiationModel:
    """Fit every kernel (:func:`fit_radiation`), stack, and reduce by balanced truncation.

    The kernel fits use least-squares weights 1/ω: the platform's natural frequencies lie low in
    the band, where B(ω) is small and an unweighted fit can turn its sign (negative damping of
    the heave and pitch modes). With ``passive_floor`` β (default 0.5) the diagonal kernel
    fits are constrained to ``Re K̂_ii ≥ β B_ii`` at the data and ``≥ 0`` everywhere
    (:func:`fit_kernel`), and after the reduction :func:`enforce_passivity` restores that
    by the smallest correction of ``C`` (balanced truncation does not preserve passivity);
    if the correction pushes the errors over the limit, the next order is tried.

    The stacked system is scaled to unit kernel peaks, ``K'_ij = K_ij / √(p_i p_j)`` with
    ``p_i = max_ω |K_ii|`` (``B' = B P^{-1/2}``, ``C' = P^{-1/2} C``), so that the Hankel
    singular values weigh all DOFs alike; it is reduced by :func:`balanced_truncation` to the
    smallest order r whose diagonal-kernel errors of ``Â`` and ``B̂`` for ``checked_dofs`` (with
    ``check_all_diagonal``, the default: every DOF) stay within
    ``max(tol, error of the unreduced stack)`` over the band, then scaled back.

    The result is stable by construction. Balanced truncation of a stable system is stable in
    exact arithmetic, but the stacks of many fits whose Hankel singular values span many
    decades can come out of it with poles in the right half plane at every order. When no
    truncation is both stable and within the errors, a second pass stabilises each order in
    turn: the truncation's poles are put in real modal form with every unstable pole
    reflected (``σ ± jω`` → ``−max(σ, 10⁻³ |λ|) ± jω``) and its residues ``C`` refitted by
    weighted linear least squares to the kernels, constrained to ``K̂(0) = 0``; the smallest
    order within the errors is kept (the ``source`` says "fit: the order-r truncation
    stabilised (n unstable poles reflected, residues refitted)"). Failing that, the unreduced
    stack is shipped (its poles are the kernel fits' own, reflected when fitted; "fit:
    unreduced"). What the fit chose is reported per DOF and per DOF pair
    (:meth:`RadiationModel.describe`, :meth:`RadiationModel.describe_pairs`).

    A diagonal kernel that misses ``tol`` at ``max_order`` is fitted with orders up to
    ``diagonal_max_order`` (:func:`fit_radiation`). That is what the surge kernel of the
    VolturnUS-S semi-submersible needs: its A(ω) and B(ω) ripple every ~0.1 rad/s (waves
    reflected between the columns), which order 12 follows only to about 8 %; order 16-20
    reaches 1-2 %. Every extra state costs plant step time (:func:`plant.platform.step_floating`).

    Parameters
    ----------
    radiation : RadiationData
    dofs : sequence of int
        WAMIT modes of the model (default surge, heave, pitch).
    max_order, tol, omega_range_rad_s
        As in :func:`fit_radiation`.
    checked_dofs : sequence of int
        WAMIT modes whose errors decide the order (default heave and pitch); with
        ``check_all_diagonal`` every DOF of ``dofs`` is held as well.
    source : str
        Provenance text stored with the model.
    passive_floor : float or None
        β of :func:`enforce_passivity`; None: no passivity enforcement (the former method).
    diagonal_max_order : int or None
        Highest order of a diagonal kernel fit (:func:`fit_radiation`); None: ``max_order``.
    check_all_diagonal : bool
        Hold every diagonal kernel, not only ``checked_dofs``, to
        ``max(tol, error of the unreduced stack)`` when choosing the reduced order.

    Returns
    -------
    RadiationModel
    """
    rad = radiation.select(dofs)
    w = rad.omega_rad_s
    if omega_range_rad_s is not None:
        keep = (w >= omega_range_rad_s[0]) & (w <= omega_range_rad_s[1])
    else:
        keep = np.ones(w.size, dtype=bool)
    w = w[keep]
    ss = fit_radiation(
        radiation,
        dofs=dofs,
        max_order=max_order,
        tol=tol,
        omega_range_rad_s=omega_range_rad_s,
        weights=1.0 / w,
        passive_floor=passive_floor,
        diagonal_max_order=diagonal_max_order,
    )
    am, bd, a_inf = rad.added_mass[keep], rad.damping[keep], rad.added_mass_inf
    k = kernel_response
    peak = np.array(
        [
            np.max(np.abs(k(w, am[:, i, i], bd[:, i, i], float(a_inf[i, i]))))
            for i in range(len(dofs))
        ]
    )
    root = np.sqrt(peak)
    b_s = ss.B / root
    c_s = ss.C / root[:, None]
    held = tuple(rad.dofs) if check_all_diagonal else tuple(checked_dofs)
    idx = [list(rad.dofs).index(d) for d in held]

    def errors(a: FloatArray, b: FloatArray, c: FloatArray) -> tuple[FloatArray, FloatArray]:
        return _kernel_errors(a, b * root, c * root[:, None], w, am, bd, a_inf)

    ea_full, eb_full = errors(*_real_modal_form(ss.A, b_s, c_s))
    limit = {i: max(tol, ea_full[i, i], eb_full[i, i]) for i in idx}

    def within(ea: FloatArray, eb: FloatArray) -> bool:
        return all(
            ea[i, i] <= limit[i] * (1 + 1e-9) and eb[i, i] <= limit[i] * (1 + 1e-9) for i in idx
        )

    def passive(a: FloatArray, b: FloatArray, c: FloatArray) -> FloatArray:
        if passive_floor is None:
            return c
        c_p, _ = enforce_passivity(a, b * root, c * root[:, None], w, bd, peak, floor=passive_floor)
        return np.asarray(c_p / root[:, None], dtype=np.float64)

    def accepted(
        a: FloatArray, b: FloatArray, c: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray] | None:
        """``(c, ea, eb)`` of a candidate within the errors before and after passivity."""
        ea, eb = errors(a, b, c)
        if not within(ea, eb):
            return None
        c = passive(a, b, c)
        ea, eb = errors(a, b, c)
        return (c, ea, eb) if within(ea, eb) else None

    n = ss.n_states
    chosen: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray] | None = None
    how = ""
    hsv = np.zeros(0)
    for r in range(1, n + 1):
        a_r, b_r, c_r, hsv = balanced_truncation(ss.A, b_s, c_s, r)
        if np.max(np.linalg.eigvals(a_r).real) >= 0.0:
            continue
        got = accepted(a_r, b_r, c_r)
        if got is None:
            continue
        chosen = (a_r, b_r, *got)
        break
    if chosen is None:
        # Every truncation that met the errors came out unstable (the balancing of a stack of
        # many fits whose Hankel singular values span many decades is ill-conditioned): the
        # truncations are stabilised (unstable poles reflected, residues refitted), and
        # failing that the unreduced stack, stable by construction, is shipped.
        k_s = _scaled_kernels(w, am, bd, a_inf, root)
        for r in range(len(dofs) + 1, n + 1):
            a_r, b_r, _, hsv = balanced_truncation(ss.A, b_s, c_s, r)
            a_m, b_m, flipped = _reflected_modal_form(a_r, b_r)
            c_m = _refit_residues(a_m, b_m, w, k_s)
            got = None if c_m is None else accepted(a_m, b_m, c_m)
            if got is None:
                continue
            chosen = (a_m, b_m, *got)
            how = (
                f"; fit: the order-{r} truncation stabilised ({flipped} unstable poles reflected, "
                "residues refitted)"
            )
            break
    if chosen is None:
        # The modal form when it is numerically the same system (stable, same errors); the
        # stacked canonical forms otherwise (their poles are the fits' own, placed at
        # Re λ <= -10⁻³ |λ|, so rounding cannot move them across the axis).
        a_f, b_f, c_f = _real_modal_form(ss.A, b_s, c_s)
        ea, eb = errors(a_f, b_f, c_f)
        ea_c, eb_c = errors(ss.A, b_s, c_s)
        same = np.allclose(ea, ea_c, rtol=1e-6, atol=1e-9) and np.allclose(
            eb, eb_c, rtol=1e-6, atol=1e-9
        )
        if not (same and np.max(np.linalg.eigvals(a_f).real) < 0.0):
            a_f, b_f, c_f = ss.A, b_s, c_s
        c_f = passive(a_f, b_f, c_f)
        ea, eb = errors(a_f, b_f, c_f)
        chosen = (a_f, b_f, c_f, ea, eb)
        how = "; fit: unreduced (every truncation was unstable)"
    a_r, b_r, c_r, ea, eb = chosen
    return RadiationModel(
        dofs=tuple(rad.dofs),
        A=a_r,
        B=b_r * root,
        C=c_r * root[:, None],
        error_added_mass=ea,
        error_damping=eb,
        omega_range_rad_s=(float(w[0]), float(w[-1])),
        fitted_order=n,
        hankel_singular_values=hsv,
        source=(source or "Perez-Fossen kernel fits, stacked, balanced truncation") + how,
    )


def _scaled_kernels(
    w: FloatArray,
    added_mass: FloatArray,
    damping: FloatArray,
    added_mass_inf: FloatArray,
    root: FloatArray,
) -> ComplexArray:
    """``K_ij(jω) / (r_i r_j)`` (m, d, d): the kernels in the units of the scaled stack."""
    d = root.size
    k = np.empty((w.size, d, d), dtype=np.complex128)
    for i in range(d):
        for j in range(d):
            k[:, i, j] = kernel_response(
                w, added_mass[:, i, j], damping[:, i, j], float(added_mass_inf[i, j])
            ) / (root[i] * root[j])
    return k


def _reflected_modal_form(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray, int]:
    """``(A', B')`` in real modal form with every pole of ``A`` moved into the left half plane.

    A pole ``σ ± jω`` with ``σ ≥ 0`` becomes ``−max(σ, 10⁻³ |λ|) ± jω`` (as the kernel fits
    reflect the roots of ``Q``); each modal state is scaled to a unit row of ``B'`` (the
    residues are refitted afterwards, :func:`_refit_residues`). Returns the number of poles
    moved.
    """
    lam, vec = np.linalg.eig(a)
    cols: list[FloatArray] = []
    blocks: list[FloatArray] = []
    done = np.zeros(lam.size, dtype=bool)
    flipped = 0
    for k in np.argsort(-lam.real, kind="stable"):
        if done[k]:
            continue
        done[k] = True
        v, pole = vec[:, k], lam[k]
        sigma = float(pole.real)
        if sigma >= 0.0:
            sigma = -max(sigma, 1e-3 * abs(pole))
        if abs(pole.imag) > 1e-12 * max(abs(pole), 1.0):
            mate = int(np.argmin(np.where(done, np.inf, np.abs(lam - np.conj(pole)))))
            done[mate] = True
            flipped += 2 if pole.real >= 0.0 else 0
            om = float(pole.imag)
            cols += [v.real, v.imag]
            blocks.append(np.array([[sigma, om], [-om, sigma]]))
        else:
            flipped += 1 if pole.real >= 0.0 else 0
            cols.append(v.real)
            blocks.append(np.array([[sigma]]))
    b_m = np.asarray(np.linalg.solve(np.column_stack(cols), b), dtype=np.float64)
    pos = 0
    for blk in blocks:
        m = blk.shape[0]
        norm = float(np.linalg.norm(b_m[pos : pos + m]))
        if norm > 0.0:
            b_m[pos : pos + m] /= norm
        pos += m
    return np.asarray(scipy.linalg.block_diag(*blocks), dtype=np.float64), b_m, flipped


def _refit_residues(
    a: FloatArray, b: FloatArray, w: FloatArray, kernels: ComplexArray
) -> FloatArray | None:
    """``C`` of ``C (jωI − A)⁻¹ B`` fitted to ``kernels`` (m, d, d) with ``A``, ``B`` fixed.

    Linear least squares per output row with weights 1/ω (as the kernel fits), constrained to
    ``C A⁻¹ B = 0`` so the kernels still vanish at ω = 0 (no static radiation force). None when
    the order leaves no freedom (n ≤ d).
    """
    n, d = b.shape
    if n <= d:
        return None
    basis = scipy.linalg.null_space(np.linalg.solve(a, b).T)  # (n, n − rank)
    if basis.shape[1] == 0:
        return None
    eye = np.eye(n)
    g = np.stack([np.linalg.solve(1j * x * eye - a, b) for x in w])  # (m, n, d)
    weight = (1.0 / w)[:, None]
    rows = np.einsum("mnd,nk->mdk", g, basis) * weight[:, :, None]  # (m, d, k)
    k = basis.shape[1]
    lhs = np.concatenate([rows.real.reshape(-1, k), rows.imag.reshape(-1, k)])
    c = np.empty((d, n))
    for i in range(d):
        rhs = kernels[:, i, :] * weight
        target = np.concatenate([rhs.real.ravel(), rhs.imag.ravel()])
        z, *_ = np.linalg.lstsq(lhs, target, rcond=None)
        c[i] = basis @ z
    return c


def fixed_order_radiation(
    radiation: RadiationData,
    dofs: Sequence[int],
    order: int,
    omega_range_rad_s: tuple[float, float] | None = None,
    source: str = "",
    passive_floor: float | None = 0.5,
) -> RadiationModel:
    """Perez-Fossen fits of one fixed order per kernel, stacked, without reduction.

    For models whose order is prescribed, e.g. the order-4 surge kernel of the casanovas-2014
    TLP buoy (the seed's section 2.2): :func:`fit_radiation` with ``order`` (unweighted least
    squares; diagonal kernels constrained to ``Re K̂_ii ≥ β B_ii`` at the data and ``≥ 0``
    everywhere with ``passive_floor`` β), realised as one :class:`RadiationModel` whose errors
    ``max_ω |Â − A| / max_ω |A − A_∞|`` and ``max_ω |B̂ − B| / max_ω |B|`` are those over the
    fitted band.

    Parameters
    ----------
    radiation : RadiationData
    dofs : sequence of int
        WAMIT modes (e.g. ``(0,)`` for surge only).
    order : int
        States per kernel (≥ 2).
    omega_range_rad_s : (lo, hi) or None
        Band of the fit (rad/s); None: all frequencies.
    source : str
        Provenance text stored with the model.
    passive_floor : float or None
        β as in :func:`fit_kernel`.

    Returns
    -------
    RadiationModel
    """
    rad = radiation.select(dofs)
    w = rad.omega_rad_s
    keep = np.ones(w.size, dtype=bool)
    if omega_range_rad_s is not None:
        keep = (w >= omega_range_rad_s[0]) & (w <= omega_range_rad_s[1])
    ss = fit_radiation(
        radiation,
        dofs=dofs,
        order=order,
        omega_range_rad_s=omega_range_rad_s,
        passive_floor=passive_floor,
    )
    a, b, c = _real_modal_form(ss.A, ss.B, ss.C)
    ea, eb = _kernel_errors(
        a, b, c, w[keep], rad.added_mass[keep], rad.damping[keep], rad.added_mass_inf
    )
    _, _, _, hsv = balanced_truncation(a, b, c, a.shape[0])
    return RadiationModel(
        dofs=tuple(rad.dofs),
        A=a,
        B=b,
        C=c,
        error_added_mass=ea,
        error_damping=eb,
        omega_range_rad_s=(float(w[keep][0]), float(w[keep][-1])),
        fitted_order=ss.n_states,
        hankel_singular_values=hsv,
        source=source or f"Perez-Fossen kernel fits of order {order}, stacked",
    )
