"""Hexicon H3 on the bench's bus: identification over the bus, the identified-model MPC,
sensor channels, the review of a platform recording, and the CAN transport.

Each bus test runs real OS processes (plant, controller or PRBS excitation, recorder) over
Zenoh on loopback (or CAN frames on python-can's ``udp_multicast`` inside a private network
namespace) and reads the MCAP file they wrote.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from _helpers import can_netns_skip_reason
from rich.console import Console

from controller.design.hexicon_identify import TABLE5, experiment_wind
from controller.hexicon import (
    HexiconMeasurement,
    PrbsExcitation,
    load_design,
    load_identified,
    make_id_mpc,
)
from hil.cli.hexicon import record_experiment
from hil.families import HexiconOptions
from hil.hexicon.model import compute_kpis, load_scenarios, run_in_process
from hil.hexicon.nodes import read_platform_run
from hil.launch import RunRequest, launch
from plant.hexicon.sensors import HexiconSensors, load_sensor_table

pytestmark = pytest.mark.e2e


def run_platform(
    out: Path, controller: str, duration_s: float, transport: str = "zenoh", plots: bool = False
) -> dict[str, Any]:
    """A lock-step run of scenario 1 through the launcher (``fowt run hexicon-s1_step15``);
    its summary."""
    req = RunRequest(
        scenario="hexicon-s1_step15",
        mode="lockstep",
        duration_s=duration_s,
        transport=transport,
        out_dir=out,
        plots=plots,
        hexicon=HexiconOptions(controller=controller),
    )
    return launch(req, Console(quiet=True))


# ----------------------------------------------------------------------------- sensors
def test_sensor_channels_are_seeded_and_match_the_preset() -> None:
    """The preset's channels: same seed -> same series, another seed -> another; the heading
    error's std is the preset's σ within 10 % (2000 samples: σ of a std estimate ≈ 1.6 %,
    plus the 1e-4 rad resolution), and an unknown channel is refused by name."""
    table = load_sensor_table()
    assert table["seed"] == 14 and "heading" in table
    from plant.hexicon.sensors import HexiconSample

    truth = HexiconSample(
        {"heading": 0.1, "yaw_rate": 0.0, "wind_direction": 0.2, "wind_speed": 12.0},
        tuple(
            {"rotor_speed": 1.0, "pitch": 0.1, "power": 5e6, "nacelle_wind": 11.0} for _ in range(3)
        ),  # type: ignore[arg-type]
    )

    def series(seed: int) -> np.ndarray:
        s = HexiconSensors(table, seed)
        return np.array([s.measure(k * 10**9, truth).platform["heading"] for k in range(2000)])

    a, b, c = series(1), series(1), series(2)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.std(a - 0.1) == pytest.approx(table["heading"]["std"], rel=0.10)
    with pytest.raises(ValueError, match="unknown channel"):
        HexiconSensors({"compass": {"std": 1.0}})


# ----------------------------------------------------------------------------- identification
def test_identification_experiment_over_the_bus(tmp_path: Path) -> None:
    """One short table-5 experiment (experiment 3, 200 cycles) as plant, PRBS excitation and
    recorder processes. From the MCAP alone: the true wind is the experiment's PRBS wind
    sample for sample; every commanded pitch is the excitation's PRBS level floored at the
    rated pitch of the measured wind (to 1e-9 rad); the measured frames differ from the truth
    (noise) and the excitation never saw the truth (its floor follows the measured speed)."""
    n = 200
    s = record_experiment(3, tmp_path, duration_s=float(n), seed=5)
    assert s["run"]["exit_code"] == 0, s["run"]
    assert s["run"]["kind"] == "identification" and s["run"]["controller"] == "prbs"
    assert s["timing"]["cycles"] == n and s["timing"]["commands_rejected"] == 0
    run = read_platform_run(tmp_path / "run.mcap")
    truth = [f for f in run["fowt/h3/platform/truth"] if not f["final"]]
    meas = [f for f in run["fowt/h3/platform"] if not f["final"]]
    speeds, dirs = experiment_wind(2, n, 5)
    assert [f["wind_speed_measured_m_s"] for f in truth] == pytest.approx(speeds, abs=1e-12)
    assert [math.degrees(f["wind_direction_measured_rad"]) for f in truth] == pytest.approx(
        dirs, abs=1e-9
    )
    assert any(
        abs(a["wind_speed_measured_m_s"] - b["wind_speed_measured_m_s"]) > 1e-3
        for a, b in zip(meas, truth, strict=True)
    )
    lo, hi = TABLE5[2][2]
    levels = PrbsExcitation(lo, hi, n, 2, 5).signals()
    d = load_design()
    for i, t in enumerate(("t1", "t2", "t3")):
        cmds = {
            c["answered_seq"]: c["blade_pitch_commanded_rad"]
            for c in run[f"fowt/h3/{t}/rotor/command"]
        }
        assert len(cmds) == n
        for k in range(n):
            want = max(
                math.radians(lo + (hi - lo) * levels[i, k]),
                d.rated_pitch_rad(meas[k]["wind_speed_measured_m_s"]),
            )
            assert cmds[k] == pytest.approx(want, abs=1e-9)


def test_identify_over_bus_fits_and_saves_a_loadable_model(tmp_path: Path) -> None:
    """``identify_over_bus`` on two short experiments (400 cycles each; 1 estimation, 2
    held out): order from the singular values within [1, 15], fits reported for both sets,
    the estimation fit of the yaw rate above 0 % (better than its mean), and the artefact
    loads and builds the identified-model MPC."""
    from hil.hexicon.identify import identify_over_bus

    res = identify_over_bus(
        tmp_path, duration_s=400.0, block_rows=8, experiments=(1, 2), record=record_experiment
    )
    assert res["runs"]["exp1"]["plant_cycles"] == 400
    assert 1 <= res["order"] <= 15
    assert res["fit_estimation_percent"]["yaw_rate_deg_s"] > 0.0
    assert set(res["fit_validation_percent"]) == {"yaw_rate_deg_s", "power_mw"}
    m = load_identified(tmp_path / "identified.json")
    assert m.a.shape == (res["order"], res["order"])
    assert np.max(np.abs(np.linalg.eigvals(m.a - m.a @ m.kalman_gain @ m.c))) < 1.0
    make_id_mpc(load_design(), m)


# ----------------------------------------------------------------------------- identified MPC
def test_identified_mpc_respects_constraints_and_turns_the_platform() -> None:
    """The shipped identified-model MPC on scenario 1 (15° step at 15 m/s, noisy sensors,
    in process, 200 s): no commanded pitch outside [θ_r(V_m), 25°], and the heading error
    falls below half the step (the identified model gets the sign of the yaw authority
    right)."""
    scn = load_scenarios()["s1_step15"]
    from dataclasses import replace

    scn = replace(scn, duration_s=200.0)
    log = run_in_process(scn, "mpc_id")
    k = compute_kpis(log, scn)
    assert k["constraint_violations"] == 0
    e = np.degrees(np.subtract(log.direction, log.heading))
    assert abs(e[-1]) < 7.5


def test_identified_mpc_first_move_pitches_the_right_turbines() -> None:
    """A platform lagging the wind by 15° (e > 0): the identified-model MPC raises the
    pitch of turbines 1 and 3 above that of turbine 2 (the seed's rule), within rate limits."""
    from controller.hexicon import id_mpc_step

    d = load_design()
    st = make_id_mpc(d, load_identified())
    m = HexiconMeasurement(0.0, 0.0, math.radians(15.0), 15.0, (1.0, 1.0, 1.0))
    for _ in range(5):
        st, cmd, _ = id_mpc_step(st, m, 18e6, 1.0)
    p = np.degrees(cmd.pitch_rad)
    lo = math.degrees(d.rated_pitch_rad(15.0))
    assert p[0] > p[1] + 1.0 and p[2] > p[1] + 1.0
    assert all(lo - 1e-6 <= x <= lo + 5 * 2.0 + 1e-6 for x in p)


# ----------------------------------------------------------------------------- review
def test_review_of_a_platform_run(tmp_path: Path) -> None:
    """``fowt review`` of a 40 s lock-step bang-bang run: recognised as a platform recording,
    its KPIs equal those of the in-process run of the same cores and sensor seed (to 1e-9),
    latency and compute percentiles present, no deadline miss, and the plot written."""
    from dataclasses import replace

    from hil.review.core import review

    s = run_platform(tmp_path, "bang_bang", 40.0)
    assert s["run"]["exit_code"] == 0, s["run"]
    summ = review(tmp_path / "run.mcap", tmp_path / "review")
    assert summ["kind"] == "hexicon" and summ["run"]["kind"] == "run"
    scn = replace(load_scenarios()["s1_step15"], duration_s=40.0)
    ref = compute_kpis(run_in_process(scn, "bang_bang"), scn)
    for key in ("heading_rms_deg", "energy_ratio", "pitch_travel_deg", "constraint_violations"):
        assert summ["kpi"][key] == pytest.approx(ref[key], abs=1e-9), key
    assert summ["timing"]["latency_us"]["p99"] > 0
    assert summ["timing"]["deadline_misses"] == 0 and summ["timing"]["cycles"] == 40
    assert summ["timing"]["controller_compute_us"]["p50"] > 0
    assert (tmp_path / "review" / "hexicon.png").stat().st_size > 10_000
    on_disk = json.loads((tmp_path / "review" / "summary.json").read_text())
    assert on_disk["kind"] == "hexicon"


# ----------------------------------------------------------------------------- CAN
_CAN_SKIP = can_netns_skip_reason()


@pytest.mark.skipif(_CAN_SKIP is not None, reason=_CAN_SKIP or "")
def test_platform_run_over_can_matches_zenoh(tmp_path: Path) -> None:
    """A 30 s lock-step MPC run with frames and commands as CAN frames (udp_multicast in a
    private namespace): every cycle answered, no CAN rejection, the recorder saw every frame
    (3 x 4 TurbineFrame + 4 PlatformFrame parts per cycle, 3 x 4 command parts per
    answered cycle), and the KPIs are within 1 % (0.05° on the RMS) of the Zenoh run's:
    only the DBC quantisation differs."""
    can = run_platform(tmp_path / "can", "mpc", 30.0, transport="can")
    assert can["run"]["exit_code"] == 0, can["run"]
    assert can["run"]["transport"] == "can" and can["run"]["can_interface"] == "udp_multicast"
    assert can["timing"]["commands_rejected"] == 0 and can["run"]["can_rejected"] == "0"
    assert can["run"]["can_frames_received"] == str(31 * 16 + 30 * 12)
    zen = run_platform(tmp_path / "zenoh", "mpc", 30.0)
    assert zen["run"]["exit_code"] == 0, zen["run"]
    kc, kz = can["kpi"], zen["kpi"]
    assert kc["heading_rms_deg"] == pytest.approx(kz["heading_rms_deg"], abs=0.05)
    assert kc["energy_ratio"] == pytest.approx(kz["energy_ratio"], rel=0.01)
    assert kc["constraint_violations"] == 0
