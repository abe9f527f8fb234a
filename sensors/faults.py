"""Fault injection: sensor faults on measured channels and bus faults on the two bus channels.

A fault acts between ``start_s`` and ``end_s`` of simulated time (the half-open window
t_start <= t < t_end, t the frame's sample time; ``end_s`` absent: to the end of the run).
Seven kinds, validated by :class:`FaultSpec`:

Sensor faults (channel: a measured :class:`bus_schemas.SensorFrame` field)
---------------------------------------------------------------------------
They act on the channel's *output* (value y_k and valid flag v_k at frame k, after the
channel model of :mod:`sensors.channel`: noise, bias, delay, sample-and-hold, dropout,
saturation, quantisation), so the channel's own state and random streams advance exactly as
without the fault and the channel is unchanged outside the window:

* ``stuck``: the reading freezes at its value at the fault start,
  y_k = y*, v_k = 1 for every frame in the window, y* the channel's reading at the first
  frame of the window, or its last valid reading before it when that one is missing (no
  valid reading yet: the channel stays invalid). A stuck sensor looks healthy: its valid
  bit stays set.
* ``dropout``: the sample is lost, v_k = 0 (the frame carries 0 with its ``valid_mask`` bit
  cleared; the old value is never passed off as fresh).
* ``bias_step``: y_k' = Q(y_k + b), b = ``bias`` in the channel's unit;
* ``noise_burst``: y_k' = Q(y_k + σ n_j), σ = ``std`` in the channel's unit, n_j ~ N(0, 1)
  i.i.d., one draw per *channel sample* j (j = ⌊t / T⌋ for a channel sampled every T, so a
  sample-and-hold channel still holds; j = t in ns for a channel sampled every call).

Q re-applies the channel's own saturation and quantisation, Q(v) = r round(min(max(v,
y_min), y_max) / r) (r = 0: no rounding), so a faulted reading is still one the instrument
can give: a bias step comes out as b to within r/2. A missing sample stays missing under a
bias step or a noise burst.

Bus faults (channel ``"sensors"`` or ``"command"``)
---------------------------------------------------
Pure decisions per message, applied by the plant node (:mod:`hil.nodes.plant_node`), which owns
the bus: ``bus_delay`` adds d = ``delay_s``; ``bus_jitter`` adds an extra delay J, either
uniform, J ~ U[0, J_max) (``distribution = "uniform"``, ``max_s`` = J_max), or half-normal,
J = min(|σ_J n|, J_max) (``distribution = "normal"``, ``std_s`` = σ_J, ``max_s`` = J_max,
default unbounded); ``bus_loss`` drops the message with probability p = ``probability``.
Delays are in simulated seconds (at a real-time speed factor s the wall delay is d / s).
Several bus faults on one channel add their delays; a lost message is not delayed.

Randomness
----------
Every random draw is a pure function of a key (counter-based: SplitMix64 of the seed, the
CRC-32 of the channel name, the fault's index in the schedule and the sample or message
``seq``), not a position in a stream. A draw therefore does not depend on how many draws
came before, on the order in which messages are looked at, or on which thread looks: a
seeded run is reproducible bit for bit, and adding a fault never changes another fault's
draws or the channel models' noise. The seed is the scenario's sensor seed unless the
fault gives its own ``seed``.

Purity
------
Nothing here reads a clock, does I/O or keeps module state. :class:`FaultSchedule` keeps
the small per-fault state a stuck fault needs (the latched value) and counters, owned by
the caller.
"""

from __future__ import annotations

import difflib
import math
import numbers
import zlib
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from sensors.channel import ChannelSpec

__all__ = [
    "BUS_CHANNELS",
    "BUS_FAULT_KINDS",
    "CHANNEL_UNITS",
    "FAULT_KINDS",
    "SENSOR_FAULT_KINDS",
    "BusEffect",
    "BusFaultPlan",
    "FaultSchedule",
    "FaultSpec",
    "counter_normal",
    "counter_uniform",
]

