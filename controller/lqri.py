r"""Gain-scheduled LQRI pitch controller with torque look-up below rated (runtime core).

Loads the design artefacts written by :func:`controller.design.design` (npz + json named
``<preset>_lqri_dt<T_s>`` and ``<preset>_waveff_dt<T_s>``, e.g. ``iea15mw_volturnus_lqri_dt0p025``)
for the control period T_s in use, from the shipped ``controller/presets/designs/`` or the user
design cache (``$FOWT_DESIGN_DIR``, default ``~/.cache/fowt-hil/designs``; see
:func:`find_design`); never imports ``plant``. A missing artefact raises
:class:`DesignNotFoundError` naming the ``fowt design`` command that writes it.

Per step (dt = T_s), with U the estimated wind speed used for scheduling:

1. Regime (hysteresis, disannio-2022 sect. 4.8 switches on the filtered wind): enter the
   pitch regime when U ≥ U_sw + h/2 or ω ≥ 1.02 ω_ref; leave it when U ≤ U_sw − h/2 and the
   previous pitch command is at the minimum. U_sw is the rated wind of the design model,
   h = ``switch_hysteresis_m_s`` of the design settings.
2. Below rated the LQRI does not act: the torque and pitch are those of the below-rated laws
   passed in the measurement (``torque_law_nm``, ``pitch_below_rated_rad``; the runtime gives
   the baseline's region 1 / 1.5 / 2 / 2.5 torque law, which holds the rotor at or above its
   minimum speed, and the baseline's pitch PI, at fine pitch below rated). Without them
   (NaN) the fallback is T_g = min(K ω², T_rated) (disannio-2022 Tab. 10 look-up;
   optimal-TSR K) and θ_min. The integrator z rests at 0 (no wind-up while the pitch sits
   at fine pitch) and is re-initialised bumplessly on entering the pitch regime (step 4).
3. Above rated: gains K_x(U), K_i(U) and the operating point x_op(U), θ_op(U) interpolated
   linearly on the wind grid (end values held):
   θ_c = θ_op − K_x (x − x_op) − K_i z,  z ← z + T_s (ω − ω_ref); T_g is the torque law's
   (region 3: T_rated; at fine pitch in a lull, region 2.5, so the rotor is not braked below
   its minimum speed), T_rated without a torque law.
4. θ_c saturated to [θ_min, θ_max] and rate limited |Δθ_c| ≤ θ'_max T_s; anti-windup by
   back-calculation: when the limited command differs from the LQRI output, z is reset so
   that the LQRI output equals the applied command (also on entering the pitch regime).
5. Optional wave feedforward (al-2019 ch. 4; artefact ``<preset>_waveff_dt<T_s>.npz`` written by
   :func:`controller.design.wave_ff.write_wave_ff_artefact`), kind ∈ {"off", "balanced",
   "max_performance"}: a discrete filter per scheduled wind driven by the forecast
   η̂₀(t + t_d) (m),

   .. math::

       u_{ff,k} = g(U)\,(c\,z_k + d\,\hat\eta_k),\qquad z_{k+1} = A_d z_k + b\,\hat\eta_k,

   with g(U) of al-2019 Tab. 5-1 interpolated linearly in U. All designs' filters run every
   step on the same forecast (one batched product) and the output is interpolated linearly in
   U between the two bracketing designs (the nearest one where they differ in kind), so a
   change of U never restarts a filter: restarting from zero lost the filters' memory (their
   impulse responses keep 5-12 % of their energy beyond 30 s) and left the FF 30-50 % wrong
   for tens of seconds after each switch. Below
   ``torque_below_m_s`` (17 m/s) u_ff (N m) is added to the torque before its saturation and
   rate limit; above, u_ff (rad) is added to the LQRI pitch before saturation and rate limit
   and the anti-windup back-calculation uses the total command. A NaN forecast gives
   u_ff = 0 and holds the filter state. The filter must run at the design period T_s.
"""

from __future__ import annotations

import json
import math
import os
from bisect import bisect_right
from dataclasses import dataclass
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

from controller import _kernels
from controller.interface import REGIME_REGION_2, REGIME_REGION_3, ControlOutput

