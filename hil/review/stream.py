"""Running statistics of a run's review, fed one batch of columns at a time.

:func:`hil.review.core.summarize` gets its numbers from here. The batches come from
:class:`hil.runlog.columns.ColumnReader` (a file, chunk by chunk) or from
:func:`hil.runlog.columns.run_batches` (a run in memory); what is kept does not grow with
the run's length, except the one thing that must see every sample to stay exact: the
latency of every logged cycle and the compute time of every controller status, for their
percentiles (exact, numpy's ``linear`` method: one float64 each per cycle in numpy blocks,
:class:`Store`; 0.2 MB for 600 s at 40 Hz, 28 MB each for 24 h). The rainflow counting of
the three DEL series is streamed (:class:`Reversals`: the reversal points found as the
samples come, each counted at once on a residue stack, the damage summed per Wöhler
exponent), with the cycles, their order and the DEL of the whole series.

Means, standard deviations and maxima are accumulated per batch (sums, and Chan's
pairwise update of the centred second moment), so they agree with numpy's over the
whole series to rounding (relative ~1e-15). The KPI window starts at t_0 = min(T_s,
t_end / 2) (:func:`hil.review.core.kpi_window`), which is known only at the end of a short run:
the windowed batches are held until a truth sample at t >= 2 T_s settles t_0 = T_s (the
first 2 T_s of the run, 120 s by default) or the run ends. The controller's estimates are
compared with the truth interpolated to their sample times; status rows wait until the
truth has passed the time they need (their own, and the time a wave forecast is for),
and only the truth from the oldest waiting row on is kept. This assumes the truth's sample
times increase through the file, as every writer of this bench writes them.
"""

from __future__ import annotations

import abc
import itertools
import math
from collections import Counter
from typing import Any

import numpy as np

from bus_schemas.messages import (
    EST_WAVE_FORECAST,
)
from hil.review.kpi import DEL_WOHLER_M

NAN = math.nan

#: Fields read per topic suffix (``sample_time_ns`` is read for every topic).
FIELDS: dict[str, tuple[str, ...]] = {
    "truth": (
        "rotor_speed_rad_s",
        "platform_pitch_rad",
        "platform_surge_m",
        "electrical_power_w",
        "blade_pitch_rad",
        "generator_torque_nm",
        "rotor_thrust_n",
        "shaft_torque_nm",
        "tower_base_moment_nm",
        "floating",
        "wind_speed_m_s",
        "platform_pitch_rate_rad_s",
        "platform_surge_velocity_m_s",
        "wave_elevation_platform_m",
        "tip_speed_ratio",  # with blade_pitch_rad: the Cp/Ct table look-up (table_range.py)
        "relative_wind_speed_m_s",
    ),
    "sensors": ("platform_pitch_measured_rad",),
    "controller/status": (
        "compute_time_ns",
        "rejected_frames",
        "estimates_valid_mask",
        "estimator_degraded",
        "wind_speed_estimated_m_s",
        "platform_pitch_rate_estimated_rad_s",
        "platform_surge_velocity_estimated_m_s",
        "wave_forecast_time_ns",
        "wave_elevation_forecast_m",
        "forecast_unstable_fits",
        "forecast_guarded",
        "estimator_faults",
    ),
    "timing/cycle": (
        "publish_time_ns",
        "latency_ns",
        "deadline_missed",
        "command_held",
        "safe_state",
    ),
    "timing/summary": ("final",),
    "command": ("mode",),
}
#: Topics whose messages are kept whole (one or a few per run).
ROW_TOPICS = ("timing/report", "controller/report")


#: Samples per block of the running sums. A series is summed in blocks of this many samples
#: counted from its first sample, whatever the chunks of the file that hold it: the same
#: samples give the same floating-point figures bit for bit, whether a recorder or the
#: in-process writer cut them into chunks (lock-step and in-process runs compare equal).
BLOCK = 4096
#: Samples per numpy block of a :class:`Store` (8 MB).
STORE_BLOCK = 1 << 20


