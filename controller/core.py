"""Compatibility names: the controller interface and the registry in one import.

The shared types (:class:`~controller.interface.ControlOutput`, the
:class:`~controller.interface.Controller` protocol, regime codes,
:class:`~controller.interface.ActuatorLimits`) live in :mod:`controller.interface`; the
``kind`` -> constructor table and :func:`~controller.registry.make_controller` live in
:mod:`controller.registry`. Neither imports a core at module level, and the cores import
only :mod:`controller.interface`, so the package has no import cycle. New code imports from
those two modules; this one keeps the names it always exported.
"""

from __future__ import annotations

from controller.interface import (
    REGIME_REGION_1,
    REGIME_REGION_1_5,
    REGIME_REGION_2,
    REGIME_REGION_2_5,
    REGIME_REGION_3,
    REGIME_SAFE,
    ActuatorLimits,
    Controller,
    ControlOutput,
)
from controller.registry import actuator_limits, available_controllers, make_controller

__all__ = [
    "REGIME_REGION_1",
    "REGIME_REGION_1_5",
    "REGIME_REGION_2",
    "REGIME_REGION_2_5",
    "REGIME_REGION_3",
    "REGIME_SAFE",
    "ActuatorLimits",
    "ControlOutput",
    "Controller",
    "actuator_limits",
    "available_controllers",
    "make_controller",
]
