"""A run log written by a child process, for the in-process mode.

The simulation loop hands its messages over in one of two ways, freely mixed:

* :meth:`BackgroundRunLog.publish` (one Struct): the message goes into its type's list of
  the batch being filled and its message id into the batch's order (two list appends,
  about 0.15 us); the batch's Structs are encoded as msgpack in one msgspec call when it
  is sent (floats copied as 8 bytes, not formatted; 0.1 to 0.35 us a message);
* :meth:`BackgroundRunLog.publish_block` (many messages as rows of
  :attr:`bus_schemas.registry.MessageType.row_dtype`, e.g. several control cycles
  written by a compiled loop): the rows' bytes are appended to their type's buffer in the
  batch and the ids to its order with :data:`ROW_FLAG` set; no Struct and no Python work
  per message (about 0.3-0.4 us a message for blocks of 8 cycles, the checks included).

The MCAP ``publish_time`` of a message is its own ``publish_time_ns`` (the host's
monotonic clock) moved to the unix epoch: in process, publishing and logging are the same
moment; ``log_time`` is the run's start plus ``sample_time_ns``. A full batch goes through
a pipe to a child process, on the other core, that does the expensive part
(:class:`_BatchFramer`): the batch's msgpack is decoded; Structs are JSON-encoded per type
in one msgspec call each; the rows' values are gathered in publish order by a compiled
kernel (:func:`_gather_kernel`: the floats into one list, the ints into another) and
formatted by orjson, one call each (:func:`_json_numbers` says why that is msgspec's text
but for a positive exponent's ``+``); one compiled kernel (:func:`_records_kernel`) then
writes every message's whole MCAP Message record, in publish order, into a buffer kept
from batch to batch: the 31-byte header (opcode, length, channel, per-channel sequence, log
and publish time) and the JSON (a row's keys interleaved with its values, each copied from
orjson's text up to its separator, the ``+`` left out), and the MessageIndex entries in the
same pass; :meth:`hil.mcap_log.BatchRunLog.write_chunk` compresses the buffer and writes it
as one MCAP Chunk with its message indexes. The path before it (:func:`_encode_batch`:
msgspec's lists, a value scan, kernels leaving 31-byte gaps that
:meth:`~hil.mcap_log.BatchRunLog.write_batch` fills with numpy-built headers) is kept as
the reference: tests/test_log_writer.py holds the two to the same file, byte for byte. The
JSON is byte for byte the one msgspec writes for the Struct with the same values (same
keys, same order, the same number formatting; NaN and inf are ``null`` both ways). A row
holds float64 in a float field, so a float field is always written as a float (``0.0``),
where a Struct given a Python int there would write ``0``: equal values, not always equal
text. If the parent dies, the child sees the pipe close and finishes the file, so nothing
handed over is lost.

Cost (bench/log_writer_speed.py ``--passes 4 --rounds 3 --compare-python
REF/.venv/bin/python --compare-root REF``: the five per-cycle messages of a
real 60 s LC2 run, 48 000 messages a round, rows in blocks of 8 cycles, alternating with
main's code (a704bdc, the path before); load 0.7-1.1; bench/results/log_writer_speed_s13.json):
the child needs 1.84 us of CPU a message for the lqri_ff stream (median 1.88; main 2.85,
median 3.11) and 1.70 for the baseline's (median 1.77; main 2.64, median 3.67), within the
2.5 us a message that 2000x real time leaves at five messages a 25 ms cycle. Its stages
(the same batches in this process, best of 5 interleaved passes, lqri_ff / baseline):
decode 0.01 / 0.02 us, numbers (gather and orjson) 0.33 / 0.30 (orjson alone 0.29 /
0.26), records 0.15 / 0.14, zstd level 1 0.92 / 0.78, framing 0.38 / 0.31 (CRC-32 0.18 /
0.17, MessageIndexes, writes): 1.80 / 1.54 us against 2.73 / 2.57 for the reference path
on the same batches. What bounds it: zstd level 1, about half, then orjson's float
formatting and the chunk's CRC-32 (zlib, ~3.7 GB/s; a table CRC in numba ran at 2.2 GB/s).
The zstd parameters measured beside it (hash table 2^11 / 2^13, window 2^17, min match 5 /
6, level 1's own tables) are no faster at the same size; acceleration 2, levels -1 to -5
and lz4 save 0.05-0.25 us at 1.6-2.1 times the file, no compression 0.92 us at 6.6 times:
the default stays zstd level 1 (:data:`hil.mcap_log.ZSTD_WINDOW_LOG`). Batches of 512,
2048 and 4096 messages (one run each) cost no less than 1024's, and 4096 makes the file
only 0.9 % smaller, so :data:`BATCH_MESSAGES` stays.

Data in flight (what a SIGKILL of the run's process loses): a batch goes to the writer when
it holds :data:`BATCH_MESSAGES` messages, and whatever went into the pipe survives the
parent (the kernel keeps it for the child). A killed run therefore loses at most the batch
being filled: at most 1023 messages, about 200 control cycles of 5 messages (5 s of
simulated time at 40 Hz, 2 s at 100 Hz; at 1000x real time about 5 ms of wall time),
whether they came one by one or in blocks (a block is split at the batch's end, so every
batch holds exactly :data:`BATCH_MESSAGES`). The batch is cut by count only, so what
survives a kill does not depend on the machine's load.
The lock-step and real-time modes do not use this path: their recorder flushes a chunk
every 0.25 s of wall time (:class:`hil.mcap_log.RunLog`).
"""

from __future__ import annotations

import abc
import contextlib
import fcntl
import multiprocessing
import multiprocessing.util
import os
import signal
import sys
import time
import typing
from collections.abc import Callable, Mapping
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import msgspec
import numba
import numpy as np
import orjson
from llvmlite import ir  # type: ignore[import-untyped]
from numba.core import types as nbtypes
from numba.cpython.unsafe.numbers import trailing_zeros as _trailing_zeros_intrinsic
from numba.extending import intrinsic

from bus_schemas.registry import MESSAGES, MessageType
from hil.mcap_log import MESSAGE_HEADER_BYTES, BatchRunLog

_BY_ID = {mt.message_id: mt for mt in MESSAGES}

#: Messages per batch (one MCAP chunk each); bench/inprocess_speed.py measured the choice.
BATCH_MESSAGES = 1024
#: Pipe buffer asked for (Linux F_SETPIPE_SZ; capped by /proc/sys/fs/pipe-max-size) [bytes]:
#: a few batches fit, so the loop does not wait whenever the writer is briefly descheduled.
PIPE_BYTES = 1 << 20


#: Bytes of the writer's last error text shared with the parent (:class:`LogWriteError`).
_ERROR_BYTES = 1024


class LogWriteError(RuntimeError):
    """The log writer could not write the file (disk full, file too large, I/O error).

    The message names the file and the system's reason; what the writer had written before
    stays in the file (it is readable up to the failure, as a truncated file).
    """


#: Set in a batch's order byte for a message given as a row (:meth:`publish_block`); the low
#: seven bits are its message id.
ROW_FLAG = 0x80

if any(not 0 <= mt.message_id < ROW_FLAG for mt in MESSAGES):  # one byte each, with ROW_FLAG
    raise ImportError("hil.log_writer: message ids must be 0..127 (one byte in a batch)")


