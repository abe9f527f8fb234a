"""A plant starts only when the recorder can get every node's messages (hil.nodes.bus).

Zenoh peers do not route for each other: the recorder connects to the plant's and the
controller's endpoints, and its connection to an endpoint nobody listens on yet is retried
later. Here the order makes that happen every time: the plant listens first, the recorder
starts (its link to the plant comes up at once, the one to the controller fails), then the
controller starts listening. The plant sees the recorder's token and, with
``--await-recorder``, the controller's only once the recorder's subscription has reached the
controller: the file must hold every cycle's command and status.

Real processes on free loopback ports, a real MCAP file; :func:`hil.nodes.bus.wait_matched`
itself on two real sessions.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from _helpers import NodeProcesses, key_file_args, lockstep_node_cmds, two_endpoints

from hil.nodes.bus import Bus, BusConfig, free_tcp_endpoint, wait_matched
from hil.runlog.mcap_io import read_run

DURATION_S = 6.0
CYCLES = 240  # the default scenario's 0.025 s control period


def test_wait_matched_says_when_a_subscriber_is_reachable() -> None:
    ep = free_tcp_endpoint()
    pub_bus = Bus(BusConfig(listen=(ep,)))
    sub_bus: Bus | None = None
    try:
        pub = pub_bus.publisher("fowt/test/readiness")
        t0 = time.monotonic()
        assert not wait_matched(pub, 0.2)  # nobody subscribes: False after the timeout
        assert time.monotonic() - t0 >= 0.2
        sub_bus = Bus(BusConfig(connect=(ep,)))
        sub_bus.subscribe("fowt/test/**", lambda _k, _p: None)
        assert wait_matched(pub, 10.0)
    finally:
        if sub_bus is not None:
            sub_bus.close()
        pub_bus.close()


def _wait_for_line(path: Path, text: str, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if path.exists() and text in path.read_text():
            return
        time.sleep(0.05)
    raise AssertionError(f"{path.name}: no {text!r} within {timeout_s} s")


@pytest.mark.e2e
def test_a_recorder_whose_link_to_the_controller_comes_late_records_every_cycle(
    tmp_path: Path,
) -> None:
    cmds = lockstep_node_cmds(
        "default", DURATION_S, tmp_path, two_endpoints(), key_file_args(tmp_path)
    )
    assert "--await-recorder" in cmds["controller"]
    with NodeProcesses(tmp_path) as nodes:
        nodes.start("plant", cmds["plant"])
        _wait_for_line(tmp_path / "plant.log", "plant waiting for", 60.0)
        nodes.start("recorder", cmds["recorder"])
        # its session is open: its connection to the controller's endpoint has failed
        _wait_for_line(tmp_path / "recorder.log", "recorder writing", 60.0)
        nodes.start("controller", cmds["controller"])
        codes = nodes.wait(timeout=180)
    logs = nodes.logs()
    assert codes == dict.fromkeys(codes, 0), logs
    assert "no recorder reached" not in logs["controller"], logs["controller"]
    run = read_run(tmp_path / "run.mcap")
    for suffix in ("sensors", "truth", "command", "controller/status", "timing/cycle"):
        assert len(run.topic(suffix)) == CYCLES, (suffix, logs)
    assert [c["answered_seq"] for c in run.topic("command")] == list(range(CYCLES))
