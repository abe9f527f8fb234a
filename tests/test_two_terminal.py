"""Two-terminal runs: plant, controller and recorder started by hand.

As docs/guide/getting-started.md ("One side alone") shows them.

Real OS processes over real Zenoh on loopback ports picked free. The plant waits for the
controller and the recorder by default, so a run started in the guide's order is recorded
from cycle 0; a plant told to wait only for the controller starts without the recorder, and
the recorder's metadata then says which cycle it recorded first. SIGINT and SIGTERM end a
waiting plant at once (exit 128 + signal, nothing ran); the wait gives up after
``--wait-timeout``.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import IO

import pytest

from hil.nodes.bus import LOG_BATCH_MAX_AGE_S, free_tcp_endpoint
from hil.runlog.mcap_io import read_run

pytestmark = pytest.mark.e2e

REPO = Path(__file__).resolve().parents[1]
SCENARIO = "nrel5mw-ramp"


class Node:
    """One ``fowt`` process with its output in a log file."""

    def __init__(self, tmp_path: Path, name: str, *args: str) -> None:
        env = {
            **os.environ,
            "PYTHONUNBUFFERED": "1",
            "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
        }
        self.log = tmp_path / f"{name}.log"
        self._fh: IO[bytes] = open(self.log, "wb")  # noqa: SIM115 - closed in stop()
        from _helpers import key_file_args

        self.proc = subprocess.Popen(
            [sys.executable, "-m", "hil", *args, *key_file_args(tmp_path)],
            stdout=self._fh,
            stderr=subprocess.STDOUT,
            env=env,
            cwd=tmp_path,
        )

    def text(self) -> str:
        return self.log.read_text(errors="replace")

    def wait_for_text(self, needle: str, timeout_s: float = 60.0) -> None:
        deadline = time.monotonic() + timeout_s
        while needle not in self.text():
            assert self.proc.poll() is None, self.text()
            assert time.monotonic() < deadline, f"no {needle!r} in:\n{self.text()}"
            time.sleep(0.05)

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
        self._fh.close()


@pytest.fixture
def nodes() -> list[Node]:
    started: list[Node] = []
    yield started
    for node in started:
        node.stop()


def _plant(tmp_path: Path, ep: str, *extra: str) -> Node:
    return Node(tmp_path, "plant", "plant", SCENARIO, "--listen", ep, *extra)


def test_readme_order_records_from_cycle_0(tmp_path: Path, nodes: list[Node]) -> None:
    """Plant, controller, then (later) recorder: the plant waits for the recorder."""
    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    mcap = tmp_path / "run.mcap"
    plant = _plant(tmp_path, plant_ep, "--mode", "lockstep", "--duration", "3")
    nodes.append(plant)
    ctl = Node(
        tmp_path, "controller", "controller", SCENARIO, "--listen", ctrl_ep, "--connect", plant_ep
    )
    nodes.append(ctl)
    plant.wait_for_text("plant waiting for ['controller', 'recorder']")
    ctl.wait_for_text(" ready on ")  # the controller has declared its liveliness token
    time.sleep(3.0)  # the controller is there; without the recorder the plant must not start
    assert "plant running" not in plant.text(), plant.text()
    rec = Node(
        tmp_path,
        "recorder",
        "record",
        SCENARIO,
        "--duration",
        "3",
        "--out",
        str(mcap),
        "--connect",
        plant_ep,
        "--connect",
        ctrl_ep,
    )
    nodes.append(rec)
    for node in (plant, ctl, rec):
        assert node.proc.wait(120) == 0, node.text()
    run = read_run(mcap)
    assert run.metadata["recorder"]["first_cycle_recorded"] == "0"
    cycles = round(3.0 / 0.01)
    assert len(run.topic("sensors")) == cycles
    assert len(run.topic("truth")) == cycles


def test_plant_without_recorder_wait_marks_the_late_start(
    tmp_path: Path, nodes: list[Node]
) -> None:
    """``--require controller``: a recorder joining mid-run records a first cycle > 0."""
    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    mcap = tmp_path / "run.mcap"
    plant = _plant(
        tmp_path, plant_ep, "--mode", "realtime", "--duration", "10", "--require", "controller"
    )
    nodes.append(plant)
    nodes.append(
        Node(
            tmp_path,
            "controller",
            "controller",
            SCENARIO,
            "--listen",
            ctrl_ep,
            "--connect",
            plant_ep,
        )
    )
    plant.wait_for_text("plant running")
    time.sleep(1.0)  # at least 100 cycles pass unrecorded
    rec = Node(
        tmp_path,
        "recorder",
        "record",
        SCENARIO,
        "--out",
        str(mcap),
        "--connect",
        plant_ep,
        "--connect",
        ctrl_ep,
    )
    nodes.append(rec)
    assert rec.proc.wait(120) == 0, rec.text()
    assert plant.proc.wait(60) == 0, plant.text()
    run = read_run(mcap)
    first = int(run.metadata["recorder"]["first_cycle_recorded"])
    assert first >= 100
    # the lowest cycle of the plant's per-cycle channels (a cycle's truth may be recorded
    # and its sensor frame, published just before the recorder joined, not: truth and
    # timing go out in log batches, so the first batch the recorder gets may hold the
    # cycles of up to LOG_BATCH_MAX_AGE_S plus one control period before it joined)
    seqs = [m["seq"] for t in ("sensors", "truth", "timing/cycle") for m in run.topic(t)]
    assert min(seqs) == first
    batch_cycles = math.ceil(LOG_BATCH_MAX_AGE_S / 0.01) + 1  # nrel5mw-ramp: 100 Hz
    assert min(m["seq"] for m in run.topic("sensors")) - first <= 1 + batch_cycles


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_ends_a_waiting_plant_at_once(
    tmp_path: Path, nodes: list[Node], sig: signal.Signals
) -> None:
    plant = _plant(tmp_path, free_tcp_endpoint(), "--wait-timeout", "600")
    nodes.append(plant)
    plant.wait_for_text("plant waiting for")
    sent = time.monotonic()
    plant.proc.send_signal(sig)
    # It has 600 s to wait; ending within 10 s (a generous bound on a loaded machine) can
    # only be the signal. The figure itself is not asserted (no timed assertions).
    code = plant.proc.wait(10)
    assert time.monotonic() - sent < 10
    assert code == 128 + sig, plant.text()
    assert f"{sig.name} while waiting for ['controller', 'recorder']" in plant.text()
    assert "nothing ran" in plant.text()
    assert "Traceback" not in plant.text()


def test_wait_timeout_gives_up_naming_who_is_missing(tmp_path: Path, nodes: list[Node]) -> None:
    plant = _plant(tmp_path, free_tcp_endpoint(), "--wait-timeout", "1")
    nodes.append(plant)
    code = plant.proc.wait(60)
    assert code == 1, plant.text()
    last = plant.text().strip().splitlines()[-1]
    assert last.startswith("error: no ['controller', 'recorder'] after 1 s (--wait-timeout)")
