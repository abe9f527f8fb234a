"""The compiled in-process loop's Python side: when it may run, its bundles in and out.

:func:`hil.inprocess.run.run_inprocess` with ``loop="compiled"`` (or ``"auto"`` when
:func:`compiled_unsupported` finds nothing against it) runs :class:`CompiledLoop`: batches
of cycles in :func:`hil.inprocess.kernels.run_cycles`, and every cycle the kernel hands back
through today's path (:meth:`PlantLoop.sample`, the runtime's ``handle_frame``,
:meth:`PlantLoop.finish_cycle`).

The kernel takes six bundles (named tuples of arrays), each built by its owner through its
public API: the plant simulator's (:meth:`plant.simulator.PlantSimulator.state_bundle`) and
the sensor suite's (:attr:`sensors.channel.SensorSuite.state_bundle`) are their storage,
advanced in place; the controller core's (``kernel_bundle``) and its wave forecast's
(``AdvancedController.forecast_bundle``, the dispersion forecaster's ring buffer in place)
are built by the core, which reads the cycles' end state back (``state_from_bundle(s)``);
the loop's own counters (:class:`hil.inprocess.kernels.LoopBundle`) take the plant loop's
and controller runtime's bookkeeping before a batch (:meth:`ControllerRuntime.counters`,
:meth:`PlantLoop.summary_counters`) and give it back after
(:meth:`ControllerRuntime.adopt_counters`, :meth:`PlantLoop.adopt_cycles`), so the Python
path (and the run's end) finds exactly what the Python loop would have left after the same
cycles.

What runs in Python instead (:func:`compiled_unsupported`, each for its reason):

* bus faults (the sensor link's and command channel's delays, drops and reorders: a
  per-message schedule in Python objects) and the perfect wave preview (a bench oracle
  published before each frame, for the casanovas-2014 cores, themselves Python);
* the bottom-fixed plant (the kernel composes the floating plant's truth and period only),
  sensor faults (:class:`sensors.faults.FaultSchedule`, Python per channel), channels
  without a true value in the truth record, an analytic wind (a Python function per step);
* a controller runtime with an injected clock, or with the wall-clock watchdog checks on
  (frame age, silence: a paced or cross-host run, real time, where speed is not the point);
* the controller kinds other than ``baseline``, ``lqri`` and ``lqri_ff``: ``rosco`` (the
  DISCON shared library, called through ctypes with its own files: no kernel can call it),
  ``lqr_wave`` (christiansen-2013) and the casanovas-2014 kinds (``no_control``,
  ``base_torque``, ``lqr_*``; they take the perfect preview): Python cores whose steps are
  not numba kernels. Compiling a core's step (as for the baseline and the advanced cores)
  and giving it a ``kernel_bundle`` is the way to bring it in; until then those runs take
  the Python loop (about 4x the CPU per cycle, still hundreds of times real time).

Inside a compiled run, Python still takes single cycles the kernel stops for
(:data:`hil.inprocess.kernels.STOP_REASONS`): the first frame of an advanced core (it starts
its filters), a gap, the safe mode, a pacing decision, a fault event, a non-finite frame, the
AR and ESPRIT forecasters' updates (:meth:`AdvancedController.forecast_update`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import msgspec
import numba
import numpy as np

from bus_schemas import CycleTiming, SensorFrame
from bus_schemas.messages import (
    VALID_GENERATOR_SPEED,
    VALID_ROTOR_SPEED,
    VALID_WAVE_GAUGE,
)
from bus_schemas.registry import (
    COMMAND,
    CONTROLLER_STATUS,
    CYCLE_TIMING,
    SENSORS,
    TIMING_SUMMARY,
    TRUTH,
    MessageType,
)
from controller._kernels import FF_SIZE, FI_SIZE, ForecastBundle
from controller.baseline import BaselineController
from controller.runtime import AdvancedController
from hil.inprocess import kernels as lk
from hil.nodes import timing
from hil.nodes.controller_node import RuntimeCounters

if TYPE_CHECKING:
    from hil.nodes.controller_node import ControllerRuntime
    from hil.nodes.plant_node import PlantLoop

#: ``publish_block(order, rows)`` of :class:`hil.runlog.writer.BackgroundRunLog`.
PublishBlock = Callable[[np.ndarray, dict[int, np.ndarray]], None]
#: Cycles per kernel call at most (the running summaries are written inside a batch).
BATCH = 1024
_TYPES: tuple[MessageType, ...] = (
    SENSORS,
    COMMAND,
    TRUTH,
    CONTROLLER_STATUS,
    CYCLE_TIMING,
    TIMING_SUMMARY,
)
_BY_ID = {mt.message_id: mt for mt in _TYPES}
if [mt.message_id for mt in _TYPES] != [
    lk.MID_SENSORS,
    lk.MID_COMMAND,
    lk.MID_TRUTH,
    lk.MID_STATUS,
    lk.MID_TIMING,
    lk.MID_SUMMARY,
]:
    raise ImportError("hil.inprocess.kernels.MID_* must be the registry's message ids")
if (lk.H_BINS_PER_DECADE, lk.H_MIN_NS, lk.H_N_BINS) != (
    timing.BINS_PER_DECADE,
    timing.MIN_NS,
    timing.N_BINS,
):
    raise ImportError("hil.inprocess.kernels.H_* must be hil.nodes.timing's histogram constants")
#: (message id, its row count in ist) of the kernel's rows.
_ROW_COUNTS = (*zip(
    (lk.MID_SENSORS, lk.MID_COMMAND, lk.MID_TRUTH, lk.MID_STATUS, lk.MID_TIMING),
    lk.I_COUNTS,
    strict=True,
), (lk.MID_SUMMARY, lk.I_N_SUMMARY))  # fmt: skip
#: Positions in the kernel's arguments (CompiledLoop._args) of the bundles whose arrays a
#: run may replace (the plant state and wave table, the suite's ring buffers, the forecast's).
_REPLACEABLE = (3, 4, 5, 6)


def _no_forecast() -> ForecastBundle:
    """The forecast bundle of a core without a forecaster (the baseline)."""
    return ForecastBundle(
        np.zeros(0),
        np.zeros(0, dtype=np.bool_),
        np.zeros(0),
        np.zeros(FI_SIZE, dtype=np.int64),
        np.zeros(FF_SIZE),
    )


def compiled_unsupported(loop: PlantLoop, runtime: ControllerRuntime | None) -> str | None:
    """Why the compiled loop cannot run this scenario (None: it can; the module docstring
    says why each case stays in Python)."""
    if runtime is None:
        return "no controller runtime given"
    if loop.bus_faults:
        return "bus faults"
    if loop.has_preview or runtime.takes_preview:
        return "perfect wave preview"
    reason = loop.sim.compiled_unsupported()
    if reason is not None:
        return reason
    if runtime.clock is not time.monotonic_ns:
        return "controller runtime with an injected clock"
    if runtime.paced is True or not runtime.same_host_clock:
        return "wall-clock watchdog checks on"
    ctrl = runtime.controller
    if isinstance(ctrl, AdvancedController | BaselineController):
        return None
    return f"controller {type(ctrl).__name__}"


def rows_to_structs(
    order: np.ndarray, rows: dict[int, np.ndarray]
) -> list[tuple[MessageType, Any]]:
    """The messages of a block as (type, Struct) in publish order (for a plain ``publish``)."""
    out: list[tuple[MessageType, Any]] = []
    seen = dict.fromkeys(rows, 0)
    lists = {mid: r.tolist() for mid, r in rows.items()}
    for mid in order.tolist():
        i = seen[mid]
        seen[mid] = i + 1
        mt = _BY_ID[mid]
        if mid == lk.MID_SUMMARY:  # (keyword-only fields)
            names = mt.cls.__struct_fields__
            out.append((mt, mt.cls(**dict(zip(names, lists[mid][i], strict=True)))))
        else:
            out.append((mt, mt.cls(*lists[mid][i])))
    return out


def _array_key(a: Any) -> tuple[Any, ...] | None:
    """What numba's type of ``a`` depends on, if ``a`` is a plain ndarray (else None)."""
    if type(a) is not np.ndarray:
        return None
    flags = a.flags
    return (a.dtype, a.ndim, flags.c_contiguous, flags.f_contiguous, flags.writeable)


