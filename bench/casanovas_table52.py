"""casanovas-2014 campaign: table 3.1 (frequency domain), table 5.2 and table 5.1 (time domain).

Every time-domain case is a ``fowt run`` of a shipped scenario
(``hil/scenario/presets/casanovas-*``)
in-process (``launch`` with ``mode="inprocess"``, the same code path as
``fowt run SCENARIO --mode inprocess``) with the controller kind, preview, wave seed, horizon
and overlap substituted into the scenario text; the mean electrical power is read back from
the run's MCAP (``PlantState.electrical_power_w``) over [settle, end] and compared with the
equivalent fixed-bottom turbine (``casanovas-fixed-u*``, same controller law, steady wind)::

    increase % = 100 (P̄_floating / P̄_fixed - 1)

The finite-horizon reset compute is taken from ``ControllerStatus.compute_time_ns`` of the
reset cycles (every ``reset_steps`` cycles from the first); overrun resets are counted by the
core (``gain_schedule_factor`` of the status).

Usage::

    python bench/casanovas_table52.py --seeds 3 --duration 300 --settle 60 --workers 2
    python bench/casanovas_table52.py --sensitivity --duration 300
    python bench/casanovas_table52.py --table31-only
    python bench/casanovas_table52.py --deviations --metric quadratic_linear --seeds 10
    python bench/casanovas_table52.py --deviations --metric electrical --hs 10 --winds 8

``--deviations`` reruns table 5.2 for the as-published configuration and for each deviation
of :data:`VARIANTS` changed alone (symmetric pitch limits, the torque weight r_τ, the steady
LQR's oscillator decay γ), on the same wave seeds, and reports every variant's paired
difference (same seeds) to ``no_control`` and to the steady LQR with its standard error
across seeds. ``--metric electrical``: ``fowt run`` in-process, mean electrical power
(above); ``--metric quadratic_linear``: the seed's own metric, the quadratic aerodynamic
power on its linear model (:mod:`hil.review.casanovas_linear`), against P̄. Saved (``save()``) as
``casanovas_table52_deviations_<metric>.json``.

Writes ``bench/results/casanovas_table52.json`` (or ``--out``). Runs with one BLAS thread (set
before numpy is imported): on this 2-vCPU shared machine a threaded OpenBLAS made an 81 x 100
complex matrix-vector product take 30 ms instead of 5 us.
"""

from __future__ import annotations

import os

for _k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_k] = "1"

import argparse  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import re  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from bench._common import RESULTS, machine  # noqa: E402

SCENARIOS = Path(__file__).resolve().parents[1] / "hil" / "scenario" / "presets"
KINDS = ("no_control", "base_torque", "lqr_steady", "lqr_finite", "lqr_overlaid")
HS_T1 = {6: 11.6, 10: 13.6}
WINDS = (6, 8, 10)
#: The seed's table 3.1 (100 m depth, 30 m draft): (kW, %) per (H_s, U).
SEED_T31 = {
    (6, 6): (29.3, 2.3),
    (6, 8): (42.8, 1.74),
    (6, 10): (67.1, 1.51),
    (10, 6): (83.3, 6.46),
    (10, 8): (120.1, 4.83),
    (10, 10): (182.5, 4.06),
}
#: The seed's table 5.2 (%, mean of 10 seeds).
SEED_T52 = {
    "no_control": {(6, 6): 1.836, (6, 8): 1.135, (6, 10): 0.747, (10, 6): 4.811, (10, 8): 3.049,
                   (10, 10): 2.293},
    "base_torque": {(6, 6): 2.147, (6, 8): 1.337, (6, 10): 0.967, (10, 6): 6.210, (10, 8): 4.041,
                    (10, 10): 2.830},
    "lqr_steady": {(6, 6): 2.498, (6, 8): 1.383, (6, 10): 0.937, (10, 6): 7.035, (10, 8): 4.101,
                   (10, 10): 2.833},
    "lqr_finite": {(6, 6): 2.709, (6, 8): 1.570, (6, 10): 1.246, (10, 6): 7.414, (10, 8): 4.342,
                   (10, 10): 3.009},
    "lqr_overlaid": {(6, 6): 2.952, (6, 8): 1.595, (6, 10): 1.261, (10, 6): 8.306, (10, 8): 4.889,
                     (10, 10): 3.927},
}  # fmt: skip


