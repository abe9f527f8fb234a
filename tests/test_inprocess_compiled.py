"""The compiled in-process loop (hil.inprocess.loop, hil.inprocess.kernels) against the Python loop.

Both loops run the same seeded scenario; every message must be equal field by field, bit
for bit, except the wall-clock stamps (publish times, the controller's compute time, the
cycle's latency and plant compute time, and the summaries' latency percentiles and speed),
which are real clock readings in both. The counters of the plant loop and of the controller
runtime and the final state of plant, sensor suite and controller core must be equal too.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bus_schemas import jit
from bus_schemas.registry import CONTROLLER_STATUS, TIMING_SUMMARY, MessageType
from controller.forecast import ForecasterState
from hil.campaign.envelope import controller_variant
from hil.inprocess import kernels as lk
from hil.inprocess.loop import CompiledLoop, compiled_unsupported
from hil.inprocess.run import run_inprocess
from hil.launch import RunRequest, launch
from hil.nodes.controller_node import ControllerRuntime, publishing_step
from hil.nodes.plant_node import PlantLoop
from hil.nodes.timing import LatencyHistogram
from hil.runlog.mcap_io import read_run
from hil.scenario.schema import Scenario, load_scenario, parse_scenario, scenario_text

#: Fields that hold wall-clock readings (equal in kind, not in value).
WALL = frozenset(
    {
        "publish_time_ns",
        "compute_time_ns",
        "latency_ns",
        "plant_compute_ns",
        "latency_p50_us",
        "latency_p99_us",
        "latency_p999_us",
        "latency_max_us",
        "sim_seconds_per_wall_second",
    }
)


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return bool(a == b)


class _Run:
    """One run's messages (type id -> Structs), plant loop and runtime, by either loop."""

    def __init__(self, scenario: Scenario, loop: str) -> None:
        self.msgs: dict[int, list[Any]] = {}
        self.sequence: list[Any] = []  # every message in publish order
        rt = ControllerRuntime(scenario)

        def publish(mt: MessageType, msg: Any) -> None:
            self.msgs.setdefault(mt.message_id, []).append(msg)
            self.sequence.append(msg)

        step = publishing_step(rt, publish)

        plant = PlantLoop(scenario, publish)
        self.plant, self.rt = plant, rt
        self.fast: CompiledLoop | None = None
        if loop == "compiled":
            assert compiled_unsupported(plant, rt) is None
            self.fast = CompiledLoop(plant, rt, step)
            self.fast.run(scenario.cycles)
        else:
            clock = time.monotonic_ns
            for _ in range(scenario.cycles):
                frame = plant.sample()
                t0 = clock()
                command = step(frame)
                plant.finish_cycle(command, clock() - t0, at_arrival=False)
        plant.count_faults()
        plant.publish_summary(final=True)


