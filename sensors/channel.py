"""Sensor channel models: noise, bias, saturation, quantization, delay, sample-and-hold, dropout.

One channel turns the true value x(t) of a plant signal into what a controller sees. With
the sensor's own sample instants t_k = k T (T = ``sample_period_s``; T = 0: every call is a
sample instant, t_k = t), the transport delay d = ``delay_s``, bias b, noise std σ, range
[y_min, y_max] and quantization step r, sample k is

    v_k = x(t_k - d) + b + σ n_k,        n_k ~ N(0, 1) i.i.d.
    s_k = min(max(v_k, y_min), y_max)
    y_k = r round(s_k / r)               (r = 0: y_k = s_k)

and with probability p = ``dropout_probability`` (independently per sample) the sample is
lost: the channel reports ``(nan, False)`` instead of ``(y_k, True)``. Between sample
instants the channel holds its last sample, value *and* valid flag: a lost sample stays
reported as missing until the next sample instant, it is never replaced by the previous,
older value passed off as fresh. The quantity held is the whole sample (noise included),
as a real sample-and-hold does.

Time resolution
---------------
Times are integer nanoseconds. ``delay_s`` and ``sample_period_s`` are rounded to whole
nanoseconds once, in :class:`ChannelSpec`. The delay is *not* rounded to the caller's
step: the channel keeps the true values of its recent calls and interpolates linearly
between the two calls that bracket t_k - d, so a ramp comes out shifted by exactly
``delay_s`` whatever the (even irregular) calling step; a signal that curves between calls
gets the usual linear-interpolation error, (h^2 / 8) max|x''| for a calling step h. Before
the first call's time + d the channel reports the first true value it was given (the
plant starts from an operating point; there is no earlier history to delay). The
history is a deque trimmed at every sample; it holds about (d + T) / h + 2 entries.

A sample instant is noticed at the first call with t >= t_k; if the caller's step is longer
than T, several instants fall between two calls and only the latest one is sampled (and
draws noise and dropout), so a channel's random streams advance once per reported sample.

Randomness
----------
Each channel owns two numpy ``Generator`` s seeded from the scenario seed and the CRC-32
of the channel name (stable across processes, unlike ``hash``): the noise stream from
``[seed mod 2^32, crc]``, exactly as :mod:`sensors.models` seeds it (a noise-only channel
reproduces ``sensors.models.SensorSuite.measure`` bit for bit), and the dropout stream
from ``[seed mod 2^32, crc, 1]``. Adding or removing a channel never changes another
channel's series, and switching dropout on does not change the noise of the samples that
survive. Both are drawn in blocks of 4096 and handed out as Python floats (a per-sample
numpy scalar call costs about 1 us; a list index about 0.05 us).

Purity
------
Nothing here reads a clock, does I/O or keeps module state. :class:`ChannelState` is a
small mutable object owned by the caller: :func:`channel_step` updates it in place and
returns it, and is deterministic given (spec, state, t_ns, true_value) -- a
``copy.deepcopy`` of a state continues exactly as the original would.
"""

from __future__ import annotations

import math
import numbers
import zlib
from collections import deque
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from sensors import _kernels as _kern

__all__ = [
    "BLOCK_SIZE",
    "ChannelSpec",
    "ChannelState",
    "SensorSuite",
    "channel_init",
    "channel_step",
    "default_floating_suite",
]

#: Random numbers drawn per numpy call, per stream.
BLOCK_SIZE = 4096

_NAN = math.nan
_NO_SLOTS = np.zeros((0, 2), dtype=np.int64)
_NO_RECORD = np.zeros(0)
_isfinite = math.isfinite


