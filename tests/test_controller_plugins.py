"""Controller plug-ins: a user's core found without a file of the bench edited.

In process: the kinds are found in the shipped table, then the entry points of
``fowt_hil.controllers`` (a ``*.dist-info`` folder written into ``tmp_path``, found by
``importlib.metadata`` like any installed distribution), then ``kind = "python"`` with
``core``; an unknown kind gets the closest names; each loading error and a bad setting is
one line naming the key; campaigns take any kind with every ``[controller]`` key and ask a
plug-in's design hook; a log whose kind is not installed still gives its KPIs.

CLI: each loading error and a bad setting is one ``error:`` line and exit 2.

End to end (``e2e``): ``examples/my-controller`` installed with pip into a scratch venv
(its ``.pth`` puts the checkout and the test interpreter's site-packages on its path: the
bench and its dependencies, offline), then that venv's ``fowt`` runs it in process,
lock-step and in real time, and in a 2-worker campaign; a ``kind = "python"`` core on
``PYTHONPATH`` runs lock-step. Each exits 0 with the user kind's KPIs in its summary and in
``fowt compare`` (run by this interpreter, where the plug-in is not installed).
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
from collections.abc import Iterator
from pathlib import Path

import msgspec
import pytest
from _helpers import fowt

from controller import registry
from controller.registry import find_kind, list_kinds
from hil.scenario.schema import ScenarioError, parse_scenario

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "examples" / "my-controller"

BASE = """\
name = "t"
turbine = "nrel5mw"
duration_s = 10.0

[wind]
kind = "steady"
speed_m_s = 18.0
"""

#: A plug-in module written into tmp_path: settings schema, design hook, a trimmed-start core
#: (the example's, imported from its source folder).
PLUGIN = """\
from pathlib import Path

import msgspec

from controller.registry import ControllerKind
from my_controller.core import MyPiController, MyPiSettings

DESIGNED = []


def _design(request, say):
    DESIGNED.append((request.kind, request.settings))
    say("designed")
    return None


KIND = ControllerKind(
    build=lambda o: MyPiController(o.settings, o.control_period_s),
    design=_design,
    settings=MyPiSettings,
    description="test plug-in",
)


def bare(options):
    \"\"\"A bare function: a kind without settings.\"\"\"
    return MyPiController(MyPiSettings(), options.control_period_s)


NOT_A_KIND = 42
BAD_SCHEMA = ControllerKind(build=bare, settings=dict)
"""


@pytest.fixture
def plugin_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """``tmp_path`` on ``sys.path`` with the module ``userplug`` (and the example's source),
    the registry's caches cleared before and after."""
    (tmp_path / "userplug.py").write_text(PLUGIN)
    (tmp_path / "userplug_raises.py").write_text("raise RuntimeError('no licence found')\n")
    monkeypatch.syspath_prepend(str(EXAMPLE / "src"))
    monkeypatch.syspath_prepend(str(tmp_path))
    _clear()
    yield tmp_path
    for name in ("userplug", "userplug_raises", "userplug_ep"):
        sys.modules.pop(name, None)
    _clear()


def _clear() -> None:
    registry._entry_points.cache_clear()
    registry._load_target.cache_clear()


def _dist(root: Path, name: str, entry_points: dict[str, str]) -> None:
    """An installed distribution as importlib.metadata finds it: ``NAME-1.0.dist-info``."""
    info = root / f"{name}-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 1.0\n")
    lines = "".join(f"{k} = {v}\n" for k, v in entry_points.items())
    (info / "entry_points.txt").write_text(f"[fowt_hil.controllers]\n{lines}")


def _scenario(controller: str) -> str:
    return BASE + "\n[controller]\n" + textwrap.dedent(controller)


def _error(text: str) -> str:
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(text, "s.toml")
    msg = str(exc.value)
    assert "\n" not in msg and "Traceback" not in msg
    return msg


# --------------------------------------------------------------------------- finding kinds


