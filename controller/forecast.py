"""Wave forecasting for the controller runtime: dispersion, AR, ESPRIT; AR(2) wave frequency.

All forecasters are pure cores with the bench's calling convention (no clock, no I/O):

``init_state() -> state`` and ``step(state, sample_m, valid) -> (state, forecast_m)``,

called once every ``dt_s`` seconds with the newest elevation sample η(t) (m); ``forecast_m`` is
the predicted platform elevation η̂(t + horizon) (m). The *state* is a small object of
preallocated numpy buffers owned by the caller: ``step`` updates it **in place** and returns it
(so the per-cycle work allocates nothing heavy); copy it if an old state must be kept.

Forecasters
-----------
* :class:`DispersionPredictor` (al-2019 sect. 3-4): a causal FIR filter from the *up-wave gauge*
  (L metres up-wave) to the platform elevation t_d seconds ahead, designed once at construction
  from H_d(ω) = exp(i(ω t_d - k(ω) L)) (al-2019 eq. 3-30, finite depth through k(ω) of eq. 3-26).
* :class:`ArForecaster` (casanovas-2014 sect. 7.2): an AR(p) model of the local elevation fitted
  by least squares to its own recent past, iterated to the horizon.
* :class:`EspritForecaster` (casanovas-2014 sect. 7.3, Potts-Tasche): a sum of damped complex
  exponentials fitted to the recent past by the SVD of a Hankel matrix, extended in time.
* :class:`WaveFrequencyEstimator` (christiansen-2013 sect. 2.11): recursive least squares of an
  AR(2) model with forgetting; the wave frequency is the natural frequency of Â(q).

:func:`make_forecaster` selects one of the three forecasters by name for a scenario.

Per-cycle cost
--------------
Every forecaster reduces its prediction to a *fixed linear combination of the last samples*:
the dispersion FIR is designed once; the AR and ESPRIT predictors are linear in the data window
for fixed model parameters, so each (re)training computes a weight table
``weights[j] (window length)`` for each of the D = sample_period/dt calls between two model
samples, and a cycle is one ring-buffer write plus one numpy dot product of fixed size.
Retraining (AR: one p-column least squares, ESPRIT: one SVD, one eigenproblem and one
pseudo-inverse) runs on the cycle that completes every ``retrain_every``-th model sample; its
cost is bounded by the fixed window sizes and is reported by ``bench`` (see the report of
``hil.review.forecast``).

Dropped samples
---------------
``valid=False`` or a non-finite sample is a dropout: the last valid sample is **held** (zero-order
hold; a causal filter cannot interpolate without adding delay). Dropouts are counted in the state
(``dropped``, and ``dropped_in_window`` over the samples the predictor currently uses), and
before the first valid sample the held value is 0 m (mean sea level).

Import boundary
---------------
This module must not import ``plant``. The 10-line finite-depth dispersion solve
(:func:`wavenumber_rad_m`) therefore duplicates ``plant.waves.wavenumber`` on purpose.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass
from typing import Any, Literal, Protocol

import numpy as np
import numpy.typing as npt

__all__ = [
    "GRAVITY_M_S2",
    "ArConfig",
    "ArForecaster",
    "DispersionConfig",
    "DispersionPredictor",
    "EspritConfig",
    "EspritForecaster",
    "Forecaster",
    "ForecasterKind",
    "ForecasterState",
    "WaveFrequencyConfig",
    "WaveFrequencyEstimator",
    "WaveFrequencyState",
    "group_velocity_m_s",
    "make_forecaster",
    "wavenumber_rad_m",
]

FloatArray = npt.NDArray[np.float64]
ComplexArray = npt.NDArray[np.complex128]

#: Standard gravity (m/s²), the same value as the plant's.
GRAVITY_M_S2 = 9.80665

ForecasterKind = Literal["dispersion", "ar", "esprit"]


# ---------------------------------------------------------------------- validation helpers
def _number(owner: str, name: str, value: object, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise ValueError(f"{owner}: {name} expected a number in {unit}, got {type(value).__name__}")
    v = float(value)
    if math.isnan(v):
        raise ValueError(f"{owner}: {name} = nan, expected a number in {unit}")
    return v


def _positive(owner: str, name: str, value: object, unit: str) -> float:
    v = _number(owner, name, value, unit)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{owner}: {name} = {value!r}, expected a finite value > 0 {unit}")
    return v


def _nonnegative(owner: str, name: str, value: object, unit: str) -> float:
    v = _number(owner, name, value, unit)
    if not (math.isfinite(v) and v >= 0.0):
        raise ValueError(f"{owner}: {name} = {value!r}, expected a finite value >= 0 {unit}")
    return v


def _int_at_least(owner: str, name: str, value: object, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{owner}: {name} = {value!r}, expected an integer >= {low}")
    if int(value) < low:
        raise ValueError(f"{owner}: {name} = {value!r}, expected an integer >= {low}")
    return int(value)


def _ratio(owner: str, sample_period_s: float, dt_s: float) -> int:
    """Integer D = sample_period / dt (the model runs on every D-th call)."""
    d = sample_period_s / dt_s
    n = round(d)
    if n < 1 or abs(d - n) > 1e-9 * max(1.0, d):
        raise ValueError(
            f"{owner}: sample_period_s = {sample_period_s} s expected an integer multiple (>= 1) "
            f"of the call period dt_s = {dt_s} s"
        )
    return int(n)


# ---------------------------------------------------------------------- dispersion
def wavenumber_rad_m(
    omega_rad_s: npt.ArrayLike, depth_m: float = math.inf, g: float = GRAVITY_M_S2
) -> FloatArray:
    """Wavenumber k (rad/m) of the linear dispersion relation ω² = g k tanh(k d).

    al-2019 eq. (3-26) written for k: c = ω/k = √(g/k · tanh(k d)). Deep water (d = ∞) gives
    k = ω²/g (the exponent of al-2019 eq. 3-27). Finite depth: Newton on y tanh y = α,
    y = k d, α = ω² d/g, from Eckart's start y₀ = α/√(tanh α), to a relative step of 1e-12.
    This duplicates ``plant.waves.wavenumber`` deliberately: the controller may not import
    ``plant``.

    Parameters
    ----------
    omega_rad_s : array_like
        Angular frequencies ω (rad/s), >= 0.
    depth_m : float, optional
        Water depth d (m), > 0, or ``math.inf``.
    g : float, optional
        Gravity (m/s²).

    Returns
    -------
    ndarray
        k (rad/m), the shape of ``omega_rad_s``.
    """
    w = np.asarray(omega_rad_s, dtype=np.float64)
    if np.any(~np.isfinite(w)) or np.any(w < 0.0):
        raise ValueError("wavenumber_rad_m: expected finite angular frequencies >= 0 rad/s")
    if not depth_m > 0.0:
        raise ValueError(f"wavenumber_rad_m: depth_m = {depth_m!r}, expected > 0 m (inf: deep)")
    k_deep: FloatArray = w * w / g
    if math.isinf(depth_m):
        return k_deep
    alpha = np.where(k_deep > 0.0, k_deep * depth_m, 1.0)
    y = alpha / np.sqrt(np.tanh(alpha))
    for _ in range(50):
        t = np.tanh(y)
        step = (y * t - alpha) / (t + y * (1.0 - t * t))
        y = y - step
        if np.all(np.abs(step) <= 1e-12 * y):
            break
    out: FloatArray = np.where(k_deep > 0.0, y / depth_m, 0.0)
    return out


def group_velocity_m_s(
    omega_rad_s: npt.ArrayLike, depth_m: float = math.inf, g: float = GRAVITY_M_S2
) -> FloatArray:
    """Group velocity c_g = dω/dk (m/s) of linear gravity waves.

    c_g = (ω/k) · ½ (1 + 2kd / sinh 2kd); deep water: c_g = g/(2ω) (half the phase speed
    c = g/ω of al-2019 eq. 3-26 for d → ∞). ω must be > 0.

    Parameters
    ----------
    omega_rad_s : array_like
        ω (rad/s), > 0.
    depth_m : float, optional
        Depth d (m) or ``math.inf``.
    g : float, optional
        Gravity (m/s²).
    """
    w = np.asarray(omega_rad_s, dtype=np.float64)
    if np.any(w <= 0.0):
        raise ValueError("group_velocity_m_s: expected omega_rad_s > 0 rad/s")
    k = wavenumber_rad_m(w, depth_m, g)
    if math.isinf(depth_m):
        deep: FloatArray = g / (2.0 * w)
        return deep
    kd2 = 2.0 * k * depth_m
    # 2kd/sinh(2kd) underflows harmlessly to 0 for large kd
    ratio = np.where(kd2 < 700.0, kd2 / np.sinh(np.minimum(kd2, 700.0)), 0.0)
    out: FloatArray = 0.5 * (w / k) * (1.0 + ratio)
    return out


@dataclass(frozen=True, slots=True)
class DispersionConfig:
    """Design of the gauge-to-platform dispersion predictor (al-2019 sect. 3-4).

    Parameters
    ----------
    distance_m : float
        L (m), how far up-wave the gauge is (al-2019 eq. 3-25), > 0. Default 450 m.
    horizon_s : float
        t_d (s), the prediction time (al-2019 eq. 3-30), >= 0. Default 10 s.
    dt_s : float
        Sample period T_s (s) of the gauge and of the calls. Default 0.1 s.
    n_taps : int
        FIR length n (samples), >= 16. Default 2048 (204.8 s at 0.1 s): the components whose
        group delay L/c_g - t_d exceeds the filter length are outside its reach, and with
        al-2019's n = 1024 that cuts the band at 1.23 rad/s, which for JONSWAP H_s 2.2 m,
        T_p 8 s loses 12 % of the variance (VAF at most 88 %); 2048 taps reach 2.34 rad/s.
    depth_m : float
        Water depth d (m), > 0, or ``math.inf`` (deep water, al-2019 eq. 3-27).
    omega_min_rad_s, omega_max_rad_s : float
        Wave band (rad/s). Defaults 2π·0.05 and 2π·0.40 rad/s (al-2019 sect. 3-3 puts linear
        waves in 0.05-0.33 Hz; the upper default is wider since the FIR can reach it).
        The effective upper edge is lowered to what the FIR length can realise (see
        :attr:`DispersionPredictor.band_rad_s`).
    edge_taper_rad_s : float
        Width (rad/s) of the raised-cosine taper at each band edge, > 0. Default 0.05.
    window_taper : float
        Fraction (0..0.5) of the taps tapered by a half cosine at each end of the FIR (Tukey
        window) to damp the truncation ripple. Default 0.05.
    g_m_s2 : float
        Gravity (m/s²).
    """

    distance_m: float = 450.0
    horizon_s: float = 10.0
    dt_s: float = 0.1
    n_taps: int = 2048
    depth_m: float = math.inf
    omega_min_rad_s: float = 2.0 * math.pi * 0.05
    omega_max_rad_s: float = 2.0 * math.pi * 0.40
    edge_taper_rad_s: float = 0.05
    window_taper: float = 0.05
    g_m_s2: float = GRAVITY_M_S2

    def __post_init__(self) -> None:
        o = "DispersionConfig"
        set_ = object.__setattr__
        set_(self, "distance_m", _positive(o, "distance_m", self.distance_m, "m"))
        set_(self, "horizon_s", _nonnegative(o, "horizon_s", self.horizon_s, "s"))
        set_(self, "dt_s", _positive(o, "dt_s", self.dt_s, "s"))
        set_(self, "n_taps", _int_at_least(o, "n_taps", self.n_taps, 16))
        d = _number(o, "depth_m", self.depth_m, "m")
        if not d > 0.0:
            raise ValueError(f"{o}: depth_m = {self.depth_m!r}, expected a depth > 0 m (inf: deep)")
        set_(self, "depth_m", d)
        lo = _positive(o, "omega_min_rad_s", self.omega_min_rad_s, "rad/s")
        hi = _positive(o, "omega_max_rad_s", self.omega_max_rad_s, "rad/s")
        if not hi > lo:
            raise ValueError(f"{o}: omega_max_rad_s = {hi} expected > omega_min_rad_s = {lo} rad/s")
        nyquist = math.pi / self.dt_s
        if hi >= nyquist:
            raise ValueError(
                f"{o}: omega_max_rad_s = {hi} rad/s expected below the Nyquist frequency "
                f"π/dt_s = {nyquist:.4g} rad/s"
            )
        set_(self, "omega_min_rad_s", lo)
        set_(self, "omega_max_rad_s", hi)
        set_(
            self,
            "edge_taper_rad_s",
            _positive(o, "edge_taper_rad_s", self.edge_taper_rad_s, "rad/s"),
        )
        wt = _number(o, "window_taper", self.window_taper, "(-)")
        if not 0.0 <= wt <= 0.5:
            raise ValueError(f"{o}: window_taper = {self.window_taper!r}, expected in [0, 0.5] (-)")
        set_(self, "window_taper", wt)
        set_(self, "g_m_s2", _positive(o, "g_m_s2", self.g_m_s2, "m/s²"))


class ForecasterState:
    """Mutable, preallocated state of one forecaster (ring buffer, counters, weights).

    Attributes
    ----------
    buffer : ndarray, shape (2 n,)
        Ring buffer of the last n model samples, written twice (at i and i + n) so that
        ``buffer[head : head + n]`` is always the window, oldest first, without copying.
    head : int
        Start of the window in ``buffer``.
    count : int
        Model samples received so far (valid or held).
    calls : int
        ``step`` calls so far.
    phase : int
        Calls since the last model sample (0 on the call that took it).
    held_m : float
        Last valid sample (m), 0 before the first one.
    dropped : int
        Dropped (invalid or non-finite) samples so far.
    dropped_in_window : int
        Dropped samples among the n model samples in the window.
    weights : ndarray, shape (D, n)
        Forecast weights per call phase (AR, ESPRIT), or the FIR (dispersion, D = 1).
    trained : bool
        Whether ``weights`` holds a usable model.
    trainings : int
        (Re)trainings done so far (AR, ESPRIT).
    rejected : int
        Trainings whose weights were rejected (norm too large or not finite).
    modes : int
        ESPRIT: number of exponentials M of the last fit; AR: the order.
    unstable_fits : int
        AR and ESPRIT: fits with a pole outside the unit circle (|z| > 1), stabilised by
        reflecting those poles to 1/z̄ before use (see :class:`_DecimatedForecaster`).
    guarded : int
        AR and ESPRIT: forecasts beyond the bound ``bound_factor · max|window|`` replaced by
        the fallback 0 m (mean sea level).
    bound_m : float
        The current forecast bound (m), set on every model sample.
    """

    __slots__ = (
        "bound_m",
        "buffer",
        "calls",
        "count",
        "drop_flags",
        "dropped",
        "dropped_in_window",
        "guarded",
        "head",
        "held_m",
        "modes",
        "n",
        "phase",
        "rejected",
        "trained",
        "trainings",
        "unstable_fits",
        "weights",
    )

    def __init__(self, n: int, n_phases: int) -> None:
        self.n = n
        self.buffer: FloatArray = np.zeros(2 * n)
        self.drop_flags = np.zeros(n, dtype=np.bool_)
        self.head = 0
        self.count = 0
        self.calls = 0
        self.phase = 0
        self.held_m = 0.0
        self.dropped = 0
        self.dropped_in_window = 0
        self.weights: FloatArray = np.zeros((n_phases, n))
        self.trained = False
        self.trainings = 0
        self.rejected = 0
        self.modes = 0
        self.unstable_fits = 0
        self.guarded = 0
        self.bound_m = math.inf

    @property
    def filled(self) -> bool:
        """True once the window holds n samples."""
        return self.count >= self.n

    @property
    def window(self) -> FloatArray:
        """The last n model samples, oldest first (a view)."""
        w: FloatArray = self.buffer[self.head : self.head + self.n]
        return w

    def copy(self) -> ForecasterState:
        """A deep copy (for callers that want to keep an old state)."""
        c = ForecasterState.__new__(ForecasterState)
        for name in ForecasterState.__slots__:
            v = getattr(self, name)
            setattr(c, name, v.copy() if isinstance(v, np.ndarray) else v)
        return c

    def _take(self, sample_m: float, valid: bool) -> bool:
        """Apply the hold rule to one call's sample (the value to use is then ``held_m``).

        Returns whether the sample was taken (valid and finite); False: dropped, held.
        """
        self.calls += 1
        if valid and math.isfinite(sample_m):
            self.held_m = float(sample_m)
            return True
        self.dropped += 1
        return False

    def _push(self, value_m: float, was_dropped: bool) -> None:
        """Append one model sample to the ring buffer (O(1), no allocation)."""
        n = self.n
        i = self.head  # slot of the oldest sample, overwritten by the newest
        self.buffer[i] = value_m
        self.buffer[i + n] = value_m
        self.dropped_in_window += int(was_dropped) - int(self.drop_flags[i])
        self.drop_flags[i] = was_dropped
        self.head = i + 1 if i + 1 < n else 0
        self.count += 1


class Forecaster(Protocol):
    """Common interface of the wave forecasters (see the module docstring)."""

    @property
    def horizon_s(self) -> float:
        """Prediction horizon (s): ``step`` at time t returns η̂(t + horizon_s)."""
        ...

    @property
    def dt_s(self) -> float:
        """Call period (s)."""
        ...

    def init_state(self) -> ForecasterState:
        """A fresh state (zero buffers, nothing trained)."""
        ...

    def step(
        self, state: ForecasterState, sample_m: float, valid: bool = True
    ) -> tuple[ForecasterState, float]:
        """Take one sample η(t) (m); return the (in-place updated) state and η̂(t + horizon) (m).

        Parameters
        ----------
        state : ForecasterState
            From :meth:`init_state` or the previous call; updated in place.
        sample_m : float
            Elevation sample (m).
        valid : bool, optional
            False for a dropped sample: the last valid one is held and counted.

        Returns
        -------
        tuple of (ForecasterState, float)
            The state and the forecast (m) for time t + horizon_s.
        """
        ...


class DispersionPredictor:
    """Causal FIR predictor from the up-wave gauge to the platform, t_d ahead (al-2019 sect. 3-4).

    Design (once, at construction). The ideal transfer function from the gauge elevation
    η_A(t) to the platform elevation η_B(t + t_d) is al-2019 eq. (3-30),

        H_d(ω) = H(ω) D(ω) = exp(-i k(ω) L) · exp(+i ω t_d),

    with k(ω) from eq. (3-26) (deep water: k = ω²/g, eq. 3-27). Its impulse response has, at
    frequency ω, the group delay τ(ω) = L/c_g(ω) - t_d, so a *causal* FIR of n taps realises
    H_d on the band where 0 <= τ(ω) <= (n - 1) T_s. This is the causality condition used here:
    t_d <= min over the band of L/c_g(ω) = L/c_g,max (the group velocity is largest at the low
    band edge). al-2019 eqs. (3-30)-(3-32) state it with the phase instead, t_d <= ωL/g,
    i.e. T <= 2πL/(g t_d); that is the deep-water condition with the phase speed, a factor 2
    stricter than the group-delay bound since c = 2 c_g.

    1. Band: [ω_min, ω_max] of the config, with ω_max lowered to the largest ω whose group
       delay fits the filter with a margin of 5 % of its length; a raised-cosine taper of
       width ``edge_taper_rad_s`` inside each edge gives B(ω). Components outside the band are
       not predicted (their variance is the floor of the error).
    2. Frequency sampling on a dense grid of M = 8n points (≥ 8 times finer than the FIR's own
       resolution): H_k = B(ω_k) H_d(ω_k), ω_k = 2πk/(M T_s); h = IDFT(H) (real, Hermitian).
    3. Causal truncation to taps 0 … n-1 and a Tukey window (cosine tapers over
       ``window_taper`` of the taps at each end). The energy of h outside [0, n) before
       truncation is kept as :attr:`truncated_energy_fraction` (a design diagnostic).

    Runtime: η̂_B(t + t_d) = Σ_{j=0}^{n-1} h[j] η_A(t - j T_s) — the real-time form of
    al-2019 eq. (3-34) (there an FFT of a stacked window of n samples, here the equivalent
    causal FIR, one dot product of n per call). Full accuracy after n samples
    (n T_s seconds, al-2019 fig. 3-11: 102.4 s for n = 1024).

    Parameters
    ----------
    config : DispersionConfig
        Geometry, horizon, sampling and band.

    Raises
    ------
    ValueError
        If t_d > L / c_g,max over the band (causality) or if the band left after fitting the
        filter length is empty.
    """

    __slots__ = ("_band", "_config", "_fir", "_truncated")

    def __init__(self, config: DispersionConfig) -> None:
        self._config = config
        c = config
        w_lo, w_hi = c.omega_min_rad_s, c.omega_max_rad_s
        cg_max = float(
            np.max(group_velocity_m_s(np.linspace(w_lo, w_hi, 512), c.depth_m, c.g_m_s2))
        )
        min_delay_s = c.distance_m / cg_max
        if c.horizon_s > min_delay_s:
            raise ValueError(
                f"DispersionPredictor: horizon_s = {c.horizon_s} s is not causal: it must not "
                f"exceed the minimum group delay L/c_g,max = {min_delay_s:.3g} s of the wave band "
                f"[{w_lo:.3g}, {w_hi:.3g}] rad/s over distance_m = {c.distance_m} m "
                f"(depth_m = {c.depth_m}); shorten the horizon, move the gauge further up-wave "
                "or raise omega_min_rad_s"
            )
        span_s = (c.n_taps - 1) * c.dt_s
        limit_s = 0.95 * span_s
        grid = np.linspace(w_lo, w_hi, 4096)
        tau = c.distance_m / group_velocity_m_s(grid, c.depth_m, c.g_m_s2) - c.horizon_s
        fits = tau <= limit_s
        if not fits[0] or grid[fits][-1] - w_lo <= 2.0 * c.edge_taper_rad_s:
            raise ValueError(
                f"DispersionPredictor: n_taps = {c.n_taps} ({span_s:.4g} s) is too short: the "
                f"group delay L/c_g - t_d at omega_min_rad_s = {w_lo:.3g} rad/s is "
                f"{tau[0]:.4g} s and the band that fits is narrower than two edge tapers of "
                f"{c.edge_taper_rad_s} rad/s; use more taps"
            )
        w_hi = float(grid[fits][-1])
        self._band = (w_lo, w_hi)

        m = 8 * c.n_taps
        omega: FloatArray = np.asarray(2.0 * math.pi * np.fft.rfftfreq(m, d=c.dt_s), np.float64)
        band = _raised_cosine_band(omega, w_lo, w_hi, c.edge_taper_rad_s)
        k = wavenumber_rad_m(omega, c.depth_m, c.g_m_s2)
        h_full = np.fft.irfft(band * np.exp(1j * (omega * c.horizon_s - k * c.distance_m)), m)
        total = float(np.sum(h_full**2))
        fir = h_full[: c.n_taps] * _tukey(c.n_taps, c.window_taper)
        kept = float(np.sum(h_full[: c.n_taps] ** 2))
        self._truncated = 1.0 - kept / total if total > 0.0 else 0.0
        # stored oldest-first, to dot directly with the ring-buffer window
        self._fir: FloatArray = np.ascontiguousarray(fir[::-1])
        self._fir.setflags(write=False)

    @property
    def config(self) -> DispersionConfig:
        """The design configuration."""
        return self._config

    @property
    def horizon_s(self) -> float:
        """t_d (s)."""
        return self._config.horizon_s

    @property
    def dt_s(self) -> float:
        """Call and sample period T_s (s)."""
        return self._config.dt_s

    @property
    def band_rad_s(self) -> tuple[float, float]:
        """Effective band (ω_min, ω_max) in rad/s after fitting the filter length."""
        return self._band

    @property
    def truncated_energy_fraction(self) -> float:
        """Energy fraction (-) of the ideal band-limited impulse response outside [0, n T_s)."""
        return self._truncated

    @property
    def fir(self) -> FloatArray:
        """FIR taps h[0 … n-1] (-), h[0] multiplying the newest sample (read-only)."""
        out: FloatArray = self._fir[::-1]
        return out

    def frequency_response(self, omega_rad_s: npt.ArrayLike) -> ComplexArray:
        """Realised H(ω) = Σ_j h[j] e^{-iωjT_s} (-) of the FIR, for design checks."""
        w = np.asarray(omega_rad_s, dtype=np.float64)
        j = np.arange(self._config.n_taps)
        out: ComplexArray = np.exp(-1j * np.outer(w, j) * self._config.dt_s) @ self.fir
        return out

    def ideal_response(self, omega_rad_s: npt.ArrayLike) -> ComplexArray:
        """Ideal H_d(ω) = exp(i(ω t_d - k(ω) L)) (al-2019 eq. 3-30) (-)."""
        c = self._config
        w = np.asarray(omega_rad_s, dtype=np.float64)
        k = wavenumber_rad_m(w, c.depth_m, c.g_m_s2)
        out: ComplexArray = np.exp(1j * (w * c.horizon_s - k * c.distance_m))
        return out

    def init_state(self) -> ForecasterState:
        """Zero ring buffer of n taps; the forecast is fully accurate once it has filled."""
        state = ForecasterState(self._config.n_taps, 1)
        state.trained = True
        return state

    def step(
        self, state: ForecasterState, sample_m: float, valid: bool = True
    ) -> tuple[ForecasterState, float]:
        """Take the gauge elevation η_A(t) (m); return η̂_B(t + t_d) (m) at the platform.

        Parameters and result as :meth:`Forecaster.step` (``sample_m``: the gauge elevation).
        """
        ok = state._take(sample_m, valid)
        state._push(state.held_m, not ok)
        return state, float(np.dot(self._fir, state.window))


def _raised_cosine_band(omega: FloatArray, lo: float, hi: float, taper: float) -> FloatArray:
    """1 inside [lo + taper, hi - taper], raised-cosine to 0 at lo and hi, 0 outside (-)."""
    rise = np.clip((omega - lo) / taper, 0.0, 1.0)
    fall = np.clip((hi - omega) / taper, 0.0, 1.0)
    out: FloatArray = 0.25 * (1.0 - np.cos(math.pi * rise)) * (1.0 - np.cos(math.pi * fall))
    return out


def _tukey(n: int, alpha: float) -> FloatArray:
    """Tukey window of n points with cosine tapers over a fraction ``alpha`` at each end."""
    w = np.ones(n)
    m = int(alpha * n)
    if m > 0:
        ramp = 0.5 * (1.0 - np.cos(math.pi * (np.arange(m) + 0.5) / m))
        w[:m] = ramp
        w[n - m :] = ramp[::-1]
    return w


# ---------------------------------------------------------------------- decimated models
@dataclass(frozen=True, slots=True)
class ArConfig:
    """AR(p) forecaster of the local elevation from its own past (casanovas-2014 sect. 7.2).

    Parameters
    ----------
    order : int
        N_AR = p (-), >= 1. Default 24 (casanovas: order 24 with 40 training samples).
    n_train : int
        M, the number of least-squares rows (training samples), >= order. Default 40. The
        window holds the last order + n_train model samples.
    sample_period_s : float
        Model sample period Δt (s). Default 0.5 s (casanovas: 2 Hz).
    dt_s : float
        Call period (s); ``sample_period_s`` must be an integer multiple of it. Default 0.1 s.
    horizon_s : float
        Prediction horizon (s), >= 0. Default 5 s.
    retrain_every : int
        Refit every this many model samples (>= 1). Default 1 (a sliding-window fit).
    ridge : float
        Relative Tikhonov term λ (-) added as λ · tr(XᵀX)/p · I, >= 0. Default 0 (the seed's
        plain least squares).
    max_weight_norm : float
        A fit whose forecast weights have a 2-norm above this (-) is rejected and the previous
        weights are kept (not in the seed; see :func:`_accept`). Default 1e12: the least-squares
        AR(24) of an oversampled noise-free sea has weight norms of 1e8-1e9 that still predict
        well, so only non-finite or absurd fits are rejected.
    stabilise : bool
        Reflect the roots of the AR polynomial outside the unit circle to 1/z̄ (stability check,
        not in the seed). Default True. False keeps the seed's raw least-squares model, whose
        iterated forecast diverges on most seas (see :class:`_DecimatedForecaster`).
    bound_factor : float
        Forecast guard (-), > 0: a forecast with |η̂| > ``bound_factor`` · max|window| is
        replaced by 0 m and counted. Default 3.
    """

    order: int = 24
    n_train: int = 40
    sample_period_s: float = 0.5
    dt_s: float = 0.1
    horizon_s: float = 5.0
    retrain_every: int = 1
    ridge: float = 0.0
    max_weight_norm: float = 1e12
    stabilise: bool = True
    bound_factor: float = 3.0

    def __post_init__(self) -> None:
        o = "ArConfig"
        set_ = object.__setattr__
        set_(self, "order", _int_at_least(o, "order", self.order, 1))
        set_(self, "n_train", _int_at_least(o, "n_train", self.n_train, self.order))
        _check_decimation(o, self)
        set_(self, "ridge", _nonnegative(o, "ridge", self.ridge, "(-)"))
        set_(self, "max_weight_norm", _positive(o, "max_weight_norm", self.max_weight_norm, "(-)"))


@dataclass(frozen=True, slots=True)
class EspritConfig:
    """ESPRIT forecaster of the local elevation from its own past (casanovas-2014 sect. 7.3).

    Parameters
    ----------
    n_half : int
        N (-): the fit window holds 2N model samples, >= 4. Default 40.
    pencil : int
        L (-), the upper bound of the number of exponentials M, 2 <= L <= 2N - 2. Default 40
        (Potts-Tasche's L = N, casanovas sect. 7.3.2.4).
    epsilon : float
        Relative singular-value threshold ε (-): M = #{σ_j >= ε σ_1} (casanovas eq. σ_{M+1} <
        ε σ_1). Default 3e-14 as casanovas sect. 7.3.2.2.
    sample_period_s : float
        Model sample period Δt (s). Default 0.5 s (casanovas' best for C2 is Δt = 1/ω_max).
    dt_s : float
        Call period (s); ``sample_period_s`` must be an integer multiple of it. Default 0.1 s.
    horizon_s : float
        Prediction horizon (s), >= 0. Default 5 s.
    retrain_every : int
        Refit the exponents every this many model samples (>= 1); in between, the amplitudes
        are re-estimated every model sample (the weights are linear in the window). Default 4.
    max_weight_norm : float
        A fit whose forecast weights have a 2-norm above this (-) is rejected and the previous
        weights are kept (not in the seed; see :func:`_accept`). Default 10.
    stabilise : bool
        Reflect the poles outside the unit circle to 1/z̄ (stability check, not in the seed).
        Default True.
    bound_factor : float
        Forecast guard (-), > 0, as :class:`ArConfig`. Default 3.
    """

    n_half: int = 40
    pencil: int = 40
    epsilon: float = 3e-14
    sample_period_s: float = 0.5
    dt_s: float = 0.1
    horizon_s: float = 5.0
    retrain_every: int = 4
    max_weight_norm: float = 10.0
    stabilise: bool = True
    bound_factor: float = 3.0

    def __post_init__(self) -> None:
        o = "EspritConfig"
        set_ = object.__setattr__
        set_(self, "n_half", _int_at_least(o, "n_half", self.n_half, 4))
        set_(self, "pencil", _int_at_least(o, "pencil", self.pencil, 2))
        if self.pencil > 2 * self.n_half - 2:
            raise ValueError(
                f"{o}: pencil = {self.pencil}, expected L <= 2 n_half - 2 = {2 * self.n_half - 2}"
            )
        e = _number(o, "epsilon", self.epsilon, "(-)")
        if not 0.0 < e < 1.0:
            raise ValueError(f"{o}: epsilon = {self.epsilon!r}, expected in (0, 1) (-)")
        set_(self, "epsilon", e)
        _check_decimation(o, self)
        set_(self, "max_weight_norm", _positive(o, "max_weight_norm", self.max_weight_norm, "(-)"))


def _check_decimation(o: str, config: ArConfig | EspritConfig) -> None:
    """Check and normalise the fields AR and ESPRIT share (periods, horizon, retraining)."""
    set_ = object.__setattr__
    set_(config, "sample_period_s", _positive(o, "sample_period_s", config.sample_period_s, "s"))
    set_(config, "dt_s", _positive(o, "dt_s", config.dt_s, "s"))
    _ratio(o, config.sample_period_s, config.dt_s)
    set_(config, "horizon_s", _nonnegative(o, "horizon_s", config.horizon_s, "s"))
    set_(config, "retrain_every", _int_at_least(o, "retrain_every", config.retrain_every, 1))
    if not isinstance(config.stabilise, bool):
        raise ValueError(f"{o}: stabilise = {config.stabilise!r}, expected true or false")
    set_(config, "bound_factor", _positive(o, "bound_factor", config.bound_factor, "(-)"))


class _DecimatedForecaster(abc.ABC):
    """Shared runtime of the AR and ESPRIT forecasters (decimation, hold, weight tables).

    The model sees every D-th call's sample (D = sample_period / dt; the held value if that
    call's sample is dropped; no anti-alias filter: the wave band lies far below the model's
    Nyquist frequency π/Δt = 6.3 rad/s at 2 Hz). On the call that completes the window and
    then every ``retrain_every`` model samples, :meth:`_train` fills ``state.weights[j]`` so that
    the forecast j calls after a model sample is ``weights[j] · window``, for the target time
    t_model + j dt + horizon, i.e. s_j = (j dt + horizon)/Δt model steps ahead.

    Bounded-prediction guard: a forecast with |η̂| > ``bound_factor`` · max|window| (the
    largest elevation of the model window, default factor 3) or a non-finite one is replaced
    by the fallback 0 m (mean sea level, the no-skill forecast) and counted in
    ``state.guarded``; so whatever the fit, the output never exceeds three times the largest
    elevation seen in the last 32-40 s. Poles outside the unit circle are reflected (AR and
    ESPRIT ``stabilise``; counted in ``state.unstable_fits``).
    """

    __slots__ = (
        "_bound",
        "_decim",
        "_dt",
        "_horizon",
        "_n",
        "_retrain",
        "_stabilise",
        "_steps_ahead",
    )

    def __init__(self, n: int, config: ArConfig | EspritConfig):
        dt_s, sample_period_s, horizon_s = config.dt_s, config.sample_period_s, config.horizon_s
        self._n = n
        self._stabilise = config.stabilise
        self._bound = config.bound_factor
        self._dt = dt_s
        self._horizon = horizon_s
        self._decim = _ratio(type(self).__name__, sample_period_s, dt_s)
        self._retrain = config.retrain_every
        self._steps_ahead: FloatArray = np.asarray(
            (np.arange(self._decim) * dt_s + horizon_s) / sample_period_s, np.float64
        )

    @property
    def horizon_s(self) -> float:
        """Prediction horizon (s)."""
        return self._horizon

    @property
    def dt_s(self) -> float:
        """Call period (s)."""
        return self._dt

    def init_state(self) -> ForecasterState:
        """Zero window; the forecast is 0 m until the first training."""
        return ForecasterState(self._n, self._decim)

    @abc.abstractmethod
    def _train(self, state: ForecasterState) -> None:
        """Fill ``state.weights`` from the model window (AR or ESPRIT)."""

    def step(
        self, state: ForecasterState, sample_m: float, valid: bool = True
    ) -> tuple[ForecasterState, float]:
        """Take the local elevation η(t) (m); return η̂(t + horizon_s) (m).

        Parameters and result as :meth:`Forecaster.step`; the forecast is 0 m until the model
        is first trained.
        """
        ok = state._take(sample_m, valid)
        tick = (state.calls - 1) % self._decim == 0
        if tick:
            state._push(state.held_m, not ok)
            state.phase = 0
            if state.filled and (not state.trained or (state.count - self._n) % self._retrain == 0):
                self._train(state)
            state.bound_m = self._bound * float(np.max(np.abs(state.window)))
        else:
            state.phase += 1
        if not state.trained:
            return state, 0.0
        f = float(np.dot(state.weights[state.phase], state.window))
        if not abs(f) <= state.bound_m:  # also catches a non-finite forecast
            state.guarded += 1
            return state, 0.0
        return state, f

    def _stable(self, state: ForecasterState, z: ComplexArray) -> ComplexArray:
        """Poles z with those outside the unit circle reflected to 1/z̄ (counted)."""
        if not self._stabilise:
            return z
        r = np.abs(z)
        if not bool(np.any(r > 1.0)):
            return z
        state.unstable_fits += 1
        out: ComplexArray = np.where(r > 1.0, 1.0 / np.conj(z), z)
        return out


class ArForecaster(_DecimatedForecaster):
    """AR(p) forecaster, least squares on a sliding window, iterated to the horizon.

    Model (casanovas-2014 sect. 7.2.1): ζ_k = Σ_{j=1}^{p} α_j ζ_{k-j}. Training: the last
    p + M model samples give M rows [ζ_{k-1} … ζ_{k-p}] → ζ_k; α by linear least squares
    (``numpy.linalg.lstsq``, plus an optional ridge term). Forecast: the companion matrix Λ
    (first row α, identity below) iterated k_c times, [ζ_{k+k_c} …]ᵀ = Λ^{k_c} [ζ_k …]ᵀ; only
    the first row e₀ᵀΛ^{k_c} is needed and is built by the recursion r_{m+1} = r_m Λ
    (= r_m[0] α + shift(r_m)), p·k_c multiply-adds, which is the seed's iterated one-step
    prediction written as weights (the seed's fig. 7.6 instability came from forming Λ^{k_c}).
    Non-integer step counts (the calls between two model samples) interpolate linearly
    between the rows of the neighbouring integers.

    Stability check (not in the seed; ``stabilise``, default on): the roots of
    z^p - α_1 z^{p-1} - … - α_p are computed at every fit; roots outside the unit circle are
    reflected to 1/z̄ (the minimum-phase AR with the same spectrum shape: the reflection is an
    all-pass factor), α is rebuilt from the roots and the fit is counted in
    ``state.unstable_fits``. The least-squares AR(24) of a sea sampled at 2 Hz nearly always
    has a root slightly outside (median max|z| 1.01-1.08), so without the check the iterated
    forecast grows as max|z|^{k_c}: a measured VAF of -59 000 % at 8 s for H_s 4.3 m,
    T_p 10 s. Reflecting costs 1.4 points of VAF (99.9 to 98.5 %, 5 s ahead) on casanovas'
    band-limited noise-free sea.

    Cost per retraining: one lstsq of M × p (40 × 24: tens of µs) and the rows up to
    ceil(max s_j) steps. Per call: one dot product of p + M.

    Parameters
    ----------
    config : ArConfig
    """

    __slots__ = ("_config",)

    def __init__(self, config: ArConfig) -> None:
        self._config = config
        super().__init__(config.order + config.n_train, config)

    @property
    def config(self) -> ArConfig:
        """The configuration."""
        return self._config

    def coefficients(self, window_m: npt.ArrayLike) -> FloatArray:
        """Least-squares AR coefficients α_1 … α_p (-) of p + M samples (oldest first)."""
        c = self._config
        s = np.asarray(window_m, dtype=np.float64)
        p = c.order
        X = np.lib.stride_tricks.sliding_window_view(s[:-1], p)[:, ::-1]
        y = s[p:]
        if c.ridge > 0.0:
            G = X.T @ X
            G[np.diag_indices(p)] += c.ridge * np.trace(G) / p
            alpha: FloatArray = np.asarray(np.linalg.solve(G, X.T @ y), np.float64)
            return alpha
        sol: FloatArray = np.asarray(np.linalg.lstsq(X, y, rcond=None)[0], np.float64)
        return sol

    def _train(self, state: ForecasterState) -> None:
        c = self._config
        p, n = c.order, self._n
        alpha = self.coefficients(state.window)
        if self._stabilise:
            roots: ComplexArray = np.roots(np.concatenate(([1.0], -alpha))).astype(np.complex128)
            stable = self._stable(state, roots)
            if stable is not roots:
                alpha = -np.real(np.poly(stable))[1:]
        steps = self._steps_ahead
        m_max = math.ceil(float(steps[-1]))
        rows = np.zeros((m_max + 1, p))
        rows[0, 0] = 1.0
        for m in range(m_max):
            r = rows[m]
            rows[m + 1, :-1] = r[0] * alpha[:-1] + r[1:]
            rows[m + 1, -1] = r[0] * alpha[-1]
        lo = np.floor(steps).astype(np.int64)
        hi = np.minimum(lo + 1, m_max)
        frac = (steps - lo)[:, None]
        w_newest_first = (1.0 - frac) * rows[lo] + frac * rows[hi]
        w = np.zeros_like(state.weights)
        w[:, n - p :] = w_newest_first[:, ::-1]
        state.trainings += 1
        _accept(state, w, c.max_weight_norm)
        state.modes = p


class EspritForecaster(_DecimatedForecaster):
    """ESPRIT (Potts-Tasche) forecaster: a sum of exponentials fitted to the recent past.

    casanovas-2014 sect. 7.3.1: ζ(t) = Re Σ_{j=1}^{M} c_j e^{f_j t}. With the window of 2N
    model samples ζ(1 … 2N):

    1. Hankel matrix H (2N - L) × (L + 1), H_{l,m} = ζ(l + m); SVD H = U D W.
    2. M = number of singular values with σ_j >= ε σ_1 (σ_{M+1} < ε σ_1), capped at L.
    3. W_{M,L+1} = W(1:M, 1:L+1); W_{M,L}(0) = W(1:M, 1:L), W_{M,L}(1) = W(1:M, 2:L+1);
       F = (W_{M,L}(0)ᵀ)⁺ W_{M,L}(1)ᵀ; its eigenvalues z_j give f_j = log(z_j)/Δt.
    4. Amplitudes c by least squares min ‖ζ(k) - Σ c_j z_j^k‖²; forecast by extending k.

    Runtime form: for fixed z_j the forecast is linear in the window,
    ζ̂(2N - 1 + s) = Re(gᵀ V⁺ ζ) with V_{k,j} = z_j^k (k = 0 … 2N-1) and g_j = z_j^{2N-1+s},
    so each fit stores the real weights Re(gᵀV⁺) for every call phase, and the amplitudes are
    re-estimated on every model sample by the dot product alone (between fits of the
    exponents every ``retrain_every`` model samples).

    Safeguards (not in the seed): a fit whose forecast weights have a norm above
    ``max_weight_norm`` is rejected and the previous weights are kept (:func:`_accept`); with
    ``stabilise`` (default) poles outside the unit circle are reflected to 1/z̄ before the
    amplitudes are fitted (counted in ``state.unstable_fits``), and every forecast passes the
    bound guard of :class:`_DecimatedForecaster`. The price: on a noise-free sea band-limited
    to 2 rad/s (casanovas' own test) the raw fit's pairs of growing and decaying modes describe
    the beating of the irregular sea and reach a VAF of 99.7 % at 5 s, the stabilised fit
    28 %; on the plant's 3 rad/s band with 0.02 m of sensor noise most fits have poles
    far outside (median max|z| 1.4, up to 140 at 2 Hz) and the raw forecast is unbounded
    (VAF -400 % to -3900 %), the stabilised one stays within the sea's amplitude
    (``bench/forecast_grid.py``). ``stabilise=False`` reproduces the seed.

    Cost per fit: SVD of (2N - L) × (L + 1), a pseudo-inverse of L × M, an M × M eigenproblem
    and a pseudo-inverse of 2N × M (complex); about 1-3 ms for N = L = 40.

    Parameters
    ----------
    config : EspritConfig
    """

    __slots__ = ("_config",)

    def __init__(self, config: EspritConfig) -> None:
        self._config = config
        super().__init__(2 * config.n_half, config)

    @property
    def config(self) -> EspritConfig:
        """The configuration."""
        return self._config

    def exponentials(self, window_m: npt.ArrayLike) -> ComplexArray:
        """Poles z_j (-) of the exponential sum fitted to 2N samples (oldest first), steps 1-3."""
        c = self._config
        s = np.asarray(window_m, dtype=np.float64)
        L = c.pencil
        H = np.lib.stride_tricks.sliding_window_view(s, L + 1)  # (2N - L) × (L + 1)
        _, sigma, W = np.linalg.svd(H, full_matrices=False)
        if sigma.size == 0 or sigma[0] <= 0.0:
            return np.zeros(0, dtype=np.complex128)
        M = min(int(np.count_nonzero(sigma >= c.epsilon * sigma[0])), L)
        WM = W[:M, :]
        F = np.linalg.pinv(WM[:, :L].T) @ WM[:, 1:].T
        z: ComplexArray = np.linalg.eigvals(F).astype(np.complex128)
        return z

    def _train(self, state: ForecasterState) -> None:
        n = self._n
        z = self.exponentials(state.window)
        state.trainings += 1
        if z.size == 0:  # a flat window: nothing to extrapolate
            _accept(state, np.zeros_like(state.weights), self._config.max_weight_norm)
            state.modes = 0
            return
        z = self._stable(state, z)
        logz = np.log(np.where(z == 0.0, 1e-300, z))
        V = np.exp(np.outer(np.arange(n), logz))  # (2N, M)
        G = np.exp(np.outer(n - 1 + self._steps_ahead, logz))  # (D, M)
        w = (G @ np.linalg.pinv(V)).real
        if _accept(state, w, self._config.max_weight_norm):
            state.modes = int(z.size)


def _accept(state: ForecasterState, w: FloatArray, max_norm: float) -> bool:
    """Install weights w if finite with every row norm <= max_norm; else keep the old ones.

    A fit is rejected (and counted in ``state.rejected``) when it would amplify the window by
    more than ``max_norm`` (-): such fits are the rare diverging extrapolations that dominate
    the error variance, and a large norm also means a large gain on sensor noise. The previous
    weights stay valid on the shifted window because they encode fixed model parameters
    relative to the newest sample; before any accepted fit the forecast stays 0.
    """
    ok = bool(np.all(np.isfinite(w))) and float(np.max(np.sum(w * w, axis=1))) <= max_norm**2
    if ok:
        state.weights[:] = w
        state.trained = True
    else:
        state.rejected += 1
    return ok


# ---------------------------------------------------------------------- factory
def make_forecaster(
    kind: ForecasterKind | str, config: DispersionConfig | ArConfig | EspritConfig | None = None
) -> DispersionPredictor | ArForecaster | EspritForecaster:
    """Build the forecaster a scenario selects.

    Parameters
    ----------
    kind : {"dispersion", "ar", "esprit"}
        ``"dispersion"`` forecasts the platform from the up-wave gauge (al-2019);
        ``"ar"`` and ``"esprit"`` forecast the local elevation from its own past (casanovas-2014).
    config : DispersionConfig or ArConfig or EspritConfig, optional
        Its configuration (of the matching type); the defaults when omitted.

    Returns
    -------
    Forecaster
        An object with ``init_state()`` and ``step(state, sample_m, valid)``.

    Raises
    ------
    ValueError
        For an unknown kind or a config of the wrong type.
    """
    table: dict[str, tuple[type[Any], Any]] = {
        "dispersion": (DispersionConfig, DispersionPredictor),
        "ar": (ArConfig, ArForecaster),
        "esprit": (EspritConfig, EspritForecaster),
    }
    if kind not in table:
        raise ValueError(
            f"make_forecaster: kind = {kind!r}, expected one of {', '.join(sorted(table))}"
        )
    cfg_type, cls = table[kind]
    cfg = cfg_type() if config is None else config
    if not isinstance(cfg, cfg_type):
        raise ValueError(
            f"make_forecaster: kind {kind!r} expected a {cfg_type.__name__}, "
            f"got {type(config).__name__}"
        )
    forecaster: DispersionPredictor | ArForecaster | EspritForecaster = cls(cfg)
    return forecaster


# ---------------------------------------------------------------------- AR(2) frequency
@dataclass(frozen=True, slots=True)
class WaveFrequencyConfig:
    """AR(2) recursive-least-squares wave-frequency estimator (christiansen-2013 sect. 2.11).

    Parameters
    ----------
    dt_s : float
        Call period (s). Default 0.1 s.
    sample_period_s : float
        Model sample period Δt (s), an integer multiple of ``dt_s``. Default 0.5 s: at fast
        sampling the AR(2) poles crowd near z = 1 and sensor noise biases the fit.
    forgetting_factor : float
        λ (-) in (0, 1]: the memory is about Δt/(1 - λ) seconds. Default 0.995 (100 s at 0.5 s).
    initial_covariance : float
        P₀ = p₀ I (1/m²), > 0. Default 1e3.
    initial_frequency_rad_s : float
        Output before the first estimate with complex poles (rad/s), > 0. Default 2π/8.
    """

    dt_s: float = 0.1
    sample_period_s: float = 0.5
    forgetting_factor: float = 0.995
    initial_covariance: float = 1e3
    initial_frequency_rad_s: float = 2.0 * math.pi / 8.0

    def __post_init__(self) -> None:
        o = "WaveFrequencyConfig"
        set_ = object.__setattr__
        set_(self, "dt_s", _positive(o, "dt_s", self.dt_s, "s"))
        set_(self, "sample_period_s", _positive(o, "sample_period_s", self.sample_period_s, "s"))
        _ratio(o, self.sample_period_s, self.dt_s)
        lam = _number(o, "forgetting_factor", self.forgetting_factor, "(-)")
        if not 0.0 < lam <= 1.0:
            raise ValueError(
                f"{o}: forgetting_factor = {self.forgetting_factor!r}, expected in (0, 1] (-)"
            )
        set_(self, "forgetting_factor", lam)
        set_(
            self,
            "initial_covariance",
            _positive(o, "initial_covariance", self.initial_covariance, "1/m²"),
        )
        set_(
            self,
            "initial_frequency_rad_s",
            _positive(o, "initial_frequency_rad_s", self.initial_frequency_rad_s, "rad/s"),
        )


@dataclass(slots=True)
class WaveFrequencyState:
    """Mutable state of :class:`WaveFrequencyEstimator` (plain floats, updated in place).

    Attributes
    ----------
    a1, a2 : float
        AR(2) parameters θ = [a1, a2] (-).
    p11, p12, p22 : float
        Symmetric RLS covariance P (1/m²).
    y1, y2 : float
        y(t-1), y(t-2) (m) at the model rate.
    held_m : float
        Last valid sample (m).
    omega_rad_s : float
        Latest natural frequency ω_n (rad/s).
    damped_omega_rad_s : float
        Latest damped frequency ω_d = arg(z)/Δt (rad/s).
    calls, samples, dropped, updates : int
        Calls, model samples, dropped samples and RLS updates so far.
    """

    a1: float
    a2: float
    p11: float
    p12: float
    p22: float
    y1: float = 0.0
    y2: float = 0.0
    held_m: float = 0.0
    omega_rad_s: float = 0.0
    damped_omega_rad_s: float = 0.0
    calls: int = 0
    samples: int = 0
    dropped: int = 0
    updates: int = 0


class WaveFrequencyEstimator:
    """Wave frequency from an AR(2) model fitted by RLS with forgetting (christiansen sect. 2.11).

    Model (christiansen-2013 sect. 2.11): A(q) y(t) = e(t) with A second order, the predictor
    ŷ(t, θ) = [y(t-1), y(t-2)] θ, θ = [a1, a2]ᵀ, and ε(t) = y(t) - ŷ(t) minimised by least
    squares. Here recursive least squares with forgetting factor λ:

        K = P φ / (λ + φᵀ P φ),   θ ← θ + K ε,   P ← (P - K φᵀ P)/λ,   φ = [y(t-1), y(t-2)]ᵀ.

    The wave frequency is the natural frequency of Â(q) = 1 - a1 q⁻¹ - a2 q⁻²: its poles are
    z = r e^{±iθ} with r = √(-a2), cos θ = a1/(2r) (complex when a1² + 4 a2 < 0), and

        ω_n = |ln z| / Δt = √(ln² r + θ²)/Δt,   ω_d = θ/Δt = arccos(a1/(2√(-a2)))/Δt.

    For a pure sinusoid r → 1 and both equal its frequency. For an irregular sea the AR(2)
    least-squares fit tracks roughly the mean zero-crossing frequency √(m₂/m₀) rather than the
    spectral peak (JONSWAP γ = 3.3: about 1.25 ω_p), see ``tests/test_forecast.py``. With real
    poles the estimate is held. P is not divided by λ while its trace exceeds p₀ (no wind-up).

    Parameters
    ----------
    config : WaveFrequencyConfig
    """

    __slots__ = ("_config", "_decim")

    def __init__(self, config: WaveFrequencyConfig | None = None) -> None:
        self._config = WaveFrequencyConfig() if config is None else config
        self._decim = _ratio(
            "WaveFrequencyEstimator", self._config.sample_period_s, self._config.dt_s
        )

    @property
    def config(self) -> WaveFrequencyConfig:
        """The configuration."""
        return self._config

    def init_state(self) -> WaveFrequencyState:
        """θ = 0, P = p₀ I, frequency = the configured initial value."""
        p0 = self._config.initial_covariance
        f0 = self._config.initial_frequency_rad_s
        return WaveFrequencyState(0.0, 0.0, p0, 0.0, p0, omega_rad_s=f0, damped_omega_rad_s=f0)

    def step(
        self, state: WaveFrequencyState, sample_m: float, valid: bool = True
    ) -> tuple[WaveFrequencyState, float]:
        """Take one elevation sample (m); return the state and the wave frequency ω_n (rad/s).

        A dropped sample (``valid=False`` or non-finite) is replaced by the held last value
        for the regressors and skips the RLS update.
        """
        c = self._config
        state.calls += 1
        ok = valid and math.isfinite(sample_m)
        if ok:
            state.held_m = float(sample_m)
        else:
            state.dropped += 1
        if (state.calls - 1) % self._decim != 0:
            return state, state.omega_rad_s
        y = state.held_m
        state.samples += 1
        if ok and state.samples > 2:
            f1, f2 = state.y1, state.y2
            pf1 = state.p11 * f1 + state.p12 * f2
            pf2 = state.p12 * f1 + state.p22 * f2
            lam = c.forgetting_factor
            den = lam + f1 * pf1 + f2 * pf2
            k1, k2 = pf1 / den, pf2 / den
            err = y - (state.a1 * f1 + state.a2 * f2)
            state.a1 += k1 * err
            state.a2 += k2 * err
            # P - K (P φ)ᵀ, symmetric
            p11 = state.p11 - k1 * pf1
            p12 = state.p12 - k1 * pf2
            p22 = state.p22 - k2 * pf2
            scale = 1.0 / lam if p11 + p22 < 2.0 * c.initial_covariance else 1.0
            state.p11, state.p12, state.p22 = p11 * scale, p12 * scale, p22 * scale
            state.updates += 1
            a1, a2 = state.a1, state.a2
            if a2 < 0.0 and a1 * a1 + 4.0 * a2 < 0.0:
                r = math.sqrt(-a2)
                theta = math.acos(max(-1.0, min(1.0, a1 / (2.0 * r))))
                dt = c.sample_period_s
                state.damped_omega_rad_s = theta / dt
                state.omega_rad_s = math.hypot(math.log(r), theta) / dt
        state.y2 = state.y1
        state.y1 = y
        return state, state.omega_rad_s
