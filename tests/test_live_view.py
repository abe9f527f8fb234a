"""The live view (hil.live): a real run served to Foxglove, checked by an independent client.

The client here speaks the Foxglove WebSocket protocol itself (the ``websockets`` package,
the published spec: JSON ``serverInfo``/``advertise``/``subscribe``, binary message data
``0x01 | u32 subscription | u64 time | payload``) and decodes every CDR payload with
``mcap-ros2-support``'s decoder from the advertised ros2msg text: nothing of the bench's
code reads what it receives. What it received must equal the run log over its window.
"""

from __future__ import annotations

import asyncio
import json
import os
import socket
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from _helpers import REPO
from mcap.reader import make_reader
from mcap_ros2._dynamic import generate_dynamic

pytestmark = pytest.mark.e2e

websockets = pytest.importorskip("websockets")

#: Subprotocols a Foxglove client offers (the sdk's own, then the ws-protocol's v1).
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _launch(
    out: Path, port: int, duration_s: float, scenario: str = "default"
) -> subprocess.Popen[str]:
    """``fowt run SCENARIO --mode lockstep --live PORT`` in a child process (output piped)."""
    path = os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "PYTHONPATH": path, "COLUMNS": "120"}
    cmd = [sys.executable, "-m", "hil", "run", scenario, "--mode", "lockstep"]
    cmd += ["--duration", str(duration_s), "--out", str(out), "--no-plots", "--live", str(port)]
    return subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env
    )


def _fields(obj: Any) -> dict[str, Any]:
    return {k: getattr(obj, k) for k in obj.__slots__} if hasattr(obj, "__slots__") else vars(obj)


class Client:
    """A Foxglove WebSocket client of its own (module docstring).

    ``stall_after``: stop reading (the socket's receive paused) after that many binary
    messages, and hold the connection open: a stuck viewer.
    """

    def __init__(self, port: int, stall_after: int | None = None) -> None:
        self.port = port
        self.stall_after = stall_after
        self.server_info: dict[str, Any] = {}
        self.channels: dict[int, dict[str, Any]] = {}
        self.received: dict[str, list[bytes]] = {}
        self.subscribed = threading.Event()
        self.stalled = threading.Event()
        self.stop = threading.Event()
        self.subprotocol: str | None = None
        self.error: BaseException | None = None

    async def _connect(self) -> Any:
        deadline = time.monotonic() + 120.0
        while True:
            sock = socket.socket()
            if self.stall_after is not None:
                # A small receive buffer (set before connecting: no autotuning), so that what
                # a stuck viewer does not read stays on the server's side and is not hidden
                # in tens of megabytes of this socket's buffer.
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8192)
            try:
                sock.connect(("127.0.0.1", self.port))
                return await websockets.connect(
                    f"ws://127.0.0.1:{self.port}",
                    subprotocols=SUBPROTOCOLS,
                    max_size=None,
                    sock=sock,
                )
            except OSError:
                sock.close()
                if time.monotonic() > deadline:
                    raise
                await asyncio.sleep(0.02)

    async def _run(self) -> None:
        ws = await self._connect()
        self.subprotocol = ws.subprotocol
        subs: dict[int, str] = {}
        binary = 0
        try:
            while not self.stop.is_set():
                try:
                    msg = await asyncio.wait_for(ws.recv(), 0.2)
                except TimeoutError:
                    continue
                except websockets.ConnectionClosed:  # the live view ended with the run
                    return
                if isinstance(msg, str):
                    data = json.loads(msg)
                    if data["op"] == "serverInfo":
                        self.server_info = data
                    elif data["op"] == "advertise":
                        new = []
                        for ch in data["channels"]:
                            self.channels[ch["id"]] = ch
                            sid = len(subs) + 1
                            subs[sid] = ch["topic"]
                            new.append({"id": sid, "channelId": ch["id"]})
                        await ws.send(json.dumps({"op": "subscribe", "subscriptions": new}))
                        self.subscribed.set()
                    continue
                assert msg[0] == 0x01, f"binary opcode {msg[0]}"
                sid, _t = struct.unpack_from("<IQ", msg, 1)
                self.received.setdefault(subs[sid], []).append(bytes(msg[13:]))
                binary += 1
                if self.stall_after is not None and binary >= self.stall_after:
                    ws.transport.pause_reading()  # never reads again, keeps the socket open
                    self.stalled.set()
                    while not self.stop.is_set():
                        await asyncio.sleep(0.1)
        finally:
            ws.transport.abort()

    def start(self) -> threading.Thread:
        def main() -> None:
            try:
                asyncio.run(self._run())
            except BaseException as exc:  # surfaced by the test
                self.error = exc

        t = threading.Thread(target=main, daemon=True)
        t.start()
        return t

    def decoded(self) -> dict[str, list[dict[str, Any]]]:
        """Every CDR message received, decoded from the advertised ros2msg text."""
        out: dict[str, list[dict[str, Any]]] = {}
        for ch in self.channels.values():
            if ch["encoding"] != "cdr":
                continue
            assert ch["schemaEncoding"] == "ros2msg"
            dec = generate_dynamic(ch["schemaName"], ch["schema"])[ch["schemaName"]]
            out[ch["topic"]] = [_fields(dec(p)) for p in self.received.get(ch["topic"], [])]
        return out


