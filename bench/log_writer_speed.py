"""Benchmark: the in-process log writer child's CPU per message, and per stage.

The streams are real: the five per-cycle messages (SensorFrame, PlantState, ActuatorCommand,
ControllerStatus, CycleTiming) of ``fowt run SCENARIO --mode inprocess --duration 60
--no-plots`` read back from its MCAP in file (= publish) order, 12 000 messages, handed over
``--passes`` times (seq and time stamps shifted per pass), for each of ``--streams``:
``lqri_ff`` (``iea15mw-lc2-lqri-ff``, all observers, forecaster, wave FF and LQRI) and
``baseline`` (``iea15mw-lc2``). For each path this script runs a real
:class:`hil.log_writer.BackgroundRunLog` (writer child on the other core, zstd file) and
reports:

* ``rows``: the messages as ``row_dtype`` rows in blocks of ``--block-cycles`` cycles through
  ``publish_block`` (what the compiled loop hands over);
* ``structs``: the same messages as Structs through ``publish``;
* ``compare_rows`` and ``compare_structs`` (with ``--compare-python PY --compare-root DIR``,
  e.g. main's venv and checkout): the same two paths with DIR's code, each in a child
  process with its own interpreter (``_common.run_child``);

each with the writer child's CPU per message (``writer_cpu_s / writer_messages``, its own
measurement after start-up), the parent's CPU per message for the hand-over (thread CPU
time around the publish calls, the batches' encoding and pipe writes included), the file
size and the messages per writer CPU second. The paths alternate ``--rounds`` times (the
2-core machine is shared; the load average is saved with every path of every round); the
best round of each is the figure, the median beside it.

``stages`` (per stream): the batches of the rows path (captured as sent) written again in
this process by the child's code (:class:`hil.log_writer._BatchFramer`), each stage timed
on the process CPU clock over ``--stage-repeats`` interleaved passes (best pass):
``decode`` (the batch's msgpack), ``numbers`` (the rows' values gathered in publish order
and formatted by orjson; ``orjson`` alone beside it), ``records`` (the kernel writing every
record's header and JSON and the MessageIndex entries), ``framing`` (``write_chunk`` less the
compressor: CRC-32 of the chunk (``crc32`` beside it), MessageIndex records, writes) and the
compressor on the chunk's records for each of ``compression``: zstd level 1 (the default:
:class:`hil.mcap_log.BatchRunLog`'s window and hash table), variants of its parameters,
level 1's own tables, levels -1, -3, -5, lz4 and none, each with the compressed bytes of
the stream; ``total_us`` is the whole writer per message (decode to file) with the default,
``reference_total_us`` the same batches through the reference path (``_encode_batch`` and
``BatchRunLog.write_batch``, main's stages) in the same passes.

``batch_sizes``: the rows path again (one run each) with other ``--batch-sizes`` (messages
per batch, i.e. per chunk): the child's CPU per message and the file size.

    python bench/log_writer_speed.py [--streams lqri_ff,baseline] [--passes 4] [--rounds 3] \\
        [--compare-python REF/.venv/bin/python --compare-root REF]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path
from typing import Any

import numpy as np
from _common import Code, add_compare_args, codes, run_child, save
from _common import order as round_order

#: The streams (``--streams``): the scenario whose 60 s in-process run is replayed.
STREAMS = {"lqri_ff": "iea15mw-lc2-lqri-ff", "baseline": "iea15mw-lc2"}
CYCLE_SUFFIXES = ("sensors", "truth", "command", "controller/status", "timing/cycle")


def real_run(scenario: str) -> Path:
    """The MCAP of a 60 s in-process run of ``scenario`` (a temporary folder)."""
    out = Path(tempfile.mkdtemp(prefix="fowt-bench-lw-"))
    cmd = [sys.executable, "-m", "hil", "run", scenario, "--mode", "inprocess"]
    cmd += ["--duration", "60", "--no-plots", "--out", str(out)]
    subprocess.run(cmd, check=True, capture_output=True)
    return out / "run.mcap"


def stream(mcap: Path) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """The per-cycle messages of a real run: ids in publish order and each type's rows."""
    import orjson
    from mcap.reader import make_reader

    from bus_schemas.registry import MESSAGES

    types = {mt.key("t1"): mt for mt in MESSAGES if mt.key_suffix in CYCLE_SUFFIXES}
    order: list[int] = []
    rows: dict[int, list[tuple[Any, ...]]] = {mt.message_id: [] for mt in types.values()}
    with open(mcap, "rb") as fh:
        for _s, ch, m in make_reader(fh).iter_messages(log_time_order=False):
            mt = types.get(ch.topic)
            if mt is not None:
                d = orjson.loads(m.data)
                order.append(mt.message_id)
                rows[mt.message_id].append(tuple(d[k] for k in mt.row_dtype.names or ()))
    by_id = {mt.message_id: mt for mt in types.values()}
    arrays = {mid: np.array(r, dtype=by_id[mid].row_dtype) for mid, r in rows.items()}
    return np.array(order, np.uint8), arrays


