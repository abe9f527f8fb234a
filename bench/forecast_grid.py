"""Forecaster VAF over a grid of sea states: dispersion, AR, ESPRIT.

JONSWAP (gamma 3.3, deep water, the same seed) at H_s 1, 2, 4, 6, 8 m and T_p 6, 8, 10, 12,
14 s, white sensor noise of 0.02 m (the gauge channel of the shipped scenarios) on what each
forecaster measures, gauge 300 m up-wave, horizon 8 s for all three, 300 s
evaluated after the dispersion filter has filled. Each forecaster runs through its runtime
``step`` (``hil.review.forecast.forecast_grid``; ``fowt analyze forecast --grid`` prints the
same table). Prints the table and saves ``bench/results/forecast_grid.json``.

    python bench/forecast_grid.py [--duration 300] [--distance 300] [--horizon 8] [--noise 0.02]
"""

from __future__ import annotations

import argparse
import time

from _common import save

from hil.review.forecast import forecast_grid


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=300.0)
    ap.add_argument("--distance", type=float, default=300.0)
    ap.add_argument("--horizon", type=float, default=8.0)
    ap.add_argument("--noise", type=float, default=0.02)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    t0 = time.monotonic()
    grid = forecast_grid(
        distance_m=args.distance,
        horizon_s=args.horizon,
        duration_s=args.duration,
        noise_m=args.noise,
        seed=args.seed,
    )
    grid["wall_s"] = round(time.monotonic() - t0, 1)
    print("Hs m  Tp s  VAF %: dispersion      AR  ESPRIT   (AR / ESPRIT stabilised fits)")
    for row in grid["rows"]:
        d, a, e = row["dispersion"], row["ar"], row["esprit"]
        print(
            f"{row['hs_m']:4.1f} {row['tp_s']:5.1f}  {d['vaf_percent']:17.1f} "
            f"{a['vaf_percent']:7.1f} {e['vaf_percent']:7.1f}   "
            f"({a['unstable_fits']}/{a['trainings']}, {e['unstable_fits']}/{e['trainings']})"
        )
    print("min VAF %:", {k: round(v, 1) for k, v in grid["min_vaf_percent"].items()})
    save("forecast_grid", grid)


if __name__ == "__main__":
    main()
