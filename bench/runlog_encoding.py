"""Run log encoding: ros2msg + CDR channels against the JSON channels they replaced.

A real in-process run of load case 2 (``iea15mw-lc2``, ``--duration`` simulated seconds,
default 600) is recorded by the bench's own writer (:class:`hil.runlog.mcap_io.RunLog` through
the in-process writer child); its messages, read back, are the stream measured. In publish
order (by sample time, a cycle's messages in the loop's order) they are cut into batches of
:data:`hil.runlog.writer.BATCH_MESSAGES`, as the writer child receives them, and per format:

* ``bytes_per_message``: payload and whole MCAP Message record (31-byte header + payload),
  raw, and a chunk's records after zstd level 1 (the writer's compressor:
  :data:`hil.runlog.mcap_io.ZSTD_LEVEL`, window 2^18, hash 2^12) divided by its messages; the
  JSON records are laid out as the JSON writer did (publish order), the CDR ones as
  :class:`~hil.runlog.mcap_io.RunLog` does (per channel within a chunk);
* ``compress_crc_us_per_message``: zstd level 1 and the chunk's CRC-32 of each batch's
  records (best of ``--passes``, this process's CPU clock);
* ``encode_us_per_message``: JSON: msgspec's encoder on each message's Struct (the cheapest
  Python path to that text; the compiled kernels the JSON writer used took 0.45-0.5 us for
  it); CDR: :func:`bus_schemas.ros2.encode_rows` per type and batch;
* ``writer_us_per_message``: the CDR writer child's whole work per batch
  (:meth:`hil.runlog.writer._BatchFramer.frame`: msgpack decode, rows, CDR, record headers,
  zstd, CRC, MessageIndexes, the write) into a file;
* ``file_bytes``: the whole run's file by the bench's writer (CDR), and the same messages on
  JSON channels (JSON Schema, msgspec's JSON) through the same writer and chunking.

    python bench/runlog_encoding.py [--duration 600] [--passes 5]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import zlib
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import save

from bus_schemas import ros2
from bus_schemas.registry import BY_SUFFIX, MESSAGES, MessageType

#: A cycle's messages in the order the loop publishes them (ties of one sample time).
_ORDER = {
    s: i
    for i, s in enumerate(
        ("sensors", "controller/status", "command", "truth", "timing/cycle", "preview/wave_perfect")
    )
}


def _record(scenario: str, duration_s: float, out: Path) -> tuple[Path, float]:
    from hil.launch import RunRequest, launch

    t0 = time.perf_counter()
    launch(RunRequest(scenario, mode="inprocess", duration_s=duration_s, out_dir=out, plots=False))
    return out / "run.mcap", time.perf_counter() - t0


def _stream(path: Path) -> list[tuple[MessageType, np.ndarray]]:
    """The file's messages in publish order: (type, one row of its row_dtype) each."""
    from hil.runlog.mcap_io import MessageList, read_run

    run = read_run(path)
    items: list[tuple[int, int, int, MessageType, np.ndarray]] = []
    for topic, msgs in run.messages.items():
        if not msgs:
            continue
        mt = BY_SUFFIX[topic.split("/", 2)[2]]
        assert isinstance(msgs, MessageList)
        ((_a, _b, rows),) = msgs.parts
        cast = np.zeros(len(rows), mt.row_dtype)
        for name in mt.row_dtype.names or ():
            cast[name] = rows[name]
        order = _ORDER.get(mt.key_suffix, 9)
        for i in range(len(cast)):
            items.append((int(cast[i]["sample_time_ns"]), order, i, mt, cast[i : i + 1]))
    items.sort(key=lambda x: x[:3])
    return [(mt, row) for *_k, mt, row in items]


def _batches(stream: list[tuple[MessageType, np.ndarray]], size: int) -> list[list[Any]]:
    return [stream[i : i + size] for i in range(0, len(stream), size)]


def _json_records(batch: list[tuple[MessageType, np.ndarray]], enc: Any) -> tuple[bytes, int]:
    """A batch's JSON Message records in publish order (headers zero: their size counts)."""
    parts = []
    payload = 0
    for mt, row in batch:
        vals = dict(zip(mt.row_dtype.names or (), row[0].tolist(), strict=True))
        data = enc(mt.cls(**vals))
        payload += len(data)
        parts.append(bytes(31) + data)
    return b"".join(parts), payload


def _cdr_records(batch: list[tuple[MessageType, np.ndarray]]) -> tuple[bytes, int]:
    """A batch's CDR Message records grouped per channel (RunLog's layout)."""
    by_type: dict[int, list[np.ndarray]] = {}
    types: dict[int, MessageType] = {}
    for mt, row in batch:
        by_type.setdefault(mt.message_id, []).append(row)
        types[mt.message_id] = mt
    parts = []
    payload = 0
    for mid in sorted(by_type):
        rows = np.concatenate(by_type[mid])
        cdr = ros2.encode_rows(types[mid], rows)
        size = cdr.dtype.itemsize
        rec = np.zeros((len(rows), 31 + size), np.uint8)
        rec[:, 31:] = cdr.view(np.uint8).reshape(len(rows), size)
        parts.append(rec.tobytes())
        payload += cdr.nbytes
    return b"".join(parts), payload


def _best_cpu_us(fn: Any, passes: int, n: int) -> float:
    best = float("inf")
    for _ in range(passes):
        c0 = time.thread_time_ns()
        fn()
        best = min(best, time.thread_time_ns() - c0)
    return round(best / n / 1e3, 4)


