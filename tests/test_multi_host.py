"""The two-host set-up of ``docs/multi-host.md`` run for real, in two network namespaces.

The test makes two network namespaces joined by a veth pair (``_two_hosts.py``); their
private addresses (``10.147.0.1`` and ``.2``) exist only inside them, and nothing is sent
on the host's interfaces. Host A runs the router (``fowt router`` with
``config/zenoh-router.json5``: mutual TLS, access control with default deny) and the
plant; host B the controller and the recorder. Certificates come from the shell block of
``docs/multi-host.md`` itself (run with bash and the test's router address), the configs
are the shipped files with their placeholders filled in, so the document and the files
are what is tested.

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
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from _two_hosts import ADDR_A, NamespacesUnavailableError, TwoHosts, must, run, two_hosts

from hil.review.core import review
from hil.scenario.schema import load_scenario

ROOT = Path(__file__).resolve().parents[1]
PROBE = Path(__file__).with_name("_zenoh_probe.py")
SCENARIO = "default"  # IEA 15 MW on VolturnUS-S, turbulent wind and irregular waves
DURATION_S = 10.0
ACL_PUTS = 20

pytestmark = pytest.mark.e2e


@pytest.fixture(scope="module")
def hosts(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TwoHosts]:
    try:
        with two_hosts(tmp_path_factory.mktemp("multihost")) as h:
            yield h
    except NamespacesUnavailableError as exc:
        pytest.skip(f"two network namespaces cannot be made here: {exc}")


def _kpis(summary: dict[str, Any]) -> dict[str, float]:
    return {k: v for k, v in summary["kpi"].items() if isinstance(v, int | float)}


def test_lockstep_run_across_two_hosts_equals_one_host_run(hosts: TwoHosts, tmp_path: Path) -> None:
    h = hosts
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
            "--duration",
            repr(DURATION_S),
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
    log_before = len(h.log_lines())
    rx_before = h.rx_bytes()
    mcap = h.lockstep_run(SCENARIO, DURATION_S, tmp_path / "two")
    one_out, _ = one_host.communicate(timeout=300)
    assert one_host.returncode == 0, one_out
    plant_log = (tmp_path / "two" / "plant.log").read_text()
    assert "plant done" in plant_log
    # The plant listened nowhere and connected only to the router (the file's endpoints).
    assert f"listen [], connect ['tls/{ADDR_A}:7447']" in plant_log
    # The run's traffic crossed the veth pair (controller and recorder are in the other
    # namespace, whose only way out is that pair).
    assert h.rx_bytes() - rx_before > 100_000

    want = review(one / "run.mcap", tmp_path / "review-one", plots=False)
    got = review(mcap, tmp_path / "review-two", plots=False)
    assert got["run"]["messages"] == want["run"]["messages"]
    cycles = round(DURATION_S / load_scenario(SCENARIO).timing.control_period_s)
    assert got["timing"]["cycles"] == want["timing"]["cycles"] == cycles
    assert got["timing"]["cycles_logged"] == cycles
    assert got["timing"]["deadline_misses"] == 0
    assert got["run"]["truncated"] is False
    assert got["kpi"].keys() == want["kpi"].keys()
    assert _kpis(got) == pytest.approx(_kpis(want), rel=1e-12, abs=0.0)
    assert _kpis(got)["mean_power_w"] > 1e6  # a turbine producing power, not an empty run
    # The deny-by-default access control let every message of the run through.
    refused = [ln for ln in h.log_lines()[log_before:] if "Using cached result" in ln]
    refused = [ln for ln in refused if " is unauthorized to " in ln]
    assert refused == []


def _probe_open(h: TwoHosts, config: Path) -> dict[str, Any]:
    r = run(h.cmd(h.ns_b, [sys.executable, str(PROBE), "open", str(config)]), cwd=ROOT)
    assert r.returncode in (0, 1), r.stderr
    out: dict[str, Any] = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["opened"] is (r.returncode == 0)
    return out


def _openssl_cert(work: Path, name: str, cn: str) -> tuple[Path, Path]:
    """A CA of its own (not the bench's) and a client certificate ``cn`` it signs."""
    d = work / name
    d.mkdir()
    ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]
    must(
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
    must(
        ["openssl", "req", *ec, "-keyout", "key.pem", "-out", "c.csr", "-subj", f"/CN={cn}"], cwd=d
    )
    (d / "ext").write_text(
        "subjectAltName=DNS:fowt-plant\nbasicConstraints=CA:FALSE\n"
        "extendedKeyUsage=serverAuth,clientAuth\n"
    )
    must(
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


def test_client_without_a_valid_certificate_is_refused(hosts: TwoHosts) -> None:
    h = hosts
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


def test_client_publishing_outside_its_acl_is_refused(hosts: TwoHosts) -> None:
    h = hosts
    outside = ["fowt/t1/sensors", "fowt/t1/truth"]  # the plant's keys
    inside = ["fowt/t1/controller/status", "fowt/t1/command"]  # the controller's own
    r = run(
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
