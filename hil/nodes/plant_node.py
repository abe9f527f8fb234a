"""The plant process: owns simulated time, the wall clock and the deadline of every cycle.

One control cycle k (period T, speed factor s, wall period T/s):

1. sample the state x_k: publish the true :class:`PlantState` and the noisy
   :class:`SensorFrame` (``seq`` = k), noting the wall time the frame left;
2. obtain the command answering frame k:

   * ``lockstep``: wait for it (no deadline consequence: deterministic, for CI/batch);
   * ``realtime``: sleep to the next tick; a command that arrived within the deadline
     (T/s wall) takes effect when it arrived, at the plant step's resolution (rounded to
     the nearest step); one that did not is a deadline miss, the last command is held and
     the late one, if it comes before the tick, is dropped and counted (its latency is
     logged in the cycle's record; 0 when no command came);
   * ``inprocess``: call the controller directly (no bus; fastest);

3. integrate x_{k+1} and publish this cycle's :class:`CycleTiming` (latency on the plant's
   own clock, so it holds across hosts); a :class:`TimingSummary` every simulated second
   and a final one (``final`` = 1) that tells the other processes the run is over.

Right after the final summary the plant publishes its :class:`PlantReport` (``final`` = 1,
:func:`plant_report`): the messages it published per channel (what a complete recording
holds), the commands it applied and every rejected command payload by reason;
``aborted`` = 1 when a signal or the lock-step timeout ended the run early. The recorder
keeps recording until it holds that many (:mod:`hil.nodes.recorder`, docs/recording.md).

Latency histograms: :class:`hil.nodes.timing.LatencyHistogram` (p50/p99/p99.9/max).

Bus faults
----------
The scenario's ``bus_delay``, ``bus_jitter`` and ``bus_loss`` faults
(:mod:`sensors.faults`) act here, on the two messages the plant owns: the sensor frame it
sends and the command it receives. Each message's fate is a pure function of the seed, the
fault and its ``seq`` (:class:`sensors.faults.BusFaultPlan`): lost, or delayed by d + J
(simulated seconds; wall seconds d / s at speed factor s). Both links are FIFO, like the
ordered transports they stand for: a message is never delivered before the one sent before
it (delivery time max(t + d + J, previous delivery)), so jitter delays but never reorders.

* Sensor frames (:class:`SensorLink`): a faulted run hands every frame to a small
  scheduler instead of publishing it. ``realtime``: each frame is published when its wall
  time comes, while the plant waits for the command and for the tick; the sensor-to-command
  latency is still measured from the sample, so a delay eats into the deadline and a frame
  later than the period is a miss (the command answering it is late and dropped).
  ``lockstep`` / ``inprocess``: the delay is in simulated time. Cycle k (t_k to t_{k+1})
  delivers, in order, every frame due before t_{k+1}, and the controller answers each (so a
  delayed frame means the controller answers an older frame; the plant waits for every
  answer, which keeps lock-step deterministic). The answer to frame k takes effect at its
  arrival, t_k + delay, at the plant step's resolution; answers to older frames are late
  and dropped (``commands_late``); if frame k is lost or due at or after t_{k+1}, the plant
  holds the last command for the cycle and counts a deadline miss (the watchdog sees it).
* Commands (``command`` channel): ``realtime``: :class:`CommandInbox` makes a delayed
  command visible only at its arrival time + d/s (it may then miss the deadline: held,
  watchdog) and drops a lost one. ``lockstep`` / ``inprocess``: the plant still waits for
  the real command (determinism), then applies the fault: lost = held, a deadline miss;
  delayed by D = (frame delay) + d + J >= T = late, held, a miss; otherwise it takes effect
  D into the period.

Every fault is counted per kind in ``PlantRunResult.faults_injected`` (sensor faults: one
per channel reading acted on; bus faults: one per message), and each fault window's start
and end is logged, as are the final counts.
"""

from __future__ import annotations

import contextlib
import math
import signal
import threading
import time
from collections import Counter, deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import msgspec
import numpy as np
import zenoh

from bus_schemas import ActuatorCommand, CycleTiming, DecodeError, SensorFrame, TimingSummary
from bus_schemas.messages import (
    COMMAND_MODE_FAULT,
    PLANT_REJECT_REASONS,
    WAVE_PREVIEW_FIELDS,
    WAVE_PREVIEW_SAMPLES,
    WAVE_PREVIEW_STEP_S,
    PlantReport,
    WavePreviewPerfect,
    rejection_fields,
)
from bus_schemas.registry import (
    COMMAND,
    CYCLE_TIMING,
    PLANT_REPORT,
    SENSORS,
    TIMING_SUMMARY,
    TRUTH,
    WAVE_PREVIEW_PERFECT,
    MessageType,
)
from hil.nodes.bus import (
    PLANT_BATCH_SUFFIX,
    Bus,
    BusConfig,
    LogBatcher,
    batch_key,
    wait_for_recorder,
)
from hil.nodes.rt import freeze_heap
from hil.nodes.signals import on_stop_signals
from hil.nodes.timing import LatencyHistogram, Pacer, wait_until
from hil.scenario.schema import (
    InitialSection,
    JonswapWavesSpec,
    PiersonMoskowitzWavesSpec,
    RampWindSpec,
    Scenario,
    SteadyWindSpec,
    StepWindSpec,
    StillWavesSpec,
    TurbulentWindSpec,
    WavesSection,
    WindSpecSection,
)
from plant.build import (
    GustRequest,
    PlantSpec,
    SensorRequest,
    TurbulenceRequest,
    WaveRequest,
    WindRequest,
    build_plant,
    make_waves,
    make_wind,
)
from plant.build import floating_plant as build_floating_plant
from plant.initial import InitialCondition
from plant.simulator import FloatingPlant, PlantConfig, PlantSimulator
from plant.turbine import TurbineParams
from plant.waves import (
    ExcitationForce,
    IsscSpectrum,
    JonswapSpectrum,
    PiersonMoskowitzSpectrum,
    WaveField,
)
from plant.wind import RampWind, SteadyWind, StepWind, WindSpec
from sensors.faults import OPEN_END_NS, BusFaultPlan

if TYPE_CHECKING:
    from hil.nodes.can_bus import CanBus, CanBusConfig, HybridBus

Mode = Literal["realtime", "lockstep", "inprocess"]
Publish = Callable[[MessageType, msgspec.Struct], None]


def wind_request(spec: WindSpecSection) -> WindRequest:
    """The plant's wind request (:mod:`plant.build`) of a scenario's ``[wind]`` section."""
    if isinstance(spec, SteadyWindSpec):
        return SteadyWind(speed_m_s=spec.speed_m_s)
    if isinstance(spec, StepWindSpec):
        return StepWind(initial_m_s=spec.initial_m_s, final_m_s=spec.final_m_s, time_s=spec.time_s)
    if isinstance(spec, RampWindSpec):
        return RampWind(
            initial_m_s=spec.initial_m_s,
            final_m_s=spec.final_m_s,
            start_s=spec.start_s,
            end_s=spec.end_s,
        )
    if isinstance(spec, TurbulentWindSpec):
        return TurbulenceRequest(
            mean_m_s=spec.mean_m_s, turbulence_class=spec.turbulence_class, seed=spec.seed
        )
    return GustRequest(
        hub_speed_m_s=spec.hub_speed_m_s,
        start_s=spec.start_s,
        turbine_class=spec.turbine_class,
        turbulence_class=spec.turbulence_class,
        period_s=spec.period_s,
    )


def wind_from_scenario(
    spec: WindSpecSection,
    turbine: TurbineParams | None = None,
    duration_s: float = 600.0,
    dt_s: float = 0.05,
) -> WindSpec:
    """The plant's wind model of a scenario's ``[wind]`` (:func:`plant.build.make_wind`)."""
    return make_wind(wind_request(spec), turbine, duration_s=duration_s, dt_s=dt_s)


