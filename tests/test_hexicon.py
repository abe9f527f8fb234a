"""The Hexicon H3 plant family: wakes vs FLORIS, yaw free decay, the seed's checks, the QP.

Tolerances are stated beside each check. FLORIS (NREL, velocity model ``jensen``) is the
field's reference for the wakes; it is a dev dependency and the test skips with a reason
when it is not installed.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from controller.hexicon import (
    BangBangState,
    HexiconMeasurement,
    MpcConfig,
    bang_bang_step,
    load_design,
    make_mpc,
    mpc_step,
)
from plant.hexicon.model import (
    load_hexicon,
    outputs,
    rated_pitch_rad,
    steady_operating_point,
    step_rk4,
)
from plant.hexicon.wakes import circle_overlap_fraction, jensen_speed_factors

D = 154.0
K = 0.05


# ----------------------------------------------------------------------------- wakes
def _floris_factors(xs, ys, beta_deg, ct, n_grid=160):  # type: ignore[no-untyped-def]
    """Area-mean U/U_inf over each rotor disc from FLORIS' jensen field sampled on a fine grid."""
    floris = pytest.importorskip("floris", reason="floris (dev dependency) is not installed")
    wd = (450.0 - beta_deg) % 360.0  # ours: CCW from +x, from-direction; FLORIS: met convention
    cfg = {
        "name": "jensen check",
        "description": "ours vs FLORIS",
        "floris_version": "v4",
        "logging": {
            "console": {"enable": False, "level": "WARNING"},
            "file": {"enable": False, "level": "WARNING"},
        },
        "solver": {"type": "turbine_grid", "turbine_grid_points": 3},
        "farm": {
            "layout_x": list(xs),
            "layout_y": list(ys),
            "turbine_type": [
                {
                    "turbine_type": "const_ct",
                    "hub_height": 110.0,
                    "rotor_diameter": D,
                    "TSR": 8.0,
                    "power_thrust_table": {
                        "ref_air_density": 1.225,
                        "ref_tilt": 0.0,
                        "cosine_loss_exponent_yaw": 1.88,
                        "cosine_loss_exponent_tilt": 1.88,
                        "wind_speed": [0.0, 3.0, 30.0, 40.0],
                        "power": [0.0, 100.0, 6000.0, 6000.0],
                        "thrust_coefficient": [ct, ct, ct, ct],
                    },
                }
            ],
        },
        "flow_field": {
            "air_density": 1.225,
            "reference_wind_height": 110.0,
            "turbulence_intensities": [0.06],
            "wind_directions": [wd],
            "wind_shear": 0.0,
            "wind_speeds": [10.0],
            "wind_veer": 0.0,
        },
        "wake": {
            "model_strings": {
                "combination_model": "sosfs",
                "deflection_model": "none",
                "turbulence_model": "none",
                "velocity_model": "jensen",
            },
            "enable_secondary_steering": False,
            "enable_yaw_added_recovery": False,
            "enable_transverse_velocities": False,
            "enable_active_wake_mixing": False,
            "wake_deflection_parameters": {"none": {}},
            "wake_velocity_parameters": {"jensen": {"we": K}},
            "wake_turbulence_parameters": {"none": {}},
        },
    }
    fm = floris.FlorisModel(cfg)
    fm.run()
    # a uniform grid over each rotor disc (points in the vertical plane across the wind)
    s = (np.arange(n_grid) + 0.5) / n_grid * 2.0 - 1.0
    gy, gz = np.meshgrid(s, s)
    inside = gy**2 + gz**2 <= 1.0
    gy, gz = gy[inside] * D / 2, gz[inside] * D / 2
    b = math.radians(beta_deg)
    # lateral direction perpendicular to the wind, in our frame
    lat = (-math.sin(b), math.cos(b))
    out = []
    for x0, y0 in zip(xs, ys, strict=True):
        # points 1 cm upstream of the rotor plane, so the rotor's own wake is excluded
        px = x0 + gy * lat[0] + 0.01 * math.cos(b)
        py = y0 + gy * lat[1] + 0.01 * math.sin(b)
        u = fm.sample_flow_at_points(px, py, 110.0 + gz)
        out.append(float(np.mean(u[0])) / 10.0)
    return out


