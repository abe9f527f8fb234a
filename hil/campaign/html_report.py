"""Self-contained HTML reports: a campaign, one run, a comparison of runs.

One file each, no external resources: the figures are PNGs embedded as base64 data URIs and
the style is inline, so the file opens anywhere (and offline). Campaign figures follow
al-2019: the wave-induced increment per load case (figure 2-5), the relative performance of
each controller vs the baseline per case (figure 5-1) and Weibull-weighted (figures 5-3 and
5-5 top), the normalised performance of eq. (5-1) per case (figure 5-2) and Weibull-weighted
(figures 5-3 and 5-5 bottom), and rotor-speed PSDs (figure 5-4, right).
"""

from __future__ import annotations

import base64
import html
import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hil.campaign import kpi as ck
from hil.review import kpi_names
from hil.review import kpi_stats as kst

_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:24px;
color:#1b1b1b;max-width:1200px}
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:8px 0;font-size:0.85em}
th,td{border:1px solid #ccc;padding:3px 8px;text-align:right}
th{background:#f0f0f0}td.l,th.l{text-align:left}
.note{color:#555;font-size:0.9em}.bad{color:#b00020}
img{max-width:100%;height:auto;border:1px solid #eee}
"""


def _esc(v: Any) -> str:
    return html.escape(str(v))


def fmt(v: Any, digits: int = 4) -> str:
    """A number for a table: ``-`` for None/nan, 4 significant digits otherwise."""
    if v is None:
        return "-"
    if isinstance(v, bool | str):
        return str(v)
    if isinstance(v, int):
        return str(v)
    x = float(v)
    if not math.isfinite(x):
        return "-"
    return f"{x:.{digits}g}"


def pct(v: Any) -> str:
    """A fraction as a signed percentage (``-`` for None/nan)."""
    if v is None or not math.isfinite(float(v)):
        return "-"
    return f"{100.0 * float(v):+.1f} %"


def pct_plain(v: Any) -> str:
    """A fraction as a percentage without sign (``-`` for None/nan)."""
    if v is None or not math.isfinite(float(v)):
        return "-"
    return f"{100.0 * float(v):.3g} %"


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]], left: int = 1) -> str:
    """An HTML table; the first ``left`` columns left-aligned, cells escaped."""
    head = "".join(
        f'<th class="l">{_esc(h)}</th>' if i < left else f"<th>{_esc(h)}</th>"
        for i, h in enumerate(headers)
    )
    body = []
    for r in rows:
        cells = "".join(
            f'<td class="l">{_esc(c)}</td>' if i < left else f"<td>{_esc(c)}</td>"
            for i, c in enumerate(r)
        )
        body.append(f"<tr>{cells}</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def png_data_uri(fig: Any, dpi: int = 90) -> str:
    """A matplotlib figure as a ``data:image/png;base64,...`` URI (the figure is closed)."""
    import matplotlib.pyplot as plt  # noqa: PLC0415

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def img(uri: str, alt: str) -> str:
    """An ``<img>`` of a data URI."""
    return f'<img src="{uri}" alt="{_esc(alt)}">'


def file_img(path: Path, alt: str) -> str:
    """An ``<img>`` embedding a PNG file."""
    data = base64.b64encode(Path(path).read_bytes()).decode()
    return img(f"data:image/png;base64,{data}", alt)


def page(title: str, body: str) -> str:
    """A complete HTML document."""
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{_esc(title)}</title><style>{_STYLE}</style></head>"
        f"<body><h1>{_esc(title)}</h1>{body}</body></html>\n"
    )


def _pyplot() -> Any:
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    return plt


def _bar_series(
    figures: dict[str, Any], kpis: Sequence[str], cases: Sequence[str]
) -> tuple[dict[str, list[Any]], dict[str, list[Any]]]:
    """A bar chart's values and their statistics (:func:`figure_stat`) per case and for the
    Weibull-weighted KPI, for ``figures[kpi]`` of the aggregates (``per_case``, ``weibull``)."""
    series = {c: [figures[k]["per_case"].get(c) for k in kpis] for c in cases}
    series["Weibull"] = [figures[k]["weibull"] for k in kpis]
    stats = {c: [figure_stat(figures[k], c) for k in kpis] for c in cases}
    stats["Weibull"] = [figure_stat(figures[k], "weibull") for k in kpis]
    return series, stats


def _bars(
    groups: Sequence[str],
    series: dict[str, list[Any]],
    ylabel: str,
    title: str,
    ref: float | None = None,
    scale: float = 1.0,
    clip: tuple[float, float] | None = None,
    stats: dict[str, list[dict[str, Any] | None]] | None = None,
) -> str:
    """Grouped bar chart (al-2019 style): x = KPI groups, one bar per series.

    ``clip`` (unscaled): bars beyond it are drawn to the limit and labelled with their value.
    ``stats`` (per series, per group ``{value, se, status}`` of :mod:`hil.review.kpi_stats`): a bar
    whose figure is ``n/m`` is not drawn but labelled "n/m" at the reference line; ±1 SE is
    an error bar; a figure within its noise is drawn hatched and pale.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(11, 3.6))
    n = max(1, len(series))
    width = 0.8 / n
    x = np.arange(len(groups))
    base_line = 0.0 if ref is None else ref * scale
    any_noise = any_nm = False
    legend: list[tuple[str, Any]] = []
    for i, (name, vals) in enumerate(series.items()):
        st = (stats or {}).get(name) or [None] * len(vals)
        status = [str((d or {}).get("status", kst.OK)) for d in st]
        v = np.array(
            [
                np.nan if a is None or s_ in (kst.NOT_MEANINGFUL, ck.BASELINE_NOISE) else float(a)
                for a, s_ in zip(vals, status, strict=True)
            ]
        )
        v = v * scale
        err = np.array([float((d or {}).get("se", np.nan)) for d in st]) * scale
        xs = x + (i - (n - 1) / 2) * width
        for xi, s_ in zip(xs, status, strict=True):
            if s_ in (kst.NOT_MEANINGFUL, ck.BASELINE_NOISE):
                any_nm = True
                ax.annotate(
                    "n/m" if s_ == kst.NOT_MEANINGFUL else "n/a",
                    (xi, base_line),
                    fontsize=6,
                    rotation=90,
                    ha="center",
                    va="bottom",
                )
        shown = np.nan_to_num(v)
        if clip is not None:  # a ratio to a near-zero value would flatten every other bar
            lo, hi = clip[0] * scale, clip[1] * scale
            for xi, vi in zip(xs, shown, strict=True):
                if vi > hi or vi < lo:
                    ax.annotate(
                        f"{vi:.3g}",
                        (xi, min(max(vi, lo), hi)),
                        fontsize=6,
                        rotation=90,
                        ha="center",
                        va="top" if vi > hi else "bottom",
                    )
            shown = np.clip(shown, lo, hi)
        bars = ax.bar(xs, shown, width, label=name)
        color = bars.patches[0].get_facecolor() if bars.patches else None
        legend.append((name, color))
        for bar, s_ in zip(bars.patches, status, strict=True):
            if s_ == kst.NOISE:
                any_noise = True
                bar.set_alpha(0.45)
                bar.set_hatch("///")
        if stats is not None and np.isfinite(err).any():
            ok = np.isfinite(err) & np.isfinite(v)
            if clip is not None:
                ok &= (shown > clip[0] * scale) & (shown < clip[1] * scale)
            ax.errorbar(
                xs[ok],
                shown[ok],
                yerr=err[ok],
                fmt="none",
                ecolor=color,
                elinewidth=0.8,
                capsize=1.5,
            )
    if ref is not None:
        ax.axhline(ref * scale, color="k", lw=0.8)
    ax.set_xticks(x, groups, fontsize=8)
    ax.set_ylabel(ylabel)
    if stats is not None:
        notes = ["error bars ±1 SE between seeds"]
        if any_noise:
            notes.append("hatched: within its noise (|change| < 2 SE)")
        if any_nm:
            notes.append("n/m: denominator near zero")
        title = f"{title}\n({'; '.join(notes)})"
    ax.set_title(title, fontsize=10)
    ax.grid(True, axis="y", alpha=0.3)
    # plain swatches: a series' first bar may be hatched (within noise), its legend must not
    from matplotlib.patches import Patch  # noqa: PLC0415

    handles = [Patch(facecolor=c, label=lab) for lab, c in legend]
    ax.legend(handles=handles, fontsize=7, ncol=min(n, 8))
    fig.tight_layout()
    return png_data_uri(fig)


# --------------------------------------------------------------------------- campaign


def _mean_psd(psds: Sequence[dict[str, Any]]) -> tuple[np.ndarray, np.ndarray] | None:
    good = [p for p in psds if p and p.get("f_hz")]
    if not good:
        return None
    n = min(len(p["f_hz"]) for p in good)
    f = np.asarray(good[0]["f_hz"][:n])
    return f, np.mean([np.asarray(p["pxx"][:n]) for p in good], axis=0)


def campaign_html(
    agg: dict[str, Any],
    rows: Sequence[dict[str, Any]],
    results: dict[str, dict[str, Any]] | None = None,
    run_dirs: dict[tuple[str, str, str, int], str] | None = None,
    extra: str = "",
) -> str:
    """The campaign report (one self-contained HTML page).

    Parameters
    ----------
    agg : dict
        :func:`hil.campaign.runner.aggregate` output.
    rows : sequence of dict
        The results table (:func:`hil.campaign.runner.row_of`).
    results : dict, optional
        Run folder -> task result (for the PSDs).
    run_dirs : dict, optional
        (case, waves, controller, seed) -> run folder, to find each row's result.
    extra : str
        HTML appended (e.g. a comparison with published figures).
    """
    kpis = list(ck.KPIS)
    labels = [f"{ck.KPIS[k][2]} [{ck.KPIS[k][0]}]" for k in kpis]
    short = [ck.KPIS[k][2] for k in kpis]
    cases = list(agg["probabilities"])
    base = agg["baseline"]
    parts: list[str] = []
    runs = agg["runs"]
    parts.append(
        f"<p>{runs['total']} runs: {runs['ok']} ok, "
        f'<span class="{"bad" if runs["failed"] else ""}">{runs["failed"]} failed</span>. '
        f"Baseline: <b>{_esc(base)}</b>. Load cases and occurrence probabilities: "
        + ", ".join(f"{_esc(c)} {100 * p:.2f} %" for c, p in agg["probabilities"].items())
        + ".</p>"
    )
    for reason in [*agg.get("not_available", {}).values(), *agg.get("notes", {}).values()]:
        parts.append(f'<p class="note">{_esc(reason)}.</p>')
    failed = [r for r in rows if r["status"] != "ok"]
    if failed:
        parts.append("<h2>Failed runs</h2>")
        parts.append(
            table(
                ["case", "waves", "controller", "seed", "error"],
                [[r["case"], r["waves"], r["controller"], r["seed"], r["error"]] for r in failed],
                left=5,
            )
        )
    # Weibull-weighted absolute values
    parts.append("<h2>Weibull-weighted KPIs</h2>")
    parts.append(
        '<p class="note">X_W = Σ p_i X_i / Σ p_i over the load cases (means over seeds).</p>'
    )
    parts.append(
        table(
            ["configuration", *labels],
            [[name, *[fmt(vals[k]) for k in kpis]] for name, vals in agg["weibull"].items()],
        )
    )
    noise = agg.get("noise") or {}
    parts.append(_noise_note(noise, base))
    inc = agg.get("wave_increment") or {}
    if inc:
        parts.append(
            f"<h2>Wave-induced increment of {_esc(base)}: waves / still water "
            f"({_esc(base)}'s still-water twins)</h2>"
        )
        parts.append(
            f'<p class="note">al-2019 table 2-5 and figure 2-5: X_waves / X_still of '
            f"<b>{_esc(base)}</b> (the campaign's baseline) with its still-water twins (same "
            "wind and seeds, no waves); 1 = waves change nothing.</p>"
        )
        parts.append(
            table(
                ["KPI", *cases, "Weibull", "Σp·ratio"],
                [
                    [
                        lab,
                        *[ratio_text(figure_stat(inc[k], c)) for c in cases],
                        ratio_text(figure_stat(inc[k], "weibull")),
                        ratio_text(figure_stat(inc[k], "weibull_of_cases")),
                    ]
                    for k, lab in zip(kpis, labels, strict=True)
                ],
            )
        )
        series, stats = _bar_series(inc, kpis, cases)
        parts.append(
            img(
                _bars(
                    short,
                    series,
                    "waves / still [-]",
                    f"Wave-induced increment of {base}",
                    ref=1.0,
                    clip=(0.0, 10.0),
                    stats=stats,
                ),
                f"wave-induced increment of {base} per load case",
            )
        )
    for ctrl, rel in agg["relative"].items():
        norm = agg["normalised"].get(ctrl, {})
        title = f"{ctrl} vs {base} (relative, waves)"
        if norm:
            title += f"; P_n against {base}'s still-water twins"
        parts.append(f"<h2>{_esc(title)}</h2>")
        head = ["KPI", "relative, Weibull", "Σp·relative"]
        if norm:
            head += ["normalised P_n, Weibull", "Σp·P_n"]
        body = []
        for k, lab in zip(kpis, labels, strict=True):
            row = [
                lab,
                kst.percent_text(figure_stat(rel[k], "weibull")),
                kst.percent_text(figure_stat(rel[k], "weibull_of_cases")),
            ]
            if norm:
                row += [
                    ck.figure_text(figure_stat(norm[k], "weibull"), signed=False),
                    ck.figure_text(figure_stat(norm[k], "weibull_of_cases"), signed=False),
                ]
            body.append(row)
        parts.append(
            f'<p class="note">relative = X_{_esc(ctrl)} / X_{_esc(base)} − 1, both in waves '
            "(al-2019 figures 5-1, 5-3/5-5 top); P_n = (X_ctrl − X_still) / (X_base − "
            f"X_still), eq. (5-1), X_still = {_esc(base)} in still water: 100 % = "
            f"{_esc(base)} in waves, 0 % = {_esc(base)} in still water (figures 5-2, 5-3/5-5 "
            "bottom). Weibull: on the Weibull-weighted KPIs; Σp·: the weighted mean of the "
            "per-case values. ± one standard error; n/m and ! as stated above.</p>"
        )
        parts.append(table(head, body))
        parts.append(_per_case_table(kpis, labels, cases, rel, norm))
        series, stats = _bar_series(rel, kpis, cases)
        parts.append(
            img(
                _bars(
                    short,
                    series,
                    "relative [%]",
                    f"{ctrl}: relative to {base} (waves)",
                    0.0,
                    100.0,
                    clip=(-1.0, 3.0),
                    stats=stats,
                ),
                f"{ctrl} relative performance",
            )
        )
        if norm:
            series, stats = _bar_series(norm, kpis, cases)
            parts.append(
                img(
                    _bars(
                        short,
                        series,
                        "P_n [%]",
                        f"{ctrl}: normalised (eq. 5-1), against {base} in waves and in still water",
                        1.0,
                        100.0,
                        clip=(-2.0, 3.0),
                        stats=stats,
                    ),
                    f"{ctrl} normalised performance",
                )
            )
    # per-case mean and spread
    parts.append("<h2>Per load case: mean ± sample standard deviation over seeds (n seeds)</h2>")
    body = []
    for case in cases:
        for waves, block in agg["per_case"].get(case, {}).items():
            for ctrl, vals in block.items():
                body.append(
                    [
                        case,
                        waves,
                        ctrl,
                        *[
                            f"{fmt(vals[k]['mean'])} ± {fmt(vals[k]['spread'], 2)} "
                            f"(n={vals[k]['n']})"
                            for k in kpis
                        ],
                    ]
                )
    parts.append(table(["case", "waves", "controller", *labels], body, left=3))
    # PSDs
    if results and run_dirs:
        parts.append(
            "<h2>Rotor-speed PSD per load case, every controller, waves and still water "
            "(mean over seeds, KPI window)</h2>"
        )
        parts.append(_psd_grid(rows, results, run_dirs, cases, base))
    parts.append(extra)
    return page(f"Campaign {agg['campaign']}", "".join(parts))


def figure_stat(block: dict[str, Any], where: str) -> dict[str, Any] | None:
    """``{value, se, status}`` of a figure of the aggregates; ``where`` is a case,
    ``weibull`` or ``weibull_of_cases``. Aggregates written before the statistics (no
    ``stats``) give the bare value with an unknown SE and status ``ok``."""
    whole = where in ("weibull", "weibull_of_cases")
    st = block.get("stats")
    if st:
        out: dict[str, Any] | None = st.get(where) if whole else st["per_case"].get(where)
        return out
    v = block.get(where) if whole else (block.get("per_case") or {}).get(where)
    return None if v is None else {"value": v, "se": math.nan, "status": kst.OK}


def ratio_text(d: dict[str, Any] | None) -> str:
    """A ratio (wave increment) as ``1.234 ± 0.01``, ``n/m`` or ``-`` (``!`` within noise)."""
    if d is None:
        return "-"
    if d.get("status") == kst.NOT_MEANINGFUL:
        return kst.NOT_MEANINGFUL
    v = d.get("value")
    if v is None or not math.isfinite(float(v)):
        return "-"
    se = d.get("se")
    text = f"{float(v):.3f}"
    text += f" ± {float(se):.2g}" if se is not None and math.isfinite(float(se)) else " ± ?"
    return text + (" !" if d.get("status") == kst.NOISE else "")


def _noise_note(noise: dict[str, Any], base: str) -> str:
    """The paragraph stating the n/m rule and where the standard errors come from."""
    k = noise.get("k", kst.NOISE_K)
    f = noise.get("near_zero_fraction", kst.NEAR_ZERO_FRACTION)
    seeds = noise.get("seeds")
    src = (
        f"between the {seeds} paired seeds (a ratio of means, linearised: SE = s_e / (√n |d̄|), "
        "e_i = a_i − R d_i)"
        if noise.get("estimable", False)
        else "not estimable: one seed per configuration (shown as ± ?); run more seeds"
    )
    return (
        '<h2>How to read the ratios (n/m, ±, !)</h2><p class="note">'
        f"Standard errors (±): {src}. <b>n/m</b> (not meaningful): the ratio's denominator D "
        f"(X_{_esc(base)}, or the wave-induced part X_{_esc(base)} − X_still for P_n, or "
        f"X_still for the increment) is near zero, |D| &lt; max({k:g} SE(D), {100 * f:g} % "
        "of the KPI's scale S), S = the largest |X| of that KPI over every case, sea state "
        "and controller of the campaign: a denominator under 1 % of the scale turns a "
        "difference of 1 % of the scale into more than 100 %. <b>!</b>: the change (R − 1; "
        f"for P_n its distance from 100 %) is within {k:g} SE, i.e. within its noise. The "
        "Σp· figures are n/m when one case is. <b>n/a: baseline within noise</b>: P_n's "
        f"denominator X_{_esc(base)} − X_still is under max({k:g} SE(D), "
        f"{100 * noise.get('wave_effect_fraction', ck.WAVE_EFFECT_FRACTION):g} % of S): the "
        "waves change the baseline too little for a fraction of their effect to mean "
        "anything, so no number is given (module hil.campaign.kpi). aggregates.json keeps "
        "every other number with its status (module hil.review.kpi_stats).</p>"
    )


def _per_case_table(
    kpis: Sequence[str],
    labels: Sequence[str],
    cases: Sequence[str],
    rel: dict[str, Any],
    norm: dict[str, Any],
) -> str:
    """Per load case: relative and P_n with their SE and status."""
    head = ["KPI", *[f"{c} relative" for c in cases]]
    if norm:
        head += [f"{c} P_n" for c in cases]
    body = []
    for k, lab in zip(kpis, labels, strict=True):
        row = [lab, *[kst.percent_text(figure_stat(rel[k], c)) for c in cases]]
        if norm:
            row += [ck.figure_text(figure_stat(norm[k], c), signed=False) for c in cases]
        body.append(row)
    return table(head, body)


def _psd_grid(
    rows: Sequence[dict[str, Any]],
    results: dict[str, dict[str, Any]],
    run_dirs: dict[tuple[str, str, str, int], str],
    cases: Sequence[str],
    base: str,
) -> str:
    plt = _pyplot()
    ncol = min(4, max(1, len(cases)))
    nrow = math.ceil(len(cases) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol, 2.6 * nrow), squeeze=False)
    configs = sorted(
        {(r["waves"], r["controller"]) for r in rows},
        key=lambda wc: (wc[0] != "waves", wc[1] != base, wc[1]),
    )
    for ax, case in zip(axes.flat, cases, strict=False):
        for waves, ctrl in configs:
            psds = []
            for r in rows:
                if (r["case"], r["waves"], r["controller"]) != (case, waves, ctrl):
                    continue
                res = results.get(run_dirs.get((case, waves, ctrl, r["seed"]), ""), {})
                psds.append((res.get("psd") or {}).get("rotor_speed_rpm", {}))
            m = _mean_psd(psds)
            if m is not None:
                ax.loglog(m[0], m[1], lw=0.9, label=f"{ctrl} ({waves})")
        ax.set_title(case, fontsize=9)
        ax.set_xlabel("f [Hz]", fontsize=8)
        ax.set_ylabel("rpm²/Hz", fontsize=8)
        ax.grid(True, which="both", alpha=0.2)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(cases) :]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="lower center", ncol=min(5, len(labels)), fontsize=7)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    return img(png_data_uri(fig), "rotor-speed PSDs per load case")


