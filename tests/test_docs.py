"""The documentation says what is true now: generated pages up to date, examples that run,
a short README, and no text naming a session, an issue number or a machine's own path."""

from __future__ import annotations

import re
import subprocess
import sys
import types
from pathlib import Path

import msgspec
import pytest

from bus_schemas.messages import SensorFrame
from controller.interface import ActuatorLimits, ControlOutput
from hil import scenario_reference

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
        "python -m hil.scenario_reference > docs/guide/scenario-keys.md"
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


def _python_blocks(page: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S)


def test_the_own_controller_example_runs() -> None:
    """The core shown on "Add your own controller" is a working controller."""
    source = _python_blocks(ROOT / "docs" / "guide" / "own-controller.md")[0]
    module = types.ModuleType("own_controller_example")
    sys.modules[module.__name__] = module  # dataclasses look their module up there
    try:
        exec(compile(source, "own-controller.md", "exec"), module.__dict__)
    finally:
        del sys.modules[module.__name__]
    cls = module.MyController
    core = cls(k_nm_s2=2.33, kp_s=0.0188, ki=0.0081, rated_speed_rad_s=122.9)  # type: ignore[operator]
    zero = SensorFrame(*([0] * len(SensorFrame.__struct_fields__)))
    frame = msgspec.structs.replace(zero, generator_speed_measured_rad_s=130.0)
    state = core.initial_state()
    state, out = core.step(state, frame, 0.025)
    assert isinstance(out, ControlOutput)
    assert isinstance(core.actuator_limits(), ActuatorLimits)
    # K ω² torque and a PI on the speed error e = 130 - 122.9 = 7.1 rad/s, to 1e-12.
    assert out.generator_torque_commanded_nm == pytest.approx(2.33 * 130.0**2, rel=1e-12)
    integral = 0.0081 * 7.1 * 0.025
    assert state.integral_rad == pytest.approx(integral, rel=1e-9)
    assert out.blade_pitch_commanded_rad == pytest.approx(0.0188 * 7.1 + integral, rel=1e-9)
