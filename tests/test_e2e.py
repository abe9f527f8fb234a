"""End to end: plant, controller and recorder as real OS processes over real Zenoh."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hil.mcap_log import read_run
from hil.review import summarize

pytestmark = pytest.mark.e2e


def _fowt(*args: str, timeout: float = 180.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "hil", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def test_lockstep_run_over_zenoh_records_every_channel(tmp_path: Path) -> None:
    out = tmp_path / "run"
    proc = _fowt("run", "default", "--mode", "lockstep", "--duration", "10", "--out", str(out))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    cycles = 1000  # 10 s at 100 Hz
    run = read_run(out / "run.mcap")
    assert not run.truncated, run.error
    for suffix in ("sensors", "command", "truth", "controller/status", "timing/cycle"):
        assert len(run.topic(suffix)) == cycles, suffix
    assert run.topic("timing/summary")[-1]["final"] == 1
    # Every command answers the frame of the same cycle, in order.
    answered = [c["answered_seq"] for c in run.topic("command")]
    assert answered == list(range(cycles))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["timing"]["cycles"] == cycles
    assert summary["timing"]["deadline_misses"] == 0
    for q in ("p50", "p99", "p999", "max"):
        assert summary["timing"]["latency_us"][q] > 0
    assert summary["scenario"]["name"] == "nrel5mw-ramp-through-rated"
    for key in ("mean_power_w", "rotor_speed_std_rad_s", "pitch_travel_deg_s"):
        assert summary["kpi"][key] is not None
    assert (out / "timeseries.png").stat().st_size > 10_000
    for name in ("plant", "controller", "recorder"):
        assert (out / "logs" / f"{name}.log").exists()


def test_lockstep_over_zenoh_equals_inprocess(tmp_path: Path) -> None:
    """Lock-step is deterministic: the bus changes nothing (float64 codec is exact)."""
    kpis = []
    for mode in ("lockstep", "inprocess"):
        out = tmp_path / mode
        proc = _fowt(
            "run", "default", "--mode", mode, "--duration", "5", "--out", str(out), "--no-plots"
        )
        assert proc.returncode == 0, proc.stdout + proc.stderr
        kpis.append(summarize(read_run(out / "run.mcap"))["kpi"])
    assert kpis[0] == kpis[1]


def test_recorder_killed_mid_run_leaves_a_readable_file(tmp_path: Path) -> None:
    """SIGKILL the recorder mid-run: the file reviews up to its last flushed chunk."""
    plant_ep, ctrl_ep = "tcp/127.0.0.1:0", "tcp/127.0.0.1:0"
    from hil.bus import free_tcp_endpoint

    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    mcap = tmp_path / "run.mcap"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    base = [sys.executable, "-m", "hil"]
    rec = subprocess.Popen(
        [
            *base,
            "record",
            "default",
            "--out",
            str(mcap),
            "--connect",
            plant_ep,
            "--connect",
            ctrl_ep,
        ],
        env=env,
    )
    ctl = subprocess.Popen(
        [*base, "controller", "default", "--listen", ctrl_ep, "--connect", plant_ep], env=env
    )
    plant = subprocess.Popen(
        [
            *base,
            "plant",
            "default",
            "--listen",
            plant_ep,
            "--mode",
            "realtime",
            "--duration",
            "20",
            "--require",
            "controller,recorder",
        ],
        env=env,
    )
    try:
        deadline = time.monotonic() + 60
        while (not mcap.exists() or mcap.stat().st_size < 50_000) and time.monotonic() < deadline:
            time.sleep(0.2)
        time.sleep(1.0)
        rec.send_signal(signal.SIGKILL)
        rec.wait(10)
    finally:
        for p in (plant, ctl, rec):
            if p.poll() is None:
                p.terminate()
                p.wait(10)
    run = read_run(mcap)
    assert run.truncated
    truth = run.topic("truth")
    assert len(truth) > 100  # seconds of data survived
    summary = summarize(run)
    assert summary["timing"]["complete"] is False
    assert summary["kpi"]["mean_power_w"] is not None
