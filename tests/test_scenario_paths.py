"""A scenario's file paths are taken from the scenario file's folder; names get suggestions.

Every key that names a file (:data:`hil.scenario.schema.FILE_KEYS`) holding a relative path is
resolved against the folder of the scenario file, wherever ``fowt`` runs from, as a campaign
file's ``scenario`` is against the campaign file; shipped preset names stay names. The run's
processes load the same file (by its absolute path) and so find the same files: checked by a
lock-step run (plant, controller, recorder as processes) started from another folder. A
campaign carries its scenarios' paths absolute. A misspelt enum value, scenario or preset
name is answered with the closest names (1-3), never the whole list.
"""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest
from _helpers import fowt

from hil.campaign.runner import load_campaign
from hil.scenario.schema import (
    ScenarioError,
    allowed_values,
    load_scenario,
    parse_scenario,
    resolve_paths,
    scenario_text,
    suggestion,
)

REPO = Path(__file__).resolve().parents[1]


def _bench(root: Path) -> Path:
    """``root/scen/s.toml``: nrel5mw-ramp with its turbine and controller presets as files
    beside it (``turb/nrel5mw.toml``, ``ctl/mine.toml``), named by relative paths."""
    scen = root / "scen"
    (scen / "turb").mkdir(parents=True)
    (scen / "ctl").mkdir()
    turbine = (REPO / "plant" / "presets" / "nrel5mw.toml").read_text()
    assert 'table_file = "nrel5mw_cp_ct_cq.txt"' in turbine
    turbine = turbine.replace(
        'table_file = "nrel5mw_cp_ct_cq.txt"', 'table_file = "preset:nrel5mw_cp_ct_cq.txt"'
    )
    (scen / "turb" / "nrel5mw.toml").write_text(turbine)
    ctl = (REPO / "controller" / "presets" / "nrel5mw_baseline.toml").read_text()
    (scen / "ctl" / "mine.toml").write_text(ctl)
    text = scenario_text("nrel5mw-ramp")[0]
    text = text.replace('turbine = "nrel5mw"', 'turbine = "turb/nrel5mw.toml"')
    text = text.replace('preset = "nrel5mw_baseline"', 'preset = "ctl/mine.toml"')
    (scen / "s.toml").write_text(text)
    return scen / "s.toml"