LAYOUTS = {
    # the preset's triangle, and two rows of the field layouts
    "h3_triangle": ((131.33, -65.67, -65.67), (0.0, 165.0, -165.0)),
    "row_4d": ((0.0, 4 * D, 8 * D), (0.0, 0.0, 0.0)),
    "staggered": ((0.0, 3 * D, 6 * D), (0.0, 0.5 * D, -0.3 * D)),
}


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
@pytest.mark.parametrize("beta_deg", [180.0, 176.0, 150.0, 10.0, 40.0, 100.0, 140.0])
@pytest.mark.parametrize("ct", [0.78, 0.4])
def test_jensen_matches_floris_within_1_percent(layout: str, beta_deg: float, ct: float) -> None:
    """Rotor-averaged U/U_inf of ours vs FLORIS' jensen (k = 0.05, sosfs): within 1 % of U.

    FLORIS evaluates the top-hat deficit point-wise; its field is averaged over a 160 x 160
    grid on each disc (~20 000 points, discretisation error of the covered area < 0.2 %).
    """
    xs, ys = LAYOUTS[layout]
    ours = jensen_speed_factors(xs, ys, math.radians(beta_deg), (ct, ct, ct), D, K)
    ref = _floris_factors(xs, ys, beta_deg, ct)
    for i, (a, b) in enumerate(zip(ours, ref, strict=True)):
        assert a == pytest.approx(b, rel=0.01), f"turbine {i + 1}: ours {a:.4f} FLORIS {b:.4f}"


def test_overlap_fraction_limits() -> None:
    """Disjoint discs 0, concentric wider wake 1, half-offset equal discs: the lens formula
    2 acos(1/2) - (√3)/2 over π = 0.3910 (analytic)."""
    assert circle_overlap_fraction(1.0, 1.0, 2.5) == 0.0
    assert circle_overlap_fraction(1.0, 1.5, 0.2) == 1.0
    lens = (2 * math.acos(0.5) - math.sqrt(3) / 2) / math.pi
    assert circle_overlap_fraction(1.0, 1.0, 1.0) == pytest.approx(lens, rel=1e-12)


# ----------------------------------------------------------------------------- yaw dynamics
def test_yaw_free_decay_matches_analytic() -> None:
    """No wind, r(0) = r0: I r' + c r|r| = 0 gives r(t) = r0 / (1 + c r0 t / I) and
    ψ(t) = (I/c) ln(1 + c r0 t / I); RK4 at 0.05 s within 1e-6 relative over 200 s."""
    p = load_hexicon()
    c, inertia = p.drag_constant, p.yaw_inertia_kg_m2
    r0 = math.radians(0.5)
    x: tuple[float, ...] = (0.0, r0) + (0.0,) * 9
    u = (0.0,) * 6 + (0.0, 0.0)
    dt = 0.05
    for _ in range(4000):
        x = step_rk4(x, u, dt, p)
    t = 200.0
    assert x[1] == pytest.approx(r0 / (1 + c * r0 * t / inertia), rel=1e-6)
    assert x[0] == pytest.approx(inertia / c * math.log(1 + c * r0 * t / inertia), rel=1e-6)


def test_seed_check_corner_torque_35deg_stops_in_about_3_minutes() -> None:
    """Seed figure 10: a torque from the three corners yaws the platform 35° and it comes to
    rest in about 3 minutes. Ours: 1 MN tangential at each corner for 50 s; the heading
    passes 35° ± 5° and the rate has fallen below 10 % of its peak by 150 s ± 30 s.

    Not a stop: with quadratic drag alone (the seed's eq. 5 and ours; no mooring yaw
    stiffness, no linear damping) the rate decays like 1/t and the heading creeps like ln t
    without bound (39° at 300 s, 52° at 1 h: ``bench/hexicon_yaw_coast_down.py``), asserted
    below from the closed form. The drag area is our geometric estimate (``hexicon_h3.toml``)
    and this same figure was its check, so the check does not validate the drag
    independently."""
    p = load_hexicon()
    lever = sum(math.hypot(a, b) for a, b in zip(p.turbine_x_m, p.turbine_y_m, strict=True))
    c, inertia = p.drag_constant, p.yaw_inertia_kg_m2
    psi = r = rmax = 0.0
    dt, t, t_rest = 0.05, 0.0, None
    while t < 180.0:
        m = 1e6 * lever if t < 50.0 else 0.0
        r += dt * (m - c * r * abs(r)) / inertia
        psi += dt * r
        t += dt
        rmax = max(rmax, r)
        if t_rest is None and t > 50.0 and r < 0.1 * rmax:
            t_rest = t
    assert math.degrees(psi) == pytest.approx(35.0, abs=5.0)
    assert t_rest is not None and t_rest == pytest.approx(150.0, abs=30.0)
    # the creep after 180 s: ψ(t) = ψ(180) + (I/c) ln(1 + c r (t − 180)/I), r = r(180)
    creep = inertia / c * math.log(1.0 + c * r * (3600.0 - 180.0) / inertia)
    assert math.degrees(creep) == pytest.approx(16.2, abs=1.0)  # 36° at 180 s -> 52° at 1 h


