"""``fowt router``: the Zenoh router between the plant host and the controller host.

Zenoh's own router binary (``zenohd``) is not on PyPI, so the bench brings its router as
a process of its own: a Zenoh session opened in ``mode: "router"`` from a JSON5 file
(``config/zenoh-router.json5``). The routing, the TLS links with mutual authentication
and the access-control interceptors are all in the Zenoh core that the ``eclipse-zenoh``
wheel embeds, so this process enforces the same file the same way ``zenohd -c FILE`` of
the same Zenoh version would (no plugins, no admin space: nothing the bench uses).

The router refuses a file that is not for a router (``mode`` other than ``"router"``) or
that listens nowhere, and it says so when the file turns access control or mutual TLS
off. Zenoh's log goes to standard error (level from ``RUST_LOG``, default ``warn``): a
client refused in the TLS handshake is a ``WARN`` line (``invalid peer certificate:
UnknownIssuer``, ``peer sent no certificates``); every message the access control
refuses is a ``TRACE`` line of ``zenoh::net::routing::interceptor::access_control``
(``... is unauthorized to Put (ingress) on fowt/t1/sensors``), so run with
``RUST_LOG=warn,zenoh::net::routing::interceptor::access_control=trace`` to see them.
"""

from __future__ import annotations

import json
import re
import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zenoh


class RouterConfigError(ValueError):
    """A router config file that cannot be used; the message says what was expected."""


@dataclass(frozen=True)
class RouterPlan:
    """What a router config file makes the router do (for its start-up line)."""

    listen: tuple[str, ...]
    access_control: bool
    default_permission: str
    mtls: bool
    protocols: tuple[str, ...]

    def warnings(self) -> list[str]:
        """What in the file leaves the bench open (empty for ``config/zenoh-router.json5``)."""
        out = []
        if not self.access_control:
            out.append("access control is off: every client may put and subscribe anything")
        elif self.default_permission != "deny":
            out.append(f"access control default_permission is {self.default_permission!r}")
        if not self.mtls:
            out.append("mutual TLS is off: any client reaching the port is accepted")
        if self.protocols != ("tls",):
            out.append(f"link protocols {list(self.protocols) or 'all'}, not only tls")
        return out


def zenoh_error_text(exc: BaseException) -> str:
    """Zenoh's error message without the Rust source location it ends with."""
    return re.sub(r"\s+at \S+\.rs:\d+\.?$", "", str(exc).strip())


def _get(conf: zenoh.Config, key: str) -> Any:
    return json.loads(conf.get_json(key))


def load_router_config(path: Path) -> tuple[zenoh.Config, RouterPlan]:
    """Parse ``path`` as a Zenoh config for a router and say what it does.

    Raises
    ------
    RouterConfigError
        The file is missing, is not a valid Zenoh JSON5 config, is not ``mode: "router"``,
        or has no ``listen/endpoints``.
    """
    if not path.is_file():
        raise RouterConfigError(f"--zenoh-config {path}: no such file")
    try:
        conf = zenoh.Config.from_file(str(path))
    except Exception as exc:  # zenoh.ZError; UnicodeDecodeError for a binary file
        raise RouterConfigError(
            f"--zenoh-config {path}: not a valid Zenoh config: {zenoh_error_text(exc)}"
        ) from exc
    mode = _get(conf, "mode")
    if mode != "router":
        raise RouterConfigError(
            f'--zenoh-config {path}: mode is {mode!r}; expected "router" '
            "(the plant, controller and recorder files are clients of the router)"
        )
    listen = _get(conf, "listen/endpoints")
    if isinstance(listen, dict):  # per-mode form {router: [...], peer: [...]}
        listen = listen.get("router", [])
    if not listen:
        raise RouterConfigError(
            f"--zenoh-config {path}: listen/endpoints is empty; expected the router's "
            "endpoint, e.g. tls/<ROUTER_ADDR>:7447"
        )
    acl = _get(conf, "access_control")
    plan = RouterPlan(
        listen=tuple(listen),
        access_control=bool(acl.get("enabled")),
        default_permission=str(acl.get("default_permission", "deny")),
        mtls=bool(_get(conf, "transport/link/tls/enable_mtls")),
        protocols=tuple(_get(conf, "transport/link/protocols") or ()),
    )
    return conf, plan


def run_router(
    config_file: Path,
    stop: threading.Event | None = None,
    echo: Callable[[str], None] = print,
) -> None:
    """Open the router session from ``config_file`` and serve until SIGINT/SIGTERM or ``stop``.

    Parameters
    ----------
    config_file : Path
        A Zenoh JSON5 config with ``mode: "router"`` (``config/zenoh-router.json5``).
    stop : threading.Event, optional
        Set to end the router (the signals set it too when this runs in the main thread).
    echo : callable
        Where the start-up and shutdown lines go.

    Raises
    ------
    RouterConfigError
        As :func:`load_router_config`.
    zenoh.ZError
        When the session cannot open (a certificate file missing, the port taken).
    """
    conf, plan = load_router_config(config_file)
    stop = stop or threading.Event()
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda _s, _f: stop.set())
    zenoh.init_log_from_env_or("warn")
    session = zenoh.open(conf)
    try:
        acl = f"on (default {plan.default_permission})" if plan.access_control else "off"
        echo(
            f"router {session.zid()} listening on {list(plan.listen)}; "
            f"mutual TLS {'on' if plan.mtls else 'off'}, access control {acl}"
        )
        for w in plan.warnings():
            echo(f"warning: {w}")
        while not stop.wait(0.5):
            pass
    finally:
        session.close()
    echo("router stopped")
