"""ROS 2 message definitions and CDR payloads of the registered per-cycle messages.

A message type's ros2msg schema is ``fowt_hil/msg/<Name>``: one ``int64`` or ``float64`` field
per Struct field, in declaration order (:attr:`bus_schemas.registry.MessageType.row_dtype`).
Its CDR payload (XCDR1, little endian) is the 4-byte encapsulation header
``00 01 00 00`` followed by the fields; every field is 8 bytes, so each sits at an offset
(after the header) that is a multiple of 8, as XCDR1 alignment asks, without padding. A run of
such payloads back to back is therefore an array of :func:`cdr_dtype` records.
"""

from __future__ import annotations

import numpy as np

from bus_schemas.registry import MessageType

ROS2_PACKAGE = "fowt_hil"

#: CDR encapsulation header: representation identifier CDR_LE (0x0001), options 0.
CDR_LE_HEADER = b"\x00\x01\x00\x00"


def schema_name(mt: MessageType) -> str:
    """The ros2msg schema name of ``mt``, e.g. ``fowt_hil/msg/SensorFrame``."""
    return f"{ROS2_PACKAGE}/msg/{mt.name}"


def msgdef(mt: MessageType) -> str:
    """The ROS 2 message definition (``.msg`` text): ``<type> <name>`` per field."""
    return "".join(f"{'float64' if f.is_float else 'int64'} {f.name}\n" for f in mt.codec.fields)


def cdr_dtype(mt: MessageType) -> np.dtype[np.void]:
    """Structured little-endian dtype of one whole CDR payload of ``mt`` (header first)."""
    fields: list[tuple[str, str]] = [("_cdr_header", "V4")]
    fields += [(f.name, "<f8" if f.is_float else "<i8") for f in mt.codec.fields]
    return np.dtype(fields)


def encode_rows(mt: MessageType, rows: np.ndarray) -> np.ndarray:
    """CDR payloads of ``rows`` (any array with ``mt``'s fields) as :func:`cdr_dtype` records."""
    out = np.zeros(len(rows), cdr_dtype(mt))
    out["_cdr_header"] = np.frombuffer(CDR_LE_HEADER, "V4")[0]
    for f in mt.codec.fields:
        out[f.name] = rows[f.name]
    return out


def decode(mt: MessageType, data: bytes | bytearray | memoryview) -> np.ndarray:
    """The records of concatenated CDR payloads of ``mt`` (read-only :func:`cdr_dtype` array).

    Raises
    ------
    ValueError
        If ``data`` is not a whole number of payloads.
    """
    dtype = cdr_dtype(mt)
    if len(data) % dtype.itemsize:
        raise ValueError(
            f"{len(data)} bytes are not a whole number of {mt.name} CDR payloads "
            f"({dtype.itemsize} bytes each)"
        )
    return np.frombuffer(data, dtype)
