"""CAN between processes: per-frame cost, then a 10-minute real-time soak at 40 Hz.

1. Per-frame cost (in a private network namespace, as ``fowt run --transport can`` runs):
   two python-can ``udp_multicast`` buses on one group in one process; for ``--count``
   sensor frames (7 classic CAN frames each, or 1 CAN FD frame with ``--can-fd``) and
   commands (4, or 1) it times, each on ``time.perf_counter_ns``:

   * ``encode``: :class:`bus_schemas.can_codec.Encoder` (signal values, cantools packing,
     frame CRC, ``can.Message`` objects), per message;
   * ``send``: ``bus.send`` per frame (python-can: msgpack packing and a UDP ``sendto``);
   * ``receive``: ``bus.recv`` per frame once the frames are queued (``select``,
     ``recvfrom``, msgpack unpacking into a ``can.Message``);
   * ``decode``: :class:`bus_schemas.can_codec.Reassembler` ``feed`` per frame (checks,
     reassembly, cantools decoding, range checks) up to the decoded message;
   * ``payload_wrap``: the binary re-encoding and decoding a node's Zenoh-style callback
     adds (``hil.nodes.can_bus.CanBus.subscribe``), per message.

   The measuring process runs under ``SCHED_FIFO`` at ``--realtime-priority`` (as the nodes
   do), so the figures are the work, not the shared machine's run queue. With
   ``--skip-soak`` only this part runs and goes to ``can_frame_cost.json``.

2. Soak: ``fowt run`` of the default floating scenario (IEA 15 MW on VolturnUS-S, load case
   2) at 40 Hz (control period 0.025 s, plant step 0.0125 s), ``--transport can
   --can-interface udp_multicast``, real time at speed 1, ``--realtime-priority`` for plant
   and controller, for ``--duration`` seconds (600: 10 minutes). Deadline
   misses (target 0), late and held commands, sensor-to-command latency p50/p99/p99.9/max and
   the controller's compute time, with the load average before and after.

Prints and saves ``bench/results/can_soak.json``.

    python bench/can_soak.py [--duration 600] [--realtime-priority 20] [--can-fd]
                             [--count 5000] [--skip-soak]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def _stats(ns: list[int] | np.ndarray) -> dict[str, float]:
    us = np.asarray(ns, dtype=float) / 1e3
    return {
        "mean": float(us.mean()),
        "p50": float(np.percentile(us, 50)),
        "p99": float(np.percentile(us, 99)),
        "max": float(us.max()),
    }


def frame_cost(count: int, fd: bool) -> dict[str, Any]:
    """Per-frame costs on two udp_multicast buses of this (private) network namespace."""
    import can

    from bus_schemas import ActuatorCommand, SensorFrame
    from bus_schemas.can_codec import Encoder, Reassembler
    from bus_schemas.registry import COMMAND, SENSORS
    from hil.nodes.can_bus import CanBusConfig, _raise_udp_rcvbuf

    cfg = CanBusConfig("udp_multicast", fd=fd)
    tx = can.Bus(**cfg.bus_kwargs())
    rx = can.Bus(**cfg.bus_kwargs())
    _raise_udp_rcvbuf(rx)
    _raise_udp_rcvbuf(tx)
    rng = np.random.default_rng(15)
    out: dict[str, Any] = {"fd": fd, "count": count, "interface": "udp_multicast"}
    frame_fields = SensorFrame.__struct_fields__
    try:
        for mt, cls in ((SENSORS, SensorFrame), (COMMAND, ActuatorCommand)):
            enc, reasm = Encoder(fd=fd), Reassembler(fd=fd)
            t_enc, t_send, t_recv, t_dec, t_wrap = [], [], [], [], []
            n_frames = 0
            for k in range(count):
                msg = _message(cls, k, rng, frame_fields)
                t0 = time.perf_counter_ns()
                frames = enc.encode(msg)
                t_enc.append(time.perf_counter_ns() - t0)
                n_frames = len(frames)
                for f in frames:
                    t0 = time.perf_counter_ns()
                    tx.send(f)
                    t_send.append(time.perf_counter_ns() - t0)
                got = None
                received = 0
                while received < n_frames:  # tx's own frames also loop back to tx, not read
                    t0 = time.perf_counter_ns()
                    f = rx.recv(1.0)
                    t1 = time.perf_counter_ns()
                    if f is None:
                        raise SystemExit("udp_multicast: a frame did not come back within 1 s")
                    t_recv.append(t1 - t0)
                    received += 1
                    t0 = time.perf_counter_ns()
                    m = reasm.feed(f)
                    t_dec.append(time.perf_counter_ns() - t0)
                    if m is not None:
                        got = m
                if got is None:
                    raise SystemExit(f"{cls.__name__} {k} was not reassembled: {reasm.rejected}")
                t0 = time.perf_counter_ns()
                mt.codec.decode(mt.codec.encode(got))
                t_wrap.append(time.perf_counter_ns() - t0)
            per_msg = {
                "frames_per_message": n_frames,
                "encode_per_message_us": _stats(t_enc),
                "send_per_frame_us": _stats(t_send),
                "receive_per_frame_us": _stats(t_recv),
                "decode_per_frame_us": _stats(t_dec),
                "payload_wrap_per_message_us": _stats(t_wrap),
            }
            means = [
                per_msg["encode_per_message_us"]["mean"],
                n_frames * per_msg["send_per_frame_us"]["mean"],
                n_frames * per_msg["receive_per_frame_us"]["mean"],
                n_frames * per_msg["decode_per_frame_us"]["mean"],
                per_msg["payload_wrap_per_message_us"]["mean"],
            ]
            per_msg["total_per_message_us_mean"] = float(sum(means))
            out[cls.__name__] = per_msg
    finally:
        tx.shutdown()
        rx.shutdown()
    return out


def _message(cls: Any, k: int, rng: np.random.Generator, fields: tuple[str, ...]) -> Any:
    """A valid message number ``k`` (mid-range values with a little noise)."""
    from bus_schemas.registry import COMMAND, SENSORS

    mt = SENSORS if cls.__name__ == "SensorFrame" else COMMAND
    values: dict[str, Any] = {}
    for f in mt.codec.fields:
        if f.name in ("seq", "answered_seq"):
            values[f.name] = k
        elif f.name.endswith("_ns"):
            values[f.name] = 25_000_000 * k + 1
        elif f.is_float:
            lo, hi = max(f.minimum, -1e6), min(f.maximum, 1e6)
            values[f.name] = lo + (hi - lo) * (0.5 + 0.01 * rng.standard_normal())
        else:
            values[f.name] = int(f.minimum)
    return cls(**values)


def _soak(duration_s: float, priority: int, fd: bool) -> dict[str, Any]:
    from _common import run_fowt, scenario_variant

    path = scenario_variant("default", 0.025, 0.0125)
    extra = ["--transport", "can", "--can-interface", "udp_multicast"]
    if fd:
        extra.append("--can-fd")
    if priority:
        extra += ["--realtime-priority", str(priority)]
    load_before = os.getloadavg()
    s = run_fowt(str(path), "realtime", duration_s, extra, inspect=_inspect)
    t = s["timing"]
    cycles = t["cycles"] or 0
    return {
        "scenario": "default",
        "control_rate_hz": 40,
        "duration_s": duration_s,
        "realtime_priority": priority,
        "can_fd": fd,
        "cycles": cycles,
        "deadline_misses": t["deadline_misses"],
        "met_zero_misses": t["deadline_misses"] == 0 and cycles > 0,
        "commands_late": t["commands_late"],
        "commands_held": t["commands_held"],
        "commands_rejected": t["commands_rejected"],
        "safe_state": t["safe_state"],
        "latency_us": t["latency_us"],
        "controller_compute_us": t.get("controller_compute_us"),
        "sim_seconds_per_wall_second": t.get("sim_seconds_per_wall_second"),
        "complete": t.get("complete"),
        "whole_command_wall_s": s["bench_command_wall_s"],
        "nodes": s.get("bench_inspect"),
        "loadavg_before": load_before,
        "loadavg_after": os.getloadavg(),
    }


def _inspect(run_dir: Path) -> dict[str, Any]:
    """The nodes' CAN and watchdog lines, the recorder's rejections, the missed cycles."""
    from hil.runlog.mcap_io import read_run

    out: dict[str, Any] = {}
    for name, marks in (
        ("plant", ("plant CAN", "plant done")),
        ("controller", ("controller stopped",)),
        ("recorder", ("CAN", "recorder")),
    ):
        path = run_dir / "logs" / f"{name}.log"
        lines = path.read_text(errors="replace").splitlines() if path.is_file() else []
        out[f"{name}_log"] = [ln for ln in lines if any(m in ln for m in marks)][-4:]
    run = read_run(run_dir / "run.mcap")
    out["recorder_metadata"] = {
        k: v for k, v in run.metadata.get("recorder", {}).items() if "reject" in k or "can" in k
    }
    missed = [c for c in run.topic("timing/cycle") if c["deadline_missed"]]
    out["missed_cycles"] = [
        {"seq": c["seq"], "latency_us": c["latency_ns"] / 1e3, "t_s": c["sample_time_ns"] / 1e9}
        for c in missed[:20]
    ]
    commands = {c["answered_seq"] for c in run.topic("command")}
    frames = {f["seq"] for f in run.topic("sensors")}
    out["missed_seq_frame_recorded"] = [c["seq"] in frames for c in missed[:20]]
    out["missed_seq_command_recorded"] = [c["seq"] in commands for c in missed[:20]]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--realtime-priority", type=int, default=20)
    ap.add_argument("--can-fd", action="store_true")
    ap.add_argument("--count", type=int, default=5000, help="messages for the per-frame cost")
    ap.add_argument("--skip-soak", action="store_true")
    ap.add_argument("--frame-cost-child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.frame_cost_child:  # inside the namespace: print the figures for the parent
        if args.realtime_priority:  # as the nodes: the costs, not the machine's queue
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(args.realtime_priority))
        print(json.dumps(frame_cost(args.count, args.can_fd)))
        return
    from _common import save

    from hil.nodes.can_bus import in_private_netns, netns_command, netns_unavailable_reason

    cmd = [sys.executable, str(Path(__file__).resolve()), "--frame-cost-child"]
    cmd += ["--count", str(args.count), "--realtime-priority", str(args.realtime_priority)]
    cmd += ["--can-fd"] if args.can_fd else []
    if not in_private_netns():
        reason = netns_unavailable_reason()
        if reason is not None:
            raise SystemExit(f"can_soak: {reason}")
        cmd = netns_command(cmd)
    res = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise SystemExit(f"per-frame cost failed:\n{res.stdout}\n{res.stderr}")
    cost = json.loads(res.stdout.strip().splitlines()[-1])
    print("per-frame cost", json.dumps(cost, indent=1))
    result: dict[str, Any] = {"frame_cost": cost, "loadavg": os.getloadavg()}
    if not args.skip_soak:
        result["soak"] = _soak(args.duration, args.realtime_priority, args.can_fd)
        print("soak", result["soak"])
    name = "can_frame_cost" if args.skip_soak else "can_soak"
    save(name + ("_fd" if args.can_fd else ""), result)


if __name__ == "__main__":
    main()
