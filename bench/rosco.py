"""Benchmark: ROSCO's compiled controller (``kind = "rosco"``) beside the bench's own.

Two parts, saved together in ``bench/results/rosco.json``:

* ``call_cost``: one process, the sensor frames of an in-process run replayed through each
  controller core; per call: the bare ``DISCON`` call (swap array already filled; ROSCO
  writes its debug line, flushed), and the whole core step (swap array filled, call,
  commands and ROSCO's debug line read back), beside the ``baseline`` core and the
  advanced ``lqri_ff`` core. NREL 5 MW ramp (100 Hz) and the floating load case 2
  (40 Hz).
* ``latency``: real-time runs over Zenoh, plant, controller and recorder as separate
  processes (``fowt run --mode realtime``), the floating load case 2 at 40 and 100 Hz with
  ``rosco``, ``baseline`` and ``lqri_ff``: sensor-to-command latency p50/p99/p99.9/max,
  deadline misses and the controller's compute time per cycle.

    python bench/rosco.py [--duration 60] [--realtime-priority 20] [--only call_cost]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import msgspec
from _common import run_fowt, save, scenario_variant

from bus_schemas import ActuatorCommand, SensorFrame

LATENCY_SCENARIOS = {
    "rosco": "iea15mw-lc2-rosco",
    "baseline": "iea15mw-lc2",
    "lqri_ff": "iea15mw-lc2-lqri-ff",
}


def _frames(scenario_name: str, duration_s: float) -> tuple[Any, list[SensorFrame]]:
    """The sensor frames of an in-process run of ``scenario_name`` (its own controller)."""
    from hil.inprocess.run import run_inprocess
    from hil.nodes.controller_node import ControllerRuntime
    from hil.scenario.schema import load_scenario

    sc = load_scenario(scenario_name).with_duration(duration_s)
    frames: list[SensorFrame] = []
    runtime = ControllerRuntime(sc)

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        frames.append(frame)
        out = runtime.handle_frame(frame)
        return None if out is None else out[0]

    run_inprocess(sc, lambda _mt, _msg: None, step)
    return sc, frames


def _pcts(ns: list[int]) -> dict[str, float]:
    xs = sorted(ns)
    q = statistics.quantiles(xs, n=1000)
    return {
        "p50_us": round(statistics.median(xs) / 1e3, 2),
        "p99_us": round(q[989] / 1e3, 2),
        "max_us": round(xs[-1] / 1e3, 2),
        "calls": len(xs),
    }


def call_cost(duration_s: float) -> dict[str, Any]:
    from controller.registry import make_controller

    out: dict[str, Any] = {}
    cases = {
        "nrel5mw-ramp-100hz": (
            "nrel5mw-ramp",
            [("rosco", "nrel5mw"), ("baseline", "nrel5mw_baseline")],
        ),
        "iea15mw-lc2-40hz": (
            "iea15mw-lc2",
            [
                ("rosco", "iea15mw_volturnus"),
                ("baseline", "iea15mw_baseline"),
                ("lqri_ff", "iea15mw_advanced"),
            ],
        ),
    }
    for case, (scenario_name, kinds) in cases.items():
        sc, frames = _frames(scenario_name, duration_s)
        dt = sc.timing.control_period_s
        res: dict[str, Any] = {}
        for kind, preset in kinds:
            with tempfile.TemporaryDirectory(prefix="fowt-bench-rosco-") as tmp:
                gauge = sc.waves.gauge_distance_m if sc.waves is not None else None
                ctrl = make_controller(
                    kind, preset, control_period_s=dt, gauge_distance_m=gauge, output_dir=tmp
                )
                state = ctrl.initial_state()
                steps: list[int] = []
                for frame in frames:
                    t0 = time.perf_counter_ns()
                    state, _ = ctrl.step(state, frame, dt)
                    steps.append(time.perf_counter_ns() - t0)
                hold = round(1.0 / dt) if kind == "rosco" else 0  # start-up phase: no call
                res[kind] = {"step": _pcts(steps[hold + 1 :])}
                if kind == "rosco":
                    lib = state.library
                    calls: list[int] = []
                    for _ in range(2000):
                        lib.swap[1] += dt
                        t0 = time.perf_counter_ns()
                        lib.call()
                        calls.append(time.perf_counter_ns() - t0)
                    res[kind]["discon_call"] = _pcts(calls)
            print(case, kind, res[kind])
        out[case] = {"scenario": scenario_name, "control_period_s": dt, **res}
    return out


def latency(duration_s: float, priority: int) -> dict[str, Any]:
    rt = ["--realtime-priority", str(priority)] if priority else []
    out: dict[str, Any] = {}
    for hz, (period, step) in {40: (0.025, 0.0125), 100: (0.01, 0.01)}.items():
        for kind, scenario in LATENCY_SCENARIOS.items():
            path = scenario_variant(scenario, period, step)
            s = run_fowt(str(path), "realtime", duration_s, rt)
            t = s["timing"]
            name = f"{kind}-{hz}hz"
            out[name] = {
                "scenario": scenario,
                "control_rate_hz": hz,
                "duration_s": duration_s,
                "realtime_priority": priority,
                "latency_us": t["latency_us"],
                "deadline_misses": t["deadline_misses"],
                "cycles": t["cycles"],
                "controller_compute_us": t.get("controller_compute_us"),
                "safe_state_cycles": t.get("safe_state_cycles"),
            }
            print(name, msgspec.json.encode(out[name]).decode())
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=60.0, help="real-time runs [s]")
    ap.add_argument("--replay", type=float, default=60.0, help="replayed frames [s]")
    ap.add_argument("--only", choices=["call_cost", "latency"], default=None)
    ap.add_argument(
        "--realtime-priority", type=int, default=0, help="SCHED_FIFO for plant and controller"
    )
    args = ap.parse_args()
    results: dict[str, Any] = {}
    path = Path(__file__).resolve().parent / "results" / "rosco.json"
    if args.only and path.is_file():  # keep the other part's last figures
        import json

        old = json.loads(path.read_text())
        results = {k: old[k] for k in ("call_cost", "latency") if k in old}
    if args.only in (None, "call_cost"):
        results["call_cost"] = call_cost(args.replay)
    if args.only in (None, "latency"):
        results["latency"] = latency(args.duration, args.realtime_priority)
    save("rosco", results)


if __name__ == "__main__":
    main()
