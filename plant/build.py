"""The plant built from its own configuration: :func:`build_plant` (PlantSpec -> PlantConfig).

A run's launcher (``hil``) reads a scenario and hands the plant its part as a
:class:`PlantSpec`, plain frozen data owned here (this package never imports ``hil``); the
plant loads its presets, synthesises its wind and waves, computes the wave excitation and
sets up its sensors itself. The bus node and the in-process loop both build the plant this
one way.

Initial condition
-----------------
:class:`InitialCondition` says where the run starts. Each field left None takes the plant's
own default (:meth:`plant.simulator.PlantSimulator.initial_state`): the rotor at the optimal
tip-speed ratio capped at rated speed, fine pitch below rated, the pitch that holds rated
power above it, the torque that balances the aerodynamic torque; floating: the static
platform equilibrium under that point's mean thrust (:func:`plant.modes.operating_point`).
A controller may hold another steady state (a minimum rotor speed, a minimum-pitch schedule):
the launcher computes it (``hil.inprocess.trim``) and passes the rotor point here; the platform
offset
then follows as the static equilibrium under *that* point's thrust, solved by the plant on
its own stiffness (hydrostatics, mooring), unless given too.
"""

from __future__ import annotations

import importlib.resources
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from plant.initial import InitialCondition
from plant.simulator import FloatingPlant, PlantConfig, TowerBaseLoads
from plant.turbine import TurbineParams, load_turbine
from plant.waves import (
    IsscSpectrum,
    JonswapSpectrum,
    PiersonMoskowitzSpectrum,
    WaveField,
    excitation_force,
    still_water,
    synthesize,
)
from plant.wind import (
    TURBULENCE_BOX_S,
    GustWind,
    RampWind,
    SteadyWind,
    StepWind,
    TurbulentWind,
    WindSpec,
)
from sensors import ChannelSpec, NoiseSpec, default_floating_suite
from sensors.faults import FaultSpec

if TYPE_CHECKING:
    from plant.hydro.wamit import HydroData

__all__ = [
    "GustRequest",
    "InitialCondition",
    "PlantSpec",
    "SensorRequest",
    "TurbulenceRequest",
    "WaveRequest",
    "WindRequest",
    "build_plant",
    "floating_plant",
    "make_waves",
    "make_wind",
    "pitch_limited",
]

#: The five turbine channels (noise-only sensors of a bottom-fixed plant), frame field names.
TURBINE_CHANNELS = (
    "generator_speed_measured_rad_s",
    "blade_pitch_measured_rad",
    "generator_torque_measured_nm",
    "electrical_power_measured_w",
    "wind_speed_measured_m_s",
)


@dataclass(frozen=True)
class TurbulenceRequest:
    """Rotor-effective IEC Kaimal turbulence (:class:`plant.wind.TurbulentWind`) to synthesise.

    The record's length, sampling and rotor come from the run and the turbine.
    """

    mean_m_s: float
    turbulence_class: str = "B"
    seed: int = 0


@dataclass(frozen=True)
class GustRequest:
    """IEC extreme operating gust (:class:`plant.wind.GustWind`); the rotor from the turbine."""

    hub_speed_m_s: float
    start_s: float = 10.0
    turbine_class: str = "I"
    turbulence_class: str = "B"
    period_s: float = 10.5


#: A wind the plant can build: the deterministic ones as they are, the others as requests.
WindRequest = SteadyWind | StepWind | RampWind | TurbulenceRequest | GustRequest


@dataclass(frozen=True)
class WaveRequest:
    """Long-crested irregular waves (``spectrum`` None: still water) and the gauge.

    ``depth_m`` None: the platform preset's water depth. The synthesis keys are those of
    :func:`plant.waves.synthesize`.
    """

    spectrum: JonswapSpectrum | PiersonMoskowitzSpectrum | IsscSpectrum | None = None
    depth_m: float | None = None
    seed: int = 0
    omega_min_rad_s: float = 0.1
    omega_max_rad_s: float = 3.0
    n_components: int = 200
    gauge_distance_m: float = 450.0


