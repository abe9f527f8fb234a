"""Free-decay periods of the OC3-Hywind and OC4-DeepCwind platforms, and closed-loop damping.

Usage::

    .venv/bin/python bench/free_decay.py [--panel 2.0] [--n-theta 16] [--n-omega 60]
        [--skip-oc4] [--oc4-preset TOML] [--skip-closed-loop] [--only decay|closed-loop]
        [--radiation-omega-max W]

1. **Free decay** (``fowt analyze decay``, :func:`plant.decay.free_decay`: the time-domain
   plant parked in still air and still water, rotor aerodynamics off) of the shipped OC3 preset
   and of the OC4-DeepCwind deck written by :func:`plant.reference_decks.write_deck` (OpenFAST
   4 layout, capytaine hydrodynamics of the columns as in ``bench/openfast_import_periods.py``)
   and imported unedited with ``fowt preset import-openfast`` (the importer's default radiation
   fit; ``--radiation-omega-max`` passes the option on), or an OC4 preset imported earlier
   (``--oc4-preset``). Surge, heave and pitch from a small offset (1 m, 0.5 m, 0.5 deg) and a
   large one (20 m, 5 m, 8 deg): first-cycle period, mean period, damping ratio, beside the
   linear periods (``fowt analyze modes --wind 0``) and the published ones (OC3: Jonkman 2010,
   NREL/TP-500-47535; OC4: Robertson et al. 2014, NREL/TP-5000-60601). The decay offsets of the
   code comparisons are not in the reference data here: 20 m / 5 m / 8 deg are chosen as sizes
   of that order, and the surge period is also given over 1-25 m.
2. **OC4 surge budget**: the WAMIT surge added mass A₁₁(ω) at zero and infinite frequency,
   at 2π/107 s and at the decay's own frequency; the mooring's tangent stiffness at 0-20 m;
   the periods without radiation memory (A₁₁(∞) alone).
3. **Closed loop** (IEA 15 MW VolturnUS-S, saved apart as ``free_decay_closed_loop``):
   ``fowt analyze closed-loop`` for the baseline, LQRI + wave FF and ROSCO at 5, 8, 11, 15,
   20 m/s (surge 2 m, pitch 1 deg); the baseline's surge released from 0.5 m and 2 m at 11
   and 15 m/s over 1500 s (the damping per cycle against the amplitude); the steady thrust's
   slope along the trimmed operating curve and the quasi-steady surge damping it gives; and a
   900 s in-process run of ``iea15mw-still-water`` in steady 11 m/s with the scenario's
   sensor noise (trimmed start): the surge standard deviation over 0-60, 60-200, 200-400 and
   400-900 s.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import save

ROOT = Path(__file__).resolve().parent.parent

PUBLISHED = {
    "oc3": {"surge": 1 / 0.0080, "heave": 1 / 0.0324, "pitch": 1 / 0.0343},
    "oc4": {"surge": 107.0, "heave": 17.5, "pitch": 26.8},
}
SOURCES = {
    "oc3": "Jonkman (2010), NREL/TP-500-47535, full-system natural frequencies (Hz inverted)",
    "oc4": "Robertson et al. (2014), NREL/TP-5000-60601, full-system natural periods",
}
SMALL = {"surge": 1.0, "heave": 0.5, "pitch": 0.5}
LARGE = {"surge": 20.0, "heave": 5.0, "pitch": 8.0}
SURGE_OFFSETS = (1.0, 5.0, 10.0, 15.0, 20.0, 25.0)
WINDS = "5,8,11,15,20"
WINDOWS_S = ((0.0, 60.0), (60.0, 200.0), (200.0, 400.0), (400.0, 900.0))


def _fowt(*args: str) -> str:
    """Run the ``fowt`` command line of this checkout; its stdout (raises on failure)."""
    done = subprocess.run(
        [sys.executable, "-m", "hil", *args], cwd=ROOT, capture_output=True, text=True, check=False
    )
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(args[:2])} failed:\n{done.stdout}\n{done.stderr}")
    return done.stdout


def _decays(preset: str, platform: str) -> dict[str, Any]:
    """Small and large decays of each DOF, the linear and published periods."""
    linear = json.loads(_fowt("analyze", "modes", preset, "--wind", "0", "--json"))
    lin = {m["name"]: m for m in linear["modes"]}
    table: dict[str, Any] = {}
    for dof in ("surge", "heave", "pitch"):
        row: dict[str, Any] = {
            "linear_period_s": round(lin[dof]["period_s"], 3),
            "linear_damping_ratio": round(lin[dof]["damping_ratio"], 5),
            "published_s": round(PUBLISHED[platform][dof], 2),
        }
        for size, offsets in (("small", SMALL), ("large", LARGE)):
            out = json.loads(
                _fowt("analyze", "decay", preset, "--dof", dof, "--offset", str(offsets[dof]),
                      "--json")
            )  # fmt: skip
            row[size] = {
                "offset": offsets[dof],
                "unit": out["unit"],
                "period_s": out["period_s"],
                "mean_period_s": out["mean_period_s"],
                "damping_ratio": out["damping_ratio"],
                "cycles": len(out["cycles"]),
                "deviation_from_published_pct": round(
                    100.0 * (out["period_s"] / PUBLISHED[platform][dof] - 1.0), 2
                )
                if out["period_s"]
                else None,
            }
        print(f"{platform} {dof}: {json.dumps(row)}", flush=True)
        table[dof] = row
    return table


def _surge_budget(preset: str) -> dict[str, Any]:
    """OC4 surge: added mass at several frequencies, tangent stiffness and period by offset."""
    from plant.decay import free_decay
    from plant.hydro.wamit import HydroData
    from plant.platform import load_floating, read_floating_preset

    p, base, _ = read_floating_preset(preset)
    hydro = HydroData.load_npz((base or Path(".")) / p.hydro_file)
    rad = hydro.radiation
    i = hydro.dofs.index(0)
    w = np.asarray(rad.omega_rad_s, dtype=np.float64)
    a11 = np.asarray(rad.added_mass[:, i, i], dtype=np.float64)
    fp = load_floating(preset, radiation=False)
    moor = fp.mooring
    by_offset = []
    for x in SURGE_OFFSETS:
        res = free_decay(preset, "surge", x, 900.0)
        memory_free = free_decay(preset, "surge", x, 900.0, radiation=False)
        by_offset.append(
            {
                "offset_m": x,
                "tangent_stiffness_n_m": round(moor.stiffness_at(x), 1),
                "period_s": round(res.period_s, 3),
                "period_without_memory_s": round(memory_free.period_s, 3),
                "damping_ratio": round(res.damping_ratio, 5),
            }
        )
        print(f"oc4 surge from {x} m: {by_offset[-1]}", flush=True)
    t_small = by_offset[0]["period_s"]
    a_members = float(p.member_added_mass[0][0]) if p.member_added_mass else 0.0
    return {
        "omega_range_rad_s": [round(float(w[0]), 4), round(float(w[-1]), 4)],
        "added_mass_surge_kg": {
            "lowest_frequency": round(float(a11[0]), 1),
            "at_2pi_over_107s": round(float(np.interp(2 * math.pi / 107.0, w, a11)), 1),
            "at_small_decay_frequency": round(float(np.interp(2 * math.pi / t_small, w, a11)), 1),
            "infinite_frequency": round(float(rad.added_mass_inf[i, i]), 1),
        },
        "members_added_mass_surge_kg": round(a_members, 1),
        "mass_matrix_surge_kg_with_a_inf": round(float(fp.mass_matrix[0, 0]), 1),
        "surge_by_offset": by_offset,
    }


def _oc4(args: argparse.Namespace, tmp: Path) -> tuple[str, str]:
    """Write and import the OC4 deck; the preset path and the hydrodynamics' description."""
    from plant.reference_decks import oc4_hydro, write_deck

    hydro, desc = oc4_hydro(n_omega=args.n_omega, panel_m=args.panel, n_theta=args.n_theta)
    print(f"OC4 hydrodynamics: {desc}", flush=True)
    fst = write_deck(tmp / "deck", "oc4", "openfast4", hydro)
    extra = (
        []
        if args.radiation_omega_max is None
        else ["--radiation-omega-max", str(args.radiation_omega_max)]
    )
    print(_fowt("preset", "import-openfast", str(fst), "--out", str(tmp / "oc4"), "--name",
                "oc4", "--turbine", "nrel5mw", *extra))  # fmt: skip
    return str(tmp / "oc4" / "oc4.toml"), desc


