"""The ``my_pi`` core: a gain-scheduled pitch PI on the filtered generator speed and a
K ω² torque law capped at constant power, after the NREL 5 MW baseline (Jonkman et al. 2009,
NREL/TP-500-38060, section 7); the defaults of :class:`MyPiSettings` are its figures.

A pure core: no clock, no I/O, no globals. It starts *trimmed*: the bench starts a run at
the steady state this very controller holds in the scenario's mean wind (a settling run of
plant and core), and the core's first step initialises its speed filter at the measured
speed, its torque at the measured torque and its pitch integrator so that the first
command equals the measured pitch: no jump at t = 0.
"""

from __future__ import annotations

import math
from typing import Annotated

import msgspec

from bus_schemas.messages import SensorFrame
from controller.interface import (
    REGIME_REGION_2,
    REGIME_REGION_3,
    ActuatorLimits,
    ControlOutput,
)

Positive = Annotated[float, msgspec.Meta(gt=0.0)]


class MyPiSettings(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[controller.settings]`` of kind ``my_pi`` (units in the keys; NREL 5 MW defaults)."""

    rated_generator_speed_rad_s: Positive = 122.9096
    rated_mechanical_power_w: Positive = 5_296_610.0
    torque_gain_nm_s2: Positive = 2.332287  # K of T = K ω² [N m / (rad/s)²]
    torque_rate_max_nm_s: Positive = 15_000.0
    speed_filter_corner_hz: Annotated[float, msgspec.Meta(gt=0.0, le=10.0)] = 0.25
    pitch_kp_s: Annotated[float, msgspec.Meta(ge=0.0)] = 0.01882681
    pitch_ki: Annotated[float, msgspec.Meta(ge=0.0)] = 0.008068634  # [-]
    pitch_gain_schedule_rad: Positive = 0.1099965  # θ_K of 1 / (1 + θ/θ_K)
    pitch_min_rad: float = 0.0
    pitch_max_rad: float = math.pi / 2
    pitch_rate_max_rad_s: Positive = math.radians(8.0)
    region3_min_pitch_rad: float = math.radians(1.0)  # constant power above this pitch

    def __post_init__(self) -> None:
        if not self.pitch_min_rad < self.pitch_max_rad:
            raise ValueError(
                f"pitch_min_rad = {self.pitch_min_rad} must be < pitch_max_rad = "
                f"{self.pitch_max_rad}"
            )


class MyPiState(msgspec.Struct, frozen=True):
    """Between steps: whether the first measurement was taken, the filtered speed [rad/s],
    the pitch integrator [rad], the last pitch [rad] and torque [N m] commands."""

    started: bool = False
    speed_filtered_rad_s: float = 0.0
    integral_rad: float = 0.0
    pitch_rad: float = 0.0
    torque_nm: float = 0.0


def _clip(x: float, lo: float, hi: float) -> float:
    return min(max(x, lo), hi)


class MyPiController:
    """The core (:class:`controller.interface.Controller`)."""

    def __init__(self, settings: MyPiSettings, control_period_s: float) -> None:
        self.s = settings
        # first-order low-pass, discretised exactly for the control period
        self.alpha = math.exp(-2.0 * math.pi * settings.speed_filter_corner_hz * control_period_s)

    def initial_state(self) -> MyPiState:
        return MyPiState()

    def actuator_limits(self) -> ActuatorLimits:
        s = self.s
        return ActuatorLimits(
            s.pitch_min_rad, s.pitch_max_rad, s.pitch_rate_max_rad_s, s.torque_rate_max_nm_s
        )

    def _schedule(self, pitch_rad: float) -> float:
        return 1.0 / (1.0 + max(pitch_rad, 0.0) / self.s.pitch_gain_schedule_rad)

    def step(
        self, state: MyPiState, m: SensorFrame, dt_s: float
    ) -> tuple[MyPiState, ControlOutput]:
        s = self.s
        speed = m.generator_speed_measured_rad_s
        if not state.started:  # trimmed start: take the plant's state as the controller's
            pitch0 = _clip(m.blade_pitch_measured_rad, s.pitch_min_rad, s.pitch_max_rad)
            e0 = speed - s.rated_generator_speed_rad_s
            state = MyPiState(
                started=True,
                speed_filtered_rad_s=speed,
                integral_rad=pitch0 - self._schedule(pitch0) * s.pitch_kp_s * e0,
                pitch_rad=pitch0,
                torque_nm=m.generator_torque_measured_nm,
            )
        w = self.alpha * state.speed_filtered_rad_s + (1.0 - self.alpha) * speed
        # pitch: gain-scheduled PI on the speed error, integrator held within the pitch range
        e = w - s.rated_generator_speed_rad_s
        gk = self._schedule(state.pitch_rad)
        integral = _clip(
            state.integral_rad + gk * s.pitch_ki * e * dt_s, s.pitch_min_rad, s.pitch_max_rad
        )
        demand = _clip(gk * s.pitch_kp_s * e + integral, s.pitch_min_rad, s.pitch_max_rad)
        step_max = s.pitch_rate_max_rad_s * dt_s
        pitch = _clip(demand, state.pitch_rad - step_max, state.pitch_rad + step_max)
        # torque: K ω² below rated, constant power above (or once the pitch is out of fine)
        w_pos = max(w, 1e-3)
        constant_power = s.rated_mechanical_power_w / w_pos
        region3 = pitch >= s.region3_min_pitch_rad or w >= s.rated_generator_speed_rad_s
        torque = constant_power if region3 else min(s.torque_gain_nm_s2 * w * w, constant_power)
        t_max = s.torque_rate_max_nm_s * dt_s
        torque = _clip(torque, state.torque_nm - t_max, state.torque_nm + t_max)
        out = ControlOutput(
            blade_pitch_commanded_rad=pitch,
            generator_torque_commanded_nm=torque,
            regime=REGIME_REGION_3 if region3 else REGIME_REGION_2,
            generator_speed_filtered_rad_s=w,
            pitch_integrator_rad=integral,
            gain_schedule_factor=gk,
        )
        return MyPiState(True, w, integral, pitch, torque), out
