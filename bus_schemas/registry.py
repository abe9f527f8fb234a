"""The registry: which messages exist, their ids, versions, keys and derived schemas.

Each row of :data:`MESSAGES` ties one declaration of :mod:`bus_schemas.messages` to a
message id, a schema version and the key suffix it is published under
(``fowt/<turbine>/<suffix>``). The binary codec, the MCAP JSON Schema and (later) the CAN
database are all generated from that row; bump ``version`` whenever a declaration changes.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import msgspec
import numpy as np

from bus_schemas.codec import Codec, DecodeError, HeaderError
from bus_schemas.messages import (
    ActuatorCommand,
    ControllerReport,
    ControllerStatus,
    CycleTiming,
    PlantReport,
    PlantState,
    PlatformControllerStatus,
    PlatformFrame,
    SensorFrame,
    TimingSummary,
    TurbineCommand,
    TurbineFrame,
    WavePreviewPerfect,
)

KEY_PREFIX = "fowt"


@dataclass(frozen=True)
class MessageType:
    """One registered message: declaration, id, version, key suffix and codec."""

    cls: type[msgspec.Struct]
    message_id: int
    version: int
    key_suffix: str
    codec: Codec[Any]

    @property
    def name(self) -> str:
        return self.cls.__name__

    def key(self, turbine: str) -> str:
        """Zenoh key expression for ``turbine``, e.g. ``fowt/t1/sensors``."""
        return f"{KEY_PREFIX}/{turbine}/{self.key_suffix}"

    @functools.cached_property  # built once (a structured dtype takes ~13 us to build)
    def row_dtype(self) -> np.dtype[np.void]:
        """The message as a packed numpy record: one 8-byte field per Struct field, in order.

        ``int64`` for an integer field, ``float64`` for a float one (every per-cycle message
        holds only numbers). All fields are 8 bytes and unpadded, so an ``(n, len(fields))``
        float64 buffer viewed with this dtype is ``n`` messages, and its integer columns can
        be written through an ``int64`` view of the same memory: a compiled loop fills rows
        that way, and the log writer takes them in bulk (no Struct per message).
        """
        return np.dtype(
            [(f.name, np.float64 if f.is_float else np.int64) for f in self.codec.fields]
        )

    def json_schema(self) -> dict[str, Any]:
        """Flat JSON Schema (draft 2020-12) of the message, units in descriptions.

        Flat (no ``$ref``) so Foxglove can plot every field directly.
        """
        props: dict[str, Any] = {}
        for f in self.codec.fields:
            props[f.name] = {
                "type": "number" if f.is_float else "integer",
                "description": f"{f.description} [{f.unit}]",
                "minimum": f.minimum,
                "maximum": f.maximum,
            }
        return {
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": f"fowt.{self.name}",
            "description": (self.cls.__doc__ or "").strip().splitlines()[0],
            "type": "object",
            "properties": props,
            "required": [f.name for f in self.codec.fields],
            "x-fowt-version": self.version,
        }


def _mt(cls: type[msgspec.Struct], mid: int, version: int, suffix: str) -> MessageType:
    return MessageType(cls, mid, version, suffix, Codec(cls, mid, version))


MESSAGES: tuple[MessageType, ...] = (
    _mt(SensorFrame, 1, 1, "sensors"),
    _mt(ActuatorCommand, 2, 1, "command"),
    _mt(PlantState, 3, 2, "truth"),
    _mt(ControllerStatus, 4, 3, "controller/status"),
    _mt(CycleTiming, 5, 1, "timing/cycle"),
    _mt(TimingSummary, 6, 2, "timing/summary"),
    _mt(WavePreviewPerfect, 7, 1, "preview/wave_perfect"),
    _mt(PlantReport, 12, 1, "timing/report"),
    _mt(ControllerReport, 13, 2, "controller/report"),
)

#: Messages of multi-turbine platforms (the Hexicon H3 family): per-turbine ones are keyed
#: ``fowt/<platform>/<turbine>/<suffix>`` (``key(f"{platform}/{turbine}")``), platform-wide
#: ones ``fowt/<platform>/<suffix>``. Kept apart from :data:`MESSAGES` (the single-turbine
#: run's channels) so single-turbine logs are unchanged.
PLATFORM_MESSAGES: tuple[MessageType, ...] = (
    _mt(TurbineFrame, 8, 1, "rotor"),
    _mt(TurbineCommand, 9, 1, "rotor/command"),
    _mt(PlatformFrame, 10, 1, "platform"),
    _mt(PlatformControllerStatus, 11, 1, "platform/status"),
)
ALL_MESSAGES: tuple[MessageType, ...] = MESSAGES + PLATFORM_MESSAGES

BY_CLASS: dict[type[msgspec.Struct], MessageType] = {m.cls: m for m in ALL_MESSAGES}
BY_ID: dict[int, MessageType] = {m.message_id: m for m in ALL_MESSAGES}
BY_SUFFIX: dict[str, MessageType] = {m.key_suffix: m for m in ALL_MESSAGES}

SENSORS = BY_CLASS[SensorFrame]
COMMAND = BY_CLASS[ActuatorCommand]
TRUTH = BY_CLASS[PlantState]
CONTROLLER_STATUS = BY_CLASS[ControllerStatus]
CYCLE_TIMING = BY_CLASS[CycleTiming]
TIMING_SUMMARY = BY_CLASS[TimingSummary]
WAVE_PREVIEW_PERFECT = BY_CLASS[WavePreviewPerfect]
PLANT_REPORT = BY_CLASS[PlantReport]
CONTROLLER_REPORT = BY_CLASS[ControllerReport]
TURBINE_FRAME = BY_CLASS[TurbineFrame]
TURBINE_COMMAND = BY_CLASS[TurbineCommand]
PLATFORM_FRAME = BY_CLASS[PlatformFrame]
PLATFORM_STATUS = BY_CLASS[PlatformControllerStatus]


def identify(payload: bytes | bytearray | memoryview) -> MessageType:
    """The registered type of a payload from its header (raises :class:`DecodeError`)."""
    if len(payload) < 4:
        raise HeaderError(f"payload of {len(payload)} bytes has no header")
    mt = BY_ID.get(payload[1])
    if mt is None or payload[0] != 0xF7:
        raise HeaderError(f"unknown message id {payload[1]} / magic {payload[0]:#x}")
    return mt


def decode_any(payload: bytes | bytearray | memoryview) -> tuple[MessageType, msgspec.Struct]:
    """Identify and decode a payload of any registered type."""
    mt = identify(payload)
    return mt, mt.codec.decode(payload)


__all__ = [
    "ALL_MESSAGES",
    "BY_CLASS",
    "BY_ID",
    "BY_SUFFIX",
    "COMMAND",
    "CONTROLLER_REPORT",
    "CONTROLLER_STATUS",
    "CYCLE_TIMING",
    "KEY_PREFIX",
    "MESSAGES",
    "PLANT_REPORT",
    "PLATFORM_FRAME",
    "PLATFORM_MESSAGES",
    "PLATFORM_STATUS",
    "SENSORS",
    "TIMING_SUMMARY",
    "TRUTH",
    "TURBINE_COMMAND",
    "TURBINE_FRAME",
    "WAVE_PREVIEW_PERFECT",
    "DecodeError",
    "MessageType",
    "decode_any",
    "identify",
]
