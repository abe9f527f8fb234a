"""Two hosts on one machine: the set-up of ``docs/multi-host.md`` in two network namespaces.

Used by ``tests/test_multi_host.py`` and ``bench/multihost_transport.py`` (which puts
``tests/`` on ``sys.path``). :func:`two_hosts` makes two network namespaces joined by a
veth pair whose addresses (:data:`ADDR_A`, :data:`ADDR_B`) exist only inside them, so
nothing is sent on the host's interfaces; makes the certificates by running the shell
block of ``docs/multi-host.md`` (bash, OpenSSL 3); fills the placeholders of the shipped
``config/zenoh-*-router.json5`` files; and starts ``fowt router`` in namespace A. On exit
every process it started is stopped and both namespaces are deleted, whatever happened.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "multi-host.md"
CONFIG_FILES = {
    "router": ROOT / "config" / "zenoh-router.json5",
    "plant": ROOT / "config" / "zenoh-plant-router.json5",
    "controller": ROOT / "config" / "zenoh-controller-router.json5",
    "recorder": ROOT / "config" / "zenoh-recorder-router.json5",
}
#: Addresses of the two namespaces' veth ends (they exist only inside the namespaces).
ADDR_A, ADDR_B = "10.147.0.1", "10.147.0.2"
#: The router's Zenoh log levels: TLS refusals are WARN, access-control decisions TRACE.
ROUTER_LOG = "warn,zenoh::net::routing::interceptor::access_control=trace"
_ANSI = re.compile(r"\x1b\[[0-9;]*m")


class NamespacesUnavailableError(RuntimeError):
    """Network namespaces cannot be made here; the message says why."""


def unavailable_reason() -> str | None:
    """Why :func:`two_hosts` cannot run here (None: it may; ``ip netns add`` decides)."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        return "creating network namespaces (ip netns add) needs root"
    for tool in ("ip", "openssl", "bash"):
        if shutil.which(tool) is None:
            return f"needs {tool!r} on PATH (iproute2, OpenSSL 3, bash)"
    return None


def run(cmd: list[str], **kw: Any) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, capture_output=True, text=True, check=False, **kw)


def must(cmd: list[str], **kw: Any) -> str:
    """Run ``cmd``; its standard output, or an AssertionError with its output."""
    r = run(cmd, **kw)
    assert r.returncode == 0, f"{' '.join(cmd)} exited {r.returncode}:\n{r.stdout}{r.stderr}"
    return r.stdout


def doc_certificate_script() -> str:
    """The OpenSSL shell block of ``docs/multi-host.md`` (it starts ``ROUTER_ADDR=``)."""
    m = re.search(r"```sh\n(ROUTER_ADDR=.*?)```", DOC.read_text(), re.S)
    assert m, f"{DOC}: no ```sh block starting with ROUTER_ADDR="
    return m.group(1)


def fill_config(text: str, router_addr: str, tls_dir: Path) -> str:
    """A shipped config's text with ``<ROUTER_ADDR>`` and ``/etc/fowt/tls/`` filled in."""
    return text.replace("<ROUTER_ADDR>", router_addr).replace("/etc/fowt/tls/", f"{tls_dir}/")