def _number(name: str, field_name: str, value: object, expected: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(
            f"ChannelSpec {name!r}: {field_name} expected {expected}, "
            f"got {type(value).__name__} {value!r}"
        )
    return float(value)


@dataclass(frozen=True)
class ChannelSpec:
    """Error model of one sensor channel, validated on construction.

    ``std``, ``bias``, ``resolution``, ``range_min`` and ``range_max`` are in the channel's
    own unit (the unit of its true value, e.g. rad/s for a speed channel).

    Parameters
    ----------
    name : str
        Channel name; with the scenario seed it seeds the channel's random streams.
    std : float
        σ, standard deviation of the white Gaussian noise added to each sample, >= 0.
    bias : float
        b, constant offset added to each sample.
    resolution : float
        r, quantization step, >= 0 (0: no quantization). Output is r round(s / r), with
        Python's round-half-to-even.
    delay_s : float
        d (s), transport delay, >= 0; rounded to whole ns, interpolated between calls.
    sample_period_s : float
        T (s), the sensor's own sample period, >= 0 (0: sample at every call). Samples are
        taken at t_k = k T on the caller's time axis (t = 0 is a sample instant) and held
        in between.
    dropout_probability : float
        p, probability in [0, 1) that a sample is lost (reported as ``nan``, invalid).
    range_min, range_max : float
        Saturation limits applied before quantization (defaults -inf, +inf); a saturated
        reading is still valid. With r > 0 the output may exceed a limit that is not a
        multiple of r by up to r / 2.

    Attributes
    ----------
    delay_ns : int
        d rounded to whole nanoseconds (derived).
    sample_period_ns : int
        T rounded to whole nanoseconds (derived; 0: sample at every call).

    Raises
    ------
    ValueError
        Naming the field, what was expected and what was given.
    """

    name: str = ""
    std: float = 0.0
    bias: float = 0.0
    resolution: float = 0.0
    delay_s: float = 0.0
    sample_period_s: float = 0.0
    dropout_probability: float = 0.0
    range_min: float = -math.inf
    range_max: float = math.inf
    delay_ns: int = field(init=False, repr=False)
    sample_period_ns: int = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str):
            raise ValueError(f"ChannelSpec name expected a str, got {type(self.name).__name__}")
        n = self.name
        checks = {
            "std": "a finite standard deviation >= 0 in the channel's unit",
            "bias": "a finite offset in the channel's unit",
            "resolution": "a finite quantization step >= 0 in the channel's unit (0: none)",
            "delay_s": "a finite transport delay >= 0 s",
            "sample_period_s": "a finite sample period >= 0 s (0: sample every call)",
            "dropout_probability": "a probability in [0, 1)",
        }
        values: dict[str, float] = {}
        for key, expected in checks.items():
            v = _number(n, key, getattr(self, key), expected)
            nonneg = key != "bias"
            if not _isfinite(v) or (nonneg and v < 0.0):
                raise ValueError(f"ChannelSpec {n!r}: {key} expected {expected}, got {v!r}")
            values[key] = v
        if not values["dropout_probability"] < 1.0:
            raise ValueError(
                f"ChannelSpec {n!r}: dropout_probability expected a probability in [0, 1), "
                f"got {values['dropout_probability']!r} (1 would never deliver a sample)"
            )
        for key in ("range_min", "range_max"):
            v = _number(n, key, getattr(self, key), "a saturation limit (may be +-inf)")
            if math.isnan(v):
                raise ValueError(
                    f"ChannelSpec {n!r}: {key} expected a saturation limit (may be +-inf), got nan"
                )
            values[key] = v
        if not values["range_min"] < values["range_max"]:
            raise ValueError(
                f"ChannelSpec {n!r}: range_min expected < range_max, got "
                f"{values['range_min']!r} >= {values['range_max']!r}"
            )
        period_ns = round(values["sample_period_s"] * 1e9)
        if values["sample_period_s"] > 0.0 and period_ns < 1:
            raise ValueError(
                f"ChannelSpec {n!r}: sample_period_s expected 0 or >= 1 ns, "
                f"got {values['sample_period_s']!r}"
            )
        for key, v in values.items():
            object.__setattr__(self, key, v)
        object.__setattr__(self, "delay_ns", round(values["delay_s"] * 1e9))
        object.__setattr__(self, "sample_period_ns", period_ns)

    @classmethod
    def table_keys(cls) -> tuple[str, ...]:
        """Keys a scenario table may give for a channel (every field but the derived ones)."""
        return tuple(f.name for f in fields(cls) if f.init and f.name != "name")

    @classmethod
    def from_table(
        cls, name: str, table: Mapping[str, Any], base: ChannelSpec | None = None
    ) -> ChannelSpec:
        """Spec of channel ``name`` from a plain mapping (a parsed TOML table).

        Parameters
        ----------
        name : str
            Channel name (the table's key in the scenario; not a key inside it).
        table : Mapping[str, Any]
            Field values, e.g. ``{"std": 0.5, "delay_s": 0.01}``.
        base : ChannelSpec, optional
            Values for the fields ``table`` does not give (default: a perfect sensor).

        Raises
        ------
        ValueError
            On a key that is not a field, naming it and the allowed keys, or on a bad value.
        """
        if not isinstance(table, Mapping):
            raise ValueError(
                f"channel {name!r}: expected a table of {', '.join(cls.table_keys())}, "
                f"got {type(table).__name__}"
            )
        allowed = cls.table_keys()
        for key in table:
            if key not in allowed:
                raise ValueError(
                    f"channel {name!r}: unknown key {key!r}; allowed keys: {', '.join(allowed)}"
                )
        start = replace(base, name=name) if base is not None else cls(name=name)
        return replace(start, **dict(table))


