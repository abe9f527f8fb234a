"""Wall-clock pacing and latency histograms for the node loops.

Pacing: ``time.sleep`` to an absolute deadline wakes 100-200 us late at p99 on this kind of
machine (DESIGN.md); sleeping to ``spin_s`` before the deadline and busy-waiting the rest
gives p99 below 1 us. :class:`Pacer` does exactly that on ``time.monotonic_ns``.

Histogram: fixed log-spaced bins (about 2 % wide, 1 us to 100 s) so recording one latency
is O(1) without allocation inside the control cycle; percentiles are read from the
cumulative counts (accurate to a bin width) and the exact maximum is kept beside them.
Hand-written because no maintained library offers an allocation-free HDR-style histogram
for CPython; ``numpy.percentile`` on the raw samples is used offline by the review instead.
"""

from __future__ import annotations

import math
import time
from bisect import bisect_left
from itertools import accumulate

_BINS_PER_DECADE = 120
_MIN_NS = 1_000  # 1 us
_DECADES = 8  # up to 100 s
_N_BINS = _BINS_PER_DECADE * _DECADES + 2  # below 1 us, the log bins, the top (overflow) bin
#: The bins' layout, for a compiled twin of :meth:`LatencyHistogram.record`.
BINS_PER_DECADE, MIN_NS, N_BINS = _BINS_PER_DECADE, _MIN_NS, _N_BINS
_log10 = math.log10


class LatencyHistogram:
    """Log-binned latency histogram in nanoseconds."""

    def __init__(self) -> None:
        self.counts = [0] * _N_BINS
        self.n = 0
        self.max_ns = 0
        # The lowest and highest bins holding a sample: the percentiles accumulate only
        # between them (a run's latencies fill a few dozen of the 962 bins).
        self._lo = _N_BINS
        self._hi = -1

    def record(self, latency_ns: int) -> None:
        """Add one latency sample."""
        counts = self.counts
        if latency_ns < _MIN_NS:
            idx = 0
        else:
            idx = 1 + int(_BINS_PER_DECADE * _log10(latency_ns / _MIN_NS))
            if idx >= _N_BINS:
                idx = _N_BINS - 1
        counts[idx] += 1
        self.n += 1
        if idx > self._hi:  # noqa: PLR1730
            self._hi = idx
        if idx < self._lo:  # noqa: PLR1730
            self._lo = idx
        if latency_ns > self.max_ns:  # noqa: PLR1730 - (max() is a call per cycle)
            self.max_ns = latency_ns

    def bins(self) -> tuple[list[int], int, int, int, int]:
        """(counts, samples, maximum ns, lowest and highest occupied bin: N_BINS and -1
        when empty): everything :meth:`record` changes, for a compiled twin of it."""
        return self.counts, self.n, self.max_ns, self._lo, self._hi

    def set_bins(self, counts: list[int], n: int, max_ns: int, lo: int, hi: int) -> None:
        """Take the state of :meth:`bins` back (after a compiled twin recorded into it)."""
        if len(counts) != _N_BINS:
            raise ValueError(f"expected {_N_BINS} bins, got {len(counts)}")
        self.counts = counts
        self.n, self.max_ns, self._lo, self._hi = n, max_ns, lo, hi

    def observe_max(self, latency_ns: int) -> None:
        """Raise the exact maximum to ``latency_ns`` without adding a sample to the bins.

        For a latency that belongs to no counted cycle: a command that came after the tick
        that ended its cycle (that cycle was already counted as unanswered). The bins stay
        the cycles' latencies; the maximum is the largest latency the plant saw at all.
        """
        if latency_ns > self.max_ns:  # noqa: PLR1730
            self.max_ns = latency_ns

    def percentile_us(self, q: float) -> float:
        """Upper edge of the bin holding the ``q``-th percentile (0 < q <= 100), in us."""
        return self.percentiles_us(q)[0]

    def percentiles_us(self, *qs: float) -> list[float]:
        """:meth:`percentile_us` of each of ``qs`` from one pass over the bins.

        The bin of q is the first whose cumulative count reaches q/100 * n: a bisection of
        the running sums, which ``itertools.accumulate`` forms in C (the running summary
        reads three percentiles every simulated second).
        """
        if self.n == 0:
            return [0.0] * len(qs)
        # The bins outside [lo, hi] are empty: below lo the running sum is 0 (< any target
        # > 0), from hi on it is n, so the bisection over [lo, hi] finds the same bin.
        lo, hi = self._lo, self._hi
        cumulative = list(accumulate(self.counts[lo : hi + 1]))
        out = []
        for q in qs:
            # target > 0, so the first bin reaching it holds a sample (the bin before it
            # did not reach it, so this bin's count is > 0).
            target = q / 100.0 * self.n
            found = bisect_left(cumulative, target)
            idx = 0 if target <= 0 else lo + found
            if found >= len(cumulative):
                out.append(self.max_ns / 1e3)
            elif idx == 0:
                out.append(_MIN_NS / 1e3)
            else:
                out.append(min(_MIN_NS * 10 ** (idx / _BINS_PER_DECADE), self.max_ns) / 1e3)
        return out


class Pacer:
    """Sleeps to absolute deadlines on ``time.monotonic_ns``, spinning the last part.

    Parameters
    ----------
    period_ns : int
        Wall-clock period between ticks.
    spin_ns : int
        How long before each deadline to stop sleeping and busy-wait.
    """

    def __init__(self, period_ns: int, spin_ns: int = 500_000) -> None:
        if period_ns <= 0:
            raise ValueError(f"period_ns must be > 0, got {period_ns}")
        self.period_ns = period_ns
        self.spin_ns = spin_ns
        self.start_ns = time.monotonic_ns()
        self.k = 0

    def deadline_ns(self, k: int) -> int:
        """Absolute monotonic time of tick ``k``."""
        return self.start_ns + k * self.period_ns

    def wait_tick(self) -> int:
        """Wait for the next tick; return how late it was taken, in ns (>= 0)."""
        self.k += 1
        target = self.deadline_ns(self.k)
        wait_until(target, self.spin_ns)
        return max(0, time.monotonic_ns() - target)


def wait_until(target_ns: int, spin_ns: int = 500_000) -> None:
    """Sleep until ``spin_ns`` before ``target_ns`` (monotonic), then busy-wait to it."""
    now = time.monotonic_ns()
    remaining = target_ns - now - spin_ns
    if remaining > 0:
        time.sleep(remaining / 1e9)
    while time.monotonic_ns() < target_ns:
        pass
