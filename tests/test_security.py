"""Security: defaults listen on loopback only, no multicast scouting, multi-host only by file.

* Real processes (marked ``e2e``): a plant, a controller and a recorder started as
  ``fowt run`` starts them; every TCP socket any of them listens on is on 127.0.0.1 or ::1
  (read from ``/proc/<pid>/net/tcp`` and ``tcp6``, keeping only the sockets whose inodes
  the process holds in ``/proc/<pid>/fd``), the plant listens on exactly its endpoint, the
  recorder on nothing, and none holds a UDP socket on the scouting port 7446 or on a
  non-loopback address.
* :class:`hil.nodes.bus.BusConfig` refuses a non-loopback endpoint with an error that names the
  endpoint and ``--zenoh-config``, unless a config file is given; so does the CLI.
* The multi-host example configs in ``config/`` parse as ``zenoh.Config`` (strictly: an
  unknown key or message type is an error) and say what ``docs/multi-host.md`` says: TLS
  only, mutual authentication, no scouting, clients that listen nowhere, and an access
  control that limits the plant and the controller to their own keys. They are run for
  real (router, plant, controller and recorder in two network namespaces) by
  ``test_multi_host.py``.
"""

from __future__ import annotations

import ipaddress
import json
import os
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import zenoh

from hil.nodes.bus import BusConfig, BusConfigError, free_tcp_endpoint
from hil.nodes.router import RouterConfigError, RouterPlan, load_router_config

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = {
    "router": ROOT / "config" / "zenoh-router.json5",
    "plant": ROOT / "config" / "zenoh-plant-router.json5",
    "controller": ROOT / "config" / "zenoh-controller-router.json5",
    "recorder": ROOT / "config" / "zenoh-recorder-router.json5",
}
SCOUTING_PORT = 7446
_TCP_LISTEN = "0A"


@dataclass(frozen=True)
class Sock:
    """One socket of a process as ``/proc/<pid>/net`` shows it."""

    proto: str
    address: ipaddress.IPv4Address | ipaddress.IPv6Address
    port: int
    state: str


def _decode(hex_addr: str) -> tuple[ipaddress.IPv4Address | ipaddress.IPv6Address, int]:
    """``0100007F:1F90`` (little-endian 32-bit words) -> (127.0.0.1, 8080)."""
    addr, port = hex_addr.split(":")
    raw = bytes.fromhex(addr)
    words = b"".join(raw[i : i + 4][::-1] for i in range(0, len(raw), 4))
    ip = ipaddress.IPv4Address(words) if len(raw) == 4 else ipaddress.IPv6Address(words)
    return ip, int(port, 16)


