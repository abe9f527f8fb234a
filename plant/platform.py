"""Floating platform, flexible tower and rotor of a floating wind turbine, as one ``f(t, x, u, p)``.

Degrees of freedom (all about the platform reference point at the still-water line, the WAMIT
and OpenFAST convention; x downwind, z up, pitch positive when the tower top moves downwind)::

    q = (x, z, φ, s)     platform surge (m), heave (m), pitch (rad),
                         first tower fore-aft mode, generalised coordinate s = tower-top
                         displacement along the tower-fixed x axis (m)

State, input and dynamics (SI)::

    x = (q, q̇, ω, θ, T_g, ξ)   ξ: radiation-memory states of surge, heave, pitch
    u = (θ_c, T_c, U, F_x^w, F_z^w, M_φ^w)   pitch and torque demands, hub-height wind (m/s),
                                              wave excitation surge force (N), heave force (N),
                                              pitch moment (N m) about the reference point

    (M_s + A_∞) q̈ = F_0 − K q + F_m(q) − D q̇ − B_q (v∘|v|) − μ + Q_T T + F_t + F^w
    dξ/dt = A_r ξ + B_r v,   μ = C_r ξ,   v = (ẋ, ż, φ̇)

* ``M_s``: rigid-body mass matrix of platform + tower + rotor-nacelle assembly (RNA) with the
  tower mode, from the linearised kinematics of every mass element: a point at body-frame
  position (a, h) moves with Ẋ = ẋ + h φ̇ + ψ ṡ, Ż = ż − a φ̇ (tower elements: ψ = ψ(η);
  RNA points, at (a, c) from the tower top: Ẋ = ẋ + (h_t + c) φ̇ + (1 + c κ) ṡ,
  Ż = ż − a (φ̇ + κ ṡ), κ = ψ'(1)/L the tower-top slope per metre of s), so that
  M_s = Σ m (J_xᵀJ_x + J_zᵀJ_z) + I J_rᵀJ_r.
* ``K``: hydrostatics (WAMIT ``.hst``, which excludes gravity), the gravity terms of the
  second-order expansion of the potential m g Z (the destabilising −m g h φ²/2 of every mass,
  the tower/pitch coupling −g φ s ∫ψ dm and the geometric softening of the tower by the weight
  above each section), the tower modal stiffness ∫EI ψ''² dh and any additional linear
  stiffness of the deck. ``F_0``: buoyancy ρ g V₀ minus the total weight, the moment of the
  weight of masses off the tower axis, and the deck's additional preload.
* ``F_m``: quasi-static mooring, see :class:`MooringTable` (nonlinear in surge, first order in
  heave and pitch, derived from a potential so it is conservative).
* ``D``: linear damping (additional linear damping of the deck, tower structural damping
  2 ζ √(k m) of the fixed-base mode); ``B_q``: additional quadratic drag (OpenFAST
  ``AddBQuad``: F = −B_q (v∘|v|), element-wise product).
* Rotor: :func:`plant.turbine.f` with the rotor-normal relative wind at the hub
  U_rel = [(U − J_h·q̇) cos ψ + (J_v·q̇) sin ψ]/cos τ, ψ = τ + φ + κ s the shaft's tilt (τ the
  built-in tilt, upwind end up), J_h = (1, 0, h_hub, 1 + c_hub κ) and J_v = (0, 1, −a_hub,
  −a_hub κ) the hub's horizontal and vertical velocity per DOF rate; the thrust
  T = ½ρπR²U_rel²Ct(λ, θ) acts along the shaft: generalised force
  Q_T T, Q_T = (cos ψ, −sin ψ, h_hub cos τ + a_hub sin τ, J_h,s cos τ − J_v,s sin τ).
* Tower drag: F_t = c_t U|U| − |U| D_t q̇ (:func:`tower_drag_matrices`).

The potential energy is V(q) = ½ qᵀ K q − F_0ᵀq + V_m(q), so with D, B_q, radiation, aero and
waves off, E = ½ q̇ᵀ(M_s + A_∞)q̇ + V(q) + ½ J ω² is conserved (:func:`energy`).

What is hand-written here and why
---------------------------------
``f`` and the integrator :func:`step_floating` run several times per plant step of a real-time
loop; both are compiled (:mod:`plant._kernels`, numba, cached on disk), with every constant
precomputed here once: for ``f`` the matrices, mooring segments, radiation block and
Cp/Ct/Cq cells packed in one array; for the step M⁻¹ folded into the stiffness (with the
mooring, per table segment), damping, drag, hub lever and wave-force maps, and the radiation
block discretised exactly (:func:`_radiation_step_matrices`). History of the step's cost per
call (CPU, 34 radiation states): 31 µs (f in Python floats), 17 µs (a specialised closure),
23 µs (with shaft tilt, tower drag, offset-dependent mooring), ~6 µs compiled including the
tuple/array conversions of the public call (``bench/step_floating_speed.py``); inside
:meth:`plant.simulator.PlantSimulator.advance`, which keeps the state as an array, ~1-2 µs.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict

import msgspec
import numpy as np
import numpy.typing as npt

from plant import _kernels as _k
from plant.turbine import WIND_MIN_M_S, TurbineParams, load_turbine

if TYPE_CHECKING:
    from plant.hydro.radiation import RadiationModel, RadiationSS
    from plant.hydro.wamit import HydroData

__all__ = [
    "DOF_NAMES",
    "N_DOF",
    "N_MECH_STATES",
    "FloatingParams",
    "MooringTable",
    "conservative",
    "energy",
    "f",
    "inverse_mass_matrix",
    "mooring_force",
    "relative_wind",
    "rotor_thrust",
    "state_names",
    "step_floating",
]

FloatArray = npt.NDArray[np.float64]

#: Structural degrees of freedom, in state order.
DOF_NAMES = ("surge", "heave", "pitch", "tower_fore_aft")
N_DOF = 4
#: Positions, velocities and the three turbine states (ω, θ, T_g); radiation states follow.
N_MECH_STATES = 2 * N_DOF + 3


def _matrix(owner: str, name: str, value: object, shape: tuple[int, ...], unit: str) -> FloatArray:
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{owner}.{name}: expected an array of numbers in {unit} ({exc})") from exc
    if arr.shape != shape:
        raise ValueError(f"{owner}.{name}: expected shape {shape} in {unit}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{owner}.{name}: non-finite entries (expected {unit})")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class MooringTable:
    """Quasi-static mooring restoring force, tabulated in surge, first order in heave and pitch.

    With F_x(x), F_z(x), M_φ(x) the mooring surge force (N), heave force (N) and pitch moment
    (N m, about the reference point) at surge offset x and zero heave and pitch (a
    precomputed catenary solution), and K_zφ(x) the 2x2 mooring stiffness in (heave, pitch) at
    offset x (the lines' tensions, hence their heave and pitch stiffness, grow with the offset:
    for the IEA 15 MW VolturnUS-S k_φφ is 2.59e8 N m/rad at 0 m and 3.05e8 at 14 m), the force
    is the gradient of the potential

        V_m(x, z, φ) = V_0(x) − z F_z(x) − φ M_φ(x) + ½ (z, φ) K_zφ(x) (z, φ)ᵀ,  V_0' = −F_x,

    i.e. F_x = F_x(x) + z F_z'(x) + φ M_φ'(x) − ½ (z, φ) K_zφ'(x) (z, φ)ᵀ and
    (F_z, M_φ) = (F_z(x), M_φ(x)) − K_zφ(x) (z, φ). Tables are interpolated linearly
    (extrapolated linearly beyond the grid), so V_0 is exact piecewise quadratic and the model
    conserves energy. Without a K_zφ(x) table, K_zφ is the constant given.

    Parameters
    ----------
    surge_m : array_like, shape (n,)
        Surge offsets (m), strictly increasing, n >= 2.
    force_surge_n, force_heave_n : array_like, shape (n,)
        Mooring force on the platform along x and z (N), z up (negative: lines pull down).
    moment_pitch_nm : array_like, shape (n,)
        Mooring moment about the y axis through the reference point (N m), positive pitch sense.
    stiffness_heave_pitch : array_like, shape (2, 2)
        K_zφ at zero offset: [[N/m, N/rad], [N m/m, N m/rad]], symmetrised.
    stiffness_heave_pitch_by_surge : array_like, shape (n, 2, 2) or (0,), optional
        K_zφ(x) at every surge offset of ``surge_m`` (same units), symmetrised; empty (default):
        the constant ``stiffness_heave_pitch`` at every offset.
    """

    surge_m: FloatArray
    force_surge_n: FloatArray
    force_heave_n: FloatArray
    moment_pitch_nm: FloatArray
    stiffness_heave_pitch: FloatArray
    stiffness_heave_pitch_by_surge: FloatArray = field(default_factory=lambda: np.zeros((0,)))
    _x: list[float] = field(init=False, repr=False)
    _seg: list[tuple[float, ...]] = field(init=False, repr=False)
    _k: tuple[float, float, float] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        owner = "MooringTable"
        x = _matrix(owner, "surge_m", self.surge_m, np.shape(self.surge_m), "m")
        n = x.size
        if x.ndim != 1 or n < 2 or not np.all(np.diff(x) > 0.0):
            raise ValueError(f"{owner}.surge_m: expected >= 2 strictly increasing offsets in m")
        fx = _matrix(owner, "force_surge_n", self.force_surge_n, (n,), "N")
        fz = _matrix(owner, "force_heave_n", self.force_heave_n, (n,), "N")
        my = _matrix(owner, "moment_pitch_nm", self.moment_pitch_nm, (n,), "N m")
        k = _matrix(owner, "stiffness_heave_pitch", self.stiffness_heave_pitch, (2, 2), "N/m..")
        k = 0.5 * (k + k.T)
        k.setflags(write=False)
        kx_in = np.asarray(self.stiffness_heave_pitch_by_surge, dtype=np.float64)
        if kx_in.size == 0:
            kx = np.broadcast_to(k, (n, 2, 2)).copy()
        else:
            kx = _matrix(owner, "stiffness_heave_pitch_by_surge", kx_in, (n, 2, 2), "N/m..")
            kx = 0.5 * (kx + kx.transpose(0, 2, 1))
        kx.setflags(write=False)
        set_ = object.__setattr__
        set_(self, "stiffness_heave_pitch_by_surge", kx if kx_in.size else np.zeros((0,)))
        for name, val in (
            ("surge_m", x),
            ("force_surge_n", fx),
            ("force_heave_n", fz),
            ("moment_pitch_nm", my),
            ("stiffness_heave_pitch", k),
        ):
            set_(self, name, val)
        # Potential V_0 at the knots, zero at x = 0 (or at the nearest knot to 0).
        v0 = np.concatenate([[0.0], np.cumsum(-0.5 * (fx[1:] + fx[:-1]) * np.diff(x))])
        v0 -= float(np.interp(0.0, x, v0))
        seg = []
        for i in range(n - 1):
            dx = float(x[i + 1] - x[i])
            seg.append(
                (
                    float(x[i]),
                    float(fx[i]),
                    float(fx[i + 1] - fx[i]) / dx,
                    float(fz[i]),
                    float(fz[i + 1] - fz[i]) / dx,
                    float(my[i]),
                    float(my[i + 1] - my[i]) / dx,
                    float(v0[i]),
                    float(kx[i, 0, 0]),
                    float(kx[i + 1, 0, 0] - kx[i, 0, 0]) / dx,
                    float(kx[i, 0, 1]),
                    float(kx[i + 1, 0, 1] - kx[i, 0, 1]) / dx,
                    float(kx[i, 1, 1]),
                    float(kx[i + 1, 1, 1] - kx[i, 1, 1]) / dx,
                )
            )
        set_(self, "_x", [float(v) for v in x])
        set_(self, "_seg", seg)
        set_(self, "_k", (float(k[0, 0]), float(k[0, 1]), float(k[1, 1])))

    def segment(self, surge_m: float) -> tuple[float, ...]:
        """Segment holding ``surge_m``: (x_i, F_x,i, F_x', F_z,i, F_z', M_i, M', V_0,i,
        k_zz,i, k_zz', k_zφ,i, k_zφ', k_φφ,i, k_φφ')."""
        i = bisect_right(self._x, surge_m) - 1
        if i < 0:
            i = 0
        elif i > len(self._seg) - 1:
            i = len(self._seg) - 1
        return self._seg[i]

    def stiffness_at(self, surge_m: float) -> float:
        """Surge stiffness −dF_x/dx at ``surge_m`` (N/m), of the interpolated table."""
        return -self.segment(surge_m)[2]


def mooring_force(
    table: MooringTable, surge_m: float, heave_m: float, pitch_rad: float
) -> tuple[float, float, float]:
    """Mooring (surge force N, heave force N, pitch moment N m) at a platform position.

    F_x = F_x(x) + z F_z'(x) + φ M_φ'(x) − ½ (z, φ) K_zφ'(x) (z, φ)ᵀ;
    F_z = F_z(x) − k_zz(x) z − k_zφ(x) φ;  M_φ = M_φ(x) − k_zφ(x) z − k_φφ(x) φ
    (see :class:`MooringTable`).
    """
    x0, fx0, dfx, fz0, dfz, my0, dmy, _, kzz, dkzz, kzp, dkzp, kpp, dkpp = table.segment(surge_m)
    d = surge_m - x0
    z, r = heave_m, pitch_rad
    return (
        fx0
        + dfx * d
        + z * dfz
        + r * dmy
        - 0.5 * (dkzz * z * z + 2.0 * dkzp * z * r + dkpp * r * r),
        fz0 + dfz * d - (kzz + dkzz * d) * z - (kzp + dkzp * d) * r,
        my0 + dmy * d - (kzp + dkzp * d) * z - (kpp + dkpp * d) * r,
    )


def _mooring_potential(
    table: MooringTable, surge_m: float, heave_m: float, pitch_rad: float
) -> float:
    x0, fx0, dfx, fz0, dfz, my0, dmy, v0, kzz, dkzz, kzp, dkzp, kpp, dkpp = table.segment(surge_m)
    d = surge_m - x0
    kzz += dkzz * d
    kzp += dkzp * d
    kpp += dkpp * d
    fz = fz0 + dfz * d
    my = my0 + dmy * d
    return (
        v0
        - (fx0 * d + 0.5 * dfx * d * d)
        - heave_m * fz
        - pitch_rad * my
        + 0.5 * (kzz * heave_m * heave_m + 2.0 * kzp * heave_m * pitch_rad + kpp * pitch_rad**2)
    )


def _tuple2(a: npt.NDArray[np.floating]) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(v) for v in row) for row in a)


