"""CAN transport for the bench's nodes: the surface of :class:`hil.nodes.bus.Bus` on a python-can
bus.

A node publishes a message and subscribes with a callback, as on Zenoh:

* ``publish(mt, msg)``: encode (:class:`bus_schemas.can_codec.Encoder`) and send its frames;
* ``publisher(key).put(payload)`` / ``put(key, payload)``: the Zenoh-compatible form, taking
  the bench's binary payload (decoded with the registry codec, then sent as CAN frames);
* ``subscribe_message(mt, callback(msg))``: decoded messages;
* ``subscribe(key, callback(key, payload))``: the Zenoh-compatible form; the payload is the
  bench's binary encoding of the decoded message, so a node's existing ``on_payload``
  callback (``CommandInbox.on_payload``, ``ControllerRuntime.handle_payload``) works as is.

Only :data:`bus_schemas.can_db.CAN_MESSAGES` travel on CAN (sensor frame and command); a key
of another message (truth, status, timing) raises :class:`UnmappedMessageError`: those stay on
Zenoh. One CAN bus is one turbine: keys must be ``fowt/<turbine_id>/<suffix>``.

Receiving runs in a ``can.Notifier`` thread that blocks in ``bus.recv(timeout)`` (no busy
loop); callbacks run in that thread, one frame at a time, so the reassembler needs no lock.
Rejected frames are counted in :attr:`CanBus.rejected` (reasons of
:data:`bus_schemas.can_codec.REJECT_REASONS`).

Interfaces (:class:`CanBusConfig`):

* ``virtual``: python-can's in-process bus; every ``CanBus`` on the same ``channel`` name in
  one process sees the others' frames (not its own). For loopback tests.
* ``socketcan``: a Linux CAN netdevice (``vcan0``, ``can0``), where the kernel has CAN
  (``ip link add vcan0 type vcan; ip link set vcan0 up``). Not available on this build host.
* ``udp_multicast``: python-can's UDP multicast bus (needs ``msgpack``) for two processes on
  one host. It is refused unless the process runs in a private network namespace (not the
  one of PID 1), so it can never use the host's interfaces: create one with ``unshare -n``
  (as root), then ``ip link set lo up multicast on; ip route add 224.0.0.0/4 dev lo``
  (:func:`netns_command` builds that command line). Default group
  :data:`DEFAULT_UDP_GROUP` (IPv4, so the ``224.0.0.0/4`` route on ``lo`` carries it). Every
  socket joined to the group receives every frame, the sender's own included (multicast
  loop); a node ignores the message types it did not subscribe to. UDP has no flow
  control, so the receive buffer is raised to :data:`UDP_RCVBUF_BYTES` (as root past
  ``net.core.rmem_max``): a lock-step run bursts 7 + 4 frames per cycle at ~1 kHz.

:class:`HybridBus` is what a node of a ``--transport can`` run opens: the sensor frame and
the command on CAN, every other key (truth, status, timing, liveliness) on the node's
loopback Zenoh session, behind the same ``publisher`` / ``subscribe`` / ``session`` surface
as :class:`hil.nodes.bus.Bus`.
"""

from __future__ import annotations

import difflib
import importlib.util
import ipaddress
import os
import shlex
import shutil
import socket
import threading
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import can
import msgspec

from bus_schemas.can_codec import Encoder, Reassembler, can_message_type, layouts
from bus_schemas.can_db import CAN_MESSAGES
from bus_schemas.codec import DecodeError
from bus_schemas.registry import BY_SUFFIX, KEY_PREFIX, MessageType
from hil.nodes.bus import Bus, BusConfig

Interface = Literal["virtual", "socketcan", "udp_multicast"]
INTERFACES: tuple[Interface, ...] = ("virtual", "socketcan", "udp_multicast")

#: The IPv4 multicast group of ``udp_multicast`` buses (python-can's IPv4 default group).
DEFAULT_UDP_GROUP = "239.74.163.2"
#: Default channel per interface.
DEFAULT_CHANNELS: dict[str, str] = {
    "virtual": "fowt",
    "socketcan": "vcan0",
    "udp_multicast": DEFAULT_UDP_GROUP,
}
#: Receive buffer asked for on a ``udp_multicast`` socket [bytes].
UDP_RCVBUF_BYTES = 8 * 1024 * 1024
#: Shell steps that make a fresh network namespace carry ``udp_multicast`` on loopback.
NETNS_SETUP = "ip link set lo up multicast on && ip route add 224.0.0.0/4 dev lo"


