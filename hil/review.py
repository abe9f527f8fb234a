"""Review of one run from its MCAP log alone: summary JSON, KPI tables and plots.

Summary keys (all numbers, ``null`` where a channel was missing)
----------------------------------------------------------------
``timing``
    ``latency_us.{p50,p99,p999,max}`` sensor-to-command latency [us], numpy linear
    percentiles of every ``timing/cycle`` ``latency_ns`` > 0 (cycles whose command never
    arrived log 0 and are left out; they are counted in ``deadline_misses``);
    ``latency_source`` says which channel they came from (``"timing/cycle"``, or
    ``"timing/summary"`` when no cycle was logged); ``latency_us_plant`` the plant's own
    histogram percentiles (about 2 % bin width) from the last ``timing/summary``;
    ``cycles``, ``deadline_misses``, ``commands_held``, ``commands_rejected``,
    ``commands_late`` [1] and ``safe_state`` (0/1) from the final summary (``final`` = 1),
    else derived from ``timing/cycle``; ``cycles_logged`` [1] cycle messages in the file;
    ``sim_seconds_per_wall_second`` [1]; ``controller_compute_us.{p50,p99,max}`` [us] of
    ``controller/status`` ``compute_time_ns``; ``complete`` False when the run has no
    final summary (crash), counts then come from the logged cycles.
``kpi``
    ``mean_power_w`` [W], ``rotor_speed_mean_rad_s``, ``rotor_speed_std_rad_s`` [rad/s],
    ``pitch_travel_deg_s`` [deg/s] (truth ``blade_pitch_rad`` vs ``sample_time_ns``),
    ``generator_torque_mean_nm`` [N m, HSS], ``thrust_mean_n``, ``thrust_max_n`` [N],
    ``shaft_del_nm`` [N m] damage-equivalent range of the low-speed-shaft torque
    ``shaft_torque_nm`` (truth), ``tower_base_del_nm`` [N m] the same for the tower-base
    fore-aft bending moment ``tower_base_moment_nm``, both by rainflow counting with Wöhler
    exponent m = ``shaft_del_wohler_m`` = 4 at f_eq = ``del_n_eq_hz`` = 1 Hz over the record:
    DEL = (Σ n_i S_i^m / (f_eq T))^(1/m), T the record length (the issue's "1 Hz equivalent,
    600 s" is this with T = 600 s for a 600 s load case; shorter records give the same
    damage rate, so DELs of runs of different lengths compare),
    ``thrust_del_n`` [N] the same for rotor thrust (m = 4),
    ``platform_pitch_mean_deg``, ``platform_pitch_std_deg`` [deg], ``surge_mean_m``,
    ``surge_std_m`` [m] of the true platform motion (truth; 0 for a bottom-fixed plant).
``run``
    the ``"run"`` metadata record (strings) plus ``turbine``, ``duration_s`` [s] (span of
    ``sample_time_ns`` over all topics), ``messages`` (count per topic suffix),
    ``truncated`` and ``error`` (what the reader stopped on).
``scenario``
    ``name`` and ``config`` (the record's ``json`` parsed), ``null`` fields when absent.
``estimator``
    Advanced controllers (``controller/status`` estimates against ``truth`` at the same
    sample time): ``wind_speed_error_mean_pct`` [%] 100 mean(Û − U)/mean(U),
    ``wind_speed_error_rms_m_s`` [m/s], ``platform_pitch_rate_error_rms_rad_s`` [rad/s],
    ``platform_surge_velocity_error_rms_m_s`` [m/s], ``degraded_fraction`` [-] of cycles with
    ``estimator_degraded``; ``null`` when no estimate was published.
``forecast``
    ``vaf_pct`` [%] of the published wave forecast against the true platform elevation at the
    time each forecast is for, 100 (1 − var(η − η̂)/var(η)); ``samples`` [1] distinct forecasts.
``controller``
    ``compute_us.{p50,p99,max}`` [us] of the status ``compute_time_ns`` (as in ``timing``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from rich.table import Table
from scipy.signal import welch

from bus_schemas.messages import (
    EST_PLATFORM_PITCH_RATE,
    EST_PLATFORM_SURGE_VELOCITY,
    EST_WAVE_FORECAST,
    EST_WIND_SPEED,
    VALID_WAVE_GAUGE,
)
from hil import kpi
from hil.mcap_log import RunData, read_run

if TYPE_CHECKING:
    from rich.console import Console

FloatArray = npt.NDArray[np.float64]

#: Wöhler exponent used for the shaft (and thrust) DEL in the summary.
SHAFT_WOHLER_M = 4.0
#: Equivalent-load frequency of the DELs in the summary [Hz].
DEL_N_EQ_HZ = 1.0

PLOT_FILES = ("timeseries.png", "timing.png", "psd.png")


# --------------------------------------------------------------------------- helpers


def _col(msgs: Sequence[dict[str, Any]], name: str) -> FloatArray:
    """One field of a message list as a float array (missing values as nan)."""
    return np.array([m.get(name, math.nan) for m in msgs], dtype=np.float64)


def _t_s(msgs: Sequence[dict[str, Any]]) -> FloatArray:
    """Simulated time of each message [s]."""
    return _col(msgs, "sample_time_ns") / 1e9


def _clean(obj: Any) -> Any:
    """Recursively replace non-finite floats by None and numpy scalars by Python ones."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        obj = float(obj)
    return kpi.finite_or_none(obj)


