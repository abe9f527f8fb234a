"""The run's plots, drawn from one pass over its columns: memory bounded whatever its length.

:func:`write_plots` writes ``timeseries.png``, ``timing.png`` and ``psd.png`` from a
:class:`PlotData`, which takes the run's messages as batches of columns
(:class:`hil.runlog.columns.ColumnBatch`: a file read chunk by chunk by
:class:`hil.runlog.columns.ColumnReader`, or a run in memory through
:func:`hil.runlog.columns.run_batches`) and keeps only what is drawn:

* **time series**: what a figure :data:`DRAW_COLUMNS` pixels wide can show: every sample of
  a run up to :data:`MAX_POINTS` (2 :data:`DRAW_COLUMNS`) samples per channel, a longer run
  (a 600 s run at 40 Hz has 24 000) in buckets of B = ceil(n / :data:`DRAW_COLUMNS`)
  consecutive samples, one a pixel column at most, each drawn as its minimum at the
  bucket's first time and its maximum at its last, so the line covers the envelope of what
  it replaces (a single-sample spike is not lost, as it would be by taking every B-th
  sample);
* **event windows** (the plant's safe state, the controller's safe mode, the feedforward's
  starts, a sensor's invalid samples) at full rate, span by span (:class:`Spans`);
* **latency**: a histogram on fixed log-spaced bins (:data:`LATENCY_BINS_PER_DECADE` a
  decade, regrouped into about 100 bins over the measured range when drawn), the in-time
  cycles as a time series as above, the missed ones each;
* **spectra**: Welch's average over the KPI window (Hann, 50 % overlap, segment
  :func:`psd_segment`), taken segment by segment as the samples come (:class:`StreamingWelch`):
  the same estimate as ``scipy.signal.welch`` over the whole record (computed with numpy:
  importing ``scipy.signal`` alone costs more than the spectra), holding at most two
  segments; marked with the frequencies that explain them (:func:`spectral_marks`).

The counts per channel (for B) come from the file's summary section (:func:`logged_counts`)
or from a first pass; the KPI window and the latency percentiles from the run's summary
(:func:`hil.review.core.summarize_batches`). A review of a complete file gathers the plots'
data in its own pass (:meth:`PlotData.finish` takes the summary at the end; the spectra's
window is then found as the review finds it), a file cut short in a second pass.

Drawn with matplotlib's Agg renderer, but for two things written here because matplotlib's
own are most of the drawing time of eight stacked panels: the ticks (:func:`_plain_ticks`)
and the legends of lines and shaded spans (:func:`_legend_outside`), each a few plain
artists instead of objects built and measured again at every draw.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

from bus_schemas.messages import EST_FEEDFORWARD, EST_WAVE_FORECAST, VALID_BITS
from hil.review.core import _scenario_of, scenario_period_s
from hil.runlog.columns import ColumnBatch, ColumnReader, suffix_of

FloatArray = npt.NDArray[np.float64]

__all__ = [
    "DRAW_COLUMNS",
    "LAYOUTS",
    "MAX_POINTS",
    "PLOT_FIELDS",
    "PLOT_FILES",
    "PSD_TARGET_SEGMENT_S",
    "PlotData",
    "Spans",
    "StreamingWelch",
    "blank_figures",
    "platform_periods_s",
    "psd_segment",
    "spectral_marks",
    "write_plots",
]

PLOT_FILES = ("timeseries.png", "timing.png", "psd.png")
#: Pixel columns a time series is drawn for at most (the plots are about 1300 pixels wide):
#: a longer channel is drawn as one min/max bucket per column.
DRAW_COLUMNS = 2000
#: Samples per channel drawn as they are (two per column); longer runs as min/max buckets.
MAX_POINTS = 2 * DRAW_COLUMNS
#: Fixed bins of the latency histogram per decade (from 1 ns to 1000 s).
LATENCY_BINS_PER_DECADE = 200
_LAT_EDGES_US = np.logspace(-3.0, 9.0, 12 * LATENCY_BINS_PER_DECADE + 1)
#: Wall-clock resolution wanted of the PSD: 0.004 Hz puts two bins below the surge mode of
#: a semi-submersible (about 0.008 Hz) and resolves its pitch mode (about 0.037 Hz).
PSD_TARGET_SEGMENT_S = 250.0
RPM_PER_RAD_S = 30.0 / math.pi
#: Resolution of the PNGs [dots per inch].
DPI = 100
#: Vertices of a line Agg rasterises at a time (matplotlib's ``agg.path.chunksize``; 0, its
#: default, is the whole line at once). A long run's min/max envelope zig-zags over the whole
#: panel height at every pixel column, and Agg holds a cell for every pixel such a line
#: crosses: 20-30 MB a line for a day, none of it Python's. In pieces it holds one piece's.
AGG_CHUNK = 500
#: ``command`` ``mode`` of a safe-mode command (:data:`hil.review.core.MODE_SAFE_COMMAND`).
MODE_SAFE_COMMAND = 2

#: (panel, truth field, measured field, scale to the panel's unit, measured label).
_PANELS: tuple[tuple[str, str, str, float, str], ...] = (
    ("wind speed [m/s]", "wind_speed_m_s", "wind_speed_measured_m_s", 1.0, "nacelle anemometer"),
    ("rotor speed [rpm]", "rotor_speed_rad_s", "rotor_speed_measured_rad_s", RPM_PER_RAD_S, ""),
    ("blade pitch [deg]", "blade_pitch_rad", "blade_pitch_measured_rad", 180.0 / math.pi, ""),
    ("generator torque [kN m]", "generator_torque_nm", "generator_torque_measured_nm", 1e-3, ""),
    ("electrical power [MW]", "electrical_power_w", "electrical_power_measured_w", 1e-6, ""),
    (
        "platform pitch [deg]",
        "platform_pitch_rad",
        "platform_pitch_measured_rad",
        180 / math.pi,
        "",
    ),
    ("platform surge [m]", "platform_surge_m", "platform_surge_measured_m", 1.0, ""),
    (
        "wave elevation [m]",
        "wave_elevation_platform_m",
        "wave_elevation_gauge_measured_m",
        1.0,
        "gauge (measured)",
    ),
)
#: (name, truth field, scale, unit of the density) of the spectra.
_SPECTRA: tuple[tuple[str, str, float, str], ...] = (
    ("rotor speed", "rotor_speed_rad_s", RPM_PER_RAD_S, "rpm²/Hz"),
    ("blade pitch", "blade_pitch_rad", 180.0 / math.pi, "deg²/Hz"),
    ("platform pitch", "platform_pitch_rad", 180.0 / math.pi, "deg²/Hz"),
    ("tower-base fore-aft moment", "tower_base_moment_nm", 1e-6, "(MN m)²/Hz"),
)
#: Each figure's size [in], panels (stacked) and margins [figure fractions]: fixed, so the
#: empty figures can be made before the data comes (:func:`blank_figures`).
LAYOUTS: dict[str, tuple[float, float, int, tuple[tuple[str, float], ...]]] = {
    "timeseries": (13, 18, len(_PANELS), (("left", 0.075), ("right", 0.8), ("top", 0.965),
                                          ("bottom", 0.035), ("hspace", 0.12))),
    "timing": (12, 8, 2, (("left", 0.08), ("right", 0.72), ("top", 0.94), ("bottom", 0.08),
                          ("hspace", 0.35))),
    "psd": (12, 12, len(_SPECTRA), (("left", 0.09), ("right", 0.75), ("top", 0.92),
                                    ("bottom", 0.05))),
}  # fmt: skip
#: A figure and its panels (matplotlib's Figure and an array of Axes).
Blank: TypeAlias = tuple[Any, Any]
_TRUTH_FIELDS = (
    *(p[1] for p in _PANELS),
    "wave_elevation_gauge_m",
    "tower_base_moment_nm",
    "floating",
)
#: The fields each topic is read for (besides ``sample_time_ns``).
PLOT_FIELDS: dict[str, tuple[str, ...]] = {
    "truth": tuple(dict.fromkeys(_TRUTH_FIELDS)),
    "sensors": ("valid_mask", *(p[2] for p in _PANELS)),
    "command": ("blade_pitch_commanded_rad", "generator_torque_commanded_nm", "mode"),
    "timing/cycle": ("seq", "latency_ns", "deadline_missed", "safe_state"),
    "controller/status": ("estimates_valid_mask",),
}


def psd_segment(n: int, fs_hz: float) -> int:
    """Welch segment length [samples] for a record of ``n`` samples at ``fs_hz``.

    min(:data:`PSD_TARGET_SEGMENT_S` fs, n / 2): at most what resolves the platform modes, and
    at least three half-overlapping segments to average; never fewer than 8 samples (or n).
    The frequency resolution is fs / nperseg.
    """
    return int(max(min(n, 8), min(round(PSD_TARGET_SEGMENT_S * fs_hz), n // 2)))


#: Frequency range of the spectra [Hz]: the surge mode of a semi-submersible (about
#: 0.008 Hz) to past 3P and the tower's first mode (about 0.5 Hz); the rest is noise floor.
PSD_RANGE_HZ = (0.005, 2.0)
#: Decades of density shown under each spectrum's peak (within :data:`PSD_RANGE_HZ`).
PSD_DECADES = 5.0


def platform_periods_s(preset: str) -> dict[str, float]:
    """Undamped natural periods [s] of the platform's surge and pitch, from its preset.

    The rigid platform's surge, heave and pitch (the tower held): ω² the eigenvalues of
    M⁻¹ K with M the structural mass and infinite-frequency added mass
    (:func:`plant.platform.load_floating`, no radiation memory) and K its hydrostatic and
    gravity stiffness plus the mooring's, linearised at zero offset (surge -dF_x/dx, the
    surge-pitch coupling -dM_φ/dx, the heave-pitch table). Each mode is named by the degree
    of freedom holding most of its kinetic energy. Within about 10 % of the damped periods of
    :func:`plant.modes.natural_modes` (which adds the radiation memory and the rotor), at a
    fraction of its cost. A preset that cannot be read, or a mode not found (a locked or
    unrestrained degree of freedom), is left out.
    """
    try:
        from plant.platform import load_floating  # noqa: PLC0415 - only for the marks

        params = load_floating(preset, radiation=False)
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    mass = np.asarray(params.mass_matrix, np.float64)[:3, :3]
    k = np.array(params.stiffness, np.float64)[:3, :3]
    moor = params.mooring
    x = np.asarray(moor.surge_m, np.float64)
    slope = np.diff(x)
    k[0, 0] -= float(np.interp(0.0, x[:-1], np.diff(moor.force_surge_n) / slope))
    coupling = -float(np.interp(0.0, x[:-1], np.diff(moor.moment_pitch_nm) / slope))
    k[0, 2] += coupling
    k[2, 0] += coupling
    k[1:3, 1:3] += np.asarray(moor.stiffness_heave_pitch, np.float64)
    w2, vec = np.linalg.eig(np.linalg.solve(mass, 0.5 * (k + k.T)))
    out: dict[str, float] = {}
    for dof, name in ((0, "surge"), (2, "pitch")):
        energy = np.abs(vec) ** 2 * np.diag(mass)[:, None]
        share = energy[dof] / energy.sum(axis=0)
        j = int(np.argmax(share))
        lam = complex(w2[j])
        if share[j] > 0.5 and lam.real > 0 and abs(lam.imag) < 1e-9 * lam.real:
            out[name] = 2.0 * math.pi / math.sqrt(lam.real)
    return out


#: :func:`platform_periods_s` of the shipped floating presets [s], so that a review does not
#: import and load the plant model to mark two lines (about 0.3 s);
#: ``tests/test_review_plots.py`` checks each against the preset it comes from.
SHIPPED_PLATFORM_PERIODS_S: dict[str, dict[str, float]] = {
    "iea15mw_volturnus": {"surge": 128.23311394923235, "pitch": 28.01236170140107},
    "nrel5mw_oc3_hywind": {"surge": 125.39837298558052, "pitch": 29.959146211400075},
    "nrel5mw_tlp": {"surge": 34.02311869877013},
}


def spectral_marks(
    summary: Mapping[str, Any], metadata: Mapping[str, Mapping[str, str]]
) -> list[tuple[str, float]]:
    """The frequencies [Hz] marked on the spectra, with their labels.

    * the wave spectrum's peak 1 / T_p (the scenario's ``waves.tp_s``);
    * 1P and 3P: the mean rotor speed over the KPI window (``kpi.rotor_speed_mean_rad_s``)
      over 2π, and three times that (the blades passing the tower);
    * the platform's surge and pitch natural frequencies (:func:`platform_periods_s` of the
      scenario's ``platform`` preset, :data:`SHIPPED_PLATFORM_PERIODS_S` for a shipped one;
      none for a bottom-fixed turbine).

    A figure the run does not have is left out.
    """
    cfg = _scenario_of(metadata).get("config") or {}
    marks: list[tuple[str, float]] = []
    waves = cfg.get("waves") if isinstance(cfg, dict) else None
    tp = waves.get("tp_s") if isinstance(waves, dict) else None
    if isinstance(tp, int | float) and tp > 0:
        marks.append((f"wave peak 1/Tp (Tp = {tp:.3g} s)", 1.0 / float(tp)))
    w = (summary.get("kpi") or {}).get("rotor_speed_mean_rad_s")
    if isinstance(w, int | float) and math.isfinite(w) and w > 0:
        one_p = float(w) / (2.0 * math.pi)
        marks.append((f"1P ({float(w) * RPM_PER_RAD_S:.3g} rpm)", one_p))
        marks.append(("3P", 3.0 * one_p))
    preset = cfg.get("platform") if isinstance(cfg, dict) else None
    if isinstance(preset, str) and preset:
        periods = SHIPPED_PLATFORM_PERIODS_S.get(preset)
        for name, period in (
            periods if periods is not None else platform_periods_s(preset)
        ).items():
            marks.append((f"platform {name} (T = {period:.3g} s)", 1.0 / period))
    return marks


class Envelope:
    """A channel group's samples, every one up to :data:`MAX_POINTS`, else min/max buckets.

    Parameters
    ----------
    count : int
        Samples the group will get (the run's message count of the topic); sets the bucket:
        B = 1 up to :data:`MAX_POINTS`, else ceil(count / :data:`DRAW_COLUMNS`) (at most one
        bucket, two points, a pixel column).
    """

    def __init__(self, count: int) -> None:
        n = int(count)
        self.bucket = 1 if n <= MAX_POINTS else -(-n // DRAW_COLUMNS)
        self._names: tuple[str, ...] | None = None
        self._parts: list[np.ndarray] = []  # (channels, samples drawn) each
        self._carry: np.ndarray | None = None  # (channels, samples of the open bucket)

    def add(self, cols: Mapping[str, np.ndarray]) -> None:
        """Append consecutive samples (``t`` and the channels, equal lengths; the same
        channels every time)."""
        names = tuple(cols)
        if self._names is None:
            self._names = names
        elif names != self._names:
            raise ValueError(f"channels {names} fed to an envelope of {self._names}")
        # all channels as one (channels, samples) array: one reduction a batch, not one each
        x = np.array([np.asarray(c, np.float64) for c in cols.values()], np.float64, ndmin=2)
        b = self.bucket
        if b == 1:
            self._parts.append(x)
            return
        if self._carry is not None and self._carry.shape[1]:
            x = np.concatenate((self._carry, x), axis=1)
        full = (x.shape[1] // b) * b
        self._carry = x[:, full:]
        if full:
            self._parts.append(self._buckets(x[:, :full].reshape(x.shape[0], -1, b)))

    def _buckets(self, rows: np.ndarray) -> np.ndarray:
        """Each bucket (the last axis) as two samples: (min, max) of a value, (first, last)
        of the time ``t``; the NaN-ignoring reductions leave a bucket with no finite value a
        gap (no warning)."""
        out = np.empty((*rows.shape[:2], 2))
        out[..., 0] = np.fmin.reduce(rows, axis=2)
        out[..., 1] = np.fmax.reduce(rows, axis=2)
        assert self._names is not None
        if "t" in self._names:
            i = self._names.index("t")
            out[i, :, 0], out[i, :, 1] = rows[i, :, 0], rows[i, :, -1]
        return out.reshape(rows.shape[0], -1)

    def get(self, name: str) -> FloatArray:
        """The drawn samples of ``name`` (``t``: their times), the last partial bucket too."""
        if self._names is None or name not in self._names:
            return np.zeros(0)
        i = self._names.index(name)
        parts = [p[i] for p in self._parts]
        if self._carry is not None and self._carry.shape[1]:
            parts.append(self._buckets(self._carry[:, None, :])[i])
        return np.concatenate(parts) if parts else np.zeros(0)


class Spans:
    """Windows of consecutive flagged samples, fed in order (chunk boundaries do not matter).

    A window runs from its first flagged sample to its last plus ``period_s`` (the samples'
    spacing): a single flagged sample is a window of one period.
    """

    def __init__(self, period_s: float) -> None:
        self.period_s = period_s  # may be set until finish (the scenario read meanwhile)
        self._spans: list[tuple[float, float]] = []  # (first, last flagged sample)
        self._open: float | None = None
        self._last = math.nan

    def add(self, t: np.ndarray, flags: np.ndarray) -> None:
        """Feed samples at times ``t`` [s] and their flags."""
        f = np.asarray(flags, dtype=bool)
        if not f.size:
            return
        continuing = self._open is not None and bool(f[0])
        if self._open is not None and not f[0]:
            self._close(self._last)  # the window left open ended with the previous batch
        edges = np.diff(np.concatenate(([0], f.astype(np.int8), [0])))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
            start = self._open if (continuing and a == 0) else float(t[a])
            self._open, self._last = start, float(t[b - 1])
            if b < f.size:
                self._close(self._last)

    def _close(self, last: float) -> None:
        if self._open is not None:
            self._spans.append((self._open, last))
        self._open = None

    @property
    def windows(self) -> list[tuple[float, float]]:
        """The windows closed so far, (first flagged sample, last + ``period_s``) [s]."""
        return [(a, b + self.period_s) for a, b in self._spans]

    def finish(self) -> list[tuple[float, float]]:
        """The windows, the one still open at the end closed."""
        if self._open is not None:
            self._close(self._last)
        return self.windows


class StreamingWelch:
    """Welch's PSD estimate of a record fed in pieces, holding at most two segments.

    The record's length is not known in advance: up to 2 L samples are kept (L =
    :data:`PSD_TARGET_SEGMENT_S` fs); a record that ends there is estimated whole with
    :func:`psd_segment`'s shorter segment, as ``scipy.signal.welch`` would. Past 2 L the
    segment is L (psd_segment's value for every longer record) and each segment's
    periodogram (Hann window, mean removed, density scaling) is added to a running sum as
    soon as its samples are in, segments starting every L - L // 2 samples (scipy's default
    overlap): the mean of those periodograms is Welch's estimate.
    """

    def __init__(self, fs_hz: float) -> None:
        self.fs = fs_hz
        self.target = max(8, round(PSD_TARGET_SEGMENT_S * fs_hz))
        self._buf = np.zeros(0)
        self._sum: np.ndarray | None = None
        self.segments = 0
        self.n = 0
        self.finite = True

    def add(self, x: np.ndarray) -> None:
        """Append samples (equally spaced at ``fs_hz``)."""
        x = np.asarray(x, np.float64)
        self.n += x.size
        self.finite = self.finite and bool(np.isfinite(x).all())
        self._buf = np.concatenate((self._buf, x))
        if self.n < 2 * self.target:
            return
        length = self.target
        step = length - length // 2
        while self._buf.size >= length:
            _f, p = _welch(self._buf[:length], self.fs, length)
            self._sum = p if self._sum is None else self._sum + p
            self.segments += 1
            self._buf = self._buf[step:]

    def finish(self) -> tuple[np.ndarray, np.ndarray, int, int]:
        """(f [Hz], PSD, segment length, segments) of the whole record."""
        if self._sum is not None:
            f = np.fft.rfftfreq(self.target, 1.0 / self.fs)
            return f, self._sum / self.segments, self.target, self.segments
        nper = psd_segment(self.n, self.fs)
        f, p = _welch(self._buf, self.fs, nper)
        return f, p, nper, max(1, (self.n - nper) // (nper // 2) + 1)


def _welch(x: np.ndarray, fs: float, nper: int) -> tuple[np.ndarray, np.ndarray]:
    """``scipy.signal.welch(x, fs, nperseg=nper, detrend="constant", window="hann")``.

    Periodic Hann window, segments every nper - nper // 2 samples, each segment's mean
    removed, density scaling 1 / (fs Σ w²), one-sided (doubled but for 0 Hz and, for an even
    segment, the Nyquist bin), the mean over segments. Written with numpy: importing
    ``scipy.signal`` costs more than the plots' spectra (about 0.3 s).
    """
    x = np.asarray(x, np.float64)
    nper = int(min(nper, x.size))
    f = np.fft.rfftfreq(nper, 1.0 / fs)
    if nper < 1:
        return f, np.zeros(f.size)
    step = nper - nper // 2
    segs = np.lib.stride_tricks.sliding_window_view(x, nper)[::step]
    win = 0.5 - 0.5 * np.cos(2.0 * math.pi * np.arange(nper) / nper)
    spec = np.fft.rfft((segs - segs.mean(axis=1, keepdims=True)) * win, axis=1)
    p = (spec.real**2 + spec.imag**2).mean(axis=0) / (fs * float(np.sum(win * win)))
    if nper % 2:
        p[1:] *= 2.0
    else:
        p[1:-1] *= 2.0
    return f, p


class PlotData:
    """What the three plots draw, gathered from one pass over the run's columns.

    Parameters
    ----------
    counts : mapping of str to int
        Messages per topic suffix (the first topic of each; sets the buckets).
    summary : dict or None
        The run's review summary: ``kpi_window``, ``timing`` (latency percentiles, deadline,
        unanswered cycles) and ``run`` (mode) are read. None: fed in the same pass as the
        review's own statistics, it is given to :meth:`finish` after the last batch (the
        spectra's window found meanwhile as the review finds it).
    metadata : dict
        The log's metadata records (scenario name and control period); may still be filled
        while the batches come (read with them from the file).
    """

    def __init__(
        self,
        counts: Mapping[str, int],
        summary: Mapping[str, Any] | None,
        metadata: Mapping[str, Mapping[str, str]],
    ) -> None:
        self.metadata = metadata
        self.series = {sfx: Envelope(counts.get(sfx, 0)) for sfx in PLOT_FIELDS}
        self.floating = False
        self.seen: set[str] = set()
        self.period_s = math.nan  # the scenario's (finish); the spans take it then
        self.plant_safe = Spans(math.nan)
        self.ctrl_safe = Spans(math.nan)
        self.acting = Spans(math.nan)
        self.invalid = {p_[2]: Spans(math.nan) for p_ in _PANELS}
        self.lat_counts = np.zeros(_LAT_EDGES_US.size - 1, np.int64)
        self.lat_n = 0
        self.late: list[np.ndarray] = []
        self.unanswered: list[np.ndarray] = []
        self.welch: dict[str, StreamingWelch] = {}
        self.psd_t = [math.nan, math.nan]
        self.summary: Mapping[str, Any] = {}
        self.window: dict[str, Any] = {}
        # the spectra's KPI window: from the summary when given, else found as the review's
        # own (hil.review.stream.Window: the truth held until its start is known)
        self._psd_window: Any = None
        self._cut_known = summary is not None
        if summary is not None:
            self.finish(summary)

    def finish(self, summary: Mapping[str, Any]) -> None:
        """Take the run's summary (KPI window, latency percentiles: what is drawn with the
        samples) once the samples are in; the spectra's window is settled."""
        self.summary = summary
        self.window = dict(summary.get("kpi_window") or {})
        self.period_s = scenario_period_s(self.metadata)
        for spans in (self.plant_safe, self.ctrl_safe, self.acting, *self.invalid.values()):
            spans.period_s = self.period_s
        if self._psd_window is not None:
            self._psd_window.finish()

    def __getstate__(self) -> dict[str, Any]:
        """What a pickle keeps (a finished PlotData drawn in another process,
        :mod:`hil.review.plot_worker`): all but the spectra's window, which only feeds them
        and is done once :meth:`finish` has run."""
        if not self.summary:
            raise ValueError("PlotData: finish() it (the run's summary) before sending it")
        state = self.__dict__.copy()
        state["_psd_window"] = None
        return state

    # ------------------------------------------------------------------ feeding
    def feed(self, batch: ColumnBatch) -> None:
        """Take a batch of the first topic of its suffix (other turbines are not drawn)."""
        if not batch.first or batch.suffix not in PLOT_FIELDS:
            return
        cols = batch.columns
        t = cols["sample_time_ns"] / 1e9
        sfx = batch.suffix
        self.seen.add(sfx)
        if sfx == "truth":
            self._truth(t, cols)
        elif sfx == "sensors":
            self._sensors(t, cols)
        elif sfx == "command":
            self.series[sfx].add({"t": t, **{k: cols[k] for k in PLOT_FIELDS[sfx][:2]}})
            self.ctrl_safe.add(t, cols["mode"] == MODE_SAFE_COMMAND)
        elif sfx == "timing/cycle":
            self._cycles(t, cols)
        else:
            mask = cols["estimates_valid_mask"]
            ok = np.isfinite(mask)
            bits = EST_FEEDFORWARD | EST_WAVE_FORECAST
            acting = np.zeros(mask.size, dtype=bool)
            acting[ok] = (mask[ok].astype(np.int64) & bits) == bits
            self.acting.add(t, acting)

    def _truth(self, t: np.ndarray, cols: Mapping[str, np.ndarray]) -> None:
        self.floating = self.floating or bool(np.nansum(np.abs(cols["floating"])) > 0)
        self.series["truth"].add({"t": t, **{k: cols[k] for k in _TRUTH_FIELDS}})
        spectra = {f: cols[f] * scale for _n, f, scale, _u in _SPECTRA}
        if self._cut_known:  # the summary given first: cut here
            start = self.window.get("from_s")
            keep = t >= (float(start) if isinstance(start, int | float) else 0.0)
            if keep.any():
                self._spectra(t[keep], {f: x[keep] for f, x in spectra.items()})
            return
        if self._psd_window is None:
            from hil.review.core import settle_s_of  # noqa: PLC0415 - core imports this module
            from hil.review.stream import Window  # noqa: PLC0415

            self._psd_window = Window(
                settle_s_of(self.metadata),
                lambda _kind, c: self._spectra(c["t_ns"] / 1e9, c),
            )
        self._psd_window.truth_times(t)
        self._psd_window.feed("truth", {"t_ns": cols["sample_time_ns"], **spectra})

    def _spectra(self, tk: np.ndarray, cols: Mapping[str, np.ndarray]) -> None:
        """Samples of the KPI window (times ``tk`` [s]) into the spectra."""
        if not self.welch:
            dt = float(np.median(np.diff(tk))) if tk.size > 1 else 0.0
            if dt <= 0:
                # one sample in this batch: the control period, else 1 Hz
                period = scenario_period_s(self.metadata)
                dt = period if math.isfinite(period) else 1.0
            self.welch = {f: StreamingWelch(1.0 / dt) for _n, f, _s, _u in _SPECTRA}
            self.psd_t[0] = float(tk[0])
        self.psd_t[1] = float(tk[-1])
        for _name, field, _scale, _unit in _SPECTRA:
            self.welch[field].add(cols[field])

    def _sensors(self, t: np.ndarray, cols: Mapping[str, np.ndarray]) -> None:
        mask = np.nan_to_num(cols["valid_mask"]).astype(np.int64)
        drawn: dict[str, np.ndarray] = {"t": t}
        for _panel, _truth, field, _scale, _label in _PANELS:
            x = cols[field]
            bit = VALID_BITS.get(field)
            if bit is not None:
                valid = (mask & bit) > 0
                x = np.where(valid, x, np.nan)
            drawn[field] = x
            self.invalid[field].add(t, np.isnan(x) & np.isfinite(cols[field]))
        self.series["sensors"].add(drawn)

    def _cycles(self, t: np.ndarray, cols: Mapping[str, np.ndarray]) -> None:
        lat, missed, seq = cols["latency_ns"], cols["deadline_missed"] > 0, cols["seq"]
        self.plant_safe.add(t, cols["safe_state"] > 0)
        answered = np.isfinite(lat) & (lat > 0)
        self.lat_counts += np.histogram(lat[answered] / 1e3, bins=_LAT_EDGES_US)[0]
        self.lat_n += int(answered.sum())
        ok = ~missed & (lat > 0)
        self.series["timing/cycle"].add({"t": seq[ok], "latency_us": lat[ok] / 1e3})
        late = missed & (lat > 0)
        if late.any():
            self.late.append(np.column_stack((seq[late], lat[late] / 1e3)))
        none = missed & ~(lat > 0)
        if none.any():
            self.unanswered.append(seq[none])

    # ------------------------------------------------------------------ results
    def events(self) -> dict[str, Any]:
        """The windows and feedforward starts (:func:`hil.review.core.run_events`)."""
        starts = [a for a, _b in self.acting.finish()]
        return {
            "plant_safe_state": self.plant_safe.finish(),
            "controller_safe_mode": self.ctrl_safe.finish(),
            "feedforward_starts_s": starts,
            "feedforward_start_s": starts[0] if starts else None,
        }

    def label(self) -> str:
        name = self.metadata.get("scenario", {}).get("name") or "run"
        mode = self.metadata.get("run", {}).get("mode", "")
        return f"{name}" + (f" ({mode})" if mode else "")


