"""The recorder process: every ``fowt/<turbine>/**`` sample into one MCAP file per run.

The samples wait in the Zenoh subscriber's FIFO channel; every 20 ms the main thread takes
them, :meth:`Recorder.on_sample` decodes each (so a bad payload is counted, never logged as
data) and queues it, and the queue is written to :class:`hil.mcap_log.RunLog` (the CAN
tap, when there is one, queues from its own thread), flushing a chunk at least every
0.25 s, so the file stays readable up to its last flush if any process, this one
included, is killed. A message's MCAP publish time is when the main thread took it (at
most about 20 ms after it arrived). The
recorder stops after the plant's final timing summary (plus a short drain) or on
SIGINT/SIGTERM, and always finishes the file.

Log batches: the plant puts its truth and cycle timing, the controller its status, a few
per put on ``fowt/<turbine>/timing/batch`` and ``fowt/<turbine>/controller/batch``
(:class:`hil.bus.LogBatcher`); the recorder splits them and writes each message on its own
channel exactly as if it had been put alone (same channel, schema and JSON; the MCAP
publish time is the batch's receive time). A batch that does not split is counted under
``rejected`` as ``<batch suffix>:<reason>``.

Authentication: in an authenticated run (the run's secret, ``--key-file``) every sample's
tag is checked before anything else (:mod:`bus_schemas.auth`); a sample that fails is
counted under ``rejected`` as ``<suffix>:auth`` and not written, so the command channel of
the file holds only the controller's genuine commands.

Its ``recorder`` metadata record holds ``messages`` (written), ``rejected`` and
``unknown_keys`` (JSON counts) and ``first_cycle_recorded``: the lowest cycle number
(``seq``) of the plant's per-cycle messages (sensor frame, truth, cycle timing) in the file,
``"0"`` for a run recorded from its start, larger when the recorder joined late (a partial
run), ``"none"`` when no cycle was recorded.

CAN runs
--------
With a CAN bus (:class:`hil.can_bus.CanBusConfig`; ``fowt record --transport can ...``,
in the plant's and controller's network namespace) the recorder also joins the CAN bus, as
a listen-only node: the sensor frames and commands, which do not travel on Zenoh in such a
run, are reassembled and decoded there and written to their usual channels, and every raw
frame goes to the channel ``fowt/<turbine>/can/raw`` (:data:`CAN_RAW_SUFFIX`; JSON Schema
:data:`CAN_RAW_SCHEMA`), one MCAP message per frame: the bus's receive timestamp,
``arbitration_id``, ``is_extended_id``, ``is_fd``, ``dlc`` (the data length in bytes) and
``data`` (hex). Its ``sample_time_ns`` (the MCAP log time) is the sample time of the
message instance the frame belongs to, known once the instance completes: frames are held
per message type until then (a frame of an unknown id, or of an instance that never
completes, gets the latest sample time seen). ``fowt review`` counts them under
``run.messages["can/raw"]``; the recorder's metadata record adds the CAN frame count and
the reassembler's rejections.
"""

from __future__ import annotations

import contextlib
import json
import queue
import signal
import threading
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec
import zenoh

from bus_schemas import CycleTiming, DecodeError, PlantState, SensorFrame, TimingSummary
from bus_schemas.auth import verify
from bus_schemas.registry import BY_SUFFIX, COMMAND, KEY_PREFIX, SENSORS, MessageType
from hil.bus import BATCH_SUFFIXES, Bus, BusConfig, split_batch
from hil.mcap_log import RunLog
from hil.scenario import Scenario

if TYPE_CHECKING:
    import can

    from hil.can_bus import CanBus, CanBusConfig

#: How often the main thread writes what the Zenoh thread queued (s); << the 0.25 s flush.
_DRAIN_PERIOD_S = 0.02

#: Samples the subscriber's channel holds between two takes (a full channel holds Zenoh's
#: receive back, it never drops: at the fastest lock-step, 2-3 samples per 0.4 ms cycle,
#: that is several seconds of a stalled main thread).
_CHANNEL_CAPACITY = 1 << 16

#: Key suffix of the raw CAN frame channel.
CAN_RAW_SUFFIX = "can/raw"

#: JSON Schema of one raw CAN frame record (:class:`CanRawFrame`).
CAN_RAW_SCHEMA: dict[str, Any] = {
    "title": "fowt.CanRawFrame",
    "description": "One CAN frame as received by the recorder (classic or CAN FD).",
    "type": "object",
    "properties": {
        "sample_time_ns": {
            "type": "integer",
            "description": "Sample time of the message instance the frame belongs to [ns]",
        },
        "timestamp_ns": {
            "type": "integer",
            "description": "Receive time on the bus interface, Unix epoch [ns]",
        },
        "arbitration_id": {"type": "integer", "minimum": 0, "maximum": 0x1FFFFFFF},
        "is_extended_id": {"type": "boolean"},
        "is_fd": {"type": "boolean"},
        "dlc": {"type": "integer", "minimum": 0, "maximum": 64, "description": "Data bytes"},
        "data": {"type": "string", "description": "Data bytes as hex"},
    },
    "required": [
        "sample_time_ns",
        "timestamp_ns",
        "arbitration_id",
        "is_extended_id",
        "is_fd",
        "dlc",
        "data",
    ],
}


