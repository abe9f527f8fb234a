"""The ``fowt campaign``, ``fowt compare`` and ``fowt report`` commands.

Registered on the ``fowt`` Typer app by :func:`register` (kept out of :mod:`hil.cli.fowt` so the
campaign work stays in its own files).
"""

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from hil.cli import common as cli_common


def _names(text: str | None) -> list[str] | None:
    return [n.strip() for n in text.split(",") if n.strip()] if text else None


def render_aggregates(agg: dict[str, Any], console: Console) -> None:
    """Print the Weibull-weighted aggregates: wave increment, relative and normalised.

    Each figure with ± one standard error between seeds (``± ?``: one seed, not
    estimable), ``n/m`` for a near-zero denominator and ``!`` for a change within its noise
    (:mod:`hil.review.kpi_stats`).
    """
    from hil.campaign import kpi as ck
    from hil.campaign.html_report import figure_stat, ratio_text
    from hil.review import kpi_stats as kst

    kpis = list(ck.KPIS)
    base = agg["baseline"]
    t = Table(title=f"campaign {agg['campaign']}: Weibull-weighted, vs {base}")
    t.add_column("KPI")
    if agg.get("wave_increment"):
        t.add_column(f"waves/still ({base})", justify="right")
    for ctrl in agg["relative"]:
        t.add_column(f"{ctrl} relative", justify="right")
        if agg["normalised"].get(ctrl):
            t.add_column(f"{ctrl} P_n", justify="right")

    for k in kpis:
        unit, _d, label = ck.KPIS[k]
        row = [f"{label} [{unit}]"]
        if agg.get("wave_increment"):
            row.append(ratio_text(figure_stat(agg["wave_increment"][k], "weibull")))
        for ctrl, rel in agg["relative"].items():
            row.append(kst.percent_text(figure_stat(rel[k], "weibull")))
            if agg["normalised"].get(ctrl):
                row.append(
                    ck.figure_text(figure_stat(agg["normalised"][ctrl][k], "weibull"), signed=False)
                )
        t.add_row(*[escape(c) for c in row])
    console.print(t)
    noise = agg.get("noise") or {}
    f = 100 * float(noise.get("near_zero_fraction", kst.NEAR_ZERO_FRACTION))
    k_se = float(noise.get("k", kst.NOISE_K))
    src = "paired seeds" if noise.get("estimable") else "not estimable with one seed (± ?)"
    console.print(
        f"± one standard error ({src}); n/m: denominator near zero (|D| < max({k_se:g} SE, "
        f"{f:g} % of the KPI's largest |X| over the configurations)); !: change within "
        f"{k_se:g} SE; "
        f"P_n and waves/still against {base}'s still-water twins; {ck.BASELINE_NOISE}: the "
        f"waves change {base}'s KPI by less than max({k_se:g} SE, "
        f"{100 * float(noise.get('wave_effect_fraction', ck.WAVE_EFFECT_FRACTION)):g} % of its "
        "scale), P_n not defined",
        markup=False,
    )
    for reason in agg.get("not_available", {}).values():
        console.print(f"[yellow]not computed:[/] {escape(str(reason))}")
    for reason in agg.get("notes", {}).values():
        console.print(f"[yellow]note:[/] {escape(str(reason))}")
    runs = agg["runs"]
    console.print(f"runs: {runs['total']} ({runs['ok']} ok, {runs['failed']} failed)")


