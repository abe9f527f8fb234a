"""``fowt hexicon identify``: the seed's PRBS experiments over the bus, merged from MCAP, N4SID.

ayotte-2015 sections 3.4, 4.2 and 5.2 (table 5). Each experiment is a run of the bench's
processes through the launcher (``fowt run hexicon-s1_step15 --controller prbs --experiment
k``; the ``record`` callable :func:`identify_over_bus` is given, e.g.
:func:`hil.cli.hexicon.record_experiment`): the plant process with the PRBS wind of the
experiment publishing its (noisy) frames, the excitation process commanding PRBS pitches
floored at the rated pitch of the measured wind, the recorder writing ``exp<k>/run.mcap``.
The identification then reads only those MCAP files
(:func:`experiment_data`): per control period k the inputs u_k = (met wind speed m/s, met
wind direction deg, commanded pitches θ_1..θ_3 deg answering frame k) and the outputs
y_k = (measured yaw rate deg/s, Σ measured turbine power MW). Experiments 1-5 are merged
(concatenated) for estimation, experiment 6 is held out; the fit is N4SID
(:func:`controller.design.hexicon_identify.n4sid`, the maintained ``nfoursid`` package) with
the order chosen from the singular values of the projected block-Hankel matrix. Fit
(NRMSE, %) on both sets of the free-run simulation (inputs only) and of the one-step-ahead
prediction (the Kalman predictor of N4SID's identified noise model, corrected by the
measured outputs up to the previous sample), beside the seed's ~70 % (estimation; the seed
does not say which of the two its toolbox figure is).

The model is saved with a steady-state Kalman gain as the design artefact the
``mpc_id`` controller loads (``controller/presets/hexicon_h3_identified.json`` with
``--write-preset``, always ``<out>/identified.json``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import scipy.linalg

from controller.design.hexicon_identify import (
    INPUTS,
    OUTPUTS,
    TABLE5,
    Identified,
    fit_percent,
    n4sid,
    predict_one_step,
    predictor_gain,
    simulate,
)
from hil.hexicon.nodes import read_platform_run

__all__ = ["experiment_data", "identify_over_bus", "kalman_gain", "model_artefact"]

PRESET = Path(__file__).resolve().parents[2] / "controller" / "presets"


def experiment_data(path: Path, platform: str = "h3") -> pd.DataFrame:
    """Inputs and outputs of one recorded experiment (module docstring), one row per cycle.

    Raises
    ------
    ValueError
        When the file holds no complete cycle (frames of the three turbines, the platform
        and the three commands answering it).
    """
    run = read_platform_run(path)
    plat = {f["seq"]: f for f in run.get(f"fowt/{platform}/platform", [])}
    tur = [
        {f["seq"]: f for f in run.get(f"fowt/{platform}/{t}/rotor", [])} for t in ("t1", "t2", "t3")
    ]
    cmd = [
        {c["answered_seq"]: c for c in run.get(f"fowt/{platform}/{t}/rotor/command", [])}
        for t in ("t1", "t2", "t3")
    ]
    rows = []
    for k in sorted(plat):
        if not all(k in c for c in cmd) or not all(k in t for t in tur):
            continue
        p = plat[k]
        rows.append(
            (
                p["wind_speed_measured_m_s"],
                math.degrees(p["wind_direction_measured_rad"]),
                *(math.degrees(c[k]["blade_pitch_commanded_rad"]) for c in cmd),
                math.degrees(p["platform_yaw_rate_measured_rad_s"]),
                sum(t[k]["electrical_power_measured_w"] for t in tur) / 1e6,
            )
        )
    if not rows:
        raise ValueError(f"{path}: no complete identification cycle recorded")
    return pd.DataFrame(rows, columns=[*INPUTS, *OUTPUTS])


def kalman_gain(m: Identified, residual_var: np.ndarray, q_scale: float = 1e-2) -> np.ndarray:
    """Steady-state Kalman (filter-form) gain L = P Cᵀ (C P Cᵀ + R)⁻¹ of the identified model.

    P solves the discrete algebraic Riccati equation with process noise Q = q B Bᵀ + 1e-6 I
    (input-shaped; per unit input², inputs in deg and m/s) and R = diag(residual variance of
    the outputs on the estimation data).
    """
    n = m.a.shape[0]
    q = q_scale * m.b @ m.b.T + 1e-6 * np.eye(n)
    r = np.diag(np.maximum(residual_var, 1e-9))
    p = scipy.linalg.solve_discrete_are(m.a.T, m.c.T, q, r)
    gain: np.ndarray = p @ m.c.T @ np.linalg.inv(m.c @ p @ m.c.T + r)
    return gain


def model_artefact(
    m: Identified, gain: np.ndarray, ts: float, info: dict[str, Any]
) -> dict[str, Any]:
    """The JSON design artefact of :func:`controller.hexicon.load_identified`."""
    return {
        "comment": (
            "N4SID model of the Hexicon H3 platform from the table-5 PRBS experiments recorded "
            "over the bus (fowt hexicon identify); u = (V m/s, beta deg, pitch1..3 deg), "
            "y = (yaw rate deg/s, platform power MW); x+ = A x + B (u - u_mean), "
            "y = C x + D (u - u_mean) + y_mean"
        ),
        "inputs": list(INPUTS),
        "outputs": list(OUTPUTS),
        "sample_time_s": ts,
        "order": m.order,
        "a": m.a.tolist(),
        "b": m.b.tolist(),
        "c": m.c.tolist(),
        "d": m.d.tolist(),
        "u_mean": m.u_mean.tolist(),
        "y_mean": m.y_mean.tolist(),
        "kalman_gain": gain.tolist(),
        **info,
    }


def identify_over_bus(
    out: Path,
    duration_s: float = 3000.0,
    block_rows: int = 10,
    seed: int = 0,
    experiments: tuple[int, ...] = (1, 2, 3, 4, 5, 6),
    write_preset: bool = False,
    transport: str = "zenoh",
    reuse: bool = False,
    *,
    record: Callable[..., dict[str, Any]],
) -> dict[str, Any]:
    """Record the experiments over the bus, merge, fit, save (module docstring).

    The last experiment of ``experiments`` is the held-out one. ``reuse``: fit existing
    ``exp<k>/run.mcap`` files of ``out`` instead of running them again. ``record(experiment,
    out_dir, duration_s=, seed=, transport=)`` runs one experiment into ``out_dir/run.mcap``
    and returns the run's summary (``run.exit_code``, ``timing``).
    """
    if len(experiments) < 2:
        raise ValueError("identification: expected >= 2 experiments (estimation + held-out)")
    out.mkdir(parents=True, exist_ok=True)
    runs: dict[str, Any] = {}
    frames = []
    for k in experiments:
        if not 1 <= k <= len(TABLE5):
            raise ValueError(f"experiment {k}: expected 1..{len(TABLE5)}")
        path = out / f"exp{k}" / "run.mcap"
        if not (reuse and path.is_file()):
            s = record(k, path.parent, duration_s=duration_s, seed=seed, transport=transport)
            if s.get("run", {}).get("exit_code") != 0:
                raise RuntimeError(f"experiment {k} failed: {json.dumps(s['run'])[-2000:]}")
            runs[f"exp{k}"] = {
                "plant_cycles": s["timing"]["cycles"],
                "records": int(s["run"]["records"]),
                "commands_rejected": s["timing"]["commands_rejected"],
                "deadline_misses": s["timing"]["deadline_misses"],
            }
        frames.append(experiment_data(path))
    est = pd.concat(frames[:-1], ignore_index=True)
    val = frames[-1]
    m = n4sid(est, INPUTS, OUTPUTS, block_rows)
    y_est = est[list(OUTPUTS)].to_numpy()
    yh_est = simulate(m, est[list(INPUTS)].to_numpy())
    fit_est = fit_percent(y_est, yh_est)
    fit_val = fit_percent(val[list(OUTPUTS)].to_numpy(), simulate(m, val[list(INPUTS)].to_numpy()))
    gain = kalman_gain(m, np.var(y_est - yh_est, axis=0))
    k_pred = predictor_gain(m)  # the identified noise model's, not the MPC filter's gain
    os_est = fit_percent(y_est, predict_one_step(m, k_pred, est[list(INPUTS)].to_numpy(), y_est))
    y_val = val[list(OUTPUTS)].to_numpy()
    os_val = fit_percent(y_val, predict_one_step(m, k_pred, val[list(INPUTS)].to_numpy(), y_val))
    result: dict[str, Any] = {
        "order": m.order,
        "singular_values": m.singular_values[:20],
        "fit_estimation_percent": dict(zip(OUTPUTS, fit_est, strict=True)),
        "fit_validation_percent": dict(zip(OUTPUTS, fit_val, strict=True)),
        "fit_one_step_estimation_percent": dict(zip(OUTPUTS, os_est, strict=True)),
        "fit_one_step_validation_percent": dict(zip(OUTPUTS, os_val, strict=True)),
        "seed_fit_estimation_percent": 70.0,
        "eigenvalues_abs": sorted(float(abs(e)) for e in np.linalg.eigvals(m.a)),
        "estimation_experiments": list(experiments[:-1]),
        "validation_experiment": experiments[-1],
        "samples_per_experiment": duration_s,
        "block_rows": block_rows,
        "seed": seed,
        "transport": transport,
        "runs": runs,
    }
    art = model_artefact(
        m,
        gain,
        1.0,
        {k: result[k] for k in ("fit_estimation_percent", "fit_validation_percent")}
        | {"experiments": list(experiments), "samples_per_experiment": duration_s, "seed": seed},
    )
    text = json.dumps(art, indent=1) + "\n"
    (out / "identified.json").write_text(text, encoding="utf-8")
    result["artefact"] = str(out / "identified.json")
    if write_preset:
        (PRESET / "hexicon_h3_identified.json").write_text(text, encoding="utf-8")
        result["preset"] = str(PRESET / "hexicon_h3_identified.json")
    (out / "identify.json").write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    return result
