"""Trimmed starts: the initial condition a scenario's run starts from (``[initial]``).

A run starts at the steady state its controller holds in the scenario's mean wind, as an
OpenFAST user sets ``RotSpeed``, ``BlPitch`` and ``PtfmSurge``. That steady state is a
property of the turbine *and* the control law (a minimum rotor speed, a region-2.5 torque
PI, a minimum-pitch schedule, an LQRI's operating-point schedule, a DISCON's own logic), so
it is found here, in the launcher's layer that sees both, by a settling run of the real
plant and the real controller core in process:

1. the scenario made steady: wind at the mean speed U (:func:`mean_wind_m_s`), still water,
   no sensor noise, quantization, dropouts or faults (a quantization step that the noise
   dithers in the run would, noise-free, leave a dead band: the default encoder's
   2π/(4096 h) = 0.061 rad/s at h = 0.025 s is 12 % of the IEA 15 MW's 5 rpm), the plant
   starting at its own operating point (``[initial] trim = false``), :data:`SETTLE_S`
   simulated seconds;
2. the rotor speed ω, blade pitch θ (and generator torque, for the controller's side)
   averaged over the last :data:`AVERAGE_S` (one surge
   period of the IEA 15 MW on VolturnUS-S, so what is left of the platform's slow
   oscillation averages out); then a second settling run of the same length started
   trimmed at that point (steps 3 and the controller's ``trimmed_state`` below) and
   averaged the same way (:data:`SETTLE_PASSES`). The first run's start is far from the
   steady state; a lightly damped surge (ζ 0.01 with the baseline at 11 m/s) still rings
   at its end, so its average missed the point (by 0.39 m of surge and 0.006° of pitch
   with ROSCO on the NREL 5 MW OC3 spar at 11 m/s), and a run started there rang again
   (9-13 mm of surge std over its first 60 s with the baseline and ROSCO on the IEA 15 MW
   at 11 m/s, sensors quiet; 0.5 and 0.3 mm now). The second run starts at
   rest near the point; a third moves it by less than 2 mm of surge and 1e-4 rpm
   (``bench/trimmed_start.py --table``);
3. the plant is handed that rotor point (:class:`plant.initial.InitialCondition`); it
   balances the generator torque against the aerodynamic torque there (N T_g = Q_a) and
   puts the platform at the static equilibrium under that point's mean thrust on its own
   hydrostatic and mooring stiffness (:mod:`plant.build`), both at the mean wind U (not
   the wind at t = 0 of a turbulent record).

The plant never imports the controller nor the controller the plant: the settling run goes
through the same in-process loop as a run (:func:`hil.inprocess.run.run_inprocess`). The
controller's side of the trim is :func:`operating_point` (mean wind, rotor speed, pitch,
and the settling run's mean generator torque): the runner hands it to a core's optional
``trimmed_state(operating_point)`` (:mod:`controller.interface`), which returns the state
the core holds in steady operation there (the baseline: its wind EKF converged on the
point instead of started from the nacelle anemometer; the advanced controller: its
observers started at the point; ROSCO: its DISCON library warmed up on the trimmed plant
before cycle 0, :mod:`controller.rosco`). A core without it initialises its filters,
integrators and observers from its first measurement (the baseline's filter at the
measured speed and its pitch integrator at the measured pitch; ``lqr_wave``'s observers at
the measured operating point), which a trimmed plant makes consistent with it
(``bench/trimmed_start.py --table`` measures the first 60 s of every kind;
``tests/test_trim.py`` bounds them).

It runs where the plant is built, before the first cycle (:class:`hil.nodes.plant_node.PlantLoop`:
the plant process of a bus run, the launcher's process of an in-process run): both passes
0.3 s of wall time for iea15mw-lc2 (the compiled loop), 0.6 s for iea15mw-lc2-lqri-ff and
2.0 s for iea15mw-lc2-rosco (a DISCON library runs the Python loop), measured idle on the
2-core machine (one pass: 0.14, 0.30 and 0.9 s). Results are kept
per process and on disk (:mod:`hil.inprocess.trim_store`): a campaign's seeds share one mean
wind and controller, and a later process (the next run, a bus run's plant process) reads
the settled point instead of settling again. A settling run that fails (a controller that
cannot be built) fails the run with its reason. A core that faults in it (raises, or gives a
non-finite or out-of-range command: :mod:`hil.nodes.controller_fault`) raises
:class:`hil.nodes.controller_fault.ControllerFaultError` carrying the fault (``phase`` =
``"trim"``): the fault is the controller's, whichever process settles. ``fowt run`` settles
in the launcher before any node starts (a bus run's plant process then reads the settled
point from the store), so such a run ends as the controller's fault (exit 7), never as the
plant's.
"""

from __future__ import annotations