class CanRawFrame(msgspec.Struct, frozen=True):
    """One raw CAN frame record (channel ``fowt/<turbine>/can/raw``)."""

    sample_time_ns: int
    timestamp_ns: int
    arbitration_id: int
    is_extended_id: bool
    is_fd: bool
    dlc: int
    data: str


class RecorderLog(RunLog):
    """:class:`hil.mcap_log.RunLog` plus the raw CAN frame channel.

    Parameters
    ----------
    path : Path
        Output file.
    turbine : str
        Turbine id of the keys.
    can_raw : bool
        Register the ``fowt/<turbine>/can/raw`` channel (a CAN run).
    """

    def __init__(self, path: Path, turbine: str, *, can_raw: bool = False) -> None:
        super().__init__(path, turbine)
        self.can_raw_key = f"{KEY_PREFIX}/{turbine}/{CAN_RAW_SUFFIX}"
        self._can_raw_channel: int | None = None
        self._can_raw_seq = 0
        if can_raw:
            schema_id = self._writer.register_schema(
                name="fowt.CanRawFrame",
                encoding="jsonschema",
                data=json.dumps(CAN_RAW_SCHEMA).encode(),
            )
            self._can_raw_channel = self._writer.register_channel(
                topic=self.can_raw_key, message_encoding="json", schema_id=schema_id
            )

    def write(self, key: str, msg: Any, receive_unix_ns: int | None = None) -> None:
        """Write one message; a :class:`CanRawFrame` goes to the raw CAN channel."""
        if not isinstance(msg, CanRawFrame):
            super().write(key, msg, receive_unix_ns)
            return
        if self._can_raw_channel is None:
            raise KeyError(f"no channel registered for key {key!r}")
        self._writer.add_message(
            channel_id=self._can_raw_channel,
            log_time=self.start_unix_ns + msg.sample_time_ns,
            data=msgspec.json.encode(msg),
            publish_time=receive_unix_ns if receive_unix_ns is not None else time.time_ns(),
            sequence=self._can_raw_seq,
        )
        self._can_raw_seq += 1
        self.count += 1
        self.maybe_flush()


#: The plant's messages that carry the cycle number (``seq``) of every control cycle.
_PER_CYCLE = (SensorFrame, PlantState, CycleTiming)


class Recorder:
    """Decode-and-queue sink for bus samples, drained into a :class:`RunLog`.

    Parameters
    ----------
    log : RunLog
        Where the messages go.
    auth_key : bytes or None
        The run's secret: every sample's tag is checked before it is decoded
        (:func:`bus_schemas.auth.verify`), a failure counted as ``<suffix>:auth`` and
        nothing of it written. None: unauthenticated run.
    """

    def __init__(self, log: RunLog, auth_key: bytes | None = None) -> None:
        self.log = log
        self.auth_key = auth_key
        self.queue: queue.SimpleQueue[tuple[str, Any, int]] = queue.SimpleQueue()
        self.rejected: Counter[str] = Counter()
        self.unknown_keys: Counter[str] = Counter()
        self.final_seen = threading.Event()
        self.prefix = f"{KEY_PREFIX}/{log.turbine}/"
        #: Lowest cycle (``seq``) of the plant's per-cycle messages written (sensor frame,
        #: truth, cycle timing); None until one is. A recorder that joined late sees a
        #: first cycle > 0: the run is partial (metadata ``first_cycle_recorded``).
        self.first_cycle: int | None = None

    def on_sample(self, key: str, payload: bytes) -> None:
        """Decode one sample and queue it for writing.

        A log batch (:data:`hil.bus.BATCH_SUFFIXES`) is split and each of its messages
        decoded and queued under its own key, as if it had been put there on its own (its
        receive time is the batch's); a batch that does not split is rejected whole
        (``<batch suffix>:<reason>``), a message in it that does not decode alone.
        """
        suffix = key.removeprefix(self.prefix)
        batch = suffix in BATCH_SUFFIXES
        mt = None if batch else BY_SUFFIX.get(suffix)
        if mt is None and not batch:
            if "/alive/" not in key:
                self.unknown_keys[key] += 1
            return
        if self.auth_key is not None:
            try:
                payload = verify(self.auth_key, key, payload)
            except DecodeError as exc:  # forged or unsigned: counted, never written
                self.rejected[f"{suffix}:{exc.reason}"] += 1
                return
        if mt is None:
            self._on_batch(suffix, payload)
            return
        self._queue(key, suffix, mt, payload, time.time_ns())

    def _queue(
        self, key: str, suffix: str, mt: MessageType, payload: bytes | memoryview, recv: int
    ) -> None:
        try:
            msg = mt.codec.decode(payload)
        except DecodeError as exc:
            self.rejected[f"{suffix}:{exc.reason}"] += 1
            return
        self.queue.put((key, msg, recv))
        if isinstance(msg, TimingSummary) and msg.final:
            self.final_seen.set()

    def _on_batch(self, batch_suffix: str, payload: bytes) -> None:
        recv = time.time_ns()
        try:
            parts = split_batch(payload)
        except DecodeError as exc:
            self.rejected[f"{batch_suffix}:{exc.reason}"] += 1
            return
        for mt, part in parts:
            self._queue(self.prefix + mt.key_suffix, mt.key_suffix, mt, part, recv)

    def drain(self, timeout_s: float = 0.05) -> int:
        """Write queued messages; wait up to ``timeout_s`` for the first. Returns the count."""
        n = 0
        try:
            item = self.queue.get(timeout=timeout_s)
        except queue.Empty:
            self.log.maybe_flush()
            return 0
        while True:
            key, msg, recv = item
            self.log.write(key, msg, recv)
            if isinstance(msg, _PER_CYCLE) and (
                self.first_cycle is None or msg.seq < self.first_cycle
            ):
                self.first_cycle = int(msg.seq)
            n += 1
            try:
                item = self.queue.get_nowait()
            except queue.Empty:
                return n


