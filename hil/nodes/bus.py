"""Zenoh transport for the bench's nodes, loopback-only unless a config file says otherwise.

Defaults follow DESIGN.md: peer mode, explicit endpoints (``tcp/127.0.0.1:<port>`` or a
unix socket), multicast scouting off, and the low-latency unicast transport (with QoS off,
as it requires) which measured the lowest round trip here. A process only listens on the
endpoints it is given; with none it listens nowhere. Multi-host use goes through a Zenoh
JSON5 config file (router, TLS, access control), never through defaults that open the host.

No loss by design
-----------------
Every publisher :meth:`Bus.publisher` declares uses congestion control ``BLOCK``: a put
waits for room towards a slow subscriber (a recorder whose channel is full holds Zenoh's
receive back) instead of dropping the sample, so a slow or niced recorder paces a run
rather than losing its messages (docs/recording.md). Measured (bench/bus_congestion.py:
two processes, 20 000 puts of 300 bytes into a subscriber that reads nothing for 7 or 24 s
through a FIFO channel of 16): over the low-latency transport every sample arrived with
``DROP`` and with ``BLOCK`` (the put waited up to 24.1 s); over the default transport
``DROP`` lost 37 % at once and ``BLOCK`` 75 % after waiting 5 s, Zenoh's
``transport/link/tx/queue/congestion_control/block/wait_before_close``. A Zenoh config
file that turns the low-latency transport off should raise that wait. Closing a session
while its samples are still on their way to a subscriber that is behind loses them; the
nodes wait for the recorder first (:func:`wait_for_recorder`).
"""

from __future__ import annotations

import contextlib
import hmac
import ipaddress
import json
import os
import secrets
import shutil
import socket
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zenoh

from bus_schemas.auth import session_credentials, sign, verify
from bus_schemas.codec import DecodeError, TruncatedError
from bus_schemas.registry import KEY_PREFIX, MessageType, identify


class BusConfigError(ValueError):
    """An endpoint or config that the bench refuses to use."""


def _check_loopback(endpoint: str) -> None:
    """Raise unless ``endpoint`` is on loopback (tcp/udp on 127.0.0.0/8 or ::1) or unix."""
    proto, _, rest = endpoint.partition("/")
    if proto == "unixsock-stream":
        return
    if proto not in ("tcp", "udp", "quic", "tls"):
        raise BusConfigError(
            f"endpoint {endpoint!r}: expected tcp/<addr>:<port> or unixsock-stream/<path>"
        )
    host = rest.rsplit(":", 1)[0].strip("[]")
    if host == "localhost":
        return
    try:
        addr = ipaddress.ip_address(host)
    except ValueError as exc:
        raise BusConfigError(f"endpoint {endpoint!r}: host must be a loopback IP address") from exc
    if not addr.is_loopback:
        raise BusConfigError(
            f"endpoint {endpoint!r} is not loopback; use --zenoh-config FILE for multi-host setups"
        )


