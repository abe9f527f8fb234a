"""No Zenoh session without the run's credential (docs/security.md, "Sessions").

Unit level, real Zenoh sessions in this process: a node of an authenticated run (a
:class:`~hil.nodes.bus.Bus` with the run's key) accepts a link from a session holding the
run's credential only; a key-less client gets no session at all, a key-less peer and a peer
holding another run's key get no link.

End to end (marked ``e2e``): short runs of ``nrel5mw-ramp`` with plant, controller and
recorder as real processes, and beside them a key-less process (``tests/_keyless_client.py``)
that keeps trying client sessions on the plant's and the controller's endpoints to (a) replay
payloads signed with the run's key (what it would have captured), (b) only subscribe (which
used to satisfy the controller's wait for the recorder and cut the start of the recording),
(c) flood 3000 garbage payloads a second. In each: no session opened, every node exits 0,
and the recording holds exactly one message per cycle on every per-cycle topic, with no
rejection counted. The same client against an unauthenticated node does get a session (the
attack is real).
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import msgspec
import pytest
from _helpers import (
    NodeProcesses,
    key_file_args,
    lockstep_node_cmds,
    sensor_frame,
    two_endpoints,
)

from bus_schemas import ActuatorCommand
from bus_schemas.auth import new_key, read_key_file, session_credentials, sign
from bus_schemas.registry import COMMAND, SENSORS
from hil.nodes.bus import Bus, BusConfig, free_tcp_endpoint
from hil.runlog.mcap_io import read_run

CLIENT = Path(__file__).with_name("_keyless_client.py")
SCENARIO = "nrel5mw-ramp"
PER_CYCLE = ("sensors", "command", "truth", "controller/status", "timing/cycle")


def _links(bus: Bus) -> int:
    return len(list(bus.session.info.peers_zid()))


def test_a_session_opens_only_with_the_runs_credential() -> None:
    key = new_key()
    ep = free_tcp_endpoint()
    node = Bus(BusConfig(listen=(ep,), auth_key=key))
    others: list[Bus] = []
    try:
        assert node.config.session_auth and "session authenticated" in node.config.describe()
        good = Bus(BusConfig(connect=(ep,), auth_key=key))
        others.append(good)
        assert _links(good) == 1
        # another run's key (the payload tags aside): refused at the session already
        stranger = Bus(BusConfig(connect=(ep,), auth_key=new_key()))
        others.append(stranger)
        keyless_peer = Bus(BusConfig(connect=(ep,)))
        others.append(keyless_peer)
        assert _links(stranger) == 0 and _links(keyless_peer) == 0
        assert _links(node) == 1  # only the good one
        user, password = session_credentials(key)
        assert user == "fowt-hil" and len(password) == 64 and password not in key.hex()
    finally:
        for bus in others:
            bus.close()
        node.close()


def _client(mode: str, duration_s: float, endpoints: tuple[str, ...], **env: str) -> Any:
    return subprocess.Popen(
        [sys.executable, str(CLIENT), mode, str(duration_s), *endpoints],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, **env},
    )


def _report(proc: Any) -> dict[str, int]:
    out, _ = proc.communicate(timeout=120)
    assert proc.returncode == 0, out
    return json.loads(out.strip().splitlines()[-1])


def test_the_keyless_client_gets_a_session_on_an_unauthenticated_node() -> None:
    ep = free_tcp_endpoint()
    node = Bus(BusConfig(listen=(ep,)))
    got: list[bytes] = []
    node.subscribe("fowt/**", lambda _k, p: got.append(p))
    try:
        report = _report(_client("flood", 1.0, (ep,)))
    finally:
        node.close()
    assert report["sessions"] == 1 and report["puts"] > 0, report
    assert len(got) > 0


# ---------------------------------------------------------------------- end to end


def _captured(key: bytes, cycles: int) -> bytes:
    """What a capture of the run's own traffic holds: payloads signed with its key."""
    out: list[tuple[str, bytes]] = []
    for seq in range(cycles):
        frame = msgspec.structs.replace(
            sensor_frame(100.0, 0.01, 20_000.0, seq=seq, valid_mask=0b11111),
            sample_time_ns=seq * 10_000_000,
        )
        out.append(("fowt/t1/sensors", sign(key, "fowt/t1/sensors", SENSORS.codec.encode(frame))))
        cmd = ActuatorCommand(
            seq=seq,
            answered_seq=seq,
            sample_time_ns=seq * 10_000_000,
            publish_time_ns=seq,
            mode=0,
            blade_pitch_commanded_rad=0.2,
            generator_torque_commanded_nm=30_000.0,
        )
        out.append(("fowt/t1/command", sign(key, "fowt/t1/command", COMMAND.codec.encode(cmd))))
    return msgspec.msgpack.encode(out)