class CanTap:
    """The recorder's CAN side: decoded sensor frames and commands, and every raw frame.

    Runs in the CAN bus's receive thread and queues into the :class:`Recorder`'s queue
    (module docstring, "CAN runs"). Raw frames are held per message type until the instance
    they belong to completes, then queued with its sample time, ahead of the decoded message.

    Parameters
    ----------
    recorder : Recorder
        Whose queue the records go to.
    bus : CanBus
        The recorder's CAN bus (subscribes to the sensor frame and the command on it).
    """

    def __init__(self, recorder: Recorder, bus: CanBus) -> None:
        self.recorder = recorder
        self.bus = bus
        tid = recorder.log.turbine
        self.raw_key = f"{KEY_PREFIX}/{tid}/{CAN_RAW_SUFFIX}"
        self.frames = 0
        self.last_sample_ns = 0
        self._held: dict[type[msgspec.Struct], list[CanRawFrame]] = {}
        for mt in (SENSORS, COMMAND):
            bus.subscribe_message(mt, self._message_handler(mt))
        bus.add_frame_listener(self.on_frame)

    def on_frame(self, frame: can.Message) -> None:
        """Hold (or, for an unknown id, queue) one raw frame."""
        self.frames += 1
        record = CanRawFrame(
            sample_time_ns=self.last_sample_ns,
            timestamp_ns=round(frame.timestamp * 1e9),
            arbitration_id=frame.arbitration_id,
            is_extended_id=frame.is_extended_id,
            is_fd=frame.is_fd,
            dlc=len(frame.data),
            data=bytes(frame.data).hex(),
        )
        mt = self.bus.reassembler.message_type_of(frame.arbitration_id)
        if mt is None:
            self.recorder.queue.put((self.raw_key, record, time.time_ns()))
            return
        self._held.setdefault(mt.cls, []).append(record)

    def _message_handler(self, mt: MessageType) -> Callable[[Any], None]:
        key = mt.key(self.recorder.log.turbine)

        def on_message(msg: Any) -> None:
            now = time.time_ns()
            self.last_sample_ns = int(msg.sample_time_ns)
            self._release(mt.cls, self.last_sample_ns, now)
            self.recorder.queue.put((key, msg, now))

        return on_message

    def _release(self, cls: type[msgspec.Struct], sample_ns: int, now: int) -> None:
        held = self._held.pop(cls, [])
        for record in held:
            stamped = msgspec.structs.replace(record, sample_time_ns=sample_ns)
            self.recorder.queue.put((self.raw_key, stamped, now))

    def flush(self) -> None:
        """Queue the frames still held (instances that never completed)."""
        now = time.time_ns()
        for cls in list(self._held):
            self._release(cls, self.last_sample_ns, now)