def _compare(a: _Run, b: _Run) -> None:
    assert a.msgs.keys() == b.msgs.keys()
    for mid, xs in a.msgs.items():
        ys = b.msgs[mid]
        assert len(xs) == len(ys), f"message {mid}: {len(xs)} != {len(ys)}"
        for i, (x, y) in enumerate(zip(xs, ys, strict=True)):
            assert type(x) is type(y)
            for name in x.__struct_fields__:
                if name in WALL:
                    continue
                assert _same(getattr(x, name), getattr(y, name)), (
                    f"{type(x).__name__} #{i} {name}: {getattr(x, name)!r} != {getattr(y, name)!r}"
                )
    pa, pb = a.plant, b.plant
    assert pa.k == pb.k
    assert pa.x == pb.x
    assert pa.applied == pb.applied
    ra, rb = pa.result, pb.result
    for name in (
        "cycles",
        "deadline_misses",
        "commands_held",
        "commands_rejected",
        "commands_late",
        "safe_state_entries",
        "safe_state_cycles",
        "faults_injected",
    ):
        assert getattr(ra, name) == getattr(rb, name), name
    assert pa.hist.n == pb.hist.n
    assert (pa.consecutive_misses, pa.on_time_run, pa.safe_state) == (
        pb.consecutive_misses,
        pb.on_time_run,
        pb.safe_state,
    )
    assert pa.summary_seq == pb.summary_seq
    sa, sb = pa.sim, pb.sim
    assert np.array_equal(sa._s, sb._s, equal_nan=True)
    assert sa._wave_n == sb._wave_n
    ca, cb = sa.channels, sb.channels
    assert ca is not None and cb is not None
    for name in ("f", "st", "ok", "hist_t", "hist_v", "rn"):
        va, vb = getattr(ca.state_bundle, name), getattr(cb.state_bundle, name)
        assert np.array_equal(va, vb, equal_nan=True), name
    rta, rtb = a.rt, b.rt
    for name in (
        "last_seq",
        "last_sample_time_ns",
        "command_seq",
        "accepted",
        "rejected",
        "consecutive_misses",
        "healthy_run",
        "safe_mode",
        "safe_entries",
        "frames_missing",
        "frames_stale",
        "_last_command",
        "_silence_counted",
    ):
        assert getattr(rta, name) == getattr(rtb, name), name
    st_a, st_b = rta.state, rtb.state
    if hasattr(st_a, "flags"):
        assert np.array_equal(st_a.values, st_b.values, equal_nan=True)
        assert np.array_equal(st_a.flags, st_b.flags)
        assert st_a.next_forecast_ns == st_b.next_forecast_ns
        assert _same(st_a.forecast_m, st_b.forecast_m)
        assert st_a.forecast_time_ns == st_b.forecast_time_ns
        fa, fb = st_a.forecaster, st_b.forecaster
        for name in ForecasterState.__slots__:
            va, vb = getattr(fa, name), getattr(fb, name)
            if isinstance(va, np.ndarray):
                assert np.array_equal(va, vb, equal_nan=True), f"forecaster {name}"
            else:
                assert _same(va, vb), f"forecaster {name}: {va!r} != {vb!r}"
    else:
        assert st_a.first_call == st_b.first_call
        assert np.array_equal(st_a.values, st_b.values, equal_nan=True)


def _scenario(name: str, duration_s: float, extra: str = "", timing: str = "") -> Scenario:
    text, source = scenario_text(name)
    if timing:
        text = text.replace("[timing]\n", f"[timing]\n{timing}\n", 1)
    return parse_scenario(text + extra, source).with_duration(duration_s)


def test_kernel_clock_is_time_monotonic_ns() -> None:
    """The kernel's CLOCK_MONOTONIC reading lies between two time.monotonic_ns() calls."""
    for _ in range(100):
        a = time.monotonic_ns()
        b = lk.monotonic_ns()
        c = time.monotonic_ns()
        assert a <= b <= c
    assert lk.clock_reads(10) >= c


@pytest.mark.parametrize(
    ("name", "duration_s"),
    [
        # 215 s: running summaries, forecaster updates (every 0.2 s), its buffer filled at
        # 204.6 s (forecast and wave feedforward on from there), the sensor suite's random
        # blocks (4096 draws) used up and refilled, the LQRI regimes switching
        ("iea15mw-lc2-lqri-ff", 215.0),
        ("iea15mw-lc2-lqri", 12.0),
        ("iea15mw-lc2", 110.0),
    ],
)
def test_compiled_loop_equals_python_loop(name: str, duration_s: float) -> None:
    scn = _scenario(name, duration_s)
    py = _Run(scn, "python")
    fast = _Run(scn, "compiled")
    _compare(py, fast)
    assert fast.fast is not None
    # most cycles ran in the kernel; summaries (every 1 s) and the refill stops happened;
    # the dispersion forecaster (every 0.2 s) ran in the kernel: no stop for it
    assert fast.fast.kernel_cycles >= 0.9 * scn.cycles
    assert fast.fast.stops.get("summary", 0) >= int(duration_s) - 1
    if duration_s > 103.0:
        assert fast.fast.stops.get("refill", 0) >= 1
    if name != "iea15mw-lc2":
        assert fast.fast.stops.get("forecast", 0) == 0
        assert py.rt.state.forecaster.calls == 5 * int(duration_s)
        regimes = {s.regime for s in py.msgs[CONTROLLER_STATUS.message_id]}
        if name == "iea15mw-lc2-lqri-ff":
            assert len(regimes) >= 3, f"the run should cross regimes, saw {regimes}"
            statuses = py.msgs[CONTROLLER_STATUS.message_id]
            assert sum(s.wave_forecast_time_ns > 0 for s in statuses) > 300
            assert any(s.feedforward_torque_nm != 0.0 for s in statuses)