__all__ = [
    "DESIGN_DIR_ENV",
    "FEEDFORWARD_KINDS",
    "PERIOD_DEPENDENT_KINDS",
    "SHIPPED_CONTROL_PERIOD_S",
    "DesignNotFoundError",
    "LqriController",
    "LqriDesign",
    "LqriMeasurement",
    "LqriState",
    "WaveFfDesign",
    "artefact_period_s",
    "artefact_stem",
    "design_command",
    "design_search_path",
    "find_design",
    "load_design_artefact",
    "load_lqri_design",
    "load_wave_ff_design",
    "period_tag",
    "user_design_dir",
]

#: Accepted wave-feedforward settings (per scenario).
FEEDFORWARD_KINDS = ("off", "balanced", "max_performance")

_DESIGN_PACKAGE = "controller.presets.designs"

#: Control period of the default design when none is given [s] (40 Hz, the IEA 15 MW deck).
SHIPPED_CONTROL_PERIOD_S = 0.025


#: Environment variable naming the user design cache (see :func:`user_design_dir`).
DESIGN_DIR_ENV = "FOWT_DESIGN_DIR"

#: Artefact kinds whose content depends on the control period (discrete gains and filters);
#: the observer artefact holds continuous models and is discretised at run time.
PERIOD_DEPENDENT_KINDS = ("lqri", "waveff")

_WHAT = {"lqri": "LQRI design", "waveff": "wave-FF design", "observer": "observer design"}


def period_tag(control_period_s: float) -> str:
    """File-name tag of a control period: ``0.025 -> "dt0p025"``, ``0.01 -> "dt0p01"``.

    Parameters
    ----------
    control_period_s : float
        Control period [s], > 0.

    Returns
    -------
    str
        ``"dt"`` followed by the period in seconds (9 significant digits, ``.`` as ``p``).
    """
    if not 0.0 < control_period_s < math.inf:
        raise ValueError(f"control_period_s = {control_period_s!r}: expected a finite value > 0")
    return "dt" + f"{control_period_s:.9g}".replace(".", "p").replace("-", "m").replace("+", "")


def artefact_stem(name: str, kind: str, control_period_s: float) -> str:
    """File stem of a design artefact (``<name>_<kind>[_dt<period>]``, no suffix).

    Parameters
    ----------
    name : str
        Design name: the stem of the plant preset it was designed for
        (e.g. ``"iea15mw_volturnus"``).
    kind : {"lqri", "waveff", "observer"}
        Artefact kind; the period-dependent kinds (:data:`PERIOD_DEPENDENT_KINDS`) carry
        :func:`period_tag`, the observer (continuous models) does not.
    control_period_s : float
        Control period [s].

    Returns
    -------
    str
        E.g. ``"iea15mw_volturnus_lqri_dt0p025"`` or ``"iea15mw_volturnus_observer"``.
    """
    if kind not in _WHAT:
        raise ValueError(f"unknown design artefact kind {kind!r}; known: {', '.join(_WHAT)}")
    if kind in PERIOD_DEPENDENT_KINDS:
        return f"{name}_{kind}_{period_tag(control_period_s)}"
    return f"{name}_{kind}"


def user_design_dir() -> Path:
    """The user design cache: ``$FOWT_DESIGN_DIR``, else ``$XDG_CACHE_HOME/fowt-hil/designs``
    (``~/.cache/fowt-hil/designs`` when ``XDG_CACHE_HOME`` is unset)."""
    env = os.environ.get(DESIGN_DIR_ENV, "").strip()
    if env:
        return Path(env).expanduser()
    cache = os.environ.get("XDG_CACHE_HOME", "").strip()
    base = Path(cache).expanduser() if cache else Path.home() / ".cache"
    return base / "fowt-hil" / "designs"


def design_search_path(design_dir: str | Path | None = None) -> list[Path | Traversable]:
    """Folders searched for a design artefact, in order.

    The shipped designs (``controller/presets/designs``), then ``design_dir`` when given, then
    the user design cache (:func:`user_design_dir`).
    """
    out: list[Path | Traversable] = [resources.files(_DESIGN_PACKAGE)]
    if design_dir is not None:
        out.append(Path(design_dir))
    cache = user_design_dir()
    if design_dir is None or Path(design_dir).resolve() != cache.resolve():
        out.append(cache)
    return out