def _state_at(p, v, th):  # type: ignore[no-untyped-def]
    from plant.hexicon.model import torque_law_nm

    w, _, _, _ = steady_operating_point(p.turbine, v, th)
    q = torque_law_nm(p.turbine, w)
    return (0.0, 0.0, w, th, q, w, th, q, w, th, q)


def _cover_t1(p, e_deg):  # type: ignore[no-untyped-def]
    """Fraction of turbine 1 covered by the wake of turbine 2 at misalignment e."""
    xs, ys = p.turbine_x_m, p.turbine_y_m
    e = math.radians(e_deg)
    dx, dy = -math.cos(e), -math.sin(e)
    rx, ry = xs[0] - xs[1], ys[0] - ys[1]
    down = rx * dx + ry * dy
    cross = rx * dy - ry * dx
    return circle_overlap_fraction(77.0, 77.0 + K * max(down, 0.0), cross) if down > 0 else 0.0


def test_seed_check_turbine1_wake_angles_and_speed() -> None:
    """Seed figures 11 and 13: turbine 1 is shadowed by turbine 2's wake from ~100°, its
    deficit is largest near 140° and near 10 m/s (where Ct peaks). Ours at rated pitch: the
    wake of turbine 2 starts to cover turbine 1 within 100° ± 10° (the seed shows it fully
    covered at 100°: its layout is more compact, see the report), covers it fully at 140°,
    and the (misalignment, wind speed) of the largest deficit over 0..180° and 5..20 m/s is
    within 140° ± 10° and 10 ± 1.5 m/s."""
    p = load_hexicon()
    onset = next(e for e in range(60, 181) if _cover_t1(p, e) > 0.0)
    assert onset == pytest.approx(100, abs=10)
    assert _cover_t1(p, 140.0) == pytest.approx(1.0, abs=1e-9)
    deficits = {}
    for v in np.arange(5.0, 20.1, 0.5):
        th = rated_pitch_rad(p.turbine, v)
        x = _state_at(p, v, th)
        for e_deg in range(0, 181, 2):
            u = (th, x[4], th, x[7], th, x[10], v, math.radians(e_deg))
            deficits[(float(v), e_deg)] = 1.0 - outputs(0.0, x, u, p).wind_factors[0]
    (v_best, e_best) = max(deficits, key=lambda k: deficits[k])
    assert e_best == pytest.approx(140.0, abs=10.0)
    assert v_best == pytest.approx(10.0, abs=1.5)


def _max_moment(p, v):  # type: ignore[no-untyped-def]
    th = rated_pitch_rad(p.turbine, v)
    x = _state_at(p, v, th)
    best = (0.0, 0)
    for e_deg in range(-180, 181, 2):
        u = (th, x[4], th, x[7], th, x[10], v, math.radians(e_deg))
        m = abs(outputs(0.0, x, u, p).yaw_moment_nm)
        best = max(best, (m, e_deg))
    return best


def test_seed_check_net_torque_at_rated_pitch() -> None:
    """Seed section 5.1.2: at rated pitch the net yaw torque is small at low wind and peaks
    near ±40° misalignment. Ours: with the turret at the layout's centroid the net torque is
    only the wakes' imbalance; its peak over all misalignments is at 36° ± 6° at every speed,
    and at 5 m/s it is below 30 % of its largest value over 5..20 m/s (which is at 10 m/s,
    where Ct peaks; the seed puts the peaks above 15 m/s: see the report)."""
    p = load_hexicon()
    peaks = {v: _max_moment(p, v) for v in (5.0, 7.0, 10.0, 15.0, 20.0)}
    for v, (_, e_deg) in peaks.items():
        assert abs(e_deg) == pytest.approx(36, abs=6), v
    top = max(m for m, _ in peaks.values())
    assert peaks[5.0][0] < 0.3 * top
    assert max(peaks, key=lambda v: peaks[v][0]) == 10.0


#: Seed table 7, row 10 m/s: best-power TSR at blade pitch 0, 5, 10, 15, 20, 25 deg (ASHES).
TABLE7_10MS = {0: 8.0, 5: 7.5, 10: 4.6, 15: 3.3, 20: 2.6, 25: 2.1}


