"""Offline design of ``lqr_wave``: LQR scheduled on wind speed and wave frequency (christiansen).

christiansen-2013 sect. 2.10-2.13: above rated, full-state LQR with the control law

.. math::

    u = u_{OP}(v) - K(v, \\omega_w)\\,(x - x_{OP}(v)),

designed on a linear model of the spar whose added mass and radiation damping are evaluated
at the current wave frequency :math:`\\omega_w` (that is how the wave frequency enters: no
wave-disturbance states, no feedforward), tabulated over the wind speed v (rated to 25 m/s,
every 0.5 m/s) and :math:`\\omega_w` (0..5 rad/s, every 0.1 rad/s) and interpolated online.

Linear model (this module's choices where the seed is silent)
------------------------------------------------------------
The plant model of :mod:`plant.platform` (surge, heave, pitch, tower fore-aft, rotor, pitch and
torque actuators), loaded without radiation memory, is linearised numerically about the
steady operating point at wind v (:func:`plant.modes.operating_point`,
:func:`plant.modes.linearize`): :math:`M_\\infty \\ddot q = F(q, \\dot q, \\ldots)` with
:math:`M_\\infty = M_s + A_\\infty`. The frequency-dependent hydrodynamics replace it by

.. math::

    (M_s + A(\\omega_w))\\,\\ddot q = F - B(\\omega_w)\\,\\dot q,

i.e. the q̈ rows of the state and input matrices become
:math:`(M_s + A(\\omega_w))^{-1}(M_\\infty\\,[\\text{rows}] - B(\\omega_w)` on the q̇ columns).
A(ω), B(ω) are the shipped BEM data interpolated linearly in ω and held at the ends of the
data band (0.05-3 rad/s): below 0.05 rad/s the lowest value, above 3 rad/s the highest
(A → A_∞-like, B small).

Design states (12) and input (1):

    z = (x, z_h, φ, s, ẋ, ż_h, φ̇, ṡ, Ω, β, ψ, β_c),   u = β̇_c

Ω rotor speed (rad/s), β the blade pitch (the actuator's first-order lag of the plant model),
ψ = ∫(Ω − Ω_rated) dt the rotor angle (sect. 2.13: "the integral action of the rotor speed"),
β_c the pitch demand, integrated from the designed pitch *rate* u so that the seed's weight on
the blade pitch rate is the input weight. Generator torque constant at its operating value
above rated (sect. 2.13, "constant torque approach"); its state is dropped.

Weights (Bryson's rule, sect. 2.13): Q = diag(1/z_max²) with ψ_max = 20 rad, φ̇_max = 1 deg/s,
β_max = 60 deg on both β and β_c (the seed's "blade pitch angle may vary 60 degrees", which it
puts in R; here the input is the pitch rate, so the angle goes to Q); R = 1/β̇_max² with
β̇_max = 5 deg/s (``LQR1``) or 8 deg/s (``LQR2``). The seed follows Bryson's guess with an
unpublished "iterative trial and error"; with only the published weights the rotor speed is
regulated through ψ alone and its standard deviation on the seed's case came out 35-55 % above
the detuned baseline's (600 s runs, Tp 2/5/10 s). **Choice**: one more Bryson weight, the rotor
speed Ω_max = 0.1 rad/s (8 % of rated), ``rotor_speed_max_rad_s`` (0 restores the published
weights only). All other weights zero. The discrete LQR is solved at the control period (zero-order
hold; 0.1 s as in the seed and 0.025 s, the bench's rate).

Observer (the seed assumes full state): the platform and tower states (8) come from the bench's
Kalman filter :class:`controller.estimators.PlatformKF` on the same linear model at each design
wind speed with the hydrodynamics at ω = 0.2 rad/s (the platform pitch/heave band), inputs
(Ω − Ω_op, β − β_op), measurements GNSS surge, platform pitch, pitch rate and nacelle
fore-aft acceleration; process noise from the wind and the wave excitation inputs.

Artefact: ``<preset>_lqr_wave_<variant>_dt<T>.npz`` + ``.json`` (preset, settings, commit).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

FloatArray = npt.NDArray[np.float64]

__all__ = [
    "VARIANTS",
    "LqrWaveSettings",
    "damping_map",
    "design_lqr_wave",
    "lqr_wave_stem",
    "spar_model",
]

#: Variant name -> blade pitch rate allowed by Bryson's rule (deg/s), christiansen-2013 s. 2.13.
VARIANTS = {"lqr1": 5.0, "lqr2": 8.0}

STATE_NAMES = (
    "surge_m",
    "heave_m",
    "pitch_rad",
    "tower_fore_aft_m",
    "surge_velocity_m_s",
    "heave_velocity_m_s",
    "pitch_rate_rad_s",
    "tower_fore_aft_velocity_m_s",
    "rotor_speed_rad_s",
    "blade_pitch_rad",
    "rotor_angle_rad",
    "blade_pitch_demand_rad",
)
_I_OMEGA, _I_BETA, _I_PSI, _I_BC = 8, 9, 10, 11


@dataclass(frozen=True)
class LqrWaveSettings:
    """Design settings (SI unless the name says otherwise).

    Attributes
    ----------
    variant : {"lqr1", "lqr2"}
        Pitch-rate weight (:data:`VARIANTS`).
    wind_min_m_s, wind_max_m_s, wind_step_m_s : float
        Wind grid (rated 11.5 .. 25 every 0.5 m/s).
    wave_min_rad_s, wave_max_rad_s, wave_step_rad_s : float
        Wave-frequency grid (0 .. 5 every 0.1 rad/s).
    rotor_angle_max_rad, platform_rate_max_deg_s, pitch_max_deg : float
        Bryson limits of ψ (20 rad), φ̇ (1 deg/s), β and β_c (60 deg).
    observer_wave_rad_s : float
        Wave frequency of the observer's hydrodynamics (0.2 rad/s).
    decoupled : bool
        Gains designed on the seed's model without the surge-pitch coupling
        (:class:`SparModel`); the observer keeps the plant's coupled model (it estimates the
        plant's states). Default False (the plant's model).
    """

    variant: str = "lqr2"
    wind_min_m_s: float = 11.5
    wind_max_m_s: float = 25.0
    wind_step_m_s: float = 0.5
    wave_min_rad_s: float = 0.0
    wave_max_rad_s: float = 5.0
    wave_step_rad_s: float = 0.1
    rotor_angle_max_rad: float = 20.0
    rotor_speed_max_rad_s: float = 0.1
    platform_rate_max_deg_s: float = 1.0
    pitch_max_deg: float = 60.0
    observer_wave_rad_s: float = 0.2
    decoupled: bool = False

    def __post_init__(self) -> None:
        if self.variant not in VARIANTS:
            raise ValueError(
                f"LqrWaveSettings.variant = {self.variant!r}: expected one of {list(VARIANTS)}"
            )
        for name in ("wind_step_m_s", "wave_step_rad_s", "rotor_angle_max_rad"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"LqrWaveSettings.{name}: expected > 0, got {getattr(self, name)}")

    def winds(self) -> FloatArray:
        """Wind grid (m/s)."""
        n = round((self.wind_max_m_s - self.wind_min_m_s) / self.wind_step_m_s)
        return np.asarray(self.wind_min_m_s + self.wind_step_m_s * np.arange(n + 1), np.float64)

    def waves(self) -> FloatArray:
        """Wave-frequency grid (rad/s)."""
        n = round((self.wave_max_rad_s - self.wave_min_rad_s) / self.wave_step_rad_s)
        return np.asarray(self.wave_min_rad_s + self.wave_step_rad_s * np.arange(n + 1), np.float64)


def lqr_wave_stem(preset: str, variant: str, control_period_s: float) -> str:
    """File stem ``<preset>_lqr_wave_<variant>_dt<T>`` of a design artefact."""
    from controller.lqri import period_tag  # noqa: PLC0415

    return f"{preset}_lqr_wave_{variant}_{period_tag(control_period_s)}"


@dataclass(frozen=True)
class _Base:
    """Linearisation at one wind (inf-frequency mass) and the hydro data to re-evaluate it."""

    wind_m_s: float
    a: FloatArray  # (11, 11) over (q, q̇, Ω, β, T_g)
    b: FloatArray  # (11, 2) pitch and torque demand
    b_dist: FloatArray  # (11, 4) wind, wave forces
    x_op: FloatArray  # (11,)
    m_inf: FloatArray  # (4, 4)
    hub_lever: FloatArray  # (4,)
    #: Decoupled model only: generalised-force Jacobians (4 rows q̈·M) over the 11 states, the
    #: 2 demands and the 4 disturbances, and the mass matrix, surge-pitch terms removed.
    force_x: FloatArray | None = None
    force_u: FloatArray | None = None
    force_dist: FloatArray | None = None
    m_dec: FloatArray | None = None


#: Surge (0) and pitch (2) DOF indices of (surge, heave, pitch, tower): the coupling removed
#: by the decoupled model.
_SURGE, _PITCH = 0, 2


def decouple(m: FloatArray, offset: int = 0) -> FloatArray:
    """Copy of a matrix over the DOFs with its surge-pitch cross terms set to zero.

    ``offset``: column offset of the DOF block (4 for the q̇ columns of a state Jacobian).
    """
    out = np.array(m, dtype=np.float64, copy=True)
    out[_SURGE, offset + _PITCH] = 0.0
    out[_PITCH, offset + _SURGE] = 0.0
    return out


class SparModel:
    """The plant's linearisation and its BEM data (offline; imports ``plant``).

    ``decoupled``: christiansen-2013's model (sect. 2.1-2.4) instead of the plant's. The seed
    keeps "the dominating diagonal elements only" of the platform's mass matrix (its cross
    terms, "i.e. pitch and surge", left out on the strength of unpublished simulations), and
    writes the platform mass, added mass, damping and stiffness about the SWL as diagonal
    matrices plus the turbine/tower coupling. Here that is: the surge-pitch (and
    pitch-surge) entries set to zero in the mass matrix M_s + A_∞, in A(ω) − A_∞, in the
    radiation damping B(ω), and in the non-aerodynamic stiffness and damping of the
    linearisation (hydrostatics, gravity, mooring, linear and quadratic hydrodynamic drag:
    the Jacobian of the plant with its rotor loads off). The aerodynamic terms (thrust and
    torque derivatives with respect to the surge and pitch rates through the relative wind
    v − ẋ − h_h θ̇, the seed's sect. 2.5) keep their coupling, as in the seed's model.
    """

    def __init__(self, preset: str, decoupled: bool = False) -> None:
        from importlib import resources  # noqa: PLC0415

        from plant.hydro.wamit import HydroData  # noqa: PLC0415
        from plant.platform import _resolve, load_floating, read_floating_preset  # noqa: PLC0415

        self.preset = preset
        self.decoupled = bool(decoupled)
        self.params = load_floating(preset, radiation=False)
        fp, base, _ = read_floating_preset(preset)
        with resources.as_file(_resolve(base, fp.hydro_file)) as path:
            hydro = HydroData.load_npz(path)
        rad = hydro.radiation
        idx = [rad.dofs.index(k) for k in (0, 2, 4)]
        self.omega_data = np.asarray(rad.omega_rad_s, dtype=np.float64)
        self.added = np.asarray(rad.added_mass)[:, idx][:, :, idx]
        self.damping = np.asarray(rad.damping)[:, idx][:, :, idx]
        self.a_inf = np.asarray(rad.added_mass_inf)[np.ix_(idx, idx)]
        self._cache: dict[float, _Base] = {}

    def hydro_at(self, omega_rad_s: float) -> tuple[FloatArray, FloatArray]:
        """A(ω), B(ω) (3x3, surge/heave/pitch), linear in ω, held beyond the data."""
        w = float(np.clip(omega_rad_s, self.omega_data[0], self.omega_data[-1]))
        a = np.empty((3, 3))
        b = np.empty((3, 3))
        for i in range(3):
            for j in range(3):
                a[i, j] = np.interp(w, self.omega_data, self.added[:, i, j])
                b[i, j] = np.interp(w, self.omega_data, self.damping[:, i, j])
        return a, b

    def base(self, wind_m_s: float) -> _Base:
        """Linearisation at ``wind_m_s`` (cached)."""
        key = round(float(wind_m_s), 6)
        if key in self._cache:
            return self._cache[key]
        from controller.design.linear import _jacobian_u  # noqa: PLC0415
        from plant.modes import linearize, operating_point  # noqa: PLC0415

        p = self.params
        op = operating_point(p, wind_m_s)
        a = linearize(p, op)
        x0 = np.array(op.state, dtype=np.float64)
        bu = _jacobian_u(p, x0, op.inputs)
        m_inf = np.asarray(p.mass_matrix, dtype=np.float64)
        dec: dict[str, FloatArray] = {}
        if self.decoupled:
            from dataclasses import replace  # noqa: PLC0415

            # Generalised forces M q̈ = F: F's Jacobian split into the rotor's (aero) part and
            # the rest (the linearisation with the rotor loads off, same state and inputs).
            fx = m_inf @ a[4:8, :]
            fx_rest = m_inf @ linearize(replace(p, aero=False), op)[4:8, :]
            dec = {
                "force_x": decouple(decouple(fx_rest), offset=4) + (fx - fx_rest),
                "force_u": m_inf @ bu[4:8, 0:2],
                "force_dist": m_inf @ bu[4:8, 2:6],
                "m_dec": decouple(m_inf),
            }
        out = _Base(
            wind_m_s=float(wind_m_s),
            a=a,
            b=bu[:, 0:2].copy(),
            b_dist=bu[:, 2:6].copy(),
            x_op=x0,
            m_inf=m_inf,
            hub_lever=np.asarray(p.hub_lever, dtype=np.float64),
            **dec,
        )
        self._cache[key] = out
        return out

    def at(self, wind_m_s: float, omega_rad_s: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(A, B, B_dist) of the 11-state model with the hydrodynamics at ``omega_rad_s``."""
        bs = self.base(wind_m_s)
        a_w, b_w = self.hydro_at(omega_rad_s)
        if self.decoupled:
            return self._at_decoupled(bs, a_w, b_w)
        m_new = bs.m_inf.copy()
        m_new[:3, :3] += a_w - self.a_inf
        d_new = np.zeros((4, 4))
        d_new[:3, :3] = b_w
        t = np.linalg.solve(m_new, bs.m_inf)
        a = bs.a.copy()
        b = bs.b.copy()
        bd = bs.b_dist.copy()
        a[4:8, :] = t @ bs.a[4:8, :]
        a[4:8, 4:8] -= np.linalg.solve(m_new, d_new)
        b[4:8, :] = t @ bs.b[4:8, :]
        bd[4:8, :] = t @ bs.b_dist[4:8, :]
        return a, b, bd

    def _at_decoupled(
        self, bs: _Base, a_w: FloatArray, b_w: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """:meth:`at` of the decoupled model (class docstring): every surge-pitch term zero."""
        assert bs.m_dec is not None and bs.force_x is not None
        assert bs.force_u is not None and bs.force_dist is not None
        m_new = bs.m_dec.copy()
        m_new[:3, :3] += decouple(a_w - self.a_inf)
        d_new = np.zeros((4, 4))
        d_new[:3, :3] = decouple(b_w)
        a = bs.a.copy()
        b = bs.b.copy()
        bd = bs.b_dist.copy()
        a[4:8, :] = np.linalg.solve(m_new, bs.force_x)
        a[4:8, 4:8] -= np.linalg.solve(m_new, d_new)
        b[4:8, :] = np.linalg.solve(m_new, bs.force_u)
        bd[4:8, :] = np.linalg.solve(m_new, bs.force_dist)
        return a, b, bd

    def coupling_terms(self, wind_m_s: float, omega_rad_s: float) -> dict[str, float]:
        """The surge-pitch cross terms of the model's mass, added mass, radiation damping and
        non-aerodynamic stiffness and damping at (v, ω) (all zero when ``decoupled``)."""
        bs = self.base(wind_m_s)
        a_w, b_w = self.hydro_at(omega_rad_s)
        if self.decoupled:
            assert bs.m_dec is not None and bs.force_x is not None
            m, a_add, b_rad = bs.m_dec, decouple(a_w - self.a_inf), decouple(b_w)
            fx = bs.force_x - (bs.m_inf @ bs.a[4:8, :] - self._rest(wind_m_s, decoupled=False))
        else:
            m, a_add, b_rad = bs.m_inf, a_w - self.a_inf, b_w
            fx = self._rest(wind_m_s, decoupled=False)
        p, s_ = _PITCH, _SURGE
        return {
            "mass_surge_pitch": float(m[s_, p]),
            "mass_pitch_surge": float(m[p, s_]),
            "added_mass_surge_pitch": float(a_add[s_, p]),
            "added_mass_pitch_surge": float(a_add[p, s_]),
            "radiation_damping_surge_pitch": float(b_rad[s_, p]),
            "radiation_damping_pitch_surge": float(b_rad[p, s_]),
            "stiffness_surge_pitch": float(fx[s_, p]),
            "stiffness_pitch_surge": float(fx[p, s_]),
            "damping_surge_pitch": float(fx[s_, 4 + p]),
            "damping_pitch_surge": float(fx[p, 4 + s_]),
        }

    def _rest(self, wind_m_s: float, decoupled: bool) -> FloatArray:
        """Non-aerodynamic generalised-force Jacobian (4 x 11) at ``wind_m_s``."""
        from dataclasses import replace  # noqa: PLC0415

        from plant.modes import linearize, operating_point  # noqa: PLC0415

        p = self.params
        op = operating_point(p, wind_m_s)
        rest = np.asarray(p.mass_matrix) @ linearize(replace(p, aero=False), op)[4:8, :]
        return decouple(decouple(rest), offset=4) if decoupled else rest


def spar_model(preset: str, decoupled: bool = False) -> SparModel:
    """The linear spar model of a floating preset (offline); ``decoupled``: the seed's model
    without the surge-pitch coupling (:class:`SparModel`)."""
    return SparModel(preset, decoupled)


def design_matrices(
    model: SparModel, wind_m_s: float, omega_rad_s: float
) -> tuple[FloatArray, FloatArray]:
    """Continuous (A, B) of the 12 design states and the pitch-rate input (module docstring)."""
    a11, b11, _ = model.at(wind_m_s, omega_rad_s)
    keep = list(range(10))  # drop the torque state (constant torque)
    a = np.zeros((12, 12))
    a[:10, :10] = a11[np.ix_(keep, keep)]
    a[:10, _I_BC] = b11[keep, 0]  # β_c drives the pitch actuator
    a[_I_PSI, _I_OMEGA] = 1.0  # ψ̇ = Ω − Ω_op
    b = np.zeros((12, 1))
    b[_I_BC, 0] = 1.0  # β̇_c = u
    return a, b


def weights(settings: LqrWaveSettings) -> tuple[FloatArray, FloatArray]:
    """Bryson weights Q (12x12) and R (1x1) (module docstring)."""
    q = np.zeros(12)
    q[_I_PSI] = 1.0 / settings.rotor_angle_max_rad**2
    if settings.rotor_speed_max_rad_s > 0.0:  # 0: not weighted (the seed's published weights)
        q[_I_OMEGA] = 1.0 / settings.rotor_speed_max_rad_s**2
    q[6] = 1.0 / math.radians(settings.platform_rate_max_deg_s) ** 2
    q[_I_BETA] = 1.0 / math.radians(settings.pitch_max_deg) ** 2
    q[_I_BC] = 1.0 / math.radians(settings.pitch_max_deg) ** 2
    r = np.array([[1.0 / math.radians(VARIANTS[settings.variant]) ** 2]])
    return np.diag(q), r


def discrete_lqr(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray, dt_s: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """ZOH discretisation and the discrete LQR gain K (u = −K z); returns (K, F, G)."""
    n, m = b.shape
    blk = np.zeros((n + m, n + m))
    blk[:n, :n], blk[:n, n:] = a, b
    e = sla.expm(blk * dt_s)
    f, g = e[:n, :n], e[:n, n:]
    # Q on the sampled states (the seed's weights are continuous-time; Q dt and R dt keep scale)
    p = sla.solve_discrete_are(f, g, q * dt_s, r * dt_s)
    k = np.linalg.solve(r * dt_s + g.T @ p @ g, g.T @ p @ f)
    return k, f, g


def _observer(model: SparModel, wind_m_s: float, omega_rad_s: float) -> dict[str, FloatArray]:
    """Continuous observer model of the 8 platform/tower states at one wind (module docstring)."""
    a11, _b11, bd = model.at(wind_m_s, omega_rad_s)
    bs = model.base(wind_m_s)
    a = a11[:8, :8]
    bu = a11[:8, 8:10]  # inputs: Ω − Ω_op, β − β_op
    jh = bs.hub_lever
    # measurements: surge, pitch, pitch rate, nacelle fore-aft acceleration (J_h · q̈)
    h = np.zeros((4, 8))
    h[0, 0] = 1.0
    h[1, 2] = 1.0
    h[2, 6] = 1.0
    h[3, :] = jh @ a[4:8, :]
    d = np.zeros((4, 2))
    d[3, :] = jh @ bu[4:8, :]
    gw = bd[:8, :]
    # process noise: wind (1 m/s)^2 s, wave forces (2e6 N, 2e5 N, 1e8 N m)^2 s
    qc = gw @ np.diag([1.0, 2e6**2, 2e5**2, 1e8**2]) @ gw.T + 1e-12 * np.eye(8)
    r = np.diag([0.05**2, math.radians(0.05) ** 2, math.radians(0.02) ** 2, 0.02**2])
    return {"A": a, "Bu": bu, "H": h, "D": d, "Qc": 0.5 * (qc + qc.T), "R": r}


def design_lqr_wave(
    preset: str = "nrel5mw_oc3_hywind",
    control_period_s: float = 0.1,
    settings: LqrWaveSettings | None = None,
    out_dir: str | Path | None = None,
    model: SparModel | None = None,
    provenance: dict[str, object] | None = None,
) -> Path:
    """Design the gain table and the observers; write ``<stem>.npz`` and ``.json``.

    Returns
    -------
    Path
        The npz written.
    """
    from controller.design import DEFAULT_DESIGN_DIR, _commit  # noqa: PLC0415

    s = settings or LqrWaveSettings()
    if not 0.0 < control_period_s <= 1.0:
        raise ValueError(f"control_period_s = {control_period_s!r}: expected (0, 1] s")
    m = model or SparModel(preset, decoupled=s.decoupled)
    if m.decoupled != s.decoupled:
        raise ValueError(f"design_lqr_wave: settings.decoupled = {s.decoupled}, model not")
    m_obs = SparModel(preset) if m.decoupled else m  # the observer estimates the plant's states
    winds, waves = s.winds(), s.waves()
    q, r = weights(s)
    gains = np.zeros((winds.size, waves.size, 12))
    rho_max = np.zeros((winds.size, waves.size))
    obs: dict[str, list[FloatArray]] = {k: [] for k in ("A", "Bu", "H", "D", "Qc", "R")}
    x_op = np.zeros((winds.size, 11))
    for i, v in enumerate(winds):
        x_op[i] = m.base(float(v)).x_op[:11]
        for j, w in enumerate(waves):
            a, b = design_matrices(m, float(v), float(w))
            k, f, g = discrete_lqr(a, b, q, r, control_period_s)
            gains[i, j] = k[0]
            rho_max[i, j] = float(np.max(np.abs(np.linalg.eigvals(f - g @ k))))
        for key, val in _observer(m_obs, float(v), s.observer_wave_rad_s).items():
            obs[key].append(val)
    tp = m.params.turbine
    out = Path(out_dir) if out_dir is not None else DEFAULT_DESIGN_DIR
    out.mkdir(parents=True, exist_ok=True)
    stem = lqr_wave_stem(preset, s.variant, control_period_s)
    npz = out / f"{stem}.npz"
    arrays: dict[str, Any] = {f"obs_{k}": np.stack(v) for k, v in obs.items()}
    arrays.update(
        wind_m_s=winds,
        wave_omega_rad_s=waves,
        gains=gains,
        closed_loop_spectral_radius=rho_max,
        x_op=x_op,
    )
    np.savez(npz, **arrays)
    meta: dict[str, Any] = {
        "kind": "lqr_wave",
        "preset": preset,
        "variant": s.variant,
        "control_period_s": control_period_s,
        "settings": {**s.__dict__, "control_period_s": control_period_s},
        "state_names": list(STATE_NAMES),
        "rated_rotor_speed_rad_s": float(tp.rated_rotor_speed_rad_s),
        "gearbox_ratio": float(tp.gearbox_ratio),
        "generator_torque_nm": float(x_op[0, 10]),
        "pitch_min_rad": float(tp.pitch_min_rad),
        "pitch_max_rad": float(tp.pitch_max_rad),
        "pitch_rate_max_rad_s": float(tp.pitch_rate_max_rad_s),
        "torque_rate_max_nm_s": float(tp.torque_rate_max_nm_s),
        "max_closed_loop_spectral_radius": float(rho_max.max()),
        "hub_lever": [float(v) for v in m.params.hub_lever],
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "commit": _commit(),
        **(provenance or {}),
    }
    (out / f"{stem}.json").write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    return npz


def damping_map(
    preset: str = "nrel5mw_oc3_hywind",
    winds_m_s: FloatArray | None = None,
    waves_rad_s: FloatArray | None = None,
    model: SparModel | None = None,
    decoupled: bool = False,
) -> dict[str, Any]:
    """Open-loop damping ratio of the platform-pitch mode over wind and wave frequency (s. 2.9).

    ``decoupled``: on the seed's model without the surge-pitch coupling (:class:`SparModel`;
    ignored when ``model`` is given, whose own setting holds).

    Open loop: pitch and torque demands held at their operating values (the actuator states
    stay, driven by nothing), the 11-state model of :meth:`SparModel.at` at each (v, ω_w); the
    pitch mode is the eigenvalue whose eigenvector has the largest pitch share
    (:func:`plant.modes.identify_modes`), damping ratio ζ = −Re λ/|λ|.

    Returns
    -------
    dict
        ``wind_m_s``, ``wave_omega_rad_s``, ``pitch_damping_ratio`` (list of rows, wind-major),
        ``pitch_frequency_hz`` and the location of the maximum.
    """
    from plant.modes import PITCH_LENGTH_M, identify_modes  # noqa: PLC0415
    from plant.platform import DOF_NAMES  # noqa: PLC0415

    m = model or SparModel(preset, decoupled=decoupled)
    winds = np.arange(3.0, 25.0 + 1e-9, 0.5) if winds_m_s is None else np.asarray(winds_m_s)
    waves = np.arange(0.05, 3.0 + 1e-9, 0.05) if waves_rad_s is None else np.asarray(waves_rad_s)
    zeta = np.full((winds.size, waves.size), np.nan)
    freq = np.full((winds.size, waves.size), np.nan)
    failed: list[str] = []
    for i, v in enumerate(winds):
        try:
            m.base(float(v))
        except ValueError as exc:  # no static equilibrium found: the row stays NaN, reported
            failed.append(f"{v:g} m/s: {exc}")
            continue
        for j, w in enumerate(waves):
            a, _, _ = m.at(float(v), float(w))
            modes = identify_modes(
                a, range(4), range(4, 8), DOF_NAMES, (1.0, 1.0, PITCH_LENGTH_M, 1.0)
            )
            for mode in modes:
                if mode.name == "pitch":
                    zeta[i, j] = mode.damping_ratio
                    freq[i, j] = mode.eigenvalue[1] / (2.0 * math.pi)
    k = int(np.nanargmax(zeta))
    i_max, j_max = divmod(k, waves.size)
    return {
        "preset": preset,
        "decoupled": m.decoupled,
        "wind_m_s": winds.tolist(),
        "wave_omega_rad_s": waves.tolist(),
        "pitch_damping_ratio": zeta.tolist(),
        "pitch_frequency_hz": freq.tolist(),
        "max_damping_ratio": float(zeta[i_max, j_max]),
        "max_at_wind_m_s": float(winds[i_max]),
        "max_at_wave_omega_rad_s": float(waves[j_max]),
        "max_at_wave_hz": float(waves[j_max] / (2.0 * math.pi)),
        "seed_max": "christiansen-2013 sect. 2.9: maximum at 10.4 m/s and 0.09 Hz",
        "failed_winds": failed,
    }
