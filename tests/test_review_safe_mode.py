"""The review never overstates a run: the controller's safe mode and rejections are in it.

A run log in which the plant never entered its safe state but the controller sent safe
(feathering) commands for 2.2 s must say "safe state: yes" with the controller's safe mode,
its first entry and the time in it, taken from the command channel when the controller's
end-of-run report is missing and from the report when it is there; the plant's rejected
commands by reason come from its report. The time-series plot shades both windows and
marks the feedforward's start.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import pytest
from _helpers import cycle_timing, timing_summary
from rich.console import Console

from bus_schemas import ActuatorCommand, ControllerStatus
from bus_schemas.messages import (
    EST_FEEDFORWARD,
    EST_WAVE_FORECAST,
    EST_WIND_SPEED,
    ControllerReport,
    PlantReport,
)
from bus_schemas.registry import (
    COMMAND,
    CONTROLLER_REPORT,
    CONTROLLER_STATUS,
    CYCLE_TIMING,
    PLANT_REPORT,
    TIMING_SUMMARY,
)
from hil.nodes.controller_node import MODE_SAFE
from hil.review.core import (
    MODE_SAFE_COMMAND,
    render_summary,
    run_events,
    safe_state_text,
    summarize,
    write_plots,
)
from hil.runlog.mcap_io import RunLog, read_run

TID = "t1"
PERIOD_NS = 50_000_000  # 20 Hz
CYCLES = 200  # 10 s
SAFE = range(60, 104)  # controller safe mode: t = 3.0 s .. 5.2 s (44 commands, 2.2 s)
PLANT_SAFE = range(150, 160)  # plant safe state: t = 7.5 s .. 8.0 s
FF_FROM = 120  # wave forecast valid (the feedforward acts) from t = 6.0 s


def _zero(cls: Any) -> dict[str, int]:
    return {name: 0 for name in cls.__struct_fields__}


def _write(path: Path, reports: bool, plant_safe: bool = False) -> None:

    log = RunLog(path, TID, start_unix_ns=1_700_000_000_000_000_000)
    cfg = {"timing": {"control_period_s": PERIOD_NS / 1e9}}
    log.add_metadata("scenario", {"name": "synthetic", "toml": "", "json": json.dumps(cfg)})
    log.add_metadata("run", {"mode": "realtime", "speed": "1"})
    for k in range(CYCLES):
        t = k * PERIOD_NS
        safe = k in SAFE
        log.write(
            COMMAND.key(TID),
            ActuatorCommand(
                seq=k,
                answered_seq=k,
                sample_time_ns=t,
                publish_time_ns=t,
                mode=MODE_SAFE if safe else 0,
                blade_pitch_commanded_rad=0.3 + 0.002 * (k - SAFE[0]) if safe else 0.05,
                generator_torque_commanded_nm=2e6 if safe else 4e6,
            ),
        )
        log.write(
            CONTROLLER_STATUS.key(TID),
            ControllerStatus(
                seq=k,
                answered_seq=k,
                sample_time_ns=t,
                publish_time_ns=t,
                compute_time_ns=20_000,
                regime=0,
                rejected_frames=3 if k > 10 else 0,
                generator_speed_filtered_rad_s=1.0,
                pitch_integrator_rad=0.0,
                gain_schedule_factor=1.0,
                estimates_valid_mask=EST_WIND_SPEED
                | EST_FEEDFORWARD  # set from the first cycle: not yet acting
                | (EST_WAVE_FORECAST if k >= FF_FROM else 0),
            ),
        )
        log.write(
            CYCLE_TIMING.key(TID),
            cycle_timing(
                k,
                t,
                latency_ns=400_000,
                safe_state=int(plant_safe and k in PLANT_SAFE),
                plant_compute_ns=1,
            ),
        )
    summary = timing_summary(
        CYCLES, CYCLES * PERIOD_NS, commands_rejected=5,
        safe_state_cycles=len(PLANT_SAFE) if plant_safe else 0,
    )  # fmt: skip
    log.write(TIMING_SUMMARY.key(TID), summary)
    if reports:
        plant = {**_zero(PlantReport), "final": 1, "cycles": CYCLES, "commands_applied": 195}
        plant.update(commands_rejected_auth=3, commands_rejected_range=2)
        plant["sample_time_ns"] = CYCLES * PERIOD_NS
        log.write(PLANT_REPORT.key(TID), PlantReport(**plant))
        ctrl = {**_zero(ControllerReport), "final": 1, "commands_published": CYCLES}
        ctrl.update(
            safe_mode_entries=1,
            safe_mode_commands=len(SAFE),
            safe_mode_first_entry_ns=SAFE[0] * PERIOD_NS,
            frames_missing=4,
            frames_stale=1,
            frames_rejected_stale=2,
            frames_rejected_header=1,
            sample_time_ns=CYCLES * PERIOD_NS,
        )
        log.write(CONTROLLER_REPORT.key(TID), ControllerReport(**ctrl))
    log.close()


def test_safe_mode_constant_is_the_controllers() -> None:
    assert MODE_SAFE_COMMAND == MODE_SAFE


def test_controller_safe_mode_from_the_commands(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _write(path, reports=False)
    s = summarize(read_run(path))
    c = s["controller"]
    assert c["source"] == "commands"
    assert c["safe_mode_entered"] is True
    assert c["safe_mode_entries"] == 1
    assert c["safe_mode_first_entry_s"] == pytest.approx(3.0)
    assert c["safe_mode_commands"] == len(SAFE)
    assert c["safe_mode_s"] == pytest.approx(2.2)
    assert c["safe_mode_at_end"] is False
    assert c["frames_missing"] is None and c["frames_rejected"] is None
    assert c["frames_rejected_total"] == 3  # the last status's total
    assert s["timing"]["safe_state"] == 0  # the plant never entered its safe state ...
    assert safe_state_text(s).startswith("yes: controller safe mode 2.2")  # ... the run did
    p = s["plant"]
    assert p["source"] == "timing/summary"
    assert p["commands_rejected_total"] == 5 and p["commands_applied"] == CYCLES


def test_controller_and_plant_reports_are_preferred(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _write(path, reports=True)
    s = summarize(read_run(path))
    c = s["controller"]
    assert c["source"] == "controller/report"
    assert (c["frames_missing"], c["frames_stale"]) == (4, 1)
    assert c["frames_rejected"]["stale"] == 2 and c["frames_rejected"]["header"] == 1
    assert c["frames_rejected_total"] == 3
    assert c["safe_mode_s"] == pytest.approx(2.2)  # the time always from the commands
    p = s["plant"]
    assert p["source"] == "timing/report"
    assert p["commands_applied"] == 195
    assert p["commands_rejected"]["auth"] == 3 and p["commands_rejected"]["range"] == 2
    assert p["commands_rejected_total"] == 5
    out = io.StringIO()
    render_summary(s, Console(file=out, width=200))
    text = out.getvalue()
    assert "controller safe mode 2.2" in text
    assert "frames rejected: stale" in text and "commands rejected: auth" in text
    assert "frames rejected: length" not in text  # zero reasons are left out


def test_no_safe_state_anywhere_says_no(tmp_path: Path) -> None:
    summary = {"timing": {"safe_state": 0, "safe_state_cycles": 0}, "controller": {}}
    assert safe_state_text(summary) == "no"
    summary["timing"]["safe_state_cycles"] = 3
    assert safe_state_text(summary).startswith("yes: plant safe state (3 cycles)")


def test_timeseries_marks_both_windows_and_the_feedforward(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _write(path, reports=True, plant_safe=True)
    run = read_run(path)
    ev = run_events(run)
    assert ev["controller_safe_mode"] == [pytest.approx((3.0, 5.2))]
    assert ev["plant_safe_state"] == [pytest.approx((7.5, 8.0))]
    assert ev["feedforward_start_s"] == pytest.approx(6.0)
    assert ev["feedforward_starts_s"] == [pytest.approx(6.0)]

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    seen: dict[str, list[str]] = {}
    original = plt.Figure.savefig

    def spy(fig: Any, fname: Any, *args: Any, **kwargs: Any) -> None:
        if Path(fname).name == "timeseries.png":  # legends drawn as plain figure texts
            seen["labels"] = [t.get_text() for t in fig.texts] + [
                t.get_text() for a in fig.axes if a.get_legend() for t in a.get_legend().texts
            ]
            seen["hatched keys"] = [getattr(a, "get_hatch", str)() for a in fig.artists]
        original(fig, fname, *args, **kwargs)

    plt.Figure.savefig = spy  # type: ignore[method-assign]
    try:
        write_plots(run, tmp_path / "plots")
    finally:
        plt.Figure.savefig = original  # type: ignore[method-assign]
    labels = seen["labels"]  # one legend entry each (on the top panel with data)
    assert labels.count("plant safe state") == 1
    assert labels.count("controller safe mode") == 1
    assert labels.count("feedforward on (t = 6.0 s)") == 1
    hatched = [h for h in seen["hatched keys"] if h]
    assert hatched == ["//"]  # the safe mode's key is hatched as its windows