@dataclass(frozen=True)
class BusConfig:
    """Where a node listens and connects.

    Parameters
    ----------
    listen, connect : tuple of str
        Zenoh endpoints such as ``tcp/127.0.0.1:7447``; must be loopback or unix sockets.
    lowlatency : bool
        Zenoh's low-latency unicast transport (QoS off); must match on both sides.
    config_file : Path or None
        A Zenoh JSON5 config replacing these defaults (multi-host: router, TLS, ACL).
        Endpoints given here are then added to it and not checked for loopback.
    auth_key : bytes or None
        The run's 32-byte secret (:mod:`bus_schemas.auth`): every payload put is signed,
        every payload received is verified before anyone decodes it. None: unauthenticated
        (``--insecure``, the in-process tools). Without ``config_file`` the key also
        authenticates the Zenoh session itself (:attr:`session_auth`).
    """

    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    lowlatency: bool = True
    config_file: Path | None = None
    extra: tuple[tuple[str, str], ...] = field(default=())
    auth_key: bytes | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.config_file is None:
            for ep in (*self.listen, *self.connect):
                _check_loopback(ep)

    @property
    def session_auth(self) -> bool:
        """True when the session opens only with the run's credential.

        Zenoh's transport authentication (``transport/auth/usrpwd``, user and password
        from :func:`bus_schemas.auth.session_credentials`) on the loopback set-up the
        launcher makes: a listening node accepts a link only from a session proving it
        holds the run's password, so a process without ``run.key`` gets no session to
        route, subscribe or flood through. With a config file the file's own transport
        security applies (mutual TLS and access control through a router,
        docs/multi-host.md): a router without the run's dictionary would refuse a node
        offering a password.
        """
        return self.auth_key is not None and self.config_file is None

    def zenoh_config(self) -> zenoh.Config:
        """Build the ``zenoh.Config`` for this node.

        With :attr:`session_auth` it carries the run's user and password (what a node
        presents when it connects); what a listening node checks against, the dictionary
        file, is added by :class:`Bus` for the moment the session opens.
        """
        if self.config_file is not None:
            conf = zenoh.Config.from_file(str(self.config_file))
        else:
            conf = zenoh.Config()
            conf.insert_json5("mode", '"peer"')
            conf.insert_json5("scouting/multicast/enabled", "false")
            # Gossip would make peers dial locators they learn from each other; every link
            # here is configured explicitly instead.
            conf.insert_json5("scouting/gossip/enabled", "false")
            if self.lowlatency:
                conf.insert_json5("transport/unicast/lowlatency", "true")
                conf.insert_json5("transport/unicast/qos/enabled", "false")
            conf.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        if self.config_file is not None and self.listen:
            conf.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        if self.connect:
            conf.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        for key, value in self.extra:
            conf.insert_json5(key, value)
        if self.session_auth:
            assert self.auth_key is not None
            user, password = session_credentials(self.auth_key)
            conf.insert_json5("transport/auth/usrpwd/user", json.dumps(user))
            conf.insert_json5("transport/auth/usrpwd/password", json.dumps(password))
        return conf

    def describe(self) -> str:
        """``listen [...], connect [...]`` as the session will use them (for log lines).

        With a config file the endpoints are the file's (unless given here), followed by
        ``, config FILE``.
        """
        if self.config_file is None:
            auth = ", session authenticated" if self.session_auth else ""
            return f"listen {list(self.listen)}, connect {list(self.connect)}{auth}"
        conf = self.zenoh_config()
        listen, connect = (
            json.loads(conf.get_json(f"{k}/endpoints")) for k in ("listen", "connect")
        )
        return f"listen {listen}, connect {connect}, config {self.config_file}"


