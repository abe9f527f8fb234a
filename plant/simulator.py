"""The plant process's core: turbine (bottom-fixed or floating), wind, waves and sensors.

:class:`PlantSimulator` advances the plant over one control period with fixed-step RK4, the
demand switching from the previous command to the new one after ``switch_step`` internal
steps (so a real-time run applies a command when it arrived, at the plant step's
resolution), and turns the state into the messages of :mod:`bus_schemas`: the noisy
:class:`SensorFrame` a controller sees and the true :class:`PlantState` for the log. It
holds no clock and does no I/O; the node layer (``hil.nodes.plant_node``) owns time and the bus.

Two plants
----------
* Bottom-fixed (``PlantConfig.floating is None``): :func:`plant.turbine.f`, state
  (ω, θ, T_g), RK4 of :func:`plant.integrate.rk4_step` with the wind held at mid-step.
* Floating (:class:`FloatingPlant`): :func:`plant.platform.f`, state (surge, heave, pitch,
  tower-top, their rates, ω, θ, T_g, radiation states), input u = (θ_c, T_c, U, F_x^w,
  F_z^w, M_φ^w). The wave excitation and the elevations at the platform and at the gauge
  come from one phasor stepper (that of :class:`plant.waves.PhasorStepper`, compiled in
  :func:`plant._kernels.phasor_step`) over the same wave field (outputs: the
  three excitation components and the two elevations), built with Δt = h/2 so that RK4
  gets its stage inputs exactly: k1 at t, k2 and k3 at t + h/2, k4 at t + h (the wind too;
  the pitch and torque demands are held over the step). This is the choice for the RK4
  mid-step: a stepper at h/2 (two complex multiplies per component per step, no
  trigonometry) rather than direct evaluation (a cosine per component per stage). The
  integrator is :func:`plant.platform.step_floating` (one step with the input held) with the
  mid-step inputs u(t + h/2).

Cost
----
A control period, the truth outputs and the sensor readings are one compiled call each
(:mod:`plant._kernels`, :mod:`sensors._kernels`): the simulator keeps the state as an array
beside the tuple it returned (a caller passing that tuple back costs no conversion), the
turbulent wind is looked up in the kernels, and the constants are packed in one array.
``bench/loop_profile.py plant`` measures a whole plant cycle (against another checkout with
``--compare-python``/``--compare-root``).

Sensor faults
-------------
``PlantConfig.sensor_faults`` (:class:`sensors.faults.FaultSpec`: stuck, dropout, bias step,
noise burst) act on the channels' readings of each frame through a
:class:`sensors.faults.FaultSchedule`, after the channel models and before the frame is
built, so a fault changes exactly the fields it names in exactly its window; the rotor speed,
derived from the generator speed, follows that channel's fault. ``PlantSimulator.faults``
counts what they did (``injected``, per kind). Bus faults are the node layer's business.

Loads in :class:`PlantState` (formulas in :class:`bus_schemas.messages.PlantState`): the
tower-base fore-aft bending moment from thrust, gravity and inertia of the masses above the
base (:class:`TowerBaseLoads`), and the low-speed-shaft torque N T_g.
"""

from __future__ import annotations

import copy
import math
import operator
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bus_schemas import PlantState, SensorFrame
from bus_schemas.messages import (
    VALID_BITS,
    VALID_GENERATOR_SPEED,
    VALID_PITCH,
    VALID_POWER,
    VALID_ROTOR_SPEED,
    VALID_TORQUE,
    VALID_WIND,
)
from plant import _kernels as _k
from plant.initial import InitialCondition
from plant.platform import FloatingParams, FloatingPreset, step_blocks, tower_modal
from plant.turbine import TurbineParams, outputs
from plant.waves import WaveField
from plant.wind import SteadyWind, TurbulentWind, WindSpec, make_wind_function, wind_speed
from sensors import ChannelSpec, ChannelSuite, NoiseSpec, SensorSuite
from sensors.faults import FaultSchedule, FaultSpec

State = tuple[float, ...]

# Bits of SensorFrame.valid_mask for the channels a bottom-fixed turbine has.
TURBINE_ONLY_MASK = (
    VALID_GENERATOR_SPEED
    | VALID_ROTOR_SPEED
    | VALID_PITCH
    | VALID_TORQUE
    | VALID_POWER
    | VALID_WIND
)

#: SensorFrame measured fields filled from channels (the rotor speed is derived).
MEASURED_FIELDS = tuple(k for k in VALID_BITS if k != "rotor_speed_measured_rad_s")

#: Platform and tower positions and rates (state order) reported by a bottom-fixed plant.
_NO_PLATFORM: State = (0.0,) * 8

#: The measured SensorFrame fields in the order the channels' readings are gathered.
FRAME_FIELDS = (
    "generator_speed_measured_rad_s",
    "blade_pitch_measured_rad",
    "generator_torque_measured_nm",
    "electrical_power_measured_w",
    "wind_speed_measured_m_s",
    "nacelle_acc_fore_aft_measured_m_s2",
    "platform_pitch_measured_rad",
    "platform_pitch_rate_measured_rad_s",
    "platform_surge_measured_m",
    "wave_elevation_gauge_measured_m",
)
if set(FRAME_FIELDS) != set(MEASURED_FIELDS):  # a SensorFrame field added or renamed
    raise ImportError(f"plant.simulator.FRAME_FIELDS {FRAME_FIELDS} != {MEASURED_FIELDS}")