def test_table7_tip_speed_ratios_at_off_optimal_pitch() -> None:
    """Seed table 7 (10 m/s row): the TSR of highest power at each pitch. Ours is the argmax
    of Cp over λ of the scaled table (0.5-spaced TSR grid): within ±0.55 of the seed's at
    every pitch (we get 7.5, 7.5, 4.5, 3.5, 2.5, 2.0)."""
    p = load_hexicon()
    table = p.turbine.table
    lam = np.linspace(float(table.tsr[0]), float(table.tsr[-1]), 2001)
    for deg, seed_tsr in TABLE7_10MS.items():
        cp = [table.coefficients(float(v), math.radians(deg))[0] for v in lam]
        best = float(lam[int(np.argmax(cp))])
        assert best == pytest.approx(seed_tsr, abs=0.55), deg


# ----------------------------------------------------------------------------- controllers
def _meas(e_deg: float, v: float, r: float = 0.0) -> HexiconMeasurement:
    return HexiconMeasurement(0.0, r, math.radians(e_deg), v, (1.0, 1.0, 1.0))


def test_bang_bang_is_the_seeds_rule() -> None:
    """Lagging (e > 0): turbines 1 and 3 at 25°, turbine 2 at θ_r(V); leading: the reverse."""
    d = load_design()
    lo = d.rated_pitch_rad(15.0)
    _, cmd = bang_bang_step(BangBangState(), _meas(5.0, 15.0), 1.0, d)
    assert cmd.pitch_rad == pytest.approx((math.radians(25.0), lo, math.radians(25.0)))
    _, cmd = bang_bang_step(BangBangState(), _meas(-5.0, 15.0), 1.0, d)
    assert cmd.pitch_rad == pytest.approx((lo, math.radians(25.0), lo))


def test_qp_hand_checkable_case() -> None:
    """Zero error, zero rate, no direction change: the unconstrained optimum of a cost with a
    positive linear term on w >= 0 is w = 0, so every pitch sits on the floor θ_r(V).
    And with a large positive error the first move turns the platform towards the wind
    (turbine 3, on the starboard side, sheds thrust: r' = -y_3 w_3 / I > 0) by exactly the
    rate limit g θ'_max T_s (the QP's rate constraint is active)."""
    d = load_design()
    st = make_mpc(d, MpcConfig(period_s=1.0, horizon=30))
    st, cmd, info = mpc_step(st, _meas(0.0, 15.0), 1.0)
    lo = d.rated_pitch_rad(15.0)
    assert info["status_solved"] == 1.0
    assert cmd.pitch_rad == pytest.approx((lo, lo, lo), abs=1e-4)
    st = make_mpc(d, MpcConfig(period_s=1.0, horizon=30, pitch_rate_max_deg_s=2.0))
    st, cmd, _ = mpc_step(st, _meas(15.0, 15.0), 1.0)
    assert cmd.pitch_rad[2] - lo == pytest.approx(math.radians(2.0), rel=1e-3)
    assert cmd.pitch_rad[1] == pytest.approx(lo, abs=1e-4)