@dataclass(slots=True)
class ChannelState:
    """Mutable state of one channel, owned by the caller (see :func:`channel_step`).

    Attributes
    ----------
    noise_rng, dropout_rng : numpy.random.Generator
        The channel's seeded streams.
    normals, uniforms : list[float]
        Current blocks of N(0, 1) and U[0, 1) draws; ``normal_index`` / ``uniform_index``
        point at the next one.
    times_ns, values : deque
        Recent call times (ns) and true values, for the transport delay.
    last_t_ns : int or None
        Time of the previous call (calls must have increasing times).
    sample_index : int or None
        k of the last sample taken (sample-and-hold).
    held_value, held_valid : float, bool
        The last sample, reported between sample instants.
    samples, dropped : int
        Samples taken and samples lost so far.
    """

    noise_rng: np.random.Generator
    dropout_rng: np.random.Generator
    normals: list[float] = field(default_factory=list)
    normal_index: int = 0
    uniforms: list[float] = field(default_factory=list)
    uniform_index: int = 0
    times_ns: deque[int] = field(default_factory=deque)
    values: deque[float] = field(default_factory=deque)
    last_t_ns: int | None = None
    sample_index: int | None = None
    held_value: float = _NAN
    held_valid: bool = False
    samples: int = 0
    dropped: int = 0


def channel_init(spec: ChannelSpec, seed: int) -> ChannelState:
    """Fresh state of channel ``spec`` for scenario ``seed``.

    Parameters
    ----------
    spec : ChannelSpec
        The channel; ``spec.name`` selects its random streams.
    seed : int
        Scenario seed; only seed mod 2^32 is used (as in :mod:`sensors.models`).

    Returns
    -------
    ChannelState
        Noise stream seeded by ``[seed mod 2^32, crc32(name)]``, dropout stream by
        ``[seed mod 2^32, crc32(name), 1]``; empty history.
    """
    s = int(seed) & 0xFFFFFFFF
    crc = zlib.crc32(spec.name.encode())
    return ChannelState(
        noise_rng=np.random.default_rng([s, crc]),
        dropout_rng=np.random.default_rng([s, crc, 1]),
    )


