"""Bus messages of the bench: one declaration each, every encoding derived from it.

See :mod:`bus_schemas.messages` for the declarations, :mod:`bus_schemas.codec` for the
binary payload codec and :mod:`bus_schemas.registry` for ids, versions, keys and JSON Schemas.
"""

from bus_schemas.codec import (
    DecodeError,
    HeaderError,
    NonFiniteError,
    RangeError,
    TruncatedError,
    VersionError,
)
from bus_schemas.messages import (
    ActuatorCommand,
    ControllerStatus,
    CycleTiming,
    PlantState,
    SensorFrame,
    TimingSummary,
)

__all__ = [
    "ActuatorCommand",
    "ControllerStatus",
    "CycleTiming",
    "DecodeError",
    "HeaderError",
    "NonFiniteError",
    "PlantState",
    "RangeError",
    "SensorFrame",
    "TimingSummary",
    "TruncatedError",
    "VersionError",
]
