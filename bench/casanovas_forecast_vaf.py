"""VAF of the gauge-to-excitation preview (controller.casanovas.ExcitationPreviewPredictor).

The casanovas-2014 cases' sea (ISSC, 100 bins to 2 rad/s, 100 m depth), the gauge 300 m
up-wave as in ``hil/scenario/presets/casanovas-tlp-*``, no gauge noise: VAF = 1 - var(X̂ - X)/var(X)
of X(t + τ) over 600 s after the FIR has filled, for τ = 0, 5, 10, 13.6 and 20 s.

    python bench/casanovas_forecast_vaf.py   # -> bench/results/casanovas_forecast_vaf.json
"""

from __future__ import annotations

import os

for _k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_k] = "1"

import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from bench._common import RESULTS, machine  # noqa: E402


def main() -> int:
    from controller.casanovas import make_casanovas
    from hil.nodes.plant_node import floating_plant
    from hil.scenario.schema import load_scenario
    from plant.waves import ExcitationForce

    out: dict[str, object] = {"machine": machine(), "cases": []}
    for hs in (6, 10):
        sc = load_scenario(f"casanovas-tlp-hs{hs}-u8")
        fp = floating_plant(sc)
        force = ExcitationForce(fp.waves, fp.excitation_transfer[:, :1])
        gauge_x = -sc.waves.gauge_distance_m if sc.waves is not None else -300.0
        core = make_casanovas("lqr_finite", f"nrel5mw_tlp_casanovas_u8_hs{hs}",
                              control_period_s=0.1, preview="forecast",
                              gauge_distance_m=-gauge_x)  # fmt: skip
        pred = core.predictor
        assert pred is not None
        dt, n = 0.1, 8000
        t = dt * np.arange(n)
        eta_g = fp.waves.eta(t, x_m=gauge_x)
        window = pred.init_state()
        est = np.empty((n, core.n_preview))
        for i in range(n):
            window, est[i] = pred.step(window, float(eta_g[i]))
        start = pred.n_taps + 10
        row: dict[str, object] = {"hs_m": hs, "n_taps": pred.n_taps}
        for tau in (0.0, 5.0, 10.0, 13.6, 20.0):
            j = round(tau / core.preview_step)
            true = force.at(t[start:] + j * core.preview_step)[:, 0]
            err = est[start:, j] - true
            row[f"vaf_{tau:g}s"] = float(1 - np.var(err) / np.var(true))
        out["cases"].append(row)  # type: ignore[union-attr]
        print(row)
    path = RESULTS / "casanovas_forecast_vaf.json"
    path.write_text(json.dumps(out, indent=2))
    print(f"saved {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