def _growth_at_11() -> dict[str, Any]:
    """Baseline at steady 11 m/s with noise, 900 s in process: surge std per window."""
    import msgspec

    from bus_schemas.registry import TRUTH, WAVE_PREVIEW_PERFECT
    from hil.inprocess.run import run_inprocess
    from hil.inprocess.trim import operating_point
    from hil.nodes.controller_node import ControllerRuntime, publishing_step
    from hil.scenario.schema import Scenario, load_scenario

    sc = load_scenario("iea15mw-still-water")
    d = msgspec.to_builtins(sc)
    d["wind"] = {"kind": "steady", "speed_m_s": 11.0}
    d["waves"] = {"kind": "still", "gauge_distance_m": 450.0}
    d["duration_s"] = 900.0
    d["initial"] = {"trim": True}
    noisy = msgspec.convert(d, Scenario)
    runtime = ControllerRuntime(noisy, paced=False, operating_point=lambda: operating_point(noisy))
    rows: list[tuple[float, float]] = []

    def publish(mt: object, msg: Any) -> None:
        if mt is TRUTH:
            rows.append((msg.sample_time_ns * 1e-9, msg.platform_surge_m))
        elif mt is WAVE_PREVIEW_PERFECT:
            runtime.handle_preview(msg)

    run_inprocess(noisy, publish, publishing_step(runtime, publish))
    a = np.array(rows)
    t = a[:, 0] - a[0, 0]
    out = {}
    for lo, hi in WINDOWS_S:
        sel = (t >= lo) & (t < hi)
        out[f"{lo:g}-{hi:g} s"] = round(float(np.std(a[sel, 1])), 4)
    return {
        "scenario": "iea15mw-still-water, wind steady 11 m/s, still water, trimmed, its "
        "sensor noise (seed 2), 900 s in process",
        "surge_std_m": out,
        "surge_mean_m": round(float(np.mean(a[:, 1])), 3),
    }


