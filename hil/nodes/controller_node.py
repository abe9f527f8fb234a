"""The controller process: sensor frames in, actuator commands out, every cycle.

:class:`ControllerRuntime` is the thin shell around a pure controller core
(``step(state, measurement, dt) -> (state, output)``): it decodes and validates each payload,
rejects and counts anything malformed, of another version, non-finite, out of range,
duplicated, reordered or stale, steps the core, and builds the command (echoing the frame's
``seq``) and the status message. It owns no clock of its own (one is injected) and does no
I/O, so the in-process runner uses the very same object as the Zenoh node and the two give
identical results.

Core faults (:mod:`hil.nodes.controller_fault`): a core whose ``step`` raises, or returns a
command that is non-finite or outside its own actuator limits' pitch range (or a negative or
absurd torque), has *faulted*. The runtime keeps the first fault (kind, message, simulated
time, cycle), logs one line naming it (no traceback: the fault is the core's, not the
process's), never steps the core again, and answers every frame from then on with the safe
command (pitch to feather, torque to 0, at the core's rate limits) flagged
:data:`MODE_FAULT`: the command is recorded, and a plant never applies it but goes to its
safe state. Nothing non-finite ever leaves the runtime. The same in every mode, so a
faulting core gets the same verdict (``controller_fault``, exit 7) everywhere. A DISCON
library that reports ``aviFAIL`` < 0 (:class:`controller.discon.DisconError`, with the
library's message) is such a fault too: the library is not called again.

Sensor-frame watchdog (the controller's counterpart of the plant's, same rule and same
scenario keys ``timing.watchdog_misses`` = N and ``timing.watchdog_recover_cycles`` = K):

* a frame is **missing** when the ``seq`` of the next accepted frame skips it (a gap of g
  counts g misses); a rejected payload is not a miss by itself, but the seqs it hid show up
  as a gap when a valid frame comes again;
* a frame is **stale** when its age, the runtime's receive time minus the frame's
  ``publish_time_ns``, exceeds one control period. Both are ``time.monotonic_ns()`` of one
  host (the bench's default: loopback only), so the age is exact. With
  ``same_host_clock=False`` (the node sets it when a Zenoh config file may join two hosts)
  the age is taken relative to the smallest receive-minus-publish difference seen so far:
  differences of the plant's publish times are true durations on any host, so this is the
  age beyond the fastest delivery of the run, whatever the offset between the two clocks;
* **no frame for a control period**: the node calls :meth:`ControllerRuntime.check_silence`
  every half period; each period past the expected arrival of the next frame (half a period
  of grace for jitter) counts one miss.

Time plausibility: a frame whose sample time lies past the run's window
(:func:`hil.nodes.bus.sample_time_limit_ns`) or further ahead of the last accepted frame's
than its seq is (frame k is sampled at k control periods; one period of slack) is refused as
``implausible_time`` and moves nothing, so a single signed far-future frame cannot make every
genuine frame after it "stale".

Sequence plausibility: a frame whose ``seq`` is more than W ahead of the last accepted one,
W = max(ceil(:data:`PLAUSIBLE_GAP_S` / T), 2 N) frames (T the control period, N the watchdog's
miss limit; 500 frames at 100 Hz), is not a gap the bus could have made in a run: it is
refused and counted as ``implausible_seq``, and it does not advance the duplicate filter (one
forged frame with seq + 1000 must not make every genuine frame after it a "duplicate"). A
genuine resync after a real outage longer than that shows itself as a *consistent run*:
:data:`RESYNC_FRAMES` such frames in a row, each seq one more than the previous and its
sample time later, with no plausible frame in between; the last of the run is accepted (the
gap it leaves counts as missing frames for the watchdog, as any gap does). A forger's
future frames interleaved with the genuine stream never form such a run, because every
accepted genuine frame resets it. The first frame is measured from seq -1 as well: a run
starts at 0, so a forged far-future frame that overtakes frame 0 cannot latch a fresh
controller either; a controller restarted into a running real-time stream takes its first
frame at the end of such a consistent run. In lock-step the plant waits for the answer to
each frame, so a lock-step run whose sensor link loses more than W frames in a row cannot
resync (the plant times out); the shipped fault scenarios stay far below that.

The wall-clock checks (age and silence) apply only while the stream is *paced in real
time*: the plant's publish times of the last 8 consecutive frames advanced by one control
period each, within 10 % (``fowt run --mode realtime --speed 1``). In lock-step and
in-process runs the plant waits for each command, so wall-clock age means nothing there and
only the seq gaps count: the watchdog stays deterministic and lock-step keeps equal to
in-process (a stall of the machine or a flood of bad payloads can never trip it). At
another real-time speed the stream is not recognised as paced and only the gaps count
(``paced=True`` forces the wall-clock checks on).

After N consecutive misses (0: never) the runtime enters its **safe mode**: every command it
publishes (it still answers each frame that arrives) is the safe command, the blade pitch
moved towards the core's own feathered pitch (its maximum pitch) at the core's pitch rate
limit, and the generator torque ramped to 0 at the core's torque rate limit, both from the
last published command over the simulated time since it; ``ActuatorCommand.mode`` =
:data:`MODE_SAFE` (2), ``ControllerStatus.regime`` = :data:`controller.interface.REGIME_SAFE`
(5), and the log says so. The core keeps stepping on the frames that arrive (its estimates
stay live in the status) but its commands are discarded. Recovery, as the plant's: latched
for the rest of the run when K = 0 (the default); with K > 0 after K consecutive healthy
frames (no gap, not stale): the core is re-initialised (``initial_state()``; its first step
starts from the current measurement: the baseline's filter, pitch and torque from the
measured speed, pitch and torque; the advanced controller's EKF and platform KF from the
frame, its wave forecaster restarting empty, so no forecast or feedforward until its buffer
refills) and the commands go out with ``mode`` = :data:`MODE_RESUMING` (1), rate limited
against the last published command, until the core's own command is within one step's rate
limit of it (bumpless transfer), then ``mode`` = :data:`MODE_NORMAL` (0).

:func:`run_controller_node` is the process: one Zenoh session, a subscriber on
``fowt/<turbine>/sensors`` whose callback runs the cycle and publishes at once (lowest
latency: no hand-off to another thread), the silence check in the main thread, a liveliness
token announcing readiness, and an exit when the plant publishes its final timing summary or
on SIGINT/SIGTERM. Before it leaves the bus it puts its last status batch and then its
:class:`bus_schemas.messages.ControllerReport` (:func:`controller_report`): the frames it
stepped on, the commands and statuses it published, its safe mode and watchdog counts and
every rejected frame by reason, so the recorder knows how many of its messages to wait for
(docs/recording.md).

This module never imports ``plant``: the controller speaks only ``bus_schemas``.
"""

