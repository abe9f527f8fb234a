"""The two-host set-up of ``docs/multi-host.md`` run for real, in two network namespaces.

The test makes two network namespaces joined by a veth pair; their private addresses
(:data:`ADDR_A`, :data:`ADDR_B`) exist only inside them, and nothing is sent on the host's
interfaces. Host A runs the router (``fowt router`` with ``config/zenoh-router.json5``:
mutual TLS, access control with default deny) and the plant; host B the controller and
the recorder. Certificates come from the shell block of ``docs/multi-host.md`` itself
(run with bash and the test's router address), the configs are the shipped files with
their placeholders filled in, so the document and the files are what is tested.

* A lock-step run of :data:`SCENARIO` for :data:`DURATION_S` simulated seconds across the
  two hosts gives the same KPIs as the same run on one host (``fowt run --mode
  lockstep``), to a relative 1e-12 (lock-step is deterministic: both are bit-identical
  here; the tolerance only allows for a different summation order), every message type
  recorded as often as on one host, no deadline miss, no message of the run refused by
  the access control, and the run's traffic crossed the veth pair.
* A client whose certificate another CA signed (with the plant's common name) and a
  client with no certificate are refused: the session does not open, and the router
  logs one refusal per attempt (``invalid peer certificate: UnknownIssuer``, ``peer sent
  no certificates``), counted here; the same probe with the plant's real certificate opens.
* A client with the controller's certificate putting on the plant's keys
  (``fowt/t1/sensors``, ``fowt/t1/truth``) reaches no subscriber (0 of
  :data:`ACL_PUTS` each, while all its puts on its own keys arrive), and the router's
  access control logs each refused put (counted from its trace lines).

Skips, saying why, where namespaces cannot be made (not root, no ``ip``/``openssl``/
``bash``, ``ip netns add`` refused).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from hil.review import review
from hil.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "multi-host.md"
PROBE = Path(__file__).with_name("_zenoh_probe.py")
CONFIG_FILES = {
    "router": ROOT / "config" / "zenoh-router.json5",
    "plant": ROOT / "config" / "zenoh-plant-router.json5",
    "controller": ROOT / "config" / "zenoh-controller-router.json5",
    "recorder": ROOT / "config" / "zenoh-recorder-router.json5",
}
#: Addresses of the two namespaces' veth ends (they exist only inside the namespaces).
ADDR_A, ADDR_B = "10.147.0.1", "10.147.0.2"
SCENARIO = "default"  # IEA 15 MW on VolturnUS-S, turbulent wind and irregular waves
DURATION_S = 10.0
ACL_PUTS = 20
#: Every Zenoh log line of the router with these modules' levels (ACL decisions are TRACE).
ROUTER_LOG = "warn,zenoh::net::routing::interceptor::access_control=trace"
_ANSI = re.compile(r"\x1b\[[0-9;]*m")

pytestmark = pytest.mark.e2e


def _skip_reason() -> str | None:
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        return "creating network namespaces (ip netns add) needs root"
    for tool in ("ip", "openssl", "bash"):
        if shutil.which(tool) is None:
            return f"needs {tool!r} on PATH (iproute2, OpenSSL 3, bash)"
    return None


def _run(cmd: list[str], **kw: Any) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, capture_output=True, text=True, check=False, **kw)


def _must(cmd: list[str], **kw: Any) -> str:
    r = _run(cmd, **kw)
    assert r.returncode == 0, f"{' '.join(cmd)} exited {r.returncode}:\n{r.stdout}{r.stderr}"
    return r.stdout


def doc_certificate_script() -> str:
    """The OpenSSL shell block of ``docs/multi-host.md`` (it starts ``ROUTER_ADDR=``)."""
    m = re.search(r"```sh\n(ROUTER_ADDR=.*?)```", DOC.read_text(), re.S)
    assert m, f"{DOC}: no ```sh block starting with ROUTER_ADDR="
    return m.group(1)


def fill_config(src: Path, dst: Path, router_addr: str, tls_dir: Path) -> Path:
    """A shipped config with ``<ROUTER_ADDR>`` and ``/etc/fowt/tls/`` filled in."""
    text = src.read_text().replace("<ROUTER_ADDR>", router_addr)
    dst.write_text(text.replace("/etc/fowt/tls/", f"{tls_dir}/"))
    return dst


@dataclass
class TwoHosts:
    """Two namespaces joined by a veth pair, certificates, configs and the running router."""

    ns_a: str
    ns_b: str
    veth_b: str
    work: Path
    tls: Path
    configs: dict[str, Path]
    router_log: Path
    procs: list[subprocess.Popen[str]] = field(default_factory=list)

    def cmd(self, ns: str, argv: list[str]) -> list[str]:
        return ["ip", "netns", "exec", ns, *argv]

    def start(self, ns: str, argv: list[str], log: Path, **env: str) -> subprocess.Popen[str]:
        out = log.open("w")
        p = subprocess.Popen(
            self.cmd(ns, argv),
            stdout=out,
            stderr=subprocess.STDOUT,
            text=True,
            cwd=ROOT,
            env={**os.environ, "PYTHONUNBUFFERED": "1", **env},
            start_new_session=True,
        )
        out.close()
        self.procs.append(p)
        return p

    def log_lines(self) -> list[str]:
        return _ANSI.sub("", self.router_log.read_text()).splitlines()

    def rx_bytes(self) -> int:
        """Bytes host B's veth end has received."""
        link = json.loads(_must(["ip", "-n", self.ns_b, "-s", "-j", "link", "show", self.veth_b]))
        return int(link[0]["stats64"]["rx"]["bytes"])


