"""Design artefacts per control period: names, lookup, and the launcher's design on first use.

The LQRI gains and the wave-FF filters are discrete, so their artefacts carry the control
period in their names (``iea15mw_volturnus_lqri_dt0p025``) and are shipped for 0.025 s and
0.01 s. A scenario at another period (0.02 s here) makes the launcher run ``fowt design`` into
the user design cache (``$FOWT_DESIGN_DIR``, a temporary folder here) before the controller
starts; the controller alone, with the artefact missing, fails naming the command to run; and
the controller's own path still loads no ``plant`` module.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from controller.lqri import (
    DESIGN_DIR_ENV,
    DesignNotFoundError,
    artefact_stem,
    load_lqri_design,
    load_wave_ff_design,
    period_tag,
)
from hil.scenario.schema import scenario_text

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = "iea15mw-lc2-lqri-ff"  # lqri_ff: needs the LQRI, wave-FF and observer artefacts


def _variant(tmp_path: Path, control_period_s: float, plant_step_s: float) -> Path:
    """The shipped lqri_ff scenario with another control period and plant step."""
    text, _ = scenario_text(SCENARIO)
    text, n1 = re.subn(
        r"(?m)^control_period_s\s*=\s*\S+", f"control_period_s = {control_period_s!r}", text
    )
    text, n2 = re.subn(r"(?m)^plant_step_s\s*=\s*\S+", f"plant_step_s = {plant_step_s!r}", text)
    assert n1 == 1 and n2 == 1
    path = tmp_path / f"lc2-ff-{period_tag(control_period_s)}.toml"
    path.write_text(text)
    return path


def test_artefact_names_carry_the_control_period() -> None:
    assert period_tag(0.025) == "dt0p025"
    assert period_tag(0.01) == "dt0p01"
    assert period_tag(1.0 / 50.0) == "dt0p02"
    assert artefact_stem("iea15mw_volturnus", "lqri", 0.025) == "iea15mw_volturnus_lqri_dt0p025"
    assert artefact_stem("iea15mw_volturnus", "waveff", 0.01) == "iea15mw_volturnus_waveff_dt0p01"
    assert artefact_stem("iea15mw_volturnus", "observer", 0.01) == "iea15mw_volturnus_observer"


@pytest.mark.parametrize("dt", [0.025, 0.01])
def test_shipped_designs_for_40_and_100_hz(dt: float) -> None:
    """Both shipped periods load, and their metadata records preset, period, date, commit."""
    lqri = load_lqri_design("iea15mw_volturnus", dt)
    ff = load_wave_ff_design("iea15mw_volturnus", dt)
    assert lqri.control_period_s == dt and ff.control_period_s == dt
    for meta in (lqri.metadata, ff.metadata):
        assert meta["preset"] == "iea15mw_volturnus"
        assert meta["control_period_s"] == dt
        assert meta["created_utc"] and meta["commit"]
        assert isinstance(meta["settings"], dict)


def test_an_artefact_of_another_period_is_refused(tmp_path: Path) -> None:
    """An explicit path to the 0.025 s gains used at 0.01 s is an error naming both periods."""
    from controller.design import DEFAULT_DESIGN_DIR

    npz = DEFAULT_DESIGN_DIR / "iea15mw_volturnus_lqri_dt0p025.npz"
    with pytest.raises(ValueError, match=r"0\.025 s.*0\.01 s"):
        load_lqri_design(npz, 0.01)


def test_missing_design_names_the_command(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from controller.registry import make_controller

    monkeypatch.setenv(DESIGN_DIR_ENV, str(tmp_path / "empty"))
    with pytest.raises(DesignNotFoundError) as info:
        make_controller("lqri", "iea15mw_advanced", control_period_s=0.02)
    msg = str(info.value)
    assert "fowt design iea15mw_volturnus --control-period 0.02" in msg
    assert "iea15mw_volturnus_lqri_dt0p02.npz" in msg


def test_controller_alone_fails_with_the_design_command(tmp_path: Path) -> None:
    """``fowt controller`` at an unshipped period, empty cache: exits non-zero at once (no bus
    session is opened) with the ``fowt design ... --control-period ...`` command."""
    scenario = _variant(tmp_path, 0.02, 0.01)
    env = {**os.environ, DESIGN_DIR_ENV: str(tmp_path / "empty")}
    proc = subprocess.run(
        [sys.executable, "-m", "hil", "controller", str(scenario), "--duration", "1", "--insecure"],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        timeout=60,
        check=False,
    )
    assert proc.returncode != 0
    assert "fowt design iea15mw_volturnus --control-period 0.02" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr


def test_run_at_an_unshipped_period_designs_on_first_use(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An in-process run of the lqri_ff scenario at 0.02 s (50 Hz): the launcher designs the
    LQRI, wave-FF and observer artefacts into ``$FOWT_DESIGN_DIR``, the run uses them, a
    second look finds them; the controller's path (core built from the cache, cycles run)
    loads no ``plant`` module."""
    from rich.console import Console

    from hil.launch import RunRequest, ensure_designs, launch
    from hil.scenario.schema import load_scenario

    cache = tmp_path / "cache"
    monkeypatch.setenv(DESIGN_DIR_ENV, str(cache))
    scenario = _variant(tmp_path, 0.02, 0.01)
    console = Console(record=True, width=200)
    summary = launch(
        RunRequest(
            scenario=str(scenario),
            mode="inprocess",
            duration_s=5.0,
            out_dir=tmp_path / "run",
            plots=False,
        ),
        console,
    )
    text = console.export_text()
    assert "designing it into" in text and "designed iea15mw_volturnus at 0.02 s" in text
    for stem in ("lqri_dt0p02", "waveff_dt0p02", "observer"):
        meta = json.loads((cache / f"iea15mw_volturnus_{stem}.json").read_text())
        assert meta["preset"] == "iea15mw_volturnus"
        assert meta["control_period_s"] == (None if stem == "observer" else 0.02)
    assert not list(cache.glob(".design-*"))  # staging folder removed
    assert (tmp_path / "run" / "run.mcap").is_file()
    assert summary["timing"]["cycles"] == 250  # 5 s at 50 Hz
    assert ensure_designs(load_scenario(str(scenario)), console) is None  # found now

    code = (
        "import sys\n"
        "from controller.registry import make_controller\n"
        "from hil.nodes.controller_node import ControllerRuntime\n"
        "from hil.scenario.schema import load_scenario\n"
        "from tests.test_controller_runtime import _frames\n"
        f"rt = ControllerRuntime(load_scenario({str(scenario)!r}))\n"
        "assert rt.controller.lqri.design.control_period_s == 0.02\n"
        "assert rt.controller.lqri.wave_ff.control_period_s == 0.02\n"
        "for f in _frames(50):\n"
        "    assert rt.handle_frame(f) is not None\n"
        "print(sorted(m for m in sys.modules if m == 'plant' or m.startswith('plant.')))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env={**os.environ, DESIGN_DIR_ENV: str(cache)},
        cwd=ROOT,
        timeout=120,
        check=True,
    )
    assert out.stdout.strip() == "[]", out.stdout + out.stderr
