"""Steady operating point, numerical linearisation and natural modes of the floating turbine.

1. Rotor: below rated, ω = min(λ* U_n / R, ω_rated) at fine pitch; above rated, the pitch at
   which the aerodynamic power at rated speed equals rated power / η; generator torque balancing
   the aerodynamic torque (held as the torque demand). U_n is the rotor-normal wind the rotor
   sees on the pitched platform (:func:`plant.platform.relative_wind`).
2. Platform: the static equilibrium F(q) = 0 of :func:`plant.platform.f` at rest (mean thrust
   along the tilted shaft, tower drag, nonlinear mooring, weight and buoyancy), solved by Newton
   iterations (:func:`_newton_equilibrium`, four unknowns and a forward-difference Jacobian;
   scipy's ``fsolve`` and a surge bracket where they do not converge); steps 1-2 repeat until
   U_n is converged (the trim). Newton is written here because importing ``scipy.optimize``
   costs about 0.3 s, a tenth of a 600 s in-process run's whole command, for a solve of four
   unknowns that takes milliseconds.
3. A = ∂f/∂x by central differences about that point (inputs held), including the radiation
   states and the aerodynamic stiffness and damping (thrust and torque depend on the
   rotor-normal relative wind U_n = [(U − J_h·q̇) cos ψ + J_v·q̇ sin ψ]/cos τ, ψ = τ + φ + κ s,
   so on the platform's pitch and its rates; tower drag on the structure's velocity), and the
   mooring's stiffness at the mean offset.
4. Eigenvalues λ = −ζω_n ± jω_d of A; a mode's DOF is the dominant entry of its displacement
   eigenvector with pitch scaled by a length (:data:`PITCH_LENGTH_M`) so that metres compare;
   among the modes of one DOF, the one with the largest drive-point resonance peak
   |residue| / |Re λ| is that DOF's natural mode (radiation-state poles, nearly cancelled by
   zeros, have tiny residues). Period T = 2π/ω_d (damped), ζ = −Re λ / |λ|.

The case is open loop (:data:`OPEN_LOOP_CASE`): no controller, blade pitch and generator torque
held at the operating point, rotor speed free. The same identification (:func:`identify_modes`)
applies to any first-order state matrix with known position/velocity indices, e.g. an OpenFAST
linearisation.

Against the OpenFAST linearisations of the IEA 15 MW VolturnUS-S
--------------------------------------------------------------------
``../shared/reference/openfast/IEA-15-240-RWT-UMaineSemi/linearizations`` (5-24 m/s; tests in
``tests/test_modes.py``). Compared term by term (A-matrix entries; force-space and with the tower
condensed statically, s̈ = ṡ = 0, which leaves the platform periods within 1 %):

* what was missing here and is now modelled: the 6° shaft tilt. The rotor sees the wind normal
  to its tilted disc, so the rotor speed depends on platform pitch: ∂ω̇/∂φ = −3.27e-2 1/s² in
  lin_10 (15 m/s), 0 before, −3.48e-2 now; the thrust acts along the shaft (moment arm
  h cos τ + a sin τ = 147.9 m, not 150 m); the heave/pitch mooring stiffness grows with the
  offset (k_φφ 2.59e8 → 3.05e8 N m/rad at 14 m; it was held at its zero-offset value); the
  tower's aerodynamic drag (AeroDyn ``TwrAero``, C_d 0.5, D 10-6.5 m, shear 0.12: 73 kN at
  15 m/s, 187 kN at 24 m/s) sets the trim at high wind. Trim at 15 m/s: surge 14.57 m (lin_10
  14.59), pitch 0.0377 rad (0.039), blade pitch 0.1995 rad (0.1982);
* with the rotor speed locked and the tower condensed, the pitch period is 1.8-2.6 % longer
  here than in the linearisations at every wind speed from 5 to 24 m/s, and the condensed pitch
  stiffness/inertia ∂φ̈/∂φ is 0.941-0.949 of theirs at every wind speed: a wind-independent
  offset, the model (the linearisations reproduce the 2020 v1.0 turbine with a 1,263 t tower,
  about 160 t lighter than the deck imported here), not the aerodynamics;
* each ``.lin`` file is one linearisation at one rotor azimuth (0.014 rad), and its A holds the
  generator azimuth ψ as a state with a non-zero column: ∂F/∂ψ, the slope at that azimuth of
  the 3P-periodic rotor loads (shear, tilt, the tower's potential-flow influence), 0.27 m/s² per
  rad in the tower row and 0.017 1/s² in the rotor-speed row at 15 m/s. Averaged over a
  revolution the derivative of a periodic load is zero, so the azimuth-averaged model, the one a
  rotor disc like this one stands for, has no ψ column (the usual practice with OpenFAST
  linearisations drops the state after averaging over azimuths). Kept, the slope at ψ = 0 acts
  through the rotor-speed loop and shortens the pitch period by 3.4 % (15 m/s: 28.43 s as
  written, 29.44 s averaged) and 4.3 % (19 m/s: 29.09 / 30.41 s), 0.1 % at 5 m/s. That was the
  pitch gap at 15 and 19 m/s (+5.8 %, +7.5 % against the files as written; +2.2 %, +2.8 %
  azimuth-averaged, the ~2 % locked-rotor offset above);
* the rotor's aerodynamic derivatives agree (``bench/modes_vs_openfast.py``, second table). The
  linearisations' own, read from AeroDyn's output Jacobians (rows ``RtAeroFxh``/``RtAeroMxh``
  of C and D, no mass matrix involved), against the table's here: ∂T/∂Ω −7.56e5 vs −8.49e5 N s
  (1.12x) at 15 m/s, −2.41e6 vs −3.00e6 (1.25x) at 19 m/s; ∂Q/∂Ω 1.11x and 1.09x, ∂Q/∂U 1.05x
  and 1.06x, ∂T/∂U 1.03x and 1.12x (an earlier "about twice" compared A entries ∂s̈/∂ω, which
  carry the other tower's inverse mass matrix). Put into this A in place of the table's, they
  move the pitch period from 30.09 to 29.91 s (15 m/s) and from 31.27 to 30.86 s (19 m/s);
* the linearisations use the equilibrium wake, not a frozen wake: a blade-element model of the
  deck's blade (:mod:`plant.rotor_bem`) with the induction re-converged reproduces their
  ∂T/∂Ω, ∂Q/∂Ω, ∂Q/∂U within 2-10 % at 15 and 19 m/s; with the induced velocities held
  (AeroDyn's ``FrozenWake``) it is 18-29 % off. This analysis therefore uses the table's
  derivatives (equilibrium wake, steady BEM): what the linearisations hold, and the physics of
  the time-domain plant (no dynamic inflow), whose table is the limit of motions slower than the
  wake's time constant τ ≈ 1.1 R/(U(1 − 1.3a)) (Øye's, about 10 s at 15 m/s, 30 s at 5 m/s); a
  frozen wake is the limit of motions much faster than it, and the 25-30 s platform periods lie
  between. With frozen-wake derivatives the pitch period here would be 30.81 s (15 m/s) and
  31.14 s (19 m/s);
* a smaller difference, found and not modelled: the linearisations' rotor pitching moment
  (``RtAeroMyh``) depends on the platform pitch rate (−6.5e8 N m s/rad at 15 m/s, 14 % more
  aerodynamic pitch damping than the thrust's h² ∂T/∂U; adding it here changes the pitch
  period by +0.5 %);
* below rated the linearisations are not open loop in generator torque: ∂ω̇/∂ω is −0.098 1/s at
  5 m/s and −1.118 1/s at 9 m/s against an aerodynamic −0.039 and −0.069 here, i.e. ServoDyn's
  generator-torque law is in their A (slopes about 1.9e7 and 3.3e8 N m s/rad); above rated
  their torque is constant (ServoDyn's region 3), this module's open-loop case.
  ``natural_modes(..., torque_slope_nm_s_rad=k)`` (``fowt analyze modes --torque-slope``) puts
  such a law in the loop: with the slope read from the ``.lin`` files, surge, heave and pitch
  agree within 0.8 % (5 m/s) and 1.6 % (9 m/s) with the azimuth-averaged linearisations; open
  loop, 9 m/s is 5.2 % short in surge and 12.5 % in pitch.

In that case (torque law below rated, held above) against the azimuth-averaged linearisations,
surge is within −0.8..+2.7 %, heave +0.3 %, pitch +0.3..+3.5 % at 5, 9, 12, 15, 19, 24 m/s
(``tests/test_modes.py``, ``bench/modes_vs_openfast.py``).

Tower fore-aft mode: 1.93 s here. The six linearisations give 2.23 s with the 2020 tower; an
OpenFAST linearisation of the current deck (the one imported here, 1,466.5 t tower) gives
0.5023 Hz = 1.99 s (IEAWindSystems/IEA-15-240-RWT issue #261); the v1.1 release notes say
"around 0.49 Hz". This model has rigid blades (0.518 Hz). The blades' first flapwise mode is
just above it (0.543 Hz at standstill: Rayleigh quotient of the deck's ElastoDyn blade with its
mode shape; higher when spinning); with flexible blades their collective flap mode couples with
the tower-top motion, and of two coupled modes the lower is pushed down, here by a few per cent:
the difference to 1.99 s.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path

import numpy as np
import numpy.typing as npt

from plant import turbine as _turbine
from plant.platform import (
    DOF_NAMES,
    FloatingParams,
    f,
    load_floating,
    relative_wind,
    rotor_thrust,
)

__all__ = [
    "NO_RESTORING_PERIOD_S",
    "OPEN_LOOP_CASE",
    "PITCH_LENGTH_M",
    "Mode",
    "OperatingPoint",
    "dofs_without_restoring",
    "identify_modes",
    "linearize",
    "modal_analysis",
    "natural_modes",
    "operating_point",
]

FloatArray = npt.NDArray[np.float64]

#: Length (m) by which pitch (rad) is scaled to compare with translations in mode shapes.
PITCH_LENGTH_M = 100.0

#: A DOF whose stiffness column ∂q̈/∂q_k (all DOFs' accelerations, in metres) would give a
#: period beyond this (s) has no restoring (e.g. surge imported without mooring): it has no
#: natural mode, and its slowest eigenvalues are drift, not an oscillation.
NO_RESTORING_PERIOD_S = 1.0e4

#: The case :func:`natural_modes` analyses (no controller in the loop).
OPEN_LOOP_CASE = (
    "open loop: no controller; blade pitch and generator torque held at the operating point, "
    "rotor speed free; rotor aerodynamics quasi-steady from the Cp/Ct/Cq table (equilibrium wake)"
)


@dataclass(frozen=True)
class Mode:
    """One natural mode (JSON-serialisable with :meth:`as_dict`).

    Attributes
    ----------
    name : str
        DOF name (``surge``, ``heave``, ``pitch``, ``tower_fore_aft``).
    period_s : float
        Damped period 2π/ω_d (s).
    damping_ratio : float
        ζ = −Re λ / |λ| (-).
    eigenvalue : tuple of float
        (Re λ 1/s, Im λ rad/s).
    """

    name: str
    period_s: float
    damping_ratio: float
    eigenvalue: tuple[float, float]

    def as_dict(self) -> dict[str, object]:
        """Plain dict (the eigenvalue as a two-element list [re, im])."""
        d = asdict(self)
        d["eigenvalue"] = list(self.eigenvalue)
        return d


@dataclass(frozen=True)
class OperatingPoint:
    """Steady state of the floating turbine at one wind speed.

    ``state`` is the full state vector (radiation states zero), ``inputs`` the held inputs
    (pitch demand rad, torque demand N m, wind m/s, zero wave forces).
    """

    wind_m_s: float
    state: tuple[float, ...]
    inputs: tuple[float, ...]
    thrust_n: float


def rotor_point(p: FloatingParams, wind_m_s: float) -> tuple[float, float, float]:
    """Step 1 of the module docstring: (ω rad/s, θ rad, T_g N m) at rotor-normal wind U_n."""
    return _rotor_point(p, wind_m_s)


def _rotor_point(p: FloatingParams, wind_m_s: float) -> tuple[float, float, float]:
    tp = p.turbine
    omega = min(tp.rated_rotor_speed_rad_s, tp.table.optimal_tsr() * wind_m_s / tp.rotor_radius_m)
    rated_mech_w = tp.rated_power_w / tp.generator_efficiency

    def aero(theta: float) -> float:
        return _turbine.outputs(0.0, (omega, theta, 0.0), (theta, 0.0, wind_m_s), tp).aero_torque_nm

    theta = tp.pitch_min_rad
    if aero(theta) * omega > rated_mech_w:
        from scipy.optimize import brentq  # noqa: PLC0415  offline only

        hi = min(tp.pitch_max_rad, math.radians(45.0))
        theta = float(brentq(lambda th: aero(th) * omega - rated_mech_w, theta, hi, xtol=1e-12))
    torque = aero(theta) / tp.gearbox_ratio
    return omega, theta, torque


def operating_point(
    params: FloatingParams,
    wind_m_s: float = 5.0,
    rotor: Callable[[float], tuple[float, float, float]] | None = None,
) -> OperatingPoint:
    """Steady rotor state and static platform equilibrium at a steady wind (module docstring).

    Parameters
    ----------
    params : FloatingParams
    wind_m_s : float
        Hub-height wind speed U (m/s), >= 0. U = 0: parked in still air (rotor at rest, no
        thrust and no aerodynamic damping; the platform modes are those of the hydrodynamics,
        mooring and structure alone).
    rotor : callable, optional
        U_n -> (ω rad/s, θ rad, T_g N m): the rotor point to hold at rotor-normal wind U_n
        (e.g. a controller's steady state); None: step 1 of the module docstring. The
        platform equilibrium is then that under this point's thrust.

    Returns
    -------
    OperatingPoint
    """
    if not (wind_m_s >= 0.0 and math.isfinite(wind_m_s)):
        raise ValueError(f"wind_m_s: expected a wind speed >= 0 m/s, got {wind_m_s}")
    nr = params.n_radiation
    # The rotor sees the rotor-normal wind U_n = U cos(τ + φ + κ s)/cos τ of the pitched platform
    # (relative_wind), and the platform's pitch depends on the rotor's thrust: fixed-point
    # iteration on U_n (converges in a few passes; the trim changes U_n by < 1 %).
    u_n = wind_m_s
    q_eq = np.zeros(4)
    for _ in range(50):
        omega, theta, torque = (rotor or partial(_rotor_point, params))(u_n)
        u = (theta, torque, wind_m_s, 0.0, 0.0, 0.0)

        def state(
            q: Sequence[float] | FloatArray, w: float = omega, th: float = theta, tg: float = torque
        ) -> tuple[float, ...]:
            return (*(float(v) for v in q), 0.0, 0.0, 0.0, 0.0, w, th, tg, *([0.0] * nr))

        def residual(q: FloatArray, u: tuple[float, ...] = u, state: object = state) -> FloatArray:
            dx = f(0.0, state(q), u, params)  # type: ignore[operator]
            return np.array(dx[4:8]) * np.array([1.0, 1.0, PITCH_LENGTH_M, 1.0])

        newton = _newton_equilibrium(residual, q_eq)
        if newton is not None:
            q_try = newton
        else:
            from scipy.optimize import fsolve  # noqa: PLC0415  the fallback only

            q_try, _, ier, msg = fsolve(residual, q_eq, full_output=True, xtol=1e-12)
            # From the previous pass's solution fsolve may stop without "progress" at the
            # solution.
            if ier != 1 and float(np.max(np.abs(residual(q_try)))) > 1e-9:
                # The mooring force is piecewise affine in surge with a first-order heave/
                # pitch term whose slope jumps at the table's knots (MooringTable), so the
                # residual jumps there and fsolve's trust region can stall at a knot short of
                # the root (9.5 m/s on OC3-Hywind: stalls at the 19 m knot, root at 19.26 m).
                q_try = _bracketed_equilibrium(residual, q_try, wind_m_s, msg)
        q_eq = q_try
        x = state(q_eq)
        u_new = relative_wind(x, wind_m_s, params) if params.aero else wind_m_s
        if abs(u_new - u_n) <= 1e-10 * wind_m_s:
            break
        u_n = u_new
    else:
        raise ValueError(f"operating point at U = {wind_m_s} m/s: rotor-normal wind not converged")
    thrust = rotor_thrust(omega, theta, u_n, params.turbine)
    return OperatingPoint(wind_m_s, x, u, float(thrust))


def _newton_equilibrium(
    residual: Callable[[FloatArray], FloatArray], q0: FloatArray, max_iter: int = 40
) -> FloatArray | None:
    """The root of ``residual`` by Newton's method from ``q0``, or None if it does not converge.

    Jacobian by forward differences (step 1e-7 max(|q_j|, 1)) at every iterate; converged
    when every step is below 1e-12 (1 + |q_j|) (fsolve's ``xtol`` here) and the residual
    (scaled accelerations) below 1e-9. None on a singular Jacobian, a non-finite iterate or
    no convergence in ``max_iter`` steps (e.g. cycling across a mooring-table knot), where
    the caller falls back to ``fsolve``.
    """
    q = np.array(q0, dtype=np.float64)
    r = residual(q)
    n = q.size
    jac = np.empty((n, n))
    for _ in range(max_iter):
        for j in range(n):
            h = 1e-7 * max(abs(float(q[j])), 1.0)
            qh = q.copy()
            qh[j] += h
            jac[:, j] = (residual(qh) - r) / h
        try:
            dq = np.linalg.solve(jac, -r)
        except np.linalg.LinAlgError:
            return None
        q = q + dq
        if not np.all(np.isfinite(q)):
            return None
        r = residual(q)
        if np.all(np.abs(dq) <= 1e-12 * (1.0 + np.abs(q))):
            return q if float(np.max(np.abs(r))) <= 1e-9 else None
    return None


def _bracketed_equilibrium(
    residual: Callable[[FloatArray], FloatArray], q0: FloatArray, wind_m_s: float, why: str
) -> FloatArray:
    """Static equilibrium by a bracket in surge, robust to the mooring table's jumps.

    For a surge x the other three DOFs solve their (smooth in them) equations, leaving the
    surge residual g(x); the bracket widens from ``q0``'s surge in 0.5 m steps (doubling) to a
    sign change of g, then Brent's method finds the root. The full residual must then be
    below 1e-9 (scaled accelerations), or, where g changes sign across a table knot's step
    rather than through zero, heave, pitch and tower solved there and the surge residual no
    larger than the step; else ValueError with fsolve's message ``why``.
    """
    from scipy.optimize import brentq, fsolve  # noqa: PLC0415  offline only

    rest = np.array(q0[1:], dtype=np.float64)

    def solve_rest(x: float) -> FloatArray:
        nonlocal rest
        sol = fsolve(lambda y: residual(np.array([x, *y]))[1:], rest, xtol=1e-13, full_output=True)[
            0
        ]
        rest = np.asarray(sol, dtype=np.float64)
        return rest

    def g(x: float) -> float:
        return float(residual(np.array([x, *solve_rest(x)]))[0])

    x0 = float(q0[0])
    g0 = g(x0)
    lo = hi = x0
    step = 0.5
    for _ in range(12):
        lo, hi = x0 - step, x0 + step
        if g(lo) * g0 <= 0.0 or g(hi) * g0 <= 0.0:
            break
        step *= 2.0
    else:
        raise ValueError(f"no static equilibrium found at U = {wind_m_s} m/s: {why}")
    a, b = (lo, x0) if g(lo) * g0 <= 0.0 else (x0, hi)
    x = float(brentq(g, a, b, xtol=1e-12, rtol=1e-14))
    q = np.array([x, *solve_rest(x)])
    r = residual(q)
    if float(np.max(np.abs(r))) <= 1e-9:
        return q
    # The surge residual can change sign across a jump instead of through a root: the
    # table's heave/pitch slope changes at its knots, so the surge force steps there by a
    # little. The bracket then closes on the knot, and the equilibrium is the knot, to
    # within that step, when heave, pitch and tower are solved there.
    below, above = g(x - 1e-9 * (1.0 + abs(x))), g(x + 1e-9 * (1.0 + abs(x)))
    step = abs(below - above)
    solved_rest = float(np.max(np.abs(r[1:]))) <= 1e-9
    if below * above <= 0.0 and solved_rest and abs(float(r[0])) <= step:
        return q
    raise ValueError(f"no static equilibrium found at U = {wind_m_s} m/s: {why}")


def linearize(params: FloatingParams, op: OperatingPoint, rel_step: float = 1e-6) -> FloatArray:
    """State matrix A = ∂f/∂x at ``op`` by central differences (inputs held).

    Step per state: h_i = rel_step · max(|x_i|, s_i), with s_i a typical magnitude of the
    state's unit (1 m, 1 rad, 1 rad/s, 1e6 N m, 1 for radiation states).
    """
    x0 = np.array(op.state, dtype=np.float64)
    n = x0.size
    scale = np.ones(n)
    scale[10] = 1e6
    A = np.zeros((n, n))
    for i in range(n):
        h = rel_step * max(abs(x0[i]), scale[i]) * 1e2
        xp = x0.copy()
        xm = x0.copy()
        xp[i] += h
        xm[i] -= h
        fp = np.array(f(0.0, tuple(xp.tolist()), op.inputs, params))
        fm = np.array(f(0.0, tuple(xm.tolist()), op.inputs, params))
        A[:, i] = (fp - fm) / (2.0 * h)
    return A


def identify_modes(
    a_matrix: FloatArray,
    position_index: Sequence[int],
    velocity_index: Sequence[int],
    names: Sequence[str],
    length_scale: Sequence[float],
) -> list[Mode]:
    """Natural mode of each DOF from a first-order state matrix (module docstring, step 4).

    Parameters
    ----------
    a_matrix : (n, n) array
        State matrix (1/s).
    position_index, velocity_index : sequences of int
        State indices of each DOF's displacement and rate.
    names : sequence of str
        DOF names, same length.
    length_scale : sequence of float
        Factor turning each DOF's unit into metres for the dominance test (1 for translations,
        a length in m for rotations).

    Returns
    -------
    list of Mode
        One per DOF that has an oscillatory mode, in the order of ``names``.
    """
    lam, vec = np.linalg.eig(a_matrix)
    left = np.linalg.inv(vec)
    pos = list(position_index)
    scale = np.asarray(length_scale, dtype=np.float64)
    dominant = np.argmax(np.abs(vec[pos, :]) * scale[:, None], axis=0)
    modes: list[Mode] = []
    for k, name in enumerate(names):
        residue = np.abs(vec[pos[k], :] * left[:, velocity_index[k]])
        score = residue / np.maximum(np.abs(lam.real), 1e-12)
        ok = (lam.imag > 1e-9) & (dominant == k)
        if not np.any(ok):
            continue
        best = int(np.argmax(np.where(ok, score, -1.0)))
        ev = complex(lam[best])
        modes.append(
            Mode(
                name=name,
                period_s=2.0 * math.pi / ev.imag,
                damping_ratio=-ev.real / abs(ev),
                eigenvalue=(ev.real, ev.imag),
            )
        )
    return modes


def dofs_without_restoring(
    a_matrix: FloatArray,
    position_index: Sequence[int],
    velocity_index: Sequence[int],
    names: Sequence[str],
    length_scale: Sequence[float],
) -> list[str]:
    """Names of the DOFs that no force pulls back: ``‖∂q̈/∂q_k‖ < (2π/T₀)²``.

    ``T₀`` is :data:`NO_RESTORING_PERIOD_S`; the column holds every DOF's acceleration per unit
    displacement of DOF k (rotations in metres by ``length_scale``), so a DOF restored only
    through a coupling still counts as restored. Arguments as in :func:`identify_modes`.
    """
    scale = np.asarray(length_scale, dtype=np.float64)
    vel = list(velocity_index)
    limit = (2.0 * math.pi / NO_RESTORING_PERIOD_S) ** 2
    free = []
    for k, name in enumerate(names):
        column = a_matrix[vel, position_index[k]] * scale / scale[k]
        if float(np.max(np.abs(column))) < limit:
            free.append(name)
    return free


def modal_analysis(
    preset: str | Path | FloatingParams, wind_m_s: float = 5.0, torque_slope_nm_s_rad: float = 0.0
) -> tuple[list[Mode], list[str]]:
    """:func:`natural_modes` and the DOFs without restoring (:func:`dofs_without_restoring`).

    A DOF without restoring (surge of a platform imported without mooring) has no natural
    mode: none is reported for it, and its name is in the second list.
    """
    params = preset if isinstance(preset, FloatingParams) else load_floating(preset)
    if not math.isfinite(torque_slope_nm_s_rad):
        raise ValueError(
            "torque_slope_nm_s_rad: expected a finite slope in N m s/rad, "
            f"got {torque_slope_nm_s_rad}"
        )
    op = operating_point(params, wind_m_s)
    a = linearize(params, op)
    a[10, 8] += torque_slope_nm_s_rad * params.turbine.inv_torque_tau
    args = (range(4), range(4, 8), DOF_NAMES, (1.0, 1.0, PITCH_LENGTH_M, 1.0))
    free = dofs_without_restoring(a, *args)
    modes = [m for m in identify_modes(a, *args) if m.name not in free]
    return modes, free


def natural_modes(
    preset: str | Path | FloatingParams, wind_m_s: float = 5.0, torque_slope_nm_s_rad: float = 0.0
) -> list[Mode]:
    """Damped natural periods and damping ratios of surge, heave, pitch and tower fore-aft.

    Parameters
    ----------
    preset : str, Path or FloatingParams
        Floating preset name/path (loaded with :func:`plant.platform.load_floating`) or params.
    wind_m_s : float, optional
        Steady hub-height wind (m/s), default 5.
    torque_slope_nm_s_rad : float, optional
        k = ∂T_c/∂ω: a generator-torque law in the loop, T_c = T_0 + k (ω − ω_0) (N m s/rad,
        low-speed shaft), entering through the torque actuator: ∂Ṫ_g/∂ω = k/τ_T. Default 0:
        the open-loop case (:data:`OPEN_LOOP_CASE`). Below rated the OpenFAST linearisations
        hold ServoDyn's torque law (module docstring); this is the option to compare with them.

    Returns
    -------
    list of Mode
        ``[surge, heave, pitch, tower_fore_aft]`` (those found), JSON-ready via ``as_dict``;
        none for a DOF without restoring (:func:`modal_analysis` names those).
    """
    return modal_analysis(preset, wind_m_s, torque_slope_nm_s_rad)[0]