@dataclass(frozen=True)
class SensorRequest:
    """Sensor models: noise std overrides, per-channel tables (:meth:`ChannelSpec.from_table`)."""

    seed: int = 1
    std: Mapping[str, float] = field(default_factory=dict)
    channels: Mapping[str, Mapping[str, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class PlantSpec:
    """The plant's part of a run, as plain data (what :func:`build_plant` needs).

    Parameters
    ----------
    turbine : str
        Turbine preset name or TOML path (:func:`plant.turbine.load_turbine`).
    wind : WindRequest
        The wind.
    plant_step_s : float
        Fixed RK4 step [s].
    steps_per_cycle : int
        Plant steps per control period.
    control_period_s : float
        Control period [s] (the sensor channels' default sample-and-hold).
    duration_s : float
        Run length [s] (a turbulent record covers it plus one second).
    platform : str, optional
        Floating preset name or path (None: bottom-fixed).
    waves : WaveRequest, optional
        Waves of a floating plant (None: still water, gauge at 450 m).
    sensors : SensorRequest
        Sensor models and seed.
    sensor_faults : tuple of FaultSpec
        The run's faults (the plant applies the sensor kinds).
    initial : InitialCondition
        Where the run starts.
    symmetric_pitch_limit_deg : float, optional
        Pitch actuator range [-θ_s, θ_s] [deg] (:func:`pitch_limited`; None: the turbine's).
    """

    turbine: str
    wind: WindRequest
    plant_step_s: float
    steps_per_cycle: int
    control_period_s: float
    duration_s: float
    platform: str | None = None
    waves: WaveRequest | None = None
    sensors: SensorRequest = field(default_factory=SensorRequest)
    sensor_faults: tuple[FaultSpec, ...] = ()
    initial: InitialCondition = field(default_factory=InitialCondition)
    symmetric_pitch_limit_deg: float | None = None


def pitch_limited(turbine: TurbineParams, symmetric_limit_deg: float | None) -> TurbineParams:
    """The turbine with its pitch actuator range set to [-θ_s, θ_s] (None: unchanged).

    Raises
    ------
    ValueError
        If -θ_s lies below the lowest pitch of the rotor's C_p/C_T table (the plant would
        extrapolate the aerodynamics).
    """
    if symmetric_limit_deg is None:
        return turbine
    th = math.radians(float(symmetric_limit_deg))
    lowest = float(turbine.table.pitch_rad[0])
    if -th < lowest - 1e-12:
        raise ValueError(
            f"controller.symmetric_pitch_limit_deg = {symmetric_limit_deg}: the rotor table of "
            f"{turbine.name!r} starts at {math.degrees(lowest):.3g} deg pitch; expected "
            f"<= {-math.degrees(lowest):.3g}"
        )
    return replace(turbine, pitch_min_rad=-th, pitch_max_rad=th)


def make_wind(
    spec: WindRequest,
    turbine: TurbineParams | None = None,
    duration_s: float = 600.0,
    dt_s: float = 0.05,
) -> WindSpec:
    """The wind model of a request.

    A turbulent record is synthesised ``duration_s`` long, at most
    :data:`plant.wind.TURBULENCE_BOX_S` (a longer run repeats that box: its memory and
    synthesis time do not grow with the run), sampled every ``dt_s``, rotor-averaged over the
    ``turbine``'s rotor at its hub height; a gust uses the turbine's rotor diameter and hub
    height (no turbine: 90 m hub, 63 m radius).
    """
    if isinstance(spec, SteadyWind | StepWind | RampWind):
        return spec
    hub = turbine.hub_height_m if turbine is not None else 90.0
    radius = turbine.rotor_radius_m if turbine is not None else 63.0
    if isinstance(spec, TurbulenceRequest):
        return TurbulentWind(
            mean_m_s=spec.mean_m_s,
            turbulence_class=spec.turbulence_class,
            seed=spec.seed,
            hub_height_m=hub,
            rotor_radius_m=radius,
            duration_s=min(duration_s, TURBULENCE_BOX_S),
            dt_s=dt_s,
        )
    return GustWind(
        hub_speed_m_s=spec.hub_speed_m_s,
        start_s=spec.start_s,
        turbine_class=spec.turbine_class,
        turbulence_class=spec.turbulence_class,
        rotor_diameter_m=2.0 * radius,
        hub_height_m=hub,
        period_s=spec.period_s,
    )


def make_waves(spec: WaveRequest | None, depth_m: float) -> WaveField:
    """The wave field of a request (None or no spectrum: still water).

    Depth: the request's ``depth_m`` if given, else ``depth_m`` (the platform's water depth).
    """
    if spec is None:
        return still_water(depth_m)
    depth = spec.depth_m if spec.depth_m is not None else depth_m
    if spec.spectrum is None:
        return still_water(depth)
    return synthesize(
        spec.spectrum,
        depth_m=depth,
        seed=spec.seed,
        omega_min_rad_s=spec.omega_min_rad_s,
        omega_max_rad_s=spec.omega_max_rad_s,
        n_components=spec.n_components,
    )


def _excitation_table(hydro: HydroData, locked_dofs: tuple[int, ...]) -> tuple[Any, Any]:
    """Frequencies [rad/s] and the head-sea surge, heave, pitch excitation per metre of wave.

    A preset whose hydrodynamic data lack heave or pitch (the ``nrel5mw_tlp`` buoy has surge
    only) has those modes locked; their column is 0. A missing mode that is not locked is
    an error.
    """
    import numpy as np  # noqa: PLC0415

    wanted = (0, 2, 4)  # surge, heave, pitch in the 6-DOF hydrodynamic numbering
    present = [d for d in wanted if d in hydro.excitation.dofs]
    exc = hydro.excitation.select(present, heading_deg=0.0)
    table = np.zeros((exc.omega_rad_s.size, len(wanted)), dtype=np.complex128)
    for model_dof, d in enumerate(wanted):  # model DOFs: 0 surge, 1 heave, 2 pitch
        if d in present:
            table[:, model_dof] = exc.force[:, 0, present.index(d)]
        elif model_dof not in locked_dofs:
            raise ValueError(
                f"the platform's hydrodynamic data have no excitation for DOF {d} and the "
                "preset does not lock it (locked_dofs)"
            )
    return exc.omega_rad_s, table


def floating_plant(
    platform: str | Path,
    waves: WaveRequest | None = None,
    symmetric_pitch_limit_deg: float | None = None,
) -> FloatingPlant:
    """Load the platform preset and build the waves and their excitation (offline, ~1 s).

    ``symmetric_pitch_limit_deg``: the rotor's pitch range [-θ_s, θ_s] (:func:`pitch_limited`).
    """
    from plant.hydro.wamit import HydroData  # noqa: PLC0415
    from plant.platform import load_floating, read_floating_preset  # noqa: PLC0415

    params = load_floating(platform)
    turbine = pitch_limited(params.turbine, symmetric_pitch_limit_deg)
    if turbine is not params.turbine:
        params = replace(params, turbine=turbine)
    preset, base, _ = read_floating_preset(platform)
    hydro_ref = preset.hydro_file
    if hydro_ref.startswith("preset:"):
        res = importlib.resources.files("plant.presets").joinpath(
            *hydro_ref.removeprefix("preset:").split("/")
        )
        with importlib.resources.as_file(res) as path:
            hydro = HydroData.load_npz(path)
    else:
        hydro = HydroData.load_npz((base or Path(".")) / hydro_ref)
    wave_field = make_waves(waves, preset.water_depth_m)
    force = excitation_force(wave_field, *_excitation_table(hydro, params.locked_dofs))
    gauge = waves.gauge_distance_m if waves is not None else 450.0
    hub = float(params.hub_lever[2])
    return FloatingPlant(
        params=params,
        loads=TowerBaseLoads.from_preset(preset, hub),
        waves=wave_field,
        excitation_transfer=force.transfer,
        gauge_distance_m=gauge,
    )


def sensor_channels(spec: PlantSpec) -> dict[str, ChannelSpec] | None:
    """The plant's full channel models (:class:`sensors.ChannelSpec`), or None.

    None for a bottom-fixed plant without channel tables (its five noise-only turbine
    channels); else :func:`sensors.default_floating_suite` for a floating plant or the
    noise-only turbine channels, then the std overrides, then the per-channel tables
    (:func:`build_plant`). Cheap: nothing of the wind, waves or platform is built.
    """
    s = spec.sensors
    if spec.platform is None and not s.channels:
        return None
    if spec.platform is not None:
        channels = dict(default_floating_suite(spec.control_period_s))
        for name, value in s.std.items():
            channels[name] = replace(channels[name], std=value)
    else:
        channels = {
            name: ChannelSpec(name=name, std=s.std.get(name, 0.0)) for name in TURBINE_CHANNELS
        }
    for name, table in s.channels.items():
        channels[name] = ChannelSpec.from_table(name, dict(table), channels.get(name))
    return channels


def build_plant(spec: PlantSpec) -> PlantConfig:
    """The plant's configuration (:class:`plant.simulator.PlantConfig`) from its spec.

    Sensors: a bottom-fixed plant without channel tables keeps the foundation's noise-only
    sensors; otherwise every channel is a full model (:class:`sensors.ChannelSpec`):
    :func:`sensors.default_floating_suite` for a floating plant, the five noise-only turbine
    channels for a bottom-fixed one, then the std overrides, then the per-channel tables.
    """
    s = spec.sensors
    noise = {name: NoiseSpec(std=s.std.get(name, 0.0)) for name in TURBINE_CHANNELS}
    limit = spec.symmetric_pitch_limit_deg
    turbine = pitch_limited(load_turbine(spec.turbine), limit)
    floating = (
        floating_plant(spec.platform, spec.waves, limit) if spec.platform is not None else None
    )
    return PlantConfig(
        turbine=turbine,
        wind=make_wind(
            spec.wind,
            turbine,
            duration_s=spec.duration_s + 1.0,
            dt_s=spec.plant_step_s,
        ),
        plant_step_s=spec.plant_step_s,
        steps_per_cycle=spec.steps_per_cycle,
        sensor_noise=noise,
        sensor_seed=s.seed,
        floating=floating,
        sensor_channels=sensor_channels(spec),
        sensor_faults=tuple(f for f in spec.sensor_faults if not f.is_bus),
        initial=spec.initial,
    )
