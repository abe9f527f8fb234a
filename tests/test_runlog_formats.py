"""Run log formats: today's CDR channels from a real run, and the JSON channels of older files.

* A real in-process run (load case 2, a few simulated seconds, the compiled loop handing
  rows to the writer child): every message handed to the log is in the file, decoded by
  ``mcap-ros2-support`` (an independent CDR decoder, from the file's own ``ros2msg``
  schemas) with exactly the values sent, compared bit for bit, per topic in publish order;
  the file is a complete MCAP file whose every message lies in its declared physical range.
* ``tests/data/runlog_json_v1.mcap``: a 10 s LC2 in-process run recorded with the JSON
  channels (schema version 1, before the CDR channels). It still reads complete, its
  review's KPIs equal the ones computed when it was recorded
  (``tests/data/runlog_json_v1.review.json``), and a cut copy of it is recovered complete
  by ``fowt recover``, as a cut CDR file is.
"""

from __future__ import annotations

import json
import math
import struct
import subprocess
import sys
import typing
from pathlib import Path

import numpy as np
import pytest
from _mcap_conformance import check_complete_mcap
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from bus_schemas import ros2
from bus_schemas.registry import BY_CLASS, MESSAGES
from hil.review.core import review
from hil.runlog.mcap_io import read_run, recover

DATA = Path(__file__).parent / "data"
JSON_V1 = DATA / "runlog_json_v1.mcap"
JSON_V1_REVIEW = json.loads((DATA / "runlog_json_v1.review.json").read_text())
RTOL = 1e-9


def _key(values: typing.Iterable[typing.Any]) -> tuple[typing.Any, ...]:
    """Values compared bit for bit (a float by its 8 bytes)."""
    return tuple(struct.pack("<d", v) if isinstance(v, float) else int(v) for v in values)


def _decoded(path: Path) -> dict[str, list[tuple[typing.Any, ...]]]:
    """Every message's values per topic, by mcap's reader and mcap-ros2-support's decoder;
    each payload is also byte for byte :func:`bus_schemas.ros2.encode_rows` of its values
    (its padding bytes zero: a file is a function of its messages)."""
    out: dict[str, list[tuple[typing.Any, ...]]] = {}
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for schema, ch, msg, dec in reader.iter_decoded_messages(log_time_order=False):
            values = [getattr(dec, k) for k in dec.__slots__]
            mt = next(m for m in BY_CLASS.values() if schema.name == ros2.schema_name(m))
            row = np.array([tuple(values)], mt.row_dtype)
            assert ros2.encode_rows(mt, row).tobytes() == msg.data
            out.setdefault(ch.topic, []).append(_key(values))
    return out