#: Symmetric pitch range of the deviation runs [deg]: the lowest pitch of the NREL 5 MW rotor
#: table (the plant never extrapolates C_p), wide beside the LQRs' pitch (std < 1 deg).
SYMMETRIC_PITCH_DEG = 5.0
_SYM = {"symmetric_pitch_limit_deg": SYMMETRIC_PITCH_DEG}
#: Torque weight factor r_τ / (½ρπR²) of the deviation runs: the decade at which the steady
#: LQR's torque gain on ϖ reaches the order of the linearised region-2 law's 2KN²Ω̄ (the seed's
#: 0.1 leaves the torque inert: its gain is ~5e5 times smaller; printed by --deviations).
TORQUE_WEIGHT = 1e-7
#: Table 5.2's variants: name -> (kind, scenario options). The first five are the seed's
#: controllers as published; each other changes one deviation (the last one two).
VARIANTS: dict[str, tuple[str, dict[str, float | str]]] = {
    "no_control": ("no_control", {}),
    "base_torque": ("base_torque", {}),
    "lqr_steady": ("lqr_steady", {}),
    "lqr_finite": ("lqr_finite", {}),
    "lqr_overlaid": ("lqr_overlaid", {}),
    "lqr_steady+symmetric_pitch": ("lqr_steady", _SYM),
    "lqr_finite+symmetric_pitch": ("lqr_finite", _SYM),
    "lqr_overlaid+symmetric_pitch": ("lqr_overlaid", _SYM),
    "lqr_steady+torque_weight": ("lqr_steady", {"torque_weight_factor": TORQUE_WEIGHT}),
    "lqr_finite+torque_weight": ("lqr_finite", {"torque_weight_factor": TORQUE_WEIGHT}),
    "lqr_steady+no_preview": ("lqr_steady", {"gamma_1_s": "no_preview"}),
    "lqr_steady+slow_gamma": ("lqr_steady", {"gamma_1_s": -0.1}),  # x 1/T1, set per case
    "lqr_finite+symmetric_pitch+torque_weight": (
        "lqr_finite",
        {"symmetric_pitch_limit_deg": SYMMETRIC_PITCH_DEG, "torque_weight_factor": TORQUE_WEIGHT},
    ),
}  # fmt: skip


def _options(name: str, hs: int) -> dict[str, float | str]:
    """The scenario options of variant ``name`` at H_s ``hs`` (γ scaled by 1/T₁)."""
    opts = dict(VARIANTS[name][1])
    if name == "lqr_steady+slow_gamma":
        opts["gamma_1_s"] = -0.1 / HS_T1[hs]  # memory of 10 T₁ instead of the design's T₁
    return opts


def _variant(
    text: str,
    kind: str,
    seed: int | None,
    preview: str | None,
    horizon_s: float | None,
    overlap: float | None,
    options: dict[str, float | str] | None = None,
) -> str:
    text = re.sub(r'(?m)^kind = "(no_control|base_torque|lqr_\w+)"$', f'kind = "{kind}"', text)
    if seed is not None:
        text = re.sub(r"(?m)^seed = \d+$", f"seed = {seed}", text, count=1)
    text = re.sub(r'(?m)^preview = "\w+"\n', "", text)
    extra = ""
    if preview is not None:
        extra += f'preview = "{preview}"\n'
    if horizon_s is not None:
        extra += f"horizon_s = {horizon_s}\n"
    if overlap is not None:
        extra += f"overlap = {overlap}\n"
    for key, value in (options or {}).items():
        extra += f"{key} = {json.dumps(value)}\n"  # a TOML string or number
    return text.replace("[controller]\n", "[controller]\n" + extra)