#: Channel name (SensorFrame field) -> the PlantState field it measures. The anemometer sits
#: on the moving nacelle and reads the relative wind.
CHANNEL_TRUTH = {
    "generator_speed_measured_rad_s": "generator_speed_rad_s",
    "blade_pitch_measured_rad": "blade_pitch_rad",
    "generator_torque_measured_nm": "generator_torque_nm",
    "electrical_power_measured_w": "electrical_power_w",
    "wind_speed_measured_m_s": "relative_wind_speed_m_s",
    "nacelle_acc_fore_aft_measured_m_s2": "nacelle_acc_fore_aft_m_s2",
    "platform_pitch_measured_rad": "platform_pitch_rad",
    "platform_pitch_rate_measured_rad_s": "platform_pitch_rate_rad_s",
    "platform_surge_measured_m": "platform_surge_m",
    "wave_elevation_gauge_measured_m": "wave_elevation_gauge_m",
}

if PlantState.__struct_fields__[3:] != _k.TRUTH_FIELDS:  # the truth record's layout
    raise ImportError("plant._kernels.TRUTH_FIELDS must be PlantState's fields after the stamps")
_TRUTH_PITCH_APPLIED = _k.TRUTH_FIELDS.index("blade_pitch_applied_rad")
_TRUTH_TORQUE_APPLIED = _k.TRUTH_FIELDS.index("generator_torque_applied_nm")

#: Steps between exact recomputations of the wave phasors (PhasorStepper's default).
WAVE_RESYNC_STEPS = 1024


@dataclass(frozen=True)
class TowerBaseLoads:
    """Constants of the tower-base fore-aft bending moment (SI; see ``PlantState``).

    M_tb = T (h_hub − h_b) + g [Σ m a + φ c_φ + s c_s] − ẍ c_φ − φ̈ c_φφ − s̈ c_ss, with

    * c_φ = ∫(h − h_b) dm_tower + Σ_RNA m (h − h_b)             (kg m)
    * c_s = ∫ψ dm_tower + Σ_RNA m (1 + c κ)                      (kg)
    * c_φφ = ∫h (h − h_b) dm_tower + Σ_RNA m h (h − h_b) + Σ I    (kg m²)
    * c_ss = ∫ψ (h − h_b) dm_tower + Σ_RNA m (1 + c κ)(h − h_b) + Σ I κ  (kg m)

    h heights above the still-water line, h_b the tower base, ψ the tower mode shape
    (ψ = 1 at the top), a the RNA masses' overhangs (x downwind), c their heights above the
    tower top, κ the tower-top slope per metre of s, I the rotor pitch inertia.
    """

    hub_arm_m: float
    overhang_moment_kg_m: float
    c_phi_kg_m: float
    c_s_kg: float
    c_phiphi_kg_m2: float
    c_ss_kg_m: float
    nacelle_height_m: float
    gravity_m_s2: float

    @classmethod
    def from_preset(cls, preset: FloatingPreset, hub_height_m: float) -> TowerBaseLoads:
        """Integrals of the tower (:func:`plant.platform.tower_modal`) and the RNA points."""
        tm = tower_modal(preset)
        hb, ht = preset.tower_base_height_m, preset.tower_top_height_m
        kap = tm.slope_per_m
        mt = tm.tower_mass_kg
        c_phi = mt * (tm.tower_cm_height_m - hb)
        c_s = tm.first_moment_kg_m
        c_pp = tm.tower_height_inertia_kg_m2 - hb * mt * tm.tower_cm_height_m
        c_ss = tm.height_moment_kg_m - hb * tm.first_moment_kg_m
        blades = preset.blade_count * preset.blade_mass_kg
        rna = [  # (m kg, a m, c m, I kg m²) relative to the tower top
            (preset.yaw_bearing_mass_kg, 0.0, 0.0, 0.0),
            (preset.nacelle_mass_kg, preset.nacelle_cm_x_m, preset.nacelle_cm_z_m, 0.0),
            (preset.hub_mass_kg, preset.rotor_apex_x_m, preset.rotor_apex_z_m, 0.0),
            (
                blades,
                preset.rotor_apex_x_m + preset.blade_cm_axial_m,
                preset.rotor_apex_z_m,
                0.5 * preset.blade_count * preset.blade_second_moment_kg_m2,
            ),
        ]
        overhang = 0.0
        for m, a, c, inertia in rna:
            h = ht + c
            lever = 1.0 + c * kap
            overhang += m * a
            c_phi += m * (h - hb)
            c_s += m * lever
            c_pp += m * h * (h - hb) + inertia
            c_ss += m * lever * (h - hb) + inertia * kap
        return cls(
            hub_arm_m=hub_height_m - hb,
            overhang_moment_kg_m=overhang,
            c_phi_kg_m=c_phi,
            c_s_kg=c_s,
            c_phiphi_kg_m2=c_pp,
            c_ss_kg_m=c_ss,
            nacelle_height_m=ht,
            gravity_m_s2=preset.gravity_m_s2,
        )

    def moment_nm(
        self,
        thrust_n: float,
        pitch_rad: float,
        tower_top_m: float,
        surge_acc_m_s2: float,
        pitch_acc_rad_s2: float,
        tower_acc_m_s2: float,
    ) -> float:
        """Tower-base fore-aft bending moment M_tb (N m), class docstring formula."""
        g = self.gravity_m_s2
        return (
            thrust_n * self.hub_arm_m
            + g
            * (self.overhang_moment_kg_m + pitch_rad * self.c_phi_kg_m + tower_top_m * self.c_s_kg)
            - surge_acc_m_s2 * self.c_phi_kg_m
            - pitch_acc_rad_s2 * self.c_phiphi_kg_m2
            - tower_acc_m_s2 * self.c_ss_kg_m
        )


