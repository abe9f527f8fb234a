"""Reference baseline controller (variable-speed, collective-pitch), as a pure core.

Source of the algorithm
-----------------------
The NREL 5 MW baseline controller of J. Jonkman, S. Butterfield, W. Musial and G. Scott,
*Definition of a 5-MW Reference Wind Turbine for Offshore System Development*,
NREL/TP-500-38060 (2009), section 7 and the DISCON source listed in its appendix. The
implementation follows that algorithm step by step (written from the published equations,
not copied from any source code):

1. **Generator-speed filter.** First order (the original):

   .. math:: \\alpha = e^{-\\Delta t\\, 2\\pi f_c},\\qquad
             \\omega_f[k] = (1-\\alpha)\\,\\omega[k] + \\alpha\\,\\omega_f[k-1]

   with :math:`f_c` = 0.25 Hz, initialised to the first measurement. A second-order
   option (:math:`\\omega_n^2/(s^2 + 2\\zeta\\omega_n s + \\omega_n^2)`, bilinear/Tustin
   discretisation without prewarping, re-derived every call from ``dt_s``) serves the IEA
   15 MW preset, whose DISCON uses ``F_LPFType = 2``.

2. **Generator torque** (high-speed shaft), from the filtered speed :math:`\\omega_f` and the
   *previous* pitch command :math:`\\theta_{k-1}`:

   * region 3 if :math:`\\omega_f \\ge \\omega_{rt}` (``VS_RtGnSp``, the end of region 2.5) or
     :math:`\\theta_{k-1} \\ge \\theta_{3}` (``VS_Rgn3MP``): :math:`T = P_{rt}/\\omega_f`
     (constant power), or :math:`T = T_{rt}` (constant torque option);
   * region 1 if :math:`\\omega_f \\le \\omega_{ci}`: :math:`T = 0`;
   * region 1.5 if :math:`\\omega_f < \\omega_2`:
     :math:`T = \\frac{K\\omega_2^2}{\\omega_2-\\omega_{ci}}(\\omega_f-\\omega_{ci})`;
   * region 2 if :math:`\\omega_f < \\omega_{tr}`: :math:`T = K\\omega_f^2`;
   * region 2.5 otherwise: :math:`T = s_{25}(\\omega_f-\\omega_{sy})`, with the synchronous
     speed :math:`\\omega_{sy} = \\omega_{rt}/(1+\\sigma/100)` (slip :math:`\\sigma` in %),
     :math:`s_{25} = (P_{rt}/\\omega_{rt})/(\\omega_{rt}-\\omega_{sy})` and the transition speed
     :math:`\\omega_{tr} = \\big(s_{25} - \\sqrt{s_{25}(s_{25}-4K\\omega_{sy})}\\big)/(2K)`
     where the line meets :math:`K\\omega^2`.

   then :math:`T \\leftarrow \\min(T, T_{max})` and the rate limit
   :math:`|T_k - T_{k-1}| \\le \\dot T_{max}\\,\\Delta t`.

   Option ``region25_mode = "pi"`` (used by the IEA 15 MW preset, in the spirit of ROSCO's
   ``VS_ControlMode = 1``): below region 3 the torque is a PI on
   :math:`e_T = \\omega_f - \\omega_{rt}`, :math:`T = K_{P,T} e_T + K_{I,T}\\int e_T\\,dt`,
   saturated between the region-1/1.5/2 law (floor) and :math:`T_{rt}` (ceiling), with
   back-calculation anti-windup (the integrator is reset so the PI output equals the
   saturated torque). Region 3 is then entered on the pitch criterion only.

   Option ``torque_law = "tsr_tracking"`` (the IEA 15 MW preset: the operating schedule of
   ROSCO's ``VS_ControlMode = 2``, ``PS_Mode = 1``, ``SS_Mode = 1``, ``Fl_Mode = 2``)
   replaces the laws above by:

   * a wind-speed estimate :math:`\\hat v` from the EKF of
     :class:`controller.estimators.WindSpeedEKF` (rotor speed :math:`\\omega/N`, measured pitch
     and torque; started from the anemometer, at least 3 m/s, as ROSCO), filtered to
     :math:`\\hat v_f` (first order, :math:`e^{-\\Delta t\\,\\omega_{we}}`);
   * the minimum pitch :math:`\\theta_{lo} = \\max(\\theta_{PS}(\\hat v_f), \\theta_{min})`, a
     linear interpolation of the table (``PS_WindSpeeds``, ``PS_BldPitchMin``), ends held;
   * the setpoint smoother: :math:`\\Delta\\omega = \\big[(\\theta_{k-1} -
     \\theta_{lo,k-1})/0.524\\,g_{VS} - (P_{rt,e} - \\eta T_{k-1}\\omega_f)/P_{rt,e}\\,g_{PC}
     \\big]\\,\\omega_{ref}`, filtered (first order) to :math:`\\Delta\\omega_f`;
   * the torque PI on :math:`e_T = \\omega_f - \\omega_{vs}` with the TSR reference
     :math:`\\omega_{vs} = \\max(\\mathrm{clip}(\\lambda^* N \\hat v_f / R,\\ \\omega_{ci},
     \\omega_{rt}) - \\max(\\Delta\\omega_f, 0),\\ \\omega_{ci})`, its integral clamped so that
     :math:`0 \\le K_{I,T} \\int e_T \\le T_{rt}` and its output clipped to :math:`[0, T_{rt}]`
     (constant torque above rated follows from the saturation); the regime reported is 3
     when :math:`\\theta_{k-1} \\ge \\theta_{lo} + (\\theta_3 - \\theta_{min})`, 2.5 at rated
     torque, 1.5 at the minimum-speed reference, else 2.

   **The estimate's guard** (step 2c, ``"tsr_tracking"``; :func:`controller._kernels.
   ekf_guarded_step`): the EKF's rotor-speed update is skipped when the innovation
   :math:`y = \\omega_r - \\hat\\omega^-` has :math:`y^2 > k^2 s` (:math:`s = P_{\\omega\\omega} +
   r`, ``wind_estimator_gate_sigma`` = k), and :math:`u_t` is set so that :math:`\\hat v =
   u_t + u_m` lies in [``wind_estimate_min_m_s``, ``wind_estimate_max_m_s``]; such a step is
   *bad*. ``wind_estimator_fault_s`` of uninterrupted bad steps, or a non-finite EKF state,
   is an estimator fault: the count (``estimator_faults``) goes up by one if the fallback
   was not on, the fallback starts, the EKF restarts at :math:`(\\omega_r, 0, \\hat v_{good})`
   with its initial covariance, where :math:`\\hat v_{good}` is the filtered estimate before
   the bad run began. In the fallback :math:`\\hat v_f = \\hat v_{good}` (held), the torque is
   :math:`T_{rt}` on the region-3 pitch criterion, else :math:`\\min(K^* \\omega_f^2, T_{rt})`
   with :math:`K^* = \\tfrac12\\rho\\pi R^5 C_p(\\lambda^*, \\theta_{min})/(\\lambda^{*3} N^3)`
   (the anemometer-free region-2 law on the EKF's Cp table), the torque integral is set to
   :math:`T/K_{I,T}`, ``estimator_degraded`` is 1 and the reported estimate is the held one;
   ``wind_estimator_recover_s`` without a bad step ends it.

   **Trimmed start** (:meth:`BaselineController.trimmed_state`): the first step takes the
   EKF's state and :math:`\\hat v_f` from the state (converged at the operating point's mean
   wind) instead of starting them from the anemometer.

3. **Blade pitch** (collective): gain schedule from the previous command,
   :math:`G_K = 1/(1+\\theta_{k-1}/\\theta_K)` (or a table of :math:`K_P(\\theta)`,
   :math:`K_I(\\theta)` with linear interpolation, end values held); speed error
   :math:`e = \\omega_f - \\omega_{ref}`; integrator :math:`I \\mathrel{+}= e\\,\\Delta t`,
   clamped to :math:`[\\theta_{min}/(G_K K_I),\\ \\theta_{max}/(G_K K_I)]` (anti-windup);
   :math:`\\theta = G_K (K_P e + K_I I)` clamped to :math:`[\\theta_{min}, \\theta_{max}]`,
   then rate limited: :math:`|\\theta_k - \\theta_{k-1}| \\le \\dot\\theta_{max}\\Delta t`.
   ``"tsr_tracking"``: the lower limit is :math:`\\theta_{lo}` instead of
   :math:`\\theta_{min}`, the speed reference :math:`\\omega_{ref} + \\max(-\\Delta\\omega_f,
   0)`, and the platform pitch rate :math:`q` (gyro; held on dropout) high-passed (first
   order, :math:`\\omega_{hp}`: :math:`q - m` with :math:`m \\mathrel{+}= g_n (q - m)`,
   :math:`g_n = \\max(1/n, 1 - e^{-\\omega_{hp}\\Delta t})` after the n-th valid sample, so
   that :math:`m` starts as the samples' running mean) and low-passed (second order,
   Tustin) to :math:`q_f` adds
   :math:`K_{fl} q_f` to the clamped PI output, clamped again, before the rate limit.
   On the first call :math:`\\theta_{k-1}` is the measured pitch (clamped to the limits) and
   :math:`I = \\theta_{k-1}/(G_K K_I)`, so that the PI output equals the measured pitch when
   the speed error is zero.

Sign convention: error = measured (filtered) speed − reference, with **positive** gains for
a normal pitch-to-feather controller. ROSCO's DISCON.IN uses error = reference − speed with
negative gains; the IEA 15 MW preset stores ROSCO's gains negated.

Deviations from the original DISCON, each deliberate:

* one rate ``dt_s`` for filter, torque and pitch (DISCON can run them at different rates);
* the pitch rate limit acts against the previous *command* (DISCON limits against the
  measured pitch ``BlPitch``), so consecutive commands never exceed the rate limit;
* on the first call the torque is rate limited against the measured torque (clamped to
  ``[0, max torque]``) instead of being passed unlimited, and the pitch against the
  measured pitch: the first command is bumpless with respect to the actuators;
* constant-power region 3 at :math:`\\omega_f \\le 0` gives zero torque (regime 0) instead
  of dividing by zero; for :math:`0 < \\omega_f \\le P_{rt}/T_{max}` it gives :math:`T_{max}`
  (same as DISCON's saturation);
* the platform-pitch-rate high pass starts as the running mean of the first samples (ROSCO
  starts it at the first sample, whose noise, about 0.6 of the gyro's bias here, then
  stayed in the feedback for :math:`1/\\omega_{hp}` ≈ 100 s: a 0.3° pitch offset and a
  10 cm surge transient at the IEA 15 MW's start).

One implementation: :meth:`BaselineController.step` is one call of the compiled
:func:`controller._kernels.baseline_step` on the state's array (:class:`BaselineState`),
which the in-process compiled loop and the advanced controller's cycle call too; the tests
check it against a plain-Python, statement-by-statement oracle of the law above
(``tests/_baseline_oracle.py``). From Python a step costs about 2 us (1.9 us with the
K omega^2 law, 2.2 us with TSR tracking; the law in Python floats took 1.0 and 6.0 us: best
of 7 x 20 000 calls on the 2-core machine).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from importlib import resources
from pathlib import Path
from typing import Any, Literal, NamedTuple

import msgspec
import numpy as np
import numpy.typing as npt

from bus_schemas.messages import EST_WIND_SPEED, VALID_PLATFORM_PITCH_RATE, SensorFrame
from controller import _kernels
from controller.estimators import (
    CpTable,
    WindEKFConfig,
    WindEKFMeasurement,
    WindSpeedEKF,
    cp_table_from_rosco_text,
)
from controller.interface import (
    ActuatorLimits,
    ControlOutput,
    OperatingPoint,
)

__all__ = [
    "BaselineController",
    "BaselineParams",
    "BaselineState",
    "available_presets",
    "load_baseline",
]

RPM_TO_RAD_S = math.pi / 30.0
"""1 rpm in rad/s."""
DEG_TO_RAD = math.pi / 180.0
"""1 degree in rad."""

_PRESET_PACKAGE = "controller.presets"


def _check_finite(name: str, value: float, unit: str) -> None:
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise TypeError(f"BaselineParams.{name} must be a number in {unit}, got {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"BaselineParams.{name} must be finite ({unit}), got {value!r}")


def _check_positive(name: str, value: float, unit: str) -> None:
    _check_finite(name, value, unit)
    if value <= 0.0:
        raise ValueError(f"BaselineParams.{name} must be > 0 {unit}, got {value!r}")


def _check_nonnegative(name: str, value: float, unit: str) -> None:
    _check_finite(name, value, unit)
    if value < 0.0:
        raise ValueError(f"BaselineParams.{name} must be >= 0 {unit}, got {value!r}")


@dataclass(frozen=True)
class BaselineParams:
    """Parameters of the baseline controller, SI units in the field names.

    All speeds are generator (high-speed shaft) speeds; all torques are generator torques.
    Validation happens on construction; messages name the field and its expected unit.

    Attributes
    ----------
    name : str
        Preset name (informational).
    gearbox_ratio : float
        Gearbox ratio, generator/rotor speed [-] (informational: the controller works on the
        generator side only).
    generator_efficiency_percent : float
        Generator efficiency [%] (informational; ``rated_mechanical_power_w`` is mechanical).
    generator_speed_lpf_order : int
        1 (NREL: first order, :math:`\\alpha = e^{-\\Delta t\\,\\omega_c}`) or 2 (second order,
        Tustin).
    generator_speed_lpf_corner_rad_s : float
        Filter corner frequency :math:`\\omega_c = 2\\pi f_c` [rad/s] (NREL: 2π·0.25 Hz).
    generator_speed_lpf_damping : float
        Damping ratio of the second-order filter [-] (ignored for order 1).
    cut_in_generator_speed_rad_s : float
        :math:`\\omega_{ci}` (``VS_CtInSp``): torque is zero at or below it [rad/s].
    region2_start_generator_speed_rad_s : float
        :math:`\\omega_2` (``VS_Rgn2Sp``): end of region 1.5, start of region 2 [rad/s].
    region2_gain_nm_per_rad_s2 : float
        :math:`K` (``VS_Rgn2K``) of :math:`T = K\\omega^2` [N m/(rad/s)^2].
    region25_end_generator_speed_rad_s : float
        :math:`\\omega_{rt}` (``VS_RtGnSp``): end of region 2.5; in ``"pi"`` mode the
        reference speed of the torque PI [rad/s].
    region25_mode : {"linear_slip", "pi"}
        NREL induction-generator-like line (``"linear_slip"``) or torque PI (``"pi"``).
    region25_slip_percent : float
        Slip :math:`\\sigma` of the region-2.5 line [%] (``"linear_slip"`` only).
    torque_pi_kp_nm_s_per_rad : float
        Proportional gain of the torque PI [N m/(rad/s)] (``"pi"`` only; sign convention
        error = speed − reference).
    torque_pi_ki_nm_per_rad : float
        Integral gain of the torque PI [N m/rad] (``"pi"`` only).
    rated_mechanical_power_w : float
        :math:`P_{rt}` (``VS_RtPwr``), mechanical power held in constant-power region 3 [W].
    rated_generator_torque_nm : float or None
        :math:`T_{rt}`: region-3 torque in constant-torque mode and the end torque of region
        2.5 [N m]. If None: :math:`P_{rt}/\\omega_{rt}` (NREL).
    region3_mode : {"constant_power", "constant_torque"}
        Torque law in region 3.
    region3_min_pitch_rad : float
        :math:`\\theta_3` (``VS_Rgn3MP``): region 3 when the previous pitch command reaches it
        [rad].
    max_generator_torque_nm : float
        :math:`T_{max}` (``VS_MaxTq``) [N m].
    max_generator_torque_rate_nm_s : float
        :math:`\\dot T_{max}` (``VS_MaxRat``) [N m/s].
    pitch_reference_generator_speed_rad_s : float
        :math:`\\omega_{ref}` (``PC_RefSpd``) [rad/s].
    min_pitch_rad, max_pitch_rad : float
        Pitch command limits (``PC_MinPit``, ``PC_MaxPit``) [rad].
    max_pitch_rate_rad_s : float
        :math:`\\dot\\theta_{max}` (``PC_MaxRat``) [rad/s].
    pitch_kp_s : float or None
        :math:`K_P` at zero pitch [s] (i.e. rad per rad/s); with ``pitch_ki_dimensionless`` and
        ``pitch_gain_schedule_theta_k_rad`` for the NREL schedule.
    pitch_ki_dimensionless : float or None
        :math:`K_I` at zero pitch [-] (rad per rad).
    pitch_gain_schedule_theta_k_rad : float or None
        :math:`\\theta_K` of :math:`G_K = 1/(1+\\theta/\\theta_K)` [rad] (NREL: 6.302336 deg).
    pitch_gs_angles_rad, pitch_gs_kp_s, pitch_gs_ki_dimensionless : tuple of float
        Alternative gain schedule: table of pitch angles [rad] (strictly increasing) and the
        gains there (same units as above; positive :math:`K_I`); linear interpolation, end
        values held. Exactly one of the two schedules must be given.
    torque_law : {"k_omega2", "tsr_tracking"}
        The NREL-style laws above, or ROSCO's TSR tracking with the wind EKF, minimum-pitch
        schedule, setpoint smoother and platform-pitch-rate feedback (module docstring).
    optimal_tsr : float or None
        :math:`\\lambda^*` (``VS_TSRopt``) [-] (``"tsr_tracking"``).
    rotor_radius_m, drivetrain_inertia_kg_m2, air_density_kg_m3 : float
        The wind EKF's R [m], J about the low-speed shaft [kg m^2], :math:`\\rho` [kg/m^3]
        (``WE_BladeRadius``, ``WE_Jtot``, ``WE_RhoAir``).
    cp_table : CpTable or None
        The EKF's Cp table (preset key ``cp_table_file``, ROSCO text layout).
    wind_estimator_speed_noise_std_rad_s : float
        The EKF's rotor-speed measurement noise [rad/s].
    wind_estimate_lpf_corner_rad_s : float
        :math:`\\omega_{we}` of the wind-estimate filter [rad/s] (``F_WECornerFreq``).
    min_pitch_wind_m_s, min_pitch_schedule_rad : tuple of float
        Minimum-pitch table [m/s] -> [rad] (``PS_WindSpeeds``, ``PS_BldPitchMin``); empty:
        ``min_pitch_rad``.
    setpoint_smoother_vs_gain, setpoint_smoother_pc_gain : float
        :math:`g_{VS}`, :math:`g_{PC}` [-] (``SS_VSGain``, ``SS_PCGain``); both 0: off.
    setpoint_smoother_lpf_corner_rad_s : float
        Corner of the shift's filter [rad/s] (``F_SSCornerFreq``).
    platform_pitch_rate_gain_s : float
        :math:`K_{fl}` [s] (-``Fl_Kp``); 0: off.
    platform_pitch_rate_lpf_corner_rad_s, platform_pitch_rate_lpf_damping : float
        Second-order low pass of the rate [rad/s], [-] (``F_FlCornerFreq``).
    platform_pitch_rate_hpf_corner_rad_s : float
        First-order high pass of the rate [rad/s] (``F_FlHighPassFreq``).
    wind_estimate_min_m_s, wind_estimate_max_m_s : float
        Physical range of the wind estimate [m/s] (the EKF's mean-wind bounds too; default
        1 and 37.5, a 25 m/s cut-out x 1.5): an estimate outside is clamped to it and counts
        as bad (``"tsr_tracking"``, module docstring step 2c).
    wind_estimator_gate_sigma : float
        k of the EKF's innovation gate, :math:`|y| \\le k\\sqrt{s}` [-] (default 5).
    wind_estimator_fault_s : float
        Time of uninterrupted gating or clamping that makes an estimator fault [s]
        (default 5).
    wind_estimator_recover_s : float
        Time without gating or clamping after which the fallback ends [s] (default 10).
    """

    generator_speed_lpf_corner_rad_s: float
    cut_in_generator_speed_rad_s: float
    region2_start_generator_speed_rad_s: float
    region2_gain_nm_per_rad_s2: float
    region25_end_generator_speed_rad_s: float
    rated_mechanical_power_w: float
    region3_min_pitch_rad: float
    max_generator_torque_nm: float
    max_generator_torque_rate_nm_s: float
    pitch_reference_generator_speed_rad_s: float
    min_pitch_rad: float
    max_pitch_rad: float
    max_pitch_rate_rad_s: float
    name: str = "custom"
    gearbox_ratio: float = 1.0
    generator_efficiency_percent: float = 100.0
    generator_speed_lpf_order: int = 1
    generator_speed_lpf_damping: float = 0.7
    region25_mode: Literal["linear_slip", "pi"] = "linear_slip"
    region25_slip_percent: float = 10.0
    torque_pi_kp_nm_s_per_rad: float = 0.0
    torque_pi_ki_nm_per_rad: float = 0.0
    rated_generator_torque_nm: float | None = None
    region3_mode: Literal["constant_power", "constant_torque"] = "constant_power"
    pitch_kp_s: float | None = None
    pitch_ki_dimensionless: float | None = None
    pitch_gain_schedule_theta_k_rad: float | None = None
    pitch_gs_angles_rad: tuple[float, ...] = field(default_factory=tuple)
    pitch_gs_kp_s: tuple[float, ...] = field(default_factory=tuple)
    pitch_gs_ki_dimensionless: tuple[float, ...] = field(default_factory=tuple)
    torque_law: Literal["k_omega2", "tsr_tracking"] = "k_omega2"
    optimal_tsr: float | None = None
    rotor_radius_m: float | None = None
    drivetrain_inertia_kg_m2: float | None = None
    air_density_kg_m3: float = 1.225
    cp_table: CpTable | None = None
    wind_estimator_speed_noise_std_rad_s: float = 1e-3
    wind_estimate_lpf_corner_rad_s: float = 0.20944
    min_pitch_wind_m_s: tuple[float, ...] = field(default_factory=tuple)
    min_pitch_schedule_rad: tuple[float, ...] = field(default_factory=tuple)
    setpoint_smoother_vs_gain: float = 0.0
    setpoint_smoother_pc_gain: float = 0.0
    setpoint_smoother_lpf_corner_rad_s: float = 0.6283
    platform_pitch_rate_gain_s: float = 0.0
    platform_pitch_rate_lpf_corner_rad_s: float = 0.2130
    platform_pitch_rate_lpf_damping: float = 1.0
    platform_pitch_rate_hpf_corner_rad_s: float = 0.01042
    wind_estimate_min_m_s: float = 1.0
    wind_estimate_max_m_s: float = 37.5
    wind_estimator_gate_sigma: float = 5.0
    wind_estimator_fault_s: float = 5.0
    wind_estimator_recover_s: float = 10.0

    def __post_init__(self) -> None:
        """Validate every field; raise ``ValueError``/``TypeError`` naming field and unit."""
        _check_positive("gearbox_ratio", self.gearbox_ratio, "(-)")
        _check_positive("generator_efficiency_percent", self.generator_efficiency_percent, "%")
        if self.generator_efficiency_percent > 100.0:
            raise ValueError(
                "BaselineParams.generator_efficiency_percent must be <= 100 %, "
                f"got {self.generator_efficiency_percent!r}"
            )
        if self.generator_speed_lpf_order not in (1, 2):
            raise ValueError(
                "BaselineParams.generator_speed_lpf_order must be 1 or 2 (-), "
                f"got {self.generator_speed_lpf_order!r}"
            )
        _check_positive(
            "generator_speed_lpf_corner_rad_s", self.generator_speed_lpf_corner_rad_s, "rad/s"
        )
        _check_positive("generator_speed_lpf_damping", self.generator_speed_lpf_damping, "(-)")
        _check_nonnegative(
            "cut_in_generator_speed_rad_s", self.cut_in_generator_speed_rad_s, "rad/s"
        )
        _check_positive(
            "region2_start_generator_speed_rad_s",
            self.region2_start_generator_speed_rad_s,
            "rad/s",
        )
        if self.region2_start_generator_speed_rad_s <= self.cut_in_generator_speed_rad_s:
            raise ValueError(
                "BaselineParams.region2_start_generator_speed_rad_s must be > "
                f"cut_in_generator_speed_rad_s ({self.cut_in_generator_speed_rad_s!r} rad/s), "
                f"got {self.region2_start_generator_speed_rad_s!r} rad/s"
            )
        _check_positive(
            "region2_gain_nm_per_rad_s2", self.region2_gain_nm_per_rad_s2, "N m/(rad/s)^2"
        )
        _check_positive(
            "region25_end_generator_speed_rad_s", self.region25_end_generator_speed_rad_s, "rad/s"
        )
        if self.region25_end_generator_speed_rad_s <= self.region2_start_generator_speed_rad_s:
            raise ValueError(
                "BaselineParams.region25_end_generator_speed_rad_s must be > "
                "region2_start_generator_speed_rad_s "
                f"({self.region2_start_generator_speed_rad_s!r} rad/s), "
                f"got {self.region25_end_generator_speed_rad_s!r} rad/s"
            )
        _check_positive("rated_mechanical_power_w", self.rated_mechanical_power_w, "W")
        if self.rated_generator_torque_nm is not None:
            _check_positive("rated_generator_torque_nm", self.rated_generator_torque_nm, "N m")
        if self.region3_mode not in ("constant_power", "constant_torque"):
            raise ValueError(
                "BaselineParams.region3_mode must be 'constant_power' or 'constant_torque', "
                f"got {self.region3_mode!r}"
            )
        _check_finite("region3_min_pitch_rad", self.region3_min_pitch_rad, "rad")
        _check_positive("max_generator_torque_nm", self.max_generator_torque_nm, "N m")
        if self.rated_torque_nm > self.max_generator_torque_nm:
            raise ValueError(
                "BaselineParams.max_generator_torque_nm must be >= the rated torque "
                f"({self.rated_torque_nm!r} N m), got {self.max_generator_torque_nm!r} N m"
            )
        _check_positive(
            "max_generator_torque_rate_nm_s", self.max_generator_torque_rate_nm_s, "N m/s"
        )
        _check_positive(
            "pitch_reference_generator_speed_rad_s",
            self.pitch_reference_generator_speed_rad_s,
            "rad/s",
        )
        _check_finite("min_pitch_rad", self.min_pitch_rad, "rad")
        _check_finite("max_pitch_rad", self.max_pitch_rad, "rad")
        if self.max_pitch_rad <= self.min_pitch_rad:
            raise ValueError(
                f"BaselineParams.max_pitch_rad must be > min_pitch_rad ({self.min_pitch_rad!r} "
                f"rad), got {self.max_pitch_rad!r} rad"
            )
        _check_positive("max_pitch_rate_rad_s", self.max_pitch_rate_rad_s, "rad/s")

        if self.region25_mode == "linear_slip":
            _check_positive("region25_slip_percent", self.region25_slip_percent, "%")
            _, _, w_tr = self._region25_line()
            if not (
                self.region2_start_generator_speed_rad_s
                <= w_tr
                < self.region25_end_generator_speed_rad_s
            ):
                raise ValueError(
                    "BaselineParams: the region-2.5 line (region25_slip_percent, "
                    "region25_end_generator_speed_rad_s, rated torque) meets K*omega^2 at "
                    f"{w_tr!r} rad/s, outside [region2_start_generator_speed_rad_s, "
                    "region25_end_generator_speed_rad_s); use region25_mode = 'pi' or adjust"
                )
        elif self.region25_mode == "pi":
            _check_positive(
                "torque_pi_kp_nm_s_per_rad", self.torque_pi_kp_nm_s_per_rad, "N m s/rad"
            )
            _check_positive("torque_pi_ki_nm_per_rad", self.torque_pi_ki_nm_per_rad, "N m/rad")
        else:
            raise ValueError(
                "BaselineParams.region25_mode must be 'linear_slip' or 'pi', "
                f"got {self.region25_mode!r}"
            )

        theta_k_given = (
            self.pitch_kp_s is not None
            or self.pitch_ki_dimensionless is not None
            or self.pitch_gain_schedule_theta_k_rad is not None
        )
        table_given = bool(
            self.pitch_gs_angles_rad or self.pitch_gs_kp_s or self.pitch_gs_ki_dimensionless
        )
        if theta_k_given == table_given:
            raise ValueError(
                "BaselineParams: give exactly one pitch gain schedule, either pitch_kp_s [s], "
                "pitch_ki_dimensionless [-] and pitch_gain_schedule_theta_k_rad [rad], or the "
                "table pitch_gs_angles_rad [rad], pitch_gs_kp_s [s], pitch_gs_ki_dimensionless [-]"
            )
        if theta_k_given:
            for name, unit in (
                ("pitch_kp_s", "s"),
                ("pitch_ki_dimensionless", "(-)"),
                ("pitch_gain_schedule_theta_k_rad", "rad"),
            ):
                value = getattr(self, name)
                if value is None:
                    raise ValueError(f"BaselineParams.{name} [{unit}] is required with theta_K")
                _check_positive(name, value, unit)
            theta_k = self.pitch_gain_schedule_theta_k_rad
            assert theta_k is not None
            if self.min_pitch_rad <= -theta_k:
                raise ValueError(
                    "BaselineParams.min_pitch_rad must be > -pitch_gain_schedule_theta_k_rad "
                    f"({-theta_k!r} rad) for a finite gain schedule, got {self.min_pitch_rad!r} rad"
                )
        else:
            n = len(self.pitch_gs_angles_rad)
            if n < 1 or len(self.pitch_gs_kp_s) != n or len(self.pitch_gs_ki_dimensionless) != n:
                raise ValueError(
                    "BaselineParams.pitch_gs_angles_rad [rad], pitch_gs_kp_s [s] and "
                    "pitch_gs_ki_dimensionless [-] must be non-empty and of equal length, got "
                    f"{n}, {len(self.pitch_gs_kp_s)}, {len(self.pitch_gs_ki_dimensionless)}"
                )
            for i, a in enumerate(self.pitch_gs_angles_rad):
                _check_finite(f"pitch_gs_angles_rad[{i}]", a, "rad")
                if i and a <= self.pitch_gs_angles_rad[i - 1]:
                    raise ValueError(
                        "BaselineParams.pitch_gs_angles_rad must be strictly increasing (rad), "
                        f"entry {i} is {a!r}"
                    )
            for i, kp in enumerate(self.pitch_gs_kp_s):
                _check_finite(f"pitch_gs_kp_s[{i}]", kp, "s")
            for i, ki in enumerate(self.pitch_gs_ki_dimensionless):
                _check_positive(f"pitch_gs_ki_dimensionless[{i}]", ki, "(-)")
            object.__setattr__(self, "pitch_gs_angles_rad", tuple(self.pitch_gs_angles_rad))
            object.__setattr__(self, "pitch_gs_kp_s", tuple(self.pitch_gs_kp_s))
            object.__setattr__(
                self, "pitch_gs_ki_dimensionless", tuple(self.pitch_gs_ki_dimensionless)
            )

        self._check_tsr_tracking()

    def _check_tsr_tracking(self) -> None:
        """Validate the TSR-tracking torque law, its wind estimator and the pitch schedule."""
        if self.torque_law not in ("k_omega2", "tsr_tracking"):
            raise ValueError(
                "BaselineParams.torque_law must be 'k_omega2' or 'tsr_tracking', "
                f"got {self.torque_law!r}"
            )
        schedule = bool(self.min_pitch_wind_m_s or self.min_pitch_schedule_rad)
        smoother = self.setpoint_smoother_vs_gain != 0.0 or self.setpoint_smoother_pc_gain != 0.0
        _check_finite("platform_pitch_rate_gain_s", self.platform_pitch_rate_gain_s, "s")
        if self.torque_law == "k_omega2":
            if schedule or smoother or self.platform_pitch_rate_gain_s != 0.0:
                raise ValueError(
                    "BaselineParams: the minimum-pitch schedule (min_pitch_wind_m_s, "
                    "min_pitch_schedule_rad), the setpoint smoother and the platform-pitch-rate "
                    "feedback belong to ROSCO's schedule: use torque_law = 'tsr_tracking'"
                )
            return
        for name in (
            "platform_pitch_rate_lpf_corner_rad_s",
            "platform_pitch_rate_lpf_damping",
            "platform_pitch_rate_hpf_corner_rad_s",
        ):
            _check_positive(name, getattr(self, name), "rad/s" if "corner" in name else "(-)")
        for name, unit in (
            ("optimal_tsr", "(-)"),
            ("rotor_radius_m", "m"),
            ("drivetrain_inertia_kg_m2", "kg m^2"),
        ):
            value = getattr(self, name)
            if value is None:
                raise ValueError(f"BaselineParams.{name} [{unit}] is required with tsr_tracking")
            _check_positive(name, value, unit)
        if not isinstance(self.cp_table, CpTable):
            raise ValueError(
                "BaselineParams.cp_table (a Cp table, preset key cp_table_file) is required "
                "with tsr_tracking"
            )
        if self.region25_mode != "pi":
            raise ValueError(
                "BaselineParams: tsr_tracking uses the torque PI; set region25_mode = 'pi' "
                "with torque_pi_kp_nm_s_per_rad and torque_pi_ki_nm_per_rad"
            )
        _check_positive("air_density_kg_m3", self.air_density_kg_m3, "kg/m^3")
        _check_positive(
            "wind_estimator_speed_noise_std_rad_s",
            self.wind_estimator_speed_noise_std_rad_s,
            "rad/s",
        )
        _check_positive(
            "wind_estimate_lpf_corner_rad_s", self.wind_estimate_lpf_corner_rad_s, "rad/s"
        )
        _check_nonnegative("wind_estimate_min_m_s", self.wind_estimate_min_m_s, "m/s")
        _check_positive("wind_estimate_max_m_s", self.wind_estimate_max_m_s, "m/s")
        if self.wind_estimate_max_m_s <= max(self.wind_estimate_min_m_s, 3.0):
            raise ValueError(
                "BaselineParams.wind_estimate_max_m_s must exceed wind_estimate_min_m_s and "
                f"3 m/s (the estimator's lowest start), got {self.wind_estimate_max_m_s!r} m/s"
            )
        _check_positive("wind_estimator_gate_sigma", self.wind_estimator_gate_sigma, "(-)")
        _check_positive("wind_estimator_fault_s", self.wind_estimator_fault_s, "s")
        _check_positive("wind_estimator_recover_s", self.wind_estimator_recover_s, "s")
        _check_nonnegative("setpoint_smoother_vs_gain", self.setpoint_smoother_vs_gain, "(-)")
        _check_nonnegative("setpoint_smoother_pc_gain", self.setpoint_smoother_pc_gain, "(-)")
        _check_positive(
            "setpoint_smoother_lpf_corner_rad_s", self.setpoint_smoother_lpf_corner_rad_s, "rad/s"
        )
        n = len(self.min_pitch_wind_m_s)
        if n != len(self.min_pitch_schedule_rad):
            raise ValueError(
                "BaselineParams.min_pitch_wind_m_s [m/s] and min_pitch_schedule_rad [rad] must "
                f"be of equal length, got {n} and {len(self.min_pitch_schedule_rad)}"
            )
        for i, v in enumerate(self.min_pitch_wind_m_s):
            _check_finite(f"min_pitch_wind_m_s[{i}]", v, "m/s")
            if i and v <= self.min_pitch_wind_m_s[i - 1]:
                raise ValueError(
                    "BaselineParams.min_pitch_wind_m_s must be strictly increasing (m/s), "
                    f"entry {i} is {v!r}"
                )
        for i, th in enumerate(self.min_pitch_schedule_rad):
            _check_finite(f"min_pitch_schedule_rad[{i}]", th, "rad")
            if not self.min_pitch_rad <= th < self.max_pitch_rad:
                raise ValueError(
                    f"BaselineParams.min_pitch_schedule_rad[{i}] must lie in [min_pitch_rad, "
                    f"max_pitch_rad) ({self.min_pitch_rad!r}, {self.max_pitch_rad!r} rad), "
                    f"got {th!r} rad"
                )
        object.__setattr__(self, "min_pitch_wind_m_s", tuple(self.min_pitch_wind_m_s))
        object.__setattr__(self, "min_pitch_schedule_rad", tuple(self.min_pitch_schedule_rad))

    def without_wind_schedule(self) -> BaselineParams:
        """These parameters with the K omega^2 torque law and a fixed minimum pitch.

        The advanced controller (:mod:`controller.runtime`) uses the baseline's region-1.5/2
        torque law and its pitch PI at fine pitch below rated; it has its own wind estimate
        and regime logic, so the TSR tracking, the minimum-pitch schedule and the setpoint
        smoother of a ``"tsr_tracking"`` preset are dropped here.
        """
        return replace(
            self,
            torque_law="k_omega2",
            min_pitch_wind_m_s=(),
            min_pitch_schedule_rad=(),
            setpoint_smoother_vs_gain=0.0,
            setpoint_smoother_pc_gain=0.0,
            platform_pitch_rate_gain_s=0.0,
        )

    def min_pitch_at(self, wind_m_s: float) -> float:
        """Minimum pitch of the schedule at a wind estimate [rad] (``min_pitch_rad`` without).

        Linear interpolation in (``min_pitch_wind_m_s``, ``min_pitch_schedule_rad``), end
        values held (ROSCO's ``interp1d``), never below ``min_pitch_rad``.
        """
        return _min_pitch(
            self.min_pitch_wind_m_s, self.min_pitch_schedule_rad, wind_m_s, self.min_pitch_rad
        )

    # --- derived quantities -------------------------------------------------------------

    @property
    def rated_torque_nm(self) -> float:
        """Rated generator torque :math:`T_{rt}` [N m]: the given value or P_rt/ω_rt (NREL)."""
        if self.rated_generator_torque_nm is not None:
            return self.rated_generator_torque_nm
        return self.rated_mechanical_power_w / self.region25_end_generator_speed_rad_s

    @property
    def region15_slope_nm_s_per_rad(self) -> float:
        """Region-1.5 slope :math:`K\\omega_2^2/(\\omega_2-\\omega_{ci})` [N m/(rad/s)]."""
        w2 = self.region2_start_generator_speed_rad_s
        return self.region2_gain_nm_per_rad_s2 * w2 * w2 / (w2 - self.cut_in_generator_speed_rad_s)

    def _region25_line(self) -> tuple[float, float, float]:
        w_rt = self.region25_end_generator_speed_rad_s
        w_sy = w_rt / (1.0 + 0.01 * self.region25_slip_percent)
        s25 = self.rated_torque_nm / (w_rt - w_sy)
        k = self.region2_gain_nm_per_rad_s2
        disc = s25 * (s25 - 4.0 * k * w_sy)
        w_tr = (s25 - math.sqrt(disc)) / (2.0 * k) if disc >= 0.0 else math.inf
        return s25, w_sy, w_tr

    @property
    def region25_slope_nm_s_per_rad(self) -> float:
        """Region-2.5 slope :math:`s_{25} = T_{rt}/(\\omega_{rt}-\\omega_{sy})` [N m/(rad/s)]."""
        return self._region25_line()[0]

    @property
    def synchronous_generator_speed_rad_s(self) -> float:
        """:math:`\\omega_{sy} = \\omega_{rt}/(1+\\sigma/100)` (``VS_SySp``) [rad/s]."""
        return self._region25_line()[1]

    @property
    def transition_generator_speed_rad_s(self) -> float:
        """Region 2 → 2.5 speed :math:`\\omega_{tr}` (``VS_TrGnSp``) [rad/s].

        In ``"pi"`` mode it is :math:`\\omega_{rt}` (the PI takes over smoothly).
        """
        if self.region25_mode == "pi":
            return self.region25_end_generator_speed_rad_s
        return self._region25_line()[2]


class BaselineState(NamedTuple):
    """State of :class:`BaselineController` between two steps: one float array and a flag.

    ``values`` (float64, :data:`controller._kernels.BL_STATE_SIZE` entries) is the storage
    :func:`controller._kernels.baseline_step` reads; :meth:`BaselineController.step` never
    modifies it (it returns a new state with a new array), so a state may be kept. Its
    entries, also readable by name (the properties below, floats):

    * ``lpf_z1``, ``lpf_z2``: generator-speed filter states [rad/s] (order 1: ``lpf_z1`` is
      the last output);
    * ``generator_speed_filtered_rad_s``: last filtered generator speed [rad/s];
    * ``pitch_speed_error_integral_rad``: :math:`I = \\int (\\omega_f-\\omega_{ref})\\,dt`
      of the pitch PI [rad];
    * ``torque_speed_error_integral_rad``: :math:`\\int (\\omega_f-\\omega_{rt})\\,dt` of the
      torque PI [rad] (``"pi"`` mode and ``"tsr_tracking"``);
    * ``blade_pitch_commanded_rad``, ``generator_torque_commanded_nm``: last commands
      [rad, N m];
    * ``"tsr_tracking"`` only: ``wind_filtered_m_s`` (:math:`\\hat v_f` [m/s]),
      ``setpoint_shift_rad_s`` (:math:`\\Delta\\omega_f` [rad/s]), ``min_pitch_rad`` (the last
      :math:`\\theta_{lo}` [rad]), ``wind_ekf_x`` (3) and ``wind_ekf_p`` (6: the wind EKF's
      state and covariance, :class:`controller.estimators.WindEKFState`), ``fl_hpf_lp``,
      ``fl_lpf_z1``, ``fl_lpf_z2`` (the platform-pitch-rate filters [rad/s]: the high
      pass's low-pass part, the second-order low pass), ``platform_pitch_rate_rad_s`` (the
      last valid rate [rad/s], held on dropout), ``estimator_faults`` (the wind guard's
      faults so far), ``wind_bad_s`` and ``wind_good_s`` (the current run of gated or
      clamped, and of healthy, steps [s]), ``wind_fallback`` (the fallback is on) and
      ``wind_last_good_m_s`` (the filtered estimate before the current bad run [m/s]);
      ``trimmed`` (with ``first_call``: start the EKF and the wind filter from these values,
      :meth:`BaselineController.trimmed_state`); ``fl_samples`` (valid platform-pitch-rate
      samples so far: the high pass starts as their running mean).

    ``first_call`` is True before the first step, which initialises from the measurement.
    """

    values: npt.NDArray[np.float64]
    first_call: bool = True

    @property
    def lpf_z1(self) -> float:
        return float(self.values[0])

    @property
    def lpf_z2(self) -> float:
        return float(self.values[1])

    @property
    def generator_speed_filtered_rad_s(self) -> float:
        return float(self.values[2])

    @property
    def pitch_speed_error_integral_rad(self) -> float:
        return float(self.values[3])

    @property
    def torque_speed_error_integral_rad(self) -> float:
        return float(self.values[4])

    @property
    def blade_pitch_commanded_rad(self) -> float:
        return float(self.values[5])

    @property
    def generator_torque_commanded_nm(self) -> float:
        return float(self.values[6])

    @property
    def wind_filtered_m_s(self) -> float:
        return float(self.values[7])

    @property
    def setpoint_shift_rad_s(self) -> float:
        return float(self.values[8])

    @property
    def min_pitch_rad(self) -> float:
        return float(self.values[9])

    @property
    def wind_ekf_x(self) -> tuple[float, float, float]:
        v = self.values
        return float(v[10]), float(v[11]), float(v[12])

    @property
    def wind_ekf_p(self) -> tuple[float, ...]:
        return tuple(self.values[13:19].tolist())

    @property
    def fl_hpf_lp(self) -> float:
        return float(self.values[19])

    @property
    def fl_lpf_z1(self) -> float:
        return float(self.values[20])

    @property
    def fl_lpf_z2(self) -> float:
        return float(self.values[21])

    @property
    def platform_pitch_rate_rad_s(self) -> float:
        return float(self.values[22])

    @property
    def estimator_faults(self) -> int:
        return int(self.values[23])

    @property
    def wind_bad_s(self) -> float:
        return float(self.values[24])

    @property
    def wind_good_s(self) -> float:
        return float(self.values[25])

    @property
    def wind_fallback(self) -> bool:
        return bool(self.values[26])

    @property
    def fl_samples(self) -> float:
        return float(self.values[29])

    @property
    def wind_last_good_m_s(self) -> float:
        return float(self.values[27])

    @property
    def trimmed(self) -> bool:
        return bool(self.values[28])


#: Time the wind EKF is stepped at a trimmed operating point [s] (``trimmed_state``), and
#: its step [s]: the covariance reaches its steady value in about 20 s.
TRIM_EKF_S = 60.0
TRIM_EKF_DT_S = 0.025

#: A frame for the warm-up step at construction (any finite values).
_WARM_FRAME = SensorFrame(0, 0, 0, 0, *(0.0,) * len(SensorFrame.__struct_fields__[4:]))


def _warm_step_s(operating_point: OperatingPoint) -> float:
    """The period [s] of a step on the point's steady frame: the run's control period
    (the speed filter's steady state depends on it), else :data:`TRIM_EKF_DT_S`."""
    return operating_point.control_period_s or TRIM_EKF_DT_S


class BaselineController:
    """NREL-style baseline torque + gain-scheduled collective-pitch PI controller.

    Immutable: all constants are derived once from :class:`BaselineParams` at construction;
    :meth:`step` is a pure function of its arguments.

    Parameters
    ----------
    params : BaselineParams
        Validated controller parameters.
    """

    __slots__ = ("_bl", "_gs", "_k", "_n_gs", "_tables", "ekf", "params")

    params: BaselineParams
    ekf: WindSpeedEKF | None
    _k: tuple[Any, ...]
    _bl: npt.NDArray[np.float64]
    _gs: npt.NDArray[np.float64]
    _n_gs: int
    _tables: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]

    def __init__(self, params: BaselineParams) -> None:
        p = params
        s25, w_sy, w_tr = p._region25_line()
        table = bool(p.pitch_gs_angles_rad)
        if table:
            kp0 = ki0 = 0.0
            theta_k = 1.0
            ki_ref = p.pitch_gs_ki_dimensionless[0]
        else:
            assert p.pitch_kp_s is not None
            assert p.pitch_ki_dimensionless is not None
            assert p.pitch_gain_schedule_theta_k_rad is not None
            kp0 = p.pitch_kp_s
            ki0 = p.pitch_ki_dimensionless
            theta_k = p.pitch_gain_schedule_theta_k_rad
            ki_ref = ki0
        pi_mode = p.region25_mode == "pi"
        tsr = p.torque_law == "tsr_tracking"
        ekf: WindSpeedEKF | None = None
        if tsr:
            assert p.cp_table is not None and p.rotor_radius_m is not None
            assert p.drivetrain_inertia_kg_m2 is not None
            ekf = WindSpeedEKF(
                WindEKFConfig(
                    p.cp_table,
                    p.rotor_radius_m,
                    p.drivetrain_inertia_kg_m2,
                    p.gearbox_ratio,
                    air_density_kg_m3=p.air_density_kg_m3,
                    rotor_speed_noise_std_rad_s=p.wind_estimator_speed_noise_std_rad_s,
                    wind_min_m_s=max(p.wind_estimate_min_m_s, 1e-3),
                    wind_max_m_s=p.wind_estimate_max_m_s,
                )
            )
        k = (
            p.generator_speed_lpf_order == 2,
            p.generator_speed_lpf_corner_rad_s,
            p.generator_speed_lpf_damping,
            p.cut_in_generator_speed_rad_s,
            p.region2_start_generator_speed_rad_s,
            p.region2_gain_nm_per_rad_s2,
            p.region15_slope_nm_s_per_rad,
            # In PI mode the speed criterion for region 3 is disabled (pitch criterion only).
            math.inf if pi_mode else p.region25_end_generator_speed_rad_s,
            math.inf if pi_mode else w_tr,
            s25,
            w_sy,
            pi_mode,
            p.region25_end_generator_speed_rad_s,
            p.torque_pi_kp_nm_s_per_rad,
            p.torque_pi_ki_nm_per_rad,
            p.region3_mode == "constant_torque",
            p.rated_mechanical_power_w,
            p.rated_torque_nm,
            p.region3_min_pitch_rad,
            p.max_generator_torque_nm,
            p.max_generator_torque_rate_nm_s,
            p.pitch_reference_generator_speed_rad_s,
            p.min_pitch_rad,
            p.max_pitch_rad,
            p.max_pitch_rate_rad_s,
            table,
            kp0,
            ki0,
            theta_k,
            p.pitch_gs_angles_rad,
            p.pitch_gs_kp_s,
            p.pitch_gs_ki_dimensionless,
            1.0 / ki_ref,
            p.rated_mechanical_power_w / p.max_generator_torque_nm,
            # --- "tsr_tracking" (indices 34-47; module docstring, step 2b)
            tsr,
            (p.optimal_tsr or 0.0) * p.gearbox_ratio / (p.rotor_radius_m or 1.0),
            p.wind_estimate_lpf_corner_rad_s,
            p.setpoint_smoother_vs_gain,
            p.setpoint_smoother_pc_gain,
            p.setpoint_smoother_lpf_corner_rad_s,
            0.01 * p.generator_efficiency_percent,
            0.01 * p.generator_efficiency_percent * p.rated_mechanical_power_w,
            p.region3_min_pitch_rad - p.min_pitch_rad,
            p.gearbox_ratio,
            ekf.config.initial_wind_std_m_s if ekf is not None else 0.0,
            len(p.min_pitch_wind_m_s),
            p.platform_pitch_rate_gain_s,
            p.platform_pitch_rate_lpf_corner_rad_s,
            p.platform_pitch_rate_lpf_damping,
            p.platform_pitch_rate_hpf_corner_rad_s,
            p.min_pitch_wind_m_s,
            p.min_pitch_schedule_rad,
            # --- the wind estimate's guard (indices 52-57; module docstring, step 2c)
            p.wind_estimator_gate_sigma**2,
            p.wind_estimate_min_m_s,
            p.wind_estimate_max_m_s,
            p.wind_estimator_fault_s,
            p.wind_estimator_recover_s,
            _fallback_region2_gain(p, ekf),
        )
        object.__setattr__(self, "params", params)
        object.__setattr__(self, "ekf", ekf)
        object.__setattr__(self, "_k", k)
        # the kernel's constants (kernel_arrays) and the wind EKF's tables (empty for the
        # K omega^2 law), once
        bl, gs, n_gs = self.kernel_arrays()
        object.__setattr__(self, "_bl", bl)
        object.__setattr__(self, "_gs", gs)
        object.__setattr__(self, "_n_gs", n_gs)
        tables = (
            ekf.kernel_tables
            if ekf is not None
            else (np.zeros(0), np.zeros(0), np.zeros(0), np.zeros((0, 8)))
        )
        object.__setattr__(self, "_tables", tables)
        # load the step's kernel now (numba's disk cache), not in the first (paced) cycle
        self.step(self.initial_state(), _WARM_FRAME, 0.025)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable")

    def __repr__(self) -> str:
        return f"BaselineController(params={self.params!r})"

    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray, int]:
        """The constants of :func:`controller._kernels.baseline_step` as arrays.

        Returns
        -------
        bl : ndarray
            ``_k`` without its four table tuples, flags as 0/1
            (:data:`controller._kernels.BL_CONSTANTS` order).
        gs : ndarray
            Pitch gain table (angles, K_P, K_I), then the minimum-pitch schedule (winds,
            pitches).
        n_gs : int
            Length of the gain table.
        """
        k = self._k
        bl = np.array([float(v) for v in (*k[:29], *k[32:50], *k[52:58])])
        gs = np.array([*k[29], *k[30], *k[31], *k[50], *k[51]], dtype=np.float64)
        return bl, gs, len(k[29])

    def kernel_bundle(self, state: BaselineState, dt_s: float | None = None) -> _kernels.CoreBundle:
        """This core's constants and ``state`` as a compiled loop takes them (the period
        ``dt_s`` is the loop's argument of every step: unused here).

        ``v`` holds ``state`` as :func:`controller._kernels.baseline_step`'s ``st``
        (:data:`controller._kernels.BL_STATE_SIZE` entries, field order of
        :class:`BaselineState`), ``ci[CI_FIRST]`` its first-call flag; the TSR-tracking
        law's wind EKF tables travel in ``cc`` with their layout in ``lay``
        (:class:`controller._kernels.CoreBundle`). A compiled loop's cycles then
        :meth:`state_from_bundle`.
        """
        bl, gs, n_gs = self._bl.copy(), self._gs.copy(), self._n_gs
        ci = np.zeros(_kernels.CI_SIZE, dtype=np.int64)
        ci[_kernels.CI_KIND] = 0
        ci[_kernels.CI_N_GS] = n_gs
        if self.ekf is not None:
            prm, tsr, pitch, cells = self.ekf.kernel_tables
            cc = np.concatenate([prm, tsr, pitch, cells.ravel()])
            lay = np.array(
                [
                    EST_WIND_SPEED,
                    prm.size,
                    tsr.size,
                    pitch.size,
                    cells.shape[0],
                    VALID_PLATFORM_PITCH_RATE,
                ],
                dtype=np.int64,
            )
        else:
            cc, lay = np.zeros(0), np.zeros(6, dtype=np.int64)
        v = np.zeros(_kernels.BL_STATE_SIZE)
        no_flags = np.zeros(0, dtype=np.int64)
        bundle = _kernels.CoreBundle(ci, cc, lay, bl, gs, v, np.zeros_like(v), no_flags, no_flags)
        self.load_bundle(bundle, state)
        return bundle

    @staticmethod
    def load_bundle(bundle: _kernels.CoreBundle, state: BaselineState) -> None:
        """Copy ``state`` into ``bundle`` (of :meth:`kernel_bundle`): its array into ``v``,
        the first-call flag into ``ci``."""
        bundle.ci[_kernels.CI_FIRST] = 1 if state.first_call else 0
        bundle.v[:] = state.values

    @staticmethod
    def state_from_bundle(bundle: _kernels.CoreBundle) -> BaselineState:
        """The state a compiled loop left in ``bundle`` (:meth:`kernel_bundle`; a copy)."""
        return BaselineState(bundle.v.copy(), bool(bundle.ci[_kernels.CI_FIRST]))

    def initial_state(self) -> BaselineState:
        """State before the first call; the first :meth:`step` initialises it from data."""
        return BaselineState(np.zeros(_kernels.BL_STATE_SIZE), True)

    def trimmed_state(self, operating_point: OperatingPoint) -> BaselineState:
        """State before the first call of a run started at ``operating_point`` (trimmed).

        The TSR law's wind EKF does not start from the anemometer (behind the rotor it reads
        low: 6.8 m/s in an 8 m/s wind, and the estimate's recovery kicked the torque by
        24 %) but converged at the point: started at the mean wind and stepped for
        :data:`TRIM_EKF_S` on the point's rotor speed, pitch and generator torque (given,
        else the EKF model's own balance at the mean wind); the wind filter at its estimate.
        Then one step on the point's steady frame (:meth:`OperatingPoint.steady_frame`:
        no noise or quantisation, the instruments' offsets) initialises what a first call
        takes from its measurement: the speed filter, the last commands, the pitch and
        torque integrators, the platform-pitch-rate high pass; at the run's control period
        (``operating_point.control_period_s``, else :data:`TRIM_EKF_DT_S`), since the
        speed filter's steady state depends on it (stepped at 0.025 s for a 0.01 s run, its
        output jumped on the first cycle and the torque law kicked the rotor 20 % at 4 m/s).
        Taken from the run's first noisy frame instead, the blade-pitch encoder's noise and
        14-bit step moved the pitch integrator by up to 0.02° and the NREL 5 MW OC3 spar's
        surge by twice the steady noise's level over the first 60 s above rated
        (``bench/trimmed_start.py --table --seeds``). Without a torque at the point the
        law's own: the step's torque command on a first frame at zero torque.

        Parameters
        ----------
        operating_point : OperatingPoint
            Mean wind [m/s], rotor speed [rad/s], pitch [rad], generator torque [N m] or
            None.
        """
        state, frame = self.trimmed_estimator_state(operating_point)
        return self.step(state, frame, _warm_step_s(operating_point))[0]

    def trimmed_estimator_state(
        self, operating_point: OperatingPoint
    ) -> tuple[BaselineState, SensorFrame]:
        """:meth:`trimmed_state` before its step: the first-call state with the wind EKF
        converged at the point (the initial state for a law without it), and the steady
        frame the step takes."""
        state = self.initial_state()
        p = self.params
        op = operating_point
        torque = op.generator_torque_nm
        ekf = self.ekf
        if ekf is not None:
            wind = min(max(op.wind_m_s, p.wind_estimate_min_m_s, 3.0), p.wind_estimate_max_m_s)
            omega, theta = op.rotor_speed_rad_s, op.blade_pitch_rad
            if torque is None:
                torque = ekf.aero_torque(omega, wind, theta)[0] / p.gearbox_ratio
            es = ekf.initial_state(omega, theta, torque, wind)
            m = WindEKFMeasurement(omega, theta, torque, True)
            for _ in range(round(TRIM_EKF_S / TRIM_EKF_DT_S)):
                es, _ = ekf.step(es, m, TRIM_EKF_DT_S)
            v = es.x[1] + es.x[2]
            values = state.values.copy()
            values[7] = v  # the wind filter
            values[10:13] = es.x
            values[13:19] = es.p
            values[27] = v  # the last good estimate
            values[28] = 1.0  # trimmed start
            state = BaselineState(values, True)
        if torque is None:  # the law's own torque at the point (K omega^2, the region-2.5 PI)
            zero = op.steady_frame(gearbox_ratio=p.gearbox_ratio, generator_torque_nm=0.0)
            torque = self.step(state, zero, _warm_step_s(op))[1].generator_torque_commanded_nm
        frame = op.steady_frame(
            gearbox_ratio=p.gearbox_ratio,
            generator_torque_nm=torque,
            generator_efficiency=p.generator_efficiency_percent / 100.0,
        )
        return state, frame

    def actuator_limits(self) -> ActuatorLimits:
        """The preset's pitch range [rad] and pitch [rad/s] and torque [N m/s] rate limits."""
        p = self.params
        return ActuatorLimits(
            p.min_pitch_rad,
            p.max_pitch_rad,
            p.max_pitch_rate_rad_s,
            p.max_generator_torque_rate_nm_s,
        )

    def pitch_gains(self, pitch_rad: float) -> tuple[float, float, float]:
        """Scheduled pitch gains at ``pitch_rad`` [rad] (kernel ``baseline_gains``).

        Returns
        -------
        kp_s, ki, factor : float
            Effective :math:`G_K K_P` [s], :math:`G_K K_I` [-] and the schedule factor
            :math:`G_K` [-] (table mode: :math:`K_I(\\theta)/K_I(\\theta_0)`).
        """
        kp, ki, gk = _kernels.baseline_gains(self._bl, self._gs, self._n_gs, float(pitch_rad))
        return kp, ki, gk

    def step(
        self, state: BaselineState, measurement: SensorFrame, dt_s: float
    ) -> tuple[BaselineState, ControlOutput]:
        """Advance the controller by one sample (:func:`controller._kernels.baseline_step`).

        One compiled call on ``state.values`` into a new array (``state`` is not modified);
        the law is the module docstring's (tests check the kernel against a plain-Python
        statement-by-statement oracle of it). A step costs about 2 us from Python.

        Parameters
        ----------
        state : BaselineState
            State returned by the previous call (or :meth:`initial_state`).
        measurement : SensorFrame
            Uses ``generator_speed_measured_rad_s`` [rad/s], and on the first call
            ``blade_pitch_measured_rad`` [rad] and ``generator_torque_measured_nm`` [N m].
        dt_s : float
            Time since the previous call [s], > 0.

        Returns
        -------
        state : BaselineState
            New state.
        output : ControlOutput
            Pitch and torque commands and controller internals.

        Raises
        ------
        ValueError
            If ``dt_s`` is not a finite positive number.
        """
        if not 0.0 < dt_s < math.inf:
            raise ValueError(f"dt_s must be finite and > 0 s, got {dt_s!r}")
        m = measurement
        values = np.zeros(_kernels.BL_STATE_SIZE)  # (the K omega^2 law writes 7 entries)
        prm, tsr_grid, pitch_grid, cells = self._tables
        # float() and bool(): a frame built in Python may hold an int where a float belongs,
        # and numba would compile another signature for it
        r = _kernels.baseline_step(
            self._bl, self._gs, self._n_gs, bool(state.first_call), state.values,
            float(m.generator_speed_measured_rad_s), float(m.blade_pitch_measured_rad),
            float(m.generator_torque_measured_nm), float(dt_s), values,
            float(m.wind_speed_measured_m_s), prm, tsr_grid, pitch_grid, cells,
            float(m.platform_pitch_rate_measured_rad_s),
            bool(m.valid_mask & VALID_PLATFORM_PITCH_RATE),
        )  # fmt: skip
        new = BaselineState(values, False)
        if self.ekf is not None:
            return new, ControlOutput(
                r[0], r[1], r[2], r[3], r[4], r[5], EST_WIND_SPEED, r[8], r[6],
                estimator_faults=r[7],
            )  # fmt: skip
        return new, ControlOutput(r[0], r[1], r[2], r[3], r[4], r[5])