def run_case(job: dict[str, Any]) -> dict[str, Any]:
    """One ``fowt run`` (in-process) and its windowed mean power and reset compute."""
    from rich.console import Console

    from hil.launch import RunRequest, launch
    from hil.runlog.mcap_io import read_run

    text = (SCENARIOS / f"{job['scenario']}.toml").read_text()
    text = _variant(
        text, job["kind"], job.get("seed"), job.get("preview"), job.get("horizon_s"),
        job.get("overlap"), job.get("options"),
    )  # fmt: skip
    if job.get("metric") == "quadratic_linear":
        return _run_linear_case(job, text)
    with tempfile.TemporaryDirectory(prefix="casanovas-") as tmp:
        path = Path(tmp) / f"{job['scenario']}.toml"
        path.write_text(text)
        t0 = time.monotonic()
        summary = launch(
            RunRequest(
                scenario=str(path),
                mode="inprocess",
                duration_s=job["duration_s"],
                out_dir=Path(tmp) / "run",
                plots=False,
            ),
            Console(file=io.StringIO()),
        )
        wall = time.monotonic() - t0
        run = read_run(Path(tmp) / "run" / "run.mcap")
    truth = run.topic("truth")
    t = np.array([m["sample_time_ns"] for m in truth]) * 1e-9
    p = np.array([m["electrical_power_w"] for m in truth])
    sel = t >= job["settle_s"]
    status = run.topic("controller/status")
    comp = np.array([m["compute_time_ns"] for m in status]) * 1e-3
    out = {
        **job,
        "mean_power_w": float(np.mean(p[sel])),
        "surge_std_m": float(np.std([m["platform_surge_m"] for m in truth])),
        "pitch_std_deg": float(np.degrees(np.std([m["blade_pitch_rad"] for m in truth]))),
        "torque_std_nm": float(np.std([m["generator_torque_nm"] for m in truth])),
        "compute_p50_us": float(np.percentile(comp, 50)) if comp.size else None,
        "compute_p99_us": float(np.percentile(comp, 99)) if comp.size else None,
        "overruns": int(status[-1]["gain_schedule_factor"]) if status else 0,
        "review_mean_power_w": summary.get("kpis", {}).get("mean_power_w"),
        "wall_s": round(wall, 2),
    }
    if job["kind"] in ("lqr_finite", "lqr_overlaid") and comp.size:
        from controller.casanovas import make_casanovas

        core = make_casanovas(
            job["kind"], _preset(text), control_period_s=0.1, preview=job.get("preview"),
            horizon_s=job.get("horizon_s"), overlap=job.get("overlap"), gauge_distance_m=450.0,
        )  # fmt: skip
        resets = comp[:: core.reset_steps]
        out["reset_steps"] = core.reset_steps
        out["reset_compute_us"] = resets.tolist()
    return out


def _run_linear_case(job: dict[str, Any], text: str) -> dict[str, Any]:
    """One run of the seed's metric: the controller on the linear model
    (hil.review.casanovas_linear)."""
    from dataclasses import asdict

    from hil.review.casanovas_linear import run_linear
    from hil.scenario.schema import load_scenario

    with tempfile.TemporaryDirectory(prefix="casanovas-") as tmp:
        path = Path(tmp) / f"{job['scenario']}.toml"
        path.write_text(text)
        scenario = load_scenario(str(path))
    t0 = time.monotonic()
    res = asdict(run_linear(scenario, job["duration_s"], job["settle_s"]))
    return {**job, **res, "wall_s": round(time.monotonic() - t0, 2)}


