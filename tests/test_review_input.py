"""What ``fowt review`` accepts: a run log of this bench, and says when one is incomplete.

An MCAP file written by another tool (a robot's ``/robot/pose`` JSON channel) is refused
with one line, ``not a fowt-hil run log: ...``, before anything is written (no summary, no
empty plots), exit 2 with or without ``--strict``. A run log of this bench without the
plant's final timing summary reviews, but ``--strict`` exits 1 and says why.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from _helpers import cycle_timing
from mcap.writer import Writer
from typer.testing import CliRunner

from bus_schemas.registry import CYCLE_TIMING
from hil.cli.fowt import app
from hil.review.core import NotRunLogError, check_run_log, review
from hil.runlog.mcap_io import RunLog, read_run


def _robot_log(path: Path) -> None:
    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start(profile="", library="robot-logger")
        sid = w.register_schema("Pose", "jsonschema", b'{"type": "object"}')
        cid = w.register_channel("/robot/pose", "json", sid)
        for k in range(50):
            w.add_message(
                cid, log_time=k * 10**7, publish_time=k * 10**7, data=json.dumps({"x": k}).encode()
            )
        w.finish()


def _bench_log_without_final_summary(path: Path) -> None:
    log = RunLog(path, "t1", start_unix_ns=0)
    log.add_metadata("run", {"mode": "realtime", "speed": "1"})
    for k in range(20):
        log.write(
            CYCLE_TIMING.key("t1"),
            cycle_timing(k, k * 10**7, publish_time_ns=0, latency_ns=400_000, plant_compute_ns=1),
            receive_unix_ns=0,
        )
    log.close()


def test_check_run_log_refuses_another_tools_mcap(tmp_path: Path) -> None:
    path = tmp_path / "robot.mcap"
    _robot_log(path)
    run = read_run(path)
    assert not run.truncated  # a perfectly good MCAP file ...
    with pytest.raises(NotRunLogError, match=r"^not a fowt-hil run log: .*/robot/pose"):
        check_run_log(run, path)  # ... but not a run log of this bench
    with pytest.raises(NotRunLogError):
        review(path, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_check_run_log_accepts_a_bench_log(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _bench_log_without_final_summary(path)
    check_run_log(read_run(path), path)


@pytest.mark.parametrize("strict", [False, True])
def test_review_cli_refuses_another_tools_mcap_in_one_line(tmp_path: Path, strict: bool) -> None:
    path = tmp_path / "robot.mcap"
    _robot_log(path)
    out = tmp_path / "out"
    args = ["review", str(path), "--out", str(out)] + (["--strict"] if strict else [])
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 2, res.output
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: not a fowt-hil run log: "), lines
    assert "turbine" not in res.output and "Traceback" not in res.output
    assert not out.exists() or not any(out.iterdir())  # no summary, no empty plots


def test_review_strict_fails_without_the_final_timing_summary(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _bench_log_without_final_summary(path)
    res = CliRunner().invoke(app, ["review", str(path), "--no-plots"])
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["timing"]["complete"] is False
    assert summary["run"]["truncated"] is False  # the file itself is whole
    res = CliRunner().invoke(app, ["review", str(path), "--no-plots", "--strict"])
    assert res.exit_code == 1, res.output
    assert "no final timing summary" in res.output
