"""The run log writer: one :class:`hil.runlog.mcap_io.RunLog` for every run, CDR channels.

:class:`hil.runlog.writer.BackgroundRunLog` hands msgpack batches to a child that writes each
batch as one chunk of :class:`hil.runlog.mcap_io.RunLog`; the recorder writes the same class
message by message. These checks read the files with readers the bench did not write: the
mcap package's reader for the records and ``mcap-ros2-support``'s CDR decoder for the
payloads. Every message of every registered type comes out with exactly the values of the
Struct or row sent (seeded random values over each field's whole wire range, including
subnormal, largest, negative-zero, NaN and infinite floats, compared bit for bit), with
per-channel sequence numbers 0, 1, ..., log time = run start + sample time, publish time
as given, and a complete, conformant file.
"""

from __future__ import annotations

import math
import random
import struct
import subprocess
import sys
import time
import typing
from pathlib import Path

import msgspec
import numpy as np
import pytest
from _mcap_conformance import check_complete_mcap
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from bus_schemas import ros2
from bus_schemas.registry import BY_CLASS, MESSAGES, MessageType
from hil.runlog.mcap_io import RunLog, read_run
from hil.runlog.writer import BATCH_MESSAGES, BackgroundRunLog

FLOATS = (
    0.0,
    -0.0,
    1.0,
    5e-324,
    -5e-324,
    1.7976931348623157e308,
    -1.7976931348623157e308,
    2.2250738585072014e-308,
    -2.5e-9,
    123456.789,
    1e17,
    1 / 3,
    math.nan,
    math.inf,
    -math.inf,
)
#: Each wire type's extremes and a few values between (a row holds int64, so u64 to 2**63-1).
WIRE_INTS = {
    "u64": (0, 1, 2**53 + 1, 40_000_000_000, 2**63 - 1),
    "i64": (0, 1, -1, -(2**63), 2**63 - 1, -40_000_000_000),
    "u32": (0, 1, 2**31, 2**32 - 1),
    "u8": (0, 1, 127, 255),
}
WIRE_RANGE = {"u64": (0, 2**63 - 1), "i64": (-(2**63), 2**63 - 1), "u32": (0, 2**32 - 1)}
WIRE_RANGE["u8"] = (0, 255)


def _values(mt: MessageType, rng: random.Random, seq: int) -> dict[str, typing.Any]:
    """Random field values over the fields' wire ranges (half of them extremes)."""
    vals: dict[str, typing.Any] = {}
    for f in mt.codec.fields:
        if f.is_float:
            vals[f.name] = rng.choice(FLOATS) if rng.random() < 0.5 else rng.uniform(-1e300, 1e300)
        elif rng.random() < 0.5:
            vals[f.name] = rng.choice(WIRE_INTS[f.wire])
        else:
            vals[f.name] = rng.randint(*WIRE_RANGE[f.wire])
    vals.update(seq=seq, sample_time_ns=seq * 25_000_000, publish_time_ns=10**9 + seq)
    return vals


def _random_message(mt: MessageType, rng: random.Random, seq: int) -> msgspec.Struct:
    return mt.cls(**_values(mt, rng, seq))


def _key(values: typing.Iterable[typing.Any]) -> tuple[typing.Any, ...]:
    """Values compared bit for bit (a float by its 8 bytes: NaN equals NaN, -0.0 is not 0.0)."""
    return tuple(struct.pack("<d", v) if isinstance(v, float) else int(v) for v in values)


def _struct_key(msg: msgspec.Struct) -> tuple[typing.Any, ...]:
    mt = BY_CLASS[type(msg)]
    return _key(
        float(v) if f.is_float else v
        for f, v in zip(mt.codec.fields, msgspec.structs.astuple(msg), strict=True)
    )


def _read_all(path: Path) -> list[tuple[str, int, int, int, tuple[typing.Any, ...]]]:
    """Every message by mcap's reader, its payload decoded by mcap-ros2-support."""
    out = []
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for schema, ch, m, dec in reader.iter_decoded_messages(log_time_order=False):
            assert ch.message_encoding == "cdr" and schema is not None
            assert schema.encoding == "ros2msg"
            mt = next(t for t in MESSAGES if ros2.schema_name(t) == schema.name)
            assert ch.metadata["version"] == str(mt.version)
            fields = mt.codec.fields
            values = _key(getattr(dec, f.name) for f in fields)
            out.append((ch.topic, m.sequence, m.log_time, m.publish_time, values))
    return out


