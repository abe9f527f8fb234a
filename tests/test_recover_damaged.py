"""A run log with a damaged chunk in the middle: recovery and review keep everything else.

The log is a real :class:`hil.runlog.mcap_io.RunLog` file of a few thousand messages in small
chunks. One chunk in the middle is damaged (its zstd data, its CRC, or a length in its header);
``fowt recover`` must skip exactly that chunk, say which bytes and log times it skipped and
how many messages they held, keep every message of every other chunk and write a file that
mcap's reader opens, and exit 0 only when no message of the input is missing from it (each
kind of damage in the table of :data:`DAMAGE`, checked against the undamaged original);
``fowt review`` must read the chunks after the damaged one too and report the file as not
complete (``--strict`` exits non-zero).
"""

from __future__ import annotations

import io
import re
import struct
from collections import Counter
from pathlib import Path

import pytest
from _helpers import cycle_timing, timing_summary
from mcap.reader import make_reader
from mcap.records import Message
from mcap.stream_reader import StreamReader, breakup_chunk
from typer.testing import CliRunner

from bus_schemas import ActuatorCommand
from bus_schemas.registry import COMMAND, CYCLE_TIMING, TIMING_SUMMARY
from hil.cli.fowt import app
from hil.review.core import review
from hil.runlog.mcap_io import RunLog, SkippedRange, read_run, recover

TID = "t1"
CYCLES = 1500  # two messages each: 3000 messages
PER_CHUNK = 100  # messages per chunk (a flush every 100): 30 chunks
PERIOD_NS = 10_000_000
START_NS = 1_700_000_000_000_000_000


def _write_log(path: Path, compression: str = "zstd") -> None:
    log = RunLog(path, TID, start_unix_ns=START_NS, flush_interval_s=1e9, compression=compression)
    log.add_metadata("run", {"mode": "realtime", "speed": "1"})
    n = 0
    for k in range(CYCLES):
        t = k * PERIOD_NS
        log.write(
            COMMAND.key(TID),
            ActuatorCommand(
                seq=k,
                answered_seq=k,
                sample_time_ns=t,
                publish_time_ns=t,
                mode=2 if 600 <= k < 700 else 0,
                blade_pitch_commanded_rad=0.01 * (k % 7),
                generator_torque_commanded_nm=1000.0 + k,
            ),
            receive_unix_ns=START_NS + t,
        )
        log.write(
            CYCLE_TIMING.key(TID),
            cycle_timing(k, t, latency_ns=500_000 + k, plant_compute_ns=80_000),
            receive_unix_ns=START_NS + t,
        )
        n += 2
        if n % PER_CHUNK == 0:
            log.flush()
    log.write(
        TIMING_SUMMARY.key(TID),
        timing_summary(
            CYCLES,
            CYCLES * PERIOD_NS,
            latency_p50_us=500.0,
            latency_p99_us=510.0,
            latency_p999_us=511.0,
            latency_max_us=511.5,
        ),
        receive_unix_ns=START_NS + CYCLES * PERIOD_NS,
    )
    log.close()


def _chunks(path: Path) -> list[tuple[int, int, Counter[str]]]:
    """Each chunk's byte range and its messages per topic (mcap's seeking reader)."""
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        assert summary is not None
        topics = {cid: ch.topic for cid, ch in summary.channels.items()}
        out = []
        for ci in summary.chunk_indexes:
            fh.seek(ci.chunk_start_offset)
            raw = fh.read(ci.chunk_length)
            chunk = next(StreamReader(io.BytesIO(raw), skip_magic=True, emit_chunks=True).records)
            counts: Counter[str] = Counter()
            for rec in breakup_chunk(chunk):
                if isinstance(rec, Message):
                    counts[topics[rec.channel_id]] += 1
            out.append((ci.chunk_start_offset, ci.chunk_length, counts))
    return out


@pytest.fixture(scope="module")
def clean_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("damaged") / "run.mcap"
    _write_log(path)
    return path


