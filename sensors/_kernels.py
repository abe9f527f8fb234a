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
* ``spec_f`` (n, 6): σ, b, r, p, y_min, y_max;  ``spec_i`` (n, 2): d (ns), T (ns).
* ``st`` (n, 10) int64: last call time (ns), has a last call, last sample index k, has a
  sample, ring head, ring count, next normal, next uniform, samples taken, samples lost.
* ``held`` (n,) float64 value and ``held_ok`` (n,) bool flag of the last sample.
* ``hist_t`` (n, cap) int64 and ``hist_v`` (n, cap) float64: the ring buffers.
"""

from __future__ import annotations

import math

import numba
import numpy as np

LAST_T, HAS_LAST, SAMPLE_K, HAS_SAMPLE, HEAD, COUNT, NORMAL_I, UNIFORM_I, SAMPLES, DROPPED = range(
    10
)

#: Return codes of :func:`suite_step` besides 0 (done) and 1 (done, a block to refill):
#: -1 - c: channel c's time does not increase; -1 - n - c: channel c's ring buffer is full.


@numba.njit(cache=True)
def suite_step(
    idx: np.ndarray,
    t_ns: int,
    truths: np.ndarray,
    spec_f: np.ndarray,
    spec_i: np.ndarray,
    st: np.ndarray,
    held: np.ndarray,
    held_ok: np.ndarray,
    hist_t: np.ndarray,
    hist_v: np.ndarray,
    normals: np.ndarray,
    uniforms: np.ndarray,
    out_v: np.ndarray,
    out_ok: np.ndarray,
) -> int:
    """Measure the channels ``idx`` at ``t_ns`` (true values ``truths[c]``) into out_v/out_ok.

    Checks every channel first and changes nothing when one fails (return code < 0).
    """
    n = spec_f.shape[0]
    cap = hist_t.shape[1]
    block = normals.shape[1]
    for c in idx:
        if st[c, HAS_LAST] and t_ns <= st[c, LAST_T]:
            return -1 - c
        if (spec_i[c, 0] or spec_i[c, 1]) and st[c, COUNT] >= cap:
            return -1 - n - c
    refill = 0
    for c in idx:
        st[c, LAST_T] = t_ns
        st[c, HAS_LAST] = 1
        delay = spec_i[c, 0]
        period = spec_i[c, 1]
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
                out_v[c] = held[c]
                out_ok[c] = held_ok[c]
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
            x = true_value
        y = x + spec_f[c, 1]
        std = spec_f[c, 0]
        if std > 0.0:
            i = st[c, NORMAL_I]
            y += std * normals[c, i]
            st[c, NORMAL_I] = i + 1
            if i + 1 >= block:
                refill = 1
        if y < spec_f[c, 4]:
            y = spec_f[c, 4]
        elif y > spec_f[c, 5]:
            y = spec_f[c, 5]
        valid = math.isfinite(y)
        r = spec_f[c, 2]
        if valid and r > 0.0:
            y = r * np.rint(y / r)
        p = spec_f[c, 3]
        if p > 0.0:
            j = st[c, UNIFORM_I]
            st[c, UNIFORM_I] = j + 1
            if j + 1 >= block:
                refill = 1
            if uniforms[c, j] < p:
                valid = False
                st[c, DROPPED] += 1
        if not valid:
            y = math.nan
        st[c, SAMPLES] += 1
        held[c] = y
        held_ok[c] = valid
        out_v[c] = y
        out_ok[c] = valid
    return refill
