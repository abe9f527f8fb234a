"""Exact recordings: replays, duplicates and implausible times never reach the file.

The recorder (:class:`hil.nodes.recorder.Recorder`) writes each cycle once per per-cycle
topic, in order: a signed sample replayed by a key holder is counted as ``duplicate``, a
sample time past the run's window as ``time`` (and a time near 2**63 - 1, which overflowed
64 bits in the log time before, cannot crash the writer). The review then finds an exact
recording complete and a recording with a duplicate, a gap or a reorder incomplete.
"""

from __future__ import annotations

from pathlib import Path

import msgspec
from _helpers import sensor_frame

from bus_schemas import ActuatorCommand
from bus_schemas.auth import new_key, sign
from bus_schemas.registry import COMMAND, SENSORS
from hil.nodes.bus import sample_time_limit_ns
from hil.nodes.recorder import Recorder, RecorderLog
from hil.runlog.mcap_io import read_run


def _frame_payload(seq: int, sample_time_ns: int | None = None) -> bytes:
    frame = sensor_frame(100.0, 0.01, 20_000.0, seq=seq, valid_mask=0b11111)
    t = seq * 10_000_000 if sample_time_ns is None else sample_time_ns
    return SENSORS.codec.encode(msgspec.structs.replace(frame, sample_time_ns=t))


def _command_payload(answered: int, seq: int) -> bytes:
    cmd = ActuatorCommand(
        seq=seq,
        answered_seq=answered,
        sample_time_ns=answered * 10_000_000,
        publish_time_ns=answered,
        mode=0,
        blade_pitch_commanded_rad=0.02,
        generator_torque_commanded_nm=30_000.0,
    )
    return COMMAND.codec.encode(cmd)


def test_the_recorder_refuses_replays_duplicates_and_times_outside_the_run(
    tmp_path: Path,
) -> None:
    key = new_key()
    log = RecorderLog(tmp_path / "r.mcap", "t1")
    recorder = Recorder(log, key, sample_time_limit_ns(10.0))

    def put(k: str, payload: bytes) -> None:
        recorder.on_sample(k, sign(key, k, payload))

    for seq in range(5):
        put("fowt/t1/sensors", _frame_payload(seq))
    for seq in (2, 4, 0):  # replays of frames already recorded
        put("fowt/t1/sensors", _frame_payload(seq))
    put("fowt/t1/sensors", _frame_payload(5, sample_time_ns=2**63 - 1))  # overflowed before
    put("fowt/t1/sensors", _frame_payload(5, sample_time_ns=sample_time_limit_ns(10.0) + 1))
    put("fowt/t1/sensors", _frame_payload(5))
    # A restarted controller numbers its commands from 0 again; the cycle it answers
    # goes on, so its first command is no duplicate.
    put("fowt/t1/command", _command_payload(0, 0))
    put("fowt/t1/command", _command_payload(1, 1))
    put("fowt/t1/command", _command_payload(1, 1))  # replayed
    put("fowt/t1/command", _command_payload(2, 0))  # restarted controller
    assert recorder.rejected == {"sensors:duplicate": 3, "sensors:time": 2, "command:duplicate": 1}
    assert recorder.drain(0.0) == 9
    log.close()
    run = read_run(tmp_path / "r.mcap")
    assert [m["seq"] for m in run.topic("sensors")] == list(range(6))
    assert [m["answered_seq"] for m in run.topic("command")] == [0, 1, 2]


def test_the_run_log_refuses_a_log_time_past_64_bits(tmp_path: Path) -> None:
    log = RecorderLog(tmp_path / "r.mcap", "t1")
    recorder = Recorder(log, None)  # no window: the writer's own guard
    recorder.on_sample("fowt/t1/sensors", _frame_payload(0, sample_time_ns=2**63 - 1))
    recorder.on_sample("fowt/t1/sensors", _frame_payload(1))
    assert recorder.drain(0.0) == 1
    assert recorder.rejected == {"sensors:range": 1}
    log.close()
    assert [m["seq"] for m in read_run(tmp_path / "r.mcap").topic("sensors")] == [1]


