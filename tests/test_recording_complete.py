"""No silent loss on the recording path: every message of every cycle is in the MCAP file.

Real processes over real Zenoh on loopback (ports picked free), real MCAP files. The load
test runs a lock-step run beside two CPU-hog processes (the 2-core machine saturated) and
checks the counts, not the speed. The review's ``recording`` section is checked on
recordings with and without a gap, and the recorder's end of run on a controller whose
last messages come well after the plant's final summary.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from _helpers import controller_report, cycle_timing, plant_report, timing_summary

from bus_schemas import (
    ActuatorCommand,
    ControllerStatus,
    PlantState,
    SensorFrame,
)
from bus_schemas.messages import (
    PlantReport,
)
from bus_schemas.registry import (
    COMMAND,
    CONTROLLER_REPORT,
    CONTROLLER_STATUS,
    CYCLE_TIMING,
    PLANT_REPORT,
    SENSORS,
    TIMING_SUMMARY,
    TRUTH,
    MessageType,
)
from hil.launch import RunRequest, launch
from hil.nodes.bus import (
    CONTROLLER_BATCH_SUFFIX,
    PLANT_BATCH_SUFFIX,
    Bus,
    BusConfig,
    batch_key,
    free_tcp_endpoint,
    wait_matched,
)
from hil.nodes.plant_node import wait_for_peers
from hil.review.core import review
from hil.runlog.completeness import completeness
from hil.runlog.mcap_io import RunLog, read_run

REPO = Path(__file__).resolve().parents[1]
PER_CYCLE = ("sensors", "command", "truth", "controller/status", "timing/cycle")
TID = "t1"
PERIOD_NS = 10_000_000  # 100 Hz


@pytest.fixture
def cpu_hogs() -> Iterator[None]:
    """Two busy-looping processes: both cores taken while the test runs."""
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        yield
    finally:
        for h in hogs:
            h.kill()
            h.wait()


@pytest.mark.e2e
def test_lockstep_run_beside_two_cpu_hogs_records_every_message(
    tmp_path: Path, cpu_hogs: None
) -> None:
    summary = launch(
        RunRequest(
            "nrel5mw-ramp",
            mode="lockstep",
            duration_s=25.0,
            out_dir=tmp_path / "run",
            plots=False,
        )
    )
    cycles = 2500  # 25 s at 100 Hz
    assert summary["timing"]["cycles"] == cycles
    rec = summary["recording"]
    for topic in PER_CYCLE:
        assert rec["topics"][topic] == {"recorded": cycles, "expected": cycles}, topic
    assert rec["problems"] == []
    assert rec["complete"] is True
    assert rec["plant_report"] and rec["controller_report"]
    run = read_run(tmp_path / "run" / "run.mcap")
    for topic in ("sensors", "truth", "controller/status", "timing/cycle"):
        assert [m["seq"] for m in run.topic(topic)] == list(range(cycles)), topic
    (plant,) = run.topic("timing/report")
    assert plant["final"] == 1 and plant["aborted"] == 0 and plant["cycles"] == cycles
    assert plant["commands_applied"] == cycles
    (ctrl,) = run.topic("controller/report")
    assert ctrl["frames_accepted"] == ctrl["commands_published"] == cycles
    assert ctrl["statuses_published"] == cycles and ctrl["safe_mode_entries"] == 0
    topics = run.metadata["recorder"]["topics"]
    assert f'"truth": {cycles}' in topics and run.metadata["recorder"]["shortfall"] == "[]"


# --------------------------------------------------------------------------- synthetic runs


def _cycle(k: int) -> list[tuple[MessageType, Any]]:
    """The five messages of cycle ``k`` (values plausible, not simulated)."""
    t = k * PERIOD_NS
    frame = SensorFrame(
        **{f: 0 for f in SensorFrame.__struct_fields__} | {"seq": k, "sample_time_ns": t}
    )
    truth = PlantState(
        **{f: 0 for f in PlantState.__struct_fields__} | {"seq": k, "sample_time_ns": t}
    )
    command = ActuatorCommand(
        seq=k,
        answered_seq=k,
        sample_time_ns=t,
        publish_time_ns=t,
        mode=0,
        blade_pitch_commanded_rad=0.0,
        generator_torque_commanded_nm=0.0,
    )
    status = ControllerStatus(
        **{f: 0 for f in ControllerStatus.__struct_fields__}
        | {"seq": k, "answered_seq": k, "sample_time_ns": t}
    )
    timing = cycle_timing(k, t, latency_ns=100_000, plant_compute_ns=10_000)
    return [(SENSORS, frame), (TRUTH, truth), (COMMAND, command), (CONTROLLER_STATUS, status),
            (CYCLE_TIMING, timing)]  # fmt: skip


def _summary(cycles: int, final: bool) -> Any:
    return timing_summary(
        cycles, cycles * PERIOD_NS, final=int(final), latency_p50_us=100.0,
        latency_p99_us=120.0, latency_p999_us=130.0, latency_max_us=140.0,
        sim_seconds_per_wall_second=20.0,
    )  # fmt: skip


def _plant_report(cycles: int) -> Any:
    return plant_report(cycles, cycles * PERIOD_NS)


def _controller_report(cycles: int) -> Any:
    return controller_report(cycles, (cycles - 1) * PERIOD_NS)


def _write_run(
    path: Path,
    cycles: int,
    drop: tuple[str, set[int]] = ("", set()),
    reports: bool = True,
) -> Path:
    """A run log written with the project's RunLog: ``cycles`` cycles, the final summary and
    both reports, less the cycles ``drop[1]`` of topic ``drop[0]``."""
    log = RunLog(path, TID)
    topic, lost = drop
    for k in range(cycles):
        for mt, msg in _cycle(k):
            if not (mt.key_suffix == topic and k in lost):
                log.write(mt.key(TID), msg)
    log.write(TIMING_SUMMARY.key(TID), _summary(cycles, final=True))
    if reports:
        log.write(PLANT_REPORT.key(TID), _plant_report(cycles))
        log.write(CONTROLLER_REPORT.key(TID), _controller_report(cycles))
    log.close()
    return path


def test_review_finds_a_complete_recording_complete(tmp_path: Path) -> None:
    summary = review(_write_run(tmp_path / "run.mcap", 200), plots=False)
    rec = summary["recording"]
    assert rec["complete"] is True, rec["problems"]
    assert rec["topics"]["truth"] == {"recorded": 200, "expected": 200}
    assert rec["topics"]["timing/report"] == {"recorded": 1, "expected": 1}


@pytest.mark.parametrize("topic", ["truth", "controller/status", "command", "sensors"])
def test_review_reports_a_gap_naming_its_topic(tmp_path: Path, topic: str) -> None:
    path = _write_run(tmp_path / "run.mcap", 200, drop=(topic, {17, 18, 150}))
    summary = review(path, plots=False)
    rec = summary["recording"]
    assert rec["complete"] is False
    assert rec["topics"][topic] == {"recorded": 197, "expected": 200}
    assert [p for p in rec["problems"] if p.startswith(f"{topic}:")] == [
        f"{topic}: 197 of 200 recorded (3 missing)"
    ]
    assert len(rec["problems"]) == 1  # the other topics are whole
    assert (tmp_path / "summary.json").read_text().count('"complete": false') == 1


def test_review_without_reports_is_incomplete(tmp_path: Path) -> None:
    summary = review(_write_run(tmp_path / "run.mcap", 50, reports=False), plots=False)
    rec = summary["recording"]
    assert rec["complete"] is False
    assert rec["plant_report"] is False and rec["controller_report"] is False
    assert any("no plant report" in p for p in rec["problems"])
    assert any("no controller report" in p for p in rec["problems"])
    assert rec["topics"]["truth"] == {"recorded": 50, "expected": None}


def test_completeness_without_final_summary_is_incomplete() -> None:
    recorded = dict.fromkeys(PER_CYCLE, 10) | {"timing/summary": 1, "timing/report": 1}
    plant = {f: 10 for f in PlantReport.__struct_fields__} | {"summaries_published": 1}
    plant["previews_published"] = 0
    ctrl = {"commands_published": 10, "statuses_published": 10}
    rec = completeness(recorded | {"controller/report": 1}, plant, [ctrl], final_summary=True)
    assert rec["complete"] is True, rec["problems"]
    rec = completeness(recorded | {"controller/report": 1}, plant, [ctrl], final_summary=False)
    assert rec["complete"] is False
    assert rec["problems"][0].startswith("no final timing summary")


# --------------------------------------------------------------------------- the recorder


def _put_batch(bus: Bus, suffix: str, payloads: list[bytes]) -> None:
    for i in range(0, len(payloads), 32):
        bus.put(batch_key(TID, suffix), b"".join(payloads[i : i + 32]))


def test_recorder_waits_for_the_controller_after_the_plant_final_summary(
    tmp_path: Path,
) -> None:
    """The controller's last statuses and its report come 3 s after the plant's final summary
    and report (a controller process behind under load): all of them are recorded."""
    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    mcap = tmp_path / "run.mcap"
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
    }
    plant = Bus(BusConfig(listen=(plant_ep,)))
    ctrl = Bus(BusConfig(listen=(ctrl_ep,)))
    rec = subprocess.Popen(
        [sys.executable, "-m", "hil", "record", "nrel5mw-ramp", "--out", str(mcap),
         "--connect", plant_ep, "--connect", ctrl_ep, "--insecure"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        plant_token = plant.session.liveliness().declare_token(f"fowt/{TID}/alive/plant")
        ctrl_token = ctrl.session.liveliness().declare_token(f"fowt/{TID}/alive/controller")
        wait_for_peers(plant, TID, ("recorder",), 60.0)
        # the recorder's token says nothing of its link to the controller's endpoint (a
        # connect Zenoh retries): put only once both publishers reach its subscription
        for bus, mt in ((plant, SENSORS), (ctrl, COMMAND)):
            assert wait_matched(bus.publisher(mt.key(TID)), 60.0), mt.key_suffix
        cycles = 300
        msgs = [m for k in range(cycles) for m in _cycle(k)]
        for mt, msg in msgs:
            if mt in (SENSORS, COMMAND):
                (plant if mt is SENSORS else ctrl).put(mt.key(TID), mt.codec.encode(msg))
        _put_batch(
            plant,
            PLANT_BATCH_SUFFIX,
            [mt.codec.encode(m) for mt, m in msgs if mt in (TRUTH, CYCLE_TIMING)],
        )
        statuses = [mt.codec.encode(m) for mt, m in msgs if mt is CONTROLLER_STATUS]
        _put_batch(ctrl, CONTROLLER_BATCH_SUFFIX, statuses[:200])
        plant.put(TIMING_SUMMARY.key(TID), TIMING_SUMMARY.codec.encode(_summary(cycles, True)))
        plant.put(PLANT_REPORT.key(TID), PLANT_REPORT.codec.encode(_plant_report(cycles)))
        time.sleep(3.0)  # ten times the drain the recorder used to stop after
        assert rec.poll() is None, rec.communicate()[0]
        _put_batch(ctrl, CONTROLLER_BATCH_SUFFIX, statuses[200:])
        report = CONTROLLER_REPORT.codec.encode(_controller_report(cycles))
        ctrl.put(CONTROLLER_REPORT.key(TID), report)
        out, _ = rec.communicate(timeout=60)
        assert rec.returncode == 0, out
        del plant_token, ctrl_token
    finally:
        if rec.poll() is None:
            rec.kill()
            rec.wait()
        plant.close()
        ctrl.close()
    run = read_run(mcap)
    for topic in PER_CYCLE:
        assert len(run.topic(topic)) == cycles, topic
    assert run.metadata["recorder"]["shortfall"] == "[]"
    assert review(mcap, plots=False)["recording"]["complete"] is True


@pytest.mark.parametrize(
    ("scenario", "loop"), [("nrel5mw-ramp", "python"), ("iea15mw-lc2", "compiled")]
)
def test_inprocess_run_writes_both_reports(tmp_path: Path, scenario: str, loop: Any) -> None:
    summary = launch(
        RunRequest(
            scenario,
            mode="inprocess",
            duration_s=3.0,
            out_dir=tmp_path / "run",
            plots=False,
            inprocess_loop=loop,
        )
    )
    assert summary["run"]["inprocess_loop"] == loop
    cycles = summary["timing"]["cycles"]
    rec = summary["recording"]
    assert rec["complete"] is True, rec["problems"]
    for topic in PER_CYCLE:
        assert rec["topics"][topic] == {"recorded": cycles, "expected": cycles}, topic
    run = read_run(tmp_path / "run" / "run.mcap")
    (plant,) = run.topic("timing/report")
    (ctrl,) = run.topic("controller/report")
    assert plant["cycles"] == cycles and plant["summaries_published"] == 4  # 3 + the final
    assert ctrl["frames_accepted"] == ctrl["statuses_published"] == cycles
    assert run.topic("timing/summary")[-1]["final"] == 1