def _stop(p: subprocess.Popen[str]) -> None:
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(10)


@pytest.fixture(scope="module")
def two_hosts(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TwoHosts]:
    reason = _skip_reason()
    if reason:
        pytest.skip(reason)
    work = tmp_path_factory.mktemp("multihost")
    tag = f"{os.getpid()}"
    ns_a, ns_b = f"fowt-mh{tag}-a", f"fowt-mh{tag}-b"
    created: list[str] = []
    hosts: TwoHosts | None = None
    try:
        for ns in (ns_a, ns_b):
            r = _run(["ip", "netns", "add", ns])
            if r.returncode != 0:
                pytest.skip(f"cannot create a network namespace: ip netns add: {r.stderr.strip()}")
            created.append(ns)
        # The veth pair is made inside the two namespaces (no interface on the host).
        _must(
            [
                "ip",
                "link",
                "add",
                "va",
                "netns",
                ns_a,
                "type",
                "veth",
                "peer",
                "name",
                "vb",
                "netns",
                ns_b,
            ]
        )
        for ns, dev, addr in ((ns_a, "va", ADDR_A), (ns_b, "vb", ADDR_B)):
            _must(["ip", "-n", ns, "addr", "add", f"{addr}/24", "dev", dev])
            _must(["ip", "-n", ns, "link", "set", dev, "up"])
            _must(["ip", "-n", ns, "link", "set", "lo", "up"])
        # Certificates exactly as docs/multi-host.md makes them.
        _must(
            ["bash", "-euo", "pipefail", "-c", doc_certificate_script()],
            cwd=work,
            env={**os.environ, "ROUTER_ADDR": ADDR_A},
        )
        tls = work / "tls"
        configs = {
            name: fill_config(src, work / f"{name}.json5", ADDR_A, tls)
            for name, src in CONFIG_FILES.items()
        }
        hosts = TwoHosts(ns_a, ns_b, "vb", work, tls, configs, work / "router.log")
        router = hosts.start(
            ns_a,
            [sys.executable, "-m", "hil", "router", "--zenoh-config", str(configs["router"])],
            hosts.router_log,
            RUST_LOG=ROUTER_LOG,
        )
        deadline = time.monotonic() + 30.0
        while not any("listening on" in line for line in hosts.log_lines()):
            assert router.poll() is None, f"router exited:\n{hosts.router_log.read_text()}"
            assert time.monotonic() < deadline, f"router not up:\n{hosts.router_log.read_text()}"
            time.sleep(0.1)
        yield hosts
    finally:
        if hosts is not None:
            for p in hosts.procs:
                _stop(p)
        for ns in created:
            _run(["ip", "netns", "del", ns])


