"""ROS 2 message definitions and CDR payloads of the run log, derived from the declarations.

Every message of :mod:`bus_schemas.messages` is logged in the MCAP run log as a ``ros2msg``
schema (:func:`msgdef`, named :func:`schema_name`) with ``cdr`` message encoding: the
encoding ROS 2 itself records, which Foxglove, ``mcap cat``, ``mcap-ros2-support`` and any
ROS 2 tool decode without this package. Nothing here is written per message by hand: the
text and the byte layout are generated from the one declaration per message (its field
order and wire types, :class:`bus_schemas.codec.FieldSpec`), beside the DBC and the wire
codec.

CDR layout (OMG CDR as ROS 2's rmw writes it: XCDR1, "plain" CDR, little endian)::

    encapsulation header 00 01 00 00 (CDR_LE, options 0) | fields in declaration order

Each primitive is aligned to its own size, alignment counted from the first byte after the
4-byte encapsulation header; a struct carries no trailing padding (the payload ends with its
last field, as Fast-CDR and ``mcap-ros2-support`` write it). Wire types map one to one:
``u64 -> uint64``, ``i64 -> int64``, ``u32 -> uint32``, ``u8 -> uint8``, ``f64 -> float64``.
Every message holds numbers only, so a payload has a fixed size and a whole run's messages
of one type are one numpy structured array (:func:`cdr_dtype`): encoding is a column copy
per field (:func:`encode_rows`), decoding a ``frombuffer`` (:func:`decode`).
"""

from __future__ import annotations

import functools

import numpy as np

from bus_schemas.registry import MessageType

#: The ROS 2 package name of every schema (``fowt_hil/msg/<Name>``).
ROS2_PACKAGE = "fowt_hil"
#: The CDR encapsulation header of every payload: representation CDR_LE, options 0.
CDR_HEADER = b"\x00\x01\x00\x00"
#: Bytes of :data:`CDR_HEADER` (alignment counts from its end).
CDR_HEADER_BYTES = 4

_ROS2_TYPE = {"u64": "uint64", "i64": "int64", "u32": "uint32", "u8": "uint8", "f64": "float64"}
_NUMPY_TYPE = {"u64": "<u8", "i64": "<i8", "u32": "<u4", "u8": "u1", "f64": "<f8"}


class CdrLengthError(ValueError):
    """Data that is not a whole number of a message type's CDR payloads (or has a wrong
    encapsulation header)."""


def schema_name(mt: MessageType) -> str:
    """The ros2msg schema name of ``mt``, e.g. ``fowt_hil/msg/SensorFrame``."""
    return f"{ROS2_PACKAGE}/msg/{mt.name}"


@functools.cache
def msgdef(mt: MessageType) -> str:
    """The ROS 2 message definition (``.msg`` text) of ``mt``.

    One ``<type> <field_name>`` line per field in declaration order, each followed by a
    comment with its description, unit and range; a first comment line names the message
    and its schema version.
    """
    doc = (mt.cls.__doc__ or "").strip().splitlines()
    lines = [f"# fowt-hil {mt.name} v{mt.version}: {doc[0] if doc else mt.name}"]
    for f in mt.codec.fields:
        if f.is_float:
            lo, hi = repr(f.minimum), repr(f.maximum)
        else:  # the declared range within the wire type's (a float bound may round past it)
            info = np.iinfo(np.dtype(_NUMPY_TYPE[f.wire]))
            lo = str(max(int(f.minimum), int(info.min)))
            hi = str(min(int(f.maximum), int(info.max)))
        line = f"{_ROS2_TYPE[f.wire]} {f.name}  # {f.description} [{f.unit}]"
        lines.append(f"{line} range {lo}..{hi}")
    return "\n".join(lines) + "\n"


