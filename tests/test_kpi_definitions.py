"""One KPI definition for ``fowt review``/``report``, ``fowt compare`` and campaigns.

A run's KPIs must not depend on the command that computes them: the same functions
(:mod:`hil.review.kpi`, :mod:`hil.campaign.kpi`) over the same window
(:func:`hil.review.kpi.window_start_s`
of ``[review] settle_s``) with the same DEL parameters. Two short in-process runs of load case
2 are reported, compared and recomputed as a campaign task; their KPIs agree exactly. Also
here: λ* of Ω_opt (``[review] tsr_opt``, the campaign's ``tsr_opt``), the run report's
section titles and the units of ``compare_psd.png``.
"""

from __future__ import annotations

import math
import re
from html import unescape
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest

from hil.campaign import kpi as ck
from hil.campaign.html_report import PLOT_TITLES, compare_runs, run_html, run_sections
from hil.campaign.runner import _turbine_figures, execute_run, parse_campaign, run_kpis_of
from hil.launch import RunRequest, launch
from hil.review import kpi
from hil.review.core import _col
from hil.runlog.mcap_io import read_run
from hil.scenario.schema import ReviewSection, Scenario

#: The default settle time: the KPI window is [SETTLE_S, DURATION_S].
SETTLE_S = ReviewSection().settle_s
DURATION_S = 150.0  # > 2 x settle_s

