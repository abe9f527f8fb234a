"""Raw zenoh-python ping-pong between two processes: the reference for the bench's bus figures.

No bench code is in the loop: two plain zenoh-python sessions, configured as the bench's
nodes are (:meth:`hil.nodes.bus.BusConfig.zenoh_config`: peer mode, multicast scouting off,
low-latency unicast transport, QoS off, explicit loopback endpoints), exchange a payload of
the encoded :class:`bus_schemas.SensorFrame`'s size one way and one of the encoded
:class:`bus_schemas.ActuatorCommand`'s size back, on express publishers as the bench's. The
``pong`` process answers each ping from its subscriber callback (Zenoh's thread, as the
controller node does); the ``ping`` process sends, blocks until the answer, and records the
round trip on ``time.perf_counter_ns``. Two ways of waiting are measured on the ping side
and the faster is the reference:

* ``callback``: the subscriber callback sets a ``threading.Event`` the sender waits on;
* ``channel``: the default FIFO handler channel, the sender blocks in ``recv()``.

``observer``: a third process, a passive peer subscribed to both keys (``pingpong/**``,
one callback per sample, niced as the launcher nices the recorder), as the recorder is in a
bench run: each ping and each pong then goes to two peers. It is an additional reference
(the plain two-process ping-pong stays the issue's reference).

``period_s`` > 0 paces the pings (one per period, as a real-time run), 0 sends them back to
back (as lock-step). ``priority`` > 0 puts both processes under ``SCHED_FIFO`` before the
sessions open (as ``--realtime-priority`` does for the nodes).

    python bench/_zenoh_pingpong.py [--count 20000] [--period 0] [--priority 0] [--observer]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

PING_KEY = "pingpong/ping"
PONG_KEY = "pingpong/pong"


def payload_sizes() -> tuple[int, int]:
    """Bytes of an encoded SensorFrame and of an encoded ActuatorCommand (the bench's codec)."""
    from bus_schemas.registry import COMMAND, SENSORS

    return SENSORS.codec.size, COMMAND.codec.size


def _config(listen: list[str], connect: list[str], lowlatency: bool) -> Any:
    from hil.nodes.bus import BusConfig

    conf = BusConfig(listen=tuple(listen), connect=tuple(connect), lowlatency=lowlatency)
    return conf.zenoh_config()


def _set_priority(priority: int) -> None:
    if priority > 0:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))


def pong(listen: str, reply_size: int, priority: int, lowlatency: bool = True) -> None:
    """Answer every ping with ``reply_size`` bytes until stdin closes."""
    import zenoh

    _set_priority(priority)
    session = zenoh.open(_config([listen], [], lowlatency))
    pub = session.declare_publisher(PONG_KEY, express=True)
    reply = bytes(reply_size)

    def on_ping(_sample: zenoh.Sample) -> None:
        pub.put(reply)

    sub = session.declare_subscriber(PING_KEY, on_ping)
    print("ready", flush=True)
    sys.stdin.read()  # the ping side closes our stdin when it is done
    sub.undeclare()
    session.close()


def observe(connect: list[str], nice: int, lowlatency: bool = True) -> None:
    """Subscribe to both keys and count the samples until stdin closes (the recorder's part)."""
    import zenoh

    if nice:
        os.nice(nice)
    session = zenoh.open(_config([], connect, lowlatency))
    seen = [0]

    def on_sample(_sample: zenoh.Sample) -> None:
        seen[0] += 1

    sub = session.declare_subscriber("pingpong/**", on_sample)
    print("ready", flush=True)
    sys.stdin.read()
    sub.undeclare()
    session.close()
    print(seen[0], flush=True)


def _percentiles(ns: np.ndarray) -> dict[str, float]:
    us = ns / 1e3
    return {
        "p50": float(np.percentile(us, 50)),
        "p99": float(np.percentile(us, 99)),
        "p999": float(np.percentile(us, 99.9)),
        "max": float(us.max()),
        "mean": float(us.mean()),
    }


def ping(
    connect: str,
    request_size: int,
    count: int,
    warmup: int,
    period_s: float,
    priority: int,
    lowlatency: bool = True,
    listen: str = "",
) -> dict[str, Any]:
    """Measure ``count`` round trips per waiting style; return their percentiles [us].

    ``listen``: an endpoint to listen on too (for the observer to connect to).
    """
    import zenoh

    _set_priority(priority)
    session = zenoh.open(_config([listen] if listen else [], [connect], lowlatency))
    if listen:  # the observer connects: wait until it is there (and the pong peer)
        deadline = time.monotonic() + 30.0
        while len(list(session.info.peers_zid())) < 2:
            if time.monotonic() > deadline:
                raise SystemExit("ping: the observer did not connect within 30 s")
            time.sleep(0.01)
    pub = session.declare_publisher(PING_KEY, express=True)
    request = bytes(request_size)
    out: dict[str, Any] = {}

    # -- callback + Event -------------------------------------------------------------
    got = threading.Event()

    def on_pong(_sample: zenoh.Sample) -> None:
        got.set()

    sub = session.declare_subscriber(PONG_KEY, on_pong)
    deadline = time.monotonic() + 30.0
    while True:  # until the pong side's subscriber is matched
        got.clear()
        pub.put(request)
        if got.wait(0.1):
            break
        if time.monotonic() > deadline:
            raise SystemExit("ping: no answer from the pong process within 30 s")
    rtt = np.empty(count, dtype=np.int64)
    next_t = time.perf_counter_ns()
    period_ns = round(period_s * 1e9)
    for i in range(-warmup, count):
        if period_ns:
            next_t += period_ns
            while (d := next_t - time.perf_counter_ns()) > 0:
                time.sleep(d / 1e9)
        got.clear()
        t0 = time.perf_counter_ns()
        pub.put(request)
        if not got.wait(5.0):
            raise SystemExit("ping: lost an answer")
        if i >= 0:
            rtt[i] = time.perf_counter_ns() - t0
    sub.undeclare()
    out["callback"] = _percentiles(rtt)

    # -- FIFO channel, blocking recv --------------------------------------------------
    sub = session.declare_subscriber(PONG_KEY, zenoh.handlers.FifoChannel(64))
    pub.put(request)
    sub.recv()
    next_t = time.perf_counter_ns()
    for i in range(-warmup, count):
        if period_ns:
            next_t += period_ns
            while (d := next_t - time.perf_counter_ns()) > 0:
                time.sleep(d / 1e9)
        t0 = time.perf_counter_ns()
        pub.put(request)
        sub.recv()
        if i >= 0:
            rtt[i] = time.perf_counter_ns() - t0
    sub.undeclare()
    out["channel"] = _percentiles(rtt)
    session.close()
    best = min(("callback", "channel"), key=lambda k: out[k]["p50"])
    out["best"] = best
    return out