def test_kernel_forecaster_holds_dropped_gauge_samples() -> None:
    """Gauge dropouts (p = 0.3): the kernel's dispersion forecaster holds the last valid
    sample and counts the drops (in the run and in its window) as ForecasterState does."""
    extra = """
[sensors.channels.wave_elevation_gauge_measured_m]
dropout_probability = 0.3
"""
    scn = _scenario("iea15mw-lc2-lqri-ff", 8.0, extra)
    py = _Run(scn, "python")
    fast = _Run(scn, "compiled")
    _compare(py, fast)  # the forecaster's state too: buffer, drop flags, counters, held_m
    assert fast.fast is not None
    assert fast.fast.stops.get("forecast", 0) == 0
    fs = py.rt.state.forecaster
    assert fs.calls == 40
    assert 4 <= fs.dropped <= 24  # binomial(40, 0.3): mean 12
    assert fs.dropped_in_window == fs.dropped == int(fs.drop_flags.sum())


@pytest.mark.parametrize(("forecaster", "duration_s"), [("ar", 28.0), ("esprit", 34.0)])
def test_compiled_loop_runs_other_forecasters_in_python(forecaster: str, duration_s: float) -> None:
    """AR and ESPRIT (fitted in Python) stop the kernel at every forecaster call (0.2 s) and
    resume the same cycle; the run past their fill (25.2 s, 31.6 s: forecasts on) equals the
    Python loop's bit for bit."""
    text = controller_variant("iea15mw-lc2", "lqri_ff", forecaster=forecaster)
    scn = parse_scenario(text, f"{forecaster}.toml").with_duration(duration_s)
    py = _Run(scn, "python")
    fast = _Run(scn, "compiled")
    _compare(py, fast)
    assert fast.fast is not None
    assert type(py.rt.controller.forecaster).__name__.lower().startswith(forecaster)
    assert fast.fast.kernel_cycles >= 0.9 * scn.cycles
    assert fast.fast.stops.get("forecast", 0) >= 5 * int(duration_s) - 1
    statuses = py.msgs[CONTROLLER_STATUS.message_id]
    assert sum(s.wave_forecast_time_ns > 0 for s in statuses) > 40


#: Two channels whose biases make a frame's sum overflow when both are valid (each is
#: finite): the runtime rejects such a frame as non-finite. Dropout (p = 0.5 each) makes it
#: one frame in four, so the compiled loop hands those frames back to handle_frame and the
#: following cycle (a gap: a missed frame) to the Python loop.
_OVERFLOW = """
[sensors.channels.electrical_power_measured_w]
bias = 1.7e308
range_max = 1.79e308
dropout_probability = 0.5

[sensors.channels.wind_speed_measured_m_s]
bias = 1.7e308
range_max = 1.79e308
dropout_probability = 0.5
"""


