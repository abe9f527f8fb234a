"""Fixtures shared by several test modules (plain helpers are in ``_helpers.py``)."""

from __future__ import annotations

import pytest

from plant.platform import FloatingParams, load_floating


@pytest.fixture(scope="module")
def params() -> FloatingParams:
    """The IEA 15 MW on the VolturnUS-S, as shipped (``load_floating``); one a module.

    A module that needs other parameters under this name defines its own ``params``.
    """
    return load_floating("iea15mw_volturnus")