def inverse_mass_matrix(mass: FloatArray, locked_dofs: Sequence[int] = ()) -> FloatArray:
    """Inverse of the mass matrix with DOFs locked: M_ff⁻¹ on the free DOFs, 0 elsewhere.

    With ``F`` the free and ``L`` the locked DOFs, the constrained equations of motion are
    M_FF q̈_F = g_F (the forces g_L on the locked DOFs are taken by the constraint) and
    q̈_L = 0, so the map from generalised forces to accelerations is the matrix returned
    (kg⁻¹, 1/(kg m), 1/(kg m²) entries). Without locked DOFs it is M⁻¹.
    """
    m = np.asarray(mass, dtype=np.float64)
    free = [i for i in range(m.shape[0]) if i not in set(locked_dofs)]
    out = np.zeros_like(m)
    out[np.ix_(free, free)] = np.linalg.inv(m[np.ix_(free, free)])
    return out


@dataclass(frozen=True, eq=False)
class FloatingParams:
    """Validated, frozen parameters of the coupled floating-turbine model (SI units).

    Matrices are in DOF order (surge m, heave m, pitch rad, tower-top displacement m), so their
    entries have the mixed units of the product of the two DOFs (e.g. mass kg, kg m, kg m²).

    Parameters
    ----------
    name : str
    turbine : TurbineParams
        Rotor, drivetrain, actuators, Cp/Ct/Cq table.
    mass_matrix : (4, 4) array
        M_s + A_∞: structural mass with the infinite-frequency added mass (kg, kg m, kg m²),
        symmetric positive definite.
    stiffness : (4, 4) array
        K: hydrostatic + gravity + tower modal + additional linear stiffness (N/m, N/rad, N m/m,
        N m/rad), excluding the mooring. Symmetric.
    static_force : (4,) array
        F_0 at q = 0 (N, N, N m, N): buoyancy − weight, moments of off-axis weights, preload.
    linear_damping : (4, 4) array
        D (N s/m, N s, N m s/rad ...).
    quadratic_damping : (3, 3) array
        B_q of (surge, heave, pitch): N/(m/s)², N m/(rad/s)² ...
    hub_lever : (4,) array
        J_h = (1, 0, h_hub m, 1 + c_hub κ): hub velocity along x per unit DOF rate (-, -, m, -).
    mooring : MooringTable
    hub_lever_vertical : (4,) array, optional
        J_v = (0, 1, −a_hub m, −a_hub κ): hub velocity along z per unit DOF rate, a_hub the hub's
        x offset from the tower axis (negative upwind). Default (0, 1, 0, 0).
    shaft_tilt_rad : float, optional
        τ: rotor shaft tilt, upwind end up (rad; the IEA 15 MW's 6° is 0.1047, ElastoDyn
        ``ShftTilt`` = −6°). Default 0.
    tower_slope_per_m : float, optional
        κ: rotation of the tower top (and shaft) per metre of the tower DOF s (rad/m).
    tower_drag : (4,) array, optional
        c_t: generalised aerodynamic drag force of the tower per U|U| (N, N, N m, N per (m/s)²),
        c_t,i = ½ρ ∫ C_d D (z/h_hub)^{2α} J_i(z) dz, J(z) = (1, 0, z, ψ(z)). Default zeros.
    tower_drag_damping : (4, 4) array, optional
        D_t: its derivative with respect to the structure's velocity per |U| (N s/m per m/s ...),
        D_t,ij = ρ ∫ C_d D (z/h_hub)^α J_i J_j dz, so that the tower drag to first order in the
        tower's velocity v(z) = J(z)·q̇ ≪ U is F_t = c_t U|U| − |U| D_t q̇. Default zeros.
    radiation_a, radiation_b, radiation_c : arrays (n, n), (n, 3), (3, n)
        Radiation memory state space of (surge, heave, pitch): dξ/dt = A ξ + B v, μ = C ξ
        (μ in N, N, N m); n = 0 for none.
    aero : bool, optional
        Rotor loads on (default). False: no thrust and no aerodynamic torque (energy checks).
    locked_dofs : tuple of int, optional
        Structural DOFs held fixed (indices into :data:`DOF_NAMES`: 0 surge, 1 heave, 2 pitch,
        3 tower fore-aft), e.g. ``(1, 2, 3)`` for the surge + rotor model of a TLP
        (casanovas-2014). The state layout is unchanged; the inverse mass matrix used by
        :func:`f` and :func:`step_floating` is that of the free DOFs, zero in the rows and
        columns of the locked ones,

            q̈_free = M_ff⁻¹ g_free,  q̈_locked = 0,

        i.e. the motion of the constrained system (the constraint forces take up the rest):
        a locked DOF keeps its initial position and rate (start it at rest).
    """

    name: str
    turbine: TurbineParams
    mass_matrix: FloatArray
    stiffness: FloatArray
    static_force: FloatArray
    linear_damping: FloatArray
    quadratic_damping: FloatArray
    hub_lever: FloatArray
    mooring: MooringTable
    radiation_a: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    radiation_b: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    radiation_c: FloatArray = field(default_factory=lambda: np.zeros((3, 0)))
    aero: bool = True
    locked_dofs: tuple[int, ...] = ()
    hub_lever_vertical: FloatArray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0, 0.0]))
    shaft_tilt_rad: float = 0.0
    tower_slope_per_m: float = 0.0
    tower_drag: FloatArray = field(default_factory=lambda: np.zeros(4))
    tower_drag_damping: FloatArray = field(default_factory=lambda: np.zeros((4, 4)))
    # Precomputed for f(): Python-float tuples and the radiation block matrix.
    _minv: tuple[tuple[float, ...], ...] = field(init=False, repr=False)
    _k: tuple[tuple[float, ...], ...] = field(init=False, repr=False)
    _d: tuple[tuple[float, ...], ...] = field(init=False, repr=False)
    _bq: tuple[tuple[float, ...], ...] = field(init=False, repr=False)
    _f0: tuple[float, ...] = field(init=False, repr=False)
    _jh: tuple[float, ...] = field(init=False, repr=False)
    _jv: tuple[float, ...] = field(init=False, repr=False)
    _rot: tuple[float, float, float, float, float] = field(init=False, repr=False)
    _tdrag: tuple[float, ...] = field(init=False, repr=False)
    _tdamp: tuple[tuple[float, ...], ...] = field(init=False, repr=False)
    _rad: FloatArray = field(init=False, repr=False)
    _step_cache: dict[float, _Stepper] = field(init=False, repr=False)
    _blocks: list[FloatArray] = field(init=False, repr=False)
    _kern: tuple[FloatArray, npt.NDArray[np.int64]] = field(init=False, repr=False)
    n_radiation: int = field(init=False)

    def __post_init__(self) -> None:
        owner = "FloatingParams"
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"{owner}.name: expected a non-empty string")
        if not isinstance(self.turbine, TurbineParams):
            raise ValueError(f"{owner}.turbine: expected TurbineParams")
        if not isinstance(self.mooring, MooringTable):
            raise ValueError(f"{owner}.mooring: expected a MooringTable")
        set_ = object.__setattr__
        m = _matrix(owner, "mass_matrix", self.mass_matrix, (4, 4), "kg, kg m, kg m^2")
        if not np.allclose(m, m.T, rtol=1e-9, atol=1e-6 * float(np.max(np.abs(m)))):
            raise ValueError(f"{owner}.mass_matrix: expected a symmetric matrix (kg, kg m, kg m^2)")
        if np.min(np.linalg.eigvalsh(m)) <= 0.0:
            raise ValueError(f"{owner}.mass_matrix: expected positive definite (kg, kg m, kg m^2)")
        k = _matrix(owner, "stiffness", self.stiffness, (4, 4), "N/m, N/rad, N m/rad")
        f0 = _matrix(owner, "static_force", self.static_force, (4,), "N, N m")
        d = _matrix(owner, "linear_damping", self.linear_damping, (4, 4), "N s/m, N m s/rad")
        bq = _matrix(owner, "quadratic_damping", self.quadratic_damping, (3, 3), "N s^2/m^2")
        jh = _matrix(owner, "hub_lever", self.hub_lever, (4,), "-, -, m, -")
        jv = _matrix(owner, "hub_lever_vertical", self.hub_lever_vertical, (4,), "-, -, m, -")
        td = _matrix(owner, "tower_drag", self.tower_drag, (4,), "N per (m/s)^2")
        tdd = _matrix(owner, "tower_drag_damping", self.tower_drag_damping, (4, 4), "N s/m per m/s")
        tilt = float(self.shaft_tilt_rad)
        if not (math.isfinite(tilt) and abs(tilt) < 0.5):
            raise ValueError(f"{owner}.shaft_tilt_rad: expected |tilt| < 0.5 rad, got {tilt}")
        kap = float(self.tower_slope_per_m)
        if not math.isfinite(kap):
            raise ValueError(f"{owner}.tower_slope_per_m: expected a finite slope in rad/m")
        a = np.array(self.radiation_a, dtype=np.float64)
        nr = a.shape[0] if a.ndim == 2 else -1
        ra = _matrix(owner, "radiation_a", a, (nr, nr), "1/s")
        rb = _matrix(owner, "radiation_b", self.radiation_b, (nr, 3), "state per (m/s)")
        rc = _matrix(owner, "radiation_c", self.radiation_c, (3, nr), "N per state")
        if nr and np.max(np.linalg.eigvals(ra).real) >= 0.0:
            raise ValueError(f"{owner}.radiation_a: expected a stable matrix (eigenvalues < 0 1/s)")
        for name, val in (
            ("mass_matrix", m),
            ("stiffness", k),
            ("static_force", f0),
            ("linear_damping", d),
            ("quadratic_damping", bq),
            ("hub_lever", jh),
            ("hub_lever_vertical", jv),
            ("tower_drag", td),
            ("tower_drag_damping", tdd),
            ("radiation_a", ra),
            ("radiation_b", rb),
            ("radiation_c", rc),
        ):
            set_(self, name, val)
        locked = tuple(sorted({int(i) for i in self.locked_dofs}))
        if len(locked) != len(tuple(self.locked_dofs)) or any(not 0 <= i < N_DOF for i in locked):
            raise ValueError(
                f"{owner}.locked_dofs: expected distinct DOF indices in 0..{N_DOF - 1}, "
                f"got {self.locked_dofs}"
            )
        if len(locked) == N_DOF:
            raise ValueError(f"{owner}.locked_dofs: at least one DOF must be free")
        set_(self, "locked_dofs", locked)
        set_(self, "_minv", _tuple2(inverse_mass_matrix(m, locked)))
        set_(self, "_k", _tuple2(k))
        set_(self, "_d", _tuple2(d))
        set_(self, "_bq", _tuple2(bq))
        set_(self, "_f0", tuple(float(v) for v in f0))
        set_(self, "_jh", tuple(float(v) for v in jh))
        set_(self, "_jv", tuple(float(v) for v in jv))
        set_(self, "_tdrag", tuple(float(v) for v in td))
        set_(self, "_tdamp", _tuple2(tdd))
        set_(self, "shaft_tilt_rad", tilt)
        set_(self, "tower_slope_per_m", kap)
        # Rotor geometry: (τ, 1/cos τ, κ, Q_φ/T, Q_s/T), Q_φ/T = h cos τ + a sin τ (the thrust's
        # moment arm about the reference point), Q_s/T = J_h,s cos τ − J_v,s sin τ.
        ct, st = math.cos(tilt), math.sin(tilt)
        set_(
            self,
            "_rot",
            (tilt, 1.0 / ct, kap, float(jh[2] * ct - jv[2] * st), float(jh[3] * ct - jv[3] * st)),
        )
        block = np.zeros((nr + 3, nr + 3))
        block[:nr, :nr] = ra
        block[:nr, nr:] = rb
        block[nr:, :nr] = rc
        set_(self, "_rad", block)
        set_(self, "_step_cache", {})
        set_(self, "n_radiation", nr)
        blocks = _f_blocks(self, block)
        set_(self, "_blocks", blocks)
        set_(self, "_kern", _k.pack(blocks))

    @property
    def n_states(self) -> int:
        """Length of the state vector: 11 mechanical/turbine states + radiation states."""
        return N_MECH_STATES + self.n_radiation


