"""Where an in-process control cycle's time goes: one profiler, five views of the same loop.

The in-process loop (:func:`hil.inprocess.run.run_inprocess`) runs, per control cycle, the
plant's truth and sensor frame, the controller runtime and its core, the plant's period and
the publishes, either compiled (:mod:`hil.inprocess.kernels`) or in Python. Each subcommand
times it from one side and saves ``bench/results/loop_profile_<subcommand>.json``:

* ``plant``: the plant side alone (:meth:`plant.simulator.PlantSimulator.truth`,
  ``sensor_frame``, ``advance``, as :class:`hil.nodes.plant_node.PlantLoop` calls them, the
  command held at the initial actuator positions), every cycle timed (wall clock): its
  percentiles (p50 is the figure least disturbed on a shared machine), the best and median
  batch of 100 cycles and the process CPU per cycle; ``floating-40hz`` (LC2 lqri_ff:
  IEA 15 MW VolturnUS-S, 25 ms cycle, 12.5 ms plant step) and ``fixed-100hz``
  (``nrel5mw-ramp``, 10 ms cycle and step). Best round: lowest p50.
* ``parts``: each part of an LC2 baseline cycle called on its own in a tight loop
  (``--cycles``, 24 000 = 600 s at 40 Hz): ``truth``, ``sensor_frame``, ``advance`` (wall
  clock, in the loop's order), ``handle_frame`` (:meth:`ControllerRuntime.handle_frame`) and
  ``publish_5`` (:meth:`BackgroundRunLog.publish` of the cycle's five messages, the writer
  child running), CPU us per call: lower bounds of the same parts inside the run (warm
  caches). Best: each part's least.
* ``kernel``: the compiled kernel's callees (``floating_truth_into``, ``suite_step``, the
  core, ``advance_floating``, the clock reads) called from a compiled loop on the state of an
  LC2 run after 9000 cycles (225 s: the wave forecast is on from 204.6 s), 2000 times (the
  sensor suite 200 times, within its random block), this thread's CPU clock, beside the
  whole kernel's CPU per cycle in a ``--duration`` run with the messages dropped. Best:
  each figure's least.
* ``loop-only``: the whole loop with the messages dropped (no log writer), compiled and
  Python, ``--duration`` of LC2 (lqri_ff and baseline): the loop's CPU (this thread's clock
  from the first cycle to the final summary) and wall time per cycle. Best: least CPU.
* ``profile``: a launcher in-process run (:func:`hil.launch._run_inprocess`: the real log
  writer, MCAP written) with each part of :meth:`hil.inprocess.loop.CompiledLoop.run` and what
  it calls wrapped in a timer; exclusive times per cycle, scaled by the loop's CPU/wall
  ratio, the time blocked in the pipe taken out; ``other`` is the loop's own lines,
  ``timers`` the timers' calibrated cost. Parts a code version lacks are absent. Best:
  least loop CPU.

Every round of every side runs in a fresh child process (``--child``), the sides
alternating (:func:`_common.alternate`) for ``--rounds`` rounds; with ``--compare-python
PY --compare-root DIR`` DIR's code is the ``compare`` side (this script, DIR's code:
:func:`_common.run_child`), and the result holds each side's best round per configuration,
every round's key figure, and the compare/this ratio of the key figure. Usage::

    python bench/loop_profile.py plant [--cycles 4000] [--reps 7] [--rounds 3]
    python bench/loop_profile.py parts [--cycles 24000] [--rounds 3]
    python bench/loop_profile.py kernel [--duration 600] [--rounds 3]
    python bench/loop_profile.py loop-only [--duration 600] [--rounds 3]
    python bench/loop_profile.py profile [--duration 600] [--rounds 2] [--only lc2-baseline]
    python bench/loop_profile.py SUBCOMMAND ... --compare-python REF/.venv/bin/python \\
        --compare-root REF
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import THIS, Patches, add_compare_args, alternate, codes, run_child, save

SCRIPT = str(Path(__file__).resolve())
#: The LC2 configurations of the loop views (name -> shipped scenario).
LC2 = {"lc2-lqri-ff": "iea15mw-lc2-lqri-ff", "lc2-baseline": "iea15mw-lc2"}
#: The plant view's configurations: name -> (scenario, control period [s], plant step [s]).
PLANT = {
    "floating-40hz": ("iea15mw-lc2-lqri-ff", 0.025, 0.0125),
    "fixed-100hz": ("nrel5mw-ramp", 0.01, 0.01),
}
BATCH = 100  # cycles per timed batch (plant view)


# --- plant: the plant side of a cycle ---------------------------------------------------


def _plant_one(scenario_name: str, cycles: int, reps: int) -> dict[str, Any]:
    from hil.nodes.plant_node import plant_config
    from hil.scenario.schema import load_scenario
    from plant.simulator import PlantSimulator

    t_build = time.perf_counter()
    sim = PlantSimulator(plant_config(load_scenario(scenario_name)))
    x = sim.initial_state()
    applied = sim.initial_applied(x)
    period_ns = round(sim.h * sim.n * 1e9)
    build_s = time.perf_counter() - t_build
    k = 0

    def cycle() -> None:
        nonlocal x, k
        t_ns = k * period_ns
        truth = sim.truth(k, t_ns, x, applied, 0)
        sim.sensor_frame(k, truth, 0)
        x = sim.advance(t_ns * 1e-9, x, applied, applied, 0)
        k += 1

    t_first = time.perf_counter()
    cycle()
    first_s = time.perf_counter() - t_first
    for _ in range(200):
        cycle()
    samples: list[int] = []
    clock, cpu = time.perf_counter_ns, time.process_time_ns
    batch_means = []
    cpu_total = 0
    for _ in range(reps):
        c0 = cpu()
        for _ in range(max(1, cycles // BATCH)):
            b0 = clock()
            for _ in range(BATCH):
                a = clock()
                cycle()
                samples.append(clock() - a)
            batch_means.append((clock() - b0) / BATCH / 1e3)
        cpu_total += cpu() - c0
    batch_means.sort()
    samples.sort()

    def pct(q: float) -> float:
        return samples[min(len(samples) - 1, int(q * len(samples)))] / 1e3

    return {
        "scenario": scenario_name,
        "cycle_s": sim.h * sim.n,
        "plant_steps_per_cycle": sim.n,
        "cycles_timed": len(samples),
        "us_per_cycle_best_batch": batch_means[0],
        "us_per_cycle_median_batch": batch_means[len(batch_means) // 2],
        "cpu_us_per_cycle": cpu_total / len(samples) / 1e3,
        "p10_us": pct(0.1),
        "p50_us": pct(0.5),
        "p99_us": pct(0.99),
        "max_us": samples[-1] / 1e3,
        "build_s": build_s,
        "first_cycle_s": first_s,
        "final_state_head": [float(v) for v in x[:4]],
    }


def measure_plant(args: argparse.Namespace) -> dict[str, Any]:
    return {
        name: _plant_one(scenario, args.cycles, args.reps)
        for name, (scenario, _period, _step) in PLANT.items()
        if args.only is None or name == args.only
    }


# --- parts: each part of a cycle in a tight loop ----------------------------------------


def measure_parts(args: argparse.Namespace) -> dict[str, Any]:
    from bus_schemas import CycleTiming
    from bus_schemas.registry import COMMAND, CONTROLLER_STATUS, CYCLE_TIMING, SENSORS, TRUTH
    from hil.nodes.controller_node import ControllerRuntime
    from hil.nodes.plant_node import plant_config
    from hil.runlog.writer import BackgroundRunLog
    from hil.scenario.schema import load_scenario
    from plant.simulator import PlantSimulator

    n = args.cycles
    scenario = load_scenario(LC2["lc2-baseline"]).with_duration(n * 0.025)
    sim = PlantSimulator(plant_config(scenario))
    x = sim.initial_state()
    applied = sim.initial_applied(x)
    period_ns = 25_000_000
    clock = time.perf_counter_ns  # (a CPU clock read costs ~2 us on this VM)
    out: dict[str, float] = {}
    truths, frames = [], []
    t_truth = t_frame = t_adv = 0
    for k in range(n):  # the loop's order: truth, its sensor frame, the period
        c0 = clock()
        tr = sim.truth(k, k * period_ns, x, applied, 0)
        c1 = clock()
        frames.append(sim.sensor_frame(k, tr, k))
        c2 = clock()
        x = sim.advance(k * 0.025, x, applied, applied, 0)
        c3 = clock()
        truths.append(tr)
        t_truth += c1 - c0
        t_frame += c2 - c1
        t_adv += c3 - c2
    out["truth"] = t_truth / n / 1e3
    out["sensor_frame"] = t_frame / n / 1e3
    out["advance"] = t_adv / n / 1e3
    clock = time.thread_time_ns
    timing = [
        CycleTiming(
            seq=k, sample_time_ns=k * period_ns, publish_time_ns=k, latency_ns=40_000,
            deadline_missed=0, command_held=0, safe_state=0, plant_compute_ns=20_000,
            tick_lateness_ns=0,
        )
        for k in range(n)
    ]  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        runtime = ControllerRuntime(scenario, run_dir=Path(tmp))
        results = []
        c0 = clock()
        for f in frames:
            results.append(runtime.handle_frame(f))
        out["handle_frame"] = (clock() - c0) / n / 1e3
        log = BackgroundRunLog(Path(tmp) / "parts.mcap", "t1", {"run": {"mode": "parts"}})
        log.wait_ready()
        publish = log.publish
        c0 = clock()
        for f, tr, r, ct in zip(frames, truths, results, timing, strict=True):
            publish(SENSORS, f)
            publish(TRUTH, tr)
            publish(CYCLE_TIMING, ct)
            if r is not None:
                publish(COMMAND, r[0])
                publish(CONTROLLER_STATUS, r[1])
        out["publish_5"] = (clock() - c0) / n / 1e3
        log.close()
        out["writer_us_per_message"] = log.writer_cpu_s / max(1, log.writer_messages) * 1e6
    return {"lc2-baseline": {k: round(v, 3) for k, v in out.items()}}


# --- kernel: the compiled kernel's callees ----------------------------------------------


def _kernel_one(scenario_name: str, duration_s: float) -> dict[str, float]:
    import numba

    import hil.inprocess.kernels as lk
    from controller._kernels import CI_N_GS, CI_STEPS, FF_ETA, advanced_cycle, baseline_step
    from hil.inprocess.loop import CompiledLoop
    from hil.nodes.controller_node import ControllerRuntime, publishing_step
    from hil.nodes.plant_node import PlantLoop
    from hil.scenario.schema import load_scenario
    from plant._kernels import advance_floating, floating_truth_into
    from sensors._kernels import suite_step

    n_truth = lk._N_TRUTH

    @numba.njit
    def h_truth(n: int, rec: Any, cf: Any, x: Any, s: Any, pc: Any, po: Any, wt: Any,
                t: float, eff: float, gear: float) -> None:  # fmt: skip
        for _ in range(n):
            floating_truth_into(rec, cf, x, s, pc, po, wt, t, 0.0, 0.1, 1e7, eff, gear)

    @numba.njit
    def h_suite(n: int, t_ns: int, rec: Any, sf: Any, si: Any, sok: Any, ht: Any, hv: Any,
                rn: Any, slots: Any, record: Any) -> int:  # fmt: skip
        c = 0
        for i in range(n):
            code, _mask = suite_step(
                -1, t_ns + i * 25_000_000, rec[n_truth:], sf, si, sok, ht, hv, rn, slots, record
            )
            c += code
        return c

    @numba.njit
    def h_baseline(n: int, bl: Any, gs: Any, n_gs: int, b: Any, b2: Any, dt: float, cc: Any,
                   lay: Any) -> float:  # fmt: skip
        o1 = lay[1]
        o2 = o1 + lay[2]
        o3 = o2 + lay[3]
        out = 0.0
        for _ in range(n):
            out += baseline_step(
                bl, gs, n_gs, False, b, 700.0, 0.1, 1e7, dt, b2, 10.0, cc[0:o1], cc[o1:o2],
                cc[o2:o3], cc[o3:].reshape((lay[4], 8)), 0.0, True,
            )[0]  # fmt: skip
        return out

    @numba.njit
    def h_advanced(n: int, cc: Any, lay: Any, v: Any, f: Any, row: Any, mask: int, eta: float,
                   dt: float, steps: int, v2: Any, f2: Any) -> float:  # fmt: skip
        out = 0.0
        for _ in range(n):
            r = advanced_cycle(
                cc, lay, v, f, row[4], row[6], row[7], row[10], row[12], row[11], row[13],
                mask, eta, dt, steps, v2, f2,
            )  # fmt: skip
            out += r[0]
        return out

    @numba.njit
    def h_period(n: int, x: Any, s: Any, wc: Any, pc: Any, po: Any, n_steps: int, wt: Any,
                 t: float, h: float) -> None:  # fmt: skip
        for i in range(n):
            advance_floating(x, s, wc, pc, po, n_steps, 0, wt, t + i * 0.025, h, 0.1, 1e7, 0.1, 1e7)

    def cpu_us(f: Any, *args: Any, n: int = 2000) -> float:
        f(1, *args)  # compile
        c0 = time.thread_time_ns()
        f(n, *args)
        return (time.thread_time_ns() - c0) / n / 1e3

    scn = load_scenario(scenario_name).with_duration(max(duration_s, 230.0))
    rt = ControllerRuntime(scn)

    def drop(*_a: Any) -> None:
        return None

    loop = PlantLoop(scn, drop)
    fast = CompiledLoop(loop, rt, publishing_step(rt, drop), drop)
    fast.run(9000)
    fast._pull(scn.cycles)
    a = fast._args(0, 0)
    lb, pb, sb, cb, fb = a[2:7]
    ist, fst = lb.ist, lb.fst
    xa, s, wc, pc, po, wt, rec, cf = pb
    sf, si, sok, ht, hv, rn, slots, record = sb
    cc, lay, cv, cfl, cv2, cf2 = cb.cc, cb.lay, cb.v, cb.f, cb.v2, cb.f2
    bl, gs, n_gs, bst, bst2 = cb.bl, cb.gs, int(cb.ci[CI_N_GS]), cb.v, cb.v2
    t_ns = int(ist[lk.I_K] * ist[lk.I_PERIOD_NS])
    out = {
        "truth": cpu_us(
            h_truth, rec, cf, xa, s, pc, po, wt, t_ns * 1e-9, fst[lk.F_EFF], fst[lk.F_GEAR]
        ),
    }
    if h_suite(200, t_ns, rec, sf.copy(), si.copy(), sok.copy(), ht.copy(), hv.copy(), rn,
               slots, record.copy()) != 0:  # fmt: skip
        raise SystemExit("the sensor suite's random block ends within 200 cycles here")
    out["sensor_suite"] = cpu_us(h_suite, t_ns, rec, sf, si, sok, ht, hv, rn, slots, record,
                                 n=200)  # fmt: skip
    if fast.advanced:
        row = fast.buf[lk.MID_SENSORS][0].copy()  # (a frame of the last batch)
        mask = int(fast.ibuf[lk.MID_SENSORS][0, 3])
        out["core"] = cpu_us(h_advanced, cc, lay, cv, cfl, row, mask, fb.ff[FF_ETA],
                             fst[lk.F_DT], int(cb.ci[CI_STEPS]), cv2, cf2)  # fmt: skip
    else:
        out["core"] = cpu_us(h_baseline, bl, gs, n_gs, bst, bst2, fst[lk.F_DT], cc, lay)
    out["period"] = cpu_us(h_period, xa.copy(), s.copy(), wc.copy(), pc, po,
                           int(ist[lk.I_N_STEPS]), wt, t_ns * 1e-9, fst[lk.F_H])  # fmt: skip
    n = 100_000
    lk.clock_reads(10)
    c0 = time.thread_time_ns()
    lk.clock_reads(n)
    out["clock_read"] = (time.thread_time_ns() - c0) / n / 1e3
    out["clock_reads_6"] = 6 * out["clock_read"]
    out["sum_of_parts"] = sum(v for k, v in out.items() if k not in ("clock_read",))
    # the whole kernel: a fresh run of the compiled loop, messages dropped
    scn2 = scn.with_duration(duration_s)
    loop2 = PlantLoop(scn2, drop)
    rt2 = ControllerRuntime(scn2)
    fast2 = CompiledLoop(loop2, rt2, publishing_step(rt2, drop), drop)
    kernel = fast2._kernel
    spent = [0]

    def timed(*args: Any) -> Any:
        c0 = time.thread_time_ns()
        r = kernel(*args)
        spent[0] += time.thread_time_ns() - c0
        return r

    if kernel is not None:
        fast2._kernel = timed
    c0 = time.thread_time_ns()
    fast2.run(scn2.cycles)
    out["loop_per_cycle"] = (time.thread_time_ns() - c0) / scn2.cycles / 1e3
    out["kernel_per_cycle"] = spent[0] / max(1, fast2.kernel_cycles) / 1e3
    return {k: round(v, 3) for k, v in out.items()}


def measure_kernel(args: argparse.Namespace) -> dict[str, Any]:
    return {
        name: _kernel_one(scenario, args.duration)
        for name, scenario in LC2.items()
        if args.only is None or name == args.only
    }


# --- loop-only: the whole loop, messages dropped ----------------------------------------


def _loop_only_one(scenario: str, loop: str, duration_s: float) -> dict[str, Any]:
    from hil.inprocess.run import run_inprocess
    from hil.nodes.controller_node import ControllerRuntime, publishing_step
    from hil.scenario.schema import load_scenario

    scn = load_scenario(scenario).with_duration(duration_s)
    rt = ControllerRuntime(scn)

    def publish(_mt: Any, _msg: Any) -> None:
        return None

    def block(_order: Any, _rows: Any) -> None:
        return None

    step = publishing_step(rt, publish)
    marks: dict[str, int] = {}

    def start() -> None:
        marks["cpu0"] = time.thread_time_ns()

    res = run_inprocess(
        scn, publish, step, before_loop=start, runtime=rt, loop=loop, publish_block=block
    )
    cpu = time.thread_time_ns() - marks["cpu0"]
    cpu_us = cpu / res.cycles / 1e3
    return {
        "loop": res.loop,
        "cpu_us_per_cycle": round(cpu_us, 2),
        "wall_us_per_cycle": round(res.wall_s / res.cycles * 1e6, 2),
        "sim_s_per_wall_s": round(res.speed, 1),
        "cycle_s_per_cpu_s": round(scn.timing.control_period_s / (cpu_us * 1e-6), 1),
        "load_average": os.getloadavg()[0],
    }


def measure_loop_only(args: argparse.Namespace) -> dict[str, Any]:
    return {
        name: _loop_only_one(scenario, args.loop, args.duration)
        for name, scenario in LC2.items()
        if args.only is None or name == args.only
    }


# --- profile: a launcher run, the loop's parts timed ------------------------------------


class _Stack(Patches):
    """Exclusive-time timers: a wrapped call's time less that of the wrapped calls in it."""

    def __init__(self) -> None:
        super().__init__()
        self.ns: dict[str, int] = defaultdict(int)
        self.calls: dict[str, int] = defaultdict(int)
        self.inner: list[int] = [0]

    def timed(self, inner: Any, part: str) -> Any:
        clock = time.perf_counter_ns
        ns, calls, stack = self.ns, self.calls, self.inner

        def wrapper(*args: Any, **kwargs: Any) -> Any:
            stack.append(0)
            t0 = clock()
            try:
                return inner(*args, **kwargs)
            finally:
                dt = clock() - t0
                children = stack.pop()
                ns[part] += dt - children
                calls[part] += 1
                stack[-1] += dt

        return wrapper

    def wrap(self, owner: Any, name: str, part: str) -> bool:
        if not hasattr(owner, name):
            return False
        self.patch(owner, name, self.timed(getattr(owner, name), part))
        return True

    @staticmethod
    def overhead_ns() -> float:
        """CPU cost of one timed call beyond the call itself."""

        def f() -> None:
            return None

        g = _Stack().timed(f, "x")
        n = 200_000
        c0 = time.thread_time_ns()
        for _ in range(n):
            f()
        plain = time.thread_time_ns() - c0
        c0 = time.thread_time_ns()
        for _ in range(n):
            g()
        return max(0.0, (time.thread_time_ns() - c0 - plain) / n)


