"""Trimmed against untrimmed starts: what is left of the start transient, window by window.

Runs the IEA 15 MW on VolturnUS-S in process, 600 s, from the plant's own operating point
(``[initial] trim = false``: optimal tip-speed ratio capped at rated, the platform at the
static equilibrium of *that* point's thrust) and from the controller's trimmed steady state
(``trim = true``, :mod:`hil.inprocess.trim`), and reports the standard deviation of rotor speed,
platform surge and platform pitch over 60-200, 200-400 and 400-600 s, and the first 10 s's
largest rotor-speed deviation from the trim. Cases: steady wind in still water at 5 m/s
(below rated, where the controller's 5 rpm minimum speed is above the optimal-TSR speed),
7.1, 10.3 and 15 m/s (above rated), with the shipped IEA 15 MW scenarios' generator-speed
encoder (2 mrad/s noise, 1 mrad/s resolution) and the other channels' defaults: there the
standard deviations are start transient plus what the sensor noise drives; and the load
cases lc1 (5 m/s) and iea15mw-baseline-15 (15 m/s), turbulent wind and waves, as a campaign
runs them.

Second part: the first 10 s of a trimmed steady-wind, still-water run for each
controller kind (does the controller's own initialisation kick the trimmed plant?).

Fourth: how long a start error of the size turbulence makes anyway is remembered. A
turbulent run's trim is for the mean wind, not the wind at t = 0 (the first 10 s of lc1 and
iea15mw-baseline-15 move the rotor 2.5-5 % off it); the same load case from the trim and
from the trim with the rotor speed 3 % off, per signal the last time the two runs differ by
more than 0.005 rpm, 1 cm of surge, 0.001° of platform pitch, and the last time they differ
by more than a tenth of the signal's own standard deviation in the run (60 s to the end).

Third: how long the start transient lasts with trimmed starts, the basis
of ``[review] settle_s``'s default: steady wind in still water, per signal the time after
which the 20 s moving mean stays within 2 % of the mean of the last 100 s
(``bench/settling.py``'s measure), trimmed and untrimmed.

    python bench/trimmed_start.py [--duration 600] [--quick]

Prints and saves ``bench/results/trimmed_start.json``.

Fifth, ``--table``: the trimmed start per controller kind, turbine and wind (steady wind,
still water, 600 s, the scenario's sensors with the turbine's preset, as ``fowt run``
starts a trimmed run: the plant at the trim, the core from ``trimmed_state`` where it has
one): the largest rotor-speed deviation from the trim over the first 60 s [%] (target
<= 0.5 %), the same over 400-600 s (the steady run's own swing), the same over a 60 s run
with the sensors quiet (no noise or quantisation, as the trim's settling run: the start
itself without the noise's response), and the surge standard deviation over 0-60 s against
400-600 s (target: within 20 %) and over 0-60 s with the sensors quiet; ``--seeds N``
adds the surge std over 0-60 s and over the 60 s windows 400-580 s, and over every 60 s
window of the run, each the mean over N sensor seeds (one seed's 60 s window scatters by a
factor of several). ``--kinds``, ``--turbines`` and ``--winds`` select part of it (the
whole table is 30 runs; ``--merge`` keeps the saved table's other rows)::

    python bench/trimmed_start.py --table --kinds baseline --turbines iea15mw --winds 5,8,11

Saves ``bench/results/trimmed_start_table.json``.

Sixth, ``--noise``: which sensor's noise moves the blades, per controller kind at one wind
(``--winds``, first value; IEA 15 MW, as ``--table``): the same 600 s run with every
channel's noise, with none, and with the noise of one channel only (the others quiet, as
the trim's settling run makes them), each reporting the largest rotor-speed deviation from
the trim over the whole run [%], the blade-pitch and surge standard deviations over
400-600 s [deg, m]::

    python bench/trimmed_start.py --noise --kinds baseline,lqri_ff --winds 15

Saves ``bench/results/trimmed_start_noise.json``.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import time
from typing import Any

import msgspec
import numpy as np
from _common import RESULTS, save

from bus_schemas.registry import TRUTH, WAVE_PREVIEW_PERFECT
from hil.inprocess.run import run_inprocess
from hil.inprocess.trim import (
    initial_condition,
    mean_wind_m_s,
    operating_point,
    settling_scenario,
)
from hil.nodes.controller_node import ControllerRuntime, publishing_step
from hil.scenario.schema import SENSOR_CHANNELS, Scenario, load_scenario, parse_scenario

#: Steady winds [m/s]: 5 (the 5 rpm minimum speed), al-2019 LC2 and LC3's means, 15 (above).
STEADY_WINDS = (5.0, 7.1, 10.3, 15.0)
WINDOWS = ((60.0, 200.0), (200.0, 400.0), (400.0, 600.0))
SIGNALS = ("rotor_speed_rad_s", "platform_surge_m", "platform_pitch_rad", "blade_pitch_rad")

STEADY = """
name = "trim-steady-{wind:g}"
turbine = "iea15mw"
platform = "iea15mw_volturnus"
duration_s = {duration}
[wind]
kind = "steady"
speed_m_s = {wind}
[waves]
kind = "still"
[timing]
control_period_s = 0.025
plant_step_s = 0.0125
[sensors.channels.generator_speed_measured_rad_s]
std = 0.002        # the direct-drive encoder of the shipped iea15mw-* scenarios
resolution = 0.001
[controller]
kind = "baseline"
preset = "iea15mw_baseline"
[initial]
trim = {trim}
"""

#: One shipped scenario per controller kind (and wind region), run steady, still and quiet.
KIND_SCENARIOS = (
    "iea15mw-lc1",
    "iea15mw-baseline-15",
    "iea15mw-lc1-lqri",
    "iea15mw-lqri-15",
    "iea15mw-lc1-lqri-ff",
    "iea15mw-lc2-rosco",
    "nrel5mw-ramp-rosco",
    "oc3-hywind-tp10-lqr2",
    "casanovas-tlp-hs6-u8",
    "casanovas-fixed-u8",
)


#: --table: (turbine, platform, controller preset) per (kind, turbine); None: no preset.
TABLE_CASES: dict[tuple[str, str], tuple[str, str, str] | None] = {
    ("baseline", "iea15mw"): ("iea15mw", "iea15mw_volturnus", "iea15mw_baseline"),
    ("baseline", "nrel5mw"): ("nrel5mw", "nrel5mw_oc3_hywind", "nrel5mw_oc3_hywind_baseline"),
    ("lqri_ff", "iea15mw"): ("iea15mw", "iea15mw_volturnus", "iea15mw_advanced"),
    ("lqri_ff", "nrel5mw"): None,  # no advanced preset for the NREL 5 MW
    ("rosco", "iea15mw"): ("iea15mw", "iea15mw_volturnus", "iea15mw_volturnus"),
    ("rosco", "nrel5mw"): ("nrel5mw", "nrel5mw_oc3_hywind", "nrel5mw"),
}
TABLE_WINDS = (5.0, 8.0, 11.0, 15.0, 20.0)

TABLE_SCENARIO = """
name = "trim-table-{kind}-{turbine}-{wind:g}"
turbine = "{turbine}"
platform = "{platform}"
duration_s = {duration}
[wind]
kind = "steady"
speed_m_s = {wind}
[waves]
kind = "still"
[timing]
control_period_s = 0.025
plant_step_s = 0.0125
[controller]
kind = "{kind}"
preset = "{preset}"
"""


def table_row(
    kind: str, turbine: str, wind: float, duration: float, seeds: int = 1
) -> dict[str, Any]:
    """One --table case: first-60-s rotor deviation and the surge std windows (``seeds`` > 1:
    also their means over that many sensor seeds, :func:`surge_ensemble`)."""
    case = TABLE_CASES[(kind, turbine)]
    if case is None:
        return {"error": "no controller preset of this kind for this turbine"}
    tb, platform, preset = case
    sc = parse_scenario(
        TABLE_SCENARIO.format(
            kind=kind, turbine=tb, platform=platform, preset=preset, wind=wind, duration=duration
        )
    )
    ic = initial_condition(sc)
    assert ic.rotor_speed_rad_s is not None
    s = truth_series(sc)
    t, w, x = s["t"], s["rotor_speed_rad_s"], s["platform_surge_m"]
    first = t < 60.0
    late = (t >= 400.0) & (t < 600.0)
    dev = float(np.max(np.abs(w[first] / ic.rotor_speed_rad_s - 1.0)) * 100.0)
    # the steady run's own swing about the trim, late in the run (no start left in it)
    dev_late = (
        float(np.max(np.abs(w[late] / ic.rotor_speed_rad_s - 1.0)) * 100.0)
        if late.any()
        else math.nan
    )
    s0 = float(np.std(x[first]))
    s1 = float(np.std(x[late])) if late.any() else math.nan
    # the same start with the sensors quiet (the trim's own conditions: no noise, no
    # quantisation), 60 s: what is left of the start itself, without the noise's response
    quiet = with_trim(settling_scenario(sc, 60.0), True)
    q = truth_series(quiet)
    dev_quiet = float(np.max(np.abs(q["rotor_speed_rad_s"] / ic.rotor_speed_rad_s - 1.0)) * 100.0)
    s0_quiet = float(np.std(q["platform_surge_m"][q["t"] < 60.0]))
    ens = surge_ensemble(sc, seeds, (t, x)) if seeds > 1 else {}
    return {
        "trim_rotor_rpm": round(ic.rotor_speed_rad_s * 30.0 / math.pi, 4),
        "rotor_max_dev_0_60_s_percent": round(dev, 3),
        "rotor_max_dev_0_60_s_quiet_percent": round(dev_quiet, 3),
        "rotor_max_dev_400_600_s_percent": round(dev_late, 3),
        "surge_std_0_60_s_m": round(s0, 4),
        "surge_std_0_60_s_quiet_m": round(s0_quiet, 5),
        "surge_std_400_600_s_m": round(s1, 4),
        "surge_std_ratio": round(s0 / s1, 3) if s1 > 0 else None,
        "trimmed_state": bool(s["has_trimmed_state"][0]),
        **ens,
    }


#: --seeds: the late 60 s windows set beside 0-60 s (the same length: a window's std of a
#: ~100 s surge swing depends on how much of one period it holds).
LATE_WINDOWS = ((400.0, 460.0), (460.0, 520.0), (520.0, 580.0))


def surge_ensemble(
    scenario: Scenario, seeds: int, first: tuple[np.ndarray, np.ndarray]
) -> dict[str, Any]:
    """The surge std over 0-60 s and over the late 60 s windows, means over ``seeds`` sensor
    seeds (the scenario's own seed first, ``first`` its run's time and surge; then seeds
    2, 3, ...): one seed's 0-60 s window holds less than one surge period of the noise's
    response, so its std scatters by a factor of several between seeds. Also the ratio's
    standard error (first order, from the two means' own over the seeds), each seed's
    0-60 s figure, and every 60 s window's std over the run, the means over the seeds
    (0-60, 60-120, ... s)."""
    runs = [first]
    for k in range(2, seeds + 1):
        d = msgspec.to_builtins(scenario)
        d.setdefault("sensors", {})["seed"] = k
        s = truth_series(msgspec.convert(d, Scenario))
        runs.append((s["t"], s["platform_surge_m"]))
    early = [float(np.std(x[t < 60.0])) for t, x in runs]
    late = [
        float(np.mean([np.std(x[(t >= a) & (t < b)]) for a, b in LATE_WINDOWS])) for t, x in runs
    ]
    e, lt = float(np.mean(early)), float(np.mean(late))
    # the ratio's standard error from the two means' own (first order; the seeds independent)
    n = len(runs)
    se_e = float(np.std(early, ddof=1)) / math.sqrt(n) if n > 1 else math.nan
    se_l = float(np.std(late, ddof=1)) / math.sqrt(n) if n > 1 else math.nan
    ratio_se = (e / lt) * math.hypot(se_e / e, se_l / lt) if e > 0 and lt > 0 else math.nan
    # every 60 s window of the run, the means over the seeds: is 0-60 s one of them?
    t_end = min(float(t[-1]) for t, _ in runs)
    starts = np.arange(0.0, t_end - 59.0, 60.0)
    windows = [
        round(float(np.mean([np.std(x[(t >= a) & (t < a + 60.0)]) for t, x in runs])), 5)
        for a in starts
    ]
    return {
        "seeds": seeds,
        "surge_std_0_60_s_seeds_m": round(e, 5),
        "surge_std_0_60_s_seeds_range_m": [round(min(early), 5), round(max(early), 5)],
        "surge_std_60_s_windows_400_580_s_seeds_m": round(lt, 5),
        "surge_std_ratio_seeds": round(e / lt, 3) if lt > 0 else None,
        "surge_std_ratio_seeds_standard_error": round(ratio_se, 3)
        if math.isfinite(ratio_se)
        else None,
        "surge_std_0_60_s_per_seed_m": [round(v, 5) for v in early],
        "surge_std_60_s_windows_seeds_m": windows,
    }


def table(args: argparse.Namespace) -> None:
    """``--table`` (module docstring)."""
    t0 = time.perf_counter()
    rows: dict[str, Any] = {}
    if args.merge:  # the saved table's other rows kept (a part re-measured)
        old = RESULTS / "trimmed_start_table.json"
        if old.is_file():
            rows.update(json.loads(old.read_text()).get("rows", {}))
    for kind in args.kinds.split(","):
        for turbine in args.turbines.split(","):
            for wind in (float(v) for v in args.winds.split(",")):
                key = f"{kind}/{turbine}/{wind:g}"
                try:
                    rows[key] = table_row(kind, turbine, wind, args.duration, args.seeds)
                except Exception as exc:  # a case that cannot run here is said, not hidden
                    rows[key] = {"error": f"{type(exc).__name__}: {exc}"}
                print(key, rows[key], flush=True)
    save(
        "trimmed_start_table",
        {
            "command": "python bench/trimmed_start.py --table"
            f" --kinds {args.kinds} --turbines {args.turbines} --winds {args.winds}"
            + (" --merge" if args.merge else "")
            + (f" --seeds {args.seeds}" if args.seeds > 1 else "")
            + (f" --duration {args.duration:g}" if args.duration != 600.0 else ""),
            "duration_s": args.duration,
            "rows": rows,
            "wall_s": round(time.perf_counter() - t0, 1),
        },
    )


def noise(args: argparse.Namespace) -> None:
    """``--noise`` (module docstring)."""
    t0 = time.perf_counter()
    wind = float(args.winds.split(",")[0])
    rows: dict[str, Any] = {}
    for kind in args.kinds.split(","):
        case = TABLE_CASES[(kind, "iea15mw")]
        assert case is not None
        tb, platform, preset = case
        sc = parse_scenario(
            TABLE_SCENARIO.format(
                kind=kind, turbine=tb, platform=platform, preset=preset, wind=wind,
                duration=args.duration,
            )
        )  # fmt: skip
        ic = initial_condition(sc)
        assert ic.rotor_speed_rad_s is not None
        variants = [("all", SENSOR_CHANNELS), ("none", ())]
        variants += [(c, (c,)) for c in SENSOR_CHANNELS]
        for name, noisy in variants:
            s = truth_series(_quiet_except(sc, set(noisy)))
            late = (s["t"] >= 400.0) & (s["t"] < 600.0)
            rows[f"{kind}/{name}"] = {
                "rotor_max_dev_percent": round(
                    float(np.max(np.abs(s["rotor_speed_rad_s"] / ic.rotor_speed_rad_s - 1.0)))
                    * 100.0,
                    3,
                ),
                "blade_pitch_std_400_600_s_deg": round(
                    float(np.degrees(np.std(s["blade_pitch_rad"][late]))), 4
                ),
                "surge_std_400_600_s_m": round(float(np.std(s["platform_surge_m"][late])), 4),
            }
            print(kind, name, rows[f"{kind}/{name}"], flush=True)
    save(
        "trimmed_start_noise",
        {
            "command": f"python bench/trimmed_start.py --noise --kinds {args.kinds}"
            f" --winds {wind:g}",
            "wind_m_s": wind,
            "duration_s": args.duration,
            "rows": rows,
            "wall_s": round(time.perf_counter() - t0, 1),
        },
    )


def _quiet_except(scenario: Scenario, noisy: set[str]) -> Scenario:
    """``scenario`` with every sensor channel but ``noisy`` without noise, quantisation or
    dropouts (biases and delays kept, as the trim's settling run)."""
    d = msgspec.to_builtins(scenario)
    channels = d.setdefault("sensors", {}).setdefault("channels", {})
    for name in SENSOR_CHANNELS:
        if name not in noisy:
            quiet = {"std": 0.0, "resolution": 0.0, "dropout_probability": 0.0}
            channels[name] = {**channels.get(name, {}), **quiet}
    return msgspec.convert(d, Scenario)


def steady(wind: float, trim: bool, *, duration: float) -> Scenario:
    """IEA 15 MW, steady ``wind`` m/s, still water, baseline controller."""
    return parse_scenario(STEADY.format(wind=wind, duration=duration, trim=str(trim).lower()))


def with_trim(scenario: Scenario, trim: bool) -> Scenario:
    """``scenario`` with ``[initial] trim`` set."""
    d = msgspec.to_builtins(scenario)
    d["initial"] = {"trim": trim}
    return msgspec.convert(d, Scenario)


def truth_series(scenario: Scenario) -> dict[str, np.ndarray]:
    """Run ``scenario`` in process as ``fowt run`` does; the truth signals over time."""
    runtime = ControllerRuntime(
        scenario, paced=False, operating_point=functools.partial(operating_point, scenario)
    )
    rows: list[tuple[float, ...]] = []

    def publish(mt: object, msg: Any) -> None:
        if mt is TRUTH:
            rows.append((msg.sample_time_ns * 1e-9, *(getattr(msg, s) for s in SIGNALS)))
        elif mt is WAVE_PREVIEW_PERFECT:
            runtime.handle_preview(msg)

    run_inprocess(scenario, publish, publishing_step(runtime, publish), runtime=runtime)
    a = np.array(rows)
    has_trim = callable(getattr(runtime.controller, "trimmed_state", None))
    return {
        "t": a[:, 0],
        **{s: a[:, i + 1] for i, s in enumerate(SIGNALS)},
        "has_trimmed_state": np.array([has_trim]),
    }


def window_std(series: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """Standard deviation of each signal per window (rotor in rpm, pitch in deg)."""
    t = series["t"]
    scale = {"rotor_speed_rad_s": 30.0 / math.pi, "platform_pitch_rad": 180 / math.pi}
    out: dict[str, dict[str, float]] = {}
    for s in SIGNALS[:3]:
        name = {"rotor_speed_rad_s": "rotor_rpm", "platform_pitch_rad": "pitch_deg"}.get(
            s, "surge_m"
        )
        k = scale.get(s, 1.0)
        out[name] = {
            f"{a:g}-{b:g}": round(float(np.std(series[s][(t >= a) & (t < b)]) * k), 4)
            for a, b in WINDOWS
            if t[-1] >= b - 1.0
        }
    return out


def first_seconds(series: dict[str, np.ndarray], seconds: float = 10.0) -> dict[str, float]:
    """Largest deviation from the t = 0 value in the first ``seconds``: rotor [rpm and %],
    blade pitch [deg], surge [m]."""
    t = series["t"]
    m = t <= seconds
    w = series["rotor_speed_rad_s"][m]
    pitch = series["blade_pitch_rad"][m]
    return {
        "rotor_start_rpm": round(float(w[0] * 30 / math.pi), 4),
        "rotor_max_dev_rpm": round(float(np.max(np.abs(w - w[0])) * 30 / math.pi), 5),
        "rotor_max_dev_percent": round(float(np.max(np.abs(w - w[0])) / w[0] * 100), 4),
        "blade_pitch_max_dev_deg": round(
            float(np.degrees(np.max(np.abs(pitch - pitch[0])))),
            4,
        ),
        "surge_max_dev_m": round(
            float(np.max(np.abs(series["platform_surge_m"][m] - series["platform_surge_m"][0]))), 4
        ),
    }


def settling_s(t: np.ndarray, x: np.ndarray, window_s: float = 20.0, band: float = 0.02) -> float:
    """First time after which the ``window_s`` moving mean stays within ``band`` of the mean
    of the last 100 s (relative; ``bench/settling.py``), the window's end time [s]."""
    dt = float(np.median(np.diff(t)))
    w = max(1, round(window_s / dt))
    ma = np.convolve(x, np.ones(w) / w, mode="valid")
    tm = t[w - 1 :]
    final = float(x[t > t[-1] - 100.0].mean())
    out = np.flatnonzero(np.abs(ma - final) > band * abs(final))
    return float(tm[out[-1] + 1]) if out.size and out[-1] + 1 < tm.size else float(tm[0])


#: Differences below which two runs count as the same (rotor 0.1 % of 5 rpm; 1 cm; 0.001°).
MEMORY_TOL = {
    "rotor_speed_rad_s": 0.001 * 5.0 * math.pi / 30.0,
    "platform_surge_m": 0.01,
    "platform_pitch_rad": math.radians(0.001),
}


def last_above(t: np.ndarray, x: np.ndarray, tol: float) -> float:
    """The last time ``x`` exceeds ``tol`` [s] (0: never)."""
    out = np.flatnonzero(x > tol)
    return float(t[out[-1]]) if out.size else 0.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--quick", action="store_true", help="steady cases only, no load cases")
    ap.add_argument("--table", action="store_true", help="the per-kind start table only")
    ap.add_argument("--noise", action="store_true", help="which sensor's noise moves the blades")
    ap.add_argument("--kinds", default="baseline,lqri_ff,rosco")
    ap.add_argument("--turbines", default="iea15mw,nrel5mw")
    ap.add_argument("--winds", default=",".join(f"{w:g}" for w in TABLE_WINDS))
    ap.add_argument(
        "--merge", action="store_true", help="--table: keep the saved table's other rows"
    )
    ap.add_argument(
        "--seeds", type=int, default=1, help="--table: surge std means over this many seeds"
    )
    args = ap.parse_args()
    if args.table:
        table(args)
        return
    if args.noise:
        noise(args)
        return
    t0 = time.perf_counter()
    cases: dict[str, Any] = {}
    for label, make in (
        *(
            (f"steady-{w:g}-still", functools.partial(steady, w, duration=args.duration))
            for w in STEADY_WINDS
        ),
        *(
            ()
            if args.quick
            else (
                ("lc1", lambda trim: with_trim(load_scenario("iea15mw-lc1"), trim)),
                ("baseline-15", lambda trim: with_trim(load_scenario("iea15mw-baseline-15"), trim)),
            )
        ),
    ):
        row: dict[str, Any] = {}
        for trim in (False, True):
            sc = make(trim).with_duration(args.duration)
            ic = initial_condition(sc)
            s = truth_series(sc)
            key = "trimmed" if trim else "untrimmed"
            row[key] = {
                "start": {
                    "rotor_rpm": round(float(s["rotor_speed_rad_s"][0] * 30 / math.pi), 4),
                    "blade_pitch_deg": round(float(np.degrees(s["blade_pitch_rad"][0])), 4),
                    "surge_m": round(float(s["platform_surge_m"][0]), 4),
                    "pitch_deg": round(float(np.degrees(s["platform_pitch_rad"][0])), 4),
                    "initial_condition": {k: v for k, v in ic.__dict__.items() if v is not None},
                },
                "std": window_std(s),
                "first_10_s": first_seconds(s),
            }
            if label.startswith("steady"):
                row[key]["settling_s"] = {
                    sig: round(settling_s(s["t"], s[sig]), 1) for sig in SIGNALS[:3]
                }
            print(label, key, row[key])
        cases[label] = row
    memory: dict[str, Any] = {}
    for name in ("iea15mw-lc1", "iea15mw-baseline-15"):
        sc = with_trim(load_scenario(name), True).with_duration(args.duration)
        ic = initial_condition(sc)
        assert ic.rotor_speed_rad_s is not None
        rpm = ic.rotor_speed_rad_s * 30.0 / math.pi
        a = truth_series(sc)
        memory[name] = {}
        for rel in (0.03, -0.03):
            d = msgspec.to_builtins(sc)
            d["initial"] = {"trim": True, "rotor_speed_rpm": rpm * (1.0 + rel)}
            b = truth_series(msgspec.convert(d, Scenario))
            late = a["t"] >= 60.0
            memory[name][f"rotor{rel:+.0%}"] = {
                sig: {
                    "below_tolerance_after_s": round(
                        last_above(a["t"], np.abs(b[sig] - a[sig]), tol), 1
                    ),
                    # the run's own variability: std of the trimmed run over 60 s - end
                    "below_10_percent_of_std_after_s": round(
                        last_above(
                            a["t"], np.abs(b[sig] - a[sig]), 0.1 * float(np.std(a[sig][late]))
                        ),
                        1,
                    ),
                }
                for sig, tol in MEMORY_TOL.items()
            }
        print("memory", name, memory[name])
    kinds: dict[str, Any] = {}
    for name in KIND_SCENARIOS:
        base = load_scenario(name)
        sc = with_trim(settling_scenario(base, 30.0), True)
        try:
            s = truth_series(sc)
        except Exception as exc:  # a kind that cannot run here is said, not hidden
            kinds[name] = {"error": f"{type(exc).__name__}: {exc}"}
            continue
        kinds[name] = {
            "kind": base.controller.kind,
            "wind_m_s": mean_wind_m_s(base.wind),
            **first_seconds(s),
        }
        print("kind", name, kinds[name])
    save(
        "trimmed_start",
        {
            "command": "python bench/trimmed_start.py"
            + (f" --duration {args.duration:g}" if args.duration != 600.0 else "")
            + (" --quick" if args.quick else ""),
            "duration_s": args.duration,
            "windows_s": [list(w) for w in WINDOWS],
            "cases": cases,
            "first_10_s_by_kind": kinds,
            "start_error_memory_s": memory,
            "memory_tolerances": {
                "rotor_rpm": 0.005,
                "surge_m": 0.01,
                "pitch_deg": 0.001,
            },
            "wall_s": round(time.perf_counter() - t0, 1),
        },
    )


if __name__ == "__main__":
    main()