def shifted(arrays: dict[int, np.ndarray], k: int, n_cycles: int) -> dict[int, np.ndarray]:
    """Pass ``k`` of the stream: seq and time stamps moved on by ``k`` runs."""
    out = {}
    for mid, a in arrays.items():
        b = a.copy()
        b["seq"] += k * n_cycles
        b["sample_time_ns"] += k * n_cycles * 25_000_000
        b["publish_time_ns"] += k * n_cycles * 25_000_000
        out[mid] = b
    return out


def run_path(
    kind: str,
    order: np.ndarray,
    arrays: dict[int, np.ndarray],
    passes: int,
    block_cycles: int,
    batch_messages: int | None = None,
) -> dict[str, Any]:
    """One real BackgroundRunLog fed the stream as rows (publish_block) or Structs."""
    from bus_schemas.registry import MESSAGES
    from hil.log_writer import BackgroundRunLog

    by_id = {mt.message_id: mt for mt in MESSAGES}
    n_cycles = len(arrays[int(order[0])])
    per_block = block_cycles * 5
    work: list[Any] = []
    for k in range(passes):
        a = shifted(arrays, k, n_cycles)
        if kind == "rows":
            done = dict.fromkeys(a, 0)
            for s in range(0, len(order), per_block):
                ids = order[s : s + per_block]
                blk = {}
                for mid in a:
                    c = int(np.count_nonzero(ids == mid))
                    blk[mid] = a[mid][done[mid] : done[mid] + c]
                    done[mid] += c
                work.append((ids, blk))
        else:
            its = {
                mid: iter(
                    [by_id[mid].cls(*r) for r in arr.tolist()]  # positional: fields in order
                )
                for mid, arr in a.items()
            }
            work.extend((by_id[mid], next(its[mid])) for mid in order.tolist())
    n = len(order) * passes
    extra = {} if batch_messages is None else {"batch_messages": batch_messages}
    with tempfile.TemporaryDirectory(prefix="fowt-bench-lw-") as tmp:
        path = Path(tmp) / "run.mcap"
        log = BackgroundRunLog(path, "t1", {"run": {"mode": "bench"}}, **extra)
        log.wait_ready()
        c0 = time.thread_time_ns()
        if kind == "rows":
            publish_block = log.publish_block
            for ids, blk in work:
                publish_block(ids, blk)
        else:
            publish = log.publish
            for mt, msg in work:
                publish(mt, msg)
        parent_ns = time.thread_time_ns() - c0
        log.close()
        size = path.stat().st_size
    if log.writer_messages != n:
        raise SystemExit(f"{kind}: the writer wrote {log.writer_messages} of {n} messages")
    return {
        "messages": n,
        "writer_cpu_us_per_msg": log.writer_cpu_s / n * 1e6,
        "writer_msgs_per_cpu_s": n / log.writer_cpu_s if log.writer_cpu_s else None,
        "parent_cpu_us_per_msg": parent_ns / n / 1e3,
        "file_bytes": size,
        "loadavg": os.getloadavg(),
    }


def captured_batches(order: np.ndarray, arrays: dict[int, np.ndarray], passes: int) -> list[bytes]:
    """The rows path's batches as they go through the pipe (a real run, its sends kept)."""
    import hil.log_writer as lw

    batches: list[bytes] = []
    send = lw.BackgroundRunLog._send

    def keep(self: Any) -> None:
        if self._ids:
            batches.append(self._payload())
        send(self)

    lw.BackgroundRunLog._send = keep  # type: ignore[method-assign]
    try:
        run_path("rows", order, arrays, passes, 8)
    finally:
        lw.BackgroundRunLog._send = send  # type: ignore[method-assign]
    return batches


