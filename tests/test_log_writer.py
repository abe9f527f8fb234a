"""The in-process log path: batches to a writer process, MCAP chunks written per batch.

:class:`hil.log_writer.BackgroundRunLog` hands msgpack batches to a child that JSON-encodes
them and :class:`hil.mcap_log.BatchRunLog` writes each batch as one chunk. These checks read
the files with the mcap package's own reader: every message of every registered type comes
out as exactly the JSON msgspec writes for the Struct itself (seeded random field values,
including extreme floats and 64-bit integers), with per-channel sequence numbers 0, 1, ...,
log time = run start + sample time, publish time as given, and a complete, conformant file.
"""

from __future__ import annotations

import random
import subprocess
import sys
import time
import typing
from pathlib import Path

import msgspec
import numpy as np
import orjson
import pytest
from _mcap_conformance import check_complete_mcap
from mcap.reader import make_reader

from bus_schemas.registry import MESSAGES, MessageType
from hil.log_writer import BATCH_MESSAGES, BackgroundRunLog
from hil.mcap_log import BatchRunLog, read_run

FLOATS = (0.0, -0.0, 1.0, 5e-324, 1.7976931348623157e308, -2.5e-9, 123456.789, 1e17)
INTS = (0, 1, -1, 2**63 - 1, 40_000_000_000)


def _random_message(mt: MessageType, rng: random.Random, seq: int) -> msgspec.Struct:
    hints = typing.get_type_hints(mt.cls)
    fields: dict[str, typing.Any] = {}
    for name, kind in hints.items():
        if kind is int:
            fields[name] = (
                rng.choice(INTS) if rng.random() < 0.5 else rng.randrange(-(2**62), 2**62)
            )
        else:
            fields[name] = rng.choice(FLOATS) if rng.random() < 0.5 else rng.uniform(-1e6, 1e6)
    fields.update(seq=seq, sample_time_ns=seq * 25_000_000, publish_time_ns=10**9 + seq)
    return mt.cls(**fields)


def _read_all(path: Path) -> list[tuple[str, int, int, int, bytes]]:
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        return [
            (ch.topic, m.sequence, m.log_time, m.publish_time, m.data)
            for _s, ch, m in reader.iter_messages(log_time_order=False)
        ]


def test_background_log_writes_the_structs_json_exactly(tmp_path: Path) -> None:
    rng = random.Random(15)
    path = tmp_path / "run.mcap"
    log = BackgroundRunLog(path, "t1", {"run": {"mode": "inprocess"}})
    log.wait_ready()
    sent: dict[str, list[bytes]] = {}
    n = BATCH_MESSAGES * 2 + 77  # two full batches and a partial one sent by close()
    for i in range(n):
        mt = MESSAGES[i % len(MESSAGES)]
        msg = _random_message(mt, rng, i)
        sent.setdefault(mt.key("t1"), []).append(msgspec.json.encode(msg))
        log.publish(mt, msg)
    log.close()
    assert log.writer_messages == n
    found = check_complete_mcap(path, validate=False)
    assert found.per_topic == {k: len(v) for k, v in sent.items()}
    got: dict[str, list[bytes]] = {}
    for topic, _seq, _lt, _pt, data in _read_all(path):
        got.setdefault(topic, []).append(data)
    assert got == sent  # byte for byte, in order, per topic
    assert read_run(path).metadata["run"] == {"mode": "inprocess"}


def test_batch_log_sequences_and_times(tmp_path: Path) -> None:
    """add_json: sequence per channel from 0, log time = start + sample time, publish time kept."""
    path = tmp_path / "c.mcap"
    start = 1_700_000_000_000_000_000
    log = BatchRunLog(path, "t1", start_unix_ns=start, batch_messages=100)
    by_id = {mt.message_id: mt for mt in MESSAGES}
    rng = random.Random(2)
    expected: dict[str, list[tuple[int, int, int]]] = {}
    for i in range(1050):
        mt = by_id[rng.choice([1, 2, 3])]
        msg = _random_message(mt, rng, i)
        seqs = expected.setdefault(mt.key("t1"), [])
        seqs.append((len(seqs), start + msg.sample_time_ns, 777 + i))  # type: ignore[attr-defined]
        log.add_json(mt.message_id, msgspec.json.encode(msg), msg.sample_time_ns, 777 + i)  # type: ignore[attr-defined]
    log.close()
    check_complete_mcap(path, validate=False)  # random values break the schemas' ranges
    got: dict[str, list[tuple[int, int, int]]] = {}
    for topic, seq, log_time, publish_time, _data in _read_all(path):
        got.setdefault(topic, []).append((seq, log_time, publish_time))
    assert got == expected


