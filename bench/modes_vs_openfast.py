"""Natural periods of ``iea15mw_volturnus`` against the six OpenFAST linearisations.

Usage::

    .venv/bin/python bench/modes_vs_openfast.py [--out bench/results/modes_vs_openfast.json]

For each wind speed of ``../shared/reference/openfast/IEA-15-240-RWT-UMaineSemi/linearizations``
(5, 9, 12, 15, 19, 24 m/s): the bench's damped surge, heave and pitch periods
(:func:`plant.modes.natural_modes`) open loop and in the linearisations' case (below rated,
their ServoDyn torque law in the loop), and those of the ``.lin`` file's A matrix
(:func:`plant.modes.identify_modes`) as written and azimuth-averaged (the generator-azimuth
state dropped; ``tests/test_modes.py``), their differences in per cent, and the diagnostic of
``plant/modes.py``: both A matrices with the tower condensed statically (s̈ = ṡ = 0) and the
rotor speed locked, which removes the rotor-speed loop. Needs ``../shared`` (reference data);
prints a message and exits 2 without it.

Second table, the rotor's aerodynamic derivatives at each operating point (the frozen-wake
question): ∂T/∂Ω, ∂T/∂U, ∂Q/∂Ω, ∂Q/∂U of

* ``table``: the bench's Cp/Ct/Cq table at the bench's trim (what :func:`plant.modes.linearize`
  differentiates; equilibrium wake);
* ``bem_eq`` / ``bem_frozen``: the blade-element model :mod:`plant.rotor_bem` of the deck's
  AeroDyn blade and polars at the same point, induction re-converged / induced velocities held
  (OpenFAST's ``FrozenWake``);
* ``lin``: the ``.lin`` file's own output Jacobians, AeroDyn's ``RtAeroFxh`` and ``RtAeroMxh``
  rows of C (∂/∂ generator speed) and D (∂/∂ hub-height wind input), so no mass matrix enters.

Third, the bench's pitch period with its table derivatives replaced by each set (the
correction A + (∂f/∂T)(ΔT_Ω e_Ω + ΔT_U ∂U_n/∂x) + (∂f/∂Q)(ΔQ_Ω e_Ω + ΔQ_U ∂U_n/∂x), exact
because f is linear in T and Q).
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path

import numpy as np

from plant import turbine as _turbine
from plant.modes import PITCH_LENGTH_M, identify_modes, linearize, operating_point
from plant.platform import DOF_NAMES, FloatingParams, f, load_floating, relative_wind, rotor_thrust
from plant.rotor_bem import derivatives, load_aerodyn_blade

LIN_DIR = (
    Path(__file__).resolve().parents[2]
    / "shared"
    / "reference"
    / "openfast"
    / "IEA-15-240-RWT-UMaineSemi"
    / "linearizations"
)
ROTOR_DIR = LIN_DIR.parents[1] / "IEA-15-240-RWT"
LIN_FILES = {5.0: "00", 9.0: "04", 12.0: "07", 15.0: "10", 19.0: "14", 24.0: "19"}
DOFS = ("surge", "heave", "pitch")
BELOW_RATED = (5.0, 9.0)


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


DERIVS = ("dT_dOmega_N_s", "dT_dU_N_s_m", "dQ_dOmega_N_m_s", "dQ_dU_N_s")


def _lin_aero_derivatives(path: Path) -> dict[str, float]:
    """∂T/∂Ω, ∂T/∂U, ∂Q/∂Ω, ∂Q/∂U from AeroDyn's RtAeroFxh / RtAeroMxh rows of C and D."""
    lines = path.read_text().splitlines()
    mats = {}
    for key in "CD":
        row = next(i for i, s in enumerate(lines) if s.startswith(key + ":"))
        n = int(lines[row].split()[1])
        mats[key] = np.array([[float(v) for v in lines[row + 1 + r].split()] for r in range(n)])
    st = next(i for i, s in enumerate(lines) if s.startswith("Order of outputs"))
    names = lines[st + 3 : st + 3 + mats["C"].shape[0]]
    it = next(i for i, s in enumerate(names) if "RtAeroFxh" in s)
    iq = next(i for i, s in enumerate(names) if "RtAeroMxh" in s)
    # States: generator speed is column 10 (index 9); inputs: hub-height wind is column 1.
    c, d = mats["C"], mats["D"]
    return {
        "dT_dOmega_N_s": float(c[it, 9]),
        "dT_dU_N_s_m": float(d[it, 0]),
        "dQ_dOmega_N_m_s": float(c[iq, 9]),
        "dQ_dU_N_s": float(d[iq, 0]),
    }


