"""``fowt review`` as a user meets it: refusals, truncation, --strict, --json, KPI window, plots.

The run logs are small synthetic ones written with :class:`hil.runlog.mcap_io.RunLog` (a
bottom-fixed or floating truth channel at 20 Hz), except the ``lqri_ff`` start notice, which
runs the shipped ``iea15mw-lc2-lqri-ff`` scenario in process for 4 s.
"""

from __future__ import annotations

import functools
import io
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from _helpers import controller_report, fowt, plant_report, timing_summary
from rich.console import Console

from bus_schemas.messages import VALID_WAVE_GAUGE, PlantState, SensorFrame
from bus_schemas.registry import CONTROLLER_REPORT, PLANT_REPORT, SENSORS, TIMING_SUMMARY, TRUTH
from hil.review import plots
from hil.review.core import (
    DEFAULT_SETTLE_S,
    PLOT_FILES,
    render_summary,
    review,
    write_plots,
)
from hil.review.plots import psd_segment
from hil.runlog.columns import run_batches, run_info
from hil.runlog.mcap_io import NotMcapError, RunLog, read_run

DT_NS = 50_000_000  # 20 Hz
N = 600  # 30 s


# A wide terminal, so that rich does not wrap the one-line messages checked here.
_fowt = functools.partial(fowt, timeout=120.0, columns=400)


def _write(path: Path, *, floating: bool, settle_s: float | None, pitch_zero: bool = False) -> None:
    """A run log: rotor speed 1 rad/s for t < 10 s, then 2 rad/s (the "transient" is the first
    10 s); a floating one also has platform pitch and surge and a gauge dropout at 5-6 s."""
    cfg: dict[str, object] = {"timing": {"control_period_s": 0.05}}
    if settle_s is not None:
        cfg["review"] = {"settle_s": settle_s}
    log = RunLog(path, "t1", start_unix_ns=1_700_000_000_000_000_000, flush_interval_s=0.0)
    log.add_metadata("scenario", {"name": "synthetic", "toml": "", "json": json.dumps(cfg)})
    log.add_metadata("run", {"mode": "inprocess", "speed": "1"})
    for i in range(N):
        t_ns = i * DT_NS
        t = t_ns / 1e9
        rotor = 1.0 if t < 10.0 else 2.0
        pitch = 0.0 if pitch_zero else 0.05 * math.sin(0.5 * t)
        plat = 0.03 + 0.01 * math.sin(2 * math.pi * 0.037 * t) if floating else 0.0
        log.write(
            TRUTH.key("t1"),
            PlantState(
                seq=i,
                sample_time_ns=t_ns,
                publish_time_ns=t_ns,
                rotor_speed_rad_s=rotor,
                generator_speed_rad_s=rotor,
                blade_pitch_rad=pitch,
                generator_torque_nm=1e6,
                aero_torque_nm=1e6,
                rotor_thrust_n=1e6,
                wind_speed_m_s=8.0,
                relative_wind_speed_m_s=8.0,
                electrical_power_w=5e6 * rotor,
                tip_speed_ratio=8.0,
                power_coefficient=0.45,
                thrust_coefficient=0.8,
                blade_pitch_applied_rad=pitch,
                generator_torque_applied_nm=1e6,
                floating=int(floating),
                platform_pitch_rad=plat,
                platform_surge_m=10.0 if floating else 0.0,
                shaft_torque_nm=1e6,
                tower_base_moment_nm=1e8 * (1 + 0.1 * math.sin(t)),
            ),
        )
        dropout = 5.0 <= t < 6.0
        log.write(
            SENSORS.key("t1"),
            SensorFrame(
                seq=i,
                sample_time_ns=t_ns,
                publish_time_ns=t_ns,
                valid_mask=0x7FF & ~(VALID_WAVE_GAUGE if dropout else 0),
                generator_speed_measured_rad_s=rotor,
                rotor_speed_measured_rad_s=rotor,
                blade_pitch_measured_rad=pitch,
                generator_torque_measured_nm=1e6,
                electrical_power_measured_w=5e6,
                wind_speed_measured_m_s=8.0,
                nacelle_acc_fore_aft_measured_m_s2=0.0,
                platform_pitch_measured_rad=plat,
                platform_pitch_rate_measured_rad_s=0.0,
                platform_surge_measured_m=10.0 if floating else 0.0,
                wave_elevation_gauge_measured_m=0.0 if dropout else 0.5,
            ),
        )
    # The plant's final timing summary: without it the run is incomplete (--strict fails).
    log.write(
        TIMING_SUMMARY.key("t1"),
        timing_summary(N, N * DT_NS, publish_time_ns=N * DT_NS),
    )
    # The nodes' end-of-run accounts: what the file must hold (sensors and truth only here).
    log.write(
        PLANT_REPORT.key("t1"),
        plant_report(N, N * DT_NS, cycle_records_published=0),
    )
    log.write(
        CONTROLLER_REPORT.key("t1"),
        controller_report(N, N * DT_NS, commands_published=0, statuses_published=0),
    )
    log.close()


