"""Hexicon H3 benchmark: cost of a plant step, a wake evaluation, FLORIS and the MPC solve,
and the MPC vs bang-bang campaign over table 6 and the sensitivity cases (in process).

    .venv/bin/python bench/hexicon.py            # everything -> bench/results/hexicon.json
    .venv/bin/python bench/hexicon.py --costs    # only the per-call costs

FLORIS is a dev dependency; its per-call cost is measured when it is installed.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench._common import machine, save
from hil.hexicon.model import (
    CONTROLLERS,
    compute_kpis,
    initial_state,
    load_scenarios,
    plant_input,
    run_in_process,
)
from plant.hexicon.model import load_hexicon, step_rk4
from plant.hexicon.wakes import jensen_speed_factors


def _per_call(fn: Any, n: int) -> float:
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t0) / n


def costs() -> dict[str, float]:
    """Median-of-5 per-call wall time (us) of the hot paths."""
    p = load_hexicon()
    x = initial_state(p, 15.0)
    from controller.hexicon import HexiconCommand

    cmd = HexiconCommand((x[3], x[6], x[9]), (x[4], x[7], x[10]))
    u = plant_input(cmd, 15.0, math.radians(140.0))
    xs, ys = p.turbine_x_m, p.turbine_y_m
    res: dict[str, float] = {}
    res["plant_rk4_step_us"] = (
        1e6 * sorted(_per_call(lambda: step_rk4(x, u, 0.05, p), 500) for _ in range(5))[2]
    )
    res["jensen_eval_us"] = (
        1e6
        * sorted(
            _per_call(
                lambda: jensen_speed_factors(
                    xs, ys, math.radians(140.0), (0.5, 0.5, 0.5), 154.0, 0.05
                ),
                2000,
            )
            for _ in range(5)
        )[2]
    )
    res["jensen_eval_two_wakes_us"] = (
        1e6
        * sorted(
            _per_call(
                lambda: jensen_speed_factors(
                    (0.0, 462.0, 924.0),
                    (0.0, 77.0, -46.0),
                    math.radians(180.0),
                    (0.5,) * 3,
                    154.0,
                    0.05,
                ),
                200,
            )
            for _ in range(5)
        )[2]
    )
    try:
        import floris  # noqa: F401

        sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
        from test_hexicon import _floris_factors  # type: ignore[import-not-found]

        t0 = time.perf_counter()
        _floris_factors(xs, ys, 140.0, 0.5, n_grid=3)
        res["floris_setup_run_sample_ms"] = 1e3 * (time.perf_counter() - t0)
        import floris as fl

        fm = fl.FlorisModel("defaults")
        fm.set(
            layout_x=list(xs),
            layout_y=list(ys),
            wind_speeds=[10.0],
            wind_directions=[270.0],
            turbulence_intensities=[0.06],
        )
        fm.core.wake.model_strings["velocity_model"] = "jensen"
        fm.run()
        res["floris_run_ms"] = 1e3 * sorted(_per_call(fm.run, 20) for _ in range(5))[2]
    except ImportError:
        res["floris_run_ms"] = float("nan")
    from controller.hexicon import HexiconMeasurement, load_design, make_mpc, mpc_step

    st = make_mpc(load_design())
    times = []
    for k in range(300):
        m = HexiconMeasurement(0.0, 0.0, math.radians(15.0 * (k % 50 < 25)), 15.0, (1.0, 1.0, 1.0))
        st, _, info = mpc_step(st, m, 1.0)
        times.append(info["solve_s"])
    times.sort()
    res["mpc_solve_p50_ms"] = 1e3 * times[len(times) // 2]
    res["mpc_solve_p99_ms"] = 1e3 * times[int(0.99 * len(times))]
    res["mpc_solve_max_ms"] = 1e3 * times[-1]
    from controller.hexicon import id_mpc_step, load_identified, make_id_mpc

    sti = make_id_mpc(load_design(), load_identified())
    times = []
    for k in range(300):
        m = HexiconMeasurement(0.0, 0.0, math.radians(15.0 * (k % 50 < 25)), 15.0, (1.0, 1.0, 1.0))
        sti, _, info = id_mpc_step(sti, m, 18e6, 1.0)
        times.append(info["solve_s"])
    times.sort()
    res["mpc_id_solve_p50_ms"] = 1e3 * times[len(times) // 2]
    res["mpc_id_solve_p99_ms"] = 1e3 * times[int(0.99 * len(times))]
    res["mpc_id_overruns_of_300"] = float(sti.overruns)
    return res


def campaign(
    noise: bool = True, names: tuple[str, ...] | None = None
) -> dict[str, dict[str, dict[str, float]]]:
    """Every controller on every scenario (in process; ``noise``: the preset's sensors)."""
    out: dict[str, dict[str, dict[str, float]]] = {}
    for name, scn in load_scenarios().items():
        if names is not None and name not in names:
            continue
        out[name] = {}
        for c in CONTROLLERS:
            out[name][c] = compute_kpis(run_in_process(scn, c, noise=noise), scn)
    return out


def table(res: dict[str, dict[str, dict[str, float]]]) -> str:
    cols = [
        ("heading_rms_deg", "RMS e [deg]", "{:.2f}"),
        ("overshoot_deg", "overshoot [deg]", "{:.2f}"),
        ("settling_time_s", "settle 1deg [s]", "{:.0f}"),
        ("energy_ratio", "E/E_wakefree", "{:.3f}"),
        ("pitch_travel_deg", "pitch travel [deg]", "{:.0f}"),
        ("constraint_violations", "violations", "{:.0f}"),
        ("solve_p99_ms", "QP p99 [ms]", "{:.1f}"),
        ("overruns", "overruns", "{:.0f}"),
    ]
    lines = ["| scenario | controller | " + " | ".join(c[1] for c in cols) + " |"]
    lines.append("|" + "---|" * (len(cols) + 2))
    for name, by_c in res.items():
        for c, k in by_c.items():
            vals = " | ".join(fmt.format(k[key]) for key, _, fmt in cols)
            lines.append(f"| {name} | {c} | {vals} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--costs", action="store_true", help="only the per-call costs")
    a = ap.parse_args()
    result: dict[str, Any] = {"machine": machine(), "costs": costs()}
    print(result["costs"])
    if not a.costs:
        result["campaign"] = campaign()
        result["table_markdown"] = table(result["campaign"])
        print(result["table_markdown"])
        result["campaign_noise_free"] = campaign(False, ("s1_step15", "s3_dirramp10"))
        result["table_markdown_noise_free"] = table(result["campaign_noise_free"])
        print(result["table_markdown_noise_free"])
    print(f"saved {save('hexicon' if not a.costs else 'hexicon_costs', result)}")


if __name__ == "__main__":
    main()