def test_relative_paths_come_from_the_scenario_files_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _bench(tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    sc = load_scenario("../scen/s.toml")
    assert sc.turbine == str(tmp_path / "scen" / "turb" / "nrel5mw.toml")
    assert sc.controller.preset == str(tmp_path / "scen" / "ctl" / "mine.toml")
    assert load_scenario(str(path)) == sc
    # a shipped scenario keeps its shipped names
    assert load_scenario("nrel5mw-ramp").controller.preset == "nrel5mw_baseline"
    assert load_scenario("default").platform == "iea15mw_volturnus"


def test_resolve_paths_names_the_path_looked_for(tmp_path: Path) -> None:
    raw = {
        "turbine": "nrel5mw",
        "platform": "floats/p.toml",
        "controller": {"kind": "rosco", "preset": "nrel5mw", "library": "lib.so"},
    }
    (tmp_path / "floats").mkdir()
    (tmp_path / "floats" / "p.toml").write_text("")
    with pytest.raises(ScenarioError) as err:
        resolve_paths(raw, tmp_path, "s.toml")
    msg = str(err.value)
    assert msg.startswith("s.toml: controller.library = 'lib.so': file not found: ")
    assert str(tmp_path / "lib.so") in msg and "scenario file's folder" in msg
    (tmp_path / "lib.so").write_text("")
    out = resolve_paths(raw, tmp_path)
    assert out["platform"] == str(tmp_path / "floats" / "p.toml")
    assert out["controller"]["library"] == str(tmp_path / "lib.so")  # type: ignore[index]
    assert out["turbine"] == "nrel5mw" and out["controller"]["preset"] == "nrel5mw"  # type: ignore[index]
    assert raw["platform"] == "floats/p.toml"  # the input is not changed
    absolute = {"controller": {"parameter_file": str(tmp_path / "none.IN")}}
    with pytest.raises(ScenarioError, match="file not found") as err:
        resolve_paths(absolute, tmp_path)
    assert "relative path" not in str(err.value)


def test_text_without_a_file_keeps_its_paths(tmp_path: Path) -> None:
    """parse_scenario of text (no file, no folder): paths are the caller's, as before."""
    text = scenario_text("nrel5mw-ramp")[0].replace(
        'preset = "nrel5mw_baseline"', 'preset = "ctl/none.toml"'
    )
    with pytest.raises(ScenarioError, match="preset file not found"):
        parse_scenario(text, "t.toml")


def test_a_campaign_carries_absolute_paths(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A case's scenario path is taken from the campaign file's folder, the scenario's own
    paths from the scenario's folder, a controller preset path of the campaign from the
    campaign's folder: the runs (in this process or in Dask workers) carry them absolute."""
    _bench(tmp_path)
    camp = tmp_path / "camp"
    (camp / "ctl").mkdir(parents=True)
    ctl = (REPO / "controller" / "presets" / "nrel5mw_baseline.toml").read_text()
    (camp / "ctl" / "other.toml").write_text(ctl)
    (camp / "c.toml").write_text(
        textwrap.dedent(
            """
            name = "paths"
            duration_s = 10.0
            still_water = false
            [[cases]]
            name = "a"
            scenario = "../scen/s.toml"
            probability = 1.0
            [[controllers]]
            name = "baseline"
            kind = "baseline"
            preset = "ctl/other.toml"
            """
        )
    )
    monkeypatch.chdir(tmp_path / "scen" / "turb")
    (run,) = load_campaign(str(camp / "c.toml")).runs
    assert run.scenario["turbine"] == str(tmp_path / "scen" / "turb" / "nrel5mw.toml")
    assert run.scenario["controller"]["preset"] == str(camp / "ctl" / "other.toml")


@pytest.mark.e2e
def test_a_process_run_from_another_folder_finds_the_scenarios_files(tmp_path: Path) -> None:
    """``fowt run ../scen/s.toml --mode lockstep`` from another folder: plant, controller
    and recorder processes all load the scenario's relative presets (exit 0), and the
    recorded scenario names them by their absolute paths."""
    _bench(tmp_path)
    cwd = tmp_path / "elsewhere"
    cwd.mkdir()
    proc = fowt(
        "run", "../scen/s.toml", "--mode", "lockstep", "--duration", "0.5", "--out", "out",
        "--no-plots", cwd=cwd, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr
    summary = json.loads((cwd / "out" / "summary.json").read_text())
    config = summary["scenario"]["config"]
    assert config["turbine"] == str(tmp_path / "scen" / "turb" / "nrel5mw.toml")
    assert config["controller"]["preset"] == str(tmp_path / "scen" / "ctl" / "mine.toml")
    assert summary["timing"]["cycles"] == 50


def test_a_missing_relative_file_is_exit_2_with_the_path_it_was_looked_for_at(
    tmp_path: Path,
) -> None:
    path = _bench(tmp_path)
    (path.parent / "ctl" / "mine.toml").unlink()
    cwd = tmp_path / "elsewhere"
    cwd.mkdir()
    proc = fowt("run", "../scen/s.toml", "--mode", "inprocess", "--out", "out", cwd=cwd)
    assert proc.returncode == 2, proc.stderr
    line = proc.stderr.strip()
    assert "\n" not in line and line.startswith("error: ")
    assert f"controller.preset = 'ctl/mine.toml': file not found: {path.parent}/ctl/mine.toml" in (
        line
    )
    assert not (cwd / "out").exists()


@pytest.mark.parametrize(
    ("path", "values"),
    [
        ("wind.kind", {"steady", "step", "ramp", "turbulent", "gust"}),
        ("waves.kind", {"jonswap", "pierson_moskowitz", "issc", "still"}),
        ("wind.turbulence_class", {"A+", "A", "B", "C"}),
        ("faults[3].kind", {"stuck", "dropout", "bus_loss", "controller_kill"}),
        ("faults[0].distribution", {"uniform", "normal"}),
        ("can.interface", {"udp_multicast", "socketcan", "virtual"}),
        ("review.power_metric", {"electrical", "quadratic_linear"}),
        ("controller.forecaster", {"dispersion", "ar", "esprit"}),
        ("duration_s", set()),
        ("no.such.key", set()),
    ],
)
def test_allowed_values_of_a_key(path: str, values: set[str]) -> None:
    got = set(allowed_values(path))
    assert got >= values and (got == set() if not values else True)


@pytest.mark.parametrize(
    ("old", "new", "said"),
    [
        ('kind = "ramp"', 'kind = "rmap"', "key 'wind.kind': Invalid value 'rmap'; did you mean"),
        (
            "seed = 7\n",
            'seed = 7\n\n[can]\ninterface = "udp_multicst"\n',
            "did you mean 'udp_multicast'?",
        ),
        ('turbine = "nrel5mw"', 'turbine = "nrel5mv"', "did you mean 'nrel5mw'?"),
        ('preset = "nrel5mw_baseline"', 'preset = "nrel5mw_baselin"', "'nrel5mw_baseline'?"),
        ('kind = "ramp"', 'kind = "xyz"', "expected one of steady, step, ramp, turbulent, gust"),
    ],
)
def test_a_near_miss_is_answered_with_the_closest_values(old: str, new: str, said: str) -> None:
    text = scenario_text("nrel5mw-ramp")[0]
    assert old in text
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text.replace(old, new, 1), "s.toml")
    assert said in str(err.value), str(err.value)


def test_suggestion_gives_the_closest_one_to_three() -> None:
    names = ["iea15mw_advanced", "iea15mw_baseline", "nrel5mw_baseline"]
    assert suggestion("iea15mw_baselin", names) == "did you mean 'iea15mw_baseline'?"
    lc = [f"iea15mw-lc{i}" for i in range(1, 8)]
    assert suggestion("iea15mw-lc", lc).count("'") == 6  # three names
    assert suggestion("zzzz", names) == ""
