"""Memory and start-up of long in-process runs: 1 h, 6 h and 24 h of load case 2 (lqri_ff).

Each duration is one ``fowt run iea15mw-lc2-lqri-ff --mode inprocess --no-plots --duration D``
in a child process, as a user runs it. Measured per run:

- the command's phases as it reports them (``summary["run"]["wall_phases_s"]``: start-up up to
  the loop's first cycle, the loop, the log writer finishing the file, the review) [s];
- peak RSS [MB]: of the whole command, the largest of its processes (``getrusage`` of a
  wrapper's children: what ``/usr/bin/time -v`` reports), and from ``/proc`` sampled every
  0.2 s, the main process and its process tree (main + log writer) split into before the
  review (start-up, loop, log) and the review itself (the review is another concern: it reads
  the file back);
- the log: bytes of ``run.mcap`` per simulated second, and per topic (1 h run only) the
  messages, their raw bytes and the zstd bytes of each topic's payloads compressed alone
  (level 1, the writer's), to say what dominates.

With ``--soak`` also the 1 h run at the ``soak`` recording level (``[recording] level =
"soak"``, truth kept once a second): its log bytes per simulated second. Prints and saves
``bench/results/soak_memory.json`` with the commit and the load before and after.

    python bench/soak_memory.py [--durations 3600 21600 86400] [--soak]
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import ROOT, load, save

SCENARIO = "iea15mw-lc2-lqri-ff"
#: Runs the command given and prints the largest RSS among its children [kB] (Linux
#: ru_maxrss of RUSAGE_CHILDREN: the peak of the largest descendant waited for).
WRAPPER = (
    "import resource, subprocess, sys\n"
    "rc = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL).returncode\n"
    "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, rc)\n"
)
PAGE_KB = os.sysconf("SC_PAGE_SIZE") / 1024


def _rss_kb(pid: int) -> int:
    try:
        with open(f"/proc/{pid}/statm") as fh:
            return int(int(fh.read().split()[1]) * PAGE_KB)
    except (OSError, ValueError, IndexError):
        return 0


def _children(pid: int) -> list[int]:
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as fh:
            return [int(p) for p in fh.read().split()]
    except OSError:
        return []


class Sampler(threading.Thread):
    """Samples the RSS of the wrapper's child (the command) and its process tree [kB]."""

    def __init__(self, wrapper_pid: int) -> None:
        super().__init__(daemon=True)
        self.wrapper = wrapper_pid
        self.samples: list[tuple[float, int, int]] = []  # (t s, main kB, tree kB)
        self.done = threading.Event()

    def run(self) -> None:
        t0 = time.monotonic()
        while not self.done.wait(0.2):
            kids = _children(self.wrapper)
            if not kids:
                continue
            main = kids[0]
            tree, todo = 0, [main]
            while todo:
                p = todo.pop()
                tree += _rss_kb(p)
                todo += _children(p)
            self.samples.append((time.monotonic() - t0, _rss_kb(main), tree))


def topic_bytes(path: Path) -> dict[str, dict[str, float]]:
    """Per topic suffix: messages, raw bytes (payload + the 31-byte Message record
    header) and the zstd bytes of its payloads compressed alone (level 1, as the writer)."""
    import zstandard
    from mcap.reader import make_reader

    count: collections.Counter[str] = collections.Counter()
    raw: collections.Counter[str] = collections.Counter()
    zbytes: collections.Counter[str] = collections.Counter()
    bufs: dict[str, list[bytes]] = collections.defaultdict(list)
    comp = zstandard.ZstdCompressor(level=1)

    def flush(topic: str) -> None:  # in ~1 MB parts, as chunks are compressed (bounded memory)
        zbytes[topic] += len(comp.compress(b"".join(bufs[topic])))
        bufs[topic].clear()

    held: collections.Counter[str] = collections.Counter()
    with path.open("rb") as fh:
        for _schema, channel, message in make_reader(fh).iter_messages():
            topic = channel.topic.split("/", 2)[-1]
            count[topic] += 1
            raw[topic] += len(message.data) + 31
            bufs[topic].append(message.data)
            held[topic] += len(message.data)
            if held[topic] >= 1 << 20:
                flush(topic)
                held[topic] = 0
    for topic in list(bufs):
        flush(topic)
    total_z = sum(zbytes.values())
    return {
        t: {
            "messages": count[t],
            "raw_bytes": raw[t],
            "zstd_bytes": zbytes[t],
            "zstd_share_pct": round(100.0 * zbytes[t] / total_z, 1) if total_z else 0.0,
        }
        for t in sorted(raw, key=lambda k: -zbytes[k])
    }