def _per_topic(rows: list[tuple[str, int, int, int, tuple[typing.Any, ...]]]) -> dict[str, list]:
    got: dict[str, list[tuple[typing.Any, ...]]] = {}
    for topic, _seq, _lt, _pt, values in rows:
        got.setdefault(topic, []).append(values)
    return got


def test_background_log_writes_every_struct_exactly(tmp_path: Path) -> None:
    rng = random.Random(15)
    path = tmp_path / "run.mcap"
    log = BackgroundRunLog(path, "t1", {"run": {"mode": "inprocess"}})
    log.wait_ready()
    sent: dict[str, list[tuple[typing.Any, ...]]] = {}
    n = BATCH_MESSAGES * 2 + 77  # two full batches and a partial one sent by close()
    for i in range(n):
        mt = MESSAGES[i % len(MESSAGES)]
        msg = _random_message(mt, rng, i)
        sent.setdefault(mt.key("t1"), []).append(_struct_key(msg))
        log.publish(mt, msg)
    log.close()
    assert log.writer_messages == n
    found = check_complete_mcap(path, validate=False)  # random values break the ranges
    assert found.per_topic == {k: len(v) for k, v in sent.items()}
    assert found.chunk_count == 3  # one chunk a batch
    assert _per_topic(_read_all(path)) == sent  # bit for bit, in order, per topic
    run = read_run(path)
    assert run.metadata["run"] == {"mode": "inprocess"}

    # The bench's own reader agrees; its dicts hold a non-finite float as None (as the JSON
    # channels wrote it), its columns the value itself.
    def as_dict_value(v: typing.Any) -> typing.Any:
        if isinstance(v, bytes) and not math.isfinite(struct.unpack("<d", v)[0]):
            return None
        return v

    got = {
        t: [tuple(None if v is None else _key([v])[0] for v in m.values()) for m in msgs]
        for t, msgs in run.messages.items()
        if msgs
    }
    assert got == {t: [tuple(map(as_dict_value, k)) for k in v] for t, v in sent.items()}
    for t, msgs in run.messages.items():
        if msgs:
            names = list(msgs[0])
            cols = [msgs.column(n) for n in names]  # type: ignore[attr-defined]
            rebuilt = [
                _key(
                    float(c[i]) if isinstance(m[n], float | None) else m[n]
                    for c, n in zip(cols, names, strict=True)
                )
                for i, m in enumerate(msgs)
            ]
            want = [
                tuple(
                    b
                    if isinstance(b, int) or math.isfinite(struct.unpack("<d", b)[0])
                    else struct.pack("<d", math.nan)
                    for b in k
                )
                for k in sent[t]
            ]
            assert rebuilt == want, t  # the columns: nan where the dict has None


def test_run_log_sequences_and_times(tmp_path: Path) -> None:
    """write(): sequence per channel from 0, log time = start + sample time, publish time
    kept; a chunk every ``batch_messages`` messages."""
    path = tmp_path / "c.mcap"
    start = 1_700_000_000_000_000_000
    log = RunLog(path, "t1", start_unix_ns=start, flush_interval_s=1e9, batch_messages=100)
    by_id = {mt.message_id: mt for mt in MESSAGES}
    rng = random.Random(2)
    expected: dict[str, list[tuple[int, int, int]]] = {}
    for i in range(1050):
        mt = by_id[rng.choice([1, 2, 3])]
        msg = _random_message(mt, rng, i)
        seqs = expected.setdefault(mt.key("t1"), [])
        seqs.append((len(seqs), start + msg.sample_time_ns, 777 + i))  # type: ignore[attr-defined]
        log.write(mt.key("t1"), msg, 777 + i)
    assert log.count == 1050
    log.close()
    assert check_complete_mcap(path, validate=False).chunk_count == 11
    got: dict[str, list[tuple[int, int, int]]] = {}
    for topic, seq, log_time, publish_time, _values in _read_all(path):
        got.setdefault(topic, []).append((seq, log_time, publish_time))
    assert got == expected