def wave_request(spec: WavesSection | None) -> WaveRequest | None:
    """The plant's wave request (:mod:`plant.build`) of a scenario's ``[waves]`` section."""
    if spec is None:
        return None
    spectrum: JonswapSpectrum | PiersonMoskowitzSpectrum | IsscSpectrum | None
    if isinstance(spec, StillWavesSpec):
        spectrum = None
    elif isinstance(spec, JonswapWavesSpec):
        spectrum = JonswapSpectrum(hs_m=spec.hs_m, tp_s=spec.tp_s, gamma=spec.gamma)
    elif isinstance(spec, PiersonMoskowitzWavesSpec):
        spectrum = PiersonMoskowitzSpectrum(hs_m=spec.hs_m, tp_s=spec.tp_s)
    else:
        spectrum = IsscSpectrum(hs_m=spec.hs_m, t1_s=spec.t1_s)
    return WaveRequest(
        spectrum=spectrum,
        depth_m=spec.depth_m,
        seed=spec.seed,
        omega_min_rad_s=spec.omega_min_rad_s,
        omega_max_rad_s=spec.omega_max_rad_s,
        n_components=spec.n_components,
        gauge_distance_m=spec.gauge_distance_m,
    )


def waves_from_scenario(spec: WavesSection | None, depth_m: float) -> WaveField:
    """The wave field of a scenario's ``[waves]`` section (:func:`plant.build.make_waves`)."""
    return make_waves(wave_request(spec), depth_m)


def initial_overrides(section: InitialSection) -> InitialCondition:
    """The ``[initial]`` keys that are set, in the plant's units (rad, rad/s); the rest None."""

    def rad(deg: float | None) -> float | None:
        return None if deg is None else math.radians(deg)

    rpm = section.rotor_speed_rpm
    return InitialCondition(
        rotor_speed_rad_s=None if rpm is None else rpm * math.pi / 30.0,
        blade_pitch_rad=rad(section.pitch_deg),
        generator_torque_nm=section.generator_torque_nm,
        platform_surge_m=section.platform_surge_m,
        platform_heave_m=section.platform_heave_m,
        platform_pitch_rad=rad(section.platform_pitch_deg),
    )


def plant_spec(scenario: Scenario, initial: InitialCondition | None = None) -> PlantSpec:
    """The plant's part of a scenario (:class:`plant.build.PlantSpec`).

    ``initial``: where the run starts (None: the plant's own operating point).
    """
    s = scenario.sensors
    return PlantSpec(
        turbine=scenario.turbine,
        wind=wind_request(scenario.wind),
        plant_step_s=scenario.timing.plant_step_s,
        steps_per_cycle=scenario.steps_per_cycle,
        control_period_s=scenario.timing.control_period_s,
        duration_s=scenario.duration_s,
        platform=scenario.platform,
        waves=wave_request(scenario.waves),
        sensors=SensorRequest(seed=s.seed, std=s.std_overrides(), channels=dict(s.channels)),
        sensor_faults=scenario.fault_specs(),
        initial=initial if initial is not None else InitialCondition(),
        symmetric_pitch_limit_deg=scenario.controller.symmetric_pitch_limit_deg,
    )


def floating_plant(scenario: Scenario) -> FloatingPlant:
    """Load the platform preset and build the waves and their excitation (offline, ~1 s)."""
    assert scenario.platform is not None
    return build_floating_plant(
        scenario.platform,
        wave_request(scenario.waves),
        scenario.controller.symmetric_pitch_limit_deg,
    )


def plant_config(scenario: Scenario) -> PlantConfig:
    """Build the plant's configuration from a scenario (:func:`plant.build.build_plant`)."""
    return build_plant(plant_spec(scenario))


@dataclass
class PlantRunResult:
    """What a plant run did."""

    cycles: int = 0
    deadline_misses: int = 0
    commands_held: int = 0
    commands_rejected: int = 0
    commands_late: int = 0
    wall_s: float = 0.0
    sim_s: float = 0.0
    aborted: str = ""
    rejected: dict[str, int] = field(default_factory=dict)
    safe_state_entries: int = 0  # watchdog trips
    safe_state_recoveries: int = 0  # control handed back (recover policy, start-up rule)
    safe_state_cycles: int = 0
    safe_state_longest_cycles: int = 0  # the longest safe-state window [cycles]
    commands_faulted: int = 0  # flagged or unusable commands, never applied (command_usable)
    faults_injected: dict[str, int] = field(default_factory=dict)
    loop: str = "python"  # in-process runs: "compiled" (hil.inprocess.loop) or "python"

    @property
    def speed(self) -> float:
        """Simulated seconds per wall second."""
        return self.sim_s / self.wall_s if self.wall_s > 0 else math.inf


def plant_report(
    result: PlantRunResult,
    published: Mapping[str, int],
    *,
    sample_time_ns: int,
    aborted: bool,
    seq: int = 0,
) -> msgspec.Struct:
    """The plant's end-of-run :class:`PlantReport` (``final`` = 1).

    Parameters
    ----------
    result : PlantRunResult
        The run's counters (cycles, commands held, rejections by reason in ``rejected``).
    published : mapping of str to int
        Messages published per key suffix (``sensors``, ``truth``, ``timing/cycle``,
        ``timing/summary``, ``preview/wave_perfect``), the final summary included.
    sample_time_ns : int
        Simulated time at the end of the run [ns].
    aborted : bool
        True when the run ended before its last cycle (a signal, the lock-step timeout).
    seq : int
        The report's sequence number (one report per run: 0).
    """
    return PlantReport(
        seq=seq,
        sample_time_ns=sample_time_ns,
        publish_time_ns=time.monotonic_ns(),
        final=1,
        aborted=int(aborted),
        cycles=result.cycles,
        sensor_frames_published=int(published.get(SENSORS.key_suffix, 0)),
        truth_published=int(published.get(TRUTH.key_suffix, 0)),
        cycle_records_published=int(published.get(CYCLE_TIMING.key_suffix, 0)),
        summaries_published=int(published.get(TIMING_SUMMARY.key_suffix, 0)),
        previews_published=int(published.get(WAVE_PREVIEW_PERFECT.key_suffix, 0)),
        # A held cycle (deadline missed, late or lost command) applied no command.
        commands_applied=max(0, result.cycles - result.commands_held),
        **rejection_fields(result.rejected, "commands_rejected", PLANT_REJECT_REASONS),
    )


def command_usable(command: ActuatorCommand) -> bool:
    """True when a plant may apply ``command``: not flagged as faulted by the controller
    (``mode`` :data:`bus_schemas.messages.COMMAND_MODE_FAULT`), finite, torque not negative.

    Over the bus the codec refuses non-finite and out-of-range payloads before this; an
    in-process command comes straight from the controller runtime, so this is its guard.
    """
    p = command.blade_pitch_commanded_rad
    q = command.generator_torque_commanded_nm
    # (NaN fails the comparisons; infinities fail the bound)
    return command.mode != COMMAND_MODE_FAULT and -10.0 <= p <= 10.0 and 0.0 <= q <= 5e7


class SensorLink:
    """The sensor frame's way to the controller under bus faults: a seeded FIFO scheduler.

    Every frame is submitted once; its fate comes from ``plan``
    (:meth:`sensors.faults.BusFaultPlan.effect`): lost, or held until its delivery time, in
    simulated time t_k + D and in wall time (frame sent) + D / s, each at least the previous
    frame's (FIFO). The real-time loop pops frames by wall time, the lock-step and
    in-process loops by simulated time.

    Parameters
    ----------
    plan : BusFaultPlan
        The ``sensors`` channel's faults.
    speed : float
        Real-time speed factor s (simulated s per wall s).
    """

    def __init__(self, plan: BusFaultPlan, speed: float = 1.0) -> None:
        self.plan = plan
        self.speed = speed
        self.held: deque[tuple[int, int, SensorFrame]] = deque()
        self.counts: Counter[str] = Counter()
        self._last_sim_ns = -1
        self._last_wall_ns = -1

    def submit(self, frame: SensorFrame, sent_wall_ns: int) -> None:
        """Decide ``frame``'s fate and hold it until its delivery time (or drop it)."""
        effect = self.plan.effect(frame.seq, frame.sample_time_ns)
        for kind in effect.kinds:
            self.counts[kind] += 1
        if effect.lost:
            return
        due_sim = max(frame.sample_time_ns + effect.delay_ns, self._last_sim_ns)
        due_wall = max(sent_wall_ns + round(effect.delay_ns / self.speed), self._last_wall_ns)
        self._last_sim_ns, self._last_wall_ns = due_sim, due_wall
        self.held.append((due_sim, due_wall, frame))

    def pop_due_sim(self, before_ns: int) -> list[tuple[SensorFrame, int]]:
        """Frames due before simulated time ``before_ns``, in order, with their due time."""
        out = []
        held = self.held
        while held and held[0][0] < before_ns:
            due, _wall, frame = held.popleft()
            out.append((frame, due))
        return out

    def pop_due_wall(self, now_ns: int) -> list[SensorFrame]:
        """Frames whose wall delivery time is at or before ``now_ns``, in order."""
        out = []
        held = self.held
        while held and held[0][1] <= now_ns:
            out.append(held.popleft()[2])
        return out

    def next_due_wall(self) -> int | None:
        """Wall delivery time of the next held frame (None: none held)."""
        return self.held[0][1] if self.held else None