def _profile_one(scenario_name: str, duration_s: float) -> dict[str, Any]:
    from rich.console import Console

    import hil.inprocess.loop as fl
    import hil.launch as launch_mod
    import hil.nodes.plant_node as pn
    import hil.runlog.writer as lw
    from controller.runtime import AdvancedController
    from hil.launch import RunRequest, ensure_designs, run_info
    from hil.nodes.timing import LatencyHistogram
    from hil.scenario.schema import load_scenario, scenario_text
    from sensors.channel import SensorSuite

    scenario = load_scenario(scenario_name).with_duration(duration_s)
    toml_text, _ = scenario_text(scenario_name)
    t = _Stack()
    parts = [
        (fl.CompiledLoop, "_ready", "ready"),
        (fl.CompiledLoop, "_pull", "pull"),
        (fl.CompiledLoop, "_set_forecast", "pull"),
        (AdvancedController, "forecast_bundle", "pull"),
        (fl.CompiledLoop, "_check_kernel_types", "check_kernel_types"),
        (fl.CompiledLoop, "_args", "args"),
        (fl.CompiledLoop, "_call", "call"),
        (fl.CompiledLoop, "_push", "push"),
        (fl.CompiledLoop, "_publish_rows", "publish_rows"),
        (fl.CompiledLoop, "_python_cycle", "python_cycles"),
        (fl.CompiledLoop, "_forecast", "python_forecast"),
        (fl.CompiledLoop, "_summary", "summary"),
        (lw.BackgroundRunLog, "publish_block", "publish_block"),
        (lw.BackgroundRunLog, "publish", "publish"),
        (lw.BackgroundRunLog, "_send", "send"),
        (pn.PlantLoop, "publish_summary", "summary"),
        (pn.PlantLoop, "sample", "python_cycles"),
        (pn.PlantLoop, "finish_cycle", "python_cycles"),
        (LatencyHistogram, "record", "hist_record"),
        (SensorSuite, "refill", "refill"),
    ]
    for owner, name, part in parts:
        t.wrap(owner, name, part)
    # The kernel's bound entry point (CompiledLoop._bind_kernel) is timed as "kernel"; the
    # dispatcher (lk.run_cycles, when no entry point is bound) is left alone, so that the
    # loop binds as in a user's run: its calls, typing included, are then in "call".
    init_loop = fl.CompiledLoop.__init__
    bind = getattr(fl.CompiledLoop, "_bind_kernel", None)
    marks: dict[str, int] = {}

    def loop_init(self: Any, *a: Any, **k: Any) -> None:
        init_loop(self, *a, **k)
        if bind is None and getattr(self, "_kernel", None) is not None:  # the entry point
            self._kernel = t.timed(self._kernel, "kernel")

    def rebind(self: Any) -> None:
        assert bind is not None
        bind(self)
        if getattr(self, "_kernel", None) is not None:
            self._kernel = t.timed(self._kernel, "kernel")

    run = fl.CompiledLoop.run

    def run_timed(self: Any, *a: Any, **k: Any) -> None:
        t.ns.clear()  # nothing before the loop counts
        t.calls.clear()
        marks["cpu0"] = time.thread_time_ns()
        marks["wall0"] = time.perf_counter_ns()
        run(self, *a, **k)
        marks["cpu1"] = time.thread_time_ns()
        marks["wall1"] = time.perf_counter_ns()
        marks["cycles"] = self.loop.k
        marks["batches"] = self.batches
        marks["kernel_cycles"] = self.kernel_cycles
        marks["python_cycles"] = self.python_cycles

    logs: list[Any] = []
    init_log = lw.BackgroundRunLog.__init__

    def log_init(self: Any, *a: Any, **k: Any) -> None:
        init_log(self, *a, **k)
        logs.append(self)

    t.patch(fl.CompiledLoop, "__init__", loop_init)
    if bind is not None:
        t.patch(fl.CompiledLoop, "_bind_kernel", rebind)
    t.patch(fl.CompiledLoop, "run", run_timed)
    t.patch(lw.BackgroundRunLog, "__init__", log_init)
    try:
        with tempfile.TemporaryDirectory(prefix="fowt-bench-") as tmp:
            out = Path(tmp)
            req = RunRequest(scenario_name, mode="inprocess", duration_s=duration_s, out_dir=out)
            design_dir = ensure_designs(scenario, Console(quiet=True))
            ran = launch_mod._run_inprocess(
                scenario, out / "run.mcap", run_info(req, scenario), toml_text, design_dir
            )
    finally:
        t.restore()
    if ran != "compiled":
        raise SystemExit(f"{scenario_name}: the {ran} loop ran")
    cycles = marks["cycles"]
    loop_cpu = marks["cpu1"] - marks["cpu0"]
    loop_wall = marks["wall1"] - marks["wall0"]
    send_ns = getattr(logs[0], "send_ns", 0)
    cpu_per_wall = loop_cpu / max(1, loop_wall - send_ns)
    overhead = _Stack.overhead_ns()
    n_timed = sum(t.calls.values())
    ns = dict(t.ns)
    ns["send"] = ns.get("send", 0) - send_ns  # blocked in the pipe: not CPU
    per = {p: v * cpu_per_wall / cycles / 1e3 for p, v in ns.items()}
    per["timers"] = overhead * n_timed / cycles / 1e3
    per["other"] = loop_cpu / cycles / 1e3 - sum(per.values())
    return {
        "scenario": scenario_name,
        "cycles": cycles,
        "batches": marks["batches"],
        "kernel_cycles": marks["kernel_cycles"],
        "python_cycles": marks["python_cycles"],
        "loop_cpu_us_per_cycle": round(loop_cpu / cycles / 1e3, 3),
        "parts_cpu_us_per_cycle": {
            k: round(v, 3) for k, v in sorted(per.items(), key=lambda kv: -kv[1])
        },
        "calls_per_batch": {k: round(v / marks["batches"], 2) for k, v in t.calls.items()},
        "timer_overhead_ns_per_call": round(overhead, 1),
        "loop_cpu_per_wall": round(cpu_per_wall, 3),
        "send_wall_us_per_cycle": round(send_ns / cycles / 1e3, 3),
    }


