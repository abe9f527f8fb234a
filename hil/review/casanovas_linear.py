"""casanovas-2014's table 5.2 metric: the quadratic aerodynamic power on the linear model.

The seed runs its controllers on its linear surge + rotor model (section 4.1) and evaluates
power with the quadratic expansion of section 4.4 (P = ½ρS [1 ξ̇ ϖ ψ] Q₀ [1 ξ̇ ϖ ψ]ᵀ, "used
to evaluate power in the simulations"). ``[review] power_metric = "quadratic_linear"`` asks
for the same figure beside the bench's electrical power; :func:`run_linear` computes it:

* Model: ẋ = A x + B u + E X(t), x = [ϖ, ξ - ξ̄, ξ̇, r₁..r₄], u = [ΔT_g, ψ], the design's
  linearisation (:func:`controller.design.casanovas.linear_model` for the design's settings,
  the same A, B, E the controllers are designed on). Integrated exactly over each plant step
  (zero-order hold of u over the control period and of X over the plant step).
* Sea: the surge excitation X(t) of the scenario's own wave field (the plant's
  :class:`plant.waves.ExcitationForce`, so seed k is the same sea as the bench run).
* Controller: the scenario's core, stepped with exact ϖ and ξ (no sensor noise) and the
  perfect preview X(t + jΔ); its commands as it sends them (its own pitch limits, the
  region-2 law K(Nω)² for ``base_torque``/``lqr_overlaid``), ΔT_g = T_g - T̄_g, ψ = θ; the
  actuators are ideal, as the seed's.
* Power: P_q = P̄ + g·z + ½ zᵀ H z, z = (ϖ, ξ̇, ψ), with P̄, g and H the power, gradient and
  Hessian of the design's local C_p surface (the seed's Q₀, where it sets ∂C_p/∂λ = 0 at
  λ*; here g is kept as fitted). The fixed-bottom turbine in steady wind sits at z = 0, so
  its power is P̄ and the table's figure is 100 (mean P_q / P̄ - 1) over [settle, end].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import linalg

from bus_schemas.messages import SensorFrame

FloatArray = npt.NDArray[np.float64]

__all__ = ["LinearRunResult", "quadratic_power", "run_linear"]


@dataclass(frozen=True)
class LinearRunResult:
    """What :func:`run_linear` measured."""

    mean_power_w: float  # mean P_q over [settle, end] [W]
    fixed_power_w: float  # P̄ [W]
    increase_percent: float  # 100 (mean P_q / P̄ - 1)
    surge_std_m: float
    pitch_std_deg: float
    torque_std_nm: float


def quadratic_power(
    p_bar: float, gradient: FloatArray, hessian: FloatArray, z: FloatArray
) -> FloatArray:
    """P_q = P̄ + g·z + ½ zᵀ H z [W] for rows z = (ϖ rad/s, ξ̇ m/s, ψ rad), shape (n, 3)."""
    zz = np.atleast_2d(np.asarray(z, dtype=np.float64))
    out: FloatArray = p_bar + zz @ gradient + 0.5 * np.einsum("ni,ij,nj->n", zz, hessian, zz)
    return out


def _frame(k: int, t_ns: int, omega: float, surge: float, gear: float) -> SensorFrame:
    return SensorFrame(
        seq=k,
        sample_time_ns=t_ns,
        publish_time_ns=t_ns,
        valid_mask=0,
        generator_speed_measured_rad_s=gear * omega,
        rotor_speed_measured_rad_s=omega,
        blade_pitch_measured_rad=0.0,
        generator_torque_measured_nm=0.0,
        electrical_power_measured_w=0.0,
        wind_speed_measured_m_s=0.0,
        nacelle_acc_fore_aft_measured_m_s2=0.0,
        platform_pitch_measured_rad=0.0,
        platform_pitch_rate_measured_rad_s=0.0,
        platform_surge_measured_m=surge,
        wave_elevation_gauge_measured_m=0.0,
    )


def run_linear(
    scenario: Any, duration_s: float | None = None, settle_s: float | None = None
) -> LinearRunResult:
    """Run a casanovas-2014 scenario's controller on the linear model (module docstring).

    Parameters
    ----------
    scenario : hil.scenario.schema.Scenario
        A floating scenario with a casanovas-2014 controller kind and a perfect preview.
    duration_s, settle_s : float or None
        Simulated time and the start of the averaging window [s] (None: the scenario's
        ``duration_s`` and min(``[review] settle_s``, duration / 2), the review's window).

    Raises
    ------
    ValueError
        If the scenario has no waves, another controller kind or the forecast preview.
    """
    from controller.casanovas import CASANOVAS_KINDS, load_casanovas_design  # noqa: PLC0415
    from controller.design.casanovas import CasanovasSettings, linear_model  # noqa: PLC0415
    from controller.registry import make_controller  # noqa: PLC0415
    from hil.nodes.plant_node import floating_plant  # noqa: PLC0415
    from plant.waves import ExcitationForce  # noqa: PLC0415

    c = scenario.controller
    if c.kind not in CASANOVAS_KINDS:
        raise ValueError(f"quadratic_linear metric: kind {c.kind!r} is not a casanovas-2014 kind")
    if scenario.waves is None or scenario.platform is None:
        raise ValueError("quadratic_linear metric: the scenario needs a platform and [waves]")
    if c.preview == "forecast":
        raise ValueError("quadratic_linear metric: only preview = 'perfect' (the seed's table)")
    duration = float(scenario.duration_s if duration_s is None else duration_s)
    settle = float(scenario.review.settle_s if settle_s is None else settle_s)
    if settle_s is None:  # as the review's KPI window: a short run keeps its second half
        settle = min(settle, 0.5 * duration)
    dt = float(scenario.timing.control_period_s)
    sub = int(scenario.steps_per_cycle)
    h = dt / sub
    core: Any = make_controller(
        c.kind,
        c.preset,
        control_period_s=dt,
        preview="perfect",
        horizon_s=c.horizon_s,
        overlap=c.overlap,
        symmetric_pitch_limit_deg=c.symmetric_pitch_limit_deg,
        torque_weight_factor=c.torque_weight_factor,
        gamma_1_s=c.gamma_value,
    )
    design = load_casanovas_design(c.preset)
    lm = linear_model(design.meta["preset"], CasanovasSettings(**design.meta["settings"]))
    nx = lm.a.shape[0]
    # exact discretisation over one plant step: [A B E; 0 0 0] (u and X held)
    big = np.zeros((nx + 3, nx + 3))
    big[:nx, :nx] = lm.a
    big[:nx, nx : nx + 2] = lm.b
    big[:nx, nx + 2] = lm.e
    ex = linalg.expm(big * h)
    ad, bd, ed = ex[:nx, :nx], ex[:nx, nx : nx + 2], ex[:nx, nx + 2]
    fp = floating_plant(scenario)
    exc = ExcitationForce(fp.waves, fp.excitation_transfer[:, :1])
    n_cycles = round(duration / dt)
    step_pv = round(core.preview_step / h)  # preview sample spacing in plant steps
    n_total = n_cycles * sub + step_pv * (core.n_preview - 1) + 1
    force = exc.series(0.0, h, n_total)[:, 0]
    pv_idx = step_pv * np.arange(core.n_preview)
    omega0, surge0, gear = lm.rotor_speed_rad_s, lm.surge_mean_m, lm.gearbox_ratio
    t_bar = lm.generator_torque_nm
    x = np.zeros(nx)
    st = core.initial_state()
    z = np.empty((n_cycles, 3))
    surge = np.empty(n_cycles)
    cmds = np.empty((n_cycles, 2))
    period_ns = round(dt * 1e9)
    for k in range(n_cycles):
        i0 = k * sub
        if hasattr(core, "accept_preview"):
            st = core.accept_preview(st, k, force[i0 + pv_idx])
        frame = _frame(k, k * period_ns, omega0 + x[0], surge0 + x[1], gear)
        st, out = core.step(st, frame, dt)
        psi = out.blade_pitch_commanded_rad
        u = np.array([out.generator_torque_commanded_nm - t_bar, psi])
        z[k] = (x[0], x[2], psi)
        surge[k] = x[1]
        cmds[k] = (out.generator_torque_commanded_nm, psi)
        bu = bd @ u
        for i in range(sub):
            x = ad @ x + bu + ed * force[i0 + i]
        if not np.all(np.isfinite(x)):
            raise ValueError(f"linear model diverged at t = {k * dt:.1f} s")
    p = quadratic_power(lm.aero_power_w, lm.power_gradient, lm.hessian, z)
    sel = dt * np.arange(n_cycles) >= settle
    if not np.any(sel):
        raise ValueError(f"quadratic_linear metric: no sample after settle_s = {settle} s")
    mean_p = float(np.mean(p[sel]))
    return LinearRunResult(
        mean_power_w=mean_p,
        fixed_power_w=lm.aero_power_w,
        increase_percent=100.0 * (mean_p / lm.aero_power_w - 1.0),
        surge_std_m=float(np.std(surge)),
        pitch_std_deg=math.degrees(float(np.std(cmds[:, 1]))),
        torque_std_nm=float(np.std(cmds[:, 0])),
    )
