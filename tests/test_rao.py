"""Linear response: surge and pitch RAO from simulation vs the frequency-domain RAO.

The time-domain model (``step_floating``: A_∞, the fitted radiation state space, hydrostatics,
gravity, the mooring table, the tower mode) driven by regular-wave excitation
F(t) = Re(a X(ω) e^{iωt}) from the shipped WAMIT data (heading 0) is compared with the
frequency-domain RAO built directly from the same WAMIT data, without the radiation fit:

    q̂/a = [−ω² (M_s + A(ω)) + iω (B(ω) + D) + K + K_moor]⁻¹ X(ω)

on the four DOFs of the model (surge, heave, pitch, tower-top), with M_s, K (hydrostatics +
gravity + tower), D (tower structural damping) and K_moor (the mooring table's slope at the
equilibrium) from the same :class:`FloatingParams`, A(ω), B(ω), X(ω) interpolated linearly in ω
from the WAMIT data. Aero and quadratic drag are off, the wave amplitude is 0.1 m, so the model
is linear (the surge motion stays inside one or two 1 m mooring-table segments).

Transients: the surge mode (123 s, almost undamped without drag) would ring for hours from
rest, so the run starts on the steady state of the time-domain model's own linearisation
(x̂ = (iωI − A)⁻¹ B_w aX, radiation states included) and is simulated for several wave periods;
amplitude and phase come from a least-squares sine fit over the last four periods.

Frequencies 0.4, 0.6 and 0.9 rad/s (periods 15.7, 10.5 and 7.0 s, the wave band of the load
cases; away from the heave/pitch resonances at 0.31/0.23 rad/s, where the RAO depends mostly
on damping, and from the cancellation frequencies of the surge and pitch excitation).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from plant.hydro.wamit import HydroData, load_hydro_preset
from plant.modes import OperatingPoint, linearize, operating_point
from plant.platform import FloatingParams, f, load_floating, mooring_force, step_floating

AMPLITUDE_M = 0.1
STEP_S = 0.0125
FREQUENCIES_RAD_S = (0.4, 0.6, 0.9)
HYDRO_DOFS = (0, 2, 4)  # surge, heave, pitch in the WAMIT numbering


@pytest.fixture(scope="module")
def params() -> FloatingParams:
    p = load_floating("iea15mw_volturnus")
    return replace(p, quadratic_damping=np.zeros((3, 3)), aero=False)


@pytest.fixture(scope="module")
def hydro() -> HydroData:
    return load_hydro_preset("iea15mw_volturnus").select(HYDRO_DOFS, heading_deg=0.0)


@pytest.fixture(scope="module")
def still(params: FloatingParams) -> OperatingPoint:
    """Static equilibrium without rotor loads: rotor at rest, no wind, no waves."""
    q = operating_point(params, 5.0).state[:4]  # aero off: the platform sees no thrust
    x = (*q, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, *([0.0] * params.n_radiation))
    return OperatingPoint(0.0, x, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0)


def _interp(omega: float, grid: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of ``values[k, ...]`` at ``omega`` (real or complex)."""
    k = int(np.clip(np.searchsorted(grid, omega) - 1, 0, grid.size - 2))
    w = (omega - grid[k]) / (grid[k + 1] - grid[k])
    return np.asarray((1.0 - w) * values[k] + w * values[k + 1])


def _mooring_stiffness(p: FloatingParams, q: tuple[float, ...]) -> np.ndarray:
    """K_moor = −∂F_m/∂q (3x3, surge/heave/pitch) at ``q`` by central differences (m, rad)."""
    k = np.zeros((3, 3))
    for j, step in enumerate((1e-3, 1e-3, 1e-5)):
        qp = [q[0], q[1], q[2]]
        qm = list(qp)
        qp[j] += step
        qm[j] -= step
        fp = np.array(mooring_force(p.mooring, *qp))
        fm = np.array(mooring_force(p.mooring, *qm))
        k[:, j] = -(fp - fm) / (2.0 * step)
    return k