def free_tcp_endpoint() -> str:
    """A free ``tcp/127.0.0.1:<port>`` endpoint (the OS picks the port)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"tcp/127.0.0.1:{port}"


class BusOpenError(RuntimeError):
    """The Zenoh session could not be opened (refused certificate, no peer, port in use)."""


@contextlib.contextmanager
def credential_dictionary(user: str, password: str) -> Iterator[Path]:
    """A ``user:password`` dictionary file for Zenoh's ``usrpwd`` check, while it is open.

    Zenoh reads the accepted credentials from a file (``dictionary_file``) once, when the
    session opens. The file is made in a fresh private folder (mode 0700, the file 0600,
    created exclusively) and removed with its folder on leaving, so the password rests on
    disk only for the moment ``zenoh.open`` takes, readable by nobody else, and never
    appears on a command line.
    """
    folder = Path(tempfile.mkdtemp(prefix="fowt-zenoh-auth-"))
    try:
        path = folder / "usrpwd"
        fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
        try:
            os.write(fd, f"{user}:{password}\n".encode())
        finally:
            os.close(fd)
        yield path
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def open_session(config: BusConfig) -> zenoh.Session:
    """``zenoh.open`` of ``config``, with the run's credential dictionary when it has one.

    Raises
    ------
    BusOpenError
        On a refused TLS handshake, an endpoint in use, a client that reached no router.
    """
    conf = config.zenoh_config()
    try:
        if not config.session_auth:
            return zenoh.open(conf)
        assert config.auth_key is not None
        with credential_dictionary(*session_credentials(config.auth_key)) as path:
            conf.insert_json5("transport/auth/usrpwd/dictionary_file", json.dumps(str(path)))
            return zenoh.open(conf)
    except zenoh.ZError as exc:  # a refused TLS handshake, an endpoint in use, ...
        raise BusOpenError(f"the Zenoh session did not open ({config.describe()}): {exc}") from exc


class SigningPublisher:
    """A Zenoh publisher whose ``put`` appends the payload's tag (:func:`bus_schemas.auth.sign`).

    Parameters
    ----------
    publisher : zenoh.Publisher
        The key's publisher.
    key : str
        Its key expression (part of what the tag covers).
    secret : bytes
        The run's secret.
    """

    def __init__(self, publisher: Any, key: str, secret: bytes) -> None:
        self.publisher = publisher
        self.key = key
        self._secret = secret

    def put(self, payload: bytes) -> None:
        """Sign and put ``payload``."""
        self.publisher.put(sign(self._secret, self.key, payload))

    def undeclare(self) -> None:
        """Undeclare the underlying publisher."""
        self.publisher.undeclare()


class Bus:
    """One Zenoh session with typed publish and raw subscribe helpers.

    With ``config.auth_key`` set, publishers sign and subscriptions verify every payload
    (:mod:`bus_schemas.auth`); the callbacks see the bare codec payload either way.
    """

    def __init__(self, config: BusConfig) -> None:
        self.config = config
        self.session = open_session(config)
        self._publishers: dict[str, Any] = {}
        self._subscribers: list[Any] = []

    def publisher(self, key: str) -> Any:
        """Declare (once) an express publisher on ``key`` (no batching: lowest latency).

        Congestion control ``BLOCK``: a put towards a subscriber that cannot take more
        waits rather than drops (module docstring, "No loss by design"). A
        :class:`SigningPublisher` around it when the bus authenticates.
        """
        pub = self._publishers.get(key)
        if pub is None:
            pub = self.session.declare_publisher(
                key, congestion_control=zenoh.CongestionControl.BLOCK, express=True
            )
            if self.config.auth_key is not None:
                pub = SigningPublisher(pub, key, self.config.auth_key)
            self._publishers[key] = pub
        return pub

    def open_payload(self, key: str, data: bytes) -> bytes:
        """The codec payload of a sample received on ``key`` (verified when authenticating).

        Raises
        ------
        bus_schemas.auth.AuthError
            On a missing or wrong tag.
        """
        secret = self.config.auth_key
        return data if secret is None else verify(secret, key, data)

    def put(self, key: str, payload: bytes) -> None:
        """Publish ``payload`` on ``key``."""
        self.publisher(key).put(payload)

    def subscribe(
        self,
        key: str,
        callback: Callable[[str, bytes], None],
        on_reject: Callable[[DecodeError], None] | None = None,
    ) -> None:
        """Call ``callback(key, payload)`` for each sample on ``key`` (in Zenoh's thread).

        When the bus authenticates, a sample whose tag does not verify never reaches
        ``callback``: it goes to ``on_reject(AuthError)`` (dropped when None).
        """
        secret = self.config.auth_key
        if secret is not None:

            def on_sample(sample: zenoh.Sample) -> None:
                k = str(sample.key_expr)
                try:
                    payload = verify(secret, k, sample.payload.to_bytes())
                except DecodeError as exc:
                    if on_reject is not None:
                        on_reject(exc)
                    return
                callback(k, payload)

            self._subscribers.append(self.session.declare_subscriber(key, on_sample))
            return

        def on_plain(sample: zenoh.Sample) -> None:
            callback(str(sample.key_expr), sample.payload.to_bytes())

        self._subscribers.append(self.session.declare_subscriber(key, on_plain))

    def peer_count(self) -> int:
        """Number of peers this session is connected to."""
        return len(list(self.session.info.peers_zid()))

    def close(self) -> None:
        """Undeclare everything and close the session (idempotent)."""
        for sub in self._subscribers:
            with contextlib.suppress(Exception):  # the session may already be going away
                sub.undeclare()
        self._subscribers.clear()
        if not self.session.is_closed():
            self.session.close()


#: Key suffixes of the batched log-only messages: the plant's truth and cycle timing go out
#: together on ``fowt/<turbine>/timing/batch``, the controller's status on
#: ``fowt/<turbine>/controller/batch`` (inside the key spaces each node may already publish
#: on under the shipped access control, ``timing/**`` and ``controller/**``).
PLANT_BATCH_SUFFIX = "timing/batch"
CONTROLLER_BATCH_SUFFIX = "controller/batch"
BATCH_SUFFIXES = (PLANT_BATCH_SUFFIX, CONTROLLER_BATCH_SUFFIX)


#: A log batch leaves when it holds this many messages ...
LOG_BATCH_MAX_MESSAGES = 32
#: ... or, when its owner looks (once per cycle, and every half control period in the
#: controller's main thread), once its oldest message is this old [s].
LOG_BATCH_MAX_AGE_S = 0.05


def batch_key(turbine: str, suffix: str) -> str:
    """``fowt/<turbine>/<suffix>`` for one of :data:`BATCH_SUFFIXES`."""
    return f"{KEY_PREFIX}/{turbine}/{suffix}"


def split_batch(payload: bytes | memoryview) -> list[tuple[MessageType, memoryview]]:
    """The encoded messages of a log batch, in order, each with its registered type.

    A batch is the plain concatenation of encoded messages (:mod:`bus_schemas.codec`:
    fixed size per message type, the header names the type), so it splits on the
    headers alone. Each part is then decoded (validated) by the receiver as a single
    message would be.

    Raises
    ------
    DecodeError
        On a header that names no registered message, or a last message cut short (the
        parts before it are not returned either: a malformed batch is rejected whole).
    """
    view = memoryview(payload)
    parts: list[tuple[MessageType, memoryview]] = []
    offset, end = 0, len(view)
    while offset < end:
        mt = identify(view[offset : offset + 4])
        size = mt.codec.size
        if offset + size > end:
            raise TruncatedError(
                f"log batch: {mt.name} at byte {offset} needs {size} bytes, {end - offset} left"
            )
        parts.append((mt, view[offset : offset + size]))
        offset += size
    return parts


def unbatching(
    mt: MessageType, callback: Callable[[str, bytes], None], turbine: str
) -> Callable[[str, bytes], None]:
    """A batch-key callback handing each ``mt`` message of a batch to ``callback``.

    ``callback(key, payload)`` gets the message's own key (``mt.key(turbine)``), as if it
    had been put there on its own; a malformed batch is skipped (the recorder counts it).
    """
    key = mt.key(turbine)

    def on_batch(_key: str, payload: bytes) -> None:
        try:
            parts = split_batch(payload)
        except DecodeError:
            return
        for part_mt, part in parts:
            if part_mt is mt:
                callback(key, bytes(part))

    return on_batch


class LogBatcher:
    """Log-only messages (nobody waits for them) put together, a few per Zenoh put.

    A Zenoh put and the receiver's wake-up cost far more than the bytes (25-90 us per put
    on this 2-core machine against about 1 us to append), and each log-only put also wakes
    the recorder, which competes with plant and controller for the two cores. The batch
    leaves when it holds ``max_messages``, when the owner finds it older than ``max_age_s``
    (:meth:`due`), and whenever the owner flushes it (before each timing summary, at the
    end). What a SIGKILL loses of the killed process's log-only messages is therefore
    bounded: at most ``max_messages - 1`` messages, and no more than ``max_age_s`` plus one
    control period of wall time.

    Parameters
    ----------
    publisher : zenoh.Publisher
        The batch key's publisher.
    max_messages : int
        Messages per batch at most.
    max_age_s : float
        Wall time after which :meth:`due` says the batch should go.
    """

    def __init__(
        self,
        publisher: Any,
        max_messages: int = LOG_BATCH_MAX_MESSAGES,
        max_age_s: float = LOG_BATCH_MAX_AGE_S,
    ) -> None:
        if max_messages < 1 or not max_age_s > 0:
            raise ValueError(
                f"log batch: expected max_messages >= 1 and max_age_s > 0, got "
                f"{max_messages} and {max_age_s}"
            )
        self.publisher = publisher
        self.max_messages = max_messages
        self.max_age_ns = round(max_age_s * 1e9)
        self._parts: list[bytes] = []
        self._first_ns = 0
        self.puts = 0  # batches put
        self.messages = 0  # messages put in them
        self.failed = 0  # puts that raised (a session going away at the end of a run)

    def add(self, payload: bytes) -> None:
        """Append one encoded message; put the batch when it is full."""
        parts = self._parts
        if not parts:
            self._first_ns = time.monotonic_ns()
        parts.append(payload)
        if len(parts) >= self.max_messages:
            self.flush()

    def age_s(self) -> float:
        """Wall time since the oldest message in the batch was added [s] (0: empty)."""
        if not self._parts:
            return 0.0
        return (time.monotonic_ns() - self._first_ns) / 1e9

    def due(self) -> bool:
        """True when the batch holds a message older than ``max_age_s``."""
        return bool(self._parts) and time.monotonic_ns() - self._first_ns >= self.max_age_ns

    def flush(self) -> None:
        """Put what the batch holds (nothing when it is empty)."""
        parts = self._parts
        if not parts:
            return
        self._parts = []
        try:
            self.publisher.put(b"".join(parts))
        except Exception:  # the session may be closing at the end of a run: counted
            self.failed += 1
            return
        self.puts += 1
        self.messages += len(parts)


#: Simulated seconds past a run's duration that a received sample time may still lie [s]
#: (a preview looks ahead; a run ends within one control period of its duration).
SAMPLE_TIME_SLACK_S = 300.0


def sample_time_limit_ns(duration_s: float) -> int:
    """The latest ``sample_time_ns`` a node accepts in a run of ``duration_s`` [s].

    A run's sample times start at 0 and end at its duration: a received time past this
    limit (:data:`SAMPLE_TIME_SLACK_S` beyond it) is implausible (a forgery by a key holder,
    or a corrupted sender) and counted as a ``time`` rejection, never used in arithmetic
    (a time near 2**63 - 1 plus the run's start overflows 64 bits).
    """
    return round((duration_s + SAMPLE_TIME_SLACK_S) * 1e9)


#: Wall seconds a node waits for its links to the others (:func:`wait_matched`) before it
#: announces itself anyway [s]: a connection to an endpoint not yet listening is retried at
#: most every 4 s by Zenoh's defaults.
LINK_TIMEOUT_S = 30.0


def wait_matched(publisher: Any, timeout_s: float, stop: threading.Event | None = None) -> bool:
    """Block until ``publisher``'s session knows a subscriber for its key; False on timeout.

    A put on a key no subscriber is known for is dropped, and a liveliness token seen by a
    third process says nothing about the route between two others: the recorder connects
    to the plant and the controller, and while its link to the controller is not up (its
    connect retried after the controller started listening) the controller's samples have
    no way to it. Zenoh's matching status of the publisher says when one has (polled every
    5 ms; a :class:`SigningPublisher` is looked through). ``stop`` set (a signal): False at
    once.
    """
    inner = getattr(publisher, "publisher", publisher)
    deadline = time.monotonic() + timeout_s
    while not inner.matching_status.matching:
        if time.monotonic() >= deadline or (stop is not None and stop.is_set()):
            return False
        time.sleep(0.005)
    return True


#: Key suffixes of the controller's readiness handshake with the recorder: the controller
#: puts a fresh nonce on ``controller/hello``; the recorder, on receiving it, puts the same
#: nonce on ``recorder/ready`` (both signed with the run's secret).
HELLO_SUFFIX = "controller/hello"
READY_SUFFIX = "recorder/ready"
#: Wall seconds between two hellos while the recorder has not answered [s].
HELLO_INTERVAL_S = 0.1


def await_recorder(
    bus: Bus,
    publisher: Any,
    turbine: str,
    timeout_s: float,
    stop: threading.Event | None = None,
) -> bool:
    """Block until the run's own recorder gets this node's samples; False on timeout or stop.

    Authenticated: the node puts a fresh 16-byte nonce on ``fowt/<turbine>/controller/hello``
    every :data:`HELLO_INTERVAL_S` and waits for the recorder's answer, the same nonce on
    ``fowt/<turbine>/recorder/ready``, both tagged with the run's secret. The answer proves
    that the recorder (a holder of the key, not any subscriber) has received a sample of
    this node over its own link, so the node's later samples reach it too; a replayed
    answer carries another run's or an earlier nonce. Otherwise :func:`wait_matched` on
    ``publisher``: unauthenticated (``--insecure``: any subscriber satisfies it), and with a
    Zenoh config file (multi-host: the router's access control lets the recorder put
    nothing, and only nodes with a client certificate have a session to subscribe from).
    """
    if not bus.config.session_auth:
        return wait_matched(publisher, timeout_s, stop)
    nonce = secrets.token_bytes(16)
    answered = threading.Event()

    def on_ready(_key: str, payload: bytes) -> None:
        if hmac.compare_digest(payload, nonce):
            answered.set()

    bus.subscribe(f"{KEY_PREFIX}/{turbine}/{READY_SUFFIX}", on_ready)
    hello = bus.publisher(f"{KEY_PREFIX}/{turbine}/{HELLO_SUFFIX}")
    deadline = time.monotonic() + timeout_s
    while not answered.is_set():
        if time.monotonic() >= deadline or (stop is not None and stop.is_set()):
            return False
        hello.put(nonce)
        answered.wait(HELLO_INTERVAL_S)
    return True


#: Wall seconds a plant or controller waits, after its report, for the recorder to say it
#: holds everything the node published (:func:`wait_for_recorder`) [s].
RECORDER_ACK_TIMEOUT_S = 120.0


def recorder_ack_key(turbine: str, node: str) -> str:
    """The liveliness token ``fowt/<turbine>/alive/recorder/has/<node>``.

    The recorder declares it once it holds everything ``node`` (``plant``,
    ``controller``) reported publishing (:mod:`hil.nodes.recorder`).
    """
    return f"{KEY_PREFIX}/{turbine}/alive/recorder/has/{node}"


def wait_for_recorder(
    session: zenoh.Session,
    turbine: str,
    node: str,
    timeout_s: float = RECORDER_ACK_TIMEOUT_S,
    stop: threading.Event | None = None,
) -> str:
    """Block until the recorder holds what ``node`` published, before its session closes.

    A session closed while its samples are still on their way to a subscriber that is
    behind (a niced recorder under load) loses them: measured, the last 1 to 4 s of a
    lock-step run's log batches. So a node keeps its session open, after its report, until
    the recorder's token :func:`recorder_ack_key` appears, or no recorder is there (its
    token ``fowt/<turbine>/alive/recorder`` absent or gone), or ``timeout_s`` [s] passed.

    ``stop`` set (a signal during the wait) ends it within 0.1 s.

    Returns
    -------
    str
        ``"acknowledged"``, ``"no recorder"``, ``"timeout"`` or ``"stopped"``.
    """
    ack = recorder_ack_key(turbine, node)
    alive = f"{KEY_PREFIX}/{turbine}/alive/recorder"
    present: set[str] = set()
    changed = threading.Event()
    lock = threading.Lock()

    def on_token(sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        with lock:
            if sample.kind == zenoh.SampleKind.DELETE:
                present.discard(key)
            else:
                present.add(key)
        changed.set()

    sub = session.liveliness().declare_subscriber(f"{alive}/**", on_token, history=True)
    try:
        deadline = time.monotonic() + timeout_s
        first = True
        while True:
            with lock:
                if ack in present:
                    return "acknowledged"
                # The history arrives with the declaration; a first look waits a moment.
                if alive not in present and not first:
                    return "no recorder"
            if time.monotonic() > deadline:
                return "timeout"
            if stop is not None and stop.is_set():
                return "stopped"
            changed.wait(0.1)
            changed.clear()
            first = False
    finally:
        with contextlib.suppress(Exception):
            sub.undeclare()