@pytest.mark.parametrize("name", ["iea15mw-lc2", "iea15mw-lc2-lqri-ff"])
def test_compiled_loop_hands_rejected_frames_back(name: str) -> None:
    scn = _scenario(name, 6.0, _OVERFLOW, timing="watchdog_misses = 0")
    py = _Run(scn, "python")
    fast = _Run(scn, "compiled")
    _compare(py, fast)
    assert py.rt.rejected["non_finite"] > 10
    assert py.rt.frames_missing > 5
    assert py.plant.result.deadline_misses == py.rt.rejected["non_finite"]
    assert fast.fast is not None
    # frames rejected after a kernel cycle were handed back (the others came in the Python
    # cycle that follows a rejection: its gap is a missed frame)
    assert fast.fast.stops.get("frame", 0) >= 3
    assert fast.fast.kernel_cycles > 0.2 * scn.cycles


def test_unsupported_scenarios_take_the_python_loop() -> None:
    for name, why in (("faults-bus", "bus faults"), ("nrel5mw-ramp", "bottom-fixed plant")):
        scn = load_scenario(name).with_duration(0.5)
        rt = ControllerRuntime(scn)
        with pytest.raises(ValueError, match=why):
            run_inprocess(scn, lambda *_: None, lambda _f: None, runtime=rt, loop="compiled")
    scn = load_scenario("faults-sensors").with_duration(0.5)
    rt = ControllerRuntime(scn)
    assert compiled_unsupported(PlantLoop(scn, lambda *_: None), rt) == "sensor faults"


def _json_by_topic(path: Path) -> dict[str, list[bytes]]:
    """Each topic's messages in file order (decoded from their CDR payloads as JSON text of
    their fields, in declaration order; a non-finite float null), wall-clock fields 0."""
    out: dict[str, list[bytes]] = {}
    for topic, msgs in read_run(path).messages.items():
        out[topic] = [
            json.dumps({k: 0 if k in WALL else v for k, v in m.items()}).encode() for m in msgs
        ]
    return out


@pytest.mark.parametrize("name", ["iea15mw-lc2-lqri-ff", "iea15mw-lc2"])
def test_mcap_of_compiled_loop_equals_python_loop(name: str, tmp_path: Path) -> None:
    """Through the launcher (BackgroundRunLog.publish_block): the file's messages per topic,
    in order, the same values bit for bit (their full-precision text) but for the wall-clock
    fields."""
    runs = {}
    for loop in ("python", "compiled"):
        summary = launch(
            RunRequest(
                name,
                mode="inprocess",
                duration_s=4.0,
                out_dir=tmp_path / loop,
                plots=False,
                inprocess_loop=loop,  # type: ignore[arg-type]
            )
        )
        assert summary["run"]["inprocess_loop"] == loop
        runs[loop] = _json_by_topic(tmp_path / loop / "run.mcap")
    a, b = runs["python"], runs["compiled"]
    assert a.keys() == b.keys()
    assert len(a["fowt/t1/sensors"]) == 160
    for topic, xs in a.items():
        ys = b[topic]
        assert len(xs) == len(ys), topic
        for i, (x, y) in enumerate(zip(xs, ys, strict=True)):
            assert x == y, f"{topic} #{i}:\n{x!r}\n{y!r}"


def _bound_loop() -> CompiledLoop:
    """A compiled loop of a 1 s baseline run, its kernel's entry point bound."""
    scn = load_scenario("iea15mw-lc2").with_duration(1.0)
    fast = CompiledLoop(PlantLoop(scn, lambda *_: None), ControllerRuntime(scn), lambda _f: None)
    assert fast._kernel is not None
    return fast


def test_kernel_entry_point_is_dropped_when_an_array_type_changes() -> None:
    """The loop calls the kernel's compiled entry point (which does not check its arguments)
    only while the replaceable arrays keep the types it was bound with."""
    fast = _bound_loop()
    sim = fast.loop.sim
    wc = sim._wc
    fast._check_kernel_types()
    assert fast._kernel is not None
    sim._wc = np.asfortranarray(np.vstack([wc, wc]))  # another layout: another type
    fast._check_kernel_types()
    assert fast._kernel is None  # the dispatcher types (and checks) every call again
    sim._wc = wc


