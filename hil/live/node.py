"""The live view's process: takes the recorder's live batches, serves them to Foxglove.

``fowt run --live [PORT]`` starts it before the recorder (``fowt live-node``): it listens on
an endpoint of its own, which the recorder (``fowt record --live-forward``) connects to,
and connects to the plant's endpoint for the plant's liveliness token only. It subscribes
to one key, ``fowt/<turbine>/recorder/live`` (:mod:`hil.nodes.live_feed`): what the recorder
has written, a batch per 20 ms drain, signed with the run's key. It subscribes to none of
the run's own keys, so the sensor frames and commands that pace the run go to no extra
session and wake nothing here, and no key of the controller's can take it for the recorder
(a controller started with ``--await-recorder`` waits for the recorder's signed answer).

Each batch's tag is checked with the run's key (:func:`bus_schemas.auth.verify`: a batch
that fails is counted under ``rejected`` as ``recorder/live:auth`` and never shown), split
(:func:`hil.nodes.live_feed.open_live_batch`), and each message decoded as the recorder
decoded it and handed to the :class:`~hil.live.server.LiveServer`.

Never in the run's way: the recorder puts the batches with congestion control ``DROP``;
the subscriber's callback (in Zenoh's thread) only appends the raw batch to a bounded
queue (:data:`RAW_CAPACITY`; full: dropped). A batch lost either way is seen in the gap of
the batches' message indices (per recorder process: a restarted recorder starts a new
stream) and its messages are counted as ``dropped`` for the viewers,
with what the server and the sdk's per-client outbox drop (``live.json``,
:class:`~hil.live.server.LiveStats`, and the run summary's ``run.live_view``); the run log
is the recorder's and is unaffected.

It ends once the plant's final timing summary and both reports have come (or the plant's
liveliness token went) and :data:`END_IDLE_S` passed without a batch, or on SIGTERM/SIGINT.
"""

from __future__ import annotations

import collections
import dataclasses
import json
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import zenoh

from bus_schemas import DecodeError, TimingSummary
from bus_schemas.auth import verify
from bus_schemas.messages import ControllerReport, PlantReport
from bus_schemas.registry import KEY_PREFIX
from hil.live.scene import geometry_of
from hil.live.server import LiveServer, LiveStats
from hil.nodes.bus import Bus, BusConfig
from hil.nodes.live_feed import LIVE_SUFFIX, open_live_batch
from hil.nodes.signals import on_stop_signals
from hil.scenario.schema import Scenario

#: Live batches held between two takes of the main thread (a batch per recorder drain,
#: 20 ms: about 40 s); more are dropped for the viewers and counted.
RAW_CAPACITY = 2048
#: Wall seconds without a batch after the run's end before the node exits.
END_IDLE_S = 1.0
#: File name of the node's counts in the run folder.
LIVE_JSON = "live.json"


class LiveFeed:
    """Live batches to :meth:`LiveServer.offer`: bounded raw queue, tag check, decode.

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
        self.key = self.prefix + LIVE_SUFFIX
        self.raw: collections.deque[bytes] = collections.deque()
        #: Messages never shown: in batches dropped here or lost on the way (index gaps).
        self.lost = 0
        self.stream: int | None = None
        self.next_index = 0
        self.rejected: collections.Counter[str] = collections.Counter()
        self.final_seen = False
        self.reports: set[str] = set()
        self.last_sample = time.monotonic()

    def on_sample(self, sample: zenoh.Sample) -> None:
        """Zenoh's callback: queue the raw batch, or drop it (never blocks; the index gap
        counts its messages when the next batch comes)."""
        self.last_sample = time.monotonic()
        if len(self.raw) < RAW_CAPACITY:
            self.raw.append(sample.payload.to_bytes())

    def take(self) -> int:
        """Check, split, decode and offer every queued batch; returns how many batches."""
        n = 0
        raw = self.raw
        while raw:
            self._batch(raw.popleft())
            n += 1
        return n

    def _batch(self, payload: bytes) -> None:
        if self.auth_key is not None:
            try:
                payload = verify(self.auth_key, self.key, payload)
            except DecodeError as exc:
                self.rejected[f"{LIVE_SUFFIX}:{exc.reason}"] += 1
                return
        try:
            batch = open_live_batch(payload)
        except DecodeError as exc:
            self.rejected[f"{LIVE_SUFFIX}:{exc.reason}"] += 1
            return
        if batch.stream != self.stream:  # the first batch, or a restarted recorder's
            self.stream = batch.stream
            self.next_index = batch.first_index
        if batch.first_index < self.next_index:  # a batch already shown, or out of order
            self.rejected[f"{LIVE_SUFFIX}:duplicate"] += 1
            return
        self.lost += batch.first_index - self.next_index
        self.next_index = batch.first_index + len(batch.parts)
        for mt, part in batch.parts:
            suffix = mt.key_suffix
            try:
                msg = mt.codec.decode(part)
            except DecodeError as exc:
                self.rejected[f"{suffix}:{exc.reason}"] += 1
                continue
            if isinstance(msg, TimingSummary) and msg.final:
                self.final_seen = True
            elif isinstance(msg, PlantReport | ControllerReport):
                self.reports.add(type(msg).__name__)
            self.server.offer(self.prefix + suffix, msg)

    def stats(self) -> LiveStats:
        """The server's counts plus this feed's losses and rejections."""
        s = self.server.stats
        return dataclasses.replace(
            s, dropped=s.dropped + self.lost, rejected=dict(self.rejected), lost_in_feed=self.lost
        )


def live_node_command(
    scenario: str,
    duration_s: float,
    listen: str,
    plant_endpoint: str,
    key_file: Path,
    port: int,
    summary: Path,
) -> list[str]:
    """The command line of the live view's process in a launched run (``fowt live-node``):
    its own endpoint (the recorder connects to it), the plant's (for the plant's liveliness)
    and the run's key file."""
    import sys  # noqa: PLC0415

    return [
        sys.executable, "-m", "hil", "live-node", scenario, "--duration", repr(duration_s),
        "--listen", listen, "--connect", plant_endpoint, "--key-file", str(key_file),
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

    on_stop_signals(lambda _signum: stop.set())  # from a thread (hil.nodes.signals)
    tid = scenario.turbine_id
    server = LiveServer(tid, geometry_of(scenario.turbine, scenario.platform), port)
    log(f"live view: ws://127.0.0.1:{server.port} (Foxglove: Open connection)")
    feed = LiveFeed(server, bus_config.auth_key)
    bus = Bus(bus_config)
    plant_gone = threading.Event()

    def on_plant(sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.DELETE:
            plant_gone.set()

    subs: list[Any] = []
    try:
        subs.append(bus.session.declare_subscriber(feed.key, feed.on_sample))
        subs.append(
            bus.session.liveliness().declare_subscriber(f"fowt/{tid}/alive/plant", on_plant)
        )
        while not stop.is_set():
            feed.take()
            ended = plant_gone.is_set() or (feed.final_seen and len(feed.reports) == 2)
            if ended and time.monotonic() - feed.last_sample >= END_IDLE_S:
                break
            stop.wait(0.02)
        feed.take()
        for sub in subs:
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
