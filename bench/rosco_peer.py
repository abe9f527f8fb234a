"""ROSCO's compiled controller against the bench's own controllers on the same plant.

Four comparisons, each run in process (deterministic: the same numbers as lock-step):

1. ``steady``: bottom-fixed NREL 5 MW, steady wind 5..24 m/s, ROSCO (its NREL 5 MW
   DISCON.IN) beside ``baseline`` (Jonkman 2009): settled rotor speed, electrical power,
   pitch, generator torque and tip-speed ratio (means over the last ``--settle`` seconds).
2. ``step``: wind step 8 -> 14 m/s at 30 s; both traces in one plot, RMS differences.
3. ``floating``: IEA 15 MW on VolturnUS-S, load case 2 (the shipped ``iea15mw-lc2``),
   ROSCO (VolturnUS-S DISCON.IN, floating feedback ``Fl_Mode`` = 2) beside ``baseline``:
   the review's KPIs side by side.
4. ``wse``: wind-speed estimation with the plant's Cp table scaled by 0.95 (a model
   mismatch the controllers do not know): ROSCO's EKF (``WE_Mode`` = 2, from its debug
   file, on the status channel) and the bench's EKF (``lqri``'s observer) against the
   true rotor-effective wind; mean and RMS error. On the floating IEA 15 MW (the bench's EKF
   belongs to the advanced controller, which needs a floating plant), two cases: steady wind
   in still water (the model mismatch alone) and IEC class B turbulence with load case 2's
   waves. Mean winds 9 and 14 m/s; ROSCO's own flag ``WE_Op`` (its EKF
   operating, or its fall-back to the filtered anemometer) from its ``.RO.dbg2``.

Usage::

    python bench/rosco_peer.py                      # all four, ~15 min on 2 shared vCPUs
    python bench/rosco_peer.py --only steady step   # some of them

Prints tables and writes ``bench/results/rosco_peer.json`` and ``rosco_step.png``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bus_schemas import ActuatorCommand, SensorFrame  # noqa: E402
from bus_schemas.registry import CONTROLLER_STATUS, TRUTH, MessageType  # noqa: E402
from hil.inprocess.run import run_inprocess  # noqa: E402
from hil.nodes.controller_node import ControllerRuntime  # noqa: E402
from hil.scenario.schema import Scenario, load_scenario, parse_scenario  # noqa: E402

RESULTS = ROOT / "bench" / "results"


def run(scenario: Scenario, run_dir: Path) -> dict[str, Any]:
    """Run in process; return the truth and status as arrays (time in s)."""
    log: dict[str, list[Any]] = defaultdict(list)

    def publish(mt: MessageType, msg: msgspec.Struct) -> None:
        if mt is TRUTH:
            log[mt.key_suffix].append(msg)

    runtime = ControllerRuntime(scenario, run_dir=run_dir)

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        out = runtime.handle_frame(frame)
        if out is None:
            return None
        log[CONTROLLER_STATUS.key_suffix].append(out[1])
        return out[0]

    t0 = time.perf_counter()
    result = run_inprocess(scenario, publish, step)
    truth, status = log[TRUTH.key_suffix], log[CONTROLLER_STATUS.key_suffix]
    out: dict[str, Any] = {"wall_s": time.perf_counter() - t0, "misses": result.deadline_misses}
    out["t"] = np.array([m.sample_time_ns * 1e-9 for m in truth])
    for name in (
        "rotor_speed_rad_s",
        "electrical_power_w",
        "blade_pitch_rad",
        "generator_torque_nm",
        "tip_speed_ratio",
        "wind_speed_m_s",
        "platform_pitch_rad",
        "power_coefficient",
    ):
        out[name] = np.array([getattr(m, name) for m in truth])
    out["status_t"] = np.array([m.sample_time_ns * 1e-9 for m in status])
    out["wind_est"] = np.array([m.wind_speed_estimated_m_s for m in status])
    out["regime"] = np.array([m.regime for m in status], dtype=np.int64)
    return out


def steady_text(kind: str, wind: float, duration: float) -> str:
    preset = "nrel5mw" if kind == "rosco" else "nrel5mw_baseline"
    return f"""