from __future__ import annotations

import math
import operator
import os
import signal
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import msgspec
import numpy as np
import zenoh

from bus_schemas import ActuatorCommand, ControllerStatus, DecodeError, SensorFrame
from bus_schemas.messages import (
    COMMAND_MODE_FAULT,
    CONTROLLER_REJECT_REASONS,
    WAVE_PREVIEW_FIELDS,
    ControllerReport,
    rejection_fields,
)
from bus_schemas.registry import (
    COMMAND,
    CONTROLLER_REPORT,
    CONTROLLER_STATUS,
    SENSORS,
    TIMING_SUMMARY,
    WAVE_PREVIEW_PERFECT,
    MessageType,
)
from controller.discon import DisconError
from controller.interface import REGIME_SAFE, ControlOutput, OperatingPoint
from controller.lqri import DesignNotFoundError
from controller.registry import actuator_limits, make_controller
from hil.nodes.bus import (
    CONTROLLER_BATCH_SUFFIX,
    Bus,
    BusConfig,
    LogBatcher,
    await_recorder,
    batch_key,
    sample_time_limit_ns,
    wait_for_recorder,
)
from hil.nodes.controller_fault import (
    FAULT_CODES,
    FAULT_FIELDS,
    TORQUE_MAX_NM,
    ControllerFault,
    write_fault,
)
from hil.nodes.rt import freeze_heap
from hil.nodes.signals import on_stop_signals
from hil.scenario.schema import Scenario

#: Float fields of a sensor frame (checked finite before a frame may reach the core).
_FLOAT_FIELDS = tuple(
    name
    for name, typ in zip(
        SensorFrame.__struct_fields__, SensorFrame.__annotations__.values(), strict=True
    )
    if "float" in str(typ)
)
_float_values = operator.attrgetter(*_FLOAT_FIELDS)

#: Index of ``generator_speed_filtered_rad_s`` in :class:`ControlOutput`: from there on its
#: fields are :class:`ControllerStatus`'s after ``rejected_frames`` (same names, same order),
#: so the status takes them positionally (handle_frame).
_STATUS_TAIL_FROM = ControlOutput.__struct_fields__.index("generator_speed_filtered_rad_s")
if (
    ControlOutput.__struct_fields__[_STATUS_TAIL_FROM:]
    != ControllerStatus.__struct_fields__[
        ControllerStatus.__struct_fields__.index("generator_speed_filtered_rad_s") :
    ]
):
    raise ImportError(
        "ControlOutput's fields from generator_speed_filtered_rad_s on must be "
        "ControllerStatus's, in the same order (hil.nodes.controller_node.handle_frame)"
    )
_astuple = msgspec.structs.astuple

#: ``ActuatorCommand.mode``: the core's command.
MODE_NORMAL = 0
#: ``ActuatorCommand.mode``: the core's command, rate limited after leaving the safe mode.
MODE_RESUMING = 1
#: ``ActuatorCommand.mode``: the safe command (feathering, torque ramp-down).
MODE_SAFE = 2
#: ``ActuatorCommand.mode``: the core faulted (:data:`bus_schemas.messages.COMMAND_MODE_FAULT`).
MODE_FAULT = COMMAND_MODE_FAULT
#: Slack on the core's own pitch range before a command counts as out of range [rad]
#: (0.06 deg: a core's clamp may round; a real excursion is far larger).
PITCH_TOLERANCE_RAD = 1e-3
#: Consecutive frames whose publish times advance by one control period (within
#: :data:`PACED_TOLERANCE`) before the stream counts as paced in real time.
PACED_FRAMES = 8
PACED_TOLERANCE = 0.1
#: Age [control periods] beyond which the node skips a frame in real time
#: (:meth:`ControllerRuntime.overdue`).
OVERDUE_PERIODS = 2
#: Longest stretch of lost frames accepted as a plain gap [s] (module docstring, W).
PLAUSIBLE_GAP_S = 5.0
#: Consecutive, consistent implausible frames that make a genuine resync.
RESYNC_FRAMES = 3


def seq_window(control_period_s: float, watchdog_misses: int) -> int:
    """W: how far [frames] a frame's seq may jump ahead of the last accepted one.

    max(ceil(:data:`PLAUSIBLE_GAP_S` / T), 2 N) for control period T [s] and the watchdog's
    miss limit N: a gap the watchdog acts on is always plausible.
    """
    return max(math.ceil(PLAUSIBLE_GAP_S / control_period_s - 1e-9), 2 * watchdog_misses)


class RuntimeCounters(NamedTuple):
    """The controller runtime's bookkeeping on :meth:`ControllerRuntime.handle_frame`'s usual
    path (:meth:`ControllerRuntime.counters`): sequence, sample time (ns), frames accepted,
    next command seq, frames rejected, the pacing detector's run, whether it still detects,
    the last frame's publish and receive times (ns), the healthy run."""

    last_seq: int
    last_sample_time_ns: int
    accepted: int
    command_seq: int
    rejected_total: int
    paced_run: int
    detect_pacing: bool
    last_publish_ns: int
    last_receive_ns: int
    healthy_run: int