def _layout(fields: list[tuple[str, str]]) -> np.dtype[np.void]:
    """The CDR payload dtype of ``(name, numpy type)`` fields in order (module docstring)."""
    names = ["_cdr_header"]
    formats: list[str] = ["V4"]
    offsets = [0]
    pos = 0  # from the end of the encapsulation header
    for name, kind in fields:
        size = np.dtype(kind).itemsize
        pos = -(-pos // size) * size  # aligned to its own size
        names.append(name)
        formats.append(kind)
        offsets.append(CDR_HEADER_BYTES + pos)
        pos += size
    return np.dtype(
        {"names": names, "formats": formats, "offsets": offsets, "itemsize": CDR_HEADER_BYTES + pos}
    )


@functools.cache
def cdr_dtype(mt: MessageType) -> np.dtype[np.void]:
    """Structured little-endian dtype of one whole CDR payload of ``mt``.

    Field ``_cdr_header`` (``V4``, :data:`CDR_HEADER`) at offset 0, then the message's
    fields at their aligned CDR offsets (module docstring); ``itemsize`` is the payload's
    length, so ``n`` concatenated payloads are an array of ``n`` records.
    """
    return _layout([(f.name, _NUMPY_TYPE[f.wire]) for f in mt.codec.fields])


_FROM_ROS2 = {ros: _NUMPY_TYPE[wire] for wire, ros in _ROS2_TYPE.items()}


@functools.cache
def dtype_of_msgdef(text: str) -> np.dtype[np.void]:
    """The CDR payload dtype of a message definition of :func:`msgdef`'s form (a run log's
    own schema, of whatever schema version it was written with).

    Raises
    ------
    ValueError
        For a line that is not ``<type> <name>`` of a fixed-size primitive this module writes.
    """
    fields = []
    for line in text.splitlines():
        body = line.split("#", 1)[0].strip()
        if not body:
            continue
        parts = body.split()
        if len(parts) != 2 or parts[0] not in _FROM_ROS2:
            raise ValueError(f"ros2msg line {line!r}: expected '<primitive type> <name>'")
        fields.append((parts[1], _FROM_ROS2[parts[0]]))
    return _layout(fields)


def encode_rows(mt: MessageType, rows: np.ndarray) -> np.ndarray:
    """CDR payloads of ``rows`` (a 1-D array of ``mt.row_dtype`` or any array with its fields).

    Returns a contiguous 1-D array of :func:`cdr_dtype` whose ``tobytes()`` is the
    concatenated payloads (padding bytes zero). Integers are cast to their wire type
    (the bus codec has checked their ranges).
    """
    dtype = cdr_dtype(mt)
    out = np.zeros(len(rows), dtype)
    out["_cdr_header"] = np.frombuffer(CDR_HEADER, "V4")[0]
    for name in mt.cls.__struct_fields__:
        out[name] = rows[name]
    return out


def decode(mt: MessageType, data: bytes | bytearray | memoryview) -> np.ndarray:
    """The records of concatenated CDR payloads of ``mt`` (a read-only array of
    :func:`cdr_dtype`; :func:`decode_as` with that dtype).

    Raises
    ------
    CdrLengthError
        If the length is not a multiple of the payload's, or a payload's encapsulation
        header is not :data:`CDR_HEADER`.
    """
    return decode_as(cdr_dtype(mt), data, schema_name(mt))


def decode_as(
    dtype: np.dtype[np.void], data: bytes | bytearray | memoryview, what: str = "CDR"
) -> np.ndarray:
    """The records of concatenated CDR payloads of layout ``dtype`` (:func:`cdr_dtype`,
    :func:`dtype_of_msgdef`); ``what`` names them in an error (:class:`CdrLengthError`)."""
    n = memoryview(data).nbytes
    if n % dtype.itemsize:
        raise CdrLengthError(
            f"{what}: {n} bytes are not a whole number of {dtype.itemsize}-byte CDR payloads"
        )
    recs = np.frombuffer(data, dtype)
    if len(recs):
        head = np.frombuffer(data, np.uint8).reshape(len(recs), dtype.itemsize)[:, :4]
        if np.any(head != np.frombuffer(CDR_HEADER, np.uint8)):
            raise CdrLengthError(f"{what}: a payload whose encapsulation header is not CDR_LE")
    return recs


__all__ = [
    "CDR_HEADER",
    "ROS2_PACKAGE",
    "CdrLengthError",
    "cdr_dtype",
    "decode",
    "decode_as",
    "dtype_of_msgdef",
    "encode_rows",
    "msgdef",
    "schema_name",
]