def test_unknown_kind_names_the_closest_few_never_all() -> None:
    msg = _error(_scenario('kind = "lqri_f"'))
    start = "s.toml: controller.kind = 'lqri_f': unknown controller kind; did you mean"
    assert msg.startswith(start)
    assert "'lqri_ff'" in msg and "'lqri'" in msg
    assert "casanovas" not in msg and "lqr_overlaid" not in msg  # not the whole list
    far = _error(_scenario('kind = "zzzzzz"'))
    assert "did you mean" not in far and "fowt controllers" in far
    assert "baseline" not in far


def test_shipped_kinds_keep_their_checks() -> None:
    msg = _error(_scenario('kind = "lqri"\npreset = "iea15mw_advanced"'))
    assert "needs a floating plant" in msg
    msg = _error(_scenario('kind = "baseline"\nlibrary = "x.so"'))
    assert "used only by kind = 'rosco'" in msg
    assert parse_scenario(_scenario('kind = "baseline"')).controller.kind == "baseline"


def test_python_core_with_settings_is_validated_on_read(plugin_path: Path) -> None:
    sc = parse_scenario(
        _scenario(
            """\
            kind = "python"
            core = "userplug:KIND"
            [controller.settings]
            pitch_kp_s = 0.02
            """
        ),
        "s.toml",
        base_dir=plugin_path,
    )
    assert sc.controller.settings == {"pitch_kp_s": 0.02}
    assert sc.controller.base_dir == str(plugin_path.resolve())
    core = registry.make_controller(
        "python",
        "unused",
        core="userplug:KIND",
        settings=sc.controller.settings,
        control_period_s=0.01,
    )
    assert core.s.pitch_kp_s == 0.02  # type: ignore[attr-defined]
    # a bare function is the kind's build, without settings
    found = find_kind("python", "userplug:bare")
    assert found.kind.settings is None and found.kind.description.startswith("A bare function")


@pytest.mark.parametrize(
    ("core", "words"),
    [
        ("no_such_pkg.mod:KIND", "no module named 'no_such_pkg'"),
        ("userplug:MISSING", "module 'userplug' has no attribute 'MISSING'"),
        ("userplug:NOT_A_KIND", "expected a controller.registry.ControllerKind"),
        ("userplug_raises:KIND", "importing 'userplug_raises' raised RuntimeError: no licence"),
        ("not a reference", "expected 'package.module:attribute'"),
        ("userplug:BAD_SCHEMA", "ControllerKind.settings must be a msgspec.Struct class"),
    ],
)
def test_loading_errors_are_one_line(plugin_path: Path, core: str, words: str) -> None:
    msg = _error(_scenario(f'kind = "python"\ncore = "{core}"'))
    assert msg.startswith(f"s.toml: controller.core = {core!r}: "), msg
    assert words in msg


@pytest.mark.parametrize(
    ("settings", "words"),
    [
        ("pitch_kp_s = 'fast'", "controller.settings.pitch_kp_s: Expected `float`, got `str`"),
        ("pitch_kp_s = -1.0", "controller.settings.pitch_kp_s: Expected `float` >= 0.0"),
        ("pitch_kp = 0.1", "unknown key 'pitch_kp'; did you mean 'pitch_kp_s'?"),
        ("pitch_min_rad = 1.0\npitch_max_rad = 0.5", "pitch_min_rad = 1.0 must be <"),
    ],
)
def test_bad_setting_is_one_line(plugin_path: Path, settings: str, words: str) -> None:
    text = _scenario(f'kind = "python"\ncore = "userplug:KIND"\n[controller.settings]\n{settings}')
    assert words in _error(text)


def test_python_kind_needs_core_and_core_needs_python(plugin_path: Path) -> None:
    assert "needs controller.core" in _error(_scenario('kind = "python"'))
    assert "used only by kind = 'python'" in _error(
        _scenario('kind = "baseline"\ncore = "userplug:KIND"')
    )
    assert "takes no settings" in _error(
        _scenario('kind = "baseline"\n[controller.settings]\ngain = 1.0')
    )