def _loose_struct(mt: MessageType) -> type[msgspec.Struct]:
    """A Struct with ``mt``'s fields in order, without their constraints, for decoding.

    msgspec's decoders refuse the registry types' integer bounds beyond int64; this twin
    decodes the msgpack the parent wrote, and its JSON is the registry type's (same keys,
    same order; a float field keeps an int it was given, as the Struct's own JSON does).
    """
    hints = typing.get_type_hints(mt.cls)
    fields = [(f, int if hints[f] is int else int | float) for f in mt.cls.__struct_fields__]
    return msgspec.defstruct(f"_Loose{mt.name}", fields)


def _decoders() -> dict[int, Any]:
    """Per message id: the decoder of a msgpack array of that message (one call a batch)."""
    return {
        mt.message_id: msgspec.msgpack.Decoder(list.__class_getitem__(_loose_struct(mt))).decode
        for mt in MESSAGES
    }


#: A batch on the pipe: the order (per message one byte: its message id, with
#: :data:`ROW_FLAG` set for a message given as a row), per message id the msgpack array of
#: its messages given as Structs, and per message id the bytes of its rows (``row_dtype``),
#: each in publish order.
_decode_batch = msgspec.msgpack.Decoder(
    tuple[bytes, dict[int, msgspec.Raw], dict[int, bytes]]
).decode
_encode_batch_payload = msgspec.msgpack.Encoder().encode
_json_encode = msgspec.json.Encoder().encode
_orjson_dumps = orjson.dumps
_ORJSON_NUMPY = orjson.OPT_SERIALIZE_NUMPY
_CLOSE_BRACE = ord("}")


_F = typing.TypeVar("_F", bound=Callable[..., Any])


def _njit(fn: _F) -> _F:
    """``numba.njit(cache=True)`` (compiled on first use, cached on disk), typed as ``fn``."""
    return typing.cast(_F, numba.njit(cache=True)(fn))


# The kernels index with unsigned integers: numba then skips the negative-index wrap-around
# check on every byte (3-4 times faster here).
_U = numba.uint64


@_njit
def _values_kernel(text: np.ndarray, sep: np.ndarray) -> int:  # pragma: no cover - compiled
    """Where each value of a flat JSON list of numbers (``[v,v,...]``; a value never holds a
    comma or a bracket) ends: the index of the comma or ``]`` after it. Returns how many
    were found. Branch-free: one store a byte."""
    count = 0
    for i in range(1, text.shape[0]):
        c = text[_U(i)]
        sep[_U(count)] = i
        count += (c == 44) | (c == 93)  # "," "]"
    return count