def test_run_log_rejects_bad_input(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="compression 'gzip'"):
        RunLog(tmp_path / "x.mcap", "t1", compression="gzip")
    with pytest.raises(ValueError, match="batch_messages"):
        BackgroundRunLog(tmp_path / "y.mcap", "t1", {}, batch_messages=0)
    log = RunLog(tmp_path / "z.mcap", "t1")
    mt = MESSAGES[0]
    with pytest.raises(KeyError, match="no channel registered"):
        log.write("fowt/t2/sensors", _random_message(mt, random.Random(1), 0))
    cid = int(log.channel_of_message_id[mt.message_id])
    with pytest.raises(ValueError, match="rows must be 1-D"):
        log.write_rows(cid, np.zeros(2, MESSAGES[1].row_dtype), 0)
    with pytest.raises(ValueError, match="registered already"):
        log.add_channel(mt.key("t1"), mt)
    log.close()
    assert read_run(tmp_path / "z.mcap").complete


def test_cdr_layout_is_mcap_ros2_supports_own(tmp_path: Path) -> None:
    """Every registered type: the payloads :func:`bus_schemas.ros2.encode_rows` builds are
    byte for byte those mcap-ros2-support's own encoder writes for the same values from the
    generated ``msgdef`` (alignment, no trailing padding), :func:`bus_schemas.ros2.decode`
    gives the values back, and data of another length is refused with a clear error."""
    import io

    from mcap_ros2.writer import Writer as Ros2Writer

    rng = random.Random(21)
    for mt in (*MESSAGES, *(m for m in BY_CLASS.values() if m not in MESSAGES)):
        msgs = [_values(mt, rng, i) for i in range(5)]
        rows = np.array([tuple(v[n] for n in mt.row_dtype.names or ()) for v in msgs], mt.row_dtype)
        mine = ros2.encode_rows(mt, rows)
        assert mine.dtype == ros2.cdr_dtype(mt) and mine.flags.c_contiguous
        buf = io.BytesIO()
        writer = Ros2Writer(buf)
        schema = writer.register_msgdef(ros2.schema_name(mt), ros2.msgdef(mt))
        for v in msgs:
            writer.write_message("t", schema, v, log_time=0, publish_time=0)
        writer.finish()
        buf.seek(0)
        theirs = [m.data for _s, _c, m in make_reader(buf).iter_messages()]
        assert [r.tobytes() for r in mine] == theirs, mt.name
        back = ros2.decode(mt, mine.tobytes())
        for v, rec in zip(msgs, back, strict=True):
            assert _key(rec[n].item() for n in mt.row_dtype.names or ()) == _key(
                float(v[f.name]) if f.is_float else v[f.name] for f in mt.codec.fields
            )
        with pytest.raises(ros2.CdrLengthError, match="not a whole number"):
            ros2.decode(mt, mine.tobytes()[:-1])
        with pytest.raises(ros2.CdrLengthError, match="CDR_LE"):
            ros2.decode(mt, b"\x00\x00" + mine.tobytes()[2:])


def test_histogram_percentiles_are_the_first_bin_reaching_the_rank() -> None:
    """The running summary's percentiles (one bisection of the running sums) against the
    definition: the upper edge of the first bin whose cumulative count reaches q/100 * n
    (capped by the exact maximum)."""
    from hil.nodes.timing import _BINS_PER_DECADE, _MIN_NS, LatencyHistogram

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
    from hil.runlog.mcap_io import MCAP_MAGIC, recover

    path = tmp_path / "run.mcap"
    log = RunLog(path, "t1", batch_messages=50, flush_interval_s=1e9)
    log.add_metadata("run", {"mode": "inprocess"})
    rng = random.Random(3)
    mt = MESSAGES[1]
    for i in range(400):
        log.write(mt.key("t1"), _random_message(mt, rng, i), i)
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
    each row's values, bit for bit, in publish order per topic; bad blocks refused."""
    rng = random.Random(7)
    path = tmp_path / "rows.mcap"
    log = BackgroundRunLog(path, "t1", {"run": {"mode": "inprocess"}}, batch_messages=100)
    log.wait_ready()
    per_cycle = [mt for mt in MESSAGES if mt.key_suffix in ("sensors", "truth", "command")]
    sent: dict[str, list[tuple[typing.Any, ...]]] = {}
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
            sent.setdefault(mt.key("t1"), []).extend(_struct_key(m) for m in msgs)
        log.publish_block(np.array(order, np.uint8), rows)
        seq += cycles
        single = _random_message(MESSAGES[block % len(MESSAGES)], rng, seq)
        sent.setdefault(MESSAGES[block % len(MESSAGES)].key("t1"), []).append(_struct_key(single))
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
    assert _per_topic(_read_all(path)) == sent