def _bundle_key(b: tuple[Any, ...]) -> tuple[Any, ...] | None:
    """:func:`_array_key` of every array of a bundle (None if one is not a plain ndarray)."""
    keys = tuple(_array_key(a) for a in b)
    return None if None in keys else keys


class CompiledLoop:
    """Runs an in-process run's cycles in batches (module docstring).

    Parameters
    ----------
    loop : PlantLoop
        The run's plant loop (its ``publish`` gets the Python path's messages).
    runtime : ControllerRuntime
        The controller runtime ``step_controller`` drives.
    step_controller : callable
        The Python path's controller cycle (publishes command and status).
    publish_block : callable, optional
        Takes each batch's rows (:data:`PublishBlock`); None: the rows are published as
        Structs through ``loop.publish``.
    """

    def __init__(
        self,
        loop: PlantLoop,
        runtime: ControllerRuntime,
        step_controller: Callable[[SensorFrame], Any],
        publish_block: PublishBlock | None = None,
    ) -> None:
        self.loop = loop
        self.runtime = runtime
        self.step_controller = step_controller
        self.publish_block = publish_block
        self.batches = 0
        self.kernel_cycles = 0
        self.python_cycles = 0
        self.summaries = 0  # running summaries the kernel wrote
        self._stops: dict[int, int] = {}
        self._kernel: Any = None
        self._sig: tuple[Any, ...] = ()
        self._keys: dict[int, tuple[Any, ...] | None] = {}
        sim = loop.sim
        suite = sim.channels
        assert suite is not None
        self.suite = suite
        self.bundle = lk.LoopBundle(
            np.zeros(lk.I_SIZE, dtype=np.int64),
            np.zeros(lk.F_SIZE),
            np.zeros(9, dtype=np.int64),
            # The latency histogram's counts while the kernel records into them
            # (hist_in_kernel; PlantLoop.hist gets them back before Python needs it).
            np.zeros(lk.H_N_BINS, dtype=np.int64),
        )
        ist, fst = self.bundle.ist, self.bundle.fst
        ist[lk.I_PERIOD_NS] = loop.period_ns
        ist[lk.I_SUMMARY_EVERY] = loop.summary_every
        ist[lk.I_N_STEPS] = sim.n
        ist[lk.I_GEN_MASK_ROTOR] = VALID_GENERATOR_SPEED
        ist[lk.I_ROTOR_BIT] = VALID_ROTOR_SPEED
        ist[lk.I_GAUGE_BIT] = VALID_WAVE_GAUGE
        fst[lk.F_H] = sim.h
        fst[lk.F_EFF] = sim.params.generator_efficiency
        fst[lk.F_GEAR] = sim.params.gearbox_ratio
        fst[lk.F_DT] = runtime.dt_s
        ctrl = runtime.controller
        assert isinstance(ctrl, AdvancedController | BaselineController)
        self.ctrl = ctrl
        self.advanced = isinstance(ctrl, AdvancedController)
        self.core = ctrl.kernel_bundle(runtime.state, runtime.dt_s)
        self.forecast = (
            ctrl.forecast_bundle(runtime.state)
            if isinstance(ctrl, AdvancedController)
            else _no_forecast()
        )
        self.hist_in_kernel = False
        cap = 6 * BATCH + 1
        order = np.zeros(cap, dtype=np.uint8)
        self.buf = {
            mt.message_id: np.zeros((BATCH + 1, len(mt.row_dtype.names or ()))) for mt in _TYPES
        }
        self.ibuf = {mid: b.view(np.int64) for mid, b in self.buf.items()}
        self.dtypes = {mt.message_id: mt.row_dtype for mt in _TYPES}
        b, ib = self.buf, self.ibuf
        self.rows = lk.RowsBundle(
            order, b[1], ib[1], b[2], ib[2], b[3], ib[3], b[4], ib[4], b[5], ib[5], b[6], ib[6]
        )
        # Load the kernels (numba's on-disk cache, ~0.05-0.3 s) now, before the run's clock
        # starts: the plant's for the cycles Python runs (on a copy of the simulator:
        # PlantSimulator.warm_up), and this loop's (a call that stops before its first
        # cycle, limit 0, changes nothing).
        sim.warm_up(loop.x, loop.applied)
        self._pull(loop.k + 1)
        lk_reason = self._call(0, limit=0)
        assert lk_reason == lk.STOP_LIMIT
        self._bind_kernel()
        self.batches = 0
        self._stops = {}

    # ------------------------------------------------------------------ state in / out
    def _ready(self) -> bool:
        """True when the next cycle may start in the kernel (else Python runs it)."""
        loop, rt = self.loop, self.runtime
        if loop.safe_state or not rt.usual_path(loop.k):
            return False
        if loop.t_ns >= loop.next_fault_event_ns:
            return False
        if self.advanced and not rt.state.flags[0]:
            return False  # the first frame starts the filters (Python)
        return loop.sim.waves_in_step(loop.t_ns * 1e-9)

    def _pull(self, cycles: int) -> None:
        loop, rt = self.loop, self.runtime
        ist, fst = self.bundle.ist, self.bundle.fst
        ist[lk.I_K] = loop.k
        ev = loop.next_fault_event_ns
        k_event = -(-ev // loop.period_ns) if ev < 2**62 else cycles
        ist[lk.I_K_END] = min(cycles, k_event)
        c = rt.counters()
        ist[lk.I_LAST_SEQ] = c.last_seq
        ist[lk.I_LAST_SAMPLE_NS] = c.last_sample_time_ns
        ist[lk.I_ACCEPTED] = c.accepted
        ist[lk.I_COMMAND_SEQ] = c.command_seq
        ist[lk.I_REJECTED_TOTAL] = c.rejected_total
        ist[lk.I_PACED_RUN] = c.paced_run
        ist[lk.I_PACED] = -1 if c.detect_pacing else 0
        ist[lk.I_LAST_PUBLISH_NS] = c.last_publish_ns
        ist[lk.I_LAST_RECEIVE_NS] = c.last_receive_ns
        ist[lk.I_HEALTHY_RUN] = c.healthy_run
        ist[lk.I_P_ON_TIME_RUN] = loop.on_time_run
        ist[lk.I_FRAME_SENT_NS] = loop.frame_sent_ns
        pt = loop.pending_timing
        ist[lk.I_PENDING] = 0
        if pt is not None:
            self.bundle.pending[:] = msgspec.structs.astuple(pt)
            ist[lk.I_PENDING] = 1
        fst[lk.F_APPLIED_PITCH], fst[lk.F_APPLIED_TORQUE] = loop.applied
        if not self.hist_in_kernel:
            self._hist_to_kernel()
        # what a running summary reads besides the histogram (PlantLoop.publish_summary)
        ist[lk.I_SUMMARY_SEQ] = loop.summary_seq
        ist[lk.I_START_WALL_NS] = loop.start_wall_ns
        (
            ist[lk.I_R_MISSES],
            ist[lk.I_R_HELD],
            ist[lk.I_R_REJECTED],
            ist[lk.I_R_LATE],
            ist[lk.I_R_SAFE_CYCLES],
            ist[lk.I_R_FAULTS],
        ) = loop.summary_counters()
        ctrl = self.ctrl
        ctrl.load_bundle(self.core, rt.state)
        if isinstance(ctrl, AdvancedController):
            self.forecast = ctrl.forecast_bundle(rt.state)
        ist[lk.I_N_ORDER] = 0
        for i in lk.I_COUNTS:
            ist[i] = 0
        ist[lk.I_N_SUMMARY] = 0
        self._check_kernel_types()

    def _hist_to_kernel(self) -> None:
        """The plant loop's latency histogram into the kernel's copy (Python recorded last)."""
        counts, n, max_ns, lo, hi = self.loop.hist.bins()
        ist = self.bundle.ist
        self.bundle.hist[:] = counts
        ist[lk.I_H_N], ist[lk.I_H_MAX], ist[lk.I_H_LO], ist[lk.I_H_HI] = n, max_ns, lo, hi
        self.hist_in_kernel = True

    def _hist_to_python(self) -> None:
        """The kernel's latency histogram back into the plant loop's (before Python records
        or reads it: a cycle Python runs, the run's end)."""
        if not self.hist_in_kernel:
            return
        ist = self.bundle.ist
        self.loop.hist.set_bins(
            self.bundle.hist.tolist(),
            int(ist[lk.I_H_N]),
            int(ist[lk.I_H_MAX]),
            int(ist[lk.I_H_LO]),
            int(ist[lk.I_H_HI]),
        )
        self.hist_in_kernel = False

    def _push(self, k0: int) -> None:
        loop, rt = self.loop, self.runtime
        ist, fst = self.bundle.ist, self.bundle.fst
        k = int(ist[lk.I_K])
        done = k - k0
        loop.frame_sent_ns = int(ist[lk.I_FRAME_SENT_NS])
        counters = RuntimeCounters(
            int(ist[lk.I_LAST_SEQ]),
            int(ist[lk.I_LAST_SAMPLE_NS]),
            int(ist[lk.I_ACCEPTED]),
            int(ist[lk.I_COMMAND_SEQ]),
            int(ist[lk.I_REJECTED_TOTAL]),
            int(ist[lk.I_PACED_RUN]),
            bool(ist[lk.I_PACED] < 0),
            int(ist[lk.I_LAST_PUBLISH_NS]),
            int(ist[lk.I_LAST_RECEIVE_NS]),
            int(ist[lk.I_HEALTHY_RUN]),
        )
        last_command = (
            float(fst[lk.F_LAST_CMD_PITCH]),
            float(fst[lk.F_LAST_CMD_TORQUE]),
            int(ist[lk.I_LAST_CMD_NS]),
        )
        rt.adopt_counters(counters, done, last_command)
        pending = self.bundle.pending
        loop.pending_timing = CycleTiming(*pending.tolist()) if ist[lk.I_PENDING] else None
        if done == 0:
            return
        self.kernel_cycles += done
        applied = (float(fst[lk.F_APPLIED_PITCH]), float(fst[lk.F_APPLIED_TORQUE]))
        loop.adopt_cycles(k, int(ist[lk.I_P_ON_TIME_RUN]), applied)
        ctrl = self.ctrl
        if isinstance(ctrl, AdvancedController):
            rt.state = ctrl.state_from_bundles(rt.state, self.core, self.forecast)
        else:
            rt.state = ctrl.state_from_bundle(self.core)
        n_summary = int(ist[lk.I_N_SUMMARY])
        if n_summary:  # what publish_summary leaves besides the message
            self.summaries += n_summary
            loop.adopt_summaries(
                int(ist[lk.I_SUMMARY_SEQ]), float(fst[lk.F_WALL_S]), float(fst[lk.F_SIM_S])
            )

    # ------------------------------------------------------------------ rows out
    def _publish_rows(self) -> None:
        ist = self.bundle.ist
        n = int(ist[lk.I_N_ORDER])
        if n == 0:
            return
        order = self.rows.order[:n]
        rows = {}
        for mid, idx in _ROW_COUNTS:
            c = int(ist[idx])
            if c:
                rows[mid] = self.buf[mid][:c].view(self.dtypes[mid]).ravel()
        if self.publish_block is not None:
            self.publish_block(order, rows)
        else:
            publish = self.loop.publish
            for mt, msg in rows_to_structs(order, rows):
                publish(mt, msg)

    # ------------------------------------------------------------------ the run
    def _args(self, resume: int, limit: int) -> tuple[Any, ...]:
        """The kernel's arguments: the caller's two ints and the six bundles (the plant's
        and the suite's taken from them now: their arrays are their storage)."""
        return (
            limit,
            resume,
            self.bundle,
            self.loop.sim.state_bundle(self.loop.x),
            self.suite.state_bundle,
            self.core,
            self.forecast,
            self.rows,
        )

    def _bind_kernel(self) -> None:
        """Call the kernel's compiled entry point for this run's argument types directly.

        numba's dispatcher types every argument on every call (about 9 us for the arrays of
        these bundles; the entry point of the matching compiled signature about 5 us). The
        types are those of the limit-0 call just made through the dispatcher, and stay so
        for the run (the bundles are the run's own, and the arrays a run may replace keep
        dtype and layout).
        """
        kernel = lk.run_cycles
        overloads = getattr(kernel, "overloads", None)  # (a wrapped kernel: benchmarks)
        if overloads is None:
            return
        args = self._args(0, 0)
        sig = tuple(numba.typeof(a) for a in args)
        cres = overloads.get(sig)
        if cres is not None:
            self._kernel = cres.entry_point
            self._sig = sig
            self._keys = {i: _bundle_key(args[i]) for i in _REPLACEABLE}

    def _check_kernel_types(self) -> None:
        """Before a batch: the bundles whose arrays may be replaced during a run (the plant
        state and wave table, the suite's ring buffers, the forecast's) still have the
        bound types, else the dispatcher takes over (an entry point does not check its
        arguments' types).

        An array's numba type is a function of what :func:`_array_key` reads (numba's
        ``typeof`` of an ndarray: dtype, dimensions, layout, writeable); where a bundle's
        keys differ from the bound ones, ``numba.typeof`` decides (about 10 us an array,
        against 0.3 us for the key).
        """
        if self._kernel is None:
            return
        args = self._args(0, 0)
        keys = self._keys
        for i in _REPLACEABLE:
            key = _bundle_key(args[i])
            if key is not None and key == keys[i]:
                continue
            if numba.typeof(args[i]) != self._sig[i]:
                self._kernel = None
                return

    @property
    def stops(self) -> dict[str, int]:
        """How often the kernel stopped for each reason (STOP_REASONS), and under
        ``summary`` how many running summaries it wrote (in its batches: no stop)."""
        out: dict[str, int] = {}
        for bits, n in self._stops.items():
            for bit, name in lk.STOP_REASONS.items():
                if bits & bit:
                    out[name] = out.get(name, 0) + n
        if self.summaries:
            out["summary"] = self.summaries
        return out

    def _call(self, resume: int, limit: int = BATCH) -> int:
        kernel = self._kernel if self._kernel is not None else lk.run_cycles
        reason = int(kernel(*self._args(resume, limit)))
        self.batches += 1
        self._stops[reason] = self._stops.get(reason, 0) + 1
        return reason

    def _last_frame(self) -> SensorFrame:
        j = int(self.bundle.ist[lk.I_N_SENSORS]) - 1
        row = self.buf[lk.MID_SENSORS][j : j + 1].view(self.dtypes[lk.MID_SENSORS])
        return SensorFrame(*row.ravel().tolist()[0])

    def _forecast(self) -> None:
        """The forecaster's update of AdvancedController.step on cycle k's frame."""
        rt = self.runtime
        ctrl = self.ctrl
        assert isinstance(ctrl, AdvancedController)
        j = int(self.bundle.ist[lk.I_N_SENSORS]) - 1
        row = self.buf[lk.MID_SENSORS][j]
        mask = int(self.ibuf[lk.MID_SENSORS][j, 3])
        t_ns = int(self.ibuf[lk.MID_SENSORS][j, 1])
        rt.state = ctrl.with_forecast(rt.state, t_ns, float(row[14]), bool(mask & VALID_WAVE_GAUGE))
        self.forecast = ctrl.forecast_bundle(rt.state)

    def _python_cycle(self) -> None:
        self._hist_to_python()
        loop = self.loop
        clock = time.monotonic_ns
        frame = loop.sample()
        t0 = clock()
        command = self.step_controller(frame)
        loop.finish_cycle(command, clock() - t0, at_arrival=False)
        self.python_cycles += 1

    def run(
        self,
        cycles: int,
        stopped: Callable[[], bool] | None = None,
        progress: Callable[[], None] | None = None,
    ) -> None:
        """Run the plant loop's cycles up to ``cycles`` (the run's end), or until
        ``stopped()`` is true when a batch is to start (a signal asked the run to end);
        ``progress()`` is called before each batch (it looks at the clock and says how far
        the run is now and then: :class:`hil.inprocess.run.Progress`)."""
        loop = self.loop
        suite = self.suite
        clock = time.monotonic_ns
        while loop.k < cycles:
            if stopped is not None and stopped():
                break
            if progress is not None:
                progress()
            if not self._ready():
                self._python_cycle()
                continue
            k0 = loop.k
            self._pull(cycles)
            reason = self._call(0)
            while reason & lk.STOP_FORECAST:
                if reason & lk.STOP_REFILL:
                    suite.refill()
                self._forecast()
                # the same batch's rows go on: at most BATCH cycles in all, cycle k included
                reason = self._call(1, BATCH - (int(self.bundle.ist[lk.I_K]) - k0))
            self._push(k0)
            self._publish_rows()
            if reason & lk.STOP_REFILL:
                suite.refill()
            if reason & lk.STOP_FRAME:  # Python's handle_frame decides on this frame
                self._hist_to_python()
                frame = self._last_frame()
                t0 = clock()
                command = self.step_controller(frame)
                loop.finish_cycle(command, clock() - t0, at_arrival=False)
                self.python_cycles += 1
            if reason & lk.STOP_BEFORE:
                self._python_cycle()
        self._hist_to_python()