name = "peer-{kind}-{wind}"
turbine = "nrel5mw"
duration_s = {duration}
[wind]
kind = "steady"
speed_m_s = {wind}
[controller]
kind = "{kind}"
preset = "{preset}"
"""


def settled(r: dict[str, Any], seconds: float) -> dict[str, float]:
    k = r["t"] >= r["t"][-1] - seconds
    return {
        "rotor_rpm": float(np.mean(r["rotor_speed_rad_s"][k]) * 60 / (2 * math.pi)),
        "power_mw": float(np.mean(r["electrical_power_w"][k]) / 1e6),
        "pitch_deg": float(np.degrees(np.mean(r["blade_pitch_rad"][k]))),
        "torque_knm": float(np.mean(r["generator_torque_nm"][k]) / 1e3),
        "tsr": float(np.mean(r["tip_speed_ratio"][k])),
        "rotor_rpm_std": float(np.std(r["rotor_speed_rad_s"][k]) * 60 / (2 * math.pi)),
        "regime": int(np.bincount(r["regime"][-int(seconds * 100) :].astype(np.int64)).argmax()),
    }


def cmp_steady(args: argparse.Namespace, tmp: Path) -> dict[str, Any]:
    rows = []
    print(f"\nsteady wind, NREL 5 MW bottom-fixed: ROSCO | baseline (last {args.settle:.0f} s)")
    print(
        f"{'U':>5} {'rpm R':>7} {'rpm B':>7} {'P R':>6} {'P B':>6} {'pitch R':>8} "
        f"{'pitch B':>8} {'dpitch':>7} {'TSR R':>6} {'TSR B':>6} {'reg R':>5} {'reg B':>5}"
    )
    for wind in args.winds:
        res = {}
        for kind in ("rosco", "baseline"):
            sc = parse_scenario(steady_text(kind, wind, args.duration))
            res[kind] = settled(run(sc, tmp / f"steady-{kind}-{wind}"), args.settle)
        r, b = res["rosco"], res["baseline"]
        row = {"wind_m_s": wind, "rosco": r, "baseline": b}
        row["pitch_diff_deg"] = r["pitch_deg"] - b["pitch_deg"]
        rows.append(row)
        print(
            f"{wind:5.1f} {r['rotor_rpm']:7.3f} {b['rotor_rpm']:7.3f} {r['power_mw']:6.3f} "
            f"{b['power_mw']:6.3f} {r['pitch_deg']:8.3f} {b['pitch_deg']:8.3f} "
            f"{row['pitch_diff_deg']:7.3f} {r['tsr']:6.2f} {b['tsr']:6.2f} {r['regime']:5d} "
            f"{b['regime']:5d}"
        )
    return {"duration_s": args.duration, "settle_s": args.settle, "rows": rows}


def cmp_step(args: argparse.Namespace, tmp: Path) -> dict[str, Any]:
    traces = {}
    for kind in ("rosco", "baseline"):
        text = steady_text(kind, 8.0, 90.0).replace(
            'kind = "steady"\nspeed_m_s = 8.0',
            'kind = "step"\ninitial_m_s = 8.0\nfinal_m_s = 14.0\ntime_s = 30.0',
        )
        traces[kind] = run(parse_scenario(text), tmp / f"step-{kind}")
    r, b = traces["rosco"], traces["baseline"]
    k = r["t"] >= 30.0
    rms = {
        "rotor_rpm": float(
            np.sqrt(np.mean((r["rotor_speed_rad_s"][k] - b["rotor_speed_rad_s"][k]) ** 2))
            * 60
            / (2 * math.pi)
        ),
        "power_mw": float(
            np.sqrt(np.mean((r["electrical_power_w"][k] - b["electrical_power_w"][k]) ** 2)) / 1e6
        ),
        "pitch_deg": float(
            np.degrees(np.sqrt(np.mean((r["blade_pitch_rad"][k] - b["blade_pitch_rad"][k]) ** 2)))
        ),
    }
    peak = {
        kind: float(np.max(tr["rotor_speed_rad_s"][k]) * 60 / (2 * math.pi))
        for kind, tr in traces.items()
    }
    print("\nwind step 8 -> 14 m/s at 30 s, NREL 5 MW: RMS difference ROSCO - baseline after 30 s")
    print(
        f"  rotor speed {rms['rotor_rpm']:.3f} rpm, power {rms['power_mw']:.3f} MW, "
        f"pitch {rms['pitch_deg']:.3f} deg; peak rotor speed ROSCO {peak['rosco']:.2f} rpm, "
        f"baseline {peak['baseline']:.2f} rpm"
    )
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    for kind, tr in traces.items():
        ax[0].plot(tr["t"], tr["wind_speed_m_s"], label=kind)
        ax[1].plot(tr["t"], tr["rotor_speed_rad_s"] * 60 / (2 * math.pi), label=kind)
        ax[2].plot(tr["t"], tr["electrical_power_w"] / 1e6, label=kind)
        ax[3].plot(tr["t"], np.degrees(tr["blade_pitch_rad"]), label=kind)
    for a, lab in zip(
        ax, ("wind [m/s]", "rotor speed [rpm]", "power [MW]", "pitch [deg]"), strict=True
    ):
        a.set_ylabel(lab)
        a.grid(True)
    ax[1].legend()
    ax[-1].set_xlabel("time [s]")
    fig.suptitle("NREL 5 MW, wind step 8 -> 14 m/s: ROSCO (compiled) vs baseline")
    fig.tight_layout()
    png = RESULTS / "rosco_step.png"
    fig.savefig(png, dpi=90)
    print(f"  plot: {png}")
    return {"rms_after_step": rms, "peak_rotor_rpm": peak, "plot": str(png.relative_to(ROOT))}


def cmp_floating(args: argparse.Namespace, tmp: Path) -> dict[str, Any]:
    from hil.launch import RunRequest, launch

    base = load_scenario("iea15mw-lc2")
    out = {}
    for kind, preset in (("rosco", "iea15mw_volturnus"), ("baseline", "iea15mw_baseline")):
        ctrl = msgspec.structs.replace(base.controller, kind=kind, preset=preset)
        sc = msgspec.structs.replace(base, controller=ctrl, duration_s=args.floating_duration)
        path = tmp / f"lc2-{kind}.toml"
        path.write_text(_toml(sc))
        summary = launch(
            RunRequest(str(path), mode="inprocess", out_dir=tmp / f"lc2-{kind}", plots=False),
            _quiet(),
        )
        out[kind] = summary["kpi"]
    keys = [k for k in out["rosco"] if isinstance(out["rosco"][k], int | float)]
    print(f"\nIEA 15 MW VolturnUS-S, load case 2, {args.floating_duration:.0f} s: KPIs")
    print(f"{'kpi':<40} {'ROSCO':>14} {'baseline':>14}")
    for k in keys:
        print(f"{k:<40} {out['rosco'][k]:>14.5g} {out['baseline'][k]:>14.5g}")
    return {"duration_s": args.floating_duration, "kpi": out}


def cmp_wse(args: argparse.Namespace, tmp: Path) -> dict[str, Any]:
    """Both estimators on the same plant with its Cp table scaled by 0.95."""
    from plant import aero

    presets = Path(aero.__file__).parent / "presets"
    table = aero.read_rosco_table(presets / "iea15mw_cp_ct_cq.txt")
    scaled = aero.PerformanceTable(
        table.pitch_rad,
        table.tsr,
        0.95 * table.cp,
        table.ct,
        0.95 * table.cq,
        table.wind_speeds_m_s,
    )
    aero.write_rosco_table(scaled, tmp / "iea15mw_cp095.txt", "IEA 15 MW, Cp and Cq x 0.95")
    text = (presets / "iea15mw.toml").read_text()
    text = text.replace('table_file = "iea15mw_cp_ct_cq.txt"', 'table_file = "iea15mw_cp095.txt"')
    tdir = tmp / "iea15mw_cp095.toml"
    tdir.write_text(text)
    # The floating plant takes its rotor from the platform preset's `turbine`: point it there.
    ptext = (presets / "floating" / "iea15mw_volturnus.toml").read_text()
    assert 'turbine = "iea15mw"' in ptext
    pdir = tmp / "iea15mw_volturnus_cp095.toml"
    pdir.write_text(ptext.replace('turbine = "iea15mw"', f'turbine = "{tdir}"'))
    out: dict[str, Any] = {"cp_scale": 0.95, "duration_s": args.wse_duration, "cases": {}}
    print(
        f"\nwind-speed estimate, IEA 15 MW VolturnUS-S, plant Cp x 0.95, {args.wse_duration:.0f} s "
        f"(first {args.wse_skip:.0f} s skipped); error relative to the mean true "
        "rotor-effective wind"
    )
    from hil.scenario.schema import SteadyWindSpec

    for case in ("steady-still", "turbulent-lc2"):
        base = load_scenario("iea15mw-still-water" if case == "steady-still" else "iea15mw-lc2")
        for wind in args.wse_winds:
            rows: dict[str, Any] = {}
            for kind, preset in (("rosco", "iea15mw_volturnus"), ("lqri", "iea15mw_advanced")):
                ctrl = msgspec.structs.replace(base.controller, kind=kind, preset=preset)
                if case == "steady-still":
                    wspec: Any = SteadyWindSpec(speed_m_s=wind)
                else:
                    wspec = msgspec.structs.replace(base.wind, mean_m_s=wind)
                sc = msgspec.structs.replace(
                    base,
                    controller=ctrl,
                    duration_s=args.wse_duration,
                    turbine=str(tdir),
                    platform=str(pdir),
                    wind=wspec,
                )
                run_dir = tmp / f"wse-{case}-{kind}-{wind}"
                r = run(sc, run_dir)
                k = r["status_t"] >= args.wse_skip
                truth = np.interp(r["status_t"][k], r["t"], r["wind_speed_m_s"])
                err = (r["wind_est"][k] - truth) / np.mean(truth)
                rows[kind] = {
                    "mean_error_pct": float(100 * np.mean(err)),
                    "rms_error_pct": float(100 * np.sqrt(np.mean(err**2))),
                    "plant_cp_mean": float(
                        np.mean(r["power_coefficient"][r["t"] >= args.wse_skip])
                    ),
                }
                if kind == "rosco":  # ROSCO's flag: EKF operating (1) or anemometer fallback
                    op = _dbg2_column(run_dir / "rosco.RO.dbg2", "WE_Op", args.wse_skip)
                    rows[kind]["we_op_fraction"] = float(np.mean(op == 1.0)) if op.size else None
                print(
                    f"  {case:<14} {wind:4.1f} m/s {kind:<6} "
                    f"mean {rows[kind]['mean_error_pct']:+.2f} %, "
                    f"RMS {rows[kind]['rms_error_pct']:.2f} %"
                    + (
                        f", EKF operating {100 * rows[kind]['we_op_fraction']:.1f} % of the time"
                        if rows[kind].get("we_op_fraction") is not None
                        else ""
                    )
                )
            out["cases"][f"{case}-{wind:g}"] = rows
    return out


def _dbg2_column(path: Path, name: str, skip_s: float) -> Any:
    """One column of ROSCO's .RO.dbg2 after ``skip_s`` (header: banner, names, blank)."""
    if not path.is_file():
        return np.array([])
    lines = path.read_text().splitlines()
    names = lines[1].split()
    data = np.array([[float(v) for v in ln.split()] for ln in lines[3:] if ln.strip()])
    keep = data[:, 0] >= skip_s
    return data[keep, names.index(name)]


