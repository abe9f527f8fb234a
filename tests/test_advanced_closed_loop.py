"""The advanced controller (observers + wave forecast + LQRI) in closed loop, in process.

The comparison above rated: IEA 15 MW on VolturnUS-S, 15 m/s turbulent wind (IEC class
B), JONSWAP Hs 3 m, Tp 9.5 s, the same seeds for both controllers (the shipped scenarios
``iea15mw-lqri-15`` and ``iea15mw-baseline-15``), run in process for ``DURATION_S`` (200 s
here to keep the suite fast; ``bench/advanced_controller.py`` runs the full 600 s and saves
its figures). Statistics skip the first ``SETTLE_S`` seconds.

Wave feedforward below rated (al-2019 load case 1: 5 m/s IEC B, Hs 1.4 m, Tp 7 s; the shipped
``iea15mw-lc1-lqri-ff`` and ``iea15mw-lc1-lqri``, same seeds): the dispersion forecast is valid
once its 1024-tap buffer has filled (204.8 s at 0.2 s), so the runs last ``FF_DURATION_S`` and
the statistics use ``FF_WINDOW_S``. On this plant the wave-induced part of the rotor-speed
variance is about 0.1 % of the total in LC1 (the rest is turbulence below 0.05 Hz, which a
wave FF cannot touch), so the check is on the wave band f_we = 0.05-0.333 Hz of al-2019
eq. (4-3), where the FF acts.
"""

from __future__ import annotations

from functools import lru_cache

import msgspec
import numpy as np
from scipy.signal import butter, sosfiltfilt

from bus_schemas import ActuatorCommand, ControllerStatus, PlantState, SensorFrame
from bus_schemas.registry import CONTROLLER_STATUS, TRUTH, MessageType
from hil.inprocess.run import run_inprocess
from hil.nodes.controller_node import ControllerRuntime
from hil.scenario.schema import load_scenario

DURATION_S = 200.0
SETTLE_S = 30.0
FF_DURATION_S = 300.0
FF_WINDOW_S = (235.0, 300.0)  # forecast valid from 204.8 s, 30 s for the FF filters to fill
WAVE_BAND_HZ = (0.05, 0.333)


@lru_cache(maxsize=4)
def _run(
    name: str, duration_s: float = DURATION_S
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    scenario = load_scenario(name).with_duration(duration_s)
    truth: list[PlantState] = []
    status: list[ControllerStatus] = []
    runtime = ControllerRuntime(scenario)

    def publish(mt: MessageType, msg: msgspec.Struct) -> None:
        if mt is TRUTH:
            assert isinstance(msg, PlantState)
            truth.append(msg)

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        result = runtime.handle_frame(frame)
        if result is None:
            return None
        status.append(result[1])
        _ = CONTROLLER_STATUS
        return result[0]

    run_inprocess(scenario, publish, step)

    def cols(msgs: list[PlantState] | list[ControllerStatus]) -> dict[str, np.ndarray]:
        names = type(msgs[0]).__struct_fields__
        return {n: np.array([getattr(m, n) for m in msgs]) for n in names}

    return cols(truth), cols(status)


def _after(t: dict[str, np.ndarray], name: str) -> np.ndarray:
    keep = t["sample_time_ns"] >= SETTLE_S * 1e9
    values: np.ndarray = t[name][keep]
    return values


def test_lqri_beats_baseline_above_rated() -> None:
    """Rotor-speed and power std lower with LQRI; platform pitch std not higher (5 % margin
    for run-to-run sampling of a 170 s window).

    Measured (200 s, seeds of the shipped scenarios): see the assertion messages; the 600 s
    figures are in ``bench/results/advanced_controller.json``.
    """
    lq, _ = _run("iea15mw-lqri-15")
    bl, _ = _run("iea15mw-baseline-15")
    figures = {
        name: (float(np.std(_after(lq, name))), float(np.std(_after(bl, name))))
        for name in ("rotor_speed_rad_s", "electrical_power_w", "platform_pitch_rad")
    }
    msg = f"(lqri std, baseline std): {figures}"
    assert figures["rotor_speed_rad_s"][0] < figures["rotor_speed_rad_s"][1], msg
    assert figures["electrical_power_w"][0] < figures["electrical_power_w"][1], msg
    assert figures["platform_pitch_rad"][0] <= 1.05 * figures["platform_pitch_rad"][1], msg


def test_status_carries_estimates_close_to_the_truth() -> None:
    """The published wind estimate tracks the rotor-effective wind (mean error within 3 %,
    the EKF's Cp table equals the plant's) and the regime is region 3 above rated."""
    truth, status = _run("iea15mw-lqri-15")
    t_s = _after(status, "sample_time_ns")
    u_true = np.interp(t_s, truth["sample_time_ns"], truth["wind_speed_m_s"])
    err = _after(status, "wind_speed_estimated_m_s") - u_true
    assert abs(np.mean(err) / np.mean(u_true)) < 0.03, np.mean(err)
    assert np.mean(_after(status, "regime") == 4) > 0.9
    assert np.all(_after(status, "compute_time_ns") > 0)


def _wave_band_variance(truth: dict[str, np.ndarray]) -> float:
    """Rotor-speed variance [(rad/s)^2] in the wave band over ``FF_WINDOW_S``.

    Zero-phase 4th-order Butterworth band-pass over the whole record (so the window has no
    filter transient), then :math:`\\mathrm{var}\\,\\omega_{bp}` on the window.
    """
    t_s = truth["sample_time_ns"] * 1e-9
    fs = 1.0 / float(np.median(np.diff(t_s)))
    sos = butter(4, WAVE_BAND_HZ, btype="band", fs=fs, output="sos")
    band = sosfiltfilt(sos, truth["rotor_speed_rad_s"])
    keep = (t_s >= FF_WINDOW_S[0]) & (t_s <= FF_WINDOW_S[1])
    return float(np.var(band[keep]))


def test_wave_feedforward_lowers_rotor_speed_variance_on_the_nonlinear_plant() -> None:
    """LC1 on the nonlinear plant: the wave-band rotor-speed variance is lower with the FF
    by at least 15 % (measured: 38 % over 235-300 s; 37 % over 210-600 s in a 600 s run, see
    the :mod:`controller.runtime` docstring), and the FF torque is really applied (nonzero,
    finite, published)."""
    ff, ff_status = _run("iea15mw-lc1-lqri-ff", FF_DURATION_S)
    no, _ = _run("iea15mw-lc1-lqri", FF_DURATION_S)
    v_ff, v_no = _wave_band_variance(ff), _wave_band_variance(no)
    reduction = 1.0 - v_ff / v_no
    msg = f"wave-band variance {v_ff:.3e} (FF) vs {v_no:.3e}: reduction {100 * reduction:.1f} %"
    assert reduction > 0.15, msg
    t_s = ff_status["sample_time_ns"] * 1e-9
    keep = t_s >= FF_WINDOW_S[0]
    tq = ff_status["feedforward_torque_nm"][keep]
    assert np.all(np.isfinite(tq)) and float(np.std(tq)) > 1e4, msg
