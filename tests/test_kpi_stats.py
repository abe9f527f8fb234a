"""Ratios of KPIs with their noise (hil.review.kpi_stats) and how the campaign shows them.

Synthetic inputs with known answers: a near-zero denominator is ``n/m``; the paired
standard error matches its formula by hand and, over seeded Monte-Carlo replicates, the
actual spread of the ratio; the campaign aggregates and report of hand-made rows say
``n/m`` where al-2019's ratios lose their meaning and label every section by the
controller it shows.
"""

from __future__ import annotations

import math
import re
from html import unescape
from pathlib import Path

import numpy as np
import pytest

from hil.campaign import kpi as ck
from hil.campaign.html_report import campaign_html, compare_diffs, diff_text
from hil.campaign.runner import aggregate, parse_campaign
from hil.review import kpi_stats as kst

# --------------------------------------------------------------------------- the n/m rule


def test_near_zero_rule_scale_and_noise() -> None:
    # scale: under 1 % of the largest |X| is near zero, whatever the noise
    assert kst.near_zero(0.009, scale=1.0)
    assert not kst.near_zero(0.011, scale=1.0)
    # noise: within 2 SE of 0 is near zero even when large against the scale's 1 %
    assert kst.near_zero(0.05, scale=1.0, se=0.03)
    assert not kst.near_zero(0.05, scale=1.0, se=0.02)
    # exactly 0 always; a non-finite denominator is "no value", not n/m
    assert kst.near_zero(0.0, scale=math.nan)
    assert not kst.near_zero(math.nan, scale=1.0)


def test_relative_change_of_a_near_zero_baseline_is_nm() -> None:
    # al-2019 LC4 shaft DEL: the baseline holds a constant torque above rated, DEL ~ 1 N m,
    # a controller moving the torque has ~ 2.9e6 N m: +2.9e8 % without the rule
    base = np.array([1.1, 0.9, 1.0])
    ctrl = np.array([2.8e6, 3.0e6, 2.9e6])
    scale = kst.scale_of([*base, *ctrl])
    r = kst.weighted_ratio([ctrl.mean()], [base.mean()], [1.0], [ctrl], [base], scale, offset=1.0)
    assert r.status == kst.NOT_MEANINGFUL
    assert kst.percent_text(r) == "n/m"
    # a denominator of 2 % of the scale with little noise is a number again
    base2 = base * 0.02 * 2.9e6
    r2 = kst.weighted_ratio(
        [ctrl.mean()], [base2.mean()], [1.0], [ctrl], [base2], scale, offset=1.0
    )
    assert r2.status == kst.OK and r2.value == pytest.approx(ctrl.mean() / base2.mean() - 1)


def test_pn_of_a_tiny_wave_induced_part_is_nm() -> None:
    # the reported case: waves lower var(Omega) by 0.43 % (X_base - X_still = -0.0043 X),
    # the controller changes it by -0.3 %: P_n = 1 + 0.3 / 0.43 = 170 % without the rule
    still = np.array([1.00, 1.02, 0.98, 1.01])
    base = still * (1 - 0.0043)
    ctrl = base * (1 - 0.003)
    p_n = (ctrl.mean() - still.mean()) / (base.mean() - still.mean())
    assert p_n == pytest.approx(1.70, abs=0.01)
    r = kst.weighted_ratio(
        [ctrl.mean() - still.mean()],
        [base.mean() - still.mean()],
        [1.0],
        [ctrl - still],
        [base - still],
        kst.scale_of([*still, *base, *ctrl]),
    )
    assert r.status == kst.NOT_MEANINGFUL
    assert r.denominator == pytest.approx(base.mean() - still.mean())


