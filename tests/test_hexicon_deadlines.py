"""The Hexicon H3 plant's deadline accounting: a miss is what the latency histogram shows.

In real time a cycle's deadline is one control period after its frame's publication
(:func:`hil.hexicon.nodes.gather_commands`): a cycle misses it when its three commands are
not all in by then. The plant used to time the period from before its first cycle's model
evaluation, which took most of the first second, so a run whose latencies stayed under
50 ms against a 1 s deadline counted one miss (``deadline_misses 1``, exit 6).

The counting is checked on the function with synthetic arrival stamps (no clock, no bus),
and on one short real-time run through the launcher, whose miss count must equal the number
of cycles the recorded latencies put over the period.
"""

from __future__ import annotations

import json
import queue
from pathlib import Path

import pytest
from rich.console import Console

from bus_schemas.messages import TurbineCommand
from hil.families import HEXICON, HexiconOptions
from hil.hexicon.nodes import gather_commands, progress_key
from hil.launch import RunRequest, launch
from hil.runlog.mcap_io import read_run

PERIOD_NS = 1_000_000_000  # the Hexicon scenarios' 1 s control period
PUBLISHED_NS = 5_000_000_000  # when the cycle's frame went out (a monotonic clock reading)
DEADLINE_NS = PUBLISHED_NS + PERIOD_NS


def _cmd(seq: int, turbine: int) -> TurbineCommand:
    return TurbineCommand(
        seq=seq,
        answered_seq=seq,
        sample_time_ns=seq * PERIOD_NS,
        publish_time_ns=0,
        turbine_index=turbine,
        blade_pitch_commanded_rad=0.1,
        generator_torque_commanded_nm=1e6,
    )


def _inbox(*items: tuple[int, TurbineCommand]) -> queue.SimpleQueue[tuple[int, TurbineCommand]]:
    q: queue.SimpleQueue[tuple[int, TurbineCommand]] = queue.SimpleQueue()
    for item in items:
        q.put(item)
    return q


def test_commands_in_time_are_no_miss_even_when_the_plant_looks_late() -> None:
    """Three commands 46 ms after the frame: on time, though the plant only looks at its
    inbox after the deadline (its own work ran long): judged by their arrival stamps."""
    arrived = PUBLISHED_NS + 46_000_000
    inbox = _inbox(*((arrived, _cmd(0, t)) for t in (1, 2, 3)))
    got, late = gather_commands(inbox, 0, DEADLINE_NS, clock=lambda: DEADLINE_NS + 10**8)
    assert sorted(got) == [1, 2, 3] and late == 0


def test_a_late_command_is_a_miss() -> None:
    """Turbine 3's command arrives 1 ns after the deadline: the cycle misses (two of three
    commands), and the late one is counted as late, not applied."""
    on_time = PUBLISHED_NS + 20_000_000
    inbox = _inbox((on_time, _cmd(7, 1)), (on_time, _cmd(7, 2)), (DEADLINE_NS + 1, _cmd(7, 3)))
    got, late = gather_commands(inbox, 7, DEADLINE_NS, clock=lambda: DEADLINE_NS + 2)
    assert sorted(got) == [1, 2] and late == 1


def test_a_missing_command_is_a_miss_and_stale_ones_are_dropped() -> None:
    """Commands answering the previous frame (after its cycle closed) do not count for this
    one: dropped, counted as late."""
    t = PUBLISHED_NS + 1_000
    inbox = _inbox((t, _cmd(2, 1)), (t, _cmd(2, 2)), (t, _cmd(3, 1)), (t, _cmd(3, 2)))
    got, late = gather_commands(inbox, 3, DEADLINE_NS, clock=lambda: DEADLINE_NS)
    assert sorted(got) == [1, 2] and late == 2
    assert inbox.empty()


def test_a_command_on_the_deadline_is_on_time() -> None:
    inbox = _inbox(*((DEADLINE_NS, _cmd(1, t)) for t in (1, 2, 3)))
    got, late = gather_commands(inbox, 1, DEADLINE_NS, clock=lambda: DEADLINE_NS + 1)
    assert len(got) == 3 and late == 0


def test_the_progress_bar_reads_the_plants_running_miss_count() -> None:
    """The launcher follows a Hexicon run on the plant's progress key: simulated time and
    the deadline misses so far (not a constant 0)."""
    assert HEXICON.progress_key("h3") == progress_key("h3") == "fowt/h3/platform/progress"
    payload = json.dumps({"sim_s": 12.0, "deadline_misses": 2}).encode()
    assert HEXICON.progress(payload) == (12.0, 2.0)
    assert HEXICON.progress(b"not json") is None


@pytest.mark.e2e
def test_a_real_time_run_counts_the_misses_its_latencies_show(tmp_path: Path) -> None:
    """``fowt run hexicon-s1_turbulent --duration 5`` in real time: the plant's miss count
    equals the cycles whose recorded latency (frame publication to the last of the three
    commands) exceeds the 1 s period, or that lack a command; an idle or a loaded machine
    alike (no timed assertion: both sides come from the same run)."""
    req = RunRequest(
        scenario="hexicon-s1_turbulent",
        mode="realtime",
        duration_s=5.0,
        out_dir=tmp_path,
        plots=False,
        hexicon=HexiconOptions(controller="mpc"),
    )
    summary = launch(req, Console(quiet=True))
    timing = summary["timing"]
    assert timing["cycles"] == 5
    run = read_run(tmp_path / "run.mcap")
    frames = {f["seq"]: f["publish_time_ns"] for f in run.messages["fowt/h3/platform"]}
    last: dict[int, list[int]] = {}
    for t in ("t1", "t2", "t3"):
        for c in run.messages[f"fowt/h3/{t}/rotor/command"]:
            last.setdefault(c["answered_seq"], []).append(c["publish_time_ns"])
    over = sum(
        1
        for k in range(timing["cycles"])
        if len(last.get(k, ())) < 3 or max(last[k]) - frames[k] > PERIOD_NS
    )
    assert timing["deadline_misses"] == over, (timing, over)
    assert timing["commands_held"] == over
    assert summary["run"]["exit_code"] == (0 if over <= 1 else 6)
