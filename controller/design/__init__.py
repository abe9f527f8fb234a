"""Offline controller design: linear models, LQRI gain schedule, wave feedforward, observer.

This package MAY import ``plant`` (offline work); the controller runtime loads only the files
it writes, named after the design (the plant preset's stem) and, for the discrete LQRI gains
and wave-FF filters, the control period (:func:`controller.lqri.artefact_stem`):

* ``<preset>_lqri_dt<T_s>.npz`` + ``.json`` (e.g. ``iea15mw_volturnus_lqri_dt0p025``),
* ``<preset>_waveff_dt<T_s>.npz`` + ``.json``,
* ``<preset>_observer.npz`` + ``.json`` (continuous models, discretised at run time).

Each json records the preset, the settings, the control period, the creation time (UTC) and
the git commit. Shipped in ``controller/presets/designs`` for 0.025 s (40 Hz) and 0.01 s
(100 Hz); other periods are designed on first use by ``fowt run`` into the user design cache
(``$FOWT_DESIGN_DIR``, default ``~/.cache/fowt-hil/designs``).

Entry points: :func:`design_all` (``fowt design PRESET --control-period T_s``), :func:`design`
(LQRI + wave FF) and :func:`linear_report` (``fowt analyze linear PRESET --wind W --json``).

Design time (2-vCPU machine, one BLAS thread): about 6 s for all three artefacts, nearly all
in the wave-FF vector fits (22 winds x 40 least-squares iterations on 1201 x 50 matrices).
With a multi-threaded BLAS on a loaded 2-core machine the same fits took 25-50 s, so
``fowt design`` and the launcher run the design with one BLAS thread.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from plant.platform import FloatingParams

__all__ = [
    "BLAS_SINGLE_THREAD_ENV",
    "DEFAULT_DESIGN_DIR",
    "design",
    "design_all",
    "linear_report",
]

#: Where the shipped artefacts live (the runtime reads them through importlib.resources).
DEFAULT_DESIGN_DIR = Path(__file__).resolve().parents[1] / "presets" / "designs"

#: Environment that makes the BLAS libraries single-threaded (effective only when set before
#: numpy is first imported, which is why this module imports numpy lazily): the design's small
#: least-squares problems ran 10-70x faster on one thread than with threads contending for
#: 2 shared cores.
BLAS_SINGLE_THREAD_ENV = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}


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
    control_period_s: float | None = None,
    provenance: dict[str, object] | None = None,
    below_rated_baseline: str = "iea15mw_baseline",
    wave_ff_wind_grid_m_s: tuple[float, ...] | None = None,
) -> dict[str, Path]:
    """Run the offline LQRI and wave-feedforward designs and write their artefacts.

    Parameters
    ----------
    preset : str
        Floating preset (:func:`plant.platform.load_floating`): a shipped name or a path to a
        preset TOML; the artefacts are named after its stem.
    out_dir : str or Path, optional
        Output folder (default: :data:`DEFAULT_DESIGN_DIR`).
    settings : dict, optional
        Overrides of :class:`controller.design.lqri.LqriSettings` fields.
    control_period_s : float, optional
        Control period T_s [s] of the discrete gains and filters (overrides
        ``settings["control_period_s"]``; default 0.025 s).
    provenance : dict, optional
        ``created_utc`` and ``commit`` to record (default: now and ``git rev-parse HEAD``).
    below_rated_baseline : str
        Baseline preset whose torque law the advanced controller runs below rated
        (``AdvancedSettings.below_rated_baseline``): the wave-FF filters are designed at the
        operating points that law holds (rotor at or above its minimum speed ``VS_MinOMSpd``).
    wave_ff_wind_grid_m_s : tuple of float, optional
        Scheduled winds of the wave feedforward [m/s] (default
        :data:`controller.design.wave_ff.FF_WIND_GRID_M_S`).

    Returns
    -------
    dict
        ``{"lqri_npz", "lqri_json", "waveff_npz", "waveff_json"}`` paths (the wave
        feedforward of :func:`controller.design.wave_ff.write_wave_ff_artefact`).
    """
    import numpy as np  # noqa: PLC0415  (lazy: BLAS_SINGLE_THREAD_ENV must come first)

    from controller.design.linear import (  # noqa: PLC0415
        linear_model,
        rated_wind_speed,
        reduce_radiation,
    )
    from controller.design.lqri import LQRI_STATE_NAMES, LqriSettings, design_lqri  # noqa: PLC0415
    from controller.lqri import artefact_stem  # noqa: PLC0415
    from plant.platform import load_floating  # noqa: PLC0415  offline only
    from plant.turbine import optimal_torque_gain  # noqa: PLC0415

    s = LqriSettings()
    if settings:
        s = replace(s, **settings)  # type: ignore[arg-type]
    if control_period_s is not None:
        s = replace(s, control_period_s=float(control_period_s))
    prov = provenance or {
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "commit": _commit(),
    }
    params = load_floating(preset)
    models = [reduce_radiation(linear_model(params, w), params) for w in s.wind_grid_m_s]
    gains = design_lqri(models, s)
    tp = params.turbine
    out = Path(out_dir) if out_dir is not None else DEFAULT_DESIGN_DIR
    out.mkdir(parents=True, exist_ok=True)
    name = Path(str(preset)).stem
    npz = out / f"{artefact_stem(name, 'lqri', s.control_period_s)}.npz"
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
        "control_period_s": s.control_period_s,
        **prov,
        "state_names": list(LQRI_STATE_NAMES),
        "law": "theta_c = theta_op - K_x (x - x_op) - K_i z, z' = omega - omega_rated",
        "settings": s.as_dict(),
        "scalars": {
            # P_rated / (η ω_rated N): the torque of region 3 (the first design wind may lie
            # below the rated rotor speed, where the trim torque is higher)
            "rated_torque_nm": tp.rated_power_w
            / (tp.generator_efficiency * tp.rated_rotor_speed_rad_s * tp.gearbox_ratio),
            "rated_rotor_speed_rad_s": tp.rated_rotor_speed_rad_s,
            "torque_gain_nm_s2": optimal_torque_gain(tp),
            "torque_max_nm": tp.torque_max_nm,
            "torque_rate_max_nm_s": tp.torque_rate_max_nm_s,
            "rated_wind_m_s": rated_wind_speed(params),
        },
    }
    js = npz.with_suffix(".json")
    js.write_text(json.dumps(meta, indent=2) + "\n")
    from controller.baseline import load_baseline  # noqa: PLC0415
    from controller.design.wave_ff import (  # noqa: PLC0415
        FF_WIND_GRID_M_S,
        write_wave_ff_artefact,
    )

    # the below-rated torque law of the advanced controller (controller.runtime) holds the
    # rotor at or above the baseline's minimum speed (VS_MinOMSpd, region 1.5)
    base = load_baseline(below_rated_baseline)
    ff = write_wave_ff_artefact(
        params,
        str(preset),
        out,
        dt_s=s.control_period_s,
        provenance=prov,
        min_rotor_speed_rad_s=base.cut_in_generator_speed_rad_s / base.gearbox_ratio,
        wind_grid_m_s=wave_ff_wind_grid_m_s or FF_WIND_GRID_M_S,
    )
    return {"lqri_npz": npz, "lqri_json": js, **ff}


def design_all(
    preset: str = "iea15mw_volturnus",
    control_period_s: float = 0.025,
    out_dir: str | Path | None = None,
) -> dict[str, Path]:
    """All artefacts the advanced controller loads, for one preset and control period.

    Runs :func:`design` (LQRI + wave FF at ``control_period_s``) and
    :func:`controller.design.observer.design_observer` into a temporary folder inside
    ``out_dir`` and then moves each file into place (json before npz, each an atomic
    ``os.replace``), so a controller looking for the artefacts meanwhile (another run sharing
    the cache) never reads a half-written file.

    Parameters
    ----------
    preset : str
        Floating preset name or preset TOML path.
    control_period_s : float
        Control period T_s [s], in (0, 1].
    out_dir : str or Path, optional
        Output folder (default: :data:`DEFAULT_DESIGN_DIR`).

    Returns
    -------
    dict
        ``{"lqri_npz", "lqri_json", "waveff_npz", "waveff_json", "observer_npz",
        "observer_json"}`` final paths.
    """
    from controller.design.observer import design_observer  # noqa: PLC0415

    if not 0.0 < control_period_s <= 1.0:
        raise ValueError(f"control_period_s = {control_period_s!r}: expected (0, 1] s")
    out = Path(out_dir) if out_dir is not None else DEFAULT_DESIGN_DIR
    out.mkdir(parents=True, exist_ok=True)
    prov: dict[str, object] = {
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "commit": _commit(),
    }
    tmp = Path(tempfile.mkdtemp(prefix=".design-", dir=out))
    try:
        t0 = time.perf_counter()
        staged = {
            **design(preset, tmp, control_period_s=control_period_s, provenance=prov),
            **design_observer(preset, tmp),
        }
        seconds = time.perf_counter() - t0
        final: dict[str, Path] = {}
        for key in sorted(staged, key=lambda k: not k.endswith("_json")):
            path = staged[key]
            if key.endswith("_json"):
                meta = json.loads(path.read_text())
                meta["design_time_s"] = round(seconds, 2)
                path.write_text(json.dumps(meta, indent=2) + "\n")
            final[key] = out / path.name
            os.replace(path, final[key])
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return final


def linear_report(
    preset: str = "iea15mw_volturnus",
    wind_m_s: float = 15.0,
    baseline_preset: str | None = None,
) -> dict[str, object]:
    """Design-model poles (with their modes), the LQRI's and the baseline's closed-loop modes.

    Parameters
    ----------
    preset : str
        Floating preset name or preset TOML path.
    wind_m_s : float
        Steady hub-height wind U [m/s].
    baseline_preset : str, optional
        Baseline controller preset of ``baseline_closed_loop_modes``
        (:func:`controller.baseline.load_baseline`), used if its rated generator speed and
        gearbox ratio are the plant's (within 0.1 %). Default: the first shipped one of
        ``<preset>_baseline``, ``iea15mw_baseline``, ``nrel5mw_baseline`` that is.

    Returns
    -------
    dict
        ``{"wind_m_s", "modes": [{name, period_s, damping_ratio, eigenvalue}],
        "closed_loop_modes": [...], "rotor_pole_1_s", "open_loop_poles": [[re, im]...],
        "closed_loop_poles_z": [[re, im]...], "closed_loop_poles_s": [[re, im]...],
        "closed_loop_spectral_radius"}`` (continuous poles in 1/s; discrete z at T_s).
        ``closed_loop_modes`` are the surge, pitch and tower modes of the LQRI design model
        with its gains (full state feedback, no observer), found as the open-loop ones
        (:func:`plant.modes.identify_modes`) in the continuous equivalent
        :math:`\\log(A_i - B_i K)/T_s` of the discrete closed loop.
        ``baseline_closed_loop_modes`` (same dicts) are the surge, heave, pitch and tower
        modes of the plant with the baseline controller at its own steady state at U: the
        discrete closed loop of the ZOH plant and the controller's step linearised about it
        (:func:`controller.design.baseline_linear.baseline_closed_loop`, T_s 0.025 s, the
        branch of the law active there); ``baseline_closed_loop_case`` says which branch, or
        why the list is empty (below rated, where only the above-rated branches are
        linearised; a baseline preset of another turbine).
    """
    import numpy as np  # noqa: PLC0415
    import scipy.linalg as sla  # noqa: PLC0415

    from controller.design.linear import linear_model, reduce_radiation  # noqa: PLC0415
    from controller.design.lqri import (  # noqa: PLC0415
        LqriSettings,
        closed_loop_matrix,
        gains_at,
    )
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
    closed = closed_loop_matrix(model, k_x, k_i, s.control_period_s)
    z = np.linalg.eigvals(closed).astype(np.complex128)
    sp = np.log(z) / s.control_period_s
    # the continuous equivalent of the discrete closed loop: same eigenvectors, poles log(z)/T_s
    a_cl = np.real(sla.logm(closed)) / s.control_period_s
    cl_modes = identify_modes(
        a_cl,
        range(3),
        range(3, 6),
        ("surge", "pitch", "tower_fore_aft"),
        (1.0, PITCH_LENGTH_M, 1.0),
    )
    baseline_modes, baseline_case = _baseline_modes(
        params, preset, float(wind_m_s), baseline_preset
    )
    return {
        "wind_m_s": float(wind_m_s),
        "modes": [m.as_dict() for m in modes],
        "closed_loop_modes": [m.as_dict() for m in cl_modes],
        "baseline_closed_loop_modes": baseline_modes,
        "baseline_closed_loop_case": baseline_case,
        "rotor_pole_1_s": rotor.real,
        "open_loop_poles": [[float(v.real), float(v.imag)] for v in lam],
        "closed_loop_poles_z": [[float(v.real), float(v.imag)] for v in z],
        "closed_loop_poles_s": [[float(v.real), float(v.imag)] for v in sp],
        "closed_loop_spectral_radius": radius,
    }


def _baseline_modes(
    params: FloatingParams, preset: str, wind_m_s: float, baseline_preset: str | None
) -> tuple[list[dict[str, object]], str]:
    """The baseline's closed-loop modes for :func:`linear_report` and the case in words
    (empty list and the reason where they are not computed)."""
    import numpy as np  # noqa: PLC0415

    from controller.baseline import available_presets, load_baseline  # noqa: PLC0415
    from controller.design.baseline_linear import baseline_closed_loop  # noqa: PLC0415

    tp = params.turbine

    def fits(name: str) -> bool:
        bp = load_baseline(name)
        omega = bp.pitch_reference_generator_speed_rad_s / bp.gearbox_ratio
        return (
            bp.gearbox_ratio == tp.gearbox_ratio
            and abs(omega - tp.rated_rotor_speed_rad_s) <= 1e-3 * tp.rated_rotor_speed_rad_s
        )

    if baseline_preset is None:
        shipped = available_presets()
        names = (f"{Path(str(preset)).stem}_baseline", "iea15mw_baseline", "nrel5mw_baseline")
        found = [n for n in names if n in shipped and fits(n)]
        if not found:
            return [], "not computed: no shipped baseline preset for this turbine"
        baseline_preset = found[0]
    elif not fits(baseline_preset):
        return [], f"not computed: baseline preset {baseline_preset!r} is for another turbine"
    try:
        loop = baseline_closed_loop(params, wind_m_s, baseline_preset)
    except ValueError as exc:
        return [], f"not computed: {exc}"
    modes = [m.as_dict() for m in loop.modes()]
    radius = float(np.max(np.abs(loop.poles_z())))
    return modes, f"{baseline_preset}: {loop.description}; spectral radius (z) {radius:.6f}"
