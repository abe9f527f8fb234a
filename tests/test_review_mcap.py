"""Review of a synthetic MCAP run written with :class:`hil.runlog.mcap_io.RunLog`."""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from _helpers import cycle_timing, timing_summary
from rich.console import Console

from bus_schemas.messages import (
    ActuatorCommand,
    ControllerStatus,
    PlantState,
    SensorFrame,
    TimingSummary,
)
from bus_schemas.registry import (
    COMMAND,
    CONTROLLER_STATUS,
    CYCLE_TIMING,
    SENSORS,
    TIMING_SUMMARY,
    TRUTH,
)
from hil.review import kpi
from hil.review.core import PLOT_FILES, render_summary, review, truncation_note
from hil.runlog.mcap_io import RunLog

TURBINE = "t1"
N = 1500
DT_NS = 20_000_000  # 50 Hz
AERO_AMPLITUDE_NM = 2.0e6
AERO_FREQ_HZ = 0.5  # 25 samples per cycle, integer cycles over the run
SCENARIO_CFG = {
    "wind": {"mean_m_s": 11.4, "ti": 0.1},
    "duration_s": 30.0,
    "seed": 7,
    "timing": {"control_period_s": 0.02},
    "review": {"settle_s": 0.0},  # KPIs over the whole record (the settling test sets more)
}
DEADLINE_NS = 20_000_000


@dataclass
class Written:
    """What the synthetic run put into the file, for the checks."""

    path: Path
    t_s: np.ndarray
    power_w: np.ndarray
    rotor_rad_s: np.ndarray
    pitch_rad: np.ndarray
    gen_torque_nm: np.ndarray
    thrust_n: np.ndarray
    platform_pitch_rad: np.ndarray
    latency_ns: np.ndarray
    missed: np.ndarray
    held: np.ndarray
    compute_ns: np.ndarray
    final: TimingSummary