# --------------------------------------------------------------------------- one run, compare


def run_html(mcap_path: Path, out_dir: Path | None = None) -> tuple[str, dict[str, Any]]:
    """The report of one run from its MCAP file: summary tables and the review's plots.

    Returns
    -------
    (str, dict)
        The HTML page and the review summary (with ``campaign_kpi``).
    """
    import tempfile  # noqa: PLC0415

    from hil.review.core import summarize, write_plots  # noqa: PLC0415
    from hil.runlog.mcap_io import read_run  # noqa: PLC0415

    run = read_run(Path(mcap_path))
    summary = summarize(run)
    camp = _campaign_kpis(run, summary)
    summary["campaign_kpi"] = camp["kpi"]
    summary["campaign_kpi_window"] = camp["kpi_window"]
    parts = [f"<p>Run log: <code>{_esc(mcap_path)}</code>. "]
    sc = summary.get("scenario") or {}
    parts.append(f"Scenario: <b>{_esc(sc.get('name'))}</b>.</p>")
    if run.truncated:
        parts.append(f'<p class="bad">The log is truncated: {_esc(run.error)}</p>')
    win = _window_text(summary.get("kpi_window") or {})
    parts.append(f'<p class="note">{_esc(win)}</p>')
    for section, title in run_sections(summary):
        flat = _flatten(summary.get(section) or {})
        if not flat:
            continue
        parts.append(f"<h2>{_esc(title)}</h2>")
        if section == "kpi":  # named and in the units of fowt review and fowt compare
            rows = [[kpi_names.heading(k), fmt(kpi_names.shown(k, v)), k] for k, v in flat]
            parts.append(table(["KPI", "value", "summary.json key (SI)"], rows))
        else:
            parts.append(table(["key", "value"], [[k, fmt(v)] for k, v in flat]))
    for reason in ck.NOT_AVAILABLE.values():
        parts.append(f'<p class="note">{_esc(reason)}.</p>')
    with tempfile.TemporaryDirectory(prefix="fowt-report-") as tmp:
        d = Path(out_dir) if out_dir is not None else Path(tmp)
        for png in write_plots(run, d, summary):
            title = PLOT_TITLES.get(png.name, png.stem)
            parts.append(f"<h2>{_esc(title)}</h2>")
            parts.append(file_img(png, title))
    title = f"Run {sc.get('name') or Path(mcap_path).parent.name}"
    return page(title, "".join(parts)), summary


