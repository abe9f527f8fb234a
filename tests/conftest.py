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


@pytest.fixture(scope="session", autouse=True)
def _trim_store(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Trims stored in the session's own directory, never the user's cache.

    Set in the environment, so the processes a test starts (plant nodes, ``fowt run``) share
    it: a trim is settled once a session (:mod:`hil.inprocess.trim_store`).
    """
    import os

    os.environ["FOWT_CACHE_DIR"] = str(tmp_path_factory.mktemp("fowt-cache"))
