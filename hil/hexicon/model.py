"""The Hexicon H3 plant family on the bench: scenarios, the in-process loop and KPIs.

The multi-turbine platform (:mod:`plant.hexicon`) is run against its heading controllers
(:mod:`controller.hexicon`) either in one process (:func:`run_in_process`, for campaigns and
tests) or as separate plant and controller processes over Zenoh (:mod:`hil.hexicon.nodes`).
Both use the same step sequence: every control period the plant samples its sensors, the
controller answers with per-turbine pitch and torque, and the plant integrates (RK4, fixed
step) until the next period with that command held.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from controller.hexicon import (
    BangBangState,
    HexiconCommand,
    HexiconDesign,
    HexiconMeasurement,
    IdentifiedModel,
    MpcConfig,
    bang_bang_step,
    id_mpc_step,
    load_design,
    load_identified,
    make_id_mpc,
    make_mpc,
    mpc_step,
)
from plant.hexicon.environment import WindProfile
from plant.hexicon.model import (
    HexiconParams,
    load_hexicon,
    outputs,
    rated_pitch_rad,
    steady_operating_point,
    step_rk4,
    torque_law_nm,
)
from plant.hexicon.sensors import HexiconSample, HexiconSensors, load_sensor_table

__all__ = [
    "HexiconScenario",
    "compute_kpis",
    "initial_state",
    "load_scenarios",
    "run_in_process",
]

#: bang_bang: the seed's law; mpc: OSQP MPC on the physical linearisation; mpc_id: OSQP MPC on
#: the identified (N4SID) model of ``controller/presets/hexicon_h3_identified.json``.
CONTROLLERS = ("bang_bang", "mpc", "mpc_id")


@dataclass(frozen=True)
class HexiconScenario:
    """One multi-turbine run: wind profile, length, rates, controller and sensitivity factors.

    Parameters
    ----------
    name : str
    wind : WindProfile
    duration_s : float
        Simulated time (s), > 0.
    plant_dt_s, control_period_s : float
        Plant integration step and control period (s); the period is a whole number of steps.
    inertia_factor, drag_factor : float
        Multipliers of I and C_d (the seed's section-6 sensitivity cases), > 0.
    platform : str
        Platform preset or TOML path.
    """

    name: str
    wind: WindProfile
    duration_s: float = 300.0
    plant_dt_s: float = 0.05
    control_period_s: float = 1.0
    inertia_factor: float = 1.0
    drag_factor: float = 1.0
    platform: str = "hexicon_h3"
    comment: str = ""

    def __post_init__(self) -> None:
        if not (self.duration_s > 0 and self.plant_dt_s > 0 and self.control_period_s > 0):
            raise ValueError(f"scenario {self.name!r}: expected durations > 0 s")
        ratio = self.control_period_s / self.plant_dt_s
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"scenario {self.name!r}: control_period_s ({self.control_period_s}) must be a "
                f"whole multiple of plant_dt_s ({self.plant_dt_s})"
            )
        if not (self.inertia_factor > 0 and self.drag_factor > 0):
            raise ValueError(f"scenario {self.name!r}: expected inertia/drag factors > 0")

    @property
    def steps_per_period(self) -> int:
        return round(self.control_period_s / self.plant_dt_s)

    def params(self) -> HexiconParams:
        p = load_hexicon(self.platform)
        if self.inertia_factor != 1.0 or self.drag_factor != 1.0:
            p = p.scaled(self.inertia_factor, self.drag_factor)
        return p


_WIND_KEYS = set(WindProfile.__dataclass_fields__) - {"_turb", "_turb_dt"}
_SCEN_KEYS = {
    "duration_s",
    "plant_dt_s",
    "control_period_s",
    "inertia_factor",
    "drag_factor",
    "platform",
    "comment",
}


def scenario_from_dict(name: str, raw: dict[str, Any]) -> HexiconScenario:
    """Build a scenario from a TOML table (``[wind]`` sub-table plus run keys)."""
    unknown = set(raw) - _SCEN_KEYS - {"wind"}
    if unknown:
        raise ValueError(f"scenario {name!r}: unknown keys {sorted(unknown)}")
    wind_raw = raw.get("wind", {})
    bad = set(wind_raw) - _WIND_KEYS
    if bad:
        raise ValueError(f"scenario {name!r}: unknown wind keys {sorted(bad)}")
    dur = float(raw.get("duration_s", 300.0))
    wind = WindProfile(**{**wind_raw, "duration_s": max(dur, 1.0)})
    return HexiconScenario(name=name, wind=wind, **{k: raw[k] for k in raw if k != "wind"})


def load_scenarios(path: str | Path | None = None) -> dict[str, HexiconScenario]:
    """Scenarios of ``hil/hexicon/presets/table6.toml`` (or a file of the same layout)."""
    if path is None:
        data = (Path(__file__).parent / "presets" / "table6.toml").read_bytes()
    else:
        data = Path(path).read_bytes()
    raw = tomllib.loads(data.decode("utf-8"))
    return {k: scenario_from_dict(k, v) for k, v in raw.get("scenario", {}).items()}


def initial_state(p: HexiconParams, wind_m_s: float) -> tuple[float, ...]:
    """ψ = 0, r = 0, each turbine at its steady point at θ_r(V) and the torque law."""
    tp = p.turbine
    th = rated_pitch_rad(tp, wind_m_s)
    w, _, _, _ = steady_operating_point(tp, wind_m_s, th)
    q = torque_law_nm(tp, w)
    return (0.0, 0.0, w, th, q, w, th, q, w, th, q)


def measure(x: tuple[float, ...], speed: float, direction: float) -> HexiconMeasurement:
    """Noise-free sample of the plant state (heading, rate, met wind and rotor speeds)."""
    return HexiconMeasurement(x[0], x[1], direction, speed, (x[2], x[5], x[8]))


def truth_sample(
    x: tuple[float, ...],
    speed: float,
    direction: float,
    powers: tuple[float, ...],
    rotor_winds: tuple[float, ...],
) -> HexiconSample:
    """The true values of every sensor channel (:mod:`plant.hexicon.sensors`)."""
    plat = {"heading": x[0], "yaw_rate": x[1], "wind_direction": direction, "wind_speed": speed}
    tur = tuple(
        {
            "rotor_speed": x[2 + 3 * i],
            "pitch": x[3 + 3 * i],
            "power": powers[i],
            "nacelle_wind": rotor_winds[i],
        }
        for i in range(3)
    )
    return HexiconSample(plat, (tur[0], tur[1], tur[2]))


def measurement_of(s: HexiconSample) -> tuple[HexiconMeasurement, float]:
    """The controller's view of a (measured) sample and the measured platform power (W)."""
    pl = s.platform
    m = HexiconMeasurement(
        pl["heading"],
        pl["yaw_rate"],
        pl["wind_direction"],
        pl["wind_speed"],
        (s.turbines[0]["rotor_speed"], s.turbines[1]["rotor_speed"], s.turbines[2]["rotor_speed"]),
    )
    return m, sum(t["power"] for t in s.turbines)


def make_sensors(scn: HexiconScenario, noise: bool = True) -> HexiconSensors:
    """The preset's sensor suite (``noise=False``: perfect sensors)."""
    return HexiconSensors(load_sensor_table(scn.platform) if noise else {})


@dataclass
class RunLog:
    """Per-control-period record of one run (SI units; angles rad)."""

    t: list[float] = field(default_factory=list)
    heading: list[float] = field(default_factory=list)
    yaw_rate: list[float] = field(default_factory=list)
    direction: list[float] = field(default_factory=list)
    speed: list[float] = field(default_factory=list)
    # the met wind speed the controller measured (its pitch floor); empty: noise-free
    speed_measured: list[float] = field(default_factory=list)
    pitch_cmd: list[tuple[float, float, float]] = field(default_factory=list)
    pitch: list[tuple[float, float, float]] = field(default_factory=list)
    power: list[float] = field(default_factory=list)
    wind_factors: list[tuple[float, ...]] = field(default_factory=list)
    solve_s: list[float] = field(default_factory=list)
    overruns: int = 0


class ControllerCore:
    """Either controller behind one ``step(measurement, dt) -> command`` call."""

    def __init__(
        self,
        kind: str,
        design: HexiconDesign,
        period_s: float,
        identified: IdentifiedModel | None = None,
    ) -> None:
        if kind not in CONTROLLERS:
            raise ValueError(f"unknown hexicon controller {kind!r}; expected one of {CONTROLLERS}")
        self.kind = kind
        self.design = design
        self.bb = BangBangState()
        self.mpc = make_mpc(design, MpcConfig(period_s=period_s)) if kind == "mpc" else None
        self.id_mpc = None
        if kind == "mpc_id":
            model = identified if identified is not None else load_identified()
            if abs(model.sample_time_s - period_s) > 1e-9:
                raise ValueError(
                    f"identified model sampled at {model.sample_time_s} s, control period "
                    f"{period_s} s: expected the same"
                )
            self.id_mpc = make_id_mpc(design, model)
        self.last_solve_s = 0.0

    @property
    def overruns(self) -> int:
        if self.id_mpc is not None:
            return self.id_mpc.overruns
        return self.mpc.overruns if self.mpc is not None else 0

    def step(self, m: HexiconMeasurement, dt: float, power_w: float = 0.0) -> HexiconCommand:
        """One control period from a measurement (and the measured platform power, W)."""
        if self.mpc is not None:
            self.mpc, cmd, info = mpc_step(self.mpc, m, dt)
            self.last_solve_s = info["solve_s"]
            return cmd
        if self.id_mpc is not None:
            self.id_mpc, cmd, info = id_mpc_step(self.id_mpc, m, power_w, dt)
            self.last_solve_s = info["solve_s"]
            return cmd
        self.bb, cmd = bang_bang_step(self.bb, m, dt, self.design)
        return cmd


def plant_input(cmd: HexiconCommand, speed: float, direction: float) -> tuple[float, ...]:
    p, q = cmd.pitch_rad, cmd.torque_nm
    return (p[0], q[0], p[1], q[1], p[2], q[2], speed, direction)


def run_in_process(
    scn: HexiconScenario,
    controller: str,
    noise: bool = True,
    identified: IdentifiedModel | None = None,
) -> RunLog:
    """Run a scenario with both cores in this process (see module docstring).

    ``noise``: the controller sees the preset's sensor channels (else the truth).
    """
    p = scn.params()
    design = load_design()
    core = ControllerCore(controller, design, scn.control_period_s, identified)
    sensors = make_sensors(scn, noise)
    wind = scn.wind
    x = initial_state(p, wind.speed_m_s(0.0))
    log = RunLog()
    n_periods = round(scn.duration_s / scn.control_period_s)
    dt = scn.plant_dt_s
    t = 0.0
    prev_cmd = _initial_command(x, p)
    for k in range(n_periods):
        t = k * scn.control_period_s
        v, b = wind.speed_m_s(t), wind.direction_rad(t)
        pre = outputs(t, x, plant_input(prev_cmd, v, b), p)
        truth = truth_sample(x, v, b, pre.powers_w, pre.rotor_winds_m_s)
        meas, power_w = measurement_of(sensors.measure(round(t * 1e9), truth))
        cmd = core.step(meas, scn.control_period_s, power_w)
        prev_cmd = cmd
        u = plant_input(cmd, v, b)
        out = outputs(t, x, u, p)
        _record(log, t, x, v, b, cmd, out.powers_w, out.wind_factors, core.last_solve_s)
        log.speed_measured.append(meas.wind_speed_m_s)
        for j in range(scn.steps_per_period):
            tj = t + j * dt
            u = plant_input(cmd, wind.speed_m_s(tj), wind.direction_rad(tj))
            x = step_rk4(x, u, dt, p)
    log.overruns = core.overruns
    return log


def _initial_command(x: tuple[float, ...], p: HexiconParams) -> HexiconCommand:
    """The command held before the first answer: steady pitch, torque law."""
    q = tuple(torque_law_nm(p.turbine, x[2 + 3 * i]) for i in range(3))
    return HexiconCommand((x[3], x[6], x[9]), (q[0], q[1], q[2]))


def _record(
    log: RunLog,
    t: float,
    x: tuple[float, ...],
    v: float,
    b: float,
    cmd: HexiconCommand,
    powers: tuple[float, ...],
    factors: tuple[float, ...],
    solve_s: float,
) -> None:
    log.t.append(t)
    log.heading.append(x[0])
    log.yaw_rate.append(x[1])
    log.direction.append(b)
    log.speed.append(v)
    log.pitch_cmd.append(cmd.pitch_rad)
    log.pitch.append((x[3], x[6], x[9]))
    log.power.append(sum(powers))
    log.wind_factors.append(factors)
    log.solve_s.append(solve_s)


def wake_free_power_w(p: HexiconParams, speed: float) -> float:
    """3 min(P_rated, η ½ρπR² V³ Cp_max): the platform's power with no wakes and no yaw pitching."""
    tp = p.turbine
    cp_max = float(np.max(tp.table.cp))
    one = tp.generator_efficiency * tp.k_thrust * speed**3 * cp_max
    return 3.0 * min(tp.rated_power_w, one)


def compute_kpis(
    log: RunLog, scn: HexiconScenario, design: HexiconDesign | None = None
) -> dict[str, float]:
    """Review KPIs of one run.

    heading error e = wrap(β - ψ) (deg): RMS, overshoot (the largest error of the opposite sign
    to the initial error, after the first zero crossing; 0 for none), settling time (first time
    after which |e| stays <= 1°; NaN if never); energy ratio ∫P / ∫P_wake-free; pitch travel
    Σ_i Σ_k |Δθ_i| (deg, actual pitch); constraint violations (commanded pitch outside
    [θ_r(V_m) - 0.01°, 25° + 0.01°], counted per turbine and period, V_m the met wind speed
    the controller measured: its constraint; the true speed without a measured one); MPC
    solve time p99 and overruns.
    """
    if not log.t:
        raise ValueError("no platform samples in the run: nothing to review")
    d = design or load_design()
    p = scn.params()
    e = np.degrees(
        np.arctan2(
            np.sin(np.subtract(log.direction, log.heading)),
            np.cos(np.subtract(log.direction, log.heading)),
        )
    )
    t = np.asarray(log.t)
    rms = float(np.sqrt(np.mean(e**2)))
    # overshoot relative to the sign of the first non-negligible error
    nz = np.nonzero(np.abs(e) > 0.1)[0]
    overshoot = 0.0
    if nz.size:
        s = np.sign(e[nz[0]])
        cross = np.nonzero(s * e[nz[0] :] < 0)[0]
        if cross.size:
            overshoot = float(max(0.0, -np.min(s * e[nz[0] + cross[0] :])))
    outside = np.nonzero(np.abs(e) > 1.0)[0]
    if outside.size == 0:
        settle = 0.0
    elif outside[-1] == len(e) - 1:
        settle = float("nan")
    else:
        settle = float(t[outside[-1] + 1])
    free = np.array([wake_free_power_w(p, v) for v in log.speed])
    energy_ratio = float(np.sum(log.power) / max(np.sum(free), 1.0))
    pitch = np.degrees(np.asarray(log.pitch))
    travel = float(np.sum(np.abs(np.diff(pitch, axis=0))))
    cmd = np.degrees(np.asarray(log.pitch_cmd))
    v_floor = log.speed_measured if len(log.speed_measured) == len(log.speed) else log.speed
    floor = np.array([math.degrees(d.rated_pitch_rad(v)) for v in v_floor])
    viol = int(np.sum(cmd < floor[:, None] - 0.01) + np.sum(cmd > d.pitch_max_deg + 0.01))
    solves = np.asarray(log.solve_s)
    return {
        "heading_rms_deg": rms,
        "heading_max_abs_deg": float(np.max(np.abs(e))),
        "overshoot_deg": overshoot,
        "settling_time_s": settle,
        "final_error_deg": float(e[-1]),
        "energy_ratio": energy_ratio,
        "pitch_travel_deg": travel,
        "constraint_violations": float(viol),
        "solve_p99_ms": float(np.percentile(solves, 99) * 1e3) if solves.any() else 0.0,
        "overruns": float(log.overruns),
    }
