"""Fuzzer node: malformed payloads on the controller's and the plant's input keys.

The fuzzer is a process of its own with a real Zenoh session connected to the plant and the
controller (explicit loopback endpoints, like every node). While a run goes, it puts
payloads that must be rejected on the controller's input key ``fowt/<turbine>/sensors`` and
on the plant's input key ``fowt/<turbine>/command``, and reports how many of each kind it
sent and which rejection reason each must be counted under.

Kinds of payload (:data:`KINDS`), one after the other in a seeded order:

``random``
    random bytes of a random length (0 to twice the message size);
``truncated``, ``padded``
    a valid payload captured from the run, cut short, or with random bytes appended;
``header``
    a valid payload with a wrong magic byte or message id;
``cross_type``
    a valid payload of the *other* input message (a command on the sensors key, a sensor
    frame on the command key);
``version``
    a valid payload with another schema version;
``non_finite``
    a valid payload with NaN, +inf, -inf or a NaN with payload bits in one float field
    (every float field in turn);
``range``
    a valid payload with one field outside its declared physical range (floats beyond
    their bounds, times negative);
``replay``
    a valid payload captured from the run, re-sent with its old sequence number;
``reorder``
    a burst of 2 to 8 old captured payloads in shuffled order;
``forged``
    (authenticated runs only) a valid payload captured from the run with a wrong tag (16
    random bytes where the run's secret would put its MAC): counted as ``auth``.

In an authenticated run (``--key-file``, the run's secret, :mod:`bus_schemas.auth`) the
fuzzer signs every payload but the ``forged`` ones, so the malformed payloads pass the tag
check and still exercise the codec's reasons.

Every payload but the replayed ones is decoded by the same codec the nodes use before it
is sent: a payload the codec would accept is never sent, and the codec's reason
(``length``, ``header``, ``version``, ``non_finite``, ``range``) is the expected counter.
Replayed and reordered payloads are valid frames whose sequence number (``seq`` of a sensor
frame, ``answered_seq`` of a command) is at least one behind the newest the fuzzer has seen
on that key; the node has then already consumed that sequence number (in lock-step, the
plant publishes frame k only after the command answering k - 1, which the controller
published only after frame k - 1), so each must be counted as ``duplicate_or_reordered``.

What the fuzzer never sends: signed *future* frames (a valid payload with a newer sequence
number, signed with the run's key). A key holder can forge anything; the nodes' sequence
plausibility checks (``implausible_seq``, ``unpublished_seq``) are tested on their own in
``tests/test_auth.py``. Keeping an impostor without the key off the bus is the job of the
payload tags (``forged`` here, ``docs/security.md``) and, across hosts, of access control
and TLS (``docs/multi-host.md``).

Pacing: the fuzzer sends ``per_cycle`` payloads per control cycle it sees on the sensors
key (so the load follows the run, whatever the machine's speed), never more than
``max_rate_hz`` per wall second, starting at cycle ``start_cycle`` (so there are frames to
replay) and stopping at ``total`` payloads or at cycle ``stop_cycle``, whichever comes
first, so that every payload has been counted before the plant's final summary. Its
publishers use ``CongestionControl.BLOCK``: none is dropped at the sender, so the counts
on both sides must agree exactly.

Run it as ``python -m hil.nodes.fuzz --connect tcp/127.0.0.1:P --connect tcp/127.0.0.1:C ...``;
it announces itself with the liveliness token ``fowt/<turbine>/alive/fuzzer`` (a plant
started with ``--require controller,recorder,fuzzer`` waits for it), exits after the plant's
final timing summary, and prints (and optionally writes) its report as JSON.
"""

from __future__ import annotations

import argparse
import json
import math
import random
import struct
import sys
import threading
import time
from collections import Counter, deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zenoh

from bus_schemas.auth import TAG_BYTES, KeyFileError, read_key_file, sign
from bus_schemas.codec import MAGIC, DecodeError
from bus_schemas.registry import COMMAND, SENSORS, TIMING_SUMMARY, MessageType
from hil.nodes.bus import LINK_TIMEOUT_S, Bus, BusConfig, wait_matched

#: Kinds of malformed payload, in the order the fuzzer cycles through them.
KINDS: tuple[str, ...] = (
    "random",
    "truncated",
    "padded",
    "header",
    "cross_type",
    "version",
    "non_finite",
    "range",
    "replay",
    "reorder",
    "forged",
)

#: Counter key of a replayed or reordered frame, in the plant and in the controller.
REPLAY_REASON = "duplicate_or_reordered"

