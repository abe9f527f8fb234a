"""Observers of the controller: EKF rotor-effective wind speed and the platform Kalman filter.

Both are *pure cores* in the style of filterpy's functional API: an immutable filter object
built from its configuration, and ``predict(state, u, dt_s) -> state``,
``update(state, z) -> state`` and ``step(state, measurement, dt_s) -> (state, estimate)``
that never mutate their arguments, hold no clock, do no I/O and cost a bounded, fixed amount
of work per call (plain floats for the 3-state EKF, n x n numpy arrays for the platform
filter; nothing grows with time). The arithmetic of both runs in compiled kernels
(:mod:`controller._kernels`, numba); the classes here hold the constants and keep the pure
signatures. The runtime owns the state
between calls. Textbook symbols (F, B, H, D, P, Q, R, K) are used inside this math module only.

Rotor-effective wind-speed EKF (:class:`WindSpeedEKF`)
------------------------------------------------------
christiansen-2013 sect. 2.12 (after Knudsen, Bak and Svenstrup; the same structure as the
ROSCO ``WE_Mode = 2`` estimator of Simley and Pao). States
:math:`x = (\\omega, u_t, u_m)`: rotor speed [rad/s, LSS], turbulent and mean wind [m/s].

.. math::

    J\\,\\dot\\omega &= T_a(\\omega, u_t + u_m, \\theta) - N\\,T_g
        &&\\text{(2.12-1: stiff drivetrain, no losses)}\\\\
    \\dot u_t &= -a(u_m)\\,u_t + n_1,\\quad a(u_m) = \\frac{\\pi u_m}{2 L}
        &&\\text{(2.12-2: turbulence, first-order in } u_t)\\\\
    \\dot u_m &= n_2 &&\\text{(2.12-3: random-walk mean wind)}

with :math:`J` the drivetrain inertia about the low-speed shaft [kg m^2], :math:`N` the
gearbox ratio, :math:`T_g` the generator torque [N m, HSS], :math:`L` the turbulence length
scale [m] (christiansen's "wind speed dynamic parameter related to the turbulence length
scale"; the form :math:`a = \\pi u_m / 2L` is Knudsen's). The aerodynamic torque comes from
the controller's own Cp table:

.. math::

    T_a = \\tfrac12 \\rho \\pi R^3 v^2 \\frac{C_p(\\lambda, \\theta)}{\\lambda}
        = \\tfrac12 \\rho \\pi R^2 \\frac{v^3 C_p}{\\omega},\\qquad
    \\lambda = \\frac{\\omega R}{v},\\quad v = u_t + u_m,

and its partial derivatives (with :math:`k = \\tfrac12\\rho\\pi R^3`,
:math:`C_{p,\\lambda} = \\partial C_p/\\partial\\lambda`)

.. math::

    \\frac{\\partial T_a}{\\partial v} = k\\,v\\Big(\\frac{3 C_p}{\\lambda} - C_{p,\\lambda}\\Big),
    \\qquad
    \\frac{\\partial T_a}{\\partial \\omega} = \\frac{k\\,v\\,R}{\\lambda}
        \\Big(C_{p,\\lambda} - \\frac{C_p}{\\lambda}\\Big).

:math:`C_p` and :math:`C_{p,\\lambda}` are bilinear interpolations of the table and of its
central finite-difference gradient along :math:`\\lambda` (``numpy.gradient``, precomputed
once), clamped at the table edges. Process noise: the stationary variance of :math:`u_t` is
:math:`\\sigma_t^2 = (I_t u_m)^2` for a turbulence intensity :math:`I_t`, so its white-noise
intensity is :math:`q_t = 2 a \\sigma_t^2 = \\pi u_m^3 I_t^2 / L` [(m/s)^2/s] (scaled with the
mean wind); :math:`q_m = \\Delta u_m^2 / T_m` (a drift of :math:`\\Delta u_m` over
:math:`T_m`, default 2 m/s per 600 s); :math:`q_\\omega` covers drivetrain model error.
Measurement: rotor speed :math:`z = \\omega + \\nu`, :math:`\\nu \\sim N(0, \\sigma_z^2)`, from
the generator encoder divided by :math:`N` (:func:`encoder_rotor_speed_std`).

Discretisation over :math:`\\Delta t` (first order, valid for :math:`\\Delta t` well below
:math:`J/|\\partial T_a/\\partial\\omega|` and :math:`1/a`, i.e. seconds):
:math:`\\hat x^- = \\hat x + \\Delta t\\, f(\\hat x, u)`,
:math:`F = I + \\Delta t\\, \\partial f/\\partial x`,
:math:`P^- = F P F^T + \\Delta t\\,\\mathrm{diag}(q_\\omega, q_t, q_m)`. The update is the
scalar Kalman update with the Joseph form (below). Output: :math:`\\hat u = u_m + u_t` with
variance :math:`P_{tt} + P_{mm} + 2 P_{tm}`.

Inputs: the **measured** blade pitch and generator torque (``SensorFrame`` has both). They are
what acts on the rotor; the commands differ from them by the actuator lag and rate limits
(NREL 5 MW: 0.32 s pitch lag, 8 deg/s), which would bias :math:`T_a - N T_g` during every
transient and hence the wind estimate.

Platform Kalman filter (:class:`PlatformKF`)
--------------------------------------------
A discrete linear model from the offline design step (e.g. the plant's linearisation at an
operating point, discretised with a zero-order hold):

.. math::

    x_{k+1} = F x_k + B u_k + w_k,\\quad w_k \\sim N(0, Q);\\qquad
    z_k = H x_k + D u_k + v_k,\\quad v_k \\sim N(0, R).

Predict: :math:`\\hat x^- = F \\hat x + B u`, :math:`P^- = F P F^T + Q`. Update: innovation
:math:`y = z - H \\hat x - D u`, its covariance :math:`S = H P H^T + R`, and per channel the
normalised innovation squared of its marginal, :math:`\\epsilon_i = y_i^2 / S_{ii}`.
Gating: :math:`\\epsilon_i > \\chi^2_{1}(p_i)` rejects channel i for this cycle (counted); an
invalid or non-finite channel is skipped (counted). The accepted channels a are used together:
:math:`K = P H_a^T S_{aa}^{-1}`, :math:`\\hat x \\leftarrow \\hat x + K y_a` and the Joseph form

.. math:: P \\leftarrow (I - K H_a) P (I - K H_a)^T + K R_{aa} K^T,
          \\quad P \\leftarrow \\tfrac12 (P + P^T),

which keeps P symmetric positive definite under rounding and for any gain. A channel whose
consecutive skipped/rejected count exceeds ``max_consecutive_misses`` makes the filter report
``degraded``; one
accepted update of that channel resets its count.

What is hand-written here and why: filterpy (the library of the field) offers the same
predict/update equations as pure functions (``filterpy.kalman.predict/update``, Joseph form
included) and the tests use it as the reference, but it has no innovation gating, no
per-channel validity, reshapes its arguments on every call and ships no type information; the
few lines of Kalman algebra here are written for a fixed shape and a bounded cost instead
(compiled: :mod:`controller._kernels`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from statistics import NormalDist
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from controller import _kernels

__all__ = [
    "CpTable",
    "GuardConfig",
    "GuardState",
    "PlatformEstimate",
    "PlatformKF",
    "PlatformKFConfig",
    "PlatformKFState",
    "PlatformMeasurement",
    "WindEKFConfig",
    "WindEKFMeasurement",
    "WindEKFState",
    "WindEstimate",
    "WindSpeedEKF",
    "chi2_gate",
    "cp_table_from_rosco_text",
    "encoder_rotor_speed_std",
    "guard_step",
    "guarded_wind_step",
]

FloatArray = npt.NDArray[np.float64]


# ------------------------------------------------------------------------------ helpers
def chi2_gate(probability: float) -> float:
    """Chi-square gate of one degree of freedom, :math:`\\chi^2_1(p) = \\Phi^{-1}((1+p)/2)^2`.

    Parameters
    ----------
    probability : float
        Probability p in (0, 1] that a consistent innovation passes the gate (e.g. 0.999 ->
        10.83). p = 1 gives ``inf`` (gate off).

    Returns
    -------
    float
        Threshold on the normalised innovation squared :math:`y^2/s` [-].
    """
    if not 0.0 < probability <= 1.0:
        raise ValueError(f"chi2_gate: probability must be in (0, 1], got {probability!r}")
    if probability == 1.0:
        return math.inf
    return NormalDist().inv_cdf(0.5 + 0.5 * probability) ** 2


def encoder_rotor_speed_std(
    generator_speed_std_rad_s: float, resolution_rad_s: float, gearbox_ratio: float
) -> float:
    """Standard deviation of the rotor speed derived from the generator-speed encoder.

    :math:`\\sigma_\\omega = \\sqrt{\\sigma_g^2 + r^2/12}\\,/\\,N`: white noise
    :math:`\\sigma_g` plus uniform quantisation of step :math:`r`, both on the high-speed
    shaft [rad/s], divided by the gearbox ratio :math:`N`.

    Parameters
    ----------
    generator_speed_std_rad_s : float
        Encoder noise :math:`\\sigma_g` [rad/s, HSS].
    resolution_rad_s : float
        Quantisation step :math:`r` [rad/s, HSS] (0: none).
    gearbox_ratio : float
        :math:`N` [-].

    Returns
    -------
    float
        :math:`\\sigma_\\omega` [rad/s, LSS].
    """
    if generator_speed_std_rad_s < 0.0 or resolution_rad_s < 0.0 or gearbox_ratio <= 0.0:
        raise ValueError("encoder_rotor_speed_std: expected std, resolution >= 0 and ratio > 0")
    return math.sqrt(generator_speed_std_rad_s**2 + resolution_rad_s**2 / 12.0) / gearbox_ratio


def _numbers(line: str) -> list[float] | None:
    try:
        return [float(tok) for tok in line.split()]
    except ValueError:
        return None


def cp_table_from_rosco_text(text: str) -> CpTable:
    """Read the power-coefficient part of a ROSCO-format ``Cp_Ct_Cq`` text (minimal parser).

    The file holds number blocks separated by ``#`` comment lines, in this order: blade pitch
    [deg] (matrix columns), tip-speed ratio [-] (matrix rows), wind speed(s) [m/s], then the
    Cp matrix (one row per TSR; Ct and Cq follow and are ignored). Blank lines do not separate
    blocks.

    Parameters
    ----------
    text : str
        File contents.

    Returns
    -------
    CpTable

    Raises
    ------
    ValueError
        If fewer than four number blocks are found or the Cp block has the wrong size.
    """
    blocks: list[list[float]] = []
    current: list[float] | None = None
    for raw in text.splitlines():
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            current = None
            continue
        values = _numbers(line)
        if values is None:
            raise ValueError(f"cp_table_from_rosco_text: not a number row: {line[:60]!r}")
        if current is None:
            current = []
            blocks.append(current)
        current.extend(values)
    if len(blocks) < 4:
        raise ValueError(
            f"cp_table_from_rosco_text: expected pitch, TSR, wind and Cp blocks, got {len(blocks)}"
        )
    pitch_deg, tsr, cp_flat = blocks[0], blocks[1], blocks[3]
    if len(cp_flat) != len(pitch_deg) * len(tsr):
        raise ValueError(
            f"cp_table_from_rosco_text: Cp block has {len(cp_flat)} numbers, expected "
            f"{len(tsr)} TSR x {len(pitch_deg)} pitch = {len(tsr) * len(pitch_deg)}"
        )
    cp = np.array(cp_flat, dtype=np.float64).reshape(len(tsr), len(pitch_deg))
    return CpTable(np.radians(pitch_deg), np.array(tsr, dtype=np.float64), cp)


# ------------------------------------------------------------------------------ Cp table
@dataclass(frozen=True, eq=False)
class CpTable:
    """Power coefficient on a (TSR, pitch) grid with its TSR gradient, for scalar lookups.

    Parameters
    ----------
    pitch_rad : array_like, shape (m,)
        Blade pitch of the columns [rad], strictly increasing, m >= 2.
    tsr : array_like, shape (n,)
        Tip-speed ratio of the rows [-], strictly increasing, positive, n >= 2.
    cp : array_like, shape (n, m)
        :math:`C_p(\\lambda_i, \\theta_j)` [-] (ROSCO orientation: rows TSR, columns pitch).

    Notes
    -----
    :meth:`lookup` interpolates bilinearly, :math:`C = c_0 + a c_1 + b (c_2 + a c_3)` with
    :math:`a, b` the fractions in the cell, with the four coefficients of every cell
    precomputed (one row of ``_cells`` per cell, evaluated by
    :func:`controller._kernels.cp_lookup`); the gradient table
    :math:`\\partial C_p/\\partial\\lambda` is
    ``numpy.gradient`` along the TSR axis (second-order central differences, one-sided at the
    edges) interpolated the same way. Outside the grid, inputs are clamped to the edge (the
    same convention as the plant's table lookup).
    """

    pitch_rad: FloatArray
    tsr: FloatArray
    cp: FloatArray
    dcp_dtsr: FloatArray = field(init=False)
    _cells: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        pitch = np.array(self.pitch_rad, dtype=np.float64)
        tsr = np.array(self.tsr, dtype=np.float64)
        cp = np.array(self.cp, dtype=np.float64)
        for name, vec in (("pitch_rad", pitch), ("tsr", tsr)):
            if vec.ndim != 1 or vec.size < 2 or not np.all(np.diff(vec) > 0.0):
                raise ValueError(f"CpTable.{name}: expected >= 2 strictly increasing values")
        if tsr[0] <= 0.0:
            raise ValueError("CpTable.tsr: expected positive tip-speed ratios")
        if np.max(np.abs(pitch)) > math.pi:
            raise ValueError("CpTable.pitch_rad: values beyond ±π; expected radians, not degrees")
        if cp.shape != (tsr.size, pitch.size) or not np.all(np.isfinite(cp)):
            raise ValueError(
                f"CpTable.cp: expected finite values of shape {(tsr.size, pitch.size)} "
                f"(TSR rows x pitch columns), got {cp.shape}"
            )
        grad = np.gradient(cp, tsr, axis=0, edge_order=2)
        for arr in (pitch, tsr, cp, grad):
            arr.setflags(write=False)
        set_ = object.__setattr__
        set_(self, "pitch_rad", pitch)
        set_(self, "tsr", tsr)
        set_(self, "cp", cp)
        set_(self, "dcp_dtsr", grad)
        cells = np.empty(((tsr.size - 1) * (pitch.size - 1), 8))
        for i in range(tsr.size - 1):
            for j in range(pitch.size - 1):
                coeffs: list[float] = []
                for mat in (cp, grad):
                    c00, c10 = float(mat[i, j]), float(mat[i + 1, j])
                    c01, c11 = float(mat[i, j + 1]), float(mat[i + 1, j + 1])
                    coeffs += [c00, c10 - c00, c01 - c00, c11 - c10 - c01 + c00]
                cells[i * (pitch.size - 1) + j] = coeffs
        cells.setflags(write=False)
        set_(self, "_cells", cells)

    def lookup(self, tsr: float, pitch_rad: float) -> tuple[float, float]:
        """:math:`(C_p, \\partial C_p/\\partial\\lambda)` at :math:`(\\lambda, \\theta)`.

        Parameters
        ----------
        tsr : float
            Tip-speed ratio :math:`\\lambda` [-].
        pitch_rad : float
            Blade pitch :math:`\\theta` [rad].

        Returns
        -------
        tuple of float
            :math:`C_p` [-] and :math:`\\partial C_p/\\partial\\lambda` [-]; the gradient is 0
            outside the TSR range, consistent with the clamped :math:`C_p`.
        """
        return _kernels.cp_lookup(self.tsr, self.pitch_rad, self._cells, tsr, pitch_rad)


# ------------------------------------------------------------------------------ wind EKF
@dataclass(frozen=True, eq=False)
class WindEKFConfig:
    """Turbine figures (as the controller knows them) and noise settings of the wind EKF.

    Parameters
    ----------
    cp_table : CpTable
        The controller's Cp table (loaded by the runtime from its design artefacts).
    rotor_radius_m : float
        R [m].
    drivetrain_inertia_kg_m2 : float
        J about the low-speed shaft (rotor + generator N^2) [kg m^2].
    gearbox_ratio : float
        N = generator speed / rotor speed [-].
    air_density_kg_m3 : float
        ρ [kg/m^3], default 1.225.
    turbulence_intensity : float
        :math:`I_t` [-] of the process noise :math:`q_t = \\pi u_m^3 I_t^2 / L`, default 0.15.
    turbulence_length_m : float
        L [m] of :math:`a = \\pi u_m/(2L)`, default 340.2 (IEC Kaimal
        :math:`8.1 \\cdot 0.7 \\cdot 60` m for hub heights above 60 m).
    mean_wind_drift_m_s, mean_wind_drift_time_s : float
        :math:`q_m = \\Delta u_m^2/T_m` [(m/s)^2/s], default 2 m/s per 600 s.
    rotor_speed_process_psd : float
        :math:`q_\\omega` [(rad/s)^2/s], drivetrain model error, default 1e-5.
    rotor_speed_noise_std_rad_s : float
        :math:`\\sigma_z` of the rotor-speed measurement [rad/s, LSS], default 1e-3
        (see :func:`encoder_rotor_speed_std`).
    wind_min_m_s, wind_max_m_s : float
        Bounds on the mean-wind state and on v in the torque model [m/s], default 1 and 60.
    initial_wind_std_m_s : float
        Initial standard deviation of :math:`u_m` [m/s], default 2.
    """

    cp_table: CpTable
    rotor_radius_m: float
    drivetrain_inertia_kg_m2: float
    gearbox_ratio: float
    air_density_kg_m3: float = 1.225
    turbulence_intensity: float = 0.15
    turbulence_length_m: float = 340.2
    mean_wind_drift_m_s: float = 2.0
    mean_wind_drift_time_s: float = 600.0
    rotor_speed_process_psd: float = 1e-5
    rotor_speed_noise_std_rad_s: float = 1e-3
    wind_min_m_s: float = 1.0
    wind_max_m_s: float = 60.0
    initial_wind_std_m_s: float = 2.0

    def __post_init__(self) -> None:
        if not isinstance(self.cp_table, CpTable):
            raise ValueError("WindEKFConfig.cp_table: expected a CpTable")
        positive = (
            ("rotor_radius_m", "m"),
            ("drivetrain_inertia_kg_m2", "kg m^2 (LSS)"),
            ("gearbox_ratio", "-"),
            ("air_density_kg_m3", "kg/m^3"),
            ("turbulence_intensity", "- (fraction, not %)"),
            ("turbulence_length_m", "m"),
            ("mean_wind_drift_m_s", "m/s"),
            ("mean_wind_drift_time_s", "s"),
            ("rotor_speed_process_psd", "(rad/s)^2/s"),
            ("rotor_speed_noise_std_rad_s", "rad/s (LSS)"),
            ("wind_min_m_s", "m/s"),
            ("wind_max_m_s", "m/s"),
            ("initial_wind_std_m_s", "m/s"),
        )
        for name, unit in positive:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0.0):
                raise ValueError(f"WindEKFConfig.{name}: expected a finite value > 0 {unit}")
        if self.wind_max_m_s <= self.wind_min_m_s:
            raise ValueError("WindEKFConfig.wind_max_m_s must exceed wind_min_m_s (m/s)")


class WindEKFState(NamedTuple):
    """State of the wind EKF between calls (plain floats: immutable and cheap).

    Attributes
    ----------
    x : tuple of float
        :math:`(\\omega\\ \\mathrm{rad/s}, u_t\\ \\mathrm{m/s}, u_m\\ \\mathrm{m/s})`.
    p : tuple of float
        Upper triangle of the symmetric error covariance P,
        :math:`(P_{\\omega\\omega}, P_{\\omega t}, P_{\\omega m}, P_{tt}, P_{tm}, P_{mm})`
        (units of x times x); :meth:`covariance` gives the 3x3 matrix.
    innovation_rad_s : float
        Last rotor-speed innovation :math:`z - \\hat\\omega^-` [rad/s].
    updates : int
        Number of measurement updates applied.
    """

    x: tuple[float, float, float]
    p: tuple[float, float, float, float, float, float]
    innovation_rad_s: float = 0.0
    updates: int = 0

    def covariance(self) -> FloatArray:
        """P as a 3x3 array (a new array)."""
        p00, p01, p02, p11, p12, p22 = self.p
        return np.array([[p00, p01, p02], [p01, p11, p12], [p02, p12, p22]])


class WindEKFMeasurement(NamedTuple):
    """One cycle's inputs and measurement for :meth:`WindSpeedEKF.step`.

    Attributes
    ----------
    rotor_speed_rad_s : float
        Measured rotor speed [rad/s, LSS] (generator encoder / N).
    blade_pitch_rad : float
        Measured collective blade pitch [rad].
    generator_torque_nm : float
        Measured generator torque [N m, HSS].
    valid : bool
        False: predict only (e.g. a dropped or implausible speed sample).
    """

    rotor_speed_rad_s: float
    blade_pitch_rad: float
    generator_torque_nm: float
    valid: bool = True


class WindEstimate(NamedTuple):
    """Output of the wind EKF.

    Attributes
    ----------
    wind_m_s : float
        Rotor-effective wind :math:`\\hat u = u_m + u_t` [m/s].
    wind_variance_m2_s2 : float
        :math:`P_{tt} + P_{mm} + 2P_{tm}` [(m/s)^2].
    mean_wind_m_s, turbulent_wind_m_s : float
        :math:`u_m`, :math:`u_t` [m/s].
    rotor_speed_rad_s : float
        Filtered rotor speed [rad/s].
    aero_torque_nm : float
        Model aerodynamic torque at the estimate [N m, LSS].
    """

    wind_m_s: float
    wind_variance_m2_s2: float
    mean_wind_m_s: float
    turbulent_wind_m_s: float
    rotor_speed_rad_s: float
    aero_torque_nm: float


def _wind_estimate(state: WindEKFState, aero_torque_nm: float) -> WindEstimate:
    """:math:`\\hat u = u_m + u_t` and its variance :math:`P_{tt} + P_{mm} + 2 P_{tm}`."""
    omega, u_t, u_m = state.x
    _, _, _, p11, p12, p22 = state.p
    return WindEstimate(u_t + u_m, p11 + p22 + 2.0 * p12, u_m, u_t, omega, aero_torque_nm)


class WindSpeedEKF:
    """Rotor-effective wind-speed EKF of christiansen-2013 sect. 2.12 (module docstring).

    Parameters
    ----------
    config : WindEKFConfig
    """

    def __init__(self, config: WindEKFConfig) -> None:
        self.config = config
        c = config
        self._k = 0.5 * c.air_density_kg_m3 * math.pi * c.rotor_radius_m**3
        self._inv_j = 1.0 / c.drivetrain_inertia_kg_m2
        self._pi_2l = math.pi / (2.0 * c.turbulence_length_m)
        self._q_m = c.mean_wind_drift_m_s**2 / c.mean_wind_drift_time_s
        self._r = c.rotor_speed_noise_std_rad_s**2
        self._tsr_min = float(c.cp_table.tsr[0])
        # the constants of the compiled kernels, in the order of _kernels.EKF_PARAMS
        prm = np.array(
            [
                self._k,
                self._inv_j,
                self._pi_2l,
                self._q_m,
                self._r,
                self._tsr_min,
                c.rotor_radius_m,
                c.gearbox_ratio,
                c.wind_min_m_s,
                c.wind_max_m_s,
                c.turbulence_intensity,
                c.rotor_speed_process_psd,
            ],
            dtype=np.float64,
        )
        t = c.cp_table
        # private writable copies: numba dispatches read-only arrays several times slower
        self._tables = (prm, t.tsr.copy(), t.pitch_rad.copy(), t._cells.copy())

    @property
    def kernel_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The kernels' constants (:data:`controller._kernels.EKF_PARAMS`), the Cp table's
        TSR and pitch grids and its cells (n, 8): the EKF's own arrays, not to be modified."""
        return self._tables

    # -------------------------------------------------------------- model
    def aero_torque(
        self, rotor_speed_rad_s: float, wind_m_s: float, pitch_rad: float
    ) -> tuple[float, float, float]:
        """Aerodynamic torque :math:`T_a` and its partials in :math:`\\omega` and :math:`v`.

        Parameters
        ----------
        rotor_speed_rad_s : float
            :math:`\\omega` [rad/s].
        wind_m_s : float
            :math:`v` [m/s] (clamped to ``[wind_min_m_s, wind_max_m_s]``).
        pitch_rad : float
            :math:`\\theta` [rad].

        Returns
        -------
        tuple of float
            :math:`T_a` [N m, LSS], :math:`\\partial T_a/\\partial\\omega` [N m s/rad],
            :math:`\\partial T_a/\\partial v` [N m s/m].
        """
        return _kernels.aero_torque(
            *self._tables, float(rotor_speed_rad_s), float(wind_m_s), float(pitch_rad)
        )

    def steady_wind(
        self, rotor_speed_rad_s: float, pitch_rad: float, generator_torque_nm: float
    ) -> float:
        """Wind speed at which :math:`T_a(\\omega, v, \\theta) = N T_g` (40 bisection steps).

        Parameters
        ----------
        rotor_speed_rad_s : float
            :math:`\\omega` [rad/s].
        pitch_rad : float
            :math:`\\theta` [rad].
        generator_torque_nm : float
            :math:`T_g` [N m, HSS].

        Returns
        -------
        float
            v [m/s] within ``[wind_min_m_s, wind_max_m_s]`` (an end if no balance lies inside).
        """
        c = self.config
        target = c.gearbox_ratio * generator_torque_nm
        lo, hi = c.wind_min_m_s, c.wind_max_m_s
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if self.aero_torque(rotor_speed_rad_s, mid, pitch_rad)[0] < target:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    # -------------------------------------------------------------- filter
    def initial_state(
        self,
        rotor_speed_rad_s: float,
        blade_pitch_rad: float,
        generator_torque_nm: float,
        wind_m_s: float | None = None,
    ) -> WindEKFState:
        """State before the first cycle: :math:`u_t = 0`, :math:`u_m` given or steady.

        Parameters
        ----------
        rotor_speed_rad_s : float
            Measured rotor speed [rad/s].
        blade_pitch_rad : float
            Measured blade pitch [rad].
        generator_torque_nm : float
            Measured generator torque [N m, HSS].
        wind_m_s : float or None
            Initial mean wind [m/s]; None: :meth:`steady_wind` of the measurements.

        Returns
        -------
        WindEKFState
        """
        c = self.config
        if wind_m_s is None:
            wind_m_s = self.steady_wind(rotor_speed_rad_s, blade_pitch_rad, generator_torque_nm)
        u_m = min(max(float(wind_m_s), c.wind_min_m_s), c.wind_max_m_s)
        sigma_t = c.turbulence_intensity * u_m
        x = (float(rotor_speed_rad_s), 0.0, u_m)
        p = (self._r, 0.0, 0.0, sigma_t * sigma_t, 0.0, c.initial_wind_std_m_s**2)
        return WindEKFState(x, p)

    def predict(self, state: WindEKFState, u: tuple[float, float], dt_s: float) -> WindEKFState:
        """Time update over ``dt_s`` with inputs held (module docstring).

        Parameters
        ----------
        state : WindEKFState
        u : tuple of float
            (blade pitch :math:`\\theta` [rad], generator torque :math:`T_g` [N m, HSS]).
        dt_s : float
            :math:`\\Delta t` [s], > 0.

        Returns
        -------
        WindEKFState
        """
        pitch, torque = u
        x, p = _kernels.ekf_predict(
            *self._tables, state.x, state.p, float(pitch), float(torque), float(dt_s)
        )
        return WindEKFState(x, p, state.innovation_rad_s, state.updates)

    def update(self, state: WindEKFState, z: float) -> WindEKFState:
        """Measurement update with the rotor speed ``z`` [rad/s] (H = [1, 0, 0], Joseph form).

        With :math:`k = P h^T / s`, :math:`s = P_{\\omega\\omega} + r`, the Joseph form
        :math:`(I - k h) P (I - k h)^T + r k k^T` expands for :math:`h = e_1` to
        :math:`P_{ij} - k_i P_{1j} - P_{i1} k_j + s\\,k_i k_j` (symmetric by construction).
        A non-finite ``z`` leaves the state unchanged.

        Parameters
        ----------
        state : WindEKFState
        z : float
            Measured rotor speed [rad/s, LSS].

        Returns
        -------
        WindEKFState
        """
        if not math.isfinite(z):
            return state
        x, p, y = _kernels.ekf_update(self._tables[0], state.x, state.p, float(z))
        return WindEKFState(x, p, y, state.updates + 1)

    def estimate(self, state: WindEKFState, blade_pitch_rad: float = 0.0) -> WindEstimate:
        """Wind estimate and its variance from a state.

        Parameters
        ----------
        state : WindEKFState
        blade_pitch_rad : float
            Pitch [rad] for the reported model aerodynamic torque.

        Returns
        -------
        WindEstimate
        """
        omega, u_t, u_m = state.x
        return _wind_estimate(state, self.aero_torque(omega, u_t + u_m, blade_pitch_rad)[0])

    def step(
        self, state: WindEKFState, measurement: WindEKFMeasurement, dt_s: float
    ) -> tuple[WindEKFState, WindEstimate]:
        """Predict over ``dt_s`` with the measured inputs, then update with the rotor speed.

        The wind estimate :math:`u_t + u_m` is then bounded to ``[wind_min_m_s,
        wind_max_m_s]`` (:math:`u_t` set at the end; :math:`u_m` is bounded by the update):
        an estimate cannot run off the physical range, whatever the measurements
        (:func:`controller._kernels.ekf_step`). The baseline's TSR law adds an innovation
        gate and a divergence detector (:mod:`controller.baseline`).

        Parameters
        ----------
        state : WindEKFState
        measurement : WindEKFMeasurement
        dt_s : float
            Control period [s].

        Returns
        -------
        tuple
            (new state, :class:`WindEstimate`).
        """
        m = measurement
        pitch = float(m.blade_pitch_rad)
        x, p, y, updated, ta = _kernels.ekf_step(
            *self._tables,
            state.x,
            state.p,
            float(m.rotor_speed_rad_s),
            bool(m.valid),
            pitch,
            float(m.generator_torque_nm),
            float(dt_s),
        )
        if updated:
            state = WindEKFState(x, p, y, state.updates + 1)
        else:
            state = WindEKFState(x, p, state.innovation_rad_s, state.updates)
        return state, _wind_estimate(state, ta)


# ------------------------------------------------------------------ the observers' guard
@dataclass(frozen=True)
class GuardConfig:
    """The observers' guard of a Python core (:func:`guarded_wind_step`, :func:`guard_step`).

    The figures and meaning of the baseline's wind guard (:mod:`controller.baseline`, step
    2c): an innovation gate at ``gate_sigma`` standard deviations, the wind estimate's
    physical range, and a divergence detector.

    Attributes
    ----------
    gate_sigma : float
        k of the gate :math:`|y| \\le k\\sqrt{s}` [-].
    wind_min_m_s, wind_max_m_s : float
        Physical range of the wind estimate [m/s].
    fault_s : float
        Uninterrupted bad steps (gated, clamped, non-finite) that make an estimator fault [s].
    recover_s : float
        Time without a bad step after which the fallback ends [s].
    """

    gate_sigma: float = 5.0
    wind_min_m_s: float = 1.0
    wind_max_m_s: float = 37.5
    fault_s: float = 5.0
    recover_s: float = 10.0

    def __post_init__(self) -> None:
        for name in ("gate_sigma", "fault_s", "recover_s", "wind_max_m_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and 0.0 < v < math.inf):
                raise ValueError(f"GuardConfig.{name}: expected a finite number > 0, got {v!r}")
        if not 0.0 <= self.wind_min_m_s < self.wind_max_m_s:
            raise ValueError(
                "GuardConfig: expected 0 <= wind_min_m_s < wind_max_m_s [m/s], got "
                f"{self.wind_min_m_s!r}, {self.wind_max_m_s!r}"
            )


class GuardState(NamedTuple):
    """The divergence detector's state.

    Attributes
    ----------
    bad_s, good_s : float
        Uninterrupted time of bad and of good steps [s].
    held_wind_m_s : float
        The last good mean-wind estimate [m/s] (NaN: none yet).
    faults : int
        Estimator faults so far (each entering the fallback once).
    fallback : bool
        The fallback is on.
    """

    bad_s: float = 0.0
    good_s: float = 0.0
    held_wind_m_s: float = math.nan
    faults: int = 0
    fallback: bool = False


def guard_step(
    guard: GuardState, bad: bool, dt_s: float, config: GuardConfig, mean_wind_m_s: float
) -> tuple[GuardState, bool]:
    """One step of the divergence detector: ``(new guard state, diverged now)``.

    ``bad`` for a gated, clamped or non-finite step. ``config.fault_s`` of bad steps is a
    divergence: the fault count goes up by one unless the fallback is already on, and the
    fallback starts (the caller restarts its observers, at :attr:`GuardState.held_wind_m_s`);
    ``config.recover_s`` without a bad step ends the fallback. The held wind follows
    ``mean_wind_m_s`` while the fallback is off and no bad step is pending.
    """
    bad_s, good_s = (guard.bad_s + dt_s, 0.0) if bad else (0.0, guard.good_s + dt_s)
    faults, fallback, held = guard.faults, guard.fallback, guard.held_wind_m_s
    diverged = bad_s >= config.fault_s
    if diverged:
        if not fallback:
            faults += 1
            fallback = True
        bad_s = good_s = 0.0
    elif fallback and good_s >= config.recover_s:
        fallback = False
    if not fallback and bad_s == 0.0 and math.isfinite(mean_wind_m_s):
        held = mean_wind_m_s
    return GuardState(bad_s, good_s, held, faults, fallback), diverged


def guarded_wind_step(
    ekf: WindSpeedEKF,
    state: WindEKFState,
    measurement: WindEKFMeasurement,
    dt_s: float,
    config: GuardConfig,
) -> tuple[WindEKFState, WindEstimate, bool]:
    """:meth:`WindSpeedEKF.step` with the innovation gated: ``(state, estimate, bad)``.

    The update is skipped when :math:`y^2 > k^2 s` (:math:`s = P_{\\omega\\omega} + r`; the
    EKF's first valid sample is taken ungated); ``bad`` when it was, when the estimate
    :math:`u_t + u_m` left ``[wind_min_m_s, wind_max_m_s]`` (it is then clamped to the
    EKF's own range as :meth:`WindSpeedEKF.step` does) or when the state is not finite.
    """
    m = measurement
    pitch, torque = float(m.blade_pitch_rad), float(m.generator_torque_nm)
    x, p = _kernels.ekf_predict(*ekf._tables, state.x, state.p, pitch, torque, float(dt_s))
    state = WindEKFState(x, p, state.innovation_rad_s, state.updates)
    bad = False
    z = float(m.rotor_speed_rad_s)
    if m.valid and math.isfinite(z):
        y = z - x[0]
        if state.updates == 0 or y * y <= config.gate_sigma**2 * (p[0] + ekf._r):
            state = ekf.update(state, z)
        else:
            bad = True
    omega, u_t, u_m = state.x
    v = u_t + u_m
    c = ekf.config
    if not config.wind_min_m_s <= v <= config.wind_max_m_s:
        bad = True
    if v < c.wind_min_m_s:
        u_t = c.wind_min_m_s - u_m
    elif v > c.wind_max_m_s:
        u_t = c.wind_max_m_s - u_m
    state = state._replace(x=(omega, u_t, u_m))
    if not (all(math.isfinite(v) for v in state.x) and all(math.isfinite(v) for v in state.p)):
        bad = True
    return state, ekf.estimate(state, pitch), bad


# ------------------------------------------------------------------------------ platform KF
def _matrix(name: str, value: object, shape: tuple[int, ...]) -> FloatArray:
    arr = np.array(value, dtype=np.float64)
    if arr.shape != shape or not np.all(np.isfinite(arr)):
        raise ValueError(f"PlatformKFConfig.{name}: expected finite values of shape {shape}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class PlatformKFConfig:
    """Discrete model and settings of the platform/tower Kalman filter (from the design step).

    Parameters
    ----------
    F : array_like, shape (n, n)
        State transition over ``dt_s`` [-].
    B : array_like, shape (n, m)
        Input matrix over ``dt_s`` (units of x per unit of u).
    H : array_like, shape (p, n)
        Measurement matrix.
    Q : array_like, shape (n, n)
        Process-noise covariance per step, symmetric positive semi-definite.
    R : array_like, shape (p, p)
        Measurement-noise covariance, symmetric positive definite (usually diagonal).
    dt_s : float
        Sample time of the discrete model [s].
    D : array_like, shape (p, m), optional
        Measurement feedthrough of the inputs (e.g. an accelerometer); zeros if empty.
    state_names, input_names, measurement_names : tuple of str
        Names with units, for logs; defaults ``x0..``, ``u0..``, ``z0..``.
    gate_probability : float or tuple of float
        Per-channel probability of the chi-square gate, default 0.999 (threshold 10.83);
        1.0 switches the gate off.
    max_consecutive_misses : int
        K: ``degraded`` when a channel has more than K consecutive skipped/rejected updates.
    x0 : array_like, shape (n,), optional
        Initial state (zeros if empty).
    P0 : array_like, shape (n, n), optional
        Initial covariance (the stationary solution of the Riccati recursion is a good
        choice); 10 Q if empty.
    max_predict_steps : int
        Largest number of model steps one :meth:`PlatformKF.predict` call may take (a late
        cycle of ``k dt_s`` is predicted by k steps), default 10.
    """

    F: FloatArray
    B: FloatArray
    H: FloatArray
    Q: FloatArray
    R: FloatArray
    dt_s: float
    D: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    state_names: tuple[str, ...] = ()
    input_names: tuple[str, ...] = ()
    measurement_names: tuple[str, ...] = ()
    gate_probability: float | tuple[float, ...] = 0.999
    max_consecutive_misses: int = 10
    x0: FloatArray = field(default_factory=lambda: np.zeros(0))
    P0: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    max_predict_steps: int = 10
    gate: tuple[float, ...] = field(init=False)

    def __post_init__(self) -> None:
        F = np.array(self.F, dtype=np.float64)
        if F.ndim != 2 or F.shape[0] != F.shape[1]:
            raise ValueError("PlatformKFConfig.F: expected a square matrix")
        n = F.shape[0]
        B = np.array(self.B, dtype=np.float64)
        m = B.shape[1] if B.ndim == 2 else -1
        H = np.array(self.H, dtype=np.float64)
        p = H.shape[0] if H.ndim == 2 else -1
        set_ = object.__setattr__
        set_(self, "F", _matrix("F", F, (n, n)))
        set_(self, "B", _matrix("B", B, (n, m)))
        set_(self, "H", _matrix("H", H, (p, n)))
        Q = _matrix("Q", self.Q, (n, n))
        if not np.allclose(Q, Q.T, rtol=1e-9, atol=1e-300) or np.min(
            np.linalg.eigvalsh(Q)
        ) < -1e-12 * max(float(np.max(np.abs(Q))), 1e-300):
            raise ValueError("PlatformKFConfig.Q: expected symmetric positive semi-definite")
        set_(self, "Q", Q)
        R = _matrix("R", self.R, (p, p))
        if not np.array_equal(R, R.T) or np.min(np.linalg.eigvalsh(R)) <= 0.0:
            raise ValueError("PlatformKFConfig.R: expected a symmetric positive definite matrix")
        set_(self, "R", R)
        D = np.zeros((p, m)) if np.size(self.D) == 0 else self.D
        set_(self, "D", _matrix("D", D, (p, m)))
        if not (math.isfinite(self.dt_s) and self.dt_s > 0.0):
            raise ValueError("PlatformKFConfig.dt_s: expected a sample time > 0 s")
        for attr, size, prefix in (
            ("state_names", n, "x"),
            ("input_names", m, "u"),
            ("measurement_names", p, "z"),
        ):
            names = tuple(getattr(self, attr)) or tuple(f"{prefix}{i}" for i in range(size))
            if len(names) != size:
                raise ValueError(f"PlatformKFConfig.{attr}: expected {size} names")
            set_(self, attr, names)
        probs = self.gate_probability
        probs_t = (float(probs),) * p if isinstance(probs, int | float) else tuple(probs)
        if len(probs_t) != p:
            raise ValueError(f"PlatformKFConfig.gate_probability: expected 1 or {p} values")
        set_(self, "gate", tuple(chi2_gate(pr) for pr in probs_t))
        if self.max_consecutive_misses < 0 or self.max_predict_steps < 1:
            raise ValueError(
                "PlatformKFConfig: max_consecutive_misses must be >= 0, max_predict_steps >= 1"
            )
        x0 = np.zeros(n) if np.size(self.x0) == 0 else self.x0
        set_(self, "x0", _matrix("x0", x0, (n,)))
        P0 = 10.0 * Q if np.size(self.P0) == 0 else self.P0
        P0 = _matrix("P0", P0, (n, n))
        if np.min(np.linalg.eigvalsh(0.5 * (P0 + P0.T))) <= 0.0:
            raise ValueError("PlatformKFConfig.P0: expected symmetric positive definite")
        set_(self, "P0", P0)


class PlatformKFState(NamedTuple):
    """State of the platform KF between calls (immutable: every call returns a new one).

    The four per-channel counters are the rows of one integer array ``counts`` (a new array
    on every call, never modified), read as tuples through the properties below.

    Attributes
    ----------
    x : ndarray, shape (n,)
        State estimate.
    P : ndarray, shape (n, n)
        Error covariance.
    counts : ndarray of int64, shape (4, p)
        Per channel: consecutive misses, skipped, rejected and accepted updates.
    nis : ndarray, shape (p,)
        Per channel: last normalised innovation squared :math:`y^2/s` (NaN if skipped).
    degraded : bool
        Some channel has more than K consecutive misses.
    """

    x: FloatArray
    P: FloatArray
    counts: npt.NDArray[np.int64]
    nis: FloatArray
    degraded: bool = False

    @property
    def consecutive_misses(self) -> tuple[int, ...]:
        """Per channel: updates skipped or rejected in a row."""
        return tuple(self.counts[0].tolist())

    @property
    def skipped(self) -> tuple[int, ...]:
        """Per channel: invalid or non-finite samples so far."""
        return tuple(self.counts[1].tolist())

    @property
    def rejected(self) -> tuple[int, ...]:
        """Per channel: samples rejected by the gate so far."""
        return tuple(self.counts[2].tolist())

    @property
    def accepted(self) -> tuple[int, ...]:
        """Per channel: samples used so far."""
        return tuple(self.counts[3].tolist())


class PlatformMeasurement(NamedTuple):
    """One cycle's inputs and measurements for :meth:`PlatformKF.step`.

    Attributes
    ----------
    u : array_like, shape (m,)
        Known inputs held over the elapsed period (deviations from the design point).
    z : array_like, shape (p,)
        Measurements (deviations from the design point, same order as ``H``).
    valid : sequence of bool, shape (p,), or None
        Per-channel validity (None: all valid).
    """

    u: npt.ArrayLike
    z: npt.ArrayLike
    valid: npt.ArrayLike | None = None


class PlatformEstimate(NamedTuple):
    """Output of the platform KF.

    Attributes
    ----------
    x : ndarray, shape (n,)
        State estimate (a copy).
    std : ndarray, shape (n,)
        :math:`\\sqrt{\\mathrm{diag}\\,P}`.
    degraded : bool
    """

    x: FloatArray
    std: FloatArray
    degraded: bool


class PlatformKF:
    """Discrete Kalman filter with per-channel gating and validity (module docstring).

    Parameters
    ----------
    config : PlatformKFConfig
    """

    def __init__(self, config: PlatformKFConfig) -> None:
        self.config = config
        c = config
        n, p = c.F.shape[0], c.H.shape[0]
        self._n = n
        self._p = p
        # the kernels' constants: private writable copies (numba dispatches read-only arrays
        # several times slower); F, B, Q for the predict, H, D, R and the gate for the update
        self._pred = (c.F.copy(), c.B.copy(), c.Q.copy())
        self._upd = (c.H.copy(), c.D.copy(), c.R.copy(), np.array(c.gate, dtype=np.float64))
        self._all_valid = np.ones(p, dtype=np.bool_)
        self._no_input = np.zeros(0)

    def initial_state(self) -> PlatformKFState:
        """State before the first cycle: ``x0``, ``P0``, counters zero."""
        c = self.config
        return PlatformKFState(
            c.x0.copy(),
            c.P0.copy(),
            np.zeros((4, self._p), dtype=np.int64),
            np.full(self._p, math.nan),
        )

    def predict(self, state: PlatformKFState, u: npt.ArrayLike, dt_s: float) -> PlatformKFState:
        """Time update :math:`\\hat x \\leftarrow F\\hat x + Bu`, :math:`P \\leftarrow FPF^T + Q`.

        ``dt_s`` is rounded to a whole number of model steps (1 to ``max_predict_steps``).
        :math:`P` is not re-symmetrised here: :math:`F P F^T` of a symmetric :math:`P` is
        symmetric up to rounding, and :meth:`update` symmetrises after its Joseph step.

        Parameters
        ----------
        state : PlatformKFState
        u : array_like, shape (m,)
            Known inputs, held over the period.
        dt_s : float
            Elapsed time [s].

        Returns
        -------
        PlatformKFState
        """
        c = self.config
        steps = min(max(round(dt_s / c.dt_s), 1), c.max_predict_steps)
        n = self._n
        x, P = np.empty(n), np.empty((n, n))
        _kernels.kf_predict(
            *self._pred, state.x, state.P, np.asarray(u, dtype=np.float64), steps, x, P
        )
        return state._replace(x=x, P=P)

    def update(
        self,
        state: PlatformKFState,
        z: npt.ArrayLike,
        valid: npt.ArrayLike | None = None,
        u: npt.ArrayLike | None = None,
    ) -> PlatformKFState:
        """Gated measurement update of the valid channels, Joseph form (module docstring).

        Cost is fixed and small: the gate uses the prior innovation covariance
        :math:`S = H P H^T + R` of all channels (one product), the accepted subset a picks
        :math:`H_a`, :math:`R_a` precomputed per subset and :math:`S_{aa}`,
        :math:`P H_a^T` by index, then :math:`K = P H_a^T S_{aa}^{-1}` (one 1x1 to 4x4
        inverse), :math:`\\hat x \\leftarrow \\hat x + K y_a` and
        :math:`P \\leftarrow A P A^T + K R_{aa} K^T`, :math:`A = I - K H_a`, symmetrised, in
        one compiled call (:func:`controller._kernels.kf_update`; :math:`S_{aa}^{-1}` by
        Gauss-Jordan elimination with partial pivoting).

        Parameters
        ----------
        state : PlatformKFState
        z : array_like, shape (p,)
            Measurements.
        valid : array_like of bool, shape (p,), optional
            Per-channel validity; None: all valid. Non-finite values count as invalid.
        u : array_like, shape (m,), optional
            Inputs for the feedthrough D (zeros if None).

        Returns
        -------
        PlatformKFState
        """
        c = self.config
        ok = self._all_valid if valid is None else np.asarray(valid, dtype=np.bool_)
        uu = self._no_input if u is None else np.asarray(u, dtype=np.float64)
        n, p = self._n, self._p
        x, P = np.empty(n), np.empty((n, n))
        counts, nis = np.empty((4, p), dtype=np.int64), np.empty(p)
        degraded = _kernels.kf_update(
            *self._upd,
            state.x,
            state.P,
            np.asarray(z, dtype=np.float64),
            ok,
            uu,
            state.counts,
            c.max_consecutive_misses,
            x,
            P,
            counts,
            nis,
        )
        return PlatformKFState(x, P, counts, nis, degraded)

    def predict_update(
        self,
        state: PlatformKFState,
        u: npt.ArrayLike,
        z: npt.ArrayLike,
        valid: npt.ArrayLike | None,
        dt_s: float,
    ) -> PlatformKFState:
        """:meth:`predict` with ``u`` over ``dt_s``, then :meth:`update` with ``z``, ``valid``
        and the feedthrough of the same ``u``, in one compiled call (the runtime's cycle).

        Returns
        -------
        PlatformKFState
            The same as ``update(predict(state, u, dt_s), z, valid, u)``.
        """
        c = self.config
        n, p = self._n, self._p
        steps = min(max(round(dt_s / c.dt_s), 1), c.max_predict_steps)
        x, P = np.empty(n), np.empty((n, n))
        counts, nis = np.empty((4, p), dtype=np.int64), np.empty(p)
        degraded = _kernels.kf_cycle(
            *self._pred,
            *self._upd,
            state.x,
            state.P,
            np.asarray(u, dtype=np.float64),
            steps,
            np.asarray(z, dtype=np.float64),
            self._all_valid if valid is None else np.asarray(valid, dtype=np.bool_),
            state.counts,
            c.max_consecutive_misses,
            x,
            P,
            counts,
            nis,
        )
        return PlatformKFState(x, P, counts, nis, degraded)

    def step(
        self, state: PlatformKFState, measurement: PlatformMeasurement, dt_s: float
    ) -> tuple[PlatformKFState, PlatformEstimate]:
        """Predict over ``dt_s`` with the inputs, then update with the measurements.

        Parameters
        ----------
        state : PlatformKFState
        measurement : PlatformMeasurement
        dt_s : float
            Control period [s].

        Returns
        -------
        tuple
            (new state, :class:`PlatformEstimate`).
        """
        m = measurement
        state = self.predict(state, m.u, dt_s)
        state = self.update(state, m.z, m.valid, m.u)
        return state, PlatformEstimate(state.x.copy(), np.sqrt(np.diag(state.P)), state.degraded)