def measure_profile(args: argparse.Namespace) -> dict[str, Any]:
    return {
        name: _profile_one(scenario, args.duration)
        for name, scenario in LC2.items()
        if args.only is None or name == args.only
    }


# --- one harness for all views ----------------------------------------------------------

#: subcommand -> (measure one round, its options passed to the children, the key figure a
#: round is judged by (None: each figure's least over the rounds), sides beyond this/compare).
VIEWS: dict[
    str, tuple[Callable[[argparse.Namespace], dict[str, Any]], tuple[str, ...], str | None]
] = {
    "plant": (measure_plant, ("cycles", "reps", "only"), "p50_us"),
    "parts": (measure_parts, ("cycles",), None),
    "kernel": (measure_kernel, ("duration", "only"), None),
    "loop-only": (measure_loop_only, ("duration", "only", "loop"), "cpu_us_per_cycle"),
    "profile": (measure_profile, ("duration", "only"), "loop_cpu_us_per_cycle"),
}


def _best(rounds: list[dict[str, Any]], key: str | None) -> dict[str, Any]:
    """Per configuration, the round with the least ``key`` (the least disturbed one), or
    with ``key`` None each number's least over the rounds."""
    out: dict[str, Any] = {}
    for name in rounds[0]:
        figs = [r[name] for r in rounds]
        if key is not None:
            out[name] = min(figs, key=lambda f: f[key])
        else:
            out[name] = {
                k: min(f[k] for f in figs) if isinstance(v, int | float) else v
                for k, v in figs[0].items()
            }
    return out