def test_paired_standard_error_by_hand() -> None:
    d = np.array([10.0, 12.0, 9.0, 11.0, 13.0])
    a = np.array([10.5, 12.4, 9.2, 11.7, 13.3])
    r = kst.weighted_ratio([a.mean()], [d.mean()], [1.0], [a], [d], 13.3, offset=1.0)
    big_r = a.mean() / d.mean()
    e = a - big_r * d
    se = np.std(e, ddof=1) / math.sqrt(5) / d.mean()
    assert r.value == pytest.approx(big_r - 1, rel=1e-12)
    assert r.se == pytest.approx(se, rel=1e-12)
    assert r.status == kst.OK  # +3.6 % with SE 0.4 %
    # one seed: SE not estimable, said as "± ?"
    one = kst.weighted_ratio([a[0]], [d[0]], [1.0], [a[:1]], [d[:1]], 13.3, offset=1.0)
    assert math.isnan(one.se) and one.status == kst.OK
    assert kst.percent_text(one).endswith("± ?")


def test_change_within_noise_is_flagged() -> None:
    rng = np.random.default_rng(7)
    d = 100 + 10 * rng.standard_normal(6)
    a = d * 1.001 + 2.0 * rng.standard_normal(6)  # +0.1 % under ~1 % of pairing noise
    r = kst.weighted_ratio([a.mean()], [d.mean()], [1.0], [a], [d], 130.0, offset=1.0)
    assert r.status == kst.NOISE and abs(r.value) < kst.NOISE_K * r.se
    assert kst.percent_text(r).endswith("!")


def test_weighted_standard_error_by_hand_and_sigma_p() -> None:
    rng = np.random.default_rng(3)
    p = [0.2, 0.5, 0.3]
    ds = [50 + 5 * rng.standard_normal(4) for _ in p]
    as_ = [d * 0.9 + rng.standard_normal(4) for d in ds]
    am = [float(x.mean()) for x in as_]
    dm = [float(x.mean()) for x in ds]
    r = kst.weighted_ratio(am, dm, p, as_, ds, 60.0, offset=1.0)
    rw = sum(pi * ai for pi, ai in zip(p, am, strict=True)) / sum(
        pi * di for pi, di in zip(p, dm, strict=True)
    )
    var = sum(pi**2 * np.var(a - rw * d, ddof=1) / 4 for pi, a, d in zip(p, as_, ds, strict=True))
    assert r.value == pytest.approx(rw - 1, rel=1e-12)
    assert r.se == pytest.approx(
        math.sqrt(var) / sum(pi * di for pi, di in zip(p, dm, strict=True))
    )
    per = [
        kst.weighted_ratio([x], [y], [1.0], [a], [d], 60.0, 1.0)
        for x, y, a, d in zip(am, dm, as_, ds, strict=True)
    ]
    m = kst.weighted_mean_of(per, p, 1.0)
    assert m.value == pytest.approx(sum(pi * q.value for pi, q in zip(p, per, strict=True)))
    assert m.se == pytest.approx(
        math.sqrt(sum((pi * q.se) ** 2 for pi, q in zip(p, per, strict=True)))
    )
    # one n/m case makes the Σp· figure n/m
    bad = [*per[:2], kst.Ratio(5e6, math.nan, kst.NOT_MEANINGFUL)]
    assert kst.weighted_mean_of(bad, p, 1.0).status == kst.NOT_MEANINGFUL


def test_standard_error_matches_the_spread_of_replicates() -> None:
    # 2000 seeded replicate campaigns of 6 paired seeds: the mean linearised SE of R is
    # the standard deviation of R over the replicates within 10 % (the delta method's
    # error at this noise is far smaller; 10 % covers the Monte-Carlo error of 2000 draws)
    rng = np.random.default_rng(2026)
    rs, ses = [], []
    for _ in range(2000):
        common = 3.0 * rng.standard_normal(6)  # shared by both configurations (same seed)
        d = 100 + common + rng.standard_normal(6)
        a = 95 + common + rng.standard_normal(6)
        r = kst.weighted_ratio([a.mean()], [d.mean()], [1.0], [a], [d], 110.0, offset=1.0)
        rs.append(r.value)
        ses.append(r.se)
    assert float(np.mean(ses)) == pytest.approx(float(np.std(rs, ddof=1)), rel=0.10)