def _kpis(summary: dict[str, Any]) -> dict[str, float]:
    return {k: v for k, v in summary["kpi"].items() if isinstance(v, int | float)}


def test_lockstep_run_across_two_hosts_equals_one_host_run(
    two_hosts: TwoHosts, tmp_path: Path
) -> None:
    h = two_hosts
    dur = ["--duration", repr(DURATION_S)]
    one = tmp_path / "one"
    # The one-host lock-step run (loopback of this namespace) goes alongside the other.
    one_host = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "hil",
            "run",
            SCENARIO,
            "--mode",
            "lockstep",
            *dur,
            "--out",
            str(one),
            "--no-plots",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        cwd=ROOT,
    )
    h.procs.append(one_host)  # stopped at teardown if a failure leaves it running
    two = tmp_path / "two"
    two.mkdir()
    mcap = two / "run.mcap"
    log_before = len(h.log_lines())
    rx_before = h.rx_bytes()
    fowt = [sys.executable, "-m", "hil"]
    ctrl = h.start(
        h.ns_b,
        [*fowt, "controller", SCENARIO, *dur, "--zenoh-config", str(h.configs["controller"])],
        two / "controller.log",
    )
    rec = h.start(
        h.ns_b,
        [
            *fowt,
            "record",
            SCENARIO,
            *dur,
            "--out",
            str(mcap),
            "--zenoh-config",
            str(h.configs["recorder"]),
        ],
        two / "recorder.log",
    )
    plant = h.start(
        h.ns_a,
        [
            *fowt,
            "plant",
            SCENARIO,
            *dur,
            "--mode",
            "lockstep",
            "--zenoh-config",
            str(h.configs["plant"]),
            "--require",
            "controller,recorder",
        ],
        two / "plant.log",
    )
    for name, p, timeout in (
        ("plant", plant, 180),
        ("controller", ctrl, 30),
        ("recorder", rec, 30),
    ):
        try:
            rc = p.wait(timeout)
        except subprocess.TimeoutExpired:
            rc = None
        assert rc == 0, f"{name} exited {rc}:\n{(two / f'{name}.log').read_text()}"
    one_out, _ = one_host.communicate(timeout=300)
    assert one_host.returncode == 0, one_out
    # The plant really reached the router through the veth pair (not a loopback shortcut).
    plant_log = (two / "plant.log").read_text()
    assert "plant done" in plant_log
    assert h.rx_bytes() - rx_before > 100_000

    want = review(one / "run.mcap", tmp_path / "review-one", plots=False)
    got = review(mcap, tmp_path / "review-two", plots=False)
    assert got["run"]["messages"] == want["run"]["messages"]
    cycles = round(DURATION_S / load_scenario(SCENARIO).timing.control_period_s)
    assert got["timing"]["cycles"] == want["timing"]["cycles"] == cycles
    assert got["timing"]["cycles_logged"] == cycles
    assert got["timing"]["deadline_misses"] == 0
    assert got["run"]["truncated"] is False
    assert _kpis(got) == pytest.approx(_kpis(want), rel=1e-12, abs=0.0)
    assert _kpis(got)["mean_power_w"] > 1e6  # a turbine producing power, not an empty run
    # The deny-by-default access control let every message of the run through.
    refused = [ln for ln in h.log_lines()[log_before:] if "Using cached result" in ln]
    refused = [ln for ln in refused if " is unauthorized to " in ln]
    assert refused == []


def _probe_open(h: TwoHosts, config: Path) -> dict[str, Any]:
    r = _run(h.cmd(h.ns_b, [sys.executable, str(PROBE), "open", str(config)]), cwd=ROOT)
    assert r.returncode in (0, 1), r.stderr
    out: dict[str, Any] = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["opened"] is (r.returncode == 0)
    return out


