"""Plant families on the one launcher (:mod:`hil.families`): a Hexicon H3 scenario runs with
``fowt run hexicon-<name>`` through the same process start, supervision, review,
``summary.json`` and exit codes as a single turbine's; ``fowt review`` picks the family from
the file; options of the other family are refused before anything starts.

The end-to-end test runs the ``fowt`` command in a child process: recorder, controller and
plant as real OS processes over Zenoh on free loopback ports, lock-step.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest
from _helpers import fowt

from hil.families import (
    HEXICON,
    HEXICON_PREFIX,
    TURBINE,
    HexiconOptions,
    RunRequestError,
    check_request,
    list_scenarios,
    resolve,
)
from hil.hexicon.model import compute_kpis, load_scenarios, run_in_process
from hil.scenario.schema import shipped_scenarios

#: The KPIs the Hexicon review computes from the truth keys (hil.hexicon.review).
KPIS = (
    "heading_rms_deg",
    "overshoot_deg",
    "final_error_deg",
    "energy_ratio",
    "pitch_travel_deg",
    "constraint_violations",
)


# ----------------------------------------------------------------------------- addresses
def test_scenario_addresses_of_the_two_families_do_not_collide() -> None:
    """Every shipped scenario of either family resolves to its own family; no turbine
    scenario carries the Hexicon prefix, and every table-6 scenario is listed with it."""
    listed = list_scenarios()
    assert set(listed) == {"turbine", "hexicon"}
    assert set(listed["turbine"]) == set(shipped_scenarios())
    assert set(listed["hexicon"]) == {f"{HEXICON_PREFIX}{n}" for n in load_scenarios()}
    assert not set(listed["turbine"]) & set(listed["hexicon"])
    for name in listed["turbine"]:
        assert resolve(name) is TURBINE, name
    for name in listed["hexicon"]:
        assert resolve(name) is HEXICON, name
    assert resolve("some/file.toml") is TURBINE
    with pytest.raises(RunRequestError, match="unknown Hexicon scenario 'hexicon-s9'"):
        resolve("hexicon-s9")


def test_options_of_the_other_family_are_refused() -> None:
    """The launcher's check: a Hexicon option on a turbine scenario, a turbine option
    (--speed, --loop, --mode inprocess) on a Hexicon scenario, each refused by name."""
    check_request(TURBINE, {"speed": True, "loop": True}, "inprocess")
    check_request(HEXICON, {"hexicon": True}, "lockstep")
    with pytest.raises(RunRequestError, match=r"--controller.*only for a Hexicon scenario"):
        check_request(TURBINE, {"hexicon": True}, "lockstep")
    for option, text in (("speed", "--speed"), ("loop", "--loop")):
        with pytest.raises(RunRequestError, match=f"{text}: not an option of a hexicon"):
            check_request(HEXICON, {option: True}, "lockstep")
    with pytest.raises(RunRequestError, match="--mode inprocess: the hexicon family"):
        check_request(HEXICON, {}, "inprocess")
    with pytest.raises(RunRequestError, match="--controller prbs goes with"):
        HexiconOptions(controller="prbs")
    with pytest.raises(RunRequestError, match="--identified: only with --controller mpc_id"):
        HexiconOptions(controller="mpc", identified=Path("model.json"))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["run", "nrel5mw-ramp", "--controller", "mpc", "--mode", "lockstep"],
            "only for a Hexicon scenario",
        ),
        (["run", "default", "--no-noise"], "only for a Hexicon scenario"),
        (["run", "hexicon-s1_step15", "--speed", "2"], "--speed: not an option of a hexicon"),
        (
            ["run", "hexicon-s1_step15", "--mode", "lockstep", "--loop", "python"],
            "--loop: not an option of a hexicon",
        ),
        (["run", "hexicon-s1_step15", "--mode", "inprocess"], "--mode inprocess: the hexicon"),
        (["run", "hexicon-s1_step15", "--controller", "pid"], "--controller 'pid': expected"),
        (["run", "hexicon-nope"], "unknown Hexicon scenario 'hexicon-nope'"),
    ],
)
def test_fowt_run_refuses_options_of_the_other_family(
    args: list[str], message: str, tmp_path: Path
) -> None:
    """``fowt run`` with an option of the other family: exit 2 (usage), one ``error:`` line
    naming the option, and nothing started or written."""
    proc = fowt(*args, "--out", str(tmp_path / "run"), cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("error: ") and message in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "run").exists()


def test_fowt_scenarios_lists_both_families(tmp_path: Path) -> None:
    proc = fowt("scenarios", cwd=tmp_path, columns=200)
    assert proc.returncode == 0, proc.stderr
    names = {line.split()[0] for line in proc.stdout.splitlines() if line.strip()}
    assert {"default", "nrel5mw-ramp", "hexicon-s1_step15", "hexicon-sens_cd_plus10"} <= names


# ----------------------------------------------------------------------------- end to end
@pytest.mark.e2e
def test_fowt_run_of_a_hexicon_scenario_and_its_review(tmp_path: Path) -> None:
    """``fowt run hexicon-s1_step15 --controller mpc --mode lockstep --duration 30``: exit 0,
    ``run.mcap`` and ``summary.json`` (outcome ok, family hexicon, the recording complete,
    30 cycles, no deadline miss, the three node logs); ``fowt review`` of the file gives
    the same summary KPIs, and both equal the in-process run of the same cores and the same
    seeded sensor channels (the Hexicon review's figures, to 1e-9: the bus only carries the
    numbers)."""
    out = tmp_path / "run"
    proc = fowt(
        "run",
        "hexicon-s1_step15",
        "--controller",
        "mpc",
        "--mode",
        "lockstep",
        "--duration",
        "30",
        "--out",
        str(out),
        timeout=600.0,
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert proc.stdout.rstrip().endswith("outcome: ok (exit 0)")
    summary = json.loads((out / "summary.json").read_text())
    run = summary["run"]
    assert summary["kind"] == "hexicon" and run["family"] == "hexicon"
    assert (run["outcome"], run["exit_code"], run["aborted"]) == ("ok", 0, False)
    assert run["scenario"] == "s1_step15" and run["controller"] == "mpc"
    assert run["mode"] == "lockstep" and run["final_seen"] == "True"
    assert summary["recording"] == {"complete": True, "problems": []}
    assert summary["timing"]["cycles"] == 30 and summary["timing"]["deadline_misses"] == 0
    assert summary["timing"]["commands_rejected"] == 0
    assert {p.name for p in (out / "logs").iterdir()} == {
        "plant.log",
        "controller.log",
        "recorder.log",
    }
    reviewed = fowt("review", str(out / "run.mcap"), "--json", "--no-plots", cwd=tmp_path)
    assert reviewed.returncode == 0, reviewed.stderr
    again = json.loads(reviewed.stdout)
    assert again["kind"] == "hexicon" and again["run"]["outcome"] == "ok"
    scn = replace(load_scenarios()["s1_step15"], duration_s=30.0)
    ref = compute_kpis(run_in_process(scn, "mpc"), scn)
    for key in KPIS:
        assert again["kpi"][key] == summary["kpi"][key], key
        assert summary["kpi"][key] == pytest.approx(ref[key], abs=1e-9), key
    strict = fowt("review", str(out / "run.mcap"), "--strict", "--no-plots", cwd=tmp_path)
    assert strict.returncode == 0, strict.stderr


@pytest.mark.e2e
def test_fowt_hexicon_run_is_an_alias(tmp_path: Path) -> None:
    """``fowt hexicon run s1_step15 --controller bang_bang --duration 10`` goes through the
    same launcher: the same files, family and outcome as ``fowt run hexicon-s1_step15``."""
    out = tmp_path / "alias"
    proc = fowt(
        "hexicon",
        "run",
        "s1_step15",
        "--controller",
        "bang_bang",
        "--duration",
        "10",
        "--out",
        str(out),
        "--no-plots",
        timeout=600.0,
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["run"]["family"] == "hexicon" and summary["run"]["mode"] == "lockstep"
    assert summary["run"]["controller"] == "bang_bang" and summary["timing"]["cycles"] == 10
    assert (out / "run.mcap").is_file() and (out / "logs" / "plant.log").is_file()