def _mcap_decoded(path: Path) -> tuple[dict[str, list[dict[str, Any]]], dict[str, Any]]:
    """The run log's CDR messages decoded with the same independent decoder, and its channels'
    schemas (name, encoding, text) by topic."""
    out: dict[str, list[dict[str, Any]]] = {}
    schemas: dict[str, Any] = {}
    decoders: dict[int, Any] = {}
    with path.open("rb") as fh:
        for schema, channel, message in make_reader(fh).iter_messages(log_time_order=False):
            if channel.message_encoding != "cdr" or schema is None:
                continue
            if schema.id not in decoders:
                decoders[schema.id] = generate_dynamic(schema.name, schema.data.decode())[
                    schema.name
                ]
            schemas[channel.topic] = (schema.name, schema.encoding, schema.data.decode())
            out.setdefault(channel.topic, []).append(_fields(decoders[schema.id](message.data)))
    return out, schemas


def _listening_addresses(port: int) -> set[str]:
    """Local addresses of the TCP sockets listening on ``port`` (from /proc/net/tcp{,6})."""
    found = set()
    for name in ("tcp", "tcp6"):
        path = Path(f"/proc/net/{name}")
        if not path.exists():
            continue
        for line in path.read_text().splitlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            addr, hexport = local.rsplit(":", 1)
            if state == "0A" and int(hexport, 16) == port:
                found.add(addr)
    return found


def test_lockstep_run_live_view_equals_the_run_log(tmp_path: Path) -> None:
    port = _free_port()
    out = tmp_path / "run"
    proc = _launch(out, port, 10.0)
    client = Client(port)
    thread = client.start()
    try:
        assert client.subscribed.wait(120.0), "the live view never advertised its channels"
        # Bound to loopback only (IPv4 127.0.0.1, little-endian hex in /proc).
        assert _listening_addresses(port) == {"0100007F"}
        stdout, _ = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
        client.stop.set()
        thread.join(10.0)
    assert proc.returncode == 0, stdout
    assert client.error is None, repr(client.error)
    assert client.subprotocol in SUBPROTOCOLS
    # Read-only: no capability (client publishing, services, parameters) announced.
    assert client.server_info["capabilities"] == []
    topics = {ch["topic"]: ch for ch in client.channels.values()}
    assert topics["/tf"]["schemaName"] == "foxglove.FrameTransforms"
    assert topics["/scene"]["schemaName"] == "foxglove.SceneUpdate"
    assert client.received.get("/tf") and client.received.get("/scene")

    logged, schemas = _mcap_decoded(out / "run.mcap")
    got = client.decoded()
    # Every run log channel is served with the same schema and encoding.
    for topic, (name, encoding, text) in schemas.items():
        ch = topics[topic]
        assert (ch["schemaName"], ch["schemaEncoding"], ch["schema"]) == (name, encoding, text)
    # Over the client's window: the same messages, in order, none missing, none extra.
    compared = _assert_window_equal(got, logged)
    summary = json.loads((out / "summary.json").read_text())
    cycles = summary["timing"]["cycles"]
    assert len(logged["fowt/t1/truth"]) == cycles > 0
    assert len(got["fowt/t1/truth"]) > 0.5 * cycles  # the client saw most of the run
    assert compared > 4 * len(got["fowt/t1/truth"])
    # The controller's statuses too (subscribed once the controller announced itself).
    assert len(got["fowt/t1/controller/status"]) > 0.5 * cycles
    live = json.loads((out / "live.json").read_text())
    in_summary = dict(summary["run"]["live_view"])
    never = in_summary.pop("never_received")  # the log's messages the live view never got
    assert in_summary == {**live, "dropped": live["dropped"] + never}
    assert live["dropped"] == 0 and live["rejected"] == {}