def _thrust_slope() -> dict[str, Any]:
    """The steady thrust's slope dT/dU along the baseline's trimmed operating curve of the
    IEA 15 MW (central difference over ±0.25 m/s of the trims), the mooring's tangent surge
    stiffness at the trimmed offset, and the quasi-steady surge damping ratio it gives,
    ζ_aero = (dT/dU) ω / (2 k) with ω = 2π / 100 s: the thrust of a controller that holds its
    operating curve while the relative wind varies slowly with the surge velocity."""
    from hil.inprocess.closed_loop import quiet_steady
    from hil.inprocess.trim import initial_condition
    from hil.nodes.plant_node import plant_spec
    from hil.scenario.schema import load_scenario
    from plant.build import build_plant
    from plant.platform import relative_wind, rotor_thrust
    from plant.simulator import PlantSimulator

    sc = load_scenario("iea15mw-still-water")
    out: dict[str, Any] = {}
    for u in (8.0, 11.0, 15.0, 20.0):
        pts = []
        for du in (-0.25, 0.25):
            q = quiet_steady(sc, u + du, 60.0)
            sim = PlantSimulator(build_plant(plant_spec(q, initial_condition(q))))
            x = sim.initial_state()
            assert sim.floating is not None
            fp = sim.floating.params
            u_n = relative_wind(x, u + du, fp)
            pts.append((rotor_thrust(x[8], x[9], u_n, fp.turbine), x[0]))
        slope = (pts[1][0] - pts[0][0]) / 0.5
        k = fp.mooring.stiffness_at(0.5 * (pts[0][1] + pts[1][1]))
        w = 2.0 * math.pi / 100.0
        out[f"{u:g} m/s"] = {
            "thrust_slope_n_s_m": round(slope, 1),
            "trimmed_surge_m": round(0.5 * (pts[0][1] + pts[1][1]), 3),
            "tangent_stiffness_n_m": round(k, 1),
            "quasi_steady_aero_damping_ratio": round(slope * w / (2.0 * k), 4),
        }
    return out


def _small_releases() -> dict[str, Any]:
    """Baseline, surge released from 0.5 m and 2 m at 11 and 15 m/s, 1500 s: per cycle."""
    out: dict[str, Any] = {}
    for u in (11.0, 15.0):
        for off in (0.5, 2.0):
            r = json.loads(
                _fowt("analyze", "closed-loop", "--controller", "baseline", "--winds", str(u),
                      "--dof", "surge", "--surge-offset", str(off), "--duration", "1500",
                      "--json")
            )["modes"][0]  # fmt: skip
            out[f"{u:g} m/s from {off:g} m"] = [
                {"amplitude_m": round(c["amplitude"], 3), "period_s": round(c["period_s"], 2),
                 "damping_ratio": round(c["damping_ratio"], 5)}
                for c in r["cycles"]
            ]  # fmt: skip
            print(f"baseline {u} m/s from {off} m: {out[f'{u:g} m/s from {off:g} m']}", flush=True)
    return out


