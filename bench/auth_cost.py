"""Benchmark: what authenticating the bus payloads costs (:mod:`bus_schemas.auth`).

1. Per message, in this process: ``sign`` (the publisher's side) and ``verify`` (the
   subscriber's side, before decoding) of an encoded SensorFrame and ActuatorCommand, and
   the CAN authenticator of one instance (:class:`bus_schemas.can_codec.Encoder` with and
   without a key, classic and FD: the extra frame's build). Median and p99 over ``--count``
   calls [us], each call timed alone with ``time.perf_counter_ns``.
2. Lock-step speed: ``nrel5mw-ramp`` for ``--duration`` simulated seconds with plant,
   controller and recorder started by hand as separate processes (as ``fowt run`` starts
   them), once with ``--key-file`` and once with ``--insecure``, alternating for
   ``--rounds`` rounds (the machine is shared: the load changes between runs); the plant's
   own "simulated s per wall s" and cycle profile from its log lines (the order of the
   two alternates between rounds).

    python bench/auth_cost.py [--count 20000] [--duration 20] [--rounds 3]
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _common import save

from bus_schemas import ActuatorCommand, SensorFrame
from bus_schemas.auth import create_key_file, new_key, sign, verify
from bus_schemas.registry import COMMAND, SENSORS


def _percentiles(samples: list[int]) -> dict[str, float]:
    s = sorted(samples)
    return {
        "median_us": round(statistics.median(s) / 1e3, 3),
        "p99_us": round(s[min(len(s) - 1, int(0.99 * len(s)))] / 1e3, 3),
    }


def _time(fn: Callable[[], Any], count: int) -> dict[str, float]:
    clock = time.perf_counter_ns
    for _ in range(200):  # warm caches
        fn()
    out = []
    for _ in range(count):
        t0 = clock()
        fn()
        out.append(clock() - t0)
    return _percentiles(out)


def _frame() -> SensorFrame:
    values: dict[str, Any] = {}
    for f in SENSORS.codec.fields:
        values[f.name] = (f.minimum + f.maximum) / 2 if f.is_float else int(f.minimum) + 7
    return SensorFrame(**values)


def _command() -> ActuatorCommand:
    return ActuatorCommand(
        seq=7,
        answered_seq=7,
        sample_time_ns=70_000_000,
        publish_time_ns=1,
        mode=0,
        blade_pitch_commanded_rad=0.02,
        generator_torque_commanded_nm=30_000.0,
    )


def per_message(count: int) -> dict[str, Any]:
    """Sign and verify costs per message type, and the CAN authenticator's."""
    from bus_schemas.can_codec import Encoder

    key = new_key()
    out: dict[str, Any] = {}
    for mt, msg in ((SENSORS, _frame()), (COMMAND, _command())):
        payload = mt.codec.encode(msg)
        k = mt.key("t1")
        data = sign(key, k, payload)
        out[mt.name] = {
            "payload_bytes": len(payload),
            "sign": _time(lambda k=k, p=payload: sign(key, k, p), count),
            "verify": _time(lambda k=k, d=data: verify(key, k, d), count),
            "decode (for scale)": _time(lambda mt=mt, p=payload: mt.codec.decode(p), count),
        }
        for fd in (False, True):
            plain, signed = Encoder(fd=fd), Encoder(fd=fd, auth_key=key)
            n = max(1000, count // 10)
            out[mt.name][f"can_{'fd' if fd else 'classic'}_encode"] = {
                "without_key": _time(lambda e=plain, m=msg: e.encode(m), n),
                "with_key": _time(lambda e=signed, m=msg: e.encode(m), n),
            }
    return out


def _lockstep_speed(duration_s: float, secure: bool) -> dict[str, float]:
    """Simulated s per wall s of one hand-started lock-step run and the plant's cycle
    profile (its log lines: mean us per cycle of sample, sensor put, wait, finish)."""
    from hil.nodes.bus import free_tcp_endpoint

    with tempfile.TemporaryDirectory(prefix="fowt-bench-auth-") as tmp:
        out = Path(tmp)
        key = ["--key-file", str(out / "run.key")] if secure else ["--insecure"]
        if secure:
            create_key_file(out / "run.key")
        plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
        while ctrl_ep == plant_ep:
            ctrl_ep = free_tcp_endpoint()
        node = [sys.executable, "-m", "hil"]
        common = ["nrel5mw-ramp", "--duration", str(duration_s), *key]
        cmds = [
            [
                *node,
                "record",
                *common,
                "--out",
                str(out / "run.mcap"),
                "--connect",
                plant_ep,
                "--connect",
                ctrl_ep,
            ],
            [
                *node,
                "controller",
                *common,
                "--listen",
                ctrl_ep,
                "--connect",
                plant_ep,
                "--await-recorder",
                "30",
            ],
            [*node, "plant", *common, "--listen", plant_ep, "--mode", "lockstep"],
        ]
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        procs = [
            subprocess.Popen(c, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env)
            for c in cmds
        ]
        texts = [p.communicate(timeout=600)[0].decode() for p in procs]
        match = re.search(r"plant done: .* \(([0-9.]+)x\)", texts[2])
        prof = re.search(
            r"sample ([0-9.]+) \(of which sensor put ([0-9.]+)\), wait ([0-9.]+), "
            r"finish ([0-9.]+)",
            texts[2],
        )
        if match is None or prof is None or any(p.returncode for p in procs):
            raise SystemExit("lock-step run failed:\n" + "\n".join(texts))
        names = ("sample_us", "sensor_put_us", "wait_us", "finish_us")
        return {
            "speed": float(match.group(1)),
            **{n: float(v) for n, v in zip(names, prof.groups(), strict=True)},
        }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--count", type=int, default=20_000)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    result: dict[str, Any] = {
        "command": f"python bench/auth_cost.py --count {args.count} --duration "
        f"{args.duration:g} --rounds {args.rounds}",
        "per_message": per_message(args.count),
        "load_average_before": os.getloadavg(),
    }
    runs: dict[str, list[dict[str, float]]] = {"authenticated": [], "insecure": []}
    for r in range(args.rounds):
        order = (True, False) if r % 2 == 0 else (False, True)  # neither always goes first
        for secure in order:
            runs["authenticated" if secure else "insecure"].append(
                _lockstep_speed(args.duration, secure)
            )
    result["lockstep_nrel5mw_ramp"] = {
        "duration_s": args.duration,
        "runs": runs,
        "median": {
            k: {f: statistics.median(run[f] for run in v) for f in v[0]} for k, v in runs.items()
        },
    }
    result["load_average_after"] = os.getloadavg()
    save("auth_cost", result)


if __name__ == "__main__":
    main()