def state_names(params: FloatingParams) -> list[str]:
    """Names (with units) of the state vector entries, in order."""
    names = [f"{d}_{u}" for d, u in zip(DOF_NAMES, ("m", "m", "rad", "m"), strict=True)]
    names += [
        f"{d}_rate_{u}" for d, u in zip(DOF_NAMES, ("m_s", "m_s", "rad_s", "m_s"), strict=True)
    ]
    names += ["rotor_speed_rad_s", "blade_pitch_rad", "generator_torque_nm"]
    names += [f"radiation_{i}" for i in range(params.n_radiation)]
    return names


def relative_wind(
    x: tuple[float, ...] | FloatArray, wind_m_s: float, params: FloatingParams
) -> float:
    """Rotor-normal wind relative to the moving hub, in the units of the Cp/Ct/Cq table (m/s).

    U_rel = [(U − J_h·q̇) cos ψ + (J_v·q̇) sin ψ] / cos τ,  ψ = τ + φ + κ s,

    the component of the relative air velocity along the shaft (tilted by ψ from the horizontal,
    upwind end up), divided by cos τ because the table's coefficients are referred to the
    horizontal wind on the rotor at its own tilt τ (so U_rel = U at rest).
    """
    jh = params._jh
    jv = params._jv
    tilt, ict, kap, _, _ = params._rot
    psi = tilt + x[2] + kap * x[3]
    vx = x[4] + jh[2] * x[6] + jh[3] * x[7]
    vz = x[5] + jv[2] * x[6] + jv[3] * x[7]
    return ((wind_m_s - vx) * math.cos(psi) + vz * math.sin(psi)) * ict


