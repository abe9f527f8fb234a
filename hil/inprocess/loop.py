"""The compiled in-process loop's Python side: when it may run, its state in and out.

:func:`hil.inprocess.run.run_inprocess` with ``loop="compiled"`` (or ``"auto"`` when
:func:`compiled_unsupported` finds nothing against it) runs :class:`CompiledLoop`: batches
of cycles in :func:`hil.inprocess.kernels.run_cycles`, and every cycle the kernel hands back
through today's path (:meth:`PlantLoop.sample`, the runtime's ``handle_frame``,
:meth:`PlantLoop.finish_cycle`). Before a batch the state the kernel needs is read from the
plant loop, its simulator and sensor suite, the controller runtime and its core; after it
everything the kernel changed is written back, so the Python path (and the run's end)
finds exactly what the Python loop would have left after the same cycles.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import msgspec
import numba
import numpy as np

from bus_schemas import CycleTiming, SensorFrame
from bus_schemas.messages import (
    EST_WIND_SPEED,
    VALID_GENERATOR_SPEED,
    VALID_PLATFORM_PITCH_RATE,
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
from controller._kernels import BL_STATE_SIZE
from controller.baseline import BaselineController, BaselineState
from controller.forecast import DispersionPredictor
from controller.runtime import AdvancedController
from hil.inprocess import kernels as lk
from hil.nodes import timing as _timing

if TYPE_CHECKING:
    from hil.nodes.controller_node import ControllerRuntime
    from hil.nodes.plant_node import PlantLoop

#: ``publish_block(order, rows)`` of :class:`hil.runlog.writer.BackgroundRunLog`.
PublishBlock = Callable[[np.ndarray, dict[int, np.ndarray]], None]
#: Positions in the kernel's arguments (CompiledLoop._args) of arrays a run may replace:
#: the plant state, wave table, ring buffers, the core's state copies, the forecaster's buffers.
_REPLACEABLE = (6, 8, 17, 18, 24, 25, 26, 27, 45, 46)
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
    _timing._BINS_PER_DECADE,
    _timing._MIN_NS,
    _timing._N_BINS,
):
    raise ImportError("hil.inprocess.kernels.H_* must be hil.nodes.timing's histogram constants")
#: (message id, its row count in ist) of the kernel's rows.
_ROW_COUNTS = (*zip(
    (lk.MID_SENSORS, lk.MID_COMMAND, lk.MID_TRUTH, lk.MID_STATUS, lk.MID_TIMING),
    lk._I_COUNT,
    strict=True,
), (lk.MID_SUMMARY, lk.I_N_SUMMARY))  # fmt: skip


def compiled_unsupported(loop: PlantLoop, runtime: ControllerRuntime | None) -> str | None:
    """Why the compiled loop cannot run this scenario (None: it can)."""
    if runtime is None:
        return "no controller runtime given"
    sim = loop.sim
    if loop.bus_faults:
        return "bus faults"
    if loop._preview is not None or runtime.takes_preview:
        return "perfect wave preview"
    if sim.floating is None:
        return "bottom-fixed plant"
    if sim._faulty:
        return "sensor faults"
    if sim.channels is None or sim._channel_values is None:
        return "sensor channels without a true value in the truth record"
    if not sim._wind_table.size:
        return "wind without a sampled record"
    if runtime.clock is not time.monotonic_ns:
        return "controller runtime with an injected clock"
    if runtime.paced is True or not runtime.same_host_clock:
        return "wall-clock watchdog checks on"
    ctrl = runtime.controller
    if isinstance(ctrl, AdvancedController):
        if runtime.dt_s != ctrl.dt_s:
            return "advanced controller at another period than its design"
        return None
    if isinstance(ctrl, BaselineController):
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
        self.ist = np.zeros(lk.I_SIZE, dtype=np.int64)
        self.fst = np.zeros(lk.F_SIZE)
        self.pending = np.zeros(9, dtype=np.int64)
        ist, fst = self.ist, self.fst
        ist[lk.I_PERIOD_NS] = loop.period_ns
        ist[lk.I_SUMMARY_EVERY] = loop._summary_every
        ist[lk.I_N_STEPS] = sim.n
        ist[lk.I_GEN_MASK_ROTOR] = VALID_GENERATOR_SPEED
        ist[lk.I_ROTOR_BIT] = VALID_ROTOR_SPEED
        fst[lk.F_H] = sim.h
        fst[lk.F_EFF] = sim._efficiency
        fst[lk.F_GEAR] = sim._gearbox
        fst[lk.F_DT] = runtime.dt_s
        ctrl = runtime.controller
        self.advanced = isinstance(ctrl, AdvancedController)
        ist[lk.I_KIND] = 1 if self.advanced else 0
        empty = np.zeros(0)
        if self.advanced:
            assert isinstance(ctrl, AdvancedController)
            self.cc, self.lay = ctrl._c, ctrl._lay
            ist[lk.I_STEPS] = ctrl._steps_at_dt
            self.bl, self.gs, self.n_gs = empty, empty, 0
            # the dispersion forecaster runs in the kernel; AR and ESPRIT stop it (Python)
            fc = ctrl.forecaster
            self.fc_kernel = type(fc) is DispersionPredictor
            if isinstance(fc, DispersionPredictor):
                # its taps oldest first, as step dots them; a writeable copy (the same
                # kernel signature as the empty array of the other kinds)
                self.fir = np.array(fc.fir[::-1], dtype=np.float64, order="C")
            ist[lk.I_FC_KIND] = 1 if self.fc_kernel else 0
            ist[lk.I_FC_PERIOD_NS] = ctrl._forecast_period_ns
            ist[lk.I_FC_HORIZON_NS] = ctrl._horizon_ns
            ist[lk.I_MASK_FC] = ctrl._mask_forecast
            ist[lk.I_MASK_NO_FC] = ctrl._mask_no_forecast
            ist[lk.I_GAUGE_BIT] = VALID_WAVE_GAUGE
        else:
            assert isinstance(ctrl, BaselineController)
            self.bl, self.gs, self.n_gs = ctrl.kernel_arrays()
            # the TSR-tracking law's wind EKF: its constants and Cp table in cc, and in lay
            # the status's estimate bit, the four lengths (prm, TSR, pitch, cells) and the
            # valid bit of the platform pitch rate
            if ctrl.ekf is not None:
                prm, tsr, pitch, cells = ctrl.ekf._tables
                self.cc = np.concatenate([prm, tsr, pitch, cells.ravel()])
                self.lay = np.array(
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
                self.cc, self.lay = empty, np.zeros(6, dtype=np.int64)
            self.fc_kernel = False
        if not self.fc_kernel:
            self.fir = np.zeros(0)
        self.fc_buf = np.zeros(0)
        self.fc_drop = np.zeros(0, dtype=np.bool_)
        self.bst = np.zeros(BL_STATE_SIZE)
        self.bst2 = np.zeros(BL_STATE_SIZE)
        # The latency histogram's counts while the kernel records into them (hist_in_kernel;
        # PlantLoop.hist gets them back before Python needs it: _hist_to_python).
        self.hist = np.zeros(lk.H_N_BINS, dtype=np.int64)
        self.hist_in_kernel = False
        cap = 6 * BATCH + 1
        self.order = np.zeros(cap, dtype=np.uint8)
        self.buf = {
            mt.message_id: np.zeros((BATCH + 1, len(mt.row_dtype.names or ()))) for mt in _TYPES
        }
        self.ibuf = {mid: b.view(np.int64) for mid, b in self.buf.items()}
        self.dtypes = {mt.message_id: mt.row_dtype for mt in _TYPES}
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
        if loop.safe_state or rt.safe_mode or rt.resuming or rt._restart_core:
            return False
        if rt.last_seq >= 0 and rt.last_seq != loop.k - 1:
            return False  # a gap: the watchdog counts misses (Python)
        if loop.t_ns >= loop._next_fault_event_ns:
            return False
        if self.advanced and not rt.state.flags[0]:
            return False  # the first frame starts the filters (Python)
        if rt.paced is None and rt._paced_run + 1 >= lk.PACED_FRAMES:
            return False
        sim = loop.sim
        t_s = loop.t_ns * 1e-9
        return not (
            sim._has_waves and abs(sim._wave_t0 + sim._wave_n * (0.5 * sim.h) - t_s) > 0.25 * sim.h
        )

    def _pull(self, cycles: int) -> None:
        loop, rt, sim = self.loop, self.runtime, self.loop.sim
        ist, fst = self.ist, self.fst
        ist[lk.I_K] = loop.k
        ev = loop._next_fault_event_ns
        k_event = -(-ev // loop.period_ns) if ev < 2**62 else cycles
        ist[lk.I_K_END] = min(cycles, k_event)
        ist[lk.I_LAST_SEQ] = rt.last_seq
        ist[lk.I_LAST_SAMPLE_NS] = rt.last_sample_time_ns
        ist[lk.I_ACCEPTED] = rt.accepted
        ist[lk.I_COMMAND_SEQ] = rt.command_seq
        ist[lk.I_REJECTED_TOTAL] = rt.rejected_total
        ist[lk.I_PACED_RUN] = rt._paced_run
        ist[lk.I_PACED] = -1 if rt.paced is None else 0
        ist[lk.I_LAST_PUBLISH_NS] = rt._last_publish_ns
        ist[lk.I_LAST_RECEIVE_NS] = rt._last_receive_ns
        ist[lk.I_HEALTHY_RUN] = rt.healthy_run
        ist[lk.I_P_ON_TIME_RUN] = loop.on_time_run
        ist[lk.I_FRAME_SENT_NS] = loop.frame_sent_ns
        pt = loop._pending_timing
        ist[lk.I_PENDING] = 0
        if pt is not None:
            self.pending[:] = msgspec.structs.astuple(pt)
            ist[lk.I_PENDING] = 1
        fst[lk.F_APPLIED_PITCH], fst[lk.F_APPLIED_TORQUE] = loop.applied
        if not self.hist_in_kernel:
            self._hist_to_kernel()
        # what a running summary reads besides the histogram (PlantLoop.publish_summary)
        r = loop.result
        ist[lk.I_SUMMARY_SEQ] = loop.summary_seq
        ist[lk.I_START_WALL_NS] = loop.start_wall_ns
        ist[lk.I_R_MISSES] = r.deadline_misses
        ist[lk.I_R_HELD] = r.commands_held
        inbox = loop._inbox
        ist[lk.I_R_REJECTED] = (
            sum(inbox.rejected.values()) if inbox is not None else r.commands_rejected
        )
        ist[lk.I_R_LATE] = r.commands_late
        ist[lk.I_R_SAFE_CYCLES] = r.safe_state_cycles
        ist[lk.I_R_FAULTS] = sum(loop.count_faults(inbox).values())
        self.xa = sim._state_array(loop.x)
        if self.advanced:
            st = rt.state
            self.cv = st.values.copy()
            self.cf = st.flags.copy()
            self.cv2 = np.empty_like(self.cv)
            self.cf2 = np.empty_like(self.cf)
            self._set_forecast(st)
        else:
            bs = rt.state
            ist[lk.I_BL_FIRST] = 1 if bs.first_call else 0
            self.bst[:] = (
                bs.lpf_z1,
                bs.lpf_z2,
                bs.generator_speed_filtered_rad_s,
                bs.pitch_speed_error_integral_rad,
                bs.torque_speed_error_integral_rad,
                bs.blade_pitch_commanded_rad,
                bs.generator_torque_commanded_nm,
                bs.wind_filtered_m_s,
                bs.setpoint_shift_rad_s,
                bs.min_pitch_rad,
                *bs.wind_ekf_x,
                *bs.wind_ekf_p,
                bs.fl_hpf_lp,
                bs.fl_lpf_z1,
                bs.fl_lpf_z2,
                bs.platform_pitch_rate_rad_s,
            )
            self.cv, self.cv2 = np.zeros(0), np.zeros(0)
            self.cf, self.cf2 = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        ist[lk.I_N_ORDER] = 0
        for i in lk._I_COUNT:
            ist[i] = 0
        ist[lk.I_N_SUMMARY] = 0
        self._check_kernel_types()

    def _hist_to_kernel(self) -> None:
        """The plant loop's latency histogram into the kernel's copy (Python recorded last)."""
        h, ist = self.loop.hist, self.ist
        self.hist[:] = h.counts
        ist[lk.I_H_N] = h.n
        ist[lk.I_H_MAX] = h.max_ns
        ist[lk.I_H_LO] = h._lo
        ist[lk.I_H_HI] = h._hi
        self.hist_in_kernel = True

    def _hist_to_python(self) -> None:
        """The kernel's latency histogram back into the plant loop's (before Python records
        or reads it: a cycle Python runs, the run's end)."""
        if not self.hist_in_kernel:
            return
        h, ist = self.loop.hist, self.ist
        h.counts = self.hist.tolist()
        h.n = int(ist[lk.I_H_N])
        h.max_ns = int(ist[lk.I_H_MAX])
        h._lo = int(ist[lk.I_H_LO])
        h._hi = int(ist[lk.I_H_HI])
        self.hist_in_kernel = False

    def _set_forecast(self, st: Any) -> None:
        """The forecast part of the advanced core's state as AdvancedController.step reads it."""
        ctrl = self.runtime.controller
        assert isinstance(ctrl, AdvancedController)
        ist, fst = self.ist, self.fst
        fstate = st.forecaster
        ok = fstate.filled and math.isfinite(st.forecast_m)
        ist[lk.I_NEXT_FC_NS] = st.next_forecast_ns
        fst[lk.F_ETA] = float(st.forecast_m) if ok else math.nan
        if ok:
            ist[lk.I_EST_MASK] = ctrl._mask_forecast
            fst[lk.F_FC_M] = st.forecast_m
            ist[lk.I_FC_NS] = st.forecast_time_ns
        else:
            ist[lk.I_EST_MASK] = ctrl._mask_no_forecast
            fst[lk.F_FC_M] = 0.0
            ist[lk.I_FC_NS] = 0
        ist[lk.I_UNSTABLE] = fstate.unstable_fits
        ist[lk.I_GUARDED] = fstate.guarded
        if self.fc_kernel:  # the kernel's forecaster works on this state (arrays in place)
            self.fc_buf = fstate.buffer
            self.fc_drop = fstate.drop_flags
            ist[lk.I_FC_HEAD] = fstate.head
            ist[lk.I_FC_COUNT] = fstate.count
            ist[lk.I_FC_CALLS] = fstate.calls
            ist[lk.I_FC_DROPPED] = fstate.dropped
            ist[lk.I_FC_DROPPED_WIN] = fstate.dropped_in_window
            ist[lk.I_FC_TIME_NS] = st.forecast_time_ns
            fst[lk.F_FC_HELD] = fstate.held_m
            fst[lk.F_FC_RAW] = st.forecast_m

    def _push(self, k0: int) -> None:
        loop, rt, sim = self.loop, self.runtime, self.loop.sim
        ist, fst = self.ist, self.fst
        k = int(ist[lk.I_K])
        done = k - k0
        loop.frame_sent_ns = int(ist[lk.I_FRAME_SENT_NS])
        rt._paced_run = int(ist[lk.I_PACED_RUN])
        rt._last_publish_ns = int(ist[lk.I_LAST_PUBLISH_NS])
        rt._last_receive_ns = int(ist[lk.I_LAST_RECEIVE_NS])
        rt.healthy_run = int(ist[lk.I_HEALTHY_RUN])
        loop._pending_timing = CycleTiming(*self.pending.tolist()) if ist[lk.I_PENDING] else None
        if done == 0:
            return
        self.kernel_cycles += done
        rt._silence_counted = 0
        rt.consecutive_misses = 0
        loop.k = k
        loop.result.cycles = k
        loop.consecutive_misses = 0
        loop.on_time_run = int(ist[lk.I_P_ON_TIME_RUN])
        loop.applied = (float(fst[lk.F_APPLIED_PITCH]), float(fst[lk.F_APPLIED_TORQUE]))
        y = tuple(self.xa.tolist())
        sim._x_tuple = y
        sim._truth_of_rec = None
        loop.x = y
        sim._wave_n += 2 * sim.n * done
        rt.last_seq = int(ist[lk.I_LAST_SEQ])
        rt.last_sample_time_ns = int(ist[lk.I_LAST_SAMPLE_NS])
        rt.accepted = int(ist[lk.I_ACCEPTED])
        rt.command_seq = int(ist[lk.I_COMMAND_SEQ])
        rt._last_command = (
            float(fst[lk.F_LAST_CMD_PITCH]),
            float(fst[lk.F_LAST_CMD_TORQUE]),
            int(ist[lk.I_LAST_CMD_NS]),
        )
        if self.advanced:
            st = rt.state
            fstate = st.forecaster
            if self.fc_kernel and int(ist[lk.I_FC_CALLS]) != fstate.calls:
                # the kernel's forecaster calls (buffer and drop flags changed in place)
                fstate.head = int(ist[lk.I_FC_HEAD])
                fstate.count = int(ist[lk.I_FC_COUNT])
                fstate.calls = int(ist[lk.I_FC_CALLS])
                fstate.held_m = float(fst[lk.F_FC_HELD])
                fstate.dropped = int(ist[lk.I_FC_DROPPED])
                fstate.dropped_in_window = int(ist[lk.I_FC_DROPPED_WIN])
                rt.state = st._replace(
                    values=self.cv,
                    flags=self.cf,
                    next_forecast_ns=int(ist[lk.I_NEXT_FC_NS]),
                    forecast_m=float(fst[lk.F_FC_RAW]),
                    forecast_time_ns=int(ist[lk.I_FC_TIME_NS]),
                )
            else:
                rt.state = st._replace(values=self.cv, flags=self.cf)
        else:
            b = self.bst.tolist()
            rt.state = BaselineState(
                False,
                b[0],
                b[1],
                b[2],
                b[3],
                b[4],
                b[5],
                b[6],
                b[7],
                b[8],
                b[9],
                (b[10], b[11], b[12]),
                (b[13], b[14], b[15], b[16], b[17], b[18]),
                b[19],
                b[20],
                b[21],
                b[22],
            )
        n_summary = int(ist[lk.I_N_SUMMARY])
        if n_summary:  # what publish_summary leaves besides the message
            self.summaries += n_summary
            loop.summary_seq = int(ist[lk.I_SUMMARY_SEQ])
            r = loop.result
            r.wall_s, r.sim_s = float(fst[lk.F_WALL_S]), float(fst[lk.F_SIM_S])
            loop.count_faults(loop._inbox)

    # ------------------------------------------------------------------ rows out
    def _publish_rows(self) -> None:
        ist = self.ist
        n = int(ist[lk.I_N_ORDER])
        if n == 0:
            return
        order = self.order[:n]
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
        sim = self.loop.sim
        ch = sim.channels
        assert ch is not None
        return (
            limit, resume, self.ist, self.fst, self.pending, self.hist,
            self.xa, sim._s, sim._wc, sim._c, sim._o, sim._wind_table, sim._truth_rec,
            sim._channel_fields,
            ch._f, ch._i, ch._ok, ch._hist_t, ch._hist_v, ch._rn, sim._slots, sim._record,
            self.cc, self.lay, self.cv, self.cf, self.cv2, self.cf2,
            self.bl, self.gs, self.n_gs, self.bst, self.bst2,
            self.order,
            self.buf[1], self.ibuf[1], self.buf[2], self.ibuf[2], self.buf[3], self.ibuf[3],
            self.buf[4], self.ibuf[4], self.buf[5], self.ibuf[5],
            self.fc_buf, self.fc_drop, self.fir, self.buf[6], self.ibuf[6],
        )  # fmt: skip

    def _bind_kernel(self) -> None:
        """Call the kernel's compiled entry point for this run's argument types directly.

        numba's dispatcher types every argument on every call (about 9 us for these 48;
        the entry point of the matching compiled signature about 5 us). The types are those
        of the limit-0 call just made through the dispatcher, and stay so for the run (the
        arrays are the run's own, and the per-batch copies keep dtype and layout).
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
            self._keys = {i: _array_key(args[i]) for i in _REPLACEABLE}

    def _check_kernel_types(self) -> None:
        """Before a batch: the arrays that may be replaced during a run (the state, the
        core's copies, the wave table, the ring buffers) still have the bound types, else
        the dispatcher takes over (an entry point does not check its arguments' types).

        An array's numba type is a function of what :func:`_array_key` reads (numba's
        ``typeof`` of an ndarray: dtype, dimensions, layout, writeable); where that differs
        from the bound one's, or for anything but a plain ndarray, ``numba.typeof``
        decides (about 10 us an array, against 0.3 us for the key).
        """
        if self._kernel is None:
            return
        args = self._args(0, 0)
        keys = self._keys
        for i in _REPLACEABLE:
            a = args[i]
            key = _array_key(a)
            if key is not None and key == keys[i]:
                continue
            if numba.typeof(a) != self._sig[i]:
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
        j = int(self.ist[lk.I_N_SENSORS]) - 1
        row = self.buf[lk.MID_SENSORS][j : j + 1].view(self.dtypes[lk.MID_SENSORS])
        return SensorFrame(*row.ravel().tolist()[0])

    def _forecast(self) -> None:
        """The forecaster's update of AdvancedController.step on cycle k's frame."""
        rt = self.runtime
        ctrl = rt.controller
        assert isinstance(ctrl, AdvancedController)
        j = int(self.ist[lk.I_N_SENSORS]) - 1
        row = self.buf[lk.MID_SENSORS][j]
        mask = int(self.ibuf[lk.MID_SENSORS][j, 3])
        t_ns = int(self.ibuf[lk.MID_SENSORS][j, 1])
        st = rt.state
        fstate, next_ns, forecast_m, forecast_ns = ctrl.forecast_update(
            st, t_ns, float(row[14]), bool(mask & VALID_WAVE_GAUGE)
        )
        rt.state = st._replace(
            forecaster=fstate,
            next_forecast_ns=next_ns,
            forecast_m=forecast_m,
            forecast_time_ns=forecast_ns,
        )
        self._set_forecast(rt.state)

    def _python_cycle(self) -> None:
        self._hist_to_python()
        loop = self.loop
        clock = time.monotonic_ns
        frame = loop.sample()
        t0 = clock()
        command = self.step_controller(frame)
        loop.finish_cycle(command, clock() - t0, at_arrival=False)
        self.python_cycles += 1

    def run(self, cycles: int, stopped: Callable[[], bool] | None = None) -> None:
        """Run the plant loop's cycles up to ``cycles`` (the run's end), or until
        ``stopped()`` is true when a batch is to start (a signal asked the run to end)."""
        loop = self.loop
        sim = loop.sim
        ch = sim.channels
        assert ch is not None
        clock = time.monotonic_ns
        while loop.k < cycles:
            if stopped is not None and stopped():
                break
            if not self._ready():
                self._python_cycle()
                continue
            k0 = loop.k
            self._pull(cycles)
            reason = self._call(0)
            while reason & lk.STOP_FORECAST:
                if reason & lk.STOP_REFILL:
                    ch._refill()
                self._forecast()
                # the same batch's rows go on: at most BATCH cycles in all, cycle k included
                reason = self._call(1, BATCH - (int(self.ist[lk.I_K]) - k0))
            self._push(k0)
            self._publish_rows()
            if reason & lk.STOP_REFILL:
                ch._refill()
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