def _suffix(topic: str) -> str:
    """``fowt/<turbine>/controller/status`` -> ``controller/status``."""
    parts = topic.split("/", 2)
    return parts[2] if len(parts) == 3 else topic


def _turbine(run: RunData) -> str | None:
    for topic in run.messages:
        parts = topic.split("/", 2)
        if len(parts) == 3:
            return parts[1]
    return None


def _int_or_none(v: Any) -> int | None:
    return None if v is None else int(v)


# --------------------------------------------------------------------------- summary


def _timing(run: RunData) -> dict[str, Any]:
    cycles = run.topic("timing/cycle")
    summaries = run.topic("timing/summary")
    status = run.topic("controller/status")
    final = next((s for s in reversed(summaries) if int(s.get("final", 0)) == 1), None)
    last_summary = final if final is not None else (summaries[-1] if summaries else None)

    lat_ns = _col(cycles, "latency_ns")
    lat_ns = lat_ns[np.isfinite(lat_ns) & (lat_ns > 0)]
    plant_lat = (
        {
            "p50": last_summary.get("latency_p50_us"),
            "p99": last_summary.get("latency_p99_us"),
            "p999": last_summary.get("latency_p999_us"),
            "max": last_summary.get("latency_max_us"),
        }
        if last_summary is not None
        else {"p50": None, "p99": None, "p999": None, "max": None}
    )
    if lat_ns.size or last_summary is None:
        latency: dict[str, Any] = dict(kpi.latency_percentiles_us(lat_ns))
        latency_source = "timing/cycle"
    else:
        latency = dict(plant_lat)
        latency_source = "timing/summary"

    out: dict[str, Any] = {
        "complete": final is not None,
        "latency_us": latency,
        "latency_source": latency_source,
        "latency_us_plant": plant_lat,
        "cycles_logged": len(cycles),
    }
    if final is not None:
        out.update(
            cycles=int(final["cycles"]),
            deadline_misses=int(final["deadline_misses"]),
            commands_held=int(final["commands_held"]),
            commands_rejected=int(final["commands_rejected"]),
            commands_late=int(final["commands_late"]),
            safe_state=int(final["safe_state"]),
            safe_state_cycles=int(final.get("safe_state_cycles", 0)),
            faults_injected=int(final.get("faults_injected", 0)),
            sim_seconds_per_wall_second=float(final["sim_seconds_per_wall_second"]),
        )
    else:
        # Crashed run: count what the logged cycles show. Rejected and late commands are not
        # in the cycle record; the last running summary (if any) gives a lower bound.
        def _sum(name: str) -> int:
            return int(sum(int(c.get(name, 0)) for c in cycles))

        sample = _col(cycles, "sample_time_ns")
        wall = _col(cycles, "publish_time_ns")
        speed = math.nan
        if len(cycles) >= 2 and wall[-1] > wall[0]:
            speed = float((sample[-1] - sample[0]) / (wall[-1] - wall[0]))
        out.update(
            cycles=len(cycles),
            deadline_misses=_sum("deadline_missed"),
            commands_held=_sum("command_held"),
            commands_rejected=_int_or_none(
                last_summary.get("commands_rejected") if last_summary else None
            ),
            commands_late=_int_or_none(last_summary.get("commands_late") if last_summary else None),
            safe_state=max((int(c.get("safe_state", 0)) for c in cycles), default=0),
            sim_seconds_per_wall_second=speed,
        )
    out["controller_compute_us"] = kpi.percentiles(
        _col(status, "compute_time_ns") / 1e3, [50.0, 99.0], ["p50", "p99", "max"]
    )
    return out


