"""Bad input: malformed payloads on the controller's and the plant's input keys.

Unit level: every payload :mod:`hil.nodes.fuzz` builds is refused by the codec (or, replayed,
by the nodes' sequence checks) for the reason it reports, and the plant's
:class:`~hil.nodes.plant_node.CommandInbox` and the controller's
:class:`~hil.nodes.controller_node.ControllerRuntime` count each one under that reason.

End to end (marked ``e2e``): a seeded lock-step run of ``nrel5mw-ramp`` (150 s simulated)
with plant, controller and recorder as real processes, and a fuzzer process on the same
Zenoh session putting over 100 000 malformed payloads on ``fowt/t1/sensors`` and
``fowt/t1/command`` (paced at 12 per control cycle, capped at 20 000/s; about 8 000/s
measured on the 2-vCPU machine, so the fuzzing lasts about 14 s; the run is long enough
for that although the lock-step plant outpaces the fuzzer: about 1 000 cycles per wall
second with it). Every process exits 0,
the rejection counters add up to exactly what was sent, per key and (where a node reports
them) per reason, and the KPIs equal those of the same run without the fuzzer.
"""

from __future__ import annotations

import ast
import json
import re
import sys
from collections import Counter
from pathlib import Path

import pytest
from _helpers import NodeProcesses, fowt, key_file_args, lockstep_node_cmds, two_endpoints

from bus_schemas import ActuatorCommand, DecodeError
from bus_schemas.auth import TAG_BYTES, AuthError, new_key, verify
from bus_schemas.registry import COMMAND, SENSORS
from hil.nodes.controller_node import ControllerRuntime
from hil.nodes.fuzz import KINDS, REPLAY_REASON, FuzzConfig, Fuzzer, PayloadFactory
from hil.nodes.plant_node import CommandInbox
from hil.review.core import review
from hil.runlog.mcap_io import read_run
from hil.scenario.schema import load_scenario

SCENARIO = "nrel5mw-ramp"
DURATION_S = 150.0
CYCLES = 15_000  # 150 s at 100 Hz
FUZZ_TOTAL = 110_000
FUZZ_PER_CYCLE = 12.0
FUZZ_MAX_RATE_HZ = 20_000.0
#: Sending stops here at the latest so every payload is counted before the final summary.
FUZZ_STOP_CYCLE = 14_400


def _sensor_payload(seq: int) -> bytes:
    from _helpers import sensor_frame

    frame = sensor_frame(100.0, 0.01, 20_000.0, seq=seq, valid_mask=0b11111)
    return SENSORS.codec.encode(frame)


def _command_payload(answered: int) -> bytes:
    cmd = ActuatorCommand(
        seq=answered,
        answered_seq=answered,
        sample_time_ns=answered * 10_000_000,
        publish_time_ns=answered,
        mode=0,
        blade_pitch_commanded_rad=0.02,
        generator_torque_commanded_nm=30_000.0,
    )
    return COMMAND.codec.encode(cmd)


KEY = new_key()


def _loaded_fuzzer(newest: int = 50) -> tuple[Fuzzer, list[tuple[str, bytes]]]:
    """A fuzzer that has seen frames and commands 1..newest, recording what it puts."""
    sent: list[tuple[str, bytes]] = []
    fuzzer = Fuzzer(FuzzConfig(seed=3), lambda key, payload: sent.append((key, payload)), KEY)
    for k in range(1, newest + 1):
        fuzzer.on_sensors("", _sensor_payload(k))
        fuzzer.on_command("", _command_payload(k))
    return fuzzer, sent