def _fallback_region2_gain(p: BaselineParams, ekf: WindSpeedEKF | None) -> float:
    """K of the fallback's :math:`T = K\\omega^2` [N m/(rad/s)^2, HSS]: the optimal
    tip-speed ratio's torque on the EKF's Cp table at the minimum pitch,
    :math:`\\tfrac12\\rho\\pi R^5 C_p(\\lambda^*, \\theta_{min})/(\\lambda^{*3} N^3)` (0
    without the TSR-tracking law)."""
    if ekf is None or p.optimal_tsr is None or p.rotor_radius_m is None:
        return 0.0
    lam = p.optimal_tsr
    cp = max(ekf.config.cp_table.lookup(lam, p.min_pitch_rad)[0], 0.0)
    k = 0.5 * p.air_density_kg_m3 * math.pi * p.rotor_radius_m**5
    return k * cp / (lam**3 * p.gearbox_ratio**3)


def _min_pitch(
    winds: tuple[float, ...], pitches: tuple[float, ...], wind_m_s: float, floor: float
) -> float:
    """Minimum pitch at ``wind_m_s``: linear interpolation, end values held, >= ``floor``."""
    n = len(winds)
    if n == 0:
        return floor
    if wind_m_s <= winds[0]:
        th = pitches[0]
    elif wind_m_s >= winds[n - 1]:
        th = pitches[n - 1]
    else:
        j = bisect_right(winds, wind_m_s)
        w0 = winds[j - 1]
        th = pitches[j - 1] + (wind_m_s - w0) / (winds[j] - w0) * (pitches[j] - pitches[j - 1])
    return th if th > floor else floor


