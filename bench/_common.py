"""Shared helpers of the benchmark scripts: run a scenario through the launcher, save JSON,
compare this checkout's code with another's (A/B: :func:`codes`, :func:`alternate`,
:func:`run_child`)."""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parent / "results"


def commit(root: Path | None = None) -> str:
    """The commit of the checkout at ``root`` (None: this one): ``<hash>`` or
    ``<hash>+dirty``, or "unknown" outside git."""
    root = root if root is not None else Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short=10", "HEAD"],
            cwd=root,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")  # fmt: skip


def machine() -> dict[str, Any]:
    """Where and under what load the figures were measured (1/5/15-min load averages)."""
    cores = os.cpu_count()
    return {
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "cpus": cores,
        "load_average": [round(x, 2) for x in os.getloadavg()],
    }


def run_fowt(
    scenario: str,
    mode: str,
    duration_s: float,
    extra: list[str] | None = None,
    inspect: Any = None,
    python: str | None = None,
    cwd: Path | None = None,
) -> dict[str, Any]:
    """Run ``fowt run`` as a user would (separate processes), return its summary.json.

    ``inspect``: an optional ``callable(run_dir) -> dict`` called on the run's folder (logs,
    MCAP) before it is deleted; its answer goes under the summary's ``bench_inspect``.
    ``python`` and ``cwd``: another interpreter and checkout to run (a comparison with main).
    """
    with tempfile.TemporaryDirectory(prefix="fowt-bench-") as tmp:
        out = Path(tmp) / "run"
        cmd = [
            python or sys.executable,
            "-m",
            "hil",
            "run",
            scenario,
            "--mode",
            mode,
            "--duration",
            str(duration_s),
            "--out",
            str(out),
            "--no-plots",
            *(extra or []),
        ]
        t0 = time.monotonic()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False, cwd=cwd)
        wall = time.monotonic() - t0
        if proc.returncode != 0:
            raise SystemExit(f"fowt run failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
        summary: dict[str, Any] = json.loads((out / "summary.json").read_text())
        summary["bench_command_wall_s"] = wall
        if inspect is not None:
            summary["bench_inspect"] = inspect(out)
        return summary


#: Absolute paths of a particular machine (checkouts, interpreters, temporary folders).
_LOCAL_PATH = re.compile(r'(?<=")/(?:work|root|home|tmp|private|Users)/[^"]*(?=")')


def scrub_paths(text: str) -> str:
    """``text`` with every absolute local path in a JSON string replaced by ``<local path>``.

    Results are committed; which folder a checkout or interpreter sat in on the machine that
    measured them says nothing about the figures (the commit does, :func:`commit`).
    """
    return _LOCAL_PATH.sub("<local path>", text)


def save(name: str, result: dict[str, Any]) -> Path:
    """Print and save one benchmark's JSON."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    result = {
        "benchmark": name,
        "measured_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "commit": commit(),
        "machine": machine(),
        **result,
    }
    path = RESULTS / f"{name}.json"
    path.write_text(scrub_paths(json.dumps(result, indent=2)))
    print(json.dumps(result, indent=2))
    print(f"saved {path}")
    return path


def scenario_variant(
    scenario: str, control_period_s: float, plant_step_s: float | None = None
) -> Path:
    """A copy of a shipped scenario with another control period (and plant step).

    The copy goes to a temporary file that lives as long as the process; the TOML text is
    edited line by line so everything else (seeds, sea state, controller) stays as shipped.
    """
    from hil.scenario.schema import scenario_text

    text, _source = scenario_text(scenario)
    step = plant_step_s if plant_step_s is not None else control_period_s
    text, n1 = re.subn(
        r"(?m)^control_period_s\s*=\s*[0-9.eE+-]+", f"control_period_s = {control_period_s!r}", text
    )
    text, n2 = re.subn(r"(?m)^plant_step_s\s*=\s*[0-9.eE+-]+", f"plant_step_s = {step!r}", text)
    if n1 != 1 or n2 != 1:
        raise SystemExit(f"scenario {scenario!r} has no single [timing] control period/plant step")
    hz = round(1.0 / control_period_s)
    fd, name = tempfile.mkstemp(prefix=f"fowt-bench-{scenario}-{hz}hz-", suffix=".toml")
    with open(fd, "w") as fh:
        fh.write(text)
    return Path(name)


class Patches:
    """Attributes replaced on classes or objects (e.g. timing wrappers), put back by
    :meth:`restore` in reverse order (an attribute the owner did not hold itself, e.g. a
    class attribute seen through an instance, is deleted again)."""

    def __init__(self) -> None:
        self.undo: list[tuple[Any, str, Any]] = []

    def patch(self, owner: Any, name: str, value: Any) -> None:
        """Set ``owner.name = value``, remembering what :meth:`restore` puts back."""
        self.undo.append((owner, name, owner.__dict__.get(name)))
        setattr(owner, name, value)

    def restore(self) -> None:
        for owner, name, old in reversed(self.undo):
            if old is None:
                delattr(owner, name)
            else:
                setattr(owner, name, old)
        self.undo.clear()


def load() -> list[float]:
    """The machine's 1, 5 and 15 minute load averages (the bench machine is shared)."""
    import os

    return [round(v, 2) for v in os.getloadavg()]


# --- A/B comparisons: this checkout against another one, in one run on the same machine ---

ROOT = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Code:
    """One side of an A/B comparison: an interpreter and the checkout whose code it runs."""

    python: str
    root: Path

    def info(self) -> dict[str, str]:
        """What the result records of it: its commit (paths are scrubbed by :func:`save`)."""
        return {"python": self.python, "root": str(self.root), "commit": commit(self.root)}

    def write_bytecode(self) -> bool:
        """Write the checkout's bytecode with its own set-up's code (``make setup``'s
        warm-up, ``hil.warmup.compile_bytecode``); False for a checkout whose set-up writes
        none (left as its users have it).

        A fresh worktree has none, and where ``PYTHONDONTWRITEBYTECODE`` is set no command
        writes it: each command would compile the bench's sources again, 0.2-0.3 s that a
        set-up checkout never spends. Scripts that time whole commands call this first for
        every side.
        """
        proc = subprocess.run(
            [self.python, "-c", _WRITE_BYTECODE],
            cwd=self.root,
            env={**os.environ, "PYTHONPATH": str(self.root)},
            capture_output=True,
            text=True,
            check=False,
        )
        if proc.returncode == _NO_BYTECODE_STEP:
            return False
        if proc.returncode != 0:
            raise SystemExit(f"writing {self.root}'s bytecode failed:\n{proc.stderr[-3000:]}")
        return True


#: Exit code of :data:`_WRITE_BYTECODE` for a checkout without the warm-up's bytecode step.
_NO_BYTECODE_STEP = 3
#: Run on a checkout (its root on ``PYTHONPATH``): its own set-up's bytecode step.
_WRITE_BYTECODE = f"""
import sys
try:
    from hil.warmup import compile_bytecode
except ImportError as exc:
    sys.exit({_NO_BYTECODE_STEP} if exc.name == "hil.warmup" else 1)
sys.exit(0 if compile_bytecode() else 1)
"""

#: This checkout, run by this interpreter.
THIS = Code(sys.executable, ROOT)


def add_compare_args(ap: argparse.ArgumentParser) -> None:
    """The options of every script that compares this code with another checkout's."""
    ap.add_argument(
        "--compare-python", default=None, help="the other checkout's interpreter (its venv)"
    )
    ap.add_argument("--compare-root", type=Path, default=None, help="the other checkout's root")


def codes(args: argparse.Namespace) -> dict[str, Code]:
    """``{"this": THIS}``, plus ``"compare"`` when ``--compare-python``/``--compare-root`` are
    given (both or neither)."""
    if (args.compare_python is None) != (args.compare_root is None):
        raise SystemExit("--compare-python and --compare-root go together")
    out = {"this": THIS}
    if args.compare_python is not None:
        out["compare"] = Code(str(args.compare_python), args.compare_root.resolve())
    return out


def order(names: list[str], k: int) -> list[str]:
    """Round ``k``'s order of the sides: reversed every other round (ABBA...), so that
    neither side always runs first on a machine whose load drifts."""
    return names if k % 2 == 0 else names[::-1]


def alternate(names: list[str], rounds: int) -> list[tuple[int, str]]:
    """(round, side) pairs of ``rounds`` rounds, each in :func:`order`."""
    return [(k, name) for k in range(rounds) for name in order(names, k)]


def run_child(
    code: Code, argv: list[str], env: dict[str, str] | None = None, timeout: float | None = None
) -> dict[str, Any]:
    """Run ``code.python ARGV`` on ``code``'s checkout (``PYTHONPATH`` = its root, working
    folder its root) and return the JSON object its stdout's last line holds.

    The script named in ``argv`` is this checkout's (one harness); the code it imports is
    ``code``'s. A child that fails stops the benchmark with its output.
    """
    full_env = {**os.environ, **(env or {}), "PYTHONPATH": str(code.root)}
    proc = subprocess.run(
        [code.python, *argv],
        cwd=code.root,
        env=full_env,
        capture_output=True,
        text=True,
        check=False,
        timeout=timeout,
    )
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        raise SystemExit(f"child failed ({code.root}):\n{proc.stdout}\n{proc.stderr}")
    result: dict[str, Any] = json.loads(lines[-1])
    return result
