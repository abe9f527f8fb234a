"""IEC 61400-1 (ed. 3) turbulence and gust models for a rotor-effective hub-height wind.

Pure functions on numpy arrays; the frozen wind specs that use them (``TurbulentWind``,
``GustWind``) live in :mod:`plant.wind`, which calls :func:`synthesize_turbulence` once, when a
spec is built, and afterwards only looks samples up.

Models
------
Normal turbulence model (NTM), IEC 61400-1 ed. 3 §6.3.1.3::

    σ₁ = I_ref (0.75 V_hub + 5.6)            [m/s],  I_ref = 0.18 / 0.16 / 0.14 / 0.12
                                                      for classes A+ / A / B / C.

Kaimal spectrum of the longitudinal component, IEC 61400-1 ed. 3 annex B (one-sided, in Hz)::

    S_u(f) = 4 σ₁² (L_u / V_hub) / (1 + 6 f L_u / V_hub)^(5/3)   [m² s⁻²/Hz],
    L_u = 8.1 Λ₁,   Λ₁ = 0.7 min(z_hub, 60 m).

Rotor averaging. The seeds do not give a rotor filter (christiansen-2013 models the turbulence
as a first-order process ``v̇_t = -a(v_m) v_t + n₁`` without a spatial model), so this module uses
the IEC exponential coherence of annex B,

    Coh(r, f) = exp(-12 √((f r / V_hub)² + (0.12 r / L_c)²)),   L_c = 8.1 Λ₁,

and defines the rotor-effective wind as the mean of u over the rotor disc. Under frozen
turbulence the cross-spectrum of two points a distance r apart is Coh(r, f) S_u(f), so the
spectrum of the disc average is

    S_eff(f) = S_u(f) ∫₀^{2R} Coh(r, f) p_R(r) dr,

with p_R the density of the distance between two independent uniform points in a disc of
radius R (a textbook result of geometric probability):

    p_R(r) = (4 r / (π R²)) [arccos(s) - s √(1 - s²)],   s = r / (2R),  0 ≤ r ≤ 2R.

The integral is done by Gauss-Legendre quadrature (64 nodes; the integrand is smooth, p_R
vanishes like (1 - s)^(3/2) at r = 2R). R = 0 gives the point (hub) wind, S_eff = S_u. Note
that the IEC coherence is below one even at f = 0 (the 0.12 r/L_c term), so a 126 m rotor
sees roughly 20 % less low-frequency variance than a point.

Synthesis: one period of a random-phase Fourier series with deterministic amplitudes
``a_k = √(2 S_eff(f_k) Δf)`` at ``f_k = k/(N Δt)``, k = 1 … N/2, and phases uniform in
[0, 2π) from ``numpy.random.default_rng(seed)``, evaluated by one inverse real FFT. The series
is periodic with period N Δt ≥ the requested duration; its mean is exactly zero over a period
and its variance is exactly Σ a_k²/2 (less the Nyquist term), i.e. the spectrum integrated over
[1/(N Δt), 1/(2 Δt)].

Extreme operating gust (EOG), IEC 61400-1 ed. 3 §6.3.2.2 (eqs. 16-17)::

    V_gust = min(1.35 (V_e1 - V_hub), 3.3 σ₁ / (1 + 0.1 D / Λ₁)),
    V(t)   = V_hub - 0.37 V_gust sin(3π t/T) (1 - cos(2π t/T)),   0 ≤ t ≤ T,  T = 10.5 s,
    V_e1   = 0.8 V_e50,  V_e50 = 1.4 V_ref,  V_ref = 50 / 42.5 / 37.5 m/s (classes I / II / III).

The shape g(τ) = sin(3πτ)(1 - cos 2πτ) has its minimum -2 at τ = 1/2 (so V_max = V_hub +
0.74 V_gust at t = T/2) and its maximum 0.72449 at τ ≈ 0.23406 and 0.76594 (the dips).

What is hand-written and why: numpy and scipy provide the FFT, the quadrature nodes and the
random generator, but no IEC 61400-1 model; those are the few formulas above.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = [
    "EOG_PERIOD_S",
    "REFERENCE_INTENSITY",
    "REFERENCE_SPEED_M_S",
    "eog_gust_amplitude",
    "eog_shape",
    "integral_scale_m",
    "kaimal_length_m",
    "kaimal_spectrum",
    "ntm_sigma",
    "rotor_average_factor",
    "synthesize_turbulence",
    "turbulence_fft_length",
]

FloatArray = npt.NDArray[np.float64]

#: I_ref of the IEC 61400-1 ed. 3 turbulence categories (ed. 4 adds A+).
REFERENCE_INTENSITY: dict[str, float] = {"A+": 0.18, "A": 0.16, "B": 0.14, "C": 0.12}
#: V_ref (m/s) of the IEC 61400-1 turbine classes.
REFERENCE_SPEED_M_S: dict[str, float] = {"I": 50.0, "II": 42.5, "III": 37.5}
#: Duration T of the extreme operating gust, s.
EOG_PERIOD_S = 10.5

_QUAD_NODES = 64
_CHUNK = 8192


def _reference_intensity(turbulence_class: str) -> float:
    try:
        return REFERENCE_INTENSITY[turbulence_class]
    except (KeyError, TypeError):
        raise ValueError(
            f"turbulence_class = {turbulence_class!r}: expected one of "
            f"{sorted(REFERENCE_INTENSITY)}"
        ) from None


def ntm_sigma(hub_speed_m_s: float, turbulence_class: str) -> float:
    """Standard deviation of the normal turbulence model, σ₁ = I_ref (0.75 V_hub + 5.6).

    Parameters
    ----------
    hub_speed_m_s : float
        10-minute mean hub-height wind V_hub (m/s).
    turbulence_class : {'A+', 'A', 'B', 'C'}
        IEC turbulence category (I_ref = 0.18, 0.16, 0.14, 0.12).

    Returns
    -------
    float
        σ₁ (m/s).
    """
    return _reference_intensity(turbulence_class) * (0.75 * float(hub_speed_m_s) + 5.6)


def integral_scale_m(hub_height_m: float) -> float:
    """Longitudinal turbulence scale parameter Λ₁ = 0.7 min(z_hub, 60 m), in m."""
    if not (math.isfinite(hub_height_m) and hub_height_m > 0.0):
        raise ValueError(f"hub_height_m = {hub_height_m!r}: expected a finite height > 0 m")
    return 0.7 * min(float(hub_height_m), 60.0)


def kaimal_length_m(hub_height_m: float) -> float:
    """Kaimal integral length of the longitudinal component, L_u = 8.1 Λ₁, in m."""
    return 8.1 * integral_scale_m(hub_height_m)


def kaimal_spectrum(
    frequency_hz: npt.ArrayLike, mean_m_s: float, sigma_m_s: float, hub_height_m: float
) -> FloatArray:
    """One-sided Kaimal spectrum of the longitudinal wind, IEC 61400-1 ed. 3 annex B.

    S_u(f) = 4 σ² (L_u/U) / (1 + 6 f L_u/U)^(5/3), L_u = 8.1 · 0.7 min(z_hub, 60 m); its
    integral over f ∈ [0, ∞) is σ².

    Parameters
    ----------
    frequency_hz : array_like
        Frequencies f (Hz); negative values give 0.
    mean_m_s : float
        Mean wind U (m/s), > 0.
    sigma_m_s : float
        Standard deviation σ (m/s), >= 0.
    hub_height_m : float
        Hub height z_hub (m), > 0.

    Returns
    -------
    ndarray
        S_u(f) in (m/s)²/Hz, same shape as ``frequency_hz``.
    """
    if not (math.isfinite(mean_m_s) and mean_m_s > 0.0):
        raise ValueError(f"mean_m_s = {mean_m_s!r}: expected a finite mean wind > 0 m/s")
    if not (math.isfinite(sigma_m_s) and sigma_m_s >= 0.0):
        raise ValueError(f"sigma_m_s = {sigma_m_s!r}: expected a finite std >= 0 m/s")
    f = np.asarray(frequency_hz, dtype=np.float64)
    tau = kaimal_length_m(hub_height_m) / mean_m_s  # L_u / U, s
    s = 4.0 * sigma_m_s**2 * tau / (1.0 + 6.0 * np.abs(f) * tau) ** (5.0 / 3.0)
    return np.where(f >= 0.0, s, 0.0)


def rotor_average_factor(
    frequency_hz: npt.ArrayLike, mean_m_s: float, rotor_radius_m: float, hub_height_m: float
) -> FloatArray:
    """Ratio S_eff(f)/S_u(f) of the disc-averaged to the point spectrum (IEC coherence).

    F(f) = ∫₀^{2R} exp(-12 √((f r/U)² + (0.12 r/L_c)²)) p_R(r) dr with L_c = 8.1 Λ₁ and p_R
    the distance density of two uniform points in a disc of radius R (module docstring).

    Parameters
    ----------
    frequency_hz : array_like
        Frequencies f (Hz).
    mean_m_s : float
        Mean wind U (m/s), > 0.
    rotor_radius_m : float
        Rotor radius R (m), >= 0; 0 gives F = 1 (point wind).
    hub_height_m : float
        Hub height (m), sets L_c.

    Returns
    -------
    ndarray
        F(f) in (0, 1], same shape as ``frequency_hz``.
    """
    f = np.asarray(frequency_hz, dtype=np.float64)
    if not (math.isfinite(rotor_radius_m) and rotor_radius_m >= 0.0):
        raise ValueError(f"rotor_radius_m = {rotor_radius_m!r}: expected a finite radius >= 0 m")
    if not (math.isfinite(mean_m_s) and mean_m_s > 0.0):
        raise ValueError(f"mean_m_s = {mean_m_s!r}: expected a finite mean wind > 0 m/s")
    if rotor_radius_m == 0.0:
        return np.ones_like(f)
    coherence_length = kaimal_length_m(hub_height_m)
    nodes, weights = np.polynomial.legendre.leggauss(_QUAD_NODES)
    s = 0.5 * (nodes + 1.0)  # r / (2R) in (0, 1)
    r = 2.0 * rotor_radius_m * s
    # p_R(r) dr with dr = R ds_node (the node interval [-1, 1] maps to r ∈ [0, 2R])
    density = (4.0 * r / (math.pi * rotor_radius_m**2)) * (np.arccos(s) - s * np.sqrt(1.0 - s * s))
    w = weights * rotor_radius_m * density
    spatial = (0.12 * r / coherence_length) ** 2
    flat = f.reshape(-1)
    out = np.empty(flat.shape)
    for start in range(0, flat.size, _CHUNK):  # bounded memory: (chunk, nodes) at a time
        fc = flat[start : start + _CHUNK, None]
        out[start : start + _CHUNK] = (
            np.exp(-12.0 * np.sqrt((fc * r / mean_m_s) ** 2 + spatial)) @ w
        )
    result: FloatArray = out.reshape(f.shape)
    return result


def turbulence_fft_length(duration_s: float, dt_s: float) -> int:
    """FFT length N used for a record: the smallest even 5-smooth N with N Δt >= duration."""
    n_min = max(2, math.ceil(duration_s / dt_s - 1e-9))
    n = n_min
    while True:
        m = n
        for p in (2, 3, 5):
            while m % p == 0:
                m //= p
        if m == 1 and n % 2 == 0:
            return n
        n += 1


def synthesize_turbulence(
    mean_m_s: float,
    sigma_m_s: float,
    hub_height_m: float,
    rotor_radius_m: float,
    duration_s: float,
    dt_s: float,
    seed: int,
) -> FloatArray:
    """One period of seeded rotor-effective turbulent wind, sampled every ``dt_s``.

    u_k = U + Σ_{k=1}^{N/2-1} a_k cos(2π f_k t_j + φ_k), a_k = √(2 S_u(f_k) F(f_k) Δf),
    f_k = k Δf, Δf = 1/(N Δt), φ_k ~ U[0, 2π) from ``default_rng(seed)``, computed by one
    inverse real FFT. The Nyquist bin is left empty (its cosine would not be random-phase).

    Parameters
    ----------
    mean_m_s, sigma_m_s : float
        Mean U (m/s, > 0) and point standard deviation σ (m/s) of the Kaimal spectrum.
    hub_height_m, rotor_radius_m : float
        Hub height (m) and rotor radius R (m, 0 for a point wind).
    duration_s, dt_s : float
        Record length (s) and sample step Δt (s); N = :func:`turbulence_fft_length`.
    seed : int
        Seed of the phase generator.

    Returns
    -------
    ndarray, shape (N,)
        Wind speed u(j Δt) (m/s), j = 0 … N-1; periodic with period N Δt. Not clipped.
    """
    n = turbulence_fft_length(duration_s, dt_s)
    df = 1.0 / (n * dt_s)
    k = np.arange(n // 2 + 1)
    f = k * df
    spec = kaimal_spectrum(f, mean_m_s, sigma_m_s, hub_height_m) * rotor_average_factor(
        f, mean_m_s, rotor_radius_m, hub_height_m
    )
    amp = np.sqrt(2.0 * spec * df)
    amp[0] = 0.0
    amp[-1] = 0.0
    phase = np.random.default_rng(seed).uniform(0.0, 2.0 * math.pi, size=k.size)
    # irfft(X)[j] = (1/N) Σ X_k e^{2πi kj/N} (Hermitian) → X_k = (N/2) a_k e^{iφ_k}
    spectrum = 0.5 * n * amp * np.exp(1j * phase)
    out: FloatArray = mean_m_s + np.fft.irfft(spectrum, n)
    return out


def eog_gust_amplitude(
    hub_speed_m_s: float,
    turbine_class: str,
    turbulence_class: str,
    rotor_diameter_m: float,
    hub_height_m: float,
) -> float:
    """EOG magnitude V_gust = min(1.35 (V_e1 - V_hub), 3.3 σ₁ / (1 + 0.1 D/Λ₁)), in m/s.

    V_e1 = 0.8 · 1.4 V_ref (one-year extreme at hub height), σ₁ from :func:`ntm_sigma`.

    Parameters
    ----------
    hub_speed_m_s : float
        V_hub (m/s).
    turbine_class : {'I', 'II', 'III'}
        Sets V_ref = 50, 42.5, 37.5 m/s.
    turbulence_class : {'A+', 'A', 'B', 'C'}
        Sets I_ref.
    rotor_diameter_m, hub_height_m : float
        D and z_hub (m).
    """
    try:
        v_ref = REFERENCE_SPEED_M_S[turbine_class]
    except (KeyError, TypeError):
        raise ValueError(
            f"turbine_class = {turbine_class!r}: expected one of {sorted(REFERENCE_SPEED_M_S)}"
        ) from None
    v_e1 = 0.8 * 1.4 * v_ref
    sigma = ntm_sigma(hub_speed_m_s, turbulence_class)
    lam = integral_scale_m(hub_height_m)
    return min(1.35 * (v_e1 - hub_speed_m_s), 3.3 * sigma / (1.0 + 0.1 * rotor_diameter_m / lam))


def eog_shape(t_s: float, period_s: float = EOG_PERIOD_S) -> float:
    """EOG shape g(t) = sin(3π t/T)(1 - cos(2π t/T)) on [0, T], 0 outside.

    The gust is V(t) = V_hub - 0.37 V_gust g(t); g ∈ [-2, 0.72449].
    """
    if t_s <= 0.0 or t_s >= period_s:
        return 0.0
    tau = t_s / period_s
    return math.sin(3.0 * math.pi * tau) * (1.0 - math.cos(2.0 * math.pi * tau))