def _write_run(path: Path, scenario_cfg: dict | None = None) -> Written:
    rng = np.random.default_rng(20240601)
    k = np.arange(N)
    t_ns = k * DT_NS
    t_s = t_ns / 1e9
    rotor = 1.2 + 0.05 * np.sin(2 * np.pi * 0.1 * t_s) + rng.normal(0.0, 0.005, N)
    # Pitch: triangle between 0.05 and 0.15 rad with slope 0.02 rad/s (5 s ramps).
    phase = np.mod(t_s, 10.0)
    pitch = 0.05 + 0.02 * np.where(phase <= 5.0, phase, 10.0 - phase)
    gen_torque = 4.0e4 + rng.normal(0.0, 500.0, N)
    power = 5.0e6 + rng.normal(0.0, 1.0e5, N)
    thrust = 7.0e5 + rng.normal(0.0, 2.0e4, N)
    aero = 4.0e6 + AERO_AMPLITUDE_NM * np.sin(2 * np.pi * AERO_FREQ_HZ * t_s)
    wind = 11.0 + rng.normal(0.0, 0.5, N)
    platform = np.radians(2.0) + rng.normal(0.0, np.radians(0.5), N)
    surge = 10.0 + 0.5 * np.sin(2 * np.pi * 0.01 * t_s)
    latency = rng.lognormal(np.log(300e3), 0.3, N).astype(np.int64) + 1
    missed = rng.random(N) < 0.01
    missed[N // 3] = True  # at least one miss before the 60 % cut
    # A missed cycle logs the latency of its late command, or 0 when none came (unanswered):
    # every other missed cycle is of each kind.
    late = missed & (np.cumsum(missed) % 2 == 0)
    latency[late] = DEADLINE_NS + rng.integers(1, 5_000_000, int(late.sum()))
    latency[missed & ~late] = 0
    held = missed.copy()
    compute = rng.integers(20_000, 80_000, N)

    log = RunLog(path, TURBINE, start_unix_ns=1_700_000_000_000_000_000, flush_interval_s=0.0)
    log.add_metadata(
        "scenario",
        {
            "name": "synthetic",
            "toml": "duration_s = 30.0\n",
            "json": json.dumps(SCENARIO_CFG if scenario_cfg is None else scenario_cfg),
        },
    )
    log.add_metadata("run", {"mode": "sim", "transport": "inproc", "seed": "7"})
    wall0 = 10_000_000_000
    for i in range(N):
        ts = int(t_ns[i])
        pub = wall0 + ts // 2  # twice real time
        log.write(
            SENSORS.key(TURBINE),
            SensorFrame(
                seq=i,
                sample_time_ns=ts,
                publish_time_ns=pub,
                valid_mask=0xFFFF,
                generator_speed_measured_rad_s=float(rotor[i]) * 97.0,
                rotor_speed_measured_rad_s=float(rotor[i]),
                blade_pitch_measured_rad=float(pitch[i]),
                generator_torque_measured_nm=float(gen_torque[i]),
                electrical_power_measured_w=float(power[i]),
                wind_speed_measured_m_s=float(wind[i]) * 0.9,
                nacelle_acc_fore_aft_measured_m_s2=0.0,
                platform_pitch_measured_rad=float(platform[i]),
                platform_pitch_rate_measured_rad_s=0.0,
                platform_surge_measured_m=0.0,
                wave_elevation_gauge_measured_m=0.0,
            ),
        )
        log.write(
            COMMAND.key(TURBINE),
            ActuatorCommand(
                seq=i,
                answered_seq=i,
                sample_time_ns=ts,
                publish_time_ns=pub + 300_000,
                mode=1,
                blade_pitch_commanded_rad=float(pitch[i]),
                generator_torque_commanded_nm=float(gen_torque[i]),
            ),
        )
        log.write(
            CONTROLLER_STATUS.key(TURBINE),
            ControllerStatus(
                seq=i,
                answered_seq=i,
                sample_time_ns=ts,
                publish_time_ns=pub + 300_000,
                compute_time_ns=int(compute[i]),
                regime=3,
                rejected_frames=0,
                generator_speed_filtered_rad_s=float(rotor[i]) * 97.0,
                pitch_integrator_rad=0.0,
                gain_schedule_factor=1.0,
            ),
        )
        log.write(
            TRUTH.key(TURBINE),
            PlantState(
                seq=i,
                sample_time_ns=ts,
                publish_time_ns=pub,
                rotor_speed_rad_s=float(rotor[i]),
                generator_speed_rad_s=float(rotor[i]) * 97.0,
                blade_pitch_rad=float(pitch[i]),
                generator_torque_nm=float(gen_torque[i]),
                aero_torque_nm=float(aero[i]),
                rotor_thrust_n=float(thrust[i]),
                wind_speed_m_s=float(wind[i]),
                relative_wind_speed_m_s=float(wind[i]),
                electrical_power_w=float(power[i]),
                tip_speed_ratio=7.5,
                power_coefficient=0.45,
                thrust_coefficient=0.75,
                blade_pitch_applied_rad=float(pitch[i]),
                generator_torque_applied_nm=float(gen_torque[i]),
                floating=1,
                platform_pitch_rad=float(platform[i]),
                platform_surge_m=float(surge[i]),
                shaft_torque_nm=float(aero[i]),
                tower_base_moment_nm=float(2.0 * aero[i]),
            ),
        )
        log.write(
            CYCLE_TIMING.key(TURBINE),
            cycle_timing(
                i,
                ts,
                publish_time_ns=pub,
                latency_ns=int(latency[i]),
                deadline_missed=int(missed[i]),
                command_held=int(held[i]),
                plant_compute_ns=50_000,
                tick_lateness_ns=1_000,
            ),
        )
        if i in (N // 2, N - 1):
            final = timing_summary(
                i + 1, ts, seq=0 if i < N - 1 else 1, publish_time_ns=pub,
                deadline_misses=int(missed[: i + 1].sum()),
                commands_held=int(held[: i + 1].sum()), commands_rejected=3, commands_late=2,
                final=int(i == N - 1), latency_p50_us=300.0, latency_p99_us=600.0,
                latency_p999_us=800.0, latency_max_us=900.0, sim_seconds_per_wall_second=2.0,
            )  # fmt: skip
            log.write(TIMING_SUMMARY.key(TURBINE), final)
    log.close()
    return Written(
        path, t_s, power, rotor, pitch, gen_torque, thrust, platform, latency, missed, held,
        compute, final,
    )  # fmt: skip


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> Written:
    return _write_run(tmp_path_factory.mktemp("run") / "run.mcap")


@pytest.fixture(scope="module")
def reviewed(written: Written, tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    out = tmp_path_factory.mktemp("review")
    return review(written.path, out), out


def test_summary_timing_matches_written(reviewed: tuple[dict, Path], written: Written) -> None:
    s, _ = reviewed
    tm = s["timing"]
    assert tm["complete"] is True
    assert tm["cycles"] == N
    assert tm["cycles_logged"] == N
    assert tm["deadline_misses"] == int(written.missed.sum()) > 0
    assert tm["commands_held"] == int(written.held.sum())
    assert tm["commands_rejected"] == 3
    assert tm["commands_late"] == 2
    assert tm["safe_state"] == 0
    assert tm["sim_seconds_per_wall_second"] == 2.0
    # Percentiles over ALL cycles: a late command at its latency, an unanswered cycle as
    # beyond any latency (numpy's linear percentile with a huge stand-in, mapped back to inf).
    unanswered = written.latency_ns == 0
    assert tm["unanswered_cycles"] == int(unanswered.sum()) > 0
    assert tm["latency_cycles"] == N
    assert tm["deadline_us"] == pytest.approx(DEADLINE_NS / 1e3)
    lat_us = np.where(unanswered, 1e300, written.latency_ns / 1e3)
    assert tm["latency_source"] == "timing/cycle"
    for key, q in (("p50", 50), ("p99", 99), ("p999", 99.9)):
        want = float(np.percentile(lat_us, q))
        if want > 1e200:
            assert tm["latency_us"][key] is None, key  # inf -> JSON null
        else:
            assert tm["latency_us"][key] == pytest.approx(want, rel=1e-12)
    assert tm["latency_us"]["p50"] is not None
    assert tm["latency_us"]["max"] is None  # some cycle was never answered
    # The late commands of missed cycles count at their real latency (above the deadline).
    late = written.missed & ~unanswered
    assert late.any() and (written.latency_ns[late] > DEADLINE_NS).all()
    assert tm["latency_us_plant"] == {"p50": 300.0, "p99": 600.0, "p999": 800.0, "max": 900.0}
    comp_us = written.compute_ns / 1e3
    cc = tm["controller_compute_us"]
    assert cc["p50"] == pytest.approx(np.percentile(comp_us, 50), rel=1e-12)
    assert cc["p99"] == pytest.approx(np.percentile(comp_us, 99), rel=1e-12)
    assert cc["max"] == pytest.approx(comp_us.max(), rel=1e-12)


def test_summary_kpis_match_written(reviewed: tuple[dict, Path], written: Written) -> None:
    s, _ = reviewed
    k = s["kpi"]
    assert k["mean_power_w"] == pytest.approx(written.power_w.mean(), rel=1e-12)
    assert k["rotor_speed_mean_rad_s"] == pytest.approx(written.rotor_rad_s.mean(), rel=1e-12)
    assert k["rotor_speed_std_rad_s"] == pytest.approx(written.rotor_rad_s.std(), rel=1e-12)
    assert k["generator_torque_mean_nm"] == pytest.approx(written.gen_torque_nm.mean(), rel=1e-12)
    assert k["thrust_mean_n"] == pytest.approx(written.thrust_n.mean(), rel=1e-12)
    assert k["thrust_max_n"] == pytest.approx(written.thrust_n.max(), rel=1e-12)
    # Triangle pitch of slope 0.02 rad/s sampled at its corners (every 5 s = 250 samples).
    assert k["pitch_travel_deg_s"] == pytest.approx(math.degrees(0.02), rel=1e-9)
    # Pure sine of amplitude A over n cycles: DEL = 2A (n / (f_eq T))^(1/4).
    duration = written.t_s[-1] - written.t_s[0]
    n_cycles = AERO_FREQ_HZ * duration
    expected_del = 2 * AERO_AMPLITUDE_NM * (n_cycles / duration) ** 0.25
    assert k["shaft_del_nm"] == pytest.approx(expected_del, rel=0.01)
    assert k["shaft_del_wohler_m"] == 4.0
    assert k["platform_pitch_std_deg"] == pytest.approx(
        math.degrees(written.platform_pitch_rad.std()), rel=1e-9
    )
    assert k["platform_pitch_mean_deg"] == pytest.approx(
        math.degrees(written.platform_pitch_rad.mean()), rel=1e-9
    )
    # The tower-base moment was written as twice the shaft torque: the DEL is linear in scale.
    assert k["tower_base_del_nm"] == pytest.approx(2.0 * k["shaft_del_nm"], rel=1e-12)
    assert k["surge_mean_m"] == pytest.approx(10.0, abs=0.5)
    assert k["surge_std_m"] > 0.0


def test_summary_run_and_scenario(reviewed: tuple[dict, Path], written: Written) -> None:
    s, _ = reviewed
    r = s["run"]
    assert r["truncated"] is False
    assert r["error"] == ""
    assert r["turbine"] == TURBINE
    assert r["mode"] == "sim" and r["transport"] == "inproc"
    assert r["duration_s"] == pytest.approx((N - 1) * DT_NS / 1e9, rel=1e-12)
    assert r["messages"] == {
        "sensors": N,
        "command": N,
        "truth": N,
        "controller/status": N,
        "timing/cycle": N,
        "timing/summary": 2,
        # preview/wave_perfect is declared in every log, and listed only for a scenario with
        # the perfect wave preview (hil.review.core.could_have)
        "timing/report": 0,  # this synthetic log has no end-of-run reports
        "controller/report": 0,
    }
    assert s["scenario"] == {"name": "synthetic", "config": SCENARIO_CFG}


def test_summary_json_and_plots_written(reviewed: tuple[dict, Path]) -> None:
    s, out = reviewed
    text = (out / "summary.json").read_text()
    loaded = json.loads(text)  # valid JSON (no NaN tokens: json.dumps used allow_nan=False)
    assert "NaN" not in text
    assert loaded == s
    for key in ("p50", "p99"):
        assert isinstance(loaded["timing"]["latency_us"][key], float)
    for key in ("deadline_misses", "cycles", "commands_held", "commands_rejected"):
        assert isinstance(loaded["timing"][key], int)
    for name in PLOT_FILES:
        png = out / name
        assert png.exists()
        assert png.stat().st_size > 10_000
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_truncated_file_still_reviews(written: Written, tmp_path: Path) -> None:
    data = written.path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(0.6 * len(data))])
    s = review(cut, tmp_path / "out")
    assert s["run"]["truncated"] is True
    assert s["timing"]["complete"] is False
    n_cyc = s["timing"]["cycles_logged"]
    assert 0 < n_cyc < N
    assert s["timing"]["cycles"] == n_cyc
    assert sum(s["run"]["messages"].values()) < 5 * N + 2
    # Counts of the surviving prefix, derived from the cycles alone.
    assert s["timing"]["deadline_misses"] == int(written.missed[:n_cyc].sum()) > 0
    assert s["timing"]["commands_held"] == int(written.held[:n_cyc].sum())
    # The running (non-final) summary at N/2 survived the 60 % cut: its counters are used.
    assert s["timing"]["commands_rejected"] == 3
    assert s["timing"]["sim_seconds_per_wall_second"] == pytest.approx(2.0, rel=1e-9)
    lat = written.latency_ns[:n_cyc]
    if (lat == 0).any():  # an unanswered cycle survived the cut: its latency is unbounded
        assert s["timing"]["latency_us"]["max"] is None
    else:
        assert s["timing"]["latency_us"]["max"] == pytest.approx(lat.max() / 1e3, rel=1e-12)
    # The cut is reported with the time of the last message that survived it.
    t_last = (n_cyc - 1) * DT_NS / 1e9
    assert s["run"]["truncated_at_s"] == pytest.approx(t_last, abs=DT_NS / 1e9)
    assert truncation_note(s).startswith(f"truncated at t = {s['run']['truncated_at_s']:.2f} s")
    assert s["scenario"]["name"] == "synthetic"
    json.loads((tmp_path / "out" / "summary.json").read_text())
    for name in PLOT_FILES:
        assert (tmp_path / "out" / name).stat().st_size > 0


def test_empty_run_reviews_with_nulls(tmp_path: Path) -> None:
    path = tmp_path / "empty.mcap"
    RunLog(path, TURBINE).close()
    s = review(path, tmp_path / "out")
    assert s["kpi"]["mean_power_w"] is None
    assert s["timing"]["latency_us"]["p50"] is None
    assert s["timing"]["cycles"] == 0
    assert s["run"]["truncated"] is False
    json.loads((tmp_path / "out" / "summary.json").read_text())


def test_render_summary_shows_misses(reviewed: tuple[dict, Path]) -> None:
    s, _ = reviewed
    console = Console(file=io.StringIO(), record=True, width=140, force_terminal=True)
    render_summary(s, console)
    text = console.export_text(clear=False)
    assert "deadline misses" in text
    assert str(s["timing"]["deadline_misses"]) in text
    assert "MW" in text and "kN m" in text and "deg/s" in text
    styled = console.export_text(styles=True)
    misses = s["timing"]["deadline_misses"]
    assert f"\x1b[1;31m{misses}\x1b[0m" in styled  # misses > 0 are bold red


def test_kpi_module_agrees_with_summary(reviewed: tuple[dict, Path], written: Written) -> None:
    s, _ = reviewed
    assert s["kpi"]["pitch_travel_deg_s"] == pytest.approx(
        kpi.pitch_travel_deg_s(written.t_s, written.pitch_rad), rel=1e-12
    )
