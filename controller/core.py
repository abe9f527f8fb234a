"""Common interface of the bench's controllers: the command record, the protocol, a registry.

Every controller of the bench is a *pure core*: an immutable object built from its
parameters, with

``initial_state() -> state`` and ``step(state, measurement, dt_s) -> (state, output)``,

holding no clock, no I/O and no globals. The node layer (bus, clock, deadlines) owns the
state between calls and turns :class:`ControlOutput` into a
:class:`bus_schemas.messages.ActuatorCommand` plus a
:class:`bus_schemas.messages.ControllerStatus`.

Regime codes (``ControlOutput.regime``), after the NREL 5 MW baseline (Jonkman et al. 2009,
NREL/TP-500-38060, section 7):

====  =========================================================================
code  meaning
====  =========================================================================
0     region 1: below cut-in (or non-positive) generator speed, zero torque
1     region 1.5: linear torque ramp from cut-in to the start of region 2
2     region 2: optimal-tip-speed-ratio torque, :math:`T = K\\,\\omega^2`
3     region 2.5: transition to rated torque (induction-generator-like slope,
      or torque PI on generator speed)
4     region 3: rated power/torque, speed regulated by blade pitch
====  =========================================================================

The controller package never imports ``plant``: it speaks only ``bus_schemas``.
"""

from __future__ import annotations

from typing import Any, Protocol, TypeVar

import msgspec

from bus_schemas.messages import SensorFrame

__all__ = [
    "REGIME_REGION_1",
    "REGIME_REGION_1_5",
    "REGIME_REGION_2",
    "REGIME_REGION_2_5",
    "REGIME_REGION_3",
    "ControlOutput",
    "Controller",
    "available_controllers",
    "make_controller",
]

REGIME_REGION_1 = 0
REGIME_REGION_1_5 = 1
REGIME_REGION_2 = 2
REGIME_REGION_2_5 = 3
REGIME_REGION_3 = 4


class ControlOutput(msgspec.Struct, frozen=True, gc=False):
    """Command and internals produced by one controller step.

    Attributes
    ----------
    blade_pitch_commanded_rad : float
        Collective blade pitch demand [rad].
    generator_torque_commanded_nm : float
        Generator torque demand on the high-speed shaft [N m].
    regime : int
        Operating region code (0 = region 1/stopped, 1 = region 1.5, 2 = region 2,
        3 = region 2.5, 4 = region 3); see the module docstring.
    generator_speed_filtered_rad_s : float
        Low-pass filtered generator (HSS) speed :math:`\\omega_f` [rad/s].
    pitch_integrator_rad : float
        Integral term of the pitch PI, :math:`G_K K_I \\int e\\,dt` [rad].
    gain_schedule_factor : float
        Pitch gain-schedule factor :math:`G_K` [-] (1 at the reference pitch).
    """

    blade_pitch_commanded_rad: float
    generator_torque_commanded_nm: float
    regime: int
    generator_speed_filtered_rad_s: float
    pitch_integrator_rad: float
    gain_schedule_factor: float


StateT = TypeVar("StateT")


class Controller(Protocol[StateT]):
    """A pure controller core: ``step(state, measurement, dt_s) -> (state, output)``."""

    def initial_state(self) -> StateT:
        """Return the state before the first call (the first step initialises from data)."""
        ...

    def step(
        self, state: StateT, measurement: SensorFrame, dt_s: float
    ) -> tuple[StateT, ControlOutput]:
        """Advance by ``dt_s`` seconds [s] given one sensor frame; return state and output."""
        ...


def available_controllers() -> tuple[str, ...]:
    """Names accepted by :func:`make_controller` as ``kind``."""
    return ("baseline",)


def make_controller(kind: str, preset: str) -> Controller[Any]:
    """Build a controller of ``kind`` from a shipped preset name or a preset file path.

    Parameters
    ----------
    kind : str
        Controller family; only ``"baseline"`` (NREL-style baseline) exists so far.
    preset : str
        Shipped preset name (e.g. ``"nrel5mw_baseline"``) or path to a TOML preset.

    Returns
    -------
    Controller
        A pure controller core.

    Raises
    ------
    ValueError
        If ``kind`` is unknown or the preset cannot be loaded.
    """
    if kind == "baseline":
        from controller.baseline import BaselineController, load_baseline  # noqa: PLC0415

        return BaselineController(load_baseline(preset))
    raise ValueError(
        f"unknown controller kind {kind!r}; known kinds: {', '.join(available_controllers())}"
    )