def _damage(
    src: Path, dst: Path, how: str, victim: int | None = None
) -> tuple[int, int, Counter[str]]:
    """Copy ``src`` to ``dst`` with one chunk damaged (default: the middle one); return its
    byte range and the messages of the other chunks."""
    chunks = _chunks(src)
    assert len(chunks) >= 20
    victim = len(chunks) // 2 if victim is None else victim
    start, length, _lost = chunks[victim]
    data = bytearray(src.read_bytes())
    if how == "zstd":  # the compressed data's first bytes (the zstd frame magic)
        (n_comp,) = struct.unpack_from("<I", data, start + 9 + 28)
        at = start + 9 + 32 + n_comp + 8
        data[at : at + 8] = b"\xde\xad\xbe\xef" * 2
    elif how == "crc":  # the uncompressed CRC: the data decompresses but does not match
        at = start + 9 + 24
        data[at : at + 4] = bytes(b ^ 0xFF for b in data[at : at + 4])
    elif how == "size":  # the compressed size: the reader takes the next records with it
        (n_comp,) = struct.unpack_from("<I", data, start + 9 + 28)
        at = start + 9 + 32 + n_comp
        (n_data,) = struct.unpack_from("<Q", data, at)
        data[at : at + 8] = struct.pack("<Q", n_data + 5000)
    elif how == "framing":  # the compression name's length: the reader loses its place
        data[start + 9 + 28 : start + 9 + 32] = struct.pack("<I", 0xFFFF_FFF0)
    else:
        raise AssertionError(how)
    dst.write_bytes(bytes(data))
    kept: Counter[str] = Counter()
    for i, (_s, _n, counts) in enumerate(chunks):
        if i != victim:
            kept += counts
    return start, start + length, kept


def _counts(path: Path) -> Counter[str]:
    with open(path, "rb") as fh:
        return Counter(ch.topic for _s, ch, _m in make_reader(fh).iter_messages())


@pytest.mark.parametrize("how", ["zstd", "crc", "size", "framing"])
def test_recover_skips_the_damaged_chunk_and_keeps_the_others(
    clean_log: Path, tmp_path: Path, how: str
) -> None:
    bad = tmp_path / "run.mcap"
    start, end, kept = _damage(clean_log, bad, how)
    out = tmp_path / "fixed.mcap"
    skipped: list[SkippedRange] = []
    n = recover(bad, out, skipped)
    assert _counts(out) == kept  # every message of every other chunk, by channel
    assert n == sum(kept.values()) < CYCLES * 2 + 1
    assert len(skipped) == 1
    # The skipped range starts at the damaged chunk and ends at or before the next record
    # the reader could use (the chunk's message indexes follow it).
    assert skipped[0].start == start
    assert end <= skipped[0].end
    with open(out, "rb") as fh:  # a complete file: summary and footer, metadata kept
        reader = make_reader(fh)
        assert reader.get_summary() is not None
        assert {m.name for m in reader.iter_metadata()} == {"run"}


def test_recover_cli_prints_the_skipped_range(clean_log: Path, tmp_path: Path) -> None:
    bad = tmp_path / "run.mcap"
    start, _end, kept = _damage(clean_log, bad, "zstd")
    res = CliRunner().invoke(app, ["recover", str(bad)])
    assert res.exit_code == 4, res.output  # recording incomplete: a range is lost
    lost = sum(Counter(_counts(clean_log)).values()) - sum(kept.values())
    assert f"warning: {lost} messages lost in 1 range(s)" in res.output
    assert "Traceback" not in res.output
    lines = [line for line in res.output.splitlines() if " lost in bytes " in line]
    assert len(lines) == 1, res.output
    assert lines[0].startswith(f"{lost} messages lost in bytes {start}-")
    # The lost chunk's log times, in seconds since the file's first message (= t here).
    times = lines[0].split("log time ")[1].removesuffix(" s").split("-")
    a, b = float(times[0]), float(times[1])
    assert 0.0 < a <= b < CYCLES * PERIOD_NS / 1e9
    assert _counts(tmp_path / "run.recovered.mcap") == kept


