"""Natural periods of the OC3-Hywind and OC4-DeepCwind decks imported unedited, vs published.

Usage::

    .venv/bin/python bench/openfast_import_periods.py [--panel 2.0] [--n-theta 16] [--n-omega 60]

For each platform (OC3-Hywind spar, OC4-DeepCwind semi) and each format generation (FAST v8 /
pre-3.5, OpenFAST 4) :func:`plant.reference_decks.write_deck` writes an r-test-style deck from
the published figures (OC3 hydrodynamics: the shipped capytaine spar data; OC4: capytaine of
the four columns, :func:`plant.hydro.semi_bem.semi_bem`, with the pontoons and braces as
strip-theory members). Each deck is then imported unedited with the command line
``fowt preset import-openfast DECK.fst --out DIR --name STEM --turbine nrel5mw`` and its
parked periods computed with ``fowt analyze modes DIR/STEM.toml --wind 0 --json`` (both run
as child processes, as a user would). Saved: the damped surge, heave and pitch periods beside
the published ones with the deviation in per cent, and the imported platform's mass, CM and
pitch inertia beside the deck's own totals; as diagnostics, the periods with the
infinite-frequency added mass and no radiation memory, and an uncoupled surge budget.
Needs the ``[hydro]`` extra (capytaine) for the OC4 hydrodynamics; prints a message and
exits 2 without it.

Published periods:

* OC3-Hywind: Jonkman (2010), NREL/TP-500-47535, full-system natural frequencies (FAST
  linearisation): surge 0.0080 Hz, heave 0.0324 Hz, pitch 0.0343 Hz, yaw 0.1210 Hz; the pitch
  figure (0.034 Hz, full system) is confirmed by the definition's author on the NREL forum.
* OC4-DeepCwind: Robertson et al. (2014), NREL/TP-5000-60601, natural periods of the full
  system: surge 107 s, heave 17.5 s, pitch 26.8 s, yaw 82.3 s (the OC4 Phase II results paper,
  Robertson et al. 2014 OMAE, Fig. 3: surge 0.0093 Hz, heave 0.0578 Hz, pitch 0.0373 Hz).

The model has surge, heave, pitch and the first tower fore-aft mode (no yaw DOF), so yaw is
listed as not available.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import save

ROOT = Path(__file__).resolve().parent.parent

#: Published full-system periods (s); None: not published / not a DOF of the model.
PUBLISHED: dict[str, dict[str, float]] = {
    "oc3": {"surge": 1 / 0.0080, "heave": 1 / 0.0324, "pitch": 1 / 0.0343, "yaw": 1 / 0.1210},
    "oc4": {"surge": 107.0, "heave": 17.5, "pitch": 26.8, "yaw": 82.3},
}
SOURCES = {
    "oc3": "Jonkman (2010), NREL/TP-500-47535, full-system natural frequencies (Hz inverted)",
    "oc4": "Robertson et al. (2014), NREL/TP-5000-60601, full-system natural periods",
}
#: The deck's own platform totals (ElastoDyn PtfmMass, PtfmCMzt, PtfmPIner; for OC4 the
#: definition's totals with the HydroDyn fill-group ballast, Robertson 2014 Table 3-2).
DECK_TOTALS: dict[str, dict[str, float]] = {
    "oc3": {"mass_kg": 7_466_330.0, "cm_z_m": -89.9155, "pitch_inertia_kg_m2": 4.22923e9},
    "oc4": {"mass_kg": 1.3473e7, "cm_z_m": -13.46, "pitch_inertia_kg_m2": 6.827e9},
}


def _fowt(*args: str) -> str:
    """Run the ``fowt`` command line of this checkout; its stdout (raises on failure)."""
    cmd = [sys.executable, "-m", "hil", *args]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(args[:2])} failed:\n{done.stdout}\n{done.stderr}")
    return done.stdout


def _periods_without_memory(toml: Path) -> dict[str, float]:
    """Diagnostic: the periods with the added mass at infinite frequency A_∞ and no radiation
    memory (``load_floating(..., radiation=False)``), i.e. without the frequency dependence
    of the added mass and damping."""
    from plant.modes import natural_modes
    from plant.platform import load_floating

    modes = natural_modes(load_floating(toml, radiation=False), 0.0)
    return {m.name: round(m.period_s, 3) for m in modes if m.name != "tower_fore_aft"}


def _truncated_memory_added_mass(rad: Any, i: int, w: float, t_max_s: float) -> float:
    """The surge added mass a time-domain model sees at ω when its radiation memory stops
    at ``t_max_s`` (OpenFAST's ``RdtnTMax``): A_∞ − (1/ω) ∫₀^T K(t) sin(ωt) dt, with the
    kernel K(t) = (2/π) ∫ B(ω') cos(ω't) dω' over the data's frequencies (trapezoids, B = 0
    outside them). With T → ∞ it is A(ω) (Kramers-Kronig)."""
    omega = np.asarray(rad.omega_rad_s, dtype=np.float64)
    damping = np.asarray(rad.damping[:, i, i], dtype=np.float64)
    t = np.arange(0.0, t_max_s + 1e-9, 0.05)
    kernel = 2.0 / math.pi * np.trapezoid(damping * np.cos(np.outer(t, omega)), omega, axis=1)
    memory = float(np.trapezoid(kernel * np.sin(w * t), t))
    return float(rad.added_mass_inf[i, i]) - memory / w


def _surge_budget(toml: Path, hydro: Any, period_s: float, published_s: float) -> dict[str, float]:
    """Uncoupled surge estimate T = 2π √((m + A₁₁(ω) + A_m)/k₁₁) from the imported preset.

    m: the whole turbine's mass (platform, ballast, tower, RNA); A₁₁(ω): the WAMIT data's
    surge added mass at the computed surge frequency (interpolated); A_m: the strip-theory
    members' surge added mass; k₁₁: the mooring's surge stiffness at zero offset. Also the
    A₁₁ that the published period implies with the same m, A_m and k₁₁.
    """
    from plant.hydro.wamit import load_hydro_preset
    from plant.platform import load_floating, read_floating_preset

    preset, _, _ = read_floating_preset(toml)
    fp = load_floating(toml, radiation=False)
    data = hydro if hydro is not None else load_hydro_preset("nrel5mw_oc3_hywind")
    rad = data.radiation
    i = data.dofs.index(0)
    a_inf = float(rad.added_mass_inf[i, i])
    a_members = float(preset.member_added_mass[0][0]) if preset.member_added_mass else 0.0
    mass = float(fp.mass_matrix[0, 0]) - a_inf - a_members
    w = 2.0 * math.pi / period_s
    a_w = float(np.interp(w, rad.omega_rad_s, rad.added_mass[:, i, i]))
    x = fp.mooring.surge_m
    j = int(np.argmin(np.abs(x)))
    k11 = -float(
        (fp.mooring.force_surge_n[j + 1] - fp.mooring.force_surge_n[j - 1]) / (x[j + 1] - x[j - 1])
    )
    return {
        "mass_kg": round(mass, 1),
        "added_mass_at_surge_frequency_kg": round(a_w, 1),
        "added_mass_truncated_memory_kg": {
            f"{t_max:g} s": round(_truncated_memory_added_mass(rad, i, w, t_max), 1)
            for t_max in (30.0, 60.0)
        },
        "added_mass_infinite_frequency_kg": round(a_inf, 1),
        "members_added_mass_kg": round(a_members, 1),
        "mooring_stiffness_n_m": round(k11, 1),
        "uncoupled_period_s": round(2.0 * math.pi * math.sqrt((mass + a_w + a_members) / k11), 2),
        "added_mass_implied_by_published_kg": round(
            (published_s / (2.0 * math.pi)) ** 2 * k11 - mass - a_members, 1
        ),
    }


def run(panel_m: float, n_theta: int, n_omega: int) -> dict[str, Any]:
    """Write, import and analyse the four decks; the figures to save."""
    from plant.reference_decks import GENERATIONS, oc4_hydro, write_deck

    oc4, oc4_desc = oc4_hydro(n_omega=n_omega, panel_m=panel_m, n_theta=n_theta)
    print(f"OC4 hydrodynamics: {oc4_desc}")
    decks: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for platform in ("oc3", "oc4"):
            for gen in GENERATIONS:
                name = f"{platform}_{gen}"
                deck_dir = Path(tmp) / name
                fst = write_deck(deck_dir, platform, gen, oc4 if platform == "oc4" else None)
                out = Path(tmp) / f"{name}_preset"
                log = _fowt(
                    "preset",
                    "import-openfast",
                    str(fst),
                    "--out",
                    str(out),
                    "--name",
                    name,
                    "--turbine",
                    "nrel5mw",
                )
                print(log)
                toml = out / f"{name}.toml"
                modes = json.loads(_fowt("analyze", "modes", str(toml), "--wind", "0", "--json"))
                preset = tomllib.loads(toml.read_text(encoding="utf-8"))
                periods = {m["name"]: m["period_s"] for m in modes["modes"]}
                pub = PUBLISHED[platform]
                table = {}
                for dof in ("surge", "heave", "pitch", "yaw"):
                    got = periods.get(dof)
                    table[dof] = {
                        "period_s": round(got, 3) if got is not None else "not a DOF",
                        "published_s": round(pub[dof], 2),
                        "deviation_pct": round(100.0 * (got / pub[dof] - 1.0), 2)
                        if got is not None
                        else "n/a",
                    }
                totals = DECK_TOTALS[platform]
                imported = {
                    "mass_kg": preset["platform_mass_kg"],
                    "cm_z_m": preset["platform_cm_z_m"],
                    "pitch_inertia_kg_m2": preset["platform_pitch_inertia_kg_m2"],
                }
                decks[name] = {
                    "periods": table,
                    "periods_without_radiation_memory_s": _periods_without_memory(toml),
                    "surge_budget": _surge_budget(
                        toml, oc4 if platform == "oc4" else None, periods["surge"], pub["surge"]
                    ),
                    "tower_fore_aft_period_s": round(periods["tower_fore_aft"], 3),
                    "platform": {
                        k: {
                            "imported": round(v, 6),
                            "deck": totals[k],
                            "deviation_pct": round(100.0 * (v / totals[k] - 1.0), 3),
                        }
                        for k, v in imported.items()
                    },
                    "members_force_heave_n": (preset.get("member_force_n") or [0, 0, 0])[2],
                    "displaced_volume_wamit_m3": preset["displaced_volume_m3"],
                }
    return {
        "command": "fowt preset import-openfast DECK.fst --out DIR --name STEM --turbine "
        "nrel5mw; fowt analyze modes DIR/STEM.toml --wind 0 --json",
        "case": "parked in still air (rotor at rest, no aerodynamic forces); damped periods",
        "published_sources": SOURCES,
        "oc4_hydrodynamics": oc4_desc,
        "decks": decks,
    }


def main() -> int:
    """Command line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--panel", type=float, default=2.0, help="OC4 BEM panel length, m")
    p.add_argument("--n-theta", type=int, default=16, help="OC4 BEM panels around a column")
    p.add_argument("--n-omega", type=int, default=60, help="OC4 BEM frequencies 0.05..3 rad/s")
    args = p.parse_args()
    try:
        import capytaine  # noqa: F401
    except ImportError:
        print("needs the [hydro] extra (capytaine) for the OC4 hydrodynamics", file=sys.stderr)
        return 2
    save("openfast_import_periods", run(args.panel, args.n_theta, args.n_omega))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
