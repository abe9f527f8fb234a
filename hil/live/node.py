"""The live view's process: subscribes on the run's bus, serves it to Foxglove.

``fowt run --live [PORT]`` starts it beside the recorder (``fowt live-node``, with the
recorder's endpoints and the run's key): it opens its Zenoh session as the recorder does
(:class:`hil.nodes.bus.Bus` from the same command-line helper), subscribes to
``fowt/<turbine>/**``, checks every sample's tag with the run's key (:func:`bus_schemas.auth.
verify`: a sample that fails is counted under ``rejected`` as ``<suffix>:auth`` and never
shown), splits the nodes' log batches (:func:`hil.nodes.bus.split_batch`) and decodes each
message as the recorder does, then hands it to the :class:`~hil.live.server.LiveServer`.

Never in the run's way: the subscriber's callback (in Zenoh's thread) only appends the raw
sample to a bounded queue (:data:`RAW_CAPACITY`; full: dropped and counted), so Zenoh's
receive never waits for this process's Python side or for a viewer, and the publishers'
``BLOCK`` congestion control (:mod:`hil.nodes.bus`) is never reached through it. Everything
after it (checking, decoding, encoding, the sdk's per-client outbox) can only lose messages
for the viewers, counted in ``live.json`` (:class:`~hil.live.server.LiveStats`) and in the
run summary's ``run.live_view``; the recorder, which subscribes on its own, is unaffected.

Never in the run's gates either: a controller started with ``--await-recorder`` announces
itself once a subscriber of its status key is reachable (:func:`hil.nodes.bus.wait_matched`),
which must be the recorder, not this process. So the controller's status keys
(``controller/batch``, ``controller/status``) are subscribed only while the controller's
liveliness token is there (it is declared after that wait), and dropped when it goes (a
restarted controller waits for the recorder again); the other keys from the start.

It ends once the plant's final timing summary and both reports have come (or the plant's
liveliness token went) and :data:`END_IDLE_S` passed without a sample, or on SIGTERM/SIGINT.
"""

from __future__ import annotations

import collections
import dataclasses
import json
import signal
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import zenoh

from bus_schemas import DecodeError, TimingSummary
from bus_schemas.auth import verify
from bus_schemas.messages import ControllerReport, PlantReport
from bus_schemas.registry import BY_SUFFIX, CONTROLLER_STATUS, KEY_PREFIX, MESSAGES
from hil.live.scene import geometry_of
from hil.live.server import LiveServer, LiveStats
from hil.nodes.bus import (
    BATCH_SUFFIXES,
    CONTROLLER_BATCH_SUFFIX,
    PLANT_BATCH_SUFFIX,
    Bus,
    BusConfig,
    split_batch,
)
from hil.scenario.schema import Scenario

#: Raw samples held between two takes of the main thread (about 2 s of the fastest
#: lock-step); more are dropped for the viewers and counted.
RAW_CAPACITY = 8192
#: Wall seconds without a sample after the run's end before the node exits.
END_IDLE_S = 1.0
#: File name of the node's counts in the run folder.
LIVE_JSON = "live.json"


class LiveFeed:
    """Bus samples to :meth:`LiveServer.offer`: bounded raw queue, tag check, decode.

    Parameters
    ----------
    server : LiveServer
        Where the decoded messages go.
    auth_key : bytes or None
        The run's secret (None: an unauthenticated run, ``--insecure``).
    """

    def __init__(self, server: LiveServer, auth_key: bytes | None) -> None:
        self.server = server
        self.auth_key = auth_key
        self.prefix = f"{KEY_PREFIX}/{server.turbine}/"
        self.raw: collections.deque[tuple[str, bytes]] = collections.deque()
        self.raw_dropped = 0
        self.rejected: collections.Counter[str] = collections.Counter()
        self.final_seen = False
        self.reports: set[str] = set()
        self.last_sample = time.monotonic()

    def on_sample(self, sample: zenoh.Sample) -> None:
        """Zenoh's callback: queue the raw sample, or count it dropped (never blocks)."""
        self.last_sample = time.monotonic()
        if len(self.raw) >= RAW_CAPACITY:
            self.raw_dropped += 1
            return
        self.raw.append((str(sample.key_expr), sample.payload.to_bytes()))

    def take(self) -> int:
        """Check, decode and offer every queued sample; returns how many."""
        n = 0
        raw = self.raw
        while raw:
            key, payload = raw.popleft()
            n += 1
            self._one(key, payload)
        return n

    def _one(self, key: str, payload: bytes) -> None:
        suffix = key.removeprefix(self.prefix)
        batch = suffix in BATCH_SUFFIXES
        mt = None if batch else BY_SUFFIX.get(suffix)
        if mt is None and not batch:
            return  # liveliness, unknown keys: the recorder counts those
        if self.auth_key is not None:
            try:
                payload = verify(self.auth_key, key, payload)
            except DecodeError as exc:
                self.rejected[f"{suffix}:{exc.reason}"] += 1
                return
        if mt is None:
            try:
                parts = split_batch(payload)
            except DecodeError as exc:
                self.rejected[f"{suffix}:{exc.reason}"] += 1
                return
            for pmt, part in parts:
                self._decoded(self.prefix + pmt.key_suffix, pmt.key_suffix, pmt, part)
            return
        self._decoded(key, suffix, mt, payload)

    def _decoded(self, key: str, suffix: str, mt: Any, payload: Any) -> None:
        try:
            msg = mt.codec.decode(payload)
        except DecodeError as exc:
            self.rejected[f"{suffix}:{exc.reason}"] += 1
            return
        if isinstance(msg, TimingSummary) and msg.final:
            self.final_seen = True
        elif isinstance(msg, PlantReport | ControllerReport):
            self.reports.add(type(msg).__name__)
        self.server.offer(key, msg)

    def stats(self) -> LiveStats:
        """The server's counts plus this feed's drops and rejections."""
        s = self.server.stats
        return dataclasses.replace(
            s, dropped=s.dropped + self.raw_dropped, rejected=dict(self.rejected)
        )


