"""christiansen-2013 sect. 2.9: open-loop platform-pitch damping map, plant model and decoupled.

The damping ratio of the platform-pitch mode over wind speed (3-25 m/s every 0.5 m/s) and wave
frequency (0.05-3 rad/s every 0.05 rad/s), from :func:`controller.design.lqr_wave.damping_map`
on two models: the plant's (surge and pitch coupled through the mass, added mass, radiation
damping and stiffness, as OpenFAST's OC3-Hywind) and the seed's (``decoupled``: those
surge-pitch terms removed, sect. 2.1; the aerodynamic coupling kept). Saves
``bench/results/christiansen_damping_map.json`` with both maps, the location of each
maximum beside the seed's (10.4 m/s, 0.09 Hz), the winds without a static equilibrium (none
expected), and the surge-pitch terms of both models at 18 m/s, 0.6 rad/s.

    python bench/christiansen_damping_map.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench._common import save

PRESET = "nrel5mw_oc3_hywind"
SEED_MAX = {"wind_m_s": 10.4, "wave_hz": 0.09}


def main() -> int:
    from controller.design.lqr_wave import SparModel, damping_map

    t0 = time.perf_counter()
    maps: dict[str, Any] = {}
    terms: dict[str, Any] = {}
    for name, dec in (("coupled", False), ("decoupled", True)):
        model = SparModel(PRESET, decoupled=dec)
        maps[name] = damping_map(PRESET, model=model)
        terms[name] = model.coupling_terms(18.0, 0.6)
    summary = {
        name: {
            "max_damping_ratio": m["max_damping_ratio"],
            "max_at_wind_m_s": m["max_at_wind_m_s"],
            "max_at_wave_omega_rad_s": m["max_at_wave_omega_rad_s"],
            "max_at_wave_hz": m["max_at_wave_hz"],
            "winds_without_equilibrium": len(m["failed_winds"]),
        }
        for name, m in maps.items()
    }
    for name, s in summary.items():
        print(
            f"{name:9s}: max zeta {s['max_damping_ratio']:.4f} at {s['max_at_wind_m_s']:g} m/s, "
            f"{s['max_at_wave_omega_rad_s']:g} rad/s ({s['max_at_wave_hz']:.3f} Hz); "
            f"winds without equilibrium: {s['winds_without_equilibrium']}"
        )
    save(
        "christiansen_damping_map",
        {
            "command": "python bench/christiansen_damping_map.py",
            "preset": PRESET,
            "summary": summary,
            "seed_max": SEED_MAX,
            "surge_pitch_terms_18m_s_0p6rad_s": terms,
            "maps": maps,
            "wall_s": time.perf_counter() - t0,
        },
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