class CanConfigError(ValueError):
    """A CAN configuration the bench refuses to use."""


class UnmappedMessageError(KeyError):
    """A message (or key) that is not carried on CAN."""


def socketcan_available(channel: str = "vcan0") -> bool:
    """Whether the Linux network device ``channel`` exists (a socketcan bus can open it)."""
    return Path("/sys/class/net", channel).exists()


def _netns_interfaces() -> list[str]:
    """Network interfaces of this process's network namespace (``/proc/net/dev`` is per
    namespace, unlike ``/sys/class/net``, which shows the namespace sysfs was mounted in)."""
    with open("/proc/net/dev") as fh:
        lines = fh.read().splitlines()[2:]
    return [line.split(":", 1)[0].strip() for line in lines if ":" in line]


def in_private_netns() -> bool:
    """Whether this process runs in a private network namespace (``unshare -n``).

    True when its namespace differs from PID 1's. Where PID 1's namespace cannot be read
    (a container or sandbox denies ``/proc/1/ns/net`` even to root), True only when this
    namespace has no interface but ``lo``: then no frame can leave the host whatever the
    namespace is. False when neither can be told.
    """
    try:
        own = os.stat("/proc/self/ns/net").st_ino
    except OSError:
        return False
    try:
        return own != os.stat("/proc/1/ns/net").st_ino
    except OSError:
        pass
    try:
        return _netns_interfaces() == ["lo"]
    except OSError:
        return False


def netns_unavailable_reason() -> str | None:
    """Why this process cannot create a private network namespace (None: it can).

    Creating one takes ``unshare -n`` (util-linux) run as root and ``ip`` (iproute2) inside it.
    """
    if os.geteuid() != 0:
        return (
            "udp_multicast between processes needs a private network namespace, and creating "
            "one (unshare -n) needs root; this process is not root: run it as root, or use "
            "--transport zenoh (the default)"
        )
    missing = [tool for tool in ("unshare", "ip") if shutil.which(tool) is None]
    if missing:
        return (
            "udp_multicast between processes needs a private network namespace: "
            f"{' and '.join(missing)} not found on PATH: install util-linux and iproute2, or "
            "use --transport zenoh (the default)"
        )
    return None


def netns_command(cmd: list[str]) -> list[str]:
    """``cmd`` run in a fresh network namespace whose ``lo`` carries IPv4 multicast.

    ``unshare -n`` gives the command a network namespace of its own with nothing but a down
    loopback; :data:`NETNS_SETUP` brings ``lo`` up with multicast and routes
    ``224.0.0.0/4`` to it, then the command replaces the shell (its exit status is the
    namespace's). The namespace goes away with its last process.
    """
    script = f"{NETNS_SETUP} && exec {shlex.join(cmd)}"
    return ["unshare", "--net", "--", "sh", "-c", script]


def frames_per_message(mt: MessageType | type[msgspec.Struct], fd: bool = False) -> int:
    """CAN frames of one instance of a CAN-carried message (classic parts, or 1 on CAN FD)."""
    cls = mt.cls if isinstance(mt, MessageType) else mt
    return len(layouts(fd)[cls].parts)


def transport_unavailable_reason(config: CanBusConfig, processes: bool = True) -> str | None:
    """Why ``config`` cannot connect separate processes here (None: it can).

    ``virtual`` never can (python-can's virtual bus lives in one process); ``socketcan``
    needs its netdevice; ``udp_multicast`` a private network namespace, this one or one
    this process can create (:func:`netns_unavailable_reason`).
    """
    if config.interface == "virtual":
        if not processes:
            return None
        return (
            "the python-can virtual bus only connects buses inside one process; separate "
            "plant and controller processes need --can-interface udp_multicast (in a private "
            "network namespace) or socketcan"
        )
    if config.interface == "socketcan":
        chan = config.effective_channel
        if socketcan_available(chan):
            return None
        return (
            f"socketcan device {chan!r} does not exist (this kernel may have no CAN: "
            f"`ip link add {chan} type vcan` fails); use --can-interface udp_multicast"
        )
    if importlib.util.find_spec("msgpack") is None:
        return "python-can's udp_multicast needs msgpack (pip install msgpack)"
    return None if in_private_netns() else netns_unavailable_reason()


