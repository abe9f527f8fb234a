"""Closed-loop damping of the platform modes: small free decays with the controller in the loop.

For a scenario (its turbine, platform, controller kind and preset, control period, sensor
models) and a steady wind U, the run is made steady and quiet exactly as the trim's settling
run (:func:`hil.inprocess.trim.settling_scenario`: steady wind, still water, sensor noise,
quantisation and dropouts off, no faults), started trimmed (the controller in its own steady
state at U, the platform at the static equilibrium under that point's thrust,
:func:`hil.inprocess.trim.initial_condition`) with one platform DOF displaced by a small
offset, and run in process (:func:`hil.inprocess.run.run_inprocess`, the controller's own
core: baseline, LQRI, ROSCO's compiled DISCON, ...). The surge or pitch response is then cut
into cycles by :func:`plant.decay.decay_cycles` (period and log decrement per cycle, damping
ratio ζ = δ/√(4π² + δ²)).

This identifies the closed-loop mode from a time-domain response rather than from the
eigenvalues of a linearised closed loop: every controller kind is treated alike, a compiled
DISCON included, and for small offsets the decay is the linear closed loop's (the offset's
size is reported; halving it must not change the figures much, which the caller can check).
A negative ζ means the mode grows: an unstable closed loop at that wind.

Beside it, :func:`open_loop_modes` gives the open-loop linear modes at the same wind
(:func:`plant.modes.natural_modes`: blade pitch and generator torque held), so the
controller's share of the damping is the difference.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass

import msgspec
import numpy as np

from bus_schemas.registry import TRUTH, WAVE_PREVIEW_PERFECT
from hil.inprocess.run import run_inprocess
from hil.inprocess.trim import initial_condition, operating_point, settling_scenario
from hil.nodes.controller_node import ControllerRuntime, publishing_step
from hil.nodes.plant_node import plant_spec
from hil.scenario.schema import Scenario
from plant.build import build_plant
from plant.decay import DecayCycle, decay_cycles
from plant.simulator import PlantSimulator

__all__ = [
    "CLOSED_LOOP_CASE",
    "ClosedLoopDecay",
    "closed_loop_decay",
    "quiet_steady",
]

CLOSED_LOOP_CASE = (
    "closed loop, identified from a small free decay of the time-domain plant with the "
    "scenario's controller core in the loop: steady wind, still water, sensor noise off, "
    "trimmed start, one platform DOF displaced"
)

#: Plant state index of each DOF that can be displaced.
_DOF_INDEX = {"surge": 0, "pitch": 2}


@dataclass(frozen=True)
class ClosedLoopDecay:
    """A closed-loop decay at one wind (JSON via :meth:`as_dict`).

    ``offset`` in m (surge) or deg (pitch); ``cycles`` of :func:`plant.decay.decay_cycles`;
    ``period_s`` and ``damping_ratio`` the means over the cycles whose starting amplitude is
    at least a quarter of the offset (the linear, small-amplitude part; NaN without one).
    """

    wind_m_s: float
    dof: str
    offset: float
    unit: str
    duration_s: float
    cycles: tuple[DecayCycle, ...]
    time_s: np.ndarray
    displacement: np.ndarray

    @property
    def _used(self) -> list[DecayCycle]:
        return [c for c in self.cycles if c.amplitude >= 0.25 * abs(self.offset)]

    @property
    def period_s(self) -> float:
        used = self._used
        return float(np.mean([c.period_s for c in used])) if used else math.nan

    @property
    def damping_ratio(self) -> float:
        used = self._used
        return float(np.mean([c.damping_ratio for c in used])) if used else math.nan

    def as_dict(self) -> dict[str, object]:
        """Plain dict (JSON), without the sampled response."""
        finite = math.isfinite(self.period_s)
        return {
            "wind_m_s": self.wind_m_s,
            "dof": self.dof,
            "offset": self.offset,
            "unit": self.unit,
            "duration_s": self.duration_s,
            "period_s": round(self.period_s, 3) if finite else None,
            "damping_ratio": round(self.damping_ratio, 5) if finite else None,
            "cycles": [c.as_dict() for c in self.cycles],
        }


def quiet_steady(scenario: Scenario, wind_m_s: float, duration_s: float) -> Scenario:
    """``scenario`` at a steady ``wind_m_s``, still water, noise off, trimmed start
    (:func:`hil.inprocess.trim.settling_scenario` with the trim back on)."""
    d = msgspec.to_builtins(scenario)
    d["wind"] = {"kind": "steady", "speed_m_s": float(wind_m_s)}
    quiet = msgspec.to_builtins(settling_scenario(msgspec.convert(d, Scenario), duration_s))
    quiet["name"] = f"{scenario.name}-closed-loop"
    quiet["initial"] = {"trim": True}
    return msgspec.convert(quiet, Scenario)


def closed_loop_decay(
    scenario: Scenario,
    wind_m_s: float,
    dof: str = "surge",
    offset: float = 2.0,
    duration_s: float = 600.0,
) -> ClosedLoopDecay:
    """Release the trimmed, controlled turbine from ``offset`` in ``dof`` (module docstring).

    Parameters
    ----------
    scenario : Scenario
        Gives the turbine, platform, controller and timing (floating only).
    wind_m_s : float
        Steady hub-height wind (m/s).
    dof : str
        ``"surge"`` (offset in m) or ``"pitch"`` (offset in deg).
    offset : float
        Initial displacement from the trimmed equilibrium (m or deg), non-zero.
    duration_s : float
        Simulated time (s).

    Returns
    -------
    ClosedLoopDecay

    Raises
    ------
    ValueError
        A bottom-fixed scenario, a bad DOF or offset.
    """
    if scenario.platform is None:
        raise ValueError(f"{scenario.name}: closed-loop platform damping needs a floating plant")
    if dof not in _DOF_INDEX:
        raise ValueError(f"dof: expected one of {', '.join(_DOF_INDEX)}, got {dof!r}")
    if not (math.isfinite(offset) and offset != 0.0):
        raise ValueError(f"offset: expected a non-zero number, got {offset}")
    quiet = quiet_steady(scenario, wind_m_s, duration_s)
    trimmed = initial_condition(quiet)
    x_eq = PlantSimulator(build_plant(plant_spec(quiet, trimmed))).initial_state()
    i = _DOF_INDEX[dof]
    scale = math.degrees(1.0) if dof == "pitch" else 1.0
    d = msgspec.to_builtins(quiet)
    d["initial"] = {
        "trim": True,
        "platform_surge_m": x_eq[0] + (offset if i == 0 else 0.0),
        "platform_heave_m": x_eq[1],
        "platform_pitch_deg": math.degrees(x_eq[2]) + (offset if i == 2 else 0.0),
    }
    displaced = msgspec.convert(d, Scenario)
    start = initial_condition(displaced)
    rows: list[tuple[float, float, float]] = []
    pos = ("platform_surge_m", "platform_heave_m", "platform_pitch_rad")[i]
    vel = ("platform_surge_velocity_m_s", "", "platform_pitch_rate_rad_s")[i]

    # a compiled controller (ROSCO's DISCON) writes its files into the run's folder: a
    # temporary one, removed with them
    run_dir = tempfile.TemporaryDirectory(prefix="fowt-closed-loop-")
    runtime = ControllerRuntime(
        displaced,
        paced=False,
        run_dir=run_dir.name,
        operating_point=lambda: operating_point(displaced),
    )

    def publish(mt: object, msg: object) -> None:
        if mt is TRUTH:
            rows.append(
                (msg.sample_time_ns * 1e-9, getattr(msg, pos), getattr(msg, vel))  # type: ignore[attr-defined]
            )
        elif mt is WAVE_PREVIEW_PERFECT:
            runtime.handle_preview(msg)

    with run_dir:
        run_inprocess(displaced, publish, publishing_step(runtime, publish), initial=start)
    a = np.array(rows, dtype=np.float64)
    t, y, v = a[:, 0] - a[0, 0], (a[:, 1] - x_eq[i]) * scale, a[:, 2]
    sign = 1.0 if offset > 0.0 else -1.0
    cycles = decay_cycles(t, y, v, sign, 0.02 * abs(offset))
    return ClosedLoopDecay(
        wind_m_s=float(wind_m_s),
        dof=dof,
        offset=float(offset),
        unit="deg" if dof == "pitch" else "m",
        duration_s=float(t[-1]),
        cycles=tuple(cycles),
        time_s=t,
        displacement=y,
    )
