"""The documentation says what is true now: generated pages up to date, examples that run,
a short README, and no text naming a session, an issue number or a machine's own path."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import msgspec
import pytest

from bus_schemas.messages import SensorFrame
from controller.interface import ActuatorLimits, ControlOutput
from hil.scenario import reference as scenario_reference

ROOT = Path(__file__).resolve().parent.parent


def _tracked_text_files() -> list[Path]:
    try:
        out = subprocess.run(
            ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: the tracked files are unknown")
    files = []
    for name in out.decode().split("\0"):
        path = ROOT / name
        if name and path.is_file() and path.suffix not in {".npz", ".png", ".mcap", ".so"}:
            files.append(path)
    return files


#: Text that belongs to the history (git), not to the product: an issue or session number,
#: or an absolute path of a particular machine.
_PATTERN = re.compile(
    r"(?i)\bissues? ?#?\d+(?![.\d])|\bsessions? ?\d+(?![.\d])"  # not "session 0.2 s later"
    r"|(?<![\w.])/(?:work|root|home)/[\w.-]+"
)
#: A citation of another project's tracker ("owner/repo issue #261") is a reference, not ours.
_CITATION = re.compile(r"[\w.-]+/[\w.-]+ $")


def _forbidden(line: str) -> str | None:
    """The first forbidden text in ``line``, or None."""
    for m in _PATTERN.finditer(line):
        if m.group(0).lower().startswith("issue") and _CITATION.search(line[: m.start()]):
            continue
        return m.group(0)
    return None


def test_no_session_issue_number_or_machine_path_in_the_repository() -> None:
    this = Path(__file__).resolve()
    found = []
    for path in _tracked_text_files():
        if path.resolve() == this:
            continue
        try:
            text = path.read_text()
        except UnicodeDecodeError:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            bad = _forbidden(line)
            if bad:
                found.append(f"{path.relative_to(ROOT)}:{n}: {bad!r}")
    assert not found, "\n".join(found[:50])


def test_the_pattern_catches_what_it_must() -> None:
    # The check above must be able to fail: each of these is caught, the citation is not.
    for bad in ("as issue 15 asks", "Session 13's figures", "/work/main/.venv", "issue #7"):
        assert _forbidden(bad), bad
    assert not _forbidden("(IEAWindSystems/IEA-15-240-RWT issue #261)")
    assert not _forbidden("a Zenoh session with peers")
    assert not _forbidden("closing its session 0.2 s after its last put")


def test_readme_is_short() -> None:
    assert len((ROOT / "README.md").read_text().splitlines()) <= 250


def test_scenario_key_reference_is_generated_from_the_schema() -> None:
    page = (ROOT / "docs" / "guide" / "scenario-keys.md").read_text()
    assert page == scenario_reference.markdown(), (
        "docs/guide/scenario-keys.md is out of date: "
        "python -m hil.scenario.reference > docs/guide/scenario-keys.md"
    )
    # Every section of the schema appears, with its keys.
    for key in ("control_period_s", "watchdog_misses", "settle_s", "hs_m", "mean_m_s"):
        assert f"| `{key}` |" in page


def test_benchmark_page_is_generated_from_the_results() -> None:
    proc = subprocess.run(
        [sys.executable, str(ROOT / "bench" / "report.py"), "--check"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    page = (ROOT / "docs" / "benchmarks.md").read_text()
    for result in (ROOT / "bench" / "results").glob("*.json"):
        assert f"## {result.stem}\n" in page


def _bench_recipe() -> str:
    """The commands of ``make bench`` (its target and the targets it depends on)."""
    make = (ROOT / "Makefile").read_text()
    deps = re.search(r"(?m)^bench:([^\n]*)", make)
    assert deps, "the Makefile has no bench target"
    recipe = []
    for target in ["bench", *deps.group(1).split()]:
        m = re.search(rf"(?ms)^{re.escape(target)}:[^\n]*\n((?:\t[^\n]*\n)*)", make)
        if m:
            recipe.append(m.group(1))
    return "".join(recipe)


def test_make_bench_runs_every_benchmark_the_docs_cite() -> None:
    """Each ``bench/<script>.py`` a page names, and the script of each
    ``bench/results/<name>.json`` a page names (its name, or the longest script name it
    starts with), is run by ``make bench``."""
    recipe = _bench_recipe()
    scripts = {p.stem for p in (ROOT / "bench").glob("*.py") if not p.stem.startswith("_")}
    cited: set[str] = set()
    for page in (ROOT / "docs").rglob("*.md"):
        if page.name == "benchmarks.md":  # generated: lists every result file
            continue
        text = page.read_text()
        cited.update(re.findall(r"bench/([a-z0-9_]+)\.py", text))
        for name in re.findall(r"results/([a-z0-9_]+)\.json", text):
            owners = sorted((s for s in scripts if name == s or name.startswith(s + "_")), key=len)
            assert owners, f"{page.name}: no bench script writes {name}.json"
            cited.add(owners[-1])
    cited.discard("report")
    assert cited, "no benchmark cited (the pattern is wrong)"
    missing = sorted(s for s in cited if f"bench/{s}.py" not in recipe)
    assert not missing, f"cited in docs/ but not run by make bench: {missing}"


def _python_blocks(page: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S)


def test_the_own_controller_page_quotes_the_example_package() -> None:
    """Every line of Python on "Add your own controller" is a line of
    ``examples/my-controller`` (lines with ``...`` abridge; trailing comments aside), so the
    page shows working code."""
    example = ROOT / "examples" / "my-controller"
    source = "\n".join(p.read_text() for p in example.rglob("*.py"))
    known = {line.split("  #")[0].strip() for line in source.splitlines()}
    blocks = _python_blocks(ROOT / "docs" / "guide" / "own-controller.md")
    assert len(blocks) >= 4
    missing = []
    for block in blocks:
        for line in block.splitlines():
            code = line.split("  #")[0].strip()
            if code and "..." not in code and not code.startswith("#") and code not in known:
                missing.append(line)
    assert not missing, f"not in examples/my-controller: {missing}"


def test_the_own_controller_example_starts_trimmed() -> None:
    """The example's core takes its first measurement as its state: its first command is
    the measured pitch (no jump at t = 0), and it regulates towards rated speed."""
    sys.path.insert(0, str(ROOT / "examples" / "my-controller" / "src"))
    try:
        from my_controller import KIND, MyPiSettings  # type: ignore[import-not-found]
    finally:
        sys.path.pop(0)
    from controller.registry import ControllerOptions

    core = KIND.build(ControllerOptions("my_pi", "", 0.025, settings=MyPiSettings()))
    zero = SensorFrame(*([0] * len(SensorFrame.__struct_fields__)))
    frame = msgspec.structs.replace(
        zero,
        generator_speed_measured_rad_s=124.0,
        blade_pitch_measured_rad=0.26,
        generator_torque_measured_nm=43_000.0,
    )
    state, out = core.step(core.initial_state(), frame, 0.025)
    assert isinstance(out, ControlOutput)
    assert isinstance(core.actuator_limits(), ActuatorLimits)
    # the measured pitch plus one step of the integrator (k_i e dt: 6.5e-5 rad here)
    assert out.blade_pitch_commanded_rad == pytest.approx(0.26, abs=1e-4)
    for _ in range(40):  # 1 s above rated speed: the pitch opens
        state, out = core.step(state, frame, 0.025)
    assert out.blade_pitch_commanded_rad > 0.26