#: Section titles of the run report's figures (the files of :func:`hil.review.core.write_plots`).
PLOT_TITLES = {
    "timeseries.png": "Time series: truth, commands and measurements (KPI window from the "
    "dotted line)",
    "timing.png": "Timing: control-loop latency per cycle and its histogram",
    "psd.png": "Power spectral densities over the KPI window",
}


def _window_text(win: dict[str, Any]) -> str:
    """The KPI window in words (the same for every KPI table of the report)."""
    lo, hi = win.get("from_s"), win.get("to_s")
    text = (
        f"Every KPI below (review, campaign, estimator, forecast) is taken over the KPI "
        f"window t = {fmt(lo)}-{fmt(hi)} s: the first {fmt(lo)} s of start-up are left out "
        f"([review] settle_s = {fmt(win.get('settle_s'))} s"
    )
    if win.get("shortened"):
        text += "; the run is shorter than twice that, so its second half is kept"
    return text + "); DELs: Wöhler m = 4, 1 Hz equivalent, rainflow over the window."


def run_sections(summary: dict[str, Any]) -> list[tuple[str, str]]:
    """(summary key, section title) of the run report's tables, each title naming what the
    table shows (the KPI window, λ* of Ω_opt)."""
    cw = summary.get("campaign_kpi_window") or {}
    tsr = cw.get("tsr_opt")
    return [
        ("kpi", "KPIs of the run (fowt review; KPI window)"),
        (
            "campaign_kpi",
            f"Campaign KPIs (al-2019 table 2-3; KPI window; Ω_opt with λ* = {fmt(tsr)}, "
            f"Ω_min = {fmt(cw.get('min_rotor_speed_rad_s'))} rad/s)",
        ),
        ("timing", "Timing and deadline accounts (whole run)"),
        ("estimator", "Estimator against the truth (KPI window)"),
        ("forecast", "Wave forecast accuracy (KPI window)"),
    ]