def test_batch_log_rejects_bad_input(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="compression 'gzip'"):
        BatchRunLog(tmp_path / "x.mcap", "t1", compression="gzip")
    with pytest.raises(ValueError, match="batch_messages"):
        BackgroundRunLog(tmp_path / "y.mcap", "t1", {}, batch_messages=0)


def test_histogram_percentiles_are_the_first_bin_reaching_the_rank() -> None:
    """The running summary's percentiles (one bisection of the running sums) against the
    definition: the upper edge of the first bin whose cumulative count reaches q/100 * n
    (capped by the exact maximum)."""
    from hil.timing import _BINS_PER_DECADE, _MIN_NS, LatencyHistogram

    rng = random.Random(7)
    qs = (0.1, 1.0, 50.0, 99.0, 99.9, 100.0)
    for trial in range(200):
        h = LatencyHistogram()
        # Every other histogram in a narrow band (a run's latencies: a few dozen bins, far
        # from the first and the last; the bisection runs over the occupied bins only).
        lo_exp, hi_exp = (0, 11) if trial % 2 else (4.5, 5.1)
        samples = [int(10 ** rng.uniform(lo_exp, hi_exp)) for _ in range(rng.randrange(0, 300))]
        for s in samples:
            h.record(s)
        want = []
        for q in qs:
            if not samples:
                want.append(0.0)
                continue
            acc = 0
            for idx, c in enumerate(h.counts):
                acc += c
                if acc >= q / 100 * len(samples) and c > 0:
                    edge = _MIN_NS if idx == 0 else _MIN_NS * 10 ** (idx / _BINS_PER_DECADE)
                    want.append((edge if idx == 0 else min(edge, max(samples))) / 1e3)
                    break
        assert h.percentiles_us(*qs) == want
        assert [h.percentile_us(q) for q in qs] == want


def test_recover_a_log_cut_inside_any_message_index(tmp_path: Path) -> None:
    """``recover`` (``fowt recover``) keeps every message before a cut, wherever the cut
    falls: here inside each MessageIndex record of a file (mcap's reader raises
    ``struct.error`` there, not an McapError)."""
    import struct

    from hil.mcap_log import MCAP_MAGIC, recover

    path = tmp_path / "run.mcap"
    log = BatchRunLog(path, "t1", batch_messages=50)
    log.add_metadata("run", {"mode": "inprocess"})
    rng = random.Random(3)
    mt = MESSAGES[1]
    for i in range(400):
        msg = _random_message(mt, rng, i)
        log.add_json(mt.message_id, msgspec.json.encode(msg), msg.sample_time_ns, i)  # type: ignore[attr-defined]
    log.close()
    data = path.read_bytes()
    pos, cuts = len(MCAP_MAGIC), []
    while pos + 9 <= len(data):
        opcode, length = struct.unpack_from("<BQ", data, pos)
        if opcode == 0x07:  # MessageIndex: cut after its channel id and part of an entry
            cuts.append(pos + 9 + 2 + 4 + 11)
        if opcode == 0x0F:  # DataEnd: the summary follows
            break
        pos += 9 + length
    assert len(cuts) == 8
    for k, at in enumerate(cuts):
        cut = tmp_path / f"cut{k}.mcap"
        cut.write_bytes(data[:at])
        kept = sum(len(m) for m in read_run(cut).messages.values())
        assert kept == 50 * (k + 1)  # every chunk before the cut, this one included
        assert recover(cut, tmp_path / f"fixed{k}.mcap") == kept
        assert (
            check_complete_mcap(tmp_path / f"fixed{k}.mcap", validate=False).message_count == kept
        )