#: Real time: the first simulated seconds of a run [s] whose missed deadlines count as
#: start-up. A safe state they trip is handed back after as many on-time commands as there
#: are start-up cycles, even where the scenario latches it (``PlantLoop._recover_after``).
STARTUP_S = 1.0


class PlantLoop:
    """Cycle bookkeeping shared by every mode: sampling, applying commands, timing."""

    def __init__(
        self,
        scenario: Scenario,
        publish: Publish,
        speed: float = 1.0,
        initial: InitialCondition | None = None,
    ) -> None:
        """``initial``: where the run starts, the trim resolved by the caller
        (:func:`hil.inprocess.trim.initial_condition`; None: the plant's own start with the
        scenario's
        ``[initial]`` keys that are set, :func:`initial_overrides`).
        """
        self.scenario = scenario
        if initial is None:  # untrimmed: the plant's own start, the [initial] keys set
            initial = initial_overrides(scenario.initial)
        self.initial = initial
        self.sim = PlantSimulator(build_plant(plant_spec(scenario, initial)))
        self.publish = publish
        self.speed = speed
        self.period_ns = round(scenario.timing.control_period_s * 1e9)
        self.wall_period_ns = max(1, round(self.period_ns / speed))
        self._summary_every = max(1, round(1e9 / self.period_ns))  # cycles per running summary
        self.x = self.sim.initial_state()
        self.applied = self.sim.initial_applied(self.x)  # hold the initial actuator positions
        self.k = 0
        self.hist = LatencyHistogram()
        self.result = PlantRunResult()
        self.summary_seq = 0
        self.frame_sent_ns = 0
        self.start_wall_ns = time.monotonic_ns()
        self._pending_timing: CycleTiming | None = None
        # Watchdog (see hil.scenario.schema.TimingSection): consecutive misses, safe state, and
        # the run of on-time commands counted towards recovery.
        self.watchdog_misses = scenario.timing.watchdog_misses
        self.watchdog_policy = scenario.timing.watchdog_rule
        self.watchdog_recover = (
            scenario.timing.watchdog_recover_cycles if self.watchdog_policy == "recover" else 0
        )
        self._safe_window = 0  # cycles of the current safe-state window
        self.consecutive_misses = 0
        self.on_time_run = 0
        self.safe_state = False
        # Start-up (real time only, :data:`STARTUP_S`): a safe state that the first
        # ``startup_cycles`` tripped is handed back after ``startup_recover_cycles`` on-time
        # commands even where the scenario latches it (0: no start-up rule, the default).
        self.startup_cycles = 0
        self.startup_recover_cycles = 0
        self._startup_safe_state = False
        turbine = self.sim.config.turbine
        self.safe_demand = (turbine.pitch_max_rad, 0.0)
        self.log: Callable[[str], None] = lambda _msg: None
        self._inbox: CommandInbox | None = None  # the bus node's, for its fault counters
        # Bus faults (module docstring): the sensor link and the command channel's plan.
        faults = scenario.fault_specs()
        seed = scenario.sensors.seed
        sensor_plan = BusFaultPlan(faults, "sensors", seed)
        command_plan = BusFaultPlan(faults, "command", seed)
        self.sensor_link = SensorLink(sensor_plan, speed) if sensor_plan else None
        self.command_plan = command_plan if command_plan else None
        self.command_fault_counts: Counter[str] = Counter()
        events = [(f.start_ns, f"fault ON  {f.describe()}") for f in faults]
        events += [(f.end_ns, f"fault OFF {f.kind} on {', '.join(f.channels)}") for f in faults]
        self._fault_events = sorted(e for e in events if e[0] < OPEN_END_NS)
        self._next_fault_event_ns = self._fault_events[0][0] if events else OPEN_END_NS
        # Perfect wave preview (casanovas-2014 controllers, [controller] preview = "perfect").
        self._preview: ExcitationForce | None = None
        self._preview_offsets = WAVE_PREVIEW_STEP_S * np.arange(WAVE_PREVIEW_SAMPLES)
        fp = self.sim.floating
        if scenario.controller.preview == "perfect" and fp is not None:
            self._preview = ExcitationForce(fp.waves, fp.excitation_transfer[:, :1])
            w = fp.waves
            self._preview_z0 = (
                w.amplitude_m * np.exp(1j * w.phase_rad) * self._preview.transfer[:, 0]
            )
            self._preview_rot = np.exp(1j * np.outer(self._preview_offsets, w.omega_rad_s))

    def _wave_preview(self, now_ns: int) -> msgspec.Struct:
        """The surge excitation force X(t + jΔ), j < 81 (:data:`WavePreviewPerfect`)."""
        assert self._preview is not None
        # X(t + kΔ) = Re Σ_i [a_i X(ω_i) e^{i(ω_i t + φ_i)}] e^{i ω_i k Δ}: one (81 x N) product
        f = self._preview.field
        z = self._preview_z0 * np.exp(1j * f.omega_rad_s * (self.t_ns * 1e-9))
        force = (self._preview_rot @ z).real
        return WavePreviewPerfect(
            seq=self.k,
            sample_time_ns=self.t_ns,
            publish_time_ns=now_ns,
            preview_step_s=WAVE_PREVIEW_STEP_S,
            **dict(zip(WAVE_PREVIEW_FIELDS, force.tolist(), strict=True)),
        )

    # ------------------------------------------------------------ compiled loop
    @property
    def has_preview(self) -> bool:
        """True when the loop publishes the perfect wave preview before each frame."""
        return self._preview is not None

    @property
    def summary_every(self) -> int:
        """Cycles per running timing summary (one simulated second)."""
        return self._summary_every

    @property
    def next_fault_event_ns(self) -> int:
        """Simulated time of the next fault switching on or off (ns; far future: none)."""
        return self._next_fault_event_ns

    @property
    def pending_timing(self) -> CycleTiming | None:
        """The previous cycle's timing record, published with the next frame."""
        return self._pending_timing

    @pending_timing.setter
    def pending_timing(self, value: CycleTiming | None) -> None:
        self._pending_timing = value

    def summary_counters(self) -> tuple[int, int, int, int, int, int]:
        """What a running summary counts besides the latencies: deadline misses, commands
        held, rejected (so far, the bus inbox's count), late, safe-state cycles, faults."""
        r = self.result
        inbox = self._inbox
        rejected = sum(inbox.rejected.values()) if inbox is not None else r.commands_rejected
        faults = sum(self.count_faults(inbox).values())
        return (
            r.deadline_misses,
            r.commands_held,
            rejected,
            r.commands_late,
            r.safe_state_cycles,
            faults,
        )

    def adopt_cycles(self, k: int, on_time_run: int, applied: tuple[float, float]) -> None:
        """Take over cycles up to ``k`` that a compiled twin of :meth:`sample` and
        :meth:`finish_cycle` ran on time, not in the safe state, on this loop's simulator
        (:meth:`plant.simulator.PlantSimulator.adopt_periods`)."""
        self.x = self.sim.adopt_periods(k - self.k)
        self.k = k
        self.result.cycles = k
        self.consecutive_misses = 0
        self.on_time_run = on_time_run
        self.applied = applied

    def adopt_summaries(self, summary_seq: int, wall_s: float, sim_s: float) -> None:
        """After a compiled twin published running summaries: the next summary's seq and
        what :meth:`publish_summary` leaves in the result (wall and simulated seconds,
        the fault counters)."""
        self.summary_seq = summary_seq
        r = self.result
        r.wall_s, r.sim_s = wall_s, sim_s
        self.count_faults(self._inbox)

    @property
    def bus_faults(self) -> bool:
        """True when the scenario has bus faults (the loops take the faulted path)."""
        return self.sensor_link is not None or self.command_plan is not None

    @property
    def t_ns(self) -> int:
        return self.k * self.period_ns

    def sample(self) -> SensorFrame:
        """Publish truth and sensor frame of the current state; return the frame."""
        now = time.monotonic_ns()
        k = self.k
        t_ns = k * self.period_ns
        if t_ns >= self._next_fault_event_ns:
            self._log_fault_events()
        sim = self.sim
        truth = sim.truth(k, t_ns, self.x, self.applied, now)
        frame = sim.sensor_frame(k, truth, now)
        publish = self.publish
        if self._preview is not None:  # bench oracle, published before the frame it goes with
            publish(WAVE_PREVIEW_PERFECT, self._wave_preview(now))
        self.frame_sent_ns = time.monotonic_ns()
        if self.sensor_link is None:
            publish(SENSORS, frame)
        else:  # the loop publishes it when the link delivers it
            self.sensor_link.submit(frame, self.frame_sent_ns)
        # The log-only messages go out while the controller works on the frame: a Zenoh
        # put costs 50-150 us, which would otherwise add to every cycle's round trip.
        publish(TRUTH, truth)
        self.flush_timing()
        return frame

    def _log_fault_events(self) -> None:
        events = self._fault_events
        while events and events[0][0] <= self.t_ns:
            self.log(f"t = {self.t_ns * 1e-9:.3f} s: {events.pop(0)[1]}")
        self._next_fault_event_ns = events[0][0] if events else OPEN_END_NS

    def count_faults(self, inbox: CommandInbox | None = None) -> dict[str, int]:
        """Collect the fault counters (sensor, sensor link, command) into the result."""
        counts: Counter[str] = Counter(self.sim.faults.injected)
        if self.sensor_link is not None:
            counts.update(self.sensor_link.counts)
        counts.update(self.command_fault_counts)
        if inbox is not None:
            counts.update(inbox.fault_counts)
        self.result.faults_injected = dict(sorted(counts.items()))
        return self.result.faults_injected

    def flush_timing(self) -> None:
        """Publish the previous cycle's timing record if it is still pending."""
        if self._pending_timing is not None:
            self.publish(CYCLE_TIMING, self._pending_timing)
            self._pending_timing = None

    def finish_cycle(
        self,
        command: ActuatorCommand | None,
        latency_ns: int,
        tick_lateness_ns: int = 0,
        at_arrival: bool = True,
        effect_at_ns: int = 0,
    ) -> None:
        """Apply ``command`` (None: deadline missed, hold), integrate, publish timing.

        ``at_arrival``: the command takes effect ``latency_ns`` into the period (real time);
        False (lock-step, in-process): ``effect_at_ns`` of simulated time into the period
        (0 unless a bus fault delayed it), whatever the wall latency, so those modes stay
        deterministic on a loaded machine.
        """
        t0 = time.monotonic_ns()
        missed = command is None
        previous = self.applied
        sim = self.sim
        t_ns = self.k * self.period_ns
        switch = 0
        faulted = command is not None and not command_usable(command)
        if faulted:
            assert command is not None
            self._faulted_command(command)
            self.hist.record(latency_ns)
            new = previous  # never applied: the safe state takes over below
            self.result.commands_held += 1
        elif command is not None:
            new = (command.blade_pitch_commanded_rad, command.generator_torque_commanded_nm)
            if at_arrival and self.speed > 0:
                switch = min(sim.n, round(latency_ns * 1e-9 * self.speed / sim.h))
            elif effect_at_ns:
                switch = min(sim.n, round(effect_at_ns * 1e-9 / sim.h))
            self.hist.record(latency_ns)
        else:
            if latency_ns > 0:
                # A late command (real time): it came after the deadline but before the next
                # tick. The cycle is a miss, and its latency is a sample like any other, so
                # the histogram's maximum is the true one, not the deadline.
                self.hist.record(latency_ns)
            new = previous
            self.result.deadline_misses += 1
            self.result.commands_held += 1
        new = self._watchdog(missed or faulted, new)
        self.x = sim.advance(t_ns * 1e-9, self.x, previous, new, switch)
        self.applied = new
        now = time.monotonic_ns()
        self._pending_timing = CycleTiming(
            seq=self.k,
            sample_time_ns=t_ns,
            publish_time_ns=now,
            latency_ns=latency_ns,
            deadline_missed=int(missed),
            command_held=int(missed or faulted),
            safe_state=int(self.safe_state),
            plant_compute_ns=now - t0,
            tick_lateness_ns=tick_lateness_ns,
        )
        self.k += 1
        self.result.cycles = self.k
        if self.k % self._summary_every == 0:
            self.publish_summary(final=False)

    def _faulted_command(self, command: ActuatorCommand) -> None:
        """A command the controller flagged as faulted, or a non-finite or negative-torque
        one (:func:`command_usable`): never applied; the plant enters its safe state at once
        (its usual safe state: pitch to feather, torque ramp-down), whatever the watchdog's
        miss count. Held there while the faulted commands go on (they count as misses
        towards the watchdog's recovery rule)."""
        self.result.commands_faulted += 1
        if self.safe_state:
            return
        self.safe_state = True
        self.result.safe_state_entries += 1
        self.on_time_run = 0
        self.log(
            f"plant SAFE STATE at t = {self.t_ns * 1e-9:.3f} s: the controller's command "
            f"{command.seq} (answering frame {command.answered_seq}) is "
            + (
                "flagged as faulted (mode 3)"
                if command.mode == COMMAND_MODE_FAULT
                else "not a usable demand (non-finite or a negative torque)"
            )
            + ": not applied; pitch to feather, torque ramp-down"
        )

    def _watchdog(self, missed: bool, demand: tuple[float, float]) -> tuple[float, float]:
        """The demand to apply this cycle after the watchdog's rule (see TimingSection)."""
        if not missed and not self.safe_state:  # the usual cycle: nothing can switch
            self.consecutive_misses = 0
            self.on_time_run += 1
            return demand
        if missed:
            self.consecutive_misses += 1
            self.on_time_run = 0
        else:
            self.consecutive_misses = 0
            self.on_time_run += 1
        if (
            not self.safe_state
            and self.watchdog_misses > 0
            and self.consecutive_misses >= self.watchdog_misses
        ):
            self.safe_state = True
            self.result.safe_state_entries += 1
            self.on_time_run = 0
            self._startup_safe_state = self.k < self.startup_cycles
            self.log(
                f"plant SAFE STATE at t = {self.t_ns * 1e-9:.3f} s after "
                f"{self.consecutive_misses} consecutive missed deadlines: pitch to feather, "
                "torque ramp-down"
                + (
                    f" (during start-up: handed back after {self._recover_after()} on-time "
                    "commands)"
                    if self._startup_safe_state
                    else ""
                )
            )
        elif self.safe_state and 0 < self._recover_after() <= self.on_time_run:
            self.safe_state = False
            self._startup_safe_state = False
            self.result.safe_state_recoveries += 1
            self.log(
                f"plant leaves the safe state at t = {self.t_ns * 1e-9:.3f} s after "
                f"{self.on_time_run} on-time commands ({self._safe_window} cycles in it)"
            )
            self._safe_window = 0
        if self.safe_state:
            r = self.result
            r.safe_state_cycles += 1
            self._safe_window += 1
            r.safe_state_longest_cycles = max(r.safe_state_longest_cycles, self._safe_window)
            return self.safe_demand
        return demand

    def _recover_after(self) -> int:
        """On-time commands that hand control back from the safe state (0: latched).

        The scenario's ``watchdog_recover_cycles`` under ``watchdog_policy = "recover"``, 0
        under ``"latch"``; for a safe state tripped in the first
        ``startup_cycles`` (the start-up's misses: a process still loading, a first
        connection) at least ``startup_recover_cycles``, even where the scenario latches it,
        so that a slow start does not make the whole run a safe-state run. A controller that
        never answers in time still keeps the plant in its safe state.
        """
        if self._startup_safe_state:
            return max(self.watchdog_recover, self.startup_recover_cycles)
        return self.watchdog_recover

    def publish_summary(self, final: bool) -> TimingSummary:
        """Publish the running (or final) timing summary."""
        if final:
            self.flush_timing()
        r = self.result
        wall_s = (time.monotonic_ns() - self.start_wall_ns) * 1e-9
        r.wall_s, r.sim_s = wall_s, self.t_ns * 1e-9
        if self._inbox is not None:
            # Commands that came after the tick that ended their cycle: no cycle's latency,
            # but the largest latency the plant saw.
            self.hist.observe_max(self._inbox.late_max_ns)
        p50, p99, p999 = self.hist.percentiles_us(50, 99, 99.9)
        summary = TimingSummary(
            seq=self.summary_seq,
            sample_time_ns=self.t_ns,
            publish_time_ns=time.monotonic_ns(),
            cycles=r.cycles,
            deadline_misses=r.deadline_misses,
            commands_held=r.commands_held,
            # The inbox counts rejections as they happen (Zenoh's thread); the running
            # summaries carry the count so far, not only the final one.
            commands_rejected=(
                sum(self._inbox.rejected.values())
                if self._inbox is not None
                else r.commands_rejected
            ),
            commands_late=r.commands_late,
            safe_state=int(self.safe_state),
            safe_state_cycles=r.safe_state_cycles,
            faults_injected=sum(self.count_faults(self._inbox).values()),
            final=int(final),
            latency_p50_us=p50,
            latency_p99_us=p99,
            latency_p999_us=p999,
            latency_max_us=self.hist.max_ns / 1e3,
            sim_seconds_per_wall_second=min(1e9, r.sim_s / wall_s) if wall_s > 0 else 0.0,
        )
        self.summary_seq += 1
        self.publish(TIMING_SUMMARY, summary)
        return summary


