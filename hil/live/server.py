"""A read-only Foxglove WebSocket server with the run log's channels (``foxglove-sdk``).

Channels: one per registered message (:data:`bus_schemas.registry.MESSAGES`), topic, schema
and encoding exactly as in the run log (:meth:`hil.runlog.mcap_io.RunLog.add_channel`: the
``ros2msg`` definition of :func:`bus_schemas.ros2.msgdef` named :func:`bus_schemas.ros2.
schema_name`, ``cdr`` payloads of :func:`bus_schemas.ros2.encode_rows`), so a Foxglove layout
works on the live view and on the file alike; plus ``/tf`` (``foxglove.FrameTransforms``:
:func:`hil.live.scene.transforms`, the pair ``world -> platform`` and ``platform -> rotor`` in
one message per truth message, so ``/tf`` runs at the control rate: a viewer such as
Lichtblick warns of topics above 60 Hz) and ``/scene`` (``foxglove.SceneUpdate``,
:func:`hil.live.scene.scene`, from the first transform on: sent to each client as it
subscribes and once a second; its entities sit in frames only ``/tf`` places).

Read-only: no capability is announced (no client publishing, services, parameters, time or
playback control), and the server binds to 127.0.0.1 only.

Never in the run's way: :meth:`LiveServer.offer` only appends to a bounded queue (a full
queue drops the message and counts it, :attr:`LiveServer.dropped`); one thread of this
process encodes and hands the messages to the sdk, whose own per-client outbox
(``message_backlog_size``) drops the oldest data when a viewer does not read. The sdk does
not count those: it logs ``outbox for client ... full`` (rate limited), and each such line is
counted (:attr:`LiveServer.outbox_full`, at least one per episode of a viewer falling behind).
"""

from __future__ import annotations

import collections
import logging
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import msgspec
import numpy as np

from bus_schemas import ros2
from bus_schemas.messages import PlantState
from bus_schemas.registry import MESSAGES, MessageType
from hil.live.scene import Azimuth, TurbineGeometry, scene, transforms

#: Default port (Foxglove's own default for a WebSocket connection).
DEFAULT_PORT = 8765
#: Messages the hand-over queue holds before it drops (about 2 s of the fastest lock-step).
QUEUE_CAPACITY = 8192
#: Messages the sdk keeps per client before it drops the oldest.
CLIENT_BACKLOG = 4096
#: Wall seconds between two scene updates.
SCENE_PERIOD_S = 1.0
#: Wall seconds :meth:`LiveServer.close` waits for the sdk's server to stop.
STOP_WAIT_S = 2.0
#: The sdk's logger of a client's full outbox.
_OUTBOX_LOGGER = "foxglove.websocket.connected_client.send_lossy"


