"""The advanced controller's cycle (controller.runtime) inside the node's ControllerRuntime.

Frames are synthetic: the steady 15 m/s operating point of the LQRI design (rotor at rated,
pitch and platform at their operating values) with small seeded noise, so each test controls
exactly which channels are valid.
"""

from __future__ import annotations

import math
import struct
import subprocess
import sys
from typing import Any

import numpy as np
import pytest

from bus_schemas import SensorFrame
from bus_schemas.messages import (
    EST_WAVE_FORECAST,
    EST_WIND_SPEED,
    VALID_BITS,
    VALID_NACELLE_ACC,
    VALID_WAVE_GAUGE,
)
from bus_schemas.registry import SENSORS
from controller.lqri import load_lqri_design
from hil.nodes.controller_node import ControllerRuntime
from hil.scenario.schema import load_scenario

DT_NS = 25_000_000
ALL_VALID = sum(VALID_BITS.values())


def _frames(n: int, drop: int = 0, drop_from: int = 0, seed: int = 0) -> list[SensorFrame]:
    """n frames at 40 Hz; ``drop`` valid bits cleared from frame ``drop_from`` on."""
    d = load_lqri_design("iea15mw_volturnus")
    i = d.wind_m_s.index(15.0)
    x = d.x_op[i]
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        mask = ALL_VALID & ~drop if k >= drop_from else ALL_VALID
        t = k * DT_NS
        eta = 0.5 * math.sin(2.0 * math.pi * t * 1e-9 / 9.5)
        out.append(
            SensorFrame(
                seq=k,
                sample_time_ns=t,
                publish_time_ns=t,
                valid_mask=mask,
                generator_speed_measured_rad_s=d.rated_rotor_speed_rad_s
                + 0.002 * rng.standard_normal(),
                rotor_speed_measured_rad_s=d.rated_rotor_speed_rad_s,
                blade_pitch_measured_rad=d.theta_op[i],
                generator_torque_measured_nm=d.rated_torque_nm,
                electrical_power_measured_w=15e6,
                wind_speed_measured_m_s=15.0,
                nacelle_acc_fore_aft_measured_m_s2=0.01 * rng.standard_normal()
                if mask & VALID_NACELLE_ACC
                else 0.0,
                platform_pitch_measured_rad=x[1] + 1e-4 * rng.standard_normal(),
                platform_pitch_rate_measured_rad_s=6e-4 * rng.standard_normal(),
                platform_surge_measured_m=x[0] + 0.02 * rng.standard_normal(),
                wave_elevation_gauge_measured_m=eta if mask & VALID_WAVE_GAUGE else 0.0,
            )
        )
    return out


@pytest.fixture
def runtime() -> ControllerRuntime:
    return ControllerRuntime(load_scenario("iea15mw-lqri-15"))


def _count_core_calls(rt: ControllerRuntime) -> list[int]:
    calls = [0]
    inner = rt.controller.step

    def counted(state: Any, frame: SensorFrame, dt_s: float) -> Any:
        calls[0] += 1
        return inner(state, frame, dt_s)

    rt.controller.step = counted  # type: ignore[method-assign,assignment]
    return calls


def test_bad_and_nan_frames_never_reach_the_core(runtime: ControllerRuntime) -> None:
    """A NaN in a payload (codec), a NaN frame handed over in process, a duplicate, a stale
    frame and garbage bytes are rejected and counted; the core is called for good frames only."""
    calls = _count_core_calls(runtime)
    good = _frames(3)
    assert runtime.handle_frame(good[0]) is not None
    payload = bytearray(SENSORS.codec.encode(good[1]))
    marker = struct.pack("<d", good[1].platform_surge_measured_m)
    pos = bytes(payload).find(marker)
    assert pos > 0
    payload[pos : pos + 8] = struct.pack("<d", math.nan)
    assert runtime.handle_payload(bytes(payload)) is None
    nan_frame = SensorFrame(**{**_asdict(good[1]), "platform_surge_measured_m": math.nan})
    assert runtime.handle_frame(nan_frame) is None
    assert runtime.handle_payload(b"\x00garbage") is None
    assert runtime.handle_frame(good[0]) is None  # duplicate
    assert runtime.handle_frame(good[2]) is not None
    assert calls[0] == 2
    assert runtime.rejected_total == 4
    assert runtime.rejected["non_finite"] == 2  # one from the codec, one in process


def _asdict(frame: SensorFrame) -> dict[str, Any]:
    return {name: getattr(frame, name) for name in frame.__struct_fields__}


