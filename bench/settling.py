"""Start-up settling time of the floating plant in steady wind and still water.

(``[review] settle_s``'s default is based on ``bench/trimmed_start.py``, which measures
trimmed and untrimmed starts side by side; this script runs the scenario's own start.)

Runs the IEA 15 MW on VolturnUS-S with its baseline controller in steady wind and still
water in process (no turbulence, no waves: what is left is the start-up transient) and
reports, per signal, the time after which the 20 s moving mean stays within 2 % of the
mean over the last 100 s. Prints and saves ``bench/results/settling.json``.

    python bench/settling.py [--duration 400] [--wind 7.1]
"""

from __future__ import annotations

import argparse
import io
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from _common import save
from rich.console import Console

from hil.launch import RunRequest, launch
from hil.runlog.mcap_io import read_run

SIGNALS = ("rotor_speed_rad_s", "tower_base_moment_nm", "platform_pitch_rad", "platform_surge_m")

SCENARIO = """
name = "settling-{wind}"
turbine = "iea15mw"
platform = "iea15mw_volturnus"
duration_s = {duration}
[wind]
kind = "steady"
speed_m_s = {wind}
[waves]
kind = "still"
gauge_distance_m = 450.0
[timing]
control_period_s = 0.025
plant_step_s = 0.0125
[controller]
kind = "baseline"
preset = "iea15mw_baseline"
"""


def settling_s(t: np.ndarray, x: np.ndarray, window_s: float = 20.0, band: float = 0.02) -> float:
    """First time after which the moving mean over ``window_s`` stays within ``band`` of the
    final mean (last 100 s); the time is that of the window's end [s]."""
    dt = float(np.median(np.diff(t)))
    w = max(1, round(window_s / dt))
    ma = np.convolve(x, np.ones(w) / w, mode="valid")
    tm = t[w - 1 :]
    final = float(x[t > t[-1] - 100.0].mean())
    out = np.flatnonzero(np.abs(ma - final) > band * abs(final))
    return float(tm[out[-1] + 1]) if out.size and out[-1] + 1 < tm.size else float(tm[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=400.0)
    ap.add_argument("--wind", type=float, default=7.1)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="fowt-settling-") as tmp:
        toml = Path(tmp) / "settling.toml"
        toml.write_text(SCENARIO.format(wind=args.wind, duration=args.duration))
        out = Path(tmp) / "run"
        quiet = Console(file=io.StringIO())
        launch(RunRequest(scenario=str(toml), mode="inprocess", out_dir=out, plots=False), quiet)
        truth = read_run(out / "run.mcap").topic("truth")
    t = np.array([m["sample_time_ns"] for m in truth]) / 1e9
    result: dict[str, Any] = {
        "scenario": "IEA 15 MW VolturnUS-S, baseline, steady wind, still water",
        "wind_m_s": args.wind,
        "duration_s": args.duration,
        "criterion": "20 s moving mean within 2 % of the mean over the last 100 s",
        "settling_s": {
            name: round(settling_s(t, np.array([m[name] for m in truth])), 1) for name in SIGNALS
        },
    }
    print(result)
    save("settling", result)


if __name__ == "__main__":
    main()
