"""Design on first use: the artefact a controller kind needs, made when it is missing.

A run's controller loads design artefacts (gain tables, filters) that offline design made;
the shipped ones cover the shipped scenarios. For another control period, platform or sea
state, the launcher asks the controller registry (:func:`controller.registry.ensure_design`),
which calls the kind's function here. Each looks the artefact up as the controller will
(shipped designs, then the user design cache :func:`controller.lqri.user_design_dir`), and
when it is missing runs the design in a child process (:func:`run_design`: one BLAS thread,
see :mod:`controller.design`), so that neither the launcher nor the controller process
imports the design code or the plant model it uses. Each returns the cache folder designed
into (to hand to the controller as ``$FOWT_DESIGN_DIR`` or ``design_dir``), or None when
nothing was missing or nothing can be designed (the controller then names what is missing).

This module imports no controller core at module level and nothing of :mod:`plant`.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

__all__ = [
    "DesignFailedError",
    "ensure_advanced",
    "ensure_casanovas",
    "ensure_lqr_wave",
    "run_design",
]

Say = Callable[[str], None]


class DesignFailedError(RuntimeError):
    """A design child process failed (its output is in the message) or left the artefact
    missing."""


def run_design(cmd: list[str], what: str, cache: Path, say: Say) -> None:
    """Run a design command (``python -m ...``) into ``cache``, one BLAS thread.

    Parameters
    ----------
    cmd : list of str
        The arguments after ``python -m``.
    what : str
        What is designed, for the messages (``"iea15mw_volturnus at 0.02 s"``).
    cache : Path
        The user design cache (``$FOWT_DESIGN_DIR`` of the child).
    say : callable
        Where the progress messages go.

    Raises
    ------
    DesignFailedError
        If the command exits non-zero.
    """
    from controller.design import BLAS_SINGLE_THREAD_ENV  # noqa: PLC0415
    from controller.lqri import DESIGN_DIR_ENV  # noqa: PLC0415

    env = {**os.environ, **BLAS_SINGLE_THREAD_ENV, DESIGN_DIR_ENV: str(cache)}
    t0 = time.monotonic()
    proc = subprocess.run(
        [sys.executable, "-m", *cmd], capture_output=True, text=True, env=env, check=False
    )
    if proc.returncode != 0:
        raise DesignFailedError(
            f"design of {what} failed ({proc.returncode}):\n{proc.stdout}{proc.stderr}"
        )
    say(f"designed {what} in {time.monotonic() - t0:.1f} s")


def _design_preset(platform: str | None, name: str) -> str:
    """The plant preset to design ``name`` from: the scenario's platform when its stem is
    ``name`` (a preset file keeps its path), else ``name`` itself (a shipped preset)."""
    if platform is not None and Path(platform).stem == name:
        return str(Path(platform).resolve()) if Path(platform).suffix == ".toml" else platform
    return name


def ensure_advanced(
    preset: str, control_period_s: float, feedforward: str, platform: str | None, say: Say
) -> Path | None:
    """The advanced controller's (``lqri``, ``lqri_ff``) LQRI, wave-FF and observer artefacts.

    For each design with an artefact missing (:func:`controller.runtime.missing_designs`),
    runs ``fowt design PRESET --control-period T_s --out CACHE``.

    Parameters
    ----------
    preset : str
        The controller preset (``[controller] preset``).
    control_period_s : float
        Control period [s].
    feedforward : str
        ``"off"`` (``lqri``), ``"balanced"`` or ``"max_performance"``.
    platform : str or None
        The scenario's platform (a preset name or file), designed from when it is the
        design's plant.
    say : callable
        Where the progress messages go.
    """
    from controller.lqri import user_design_dir  # noqa: PLC0415
    from controller.runtime import load_advanced_settings, missing_designs  # noqa: PLC0415

    dt = control_period_s
    missing = missing_designs(load_advanced_settings(preset), dt, feedforward)  # type: ignore[arg-type]
    if not missing:
        return None
    cache = user_design_dir()
    for name in sorted({m.name for m in missing}):
        kinds = ", ".join(m.kind for m in missing if m.name == name)
        plant = _design_preset(platform, name)
        say(
            f"no {name} controller design ({kinds}) for control period {dt:g} s: "
            f"designing it into {cache} (fowt design {plant} --control-period {dt:g}) ..."
        )
        cmd = ["hil", "design", plant, "--control-period", repr(dt), "--out", str(cache)]
        run_design(cmd, f"{name} at {dt:g} s", cache, say)
    still = missing_designs(load_advanced_settings(preset), dt, feedforward, cache)  # type: ignore[arg-type]
    if still:
        raise DesignFailedError(str(still[0]))
    return cache


def ensure_lqr_wave(preset: str, control_period_s: float, say: Say) -> Path | None:
    """christiansen-2013's ``lqr_wave`` gain table for the control period.

    Runs ``fowt design DESIGN --lqr-wave VARIANT --control-period T_s --out CACHE`` when
    neither the shipped designs nor the user cache hold it; None when the preset names the
    artefact's file itself (loading it reports any problem).
    """
    from controller.lqr_wave import (  # noqa: PLC0415
        LqrWaveDesignNotFoundError,
        find_lqr_wave_design,
        load_lqr_wave_preset,
    )
    from controller.lqri import user_design_dir  # noqa: PLC0415

    dt = control_period_s
    p = load_lqr_wave_preset(preset)
    if p.design.endswith(".npz"):
        return None
    try:
        find_lqr_wave_design(p.design, p.variant, dt)
        return None
    except LqrWaveDesignNotFoundError:
        pass
    cache = user_design_dir()
    cmd = ["hil", "design", p.design, "--lqr-wave", p.variant]
    cmd += ["--control-period", repr(dt), "--out", str(cache)]
    say(f"no lqr_wave design {p.design} {p.variant} at {dt:g} s: {' '.join(cmd)}")
    run_design(cmd, f"lqr_wave {p.variant} at {dt:g} s", cache, say)
    return cache


def ensure_casanovas(
    preset: str,
    control_period_s: float,
    platform: str | None,
    wind_speed_m_s: float | None,
    hs_m: float | None,
    t1_s: float | None,
    say: Say,
) -> Path | None:
    """A casanovas-2014 artefact, designed from the scenario's platform, wind and sea.

    Runs ``python -m controller.design.casanovas --preset PLATFORM --wind U --hs H --t1 T1
    --out CACHE`` when ``preset`` is not found and is the artefact name of that case
    (:func:`controller.design.casanovas.artefact_stem`); otherwise None, and the controller's
    own error names what is missing.
    """
    from controller.casanovas import load_casanovas_design  # noqa: PLC0415
    from controller.lqri import user_design_dir  # noqa: PLC0415

    try:
        load_casanovas_design(preset)
        return None
    except ValueError:
        pass
    if platform is None or hs_m is None or t1_s is None or wind_speed_m_s is None:
        return None
    from controller.design.casanovas import artefact_stem  # noqa: PLC0415

    if artefact_stem(platform, wind_speed_m_s, hs_m) != preset:
        return None
    cache = user_design_dir()
    cmd = [
        "controller.design.casanovas", "--preset", platform, "--wind", repr(wind_speed_m_s),
        "--hs", repr(hs_m), "--t1", repr(t1_s), "--out", str(cache),
        "--control-period", repr(control_period_s),
    ]  # fmt: skip
    say(f"no design {preset}: designing it into {cache} ...")
    run_design(cmd, preset, cache, say)
    return cache