@_njit
def _rows_kernel(
    ftext: np.ndarray,
    fsep: np.ndarray,
    itext: np.ndarray,
    isep: np.ndarray,
    is_float: np.ndarray,
    keys: np.ndarray,
    key_at: np.ndarray,
    dest: np.ndarray,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled (its results are tested byte for byte)
    """Write each row of one type as its Struct's JSON at its place in the record buffer.

    ``ftext`` / ``itext`` are msgspec's JSON of the flat lists of the rows' float / int
    values in row order; ``fsep`` / ``isep`` where each value in them ends
    (:func:`_values_kernel`; a value starts after the previous one's separator). Row ``r``
    goes to ``out[dest[r]:]``: ``{``, then per field its key (``"name":``, after a comma
    from the second on: ``keys`` from ``key_at[j]`` to ``key_at[j + 1]``) and the text of
    the next float or int value, then ``}``.
    """
    fi = 0
    ii = 0
    fnext = 1  # where the next float value starts (after "[") ...
    inext = 1  # ... and the next int value
    nfields = is_float.shape[0]
    for r in range(dest.shape[0]):
        o = dest[r]
        for j in range(nfields):
            ks = key_at[j]
            kl = key_at[j + 1] - ks
            for k in range(kl):
                out[_U(o + k)] = keys[_U(ks + k)]
            o += kl
            if is_float[j]:
                s = fnext
                e = fsep[fi]
                for k in range(e - s):
                    out[_U(o + k)] = ftext[_U(s + k)]
                fnext = e + 1
                fi += 1
            else:
                s = inext
                e = isep[ii]
                for k in range(e - s):
                    out[_U(o + k)] = itext[_U(s + k)]
                inext = e + 1
                ii += 1
            o += e - s
        out[_U(o)] = 125  # "}"


@_njit
def _texts_kernel(
    text: np.ndarray, start: np.ndarray, length: np.ndarray, dest: np.ndarray, out: np.ndarray
) -> None:  # pragma: no cover - compiled (its results are tested byte for byte)
    """Copy ``text[start[i]:start[i] + length[i]]`` to ``out[dest[i]:]``."""
    for i in range(dest.shape[0]):
        s = start[i]
        o = dest[i]
        for k in range(length[i]):
            out[_U(o + k)] = text[_U(s + k)]


@_njit
def _place_headers(
    buf: np.ndarray, offsets: np.ndarray, headers: np.ndarray
) -> None:  # pragma: no cover - compiled (its results are tested byte for byte)
    """``buf[offsets[i]:offsets[i] + 31] = headers[i]`` (:class:`BatchRunLog`'s record
    headers; a compiled loop instead of one numpy assignment through an index array)."""
    for i in range(offsets.shape[0]):
        o = offsets[i]
        for k in range(headers.shape[1]):
            buf[_U(o + k)] = headers[i, k]


def _values(text: bytes, expected: int, per_row: int) -> tuple[np.ndarray, np.ndarray, Any]:
    """A flat JSON list's bytes, where each value ends, and the value bytes of each row
    (``per_row`` values a row, ``expected`` in all)."""
    t = np.frombuffer(text, np.uint8)
    sep = np.empty(expected + 1, np.int64)
    found = _values_kernel(t, sep) if expected else 0
    if found != expected:
        raise ValueError(f"batch: {found} values in the rows' JSON, expected {expected}")
    if not expected:
        return t, sep, 0
    # A row's values run from after the separator before its first to its last separator,
    # less the commas between them.
    before = np.empty(expected // per_row, np.int64)
    before[0] = 0  # "["
    before[1:] = sep[per_row - 1 : expected - 1 : per_row]
    return t, sep, sep[per_row - 1 : expected : per_row] - before - per_row


def _json_numbers(values: np.ndarray) -> bytes:
    """``values`` (1-D float64 or int64) as msgspec writes the list of them: ``[v,v,...]``.

    orjson formats the numbers straight from the array (about 40 ns a float, against about
    100 ns for ``tolist`` and msgspec); its floats are the same shortest round-trip digits
    with the same switch to exponent notation, and differ only in writing a positive
    exponent as ``e+16`` where msgspec writes ``e16`` (no other ``e+`` can occur in a list
    of numbers). NaN and infinities are ``null`` in both. tests/test_log_writer.py holds the
    result to msgspec's JSON of the Struct byte for byte, extreme values included.
    """
    text: bytes = _orjson_dumps(values, option=_ORJSON_NUMPY)
    return text.replace(b"e+", b"e") if values.dtype.kind == "f" else text


class _RowType:
    """How one message type's rows become its Struct's JSON (:func:`_rows_kernel`)."""

    def __init__(self, mt: MessageType) -> None:
        dtype = mt.row_dtype
        self.dtype = dtype
        names = dtype.names or ()
        self.nfields = len(names)
        kinds = [dtype[name].kind == "f" for name in names]
        self.is_float = np.array(kinds, np.uint8)
        self.float_cols = np.flatnonzero(self.is_float)
        self.int_cols = np.flatnonzero(self.is_float == 0)
        prefixes = [
            ("{" if j == 0 else ",").encode() + _json_encode(name) + b":"
            for j, name in enumerate(names)
        ]
        self.keys = np.frombuffer(b"".join(prefixes), np.uint8)
        self.key_at = np.zeros(len(prefixes) + 1, np.int64)
        np.cumsum([len(p) for p in prefixes], out=self.key_at[1:])
        self.key_bytes = int(self.key_at[-1]) + 1  # the keys and the closing brace of a row
        self.sample_col = names.index("sample_time_ns")
        self.publish_col = names.index("publish_time_ns")
        if kinds[self.sample_col] or kinds[self.publish_col]:
            raise ImportError(f"hil.log_writer: {mt.name}'s time stamps must be int fields")

    def texts(self, raw: bytes) -> tuple[Any, ...]:
        """The rows' float and int values as JSON (one msgspec call each), where each value
        is in them, each row's JSON length, and the rows as int64."""
        a = np.frombuffer(raw, np.float64).reshape(-1, self.nfields)
        n = len(a)
        nf, ni = n * len(self.float_cols), n * len(self.int_cols)
        ftext, fsep, flen = _values(
            _json_numbers(a[:, self.float_cols].ravel()), nf, len(self.float_cols)
        )
        ints = a.view(np.int64)
        itext, isep, ilen = _values(
            _json_numbers(ints[:, self.int_cols].ravel()), ni, len(self.int_cols)
        )
        lengths = self.key_bytes + flen + ilen + np.zeros(n, np.int64)
        return (ftext, fsep, itext, isep), lengths, ints

    def write(self, texts: tuple[Any, ...], dest: np.ndarray, out: np.ndarray) -> None:
        """Write the rows' JSON at ``dest`` in ``out`` (:func:`_rows_kernel`)."""
        ft, fs, it, ist = texts
        _rows_kernel(ft, fs, it, ist, self.is_float, self.keys, self.key_at, dest, out)


_ROW_TYPES = {mt.message_id: _RowType(mt) for mt in MESSAGES}


def _warm_kernels(framer: _BatchFramer | None = None) -> None:
    """Compile (first run) or load (from numba's cache) the kernels, before the first batch:
    the fused path's through ``framer`` (batches encoded, not written), else the reference
    path's (:func:`_encode_batch`, :func:`_place_headers`)."""
    blobs = []
    for mid, rt in _ROW_TYPES.items():
        blobs.append(
            _encode_batch_payload((bytes([mid | ROW_FLAG]), {}, {mid: bytes(8 * rt.nfields)}))
        )
    mt = MESSAGES[0]
    blobs.append(
        _encode_batch_payload(
            (bytes([mt.message_id]), {mt.message_id: [mt.cls(*[0] * _ROW_TYPES[1].nfields)]}, {})
        )
    )
    if framer is not None:
        for blob in blobs:
            framer.encode(blob)
        return
    decoders = _decoders()
    for blob in blobs:
        _encode_batch(blob, decoders)
    meta = np.zeros((1, 4), np.int64)  # as BatchRunLog.write_batch calls it
    _place_headers(
        np.zeros(MESSAGE_HEADER_BYTES, np.uint8), meta[:, 3], np.zeros((1, 31), np.uint8)
    )


def _struct_texts(
    decode: Any, raw: bytes, flags: np.ndarray, message_id: int
) -> tuple[Any, bytes, np.ndarray, np.ndarray, np.ndarray]:
    """One type's Structs of a batch JSON-encoded in one msgspec call (``[{...},{...}]``: a
    flat object of numbers per message, so its closing brace is the only ``}`` of a message
    and marks where it ends). Returns the messages, the text, their places in the batch's
    order and where each message's JSON begins and ends in the text.

    Raises
    ------
    ValueError
        If the messages do not match the order's count of ``message_id``.
    """
    msgs = decode(raw)
    text = _json_encode(msgs)
    ends = np.flatnonzero(np.frombuffer(text, np.uint8) == _CLOSE_BRACE) + 1
    where = np.flatnonzero(flags == message_id)
    if len(ends) != len(msgs) or len(where) != len(msgs):
        raise ValueError(f"batch: message id {message_id} does not match its messages")
    begins = np.empty(len(ends), np.int64)
    begins[0] = 1  # after the list's "["
    begins[1:] = ends[:-1] + 1  # after "},"
    return msgs, text, where, begins, ends


def _encode_batch(
    blob: bytes, decoders: dict[int, Any], unix_minus_monotonic_ns: int = 0
) -> tuple[np.ndarray, bytearray]:
    """JSON-encode a batch: the record buffer (a 31-byte gap before each message's JSON)
    and its (n, 4) table of message id, sample time, publish time (the message's
    ``publish_time_ns`` on the host's monotonic clock, moved to the unix epoch by
    ``unix_minus_monotonic_ns``), record offset.

    Messages given as Structs: each type's are decoded and JSON-encoded in one msgspec call
    (``[{...},{...},...]``: a flat object of numbers per message, so its closing brace is
    the only ``}`` of a message and marks where it ends). Messages given as rows: each
    type's float columns and int columns are JSON-encoded as two flat lists in one msgspec
    call each (the number formatting). Each message's length is then known, so its record's
    place; :func:`_texts_kernel` and :func:`_rows_kernel` write the JSON there (the rows'
    with their keys), one call per type. No Python work per message.
    """
    ids_bytes, by_id, by_rows = _decode_batch(blob)
    flags = np.frombuffer(ids_bytes, np.uint8)
    n = len(flags)
    meta = np.empty((n, 4), np.int64)
    meta[:, 0] = flags & (ROW_FLAG - 1)
    lengths = np.empty(n, np.int64)
    jobs: list[tuple[Any, ...]] = []
    seen = 0
    for mid, raw in by_id.items():
        msgs, text, where, begins, ends = _struct_texts(decoders[mid], raw, flags, mid)
        lengths[where] = ends - begins
        meta[where, 1] = [m.sample_time_ns for m in msgs]
        meta[where, 2] = [m.publish_time_ns for m in msgs]
        jobs.append((None, where, (np.frombuffer(text, np.uint8), begins, ends - begins)))
        seen += len(msgs)
    for message_id, row_bytes in by_rows.items():
        rt = _ROW_TYPES.get(message_id)
        if rt is None or len(row_bytes) % (8 * rt.nfields):
            raise ValueError(f"batch: rows of message id {message_id} do not fit its type")
        texts, row_lengths, ints = rt.texts(row_bytes)
        where = np.flatnonzero(flags == (message_id | ROW_FLAG))
        if len(where) != len(ints):
            raise ValueError(f"batch: message id {message_id} does not match its rows")
        lengths[where] = row_lengths
        meta[where, 1] = ints[:, rt.sample_col]
        meta[where, 2] = ints[:, rt.publish_col]
        jobs.append((rt, where, texts))
        seen += len(ints)
    if seen != n:
        raise ValueError(f"batch: {n} message ids for {seen} messages")
    meta[:, 2] += unix_minus_monotonic_ns
    if n:
        meta[0, 3] = 0
        np.cumsum(lengths[:-1] + MESSAGE_HEADER_BYTES, out=meta[1:, 3])
    total = int(lengths.sum()) + n * MESSAGE_HEADER_BYTES
    records = bytearray(total)
    out = np.frombuffer(records, np.uint8)
    for rt, where, texts in jobs:
        dest = meta[where, 3] + MESSAGE_HEADER_BYTES
        if rt is None:
            _texts_kernel(texts[0], texts[1], texts[2], dest, out)
        else:
            rt.write(texts, dest, out)
    return meta, records


# The fused path (what the writer child runs): per batch, one kernel gathers the rows'
# float and int values in publish order, orjson formats each list in one call, and one
# kernel writes every message's whole MCAP Message record (header and JSON) into the chunk
# buffer in publish order, with the MessageIndex entries grouped by channel.
# :func:`_encode_batch` and :meth:`hil.mcap_log.BatchRunLog.write_batch` above stay as the
# reference (tests/test_log_writer.py holds the two byte for byte against each other).


@_njit
def _gather_kernel(
    flags: np.ndarray,
    rows_f: np.ndarray,
    rows_i: np.ndarray,
    row_base: np.ndarray,
    nfields: np.ndarray,
    field_base: np.ndarray,
    is_float: np.ndarray,
    fout: np.ndarray,
    iout: np.ndarray,
) -> tuple[int, int]:  # pragma: no cover - compiled (its results are tested byte for byte)
    """The rows' float values (``fout``) and int values (``iout``) in publish order, each
    row's in field order. ``rows_f`` / ``rows_i`` are the batch's row bytes (all types, one
    after the other) as float64 / int64; for an order byte ``f`` with :data:`ROW_FLAG`, its
    rows start at ``row_base[f]`` (in 8-byte words), have ``nfields[f]`` fields and the
    kinds ``is_float[field_base[f]:]``. Returns the floats and ints written."""
    cursor = np.zeros(256, np.int64)
    nf = 0
    ni = 0
    for i in range(flags.shape[0]):
        f = flags[_U(i)]
        if f < ROW_FLAG:
            continue
        nfld = nfields[f]
        base = row_base[f] + cursor[f] * nfld
        cursor[f] += 1
        fb = field_base[f]
        for j in range(nfld):
            if is_float[_U(fb + j)]:
                fout[_U(nf)] = rows_f[_U(base + j)]
                nf += 1
            else:
                iout[_U(ni)] = rows_i[_U(base + j)]
                ni += 1
    return nf, ni


def _word_pointer(context: Any, builder: Any, aryty: Any, ary: Any, idx: Any, idxty: Any) -> Any:
    """LLVM pointer to the 8 bytes at ``ary[idx:]`` of a uint8 array (any alignment)."""
    array = context.make_array(aryty)(context, builder, ary)
    at = context.cast(builder, idx, idxty, nbtypes.intp)
    return builder.bitcast(builder.gep(array.data, [at]), ir.IntType(64).as_pointer())


@intrinsic
def _load8_intrinsic(typingctx: Any, arr: Any, idx: Any) -> Any:  # pragma: no cover - compiled
    """The 8 bytes at ``arr[idx:]`` (uint8 array) as a little-endian uint64, unaligned."""

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        ptr = _word_pointer(context, builder, sig.args[0], args[0], args[1], sig.args[1])
        return builder.load(ptr, align=1)

    return nbtypes.uint64(arr, idx), codegen


@intrinsic
def _store8_intrinsic(typingctx: Any, arr: Any, idx: Any, value: Any) -> Any:  # pragma: no cover
    """``arr[idx:idx + 8]`` = ``value`` (uint64, little-endian), unaligned."""

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        ptr = _word_pointer(context, builder, sig.args[0], args[0], args[1], sig.args[1])
        builder.store(args[2], ptr, align=1)
        return context.get_dummy_value()

    return nbtypes.void(arr, idx, nbtypes.uint64), codegen


# As the kernels call them (an intrinsic's own signature starts with numba's typing context).
_load8 = typing.cast(Callable[[np.ndarray, int], np.uint64], _load8_intrinsic)
_store8 = typing.cast(Callable[[np.ndarray, int, np.uint64], None], _store8_intrinsic)
#: Count of trailing zero bits (numba's intrinsic).
_trailing_zeros = typing.cast(Callable[[np.uint64], int], _trailing_zeros_intrinsic)

_ONES = np.uint64(0x0101010101010101)
_HIGHS = np.uint64(0x8080808080808080)
_COMMAS = np.uint64(0x2C2C2C2C2C2C2C2C)  # ","
_BRACKETS = np.uint64(0x5D5D5D5D5D5D5D5D)  # "]"
_PLUSES = np.uint64(0x2B2B2B2B2B2B2B2B)  # "+"


@_njit
def _bytes_equal(word: np.uint64, pattern: np.uint64) -> np.uint64:  # pragma: no cover
    """The high bit of each byte of ``word`` equal to ``pattern``'s, exact up to the first
    such byte (above it a byte may be flagged wrongly: only the lowest flag is read)."""
    y = word ^ pattern
    return (y - _ONES) & ~y & _HIGHS


@_njit
def _copy_value(
    text: np.ndarray, p: int, out: np.ndarray, d: int, plus: bool
) -> tuple[int, int]:  # pragma: no cover - compiled (tested byte for byte)
    """Copy the value at ``text[p:]`` (up to its ``,`` or ``]``; a ``+`` left out if
    ``plus``) to ``out[d:]``, 8 bytes at a time while 8 are left in ``text``. Returns the
    positions after the separator and after the copy. Up to 7 bytes after the copy in
    ``out`` are overwritten with what follows the value in ``text`` (the caller writes
    what belongs there afterwards, and keeps 8 bytes to spare at the end of ``out``)."""
    n = text.shape[0]
    while p + 8 <= n:
        w = _load8(text, p)
        m = _bytes_equal(w, _COMMAS) | _bytes_equal(w, _BRACKETS)
        if plus:
            m |= _bytes_equal(w, _PLUSES)
        _store8(out, d, w)
        if m == 0:
            p += 8
            d += 8
            continue
        t = _trailing_zeros(m) >> 3
        d += t
        p += t + 1
        if text[_U(p - 1)] != 43:  # "," or "]": the value's end; "+": left out, go on
            return p, d
    while True:  # the text's last bytes
        b = text[_U(p)]
        p += 1
        if (b == 44) | (b == 93):
            return p, d
        out[_U(d)] = b
        d += (b != 43) | (not plus)


@_njit
def _put_le(out: np.ndarray, o: int, value: int, nbytes: int) -> None:  # pragma: no cover
    """``value``'s ``nbytes`` low bytes at ``out[o:]``, little-endian (two's complement)."""
    for k in range(nbytes):
        out[_U(o + k)] = (value >> (8 * k)) & 0xFF


@_njit
def _records_kernel(
    flags: np.ndarray,
    chan_of_flag: np.ndarray,
    rows_i: np.ndarray,
    row_base: np.ndarray,
    nfields: np.ndarray,
    field_base: np.ndarray,
    is_float: np.ndarray,
    time_cols: np.ndarray,
    keys: np.ndarray,
    key_at: np.ndarray,
    ftext: np.ndarray,
    itext: np.ndarray,
    stext: np.ndarray,
    smeta: np.ndarray,
    seq_base: np.ndarray,
    start_unix_ns: int,
    unix_minus_monotonic_ns: int,
    out: np.ndarray,
    entries: np.ndarray,
    counts: np.ndarray,
) -> tuple[int, int, int, int]:  # pragma: no cover - compiled (tested byte for byte)
    """Write a batch's MCAP Message records, in publish order, into ``out``.

    Per message ``i`` (order byte ``f = flags[i]``, channel ``c = chan_of_flag[f]``): the
    31-byte header (opcode 0x05, record length 22 + len(JSON), channel id, sequence
    ``seq_base[c]`` + the channel's messages before it in the batch, log time
    ``start_unix_ns`` + sample time, publish time = ``publish_time_ns`` +
    ``unix_minus_monotonic_ns``; little-endian), then the JSON:

    * a row (``f`` with :data:`ROW_FLAG`; its int fields in ``rows_i`` as in
      :func:`_gather_kernel`; sample and publish time in fields ``time_cols[f, 0 / 1]``):
      per field its key (``keys[key_at[field_base[f] + j]:key_at[... + j + 1]]``,
      ``{"name":`` or ``,"name":``) and the next value of ``ftext`` or ``itext`` (orjson's
      ``[v,v,...]`` of the gathered values: the bytes up to the next ``,`` or ``]``, the
      ``+`` of a positive exponent left out, msgspec's text), then ``}``;
    * a Struct: ``stext[smeta[i, 0]:smeta[i, 0] + smeta[i, 1]]``, sample and publish time
      ``smeta[i, 2 / 3]``.

    ``entries`` gets each message's (log time, record offset), grouped by channel in
    ascending channel id, publish order within one (the MessageIndex records);
    ``counts[c]`` the channel's messages. Returns (bytes written, first and last log
    time, status): status 0, or 1 for an unregistered message id, 2 for a value list
    that ends early, 3 for values left over.
    """
    n = flags.shape[0]
    counts[:] = 0
    for i in range(n):
        c = chan_of_flag[flags[_U(i)]]
        if c == 0:
            return 0, 0, 0, 1
        counts[c] += 1
    ebase = np.empty(counts.shape[0], np.int64)
    acc = 0
    for c in range(counts.shape[0]):
        ebase[c] = acc
        acc += counts[c]
    seen = np.zeros(counts.shape[0], np.int64)
    cursor = np.zeros(256, np.int64)
    flen = ftext.shape[0]
    ilen = itext.shape[0]
    fp = 1  # after "["
    ip = 1
    o = 0
    lo = 0
    hi = 0
    for i in range(n):
        f = flags[_U(i)]
        c = chan_of_flag[f]
        start = o
        d = o + 31
        if f >= ROW_FLAG:
            nfld = nfields[f]
            base = row_base[f] + cursor[f] * nfld
            cursor[f] += 1
            sample = rows_i[_U(base + time_cols[f, 0])]
            publish = rows_i[_U(base + time_cols[f, 1])]
            fb = field_base[f]
            for j in range(nfld):
                ks = key_at[_U(fb + j)]
                kl = key_at[_U(fb + j + 1)] - ks
                for k in range(0, kl, 8):  # keys has 8 bytes to spare at its end
                    _store8(out, d + k, _load8(keys, ks + k))
                d += kl
                # A value ends at the next "," or "]"; the text ends with "]", so only
                # the value's start needs a bounds check.
                if is_float[_U(fb + j)]:
                    if fp >= flen:
                        return 0, 0, 0, 2
                    fp, d = _copy_value(ftext, fp, out, d, True)
                else:
                    if ip >= ilen:
                        return 0, 0, 0, 2
                    ip, d = _copy_value(itext, ip, out, d, False)
            out[_U(d)] = 125  # "}"
            d += 1
        else:
            s = smeta[i, 0]
            ln = smeta[i, 1]
            for k in range(ln):
                out[_U(d + k)] = stext[_U(s + k)]
            d += ln
            sample = smeta[i, 2]
            publish = smeta[i, 3]
        log_time = start_unix_ns + sample
        out[_U(start)] = 0x05
        _put_le(out, start + 1, d - start - 9, 8)
        _put_le(out, start + 9, c, 2)
        _put_le(out, start + 11, seq_base[c] + seen[c], 4)
        _put_le(out, start + 15, log_time, 8)
        _put_le(out, start + 23, publish + unix_minus_monotonic_ns, 8)
        e = ebase[c] + seen[c]
        seen[c] += 1
        entries[e, 0] = log_time
        entries[e, 1] = start
        if i == 0:
            lo = log_time
            hi = log_time
        else:
            lo = min(lo, log_time)
            hi = max(hi, log_time)
        o = d
    if not (fp == flen or (fp == 1 and flen <= 2)) or not (ip == ilen or (ip == 1 and ilen <= 2)):
        return 0, 0, 0, 3
    return o, lo, hi, 0


class _BatchFramer:
    """Writes batches from the pipe to a :class:`BatchRunLog`, the fused way.

    Per batch: the msgpack decoded (:data:`_decode_batch`), the Structs JSON-encoded per
    type (one msgspec call each, as in :func:`_encode_batch`), the rows' values gathered
    in publish order (:func:`_gather_kernel`) and formatted by orjson (one call for the
    floats, one for the ints, :func:`_json_numbers`' reasoning), then every record written
    by :func:`_records_kernel` into a buffer kept from batch to batch, which
    :meth:`BatchRunLog.write_chunk` compresses and writes with its MessageIndexes. The
    bytes are those of :func:`_encode_batch` + :meth:`BatchRunLog.write_batch`.
    """

    def __init__(
        self, log: BatchRunLog, decoders: dict[int, Any], unix_minus_monotonic_ns: int = 0
    ) -> None:
        self.log = log
        self.decoders = decoders
        self.unix_minus_monotonic_ns = unix_minus_monotonic_ns
        # Per order byte (a message id, with ROW_FLAG for rows): its channel (0: none), and
        # for a row type its field count, where its fields' kinds and keys start in the
        # tables, its time stamps' columns.
        self.chan_of_flag = np.zeros(256, np.int64)
        self.nfields = np.zeros(256, np.int64)
        self.field_base = np.zeros(256, np.int64)
        self.time_cols = np.zeros((256, 2), np.int64)
        self.nfloat = np.zeros(256, np.int64)
        self.key_bytes = np.zeros(256, np.int64)  # a row's JSON less its values
        kinds: list[np.ndarray] = []
        keys: list[bytes] = []
        key_at: list[int] = []
        at = 0
        nfld = 0
        for mid, rt in _ROW_TYPES.items():
            f = mid | ROW_FLAG
            self.nfields[f] = rt.nfields
            self.field_base[f] = nfld
            self.time_cols[f] = rt.sample_col, rt.publish_col
            self.nfloat[f] = len(rt.float_cols)
            self.key_bytes[f] = rt.key_bytes
            kinds.append(rt.is_float)
            raw = rt.keys.tobytes()
            keys.append(raw)
            key_at.extend((at + rt.key_at[:-1]).tolist())
            nfld += rt.nfields
            at += len(raw)
        key_at.append(at)
        self.is_float = np.concatenate(kinds)
        self.keys = np.frombuffer(b"".join(keys) + bytes(8), np.uint8)  # 8 to spare
        self.key_at = np.array(key_at, np.int64)
        self.max_key_bytes = int(self.key_bytes.max())
        for mid in range(ROW_FLAG):
            if mid < len(log.channel_of_message_id):
                self.chan_of_flag[mid] = log.channel_of_message_id[mid]
                self.chan_of_flag[mid | ROW_FLAG] = log.channel_of_message_id[mid]
        self.counts = np.zeros(len(log.channel_seq), np.int64)
        self.out = np.empty(1 << 20, np.uint8)
        self.entries = np.empty((BATCH_MESSAGES, 2), np.int64)
        self._no_structs = np.empty((0, 4), np.int64)
        self._no_text = np.empty(0, np.uint8)

    def encode(
        self, blob: bytes | memoryview
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
        """A batch's chunk records, messages per channel, MessageIndex entries and log time
        range (:meth:`BatchRunLog.write_chunk`'s arguments; the buffers are reused by the
        next call). Sequence numbers continue from the log's (``channel_seq``)."""
        return self.records(self.values(blob))

    def values(self, blob: bytes | memoryview) -> tuple[Any, ...]:
        """Decode a batch, check its parts match, JSON-encode its Structs and its rows'
        numbers (the inputs of :meth:`records`)."""
        ids_bytes, by_id, by_rows = _decode_batch(blob)
        flags = np.frombuffer(ids_bytes, np.uint8)
        n = len(flags)
        per_flag = np.bincount(flags, minlength=256)
        seen = 0
        bound = 0  # bytes of the records but the values' text
        row_base = np.zeros(256, np.int64)
        nf_total = ni_total = 0
        words = 0
        for mid, row_bytes in by_rows.items():
            f = mid | ROW_FLAG
            nfld = int(self.nfields[f]) if 0 <= mid < ROW_FLAG else 0
            k = len(row_bytes) // (8 * nfld) if nfld else -1
            if not nfld or len(row_bytes) % (8 * nfld):
                raise ValueError(f"batch: rows of message id {mid} do not fit its type")
            if k != per_flag[f]:
                raise ValueError(f"batch: message id {mid} does not match its rows")
            row_base[f] = words
            words += k * nfld
            nf = k * int(self.nfloat[f])
            nf_total += nf
            ni_total += k * nfld - nf
            bound += k * int(self.key_bytes[f])
            seen += k
        rows_raw = b"".join(by_rows.values()) if len(by_rows) != 1 else next(iter(by_rows.values()))
        rows_f = np.frombuffer(rows_raw, np.float64)
        rows_i = rows_f.view(np.int64)
        smeta = self._no_structs
        stext = self._no_text
        if by_id:
            smeta = np.zeros((n, 4), np.int64)
            texts = []
            at = 0
            for mid, raw in by_id.items():
                decode = self.decoders.get(mid)
                if decode is None:
                    raise ValueError(f"batch: unknown message id {mid}")
                msgs, text, where, begins, ends = _struct_texts(decode, raw, flags, mid)
                smeta[where, 0] = begins + at
                smeta[where, 1] = ends - begins
                smeta[where, 2] = [m.sample_time_ns for m in msgs]
                smeta[where, 3] = [m.publish_time_ns for m in msgs]
                texts.append(text)
                at += len(text)
                bound += len(text)
                seen += len(msgs)
            stext = np.frombuffer(b"".join(texts), np.uint8)
        if seen != n:
            raise ValueError(f"batch: {n} message ids for {seen} messages")
        fvals = np.empty(nf_total, np.float64)
        ivals = np.empty(ni_total, np.int64)
        if by_rows:
            _gather_kernel(
                flags,
                rows_f,
                rows_i,
                row_base,
                self.nfields,
                self.field_base,
                self.is_float,
                fvals,
                ivals,
            )
        ftext = _orjson_dumps(fvals, option=_ORJSON_NUMPY)
        itext = _orjson_dumps(ivals, option=_ORJSON_NUMPY)
        bound += len(ftext) + len(itext) + n * MESSAGE_HEADER_BYTES
        return flags, rows_i, row_base, ftext, itext, stext, smeta, bound

    def records(
        self, values: tuple[Any, ...]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
        """Write the records of a batch given by :meth:`values` (:func:`_records_kernel`)."""
        flags, rows_i, row_base, ftext, itext, stext, smeta, bound = values
        n = len(flags)
        if bound + 8 > len(self.out):  # 8 bytes to spare (_copy_value)
            self.out = np.empty(bound + 8, np.uint8)
        if n > len(self.entries):
            self.entries = np.empty((n, 2), np.int64)
        total, lo, hi, status = _records_kernel(
            flags,
            self.chan_of_flag,
            rows_i,
            row_base,
            self.nfields,
            self.field_base,
            self.is_float,
            self.time_cols,
            self.keys,
            self.key_at,
            np.frombuffer(ftext, np.uint8),
            np.frombuffer(itext, np.uint8),
            stext,
            smeta,
            self.log.channel_seq,
            self.log.start_unix_ns,
            self.unix_minus_monotonic_ns,
            self.out,
            self.entries,
            self.counts,
        )
        if status:
            what = ("", "an unregistered message id", "too few values", "values left over")
            raise ValueError(f"batch: {what[status]} in the batch")
        return self.out[:total], self.counts, self.entries[:n], lo, hi

    def frame(self, blob: bytes | memoryview) -> None:
        """Write one batch from the pipe as a Chunk with its MessageIndexes."""
        records, counts, entries, lo, hi = self.encode(blob)
        if len(entries):
            self.log.write_chunk(records, counts, entries, lo, hi)


#: A batch's length before its bytes on the pipe (0: the end).
_LENGTH_BYTES = 8


def _write_message(fd: int, payload: bytes) -> None:
    """Put one batch on the pipe: its length (8 bytes, little-endian), then its bytes, in
    one ``writev`` (the rest again after a partial write); read by :class:`_PipeReader`.
    The pipe's own framing instead of ``Connection.send_bytes``, whose reader copies each
    batch twice more (about 0.08 us of the writer's CPU a message)."""
    parts = [memoryview(len(payload).to_bytes(_LENGTH_BYTES, "little")), memoryview(payload)]
    while parts:
        n = os.writev(fd, parts)
        while parts and n >= len(parts[0]):
            n -= len(parts[0])
            parts.pop(0)
        if parts and n:
            parts[0] = parts[0][n:]


class _PipeReader:
    """Reads the batches :func:`_write_message` puts on a pipe into one reused buffer."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.head = bytearray(_LENGTH_BYTES)
        self.buf = bytearray(1 << 20)

    def _fill(self, view: memoryview) -> bool:
        got = 0
        while got < len(view):
            n = os.readv(self.fd, [view[got:]])
            if n == 0:
                return False
            got += n
        return True

    def read(self) -> memoryview | None:
        """The next batch (valid until the next call), or None at the end marker or when
        the pipe closes (the parent gone; a batch cut by it is dropped)."""
        if not self._fill(memoryview(self.head)):
            return None
        size = int.from_bytes(self.head, "little")
        if size == 0:
            return None
        if size > len(self.buf):
            self.buf = bytearray(size)  # a new one: views of the old may still be alive
        view = memoryview(self.buf)[:size]
        return view if self._fill(view) else None


def _writer_main(
    conn: Connection,
    path: str,
    turbine: str,
    metadata: dict[str, dict[str, str]],
    compression: str,
    ready: Any,
    unix_minus_monotonic_ns: int,
    stats: Any,
    error: Any = None,
) -> bool:
    """Write the file from the pipe's batches; False (the reason in ``error``) when a write
    failed: the writer then stops reading, so the parent's next batch finds the pipe closed."""

    def failed(exc: OSError) -> bool:
        if error is not None and not error.value:
            error.value = f"writing {path}: {exc.strerror or exc}".encode()[: _ERROR_BYTES - 1]
        return False

    try:
        log = BatchRunLog(Path(path), turbine, compression=compression)
    except OSError as exc:
        return failed(exc)
    framer = _BatchFramer(log, _decoders(), unix_minus_monotonic_ns)
    _warm_kernels(framer)
    cpu0 = time.process_time()
    pipe = _PipeReader(conn.fileno())
    ok = True
    try:
        for name, data in metadata.items():
            log.add_metadata(name, data)
        ready.set()
        while True:
            blob = pipe.read()
            if blob is None:  # the end, or the parent is gone
                break
            framer.frame(blob)
    except OSError as exc:
        ok = failed(exc)
    finally:
        try:
            log.close()
        except OSError as exc:  # the summary section and footer did not fit either
            ok = failed(exc)
        stats[0] = time.process_time() - cpu0
        stats[1] = log.count
    return ok


def _writer_process(*args: Any) -> None:
    """The writer child's target: :func:`_writer_main`, then an immediate exit.

    Once the file is finished (the summary section and footer written, the file closed)
    nothing is left to do, but the interpreter's teardown with numba and llvmlite loaded
    takes about 0.3 s, which :meth:`BackgroundRunLog.close` would wait for (measured: the
    file done 0.3 ms after the end marker, the child gone 0.25-0.33 s later). ``os._exit``
    skips it. An exception in :func:`_writer_main` still ends the child the usual way (its
    traceback printed, exit code 1). A write that failed (:class:`LogWriteError`) is said
    by the parent, from the text left in the shared error buffer: exit code 1, no traceback.

    SIGINT is ignored: a terminal's Ctrl-C reaches the whole process group, and the parent
    decides how the run ends (it closes the pipe, and the file is finished).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    ok = _writer_main(*args)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0 if ok else 1)


#: bytes.translate table setting :data:`ROW_FLAG` (the ids are < ROW_FLAG once checked).
_FLAG_ROWS = bytes((b | ROW_FLAG) & 0xFF for b in range(256))


def _row_dtype_ok(mt: MessageType, block: np.ndarray) -> bool:
    """Whether ``block``'s dtype is ``mt``'s row dtype: the same object (``row_dtype`` is
    built once; views and arrays made with it keep it), else compared (a structured
    dtype's ``==`` takes ~3 us)."""
    dtype = block.dtype
    expected = mt.row_dtype
    return dtype is expected or bool(dtype == expected)


class MessageBatcher(abc.ABC):
    """The batch being filled: messages given one by one (:meth:`publish`) or as rows
    (:meth:`publish_block`), cut by count into batches of ``batch_messages``, each handed
    to :meth:`_send` as it fills (:meth:`_payload`: the batch's bytes, as the writer reads
    them). :class:`BackgroundRunLog` sends a batch through a pipe to its writer child; a
    campaign worker (a daemon process, which may not start children) frames it in its own
    process (:class:`hil.campaign`'s run log).

    Parameters
    ----------
    batch_messages : int
        Messages per batch (module docstring).
    """

    def __init__(self, batch_messages: int = BATCH_MESSAGES) -> None:
        if batch_messages < 1:
            raise ValueError(f"batch_messages: expected an integer >= 1, got {batch_messages}")
        self._batch_messages = batch_messages
        # Messages per message id in the batches sent so far (counted per batch, from its
        # order, so publishing costs nothing more): published() adds the batch being filled.
        self._sent_counts = np.zeros(ROW_FLAG, np.int64)
        self._ids = bytearray()
        self._new_batch()

    @abc.abstractmethod
    def _send(self) -> None:
        """Hand the full (or, at the end, last) batch on and start a new one."""

    def _new_batch(self) -> None:
        # The batch being filled: the message ids in publish order and, per message id,
        # its messages given to publish (the Structs themselves; encoded when the batch is
        # sent) and the bytes of its rows given to publish_block. The batch before (sent,
        # or empty at the start) is counted first.
        if self._ids:
            self._sent_counts += self._id_counts(self._ids)
        self._ids = bytearray()
        self._by_id: dict[int, list[msgspec.Struct]] = {}
        self._rows: dict[int, bytearray] = {}

    @staticmethod
    def _id_counts(ids: bytearray) -> np.ndarray:
        flags = np.frombuffer(bytes(ids), np.uint8) & (ROW_FLAG - 1)
        return np.bincount(flags, minlength=ROW_FLAG).astype(np.int64)

    def published(self) -> dict[str, int]:
        """Messages handed to the log so far per key suffix (Structs and rows alike)."""
        counts = self._sent_counts + self._id_counts(self._ids)
        return {mt.key_suffix: int(counts[mid]) for mid, mt in _BY_ID.items()}

    def publish(self, mt: MessageType, msg: msgspec.Struct) -> None:
        """Queue one message for the log (the simulation loop's only logging cost)."""
        mid = mt.message_id
        ids = self._ids
        ids.append(mid)
        lst = self._by_id.get(mid)
        if lst is None:
            self._by_id[mid] = [msg]
        else:
            lst.append(msg)
        if len(ids) >= self._batch_messages:
            self._send()

    def publish_block(self, order: np.ndarray, rows: Mapping[int, np.ndarray]) -> None:
        """Queue many messages given as rows (:attr:`MessageType.row_dtype`) at once.

        Parameters
        ----------
        order : ndarray of uint8
            The block's message ids in publish order.
        rows : mapping of message id to structured ndarray
            Per message id, its messages in publish order as a 1-D array of that type's
            ``row_dtype``; as many rows as the id occurs in ``order``. The rows are used
            before this call returns (the caller may reuse its buffers).

        Raises
        ------
        ValueError
            If a message id is unknown, or the rows do not match ``order`` or the dtype.

        Notes
        -----
        The rows' bytes are appended to the batch being filled, per message id, and the ids
        to its order with :data:`ROW_FLAG` set (no Struct, no Python work per message); the
        writer turns them into the Struct's JSON (:func:`_encode_batch`). A block that
        does not fit the batch is split at the batch's end (batches are cut by count).
        """
        ids = np.asarray(order, np.uint8)
        if ids.ndim != 1:
            raise ValueError(f"publish_block: order must be 1-D, got shape {ids.shape}")
        counts = np.bincount(ids, minlength=256)
        total = 0
        for mid, block in rows.items():
            mt = _BY_ID.get(mid)
            if mt is None:
                raise ValueError(f"publish_block: unknown message id {mid}")
            if not isinstance(block, np.ndarray) or block.ndim != 1 or not _row_dtype_ok(mt, block):
                raise ValueError(f"publish_block: {mt.name} rows must be 1-D {mt.row_dtype}")
            if len(block) != counts[mid]:
                raise ValueError(f"publish_block: {len(block)} {mt.name} rows for its ids")
            total += len(block)
        if total != len(ids):
            raise ValueError("publish_block: an id in order has no rows")
        if len(ids) <= self._batch_messages - len(self._ids):  # the block fits the batch
            self._ids += ids.tobytes().translate(_FLAG_ROWS)
            for mid, block in rows.items():
                buf = self._rows.get(mid)
                if buf is None:
                    self._rows[mid] = bytearray(block.tobytes())
                else:
                    buf += block.tobytes()
            if len(self._ids) >= self._batch_messages:
                self._send()
            return
        done = {mid: 0 for mid in rows}
        while len(ids):
            room = self._batch_messages - len(self._ids)
            part = ids if len(ids) <= room else ids[:room]  # a batch is cut by count
            self._ids += part.tobytes().translate(_FLAG_ROWS)
            whole = part is ids
            for mid, block in rows.items():
                a = done[mid]
                b = len(block) if whole else a + int(np.count_nonzero(part == mid))
                if b > a:
                    buf = self._rows.get(mid)
                    if buf is None:
                        self._rows[mid] = bytearray(block[a:b].tobytes())
                    else:
                        buf += block[a:b].tobytes()
                    done[mid] = b
            ids = ids[len(part) :]
            if len(self._ids) >= self._batch_messages:
                self._send()

    def _payload(self) -> bytes:
        """The batch as it goes to the writer: one msgpack call for all its messages."""
        return _encode_batch_payload((self._ids, self._by_id, self._rows))


class BackgroundRunLog(MessageBatcher):
    """Publish sink whose MCAP writing happens in a child process.

    Parameters
    ----------
    path : Path
        MCAP file to write.
    turbine : str
        Turbine id of the keys.
    metadata : dict
        Metadata records (name -> string map) written first.
    compression : str
        Chunk compression of the file (:data:`hil.mcap_log.COMPRESSIONS`).
    batch_messages : int
        Messages per batch (module docstring).
    """

    def __init__(
        self,
        path: Path,
        turbine: str,
        metadata: dict[str, dict[str, str]],
        compression: str = "zstd",
        batch_messages: int = BATCH_MESSAGES,
    ) -> None:
        super().__init__(batch_messages)
        ctx = multiprocessing.get_context("spawn")
        recv_end, send_end = ctx.Pipe(duplex=False)
        setpipe = getattr(fcntl, "F_SETPIPE_SZ", None)
        if setpipe is not None:
            with contextlib.suppress(OSError):  # a smaller pipe only costs waiting
                fcntl.fcntl(send_end.fileno(), setpipe, PIPE_BYTES)
        self._conn = send_end
        self._fd = send_end.fileno()
        self._ready = ctx.Event()
        self._stats = ctx.Array("d", 2)  # the writer's CPU seconds after start-up, messages
        self._error = ctx.Array("c", _ERROR_BYTES)  # why a write failed (LogWriteError)
        self._path = path
        self._proc = ctx.Process(
            target=_writer_process,
            args=(
                recv_end,
                str(path),
                turbine,
                metadata,
                compression,
                self._ready,
                time.time_ns() - time.monotonic_ns(),
                self._stats,
                self._error,
            ),
            name="fowt-log-writer",
            daemon=False,
        )
        self._proc.start()
        recv_end.close()
        # A log never closed (an exception before close(), a failing test) would keep the
        # interpreter from exiting: multiprocessing joins its non-daemon children at exit,
        # and the child waits on the pipe. Closing our end first (multiprocessing runs its
        # finalizers before that join) lets the child see EOF and finish the file.
        multiprocessing.util.Finalize(self, send_end.close, exitpriority=10)
        #: Messages and batches handed to the writer so far, and the time spent sending [ns].
        self.messages = 0
        self.batches = 0
        self.send_ns = 0
        #: Wall time :meth:`close` waited for the writer to finish the file [ns].
        self.close_wait_ns = 0
        #: After :meth:`close`: the writer's CPU time from its start-up's end to the file's
        #: end [s] and the messages it wrote (its throughput, bench/inprocess_speed.py).
        self.writer_cpu_s = 0.0
        self.writer_messages = 0

    def wait_ready(self, timeout_s: float = 120.0) -> None:
        """Wait until the writer has started (its imports take ~0.5 s) and opened the file.

        Called before the loop's first cycle, so the loop never waits on a writer that is
        still starting; the messages published meanwhile wait in the pipe and the batch.

        Raises
        ------
        RuntimeError
            If the writer exited or did not start within ``timeout_s``.
        """
        deadline = time.monotonic() + timeout_s
        while not self._ready.wait(0.05):
            if not self._proc.is_alive():
                raise self._failure()
            if time.monotonic() > deadline:
                raise RuntimeError(f"log writer did not start within {timeout_s:g} s")

    def _failure(self) -> LogWriteError | RuntimeError:
        """Why the writer stopped: its write error, else its exit status."""
        self._proc.join(5.0)
        why = bytes(self._error.value).decode(errors="replace")  # type: ignore[attr-defined]
        if why:
            return LogWriteError(why)
        return RuntimeError(f"log writer exited with {self._proc.exitcode}")

    def _send(self) -> None:
        n = len(self._ids)
        if n:
            payload = self._payload()
            t0 = time.perf_counter_ns()
            try:  # blocks while the pipe is full (writer behind)
                _write_message(self._fd, payload)
            except BrokenPipeError:  # the writer has stopped: say why, not "broken pipe"
                raise self._failure() from None
            self.send_ns += time.perf_counter_ns() - t0
            self.messages += n
            self.batches += 1
            self._new_batch()

    def close(self, timeout_s: float = 120.0) -> None:
        """Send what is left, wait for the child to finish the file."""
        t0 = time.perf_counter_ns()
        if self._conn.closed:  # closed before, after a failure that was raised then
            return
        try:
            self._send()
            with contextlib.suppress(BrokenPipeError):  # a writer that stopped says why below
                _write_message(self._fd, b"")
        finally:
            self._conn.close()
        self._proc.join(timeout_s)
        self.close_wait_ns = time.perf_counter_ns() - t0
        if self._proc.exitcode != 0:
            raise self._failure()
        self.writer_cpu_s, self.writer_messages = self._stats[0], int(self._stats[1])


class InProcessRunLog(MessageBatcher):
    """Publish sink writing its MCAP file in the caller's process, batch by batch.

    :class:`BackgroundRunLog`'s batching, each full batch framed here by the writer child's
    :class:`_BatchFramer` (one Chunk a batch) instead of going through a pipe to a child:
    for a process that may not start children (a Dask worker is a daemon process: a
    campaign's runs). The file is what :class:`BackgroundRunLog` writes for the same
    messages. A killed process loses the batch being filled, as there. Parameters: those
    of :class:`BackgroundRunLog`.
    """

    def __init__(
        self,
        path: Path,
        turbine: str,
        metadata: dict[str, dict[str, str]],
        compression: str = "zstd",
        batch_messages: int = BATCH_MESSAGES,
    ) -> None:
        super().__init__(batch_messages)
        self.log = BatchRunLog(path, turbine, compression=compression)
        for name, data in metadata.items():
            self.log.add_metadata(name, data)
        self._framer = _BatchFramer(self.log, _decoders(), time.time_ns() - time.monotonic_ns())
        _warm_kernels(self._framer)  # numba's on-disk cache (compiled on a first run)

    def _send(self) -> None:
        if self._ids:
            self._framer.frame(self._payload())
            self._new_batch()

    def close(self) -> None:
        """Frame what is left, write the summary section and the footer."""
        try:
            self._send()
        finally:
            self.log.close()