def _flatten(d: dict[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    out: list[tuple[str, Any]] = []
    for k, v in d.items():
        if isinstance(v, dict):
            out += _flatten(v, f"{prefix}{k}.")
        elif not isinstance(v, list):
            out.append((f"{prefix}{k}", v))
    return out


def _campaign_kpis(run: Any, summary: dict[str, Any]) -> dict[str, Any]:
    """The campaign KPIs of a run read from its MCAP file and their window: ``{"kpi",
    "kpi_window"}`` (nan KPIs when the log's scenario cannot be read)."""
    import msgspec  # noqa: PLC0415

    from hil.campaign.runner import run_kpis_of  # noqa: PLC0415
    from hil.scenario.schema import Scenario, recorded_scenarios  # noqa: PLC0415

    config = (summary.get("scenario") or {}).get("config")
    try:
        # the KPIs need the turbine, wind and review keys: a controller kind whose plug-in is
        # not installed where the log is read takes nothing away from them
        with recorded_scenarios():
            scenario = msgspec.convert(config, Scenario)
    except (msgspec.ValidationError, TypeError, ValueError):
        return {"kpi": {k: math.nan for k in ck.KPIS}, "kpi_window": {}}
    res = run_kpis_of(run, scenario, None)
    return {"kpi": res["kpi"], "kpi_window": res["kpi_window"]}


_COMPARE_SERIES = (
    ("rotor_speed_rad_s", "rotor speed [rpm]", ck.RPM_PER_RAD_S),
    ("blade_pitch_rad", "blade pitch [deg]", 180.0 / math.pi),
    ("generator_torque_nm", "generator torque [MN m]", 1e-6),
    ("electrical_power_w", "electrical power [MW]", 1e-6),
    ("platform_pitch_rad", "platform pitch [deg]", 180.0 / math.pi),
    ("tower_base_moment_nm", "tower-base moment [MN m]", 1e-6),
)

#: Spectra of ``fowt compare``: field, name, PSD unit (the square of the series' unit per
#: Hz: a PSD integrates over frequency to the variance), scale to the series' unit.
COMPARE_PSDS = (
    ("rotor_speed_rad_s", "rotor speed", "rpm²/Hz", ck.RPM_PER_RAD_S),
    ("platform_pitch_rad", "platform pitch", "deg²/Hz", 180.0 / math.pi),
    ("tower_base_moment_nm", "tower-base moment", "(MN m)²/Hz", 1e-6),
)


def compare_diffs(vals: Sequence[Any]) -> tuple[list[float | None], list[str]]:
    """Δ % of each run vs run 0 and its status (:func:`hil.review.kpi_stats.simple_ratio_status`).

    The scale S of the n/m rule is the largest |x| over the compared runs; single runs
    carry no standard error, so a difference is never called noise here.
    """
    nums = [
        float(v) if isinstance(v, int | float) and not isinstance(v, bool) else math.nan
        for v in vals
    ]
    scale = kst.scale_of(nums)
    ref = nums[0]
    diffs: list[float | None] = []
    status: list[str] = []
    for x in nums:
        st = kst.simple_ratio_status(x, ref, scale)
        status.append(st)
        diffs.append(100.0 * (x / ref - 1.0) if st == kst.OK else None)
    return diffs, status


def _scaled(v: Any, scale: float) -> Any:
    """``v`` x ``scale`` for a number, anything else as it is."""
    return v * scale if isinstance(v, int | float) and not isinstance(v, bool) else v


def diff_text(d: float | None, status: str) -> str:
    """A compare cell's difference: ``+1.23 %``, ``n/m`` or ``-``."""
    if status == kst.NOT_MEANINGFUL:
        return kst.NOT_MEANINGFUL
    return "-" if d is None else f"{d:+.2f} %"


def compare_name(key: str) -> tuple[str, float]:
    """(``label [unit]``, scale to that unit) of a row of :func:`compare_runs`: a review KPI
    (``kpi.*``) as ``fowt review`` names it (:mod:`hil.review.kpi_names`), a campaign KPI
    (``campaign.*``) as the campaign tables do (:data:`hil.campaign.kpi.KPIS`)."""
    group, _, name = key.partition(".")
    if group == "kpi":
        k = kpi_names.kpi_name(name)
        return k.heading, k.scale
    if group == "campaign" and name in ck.KPIS:
        unit, _direction, label = ck.KPIS[name]
        return f"campaign {label} [{unit}]", 1.0
    if key == "timing.deadline_misses":
        return "deadline misses [1]", 1.0
    return key, 1.0


def compare_runs(paths: Sequence[Path], out: Path) -> dict[str, Any]:
    """Compare runs: KPI table with % differences vs the first, overlaid series and PSDs.

    Writes ``compare.json``, ``compare_timeseries.png``, ``compare_psd.png`` and
    ``compare.html`` into ``out``.

    Every KPI comes from the functions ``fowt review`` and campaigns use, over the same KPI
    window (:func:`hil.review.kpi.window_start_s`), so a run's values here equal its report's.

    Returns
    -------
    dict
        ``runs`` (labels, paths, KPI windows), ``kpi[name] = [value per run]``,
        ``kpi_names[name]`` (the row's ``label [unit]``, :func:`compare_name`; ``kpi`` keeps
        the values as named, SI), ``diff_pct[name] = [100 (x_j / x_0 − 1) per run]`` (None
        where not given) and
        ``diff_status[name]`` (``ok``, ``n/m``: x_0 near zero against the largest |x| of the
        runs, :mod:`hil.review.kpi_stats`; ``n/a``: missing); ``psd_ylabels`` (the PSD panels'
        axis labels: units squared per Hz).
    """
    import json  # noqa: PLC0415

    from scipy.signal import welch  # noqa: PLC0415

    from hil.review.core import summarize  # noqa: PLC0415
    from hil.runlog.mcap_io import read_run  # noqa: PLC0415

    out.mkdir(parents=True, exist_ok=True)
    runs = []
    labels: list[str] = []
    windows: list[dict[str, Any]] = []
    kpi_rows: dict[str, list[Any]] = {}
    for p in paths:
        run = read_run(Path(p))
        if not run.topic("truth"):
            raise ValueError(f"{p}: no truth channel in the log ({run.error or 'empty'})")
        s = summarize(run)
        camp = _campaign_kpis(run, s)
        windows.append({**(s.get("kpi_window") or {}), **camp["kpi_window"]})
        merged = {**{f"kpi.{k}": v for k, v in _flatten(s.get("kpi") or {})}}
        merged.update({f"campaign.{k}": v for k, v in camp["kpi"].items()})
        merged["timing.deadline_misses"] = (s.get("timing") or {}).get("deadline_misses")
        runs.append(run)
        name = (s.get("scenario") or {}).get("name") or Path(p).parent.name
        label = f"{len(labels)}: {name}"
        labels.append(label)
        for k, v in merged.items():
            kpi_rows.setdefault(k, [None] * (len(labels) - 1)).append(v)
        for vals in kpi_rows.values():
            if len(vals) < len(labels):
                vals.append(None)
    diff: dict[str, list[Any]] = {}
    diff_status: dict[str, list[str]] = {}
    for k, vals in kpi_rows.items():
        diff[k], diff_status[k] = compare_diffs(vals)
    plt = _pyplot()
    fig, axes = plt.subplots(len(_COMPARE_SERIES), 1, figsize=(11, 14), sharex=True)
    fig2, axes2 = plt.subplots(3, 1, figsize=(10, 9))
    for run, label, win in zip(runs, labels, windows, strict=True):
        truth = run.topic("truth")
        t = np.array([m["sample_time_ns"] for m in truth], dtype=np.float64) / 1e9
        for ax, (name, ylab, scale) in zip(axes, _COMPARE_SERIES, strict=True):
            y = np.array([m.get(name, np.nan) for m in truth], dtype=np.float64) * scale
            ax.plot(t, y, lw=0.8, label=label)
            ax.set_ylabel(ylab, fontsize=8)
            if win.get("from_s") is not None:
                ax.axvline(float(win["from_s"]), color="0.5", ls=":", lw=0.8)
        in_window = t >= float(win.get("from_s") or 0.0)
        tw = t[in_window]
        dt = float(np.median(np.diff(tw))) if tw.size > 1 else 1.0
        for ax, (name, what, unit, scale) in zip(axes2, COMPARE_PSDS, strict=True):
            y = np.array([m.get(name, np.nan) for m in truth], dtype=np.float64)[in_window]
            y = y * scale
            if tw.size >= 64 and np.isfinite(y).all():
                f, pxx = welch(y, fs=1.0 / dt, nperseg=min(tw.size, round(256 / dt)))
                sel = (f > 0) & (f <= 1.0)
                ax.loglog(f[sel], pxx[sel], lw=0.9, label=label)
            ax.set_ylabel(f"PSD of {what}\n[{unit}]", fontsize=8)
    for ax in [*axes, *axes2]:
        ax.grid(True, alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=7)
    axes[-1].set_xlabel("simulated time [s]")
    axes2[-1].set_xlabel("frequency [Hz]")
    fig.tight_layout()
    fig2.tight_layout()
    psd_ylabels = [ax.get_ylabel() for ax in axes2]
    ts_path = out / "compare_timeseries.png"
    psd_path = out / "compare_psd.png"
    fig.savefig(ts_path, dpi=90)
    fig2.savefig(psd_path, dpi=90)
    plt.close(fig)
    plt.close(fig2)
    result = {
        "runs": [
            {"label": lab, "path": str(p), "kpi_window": w}
            for lab, p, w in zip(labels, paths, windows, strict=True)
        ],
        "kpi": kpi_rows,
        "kpi_names": {k: compare_name(k)[0] for k in kpi_rows},
        "diff_pct": diff,
        "diff_status": diff_status,
        "psd_ylabels": psd_ylabels,
    }
    from hil.campaign.runner import _json_clean  # noqa: PLC0415

    (out / "compare.json").write_text(json.dumps(_json_clean(result), indent=1) + "\n")
    head = ["KPI", *labels[:1], *[f"{lab} (Δ %)" for lab in labels[1:]]]
    body = []
    for k, vals in kpi_rows.items():
        name, scale = compare_name(k)
        cells = [fmt(_scaled(vals[0], scale))]
        for v, d, st in zip(vals[1:], diff[k][1:], diff_status[k][1:], strict=True):
            cells.append(f"{fmt(_scaled(v, scale))} ({diff_text(d, st)})")
        body.append([name, *cells])
    note = (
        '<p class="note">KPIs over each run\'s KPI window ('
        + "; ".join(
            f"{_esc(lab)}: t = {fmt(w.get('from_s'))}-{fmt(w.get('to_s'))} s, λ* = "
            f"{fmt(w.get('tsr_opt'))}"
            for lab, w in zip(labels, windows, strict=True)
        )
        + "), the same functions and window as fowt report and campaigns (DELs: Wöhler m = "
        "4, 1 Hz equivalent). The review's KPIs are named and in the units of fowt review, "
        "campaign ones are al-2019's table 2-3 (compare.json keeps them in SI units, kpi.* "
        "and campaign.*; the same name in both is the same number). Δ % vs run 0; n/m: run "
        f"0's value is near zero, under {100 * kst.NEAR_ZERO_FRACTION:g} % of the largest "
        "|x| of the runs (hil.review.kpi_stats); single runs carry no standard error, so a "
        "difference here is not tested against its noise (a campaign with several seeds is).</p>"
    )
    body_html = (
        note
        + table(head, body)
        + "<h2>Time series (dotted: start of the KPI window)</h2>"
        + file_img(ts_path, "overlaid time series")
        + "<h2>PSDs over the KPI window [rpm²/Hz, deg²/Hz, (MN m)²/Hz]</h2>"
        + file_img(psd_path, "PSDs")
    )
    (out / "compare.html").write_text(page("Comparison of runs", body_html))
    return result