def _compressors() -> dict[str, Any]:
    """The compressions measured on the chunks: name -> compress(records) (None: absent)."""
    import zstandard

    import hil.mcap_log as ml

    def zstd(level: int, **kw: int) -> Any:
        params = zstandard.ZstdCompressionParameters.from_level(level, **kw)
        return zstandard.ZstdCompressor(compression_params=params).compress

    w, h = ml.ZSTD_WINDOW_LOG, ml.ZSTD_HASH_LOG
    out: dict[str, Any] = {
        "zstd1": zstd(1, window_log=w, hash_log=h),  # the default (BatchRunLog's)
        "zstd1_level_tables": zstandard.ZstdCompressor(level=1).compress,
        "zstd1_hash13": zstd(1, window_log=w, hash_log=13),
        "zstd1_hash11": zstd(1, window_log=w, hash_log=11),
        "zstd1_window17": zstd(1, window_log=17, hash_log=h),
        "zstd1_min_match6": zstd(1, window_log=w, hash_log=h, min_match=6),
        "zstd1_min_match5": zstd(1, window_log=w, hash_log=h, min_match=5),
        "zstd1_accel2": zstd(1, window_log=w, hash_log=h, target_length=2),
        "zstd-1": zstd(-1, window_log=w, hash_log=h),
        "zstd-3": zstd(-3, window_log=w, hash_log=h),
        "zstd-5": zstd(-5, window_log=w, hash_log=h),
        "none": bytes,
    }
    try:
        import lz4.frame  # type: ignore[import-untyped]

        out["lz4"] = lz4.frame.compress
    except ImportError:
        out["lz4"] = None
    return out


def each(fn: Any, items: list[Any]) -> Any:
    """A stage: ``fn`` on every item, its results dropped at once (kept, they would cost
    the next allocations page faults that the writer does not pay)."""

    def run() -> None:
        for item in items:
            fn(item)

    return run


def stages(batches: list[bytes], repeats: int) -> dict[str, Any]:
    """The child's code on the captured batches, in this process, stage by stage."""
    import hil.log_writer as lw
    import hil.mcap_log as ml

    decoders = lw._decoders()
    n = sum(len(lw._decode_batch(b)[0]) for b in batches)
    tmp = Path(tempfile.mkdtemp(prefix="fowt-bench-lw-"))
    log = ml.BatchRunLog(tmp / "s.mcap", "t1")
    framer = lw._BatchFramer(log, decoders)
    lw._warm_kernels(framer)
    # orjson's inputs (the gathered values), captured from one pass of the real code.
    numbers: list[np.ndarray] = []
    dumps = lw._orjson_dumps

    def keep(values: np.ndarray, option: int) -> bytes:
        numbers.append(values.copy())
        return dumps(values, option=option)

    lw._orjson_dumps = keep
    try:
        for b in batches:
            framer.values(b)
    finally:
        lw._orjson_dumps = dumps
    records = [bytes(framer.encode(b)[0]) for b in batches]
    compressors = _compressors()
    sizes = {k: sum(len(c(r)) for r in records) for k, c in compressors.items() if c is not None}

    def frame_all(compression: str) -> Any:
        def run() -> None:
            out = ml.BatchRunLog(tmp / "f.mcap", "t1", compression=compression)
            fr = lw._BatchFramer(out, decoders)
            c0 = time.process_time_ns()
            for b in batches:
                fr.frame(b)
            frame_ns.append(time.process_time_ns() - c0)  # the file's set-up and end left out
            out.close()

        return run

    def reference() -> None:
        out = ml.BatchRunLog(tmp / "r.mcap", "t1", place_headers=lw._place_headers)
        c0 = time.process_time_ns()
        for b in batches:
            meta, recs = lw._encode_batch(b, decoders)
            out.write_batch(meta, recs)
        frame_ns.append(time.process_time_ns() - c0)
        out.close()

    frame_ns: list[int] = []
    fns: dict[str, Any] = {
        "decode": each(lw._decode_batch, batches),
        "values": each(framer.values, batches),
        "orjson": each(lambda v: dumps(v, option=lw._ORJSON_NUMPY), numbers),
        "encode": each(framer.encode, batches),
        "crc32": each(zlib.crc32, records),
        "total": frame_all("zstd"),
        "reference_total": reference,
    }
    fns.update({f"compress_{k}": each(c, records) for k, c in compressors.items() if c})
    times: dict[str, list[int]] = {k: [] for k in fns}
    for _ in range(repeats):  # interleaved: each stage in every pass, the best pass of each
        for name, fn in fns.items():
            frame_ns.clear()
            c0 = time.process_time_ns()
            fn()
            times[name].append(frame_ns[0] if frame_ns else time.process_time_ns() - c0)
    log.close()
    us = {k: min(v) / n / 1e3 for k, v in times.items()}
    raw = sum(len(r) for r in records)
    out: dict[str, Any] = {
        "messages": n,
        "batches": len(batches),
        "repeats": repeats,
        "record_bytes_per_msg": raw / n,
        "decode_us": us["decode"],
        "numbers_us": us["values"] - us["decode"],
        "orjson_us": us["orjson"],
        "records_us": us["encode"] - us["values"],
        "compress_us": us["compress_zstd1"],
        "framing_us": us["total"] - us["encode"] - us["compress_zstd1"],
        "crc32_us": us["crc32"],
        "total_us": us["total"],
        "reference_total_us": us["reference_total"],
    }
    out["compression"] = {
        k: {
            "compress_us": us.get(f"compress_{k}"),
            "compressed_bytes": sizes.get(k),
            "ratio": raw / sizes[k] if k in sizes else None,
            "writer_total_us": us["total"] - us["compress_zstd1"] + us[f"compress_{k}"]
            if f"compress_{k}" in us
            else None,
        }
        for k in compressors
    }
    out["loadavg"] = os.getloadavg()
    return out