class CommandInbox:
    """Receives command payloads in Zenoh's thread; the plant loop reads them.

    Parameters
    ----------
    faults : BusFaultPlan, optional
        The ``command`` channel's bus faults, applied on arrival (real-time mode only; the
        lock-step loop applies them in simulated time): a lost command is dropped, a
        delayed one becomes visible (and counts as arrived) D / ``speed`` later, FIFO.
    speed : float
        Real-time speed factor s: a delay of D simulated seconds is D / s wall seconds.

    Attributes
    ----------
    published_seq : int or None
        The newest sensor frame seq the plant has published (:meth:`published`); a command
        answering a later one cannot be genuine and is refused as ``unpublished_seq``.
        None: not tracked (unit use without a plant loop).
    period_ns : int or None
        The control period [ns]: frame k is sampled at k periods and a command echoes its
        frame's sample time, so a command whose ``sample_time_ns`` is more than one period
        away from ``answered_seq`` periods is refused as ``implausible_time`` (never used in
        arithmetic). None: not checked.
    """

    def __init__(self, faults: BusFaultPlan | None = None, speed: float = 1.0) -> None:
        self.cond = threading.Condition()
        self.latest: tuple[ActuatorCommand, int] | None = None
        self.rejected: Counter[str] = Counter()
        self.last_answered = -1
        self.published_seq: int | None = None
        self.period_ns: int | None = None
        self.late = 0  # commands that answered an older frame than the one awaited
        self.faults = faults if faults else None
        self.speed = speed
        self.fault_counts: Counter[str] = Counter()
        self.pending: deque[tuple[int, ActuatorCommand]] = deque()  # (visible at ns, command)
        self._last_visible_ns = -1
        # When each recent frame went out (seq, monotonic ns), by seq modulo the ring's
        # length: the latency of a command that comes after its cycle ended is measured
        # from it (late_max_ns), so the summary's maximum is the true one.
        self._sent: list[tuple[int, int]] = [(-1, 0)] * self.SENT_RING
        self.late_max_ns = 0

    #: Frames whose send time is kept for :attr:`late_max_ns` (10 s at 100 Hz).
    SENT_RING = 1024

    def note_sent(self, seq: int, sent_ns: int) -> None:
        """Remember when frame ``seq`` went out (the plant loop's thread)."""
        self._sent[seq % self.SENT_RING] = (seq, sent_ns)

    def _note_late(self, command: ActuatorCommand, visible_ns: int) -> None:
        """Count a command that came after its cycle; keep its latency's maximum (lock held)."""
        self.late += 1
        seq, sent = self._sent[command.answered_seq % self.SENT_RING]
        if seq == command.answered_seq and visible_ns - sent > self.late_max_ns:
            self.late_max_ns = visible_ns - sent

    def _promote(self, now_ns: int) -> None:
        """Make the delayed commands whose time has come visible (lock held)."""
        pending = self.pending
        while pending and pending[0][0] <= now_ns:
            visible, command = pending.popleft()
            if self.latest is not None:  # superseded before anyone took it
                self._note_late(*self.latest)
            self.latest = (command, visible)

    def _next_visible_ns(self) -> int | None:
        return self.pending[0][0] if self.pending else None

    def _drop_older(self, seq: int) -> None:
        if self.latest is not None and self.latest[0].answered_seq < seq:
            self._note_late(*self.latest)
            self.latest = None

    def published(self, seq: int) -> None:
        """Note that sensor frame ``seq`` is being published (call before the put)."""
        if self.published_seq is None or seq > self.published_seq:
            self.published_seq = seq  # one int store: atomic under the GIL

    def reject(self, exc: DecodeError) -> None:
        """Count a payload refused before decoding (a failed authentication tag)."""
        with self.cond:
            self.rejected[exc.reason] += 1

    def on_payload(self, _key: str, payload: bytes) -> None:
        arrival = time.monotonic_ns()
        try:
            command = COMMAND.codec.decode(payload)
        except DecodeError as exc:
            with self.cond:
                self.rejected[exc.reason] += 1
            return
        with self.cond:
            if command.answered_seq <= self.last_answered:
                self.rejected["duplicate_or_reordered"] += 1
                return
            published = self.published_seq
            if published is not None and command.answered_seq > published:
                # An answer to a frame not yet sent: forged, and accepting it would advance
                # last_answered past the genuine answers (they would all be duplicates).
                self.rejected["unpublished_seq"] += 1
                return
            period = self.period_ns
            if (
                period is not None
                and abs(command.sample_time_ns - command.answered_seq * period) > period
            ):
                self.rejected["implausible_time"] += 1  # does not advance last_answered
                return
            self.last_answered = command.answered_seq
            if self.faults is not None:
                effect = self.faults.effect(command.answered_seq, command.sample_time_ns)
                for kind in effect.kinds:
                    self.fault_counts[kind] += 1
                if effect.lost:
                    return
                if effect.delay_ns or self.pending:  # FIFO: never overtake a delayed one
                    visible = arrival + round(effect.delay_ns / self.speed)
                    visible = max(visible, self._last_visible_ns)
                    self._last_visible_ns = visible
                    self.pending.append((visible, command))
                    self.cond.notify_all()
                    return
            self.latest = (command, arrival)
            self.cond.notify_all()

    def take(self, seq: int) -> tuple[ActuatorCommand, int] | None:
        """The command answering ``seq`` if it has arrived (consumed), else None."""
        with self.cond:
            if self.pending:
                self._promote(time.monotonic_ns())
            self._drop_older(seq)
            if self.latest is not None and self.latest[0].answered_seq == seq:
                got, self.latest = self.latest, None
                return got
            return None

    def wait_for(self, seq: int, timeout_s: float) -> tuple[ActuatorCommand, int] | None:
        """Block until the command answering ``seq`` arrives, or ``timeout_s`` passes."""
        deadline = time.monotonic() + timeout_s
        with self.cond:
            if self.pending:
                self._promote(time.monotonic_ns())
            self._drop_older(seq)
            while self.latest is None or self.latest[0].answered_seq != seq:
                self._drop_older(seq)
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return None
                nxt = self._next_visible_ns()
                if nxt is not None:
                    remaining = min(remaining, max(0.0, (nxt - time.monotonic_ns()) / 1e9))
                self.cond.wait(remaining)
                if self.pending:
                    self._promote(time.monotonic_ns())
            got, self.latest = self.latest, None
            return got