def measure(
    count: int = 20000,
    warmup: int = 500,
    period_s: float = 0.0,
    priority: int = 0,
    sizes: tuple[int, int] | None = None,
    lowlatency: bool = True,
    observer: bool = False,
) -> dict[str, Any]:
    """Run pong and ping as two processes; the ping side's figures and the sizes used.

    ``lowlatency``: Zenoh's low-latency unicast transport (the bench's default), else the
    default transport (QoS on, a transmission task per link), as :class:`hil.nodes.bus.BusConfig`.
    ``observer``: a third, passive peer subscribed to both keys (module docstring).
    """
    from hil.launch import RECORDER_NICE
    from hil.nodes.bus import free_tcp_endpoint

    req, rep = sizes if sizes is not None else payload_sizes()
    ep = free_tcp_endpoint()
    ping_ep = free_tcp_endpoint() if observer else ""
    while ping_ep == ep:
        ping_ep = free_tcp_endpoint()
    me = [sys.executable, str(Path(__file__).resolve())]
    ll = [] if lowlatency else ["--normal-transport"]
    obs_proc: subprocess.Popen[str] | None = None
    pong_proc = subprocess.Popen(
        [*me, "pong", "--endpoint", ep, "--reply-size", str(rep), "--priority", str(priority), *ll],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert pong_proc.stdout is not None
        if pong_proc.stdout.readline().strip() != "ready":
            raise SystemExit("pong process did not start")
        ping_cmd = [
            *me,
            "ping",
            "--endpoint",
            ep,
            "--request-size",
            str(req),
            "--count",
            str(count),
            "--warmup",
            str(warmup),
            "--period",
            repr(period_s),
            "--priority",
            str(priority),
            *ll,
        ]
        if observer:
            ping_cmd += ["--listen", ping_ep]
            obs_proc = subprocess.Popen(
                [
                    *me,
                    "observe",
                    "--endpoint",
                    ep,
                    "--endpoint2",
                    ping_ep,
                    "--nice",
                    str(RECORDER_NICE),
                    *ll,
                ],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                text=True,
            )
        res = subprocess.run(ping_cmd, capture_output=True, text=True, check=False)
        if res.returncode != 0:
            raise SystemExit(f"ping failed: {res.stdout}\n{res.stderr}")
        figures: dict[str, Any] = json.loads(res.stdout.strip().splitlines()[-1])
    finally:
        for proc in (pong_proc, obs_proc):
            if proc is None:
                continue
            if proc.stdin is not None:
                proc.stdin.close()
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
    figures.update(
        request_bytes=req,
        reply_bytes=rep,
        count=count,
        period_s=period_s,
        realtime_priority=priority,
        lowlatency=lowlatency,
        observer=observer,
        round_trip_us=figures[figures["best"]],
    )
    return figures


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("role", nargs="?", choices=("pong", "ping", "observe"), default=None)
    ap.add_argument("--endpoint", default="")
    ap.add_argument("--endpoint2", default="", help="observe: the ping side's endpoint")
    ap.add_argument("--listen", default="", help="ping: listen here too (for the observer)")
    ap.add_argument("--nice", type=int, default=0)
    ap.add_argument("--observer", action="store_true", help="a passive third peer on both keys")
    ap.add_argument("--reply-size", type=int, default=0)
    ap.add_argument("--request-size", type=int, default=0)
    ap.add_argument("--count", type=int, default=20000)
    ap.add_argument("--warmup", type=int, default=500)
    ap.add_argument("--period", type=float, default=0.0)
    ap.add_argument("--priority", type=int, default=0)
    ap.add_argument("--normal-transport", action="store_true", help="not the low-latency one")
    a = ap.parse_args()
    ll = not a.normal_transport
    if a.role == "pong":
        pong(a.endpoint, a.reply_size, a.priority, ll)
    elif a.role == "ping":
        r = ping(a.endpoint, a.request_size, a.count, a.warmup, a.period, a.priority, ll, a.listen)
        print(json.dumps(r))
    elif a.role == "observe":
        observe([a.endpoint, a.endpoint2], a.nice, ll)
    else:
        figures = measure(
            a.count, a.warmup, a.period, a.priority, lowlatency=ll, observer=a.observer
        )
        print(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
