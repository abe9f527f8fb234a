"""The review's ``messages`` list the channels the run could have: an empty channel the
scenario could never publish on (``preview/wave_perfect`` without a perfect wave preview)
is left out, an empty one it could have (a lost stream) stays, as a count of 0."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from hil.launch import RunRequest, launch
from hil.review.core import could_have
from hil.scenario.schema import load_scenario


def test_could_have_follows_the_plants_preview_rule() -> None:
    """The plant publishes the perfect preview only for ``preview = "perfect"`` on a floating
    plant (:mod:`hil.nodes.plant_node`); other topics are always possible, and an unknown
    scenario keeps every topic."""
    casanovas = load_scenario("casanovas-tlp-hs6-u8").to_toml_dict()
    assert casanovas["controller"]["preview"] == "perfect"
    assert could_have("preview/wave_perfect", casanovas)
    default = load_scenario("default").to_toml_dict()
    assert not could_have("preview/wave_perfect", default)
    fixed = {**casanovas, "platform": None}
    assert not could_have("preview/wave_perfect", fixed)
    assert could_have("preview/wave_perfect", None)
    assert could_have("controller/report", default) and could_have("sensors", default)


def test_a_run_without_a_preview_does_not_list_its_channel(tmp_path: Path) -> None:
    summary = launch(
        RunRequest("nrel5mw-ramp", mode="inprocess", duration_s=1.0, out_dir=tmp_path, plots=False),
        Console(quiet=True),
    )
    messages = summary["run"]["messages"]
    assert "preview/wave_perfect" not in messages
    assert messages["sensors"] == 100 and messages["controller/report"] == 1
    assert summary["run"]["exit_code"] == 0