#: Sensor fault kinds (act on a measured channel's reading).
SENSOR_FAULT_KINDS = ("stuck", "dropout", "bias_step", "noise_burst")
#: Bus fault kinds (act on the messages of a bus channel).
BUS_FAULT_KINDS = ("bus_delay", "bus_jitter", "bus_loss")
FAULT_KINDS = SENSOR_FAULT_KINDS + BUS_FAULT_KINDS
#: Bus channels: the sensor frame to the controller, the command back to the plant.
BUS_CHANNELS = ("sensors", "command")
#: Unit of every measured SensorFrame field a sensor fault may name (the rotor speed is
#: derived from the generator speed and shares its fault).
CHANNEL_UNITS: dict[str, str] = {
    "generator_speed_measured_rad_s": "rad/s",
    "blade_pitch_measured_rad": "rad",
    "generator_torque_measured_nm": "N m",
    "electrical_power_measured_w": "W",
    "wind_speed_measured_m_s": "m/s",
    "nacelle_acc_fore_aft_measured_m_s2": "m/s^2",
    "platform_pitch_measured_rad": "rad",
    "platform_pitch_rate_measured_rad_s": "rad/s",
    "platform_surge_measured_m": "m",
    "wave_elevation_gauge_measured_m": "m",
}
#: End of an open window (ns): later than any run.
OPEN_END_NS = 2**62

#: Keys each kind takes besides kind, channel, start_s, end_s.
_KIND_KEYS: dict[str, tuple[str, ...]] = {
    "stuck": (),
    "dropout": (),
    "bias_step": ("bias",),
    "noise_burst": ("std", "seed"),
    "bus_delay": ("delay_s",),
    "bus_jitter": ("distribution", "std_s", "max_s", "seed"),
    "bus_loss": ("probability", "seed"),
}
_COMMON_KEYS = ("kind", "channel", "start_s", "end_s")
_PARAM_KEYS = ("bias", "std", "delay_s", "distribution", "std_s", "max_s", "probability", "seed")

# ---------------------------------------------------------------------- counter-based draws
_M64 = (1 << 64) - 1
_GOLDEN = 0x9E3779B97F4A7C15


def _mix64(z: int) -> int:
    """SplitMix64 finaliser (Steele, Lea and Flood 2014): a bijective 64-bit mix."""
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _M64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _M64
    return z ^ (z >> 31)


def counter_uniform(*key: int) -> float:
    """U[0, 1) draw that is a pure function of the integer ``key``.

    h_0 = φ, h_{i+1} = mix64(h_i ⊕ (k_i mod 2^64) + φ) (φ = 2^64 / golden ratio,
    mix64 the SplitMix64 finaliser), u = ⌊h / 2^11⌋ 2^-53: 53 random bits.

    Parameters
    ----------
    *key : int
        Seed, stream and counter components (any integers).

    Returns
    -------
    float
        u in [0, 1).
    """
    h = _GOLDEN
    for k in key:
        h = _mix64(((h ^ (k & _M64)) + _GOLDEN) & _M64)
    return (h >> 11) * (1.0 / 9007199254740992.0)


def counter_normal(*key: int) -> float:
    """N(0, 1) draw that is a pure function of ``key`` (Box-Muller on two keyed uniforms).

    n = sqrt(-2 ln(1 - u_1)) cos(2π u_2), u_i = :func:`counter_uniform` ``(*key, i)``.
    """
    u1 = counter_uniform(*key, 1)
    u2 = counter_uniform(*key, 2)
    return math.sqrt(-2.0 * math.log1p(-u1)) * math.cos(2.0 * math.pi * u2)


# ---------------------------------------------------------------------- specs
def _where(kind: str, channels: Sequence[str]) -> str:
    return f"fault {kind} on {', '.join(repr(c) for c in channels) or '?'}"