class ControllerRuntime:
    """Validation, sequencing, the sensor-frame watchdog and message building around a core.

    Parameters
    ----------
    scenario : Scenario
        Gives the controller kind, its preset, the control period (the core's dt) and the
        watchdog's rule (``timing.watchdog_misses``, ``timing.watchdog_recover_cycles``).
    clock : callable
        Monotonic clock in ns (``time.monotonic_ns`` in a node).
    design_dir : str or Path, optional
        Folder of controller design artefacts searched after the shipped ones (the launcher
        passes the cache it designed into); None: the shipped designs and the user design
        cache (``$FOWT_DESIGN_DIR``, default ``~/.cache/fowt-hil/designs``).
    paced : bool or None
        Whether the wall-clock checks (frame age, silence) apply: None (default) detects a
        stream paced in real time from the frames' publish times (module docstring); True
        or False forces them on or off.
    same_host_clock : bool
        True (default): ``clock`` and the frames' ``publish_time_ns`` are one host's
        monotonic clock, the age is exact; False: the age is relative to the fastest
        delivery seen (module docstring).
    log : callable, optional
        Receives the watchdog's messages (entering and leaving the safe mode).
    run_dir : str or Path, optional
        The run's folder, where a ``"rosco"`` core's library writes its files (None: the
        core's default, ``$FOWT_RUN_DIR``; :mod:`controller.rosco`).
    phase : str
        ``"run"``, or ``"trim"`` for the trim's settling run: recorded in a core fault
        (:class:`hil.nodes.controller_fault.ControllerFault`).
    operating_point : OperatingPoint, callable or None
        A trimmed run's operating point (:func:`hil.inprocess.trim.operating_point`), or a
        function returning it (called only for a core that has ``trimmed_state``): the core
        then starts from ``trimmed_state(operating_point)`` instead of ``initial_state()``
        (:mod:`controller.interface`). None: ``initial_state()``.

    Raises
    ------
    controller.lqri.DesignNotFoundError
        If the advanced controller's artefacts for the scenario's control period are missing
        (the message names the ``fowt design`` command to run).
    """

    def __init__(
        self,
        scenario: Scenario,
        clock: Callable[[], int] = time.monotonic_ns,
        design_dir: str | Path | None = None,
        *,
        paced: bool | None = None,
        same_host_clock: bool = True,
        log: Callable[[str], None] | None = None,
        run_dir: str | Path | None = None,
        phase: str = "run",
        operating_point: OperatingPoint | Callable[[], OperatingPoint | None] | None = None,
    ) -> None:
        c = scenario.controller
        self.phase = phase
        waves = scenario.waves
        self.controller = make_controller(
            c.kind,
            c.preset,
            control_period_s=scenario.timing.control_period_s,
            forecaster=c.forecaster,
            feedforward=c.feedforward,
            gauge_distance_m=waves.gauge_distance_m if waves is not None else None,
            design_dir=None if design_dir is None else str(design_dir),
            library=c.library,
            parameter_file=c.parameter_file,
            output_dir=None if run_dir is None else str(run_dir),
            preview=c.preview,
            horizon_s=c.horizon_s,
            overlap=c.overlap,
            symmetric_pitch_limit_deg=c.symmetric_pitch_limit_deg,
            torque_weight_factor=c.torque_weight_factor,
            gamma_1_s=c.gamma_value,
            core=c.core,
            settings=c.settings,
            base_dir=c.base_dir,
        )
        trimmed_state = getattr(self.controller, "trimmed_state", None)
        op: OperatingPoint | None = None
        if operating_point is not None and callable(trimmed_state):
            op = operating_point() if callable(operating_point) else operating_point
        # a trimmed run: the core starts in its steady state there (a DISCON core warmed up
        # on the trimmed plant), built once: a core's instance may hold a loaded library
        self.state: Any = (
            self.controller.initial_state() if op is None else trimmed_state(op)  # type: ignore[misc]
        )
        # casanovas-2014 cores take the plant's perfect wave preview (bench oracle) this way.
        self._accept_preview = getattr(self.controller, "accept_preview", None)
        self.preview_seq = -1  # seq of the newest preview handed to the core
        self.dt_s = scenario.timing.control_period_s
        self.period_ns = round(self.dt_s * 1e9)
        self.clock = clock
        self.last_seq = -1
        self.last_sample_time_ns = -1
        self.max_sample_time_ns = sample_time_limit_ns(scenario.duration_s)
        self.seq_window = seq_window(self.dt_s, scenario.timing.watchdog_misses)
        # A run of implausible frames: (its last seq, its last sample time ns, length).
        self._jump_run: tuple[int, int, int] | None = None
        self.command_seq = 0
        self.rejected: Counter[str] = Counter()
        self.accepted = 0
        self.log: Callable[[str], None] = log if log is not None else _no_log
        # Watchdog (module docstring): rule, counters and state.
        self.limits = actuator_limits(self.controller)
        self.watchdog_misses = scenario.timing.watchdog_misses
        self.watchdog_recover = scenario.timing.watchdog_recover_cycles
        self.paced = paced
        self.same_host_clock = same_host_clock
        self.consecutive_misses = 0
        self.healthy_run = 0
        self.safe_mode = False
        self.resuming = False
        self.safe_entries = 0
        self.safe_commands = 0
        #: Sample time at which the safe mode was first entered [ns] (-1: never).
        self.safe_first_entry_ns = -1
        self.frames_missing = 0
        self.frames_stale = 0
        self.silent_periods = 0
        self._silence_counted = 0
        self._paced_run = 0
        self._min_delay_ns: int | None = None
        self._last_publish_ns = -1
        self._last_receive_ns = -1
        # The last published command: (pitch rad, torque N m, its frame's sample time ns).
        self._last_command: tuple[float, float, int] | None = None
        # The core's first fault (hil.nodes.controller_fault; None: none) and the commands
        # flagged MODE_FAULT since; the pitch range a command must be in [rad].
        self.fault: ControllerFault | None = None
        self.fault_commands = 0
        self.frames_overdue = 0  # skipped by the node (overdue)
        self.last_compute_ns = 0  # the last cycle's time around the core's step [ns]
        self._pitch_lo = self.limits.pitch_min_rad - PITCH_TOLERANCE_RAD
        self._pitch_hi = self.limits.pitch_max_rad + PITCH_TOLERANCE_RAD
        self._restart_core = False

    # ------------------------------------------------------------ compiled loop
    def usual_path(self, seq: int) -> bool:
        """True when frame ``seq`` would take :meth:`handle_frame`'s usual path: not in or
        leaving the safe mode, no gap in the sequence, no pacing decision due (a compiled
        twin of the path may then run it; wall-clock checks are the caller's to rule out)."""
        if self.safe_mode or self.resuming or self._restart_core or self.fault is not None:
            return False
        if self.last_seq >= 0 and self.last_seq != seq - 1:
            return False  # a gap: the watchdog counts misses
        return not (self.paced is None and self._paced_run + 1 >= PACED_FRAMES)

    def counters(self) -> RuntimeCounters:
        """What :meth:`handle_frame`'s usual path reads and writes besides the core."""
        return RuntimeCounters(
            self.last_seq,
            self.last_sample_time_ns,
            self.accepted,
            self.command_seq,
            self.rejected_total,
            self._paced_run,
            self.paced is None,
            self._last_publish_ns,
            self._last_receive_ns,
            self.healthy_run,
        )

    def adopt_counters(
        self, c: RuntimeCounters, frames: int, last_command: tuple[float, float, int]
    ) -> None:
        """Take back :meth:`counters` after a compiled twin of the usual path handled
        ``frames`` frames (0: only the watchdog's pacing figures may have moved), the last
        of them answered with ``last_command`` (pitch rad, torque N m, sample time ns)."""
        self._paced_run = c.paced_run
        self._last_publish_ns = c.last_publish_ns
        self._last_receive_ns = c.last_receive_ns
        self.healthy_run = c.healthy_run
        if frames == 0:
            return
        self._silence_counted = 0
        self.consecutive_misses = 0
        self.last_seq = c.last_seq
        self.last_sample_time_ns = c.last_sample_time_ns
        self.accepted = c.accepted
        self.command_seq = c.command_seq
        self._last_command = last_command

    @property
    def rejected_total(self) -> int:
        """All rejected frames so far."""
        return sum(self.rejected.values())

    @property
    def wall_checks(self) -> bool:
        """True when the wall-clock checks (frame age, silence) apply now."""
        if self.paced is not None:
            return self.paced
        return self._paced_run >= PACED_FRAMES

    def handle_payload(self, payload: bytes) -> tuple[ActuatorCommand, ControllerStatus] | None:
        """Decode one payload and run a cycle; None (and a counted rejection) if unusable."""
        try:
            frame = SENSORS.codec.decode(payload)
        except DecodeError as exc:
            self.rejected[exc.reason] += 1
            return None
        return self.handle_frame(frame)

    def handle_preview_payload(self, payload: bytes) -> None:
        """Decode a :data:`bus_schemas.messages.WavePreviewPerfect` and hand it to the core.

        Only cores with ``accept_preview(state, seq, force_n)`` take it; an undecodable one is
        counted under ``rejected["preview_" + reason]``.
        """
        try:
            msg = WAVE_PREVIEW_PERFECT.codec.decode(payload)
        except DecodeError as exc:
            self.rejected["preview_" + exc.reason] += 1
            return
        self.handle_preview(msg)

    def handle_preview(self, msg: Any) -> None:
        """Hand a decoded perfect preview to the core (no-op for cores without one)."""
        if self._accept_preview is None:
            return
        force = np.array([getattr(msg, f) for f in WAVE_PREVIEW_FIELDS])
        self.state = self._accept_preview(self.state, msg.seq, force)
        self.preview_seq = max(self.preview_seq, int(msg.seq))

    @property
    def takes_preview(self) -> bool:
        """True when the core takes the perfect wave preview (``accept_preview``)."""
        return self._accept_preview is not None

    def handle_frame(self, frame: SensorFrame) -> tuple[ActuatorCommand, ControllerStatus] | None:
        """Run one control cycle on a decoded, range-checked frame.

        A frame whose ``seq`` is not newer than the last one (duplicate, replay, reordered)
        or whose sample time goes backwards is rejected: a controller must never step twice
        on one sample or on an older one. A frame with a non-finite value is rejected too
        (the bus codec already refuses them; this guards the in-process path). An accepted
        frame then goes through the watchdog (module docstring), which decides whether the
        command is the core's or the safe one. The status carries the core's estimates and
        ``compute_time_ns``, the injected clock's time around the core's step [ns].
        """
        if frame.seq <= self.last_seq:
            self.rejected["duplicate_or_reordered"] += 1
            return None
        # Before the first frame last_seq is -1: a run starts at seq 0 (module docstring).
        if frame.seq - self.last_seq > self.seq_window and not self._resync(frame):
            self.rejected["implausible_seq"] += 1
            return None
        if frame.sample_time_ns <= self.last_sample_time_ns:
            self.rejected["stale"] += 1
            return None
        # Plausible time: inside the run's window, and no further ahead of the last accepted
        # frame than its seq is (frame k is sampled at k periods, plus one period of slack).
        # A key holder's single far-future frame would otherwise make every genuine frame
        # after it "stale" and wedge the controller.
        ahead = frame.sample_time_ns - max(self.last_sample_time_ns, 0)
        if (
            frame.sample_time_ns > self.max_sample_time_ns
            or ahead > (frame.seq - self.last_seq + 1) * self.period_ns
        ):
            self.rejected["implausible_time"] += 1
            return None
        # One C-level sum instead of a check per field: a sum of finite floats of at most
        # ~1e8 each is finite, and any NaN or infinity makes it NaN or infinite.
        if not math.isfinite(sum(_float_values(frame))):
            self.rejected["non_finite"] += 1  # the codec refuses these; in-process frames too
            return None
        t0 = self.clock()
        self._watchdog(frame, t0)
        if self._restart_core:  # leaving the safe mode: restart from this measurement
            self._restart_core = False
            self.state = self.controller.initial_state()
        if self.fault is None:
            try:
                self.state, out = self.controller.step(self.state, frame, self.dt_s)
            except Exception as exc:  # the core's fault, never the process's (module docstring)
                out = self._core_fault(frame, "raised", repr(exc), "")
            else:
                p, q = out.blade_pitch_commanded_rad, out.generator_torque_commanded_nm
                # (NaN fails every comparison: one test for the usual cycle)
                if not (self._pitch_lo <= p <= self._pitch_hi and 0.0 <= q <= TORQUE_MAX_NM):
                    out = self._check_output(frame, out)
        else:
            out = self._faulted_output(frame)
        self.last_seq = frame.seq
        self._jump_run = None
        self.last_sample_time_ns = frame.sample_time_ns
        self.accepted += 1
        pitch, torque = out.blade_pitch_commanded_rad, out.generator_torque_commanded_nm
        regime = out.regime
        if self.fault is not None:  # the safe command, flagged: a plant never applies it
            mode = MODE_FAULT
            self.fault_commands += 1
        elif self.safe_mode:
            pitch, torque = self._safe_command(frame)
            mode, regime = MODE_SAFE, REGIME_SAFE
            self.safe_commands += 1
        elif self.resuming:
            pitch, torque, clamped = self._transfer(frame, pitch, torque)
            mode = MODE_RESUMING
            if not clamped:
                self.resuming = False
                mode = MODE_NORMAL
                self.log(
                    f"controller back to normal commands at t = "
                    f"{frame.sample_time_ns * 1e-9:.3f} s (bumpless transfer done)"
                )
        else:
            mode = MODE_NORMAL
        self._last_command = (pitch, torque, frame.sample_time_ns)
        now = self.clock()
        command = ActuatorCommand(
            seq=self.command_seq,
            answered_seq=frame.seq,
            sample_time_ns=frame.sample_time_ns,
            publish_time_ns=now,
            mode=mode,
            blade_pitch_commanded_rad=pitch,
            generator_torque_commanded_nm=torque,
        )
        rejected = self.rejected
        self.last_compute_ns = compute_ns = now - t0  # (overdue)
        # Positional: the status's fields after ``rejected_frames`` are the core output's
        # after ``regime``, in the same order (checked at import, _STATUS_TAIL_FROM); one
        # astuple and a positional call cost ~1.1 us less than 24 keywords.
        status = ControllerStatus(
            self.command_seq,  # seq
            frame.seq,  # answered_seq
            frame.sample_time_ns,  # sample_time_ns
            now,  # publish_time_ns
            compute_ns,  # compute_time_ns
            regime,  # regime
            sum(rejected.values()) if rejected else 0,  # rejected_frames (rejected_total)
            *_astuple(out)[_STATUS_TAIL_FROM:],
        )
        self.command_seq += 1
        return command, status

    def _resync(self, frame: SensorFrame) -> bool:
        """Extend the run of implausible frames with ``frame``; True once it is long enough
        to be a genuine resync (module docstring, sequence plausibility)."""
        run = self._jump_run
        if run is not None and frame.seq == run[0] + 1 and frame.sample_time_ns > run[1]:
            length = run[2] + 1
        else:
            length = 1
        if length >= RESYNC_FRAMES:
            self._jump_run = None
            self.log(
                f"controller resynchronised on seq {frame.seq} ({length} consistent frames "
                f"{frame.seq - self.last_seq} ahead of the last accepted seq {self.last_seq})"
            )
            return True
        self._jump_run = (frame.seq, frame.sample_time_ns, length)
        return False

    def overdue(self, frame: SensorFrame, now_ns: int) -> bool:
        """True when ``frame`` queued behind a core slower than the period: the last step
        took longer than a control period and the frame is older than
        :data:`OVERDUE_PERIODS` periods, while the wall-clock checks apply (real time, one
        host's clock). Its answer could only be late; the node skips it (the next frame's
        seq gap counts it as missing for the watchdog), so a slow core answers the newest
        frames instead of falling ever further behind. A frame late for another reason (a
        bus delay) with a core on time is stepped on as before (stale)."""
        if self.last_compute_ns <= self.period_ns or not self.wall_checks:
            return False
        return self.same_host_clock and (
            now_ns - frame.publish_time_ns > OVERDUE_PERIODS * self.period_ns
        )

    # ------------------------------------------------------------------ core faults
    def _check_output(self, frame: SensorFrame, out: ControlOutput) -> ControlOutput:
        """The core's output, or the faulted output when its command is non-finite or out
        of range (the pitch outside the core's own limits, the torque negative or above
        :data:`hil.nodes.controller_fault.TORQUE_MAX_NM`)."""
        for name in FAULT_FIELDS[1:]:
            v = getattr(out, name)
            if not math.isfinite(v):
                return self._core_fault(frame, "non_finite", f"{name} = {v!r}", name)
        p, q = out.blade_pitch_commanded_rad, out.generator_torque_commanded_nm
        lim = self.limits
        if not self._pitch_lo <= p <= self._pitch_hi:
            why = (
                f"blade_pitch_commanded_rad = {p:.6g} outside "
                f"[{lim.pitch_min_rad:.6g}, {lim.pitch_max_rad:.6g}] rad"
            )
            return self._core_fault(frame, "out_of_range", why, FAULT_FIELDS[1])
        if not 0.0 <= q <= TORQUE_MAX_NM:
            why = f"generator_torque_commanded_nm = {q:.6g} outside [0, {TORQUE_MAX_NM:g}] N m"
            return self._core_fault(frame, "out_of_range", why, FAULT_FIELDS[2])
        return out

    def _core_fault(self, frame: SensorFrame, kind: str, message: str, field: str) -> ControlOutput:
        """Keep the core's first fault, say it once, and answer with the faulted output.

        From now on the core is not stepped again (its state is not to be trusted after an
        exception or a non-finite output): every command is the safe command (pitch to
        feather, torque to 0, at the core's rate limits) flagged :data:`MODE_FAULT`.
        """
        self.fault = ControllerFault(
            kind=kind,
            message=message,
            t_s=frame.sample_time_ns * 1e-9,
            cycle=int(frame.seq),
            field=field,
            phase=self.phase,
        )
        self.log(
            f"controller FAULT: {self.fault.line()}; the core is not stepped again, its "
            f"commands are flagged as faulted (mode {MODE_FAULT}: pitch to feather, torque "
            "ramp-down) and the plant goes to its safe state"
        )
        return self._faulted_output(frame)

    def _faulted_output(self, frame: SensorFrame) -> ControlOutput:
        """The output after a fault: the safe command, no estimates (all finite)."""
        pitch, torque = self._safe_command(frame)
        return ControlOutput(pitch, torque, REGIME_SAFE, 0.0, 0.0, 0.0)

    # ------------------------------------------------------------------ watchdog
    def check_silence(self, now_ns: int | None = None) -> bool:
        """Count the control periods without a frame; called by the node's timer.

        Each period past the expected arrival of the next frame (the last one's arrival plus
        one period, plus half a period of grace) counts one miss, once. Does nothing before
        the first frame, in the safe mode, or while the wall-clock checks are off.

        Parameters
        ----------
        now_ns : int, optional
            The clock's time [ns] (None: read the clock).

        Returns
        -------
        bool
            True when this call put the runtime in its safe mode.
        """
        if self._last_receive_ns < 0 or self.safe_mode or not self.wall_checks:
            return False
        now = self.clock() if now_ns is None else now_ns
        silent = (now - self._last_receive_ns - self.period_ns // 2) // self.period_ns
        new = silent - self._silence_counted
        if new <= 0:
            return False
        self._silence_counted = silent
        self.silent_periods += new
        return self._miss(
            new,
            f"no sensor frame for {silent} control period(s)",
            self.last_seq,
            self.last_sample_time_ns + silent * self.period_ns,
        )

    def _watchdog(self, frame: SensorFrame, now_ns: int) -> None:
        """Classify an accepted frame (gap, stale, healthy) and apply the rule."""
        gap = frame.seq - self.last_seq - 1 if self.last_seq >= 0 else 0
        delay = now_ns - frame.publish_time_ns
        if not self.same_host_clock:
            if self._min_delay_ns is None or delay < self._min_delay_ns:
                self._min_delay_ns = delay
            delay -= self._min_delay_ns
        if gap == 0 and self._last_publish_ns >= 0:  # pacing: publish interval ~ one period
            interval = frame.publish_time_ns - self._last_publish_ns
            if abs(interval - self.period_ns) <= PACED_TOLERANCE * self.period_ns:
                self._paced_run += 1
            else:
                self._paced_run = 0
        self._last_publish_ns = frame.publish_time_ns
        self._last_receive_ns = now_ns
        tripped = False
        unseen = gap - self._silence_counted  # the silence timer counted some already
        self._silence_counted = 0
        if gap > 0:
            self.frames_missing += gap
        if unseen > 0:
            tripped = self._miss(
                unseen, f"{gap} sensor frame(s) missing", frame.seq, frame.sample_time_ns
            )
        if delay > self.period_ns and self.wall_checks:  # (the cheap test first)
            self.frames_stale += 1
            why = f"stale sensor frame ({delay * 1e-6:.1f} ms old)"
            tripped |= self._miss(1, why, frame.seq, frame.sample_time_ns)
            return
        self.consecutive_misses = 0
        if tripped or not self.safe_mode:
            self.healthy_run = 0 if tripped else self.healthy_run + 1
            return
        self.healthy_run += 1
        if 0 < self.watchdog_recover <= self.healthy_run:
            self.safe_mode = False
            self.resuming = True
            self._restart_core = True
            self.log(
                f"controller leaves its safe mode at t = {frame.sample_time_ns * 1e-9:.3f} s "
                f"after {self.healthy_run} healthy sensor frames: core restarted from the "
                "measurement, rate-limited transfer"
            )

    def _miss(self, n: int, why: str, seq: int, sample_ns: int) -> bool:
        """Count ``n`` missed frames; enter the safe mode at the limit (True if it did).

        ``sample_ns``: the simulated time of the miss [ns] (the safe mode's first entry).
        """
        self.consecutive_misses += n
        self.healthy_run = 0
        if (
            self.safe_mode
            or self.watchdog_misses <= 0
            or self.consecutive_misses < self.watchdog_misses
        ):
            return False
        self.safe_mode = True
        self.resuming = False
        self.safe_entries += 1
        if self.safe_first_entry_ns < 0:
            self.safe_first_entry_ns = max(0, sample_ns)
        self.log(
            f"controller SAFE MODE after {self.consecutive_misses} consecutive missing or stale "
            f"sensor frames ({why}; last seq {seq}): pitch to feather at "
            f"{self.limits.pitch_rate_max_rad_s:g} rad/s, torque ramp-down at "
            f"{self.limits.torque_rate_max_nm_s:g} N m/s, mode {MODE_SAFE}"
        )
        return True

    def _elapsed_s(self, frame: SensorFrame) -> float:
        """Simulated time since the last published command [s] (one period if none)."""
        if self._last_command is None:
            return self.dt_s
        return (frame.sample_time_ns - self._last_command[2]) * 1e-9

    def _previous_command(self, frame: SensorFrame) -> tuple[float, float]:
        """The last published command, or the measured actuator positions if none yet."""
        if self._last_command is not None:
            return self._last_command[0], self._last_command[1]
        lim = self.limits
        pitch = min(max(frame.blade_pitch_measured_rad, lim.pitch_min_rad), lim.pitch_max_rad)
        return pitch, max(frame.generator_torque_measured_nm, 0.0)

    def _safe_command(self, frame: SensorFrame) -> tuple[float, float]:
        """Pitch towards feather and torque towards 0, each at the core's rate limit."""
        lim = self.limits
        dt = self._elapsed_s(frame)
        pitch, torque = self._previous_command(frame)
        step = lim.pitch_rate_max_rad_s * dt
        feather = lim.pitch_max_rad
        pitch = min(pitch + step, feather) if pitch < feather else max(pitch - step, feather)
        torque = max(torque - lim.torque_rate_max_nm_s * dt, 0.0)
        return pitch, torque

    def _transfer(
        self, frame: SensorFrame, pitch: float, torque: float
    ) -> tuple[float, float, bool]:
        """Rate-limit the core's command against the last published one (bumpless return).

        Returns the command and whether either channel was clamped.
        """
        lim = self.limits
        dt = self._elapsed_s(frame)
        p0, q0 = self._previous_command(frame)
        dp, dq = lim.pitch_rate_max_rad_s * dt, lim.torque_rate_max_nm_s * dt
        p = min(max(pitch, p0 - dp), p0 + dp)
        q = min(max(torque, q0 - dq), q0 + dq)
        return p, q, (p != pitch or q != torque)


def publishing_step(
    runtime: ControllerRuntime, publish: Callable[[MessageType, msgspec.Struct], None]
) -> Callable[[SensorFrame], ActuatorCommand | None]:
    """The in-process controller cycle: ``runtime.handle_frame``, then its command and
    status to ``publish``; the command, or None for a rejected frame (nothing published)."""
    handle_frame = runtime.handle_frame

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        result = handle_frame(frame)
        if result is None:
            return None
        command, status = result
        publish(COMMAND, command)
        publish(CONTROLLER_STATUS, status)
        return command

    return step


def controller_report(
    runtime: ControllerRuntime,
    commands_published: int,
    statuses_published: int,
    *,
    aborted: bool,
    seq: int = 0,
) -> msgspec.Struct:
    """The controller's end-of-run :class:`bus_schemas.messages.ControllerReport`.

    Parameters
    ----------
    runtime : ControllerRuntime
        Its counters: frames accepted, safe mode, watchdog, rejections by reason.
    commands_published, statuses_published : int
        Commands and status messages handed to the bus (or the in-process log).
    aborted : bool
        True when a signal stopped the controller before the plant's end.
    seq : int
        The report's sequence number (one report per controller process: 0).
    """
    rt = runtime
    return ControllerReport(
        seq=seq,
        sample_time_ns=max(0, rt.last_sample_time_ns),
        publish_time_ns=time.monotonic_ns(),
        final=1,
        aborted=int(aborted),
        frames_accepted=rt.accepted,
        commands_published=commands_published,
        statuses_published=statuses_published,
        safe_mode=int(rt.safe_mode),
        safe_mode_entries=rt.safe_entries,
        safe_mode_commands=rt.safe_commands,
        safe_mode_first_entry_ns=max(0, rt.safe_first_entry_ns),
        frames_missing=rt.frames_missing,
        frames_stale=rt.frames_stale,
        **rejection_fields(rt.rejected, "frames_rejected", CONTROLLER_REJECT_REASONS),
        **fault_fields(rt.fault, rt.fault_commands),
    )


def fault_fields(fault: ControllerFault | None, commands: int) -> dict[str, int]:
    """The ``core_fault*`` fields of a :class:`ControllerReport` (all 0: no fault)."""
    if fault is None:
        return {
            "core_fault": 0,
            "core_fault_seq": 0,
            "core_fault_time_ns": 0,
            "core_fault_field": 0,
            "core_fault_commands": 0,
        }
    return {
        "core_fault": FAULT_CODES[fault.kind],
        "core_fault_seq": fault.cycle,
        "core_fault_time_ns": max(0, round(fault.t_s * 1e9)),
        "core_fault_field": FAULT_FIELDS.index(fault.field),
        "core_fault_commands": commands,
    }


def _no_log(_msg: str) -> None:
    """Discard a log line (the runtime's default logger)."""


@dataclass
class ControllerNodeResult:
    """What the controller process did, for its exit report."""

    cycles: int
    rejected: dict[str, int]
    reason: str
    safe_entries: int = 0
    safe_commands: int = 0
    frames_missing: int = 0
    frames_stale: int = 0


def feedforward_notice(scenario: Scenario) -> list[tuple[str, str]]:
    """What to say at the start of an ``lqri_ff`` run about its wave feedforward.

    The feedforward acts only once the wave forecast is valid, i.e. after the forecaster's
    fill time (:func:`controller.runtime.forecast_fill_time_s`, 204.6 s for the shipped
    IEA 15 MW preset). Returns ``[(level, line), ...]``: an ``"info"`` line with that time
    and, when the run is not longer, a ``"warning"`` that the feedforward never acts. Empty
    for the other controllers.
    """
    c = scenario.controller
    if c.kind != "lqri_ff":
        return []
    from controller.runtime import (  # noqa: PLC0415 - only the advanced kinds need it
        forecast_fill_time_s,
        load_advanced_settings,
    )

    waves = scenario.waves
    fill = forecast_fill_time_s(
        load_advanced_settings(c.preset),
        c.forecaster,
        waves.gauge_distance_m if waves is not None else None,
    )
    out = [("info", f"lqri_ff: feedforward active from t = {fill:.1f} s (wave forecast filled)")]
    if scenario.duration_s <= fill:
        out.append(
            (
                "warning",
                f"the run is {scenario.duration_s:g} s, not longer than the forecast fill time "
                f"{fill:.1f} s: the wave feedforward never acts in it",
            )
        )
    return out


def run_controller_node(
    scenario: Scenario,
    bus_config: BusConfig,
    timeout_s: float | None = None,
    log: Callable[[str], None] = print,
    bus_factory: Callable[[BusConfig], Any] = Bus,
    await_recorder_s: float = 0.0,
    operating_point: Callable[[], OperatingPoint | None] | None = None,
) -> ControllerNodeResult:
    """Serve commands until the plant's final summary, a signal, or ``timeout_s``.

    ``operating_point``: a trimmed run's operating point, computed once the core is built
    and only for a core with ``trimmed_state`` (:class:`ControllerRuntime`).

    ``await_recorder_s`` > 0: the controller announces itself (its liveliness token, which
    the plant waits for) only once the run's recorder answers its hello
    (:func:`hil.nodes.bus.await_recorder`: a signed nonce back, in an authenticated run;
    else any subscription reaching its status key), waiting at most that many seconds
    (then it says so and announces itself anyway); a signal ends the wait at once.
    ``fowt run`` asks for it: without it a plant may start while the recorder's link to the
    controller is still being made, and the first cycles' statuses would be lost.

    The design artefacts are looked up in the shipped designs and in ``$FOWT_DESIGN_DIR``
    (the launcher sets it to the cache it designed into). When one is missing for the
    scenario's control period the process exits at once (``SystemExit``, status 1) with a
    message naming the ``fowt design ... --control-period ...`` command to run: the
    controller process never designs (that would import ``plant``).

    The sensor-frame watchdog (module docstring) logs through ``log``; its silence check
    runs in this (the main) thread every half control period while waiting. The frame age is
    exact (one host's monotonic clock) unless ``bus_config`` has a Zenoh config file, which
    may join two hosts: then it is relative to the fastest delivery seen.
    """
    try:
        runtime = ControllerRuntime(
            scenario,
            same_host_clock=bus_config.config_file is None,
            log=log,
            operating_point=operating_point,
        )
    except (DesignNotFoundError, DisconError) as exc:
        raise SystemExit(f"error: {exc}") from exc
    except ValueError as exc:  # e.g. a malformed DISCON.IN: the message names it
        raise SystemExit(f"error: controller {scenario.controller.kind!r}: {exc}") from exc
    for level, line in feedforward_notice(scenario):
        log(f"{level}: {line}" if level != "info" else line)
    # ``bus_factory``: a Zenoh Bus, or a CAN run's HybridBus (sensors and commands on CAN,
    # the rest on Zenoh) with the same surface, so this loop runs unchanged over either.
    # No full garbage collection walking the set-up's objects mid-run; done before the
    # subscriptions, so a controller restarted into a running plant answers at once.
    freeze_heap()
    bus = bus_factory(bus_config)
    tid = scenario.turbine_id
    cmd_pub = bus.publisher(COMMAND.key(tid))
    # The status is log-only (nobody waits for it): it goes out a few per put on the batch
    # key (hil.nodes.bus.LogBatcher), so a cycle costs one put (the command) and wakes the
    # recorder once instead of twice. A full or old (50 ms) batch goes right after a
    # cycle's command; the main thread's poll below puts one that frames stopped coming to
    # (twice as old), the last one goes when the node stops.
    statuses = LogBatcher(bus.publisher(batch_key(tid, CONTROLLER_BATCH_SUFFIX)))
    report_pub = bus.publisher(CONTROLLER_REPORT.key(tid))
    commands = [0]  # commands put (the report's count)
    done = threading.Event()
    reason = ["timeout"]
    lock = threading.Lock()

    put_failed: list[Exception] = []
    # The run's folder (the launcher's $FOWT_RUN_DIR) takes a core fault's text.
    run_dir_env = os.environ.get("FOWT_RUN_DIR", "").strip()
    fault_dir = Path(run_dir_env) if run_dir_env and Path(run_dir_env).is_dir() else None
    # A core that takes the perfect wave preview waits for the preview of its frame: the two
    # keys are delivered by Zenoh without a mutual order, so a frame that arrives first is
    # held (at most half a control period, then it runs on the last preview, which the core
    # counts as stale).
    wants_preview = scenario.controller.preview == "perfect" and runtime.takes_preview
    pending: list[tuple[SensorFrame, float]] = []

    def cycle(frame: SensorFrame) -> None:
        had_fault = runtime.fault is not None
        result = runtime.handle_frame(frame)
        if not had_fault and runtime.fault is not None and fault_dir is not None:
            write_fault(fault_dir, runtime.fault)  # the fault's text beside the run's file
        if result is None:
            return
        command, status = result
        try:
            cmd_pub.put(COMMAND.codec.encode(command))
            commands[0] += 1
            statuses.add(CONTROLLER_STATUS.codec.encode(status))
            if statuses.due():
                statuses.flush()
        except zenoh.ZError as exc:
            # The session is closing (the run's end): nothing more goes out. During the
            # run it is said once, never as a traceback.
            if not done.is_set() and not put_failed:
                log(f"controller: a command did not go out ({exc})")
            put_failed.append(exc)

    def on_frame(_key: str, payload: bytes) -> None:
        if done.is_set():  # the run is over: frames still queued are not stepped on
            return
        with lock:  # one cycle at a time, whatever thread Zenoh calls us from
            if done.is_set():
                return
            try:
                frame = SENSORS.codec.decode(payload)
            except DecodeError as exc:
                runtime.rejected[exc.reason] += 1
                return
            if runtime.overdue(frame, time.monotonic_ns()):
                # Frames queued behind a core slower than the period: stepping on each would
                # put the controller ever further behind (and keep the final summary queued
                # behind them); the next frame shows the gap, which the watchdog counts.
                runtime.frames_overdue += 1
                return
            if wants_preview and runtime.preview_seq < frame.seq:
                if pending:  # a newer frame: the held one goes now
                    cycle(pending.pop()[0])
                pending.append((frame, time.monotonic()))
                return
            cycle(frame)

    def on_frame_rejected(exc: DecodeError) -> None:  # a failed tag: counted, never decoded
        with lock:
            runtime.rejected[exc.reason] += 1

    def on_summary(_key: str, payload: bytes) -> None:
        try:
            summary = TIMING_SUMMARY.codec.decode(payload)
        except DecodeError:
            return
        if summary.final:
            reason[0] = "plant finished"
            done.set()

    signalled = threading.Event()  # a signal, also one after the run's end

    def on_signal(signum: int) -> None:  # from a thread, never in a handler (hil.nodes.signals)
        reason[0] = f"signal {signal.Signals(signum).name}"
        done.set()
        signalled.set()

    on_stop_signals(on_signal)

    def on_preview(_key: str, payload: bytes) -> None:
        with lock:
            runtime.handle_preview_payload(payload)
            if pending and runtime.preview_seq >= pending[0][0].seq:
                cycle(pending.pop()[0])

    if scenario.controller.preview == "perfect":
        bus.subscribe(WAVE_PREVIEW_PERFECT.key(tid), on_preview)
    bus.subscribe(SENSORS.key(tid), on_frame, on_frame_rejected)
    bus.subscribe(TIMING_SUMMARY.key(tid), on_summary)
    if await_recorder_s > 0:
        log(f"controller: waiting up to {await_recorder_s:g} s for the recorder")
    if (
        await_recorder_s > 0
        and not await_recorder(bus, statuses.publisher, tid, await_recorder_s, done)
        and not done.is_set()
    ):
        log(
            f"controller: no recorder reached its status key within {await_recorder_s:g} s; "
            "announcing itself anyway (what it publishes before one does is not recorded)"
        )
    # Declared after the subscriptions (and, with a recorder, once it can be reached): a
    # plant that waits for this token finds the controller's whole path in place.
    token = bus.session.liveliness().declare_token(f"fowt/{tid}/alive/controller")

    def on_plant_liveliness(sample: zenoh.Sample) -> None:
        # The plant's token goes away when it exits or is killed (Zenoh sees its session
        # drop). A normal end sends the final summary first; a killed plant never will, so
        # without this the controller would wait for ever.
        if sample.kind == zenoh.SampleKind.DELETE and not done.is_set():
            reason[0] = "plant gone (its liveliness token disappeared)"
            done.set()

    plant_watch = bus.session.liveliness().declare_subscriber(
        f"fowt/{tid}/alive/plant", on_plant_liveliness
    )
    log(
        f"controller {scenario.controller.kind}/{scenario.controller.preset} ready on "
        f"{SENSORS.key(tid)} ({bus_config.describe()})"
    )
    poll_s = max(runtime.dt_s / 2, 1e-3)
    end = math.inf if timeout_s is None else time.monotonic() + timeout_s
    try:
        while not done.wait(min(poll_s, max(0.0, end - time.monotonic()))):
            if time.monotonic() >= end:
                break
            with lock:
                runtime.check_silence()
                if pending and time.monotonic() - pending[0][1] > runtime.dt_s / 2:
                    cycle(pending.pop()[0])
                if statuses.age_s() > 2 * statuses.max_age_ns / 1e9:
                    statuses.flush()
    finally:
        with lock:
            statuses.flush()  # the statuses first: the report counts them as published
            report = controller_report(
                runtime,
                commands[0],
                statuses.messages,
                aborted=reason[0].startswith("signal"),
            )
            try:
                report_pub.put(CONTROLLER_REPORT.codec.encode(report))
            except Exception as exc:  # the session going away: said, never silent
                log(f"controller: its report did not go out ({exc})")
        if statuses.failed:
            log(f"controller: {statuses.failed} status batches failed to go out")
        # Open until the recorder holds what it published (hil.nodes.bus.wait_for_recorder).
        # A signal that ended the run does not skip this wait; one during it ends it.
        signalled.clear()
        if wait_for_recorder(bus.session, tid, "controller", stop=signalled) == "timeout":
            log("controller: the recorder did not confirm it holds its messages; closing anyway")
        plant_watch.undeclare()
        token.undeclare()
        bus.close()
    rt = runtime
    log(
        f"controller stopped ({reason[0]}): {rt.accepted} cycles, rejected {dict(rt.rejected)}; "
        f"watchdog: {rt.frames_missing} frames missing, {rt.frames_stale} stale, "
        f"{rt.silent_periods} silent periods, safe mode entered {rt.safe_entries} times "
        f"({rt.safe_commands} safe commands)"
        + (", in safe mode at the end" if rt.safe_mode else "")
        + (f"; {rt.frames_overdue} overdue frames skipped" if rt.frames_overdue else "")
        + (f"; core FAULT: {rt.fault.line()}" if rt.fault is not None else "")
    )
    return ControllerNodeResult(
        rt.accepted,
        dict(rt.rejected),
        reason[0],
        rt.safe_entries,
        rt.safe_commands,
        rt.frames_missing,
        rt.frames_stale,
    )