class CommandChannel:
    """Lock-step over Zenoh: the command key's samples received in the plant's own thread.

    A subscriber callback runs in a thread of zenoh-python's (which takes the GIL), and
    handing its command on to the waiting loop through a condition variable wakes a second
    thread: two thread switches per cycle on two cores. Here the loop blocks in the
    subscriber's FIFO channel (``recv`` releases the GIL while it waits) and handles the
    payload itself through the :class:`CommandInbox` (decode, rejection counting,
    duplicates), one switch fewer; measured in ``bench/lockstep_speed.py``.

    ``recv`` has no timeout, so a waker thread checks every ``poll_s`` whether the loop has
    been waiting that long and, if so, puts an empty sample on the command key that only
    this session sees (``Locality.SESSION_LOCAL``): the loop wakes, runs any signal handler
    that came meanwhile (Python runs them in the main thread between bytecodes), checks
    its stop event and timeout, and waits again. An empty payload that no waker put (a
    remote one) is counted as a rejected command as before.

    Parameters
    ----------
    session : zenoh.Session
        The plant's session.
    key : str
        The command key.
    inbox : CommandInbox
        Decodes and keeps the commands (no bus faults: lock-step applies them in the loop).
    stop : threading.Event
        Set by the signal handlers; a wait ends with None soon after it is set.
    poll_s : float
        How long a wait goes before the waker wakes it to look at the stop event [s].
    open_payload : callable, optional
        ``(key, data) -> payload``: the bus's tag check (:meth:`hil.nodes.bus.Bus.open_payload`),
        raising :class:`bus_schemas.auth.AuthError`, counted by the inbox; None: the data
        is the payload (unauthenticated).
    """

    def __init__(
        self,
        session: zenoh.Session,
        key: str,
        inbox: CommandInbox,
        stop: threading.Event,
        poll_s: float = 0.05,
        open_payload: Callable[[str, bytes], bytes] | None = None,
    ) -> None:
        self.key = key
        self.inbox = inbox
        self.open_payload = open_payload
        self.stop = stop
        self.poll_ns = round(poll_s * 1e9)
        self._sub = session.declare_subscriber(key, zenoh.handlers.FifoChannel(256))
        self._waker = session.declare_publisher(
            key, allowed_destination=zenoh.Locality.SESSION_LOCAL
        )
        self._waiting_since_ns = 0  # written by the loop, read by the waker
        self._markers = 0  # wake-up samples put and not yet received
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._wake, name="plant-waker", daemon=True)
        self._thread.start()

    def _wake(self) -> None:
        while not self._closed.wait(self.poll_ns / 1e9):
            since = self._waiting_since_ns
            if since and time.monotonic_ns() - since >= self.poll_ns:
                with self._lock:
                    self._markers += 1
                try:
                    self._waker.put(b"")
                except Exception:  # the session is closing
                    return

    def wait_for(self, seq: int, timeout_s: float) -> tuple[ActuatorCommand, int] | None:
        """The command answering ``seq``, or None once ``timeout_s`` passed or stop is set."""
        got = self.inbox.take(seq)
        if got is not None:
            return got
        deadline = time.monotonic_ns() + round(timeout_s * 1e9)
        self._waiting_since_ns = time.monotonic_ns()
        try:
            while True:
                payload = self._sub.recv().payload.to_bytes()
                if not payload:
                    with self._lock:
                        marker = self._markers > 0
                        self._markers -= marker
                    if marker:
                        if self.stop.is_set() or time.monotonic_ns() >= deadline:
                            return None
                        continue
                self._deliver(payload)
                got = self.inbox.take(seq)
                if got is not None:
                    return got
        finally:
            self._waiting_since_ns = 0

    def drain(self) -> int:
        """Hand every sample already received to the inbox without waiting (the end of a
        run: a payload that came after the last command waited for is counted too).

        Returns the number of samples taken (the waker's empty markers included).
        """
        n = 0
        while (sample := self._sub.try_recv()) is not None:
            n += 1
            payload = sample.payload.to_bytes()
            if not payload:
                with self._lock:
                    if self._markers > 0:
                        self._markers -= 1
                        continue
            self._deliver(payload)
        return n

    def _deliver(self, data: bytes) -> None:
        """Check the tag (an authenticated run) and hand the payload to the inbox."""
        if self.open_payload is not None:
            try:
                data = self.open_payload(self.key, data)
            except DecodeError as exc:
                self.inbox.reject(exc)
                return
        self.inbox.on_payload(self.key, data)

    def close(self) -> None:
        """Stop the waker and undeclare the subscriber (idempotent)."""
        self._closed.set()
        self._thread.join(1.0)
        with contextlib.suppress(Exception):  # the session may already be going away
            self._sub.undeclare()
            self._waker.undeclare()