class _OutboxCounter(logging.Handler):
    """Counts the sdk's ``outbox ... full`` log lines (module docstring)."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.count = 0

    def emit(self, record: logging.LogRecord) -> None:
        if "full" in record.getMessage():
            self.count += 1


@dataclass
class LiveStats:
    """What a live server did (``live.json``, the run summary's ``run.live_view``)."""

    port: int
    offered: int = 0
    published: int = 0
    dropped: int = 0
    outbox_full: int = 0
    clients: int = 0
    rejected: dict[str, int] = field(default_factory=dict)
    #: The server had not stopped after STOP_WAIT_S (a viewer held its socket open).
    stop_waited: bool = False
    #: Of ``dropped``: messages of batches lost on the way from the recorder (index gaps).
    lost_in_feed: int = 0


class LiveServer:
    """The live view's server (module docstring).

    Parameters
    ----------
    turbine : str
        Turbine id of the topics (``fowt/<turbine>/<suffix>``).
    geometry : TurbineGeometry
        What ``/scene`` draws.
    port : int
        TCP port on 127.0.0.1 (0: any free one, see :attr:`port`).
    start_unix_ns : int or None
        Log time of simulated time 0 [ns] (the run log's convention); default now.
    queue_capacity : int
        Bound of the hand-over queue.
    client_backlog : int
        Messages the sdk keeps per client before it drops the oldest.
    schemas : dict or None
        ``topic -> (schema name, ros2msg text)`` replacing the current declarations' (a
        recorded file's own schemas, :mod:`hil.live.replay`).
    """

    def __init__(
        self,
        turbine: str,
        geometry: TurbineGeometry,
        port: int = DEFAULT_PORT,
        start_unix_ns: int | None = None,
        queue_capacity: int = QUEUE_CAPACITY,
        client_backlog: int = CLIENT_BACKLOG,
        schemas: dict[str, tuple[str, str]] | None = None,
    ) -> None:
        import foxglove  # noqa: PLC0415
        from foxglove.channels import FrameTransformsChannel, SceneUpdateChannel  # noqa: PLC0415
        from foxglove.websocket import ServerListener  # noqa: PLC0415

        self.turbine = turbine
        self.geometry = geometry
        self.start_unix_ns = time.time_ns() if start_unix_ns is None else start_unix_ns
        self._context = foxglove.Context()
        self._channels: dict[str, tuple[Any, MessageType]] = {}
        for mt in MESSAGES:
            topic = mt.key(turbine)
            name, text = (schemas or {}).get(topic, (ros2.schema_name(mt), ros2.msgdef(mt)))
            schema = foxglove.Schema(name=name, encoding="ros2msg", data=text.encode())
            meta = {"version": str(mt.version), "message_id": str(mt.message_id)}
            ch = foxglove.Channel(
                topic, schema=schema, message_encoding="cdr", context=self._context, metadata=meta
            )
            self._channels[topic] = (ch, mt)
        self._tf = FrameTransformsChannel("/tf", context=self._context)
        self._scene = SceneUpdateChannel("/scene", context=self._context)
        self._truth_topic = f"fowt/{turbine}/truth"
        self._azimuth = Azimuth()
        self._queue: collections.deque[tuple[str, Any]] = collections.deque()
        self._capacity = queue_capacity
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._last_scene = 0.0
        self._placed = False  # a transform was published (the scene may follow)
        self._outbox = _OutboxCounter()
        outbox_log = logging.getLogger(_OUTBOX_LOGGER)
        outbox_log.addHandler(self._outbox)
        outbox_log.setLevel(logging.INFO)  # the sdk says it at INFO: let it through
        server_self = self

        class _Listener(ServerListener):
            def on_subscribe(self, client: Any, channel: Any) -> None:
                server_self._clients.add(int(client.id))
                server_self.stats.clients = len(server_self._clients)
                if channel.topic == "/scene" and server_self._placed:
                    server_self._send_scene()

        self._clients: set[int] = set()
        self._server = foxglove.start_server(
            name=f"fowt-hil {turbine}",
            host="127.0.0.1",
            port=port,
            capabilities=[],
            server_listener=_Listener(),
            context=self._context,
            message_backlog_size=client_backlog,
        )
        self.stats = LiveStats(port=self._server.port)
        self._thread = threading.Thread(target=self._run, name="live-view", daemon=True)
        self._thread.start()

    @property
    def port(self) -> int:
        """The TCP port the server listens on (127.0.0.1)."""
        return int(self._server.port)

    # ------------------------------------------------------------------ feeding
    def offer(self, topic: str, msg: msgspec.Struct) -> bool:
        """Queue a decoded message of ``topic`` for the viewers; False (counted) when full.

        Never blocks: called from the bus's thread.
        """
        self.stats.offered += 1
        if len(self._queue) >= self._capacity:
            self.stats.dropped += 1
            return False
        self._queue.append((topic, msg))
        self._wake.set()
        return True

    def offer_cdr(
        self, topic: str, payload: bytes, log_time_ns: int, truth: np.void | None = None
    ) -> None:
        """Publish a CDR payload as it is (a run log's message, :mod:`hil.live.replay`).

        ``truth``: the decoded record when it is the truth's (it places the frames; a field
        it lacks, in a file of an older schema, counts as 0).
        """
        got = self._channels.get(topic)
        if got is None:
            return
        ch, _mt = got
        ch.log(payload, log_time=log_time_ns)
        self.stats.published += 1
        if truth is not None:
            names = truth.dtype.names or ()

            def f(name: str) -> float:
                return float(truth[name]) if name in names else 0.0

            self._place(
                log_time_ns,
                int(truth["sample_time_ns"]),
                f("rotor_speed_rad_s"),
                f("platform_surge_m"),
                f("platform_heave_m"),
                f("platform_pitch_rad"),
            )
        self._maybe_scene()

    def _place(
        self, unix_ns: int, sample_ns: int, omega: float, surge: float, heave: float, pitch: float
    ) -> None:
        azimuth = self._azimuth.update(sample_ns, omega)
        self._tf.log(
            transforms(self.geometry, unix_ns, surge, heave, pitch, azimuth), log_time=unix_ns
        )
        self._placed = True

    def _send_scene(self) -> None:
        with self._lock:
            self._scene.log(scene(self.geometry, time.time_ns()))
            self._last_scene = time.monotonic()

    def _maybe_scene(self) -> None:
        if self._placed and time.monotonic() - self._last_scene >= SCENE_PERIOD_S:
            self._send_scene()

    def _run(self) -> None:
        # Woken by offer (the feeder offers in batches: the node every 20 ms), else once per
        # scene period: no polling beside the run's processes.
        while not self._stop.is_set():
            self._wake.wait(SCENE_PERIOD_S)
            self._wake.clear()
            self._publish_queued()
            self._maybe_scene()
        self._publish_queued()

    def _publish_queued(self) -> None:
        """Encode what is queued, per type in one go, and hand it to the sdk in order."""
        items: list[tuple[str, Any]] = []
        q = self._queue
        while q:
            items.append(q.popleft())
        if not items:
            return
        # CDR per message type in one numpy pass (bus_schemas.ros2.encode_rows), then logged
        # in arrival order.
        by_type: dict[str, list[int]] = {}
        for i, (topic, _msg) in enumerate(items):
            by_type.setdefault(topic, []).append(i)
        payloads: list[bytes] = [b""] * len(items)
        for topic, idx in by_type.items():
            got = self._channels.get(topic)
            if got is None:
                continue
            _ch, mt = got
            rows = np.array([msgspec.structs.astuple(items[i][1]) for i in idx], mt.row_dtype)
            data = ros2.encode_rows(mt, rows).tobytes()
            size = ros2.cdr_dtype(mt).itemsize
            for k, i in enumerate(idx):
                payloads[i] = data[k * size : (k + 1) * size]
        t0 = self.start_unix_ns
        for (topic, msg), payload in zip(items, payloads, strict=True):
            if not payload:
                continue
            ch, _mt = self._channels[topic]
            log_time = t0 + int(msg.sample_time_ns)
            ch.log(payload, log_time=log_time)
            self.stats.published += 1
            if isinstance(msg, PlantState):
                self._place(
                    log_time,
                    int(msg.sample_time_ns),
                    msg.rotor_speed_rad_s,
                    msg.platform_surge_m,
                    msg.platform_heave_m,
                    msg.platform_pitch_rad,
                )
        self._maybe_scene()

    # ------------------------------------------------------------------ end
    def close(self) -> LiveStats:
        """Publish what is queued, stop the server; returns the counts."""
        self._stop.set()
        self._wake.set()
        self._thread.join(5.0)
        # The sdk's stop waits for every client's socket to close, which a viewer that does
        # not read never does: it gets STOP_WAIT_S, then the process goes on (and ends with
        # os._exit, hil.cli.fowt, so the sdk's exit hook does not wait either).
        stopper = threading.Thread(target=self._server.stop, name="live-stop", daemon=True)
        stopper.start()
        stopper.join(STOP_WAIT_S)
        self.stats.stop_waited = stopper.is_alive()
        logging.getLogger(_OUTBOX_LOGGER).removeHandler(self._outbox)
        self.stats.outbox_full = self._outbox.count
        return self.stats