def test_every_message_of_a_real_run_decodes_to_what_was_sent(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from hil.launch import RunRequest, launch
    from hil.runlog import writer as log_writer

    sent: dict[str, list[tuple[typing.Any, ...]]] = {}
    by_id = {mt.message_id: mt for mt in MESSAGES}
    publish = log_writer.MessageBatcher.publish
    publish_block = log_writer.MessageBatcher.publish_block

    def spy_publish(self: typing.Any, mt: typing.Any, msg: typing.Any) -> None:
        fields = mt.codec.fields
        values = [getattr(msg, f.name) for f in fields]
        sent.setdefault(mt.key_suffix, []).append(
            _key(float(v) if f.is_float else v for f, v in zip(fields, values, strict=True))
        )
        publish(self, mt, msg)

    def spy_block(self: typing.Any, order: np.ndarray, rows: typing.Any) -> None:
        for mid, block in rows.items():
            mt = by_id[mid]
            sent.setdefault(mt.key_suffix, []).extend(_key(r) for r in block.tolist())
        publish_block(self, order, rows)

    monkeypatch.setattr(log_writer.MessageBatcher, "publish", spy_publish)
    monkeypatch.setattr(log_writer.MessageBatcher, "publish_block", spy_block)
    summary = launch(
        RunRequest("iea15mw-lc2", mode="inprocess", duration_s=4.0, out_dir=tmp_path, plots=False)
    )
    assert summary["run"]["outcome"] == "ok"
    path = tmp_path / "run.mcap"
    found = check_complete_mcap(path)  # every message within its declared range
    assert found.profile == "fowt-hil"
    got = {t.removeprefix("fowt/t1/"): v for t, v in _decoded(path).items()}
    assert {k: len(v) for k, v in got.items()} == {k: len(v) for k, v in sent.items() if v}
    assert got == {k: v for k, v in sent.items() if v}
    assert len(got["sensors"]) == len(got["truth"]) == 160  # 4 s at 40 Hz
    with open(path, "rb") as fh:
        summary_rec = make_reader(fh).get_summary()
    assert summary_rec is not None
    for ch in summary_rec.channels.values():
        schema = summary_rec.schemas[ch.schema_id]
        assert (ch.message_encoding, schema.encoding) == ("cdr", "ros2msg")
        mt = next(m for m in BY_CLASS.values() if schema.name == f"fowt_hil/msg/{m.name}")
        assert ch.metadata["version"] == str(mt.version)


def _close(a: typing.Any, b: typing.Any) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return math.isclose(a, b, rel_tol=RTOL, abs_tol=1e-12) or (math.isnan(a) and math.isnan(b))
    return bool(a == b)


def test_json_v1_run_log_still_reads_and_reviews_as_recorded() -> None:
    run = read_run(JSON_V1)
    assert run.complete and run.statistics_ok and not run.error
    counts = {t.removeprefix("fowt/t1/"): len(m) for t, m in run.messages.items()}
    assert counts == JSON_V1_REVIEW["messages"]
    summary = review(JSON_V1, plots=False, write_summary=False)
    for section in ("kpi", "kpi_window"):
        want = JSON_V1_REVIEW[section]
        have = summary[section]
        assert set(have) == set(want), section
        bad = [f"{k}: {have[k]!r} != {want[k]!r}" for k in want if not _close(have[k], want[k])]
        assert not bad, bad
    assert summary["timing"]["cycles"] == JSON_V1_REVIEW["cycles"] == 400
    assert 4.0e6 < summary["kpi"]["mean_power_w"] < 5.0e6  # 7.1 m/s on the 15 MW rotor


def test_json_v1_and_cdr_files_cut_are_recovered(tmp_path: Path) -> None:
    """A cut copy of each format reads up to the cut; ``recover`` and ``fowt recover``
    rewrite it complete with its channels' encodings and every message read."""
    from hil.runlog.mcap_io import RunLog

    cdr = tmp_path / "cdr.mcap"
    log = RunLog(cdr, "t1", flush_interval_s=1e9, batch_messages=100)
    fields = {f.name: 0.5 if f.is_float else 1 for f in MESSAGES[0].codec.fields}
    for i in range(1000):
        fields.update(seq=i, sample_time_ns=i * 25_000_000, publish_time_ns=i)
        log.write("fowt/t1/sensors", MESSAGES[0].cls(**fields))
    log.close()
    for path, encoding in ((JSON_V1, "json"), (cdr, "cdr")):
        data = path.read_bytes()
        cut = tmp_path / f"cut-{encoding}.mcap"
        cut.write_bytes(data[: int(len(data) * 0.6)])
        partial = read_run(cut)
        assert partial.truncated
        n = sum(len(m) for m in partial.messages.values())
        assert n > 0
        fixed = tmp_path / f"fixed-{encoding}.mcap"
        assert recover(cut, fixed) == n
        found = check_complete_mcap(fixed)
        assert found.message_count == n
        again = read_run(fixed)
        assert again.complete
        assert again.messages == partial.messages
        with open(fixed, "rb") as fh:
            summary = make_reader(fh).get_summary()
        assert summary is not None
        assert {c.message_encoding for c in summary.channels.values()} == {encoding}
        proc = subprocess.run(
            [sys.executable, "-m", "hil", "recover", str(cut), "--out", str(tmp_path / "c.mcap")],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        # The cut tail's messages are lost: recorded as incomplete (exit 4), not as healthy.
        assert proc.returncode == 4, proc.stdout + proc.stderr
        assert f"recovered {n} messages" in proc.stdout