def test_every_kind_is_built_and_rejected_for_its_reason() -> None:
    for target, other, seq_field, make in (
        (SENSORS, COMMAND, "seq", _sensor_payload),
        (COMMAND, SENSORS, "answered_seq", _command_payload),
    ):
        factory = PayloadFactory(target, other, seed=5, seq_field=seq_field)
        for k in range(1, 41):
            factory.capture(make(k))
            factory.capture_other((_command_payload if target is SENSORS else _sensor_payload)(k))
        for kind in KINDS:
            items = [p for _ in range(200) for p in factory.make(kind)]
            assert items, kind
            for item in items:
                assert item.kind == kind
                if kind == "forged":  # a valid payload with a wrong tag
                    target.codec.decode(item.payload[:-TAG_BYTES])
                    assert item.reason == "auth" and not item.signed
                    with pytest.raises(AuthError):
                        verify(KEY, target.key("t1"), item.payload)
                    continue
                if kind in ("replay", "reorder"):
                    msg = target.codec.decode(item.payload)  # a valid frame ...
                    assert getattr(msg, seq_field) <= 39  # ... at least one behind the newest
                    assert item.reason == REPLAY_REASON
                    continue
                with pytest.raises(DecodeError) as info:
                    target.codec.decode(item.payload)
                assert info.value.reason == item.reason, (kind, item.payload.hex())


def test_non_finite_covers_every_float_field_with_nan_and_both_infinities() -> None:
    factory = PayloadFactory(SENSORS, COMMAND, seed=1, seq_field="seq")
    factory.capture(_sensor_payload(1))
    floats = [f.name for f in SENSORS.codec.fields if f.is_float]
    hit: Counter[str] = Counter()
    for _ in range(4 * len(floats)):
        (item,) = factory.make("non_finite")
        with pytest.raises(DecodeError) as info:
            SENSORS.codec.decode(item.payload)
        assert info.value.reason == "non_finite"
        assert info.value.field is not None
        hit[info.value.field] += 1
    assert hit == dict.fromkeys(floats, 4)  # NaN, +inf, -inf, NaN with payload: each field


def test_fuzz_payloads_are_counted_by_the_plant_and_the_controller_in_process() -> None:
    """The very objects the nodes run count every fuzz payload under its expected reason."""
    fuzzer, sent = _loaded_fuzzer()
    for _ in range(5000):
        assert fuzzer.send_one()
    inbox = CommandInbox()
    inbox.last_answered = 50  # the plant has consumed the commands the fuzzer saw
    runtime = ControllerRuntime(load_scenario(SCENARIO))
    assert runtime.handle_payload(_sensor_payload(50)) is not None  # and so has the controller
    for key, data in sent:
        try:  # the nodes' bus edge: the tag first
            payload = verify(KEY, key, data)
        except AuthError as exc:
            if key.endswith("/sensors"):
                runtime.rejected[exc.reason] += 1
            else:
                inbox.reject(exc)
            continue
        if key.endswith("/sensors"):
            assert runtime.handle_payload(payload) is None
        else:
            inbox.on_payload(key, payload)
    assert inbox.latest is None  # nothing reached the plant loop
    assert runtime.accepted == 1
    report = fuzzer.report
    assert dict(runtime.rejected) == dict(report.expected["fowt/t1/sensors"])
    assert dict(inbox.rejected) == dict(report.expected["fowt/t1/command"])
    for key in ("fowt/t1/sensors", "fowt/t1/command"):
        assert set(report.sent[key]) == set(KINDS)
        assert sum(report.sent[key].values()) == 2500


def test_pacing_follows_cycles_and_the_rate_cap() -> None:
    fuzzer, _ = _loaded_fuzzer(newest=30)  # start_cycle 10: 21 cycles seen
    assert fuzzer.allowed(now_s=100.0, started_s=0.0) == 21 * 20
    assert fuzzer.allowed(now_s=0.001, started_s=0.0) == 21  # 20 000/s for 1 ms, plus one


def test_a_fuzzer_without_the_key_sends_no_forged_kind() -> None:
    fuzzer = Fuzzer(FuzzConfig(), lambda _k, _p: None)
    assert "forged" not in fuzzer.kinds and set(fuzzer.kinds) == set(KINDS) - {"forged"}


