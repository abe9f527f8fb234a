"""Offline design of the platform Kalman filter (:class:`controller.estimators.PlatformKF`).

This module MAY import ``plant`` (offline work); the runtime (:mod:`controller.runtime`) only
loads the artefact it writes, ``controller/presets/designs/<preset>_observer.npz`` + ``.json``.

Model (per scheduled wind U, default 8, 11, 14, 18 and 22 m/s)
--------------------------------------------------------------
The radiation-reduced linear model of :mod:`controller.design.linear` is truncated to the
filter states

.. math:: x = (x_s, \\varphi, s, \\dot x_s, \\dot\\varphi, \\dot s)

(surge m, platform pitch rad, tower-top modal coordinate m and their rates; heave is nearly
decoupled and unobservable from these sensors). The measured rotor speed and blade pitch are
*known inputs* (their columns of A), :math:`u = (\\tilde\\omega, \\tilde\\theta)`, deviations
from the operating point :math:`(\\omega_{op}, \\theta_{op})`:

.. math:: \\dot x = A x + B_u u + G_w F^w,

with :math:`G_w` the columns of :math:`B_F` for the surge force (N) and pitch moment (N m).
The wave forces are not states: they enter as white process noise of intensity
:math:`Q_c = G_w\\,\\mathrm{diag}(\\pi |X_j(\\omega_p)|^2 S_\\eta(\\omega_p))\\,G_w^T` at the
design sea state's peak frequency :math:`\\omega_p = 2\\pi/T_p` (JONSWAP, default
:math:`H_s` 3 m, :math:`T_p` 9.5 s), plus a small model-error intensity on the rates.

Measurements (deviations from the operating point, the order of
:data:`MEASUREMENT_NAMES`): the nacelle IMU's *kinematic* fore-aft acceleration
:math:`a = \\ddot x_s + h_n\\ddot\\varphi + \\ddot s` (the plant's sensor has no gravity
component; :math:`h_n` the tower-top height), so
:math:`H_a = c_a A_{rates}`, :math:`D_a = c_a B_{u,rates}`, :math:`c_a = (1, h_n, 1)`; the
gyro pitch rate; the AHRS pitch; the GNSS surge. R is diagonal: each sensor's noise variance
plus its bias squared (the filter has no bias states) and, for the accelerometer, the direct
wave-force part :math:`g_a C_F g_a^T`, :math:`g_a = c_a G_{w,rates}`,
:math:`C_F = \\int \\mathrm{Re}(X X^H) S_\\eta\\,d\\omega`.

The artefact stores the *continuous* matrices (A, B_u, Q_c) with H, D, R and the operating
points; the runtime discretises them at its own control period (zero-order hold by the block
matrix exponential, Q by Van Loan's method, :func:`controller.runtime.discretize`), so one
artefact serves 40 Hz and 100 Hz runs. The recipe is the one that
``tests/test_estimators.py::_design`` validated against the nonlinear plant (there with the
gravity-tilted accelerometer row; here the plant's kinematic IMU).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from plant.platform import FloatingParams

__all__ = [
    "INPUT_NAMES",
    "MEASUREMENT_NAMES",
    "STATE_NAMES",
    "ObserverSettings",
    "design_observer",
]

FloatArray = npt.NDArray[np.float64]

#: Filter states (indices 0, 2, 3, 4, 6, 7 of the 11-state reduced model).
STATE_NAMES = (
    "surge_m",
    "pitch_rad",
    "tower_top_m",
    "surge_rate_m_s",
    "pitch_rate_rad_s",
    "tower_top_rate_m_s",
)
#: Known inputs (deviations from the operating point).
INPUT_NAMES = ("rotor_speed_dev_rad_s", "blade_pitch_dev_rad")
#: Measurements (deviations from the operating point), rows of H.
MEASUREMENT_NAMES = ("nacelle_acc_m_s2", "pitch_rate_rad_s", "pitch_rad", "surge_m")

_IDX = [0, 2, 3, 4, 6, 7]
_RATES = [4, 6, 7]
_INPUTS = [8, 9]


@dataclass(frozen=True)
class ObserverSettings:
    """Settings of the observer design (SI units in the names).

    Attributes
    ----------
    wind_grid_m_s : tuple of float
        Scheduled winds (m/s); the runtime uses the design nearest its wind estimate.
    design_hs_m, design_tp_s, design_gamma : float
        JONSWAP sea state of the wave-force process noise (m, s, -).
    rate_model_error_psd : tuple of float
        Extra process-noise intensity on the surge, pitch and tower rates
        ((m/s)^2/s, (rad/s)^2/s, (m/s)^2/s).
    acc_std_m_s2, acc_bias_m_s2, gyro_std_rad_s, gyro_bias_rad_s, attitude_std_rad,
    attitude_bias_rad, gnss_std_m : float
        Sensor noise and bias of :func:`sensors.channel.default_floating_suite`.
    gate_probability : float
        Chi-square gate probability per channel.
    degraded_after_s : float
        A channel missing for longer than this makes the filter ``degraded`` (s); the runtime
        converts it to a count of cycles at its control period.
    """

    wind_grid_m_s: tuple[float, ...] = (8.0, 11.0, 14.0, 18.0, 22.0)
    design_hs_m: float = 3.0
    design_tp_s: float = 9.5
    design_gamma: float = 3.3
    rate_model_error_psd: tuple[float, float, float] = (1e-4, 1e-7, 1e-3)
    acc_std_m_s2: float = 0.01
    acc_bias_m_s2: float = 0.02
    gyro_std_rad_s: float = 6e-4
    gyro_bias_rad_s: float = 1e-3
    attitude_std_rad: float = math.radians(0.05)
    attitude_bias_rad: float = math.radians(0.1)
    gnss_std_m: float = 0.02
    gate_probability: float = 0.999
    degraded_after_s: float = 0.5

    def as_dict(self) -> dict[str, object]:
        """JSON-ready dict."""
        d = asdict(self)
        d["wind_grid_m_s"] = list(self.wind_grid_m_s)
        d["rate_model_error_psd"] = list(self.rate_model_error_psd)
        return d


def _one_point(
    params: FloatingParams, hydro: str, wind_m_s: float, s: ObserverSettings, h_nac: float
) -> dict[str, FloatArray]:
    """Continuous filter model at one wind (module docstring); ``h_nac`` tower-top height (m)."""
    from controller.design.linear import linear_model, reduce_radiation  # noqa: PLC0415
    from plant.hydro.wamit import load_hydro_preset  # noqa: PLC0415
    from plant.waves import JonswapSpectrum, spectral_density  # noqa: PLC0415

    model = reduce_radiation(linear_model(params, wind_m_s), params)
    a_full = model.a
    A = a_full[np.ix_(_IDX, _IDX)]
    Bu = a_full[np.ix_(_IDX, _INPUTS)]
    Gw = model.b_wave[np.ix_(_IDX, [0, 2])]
    exc = load_hydro_preset(hydro).excitation.select((0, 4), 0.0)
    spec = JonswapSpectrum(s.design_hs_m, s.design_tp_s, s.design_gamma)
    wp = 2.0 * math.pi / s.design_tp_s
    mag = np.array([np.interp(wp, exc.omega_rad_s, np.abs(exc.force[:, 0, j])) for j in range(2)])
    s_eta = float(spectral_density(spec, np.array([wp]))[0])
    Qc = Gw @ np.diag(math.pi * mag**2 * s_eta) @ Gw.T
    Qc += np.diag([0.0, 0.0, 0.0, *s.rate_model_error_psd])
    Qc = 0.5 * (Qc + Qc.T)
    c_acc = np.array([1.0, h_nac, 1.0])
    H = np.zeros((4, 6))
    D = np.zeros((4, 2))
    H[0] = c_acc @ A[3:6]
    D[0] = c_acc @ Bu[3:6]
    H[1, 4] = H[2, 1] = H[3, 0] = 1.0
    w = exc.omega_rad_s
    X = exc.force[:, 0, :]
    s_w = spectral_density(spec, w)
    C_F = np.trapezoid((X[:, :, None] * X[:, None, :].conj()).real * s_w[:, None, None], w, axis=0)
    g_a = c_acc @ Gw[3:6]
    R = np.diag(
        [
            s.acc_std_m_s2**2 + s.acc_bias_m_s2**2 + float(g_a @ C_F @ g_a),
            s.gyro_std_rad_s**2 + s.gyro_bias_rad_s**2,
            s.attitude_std_rad**2 + s.attitude_bias_rad**2,
            s.gnss_std_m**2,
        ]
    )
    x_op = model.x_op[_IDX]
    u_op = model.x_op[_INPUTS]
    return {"A": A, "Bu": Bu, "Qc": Qc, "H": H, "D": D, "R": R, "x_op": x_op, "u_op": u_op}


def design_observer(
    preset: str = "iea15mw_volturnus",
    out_dir: str | Path | None = None,
    settings: ObserverSettings | None = None,
) -> dict[str, Path]:
    """Design the platform KF models at the scheduled winds and write the artefact.

    Parameters
    ----------
    preset : str
        Floating preset (:func:`plant.platform.load_floating`); its name is also the hydro
        data set for the wave excitation.
    out_dir : str or Path, optional
        Output folder (default :data:`controller.design.DEFAULT_DESIGN_DIR`).
    settings : ObserverSettings, optional
        Design settings (defaults documented on the class).

    Returns
    -------
    dict
        ``{"observer_npz": path, "observer_json": path}``. Arrays (k = number of winds):
        ``wind_m_s`` (k,), ``A`` (k, 6, 6) 1/s, ``Bu`` (k, 6, 2), ``Qc`` (k, 6, 6),
        ``H`` (k, 4, 6), ``D`` (k, 4, 2), ``R`` (k, 4, 4), ``x_op`` (k, 6), ``u_op`` (k, 2)
        (rotor speed rad/s, blade pitch rad).
    """
    from controller.design import DEFAULT_DESIGN_DIR, _commit  # noqa: PLC0415
    from plant.platform import load_floating, read_floating_preset  # noqa: PLC0415

    s = settings or ObserverSettings()
    params = load_floating(preset)
    fp, _, _ = read_floating_preset(preset)
    h_nac = float(fp.tower_top_height_m)
    points = [_one_point(params, str(preset), w, s, h_nac) for w in s.wind_grid_m_s]
    arrays = {k: np.stack([p[k] for p in points]) for k in points[0]}
    out = Path(out_dir) if out_dir is not None else DEFAULT_DESIGN_DIR
    out.mkdir(parents=True, exist_ok=True)
    npz = out / f"{Path(str(preset)).stem}_observer.npz"
    arrays["wind_m_s"] = np.array(s.wind_grid_m_s)
    np.savez_compressed(npz, allow_pickle=False, **arrays)
    meta = {
        "format_version": 1,
        "kind": "platform_kf_schedule",
        "preset": str(preset),
        "control_period_s": None,  # continuous models: discretised at run time
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "commit": _commit(),
        "state_names": list(STATE_NAMES),
        "input_names": list(INPUT_NAMES),
        "measurement_names": list(MEASUREMENT_NAMES),
        "model": "continuous: x' = A x + Bu u + w, E[w w^T] = Qc delta; z = H x + D u + v, "
        "E[v v^T] = R; deviations from x_op, u_op",
        "settings": s.as_dict(),
    }
    js = npz.with_suffix(".json")
    js.write_text(json.dumps(meta, indent=2) + "\n")
    return {"observer_npz": npz, "observer_json": js}
