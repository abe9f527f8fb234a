"""The compiled kernels (plant._kernels, sensors._kernels) against the Python models they run.

Where a kernel computes what a Python function of the package also computes (the Cp/Ct/Cq
look-up, the turbulent wind, the wave phasor stepper, the turbine's RK4 and outputs, the
floating plant's truth outputs, the sensor channels), the two are compared here: bit for bit
where the operations are the same in the same order, to 1e-12 relative where only the order
of a sum differs (a matrix product), and within a stated bound where a stepper accumulates
its rounding (the wave phasors).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.nodes.plant_node import plant_config
from hil.scenario.schema import load_scenario
from plant import _kernels as pk
from plant import turbine as turbine_mod
from plant.integrate import rk4_step
from plant.platform import f as floating_f
from plant.platform import relative_wind
from plant.simulator import PlantSimulator
from plant.turbine import f as turbine_f
from plant.turbine import load_turbine, outputs
from plant.waves import PhasorStepper
from plant.wind import TurbulentWind
from sensors import ChannelSuite
from sensors.channel import ChannelSpec, channel_init, channel_step, default_floating_suite


def test_wind_threshold_is_the_turbines() -> None:
    assert pk.WIND_MIN_M_S == turbine_mod.WIND_MIN_M_S


def test_table_lookup_equals_performance_table_bit_for_bit() -> None:
    table = load_turbine("nrel5mw").table
    rng = np.random.default_rng(3)
    lo_t, hi_t = float(table.tsr[0]), float(table.tsr[-1])
    lo_p, hi_p = float(table.pitch_rad[0]), float(table.pitch_rad[-1])
    tsrs = np.concatenate([rng.uniform(lo_t - 2, hi_t + 2, 2000), table.tsr])
    pitches = np.concatenate([rng.uniform(lo_p - 0.2, hi_p + 0.2, 2000), table.pitch_rad[:1]])
    for tsr, pitch in zip(tsrs.tolist(), np.resize(pitches, tsrs.size).tolist(), strict=True):
        got = pk.coefficients_clamped(
            tsr, pitch, table._tsr_array, table._pitch_array, table._cell_array
        )
        assert got == table.coefficients(tsr, pitch)


def test_turbulent_wind_lookup_equals_speed_at_bit_for_bit() -> None:
    wind = TurbulentWind(
        mean_m_s=11.0,
        turbulence_class="B",
        hub_height_m=90.0,
        rotor_radius_m=63.0,
        duration_s=60.0,
        dt_s=0.05,
        seed=4,
    )
    table = np.array(wind.samples_m_s)
    for t in np.linspace(0.0, 3.5 * wind.period_s, 5001).tolist():
        assert pk.turbulent_speed(table, wind.dt_s, t) == wind.speed_at(t)


def _floating_sim() -> PlantSimulator:
    return PlantSimulator(plant_config(load_scenario("iea15mw-lc2-lqri-ff")))


def test_wave_kernel_follows_phasor_stepper_through_resyncs() -> None:
    """3000 half-steps (two exact recomputations at 1024 and 2048) of the plant's wave stepper
    against plant.waves.PhasorStepper over the same field: the same products, summed in
    another order, so equal to ~1e-12 of the signal's size."""
    sim = _floating_sim()
    fp = sim.floating
    assert fp is not None
    w = fp.waves
    gx, gy = w.up_wave_point(fp.gauge_distance_m)
    proj = gx * math.cos(w.heading_rad) + gy * math.sin(w.heading_rad)
    coeff = np.vstack(
        [
            np.asarray(fp.excitation_transfer, dtype=np.complex128).T,
            np.ones((1, w.n_components)),
            np.exp(-1j * w.wavenumber_rad_m * proj)[None, :],
        ]
    )
    ref = PhasorStepper(
        w.omega_rad_s, w.amplitude_m * np.exp(1j * w.phase_rad), coeff, 0.0, 0.5 * sim.h
    )
    got = np.zeros(5)
    scale = np.zeros(5)
    worst = np.zeros(5)
    for _ in range(3000):
        ref.advance()
        pk.phasor_step(sim._wc, sim._s, got, 5)
        want = ref.values()
        scale = np.maximum(scale, np.abs(want))
        worst = np.maximum(worst, np.abs(got - want))
    assert np.all(worst <= 1e-12 * scale)