import functools
import tempfile
from collections.abc import Mapping
from typing import TYPE_CHECKING

import msgspec
import numpy as np

from controller.interface import OperatingPoint
from hil.nodes.controller_fault import ControllerFaultError
from hil.nodes.plant_node import initial_overrides, plant_spec
from hil.scenario.schema import (
    SENSOR_CHANNELS,
    GustWindSpec,
    RampWindSpec,
    Scenario,
    SteadyWindSpec,
    StepWindSpec,
    TurbulentWindSpec,
    WindSpecSection,
)
from plant.build import sensor_channels
from plant.initial import InitialCondition

if TYPE_CHECKING:
    pass

__all__ = [
    "AVERAGE_S",
    "SETTLE_S",
    "initial_condition",
    "mean_wind_m_s",
    "operating_point",
    "settle_platform",
    "settle_point",
    "settle_rotor",
]

#: Length of the settling run [s]: the baseline's rotor speed from the plant's own start at
#: 5 m/s (3.84 rpm) to within 0.1 % of its steady 5.1 rpm takes about 100 s (the slowest
#: case measured, ``bench/trimmed_start.py``); the averaging window follows.
SETTLE_S = 300.0
#: Window at the end of the settling run the rotor point is averaged over [s].
AVERAGE_S = 120.0
#: Settling runs per trim (:func:`_settled`): the second starts trimmed at the first's point.
SETTLE_PASSES = 2

_TURBINE_CHANNELS = SENSOR_CHANNELS[:5]


def mean_wind_m_s(spec: WindSpecSection) -> float:
    """The wind a run is trimmed for [m/s]: the speed the run starts in, on average.

    Steady: its speed; step and ramp: the initial speed; turbulent: the mean; gust: the hub
    speed before the gust.
    """
    if isinstance(spec, SteadyWindSpec):
        return spec.speed_m_s
    if isinstance(spec, StepWindSpec | RampWindSpec):
        return spec.initial_m_s
    if isinstance(spec, TurbulentWindSpec):
        return spec.mean_m_s
    assert isinstance(spec, GustWindSpec)
    return spec.hub_speed_m_s


def settling_scenario(scenario: Scenario, duration_s: float = SETTLE_S) -> Scenario:
    """Step 1 of the module docstring: the scenario made steady, quiet and untrimmed."""
    d = msgspec.to_builtins(scenario)
    # what cannot change the steady state is made the same, so that a campaign's seeds and
    # cases with one controller and mean wind share one settling run (the cache's key)
    d["name"] = "trim"
    d["description"] = ""
    d["duration_s"] = duration_s
    d["wind"] = {"kind": "steady", "speed_m_s": mean_wind_m_s(scenario.wind)}
    if scenario.waves is not None:
        d["waves"] = {"kind": "still", "gauge_distance_m": scenario.waves.gauge_distance_m}
        if scenario.waves.depth_m is not None:
            d["waves"]["depth_m"] = scenario.waves.depth_m
    d["faults"] = []
    sensors = d.setdefault("sensors", {})
    sensors["seed"] = 1  # noise and dropouts are off: the seed draws nothing
    for key in list(sensors):
        if key.endswith("_std_rad_s") or "_std_" in key:
            sensors[key] = 0.0
    names = SENSOR_CHANNELS if scenario.platform is not None else _TURBINE_CHANNELS
    channels = sensors.setdefault("channels", {})
    for name in names:  # noise, quantization and dropouts off; biases and delays kept
        channels[name] = {
            **channels.get(name, {}),
            "std": 0.0,
            "resolution": 0.0,
            "dropout_probability": 0.0,
        }
    d["initial"] = {"trim": False}
    d.pop("review", None)
    return msgspec.convert(d, Scenario)


@functools.lru_cache(maxsize=64)
def _settled(encoded: bytes) -> tuple[float, float, float, float, float]:
    """(ω rad/s, θ rad, T_g N m, platform surge m, platform pitch rad) averaged over the
    last :data:`AVERAGE_S` of the settling runs' last pass (surge and pitch 0 without a
    platform): :data:`SETTLE_PASSES` passes, the first from the plant's own operating
    point, each next one started trimmed at the point the one before averaged."""
    scenario = msgspec.json.decode(encoded, type=Scenario)
    point = _settling_pass(scenario, None)
    for _ in range(SETTLE_PASSES - 1):
        point = _settling_pass(scenario, point)
    return point