def _scaled(p: FloatingParams, k_thrust: float = 1.0, k_torque: float = 1.0) -> FloatingParams:
    """Copy of ``p`` with the rotor's thrust and torque scaled (for ∂f/∂T and ∂f/∂Q)."""
    tp = copy.copy(p.turbine)
    object.__setattr__(tp, "k_thrust", p.turbine.k_thrust * k_thrust)
    object.__setattr__(tp, "k_torque", p.turbine.k_torque * k_torque)
    q = copy.copy(p)
    object.__setattr__(q, "turbine", tp)
    return q


def _table_point(p: FloatingParams, op_state: tuple[float, ...], wind: float) -> dict[str, float]:
    x0 = np.array(op_state)
    un = relative_wind(x0, wind, p)
    w, th, tp = float(x0[8]), float(x0[9]), p.turbine

    def thrust(w_: float, u_: float) -> float:
        return rotor_thrust(w_, th, u_, tp)

    def torque(w_: float, u_: float) -> float:
        return _turbine.outputs(0.0, (w_, th, 0.0), (th, 0.0, u_), tp).aero_torque_nm

    hw, hu = 1e-4 * w, 1e-4 * un
    return {
        "omega_rad_s": w,
        "pitch_rad": th,
        "wind_n_m_s": un,
        "thrust_n": thrust(w, un),
        "torque_nm": torque(w, un),
        "dT_dOmega_N_s": (thrust(w + hw, un) - thrust(w - hw, un)) / (2 * hw),
        "dT_dU_N_s_m": (thrust(w, un + hu) - thrust(w, un - hu)) / (2 * hu),
        "dQ_dOmega_N_m_s": (torque(w + hw, un) - torque(w - hw, un)) / (2 * hw),
        "dQ_dU_N_s": (torque(w, un + hu) - torque(w, un - hu)) / (2 * hu),
    }


def _with_derivatives(
    p: FloatingParams,
    op_state: tuple[float, ...],
    inputs: tuple[float, ...],
    wind: float,
    a: np.ndarray,
    table: dict[str, float],
    new: dict[str, float],
) -> np.ndarray:
    """A with the table's ∂T/∂(Ω, U_n), ∂Q/∂(Ω, U_n) replaced by ``new`` (docstring)."""
    x0 = np.array(op_state)
    e = 1e-3
    dfdt = (
        np.array(f(0, op_state, inputs, _scaled(p, 1 + e)))
        - np.array(f(0, op_state, inputs, _scaled(p, 1 - e)))
    ) / (2 * e * table["thrust_n"])
    dfdq = (
        np.array(f(0, op_state, inputs, _scaled(p, 1, 1 + e)))
        - np.array(f(0, op_state, inputs, _scaled(p, 1, 1 - e)))
    ) / (2 * e * table["torque_nm"])
    h = 1e-6
    eye = np.eye(x0.size)
    du = np.array(
        [
            (relative_wind(x0 + h * eye[i], wind, p) - relative_wind(x0 - h * eye[i], wind, p))
            / (2 * h)
            for i in range(x0.size)
        ]
    )
    ew = eye[8]
    rt = (new["dT_dOmega_N_s"] - table["dT_dOmega_N_s"]) * ew + (
        new["dT_dU_N_s_m"] - table["dT_dU_N_s_m"]) * du  # fmt: skip
    rq = (new["dQ_dOmega_N_m_s"] - table["dQ_dOmega_N_m_s"]) * ew + (
        new["dQ_dU_N_s"] - table["dQ_dU_N_s"]) * du  # fmt: skip
    return a + np.outer(dfdt, rt) + np.outer(dfdq, rq)


