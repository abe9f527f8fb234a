"""Linearised closed loop of the floating turbine with the baseline controller (offline only).

This module MAY import ``plant`` (offline analysis, as :mod:`controller.design.linear`); the
controller runtime never imports it.

Closed loop (discrete, at the control period :math:`T_s`, default 0.025 s)
----------------------------------------------------------------------------
The plant is the radiation-reduced linear model of :mod:`controller.design.linear` (the
eleven mechanical states :math:`x` of :func:`plant.platform.state_names`: surge, heave, pitch,
tower-top [m, m, rad, m], their rates, rotor speed :math:`\\omega` [rad/s], blade pitch
:math:`\\theta` [rad], generator torque :math:`T_g` [N m], the actuators' lags included),
linearised about the closed loop's own steady state (below) and held over each period
(zero-order hold): :math:`x_{k+1} = A_d x_k + B_d u_k`, :math:`u = (\\theta_c, T_c)`. The
controller measures, without noise, bias or delay,
:math:`y = C x = (N\\omega, \\theta, T_g, \\dot\\varphi)` (generator speed [rad/s], blade pitch
[rad], generator torque [N m], platform pitch rate [rad/s]; :math:`N` the gearbox ratio) and
answers in the same period (no transport delay, as the LQRI analysis of
:func:`controller.design.linear_report`). Its step is the compiled law itself
(:meth:`controller.baseline.BaselineController.step`, the kernel
:func:`controller._kernels.baseline_step`): the next controller state and the commands
:math:`c_{k+1} = G(c_k, y_k)`, :math:`u_k = (c_{k+1}[\\theta_{prev}], c_{k+1}[T_{prev}])` are
linearised by central differences (steps :math:`10^{-6}\\max(|v|, s)` per entry), so that the
whole law (second-order generator-speed filter, gain-scheduled pitch PI with its anti-windup
clamp, TSR-tracking torque PI and its saturation, setpoint smoother, wind EKF, its
low-passed estimate, the minimum-pitch schedule on that estimate, platform-pitch-rate
feedback) enters as implemented:

.. math::

    \\begin{bmatrix} x \\\\ c \\end{bmatrix}_{k+1} =
    \\begin{bmatrix} A_d + B_d G_{u,y} C & B_d G_{u,c} \\\\ G_{c,y} C & G_{c,c}\\end{bmatrix}
    \\begin{bmatrix} x \\\\ c \\end{bmatrix}_k .

Controller states kept (deviations): the generator-speed filter's two states [rad/s], the
pitch-PI integral [rad] and the torque-PI integral [rad], the previous pitch [rad] and torque
[N m] commands, the filtered wind estimate :math:`\\hat v_f` [m/s], the setpoint shift
[rad/s], the previous minimum pitch [rad], the wind EKF's state (rotor speed [rad/s],
turbulent and mean wind [m/s]) and the three platform-pitch-rate filter states [rad/s];
then those with no path to the commands are dropped (their eigenvalues are not the loop's).
Left out: the EKF's covariance (it acts on the state only through :math:`K y`, and the
innovation :math:`y` is zero at the steady state, so its first-order effect is nil: the
matrix is block triangular and the covariance's own Riccati poles are not the loop's; it is
held at its steady value, which sets the EKF's gain), the wind guard's bookkeeping (timers,
fault count, the held estimate: inactive at a healthy steady state) and the last valid gyro
sample (read only on a dropout).

Poles :math:`z` of the matrix; their continuous equivalents :math:`s = \\log(z)/T_s`
[1/s]. The surge, heave, platform-pitch and tower modes are identified as the open-loop ones
(:func:`plant.modes.identify_modes`) in the continuous equivalent
:math:`\\mathrm{Re}\\,V\\log(\\Lambda)V^{-1}/T_s` (M's eigenvectors V, poles
:math:`\\log z/T_s`): period :math:`2\\pi/\\mathrm{Im}\\,s` [s], damping ratio
:math:`-\\mathrm{Re}\\,s/|s|` [-].

Steady state, and the branch linearised
---------------------------------------
The closed loop's steady state at a steady hub-height wind :math:`U` is that of the plant
(:func:`plant.modes.operating_point` with the controller's rotor point, so the platform's
static equilibrium under that point's thrust at the rotor-normal wind :math:`U_n`) and of the
law, computed on its two above-rated branches:

* **pitch PI in control** (``"pitch_pi"``): :math:`\\omega = \\omega_{ref}/N`,
  :math:`T_g = T_{rt}` (the torque PI saturated at rated: the setpoint shift is positive, so
  the torque reference lies below the speed), :math:`\\theta` from
  :math:`Q_a(\\omega, \\theta, U_n) = N T_{rt}`; valid when that :math:`\\theta` lies above
  the minimum pitch :math:`\\theta_{PS}(\\hat v)` of the schedule at the EKF's steady estimate
  :math:`\\hat v` (:math:`Q_{a,EKF}(\\omega, \\hat v, \\theta) = N T_g` on the controller's
  own C_p table). Linearised: the PI and its gain schedule, the torque at its limit (no
  torque feedback), the minimum pitch inactive.
* **minimum pitch active** (``"min_pitch"``, peak shaving): the blades at
  :math:`\\theta = \\theta_{PS}(\\hat v(\\theta, T_g))`, :math:`\\omega = \\omega_{ref}/N`
  held by the torque PI (unsaturated, :math:`T_g = Q_a/N < T_{rt}`), the pitch PI's output
  and integral clamped at the minimum pitch (the setpoint shift is negative: the pitch
  reference is raised and the speed error stays negative). Linearised: the torque PI, and
  the pitch :math:`\\theta_c = \\theta_{PS}(\\hat v_f)` following the filtered estimate
  through the schedule's local slope :math:`d\\theta_{PS}/d\\hat v` (1.30 deg per m/s between
  10.74 and 11.22 m/s in the IEA 15 MW preset).

A wind where neither holds (below rated, where the TSR tracking is in control) raises
``ValueError``. The commands are checked to reproduce the measurements at the point
(relative 1e-6).

On the minimum-pitch branch the platform-pitch-rate feedback is added *after* the clamp and
clamped again: :math:`\\theta_c = \\theta_{PS} + \\max(K_{fl} q_f, 0)`, and its filtered rate
:math:`q_f` is zero at the point, so the two branches meet there (a one-sided law, not
differentiable). ``pitch_rate_feedback`` chooses what is linearised: ``"average"`` (default;
the central difference, gain :math:`K_{fl}/2`: the describing-function gain of
:math:`\\max(K_{fl} q, 0)` for a sinusoidal :math:`q` centred on the clamp), ``"on"``
(:math:`K_{fl}`, the half-cycles with :math:`q_f > 0`) or ``"off"`` (0, the other half).
On the pitch-PI branch the feedback is unclamped and the choice does nothing.

``min_pitch="flat"`` replaces the schedule by a constant minimum pitch equal to the steady
:math:`\\theta_{PS}(\\hat v)` (same steady state; the path platform velocity
:math:`\\to \\hat v \\to \\theta_{PS}` is cut), the comparison that isolates peak shaving.

Found along the way: from about 16 m/s (IEA 15 MW preset) the loop has a real pole
:math:`z < -1`, a two-sample oscillation of the pitch command inside the controller. The
law schedules the integral *term* :math:`G_K K_I I` on the previous command, so
:math:`\\partial\\theta_k/\\partial\\theta_{k-1} = (dK_I/d\\theta)\\,I`; the preset's
:math:`K_I(\\theta)` table falls fast enough at high pitch that this exceeds 1 in magnitude
(-0.91 at 15 m/s, -1.12 at 17 m/s, -1.23 at 20 m/s). In the nonlinear law it ends at the
pitch rate limit (a +/- 0.44 mrad command ripple at 20 Hz). It is not a platform mode and does
not change the modes reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Literal

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from bus_schemas.messages import VALID_GENERATOR_SPEED, VALID_PLATFORM_PITCH_RATE, SensorFrame
from controller.baseline import BaselineController, BaselineParams, BaselineState, load_baseline
from controller.design.linear import LinearModel, reduce_radiation
from controller.interface import OperatingPoint as ControllerPoint

if TYPE_CHECKING:
    from plant.modes import Mode, OperatingPoint
    from plant.platform import FloatingParams

__all__ = [
    "CONTROLLER_STATE_NAMES",
    "MEASUREMENT_NAMES",
    "SETTLE_S",
    "BaselineClosedLoop",
    "Branch",
    "MinPitch",
    "RateFeedback",
    "baseline_closed_loop",
    "baseline_closed_loop_modes",
]

FloatArray = npt.NDArray[np.float64]

#: Names (with units) of the baseline's state entries
#: (:class:`controller.baseline.BaselineState`, TSR-tracking layout).
CONTROLLER_STATE_NAMES = (
    "speed_filter_z1_rad_s",
    "speed_filter_z2_rad_s",
    "generator_speed_filtered_rad_s",
    "pitch_integral_rad",
    "torque_integral_rad",
    "pitch_command_rad",
    "torque_command_nm",
    "wind_estimate_filtered_m_s",
    "setpoint_shift_rad_s",
    "min_pitch_rad",
    "ekf_rotor_speed_rad_s",
    "ekf_turbulent_wind_m_s",
    "ekf_mean_wind_m_s",
    "ekf_p00",
    "ekf_p01",
    "ekf_p02",
    "ekf_p11",
    "ekf_p12",
    "ekf_p22",
    "rate_highpass_mean_rad_s",
    "rate_lowpass_z1_rad_s",
    "rate_lowpass_z2_rad_s",
    "platform_pitch_rate_held_rad_s",
    "estimator_faults",
    "wind_bad_s",
    "wind_good_s",
    "wind_fallback",
    "wind_last_good_m_s",
    "trimmed",
    "rate_samples",
)

#: Entries the step reads and that can carry a deviation (module docstring): the
#: covariance (13-18), the guard's bookkeeping (23-29), the filtered-speed output (2) and
#: the held gyro sample (22) are left out.
_CANDIDATES = (0, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 19, 20, 21)
_PITCH_CMD, _TORQUE_CMD = 5, 6
_EKF_X = slice(10, 13)
#: Floor of the finite-difference step scale, in each entry's unit (step 1e-6 max(|v|, floor)).
_FLOOR = 1e-3

#: Measurements (rows of C): generator speed, blade pitch, generator torque, pitch rate.
MEASUREMENT_NAMES = (
    "generator_speed_rad_s",
    "blade_pitch_rad",
    "generator_torque_nm",
    "platform_pitch_rate_rad_s",
)
#: Simulated time the controller settles on the frozen point [s]: its slowest part, the wind
#: EKF's covariance, converges in about 1500 s (the mean-wind/turbulence pair's ~150 s mode).
SETTLE_S = 2400.0

_OMEGA, _PITCH, _TORQUE, _PITCH_RATE = 8, 9, 10, 6

Branch = Literal["pitch_pi", "min_pitch"]
RateFeedback = Literal["average", "on", "off"]
MinPitch = Literal["schedule", "flat"]


@dataclass(frozen=True, eq=False)
class BaselineClosedLoop:
    """The discrete closed loop of plant and baseline controller about one steady point.

    Attributes
    ----------
    wind_m_s : float
        Steady hub-height wind U [m/s].
    control_period_s : float
        :math:`T_s` [s].
    matrix : (n, n) array
        Discrete closed-loop matrix M (module docstring), states :attr:`state_names`
        (the plant's eleven, then the controller's kept entries) [-].
    state_names : tuple of str
        Names (with units) of M's states.
    plant : LinearModel
        The radiation-reduced continuous plant model at the point.
    branch : {"pitch_pi", "min_pitch"}
        The branch of the law linearised (module docstring).
    min_pitch : {"schedule", "flat"}
        The minimum pitch as shipped, or flat at its steady value.
    pitch_rate_feedback : {"average", "on", "off"}
        The platform-pitch-rate feedback's gain at the clamp (``"min_pitch"`` only).
    rotor_speed_rad_s, blade_pitch_rad, generator_torque_nm : float
        The steady rotor point [rad/s, rad, N m (HSS)].
    wind_estimate_m_s : float
        The EKF's steady estimate :math:`\\hat v` [m/s].
    min_pitch_rad : float
        The schedule's minimum pitch at :math:`\\hat v` [rad].
    min_pitch_slope_rad_per_m_s : float
        :math:`d\\theta_{PS}/d\\hat v` there [rad/(m/s)] (0 when flat).
    description : str
        One line: the branch linearised and the variant.
    """

    wind_m_s: float
    control_period_s: float
    matrix: FloatArray
    state_names: tuple[str, ...]
    plant: LinearModel
    branch: Branch
    min_pitch: MinPitch
    pitch_rate_feedback: RateFeedback
    rotor_speed_rad_s: float
    blade_pitch_rad: float
    generator_torque_nm: float
    wind_estimate_m_s: float
    min_pitch_rad: float
    min_pitch_slope_rad_per_m_s: float
    description: str

    def poles_z(self) -> npt.NDArray[np.complex128]:
        """Discrete poles z of :attr:`matrix` [-]."""
        z: npt.NDArray[np.complex128] = np.linalg.eigvals(self.matrix).astype(np.complex128)
        return z

    def poles_s(self) -> npt.NDArray[np.complex128]:
        """Continuous equivalents :math:`\\log(z)/T_s` [1/s]."""
        s = np.log(self.poles_z()) / self.control_period_s
        return np.asarray(s, dtype=np.complex128)

    def continuous_matrix(self) -> FloatArray:
        """:math:`\\mathrm{Re}\\,V\\log(\\Lambda)V^{-1}/T_s` [1/s], from M's eigenvalues
        :math:`\\Lambda` and eigenvectors V: the continuous equivalent with M's eigenvectors
        and poles :math:`\\log z/T_s` (a real negative z contributes :math:`\\log|z|/T_s`).

        The eigen-decomposition rather than ``scipy.linalg.logm``: the slow platform poles
        (:math:`|s| \\approx 0.06` 1/s) sit beside filter poles of 20 1/s, and ``logm``'s
        error, small against the largest, was 1e-5 of the surge pole here.
        """
        z, vec = np.linalg.eig(self.matrix)
        log_z = np.log(z.astype(np.complex128))
        a: FloatArray = np.real(vec @ np.diag(log_z) @ np.linalg.inv(vec)) / self.control_period_s
        return a

    def modes(self) -> list[Mode]:
        """Surge, heave, pitch and tower fore-aft modes of the closed loop (those found)."""
        from plant.modes import PITCH_LENGTH_M, identify_modes  # noqa: PLC0415
        from plant.platform import DOF_NAMES  # noqa: PLC0415

        return identify_modes(
            self.continuous_matrix(),
            range(4),
            range(4, 8),
            DOF_NAMES,
            (1.0, 1.0, PITCH_LENGTH_M, 1.0),
        )


def _plant_model(params: FloatingParams, op: OperatingPoint) -> LinearModel:
    """The radiation-reduced linear model at ``op`` (:func:`controller.design.linear.
    linear_model`'s recipe at a given operating point)."""
    from controller.design.linear import _jacobian_u, _output_matrix  # noqa: PLC0415
    from plant.modes import linearize  # noqa: PLC0415
    from plant.platform import state_names  # noqa: PLC0415

    a = linearize(params, op)
    x0 = np.array(op.state, dtype=np.float64)
    bu = _jacobian_u(params, x0, op.inputs)
    full = LinearModel(
        wind_m_s=float(op.wind_m_s),
        a=a,
        b=bu[:, 0:2].copy(),
        b_wind=bu[:, 2:3].copy(),
        b_wave=bu[:, 3:6].copy(),
        c=_output_matrix(params, a.shape[0]),
        state_names=tuple(state_names(params)),
        x_op=x0,
        u_op=np.array(op.inputs[:2], dtype=np.float64),
        thrust_n=op.thrust_n,
    )
    return reduce_radiation(full, params)


def _steady_point(
    params: FloatingParams, ctrl: BaselineController, wind_m_s: float
) -> tuple[OperatingPoint, Branch]:
    """The closed loop's steady plant point and the branch of the law (module docstring)."""
    from scipy.optimize import brentq  # noqa: PLC0415

    from plant import turbine as _turbine  # noqa: PLC0415
    from plant.modes import operating_point  # noqa: PLC0415

    p = ctrl.params
    ekf = ctrl.ekf
    tp = params.turbine
    n = tp.gearbox_ratio
    omega = p.pitch_reference_generator_speed_rad_s / n
    if p.torque_law == "tsr_tracking" or p.region3_mode == "constant_torque":
        t_rated = p.rated_torque_nm
    else:
        t_rated = p.rated_mechanical_power_w / p.pitch_reference_generator_speed_rad_s
    lo, hi = p.min_pitch_rad, min(p.max_pitch_rad, math.radians(45.0))

    def aero(theta: float, u_n: float) -> float:
        out = _turbine.outputs(0.0, (omega, theta, 0.0), (theta, 0.0, u_n), tp)
        return float(out.aero_torque_nm)

    def estimate(theta: float, torque: float) -> float:
        return ekf.steady_wind(omega, theta, torque) if ekf is not None else math.nan

    def floor(theta: float, torque: float) -> float:
        return p.min_pitch_at(estimate(theta, torque)) if ekf is not None else p.min_pitch_rad

    def pitch_pi(u_n: float) -> tuple[float, float, float]:
        if aero(lo, u_n) <= n * t_rated:
            raise ValueError(
                f"U = {wind_m_s} m/s: below rated (the rotor at fine pitch and rated speed "
                "does not reach rated torque); only the above-rated branches are linearised"
            )
        th = float(brentq(lambda t: aero(t, u_n) - n * t_rated, lo, hi, xtol=1e-14))
        return omega, th, t_rated

    def min_pitch(u_n: float) -> tuple[float, float, float]:
        def g(t: float) -> float:
            return t - floor(t, aero(t, u_n) / n)

        th = float(brentq(g, lo, hi, xtol=1e-14))
        return omega, th, aero(th, u_n) / n

    op = operating_point(params, wind_m_s, rotor=pitch_pi)
    th, tq = op.state[_PITCH], op.state[_TORQUE]
    if th > floor(th, tq) + 1e-9:
        return op, "pitch_pi"
    op = operating_point(params, wind_m_s, rotor=min_pitch)
    th, tq = op.state[_PITCH], op.state[_TORQUE]
    if tq >= t_rated:  # pragma: no cover - both limits met at once
        raise ValueError(f"U = {wind_m_s} m/s: the minimum pitch and rated torque both hold")
    tsr_ref = (p.optimal_tsr or 0.0) * n / (p.rotor_radius_m or 1.0) * estimate(th, tq)
    if tsr_ref < p.region25_end_generator_speed_rad_s:
        raise ValueError(
            f"U = {wind_m_s} m/s: below rated (the TSR-tracking speed reference "
            f"{tsr_ref:.4f} rad/s is under the rated speed); only the above-rated branches "
            "are linearised"
        )
    return op, "min_pitch"


def _frame(y: FloatArray, wind_m_s: float) -> SensorFrame:
    """A noise-free frame with the measurements ``y`` (:data:`MEASUREMENT_NAMES`); the
    anemometer reads U (the law uses it only on a first call) and the rest is zero."""
    return SensorFrame(
        seq=0,
        sample_time_ns=0,
        publish_time_ns=0,
        valid_mask=VALID_GENERATOR_SPEED | VALID_PLATFORM_PITCH_RATE,
        generator_speed_measured_rad_s=float(y[0]),
        rotor_speed_measured_rad_s=0.0,
        blade_pitch_measured_rad=float(y[1]),
        generator_torque_measured_nm=float(y[2]),
        electrical_power_measured_w=0.0,
        wind_speed_measured_m_s=float(wind_m_s),
        nacelle_acc_fore_aft_measured_m_s2=0.0,
        platform_pitch_measured_rad=0.0,
        platform_pitch_rate_measured_rad_s=float(y[3]),
        platform_surge_measured_m=0.0,
        wave_elevation_gauge_measured_m=0.0,
    )


def _settled_state(
    ctrl: BaselineController, y0: FloatArray, wind_m_s: float, dt_s: float
) -> FloatArray:
    """The controller's state at the steady point: its own trim, then ``SETTLE_S`` of steps
    on the frozen measurements with the commands and the EKF's state pinned to the point
    (the EKF's steady state is exact: rotor speed measured, no turbulence, the mean wind of
    its torque balance; the pinned commands keep the gain schedule's two-sample mode, which
    may be unstable, from moving the point)."""
    p = ctrl.params
    n = p.gearbox_ratio
    op = ControllerPoint(wind_m_s, float(y0[0]) / n, float(y0[1]), float(y0[2]))
    frame = _frame(y0, wind_m_s)
    state = ctrl.trimmed_state(op)
    state, _ = ctrl.step(state, frame, dt_s)
    ekf_x = None
    if ctrl.ekf is not None:
        v_hat = ctrl.ekf.steady_wind(float(y0[0]) / n, float(y0[1]), float(y0[2]))
        ekf_x = (float(y0[0]) / n, 0.0, v_hat)
    for _ in range(round(SETTLE_S / dt_s)):
        values = state.values.copy()
        values[_PITCH_CMD] = y0[1]
        values[_TORQUE_CMD] = y0[2]
        if ekf_x is not None:
            values[_EKF_X] = ekf_x
        state, _ = ctrl.step(BaselineState(values, False), frame, dt_s)
    values = state.values.copy()
    values[_PITCH_CMD] = y0[1]
    values[_TORQUE_CMD] = y0[2]
    if ekf_x is not None:
        values[_EKF_X] = ekf_x
    return values


def _controller_jacobians(
    ctrl: BaselineController, c0: FloatArray, y0: FloatArray, wind_m_s: float, dt_s: float
) -> tuple[FloatArray, FloatArray]:
    """Central differences of the step: (∂c⁺/∂c, ∂c⁺/∂y), all 30 entries × candidates."""

    def step(c: FloatArray, y: FloatArray) -> FloatArray:
        new, _ = ctrl.step(BaselineState(c, False), _frame(y, wind_m_s), dt_s)
        return new.values

    cand = list(_CANDIDATES)
    g_c = np.zeros((c0.size, len(cand)))
    for j, i in enumerate(cand):
        h = 1e-6 * max(abs(float(c0[i])), _FLOOR)
        cp, cm = c0.copy(), c0.copy()
        cp[i] += h
        cm[i] -= h
        g_c[:, j] = (step(cp, y0) - step(cm, y0)) / (2.0 * h)
    g_y = np.zeros((c0.size, y0.size))
    for j in range(y0.size):
        h = 1e-6 * max(abs(float(y0[j])), _FLOOR)
        yp, ym = y0.copy(), y0.copy()
        yp[j] += h
        ym[j] -= h
        g_y[:, j] = (step(c0, yp) - step(c0, ym)) / (2.0 * h)
    return g_c, g_y


def _kept(g_c: FloatArray) -> list[int]:
    """Positions (in :data:`_CANDIDATES`) of the entries with a path to the commands.

    Entry j feeds entry i when ``g_c[i, j]`` is non-zero (an entry the step does not read
    gives an exactly zero column); the commands' rows are the start. The others form a block
    that the kept ones do not see, whose poles are not the loop's.
    """
    cand = list(_CANDIDATES)
    kept: set[int] = set()
    rows = [_PITCH_CMD, _TORQUE_CMD]  # state entries whose inputs are looked for
    looked = set(rows)
    while rows:
        row = rows.pop()
        for j, entry in enumerate(cand):
            if g_c[row, j] != 0.0 and j not in kept:
                kept.add(j)
                if entry not in looked:
                    looked.add(entry)
                    rows.append(entry)
    return sorted(kept)


def _zoh(a: FloatArray, b: FloatArray, ts: float) -> tuple[FloatArray, FloatArray]:
    """Zero-order-hold discretisation (block matrix exponential)."""
    n, m = a.shape[0], b.shape[1]
    blk = np.zeros((n + m, n + m))
    blk[:n, :n] = a
    blk[:n, n:] = b
    e = sla.expm(blk * ts)
    return e[:n, :n], e[:n, n:]


def baseline_closed_loop(
    preset: str | FloatingParams,
    wind_m_s: float,
    baseline_preset: str | BaselineParams = "iea15mw_baseline",
    *,
    min_pitch: MinPitch = "schedule",
    pitch_rate_feedback: RateFeedback = "average",
    control_period_s: float = 0.025,
) -> BaselineClosedLoop:
    """Linearised discrete closed loop of plant and baseline controller at a steady wind.

    Parameters
    ----------
    preset : str or FloatingParams
        Floating preset (:func:`plant.platform.load_floating`) or its parameters.
    wind_m_s : float
        Steady hub-height wind U [m/s], above rated.
    baseline_preset : str or BaselineParams
        Baseline preset (:func:`controller.baseline.load_baseline`) or its parameters.
    min_pitch : {"schedule", "flat"}
        The minimum-pitch schedule as given, or flat at its steady value (module docstring).
    pitch_rate_feedback : {"average", "on", "off"}
        Gain of the platform-pitch-rate feedback where it meets the minimum-pitch clamp.
    control_period_s : float
        :math:`T_s` [s], > 0.

    Returns
    -------
    BaselineClosedLoop

    Raises
    ------
    ValueError
        Below rated (neither above-rated branch holds), a bad option, or the law's commands
        not reproducing the steady point.
    """
    from plant.platform import FloatingParams, load_floating  # noqa: PLC0415

    if not (wind_m_s > 0.0 and math.isfinite(wind_m_s)):
        raise ValueError(f"wind_m_s: expected a finite wind > 0 m/s, got {wind_m_s!r}")
    if not (control_period_s > 0.0 and math.isfinite(control_period_s)):
        raise ValueError(
            f"control_period_s: expected a finite period > 0 s, got {control_period_s!r}"
        )
    if min_pitch not in ("schedule", "flat"):
        raise ValueError(f"min_pitch: expected 'schedule' or 'flat', got {min_pitch!r}")
    if pitch_rate_feedback not in ("average", "on", "off"):
        raise ValueError(
            f"pitch_rate_feedback: expected 'average', 'on' or 'off', got {pitch_rate_feedback!r}"
        )
    params = preset if isinstance(preset, FloatingParams) else load_floating(preset)
    bp = (
        baseline_preset
        if isinstance(baseline_preset, BaselineParams)
        else load_baseline(baseline_preset)
    )
    ts = float(control_period_s)
    ctrl = BaselineController(bp)
    op, branch = _steady_point(params, ctrl, float(wind_m_s))
    n_gear = params.turbine.gearbox_ratio
    omega, theta, torque = op.state[_OMEGA], op.state[_PITCH], op.state[_TORQUE]
    v_hat = ctrl.ekf.steady_wind(omega, theta, torque) if ctrl.ekf is not None else math.nan
    floor = bp.min_pitch_at(v_hat) if ctrl.ekf is not None else bp.min_pitch_rad
    slope = 0.0
    if bp.min_pitch_wind_m_s and math.isfinite(v_hat):
        h = 1e-4
        slope = (bp.min_pitch_at(v_hat + h) - bp.min_pitch_at(v_hat - h)) / (2.0 * h)
    if min_pitch == "flat" and bp.min_pitch_wind_m_s:
        bp = replace(
            bp,
            min_pitch_wind_m_s=(bp.min_pitch_wind_m_s[0], bp.min_pitch_wind_m_s[-1]),
            min_pitch_schedule_rad=(floor, floor),
        )
        ctrl = BaselineController(bp)
        slope = 0.0
    y0 = np.array([omega * n_gear, theta, torque, 0.0])
    c0 = _settled_state(ctrl, y0, float(wind_m_s), ts)
    nxt, out = ctrl.step(BaselineState(c0, False), _frame(y0, float(wind_m_s)), ts)
    cmd = np.array([out.blade_pitch_commanded_rad, out.generator_torque_commanded_nm])
    cand = list(_CANDIDATES)
    moved = np.abs(nxt.values[cand] - c0[cand]) > 1e-6 * np.maximum(np.abs(c0[cand]), _FLOOR)
    if np.any(np.abs(cmd - y0[1:3]) > 1e-6 * np.maximum(np.abs(y0[1:3]), 1.0)) or moved.any():
        raise ValueError(
            f"U = {wind_m_s} m/s: the law's steady state is not a fixed point (commands "
            f"{cmd.tolist()} for the point's pitch and torque {y0[1:3].tolist()}; entries "
            f"moving: {[CONTROLLER_STATE_NAMES[i] for i, m in zip(cand, moved, strict=True) if m]})"
        )
    g_c, g_y = _controller_jacobians(ctrl, c0, y0, float(wind_m_s), ts)
    if branch == "min_pitch" and pitch_rate_feedback != "average" and bp.platform_pitch_rate_gain_s:
        # the feedback acts on the pitch command only: J_off with K_fl = 0, J_on = 2 J - J_off
        off = BaselineController(replace(bp, platform_pitch_rate_gain_s=0.0))
        g_c_off, g_y_off = _controller_jacobians(off, c0, y0, float(wind_m_s), ts)
        if pitch_rate_feedback == "off":
            g_c, g_y = g_c_off, g_y_off
        else:
            g_c, g_y = 2.0 * g_c - g_c_off, 2.0 * g_y - g_y_off
    kept = _kept(g_c)
    idx = [_CANDIDATES[j] for j in kept]
    plant = _plant_model(params, op)
    ad, bd = _zoh(plant.a, plant.b, ts)
    nx = ad.shape[0]
    c_meas = np.zeros((4, nx))
    c_meas[0, _OMEGA] = n_gear
    c_meas[1, _PITCH] = 1.0
    c_meas[2, _TORQUE] = 1.0
    c_meas[3, _PITCH_RATE] = 1.0
    u_rows = [_PITCH_CMD, _TORQUE_CMD]
    g_uc = g_c[np.ix_(u_rows, kept)]
    g_uy = g_y[u_rows, :]
    m = np.zeros((nx + len(idx), nx + len(idx)))
    m[:nx, :nx] = ad + bd @ g_uy @ c_meas
    m[:nx, nx:] = bd @ g_uc
    m[nx:, :nx] = g_y[idx, :] @ c_meas
    m[nx:, nx:] = g_c[np.ix_(idx, kept)]
    names = (*plant.state_names, *(CONTROLLER_STATE_NAMES[i] for i in idx))
    return BaselineClosedLoop(
        wind_m_s=float(wind_m_s),
        control_period_s=ts,
        matrix=m,
        state_names=names,
        plant=plant,
        branch=branch,
        min_pitch=min_pitch,
        pitch_rate_feedback=pitch_rate_feedback,
        rotor_speed_rad_s=float(omega),
        blade_pitch_rad=float(theta),
        generator_torque_nm=float(torque),
        wind_estimate_m_s=float(v_hat),
        min_pitch_rad=float(floor),
        min_pitch_slope_rad_per_m_s=float(slope),
        description=_describe(bp, branch, min_pitch, pitch_rate_feedback),
    )


def _describe(
    bp: BaselineParams, branch: Branch, min_pitch: MinPitch, feedback: RateFeedback
) -> str:
    """The branch linearised and the variant, in words."""
    if branch == "pitch_pi":
        if bp.torque_law == "tsr_tracking" or bp.region3_mode == "constant_torque":
            torque = "torque at rated"
        else:
            torque = "torque P/omega_f (constant power)"
        what = f"pitch PI in control, {torque}, minimum pitch inactive"
    else:
        gain = {
            "average": "at half its gain (the mean of its two branches)",
            "on": "at its full gain (its active branch)",
            "off": "off (its clipped branch)",
        }[feedback]
        what = (
            "minimum pitch active (peak shaving), torque PI in control, "
            f"platform-pitch-rate feedback (one-sided at the clamp) {gain}"
        )
    return what + (", minimum pitch flat" if min_pitch == "flat" else "")


def baseline_closed_loop_modes(
    preset: str | FloatingParams,
    wind_m_s: float,
    baseline_preset: str | BaselineParams = "iea15mw_baseline",
    **options: str,
) -> list[dict[str, object]]:
    """Surge, heave, pitch and tower modes of :func:`baseline_closed_loop` as dicts
    (``name``, ``period_s`` [s], ``damping_ratio`` [-], ``eigenvalue`` [re 1/s, im rad/s]:
    :meth:`plant.modes.Mode.as_dict`); ``options`` go to :func:`baseline_closed_loop`."""
    loop = baseline_closed_loop(preset, wind_m_s, baseline_preset, **options)  # type: ignore[arg-type]
    return [m.as_dict() for m in loop.modes()]