def test_entry_points_are_found_and_clashes_refused(plugin_path: Path) -> None:
    (plugin_path / "userplug_ep.py").write_text("from userplug import KIND\n")
    _dist(plugin_path, "good_plugin", {"my_ep_kind": "userplug_ep:KIND"})
    _dist(
        plugin_path,
        "bad_plugin",
        {"baseline": "userplug:KIND", "twice": "userplug:KIND", "python": "userplug:KIND"},
    )
    _dist(plugin_path, "other_plugin", {"twice": "userplug:KIND"})
    _clear()
    found = find_kind("my_ep_kind")
    assert found.source == "entry point good_plugin==1.0"
    assert found.kind.settings is not None
    sc = parse_scenario(_scenario('kind = "my_ep_kind"\n[controller.settings]\npitch_ki = 0.01'))
    assert sc.controller.kind == "my_ep_kind"
    assert "did you mean 'my_ep_kind'" in _error(_scenario('kind = "my_ep_knd"'))
    clash = _error(_scenario('kind = "baseline"'))
    assert "has the name of a shipped kind; it is refused" in clash
    assert "bad_plugin==1.0" in clash
    assert "more than one distribution" in _error(_scenario('kind = "twice"'))
    rows = {r.name: r for r in list_kinds()}
    assert rows["my_ep_kind"].design and rows["my_ep_kind"].settings.endswith("MyPiSettings")
    assert rows["baseline"].error and not rows["lqri"].error
    refused = [r for r in list_kinds() if r.name == "python" and r.source != "python"]
    assert "has the name of a shipped kind" in refused[0].error
    assert rows["python"].source == "python" and not rows["python"].error  # the kind itself
    assert find_kind("python", "userplug:KIND").source == "python"  # the kind itself works


def test_design_hook_gets_validated_settings(plugin_path: Path) -> None:
    import userplug  # type: ignore[import-not-found]

    req = registry.DesignRequest(
        kind="python",
        preset="x",
        control_period_s=0.01,
        core="userplug:KIND",
        settings={"pitch_ki": 0.01},
    )
    said: list[str] = []
    assert registry.ensure_design(req, said.append) is None
    assert said == ["designed"]
    assert userplug.DESIGNED[-1][1].pitch_ki == 0.01


# --------------------------------------------------------------------------- campaigns


def test_campaign_takes_every_kind_and_key_and_asks_design_hooks(plugin_path: Path) -> None:
    from rich.console import Console

    from hil.campaign.runner import _designs, parse_campaign

    text = textwrap.dedent(
        """\
        name = "c"
        duration_s = 10.0
        still_water = false
        [[cases]]
        name = "u18"
        scenario = "nrel5mw-steady-18"
        probability = 1.0
        [[controllers]]
        name = "baseline"
        kind = "baseline"
        preset = "nrel5mw_baseline"
        [[controllers]]
        name = "rosco"
        kind = "rosco"
        preset = "nrel5mw"
        parameter_file = "my_DISCON.IN"
        [[controllers]]
        name = "mine"
        kind = "python"
        core = "userplug:KIND"
        settings = { pitch_ki = 0.01, speed_filter_corner_hz = 0.3 }
        """
    )
    (plugin_path / "my_DISCON.IN").write_text("! a parameter file the campaign names\n")
    c = parse_campaign(text, "c.toml", plugin_path)
    by = {r.controller: r.scenario["controller"] for r in c.runs}
    # a variant's file paths are taken from the campaign file's folder, and carried absolute
    assert by["rosco"]["parameter_file"] == str(plugin_path.resolve() / "my_DISCON.IN")
    assert by["mine"]["core"] == "userplug:KIND"
    assert by["mine"]["settings"] == {"pitch_ki": 0.01, "speed_filter_corner_hz": 0.3}
    assert by["mine"]["base_dir"] == str(plugin_path.resolve())
    import userplug  # type: ignore[import-not-found]

    userplug.DESIGNED.clear()
    with open(os.devnull, "w") as devnull:
        _designs([r for r in c.runs if r.controller == "mine"], Console(file=devnull))
    assert [k for k, _ in userplug.DESIGNED] == ["python"]  # once, with its settings
    bad = text.replace("pitch_ki = 0.01", "pitch_ki = 'x'")
    with pytest.raises(ValueError, match=r"controllers\[2\]\.settings\.pitch_ki: Expected `float`"):
        parse_campaign(bad, "c.toml", plugin_path)
    typo = text.replace('kind = "baseline"', 'kind = "baselne"')
    with pytest.raises(ValueError, match="did you mean 'baseline'"):
        parse_campaign(typo, "c.toml", plugin_path)


