"""Where the compiled in-process loop's CPU goes: its parts timed one by one.

One 600 s in-process run of LC2 per configuration through the launcher's in-process path
(:func:`hil.launch._run_inprocess`: the real log writer child, MCAP written), in this
process, with each part of :meth:`hil._fast_loop.CompiledLoop.run` and what it calls per
batch wrapped in a ``time.perf_counter_ns`` timer: the kernel's calls (its bound entry point;
through numba's dispatcher, typing included, they are in ``call``), the state in
(``_pull``; the types check ``_check_kernel_types`` and the argument tuple ``_args`` apart)
and out (``_push``; the latency histogram ``LatencyHistogram.record`` apart), the rows
handed to the writer (``_publish_rows``; ``BackgroundRunLog.publish_block`` and its
``_send`` to the pipe apart), the running summary (``PlantLoop.publish_summary``), the
sensor suite's refills and the cycles Python runs. Times are exclusive (a part's time less
its timed callees') and per 25 ms cycle; ``other`` is the loop's CPU time (this thread's
clock from the first cycle to the run's end) less the parts, i.e. ``run``'s own lines, and
``timers`` the timers' own cost (calibrated: two clock reads and the bookkeeping per
call). The parts are wall-clock intervals scaled by the loop's CPU/wall ratio (the machine
is shared), the time blocked in the pipe taken out. Parts a code version lacks are absent
(``--root`` another checkout, e.g. main, run with its own venv)::

    python bench/inprocess_loop_profile.py [--duration 600] [--repeat 2] [--save-as NAME]
    PYTHONPATH=REF REF/.venv/bin/python bench/inprocess_loop_profile.py \
        --save-as inprocess_loop_profile_main
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from _common import Patches, save

CONFIGS = {"lc2-lqri-ff": "iea15mw-lc2-lqri-ff", "lc2-baseline": "iea15mw-lc2"}


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

        t = _Stack()
        g = t.timed(f, "x")
        n = 200_000
        c0 = time.thread_time_ns()
        for _ in range(n):
            f()
        plain = time.thread_time_ns() - c0
        c0 = time.thread_time_ns()
        for _ in range(n):
            g()
        return max(0.0, (time.thread_time_ns() - c0 - plain) / n)


def profile_run(scenario_name: str, duration_s: float) -> dict[str, Any]:
    """One run, its loop's parts timed (module docstring)."""
    import hil._fast_loop as fl
    import hil.launch as launch_mod
    import hil.log_writer as lw
    import hil.plant_node as pn
    from hil.launch import RunRequest, ensure_designs, run_info
    from hil.scenario import load_scenario, scenario_text
    from hil.timing import LatencyHistogram
    from sensors.channel import SensorSuite

    scenario = load_scenario(scenario_name).with_duration(duration_s)
    toml_text, _ = scenario_text(scenario_name)
    t = _Stack()
    parts = [
        (fl.CompiledLoop, "_ready", "ready"),
        (fl.CompiledLoop, "_pull", "pull"),
        (fl.CompiledLoop, "_set_forecast", "pull"),
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
        (SensorSuite, "_refill", "refill"),
    ]
    for owner, name, part in parts:
        t.wrap(owner, name, part)
    # The kernel's bound entry point (CompiledLoop._bind_kernel) is timed as "kernel"; the
    # dispatcher (lk.run_cycles, when no entry point is bound) is left alone, so that the
    # loop binds as in a user's run: its calls, typing included, are then in "call".
    kernel_part = "kernel"
    init_loop = fl.CompiledLoop.__init__
    bind = getattr(fl.CompiledLoop, "_bind_kernel", None)
    marks: dict[str, int] = {}

    def loop_init(self: Any, *a: Any, **k: Any) -> None:
        init_loop(self, *a, **k)
        if bind is None and getattr(self, "_kernel", None) is not None:  # the entry point
            self._kernel = t.timed(self._kernel, kernel_part)

    def rebind(self: Any) -> None:
        assert bind is not None
        bind(self)
        if getattr(self, "_kernel", None) is not None:
            self._kernel = t.timed(self._kernel, kernel_part)

    run = fl.CompiledLoop.run

    def run_timed(self: Any, cycles: int) -> None:
        t.ns.clear()  # nothing before the loop counts
        t.calls.clear()
        marks["cpu0"] = time.thread_time_ns()
        marks["wall0"] = time.perf_counter_ns()
        run(self, cycles)
        marks["cpu1"] = time.thread_time_ns()
        marks["wall1"] = time.perf_counter_ns()
        marks["cycles"] = self.loop.k
        marks["batches"] = self.batches
        marks["kernel_cycles"] = self.kernel_cycles
        marks["python_cycles"] = self.python_cycles

    fl.CompiledLoop.__init__ = loop_init  # type: ignore[method-assign]
    if bind is not None:
        fl.CompiledLoop._bind_kernel = rebind  # type: ignore[method-assign]
    fl.CompiledLoop.run = run_timed  # type: ignore[method-assign]
    logs: list[Any] = []
    init_log = lw.BackgroundRunLog.__init__

    def log_init(self: Any, *a: Any, **k: Any) -> None:
        init_log(self, *a, **k)
        logs.append(self)

    lw.BackgroundRunLog.__init__ = log_init  # type: ignore[method-assign]
    try:
        with tempfile.TemporaryDirectory(prefix="fowt-bench-") as tmp:
            out = Path(tmp)
            req = RunRequest(scenario_name, mode="inprocess", duration_s=duration_s, out_dir=out)
            from rich.console import Console

            design_dir = ensure_designs(scenario, Console(quiet=True))
            ran = launch_mod._run_inprocess(
                scenario, out / "run.mcap", run_info(req, scenario), toml_text, design_dir
            )
    finally:
        t.restore()
        fl.CompiledLoop.__init__ = init_loop  # type: ignore[method-assign]
        fl.CompiledLoop.run = run  # type: ignore[method-assign]
        if bind is not None:
            fl.CompiledLoop._bind_kernel = bind  # type: ignore[method-assign]
        lw.BackgroundRunLog.__init__ = init_log  # type: ignore[method-assign]
    if ran != "compiled":
        raise SystemExit(f"{scenario_name}: the {ran} loop ran")
    log = logs[0]
    cycles = marks["cycles"]
    loop_cpu = marks["cpu1"] - marks["cpu0"]
    loop_wall = marks["wall1"] - marks["wall0"]
    send_ns = getattr(log, "send_ns", 0)
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
        "load_average": os.getloadavg(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--repeat", type=int, default=2, help="runs per configuration (least CPU)")
    ap.add_argument("--only", choices=sorted(CONFIGS), default=None)
    ap.add_argument("--save-as", default="inprocess_loop_profile")
    args = ap.parse_args()
    import hil

    result: dict[str, Any] = {
        "code": str(Path(hil.__file__).resolve().parent.parent),
        "load_average_start": os.getloadavg(),
    }
    for name, scenario in CONFIGS.items():
        if args.only and name != args.only:
            continue
        runs = [profile_run(scenario, args.duration) for _ in range(args.repeat)]
        best = min(runs, key=lambda r: r["loop_cpu_us_per_cycle"])
        best["rounds_loop_cpu_us_per_cycle"] = [r["loop_cpu_us_per_cycle"] for r in runs]
        result[name] = best
        print(name, best, flush=True)
    result["load_average_end"] = os.getloadavg()
    save(args.save_as, result)


if __name__ == "__main__":
    sys.exit(main())
