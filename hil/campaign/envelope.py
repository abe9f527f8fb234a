"""Operating envelope of a run, checked from its MCAP log alone.

The limits are the turbine's as its baseline controller preset states them (IEA 15 MW: the
DISCON.IN of the OpenFAST deck, ``controller/presets/iea15mw_baseline.toml``):

* minimum rotor speed ω_min = ``VS_MinOMSpd`` / N (IEA 15 MW: 0.5236 rad/s = 5 rpm), held by
  the torque law's region 1.5;
* rated rotor speed ω_r = ``PC_RefSpd`` / N and rated electrical power
  P_r = P_mech,rated · η (``VS_RtPwr``, 15 MW);
* pitch command limits [θ_min, θ_max] and rate θ'_max (``PC_MinPit``, ``PC_MaxPit``,
  ``PC_MaxRat``); torque command limits [0, T_max] and rate T'_max (``VS_MaxTq``,
  ``VS_MaxRat``).

Checked on the samples after ``settle_s`` (the start transient from the initial condition is
not an operating point; al-2019 also discards it) unless stated:

* rotor speed (``truth``) ≥ ω_min (1 − ``speed_tolerance``) and ≤ ``overspeed_factor`` · ω_r;
* electrical power (``truth``): mean ≤ ``mean_power_factor`` · P_r, every sample
  ≤ ``peak_power_factor`` · P_r;
* every command (``command``, whole run): θ_min ≤ θ_c ≤ θ_max, 0 ≤ T_c ≤ T_max, and between
  consecutive commands |Δθ_c| ≤ θ'_max Δt, |ΔT_c| ≤ T'_max Δt (1e-9 relative slack);
* pitch integrator (``controller/status`` ``pitch_integrator_rad``) not wound up below rated:
  on the cycles with the regime below region 3 and the pitch command at θ_min, the integral
  term stays within ``integrator_tolerance_rad`` of θ_min (a PI whose integrator is clamped or
  at rest there; -0.74 to -0.17 rad were measured before the fix).
"""

from __future__ import annotations

import io
import math
import re
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console

from controller.baseline import BaselineParams
from controller.interface import REGIME_REGION_3
from hil.runlog.mcap_io import RunData, read_run
from hil.scenario.schema import scenario_text

__all__ = ["EnvelopeLimits", "check_envelope", "controller_variant", "run_inprocess_logged"]


@dataclass(frozen=True)
class EnvelopeLimits:
    """The turbine's envelope (SI units) and the check's tolerances.

    Attributes
    ----------
    min_rotor_speed_rad_s, rated_rotor_speed_rad_s : float
        ω_min and ω_r (rad/s, low-speed shaft).
    rated_power_w : float
        Rated electrical power P_r (W).
    pitch_min_rad, pitch_max_rad, pitch_rate_max_rad_s : float
        Pitch command limits (rad, rad/s).
    torque_max_nm, torque_rate_max_nm_s : float
        Torque command limits (N m, N m/s, generator side).
    speed_tolerance : float
        Allowed relative undershoot of ω_min (-); default 0.02.
    overspeed_factor : float
        Upper rotor-speed bound as a multiple of ω_r (-); default 1.2 (the baseline reaches
        1.18 in the 25 m/s load case).
    mean_power_factor, peak_power_factor : float
        Mean and peak electrical power bounds as multiples of P_r (-); defaults 1.08, 1.2
        (constant torque above rated: P follows the rotor speed; the baseline reaches a
        mean of 1.04 P_r and peaks of 1.18 P_r in the 22.1 and 25 m/s load cases).
    integrator_tolerance_rad : float
        Allowed pitch-integrator offset from θ_min at fine pitch below rated (rad); 0.01.
    settle_s : float
        Start-up time excluded from the speed and power checks (s); default 20.
    """

    min_rotor_speed_rad_s: float
    rated_rotor_speed_rad_s: float
    rated_power_w: float
    pitch_min_rad: float
    pitch_max_rad: float
    pitch_rate_max_rad_s: float
    torque_max_nm: float
    torque_rate_max_nm_s: float
    speed_tolerance: float = 0.02
    overspeed_factor: float = 1.2
    mean_power_factor: float = 1.08
    peak_power_factor: float = 1.2
    integrator_tolerance_rad: float = 0.01
    settle_s: float = 20.0

    @classmethod
    def from_baseline(cls, p: BaselineParams, **tolerances: float) -> EnvelopeLimits:
        """The limits a baseline preset states (module docstring), tolerances overridable."""
        n = p.gearbox_ratio
        return cls(
            min_rotor_speed_rad_s=p.cut_in_generator_speed_rad_s / n,
            rated_rotor_speed_rad_s=p.pitch_reference_generator_speed_rad_s / n,
            rated_power_w=p.rated_mechanical_power_w * p.generator_efficiency_percent / 100.0,
            pitch_min_rad=p.min_pitch_rad,
            pitch_max_rad=p.max_pitch_rad,
            pitch_rate_max_rad_s=p.max_pitch_rate_rad_s,
            torque_max_nm=p.max_generator_torque_nm,
            torque_rate_max_nm_s=p.max_generator_torque_rate_nm_s,
            **tolerances,
        )