def _json_file(stream: list[tuple[MessageType, np.ndarray]], path: Path, size: int) -> int:
    """The same messages on JSON channels through RunLog (same chunking), its bytes."""
    from hil.runlog.mcap_io import RunLog

    log = RunLog(path, None, start_unix_ns=0, flush_interval_s=1e9, batch_messages=size)
    cids = {
        mt.message_id: log.add_json_channel(mt.key("t1"), f"fowt.{mt.name}", mt.json_schema())
        for mt in MESSAGES
    }
    enc = msgspec.json.Encoder().encode
    for mt, row in stream:
        vals = dict(zip(mt.row_dtype.names or (), row[0].tolist(), strict=True))
        log.write_json(cids[mt.message_id], enc(mt.cls(**vals)), vals["sample_time_ns"], 0)
    log.close()
    return path.stat().st_size


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenario", default="iea15mw-lc2")
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--passes", type=int, default=5)
    ap.add_argument("--save-as", default="runlog_encoding")
    args = ap.parse_args()

    import zstandard

    from hil.runlog import mcap_io as mcap_log
    from hil.runlog.writer import BATCH_MESSAGES, ROW_FLAG, _BatchFramer, _decoders
    from hil.runlog.writer import _encode_batch_payload as pack

    params = zstandard.ZstdCompressionParameters.from_level(
        mcap_log.ZSTD_LEVEL, window_log=mcap_log.ZSTD_WINDOW_LOG, hash_log=mcap_log.ZSTD_HASH_LOG
    )
    compress = zstandard.ZstdCompressor(compression_params=params).compress
    with tempfile.TemporaryDirectory(prefix="fowt-bench-") as tmp:
        cdr_path, run_wall_s = _record(args.scenario, args.duration, Path(tmp) / "run")
        cdr_file = cdr_path.stat().st_size
        stream = _stream(cdr_path)
        n = len(stream)
        batches = _batches(stream, BATCH_MESSAGES)
        json_file = _json_file(stream, Path(tmp) / "json.mcap", BATCH_MESSAGES)
        enc = msgspec.json.Encoder().encode
        js = [_json_records(b, enc) for b in batches]
        cd = [_cdr_records(b) for b in batches]
        result: dict[str, Any] = {}
        for label, recs in (("json", js), ("cdr", cd)):
            raw = sum(len(r) for r, _p in recs)
            payload = sum(p for _r, p in recs)
            zipped = sum(len(compress(r)) for r, _p in recs)
            result[label] = {
                "bytes_per_message": {
                    "payload": round(payload / n, 1),
                    "record": round(raw / n, 1),
                    "record_zstd1": round(zipped / n, 1),
                },
                "compress_crc_us_per_message": _best_cpu_us(
                    lambda recs=recs: [(compress(r), zlib.crc32(r)) for r, _p in recs],
                    args.passes,
                    n,
                ),
            }

        def json_encode() -> None:
            for b in batches:
                structs = [
                    mt.cls(**dict(zip(mt.row_dtype.names or (), row[0].tolist(), strict=True)))
                    for mt, row in b
                ]
                c0 = time.thread_time_ns()
                [enc(m) for m in structs]
                timing[0] += time.thread_time_ns() - c0

        timing = [0]
        best = float("inf")
        for _ in range(args.passes):
            timing[0] = 0
            json_encode()
            best = min(best, timing[0])
        result["json"]["encode_us_per_message"] = round(best / n / 1e3, 4)
        grouped = []
        for b in batches:
            by: dict[int, list[np.ndarray]] = {}
            for mt, row in b:
                by.setdefault(mt.message_id, []).append(row)
            grouped.append([(BY_ID[mid], np.concatenate(r)) for mid, r in by.items()])
        result["cdr"]["encode_us_per_message"] = _best_cpu_us(
            lambda: [ros2.encode_rows(mt, rows) for g in grouped for mt, rows in g],
            args.passes,
            n,
        )
        blobs = []
        for g, b in zip(grouped, batches, strict=True):
            ids = bytes(mt.message_id | ROW_FLAG for mt, _r in b)
            blobs.append(pack((ids, {}, {mt.message_id: rows.tobytes() for mt, rows in g})))

        def frame_all() -> None:
            log = mcap_log.RunLog(Path(tmp) / "frame.mcap", "t1")
            framer = _BatchFramer(log, _decoders())
            for blob in blobs:
                framer.frame(blob)
            log.close()

        result["cdr"]["writer_us_per_message"] = _best_cpu_us(frame_all, args.passes, n)
        result["json"]["file_bytes"] = json_file
        result["cdr"]["file_bytes"] = cdr_file
    per_topic: dict[str, int] = {}
    for mt, _row in stream:
        per_topic[mt.key_suffix] = per_topic.get(mt.key_suffix, 0) + 1
    save(
        args.save_as,
        {
            "scenario": args.scenario,
            "duration_s": args.duration,
            "messages": n,
            "messages_per_topic": per_topic,
            "batch_messages": BATCH_MESSAGES,
            "passes": args.passes,
            "run_wall_s": round(run_wall_s, 2),
            **result,
            "cdr_over_json": {
                "record_bytes": round(
                    result["cdr"]["bytes_per_message"]["record"]
                    / result["json"]["bytes_per_message"]["record"],
                    3,
                ),
                "record_zstd1_bytes": round(
                    result["cdr"]["bytes_per_message"]["record_zstd1"]
                    / result["json"]["bytes_per_message"]["record_zstd1"],
                    3,
                ),
                "file_bytes": round(cdr_file / json_file, 3),
            },
        },
    )


BY_ID = {mt.message_id: mt for mt in MESSAGES}

if __name__ == "__main__":
    main()