def _pitch_period(a: np.ndarray) -> float:
    modes = identify_modes(a, range(4), range(4, 8), DOF_NAMES, (1.0, 1.0, PITCH_LENGTH_M, 1.0))
    return next(m.period_s for m in modes if m.name == "pitch")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("bench/results/modes_vs_openfast.json"))
    args = ap.parse_args()
    if not LIN_DIR.is_dir():
        print(f"reference linearisations not found at {LIN_DIR} (../shared absent)")
        return 2
    params = load_floating("iea15mw_volturnus")
    rows = []
    print("bench: open loop (blade pitch, generator torque held; rotor speed free) and the")
    print("linearisations' case (below rated their ServoDyn torque law in the loop, slope from")
    print("the file); lin: A as written (azimuth 0.014 rad) and azimuth-averaged (generator")
    print("azimuth state dropped: the mean of the 3P load slope over a revolution is zero)")
    print(f"{'U':>4} {'DOF':>6} {'open':>8} {'case':>8} {'lin':>8} {'lin avg':>8} "
          f"{'open/lin':>9} {'case/avg':>9}   {'locked':>7} {'lin lck':>7} "
          f"{'diff':>6}")  # fmt: skip
    for wind, tag in LIN_FILES.items():
        a_of, op_of = _read_lin(LIN_DIR / f"lin_{tag}.1.lin")
        op = operating_point(params, wind)
        a = linearize(params, op)
        of = _periods(a_of, [0, 1, 2, 3], [5, 6, 7, 8])
        keep = [i for i in range(a_of.shape[0]) if i != 4]
        ofa = _periods(a_of[np.ix_(keep, keep)], [0, 1, 2, 3], [4, 5, 6, 7])
        us = _periods(a, [0, 1, 2, 3], [4, 5, 6, 7])
        # Below rated: ServoDyn's torque law of the linearisation, k = −(∂ω̇/∂ω|lin − aero) J.
        slope = -(a_of[9, 9] - a[8, 8]) * params.turbine.drivetrain_inertia_kg_m2
        slope = slope if wind in BELOW_RATED else 0.0
        ac = a.copy()
        ac[10, 8] += slope * params.turbine.inv_torque_tau
        uc = _periods(ac, [0, 1, 2, 3], [4, 5, 6, 7])
        # OpenFAST states: q0..3, generator azimuth 4, rates 5..8, rotor speed 9, HydroDyn after.
        ofl = _periods(_condense_lock(a_of, 3, 8, [4, 9]), [0, 1, 2], [3, 4, 5])
        # Bench states: q0..3, rates 4..7, rotor speed 8, blade pitch 9, torque 10, radiation.
        usl = _periods(_condense_lock(a, 3, 7, [8, 9, 10]), [0, 1, 2], [3, 4, 5])
        for dof in DOFS:
            d = 100.0 * (us[dof] / of[dof] - 1.0)
            dc = 100.0 * (uc[dof] / ofa[dof] - 1.0)
            dl = 100.0 * (usl[dof] / ofl[dof] - 1.0)
            print(f"{wind:4.0f} {dof:>6} {us[dof]:8.2f} {uc[dof]:8.2f} {of[dof]:8.2f} "
                  f"{ofa[dof]:8.2f} {d:+8.1f}% {dc:+8.1f}%   {usl[dof]:7.2f} {ofl[dof]:7.2f} "
                  f"{dl:+5.1f}%")  # fmt: skip
            rows.append(
                {
                    "wind_m_s": wind,
                    "dof": dof,
                    "bench_open_loop_s": us[dof],
                    "bench_case_s": uc[dof],
                    "torque_slope_nm_s_rad": slope,
                    "openfast_s": of[dof],
                    "openfast_azimuth_averaged_s": ofa[dof],
                    "open_loop_vs_openfast_percent": d,
                    "case_vs_azimuth_averaged_percent": dc,
                    "rotor_locked_bench_s": usl[dof],
                    "rotor_locked_openfast_s": ofl[dof],
                    "rotor_locked_diff_percent": dl,
                }
            )
        print(f"{'':4} trim: surge {op.state[0]:.2f} m (lin {op_of[0]:.2f}), platform pitch "
              f"{op.state[2]:.4f} rad (lin {op_of[2]:.4f}), tower {us.get('tower_fore_aft', 0):.2f}"
              f" s (lin {of.get('tower_fore_aft', 0):.2f}); torque slope {slope:.3g} "
              "N m s/rad")  # fmt: skip
    deriv_rows = _derivative_table(params)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(
        json.dumps(
            {
                "case": "open loop; case: below rated the linearisation's torque law in the loop",
                "reference": "lin A as written, and azimuth-averaged (generator azimuth dropped)",
                "rows": rows,
                "aero_derivatives": deriv_rows,
            },
            indent=2,
        )
        + "\n"
    )
    print(f"wrote {args.out}")
    return 0