def test_bottom_fixed_advance_and_truth_equal_rk4_of_turbine_f() -> None:
    """The compiled period equals plant.integrate.rk4_step of plant.turbine.f (same
    operations, same order: bit for bit) and the truth plant.turbine.outputs."""
    sim = PlantSimulator(plant_config(load_scenario("nrel5mw-ramp")))
    p = sim.params
    x = sim.initial_state()
    x_ref = x
    demand = (0.02, 0.9 * p.torque_max_nm)
    held = sim.initial_applied(x)
    for k in range(500):
        t = k * sim.h * sim.n
        switch = k % (sim.n + 1)
        x = sim.advance(t, x, held, demand, switch)
        for i in range(sim.n):
            d = held if i < switch else demand
            ti = t + i * sim.h
            x_ref = rk4_step(turbine_f, ti, x_ref, (*d, sim._wind(ti + 0.5 * sim.h)), sim.h, p)
        assert x == x_ref
        truth = sim.truth(k, round(t * 1e9), x, demand, 0)
        u = sim._wind(round(t * 1e9) * 1e-9)
        out = outputs(0.0, x, (demand[0], demand[1], u), p)
        assert truth.wind_speed_m_s == u
        assert truth.aero_torque_nm == out.aero_torque_nm
        assert truth.rotor_thrust_n == out.rotor_thrust_n
        assert truth.electrical_power_w == out.electrical_power_w
        assert truth.power_coefficient == out.cp
        assert truth.tip_speed_ratio == out.tip_speed_ratio


def test_floating_truth_equals_the_python_formulas() -> None:
    """PlantSimulator.truth (one kernel) against plant.platform.f, relative_wind,
    plant.turbine.outputs and TowerBaseLoads.moment_nm, along a 400-cycle run."""
    sim = _floating_sim()
    fp = sim.floating
    assert fp is not None
    p = fp.params
    x = sim.initial_state()
    applied = sim.initial_applied(x)
    per_ns = round(sim.h * sim.n * 1e9)
    for k in range(400):
        t_ns = k * per_ns
        truth = sim.truth(k, t_ns, x, applied, 7)
        u = sim._wind(t_ns * 1e-9)
        w = sim.wave_values()
        dx = floating_f(0.0, x, (applied[0], applied[1], u, w[0], w[1], w[2]), p)
        u_rel = relative_wind(x, u, p)
        out = outputs(0.0, (x[8], x[9], x[10]), (applied[0], applied[1], u_rel), p.turbine)
        tbm = fp.loads.moment_nm(out.rotor_thrust_n, x[2], x[3], dx[4], dx[6], dx[7])
        acc = dx[4] + fp.loads.nacelle_height_m * dx[6] + dx[7]
        assert truth.wind_speed_m_s == u
        assert truth.relative_wind_speed_m_s == u_rel
        assert truth.rotor_thrust_n == out.rotor_thrust_n
        assert truth.aero_torque_nm == out.aero_torque_nm
        assert truth.electrical_power_w == out.electrical_power_w
        assert truth.wave_elevation_gauge_m == w[4]
        # The accelerations come from the same kernel (f); the radiation sum's order differs.
        assert truth.tower_base_moment_nm == pytest.approx(tbm, rel=1e-12, abs=1e-3)
        assert truth.nacelle_acc_fore_aft_m_s2 == pytest.approx(acc, rel=1e-12, abs=1e-12)
        # Every other field by name (truth builds the Struct positionally).
        assert (truth.seq, truth.sample_time_ns, truth.publish_time_ns) == (k, t_ns, 7)
        assert truth.floating == 1
        assert (truth.rotor_speed_rad_s, truth.blade_pitch_rad) == (x[8], x[9])
        assert truth.generator_torque_nm == x[10]
        assert truth.generator_speed_rad_s == out.generator_speed_rad_s
        assert truth.tip_speed_ratio == out.tip_speed_ratio
        assert (truth.power_coefficient, truth.thrust_coefficient) == (out.cp, out.ct)
        assert (truth.blade_pitch_applied_rad, truth.generator_torque_applied_nm) == applied
        assert (truth.platform_surge_m, truth.platform_heave_m) == (x[0], x[1])
        assert (truth.platform_pitch_rad, truth.tower_top_displacement_m) == (x[2], x[3])
        assert truth.platform_surge_velocity_m_s == x[4]
        assert truth.platform_heave_velocity_m_s == x[5]
        assert truth.platform_pitch_rate_rad_s == x[6]
        assert truth.tower_top_velocity_m_s == x[7]
        assert (truth.wave_force_surge_n, truth.wave_moment_pitch_nm) == (w[0], w[2])
        assert truth.wave_elevation_platform_m == w[3]
        assert truth.shaft_torque_nm == p.turbine.gearbox_ratio * x[10]
        x = sim.advance(t_ns * 1e-9, x, applied, (applied[0] + 0.01, applied[1]), 1)