def _real(where: str, key: str, value: object, expected: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(
            f"{where}: {key} expected {expected}, got {type(value).__name__} {value!r}"
        )
    v = float(value)
    if math.isnan(v):
        raise ValueError(f"{where}: {key} expected {expected}, got nan")
    return v


@dataclass(frozen=True)
class FaultSpec:
    """One fault, validated on construction (see the module docstring for the models).

    Parameters
    ----------
    kind : str
        ``stuck`` | ``dropout`` | ``bias_step`` | ``noise_burst`` (sensor faults) or
        ``bus_delay`` | ``bus_jitter`` | ``bus_loss`` (bus faults).
    channels : tuple of str
        Sensor faults: measured SensorFrame fields (:data:`CHANNEL_UNITS`); bus faults:
        ``"sensors"`` and/or ``"command"``.
    start_s : float
        t_start (s of simulated time), >= 0.
    end_s : float or None
        t_end (s), > t_start; None: to the end of the run.
    bias : float, optional
        b of ``bias_step``, in the channel's unit (finite, may be negative).
    std : float, optional
        σ of ``noise_burst``, in the channel's unit, > 0.
    delay_s : float, optional
        d of ``bus_delay`` (s), > 0.
    distribution : str, optional
        ``"uniform"`` (default) or ``"normal"`` for ``bus_jitter``.
    std_s : float, optional
        σ_J of a normal ``bus_jitter`` (s), > 0.
    max_s : float, optional
        J_max of ``bus_jitter`` (s), > 0; required for uniform, optional for normal.
    probability : float, optional
        p of ``bus_loss``, in [0, 1].
    seed : int, optional
        Seed of this fault's draws (default: the schedule's seed), >= 0.

    Attributes
    ----------
    start_ns, end_ns : int
        The window in whole ns (derived; an open window ends at :data:`OPEN_END_NS`).

    Raises
    ------
    ValueError
        Naming the field, the expected value and unit, and what was given.
    """

    kind: str
    channels: tuple[str, ...]
    start_s: float = 0.0
    end_s: float | None = None
    bias: float | None = None
    std: float | None = None
    delay_s: float | None = None
    distribution: str | None = None
    std_s: float | None = None
    max_s: float | None = None
    probability: float | None = None
    seed: int | None = None
    start_ns: int = field(init=False, repr=False)
    end_ns: int = field(init=False, repr=False)

    def __post_init__(self) -> None:
        kind = self.kind
        if kind not in FAULT_KINDS:
            close = difflib.get_close_matches(str(kind), FAULT_KINDS, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ValueError(
                f"fault: unknown kind {kind!r}{hint} (kinds: {', '.join(FAULT_KINDS)})"
            )
        channels = self.channels
        if isinstance(channels, str):
            channels = (channels,)
        if not isinstance(channels, Iterable) or not channels:
            raise ValueError(f"fault {kind}: channel expected a channel name or a list of them")
        channels = tuple(channels)
        object.__setattr__(self, "channels", channels)
        where = _where(kind, channels)
        allowed = BUS_CHANNELS if kind in BUS_FAULT_KINDS else tuple(CHANNEL_UNITS)
        what = "a bus channel" if kind in BUS_FAULT_KINDS else "a measured SensorFrame field"
        for ch in channels:
            if ch not in allowed:
                close = difflib.get_close_matches(str(ch), allowed, n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise ValueError(
                    f"fault {kind}: channel {ch!r} is not {what}{hint} "
                    f"(channels for {kind}: {', '.join(allowed)})"
                )
        if len(set(channels)) != len(channels):
            raise ValueError(f"{where}: channel names a channel twice")
        start = _real(where, "start_s", self.start_s, "a start time >= 0 s")
        if not (math.isfinite(start) and start >= 0.0):
            raise ValueError(f"{where}: start_s expected a start time >= 0 s, got {start!r}")
        object.__setattr__(self, "start_s", start)
        object.__setattr__(self, "start_ns", round(start * 1e9))
        end_ns = OPEN_END_NS
        if self.end_s is not None:
            end = _real(where, "end_s", self.end_s, "an end time > start_s in s")
            if not (math.isfinite(end) and end > start):
                raise ValueError(
                    f"{where}: end_s expected an end time > start_s = {start:g} s, got {end!r}"
                )
            object.__setattr__(self, "end_s", end)
            end_ns = round(end * 1e9)
        object.__setattr__(self, "end_ns", end_ns)
        for key in _PARAM_KEYS:
            if getattr(self, key) is not None and key not in _KIND_KEYS[kind]:
                takes = ", ".join(_KIND_KEYS[kind]) or "no other keys"
                raise ValueError(
                    f"{where}: key {key!r} is not used by kind {kind!r} ({kind} takes: {takes})"
                )
        self._check_params(where, channels)

    def _check_params(self, where: str, channels: tuple[str, ...]) -> None:
        kind = self.kind
        unit = "/".join(sorted({CHANNEL_UNITS.get(c, "?") for c in channels}))

        def need(key: str, expected: str, ok: Any) -> float:
            value = getattr(self, key)
            if value is None:
                raise ValueError(f"{where}: {key} is required: expected {expected}")
            v = _real(where, key, value, expected)
            if not (math.isfinite(v) and ok(v)):
                raise ValueError(f"{where}: {key} expected {expected}, got {v!r}")
            object.__setattr__(self, key, v)
            return v

        if kind == "bias_step":
            need("bias", f"a finite offset in the channel's unit ({unit})", lambda v: True)
        elif kind == "noise_burst":
            need("std", f"a noise standard deviation > 0 in the channel's unit ({unit})",
                 lambda v: v > 0.0)  # fmt: skip
        elif kind == "bus_delay":
            need("delay_s", "a delay > 0 s", lambda v: v > 0.0)
        elif kind == "bus_jitter":
            dist = self.distribution if self.distribution is not None else "uniform"
            if dist not in ("uniform", "normal"):
                raise ValueError(
                    f"{where}: distribution expected 'uniform' or 'normal', got {dist!r}"
                )
            object.__setattr__(self, "distribution", dist)
            if dist == "uniform":
                if self.std_s is not None:
                    raise ValueError(
                        f"{where}: std_s is for distribution = 'normal'; a uniform jitter "
                        "takes max_s (s), the upper bound of U[0, max_s)"
                    )
                need("max_s", "the upper bound > 0 s of the uniform extra delay", lambda v: v > 0)
            else:
                need("std_s", "the standard deviation > 0 s of the normal jitter", lambda v: v > 0)
                if self.max_s is not None:
                    need("max_s", "a bound > 0 s on the extra delay", lambda v: v > 0.0)
        elif kind == "bus_loss":
            need("probability", "a loss probability in [0, 1]", lambda v: 0.0 <= v <= 1.0)
        if self.seed is not None and (
            isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0
        ):
            raise ValueError(f"{where}: seed expected an integer >= 0, got {self.seed!r}")

    @property
    def is_bus(self) -> bool:
        """True for the bus kinds."""
        return self.kind in BUS_FAULT_KINDS

    def active(self, t_ns: int) -> bool:
        """True when ``t_ns`` lies in the window [start_ns, end_ns)."""
        return self.start_ns <= t_ns < self.end_ns

    def describe(self) -> str:
        """One line for a log: kind, channels, window and parameters with units."""
        end = "end" if self.end_s is None else f"{self.end_s:g} s"
        params = {
            "bias": self.bias,
            "std": self.std,
            "delay_s": self.delay_s,
            "distribution": self.distribution,
            "std_s": self.std_s,
            "max_s": self.max_s,
            "probability": self.probability,
        }
        extra = ", ".join(f"{k} = {v!r}" for k, v in params.items() if v is not None)
        return f"{self.kind} on {', '.join(self.channels)} from {self.start_s:g} s to {end}" + (
            f" ({extra})" if extra else ""
        )

    @classmethod
    def table_keys(cls, kind: str | None = None) -> tuple[str, ...]:
        """Keys a ``[[faults]]`` table may give (for ``kind``, or for any kind)."""
        if kind in _KIND_KEYS:
            return _COMMON_KEYS + _KIND_KEYS[kind]
        return _COMMON_KEYS + _PARAM_KEYS

    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> FaultSpec:
        """Spec from a plain mapping (a parsed ``[[faults]]`` TOML table).

        ``channel`` is a channel name or a list of them; every other key is a field.

        Raises
        ------
        ValueError
            On a missing ``kind`` or ``channel``, an unknown key (naming it and the kind's
            keys) or a bad value.
        """
        if not isinstance(table, Mapping):
            raise ValueError(f"fault: expected a table, got {type(table).__name__}")
        kind = table.get("kind")
        if kind is None:
            raise ValueError(f"fault: kind is required (kinds: {', '.join(FAULT_KINDS)})")
        allowed = cls.table_keys(kind if isinstance(kind, str) else None)
        for key in table:
            if key not in cls.table_keys():
                close = difflib.get_close_matches(str(key), allowed, n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise ValueError(
                    f"fault {kind}: unknown key {key!r}{hint} (keys: {', '.join(allowed)})"
                )
        if "channel" not in table:
            raise ValueError(f"fault {kind}: channel is required")
        channel = table["channel"]
        channels = (channel,) if isinstance(channel, str) else tuple(channel)
        params = {k: v for k, v in table.items() if k not in ("kind", "channel")}
        return cls(kind=kind, channels=channels, **params)


def _crc(name: str) -> int:
    return zlib.crc32(name.encode())


# ---------------------------------------------------------------------- sensor faults
@dataclass(slots=True)
class _Live:
    """A sensor fault in a schedule with its state."""

    index: int
    spec: FaultSpec
    seed: int
    crcs: tuple[int, ...]
    latched: dict[str, tuple[float, bool]] = field(default_factory=dict)
    last_valid: dict[str, float] = field(default_factory=dict)


class FaultSchedule:
    """The sensor faults of a run, applied frame by frame to the channels' readings.

    Parameters
    ----------
    faults : sequence of FaultSpec
        Every fault of the scenario, in file order; bus faults are ignored here (the plant
        node applies them). Faults on one channel compose in this order, each acting on
        the output of the ones before it.
    seed : int
        Default seed of the draws (the scenario's sensor seed); only seed mod 2^64 counts.
    channels : mapping of str to ChannelSpec, optional
        The channel models, for the sample period T (one noise draw per sample), the range
        and the resolution r that a faulted reading is re-quantised to (absent: T = 0, no
        range, r = 0).

    Attributes
    ----------
    injected : Counter[str]
        Kind -> channel readings the faults acted on (one per channel per frame).
    """

    def __init__(
        self,
        faults: Sequence[FaultSpec],
        seed: int,
        channels: Mapping[str, ChannelSpec] | None = None,
    ) -> None:
        self.faults = tuple(f for f in faults if not f.is_bus)
        self.seed = int(seed)
        self.channels = dict(channels or {})
        self.injected: Counter[str] = Counter()
        self._live = [
            _Live(
                index=i,
                spec=f,
                seed=self.seed if f.seed is None else f.seed,
                crcs=tuple(_crc(c) for c in f.channels),
            )
            for i, f in enumerate(self.faults)
        ]
        self._last_t_ns: int | None = None

    def __bool__(self) -> bool:
        return bool(self.faults)

    def _requantise(self, name: str, v: float) -> float:
        spec = self.channels.get(name)
        if spec is None:
            return v
        v = min(max(v, spec.range_min), spec.range_max)
        r = spec.resolution
        return r * round(v / r) if r > 0.0 else v

    def apply(
        self, t_ns: int, readings: dict[str, tuple[float, bool]]
    ) -> dict[str, tuple[float, bool]]:
        """Apply the faults active at ``t_ns`` to ``readings`` (updated in place, returned).

        Parameters
        ----------
        t_ns : int
            The frame's sample time (ns), increasing from call to call.
        readings : dict of str to (float, bool)
            Channel -> (value in the channel's unit, valid) as the channel models gave them;
            a channel the plant does not have may be absent (read as missing).

        Returns
        -------
        dict of str to (float, bool)
            The same dict; a faulted channel that was absent is added.

        Raises
        ------
        ValueError
            When ``t_ns`` does not increase.
        """
        last = self._last_t_ns
        if last is not None and t_ns <= last:
            raise ValueError(f"fault schedule: t_ns expected to increase, got {t_ns} after {last}")
        self._last_t_ns = t_ns
        done = False
        for live in self._live:
            spec = live.spec
            if t_ns >= spec.end_ns:
                done = True
                continue
            if t_ns < spec.start_ns:
                if spec.kind == "stuck":  # remember the last valid reading before the start
                    for name in spec.channels:
                        y, ok = readings.get(name, (math.nan, False))
                        if ok:
                            live.last_valid[name] = y
                continue
            self._act(live, t_ns, readings)
        if done:
            self._live = [v for v in self._live if t_ns < v.spec.end_ns]
        return readings

    def _act(self, live: _Live, t_ns: int, readings: dict[str, tuple[float, bool]]) -> None:
        spec = live.spec
        kind = spec.kind
        for name, crc in zip(spec.channels, live.crcs, strict=True):
            y, ok = readings.get(name, (math.nan, False))
            if kind == "stuck":
                held = live.latched.get(name)
                if held is None:
                    if ok:
                        held = (y, True)
                    elif name in live.last_valid:
                        held = (live.last_valid[name], True)
                    else:
                        held = (math.nan, False)
                    live.latched[name] = held
                readings[name] = held
            elif kind == "dropout":
                readings[name] = (math.nan, False)
            elif not ok:
                pass  # a missing sample stays missing under a bias step or a noise burst
            elif kind == "bias_step":
                assert spec.bias is not None
                readings[name] = (self._requantise(name, y + spec.bias), True)
            else:  # noise_burst
                assert spec.std is not None
                channel = self.channels.get(name)
                period = channel.sample_period_ns if channel is not None else 0
                j = t_ns // period if period else t_ns
                n = counter_normal(live.seed, crc, live.index, j)
                readings[name] = (self._requantise(name, y + spec.std * n), True)
            self.injected[kind] += 1


# ---------------------------------------------------------------------- bus faults
@dataclass(frozen=True, slots=True)
class BusEffect:
    """What the bus faults do to one message.

    Attributes
    ----------
    lost : bool
        The message is dropped.
    delay_ns : int
        Extra delay (ns of simulated time), d + J; 0 when lost.
    kinds : tuple of str
        The fault kinds that acted on it (for the counters).
    """

    lost: bool
    delay_ns: int
    kinds: tuple[str, ...]


NO_EFFECT = BusEffect(lost=False, delay_ns=0, kinds=())


class BusFaultPlan:
    """The bus faults of one bus channel: a pure decision per message.

    Parameters
    ----------
    faults : sequence of FaultSpec
        Every fault of the scenario; those naming ``channel`` are used.
    channel : str
        ``"sensors"`` or ``"command"``.
    seed : int
        Default seed of the draws.
    """

    def __init__(self, faults: Sequence[FaultSpec], channel: str, seed: int) -> None:
        if channel not in BUS_CHANNELS:
            raise ValueError(f"bus channel expected one of {BUS_CHANNELS}, got {channel!r}")
        self.channel = channel
        crc = _crc(channel)
        self._faults = [
            (i, f, (f.seed if f.seed is not None else int(seed)), crc)
            for i, f in enumerate(faults)
            if f.is_bus and channel in f.channels
        ]
        self.start_ns = min((f.start_ns for _, f, _, _ in self._faults), default=OPEN_END_NS)

    def __bool__(self) -> bool:
        return bool(self._faults)

    def effect(self, seq: int, t_ns: int) -> BusEffect:
        """The faults' effect on message ``seq`` (a frame, or the command answering it).

        Parameters
        ----------
        seq : int
            The frame's ``seq`` (the command's ``answered_seq``): the draws' counter.
        t_ns : int
            The frame's sample time (ns): selects the faults whose window holds it.

        Returns
        -------
        BusEffect
            Lost, or the extra delay d + J (ns); a function of (seed, fault, seq) only.
        """
        if t_ns < self.start_ns:
            return NO_EFFECT
        delay_s = 0.0
        kinds: list[str] = []
        for index, f, seed, crc in self._faults:
            if not f.start_ns <= t_ns < f.end_ns:
                continue
            if f.kind == "bus_loss":
                assert f.probability is not None
                if counter_uniform(seed, crc, index, seq) < f.probability:
                    return BusEffect(lost=True, delay_ns=0, kinds=("bus_loss",))
            elif f.kind == "bus_delay":
                assert f.delay_s is not None
                delay_s += f.delay_s
                kinds.append("bus_delay")
            else:  # bus_jitter
                if f.distribution == "uniform":
                    assert f.max_s is not None
                    j = f.max_s * counter_uniform(seed, crc, index, seq)
                else:
                    assert f.std_s is not None
                    j = abs(f.std_s * counter_normal(seed, crc, index, seq))
                    if f.max_s is not None:
                        j = min(j, f.max_s)
                delay_s += j
                kinds.append("bus_jitter")
        if not kinds:
            return NO_EFFECT
        return BusEffect(lost=False, delay_ns=round(delay_s * 1e9), kinds=tuple(kinds))
