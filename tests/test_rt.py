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