def _decay_part(args: argparse.Namespace) -> dict[str, Any] | None:
    result: dict[str, Any] = {
        "decay_command": "fowt analyze decay PRESET --dof DOF --offset X --json",
        "linear_command": "fowt analyze modes PRESET --wind 0 --json",
        "case": "parked in still air and still water, rotor aerodynamics off (decks: "
        "CompAero = 0); nonlinear mooring table, radiation memory, quadratic drag",
        "published_sources": SOURCES,
        "platforms": {"oc3": {"preset": "nrel5mw_oc3_hywind"}},
    }
    result["platforms"]["oc3"]["decays"] = _decays("nrel5mw_oc3_hywind", "oc3")
    how = (
        "the importer's default radiation fit"
        if args.radiation_omega_max is None
        else f"--radiation-omega-max {args.radiation_omega_max:g}"
    )
    bem = (
        f"capytaine of the columns, plant.reference_decks.oc4_hydro with {args.n_omega} "
        f"frequencies 0.05..3 rad/s, panel {args.panel:g} m, {args.n_theta} around a column"
    )
    if args.skip_oc4:
        return result
    if args.oc4_preset is not None:
        toml = str(args.oc4_preset)
        result["platforms"]["oc4"] = {
            "preset": "OC4-DeepCwind deck of plant.reference_decks (openfast4), imported "
            f"earlier (--oc4-preset) with {how}",
            "hydrodynamics": bem,
            "decays": _decays(toml, "oc4"),
            "surge_budget": _surge_budget(toml),
        }
        return result
    try:
        import capytaine  # noqa: F401
    except ImportError:
        print("needs the [hydro] extra (capytaine) for the OC4 deck", file=sys.stderr)
        return None
    with tempfile.TemporaryDirectory() as tmp:
        toml, desc = _oc4(args, Path(tmp))
        result["platforms"]["oc4"] = {
            "preset": "OC4-DeepCwind deck of plant.reference_decks (openfast4), imported "
            f"with {how}",
            "hydrodynamics": desc,
            "decays": _decays(toml, "oc4"),
            "surge_budget": _surge_budget(toml),
        }
    return result


def _closed_loop_part() -> dict[str, Any]:
    closed: dict[str, Any] = {}
    for kind in ("baseline", "lqri_ff", "rosco"):
        out = json.loads(
            _fowt("analyze", "closed-loop", "--controller", kind, "--winds", WINDS, "--json")
        )
        closed[kind] = [
            {k: r[k] for k in ("wind_m_s", "dof", "offset", "period_s", "damping_ratio",
                               "open_loop_period_s", "open_loop_damping_ratio")}
            | {"cycles": len(r["cycles"])}
            for r in out["modes"]
        ]  # fmt: skip
        print(f"closed loop {kind}: {json.dumps(closed[kind])}", flush=True)
    return {
        "command": f"fowt analyze closed-loop --controller KIND --winds {WINDS} --json",
        "modes": closed,
        "baseline_surge_small_releases": _small_releases(),
        "thrust_slope": _thrust_slope(),
        "growth_at_11_m_s": _growth_at_11(),
    }


def main() -> int:
    """Command line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--panel", type=float, default=2.0, help="OC4 BEM panel length, m")
    p.add_argument("--n-theta", type=int, default=16, help="OC4 BEM panels around a column")
    p.add_argument("--n-omega", type=int, default=60, help="OC4 BEM frequencies 0.05..3 rad/s")
    p.add_argument(
        "--radiation-omega-max",
        type=float,
        default=None,
        help="import option, rad/s (default: the importer's own)",
    )
    p.add_argument(
        "--only",
        choices=("decay", "closed-loop"),
        default=None,
        help="one part (saved as free_decay or free_decay_closed_loop)",
    )
    p.add_argument("--skip-oc4", action="store_true", help="no OC4 (needs capytaine)")
    p.add_argument(
        "--oc4-preset",
        type=Path,
        default=None,
        help="an OC4 preset already imported from this deck (skips the BEM run)",
    )
    p.add_argument("--skip-closed-loop", action="store_true", help="no closed-loop part")
    args = p.parse_args()
    if args.only != "closed-loop":
        decay = _decay_part(args)
        if decay is None:
            return 2
        save("free_decay", decay)
    if args.only != "decay" and not args.skip_closed_loop:
        save("free_decay_closed_loop", _closed_loop_part())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