def test_review_finds_repeats_reorders_skips_and_excess() -> None:
    import numpy as np

    from hil.runlog.completeness import CycleOrder, completeness

    exact = CycleOrder(consecutive=True)
    exact.feed(np.arange(0, 50))
    exact.feed(np.arange(50, 100))
    assert exact.as_dict() == {"repeated": 0, "reordered": 0, "skipped": 0}
    bad = CycleOrder(consecutive=True)
    bad.feed(np.array([0, 1, 1, 2]))
    bad.feed(np.array([2, 5, 4, 6]))  # a repeat across batches, a skip, a reorder
    assert bad.as_dict() == {"repeated": 2, "reordered": 1, "skipped": 2}
    answered = CycleOrder(consecutive=False)  # a controller may skip frames, not repeat
    answered.feed(np.array([0, 1, 3, 7]))
    assert answered.as_dict() == {"repeated": 0, "reordered": 0, "skipped": 0}

    plant = {"sensor_frames_published": 100, "truth_published": 100}
    ctrl = {"commands_published": 100, "statuses_published": 100}
    recorded = {"sensors": 100, "truth": 100, "command": 100, "controller/status": 100}
    recorded |= {"timing/report": 1, "controller/report": 1}
    ok = completeness(recorded, plant, [ctrl], True, order={"sensors": exact.as_dict()})
    assert ok["complete"], ok["problems"]
    more = completeness(recorded | {"truth": 150}, plant, [ctrl], True)
    assert more["problems"] == ["truth: 150 recorded, 100 published (50 more than the plant put)"]
    out = completeness(recorded, plant, [ctrl], True, order={"sensors": bad.as_dict()})
    assert not out["complete"]
    assert out["problems"] == [
        "sensors: 2 cycles recorded again, 1 cycles out of order, "
        "2 cycles missing between recorded ones"
    ]


def test_only_the_runs_recorder_satisfies_the_controllers_wait(tmp_path: Path) -> None:
    """The controller's ``--await-recorder`` wait ends on the recorder's signed answer to
    its nonce, not on any subscriber (which made a plant start before the recorder's link
    was up, cutting the start of the recording)."""
    import threading

    from hil.nodes.bus import Bus, BusConfig, await_recorder, free_tcp_endpoint

    key = new_key()
    ep = free_tcp_endpoint()
    controller = Bus(BusConfig(listen=(ep,), auth_key=key))
    others: list[Bus] = []
    try:
        status = controller.publisher("fowt/t1/controller/batch")
        # A session holding the credential that subscribes to everything but is no recorder
        # (and one answering with its own nonce) does not end the wait.
        bystander = Bus(BusConfig(connect=(ep,), auth_key=key))
        others.append(bystander)
        bystander.subscribe("fowt/t1/**", lambda _k, _p: None)
        liar = bystander.publisher("fowt/t1/recorder/ready")
        bystander.subscribe("fowt/t1/controller/hello", lambda _k, _p: liar.put(bytes(16)))
        assert not await_recorder(controller, status, "t1", 1.0)
        stop = threading.Event()
        stop.set()  # a signal ends the wait at once
        assert not await_recorder(controller, status, "t1", 60.0, stop)
        # The run's recorder answers the nonce it got.
        log = RecorderLog(tmp_path / "r.mcap", "t1")
        recorder = Recorder(log, key)
        rec_bus = Bus(BusConfig(connect=(ep,), auth_key=key))
        others.append(rec_bus)
        recorder.answer_hello = lambda nonce: rec_bus.put("fowt/t1/recorder/ready", nonce)
        sub = rec_bus.session.declare_subscriber(
            "fowt/t1/**", lambda s: recorder.on_sample(str(s.key_expr), s.payload.to_bytes())
        )
        assert await_recorder(controller, status, "t1", 30.0)
        sub.undeclare()
        assert recorder.rejected == {} and recorder.unknown_keys == {}
        log.close()
    finally:
        for bus in others:
            bus.close()
        controller.close()