def channel_step(
    spec: ChannelSpec, state: ChannelState, t_ns: int, true_value: float
) -> tuple[ChannelState, float, bool]:
    """Measure ``true_value`` at time ``t_ns`` (see the module docstring for the model).

    Parameters
    ----------
    spec : ChannelSpec
        The channel; must be the spec ``state`` was created for (or an equal one).
    state : ChannelState
        Updated in place and returned.
    t_ns : int
        Time of this call (ns), strictly greater than the previous call's.
    true_value : float
        x(t), true value in the channel's unit.

    Returns
    -------
    state : ChannelState
        The same object, advanced.
    value : float
        The measurement y, or ``nan`` when the sample was lost or non-finite.
    valid : bool
        False exactly when ``value`` is missing (dropout, or a non-finite reading).

    Raises
    ------
    ValueError
        When ``t_ns`` does not increase.
    """
    last = state.last_t_ns
    if last is not None and t_ns <= last:
        raise ValueError(
            f"channel {spec.name!r}: t_ns expected to increase, got {t_ns} after {last}"
        )
    state.last_t_ns = t_ns
    period = spec.sample_period_ns
    delay = spec.delay_ns
    buffered = delay or period
    if buffered:
        state.times_ns.append(t_ns)
        state.values.append(true_value)
    if period:
        k = t_ns // period
        if k == state.sample_index:
            return state, state.held_value, state.held_valid
        state.sample_index = k
        t_sample = k * period
    else:
        t_sample = t_ns

    # x(t_k - d): linear interpolation in the history, clamped to its first value.
    if buffered:
        times = state.times_ns
        values = state.values
        tau = t_sample - delay
        while len(times) > 1 and times[1] <= tau:
            times.popleft()
            values.popleft()
        t0 = times[0]
        x0 = values[0]
        x = x0 if tau <= t0 else x0 + (values[1] - x0) * ((tau - t0) / (times[1] - t0))
    else:
        x = true_value

    y = x + spec.bias
    std = spec.std
    if std > 0.0:
        i = state.normal_index
        normals = state.normals
        if i >= len(normals):
            normals = state.normals = state.noise_rng.standard_normal(BLOCK_SIZE).tolist()
            i = 0
        y += std * normals[i]
        state.normal_index = i + 1
    if y < spec.range_min:
        y = spec.range_min
    elif y > spec.range_max:
        y = spec.range_max
    valid = _isfinite(y)
    r = spec.resolution
    if valid and r > 0.0:
        y = r * round(y / r)
    p = spec.dropout_probability
    if p > 0.0:
        j = state.uniform_index
        uniforms = state.uniforms
        if j >= len(uniforms):
            uniforms = state.uniforms = state.dropout_rng.random(BLOCK_SIZE).tolist()
            j = 0
        state.uniform_index = j + 1
        if uniforms[j] < p:
            valid = False
            state.dropped += 1
    if not valid:
        y = _NAN
    state.samples += 1
    state.held_value = y
    state.held_valid = valid
    return state, y, valid


