"""Where the compiled in-process loop's kernel spends a cycle: its callees one at a time.

:func:`hil._loop_kernels.run_cycles` composes, per 25 ms cycle, the truth record
(``floating_truth_into``), the sensor suite (``suite_step``), the controller core
(``baseline_step`` or ``advanced_cycle``), the plant's period (``advance_floating``, two
steps at 40 Hz) and six clock reads. Each callee is called here from a compiled loop (no
Python between calls) on the state of an LC2 run after 9000 cycles (225 s: the wave
forecast is on from 204.6 s) of the compiled loop, 2000 times (the sensor suite 200 times,
within its random block, which is not refilled here), timed on this thread's CPU clock,
and set beside the whole kernel's CPU per cycle in a 600 s run of the compiled loop with
the messages dropped. The core and the period are called on the same
state each time (the period advances the state; the core's outputs go to other arrays).

    python bench/loop_kernel_parts.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Any

from _common import save

SCENARIOS = {"lc2-lqri-ff": "iea15mw-lc2-lqri-ff", "lc2-baseline": "iea15mw-lc2"}


def measure(scenario_name: str) -> dict[str, float]:
    """CPU us per call of each callee and per cycle of the whole kernel (module docstring)."""
    import numba

    import hil._loop_kernels as lk
    from controller._kernels import advanced_cycle, baseline_step
    from hil._fast_loop import CompiledLoop
    from hil.controller_node import ControllerRuntime, publishing_step
    from hil.plant_node import PlantLoop
    from hil.scenario import load_scenario
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
    def h_baseline(n: int, bl: Any, gs: Any, n_gs: int, b: Any, b2: Any, dt: float) -> float:
        out = 0.0
        for _ in range(n):
            out += baseline_step(bl, gs, n_gs, False, b, 700.0, 0.1, 1e7, dt, b2)[0]
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

    scn = load_scenario(scenario_name).with_duration(600.0)
    rt = ControllerRuntime(scn)

    def drop(*_a: Any) -> None:
        return None

    loop = PlantLoop(scn, drop)
    fast = CompiledLoop(loop, rt, publishing_step(rt, drop), drop)
    fast.run(9000)
    fast._pull(scn.cycles)
    a = fast._args(0, 0)
    ist, fst = a[2], a[3]
    xa, s, wc, pc, po, wt, rec, cf = a[6:14]
    sf, si, sok, ht, hv, rn, slots, record = a[14:22]
    cc, lay, cv, cfl, cv2, cf2, bl, gs, n_gs, bst, bst2 = a[22:33]
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
        out["core"] = cpu_us(h_advanced, cc, lay, cv, cfl, row, mask, fst[lk.F_ETA],
                             fst[lk.F_DT], int(ist[lk.I_STEPS]), cv2, cf2)  # fmt: skip
    else:
        out["core"] = cpu_us(h_baseline, bl, gs, n_gs, bst, bst2, fst[lk.F_DT])
    out["period"] = cpu_us(h_period, xa.copy(), s.copy(), wc.copy(), pc, po,
                           int(ist[lk.I_N_STEPS]), wt, t_ns * 1e-9, fst[lk.F_H])  # fmt: skip
    n = 100_000
    lk.clock_reads(10)
    c0 = time.thread_time_ns()
    lk.clock_reads(n)
    out["clock_read"] = (time.thread_time_ns() - c0) / n / 1e3
    out["clock_reads_6"] = 6 * out["clock_read"]
    out["sum_of_parts"] = sum(v for k, v in out.items() if k not in ("clock_read",))
    # the whole kernel: a fresh 60 s run of the compiled loop, messages dropped
    loop2 = PlantLoop(scn, drop)
    rt2 = ControllerRuntime(scn)
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
    fast2.run(scn.cycles)
    out["loop_per_cycle"] = (time.thread_time_ns() - c0) / scn.cycles / 1e3
    out["kernel_per_cycle"] = spent[0] / max(1, fast2.kernel_cycles) / 1e3
    return {k: round(v, 3) for k, v in out.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3, help="measurements (least CPU kept)")
    args = ap.parse_args()
    result: dict[str, Any] = {"load_average_start": os.getloadavg(), "cpu_us": {}}
    for name, scenario in SCENARIOS.items():
        runs = [measure(scenario) for _ in range(args.repeat)]
        best = {k: min(r[k] for r in runs) for k in runs[0]}
        result["cpu_us"][name] = {"best": best, "runs": runs}
        print(name, best, flush=True)
    result["load_average_end"] = os.getloadavg()
    save("loop_kernel_parts", result)


if __name__ == "__main__":
    sys.exit(main())