def rotor_thrust(
    rotor_speed_rad_s: float, pitch_rad: float, wind_rel_m_s: float, tp: TurbineParams
) -> float:
    """Quasi-steady thrust T = ½ρπR² U_rel² Ct(λ, θ), λ = ωR/U_rel (N); 0 for U_rel <= 0."""
    if wind_rel_m_s <= WIND_MIN_M_S:
        return 0.0
    tsr = (rotor_speed_rad_s if rotor_speed_rad_s > 0.0 else 0.0) * tp.rotor_radius_m / wind_rel_m_s
    ct = tp.table.coefficients(tsr, pitch_rad)[1]
    return tp.k_thrust * wind_rel_m_s * wind_rel_m_s * ct


def _f_blocks(p: FloatingParams, block: FloatArray) -> list[FloatArray]:
    """Blocks of the packed constants (:mod:`plant._kernels`, ``B_*``) that :func:`f` uses:
    FP, mooring knots and segments (n, 14), the radiation block [[A, B], [C, 0]] transposed,
    the Cp/Ct/Cq grids and cells; the step's blocks empty."""
    tp = p.turbine
    fp = np.zeros(_k.F_SIZE)
    fp[_k.F_F0 : _k.F_F0 + 4] = p.static_force
    fp[_k.F_K : _k.F_K + 16] = p.stiffness.ravel()
    fp[_k.F_D : _k.F_D + 16] = p.linear_damping.ravel()
    fp[_k.F_BQ : _k.F_BQ + 9] = p.quadratic_damping.ravel()
    fp[_k.F_JH : _k.F_JH + 4] = p._jh
    fp[_k.F_JV : _k.F_JV + 4] = p._jv
    fp[_k.F_ROT : _k.F_ROT + 5] = p._rot
    fp[_k.F_TC : _k.F_TC + 4] = p._tdrag
    fp[_k.F_TD : _k.F_TD + 16] = np.array(p._tdamp).ravel()
    fp[_k.F_MI : _k.F_MI + 16] = np.array(p._minv).ravel()
    fp[_k.F_TB : _k.F_TB + 13] = (
        tp.rotor_radius_m,
        tp.k_thrust,
        tp.k_torque,
        tp.gearbox_ratio,
        tp.inv_inertia,
        tp.pitch_min_rad,
        tp.pitch_max_rad,
        tp.inv_pitch_tau,
        tp.pitch_rate_max_rad_s,
        tp.torque_max_nm,
        tp.inv_torque_tau,
        tp.torque_rate_max_nm_s,
        1.0 if p.aero else 0.0,
    )
    tab = p.mooring
    table = tp.table
    blocks = [np.zeros(0)] * _k.N_BLOCKS
    blocks[_k.B_KNOTS] = np.array(tab._x, dtype=np.float64)
    blocks[_k.B_XS] = table._tsr_array
    blocks[_k.B_YS] = table._pitch_array
    blocks[_k.B_CELLS] = table._cell_array
    blocks[_k.B_FP] = fp
    blocks[_k.B_SEG14] = np.array(tab._seg, dtype=np.float64)
    blocks[_k.B_RADT] = np.array(block, dtype=np.float64).T
    blocks[_k.B_LOADS] = np.zeros(8)
    return blocks


def f(
    t: float, x: tuple[float, ...], u: tuple[float, ...], params: FloatingParams
) -> tuple[float, ...]:
    """Time derivative of the floating-turbine state (equations in the module docstring).

    (M_s + A_∞) q̈ = F_0 − K q + F_m(q) − D q̇ − B_q(v∘|v|) − C_r ξ + Q_T T(U_rel) + F_t + F^w;
    dξ/dt = A_r ξ + B_r v; rotor states from :func:`plant.turbine.f` at U_rel = U − J_h·q̇.
    Computed by the compiled :func:`plant._kernels.floating_f` (one Cp/Ct/Cq cell look-up
    for thrust and torque, mooring of :func:`mooring_force`).

    Parameters
    ----------
    t : float
        Time (s); unused (time-invariant), kept for the ``f(t, x, u, p)`` form.
    x : sequence of float, length ``params.n_states``
        (surge m, heave m, pitch rad, tower-top m, their rates, ω rad/s, θ rad, T_g N m,
        radiation states).
    u : sequence of float, length 6
        (θ_c rad, T_c N m, U m/s, wave surge force N, wave heave force N, wave pitch moment N m).
    params : FloatingParams

    Returns
    -------
    tuple of float
        dx/dt, same length as ``x``.
    """
    xa = np.array(x, dtype=np.float64)
    if xa.shape != (params.n_states,):
        raise ValueError(f"f: expected {params.n_states} states, got shape {xa.shape}")
    ua = np.array(u, dtype=np.float64)
    if ua.shape != (6,):
        raise ValueError(f"f: expected 6 inputs, got shape {ua.shape}")
    out = np.empty_like(xa)
    c, o = params._kern
    _k.floating_f(xa, ua, c, o, out)
    return tuple(out.tolist())


