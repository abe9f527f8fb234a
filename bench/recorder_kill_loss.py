"""What a SIGKILL of the recorder loses, in simulated seconds, in real time under load.

A real-time run of ``nrel5mw-ramp`` (speed 1, 100 Hz) as ``fowt run`` starts it (plant,
controller and recorder processes over Zenoh on loopback, the recorder niced as the
launcher nices it: ``$FOWT_RECORDER_NICE``, default 10), beside N CPU hogs (``python -c
'while True: pass'``), and a monitor session in this process that follows the sensor
frames, truth and controller status on the bus. At ``--kill-at`` seconds the recorder gets
SIGKILL; the newest sample time the monitor had seen per topic is the kill's time. The
loss per topic is that minus the newest sample time in the cut file [simulated s]
(:func:`hil.runlog.mcap_io.read_run` reads it up to its last flushed chunk). Repeated
``--rounds`` times; prints and saves each round and the maximum per topic to
``bench/results/recorder_kill_loss.json`` with the commit and the load.

    python bench/recorder_kill_loss.py [--rounds 8] [--hogs 2] [--kill-at 4]
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _common import commit, load, save

from bus_schemas.registry import CONTROLLER_STATUS, SENSORS, TRUTH, MessageType
from hil.launch import RECORDER_NICE
from hil.nodes.bus import (
    CONTROLLER_BATCH_SUFFIX,
    PLANT_BATCH_SUFFIX,
    Bus,
    BusConfig,
    batch_key,
    free_tcp_endpoint,
    unbatching,
)
from hil.runlog.mcap_io import read_run

SCENARIO = "nrel5mw-ramp"
TOPICS = (SENSORS, TRUTH, CONTROLLER_STATUS)


class Monitor:
    """Newest sample time seen on the bus per topic (its own Zenoh session)."""

    def __init__(self, connect: tuple[str, ...]) -> None:
        self.latest = {mt.key_suffix: -1 for mt in TOPICS}
        self._lock = threading.Lock()
        self.bus = Bus(BusConfig(connect=connect))
        self.bus.subscribe(SENSORS.key("t1"), self._on(SENSORS))
        batched = ((TRUTH, PLANT_BATCH_SUFFIX), (CONTROLLER_STATUS, CONTROLLER_BATCH_SUFFIX))
        for mt, suffix in batched:
            self.bus.subscribe(batch_key("t1", suffix), unbatching(mt, self._on(mt), "t1"))

    def _on(self, mt: MessageType) -> Callable[[str, bytes], None]:
        def on_sample(_key: str, payload: bytes) -> None:
            t = mt.codec.decode(payload).sample_time_ns
            with self._lock:
                self.latest[mt.key_suffix] = max(self.latest[mt.key_suffix], t)

        return on_sample

    def snapshot(self) -> dict[str, float]:
        with self._lock:
            return {k: v / 1e9 for k, v in self.latest.items()}


def one_round(tmp: Path, kill_at_s: float, duration_s: float) -> dict[str, Any]:
    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    base = [sys.executable, "-m", "hil"]
    dur = ["--duration", str(duration_s)]
    mcap = tmp / "run.mcap"
    cmds = {
        "recorder": [*base, "record", SCENARIO, *dur, "--out", str(mcap),
                     "--connect", plant_ep, "--connect", ctrl_ep],
        "controller": [*base, "controller", SCENARIO, *dur, "--listen", ctrl_ep,
                       "--connect", plant_ep, "--await-recorder", "30"],
        "plant": [*base, "plant", SCENARIO, *dur, "--listen", plant_ep, "--mode", "realtime",
                  "--require", "controller,recorder"],
    }  # fmt: skip
    procs: dict[str, subprocess.Popen[bytes]] = {}
    for name, cmd in cmds.items():
        nice = RECORDER_NICE if name == "recorder" else 0
        procs[name] = subprocess.Popen(
            cmd,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            preexec_fn=(lambda n=nice: os.nice(n)) if nice else None,  # noqa: PLW1509
        )
    monitor = Monitor((plant_ep, ctrl_ep))
    try:
        deadline = time.monotonic() + 120
        while monitor.snapshot()["sensors"] < kill_at_s:
            if time.monotonic() > deadline:
                raise SystemExit("the run did not start")
            time.sleep(0.005)
        procs["recorder"].send_signal(signal.SIGKILL)
        at_kill = monitor.snapshot()
        procs["recorder"].wait(10)
    finally:
        monitor.bus.close()
        for p in procs.values():
            if p.poll() is None:
                p.terminate()
                p.wait(30)
    run = read_run(mcap)
    in_file = {
        t: max((m["sample_time_ns"] for m in run.topic(t)), default=0) / 1e9 for t in at_kill
    }
    loss = {t: round(max(0.0, at_kill[t] - in_file[t]), 3) for t in at_kill}
    print(f"SIGKILL at {at_kill['sensors']:.2f} s simulated: lost {loss} s", flush=True)
    return {"at_kill_s": at_kill, "newest_in_file_s": in_file, "loss_s": loss}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=8)
    ap.add_argument("--hogs", type=int, default=2)
    ap.add_argument("--kill-at", type=float, default=4.0, help="simulated s [s]")
    a = ap.parse_args()
    load_before = load()
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(a.hogs)]
    rounds = []
    try:
        for _ in range(a.rounds):
            with tempfile.TemporaryDirectory(prefix="fowt-bench-") as tmp:
                rounds.append(one_round(Path(tmp), a.kill_at, a.kill_at + 6.0))
    finally:
        for h in hogs:
            h.kill()
            h.wait()
    worst = {t: max(r["loss_s"][t] for r in rounds) for t in rounds[0]["loss_s"]}
    save(
        "recorder_kill_loss",
        {
            "commit": commit(),
            "load_before": load_before,
            "load_after": load(),
            "scenario": SCENARIO,
            "mode": "realtime, speed 1",
            "hogs": a.hogs,
            "recorder_nice": RECORDER_NICE,
            "kill_at_s": a.kill_at,
            "max_loss_s": worst,
            "rounds": rounds,
        },
    )


if __name__ == "__main__":
    main()
