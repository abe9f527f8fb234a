"""Compiled step of a whole sensor suite (numba, cached on disk).

Why hand-written: :class:`sensors.channel.SensorSuite` steps about ten channels per control
cycle; each :func:`sensors.channel.channel_step` is a few dozen Python operations (~2 µs), so
the suite cost ~25 µs per frame. No library implements this channel model (transport delay
interpolated between calls, sample-and-hold on the sensor's own clock, saturation,
quantization, dropout with seeded per-channel streams), so the same equations run here over
all channels in one call, on arrays:

    v_k = x(t_k − d) + b + σ n_k,   s_k = min(max(v_k, y_min), y_max),   y_k = r round(s_k / r),

x(t_k − d) linear between the two calls that bracket it (the history is a ring buffer per
channel), the sample lost when u_k < p. ``round`` is round-half-to-even (``np.rint``), as
Python's. The random numbers are drawn by the channels' numpy Generators in blocks
(``BLOCK_SIZE``) outside the kernel; the kernel reports when a block is used up, and the
caller refills it before the next call, so every channel consumes its streams exactly as
:func:`sensors.channel.channel_step` does (tests/test_sensor_channels.py compares the two
bit for bit).

Layouts (rows are channels)
---------------------------
* ``f`` (n, 8) float64: σ, b, r, p, y_min, y_max, held value, reading.
* ``i`` (n, 12) int64: d (ns), T (ns), last call time (ns), has a last call, last sample
  index k, has a sample, ring head, ring count, next normal, next uniform, samples taken,
  samples lost.
* ``ok`` (n, 2) bool: held flag, reading flag.
* ``hist_t`` (n, cap) int64 and ``hist_v`` (n, cap) float64: the ring buffers.
* ``rn`` (n, 2, BLOCK) float64: the current blocks of N(0, 1) and U[0, 1) draws.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from bus_schemas.jit import njit

DELAY, PERIOD, LAST_T, HAS_LAST, SAMPLE_K, HAS_SAMPLE, HEAD, COUNT = range(8)
NORMAL_I, UNIFORM_I, SAMPLES, DROPPED = range(8, 12)
STD, BIAS, RES, P_DROP, Y_MIN, Y_MAX, HELD, READING = range(8)


class SuiteBundle(NamedTuple):
    """A channel suite's arrays (layouts above): its storage, one kernel argument.

    :class:`sensors.channel.SensorSuite` keeps its state here (``state_bundle``), and
    :func:`suite_step` reads and writes it in place; ``slots`` and ``record`` are where
    the readings are scattered (``SensorSuite.bind_record``).
    """

    f: np.ndarray
    st: np.ndarray
    ok: np.ndarray
    hist_t: np.ndarray
    hist_v: np.ndarray
    rn: np.ndarray
    slots: np.ndarray
    record: np.ndarray


#: Return codes of :func:`suite_step` besides 0 (done) and 1 (done, a block to refill):
#: -1 - c: channel c's time does not increase; -1 - n - c: channel c's ring buffer is full.


@njit
def suite_step(
    which: int,
    t_ns: int,
    truths: tuple[float, ...],
    f: np.ndarray,
    st: np.ndarray,
    ok: np.ndarray,
    hist_t: np.ndarray,
    hist_v: np.ndarray,
    rn: np.ndarray,
    slots: np.ndarray,
    record: np.ndarray,
) -> tuple[int, int]:
    """Measure channel ``which`` (-1: every channel) at ``t_ns``, true values ``truths[c]``.

    The readings go to f[:, READING] and ok[:, 1], and are scattered into ``record``: with
    ``slots`` (n, 2) = (index in ``record``, or -1 or beyond it: none; bit), record = 0
    except the valid
    readings at their index, and the returned mask the OR of their bits. Returns (code,
    mask); checks the channels first and changes nothing when one fails (code < 0).
    """
    n = f.shape[0]
    cap = hist_t.shape[1]
    block = rn.shape[2]
    lo = 0 if which < 0 else which
    hi = n if which < 0 else which + 1
    for c in range(lo, hi):
        if st[c, HAS_LAST] and t_ns <= st[c, LAST_T]:
            return -1 - c, 0
        if (st[c, DELAY] or st[c, PERIOD]) and st[c, COUNT] >= cap:
            return -1 - n - c, 0
    refill = 0
    for c in range(lo, hi):
        st[c, LAST_T] = t_ns
        st[c, HAS_LAST] = 1
        delay = st[c, DELAY]
        period = st[c, PERIOD]
        buffered = delay != 0 or period != 0
        true_value = truths[c]
        if buffered:
            pos = (st[c, HEAD] + st[c, COUNT]) % cap
            hist_t[c, pos] = t_ns
            hist_v[c, pos] = true_value
            st[c, COUNT] += 1
        if period:
            k = t_ns // period
            if st[c, HAS_SAMPLE] and k == st[c, SAMPLE_K]:
                f[c, READING] = f[c, HELD]
                ok[c, 1] = ok[c, 0]
                continue
            st[c, SAMPLE_K] = k
            st[c, HAS_SAMPLE] = 1
            t_sample = k * period
        else:
            t_sample = t_ns
        if buffered:
            tau = t_sample - delay
            head = st[c, HEAD]
            count = st[c, COUNT]
            while count > 1 and hist_t[c, (head + 1) % cap] <= tau:
                head = (head + 1) % cap
                count -= 1
            st[c, HEAD] = head
            st[c, COUNT] = count
            t0 = hist_t[c, head]
            x0 = hist_v[c, head]
            if tau <= t0:
                x = x0
            else:
                nxt = (head + 1) % cap
                x = x0 + (hist_v[c, nxt] - x0) * ((tau - t0) / (hist_t[c, nxt] - t0))
        else:
            x = float(true_value)
        y = x + f[c, BIAS]
        std = f[c, STD]
        if std > 0.0:
            i = st[c, NORMAL_I]
            y += std * rn[c, 0, i]
            st[c, NORMAL_I] = i + 1
            if i + 1 >= block:
                refill = 1
        if y < f[c, Y_MIN]:
            y = f[c, Y_MIN]
        elif y > f[c, Y_MAX]:
            y = f[c, Y_MAX]
        valid = math.isfinite(y)
        r = f[c, RES]
        if valid and r > 0.0:
            y = r * np.rint(y / r)
        p = f[c, P_DROP]
        if p > 0.0:
            j = st[c, UNIFORM_I]
            st[c, UNIFORM_I] = j + 1
            if j + 1 >= block:
                refill = 1
            if rn[c, 1, j] < p:
                valid = False
                st[c, DROPPED] += 1
        if not valid:
            y = math.nan
        st[c, SAMPLES] += 1
        f[c, HELD] = y
        ok[c, 0] = valid
        f[c, READING] = y
        ok[c, 1] = valid
    mask = 0
    if record.size:
        record[:] = 0.0
        for c in range(lo, hi):
            k = slots[c, 0]
            if 0 <= k < record.size and ok[c, 1]:
                record[k] = f[c, READING]
                mask |= slots[c, 1]
    return refill, mask
