"""Does a Zenoh put block or drop when the subscriber cannot take more? (the recording path)

Two processes on loopback with the bench's Zenoh config (:class:`hil.nodes.bus.BusConfig`): a
subscriber with a small FIFO channel (``--capacity``, default 16) that takes nothing for
``--stall`` seconds, then takes everything; a publisher (express) that puts ``--count``
samples of ``--size`` bytes as fast as it can, with congestion control ``DROP`` or
``BLOCK``, over the low-latency transport (the bench's default) or the default one. Per
configuration: samples put and received, the total put time and the longest single put
[s]. Saves ``bench/results/bus_congestion.json`` with the commit and the load.

    python bench/bus_congestion.py [--count 20000] [--size 300] [--stall 8 25]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from typing import Any

import zenoh
from _common import commit, load, save

from hil.nodes.bus import Bus, BusConfig, free_tcp_endpoint


def subscriber(endpoint: str, capacity: int, lowlatency: bool, stall_s: float) -> None:
    """Listen on ``endpoint``; after ``stall_s`` take every sample; print how many came."""
    bus = Bus(BusConfig(listen=(endpoint,), lowlatency=lowlatency))
    sub = bus.session.declare_subscriber("bench/**", zenoh.handlers.FifoChannel(capacity))
    print("ready", flush=True)
    time.sleep(stall_s)
    n, last = 0, time.monotonic()
    while time.monotonic() - last < 3.0:  # until nothing came for 3 s
        if sub.try_recv() is None:
            time.sleep(0.001)
            continue
        n += 1
        last = time.monotonic()
    print(n, flush=True)
    bus.close()


def one(cc: str, lowlatency: bool, count: int, size: int, capacity: int, stall_s: float) -> Any:
    ep = free_tcp_endpoint()
    sub = subprocess.Popen(
        [sys.executable, __file__, "--subscriber", ep, str(capacity), str(int(lowlatency)),
         str(stall_s)],
        stdout=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    assert sub.stdout is not None
    sub.stdout.readline()  # "ready"
    t_ready = time.monotonic()
    bus = Bus(BusConfig(connect=(ep,), lowlatency=lowlatency))
    control = zenoh.CongestionControl.BLOCK if cc == "block" else zenoh.CongestionControl.DROP
    pub = bus.session.declare_publisher("bench/x", congestion_control=control, express=True)
    time.sleep(1.0)  # the subscription reaches this session
    payload = bytes(size)
    longest = 0.0
    t0 = time.monotonic()
    for _ in range(count):
        a = time.monotonic()
        pub.put(payload)
        longest = max(longest, time.monotonic() - a)
    put_s = time.monotonic() - t0
    received = int(sub.communicate(timeout=600)[0].split()[-1])
    bus.close()
    row = {
        "congestion_control": cc,
        "lowlatency": lowlatency,
        "subscriber_stall_s": stall_s,
        "stall_after_first_put_s": round(stall_s - (t0 - t_ready), 2),
        "put": count,
        "received": received,
        "lost": count - received,
        "put_s": round(put_s, 3),
        "longest_put_s": round(longest, 3),
    }
    print(row, flush=True)
    return row


def main() -> None:
    if sys.argv[1:2] == ["--subscriber"]:
        ep, cap, low, stall = sys.argv[2:6]
        subscriber(ep, int(cap), low == "1", float(stall))
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=20000)
    ap.add_argument("--size", type=int, default=300)
    ap.add_argument("--capacity", type=int, default=16)
    ap.add_argument("--stall", type=float, nargs="+", default=[8.0, 25.0])
    a = ap.parse_args()
    load_before = load()
    rows = [
        one(cc, low, a.count, a.size, a.capacity, stall)
        for stall in a.stall
        for low in (True, False)
        for cc in ("drop", "block")
    ]
    save(
        "bus_congestion",
        {
            "commit": commit(),
            "load_before": load_before,
            "load_after": load(),
            "zenoh": zenoh.__version__ if hasattr(zenoh, "__version__") else "",
            "payload_bytes": a.size,
            "subscriber_channel": a.capacity,
            "runs": rows,
        },
    )


if __name__ == "__main__":
    main()