def test_publish_block_rows_are_written_as_their_structs(tmp_path: Path) -> None:
    """Rows (row_dtype) handed over in blocks, mixed with single messages: the file holds
    each row's Struct JSON, byte for byte, in publish order per topic; bad blocks refused."""
    rng = random.Random(7)
    path = tmp_path / "rows.mcap"
    log = BackgroundRunLog(path, "t1", {"run": {"mode": "inprocess"}}, batch_messages=100)
    log.wait_ready()
    per_cycle = [mt for mt in MESSAGES if mt.key_suffix in ("sensors", "truth", "command")]
    sent: dict[str, list[bytes]] = {}
    seq = 0
    for block in range(40):
        cycles = 1 + block % 9
        order = [mt.message_id for _ in range(cycles) for mt in per_cycle]
        rows = {}
        for mt in per_cycle:
            msgs = [_random_message(mt, rng, seq + c) for c in range(cycles)]
            rows[mt.message_id] = np.array(
                [msgspec.structs.astuple(m) for m in msgs], dtype=mt.row_dtype
            )
        for c in range(cycles):
            for mt in per_cycle:
                values = rows[mt.message_id][c].tolist()
                msg = mt.cls(**dict(zip(mt.row_dtype.names, values, strict=True)))
                sent.setdefault(mt.key("t1"), []).append(msgspec.json.encode(msg))
        log.publish_block(np.array(order, np.uint8), rows)
        seq += cycles
        single = _random_message(MESSAGES[block % len(MESSAGES)], rng, seq)
        sent.setdefault(MESSAGES[block % len(MESSAGES)].key("t1"), []).append(
            msgspec.json.encode(single)
        )
        log.publish(MESSAGES[block % len(MESSAGES)], single)
    mt0 = per_cycle[0]
    good = np.zeros(2, mt0.row_dtype)
    with pytest.raises(ValueError, match="rows for its ids"):
        log.publish_block(np.array([mt0.message_id], np.uint8), {mt0.message_id: good})
    with pytest.raises(ValueError, match="must be 1-D"):
        log.publish_block(np.array([mt0.message_id] * 2, np.uint8), {mt0.message_id: np.zeros(2)})
    with pytest.raises(ValueError, match="unknown message id"):
        log.publish_block(np.array([250], np.uint8), {250: good})
    with pytest.raises(ValueError, match="has no rows"):
        log.publish_block(
            np.array([mt0.message_id] * 2 + [per_cycle[1].message_id], np.uint8),
            {mt0.message_id: good},
        )
    log.close()
    got: dict[str, list[bytes]] = {}
    for topic, _seq, _lt, _pt, data in _read_all(path):
        got.setdefault(topic, []).append(data)
    assert got == sent


ROW_FLOATS = (
    *FLOATS,
    -5e-324,
    -1.7976931348623157e308,
    2.2250738585072014e-308,
    0.1,
    1 / 3,
    -123.0,
    1e16,
    1e-7,
    float("nan"),
    float("inf"),
    float("-inf"),
)
ROW_INTS = (*INTS, -(2**63), -(2**63) + 1, 2**53 + 1, -40_000_000_000)


