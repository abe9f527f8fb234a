"""The recorder process: every ``fowt/<turbine>/**`` sample into one MCAP file per run.

The samples wait in the Zenoh subscriber's FIFO channel; every 20 ms the main thread takes
them, :meth:`Recorder.on_sample` decodes each (so a bad payload is counted, never logged as
data) and queues it, and the queue is written to :class:`hil.runlog.mcap_io.RunLog` (the CAN
tap, when there is one, queues from its own thread), flushing a chunk every
:data:`FLUSH_INTERVAL_S` (0.15 s), so the file stays readable up to its last flush if any
process, this one included, is killed. A message's MCAP publish time is when the main
thread took it (at most about 20 ms after it arrived).

No silent loss
--------------
The recording path is not lossy by design (docs/recording.md): the nodes publish with
congestion control ``BLOCK`` (:mod:`hil.nodes.bus`), and a full subscriber channel holds Zenoh's
receive back rather than dropping, so a recorder that falls behind (it runs niced, under
load) makes the publishers wait once its channel (:data:`_CHANNEL_CAPACITY` samples) and
the sockets' buffers are full: it paces a lock-step run instead of losing its messages.
The recorder does not stop on a fixed drain either: after the plant's final timing summary
it keeps taking samples until it holds the plant's :class:`~bus_schemas.messages.
PlantReport`, the controller's :class:`~bus_schemas.messages.ControllerReport` (unless the
controller is gone: its liveliness token ``fowt/<turbine>/alive/controller`` deleted) and,
per topic, as many messages as the reports count (:mod:`hil.runlog.completeness`). Only when no
sample has come for :data:`END_IDLE_S` does it stop short, and it logs the shortfall. A
plant whose liveliness token went (it exited, or was killed) while its final summary is not
in yet is taken as killed only once the recorder has taken everything waiting in its
channel and :data:`KILLED_IDLE_S` passed without a sample (a recorder behind the run is
still taking what the plant sent before it exited); the recording then ends once the
controller's report is in or the controller is gone. SIGINT/SIGTERM stop it
at once; it always finishes the file. A Zenoh session closed while its samples are still
on their way to a recorder that is behind loses them, so plant and controller keep theirs
open until the recorder declares the liveliness token ``fowt/<turbine>/alive/recorder/
has/<node>`` (:func:`hil.nodes.bus.wait_for_recorder`): it does once it holds that node's report
and every message the report counts (:meth:`Recorder.holds`).

What a SIGKILL of the recorder loses: the messages it took but had not flushed (it flushes
a chunk every :data:`FLUSH_INTERVAL_S` = 0.15 s of wall time, :class:`hil.runlog.mcap_io.RunLog`)
and the samples waiting in its subscriber channel (taken every 20 ms while it keeps up):
0.17 s of wall time plus how far it is behind the run, i.e. at most 0.25 s simulated in
real time (speed 1) while it keeps up. Measured beside two CPU hogs, recorder niced: at
most 0.27 s with the 0.25 s flush before, within the bound with 0.15 s
(bench/recorder_kill_loss.py; docs/recording.md). A lock-step run goes faster than real
time, so the same wall time is more simulated time there.

Log batches: the plant puts its truth and cycle timing, the controller its status, a few
per put on ``fowt/<turbine>/timing/batch`` and ``fowt/<turbine>/controller/batch``
(:class:`hil.nodes.bus.LogBatcher`); the recorder splits them and writes each message on its own
channel exactly as if it had been put alone (same channel, schema and payload; the MCAP
publish time is the batch's receive time). A batch that does not split is counted under
``rejected`` as ``<batch suffix>:<reason>``.

The live view (``fowt run --live``, ``--live-forward`` here): every message written is
also handed to :class:`hil.nodes.live_feed.LiveForward`, which puts each drain's messages as
one signed batch on ``fowt/<turbine>/recorder/live`` with congestion control ``DROP`` (a
live view that falls behind loses batches, counted on its side; the recording never waits
for it).

Authentication: in an authenticated run (the run's secret, ``--key-file``) every sample's
tag is checked before anything else (:mod:`bus_schemas.auth`); a sample that fails is
counted under ``rejected`` as ``<suffix>:auth`` and not written, so the command channel of
the file holds only the controller's genuine commands.

Its ``recorder`` metadata record holds ``messages`` (written), ``topics`` (JSON: messages
written per key suffix), ``samples`` (JSON: samples taken from the bus per key suffix, a
log batch counting once), ``expected`` (JSON: per key suffix, what the reports count),
``shortfall`` (JSON list: the topics short of it when the recorder stopped, and why),
``rejected`` and ``unknown_keys`` (JSON counts) and ``first_cycle_recorded``: the lowest
cycle number
(``seq``) of the plant's per-cycle messages (sensor frame, truth, cycle timing) in the file,
``"0"`` for a run recorded from its start, larger when the recorder joined late (a partial
run), ``"none"`` when no cycle was recorded; ``truth_decimated``: the truth messages a
``soak`` recording left out. The ``recording`` record (written first, with the scenario)
names the recording level (scenario ``[recording]``): at ``soak`` the truth of the cycles
whose ``seq`` is not a multiple of its ``truth_every`` N is taken and not written, as the
in-process writer does, and the reports' truth count is expected at 1 in N.

CAN runs
--------
With a CAN bus (:class:`hil.nodes.can_bus.CanBusConfig`; ``fowt record --transport can ...``,
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
import math
import queue
import threading
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec
import zenoh

from bus_schemas import (
    ActuatorCommand,
    ControllerStatus,
    CycleTiming,
    DecodeError,
    PlantState,
    SensorFrame,
    TimingSummary,
)
from bus_schemas.auth import sign, verify
from bus_schemas.messages import ControllerReport, PlantReport
from bus_schemas.registry import BY_SUFFIX, COMMAND, KEY_PREFIX, SENSORS, MessageType
from hil.nodes.bus import (
    BATCH_SUFFIXES,
    HELLO_SUFFIX,
    READY_SUFFIX,
    Bus,
    BusConfig,
    recorder_ack_key,
    sample_time_limit_ns,
    split_batch,
)
from hil.nodes.live_feed import LIVE_SUFFIX, LiveForward
from hil.nodes.signals import on_stop_signals
from hil.runlog.completeness import (
    CONTROLLER_TOPICS,
    PLANT_TOPICS,
    RECORDING_RECORD,
    expected_counts,
    recording_metadata,
    shortfall,
    truth_kept,
)
from hil.runlog.mcap_io import RunLog
from hil.scenario.schema import Scenario

if TYPE_CHECKING:
    import can

    from hil.nodes.can_bus import CanBus, CanBusConfig

#: How often the main thread writes what the Zenoh thread queued (s); << the 0.25 s flush.
_DRAIN_PERIOD_S = 0.02

#: Samples the subscriber's channel holds between two takes (a full channel holds Zenoh's
#: receive back, it never drops: at the fastest lock-step, 2-3 samples per 0.4 ms cycle,
#: that is several seconds of a stalled main thread).
_CHANNEL_CAPACITY = 1 << 16
#: Samples taken from the channel per pass at most (then they are written, so a recorder
#: catching up keeps flushing and looking at its stop event).
_TAKE_MAX = 4096
#: After the plant's final summary: wall seconds without a new sample after which the
#: recorder stops short of what the reports count (and logs the shortfall) [s].
END_IDLE_S = 10.0
#: After the controller went away without its report (or a recorder that joined late has
#: the reports): wall seconds without a new sample before the recorder stops [s].
GONE_IDLE_S = 0.5
#: After the plant went away without its final summary: wall seconds without a new sample
#: before the recorder takes it as killed [s]. Its liveliness token goes over the same
#: link, after everything it sent, so what it sent is in the channel by then; a recorder
#: behind the run takes it all first (taking is not idle).
KILLED_IDLE_S = 0.5

#: Wall seconds between two chunk flushes of the recorder's file (what a SIGKILL of the
#: recorder loses, module docstring): 0.15 + 0.02 (the take period) + the nodes' log batch
#: age and scheduling stay within 0.25 s.
FLUSH_INTERVAL_S = 0.15

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


#: The largest cycle number a run log's int64 rows hold (the codec's counters are uint64).
_INT64_MAX = 2**63 - 1


class RecorderLog(RunLog):
    """:class:`hil.runlog.mcap_io.RunLog` plus the raw CAN frame channel.

    Parameters
    ----------
    path : Path
        Output file.
    turbine : str
        Turbine id of the keys.
    can_raw : bool
        Register the ``fowt/<turbine>/can/raw`` channel (a CAN run).
    flush_interval_s : float
        Wall seconds between chunk flushes (:data:`FLUSH_INTERVAL_S`).
    """

    def __init__(
        self,
        path: Path,
        turbine: str,
        *,
        can_raw: bool = False,
        flush_interval_s: float = FLUSH_INTERVAL_S,
    ) -> None:
        super().__init__(path, turbine, flush_interval_s=flush_interval_s)
        self.can_raw_key = f"{KEY_PREFIX}/{turbine}/{CAN_RAW_SUFFIX}"
        self._can_raw_channel: int | None = None
        if can_raw:
            self._can_raw_channel = self.add_json_channel(
                self.can_raw_key, "fowt.CanRawFrame", CAN_RAW_SCHEMA
            )

    def write(self, key: str, msg: Any, receive_unix_ns: int | None = None) -> None:
        """Write one message; a :class:`CanRawFrame` goes to the raw CAN channel (JSON)."""
        if not isinstance(msg, CanRawFrame):
            super().write(key, msg, receive_unix_ns)
            return
        if self._can_raw_channel is None:
            raise KeyError(f"no channel registered for key {key!r}")
        self.write_json(
            self._can_raw_channel,
            msgspec.json.encode(msg),
            msg.sample_time_ns,
            receive_unix_ns if receive_unix_ns is not None else time.time_ns(),
        )


#: The plant's messages that carry the cycle number (``seq``) of every control cycle.
_PER_CYCLE = (SensorFrame, PlantState, CycleTiming)
#: Per-cycle messages and the field naming their cycle: the plant's own ``seq``, the
#: controller's ``answered_seq`` (its own ``seq`` starts again at 0 when a controller is
#: restarted during a run; the cycle it answers does not go back).
CYCLE_FIELD: dict[type, str] = {
    SensorFrame: "seq",
    PlantState: "seq",
    CycleTiming: "seq",
    ActuatorCommand: "answered_seq",
    ControllerStatus: "answered_seq",
}


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
    max_sample_time_ns : int or None
        The end of the run's time window [ns] (:func:`hil.nodes.bus.sample_time_limit_ns`):
        a message whose ``sample_time_ns`` lies past it is counted as ``<suffix>:time`` and
        not written. None: no limit (beyond what the run log can hold).
    truth_every : int
        A ``soak`` recording (scenario ``[recording]``): the truth of a cycle whose ``seq``
        is not a multiple of N is counted in ``decimated`` and not written (the in-process
        writer keeps the same cycles); the reports' truth count is expected at 1 in N.

    Notes
    -----
    Exact recordings: per per-cycle topic (:data:`CYCLE_FIELD`) the recorder writes each
    cycle once and in order. A message whose cycle is not newer than the newest written on
    its topic is a replay or a duplicate (a key holder re-putting a captured sample):
    counted as ``<suffix>:duplicate`` and not written, so the file never holds more
    messages than the nodes published (the nodes' own publishers put each cycle once and
    in order, one link per publisher).
    """

    def __init__(
        self,
        log: RunLog,
        auth_key: bytes | None = None,
        max_sample_time_ns: int | None = None,
        truth_every: int = 1,
    ) -> None:
        self.log = log
        self.auth_key = auth_key
        self.max_sample_time_ns = max_sample_time_ns
        self.truth_every = truth_every
        #: Truth messages taken and not written (a soak recording's decimation).
        self.decimated = 0
        #: Per per-cycle topic, the newest cycle queued for writing.
        self.newest_cycle: dict[str, int] = {}
        #: Puts a controller's hello nonce back on ``recorder/ready`` (None: no answer).
        self.answer_hello: Callable[[bytes], None] | None = None
        #: The live view's feed (``fowt run --live``): every message written is handed to it.
        self.live: LiveForward | None = None
        self.queue: queue.SimpleQueue[tuple[str, Any, int]] = queue.SimpleQueue()
        self.rejected: Counter[str] = Counter()
        self.unknown_keys: Counter[str] = Counter()
        self.final_seen = threading.Event()
        self.prefix = f"{KEY_PREFIX}/{log.turbine}/"
        #: Messages written per key suffix.
        self.counts: Counter[str] = Counter()
        #: Samples taken from the bus per key suffix (a log batch is one sample).
        self.samples: Counter[str] = Counter()
        #: The plant's report (its fields) once written, and every controller report.
        self.plant_report: dict[str, Any] | None = None
        self.controller_reports: list[dict[str, Any]] = []
        #: Lowest cycle (``seq``) of the plant's per-cycle messages written (sensor frame,
        #: truth, cycle timing); None until one is. A recorder that joined late sees a
        #: first cycle > 0: the run is partial (metadata ``first_cycle_recorded``).
        self.first_cycle: int | None = None

    def on_sample(self, key: str, payload: bytes) -> None:
        """Decode one sample and queue it for writing.

        A log batch (:data:`hil.nodes.bus.BATCH_SUFFIXES`) is split and each of its messages
        decoded and queued under its own key, as if it had been put there on its own (its
        receive time is the batch's); a batch that does not split is rejected whole
        (``<batch suffix>:<reason>``), a message in it that does not decode alone.
        """
        suffix = key.removeprefix(self.prefix)
        if suffix in (HELLO_SUFFIX, READY_SUFFIX):  # the readiness handshake, not run data
            self._on_hello(key, suffix, payload)
            return
        if suffix == LIVE_SUFFIX:  # the live view's feed (its own puts), not run data
            return
        self.samples[suffix] += 1
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

    def _on_hello(self, key: str, suffix: str, payload: bytes) -> None:
        """Answer a controller's hello (:func:`hil.nodes.bus.await_recorder`) with its nonce.

        Its own answers come back through its subscription and are skipped; a hello whose
        tag does not verify is counted as ``controller/hello:auth`` and not answered.
        """
        if suffix != HELLO_SUFFIX or self.answer_hello is None:
            return
        if self.auth_key is not None:
            try:
                payload = verify(self.auth_key, key, payload)
            except DecodeError as exc:
                self.rejected[f"{suffix}:{exc.reason}"] += 1
                return
        self.answer_hello(payload)

    def _queue(
        self, key: str, suffix: str, mt: MessageType, payload: bytes | memoryview, recv: int
    ) -> None:
        try:
            msg = mt.codec.decode(payload)
        except DecodeError as exc:
            self.rejected[f"{suffix}:{exc.reason}"] += 1
            return
        limit = self.max_sample_time_ns
        if limit is not None and getattr(msg, "sample_time_ns", 0) > limit:
            self.rejected[f"{suffix}:time"] += 1  # outside the run's window: never written
            return
        field = CYCLE_FIELD.get(type(msg))
        if field is not None:
            cycle = getattr(msg, field)
            if cycle > _INT64_MAX:
                # no row of the log holds it: refused here, before it could move the
                # duplicate filter past every later cycle of its topic
                self.rejected[f"{suffix}:range"] += 1
                return
            if cycle <= self.newest_cycle.get(suffix, -1):
                self.rejected[f"{suffix}:duplicate"] += 1
                return
            self.newest_cycle[suffix] = cycle
            if (
                self.truth_every > 1
                and isinstance(msg, PlantState)
                and not truth_kept(cycle, self.truth_every)
            ):
                self.decimated += 1
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
        counts = self.counts
        prefix = self.prefix
        live = self.live
        while True:
            key, msg, recv = item
            try:
                self.log.write(key, msg, recv)
            except ValueError:  # a sequence number past int64: counted, not written
                self.rejected[f"{key.removeprefix(prefix)}:range"] += 1
                msg = None
            if msg is not None:
                suffix = key.removeprefix(prefix)
                counts[suffix] += 1
                if live is not None and (mt := BY_SUFFIX.get(suffix)) is not None:
                    live.add(mt, msg)
                if isinstance(msg, PlantReport):
                    self.plant_report = msgspec.structs.asdict(msg)
                elif isinstance(msg, ControllerReport):
                    self.controller_reports.append(msgspec.structs.asdict(msg))
                if isinstance(msg, _PER_CYCLE) and (
                    self.first_cycle is None or msg.seq < self.first_cycle
                ):
                    self.first_cycle = int(msg.seq)
                n += 1
            try:
                item = self.queue.get_nowait()
            except queue.Empty:
                if live is not None:
                    live.flush()
                return n

    def expected(self) -> dict[str, int]:
        """Messages per key suffix the reports written so far count
        (:mod:`hil.runlog.completeness`)."""
        return expected_counts(self.plant_report, self.controller_reports, self.truth_every)

    def holds(self, node: str) -> bool:
        """True once the report of ``node`` (``plant``, ``controller``) is in and, per topic
        it counts, as many messages as it says."""
        if node == "plant":
            if self.plant_report is None:
                return False
            topics = PLANT_TOPICS
        else:
            if not self.controller_reports:
                return False
            topics = CONTROLLER_TOPICS
        expected = self.expected()
        return all(self.counts[t] >= expected.get(t, 0) for t in topics)

    def missing(self, controller_gone: bool) -> list[str]:
        """What the recording still lacks after the plant's final summary (empty: done).

        The plant's report, the controller's (unless ``controller_gone``: its liveliness
        token was deleted) and, per topic, the messages the reports count.
        """
        out = [] if self.plant_report is not None else ["the plant's report"]
        if not self.controller_reports and not controller_gone:
            out.append("the controller's report")
        return out + shortfall(self.counts, self.expected())


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
    log: Callable[[str], None] = print,
    can: CanBusConfig | None = None,
    end_idle_s: float = END_IDLE_S,
    live_forward: bool = False,
) -> int:
    """Record until the run's messages are all in (module docstring, "No silent loss").

    After the plant's final summary the recorder takes samples until it holds the plant's
    and the controller's reports (the latter unless the controller is gone) and what they
    count, or until ``end_idle_s`` [s] pass without a sample (the shortfall is logged and
    kept in the ``recorder`` metadata). A signal stops it at once. With ``can`` the
    recorder also listens on that CAN bus (module docstring, "CAN runs"). Returns the
    number of messages written.
    """
    # Signals first: a stop that arrives while the log is being opened still ends with a
    # complete (possibly empty) MCAP file instead of the default SIGTERM death.
    stop = threading.Event()

    on_stop_signals(lambda _signum: stop.set())  # from a thread (hil.nodes.signals)
    can_bus: CanBus | None = None
    if can is not None:  # imported here: a Zenoh-only recorder does not load python-can
        from hil.nodes.can_bus import CanBus  # noqa: PLC0415

        can_bus = CanBus(
            can, auth_key=bus_config.auth_key
        )  # first: a bus that cannot open leaves no half-written file
    run_log = RecorderLog(out, scenario.turbine_id, can_raw=can is not None)
    run_log.add_metadata("scenario", scenario_metadata(scenario, scenario_toml))
    run_log.add_metadata(RECORDING_RECORD, scenario_recording_metadata(scenario))
    if run_info:
        run_log.add_metadata("run", run_info)
    recorder = Recorder(
        run_log,
        bus_config.auth_key,
        sample_time_limit_ns(scenario.duration_s),
        truth_every=scenario_truth_every(scenario),
    )
    tap = CanTap(recorder, can_bus) if can_bus is not None else None
    bus = Bus(bus_config)
    ready_key = f"{KEY_PREFIX}/{scenario.turbine_id}/{READY_SUFFIX}"
    recorder.answer_hello = lambda nonce: bus.put(ready_key, nonce)
    if live_forward:
        recorder.live = _live_forward(bus, scenario.turbine_id)
    written = 0
    # The samples wait in the subscriber's FIFO channel and the main thread takes them every
    # 20 ms: no Python thread wakes per sample (a callback subscriber hands each one to a
    # thread of zenoh-python's, which takes the GIL: two wake-ups per sample, two samples
    # per cycle, competing with plant and controller for the two cores).
    sub: Any = None

    def take(limit: float = _TAKE_MAX) -> int:
        n = 0
        if sub is None:
            return n
        while n < limit and (sample := sub.try_recv()) is not None:
            recorder.on_sample(str(sample.key_expr), sample.payload.to_bytes())
            n += 1
        return n

    missing: list[str] = []

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
        # The controller's token: alive while it is there (a restarted controller declares
        # it again); once it is deleted no report of it is waited for.
        controller_alive = threading.Event()

        def on_controller_liveliness(sample: zenoh.Sample) -> None:
            if sample.kind == zenoh.SampleKind.DELETE:
                controller_alive.clear()
            else:
                controller_alive.set()

        controller_watch = bus.session.liveliness().declare_subscriber(
            f"fowt/{scenario.turbine_id}/alive/controller", on_controller_liveliness, history=True
        )
        log(f"recorder writing {out}")
        while not stop.is_set() and not recorder.final_seen.is_set() and not plant_gone.is_set():
            # Drain in batches every 20 ms rather than waking per message: a wake-up per
            # sample costs a thread switch and a GIL hand-over with Zenoh's thread, which
            # took the CPU the plant and controller need (recorder CPU -20 % in lock-step).
            # A full take (catching up) goes on at once.
            took = take()
            written += recorder.drain(0.0)
            if took < _TAKE_MAX:
                time.sleep(_DRAIN_PERIOD_S)
        acks: dict[str, Any] = {}  # kept referenced: a dropped token is undeclared

        def acknowledge() -> None:
            # The plant and the controller keep their sessions open until the recorder says
            # it holds what they published (hil.nodes.bus.wait_for_recorder).
            for node in ("plant", "controller"):
                if node not in acks and recorder.holds(node):
                    key = recorder_ack_key(scenario.turbine_id, node)
                    acks[node] = bus.session.liveliness().declare_token(key)

        missing = _record_to_the_end(
            recorder, take, stop, controller_alive, plant_gone, end_idle_s, log, acknowledge
        )
        for ack in acks.values():
            ack.undeclare()
        written += recorder.drain(0.0)
        controller_watch.undeclare()
        plant_watch.undeclare()
        token.undeclare()
    finally:
        with contextlib.suppress(Exception):  # a session failing at its start: nothing to take
            take(math.inf)
            sub.undeclare()
        if recorder.live is not None:  # the live view gets the last messages while it can
            written += recorder.drain(0.0)
            recorder.live = None
        bus.close()
        meta = {
            "messages": str(run_log.count),
            "shortfall": json.dumps(missing),
            "rejected": json.dumps(dict(recorder.rejected)),
            # --insecure: payloads neither signed nor checked, the session open to anyone
            "authenticated": "false" if bus_config.auth_key is None else "true",
            "session_authenticated": str(bus_config.session_auth).lower(),
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
        meta["topics"] = json.dumps(dict(sorted(recorder.counts.items())))
        meta["samples"] = json.dumps(dict(sorted(recorder.samples.items())))
        meta["expected"] = json.dumps(recorder.expected())
        meta["truth_decimated"] = str(recorder.decimated)
        meta["first_cycle_recorded"] = (
            "none" if recorder.first_cycle is None else str(recorder.first_cycle)
        )
        run_log.add_metadata("recorder", meta)
        run_log.close()
    log(f"recorder closed {out}: {run_log.count} messages, rejected {dict(recorder.rejected)}")
    if can_bus is not None and tap is not None:
        log(f"recorder CAN: {tap.frames} frames, rejected {dict(can_bus.rejected)}")
    return written


def _live_forward(bus: Bus, turbine: str) -> LiveForward:
    """The live view's feed (:mod:`hil.nodes.live_feed`): signed puts with ``DROP`` congestion
    control, to other sessions only, so a live view that does not keep up never holds the
    recorder back."""
    key = f"{KEY_PREFIX}/{turbine}/{LIVE_SUFFIX}"
    pub = bus.session.declare_publisher(
        key,
        congestion_control=zenoh.CongestionControl.DROP,
        allowed_destination=zenoh.Locality.REMOTE,
    )
    secret = bus.config.auth_key
    if secret is None:
        return LiveForward(pub.put)
    return LiveForward(lambda payload: pub.put(sign(secret, key, payload)))


def _record_to_the_end(
    recorder: Recorder,
    take: Callable[[], int],
    stop: threading.Event,
    controller_alive: threading.Event,
    plant_gone: threading.Event,
    end_idle_s: float,
    log: Callable[[str], None],
    acknowledge: Callable[[], None] = lambda: None,
) -> list[str]:
    """Take and write samples after the plant's end until the recording is complete.

    ``acknowledge`` is called after each take (it tells the nodes what the recorder holds).

    Complete (module docstring, "No silent loss"): the final summary, the reports and the
    counts they give are all in. The plant's liveliness token may go before the recorder
    (behind, niced) has taken its last samples: a plant gone counts as killed only while
    no final summary has come after :data:`KILLED_IDLE_S` without a sample, and then once
    the controller's report is in or the controller is gone too. Stops early on ``stop``
    (a signal), or once no sample came for ``end_idle_s``. Returns what was still missing
    (empty when complete) and logs it.
    """
    if not recorder.final_seen.is_set() and not plant_gone.is_set():
        return ["stopped by a signal before the run's end"]
    last_sample = time.monotonic()
    missing: list[str] = []
    while True:
        if stop.is_set():
            return ["stopped by a signal before the recording was complete", *missing]
        took = take()
        recorder.drain(0.0)
        acknowledge()
        now = time.monotonic()
        if took:
            last_sample = now
        idle = now - last_sample
        gone = not controller_alive.is_set()
        if recorder.final_seen.is_set():
            missing = recorder.missing(controller_gone=gone)
            # A controller gone without a report: its report may still be on its way.
            settled = recorder.controller_reports or not gone or idle >= GONE_IDLE_S
            if not missing and settled:
                return []
        elif idle >= KILLED_IDLE_S:  # the plant was killed: nothing more comes from it
            missing = ["the plant's final summary and report (the plant went away)"]
            if recorder.controller_reports or gone:
                log("recorder: the plant went away without its final summary (killed?)")
                return missing
        # A recorder that joined the run late (its first cycle > 0) cannot catch up on what
        # went before: it stops once nothing more comes, without the long wait.
        late = recorder.first_cycle is not None and recorder.first_cycle > 0
        reports_in = recorder.plant_report is not None and (recorder.controller_reports or gone)
        limit = GONE_IDLE_S if late and reports_in else end_idle_s
        if idle >= limit:
            log(
                f"recorder: INCOMPLETE, no sample for {limit:g} s and still missing: "
                + "; ".join(missing or ["the plant's final summary"])
                + (f" (it joined the run at cycle {recorder.first_cycle})" if late else "")
            )
            return missing or ["the plant's final summary"]
        if took < _TAKE_MAX:
            time.sleep(_DRAIN_PERIOD_S)


def scenario_truth_every(scenario: Scenario) -> int:
    """N of the scenario's recording level: one truth message in N is recorded."""
    return scenario.recording.truth_every(scenario.timing.control_period_s)


def scenario_recording_metadata(scenario: Scenario) -> dict[str, str]:
    """The ``recording`` metadata record (level, N, truth period) of a scenario's runs."""
    rec = scenario.recording
    return recording_metadata(rec.level, scenario_truth_every(scenario), rec.truth_period_s)


def scenario_metadata(scenario: Scenario, toml_text: str) -> dict[str, str]:
    """The ``scenario`` metadata record written into every run's MCAP file."""
    return {
        "name": scenario.name,
        "json": json.dumps(scenario.to_toml_dict()),
        "toml": toml_text,
    }
