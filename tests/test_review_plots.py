"""The plots' one-pass accumulators (hil.review.plots) against whole-record answers.

Spans and Welch's estimate must not depend on how the record is cut into batches (a file's
chunks), and a run longer than MAX_POINTS is drawn from buckets whose min/max cover every
sample. Seeded random records; tolerances stated per check.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import welch

from hil.review.plots import MAX_POINTS, Envelope, Spans, StreamingWelch, psd_segment


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
    short = Envelope(24_000)
    x = rng.standard_normal(24_000)
    for a in range(0, 24_000, 4096):
        short.add({"t": np.arange(a, min(a + 4096, 24_000)) * 1.0, "x": x[a : a + 4096]})
    assert short.bucket == 1
    np.testing.assert_array_equal(short.get("x"), x)
    n = 24 * 3600 * 40  # a day at 40 Hz
    long = Envelope(n)
    assert long.bucket == -(-n // (MAX_POINTS // 2))
    y = rng.standard_normal(200_000)
    y[123_457] = 50.0  # a spike every-B-th sampling would miss
    for a in range(0, y.size, 4096):
        long.add({"t": np.arange(a, min(a + 4096, y.size)) * 1.0, "x": y[a : a + 4096]})
    drawn, t = long.get("x"), long.get("t")
    assert drawn.size == t.size == 2 * -(-y.size // long.bucket)
    assert drawn.max() == 50.0 and drawn.min() == y.min()
    assert np.all(np.diff(t) >= 0)
