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
from _helpers import fowt

from bus_schemas.messages import EST_WIND_SPEED
from hil.review.core import summarize
from hil.runlog.mcap_io import read_run

pytestmark = pytest.mark.e2e


def test_lockstep_run_over_zenoh_records_every_channel(tmp_path: Path) -> None:
    out = tmp_path / "run"
    proc = fowt("run", "nrel5mw-ramp", "--mode", "lockstep", "--duration", "10", "--out", str(out))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    cycles = 1000  # 10 s at 100 Hz
    run = read_run(out / "run.mcap")
    assert not run.truncated, run.error
    for suffix in ("sensors", "command", "truth", "controller/status", "timing/cycle"):
        assert len(run.topic(suffix)) == cycles, suffix
    # Every cycle's record of each, once (truth, timing and status travel in log batches).
    for suffix in ("sensors", "truth", "controller/status", "timing/cycle"):
        assert [m["seq"] for m in run.topic(suffix)] == list(range(cycles)), suffix
    assert run.topic("timing/summary")[-1]["final"] == 1
    # Every command answers the frame of the same cycle, in order.
    answered = [c["answered_seq"] for c in run.topic("command")]
    assert answered == list(range(cycles))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["timing"]["cycles"] == cycles
    assert summary["timing"]["deadline_misses"] == 0
    for q in ("p50", "p99", "p999", "max"):
        assert summary["timing"]["latency_us"][q] > 0
    assert summary["scenario"]["name"] == "nrel5mw-ramp"
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
        proc = fowt(
            "run",
            "nrel5mw-ramp",
            "--mode",
            mode,
            "--duration",
            "5",
            "--out",
            str(out),
            "--no-plots",
        )
        assert proc.returncode == 0, proc.stdout + proc.stderr
        kpis.append(summarize(read_run(out / "run.mcap"))["kpi"])
    assert kpis[0] == kpis[1]


def test_recorder_killed_mid_run_leaves_a_readable_file(tmp_path: Path) -> None:
    """SIGKILL the recorder mid-run: the file reviews up to its last flushed chunk."""
    plant_ep, ctrl_ep = "tcp/127.0.0.1:0", "tcp/127.0.0.1:0"
    from hil.nodes.bus import free_tcp_endpoint

    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    mcap = tmp_path / "run.mcap"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    from _helpers import key_file_args

    key = key_file_args(tmp_path)
    base = [sys.executable, "-m", "hil"]
    rec = subprocess.Popen(
        [
            *base,
            "record",
            "default",
            *key,
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
        [*base, "controller", "default", *key, "--listen", ctrl_ep, "--connect", plant_ep],
        env=env,
    )
    plant = subprocess.Popen(
        [
            *base,
            "plant",
            "default",
            *key,
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
        # The file opens with its schemas and channels (~24 kB of ros2msg text, outside the
        # chunks), then about 62 B a message in zstd chunks: 75 kB is seconds of data.
        deadline = time.monotonic() + 60
        while (not mcap.exists() or mcap.stat().st_size < 75_000) and time.monotonic() < deadline:
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


def test_lockstep_floating_run_records_platform_waves_and_loads(tmp_path: Path) -> None:
    """The default (floating, load case 2) scenario over Zenoh in lock-step, 5 s."""
    out = tmp_path / "floating"
    proc = fowt(
        "run", "default", "--mode", "lockstep", "--duration", "5", "--out", str(out), "--no-plots"
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    cycles = 200  # 5 s at 40 Hz
    run = read_run(out / "run.mcap")
    assert not run.truncated, run.error
    for suffix in ("sensors", "command", "truth", "controller/status", "timing/cycle"):
        assert len(run.topic(suffix)) == cycles, suffix
    truth = run.topic("truth")
    assert all(m["floating"] == 1 for m in truth)
    surge = [m["platform_surge_m"] for m in truth]
    pitch = [m["platform_pitch_rad"] for m in truth]
    # VolturnUS-S at 7.1 m/s: mean offset of order 10 m and 2 deg (static thrust ~1.1 MN
    # against the mooring); waves of Hs 1.7 m make the elevations move.
    assert 3.0 < sum(surge) / cycles < 25.0
    assert 0.01 < sum(pitch) / cycles < 0.07
    eta = [m["wave_elevation_platform_m"] for m in truth]
    gauge = [m["wave_elevation_gauge_m"] for m in truth]
    assert max(eta) - min(eta) > 0.1 and max(gauge) - min(gauge) > 0.1
    assert all(m["tower_base_moment_nm"] > 0 for m in truth)
    frames = run.topic("sensors")
    assert any(f["valid_mask"] & (1 << 10) for f in frames)  # the wave gauge reports
    status = run.topic("controller/status")
    # the IEA 15 MW baseline (ROSCO's schedule) estimates the wind only (its EKF)
    assert all(s["estimates_valid_mask"] == EST_WIND_SPEED for s in status)
    assert all(3.0 < s["wind_speed_estimated_m_s"] < 12.0 for s in status)
    k = json.loads((out / "summary.json").read_text())["kpi"]
    for key in (
        "platform_pitch_std_deg",
        "platform_pitch_mean_deg",
        "surge_std_m",
        "surge_mean_m",
        "tower_base_del_nm",
        "shaft_del_nm",
    ):
        assert k[key] is not None and k[key] >= 0.0, key