_WIRE = {"u64": "Q", "i64": "q", "u32": "I", "u8": "B", "f64": "d"}
#: Non-finite values written into float fields (the last is a quiet NaN with payload bits).
_NON_FINITE = (
    math.nan,
    math.inf,
    -math.inf,
    struct.unpack("<d", struct.pack("<Q", 0x7FF8_0000_DEAD_BEEF))[0],
)


@dataclass(frozen=True)
class FuzzPayload:
    """One payload to put, its kind and the rejection reason it must be counted under."""

    kind: str
    payload: bytes
    reason: str
    signed: bool = True  # False: the payload already ends in its (wrong) tag


class PayloadFactory:
    """Malformed payloads for one input key, built from valid payloads captured on the bus.

    Parameters
    ----------
    target : MessageType
        The message the key carries (:data:`~bus_schemas.registry.SENSORS` or
        :data:`~bus_schemas.registry.COMMAND`).
    other : MessageType
        The other input message (source of ``cross_type`` payloads).
    seed : int
        Seed of the generator (the sequence of kinds and mutations is reproducible given
        the same captured payloads).
    seq_field : str
        The field the receiving node orders payloads by (``seq`` for sensor frames,
        ``answered_seq`` for commands).
    history : int
        Captured payloads kept for replaying.
    """

    def __init__(
        self,
        target: MessageType,
        other: MessageType,
        seed: int,
        seq_field: str,
        history: int = 256,
    ) -> None:
        self.target = target
        self.other = other
        self.rng = random.Random(seed)
        self.codec = target.codec
        self.fields = self.codec.fields
        self._struct = struct.Struct("<BBH" + "".join(_WIRE[f.wire] for f in self.fields))
        self._seq_index = [f.name for f in self.fields].index(seq_field)
        self._float_idx = [i for i, f in enumerate(self.fields) if f.is_float]
        # Fields whose declared range is narrower than their wire type.
        self._range_idx = [i for i, f in enumerate(self.fields) if f.is_float or f.wire == "i64"]
        self._lock = threading.Lock()
        self._captured: deque[tuple[int, bytes]] = deque(maxlen=history)
        self._other_captured: deque[bytes] = deque(maxlen=16)
        self.newest_seq = -1
        self._non_finite_k = 0

    # ------------------------------------------------------------------ capture

    def capture(self, payload: bytes) -> None:
        """Keep a payload seen on the target key (ignored unless the codec accepts it)."""
        try:
            msg = self.codec.decode(payload)
        except DecodeError:
            return
        seq = int(getattr(msg, self.fields[self._seq_index].name))
        with self._lock:
            self._captured.append((seq, bytes(payload)))
            self.newest_seq = max(self.newest_seq, seq)

    def capture_other(self, payload: bytes) -> None:
        """Keep a valid payload of the other input message (for ``cross_type``)."""
        try:
            self.other.codec.decode(payload)
        except DecodeError:
            return
        with self._lock:
            self._other_captured.append(bytes(payload))

    def _old(self) -> list[bytes]:
        """Captured payloads at least one sequence number behind the newest seen."""
        with self._lock:
            newest = self.newest_seq
            return [p for s, p in self._captured if s <= newest - 1]

    def _valid(self) -> bytes | None:
        with self._lock:
            if not self._captured:
                return None
            return self._captured[self.rng.randrange(len(self._captured))][1]

    # ------------------------------------------------------------------ mutations

    def _reason(self, payload: bytes) -> str | None:
        """The codec's rejection reason for ``payload``; None if it would be accepted."""
        try:
            self.codec.decode(payload)
        except DecodeError as exc:
            return exc.reason
        return None

    def _mutate(self, base: bytes, index: int, value: float | int) -> bytes:
        values = list(self._struct.unpack(base))
        values[3 + index] = value
        return self._struct.pack(*values)

    def _out_of_range(self, index: int) -> float | int:
        f = self.fields[index]
        if not f.is_float:  # i64 time: the only way out of [0, 2**63 - 1] is below 0
            return -self.rng.randint(1, 2**62)
        span = max(1.0, f.maximum - f.minimum)
        magnitude = span * 10.0 ** self.rng.uniform(-3.0, 3.0)
        return f.maximum + magnitude if self.rng.random() < 0.5 else f.minimum - magnitude

    def make(self, kind: str) -> list[FuzzPayload]:
        """Payloads of ``kind`` (empty when nothing was captured yet to build them from).

        Every payload but ``replay``/``reorder`` has been checked to be rejected by the
        codec; the reason it gives is the one returned.
        """
        rng = self.rng
        size = self.codec.size
        raw: list[bytes] = []
        if kind in ("replay", "reorder"):
            old = self._old()
            if not old:
                return []
            if kind == "replay":
                picked = [old[rng.randrange(len(old))]]
            else:
                picked = rng.sample(old, min(len(old), rng.randint(2, 8)))
                rng.shuffle(picked)
            return [FuzzPayload(kind, p, REPLAY_REASON) for p in picked]
        if kind == "forged":
            base = self._valid()
            if base is None:
                return []
            return [FuzzPayload(kind, base + rng.randbytes(TAG_BYTES), "auth", signed=False)]
        if kind == "random":
            n = rng.randrange(0, 2 * size + 1)
            raw.append(rng.randbytes(n))
        elif kind == "cross_type":
            with self._lock:
                others = list(self._other_captured)
            if not others:
                return []
            raw.append(others[rng.randrange(len(others))])
        else:
            base = self._valid()
            if base is None:
                return []
            if kind == "truncated":
                raw.append(base[: rng.randrange(0, size)])
            elif kind == "padded":
                raw.append(base + rng.randbytes(rng.randint(1, 64)))
            elif kind == "header":
                b = bytearray(base)
                pos, good = (0, MAGIC) if rng.random() < 0.5 else (1, self.target.message_id)
                b[pos] = (good + rng.randint(1, 255)) % 256  # any byte but the right one
                raw.append(bytes(b))
            elif kind == "version":
                version = rng.randrange(65535)
                version += version >= self.target.version  # any u16 but ours
                raw.append(base[:2] + struct.pack("<H", version) + base[4:])
            elif kind == "non_finite":
                k = self._non_finite_k
                self._non_finite_k += 1
                index = self._float_idx[k % len(self._float_idx)]
                value = _NON_FINITE[(k // len(self._float_idx)) % len(_NON_FINITE)]
                raw.append(self._mutate(base, index, value))
            elif kind == "range":
                index = self._range_idx[rng.randrange(len(self._range_idx))]
                raw.append(self._mutate(base, index, self._out_of_range(index)))
            else:
                raise ValueError(f"unknown fuzz kind {kind!r}; expected one of {KINDS}")
        out = []
        for payload in raw:
            reason = self._reason(payload)
            if reason is not None:  # a payload the codec accepts is never sent
                out.append(FuzzPayload(kind, payload, reason))
        return out


@dataclass(frozen=True)
class FuzzConfig:
    """What the fuzzer sends and when.

    Parameters
    ----------
    turbine_id : str
        Turbine of the keys (``fowt/<turbine>/...``).
    total : int
        Payloads to send over both keys together (half on each, alternating).
    per_cycle : float
        Payloads per control cycle seen on the sensors key (pacing that follows the run).
    max_rate_hz : float
        Cap on payloads per wall second (both keys together).
    start_cycle : int
        First cycle (sensor ``seq``) at which to send (so there are frames to replay).
    stop_cycle : int or None
        Cycle at which sending stops even if ``total`` is not reached (None: no limit);
        leave room before the run's end so every payload is counted before the final summary.
    seed : int
        Seed of the payload generators.
    timeout_s : float
        Give up waiting for the plant's final summary after this many wall seconds.
    """

    turbine_id: str = "t1"
    total: int = 100_000
    per_cycle: float = 20.0
    max_rate_hz: float = 20_000.0
    start_cycle: int = 10
    stop_cycle: int | None = None
    seed: int = 1
    timeout_s: float = 600.0


@dataclass
class FuzzReport:
    """What the fuzzer sent: per key, counts by kind and by expected rejection reason."""

    sent: dict[str, Counter[str]] = field(default_factory=dict)
    expected: dict[str, Counter[str]] = field(default_factory=dict)
    total: int = 0
    first_cycle: int = -1
    last_cycle: int = -1
    sending_wall_s: float = 0.0
    final_seen: bool = False
    stopped_by: str = ""

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-ready form; ``rate_hz`` is the mean rate while sending."""
        rate = self.total / self.sending_wall_s if self.sending_wall_s > 0 else 0.0
        return {
            "total": self.total,
            "per_key": {k: sum(v.values()) for k, v in self.sent.items()},
            "sent": {k: dict(v) for k, v in self.sent.items()},
            "expected_rejections": {k: dict(v) for k, v in self.expected.items()},
            "first_cycle": self.first_cycle,
            "last_cycle": self.last_cycle,
            "sending_wall_s": round(self.sending_wall_s, 3),
            "rate_hz": round(rate, 1),
            "final_seen": self.final_seen,
            "stopped_by": self.stopped_by,
        }


class Fuzzer:
    """The sending side: two payload factories, their publishers and the pacing rule."""

    def __init__(
        self,
        config: FuzzConfig,
        put: Callable[[str, bytes], None],
        auth_key: bytes | None = None,
    ) -> None:
        self.config = config
        self.put = put
        self.auth_key = auth_key
        # Without the run's secret there is no tag to forge: every payload is unsigned.
        self.kinds = KINDS if auth_key is not None else tuple(k for k in KINDS if k != "forged")
        tid = config.turbine_id
        self.keys = (SENSORS.key(tid), COMMAND.key(tid))
        self.factories = {
            self.keys[0]: PayloadFactory(SENSORS, COMMAND, config.seed, "seq"),
            self.keys[1]: PayloadFactory(COMMAND, SENSORS, config.seed + 1, "answered_seq"),
        }
        self.report = FuzzReport(
            sent={k: Counter() for k in self.keys}, expected={k: Counter() for k in self.keys}
        )
        self._kind_rng = random.Random(config.seed + 2)
        self._queue: dict[str, deque[FuzzPayload]] = {k: deque() for k in self.keys}
        self._turn = 0

    @property
    def cycle(self) -> int:
        """Newest control cycle (sensor ``seq``) seen on the bus."""
        return self.factories[self.keys[0]].newest_seq

    def on_sensors(self, _key: str, payload: bytes) -> None:
        """Capture a sensor frame of the run."""
        self.factories[self.keys[0]].capture(payload)
        self.factories[self.keys[1]].capture_other(payload)

    def on_command(self, _key: str, payload: bytes) -> None:
        """Capture a command of the run."""
        self.factories[self.keys[1]].capture(payload)
        self.factories[self.keys[0]].capture_other(payload)

    def _next(self, key: str) -> FuzzPayload | None:
        queue = self._queue[key]
        attempts = 0
        while not queue and attempts < 4 * len(KINDS):
            kinds = list(self.kinds)
            self._kind_rng.shuffle(kinds)
            for kind in kinds:
                queue.extend(self.factories[key].make(kind))
            attempts += len(self.kinds)
        return queue.popleft() if queue else None

    def send_one(self) -> bool:
        """Send the next payload, alternating keys; False if none could be built yet."""
        key = self.keys[self._turn % 2]
        self._turn += 1
        item = self._next(key)
        if item is None:
            return False
        data = item.payload
        if item.signed and self.auth_key is not None:
            data = sign(self.auth_key, key, data)
        self.put(key, data)
        self.report.sent[key][item.kind] += 1
        self.report.expected[key][item.reason] += 1
        self.report.total += 1
        return True

    def allowed(self, now_s: float, started_s: float) -> int:
        """How many payloads may have been sent by now (cycle pacing and the rate cap)."""
        c = self.config
        cycles = self.cycle - c.start_cycle + 1
        by_cycle = math.floor(c.per_cycle * max(0, cycles))
        by_rate = math.floor(c.max_rate_hz * max(0.0, now_s - started_s)) + 1
        return min(c.total, by_cycle, by_rate)

    def finished_sending(self) -> str:
        """Why sending is over ('' while it is not)."""
        c = self.config
        if self.report.total >= c.total:
            return "total"
        if c.stop_cycle is not None and self.cycle >= c.stop_cycle:
            return "stop_cycle"
        return ""


def run_fuzzer(
    config: FuzzConfig, bus_config: BusConfig, log: Callable[[str], None] = print
) -> FuzzReport:
    """Fuzz the run the bus config reaches until the plant's final summary (or timeout).

    Parameters
    ----------
    config : FuzzConfig
        What to send and the pacing.
    bus_config : BusConfig
        Endpoints to connect to: the plant's and the controller's (gossip is off, so each
        must be given).
    log : callable
        Progress lines.

    Returns
    -------
    FuzzReport
        Counts of what was sent, per key, by kind and by expected rejection reason.
    """
    bus = Bus(bus_config)
    tid = config.turbine_id
    # Remote destinations only: its own session subscribes to the same keys (it captures
    # the run's frames and commands), which would take its payloads and would make the
    # publishers' matching status (below) true before any node is reached.
    pubs = {
        key: bus.session.declare_publisher(
            key,
            congestion_control=zenoh.CongestionControl.BLOCK,
            express=True,
            allowed_destination=zenoh.Locality.REMOTE,
        )
        for key in (SENSORS.key(tid), COMMAND.key(tid))
    }

    def put(key: str, payload: bytes) -> None:
        pubs[key].put(payload)

    fuzzer = Fuzzer(config, put, bus_config.auth_key)
    final = threading.Event()

    def on_summary(_key: str, payload: bytes) -> None:
        try:
            if TIMING_SUMMARY.codec.decode(payload).final:
                final.set()
        except DecodeError:
            pass

    bus.subscribe(SENSORS.key(tid), fuzzer.on_sensors)
    bus.subscribe(COMMAND.key(tid), fuzzer.on_command)
    bus.subscribe(TIMING_SUMMARY.key(tid), on_summary)
    # Announced once both links are up: the controller's subscription reaches the sensors
    # key, the plant's the command key (hil.nodes.bus.wait_matched). A plant that saw the
    # token before would run cycles the fuzzer cannot reach yet (its connection to an
    # endpoint not yet listening is retried every 1-4 s).
    for key, pub in pubs.items():
        if not wait_matched(pub, LINK_TIMEOUT_S):
            log(f"fuzzer: nobody reached {key} within {LINK_TIMEOUT_S:g} s; starting anyway")
    token = bus.session.liveliness().declare_token(f"fowt/{tid}/alive/fuzzer")
    log(
        f"fuzzer ready on {list(pubs)} (connect {list(bus_config.connect)}): "
        f"{config.total} payloads, {config.per_cycle:g}/cycle, <= {config.max_rate_hz:g}/s"
    )
    report = fuzzer.report
    deadline = time.monotonic() + config.timeout_s
    started: float | None = None
    try:
        while not final.is_set() and time.monotonic() < deadline:
            why = fuzzer.finished_sending()
            if why:
                report.stopped_by = why
                break
            if fuzzer.cycle < config.start_cycle:
                time.sleep(0.002)
                continue
            now = time.monotonic()
            if started is None:
                started = now
                report.first_cycle = fuzzer.cycle
            budget = fuzzer.allowed(now, started) - report.total
            if budget <= 0:
                time.sleep(0.001)
                continue
            for _ in range(min(budget, 200)):
                if not fuzzer.send_one():
                    time.sleep(0.001)
                    break
        if started is not None:
            report.sending_wall_s = time.monotonic() - started
        report.last_cycle = fuzzer.cycle
        if not report.stopped_by:
            report.stopped_by = "final summary" if final.is_set() else "timeout"
        log(
            f"fuzzer sent {report.total} payloads in {report.sending_wall_s:.2f} s "
            f"(cycles {report.first_cycle}..{report.last_cycle}, stopped by {report.stopped_by})"
        )
        final.wait(max(0.0, deadline - time.monotonic()))
        report.final_seen = final.is_set()
    finally:
        token.undeclare()
        bus.close()
    return report


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m hil.nodes.fuzz``: run the fuzzer node, print its report as JSON."""
    ap = argparse.ArgumentParser(
        prog="python -m hil.nodes.fuzz", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--connect", action="append", default=[], help="endpoint (repeatable)")
    ap.add_argument("--turbine", default="t1")
    ap.add_argument("--total", type=int, default=FuzzConfig.total)
    ap.add_argument("--per-cycle", type=float, default=FuzzConfig.per_cycle)
    ap.add_argument("--max-rate", type=float, default=FuzzConfig.max_rate_hz)
    ap.add_argument("--start-cycle", type=int, default=FuzzConfig.start_cycle)
    ap.add_argument("--stop-cycle", type=int, default=None)
    ap.add_argument("--seed", type=int, default=FuzzConfig.seed)
    ap.add_argument("--timeout", type=float, default=FuzzConfig.timeout_s)
    ap.add_argument("--report", type=Path, default=None, help="also write the JSON report here")
    ap.add_argument("--key-file", type=Path, default=None, help="the run's secret (run.key)")
    ap.add_argument("--insecure", action="store_true", help="the run is unauthenticated")
    args = ap.parse_args(argv)
    if (args.key_file is None) == (not args.insecure):
        ap.error("give --key-file FILE (the run's secret) or --insecure, not both")
    try:
        auth_key = None if args.key_file is None else read_key_file(args.key_file)
    except KeyFileError as exc:
        ap.error(str(exc))
    config = FuzzConfig(
        turbine_id=args.turbine,
        total=args.total,
        per_cycle=args.per_cycle,
        max_rate_hz=args.max_rate,
        start_cycle=args.start_cycle,
        stop_cycle=args.stop_cycle,
        seed=args.seed,
        timeout_s=args.timeout,
    )
    report = run_fuzzer(config, BusConfig(connect=tuple(args.connect), auth_key=auth_key))
    text = json.dumps(report.as_dict(), indent=2)
    if args.report is not None:
        args.report.write_text(text)
    sys.stdout.write(text + "\n")
    return 0 if report.final_seen else 1


if __name__ == "__main__":
    raise SystemExit(main())