def design_command(name: str, control_period_s: float) -> str:
    """The command that writes the artefacts of ``name`` at ``control_period_s``."""
    return f"fowt design {name} --control-period {control_period_s:.9g} --out {user_design_dir()}"


class DesignNotFoundError(ValueError):
    """A design artefact for the requested control period is in none of the searched folders.

    Attributes
    ----------
    name, kind : str
        Design name and artefact kind (``"lqri"``, ``"waveff"`` or ``"observer"``).
    control_period_s : float
        The control period asked for [s].
    searched : tuple of str
        The folders looked in.
    """

    def __init__(
        self, name: str, kind: str, control_period_s: float, searched: tuple[str, ...]
    ) -> None:
        self.name, self.kind, self.control_period_s = name, kind, control_period_s
        self.searched = searched
        stem = artefact_stem(name, kind, control_period_s)
        super().__init__(
            f"no {_WHAT[kind]} {stem}.npz for control period {control_period_s:.9g} s "
            f"(looked in {', '.join(searched)}); run `{design_command(name, control_period_s)}` "
            f"(or set {DESIGN_DIR_ENV} to the folder holding it)"
        )


def find_design(
    name: str, kind: str, control_period_s: float, design_dir: str | Path | None = None
) -> Path | Traversable:
    """The ``.npz`` of a design artefact for ``control_period_s`` (first hit on the search path).

    Parameters
    ----------
    name : str
        Design name (plant preset stem).
    kind : {"lqri", "waveff", "observer"}
    control_period_s : float
        Control period [s].
    design_dir : str or Path, optional
        Extra folder searched after the shipped designs (:func:`design_search_path`).

    Returns
    -------
    Path or Traversable
        The npz; its ``.json`` metadata lies beside it.

    Raises
    ------
    DesignNotFoundError
        If no searched folder holds both the npz and its json.
    """
    stem = artefact_stem(name, kind, control_period_s)
    folders = design_search_path(design_dir)
    for folder in folders:
        npz, js = folder / f"{stem}.npz", folder / f"{stem}.json"
        if npz.is_file() and js.is_file():
            return npz
    searched = tuple(
        "controller/presets/designs" if i == 0 else str(f) for i, f in enumerate(folders)
    )
    raise DesignNotFoundError(name, kind, control_period_s, searched)


def artefact_period_s(meta: dict[str, Any]) -> float | None:
    """Control period an artefact was designed for [s] (None for continuous models)."""
    value = meta.get("control_period_s", meta.get("settings", {}).get("control_period_s"))
    return None if value is None else float(value)