def test_recorded_scenario_of_an_absent_kind_still_reads(plugin_path: Path) -> None:
    from hil.scenario.schema import Scenario, recorded_scenarios

    d = msgspec.to_builtins(parse_scenario(BASE))
    d["controller"] = {"kind": "not_installed_here", "settings": {"gain": 1.0}}
    with pytest.raises(msgspec.ValidationError):
        msgspec.convert(d, Scenario)
    with recorded_scenarios():
        assert msgspec.convert(d, Scenario).controller.kind == "not_installed_here"


# --------------------------------------------------------------------------- CLI, exit 2


@pytest.mark.parametrize(
    ("controller", "words"),
    [
        ('kind = "python"\ncore = "no_such_pkg:KIND"', "no module named 'no_such_pkg'"),
        ('kind = "python"\ncore = "userplug:MISSING"', "has no attribute 'MISSING'"),
        ('kind = "python"\ncore = "userplug:NOT_A_KIND"', "expected a controller.registry"),
        ('kind = "python"\ncore = "userplug_raises:KIND"', "raised RuntimeError"),
        (
            'kind = "python"\ncore = "userplug:KIND"\n[controller.settings]\npitch_ki = "x"',
            "controller.settings.pitch_ki",
        ),
        ('kind = "baselin"', "did you mean 'baseline'"),
    ],
)
def test_cli_refuses_with_one_line_and_exit_2(
    plugin_path: Path, controller: str, words: str
) -> None:
    work = plugin_path / "work"
    work.mkdir()
    (work / "s.toml").write_text(_scenario(controller))
    env_path = os.pathsep.join([str(plugin_path), str(EXAMPLE / "src")])
    old = os.environ.get("PYTHONPATH", "")
    os.environ["PYTHONPATH"] = os.pathsep.join([env_path, old])
    try:
        proc = fowt("run", "s.toml", "--mode", "inprocess", cwd=work, timeout=120)
    finally:
        os.environ["PYTHONPATH"] = old
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert words in lines[0]
    assert sorted(p.name for p in work.iterdir()) == ["s.toml"]  # nothing started or written


# --------------------------------------------------------------------------- end to end