def _settling_pass(
    scenario: Scenario, start: tuple[float, float, float, float, float] | None
) -> tuple[float, float, float, float, float]:
    """One settling run (:func:`_settled`): from the plant's own operating point (``start``
    None) or trimmed at ``start`` (the plant at that rotor point, the controller's core in
    its ``trimmed_state`` there, as a trimmed run starts)."""
    from bus_schemas.registry import TRUTH, WAVE_PREVIEW_PERFECT  # noqa: PLC0415
    from hil.inprocess.run import run_inprocess  # noqa: PLC0415
    from hil.nodes.controller_node import ControllerRuntime, publishing_step  # noqa: PLC0415

    start_ns = round((scenario.duration_s - AVERAGE_S) * 1e9)
    sums = [0.0, 0.0, 0.0, 0.0, 0.0, 0]  # ω, θ, T_g, surge, platform pitch and the count
    wind = mean_wind_m_s(scenario.wind)
    initial = InitialCondition()
    op: OperatingPoint | None = None
    if start is not None:
        omega, theta, torque, surge, pitch = start
        initial = InitialCondition(rotor_speed_rad_s=omega, blade_pitch_rad=theta, wind_m_s=wind)
        floating = scenario.platform is not None
        op = OperatingPoint(
            wind_m_s=wind,
            rotor_speed_rad_s=omega,
            blade_pitch_rad=theta,
            generator_torque_nm=torque,
            platform_surge_m=surge if floating else None,
            platform_pitch_rad=pitch if floating else None,
            measurement_offsets=_measurement_offsets(scenario),
            control_period_s=scenario.timing.control_period_s,
        )

    with tempfile.TemporaryDirectory(prefix="fowt-trim-") as run_dir:
        runtime = ControllerRuntime(
            scenario,
            run_dir=run_dir,
            paced=False,
            phase="trim",
            operating_point=op,
        )

        def publish(mt: object, msg: msgspec.Struct) -> None:
            if mt is TRUTH:
                if msg.sample_time_ns >= start_ns:  # type: ignore[attr-defined]
                    sums[0] += msg.rotor_speed_rad_s  # type: ignore[attr-defined]
                    sums[1] += msg.blade_pitch_rad  # type: ignore[attr-defined]
                    sums[2] += msg.generator_torque_nm  # type: ignore[attr-defined]
                    sums[3] += msg.platform_surge_m  # type: ignore[attr-defined]
                    sums[4] += msg.platform_pitch_rad  # type: ignore[attr-defined]
                    sums[5] += 1
            elif mt is WAVE_PREVIEW_PERFECT:
                runtime.handle_preview(msg)

        def publish_block(_order: np.ndarray, rows: Mapping[int, np.ndarray]) -> None:
            # the compiled loop's rows: only the truth's two columns are summed, no Struct
            truth = rows.get(TRUTH.message_id)
            if truth is None:
                return
            late = truth[truth["sample_time_ns"] >= start_ns]
            if late.size:
                # sums in publish order, as the Structs' path adds them (same bits)
                columns = [
                    late[name].tolist()
                    for name in (
                        "rotor_speed_rad_s",
                        "blade_pitch_rad",
                        "generator_torque_nm",
                        "platform_surge_m",
                        "platform_pitch_rad",
                    )
                ]
                for row in zip(*columns, strict=True):
                    for k, value in enumerate(row):
                        sums[k] += value
                sums[5] += int(late.size)

        result = run_inprocess(
            scenario,
            publish,
            publishing_step(runtime, publish),
            runtime=runtime,
            initial=initial,
            publish_block=publish_block,
        )
        close = getattr(runtime.controller, "close", None)
        if callable(close):
            close()
    if runtime.fault is not None:  # the controller's fault, not the plant's: said so
        raise ControllerFaultError(runtime.fault)
    n = int(sums[5])
    if n == 0 or result.aborted:
        raise RuntimeError(f"trim of {scenario.name!r}: the settling run did not complete")
    return sums[0] / n, sums[1] / n, sums[2] / n, sums[3] / n, sums[4] / n


@functools.lru_cache(maxsize=64)
def _settled_stored(encoded: bytes, name: str) -> tuple[float, ...]:
    """:func:`_settled` through the on-disk store (:mod:`hil.inprocess.trim_store`)."""
    from hil.inprocess.trim_store import settled_cached  # noqa: PLC0415

    return settled_cached(encoded, name, _settled)


def settle_rotor(scenario: Scenario, duration_s: float = SETTLE_S) -> tuple[float, float]:
    """The controller's steady (ω rad/s, θ rad) at the scenario's mean wind (steps 1-2).

    Read from the on-disk store when an earlier process settled the same scenario with the
    same code (:mod:`hil.inprocess.trim_store`), else settled here and stored.
    """
    omega, theta, _torque = settle_point(scenario, duration_s)
    return omega, theta


def settle_point(scenario: Scenario, duration_s: float = SETTLE_S) -> tuple[float, float, float]:
    """:func:`settle_rotor` and the settled generator torque [N m, HSS]: (ω, θ, T_g)."""
    omega, theta, torque, _surge, _pitch = _settled_point(scenario, duration_s)
    return omega, theta, torque