def _raise_udp_rcvbuf(bus: can.BusABC, size: int = UDP_RCVBUF_BYTES) -> None:
    """Raise the receive buffer of a ``udp_multicast`` bus's socket (best effort).

    ``SO_RCVBUFFORCE`` (root, CAP_NET_ADMIN) passes ``net.core.rmem_max``; otherwise
    ``SO_RCVBUF`` up to it. Works on a duplicate of the bus's descriptor (public
    ``fileno()``), which shares the socket.
    """
    try:
        fd = bus.fileno()
    except (AttributeError, NotImplementedError):
        return
    if fd < 0:
        return
    with socket.socket(fileno=os.dup(fd)) as sock:
        force = getattr(socket, "SO_RCVBUFFORCE", None)
        try:
            if force is None:
                raise PermissionError
            sock.setsockopt(socket.SOL_SOCKET, force, size)
        except OSError:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, size)


@dataclass(frozen=True)
class CanBusConfig:
    """Which python-can bus a node opens.

    Parameters
    ----------
    interface : {"virtual", "socketcan", "udp_multicast"}
        python-can interface.
    channel : str
        ``virtual``: any name shared by the nodes; ``socketcan``: the netdevice (``vcan0``);
        ``udp_multicast``: the multicast group. Empty: the interface's default
        (:data:`DEFAULT_CHANNELS`; :attr:`effective_channel`).
    fd : bool
        CAN FD: each message in one frame (sensor frame 48 bytes, command 20 bytes) instead
        of classic 8-byte parts on consecutive ids.
    turbine_id : str
        The turbine this bus belongs to (keys ``fowt/<turbine_id>/...``).
    receive_own_messages : bool
        Deliver this bus's own frames back to it (tests).
    """

    interface: Interface = "virtual"
    channel: str = ""
    fd: bool = False
    turbine_id: str = "t1"
    receive_own_messages: bool = False

    def __post_init__(self) -> None:
        if self.interface not in INTERFACES:
            raise CanConfigError(
                f"CAN interface {self.interface!r}: expected virtual, socketcan or udp_multicast"
            )
        if self.interface == "udp_multicast":
            try:
                multicast = ipaddress.ip_address(self.effective_channel).is_multicast
            except ValueError:
                multicast = False
            if not multicast:
                raise CanConfigError(
                    f"udp_multicast channel {self.channel!r}: expected a multicast group "
                    f"address such as {DEFAULT_UDP_GROUP}"
                )

    @classmethod
    def for_interface(
        cls, interface: str, channel: str | None = None, fd: bool = False, turbine_id: str = "t1"
    ) -> CanBusConfig:
        """A configuration with the interface's default channel (:data:`DEFAULT_CHANNELS`).

        Raises
        ------
        CanConfigError
            For an unknown interface or a ``udp_multicast`` channel that is not a group.
        """
        if interface not in INTERFACES:
            close = difflib.get_close_matches(interface, INTERFACES, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise CanConfigError(
                f"CAN interface {interface!r}: expected virtual, socketcan or udp_multicast{hint}"
            )
        return cls(interface, channel or "", fd, turbine_id)

    @property
    def effective_channel(self) -> str:
        """The channel opened: :attr:`channel`, or the interface's default."""
        return self.channel or DEFAULT_CHANNELS[self.interface]

    def cli_args(self) -> list[str]:
        """The ``fowt`` node options that select this bus (``--transport can ...``)."""
        args = ["--transport", "can", "--can-interface", self.interface]
        args += ["--can-channel", self.effective_channel]
        return [*args, "--can-fd"] if self.fd else args

    def bus_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of ``can.Bus`` for this configuration."""
        kwargs: dict[str, Any] = {
            "interface": self.interface,
            "receive_own_messages": self.receive_own_messages,
            "fd": self.fd,
        }
        if self.interface == "udp_multicast" and not in_private_netns():
            raise CanConfigError(
                "udp_multicast is only used inside a private network namespace "
                "(unshare -n, lo up with a multicast route), never on the host's interfaces"
            )
        kwargs["channel"] = self.effective_channel
        return kwargs


class _Publisher:
    """``put(payload)`` on one key, as a Zenoh publisher."""

    def __init__(self, bus: CanBus, mt: MessageType) -> None:
        self._bus = bus
        self._mt = mt

    def put(self, payload: bytes) -> None:
        self._bus.publish(self._mt, self._mt.codec.decode(payload))


class CanBus:
    """One python-can bus with typed publish and subscribe helpers (see module docstring).

    Parameters
    ----------
    config : CanBusConfig
        Interface, channel, frame format and turbine.
    bus : can.BusABC or None
        An already open bus to use instead of opening one from ``config`` (closed with this
        object).
    auth_key : bytes or None
        The run's secret: instances are sent with, and must arrive with, their
        authenticator frame (:mod:`bus_schemas.can_codec`); None: unauthenticated.
    """

    def __init__(
        self,
        config: CanBusConfig,
        bus: can.BusABC | None = None,
        auth_key: bytes | None = None,
    ) -> None:
        self.config = config
        self.bus: can.BusABC = bus if bus is not None else can.Bus(**config.bus_kwargs())
        if bus is None and config.interface == "udp_multicast":
            _raise_udp_rcvbuf(self.bus)
        self.encoder = Encoder(fd=config.fd, auth_key=auth_key)
        self.reassembler = Reassembler(fd=config.fd, auth_key=auth_key)
        self.frames_sent = 0
        self.frames_received = 0
        self.ignored_frames = 0
        self._send_lock = threading.Lock()
        self._subs: dict[type[msgspec.Struct], list[Callable[[msgspec.Struct], None]]] = {}
        self._frame_listeners: list[Callable[[can.Message], None]] = []
        self._closed = False
        self._notifier = can.Notifier(self.bus, [self._on_frame], timeout=0.5)

    # -- keys ---------------------------------------------------------------------------
    def message_type(self, key: str) -> MessageType:
        """The CAN-carried message type of ``fowt/<turbine_id>/<suffix>``."""
        prefix = f"{KEY_PREFIX}/{self.config.turbine_id}/"
        if not key.startswith(prefix):
            raise UnmappedMessageError(f"key {key!r} is not under {prefix!r}")
        mt = BY_SUFFIX.get(key.removeprefix(prefix))
        if mt is None or mt not in CAN_MESSAGES:
            raise UnmappedMessageError(f"{key!r} is not carried on CAN (Zenoh only)")
        return mt

    # -- sending ------------------------------------------------------------------------
    def publish(self, mt: MessageType | type[msgspec.Struct], msg: msgspec.Struct) -> None:
        """Encode ``msg`` and send its frames (in part order, atomically per message)."""
        cls = mt.cls if isinstance(mt, MessageType) else mt
        can_message_type(cls)
        with self._send_lock:
            frames = self.encoder.encode(msg)
            for frame in frames:
                self.bus.send(frame)
            self.frames_sent += len(frames)

    def publisher(self, key: str) -> _Publisher:
        """A Zenoh-like publisher of binary payloads on ``key``."""
        return _Publisher(self, self.message_type(key))

    def put(self, key: str, payload: bytes) -> None:
        """Publish a binary payload (the bench's Zenoh encoding) on ``key``."""
        self.publisher(key).put(payload)

    # -- receiving ----------------------------------------------------------------------
    def subscribe_message(
        self, mt: MessageType | type[msgspec.Struct], callback: Callable[[Any], None]
    ) -> None:
        """Call ``callback(message)`` for every complete, valid message of type ``mt``."""
        cls = mt.cls if isinstance(mt, MessageType) else mt
        can_message_type(cls)
        self._subs.setdefault(cls, []).append(callback)

    def subscribe(
        self,
        key: str,
        callback: Callable[[str, bytes], None],
        on_reject: Callable[[DecodeError], None] | None = None,
    ) -> None:
        """Call ``callback(key, payload)`` with the bench's binary payload, as on Zenoh.

        ``on_reject`` is accepted for the Zenoh surface: on CAN the reassembler counts the
        instances it refuses (authenticator included) in :attr:`rejected`.
        """
        mt = self.message_type(key)

        def deliver(msg: msgspec.Struct) -> None:
            callback(key, mt.codec.encode(msg))

        self.subscribe_message(mt, deliver)

    def add_frame_listener(self, callback: Callable[[can.Message], None]) -> None:
        """Call ``callback(frame)`` for every received frame, before it is decoded.

        Runs in the receive thread; a frame that completes a message reaches the listeners
        before the message reaches :meth:`subscribe_message` callbacks.
        """
        self._frame_listeners.append(callback)

    def _on_frame(self, frame: can.Message) -> None:
        self.frames_received += 1
        for listener in self._frame_listeners:
            listener(frame)
        mt = self.reassembler.message_type_of(frame.arbitration_id)
        if mt is not None and mt.cls not in self._subs:
            self.ignored_frames += 1  # another node's traffic: not decoded
            return
        msg = self.reassembler.feed(frame)
        if msg is None:
            return
        for callback in self._subs.get(type(msg), ()):
            callback(msg)

    @property
    def rejected(self) -> Counter[str]:
        """Rejected frames / message instances by reason."""
        return self.reassembler.rejected

    def close(self) -> None:
        """Stop the receive thread and shut the bus down (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._notifier.stop(timeout=2.0)
        self.bus.shutdown()

    def __enter__(self) -> CanBus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class HybridBus:
    """A node's bus in a CAN run: CAN for the sensor frame and command, Zenoh for the rest.

    Same surface as :class:`hil.nodes.bus.Bus` (``publisher``, ``put``, ``subscribe``,
    ``session``, ``close``): a key of :data:`bus_schemas.can_db.CAN_MESSAGES` goes to the
    :class:`CanBus`, any other key (truth, controller status, timing, liveliness) to the
    loopback Zenoh session. Both are opened here, the CAN bus first, so a node that
    declares its liveliness token after subscribing is ready on both.

    Parameters
    ----------
    zenoh_config : BusConfig
        The node's Zenoh endpoints.
    can_config : CanBusConfig
        The node's CAN bus (its ``turbine_id`` names the keys it carries).
    """

    def __init__(self, zenoh_config: BusConfig, can_config: CanBusConfig) -> None:
        self.config = zenoh_config
        self.can = CanBus(can_config, auth_key=zenoh_config.auth_key)
        try:
            self.zenoh = Bus(zenoh_config)
        except BaseException:
            self.can.close()
            raise

    @property
    def session(self) -> Any:
        """The Zenoh session (liveliness, queries)."""
        return self.zenoh.session

    def on_can(self, key: str) -> bool:
        """Whether ``key`` travels on CAN."""
        try:
            self.can.message_type(key)
        except UnmappedMessageError:
            return False
        return True

    def publisher(self, key: str) -> Any:
        """A publisher of binary payloads on ``key`` (CAN or Zenoh)."""
        return self.can.publisher(key) if self.on_can(key) else self.zenoh.publisher(key)

    def put(self, key: str, payload: bytes) -> None:
        """Publish ``payload`` on ``key``."""
        self.publisher(key).put(payload)

    def subscribe(
        self,
        key: str,
        callback: Callable[[str, bytes], None],
        on_reject: Callable[[DecodeError], None] | None = None,
    ) -> None:
        """Call ``callback(key, payload)`` for each message on ``key`` (CAN or Zenoh)."""
        if self.on_can(key):
            self.can.subscribe(key, callback, on_reject)
        else:
            self.zenoh.subscribe(key, callback, on_reject)

    def open_payload(self, key: str, data: bytes) -> bytes:
        """The verified codec payload of a Zenoh sample (:meth:`hil.nodes.bus.Bus.open_payload`)."""
        return self.zenoh.open_payload(key, data)

    def peer_count(self) -> int:
        """Zenoh peers of this session."""
        return self.zenoh.peer_count()

    def close(self) -> None:
        """Close both buses (idempotent)."""
        try:
            self.zenoh.close()
        finally:
            self.can.close()


def hybrid_bus_factory(can_config: CanBusConfig) -> Callable[[BusConfig], HybridBus]:
    """``BusConfig -> HybridBus`` with this CAN bus: stands in for :class:`hil.nodes.bus.Bus` where
    a
    node opens its bus from a Zenoh configuration."""

    def factory(zenoh_config: BusConfig) -> HybridBus:
        return HybridBus(zenoh_config, can_config)

    return factory