def _radiation_step_matrices(
    p: FloatingParams, h: float, minv: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Exact first-order-hold discretisation of the radiation block, mapped onto accelerations.

    With Φ = e^{Ah}, Γ0 = ∫₀ʰ e^{A(h−τ)} dτ B and Γ1 = ∫₀ʰ e^{A(h−τ)} (τ/h) dτ B (one matrix
    exponential of [[A h, B h, 0], [0, 0, I], [0, 0, 0]], Van Loan), a velocity varying linearly
    from v0 to v1 over the step gives ξ1 = Φ ξ0 + (Γ0 − Γ1) v0 + Γ1 v1. Returned:

    * ``end`` (n + 8, n + 6) on (ξ0, v0, v1): rows ξ1, then a_μ = −M⁻¹[:, :3] C ξ1 and
      a_r = −M⁻¹[:, :3] (C A ξ1 + C B v1), the acceleration due to μ and its rate at the start
      of the next step;
    * ``start`` (8, 11 + n) on the whole state x: (a_μ, a_r) of the current step (used when the
      state was not produced by the previous call).
    """
    import scipy.linalg  # noqa: PLC0415  once per (params, h)

    a, b, c = p.radiation_a, p.radiation_b, p.radiation_c
    n = a.shape[0]
    blk = np.zeros((n + 6, n + 6))
    blk[:n, :n] = a * h
    blk[:n, n : n + 3] = b * h
    blk[n : n + 3, n + 3 :] = np.eye(3)
    e = scipy.linalg.expm(blk)
    phi, g0, g1 = e[:n, :n], e[:n, n : n + 3], e[:n, n + 3 :]
    mi3 = minv[:, :3]
    xi1 = np.zeros((n, n + 6))
    xi1[:, :n] = phi
    xi1[:, n : n + 3] = g0 - g1
    xi1[:, n + 3 :] = g1
    end = np.zeros((n + 8, n + 6))
    end[:n] = xi1
    end[n : n + 4] = -mi3 @ c @ xi1
    end[n + 4 :] = -mi3 @ c @ a @ xi1
    end[n + 4 :, n + 3 :] -= mi3 @ c @ b
    m = N_MECH_STATES
    start = np.zeros((8, m + n))
    start[:4, m:] = -mi3 @ c
    start[4:, m:] = -mi3 @ c @ a
    start[4:, 4:7] = -mi3 @ c @ b
    return end, start


def _mooring_segments(
    p: FloatingParams, minv: FloatArray
) -> tuple[list[float], list[tuple[float, ...]]]:
    """Per mooring-table segment: (lo, hi, M⁻¹(L_m − K) row-major 16, M⁻¹(F_0 + F_m,c) 4,
    x_i, k_zz', k_zφ', k_φφ').

    Inside a segment the mooring force is affine in q with K_zφ at the segment's start x_i
    (:func:`mooring_force`): F_m = F_m,c + L_m q with
    L_m = [[F_x', F_z', M'], [F_z', −k_zz,i, −k_zφ,i], [M', −k_zφ,i, −k_φφ,i]] (padded to 4x4), so
    mooring, stiffness and static force fold into one affine map per segment; the terms of the
    offset-dependent K_zφ(x) (k' (x − x_i) (z, φ) and the surge force −½ (z, φ) K' (z, φ)ᵀ) are
    added per stage. The first and last segments extend to ∓∞ (linear extrapolation, as the
    table).
    """
    tab = p.mooring
    knots = tab._x
    nseg = len(tab._seg)
    out: list[tuple[float, ...]] = []
    for i, (x0, fx0, dfx, fz0, dfz, my0, dmy, _, kzz, dkzz, kzp, dkzp, kpp, dkpp) in enumerate(
        tab._seg
    ):
        lm = np.zeros((4, 4))
        lm[:3, :3] = [[dfx, dfz, dmy], [dfz, -kzz, -kzp], [dmy, -kzp, -kpp]]
        fc = np.array([fx0 - dfx * x0, fz0 - dfz * x0, my0 - dmy * x0, 0.0])
        kt = minv @ (lm - p.stiffness)
        ct = minv @ (p.static_force + fc)
        lo = -math.inf if i == 0 else knots[i]
        hi = math.inf if i == nseg - 1 else knots[i + 1]
        out.append((lo, hi, *kt.ravel().tolist(), *ct.tolist(), x0, dkzz, dkzp, dkpp))
    return knots, out


class _Stepper:
    """The RK4 + exact-radiation step of :func:`step_floating` for one (params, h).

    Every constant is computed here once (:func:`step_blocks`): M⁻¹ folded into the
    stiffness (with the mooring, per table segment), damping, drag, hub lever and wave-force
    maps; the step itself is the compiled :func:`plant._kernels.floating_step`. The radiation
    update also yields the radiation accelerations of the next step, reused when the next
    call continues from this call's result (the same tuple object).
    """

    def __init__(self, p: FloatingParams, h: float) -> None:
        self.consts = _k.pack(step_blocks(p, h))
        self.n_states = p.n_states
        self.z = np.zeros(p.n_radiation + 8)
        self.out = np.empty(p.n_states)
        self.work = np.empty(56)
        self.last: object = None

    def __call__(self, x: Sequence[float], u: Sequence[float]) -> tuple[float, ...]:
        xa = np.array(x, dtype=np.float64)
        if xa.shape != (self.n_states,):
            raise ValueError(f"step_floating: expected {self.n_states} states, got {xa.shape}")
        use_last = x is self.last
        c, o = self.consts
        ua = np.array(u, dtype=np.float64)
        if ua.shape != (6,):
            raise ValueError(f"step_floating: expected 6 inputs, got shape {ua.shape}")
        _k.floating_step(xa, ua, self.out, self.z, use_last, c, o, self.work)
        y = tuple(self.out.tolist())
        self.last = y
        return y


def step_blocks(p: FloatingParams, h: float) -> list[FloatArray]:
    """Blocks of the packed constants of :func:`plant._kernels.floating_step` for (params, h).

    Those of :func:`f` with SP, the mooring segments (n, 26) and the radiation ``end`` and
    ``start`` (transposed), SP laid out as in :mod:`plant._kernels`: M⁻¹ folded into the wave
    force (W = M⁻¹[:, :3]), damping (−M⁻¹D), tower drag (M⁻¹c_t, −M⁻¹D_t), quadratic drag
    (−M⁻¹[:, :3]B_q) and the thrust's pitch/tower moment arms (J).
    """
    if not (h > 0.0 and math.isfinite(h)):
        raise ValueError(f"step_floating: h must be > 0 s, got {h}")
    minv: FloatArray = np.array(p._minv, dtype=np.float64)  # with locked DOFs zeroed
    tp = p.turbine
    aero = p.aero
    tilt, ict, kap, arm_p, arm_s = p._rot
    sp = np.zeros(_k.S_SIZE)
    sp[:20] = (
        h,
        tilt,
        ict if aero else 0.0,  # aero off: no wind into the rotor (as f)
        kap,
        tp.rotor_radius_m,
        tp.k_thrust,
        tp.k_torque * tp.inv_inertia,
        tp.gearbox_ratio * tp.inv_inertia,
        tp.pitch_min_rad,
        tp.pitch_max_rad,
        tp.inv_pitch_tau,
        tp.pitch_rate_max_rad_s,
        tp.torque_max_nm,
        tp.inv_torque_tau,
        tp.torque_rate_max_nm_s,
        p._jh[2],
        p._jh[3],
        p._jv[2],
        p._jv[3],
        1.0 if aero else 0.0,
    )
    sp[_k.S_W : _k.S_W + 12] = minv[:, :3].ravel()
    sp[_k.S_D : _k.S_D + 16] = (-minv @ p.linear_damping).ravel()
    sp[_k.S_TC : _k.S_TC + 4] = minv @ p.tower_drag
    sp[_k.S_TD : _k.S_TD + 16] = (-minv @ p.tower_drag_damping).ravel()
    sp[_k.S_E : _k.S_E + 12] = (-minv[:, :3] @ p.quadratic_damping).ravel()
    sp[_k.S_J : _k.S_J + 4] = minv[:, 2] * arm_p + minv[:, 3] * arm_s
    knots, segs = _mooring_segments(p, minv)
    seg_array = np.array(segs, dtype=np.float64).reshape(len(segs), 26)
    if p.n_radiation:
        end, start = _radiation_step_matrices(p, h, minv)
    else:
        end, start = np.zeros((8, 6)), np.zeros((8, N_MECH_STATES))
    blocks = list(p._blocks)
    blocks[_k.B_SP] = sp
    blocks[_k.B_KNOTS] = np.array(knots, dtype=np.float64)
    blocks[_k.B_SEG26] = seg_array
    blocks[_k.B_ENDT] = end.T
    blocks[_k.B_STARTT] = start.T
    return blocks


def step_floating(
    t: float, x: Sequence[float], u: Sequence[float], h: float, params: FloatingParams
) -> tuple[float, ...]:
    """Advance the floating turbine by one step ``h`` (s) with the input ``u`` held.

    The integrator the simulator should use (pure: no clock, no I/O; the caches below change
    only the cost, not the result). The state is split into the 11 mechanical + rotor states y
    and the linear radiation states ξ:

    1. Radiation force over the step, from the state at t: μ(t + τ) ≈ μ0 + τ μ̇0 with
       μ0 = C ξ0 and μ̇0 = C (A ξ0 + B v0) (v = surge, heave, pitch rates).
    2. y by classic RK4 of the mechanical part of :func:`f` with that μ (inputs held).
    3. ξ exactly for a velocity that varies linearly over the step (first-order hold between
       v0 and v1 = v(t + h)):

           ξ1 = Φ ξ0 + Γ0 v0 + Γ1 (v1 − v0),  Φ = e^{Ah},  Γ0 = ∫₀ʰ e^{A(h−τ)} dτ B,
           Γ1 = ∫₀ʰ e^{A(h−τ)} (τ/h) dτ B,

       all from one matrix exponential of [[A h, B h, 0], [0, 0, I], [0, 0, 0]] (Van Loan).

    Without radiation states this is plain RK4 of :func:`f`. The split removes the radiation
    states from the four RK4 stages and is exact for the linear block, so stiff radiation poles
    never limit the step.

    Cost: the constants are built once per (params, h) (:class:`_Stepper`, cached on the
    params) and the step is the compiled :func:`plant._kernels.floating_step`, whose radiation
    update also gives the next step's μ0, μ̇0 (reused when ``x`` is the tuple the previous
    call returned). About 6 µs per call on the 2-vCPU bench machine with 34 radiation states,
    most of it the conversion of the tuples.

    Parameters
    ----------
    t : float
        Time at the start of the step (s); unused (time-invariant).
    x : sequence of float, length ``params.n_states``
        State at t (layout of :func:`f`).
    u : sequence of float, length 6
        Input held over the step (layout of :func:`f`).
    h : float
        Step (s), > 0.
    params : FloatingParams

    Returns
    -------
    tuple of float
        State at t + h.
    """
    stepper = params._step_cache.get(h)
    if stepper is None:
        if len(params._step_cache) >= 8:
            params._step_cache.clear()
        stepper = params._step_cache[h] = _Stepper(params, h)
    return stepper(x, u)


def energy(x: tuple[float, ...] | FloatArray, params: FloatingParams) -> float:
    """Mechanical energy of the conservative part (J).

    E = ½ q̇ᵀ(M_s + A_∞)q̇ + ½ qᵀKq − F_0ᵀq + V_m(q) + ½ J ω². Conserved by :func:`f` when
    damping, drag, radiation, aero (U = 0), generator torque and waves are off (see
    :func:`conservative`).
    """
    q = np.array([float(v) for v in x[:4]])
    v = np.array([float(v) for v in x[4:8]])
    p = params
    kin = 0.5 * float(v @ p.mass_matrix @ v)
    pot = 0.5 * float(q @ p.stiffness @ q) - float(p.static_force @ q)
    pot += _mooring_potential(p.mooring, float(q[0]), float(q[1]), float(q[2]))
    rot = 0.5 * p.turbine.drivetrain_inertia_kg_m2 * float(x[8]) ** 2
    return kin + pot + rot


def conservative(params: FloatingParams) -> FloatingParams:
    """Copy without linear damping, quadratic drag, radiation memory and rotor loads."""
    return replace(
        params,
        name=params.name + " (conservative)",
        linear_damping=np.zeros((4, 4)),
        quadratic_damping=np.zeros((3, 3)),
        radiation_a=np.zeros((0, 0)),
        radiation_b=np.zeros((0, 3)),
        radiation_c=np.zeros((3, 0)),
        aero=False,
    )


# ====================================================================== presets (offline)
class FloatingPreset(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """Physical description of a floating turbine as a preset TOML holds it (SI, keys with units).

    Heights are above the still-water line (the platform reference point); RNA positions are
    relative to the tower top (x downwind, z up). See ``plant/presets/README.md`` for sources.
    """

    name: str
    turbine: str
    hydro_file: str
    mooring_file: str
    gravity_m_s2: float
    water_density_kg_m3: float
    water_depth_m: float
    displaced_volume_m3: float
    platform_mass_kg: float
    platform_pitch_inertia_kg_m2: float
    platform_cm_x_m: float
    platform_cm_z_m: float
    tower_base_height_m: float
    tower_top_height_m: float
    tower_height_fraction: list[float]
    tower_mass_density_kg_m: list[float]
    tower_fore_aft_stiffness_n_m2: list[float]
    tower_mode_shape_coefficients: list[float]
    tower_damping_ratio: float
    yaw_bearing_mass_kg: float
    nacelle_mass_kg: float
    nacelle_cm_x_m: float
    nacelle_cm_z_m: float
    hub_mass_kg: float
    rotor_apex_x_m: float
    rotor_apex_z_m: float
    blade_count: int
    blade_mass_kg: float
    blade_cm_axial_m: float
    blade_second_moment_kg_m2: float
    #: Rotor shaft tilt, upwind end up (rad): −ElastoDyn ``ShftTilt``. The Cp/Ct/Cq table is
    #: referred to the horizontal wind at this tilt; platform pitch adds to it (plant.platform).
    shaft_tilt_rad: float = 0.0
    #: Tower aerodynamic drag (AeroDyn tower table): heights above SWL (m), diameters (m) and
    #: drag coefficients (-) at stations; empty: no tower drag.
    tower_drag_height_m: list[float] = []
    tower_drag_diameter_m: list[float] = []
    tower_drag_coefficient: list[float] = []
    #: Power-law exponent α of the mean wind over height, U(z) = U_hub (z/h_hub)^α (InflowWind
    #: ``PLexp``), for the tower drag.
    wind_shear_exponent: float = 0.0
    additional_force_n: list[float]
    additional_linear_stiffness: list[list[float]]
    additional_linear_damping: list[list[float]]
    additional_quadratic_damping: list[list[float]]
    #: HydroDyn strip-theory members (``PropPot = FALSE``, not in the WAMIT data), 6-vector and
    #: 6x6 in WAMIT DOF order about the reference point: static buoyancy load (N, N m),
    #: hydrostatic restoring (``.hst`` convention) and transverse Morison added mass
    #: (:func:`plant.openfast_import.read_morison_members`); empty: none.
    member_force_n: list[float] = []
    member_stiffness: list[list[float]] = []
    member_added_mass: list[list[float]] = []
    radiation_max_order: int = 8
    radiation_tolerance: float = 0.02
    radiation_omega_max_rad_s: float = 0.0
    #: Shipped radiation state space (:class:`plant.hydro.radiation.RadiationModel` npz);
    #: empty: fit the kernels when loading (slow, 0.3-0.6 s).
    radiation_file: str = ""
    #: Structural DOFs held fixed (names of :data:`DOF_NAMES`), e.g. ``["heave", "pitch",
    #: "tower_fore_aft"]`` for a surge + rotor model (:attr:`FloatingParams.locked_dofs`).
    #: The hydrodynamic data and radiation model may then omit the locked platform DOFs.
    locked_dofs: list[str] = []

    def radiation_fit_options(self) -> RadiationFitOptions:
        """Keyword arguments of the radiation fits of this preset (surge, heave and pitch).

        For :func:`plant.hydro.radiation.fit_radiation` and
        :func:`plant.hydro.radiation.fit_reduced_radiation`: ``radiation_max_order``,
        ``radiation_tolerance`` and the band up to ``radiation_omega_max_rad_s`` (0: the whole
        band of the data).
        """
        band = None
        if self.radiation_omega_max_rad_s > 0.0:
            band = (0.0, self.radiation_omega_max_rad_s)
        return {
            "dofs": (0, 2, 4),
            "max_order": self.radiation_max_order,
            "tol": self.radiation_tolerance,
            "omega_range_rad_s": band,
        }


class RadiationFitOptions(TypedDict):
    """What :meth:`FloatingPreset.radiation_fit_options` returns."""

    dofs: tuple[int, int, int]
    max_order: int
    tol: float
    omega_range_rad_s: tuple[float, float] | None


class MooringFile(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """Mooring data file (JSON): quasi-static tables of :class:`MooringTable`, and their source."""

    source: str
    surge_m: list[float]
    force_surge_n: list[float]
    force_heave_n: list[float]
    moment_pitch_nm: list[float]
    stiffness_heave_pitch: list[list[float]]
    stiffness_6x6_at_zero: list[list[float]]
    #: K_zφ(x) (2x2 per surge offset of ``surge_m``); empty: ``stiffness_heave_pitch`` everywhere.
    stiffness_heave_pitch_by_surge: list[list[list[float]]] = []
    lines: list[dict[str, float | str]] = []


@dataclass(frozen=True)
class TowerModal:
    """First fore-aft tower mode integrals (SI), see :func:`tower_modal`.

    Attributes
    ----------
    tower_mass_kg, modal_mass_kg, modal_stiffness_elastic_n_m, modal_stiffness_gravity_n_m,
    first_moment_kg_m (∫ψ dm), height_moment_kg_m (∫h ψ dm), tower_cm_height_m,
    tower_height_inertia_kg_m2 (∫h² dm), slope_per_m (κ = ψ'(1)/L, rad per m of s),
    slope_integral_per_m (∫ψ'² dh, 1/m), fixed_base_frequency_hz.
    """

    tower_mass_kg: float
    modal_mass_kg: float
    modal_stiffness_elastic_n_m: float
    modal_stiffness_gravity_n_m: float
    first_moment_kg_m: float
    height_moment_kg_m: float
    tower_cm_height_m: float
    tower_height_inertia_kg_m2: float
    slope_per_m: float
    slope_integral_per_m: float
    rna_mass_kg: float
    fixed_base_frequency_hz: float


def _rna_points(p: FloatingPreset) -> list[tuple[float, float, float, float]]:
    """RNA masses as (m kg, a m, c m, I_y kg m²) relative to the tower top."""
    blades = p.blade_count * p.blade_mass_kg
    # Rotor inertia about the lateral axis through the apex: half the polar inertia of the blades
    # (n ∫r² dm / 2 for n >= 3 equally spaced blades).
    i_rotor = 0.5 * p.blade_count * p.blade_second_moment_kg_m2
    return [
        (p.yaw_bearing_mass_kg, 0.0, 0.0, 0.0),
        (p.nacelle_mass_kg, p.nacelle_cm_x_m, p.nacelle_cm_z_m, 0.0),
        (p.hub_mass_kg, p.rotor_apex_x_m, p.rotor_apex_z_m, 0.0),
        (blades, p.rotor_apex_x_m + p.blade_cm_axial_m, p.rotor_apex_z_m, i_rotor),
    ]


def tower_modal(p: FloatingPreset, n_points: int = 401) -> TowerModal:
    """Generalised mass and stiffness of the first fore-aft tower mode (Rayleigh-Ritz).

    Mode shape ψ(η) = Σ_k c_k η^k (k = 2..6, ElastoDyn ``TwFAM1Sh``), η = (h − h_b)/L, normalised
    so ψ(1) = 1 and s is the tower-top displacement. With μ(h) the mass density and EI(h) the
    fore-aft bending stiffness, linearly interpolated between the stations, trapezoidal rule on
    ``n_points`` nodes:

        m_t = ∫ μ ψ² dh + m_RNA   (fixed-base modal mass incl. the RNA as a tower-top point mass)
        k_e = ∫ EI (ψ'')² dh,   k_g = −g ∫ (N(h) + m_RNA) ψ'² dh,  N(h) = ∫_h^top μ dh'
        f_fb = √((k_e + k_g)/m_t) / 2π   (fixed-base frequency, as ElastoDyn forms it)
    """
    L = p.tower_top_height_m - p.tower_base_height_m
    eta = np.linspace(0.0, 1.0, n_points)
    h = p.tower_base_height_m + L * eta
    mu = np.interp(eta, p.tower_height_fraction, p.tower_mass_density_kg_m)
    ei = np.interp(eta, p.tower_height_fraction, p.tower_fore_aft_stiffness_n_m2)
    c = p.tower_mode_shape_coefficients
    zero = np.zeros_like(eta)
    psi = zero + sum(ck * eta ** (k + 2) for k, ck in enumerate(c))
    d1 = (zero + sum((k + 2) * ck * eta ** (k + 1) for k, ck in enumerate(c))) / L
    d2 = (zero + sum((k + 2) * (k + 1) * ck * eta**k for k, ck in enumerate(c))) / L**2
    trap = np.trapezoid
    m_tower = float(trap(mu, h))
    above = m_tower - np.concatenate([[0.0], np.cumsum(0.5 * (mu[1:] + mu[:-1]) * np.diff(h))])
    m_rna = sum(m for m, *_ in _rna_points(p))
    g = p.gravity_m_s2
    modal_mass = float(trap(mu * psi**2, h)) + m_rna
    k_e = float(trap(ei * d2**2, h))
    k_g = -g * float(trap((above + m_rna) * d1**2, h))
    return TowerModal(
        tower_mass_kg=m_tower,
        modal_mass_kg=modal_mass,
        modal_stiffness_elastic_n_m=k_e,
        modal_stiffness_gravity_n_m=k_g,
        first_moment_kg_m=float(trap(mu * psi, h)),
        height_moment_kg_m=float(trap(mu * psi * h, h)),
        tower_cm_height_m=float(trap(mu * h, h)) / m_tower,
        tower_height_inertia_kg_m2=float(trap(mu * h * h, h)),
        slope_per_m=float(d1[-1]),
        slope_integral_per_m=float(trap(d1**2, h)),
        rna_mass_kg=m_rna,
        fixed_base_frequency_hz=math.sqrt(max(k_e + k_g, 0.0) / modal_mass) / (2.0 * math.pi),
    )


@dataclass(frozen=True)
class StructuralMatrices:
    """Structural mass, gravity/elastic stiffness, static force and hub lever (no hydro, mooring).

    Units as in :class:`FloatingParams`; ``tower_damping`` is the tower modal damping (N s/m).
    """

    mass: FloatArray
    stiffness: FloatArray
    static_force: FloatArray
    hub_lever: FloatArray
    tower_damping_n_s_m: float
    total_mass_kg: float
    modal: TowerModal
    hub_lever_vertical: FloatArray


def structural_matrices(p: FloatingPreset) -> StructuralMatrices:
    """Assemble M_s, the gravity + tower stiffness and the static weight forces (module docstring).

    Each mass element contributes m (J_xᵀJ_x + J_zᵀJ_z) + I J_rᵀJ_r to M_s and, from the
    second-order expansion of m g Z, −m g h_e to K_φφ (h_e the element height above the
    reference point), with the tower/pitch coupling −g ∫ψ dm − g Σ m_RNA (1 + c κ), the tower
    softening of :func:`tower_modal` and −m g c κ² of the RNA; F_0 gets −m g (heave) and
    m g a (pitch, and m g a κ on the tower DOF) for masses at a ≠ 0 downwind of the tower axis.
    """
    tm = tower_modal(p)
    g = p.gravity_m_s2
    ht = p.tower_top_height_m
    kap = tm.slope_per_m
    M = np.zeros((4, 4))
    K = np.zeros((4, 4))
    F = np.zeros(4)

    def add_point(m: float, a: float, h: float, sx: float, sr: float, inertia: float) -> None:
        jx = np.array([1.0, 0.0, h, sx])
        jz = np.array([0.0, 1.0, -a, -a * sr])
        jr = np.array([0.0, 0.0, 1.0, sr])
        M[:, :] += m * (np.outer(jx, jx) + np.outer(jz, jz)) + inertia * np.outer(jr, jr)

    # Platform rigid body (inertia given about its own CM).
    mp, xp, zp = p.platform_mass_kg, p.platform_cm_x_m, p.platform_cm_z_m
    add_point(mp, xp, zp, 0.0, 0.0, p.platform_pitch_inertia_kg_m2)
    K[2, 2] += -mp * g * zp
    F[1] -= mp * g
    F[2] += mp * g * xp
    # Tower (on the axis a = 0): integrals of tower_modal.
    mt = tm.tower_mass_kg
    M[0, 0] += mt
    M[1, 1] += mt
    M[0, 2] += mt * tm.tower_cm_height_m
    M[2, 2] += tm.tower_height_inertia_kg_m2
    M[0, 3] += tm.first_moment_kg_m
    M[2, 3] += tm.height_moment_kg_m
    M[3, 3] += tm.modal_mass_kg - tm.rna_mass_kg
    M[2, 0] = M[0, 2]
    M[3, 0] = M[0, 3]
    M[3, 2] = M[2, 3]
    K[2, 2] += -g * mt * tm.tower_cm_height_m
    K[2, 3] += -g * tm.first_moment_kg_m
    K[3, 3] += tm.modal_stiffness_elastic_n_m + tm.modal_stiffness_gravity_n_m
    F[1] -= mt * g
    # RNA: the tower-top point masses (the RNA share of the tower softening is in tower_modal).
    for m, a, c, inertia in _rna_points(p):
        add_point(m, a, ht + c, 1.0 + c * kap, kap, inertia)
        K[2, 2] += -m * g * (ht + c)
        K[2, 3] += -m * g * (1.0 + c * kap)
        K[3, 3] += -m * g * c * kap * kap
        F[1] -= m * g
        F[2] += m * g * a
        F[3] += m * g * a * kap
    K[3, 2] = K[2, 3]
    k_fb = tm.modal_stiffness_elastic_n_m + tm.modal_stiffness_gravity_n_m
    c_tower = 2.0 * p.tower_damping_ratio * math.sqrt(max(k_fb, 0.0) * tm.modal_mass_kg)
    hub_lever = np.array([1.0, 0.0, ht + p.rotor_apex_z_m, 1.0 + p.rotor_apex_z_m * kap])
    hub_lever_vertical = np.array([0.0, 1.0, -p.rotor_apex_x_m, -p.rotor_apex_x_m * kap])
    total = mp + mt + tm.rna_mass_kg
    return StructuralMatrices(M, K, F, hub_lever, c_tower, total, tm, hub_lever_vertical)


def tower_drag_matrices(
    p: FloatingPreset, air_density_kg_m3: float, n_points: int = 401
) -> tuple[FloatArray, FloatArray]:
    """Generalised tower drag c_t (4,) and its velocity derivative D_t (4, 4) (FloatingParams).

    With C_d(z), D(z) interpolated linearly between the preset's stations, the mean wind
    U(z) = U_hub (z/h_hub)^α, and J(z) = (1, 0, z, ψ(η)) the horizontal velocity of the tower
    section at height z per DOF rate (ψ the tower mode shape, η = (z − h_b)/L, 0 below the
    base), the drag ½ρ C_d D (U(z) − v)|U(z) − v| dz of each section expanded to first order in
    v = J·q̇ gives (trapezoidal rule on ``n_points``)

        c_t = ½ρ ∫ C_d D (z/h_hub)^{2α} J dz,   D_t = ρ ∫ C_d D (z/h_hub)^α J Jᵀ dz.

    Both are zero without a tower drag table.
    """
    zs = np.asarray(p.tower_drag_height_m, dtype=np.float64)
    if zs.size == 0:
        return np.zeros(4), np.zeros((4, 4))
    ds = np.asarray(p.tower_drag_diameter_m, dtype=np.float64)
    cds = np.asarray(p.tower_drag_coefficient, dtype=np.float64)
    if not (zs.size >= 2 and ds.shape == zs.shape and cds.shape == zs.shape):
        raise ValueError(
            "tower_drag_height_m, tower_drag_diameter_m, tower_drag_coefficient: expected lists "
            "of the same length >= 2 (m, m, -)"
        )
    if not (np.all(np.diff(zs) > 0.0) and zs[0] > 0.0 and np.all(ds >= 0.0) and np.all(cds >= 0)):
        raise ValueError(
            "tower_drag_height_m: expected increasing heights above the water line (m), "
            "with diameters (m) and drag coefficients (-) >= 0"
        )
    z = np.linspace(float(zs[0]), float(zs[-1]), n_points)
    width = np.interp(z, zs, ds) * np.interp(z, zs, cds)
    hub = p.tower_top_height_m + p.rotor_apex_z_m
    prof = (z / hub) ** p.wind_shear_exponent
    length = p.tower_top_height_m - p.tower_base_height_m
    eta = np.clip((z - p.tower_base_height_m) / length, 0.0, 1.0)
    psi = sum(ck * eta ** (k + 2) for k, ck in enumerate(p.tower_mode_shape_coefficients))
    jac = np.stack([np.ones_like(z), np.zeros_like(z), z, psi + np.zeros_like(z)])
    rho = air_density_kg_m3
    c = 0.5 * rho * np.asarray(np.trapezoid(width * prof**2 * jac, z, axis=1), dtype=np.float64)
    d = rho * np.asarray(
        np.trapezoid(width * prof * jac[:, None, :] * jac[None, :, :], z, axis=2), dtype=np.float64
    )
    return c, d


def _resolve(base: Path | None, name: str) -> Path | Traversable:
    if base is None or name.startswith(_PRESET_PREFIX):
        return resources.files(_PRESET_PACKAGE).joinpath(
            *name.removeprefix(_PRESET_PREFIX).split("/")
        )
    return base / name


_PRESET_PACKAGE = "plant.presets"
_PRESET_PREFIX = "preset:"
_FLOATING_PRESETS = ("iea15mw_volturnus", "nrel5mw_tlp", "nrel5mw_oc3_hywind")


def read_floating_preset(name_or_path: str | Path) -> tuple[FloatingPreset, Path | None, str]:
    """Decode a floating preset TOML: (preset, folder for relative files or None, source text)."""
    key = str(name_or_path)
    if not isinstance(name_or_path, Path) and key in _FLOATING_PRESETS:
        data = resources.files(_PRESET_PACKAGE).joinpath("floating", f"{key}.toml").read_bytes()
        base: Path | None = None
        source = f"floating preset {key!r}"
    elif isinstance(name_or_path, Path) or "/" in key or key.endswith(".toml"):
        path = Path(name_or_path)
        data = path.read_bytes()
        base = path.parent
        source = str(path)
    else:
        raise ValueError(
            f"unknown floating preset {key!r}; shipped: {', '.join(_FLOATING_PRESETS)} "
            "(or give a path to a .toml file)"
        )
    try:
        return msgspec.toml.decode(data, type=FloatingPreset), base, source
    except (msgspec.ValidationError, msgspec.DecodeError) as exc:
        raise ValueError(f"{source}: {exc}") from exc


def read_mooring_file(path: Path | Traversable) -> MooringFile:
    """Decode a mooring JSON file written by :func:`plant.openfast_import.write_preset`."""
    try:
        return msgspec.json.decode(path.read_bytes(), type=MooringFile)
    except (msgspec.ValidationError, msgspec.DecodeError) as exc:
        raise ValueError(f"{path}: {exc}") from exc


def build_floating_params(
    preset: FloatingPreset,
    turbine: TurbineParams,
    hydro: HydroData,
    mooring: MooringFile,
    radiation: RadiationSS | RadiationModel | None,
) -> FloatingParams:
    """Assemble :class:`FloatingParams` from a preset, its hydro data, mooring and radiation fit.

    M = M_s + A_∞[surge, heave, pitch] + A_members; K = K_s + C_hst + C_add + C_members;
    F_0 = F_s + ρ g V₀ e_z + F_add + F_members (strip-theory members' buoyancy);
    D = B_add (platform block) + tower modal damping; B_q = AddBQuad (platform block).
    With ``preset.locked_dofs``, the hydrodynamic data and the radiation model may lack the
    locked platform DOFs (their A_∞, C_hst and memory are then zero).
    """
    s = structural_matrices(preset)
    idx = [0, 2, 4]
    unknown = [n for n in preset.locked_dofs if n not in DOF_NAMES]
    if unknown:
        raise ValueError(f"locked_dofs: unknown {unknown}; expected names of {DOF_NAMES}")
    locked = tuple(DOF_NAMES.index(n) for n in preset.locked_dofs)
    for k, wamit in enumerate(idx):
        if wamit not in hydro.dofs and k not in locked:
            raise ValueError(
                f"hydro data lack the {DOF_NAMES[k]} DOF; lock it (locked_dofs) or give its data"
            )
    have = [k for k, wamit in enumerate(idx) if wamit in hydro.dofs]
    pos = [hydro.dofs.index(idx[k]) for k in have]
    rad = hydro.radiation
    for key, shape in (
        ("member_force_n", (6,)),
        ("member_stiffness", (6, 6)),
        ("member_added_mass", (6, 6)),
    ):
        value = getattr(preset, key)
        if value and np.shape(value) != shape:
            raise ValueError(f"{key}: expected shape {shape} (or empty), got {np.shape(value)}")
    M = s.mass.copy()
    M[np.ix_(have, have)] += rad.added_mass_inf[np.ix_(pos, pos)]
    if preset.member_added_mass:
        M[:3, :3] += np.array(preset.member_added_mass)[np.ix_(idx, idx)]
    K = s.stiffness.copy()
    K[np.ix_(have, have)] += hydro.hydrostatic_stiffness[np.ix_(pos, pos)]
    K[:3, :3] += np.array(preset.additional_linear_stiffness)[np.ix_(idx, idx)]
    if preset.member_stiffness:
        K[:3, :3] += np.array(preset.member_stiffness)[np.ix_(idx, idx)]
    F = s.static_force.copy()
    F[1] += preset.water_density_kg_m3 * preset.gravity_m_s2 * preset.displaced_volume_m3
    F[:3] += np.array(preset.additional_force_n)[idx]
    if preset.member_force_n:
        F[:3] += np.array(preset.member_force_n)[idx]
    D = np.zeros((4, 4))
    D[:3, :3] = np.array(preset.additional_linear_damping)[np.ix_(idx, idx)]
    D[3, 3] = s.tower_damping_n_s_m
    bq = np.array(preset.additional_quadratic_damping)[np.ix_(idx, idx)]
    table = MooringTable(
        surge_m=np.array(mooring.surge_m),
        force_surge_n=np.array(mooring.force_surge_n),
        force_heave_n=np.array(mooring.force_heave_n),
        moment_pitch_nm=np.array(mooring.moment_pitch_nm),
        stiffness_heave_pitch=np.array(mooring.stiffness_heave_pitch),
        stiffness_heave_pitch_by_surge=np.array(mooring.stiffness_heave_pitch_by_surge),
    )
    drag, drag_damping = tower_drag_matrices(preset, turbine.air_density_kg_m3)
    if radiation is None:
        ra, rb, rc = np.zeros((0, 0)), np.zeros((0, 3)), np.zeros((3, 0))
    else:
        rdofs = tuple(radiation.dofs)
        if rdofs != (0, 2, 4) and not (
            set(rdofs) <= set(idx)
            and all(k in locked for k, wamit in enumerate(idx) if wamit not in rdofs)
        ):
            raise ValueError(
                f"radiation: expected dofs (0, 2, 4) (or those of the free DOFs), got {rdofs}"
            )
        ra = radiation.A
        rb = np.zeros((ra.shape[0], 3))
        rc = np.zeros((3, ra.shape[0]))
        for j, wamit in enumerate(rdofs):
            rb[:, idx.index(wamit)] = radiation.B[:, j]
            rc[idx.index(wamit), :] = radiation.C[j, :]
    return FloatingParams(
        name=preset.name,
        turbine=turbine,
        mass_matrix=0.5 * (M + M.T),
        stiffness=0.5 * (K + K.T),
        static_force=F,
        linear_damping=D,
        quadratic_damping=bq,
        hub_lever=s.hub_lever,
        hub_lever_vertical=s.hub_lever_vertical,
        shaft_tilt_rad=preset.shaft_tilt_rad,
        tower_slope_per_m=s.modal.slope_per_m,
        tower_drag=drag,
        tower_drag_damping=drag_damping,
        mooring=table,
        radiation_a=ra,
        radiation_b=rb,
        radiation_c=rc,
        locked_dofs=locked,
    )


def load_floating(name_or_path: str | Path, radiation: bool = True) -> FloatingParams:
    """Load a floating turbine from a shipped preset name or a preset TOML path (offline).

    Reads the turbine preset, the hydrodynamic npz (:class:`plant.hydro.wamit.HydroData`), the
    mooring JSON and the radiation memory of surge, heave and pitch: the shipped state space
    of ``radiation_file`` (:class:`plant.hydro.radiation.RadiationModel`, fitted and reduced
    once by the importer), or, for a preset without one, a fit at load with
    :func:`plant.hydro.radiation.fit_radiation` (``radiation=False``: no memory states).

    Parameters
    ----------
    name_or_path : str or Path
        ``"iea15mw_volturnus"`` or a path to a ``.toml`` written by
        :func:`plant.openfast_import.write_preset`.
    radiation : bool, optional
        Fit and include the radiation memory (default True).

    Returns
    -------
    FloatingParams
    """
    from plant.hydro.radiation import RadiationModel, fit_radiation  # noqa: PLC0415  offline
    from plant.hydro.wamit import HydroData  # noqa: PLC0415

    preset, base, source = read_floating_preset(name_or_path)
    turbine_ref = preset.turbine
    if (
        base is not None
        and not turbine_ref.startswith(_PRESET_PREFIX)
        and ("/" in turbine_ref or turbine_ref.endswith(".toml"))
    ):
        turbine = load_turbine(base / turbine_ref)
    else:
        turbine = load_turbine(turbine_ref.removeprefix(_PRESET_PREFIX))
    with resources.as_file(_resolve(base, preset.hydro_file)) as hydro_path:
        hydro = HydroData.load_npz(hydro_path)
    mooring = read_mooring_file(_resolve(base, preset.mooring_file))
    ss: RadiationSS | RadiationModel | None = None
    if radiation and preset.radiation_file:
        with resources.as_file(_resolve(base, preset.radiation_file)) as rad_path:
            ss = RadiationModel.load_npz(rad_path)
    elif radiation:
        ss = fit_radiation(hydro.radiation, **preset.radiation_fit_options())
    try:
        return build_floating_params(preset, turbine, hydro, mooring, ss)
    except ValueError as exc:
        raise ValueError(f"{source}: {exc}") from exc