def logged_counts(path: Path) -> dict[str, int] | None:
    """Messages per topic suffix (its first topic's, in channel order) as a complete run log's
    summary section counts them; None for a file without one (cut short, damaged).

    What sets the plots' min/max buckets before the file is read (:class:`Envelope`), so
    the plots' data can be gathered in the review's own pass.
    """
    from mcap.reader import SeekingReader  # noqa: PLC0415 - only for a review that draws

    try:
        with open(path, "rb") as fh:
            summary = SeekingReader(fh).get_summary()
    except Exception:  # a cut or damaged tail: no summary (the caller reads the file twice)
        return None
    if summary is None or summary.statistics is None:
        return None
    per_channel = summary.statistics.channel_message_counts
    out: dict[str, int] = {}
    for cid in sorted(summary.channels):
        out.setdefault(suffix_of(summary.channels[cid].topic), int(per_channel.get(cid, 0)))
    return out


def with_plot_fields(fields: Mapping[str, Sequence[str]]) -> dict[str, tuple[str, ...]]:
    """``fields`` (topic suffix to columns) and the plots' :data:`PLOT_FIELDS` together."""
    out = {k: tuple(v) for k, v in fields.items()}
    for k, v in PLOT_FIELDS.items():
        out[k] = tuple(dict.fromkeys((*out.get(k, ()), *v)))
    return out


