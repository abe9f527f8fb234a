"""``hil.nodes.rt``: SCHED_FIFO for the bench's processes, or a clear reason why not.

Each case runs in a child process so the test runner itself never changes policy.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from hil.nodes.rt import MAX_PRIORITY, RealtimeError, set_realtime_priority


def _child(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, timeout=60
    )


def test_zero_keeps_normal_scheduling() -> None:
    assert set_realtime_priority(0) == "normal"
    assert os.sched_getscheduler(0) == os.SCHED_OTHER


@pytest.mark.parametrize("bad", [-1, MAX_PRIORITY + 1, 99, 1.5, True])
def test_out_of_range_priorities_are_refused(bad: object) -> None:
    with pytest.raises(RealtimeError, match="realtime priority"):
        set_realtime_priority(bad)  # type: ignore[arg-type]


def test_fifo_is_set_or_refused_with_the_reason() -> None:
    out = _child(
        "import os\n"
        "from hil.nodes.rt import set_realtime_priority, RealtimeError\n"
        "try:\n"
        "    print(set_realtime_priority(10))\n"
        "    fifo = os.sched_getscheduler(0) == os.SCHED_FIFO\n"
        "    print(fifo, os.sched_getparam(0).sched_priority)\n"
        "except RealtimeError as exc:\n"
        "    print('refused:', exc)\n"
    )
    assert out.returncode == 0, out.stderr
    lines = out.stdout.strip().splitlines()
    if lines[0].startswith("refused:"):
        # Not root and no CAP_SYS_NICE: the error must say what to do.
        assert "root" in lines[0] or "CAP_SYS_NICE" in lines[0]
    else:
        assert lines[0] == "SCHED_FIFO priority 10"
        assert lines[1] == "True 10"


def _child_ok(code: str) -> None:
    """Run ``code`` in a child; it must exit 0 (its asserts held)."""
    proc = _child(code)
    assert proc.returncode == 0, proc.stderr


def test_startup_collects_rarely_and_the_loop_gets_the_default_collector_back() -> None:
    """``startup_gc`` raises the young-generation threshold to STARTUP_GC_THRESHOLD; both
    ``steady_gc`` and ``freeze_heap`` (a node's last set-up step) put back the thresholds it
    found, and ``freeze_heap`` leaves the set-up's objects frozen."""
    code = (
        "import gc\n"
        "from hil.nodes import rt\n"
        "default = gc.get_threshold()\n"
        "rt.steady_gc()\n"  # before startup_gc: nothing to put back
        "assert gc.get_threshold() == default, gc.get_threshold()\n"
        "rt.startup_gc()\n"
        "assert gc.get_threshold() == (rt.STARTUP_GC_THRESHOLD, *default[1:]), gc.get_threshold()\n"
        "rt.startup_gc()\n"  # twice: still the first thresholds to go back to
        "rt.steady_gc()\n"
        "assert gc.get_threshold() == default, gc.get_threshold()\n"
        "rt.startup_gc()\n"
        "assert rt.freeze_heap() > 1000\n"
        "assert gc.get_threshold() == default, gc.get_threshold()\n"
    )
    _child_ok(code)


def test_the_fowt_command_starts_with_the_start_up_threshold() -> None:
    """``fowt``'s entry point calls ``startup_gc`` before any command runs (the threshold
    read where the command would start, in the entry point's own process)."""
    code = (
        "import gc, sys\n"
        "from hil.cli import fowt\n"
        "from hil.nodes import rt\n"
        "seen = []\n"
        "def app(*a, **k):\n"
        "    seen.append(gc.get_threshold()[0])\n"
        "fowt.app = app\n"
        "try:\n"
        "    fowt.main(['scenarios'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "assert seen == [rt.STARTUP_GC_THRESHOLD], seen\n"
    )
    _child_ok(code)
