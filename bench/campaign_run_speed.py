"""Benchmark: one campaign run (:func:`hil.campaign.runner.execute_run`), 600 s of load case 2.

A campaign worker's run in process: build the plant and controller, run 600 s of the
shipped ``al2019-iea15mw`` campaign's ``lc2`` case (seed 0, waves) with the controller
variants ``lqri_ff_bp`` (all observers, forecaster, wave feedforward, LQRI) and ``baseline``,
keep its messages, review them (``summarize``) and compute the campaign KPIs
(``run_kpis_of``); with ``--record mcap`` also write ``run.mcap``, with ``none`` not.
Measured per run: the wall time and this process's CPU time of ``execute_run`` (both
include the set-up; with ``mcap`` the file is written in the same process, as a Dask
worker does it), and the speed 600 s / wall.

Each measurement runs in a child process (``--child``) of the code under test; with
``--compare-python PY --compare-root DIR`` (e.g. main's venv and checkout) the children of
this code and of DIR's code alternate ``--rounds`` times in one run, as
bench/inprocess_speed.py does, since the shared machine's load changes from minute to minute.
In each child the first ``execute_run`` (numba's caches loaded, imports) is reported apart
as ``first_wall_s``; then ``--repeat`` runs per record mode, alternating none / mcap. The
load average (1 min) is saved with every round. Figures: per code, configuration and record
mode the median and best wall and CPU over all rounds, and the ratio of the medians.

    python bench/campaign_run_speed.py --compare-python REF/.venv/bin/python \\
        --compare-root REF [--rounds 3] [--repeat 2] [--duration 600]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import Code, add_compare_args, codes, order, run_child, save

CONTROLLERS = ("lqri_ff_bp", "baseline")
RECORDS = ("none", "mcap")


def _child(duration_s: float, repeat: int, controller: str) -> dict[str, Any]:
    """Run in the code under test: the first run, then ``repeat`` runs per record mode."""
    from hil.campaign.runner import execute_run, load_campaign

    camp = load_campaign("al2019-iea15mw")
    spec = next(
        s
        for s in camp.runs
        if s.case == "lc2" and s.controller == controller and s.waves == "waves" and s.seed == 0
    )
    sc = dict(spec.scenario)
    sc["duration_s"] = duration_s
    out: dict[str, Any] = {"label": spec.label, "runs": {r: [] for r in RECORDS}}
    with tempfile.TemporaryDirectory(prefix="fowt-bench-camp-") as tmp:

        def one(record: str, i: int) -> dict[str, Any]:
            payload = {
                "scenario": sc,
                "mode": "inprocess",
                "run_dir": str(Path(tmp) / f"{record}{i}"),
                "record": record,
                "design_dir": None,
                "min_rotor_speed_rad_s": None,
            }
            t0, c0 = time.monotonic(), time.process_time()
            r = execute_run(payload)
            wall, cpu = time.monotonic() - t0, time.process_time() - c0
            if r["status"] != "ok":
                raise SystemExit(f"run failed: {r['error']}\n{r['traceback']}")
            mcap = Path(payload["run_dir"]) / "run.mcap"
            return {
                "wall_s": wall,
                "cpu_s": cpu,
                "speed_x": duration_s / wall,
                "mcap_bytes": mcap.stat().st_size if mcap.exists() else 0,
                "mean_power_w": r["kpi"].get("mean_power_w"),
                "load_1min": os.getloadavg()[0],
            }

        first = one("none", 0)
        out["first_wall_s"] = first["wall_s"]
        for i in range(repeat):
            for record in RECORDS:
                out["runs"][record].append(one(record, i + 1))
    return out


def _spawn(code: Code, args: argparse.Namespace, controller: str) -> dict[str, Any]:
    argv = [str(Path(__file__).resolve()), "--child", "--controller", controller]
    argv += ["--duration", str(args.duration), "--repeat", str(args.repeat)]
    return run_child(code, argv)


def _stats(runs: list[dict[str, Any]]) -> dict[str, Any]:
    walls = [r["wall_s"] for r in runs]
    cpus = [r["cpu_s"] for r in runs]
    return {
        "n": len(runs),
        "wall_s_median": statistics.median(walls),
        "wall_s_best": min(walls),
        "cpu_s_median": statistics.median(cpus),
        "cpu_s_best": min(cpus),
        "speed_x_median": statistics.median(r["speed_x"] for r in runs),
        "speed_x_best": max(r["speed_x"] for r in runs),
        "load_1min": [round(r["load_1min"], 2) for r in runs],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--repeat", type=int, default=2, help="runs per record mode per child")
    ap.add_argument("--rounds", type=int, default=3)
    add_compare_args(ap)
    ap.add_argument("--save-as", default="campaign_run_speed")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--controller", default=CONTROLLERS[0], help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(_child(args.duration, args.repeat, args.controller)))
        return
    sides = codes(args)
    rounds: list[dict[str, Any]] = []
    runs: dict[str, dict[str, dict[str, list[dict[str, Any]]]]] = {
        code: {c: {r: [] for r in RECORDS} for c in CONTROLLERS} for code in sides
    }
    firsts: dict[str, dict[str, list[float]]] = {
        code: {c: [] for c in CONTROLLERS} for code in sides
    }
    for k in range(args.rounds):
        for controller in CONTROLLERS:
            for code in order(list(sides), k):
                root = sides[code].root
                load0 = os.getloadavg()[0]
                res = _spawn(sides[code], args, controller)
                rounds.append(
                    {
                        "round": k,
                        "code": code,
                        "root": str(root),
                        "controller": controller,
                        "load_1min_before": load0,
                        **res,
                    }
                )
                firsts[code][controller].append(res["first_wall_s"])
                for r in RECORDS:
                    runs[code][controller][r].extend(res["runs"][r])
                med = {
                    r: round(statistics.median(x["wall_s"] for x in res["runs"][r]), 3)
                    for r in RECORDS
                }
                print(f"round {k} {code:8s} {controller:11s} wall median {med} load {load0:.2f}")
    summary: dict[str, Any] = {}
    for controller in CONTROLLERS:
        for r in RECORDS:
            entry = {code: _stats(runs[code][controller][r]) for code in sides}
            if "compare" in sides:
                a, b = entry["this"], entry["compare"]
                entry["wall_ratio_compare_over_this"] = b["wall_s_median"] / a["wall_s_median"]
                entry["cpu_ratio_compare_over_this"] = b["cpu_s_median"] / a["cpu_s_median"]
            summary[f"{controller}/{r}"] = entry
    for key, entry in summary.items():
        line = " ".join(
            f"{code}: wall {e['wall_s_median']:.2f} s cpu {e['cpu_s_median']:.2f} s "
            f"({e['speed_x_median']:.0f}x)"
            for code, e in entry.items()
            if isinstance(e, dict)
        )
        print(f"{key:22s} {line}")
    save(
        args.save_as,
        {
            "duration_s": args.duration,
            "repeat": args.repeat,
            "rounds_n": args.rounds,
            "codes": {k: str(v.root) for k, v in sides.items()},
            "summary": summary,
            "first_wall_s": firsts,
            "rounds": rounds,
        },
    )


if __name__ == "__main__":
    main()
