"""Offline controller design: linear models, LQRI gain schedule, wave feedforward.

This package MAY import ``plant`` (offline work); the controller runtime loads only the files
it writes (``controller/presets/designs/<preset>_lqri.npz`` + ``.json``).

Entry points: :func:`design` (``fowt design PRESET``) and :func:`linear_report`
(``fowt analyze linear PRESET --wind W --json``).
"""

from __future__ import annotations

import datetime as _dt
import json
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np

__all__ = ["DEFAULT_DESIGN_DIR", "design", "linear_report"]

#: Where the shipped artefacts live (the runtime reads them through importlib.resources).
DEFAULT_DESIGN_DIR = Path(__file__).resolve().parents[1] / "presets" / "designs"


def _commit() -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def design(
    preset: str = "iea15mw_volturnus",
    out_dir: str | Path | None = None,
    settings: dict[str, object] | None = None,
) -> dict[str, Path]:
    """Run the offline LQRI and wave-feedforward designs and write their artefacts.

    Parameters
    ----------
    preset : str
        Floating preset (:func:`plant.platform.load_floating`).
    out_dir : str or Path, optional
        Output folder (default: :data:`DEFAULT_DESIGN_DIR`).
    settings : dict, optional
        Overrides of :class:`controller.design.lqri.LqriSettings` fields.

    Returns
    -------
    dict
        ``{"lqri_npz", "lqri_json", "waveff_npz", "waveff_json"}`` paths (the wave
        feedforward of :func:`controller.design.wave_ff.write_wave_ff_artefact`).
    """
    from controller.design.linear import (  # noqa: PLC0415
        linear_model,
        rated_wind_speed,
        reduce_radiation,
    )
    from controller.design.lqri import LqriSettings, design_lqri  # noqa: PLC0415
    from plant.platform import load_floating  # noqa: PLC0415  offline only
    from plant.turbine import optimal_torque_gain  # noqa: PLC0415

    s = LqriSettings()
    if settings:
        s = replace(s, **settings)  # type: ignore[arg-type]
    params = load_floating(preset)
    models = [reduce_radiation(linear_model(params, w), params) for w in s.wind_grid_m_s]
    gains = design_lqri(models, s)
    tp = params.turbine
    out = Path(out_dir) if out_dir is not None else DEFAULT_DESIGN_DIR
    out.mkdir(parents=True, exist_ok=True)
    npz = out / f"{Path(str(preset)).stem}_lqri.npz"
    np.savez_compressed(
        npz,
        wind_m_s=gains.wind_m_s,
        k_x=gains.k_x,
        k_i=gains.k_i,
        x_op=gains.x_op,
        u_op=gains.u_op,
        closed_loop_radius=gains.closed_loop_radius,
    )
    meta = {
        "format_version": 1,
        "kind": "lqri_gain_schedule",
        "preset": str(preset),
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "commit": _commit(),
        "state_names": [
            "surge_m",
            "pitch_rad",
            "tower_fore_aft_m",
            "surge_rate_m_s",
            "pitch_rate_rad_s",
            "tower_fore_aft_rate_m_s",
            "rotor_speed_rad_s",
            "blade_pitch_rad",
        ],
        "law": "theta_c = theta_op - K_x (x - x_op) - K_i z, z' = omega - omega_rated",
        "settings": s.as_dict(),
        "scalars": {
            "rated_torque_nm": float(models[0].u_op[1]),
            "rated_rotor_speed_rad_s": tp.rated_rotor_speed_rad_s,
            "torque_gain_nm_s2": optimal_torque_gain(tp),
            "torque_max_nm": tp.torque_max_nm,
            "torque_rate_max_nm_s": tp.torque_rate_max_nm_s,
            "rated_wind_m_s": rated_wind_speed(params),
        },
    }
    js = npz.with_suffix(".json")
    js.write_text(json.dumps(meta, indent=2) + "\n")
    from controller.design.wave_ff import write_wave_ff_artefact  # noqa: PLC0415

    ff = write_wave_ff_artefact(
        params,
        str(preset),
        out,
        dt_s=s.control_period_s,
        provenance={"created_utc": meta["created_utc"], "commit": meta["commit"]},
    )
    return {"lqri_npz": npz, "lqri_json": js, **ff}


def linear_report(preset: str = "iea15mw_volturnus", wind_m_s: float = 15.0) -> dict[str, object]:
    """Design-model poles (with their modes) and the LQRI closed-loop poles at one wind.

    Returns
    -------
    dict
        ``{"wind_m_s", "modes": [{name, period_s, damping_ratio, eigenvalue}],
        "rotor_pole_1_s", "open_loop_poles": [[re, im]...],
        "closed_loop_poles_z": [[re, im]...], "closed_loop_poles_s": [[re, im]...],
        "closed_loop_spectral_radius"}`` (continuous poles in 1/s; discrete z at T_s).
    """
    from controller.design.linear import linear_model, reduce_radiation  # noqa: PLC0415
    from controller.design.lqri import LqriSettings, closed_loop_poles, gains_at  # noqa: PLC0415
    from plant.modes import PITCH_LENGTH_M, identify_modes  # noqa: PLC0415
    from plant.platform import DOF_NAMES, load_floating  # noqa: PLC0415

    params = load_floating(preset)
    model = reduce_radiation(linear_model(params, wind_m_s), params)
    s = LqriSettings()
    modes = identify_modes(
        model.a, range(4), range(4, 8), DOF_NAMES, (1.0, 1.0, PITCH_LENGTH_M, 1.0)
    )
    lam, vec = np.linalg.eig(model.a)
    part = np.abs(vec[8, :] * np.linalg.inv(vec)[:, 8])
    real = np.abs(lam.imag) < 1e-9
    rotor = complex(lam[int(np.argmax(np.where(real, part, -1.0)))])
    k_x, k_i, radius = gains_at(model, s)
    z = closed_loop_poles(model, k_x, k_i, s.control_period_s)
    sp = np.log(z.astype(np.complex128)) / s.control_period_s
    return {
        "wind_m_s": float(wind_m_s),
        "modes": [m.as_dict() for m in modes],
        "rotor_pole_1_s": rotor.real,
        "open_loop_poles": [[float(v.real), float(v.imag)] for v in lam],
        "closed_loop_poles_z": [[float(v.real), float(v.imag)] for v in z],
        "closed_loop_poles_s": [[float(v.real), float(v.imag)] for v in sp],
        "closed_loop_spectral_radius": radius,
    }
