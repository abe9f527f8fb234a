"""The review's streaming statistics against the whole-series functions, and the column
reader's two encodings (JSON and CDR) against the dict reader.

Random series (seeded) are fed in uneven pieces; every figure must equal the one of
:mod:`hil.review.kpi` over the whole series: means, standard deviations and maxima to 1e-12
relative (summation order), rainflow DEL and pitch travel to 1e-12, the median exactly.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter
from pathlib import Path

import msgspec
import numpy as np
import pytest

from bus_schemas import ros2
from bus_schemas.registry import MESSAGES
from hil.review import kpi
from hil.review import stream as rs
from hil.runlog.columns import ColumnReader
from hil.runlog.mcap_io import RunLog, read_run


def _pieces(x: np.ndarray, rng: np.random.Generator) -> list[slice]:
    cuts = np.sort(rng.choice(np.arange(1, x.size), size=7, replace=False))
    edges = [0, *cuts.tolist(), x.size]
    return [slice(a, b) for a, b in itertools.pairwise(edges)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_streamed_figures_equal_whole_series(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 5000
    t = np.arange(n) * 0.025
    x = np.cumsum(rng.normal(size=n)) + 3.0
    x[100:140] = x[100]  # a plateau (equal neighbours are skipped by the reversals)
    mom, rev, trav = rs.Moments(), rs.Reversals(), rs.Travel()
    for s in _pieces(x, rng):
        mom.add(x[s])
        rev.add(x[s], t[s])
        trav.add(x[s], t[s])
    assert math.isclose(mom.mean(), kpi.mean(x), rel_tol=1e-12)
    assert math.isclose(mom.std(), kpi.std(x), rel_tol=1e-12)
    assert mom.max() == kpi.maximum(x)
    assert math.isclose(
        rev.damage_equivalent_load(4.0, 1.0),
        kpi.damage_equivalent_load(x, t, 4.0, 1.0),
        rel_tol=1e-12,
    )
    assert math.isclose(trav.per_second(), kpi.pitch_travel_deg_s(t, x), rel_tol=1e-12)
    d = np.round(rng.normal(size=101), 1)
    assert rs.median_of_counts(Counter(d.tolist())) == float(np.median(d))
    assert rs.median_of_counts(Counter(d[:100].tolist())) == float(np.median(d[:100]))


@pytest.mark.parametrize("seed", [0, 1])
def test_blocked_sums_do_not_depend_on_the_pieces(seed: int) -> None:
    """The estimator's error sums: the same bits however the series is cut (a file's
    chunks differ between a lock-step and an in-process run of the same cycles)."""
    rng = np.random.default_rng(seed)
    e, u = rng.normal(size=20_000), 8.0 + rng.normal(size=20_000)
    totals = []
    for cuts in (7, 31, 0):
        sums = rs.Sums(3)
        edges = [0, *np.sort(rng.choice(np.arange(1, e.size), cuts, replace=False)), e.size]
        for a, b in itertools.pairwise(edges):
            sums.add(e[a:b], u[a:b], e[a:b] ** 2)
        totals.append(sums.totals())
    assert totals[0] == totals[1] == totals[2]
    n, (se, su, see) = totals[0]
    assert n == e.size
    assert math.isclose(se, float(np.sum(e)), rel_tol=1e-12, abs_tol=1e-9)
    assert math.isclose(su, float(np.sum(u)), rel_tol=1e-12)
    assert math.isclose(see, float(np.sum(e * e)), rel_tol=1e-12)


def test_reversals_of_short_series_follow_rainflow() -> None:
    """Two samples: rainflow counts no cycle (only the first point is a reversal)."""
    for x in ([1.0, 2.0], [1.0, 2.0, 2.0, 2.0], [1.0, 1.0, 2.0, 1.0], [5.0, 5.0, 5.0]):
        rev = rs.Reversals()
        a = np.array(x)
        rev.add(a, np.arange(a.size, dtype=float))
        want = kpi.damage_equivalent_load(a, np.arange(a.size), 4.0, 1.0)
        got = rev.damage_equivalent_load(4.0, 1.0)
        assert got == want or (math.isnan(got) and math.isnan(want)), x


def _write(path: Path, encoding: str, n: int) -> None:
    """A log of ``n`` PlantState messages on the truth channel in the given encoding."""
    mt = next(m for m in MESSAGES if m.key_suffix == "truth")
    rng = np.random.default_rng(3)
    rows = np.zeros(n, mt.row_dtype)
    rows["sample_time_ns"] = np.arange(n) * 25_000_000
    rows["seq"] = np.arange(n)
    rows["rotor_speed_rad_s"] = 0.6 + 0.01 * rng.normal(size=n)
    rows["floating"] = 1
    if encoding == "json":  # a log of the format before the CDR channels
        log = RunLog(path, None)
        cid = log.add_json_channel(mt.key("t1"), mt.name, mt.json_schema())
        for r in rows:
            msg = mt.cls(**{k: r[k].item() for k in mt.row_dtype.names or ()})
            log.write_json(cid, msgspec.json.encode(msg), int(r["sample_time_ns"]), 0)
    else:
        log = RunLog(path, "t1")
        log.write_rows(int(log.channel_of_message_id[mt.message_id]), rows, 0)
    log.close()


def test_json_columns_equal_the_dicts(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    _write(path, "json", 3000)
    reader = ColumnReader(path, {"truth": ("rotor_speed_rad_s", "floating", "absent_field")})
    got = [b for b in reader.batches() if b.suffix == "truth"]
    assert len(got) >= 3  # several chunks
    col = np.concatenate([b.columns["rotor_speed_rad_s"] for b in got])
    truth = read_run(path).topic("truth")
    assert col.tolist() == [m["rotor_speed_rad_s"] for m in truth]
    assert all(np.isnan(b.columns["absent_field"]).all() for b in got)
    assert got[-1].row(got[-1].size - 1) == truth[-1]
    assert reader.info.complete and reader.info.statistics_ok


@pytest.mark.parametrize("encoding", ["json", "cdr"])
def test_columns_of_a_written_file_equal_the_dicts(encoding: str, tmp_path: Path) -> None:
    """Both channel encodings, from files the run log wrote: the same columns as the dicts."""
    path = tmp_path / "run.mcap"
    _write(path, encoding, 3000)
    reader = ColumnReader(path, {"truth": ("rotor_speed_rad_s", "floating")})
    got = [b for b in reader.batches() if b.suffix == "truth"]
    col = np.concatenate([b.columns["rotor_speed_rad_s"] for b in got])
    truth = read_run(path).topic("truth")
    assert len(truth) == 3000
    assert col.tolist() == [m["rotor_speed_rad_s"] for m in truth]
    assert reader.info.complete


def test_cdr_payloads_decode_as_records() -> None:
    mt = next(m for m in MESSAGES if m.key_suffix == "truth")
    rows = np.zeros(4, mt.row_dtype)
    rows["sample_time_ns"] = [0, 25, 50, 75]
    rows["rotor_speed_rad_s"] = [0.5, 0.6, 0.7, 0.8]
    payloads = ros2.encode_rows(mt, rows)
    data = payloads.tobytes()
    assert data[:4] == ros2.CDR_HEADER
    back = ros2.decode(mt, data)
    assert back["rotor_speed_rad_s"].tolist() == [0.5, 0.6, 0.7, 0.8]
    assert back["sample_time_ns"].tolist() == [0, 25, 50, 75]
    with pytest.raises(ValueError, match="whole number"):
        ros2.decode(mt, data[:-1])


def _rainflow_damage(x: np.ndarray, m: float) -> float:
    """Σ count range^m of ``rainflow.extract_cycles`` over the whole series (the reference)."""
    import rainflow

    return sum(float(c) * float(r) ** m for r, _mean, c, _i0, _i1 in rainflow.extract_cycles(x))


@pytest.mark.parametrize("seed", range(6))
def test_streaming_rainflow_equals_the_rainflow_package(seed: int) -> None:
    """The streaming rainflow (a residue stack, damage sums per Wöhler exponent) against
    ``rainflow.extract_cycles`` over the whole series, fed in pieces cut anywhere (single
    samples, cuts on a reversal, on a plateau, at the last sample): 1e-12 relative."""
    rng = np.random.default_rng(seed)
    n = 3000
    kind = seed % 3
    if kind == 0:  # random walk: many reversals, a residue that grows and shrinks
        x = np.cumsum(rng.normal(size=n))
    elif kind == 1:  # white noise rounded: plateaus and equal neighbours
        x = np.round(rng.normal(size=n), 1)
    else:  # a drifting sine with noise (a load signal)
        t = np.arange(n) * 0.025
        x = 1e6 * np.sin(2 * math.pi * t / 7.0) + 2e4 * t + 1e4 * rng.normal(size=n)
    x[200:260] = x[200]
    x[-5:] = x[-5]  # a plateau at the end: the last sample is still the last reversal
    ms = (3.0, 4.0, 10.0)
    t = np.arange(n) * 0.025
    for cuts in (
        [1, 2, 3, *np.sort(rng.choice(np.arange(4, n), 40, replace=False)).tolist()],
        [n - 1],
        list(range(1, n)),  # one sample at a time
    ):
        rev = rs.Reversals(ms)
        for a, b in itertools.pairwise([0, *cuts, n]):
            rev.add(x[a:b], t[a:b])
        got = rev.damages()
        assert rev.damages() == got  # the state is kept: asking twice changes nothing
        for m, d in zip(ms, got, strict=True):
            assert math.isclose(d, _rainflow_damage(x, m), rel_tol=1e-12), (m, cuts[:3])
        assert math.isclose(
            rev.damage_equivalent_load(4.0, 1.0),
            kpi.damage_equivalent_load(x, t, 4.0, 1.0),
            rel_tol=1e-12,
        )
    # what is kept does not grow with the series: the residue of a stationary signal
    assert len(rev._stack) < 40, len(rev._stack)


def test_streaming_rainflow_refuses_an_exponent_not_kept() -> None:
    rev = rs.Reversals((4.0,))
    rev.add(np.array([0.0, 1.0, 0.0]), np.arange(3.0))
    with pytest.raises(ValueError, match="Wöhler exponent 10"):
        rev.damage_equivalent_load(10.0, 1.0)