def settle_platform(scenario: Scenario, duration_s: float = SETTLE_S) -> tuple[float, float]:
    """The platform's mean surge [m] and pitch [rad] at the settled point (0, 0 without a
    platform): where the trimmed plant stands, for a core's observers to start at."""
    _omega, _theta, _torque, surge, pitch = _settled_point(scenario, duration_s)
    return surge, pitch


def _settled_point(
    scenario: Scenario, duration_s: float
) -> tuple[float, float, float, float, float]:
    sc = settling_scenario(scenario, duration_s)
    omega, theta, torque, surge, pitch = _settled_stored(msgspec.json.encode(sc), scenario.name)
    return omega, theta, torque, surge, pitch


def operating_point(scenario: Scenario) -> OperatingPoint | None:
    """The controller's side of the trim: the operating point its core starts at.

    None for an untrimmed run (``[initial] trim = false``). Else the mean wind and the rotor
    speed and blade pitch of :func:`initial_condition` (the settled point, or the
    ``[initial]`` keys where set) and the generator torque: ``generator_torque_nm`` when
    set, else the settled point's mean generator torque when neither the rotor speed nor
    the pitch was overridden (the torque the plant balances there, so that a core's
    estimator starts at the wind the plant's rotor sees, not at the wind its own model
    would balance), else None (the core derives it); and the instruments' constant
    offsets (the sensor channels' biases, :attr:`OperatingPoint.measurement_offsets`).
    The runner hands it to a core's optional ``trimmed_state``
    (:class:`hil.nodes.controller_node.ControllerRuntime`, :mod:`controller.interface`):
    the controller then starts in its own steady state there
    instead of initialising from its first measurement. Computed after the plant's
    :func:`initial_condition` in the same process it costs nothing (both read the same
    settled point); in a bus run's controller process it reads the on-disk store the plant
    process filled (:mod:`hil.inprocess.trim_store`), or settles once more.
    """
    if not scenario.initial.trim:
        return None
    ic = initial_condition(scenario)
    assert ic.rotor_speed_rad_s is not None and ic.blade_pitch_rad is not None
    torque = ic.generator_torque_nm
    if torque is None and (
        initial_overrides(scenario.initial).rotor_speed_rad_s is None
        and initial_overrides(scenario.initial).blade_pitch_rad is None
    ):  # the settled point itself: its torque too
        torque = settle_point(scenario)[2]
    # where the platform stands: the settled point's, unless [initial] moved the rotor
    # point (then the plant's equilibrium is another's) or the platform itself
    surge: float | None = None
    pitch: float | None = None
    moved = initial_overrides(scenario.initial)
    if scenario.platform is not None and all(
        getattr(moved, k) is None
        for k in ("rotor_speed_rad_s", "blade_pitch_rad", "generator_torque_nm")
    ):
        surge, pitch = settle_platform(scenario)
        surge = surge if moved.platform_surge_m is None else moved.platform_surge_m
        pitch = pitch if moved.platform_pitch_rad is None else moved.platform_pitch_rad
    return OperatingPoint(
        wind_m_s=mean_wind_m_s(scenario.wind),
        rotor_speed_rad_s=ic.rotor_speed_rad_s,
        blade_pitch_rad=ic.blade_pitch_rad,
        generator_torque_nm=torque,
        platform_surge_m=surge,
        platform_pitch_rad=pitch,
        measurement_offsets=_measurement_offsets(scenario),
        control_period_s=scenario.timing.control_period_s,
    )


def _measurement_offsets(scenario: Scenario) -> tuple[tuple[str, float], ...]:
    """The scenario's instruments' constant offsets (:attr:`OperatingPoint.measurement_offsets`)."""
    channels = sensor_channels(plant_spec(scenario)) or {}
    return tuple((name, float(c.bias)) for name, c in sorted(channels.items()) if c.bias != 0.0)


def initial_condition(scenario: Scenario) -> InitialCondition:
    """Where the scenario's run starts (module docstring; ``[initial]`` keys override).

    ``[initial] trim = false``: the plant's own operating point with the set keys replaced.
    """
    section = scenario.initial
    explicit = initial_overrides(section)
    if not section.trim:
        return explicit
    omega, theta = settle_rotor(scenario)
    return InitialCondition(
        rotor_speed_rad_s=omega
        if explicit.rotor_speed_rad_s is None
        else explicit.rotor_speed_rad_s,
        blade_pitch_rad=theta if explicit.blade_pitch_rad is None else explicit.blade_pitch_rad,
        generator_torque_nm=explicit.generator_torque_nm,
        platform_surge_m=explicit.platform_surge_m,
        platform_heave_m=explicit.platform_heave_m,
        platform_pitch_rad=explicit.platform_pitch_rad,
        wind_m_s=mean_wind_m_s(scenario.wind),
    )