def register(app: typer.Typer, console: Console) -> None:
    """Add ``campaign``, ``compare`` and ``report`` to the ``fowt`` app.

    Called at the end of :mod:`hil.cli.fowt`; the option checks (finite numbers, writable paths,
    choices) are :mod:`hil.cli.common`'s, so bad input is one line and exit code 2 here too.
    """
    from hil.scenario.schema import MAX_DURATION_S

    @app.command("campaign", short_help="Run a campaign of cases x seeds x controllers on Dask.")
    def campaign_cmd(
        campaign: Annotated[
            str, typer.Argument(help="Shipped campaign name (al2019-iea15mw) or a TOML file.")
        ],
        out: Annotated[
            Path | None,
            typer.Option(
                "--out",
                help="Output folder (runs/campaign-<name>).",
                callback=cli_common.writable("folder"),
            ),
        ] = None,
        scheduler: Annotated[
            str | None,
            typer.Option(
                "--scheduler",
                help="tcp://HOST:PORT of a running Dask scheduler (default: a local cluster of"
                " processes on 127.0.0.1, one per core).",
            ),
        ] = None,
        workers: Annotated[
            int | None,
            typer.Option("--workers", help="Local worker processes (default: cores).", min=1),
        ] = None,
        record: Annotated[
            str,
            typer.Option(
                "--record",
                help="mcap (keep run.mcap) | none (summaries only).",
                callback=cli_common.choice("mcap", "none"),
            ),
        ] = "mcap",
        resume: Annotated[
            bool, typer.Option("--resume", help="Skip runs already done (same scenario hash).")
        ] = False,
        cases: Annotated[
            str | None, typer.Option("--cases", help="Only these cases (comma-separated).")
        ] = None,
        controllers: Annotated[
            str | None,
            typer.Option("--controllers", help="Only these controllers (the baseline stays)."),
        ] = None,
        seeds: Annotated[
            int | None, typer.Option("--seeds", help="Seeds per case.", min=1, max=10_000)
        ] = None,
        duration: Annotated[
            float | None,
            typer.Option(
                "--duration",
                help="Simulated seconds per run.",
                callback=cli_common.number("s", gt=0.0, le=MAX_DURATION_S),
            ),
        ] = None,
        baseline: Annotated[
            str | None,
            typer.Option(
                "--baseline",
                help="Compare with this controller instead (it gets the still-water twins).",
            ),
        ] = None,
        html: Annotated[bool, typer.Option(help="Write report.html.")] = True,
    ) -> None:
        """Run a campaign (cases x seeds x controllers) on Dask; tables, aggregates, report.

        Exits 1 when a run failed (every other run still ran; the failures are in the table
        with their error), 2 on a bad campaign file or option.
        """
        from hil.campaign.runner import CampaignError, load_campaign, run_campaign, select

        if record not in ("mcap", "none"):
            cli_common.fail(f"--record {record!r}: expected mcap or none")
        try:
            c = load_campaign(campaign)
            if cases or controllers or seeds is not None or duration is not None or baseline:
                c = select(c, _names(cases), _names(controllers), seeds, duration, baseline)
        except CampaignError as exc:
            cli_common.fail(str(exc))
        out_dir = out or Path("runs") / f"campaign-{c.spec.name}"
        try:
            result = run_campaign(
                c,
                out_dir,
                scheduler=scheduler,
                workers=workers,
                record=record,  # type: ignore[arg-type]
                resume=resume,
                console=console,
            )
        except (OSError, TimeoutError) as exc:
            where = f"scheduler {scheduler}" if scheduler else "the local Dask cluster"
            cli_common.fail(f"cannot use {where}: {exc}")
        render_aggregates(result.aggregates, console)
        if html:
            path = write_campaign_report(result, c)
            console.print(f"report:  {path}", markup=False)
        console.print(
            f"table:   {out_dir / 'results.parquet'} , {out_dir / 'results.csv'}", markup=False
        )
        console.print(f"aggregates: {out_dir / 'aggregates.json'}", markup=False)
        line = f"{len(c.runs)} runs ({result.skipped} resumed) in {result.wall_s:.1f} s wall"
        if result.tasks_wall_s > 0:
            speed = result.simulated_s / result.tasks_wall_s
            line += f", {result.workers} worker(s): {speed:.1f} simulated s / wall s"
        console.print(line)
        if result.aggregates["runs"]["failed"]:
            raise typer.Exit(1)

    @app.command("compare", short_help="Compare runs: KPIs, time series, PSDs.")
    def compare_cmd(
        runs: Annotated[list[Path], typer.Argument(help="Two or more run MCAP files.")],
        out: Annotated[
            Path,
            typer.Option("--out", help="Output folder.", callback=cli_common.writable("folder")),
        ] = Path("compare"),
    ) -> None:
        """Compare runs: KPI table with % differences vs the first, overlaid series, PSDs."""
        from hil.campaign.html_report import compare_name, compare_runs, diff_text, fmt

        if len(runs) < 2:
            cli_common.fail("give at least two MCAP files")
        for p in runs:
            if not p.is_file():
                cli_common.fail(f"{p} is not a file")
        try:
            res = compare_runs(runs, out)
        except ValueError as exc:
            cli_common.fail(str(exc))
        labels = [r["label"] for r in res["runs"]]
        t = Table(title="KPIs (Δ % vs run 0)")
        t.add_column("KPI")
        for lab in labels:
            t.add_column(lab, justify="right")
        for k, vals in res["kpi"].items():
            name, scale = compare_name(k)  # the review's naming and units
            shown = [v * scale if isinstance(v, int | float) else v for v in vals]
            cells = [fmt(shown[0])]
            for v, d, st in zip(
                shown[1:], res["diff_pct"][k][1:], res["diff_status"][k][1:], strict=True
            ):
                cells.append(f"{fmt(v)} ({diff_text(d, st)})")
            t.add_row(name, *cells)
        console.print(t)
        for name in ("compare.html", "compare_timeseries.png", "compare_psd.png", "compare.json"):
            console.print(f"wrote {out / name}", markup=False)

    @app.command("report", short_help="Write a self-contained HTML report of a run.")
    def report_cmd(
        mcap: Annotated[Path, typer.Argument(help="A run's MCAP file.")],
        out: Annotated[
            Path | None,
            typer.Option(
                "--out",
                help="HTML file (default: report.html beside it).",
                callback=cli_common.writable("file"),
            ),
        ] = None,
    ) -> None:
        """One self-contained HTML report of a run (KPI tables, time series, timing, PSDs)."""
        from hil.campaign.html_report import run_html

        if not mcap.is_file():
            cli_common.fail(f"{mcap} is not a file")
        from hil.runlog.mcap_io import NotMcapError

        try:
            text, _summary = run_html(mcap)
        except NotMcapError as exc:
            cli_common.fail(str(exc))
        path = out or mcap.parent / "report.html"
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
        except OSError as exc:
            cli_common.fail(cli_common.os_error_text(exc, path), code=1)
        console.print(f"report: {path}", markup=False)


def write_campaign_report(result: Any, campaign: Any) -> Path:
    """Write ``report.html`` of a finished campaign
    (:class:`hil.campaign.runner.CampaignResult`)."""
    from hil.campaign.html_report import campaign_html

    run_dirs = {(s.case, s.waves, s.controller, s.seed): s.rel_dir for s in campaign.runs}
    text = campaign_html(result.aggregates, result.rows, result.results, run_dirs)
    path: Path = result.out / "report.html"
    path.write_text(text)
    return path