def sockets_of(pid: int) -> list[Sock]:
    """The TCP and UDP sockets (IPv4 and IPv6) the process ``pid`` holds open."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:  # closed meanwhile
            continue
        if target.startswith("socket:["):
            inodes.add(target[len("socket:[") : -1])
    found = []
    for proto in ("tcp", "tcp6", "udp", "udp6"):
        lines = Path(f"/proc/{pid}/net/{proto}").read_text().splitlines()[1:]
        for line in lines:
            cols = line.split()
            if cols[9] in inodes:
                ip, port = _decode(cols[1])
                found.append(Sock(proto, ip, port, cols[3]))
    return found


def test_proc_address_decoding() -> None:
    assert _decode("0100007F:1F90") == (ipaddress.IPv4Address("127.0.0.1"), 8080)
    assert _decode("00000000000000000000000001000000:0050") == (ipaddress.IPv6Address("::1"), 80)


def test_sockets_of_sees_this_process_listening() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        mine = sockets_of(os.getpid())
    assert Sock("tcp", ipaddress.IPv4Address("127.0.0.1"), port, _TCP_LISTEN) in mine


@pytest.mark.e2e
def test_nodes_listen_on_loopback_only_and_do_not_scout(tmp_path: Path) -> None:
    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    while ctrl_ep == plant_ep:
        ctrl_ep = free_tcp_endpoint()
    from _helpers import key_file_args

    key = key_file_args(tmp_path)
    base = [sys.executable, "-m", "hil"]
    cmds = {
        # The plant waits for a node that never comes here (the launcher's token), so all
        # three stay up and connected. (--require accepts only the bench's node names.)
        "plant": [
            *base,
            "plant",
            "nrel5mw-ramp",
            *key,
            "--listen",
            plant_ep,
            "--require",
            "controller,recorder,launcher",
        ],
        "controller": [
            *base,
            "controller",
            "nrel5mw-ramp",
            *key,
            "--listen",
            ctrl_ep,
            "--connect",
            plant_ep,
        ],
        "recorder": [
            *base,
            "record",
            "nrel5mw-ramp",
            *key,
            "--out",
            str(tmp_path / "run.mcap"),
            "--connect",
            plant_ep,
            "--connect",
            ctrl_ep,
        ],
    }
    procs = {
        name: subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
        for name, cmd in cmds.items()
    }
    try:
        # Connected: the plant holds an established link to the controller and recorder.
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            established = [s for s in sockets_of(procs["plant"].pid) if s.state == "01"]
            if len(established) >= 2:
                break
            time.sleep(0.2)
        assert len(established) >= 2, sockets_of(procs["plant"].pid)
        socks = {name: sockets_of(p.pid) for name, p in procs.items()}
        for p in procs.values():
            assert p.poll() is None  # all still up
    finally:
        for p in procs.values():
            p.kill()  # the plant ignores SIGTERM while it waits for peers (reported)
            p.wait(10)
    for name, mine in socks.items():
        listening = [s for s in mine if s.proto.startswith("tcp") and s.state == _TCP_LISTEN]
        for s in listening:
            assert s.address.is_loopback, (name, s)
        for s in mine:
            if s.proto.startswith("udp"):
                assert s.port != SCOUTING_PORT, (name, s)
                assert s.address.is_loopback, (name, s)
    port = {n: int(ep.rsplit(":", 1)[1]) for n, ep in (("plant", plant_ep), ("ctrl", ctrl_ep))}
    assert {(s.port, s.state) for s in socks["plant"] if s.state == _TCP_LISTEN} == {
        (port["plant"], _TCP_LISTEN)
    }
    assert [s.port for s in socks["controller"] if s.state == _TCP_LISTEN] == [port["ctrl"]]
    assert [s for s in socks["recorder"] if s.state == _TCP_LISTEN] == []


def test_default_zenoh_config_is_peer_without_scouting() -> None:
    conf = BusConfig(listen=("tcp/127.0.0.1:7447",)).zenoh_config()
    assert json.loads(conf.get_json("mode")) == "peer"
    assert json.loads(conf.get_json("scouting/multicast/enabled")) is False
    assert json.loads(conf.get_json("scouting/gossip/enabled")) is False
    assert json.loads(conf.get_json("listen/endpoints")) == ["tcp/127.0.0.1:7447"]
    # Zenoh's own default for a peer is tcp/[::]:0 (every interface): a node given no
    # endpoint must listen nowhere instead.
    assert json.loads(BusConfig().zenoh_config().get_json("listen/endpoints")) == []


@pytest.mark.parametrize(
    "endpoint",
    [
        "tcp/0.0.0.0:7447",
        "tcp/[::]:7447",
        "tcp/192.168.1.20:7447",
        "udp/10.0.0.1:7447",
        "tls/0.0.0.0:7447",
        "tcp/example.com:7447",
    ],
)
def test_non_loopback_endpoint_is_refused_without_a_config_file(endpoint: str) -> None:
    for kwargs in ({"listen": (endpoint,)}, {"connect": (endpoint,)}):
        with pytest.raises(BusConfigError, match="loopback") as info:
            BusConfig(**kwargs)  # type: ignore[arg-type]
        assert endpoint in str(info.value)
    with pytest.raises(BusConfigError, match="--zenoh-config"):
        BusConfig(listen=("tcp/0.0.0.0:7447",))
    # With a config file the endpoint is the file's business (not checked, not opened here).
    BusConfig(listen=(endpoint,), config_file=CONFIGS["router"])


@pytest.mark.parametrize("endpoint", ["tcp/127.0.0.1:7447", "tcp/[::1]:7447", "tcp/127.0.0.2:1"])
def test_loopback_endpoints_are_accepted(endpoint: str) -> None:
    BusConfig(listen=(endpoint,), connect=(endpoint,))


def test_cli_refuses_a_non_loopback_listen() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "hil", "plant", "nrel5mw-ramp", "--listen", "tcp/0.0.0.0:7447"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 2
    out = " ".join((proc.stdout + proc.stderr).split())
    assert "tcp/0.0.0.0:7447" in out
    assert "--zenoh-config" in out


# ------------------------------------------------------------------ multi-host configs


def _conf(name: str) -> zenoh.Config:
    return zenoh.Config.from_file(str(CONFIGS[name]))


def _get(conf: zenoh.Config, key: str) -> Any:
    return json.loads(conf.get_json(key))


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_multi_host_config_parses_with_tls_and_without_scouting(name: str) -> None:
    conf = _conf(name)
    assert _get(conf, "scouting/multicast/enabled") is False
    assert _get(conf, "scouting/gossip/enabled") is False
    assert _get(conf, "transport/link/protocols") == ["tls"]
    # Router and clients must agree on the transport (the bench's low-latency one).
    assert _get(conf, "transport/unicast/lowlatency") is True
    assert _get(conf, "transport/unicast/qos/enabled") is False
    assert _get(conf, "transport/link/tls/enable_mtls") is True
    assert _get(conf, "transport/link/tls/root_ca_certificate")
    endpoints = _get(conf, "listen/endpoints") + _get(conf, "connect/endpoints")
    assert endpoints
    assert all(ep.startswith("tls/") for ep in endpoints)
    if name == "router":
        assert _get(conf, "mode") == "router"
        assert _get(conf, "transport/link/tls/listen_certificate")
        assert _get(conf, "transport/link/tls/listen_private_key")
    else:
        assert _get(conf, "mode") == "client"
        assert _get(conf, "listen/endpoints") == []  # a client opens no listening socket
        assert _get(conf, "transport/link/tls/connect_certificate")
        assert _get(conf, "transport/link/tls/connect_private_key")


def test_zenoh_config_parsing_is_strict(tmp_path: Path) -> None:
    """An unknown message type in a rule is an error: the parse test above means something."""
    bad = tmp_path / "bad.json5"
    bad.write_text(CONFIGS["router"].read_text().replace('"liveliness_query"', '"subscribe"'))
    with pytest.raises(Exception, match="subscribe"):
        zenoh.Config.from_file(str(bad))


def _allowed(acl: dict[str, Any], subject: str, flow: str, message: str) -> set[str]:
    """Key expressions ``subject`` is allowed ``message`` on, in ``flow``."""
    rules = {r["id"]: r for r in acl["rules"]}
    keys: set[str] = set()
    for policy in acl["policies"]:
        if subject not in policy["subjects"]:
            continue
        for rid in policy["rules"]:
            rule = rules[rid]
            if (
                rule["permission"] == "allow"
                and flow in rule.get("flows", ["ingress", "egress"])
                and message in rule["messages"]
            ):
                keys.update(rule["key_exprs"])
    return keys


def test_router_access_control_limits_each_node_to_its_keys() -> None:
    acl = _get(_conf("router"), "access_control")
    assert acl["enabled"] is True
    assert acl["default_permission"] == "deny"
    assert not [r for r in acl["rules"] if r["permission"] != "allow"]
    subjects = {s["id"]: s for s in acl["subjects"]}
    rule_ids = {r["id"] for r in acl["rules"]}
    for policy in acl["policies"]:
        assert set(policy["subjects"]) <= set(subjects)
        assert set(policy["rules"]) <= rule_ids
    assert subjects["plant"]["cert_common_names"] == ["fowt-plant"]
    assert subjects["controller"]["cert_common_names"] == ["fowt-controller"]
    assert subjects["recorder"]["cert_common_names"] == ["fowt-recorder"]

    def puts(s: str) -> set[str]:
        return _allowed(acl, s, "ingress", "put")

    def subs(s: str) -> set[str]:
        return _allowed(acl, s, "ingress", "declare_subscriber")

    assert puts("plant") == {"fowt/t1/sensors", "fowt/t1/truth", "fowt/t1/timing/**"}
    assert subs("plant") == {"fowt/t1/command"}
    assert _allowed(acl, "plant", "egress", "put") == {"fowt/t1/command"}
    assert puts("controller") == {"fowt/t1/command", "fowt/t1/controller/**"}
    assert subs("controller") == {"fowt/t1/sensors", "fowt/t1/timing/summary"}
    assert _allowed(acl, "controller", "egress", "put") == subs("controller")
    assert puts("recorder") == set()
    assert subs("recorder") == {"fowt/t1/**"}
    for subject in ("plant", "controller", "recorder"):
        assert _allowed(acl, subject, "ingress", "liveliness_token") == {"fowt/t1/alive/**"}
        assert _allowed(acl, subject, "ingress", "declare_queryable") == set()


# ------------------------------------------------------------------ fowt router


def test_router_plan_of_the_shipped_router_config() -> None:
    _, plan = load_router_config(CONFIGS["router"])
    assert plan == RouterPlan(
        listen=("tls/<ROUTER_ADDR>:7447",),
        access_control=True,
        default_permission="deny",
        mtls=True,
        protocols=("tls",),
    )
    assert plan.warnings() == []


def test_router_refuses_what_is_not_a_router_config(tmp_path: Path) -> None:
    with pytest.raises(RouterConfigError, match=r"mode is 'client'; expected \"router\""):
        load_router_config(CONFIGS["plant"])
    with pytest.raises(RouterConfigError, match="no such file"):
        load_router_config(tmp_path / "absent.json5")
    binary = tmp_path / "binary.json5"
    binary.write_bytes(bytes(range(256)))
    with pytest.raises(RouterConfigError, match="not a valid Zenoh config"):
        load_router_config(binary)
    deaf = tmp_path / "deaf.json5"
    deaf.write_text('{mode: "router", listen: {endpoints: []}}')
    with pytest.raises(RouterConfigError, match="listen/endpoints is empty"):
        load_router_config(deaf)


def test_router_warns_when_the_file_leaves_the_bench_open(tmp_path: Path) -> None:
    text = CONFIGS["router"].read_text()
    open_file = tmp_path / "open.json5"
    open_file.write_text(
        text.replace(
            "enabled: true,\n    default_permission", "enabled: false,\n    default_permission"
        ).replace("enable_mtls: true", "enable_mtls: false")
    )
    _, plan = load_router_config(open_file)
    warnings = plan.warnings()
    assert any("access control is off" in w for w in warnings)
    assert any("mutual TLS is off" in w for w in warnings)


def test_router_cli_refuses_a_client_config_in_one_line() -> None:
    r = subprocess.run(
        [sys.executable, "-m", "hil", "router", "--zenoh-config", str(CONFIGS["plant"])],
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, "COLUMNS": "200"},
    )
    assert r.returncode == 2
    assert "Traceback" not in r.stdout + r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), r.stderr
    assert "mode is 'client'; expected \"router\"" in lines[0]


def test_bus_config_describes_the_endpoints_a_config_file_gives() -> None:
    assert BusConfig(listen=("tcp/127.0.0.1:7447",)).describe() == (
        "listen ['tcp/127.0.0.1:7447'], connect []"
    )
    text = BusConfig(config_file=CONFIGS["plant"]).describe()
    assert text.startswith("listen [], connect ['tls/<ROUTER_ADDR>:7447'], config ")
    moved = BusConfig(connect=("tls/192.0.2.1:7447",), config_file=CONFIGS["plant"])
    assert "connect ['tls/192.0.2.1:7447']" in moved.describe()