def load_design_artefact(
    name_or_path: str | Path,
    kind: str,
    control_period_s: float | None = None,
    design_dir: str | Path | None = None,
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Arrays of a design artefact's ``.npz`` and the parsed ``.json`` beside it.

    Parameters
    ----------
    name_or_path : str or Path
        A design name, looked up with :func:`find_design`, or a path to the npz.
    kind : {"lqri", "waveff", "observer"}
    control_period_s : float, optional
        The runtime's control period [s]; None takes the shipped 0.025 s design for a name
        and skips the check for a path.
    design_dir : str or Path, optional
        Extra folder searched (:func:`design_search_path`).

    Returns
    -------
    arrays : dict of ndarray
    meta : dict

    Raises
    ------
    DesignNotFoundError
        If a named artefact is missing for the period.
    ValueError
        If the artefact was designed for another control period than ``control_period_s``
        (discrete gains and filters are only valid at their design period).
    """
    if isinstance(name_or_path, Path) or str(name_or_path).endswith(".npz"):
        ref: Path | Traversable = Path(name_or_path)
        if not ref.is_file():
            raise ValueError(f"{_WHAT[kind]} {name_or_path} does not exist")
    else:
        dt = SHIPPED_CONTROL_PERIOD_S if control_period_s is None else control_period_s
        ref = find_design(str(name_or_path), kind, dt, design_dir)
    with resources.as_file(ref) as path, np.load(path, allow_pickle=False) as z:
        arrays = {k: np.array(v) for k, v in z.items()}
        meta: dict[str, Any] = json.loads(path.with_suffix(".json").read_text())
    period = artefact_period_s(meta)
    if (
        control_period_s is not None
        and period is not None
        and abs(period - control_period_s) > 1e-9 * max(1.0, control_period_s)
    ):
        raise ValueError(
            f"{_WHAT[kind]} {name_or_path} was designed for a control period of {period:.9g} s, "
            f"the controller runs at {control_period_s:.9g} s; run "
            f"`{design_command(str(meta.get('preset', name_or_path)), control_period_s)}`"
        )
    return arrays, meta


class LqriMeasurement(msgspec.Struct, frozen=True, kw_only=True):
    """What the observers give the LQRI each cycle (SI units).

    Attributes
    ----------
    wind_speed_estimate_m_s : float
        Rotor-effective wind estimate for scheduling and the regime switch (m/s).
    rotor_speed_rad_s : float
        Rotor (LSS) speed (rad/s).
    blade_pitch_rad : float
        Measured collective pitch (rad).
    platform_surge_m, platform_pitch_rad, tower_top_deflection_m : float
        Estimated positions (m, rad, m): tower-top deflection is the tower mode coordinate s.
    platform_surge_rate_m_s, platform_pitch_rate_rad_s, tower_top_deflection_rate_m_s : float
        Estimated rates.
    wave_elevation_forecast_m : float
        Predicted elevation η̂₀(t + t_d) at the platform (m); NaN when no forecast.
    torque_law_nm : float
        Generator torque (N m) of the below-rated torque law for this cycle (the baseline's
        region 1 / 1.5 / 2 / 2.5 / 3 law, :class:`controller.runtime.AdvancedController`);
        NaN: the LQRI's own fallback law min(K ω², T_rated) (no minimum-speed region).
    pitch_below_rated_rad : float
        Pitch command (rad) of the below-rated pitch law for this cycle (the baseline's PI,
        at fine pitch below rated); NaN: fine pitch θ_min (approached at the rate limit).
    regime_below_rated : int
        Regime code the below-rated laws report (``controller.core.REGIME_*``).
    """

    wind_speed_estimate_m_s: float
    rotor_speed_rad_s: float
    blade_pitch_rad: float
    platform_surge_m: float = 0.0
    platform_pitch_rad: float = 0.0
    tower_top_deflection_m: float = 0.0
    platform_surge_rate_m_s: float = 0.0
    platform_pitch_rate_rad_s: float = 0.0
    tower_top_deflection_rate_m_s: float = 0.0
    wave_elevation_forecast_m: float = math.nan
    torque_law_nm: float = math.nan
    pitch_below_rated_rad: float = math.nan
    regime_below_rated: int = REGIME_REGION_2


class LqriState(msgspec.Struct, frozen=True, gc=False):
    """Controller state between calls (all SI).

    ``integrator_rad`` is z = ∫(ω − ω_ref) dt (rad s); ``ff_state`` the states of all FF
    filters, an (m, n) array (None before the first FF step), ``ff_index`` the FF design
    nearest to the scheduling wind (−1: none); ``feedforward`` g·(c z + d η̂) in the unit of
    its input, also split into ``feedforward_pitch_rad`` and ``feedforward_torque_nm`` (the
    part applied to each command before limits; published for the log).
    """

    first_call: bool = True
    above_rated: bool = False
    integrator_rad: float = 0.0
    blade_pitch_commanded_rad: float = 0.0
    generator_torque_commanded_nm: float = 0.0
    feedforward: float = 0.0
    ff_index: int = -1
    ff_state: np.ndarray | None = None
    feedforward_pitch_rad: float = 0.0
    feedforward_torque_nm: float = 0.0


@dataclass(frozen=True, eq=False)
class LqriDesign:
    """Gain schedule and limits read from the artefact (see :func:`load_lqri_design`)."""

    wind_m_s: tuple[float, ...]
    k_x: tuple[tuple[float, ...], ...]
    k_i: tuple[float, ...]
    x_op: tuple[tuple[float, ...], ...]
    theta_op: tuple[float, ...]
    rated_torque_nm: float
    rated_rotor_speed_rad_s: float
    torque_gain_nm_s2: float
    torque_max_nm: float
    torque_rate_max_nm_s: float
    switch_wind_m_s: float
    hysteresis_m_s: float
    pitch_min_rad: float
    pitch_max_rad: float
    pitch_rate_max_rad_s: float
    control_period_s: float
    metadata: dict[str, object]


def load_lqri_design(
    name_or_path: str | Path = "iea15mw_volturnus",
    control_period_s: float | None = None,
    design_dir: str | Path | None = None,
) -> LqriDesign:
    """Load the LQRI gain schedule ``<name>_lqri_dt<T_s>.npz`` + ``.json``.

    Parameters
    ----------
    name_or_path : str or Path
        Design name (looked up on :func:`design_search_path`) or a path to the npz.
    control_period_s : float, optional
        The runtime's control period [s] (None: the shipped 0.025 s design; a path is then
        not checked).
    design_dir : str or Path, optional
        Extra folder searched after the shipped designs.

    Returns
    -------
    LqriDesign

    Raises
    ------
    DesignNotFoundError
        If no artefact for ``control_period_s`` is found.
    ValueError
        If the artefact was designed for another period.
    """
    arrays, meta = load_design_artefact(name_or_path, "lqri", control_period_s, design_dir)
    s = meta["settings"]
    sc = meta["scalars"]
    return LqriDesign(
        wind_m_s=tuple(float(v) for v in arrays["wind_m_s"]),
        k_x=tuple(tuple(float(v) for v in row) for row in arrays["k_x"]),
        k_i=tuple(float(v) for v in arrays["k_i"]),
        x_op=tuple(tuple(float(v) for v in row) for row in arrays["x_op"]),
        theta_op=tuple(float(v) for v in arrays["u_op"][:, 0]),
        rated_torque_nm=float(sc["rated_torque_nm"]),
        rated_rotor_speed_rad_s=float(sc["rated_rotor_speed_rad_s"]),
        torque_gain_nm_s2=float(sc["torque_gain_nm_s2"]),
        torque_max_nm=float(sc["torque_max_nm"]),
        torque_rate_max_nm_s=float(sc["torque_rate_max_nm_s"]),
        switch_wind_m_s=float(sc["rated_wind_m_s"]),
        hysteresis_m_s=float(s["switch_hysteresis_m_s"]),
        pitch_min_rad=float(s["pitch_min_rad"]),
        pitch_max_rad=float(s["pitch_max_rad"]),
        pitch_rate_max_rad_s=float(s["pitch_rate_max_rad_s"]),
        control_period_s=float(s["control_period_s"]),
        metadata=meta,
    )


@dataclass(frozen=True, eq=False)
class WaveFfDesign:
    """Wave-FF filters per scheduled wind, read from the artefact (:func:`load_wave_ff_design`).

    Attributes
    ----------
    wind_m_s : tuple of float
        Design winds (m/s), increasing.
    is_pitch : tuple of bool
        True where the filter output is pitch (rad), False for torque (N m).
    a : (m, n, n) array; b, c : (m, n) arrays; d : (m,) array
        Discrete filters at ``control_period_s``.
    control_period_s, delay_s : float
        T_s and the forecast preview t_d the filters expect (s).
    gain_table : dict
        ``{kind: (winds m/s, g)}`` of al-2019 Tab. 5-1.
    metadata : dict
        The json.
    """

    wind_m_s: tuple[float, ...]
    is_pitch: tuple[bool, ...]
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    control_period_s: float
    delay_s: float
    gain_table: dict[str, tuple[tuple[float, ...], tuple[float, ...]]]
    metadata: dict[str, object]

    def gain(self, kind: str, wind_m_s: float) -> float:
        """g(U) of ``kind`` (linear in U, ends held); 0 for ``"off"``."""
        if kind == "off":
            return 0.0
        winds, g = self.gain_table[kind]
        i, w = _interp(winds, wind_m_s)
        return (1.0 - w) * g[i] + w * g[min(i + 1, len(g) - 1)]


def load_wave_ff_design(
    name_or_path: str | Path = "iea15mw_volturnus",
    control_period_s: float | None = None,
    design_dir: str | Path | None = None,
) -> WaveFfDesign:
    """Load the wave-FF filters ``<name>_waveff_dt<T_s>.npz`` + ``.json``.

    Parameters and errors as :func:`load_lqri_design`.
    """
    arrays, meta = load_design_artefact(name_or_path, "waveff", control_period_s, design_dir)
    st = meta["settings"]
    table = {
        k: (tuple(float(x) for x in v["wind_m_s"]), tuple(float(x) for x in v["g"]))
        for k, v in meta["gain_table"].items()
    }
    return WaveFfDesign(
        wind_m_s=tuple(float(v) for v in arrays["wind_m_s"]),
        is_pitch=tuple(bool(v) for v in arrays["is_pitch"]),
        a=arrays["a"].astype(np.float64),
        b=arrays["b"].astype(np.float64),
        c=arrays["c"].astype(np.float64),
        d=arrays["d"].astype(np.float64),
        control_period_s=float(st["control_period_s"]),
        delay_s=float(st["delay_s"]),
        gain_table=table,
        metadata=meta,
    )


def _interp(grid: tuple[float, ...], u: float) -> tuple[int, float]:
    """Cell index i and weight w so that value = (1 − w) v_i + w v_{i+1} (ends held)."""
    n = len(grid)
    if n == 1 or u <= grid[0]:
        return 0, 0.0
    if u >= grid[-1]:
        return n - 2, 1.0
    i = bisect_right(grid, u) - 1
    return i, (u - grid[i]) / (grid[i + 1] - grid[i])


class LqriController:
    """Pure core: ``step(state, measurement, dt_s) -> (state, ControlOutput)``.

    Parameters
    ----------
    design : LqriDesign
        Gain schedule (:func:`load_lqri_design`).
    wave_ff : WaveFfDesign, optional
        Wave-FF filters (:func:`load_wave_ff_design`); required unless ``feedforward="off"``.
    feedforward : str
        One of :data:`FEEDFORWARD_KINDS` (per scenario), default ``"off"``.
    """

    def __init__(
        self, design: LqriDesign, wave_ff: WaveFfDesign | None = None, feedforward: str = "off"
    ) -> None:
        if feedforward not in FEEDFORWARD_KINDS:
            raise ValueError(f"feedforward = {feedforward!r}, expected one of {FEEDFORWARD_KINDS}")
        if feedforward != "off" and wave_ff is None:
            raise ValueError(f"feedforward = {feedforward!r} needs a wave-FF design")
        self.design = design
        self.wave_ff = wave_ff
        self._schedule = (  # the gain schedule as arrays for the compiled kernel
            np.array(design.wind_m_s, dtype=np.float64),
            np.array(design.k_x, dtype=np.float64).reshape(len(design.wind_m_s), -1),
            np.array(design.x_op, dtype=np.float64).reshape(len(design.wind_m_s), -1),
            np.array(design.k_i, dtype=np.float64),
            np.array(design.theta_op, dtype=np.float64),
            float(design.rated_rotor_speed_rad_s),
        )
        d = design
        self._limits = np.array(  # in the order of _kernels.LQRI_LIMITS
            [
                d.pitch_min_rad,
                d.pitch_max_rad,
                d.pitch_rate_max_rad_s,
                d.torque_max_nm,
                d.torque_rate_max_nm_s,
                d.rated_torque_nm,
                d.torque_gain_nm_s2,
                d.rated_rotor_speed_rad_s,
                REGIME_REGION_3,
                REGIME_REGION_2,
            ],
            dtype=np.float64,
        )
        self.feedforward = feedforward
        if wave_ff is not None:  # the filter matrices transposed, contiguous, for the kernel
            g_wind, g = (
                ((0.0,), (0.0,)) if feedforward == "off" else wave_ff.gain_table[feedforward]
            )
            self._ff = (
                np.array(wave_ff.wind_m_s, dtype=np.float64),
                np.array(wave_ff.is_pitch, dtype=np.bool_),
                np.array(g_wind, dtype=np.float64),
                np.array(g, dtype=np.float64),
                np.ascontiguousarray(wave_ff.a.transpose(0, 2, 1)),
                np.ascontiguousarray(wave_ff.b),
                np.ascontiguousarray(wave_ff.c),
                np.ascontiguousarray(wave_ff.d),
            )

    def _feedforward(
        self, state: LqriState, u: float, eta: float
    ) -> tuple[float, bool, int, np.ndarray | None]:
        """One step of every FF filter: (g·u_ff, is_pitch, nearest design, new filter states).

        :math:`u_{ff} = (1 - w)(c_i z_i + d_i \\hat\\eta) + w (c_{i+1} z_{i+1} + d_{i+1}
        \\hat\\eta)` with (i, w) the cell of U on the design grid; a NaN forecast holds all
        states and gives 0. One compiled call (:func:`controller._kernels.ff_cycle`).
        """
        ff = self.wave_ff
        if ff is None or self.feedforward == "off":
            return 0.0, False, -1, None
        zs = state.ff_state if state.ff_state is not None else np.zeros(ff.b.shape)
        zn = np.empty(zs.shape)
        u_ff, is_pitch, near = _kernels.ff_cycle(*self._ff, zs, float(u), float(eta), zn)
        return u_ff, bool(is_pitch), near, zn

    def initial_state(self) -> LqriState:
        """State before the first call."""
        return LqriState()

    def step(
        self, state: LqriState, m: LqriMeasurement, dt_s: float
    ) -> tuple[LqriState, ControlOutput]:
        """Advance one control period (module docstring, steps 1-4).

        Parameters
        ----------
        state : LqriState
        m : LqriMeasurement
        dt_s : float
            Time since the previous call (s), > 0.

        Returns
        -------
        state : LqriState
        output : ControlOutput
            ``pitch_integrator_rad`` carries K_i z (rad), ``gain_schedule_factor`` the
            scheduling wind (m/s), ``generator_speed_filtered_rad_s`` the rotor speed used.
        """
        if not 0.0 < dt_s < math.inf:
            raise ValueError(f"dt_s must be finite and > 0 s, got {dt_s!r}")
        d = self.design
        u = m.wind_speed_estimate_m_s
        w = m.rotor_speed_rad_s
        if state.first_call:
            th_prev = min(max(m.blade_pitch_rad, d.pitch_min_rad), d.pitch_max_rad)
            law0 = m.torque_law_nm
            tq_prev = law0 if math.isfinite(law0) else d.torque_gain_nm_s2 * w * w
            above = u >= d.switch_wind_m_s
        else:
            th_prev = state.blade_pitch_commanded_rad
            tq_prev = state.generator_torque_commanded_nm
            above = state.above_rated
        h = 0.5 * d.hysteresis_m_s
        if not above and (u >= d.switch_wind_m_s + h or w >= 1.02 * d.rated_rotor_speed_rad_s):
            above = True
            entering = True
        else:
            entering = state.first_call
            if above and u <= d.switch_wind_m_s - h and th_prev <= d.pitch_min_rad + 1e-4:
                above = False

        x = np.array(
            (
                m.platform_surge_m,
                m.platform_pitch_rad,
                m.tower_top_deflection_m,
                m.platform_surge_rate_m_s,
                m.platform_pitch_rate_rad_s,
                m.tower_top_deflection_rate_m_s,
                w,
                m.blade_pitch_rad,
            ),
            dtype=np.float64,
        )
        # K_x (x - x_op), K_i and θ_op interpolated in U (module docstring, step 3)
        fb, ki, th_op = _kernels.lqri_schedule(*self._schedule, float(u), x)
        u_ff, ff_pitch, ff_idx, ff_z = self._feedforward(state, u, m.wave_elevation_forecast_m)
        ff_th = u_ff if (ff_pitch and above) else 0.0
        ff_tq = 0.0 if ff_pitch else u_ff
        # limits, anti-windup and the torque law (module docstring, steps 2-4)
        th, tq, z, regime = _kernels.lqri_law(
            self._limits,
            above,
            entering,
            state.integrator_rad,
            th_prev,
            tq_prev,
            fb,
            ki,
            th_op,
            ff_th,
            ff_tq,
            w,
            m.torque_law_nm,
            m.pitch_below_rated_rad,
            m.regime_below_rated,
            dt_s,
        )
        new = LqriState(
            first_call=False,
            above_rated=above,
            integrator_rad=z,
            blade_pitch_commanded_rad=th,
            generator_torque_commanded_nm=tq,
            feedforward=u_ff,
            ff_index=ff_idx,
            ff_state=ff_z,
            feedforward_pitch_rad=ff_th,
            feedforward_torque_nm=ff_tq,
        )
        out = ControlOutput(
            blade_pitch_commanded_rad=th,
            generator_torque_commanded_nm=tq,
            regime=regime,
            generator_speed_filtered_rad_s=w,
            pitch_integrator_rad=ki * z if above else 0.0,
            gain_schedule_factor=u,
        )
        return new, out