def _kpis(run: RunData) -> dict[str, Any]:
    truth = run.topic("truth")
    sensors = run.topic("sensors")
    t = _t_s(truth)
    rotor = _col(truth, "rotor_speed_rad_s")
    platform_pitch = _col(truth, "platform_pitch_rad")
    if truth and not np.isfinite(platform_pitch).all():  # a log of PlantState version 1
        platform_pitch = _col(sensors, "platform_pitch_measured_rad")
    surge = _col(truth, "platform_surge_m")
    return {
        "mean_power_w": kpi.mean_power_w(_col(truth, "electrical_power_w")),
        "rotor_speed_mean_rad_s": kpi.mean(rotor),
        "rotor_speed_std_rad_s": kpi.std(rotor),
        "pitch_travel_deg_s": kpi.pitch_travel_deg_s(t, _col(truth, "blade_pitch_rad")),
        "generator_torque_mean_nm": kpi.mean(_col(truth, "generator_torque_nm")),
        "thrust_mean_n": kpi.mean(_col(truth, "rotor_thrust_n")),
        "thrust_max_n": kpi.maximum(_col(truth, "rotor_thrust_n")),
        "shaft_del_nm": kpi.damage_equivalent_load(
            _col(truth, "shaft_torque_nm"), t, SHAFT_WOHLER_M, DEL_N_EQ_HZ
        ),
        "tower_base_del_nm": kpi.damage_equivalent_load(
            _col(truth, "tower_base_moment_nm"), t, SHAFT_WOHLER_M, DEL_N_EQ_HZ
        ),
        "thrust_del_n": kpi.damage_equivalent_load(
            _col(truth, "rotor_thrust_n"), t, SHAFT_WOHLER_M, DEL_N_EQ_HZ
        ),
        "shaft_del_wohler_m": SHAFT_WOHLER_M,
        "del_n_eq_hz": DEL_N_EQ_HZ,
        "platform_pitch_mean_deg": math.degrees(kpi.mean(platform_pitch)),
        "platform_pitch_std_deg": math.degrees(kpi.std(platform_pitch)),
        "surge_mean_m": kpi.mean(surge),
        "surge_std_m": kpi.std(surge),
        "tower_base_moment_mean_nm": kpi.mean(_col(truth, "tower_base_moment_nm")),
    }


