"""Wave feedforward by model inversion (al-2019 ch. 4), offline design.

Control law
-----------
For the rotor speed y = ω (rad/s) and one FF input u (generator torque demand in N m below
``torque_below_m_s`` = 17 m/s, collective pitch demand in rad above; al-2019 sect. 4-1-3 and
4-3), the full-order feedforward of al-2019 eq. (4-6), (4-13), (4-14) is

.. math::

    u_{ff}(s) = -g\\,\\frac{G_{\\eta\\to\\omega}(s)}{G_{u\\to\\omega}(s)}\\,\\eta_0(s),\\qquad
    G_{\\eta\\to\\omega}(j\\omega) = G_{F\\to\\omega}(j\\omega)\\,X(\\omega),

with :math:`G_{F\\to\\omega} = C_\\omega (j\\omega I - A)^{-1} B_F` the response of the open-loop
linear model (:mod:`controller.design.linear`) to the wave forces (surge N, heave N,
pitch N m) and :math:`X(\\omega)` the WAMIT excitation per metre of elevation at the platform
origin (the *data*, linearly interpolated, as the plant's :func:`plant.waves.excitation_force`
uses it; not the fitted excitation model). The feedback loop is not part of the target: with
the FF added to the command, the closed loop is
:math:`Y = (G_\\eta - G_u C_{ff})\\eta / (1 + G_u C)` (al-2019 eq. 4-10), so
:math:`C_{ff} = G_\\eta/G_u` cancels the numerator whatever the feedback C is.

Preview alignment
-----------------
The forecaster delivers :math:`\\hat\\eta_0(t + t_d)`, t_d = 10 s (al-2019 sect. 3-4). The filter
is driven by that forecast and must output :math:`u_{ff}(t)`, so its target response is

.. math::

    F(j\\omega) = -\\,\\frac{G_{\\eta\\to\\omega}(j\\omega)}{G_{u\\to\\omega}(j\\omega)}
    \\,e^{-j\\omega t_d}

(the filter delays the forecast by t_d minus the anticipation the inverse needs). The
impulse response of :math:`G_\\eta/G_u` reaches about 10 s into the past (the excitation is
non-causal over the platform's length and the inverse adds lead); with t_d = 10 s about 2 %
of its energy remains non-causal at 7.1 m/s, which is why the whole preview is spent in the
filter (shorter residual previews gave larger fit errors).

Realisation (why not pole-zero bookkeeping)
-------------------------------------------
Instead of building G_η/G_u in pole-zero form and mirroring its unstable poles, F(jω) is
fitted directly by a stable rational function (vector fitting, Gustavsen & Semlyen 1999, with
relaxation; unstable poles are mirrored across the imaginary axis at every iteration, which is
the al-2019 eq. (4-15) operation applied inside the fit). The fit is weighted 1 on the wave
band f^we = 0.05..0.333 Hz (al-2019 eq. 4-3) and ``out_of_band_weight`` outside, so its order
plays the role of the balanced truncation over the band (al-2019: order 8 for torque, 12 for
pitch; here 24, because the target uses the excitation *data* with its notches). Then:

1. High-pass :math:`H(s) = s/(s + \\omega_{hp})`, :math:`\\omega_{hp} = 2\\pi/25` rad/s
   (al-2019 sect. 4-3-1), in series; the fit target is :math:`F/H` so that the product matches
   F over the band (the seed accepts the high-pass phase lead; here it is compensated in band
   and acts only below it).
2. Tustin discretisation at the control period T_s (0.025 s):
   :math:`z_{k+1} = A_d z_k + b_d \\hat\\eta_k`, :math:`u_k = c_d z_k + d_d \\hat\\eta_k`.

The gain g is applied at run time: al-2019 Tab. 5-1 per load case, at the Tab. 2-2 winds
(:data:`FF_GAIN_TABLE`), interpolated linearly in the wind and held at the ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
from scipy.signal import cont2discrete

from controller.design.linear import LinearModel

__all__ = [
    "FF_GAIN_TABLE",
    "FF_STATE_INDEX",
    "FF_WIND_GRID_M_S",
    "HIGH_PASS_RAD_S",
    "WAVE_BAND_RAD_S",
    "FfDesign",
    "band_errors",
    "design_wave_ff",
    "discrete_response",
    "target_response",
    "vector_fit",
    "write_wave_ff_artefact",
]

FloatArray = npt.NDArray[np.float64]
ComplexArray = npt.NDArray[np.complex128]

#: al-2019 Tab. 2-2 winds (m/s) and Tab. 5-1 FF gains g per load case 1..7.
FF_GAIN_TABLE: dict[str, tuple[tuple[float, ...], tuple[float, ...]]] = {
    "balanced": (
        (5.0, 7.1, 10.3, 13.9, 17.9, 22.1, 25.0),
        (0.25, 0.12, 0.075, 0.267, 0.28, 0.070, 0.060),
    ),
    "max_performance": (
        (5.0, 7.1, 10.3, 13.9, 17.9, 22.1, 25.0),
        (0.25, 0.35, 0.35, 0.65, 0.73, 0.700, 0.62),
    ),
}

#: Wave band f^we of al-2019 eq. (4-3): 0.05..0.333 Hz, in rad/s.
WAVE_BAND_RAD_S = (2.0 * math.pi * 0.05, 2.0 * math.pi / 3.0)
#: High-pass corner 1/25 Hz (al-2019 sect. 4-3-1), rad/s.
HIGH_PASS_RAD_S = 2.0 * math.pi / 25.0
#: States of the 11-state reduced model kept for the FF design: heave and heave rate are
#: dropped (al-2019's 2-D model: surge, pitch, rotor, tower fore-aft; the reduced model's
#: heave mode is nearly undamped at 0.307 rad/s and only weakly coupled to the rotor).
FF_STATE_INDEX = (0, 2, 3, 4, 6, 7, 8, 9, 10)
_OMEGA_ROW = 0  # row of C: rotor speed


@dataclass(frozen=True, eq=False)
class FfDesign:
    """One discrete FF filter: η̂₀(t + t_d) (m) → u_ff (N m or rad), before the gain g.

    Attributes
    ----------
    wind_m_s : float
        Design wind (m/s).
    input_name : str
        ``"generator_torque_nm"`` or ``"blade_pitch_rad"``.
    a : (n, n) array
        Discrete state matrix A_d (-).
    b, c : (n,) arrays
        Input and output vectors (state per m; output unit per state).
    d : float
        Direct term (output unit per m).
    dt_s : float
        Sample period T_s (s).
    delay_s : float
        Preview t_d of the forecast the filter expects (s).
    order : int
        n (fit order + 1 for the high-pass).
    band_error_rel_max : float
        max over the band of |F_d − F| / max|F| (-), F_d the discrete response.
    band_error_rel_pointwise_p95 : float
        95th percentile over the band of |F_d − F| / |F| (-).
    magnitude_error_max : float
        max of | |F_d|/|F| − 1 | where |F| ≥ 0.3 max|F| (-).
    phase_error_max_deg : float
        max of |∠F_d − ∠F| where |F| ≥ 0.3 max|F| (deg).
    spectral_radius : float
        max |eig(A_d)| (-), < 1.
    """

    wind_m_s: float
    input_name: str
    a: FloatArray
    b: FloatArray
    c: FloatArray
    d: float
    dt_s: float
    delay_s: float
    order: int
    band_error_rel_max: float
    band_error_rel_pointwise_p95: float
    magnitude_error_max: float
    phase_error_max_deg: float
    spectral_radius: float


def _freq(a: FloatArray, b: FloatArray, c: FloatArray, w: FloatArray) -> ComplexArray:
    """C (jωI − A)⁻¹ B for each ω: shape (len(ω), ny, nu)."""
    n = a.shape[0]
    eye = np.eye(n)
    return np.asarray([c @ np.linalg.solve(1j * wi * eye - a, b) for wi in w], dtype=np.complex128)


def target_response(
    model: LinearModel,
    omega_tf_rad_s: FloatArray,
    x_tf: ComplexArray,
    omega_rad_s: FloatArray,
    delay_s: float = 10.0,
    torque_below_m_s: float = 17.0,
) -> ComplexArray:
    """Target F(jω) = −G_F→ω X(ω) e^{−jωt_d} / G_u→ω of the FF filter (module docstring).

    Parameters
    ----------
    model : LinearModel
        Radiation-reduced model (11 states); heave is dropped (:data:`FF_STATE_INDEX`).
    omega_tf_rad_s, x_tf : arrays
        Excitation data: frequencies (rad/s) and X (n, 3) in N/m, N/m, N m/m (e^{+jωt}).
    omega_rad_s : array
        Frequencies of the result (rad/s); X is interpolated linearly (re, im), zero outside.
    delay_s : float
        Forecast preview t_d (s).
    torque_below_m_s : float
        Torque FF below this wind, pitch FF at and above (m/s).

    Returns
    -------
    array (len(ω),) complex
        F in N m/m (torque) or rad/m (pitch).
    """
    idx = list(FF_STATE_INDEX)
    iu = 1 if model.wind_m_s < torque_below_m_s else 0
    a = model.a[np.ix_(idx, idx)]
    c = model.c[_OMEGA_ROW : _OMEGA_ROW + 1, idx]
    bu = model.b[idx, iu : iu + 1]
    bf = model.b_wave[idx, :]
    w = np.asarray(omega_rad_s, dtype=np.float64)
    xi = np.stack(
        [
            np.interp(w, omega_tf_rad_s, x_tf[:, j].real, left=0.0, right=0.0)
            + 1j * np.interp(w, omega_tf_rad_s, x_tf[:, j].imag, left=0.0, right=0.0)
            for j in range(x_tf.shape[1])
        ],
        axis=1,
    )
    g_eta = np.sum(_freq(a, bf, c, w)[:, 0, :] * xi, axis=1)
    g_u = _freq(a, bu, c, w)[:, 0, 0]
    return np.asarray(-g_eta / g_u * np.exp(-1j * w * delay_s), dtype=np.complex128)


def _real_basis(s: ComplexArray, p: ComplexArray) -> ComplexArray:
    """Partial-fraction basis with real coefficients (pairs: 1/(s−p) ± 1/(s−p̄))."""
    phi = 1.0 / (s[:, None] - p[None, :])
    cols: list[ComplexArray] = []
    i = 0
    while i < p.size:
        if p[i].imag != 0.0:
            cols += [phi[:, i] + phi[:, i + 1], 1j * (phi[:, i] - phi[:, i + 1])]
            i += 2
        else:
            cols.append(phi[:, i])
            i += 1
    return np.stack(cols, axis=1)


def _pole_matrix(p: ComplexArray) -> tuple[FloatArray, FloatArray]:
    """Real block-diagonal A_p and b_p whose eigenvalues are p (pairs adjacent)."""
    n = p.size
    ap = np.zeros((n, n))
    bp = np.zeros(n)
    i = 0
    while i < n:
        if p[i].imag != 0.0:
            ap[i : i + 2, i : i + 2] = [[p[i].real, p[i].imag], [-p[i].imag, p[i].real]]
            bp[i] = 2.0
            i += 2
        else:
            ap[i, i] = p[i].real
            bp[i] = 1.0
            i += 1
    return ap, bp


def _sorted_stable(z: ComplexArray) -> ComplexArray:
    """Mirror right-half-plane roots (p → −p̄) and order them: reals, then pairs (p, p̄)."""
    z = np.where(z.real > 0.0, -z.real + 1j * z.imag, z)
    tol = 1e-9
    reals = [complex(v.real) for v in z if abs(v.imag) <= tol * max(1.0, abs(v))]
    upper = [v for v in z if v.imag > tol * max(1.0, abs(v))]
    out = reals + [q for v in upper for q in (complex(v), complex(np.conj(v)))]
    return np.asarray(out, dtype=np.complex128)


def vector_fit(
    omega_rad_s: FloatArray,
    f: ComplexArray,
    weight: FloatArray,
    order: int,
    iterations: int = 40,
    initial_damping: float = 0.05,
) -> tuple[FloatArray, FloatArray, FloatArray, float]:
    """Stable rational fit F(jω) ≈ c (jωI − A)⁻¹ b + d by relaxed vector fitting.

    Starting poles −ζβ ± jβ, β spread linearly over the fitted frequencies; each iteration
    solves the linearised problem σ(s)F(s) ≈ Σ r_i/(s − p_i) + d with
    σ(s) = Σ r̃_i/(s − p_i) + d̃ (relaxation: Re Σ σ = N), takes the zeros of σ as the new
    poles and mirrors any in the right half-plane. Residues and d by weighted least squares.

    Parameters
    ----------
    omega_rad_s : array
        Frequencies (rad/s), > 0.
    f : array complex
        Values to fit.
    weight : array
        Least-squares weights (-).
    order : int
        Number of poles (even: complex pairs).
    iterations : int
        Pole relocation iterations.
    initial_damping : float
        ζ of the starting poles.

    Returns
    -------
    a : (order, order) array
        Real block-diagonal (modal) state matrix, all eigenvalues with Re < 0 (1/s).
    b, c : (order,) arrays
    d : float
    """
    s = np.asarray(1j * np.asarray(omega_rad_s, dtype=np.float64), dtype=np.complex128)
    n_pts = s.size
    beta = np.linspace(float(omega_rad_s.min()), float(omega_rad_s.max()), order // 2)
    p = np.asarray(
        [
            q
            for bt in beta
            for q in (-initial_damping * bt + 1j * bt, -initial_damping * bt - 1j * bt)
        ],
        dtype=np.complex128,
    )
    scale = float(np.sqrt(np.sum(weight**2)))
    for _ in range(iterations):
        n = p.size
        r = _real_basis(s, p)
        m = np.hstack([r, np.ones((n_pts, 1)), -f[:, None] * r, -f[:, None]]) * weight[:, None]
        mm = np.vstack([m.real, m.imag])
        relax = np.concatenate([np.zeros(n + 1), np.real(r.sum(axis=0)), [n_pts]])
        mm = np.vstack([mm, relax * scale / n_pts])
        rhs = np.zeros(2 * n_pts + 1)
        rhs[-1] = scale
        x = np.linalg.lstsq(mm, rhs, rcond=None)[0]
        c_sig = x[n + 1 : 2 * n + 1]
        d_sig = float(x[-1])
        if abs(d_sig) < 1e-8:
            d_sig = 1e-8 if d_sig >= 0.0 else -1e-8
        ap, bp = _pole_matrix(p)
        lam = np.asarray(np.linalg.eigvals(ap - np.outer(bp, c_sig) / d_sig), dtype=np.complex128)
        p = _sorted_stable(lam)
    r = _real_basis(s, p)
    m = np.hstack([r, np.ones((n_pts, 1))]) * weight[:, None]
    x = np.linalg.lstsq(
        np.vstack([m.real, m.imag]),
        np.concatenate([(f * weight).real, (f * weight).imag]),
        rcond=None,
    )[0]
    ap, bp = _pole_matrix(p)
    # Realisation: basis column k is e_kᵀ(sI − A_p)⁻¹ b_p for the block form above.
    return ap, bp, x[: p.size].copy(), float(x[-1])


def design_wave_ff(
    model: LinearModel,
    omega_tf_rad_s: FloatArray,
    x_tf: ComplexArray,
    dt_s: float = 0.025,
    delay_s: float = 10.0,
    torque_below_m_s: float = 17.0,
    order: int = 24,
    out_of_band_weight: float = 0.1,
    fit_range_rad_s: tuple[float, float] = (0.1, 6.0),
    n_points: int = 600,
) -> FfDesign:
    """Wave-FF filter at one operating point (module docstring).

    Parameters
    ----------
    model : LinearModel
        Radiation-reduced model (:func:`controller.design.linear.reduce_radiation`).
    omega_tf_rad_s, x_tf : arrays
        Excitation data (:func:`controller.design.linear.excitation_transfer`).
    dt_s : float
        Control period T_s (s).
    delay_s : float
        Forecast preview t_d (s).
    torque_below_m_s : float
        Torque FF below, pitch FF at and above this wind (m/s); al-2019: 17.
    order : int
        Order of the rational fit (the filter has one more state, the high-pass).
    out_of_band_weight : float
        Fit weight outside the wave band (1 inside).
    fit_range_rad_s : (float, float)
        Frequencies fitted (rad/s).
    n_points : int
        Number of fitted frequencies.

    Returns
    -------
    FfDesign
    """
    w = np.linspace(*fit_range_rad_s, n_points)
    f_target = target_response(model, omega_tf_rad_s, x_tf, w, delay_s, torque_below_m_s)
    hp = 1j * w / (1j * w + HIGH_PASS_RAD_S)
    band = (w >= WAVE_BAND_RAD_S[0]) & (w <= WAVE_BAND_RAD_S[1])
    # Outside the band the fit is pulled towards a roll-off: F tapered to zero above the band
    # (half-cosine to 2 x the upper edge) so forecast noise is not passed at high frequency.
    w_hi = WAVE_BAND_RAD_S[1]
    roll = np.where(
        w <= w_hi, 1.0, 0.5 * (1.0 + np.cos(np.pi * np.clip((w - w_hi) / w_hi, 0.0, 1.0)))
    )
    weight = np.where(band, 1.0, out_of_band_weight) / float(np.max(np.abs(f_target[band])))
    af, bf, cf, df = vector_fit(w, f_target * roll / hp, weight, order)
    # Series: fit then high-pass s/(s + w_hp) = 1 − w_hp/(s + w_hp).
    n = af.shape[0]
    ah = np.zeros((n + 1, n + 1))
    ah[:n, :n] = af
    ah[n, :n] = cf
    ah[n, n] = -HIGH_PASS_RAD_S
    bh = np.concatenate([bf, [df]])[:, None]
    ch = np.concatenate([cf, [-HIGH_PASS_RAD_S]])[None, :]
    dh = np.array([[df]])
    ad, bd, cd, dd, _ = cont2discrete((ah, bh, ch, dh), dt_s, method="bilinear")
    input_name = "generator_torque_nm" if model.wind_m_s < torque_below_m_s else "blade_pitch_rad"
    design = FfDesign(
        wind_m_s=float(model.wind_m_s),
        input_name=input_name,
        a=np.asarray(ad, dtype=np.float64),
        b=np.asarray(bd, dtype=np.float64).ravel(),
        c=np.asarray(cd, dtype=np.float64).ravel(),
        d=float(np.asarray(dd)[0, 0]),
        dt_s=float(dt_s),
        delay_s=float(delay_s),
        order=n + 1,
        band_error_rel_max=0.0,
        band_error_rel_pointwise_p95=0.0,
        magnitude_error_max=0.0,
        phase_error_max_deg=0.0,
        spectral_radius=float(np.max(np.abs(np.linalg.eigvals(ad)))),
    )
    err = band_errors(design, w[band], f_target[band])
    return FfDesign(**{**design.__dict__, **err})


def band_errors(ff: FfDesign, omega_rad_s: FloatArray, f_target: ComplexArray) -> dict[str, float]:
    """Errors of the discrete filter against the target over the given (band) frequencies.

    Returns
    -------
    dict
        ``band_error_rel_max`` = max |F_d − F|/max|F|; ``band_error_rel_pointwise_p95`` =
        95th percentile of |F_d − F|/|F|; ``magnitude_error_max`` and ``phase_error_max_deg``
        over the frequencies where |F| ≥ 0.3 max|F| (away from the excitation notches).
    """
    fd = discrete_response(ff, omega_rad_s)
    diff = np.abs(fd - f_target)
    big = np.abs(f_target) >= 0.3 * np.max(np.abs(f_target))
    mag = np.abs(np.abs(fd[big]) / np.abs(f_target[big]) - 1.0)
    ph = np.degrees(np.abs(np.angle(fd[big] / f_target[big])))
    return {
        "band_error_rel_max": float(np.max(diff) / np.max(np.abs(f_target))),
        "band_error_rel_pointwise_p95": float(np.percentile(diff / np.abs(f_target), 95.0)),
        "magnitude_error_max": float(np.max(mag)),
        "phase_error_max_deg": float(np.max(ph)),
    }


def discrete_response(ff: FfDesign, omega_rad_s: FloatArray) -> ComplexArray:
    """Frequency response c (zI − A_d)⁻¹ b + d of the discrete filter at z = e^{jωT_s}."""
    n = ff.a.shape[0]
    eye = np.eye(n)
    out = [
        complex(ff.c @ np.linalg.solve(np.exp(1j * w * ff.dt_s) * eye - ff.a, ff.b)) + ff.d
        for w in np.asarray(omega_rad_s, dtype=np.float64)
    ]
    return np.asarray(out, dtype=np.complex128)


#: Scheduled winds of the shipped FF artefact (m/s): 4..25 every 1 m/s.
FF_WIND_GRID_M_S = tuple(float(v) for v in range(4, 26))


def write_wave_ff_artefact(
    params: object,
    preset: str,
    out_dir: Path,
    dt_s: float = 0.025,
    delay_s: float = 10.0,
    wind_grid_m_s: tuple[float, ...] = FF_WIND_GRID_M_S,
    torque_below_m_s: float = 17.0,
    hydro_preset: str = "iea15mw_volturnus",
    provenance: dict[str, object] | None = None,
    min_rotor_speed_rad_s: float = 0.0,
) -> dict[str, Path]:
    """Design the FF filters over the wind grid; write ``<preset>_waveff_dt<T_s>.npz`` + ``.json``.

    The npz holds per scheduled wind k: ``a`` (m, n, n), ``b``, ``c`` (m, n), ``d`` (m,),
    ``wind_m_s`` (m,), ``is_pitch`` (m,) and the band errors; the json the settings, the gain
    table g (al-2019 Tab. 5-1) and the provenance.

    Parameters
    ----------
    params : FloatingParams
        Plant parameters (:func:`plant.platform.load_floating`).
    preset : str
        Preset name used for the file names.
    out_dir : Path
        Output folder.
    dt_s, delay_s : float
        Control period and forecast preview (s).
    wind_grid_m_s : tuple of float
        Scheduled winds (m/s).
    torque_below_m_s : float
        Torque FF below, pitch FF at and above (m/s).
    hydro_preset : str
        Hydrodynamic data of the excitation.
    provenance : dict, optional
        Extra metadata (commit, creation time).
    min_rotor_speed_rad_s : float
        Minimum rotor speed of the torque law (rad/s): at winds where the optimal tip-speed
        ratio would run the rotor slower, the filters are designed at this speed (the
        turbine's real operating point, :func:`controller.design.linear.linear_model`).

    Returns
    -------
    dict
        ``{"waveff_npz": path, "waveff_json": path}``.
    """
    import json  # noqa: PLC0415

    from controller.design.linear import (  # noqa: PLC0415
        excitation_transfer,
        linear_model,
        reduce_radiation,
    )

    om, x_tf = excitation_transfer(hydro_preset)
    designs = [
        design_wave_ff(
            reduce_radiation(
                linear_model(params, w, min_rotor_speed_rad_s),  # type: ignore[arg-type]
                params,  # type: ignore[arg-type]
            ),
            om,
            x_tf,
            dt_s=dt_s,
            delay_s=delay_s,
            torque_below_m_s=torque_below_m_s,
        )
        for w in wind_grid_m_s
    ]
    from controller.lqri import artefact_stem  # noqa: PLC0415

    out_dir.mkdir(parents=True, exist_ok=True)
    npz = out_dir / f"{artefact_stem(Path(str(preset)).stem, 'waveff', dt_s)}.npz"
    np.savez_compressed(
        npz,
        wind_m_s=np.array([d.wind_m_s for d in designs]),
        is_pitch=np.array([d.input_name == "blade_pitch_rad" for d in designs]),
        a=np.stack([d.a for d in designs]),
        b=np.stack([d.b for d in designs]),
        c=np.stack([d.c for d in designs]),
        d=np.array([d.d for d in designs]),
        band_error_rel_max=np.array([d.band_error_rel_max for d in designs]),
        magnitude_error_max=np.array([d.magnitude_error_max for d in designs]),
        phase_error_max_deg=np.array([d.phase_error_max_deg for d in designs]),
        spectral_radius=np.array([d.spectral_radius for d in designs]),
    )
    meta: dict[str, object] = {
        "format_version": 1,
        "kind": "wave_feedforward",
        "preset": str(preset),
        "control_period_s": dt_s,
        "hydro_preset": hydro_preset,
        "law": "u_ff = g(U) * (c z + d eta), z' = A z + b eta, eta = forecast eta0(t + t_d)",
        "settings": {
            "control_period_s": dt_s,
            "delay_s": delay_s,
            "torque_below_m_s": torque_below_m_s,
            "wave_band_rad_s": list(WAVE_BAND_RAD_S),
            "high_pass_rad_s": HIGH_PASS_RAD_S,
            "order": designs[0].order,
            "wind_grid_m_s": list(wind_grid_m_s),
            "min_rotor_speed_rad_s": min_rotor_speed_rad_s,
            "scheduling": "all filters run; outputs blended linearly in the scheduling wind",
        },
        "gain_table": {
            k: {"wind_m_s": list(v[0]), "g": list(v[1])} for k, v in FF_GAIN_TABLE.items()
        },
        "band_errors": [
            {
                "wind_m_s": d.wind_m_s,
                "input": d.input_name,
                "band_error_rel_max": d.band_error_rel_max,
                "magnitude_error_max": d.magnitude_error_max,
                "phase_error_max_deg": d.phase_error_max_deg,
                "spectral_radius": d.spectral_radius,
            }
            for d in designs
        ],
        **(provenance or {}),
    }
    js = npz.with_suffix(".json")
    js.write_text(json.dumps(meta, indent=2) + "\n")
    return {"waveff_npz": npz, "waveff_json": js}