def _col(msgs: list[dict[str, Any]], name: str) -> np.ndarray:
    return np.array([m.get(name, math.nan) for m in msgs], dtype=np.float64)


def check_envelope(run: RunData, limits: EnvelopeLimits) -> dict[str, Any]:
    """Envelope figures and violations of one run (module docstring).

    Parameters
    ----------
    run : RunData
        The run log (:func:`hil.runlog.mcap_io.read_run`).
    limits : EnvelopeLimits

    Returns
    -------
    dict
        ``{"figures": {...}, "violations": [str, ...], "limits": {...}}``; no violation
        means the run stayed in the envelope. A log without truth or commands is a violation
        (nothing to check is not a pass).
    """
    lim = limits
    truth, cmd, status = run.topic("truth"), run.topic("command"), run.topic("controller/status")
    bad: list[str] = []
    fig: dict[str, Any] = {}
    if not truth or not cmd:
        return {"figures": fig, "violations": ["no truth or command messages"], "limits": {}}
    t = _col(truth, "sample_time_ns") / 1e9
    keep = t >= t[0] + lim.settle_s
    if not keep.any():
        bad.append(f"run shorter than settle_s = {lim.settle_s} s")
        keep = np.ones_like(t, dtype=bool)
    w = _col(truth, "rotor_speed_rad_s")[keep]
    p = _col(truth, "electrical_power_w")[keep]
    rpm = 30.0 / math.pi
    fig["rotor_speed_min_rpm"] = float(np.min(w) * rpm)
    fig["rotor_speed_max_rpm"] = float(np.max(w) * rpm)
    fig["below_min_speed_fraction"] = float(np.mean(w < lim.min_rotor_speed_rad_s))
    fig["power_mean_w"] = float(np.mean(p))
    fig["power_max_w"] = float(np.max(p))
    w_lo = lim.min_rotor_speed_rad_s * (1.0 - lim.speed_tolerance)
    if np.min(w) < w_lo:
        bad.append(
            f"rotor speed {fig['rotor_speed_min_rpm']:.3f} rpm below the minimum "
            f"{lim.min_rotor_speed_rad_s * rpm:.3f} rpm - {100 * lim.speed_tolerance:g} % "
            f"({100 * fig['below_min_speed_fraction']:.1f} % of the time below it)"
        )
    if np.max(w) > lim.overspeed_factor * lim.rated_rotor_speed_rad_s:
        bad.append(
            f"rotor speed {fig['rotor_speed_max_rpm']:.3f} rpm above {lim.overspeed_factor:g} x "
            f"rated {lim.rated_rotor_speed_rad_s * rpm:.3f} rpm"
        )
    if fig["power_mean_w"] > lim.mean_power_factor * lim.rated_power_w:
        bad.append(f"mean power {fig['power_mean_w'] / 1e6:.3f} MW above the bound")
    if fig["power_max_w"] > lim.peak_power_factor * lim.rated_power_w:
        bad.append(f"peak power {fig['power_max_w'] / 1e6:.3f} MW above the bound")

    tc = _col(cmd, "sample_time_ns") / 1e9
    th = _col(cmd, "blade_pitch_commanded_rad")
    tq = _col(cmd, "generator_torque_commanded_nm")
    slack = 1e-9
    fig["pitch_command_min_deg"] = math.degrees(float(np.min(th)))
    fig["pitch_command_max_deg"] = math.degrees(float(np.max(th)))
    fig["torque_command_max_nm"] = float(np.max(tq))
    if np.min(th) < lim.pitch_min_rad - slack or np.max(th) > lim.pitch_max_rad + slack:
        bad.append("pitch command outside [pitch_min, pitch_max]")
    if np.min(tq) < -slack * lim.torque_max_nm or np.max(tq) > lim.torque_max_nm * (1 + slack):
        bad.append("torque command outside [0, torque_max]")
    if tc.size > 1:
        dt = np.diff(tc)
        ok = dt > 0.0
        pitch_rate = np.abs(np.diff(th))[ok] / dt[ok]
        torque_rate = np.abs(np.diff(tq))[ok] / dt[ok]
        fig["pitch_rate_max_rad_s"] = float(np.max(pitch_rate, initial=0.0))
        fig["torque_rate_max_nm_s"] = float(np.max(torque_rate, initial=0.0))
        # 1e-6 relative: the command times are whole nanoseconds
        if fig["pitch_rate_max_rad_s"] > lim.pitch_rate_max_rad_s * (1 + 1e-6):
            bad.append(f"pitch rate {fig['pitch_rate_max_rad_s']:.5f} rad/s above the limit")
        if fig["torque_rate_max_nm_s"] > lim.torque_rate_max_nm_s * (1 + 1e-6):
            bad.append(f"torque rate {fig['torque_rate_max_nm_s']:.4g} N m/s above the limit")

    if status:
        regime = _col(status, "regime")
        integ = _col(status, "pitch_integrator_rad")
        ts = _col(status, "sample_time_ns")
        tcn = _col(cmd, "sample_time_ns")
        th_at = np.interp(ts, tcn, th)  # the command of each status (same cycle)
        fine = (regime < REGIME_REGION_3) & (th_at <= lim.pitch_min_rad + slack)
        fig["fine_pitch_below_rated_cycles"] = int(np.count_nonzero(fine))
        if fine.any():
            off = integ[fine] - lim.pitch_min_rad
            fig["integrator_at_fine_pitch_rad"] = [float(np.min(off)), float(np.max(off))]
            if np.max(np.abs(off)) > lim.integrator_tolerance_rad:
                bad.append(
                    "pitch integrator wound up at fine pitch below rated: "
                    f"{np.min(off):.3f} to {np.max(off):.3f} rad from pitch_min"
                )
    return {"figures": fig, "violations": bad, "limits": asdict(lim)}


