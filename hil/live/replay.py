"""``fowt view run.mcap``: a recorded run log served to Foxglove as the live view serves a run.

The file's ``cdr`` messages of the registered channels go out as they are (same topics,
schemas and payloads, :mod:`hil.live.server`), paced by their log times divided by
``speed`` (0: as fast as the sdk takes them), with the frame transforms and the scene of the
scenario's turbine (:mod:`hil.live.scene`; the scenario from the file's ``scenario``
metadata record). No plant runs.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from pathlib import Path

from mcap.reader import make_reader

from bus_schemas import ros2
from hil.live.scene import geometry_of
from hil.live.server import LiveServer, LiveStats
from hil.runlog.mcap_io import check_magic


class ReplayError(ValueError):
    """A file that cannot be replayed (no scenario record, no turbine channel)."""


def _scenario_of(path: Path) -> tuple[str, str | None]:
    with path.open("rb") as fh:
        for rec in make_reader(fh).iter_metadata():
            if rec.name == "scenario":
                sc = json.loads(rec.metadata["json"])
                return str(sc["turbine"]), sc.get("platform")
    raise ReplayError(f"{path}: no 'scenario' metadata record (not a fowt run log?)")


def _channels(path: Path) -> tuple[str, dict[str, tuple[str, str]]]:
    """The file's turbine id (from its truth channel) and its ``cdr`` channels' ros2msg
    schemas by topic (so a file of older schema versions is served as it was written)."""
    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    if summary is None:
        raise ReplayError(f"{path}: no summary section (fowt recover makes the file complete)")
    schemas: dict[str, tuple[str, str]] = {}
    tid = None
    for c in summary.channels.values():
        schema = summary.schemas.get(c.schema_id)
        if c.message_encoding == "cdr" and schema is not None and schema.encoding == "ros2msg":
            schemas[c.topic] = (schema.name, schema.data.decode())
        parts = c.topic.split("/")
        if len(parts) == 3 and parts[0] == "fowt" and parts[2] == "truth":
            tid = parts[1]
    if tid is None:
        raise ReplayError(f"{path}: no fowt/<turbine>/truth channel")
    return tid, schemas


def replay(
    path: Path,
    port: int,
    speed: float = 1.0,
    stop: threading.Event | None = None,
    on_ready: Callable[[int], None] | None = None,
) -> LiveStats:
    """Serve ``path`` on 127.0.0.1:``port`` once, paced at ``speed`` x its log times.

    ``on_ready(port)`` is called once the server listens; ``stop`` ends the replay early.
    """
    check_magic(path)
    turbine, platform = _scenario_of(path)
    tid, schemas = _channels(path)
    truth_topic = f"fowt/{tid}/truth"
    truth_dtype = ros2.dtype_of_msgdef(schemas[truth_topic][1]) if truth_topic in schemas else None
    stop = stop or threading.Event()
    server = LiveServer(tid, geometry_of(turbine, platform), port, schemas=schemas)
    try:
        if on_ready is not None:
            on_ready(server.port)
        t_wall0: float | None = None
        t_log0 = 0
        with path.open("rb") as fh:
            for _schema, channel, message in make_reader(fh).iter_messages(log_time_order=True):
                if stop.is_set():
                    break
                if channel.message_encoding != "cdr":
                    continue
                if t_wall0 is None:
                    t_wall0, t_log0 = time.monotonic(), message.log_time
                if speed > 0:
                    due = t_wall0 + (message.log_time - t_log0) * 1e-9 / speed
                    wait = due - time.monotonic()
                    if wait > 0 and stop.wait(wait):
                        break
                truth = None
                if channel.topic == truth_topic and truth_dtype is not None:
                    truth = ros2.decode_as(truth_dtype, message.data)[0]
                server.offer_cdr(channel.topic, message.data, message.log_time, truth)
    finally:
        stats = server.close()
    return stats
