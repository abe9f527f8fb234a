"""Kill safety: SIGKILL any process of a real-time run and measure what the MCAP file lost.

For each process (plant, controller, recorder) a real-time run of ``nrel5mw-ramp`` (speed 1,
100 Hz) is started as ``fowt run`` starts it, plus a monitor session in this process that
follows the truth and the controller status on the bus. The victim gets SIGKILL once three
things have been observed (no wall-clock sleep decides it, so a loaded machine only makes
the wait longer): the monitor has seen the truth reach 3 s, it has seen a controller status,
and the file holds a flushed chunk of each. The sample time of the newest message the
monitor had seen is the time of the kill in simulated seconds. Then:

* the file reviews (``fowt review --json``) up to its last flushed chunk; when the recorder
  survives it is a complete, conformant MCAP file (``_mcap_conformance``), and when the
  recorder is the victim :func:`hil.runlog.mcap_io.recover` makes one of it;
* the data lost is, per channel, the newest sample seen on the bus at the kill minus the
  newest sample in the file [simulated s]; it must stay within :data:`MAX_LOSS_S`. The
  recorder flushes a chunk every 0.25 s wall and drains its queue every 0.02 s, so a
  SIGKILL of the recorder loses at most 0.25 s + 0.02 s of wall time, i.e. 0.27 s
  simulated at speed 1 (speed s: 0.27 s times s); killing the plant or the controller
  loses nothing already published (the recorder lives on and closes its file);
* the other processes end on their own within :data:`EXIT_TIMEOUT_S`: a dead controller
  leaves the plant running on its watchdog to the end of the run; a dead recorder changes
  nothing for the others; a dead plant must end the controller and the recorder.

The measured losses are printed (``pytest -s``) and checked against the bound.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import pytest
from _mcap_conformance import check_complete_mcap

from bus_schemas.registry import CONTROLLER_STATUS, TRUTH, MessageType
from hil.nodes.bus import (
    CONTROLLER_BATCH_SUFFIX,
    PLANT_BATCH_SUFFIX,
    Bus,
    BusConfig,
    batch_key,
    free_tcp_endpoint,
    unbatching,
)

pytestmark = pytest.mark.e2e

SCENARIO = "nrel5mw-ramp"
DURATION_S = 8.0
KILL_AT_S = 3.0
#: The bound on the data lost by a SIGKILL, simulated seconds at speed 1 (see docstring).
MAX_LOSS_S = 0.5
#: The others must be gone this long (wall) after the kill or after the run's end.
EXIT_TIMEOUT_S = 15.0


class Monitor:
    """Newest sample time seen on the bus per channel (its own Zenoh session)."""

    def __init__(self, connect: tuple[str, ...], auth_key: bytes | None = None) -> None:
        self.latest: dict[str, int] = {"truth": -1, "controller/status": -1}
        self._lock = threading.Lock()
        self.bus = Bus(BusConfig(connect=connect, auth_key=auth_key))
        # The nodes put these log-only messages in batches (hil.nodes.bus.LogBatcher): what a
        # killed node had not put yet was never on the bus, and the bound covers it.
        for mt, suffix in (
            (TRUTH, PLANT_BATCH_SUFFIX),
            (CONTROLLER_STATUS, CONTROLLER_BATCH_SUFFIX),
        ):
            self.bus.subscribe(mt.key("t1"), self._on(mt))
            self.bus.subscribe(batch_key("t1", suffix), unbatching(mt, self._on(mt), "t1"))

    def _on(self, mt: MessageType) -> Callable[[str, bytes], None]:
        def on_sample(_key: str, payload: bytes) -> None:
            t = mt.codec.decode(payload).sample_time_ns
            with self._lock:
                self.latest[mt.key_suffix] = max(self.latest[mt.key_suffix], t)

        return on_sample

    def snapshot(self) -> dict[str, float]:
        """Newest sample time per channel [simulated s]."""
        with self._lock:
            return {k: v / 1e9 for k, v in self.latest.items()}


def _start(
    tmp_path: Path,
) -> tuple[dict[str, subprocess.Popen[bytes]], tuple[str, str], list[IO[bytes]]]:
    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    while ctrl_ep == plant_ep:
        ctrl_ep = free_tcp_endpoint()
    from _helpers import key_file_args

    base = [sys.executable, "-m", "hil"]
    dur = ["--duration", str(DURATION_S), *key_file_args(tmp_path)]
    cmds = {
        "recorder": [
            *base,
            "record",
            SCENARIO,
            *dur,
            "--out",
            str(tmp_path / "run.mcap"),
            "--connect",
            plant_ep,
            "--connect",
            ctrl_ep,
        ],
        "controller": [
            *base,
            "controller",
            SCENARIO,
            *dur,
            "--listen",
            ctrl_ep,
            "--connect",
            plant_ep,
        ],
        "plant": [
            *base,
            "plant",
            SCENARIO,
            *dur,
            "--listen",
            plant_ep,
            "--mode",
            "realtime",
            "--require",
            "controller,recorder",
        ],
    }
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    procs: dict[str, subprocess.Popen[bytes]] = {}
    files: list[IO[bytes]] = []
    for name, cmd in cmds.items():
        fh = open(tmp_path / f"{name}.log", "wb")  # noqa: SIM115 - closed by the test
        files.append(fh)
        procs[name] = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, env=env)
    return procs, (plant_ep, ctrl_ep), files


CHANNELS = ("truth", "controller/status")


def _recorded(mcap: Path) -> dict[str, float]:
    """Newest sample time per channel of :data:`CHANNELS` in the file [simulated s]: the
    flushed chunks of a file being written, or of a cut one (a channel with no message
    yet is absent)."""
    from hil.runlog.mcap_io import read_run

    if not mcap.is_file() or mcap.stat().st_size < 64:
        return {}
    try:
        run = read_run(mcap)
    except Exception:  # the recorder has not written its header yet
        return {}
    return {
        s: max(m["sample_time_ns"] for m in run.topic(s)) / 1e9 for s in CHANNELS if run.topic(s)
    }


def _review_cli(mcap: Path) -> dict[str, Any]:
    proc = subprocess.run(
        [sys.executable, "-m", "hil", "review", str(mcap), "--json", "--no-plots"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    result: dict[str, Any] = json.loads(proc.stdout)
    return result


@pytest.mark.parametrize("victim", ["plant", "controller", "recorder"])
def test_sigkill_leaves_a_reviewable_file_and_bounded_loss(victim: str, tmp_path: Path) -> None:
    from hil.runlog.mcap_io import read_run, recover

    procs, endpoints, files = _start(tmp_path)
    mcap = tmp_path / "run.mcap"
    from bus_schemas.auth import KEY_FILE_NAME, read_key_file

    monitor = Monitor(endpoints, read_key_file(tmp_path / KEY_FILE_NAME))
    others = [n for n in procs if n != victim]
    hung: list[str] = []
    try:
        # Kill on observed events, not on the clock: the run has reached KILL_AT_S on the
        # bus, the monitor has seen both channels, and the file holds a chunk of each (on a
        # loaded machine a process can be seconds late to publish or flush its first
        # message; killing before that measures nothing).
        deadline = time.monotonic() + 60
        while True:
            assert time.monotonic() < deadline, (
                f"the run did not reach {KILL_AT_S} s with both channels on the bus and in "
                f"the file: bus {monitor.snapshot()}, file {_recorded(mcap)}"
            )
            assert all(p.poll() is None for p in procs.values()), "a process ended early"
            seen = monitor.snapshot()
            on_bus = seen["truth"] >= KILL_AT_S and min(seen.values()) >= 0
            if on_bus and len(_recorded(mcap)) == len(CHANNELS):
                break
            time.sleep(0.05)
        procs[victim].send_signal(signal.SIGKILL)
        at_kill = monitor.snapshot()
        assert procs[victim].wait(10) == -signal.SIGKILL
        end = time.monotonic() + DURATION_S - KILL_AT_S + EXIT_TIMEOUT_S
        for name in others:
            try:
                procs[name].wait(max(0.1, end - time.monotonic()))
            except subprocess.TimeoutExpired:
                hung.append(name)
    finally:
        monitor.bus.close()
        for p in procs.values():
            if p.poll() is None:
                p.terminate()  # the recorder then finishes its file
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait(10)
        for fh in files:
            fh.close()
    logs = {n: (tmp_path / f"{n}.log").read_text() for n in procs}

    summary = _review_cli(mcap)
    run = read_run(mcap)
    assert summary["run"]["truncated"] is (victim == "recorder")
    in_file = _recorded(mcap)
    assert set(in_file) == set(CHANNELS), in_file  # (both were in the file before the kill)
    # A channel that went on after the kill (the plant's, when the controller died) lost 0.
    loss = {s: round(max(0.0, at_kill[s] - in_file[s]), 3) for s in at_kill}
    print(f"\nSIGKILL {victim} at t = {at_kill['truth']:.2f} s simulated: lost {loss} s")
    assert summary["kpi"]["mean_power_w"] is not None
    for suffix, lost in loss.items():
        assert lost <= MAX_LOSS_S, (suffix, loss)
    if victim == "controller":
        # The plant ran on to the end on its watchdog, and the recorder logged all of it.
        assert procs["plant"].returncode == 0, logs["plant"]
        assert summary["timing"]["complete"]
        assert summary["timing"]["deadline_misses"] > 0
        assert summary["timing"]["cycles"] == round(DURATION_S * 100)
    if victim == "recorder":
        assert procs["plant"].returncode == 0, logs["plant"]
        assert procs["controller"].returncode == 0, logs["controller"]
        assert summary["timing"]["complete"] is False
        # The cut file is recovered (mcap's sequential reader up to the cut, rewritten with
        # a summary) into a complete file that every MCAP reader opens, nothing lost.
        fixed = tmp_path / "recovered.mcap"
        assert recover(mcap, fixed) == sum(len(m) for m in run.messages.values())
        assert check_complete_mcap(fixed).message_count == recover(mcap, fixed)
    else:
        # The recorder survived and closed its file: complete and conformant.
        check_complete_mcap(mcap)
    if hung:
        pytest.fail(f"{hung} did not exit within {EXIT_TIMEOUT_S} s of the end: {logs}")
