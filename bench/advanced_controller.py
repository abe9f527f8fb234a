"""Advanced controller (observers + wave forecast + LQRI [+ wave FF]) against its references.

In process (``hil.plant_node.run_inprocess`` with the node's ``ControllerRuntime``), full
length of the shipped scenarios (600 s), same seeds per pair; statistics after ``SETTLE_S``:

* issue 4 above rated: ``iea15mw-lqri-15`` vs ``iea15mw-baseline-15`` (15 m/s IEC B,
  Hs 3 m, Tp 9.5 s): rotor-speed, power and platform-pitch standard deviations;
* wave FF below rated: ``iea15mw-lc1/2-lqri-ff`` vs ``iea15mw-lc1/2-lqri``: rotor-speed
  variance reduction, next to al-2019's 41 % (LC1) and 22 % (LC2);
* per scenario: the controller's cycle compute time (p50, p99, max, us), the wind-estimate
  error and the forecast VAF against the truth.

Usage: ``python bench/advanced_controller.py [--duration S]``; prints and saves
``bench/results/advanced_controller.json``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _common import machine, save

from bus_schemas import ActuatorCommand, ControllerStatus, PlantState, SensorFrame
from bus_schemas.messages import EST_WAVE_FORECAST
from bus_schemas.registry import TRUTH, MessageType
from hil.controller_node import ControllerRuntime
from hil.plant_node import run_inprocess
from hil.scenario import load_scenario

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


def main() -> None:
    """Run the pairs, print and save the figures."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--duration", type=float, default=None, help="override, s")
    args = parser.parse_args()
    runs = {
        n: run(n, args.duration)
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
    result: dict[str, Any] = {
        "machine": machine(),
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
    for name, r in runs.items():
        print(name, {k: v for k, v in r.items() if k != "scenario"})
    print("above rated:", result["above_rated_lqri_vs_baseline"])
    print("wave FF:", result["wave_ff_rotor_speed_variance_reduction_pct"])
    print("saved", save("advanced_controller", result))


if __name__ == "__main__":
    main()
