"""Compiled in-process loop: several control cycles per call (numba, cached on disk).

The in-process loop (:func:`hil.inprocess.run.run_inprocess`) calls, per 25 ms cycle, the
plant's truth and sensor kernels, the controller runtime's checks, the controller core's
kernel, the plant's period kernel and five publishes, with Python between them (about 40 us
of glue per cycle against about 17 us of kernels). :func:`run_cycles` composes the same
kernels, in the same order and with the same arithmetic, for up to ``limit`` cycles in one
call, and writes each cycle's messages as rows (:attr:`bus_schemas.registry.MessageType.
row_dtype`) for :meth:`hil.runlog.writer.BackgroundRunLog.publish_block`:

1. the truth record (:func:`plant._kernels.floating_truth_into`) and the sensor frame
   (:func:`sensors._kernels.suite_step`; its random blocks are refilled by the caller
   between calls, as :meth:`sensors.channel.SensorSuite.step_into` does), stamped with
   the monotonic clock;
2. the controller runtime's frame checks and watchdog bookkeeping
   (:meth:`hil.nodes.controller_node.ControllerRuntime.handle_frame`, usual path: no gap, no
   rejection, wall-clock checks off as in every in-process run);
3. the core: :func:`controller._kernels.advanced_cycle` (``lqri``, ``lqri_ff``) or
   :func:`controller._kernels.baseline_step` (``baseline``);
4. the plant's watchdog bookkeeping and period (:func:`plant._kernels.advance_floating`),
   the cycle's timing record, its latency in the histogram (:func:`hist_record`) and,
   every simulated second, the running timing summary as a row at its place in the
   publish order (:func:`_summary_row`, ``PlantLoop.publish_summary``).

The wave forecaster's update (every ``sample_period_s``, after the runtime's checks) runs
here for the dispersion forecaster (:func:`controller._kernels.dispersion_forecast`,
``fb.fi[FI_KIND]`` = 1).
It returns before anything that needs Python (:data:`STOP_REASONS`): the update of another
forecaster (AR, ESPRIT: the caller runs it and resumes the same cycle with ``resume`` = 1),
a non-finite frame, a sensor suite that needs
Python, a random block to refill, the caller's limit. Wall
clock stamps are real: :func:`monotonic_ns` reads ``CLOCK_MONOTONIC`` through
``clock_gettime``, the clock of ``time.monotonic_ns``.

State: :func:`run_cycles` takes six bundles (named tuples of arrays, attribute access in
compiled code), each built and owned by its component: the loop's own counters
(:class:`LoopBundle`: ``ist`` int64 and ``fst`` float64, indices ``I_*`` and ``F_*``
below), the plant's (:class:`plant._kernels.PlantBundle`), the sensor suite's
(:class:`sensors._kernels.SuiteBundle`), the controller core's and its forecast's
(:class:`controller._kernels.CoreBundle`, :class:`~controller._kernels.ForecastBundle`)
and the rows (:class:`RowsBundle`).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple, cast

import llvmlite.binding as llvm  # type: ignore[import-untyped]
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from bus_schemas.jit import key_cache_by, njit
from controller._kernels import (
    CI_FIRST,
    CI_KIND,
    CI_N_GS,
    CI_STEPS,
    FF_ETA,
    FF_STATUS_M,
    FI_EST_MASK,
    FI_GUARDED,
    FI_KIND,
    FI_NEXT_NS,
    FI_STATUS_NS,
    FI_UNSTABLE,
    CoreBundle,
    ForecastBundle,
    advanced_cycle,
    baseline_step,
    dispersion_forecast,
)
from plant._kernels import (
    TRUTH_FIELDS,
    TRUTH_FLOATING,
    PlantBundle,
    advance_floating,
    floating_truth_into,
)
from sensors._kernels import SuiteBundle, suite_step

#: The kernels' sources composed by :func:`run_cycles` (its cache key includes them, so a
#: change there recompiles it: numba alone keys a cache by the function's own file).
_CALLEE_FILES = tuple(
    Path(__file__).resolve().parents[2] / name / "_kernels.py"
    for name in ("plant", "sensors", "controller")
)
key_cache_by(__file__, _CALLEE_FILES)

# clock_gettime by name: the cached machine code refers to the symbol, bound here in every
# process (so the kernel stays cacheable, unlike a ctypes pointer baked in as a constant).
_libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=False)
llvm.add_symbol("clock_gettime", ctypes.cast(_libc.clock_gettime, ctypes.c_void_p).value or 0)
_CLOCK_MONOTONIC = 1  # Linux <time.h>; time.monotonic_ns reads the same clock


@intrinsic
def _clock_intrinsic(typingctx: Any) -> Any:
    """CLOCK_MONOTONIC in ns: clock_gettime into a stack timespec, s * 10^9 + ns."""
    sig = types.int64()

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        i32, i64 = ir.IntType(32), ir.IntType(64)
        ts_t = ir.LiteralStructType([i64, i64])
        fnty = ir.FunctionType(i32, [i32, ts_t.as_pointer()])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "clock_gettime")
        ts = cgutils.alloca_once(builder, ts_t)
        builder.call(fn, [ir.Constant(i32, _CLOCK_MONOTONIC), ts])
        sec = builder.load(cgutils.gep_inbounds(builder, ts, 0, 0))
        nsec = builder.load(cgutils.gep_inbounds(builder, ts, 0, 1))
        return builder.add(builder.mul(sec, ir.Constant(i64, 1_000_000_000)), nsec)

    return sig, codegen


_clock_ns = cast(Callable[[], int], _clock_intrinsic)


@njit
def monotonic_ns() -> int:
    """``time.monotonic_ns()`` from compiled code (CLOCK_MONOTONIC, ns)."""
    return _clock_ns()


@njit
def clock_reads(n: int) -> int:
    """Read the clock ``n`` times (its cost per read: bench); returns the last reading."""
    t = 0
    for _ in range(n):
        t = _clock_ns()
    return t


# ---- message ids (bus_schemas.registry) and the int state ist -----------------------------
MID_SENSORS, MID_COMMAND, MID_TRUTH, MID_STATUS, MID_TIMING, MID_SUMMARY = 1, 2, 3, 4, 5, 6

(
    I_K,  # plant cycle k (the next one to run)
    I_PERIOD_NS,
    I_K_END,  # stop before this cycle (run end, fault event)
    I_SUMMARY_EVERY,
    I_N_STEPS,
    I_LAST_SEQ,
    I_LAST_SAMPLE_NS,
    I_ACCEPTED,
    I_COMMAND_SEQ,
    I_REJECTED_TOTAL,
    I_PACED_RUN,
    I_PACED,  # -1 detect, 0 off
    I_LAST_PUBLISH_NS,
    I_LAST_RECEIVE_NS,
    I_HEALTHY_RUN,
    I_P_ON_TIME_RUN,  # plant watchdog
    I_FRAME_SENT_NS,
    I_PENDING,  # a timing row of the previous cycle waits (row in pending)
    I_LAST_CMD_NS,  # the runtime's last command's sample time (-1: none)
    I_N_ORDER,  # rows written so far (order), and per message id below
    I_N_SENSORS,
    I_N_COMMAND,
    I_N_TRUTH,
    I_N_STATUS,
    I_N_TIMING,
    I_T0_RUN,  # runner's clock before the controller (kept across a forecast stop)
    I_T0_CTRL,  # runtime's clock at its checks (idem)
    I_GEN_MASK_ROTOR,  # VALID_GENERATOR_SPEED
    I_ROTOR_BIT,  # VALID_ROTOR_SPEED
    I_GAUGE_BIT,  # VALID_WAVE_GAUGE
    I_H_N,  # the latency histogram (LatencyHistogram): samples, max_ns, lowest, highest bin
    I_H_MAX,
    I_H_LO,
    I_H_HI,
    I_SUMMARY_SEQ,  # PlantLoop.summary_seq (the next running summary's seq)
    I_START_WALL_NS,  # PlantLoop.start_wall_ns
    I_R_MISSES,  # the summary's counters, constant during a batch (PlantRunResult)
    I_R_HELD,
    I_R_REJECTED,
    I_R_LATE,
    I_R_SAFE_CYCLES,
    I_R_FAULTS,
    I_N_SUMMARY,  # summary rows written
    I_SIZE,
) = range(44)
I_COUNTS = (I_N_SENSORS, I_N_COMMAND, I_N_TRUTH, I_N_STATUS, I_N_TIMING)  # mid 1..5

(
    F_APPLIED_PITCH,
    F_APPLIED_TORQUE,
    F_H,
    F_EFF,
    F_GEAR,  # plant gearbox ratio (truth, frame's rotor speed)
    F_DT,
    F_LAST_CMD_PITCH,
    F_LAST_CMD_TORQUE,
    F_WALL_S,  # the last running summary's PlantRunResult.wall_s and sim_s
    F_SIM_S,
    F_SIZE,
) = range(11)


class LoopBundle(NamedTuple):
    """The compiled loop's own state (:class:`hil.inprocess.loop.CompiledLoop` owns it).

    ``ist`` (int64, ``I_*``) and ``fst`` (float64, ``F_*``): the plant loop's and the
    controller runtime's counters, the run's constants; ``pending`` (9 int64): the timing
    row of the previous cycle while ``ist[I_PENDING]``; ``hist``: the latency histogram's
    counts (with ``ist[I_H_*]``).
    """

    ist: np.ndarray
    fst: np.ndarray
    pending: np.ndarray
    hist: np.ndarray


class RowsBundle(NamedTuple):
    """A batch's messages as rows (:attr:`bus_schemas.registry.MessageType.row_dtype`, as
    float64 with an int64 view of the same memory, ``*_i``), and ``order``, their message
    ids in publish order."""

    order: np.ndarray
    sen: np.ndarray
    sen_i: np.ndarray
    cmd: np.ndarray
    cmd_i: np.ndarray
    tru: np.ndarray
    tru_i: np.ndarray
    sta: np.ndarray
    sta_i: np.ndarray
    tim: np.ndarray
    tim_i: np.ndarray
    summ: np.ndarray
    summ_i: np.ndarray


#: Reasons :func:`run_cycles` returns (bits may combine for END_OF_CYCLE ones).
STOP_LIMIT = 1  # the caller's limit of cycles (or I_K_END) reached: before cycle k
STOP_BEFORE = 2  # cycle k needs Python from its start (suite, pacing): nothing of it done
STOP_FRAME = 4  # cycle k's frame (rows written) goes to Python's handle_frame
STOP_FORECAST = 8  # cycle k stopped before the core: run the forecaster, resume
STOP_REFILL = 32  # cycle k-1 done; a random block of the sensor suite is used up
STOP_REASONS = {
    STOP_LIMIT: "limit",
    STOP_BEFORE: "before",
    STOP_FRAME: "frame",
    STOP_FORECAST: "forecast",
    STOP_REFILL: "refill",
}
PACED_FRAMES = 8  # hil.nodes.controller_node.PACED_FRAMES (checked there at import)
PACED_TOLERANCE = 0.1
_N_TRUTH = len(TRUTH_FIELDS)


# ---- the latency histogram (hil.nodes.timing.LatencyHistogram) -----------------------------------
H_BINS_PER_DECADE = 120  # hil.nodes.timing._BINS_PER_DECADE (checked by hil.inprocess.loop)
H_MIN_NS = 1_000  # hil.nodes.timing._MIN_NS
H_N_BINS = H_BINS_PER_DECADE * 8 + 2  # hil.nodes.timing._N_BINS
#: Percentiles of the running summary (PlantLoop.publish_summary).
SUMMARY_PERCENTILES = (50.0, 99.0, 99.9)


@njit
def hist_record(hist: np.ndarray, ist: np.ndarray, latency_ns: int) -> None:
    r"""``LatencyHistogram.record`` on ``hist`` (its counts) and ``ist[I_H_*]``.

    Bin :math:`i = 1 + \lfloor 120 \log_{10}(L / 1000\,\mathrm{ns}) \rfloor` (0 below
    1 us, capped at the top bin), with the same float operations as the Python method
    (the true quotient, ``log10``, truncation), so the counts are the same.
    """
    if latency_ns < H_MIN_NS:
        idx = 0
    else:
        idx = 1 + int(H_BINS_PER_DECADE * math.log10(latency_ns / H_MIN_NS))
        if idx >= H_N_BINS:
            idx = H_N_BINS - 1
    hist[idx] += 1
    ist[I_H_N] += 1
    ist[I_H_HI] = max(ist[I_H_HI], idx)
    ist[I_H_LO] = min(ist[I_H_LO], idx)
    ist[I_H_MAX] = max(ist[I_H_MAX], latency_ns)


@njit
def hist_percentile_us(hist: np.ndarray, ist: np.ndarray, q: float) -> float:
    """``LatencyHistogram.percentiles_us`` for one ``q`` (0 < q <= 100), in us.

    The first bin between the lowest and highest occupied ones whose running count reaches
    q/100 * n (``bisect_left`` over the running sums), its upper edge
    :math:`10^{3 + i/120}` ns capped at the maximum; the same float operations as the
    Python method.
    """
    n = ist[I_H_N]
    if n == 0:
        return 0.0
    lo = ist[I_H_LO]
    hi = ist[I_H_HI]
    max_ns = ist[I_H_MAX]
    target = q / 100.0 * n
    running = 0
    found = hi - lo + 1
    for i in range(lo, hi + 1):
        running += hist[i]
        if running >= target:
            found = i - lo
            break
    idx = 0 if target <= 0 else lo + found
    if found >= hi - lo + 1:
        return max_ns / 1e3
    if idx == 0:
        return H_MIN_NS / 1e3
    edge = H_MIN_NS * 10.0 ** (idx / H_BINS_PER_DECADE)
    if max_ns < edge:
        return max_ns / 1e3
    return edge / 1e3


@njit
def _summary_row(
    hist: np.ndarray,
    ist: np.ndarray,
    fst: np.ndarray,
    r_sum: np.ndarray,
    r_sum_i: np.ndarray,
    k: int,
    t_ns: int,
) -> None:
    """The running summary after cycle k - 1 (``PlantLoop.publish_summary(final=False)``
    on the usual path: not in the safe state; the counters are the caller's, constant
    while the kernel runs), as a ``TimingSummary`` row; ``fst[F_WALL_S]``, ``[F_SIM_S]``
    get the run result's wall and simulated seconds."""
    wall_s = (_clock_ns() - ist[I_START_WALL_NS]) * 1e-9
    sim_s = t_ns * 1e-9
    fst[F_WALL_S] = wall_s
    fst[F_SIM_S] = sim_s
    j = ist[I_N_SUMMARY]
    r_sum[j, 12] = hist_percentile_us(hist, ist, SUMMARY_PERCENTILES[0])
    r_sum[j, 13] = hist_percentile_us(hist, ist, SUMMARY_PERCENTILES[1])
    r_sum[j, 14] = hist_percentile_us(hist, ist, SUMMARY_PERCENTILES[2])
    r_sum_i[j, 0] = ist[I_SUMMARY_SEQ]
    r_sum_i[j, 1] = t_ns
    r_sum_i[j, 2] = _clock_ns()
    r_sum_i[j, 3] = k
    r_sum_i[j, 4] = ist[I_R_MISSES]
    r_sum_i[j, 5] = ist[I_R_HELD]
    r_sum_i[j, 6] = ist[I_R_REJECTED]
    r_sum_i[j, 7] = ist[I_R_LATE]
    r_sum_i[j, 8] = 0  # safe_state
    r_sum_i[j, 9] = ist[I_R_SAFE_CYCLES]
    r_sum_i[j, 10] = ist[I_R_FAULTS]
    r_sum_i[j, 11] = 0  # final
    r_sum[j, 15] = ist[I_H_MAX] / 1e3
    speed = 0.0
    if wall_s > 0:
        speed = sim_s / wall_s
        if not speed < 1e9:  # min(1e9, speed)
            speed = 1e9
    r_sum[j, 16] = speed
    ist[I_N_SUMMARY] = j + 1
    ist[I_SUMMARY_SEQ] += 1


