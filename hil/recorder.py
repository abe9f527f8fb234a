"""The recorder process: every ``fowt/<turbine>/**`` sample into one MCAP file per run.

Zenoh calls :meth:`Recorder.on_sample` in its own thread; the callback only decodes (so a
bad payload is counted, never logged as data) and queues. The main thread writes the
queue to :class:`hil.mcap_log.RunLog`, flushing a chunk at least every 0.25 s, so the file
stays readable up to its last flush if any process, this one included, is killed. The
recorder stops after the plant's final timing summary (plus a short drain) or on
SIGINT/SIGTERM, and always finishes the file.
"""

from __future__ import annotations

import json
import queue
import signal
import threading
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bus_schemas import DecodeError, TimingSummary
from bus_schemas.registry import BY_SUFFIX, KEY_PREFIX
from hil.bus import Bus, BusConfig
from hil.mcap_log import RunLog
from hil.scenario import Scenario

#: How often the main thread writes what the Zenoh thread queued (s); << the 0.25 s flush.
_DRAIN_PERIOD_S = 0.02


class Recorder:
    """Decode-and-queue sink for bus samples, drained into a :class:`RunLog`."""

    def __init__(self, log: RunLog) -> None:
        self.log = log
        self.queue: queue.SimpleQueue[tuple[str, Any, int]] = queue.SimpleQueue()
        self.rejected: Counter[str] = Counter()
        self.unknown_keys: Counter[str] = Counter()
        self.final_seen = threading.Event()
        self.prefix = f"{KEY_PREFIX}/{log.turbine}/"

    def on_sample(self, key: str, payload: bytes) -> None:
        """Decode one sample (Zenoh's thread) and queue it for writing."""
        suffix = key.removeprefix(self.prefix)
        mt = BY_SUFFIX.get(suffix)
        if mt is None:
            if "/alive/" not in key:
                self.unknown_keys[key] += 1
            return
        try:
            msg = mt.codec.decode(payload)
        except DecodeError as exc:
            self.rejected[f"{suffix}:{exc.reason}"] += 1
            return
        self.queue.put((key, msg, time.time_ns()))
        if isinstance(msg, TimingSummary) and msg.final:
            self.final_seen.set()

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
            n += 1
            try:
                item = self.queue.get_nowait()
            except queue.Empty:
                return n


def run_recorder_node(
    scenario: Scenario,
    bus_config: BusConfig,
    out: Path,
    run_info: dict[str, str] | None = None,
    scenario_toml: str = "",
    drain_s: float = 0.3,
    log: Callable[[str], None] = print,
) -> int:
    """Record until the plant's final summary (plus ``drain_s``) or a signal.

    Returns the number of messages written.
    """
    run_log = RunLog(out, scenario.turbine_id)
    run_log.add_metadata("scenario", scenario_metadata(scenario, scenario_toml))
    if run_info:
        run_log.add_metadata("run", run_info)
    recorder = Recorder(run_log)
    stop = threading.Event()

    def on_signal(signum: int, _frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    bus = Bus(bus_config)
    written = 0
    try:
        bus.subscribe(f"{KEY_PREFIX}/{scenario.turbine_id}/**", recorder.on_sample)
        token = bus.session.liveliness().declare_token(f"fowt/{scenario.turbine_id}/alive/recorder")
        log(f"recorder writing {out}")
        while not stop.is_set() and not recorder.final_seen.is_set():
            # Drain in batches every 20 ms rather than waking per message: a wake-up per
            # sample costs a thread switch and a GIL hand-over with Zenoh's thread, which
            # took the CPU the plant and controller need (recorder CPU -20 % in lock-step).
            time.sleep(_DRAIN_PERIOD_S)
            written += recorder.drain(0.0)
        end = time.monotonic() + drain_s
        while time.monotonic() < end:
            written += recorder.drain(0.02)
        token.undeclare()
    finally:
        bus.close()
        written += recorder.drain(0.0)
        run_log.add_metadata(
            "recorder",
            {
                "messages": str(run_log.count),
                "rejected": json.dumps(dict(recorder.rejected)),
                "unknown_keys": json.dumps(dict(recorder.unknown_keys)),
            },
        )
        run_log.close()
    log(f"recorder closed {out}: {run_log.count} messages, rejected {dict(recorder.rejected)}")
    return written


def scenario_metadata(scenario: Scenario, toml_text: str) -> dict[str, str]:
    """The ``scenario`` metadata record written into every run's MCAP file."""
    return {
        "name": scenario.name,
        "json": json.dumps(scenario.to_toml_dict()),
        "toml": toml_text,
    }