def test_loop_kernel_cache_is_keyed_by_the_composed_kernels_sources() -> None:
    """numba keys a cache by the function's own file; the loop kernel's key also holds the
    compile options' file and the plant, sensor and controller kernel files it composes (a
    change there recompiles it)."""
    locator = lk.run_cycles._cache._impl._locator
    assert type(locator).__name__.startswith("Keyed")
    _own, extra = locator.get_source_stamp()
    files = jit.cache_key_files(lk.__file__)
    assert files == (Path(jit.__file__).resolve(), *lk._CALLEE_FILES)
    assert extra == jit._files_hash(files)
    assert [p.name for p in lk._CALLEE_FILES] == ["_kernels.py"] * 3
    assert all(p.is_file() for p in lk._CALLEE_FILES)


def test_every_kernel_cache_is_keyed_by_the_compile_options() -> None:
    """A kernel compiled through :mod:`bus_schemas.jit` has a cache key holding that file
    (its options live there, not beside the kernel)."""
    from controller import _kernels as ck
    from plant import _kernels as pk
    from sensors import _kernels as sk

    for fn in (pk.floating_step, sk.suite_step, ck.advanced_cycle):
        locator = fn._cache._impl._locator
        assert type(locator).__name__.startswith("Keyed"), fn
        assert jit.cache_key_files(locator._py_file) == (Path(jit.__file__).resolve(),)
    assert ck.advanced_cycle.targetoptions.get("nogil") is True
    assert not pk.floating_step.targetoptions.get("nogil")
    assert not any(f.targetoptions.get("fastmath") for f in (pk.floating_step, ck.advanced_cycle))


@pytest.mark.parametrize(("name", "duration_s"), [("iea15mw-lc2", 30.0), ("iea15mw-lc2-lqri", 9.0)])
def test_summaries_inside_a_batch_at_their_place(name: str, duration_s: float) -> None:
    """The kernel writes the running summary (every simulated second) as a row inside its
    batch: the messages of both loops in one publish order, type for type and field for
    field (wall-clock fields aside), with fewer kernel calls than summaries."""
    scn = _scenario(name, duration_s)
    py = _Run(scn, "python")
    fast = _Run(scn, "compiled")
    _compare(py, fast)
    assert len(py.sequence) == len(fast.sequence)
    for i, (x, y) in enumerate(zip(py.sequence, fast.sequence, strict=True)):
        assert type(x) is type(y), f"#{i}: {type(x).__name__} != {type(y).__name__}"
        for f in x.__struct_fields__:
            if f not in WALL:
                assert _same(getattr(x, f), getattr(y, f)), f"#{i} {type(x).__name__}.{f}"
    summaries = fast.msgs[TIMING_SUMMARY.message_id]
    assert [s.seq for s in summaries] == list(range(int(duration_s) + 1))
    assert summaries[-1].final == 1 and not any(s.final for s in summaries[:-1])
    assert fast.fast is not None
    assert fast.fast.stops["summary"] == int(duration_s)  # all written by the kernel
    assert fast.fast.batches < int(duration_s) / 4  # a batch holds several of them
    # the kernel's histogram is the plant loop's again at the end (its latencies are wall
    # clock readings: counted, each in one bin, the lowest and highest occupied bins kept)
    h = fast.plant.hist
    assert h.n == py.plant.hist.n == scn.cycles == sum(h.counts)
    occupied = np.flatnonzero(h.counts)
    assert (h._lo, h._hi) == (occupied[0], occupied[-1])
    assert h.max_ns > 0 and h.percentiles_us(100)[0] == h.max_ns / 1e3
    t_end_s = scn.cycles * fast.plant.period_ns * 1e-9
    assert fast.plant.result.sim_s == py.plant.result.sim_s == t_end_s


