"""Controller runtime of the bench: pure controller cores speaking only ``bus_schemas``.

* :mod:`controller.core`: :class:`~controller.core.ControlOutput`, the
  :class:`~controller.core.Controller` protocol and :func:`~controller.core.make_controller`.
* :mod:`controller.baseline`: the NREL 5 MW-style baseline controller and its presets.

This package never imports ``plant``.
"""

from controller.core import Controller, ControlOutput, make_controller

__all__ = ["ControlOutput", "Controller", "make_controller"]
