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
Passivity (``Re K̂(jω) ≥ 0``) is checked on a wide frequency grid and reported, not enforced.

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
    x: FloatArray, H: ComplexArray, w: FloatArray, n: int, iterations: int = 40
) -> tuple[FloatArray, FloatArray, int]:
    """Fit ``H(jx) ≈ P(jx)/Q(jx)``, ``deg P = n-2``, ``Q`` monic of degree ``n``, stable.

    Returns ``(p, q, reflected)`` with coefficients in descending powers.
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
    return p, q, reflected


def _single_fit(
    omega: FloatArray,
    K: ComplexArray,
    added_mass_inf: float,
    n: int,
    weights: FloatArray,
    tol: float,
) -> KernelFit:
    k_max = float(np.max(np.abs(K)))
    alpha = 1.0 / k_max
    w_scale = float(omega[int(np.argmax(np.abs(K)))])
    x = omega / w_scale
    H = alpha * K / (1j * x)
    p, q, reflected = _fit_normalised(x, H, weights, n)
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
    orders = [order] if order is not None else list(range(MIN_ORDER, max_order + 1))
    if not orders or min(orders) < MIN_ORDER:
        raise ValueError(f"fit_kernel: order must be >= {MIN_ORDER} (relative degree 1, zero at 0)")
    n_params = 2 * max(orders) - 1
    if 2 * w.size < n_params:
        raise ValueError(f"fit_kernel: {w.size} frequencies are too few for order {max(orders)}")
    best: KernelFit | None = None
    for n in orders:
        fit = _single_fit(w, K, added_mass_inf, n, wt, tol)
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
            fits.append(
                fit_kernel(
                    w,
                    rad.added_mass[mask, i, j],
                    rad.damping[mask, i, j],
                    float(rad.added_mass_inf[i, j]),
                    order=order,
                    max_order=max_order,
                    tol=tol,
                    weights=weights,
                )
            )
            pairs.append((i, j))
    return RadiationSS(
        dofs=rad.dofs,
        added_mass_inf=rad.added_mass_inf.copy(),
        pairs=tuple(pairs),
        fits=tuple(fits),
        skipped=tuple(skipped),
    )
