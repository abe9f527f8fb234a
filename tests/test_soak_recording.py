"""The ``soak`` recording level: truth decimated 1:N, every per-cycle control channel whole.

Unit checks of the writer's decimation (Structs and compiled-loop rows alike), of the
completeness account, of the scenario key; then a short in-process and a short lock-step
soak run (real processes over real Zenoh on loopback, ports picked free, a real MCAP
file): the review names the level, finds the recording complete, the run exits 0, and the
file holds 1 truth message in N and is smaller than a full recording by the truth's share.
"""

from __future__ import annotations

import io
from pathlib import Path

import msgspec
import numpy as np
import pytest
from _helpers import plant_report
from rich.console import Console

from bus_schemas.registry import SENSORS, TRUTH
from hil.launch import RunRequest, launch
from hil.review.core import render_summary
from hil.runlog.completeness import (
    completeness,
    expected_counts,
    kept_count,
    recording_level,
    recording_metadata,
    soak_unavailable,
    truth_kept,
)
from hil.runlog.mcap_io import read_run
from hil.runlog.writer import InProcessRunLog
from hil.scenario.schema import ScenarioError, load_scenario, parse_scenario

PRESETS = Path(__file__).resolve().parents[1] / "hil" / "scenario" / "presets"
PER_CYCLE_WHOLE = ("sensors", "command", "controller/status", "timing/cycle")


def _truth_rows(seqs: np.ndarray) -> np.ndarray:
    rows = np.zeros(seqs.size, TRUTH.row_dtype)
    rows["seq"] = seqs
    rows["sample_time_ns"] = seqs * 25_000_000
    return rows


def _sensor_rows(seqs: np.ndarray) -> np.ndarray:
    rows = np.zeros(seqs.size, SENSORS.row_dtype)
    rows["seq"] = seqs
    rows["sample_time_ns"] = seqs * 25_000_000
    return rows


def test_truth_kept_is_by_cycle_number() -> None:
    seq = np.arange(0, 12)
    assert truth_kept(seq, 4).tolist() == [k % 4 == 0 for k in range(12)]  # type: ignore[union-attr]
    assert truth_kept(8, 4) is True and truth_kept(9, 4) is False
    assert truth_kept(seq, 1).all()  # type: ignore[union-attr]
    assert [kept_count(p, 4) for p in (0, 1, 4, 5, 8, 9)] == [0, 1, 1, 2, 2, 3]


def test_writer_decimates_truth_given_as_rows_and_structs(tmp_path: Path) -> None:
    """A compiled block (rows, split across batches) and single Structs: the file keeps the
    truth of the cycles that are multiples of N, every sensor frame, and published()
    counts what was published (the plant's report)."""
    n_every = 4
    path = tmp_path / "run.mcap"
    meta = {"recording": recording_metadata("soak", n_every, 0.1)}
    log = InProcessRunLog(path, "t1", meta, batch_messages=7, truth_every=n_every)
    seqs = np.arange(0, 30)
    order = np.empty(2 * seqs.size, np.uint8)
    order[0::2] = SENSORS.message_id
    order[1::2] = TRUTH.message_id
    log.publish_block(
        order, {SENSORS.message_id: _sensor_rows(seqs), TRUTH.message_id: _truth_rows(seqs)}
    )
    # then cycles 30..39 one by one, as the Python loop publishes them
    for row in _truth_rows(np.arange(30, 40)):
        log.publish(TRUTH, TRUTH.cls(*row.tolist()))
    published = log.published()
    log.close()
    assert published["truth"] == 40
    assert published["sensors"] == 30
    assert log.decimated == 40 - 10
    run = read_run(path)
    truth = [m["seq"] for m in run.topic("truth")]
    assert truth == list(range(0, 40, n_every))
    assert [m["seq"] for m in run.topic("sensors")] == list(range(30))
    assert recording_level(run.metadata) == ("soak", n_every)


def test_recording_level_of_a_file_without_the_record() -> None:
    assert recording_level({}) == ("full", 1)
    assert recording_level({"recording": {"level": "soak", "truth_every": "x"}}) == ("full", 1)
    assert recording_level({"recording": recording_metadata("full", 40, 1.0)}) == ("full", 1)


def test_completeness_expects_the_kept_share_of_truth() -> None:
    report = msgspec.structs.asdict(plant_report(9, 9 * 25_000_000))  # 9 cycles published
    expected = expected_counts(report, [], truth_every=4)
    assert expected["truth"] == 3  # cycles 0, 4, 8
    assert expected["sensors"] == 9
    recorded = {"sensors": 9, "truth": 3, "timing/cycle": 9, "timing/summary": 1}
    recorded["timing/report"] = 1
    # the decimated truth skips cycles on purpose: not a gap
    order = {"truth": {"repeated": 0, "reordered": 0, "skipped": 6}}
    got = completeness(recorded, report, [], True, order=order, truth_every=4)
    assert not [p for p in got["problems"] if p.startswith("truth")], got["problems"]
    assert got["topics"]["truth"] == {"recorded": 3, "expected": 3}
    # one kept truth message lost is still found
    short = completeness({**recorded, "truth": 2}, report, [], True, order=order, truth_every=4)
    assert any(p.startswith("truth: 2 of 3") for p in short["problems"]), short["problems"]
    # a full recording's skip is still a gap
    full = completeness(recorded, report, [], True, order=order)
    assert any(p.startswith("truth") for p in full["problems"])