def test_compare_diffs_nm_and_text() -> None:
    diffs, status = compare_diffs([2.0, 3.0e6, 2.9e6])
    assert status == ["n/m", "n/m", "n/m"] and diffs == [None, None, None]
    assert diff_text(diffs[1], status[1]) == "n/m"
    diffs, status = compare_diffs([4.512e6, 4.493e6])
    assert status == ["ok", "ok"] and diffs[1] == pytest.approx(100 * (4.493 / 4.512 - 1))
    assert diff_text(diffs[1], status[1]) == f"{diffs[1]:+.2f} %"
    assert compare_diffs([0.0, 0.0])[1] == ["n/m", "n/m"]
    assert compare_diffs([None, 1.0])[1] == ["n/a", "n/a"]


# --------------------------------------------------------------------------- campaign


_TOML = """
name = "stats"
seeds = {seeds}
duration_s = 100.0
baseline = "{base}"
still_water_controllers = ["{base}"]
[[cases]]
name = "lc2"
scenario = "iea15mw-lc2"
probability = 0.5
[[cases]]
name = "lc4"
scenario = "iea15mw-lc4"
probability = 0.5
[[controllers]]
name = "baseline"
kind = "baseline"
preset = "iea15mw_baseline"
[[controllers]]
name = "lqri"
kind = "lqri"
preset = "iea15mw_advanced"
[[controllers]]
name = "ff"
kind = "lqri_ff"
preset = "iea15mw_advanced"
"""


def _rows(campaign: object, seeds: int) -> list[dict[str, object]]:
    """Hand-made rows: shaft DEL of the baseline above rated (lc4) ~ 1 N m, the others
    ~ 3e6; var(Ω) with a wave-induced part of -0.43 % and a change of -0.3 % (ff)."""
    rng = np.random.default_rng(11)
    rows = []
    shared: dict[tuple[str, int], float] = {}  # a seed's wind and waves: common to its runs
    for spec in campaign.runs:  # type: ignore[attr-defined]
        row: dict[str, object] = {
            "case": spec.case,
            "probability": spec.probability,
            "controller": spec.controller,
            "waves": spec.waves,
            "seed": spec.seed,
            "status": "ok",
        }
        common = shared.setdefault((spec.case, spec.seed), float(rng.standard_normal()))
        for k in ck.KPIS:
            row[k] = 10.0 + 0.5 * common + 0.01 * rng.standard_normal()
        above_rated_constant_torque = spec.case == "lc4" and spec.controller == "baseline"
        row["shaft_del_nm"] = (
            1.0 + 0.1 * rng.standard_normal()
            if above_rated_constant_torque
            else 2.9e6 * (1 + 0.02 * common)
        )
        v = 1.0 + 0.02 * common
        if spec.waves == "waves":
            v *= 1 - 0.0043
            if spec.controller == "ff":
                v *= 1 - 0.003
        row["rotor_speed_var_rpm2"] = v
        rows.append(row)
    return rows


@pytest.mark.parametrize("base", ["baseline", "lqri"])
def test_campaign_aggregates_and_report_say_nm_and_name_sections(base: str) -> None:
    seeds = 4
    c = parse_campaign(_TOML.format(seeds=seeds, base=base), base_dir=Path("."))
    agg = aggregate(_rows(c, seeds), c)
    if base == "baseline":
        shaft = agg["relative"]["ff"]["shaft_del_nm"]["stats"]
        assert shaft["per_case"]["lc4"]["status"] == "n/m"
        assert shaft["per_case"]["lc2"]["status"] != "n/m"
        assert shaft["weibull_of_cases"]["status"] == "n/m"
        # the raw number stays in the JSON beside its status
        assert agg["relative"]["ff"]["shaft_del_nm"]["per_case"]["lc4"] > 1e5
    pn = agg["normalised"]["ff"]["rotor_speed_var_rpm2"]
    assert pn["per_case"]["lc2"] == pytest.approx(1.70, abs=0.05)
    # the waves change the baseline's var(Ω) by 0.43 %: P_n not defined
    assert pn["stats"]["per_case"]["lc2"]["status"] == ck.BASELINE_NOISE
    assert agg["noise"]["still_water_of"] == base and agg["noise"]["estimable"]
    html = campaign_html(agg, [])
    titles = [unescape(t) for t in re.findall(r"<h2>(.*?)</h2>", html)]
    inc = [t for t in titles if t.startswith("Wave-induced increment")]
    assert inc == [
        f"Wave-induced increment of {base}: waves / still water ({base}'s still-water twins)"
    ]
    others = [n for n in ("baseline", "lqri", "ff") if n != base]
    for ctrl in others:
        assert (
            f"{ctrl} vs {base} (relative, waves); P_n against {base}'s still-water twins" in titles
        )
    # the other controllers' names never label the increment (it is the baseline's twins)
    assert not any(o in inc[0] for o in others)
    assert "n/m" in html
    # no percentage of a near-zero denominator anywhere in the page
    pcts = [float(x) for x in re.findall(r"([+-]?\d+(?:\.\d+)?) %", html)]
    assert max(abs(x) for x in pcts) < 1000