def _gated(tid: str) -> tuple[str, ...]:
    """The keys of the controller's statuses: subscribed only once it announced itself."""
    return (f"{KEY_PREFIX}/{tid}/{CONTROLLER_BATCH_SUFFIX}", CONTROLLER_STATUS.key(tid))


def _open_keys(tid: str) -> list[str]:
    """Every other key of the run's messages (and the plant's log batches)."""
    keys = [mt.key(tid) for mt in MESSAGES] + [f"{KEY_PREFIX}/{tid}/{PLANT_BATCH_SUFFIX}"]
    return [k for k in keys if k not in _gated(tid)]


def live_node_command(
    scenario: str,
    duration_s: float,
    endpoints: tuple[str, str],
    key_file: Path,
    port: int,
    summary: Path,
) -> list[str]:
    """The command line of the live view's process in a launched run (``fowt live-node``):
    the recorder's endpoints (plant, controller) and the run's key file."""
    import sys  # noqa: PLC0415

    plant_ep, ctrl_ep = endpoints
    return [
        sys.executable, "-m", "hil", "live-node", scenario, "--duration", repr(duration_s),
        "--connect", plant_ep, "--connect", ctrl_ep, "--key-file", str(key_file),
        "--port", str(port), "--summary", str(summary),
    ]  # fmt: skip


def run_live_node(
    scenario: Scenario,
    bus_config: BusConfig,
    port: int,
    summary: Path | None = None,
    log: Callable[[str], None] = print,
) -> LiveStats:
    """Serve the run of ``scenario`` on 127.0.0.1:``port`` until it ends (module docstring).

    Writes the counts (:class:`LiveStats`) to ``summary`` as JSON when given.
    """
    stop = threading.Event()

    def on_signal(_signum: int, _frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    tid = scenario.turbine_id
    server = LiveServer(tid, geometry_of(scenario.turbine, scenario.platform), port)
    log(f"live view: ws://127.0.0.1:{server.port} (Foxglove: Open connection)")
    feed = LiveFeed(server, bus_config.auth_key)
    bus = Bus(bus_config)
    plant_gone = threading.Event()

    def on_plant(sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.DELETE:
            plant_gone.set()

    controller_up = threading.Event()

    def on_controller(sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.DELETE:
            controller_up.clear()
        else:
            controller_up.set()

    subs: list[Any] = []
    gated: list[Any] = []
    try:
        for key in _open_keys(tid):
            subs.append(bus.session.declare_subscriber(key, feed.on_sample))
        liveliness = bus.session.liveliness()
        subs.append(liveliness.declare_subscriber(f"fowt/{tid}/alive/plant", on_plant))
        subs.append(
            liveliness.declare_subscriber(
                f"fowt/{tid}/alive/controller", on_controller, history=True
            )
        )
        while not stop.is_set():
            # The controller's status keys only while its token is there (module docstring).
            if controller_up.is_set() and not gated:
                gated = [bus.session.declare_subscriber(k, feed.on_sample) for k in _gated(tid)]
            elif not controller_up.is_set() and gated:
                for sub in gated:
                    sub.undeclare()
                gated = []
            feed.take()
            ended = plant_gone.is_set() or (feed.final_seen and len(feed.reports) == 2)
            if ended and time.monotonic() - feed.last_sample >= END_IDLE_S:
                break
            stop.wait(0.02)
        feed.take()
        for sub in gated + subs:
            sub.undeclare()
    finally:
        bus.close()
        server.close()
        stats = feed.stats()
        if summary is not None:
            summary.write_text(json.dumps(dataclasses.asdict(stats), indent=2))
        log(
            f"live view closed: {stats.published} messages published, {stats.dropped} dropped "
            f"for the viewers, {stats.outbox_full} client outbox overflows, "
            f"rejected {stats.rejected}"
        )
    return stats
