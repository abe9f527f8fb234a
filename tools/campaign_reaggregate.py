"""Aggregate a campaign's results table again with the current
:func:`hil.campaign.runner.aggregate`.

Reads a ``results.csv`` of ``fowt campaign`` (one row per run), takes the shipped or given
campaign file for the cases, probabilities and controllers (``--baseline`` as with ``fowt
campaign``), and writes ``aggregates.json`` (with the standard errors and n/m statuses of
:mod:`hil.review.kpi_stats`) and, with ``--html``, the report without the PSDs (they need the runs'
summaries). The runs' KPIs are used as they are in the table.

    python tools/campaign_reaggregate.py results.csv --campaign al2019-iea15mw \\
        [--baseline lqri] --out aggregates.json [--html report.html]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

from hil.campaign import kpi as ck
from hil.campaign.html_report import campaign_html
from hil.campaign.runner import _json_clean, aggregate, load_campaign, select


def read_rows(path: Path) -> list[dict[str, object]]:
    """The table's rows with the KPI columns as floats (empty cell: nan)."""
    rows: list[dict[str, object]] = []
    with path.open(newline="") as fh:
        for r in csv.DictReader(fh):
            row: dict[str, object] = dict(r)
            row["seed"] = int(r["seed"])
            row["probability"] = float(r["probability"])
            for k in ck.KPIS:
                row[k] = float(r[k]) if r.get(k) not in (None, "") else math.nan
            rows.append(row)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table", type=Path)
    ap.add_argument("--campaign", default="al2019-iea15mw")
    ap.add_argument("--baseline", default=None)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--html", type=Path, default=None)
    args = ap.parse_args()
    rows = read_rows(args.table)
    c = load_campaign(args.campaign)
    ctrls = sorted({str(r["controller"]) for r in rows})
    seeds = 1 + max(int(r["seed"]) for r in rows)  # type: ignore[call-overload]
    c = select(c, None, ctrls, seeds, None, args.baseline)
    agg = aggregate(rows, c)
    args.out.write_text(json.dumps(_json_clean(agg), indent=1) + "\n")
    print(f"wrote {args.out}")
    if args.html is not None:
        args.html.write_text(campaign_html(agg, rows))
        print(f"wrote {args.html}")


if __name__ == "__main__":
    main()