class SensorSuite(Mapping[str, ChannelSpec]):
    """A set of named channels, each with its own seeded state; a read-only mapping name -> spec.

    Exported by the package as ``sensors.ChannelSuite`` (``sensors.SensorSuite`` is the
    older noise-only suite of :mod:`sensors.models`, kept as is). All channels step in one
    compiled call (:func:`sensors._kernels.suite_step`, the model of :func:`channel_step` on
    arrays; tests/test_plant_kernels.py compares the two bit for bit).

    Parameters
    ----------
    specs : Mapping[str, ChannelSpec]
        Channels by name. A spec with an empty ``name`` takes its key; any other name
        must equal its key (the name seeds the channel's streams).
    seed : int
        Scenario seed.

    Raises
    ------
    ValueError
        When a spec's name differs from its key.
    """

    def __init__(self, specs: Mapping[str, ChannelSpec], seed: int) -> None:
        named: dict[str, ChannelSpec] = {}
        for key, given in specs.items():
            if not isinstance(given, ChannelSpec):
                raise ValueError(
                    f"channel {key!r}: expected a ChannelSpec, got {type(given).__name__}"
                )
            if given.name not in ("", key):
                raise ValueError(f"channel {key!r}: spec name expected {key!r}, got {given.name!r}")
            named[key] = replace(given, name=key) if given.name == "" else given
        self._specs = named
        self.seed = seed
        self._keys = list(named)
        self._index = {key: i for i, key in enumerate(self._keys)}
        n = len(named)
        spec_list = list(named.values())
        # Array state of sensors._kernels.suite_step (layouts in its module docstring): the
        # bundle is the storage, for the Python methods and the compiled loop alike.
        f = np.zeros((n, 8))
        f[:, _kern.HELD] = _NAN
        st = np.zeros((n, 12), dtype=np.int64)
        for c, sp in enumerate(spec_list):
            f[c, :6] = (
                sp.std,
                sp.bias,
                sp.resolution,
                sp.dropout_probability,
                sp.range_min,
                sp.range_max,
            )
            st[c, _kern.DELAY] = sp.delay_ns
            st[c, _kern.PERIOD] = sp.sample_period_ns
        self._rngs = [channel_init(sp, seed) for sp in spec_list]
        self._b = _kern.SuiteBundle(
            f,
            st,
            np.zeros((n, 2), dtype=np.bool_),
            np.zeros((n, 16), dtype=np.int64),
            np.zeros((n, 16)),
            np.zeros((n, 2, BLOCK_SIZE)),
            _NO_SLOTS,
            _NO_RECORD,
        )
        for c, sp in enumerate(spec_list):  # first blocks of the streams each channel uses
            if sp.std > 0.0:
                self._b.rn[c, 0] = self._rngs[c].noise_rng.standard_normal(BLOCK_SIZE)
            if sp.dropout_probability > 0.0:
                self._b.rn[c, 1] = self._rngs[c].dropout_rng.random(BLOCK_SIZE)

    def _run(
        self,
        which: int,
        t_ns: int,
        truths: tuple[float, ...],
        slots: np.ndarray = _NO_SLOTS,
        record: np.ndarray = _NO_RECORD,
    ) -> int:
        """One :func:`sensors._kernels.suite_step` call; errors, growth and refills here."""
        while True:
            b = self._b
            code, mask = _kern.suite_step(
                which, t_ns, truths, b.f, b.st, b.ok, b.hist_t, b.hist_v, b.rn, slots, record
            )
            if code >= 0:
                break
            n = len(self._keys)
            c = -1 - code
            if c < n:
                raise ValueError(
                    f"channel {self._keys[c]!r}: t_ns expected to increase, got {t_ns} "
                    f"after {int(self._b.st[c, _kern.LAST_T])}"
                )
            self._grow()
        if code:
            self.refill()
        return mask

    def _grow(self) -> None:
        """Double the ring buffers (unrolled so that every ring starts at 0)."""
        cap = self._b.hist_t.shape[1]
        st = self._b.st
        order = (st[:, _kern.HEAD, None] + np.arange(cap)[None, :]) % cap
        b = self._b
        self._b = b._replace(
            hist_t=np.concatenate(
                [np.take_along_axis(b.hist_t, order, 1), np.zeros_like(b.hist_t)], axis=1
            ),
            hist_v=np.concatenate(
                [np.take_along_axis(b.hist_v, order, 1), np.zeros_like(b.hist_v)], axis=1
            ),
        )
        st[:, _kern.HEAD] = 0

    @property
    def state_bundle(self) -> _kern.SuiteBundle:
        """The suite's state (:class:`sensors._kernels.SuiteBundle`): its storage, which a
        kernel calling :func:`sensors._kernels.suite_step` reads and writes in place (the
        ring buffers are replaced when they grow: take the bundle again after a step here)."""
        return self._b

    def refill(self) -> None:
        """Next blocks of the streams used up by the last call (as channel_step draws them);
        after a kernel's :func:`sensors._kernels.suite_step` reported a block used up."""
        st = self._b.st
        for c in range(len(self._keys)):
            if st[c, _kern.NORMAL_I] >= BLOCK_SIZE:
                self._b.rn[c, 0] = self._rngs[c].noise_rng.standard_normal(BLOCK_SIZE)
                st[c, _kern.NORMAL_I] = 0
            if st[c, _kern.UNIFORM_I] >= BLOCK_SIZE:
                self._b.rn[c, 1] = self._rngs[c].dropout_rng.random(BLOCK_SIZE)
                st[c, _kern.UNIFORM_I] = 0

    @classmethod
    def from_table(
        cls,
        table: Mapping[str, Mapping[str, Any]],
        seed: int,
        defaults: Mapping[str, ChannelSpec] | None = None,
    ) -> SensorSuite:
        """Suite from a plain dict of channel tables (a parsed TOML scenario table).

        Parameters
        ----------
        table : Mapping[str, Mapping[str, Any]]
            Channel name -> field values, e.g.
            ``{"generator_speed": {"std": 0.5, "delay_s": 0.01, "dropout_probability": 0.01}}``.
        seed : int
            Scenario seed.
        defaults : Mapping[str, ChannelSpec], optional
            Base suite (e.g. :func:`default_floating_suite`): its channels are all included,
            a table entry overrides only the fields it gives, and a name not in
            ``defaults`` adds a channel (starting from a perfect sensor).

        Raises
        ------
        ValueError
            On an unknown key (naming it and the allowed keys) or a bad value.
        """
        specs: dict[str, ChannelSpec] = dict(defaults or {})
        for name, entries in table.items():
            specs[name] = ChannelSpec.from_table(name, entries, specs.get(name))
        return cls(specs, seed)

    def __getitem__(self, name: str) -> ChannelSpec:
        return self._specs[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._specs)

    def __len__(self) -> int:
        return len(self._specs)

    def __repr__(self) -> str:
        return f"SensorSuite({list(self._specs)!r}, seed={self.seed})"

    def step(self, t_ns: int, truths: Mapping[str, float]) -> dict[str, tuple[float, bool]]:
        """Measure every channel at ``t_ns``.

        Parameters
        ----------
        t_ns : int
            Time (ns), increasing from call to call.
        truths : Mapping[str, float]
            True value of each channel (extra keys are ignored).

        Returns
        -------
        dict[str, tuple[float, bool]]
            Channel name -> (value, valid); value is ``nan`` when not valid.

        Raises
        ------
        KeyError
            When ``truths`` lacks a channel of the suite.
        """
        try:
            tv = tuple([float(truths[key]) for key in self._keys])
        except KeyError:
            missing = [k for k in self._specs if k not in truths]
            raise KeyError(f"no true value for channel(s) {missing}") from None
        self._run(-1, t_ns, tv)
        values = zip(self._b.f[:, _kern.READING].tolist(), self._b.ok[:, 1].tolist(), strict=True)
        return dict(zip(self._keys, values, strict=True))

    def step_values(self, t_ns: int, truths: tuple[float, ...]) -> tuple[list[float], list[bool]]:
        """:meth:`step` with the true values and the readings in the suite's channel order.

        Parameters
        ----------
        t_ns : int
            Time (ns), increasing from call to call.
        truths : tuple of float
            True value of each channel, in the order of ``list(suite)``.

        Returns
        -------
        values, valid : list of float, list of bool
            Readings (``nan`` when not valid) and their flags, in the same order.
        """
        if len(truths) != len(self._keys):
            raise ValueError(f"expected {len(self._keys)} true values, got {len(truths)}")
        self._run(-1, t_ns, truths)
        return self._b.f[:, _kern.READING].tolist(), self._b.ok[:, 1].tolist()

    def bind_record(self, slots: np.ndarray, record: np.ndarray) -> None:
        """Set where :meth:`step_into` scatters the readings (checked once, here).

        Parameters
        ----------
        slots : ndarray of int64, shape (len(suite), 2)
            Per channel: its index in ``record`` (-1 or beyond it: not recorded) and its bit.
        record : ndarray of float64, shape (m,)
            Set to 0 at every :meth:`step_into`, then each valid reading at its index.
        """
        if slots.shape != (len(self._keys), 2) or slots.dtype != np.int64:
            raise ValueError(f"slots: expected int64 of shape ({len(self._keys)}, 2)")
        if record.dtype != np.float64 or record.ndim != 1:
            raise ValueError("record: expected a float64 vector (slots beyond it are skipped)")
        self._b = self._b._replace(slots=slots, record=record)

    def step_into(self, t_ns: int, truths: tuple[float, ...]) -> int:
        """:meth:`step_values`, the readings scattered into the record of :meth:`bind_record`.

        Parameters
        ----------
        t_ns : int
            Time (ns), increasing from call to call.
        truths : tuple of float
            True value of each channel, in the order of ``list(suite)``.

        Returns
        -------
        int
            The OR of the bits of the valid readings.
        """
        if len(truths) != len(self._keys):
            raise ValueError(f"expected {len(self._keys)} true values, got {len(truths)}")
        b = self._b
        code, mask = _kern.suite_step(
            -1, t_ns, truths, b.f, b.st, b.ok, b.hist_t, b.hist_v, b.rn, b.slots, b.record
        )
        if code == 0:
            return mask
        if code > 0:
            self.refill()
            return mask
        return self._run(-1, t_ns, truths, self._b.slots, self._b.record)  # nothing was changed

    def step_channel(self, name: str, t_ns: int, true_value: float) -> tuple[float, bool]:
        """Measure one channel at ``t_ns`` (same model as :meth:`step`)."""
        c = self._index[name]
        tv = [0.0] * len(self._keys)
        tv[c] = float(true_value)
        self._run(c, t_ns, tuple(tv))
        return float(self._b.f[c, _kern.READING]), bool(self._b.ok[c, 1])

    def counts(self, name: str) -> tuple[int, int]:
        """(samples taken, samples lost) of channel ``name`` so far."""
        c = self._index[name]
        return int(self._b.st[c, _kern.SAMPLES]), int(self._b.st[c, _kern.DROPPED])