class _Blocked(abc.ABC):
    """Samples fed in pieces, handed on in blocks of :data:`BLOCK` (the last one shorter)."""

    def __init__(self) -> None:
        self._pending: list[np.ndarray] = []
        self._npend = 0

    def _feed(self, *cols: np.ndarray) -> None:
        if not cols[0].size:
            return
        self._pending.append(np.stack([np.asarray(c, np.float64) for c in cols]))
        self._npend += cols[0].size
        if self._npend >= BLOCK:
            buf = np.concatenate(self._pending, axis=1)
            whole = (buf.shape[1] // BLOCK) * BLOCK
            for i in range(0, whole, BLOCK):
                self._block(*buf[:, i : i + BLOCK])
            rest = buf[:, whole:]
            self._pending = [rest] if rest.shape[1] else []
            self._npend = rest.shape[1]

    def _settle(self) -> None:
        """Hand on what is pending (the series' last, shorter block)."""
        if self._npend:
            buf = np.concatenate(self._pending, axis=1)
            self._pending, self._npend = [], 0
            self._block(*buf)

    @abc.abstractmethod
    def _block(self, *cols: np.ndarray) -> None:
        """Take one block of the series (its columns, in the order fed)."""


class Sums(_Blocked):
    """Count and column sums of samples fed in pieces, summed per block (:data:`BLOCK`), so
    the totals do not depend on how the pieces were cut (a file's chunks)."""

    def __init__(self, columns: int) -> None:
        super().__init__()
        self.n = 0
        self._totals = [0.0] * columns

    def add(self, *cols: np.ndarray) -> None:
        self._feed(*cols)

    def _block(self, *cols: np.ndarray) -> None:
        self.n += cols[0].size
        for i, c in enumerate(cols):
            self._totals[i] += float(np.sum(c))

    def totals(self) -> tuple[int, list[float]]:
        """(count, the sum of each column)."""
        self._settle()
        return self.n, list(self._totals)


class Moments(_Blocked):
    """Count, mean, population variance and maximum of a series fed in pieces.

    The mean is the sum over the count; the centred second moment M2 = Σ (x - x̄)² is
    combined per block (:data:`BLOCK`) as Chan et al. do: M2 = M2_a + M2_b + δ² n_a n_b /
    (n_a + n_b), δ = x̄_b - x̄_a. A nan anywhere makes every figure nan (as numpy's).
    """

    def __init__(self) -> None:
        super().__init__()
        self.n = 0
        self.total = 0.0
        self.m2 = 0.0
        self.peak = -math.inf

    def add(self, x: np.ndarray) -> None:
        self._feed(x)

    def _block(self, *cols: np.ndarray) -> None:
        x = cols[0]
        k = x.size
        s = float(np.sum(x))
        mb = s / k
        m2b = float(np.sum((x - mb) ** 2))
        if self.n:
            ma = self.total / self.n
            d = mb - ma
            self.m2 += m2b + d * d * self.n * k / (self.n + k)
        else:
            self.m2 = m2b
        self.n += k
        self.total += s
        self.peak = float(np.maximum(self.peak, np.max(x)))

    def mean(self) -> float:
        self._settle()
        return self.total / self.n if self.n else NAN

    def var(self) -> float:
        """Population variance M2 / n."""
        self._settle()
        return self.m2 / self.n if self.n else NAN

    def std(self) -> float:
        return math.sqrt(self.var()) if self.n or self._npend else NAN

    def max(self) -> float:
        self._settle()
        return self.peak if self.n else NAN


class Reversals:
    """Rainflow counting (``rainflow.extract_cycles``, ASTM E1049) of a series fed in pieces,
    in memory that does not grow with the series.

    The reversal points are found as the samples come, as ``rainflow.reversals`` does: the
    first sample, every sample after which the slope changes sign (equal neighbours skipped,
    the product of the slopes < 0), and the last sample when there are three or more. Each
    point goes at once through the three-point counting of ``rainflow.extract_cycles`` on a
    stack of the points not yet closed into a cycle (the residue): a range Y closed by a
    range X >= Y is a full cycle (count 1), or a half cycle (count 0.5) when Y holds the
    stack's first point. Each cycle adds count * range^m to a sum per Wöhler exponent m of
    ``wohler_m``, in the order ``extract_cycles`` yields them, so the sums are those of the
    whole series bit for bit. At the end the last sample closes the reversals and the
    residue is counted as half cycles (:meth:`damages`; the state is left as it was, so the
    series may go on). The residue holds a sequence of ranges that only grow, so it stays
    small for a load signal (its length is the number of ever-larger ranges seen).
    Also the series' first and last time [s] and whether every sample was finite, for
    :func:`hil.review.kpi.damage_equivalent_load`.

    Parameters
    ----------
    wohler_m : tuple of float
        The Wöhler exponents m [-] the damage sums are kept for.
    """

    def __init__(self, wohler_m: tuple[float, ...] = (DEL_WOHLER_M,)) -> None:
        self.wohler_m = tuple(float(m) for m in wohler_m)
        self.n = 0
        self.finite = True
        self.t_first = NAN
        self.t_last = NAN
        self.reversals = 0  # reversal points found (the last sample not counted)
        self._stack: list[float] = []  # the residue
        self._damage = [0.0] * len(self.wohler_m)  # Σ count range^m per exponent
        self._first = 0.0  # the first sample
        self._x = 0.0  # the last distinct value after the first sample
        self._d = 0.0  # the last slope
        self._end = 0.0

    def add(self, x: np.ndarray, t: np.ndarray) -> None:
        if not x.size:
            return
        if self.n == 0:
            self.t_first = float(t[0])
        self.t_last = float(t[-1])
        self.finite = self.finite and bool(np.isfinite(x).all())
        self._end = float(x[-1])
        if self.n == 0:
            self._point(float(x[0]))
            self.n = 1
            x = x[1:]
            if not x.size:
                return
        if self.n == 1:
            self._x = float(x[0])
            self._d = self._x - self._first
            self.n = 2
            x = x[1:]
            if not x.size:
                return
        self.n += x.size
        ys = np.concatenate(([self._x], x))
        ys = ys[np.concatenate(([True], ys[1:] != ys[:-1]))]
        if ys.size < 2:
            return
        d = np.concatenate(([self._d], np.diff(ys)))
        turn = d[:-1] * d[1:] < 0
        for p in ys[:-1][turn].tolist():
            self._point(p)
        self._x = float(ys[-1])
        self._d = float(d[-1])

    def _point(self, p: float) -> None:
        """Count what reversal point ``p`` closes (``extract_cycles``' loop body)."""
        if self.reversals == 0:
            self._first = p
        self.reversals += 1
        self._count(self._stack, self._damage, p)

    def _count(self, pts: list[float], damage: list[float], p: float) -> None:
        pts.append(p)
        ms = self.wohler_m
        while len(pts) >= 3:
            x1, x2, x3 = pts[-3], pts[-2], pts[-1]
            if abs(x3 - x2) < abs(x2 - x1):
                break
            if len(pts) == 3:  # Y holds the first point: a half cycle, the point dropped
                r = abs(pts[0] - pts[1])
                for i, m in enumerate(ms):
                    damage[i] += 0.5 * r**m
                del pts[0]
            else:  # a full cycle: its peak and valley dropped
                r = abs(x1 - x2)
                for i, m in enumerate(ms):
                    damage[i] += 1.0 * r**m
                del pts[-3:-1]

    def damages(self) -> list[float]:
        """Σ count range^m of the whole series fed so far, per exponent of ``wohler_m``
        (the last sample and the residue's half cycles included; the state kept)."""
        pts, damage = list(self._stack), list(self._damage)
        if self.n >= 3:  # rainflow.reversals yields the last sample of three or more
            self._count(pts, damage, self._end)
        for a, b in itertools.pairwise(pts):
            r = abs(a - b)
            for i, m in enumerate(self.wohler_m):
                damage[i] += 0.5 * r**m
        return damage

    def damage_equivalent_load(self, wohler_m: float, n_eq_hz: float) -> float:
        """:func:`hil.review.kpi.damage_equivalent_load` of the series fed (same cycles, same
        order); ``wohler_m`` must be one of the exponents given at construction."""
        if float(wohler_m) not in self.wohler_m:
            raise ValueError(
                f"Wöhler exponent {wohler_m} not kept: expected one of {self.wohler_m}"
            )
        if self.n < 2 or not self.finite:
            return NAN
        duration = self.t_last - self.t_first
        if not duration > 0.0 or not n_eq_hz > 0.0 or not wohler_m > 0.0:
            return NAN
        damage = self.damages()[self.wohler_m.index(float(wohler_m))]
        return float((damage / (n_eq_hz * duration)) ** (1.0 / wohler_m))


class Travel(_Blocked):
    """Σ |θ_{k+1} - θ_k| and the first and last time of a series fed in pieces (summed in
    blocks of :data:`BLOCK` samples, as :class:`Moments`)."""

    def __init__(self) -> None:
        super().__init__()
        self.n = 0
        self.total = 0.0
        self.t_first = NAN
        self.t_last = NAN
        self._last = NAN

    def add(self, x: np.ndarray, t: np.ndarray) -> None:
        self._feed(x, t)

    def _block(self, *cols: np.ndarray) -> None:
        x, t = cols
        if self.n:
            self.total += abs(float(x[0]) - self._last)
        else:
            self.t_first = float(t[0])
        self.total += float(np.sum(np.abs(np.diff(x))))
        self.n += x.size
        self._last = float(x[-1])
        self.t_last = float(t[-1])

    def per_second(self) -> float:
        """Mean |dθ/dt| [deg/s] (:func:`hil.review.kpi.pitch_travel_deg_s`)."""
        self._settle()
        if self.n < 2:
            return NAN
        duration = self.t_last - self.t_first
        if not duration > 0.0:
            return NAN
        return math.degrees(self.total) / duration


class Store:
    """A growing float64 column kept whole (exact percentiles need every sample).

    Held in numpy blocks of :data:`STORE_BLOCK` samples (8 bytes a sample, nothing per
    sample besides: 28 MB for a day at 40 Hz), joined into one array when asked for.
    """

    def __init__(self) -> None:
        self._blocks: list[np.ndarray] = []
        self._fill = 0  # samples in the last block

    def add(self, x: np.ndarray) -> None:
        x = np.asarray(x, np.float64).ravel()
        while x.size:
            if not self._blocks or self._fill == self._blocks[-1].size:
                self._blocks.append(np.empty(STORE_BLOCK))
                self._fill = 0
            last = self._blocks[-1]
            k = min(x.size, last.size - self._fill)
            last[self._fill : self._fill + k] = x[:k]
            self._fill += k
            x = x[k:]

    def __len__(self) -> int:
        if not self._blocks:
            return 0
        return sum(b.size for b in self._blocks[:-1]) + self._fill

    def array(self) -> np.ndarray:
        """Every sample in order (one array; the blocks are replaced by it)."""
        if not self._blocks:
            return np.empty(0)
        if len(self._blocks) > 1 or self._fill < self._blocks[0].size:
            blocks, self._blocks = self._blocks, []
            blocks[-1] = blocks[-1][: self._fill]
            whole = np.concatenate(blocks) if len(blocks) > 1 else blocks[0].copy()
            del blocks
            self._blocks, self._fill = [whole], whole.size
        return self._blocks[0]


def median_of_counts(counts: Counter[float]) -> float:
    """``np.median`` of the values counted in ``counts`` (nan when empty)."""
    n = sum(counts.values())
    if not n:
        return NAN
    want = (n - 1) // 2, n // 2
    got: list[float] = []
    seen = 0
    for v in sorted(counts):
        c = counts[v]
        for k in want[len(got) :]:
            if seen <= k < seen + c:
                got.append(v)
        seen += c
        if len(got) == 2:
            break
    return got[0] if want[0] == want[1] else (got[0] + got[1]) / 2.0


class Window:
    """The KPI window's start t_0 = min(T_s, t_end / 2), and the batches held until it is
    known (module docstring). ``sink(kind, columns)`` gets each batch cut to t >= t_0."""

    def __init__(self, settle_s: float, sink: Any) -> None:
        self.settle = settle_s
        self.sink = sink
        self.t0: float | None = None
        self.end = -math.inf
        self._held: list[tuple[str, dict[str, np.ndarray]]] = []

    def truth_times(self, t_s: np.ndarray) -> None:
        fin = t_s[np.isfinite(t_s)]
        if fin.size:
            self.end = max(self.end, float(fin.max()))
        if self.t0 is None and self.end >= 2.0 * self.settle:
            self._decide(self.settle)

    def feed(self, kind: str, cols: dict[str, np.ndarray]) -> None:
        if self.t0 is None:
            self._held.append((kind, cols))
        else:
            self._send(kind, cols)

    def _send(self, kind: str, cols: dict[str, np.ndarray]) -> None:
        assert self.t0 is not None
        keep = cols["t_ns"] >= self.t0 * 1e9
        if keep.all():
            self.sink(kind, cols)
        elif keep.any():
            self.sink(kind, {k: v[keep] for k, v in cols.items()})

    def _decide(self, t0: float) -> None:
        self.t0 = t0
        held, self._held = self._held, []
        for kind, cols in held:
            self._send(kind, cols)

    def finish(self) -> dict[str, Any]:
        """Settle t_0 (if not yet) and return :func:`hil.review.core.kpi_window`'s dict."""
        end = self.end if math.isfinite(self.end) else NAN
        start = min(self.settle, 0.5 * end) if math.isfinite(end) else self.settle
        if self.t0 is None:
            self._decide(start)
        return {
            "settle_s": self.settle,
            "from_s": start,
            "to_s": end,
            "shortened": bool(start < self.settle),
        }


#: Simulated time of truth the join keeps behind its last sample [s]: a status message
#: logged up to this much later than the truth of its cycle still finds it.
RETAIN_S = 30.0

_JOIN_TRUTH = (
    "wind_speed_m_s",
    "platform_pitch_rate_rad_s",
    "platform_surge_velocity_m_s",
    "wave_elevation_platform_m",
)


class TruthJoin:
    """Status rows with the truth interpolated to their sample time and forecast time.

    ``out(columns)`` gets the rows in order once the truth has reached the times they need;
    ``inside`` (the status time within the truth's first and last sample time) and
    ``f_ok`` (the forecast time so) say which interpolations hold (the others are nan).
    """

    def __init__(self, out: Any) -> None:
        self.out = out
        self.t_first = NAN
        self.t_last = NAN
        self.any_truth = False
        self._tt: list[np.ndarray] = []
        self._tv: list[dict[str, np.ndarray]] = []
        self._pending: list[dict[str, np.ndarray]] = []
        self._last_ts = NAN

    def add_truth(self, cols: dict[str, np.ndarray]) -> None:
        t = cols["sample_time_ns"]
        if not t.size:
            return
        if not self.any_truth:
            self.t_first = float(t[0])
            self.any_truth = True
        self.t_last = float(t[-1])
        self._tt.append(t)
        self._tv.append({k: cols[k] for k in _JOIN_TRUTH})
        self._resolve(final=False)
        if not self._pending:  # nothing waits: keep from the last status resolved on
            self._trim(self._floor())

    def add_status(self, cols: dict[str, np.ndarray]) -> None:
        self._pending.append(cols)
        self._resolve(final=False)

    def finish(self) -> None:
        self._resolve(final=True)

    def _resolve(self, final: bool) -> None:
        if not self._pending or (not final and not self.any_truth):
            return
        rows = _concat(self._pending)
        ts = rows["sample_time_ns"]
        mask = rows["estimates_valid_mask"]
        m = np.where(np.isfinite(mask), mask, 0).astype(np.int64)
        f_t = rows["wave_forecast_time_ns"]
        fbit = (m & EST_WAVE_FORECAST) != 0
        if final:
            k = ts.size
        else:
            need = np.fmax(ts, np.where(fbit, f_t, -math.inf))
            ready = need <= self.t_last
            k = ts.size if ready.all() else int(np.argmin(ready))
        if k == 0:
            return
        done = {n: v[:k] for n, v in rows.items()}
        rest = {n: v[k:] for n, v in rows.items()}
        self._pending = [rest] if rest["sample_time_ns"].size else []
        tt = np.concatenate(self._tt) if self._tt else np.empty(0)
        tv = _concat(self._tv) if self._tv else {n: np.empty(0) for n in _JOIN_TRUTH}
        ts, f_t, m = ts[:k], f_t[:k], m[:k]
        inside = (ts >= self.t_first) & (ts <= self.t_last) if self.any_truth else np.zeros(k, bool)
        f_ok = fbit[:k] & (f_t >= self.t_first) & (f_t <= self.t_last) if self.any_truth else inside
        done["inside"] = inside
        done["f_ok"] = f_ok
        done["t_ns"] = ts
        for name in _JOIN_TRUTH[:3]:
            col = np.full(k, NAN)
            if inside.any():
                col[inside] = np.interp(ts[inside], tt, tv[name])
            done["truth_" + name] = col
        eta = np.full(k, NAN)
        if f_ok.any():
            eta[f_ok] = np.interp(f_t[f_ok], tt, tv["wave_elevation_platform_m"])
        done["truth_eta_at_forecast"] = eta
        self.out(done)
        self._last_ts = float(ts[-1])
        self._trim(self._floor())

    def _floor(self) -> float:
        """The oldest truth time [ns] still needed: the oldest waiting status's (a forecast
        is for a time after its own), else the last resolved one's (statuses come in
        order), and at least the last :data:`RETAIN_S` (a status logged later than its
        truth)."""
        floor = self.t_last - RETAIN_S * 1e9
        if self._pending:
            return min(floor, float(np.nanmin(self._pending[0]["sample_time_ns"])))
        if math.isfinite(self._last_ts):
            return min(floor, self._last_ts)
        return floor

    def _trim(self, floor: float) -> None:
        """Drop the truth before the last sample at or before ``floor`` [ns]."""
        if not self._tt or not math.isfinite(floor):
            return
        tt = np.concatenate(self._tt) if len(self._tt) > 1 else self._tt[0]
        j = max(int(np.searchsorted(tt, floor, side="right")) - 1, 0)
        if j == 0 and len(self._tt) == 1:
            return
        tv = _concat(self._tv)
        self._tt = [tt[j:]]
        self._tv = [{n: v[j:] for n, v in tv.items()}]


def _concat(parts: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    if len(parts) == 1:
        return parts[0]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
