"""christiansen-2013's case (section 3-5) on the OC3-Hywind spar: baseline vs LQR1 vs LQR2.

Runs (or reads, with ``--runs DIR`` holding ``<scenario>/run.mcap`` from ``fowt run ...
--mode inprocess``) the nine shipped scenarios ``oc3-hywind-tp{2,5,10}-{baseline,lqr1,lqr2}``
(18 m/s, TI 14.9 %, JONSWAP Hs 6 m, Tp 2/5/10 s, 600 s, aligned), and prints, per peak period,
the change of each controller against the detuned baseline of the seed's Figure 12 measures:
standard deviation of platform pitch, of electrical power and of the tower-top fore-aft
deflection (the tower mode coordinate), the blade-pitch travel ∫|β̇|dt ("abs" in the seed),
and the mean electrical power. Statistics over the whole run after ``SETTLE_S``. Saves JSON to
``bench/results/christiansen_case.json``.

Usage::

    python bench/christiansen_case.py [--runs DIR]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from hil.runlog.mcap_io import read_run

RESULTS = Path(__file__).resolve().parent / "results"
SETTLE_S = 60.0
CONTROLLERS = ("baseline", "lqr1", "lqr2")
PERIODS = (2, 5, 10)
#: The seed's reading of its Figure 12 (LQR2 vs the detuned baseline, aligned waves).
SEED = {
    "platform_pitch_std": "about -50 %",
    "pitch_travel": "about +150 %",
    "electrical_power": "improved 7-20 %",
    "tower_fore_aft_std": "improved 5-17 %",
}


def measures(mcap: Path) -> dict[str, float]:
    """The seed's measures from one run's truth channel."""
    run = read_run(mcap)
    truth = run.topic("truth")
    t = np.array([m["sample_time_ns"] for m in truth]) * 1e-9
    keep = t >= SETTLE_S

    def col(name: str) -> np.ndarray:
        return np.array([m[name] for m in truth], dtype=float)[keep]

    pitch = col("blade_pitch_rad")
    dt = float(np.median(np.diff(t)))
    return {
        "platform_pitch_std_deg": float(np.degrees(col("platform_pitch_rad").std())),
        "electrical_power_std_w": float(col("electrical_power_w").std()),
        "electrical_power_mean_w": float(col("electrical_power_w").mean()),
        "tower_fore_aft_std_m": float(col("tower_top_displacement_m").std()),
        "pitch_travel_deg": float(np.degrees(np.abs(np.diff(pitch)).sum())),
        "rotor_speed_std_rad_s": float(col("rotor_speed_rad_s").std()),
        "duration_s": float(keep.sum() * dt),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=Path, help="folder with <scenario>/run.mcap (else run them)")
    args = ap.parse_args()
    runs = args.runs or Path(tempfile.gettempdir()) / "christiansen_runs"
    table: dict[str, dict[str, dict[str, float]]] = {}
    for tp in PERIODS:
        table[f"tp{tp}"] = {}
        for c in CONTROLLERS:
            name = f"oc3-hywind-tp{tp}-{c}"
            mcap = runs / name / "run.mcap"
            if not mcap.is_file():
                cmd = [sys.executable, "-m", "hil", "run", name, "--mode", "inprocess"]
                cmd += ["--out", str(runs / name), "--no-plots"]
                subprocess.run(cmd, check=True, capture_output=True)
            table[f"tp{tp}"][c] = measures(mcap)
    rel: dict[str, dict[str, dict[str, float]]] = {}
    for tp, rows in table.items():
        base = rows["baseline"]
        rel[tp] = {
            c: {k: 100.0 * (rows[c][k] / base[k] - 1.0) for k in base if k != "duration_s"}
            for c in ("lqr1", "lqr2")
        }
    for tp, rows in rel.items():
        for c, r in rows.items():
            print(tp, c, "  ".join(f"{k} {v:+.1f}%" for k, v in r.items()))
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / "christiansen_case.json"
    out.write_text(
        json.dumps({"absolute": table, "percent_vs_baseline": rel, "seed": SEED}, indent=1) + "\n"
    )
    print(f"saved {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
