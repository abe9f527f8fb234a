"""Benchmark: the in-process log writer's CPU per message, rows in blocks against Structs.

The stream is real: the five per-cycle messages (SensorFrame, PlantState, ActuatorCommand,
ControllerStatus, CycleTiming) of ``fowt run iea15mw-lc2-lqri-ff --mode inprocess
--duration 60 --no-plots`` read back from its MCAP in file (= publish) order, 12 000
messages, handed over ``--passes`` times (seq and time stamps shifted per pass). For each
path this script runs a real :class:`hil.log_writer.BackgroundRunLog` (writer child on the
other core, zstd file) and reports:

* ``rows``: the messages as ``row_dtype`` rows in blocks of ``--block-cycles`` cycles through
  ``publish_block`` (what the compiled loop hands over);
* ``structs``: the same messages as Structs through ``publish`` (today's loop);
* ``main_structs`` (with ``--compare-python PY --compare-root DIR``, e.g. main's venv and
  checkout): the Struct path of DIR's code, in a child process with its own interpreter;

each with the writer child's CPU per message (``writer_cpu_s / writer_messages``, its own
measurement after start-up), the parent's CPU per message for the hand-over (thread CPU
time around the publish calls, the batches' encoding and pipe writes included), the file
size and the messages per writer CPU second. The paths alternate ``--rounds`` times (the
2-core machine is shared; the load average is saved with every round); the best round of
each is the figure.

``stages``: the batches of the rows path (captured as sent) written again in this process,
each stage timed on the process CPU clock over ``--stage-repeats`` passes (best pass):
decode + rows -> JSON numbers (msgspec on the flat float and int columns, each value's
place in them); layout in publish order (the rest of ``_encode_batch``: each message's
length and record offset, the kernels writing keys and values there); the MCAP framing
(``write_batch`` without compression: record headers, CRC-32 of the chunk, message
indexes, writes; the CRC-32 alone beside it); and the compression (``write_batch`` with
it minus without), for zstd level 1 (the default: BatchRunLog's window and hash table),
level 1 with its own tables (``zstd1_level_tables``, main's compressor), levels -1, -3, -5,
lz4 and none, each with the file size.

    python bench/log_writer_speed.py [--passes 4] [--rounds 3] \\
        [--compare-python /work/main/.venv/bin/python --compare-root /work/main]
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
from _common import save

SCENARIO = "iea15mw-lc2-lqri-ff"
CYCLE_SUFFIXES = ("sensors", "truth", "command", "controller/status", "timing/cycle")


def real_run() -> Path:
    """The MCAP of a 60 s in-process run of :data:`SCENARIO` (a temporary folder)."""
    out = Path(tempfile.mkdtemp(prefix="fowt-bench-lw-"))
    cmd = [sys.executable, "-m", "hil", "run", SCENARIO, "--mode", "inprocess"]
    cmd += ["--duration", "60", "--no-plots", "--out", str(out)]
    subprocess.run(cmd, check=True, capture_output=True)
    return out / "run.mcap"


def stream(mcap: Path | None) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """The per-cycle messages of a real run: ids in publish order and each type's rows."""
    import orjson
    from mcap.reader import make_reader

    from bus_schemas.registry import MESSAGES

    if mcap is None:
        mcap = real_run()
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
    kind: str, order: np.ndarray, arrays: dict[int, np.ndarray], passes: int, block_cycles: int
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
    with tempfile.TemporaryDirectory(prefix="fowt-bench-lw-") as tmp:
        path = Path(tmp) / "run.mcap"
        log = BackgroundRunLog(path, "t1", {"run": {"mode": "bench"}})
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


