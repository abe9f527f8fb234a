"""Benchmark 3: in-process runs (no bus), 600 s of load case 2, MCAP written.

The targets: ``fowt run iea15mw-lc2-lqri-ff --mode inprocess --duration 600`` at
>= 1000x real time and ``iea15mw-lc2`` (the baseline controller) at >= 2000x. For each
configuration this script measures:

* ``user_run``: the command as a user runs it (``python -m hil run ... --mode inprocess
  --no-plots`` in a subprocess): the summary's simulated seconds per wall second (the loop,
  MCAP handed to the writer) and the wall time of the whole command (start-up, run, writer
  finishing the file, review);
* ``split``: the same run in this process, with the plant (``PlantSimulator.truth``,
  ``sensor_frame``, ``advance``), the controller core (``<controller>.step``) and the logging
  (``BackgroundRunLog.publish``) timed on this thread's CPU clock
  (``time.perf_counter_ns``, scaled by the loop's CPU/wall ratio read on this thread's CPU
  clock, so the split holds on a machine loaded by other jobs); glue is the loop's CPU time
  minus these three (the loop in ``run_inprocess``, ``PlantLoop``,
  ``ControllerRuntime.handle_frame``'s checks and message building, the launcher's
  closures), less the timers' own cost (calibrated). Per cycle, in us; also the loop's wall
  time and the speed it gives, and the speed its CPU time would give on an idle core;
* ``writer``: the log writer child's CPU time after its start-up (it measures it and hands
  it back; ``RUSAGE_CHILDREN`` around the run, start-up included, is saved beside it), its
  throughput in messages per CPU second, and
  whether it or the loop bounds the speed (the loop produces 5 messages a cycle);
* ``compression`` (lqri_ff only): the batches of that run written again in this process
  with zstd (levels 1, 3 and -1), lz4 and none: writer CPU per message and file size;
* ``compare`` (with ``--compare-python PY --compare-root DIR``, e.g. main's venv and
  checkout): split runs of this code and of DIR's code, each in a child process with its
  own interpreter, alternated ``--rounds`` times in one run (the machine's load changes
  from minute to minute): per configuration the least-CPU round of each, every round's
  loop CPU per cycle and load average, and the ratio of the two loops' CPU per cycle;
  with ``--compare-user-runs`` each round also runs the user's command with each code
  (``user_run`` above, the summary's speed), alternating as the splits do.

The machine is shared (2 cores, other jobs): the load average is saved with the figures.

    python bench/inprocess_speed.py [--duration 600] [--only NAME] [--repeat 2] [--legacy]
    python bench/inprocess_speed.py --compare-python REF/.venv/bin/python \
        --compare-root REF --compare-only --rounds 3
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import resource
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from _common import (
    THIS,
    Patches,
    add_compare_args,
    alternate,
    codes,
    run_child,
    run_fowt,
    save,
    scenario_variant,
)

CONFIGS: dict[str, dict[str, Any]] = {
    "lc2-lqri-ff": {"scenario": "iea15mw-lc2-lqri-ff", "target": 1000},
    "lc2-baseline": {"scenario": "iea15mw-lc2", "target": 2000},
}
#: The first in-process configurations (target 500x), with ``--legacy``.
LEGACY: dict[str, tuple[str, float, float]] = {
    "foundation-100hz": ("nrel5mw-ramp", 0.01, 0.01),
    "floating-40hz": ("default", 0.025, 0.0125),
}


def _children_cpu_s() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _writer_overhead_cpu_s() -> float:
    """CPU seconds of a writer child that starts, writes nothing and closes the file."""
    from hil.runlog.writer import BackgroundRunLog

    with tempfile.TemporaryDirectory() as tmp:
        c0 = _children_cpu_s()
        log = BackgroundRunLog(Path(tmp) / "empty.mcap", "t1", {"run": {"mode": "x"}})
        if hasattr(log, "wait_ready"):
            log.wait_ready()
        log.close()
        return _children_cpu_s() - c0


class _Timers(Patches):
    """CPU-time accumulators wrapped around the parts of the loop."""

    def __init__(self) -> None:
        super().__init__()
        self.ns: dict[str, int] = defaultdict(int)
        self.calls: dict[str, int] = defaultdict(int)

    def wrap(self, owner: Any, name: str, part: str) -> None:
        inner = getattr(owner, name)
        clock = time.perf_counter_ns
        ns, calls = self.ns, self.calls

        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = clock()
            out = inner(*args, **kwargs)
            ns[part] += clock() - t0
            calls[part] += 1
            return out

        self.patch(owner, name, timed)

    @staticmethod
    def clock_ns() -> float:
        """Cost of one ``time.perf_counter_ns()`` call (each timed interval holds about one)."""
        n = 200_000
        clock = time.perf_counter_ns
        c0 = time.thread_time_ns()
        for _ in range(n):
            clock()
        return (time.thread_time_ns() - c0) / n

    @staticmethod
    def overhead_ns() -> float:
        """CPU cost of one timed call beyond the call itself (both clock reads, counters)."""

        class Probe:
            def f(self) -> None:
                return None

        t = _Timers()
        p = Probe()
        n = 200_000
        c0 = time.thread_time_ns()
        for _ in range(n):
            p.f()
        plain = time.thread_time_ns() - c0
        t.wrap(Probe, "f", "x")
        c0 = time.thread_time_ns()
        for _ in range(n):
            p.f()
        timed = time.thread_time_ns() - c0
        return max(0.0, (timed - plain) / n)


def split_run(
    scenario_name: str, duration_s: float, keep_batches: bool, loop: str = "auto"
) -> dict[str, Any]:
    """One in-process run in this process, the loop's parts timed (module docstring).

    ``loop``: the in-process loop (``auto``, ``compiled``, ``python``; code without the
    compiled loop takes no such argument and runs its only loop). In the compiled loop the
    kernel's calls are timed as ``kernel`` (plant, sensors, controller core and the
    runtime's checks of every cycle it runs); ``plant`` and ``controller`` are then the
    cycles handed back to Python (and the AR / ESPRIT forecasters' updates, in
    ``controller``; the dispersion forecaster runs in the kernel). The loop calls the
    kernel's bound entry point as in a user's run (``CompiledLoop._bind_kernel``; before
    glue4 this split called numba's dispatcher instead, its typing, about 9 us a call, in
    ``kernel``, and the loop's per-batch check of the entry point's types was skipped).
    """
    from rich.console import Console

    import hil.launch as launch_mod
    import hil.nodes.plant_node as pn
    import hil.runlog.writer as lw
    from hil.launch import RunRequest, ensure_designs, run_info
    from hil.scenario.schema import load_scenario, scenario_text
    from plant.simulator import PlantSimulator

    scenario = load_scenario(scenario_name).with_duration(duration_s)
    toml_text, _ = scenario_text(scenario_name)
    timers = _Timers()
    for name in ("truth", "sensor_frame", "advance"):
        timers.wrap(PlantSimulator, name, "plant")
    timers.wrap(lw.BackgroundRunLog, "publish", "logging")
    block = getattr(lw.BackgroundRunLog, "publish_block", None)  # (absent before s3)
    if block is not None:
        # one "logging" interval per block (the reference publish_block calls publish:
        # those inner intervals are replaced by the block's)
        def timed_block(self: Any, order: Any, rows: Any) -> None:
            snap, calls = timers.ns["logging"], timers.calls["logging"]
            t0 = time.perf_counter_ns()
            block(self, order, rows)
            timers.ns["logging"] = snap + time.perf_counter_ns() - t0
            timers.calls["logging"] = calls + 1

        lw.BackgroundRunLog.publish_block = timed_block  # type: ignore[method-assign]
    import importlib.util

    kernel_mod = None  # the compiled loop (absent before s3)
    if importlib.util.find_spec("hil.inprocess.loop") is not None:
        kernel_mod = importlib.import_module("hil.inprocess.loop")
    if kernel_mod is not None:
        dispatcher = kernel_mod.lk.run_cycles
        timers.wrap(kernel_mod.lk, "run_cycles", "kernel")
        timers.wrap(kernel_mod.CompiledLoop, "_forecast", "controller")
        bind = getattr(kernel_mod.CompiledLoop, "_bind_kernel", None)
        if bind is not None and hasattr(dispatcher, "overloads"):
            # The loop binds the kernel's compiled entry point as in a user's run (through
            # the timed wrapper's overloads) and the bound entry point is timed as kernel.
            kernel_mod.lk.run_cycles.overloads = dispatcher.overloads

            def timed_bind(self: Any) -> None:
                bind(self)
                if self._kernel is not None:
                    inner = self._kernel
                    clock = time.perf_counter_ns

                    def entry(*a: Any) -> Any:
                        t0 = clock()
                        out = inner(*a)
                        timers.ns["kernel"] += clock() - t0
                        timers.calls["kernel"] += 1
                        return out

                    self._kernel = entry

            owner = kernel_mod.CompiledLoop
            timers.patch(owner, "_bind_kernel", timed_bind)
    logs: list[Any] = []
    wrapped: set[type] = set()
    batches: list[bytes] = []
    marks: dict[str, int] = {}
    init_log = lw.BackgroundRunLog.__init__
    init_runtime = launch_mod.ControllerRuntime.__init__
    send = getattr(lw.BackgroundRunLog, "_send", None)  # (absent in older checkouts)
    keep_batches = keep_batches and send is not None
    run_loop = launch_mod.run_inprocess

    def log_init(self: Any, *a: Any, **k: Any) -> None:
        init_log(self, *a, **k)
        logs.append(self)

    def runtime_init(self: Any, *a: Any, **k: Any) -> None:
        init_runtime(self, *a, **k)
        cls = type(self.controller)
        if cls not in wrapped:  # once per run (the wrapper is undone after it)
            timers.wrap(cls, "step", "controller")
            wrapped.add(cls)

    payload = getattr(lw.BackgroundRunLog, "_payload", None)  # (absent before s2loop)

    def keep_send(self: Any) -> None:
        if payload is not None:
            if self._ids:
                batches.append(payload(self))
        elif self._n:
            records = self._records
            records[0] = 0xDD  # the msgpack array32 header _send writes
            records[1:5] = self._n.to_bytes(4, "big")
            batches.append(bytes(records))
        send(self)  # type: ignore[misc]

    def mark_start() -> None:
        timers.ns.clear()  # nothing before the loop counts (the kernel's first load)
        timers.calls.clear()
        marks["cpu0"] = time.thread_time_ns()
        marks["wall0"] = time.perf_counter_ns()

    init_loop = pn.PlantLoop.__init__

    def loop_init(self: Any, *a: Any, **k: Any) -> None:
        init_loop(self, *a, **k)
        mark_start()  # the loop starts when the plant is built ...

    def loop_timed(*a: Any, before_loop: Any = None, **k: Any) -> Any:
        def ready() -> None:
            if before_loop is not None:
                before_loop()
            mark_start()  # ... or, where the launcher waits for its writer, after that

        if "before_loop" in inspect.signature(run_loop).parameters:
            k["before_loop"] = ready
        result = run_loop(*a, **k)
        marks["cpu1"] = time.thread_time_ns()
        marks["wall1"] = time.perf_counter_ns()
        return result

    lw.BackgroundRunLog.__init__ = log_init  # type: ignore[method-assign]
    launch_mod.ControllerRuntime.__init__ = runtime_init  # type: ignore[method-assign]
    launch_mod.run_inprocess = loop_timed  # type: ignore[assignment]
    pn.PlantLoop.__init__ = loop_init  # type: ignore[method-assign]
    if keep_batches:
        lw.BackgroundRunLog._send = keep_send  # type: ignore[method-assign]
    try:
        with tempfile.TemporaryDirectory(prefix="fowt-bench-") as tmp:
            out = Path(tmp)
            req = RunRequest(scenario_name, mode="inprocess", duration_s=duration_s, out_dir=out)
            design_dir = ensure_designs(scenario, Console(quiet=True))
            children0 = _children_cpu_s()
            wall0 = time.perf_counter_ns()
            extra = {}
            if "loop" in inspect.signature(launch_mod._run_inprocess).parameters:
                extra["loop"] = loop
            ran = launch_mod._run_inprocess(
                scenario, out / "run.mcap", run_info(req, scenario), toml_text, design_dir, **extra
            )
            wall_total = time.perf_counter_ns() - wall0
            writer_cpu_s = _children_cpu_s() - children0
            mcap_bytes = (out / "run.mcap").stat().st_size
    finally:
        timers.restore()
        if block is not None:
            lw.BackgroundRunLog.publish_block = block  # type: ignore[method-assign]
        lw.BackgroundRunLog.__init__ = init_log  # type: ignore[method-assign]
        if send is not None:
            lw.BackgroundRunLog._send = send  # type: ignore[method-assign]
        launch_mod.ControllerRuntime.__init__ = init_runtime  # type: ignore[method-assign]
        launch_mod.run_inprocess = run_loop
        pn.PlantLoop.__init__ = init_loop  # type: ignore[method-assign]
    log = logs[0]
    cycles = scenario.cycles
    overhead, clock = _Timers.overhead_ns(), _Timers.clock_ns()
    loop_cpu = marks["cpu1"] - marks["cpu0"]
    loop_wall = marks["wall1"] - marks["wall0"]
    # The parts are timed on the wall clock (perf_counter_ns: a CPU clock read costs ~2 us
    # here); each interval holds about one clock read. Wall time includes the time this
    # process was preempted by other jobs, so the parts are scaled by the loop's CPU/wall
    # ratio (preemption taken as spread evenly over the loop).
    # The time blocked in the pipe (waiting for the writer) is not CPU time: it is taken
    # out of the logging part and of the loop's wall time before scaling.
    send_ns = getattr(log, "send_ns", 0)  # (older checkouts do not count it)
    cpu_per_wall = loop_cpu / max(1, loop_wall - send_ns)
    timers.ns["logging"] -= send_ns
    parts = {
        p: (timers.ns[p] - clock * timers.calls[p]) * cpu_per_wall / cycles / 1e3
        for p in ("plant", "controller", "logging", "kernel")
    }
    n_timed = sum(timers.calls.values())
    parts["glue"] = (
        loop_cpu / cycles / 1e3
        - sum(parts.values())
        - ((overhead - clock) * n_timed / cycles / 1e3)
    )
    return {
        "loop": ran or "python",
        "cycles": cycles,
        "per_cycle_cpu_us": {k: round(v, 2) for k, v in parts.items()},
        "per_cycle_cpu_us_total": round(loop_cpu / cycles / 1e3, 2),
        "timer_overhead_ns_per_call": round(overhead, 1),
        "clock_read_ns": round(clock, 1),
        "loop_cpu_per_wall": round(cpu_per_wall, 3),
        "timed_calls_per_cycle": round(n_timed / cycles, 2),
        "loop_wall_s": round(loop_wall / 1e9, 3),
        "loop_sim_s_per_wall_s": round(duration_s / (loop_wall / 1e9), 1),
        "loop_sim_s_per_cpu_s": round(duration_s / (loop_cpu / 1e9), 1),
        "run_wall_s_incl_setup_and_close": round(wall_total / 1e9, 3),
        "close_wait_s": round(getattr(log, "close_wait_ns", 0) / 1e9, 3),
        "send_wall_us_per_cycle": round(send_ns / cycles / 1e3, 2),
        "messages": getattr(log, "messages", timers.calls["logging"]),
        "batches": getattr(log, "batches", None),
        "mcap_bytes": mcap_bytes,
        "writer_children_cpu_s": round(writer_cpu_s, 3),
        "writer_cpu_s": round(getattr(log, "writer_cpu_s", writer_cpu_s), 3),
        "writer_messages": getattr(log, "writer_messages", timers.calls["logging"]),
        "_batches": batches,
    }


def compression_table(batches: list[bytes], turbine: str) -> dict[str, Any]:
    """Write the recorded batches again with each compression (the writer child's framing,
    :class:`hil.runlog.writer._BatchFramer`, into :class:`hil.runlog.mcap_io.RunLog`); writer CPU
    per message and file size."""
    import hil.runlog.mcap_io as ml
    from hil.runlog.writer import _BatchFramer, _decoders

    decoders = _decoders()
    out: dict[str, Any] = {}
    for label, comp, level in (
        ("zstd-1", "zstd", 1),
        ("zstd-3", "zstd", 3),
        ("zstd-neg1", "zstd", -1),
        ("lz4", "lz4", 0),
        ("none", "", 0),
    ):
        saved = ml.ZSTD_LEVEL
        ml.ZSTD_LEVEL = level or saved
        try:
            with tempfile.TemporaryDirectory() as tmp:
                path = Path(tmp) / "c.mcap"
                log = ml.RunLog(path, turbine, compression=comp)
                framer = _BatchFramer(log, decoders)
                c0 = time.thread_time_ns()
                for blob in batches:
                    framer.frame(blob)
                log.close()
                cpu = time.thread_time_ns() - c0
                out[label] = {
                    "writer_cpu_us_per_message": round(cpu / max(1, log.count) / 1e3, 3),
                    "file_bytes": path.stat().st_size,
                }
        finally:
            ml.ZSTD_LEVEL = saved
    return out


def _split_child(name: str, duration_s: float, loop: str = "auto") -> None:
    """``--split-child``: one split run, its JSON on stdout (for ``--compare-python``)."""
    r = split_run(CONFIGS[name]["scenario"], duration_s, keep_batches=False, loop=loop)
    r.pop("_batches")
    r["load_average"] = os.getloadavg()
    print(json.dumps(r), flush=True)


def compare_rounds(args: argparse.Namespace, names: list[str]) -> dict[str, Any]:
    """Alternate split runs of this code and of ``--compare-root`` (same script, each in a
    child process with its own interpreter), ``--rounds`` times; per configuration the
    least-CPU round of each and every round's figures."""
    here = str(Path(__file__).resolve())
    # (code, --loop): this code's compiled and Python loops, and the other code
    sides = {
        "this": (THIS, "compiled"),
        "this_python_loop": (THIS, "python"),
        "compare": (codes(args)["compare"], "auto"),
    }
    out: dict[str, Any] = {"compare_root": str(args.compare_root), "rounds": args.rounds}
    for name in names:
        per: dict[str, list[dict[str, Any]]] = {code: [] for code in sides}
        for _k, code in alternate(list(sides), args.rounds):
            c, loop = sides[code]
            argv = [here, "--split-child", name, "--duration", str(args.duration), "--loop", loop]
            split = run_child(c, argv)
            if args.compare_user_runs and code != "this_python_loop":
                # the command as a user runs it, with this code's or the other's
                # interpreter and checkout, right after its split run
                u = run_fowt(CONFIGS[name]["scenario"], "inprocess", args.duration,
                             python=c.python, cwd=c.root)  # fmt: skip
                split["user_run_sim_s_per_wall_s"] = u["timing"]["sim_seconds_per_wall_second"]
                split["user_run_load_average"] = os.getloadavg()[0]
            per[code].append(split)
        entry: dict[str, Any] = {}
        for code, runs in per.items():
            best = min(runs, key=lambda r: r["per_cycle_cpu_us_total"])
            entry[code] = {
                "loop": best.get("loop", "python"),
                "per_cycle_cpu_us": best["per_cycle_cpu_us"],
                "per_cycle_cpu_us_total": best["per_cycle_cpu_us_total"],
                "loop_sim_s_per_cpu_s": best["loop_sim_s_per_cpu_s"],
                "loop_sim_s_per_wall_s": best["loop_sim_s_per_wall_s"],
                "writer_cpu_us_per_message": round(
                    best["writer_cpu_s"] / max(1, best["writer_messages"]) * 1e6, 3
                ),
                "mcap_bytes": best["mcap_bytes"],
                "rounds_per_cycle_cpu_us_total": [r["per_cycle_cpu_us_total"] for r in runs],
                "rounds_load_average": [r["load_average"][0] for r in runs],
            }
            if args.compare_user_runs and code != "this_python_loop":
                entry[code]["rounds_user_run_sim_s_per_wall_s"] = [
                    round(r["user_run_sim_s_per_wall_s"], 1) for r in runs
                ]
                entry[code]["rounds_user_run_load_average"] = [
                    r["user_run_load_average"] for r in runs
                ]
        entry["loop_cpu_ratio_this_python_loop_over_this"] = round(
            entry["this_python_loop"]["per_cycle_cpu_us_total"]
            / entry["this"]["per_cycle_cpu_us_total"],
            3,
        )
        entry["loop_cpu_ratio_compare_over_this"] = round(
            entry["compare"]["per_cycle_cpu_us_total"] / entry["this"]["per_cycle_cpu_us_total"],
            3,
        )
        out[name] = entry
        print(name, entry, flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--only", choices=sorted(CONFIGS), default=None)
    ap.add_argument("--legacy", action="store_true", help="also the first two configurations")
    ap.add_argument("--no-user-run", action="store_true", help="skip the fowt run subprocess")
    ap.add_argument("--repeat", type=int, default=2, help="split runs per configuration")
    ap.add_argument("--label", default="", help="what code was measured (saved)")
    ap.add_argument("--save-as", default="inprocess_speed", help="name of the JSON")
    ap.add_argument("--split-child", choices=sorted(CONFIGS), default=None, help=argparse.SUPPRESS)
    add_compare_args(ap)
    ap.add_argument("--compare-only", action="store_true", help="only the --compare-* rounds")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds with --compare-*")
    ap.add_argument(
        "--compare-user-runs",
        action="store_true",
        help="with --compare-*: also a fowt run of each code after its split, every round",
    )
    ap.add_argument(
        "--loops",
        default="compiled,python",
        help="in-process loops to split (comma-separated: compiled, python, auto)",
    )
    ap.add_argument("--loop", default="auto", help=argparse.SUPPRESS)  # (--split-child)
    args = ap.parse_args()
    if args.split_child:
        _split_child(args.split_child, args.duration, args.loop)
        return
    import hil

    results: dict[str, Any] = {"load_average_start": os.getloadavg()}
    results["code"] = args.label or str(Path(hil.__file__).resolve().parent.parent)
    overhead_cpu = _writer_overhead_cpu_s()
    results["writer_startup_and_close_cpu_s"] = round(overhead_cpu, 3)
    runs: dict[str, Any] = {}
    for name, cfg in CONFIGS.items():
        if (args.only and name != args.only) or args.compare_only:
            continue
        entry: dict[str, Any] = {"scenario": cfg["scenario"], "duration_s": args.duration}
        entry["target"] = cfg["target"]
        if not args.no_user_run:
            s = run_fowt(cfg["scenario"], "inprocess", args.duration)
            speed = s["timing"]["sim_seconds_per_wall_second"]
            entry["user_run"] = {
                "command": f"fowt run {cfg['scenario']} --mode inprocess "
                f"--duration {args.duration:g} --no-plots",
                "sim_seconds_per_wall_second": speed,
                "whole_command_wall_s": round(s["bench_command_wall_s"], 3),
                "met": speed is not None and speed >= cfg["target"],
            }
        loops = [x.strip() for x in args.loops.split(",") if x.strip()]
        by_loop: dict[str, Any] = {}
        batches: list[bytes] = []
        for li, loop in enumerate(loops):
            splits = [
                split_run(
                    cfg["scenario"],
                    args.duration,
                    keep_batches=name == "lc2-lqri-ff" and i == 0 and li == 0,
                    loop=loop,
                )
                for i in range(args.repeat)
            ]
            if li == 0:
                batches = splits[0].pop("_batches")
            for extra in splits:
                extra.pop("_batches", None)
            # The machine is shared: of the repeats, the one whose loop took the least CPU
            # (the least disturbed), with every repeat's per-cycle split beside it.
            best = min(splits, key=lambda r: r["per_cycle_cpu_us_total"])
            best["repeats_per_cycle_cpu_us"] = [r["per_cycle_cpu_us"] for r in splits]
            by_loop[loop] = best
        split = by_loop[loops[0]]
        entry["splits_by_loop"] = {
            loop: {k: v for k, v in r.items() if k != "repeats_per_cycle_cpu_us"}
            for loop, r in by_loop.items()
            if loop != loops[0]
        }
        writer_cpu = max(1e-9, split["writer_cpu_s"])
        msgs_per_cpu_s = split["messages"] / writer_cpu
        loop_msgs_per_cpu_s = split["messages"] / (
            split["per_cycle_cpu_us_total"] * split["cycles"] / 1e6
        )
        entry["split"] = split
        entry["writer"] = {
            "cpu_s_for_run": round(writer_cpu, 3),
            "cpu_us_per_message": round(1e6 / msgs_per_cpu_s, 3),
            "messages_per_cpu_s": round(msgs_per_cpu_s),
            "loop_messages_per_cpu_s": round(loop_msgs_per_cpu_s),
            "bound_by": "writer" if msgs_per_cpu_s < loop_msgs_per_cpu_s else "loop",
            "writer_bound_sim_s_per_s": round(
                msgs_per_cpu_s
                / (split["messages"] / split["cycles"])
                * (args.duration / split["cycles"]),
                1,
            ),
        }
        if batches:
            entry["compression"] = compression_table(batches, "t1")
        runs[name] = entry
        print(name, {k: v for k, v in entry.items() if k != "compression"}, flush=True)
    if args.legacy:
        for name, (scenario, period, step) in LEGACY.items():
            s = run_fowt(str(scenario_variant(scenario, period, step)), "inprocess", args.duration)
            speed = s["timing"]["sim_seconds_per_wall_second"]
            runs[name] = {
                "scenario": scenario,
                "control_rate_hz": round(1.0 / period),
                "duration_s": args.duration,
                "sim_seconds_per_wall_second": speed,
                "whole_command_wall_s": round(s["bench_command_wall_s"], 3),
                "target": 500,
            }
    results["runs"] = runs
    if "compare" in codes(args):
        names = [n for n in CONFIGS if not args.only or n == args.only]
        results["compare"] = compare_rounds(args, names)
    results["load_average_end"] = os.getloadavg()
    save(args.save_as, results)


if __name__ == "__main__":
    sys.exit(main())
