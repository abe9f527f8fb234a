"""A local process without the run's key that tries to use the bench's Zenoh sessions.

Run as ``python tests/_keyless_client.py MODE DURATION_S ENDPOINT [ENDPOINT ...]``; it prints
one JSON line when done: ``attempts`` (sessions it tried to open), ``sessions`` (how many
opened with a link to a bench node), ``puts`` and ``received``. It tries, for
``DURATION_S`` wall seconds, a Zenoh *client* session (the mode a process uses to reach a
router, and which a peer routes for) on each endpoint in turn; once one has a link it:

* ``replay``: puts the signed payloads of the file named by ``FOWT_REPLAY_FILE`` (msgpack
  list of ``[key, payload]``: what it captured) over and over;
* ``subscribe``: subscribes to ``fowt/**`` and only counts what it gets;
* ``flood``: puts 3000 random payloads a second, spread over the bench's keys.

Used by ``tests/test_session_auth.py`` against authenticated runs (where no session may
open) and against an unauthenticated node (where it must, so the attack is real).
"""

from __future__ import annotations

import json
import os
import random
import sys
import time
from pathlib import Path

import msgspec
import zenoh

FLOOD_PER_S = 3000
KEYS = (
    "fowt/t1/command",
    "fowt/t1/sensors",
    "fowt/t1/timing/batch",
    "fowt/t1/controller/batch",
    "fowt/t1/timing/summary",
)


def _client(endpoint: str) -> zenoh.Session | None:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "false")
    conf.insert_json5("transport/unicast/lowlatency", "true")
    conf.insert_json5("transport/unicast/qos/enabled", "false")
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("connect/timeout_ms", "300")
    try:
        session = zenoh.open(conf)
    except zenoh.ZError:
        return None
    if not list(session.info.routers_zid()) and not list(session.info.peers_zid()):
        session.close()
        return None
    return session


def main() -> None:
    mode, duration_s, endpoints = sys.argv[1], float(sys.argv[2]), sys.argv[3:]
    rng = random.Random(5)
    replay: list[tuple[str, bytes]] = []
    if mode == "replay":
        replay = [(k, bytes(p)) for k, p in msgspec.msgpack.decode(
            Path(os.environ["FOWT_REPLAY_FILE"]).read_bytes())]  # fmt: skip
    report = {"attempts": 0, "sessions": 0, "puts": 0, "received": 0}
    end = time.monotonic() + duration_s
    i = 0
    while time.monotonic() < end:
        session = _client(endpoints[i % len(endpoints)])
        i += 1
        report["attempts"] += 1
        if session is None:
            time.sleep(0.05)
            continue
        report["sessions"] += 1
        if mode == "subscribe":

            def count(_s: zenoh.Sample) -> None:
                report["received"] += 1

            sub = session.declare_subscriber("fowt/**", count)
            time.sleep(max(0.0, end - time.monotonic()))
            sub.undeclare()
        else:
            n = 0
            t0 = time.monotonic()
            while time.monotonic() < end:
                if mode == "replay":
                    key, payload = replay[n % len(replay)]
                else:
                    key, payload = KEYS[n % len(KEYS)], rng.randbytes(rng.randrange(8, 200))
                session.put(key, payload)
                n += 1
                if mode == "flood":
                    ahead = n / FLOOD_PER_S - (time.monotonic() - t0)
                    if ahead > 0:
                        time.sleep(ahead)
            report["puts"] += n
        session.close()
    print(json.dumps(report), flush=True)


if __name__ == "__main__":
    main()