def test_soak_marks_every_cycle_figures_unavailable() -> None:
    summary = {
        "kpi": {"mean_power_w": 1.0, "thrust_max_n": 2.0, "shaft_del_nm": 3.0},
        "forecast": {"vaf_pct": 50.0, "samples": 10},
        "recording": {},
    }
    gone = soak_unavailable(summary, 40)
    assert summary["kpi"] == {"mean_power_w": 1.0, "thrust_max_n": None, "shaft_del_nm": None}
    assert summary["forecast"] == {"vaf_pct": None, "samples": 10}
    assert summary["recording"]["unavailable"] == gone
    assert soak_unavailable({"kpi": {"thrust_max_n": 1.0}}, 1) == []


def test_scenario_recording_key() -> None:
    text = (PRESETS / "nrel5mw-ramp.toml").read_text()
    sc = parse_scenario(text + '\n[recording]\nlevel = "soak"\ntruth_period_s = 0.5\n')
    assert sc.recording.truth_every(sc.timing.control_period_s) == 50  # 100 Hz
    assert load_scenario("nrel5mw-ramp").recording.truth_every(0.01) == 1
    with pytest.raises((ScenarioError, ValueError), match="truth_period_s"):
        parse_scenario(text + '\n[recording]\nlevel = "soak"\ntruth_period_s = 0.015\n')
    with pytest.raises((ScenarioError, ValueError), match="level"):
        parse_scenario(text + '\n[recording]\nlevel = "most"\n')


def _soak_file(tmp_path: Path, name: str, period_s: float) -> Path:
    path = tmp_path / f"{name}-soak.toml"
    text = (PRESETS / f"{name}.toml").read_text()
    path.write_text(text + f'\n[recording]\nlevel = "soak"\ntruth_period_s = {period_s}\n')
    return path


def _check_soak_summary(summary: dict, n_every: int) -> None:
    rec = summary["recording"]
    assert rec["level"] == "soak" and rec["truth_every"] == n_every
    assert rec["complete"] is True, rec["problems"]
    assert summary["run"]["exit_code"] == 0, summary["run"]["outcome_reasons"]
    cycles = summary["timing"]["cycles"]
    for topic in PER_CYCLE_WHOLE:
        assert rec["topics"][topic]["recorded"] == cycles, topic
    assert rec["topics"]["truth"] == {
        "recorded": kept_count(cycles, n_every),
        "expected": kept_count(cycles, n_every),
    }
    assert summary["kpi"]["shaft_del_nm"] is None
    assert summary["kpi"]["mean_power_w"] is not None
    out = io.StringIO()
    render_summary(summary, Console(file=out, width=200))
    assert f"recording level: soak (truth decimated 1:{n_every})" in out.getvalue()


@pytest.mark.e2e
def test_inprocess_soak_run_is_complete_and_smaller(tmp_path: Path) -> None:
    """60 s of load case 2 in process, full and soak (1 s truth: 1:40): the soak file
    is complete at its level, exits 0, and is smaller by the truth's share (the truth's
    bytes in the full file, less the 1/40 kept)."""
    full = launch(
        RunRequest(
            "iea15mw-lc2-lqri-ff",
            mode="inprocess",
            duration_s=60.0,
            out_dir=tmp_path / "full",
            plots=False,
        )
    )
    soak = launch(
        RunRequest(
            str(_soak_file(tmp_path, "iea15mw-lc2-lqri-ff", 1.0)),
            mode="inprocess",
            duration_s=60.0,
            out_dir=tmp_path / "soak",
            plots=False,
        )
    )
    _check_soak_summary(soak, 40)
    assert full["recording"]["level"] == "full" and full["recording"]["truth_every"] == 1
    # the control figures are those of the full recording (the same seeded run)
    assert soak["timing"]["cycles"] == full["timing"]["cycles"]
    assert soak["kpi"]["mean_power_w"] == pytest.approx(full["kpi"]["mean_power_w"], rel=0.05)
    size_full = (tmp_path / "full" / "run.mcap").stat().st_size
    size_soak = (tmp_path / "soak" / "run.mcap").stat().st_size
    # Measured (docs/guide/run-log.md): the truth is 57 % of a full file's compressed
    # payloads, and every message costs 16 bytes of uncompressed index; at 1:40 the soak
    # file is 55 % of the full one. Bounds a few points either side (seeded run: the bytes
    # vary only with the wall-clock fields' compression).
    assert 0.45 * size_full < size_soak < 0.62 * size_full, (size_soak, size_full)


@pytest.mark.e2e
def test_lockstep_soak_run_is_complete(tmp_path: Path) -> None:
    """10 s lock-step through the bus recorder, truth every 0.1 s (1:10 at 100 Hz)."""
    summary = launch(
        RunRequest(
            str(_soak_file(tmp_path, "nrel5mw-ramp", 0.1)),
            mode="lockstep",
            duration_s=10.0,
            out_dir=tmp_path / "run",
            plots=False,
        )
    )
    _check_soak_summary(summary, 10)
    run = read_run(tmp_path / "run" / "run.mcap")
    assert all(m["seq"] % 10 == 0 for m in run.topic("truth"))
    assert run.metadata["recorder"]["truth_decimated"] == str(1000 - 100)