def controller_variant(
    scenario: str,
    kind: str,
    forecaster: str | None = None,
    preset: str | None = None,
) -> str:
    """The TOML text of a shipped scenario with another ``[controller]`` table.

    Parameters
    ----------
    scenario : str
        Shipped scenario name or TOML path whose ``[controller]`` table is its last table.
    kind : {"baseline", "lqri", "lqri_ff"}
        Controller kind; the preset defaults to ``iea15mw_baseline`` / ``iea15mw_advanced``.
    forecaster : {"dispersion", "ar", "esprit"}, optional
        For the advanced kinds; ``"ar"`` and ``"esprit"`` also move the gauge to the platform
        (``gauge_distance_m = 0``), as those forecast the elevation from its own past.
    preset : str, optional
        Controller preset name.
    """
    text, _ = scenario_text(scenario)
    head, sep, _tail = text.partition("\n[controller]")
    if not sep:
        raise ValueError(f"scenario {scenario!r} has no [controller] table to replace")
    name = f"{Path(scenario).stem}-{kind.replace('_', '-')}" + (
        f"-{forecaster}" if forecaster else ""
    )
    head = re.sub(r'(?m)^name = ".*"$', f'name = "{name}"', head, count=1)
    if forecaster in ("ar", "esprit"):
        head = re.sub(r"(?m)^gauge_distance_m = .*$", "gauge_distance_m = 0.0", head, count=1)
    ctrl = preset or ("iea15mw_baseline" if kind == "baseline" else "iea15mw_advanced")
    lines = [f'kind = "{kind}"', f'preset = "{ctrl}"']
    if forecaster:
        lines.append(f'forecaster = "{forecaster}"')
    return head + "\n[controller]\n" + "\n".join(lines) + "\n"


def run_inprocess_logged(
    scenario_toml: str, out_dir: Path, duration_s: float | None = None
) -> tuple[dict[str, Any], RunData]:
    """Run a scenario (TOML text) in process as ``fowt run --mode inprocess --no-plots`` does.

    Writes ``scenario.toml``, ``run.mcap`` and ``summary.json`` into ``out_dir`` and returns
    the summary and the log read back from the MCAP file.
    """
    from hil.launch import RunRequest, launch  # noqa: PLC0415  (launch imports the nodes)

    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "scenario.toml"
    path.write_text(scenario_toml)
    req = RunRequest(
        scenario=str(path), mode="inprocess", duration_s=duration_s, out_dir=out_dir, plots=False
    )
    summary = launch(req, console=Console(file=io.StringIO()))
    return summary, read_run(out_dir / "run.mcap")