def test_campaign_with_one_seed_says_se_not_estimable() -> None:
    c = parse_campaign(_TOML.format(seeds=1, base="baseline"), base_dir=Path("."))
    agg = aggregate(_rows(c, 1), c)
    assert not agg["noise"]["estimable"]
    rel = agg["relative"]["lqri"]["mean_power_w"]["stats"]["weibull"]
    assert math.isnan(rel["se"]) and rel["status"] in ("ok", "noise")
    html = campaign_html(agg, [])
    assert "not estimable: one seed" in html and "± ?" in html


def test_normalised_of_a_baseline_within_noise_is_not_a_number() -> None:
    """var(Ω − Ω_opt): the waves add 1.2 % of the KPI's scale to the baseline (above the n/m
    rule's 1 % floor, and 7 SE from zero), the controller 40 %: eq. (5-1) gives about
    −3500 %. The normalised figure is "n/a: baseline within noise" (under 5 % of the scale),
    in the JSON, the console table and the HTML; the relative figure stays a number."""
    from rich.console import Console

    from hil.cli.campaign import render_aggregates

    seeds = 4
    c = parse_campaign(_TOML.format(seeds=seeds, base="baseline"), base_dir=Path("."))
    rows = _rows(c, seeds)
    rng = np.random.default_rng(5)
    for row in rows:
        v = 1.0 + 0.0005 * rng.standard_normal()
        if row["waves"] == "waves":
            v += 0.012
            if row["controller"] == "ff":
                v -= 0.42
        row["rotor_speed_error_var_rpm2"] = v
    agg = aggregate(rows, c)
    k = "rotor_speed_error_var_rpm2"
    pn = agg["normalised"]["ff"][k]
    assert pn["weibull"] == pytest.approx(-34.0, rel=0.1)  # eq. (5-1) as such
    # the old rule let it through: D = 1.2 % of S > 1 %, and far outside 2 SE(D)
    d = 0.012
    assert not kst.near_zero(d, scale=1.012, se=0.0005)
    stats = pn["stats"]
    for figure in (stats["weibull"], stats["weibull_of_cases"], *stats["per_case"].values()):
        assert figure["status"] == ck.BASELINE_NOISE
        assert math.isnan(figure["value"])
    assert agg["noise"]["wave_effect_fraction"] == ck.WAVE_EFFECT_FRACTION
    rel = agg["relative"]["ff"][k]["stats"]["weibull"]
    assert rel["status"] == "ok" and rel["value"] == pytest.approx(-0.41, abs=0.01)
    console = Console(width=400, record=True)
    render_aggregates(agg, console)
    text = console.export_text()
    assert "n/a: baseline within noise" in text
    html = campaign_html(agg, [])
    assert "n/a: baseline within noise" in html
    pcts = [float(x) for x in re.findall(r"([+-]?\d+(?:\.\d+)?) %", html)]
    assert max(abs(x) for x in pcts) < 1000
    # a wave effect of 20 % of the scale, well outside its noise: P_n is a number again
    for row in rows:
        if row["waves"] == "waves":
            row[k] = float(row[k]) + 0.2  # type: ignore[arg-type]
    pn = aggregate(rows, c)["normalised"]["ff"][k]["stats"]["weibull"]
    assert pn["status"] in ("ok", "noise") and pn["value"] == pytest.approx(
        1 - 0.42 / 0.212, rel=0.05
    )