@njit
def run_cycles(
    limit: int,
    resume: int,
    lb: LoopBundle,
    pb: PlantBundle,
    sb: SuiteBundle,
    cb: CoreBundle,
    fb: ForecastBundle,
    rb: RowsBundle,
) -> int:
    """Run cycles from ``ist[I_K]`` until a stop (module docstring); return its bits.

    The bundles: the loop's own (``lb``, :class:`LoopBundle`), the plant's
    (:class:`plant._kernels.PlantBundle`), the sensor suite's
    (:class:`sensors._kernels.SuiteBundle`), the controller core's
    (:class:`controller._kernels.CoreBundle`) and its wave forecast's
    (:class:`controller._kernels.ForecastBundle`), the batch's rows (:class:`RowsBundle`).
    ``resume`` = 1 continues cycle k after :data:`STOP_FORECAST` (the caller has set the
    forecast in ``fb``). ``cb.v``/``cb.f`` hold the core's state on return (the kernel
    swaps with ``cb.v2``/``cb.f2`` and copies back). ``lb.pending`` (9 int64) is the
    timing row of the previous cycle while ``ist[I_PENDING]``; ``lb.hist`` (the latency
    histogram's counts, with ``ist[I_H_*]``) gets each finished cycle's latency, and after
    a cycle k - 1 with k % ``ist[I_SUMMARY_EVERY]`` == 0 the running summary is written as
    a row (:func:`_summary_row`) without stopping. Rows are appended from ``ist[I_N_*]``
    on; ``rb.order`` gets their message ids.
    """
    ist, fst, pending, hist = lb.ist, lb.fst, lb.pending, lb.hist
    xa, s, wc, pc, po = pb.x, pb.s, pb.wc, pb.c, pb.o
    wind_table, truth_rec, channel_fields = pb.wind_table, pb.truth_rec, pb.channel_fields
    sf, si, sok, hist_t, hist_v = sb.f, sb.st, sb.ok, sb.hist_t, sb.hist_v
    rn, slots, record = sb.rn, sb.slots, sb.record
    cc, lay, bl, gs = cb.cc, cb.lay, cb.bl, cb.gs
    ci = cb.ci
    n_gs = ci[CI_N_GS]
    fi, ff = fb.fi, fb.ff
    order = rb.order
    r_sen, r_sen_i, r_cmd, r_cmd_i = rb.sen, rb.sen_i, rb.cmd, rb.cmd_i
    r_tru, r_tru_i, r_sta, r_sta_i = rb.tru, rb.tru_i, rb.sta, rb.sta_i
    r_tim_i, r_sum, r_sum_i = rb.tim_i, rb.summ, rb.summ_i  # (timing rows: all int)
    period = ist[I_PERIOD_NS]
    n_steps = ist[I_N_STEPS]
    h = fst[F_H]
    dt = fst[F_DT]
    gear = fst[F_GEAR]
    eff = fst[F_EFF]
    advanced = ci[CI_KIND] == 1
    done = 0
    phase = resume
    k = ist[I_K]
    no = ist[I_N_ORDER]
    v = cb.v
    f = cb.f
    v2 = cb.v2
    f2 = cb.f2
    reason = 0
    swaps = 0
    gen = 0.0
    pitch_m = 0.0
    torque_m = 0.0
    wind_m = 0.0
    acc = 0.0
    ppitch = 0.0
    prate = 0.0
    surge = 0.0
    mask = 0
    t_ns = k * period
    publish_ns = 0
    t0_run = ist[I_T0_RUN]
    t0_ctrl = ist[I_T0_CTRL]
    if phase == 1:  # the frame of cycle k is the last sensors row
        j = ist[I_N_SENSORS] - 1
        mask = r_sen_i[j, 3]
        publish_ns = r_sen_i[j, 2]
        gen = r_sen[j, 4]
        pitch_m = r_sen[j, 6]
        torque_m = r_sen[j, 7]
        wind_m = r_sen[j, 9]
        acc = r_sen[j, 10]
        ppitch = r_sen[j, 11]
        prate = r_sen[j, 12]
        surge = r_sen[j, 13]
    while True:
        if phase == 0:
            # ---- before cycle k: anything that needs Python?
            if done >= limit or k >= ist[I_K_END]:
                reason = STOP_LIMIT
                break
            t_ns = k * period
            if ist[I_PACED] < 0 and ist[I_PACED_RUN] + 1 >= PACED_FRAMES:
                reason = STOP_BEFORE
                break
            # ---- 1. truth and sensor frame (PlantLoop.sample)
            now = _clock_ns()
            floating_truth_into(
                truth_rec, channel_fields, xa, s, pc, po, wind_table, t_ns * 1e-9, 0.0,
                fst[F_APPLIED_PITCH], fst[F_APPLIED_TORQUE], eff, gear,
            )  # fmt: skip
            code, mask = suite_step(
                -1, t_ns, truth_rec[_N_TRUTH:],  # type: ignore[arg-type]
                sf, si, sok, hist_t, hist_v, rn, slots, record,
            )  # fmt: skip
            if code < 0:  # the suite changed nothing: Python runs the whole cycle
                reason = STOP_BEFORE
                break
            refill = code > 0
            gen = record[0]
            rotor = 0.0
            if mask & ist[I_GEN_MASK_ROTOR]:
                rotor = gen / gear
                mask |= ist[I_ROTOR_BIT]
            pitch_m = record[1]
            torque_m = record[2]
            wind_m = record[4]
            acc = record[5]
            ppitch = record[6]
            prate = record[7]
            surge = record[8]
            publish_ns = now
            j = ist[I_N_SENSORS]
            r_sen_i[j, 0] = k
            r_sen_i[j, 1] = t_ns
            r_sen_i[j, 2] = now
            r_sen_i[j, 3] = mask
            r_sen[j, 4] = gen
            r_sen[j, 5] = rotor
            for q in range(1, 10):
                r_sen[j, 5 + q] = record[q]
            ist[I_FRAME_SENT_NS] = _clock_ns()
            ist[I_N_SENSORS] = j + 1
            order[no] = MID_SENSORS
            no += 1
            j = ist[I_N_TRUTH]
            r_tru_i[j, 0] = k
            r_tru_i[j, 1] = t_ns
            r_tru_i[j, 2] = now
            for q in range(_N_TRUTH):
                r_tru[j, 3 + q] = truth_rec[q]
            r_tru_i[j, 3 + TRUTH_FLOATING] = 1
            ist[I_N_TRUTH] = j + 1
            order[no] = MID_TRUTH
            no += 1
            if ist[I_PENDING]:
                j = ist[I_N_TIMING]
                for q in range(9):
                    r_tim_i[j, q] = pending[q]
                ist[I_N_TIMING] = j + 1
                ist[I_PENDING] = 0
                order[no] = MID_TIMING
                no += 1
            # ---- 2. the runtime's checks (handle_frame): seq and time increase (the
            # caller checked the gap), values finite (else Python rejects it)
            total = 0.0
            for q in range(4, 15):
                total += r_sen[ist[I_N_SENSORS] - 1, q]
            if not math.isfinite(total):
                reason = STOP_FRAME | (STOP_REFILL if refill else 0)
                break
            # the runner's clock before the controller and the runtime's at its checks:
            # one reading (the Python path reads twice, back to back)
            t0_run = _clock_ns()
            t0_ctrl = t0_run
            # _watchdog, usual path: gap 0, not stale (wall checks off), healthy
            if ist[I_LAST_PUBLISH_NS] >= 0:
                interval = publish_ns - ist[I_LAST_PUBLISH_NS]
                if abs(interval - period) <= PACED_TOLERANCE * period:
                    ist[I_PACED_RUN] += 1
                else:
                    ist[I_PACED_RUN] = 0
            ist[I_LAST_PUBLISH_NS] = publish_ns
            ist[I_LAST_RECEIVE_NS] = t0_ctrl
            ist[I_HEALTHY_RUN] += 1
            if advanced and t_ns >= fi[FI_NEXT_NS] and fi[FI_KIND] == 1:
                dispersion_forecast(
                    fb, t_ns, r_sen[ist[I_N_SENSORS] - 1, 14], (mask & ist[I_GAUGE_BIT]) != 0
                )
            elif advanced and t_ns >= fi[FI_NEXT_NS]:
                ist[I_T0_RUN] = t0_run
                ist[I_T0_CTRL] = t0_ctrl
                reason = STOP_FORECAST | (STOP_REFILL if refill else 0)
                break
        else:
            refill = False
        phase = 0
        # ---- 3. the core, the command and the status (rows)
        cseq = ist[I_COMMAND_SEQ]
        js = ist[I_N_STATUS]
        if advanced:
            r = advanced_cycle(
                cc, lay, v, f, gen, pitch_m, torque_m, acc, prate, ppitch, surge, mask,
                ff[FF_ETA], dt, ci[CI_STEPS], v2, f2,
            )  # fmt: skip
            v, v2 = v2, v
            f, f2 = f2, f
            swaps += 1
            th = r[0]
            tq = r[1]
            r_sta_i[js, 5] = r[2]
            r_sta[js, 7] = r[3]
            r_sta[js, 8] = r[4]
            r_sta[js, 9] = r[5]
            r_sta_i[js, 10] = fi[FI_EST_MASK]
            r_sta_i[js, 11] = r[6]
            r_sta[js, 12] = r[7]
            r_sta[js, 13] = r[8]
            r_sta[js, 14] = r[9]
            r_sta[js, 15] = r[10]
            r_sta[js, 16] = r[11]
            r_sta[js, 17] = r[12]
            r_sta[js, 18] = ff[FF_STATUS_M]
            r_sta_i[js, 19] = fi[FI_STATUS_NS]
            r_sta[js, 20] = r[13]
            r_sta[js, 21] = r[14]
            r_sta_i[js, 22] = fi[FI_UNSTABLE]
            r_sta_i[js, 23] = fi[FI_GUARDED]
            r_sta_i[js, 24] = r[15]  # estimator faults (the observers' guard)
        else:
            # the TSR-tracking law's wind EKF tables travel in cc (layout in lay:
            # controller._kernels.CoreBundle), empty for the K omega^2 law
            o1 = lay[1]
            o2 = o1 + lay[2]
            o3 = o2 + lay[3]
            rs = baseline_step(
                bl, gs, n_gs, ci[CI_FIRST] != 0, v, gen, pitch_m, torque_m, dt, v2,
                wind_m, cc[0:o1], cc[o1:o2], cc[o2:o3], cc[o3:].reshape((lay[4], 8)),
                prate, (mask & lay[5]) != 0,
            )  # fmt: skip
            ci[CI_FIRST] = 0
            v, v2 = v2, v
            swaps += 1
            th = rs[0]
            tq = rs[1]
            r_sta_i[js, 5] = rs[2]
            r_sta[js, 7] = rs[3]
            r_sta[js, 8] = rs[4]
            r_sta[js, 9] = rs[5]
            r_sta_i[js, 10] = lay[0]  # EST_WIND_SPEED for the TSR-tracking law, else 0
            r_sta_i[js, 11] = rs[8]  # the wind guard's fallback
            r_sta[js, 12] = rs[6]
            for q in range(13, 19):
                r_sta[js, q] = 0.0
            r_sta_i[js, 19] = 0
            r_sta[js, 20] = 0.0
            r_sta[js, 21] = 0.0
            r_sta_i[js, 22] = 0
            r_sta_i[js, 23] = 0
            r_sta_i[js, 24] = rs[7]  # estimator faults
        ist[I_LAST_SEQ] = k
        ist[I_LAST_SAMPLE_NS] = t_ns
        ist[I_ACCEPTED] += 1
        fst[F_LAST_CMD_PITCH] = th
        fst[F_LAST_CMD_TORQUE] = tq
        ist[I_LAST_CMD_NS] = t_ns
        now = _clock_ns()
        j = ist[I_N_COMMAND]
        r_cmd_i[j, 0] = cseq
        r_cmd_i[j, 1] = k
        r_cmd_i[j, 2] = t_ns
        r_cmd_i[j, 3] = now
        r_cmd_i[j, 4] = 0  # MODE_NORMAL
        r_cmd[j, 5] = th
        r_cmd[j, 6] = tq
        ist[I_N_COMMAND] = j + 1
        order[no] = MID_COMMAND
        no += 1
        j = js
        r_sta_i[j, 0] = cseq
        r_sta_i[j, 1] = k
        r_sta_i[j, 2] = t_ns
        r_sta_i[j, 3] = now
        r_sta_i[j, 4] = now - t0_ctrl
        r_sta_i[j, 6] = ist[I_REJECTED_TOTAL]
        ist[I_N_STATUS] = j + 1
        order[no] = MID_STATUS
        no += 1
        ist[I_COMMAND_SEQ] = cseq + 1
        t0p = _clock_ns()  # the latency's end and the plant period's start (one reading)
        latency = t0p - t0_run
        hist_record(hist, ist, latency)
        # ---- 4. the plant's period (finish_cycle: on time, switch 0, not in safe state)
        ist[I_P_ON_TIME_RUN] += 1
        advance_floating(
            xa, s, wc, pc, po, n_steps, 0, wind_table, t_ns * 1e-9, h,
            fst[F_APPLIED_PITCH], fst[F_APPLIED_TORQUE], th, tq,
        )  # fmt: skip
        fst[F_APPLIED_PITCH] = th
        fst[F_APPLIED_TORQUE] = tq
        now = _clock_ns()
        pending[0] = k
        pending[1] = t_ns
        pending[2] = now
        pending[3] = latency
        pending[4] = 0
        pending[5] = 0
        pending[6] = 0
        pending[7] = now - t0p
        pending[8] = 0
        ist[I_PENDING] = 1
        k += 1
        done += 1
        if k % ist[I_SUMMARY_EVERY] == 0:
            _summary_row(hist, ist, fst, r_sum, r_sum_i, k, k * period)
            order[no] = MID_SUMMARY
            no += 1
        if refill:
            reason = STOP_REFILL
            break
    ist[I_K] = k
    ist[I_N_ORDER] = no
    # the core's state back in the caller's arrays
    if swaps % 2 == 1:
        cv = cb.v
        for q in range(cv.size):
            cv[q] = v[q]
        if advanced:
            cf = cb.f
            for q in range(cf.size):
                cf[q] = f[q]
    return reason
