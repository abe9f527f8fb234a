"""The plots' one-pass accumulators (hil.review.plots) against whole-record answers.

Spans and Welch's estimate must not depend on how the record is cut into batches (a file's
chunks), and a run longer than MAX_POINTS is drawn from buckets whose min/max cover every
sample. Seeded random records; tolerances stated per check.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.signal import welch
from test_review_long_run import write_log

from hil.review import core, plots
from hil.review import stream as rs
from hil.review.plots import (
    DRAW_COLUMNS,
    MAX_POINTS,
    SHIPPED_PLATFORM_PERIODS_S,
    Envelope,
    Spans,
    StreamingWelch,
    platform_periods_s,
    psd_segment,
    spectral_marks,
)
from hil.runlog.columns import ColumnReader


def _reference_spans(t: np.ndarray, f: np.ndarray, period: float) -> list[tuple[float, float]]:
    """Windows of consecutive flagged samples over the whole record, directly."""
    out, i = [], 0
    while i < f.size:
        if f[i]:
            j = i
            while j + 1 < f.size and f[j + 1]:
                j += 1
            out.append((float(t[i]), float(t[j]) + period))
            i = j + 1
        else:
            i += 1
    return out


@pytest.mark.parametrize("seed", range(5))
def test_spans_do_not_depend_on_the_batches(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 2000
    t = np.arange(n) * 0.025
    # runs of flags of random lengths (some of one sample, some across cuts)
    f = np.repeat(rng.random(200) < 0.4, rng.integers(1, 20, 200))[:n]
    f = np.pad(f, (0, n - f.size))
    expected = _reference_spans(t, f, 0.025)
    cuts = np.sort(rng.choice(np.arange(1, n), size=30, replace=False))
    spans = Spans(0.025)
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, n], strict=True):
        spans.add(t[a:b], f[a:b])
    assert spans.finish() == expected


def test_spans_of_all_and_none_flagged() -> None:
    t = np.arange(10.0)
    s = Spans(1.0)
    s.add(t[:5], np.ones(5, bool))
    s.add(t[5:], np.ones(5, bool))
    assert s.finish() == [(0.0, 10.0)]
    s = Spans(1.0)
    s.add(t, np.zeros(10, bool))
    assert s.finish() == []


@pytest.mark.parametrize("n_s", [30.0, 600.0, 1800.0])
def test_streaming_welch_equals_scipy_on_the_whole_record(n_s: float) -> None:
    """Fed in uneven pieces, the estimate is scipy's welch of the whole record (relative
    1e-9: the same periodograms averaged in another order)."""
    fs = 40.0
    rng = np.random.default_rng(7)
    n = int(n_s * fs)
    t = np.arange(n) / fs
    x = np.sin(2 * np.pi * 0.037 * t) + 0.3 * rng.standard_normal(n) + 2.0
    w = StreamingWelch(fs)
    at = 0
    for size in rng.integers(1, 5000, 1000):
        if at >= n:
            break
        w.add(x[at : at + size])
        at += int(size)
    f, p, nper, n_seg = w.finish()
    nper_ref = psd_segment(n, fs)
    f_ref, p_ref = welch(x, fs=fs, nperseg=nper_ref, detrend="constant", window="hann")
    assert nper == nper_ref
    assert n_seg == (n - nper_ref) // (nper_ref // 2) + 1
    np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(p, p_ref, rtol=1e-9, atol=1e-12 * p_ref.max())


def test_envelope_keeps_every_sample_of_a_short_run_and_bounds_a_long_one() -> None:
    rng = np.random.default_rng(3)
    short = Envelope(MAX_POINTS)
    x = rng.standard_normal(MAX_POINTS)
    for a in range(0, MAX_POINTS, 1000):
        short.add({"t": np.arange(a, min(a + 1000, MAX_POINTS)) * 1.0, "x": x[a : a + 1000]})
    assert short.bucket == 1
    np.testing.assert_array_equal(short.get("x"), x)
    n = 24 * 3600 * 40  # a day at 40 Hz
    long = Envelope(n)
    assert long.bucket == -(-n // DRAW_COLUMNS)
    y = rng.standard_normal(200_000)
    y[123_457] = 50.0  # a spike every-B-th sampling would miss
    for a in range(0, y.size, 4096):
        long.add({"t": np.arange(a, min(a + 4096, y.size)) * 1.0, "x": y[a : a + 4096]})
    drawn, t = long.get("x"), long.get("t")
    assert drawn.size == t.size == 2 * -(-y.size // long.bucket)
    assert drawn.max() == 50.0 and drawn.min() == y.min()
    assert np.all(np.diff(t) >= 0)


def test_min_max_decimation_of_a_600_s_run_keeps_every_single_sample_spike() -> None:
    """A 600 s run at 40 Hz (24 000 samples) is drawn as at most one min/max bucket per pixel
    column; each single-sample spike, up or down, is one of the drawn points (exactly), and
    every bucket's two points are the bucket's minimum and maximum."""
    rng = np.random.default_rng(11)
    n = 24_000
    t = np.arange(n) / 40.0
    x = np.sin(2 * np.pi * 0.1 * t) + 0.05 * rng.standard_normal(n)
    where = rng.choice(n, size=40, replace=False)
    spikes = np.where(rng.random(40) < 0.5, 1.0, -1.0) * rng.uniform(5.0, 50.0, 40)
    x[where] += spikes
    env = Envelope(n)
    assert env.bucket > 1
    at = 0
    for size in rng.integers(1, 3000, 100):
        env.add({"t": t[at : at + size], "x": x[at : at + size]})
        at += int(size)
        if at >= n:
            break
    drawn, times = env.get("x"), env.get("t")
    assert drawn.size == times.size <= 2 * DRAW_COLUMNS
    for k in where:
        assert x[k] in drawn, (k, x[k])
    b = env.bucket
    pad = (-n) % b
    rows = np.concatenate((x, np.full(pad, np.nan))).reshape(-1, b)
    np.testing.assert_array_equal(drawn[0::2], np.nanmin(rows, axis=1))
    np.testing.assert_array_equal(drawn[1::2], np.nanmax(rows, axis=1))
    assert np.all(np.diff(times) >= 0)


def _metadata(config: dict[str, object]) -> dict[str, dict[str, str]]:
    import json

    return {"scenario": {"name": "x", "json": json.dumps(config)}}


def test_spectra_mark_the_wave_peak_1p_3p_and_the_platform_modes_of_the_preset() -> None:
    """Wave peak 1/Tp, 1P = mean rotor speed / 2 pi and 3P, and the platform's surge and
    pitch modes within 10 % of the damped natural periods of the preset's linearised model
    (plant.modes.natural_modes, which adds radiation memory and the rotor)."""
    from plant.modes import natural_modes

    omega = 0.6  # rad/s
    cfg = {"platform": "iea15mw_volturnus", "waves": {"kind": "jonswap", "tp_s": 8.0}}
    marks = dict(
        (text.split(" (")[0], hz)
        for text, hz in spectral_marks({"kpi": {"rotor_speed_mean_rad_s": omega}}, _metadata(cfg))
    )
    assert marks["wave peak 1/Tp"] == pytest.approx(1 / 8.0, rel=1e-12)
    assert marks["1P"] == pytest.approx(omega / (2 * np.pi), rel=1e-12)
    assert marks["3P"] == pytest.approx(3 * omega / (2 * np.pi), rel=1e-12)
    modes = {m.name: m.period_s for m in natural_modes("iea15mw_volturnus")}
    assert 1 / marks["platform surge"] == pytest.approx(modes["surge"], rel=0.1)
    assert 1 / marks["platform pitch"] == pytest.approx(modes["pitch"], rel=0.1)
    # a bottom-fixed turbine in still water with no rotor speed: nothing to mark
    assert spectral_marks({"kpi": {}}, _metadata({"waves": {"kind": "still"}})) == []


def test_shipped_platform_periods_are_those_of_their_presets() -> None:
    """The table the review marks from is the computation on each shipped floating preset."""
    from pathlib import Path

    from plant.presets import floating

    names = sorted(p.stem for p in Path(floating.__file__).parent.glob("*.toml"))
    assert sorted(SHIPPED_PLATFORM_PERIODS_S) == names
    for name in names:
        got = platform_periods_s(name)
        assert got.keys() == SHIPPED_PLATFORM_PERIODS_S[name].keys(), name
        for dof, period in got.items():
            assert SHIPPED_PLATFORM_PERIODS_S[name][dof] == pytest.approx(period, rel=1e-9)


def test_plots_gathered_in_the_review_pass_equal_a_second_pass(tmp_path: Path) -> None:
    """A complete log's plots data gathered in the review's own pass (counts from the
    summary section, the spectra's window found on the way) equals the second pass's, which
    knows the summary: the same buckets, spans and spectra."""
    path = tmp_path / "run.mcap"
    write_log(path, 1500.0)  # 7500 cycles at 5 Hz: past MAX_POINTS, min/max buckets
    counts = plots.logged_counts(path)
    assert counts is not None and counts["truth"] == 7500
    reader = ColumnReader(path, plots.with_plot_fields(rs.FIELDS))
    one = plots.PlotData(counts, None, reader.info.metadata)
    summary = core.summarize_batches(reader.batches(), reader.info, one.feed)
    one.finish(summary)
    two = plots.collect(
        ColumnReader(path, plots.PLOT_FIELDS).batches(),
        reader.info.counts,
        summary,
        reader.info.metadata,
    )
    assert one.series["truth"].bucket == two.series["truth"].bucket > 1
    for sfx in ("truth", "timing/cycle"):
        for name in ("t", *plots.PLOT_FIELDS[sfx]):
            a, b = one.series[sfx].get(name), two.series[sfx].get(name)
            np.testing.assert_array_equal(a, b)
    assert one.events() == two.events()
    assert one.psd_t == two.psd_t
    for field, w in two.welch.items():
        f1, p1, n1, s1 = one.welch[field].finish()
        f2, p2, n2, s2 = w.finish()
        np.testing.assert_array_equal(f1, f2)
        assert (n1, s1) == (n2, s2)
        np.testing.assert_allclose(p1, p2, rtol=1e-12)


def _in_fresh_interpreter(script: str, tmp_path: Path) -> dict[str, Any]:
    """Run ``script`` (argv: ``tmp_path``, this folder) in a fresh interpreter, one thread,
    and return the JSON object its last line prints."""
    import json
    import os
    import subprocess
    import sys

    here = Path(__file__).resolve().parent
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(here.parent), str(here)])}
    proc = subprocess.run(
        [sys.executable, "-c", script, str(tmp_path), str(here)],
        capture_output=True,
        text=True,
        check=False,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    out: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


#: Run in a fresh interpreter (no thread of another test can make the drawing serial):
#: the review's plots drawn in two processes (fork counted) and serially, and a failing
#: child figure; prints what the tests check as JSON.
_FORK_CHECK = r"""
import json, os, sys
from pathlib import Path
from typing import Any
sys.path.insert(0, sys.argv[2])
from test_review_long_run import write_log
from hil.review import core, plots

tmp = Path(sys.argv[1])
path = tmp / "run.mcap"
write_log(path, 300.0)
forks = []
real_fork = os.fork
def counted_fork():
    forks.append(1)
    return real_fork()
os.fork = counted_fork
core.review(path, tmp / "two", plots=True)
os.fork = real_fork
two_processes = plots._in_two_processes
def serial(first, second):
    first()
    second()
plots._in_two_processes = serial
core.review(path, tmp / "one", plots=True)
same = {n: (tmp / "one" / n).read_bytes() == (tmp / "two" / n).read_bytes()
        for n in plots.PLOT_FILES}
def second():
    (tmp / "child.txt").write_text("drawn")
    raise ValueError("a figure the child could not draw")
try:
    two_processes(lambda: (tmp / "parent.txt").write_text("drawn"), second)
    error = None
except RuntimeError as exc:
    error = str(exc)
print(json.dumps({"forks": len(forks), "same": same, "error": error,
                  "parent": (tmp / "parent.txt").read_text(),
                  "child": (tmp / "child.txt").read_text()}))
"""


def test_plots_drawn_in_two_processes_equal_the_serial_ones_and_fail_loudly(
    tmp_path: Path,
) -> None:
    """In a fresh process on two cores the review draws the timing and spectra figures in
    a forked child (one fork), and they are the same files, byte for byte, as drawn in the
    calling process; a child figure that raises reaches the caller as one line with its
    type and message, and what both sides wrote is there."""
    import os

    if not hasattr(os, "fork") or len(os.sched_getaffinity(0)) < 2:
        pytest.skip("no fork or one core: the drawing is serial by design")
    got = _in_fresh_interpreter(_FORK_CHECK, tmp_path)
    assert got["forks"] == 1
    assert got["same"] == {name: True for name in plots.PLOT_FILES}
    assert got["error"] is not None
    assert "ValueError: a figure the child could not draw" in got["error"]
    assert (got["parent"], got["child"]) == ("drawn", "drawn")


#: Run in a fresh interpreter (one thread: the worker forks): the review's plots drawn by a
#: PlotWorker and here; a drawing that raises OSError; an unused worker closed; a worker
#: whose parent leaves without closing it. Prints what the test checks as JSON.
_WORKER_CHECK = r"""
import errno, json, os, signal, subprocess, sys, time
from pathlib import Path
from typing import Any
sys.path.insert(0, sys.argv[2])
from test_review_long_run import write_log
from hil.review import core, plots
from hil.review.plot_worker import PlotWorker

tmp = Path(sys.argv[1])
path = tmp / "run.mcap"
write_log(path, 300.0)
out = {}
worker = PlotWorker.start()
out["started"] = worker is not None
written = []
core.review(path, tmp / "worker", plots=True, written=written, worker=worker)
worker.close()
core.review(path, tmp / "here", plots=True)
out["written"] = [p.name for p in written]
out["same"] = {n: (tmp / "here" / n).read_bytes() == (tmp / "worker" / n).read_bytes()
               for n in plots.PLOT_FILES}
# a worker that has imported the drawing code reads the file itself, beside the review's
# pass, and draws once the summary comes: the same files
def ready(w):
    deadline = time.monotonic() + 120.0
    while not w.ready() and time.monotonic() < deadline:
        time.sleep(0.01)
    return w.ready()
gatherer = PlotWorker.start()
out["gatherer_ready"] = ready(gatherer)
written = []
core.review(path, tmp / "gathered", plots=True, written=written, worker=gatherer)
out["gathered_written"] = [p.name for p in written]
out["gathered_same"] = all((tmp / "here" / n).read_bytes() == (tmp / "gathered" / n).read_bytes()
                           for n in plots.PLOT_FILES)
out["gatherer_status"] = gatherer._status
# a file the review refuses: the worker that read it too writes nothing and is killed
robot = tmp / "robot.mcap"
from mcap.writer import Writer
with open(robot, "wb") as fh:
    w = Writer(fh)
    w.start(profile="", library="robot-logger")
    cid = w.register_channel("/robot/pose", "json", w.register_schema("Pose", "jsonschema", b"{}"))
    for k in range(50):
        w.add_message(cid, log_time=k * 10**7, publish_time=k * 10**7, data=b"{}")
    w.finish()
refused = PlotWorker.start()
ready(refused)
try:
    core.review(robot, tmp / "refused", plots=True, worker=refused)
    out["refused"] = None
except core.NotRunLogError as exc:
    out["refused"] = type(exc).__name__
refused.close()
time.sleep(0.5)
out["refused_status"] = refused._status
out["refused_wrote"] = sorted(p.name for p in (tmp / "refused").glob("*"))
# a worker killed while it reads the file: the review reads it again and draws here
doomed = PlotWorker.start()
ready(doomed)
real_gather = core.ColumnReader
def gather_then_kill(*a, **k):  # the review's own pass starts after the worker's job was sent
    core.ColumnReader = real_gather
    os.kill(doomed._pid, signal.SIGKILL)
    return real_gather(*a, **k)
core.ColumnReader = gather_then_kill
written = []
core.review(path, tmp / "doomed", plots=True, written=written, worker=doomed)
core.ColumnReader = real_gather
out["doomed_written"] = [p.name for p in written]
out["doomed_same"] = all((tmp / "here" / n).read_bytes() == (tmp / "doomed" / n).read_bytes()
                         for n in plots.PLOT_FILES)
# a drawing that fails in the child: the parent raises the child's exception
real = plots.write_plots
def full(data, out_dir, blank=None):
    raise OSError(errno.ENOSPC, "No space left on device", str(out_dir / "timeseries.png"))
for key, wait in (("error", False), ("gathered_error", True)):  # handed the data; read the file
    plots.write_plots = full
    failing = PlotWorker.start()  # the child has the failing drawing
    plots.write_plots = real
    if wait:
        ready(failing)
    try:
        core.review(path, tmp / "full", plots=True, worker=failing)
        out[key] = None
    except OSError as exc:
        out[key] = [type(exc).__name__, exc.errno, exc.filename]
    failing.close()
# its name; the signals a terminal sends the whole group do not end it (the launcher still
# wants its plots); killed from outside, the review draws in its own process instead
def alive(p):
    try:
        return Path(f"/proc/{p}/stat").read_text().split(")")[1].split()[0] != "Z"
    except OSError:
        return False
def comm(pid):
    try:
        return Path(f"/proc/{pid}/comm").read_text().strip()
    except OSError:
        return None
hardy = PlotWorker.start()
deadline = time.monotonic() + 60.0  # named once its signal handlers are set
while comm(hardy._pid) != "fowt-plots" and time.monotonic() < deadline:
    time.sleep(0.01)
out["name"] = comm(hardy._pid)
for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
    os.kill(hardy._pid, sig)
time.sleep(0.5)
out["hardy_alive"] = alive(hardy._pid)
written = []
core.review(path, tmp / "hardy", plots=True, written=written, worker=hardy)
out["hardy_drew"] = [p.name for p in written]
killed = PlotWorker.start()
os.kill(killed._pid, signal.SIGKILL)
written = []
core.review(path, tmp / "killed", plots=True, written=written, worker=killed)
out["killed_same"] = all((tmp / "here" / n).read_bytes() == (tmp / "killed" / n).read_bytes()
                         for n in plots.PLOT_FILES)
out["killed_written"] = [p.name for p in written]
# a worker given nothing: killed and reaped at close
unused = PlotWorker.start()
unused.close()
out["unused_status"] = unused._status
out["unused_gone"] = not os.path.exists(f"/proc/{unused._pid}")
# a parent that leaves without closing: its worker sees end-of-file and leaves too
code = ("import sys; sys.path[:0] = " + repr(sys.path[:3]) + "\n"
        "import os\nfrom hil.review.plot_worker import PlotWorker\n"
        "w = PlotWorker.start(); print(w._pid, flush=True); os._exit(0)")
pid = int(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip())
deadline = time.monotonic() + 60.0
while alive(pid) and time.monotonic() < deadline:
    time.sleep(0.05)
out["orphan_left"] = not alive(pid)
print(json.dumps(out))
"""


def test_plots_drawn_by_the_plot_worker_equal_those_drawn_here(tmp_path: Path) -> None:
    """The drawing process ``fowt run`` and ``fowt review`` start first
    (:class:`hil.review.plot_worker.PlotWorker`) writes the same three files, byte for byte,
    as the review drawing them itself; a drawing that raises there (a full disk) is raised
    by the review as the same ``OSError`` (errno and file kept), so the commands' one-line
    exit 1 holds; it is named ``fowt-plots`` and outlives the SIGINT, SIGTERM and SIGHUP a
    terminal sends the whole process group (the launcher reviews an aborted run with its
    plots); a worker that is ready when the review starts reads the file itself and draws
    the same files (the same error where the drawing fails; nothing written for a file the
    review refuses; the review draws itself where it is killed while reading); a worker
    killed from outside leaves the review to draw the same files itself; a
    worker given nothing is killed and reaped at close (SIGKILL); a worker whose parent
    leaves without closing it leaves too (end-of-file on its pipe)."""
    import errno
    import os
    import signal

    if not hasattr(os, "fork") or len(os.sched_getaffinity(0)) < 2:
        pytest.skip("no fork or one core: the review draws in its own process by design")
    got = _in_fresh_interpreter(_WORKER_CHECK, tmp_path)
    assert got["started"]
    assert got["written"] == ["summary.json", *plots.PLOT_FILES]
    assert got["same"] == {name: True for name in plots.PLOT_FILES}
    assert got["error"] == ["OSError", errno.ENOSPC, str(tmp_path / "full" / "timeseries.png")]
    # ready before the review: it read the file itself, and drew the same files
    assert got["gatherer_ready"] and got["gatherer_status"] == 0
    assert got["gathered_written"] == ["summary.json", *plots.PLOT_FILES]
    assert got["gathered_same"]
    assert got["gathered_error"] == got["error"]
    assert got["refused"] == "NotRunLogError" and got["refused_wrote"] == []
    assert got["refused_status"] == -signal.SIGKILL
    assert got["doomed_written"] == ["summary.json", *plots.PLOT_FILES] and got["doomed_same"]
    assert got["unused_status"] == -signal.SIGKILL and got["unused_gone"]
    assert got["name"] == "fowt-plots" and got["hardy_alive"]
    assert got["hardy_drew"] == ["summary.json", *plots.PLOT_FILES]
    assert got["killed_written"] == ["summary.json", *plots.PLOT_FILES] and got["killed_same"]
    assert got["orphan_left"]
