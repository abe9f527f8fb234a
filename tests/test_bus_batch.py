"""Log batches and the lock-step command channel (hil.nodes.bus, hil.nodes.recorder,
hil.nodes.plant_node).

Real Zenoh sessions on free loopback ports, a real MCAP file: a batch splits into exactly
the messages that went in, the recorder writes each on its own channel with the same JSON
as when put alone, a malformed batch is a counted rejection, and the plant's command
channel hands over the answer, times out and stops.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest
from _helpers import cycle_timing

from bus_schemas import ActuatorCommand, ControllerStatus, CycleTiming
from bus_schemas.codec import HeaderError, TruncatedError
from bus_schemas.registry import COMMAND, CONTROLLER_STATUS, CYCLE_TIMING, MessageType
from hil.nodes.bus import (
    CONTROLLER_BATCH_SUFFIX,
    PLANT_BATCH_SUFFIX,
    Bus,
    BusConfig,
    LogBatcher,
    batch_key,
    free_tcp_endpoint,
    split_batch,
)
from hil.nodes.plant_node import CommandChannel, CommandInbox
from hil.nodes.recorder import Recorder, RecorderLog
from hil.runlog.mcap_io import read_run


def _timing(seq: int) -> CycleTiming:
    return cycle_timing(
        seq, seq * 25_000_000, publish_time_ns=10_000 + seq, latency_ns=300_000 + seq,
        plant_compute_ns=20_000,
    )  # fmt: skip


def _command(seq: int) -> ActuatorCommand:
    values = {f.name: 0 for f in COMMAND.codec.fields}
    values.update(seq=seq, answered_seq=seq, sample_time_ns=seq * 25_000_000)
    values.update(blade_pitch_commanded_rad=0.01 * seq, generator_torque_commanded_nm=1e4)
    return ActuatorCommand(**values)


def _status(seq: int) -> ControllerStatus:
    values: dict[str, float | int] = {}
    for f in CONTROLLER_STATUS.codec.fields:
        values[f.name] = 0.0 if f.is_float else 0
        if f.is_float and not f.minimum <= 0.0 <= f.maximum:
            values[f.name] = f.minimum
    # a status answers the frame of its cycle (the recorder keeps one per answered frame)
    values.update(seq=seq, answered_seq=seq, sample_time_ns=seq * 25_000_000)
    return ControllerStatus(**values)


def test_a_batch_splits_into_the_messages_put_in_it() -> None:
    msgs: list[tuple[MessageType, object]] = []
    for k in range(5):
        msgs += [(CYCLE_TIMING, _timing(k)), (CONTROLLER_STATUS, _status(k))]
    payload = b"".join(mt.codec.encode(m) for mt, m in msgs)
    parts = split_batch(payload)
    assert [mt for mt, _ in parts] == [mt for mt, _ in msgs]
    assert [mt.codec.decode(p) for mt, p in parts] == [m for _, m in msgs]
    # Cut short: rejected whole; a header of no registered message: rejected whole.
    with pytest.raises(TruncatedError):
        split_batch(payload[:-1])
    with pytest.raises(HeaderError):
        split_batch(payload[:8] + b"\x00\x00\x00\x00" + payload[8:])
    assert split_batch(b"") == []


def test_batcher_puts_when_full_old_or_flushed_and_every_message_arrives() -> None:
    ep = free_tcp_endpoint()
    rx, tx = Bus(BusConfig(listen=(ep,))), Bus(BusConfig(connect=(ep,)))
    got: list[bytes] = []
    lock = threading.Lock()

    def on_batch(_key: str, payload: bytes) -> None:
        with lock:
            got.append(payload)

    key = batch_key("t1", PLANT_BATCH_SUFFIX)
    try:
        rx.subscribe(key, on_batch)
        time.sleep(0.5)  # the subscription reaches the publisher
        batcher = LogBatcher(tx.publisher(key), max_messages=4, max_age_s=0.05)
        payloads = [CYCLE_TIMING.codec.encode(_timing(k)) for k in range(11)]
        for p in payloads[:4]:  # full at 4: put at once
            batcher.add(p)
        assert batcher.puts == 1 and not batcher.due()
        batcher.add(payloads[4])
        assert not batcher.due()  # 1 message, younger than 50 ms
        time.sleep(0.06)
        assert batcher.due()
        batcher.flush()
        for p in payloads[5:]:
            batcher.add(p)
        batcher.flush()  # 4 + 2 more: one full batch, then the rest
        batcher.flush()  # nothing left: no put
        assert (batcher.puts, batcher.messages, batcher.failed) == (4, 11, 0)
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and len(got) < 4:
            time.sleep(0.01)
    finally:
        tx.close()
        rx.close()
    assert [len(b) // CYCLE_TIMING.codec.size for b in got] == [4, 1, 4, 2]
    assert [bytes(p) for b in got for _, p in split_batch(b)] == payloads
    with pytest.raises(ValueError, match="max_messages >= 1"):
        LogBatcher(None, max_messages=0)


def test_recorder_writes_batched_messages_as_if_put_alone(tmp_path: Path) -> None:
    """Same channels, same JSON, same order; a malformed batch is a counted rejection."""
    timings = [_timing(k) for k in range(3)]
    statuses = [_status(k) for k in range(3)]
    files = {}
    for how in ("alone", "batched"):
        log = RecorderLog(tmp_path / f"{how}.mcap", "t1")
        rec = Recorder(log)
        if how == "alone":
            for t, s in zip(timings, statuses, strict=True):
                rec.on_sample(CYCLE_TIMING.key("t1"), CYCLE_TIMING.codec.encode(t))
                rec.on_sample(CONTROLLER_STATUS.key("t1"), CONTROLLER_STATUS.codec.encode(s))
        else:
            plant = b"".join(CYCLE_TIMING.codec.encode(t) for t in timings)
            ctrl = b"".join(CONTROLLER_STATUS.codec.encode(s) for s in statuses)
            rec.on_sample(batch_key("t1", PLANT_BATCH_SUFFIX), plant)
            rec.on_sample(batch_key("t1", CONTROLLER_BATCH_SUFFIX), ctrl)
            rec.on_sample(batch_key("t1", PLANT_BATCH_SUFFIX), plant[:-3])  # cut short
            assert rec.rejected == {f"{PLANT_BATCH_SUFFIX}:length": 1}
            assert not rec.unknown_keys
        assert rec.drain(0.0) == 6
        log.close()
        files[how] = read_run(tmp_path / f"{how}.mcap")
    for suffix in ("timing/cycle", "controller/status"):
        assert files["batched"].topic(suffix) == files["alone"].topic(suffix), suffix
        assert [m["seq"] for m in files["batched"].topic(suffix)] == [0, 1, 2]


def test_command_channel_answers_times_out_and_stops() -> None:
    ep = free_tcp_endpoint()
    plant, ctrl = Bus(BusConfig(listen=(ep,))), Bus(BusConfig(connect=(ep,)))
    inbox = CommandInbox()
    stop = threading.Event()
    key = COMMAND.key("t1")
    channel = CommandChannel(plant.session, key, inbox, stop, poll_s=0.02)
    try:
        pub = ctrl.publisher(key)
        deadline = time.monotonic() + 10
        got = None
        while got is None:  # until the subscription has reached the controller's session
            assert time.monotonic() < deadline
            pub.put(COMMAND.codec.encode(_command(0)))
            got = channel.wait_for(0, 0.1)
        assert got[0] == _command(0)
        # An older answer and an empty remote payload are dropped and counted; the right
        # one is returned.
        pub.put(b"")
        pub.put(COMMAND.codec.encode(_command(0)))
        pub.put(COMMAND.codec.encode(_command(1)))
        got = channel.wait_for(1, 5.0)
        assert got is not None and got[0] == _command(1)
        assert inbox.rejected == {"length": 1, "duplicate_or_reordered": 1}
        # No answer: None after the timeout (woken by the waker, poll 20 ms) ...
        t0 = time.monotonic()
        assert channel.wait_for(2, 0.1) is None
        assert 0.1 <= time.monotonic() - t0 < 1.0
        # ... and soon after stop is set, however long the timeout.
        threading.Timer(0.1, stop.set).start()
        t0 = time.monotonic()
        assert channel.wait_for(2, 60.0) is None
        assert time.monotonic() - t0 < 1.0
    finally:
        channel.close()
        ctrl.close()
        plant.close()