def run_recorder_node(
    scenario: Scenario,
    bus_config: BusConfig,
    out: Path,
    run_info: dict[str, str] | None = None,
    scenario_toml: str = "",
    drain_s: float = 0.3,
    log: Callable[[str], None] = print,
    can: CanBusConfig | None = None,
) -> int:
    """Record until the plant's final summary (plus ``drain_s``) or a signal.

    With ``can`` the recorder also listens on that CAN bus (module docstring, "CAN runs").
    Returns the number of messages written.
    """
    # Signals first: a stop that arrives while the log is being opened still ends with a
    # complete (possibly empty) MCAP file instead of the default SIGTERM death.
    stop = threading.Event()

    def on_signal(signum: int, _frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    can_bus: CanBus | None = None
    if can is not None:  # imported here: a Zenoh-only recorder does not load python-can
        from hil.can_bus import CanBus  # noqa: PLC0415

        can_bus = CanBus(
            can, auth_key=bus_config.auth_key
        )  # first: a bus that cannot open leaves no half-written file
    run_log = RecorderLog(out, scenario.turbine_id, can_raw=can is not None)
    run_log.add_metadata("scenario", scenario_metadata(scenario, scenario_toml))
    if run_info:
        run_log.add_metadata("run", run_info)
    recorder = Recorder(run_log, bus_config.auth_key)
    tap = CanTap(recorder, can_bus) if can_bus is not None else None
    bus = Bus(bus_config)
    written = 0
    # The samples wait in the subscriber's FIFO channel and the main thread takes them every
    # 20 ms: no Python thread wakes per sample (a callback subscriber hands each one to a
    # thread of zenoh-python's, which takes the GIL: two wake-ups per sample, two samples
    # per cycle, competing with plant and controller for the two cores).
    sub: Any = None

    def take() -> None:
        if sub is None:
            return
        while (sample := sub.try_recv()) is not None:
            recorder.on_sample(str(sample.key_expr), sample.payload.to_bytes())

    try:
        sub = bus.session.declare_subscriber(
            f"{KEY_PREFIX}/{scenario.turbine_id}/**",
            zenoh.handlers.FifoChannel(_CHANNEL_CAPACITY),
        )
        token = bus.session.liveliness().declare_token(f"fowt/{scenario.turbine_id}/alive/recorder")
        plant_gone = threading.Event()

        def on_plant_liveliness(sample: zenoh.Sample) -> None:
            # The plant's token goes when it exits or is killed; a killed plant sends no
            # final summary, and without this the recorder would wait for ever. What the
            # plant sent before dying is still drained and written below.
            if sample.kind == zenoh.SampleKind.DELETE:
                plant_gone.set()

        plant_watch = bus.session.liveliness().declare_subscriber(
            f"fowt/{scenario.turbine_id}/alive/plant", on_plant_liveliness
        )
        log(f"recorder writing {out}")
        while not stop.is_set() and not recorder.final_seen.is_set() and not plant_gone.is_set():
            # Drain in batches every 20 ms rather than waking per message: a wake-up per
            # sample costs a thread switch and a GIL hand-over with Zenoh's thread, which
            # took the CPU the plant and controller need (recorder CPU -20 % in lock-step).
            time.sleep(_DRAIN_PERIOD_S)
            take()
            written += recorder.drain(0.0)
        end = time.monotonic() + drain_s
        while time.monotonic() < end:
            take()
            written += recorder.drain(0.02)
        take()
        if plant_gone.is_set() and not recorder.final_seen.is_set():
            log("recorder: the plant went away without its final summary (killed?)")
        plant_watch.undeclare()
        token.undeclare()
    finally:
        with contextlib.suppress(Exception):  # a session failing at its start: nothing to take
            take()
            sub.undeclare()
        bus.close()
        meta = {
            "messages": str(run_log.count),
            "rejected": json.dumps(dict(recorder.rejected)),
            "unknown_keys": json.dumps(dict(recorder.unknown_keys)),
        }
        if can_bus is not None and tap is not None:
            can_bus.close()
            tap.flush()
            cfg = can_bus.config
            meta.update(
                can_interface=cfg.interface,
                can_channel=cfg.effective_channel,
                can_fd=str(int(cfg.fd)),
                can_frames=str(tap.frames),
                can_rejected=json.dumps(dict(can_bus.rejected)),
            )
        written += recorder.drain(0.0)
        meta["messages"] = str(run_log.count)
        meta["first_cycle_recorded"] = (
            "none" if recorder.first_cycle is None else str(recorder.first_cycle)
        )
        run_log.add_metadata("recorder", meta)
        run_log.close()
    log(f"recorder closed {out}: {run_log.count} messages, rejected {dict(recorder.rejected)}")
    if can_bus is not None and tap is not None:
        log(f"recorder CAN: {tap.frames} frames, rejected {dict(can_bus.rejected)}")
    return written


def scenario_metadata(scenario: Scenario, toml_text: str) -> dict[str, str]:
    """The ``scenario`` metadata record written into every run's MCAP file."""
    return {
        "name": scenario.name,
        "json": json.dumps(scenario.to_toml_dict()),
        "toml": toml_text,
    }