def _estimates(run: RunData) -> dict[str, Any]:
    """Estimator, forecast and compute-time KPIs of an advanced controller's status messages.

    The truth (``truth`` channel) is linearly interpolated to each status sample time.
    Wind: error e = Û − U (rotor-effective wind, ``wind_speed_m_s``) over the cycles whose
    status sets ``EST_WIND_SPEED``: mean 100 mean(e)/mean(U) [%] and RMS [m/s]. Forecast: each
    distinct (``wave_forecast_time_ns``, forecast) pair with ``EST_WAVE_FORECAST`` set is
    compared with the true platform elevation ``wave_elevation_platform_m`` at the time it is
    a forecast for; VAF = 100 (1 − var(η − η̂)/var(η)) [%] over the pairs inside the record.
    """
    status = run.topic("controller/status")
    truth = run.topic("truth")
    nan = math.nan
    est: dict[str, Any] = {
        "wind_speed_error_mean_pct": nan,
        "wind_speed_error_rms_m_s": nan,
        "platform_pitch_rate_error_rms_rad_s": nan,
        "platform_surge_velocity_error_rms_m_s": nan,
        "degraded_fraction": nan,
    }
    fc: dict[str, Any] = {"vaf_pct": nan, "samples": 0}
    compute = kpi.percentiles(
        _col(status, "compute_time_ns") / 1e3, [50.0, 99.0], ["p50", "p99", "max"]
    )
    out = {"estimator": est, "forecast": fc, "controller": {"compute_us": compute}}
    if not status or not truth:
        return out
    mask = _col(status, "estimates_valid_mask")
    if not np.isfinite(mask).all():  # a log of ControllerStatus version 1
        return out
    m = mask.astype(np.int64)
    ts = _col(status, "sample_time_ns")
    tt = _col(truth, "sample_time_ns")
    inside = (ts >= tt[0]) & (ts <= tt[-1])
    est["degraded_fraction"] = float(np.mean(_col(status, "estimator_degraded") > 0))

    def _err(bit: int, est_name: str, truth_name: str) -> FloatArray:
        sel = inside & ((m & bit) != 0)
        ref = np.interp(ts[sel], tt, _col(truth, truth_name))
        err: FloatArray = _col(status, est_name)[sel] - ref
        return err

    wind_sel = inside & ((m & EST_WIND_SPEED) != 0)
    if wind_sel.any():
        u_true = np.interp(ts[wind_sel], tt, _col(truth, "wind_speed_m_s"))
        e = _col(status, "wind_speed_estimated_m_s")[wind_sel] - u_true
        est["wind_speed_error_mean_pct"] = float(100.0 * np.mean(e) / np.mean(u_true))
        est["wind_speed_error_rms_m_s"] = float(np.sqrt(np.mean(e * e)))
    for key, bit, name, tname in (
        (
            "platform_pitch_rate_error_rms_rad_s",
            EST_PLATFORM_PITCH_RATE,
            "platform_pitch_rate_estimated_rad_s",
            "platform_pitch_rate_rad_s",
        ),
        (
            "platform_surge_velocity_error_rms_m_s",
            EST_PLATFORM_SURGE_VELOCITY,
            "platform_surge_velocity_estimated_m_s",
            "platform_surge_velocity_m_s",
        ),
    ):
        e = _err(bit, name, tname)
        if e.size:
            est[key] = float(np.sqrt(np.mean(e * e)))
    f_sel = (m & EST_WAVE_FORECAST) != 0
    if f_sel.any():
        f_t = _col(status, "wave_forecast_time_ns")[f_sel]
        f_v = _col(status, "wave_elevation_forecast_m")[f_sel]
        keep = np.ones(f_t.size, dtype=bool)
        keep[1:] = f_t[1:] != f_t[:-1]  # a forecast is held between forecaster calls
        f_t, f_v = f_t[keep], f_v[keep]
        ok = (f_t >= tt[0]) & (f_t <= tt[-1])
        if ok.sum() >= 2:
            eta = np.interp(f_t[ok], tt, _col(truth, "wave_elevation_platform_m"))
            fc["samples"] = int(ok.sum())
            var = float(np.var(eta))
            if var > 0.0:
                fc["vaf_pct"] = float(100.0 * (1.0 - np.var(eta - f_v[ok]) / var))
    # AR/ESPRIT forecaster: fits stabilised and forecasts guarded (counts since the start)
    for key, name in (("unstable_fits", "forecast_unstable_fits"), ("guarded", "forecast_guarded")):
        col = _col(status, name)
        fc[key] = int(np.nanmax(col)) if col.size and np.isfinite(col).any() else 0
    return out


