"""christiansen-2013's case over many seed pairs: each KPI change with its spread across seeds.

The shipped case (``bench/christiansen_case.py``) is one turbulent-wind / irregular-sea seed
pair; the change of a KPI against the detuned baseline depends on that pair (platform pitch
at Tp 5 s: from -2 % to -45 % over a few pairs). This bench reruns the nine scenarios
``oc3-hywind-tp{2,5,10}-{baseline,lqr1,lqr2}`` in process for ``--pairs`` seed pairs
(pair k: wind and sensor seed 13 + k, wave seed 113 + k; pair 0 is the shipped one) and
reports, per peak period, controller and KPI, the mean of the per-pair percent change
against the baseline of the same pair, its standard deviation across pairs and the standard
error of the mean (std / sqrt(n)), with the minimum and maximum.

Controllers: the shipped ``lqr1``/``lqr2`` designs (the seed's Bryson weights plus this
project's rotor-speed weight, ``controller/design/lqr_wave.py``) and, with ``--published``,
the same variants designed with the seed's published weights alone
(``rotor_speed_max_rad_s = 0``: ``lqr1_pub``/``lqr2_pub``), designed once into a temporary
folder. ``--decoupled`` adds ``lqr2_dec``: LQR2 designed on the model without the
surge-pitch coupling (the seed's model, :class:`controller.design.lqr_wave.SparModel`),
run on the full plant.

KPIs (statistics after ``SETTLE_S``, truth channel, as ``christiansen_case.py``): standard
deviation of platform pitch, electrical power, tower-top fore-aft deflection and rotor speed,
blade-pitch travel ∫|β̇|dt, mean electrical power. Saves
``bench/results/christiansen_seeds_statistics.json`` (partial results after every pair in
``christiansen_seeds_statistics.partial.json`` beside it, removed at the end).

    python bench/christiansen_seeds.py [--pairs 10] [--periods 2 5 10] [--published]
        [--decoupled] [--workers 1] [--duration 600] [--reuse RESULT.json ...] [--name STEM]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench._common import RESULTS, load, save

SETTLE_S = 60.0
CONTROL_PERIOD_S = 0.1
#: Variant -> (scenario controller, design settings overrides or None for the shipped design).
VARIANTS: dict[str, tuple[str, dict[str, Any] | None]] = {
    "baseline": ("baseline", None),
    "lqr1": ("lqr1", None),
    "lqr2": ("lqr2", None),
    "lqr1_pub": ("lqr1", {"variant": "lqr1", "rotor_speed_max_rad_s": 0.0}),
    "lqr2_pub": ("lqr2", {"variant": "lqr2", "rotor_speed_max_rad_s": 0.0}),
    "lqr2_dec": ("lqr2", {"variant": "lqr2", "decoupled": True}),
}
KPIS = (
    "platform_pitch_std_deg",
    "pitch_travel_deg",
    "electrical_power_std_w",
    "tower_fore_aft_std_m",
    "rotor_speed_std_rad_s",
    "electrical_power_mean_w",
)


def seeds(pair: int) -> tuple[int, int, int]:
    """(wind, wave, sensor) seeds of pair ``pair`` (pair 0: the shipped scenarios')."""
    return 13 + pair, 113 + pair, 13 + pair


def design_variant(name: str, overrides: dict[str, Any], folder: Path) -> Path:
    """Design a variant's gain table into ``folder``; return an lqr_wave preset TOML using it."""
    from controller.design.lqr_wave import LqrWaveSettings, design_lqr_wave

    npz = design_lqr_wave(
        "nrel5mw_oc3_hywind",
        CONTROL_PERIOD_S,
        LqrWaveSettings(**overrides),
        out_dir=folder / name,
        provenance={"bench_variant": name},
    )
    shipped = resources.files("controller.presets")
    text = (shipped / f"nrel5mw_oc3_hywind_{overrides['variant']}.toml").read_text()
    lines = []
    for line in text.splitlines():
        if line.startswith("design ="):
            lines.append(f"design = {json.dumps(str(npz))}")
        elif line.startswith("name ="):
            lines.append(f'name = "nrel5mw_oc3_hywind_{name}"')
        else:
            lines.append(line)
    with resources.as_file(shipped) as shipped_dir:
        lines.insert(lines.index("[ekf]"), f"preset_dir = {json.dumps(str(shipped_dir))}")
    toml = folder / f"{name}.toml"
    toml.write_text("\n".join(lines) + "\n")
    return toml


def measures(truth: list[Any]) -> dict[str, float]:
    """The seed's measures of one run (after ``SETTLE_S``)."""
    t = np.array([m.sample_time_ns for m in truth], dtype=np.float64) * 1e-9
    keep = t >= SETTLE_S

    def col(name: str) -> np.ndarray:
        return np.array([getattr(m, name) for m in truth], dtype=np.float64)[keep]

    pitch = col("blade_pitch_rad")
    return {
        "platform_pitch_std_deg": float(np.degrees(col("platform_pitch_rad").std())),
        "pitch_travel_deg": float(np.degrees(np.abs(np.diff(pitch)).sum())),
        "electrical_power_std_w": float(col("electrical_power_w").std()),
        "tower_fore_aft_std_m": float(col("tower_top_displacement_m").std()),
        "rotor_speed_std_rad_s": float(col("rotor_speed_rad_s").std()),
        "electrical_power_mean_w": float(col("electrical_power_w").mean()),
    }


def run_one(job: tuple[int, int, str, str | None, float]) -> tuple[int, int, str, dict[str, float]]:
    """One in-process run: (pair, Tp, variant, preset TOML or None, duration) -> measures."""
    import msgspec

    from bus_schemas.registry import TRUTH
    from hil.inprocess.run import run_inprocess
    from hil.nodes.controller_node import ControllerRuntime
    from hil.scenario.schema import load_scenario

    pair, tp, variant, preset, duration = job
    sc = load_scenario(f"oc3-hywind-tp{tp}-{VARIANTS[variant][0]}").with_duration(duration)
    w, wv, s = seeds(pair)
    rep = msgspec.structs.replace
    assert sc.waves is not None
    sc = rep(
        sc,
        wind=rep(sc.wind, seed=w),
        waves=rep(sc.waves, seed=wv),
        sensors=rep(sc.sensors, seed=s),
    )
    if preset is not None:
        sc = rep(sc, controller=rep(sc.controller, preset=preset))
    runtime = ControllerRuntime(sc)
    truth: list[Any] = []

    def publish(mt: Any, msg: Any) -> None:
        if mt is TRUTH:
            truth.append(msg)

    def step(frame: Any) -> Any:
        result = runtime.handle_frame(frame)
        return None if result is None else result[0]

    run_inprocess(sc, publish, step, runtime=runtime)
    return pair, tp, variant, measures(truth)


def statistics(runs: dict[str, Any], periods: list[int], variants: list[str]) -> dict[str, Any]:
    """Per Tp, controller and KPI: mean, std, SE, min, max of the per-pair % change."""
    out: dict[str, Any] = {}
    for tp in periods:
        rows = runs[f"tp{tp}"]
        pairs = sorted(int(p) for p in rows if all(v in rows[p] for v in ["baseline", *variants]))
        out[f"tp{tp}"] = {"pairs": len(pairs)}
        for v in variants:
            out[f"tp{tp}"][v] = {}
            for k in KPIS:
                ch = np.array(
                    [
                        100.0 * (rows[str(p)][v][k] / rows[str(p)]["baseline"][k] - 1.0)
                        for p in pairs
                    ]
                )
                n = ch.size
                sd = float(ch.std(ddof=1)) if n > 1 else math.nan
                out[f"tp{tp}"][v][k] = {
                    "mean_percent": float(ch.mean()) if n else math.nan,
                    "std_percent": sd,
                    "se_percent": sd / math.sqrt(n) if n > 1 else math.nan,
                    "min_percent": float(ch.min()) if n else math.nan,
                    "max_percent": float(ch.max()) if n else math.nan,
                    "per_pair_percent": [float(c) for c in ch],
                }
    return out


def summary(stats: dict[str, Any], periods: list[int], variants: list[str]) -> dict[str, Any]:
    """One line per Tp and controller: mean ± std across pairs of the seed's four measures."""
    short = {
        "platform_pitch_std_deg": "pitch",
        "pitch_travel_deg": "travel",
        "electrical_power_std_w": "power std",
        "tower_fore_aft_std_m": "tower",
    }
    return {
        f"tp{tp}": {
            v: ", ".join(
                f"{name} {stats[f'tp{tp}'][v][k]['mean_percent']:+.0f}"
                f"±{stats[f'tp{tp}'][v][k]['std_percent']:.0f}"
                for k, name in short.items()
            )
            + " %"
            for v in variants
        }
        for tp in periods
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pairs", type=int, default=10, help="seed pairs (>= 2)")
    ap.add_argument("--first-pair", type=int, default=0)
    ap.add_argument("--periods", type=int, nargs="+", default=[2, 5, 10], choices=[2, 5, 10])
    ap.add_argument("--published", action="store_true", help="also the published weights alone")
    ap.add_argument("--decoupled", action="store_true", help="also LQR2 on the decoupled model")
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--name", default="christiansen_seeds_statistics", help="result file stem")
    ap.add_argument(
        "--reuse",
        type=Path,
        nargs="+",
        default=[],
        help="saved results whose runs (same seeds, deterministic) count",
    )
    a = ap.parse_args()
    if a.pairs < 2:
        raise SystemExit("--pairs: expected >= 2 (a spread needs two pairs)")
    variants = ["lqr1", "lqr2"]
    variants += ["lqr1_pub", "lqr2_pub"] if a.published else []
    variants += ["lqr2_dec"] if a.decoupled else []
    t0 = time.perf_counter()
    names = ["baseline", *variants]
    pairs = list(range(a.first_pair, a.first_pair + a.pairs))
    todo = [(p, tp, v) for p in pairs for tp in a.periods for v in names]
    runs: dict[str, Any] = {f"tp{tp}": {} for tp in a.periods}
    reused: dict[str, Any] = {}
    for path in a.reuse:  # the in-process runs are deterministic given the seeds
        saved = json.loads(path.read_text())
        if saved.get("duration_s") != a.duration:
            continue
        for tp in a.periods:
            for pair, row in saved["runs"].get(f"tp{tp}", {}).items():
                if int(pair) in pairs:
                    have = runs[f"tp{tp}"].setdefault(pair, {})
                    have.update({v: m for v, m in row.items() if v in names})
        keys = ("measured_utc", "commit", "wall_s", "load_average_start", "command")
        reused[path.stem] = saved.get("runs_measured") or {k: saved.get(k) for k in keys}
    todo = [j for j in todo if j[2] not in runs[f"tp{j[1]}"].get(str(j[0]), {})]
    tmp = Path(tempfile.mkdtemp(prefix="christiansen-seeds-"))
    presets: dict[str, str | None] = {"baseline": None, "lqr1": None, "lqr2": None}
    for v in sorted({j[2] for j in todo}):  # design only the variants still to run
        over = VARIANTS[v][1]
        if over is not None:
            presets[v] = str(design_variant(v, over, tmp))
    design_s = time.perf_counter() - t0
    jobs = [(p, tp, v, presets[v], a.duration) for p, tp, v in todo]
    partial = RESULTS / f"{a.name}.partial.json"
    load_start = load()
    with ProcessPoolExecutor(max_workers=a.workers) as pool:
        for pair, tp, v, m in pool.map(run_one, jobs):
            runs[f"tp{tp}"].setdefault(str(pair), {})[v] = m
            print(f"pair {pair} tp{tp} {v}: " + ", ".join(f"{k} {x:.4g}" for k, x in m.items()))
            partial.write_text(json.dumps({"runs": runs}, indent=1) + "\n")
    stats = statistics(runs, a.periods, variants)
    for tp in a.periods:
        for v in variants:
            row = stats[f"tp{tp}"][v]
            print(
                f"tp{tp} {v:9s} "
                + "  ".join(
                    f"{k} {row[k]['mean_percent']:+.1f}±{row[k]['std_percent']:.1f}%"
                    for k in KPIS[:4]
                )
            )
    save(
        a.name,
        {
            # absolute paths (a --reuse file outside the checkout) by their file name only
            "command": "python bench/christiansen_seeds.py "
            + " ".join(Path(x).name if Path(x).is_absolute() else x for x in sys.argv[1:]),
            "note": (
                "percent change against the detuned baseline of the same seed pair; mean, "
                "std (ddof 1) and standard error across pairs; in process, "
                f"{a.duration:g} s runs, statistics after {SETTLE_S:g} s"
            ),
            "pairs": pairs,
            "seeds_of_pair": "wind 13+k, waves 113+k, sensors 13+k (pair 0 = shipped)",
            "periods_s": a.periods,
            "variants": variants,
            "duration_s": a.duration,
            "summary": summary(stats, a.periods, variants),
            "statistics": stats,
            "runs": runs,
            "design_wall_s": design_s,
            "wall_s": time.perf_counter() - t0,
            "workers": a.workers,
            "load_average_start": load_start,
            "cpu_count": os.cpu_count(),
            "runs_reused": sum(len(r) for tp in runs.values() for r in tp.values()) - len(jobs),
            "runs_measured": reused or None,
        },
    )
    partial.unlink(missing_ok=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