@pytest.fixture(scope="module")
def floating_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("floating") / "run.mcap"
    _write(path, floating=True, settle_s=10.0)
    return path


# ----------------------------------------------------------------- refusals


@pytest.mark.parametrize(
    "content",
    [b"", b"not an mcap file at all\n", bytes(np.random.default_rng(3).integers(0, 256, 4096))],
    ids=["empty", "text", "random"],
)
def test_review_refuses_what_is_not_mcap(content: bytes, tmp_path: Path) -> None:
    folder = tmp_path / "in"
    folder.mkdir()
    bad = folder / "run.mcap"
    bad.write_bytes(content)
    with pytest.raises(NotMcapError, match="is not an MCAP file"):
        read_run(bad)
    args = ["review", str(bad)] if content else ["review", str(bad), "--json", "--plots"]
    proc = _fowt(*args)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = (proc.stdout + proc.stderr).strip().splitlines()
    assert len(lines) == 1 and "is not an MCAP file" in lines[0], lines
    assert sorted(p.name for p in folder.iterdir()) == ["run.mcap"]  # nothing written


def test_review_of_a_truncated_log_says_where_and_strict_fails(
    floating_log: Path, tmp_path: Path
) -> None:
    data = floating_log.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    s = review(cut, tmp_path / "a", plots=False)
    at = s["run"]["truncated_at_s"]
    truth = read_run(cut).topic("truth")
    assert at == pytest.approx(max(m["sample_time_ns"] for m in truth) / 1e9)
    assert 0.0 < at < (N - 1) * DT_NS / 1e9
    proc = _fowt("review", str(cut), "--out", str(tmp_path / "b"), "--no-plots")
    assert proc.returncode == 0
    assert f"truncated at t = {at:.2f} s" in proc.stdout
    proc = _fowt("review", str(cut), "--json", "--out", str(tmp_path / "c"), "--strict")
    assert proc.returncode == 1
    assert f"truncated at t = {at:.2f} s" in proc.stderr
    proc = _fowt("review", str(floating_log), "--json", "--out", str(tmp_path / "d"), "--strict")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_json_writes_no_plots_unless_asked(floating_log: Path, tmp_path: Path) -> None:
    proc = _fowt("review", str(floating_log), "--json", "--out", str(tmp_path / "j"))
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["run"]["truncated"] is False
    assert sorted(p.name for p in (tmp_path / "j").iterdir()) == ["summary.json"]
    proc = _fowt("review", str(floating_log), "--json", "--plots", "--out", str(tmp_path / "p"))
    assert proc.returncode == 0, proc.stderr
    assert {p.name for p in (tmp_path / "p").iterdir()} == {"summary.json", *PLOT_FILES}


# ----------------------------------------------------------------- KPI window


def test_kpis_leave_out_the_settling_time(floating_log: Path, tmp_path: Path) -> None:
    """Rotor speed is 1 rad/s for t < 10 s and 2 rad/s after: with settle_s = 10 the KPIs see
    only the 2 rad/s part (mean 2, std 0); the review says which window it used."""
    s = review(floating_log, tmp_path, plots=False)
    assert s["kpi_window"] == {
        "settle_s": 10.0,
        "from_s": 10.0,
        "to_s": pytest.approx((N - 1) * DT_NS / 1e9),
        "shortened": False,
    }
    assert s["kpi"]["rotor_speed_mean_rad_s"] == pytest.approx(2.0, abs=1e-12)
    assert s["kpi"]["rotor_speed_std_rad_s"] == pytest.approx(0.0, abs=1e-12)
    console = Console(file=io.StringIO(), record=True, width=200)
    render_summary(s, console)
    text = console.export_text()
    assert "KPIs over t = 10.0-29.9 s: the first 10.0 s (start-up settling" in text