def test_review_reads_past_the_damaged_chunk(clean_log: Path, tmp_path: Path) -> None:
    bad = tmp_path / "run.mcap"
    start, _end, kept = _damage(clean_log, bad, "zstd")
    run = read_run(bad)
    assert {t: len(m) for t, m in run.messages.items() if m} == dict(kept)
    assert run.truncated and not run.complete
    assert [r.start for r in run.skipped] == [start]
    summary = review(bad, tmp_path / "out", plots=False)
    assert summary["run"]["skipped_ranges"][0]["start"] == start
    # The chunks after the damaged one were read: the last cycle and the final summary.
    assert summary["timing"]["complete"] is True
    assert summary["run"]["messages"]["timing/cycle"] == kept[CYCLE_TIMING.key(TID)]
    res = CliRunner().invoke(app, ["review", str(bad), "--no-plots", "--strict"])
    assert res.exit_code == 1, res.output


def test_a_clean_log_reads_complete(clean_log: Path) -> None:
    run = read_run(clean_log)
    assert run.complete and not run.skipped and run.statistics_ok
    assert sum(len(m) for m in run.messages.values()) == 2 * CYCLES + 1


def test_channels_lost_with_the_first_chunk_come_from_the_summary(
    clean_log: Path, tmp_path: Path
) -> None:
    """mcap's writer puts the Schema and Channel records in the first chunk: with it lost,
    the summary section's copies name the channels of the messages after it."""
    bad = tmp_path / "run.mcap"
    start, _end, kept = _damage(clean_log, bad, "zstd", victim=0)
    out = tmp_path / "fixed.mcap"
    skipped: list[SkippedRange] = []
    assert recover(bad, out, skipped) == sum(kept.values())
    assert _counts(out) == kept
    assert [r.start for r in skipped] == [start]
    run = read_run(bad)
    assert {t: len(m) for t, m in run.messages.items() if m} == dict(kept)
    assert run.metadata["run"]["mode"] == "realtime"


# --- Every kind of damage against what recover says it lost --------------------------------


@pytest.fixture(scope="module")
def raw_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The same log with uncompressed chunks (its message records lie bare in the file)."""
    path = tmp_path_factory.mktemp("raw") / "run.mcap"
    _write_log(path, compression="")
    return path


def _identities(path: Path) -> Counter[tuple[str, int, int]]:
    """Each message by channel, sequence and log time, read by mcap's own reader (without
    its summary, which a damaged file may lack)."""
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        return Counter((ch.topic, m.sequence, m.log_time) for _s, ch, m in reader.iter_messages())


def _layout(path: Path) -> tuple[list[tuple[int, int]], int, int]:
    """The chunks' byte ranges, the summary section's start and the Footer's offset."""
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        assert summary is not None
        chunks = [(ci.chunk_start_offset, ci.chunk_length) for ci in summary.chunk_indexes]
    data = path.read_bytes()
    footer = len(data) - 8 - 29  # Footer record (1 + 8 + 20 B) before the closing magic
    (summary_start,) = struct.unpack_from("<Q", data, footer + 9)
    return chunks, summary_start, footer


