"""The recorder's feed of the live view (hil.nodes.live_feed, hil.live.node.LiveFeed).

What the recorder writes is what the live view gets, in the same order; a batch lost on the
way is counted with every message it held; a forged, cut, duplicated batch is a counted
rejection and nothing of it is shown. Real MCAP files and the real signing; the Foxglove
server is replaced by a list (the server has its own end-to-end tests).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgspec
import pytest
from _helpers import cycle_timing, sensor_frame

from bus_schemas import DecodeError, SensorFrame
from bus_schemas.auth import sign
from bus_schemas.registry import CYCLE_TIMING, SENSORS
from hil.live.node import LiveFeed
from hil.live.server import LiveStats
from hil.nodes.live_feed import LIVE_SUFFIX, LiveForward, open_live_batch
from hil.nodes.recorder import Recorder, RecorderLog
from hil.runlog.mcap_io import read_run

SECRET = bytes(range(32))
KEY = f"fowt/t1/{LIVE_SUFFIX}"


def _frame(seq: int) -> SensorFrame:
    frame = sensor_frame(100.0 + seq, 0.01, 20_000.0, seq=seq, valid_mask=0b11111)
    return msgspec.structs.replace(frame, sample_time_ns=seq * 25_000_000)


class _Server:
    """Stands in for the Foxglove server: keeps what it is offered."""

    turbine = "t1"

    def __init__(self) -> None:
        self.offered: list[tuple[str, Any]] = []
        self.stats = LiveStats(port=0)

    def offer(self, key: str, msg: Any) -> None:
        self.offered.append((key, msg))


def _feed() -> tuple[LiveFeed, _Server]:
    server = _Server()
    return LiveFeed(server, SECRET), server  # type: ignore[arg-type]


def test_the_live_view_gets_what_the_recorder_writes_in_its_order(tmp_path: Path) -> None:
    log = RecorderLog(tmp_path / "run.mcap", "t1")
    recorder = Recorder(log)
    puts: list[bytes] = []
    recorder.live = LiveForward(lambda p: puts.append(sign(SECRET, KEY, p)))
    for seq in range(30):
        recorder.on_sample("fowt/t1/sensors", SENSORS.codec.encode(_frame(seq)))
        recorder.on_sample(
            "fowt/t1/timing/cycle", CYCLE_TIMING.codec.encode(cycle_timing(seq, seq * 25_000_000))
        )
        if seq % 7 == 6:
            recorder.drain(0.0)  # a drain puts what it wrote as one batch
    recorder.on_sample("fowt/t1/sensors", SENSORS.codec.encode(_frame(3)))  # a duplicate
    recorder.drain(0.0)
    log.close()
    assert recorder.rejected == {"sensors:duplicate": 1}
    assert len(puts) == 5  # drains after cycles 6, 13, 20, 27 and the last
    feed, server = _feed()
    for p in puts:
        feed.on_sample(_Sample(p))  # type: ignore[arg-type]
    assert feed.take() == 5
    written = read_run(tmp_path / "run.mcap")
    for suffix in ("sensors", "timing/cycle"):
        shown = [msgspec.structs.asdict(m) for k, m in server.offered if k == f"fowt/t1/{suffix}"]
        in_file = written.topic(suffix)
        assert len(shown) == len(in_file) == 30, suffix
        for a, b in zip(shown, in_file, strict=True):  # field by field, as the file holds them
            assert {f: a[f] for f in b if f in a} == {f: b[f] for f in b if f in a}
            assert a["seq"] == b["seq"]
    # in the order the recorder wrote them: each drain's messages after the previous ones
    assert [m.seq for k, m in server.offered if k == "fowt/t1/sensors"] == list(range(30))
    assert feed.stats().dropped == 0 and feed.stats().rejected == {}


class _Sample:
    """What the feed's callback reads of a Zenoh sample (its payload's bytes)."""

    def __init__(self, data: bytes) -> None:
        self.payload = self
        self._data = data

    def to_bytes(self) -> bytes:
        return self._data


def _batches(n_batches: int, per_batch: int) -> list[bytes]:
    out: list[bytes] = []
    fwd = LiveForward(lambda p: out.append(sign(SECRET, KEY, p)), max_messages=per_batch)
    for seq in range(n_batches * per_batch):
        fwd.add(SENSORS, _frame(seq))  # a full batch is put at once
    return out


def test_a_lost_batch_is_counted_with_every_message_it_held() -> None:
    batches = _batches(5, 4)
    feed, server = _feed()
    for i in (0, 1, 3, 4):  # batch 2 lost on the way
        feed._batch(batches[i])
    assert [m.seq for _, m in server.offered] == [0, 1, 2, 3, 4, 5, 6, 7, *range(12, 20)]
    assert feed.stats().dropped == 4


def test_a_restarted_recorders_stream_is_shown_from_its_first_batch() -> None:
    first, again = _batches(2, 3), _batches(2, 3)  # two recorder processes, one after the other
    feed, server = _feed()
    for b in (*first, *again):
        feed._batch(b)
    assert [m.seq for _, m in server.offered] == [*range(6), *range(6)]
    assert feed.stats().dropped == 0 and feed.stats().rejected == {}


def test_forged_cut_and_repeated_batches_are_counted_and_never_shown() -> None:
    batches = _batches(2, 3)
    feed, server = _feed()
    feed._batch(batches[0])
    feed._batch(batches[0])  # repeated (a replay by a key holder)
    unsigned = open_live_batch_payload(batches[1])
    feed._batch(unsigned + bytes(32))  # a wrong tag
    feed._batch(sign(SECRET, KEY, unsigned[:-5]))  # cut inside its last message
    feed._batch(sign(SECRET, KEY, b"\x00" * 7))  # shorter than the header
    feed._batch(sign(SECRET, "fowt/t1/sensors", unsigned))  # signed for another key
    assert len(server.offered) == 3
    assert feed.stats().rejected == {
        f"{LIVE_SUFFIX}:duplicate": 1,
        f"{LIVE_SUFFIX}:auth": 2,
        f"{LIVE_SUFFIX}:length": 2,
    }
    feed._batch(batches[1])  # the genuine one still goes through
    assert [m.seq for _, m in server.offered] == list(range(6))


def open_live_batch_payload(signed: bytes) -> bytes:
    """The payload of a signed batch (the tag cut off), checked to split."""
    from bus_schemas.auth import verify

    payload = verify(SECRET, KEY, signed)
    open_live_batch(payload)
    return payload


def test_live_forward_refuses_an_empty_batch_size() -> None:
    with pytest.raises(ValueError, match="max_messages >= 1"):
        LiveForward(lambda p: None, max_messages=0)
    with pytest.raises(DecodeError):
        open_live_batch(b"\x01" * 24 + b"\xff\xff\xff\xff")  # no such message
