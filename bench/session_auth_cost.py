"""Benchmark: what Zenoh's session authentication costs (``transport/auth/usrpwd``).

An authenticated run's sessions open only with the run's credential
(:attr:`hil.nodes.bus.BusConfig.session_auth`, docs/security.md). The check runs when a
link is set up (a challenge-response in Zenoh's handshake); the data path is unchanged. So:

1. Per run: the time from opening a connecting session to its link to a listening node
   (``Bus`` with ``connect`` to a ``Bus`` with ``listen``, on loopback TCP), with and
   without session authentication, alternating, ``--links`` times each. A run opens about
   five such links (controller to plant, recorder to plant and controller, the launcher's
   progress session to the plant). Median and p90 [ms].
2. Per cycle: a ping-pong round trip (put, the other session's subscriber puts back, the
   first one's subscriber wakes) between two sessions of this process over one link, with
   and without session authentication (payload signing off in both, to show the session's
   share only), ``--count`` round trips each, alternating in ``--rounds`` rounds. Median
   and p99 [us].

    python bench/session_auth_cost.py [--links 20] [--count 2000] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import threading
import time
from typing import Any

from _common import save

from bus_schemas.auth import new_key
from hil.nodes.bus import Bus, BusConfig, free_tcp_endpoint


def _configs(ep: str, secure: bool) -> tuple[BusConfig, BusConfig]:
    key = new_key() if secure else None
    return BusConfig(listen=(ep,), auth_key=key), BusConfig(connect=(ep,), auth_key=key)


def _link_ms(secure: bool) -> float:
    ep = free_tcp_endpoint()
    listen, connect = _configs(ep, secure)
    node = Bus(listen)
    try:
        t0 = time.perf_counter_ns()
        other = Bus(connect)
        while not list(other.session.info.peers_zid()):
            time.sleep(0.0002)
        dt = (time.perf_counter_ns() - t0) / 1e6
        other.close()
    finally:
        node.close()
    return dt


def _round_trips_us(secure: bool, count: int) -> list[float]:
    ep = free_tcp_endpoint()
    listen, connect = _configs(ep, secure)
    a, b = Bus(listen), Bus(connect)
    # Raw publishers and subscribers of the sessions: no payload tag in either variant, so
    # the difference is the session's alone.
    got = threading.Event()
    try:
        pong = b.session.declare_publisher("bench/pong", express=True)
        ping = a.session.declare_publisher("bench/ping", express=True)
        subs = [
            b.session.declare_subscriber("bench/ping", lambda s: pong.put(s.payload)),
            a.session.declare_subscriber("bench/pong", lambda _s: got.set()),
        ]
        while not ping.matching_status.matching or not pong.matching_status.matching:
            time.sleep(0.001)
        payload = bytes(120)
        out: list[float] = []
        for i in range(count + 100):
            got.clear()
            t0 = time.perf_counter_ns()
            ping.put(payload)
            if not got.wait(2.0):
                continue
            if i >= 100:  # warm-up
                out.append((time.perf_counter_ns() - t0) / 1e3)
        for sub in subs:
            sub.undeclare()
        return out
    finally:
        b.close()
        a.close()


def _stats(xs: list[float], p: float) -> dict[str, float]:
    s = sorted(xs)
    return {
        "median": round(statistics.median(s), 3),
        f"p{round(p * 100)}": round(s[min(len(s) - 1, int(p * len(s)))], 3),
        "n": len(s),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--links", type=int, default=20)
    ap.add_argument("--count", type=int, default=2000)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    links: dict[str, list[float]] = {"authenticated": [], "plain": []}
    for i in range(args.links):
        for secure in (i % 2 == 0, i % 2 == 1):
            links["authenticated" if secure else "plain"].append(_link_ms(secure))
    trips: dict[str, list[float]] = {"authenticated": [], "plain": []}
    for r in range(args.rounds):
        for secure in (r % 2 == 0, r % 2 == 1):
            trips["authenticated" if secure else "plain"] += _round_trips_us(secure, args.count)
    result: dict[str, Any] = {
        "args": vars(args),
        "link_setup_ms": {k: _stats(v, 0.9) for k, v in links.items()},
        "round_trip_us": {k: _stats(v, 0.99) for k, v in trips.items()},
    }
    save("session_auth_cost", result)


if __name__ == "__main__":
    main()