def test_publish_block_extremes_all_cycle_types_times_and_order(tmp_path: Path) -> None:
    """All five per-cycle types as rows, with extreme values, in blocks that straddle
    batches (split by count), mixed with Structs of the same types: the file holds exactly
    the values sent in publish order per topic, sequence numbers 0, 1, ... per channel,
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
    sent: dict[str, list[tuple[tuple[typing.Any, ...], int, int]]] = {}
    seq = 0
    for block in range(30):
        cycles = 1 + (block * 5) % 13  # 1 .. 13 cycles: blocks cross the 64-message batches
        order: list[int] = []
        rows: dict[int, list[tuple[typing.Any, ...]]] = {mt.message_id: [] for mt in cycle_types}
        for _c in range(cycles):
            for mt in rng.sample(cycle_types, len(cycle_types)):  # any order within a cycle
                vals = _values(mt, rng, seq)
                vals.update(publish_time_ns=5 * seq)
                seq += 1
                rows[mt.message_id].append(tuple(vals[n] for n in mt.row_dtype.names or ()))
                order.append(mt.message_id)
                sent.setdefault(mt.key("t1"), []).append(
                    (_struct_key(mt.cls(**vals)), vals["sample_time_ns"], vals["publish_time_ns"])
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
            sent.setdefault(mt.key("t1"), []).append(
                (_struct_key(single), seq * 25_000_000, 10**9 + seq)
            )
            seq += 1
            log.publish(mt, single)
    log.close()
    assert log.writer_messages == sum(len(v) for v in sent.values())
    check_complete_mcap(path, validate=False)
    got = _read_all(path)
    assert _per_topic(got) == {t: [v for v, _s, _p in m] for t, m in sent.items()}
    per_topic: dict[str, int] = {}
    log_offsets, publish_offsets = set(), set()
    for topic, sequence, log_time, publish_time, _v in got:
        _values_sent, sample, publish = sent[topic][sequence]
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
    assert [v[0] for *_x, v in _read_all(path)] == [0, 1, 2]


_NO_CLOSE = """
import sys
from pathlib import Path
from bus_schemas.registry import TIMING_SUMMARY
from hil.runlog.writer import BackgroundRunLog
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
) -> tuple[bytes, dict[str, list[tuple[typing.Any, ...]]]]:
    """A batch as the pipe carries it: ``n`` messages of every registered type in random
    order, each a row (probability ``row_share``) or a Struct; and the values of each
    message per topic in publish order."""
    from hil.runlog.writer import ROW_FLAG, _encode_batch_payload

    ids = bytearray()
    structs: dict[int, list[msgspec.Struct]] = {}
    rows: dict[int, list[tuple[typing.Any, ...]]] = {}
    want: dict[str, list[tuple[typing.Any, ...]]] = {}
    for i in range(n):
        mt = rng.choice(MESSAGES)
        vals = _values(mt, rng, seq0 + i)
        if rng.random() < row_share:
            rows.setdefault(mt.message_id, []).append(
                tuple(vals[k] for k in mt.row_dtype.names or ())
            )
            ids.append(mt.message_id | ROW_FLAG)
        else:
            structs.setdefault(mt.message_id, []).append(mt.cls(**vals))
            ids.append(mt.message_id)
        want.setdefault(mt.key("t1"), []).append(_struct_key(mt.cls(**vals)))
    by_id = {mt.message_id: mt for mt in MESSAGES}
    raw = {mid: np.array(r, dtype=by_id[mid].row_dtype).tobytes() for mid, r in rows.items()}
    return _encode_batch_payload((bytes(ids), structs, raw)), want