# ----------------------------------------------------------------------------- over Zenoh
@pytest.mark.parametrize("controller", ["mpc", "bang_bang"])
def test_closed_loop_over_zenoh_tracks_15_deg_step(controller: str, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Plant and controller as two OS processes over Zenoh (lock-step), recorded to MCAP:
    150 s of scenario 1 (15 m/s, +15° direction step). Every cycle answered, nothing
    rejected; the recorded true heading equals the in-process run of the same cores and the
    same seeded sensor channels to 1e-9 rad (same arithmetic, the bus only carries it); the
    heading error ends within 1.5°; no commanded pitch leaves [θ_r(V_m), 25°] (V_m the met
    wind speed the controller measured); the MPC's pitch demand moves at most 2°/s."""

    from rich.console import Console

    from hil.families import HexiconOptions
    from hil.hexicon.model import load_scenarios, run_in_process
    from hil.hexicon.nodes import read_platform_run
    from hil.launch import RunRequest, launch

    req = RunRequest(
        scenario="hexicon-s1_step15",
        mode="lockstep",
        duration_s=150.0,
        out_dir=tmp_path,
        plots=False,
        hexicon=HexiconOptions(controller=controller),
    )
    s = launch(req, Console(quiet=True))
    assert s["run"]["exit_code"] == 0, s["run"]
    assert s["timing"]["cycles"] == 150 and s["timing"]["commands_rejected"] == 0
    assert s["run"]["final_seen"] == "True"
    run = read_platform_run(tmp_path / "run.mcap")
    frames = run["fowt/h3/platform/truth"]
    measured = run["fowt/h3/platform"]
    assert len(frames) == 151 and len(measured) == 151
    scn = load_scenarios()["s1_step15"]
    ref = run_in_process(scn, controller)
    for fr, psi in zip(frames[:150], ref.heading[:150], strict=True):
        assert fr["platform_heading_measured_rad"] == pytest.approx(psi, abs=1e-9)
    last = frames[-1]
    err = math.degrees(last["wind_direction_measured_rad"] - last["platform_heading_measured_rad"])
    assert abs(err) < 1.5
    d = load_design()
    los = [math.degrees(d.rated_pitch_rad(f["wind_speed_measured_m_s"])) for f in measured]
    hi = 25.0
    for t in ("t1", "t2", "t3"):
        cmds = [
            math.degrees(c["blade_pitch_commanded_rad"]) for c in run[f"fowt/h3/{t}/rotor/command"]
        ]
        assert len(cmds) == 150
        assert all(lo - 1e-6 <= c <= hi + 1e-6 for lo, c in zip(los, cmds, strict=False))
        if controller == "mpc":
            # 2°/s, unless the floor θ_r(V_m) rises faster (the demand then follows it)
            for k, (a, b) in enumerate(itertools.pairwise(cmds)):
                assert abs(b - a) <= 2.0 + max(0.0, los[k + 1] - los[k]) + 1e-6


# ----------------------------------------------------------------------------- bus messages
def test_platform_messages_round_trip_with_turbine_keys() -> None:
    """Each platform message encodes and decodes to itself; per-turbine keys carry the
    platform and the turbine; out-of-range values are rejected with a RangeError."""
    from bus_schemas.codec import RangeError
    from bus_schemas.messages import TurbineCommand
    from bus_schemas.registry import PLATFORM_MESSAGES, TURBINE_COMMAND, decode_any

    for mt in PLATFORM_MESSAGES:
        msg = mt.cls(**{f.name: (1 if not f.is_float else 0.25) for f in mt.codec.fields})
        got_mt, got = decode_any(mt.codec.encode(msg))
        assert got_mt is mt and got == msg
    assert TURBINE_COMMAND.key("h3/t2") == "fowt/h3/t2/rotor/command"
    bad = TurbineCommand(
        seq=0,
        answered_seq=0,
        sample_time_ns=0,
        publish_time_ns=0,
        turbine_index=1,
        blade_pitch_commanded_rad=3.0,
        generator_torque_commanded_nm=0.0,
    )
    with pytest.raises(RangeError):
        TURBINE_COMMAND.codec.decode(TURBINE_COMMAND.codec.encode(bad))


# ----------------------------------------------------------------------------- identification
def test_n4sid_recovers_a_known_linear_system_from_its_prbs_data() -> None:
    """A known 2-state, 2-input, 1-output discrete system (poles 0.95 and 0.8) driven by
    seeded PRBS inputs from rest, no noise: the identified order is 2, its poles match within
    1e-3 and
    the free-run fit on fresh PRBS data is above 99 %."""
    pd = pytest.importorskip("pandas")
    from controller.design.hexicon_identify import fit_percent, n4sid, prbs, simulate

    a = np.array([[0.95, 0.1], [0.0, 0.8]])
    b = np.array([[0.0, 0.5], [1.0, -0.3]])
    c = np.array([[1.0, 0.5]])

    def data(seed: int) -> tuple[np.ndarray, np.ndarray]:
        rng = np.random.default_rng(seed)
        u = np.column_stack([prbs(3000, 5, 40, rng), prbs(3000, 5, 40, rng)])
        x = np.zeros(2)
        y = np.empty((3000, 1))
        for k in range(3000):
            y[k] = c @ x
            x = a @ x + b @ u[k]
        return u, y

    u, y = data(1)
    frame = pd.DataFrame({"u1": u[:, 0], "u2": u[:, 1], "y": y[:, 0]})
    m = n4sid(frame, ["u1", "u2"], ["y"], block_rows=8, remove_means=False)
    assert m.order == 2
    assert sorted(np.linalg.eigvals(m.a).real) == pytest.approx([0.8, 0.95], abs=1e-3)
    u2, y2 = data(2)
    assert fit_percent(y2, simulate(m, u2))[0] > 99.0