@dataclass
class TwoHosts:
    """Two namespaces joined by a veth pair, certificates, configs and the running router."""

    ns_a: str
    ns_b: str
    work: Path
    tls: Path
    configs: dict[str, Path]
    router_log: Path
    procs: list[subprocess.Popen[str]] = field(default_factory=list)

    def cmd(self, ns: str, argv: list[str]) -> list[str]:
        return ["ip", "netns", "exec", ns, *argv]

    def start(self, ns: str, argv: list[str], log: Path, **env: str) -> subprocess.Popen[str]:
        """Start ``argv`` in namespace ``ns`` (output to ``log``); stopped on exit."""
        with log.open("w") as out:
            p = subprocess.Popen(
                self.cmd(ns, argv),
                stdout=out,
                stderr=subprocess.STDOUT,
                text=True,
                cwd=ROOT,
                env={**os.environ, "PYTHONUNBUFFERED": "1", **env},
                start_new_session=True,
            )
        self.procs.append(p)
        return p

    def log_lines(self) -> list[str]:
        """The router's log so far, without colour codes."""
        return _ANSI.sub("", self.router_log.read_text()).splitlines()

    def rx_bytes(self) -> int:
        """Bytes namespace B's veth end has received."""
        out = must(["ip", "-n", self.ns_b, "-s", "-j", "link", "show", "vb"])
        return int(json.loads(out)[0]["stats64"]["rx"]["bytes"])

    def lockstep_run(
        self, scenario: str, duration_s: float, out: Path, timeout_s: float = 300.0
    ) -> Path:
        """Plant in A, controller and recorder in B, lock-step; the MCAP file written.

        Raises AssertionError naming the node (with its log) that failed or hung.
        """
        out.mkdir(parents=True, exist_ok=True)
        mcap = out / "run.mcap"
        fowt = [sys.executable, "-m", "hil"]
        from _helpers import key_file_args

        dur = ["--duration", repr(duration_s), *key_file_args(out)]
        conf = {k: ["--zenoh-config", str(v)] for k, v in self.configs.items()}
        nodes = {
            "controller": (self.ns_b, ["controller", scenario, *dur, *conf["controller"]]),
            "recorder": (
                self.ns_b,
                ["record", scenario, *dur, "--out", str(mcap), *conf["recorder"]],
            ),
            "plant": (
                self.ns_a,
                [
                    "plant",
                    scenario,
                    *dur,
                    "--mode",
                    "lockstep",
                    *conf["plant"],
                    "--require",
                    "controller,recorder",
                ],
            ),
        }
        procs = {
            name: self.start(ns, [*fowt, *argv], out / f"{name}.log")
            for name, (ns, argv) in nodes.items()
        }
        for name in ("plant", "controller", "recorder"):
            try:
                rc: int | None = procs[name].wait(timeout_s if name == "plant" else 30.0)
            except subprocess.TimeoutExpired:
                rc = None
            assert rc == 0, f"{name} exited {rc}:\n{(out / f'{name}.log').read_text()}"
        return mcap


def stop(p: subprocess.Popen[str]) -> None:
    """SIGTERM, then SIGKILL after 10 s, for one process this module started."""
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(10)


@contextlib.contextmanager
def two_hosts(work: Path, edit: Callable[[str, str], str] | None = None) -> Iterator[TwoHosts]:
    """The two namespaces with the router running in A (see the module docstring).

    Parameters
    ----------
    work : Path
        An empty folder for certificates, configs and logs.
    edit : callable, optional
        ``edit(name, text)`` returns the config text to use for ``name`` (router, plant,
        controller, recorder) after the placeholders are filled in.

    Raises
    ------
    NamespacesUnavailableError
        When namespaces cannot be made here (:func:`unavailable_reason`, or
        ``ip netns add`` refused).
    """
    reason = unavailable_reason()
    if reason:
        raise NamespacesUnavailableError(reason)
    ns_a, ns_b = f"fowt-mh{os.getpid()}-a", f"fowt-mh{os.getpid()}-b"
    created: list[str] = []
    hosts: TwoHosts | None = None
    try:
        for ns in (ns_a, ns_b):
            r = run(["ip", "netns", "add", ns])
            if r.returncode != 0:
                raise NamespacesUnavailableError(f"ip netns add {ns}: {r.stderr.strip()}")
            created.append(ns)
        # The veth pair is made inside the two namespaces (no interface on the host).
        must(
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
            must(["ip", "-n", ns, "addr", "add", f"{addr}/24", "dev", dev])
            must(["ip", "-n", ns, "link", "set", dev, "up"])
            must(["ip", "-n", ns, "link", "set", "lo", "up"])
        # Certificates exactly as docs/multi-host.md makes them.
        script = ["bash", "-euo", "pipefail", "-c", doc_certificate_script()]
        must(script, cwd=work, env={**os.environ, "ROUTER_ADDR": ADDR_A})
        tls = work / "tls"
        configs = {}
        for name, src in CONFIG_FILES.items():
            text = fill_config(src.read_text(), ADDR_A, tls)
            configs[name] = work / f"{name}.json5"
            configs[name].write_text(edit(name, text) if edit else text)
        hosts = TwoHosts(ns_a, ns_b, work, tls, configs, work / "router.log")
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
                stop(p)
        for ns in created:
            run(["ip", "netns", "del", ns])
