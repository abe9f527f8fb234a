"""The slow surge growth of the IEA 15 MW baseline near rated, with and without peak shaving.

Steady wind (default 11 m/s), still water, the scenario's sensors (generator-speed encoder
of the shipped IEA 15 MW scenarios, the other channels' defaults), trimmed start, in
process, ``--duration`` s (default 3600). Three variants of the baseline preset
``iea15mw_baseline``, written to a temporary folder beside their C_p table:

* ``shipped``: the minimum-pitch (peak-shaving) schedule as shipped, on the filtered wind
  estimate;
* ``flat``: the same minimum pitch at every wind, the trimmed pitch of the shipped run's
  wind (the blades held where the shipped schedule holds them, not following the estimate);
* ``none``: no minimum pitch above fine pitch (the pitch PI acts from rated on).

Per variant the platform surge's and the blade pitch's standard deviations over windows of
the run (0-60, 60-200, 200-400, 400-600, 600-900 s, then every 900 s) and the pitch's mean.

    python bench/peak_shaving_surge.py [--wind 11] [--duration 3600]

Saves ``bench/results/peak_shaving_surge.json``.
"""

from __future__ import annotations

import argparse
import functools
import itertools
import math
import re
import shutil
import sys
import tempfile
import time
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from _common import save
from trimmed_start import TABLE_SCENARIO

from bus_schemas.registry import TRUTH
from hil.inprocess.run import run_inprocess
from hil.inprocess.trim import initial_condition, operating_point
from hil.nodes.controller_node import ControllerRuntime, publishing_step
from hil.scenario.schema import parse_scenario

_SCHEDULE = re.compile(r"min_pitch_schedule_rad = \[[^\]]*\]", re.S)


def _preset(folder: Path, variant: str, flat_rad: float) -> str:
    """The baseline preset of ``variant`` as a file in ``folder`` (the shipped name for
    ``shipped``)."""
    if variant == "shipped":
        return "iea15mw_baseline"
    presets = resources.files("controller.presets")
    text = presets.joinpath("iea15mw_baseline.toml").read_text()
    value = 0.0 if variant == "none" else flat_rad
    n = len(tomllib.loads(text)["min_pitch_schedule_rad"])
    text = _SCHEDULE.sub(f"min_pitch_schedule_rad = [{', '.join([f'{value:.6f}'] * n)}]", text)
    with resources.as_file(presets.joinpath("iea15mw_cp_ct_cq.txt")) as cp:
        shutil.copy(cp, folder / "iea15mw_cp_ct_cq.txt")
    path = folder / f"iea15mw_baseline_{variant}.toml"
    path.write_text(text)
    return str(path)


def _windows(duration: float) -> list[tuple[float, float]]:
    edges = [0.0, 60.0, 200.0, 400.0, 600.0, 900.0]
    while edges[-1] + 900.0 <= duration:
        edges.append(edges[-1] + 900.0)
    return [(a, b) for a, b in itertools.pairwise(edges) if b <= duration]


def run(variant: str, preset: str, wind: float, duration: float) -> dict[str, Any]:
    """One variant's run: its trim and the windows' statistics."""
    # --table's steady, still, trimmed case of bench/trimmed_start.py, with this preset
    sc = parse_scenario(
        TABLE_SCENARIO.format(
            kind="baseline", turbine="iea15mw", platform="iea15mw_volturnus", preset=preset,
            wind=wind, duration=duration,
        )
    )  # fmt: skip
    ic = initial_condition(sc)
    runtime = ControllerRuntime(
        sc, paced=False, operating_point=functools.partial(operating_point, sc)
    )
    rows: list[tuple[float, float, float]] = []

    def publish(mt: object, msg: Any) -> None:
        if mt is TRUTH:
            rows.append((msg.sample_time_ns * 1e-9, msg.platform_surge_m, msg.blade_pitch_rad))

    run_inprocess(sc, publish, publishing_step(runtime, publish), runtime=runtime)
    a = np.array(rows)
    windows = []
    for lo, hi in _windows(duration):
        m = (a[:, 0] >= lo) & (a[:, 0] < hi)
        windows.append(
            {
                "from_s": lo,
                "to_s": hi,
                "surge_std_m": round(float(np.std(a[m, 1])), 4),
                "pitch_mean_deg": round(math.degrees(float(np.mean(a[m, 2]))), 3),
                "pitch_std_deg": round(math.degrees(float(np.std(a[m, 2]))), 4),
            }
        )
        print(variant, windows[-1], flush=True)
    assert ic.blade_pitch_rad is not None and ic.rotor_speed_rad_s is not None
    return {
        "trim_pitch_deg": round(math.degrees(ic.blade_pitch_rad), 3),
        "trim_rotor_rpm": round(ic.rotor_speed_rad_s * 30.0 / math.pi, 4),
        "windows": windows,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wind", type=float, default=11.0, help="steady wind [m/s]")
    ap.add_argument("--duration", type=float, default=3600.0, help="simulated seconds")
    args = ap.parse_args()
    t0 = time.perf_counter()
    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="fowt-ps-") as tmp:
        out["shipped"] = run("shipped", "iea15mw_baseline", args.wind, args.duration)
        flat = math.radians(out["shipped"]["trim_pitch_deg"])
        for variant in ("flat", "none"):
            preset = _preset(Path(tmp), variant, flat)
            out[variant] = run(variant, preset, args.wind, args.duration)
    save(
        "peak_shaving_surge",
        {
            "command": f"python bench/peak_shaving_surge.py --wind {args.wind:g}"
            f" --duration {args.duration:g}",
            "wind_m_s": args.wind,
            "duration_s": args.duration,
            "variants": out,
            "wall_s": round(time.perf_counter() - t0, 1),
        },
    )


if __name__ == "__main__":
    sys.exit(main())
