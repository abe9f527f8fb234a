"""A run log written by a child process, for the in-process mode.

Writing one MCAP message costs about 5.6 us in ``mcap.Writer.add_message`` on this kind of
machine, more than a whole plant step. In the in-process mode the simulation loop therefore
only JSON-encodes each message (msgspec, under 1 us) and batches it; batches go through a
pipe to a child process that owns the :class:`hil.mcap_log.RunLog`, so encoding and
compression run on the other core. If the parent dies, the child sees the pipe close and
finishes the file, so no flushed data is lost.
"""

from __future__ import annotations

import multiprocessing
import time
from multiprocessing.connection import Connection
from pathlib import Path

import msgspec

from bus_schemas.registry import BY_ID, MessageType
from hil.mcap_log import RunLog

_BATCH = 4096


def _writer_main(
    conn: Connection, path: str, turbine: str, metadata: dict[str, dict[str, str]]
) -> None:
    log = RunLog(Path(path), turbine)
    keys = {mid: mt.key(turbine) for mid, mt in BY_ID.items()}
    decoder = msgspec.msgpack.Decoder(list[tuple[int, int, bytes, int]])
    try:
        for name, data in metadata.items():
            log.add_metadata(name, data)
        while True:
            try:
                blob = conn.recv_bytes()
            except EOFError:
                break
            if not blob:
                break
            for mid, sample_time_ns, js, recv in decoder.decode(blob):
                log.write_json(keys[mid], sample_time_ns, js, recv)
    finally:
        log.close()


class BackgroundRunLog:
    """Publish sink whose MCAP writing happens in a child process.

    Parameters
    ----------
    path : Path
        MCAP file to write.
    turbine : str
        Turbine id of the keys.
    metadata : dict
        Metadata records (name -> string map) written first.
    """

    def __init__(self, path: Path, turbine: str, metadata: dict[str, dict[str, str]]) -> None:
        ctx = multiprocessing.get_context("spawn")
        recv_end, send_end = ctx.Pipe(duplex=False)
        self._conn = send_end
        self._proc = ctx.Process(
            target=_writer_main,
            args=(recv_end, str(path), turbine, metadata),
            name="fowt-log-writer",
            daemon=False,
        )
        self._proc.start()
        recv_end.close()
        self._batch: list[tuple[int, int, bytes, int]] = []
        self._encode = msgspec.json.encode
        self._pack = msgspec.msgpack.encode

    def publish(self, mt: MessageType, msg: msgspec.Struct) -> None:
        """Queue one message for the log (the simulation loop's only logging cost)."""
        batch = self._batch
        batch.append((mt.message_id, msg.sample_time_ns, self._encode(msg), time.time_ns()))  # type: ignore[attr-defined]
        if len(batch) >= _BATCH:
            self._conn.send_bytes(self._pack(batch))
            batch.clear()

    def close(self, timeout_s: float = 120.0) -> None:
        """Send what is left, wait for the child to finish the file."""
        if self._batch:
            self._conn.send_bytes(self._pack(self._batch))
            self._batch.clear()
        self._conn.send_bytes(b"")
        self._conn.close()
        self._proc.join(timeout_s)
        if self._proc.exitcode != 0:
            raise RuntimeError(f"log writer exited with {self._proc.exitcode}")