def compare_path(args: argparse.Namespace, code: Code, kind: str, mcap: Path) -> dict[str, Any]:
    """``kind`` (rows or structs) with another checkout's code in its own interpreter."""
    argv = [str(Path(__file__).resolve()), "--only-path", kind]
    argv += ["--mcap", str(mcap), "--passes", str(args.passes)]
    argv += ["--block-cycles", str(args.block_cycles)]
    return run_child(code, argv)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--streams", default="lqri_ff,baseline", help="of " + ",".join(STREAMS))
    ap.add_argument("--mcap", type=Path, default=None, help="a run's MCAP (one stream only)")
    ap.add_argument("--passes", type=int, default=4)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--block-cycles", type=int, default=8)
    ap.add_argument("--stage-repeats", type=int, default=5)
    ap.add_argument("--batch-sizes", default="512,2048,4096", help="'' for none")
    add_compare_args(ap)
    ap.add_argument("--only-path", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--save-as", default="log_writer_speed")
    args = ap.parse_args()
    if args.only_path:  # one path with the compared code (child of the compare run)
        order, arrays = stream(args.mcap)
        r = run_path(args.only_path, order, arrays, args.passes, args.block_cycles)
        print(json.dumps(r))
        return
    names = [s for s in args.streams.split(",") if s]
    if any(s not in STREAMS for s in names) or (args.mcap and len(names) != 1):
        raise SystemExit(f"--streams: of {list(STREAMS)}; --mcap with one stream only")
    sides = codes(args)
    compare = "compare" in sides
    result: dict[str, Any] = {"streams": {}, "block_cycles": args.block_cycles}
    for name in names:
        mcap = args.mcap or real_run(STREAMS[name])  # the same stream for the compared code
        order, arrays = stream(mcap)
        rounds: list[dict[str, Any]] = []
        for r in range(args.rounds):
            entry: dict[str, Any] = {}
            for kind in ("rows", "structs"):
                for side in round_order(list(sides), r):
                    if side == "this":
                        entry[kind] = run_path(kind, order, arrays, args.passes, args.block_cycles)
                    else:
                        entry[f"compare_{kind}"] = compare_path(args, sides[side], kind, mcap)
            cpu = {k: round(v["writer_cpu_us_per_msg"], 3) for k, v in entry.items()}
            print(f"{name} round {r}: writer CPU per message [us] {cpu}", flush=True)
            rounds.append(entry)
        best = {
            k: min((e[k] for e in rounds), key=lambda v: v["writer_cpu_us_per_msg"])
            for k in rounds[0]
        }
        median = {
            k: float(np.median([e[k]["writer_cpu_us_per_msg"] for e in rounds])) for k in rounds[0]
        }
        batches = captured_batches(order, arrays, args.passes)
        st = stages(batches, args.stage_repeats)
        print(
            f"{name} stages [us/msg]: "
            + ", ".join(f"{k} {v:.3f}" for k, v in st.items() if k.endswith("_us")),
            flush=True,
        )
        sizes = {}
        for size in [int(x) for x in args.batch_sizes.split(",") if x]:
            r = run_path("rows", order, arrays, args.passes, args.block_cycles, size)
            sizes[str(size)] = r
        entry_out: dict[str, Any] = {
            "scenario": STREAMS[name],
            "stream_messages": len(order) * args.passes,
            "best": best,
            "median_writer_cpu_us_per_msg": median,
            "rounds": rounds,
            "stages": st,
            "batch_sizes": sizes,
        }
        if compare:
            entry_out["writer_ratio_compare_rows_over_rows"] = (
                best["compare_rows"]["writer_cpu_us_per_msg"]
                / best["rows"]["writer_cpu_us_per_msg"]
            )
        result["streams"][name] = entry_out
    result["loadavg"] = os.getloadavg()
    save(args.save_as, result)


if __name__ == "__main__":
    main()