def one_run(duration_s: float, scenario: str, with_topics: bool) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="fowt-soak-") as tmp:
        out = Path(tmp) / "run"
        cmd = [
            sys.executable,
            "-c",
            WRAPPER,
            sys.executable,
            "-m",
            "hil",
            "run",
            scenario,
            "--mode",
            "inprocess",
            "--no-plots",
            "--duration",
            f"{duration_s:g}",
            "--out",
            str(out),
        ]
        t0 = time.monotonic()
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, text=True)
        sampler = Sampler(proc.pid)
        sampler.start()
        stdout, _ = proc.communicate()
        sampler.done.set()
        sampler.join()
        wall = time.monotonic() - t0
        maxrss_kb, rc = (int(v) for v in stdout.split())
        if rc != 0:
            raise SystemExit(f"fowt run --duration {duration_s:g} exited {rc}")
        summary = json.loads((out / "summary.json").read_text())
        phases = summary["run"]["wall_phases_s"]
        review_from = phases["start_up"] + phases["run"] + phases["log"]
        before = [s for s in sampler.samples if s[0] < review_from]
        during = [s for s in sampler.samples if s[0] >= review_from]
        mcap = out / "run.mcap"
        size = mcap.stat().st_size
        result: dict[str, Any] = {
            "duration_s": duration_s,
            "exit_code": summary["run"]["exit_code"],
            "start_up_s": phases["start_up"],
            "loop_s": phases["run"],
            "log_close_s": phases["log"],
            "review_s": phases["review"],
            "command_wall_s": round(wall, 2),
            "peak_rss_mb": round(maxrss_kb / 1024, 1),
            "rss_mb_before_review": {
                "main": round(max((s[1] for s in before), default=0) / 1024, 1),
                "tree": round(max((s[2] for s in before), default=0) / 1024, 1),
            },
            "rss_mb_review": {
                "main": round(max((s[1] for s in during), default=0) / 1024, 1),
                "tree": round(max((s[2] for s in during), default=0) / 1024, 1),
            },
            "rss_samples": len(sampler.samples),
            "log_bytes": size,
            "log_bytes_per_sim_s": round(size / duration_s, 1),
            "recording_level": summary["recording"].get("level", "full"),
        }
        if with_topics:
            result["topics"] = topic_bytes(mcap)
        return result


def soak_scenario() -> Path:
    """The scenario with ``[recording] level = "soak"`` (truth once a second), as a file."""
    from hil.scenario.schema import scenario_text

    text, _source = scenario_text(SCENARIO)
    fd, name = tempfile.mkstemp(prefix="fowt-bench-soak-", suffix=".toml")
    with open(fd, "w") as fh:
        fh.write(text + '\n[recording]\nlevel = "soak"\ntruth_period_s = 1.0\n')
    return Path(name)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--durations", type=float, nargs="+", default=[3600.0, 21600.0, 86400.0])
    ap.add_argument("--soak", action="store_true", help="also the 1 h run at the soak level")
    args = ap.parse_args()
    load_before = load()
    runs = []
    for i, d in enumerate(args.durations):
        r = one_run(d, SCENARIO, with_topics=i == 0)
        print(json.dumps({k: v for k, v in r.items() if k != "topics"}), flush=True)
        runs.append(r)
    soak = None
    if args.soak:
        path = soak_scenario()
        try:
            soak = one_run(args.durations[0], str(path), with_topics=True)
        finally:
            path.unlink()
    first, last = runs[0], runs[-1]
    result: dict[str, Any] = {
        "scenario": SCENARIO,
        "mode": "inprocess",
        "load_before": load_before,
        "load_after": load(),
        "runs": runs,
        f"ratio_{last['duration_s']:g}s_to_{first['duration_s']:g}s": {
            "start_up": round(last["start_up_s"] / first["start_up_s"], 3),
            "peak_rss": round(last["peak_rss_mb"] / first["peak_rss_mb"], 3),
            "rss_before_review_tree": round(
                last["rss_mb_before_review"]["tree"] / first["rss_mb_before_review"]["tree"], 3
            ),
        },
    }
    if soak is not None:
        result["soak_1_in_40"] = soak
    save("soak_memory", result)


if __name__ == "__main__":
    main()