def _scenario(run: RunData) -> dict[str, Any]:
    rec = run.metadata.get("scenario", {})
    out: dict[str, Any] = {"name": rec.get("name"), "config": None}
    raw = rec.get("json")
    if raw:
        try:
            out["config"] = json.loads(raw)
        except ValueError as exc:
            out["config_error"] = f"{type(exc).__name__}: {exc}"
    return out


def _run_info(run: RunData) -> dict[str, Any]:
    t_min, t_max = math.inf, -math.inf
    for msgs in run.messages.values():
        if msgs:
            ts = _col(msgs, "sample_time_ns")
            ts = ts[np.isfinite(ts)]
            if ts.size:
                t_min = min(t_min, float(ts.min()))
                t_max = max(t_max, float(ts.max()))
    duration = (t_max - t_min) / 1e9 if t_max >= t_min else math.nan
    info: dict[str, Any] = dict(run.metadata.get("run", {}))
    info.update(
        turbine=_turbine(run),
        duration_s=duration,
        messages={_suffix(k): len(v) for k, v in run.messages.items()},
        truncated=run.truncated,
        error=run.error,
    )
    return info


def summarize(run: RunData) -> dict[str, Any]:
    """Summary of one run from the MCAP contents alone (JSON-ready, nan as None).

    Parameters
    ----------
    run : RunData
        Output of :func:`hil.mcap_log.read_run` (possibly truncated).

    Returns
    -------
    dict
        ``{"timing", "kpi", "run", "scenario"}``; keys and units in the module docstring.
    """
    summary = {
        "timing": _timing(run),
        "kpi": _kpis(run),
        "run": _run_info(run),
        "scenario": _scenario(run),
        **_estimates(run),
    }
    cleaned: dict[str, Any] = _clean(summary)
    return cleaned


# --------------------------------------------------------------------------- plots


def _no_data(ax: Any) -> None:
    ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes)


