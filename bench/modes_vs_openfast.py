"""Natural periods of ``iea15mw_volturnus`` against the six OpenFAST linearisations.

Usage::

    .venv/bin/python bench/modes_vs_openfast.py [--out bench/results/modes_vs_openfast.json]

For each wind speed of ``../shared/reference/openfast/IEA-15-240-RWT-UMaineSemi/linearizations``
(5, 9, 12, 15, 19, 24 m/s): the bench's damped surge, heave and pitch periods
(:func:`plant.modes.natural_modes`, open loop) and those of the ``.lin`` file's A matrix
(:func:`plant.modes.identify_modes`), their difference in per cent, and the diagnostic of
``plant/modes.py``: both A matrices with the tower condensed statically (s̈ = ṡ = 0) and the
rotor speed locked, which removes the rotor-speed loop. Needs ``../shared`` (reference data);
prints a message and exits 2 without it.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from plant.modes import PITCH_LENGTH_M, identify_modes, linearize, operating_point
from plant.platform import load_floating

LIN_DIR = (
    Path(__file__).resolve().parents[2]
    / "shared"
    / "reference"
    / "openfast"
    / "IEA-15-240-RWT-UMaineSemi"
    / "linearizations"
)
LIN_FILES = {5.0: "00", 9.0: "04", 12.0: "07", 15.0: "10", 19.0: "14", 24.0: "19"}
DOFS = ("surge", "heave", "pitch")


def _read_lin(path: Path) -> tuple[np.ndarray, list[float]]:
    lines = path.read_text().splitlines()
    start = next(i for i, s in enumerate(lines) if s.startswith("Order of continuous states:"))
    op = [float(lines[start + 3 + k].split()[1]) for k in range(10)]
    row = next(i for i, s in enumerate(lines) if s.startswith("A:"))
    n = int(lines[row].split()[1])
    return np.array([[float(v) for v in lines[row + 1 + r].split()] for r in range(n)]), op


def _periods(a: np.ndarray, pos: list[int], vel: list[int]) -> dict[str, float]:
    names = list(DOFS) + ["tower_fore_aft"][: len(pos) - 3]
    scale = (1.0, 1.0, PITCH_LENGTH_M, 1.0)[: len(pos)]
    return {m.name: m.period_s for m in identify_modes(a, pos, vel, names, scale)}


def _condense_lock(a: np.ndarray, s: int, sd: int, rotor: list[int]) -> np.ndarray:
    """Tower condensed statically (s from the s̈ row with s̈ = ṡ = 0), rotor states removed."""
    keep = [i for i in range(a.shape[0]) if i not in (s, sd)]
    t = -a[sd, keep] / a[sd, s]
    c = a[np.ix_(keep, keep)] + np.outer(a[keep, s], t)
    # Rotor states (indices in the full matrix) map to the condensed order.
    drop = [keep.index(i) for i in rotor]
    rest = [i for i in range(c.shape[0]) if i not in drop]
    return c[np.ix_(rest, rest)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("bench/results/modes_vs_openfast.json"))
    args = ap.parse_args()
    if not LIN_DIR.is_dir():
        print(f"reference linearisations not found at {LIN_DIR} (../shared absent)")
        return 2
    params = load_floating("iea15mw_volturnus")
    rows = []
    print("open loop (blade pitch and generator torque held, rotor speed free)")
    print(f"{'U m/s':>6} {'DOF':>6} {'bench s':>8} {'lin s':>8} {'diff %':>7}   "
          f"{'locked bench':>12} {'locked lin':>10} {'diff %':>7}")  # fmt: skip
    for wind, tag in LIN_FILES.items():
        a_of, op_of = _read_lin(LIN_DIR / f"lin_{tag}.1.lin")
        op = operating_point(params, wind)
        a = linearize(params, op)
        of = _periods(a_of, [0, 1, 2, 3], [5, 6, 7, 8])
        us = _periods(a, [0, 1, 2, 3], [4, 5, 6, 7])
        # OpenFAST states: q0..3, generator azimuth 4, rates 5..8, rotor speed 9, HydroDyn after.
        ofl = _periods(_condense_lock(a_of, 3, 8, [4, 9]), [0, 1, 2], [3, 4, 5])
        # Bench states: q0..3, rates 4..7, rotor speed 8, blade pitch 9, torque 10, radiation.
        usl = _periods(_condense_lock(a, 3, 7, [8, 9, 10]), [0, 1, 2], [3, 4, 5])
        for dof in DOFS:
            d = 100.0 * (us[dof] / of[dof] - 1.0)
            dl = 100.0 * (usl[dof] / ofl[dof] - 1.0)
            print(f"{wind:6.0f} {dof:>6} {us[dof]:8.2f} {of[dof]:8.2f} {d:+7.1f}   "
                  f"{usl[dof]:12.2f} {ofl[dof]:10.2f} {dl:+7.1f}")  # fmt: skip
            rows.append(
                {
                    "wind_m_s": wind,
                    "dof": dof,
                    "bench_s": us[dof],
                    "openfast_s": of[dof],
                    "diff_percent": d,
                    "rotor_locked_bench_s": usl[dof],
                    "rotor_locked_openfast_s": ofl[dof],
                    "rotor_locked_diff_percent": dl,
                }
            )
        print(f"{'':6} trim: surge {op.state[0]:.2f} m (lin {op_of[0]:.2f}), platform pitch "
              f"{op.state[2]:.4f} rad (lin {op_of[2]:.4f}), tower {us.get('tower_fore_aft', 0):.2f}"
              f" s (lin {of.get('tower_fore_aft', 0):.2f})")  # fmt: skip
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"case": "open loop", "rows": rows}, indent=2) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