def test_publish_block_extremes_all_cycle_types_times_and_order(tmp_path: Path) -> None:
    """All five per-cycle types as rows, with extreme floats (subnormals, the largest
    double, -0.0, NaN and inf, which msgspec writes as ``null``) and int64 extremes in the
    int fields, in blocks that straddle batches (split by count), mixed with Structs of
    the same types: the file holds exactly the Structs' JSON in publish order (the whole
    file's message sequence, not only per topic), sequence numbers 0, 1, ... per channel,
    log time = run start + sample time and publish time = publish_time_ns + one constant
    (the monotonic clock moved to the unix epoch) for every message."""
    rng = random.Random(1515)
    path = tmp_path / "rows.mcap"
    log = BackgroundRunLog(path, "t1", {"run": {"mode": "inprocess"}}, batch_messages=64)
    log.wait_ready()
    cycle_types = [
        mt
        for mt in MESSAGES
        if mt.key_suffix in ("sensors", "truth", "command", "controller/status", "timing/cycle")
    ]
    assert len(cycle_types) == 5
    sent: list[tuple[str, bytes, int, int]] = []
    seq = 0

    def value(kind: str) -> typing.Any:
        if kind == "i":
            return rng.choice(ROW_INTS) if rng.random() < 0.7 else rng.randrange(-(2**63), 2**63)
        return rng.choice(ROW_FLOATS) if rng.random() < 0.7 else rng.uniform(-1e300, 1e300)

    for block in range(30):
        cycles = 1 + (block * 5) % 13  # 1 .. 13 cycles: blocks cross the 64-message batches
        order: list[int] = []
        rows: dict[int, list[tuple[typing.Any, ...]]] = {mt.message_id: [] for mt in cycle_types}
        for _c in range(cycles):
            for mt in rng.sample(cycle_types, len(cycle_types)):  # any order within a cycle
                dtype = mt.row_dtype
                vals = {name: value(dtype[name].kind) for name in dtype.names or ()}
                vals.update(seq=seq, sample_time_ns=seq * 25_000_000, publish_time_ns=5 * seq)
                seq += 1
                values = tuple(vals[name] for name in dtype.names or ())
                rows[mt.message_id].append(values)
                order.append(mt.message_id)
                msg = mt.cls(**vals)
                sent.append(
                    (mt.key("t1"), msgspec.json.encode(msg), vals["sample_time_ns"], 5 * (seq - 1))
                )
        arrays = {
            mid: np.array(r, dtype=next(m for m in MESSAGES if m.message_id == mid).row_dtype)
            for mid, r in rows.items()
        }
        log.publish_block(np.array(order, np.uint8), arrays)
        for buf in arrays.values():  # the caller may reuse its buffers at once
            buf.view(np.uint8)[:] = 0xFF
        if block % 3 == 0:
            mt = cycle_types[block % 5]
            single = _random_message(mt, rng, seq)
            sent.append((mt.key("t1"), msgspec.json.encode(single), seq * 25_000_000, 10**9 + seq))
            seq += 1
            log.publish(mt, single)
    log.close()
    assert log.writer_messages == len(sent)
    check_complete_mcap(path, validate=False)
    got = _read_all(path)
    assert [(t, d) for t, _s, _lt, _pt, d in got] == [(t, d) for t, d, _st, _pt in sent]
    per_topic: dict[str, int] = {}
    log_offsets, publish_offsets = set(), set()
    for (topic, sequence, log_time, publish_time, _d), (_t, _data, sample, publish) in zip(
        got, sent, strict=True
    ):
        assert sequence == per_topic.get(topic, 0)
        per_topic[topic] = sequence + 1
        log_offsets.add(log_time - sample)
        publish_offsets.add(publish_time - publish)
    assert len(log_offsets) == 1 and len(publish_offsets) == 1
    assert abs(publish_offsets.pop() - (time.time_ns() - time.monotonic_ns())) < 10**9
    assert abs(log_offsets.pop() - time.time_ns()) < 600 * 10**9


def test_publish_block_refuses_bad_blocks_and_keeps_the_batch(tmp_path: Path) -> None:
    """Refused blocks (wrong shape, a list instead of an array, a wrong dtype, an id 0x80
    and above) raise before anything is queued: the file holds only the good messages."""
    path = tmp_path / "bad.mcap"
    log = BackgroundRunLog(path, "t1", {}, batch_messages=8)
    mt = MESSAGES[0]
    good = np.zeros(3, mt.row_dtype)
    good["seq"] = [0, 1, 2]
    ids = np.full(3, mt.message_id, np.uint8)
    with pytest.raises(ValueError, match="order must be 1-D"):
        log.publish_block(ids.reshape(3, 1), {mt.message_id: good})
    with pytest.raises(ValueError, match="must be 1-D"):
        log.publish_block(ids, {mt.message_id: good.tolist()})  # type: ignore[dict-item]
    with pytest.raises(ValueError, match="must be 1-D"):
        log.publish_block(ids, {mt.message_id: np.zeros(3, MESSAGES[1].row_dtype)})
    with pytest.raises(ValueError, match="unknown message id"):
        log.publish_block(ids | 0x80, {mt.message_id | 0x80: good})
    with pytest.raises(ValueError, match="has no rows"):
        log.publish_block(ids | 0x80, {mt.message_id: good[:0]})
    log.publish_block(ids, {mt.message_id: good})
    log.close()
    assert log.writer_messages == 3
    assert [orjson.loads(d)["seq"] for *_x, d in _read_all(path)] == [0, 1, 2]


_NO_CLOSE = """
import sys
from pathlib import Path
from bus_schemas.registry import TIMING_SUMMARY
from hil.log_writer import BackgroundRunLog
if __name__ == "__main__":
    log = BackgroundRunLog(Path(sys.argv[1]), "t1", {"run": {"mode": "inprocess"}})
    log.wait_ready()
    raise SystemExit("the run failed before close()")
"""