def test_default_settle_is_shortened_to_half_a_short_run(tmp_path: Path) -> None:
    """No ``[review]`` in the log: the default 60 s, shortened to half of this 30 s run."""
    path = tmp_path / "run.mcap"
    _write(path, floating=False, settle_s=None)
    s = review(path, tmp_path, plots=False)
    w = s["kpi_window"]
    assert w["settle_s"] == DEFAULT_SETTLE_S == 40.0
    assert w["shortened"] is True and w["from_s"] == pytest.approx(w["to_s"] / 2)
    assert s["kpi"]["rotor_speed_mean_rad_s"] == pytest.approx(2.0)


def test_bottom_fixed_plant_has_no_platform_kpis(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _write(path, floating=False, settle_s=0.0)
    s = review(path, tmp_path, plots=False)
    for key in ("platform_pitch_mean_deg", "platform_pitch_std_deg", "surge_mean_m", "surge_std_m"):
        assert s["kpi"][key] is None, key
    console = Console(file=io.StringIO(), record=True, width=200)
    render_summary(s, console)
    rows = {
        line.split("│")[1].strip(): line.split("│")[2].strip()
        for line in console.export_text().splitlines()
        if line.count("│") >= 4
    }
    assert rows["platform pitch mean"] == "-" and rows["surge std"] == "-"
    assert rows["mean electrical power"] != "-"


# ----------------------------------------------------------------- plots


def test_dropouts_are_gaps_not_zeros(floating_log: Path) -> None:
    run = read_run(floating_log)
    data = plots.collect(
        run_batches(run, plots.PLOT_FIELDS), run_info(run).counts, {}, run.metadata
    )
    sensors = data.series["sensors"]
    gauge = sensors.get("wave_elevation_gauge_measured_m")
    t = sensors.get("t")
    dropout = (t >= 5.0) & (t < 6.0)
    assert np.isnan(gauge[dropout]).all() and dropout.sum() == 20
    assert (gauge[~dropout] == 0.5).all()
    # the dropout is one shaded span, to its last sample plus a sample spacing
    (span,) = data.invalid["wave_elevation_gauge_measured_m"].finish()
    assert span[0] == pytest.approx(5.0) and span[1] == pytest.approx(6.0, abs=0.051)


def test_psd_segment_resolves_the_platform_modes_when_the_run_allows() -> None:
    fs = 40.0
    # 600 s load case with 60 s settled: 540 s kept -> 250 s segments, 0.004 Hz resolution,
    # below half the surge frequency (0.008 Hz): surge and pitch (0.037 Hz) are resolved.
    n = psd_segment(540 * 40, fs)
    assert n == 10_000 and fs / n == pytest.approx(0.004)
    # A 60 s run keeps 30 s: 15 s segments (three averaged), 0.067 Hz, stated on the plot.
    assert psd_segment(30 * 40, fs) == 600
    assert psd_segment(5, fs) == 5


def test_plots_render_without_warnings_for_constant_pitch(tmp_path: Path) -> None:
    """All-zero blade pitch (below rated) and a bottom-fixed plant: no log-axis warning."""
    path = tmp_path / "run.mcap"
    _write(path, floating=False, settle_s=0.0, pitch_zero=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        written = write_plots(read_run(path), tmp_path / "plots")
    assert [p.name for p in written] == list(PLOT_FILES)
    for p in written:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 20_000


# ----------------------------------------------------------------- lqri_ff notice


def test_lqri_ff_run_says_when_its_feedforward_starts(tmp_path: Path) -> None:
    """The fill time printed equals the controller's own (its forecaster's window), and a run
    shorter than it is warned about; the review shows the estimator and forecast table."""
    from controller.registry import make_controller
    from hil.nodes.controller_node import feedforward_notice
    from hil.scenario.schema import load_scenario

    sc = load_scenario("iea15mw-lc2-lqri-ff")
    core = make_controller(
        "lqri_ff", sc.controller.preset, control_period_s=sc.timing.control_period_s
    )
    fill = core.forecast_fill_time_s  # type: ignore[attr-defined]
    assert fill == pytest.approx((1024 - 1) * 0.2)  # n_taps 1024 at 0.2 s (the preset)
    long_run = feedforward_notice(sc.with_duration(600.0))
    assert long_run == [
        ("info", f"lqri_ff: feedforward active from t = {fill:.1f} s " + "(wave forecast filled)")
    ]
    assert [lvl for lvl, _ in feedforward_notice(sc.with_duration(100.0))] == ["info", "warning"]
    assert feedforward_notice(load_scenario("default")) == []
    out = tmp_path / "ff"
    proc = _fowt(
        "run", "iea15mw-lc2-lqri-ff", "--mode", "inprocess", "--duration", "4",
        "--out", str(out), "--no-plots", timeout=180,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    text = " ".join(proc.stdout.split())
    assert f"lqri_ff: feedforward active from t = {fill:.1f} s" in text
    assert "warning: the run is 4 s, not longer than the forecast fill time" in text
    assert "Estimator and wave forecast" in text and "wind speed error, RMS" in text


# ----------------------------------------------------------------- outputs and verdict


def test_review_writes_only_into_out_names_each_file_and_ends_with_the_verdict(
    floating_log: Path, tmp_path: Path
) -> None:
    """With --out nothing is written beside the file; every file written is named; the last
    line is the verdict 'fowt run' gives (hil.review.outcome.run_outcome), exit 0 without
    --strict and that code with it; with --json stdout stays the summary alone."""
    from hil.review.outcome import outcome_line, run_outcome

    here = tmp_path / "log"
    here.mkdir()
    log = here / "run.mcap"
    log.write_bytes(floating_log.read_bytes())
    out = tmp_path / "out"
    proc = _fowt("review", str(log), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in here.iterdir()) == ["run.mcap"]
    assert {p.name for p in out.iterdir()} == {"summary.json", *PLOT_FILES}
    lines = proc.stdout.strip().splitlines()
    for name in ("summary.json", *PLOT_FILES):
        assert any(line.endswith(str(out / name)) for line in lines), name
    summary = json.loads((out / "summary.json").read_text())
    code, reasons = run_outcome(summary)
    assert lines[-1] == outcome_line(code, reasons)
    assert lines[-1].startswith(f"outcome: {code.word} (exit {int(code)})")
    strict = _fowt("review", str(log), "--out", str(out), "--no-plots", "--strict")
    assert strict.returncode == int(code), strict.stdout + strict.stderr
    as_json = _fowt("review", str(log), "--out", str(out), "--json")
    assert json.loads(as_json.stdout)["kpi"] == summary["kpi"]
    assert as_json.stderr.strip().splitlines()[-1] == outcome_line(code, reasons)


def test_one_kpi_naming_for_review_compare_and_report(floating_log: Path) -> None:
    """Every KPI of a review is declared once (hil.review.kpi_names), and the review's table,
    fowt compare's rows and fowt report's table show it under the same label and unit."""
    from hil.campaign.html_report import compare_name, run_html
    from hil.review.kpi_names import REVIEW_KPIS, kpi_name

    s = review(floating_log, plots=False, write_summary=False)
    declared = {k.key for k in REVIEW_KPIS}
    assert set(s["kpi"]) <= declared, set(s["kpi"]) - declared
    console = Console(file=io.StringIO(), record=True, width=200)
    render_summary(s, console)
    text = console.export_text()
    html, _summary = run_html(floating_log)
    for key in s["kpi"]:
        name = kpi_name(key)
        assert compare_name(f"kpi.{key}") == (name.heading, name.scale)
        assert name.heading in html
        if name.console:
            assert any(name.label in line and name.unit in line for line in text.splitlines())
    assert compare_name("kpi.rotor_speed_mean_rad_s") == ("rotor speed mean [rpm]", 30 / math.pi)