class PeerWaitInterruptedError(Exception):
    """SIGINT or SIGTERM arrived while the plant waited for its peers (nothing ran).

    Attributes
    ----------
    signum : int
        The signal number.
    """

    def __init__(self, signum: int, missing: list[str]) -> None:
        super().__init__(
            f"{signal.Signals(signum).name} while waiting for {missing}: stopped before the "
            "first cycle, nothing ran"
        )
        self.signum = signum


def wait_for_peers(
    bus: Bus | HybridBus,
    turbine_id: str,
    required: tuple[str, ...],
    timeout_s: float,
    stop: threading.Event | None = None,
) -> None:
    """Block until every ``required`` node (e.g. controller, recorder) has announced itself.

    Nodes declare a liveliness token ``fowt/<turbine>/alive/<name>`` after their
    subscribers, so once the token is seen their subscriptions are in place too. A
    liveliness subscriber with history sees the tokens already there and every new one, so
    the wait ends as soon as the last one appears, and within 50 ms of ``stop`` being set.

    Raises
    ------
    TimeoutError
        When ``timeout_s`` (``math.inf``: no limit) passes first, naming who is missing.
    """
    missing = set(required)
    if not missing:
        return
    seen: set[str] = set()
    changed = threading.Event()
    lock = threading.Lock()

    def on_token(sample: zenoh.Sample) -> None:
        name = str(sample.key_expr).rsplit("/", 1)[-1]
        with lock:
            if sample.kind == zenoh.SampleKind.DELETE:
                seen.discard(name)
            else:
                seen.add(name)
        changed.set()

    sub = bus.session.liveliness().declare_subscriber(
        f"fowt/{turbine_id}/alive/*", on_token, history=True
    )
    deadline = time.monotonic() + timeout_s
    try:
        while True:
            with lock:
                left = missing - seen
            if not left:
                return
            if stop is not None and stop.is_set():
                return
            if time.monotonic() > deadline:
                raise TimeoutError(
                    f"no {sorted(left)} after {timeout_s:g} s (--wait-timeout); is it running?"
                )
            changed.wait(0.05)
            changed.clear()
    finally:
        sub.undeclare()