def test_framer_writes_one_chunk_a_batch_rows_and_structs_in_publish_order(
    tmp_path: Path,
) -> None:
    """The writer child's framing (:class:`hil.runlog.writer._BatchFramer`): batches of every
    registered type, rows and Structs of one type mixed, only rows, only Structs, one
    message and one larger than BATCH_MESSAGES, each one chunk, every message's values in
    publish order per topic; an empty batch writes nothing."""
    from hil.runlog.writer import _BatchFramer, _decoders

    rng = random.Random(1313)
    plan = [(BATCH_MESSAGES, 0.9), (BATCH_MESSAGES, 1.0), (300, 0.0), (1, 1.0), (1, 0.0)]
    plan += [(3 * BATCH_MESSAGES, 0.8), (7, 0.5)]
    wanted: dict[str, list[tuple[typing.Any, ...]]] = {}
    log = RunLog(tmp_path / "f.mcap", "t1", start_unix_ns=1_700_000_000_000_000_000)
    framer = _BatchFramer(log, _decoders(), 12_345)
    seq = 0
    for n, share in plan:
        blob, want = _batch_blob(rng, n, share, seq)
        for topic, values in want.items():
            wanted.setdefault(topic, []).extend(values)
        framer.frame(blob)
        seq += n
    framer.frame(_batch_blob(rng, 0, 1.0, seq)[0])
    log.close()
    found = check_complete_mcap(tmp_path / "f.mcap", validate=False)
    assert found.chunk_count == len(plan)
    assert _per_topic(_read_all(tmp_path / "f.mcap")) == wanted


def test_framer_refuses_bad_batches(tmp_path: Path) -> None:
    """A batch whose parts do not match (rows that do not fit their type, more or fewer
    ids than messages, an unknown message id) raises a ValueError saying so and writes
    nothing; the next good batch is written as usual."""
    from hil.runlog.writer import ROW_FLAG, _BatchFramer, _decoders, _encode_batch_payload

    log = RunLog(tmp_path / "bad.mcap", "t1")
    framer = _BatchFramer(log, _decoders())
    mt = MESSAGES[0]
    mid = mt.message_id
    row = np.zeros(1, mt.row_dtype).tobytes()
    flag = bytes([mid | ROW_FLAG])
    bad = {
        "do not fit its type": (flag, {}, {mid: row[:-8]}),
        "does not match its rows": (flag * 2, {}, {mid: row}),
        "does not match its messages": (flag + bytes([mid]), {}, {mid: row}),
        "message ids for": (flag + bytes([2 | ROW_FLAG]), {}, {mid: row}),
        "unknown message id": (bytes([99]), {99: [mt.cls(*[0] * len(mt.row_dtype))]}, {}),
        "unknown message id 99": (bytes([99 | ROW_FLAG]), {}, {99: row}),
    }
    for match, parts in bad.items():
        with pytest.raises(ValueError, match=match):
            framer.frame(_encode_batch_payload(parts))
    framer.frame(_encode_batch_payload((flag, {}, {mid: row})))
    log.close()
    assert log.count == 1
    assert [v[0] for *_x, v in _read_all(tmp_path / "bad.mcap")] == [0]


def test_pipe_framing_whole_batches_end_marker_and_cut_batches() -> None:
    """The batches' own framing on the pipe: a batch larger than the pipe's buffer (written
    from a thread while the reader reads, so the writes are partial) and a small one come
    out whole and in order, each in the reader's reused buffer; an empty batch is the end
    marker; a batch cut by the writer's death (its end of the pipe closed mid-batch) reads
    as the end, not as a short batch."""
    import os
    import threading

    from hil.runlog.writer import _PipeReader, _write_message

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


def test_a_sequence_number_past_int64_is_refused_and_counted_by_the_recorder(
    tmp_path: Path,
) -> None:
    """The codec lets a ``uint64`` sequence number reach 2**64 - 1; the run log's rows are
    int64. ``RunLog.write`` refuses such a message (ValueError, nothing queued) and the
    recorder counts it as a ``range`` rejection; the messages around it are written."""
    from hil.nodes.recorder import Recorder, RecorderLog

    mt = MESSAGES[0]
    fields = {f.name: 0.0 if f.is_float else 0 for f in mt.codec.fields}
    log = RecorderLog(tmp_path / "r.mcap", "t1")
    with pytest.raises(ValueError, match="does not fit"):
        log.write(mt.key("t1"), mt.cls(**{**fields, "seq": 2**63}))
    rec = Recorder(log)
    for seq in (0, 2**64 - 1, 1):
        rec.on_sample(mt.key("t1"), mt.codec.encode(mt.cls(**{**fields, "seq": seq})))
    assert rec.drain(0.0) == 2
    log.close()
    assert rec.rejected == {"sensors:range": 1}
    assert [m["seq"] for m in read_run(tmp_path / "r.mcap").topic("sensors")] == [0, 1]
