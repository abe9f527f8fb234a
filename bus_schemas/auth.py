"""Message authentication of the bench's bus payloads: one per-run secret, one MAC scheme.

Every payload a node puts on Zenoh (sensor frame, command, log batches, summaries, reports,
preview) travels as ``payload || tag``, where

.. math:: tag = \\operatorname{HMAC-SHA256}(K,\\ L \\,\\|\\, k \\,\\|\\, 0 \\,\\|\\, p)[0:16]

with K the run's 32-byte secret, L the domain-separation label :data:`ZENOH_LABEL`, k the
key expression the payload is put on (``fowt/<turbine>/<suffix>``, UTF-8) and p the codec
payload. The key expression names the turbine and the message type, so a signed payload
cannot be replayed as another type or for another turbine; the codec header inside p names
the message id and schema version again. The receiver checks the tag *before* decoding
(:func:`verify`, constant-time compare) and counts a failure under the reason ``auth``
(:class:`AuthError`, a :class:`~bus_schemas.codec.DecodeError`). Freshness is not in the
tag: a replayed signed frame is refused by the nodes' sequence checks as a duplicate.

A 128-bit tag leaves a forger a chance of 2^-128 per attempt (HMAC-SHA256 truncated to
16 bytes keeps its full strength up to that length, NIST SP 800-107). CAN frames carry a
shorter authenticator in the spirit of AUTOSAR SecOC (:mod:`bus_schemas.can_codec`), made
from the same secret under another label (:data:`CAN_LABEL`).

The secret lives in a file of mode 0600 in the run's folder, made by the launcher
(:func:`create_key_file`) and read by each node (:func:`read_key_file`); see
``docs/security.md``.
"""

from __future__ import annotations

import hmac
import os
import secrets
import stat
from pathlib import Path

from bus_schemas.codec import DecodeError

#: Bytes of the run's secret.
KEY_BYTES = 32
#: Bytes of a Zenoh payload's tag (HMAC-SHA256 truncated).
TAG_BYTES = 16
#: Domain-separation label of the Zenoh payload tag.
ZENOH_LABEL = b"fowt-hil/zenoh-payload/v1\x00"
#: Domain-separation label of the CAN authenticator (:mod:`bus_schemas.can_codec`).
CAN_LABEL = b"fowt-hil/can-secoc/v1\x00"
#: Domain-separation label of the Zenoh session password (:func:`session_credentials`).
SESSION_LABEL = b"fowt-hil/zenoh-session/v1\x00"
#: Zenoh user name of every authenticated bench node (the password is what is secret).
SESSION_USER = "fowt-hil"
#: File name of the run's secret in its folder.
KEY_FILE_NAME = "run.key"


class AuthError(DecodeError):
    """A payload without a valid tag: unsigned, forged, signed with another key or for
    another key expression."""

    reason = "auth"


class KeyFileError(ValueError):
    """A key file the bench refuses to use (missing, wrong size, readable by others)."""


def _mac(secret: bytes, label: bytes, key_expr: bytes, payload: bytes | memoryview) -> bytes:
    return hmac.digest(secret, b"".join((label, key_expr, b"\x00", payload)), "sha256")


def sign(secret: bytes, key_expr: str, payload: bytes) -> bytes:
    """``payload`` followed by its 16-byte tag for ``key_expr`` (module docstring)."""
    return payload + _mac(secret, ZENOH_LABEL, key_expr.encode(), payload)[:TAG_BYTES]


def verify(secret: bytes, key_expr: str, data: bytes | bytearray | memoryview) -> bytes:
    """The payload of ``data`` (``payload || tag``) if its tag is right for ``key_expr``.

    Raises
    ------
    AuthError
        When ``data`` is shorter than a tag or the tag does not match (compared in
        constant time).
    """
    if len(data) < TAG_BYTES:
        raise AuthError(f"{key_expr}: {len(data)} bytes, no room for a {TAG_BYTES}-byte tag")
    view = memoryview(data)
    payload = bytes(view[:-TAG_BYTES])
    tag = _mac(secret, ZENOH_LABEL, key_expr.encode(), payload)[:TAG_BYTES]
    if not hmac.compare_digest(tag, bytes(view[-TAG_BYTES:])):
        raise AuthError(f"{key_expr}: authentication tag does not match")
    return payload


def can_mac(secret: bytes, message_id: int, freshness: int, data: bytes, size: int) -> bytes:
    """The truncated CAN authenticator (``size`` bytes) of one message instance.

    Computed over :data:`CAN_LABEL`, the message's base CAN id (2 bytes LE), the freshness
    value (4 bytes LE) and every data byte of the instance's frames, in part order.
    """
    head = message_id.to_bytes(2, "little") + (freshness & 0xFFFFFFFF).to_bytes(4, "little")
    return hmac.digest(secret, CAN_LABEL + head + data, "sha256")[:size]


def session_credentials(secret: bytes) -> tuple[str, str]:
    """The Zenoh transport credential (user, password) of the run whose secret is ``secret``.

    Every node of an authenticated run opens its Zenoh session with this user name and
    password (``transport/auth/usrpwd``), and a node that listens accepts a link only from
    a session that proves it holds the same password (Zenoh's challenge-response: the
    password itself never crosses the link). The password is
    ``hex(HMAC-SHA256(K, SESSION_LABEL))``: derived from the run's secret, so holding
    ``run.key`` is holding the credential, and a session password that leaks (it sits in
    the node's memory and, for a moment, in a 0600 file Zenoh reads) does not give away K,
    which signs the payloads.
    """
    return SESSION_USER, hmac.digest(secret, SESSION_LABEL, "sha256").hex()


def new_key() -> bytes:
    """A fresh 32-byte secret from the operating system's CSPRNG."""
    return secrets.token_bytes(KEY_BYTES)


def create_key_file(path: Path) -> bytes:
    """Write a fresh secret to ``path`` (created, never overwritten, mode 0600); return it.

    Raises
    ------
    FileExistsError
        If ``path`` exists (a secret is never reused across runs).
    """
    key = new_key()
    fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
    try:
        os.write(fd, key)
    finally:
        os.close(fd)
    return key


def read_key_file(path: Path) -> bytes:
    """The secret in ``path``, checked: exactly :data:`KEY_BYTES` bytes, no group/other access.

    Raises
    ------
    KeyFileError
        If the file is missing, of another size, or readable or writable by group or others.
    """
    try:
        st = path.stat()
        data = path.read_bytes()
    except OSError as exc:
        raise KeyFileError(f"key file {path}: {exc.strerror or exc}") from exc
    if stat.S_IMODE(st.st_mode) & 0o077:
        raise KeyFileError(
            f"key file {path}: mode {stat.S_IMODE(st.st_mode):04o} lets others read it; "
            "expected 0600"
        )
    if len(data) != KEY_BYTES:
        raise KeyFileError(f"key file {path}: {len(data)} bytes, expected {KEY_BYTES}")
    return data


__all__ = [
    "CAN_LABEL",
    "KEY_BYTES",
    "KEY_FILE_NAME",
    "SESSION_LABEL",
    "SESSION_USER",
    "TAG_BYTES",
    "ZENOH_LABEL",
    "AuthError",
    "KeyFileError",
    "can_mac",
    "create_key_file",
    "new_key",
    "read_key_file",
    "session_credentials",
    "sign",
    "verify",
]
