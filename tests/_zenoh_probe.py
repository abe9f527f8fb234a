"""Zenoh clients for ``test_multi_host.py``, run inside a test's network namespace.

``python tests/_zenoh_probe.py open CONFIG``
    Open a :class:`hil.nodes.bus.Bus` from ``CONFIG`` and close it again. Prints one JSON line
    ``{"opened": bool, "zid": str, "routers": int, "error": str}``; exit status 0 when it
    opened, 1 when Zenoh refused (e.g. the router rejected the client certificate).

``python tests/_zenoh_probe.py acl SUBSCRIBER_CONFIG PUBLISHER_CONFIG N KEY [KEY ...]``
    A subscriber (its own session) on ``fowt/t1/**``, then a second session that puts ``N``
    samples on each ``KEY`` in turn. Prints one JSON line ``{"publisher_zid": str,
    "delivered": {key: count}}`` once the deliveries have settled.
"""

from __future__ import annotations

import json
import sys
import threading
import time
from collections import Counter
from pathlib import Path

from hil.nodes.bus import Bus, BusConfig


def probe_open(config: Path) -> int:
    try:
        bus = Bus(BusConfig(config_file=config))
    except Exception as exc:  # zenoh.ZError: "Unable to connect to any of [...]"
        print(json.dumps({"opened": False, "zid": "", "routers": 0, "error": str(exc)}))
        return 1
    try:
        info = bus.session.info
        routers = len(list(info.routers_zid()))
        print(json.dumps({"opened": True, "zid": str(info.zid()), "routers": routers, "error": ""}))
    finally:
        bus.close()
    return 0


def probe_acl(sub_config: Path, pub_config: Path, n: int, keys: list[str]) -> int:
    delivered: Counter[str] = Counter()
    lock = threading.Lock()

    def on_sample(key: str, _payload: bytes) -> None:
        with lock:
            delivered[key] += 1

    sub = Bus(BusConfig(config_file=sub_config))
    pub = Bus(BusConfig(config_file=pub_config))
    try:
        sub.subscribe("fowt/t1/**", on_sample)
        time.sleep(1.0)  # the subscription reaches the router and the publisher
        for key in keys:
            for i in range(n):
                pub.put(key, i.to_bytes(4, "little"))
        # Wait until no sample has arrived for 1 s (at most 10 s).
        last, deadline = -1, time.monotonic() + 10.0
        while time.monotonic() < deadline:
            time.sleep(1.0)
            with lock:
                now = sum(delivered.values())
            if now == last:
                break
            last = now
        with lock:
            out = {k: delivered.get(k, 0) for k in keys}
        print(json.dumps({"publisher_zid": str(pub.session.info.zid()), "delivered": out}))
    finally:
        pub.close()
        sub.close()
    return 0


def main(argv: list[str]) -> int:
    if argv[:1] == ["open"] and len(argv) == 2:
        return probe_open(Path(argv[1]))
    if argv[:1] == ["acl"] and len(argv) >= 5:
        return probe_acl(Path(argv[1]), Path(argv[2]), int(argv[3]), argv[4:])
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