def test_stuck_viewer_costs_the_run_nothing(tmp_path: Path) -> None:
    """A viewer that subscribes and then never reads: the run completes (exit 0, every
    message recorded) and the viewer's losses are counted in the summary."""
    port = _free_port()
    out = tmp_path / "run"
    # 100 Hz for 150 s: ~12 MB to the viewer, more than the socket and the outbox hold.
    proc = _launch(out, port, 150.0, "nrel5mw-ramp")
    client = Client(port, stall_after=10)
    thread = client.start()
    try:
        stdout, _ = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
        client.stop.set()
        thread.join(10.0)
    assert client.stalled.is_set(), "the client never got to stall"
    assert proc.returncode == 0, stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["run"]["exit_code"] == 0
    with (out / "run.mcap").open("rb") as fh:
        reader = make_reader(fh)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        stats = reader.get_summary().statistics  # type: ignore[union-attr]
    assert json.loads(meta["recorder"]["shortfall"]) == []
    expected = json.loads(meta["recorder"]["expected"])
    topics = json.loads(meta["recorder"]["topics"])
    assert all(topics.get(k, 0) == n for k, n in expected.items()), (topics, expected)
    assert topics["truth"] == summary["timing"]["cycles"] > 0
    assert stats.message_count == int(meta["recorder"]["messages"])
    live = summary["run"]["live_view"]
    # The stuck viewer lost messages, and they were counted (the bench's queue or the sdk's
    # per-client outbox overflowing): certain once what was sent exceeds what the server's
    # socket can hold beside the sdk's outbox (its send buffer's limit, tcp_wmem).
    sent = 0
    with (out / "run.mcap").open("rb") as fh:
        for _s, _c, message in make_reader(fh).iter_messages():
            sent += len(message.data) + 20  # + the protocol's and WebSocket's headers
    wmem = Path("/proc/sys/net/ipv4/tcp_wmem")
    buffer_max = int(wmem.read_text().split()[2]) if wmem.exists() else 4 << 20
    if sent > 1.2 * buffer_max + 4096 * 400:
        assert live["dropped"] + live["outbox_full"] > 0, (live, sent, buffer_max)
    assert "dropped for the viewers" in stdout


def _assert_window_equal(
    got: dict[str, list[dict[str, Any]]], logged: dict[str, list[dict[str, Any]]]
) -> int:
    """Per topic, what the client decoded is a run of consecutive run log messages, equal
    field by field; returns how many were compared."""
    compared = 0
    for topic, msgs in got.items():
        if not msgs:
            continue
        ref = logged[topic]
        first = ref.index(msgs[0])
        assert ref[first : first + len(msgs)] == msgs, topic
        compared += len(msgs)
    return compared