def test_degraded_flag_published_when_the_imu_drops_out(runtime: ControllerRuntime) -> None:
    """The IMU acceleration channel invalid from t = 5 s on: the status says degraded once it
    has been missing for longer than the design's 0.5 s (20 cycles at 40 Hz), not before."""
    frames = _frames(400, drop=VALID_NACELLE_ACC, drop_from=200)
    flags = []
    for f in frames:
        result = runtime.handle_frame(f)
        assert result is not None
        flags.append(result[1].estimator_degraded)
        assert result[1].estimates_valid_mask & EST_WIND_SPEED
    assert not any(flags[:200])
    assert not any(flags[200:215])
    assert all(flags[225:])


def test_forecast_is_for_sample_time_plus_horizon(runtime: ControllerRuntime) -> None:
    """Once the dispersion filter has filled (1024 taps at 0.2 s = 204.8 s), every status has
    a forecast whose target time is the forecaster's call time plus the 10 s horizon, the call
    time being the latest multiple of 0.2 s not after the status's sample time."""
    horizon_ns = 10_000_000_000
    period_ns = 200_000_000
    seen = 0
    for f in _frames(round(215.0 / 0.025)):
        result = runtime.handle_frame(f)
        assert result is not None
        st = result[1]
        if st.estimates_valid_mask & EST_WAVE_FORECAST:
            seen += 1
            call_ns = (st.sample_time_ns // period_ns) * period_ns
            assert st.wave_forecast_time_ns == call_ns + horizon_ns
            assert math.isfinite(st.wave_elevation_forecast_m)
        else:
            assert st.sample_time_ns < 206e9
    assert seen > 300


def test_advanced_controller_never_imports_plant() -> None:
    """Loading a floating scenario, building the advanced controller and running cycles on
    frames loads no ``plant`` module (the controller process's whole path)."""
    code = (
        "import sys\n"
        "from controller.registry import make_controller\n"
        "from hil.scenario.schema import load_scenario\n"
        "from tests.test_controller_runtime import _frames\n"
        "load_scenario('iea15mw-lqri-15')\n"
        "c = make_controller('lqri', 'iea15mw_advanced', control_period_s=0.025)\n"
        "s = c.initial_state()\n"
        "for f in _frames(50):\n"
        "    s, out = c.step(s, f, 0.025)\n"
        "print(sorted(m for m in sys.modules if m == 'plant' or m.startswith('plant.')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_lqri_ff_publishes_its_feedforward_part() -> None:
    """kind "lqri_ff": the status sets EST_FEEDFORWARD; the forecast horizon is the FF
    design's preview time."""
    from bus_schemas.messages import EST_FEEDFORWARD
    from controller.registry import make_controller
    from controller.runtime import AdvancedController

    ctrl = make_controller("lqri_ff", "iea15mw_advanced", control_period_s=0.025)
    assert isinstance(ctrl, AdvancedController)
    state = ctrl.initial_state()
    for f in _frames(40):
        state, out = ctrl.step(state, f, 0.025)
        assert out.estimates_valid_mask & EST_FEEDFORWARD
        assert math.isfinite(out.feedforward_pitch_rad + out.feedforward_torque_nm)


def test_status_carries_the_core_output_field_by_field(runtime: ControllerRuntime) -> None:
    """handle_frame builds the status positionally: every field named like one of the core's
    output equals it, and the stamps are the frame's and the command's (400 cycles, the
    advanced core with its estimates, forecast and feed-forward)."""
    core_step = runtime.controller.step
    outs: list[Any] = []

    def step(state: Any, frame: SensorFrame, dt: float) -> Any:
        state, out = core_step(state, frame, dt)
        outs.append(out)
        return state, out

    runtime.controller.step = step  # type: ignore[method-assign]
    for f in _frames(400):
        result = runtime.handle_frame(f)
        assert result is not None
        command, status = result
        out = outs[-1]
        shared = [n for n in out.__struct_fields__ if n in status.__struct_fields__]
        assert len(shared) == 19  # (+ estimator_faults, ControllerStatus v3)
        for name in shared:
            if name != "regime":  # the watchdog's safe mode overrides it
                assert getattr(status, name) == getattr(out, name), name
        if command.mode == 0:
            assert status.regime == out.regime
        assert (status.seq, status.answered_seq) == (command.seq, f.seq)
        assert status.sample_time_ns == f.sample_time_ns
        assert status.publish_time_ns == command.publish_time_ns
        assert status.rejected_frames == runtime.rejected_total
    assert len(outs) == 400