def _quiet() -> Any:
    from rich.console import Console

    return Console(quiet=True)


def _toml(sc: Scenario) -> str:
    return _dump_toml(msgspec.to_builtins(sc))


def _dump_toml(d: dict[str, Any], prefix: str = "") -> str:
    """Minimal TOML writer for scenario and preset dicts (tables, arrays of tables)."""
    lines, tables = [], []
    for k, v in d.items():
        if v is None:
            continue
        if isinstance(v, dict):
            tables.append((k, v))
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            for item in v:
                tables.append((f"[{k}]", item))
        else:
            lines.append(f"{k} = {json.dumps(v)}")
    for k, v in tables:
        name = f"{prefix}{k}" if not k.startswith("[") else f"[{prefix}{k[1:-1]}]"
        body = _dump_toml(v, f"{prefix}{k.strip('[]')}.")
        lines.append(f"\n[{name}]\n{body}")
    return "\n".join(lines)


COMPARISONS = {"steady": cmp_steady, "step": cmp_step, "floating": cmp_floating, "wse": cmp_wse}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", default=["steady", "step", "floating", "wse"])
    ap.add_argument(
        "--winds",
        type=float,
        nargs="*",
        default=[5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 16.0, 18.0, 20.0, 24.0],
    )
    ap.add_argument("--duration", type=float, default=90.0, help="steady runs [s]")
    ap.add_argument("--settle", type=float, default=20.0, help="averaging window [s]")
    ap.add_argument("--floating-duration", type=float, default=600.0)
    ap.add_argument("--wse-duration", type=float, default=300.0)
    ap.add_argument("--wse-winds", type=float, nargs="*", default=[9.0, 14.0])
    ap.add_argument("--wse-skip", type=float, default=100.0)
    args = ap.parse_args()
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / "rosco_peer.json"
    results: dict[str, Any] = json.loads(path.read_text()) if path.is_file() else {}
    with tempfile.TemporaryDirectory(prefix="fowt-rosco-peer-") as td:
        tmp = Path(td)
        for name in args.only:
            results[name] = {
                "steady": cmp_steady,
                "step": cmp_step,
                "floating": cmp_floating,
                "wse": cmp_wse,
            }[name](args, tmp)
            results[name]["measured"] = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
            path.write_text(json.dumps(results, indent=2) + "\n")
    print(f"\nsaved {path}")


if __name__ == "__main__":
    main()