def _openssl_cert(work: Path, name: str, cn: str) -> tuple[Path, Path]:
    """A CA of its own (not the bench's) and a client certificate ``cn`` it signs."""
    d = work / name
    d.mkdir()
    ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]
    _must(
        [
            "openssl",
            "req",
            "-x509",
            *ec,
            "-days",
            "1",
            "-keyout",
            "ca-key.pem",
            "-out",
            "ca.pem",
            "-subj",
            f"/CN={name}-ca",
            "-addext",
            "basicConstraints=critical,CA:TRUE",
        ],
        cwd=d,
    )
    _must(
        ["openssl", "req", *ec, "-keyout", "key.pem", "-out", "c.csr", "-subj", f"/CN={cn}"], cwd=d
    )
    (d / "ext").write_text(
        "subjectAltName=DNS:fowt-plant\nbasicConstraints=CA:FALSE\n"
        "extendedKeyUsage=serverAuth,clientAuth\n"
    )
    _must(
        [
            "openssl",
            "x509",
            "-req",
            "-in",
            "c.csr",
            "-CA",
            "ca.pem",
            "-CAkey",
            "ca-key.pem",
            "-CAcreateserial",
            "-days",
            "1",
            "-out",
            "cert.pem",
            "-extfile",
            "ext",
        ],
        cwd=d,
    )
    return d / "cert.pem", d / "key.pem"


def _count(lines: list[str], needle: str) -> int:
    return sum(needle in ln for ln in lines)


def test_client_without_a_valid_certificate_is_refused(two_hosts: TwoHosts) -> None:
    h = two_hosts
    plant_conf = h.configs["plant"].read_text()
    cert, key = _openssl_cert(h.work, "rogue", "fowt-plant")
    rogue = h.work / "rogue.json5"
    rogue.write_text(
        plant_conf.replace(f"{h.tls}/plant.pem", str(cert)).replace(
            f"{h.tls}/plant-key.pem", str(key)
        )
    )
    nocert = h.work / "nocert.json5"
    text = re.sub(r"\n\s*connect_(certificate|private_key): [^\n]*", "", plant_conf)
    nocert.write_text(text.replace("enable_mtls: true", "enable_mtls: false"))
    assert "plant.pem" not in nocert.read_text() and str(cert) in rogue.read_text()

    # The probe itself works: with the plant's certificate it opens through the router.
    ok = _probe_open(h, h.configs["plant"])
    assert ok["opened"] and ok["routers"] == 1, ok

    attempts = 2
    marks = {"rogue": "UnknownIssuer", "nocert": "peer sent no certificates"}
    before = {k: _count(h.log_lines(), m) for k, m in marks.items()}
    for _ in range(attempts):
        for config in (rogue, nocert):
            out = _probe_open(h, config)
            assert not out["opened"] and "Unable to connect" in out["error"], out
    time.sleep(0.5)  # the router's log line may trail the client's error
    after = {k: _count(h.log_lines(), m) for k, m in marks.items()}
    refused = {k: after[k] - before[k] for k in marks}
    assert refused == {"rogue": attempts, "nocert": attempts}, h.log_lines()[-10:]


def test_client_publishing_outside_its_acl_is_refused(two_hosts: TwoHosts) -> None:
    h = two_hosts
    outside = ["fowt/t1/sensors", "fowt/t1/truth"]  # the plant's keys
    inside = ["fowt/t1/controller/status", "fowt/t1/command"]  # the controller's own
    r = _run(
        h.cmd(
            h.ns_b,
            [
                sys.executable,
                str(PROBE),
                "acl",
                str(h.configs["recorder"]),
                str(h.configs["controller"]),
                str(ACL_PUTS),
                *outside,
                *inside,
            ],
        ),
        cwd=ROOT,
        timeout=60,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    out = json.loads(r.stdout.strip().splitlines()[-1])
    delivered = out["delivered"]
    assert {k: delivered[k] for k in inside} == dict.fromkeys(inside, ACL_PUTS)
    assert {k: delivered[k] for k in outside} == dict.fromkeys(outside, 0)
    zid = out["publisher_zid"]
    lines = h.log_lines()
    refused = {
        k: _count(lines, f"Using cached result: {zid} is unauthorized to Put (ingress) on {k}")
        for k in outside
    }
    assert refused == dict.fromkeys(outside, ACL_PUTS)
    allowed = {
        k: _count(lines, f"Using cached result: {zid} is authorized to Put (ingress) on {k}")
        for k in inside
    }
    assert allowed == dict.fromkeys(inside, ACL_PUTS)