def test_a_log_never_closed_does_not_keep_the_interpreter_alive(tmp_path: Path) -> None:
    """An exception before close(): the process exits (the writer child sees the pipe close,
    finishes the file) instead of waiting forever in multiprocessing's join at exit."""
    script = tmp_path / "no_close.py"
    script.write_text(_NO_CLOSE)
    path = tmp_path / "run.mcap"
    done = subprocess.run(
        [sys.executable, str(script), str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        cwd=Path(__file__).resolve().parent.parent,
    )
    assert done.returncode == 1, done.stderr
    assert "the run failed before close()" in done.stderr
    with open(path, "rb") as fh:  # a finished file: summary and footer written
        assert make_reader(fh).get_summary() is not None
    assert read_run(path).metadata["run"] == {"mode": "inprocess"}


def _batch_blob(
    rng: random.Random, n: int, row_share: float, seq0: int
) -> tuple[bytes, list[bytes]]:
    """A batch as the pipe carries it: ``n`` messages of every registered type in random
    order, each a row (extreme values; probability ``row_share``) or a Struct; and the
    Struct JSON of each message in order."""
    from hil.log_writer import ROW_FLAG, _encode_batch_payload

    ids = bytearray()
    structs: dict[int, list[msgspec.Struct]] = {}
    rows: dict[int, list[tuple[typing.Any, ...]]] = {}
    want: list[bytes] = []
    for i in range(n):
        mt = rng.choice(MESSAGES)
        seq = seq0 + i
        if rng.random() < row_share:
            dtype = mt.row_dtype
            vals = {
                name: (
                    rng.choice(ROW_INTS)
                    if dtype[name].kind == "i" and rng.random() < 0.7
                    else rng.randrange(-(2**63), 2**63)
                    if dtype[name].kind == "i"
                    else rng.choice(ROW_FLOATS)
                    if rng.random() < 0.7
                    else rng.uniform(-1e300, 1e300)
                )
                for name in dtype.names or ()
            }
            vals.update(seq=seq, sample_time_ns=seq * 25_000_000, publish_time_ns=7 * seq)
            rows.setdefault(mt.message_id, []).append(tuple(vals[k] for k in dtype.names or ()))
            ids.append(mt.message_id | ROW_FLAG)
            want.append(msgspec.json.encode(mt.cls(**vals)))
        else:
            msg = _random_message(mt, rng, seq)
            structs.setdefault(mt.message_id, []).append(msg)
            ids.append(mt.message_id)
            want.append(msgspec.json.encode(msg))
    by_id = {mt.message_id: mt for mt in MESSAGES}
    raw = {mid: np.array(r, dtype=by_id[mid].row_dtype).tobytes() for mid, r in rows.items()}
    return _encode_batch_payload((bytes(ids), structs, raw)), want


@pytest.mark.parametrize("compression", ["zstd", ""])
def test_fused_records_equal_the_reference_framing_byte_for_byte(
    tmp_path: Path, compression: str
) -> None:
    """The writer child's fused path (:class:`hil.log_writer._BatchFramer`: the record
    kernel writing each message's header and JSON, the MessageIndex entries from the same
    pass, :meth:`BatchRunLog.write_chunk`) writes the same file, byte for byte, as the
    reference (:func:`hil.log_writer._encode_batch` and :meth:`BatchRunLog.write_batch`,
    record headers and indexes built with numpy): batches of every registered type, rows
    with extreme values and Structs mixed, only rows, only Structs, one message, a batch
    larger than BATCH_MESSAGES and one larger than the framer's first buffer (1 MiB)."""
    from hil.log_writer import _BatchFramer, _decoders, _encode_batch, _warm_kernels

    rng = random.Random(1313)
    plan = [(BATCH_MESSAGES, 0.9), (BATCH_MESSAGES, 1.0), (300, 0.0), (1, 1.0), (1, 0.0)]
    plan += [(3 * BATCH_MESSAGES, 0.8), (7, 0.5)]
    blobs: list[bytes] = []
    wanted: list[bytes] = []
    seq = 0
    for n, share in plan:
        blob, want = _batch_blob(rng, n, share, seq)
        blobs.append(blob)
        wanted += want
        seq += n
    blobs.append(_batch_blob(rng, 0, 1.0, seq)[0])  # an empty batch writes nothing
    decoders = _decoders()
    start, shift = 1_700_000_000_000_000_000, 12_345
    ref = BatchRunLog(tmp_path / "ref.mcap", "t1", compression=compression, start_unix_ns=start)
    fused = BatchRunLog(tmp_path / "fused.mcap", "t1", compression=compression, start_unix_ns=start)
    framer = _BatchFramer(fused, decoders, shift)
    _warm_kernels(framer)
    grew = False
    for blob in blobs:
        meta, records = _encode_batch(blob, decoders, shift)
        ref.write_batch(meta, records)
        size = len(framer.out)
        framer.frame(blob)
        grew |= len(framer.out) > size
    ref.close()
    fused.close()
    assert grew  # the 3 * BATCH_MESSAGES batch outgrew the first buffer
    assert (tmp_path / "fused.mcap").read_bytes() == (tmp_path / "ref.mcap").read_bytes()
    check_complete_mcap(tmp_path / "fused.mcap", validate=False)
    assert [d for *_x, d in _read_all(tmp_path / "fused.mcap")] == wanted


def test_fused_framer_refuses_bad_batches(tmp_path: Path) -> None:
    """A batch whose parts do not match (rows that do not fit their type, more or fewer
    ids than messages, an unknown message id) raises a ValueError saying so and writes
    nothing; the next good batch is written as usual."""
    from hil.log_writer import ROW_FLAG, _BatchFramer, _decoders, _encode_batch_payload

    log = BatchRunLog(tmp_path / "bad.mcap", "t1")
    framer = _BatchFramer(log, _decoders())
    mt = MESSAGES[0]
    mid = mt.message_id
    row = np.zeros(1, mt.row_dtype).tobytes()
    flag = bytes([mid | ROW_FLAG])
    bad = {
        "do not fit its type": (flag, {}, {mid: row[:-8]}),
        "does not match its rows": (flag * 2, {}, {mid: row}),
        "message ids for": (flag + bytes([mid]), {}, {mid: row}),
        "unknown message id": (bytes([99]), {99: [mt.cls(*[0] * len(mt.row_dtype))]}, {}),
        "rows of message id 99": (bytes([99 | ROW_FLAG]), {}, {99: row}),
    }
    for match, parts in bad.items():
        with pytest.raises(ValueError, match=match):
            framer.frame(_encode_batch_payload(parts))
    framer.frame(_encode_batch_payload((flag, {}, {mid: row})))
    log.close()
    assert log.count == 1
    assert [orjson.loads(d)["seq"] for *_x, d in _read_all(tmp_path / "bad.mcap")] == [0]


def test_copy_value_finds_each_separator_at_every_byte_position() -> None:
    """The record kernel's value copy (8 bytes at a time, the text's last bytes one by
    one): every value of a list ``[v,v,...]`` comes out whole, its ``+`` left out for
    floats (kept for ints, where it cannot occur), at every length from 1 to 26 bytes and
    every position of its separator within an 8-byte word, the last value included."""
    from hil.log_writer import _copy_value

    rng = random.Random(99)
    alphabet = b"0123456789.e-+"
    for plus in (True, False):
        for trial in range(40):
            values = [
                bytes(rng.choice(alphabet) for _ in range(rng.randrange(1, 27)))
                for _ in range(1 + trial % 13)
            ]
            text = np.frombuffer(b"[" + b",".join(values) + b"]", np.uint8)
            out = np.full(len(text) + 8, 0xAA, np.uint8)
            p, d = 1, 0
            for v in values:
                p, d_end = _copy_value(text, p, out, d, plus)
                want = v.replace(b"+", b"") if plus else v
                assert out[d:d_end].tobytes() == want
                d = d_end
            assert p == len(text)  # after the closing "]"


def test_pipe_framing_whole_batches_end_marker_and_cut_batches() -> None:
    """The batches' own framing on the pipe: a batch larger than the pipe's buffer (written
    from a thread while the reader reads, so the writes are partial) and a small one come
    out whole and in order, each in the reader's reused buffer; an empty batch is the end
    marker; a batch cut by the writer's death (its end of the pipe closed mid-batch) reads
    as the end, not as a short batch."""
    import os
    import threading

    from hil.log_writer import _PipeReader, _write_message

    rng = random.Random(5)
    big = rng.randbytes(3 << 20)  # 3 MiB: larger than the pipe and the reader's buffer
    small = b"batch"
    r, w = os.pipe()
    writer = threading.Thread(target=lambda: [_write_message(w, p) for p in (big, small, b"")])
    writer.start()
    reader = _PipeReader(r)
    got = reader.read()
    assert got is not None and bytes(got) == big
    got = reader.read()
    assert got is not None and bytes(got) == small
    assert reader.read() is None  # the end marker
    writer.join()
    os.write(w, (100).to_bytes(8, "little") + b"0123456789")  # a batch cut after 10 bytes
    os.close(w)
    assert reader.read() is None
    assert reader.read() is None  # and the pipe stays at its end
    os.close(r)