def run_plant_node(
    scenario: Scenario,
    bus_config: BusConfig,
    mode: Mode = "realtime",
    speed: float = 1.0,
    require: tuple[str, ...] = ("controller",),
    peer_timeout_s: float = 120.0,
    lockstep_timeout_s: float = 10.0,
    log: Callable[[str], None] = print,
    can: CanBusConfig | None = None,
    initial: InitialCondition | None = None,
) -> PlantRunResult:
    """Run the plant as its own process on the bus in ``realtime`` or ``lockstep`` mode.

    ``initial``: where the run starts (the caller resolves the scenario's trim,
    :func:`hil.inprocess.trim.initial_condition`; None: :class:`PlantLoop`'s untrimmed start).

    Transport: with ``can`` None everything goes over the Zenoh session of ``bus_config``;
    with a :class:`hil.nodes.can_bus.CanBusConfig` the sensor frame goes out and the command
    comes in on that CAN bus (:class:`hil.nodes.can_bus.HybridBus`), while truth, timing and
    liveliness stay on Zenoh. The loops are the same: lock-step waits for the command whose
    (reassembled, unwrapped) ``answered_seq`` is frame k's.
    """
    if mode not in ("realtime", "lockstep"):
        raise ValueError(f"the plant node runs realtime or lockstep, not {mode!r}")
    if not speed > 0:
        raise ValueError(f"speed factor must be > 0, got {speed}")
    bus: Bus | HybridBus
    can_bus: CanBus | None = None
    if can is None:
        bus = Bus(bus_config)
    else:  # imported here: a Zenoh-only plant does not load python-can and cantools
        from hil.nodes.can_bus import HybridBus  # noqa: PLC0415

        bus = HybridBus(bus_config, can)
        can_bus = bus.can
    tid = scenario.turbine_id
    publishers = {
        mt.key_suffix: bus.publisher(mt.key(tid))
        for mt in (SENSORS, TIMING_SUMMARY, WAVE_PREVIEW_PERFECT, PLANT_REPORT)
    }
    # Messages handed to the bus per key suffix: the PlantReport's counts.
    published: Counter[str] = Counter()

    # Log-only messages (truth and cycle timing: nobody waits for them) go out a few per
    # put on the batch key (hil.nodes.bus.LogBatcher): one put and one wake-up of the recorder
    # for up to 16 cycles instead of two per cycle. Lock-step puts a batch when it is full
    # or 50 ms old, on the run's pace; real time puts it after the cycle's command came (or
    # its tick passed), so it never competes with the controller's turn. Every timing
    # summary goes after the batch before it, so the recorder sees the final summary last.
    batcher = LogBatcher(bus.publisher(batch_key(tid, PLANT_BATCH_SUFFIX)))
    batched = {TRUTH.key_suffix, CYCLE_TIMING.key_suffix}
    lockstep = mode == "lockstep"
    profile = CycleProfile()

    def publish(mt: MessageType, msg: msgspec.Struct) -> None:
        published[mt.key_suffix] += 1
        if mt is SENSORS:  # before the put: its answer may come back before put returns
            inbox.published(msg.seq)  # type: ignore[attr-defined]
        if can_bus is not None and mt is SENSORS:
            can_bus.publish(SENSORS, msg)  # straight to CAN frames, no payload round trip
            return
        payload = mt.codec.encode(msg)
        if mt.key_suffix in batched:
            batcher.add(payload)
            if lockstep and batcher.due():
                batcher.flush()
            return
        if mt is TIMING_SUMMARY:
            batcher.flush()
        t0 = time.monotonic_ns()
        publishers[mt.key_suffix].put(payload)
        profile.put_ns += time.monotonic_ns() - t0

    # Real time: command faults act on arrival in the inbox; lock-step: in the loop.
    command_faults = BusFaultPlan(scenario.fault_specs(), "command", scenario.sensors.seed)
    inbox = CommandInbox(command_faults if mode == "realtime" else None, speed)
    inbox.published_seq = -1  # nothing published yet: no command can be an answer
    inbox.period_ns = round(scenario.timing.control_period_s * 1e9)
    stop = threading.Event()
    channel: CommandChannel | None = None
    if mode == "lockstep" and can_bus is None:
        channel = CommandChannel(
            bus.session, COMMAND.key(tid), inbox, stop, open_payload=bus.open_payload
        )
    else:  # real time waits with a deadline per cycle; CAN delivers from its own thread
        bus.subscribe(COMMAND.key(tid), inbox.on_payload, inbox.reject)
    received: list[int] = []

    signalled = threading.Event()  # a signal, also one after the run's end

    def on_signal(signum: int) -> None:  # from a thread, never in a handler (hil.nodes.signals)
        received.append(signum)
        stop.set()
        signalled.set()

    on_stop_signals(on_signal)
    # The plant is built, and its kernels loaded (warm_up: their first call must not fall
    # into a paced cycle), before the liveliness token says it is ready; it becomes the run's
    # loop once the peers are there (a run that never starts publishes no summary).
    prepared = PlantLoop(
        scenario, publish, speed=speed if mode == "realtime" else 1.0, initial=initial
    )
    if mode == "realtime":
        prepared.sim.warm_up(prepared.x, prepared.applied)
        prepared.startup_cycles = max(1, round(STARTUP_S * 1e9 / prepared.period_ns))
        prepared.startup_recover_cycles = prepared.startup_cycles
    token = bus.session.liveliness().declare_token(f"fowt/{tid}/alive/plant")
    loop: PlantLoop | None = None
    try:
        log(f"plant waiting for {list(require)} ({bus_config.describe()})")
        wait_for_peers(bus, tid, require, peer_timeout_s, stop)
        if stop.is_set():
            signum = received[0] if received else signal.SIGTERM
            raise PeerWaitInterruptedError(signum, list(require))
        loop = prepared
        loop.start_wall_ns = time.monotonic_ns()  # the run's wall time starts now
        loop.log = log
        loop._inbox = inbox
        freeze_heap()  # no full garbage collection walking the set-up's objects mid-run
        cycles = scenario.cycles
        log(f"plant running {scenario.name}: {cycles} cycles, mode {mode}, speed {speed:g}")
        if mode == "lockstep":
            waiter = channel if channel is not None else inbox
            _run_lockstep(loop, waiter, cycles, lockstep_timeout_s, stop, profile)
            log(profile.describe())
        else:
            _run_realtime(loop, inbox, cycles, stop, batcher)
        if stop.is_set() and not loop.result.aborted:
            loop.result.aborted = "stopped by signal"
    except TimeoutError as exc:
        if loop is None:
            raise
        loop.result.aborted = str(exc)
    finally:
        if loop is not None:
            if channel is not None:  # lock-step reads its FIFO only while it waits
                channel.drain()
            loop.result.commands_rejected = sum(inbox.rejected.values())
            loop.result.rejected = dict(inbox.rejected)
            loop.count_faults(inbox)
            final = loop.publish_summary(final=True)  # after the last log batch
            # The report goes last: the recorder records until it holds what it counts.
            report = plant_report(
                loop.result,
                published,
                sample_time_ns=final.sample_time_ns,
                aborted=bool(loop.result.aborted),
            )
            publishers[PLANT_REPORT.key_suffix].put(PLANT_REPORT.codec.encode(report))
            # What went out in log batches; a put that raised is said (the report counts
            # its messages as published, so the review finds them missing).
            log(
                f"plant log batches: {batcher.puts} put ({batcher.messages} messages), "
                f"{batcher.failed} failed"
            )
            time.sleep(0.2)  # let the final summary reach the others before the link goes
            # A session closed while its samples are on their way to a recorder behind the
            # run loses them (hil.nodes.bus.wait_for_recorder): it stays open until the recorder
            # holds them all.
            # A signal that ended the run does not skip this wait; one during it ends it.
            signalled.clear()
            ack = wait_for_recorder(bus.session, tid, "plant", stop=signalled)
            if ack == "timeout":
                log("plant: the recorder did not confirm it holds the run; closing anyway")
        token.undeclare()
        if channel is not None:
            channel.close()
        if can_bus is not None:
            log(
                f"plant CAN ({can_bus.config.interface} {can_bus.config.effective_channel}"
                f"{', FD' if can_bus.config.fd else ''}): {can_bus.frames_sent} frames sent, "
                f"{can_bus.frames_received} received, rejected {dict(can_bus.rejected)}"
            )
        bus.close()
    assert loop is not None
    r = loop.result
    log(
        f"plant done: {r.cycles} cycles, {r.sim_s:.1f} s simulated in {r.wall_s:.2f} s "
        f"({r.speed:.1f}x), deadline misses {r.deadline_misses}"
        + (
            f", safe state for {r.safe_state_cycles} cycles ({r.safe_state_entries} trip(s), "
            f"{r.safe_state_recoveries} recovered, longest {r.safe_state_longest_cycles} cycles)"
            if r.safe_state_cycles
            else ""
        )
        + (f", rejected commands {r.rejected}" if r.rejected else "")
        + (
            f", {r.commands_faulted} commands flagged as faulted not applied"
            if r.commands_faulted
            else ""
        )
        + (f", aborted: {r.aborted}" if r.aborted else "")
    )
    if r.faults_injected:
        log(f"plant faults injected: {fault_counts_text(r.faults_injected)}")
    return r