def collect(
    batches: Iterable[ColumnBatch],
    counts: Mapping[str, int],
    summary: Mapping[str, Any],
    metadata: Mapping[str, Mapping[str, str]],
) -> PlotData:
    """A :class:`PlotData` fed every batch; ``counts`` per topic (any turbine's name)."""
    by_suffix: dict[str, int] = {}
    for topic, n in counts.items():
        by_suffix.setdefault(suffix_of(topic), n)
    data = PlotData(by_suffix, summary, metadata)
    for batch in batches:
        data.feed(batch)
    return data


def gather_file(mcap_path: Path, counts: Mapping[str, int]) -> PlotData:
    """The plots' data of a complete run log, read chunk by chunk in a pass of its own (the
    plot worker's, beside the review's pass for the summary: :mod:`hil.review.plot_worker`);
    ``counts`` per topic suffix (:func:`logged_counts`). The KPI window of the spectra is
    found as the review finds it; :meth:`PlotData.finish` takes the summary before drawing."""
    reader = ColumnReader(mcap_path, PLOT_FIELDS)
    data = PlotData(counts, None, reader.info.metadata)
    for batch in reader.batches():
        data.feed(batch)
    return data


# --------------------------------------------------------------------------- drawing


def write_plots(
    data: PlotData, out_dir: Path, blank: Mapping[str, Blank] | None = None
) -> list[Path]:
    """Write ``timeseries.png``, ``timing.png`` and ``psd.png`` into ``out_dir``, on the
    empty figures ``blank`` (:func:`blank_figures`, made ahead) where given.

    Drawn on :class:`matplotlib.figure.Figure` objects saved with the Agg renderer (no
    pyplot, no backend selected: nothing global changes for importers), the time series in
    this process and the other two at the same time in a forked child where there are two
    cores (:func:`_in_two_processes`), with fixed margins
    (a layout engine would measure every label again per figure) and every legend outside
    the data, to the right of its panel. Panels with no data say so.

    * timeseries: truth (bold) and command (dashed steps) over the measured readings (thin,
      transparent, behind), so quantised and noisy sensors do not hide them; a reading whose
      valid bit is clear (dropout) is a gap and shaded; the platform panels say
      "bottom-fixed" for a plant without one. The KPI window's start is a dotted line. The
      plant's safe-state windows are shaded, the controller's safe-mode windows hatched,
      and each start of the feedforward is a dash-dotted vertical line, each with one
      legend entry on the top panel. A run longer than :data:`MAX_POINTS` samples is drawn
      as min/max buckets, one a pixel column (module docstring; the title says so).
    * timing: histogram of every cycle's latency with the deadline, p50 and p99; latency per
      cycle with missed cycles marked (late command at its latency, or no command at all).
    * psd: Welch spectra over the KPI window (Hann, 50 % overlap, segment from
      :func:`psd_segment`, its resolution in each title) of the rotor speed [rpm²/Hz], blade
      pitch [deg²/Hz], platform pitch [deg²/Hz] and tower-base moment [(MN m)²/Hz], over
      :data:`PSD_RANGE_HZ` and :data:`PSD_DECADES` decades under each one's peak, with the
      wave peak, 1P, 3P and the platform's surge and pitch modes marked
      (:func:`spectral_marks`).

    Returns
    -------
    list of Path
        The files written, in the order above.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    label = data.label()
    written = [out_dir / name for name in PLOT_FILES]

    ready = dict(blank or {})

    def figure(name: str) -> Blank:
        return ready.pop(name, None) or _figure(name)

    def timing_and_spectra() -> None:
        _timing_plot(data, label, written[1], figure("timing"))
        _psd_plot(data, label, written[2], figure("psd"))

    _in_two_processes(
        lambda: _timeseries_plot(data, label, written[0], figure("timeseries")),
        timing_and_spectra,
    )
    return written


def _in_two_processes(first: Callable[[], object], second: Callable[[], object]) -> None:
    """Run ``first`` here and ``second`` in a forked child, at once, where that can help.

    The three figures are independent: the time series (about 60 % of the drawing) here,
    the timing and spectra in a child forked after the data is gathered (it shares the data
    copy-on-write and only writes its two files). On two free cores the plots take the
    time series' time instead of the sum (``bench/plot_speed.py``). Serial where fork does
    not exist, on one core, or with Python threads running (a fork copies only the calling
    thread; a lock another thread held would stay held in the child). The child leaves by
    ``os._exit`` (no finalizers or exit handlers of the parent run twice); its failure is
    raised here with its traceback's last line.
    """
    import os  # noqa: PLC0415
    import threading  # noqa: PLC0415

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    if not hasattr(os, "fork") or cores < 2 or threading.active_count() > 1:
        first()
        second()
        return
    import traceback  # noqa: PLC0415

    import matplotlib.figure  # noqa: F401, PLC0415 - imported once, before the fork

    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: draw, report, leave without the parent's exit machinery
        code = 0
        try:
            os.close(read_fd)
            second()
        except BaseException:
            code = 1
            os.write(write_fd, traceback.format_exc().encode(errors="replace")[-4000:])
        finally:
            os._exit(code)
    os.close(write_fd)
    try:
        first()
    finally:
        chunks = []
        while chunk := os.read(read_fd, 65536):
            chunks.append(chunk)
        os.close(read_fd)
        _, status = os.waitpid(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        lines = b"".join(chunks).decode(errors="replace").strip().splitlines()
        raise RuntimeError(
            f"drawing the timing and spectra plots failed: {lines[-1] if lines else status}"
        )


def blank_figures() -> dict[str, Blank]:
    """The three figures, empty (:data:`LAYOUTS`), for :func:`write_plots`.

    Their panels are about a tenth of the drawing (0.03 s of the time series'); the plot
    worker (:mod:`hil.review.plot_worker`) makes them while the run goes, before its data
    comes. Each is drawn on once.
    """
    return {name: _figure(name) for name in LAYOUTS}


def _figure(name: str) -> Blank:
    """The empty figure ``name`` of :data:`LAYOUTS`: its panels stacked, sharing nothing."""
    # Lazy: matplotlib is imported only by a review that draws.
    from matplotlib.figure import Figure  # noqa: PLC0415

    width_in, height_in, rows, margins = LAYOUTS[name]
    fig = Figure(figsize=(width_in, height_in))
    axes = fig.subplots(rows, 1, squeeze=False, gridspec_kw=dict(margins))[:, 0]
    return fig, axes


def _save(fig: Any, path: Path) -> None:
    """Write ``fig`` as a PNG at :data:`DPI` (zlib level 1: the default 6 costs about a fifth of
    the drawing for files a little smaller), its ticks first made cheap to draw
    (:func:`_plain_ticks`)."""
    import matplotlib as mpl  # noqa: PLC0415 - drawing only

    _plain_ticks(fig)
    with mpl.rc_context({"agg.path.chunksize": AGG_CHUNK}):
        fig.savefig(path, dpi=DPI, pil_kwargs={"compress_level": 1})


#: Length of the tick marks and gap to their labels [points] (matplotlib's defaults).
_TICK_PT, _PAD_PT = 3.5, 3.5


def _plain_ticks(fig: Any) -> None:
    """Every axis's ticks drawn as a few plain artists instead of matplotlib's tick objects.

    A matplotlib tick is five artists (two marks, two labels, a grid line), built, copied
    and measured at every draw: on the eight stacked panels of the time series they were
    most of the drawing time. Each axis keeps the positions its locator gives for the final
    limits, drawn as one collection of grid lines, one of tick marks and a plain text per
    label (10⁻³ on a log axis, :func:`_power_of_ten`: matplotlib's own log labels are
    mathtext, whose parser costs about a second to build; a linear axis's values with the
    decimals their step needs); the axis labels are placed beside them. An axis whose locator
    gives nothing (the upper panels of :func:`_one_x_axis`) stays bare.
    """
    import matplotlib as mpl  # noqa: PLC0415 - drawing only
    from matplotlib.collections import LineCollection  # noqa: PLC0415
    from matplotlib.ticker import NullLocator  # noqa: PLC0415
    from matplotlib.transforms import ScaledTranslation  # noqa: PLC0415

    size = mpl.rcParams["ytick.labelsize"]
    for ax in fig.axes:
        box = ax.get_position()
        width_in = box.width * fig.get_figwidth()
        height_in = box.height * fig.get_figheight()
        for name in ("x", "y"):
            axis = ax.xaxis if name == "x" else ax.yaxis
            lim = ax.get_xlim() if name == "x" else ax.get_ylim()
            lo, hi = min(lim), max(lim)
            log = axis.get_scale() == "log"
            tol = 1e-9 * (hi - lo)
            at = [float(v) for v in axis.get_major_locator()() if lo - tol <= v <= hi + tol]
            axis.set_major_locator(NullLocator())
            axis.set_minor_locator(NullLocator())
            if not at:
                continue
            texts = [_power_of_ten(v) for v in at] if log else _linear_labels(at)
            if name == "y":
                trans = ax.get_yaxis_transform()  # x in axes fraction, y in data
                mark = -_TICK_PT / 72.0 / width_in
                segs = [((0.0, v), (1.0, v)) for v in at] + [((mark, v), (0.0, v)) for v in at]
                shift = ScaledTranslation(-(_TICK_PT + _PAD_PT) / 72.0, 0.0, fig.dpi_scale_trans)
                place = {"ha": "right", "va": "center"}
                chars = max(len(t) for t in texts)
                gap_pt = _TICK_PT + _PAD_PT + 0.62 * chars * _font_pt(size) + 4.0
                axis.set_label_coords(-gap_pt / 72.0 / width_in, 0.5)
            else:
                trans = ax.get_xaxis_transform()  # x in data, y in axes fraction
                mark = -_TICK_PT / 72.0 / height_in
                segs = [((v, 0.0), (v, 1.0)) for v in at] + [((v, mark), (v, 0.0)) for v in at]
                shift = ScaledTranslation(0.0, -(_TICK_PT + _PAD_PT) / 72.0, fig.dpi_scale_trans)
                place = {"ha": "center", "va": "top"}
                gap_pt = _TICK_PT + _PAD_PT + 1.2 * _font_pt(size) + 3.0
                axis.set_label_coords(0.5, -gap_pt / 72.0 / height_in)
            # grid lines (light, behind) and tick marks (outside the panel): one artist
            colors = [(0.69, 0.69, 0.69, 0.3)] * len(at) + [(0.0, 0.0, 0.0, 1.0)] * len(at)
            lines = LineCollection(segs, colors=colors, linewidths=0.8, transform=trans,
                                   zorder=0.5, clip_on=False)  # fmt: skip
            ax.add_collection(lines, autolim=False)
            for v, text in zip(at, texts, strict=True):
                xy = (0.0, v) if name == "y" else (v, 0.0)
                ax.text(*xy, text, transform=trans + shift, fontsize=size, **place)


def _font_pt(size: Any) -> float:
    """A font size [points] from a matplotlib size (a number or a name like ``medium``)."""
    from matplotlib.font_manager import FontProperties  # noqa: PLC0415 - drawing only

    return float(FontProperties(size=size).get_size_in_points())


def _linear_labels(at: Sequence[float]) -> list[str]:
    """Labels of evenly spaced ticks on a linear axis: as many decimals as their step needs
    (matplotlib's minus sign)."""
    step = min((abs(b - a) for a, b in itertools.pairwise(at) if b != a), default=0.0)
    dec = max(0, -math.floor(math.log10(step) + 1e-9)) if step > 0 else 0
    out = []
    for v in at:
        text = f"{v:.{dec}f}"
        if float(text) == 0.0:
            text = f"{0.0:.{dec}f}"
        out.append(text.replace("-", "\u2212"))
    return out


_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _power_of_ten(value: float, _pos: int | None = None) -> str:
    """A log axis's tick label: 10ⁿ for a power of ten, else the value (``%g``)."""
    if not value > 0:
        return ""
    exp = math.log10(value)
    if abs(exp - round(exp)) < 1e-9:
        return "10" + str(round(exp)).translate(_SUPERSCRIPT)
    return f"{value:g}"


def _one_x_axis(axes: Sequence[Any], lo: float, hi: float, ticks: Iterable[float]) -> None:
    """Panels stacked over one x range: ticks and labels on the bottom panel only, the others
    with grid lines at the same places and no ticks.

    Not ``sharex``: the shared axes would share their tick locator, and every panel would
    build and measure a full set of ticks (five artists each) that it does not label.
    """
    from matplotlib.ticker import FixedLocator, NullLocator  # noqa: PLC0415 - drawing only

    at = [float(v) for v in ticks if lo <= v <= hi]
    for a in axes:
        a.set_xlim(lo, hi)
    for a in axes[:-1]:
        a.xaxis.set_major_locator(NullLocator())
        a.xaxis.set_minor_locator(NullLocator())
        if at:
            a.vlines(
                at, 0.0, 1.0, transform=a.get_xaxis_transform(), colors="0.69", lw=0.8, alpha=0.3
            )
    axes[-1].xaxis.set_major_locator(FixedLocator(at))


def _few_ticks(axes: Sequence[Any]) -> None:
    """At most about five labelled ticks on each linear y axis (matplotlib's default up to ten):
    each tick is five artists, built and measured when the figure is drawn."""
    from matplotlib.ticker import MaxNLocator  # noqa: PLC0415 - drawing only

    for a in axes:
        a.yaxis.set_major_locator(MaxNLocator(nbins=5))


#: The plain legend's geometry [font sizes] (matplotlib's legend defaults): the key's
#: length, the gap from key to text, a row's height (a line and the spacing between rows),
#: the space above the first row, and the key's half-height of a shaded span.
_KEY_EM, _KEY_GAP_EM, _ROW_EM, _TOP_EM, _SPAN_EM = 2.0, 0.8, 1.5, 0.4, 0.35


def _legend_outside(ax: Any, title: str | None = None) -> None:
    """The panel's legend to its right, in the figure's right margin (never over data).

    Drawn as plain figure artists, a key and a text per entry placed from the panel's
    top-right corner, where every entry is a line (a plotted line, a step line, marks, a
    collection of lines) or a shaded span: matplotlib's legend lays its entries out as
    nested boxes and measures each of their texts again at every draw, a sixth of the time
    series' drawing (eight legends). The margin holds no data, so there is no frame. Any
    other entry (a histogram's filled steps) gets matplotlib's legend, placed the same way.
    """
    from matplotlib.collections import LineCollection, PolyCollection  # noqa: PLC0415
    from matplotlib.lines import Line2D  # noqa: PLC0415 - drawing only

    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return
    if not all(isinstance(h, Line2D | LineCollection | PolyCollection) for h in handles):
        ax.legend(
            loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize="small",
            title=title,
        )  # fmt: skip
        return
    fig = ax.figure
    em = _font_pt("small") / 72.0  # [in]
    box = ax.get_position()
    x0 = (box.x1 + 0.01 * box.width) * fig.get_figwidth()  # [in], as bbox_to_anchor 1.01
    y = box.y1 * fig.get_figheight() - _TOP_EM * em
    rows = ([(None, title)] if title else []) + list(zip(handles, labels, strict=True))
    for handle, text in rows:
        y -= 0.5 * _ROW_EM * em
        if handle is None:  # the title, over the keys
            fig.text(x0, y, text, transform=fig.dpi_scale_trans, fontsize="small", va="center")
        else:
            for key in _legend_keys(handle, x0, x0 + _KEY_EM * em, y, _SPAN_EM * em):
                key.set_transform(fig.dpi_scale_trans)
                fig.add_artist(key)
            fig.text(x0 + (_KEY_EM + _KEY_GAP_EM) * em, y, text, transform=fig.dpi_scale_trans,
                     fontsize="small", va="center")  # fmt: skip
        y -= 0.5 * _ROW_EM * em


def _legend_keys(handle: Any, x0: float, x1: float, y: float, half: float) -> list[Any]:
    """The key artists of a legend entry for ``handle`` between ``x0`` and ``x1`` at height
    ``y`` [in] (a span's key ``half`` high): its line, its mark at the middle, or its shade."""
    import matplotlib as mpl  # noqa: PLC0415 - drawing only
    from matplotlib.collections import LineCollection  # noqa: PLC0415
    from matplotlib.lines import Line2D  # noqa: PLC0415
    from matplotlib.patches import Rectangle  # noqa: PLC0415

    if isinstance(handle, Line2D):
        keys = []
        if handle.get_linestyle() not in ("None", " ", ""):
            keys.append(Line2D([x0, x1], [y, y], color=handle.get_color(),
                               linestyle=handle.get_linestyle(), alpha=handle.get_alpha(),
                               linewidth=handle.get_linewidth()))  # fmt: skip
        if handle.get_marker() not in (None, "None", " ", ""):
            keys.append(Line2D([0.5 * (x0 + x1)], [y], linestyle="None", marker=handle.get_marker(),
                               markersize=handle.get_markersize(), color=handle.get_color(),
                               markerfacecolor=handle.get_markerfacecolor(),
                               markeredgecolor=handle.get_markeredgecolor(),
                               alpha=handle.get_alpha()))  # fmt: skip
        return keys
    if isinstance(handle, LineCollection):
        lines: Any = handle  # its getters return per-line arrays (the stubs say otherwise)
        width = float(lines.get_linewidths()[0])
        offset, dashes = lines.get_linestyles()[0]
        if dashes is not None and mpl.rcParams["lines.scale_dashes"] and width > 0:
            dashes = [d / width for d in dashes]  # the collection's are scaled by its width
        style: Any = "solid" if dashes is None else (offset, dashes)
        return [Line2D([x0, x1], [y, y], color=lines.get_colors()[0], linewidth=width,
                       linestyle=style, alpha=lines.get_alpha())]  # fmt: skip
    face, edge = handle.get_facecolor(), handle.get_edgecolor()  # a PolyCollection
    return [Rectangle((x0, y - half), x1 - x0, 2.0 * half,
                      facecolor=face[0] if len(face) else "none",
                      edgecolor=edge[0] if len(edge) else "none",
                      hatch=handle.get_hatch(), linewidth=0.0)]  # fmt: skip


def _no_data(ax: Any, text: str = "no data") -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, color="0.4")


def _timeseries_plot(data: PlotData, label: str, path: Path, blank: Blank) -> None:
    truth, sensors, command = (data.series[k] for k in ("truth", "sensors", "command"))
    has = {k: k in data.seen for k in ("truth", "sensors", "command")}
    tt, ts, tc = truth.get("t"), sensors.get("t"), command.get("t")
    floating = data.floating
    behind = {"lw": 0.7, "alpha": 0.6, "zorder": 1, "color": "0.45"}
    front = {"lw": 1.3, "zorder": 3}
    cmd_style = {"where": "post", "lw": 1.0, "ls": "--", "zorder": 4}
    fig, axes = blank
    _few_ticks(axes)
    commanded = {
        "blade_pitch_rad": ("blade_pitch_commanded_rad", 180.0 / math.pi),
        "generator_torque_nm": ("generator_torque_commanded_nm", 1e-3),
    }
    for i, (ax, (panel, tfield, mfield, scale, mlabel)) in enumerate(
        zip(axes, _PANELS, strict=True)
    ):
        platform = i >= 5
        if platform and not floating:
            ax.set_ylabel(panel)
            continue
        if has["sensors"]:
            ax.plot(ts, sensors.get(mfield) * scale, label=mlabel or "measured", **behind)
            _spans(ax, data.invalid[mfield].finish(), "invalid", color="tab:red", alpha=0.15)
        if has["truth"]:
            if tfield == "wave_elevation_platform_m":
                ax.plot(
                    tt,
                    truth.get("wave_elevation_gauge_m"),
                    label="at the gauge (truth)",
                    lw=0.9,
                    ls="--",
                    zorder=2,
                )
                ax.plot(tt, truth.get(tfield), label="at the platform", **front)
            else:
                text = "hub wind (truth)" if i == 0 else "truth"
                ax.plot(tt, truth.get(tfield) * scale, label=text, **front)
        if has["command"] and tfield in commanded:
            cfield, cscale = commanded[tfield]
            ax.step(tc, command.get(cfield) * cscale, label="command", **cmd_style)
        ax.set_ylabel(panel)
    axes[-1].set_xlabel("simulated time [s]")
    # A minimum visible span per panel (its unit), so that sensor quantisation and noise
    # around a flat truth (pitch at 0 below rated) stay a thin band, not the whole panel.
    for a, span in zip(axes, (1.0, 0.5, 1.0, 100.0, 0.1, 0.5, 1.0, 0.5), strict=True):
        if a.lines:
            lo, hi = a.get_ylim()
            if hi - lo < span:
                mid = 0.5 * (lo + hi)
                a.set_ylim(mid - 0.5 * span, mid + 0.5 * span)
    start = data.window.get("from_s")
    has_data = [bool(a.lines) for a in axes]
    _mark_run_events(data.events(), [a for a, d in zip(axes, has_data, strict=True) if d])
    for i, (a, drawn) in enumerate(zip(axes, has_data, strict=True)):
        if drawn:
            if isinstance(start, float) and start > 0:
                a.axvline(start, color="0.3", ls=":", lw=0.8, zorder=0)
            _legend_outside(a)
        elif has["truth"] and not floating and i >= 5:
            _no_data(a, "bottom-fixed plant: no platform")
        else:
            _no_data(a)
    if any(has_data):
        from matplotlib.ticker import MaxNLocator  # noqa: PLC0415 - drawing only

        lo = min(a.dataLim.x0 for a, d in zip(axes, has_data, strict=True) if d)
        hi = max(a.dataLim.x1 for a, d in zip(axes, has_data, strict=True) if d)
        if hi > lo:
            _one_x_axis(axes, lo, hi, MaxNLocator(nbins=8).tick_values(lo, hi))
    note = ""
    if isinstance(start, float) and start > 0:
        note = f"; KPIs from t = {start:.1f} s (dotted line)"
    if truth.bucket > 1:
        note += f"; min/max of every {truth.bucket} samples"
    fig.suptitle(
        f"{label}: time series\n(truth bold, command dashed, measured grey{note})",
        fontsize="medium",
    )
    _save(fig, path)


def _mark_run_events(ev: Mapping[str, Any], axes: Sequence[Any]) -> None:
    """Shade the safe-state and safe-mode windows and draw the feedforward's start on
    ``axes``; the legend entries go on the first (top) panel only."""
    for i, a in enumerate(axes):
        first = i == 0
        _spans(a, ev["plant_safe_state"], "plant safe state" if first else None,
               color="tab:purple", alpha=0.18, zorder=0)  # fmt: skip
        _spans(a, ev["controller_safe_mode"], "controller safe mode" if first else None,
               facecolor="none", edgecolor="tab:orange", hatch="//", zorder=0)  # fmt: skip
        starts = ev["feedforward_starts_s"]
        if starts:
            text = f"feedforward on (t = {starts[0]:.1f} s)" if first else None
            a.add_collection(
                _lines_across(a, starts, color="tab:green", ls="-.", lw=1.2, zorder=2, label=text),
                autolim=False,
            )


def _spans(
    ax: Any, windows: Sequence[tuple[float, float]], label: str | None, **style: Any
) -> None:
    """Shade the x ``windows`` [(from, to)] over the panel's height: one artist for all
    (``axvspan`` builds a patch each), one legend entry ``label``."""
    if not windows:
        return
    from matplotlib.collections import PolyCollection  # noqa: PLC0415 - drawing only

    verts = [((lo, 0.0), (lo, 1.0), (hi, 1.0), (hi, 0.0)) for lo, hi in windows]
    ax.add_collection(
        PolyCollection(
            verts, transform=ax.get_xaxis_transform(), linewidths=0, label=label, **style
        ),
        autolim=False,
    )


def _lines_across(ax: Any, xs: Sequence[float], **style: Any) -> Any:
    """Vertical lines at ``xs`` over the panel's height, as one collection."""
    from matplotlib.collections import LineCollection  # noqa: PLC0415 - drawing only

    segs = [((x, 0.0), (x, 1.0)) for x in xs]
    return LineCollection(segs, transform=ax.get_xaxis_transform(), **style)


def _mark_safe_state_cycles(data: PlotData, timing: Mapping[str, Any], ax: Any) -> None:
    """Shade the plant's safe-state windows on a per-cycle axis (the windows' seconds over
    the control period), the watchdog's trips and recoveries in the legend."""
    period = data.period_s
    if not (math.isfinite(period) and period > 0):
        return
    trips, back = timing.get("watchdog_trips"), timing.get("watchdog_recoveries")
    label = "plant safe state" + (
        f" ({trips} trip(s), {back} recovered)" if isinstance(trips, int) else ""
    )
    windows = [(lo / period, hi / period) for lo, hi in data.events()["plant_safe_state"]]
    _spans(ax, windows, label, color="tab:purple", alpha=0.18, zorder=0)


def _timing_plot(data: PlotData, label: str, path: Path, blank: Blank) -> None:
    timing = data.summary.get("timing") or {}
    pct = timing.get("latency_us") or {}
    deadline = timing.get("deadline_us")
    deadline = float(deadline) if isinstance(deadline, int | float) else math.nan
    unanswered = sum(int(u.size) for u in data.unanswered)
    late = np.concatenate(data.late) if data.late else np.zeros((0, 2))
    n_cycles = data.lat_n + unanswered
    fig, (a0, a1) = blank
    mode = data.metadata.get("run", {}).get("mode", "")
    enforced = mode not in ("lockstep", "inprocess")
    dl_label = f"deadline {deadline:.0f} us" + ("" if enforced else f" (not enforced in {mode})")
    if n_cycles:
        counts = data.lat_counts
        nz = np.flatnonzero(counts)
        if nz.size:
            # display bins of whole fixed bins (about 100 over the range seen, the deadline
            # included): regrouping parts of bins would alias into a comb
            centers = np.sqrt(_LAT_EDGES_US[:-1] * _LAT_EDGES_US[1:])
            i0, i1 = int(nz[0]), int(nz[-1]) + 1
            if deadline > 0:
                i1 = max(i1, int(np.searchsorted(_LAT_EDGES_US, deadline)) + 1)
            i1 = min(i1, _LAT_EDGES_US.size - 1)
            step = max(1, -(-(i1 - i0) // 100))
            edges = np.unique(np.minimum(np.arange(i0, i1 + step, step), _LAT_EDGES_US.size - 1))
            bins = _LAT_EDGES_US[edges]
            # one artist for the whole histogram (hist draws a patch per bin)
            per_bin = np.histogram(centers[nz], bins=bins, weights=counts[nz])[0]
            a0.stairs(
                per_bin,
                bins,
                fill=True,
                color="tab:blue",
                label=f"{data.lat_n} cycles with a command",
            )
            a0.set_xscale("log")
        for q, color in (("p50", "tab:green"), ("p99", "tab:orange")):
            v = pct.get(q)
            if isinstance(v, int | float) and math.isfinite(v):
                a0.axvline(v, color=color, ls="--", label=f"{q} = {v:.0f} us")
            else:
                share = 100.0 * unanswered / n_cycles
                a0.plot([], [], " ", label=f"{q} = inf ({share:.2g} % of cycles had no command)")
        if deadline > 0:
            a0.axvline(deadline, color="tab:red", lw=1.5, label=dl_label)
        a0.set_yscale("log")
        _legend_outside(a0)
        ok = data.series["timing/cycle"]
        a1.plot(
            ok.get("t"), ok.get("latency_us"), ".", ms=2, color="tab:blue", label="command in time"
        )
        a1.set_yscale("log")
        if late.size:
            a1.plot(
                late[:, 0],
                late[:, 1],
                "x",
                color="tab:red",
                ms=6,
                label=f"missed: command late ({late.shape[0]})",
            )
        if unanswered:
            seen = [float(_LAT_EDGES_US[nz[-1] + 1])] if nz.size else [0.0]
            top = max(*seen, deadline if deadline > 0 else 0.0) * 1.05
            seqs = np.concatenate(data.unanswered)
            a1.plot(
                seqs,
                np.full(seqs.size, top),
                "v",
                color="darkred",
                ms=6,
                label=f"missed: no command by the next tick ({unanswered})",
            )
        if deadline > 0:
            a1.axhline(deadline, color="tab:red", lw=1.2, label=dl_label)
        _mark_safe_state_cycles(data, timing, a1)
        _legend_outside(a1)
    else:
        _no_data(a0)
        _no_data(a1)
    n_missed = int(late.shape[0]) + unanswered
    a0.set_title(
        f"{label}: sensor-to-command latency of all {n_cycles} cycles "
        f"({n_missed} missed, {unanswered} without a command)",
        loc="left",
        fontsize="medium",
    )
    a0.set_xlabel("sensor-to-command latency [us]")
    a0.set_ylabel("cycles [1]")
    a1.set_title(
        "latency per cycle"
        + (
            f" (min/max of every {data.series['timing/cycle'].bucket} cycles in time)"
            if data.series["timing/cycle"].bucket > 1
            else ""
        )
    )
    a1.set_xlabel("cycle [1]")
    a1.set_ylabel("latency [us]")
    _save(fig, path)


def _psd_plot(data: PlotData, label: str, path: Path, blank: Blank) -> None:
    fig, axes = blank
    title = f"{label}: power spectral densities"
    n = next(iter(data.welch.values())).n if data.welch else 0
    marks = spectral_marks(data.summary, data.metadata)
    if n >= 8:
        shown = False
        drawn = []
        fs = next(iter(data.welch.values())).fs
        lo_hz, hi_hz = PSD_RANGE_HZ[0], min(PSD_RANGE_HZ[1], 0.5 * fs)
        for ax, (name, field, _scale, unit) in zip(axes, _SPECTRA, strict=True):
            ax.set_ylabel(f"{name}\n[{unit}]")
            if field == "platform_pitch_rad" and not data.floating:
                _no_data(ax, "bottom-fixed plant: no platform")
                continue
            w = data.welch[field]
            if not w.finite:
                _no_data(ax, "not logged")
                continue
            f, pxx, nper, n_seg = w.finish()
            if not shown:
                t0, t1 = data.psd_t
                title += (
                    f", t = {t0:.4g}-{t1:.4g} s (KPI window)\nWelch, Hann window, segment "
                    f"{nper / w.fs:.4g} s, resolution {w.fs / nper:.3g} Hz, {n_seg} segments "
                    "with 50 % overlap"
                )
                shown = True
            pos = pxx[1:] > 0
            if not pos.any():
                _no_data(ax, f"{name} constant over the window: no spectrum")
                continue
            fp, pp = f[1:][pos], pxx[1:][pos]
            ax.loglog(fp, pp, lw=1.0, color="tab:blue")
            inside = (fp >= lo_hz) & (fp <= hi_hz)
            peak = float(pp[inside].max()) if inside.any() else float(pp.max())
            ax.set_ylim(peak * 10.0**-PSD_DECADES, peak * 3.0)
            drawn.append(ax)
        if drawn:
            for ax in axes:
                ax.set_xscale("log")
            decades = range(math.ceil(math.log10(lo_hz)), math.floor(math.log10(hi_hz)) + 1)
            _one_x_axis(axes, lo_hz, hi_hz, [10.0**k for k in decades])
            _mark_frequencies(marks, drawn)
    else:
        for ax, (name, _field, _scale, unit) in zip(axes, _SPECTRA, strict=True):
            ax.set_ylabel(f"{name}\n[{unit}]")
            _no_data(ax)
    axes[-1].set_xlabel("frequency [Hz]")
    fig.suptitle(title, fontsize="medium")
    _save(fig, path)


#: Line style of each kind of mark on the spectra, in :func:`spectral_marks`' order.
_MARK_STYLES = {
    "wave": {"color": "tab:cyan", "ls": "-"},
    "1P": {"color": "tab:red", "ls": "--"},
    "3P": {"color": "tab:red", "ls": ":"},
    "platform surge": {"color": "tab:green", "ls": "--"},
    "platform pitch": {"color": "tab:purple", "ls": "--"},
}


def _mark_frequencies(marks: Sequence[tuple[str, float]], axes: Sequence[Any]) -> None:
    """A vertical line at each marked frequency on every drawn spectrum; the legend (outside,
    right of the top one) names them."""
    for i, ax in enumerate(axes):
        for text, hz in marks:
            style = next((v for k, v in _MARK_STYLES.items() if text.startswith(k)), {})
            ax.axvline(hz, lw=1.1, alpha=0.8, zorder=0, label=text if i == 0 else None, **style)
    if marks:
        _legend_outside(axes[0], title="marked")