def stages(
    order: np.ndarray, arrays: dict[int, np.ndarray], passes: int, repeats: int
) -> dict[str, Any]:
    """The rows path's batches written again in this process, stage by stage."""
    import hil.log_writer as lw
    import hil.mcap_log as ml

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
    n = sum(len(lw._decode_batch(b)[0]) for b in batches)
    decoders = lw._decoders()
    lw._warm_kernels()

    def json_only() -> None:
        for b in batches:
            _ids, _structs, rows = lw._decode_batch(b)
            for mid, raw in rows.items():
                lw._ROW_TYPES[mid].texts(raw)

    encoded = [lw._encode_batch(b, decoders) for b in batches]
    tmp = tempfile.mkdtemp(prefix="fowt-bench-lw-")
    sizes: dict[str, int] = {}

    def writer(name: str, compression: str, level: int, window: int, hashes: int) -> Any:
        def write() -> None:
            saved = ml.ZSTD_LEVEL, ml.ZSTD_WINDOW_LOG, ml.ZSTD_HASH_LOG
            ml.ZSTD_LEVEL, ml.ZSTD_WINDOW_LOG, ml.ZSTD_HASH_LOG = level, window, hashes
            try:
                path = Path(tmp) / "c.mcap"
                log = ml.BatchRunLog(
                    path, "t1", compression=compression, place_headers=lw._place_headers
                )
                for meta, records in encoded:
                    log.write_batch(meta, bytearray(records))
                log.close()
                sizes[name] = path.stat().st_size
            finally:
                ml.ZSTD_LEVEL, ml.ZSTD_WINDOW_LOG, ml.ZSTD_HASH_LOG = saved

        return write

    w, h = ml.ZSTD_WINDOW_LOG, ml.ZSTD_HASH_LOG  # 0, 0: the level's own (main's compressor)
    configs = {
        "none": ("", 1, w, h),
        "zstd1": ("zstd", 1, w, h),  # the default
        "zstd1_level_tables": ("zstd", 1, 0, 0),
        "zstd-1": ("zstd", -1, w, h),
        "zstd-3": ("zstd", -3, w, h),
        "zstd-5": ("zstd", -5, w, h),
        "lz4": ("lz4", 1, w, h),
    }
    fns: dict[str, Any] = {
        "rows_to_json_us": json_only,
        "encode_batch_us": lambda: [lw._encode_batch(b, decoders) for b in batches],
        "crc32_us": lambda: [zlib.crc32(r) for _m, r in encoded],
        "copy_us": lambda: [bytearray(r) for _m, r in encoded],  # the copy in write()
    }
    fns.update({f"write_{k}": writer(k, *v) for k, v in configs.items()})
    times: dict[str, list[int]] = {k: [] for k in fns}
    errors: dict[str, str] = {}
    for _ in range(repeats):  # interleaved: each stage in every pass, the best pass of each
        for name, fn in fns.items():
            if name in errors:
                continue
            c0 = time.process_time_ns()
            try:
                fn()
            except ValueError as exc:  # lz4 not installed
                errors[name] = str(exc)
                continue
            times[name].append(time.process_time_ns() - c0)
    us = {k: min(v) / n / 1e3 for k, v in times.items() if v}
    out: dict[str, Any] = {"messages": n, "batches": len(batches), "repeats": repeats}
    for k in ("rows_to_json_us", "encode_batch_us", "crc32_us"):
        out[k] = us[k]
    out["layout_us"] = us["encode_batch_us"] - us["rows_to_json_us"]
    out["record_bytes_per_msg"] = sum(len(r) for _m, r in encoded) / n
    out["framing_us"] = us["write_none"] - us["copy_us"]
    comp: dict[str, Any] = {}
    for k in configs:
        if f"write_{k}" in errors:
            comp[k] = {"error": errors[f"write_{k}"]}
            continue
        wb = us[f"write_{k}"] - us["copy_us"]
        comp[k] = {
            "write_batch_us": wb,
            "compression_us": wb - out["framing_us"],
            "file_bytes": sizes[k],
        }
    out["compression"] = comp
    out["writer_total_default_us"] = out["encode_batch_us"] + comp["zstd1"]["write_batch_us"]
    out["loadavg"] = os.getloadavg()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--mcap", type=Path, default=None, help="a run's MCAP (default: run 60 s)")
    ap.add_argument("--passes", type=int, default=4)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--block-cycles", type=int, default=8)
    ap.add_argument("--stage-repeats", type=int, default=3)
    ap.add_argument("--compare-python", default=None)
    ap.add_argument("--compare-root", type=Path, default=None)
    ap.add_argument("--only-structs", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--save-as", default="log_writer_speed")
    args = ap.parse_args()
    if args.only_structs:  # the compared code's Struct path (child of the compare run)
        order, arrays = stream(args.mcap)
        print(json.dumps(run_path("structs", order, arrays, args.passes, args.block_cycles)))
        return
    mcap = args.mcap or real_run()  # the same stream for the compared code
    order, arrays = stream(mcap)
    rounds: list[dict[str, Any]] = []
    for r in range(args.rounds):
        entry = {
            "rows": run_path("rows", order, arrays, args.passes, args.block_cycles),
            "structs": run_path("structs", order, arrays, args.passes, args.block_cycles),
        }
        if args.compare_python and args.compare_root:
            cmd = [args.compare_python, str(Path(__file__).resolve()), "--only-structs"]
            cmd += ["--mcap", str(mcap), "--passes", str(args.passes)]
            env = dict(os.environ, PYTHONPATH=str(args.compare_root))
            proc = subprocess.run(
                cmd, check=True, capture_output=True, text=True, cwd=args.compare_root, env=env
            )
            entry["main_structs"] = json.loads(proc.stdout.strip().splitlines()[-1])
        cpu = {k: v["writer_cpu_us_per_msg"] for k, v in entry.items()}
        print(f"round {r}: writer CPU per message [us] {cpu}")
        rounds.append(entry)
    best_of = {
        k: min((e[k] for e in rounds), key=lambda v: v["writer_cpu_us_per_msg"]) for k in rounds[0]
    }
    result: dict[str, Any] = {
        "scenario": SCENARIO,
        "stream_messages": len(order) * args.passes,
        "block_cycles": args.block_cycles,
        "best": best_of,
        "rounds": rounds,
        "stages": stages(order, arrays, args.passes, args.stage_repeats),
        "loadavg": os.getloadavg(),
    }
    if "main_structs" in best_of:
        result["writer_ratio_main_structs_over_rows"] = (
            best_of["main_structs"]["writer_cpu_us_per_msg"]
            / best_of["rows"]["writer_cpu_us_per_msg"]
        )
    save(args.save_as, result)


if __name__ == "__main__":
    main()
