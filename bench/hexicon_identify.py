"""Benchmark: the seed's table-5 identification over the bus (``fowt hexicon identify``).

Six 3000-cycle PRBS experiments, each as plant, PRBS-excitation and recorder processes over
Zenoh (lock-step), merged from the MCAP files, N4SID on 1-5, held-out 6. Saves
``bench/results/hexicon_identify.json`` and (``--write-preset``) the ``mpc_id`` artefact.

    python bench/hexicon_identify.py [--out runs/hexicon_identify] [--reuse] [--write-preset]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench._common import machine, save
from hil.cli.hexicon import record_experiment
from hil.hexicon.identify import identify_over_bus


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, default=Path("runs/hexicon_identify"))
    ap.add_argument("--duration", type=float, default=3000.0)
    ap.add_argument("--reuse", action="store_true", help="fit the MCAP files already in --out")
    ap.add_argument("--write-preset", action="store_true")
    a = ap.parse_args()
    t0 = time.perf_counter()
    res = identify_over_bus(
        a.out, a.duration, reuse=a.reuse, write_preset=a.write_preset, record=record_experiment
    )
    res["wall_s"] = time.perf_counter() - t0
    res["machine"] = machine()
    print({k: res[k] for k in ("order", "fit_estimation_percent", "fit_validation_percent")})
    print(f"saved {save('hexicon_identify', res)}")


if __name__ == "__main__":
    main()