#: review KPI name -> the campaign KPI computed by the same function on the same window
SAME = {
    "mean_power_w": "mean_power_w",
    "shaft_del_nm": "shaft_del_nm",
    "tower_base_del_nm": "tower_base_del_nm",
    "pitch_travel_deg_s": "pitch_rate_mean_abs_deg_s",
    "platform_pitch_std_deg": "platform_pitch_std_deg",
    "surge_std_m": "platform_surge_std_m",
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    root = tmp_path_factory.mktemp("kpidef")
    out = {}
    for name in ("iea15mw-lc2", "iea15mw-lc2-lqri"):
        launch(
            RunRequest(
                name, mode="inprocess", duration_s=DURATION_S, out_dir=root / name, plots=False
            )
        )
        out[name] = root / name / "run.mcap"
    out["root"] = root
    return out


def test_report_compare_and_campaign_give_identical_kpis(runs: dict[str, Any]) -> None:
    a, b = runs["iea15mw-lc2"], runs["iea15mw-lc2-lqri"]
    _text, summary = run_html(a)
    res = compare_runs([a, b], runs["root"] / "cmp")
    # the review's and the campaign's KPIs of one run over one window
    win = summary["kpi_window"]
    assert win["from_s"] == SETTLE_S and summary["campaign_kpi_window"]["from_s"] == SETTLE_S
    for rk, ckey in SAME.items():
        assert summary["kpi"][rk] == pytest.approx(summary["campaign_kpi"][ckey], rel=1e-12), rk
    assert summary["kpi"]["shaft_del_wohler_m"] == kpi.DEL_WOHLER_M == 4.0
    # report == compare, KPI by KPI
    for k, v in summary["campaign_kpi"].items():
        got = res["kpi"][f"campaign.{k}"][0]
        assert (v is None and got is None) or got == pytest.approx(v, rel=1e-12), k
    for k, v in summary["kpi"].items():
        got = res["kpi"][f"kpi.{k}"][0]
        assert (v is None and got is None) or got == pytest.approx(v, rel=1e-12), k
    # a campaign task on the same scenario (in memory, no MCAP read back) gives the same
    scenario = read_run(a).metadata["scenario"]["json"]
    task = execute_run(
        {
            "scenario": msgspec.json.decode(scenario),
            "mode": "inprocess",
            "run_dir": str(runs["root"] / "task"),
            "record": "none",
            "design_dir": None,
            "min_rotor_speed_rad_s": None,
        }
    )
    assert task["status"] == "ok", task["error"]
    for k, v in summary["campaign_kpi"].items():
        assert task["kpi"][k] == pytest.approx(v, rel=1e-12, nan_ok=True), k
    assert task["kpi_window"]["from_s"] == SETTLE_S


def test_campaign_kpis_leave_the_start_up_out(runs: dict[str, Any]) -> None:
    # the window is what made report and compare differ (4.512 vs 4.493 MW in LC2): the
    # campaign KPIs used to start at t = 0, through the start-up transient
    run = read_run(runs["iea15mw-lc2"])
    truth = run.topic("truth")
    t = _col(truth, "sample_time_ns") / 1e9
    p = _col(truth, "electrical_power_w")
    cfg = msgspec.json.decode(run.metadata["scenario"]["json"])
    k = run_kpis_of(run, msgspec.convert(cfg, Scenario), None)["kpi"]
    assert k["mean_power_w"] == pytest.approx(float(np.mean(p[t >= SETTLE_S])), rel=1e-12)
    assert k["mean_power_w"] != pytest.approx(float(np.mean(p)), rel=1e-4)


def test_tsr_opt_default_key_and_campaign_key(runs: dict[str, Any]) -> None:
    run = read_run(runs["iea15mw-lc2"])
    cfg = msgspec.json.decode(run.metadata["scenario"]["json"])
    default = msgspec.convert(cfg, Scenario)
    assert default.review.tsr_opt is None
    # default: the argmax of Cp(λ, 0) as the plant interpolates it, a grid point (8.5)
    from plant.turbine import load_turbine

    table = load_turbine("iea15mw").table
    lam0 = _turbine_figures("iea15mw")[0]
    assert lam0 == pytest.approx(8.5) and np.min(np.abs(table.tsr - lam0)) < 1e-9
    k0 = run_kpis_of(run, default, None)
    assert k0["kpi_window"]["tsr_opt"] == lam0
    smooth = msgspec.convert({**cfg, "review": {**cfg["review"], "tsr_opt": 8.71}}, Scenario)
    k1 = run_kpis_of(run, smooth, None)
    assert k1["kpi_window"]["tsr_opt"] == 8.71
    # by hand over the window with λ* = 8.71
    truth = run.topic("truth")
    t = _col(truth, "sample_time_ns") / 1e9
    sel = t >= SETTLE_S
    _, radius, rated = _turbine_figures("iea15mw")
    opt = ck.optimal_rotor_speed_rad_s(
        _col(truth, "wind_speed_m_s")[sel], 8.71, radius, rated, 0.5236
    )
    want = ck.rotor_speed_error_var_rpm2(_col(truth, "rotor_speed_rad_s")[sel], opt)
    assert k1["kpi"]["rotor_speed_error_var_rpm2"] == pytest.approx(want, rel=1e-12)
    assert k1["kpi"]["rotor_speed_error_var_rpm2"] != pytest.approx(
        k0["kpi"]["rotor_speed_error_var_rpm2"], rel=1e-3
    )
    assert k1["kpi"]["rotor_speed_var_rpm2"] == k0["kpi"]["rotor_speed_var_rpm2"]
    # the campaign key writes [review] tsr_opt into every run (and so into its hash)
    text = """
name = "lam"
duration_s = 100.0
{key}
[[cases]]
name = "lc2"
scenario = "iea15mw-lc2"
probability = 1.0
[[controllers]]
name = "baseline"
preset = "iea15mw_baseline"
"""
    with_key = parse_campaign(text.format(key="tsr_opt = 8.71"), base_dir=Path("."))
    without = parse_campaign(text.format(key=""), base_dir=Path("."))
    assert all(r.scenario["review"]["tsr_opt"] == 8.71 for r in with_key.runs)
    assert all(r.scenario["review"]["tsr_opt"] is None for r in without.runs)
    assert with_key.runs[0].scenario_hash != without.runs[0].scenario_hash


def test_run_report_sections_say_what_they_show(runs: dict[str, Any]) -> None:
    text, summary = run_html(runs["iea15mw-lc2"])
    titles = [unescape(t) for t in re.findall(r"<h2>(.*?)</h2>", text)]
    expected = [t for key, t in run_sections(summary) if summary.get(key)]
    expected += list(PLOT_TITLES.values())
    assert titles == expected
    lam = summary["campaign_kpi_window"]["tsr_opt"]
    assert f"λ* = {lam:.4g}, Ω_min = 0.5236 rad/s" in titles[1]
    assert f"t = {SETTLE_S:g}-150 s" in unescape(text)


def test_compare_psd_axes_are_squared_units_per_hz(runs: dict[str, Any]) -> None:
    res = compare_runs([runs["iea15mw-lc2"], runs["iea15mw-lc2-lqri"]], runs["root"] / "c2")
    units = [re.search(r"\[(.*)\]", lab).group(1) for lab in res["psd_ylabels"]]  # type: ignore[union-attr]
    assert units == ["rpm²/Hz", "deg²/Hz", "(MN m)²/Hz"]
    assert all(not math.isnan(v) for v in res["kpi"]["campaign.mean_power_w"])