def write_plots(run: RunData, out_dir: Path) -> list[Path]:
    """Write ``timeseries.png``, ``timing.png`` and ``psd.png`` into ``out_dir``.

    Uses the Agg backend (selected here, not at import). Panels with no data say so.

    Returns
    -------
    list of Path
        The files written, in the order above.
    """
    # Lazy: selecting a backend at import would be a global side effect for importers.
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    out_dir.mkdir(parents=True, exist_ok=True)
    truth = run.topic("truth")
    sensors = run.topic("sensors")
    command = run.topic("command")
    cycles = run.topic("timing/cycle")
    written: list[Path] = []

    # --- time series
    tt, ts, tc = _t_s(truth), _t_s(sensors), _t_s(command)
    fig, axes = plt.subplots(8, 1, figsize=(11, 18), sharex=True)
    ax = axes[0]
    if truth:
        ax.plot(tt, _col(truth, "wind_speed_m_s"), label="hub wind (truth)")
    if sensors:
        ax.plot(ts, _col(sensors, "wind_speed_measured_m_s"), label="nacelle anemometer", lw=0.7)
    ax.set_ylabel("wind speed [m/s]")
    ax = axes[1]
    if truth:
        ax.plot(tt, _col(truth, "rotor_speed_rad_s") * 30.0 / math.pi, label="truth")
    if sensors:
        ax.plot(
            ts,
            _col(sensors, "rotor_speed_measured_rad_s") * 30.0 / math.pi,
            label="measured",
            lw=0.7,
        )
    ax.set_ylabel("rotor speed [rpm]")
    ax = axes[2]
    if truth:
        ax.plot(tt, np.degrees(_col(truth, "blade_pitch_rad")), label="truth")
    if sensors:
        ax.plot(ts, np.degrees(_col(sensors, "blade_pitch_measured_rad")), label="measured")
    if command:
        ax.step(
            tc,
            np.degrees(_col(command, "blade_pitch_commanded_rad")),
            where="post",
            label="commanded",
            lw=0.8,
        )
    ax.set_ylabel("blade pitch [deg]")
    ax = axes[3]
    if truth:
        ax.plot(tt, _col(truth, "generator_torque_nm") / 1e3, label="truth")
    if command:
        ax.step(
            tc,
            _col(command, "generator_torque_commanded_nm") / 1e3,
            where="post",
            label="commanded",
            lw=0.8,
        )
    ax.set_ylabel("generator torque [kN m]")
    ax = axes[4]
    if truth:
        ax.plot(tt, _col(truth, "electrical_power_w") / 1e6, label="truth")
    ax.set_ylabel("electrical power [MW]")
    floating = bool(truth) and bool(np.nansum(np.abs(_col(truth, "floating"))) > 0)
    ax = axes[5]
    if floating:
        ax.plot(tt, np.degrees(_col(truth, "platform_pitch_rad")), label="truth")
    if floating and sensors:
        ax.plot(
            ts, np.degrees(_col(sensors, "platform_pitch_measured_rad")), label="measured", lw=0.7
        )
    ax.set_ylabel("platform pitch [deg]")
    ax = axes[6]
    if floating:
        ax.plot(tt, _col(truth, "platform_surge_m"), label="truth")
    if floating and sensors:
        ax.plot(ts, _col(sensors, "platform_surge_measured_m"), label="measured", lw=0.7)
    ax.set_ylabel("platform surge [m]")
    ax = axes[7]
    if floating:
        ax.plot(tt, _col(truth, "wave_elevation_platform_m"), label="at the platform")
        ax.plot(tt, _col(truth, "wave_elevation_gauge_m"), label="at the gauge (truth)", lw=0.8)
    if floating and sensors:
        gauge = _col(sensors, "wave_elevation_gauge_measured_m")
        valid = (_col(sensors, "valid_mask").astype(np.int64) & VALID_WAVE_GAUGE) > 0
        ax.plot(ts, np.where(valid, gauge, np.nan), label="gauge (measured)", lw=0.6)
    ax.set_ylabel("wave elevation [m]")
    ax.set_xlabel("simulated time [s]")
    for a in axes:
        if a.lines:
            a.legend(loc="upper right", fontsize="small")
        else:
            _no_data(a)
        a.grid(True, alpha=0.3)
    fig.suptitle("Run time series")
    fig.tight_layout()
    path = out_dir / "timeseries.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    written.append(path)

    # --- timing
    lat_ns = _col(cycles, "latency_ns")
    ok = np.isfinite(lat_ns) & (lat_ns > 0)
    lat_us = lat_ns[ok] / 1e3
    fig, (a0, a1) = plt.subplots(2, 1, figsize=(10, 8))
    if lat_us.size:
        a0.hist(lat_us, bins=min(100, max(10, lat_us.size // 10)), color="tab:blue")
        pct = kpi.latency_percentiles_us(lat_ns[ok])
        for name, color in (("p50", "tab:green"), ("p99", "tab:red")):
            a0.axvline(pct[name], color=color, ls="--", label=f"{name} = {pct[name]:.1f} us")
        a0.set_yscale("log")
        a0.legend()
        seq = _col(cycles, "seq")[ok]
        a1.plot(seq, lat_us, ".", ms=2)
        missed = _col(cycles, "deadline_missed") > 0
        if missed.any():
            for x in _col(cycles, "seq")[missed]:
                a1.axvline(x, color="tab:red", alpha=0.3, lw=0.5)
    else:
        _no_data(a0)
        _no_data(a1)
    a0.set_xlabel("sensor-to-command latency [us]")
    a0.set_ylabel("cycles [1]")
    a1.set_xlabel("cycle [1]")
    a1.set_ylabel("latency [us]")
    a1.grid(True, alpha=0.3)
    fig.tight_layout()
    path = out_dir / "timing.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    written.append(path)

    # --- PSD
    fig, (p0, p1) = plt.subplots(2, 1, figsize=(10, 8), sharex=True)
    if len(truth) >= 8:
        dt = float(np.median(np.diff(tt)))
        fs = 1.0 / dt if dt > 0 else 1.0
        nper = min(len(truth), 1024)
        for ax, x, label, unit in (
            (p0, _col(truth, "rotor_speed_rad_s"), "rotor speed", "(rad/s)$^2$/Hz"),
            (p1, np.degrees(_col(truth, "blade_pitch_rad")), "blade pitch", "deg$^2$/Hz"),
        ):
            f, pxx = welch(x, fs=fs, nperseg=nper, detrend="constant")
            ax.loglog(f[1:], pxx[1:], label=label)
            ax.set_ylabel(f"PSD [{unit}]")
            ax.legend()
            ax.grid(True, which="both", alpha=0.3)
    else:
        _no_data(p0)
        _no_data(p1)
        p0.set_ylabel("PSD [(rad/s)$^2$/Hz]")
        p1.set_ylabel("PSD [deg$^2$/Hz]")
    p1.set_xlabel("frequency [Hz]")
    fig.tight_layout()
    path = out_dir / "psd.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    written.append(path)
    return written


# --------------------------------------------------------------------------- entry points


def review(mcap_path: Path, out_dir: Path | None = None, plots: bool = True) -> dict[str, Any]:
    """Read a run log, write ``summary.json`` (and plots) and return the summary.

    Parameters
    ----------
    mcap_path : Path
        The run's MCAP file (may be truncated).
    out_dir : Path, optional
        Output folder; defaults to the MCAP file's folder.
    plots : bool
        Also write the PNG plots (:func:`write_plots`).
    """
    mcap_path = Path(mcap_path)
    out = Path(out_dir) if out_dir is not None else mcap_path.parent
    out.mkdir(parents=True, exist_ok=True)
    run = read_run(mcap_path)
    summary = summarize(run)
    summary["run"]["source"] = str(mcap_path)
    (out / "summary.json").write_text(json.dumps(summary, indent=2, allow_nan=False) + "\n")
    if plots:
        write_plots(run, out)
    return summary


def _fmt(v: Any, scale: float = 1.0, digits: int = 3) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, int):
        return f"{v}"
    if isinstance(v, float):
        return f"{v * scale:.{digits}g}" if abs(v * scale) < 1e-3 else f"{v * scale:,.{digits}f}"
    return str(v)


def render_summary(summary: dict[str, Any], console: Console) -> None:
    """Print the summary as rich tables: run, KPIs with units, timing."""
    run = summary.get("run", {})
    scen = summary.get("scenario", {})
    head = Table(title="Run", show_header=False)
    head.add_column("item")
    head.add_column("value")
    head.add_row("scenario", str(scen.get("name") or "-"))
    for k in ("mode", "transport", "turbine"):
        if k in run:
            head.add_row(k, str(run[k]))
    head.add_row("duration", f"{_fmt(run.get('duration_s'), digits=2)} s")
    trunc = bool(run.get("truncated"))
    head.add_row("truncated", "[red]yes[/red]" if trunc else "no")
    if run.get("error"):
        head.add_row("reader stopped on", f"[yellow]{run['error']}[/yellow]")
    msgs = run.get("messages", {})
    head.add_row("messages", ", ".join(f"{k}: {v}" for k, v in msgs.items()) or "-")
    console.print(head)

    k = summary.get("kpi", {})
    t = Table(title="KPIs")
    t.add_column("KPI")
    t.add_column("value", justify="right")
    t.add_column("unit")
    rows: list[tuple[str, Any, float, str]] = [
        ("mean electrical power", k.get("mean_power_w"), 1e-6, "MW"),
        ("rotor speed mean", k.get("rotor_speed_mean_rad_s"), 30.0 / math.pi, "rpm"),
        ("rotor speed std", k.get("rotor_speed_std_rad_s"), 30.0 / math.pi, "rpm"),
        ("pitch travel |dθ/dt|", k.get("pitch_travel_deg_s"), 1.0, "deg/s"),
        ("generator torque mean", k.get("generator_torque_mean_nm"), 1e-3, "kN m"),
        ("thrust mean", k.get("thrust_mean_n"), 1e-3, "kN"),
        ("thrust max", k.get("thrust_max_n"), 1e-3, "kN"),
        (
            f"shaft DEL (m={_fmt(k.get('shaft_del_wohler_m'), digits=0)})",
            k.get("shaft_del_nm"),
            1e-3,
            "kN m",
        ),
        ("thrust DEL (m=4)", k.get("thrust_del_n"), 1e-3, "kN"),
        ("tower-base moment mean", k.get("tower_base_moment_mean_nm"), 1e-6, "MN m"),
        ("tower-base DEL (m=4)", k.get("tower_base_del_nm"), 1e-6, "MN m"),
        ("platform pitch mean", k.get("platform_pitch_mean_deg"), 1.0, "deg"),
        ("platform pitch std", k.get("platform_pitch_std_deg"), 1.0, "deg"),
        ("surge mean", k.get("surge_mean_m"), 1.0, "m"),
        ("surge std", k.get("surge_std_m"), 1.0, "m"),
    ]
    for name, v, scale, unit in rows:
        t.add_row(name, _fmt(v, scale), unit)
    console.print(t)

    tm = summary.get("timing", {})
    tt = Table(title="Timing" + ("" if tm.get("complete", True) else " (incomplete run)"))
    tt.add_column("quantity")
    tt.add_column("p50", justify="right")
    tt.add_column("p99", justify="right")
    tt.add_column("p99.9", justify="right")
    tt.add_column("max", justify="right")
    tt.add_column("unit")
    lat = tm.get("latency_us", {})
    tt.add_row(
        f"latency ({tm.get('latency_source', '-')})",
        *(_fmt(lat.get(q), digits=1) for q in ("p50", "p99", "p999", "max")),
        "us",
    )
    plat = tm.get("latency_us_plant", {})
    if any(v is not None for v in plat.values()):
        tt.add_row(
            "latency (plant histogram)",
            *(_fmt(plat.get(q), digits=1) for q in ("p50", "p99", "p999", "max")),
            "us",
        )
    cc = tm.get("controller_compute_us", {})
    tt.add_row(
        "controller compute",
        _fmt(cc.get("p50"), digits=1),
        _fmt(cc.get("p99"), digits=1),
        "-",
        _fmt(cc.get("max"), digits=1),
        "us",
    )
    console.print(tt)

    ct = Table(title="Cycle counts")
    ct.add_column("counter")
    ct.add_column("value", justify="right")
    misses = tm.get("deadline_misses")
    ct.add_row("cycles", _fmt(tm.get("cycles")))
    ct.add_row(
        "deadline misses",
        f"[bold red]{misses}[/bold red]" if misses else _fmt(misses),
    )
    for name in (
        "commands_held",
        "commands_rejected",
        "commands_late",
        "safe_state_cycles",
        "faults_injected",
    ):
        v = tm.get(name)
        ct.add_row(name.replace("_", " "), f"[yellow]{v}[/yellow]" if v else _fmt(v))
    safe = tm.get("safe_state")
    ct.add_row("safe state", "[bold red]entered[/bold red]" if safe else "no")
    ct.add_row("sim s / wall s", _fmt(tm.get("sim_seconds_per_wall_second"), digits=3))
    console.print(ct)


__all__ = ["PLOT_FILES", "render_summary", "review", "summarize", "write_plots"]