@dataclass(frozen=True)
class FloatingPlant:
    """What a floating plant adds to :class:`PlantConfig`.

    Parameters
    ----------
    params : FloatingParams
        Coupled platform-tower-rotor model.
    loads : TowerBaseLoads
        Constants of the tower-base moment.
    waves : WaveField
        Incident long-crested waves (:func:`plant.waves.still_water` for none).
    excitation_transfer : ndarray, shape (N, 3), complex
        X(ω_i) of surge force (N/m), heave force (N/m), pitch moment (N m/m) at the field's
        component frequencies (per metre of wave amplitude, e^{+iωt}).
    gauge_distance_m : float
        Distance of the wave gauge up-wave of the platform (m).
    """

    params: FloatingParams
    loads: TowerBaseLoads
    waves: WaveField
    excitation_transfer: np.ndarray
    gauge_distance_m: float = 450.0


@dataclass(frozen=True)
class PlantConfig:
    """What the plant process simulates.

    Parameters
    ----------
    turbine : TurbineParams
        Rotor, drivetrain, generator and actuators.
    wind : WindSpec
        Hub-height (rotor-effective) wind over time.
    plant_step_s : float
        Fixed RK4 step, s.
    steps_per_cycle : int
        Plant steps per control period.
    sensor_noise : dict of str to NoiseSpec
        Noise-only sensors (keys: SensorFrame field names), used when ``sensor_channels``
        is None.
    sensor_seed : int
        Seed of the sensor streams.
    floating : FloatingPlant, optional
        The floating platform and waves (None: bottom-fixed).
    sensor_channels : mapping of str to ChannelSpec, optional
        Full channel models (noise, bias, quantization, delay, sample-and-hold, dropout).
    sensor_faults : tuple of FaultSpec
        Faults of the run (:mod:`sensors.faults`); the sensor kinds are applied to the
        frames here, the bus kinds are ignored (the plant node applies them).
    initial : InitialCondition
        Where the run starts (:meth:`PlantSimulator.initial_state`; all None: the plant's
        own operating point).
    """

    turbine: TurbineParams
    wind: WindSpec
    plant_step_s: float
    steps_per_cycle: int
    sensor_noise: dict[str, NoiseSpec]
    sensor_seed: int = 1
    floating: FloatingPlant | None = None
    sensor_channels: Mapping[str, ChannelSpec] | None = field(default=None)
    sensor_faults: tuple[FaultSpec, ...] = ()
    initial: InitialCondition = field(default_factory=InitialCondition)

    def __post_init__(self) -> None:
        if not (self.plant_step_s > 0 and math.isfinite(self.plant_step_s)):
            raise ValueError(
                f"plant_step_s must be a positive number of seconds, got {self.plant_step_s}"
            )
        if self.steps_per_cycle < 1:
            raise ValueError(f"steps_per_cycle must be >= 1, got {self.steps_per_cycle}")


