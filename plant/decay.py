"""Free decay of the floating platform: the time-domain plant released from an offset.

What runs
---------
The plant of a run (:class:`plant.simulator.PlantSimulator`, the compiled fixed-step RK4 of
:func:`plant._kernels.advance_floating` with the nonlinear mooring table, the radiation memory
states, the quadratic drag and the flexible tower) in its **parked, no-wind configuration**:
still air (U = 0) with the rotor aerodynamics off (``FloatingParams.aero = False``, as the
decks' ``CompAero = 0``), the rotor at rest (speed 0, generator torque 0, blade pitch held at
its minimum: with no aerodynamics the pitch changes nothing), still water (no wave
excitation). The platform starts at rest at its static equilibrium (:meth:`PlantSimulator.
initial_state`, the still-air equilibrium of :func:`plant.modes.operating_point`) with one
DOF displaced by ``offset`` (surge or heave m, pitch deg), every other DOF and the tower at
their equilibrium, the radiation states zero; then it is left alone.

What is measured
----------------
The displacement y(t) = q(t) − q_eq from the static equilibrium and its rate (a state of
the plant, so the extrema are where the rate changes sign, interpolated linearly between
samples). A *cycle* runs from one extremum on the side of the offset to the next on the
same side (the release at t = 0 is the first: the platform starts at rest). For cycle k,
from amplitude a_k to a_{k+1}:

* period T_k = t_{k+1} − t_k (s);
* logarithmic decrement δ_k = ln(a_k / a_{k+1});
* damping ratio ζ_k = δ_k / √(4π² + δ_k²) (exact for a linear oscillator).

With quadratic drag and the mooring's hardening both depend on the amplitude, which is why
each cycle is listed with its starting amplitude. Cycles stop when the amplitude falls below
``min_amplitude_fraction`` of the offset (the decay is then lost in the slower modes' beat).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import numpy.typing as npt

from plant.initial import InitialCondition
from plant.simulator import FloatingPlant, PlantConfig, PlantSimulator
from plant.wind import SteadyWind

__all__ = [
    "DECAY_CASE",
    "DECAY_DOFS",
    "DecayCycle",
    "DecayResult",
    "decay_cycles",
    "free_decay",
]

FloatArray = npt.NDArray[np.float64]

#: The decaying DOF -> its index in the plant state (positions 0..3, rates 4..7).
DECAY_DOFS = {"surge": 0, "heave": 1, "pitch": 2}

#: The configuration the decay runs in (said in every report).
DECAY_CASE = (
    "time-domain plant, parked in still air: rotor aerodynamics off, rotor at rest (speed 0, "
    "torque 0, pitch at its minimum), still water; nonlinear mooring table, radiation memory, "
    "quadratic drag, flexible tower"
)

#: Default duration per DOF (s): about five cycles of the slowest preset's period.
DEFAULT_DURATION_S = {"surge": 800.0, "heave": 200.0, "pitch": 250.0}


@dataclass(frozen=True)
class DecayCycle:
    """One cycle of a free decay (module docstring).

    Attributes
    ----------
    index : int
        0 for the cycle that starts at the release.
    start_s : float
        Time of the extremum the cycle starts at (s).
    amplitude : float
        |y| there, in the DOF's report unit (m, or deg for pitch).
    period_s : float
        Time to the next extremum on the same side (s).
    log_decrement : float
        δ = ln(a_k / a_{k+1}) (-); negative when the motion grows.
    damping_ratio : float
        ζ = δ / √(4π² + δ²) (-).
    """

    index: int
    start_s: float
    amplitude: float
    period_s: float
    log_decrement: float
    damping_ratio: float

    def as_dict(self) -> dict[str, float | int]:
        """Plain dict (JSON)."""
        return {
            "index": self.index,
            "start_s": round(self.start_s, 3),
            "amplitude": round(self.amplitude, 6),
            "period_s": round(self.period_s, 4),
            "log_decrement": round(self.log_decrement, 6),
            "damping_ratio": round(self.damping_ratio, 6),
        }


@dataclass(frozen=True)
class DecayResult:
    """A free decay's cycles and summary.

    Attributes
    ----------
    preset : str
    dof : str
        ``surge``, ``heave`` or ``pitch``.
    offset : float
        Initial displacement from the equilibrium (m, or deg for pitch).
    unit : str
        ``"m"`` or ``"deg"``.
    equilibrium : float
        Static equilibrium of the DOF (m or deg).
    duration_s, plant_step_s : float
        Simulated time and RK4 step (s).
    radiation : bool
        Radiation memory on (False: infinite-frequency added mass only).
    cycles : tuple of DecayCycle
    time_s, displacement : ndarray
        The sampled response y(t) (report unit), kept for plots and tests.
    case : str
        :data:`DECAY_CASE`.
    """

    preset: str
    dof: str
    offset: float
    unit: str
    equilibrium: float
    duration_s: float
    plant_step_s: float
    radiation: bool
    cycles: tuple[DecayCycle, ...]
    time_s: FloatArray = field(repr=False)
    displacement: FloatArray = field(repr=False)
    case: str = DECAY_CASE

    @property
    def period_s(self) -> float:
        """Period of the first cycle (s; NaN without a whole cycle)."""
        return self.cycles[0].period_s if self.cycles else math.nan

    @property
    def mean_period_s(self) -> float:
        """Mean period of the cycles (s; NaN without one)."""
        return float(np.mean([c.period_s for c in self.cycles])) if self.cycles else math.nan

    @property
    def damping_ratio(self) -> float:
        """Damping ratio of the first cycle (-; NaN without a whole cycle)."""
        return self.cycles[0].damping_ratio if self.cycles else math.nan

    def as_dict(self) -> dict[str, object]:
        """Plain dict (JSON), without the sampled response."""
        return {
            "preset": self.preset,
            "dof": self.dof,
            "offset": self.offset,
            "unit": self.unit,
            "equilibrium": round(self.equilibrium, 6),
            "duration_s": self.duration_s,
            "plant_step_s": self.plant_step_s,
            "radiation_memory": self.radiation,
            "case": self.case,
            "period_s": round(self.period_s, 4) if self.cycles else None,
            "mean_period_s": round(self.mean_period_s, 4) if self.cycles else None,
            "damping_ratio": round(self.damping_ratio, 6) if self.cycles else None,
            "cycles": [c.as_dict() for c in self.cycles],
        }


def _damping_ratio(delta: float) -> float:
    return delta / math.sqrt(4.0 * math.pi * math.pi + delta * delta)


def decay_cycles(
    t_s: FloatArray,
    y: FloatArray,
    rate: FloatArray,
    sign: float,
    min_amplitude: float = 0.0,
) -> list[DecayCycle]:
    """Cycles of a sampled decay (module docstring).

    Parameters
    ----------
    t_s : ndarray
        Sample times (s), increasing.
    y : ndarray
        Displacement from the equilibrium at ``t_s``.
    rate : ndarray
        dy/dt at ``t_s`` (any positive multiple of it: only its sign changes are used).
    sign : float
        +1 or −1: the side of the offset (the extrema counted are maxima for +1, minima for −1).
    min_amplitude : float
        Cycles stop at an extremum with |y| below this (same unit as ``y``).

    Returns
    -------
    list of DecayCycle
    """
    t = np.asarray(t_s, dtype=np.float64)
    yy = np.asarray(y, dtype=np.float64) * sign
    v = np.asarray(rate, dtype=np.float64) * sign
    # extrema on the offset's side: the rate goes from + to − (a maximum of sign·y)
    idx = np.nonzero((v[:-1] > 0.0) & (v[1:] <= 0.0))[0]
    times = [float(t[0])] if v[0] <= 0.0 else []
    amps = [float(yy[0])] if v[0] <= 0.0 else []
    for i in idx:
        w = v[i] / (v[i] - v[i + 1])  # linear interpolation of the rate's zero
        tk = float(t[i] + w * (t[i + 1] - t[i]))
        # y near an extremum is flat: the quadratic through the rate's zero is
        # y(t) ≈ y_i + v_i (tk − t_i)/2 (the mean rate over the interval is v_i/2)
        ak = float(yy[i] + 0.5 * v[i] * (tk - t[i]))
        times.append(tk)
        amps.append(ak)
    out: list[DecayCycle] = []
    for k in range(len(times) - 1):
        a0, a1 = amps[k], amps[k + 1]
        if a0 <= max(min_amplitude, 0.0) or a1 <= 0.0:
            break
        delta = math.log(a0 / a1)
        out.append(
            DecayCycle(
                index=k,
                start_s=times[k],
                amplitude=a0,
                period_s=times[k + 1] - times[k],
                log_decrement=delta,
                damping_ratio=_damping_ratio(delta),
            )
        )
        if a1 < min_amplitude:
            break
    return out


def _parked(fp: FloatingPlant, radiation: bool) -> FloatingPlant:
    """The floating plant with the rotor aerodynamics off (and without radiation memory
    when ``radiation`` is False: the infinite-frequency added mass alone)."""
    params = replace(fp.params, aero=False)
    if not radiation:
        params = replace(
            params,
            radiation_a=np.zeros((0, 0)),
            radiation_b=np.zeros((0, 3)),
            radiation_c=np.zeros((3, 0)),
        )
    return replace(fp, params=params)


def free_decay(
    preset: str | Path,
    dof: str,
    offset: float,
    duration_s: float | None = None,
    *,
    plant_step_s: float = 0.0125,
    sample_steps: int = 4,
    radiation: bool = True,
    min_amplitude_fraction: float = 0.01,
    plant: FloatingPlant | None = None,
) -> DecayResult:
    """Release the parked platform from ``offset`` in ``dof`` and measure its cycles.

    Parameters
    ----------
    preset : str or Path
        Floating preset name or preset ``.toml`` path.
    dof : str
        ``"surge"``, ``"heave"`` or ``"pitch"``.
    offset : float
        Initial displacement from the static equilibrium: m (surge, heave) or deg (pitch);
        non-zero, |offset| <= 60 m or 20 deg.
    duration_s : float, optional
        Simulated time (s); default :data:`DEFAULT_DURATION_S` of the DOF.
    plant_step_s : float
        RK4 step (s), as a scenario's ``[timing] plant_step_s``.
    sample_steps : int
        Steps between samples of the response (one :meth:`PlantSimulator.advance` call).
    radiation : bool
        Radiation memory on (default); False: the infinite-frequency added mass alone.
    min_amplitude_fraction : float
        Cycles stop below this fraction of |offset|.
    plant : FloatingPlant, optional
        An already built plant of ``preset`` (:func:`plant.build.floating_plant`), to
        reuse across several decays.

    Returns
    -------
    DecayResult

    Raises
    ------
    ValueError
        On a bad DOF, offset, duration or step, or a preset that cannot be loaded.
    """
    if dof not in DECAY_DOFS:
        raise ValueError(f"dof: expected one of {', '.join(DECAY_DOFS)}, got {dof!r}")
    limit = 20.0 if dof == "pitch" else 60.0
    if not (math.isfinite(offset) and offset != 0.0 and abs(offset) <= limit):
        unit = "deg" if dof == "pitch" else "m"
        raise ValueError(f"offset: expected a non-zero {dof} offset within ±{limit:g} {unit}")
    duration = DEFAULT_DURATION_S[dof] if duration_s is None else float(duration_s)
    if not (math.isfinite(duration) and 0.0 < duration <= 20_000.0):
        raise ValueError(f"duration: expected 0 < duration <= 20000 s, got {duration_s}")
    if not (math.isfinite(plant_step_s) and 0.0 < plant_step_s <= 0.1):
        raise ValueError(f"plant_step_s: expected 0 < step <= 0.1 s, got {plant_step_s}")
    if sample_steps < 1:
        raise ValueError(f"sample_steps: expected >= 1, got {sample_steps}")
    if plant is None:
        from plant.build import floating_plant  # noqa: PLC0415  loads the hydro data

        plant = floating_plant(preset)
    fp = _parked(plant, radiation)
    tp = fp.params.turbine
    pitch0 = tp.pitch_min_rad
    parked = InitialCondition(
        rotor_speed_rad_s=0.0, blade_pitch_rad=pitch0, generator_torque_nm=0.0, wind_m_s=0.0
    )

    def simulator(initial: InitialCondition) -> PlantSimulator:
        return PlantSimulator(
            PlantConfig(
                turbine=tp,
                wind=SteadyWind(0.0),
                plant_step_s=plant_step_s,
                steps_per_cycle=sample_steps,
                sensor_noise={},
                floating=fp,
                initial=initial,
            )
        )

    i = DECAY_DOFS[dof]
    x_eq = simulator(parked).initial_state()
    scale = math.degrees(1.0) if dof == "pitch" else 1.0
    start = x_eq[i] + offset / scale
    sim = simulator(
        replace(
            parked,
            platform_surge_m=start if i == 0 else x_eq[0],
            platform_heave_m=start if i == 1 else x_eq[1],
            platform_pitch_rad=start if i == 2 else x_eq[2],
        )
    )
    x = sim.initial_state()
    command = (pitch0, 0.0)
    period = plant_step_s * sample_steps
    n = round(duration / period)
    ts = np.arange(n + 1, dtype=np.float64) * period
    y = np.empty(n + 1)
    v = np.empty(n + 1)
    y[0], v[0] = x[i] - x_eq[i], x[4 + i]
    for k in range(n):
        x = sim.advance(float(ts[k]), x, command, command)
        y[k + 1], v[k + 1] = x[i] - x_eq[i], x[4 + i]
    if not np.all(np.isfinite(y)):
        raise ValueError(
            f"{preset}: the decay diverged (non-finite {dof}); try a smaller plant_step_s"
        )
    sign = 1.0 if offset > 0.0 else -1.0
    cycles = decay_cycles(ts, y * scale, v, sign, min_amplitude_fraction * abs(offset))
    return DecayResult(
        preset=str(preset),
        dof=dof,
        offset=float(offset),
        unit="deg" if dof == "pitch" else "m",
        equilibrium=float(x_eq[i] * scale),
        duration_s=float(n * period),
        plant_step_s=plant_step_s,
        radiation=radiation,
        cycles=tuple(cycles),
        time_s=ts,
        displacement=y * scale,
    )
