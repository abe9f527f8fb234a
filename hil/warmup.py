"""Compile the bench's numba kernels once, so that no run or test pays for it.

The plant (:mod:`plant._kernels`), the sensor channels (:mod:`sensors._kernels`) and the
advanced controller (:mod:`controller._kernels`) are compiled by numba on first use and the
machine code is cached next to the sources (``__pycache__``, ``cache=True``). On a fresh
clone the cache is empty, and the first process to use the kernels spends about 20-30 s per
package compiling them (``bench/plant_compile_time.py``, ``bench/controller_compile.py``): a
real-time plant or a lock-step peer would start late. ``make setup`` therefore runs this
module once; every later process loads the cached code (about 1-2 s).

It warms the kernels by running the real code paths, not by calling kernels with made-up
arguments, so every signature a run uses is compiled: a short in-process run of the floating
IEA 15 MW with ``lqri_ff`` (floating plant, sensor suite, observers, forecaster, LQRI and
wave feed-forward), of the bottom-fixed NREL 5 MW with the baseline, and of the Hexicon
platform's sensor suite (another channel count). The in-process runs take the compiled
loop where the scenario allows it (:mod:`hil.inprocess.kernels`, about 9 s to compile once its
callees are, ``bench/loop_compile_time.py``): the floating IEA 15 MW run compiles it (one
signature serves the baseline and the advanced controller). Nothing is written outside a
temporary folder.

It first writes the bytecode of the bench's own packages (``compileall``): an editable
install (``pip install -e``, what ``make setup`` does) leaves it to the first import, and a
machine that sets ``PYTHONDONTWRITEBYTECODE`` never writes it, so every command would compile
the bench's sources again (about 0.15-0.2 s of each ``fowt`` command's start-up, measured).

It says what it does as it goes (flushed, so ``make setup`` shows it through a pipe): one
line as each step starts, with what it compiles, a line every :data:`HEARTBEAT_S` while a
step runs (numba prints nothing while it compiles: the first run takes a few minutes on two
cores) and one with each step's time.

    python -m hil.warmup
"""

from __future__ import annotations

import compileall
import contextlib
import dataclasses
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

from rich.console import Console

from hil.hexicon.model import load_scenarios, run_in_process
from hil.launch import RunRequest, launch

# (scenario, simulated seconds): together they reach every kernel and kernel signature.
WARM_RUNS: tuple[tuple[str, float], ...] = (
    ("iea15mw-lc2-lqri-ff", 2.0),
    ("nrel5mw-ramp", 1.0),
)
#: What each step compiles, as the progress line says it.
WHAT: dict[str, str] = {
    "bytecode": "bytecode of the bench's packages",
    "iea15mw-lc2-lqri-ff": (
        "floating plant, sensor suite, observers, forecaster, LQRI and wave feed-forward, "
        "compiled loop (the longest step)"
    ),
    "nrel5mw-ramp": "bottom-fixed plant and baseline controller",
    "hexicon": "Hexicon platform's sensor suite",
}
#: Seconds between the "still compiling" lines of a long step.
HEARTBEAT_S = 15.0


#: The bench's own packages, whose bytecode is written first.
PACKAGES = ("bus_schemas", "plant", "sensors", "controller", "hil")


def compile_bytecode() -> bool:
    """Write the ``.pyc`` files of :data:`PACKAGES` (module docstring); True when all compiled."""
    root = Path(__file__).resolve().parent.parent
    return all(compileall.compile_dir(root / pkg, quiet=1) for pkg in PACKAGES)


@contextlib.contextmanager
def _step(console: Console, k: int, n: int, name: str, walls: dict[str, float]) -> Iterator[None]:
    """Say step ``k`` of ``n`` starts, every :data:`HEARTBEAT_S` that it still runs, and its
    time when done (into ``walls[name]``); each line flushed."""

    def say(text: str) -> None:
        console.print(text, markup=False, highlight=False, soft_wrap=True)
        console.file.flush()

    say(f"warm-up [{k}/{n}] {name}: {WHAT.get(name, name)} ...")
    done = threading.Event()
    t0 = time.monotonic()

    def beat() -> None:
        while not done.wait(HEARTBEAT_S):
            say(f"warm-up [{k}/{n}] {name}: still running, {time.monotonic() - t0:.0f} s")

    ticker = threading.Thread(target=beat, name="warm-up progress", daemon=True)
    ticker.start()
    try:
        yield
    finally:
        done.set()
        ticker.join()
        walls[name] = time.monotonic() - t0
    say(f"warm-up [{k}/{n}] {name}: done in {walls[name]:.1f} s")


def warm_up(console: Console | None = None) -> dict[str, float]:
    """Write the bytecode, then run the warm-up runs; return the wall time of each (s)."""
    console = console or Console()
    walls: dict[str, float] = {}
    n = 2 + len(WARM_RUNS)
    with _step(console, 1, n, "bytecode", walls):
        if not compile_bytecode():
            raise SystemExit("warm-up: a source file of the bench did not compile")
    with tempfile.TemporaryDirectory(prefix="fowt-warmup-") as tmp:
        for k, (name, duration) in enumerate(WARM_RUNS, start=2):
            with _step(console, k, n, name, walls):
                launch(
                    RunRequest(
                        name,
                        mode="inprocess",
                        duration_s=duration,
                        out_dir=Path(tmp) / name,
                        plots=False,
                    ),
                    Console(quiet=True),
                )
    with _step(console, n, n, "hexicon", walls):
        scn = next(iter(load_scenarios().values()))
        run_in_process(dataclasses.replace(scn, duration_s=10.0), "bang_bang")
    console.print(
        f"warm-up done in {sum(walls.values()):.0f} s: later runs load the compiled kernels",
        markup=False,
        soft_wrap=True,
    )
    console.file.flush()
    return walls


if __name__ == "__main__":
    warm_up()