def test_view_replays_a_run_log_as_the_live_view_serves_it(tmp_path: Path) -> None:
    """``fowt view``: a recorded run log (a short lock-step run) to the same protocol client."""
    out = tmp_path / "run"
    rec = _launch(out, _free_port(), 5.0)
    stdout, _ = rec.communicate(timeout=300)
    assert rec.returncode == 0, stdout
    port = _free_port()
    path = os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])
    view = subprocess.Popen(
        [sys.executable, "-m", "hil", "view", str(out / "run.mcap"), "--port", str(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "PYTHONPATH": path},
    )
    client = Client(port)
    thread = client.start()
    try:
        assert client.subscribed.wait(120.0)
        vout, _ = view.communicate(timeout=300)
    finally:
        if view.poll() is None:
            view.kill()
        client.stop.set()
        thread.join(10.0)
    assert view.returncode == 0, vout
    assert client.server_info["capabilities"] == []
    logged, _schemas = _mcap_decoded(out / "run.mcap")
    got = client.decoded()
    assert _assert_window_equal(got, logged) > 0
    assert len(got["fowt/t1/truth"]) > 0.5 * len(logged["fowt/t1/truth"])
    assert client.received.get("/tf") and client.received.get("/scene")


def test_live_is_refused_where_it_cannot_serve(tmp_path: Path) -> None:
    """Exit 2 before anything starts: no bus to watch, another transport, a port in use."""
    from _helpers import fowt

    for args in (["--mode", "inprocess", "--live"], ["--transport", "can", "--live", "0"]):
        proc = fowt("run", "default", *args, "--out", str(tmp_path / "x"), timeout=120)
        assert proc.returncode == 2, proc.stdout + proc.stderr
        assert "--live" in proc.stderr
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        proc = fowt("run", "default", "--live", str(port), "--out", str(tmp_path / "x"))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert f"127.0.0.1:{port} is not free" in proc.stderr
    assert not (tmp_path / "x").exists()  # nothing started


def test_bare_live_means_the_default_port() -> None:
    from hil.cli.fowt import LIVE_DEFAULT_PORT, _bare_live

    assert _bare_live(["run", "--live"]) == ["run", f"--live={LIVE_DEFAULT_PORT}"]
    assert _bare_live(["run", "--live", "default"]) == [
        "run",
        f"--live={LIVE_DEFAULT_PORT}",
        "default",
    ]
    assert _bare_live(["run", "--live", "9000"]) == ["run", "--live", "9000"]


def test_the_live_view_never_stands_in_for_the_recorder(tmp_path: Path) -> None:
    """A controller started with --await-recorder announces itself once a subscriber of its
    status key is reachable: the live view (linked to it first) must not count as one."""
    from _helpers import NodeProcesses, key_file_args, two_endpoints

    plant_ep, ctrl_ep = two_endpoints()
    key = key_file_args(tmp_path)
    hil = [sys.executable, "-m", "hil"]
    with NodeProcesses(tmp_path) as nodes:
        nodes.start(
            "live",
            [*hil, "live-node", "default", "--connect", plant_ep, "--connect", ctrl_ep,
             "--port", "0", *key],
        )  # fmt: skip
        time.sleep(1.0)  # its connect to the controller's endpoint is retried from now on
        nodes.start(
            "controller",
            [*hil, "controller", "default", "--listen", ctrl_ep, "--connect", plant_ep,
             "--await-recorder", "8", *key],
        )  # fmt: skip
        log = tmp_path / "controller.log"
        deadline = time.monotonic() + 120.0
        while "announcing itself anyway" not in log.read_text() and time.monotonic() < deadline:
            assert nodes.procs["controller"].poll() is None, log.read_text()
            time.sleep(0.2)
        assert "no recorder reached its status key" in log.read_text(), log.read_text()


def test_shipped_layout_plots_fields_the_live_view_serves() -> None:
    """docs/foxglove-layout.json: every plotted path is a served topic's field, and the 3-D
    panel shows the scene and the frames."""
    import re

    from bus_schemas.registry import MESSAGES

    layout = json.loads((REPO / "docs" / "foxglove-layout.json").read_text())
    fields = {mt.key("t1"): set(mt.cls.__struct_fields__) for mt in MESSAGES}
    paths = [
        p["value"]
        for key, cfg in layout["configById"].items()
        if key.startswith("Plot!")
        for p in cfg["paths"]
    ]
    assert len(paths) >= 5
    for path in paths:
        m = re.fullmatch(r'"([^"]+)"\.([a-z0-9_]+)', path)
        assert m, path
        assert m.group(2) in fields[m.group(1)], path
    (three_d,) = [c for k, c in layout["configById"].items() if k.startswith("3D!")]
    assert three_d["topics"]["/scene"]["visible"]
    assert set(three_d["transforms"]) == {"frame:world", "frame:platform", "frame:rotor"}


def test_messages_that_never_reached_the_live_view_are_counted(tmp_path: Path) -> None:
    """The recorder's last live batch, put as its session closes, has no batch after it to
    show it missing: the launcher counts the run log's messages the live view neither offered
    nor counted in a gap (``never_received``) among the viewers' drops."""
    from rich.console import Console

    from hil.launch import _live_summary

    live = {"port": 1, "offered": 90, "published": 90, "dropped": 7, "lost_in_feed": 5,
            "outbox_full": 0, "clients": 1, "rejected": {}, "stop_waited": False}  # fmt: skip
    (tmp_path / "live.json").write_text(json.dumps(live))
    topics = {"truth": {"recorded": 60, "expected": 60}, "command": {"recorded": 40}}
    summary: dict[str, Any] = {"recording": {"topics": topics}}
    console = Console(record=True, width=200)
    _live_summary(summary, tmp_path, console)
    got = summary["run"]["live_view"]
    assert got["never_received"] == 100 - 90 - 5
    assert got["dropped"] == 7 + 5
    assert "12 dropped for the viewers" in console.export_text()
    # every message accounted for: nothing more
    live.update(offered=95)
    (tmp_path / "live.json").write_text(json.dumps(live))
    summary = {"recording": {"topics": topics}}
    _live_summary(summary, tmp_path, console)
    assert summary["run"]["live_view"]["never_received"] == 0
    assert summary["run"]["live_view"]["dropped"] == 7
    # no live.json: said so, nothing computed
    (tmp_path / "live.json").unlink()
    summary = {"recording": {"topics": topics}}
    _live_summary(summary, tmp_path, console)
    assert "error" in summary["run"]["live_view"]
    assert "never_received" not in summary["run"]["live_view"]