def paired_stats(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Per case and variant: mean increase and the paired differences (same wave seeds) to
    ``no_control`` and to ``lqr_steady`` [percentage points], each with its standard error
    across seeds (sample std / √n)."""
    by: dict[tuple[int, int, str], dict[int, float]] = {}
    for r in runs:
        if r.get("role") == "deviation":
            key = (r["hs_m"], r["wind_m_s"], r["variant"])
            by.setdefault(key, {})[r["seed"]] = r["increase_percent"]

    def stat(v: list[float]) -> dict[str, float]:
        a = np.asarray(v)
        se = float(np.std(a, ddof=1) / math.sqrt(a.size)) if a.size > 1 else math.nan
        return {"mean": float(np.mean(a)), "se": se, "n": int(a.size)}

    out: dict[str, Any] = {}
    for (hs, u, name), seeds in sorted(by.items()):
        row: dict[str, Any] = {"increase_percent": stat(list(seeds.values()))}
        for ref in ("no_control", "lqr_steady"):
            other = by.get((hs, u, ref), {})
            common = sorted(set(seeds) & set(other))
            if common and name != ref:
                row[f"minus_{ref}_pp"] = stat([seeds[k] - other[k] for k in common])
        seed_kind = VARIANTS[name][0] if name == VARIANTS[name][0] else None
        row["seed_percent"] = SEED_T52.get(seed_kind or "", {}).get((hs, u))
        out[f"hs{hs}/u{u}/{name}"] = row
    return out


def region2_torque_stiffness() -> dict[str, Any]:
    """Torque per ϖ [N m s/rad, HSS torque per rotor rad/s]: the linearised region-2 law
    2KN²Ω̄ beside the steady LQR's -K_τϖ at the seed's r_τ and at :data:`TORQUE_WEIGHT`."""
    from controller.casanovas import make_casanovas

    out = {}
    for hs in HS_T1:
        for u in WINDS:
            preset = f"nrel5mw_tlp_casanovas_u{u}_hs{hs}"
            c0 = make_casanovas("lqr_steady", preset, control_period_s=0.1)
            c1 = make_casanovas("lqr_steady", preset, control_period_s=0.1,
                                torque_weight_factor=TORQUE_WEIGHT)  # fmt: skip
            out[f"hs{hs}/u{u}"] = {
                "region2_law": 2 * c0.k_gen * c0.gear**2 * c0.omega0,
                "lqr_seed_weight": float(-c0.k_steady[0, 0]),
                "lqr_torque_weight": float(-c1.k_steady[0, 0]),
            }
    return out


def summary_rows(table: dict[str, Any]) -> dict[str, str]:
    """One line per case and variant: increase, and the paired differences ± standard error."""
    out = {}
    for k, v in table.items():
        parts = [f"{v['increase_percent']['mean']:.3f} % (n={v['increase_percent']['n']})"]
        for ref, label in (("no_control", "none"), ("lqr_steady", "steady")):
            d = v.get(f"minus_{ref}_pp")
            if d is not None:
                parts.append(f"vs {label} {d['mean']:+.4f} ± {d['se']:.4f} pp")
        out[k] = "; ".join(parts)
    return out


def markdown(paths: list[str]) -> str:
    """Markdown tables of saved ``--deviations`` results: per case, per variant, the increase
    over the fixed-bottom turbine and the paired differences to no_control and to the steady
    LQR (mean ± standard error over the seeds, percentage points), beside the seed's."""
    out: list[str] = []
    for path in paths:
        res = json.loads(Path(path).read_text())
        table = res["table52"]
        cases = sorted({tuple(k.split("/")[:2]) for k in table}, key=lambda c: (
            int(c[0][2:]), int(c[1][1:])))  # fmt: skip
        out += [f"`{Path(path).name}` (metric {res['metric']}):", ""]
        if len(cases) > 1:  # compact: paired differences per case, the seed's below
            for ref in ("no_control", "lqr_steady"):
                out += [f"minus {ref} (pp, mean ± standard error over the seeds):", "",
                        "| variant | " + " | ".join(f"{h[2:]} m, {w[1:]} m/s" for h, w in cases)
                        + " |", "| --- |" + " --- |" * len(cases)]  # fmt: skip
                for name in VARIANTS:
                    cells = []
                    for hs, u in cases:
                        d = table.get(f"{hs}/{u}/{name}", {}).get(f"minus_{ref}_pp")
                        cells.append("" if d is None else f"{d['mean']:+.3f} ± {d['se']:.3f}")
                    if any(cells):
                        out.append(f"| {name} | " + " | ".join(cells) + " |")
                for kind in KINDS:
                    if kind == ref:
                        continue
                    keys = [(int(h[2:]), int(w[1:])) for h, w in cases]
                    cells = [f"{SEED_T52[kind][c] - SEED_T52[ref][c]:+.3f}" for c in keys]
                    out.append(f"| seed: {kind} | " + " | ".join(cells) + " |")
                out.append("")
        for hs, u in cases:
            if len(cases) > 1 and sum(k.startswith(f"{hs}/{u}/") for k in table) <= 9:
                continue  # the compact tables above hold these cases
            nc_seed = SEED_T52["no_control"][(int(hs[2:]), int(u[1:]))]
            st_seed = SEED_T52["lqr_steady"][(int(hs[2:]), int(u[1:]))]
            out += [f"H_s {hs[2:]} m, {u[1:]} m/s:", "",
                    "| variant | increase % | minus no control (pp) | minus steady LQR (pp) "
                    "| seed: increase % / minus no control / minus steady |",
                    "| --- | --- | --- | --- | --- |"]  # fmt: skip
            for name in VARIANTS:
                v = table.get(f"{hs}/{u}/{name}")
                if v is None:
                    continue
                inc = v["increase_percent"]
                cells = [f"{inc['mean']:.3f} ± {inc['se']:.3f} (n={inc['n']})"]
                for ref in ("no_control", "lqr_steady"):
                    d = v.get(f"minus_{ref}_pp")
                    cells.append("-" if d is None else f"{d['mean']:+.4f} ± {d['se']:.4f}")
                sp = v.get("seed_percent")
                seed = "" if sp is None else (
                    f"{sp} / {sp - nc_seed:+.3f} / {sp - st_seed:+.3f}")  # fmt: skip
                out.append(f"| {name} | " + " | ".join(cells) + f" | {seed} |")
            out.append("")
    return "\n".join(out)


def _ordered(res: dict[str, Any]) -> dict[str, Any]:
    """``res`` with its table and summary recomputed from its runs, the summary first (the
    benchmark page shows a result's first figures)."""
    table = paired_stats(res["runs"])
    desc = (
        "casanovas-2014 table 5.2: the seed's controllers as published and one deviation at "
        f"a time; metric {res['metric']}; increase over the fixed-bottom turbine and paired "
        "differences (same wave seeds) to no control and to the steady LQR, mean ± standard "
        "error over the seeds [pp]"
    )
    rest = {k: v for k, v in res.items() if k not in ("summary", "description", "table52")}
    return {"summary": summary_rows(table), "description": desc, **rest, "table52": table}


def resummarise(path: str) -> None:
    """Rewrite a saved ``--deviations`` result with the table and summary recomputed from its
    runs (what it measured, when and on which commit stay as saved)."""
    res = json.loads(Path(path).read_text())
    meta = {k: res.pop(k) for k in ("benchmark", "measured_utc", "commit", "machine")}
    Path(path).write_text(json.dumps({**meta, **_ordered(res)}, indent=2))
    print(f"rewrote {path}")


def deviations(args: argparse.Namespace) -> int:
    """``--deviations``: table 5.2 as published and one deviation at a time (module doc)."""
    from bench._common import load, save

    hs_list = [int(x) for x in args.hs.split(",")]
    winds = [int(x) for x in args.winds.split(",")]
    names = list(VARIANTS) if args.variants == "all" else args.variants.split(",")
    for n in names:
        if n not in VARIANTS:
            raise SystemExit(f"unknown variant {n!r}; known: {', '.join(VARIANTS)}")
    base = {"duration_s": args.duration, "settle_s": args.settle, "metric": args.metric}
    jobs: list[dict[str, Any]] = []
    if args.metric == "electrical":
        for u in winds:
            jobs.append({**base, "scenario": f"casanovas-fixed-u{u}", "kind": "base_torque",
                         "role": "fixed", "wind_m_s": u})  # fmt: skip
    for hs in hs_list:
        for u in winds:
            for seed in range(args.seed_start, args.seed_start + args.seeds):
                for name in list(VARIANTS) if f"{hs}:{u}" == args.full_case else names:
                    jobs.append({**base, "scenario": f"casanovas-tlp-hs{hs}-u{u}",
                                 "kind": VARIANTS[name][0], "variant": name,
                                 "options": _options(name, hs), "seed": seed,
                                 "preview": "perfect", "role": "deviation", "hs_m": hs,
                                 "wind_m_s": u})  # fmt: skip
    load_before = load()
    t0 = time.monotonic()
    runs: list[dict[str, Any]] = []
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for i, r in enumerate(pool.map(run_case, jobs)):
            runs.append(r)
            name = r.get("variant", r["kind"])
            kw, el = r["mean_power_w"] / 1e3, time.monotonic() - t0
            print(
                f"[{i + 1}/{len(jobs)} {el:6.0f} s] {r['scenario']} {name} "
                f"seed {r.get('seed')}: {kw:.2f} kW (wall {r['wall_s']} s)",
                flush=True,
            )
    fixed = {r["wind_m_s"]: r["mean_power_w"] for r in runs if r["role"] == "fixed"}
    for r in runs:
        if r["role"] == "deviation" and args.metric == "electrical":
            r["increase_percent"] = 100 * (r["mean_power_w"] / fixed[r["wind_m_s"]] - 1)
    table = paired_stats(runs)
    for k, v in table.items():
        d = v.get("minus_no_control_pp")
        e = v.get("minus_lqr_steady_pp")
        print(f"{k:50s} {v['increase_percent']['mean']:7.3f} %  seed {v['seed_percent']}"
              + (f"  vs no_control {d['mean']:+.4f} ± {d['se']:.4f}" if d else "")
              + (f"  vs steady {e['mean']:+.4f} ± {e['se']:.4f}" if e else ""))  # fmt: skip
    save(
        f"casanovas_table52_deviations_{args.metric}" + (f"_{args.tag}" if args.tag else ""),
        _ordered(
            {
                "script": "casanovas_table52.py",
                "metric": args.metric,
                "args": {k: v for k, v in vars(args).items() if k != "out"},
                "symmetric_pitch_deg": SYMMETRIC_PITCH_DEG,
                "torque_weight_factor": TORQUE_WEIGHT,
                "torque_stiffness_n_m_s_rad": region2_torque_stiffness(),
                "load_before": load_before,
                "load_after": load(),
                "wall_s": round(time.monotonic() - t0, 1),
                "fixed_power_w": fixed,
                "runs": runs,
            }
        ),
    )
    return 0


def _preset(text: str) -> str:
    m = re.search(r'(?m)^preset = "([^"]+)"$', text)
    assert m is not None
    return m.group(1)


def table31() -> list[dict[str, Any]]:
    """Frequency-domain upper bound (controller.design.casanovas.upper_bound) beside the seed."""
    from controller.design.casanovas import upper_bound

    rows = []
    for hs, t1 in HS_T1.items():
        for u in WINDS:
            r = upper_bound("nrel5mw_tlp", u, hs, t1)
            kw_seed, pc_seed = SEED_T31[(hs, u)]
            rows.append(
                {
                    "hs_m": hs,
                    "t1_s": t1,
                    "wind_m_s": u,
                    "p_ext_kw": r["p_ext_w"] / 1e3,
                    "p_ext_haskind_kw": r["p_ext_haskind_w"] / 1e3,
                    "percent_of_aero_power": r["percent"],
                    "seed_kw": kw_seed,
                    "seed_percent": pc_seed,
                    "kw_ratio_to_seed": r["p_ext_w"] / 1e3 / kw_seed,
                    "seed_implied_base_power_kw": kw_seed / (pc_seed / 100),
                    "aero_power_kw": r["p_aero_w"] / 1e3,
                }
            )
    return rows


def solve_bench(n: int = 40) -> dict[str, Any]:
    """Per-reset compute of the finite-horizon solve [us]: seed-style (both equations
    integrated every reset) and cached (P and the operator X -> φ precomputed)."""
    from controller.casanovas import finite_horizon_solve, make_casanovas

    full: list[float] = []
    cached: list[float] = []
    for hs in HS_T1:
        for u in WINDS:
            c = make_casanovas("lqr_finite", f"nrel5mw_tlp_casanovas_u{u}_hs{hs}",
                               control_period_s=0.1)  # fmt: skip
            rng = np.random.default_rng(0)
            for _ in range(n):
                f = rng.normal(0, 1e5, c.n_preview)
                t0 = time.perf_counter_ns()
                force = np.interp(c._t_half, c._t_prev, f)
                finite_horizon_solve(c.a, c.b, c.q, c.r, c.n, c.e, force, c.dt)
                full.append((time.perf_counter_ns() - t0) / 1e3)
                t0 = time.perf_counter_ns()
                force = np.interp(c._t_half, c._t_prev, f)
                _ = c._ff_operator @ force
                cached.append((time.perf_counter_ns() - t0) / 1e3)
    return {
        "every_reset_p50": float(np.percentile(full, 50)),
        "every_reset_p99": float(np.percentile(full, 99)),
        "cached_p50": float(np.percentile(cached, 50)),
        "cached_p99": float(np.percentile(cached, 99)),
        "n": len(full),
    }


_LINE = re.compile(
    r"\] (\S+) (\S+) seed (\S+) (\S+) T (\S+) δ (\S+): ([\d.]+) kW "
    r"\(wall [\d.]+ s, overruns (\d+)\)"
)


def tables_from_logs(paths: list[str]) -> dict[str, Any]:
    """Rebuild table 5.2 / 5.1 from the per-run lines this script prints (partial campaigns)."""
    fixed: dict[int, float] = {}
    rows: list[dict[str, Any]] = []
    for path in paths:
        for line in Path(path).read_text().splitlines():
            m = _LINE.search(line)
            if m is None:
                continue
            sc, kind, seed, pv, h, d, kw, over = m.groups()
            u = int(sc.rsplit("-u", 1)[1])
            if sc.startswith("casanovas-fixed"):
                fixed[u] = float(kw) * 1e3
                continue
            hs = int(re.search(r"hs(\d+)", sc).group(1))  # type: ignore[union-attr]
            rows.append({"kind": kind, "seed": int(seed), "preview": pv, "hs_m": hs,
                         "wind_m_s": u, "horizon_s": None if h == "None" else float(h),
                         "overlap": None if d == "None" else float(d),
                         "mean_power_w": float(kw) * 1e3, "overruns": int(over)})  # fmt: skip
    table: dict[str, list[float]] = {}
    sens: list[dict[str, Any]] = []
    for r in rows:
        r["increase_percent"] = 100 * (r["mean_power_w"] / fixed[r["wind_m_s"]] - 1)
        r["increase_kw"] = (r["mean_power_w"] - fixed[r["wind_m_s"]]) / 1e3
        if r["horizon_s"] is not None:
            sens.append(r)
        else:
            key = f"{r['kind']}/{r['preview']}/hs{r['hs_m']}/u{r['wind_m_s']}"
            table.setdefault(key, []).append(r["increase_percent"])
    t52 = {
        k: {
            "mean_percent": float(np.mean(v)),
            "std_percent": float(np.std(v)),
            "n": len(v),
            "seed_percent": SEED_T52.get(k.split("/")[0], {}).get(
                (int(k.split("/")[2][2:]), int(k.split("/")[3][1:]))
            ),
        }
        for k, v in sorted(table.items())
    }
    # paired by wave seed: the difference to no_control on the same sea [percentage points]
    ref = {(r["hs_m"], r["wind_m_s"], r["seed"]): r["increase_percent"] for r in rows
           if r["kind"] == "no_control" and r["horizon_s"] is None}  # fmt: skip
    for k, v in t52.items():
        kind, pv, hs, u = k.split("/")
        d = [r["increase_percent"] - ref[(r["hs_m"], r["wind_m_s"], r["seed"])] for r in rows
             if r["kind"] == kind and r["preview"] == pv and r["horizon_s"] is None
             and f"hs{r['hs_m']}" == hs and f"u{r['wind_m_s']}" == u
             and (r["hs_m"], r["wind_m_s"], r["seed"]) in ref]  # fmt: skip
        v["minus_no_control_pp"] = float(np.mean(d)) if d else None
        v["minus_no_control_pp_min_max"] = [float(np.min(d)), float(np.max(d))] if d else None
    return {"fixed_power_w": fixed, "table52": t52, "table51": sens, "runs": rows}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3, help="wave seeds per case (seed: 10)")
    ap.add_argument("--seed-start", type=int, default=1, help="first wave seed")
    ap.add_argument("--duration", type=float, default=300.0, help="simulated s per run")
    ap.add_argument("--settle", type=float, default=60.0, help="s discarded at the start")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--hs", default="6,10")
    ap.add_argument("--winds", default="6,8,10")
    ap.add_argument("--forecast", action="store_true", help="also preview = forecast")
    ap.add_argument("--forecast-kinds", default="lqr_finite,lqr_overlaid")
    ap.add_argument("--sensitivity", action="store_true", help="table 5.1 (H_s 6, 10 m/s)")
    ap.add_argument("--table31-only", action="store_true")
    ap.add_argument("--out", default=str(RESULTS / "casanovas_table52.json"))
    ap.add_argument("--from-logs", nargs="+", help="rebuild the tables from printed run lines")
    ap.add_argument(
        "--deviations",
        action="store_true",
        help="table 5.2 as published and one deviation at a time (VARIANTS)",
    )
    ap.add_argument("--variants", default="all", help="--deviations: comma list or 'all'")
    ap.add_argument("--full-case", default="", help="--deviations: HS:U run with every variant")
    ap.add_argument("--tag", default="", help="--deviations: suffix of the result's name")
    ap.add_argument(
        "--metric",
        choices=("electrical", "quadratic_linear"),
        default="electrical",
        help="--deviations: the power compared",
    )
    ap.add_argument("--markdown", nargs="+", help="print saved --deviations results as tables")
    ap.add_argument("--resummarise", nargs="+", help="recompute saved --deviations tables")
    args = ap.parse_args(argv)
    if args.resummarise:
        for path in args.resummarise:
            resummarise(path)
        return 0
    if args.markdown:
        print(markdown(args.markdown))
        return 0
    if args.deviations:
        return deviations(args)
    if args.from_logs:
        res = {"machine": machine(), "from_logs": args.from_logs, "table31": table31(),
               **tables_from_logs(args.from_logs)}  # fmt: skip
        Path(args.out).write_text(json.dumps(res, indent=2))
        for k, v in res["table52"].items():
            d = v["minus_no_control_pp"]
            print(f"{k:32s} {v['mean_percent']:7.3f} % ± {v['std_percent']:.3f} (n={v['n']})"
                  f"  seed {v['seed_percent']}  vs no_control "
                  f"{'-' if d is None else f'{d:+.4f}'} pp")  # fmt: skip
        for r in res["table51"]:
            print(f"T {r['horizon_s']:5} δ {r['overlap']:4}: {r['increase_percent']:.4f} %")
        print(f"saved {args.out}")
        return 0

    result: dict[str, Any] = {"machine": machine(), "args": vars(args), "table31": table31()}
    print("table 3.1 (kW; % of the aerodynamic power ½ρπR²Cp*V³):")
    for r in result["table31"]:
        print(
            f"  Hs {r['hs_m']:>2} m U {r['wind_m_s']:>2} m/s: {r['p_ext_kw']:7.1f} kW "
            f"({r['percent_of_aero_power']:.2f} %)  seed {r['seed_kw']} kW ({r['seed_percent']} %)"
            f"  ratio {r['kw_ratio_to_seed']:.3f}"
        )
    result["solve_compute_us"] = solve_bench()
    print("finite-horizon reset solve, one process, T = T1:", result["solve_compute_us"])
    if args.table31_only:
        Path(args.out).write_text(json.dumps(result, indent=2))
        return 0

    hs_list = [int(x) for x in args.hs.split(",")]
    winds = [int(x) for x in args.winds.split(",")]
    kinds = args.kinds.split(",")
    jobs: list[dict[str, Any]] = []
    base = {"duration_s": args.duration, "settle_s": args.settle}
    for u in winds if args.seed_start == 1 else ():  # the reference, once per campaign
        jobs.append({**base, "scenario": f"casanovas-fixed-u{u}", "kind": "base_torque",
                     "role": "fixed", "wind_m_s": u})  # fmt: skip
    if args.sensitivity:
        for h in (0.5, 2.0, 5.0, 10.0, 15.0, 20.0):
            for d in (0.0, 0.5, 0.95):
                jobs.append({**base, "scenario": "casanovas-tlp-hs6-u10", "kind": "lqr_finite",
                             "seed": 1, "preview": "perfect", "horizon_s": h, "overlap": d,
                             "role": "sensitivity", "hs_m": 6, "wind_m_s": 10})  # fmt: skip
    else:
        for hs in hs_list:
            for u in winds:
                for seed in range(args.seed_start, args.seed_start + args.seeds):
                    for kind in kinds:
                        previews = ["perfect"]
                        if args.forecast and kind in args.forecast_kinds.split(","):
                            previews.append("forecast")
                        for pv in previews:
                            jobs.append({**base, "scenario": f"casanovas-tlp-hs{hs}-u{u}",
                                         "kind": kind, "seed": seed, "preview": pv,
                                         "role": "table52", "hs_m": hs, "wind_m_s": u})  # fmt: skip
    t0 = time.monotonic()
    runs: list[dict[str, Any]] = []
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for i, r in enumerate(pool.map(run_case, jobs)):
            runs.append(r)
            print(
                f"[{i + 1}/{len(jobs)} {time.monotonic() - t0:6.0f} s] {r['scenario']} "
                f"{r['kind']} seed {r.get('seed')} {r.get('preview')} T {r.get('horizon_s')} "
                f"δ {r.get('overlap')}: {r['mean_power_w'] / 1e3:.2f} kW "
                f"(wall {r['wall_s']} s, overruns {r['overruns']})",
                flush=True,
            )
    result["runs"] = runs
    fixed = {r["wind_m_s"]: r["mean_power_w"] for r in runs if r["role"] == "fixed"}
    result["fixed_power_w"] = fixed
    table: dict[str, Any] = {}
    for r in runs:
        if r["role"] == "fixed" or r["wind_m_s"] not in fixed:
            continue  # (a --seed-start > 1 campaign: combine its log with --from-logs)
        r["increase_percent"] = 100 * (r["mean_power_w"] / fixed[r["wind_m_s"]] - 1)
        if r["role"] == "table52":
            key = f"{r['kind']}/{r['preview']}/hs{r['hs_m']}/u{r['wind_m_s']}"
            table.setdefault(key, []).append(r["increase_percent"])
    result["table52"] = {
        k: {
            "mean_percent": float(np.mean(v)),
            "std_percent": float(np.std(v)),
            "n": len(v),
            "seed_percent": SEED_T52.get(k.split("/")[0], {}).get(
                (int(k.split("/")[2][2:]), int(k.split("/")[3][1:]))
            ),
        }
        for k, v in sorted(table.items())
    }
    resets = [x for r in runs for x in r.get("reset_compute_us", [])]
    if resets:
        result["reset_compute_us"] = {
            "n": len(resets),
            "p50": float(np.percentile(resets, 50)),
            "p99": float(np.percentile(resets, 99)),
            "max": float(np.max(resets)),
            "overruns": int(sum(r["overruns"] for r in runs)),
        }
    keys = ("table52", "reset_compute_us", "fixed_power_w")
    print(json.dumps({k: v for k, v in result.items() if k in keys}, indent=1))
    if args.sensitivity:
        for r in runs:
            if r["role"] == "sensitivity":
                print(f"T {r['horizon_s']:5} δ {r['overlap']:4}: {r['increase_percent']:.4f} %")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2))
    print(f"saved {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
