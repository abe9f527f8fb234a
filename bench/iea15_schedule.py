"""Benchmark: the IEA 15 MW baseline's operating schedule beside ROSCO's (steady winds).

Runs the IEA 15 MW on VolturnUS-S in process at steady winds 4..25 m/s (no turbulence,
still water, the load cases' sensors and 40 Hz control) with the bench's ``baseline``
controller (preset ``iea15mw_baseline``) and with ``rosco`` (ROSCO's compiled DISCON with
the VolturnUS-S DISCON.IN, preset ``iea15mw_volturnus``), and compares the means over the
last ``--window`` seconds of each run: rotor thrust, electrical power, blade pitch, rotor
speed, generator torque, platform surge and pitch, and the controller's wind estimate.
Acceptance of the baseline's schedule: thrust and power within 2 %, pitch within 0.2 deg
of ROSCO's at every wind. Prints the table and saves ``bench/results/iea15_schedule.json``.

    python bench/iea15_schedule.py [--duration 900] [--window 300] [--winds 4 5 ...]
        [--kinds baseline rosco]

``--kinds baseline`` reruns the baseline only and keeps the ROSCO figures of the last saved
run (same duration and window; ROSCO's figures do not depend on the bench's controller).
ROSCO prints its own progress lines to the console.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
from _common import save

from bus_schemas.messages import EST_WIND_SPEED, ControllerStatus, PlantState

WINDS = (
    4,
    5,
    6,
    7,
    8,
    9,
    10,
    10.5,
    11,
    11.5,
    12,
    13,
    14,
    15,
    16,
    17,
    18,
    19,
    20,
    21,
    22,
    23,
    24,
    25,
)
PRESETS = {"baseline": "iea15mw_baseline", "rosco": "iea15mw_volturnus"}

SCENARIO = """
name = "iea15-schedule-{kind}-{wind}"
turbine = "iea15mw"
platform = "iea15mw_volturnus"
turbine_id = "t1"
duration_s = {duration}
[wind]
kind = "steady"
speed_m_s = {wind}
[waves]
kind = "still"
gauge_distance_m = 450.0
[timing]
control_period_s = 0.025
plant_step_s = 0.0125
[sensors]
seed = 2
[sensors.channels.generator_speed_measured_rad_s]
std = 0.002
resolution = 0.001
[controller]
kind = "{kind}"
preset = "{preset}"
"""

#: PlantState fields averaged, with the unit factor applied to the reported mean.
FIELDS = {
    "thrust_kn": ("rotor_thrust_n", 1e-3),
    "power_mw": ("electrical_power_w", 1e-6),
    "pitch_deg": ("blade_pitch_rad", 180.0 / math.pi),
    "rotor_speed_rpm": ("rotor_speed_rad_s", 30.0 / math.pi),
    "generator_torque_mnm": ("generator_torque_nm", 1e-6),
    "surge_m": ("platform_surge_m", 1.0),
    "platform_pitch_deg": ("platform_pitch_rad", 180.0 / math.pi),
    "tsr": ("tip_speed_ratio", 1.0),
}


def steady_run(kind: str, wind: float, duration_s: float, window_s: float) -> dict[str, Any]:
    """One in-process run; means over the last ``window_s`` seconds (and the wall time)."""
    from hil.inprocess.run import run_inprocess
    from hil.nodes.controller_node import ControllerRuntime
    from hil.scenario.schema import parse_scenario

    text = SCENARIO.format(kind=kind, wind=wind, duration=duration_s, preset=PRESETS[kind])
    sc = parse_scenario(text)
    truth: list[PlantState] = []
    status: list[ControllerStatus] = []

    def publish(_mt: Any, msg: msgspec.Struct) -> None:
        if isinstance(msg, PlantState):
            truth.append(msg)
        elif isinstance(msg, ControllerStatus):
            status.append(msg)

    with tempfile.TemporaryDirectory(prefix="fowt-iea15-schedule-") as tmp:
        runtime = ControllerRuntime(sc, run_dir=tmp)  # ROSCO's debug files go there

        def step(frame: Any) -> Any:
            out = runtime.handle_frame(frame)
            return None if out is None else out[0]

        t0 = time.perf_counter()
        run_inprocess(sc, publish, step, runtime=runtime)
        wall = time.perf_counter() - t0
    t = np.array([m.sample_time_ns for m in truth]) / 1e9
    keep = t >= t[-1] - window_s
    out: dict[str, Any] = {}
    for key, (name, factor) in FIELDS.items():
        x = np.array([getattr(m, name) for m in truth])[keep]
        out[key] = round(float(np.mean(x)) * factor, 5)
        if key in ("thrust_kn", "pitch_deg", "power_mw"):
            out[key + "_std"] = round(float(np.std(x)) * factor, 5)
    ts = np.array([m.sample_time_ns for m in status]) / 1e9
    west = [
        m.wind_speed_estimated_m_s
        for m, tt in zip(status, ts, strict=True)
        if tt >= t[-1] - window_s and m.estimates_valid_mask & EST_WIND_SPEED
    ]
    out["wind_estimate_m_s"] = round(float(np.mean(west)), 4) if west else None
    out["wall_s"] = round(wall, 2)
    return out


def compare(base: dict[str, Any], ref: dict[str, Any]) -> dict[str, float]:
    """Baseline minus ROSCO: thrust and power in % of ROSCO's, pitch in deg."""
    return {
        "thrust_pct": round(100.0 * (base["thrust_kn"] / ref["thrust_kn"] - 1.0), 3),
        "power_pct": round(100.0 * (base["power_mw"] / ref["power_mw"] - 1.0), 3),
        "pitch_deg": round(base["pitch_deg"] - ref["pitch_deg"], 3),
        "surge_m": round(base["surge_m"] - ref["surge_m"], 3),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=900.0, help="simulated s per run")
    ap.add_argument("--window", type=float, default=300.0, help="averaging window, last s")
    ap.add_argument("--winds", type=float, nargs="+", default=list(WINDS))
    ap.add_argument("--kinds", nargs="+", choices=list(PRESETS), default=list(PRESETS))
    args = ap.parse_args()
    path = Path(__file__).resolve().parent / "results" / "iea15_schedule.json"
    old: dict[str, Any] = json.loads(path.read_text()) if path.is_file() else {}
    rows: dict[str, dict[str, Any]] = {}
    for wind in args.winds:
        key = f"{wind:g}"
        row: dict[str, Any] = {}
        for kind in PRESETS:
            if kind in args.kinds:
                row[kind] = steady_run(kind, wind, args.duration, args.window)
            else:
                prev = old.get("winds", {}).get(key, {}).get(kind)
                same = old.get("duration_s") == args.duration and old.get("window_s") == args.window
                row[kind] = prev if same else None
        if row["baseline"] is not None and row["rosco"] is not None:
            row["baseline_minus_rosco"] = compare(row["baseline"], row["rosco"])
        rows[key] = row
        print(key, json.dumps(row))
    diffs = [r["baseline_minus_rosco"] for r in rows.values() if "baseline_minus_rosco" in r]
    worst = {
        k: max((abs(d[k]) for d in diffs), default=math.nan)
        for k in ("thrust_pct", "power_pct", "pitch_deg")
    }
    result = {
        "scenario": "IEA 15 MW on VolturnUS-S, steady wind, still water, 40 Hz, in process",
        "controllers": PRESETS,
        "duration_s": args.duration,
        "window_s": args.window,
        "acceptance": "thrust and power within 2 %, pitch within 0.2 deg of ROSCO's",
        "worst_abs_difference": worst,
        "met": bool(diffs)
        and len(diffs) == len(rows)
        and worst["thrust_pct"] <= 2.0
        and worst["power_pct"] <= 2.0
        and worst["pitch_deg"] <= 0.2,
        "winds": rows,
    }
    print("worst", worst)
    save("iea15_schedule", result)


if __name__ == "__main__":
    main()
