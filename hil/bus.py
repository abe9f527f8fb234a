"""Zenoh transport for the bench's nodes, loopback-only unless a config file says otherwise.

Defaults follow DESIGN.md: peer mode, explicit endpoints (``tcp/127.0.0.1:<port>`` or a
unix socket), multicast scouting off, and the low-latency unicast transport (with QoS off,
as it requires) which measured the lowest round trip here. A process only listens on the
endpoints it is given; with none it listens nowhere. Multi-host use goes through a Zenoh
JSON5 config file (router, TLS, access control), never through defaults that open the host.
"""

from __future__ import annotations

import contextlib
import ipaddress
import json
import queue
import socket
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zenoh


class BusConfigError(ValueError):
    """An endpoint or config that the bench refuses to use."""


def _check_loopback(endpoint: str) -> None:
    """Raise unless ``endpoint`` is on loopback (tcp/udp on 127.0.0.0/8 or ::1) or unix."""
    proto, _, rest = endpoint.partition("/")
    if proto == "unixsock-stream":
        return
    if proto not in ("tcp", "udp", "quic", "tls"):
        raise BusConfigError(
            f"endpoint {endpoint!r}: expected tcp/<addr>:<port> or unixsock-stream/<path>"
        )
    host = rest.rsplit(":", 1)[0].strip("[]")
    if host == "localhost":
        return
    try:
        addr = ipaddress.ip_address(host)
    except ValueError as exc:
        raise BusConfigError(f"endpoint {endpoint!r}: host must be a loopback IP address") from exc
    if not addr.is_loopback:
        raise BusConfigError(
            f"endpoint {endpoint!r} is not loopback; use --zenoh-config FILE for multi-host setups"
        )


@dataclass(frozen=True)
class BusConfig:
    """Where a node listens and connects.

    Parameters
    ----------
    listen, connect : tuple of str
        Zenoh endpoints such as ``tcp/127.0.0.1:7447``; must be loopback or unix sockets.
    lowlatency : bool
        Zenoh's low-latency unicast transport (QoS off); must match on both sides.
    config_file : Path or None
        A Zenoh JSON5 config replacing these defaults (multi-host: router, TLS, ACL).
        Endpoints given here are then added to it and not checked for loopback.
    """

    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    lowlatency: bool = True
    config_file: Path | None = None
    extra: tuple[tuple[str, str], ...] = field(default=())

    def __post_init__(self) -> None:
        if self.config_file is None:
            for ep in (*self.listen, *self.connect):
                _check_loopback(ep)

    def zenoh_config(self) -> zenoh.Config:
        """Build the ``zenoh.Config`` for this node."""
        if self.config_file is not None:
            conf = zenoh.Config.from_file(str(self.config_file))
        else:
            conf = zenoh.Config()
            conf.insert_json5("mode", '"peer"')
            conf.insert_json5("scouting/multicast/enabled", "false")
            # Gossip would make peers dial locators they learn from each other; every link
            # here is configured explicitly instead.
            conf.insert_json5("scouting/gossip/enabled", "false")
            if self.lowlatency:
                conf.insert_json5("transport/unicast/lowlatency", "true")
                conf.insert_json5("transport/unicast/qos/enabled", "false")
            conf.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        if self.config_file is not None and self.listen:
            conf.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        if self.connect:
            conf.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        for key, value in self.extra:
            conf.insert_json5(key, value)
        return conf

    def describe(self) -> str:
        """``listen [...], connect [...]`` as the session will use them (for log lines).

        With a config file the endpoints are the file's (unless given here), followed by
        ``, config FILE``.
        """
        if self.config_file is None:
            return f"listen {list(self.listen)}, connect {list(self.connect)}"
        conf = self.zenoh_config()
        listen, connect = (
            json.loads(conf.get_json(f"{k}/endpoints")) for k in ("listen", "connect")
        )
        return f"listen {listen}, connect {connect}, config {self.config_file}"


def free_tcp_endpoint() -> str:
    """A free ``tcp/127.0.0.1:<port>`` endpoint (the OS picks the port)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"tcp/127.0.0.1:{port}"


class BusOpenError(RuntimeError):
    """The Zenoh session could not be opened (refused certificate, no peer, port in use)."""


class Bus:
    """One Zenoh session with typed publish and raw subscribe helpers."""

    def __init__(self, config: BusConfig) -> None:
        self.config = config
        try:
            self.session = zenoh.open(config.zenoh_config())
        except zenoh.ZError as exc:  # a refused TLS handshake, an endpoint in use, ...
            raise BusOpenError(
                f"the Zenoh session did not open ({config.describe()}): {exc}"
            ) from exc
        self._publishers: dict[str, Any] = {}
        self._subscribers: list[Any] = []

    def publisher(self, key: str) -> Any:
        """Declare (once) an express publisher on ``key`` (no batching: lowest latency)."""
        pub = self._publishers.get(key)
        if pub is None:
            pub = self.session.declare_publisher(key, express=True)
            self._publishers[key] = pub
        return pub

    def put(self, key: str, payload: bytes) -> None:
        """Publish ``payload`` on ``key``."""
        self.publisher(key).put(payload)

    def subscribe(self, key: str, callback: Callable[[str, bytes], None]) -> None:
        """Call ``callback(key, payload)`` for each sample on ``key`` (in Zenoh's thread)."""

        def on_sample(sample: zenoh.Sample) -> None:
            callback(str(sample.key_expr), sample.payload.to_bytes())

        self._subscribers.append(self.session.declare_subscriber(key, on_sample))

    def peer_count(self) -> int:
        """Number of peers this session is connected to."""
        return len(list(self.session.info.peers_zid()))

    def close(self) -> None:
        """Undeclare everything and close the session (idempotent)."""
        for sub in self._subscribers:
            with contextlib.suppress(Exception):  # the session may already be going away
                sub.undeclare()
        self._subscribers.clear()
        if not self.session.is_closed():
            self.session.close()


class PutQueue:
    """Puts done by a background thread, in the order they were queued.

    For log-only messages (truth, per-cycle timing, running summaries), which nobody waits
    for: a Zenoh put on the low-latency transport writes to each peer's socket in the
    caller's thread (25-90 us per put on this 2-core machine with one or two peers, measured
    in bench/lockstep_speed.py's profile), and it releases the GIL while it does so. Queued
    here (about 1 us for the caller), those writes overlap with the controller's turn
    instead of adding to every control cycle. One thread: the puts keep their order.
    """

    def __init__(self, name: str = "fowt-put-queue") -> None:
        self._queue: queue.SimpleQueue[tuple[Any, bytes] | None] = queue.SimpleQueue()
        self.failed = 0  # puts that raised (a session going away at the end of a run)
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def put(self, publisher: Any, payload: bytes) -> None:
        """Queue ``publisher.put(payload)``."""
        self._queue.put((publisher, payload))

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            target, payload = item
            if isinstance(target, threading.Event):  # a flush marker
                target.set()
                continue
            try:
                target.put(payload)
            except Exception:  # the session may be closing at the end of a run: counted
                self.failed += 1

    def flush(self, timeout_s: float = 5.0) -> bool:
        """Block until every put queued so far is done (False: ``timeout_s`` passed)."""
        done = threading.Event()
        self._queue.put((done, b""))
        return done.wait(timeout_s)

    def close(self, timeout_s: float = 5.0) -> None:
        """Do the queued puts, then stop the thread (idempotent)."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join(timeout_s)
