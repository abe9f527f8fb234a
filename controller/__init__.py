"""Controller runtime of the bench: pure controller cores speaking only ``bus_schemas``.

* :mod:`controller.interface`: :class:`~controller.interface.ControlOutput`, the
  :class:`~controller.interface.Controller` protocol, regime codes and actuator limits.
* :mod:`controller.registry`: the ``kind`` -> constructor table and
  :func:`~controller.registry.make_controller`.
* :mod:`controller.baseline`: the NREL 5 MW-style baseline controller and its presets;
  :mod:`controller.runtime`: the advanced (LQRI + wave feedforward) controller.

This package never imports ``plant``.
"""

from controller.interface import Controller, ControlOutput
from controller.registry import make_controller

__all__ = ["ControlOutput", "Controller", "make_controller"]
