"""Offline design data of the Hexicon H3 heading controllers (may use ``plant``; runs offline).

Writes ``controller/presets/hexicon_h3_control.json``: the rated-pitch floor θ_r(V) (the seed's
figure 18), the steady thrust at θ_r(V) and at 25°, the secant thrust-per-pitch slope
g(V) = (T(V, θ_r) - T(V, 25°)) / (25° - θ_r) used by the MPC's linear model, the torque law
constants, the layout and the yaw inertia/drag of the preset. Run::

    python -m controller.design.hexicon
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from plant import turbine as tb
from plant.hexicon.model import load_hexicon, rated_pitch_rad, steady_operating_point

OUT = Path(__file__).resolve().parent.parent / "presets" / "hexicon_h3_control.json"
PITCH_MAX_DEG = 25.0


def design() -> dict[str, object]:
    """Compute the design tables (see module docstring)."""
    p = load_hexicon("hexicon_h3")
    tp = p.turbine
    winds = [float(v) for v in range(2, 31)]
    rated, t_rated, t_max, slope = [], [], [], []
    for v in winds:
        th = rated_pitch_rad(tp, v)
        th = min(th, math.radians(PITCH_MAX_DEG) - 1e-3)
        _, thrust_r, _, _ = steady_operating_point(tp, v, th)
        _, thrust_m, _, _ = steady_operating_point(tp, v, math.radians(PITCH_MAX_DEG))
        rated.append(math.degrees(th))
        t_rated.append(thrust_r)
        t_max.append(thrust_m)
        slope.append(max(thrust_r - thrust_m, 1.0) / (math.radians(PITCH_MAX_DEG) - th))
    return {
        "source": "python -m controller.design.hexicon (plant preset hexicon_h3)",
        "wind_grid_m_s": winds,
        "rated_pitch_deg": rated,
        "thrust_rated_pitch_n": t_rated,
        "thrust_max_pitch_n": t_max,
        "thrust_slope_n_per_rad": slope,
        "pitch_max_deg": PITCH_MAX_DEG,
        "turbine_x_m": list(p.turbine_x_m),
        "turbine_y_m": list(p.turbine_y_m),
        "yaw_inertia_kg_m2": p.yaw_inertia_kg_m2,
        "drag_constant_kg_m2": p.drag_constant,
        "torque_gain_nm_s2": tb.optimal_torque_gain(tp),
        "rated_rotor_speed_rad_s": tp.rated_rotor_speed_rad_s,
        "rated_power_w": tp.rated_power_w,
        "generator_efficiency": tp.generator_efficiency,
        "gearbox_ratio": tp.gearbox_ratio,
        "torque_max_nm": tp.torque_max_nm,
    }


def main() -> None:
    OUT.write_text(json.dumps(design(), indent=1) + "\n", encoding="utf-8")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
