"""ayotte-2015 figure 10: the Hexicon platform's yaw coast-down under quadratic drag alone.

The seed's check: a torque from the three corners yaws the platform ~35° and the water's drag
"slows it to a complete stop around 3 minutes". Its yaw equation (its eq. 5) has inertia and
quadratic drag only, I ψ'' + c ψ'|ψ'| = M (c = ½ ρ C_d A r_d³, no mooring stiffness, no
linear damping), and so has ours (``plant/hexicon``). After the torque ends at t₁ with rate
r₁ the solution is r(t) = r₁ / (1 + c r₁ (t − t₁)/I), ψ(t) = ψ₁ + (I/c) ln(1 + c r₁ (t − t₁)/I):
the rate decays like 1/t and the heading grows like ln t without bound, i.e. the platform
never stops. This bench integrates the seed's case (1 MN tangential at each corner for 50 s,
RK4 at 0.05 s) with the preset's I and c, continues it with the closed form, and saves the
heading and the rate (as a fraction of its peak) at several times, and the times the rate
falls below 10 % and 1 % of its peak: ``bench/results/hexicon_yaw_coast_down.json``.

    python bench/hexicon_yaw_coast_down.py
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench._common import save

FORCE_N = 1e6
FORCE_S = 50.0
TIMES_S = (50.0, 150.0, 180.0, 300.0, 600.0, 1800.0, 3600.0)


def main() -> None:
    from plant.hexicon.model import load_hexicon

    p = load_hexicon()
    lever = sum(math.hypot(a, b) for a, b in zip(p.turbine_x_m, p.turbine_y_m, strict=True))
    c, inertia = p.drag_constant, p.yaw_inertia_kg_m2
    moment = FORCE_N * lever

    def rate_dot(r: float) -> float:
        return (moment - c * r * abs(r)) / inertia

    dt, psi, r = 0.05, 0.0, 0.0
    for _ in range(round(FORCE_S / dt)):  # RK4 of (ψ, r) while the torque acts
        k1 = rate_dot(r)
        k2 = rate_dot(r + 0.5 * dt * k1)
        k3 = rate_dot(r + 0.5 * dt * k2)
        k4 = rate_dot(r + dt * k3)
        psi += dt * (r + dt * (k1 + k2 + k3) / 6.0)
        r += dt * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0
    r1, psi1 = r, psi  # the rate peaks when the torque ends (it only accelerates before)

    def after(t: float) -> tuple[float, float]:
        s = 1.0 + c * r1 * (t - FORCE_S) / inertia
        return psi1 + inertia / c * math.log(s), r1 / s

    table = {}
    for t in TIMES_S:
        h, rt = after(t)
        table[f"{t:g}_s"] = {"heading_deg": math.degrees(h), "rate_over_peak": rt / r1}
    # r / r1 = 1 / (1 + c r1 (t - t1)/I) = f  ->  t = t1 + (1/f - 1) I / (c r1)
    below = {f"{f:g}": FORCE_S + (1.0 / f - 1.0) * inertia / (c * r1) for f in (0.1, 0.01)}
    for t, row in table.items():
        print(f"{t:>7s}: heading {row['heading_deg']:6.2f} deg, rate {row['rate_over_peak']:.3f}")
    print(f"rate below 10 % of peak at {below['0.1']:.0f} s, below 1 % at {below['0.01']:.0f} s")
    save(
        "hexicon_yaw_coast_down",
        {
            "command": "python bench/hexicon_yaw_coast_down.py",
            "case": "1 MN tangential at each corner for 50 s, then free (seed figure 10)",
            "drag_constant_kg_m2": c,
            "yaw_inertia_kg_m2": inertia,
            "peak_rate_deg_s": math.degrees(r1),
            "heading_at": table,
            "rate_below_fraction_of_peak_at_s": below,
            "seed": "comes to a complete stop around 3 minutes (figure 10)",
        },
    )


if __name__ == "__main__":
    main()
