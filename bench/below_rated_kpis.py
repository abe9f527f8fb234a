"""Below rated: baseline vs lqri vs lqri_ff on al-2019's KPIs.

Runs the shipped load cases 1 and 2 (5.0 and 7.1 m/s turbulent IEC B, their JONSWAP seas,
same seeds) for ``--duration`` (600 s) in process, written to MCAP as ``fowt run --mode
inprocess --no-plots`` does, for the three controllers (``iea15mw-lcN``, ``-lqri``,
``-lqri-ff``: the dispersion forecast from the 450 m gauge, valid after 205 s), and computes
from each MCAP file, over two windows (from ``--settle`` s, and from 235 s where the wave
feedforward acts):

* mean electrical power (MW);
* rotor-speed variance about the optimal speed, mean((ω - ω_opt)²) with
  ω_opt = clip(λ_opt U / R, ω_min, ω_rated), U the rotor-effective wind of the truth channel,
  λ_opt of the plant's Cp table, ω_min = 5 rpm (al-2019's rotor-speed KPI);
* tower-base fore-aft and low-speed-shaft DELs (Wöhler m = 4, 1 Hz, as ``fowt review``);
* pitch travel (deg/s) and platform pitch std (deg);
* the envelope check of :mod:`hil.campaign.envelope` (from ``--settle``).

Prints the table and saves ``bench/results/below_rated_kpis.json``.

    python bench/below_rated_kpis.py [--duration 600] [--settle 60] [--cases 1 2]
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from _common import save

from controller.baseline import load_baseline
from hil.campaign.envelope import EnvelopeLimits, check_envelope, run_inprocess_logged
from hil.review import kpi
from hil.review.core import DEL_N_EQ_HZ, SHAFT_WOHLER_M
from hil.runlog.mcap_io import RunData
from hil.scenario.schema import scenario_text
from plant.platform import load_floating

CONTROLLERS = {"baseline": "", "lqri": "-lqri", "lqri_ff": "-lqri-ff"}
FF_FROM_S = 235.0  # dispersion forecast valid from 204.8 s, 30 s for the FF filters


def _kpis(run: RunData, start_s: float, tsr: float, radius_m: float) -> dict[str, float]:
    truth = run.topic("truth")
    t = np.array([m["sample_time_ns"] for m in truth]) / 1e9
    keep = t >= start_s

    def col(name: str) -> np.ndarray:
        return np.array([m[name] for m in truth], dtype=np.float64)[keep]

    lim = EnvelopeLimits.from_baseline(load_baseline("iea15mw_baseline"))
    w = col("rotor_speed_rad_s")
    w_opt = np.clip(
        tsr * col("wind_speed_m_s") / radius_m,
        lim.min_rotor_speed_rad_s,
        lim.rated_rotor_speed_rad_s,
    )
    tk = t[keep]
    return {
        "mean_power_mw": kpi.mean_power_w(col("electrical_power_w")) / 1e6,
        "rotor_speed_var_about_opt_rad2_s2": float(np.mean((w - w_opt) ** 2)),
        "tower_base_del_mnm": kpi.damage_equivalent_load(
            col("tower_base_moment_nm"), tk, SHAFT_WOHLER_M, DEL_N_EQ_HZ
        )
        / 1e6,
        "shaft_del_mnm": kpi.damage_equivalent_load(
            col("shaft_torque_nm"), tk, SHAFT_WOHLER_M, DEL_N_EQ_HZ
        )
        / 1e6,
        "pitch_travel_deg_s": kpi.pitch_travel_deg_s(tk, col("blade_pitch_rad")),
        "platform_pitch_std_deg": math.degrees(float(np.std(col("platform_pitch_rad")))),
        "rotor_speed_min_rpm": float(np.min(w) * 30.0 / math.pi),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--settle", type=float, default=60.0)
    ap.add_argument("--cases", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    turbine = load_floating("iea15mw_volturnus").turbine
    tsr, radius = float(turbine.table.optimal_tsr()), float(turbine.rotor_radius_m)
    lim = EnvelopeLimits.from_baseline(load_baseline("iea15mw_baseline"), settle_s=args.settle)
    results: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="fowt-kpis-") as tmp:
        for case in args.cases:
            for kind, suffix in CONTROLLERS.items():
                name = f"iea15mw-lc{case}{suffix}"
                t0 = time.monotonic()
                _, run = run_inprocess_logged(
                    scenario_text(name)[0], Path(tmp) / name, args.duration
                )
                env = check_envelope(run, lim)
                results[name] = {
                    "case": case,
                    "controller": kind,
                    "from_settle": _kpis(run, args.settle, tsr, radius),
                    "from_ff_valid": _kpis(run, FF_FROM_S, tsr, radius),
                    "envelope_violations": env["violations"],
                    "envelope": env["figures"],
                    "wall_s": round(time.monotonic() - t0, 1),
                }
    cols = [
        ("mean_power_mw", "P MW", 3),
        ("rotor_speed_var_about_opt_rad2_s2", "var(w-wopt)", 6),
        ("tower_base_del_mnm", "TB DEL", 2),
        ("shaft_del_mnm", "shaft DEL", 3),
        ("pitch_travel_deg_s", "pitch deg/s", 3),
        ("platform_pitch_std_deg", "ptfm std deg", 3),
        ("rotor_speed_min_rpm", "min rpm", 2),
    ]
    for window in ("from_settle", "from_ff_valid"):
        print(f"\n{window} ({args.settle if window == 'from_settle' else FF_FROM_S:g} s on)")
        print(f"{'run':24s}" + "".join(f"{c[1]:>13s}" for c in cols))
        for name, r in results.items():
            k = r[window]
            print(f"{name:24s}" + "".join(f"{k[c[0]]:13.{c[2]}f}" for c in cols))
    save(
        "below_rated_kpis",
        {
            "duration_s": args.duration,
            "settle_s": args.settle,
            "ff_valid_from_s": FF_FROM_S,
            "optimal_tsr": tsr,
            "runs": results,
        },
    )


if __name__ == "__main__":
    main()