def _damage_kind(src: Path, dst: Path, kind: str) -> None:
    chunks, summary_start, footer = _layout(src)
    start, length = chunks[len(chunks) // 2]
    data = bytearray(src.read_bytes())
    (n_comp,) = struct.unpack_from("<I", data, start + 9 + 28)
    records = start + 9 + 32 + n_comp + 8  # the (compressed) records
    if kind == "opcode":  # the chunk's opcode byte: no record the reader knows
        data[start] = 0x7F
    elif kind == "opcode-as-message":  # a known opcode, the wrong one
        data[start] = 0x05
    elif kind == "length-longer":  # the record length: the reader swallows what follows
        (n,) = struct.unpack_from("<Q", data, start + 1)
        struct.pack_into("<Q", data, start + 1, n + 3000)
    elif kind == "length-shorter":
        (n,) = struct.unpack_from("<Q", data, start + 1)
        struct.pack_into("<Q", data, start + 1, n - 40)
    elif kind == "length-huge":
        struct.pack_into("<Q", data, start + 1, 1 << 40)
    elif kind == "compression":  # the compression name
        data[start + 9 + 32 : start + 9 + 32 + n_comp] = b"zsxd"[:n_comp].ljust(n_comp, b"?")
    elif kind == "crc":  # the uncompressed CRC
        data[start + 9 + 24] ^= 0xFF
    elif kind == "data":  # bytes in the middle of the compressed data
        mid = records + (start + length - records) // 2
        data[mid : mid + 16] = bytes(16)
    elif kind == "message-length":  # (uncompressed chunks) the third message's length
        at = records
        for _ in range(2):
            (n,) = struct.unpack_from("<Q", data, at + 1)
            at += 9 + n
        assert data[at] == 0x05
        struct.pack_into("<Q", data, at + 1, 7)
    elif kind == "cut-mid-chunk":
        del data[start + length // 2 :]
    elif kind == "cut-between-chunks":
        del data[chunks[-1][0] :]
    elif kind == "cut-in-summary":
        del data[summary_start + (footer - summary_start) // 2 :]
    elif kind == "summary-bytes":  # the summary's Statistics and indexes garbled
        data[summary_start : summary_start + 64] = b"\xa5" * 64
    elif kind == "footer":
        data[footer : footer + 29] = b"\x00" * 29
    else:
        raise AssertionError(kind)
    dst.write_bytes(bytes(data))


LOST_LINE = re.compile(r"^(\d+ messages|unknown number) lost in bytes (\d+)-(\d+) ")

#: Damage kind -> (exit code, the count is known). 0 only where nothing is lost.
DAMAGE = {
    "opcode": (4, True),
    "opcode-as-message": (4, True),
    "length-longer": (4, True),
    "length-shorter": (4, True),
    "length-huge": (4, True),
    "compression": (4, True),
    "crc": (4, True),
    "data": (4, True),
    "message-length": (4, True),
    "cut-mid-chunk": (4, False),
    "cut-between-chunks": (4, False),
    "cut-in-summary": (0, True),
    "summary-bytes": (0, True),
    "footer": (0, True),
}


@pytest.mark.parametrize("kind", list(DAMAGE))
def test_recover_counts_what_each_damage_lost(
    clean_log: Path, raw_log: Path, tmp_path: Path, kind: str
) -> None:
    src = raw_log if kind == "message-length" else clean_log
    bad, out = tmp_path / "run.mcap", tmp_path / "fixed.mcap"
    _damage_kind(src, bad, kind)
    res = CliRunner().invoke(app, ["recover", str(bad), "--out", str(out)])
    assert "Traceback" not in res.output, res.output
    original, kept = _identities(src), _identities(out)
    assert not kept - original, "recover wrote messages the input never had"
    truly_lost = sum((original - kept).values())
    code, known = DAMAGE[kind]
    print(f"\n{kind}: exit {res.exit_code}, {truly_lost} lost\n{res.output}")
    assert res.exit_code == code, res.output
    lines = [m for m in map(LOST_LINE.match, res.output.splitlines()) if m]
    said = [None if m[1] == "unknown number" else int(m[1].split()[0]) for m in lines]
    if code == 0:
        assert truly_lost == 0 and not any(said), res.output
        return
    assert truly_lost > 0 or not known
    assert lines, res.output
    if known:
        assert None not in said and sum(n or 0 for n in said) == truly_lost, res.output
    else:
        assert None in said, res.output
    for m in lines:
        assert int(m[2]) < int(m[3]) or m[1] == "unknown number"