def frequency_domain_rao(
    p: FloatingParams, hydro: HydroData, q_eq: tuple[float, ...], omega: float
) -> np.ndarray:
    """Complex RAO q̂/a of (surge m/m, heave m/m, pitch rad/m, tower-top m/m) from WAMIT data."""
    rad = hydro.radiation
    a_w = _interp(omega, rad.omega_rad_s, rad.added_mass)
    b_w = _interp(omega, rad.omega_rad_s, rad.damping)
    x_w = _interp(omega, hydro.excitation.omega_rad_s, hydro.excitation.force[:, 0, :])
    mass = p.mass_matrix.copy()  # M_s + A_∞
    mass[:3, :3] += a_w - rad.added_mass_inf
    damping = p.linear_damping.copy()
    damping[:3, :3] += b_w
    stiffness = p.stiffness.copy()
    stiffness[:3, :3] += _mooring_stiffness(p, q_eq)
    z = -(omega**2) * mass + 1j * omega * damping + stiffness
    force = np.zeros(4, dtype=complex)
    force[:3] = x_w
    return np.asarray(np.linalg.solve(z, force))


def _steady_state_of_model(
    p: FloatingParams, still: OperatingPoint, omega: float, force: np.ndarray
) -> np.ndarray:
    """Complex steady-state amplitudes of the whole state for F = Re(force e^{iωt})."""
    a = linearize(p, still)
    b = np.zeros((a.shape[0], 3))
    for j in range(3):
        up = list(still.inputs)
        up[3 + j] = 1e6
        fp = np.array(f(0.0, still.state, tuple(up), p))
        b[:, j] = (fp - np.array(f(0.0, still.state, still.inputs, p))) / 1e6
    return np.asarray(np.linalg.solve(1j * omega * np.eye(a.shape[0]) - a, b @ force))


def simulated_rao(
    p: FloatingParams, hydro: HydroData, still: OperatingPoint, omega: float, periods: int = 10
) -> np.ndarray:
    """RAO of (surge, heave, pitch, tower) fitted to a ``step_floating`` run in regular waves."""
    x_w = _interp(omega, hydro.excitation.omega_rad_s, hydro.excitation.force[:, 0, :])
    force = AMPLITUDE_M * x_w
    x_hat = _steady_state_of_model(p, still, omega, force)
    x = tuple(float(v) for v in np.array(still.state) + x_hat.real)
    period = 2.0 * math.pi / omega
    n = round(periods * period / STEP_S)
    n_fit = round(4 * period / STEP_S)
    t = np.arange(n + 1) * STEP_S
    q = np.empty((n + 1, 4))
    q[0] = x[:4]
    for k in range(n):
        tm = (k + 0.5) * STEP_S  # input held over the step at its midpoint
        wave = (force * np.exp(1j * omega * tm)).real
        u = (0.0, 0.0, 0.0, float(wave[0]), float(wave[1]), float(wave[2]))
        x = step_floating(t[k], x, u, STEP_S, p)
        q[k + 1] = x[:4]
    tt = t[-n_fit:]
    basis = np.column_stack([np.cos(omega * tt), np.sin(omega * tt), np.ones_like(tt)])
    coef, *_ = np.linalg.lstsq(basis, q[-n_fit:], rcond=None)
    # y = c cos + s sin = Re((c − i s) e^{iωt})
    return np.asarray((coef[0] - 1j * coef[1]) / AMPLITUDE_M)


@pytest.mark.parametrize("omega", FREQUENCIES_RAD_S)
def test_surge_and_pitch_rao_match_frequency_domain(
    params: FloatingParams, hydro: HydroData, still: OperatingPoint, omega: float
) -> None:
    fd = frequency_domain_rao(params, hydro, still.state[:4], omega)
    sim = simulated_rao(params, hydro, still, omega)
    for dof, name in ((0, "surge"), (2, "pitch")):
        rel_amp = abs(abs(sim[dof]) / abs(fd[dof]) - 1.0)
        rel_complex = abs(sim[dof] - fd[dof]) / abs(fd[dof])
        print(
            f"ω={omega} {name}: |RAO| sim {abs(sim[dof]):.5g} fd {abs(fd[dof]):.5g} "
            f"amp err {rel_amp:.4f}, phase sim {np.angle(sim[dof], deg=True):.2f} "
            f"fd {np.angle(fd[dof], deg=True):.2f} deg, complex err {rel_complex:.4f}"
        )
        assert rel_amp < 0.05, (name, omega, sim[dof], fd[dof])
        assert rel_complex < 0.05, (name, omega, sim[dof], fd[dof])