def _run_beside(tmp_path: Path, mode: str, lockstep: bool, duration_s: float) -> None:
    out = tmp_path / mode
    out.mkdir()
    key_args = key_file_args(out)
    endpoints = two_endpoints()
    nodes = lockstep_node_cmds(SCENARIO, duration_s, out, endpoints, key_args)
    if not lockstep:
        plant = nodes["plant"]
        i = plant.index("--mode")
        nodes["plant"] = plant[:i] + plant[i + 2 :]
    env = {}
    if mode == "replay":
        replay = out / "captured.msgpack"
        replay.write_bytes(_captured(read_key_file(Path(key_args[1])), 200))
        env["FOWT_REPLAY_FILE"] = str(replay)
    # The client starts first (a subscriber waiting for the controller's endpoint) and
    # keeps trying for longer than the run can last.
    client = _client(mode, 40.0 if lockstep else duration_s + 20.0, endpoints, **env)
    try:
        with NodeProcesses(out) as procs:
            for name, cmd in nodes.items():
                procs.start(name, cmd)
            codes = procs.wait(timeout=240)
            logs = procs.logs()
    finally:
        report = _report(client)
    assert codes == dict.fromkeys(codes, 0), logs
    assert report["attempts"] > 10 and report["sessions"] == 0, report
    assert report["puts"] == 0 and report["received"] == 0, report
    run = read_run(out / "run.mcap")
    cycles = round(duration_s / 0.01)
    for topic in PER_CYCLE:
        seqs = [m["seq"] for m in run.topic(topic)]
        assert seqs == list(range(cycles)), (topic, len(seqs))
    assert ast.literal_eval(run.metadata["recorder"]["rejected"]) == {}
    assert run.metadata["recorder"]["first_cycle_recorded"] == "0"


@pytest.mark.e2e
@pytest.mark.parametrize("mode", ["replay", "subscribe"])
def test_a_keyless_client_cannot_touch_a_lockstep_run(tmp_path: Path, mode: str) -> None:
    _run_beside(tmp_path, mode, lockstep=True, duration_s=10.0)


@pytest.mark.e2e
def test_a_keyless_flood_cannot_stop_a_realtime_run(tmp_path: Path) -> None:
    _run_beside(tmp_path, "flood", lockstep=False, duration_s=5.0)


@pytest.mark.e2e
def test_fowt_run_removes_the_key_unless_asked_to_keep_it(tmp_path: Path) -> None:
    from _helpers import fowt

    for keep in (False, True):
        out = tmp_path / f"keep{keep}"
        args = ["run", SCENARIO, "--mode", "lockstep", "--duration", "2", "--out", str(out)]
        proc = fowt(*args, "--no-plots", *(["--keep-key"] if keep else []), timeout=180)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert (out / "run.key").exists() == keep
        meta = read_run(out / "run.mcap").metadata["recorder"]
        assert meta["authenticated"] == "true" and meta["session_authenticated"] == "true"
        assert "unauthenticated" not in proc.stdout


@pytest.mark.e2e
def test_an_insecure_run_warns_and_says_so_in_its_recording_and_review(tmp_path: Path) -> None:
    from _helpers import fowt

    endpoints = two_endpoints()
    nodes = lockstep_node_cmds(SCENARIO, 2.0, tmp_path, endpoints, ["--insecure"])
    with NodeProcesses(tmp_path) as procs:
        for name, cmd in nodes.items():
            procs.start(name, cmd)
        codes = procs.wait(timeout=180)
        logs = procs.logs()
    assert codes == dict.fromkeys(codes, 0), logs
    for log in logs.values():
        assert "warning: --insecure" in log
    meta = read_run(tmp_path / "run.mcap").metadata["recorder"]
    assert meta["authenticated"] == "false" and meta["session_authenticated"] == "false"
    review = fowt("review", str(tmp_path / "run.mcap"), "--no-plots", "--json")
    assert review.returncode == 0, review.stderr
    assert json.loads(review.stdout)["run"]["authenticated"] is False
    shown = fowt("review", str(tmp_path / "run.mcap"), "--no-plots", columns=200)
    assert "unauthenticated run" in shown.stdout


@pytest.mark.e2e
def test_a_controller_waiting_for_the_recorder_stops_on_sigterm(tmp_path: Path) -> None:
    """SIGTERM ends ``--await-recorder``'s wait (it used to run out its whole timeout)."""
    import signal
    import time

    cmd = [sys.executable, "-m", "hil", "controller", SCENARIO, "--duration", "5",
           "--listen", free_tcp_endpoint(), "--await-recorder", "600",
           *key_file_args(tmp_path)]  # fmt: skip
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        assert proc.stdout is not None
        for line in proc.stdout:  # no recorder comes: it waits
            if "waiting up to 600 s for the recorder" in line:
                break
        time.sleep(0.5)  # inside the wait, not before it
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=120)  # far below the 600 s it would wait
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
    assert "signal SIGTERM" in out or "SIGTERM" in out, out