# --- presets ------------------------------------------------------------------------------


class _PresetFile(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """Schema of a baseline preset TOML file.

    Quantities may be given in the SI unit of :class:`BaselineParams` or in the published
    unit (rpm, deg, Hz, N m/rpm^2); exactly one spelling per quantity.
    """

    name: str | None = None
    source: str | None = None
    gearbox_ratio: float | None = None
    generator_efficiency_percent: float | None = None
    generator_speed_lpf_order: int | None = None
    generator_speed_lpf_corner_rad_s: float | None = None
    generator_speed_lpf_corner_hz: float | None = None
    generator_speed_lpf_damping: float | None = None
    cut_in_generator_speed_rad_s: float | None = None
    cut_in_generator_speed_rpm: float | None = None
    region2_start_generator_speed_rad_s: float | None = None
    region2_start_generator_speed_rpm: float | None = None
    region2_gain_nm_per_rad_s2: float | None = None
    region2_gain_nm_per_rpm2: float | None = None
    region25_end_generator_speed_rad_s: float | None = None
    region25_end_generator_speed_rpm: float | None = None
    region25_mode: Literal["linear_slip", "pi"] | None = None
    region25_slip_percent: float | None = None
    torque_pi_kp_nm_s_per_rad: float | None = None
    torque_pi_ki_nm_per_rad: float | None = None
    rated_mechanical_power_w: float | None = None
    rated_generator_torque_nm: float | None = None
    region3_mode: Literal["constant_power", "constant_torque"] | None = None
    region3_min_pitch_rad: float | None = None
    region3_min_pitch_deg: float | None = None
    max_generator_torque_nm: float | None = None
    max_generator_torque_rate_nm_s: float | None = None
    pitch_reference_generator_speed_rad_s: float | None = None
    pitch_reference_generator_speed_rpm: float | None = None
    min_pitch_rad: float | None = None
    min_pitch_deg: float | None = None
    max_pitch_rad: float | None = None
    max_pitch_deg: float | None = None
    max_pitch_rate_rad_s: float | None = None
    max_pitch_rate_deg_s: float | None = None
    pitch_kp_s: float | None = None
    pitch_ki_dimensionless: float | None = None
    pitch_gain_schedule_theta_k_rad: float | None = None
    pitch_gain_schedule_theta_k_deg: float | None = None
    pitch_gs_angles_rad: list[float] | None = None
    pitch_gs_angles_deg: list[float] | None = None
    pitch_gs_kp_s: list[float] | None = None
    pitch_gs_ki_dimensionless: list[float] | None = None
    torque_law: Literal["k_omega2", "tsr_tracking"] | None = None
    optimal_tsr: float | None = None
    rotor_radius_m: float | None = None
    drivetrain_inertia_kg_m2: float | None = None
    air_density_kg_m3: float | None = None
    cp_table_file: str | None = None
    wind_estimator_speed_noise_std_rad_s: float | None = None
    wind_estimate_lpf_corner_rad_s: float | None = None
    min_pitch_wind_m_s: list[float] | None = None
    min_pitch_schedule_rad: list[float] | None = None
    setpoint_smoother_vs_gain: float | None = None
    setpoint_smoother_pc_gain: float | None = None
    setpoint_smoother_lpf_corner_rad_s: float | None = None
    platform_pitch_rate_gain_s: float | None = None
    platform_pitch_rate_lpf_corner_rad_s: float | None = None
    platform_pitch_rate_lpf_damping: float | None = None
    platform_pitch_rate_hpf_corner_rad_s: float | None = None
    wind_estimate_min_m_s: float | None = None
    wind_estimate_max_m_s: float | None = None
    wind_estimator_gate_sigma: float | None = None
    wind_estimator_fault_s: float | None = None
    wind_estimator_recover_s: float | None = None


# Alternative spellings: field of BaselineParams -> ((toml key, factor to SI), ...).
_UNIT_ALIASES: dict[str, tuple[tuple[str, float], ...]] = {
    "generator_speed_lpf_corner_rad_s": (("generator_speed_lpf_corner_hz", 2.0 * math.pi),),
    "cut_in_generator_speed_rad_s": (("cut_in_generator_speed_rpm", RPM_TO_RAD_S),),
    "region2_start_generator_speed_rad_s": (("region2_start_generator_speed_rpm", RPM_TO_RAD_S),),
    "region2_gain_nm_per_rad_s2": (("region2_gain_nm_per_rpm2", 1.0 / RPM_TO_RAD_S**2),),
    "region25_end_generator_speed_rad_s": (("region25_end_generator_speed_rpm", RPM_TO_RAD_S),),
    "region3_min_pitch_rad": (("region3_min_pitch_deg", DEG_TO_RAD),),
    "pitch_reference_generator_speed_rad_s": (
        ("pitch_reference_generator_speed_rpm", RPM_TO_RAD_S),
    ),
    "min_pitch_rad": (("min_pitch_deg", DEG_TO_RAD),),
    "max_pitch_rad": (("max_pitch_deg", DEG_TO_RAD),),
    "max_pitch_rate_rad_s": (("max_pitch_rate_deg_s", DEG_TO_RAD),),
    "pitch_gain_schedule_theta_k_rad": (("pitch_gain_schedule_theta_k_deg", DEG_TO_RAD),),
    "pitch_gs_angles_rad": (("pitch_gs_angles_deg", DEG_TO_RAD),),
}


def _params_from_file(
    data: _PresetFile, origin: str, default_name: str, read: Callable[[str], bytes]
) -> BaselineParams:
    raw = {k: v for k, v in msgspec.structs.asdict(data).items() if v is not None}
    raw.pop("source", None)
    kwargs: dict[str, Any] = {"name": default_name}
    cp_file = raw.pop("cp_table_file", None)
    if cp_file is not None:  # relative to the preset file (ROSCO text layout)
        try:
            kwargs["cp_table"] = cp_table_from_rosco_text(read(cp_file).decode())
        except (OSError, ValueError, UnicodeDecodeError) as exc:
            raise ValueError(f"{origin}: cp_table_file {cp_file!r}: {exc}") from exc
    for f in fields(BaselineParams):
        spellings = ((f.name, 1.0), *_UNIT_ALIASES.get(f.name, ()))
        given = [(key, factor) for key, factor in spellings if key in raw]
        if len(given) > 1:
            keys = " and ".join(key for key, _ in given)
            raise ValueError(f"{origin}: {keys} give the same quantity; keep one")
        if not given:
            continue
        key, factor = given[0]
        value = raw[key]
        if isinstance(value, list):
            kwargs[f.name] = tuple(float(v) * factor for v in value)
        elif factor != 1.0:
            kwargs[f.name] = float(value) * factor
        else:
            kwargs[f.name] = value
    try:
        return BaselineParams(**kwargs)
    except TypeError as exc:  # a required quantity is missing, or of the wrong type
        raise ValueError(f"{origin}: {exc}") from exc
    except ValueError as exc:
        raise ValueError(f"{origin}: {exc}") from exc


def available_presets() -> tuple[str, ...]:
    """Names of the baseline presets shipped in ``controller/presets``."""
    root = resources.files(_PRESET_PACKAGE)
    return tuple(
        sorted(p.name[: -len(".toml")] for p in root.iterdir() if p.name.endswith(".toml"))
    )


def load_baseline(name_or_path: str | Path) -> BaselineParams:
    """Load baseline parameters from a shipped preset name or a TOML file path.

    Parameters
    ----------
    name_or_path : str or Path
        A shipped preset name (``"nrel5mw_baseline"``, ``"iea15mw_baseline"``, with or
        without ``.toml``) or the path to a user TOML file of the same schema.

    Returns
    -------
    BaselineParams
        Validated parameters, converted to SI units.

    Raises
    ------
    ValueError
        Unknown preset, unknown key (named), duplicated quantity, missing or invalid value.
    """
    path = Path(name_or_path)
    is_path = isinstance(name_or_path, Path) or len(path.parts) > 1
    if is_path or (path.suffix == ".toml" and path.exists()):
        if not path.is_file():
            raise ValueError(f"baseline preset file not found: {path}")
        text = path.read_bytes()
        origin = str(path)
        folder = path.parent

        def read(name: str) -> bytes:
            return (folder / name).read_bytes()
    else:
        stem = str(name_or_path).removesuffix(".toml")
        resource = resources.files(_PRESET_PACKAGE) / f"{stem}.toml"
        if not resource.is_file():
            raise ValueError(
                f"unknown baseline preset {stem!r}; shipped presets: "
                f"{', '.join(available_presets())} (or give a path to a .toml file)"
            )
        text = resource.read_bytes()
        origin = f"preset {stem}"

        def read(name: str) -> bytes:
            return (resources.files(_PRESET_PACKAGE) / name).read_bytes()

    try:
        data = msgspec.toml.decode(text, type=_PresetFile)
    except msgspec.DecodeError as exc:
        raise ValueError(f"{origin}: {exc}") from exc
    return _params_from_file(data, origin, path.stem, read)
