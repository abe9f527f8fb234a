"""Soak benchmark: a long real-time run at 100 Hz with a CPU hog on the other core.

The default floating scenario (IEA 15 MW on VolturnUS-S, load case 2) at 100 Hz (control
period and plant step 0.01 s) runs in real time (speed 1) for ``--duration`` seconds (600 s:
10 minutes) as ``fowt run`` runs it: plant, controller and recorder as separate
processes over Zenoh. Meanwhile a CPU-bound process (a pure-Python busy loop) runs on the
other core: with ``--pin`` (default) the bench's processes are pinned to core 0 and the hog
to core 1, so the bench has exactly one core; ``--no-pin`` lets the scheduler place them.

Prints and saves ``bench/results/soak.json``: deadline misses, commands late and held,
safe-state entries, sensor-to-command latency p50/p99/p99.9/max [us], the controller's
compute time, and the hog's CPU time (proof it ran). The same over CAN where available:
``fowt run --transport can`` is probed first; while it is refused (CAN is not yet a
two-process transport of the launcher) the CAN entry records that and why.

    python bench/soak.py [--duration 600] [--scenario default] [--no-pin]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import run_fowt, save, scenario_variant

HOG = "while True:\n    pass\n"


def _start_hog(core: int | None) -> subprocess.Popen[bytes]:
    hog = subprocess.Popen([sys.executable, "-c", HOG])
    if core is not None:
        os.sched_setaffinity(hog.pid, {core})
    return hog


def _cpu_s(pid: int) -> float:
    """User + system CPU seconds of a running process (from /proc)."""
    with open(f"/proc/{pid}/stat") as fh:
        fields = fh.read()
    values = fields.rsplit(")", 1)[1].split()
    return (int(values[11]) + int(values[12])) / os.sysconf("SC_CLK_TCK")


def _figures(summary: dict[str, Any], duration_s: float) -> dict[str, Any]:
    t = summary["timing"]
    cycles = t["cycles"] or 0
    return {
        "duration_s": duration_s,
        "cycles": cycles,
        "deadline_misses": t["deadline_misses"],
        "deadline_miss_fraction": (t["deadline_misses"] / cycles) if cycles else None,
        "commands_late": t["commands_late"],
        "commands_held": t["commands_held"],
        "safe_state": t["safe_state"],
        "latency_us": t["latency_us"],
        "latency_us_plant": t.get("latency_us_plant"),
        "controller_compute_us": t.get("controller_compute_us"),
        "sim_seconds_per_wall_second": t.get("sim_seconds_per_wall_second"),
        "complete": t.get("complete"),
    }


def _can_probe(scenario: str) -> dict[str, Any]:
    """Is ``fowt run --transport can`` accepted? (A refused run costs about a second.)"""
    with tempfile.TemporaryDirectory(prefix="fowt-can-probe-") as tmp:
        proc = subprocess.run(
            [
                sys.executable,
                "-m",
                "hil",
                "run",
                scenario,
                "--transport",
                "can",
                "--mode",
                "realtime",
                "--duration",
                "0.05",
                "--no-plots",
                "--out",
                tmp,
            ],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
    out = " ".join((proc.stdout + proc.stderr).split())
    return {"available": proc.returncode == 0, "probe_exit_code": proc.returncode, "message": out}


def _soak(
    path: Path, duration_s: float, bench_core: int | None, hog_core: int | None, extra: list[str]
) -> dict[str, Any]:
    """One soak run with the CPU hog on the other core; its figures."""
    original = os.sched_getaffinity(0)
    hog = _start_hog(hog_core)
    try:
        if bench_core is not None:
            os.sched_setaffinity(0, {bench_core})  # the run's processes inherit it
        t0 = time.monotonic()
        summary = run_fowt(str(path), "realtime", duration_s, extra)
        wall = time.monotonic() - t0
        hog_cpu = _cpu_s(hog.pid)
    finally:
        os.sched_setaffinity(0, original)
        hog.kill()
        hog.wait()
    out = {**_figures(summary, duration_s), "hog_cpu_s": round(hog_cpu, 1)}
    out["hog_cpu_fraction_of_run"] = round(hog_cpu / wall, 3) if wall > 0 else None
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=600.0, help="simulated = wall seconds")
    ap.add_argument("--scenario", default="default", help="shipped scenario, run at 100 Hz")
    ap.add_argument("--pin", action=argparse.BooleanOptionalAction, default=True)
    ap.add_argument(
        "--realtime-priority", type=int, default=0, help="SCHED_FIFO for plant and controller"
    )
    args = ap.parse_args()
    cores = sorted(os.sched_getaffinity(0))
    pin = args.pin and len(cores) >= 2
    bench_core, hog_core = (cores[0], cores[-1]) if pin else (None, None)
    path = scenario_variant(args.scenario, 0.01, 0.01)
    rt = ["--realtime-priority", str(args.realtime_priority)] if args.realtime_priority else []
    zenoh = _soak(path, args.duration, bench_core, hog_core, rt)
    print("zenoh", zenoh)
    can = _can_probe(args.scenario)
    if can["available"]:
        # udp_multicast inside the private network namespace the launcher makes.
        can.update(_soak(path, args.duration, bench_core, hog_core, ["--transport", "can", *rt]))
    else:
        can["note"] = "fowt run --transport can was refused here (see message)"
    print("can", can)
    save(
        "soak",
        {
            "scenario": args.scenario,
            "control_rate_hz": 100,
            "mode": "realtime",
            "speed": 1.0,
            "realtime_priority": args.realtime_priority,
            "pinned": {"bench_core": bench_core, "hog_core": hog_core} if pin else None,
            "cpu_hog": "pure-Python busy loop, one process",
            "zenoh": zenoh,
            "can": can,
        },
    )


if __name__ == "__main__":
    main()
