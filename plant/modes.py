"""Steady operating point, numerical linearisation and natural modes of the floating turbine.

1. Rotor: below rated, ω = min(λ* U / R, ω_rated) at fine pitch; above rated, the pitch at which
   the aerodynamic power at rated speed equals rated power / η; generator torque balancing the
   aerodynamic torque (held as the torque demand).
2. Platform: the static equilibrium F(q) = 0 of :func:`plant.platform.f` at rest (mean thrust,
   nonlinear mooring, weight and buoyancy), solved by Newton iterations (scipy ``fsolve``).
3. A = ∂f/∂x by central differences about that point (inputs held), including the radiation
   states and the aerodynamic damping (thrust and torque depend on U_rel = U − J_h·q̇).
4. Eigenvalues λ = −ζω_n ± jω_d of A; a mode's DOF is the dominant entry of its displacement
   eigenvector with pitch scaled by a length (:data:`PITCH_LENGTH_M`) so that metres compare;
   among the modes of one DOF, the one with the largest drive-point resonance peak
   |residue| / |Re λ| is that DOF's natural mode (radiation-state poles, nearly cancelled by
   zeros, have tiny residues). Period T = 2π/ω_d (damped), ζ = −Re λ / |λ|.

The same identification (:func:`identify_modes`) applies to any first-order state matrix with
known position/velocity indices, e.g. an OpenFAST linearisation.

Known discrepancy: the tower fore-aft mode
------------------------------------------
For ``iea15mw_volturnus`` at 5 m/s, surge, heave and pitch agree with the OpenFAST
linearisation ``lin_00.1.lin`` (123.2 s, 20.4 s, 27.3 s), the first tower fore-aft mode does
not: 1.93 s here against 2.23 s there. The evidence says the linearisation was made with another
tower than the deck the preset is imported from, so the preset is not tuned by hand to match:

* the tower column of lin_00's A (∂ṡ̇/∂s, the modal stiffness over the modal mass as coupled
  to the platform) is 0.745 of ours (−7.79 vs −10.46 1/s²), and √(1/0.745) × 1.93 s = 2.23 s:
  the whole period difference is that one ratio, not the coupling or the damping;
* lin_00's static heave at its operating point is −0.021 m, ours −0.356 m; with the heave
  restoring of 4.52e6 N/m (hydrostatics + mooring) that is about 150 t less weight in the
  linearised turbine;
* lin_00 was generated on 02-Feb-2021 from a WEIS/AeroElasticSE deck ("Generated with
  AeroElasticSE FAST driver", MAP++ of Jan 2021), while the preset comes from the deck shipped
  with rosco 2.10.6, whose tower weighs 1467 t (ElastoDyn tower file, ``TMassDen`` integrated)
  against 1263 t in the VolturnUS-S definition report (NREL/TP-5000-76773);
* so the linearisation's tower is lighter and softer relative to its mass than the deck's; the
  test keeps the 5 % tower check as an expected failure with this reason
  (``tests/test_modes.py``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
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
    "PITCH_LENGTH_M",
    "Mode",
    "OperatingPoint",
    "identify_modes",
    "linearize",
    "natural_modes",
    "operating_point",
]

FloatArray = npt.NDArray[np.float64]

#: Length (m) by which pitch (rad) is scaled to compare with translations in mode shapes.
PITCH_LENGTH_M = 100.0


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


def operating_point(params: FloatingParams, wind_m_s: float = 5.0) -> OperatingPoint:
    """Steady rotor state and static platform equilibrium at a steady wind (module docstring).

    Parameters
    ----------
    params : FloatingParams
    wind_m_s : float
        Hub-height wind speed U (m/s), > 0.

    Returns
    -------
    OperatingPoint
    """
    from scipy.optimize import fsolve  # noqa: PLC0415  offline only

    if not wind_m_s > 0.0:
        raise ValueError(f"wind_m_s: expected a positive wind speed in m/s, got {wind_m_s}")
    nr = params.n_radiation
    # The rotor sees the rotor-normal wind U_n = U cos(τ + φ + κ s)/cos τ of the pitched platform
    # (relative_wind), and the platform's pitch depends on the rotor's thrust: fixed-point
    # iteration on U_n (converges in a few passes; the trim changes U_n by < 1 %).
    u_n = wind_m_s
    q_eq = np.zeros(4)
    for _ in range(50):
        omega, theta, torque = _rotor_point(params, u_n)
        u = (theta, torque, wind_m_s, 0.0, 0.0, 0.0)

        def state(
            q: Sequence[float] | FloatArray, w: float = omega, th: float = theta, tg: float = torque
        ) -> tuple[float, ...]:
            return (*(float(v) for v in q), 0.0, 0.0, 0.0, 0.0, w, th, tg, *([0.0] * nr))

        def residual(q: FloatArray, u: tuple[float, ...] = u, state: object = state) -> FloatArray:
            dx = f(0.0, state(q), u, params)  # type: ignore[operator]
            return np.array(dx[4:8]) * np.array([1.0, 1.0, PITCH_LENGTH_M, 1.0])

        q_eq, _, ier, msg = fsolve(residual, q_eq, full_output=True, xtol=1e-12)
        # From the previous pass's solution fsolve may stop without "progress" at the solution.
        if ier != 1 and float(np.max(np.abs(residual(q_eq)))) > 1e-9:
            raise ValueError(f"no static equilibrium found at U = {wind_m_s} m/s: {msg}")
        x = state(q_eq)
        u_new = relative_wind(x, wind_m_s, params) if params.aero else wind_m_s
        if abs(u_new - u_n) < 1e-10 * wind_m_s:
            break
        u_n = u_new
    else:
        raise ValueError(f"operating point at U = {wind_m_s} m/s: rotor-normal wind not converged")
    thrust = rotor_thrust(omega, theta, u_n, params.turbine)
    return OperatingPoint(wind_m_s, x, u, float(thrust))


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


def natural_modes(preset: str | Path | FloatingParams, wind_m_s: float = 5.0) -> list[Mode]:
    """Damped natural periods and damping ratios of surge, heave, pitch and tower fore-aft.

    Parameters
    ----------
    preset : str, Path or FloatingParams
        Floating preset name/path (loaded with :func:`plant.platform.load_floating`) or params.
    wind_m_s : float, optional
        Steady hub-height wind (m/s), default 5.

    Returns
    -------
    list of Mode
        ``[surge, heave, pitch, tower_fore_aft]`` (those found), JSON-ready via ``as_dict``.
    """
    params = preset if isinstance(preset, FloatingParams) else load_floating(preset)
    op = operating_point(params, wind_m_s)
    a = linearize(params, op)
    return identify_modes(a, range(4), range(4, 8), DOF_NAMES, (1.0, 1.0, PITCH_LENGTH_M, 1.0))