def test_suite_kernel_equals_channel_step_bit_for_bit() -> None:
    """The whole default floating suite (delays, sample-and-hold, dropout, saturation,
    quantization) and a long-delay channel whose history outgrows the first ring buffer,
    stepped by the compiled suite and by channel_step, 3 x BLOCK_SIZE calls (refills)."""
    specs = dict(default_floating_suite(0.025))
    specs["long_m"] = ChannelSpec(name="long_m", std=0.1, delay_s=1.0, dropout_probability=0.2)
    suite = ChannelSuite(specs, seed=11)
    states = {k: channel_init(s, 11) for k, s in specs.items()}
    rng = np.random.default_rng(5)
    for k in range(3 * 4096 + 7):
        t_ns = k * 10_000_000 + int(rng.integers(0, 3_000_000))
        truths = {
            key: float(v) for key, v in zip(specs, rng.normal(1.0, 5.0, len(specs)), strict=True)
        }
        got = suite.step(t_ns, truths)
        for key, spec in specs.items():
            _, y, ok = channel_step(spec, states[key], t_ns, truths[key])
            assert got[key][1] == ok
            assert got[key][0] == y or (math.isnan(y) and math.isnan(got[key][0]))
    for key, st in states.items():
        assert suite.counts(key) == (st.samples, st.dropped)


def test_suite_rejects_time_that_does_not_increase_and_changes_nothing() -> None:
    suite = ChannelSuite({"a": ChannelSpec(std=1.0), "b": ChannelSpec(delay_s=0.1)}, seed=1)
    suite.step(5, {"a": 1.0, "b": 2.0})
    before = suite.counts("a")
    with pytest.raises(ValueError, match=r"'a'.*increase"):
        suite.step(5, {"a": 1.0, "b": 2.0})
    assert suite.counts("a") == before
    with pytest.raises(ValueError, match="expected 2 true values"):
        suite.step_values(6, (1.0,))


def test_nan_operating_point_gives_nan_not_a_stray_read() -> None:
    table = load_turbine("iea15mw").table
    args = (table._tsr_array, table._pitch_array, table._cell_array)
    assert all(math.isnan(v) for v in pk.coefficients_clamped(math.nan, 0.1, *args))
    assert all(math.isnan(v) for v in pk.coefficients_clamped(7.0, math.nan, *args))


@pytest.mark.parametrize("name", ["nrel5mw-ramp", "iea15mw-lc2", "faults-sensors"])
def test_warm_up_leaves_the_seeded_run_unchanged(name: str) -> None:
    """The real-time node's warm-up runs a cycle on a copy: the frames, truth and states of
    the run after it are the same, bit for bit, as without it (sensor noise streams, fault
    schedules and cached records untouched). 480 cycles with a demand that changes each
    cycle; ``faults-sensors`` (40 Hz, 12 s) passes its first fault window's start at 10 s."""
    scenario = load_scenario(name)
    warmed = PlantSimulator(plant_config(scenario))
    cold = PlantSimulator(plant_config(scenario))
    x_w = warmed.initial_state()
    x_c = cold.initial_state()
    applied = warmed.initial_applied(x_w)
    warmed.warm_up(x_w, applied)
    period_ns = round(scenario.timing.control_period_s * 1e9)
    for k in range(480):
        t_ns = k * period_ns
        tw = warmed.truth(k, t_ns, x_w, applied, 0)
        tc = cold.truth(k, t_ns, x_c, applied, 0)
        assert tw == tc
        assert warmed.sensor_frame(k, tw, 0) == cold.sensor_frame(k, tc, 0)
        new = (applied[0] + 1e-4 * math.sin(k), applied[1] * (1.0 + 1e-3 * math.cos(k)))
        x_w = warmed.advance(t_ns * 1e-9, x_w, applied, new, 0)
        x_c = cold.advance(t_ns * 1e-9, x_c, applied, new, 0)
        assert tuple(x_w) == tuple(x_c)
        applied = new
