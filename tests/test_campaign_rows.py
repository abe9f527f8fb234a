"""A campaign run's in-process path taking the compiled loop's rows (hil.campaign.runner._RunSink,
hil.runlog.writer.InProcessRunLog) against the path before it (every message a Struct,
JSON-encoded by msgspec when published, ``orjson.loads`` at the end) and the recorder's
(every Struct written by ``RunLog.write``).

One run feeds both: its Python-path Structs go to both sinks, its compiled blocks of rows to
the new sink as rows and to the old one as the Structs ``CompiledLoop`` makes of them without
``publish_block`` (``rows_to_structs``). So everything must be equal, wall-clock fields
included: the RunData message for message and dict for dict (a non-finite float None), the
review summary and the campaign KPIs, and the MCAP files' messages (topic, sequence, log
time, CDR bytes); only the records' ``publish_time`` (the wall clock, read at another
moment) may differ.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import orjson
import pytest
from mcap.reader import make_reader

from bus_schemas.registry import MessageType
from hil.campaign.runner import _inprocess, _RunSink, execute_run, run_kpis_of, to_toml
from hil.inprocess.loop import rows_to_structs
from hil.inprocess.run import run_inprocess
from hil.nodes.controller_node import ControllerRuntime, publishing_step
from hil.review.core import _col, summarize
from hil.runlog.mcap_io import MessageList, RunData, RunLog, read_run
from hil.runlog.writer import InProcessRunLog
from hil.scenario.schema import Scenario, load_scenario


class _OldSink:
    """hil.campaign.runner._inprocess before the rows: JSON per message, orjson.loads; the file
    written message by message (RunLog.write, the recorder's path)."""

    def __init__(self, turbine: str, log: RunLog | None) -> None:
        self.turbine = turbine
        self.log = log
        self.store: dict[str, list[bytes]] = {}

    def publish(self, mt: MessageType, msg: Any) -> None:
        data = msgspec.json.encode(msg)
        self.store.setdefault(mt.key(self.turbine), []).append(data)
        if self.log is not None:
            self.log.write(mt.key(self.turbine), msg, time.time_ns())

    def run_data(self) -> RunData:
        run = RunData()
        for key, blobs in self.store.items():
            run.messages[key] = [orjson.loads(b) for b in blobs]
        return run


def _both(scenario: Scenario, tmp: Path | None) -> tuple[RunData, RunData, str]:
    """One run into the old and the new sink (files old.mcap / new.mcap in ``tmp``)."""
    turbine = scenario.turbine_id
    meta = {"run": {"mode": "inprocess"}}
    old_log = RunLog(tmp / "old.mcap", turbine) if tmp is not None else None
    if old_log is not None:
        old_log.add_metadata("run", meta["run"])
    new_log = InProcessRunLog(tmp / "new.mcap", turbine, meta) if tmp is not None else None
    if old_log is not None and new_log is not None:  # the same t = 0 (log time = it + t)
        new_log.log.start_unix_ns = old_log.start_unix_ns
    old, new = _OldSink(turbine, old_log), _RunSink(turbine, new_log)

    def publish(mt: MessageType, msg: Any) -> None:
        old.publish(mt, msg)
        new.publish(mt, msg)

    def publish_block(order: Any, rows: dict[int, Any]) -> None:
        new.publish_block(order, rows)
        for mt, msg in rows_to_structs(order, rows):
            old.publish(mt, msg)

    runtime = ControllerRuntime(scenario, paced=False)
    result = run_inprocess(
        scenario,
        publish,
        publishing_step(runtime, publish),
        runtime=runtime,
        publish_block=publish_block,
    )
    if old_log is not None and new_log is not None:
        old_log.close()
        new_log.close()
    a, b = old.run_data(), new.run_data({})
    return a, b, result.loop


def _same_json(a: Any, b: Any) -> bool:
    """Equal as JSON text (nan and inf written as NaN/Infinity, so equal only to themselves)."""
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


def _records(path: Path) -> dict[str, list[tuple[int, int, bytes]]]:
    out: dict[str, list[tuple[int, int, bytes]]] = {}
    with path.open("rb") as f:
        for _s, channel, m in make_reader(f).iter_messages(log_time_order=False):
            out.setdefault(channel.topic, []).append((m.sequence, m.log_time, m.data))
    return out


CASES = [
    # 40 s: lqri_ff's forecaster buffer not yet filled (its forecast NaN: None in the dicts)
    ("iea15mw-lc2-lqri-ff", 40.0, "compiled"),
    ("iea15mw-lc2", 40.0, "compiled"),
    # sensor faults: the compiled loop does not run it; every message is a Struct
    ("faults-sensors", 10.0, "python"),
]


@pytest.mark.parametrize(("name", "duration_s", "loop"), CASES)
def test_rows_path_equals_the_json_path(
    name: str, duration_s: float, loop: str, tmp_path: Path
) -> None:
    scenario = load_scenario(name).with_duration(duration_s)
    old, new, ran = _both(scenario, tmp_path)
    assert ran == loop
    # the RunData, message for message, dict for dict (and in publish order)
    assert old.messages.keys() == new.messages.keys()
    assert len(new.topic("truth")) == scenario.cycles
    for key, msgs in old.messages.items():
        got = new.messages[key]
        assert isinstance(got, MessageList)
        assert len(got) == len(msgs), key
        for i, (x, y) in enumerate(zip(msgs, got, strict=True)):
            assert x == y, f"{key} #{i}"
            assert [type(v) for v in x.values()] == [type(v) for v in y.values()], f"{key} #{i}"
        # the columns are the list comprehension's arrays, nan for None
        for field in [*msgs[0].keys(), "no_such_field"]:
            want = _col(list(msgs), field)
            have = got.column(field)
            assert have.tobytes() == want.tobytes(), f"{key}.{field}"
    # what the campaign makes of them: the review summary and the KPIs
    assert _same_json(summarize(old), summarize(new))
    k_old = run_kpis_of(old, scenario, None)
    k_new = run_kpis_of(new, scenario, None)
    assert _same_json(k_old, k_new)
    # the KPI window (a campaign's discard_s is each run's [review] settle_s): t >= settle_s
    t = new.topic("truth").column("sample_time_ns") / 1e9
    power = new.topic("truth").column("electrical_power_w")
    quarter = 0.25 * duration_s
    late = msgspec.structs.replace(
        scenario, review=msgspec.structs.replace(scenario.review, settle_s=quarter)
    )
    k_late = run_kpis_of(new, late, None)["kpi"]
    assert k_late["mean_power_w"] == pytest.approx(float(power[t >= quarter].mean()), rel=1e-12)
    # a settle time longer than half the run (a campaign shortened by --duration): its second half
    short = msgspec.structs.replace(
        scenario, review=msgspec.structs.replace(scenario.review, settle_s=10.0 * duration_s)
    )
    k_short = run_kpis_of(new, short, None)["kpi"]
    second = t >= 0.5 * t[-1]
    assert k_short["mean_power_w"] == pytest.approx(float(power[second].mean()), rel=1e-12)
    # the files: per topic the same messages (sequence, log time, CDR bytes)
    a, b = _records(tmp_path / "old.mcap"), _records(tmp_path / "new.mcap")
    assert a.keys() == b.keys()
    for topic, recs in a.items():
        assert recs == b[topic], topic
    assert read_run(tmp_path / "new.mcap").complete


def test_row_dicts_are_the_structs_json_decoded() -> None:
    """_row_dicts against rows_to_structs + msgspec JSON + orjson.loads on extreme values:
    NaN, infinities, -0.0, a positive exponent, subnormals, int64's ends."""
    from bus_schemas.registry import CONTROLLER_STATUS, TRUTH
    from hil.campaign.runner import _row_dicts

    specials = [math.nan, math.inf, -math.inf, -0.0, 1e16, 1.5e300, 5e-324, 0.1, -2.5, 0.0]
    ints = [0, -1, 2**63 - 1, -(2**63), 40_000_000_000, 7]
    for mt in (TRUTH, CONTROLLER_STATUS):
        dt = mt.row_dtype
        names = dt.names or ()
        rows = np.zeros(len(specials), dt)
        for j, n in enumerate(names):
            if dt[n].kind == "f":
                rows[n] = np.roll(specials, j)
            else:
                rows[n] = np.roll(np.resize(ints, len(specials)), j)
        order = np.full(len(rows), mt.message_id, np.uint8)
        want = [
            orjson.loads(msgspec.json.encode(m))
            for _, m in rows_to_structs(order, {mt.message_id: rows})
        ]
        got = _row_dicts(rows)
        assert got == want
        for x, y in zip(want, got, strict=True):
            assert [type(v) for v in x.values()] == [type(v) for v in y.values()]
            assert [math.copysign(1.0, v) for v in x.values() if isinstance(v, float)] == [
                math.copysign(1.0, v) for v in y.values() if isinstance(v, float)
            ]
        # NaN and the infinities (3 of the 10 specials) are null in every float column
        n_float = sum(dt[n].kind == "f" for n in names)
        assert n_float > 0
        assert sum(v is None for d in got for v in d.values()) == 3 * n_float


def test_inprocess_run_data_is_its_mcap(tmp_path: Path) -> None:
    """The campaign's own run: the RunData in memory equals the file read back."""
    scenario = load_scenario("iea15mw-lc2-lqri-ff").with_duration(30.0)
    run = _inprocess(scenario, tmp_path / "run.mcap", "", None)
    back = read_run(tmp_path / "run.mcap")
    assert back.complete and back.statistics_ok
    assert {k: v for k, v in back.messages.items() if v} == run.messages
    assert back.metadata == run.metadata
    assert back.statistics is not None
    assert {k: n for k, n in back.statistics.items() if n} == {
        k: len(v) for k, v in run.messages.items()
    }
    since = run.topic("truth")
    assert isinstance(since, MessageList)
    # MessageList.since: the plain comprehension's messages, its columns theirs
    t0 = 12.5e9
    cut = since.since("sample_time_ns", t0)
    plain = [m for m in since if m.get("sample_time_ns", -1) >= t0]
    assert cut == plain and len(plain) == len(since) - 500
    assert cut.column("rotor_speed_rad_s").tolist() == [m["rotor_speed_rad_s"] for m in plain]


def test_execute_run_with_and_without_record(tmp_path: Path) -> None:
    """execute_run on the rows path: the same KPIs recording or not; the file complete."""
    sc = msgspec.to_builtins(load_scenario("iea15mw-lc2").with_duration(20.0))
    results = {}
    for record in ("mcap", "none"):
        payload = {
            "scenario": sc,
            "mode": "inprocess",
            "run_dir": str(tmp_path / record),
            "record": record,
            "design_dir": None,
            "min_rotor_speed_rad_s": None,
        }
        r = execute_run(payload)
        assert r["status"] == "ok", r["traceback"]
        results[record] = r
    assert _same_json(results["mcap"]["kpi"], results["none"]["kpi"])
    assert math.isfinite(results["none"]["kpi"]["mean_power_w"])
    back = read_run(tmp_path / "mcap" / "run.mcap")
    assert back.complete and len(back.topic("truth")) == 800
    assert to_toml(sc)
