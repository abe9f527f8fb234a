"""Advanced controller (observers + wave forecast + LQRI [+ wave FF]): cost and benefit.

The advanced controller's benchmark, three parts (each prints its figures; all saved together to
``bench/results/advanced_controller.json``):

a. **Cycle compute, one process** (``replay``): the ``lqri_ff`` scenario
   ``iea15mw-lc2-lqri-ff`` is run in process for ``--replay-duration`` seconds (300: the
   dispersion forecaster's 1024-tap buffer fills at 204.8 s, after which the wave-FF filter
   bank runs every cycle) and its sensor frames recorded; the frames are then replayed into a
   fresh controller core (EKF, platform KF, forecaster, LQRI, FF) and each ``step`` is timed
   with ``time.perf_counter_ns`` (wall) and ``time.thread_time_ns`` (CPU of this thread):
   p50/p99/p99.9/max over all cycles and over the cycles with every part on (forecast valid,
   FF filters stepping), at 40 Hz (the shipped 0.025 s design) and 100 Hz (0.01 s design).
b. **Two-process real-time runs** (``realtime``): ``fowt run`` of the same scenario,
   ``--realtime-duration`` seconds (60) at 40 Hz and 100 Hz (plant, controller and recorder
   as separate processes over Zenoh): deadline misses, sensor-to-command latency
   p50/p99/p99.9/max and the controller's compute p50/p99/max from the run summary (the
   MCAP). Targets: 0 deadline misses and p99 compute <= 1 ms. In a 60 s run the forecast is
   not yet valid, so the FF filter bank holds (part a gives the all-parts-on cost).
c. **Benefit, in process, 600 s, same seeds** (``comparison``): above rated,
   ``iea15mw-lqri-15`` vs ``iea15mw-baseline-15`` (15 m/s IEC B, Hs 3 m, Tp 9.5 s):
   rotor-speed, power and platform-pitch standard deviations; wave FF below rated,
   ``iea15mw-lc1/2-lqri-ff`` vs ``iea15mw-lc1/2-lqri``: rotor-speed variance reduction next
   to al-2019's 41 % (LC1) and 22 % (LC2); per scenario the cycle compute time, the
   wind-estimate error and the forecast VAF against the truth.

Reference: ROSCO's compiled controller takes about 19 us per call (``bench/rosco.py``).
The machine's load average (1, 5, 15 min) is saved before and after: the figures are only
as quiet as the machine was.

Usage: ``python bench/advanced_controller.py [--only replay|realtime|comparison]
[--duration S] [--replay-duration S] [--realtime-duration S]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _common import machine, run_fowt, save, scenario_variant

from bus_schemas import ActuatorCommand, ControllerStatus, PlantState, SensorFrame
from bus_schemas.messages import EST_FEEDFORWARD, EST_WAVE_FORECAST
from bus_schemas.registry import TRUTH, MessageType
from hil.inprocess.run import run_inprocess
from hil.nodes.controller_node import ControllerRuntime
from hil.scenario.schema import load_scenario

#: The all-parts-on scenario of parts a and b (lqri_ff, dispersion forecast, balanced FF).
FF_SCENARIO = "iea15mw-lc2-lqri-ff"
#: (control period s, plant step s) of the two rates; 40 Hz is the scenario as shipped.
RATES = {"40hz": (0.025, 0.0125), "100hz": (0.01, 0.01)}
ROSCO_US_PER_CALL = 19.0
COMPUTE_P99_TARGET_US = 1000.0

SETTLE_S = 30.0


def run(name: str, duration_s: float | None) -> dict[str, Any]:
    """One in-process run; returns its figures."""
    scenario = load_scenario(name).with_duration(duration_s)
    runtime = ControllerRuntime(scenario)
    truth: list[PlantState] = []
    status: list[ControllerStatus] = []

    def publish(mt: MessageType, msg: msgspec.Struct) -> None:
        if mt is TRUTH:
            assert isinstance(msg, PlantState)
            truth.append(msg)

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        result = runtime.handle_frame(frame)
        if result is None:
            return None
        status.append(result[1])
        return result[0]

    run_inprocess(scenario, publish, step)
    tt = np.array([m.sample_time_ns for m in truth], dtype=np.float64)
    keep = tt >= SETTLE_S * 1e9

    def col(msgs: list[Any], name: str) -> np.ndarray:
        return np.array([getattr(m, name) for m in msgs], dtype=np.float64)

    out: dict[str, Any] = {
        "scenario": name,
        "duration_s": scenario.duration_s,
        "rotor_speed_std_rad_s": float(np.std(col(truth, "rotor_speed_rad_s")[keep])),
        "rotor_speed_var_rad2_s2": float(np.var(col(truth, "rotor_speed_rad_s")[keep])),
        "power_std_w": float(np.std(col(truth, "electrical_power_w")[keep])),
        "power_mean_w": float(np.mean(col(truth, "electrical_power_w")[keep])),
        "platform_pitch_std_deg": float(np.degrees(np.std(col(truth, "platform_pitch_rad")[keep]))),
    }
    compute_us = col(status, "compute_time_ns") / 1e3
    out["compute_us"] = {
        "p50": float(np.percentile(compute_us, 50)),
        "p99": float(np.percentile(compute_us, 99)),
        "max": float(np.max(compute_us)),
    }
    ts = col(status, "sample_time_ns")
    mask = col(status, "estimates_valid_mask").astype(np.int64)
    if mask.any():
        u = np.interp(ts, tt, col(truth, "wind_speed_m_s"))
        e = col(status, "wind_speed_estimated_m_s") - u
        sel = ts >= SETTLE_S * 1e9
        out["wind_error_mean_pct"] = float(100.0 * np.mean(e[sel]) / np.mean(u[sel]))
        out["wind_error_rms_m_s"] = float(np.sqrt(np.mean(e[sel] ** 2)))
        f = (mask & EST_WAVE_FORECAST) != 0
        ft, fv = (
            col(status, "wave_forecast_time_ns")[f],
            col(status, "wave_elevation_forecast_m")[f],
        )
        ok = ft <= tt[-1]
        if ok.sum() > 10:
            eta = np.interp(ft[ok], tt, col(truth, "wave_elevation_platform_m"))
            out["forecast_vaf_pct"] = float(100.0 * (1.0 - np.var(eta - fv[ok]) / np.var(eta)))
    return out


def _percentiles(values_ns: np.ndarray) -> dict[str, float]:
    """p50/p99/p99.9/max of nanosecond samples, in microseconds."""
    us = values_ns / 1e3
    return {
        "p50": float(np.percentile(us, 50)),
        "p99": float(np.percentile(us, 99)),
        "p999": float(np.percentile(us, 99.9)),
        "max": float(np.max(us)),
        "mean": float(np.mean(us)),
        "n": int(us.size),
    }


def _scenario_ref(rate: str) -> str:
    """The FF scenario at ``rate`` (a temporary TOML for 100 Hz, the shipped name for 40)."""
    period, step = RATES[rate]
    if rate == "40hz":
        return FF_SCENARIO
    return str(scenario_variant(FF_SCENARIO, period, step))


def replay(rate: str, duration_s: float) -> dict[str, Any]:
    """Part a: record the frames of a closed-loop run, replay them into a fresh core, time it.

    Parameters
    ----------
    rate : {"40hz", "100hz"}
    duration_s : float
        Simulated seconds recorded (s).

    Returns
    -------
    dict
        Wall and CPU percentiles (us) over all cycles and over the all-parts-on cycles.
    """
    scenario = load_scenario(_scenario_ref(rate)).with_duration(duration_s)
    recorder = ControllerRuntime(scenario)
    frames: list[SensorFrame] = []

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        frames.append(frame)
        result = recorder.handle_frame(frame)
        return None if result is None else result[0]

    run_inprocess(scenario, lambda _mt, _msg: None, step)
    core = ControllerRuntime(scenario).controller
    dt = scenario.timing.control_period_s
    state = core.initial_state()
    n = len(frames)
    wall = np.empty(n, dtype=np.int64)
    cpu = np.empty(n, dtype=np.int64)
    all_on = np.zeros(n, dtype=bool)
    perf, thread = time.perf_counter_ns, time.thread_time_ns
    both = EST_WAVE_FORECAST | EST_FEEDFORWARD
    for k, frame in enumerate(frames):
        c0, w0 = thread(), perf()
        state, out = core.step(state, frame, dt)
        w1, c1 = perf(), thread()
        wall[k], cpu[k] = w1 - w0, c1 - c0
        all_on[k] = (out.estimates_valid_mask & both) == both
    return {
        "scenario": FF_SCENARIO,
        "control_period_s": dt,
        "frames": n,
        "all_parts_on_cycles": int(all_on.sum()),
        "all_cycles": {"wall_us": _percentiles(wall), "cpu_us": _percentiles(cpu)},
        "all_parts_on": {
            "wall_us": _percentiles(wall[all_on]),
            "cpu_us": _percentiles(cpu[all_on]),
        }
        if all_on.any()
        else None,
    }


def realtime(rate: str, duration_s: float, priority: int = 0) -> dict[str, Any]:
    """Part b: ``fowt run`` (plant, controller, recorder processes) in real time.

    Returns
    -------
    dict
        Deadline misses, latency and controller compute percentiles (us) of the summary.
    """
    extra = ["--realtime-priority", str(priority)] if priority else []
    s = run_fowt(_scenario_ref(rate), "realtime", duration_s, extra)
    t = s["timing"]
    compute = t.get("controller_compute_us") or {}
    return {
        "scenario": FF_SCENARIO,
        "control_period_s": RATES[rate][0],
        "duration_s": duration_s,
        "cycles": t["cycles"],
        "deadline_misses": t["deadline_misses"],
        "commands_held": t["commands_held"],
        "latency_us": t["latency_us"],
        "controller_compute_us": compute,
        "met": t["deadline_misses"] == 0
        and compute.get("p99", float("inf")) <= COMPUTE_P99_TARGET_US,
    }


def comparison(duration_s: float | None) -> dict[str, Any]:
    """Part c: the LQRI-vs-baseline and FF-vs-no-FF pairs, in process, same seeds."""
    runs = {
        n: run(n, duration_s)
        for n in (
            "iea15mw-baseline-15",
            "iea15mw-lqri-15",
            "iea15mw-lc1-lqri",
            "iea15mw-lc1-lqri-ff",
            "iea15mw-lc2-lqri",
            "iea15mw-lc2-lqri-ff",
        )
    }
    b, q = runs["iea15mw-baseline-15"], runs["iea15mw-lqri-15"]
    for name, r in runs.items():
        print(name, {k: v for k, v in r.items() if k != "scenario"})
    return {
        "runs": runs,
        "above_rated_lqri_vs_baseline": {
            k: {"lqri": q[k], "baseline": b[k]}
            for k in ("rotor_speed_std_rad_s", "power_std_w", "platform_pitch_std_deg")
        },
        "wave_ff_rotor_speed_variance_reduction_pct": {
            lc: {
                "bench": 100.0
                * (
                    1.0
                    - runs[f"iea15mw-{lc}-lqri-ff"]["rotor_speed_var_rad2_s2"]
                    / runs[f"iea15mw-{lc}-lqri"]["rotor_speed_var_rad2_s2"]
                ),
                "al_2019": ref,
            }
            for lc, ref in (("lc1", 41.0), ("lc2", 22.0))
        },
    }


def main() -> None:
    """Run the parts asked for, print and save the figures."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--only", choices=("replay", "realtime", "comparison"), default=None)
    parser.add_argument("--duration", type=float, default=None, help="part c override, s")
    parser.add_argument("--replay-duration", type=float, default=300.0, help="part a, s")
    parser.add_argument("--realtime-duration", type=float, default=60.0, help="part b, s")
    parser.add_argument(
        "--realtime-priority", type=int, default=0, help="part b: SCHED_FIFO priority"
    )
    args = parser.parse_args()
    load_before = os.getloadavg()
    result: dict[str, Any] = {
        "machine": machine(),
        "load_average_before": list(load_before),
        "reference": {"rosco_compiled_us_per_call": ROSCO_US_PER_CALL},
        "targets": {"deadline_misses": 0, "compute_p99_us_max": COMPUTE_P99_TARGET_US},
    }
    t0 = time.monotonic()
    if args.only in (None, "replay"):
        result["replay_compute"] = {}
        for rate in RATES:
            r = replay(rate, args.replay_duration)
            result["replay_compute"][rate] = r
            print("replay", rate, r)
    if args.only in (None, "realtime"):
        result["realtime"] = {}
        for rate in RATES:
            r = realtime(rate, args.realtime_duration, args.realtime_priority)
            r["realtime_priority"] = args.realtime_priority
            result["realtime"][rate] = r
            print("realtime", rate, r)
    if args.only in (None, "comparison"):
        result.update(comparison(args.duration))
        print("above rated:", result["above_rated_lqri_vs_baseline"])
        print("wave FF:", result["wave_ff_rotor_speed_variance_reduction_pct"])
    result["load_average_after"] = list(os.getloadavg())
    result["bench_wall_s"] = round(time.monotonic() - t0, 1)
    print("load average before", load_before, "after", result["load_average_after"])
    save("advanced_controller", result)


if __name__ == "__main__":
    main()
