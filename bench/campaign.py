"""Benchmark: campaign throughput on Dask with 1 and 2 local workers, and Dask's overhead.

Runs a subset of the shipped ``al2019-iea15mw`` campaign (by default load cases 1 and 4,
the baseline and the balanced wave feedforward, the baseline's still-water twins, 2 seeds,
120 s, ``--record none``) on a LocalCluster of 1, then 2 worker processes, and prints:

* throughput = Σ simulated seconds / wall seconds from the first submission to the last
  result (the cluster's start-up excluded; it is printed apart), for each worker count, and
  the ratio 2 workers / 1 worker (the target: >= 1.8 on a 2-core machine);
* the CPU share of the runs (Σ CPU time of the worker processes / Σ run wall time): below 1
  when other load on the machine takes the cores, which caps the speed-up;
* Dask's overhead per task: (a) the round trip of a no-op task on the 2-worker cluster
  (submit -> result, tasks one after the other); (b) inside the campaign, the wall time per
  run not spent in :func:`hil.campaign.runner.execute_run`,
  (workers x tasks wall − Σ run wall) / runs.

    python bench/campaign.py [--cases lc1,lc4] [--controllers baseline,lqri_ff_bp]
                             [--seeds 2] [--duration 120]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import save


def _noop(x: int) -> int:
    return x


def _campaign(args: argparse.Namespace) -> Any:
    from hil.campaign.runner import load_campaign, select

    return select(
        load_campaign("al2019-iea15mw"),
        cases=args.cases.split(","),
        controllers=args.controllers.split(","),
        seeds=args.seeds,
        duration_s=args.duration,
    )


def _measure(campaign: Any, workers: int) -> dict[str, Any]:
    from hil.campaign.runner import run_campaign

    with tempfile.TemporaryDirectory(prefix="fowt-bench-campaign-") as tmp:
        t0 = time.monotonic()
        res = run_campaign(campaign, Path(tmp), workers=workers, record="none", progress=False)
        total = time.monotonic() - t0
    sim = sum(s.scenario["duration_s"] for s in campaign.runs)
    run_wall = sum(float(r.get("wall_s", 0.0)) for r in res.results.values())
    run_cpu = sum(float(r.get("cpu_s", 0.0)) for r in res.results.values())
    failed = res.aggregates["runs"]["failed"]
    if failed:
        raise SystemExit(f"{failed} run(s) failed")
    overhead = (workers * res.tasks_wall_s - run_wall) / len(campaign.runs)
    return {
        "workers": workers,
        "runs": len(campaign.runs),
        "simulated_s": sim,
        "tasks_wall_s": res.tasks_wall_s,
        "command_wall_s": total,
        "cluster_start_and_stop_s": total - res.tasks_wall_s,
        "sum_run_wall_s": run_wall,
        "sum_run_cpu_s": run_cpu,
        "cpu_share_of_run_wall": run_cpu / run_wall if run_wall > 0 else None,
        "throughput_sim_s_per_wall_s": sim / res.tasks_wall_s,
        "overhead_per_run_s": overhead,
    }


def _noop_round_trip(n: int = 200) -> dict[str, Any]:
    import logging

    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as client,
    ):
        client.submit(_noop, -1, pure=False).result()  # warm-up
        t0 = time.monotonic()
        for i in range(n):
            client.submit(_noop, i, pure=False).result()
        serial = (time.monotonic() - t0) / n
        t0 = time.monotonic()
        futs = [client.submit(_noop, i, pure=False) for i in range(n)]
        client.gather(futs)
        batch = (time.monotonic() - t0) / n
    return {"tasks": n, "round_trip_serial_ms": 1e3 * serial, "per_task_batched_ms": 1e3 * batch}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cases", default="lc1,lc4")
    ap.add_argument("--controllers", default="baseline,lqri_ff_bp")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--duration", type=float, default=120.0)
    args = ap.parse_args()
    campaign = _campaign(args)
    one = _measure(campaign, 1)
    two = _measure(campaign, 2)
    result = {
        "campaign": "al2019-iea15mw subset",
        "cases": args.cases,
        "controllers": args.controllers,
        "seeds": args.seeds,
        "duration_s": args.duration,
        "record": "none",
        "one_worker": one,
        "two_workers": two,
        "speedup_2_over_1": two["throughput_sim_s_per_wall_s"] / one["throughput_sim_s_per_wall_s"],
        "target_speedup": 1.8,
        "noop_task": _noop_round_trip(),
    }
    save("campaign", result)


if __name__ == "__main__":
    main()