def fault_counts_text(counts: dict[str, int]) -> str:
    return ", ".join(f"{kind} {n}" for kind, n in counts.items())


Exchange = Callable[[SensorFrame, int], "tuple[ActuatorCommand | None, int]"]


def faulted_sim_cycle(loop: PlantLoop, frame: SensorFrame, exchange: Exchange) -> None:
    """One lock-step / in-process cycle under bus faults, in simulated time.

    Delivers the frames due before t_{k+1} (the sensor link; without one, frame k, already
    published), gets the controller's answer to each through ``exchange(frame, sent_ns)``
    -> (command or None, wall latency ns), and applies the answer to frame k at its
    simulated arrival, or holds (module docstring, "Bus faults").
    """
    k, t_k, period = loop.k, loop.t_ns, loop.period_ns
    link = loop.sensor_link
    due = [(frame, t_k)] if link is None else link.pop_due_sim(t_k + period)
    answer: tuple[ActuatorCommand, int, int] | None = None
    for f, due_ns in due:
        if link is not None:
            loop.publish(SENSORS, f)
        command, latency = exchange(f, time.monotonic_ns())
        if command is None:
            continue
        if f.seq == k:
            answer = (command, latency, due_ns - t_k)
        else:
            loop.result.commands_late += 1  # answered an older frame: dropped
    if answer is None:  # frame k lost or delayed past the period: hold, a miss
        loop.finish_cycle(None, 0)
        return
    command, latency, effect_at = answer
    plan = loop.command_plan
    if plan is not None:
        effect = plan.effect(k, t_k)
        loop.command_fault_counts.update(effect.kinds)
        if effect.lost:
            loop.finish_cycle(None, 0)
            return
        effect_at += effect.delay_ns
    if effect_at >= period:
        loop.result.commands_late += 1
        loop.finish_cycle(None, 0)
        return
    loop.finish_cycle(command, latency, at_arrival=False, effect_at_ns=effect_at)


@dataclass
class CycleProfile:
    """Where a lock-step plant's cycles went, summed over the run [ns] (the end's log line).

    ``sample``: :meth:`PlantLoop.sample` (truth, sensor frame, their encoding and the sensor
    frame's put, ``put`` of it); ``wait``: blocked until the command answering the frame
    was handed to this thread (the round trip over the bus plus the controller's turn);
    ``finish``: :meth:`PlantLoop.finish_cycle` (applying the command, integrating).
    """

    cycles: int = 0
    sample_ns: int = 0
    put_ns: int = 0
    wait_ns: int = 0
    finish_ns: int = 0

    def describe(self) -> str:
        """One log line with the means per cycle [us]."""
        n = max(1, self.cycles)
        return (
            f"plant lock-step cycle profile ({self.cycles} cycles, mean us per cycle): "
            f"sample {self.sample_ns / n / 1e3:.1f} (of which sensor put "
            f"{self.put_ns / n / 1e3:.1f}), wait {self.wait_ns / n / 1e3:.1f}, "
            f"finish {self.finish_ns / n / 1e3:.1f}"
        )


class _StopRequestedError(Exception):
    """The stop event was set while the lock-step loop waited for a command."""


def _run_lockstep(
    loop: PlantLoop,
    inbox: CommandInbox | CommandChannel,
    cycles: int,
    timeout_s: float,
    stop: threading.Event,
    profile: CycleProfile | None = None,
) -> None:
    try:
        _lockstep_cycles(loop, inbox, cycles, timeout_s, stop, profile)
    except _StopRequestedError:
        return


def _lockstep_cycles(
    loop: PlantLoop,
    inbox: CommandInbox | CommandChannel,
    cycles: int,
    timeout_s: float,
    stop: threading.Event,
    profile: CycleProfile | None = None,
) -> None:
    def exchange(frame: SensorFrame, sent_ns: int) -> tuple[ActuatorCommand | None, int]:
        got = inbox.wait_for(frame.seq, timeout_s)
        if got is None:
            if stop.is_set():
                raise _StopRequestedError
            raise TimeoutError(
                f"controller did not answer frame {frame.seq} within {timeout_s:g} s"
            )
        return got[0], got[1] - sent_ns

    prof = profile if profile is not None else CycleProfile()
    clock = time.monotonic_ns
    faulted = loop.bus_faults
    for _ in range(cycles):
        if stop.is_set():
            return
        t0 = clock()
        frame = loop.sample()
        if faulted:
            faulted_sim_cycle(loop, frame, exchange)
            continue
        t1 = clock()
        command, latency = exchange(frame, loop.frame_sent_ns)
        t2 = clock()
        loop.finish_cycle(command, latency, at_arrival=False)
        prof.sample_ns += t1 - t0
        prof.wait_ns += t2 - t1
        prof.finish_ns += clock() - t2
        prof.cycles += 1


def _run_realtime(
    loop: PlantLoop,
    inbox: CommandInbox,
    cycles: int,
    stop: threading.Event,
    batcher: LogBatcher | None = None,
) -> None:
    pacer = Pacer(loop.wall_period_ns)
    loop.start_wall_ns = pacer.start_ns
    lateness = 0
    for _ in range(cycles):
        if stop.is_set():
            return
        frame = loop.sample()
        sent = loop.frame_sent_ns
        inbox.note_sent(frame.seq, sent)
        tick = pacer.deadline_ns(pacer.k + 1)
        if loop.sensor_link is not None:
            got = _wait_delivering(loop, loop.sensor_link, inbox, frame.seq, tick)
        else:
            # Block on the inbox until the command or the next tick, whichever first
            # (blocking, not spinning, leaves the CPU to the controller on 2 cores) ...
            remaining_s = (tick - time.monotonic_ns()) / 1e9
            got = (
                inbox.wait_for(frame.seq, remaining_s) if remaining_s > 0 else inbox.take(frame.seq)
            )
        late_ns = 0
        if got is not None and got[1] - sent > loop.wall_period_ns:
            late_ns = got[1] - sent  # logged as this missed cycle's latency
            got = None  # it came, but later than its control period: a miss
            loop.result.commands_late += 1
        # The log batch goes now that the command is in (or its time is up): its put never
        # competes with the controller's turn.
        if batcher is not None and batcher.due():
            batcher.flush()
        # ... then pace precisely to the tick.
        lateness_next = pacer.wait_tick()
        if got is None:
            loop.finish_cycle(None, late_ns, lateness)
        else:
            loop.finish_cycle(got[0], got[1] - sent, lateness)
        lateness = lateness_next
    loop.result.commands_late += inbox.late


def _wait_delivering(
    loop: PlantLoop, link: SensorLink, inbox: CommandInbox, seq: int, tick_ns: int
) -> tuple[ActuatorCommand, int] | None:
    """Real time under sensor bus faults: wait for the command answering ``seq`` until
    ``tick_ns``, publishing the held frames at their wall delivery times meanwhile (and
    after the command came, up to the tick)."""
    got: tuple[ActuatorCommand, int] | None = None
    while True:
        now = time.monotonic_ns()
        for f in link.pop_due_wall(now):
            loop.publish(SENSORS, f)
        if now >= tick_ns:
            break
        nxt = link.next_due_wall()
        if got is not None:
            if nxt is None or nxt >= tick_ns:
                break
            wait_until(nxt, 200_000)
            continue
        limit = tick_ns if nxt is None else min(tick_ns, nxt)
        remaining_s = (limit - now) / 1e9
        got = inbox.wait_for(seq, remaining_s) if remaining_s > 0 else inbox.take(seq)
    return got if got is not None else inbox.take(seq)