#: Counts per revolution of the generator-speed encoder: a 1024-line quadrature encoder
#: (ASSUMPTION, a common HSS incremental encoder; no source in this project).
GENERATOR_ENCODER_COUNTS = 2**12
#: Counts per revolution of the blade-pitch absolute encoder (ASSUMPTION: 14-bit).
PITCH_ENCODER_COUNTS = 2**14
_G = 9.80665  # standard gravity, m/s^2


def default_floating_suite(control_period_s: float = 0.01) -> dict[str, ChannelSpec]:
    """Sensor channels of a floating turbine (NREL 5 MW class), keyed by SensorFrame field.

    The names are the measured fields of :class:`bus_schemas.messages.SensorFrame`, so a
    suite's output fills a frame directly. All figures are ASSUMPTIONS of plausible
    commercial instruments (no datasheet or published turbine figure in this project);
    override them per scenario with :meth:`SensorSuite.from_table` ``(..., defaults=...)``.

    ================================== ===== ===================================================
    channel                            unit  model
    ================================== ===== ===================================================
    generator_speed_measured_rad_s     rad/s HSS encoder, N = 2^12 counts/rev, speed from the
                                             count difference over one period h: r = 2π/(N h)
                                             = 0.153 rad/s at h = 0.01 s; σ = 0.05 (edge jitter,
                                             torsional ripple); sampled every call
    blade_pitch_measured_rad           rad   14-bit absolute encoder r = 2π/2^14 = 3.8e-4 rad;
                                             σ = 2e-4 rad (bearing play); every call
    nacelle_acc_fore_aft_measured_m_s2 m/s²  MEMS IMU ±2 g, 16 bit: r = 4g/2^16 = 6.0e-4;
                                             σ = 0.01 (≈150 µg/√Hz over 50 Hz), b = 0.02
                                             (2 mg residual), range ±2 g; 100 Hz, d = 5 ms
                                             (anti-alias filter group delay)
    platform_pitch_rate_measured_rad_s rad/s MEMS gyro ±250 °/s, 16 bit: r = 1.33e-4;
                                             σ = 6e-4 (≈0.005 °/s/√Hz over 50 Hz), b = 1e-3
                                             (0.06 °/s), range ±4.36; 100 Hz, d = 5 ms
    platform_pitch_measured_rad        rad   IMU attitude (AHRS) σ = 8.7e-4 (0.05°), b = 1.75e-3
                                             (0.1° mounting misalignment); 100 Hz, d = 10 ms
    platform_surge_measured_m          m     RTK GNSS σ = 0.02 m, r = 1 mm; 10 Hz, d = 50 ms
                                             (receiver latency), p = 0.001
    wave_elevation_gauge_measured_m    m     upstream radar/buoy gauge σ = 0.02 m, r = 1 cm;
                                             5 Hz, d = 0.1 s (radio link), p = 0.01
    wind_speed_measured_m_s            m/s   nacelle sonic anemometer behind the rotor:
                                             σ = 0.5 (rotor-wake turbulence), b = -0.5 (wake
                                             deficit, really ≈ proportional; constant here),
                                             r = 0.01, range [0, 60]; 4 Hz
    generator_torque_measured_nm       N m   converter torque estimate (HSS) σ = 100 (0.2 % of
                                             rated 43 094), r = 1; every call, d = 10 ms
    electrical_power_measured_w        W     power transducer σ = 10 kW (0.2 % of 5 MW),
                                             r = 1 kW; every call, d = 20 ms
    ================================== ===== ===================================================

    Parameters
    ----------
    control_period_s : float
        h (s), the period at which the generator speed is estimated from encoder counts;
        sets its quantization step 2π/(N h).

    Returns
    -------
    dict[str, ChannelSpec]
        Channel name -> spec.
    """
    if not (_isfinite(control_period_s) and control_period_s > 0.0):
        raise ValueError(f"control_period_s expected a period > 0 s, got {control_period_s!r}")
    two_pi = 2.0 * math.pi
    gyro_range = math.radians(250.0)
    specs = [
        ChannelSpec(
            name="generator_speed_measured_rad_s",
            std=0.05,
            resolution=two_pi / (GENERATOR_ENCODER_COUNTS * control_period_s),
        ),
        ChannelSpec(
            name="blade_pitch_measured_rad",
            std=2e-4,
            resolution=two_pi / PITCH_ENCODER_COUNTS,
        ),
        ChannelSpec(
            name="nacelle_acc_fore_aft_measured_m_s2",
            std=0.01,
            bias=0.02,
            resolution=4.0 * _G / 2**16,
            delay_s=0.005,
            sample_period_s=0.01,
            range_min=-2.0 * _G,
            range_max=2.0 * _G,
        ),
        ChannelSpec(
            name="platform_pitch_rate_measured_rad_s",
            std=6e-4,
            bias=1e-3,
            resolution=2.0 * gyro_range / 2**16,
            delay_s=0.005,
            sample_period_s=0.01,
            range_min=-gyro_range,
            range_max=gyro_range,
        ),
        ChannelSpec(
            name="platform_pitch_measured_rad",
            std=math.radians(0.05),
            bias=math.radians(0.1),
            delay_s=0.01,
            sample_period_s=0.01,
        ),
        ChannelSpec(
            name="platform_surge_measured_m",
            std=0.02,
            resolution=0.001,
            delay_s=0.05,
            sample_period_s=0.1,
            dropout_probability=0.001,
        ),
        ChannelSpec(
            name="wave_elevation_gauge_measured_m",
            std=0.02,
            resolution=0.01,
            delay_s=0.1,
            sample_period_s=0.2,
            dropout_probability=0.01,
        ),
        ChannelSpec(
            name="wind_speed_measured_m_s",
            std=0.5,
            bias=-0.5,
            resolution=0.01,
            sample_period_s=0.25,
            range_min=0.0,
            range_max=60.0,
        ),
        ChannelSpec(
            name="generator_torque_measured_nm",
            std=100.0,
            resolution=1.0,
            delay_s=0.01,
        ),
        ChannelSpec(
            name="electrical_power_measured_w",
            std=1.0e4,
            resolution=1.0e3,
            delay_s=0.02,
        ),
    ]
    return {s.name: s for s in specs}