def _run_fuzzed(out: Path) -> tuple[dict[str, int], dict[str, object]]:
    """The lock-step run with the fuzzer; returns exit codes and the fuzzer's report."""
    plant_ep, ctrl_ep = two_endpoints()
    out.mkdir(parents=True)
    key = key_file_args(out)
    nodes = lockstep_node_cmds(
        SCENARIO, DURATION_S, out, (plant_ep, ctrl_ep), key, "controller,recorder,fuzzer"
    )
    fuzzer = [
        sys.executable, "-m", "hil.nodes.fuzz", "--connect", plant_ep, "--connect", ctrl_ep,
        "--total", str(FUZZ_TOTAL), "--per-cycle", str(FUZZ_PER_CYCLE),
        "--max-rate", str(FUZZ_MAX_RATE_HZ), "--stop-cycle", str(FUZZ_STOP_CYCLE),
        "--timeout", "150", "--report", str(out / "fuzz.json"), *key,
    ]  # fmt: skip
    with NodeProcesses(out) as procs:
        procs.start("recorder", nodes["recorder"])
        procs.start("controller", nodes["controller"])
        procs.start("fuzzer", fuzzer)
        procs.start("plant", nodes["plant"])
        codes = procs.wait(timeout=170)
    return codes, json.loads((out / "fuzz.json").read_text())


@pytest.mark.e2e
def test_fuzzing_a_lockstep_run_is_rejected_counted_and_changes_nothing(tmp_path: Path) -> None:
    base = tmp_path / "base"
    proc = fowt(
        "run", SCENARIO, "--mode", "lockstep", "--duration", str(DURATION_S), "--out", str(base),
        "--no-plots", timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout + proc.stderr
    baseline = json.loads((base / "summary.json").read_text())

    out = tmp_path / "fuzzed"
    codes, report = _run_fuzzed(out)
    logs = {n: (out / f"{n}.log").read_text() for n in codes}
    assert codes == dict.fromkeys(codes, 0), logs  # nothing crashed
    assert report["final_seen"]
    print(
        f"\nfuzzer: {report['total']} payloads {report['per_key']} at {report['rate_hz']}/s "
        f"over {report['sending_wall_s']} s, cycles {report['first_cycle']}..{report['last_cycle']}"
    )
    sent: dict[str, int] = report["per_key"]  # type: ignore[assignment]
    expected: dict[str, dict[str, int]] = report["expected_rejections"]  # type: ignore[assignment]
    assert sum(sent.values()) >= 100_000, report
    assert min(sent.values()) >= 50_000
    assert set(report["sent"]["fowt/t1/sensors"]) == set(KINDS)  # type: ignore[index]

    # The controller: its exit line gives the rejections by reason.
    match = re.search(
        r"controller stopped \(plant finished\): (\d+) cycles, rejected (\{.*\})",
        logs["controller"],
    )
    assert match, logs["controller"]
    assert int(match.group(1)) == CYCLES
    assert ast.literal_eval(match.group(2)) == expected["fowt/t1/sensors"]

    # The plant: only the total is reported (final timing summary, in the MCAP file).
    summary = review(out / "run.mcap", None, plots=False)
    assert summary["timing"]["complete"]
    assert summary["timing"]["cycles"] == CYCLES
    assert summary["timing"]["commands_rejected"] == sent["fowt/t1/command"]
    assert summary["timing"]["commands_rejected"] == sum(expected["fowt/t1/command"].values())
    # The controller's status carries its running total of rejected frames.
    run = read_run(out / "run.mcap")
    assert run.topic("controller/status")[-1]["rejected_frames"] == sent["fowt/t1/sensors"]
    assert len(run.topic("truth")) == CYCLES  # the recorder lost nothing under the load

    # Identical KPIs: nothing the fuzzer sent reached the plant loop or the controller core.
    assert summary["kpi"] == baseline["kpi"]