class PlantSimulator:
    """Integrates the plant over control periods and produces its messages."""

    def __init__(self, config: PlantConfig) -> None:
        self.config = config
        self.params = config.turbine
        self.h = config.plant_step_s
        self.n = config.steps_per_cycle
        self.floating = config.floating
        self._wind = make_wind_function(config.wind)
        self.channels: ChannelSuite | None = None
        if config.sensor_channels is not None:
            self.channels = ChannelSuite(config.sensor_channels, config.sensor_seed)
        self.sensors = SensorSuite(config.sensor_noise, config.sensor_seed)
        self.faults = FaultSchedule(
            config.sensor_faults, config.sensor_seed, config.sensor_channels
        )
        self._faulty = bool(self.faults)
        # The channels' true values in suite order (one attrgetter call) and their frame bits.
        self._channel_truths: Callable[[PlantState], tuple[float, ...]] | None = None
        self._slots = np.zeros((0, 2), dtype=np.int64)
        self._record = np.zeros(len(FRAME_FIELDS))
        if self.channels is not None:
            keys = list(self.channels)
            if all(k in CHANNEL_TRUTH for k in keys):
                names = [CHANNEL_TRUTH[k] for k in keys]
                if len(names) == 1:
                    one = names[0]
                    self._channel_truths = lambda s: (getattr(s, one),)
                else:
                    self._channel_truths = operator.attrgetter(*names)
            self._slots = np.array(
                [
                    (FRAME_FIELDS.index(k), VALID_BITS[k]) if k in FRAME_FIELDS else (-1, 0)
                    for k in keys
                ],
                dtype=np.int64,
            ).reshape(len(keys), 2)
            self.channels.bind_record(self._slots, self._record)
        # Floating plant: the truth message's record and, after it, the channels' true values
        # (plant._kernels.floating_truth_into); the channels read them straight from there
        # when sensor_frame gets the truth built last from it.
        n_truth = len(_k.TRUTH_FIELDS)
        fields = [CHANNEL_TRUTH.get(k, "") for k in self.channels] if self.channels else []
        self._channel_fields = np.array(
            [_k.TRUTH_FIELDS.index(f) for f in fields if f in _k.TRUTH_FIELDS], dtype=np.int64
        )
        self._truth_rec = np.zeros(n_truth + len(self._channel_fields))
        self._truth_head = self._truth_rec[:n_truth]
        self._channel_values: np.ndarray | None = None
        if self.channels is not None and len(self._channel_fields) == len(fields):
            self._channel_values = self._truth_rec[n_truth:]
        self._truth_of_rec: PlantState | None = None
        # Compiled period (plant._kernels): the state as an array beside the tuple returned
        # last (reused when the caller passes that tuple back); the kernels' state ``_s``
        # (demands, winds of the steps, wave clock and values, radiation accelerations of the
        # last step's end: layout S_* of plant._kernels), the wave arrays and the constants.
        self._x_tuple: object = None
        self._wave_t0, self._wave_n = 0.0, 0
        self._x_arr = np.zeros(0)
        self._wc = np.zeros((_k.W_ROWS, 0))
        self._has_waves = False
        tp = self.params
        self._efficiency = tp.generator_efficiency
        self._gearbox = tp.gearbox_ratio
        # A turbulent wind record is looked up inside the kernels (plant._kernels.turbulent_speed);
        # so is a steady wind, as a one-sample record (U + (U - U) frac = U exactly), so that
        # the compiled in-process loop, which needs a record, runs steady scenarios too (the
        # trim's settling runs among them).
        wind = config.wind
        samples: Sequence[float] | np.ndarray = ()
        wind_dt = 0.0
        if isinstance(wind, TurbulentWind):
            wind_dt, samples = wind.dt_s, wind.samples_m_s
        elif isinstance(wind, SteadyWind):
            wind_dt, samples = 1.0, (wind.speed_m_s,)
        self._wind_table = np.array(samples, dtype=np.float64)
        if self.floating is None:
            self._w0 = 5
            self._s = np.zeros(self._w0 + self.n)
            self._s[4] = wind_dt
            table = tp.table
            tpa = np.array(
                [
                    tp.rotor_radius_m,
                    tp.k_torque,
                    tp.gearbox_ratio,
                    tp.inv_inertia,
                    tp.pitch_min_rad,
                    tp.pitch_max_rad,
                    tp.inv_pitch_tau,
                    tp.pitch_rate_max_rad_s,
                    tp.torque_max_nm,
                    tp.inv_torque_tau,
                    tp.torque_rate_max_nm_s,
                    tp.k_thrust,
                ]
            )
            self._c, self._o = _k.pack(
                [tpa, table._tsr_array, table._pitch_array, table._cell_array]
            )
        else:
            fl = self.floating
            nr = fl.params.n_radiation
            self._w0 = _k.S_Z + nr + 8
            self._s = np.zeros(self._w0 + self.n)
            self._s[_k.S_WIND_DT] = wind_dt
            ld = fl.loads
            blocks = step_blocks(fl.params, self.h)
            blocks[_k.B_LOADS] = np.array(
                [
                    ld.hub_arm_m,
                    ld.overhang_moment_kg_m,
                    ld.c_phi_kg_m,
                    ld.c_s_kg,
                    ld.c_phiphi_kg_m2,
                    ld.c_ss_kg_m,
                    ld.nacelle_height_m,
                    ld.gravity_m_s2,
                ]
            )
            self._c, self._o = _k.pack(blocks)
            if fl.waves.n_components:
                self._reset_waves(0.0)

    # ------------------------------------------------------------------ waves
    def _reset_waves(self, t_s: float) -> None:
        """(Re)build the wave stepper at ``t_s`` with Δt = h/2 (module docstring).

        The stepper of :class:`plant.waves.PhasorStepper` (p = z e^{iωt₀}, r = e^{iωΔt},
        exact recomputation every 1024 steps) as arrays for :func:`plant._kernels.phasor_advance`
        (tests/test_plant_kernels.py compares the two).
        """
        fp = self.floating
        assert fp is not None
        w = fp.waves
        gx, gy = w.up_wave_point(fp.gauge_distance_m)
        proj = gx * math.cos(w.heading_rad) + gy * math.sin(w.heading_rad)
        coeff = np.vstack(
            [
                np.asarray(fp.excitation_transfer, dtype=np.complex128).T,
                np.ones((1, w.n_components), dtype=np.complex128),
                np.exp(-1j * w.wavenumber_rad_m * proj)[None, :],
            ]
        )
        omega = np.array(w.omega_rad_s, dtype=np.float64)
        z0 = np.asarray(w.amplitude_m * np.exp(1j * w.phase_rad), dtype=np.complex128)
        dt = 0.5 * self.h
        wc = np.zeros((_k.W_ROWS, omega.size))
        p = z0 * np.exp(1j * omega * t_s)
        r = np.exp(1j * omega * dt)
        wc[_k.W_PR], wc[_k.W_PI] = p.real, p.imag
        wc[_k.W_RR], wc[_k.W_RI] = r.real, r.imag
        wc[_k.W_ZR], wc[_k.W_ZI] = z0.real, z0.imag
        wc[_k.W_OMEGA] = omega
        wc[_k.W_CR : _k.W_CR + 5] = coeff.real
        wc[_k.W_CI : _k.W_CI + 5] = coeff.imag
        self._wc = wc
        self._has_waves = omega.size > 0
        self._s[_k.S_CLOCK : _k.S_CLOCK + 4] = (0.0, float(WAVE_RESYNC_STEPS), float(t_s), dt)
        self._wave_t0, self._wave_n = float(t_s), 0
        _k.phasor_values(wc, self._s[_k.S_WAVE : _k.S_WAVE + 5])

    @property
    def wave_time_s(self) -> float:
        """Time of the wave stepper t₀ + n Δt (s)."""
        return self._wave_t0 + self._wave_n * (0.5 * self.h)

    def wave_values(self) -> tuple[float, float, float, float, float]:
        """Current (F_x N, F_z N, M_φ N m, η platform m, η gauge m) at the last step's end."""
        if self.floating is None:
            return (0.0, 0.0, 0.0, 0.0, 0.0)
        v = self._s[_k.S_WAVE : _k.S_WAVE + 5].tolist()
        return (v[0], v[1], v[2], v[3], v[4])

    def _state_array(self, x: State) -> np.ndarray:
        """x as an array: the kept one when ``x`` is the tuple returned last, else a copy."""
        if x is self._x_tuple:
            return self._x_arr
        xa = np.array(x, dtype=np.float64)
        n = 3 if self.floating is None else self.floating.params.n_states
        if xa.shape != (n,):
            raise ValueError(f"plant state: expected {n} numbers, got shape {xa.shape}")
        if self.floating is not None:
            self._s[_k.S_HAVE_Z] = 0.0
        self._x_tuple = x
        self._x_arr = xa
        return xa

    # ------------------------------------------------------------------ compiled loop
    def compiled_unsupported(self) -> str | None:
        """Why a whole-cycle kernel cannot run this plant (None: it can).

        The compiled loop (:mod:`hil.inprocess.kernels`) composes the floating plant's
        truth record, the channel suite's step and the floating period; the bottom-fixed
        plant, fault injection, channels whose true values are not in the truth record
        and an analytic wind (a Python function per step) stay in Python.
        """
        if self.floating is None:
            return "bottom-fixed plant"
        if self._faulty:
            return "sensor faults"
        if self.channels is None or self._channel_values is None:
            return "sensor channels without a true value in the truth record"
        if not self._wind_table.size:
            return "wind without a sampled record"
        return None

    def state_bundle(self, x: State) -> _k.PlantBundle:
        """The simulator's own arrays for a kernel, the state array holding ``x``.

        Not copies: a kernel advances ``bundle.x`` and ``bundle.s`` in place, then
        :meth:`adopt_periods` makes the result this simulator's state.
        """
        return _k.PlantBundle(
            self._state_array(x), self._s, self._wc, self._c, self._o, self._wind_table,
            self._truth_rec, self._channel_fields,
        )  # fmt: skip

    def adopt_periods(self, periods: int) -> State:
        """The state after a kernel ran ``periods`` floating periods on :meth:`state_bundle`.

        The wave clock moves on by 2 ``periods`` ``steps_per_cycle`` half steps, and the
        truth of the last record is stale. Returns the new state as a tuple (what
        :meth:`advance` would have returned).
        """
        y = tuple(self._x_arr.tolist())
        self._x_tuple = y
        self._truth_of_rec = None
        self._wave_n += 2 * self.n * periods
        return y

    def waves_in_step(self, t_s: float) -> bool:
        """True when the wave stepper stands at ``t_s`` (within h/4): no resynchronisation
        before a period from ``t_s`` (:meth:`advance`)."""
        h = self.h
        return not (
            self._has_waves and abs(self._wave_t0 + self._wave_n * (0.5 * h) - t_s) > 0.25 * h
        )

    # ------------------------------------------------------------------ initial state
    def initial_state(self) -> State:
        """Operating point at t = 0 (``PlantConfig.initial``; fields left None: defaults).

        Solved at the wind ``initial.wind_m_s`` (None: the run's wind at t = 0).
        Default: the rotor at the optimal tip-speed ratio, capped at rated; above rated, the
        pitch at which aerodynamic power equals rated mechanical power at rated speed;
        generator torque balancing the aerodynamic torque. A given rotor speed or pitch
        replaces the default's; a torque not given balances the aerodynamic torque at the
        resulting point (N T_g = Q_a). Floating: that rotor point and the static platform
        equilibrium under its mean thrust on the platform's own hydrostatic and mooring
        stiffness (:func:`plant.modes.operating_point`), surge, heave and pitch replaced where
        given, at rest, radiation states zero.
        """
        ic = self.config.initial
        if self.floating is not None:
            from plant.modes import operating_point, rotor_point  # noqa: PLC0415  scipy, once

            fp = self.floating.params
            tp = fp.turbine

            def rotor(u_n: float) -> tuple[float, float, float]:
                omega, theta, torque = rotor_point(fp, u_n)
                if ic.rotor_speed_rad_s is None and ic.blade_pitch_rad is None:
                    return (
                        omega,
                        theta,
                        (torque if ic.generator_torque_nm is None else ic.generator_torque_nm),
                    )
                omega = omega if ic.rotor_speed_rad_s is None else ic.rotor_speed_rad_s
                theta = theta if ic.blade_pitch_rad is None else ic.blade_pitch_rad
                if ic.generator_torque_nm is not None:
                    return omega, theta, ic.generator_torque_nm
                out = outputs(0.0, (omega, theta, 0.0), (theta, 0.0, u_n), tp)
                return omega, theta, max(0.0, out.aero_torque_nm / tp.gearbox_ratio)

            u0 = max(0.5, self._wind(0.0) if ic.wind_m_s is None else ic.wind_m_s)
            default = ic.is_default or (
                ic.rotor_speed_rad_s is None
                and ic.blade_pitch_rad is None
                and ic.generator_torque_nm is None
            )
            x = list(operating_point(fp, u0, rotor=None if default else rotor).state)
            for i, v in enumerate((ic.platform_surge_m, ic.platform_heave_m)):
                if v is not None:
                    x[i] = v
            if ic.platform_pitch_rad is not None:
                x[2] = ic.platform_pitch_rad
            return tuple(x)
        p = self.params
        u = wind_speed(0.0, self.config.wind) if ic.wind_m_s is None else ic.wind_m_s
        tsr_opt = p.table.optimal_tsr()
        omega = p.rated_rotor_speed_rad_s
        if u > 0:
            omega = min(omega, tsr_opt * u / p.rotor_radius_m)
        if ic.rotor_speed_rad_s is not None:
            omega = ic.rotor_speed_rad_s
        pitch = p.pitch_min_rad
        rated_mech_w = p.rated_power_w / p.generator_efficiency

        def aero_power(theta: float) -> float:
            out = outputs(0.0, (omega, theta, 0.0), (theta, 0.0, u), p)
            return out.aero_torque_nm * omega

        if ic.blade_pitch_rad is not None:
            pitch = ic.blade_pitch_rad
        elif aero_power(pitch) > rated_mech_w:
            lo, hi = p.pitch_min_rad, min(p.pitch_max_rad, math.radians(45.0))
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if aero_power(mid) > rated_mech_w:
                    lo = mid
                else:
                    hi = mid
            pitch = 0.5 * (lo + hi)
        if ic.generator_torque_nm is not None:
            return (omega, pitch, ic.generator_torque_nm)
        out = outputs(0.0, (omega, pitch, 0.0), (pitch, 0.0, u), p)
        torque = max(0.0, min(p.torque_max_nm, out.aero_torque_nm / p.gearbox_ratio))
        return (omega, pitch, torque)

    def initial_applied(self, x: State) -> tuple[float, float]:
        """(pitch rad, torque N m) demand that holds the actuators of state ``x``."""
        if self.floating is not None:
            return (x[9], x[10])
        return (x[1], x[2])

    def warm_up(self, x: State, applied: tuple[float, float]) -> None:
        """Run one cycle (truth, sensor frame, control period) on a copy; discard it.

        The compiled kernels (:mod:`plant._kernels`, :mod:`sensors._kernels`) are loaded
        from numba's on-disk cache on their first call in a process: about 0.24 s for the
        bottom-fixed plant, 0.06 s for the floating one (measured on the 2-core machine).
        A paced run that paid this in its first cycle started about 20 ticks late at
        100 Hz, missed every deadline while catching up, and its watchdog latched the safe
        state for the rest of the run. The real-time plant node calls this before its
        pacer starts. The copy keeps this simulator's seeded sensor streams, fault state
        and cached records untouched, so a warmed run is the same run.

        Parameters
        ----------
        x : State
            A plant state (e.g. :meth:`initial_state`); not modified.
        applied : tuple of float
            (pitch rad, torque N m) demand.
        """
        # Frozen models and configs are shared with the twin (nothing can change them):
        # copying their tables element by element was most of the warm-up's cost.
        shared = [*vars(self).values(), getattr(self._wind, "__self__", None)]
        memo: dict[int, object] = {id(v): v for v in shared if _frozen(v)}
        twin = copy.deepcopy(self, memo)
        truth = twin.truth(0, 0, x, applied, 0)
        twin.sensor_frame(0, truth, 0)
        twin.advance(0.0, x, applied, applied, 0)

    # ------------------------------------------------------------------ integration
    def advance(
        self,
        t_s: float,
        x: State,
        previous: tuple[float, float],
        command: tuple[float, float],
        switch_step: int = 0,
    ) -> State:
        """Integrate one control period from ``t_s``.

        Parameters
        ----------
        t_s : float
            Simulated time at the start of the period, s.
        x : State
            Bottom-fixed: (rotor speed rad/s, blade pitch rad, generator torque N m);
            floating: the state of :func:`plant.platform.f`.
        previous, command : (pitch rad, torque N m)
            Demand held before the new command arrived, and the new command.
        switch_step : int
            Plant steps during which ``previous`` still applies (0: ``command`` at once).
        """
        if self.floating is not None:
            return self._advance_floating(t_s, x, previous, command, switch_step)
        h, s = self.h, self._s
        s[0], s[1], s[2], s[3] = previous[0], previous[1], command[0], command[1]
        table = self._wind_table
        if not table.size:
            wind = self._wind
            for i in range(self.n):
                s[5 + i] = wind(t_s + i * h + 0.5 * h)
        xa = self._state_array(x)
        _k.turbine_advance(xa, s, self._c, self._o, h, self.n, switch_step, table, t_s)
        a0, a1, a2 = xa.tolist()
        y = (a0, a1, a2)
        self._x_tuple = y
        return y

    def _advance_floating(
        self,
        t_s: float,
        x: State,
        previous: tuple[float, float],
        command: tuple[float, float],
        switch_step: int,
    ) -> State:
        """One period of :func:`plant._kernels.advance_floating` (module docstring)."""
        h, s, n = self.h, self._s, self.n
        if self._has_waves and abs(self._wave_t0 + self._wave_n * (0.5 * h) - t_s) > 0.25 * h:
            self._reset_waves(t_s)  # called out of sequence: resynchronise the waves
        xa = self._state_array(x)
        table = self._wind_table
        if not table.size:
            wind, w0 = self._wind, self._w0
            for i in range(n):
                s[w0 + i] = wind(t_s + i * h + 0.5 * h)
        _k.advance_floating(
            xa, s, self._wc, self._c, self._o, n, switch_step, table, t_s, h, previous[0],
            previous[1], command[0], command[1],
        )  # fmt: skip
        self._wave_n += 2 * n
        y = tuple(xa.tolist())
        self._x_tuple = y
        return y

    # ------------------------------------------------------------------ messages
    def truth(
        self, seq: int, t_ns: int, x: State, applied: tuple[float, float], publish_ns: int
    ) -> PlantState:
        """The true state and loads at ``t_ns`` (for the log, never for a controller).

        A bottom-fixed plant reports its platform, tower and wave fields as 0 (``floating=0``).
        """
        t = t_ns * 1e-9
        table = self._wind_table
        u_wind = 0.0 if table.size else self._wind(t)
        fp = self.floating
        if fp is None:
            tp = self.params
            omega, theta, torque = x[0], x[1], x[2]
            u_wind, t_aero, thrust, p_el, w_gen, tsr, cp, ct, _ = _k.turbine_outputs(
                self._state_array(x), self._s, self._c, self._o, table, t, u_wind,
                tp.generator_efficiency,
            )  # fmt: skip
            u_rel = u_wind
            tbm = thrust * tp.hub_height_m
            return PlantState(
                seq=seq,
                sample_time_ns=t_ns,
                publish_time_ns=publish_ns,
                rotor_speed_rad_s=omega,
                generator_speed_rad_s=w_gen,
                blade_pitch_rad=theta,
                generator_torque_nm=torque,
                aero_torque_nm=t_aero,
                rotor_thrust_n=thrust,
                wind_speed_m_s=u_wind,
                relative_wind_speed_m_s=u_rel,
                electrical_power_w=p_el,
                tip_speed_ratio=tsr,
                power_coefficient=cp,
                thrust_coefficient=ct,
                blade_pitch_applied_rad=applied[0],
                generator_torque_applied_nm=applied[1],
                floating=0,
                tower_base_moment_nm=tbm,
                shaft_torque_nm=tp.gearbox_ratio * torque,
            )
        _k.floating_truth_into(
            self._truth_rec, self._channel_fields, self._state_array(x), self._s, self._c,
            self._o, table, t, u_wind, applied[0], applied[1], self._efficiency, self._gearbox,
        )  # fmt: skip
        # PlantState positionally from the record (its field order; the keyword call of 33
        # fields costs about 1.4 us more); tests/test_plant_kernels.py checks every field by
        # name. ``floating`` is the int 1, the applied demands the caller's objects.
        v = self._truth_head.tolist()
        v[_k.TRUTH_FLOATING] = 1
        v[_TRUTH_PITCH_APPLIED] = applied[0]
        v[_TRUTH_TORQUE_APPLIED] = applied[1]
        state = PlantState(seq, t_ns, publish_ns, *v)
        self._truth_of_rec = state
        return state

    def sensor_frame(self, seq: int, truth: PlantState, publish_ns: int) -> SensorFrame:
        """Measured values of ``truth``, each channel with its own seeded streams.

        With channel models, a channel whose sample is missing (dropout, or a channel the
        plant does not have) reports 0.0 with its ``valid_mask`` bit cleared; the rotor
        speed is the generator-speed reading over the gearbox ratio and shares its bit.
        The anemometer sits on the moving nacelle and reads the relative wind; the IMU
        gives the nacelle's kinematic fore-aft acceleration (gravity not included).
        """
        if self.channels is None:
            frame = self._noise_frame(seq, truth, publish_ns)
            return self._fault_noise_frame(frame) if self._faulty else frame
        get = self._channel_truths
        if get is None:  # a channel without a true value: the suite's KeyError naming it
            self.channels.step(truth.sample_time_ns, {})
            raise AssertionError("unreachable: the suite raised KeyError")
        if self._faulty:
            vals, oks = self.channels.step_values(truth.sample_time_ns, get(truth))
            readings = dict(zip(self.channels, zip(vals, oks, strict=True), strict=True))
            self.faults.apply(truth.sample_time_ns, readings)
            values = dict.fromkeys(MEASURED_FIELDS, 0.0)
            mask = 0
            for name, (value, ok) in readings.items():
                if ok and name in values:
                    values[name] = value
                    mask |= VALID_BITS[name]
            v = [values[name] for name in FRAME_FIELDS]
        else:
            rec = self._record
            if truth is self._truth_of_rec and self._channel_values is not None:
                truths: Any = self._channel_values  # written with the truth (truth())
            else:
                truths = get(truth)
            mask = self.channels.step_into(truth.sample_time_ns, truths)
            v = rec.tolist()
        rotor = 0.0
        if mask & VALID_GENERATOR_SPEED:
            rotor = v[0] / self.params.gearbox_ratio
            mask |= VALID_ROTOR_SPEED
        return SensorFrame(
            seq=seq,
            sample_time_ns=truth.sample_time_ns,
            publish_time_ns=publish_ns,
            valid_mask=mask,
            generator_speed_measured_rad_s=v[0],
            rotor_speed_measured_rad_s=rotor,
            blade_pitch_measured_rad=v[1],
            generator_torque_measured_nm=v[2],
            electrical_power_measured_w=v[3],
            wind_speed_measured_m_s=v[4],
            nacelle_acc_fore_aft_measured_m_s2=v[5],
            platform_pitch_measured_rad=v[6],
            platform_pitch_rate_measured_rad_s=v[7],
            platform_surge_measured_m=v[8],
            wave_elevation_gauge_measured_m=v[9],
        )

    def _fault_noise_frame(self, frame: SensorFrame) -> SensorFrame:
        """Apply the sensor faults to a frame of the noise-only sensors."""
        readings: dict[str, tuple[float, bool]] = {
            name: (getattr(frame, name), bool(frame.valid_mask & VALID_BITS[name]))
            for name in MEASURED_FIELDS
        }
        self.faults.apply(frame.sample_time_ns, readings)
        values = dict.fromkeys(MEASURED_FIELDS, 0.0)
        mask = 0
        for name, (value, ok) in readings.items():
            if ok:
                values[name] = value
                mask |= VALID_BITS[name]
        rotor = 0.0
        if mask & VALID_GENERATOR_SPEED:
            rotor = values["generator_speed_measured_rad_s"] / self.params.gearbox_ratio
            mask |= VALID_ROTOR_SPEED
        return SensorFrame(
            seq=frame.seq,
            sample_time_ns=frame.sample_time_ns,
            publish_time_ns=frame.publish_time_ns,
            valid_mask=mask,
            rotor_speed_measured_rad_s=rotor,
            **values,
        )

    def _noise_frame(self, seq: int, truth: PlantState, publish_ns: int) -> SensorFrame:
        m = self.sensors.measure
        gen_speed = m("generator_speed_measured_rad_s", truth.generator_speed_rad_s)
        return SensorFrame(
            seq=seq,
            sample_time_ns=truth.sample_time_ns,
            publish_time_ns=publish_ns,
            valid_mask=TURBINE_ONLY_MASK,
            generator_speed_measured_rad_s=gen_speed,
            rotor_speed_measured_rad_s=gen_speed / self.params.gearbox_ratio,
            blade_pitch_measured_rad=m("blade_pitch_measured_rad", truth.blade_pitch_rad),
            generator_torque_measured_nm=m(
                "generator_torque_measured_nm", truth.generator_torque_nm
            ),
            electrical_power_measured_w=m("electrical_power_measured_w", truth.electrical_power_w),
            wind_speed_measured_m_s=m("wind_speed_measured_m_s", truth.wind_speed_m_s),
            nacelle_acc_fore_aft_measured_m_s2=0.0,
            platform_pitch_measured_rad=0.0,
            platform_pitch_rate_measured_rad_s=0.0,
            platform_surge_measured_m=0.0,
            wave_elevation_gauge_measured_m=0.0,
        )


def _frozen(value: object) -> bool:
    """True for an instance of a frozen dataclass (immutable: safe to share, not copy)."""
    params = getattr(type(value), "__dataclass_params__", None)
    return params is not None and bool(params.frozen)