def test_kernel_histogram_is_latency_histogram() -> None:
    """hist_record and hist_percentile_us give LatencyHistogram's bins, counts, maximum
    and percentiles exactly (seeded latencies from 0.1 us to beyond the top bin)."""
    rng = np.random.default_rng(7)
    lats = np.concatenate(
        [
            (10 ** rng.uniform(2, 11.5, 5000)).astype(np.int64),
            [0, 1, 999, 1000, 1001, 10**11, 10**12, 2**62],
        ]
    )
    py = LatencyHistogram()
    counts = np.zeros(lk.H_N_BINS, np.int64)
    ist = np.zeros(lk.I_SIZE, np.int64)
    ist[lk.I_H_LO], ist[lk.I_H_HI] = py._lo, py._hi
    assert lk.hist_percentile_us(counts, ist, 50.0) == py.percentiles_us(50)[0] == 0.0
    for i, lat in enumerate(lats.tolist()):
        py.record(lat)
        lk.hist_record(counts, ist, lat)
        if i % 97 == 0 or i >= len(lats) - 8:
            assert counts.tolist() == py.counts
            assert ist[lk.I_H_N] == py.n and ist[lk.I_H_MAX] == py.max_ns
            assert (ist[lk.I_H_LO], ist[lk.I_H_HI]) == (py._lo, py._hi)
            qs = (*lk.SUMMARY_PERCENTILES, 0.01, 100.0)
            got = [lk.hist_percentile_us(counts, ist, q) for q in qs]
            assert got == py.percentiles_us(*qs)
    # every bin's upper edge, capped or not by the maximum
    for idx in range(1, lk.H_N_BINS - 1):
        one = LatencyHistogram()
        one.counts[idx], one.n, one._lo, one._hi = 1, 1, idx, idx
        c = np.zeros(lk.H_N_BINS, np.int64)
        c[idx] = 1
        for max_ns in (10**13, int(1000 * 10 ** (idx / 120)) - 1):
            one.max_ns = max_ns
            ist[lk.I_H_N], ist[lk.I_H_LO], ist[lk.I_H_HI], ist[lk.I_H_MAX] = 1, idx, idx, max_ns
            assert lk.hist_percentile_us(c, ist, 50.0) == one.percentiles_us(50)[0], idx


def test_kernel_entry_point_kept_while_the_types_hold() -> None:
    """A replaced array of the same numba type keeps the bound entry point; a read-only
    one (another type, the same dtype, shape and layout) drops it."""
    fast = _bound_loop()
    sim = fast.loop.sim
    wc = sim._wc
    sim._wc = wc.copy()
    fast._check_kernel_types()
    assert fast._kernel is not None
    ro = wc.copy()
    ro.flags.writeable = False
    sim._wc = ro
    fast._check_kernel_types()
    assert fast._kernel is None
    sim._wc = wc


def test_compiled_loop_reads_no_private_attribute_of_another_object() -> None:
    """The compiled loop uses the components' public API (their bundles, counters and
    adopt methods): no ``obj._name`` attribute in hil/inprocess except on ``self``."""
    import ast

    root = Path(__file__).resolve().parents[1] / "hil" / "inprocess"
    bad = []
    files = sorted(root.glob("*.py"))
    assert {"loop.py", "kernels.py"} <= {f.name for f in files}
    for path in files:
        name = path.name
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.Attribute):
                continue
            attr = node.attr
            if not attr.startswith("_") or attr.startswith("__"):
                continue
            if isinstance(node.value, ast.Name) and node.value.id == "self":
                continue
            bad.append(f"{name}:{node.lineno}: {ast.unparse(node)}")
    assert not bad, "\n".join(bad)


def test_run_cycles_takes_a_handful_of_bundles() -> None:
    """run_cycles' arguments: two ints and six bundles (named tuples of arrays)."""
    import inspect

    params = list(inspect.signature(lk.run_cycles.py_func).parameters)
    assert params == ["limit", "resume", "lb", "pb", "sb", "cb", "fb", "rb"]
