"""The settings schema of ``kind = "fmu"`` (:class:`FmuSettings`), apart from the FMU core.

:mod:`controller.registry` declares every shipped kind's settings schema in its table, so it
imports this module in every process that reads a scenario; the core (:mod:`controller.fmu`:
the archive checks, fmpy, units) is imported only when an FMU is checked or built.
"""

from __future__ import annotations

import math
from typing import Annotated

import msgspec

__all__ = ["FmuSettings", "Positive", "StartValue"]

StartValue = float | int | bool | str
Positive = Annotated[float, msgspec.Meta(gt=0.0)]


class FmuSettings(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[controller.settings]`` of ``kind = "fmu"`` (:mod:`controller.fmu`).

    Attributes
    ----------
    fmu : str
        Path to the ``.fmu`` (relative: from the scenario file's folder).
    inputs : dict
        SensorFrame field -> FMU input variable name.
    outputs : dict
        Command or status field -> FMU output variable name.
    start_values : dict
        FMU variable name -> value set before initialisation.
    units : dict
        FMU variable name -> its unit, for variables that declare none.
    pitch_min_rad, pitch_max_rad : float
        Pitch demand range [rad] (the NREL 5 MW's 0 to 90 deg by default).
    pitch_rate_max_rad_s : float
        Pitch rate limit [rad/s] for the safe mode (8 deg/s by default).
    torque_rate_max_nm_s : float
        Generator torque rate limit [N m/s] for the safe mode (15 kN m/s by default).
    """

    fmu: str
    outputs: dict[str, str]
    inputs: dict[str, str] = msgspec.field(default_factory=dict)
    start_values: dict[str, StartValue] = msgspec.field(default_factory=dict)
    units: dict[str, str] = msgspec.field(default_factory=dict)
    pitch_min_rad: float = 0.0
    pitch_max_rad: float = math.pi / 2.0
    pitch_rate_max_rad_s: Positive = 0.13962634015954636
    torque_rate_max_nm_s: Positive = 15000.0

    def __post_init__(self) -> None:
        if not self.pitch_min_rad < self.pitch_max_rad:
            raise ValueError(
                f"pitch_min_rad = {self.pitch_min_rad} must be < pitch_max_rad = "
                f"{self.pitch_max_rad}"
            )
