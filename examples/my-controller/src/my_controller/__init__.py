"""An example controller plug-in for fowt-hil: kind ``my_pi``.

The package declares one :class:`controller.registry.ControllerKind`, :data:`KIND`, and its
``pyproject.toml`` registers it in the entry-point group ``fowt_hil.controllers`` under the
name ``my_pi``; a scenario then says ``[controller] kind = "my_pi"`` and gives its gains in
``[controller.settings]`` (:class:`MyPiSettings`), validated when the scenario is read.
Without installing it, ``kind = "python"`` with ``core = "my_controller:KIND"`` finds the
same object on ``PYTHONPATH``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from controller.registry import ControllerKind, ControllerOptions, DesignRequest
from my_controller.core import MyPiController, MyPiSettings, MyPiState

__all__ = ["KIND", "MyPiController", "MyPiSettings", "MyPiState", "build", "design"]


def build(options: ControllerOptions) -> MyPiController:
    """options.settings is the validated MyPiSettings."""
    settings = options.settings if options.settings is not None else MyPiSettings()
    return MyPiController(settings, options.control_period_s)


def design(request: DesignRequest, say: Callable[[str], None]) -> Path | None:
    """The design hook: runs in the launcher before the run (once per campaign).

    A model-based controller would make its missing artefacts here (gains for the scenario's
    control period, platform and sea, written to a folder it returns). This one takes its
    gains from the settings, so it only checks that its speed filter suits the control
    period and says so.
    """
    s = request.settings  # the validated MyPiSettings
    assert isinstance(s, MyPiSettings)
    nyquist_hz = 0.5 / request.control_period_s
    say(
        f"my_pi: speed filter {s.speed_filter_corner_hz:g} Hz at "
        f"{1.0 / request.control_period_s:g} Hz control rate (Nyquist {nyquist_hz:g} Hz); "
        "nothing to design"
    )
    return None


KIND = ControllerKind(
    build=build,
    design=design,
    settings=MyPiSettings,
    description="example plug-in: gain-scheduled pitch PI and K w^2 / constant-power torque",
)