@pytest.fixture(scope="module")
def scratch_venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A venv with ``examples/my-controller`` installed by pip (offline, no build isolation),
    the checkout and this interpreter's site-packages on its path by a ``.pth`` file."""
    root = tmp_path_factory.mktemp("scratch")
    venv = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    python = venv / "bin" / "python"
    site = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    ours = sysconfig.get_paths()["purelib"]
    Path(site, "_fowt_bench.pth").write_text(f"{REPO}\n{ours}\n")
    src = root / "my-controller"  # built from a copy: the build leaves files beside the source
    shutil.copytree(EXAMPLE, src)
    pip = [str(python), "-m", "pip", "install", "--no-deps", "--no-build-isolation"]
    proc = subprocess.run(
        [*pip, "--no-index", "-q", str(src)],
        capture_output=True,
        text=True,
        env=_env(),
        check=False,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return python


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return {**env, "COLUMNS": "200", **extra}


def _run(python: Path, *args: str, cwd: Path, **env: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(python), "-m", "hil", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=_env(**env),
        timeout=900,
        check=False,
    )


def _e2e_scenario(folder: Path, controller: str) -> Path:
    """The example's scenario at 50 Hz (a shorter settling run), watchdog and miss budget
    off: a loaded machine's late real-time commands are not this test's subject."""
    text = (EXAMPLE / "scenario.toml").read_text()
    text = text.replace('kind = "my_pi"', controller)
    text += (
        "\n[timing]\ncontrol_period_s = 0.02\nplant_step_s = 0.01\nwatchdog_misses = 0\n"
        "max_deadline_miss_fraction = 1.0\n"
    )
    path = folder / "scenario.toml"
    path.write_text(text)
    return path


def _kpis_present(summary: dict[str, object]) -> None:
    kpi = summary["kpi"]
    assert isinstance(kpi, dict) and kpi
    scenario = summary["scenario"]
    assert isinstance(scenario, dict)


@pytest.mark.e2e
def test_installed_plugin_runs_inprocess_lockstep_realtime(
    scratch_venv: Path, tmp_path: Path
) -> None:
    listing = _run(scratch_venv, "controllers", cwd=tmp_path)
    assert listing.returncode == 0, listing.stdout + listing.stderr
    assert "my_pi" in listing.stdout and "fowt-my-controller==0.1.0" in listing.stdout
    scenario = _e2e_scenario(tmp_path, 'kind = "my_pi"')
    runs = []
    for mode in ("inprocess", "lockstep", "realtime"):
        out = tmp_path / mode
        args = ["run", str(scenario), "--mode", mode, "--duration", "12", "--out", str(out)]
        proc = _run(scratch_venv, *args, "--no-plots", cwd=tmp_path)
        assert proc.returncode == 0, f"{mode}:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
        summary = json.loads((out / "summary.json").read_text())
        _kpis_present(summary)
        assert summary["scenario"]["config"]["controller"]["kind"] == "my_pi"
        runs.append(out / "run.mcap")
    # trimmed start: the first command is the plant's pitch (no jump at t = 0)
    from hil.runlog.mcap_io import read_run

    run = read_run(runs[1])
    pitch0 = run.topic("truth")[0]["blade_pitch_rad"]
    assert pitch0 > math.radians(5.0)  # 18 m/s: region 3, well out of fine pitch
    first = [c["blade_pitch_commanded_rad"] for c in run.topic("command")[:50]]
    assert max(abs(p - pitch0) for p in first) < math.radians(0.2)
    # compare here, where the plug-in is not installed: every KPI of the user kind is there
    proc = fowt("compare", *map(str, runs), "--out", str(tmp_path / "cmp"), cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    res = json.loads((tmp_path / "cmp" / "compare.json").read_text())
    campaign_kpis = {k: v for k, v in res["kpi"].items() if k.startswith("campaign.")}
    assert all(v is not None and v > 1e6 for v in campaign_kpis["campaign.mean_power_w"])
    for k, vals in campaign_kpis.items():  # bottom-fixed: no platform KPI for any run
        assert len({v is None for v in vals}) == 1, (k, vals)


@pytest.mark.e2e
def test_installed_plugin_in_a_two_worker_campaign(scratch_venv: Path, tmp_path: Path) -> None:
    camp = tmp_path / "campaign.toml"
    camp.write_text((EXAMPLE / "campaign.toml").read_text().replace("60.0", "10.0"))
    out = tmp_path / "out"
    proc = _run(
        scratch_venv,
        "campaign",
        str(camp),
        "--workers",
        "2",
        "--record",
        "none",
        "--no-html",
        "--out",
        str(out),
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    with (out / "results.csv").open() as fh:
        rows = {r["controller"]: r for r in csv.DictReader(fh)}
    assert rows["my_pi"]["status"] == "ok", rows["my_pi"]["error"]
    assert float(rows["my_pi"]["mean_power_w"]) > 1e6
    assert "my_pi relative" in proc.stdout


@pytest.mark.e2e
def test_python_core_on_pythonpath_runs_lockstep(tmp_path: Path) -> None:
    pkg = tmp_path / "lib"
    pkg.mkdir()
    (pkg / "user_core.py").write_text(
        "from my_controller import KIND as MY_KIND\n"
        "from controller.registry import ControllerKind\n"
        "KIND = ControllerKind(build=MY_KIND.build, settings=MY_KIND.settings)\n"
    )
    scenario = _e2e_scenario(tmp_path, 'kind = "python"\ncore = "user_core:KIND"')
    path = os.pathsep.join([str(REPO), str(pkg), str(EXAMPLE / "src")])
    out = tmp_path / "run"
    args = ["--duration", "10", "--out", str(out), "--no-plots"]
    proc = subprocess.run(
        [*[sys.executable, "-m", "hil", "run", str(scenario), "--mode", "lockstep"], *args],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=_env(PYTHONPATH=path),
        timeout=900,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    _kpis_present(summary)
    assert summary["scenario"]["config"]["controller"]["core"] == "user_core:KIND"