def _derivative_table(params: FloatingParams) -> list[dict[str, object]]:
    polars = [ROTOR_DIR / "Airfoils" / f"IEA-15-240-RWT_AeroDyn15_Polar_{k:02d}.dat"
              for k in range(50)]  # fmt: skip
    # ElastoDyn HubRad 3.97 m, PreCone -4 deg (the deck's IEA-15-240-RWT-UMaineSemi_ElastoDyn.dat).
    blade = load_aerodyn_blade(ROTOR_DIR / "IEA-15-240-RWT_AeroDyn15_blade.dat", polars, 3.97, -4.0)
    out: list[dict[str, object]] = []
    print()
    print("rotor derivatives at the bench's trim (table, BEM equilibrium / frozen wake) and the")
    print("lin file's AeroDyn output Jacobians (RtAeroFxh, RtAeroMxh); ratio to lin in brackets")
    print(f"{'U':>4} {'source':>10} {'dT/dW N s':>16} {'dT/dU N s/m':>16} {'dQ/dW N m s':>16} "
          f"{'dQ/dU N s':>16} {'pitch T s':>10}")  # fmt: skip
    for wind, tag in LIN_FILES.items():
        path = LIN_DIR / f"lin_{tag}.1.lin"
        op = operating_point(params, wind)
        a = linearize(params, op)
        table = _table_point(params, op.state, wind)
        w, th, un = table["omega_rad_s"], table["pitch_rad"], table["wind_n_m_s"]
        sets = {
            "table": {k: table[k] for k in DERIVS},
            "bem_eq": derivatives(blade, w, un, th, "equilibrium"),
            "bem_frozen": derivatives(blade, w, un, th, "frozen"),
            "lin": _lin_aero_derivatives(path),
        }
        a_of, _ = _read_lin(path)
        for name, d in sets.items():
            period = _pitch_period(
                _with_derivatives(params, op.state, op.inputs, wind, a, table, d)
            )
            row: dict[str, object] = {"wind_m_s": wind, "source": name, "pitch_period_s": period}
            extra = ""
            if name == "lin":
                own = _periods(a_of, [0, 1, 2, 3], [5, 6, 7, 8])["pitch"]
                keep = [i for i in range(a_of.shape[0]) if i != 4]
                avg = _periods(a_of[np.ix_(keep, keep)], [0, 1, 2, 3], [4, 5, 6, 7])["pitch"]
                row["openfast_pitch_period_s"] = own
                row["openfast_azimuth_averaged_pitch_period_s"] = avg
                extra = f"  (OpenFAST's own: {own:.2f}, azimuth-averaged {avg:.2f})"
            row.update({k: float(d[k]) for k in DERIVS})
            out.append(row)
            cells = " ".join(f"{d[k]:10.3e} ({d[k] / sets['lin'][k]:5.2f})" for k in DERIVS)
            print(f"{wind:4.0f} {name:>10} {cells} {period:10.2f}{extra}")
    print("pitch T: damped pitch period of the bench with that set of derivatives in its A")
    return out


if __name__ == "__main__":
    sys.exit(main())
