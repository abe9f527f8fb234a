"""Two hosts through the router: records lost with Zenoh's default transport vs low-latency.

Runs the set-up of ``docs/multi-host.md`` in two network namespaces (as
``tests/test_multi_host.py`` does, with its harness ``tests/_two_hosts.py``): router and
plant in one, controller and recorder in the other, mutual TLS and the access control on.
For each transport setting it makes ``--runs`` lock-step runs of ``--scenario`` for
``--duration`` simulated seconds and counts, per message type, how many of the plant's
cycles the recorder got (the frames and commands the lock-step plant waited for cannot go
missing; the other records can be dropped on a full transmission queue):

* ``lowlatency``: the shipped files (``transport/unicast/lowlatency: true``, QoS off);
* ``default``: the same files without that line (Zenoh's batching transport with QoS).

A run whose plant aborts (a lost frame or command leaves the lock-step plant waiting until
its 10-s timeout) is counted as failed, with the node's last log line.

Prints and saves ``bench/results/multihost_transport.json``. Needs root, ``ip``,
``openssl`` and ``bash``.

    python bench/multihost_transport.py [--runs 3] [--scenario default] [--duration 10]
        [--only lowlatency|default]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from _common import machine, save
from _two_hosts import NamespacesUnavailableError, stop, two_hosts

from hil.runlog.mcap_io import read_run
from hil.scenario.schema import load_scenario

LOWLATENCY_LINE = "    unicast: { lowlatency: true, qos: { enabled: false } },\n"
TOPICS = ("sensors", "command", "truth", "controller/status", "timing/cycle")


def without_lowlatency(_name: str, text: str) -> str:
    """A config with the low-latency transport line removed (Zenoh's default transport)."""
    if LOWLATENCY_LINE not in text:
        raise SystemExit("config/zenoh-*.json5 no longer carry the lowlatency line this edits")
    return text.replace(LOWLATENCY_LINE, "")


def lost_records(mcap: Path, cycles: int) -> dict[str, int]:
    """Per topic, the cycles of the run whose record the recorder did not write."""
    data = read_run(mcap)
    return {t: cycles - len({m["seq"] for m in data.topic(t)}) for t in TOPICS}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--scenario", default="default")
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--only", choices=("lowlatency", "default"), default=None)
    args = ap.parse_args()
    cycles = round(args.duration / load_scenario(args.scenario).timing.control_period_s)
    results: dict[str, Any] = {}
    for setting, edit in (("lowlatency", None), ("default", without_lowlatency)):
        if args.only and setting != args.only:
            continue
        runs = []
        with tempfile.TemporaryDirectory(prefix="fowt-multihost-") as tmp:
            try:
                with two_hosts(Path(tmp), edit) as h:
                    for i in range(args.runs):
                        t0 = time.monotonic()
                        out = Path(tmp) / f"r{i}"
                        try:
                            mcap = h.lockstep_run(args.scenario, args.duration, out)
                        except AssertionError as exc:  # a node failed: say which and why
                            lines = str(exc).strip().splitlines()
                            logs = {
                                n: (out / f"{n}.log").read_text().strip().splitlines()[-1:]
                                for n in ("controller", "recorder")
                                if (out / f"{n}.log").is_file()
                            }
                            failed = f"{lines[0]} {lines[-1]}"
                            runs.append({"failed": failed, "logs": logs, "lost": {}})
                            for p in h.procs[-3:]:  # this run's nodes, if still up
                                stop(p)
                        else:
                            wall = time.monotonic() - t0
                            lost = lost_records(mcap, cycles)
                            runs.append({"lost": lost, "wall_s": round(wall, 2)})
                        print(setting, i, runs[-1], flush=True)
            except NamespacesUnavailableError as exc:
                raise SystemExit(f"two network namespaces cannot be made here: {exc}") from exc
        total = {t: sum(r["lost"].get(t, 0) for r in runs) for t in TOPICS}
        results[setting] = {
            "runs": runs,
            "lost_total": total,
            "records_expected_per_topic": cycles * args.runs,
            "runs_with_loss": sum(any(r["lost"].values()) for r in runs),
            "runs_failed": sum("failed" in r for r in runs),
        }
        print(setting, "lost in all runs:", total, flush=True)
    save(
        "multihost_transport" + (f"_{args.only}" if args.only else ""),
        {
            "scenario": args.scenario,
            "duration_s": args.duration,
            "cycles_per_run": cycles,
            "settings": results,
            "machine": machine(),
        },
    )


if __name__ == "__main__":
    main()
