"""A long run's waves and wind are produced as the loop needs them, with today's bits.

Waves: the plant steps its phasors (no record of the run's length exists); the evaluators
that build series work in blocks, and a series built in blocks equals the whole-duration
series bit for bit, block boundaries included. Wind: a plant's turbulent record is a
periodic box of at most :data:`plant.wind.TURBULENCE_BOX_S`; a run up to that long gets
bit for bit the record synthesised for its whole duration, a longer run the box, repeated
(the same speed at t and at t + the box, seeded). The plant's memory for the wind does not
grow with the run.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.nodes.plant_node import PlantLoop
from hil.scenario.schema import load_scenario
from plant.build import TurbulenceRequest, load_turbine, make_waves, make_wind
from plant.turbulence import ntm_sigma, synthesize_turbulence
from plant.waves import JonswapSpectrum, excitation_force, synthesize
from plant.wind import TURBULENCE_BOX_S, TurbulentWind

DT = 0.0125  # the IEA 15 MW scenarios' plant step [s]
REQUEST = TurbulenceRequest(mean_m_s=7.1, turbulence_class="B", seed=2)


def _whole_duration(duration_s: float, hub: float, radius: float) -> np.ndarray:
    """The record as synthesised for the whole duration (clipped at 0 as the spec does)."""
    out = synthesize_turbulence(7.1, ntm_sigma(7.1, "B"), hub, radius, duration_s, DT, 2)
    return np.maximum(out, 0.0)


@pytest.mark.parametrize("duration_s", [601.0, 1801.0, TURBULENCE_BOX_S - 1.0])
def test_wind_up_to_the_box_is_the_whole_duration_record(duration_s: float) -> None:
    turbine = load_turbine("iea15mw")
    wind = make_wind(REQUEST, turbine, duration_s=duration_s, dt_s=DT)
    assert isinstance(wind, TurbulentWind)
    whole = _whole_duration(duration_s, turbine.hub_height_m, turbine.rotor_radius_m)
    assert np.array_equal(wind.samples_m_s, whole)  # bit for bit
    assert wind.period_s >= duration_s


def test_wind_beyond_the_box_repeats_the_box() -> None:
    """A day's run: the one-hour box, the same bits; t and t + k box give the same speed at
    every block boundary (and between: the lookup interpolates on the same samples)."""
    turbine = load_turbine("iea15mw")
    day = make_wind(REQUEST, turbine, duration_s=86_401.0, dt_s=DT)
    box = make_wind(REQUEST, turbine, duration_s=TURBULENCE_BOX_S, dt_s=DT)
    assert isinstance(day, TurbulentWind) and isinstance(box, TurbulentWind)
    assert day.samples_m_s.size == box.samples_m_s.size  # memory of an hour, not a day
    assert np.array_equal(day.samples_m_s, box.samples_m_s)
    period = day.period_s
    assert period == pytest.approx(TURBULENCE_BOX_S, abs=DT)
    rng = np.random.default_rng(7)
    n = day.samples_m_s.size
    for j in [0, 1, n // 2, n - 1, *rng.integers(0, n, 20).tolist()]:
        for k in (1, 5, 23):
            # a sample time of block k: the same sample (the lookup's time t/Δt carries
            # the rounding of a large t, as any long record's lookup does: 1e-9 m/s)
            assert day.speed_at((j + k * n) * DT) == pytest.approx(
                float(day.samples_m_s[j]), abs=1e-9
            )
    # the wrap is continuous: half a step before the box's end lies between its last and
    # first samples
    mid = day.speed_at(period - 0.5 * DT)
    lo, hi = sorted((float(day.samples_m_s[-1]), float(day.samples_m_s[0])))
    assert lo - 1e-12 <= mid <= hi + 1e-12


def test_wave_series_in_blocks_equals_the_whole_duration_series() -> None:
    """Elevation at the platform and the gauge, and the excitation: one call over the whole
    record and calls block by block (boundaries at the evaluator's 2048-sample blocks, as a
    loop consuming them would) give the same bits."""
    field = make_waves(None, math.inf)
    assert field.n_components == 0
    field = synthesize(JonswapSpectrum(1.7, 8.0, 3.3), depth_m=200.0, seed=102)
    dt, blocks, per = 0.00625, 5, 2048
    n = blocks * per
    for x in (0.0, -450.0):  # platform, gauge 450 m up-wave
        whole = field.series(0.0, dt, n, x_m=x)
        parts = np.concatenate([field.series(b * per * dt, dt, per, x_m=x) for b in range(blocks)])
        # The block start time b·per·dt vs the whole call's t0 + start·dt: the same float
        assert np.array_equal(whole, parts)
    omega_tf = np.linspace(0.05, 3.5, 50)
    transfer = np.stack([np.exp(1j * omega_tf), 2.0 * np.exp(-1j * omega_tf)], axis=1)
    force = excitation_force(field, omega_tf, transfer)
    whole_f = force.series(0.0, dt, n)
    parts_f = np.concatenate([force.series(b * per * dt, dt, per) for b in range(blocks)])
    assert np.array_equal(whole_f, parts_f)


def test_plant_waves_stepped_across_blocks_match_the_field() -> None:
    """The plant's wave stepper (the run's only wave evaluation: nothing of the run's
    length) across three resynchronisation blocks agrees with the direct sum of the same
    field at the platform and the gauge (rounding only: 1e-9 m)."""

    sc = load_scenario("iea15mw-lc2-lqri-ff").with_duration(200.0)
    loop = PlantLoop(sc, lambda _mt, _msg: None)
    sim = loop.sim
    fp = sim.floating
    assert fp is not None
    x = sim.initial_state()
    applied = sim.initial_applied(x)
    period = sc.timing.control_period_s
    gx, _ = fp.waves.up_wave_point(fp.gauge_distance_m)
    for k in range(0, 3 * 1024 // (2 * sim.n) + 3):
        x = sim.advance(k * period, x, applied, applied)
        t = (k + 1) * period
        _, _, _, eta_p, eta_g = sim.wave_values()
        assert eta_p == pytest.approx(float(fp.waves.eta(t, 0.0)), abs=1e-9)
        assert eta_g == pytest.approx(float(fp.waves.eta(t, gx)), abs=1e-9)


def test_progress_line_says_how_far_a_long_run_is() -> None:
    """The in-process loop's progress: simulated time, share and speed, in hours for a
    long run; nothing is said before its interval has passed."""
    from types import SimpleNamespace

    from hil.inprocess.run import Progress

    lines: list[str] = []
    plant = SimpleNamespace(k=0, period_ns=25_000_000)
    day = 86_400 * 40  # cycles of a day at 40 Hz
    slow = Progress(plant, day, lines.append, every_s=3600.0)  # type: ignore[arg-type]
    slow()
    assert lines == []
    report = Progress(plant, day, lines.append, every_s=0.0)  # type: ignore[arg-type]
    plant.k = day // 8  # 3 h
    report()
    assert len(lines) == 1
    assert lines[0].startswith("in-process: 3.0 h of 24 h simulated (12 %), ")
    assert lines[0].endswith("x real time")