def _child_argv(args: argparse.Namespace, opts: tuple[str, ...], **over: Any) -> list[str]:
    argv = [SCRIPT, args.view, "--child"]
    for opt in opts:
        value = over.get(opt, getattr(args, opt))
        if value is not None:
            argv += [f"--{opt.replace('_', '-')}", str(value)]
    return argv


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="view", required=True)
    for view in VIEWS:
        p = sub.add_parser(view)
        p.add_argument("--rounds", type=int, default=2 if view == "profile" else 3)
        p.add_argument("--save-as", default=f"loop_profile_{view.replace('-', '_')}")
        p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
        add_compare_args(p)
        if view == "plant":
            p.add_argument("--cycles", type=int, default=4000)
            p.add_argument("--reps", type=int, default=7)
            p.add_argument("--only", choices=sorted(PLANT), default=None)
        elif view == "parts":
            p.add_argument("--cycles", type=int, default=24_000)
        else:
            p.add_argument("--duration", type=float, default=600.0)
            p.add_argument("--only", choices=sorted(LC2), default=None)
        if view == "loop-only":
            p.add_argument("--loop", choices=("compiled", "python"), default=None)
    args = ap.parse_args()
    measure, opts, key = VIEWS[args.view]
    if args.child:
        print(json.dumps(measure(args)), flush=True)
        return 0
    sides = {name: (code, {}) for name, code in codes(args).items()}
    if args.view == "loop-only":  # this code's two loops, the other code's compiled loop
        sides = {
            "compiled": (THIS, {"loop": "compiled"}),
            "python": (THIS, {"loop": "python"}),
            **{n: (c, {"loop": "compiled"}) for n, (c, _o) in sides.items() if n != "this"},
        }
    result: dict[str, Any] = {"load_average_start": os.getloadavg(), "rounds": args.rounds}
    rounds: dict[str, list[dict[str, Any]]] = {name: [] for name in sides}
    for k, name in alternate(list(sides), args.rounds):
        code, over = sides[name]
        rounds[name].append(run_child(code, _child_argv(args, opts, **over)))
        print(f"round {k} {name}: load {os.getloadavg()[0]:.2f}", flush=True)
    first = next(iter(sides))
    for name, runs in rounds.items():
        code = sides[name][0]
        result[name] = {
            "code": code.info(),
            "best": _best(runs, key),
            "rounds": runs if key is None else {c: [r[c][key] for r in runs] for c in runs[0]},
        }
        if key is not None and name != first:
            a, b = result[first]["best"], result[name]["best"]
            result[name][f"{key}_over_{first}"] = {c: round(b[c][key] / a[c][key], 3) for c in b}
        print(name, json.dumps(result[name]["best"]), flush=True)
    result["load_average_end"] = os.getloadavg()
    save(args.save_as, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
