"""``fowt campaign``: load cases x seeds x controller variants as tasks on Dask distributed.

A campaign file (TOML, validated on load like a scenario: a wrong key or unit is an error
naming it) lists load cases (a scenario, optional overrides, the probability of occurrence),
the number of seeds, the controller variants, the run length, the mode, and whether each
case gets its still-water twin (same wind and seeds, ``waves.kind = "still"``). Shipped:
``hil/campaign/presets/al2019-iea15mw.toml`` (al-2019 table 2-2, load cases 1-7).

Runs
----
Every (case, waves/still, controller, seed) is one run. Seed index i (0 ... seeds - 1) adds
``i * seed_stride`` to the scenario's wind, wave and sensor seeds, so seed 0 is the scenario
as shipped and two campaigns with the same file run the same realisations. ``discard_s``
(optional): the start transient left out of every run's KPIs and PSDs, written into each
run's ``[review] settle_s`` (the one KPI window of review, report, compare and campaigns,
:func:`hil.review.kpi.window_start_s`): al-2019's protocol is 1200 s runs with the first 600 s
discarded. Unset: each scenario's own ``settle_s``. Each run is a Dask task
(:func:`execute_run`) running the in-process runner of ``fowt run --mode inprocess`` (plant
and controller in one process, :func:`hil.inprocess.run.run_inprocess`) or, with ``mode =
"lockstep"``, :func:`hil.launch.launch` (plant, controller and recorder as OS processes over
Zenoh). A task never raises: a failing run comes back with its error, is
recorded (``status = "failed"``) and the campaign goes on. The KPIs of a run depend only on
its scenario (seeded, simulated time), never on the worker or the order.

In process, the compiled loop hands its messages over as numpy rows (``publish_block``):
:class:`_RunSink` keeps them and builds the run's :class:`hil.runlog.mcap_io.RunData` from them
(each message's dict as ``orjson.loads`` of its Struct's JSON would give it; each topic a
:class:`hil.runlog.mcap_io.MessageList`, whose columns the review and the KPIs read), and
:class:`hil.runlog.writer.InProcessRunLog` writes ``run.mcap`` from them in this process with
the log writer's framer. 600 s of LC2 take about half the wall time they took as Structs
JSON-encoded one by one (bench/campaign_run_speed.py; docs/benchmarks.md).

Cluster: by default a :class:`distributed.LocalCluster` of processes, one per core (one
thread each), bound to 127.0.0.1, no dashboard, started and stopped by the command;
``--scheduler tcp://HOST:PORT`` submits to an existing cluster instead (the workers then need
fowt-hil installed and, with ``--record mcap``, ``OUT`` on a filesystem they share: the
worker writes ``run.mcap``, the client writes ``summary.json`` and the tables).

Output (``OUT``)
----------------
``runs/<case>/<controller>/s<i>/`` (the still-water twin: ``runs/<case>-still/...``) with
``summary.json`` (the review summary plus ``campaign``: identity, scenario hash, status,
error, KPIs, PSDs) and ``run.mcap`` (not with ``--record none``); ``results.parquet`` and
``results.csv`` (a row per run); ``aggregates.json``; ``report.html``. ``--resume`` skips runs
whose ``summary.json`` says ``ok`` for the same scenario hash (SHA-256 of the run's scenario
without its name and description, plus the mode).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import re
import time
import tomllib
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import msgspec
import numpy as np

from hil.campaign import kpi as ck
from hil.review import kpi_stats as kst
from hil.scenario.schema import (
    ControllerSection,
    Scenario,
    ScenarioError,
    _known_fields,
    key_at_text,
    resolve_paths,
    scenario_folder,
    scenario_text,
    settings_base_dir,
    unknown_key_text,
)

if TYPE_CHECKING:
    from rich.console import Console

Name = Annotated[str, msgspec.Meta(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$", max_length=64)]
Probability = Annotated[float, msgspec.Meta(ge=0.0, le=1.0)]
Mode = Literal["inprocess", "lockstep"]
Record = Literal["mcap", "none"]
STILL_SUFFIX = "-still"


class CampaignError(ValueError):
    """A campaign file that cannot be used, naming the key at fault."""


class _Section(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    pass


class CaseSpec(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One load case: a scenario (shipped name or path, relative to the campaign file), its
    occurrence probability ``probability`` (fraction, 0..1) and ``overrides`` (a table with
    the scenario's own keys, merged into it; a ``kind`` in ``wind`` or ``waves`` replaces
    that section)."""

    name: Name
    scenario: str
    probability: Probability
    overrides: dict[str, Any] = msgspec.field(default_factory=dict)


class ControllerVariant(ControllerSection, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One controller variant: a ``name`` and every key of a scenario's ``[controller]``.

    Any controller kind the bench finds (shipped, an installed plug-in, ``kind = "python"``
    with ``core``), with its keys (``preset``, ``forecaster``, ``feedforward``, ``library``,
    ``parameter_file``, the casanovas-2014 keys, ``settings`` as an inline table or a
    ``[controllers.settings]`` table, ...), validated when the campaign is read. The
    variant's section replaces the case scenario's ``[controller]`` in each of its runs.
    ``preset`` defaults to ``iea15mw_baseline`` (the campaigns' turbine); a variant's
    ``settings`` resolve their relative paths against the campaign file's folder.
    """

    name: Name
    preset: str = "iea15mw_baseline"

    def section(self) -> ControllerSection:
        """The scenario's ``[controller]`` section of this variant."""
        fields = {f: getattr(self, f) for f in ControllerSection.__struct_fields__}
        return ControllerSection(**fields)


class CampaignFile(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A campaign: ``cases`` x ``seeds`` x ``controllers`` (module docstring)."""

    name: Name
    cases: list[CaseSpec]
    controllers: list[ControllerVariant]
    description: str = ""
    duration_s: Annotated[float, msgspec.Meta(gt=0.0)] = 600.0
    seeds: Annotated[int, msgspec.Meta(ge=1, le=1000)] = 1
    seed_stride: Annotated[int, msgspec.Meta(ge=1)] = 1000
    mode: Mode = "inprocess"
    baseline: str = "baseline"
    still_water: bool = True
    still_water_controllers: list[str] | None = None
    min_rotor_speed_rad_s: Annotated[float, msgspec.Meta(ge=0.0)] | None = None
    #: λ* [-] of Ω_opt in var(Ω − Ω_opt), written into every run's ``[review] tsr_opt`` (so
    #: it is part of the scenario hash); None: each scenario's own (default: from the Cp table).
    tsr_opt: Annotated[float, msgspec.Meta(gt=0.0)] | None = None
    #: start transient [s] left out of every run's KPIs: written into each run's
    #: ``[review] settle_s`` (the one KPI window of review, report, compare and campaigns).
    discard_s: Annotated[float, msgspec.Meta(ge=0.0)] | None = None

    def __post_init__(self) -> None:
        if self.discard_s is not None and not self.discard_s < self.duration_s:
            raise ValueError(
                f"discard_s = {self.discard_s:g} s: expected < duration_s = {self.duration_s:g} s"
            )
        if not self.cases:
            raise ValueError("cases: expected at least one [[cases]] table")
        if not self.controllers:
            raise ValueError("controllers: expected at least one [[controllers]] table")
        for label, names in (
            ("cases", [c.name for c in self.cases]),
            ("controllers", [c.name for c in self.controllers]),
        ):
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"{label}: duplicate name {dup[0]!r}")
        for i, c in enumerate(self.cases):
            if c.name.endswith(STILL_SUFFIX):
                raise ValueError(
                    f"cases[{i}].name = {c.name!r}: a name may not end in {STILL_SUFFIX!r} "
                    "(the still-water twins' folders are named so)"
                )
        names = [c.name for c in self.controllers]
        if self.baseline not in names:
            raise ValueError(
                f"baseline = {self.baseline!r}: expected one of the controllers' names {names}"
            )
        for n in self.still_water_controllers or []:
            if n not in names:
                raise ValueError(
                    f"still_water_controllers: {n!r} is not a controller name (names: {names})"
                )
        total = sum(c.probability for c in self.cases)
        if total > 1.0 + 1e-6:
            raise ValueError(f"cases: probabilities sum to {total:.4f}, expected <= 1")
        if not total > 0.0:
            raise ValueError("cases: probabilities sum to 0 (the Weibull weights need one > 0)")

    @property
    def twin_controllers(self) -> list[str]:
        """Controllers that get a still-water twin (default: the baseline only)."""
        if not self.still_water:
            return []
        return list(self.still_water_controllers or [self.baseline])


@dataclass(frozen=True)
class RunSpec:
    """One run of a campaign: identity, the full validated scenario and its hash."""

    case: str
    controller: str
    waves: Literal["waves", "still"]
    seed: int
    probability: float
    scenario: dict[str, Any] = field(repr=False)
    scenario_hash: str = ""

    @property
    def rel_dir(self) -> str:
        """``runs/<case>[-still]/<controller>/s<seed>``."""
        case = self.case + (STILL_SUFFIX if self.waves == "still" else "")
        return f"runs/{case}/{self.controller}/s{self.seed}"

    @property
    def label(self) -> str:
        """Short text naming the run."""
        return f"{self.case}/{self.waves}/{self.controller}/s{self.seed}"


@dataclass(frozen=True)
class Campaign:
    """A loaded campaign: the file's contents, where it came from and its runs."""

    spec: CampaignFile
    source: str
    runs: tuple[RunSpec, ...]

    @property
    def case_probabilities(self) -> dict[str, float]:
        """Case name -> occurrence probability, in file order."""
        return {c.name: c.probability for c in self.spec.cases}


# --------------------------------------------------------------------------- loading


_SECTIONS: dict[str, type[msgspec.Struct]] = {
    "cases": CaseSpec,
    "controllers": ControllerVariant,
}


def _known(path: str) -> list[str]:
    parts = [p for p in path.lstrip("$").split(".") if p]
    if parts:
        head = parts[0].split("[", 1)[0]
        cls = _SECTIONS.get(head)
        if cls is not None:
            return list(cls.__struct_fields__)
    return list(CampaignFile.__struct_fields__)


def _deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in over.items():
        if (
            isinstance(value, dict)
            and isinstance(out.get(key), dict)
            and not (key in ("wind", "waves") and "kind" in value)
        ):
            out[key] = _deep_merge(out[key], value)
        else:
            out[key] = value
    return out


def canonical_hash(scenario: dict[str, Any], mode: str) -> str:
    """SHA-256 of the scenario's content (name and description left out) and the mode."""
    content = {k: v for k, v in scenario.items() if k not in ("name", "description")}
    blob = json.dumps({"scenario": content, "mode": mode}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()


def _seeded(d: dict[str, Any], offset: int) -> dict[str, Any]:
    out = dict(d)
    for section in ("wind", "waves", "sensors"):
        sec = out.get(section)
        if isinstance(sec, dict) and "seed" in sec:
            out[section] = {**sec, "seed": int(sec["seed"]) + offset}
    return out


def _still(d: dict[str, Any]) -> dict[str, Any]:
    waves = d.get("waves") or {}
    still: dict[str, Any] = {"kind": "still"}
    for key in ("gauge_distance_m", "depth_m", "seed"):
        if waves.get(key) is not None:
            still[key] = waves[key]
    return {**d, "waves": still}


def _convert(d: dict[str, Any], where: str) -> Scenario:
    try:
        return msgspec.convert(d, Scenario)
    except msgspec.ValidationError as exc:
        msg = str(exc)
        unknown = unknown_key_text(msg, _known_fields)
        if unknown is not None:
            raise CampaignError(f"{where}: unknown scenario key {unknown}") from exc
        raise CampaignError(f"{where}: {msg}") from exc


def _scenario_base(ref: str, base_dir: Path, where: str) -> dict[str, Any]:
    path = Path(ref)
    if path.suffix == ".toml" and not path.is_absolute():
        path = base_dir / path
    scenario = str(path) if path.suffix == ".toml" else ref
    try:
        text, source = scenario_text(scenario)
    except ScenarioError as exc:
        raise CampaignError(f"{where}: {exc}") from exc
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CampaignError(f"{where}: {source}: not valid TOML: {exc}") from exc
    folder = scenario_folder(scenario)
    try:  # the scenario's own file paths: from its folder, as when it runs alone
        raw = resolve_paths(raw, folder, source)
    except ScenarioError as exc:
        raise CampaignError(f"{where}: {exc}") from exc
    settings_base_dir(raw, folder)
    # Validate the scenario as shipped first, so its own errors name its file.
    _convert(raw, f"{where} ({source})")
    return raw


def _campaign_paths(d: dict[str, Any], base_dir: Path, where: str) -> dict[str, Any]:
    """The file paths the campaign file gave (overrides, controllers) taken from its folder;
    the scenario's own are absolute already (:func:`_scenario_base`)."""
    try:
        return resolve_paths(d, base_dir)
    except ScenarioError as exc:
        raise CampaignError(f"{where}: {exc}") from exc


def expand(spec: CampaignFile, base_dir: Path) -> tuple[RunSpec, ...]:
    """Every run of a campaign, each scenario merged, seeded and validated.

    Order: case, then waves before still, then controller, then seed (file order).

    Raises
    ------
    CampaignError
        Naming the case (``cases[i]``), the controller and the key at fault.
    """
    runs: list[RunSpec] = []
    twins = spec.twin_controllers
    for i, case in enumerate(spec.cases):
        where = f"cases[{i}] ({case.name})"
        raw = _scenario_base(case.scenario, base_dir, where)
        merged = _campaign_paths(_deep_merge(raw, case.overrides), base_dir, where)
        merged["duration_s"] = spec.duration_s
        if spec.tsr_opt is not None:
            merged["review"] = {**(merged.get("review") or {}), "tsr_opt": spec.tsr_opt}
        if spec.discard_s is not None:  # the run's own review windows its KPIs alike
            merged["review"] = {**(merged.get("review") or {}), "settle_s": spec.discard_s}
        _convert(merged, f"{where}.overrides")
        kinds: list[Literal["waves", "still"]] = ["waves"]
        if twins:
            if merged.get("waves") is None:
                raise CampaignError(
                    f"{where}: still_water = true needs a [waves] section in the scenario "
                    "(a floating plant); set still_water = false for this campaign"
                )
            kinds.append("still")
        for waves in kinds:
            for variant in spec.controllers:
                if waves == "still" and variant.name not in twins:
                    continue
                for seed in range(spec.seeds):
                    d = _seeded(merged, seed * spec.seed_stride)
                    if waves == "still":
                        d = _still(d)
                    holder = {"controller": msgspec.to_builtins(variant.section())}
                    settings_base_dir(holder, base_dir)  # a variant's settings: the file's
                    d["controller"] = holder["controller"]
                    d = _campaign_paths(d, base_dir, f"{where}, controller {variant.name!r}")
                    label = f"{spec.name}-{case.name}-{variant.name}-{waves}-s{seed}"
                    d["name"] = label
                    sc = _convert(d, f"{where}, controller {variant.name!r}, seed {seed}")
                    full = msgspec.to_builtins(sc)
                    runs.append(
                        RunSpec(
                            case=case.name,
                            controller=variant.name,
                            waves=waves,
                            seed=seed,
                            probability=case.probability,
                            scenario=full,
                            scenario_hash=canonical_hash(full, spec.mode),
                        )
                    )
    return tuple(runs)


def parse_campaign(text: str, source: str = "<string>", base_dir: Path | None = None) -> Campaign:
    """Parse, validate and expand campaign TOML text.

    Raises
    ------
    CampaignError
        Naming the file and the key at fault (with the key meant, when it is a known key
        with another unit).
    """
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CampaignError(f"{source}: not valid TOML: {exc}") from exc
    try:
        spec = msgspec.convert(raw, CampaignFile)
    except msgspec.ValidationError as exc:
        msg = str(exc)
        unknown = unknown_key_text(msg, _known)
        if unknown is not None:
            raise CampaignError(f"{source}: unknown key {unknown}") from exc
        text = key_at_text(msg)
        # a variant's [controller] error names its key as a scenario's: say which variant
        variant = re.match(r"key '(controllers\[\d+\])': controller\.(.*)$", text)
        if variant is not None:
            text = f"{variant.group(1)}.{variant.group(2)}"
        raise CampaignError(f"{source}: {text}") from exc
    try:
        runs = expand(spec, base_dir or Path.cwd())
    except CampaignError as exc:
        raise CampaignError(f"{source}: {exc}") from exc
    return Campaign(spec=spec, source=source, runs=runs)


def shipped_campaigns() -> list[str]:
    """Names of the campaigns shipped with the package (``hil/campaign/presets/*.toml``)."""
    root = Path(__file__).parent / "presets"
    return sorted(p.stem for p in root.glob("*.toml"))


def load_campaign(name_or_path: str) -> Campaign:
    """Load a shipped campaign by name or a campaign file by path."""
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise CampaignError(f"campaign file {path} does not exist")
        return parse_campaign(path.read_text(), str(path), path.parent)
    shipped = Path(__file__).parent / "presets" / f"{name_or_path}.toml"
    if not shipped.is_file():
        raise CampaignError(
            f"no campaign {name_or_path!r}: expected a .toml path or one of {shipped_campaigns()}"
        )
    return parse_campaign(
        shipped.read_text(), f"hil/campaign/presets/{shipped.name}", shipped.parent
    )


def select(
    campaign: Campaign,
    cases: Sequence[str] | None = None,
    controllers: Sequence[str] | None = None,
    seeds: int | None = None,
    duration_s: float | None = None,
    baseline: str | None = None,
) -> Campaign:
    """A reduced campaign: some cases, some controllers, fewer seeds or another length.

    The baseline (and its still-water twins) stays whatever ``controllers`` says, since the
    aggregates are relative to it. ``baseline`` names another controller of the campaign to
    compare with (it then gets the still-water twins instead), e.g. ``lqri`` to isolate what
    the wave feedforward of ``lqri_ff`` adds.

    Raises
    ------
    CampaignError
        For a name that is not in the campaign.
    """
    spec = campaign.spec
    case_names = [c.name for c in spec.cases]
    ctrl_names = [c.name for c in spec.controllers]
    for asked, known, what in (
        (cases, case_names, "case"),
        (controllers, ctrl_names, "controller"),
    ):
        for n in asked or []:
            if n not in known:
                raise CampaignError(f"--{what}s: no {what} {n!r} (names: {', '.join(known)})")
    if baseline is not None and baseline not in ctrl_names:
        raise CampaignError(f"--baseline: no controller {baseline!r} (names: {ctrl_names})")
    base = baseline or spec.baseline
    twins = spec.twin_controllers
    if baseline is not None and twins:
        twins = [baseline]
    keep_ctrl = set(controllers or ctrl_names) | {base}
    new = msgspec.structs.replace(
        spec,
        baseline=base,
        cases=[c for c in spec.cases if cases is None or c.name in cases],
        controllers=[c for c in spec.controllers if c.name in keep_ctrl],
        seeds=seeds if seeds is not None else spec.seeds,
        duration_s=duration_s if duration_s is not None else spec.duration_s,
        still_water_controllers=[n for n in twins if n in keep_ctrl] or None,
    )
    src = Path(campaign.source)
    base_dir = src.parent if src.exists() else Path(__file__).parent / "presets"
    return Campaign(spec=new, source=campaign.source, runs=expand(new, base_dir))


# --------------------------------------------------------------------------- one run (task)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        return repr(v) if isinstance(v, int) or math.isfinite(v) else "nan"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def to_toml(d: dict[str, Any], prefix: str = "") -> str:
    """A scenario dict (plain values, tables, arrays of tables) as TOML text."""
    lines: list[str] = []
    tables: list[tuple[str, dict[str, Any]]] = []
    arrays: list[tuple[str, list[dict[str, Any]]]] = []
    for k, v in d.items():
        if v is None:
            continue
        if isinstance(v, dict):
            tables.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            arrays.append((k, v))
        else:
            lines.append(f"{k} = {_toml_value(v)}")
    for k, v in tables:
        name = f"{prefix}{k}"
        lines.append(f"\n[{name}]")
        lines.append(to_toml(v, name + ".").strip("\n"))
    for k, items in arrays:
        for item in items:
            lines.append(f"\n[[{prefix}{k}]]")
            lines.append(to_toml(item, f"{prefix}{k}.").strip("\n"))
    return "\n".join(x for x in lines if x != "") + "\n"


@lru_cache(maxsize=8)
def _turbine_figures(turbine: str) -> tuple[float, float, float]:
    """(λ*, R [m], Ω_rated [rad/s]) of a turbine preset.

    λ* is the default of ``[review] tsr_opt``: the argmax over λ of Cp(λ, θ = 0) as the
    plant evaluates the table (:meth:`plant.aero.AeroTable.optimal_tsr`; bilinear, so a
    grid point of the table).
    """
    from plant.turbine import load_turbine  # noqa: PLC0415

    params = load_turbine(turbine)
    return (
        float(params.table.optimal_tsr(0.0)),
        float(params.rotor_radius_m),
        float(params.rated_rotor_speed_rad_s),
    )


def _psd(t: np.ndarray, x: np.ndarray, f_max_hz: float = 0.5) -> dict[str, list[float]]:
    """Welch PSD (600-s records: 0.004 Hz bins) up to ``f_max_hz``, for the report."""
    from scipy.signal import welch  # noqa: PLC0415

    if t.size < 64 or not np.isfinite(x).all():
        return {"f_hz": [], "pxx": []}
    dt = float(np.median(np.diff(t)))
    nper = min(t.size, round(256.0 / dt))
    f, p = welch(x, fs=1.0 / dt, nperseg=nper, detrend="constant")
    sel = (f > 0) & (f <= f_max_hz)
    return {"f_hz": [float(v) for v in f[sel]], "pxx": [float(v) for v in p[sel]]}


def run_kpis_of(run_data: Any, scenario: Scenario, min_rad_s: float | None) -> dict[str, Any]:
    """Campaign KPIs (:data:`hil.campaign.kpi.KPIS`) and PSDs of a run's messages.

    Parameters
    ----------
    run_data : hil.runlog.mcap_io.RunData
        The run's messages (from memory or from its MCAP file).
    scenario : Scenario
        The run's scenario: its turbine gives R, the rated speed and the default λ*,
        ``[review] tsr_opt`` overrides λ*, ``[review] settle_s`` sets the KPI window.
    min_rad_s : float or None
        Ω_min [rad/s] of Ω_opt; None: :data:`hil.campaign.kpi.MIN_ROTOR_SPEED_RAD_S` of the
        turbine (0 if unknown).

    Returns
    -------
    dict
        ``kpi`` (over the KPI window [t_0, t_end], t_0 = :func:`hil.review.kpi.window_start_s` of
        ``[review] settle_s``: the window of ``fowt review``, ``report`` and ``compare``),
        ``psd`` (the same window), ``kpi_window`` (``from_s``, ``to_s``, ``settle_s``,
        ``tsr_opt``, ``min_rotor_speed_rad_s``).
    """
    from hil.review import kpi  # noqa: PLC0415
    from hil.review.core import _col, _since  # noqa: PLC0415

    truth = run_data.topic("truth")
    t_all = _col(truth, "sample_time_ns") / 1e9
    t_fin = t_all[np.isfinite(t_all)]
    end = float(t_fin.max()) if t_fin.size else math.nan
    t0 = kpi.window_start_s(end, scenario.review.settle_s)
    truth = _since(truth, t0)
    t = _col(truth, "sample_time_ns") / 1e9
    names = (
        "electrical_power_w",
        "rotor_speed_rad_s",
        "wind_speed_m_s",
        "blade_pitch_rad",
        "tower_base_moment_nm",
        "shaft_torque_nm",
        "platform_pitch_rad",
        "platform_surge_m",
    )
    cols = {n: _col(truth, n) for n in names}
    summaries = [s for s in run_data.topic("timing/summary") if int(s.get("final", 0)) == 1]
    misses = int(summaries[-1]["deadline_misses"]) if summaries else None
    tsr, radius, rated = _turbine_figures(scenario.turbine)
    if scenario.review.tsr_opt is not None:
        tsr = float(scenario.review.tsr_opt)
    if min_rad_s is None:
        min_rad_s = ck.MIN_ROTOR_SPEED_RAD_S.get(Path(scenario.turbine).stem, 0.0)
    kpis = ck.run_kpis(t, cols, misses, tsr, radius, rated, min_rad_s)
    psd = {
        "rotor_speed_rpm": _psd(t, cols["rotor_speed_rad_s"] * ck.RPM_PER_RAD_S),
        "platform_pitch_deg": _psd(t, np.degrees(cols["platform_pitch_rad"])),
        "tower_base_moment_mnm": _psd(t, cols["tower_base_moment_nm"] / 1e6),
    }
    window = {
        "settle_s": scenario.review.settle_s,
        "from_s": t0,
        "to_s": end,
        "tsr_opt": tsr,
        "min_rotor_speed_rad_s": min_rad_s,
    }
    return {"kpi": kpis, "psd": psd, "kpi_window": window}


class _RunSink:
    """A campaign run's messages as the in-process loop hands them over, kept for its
    :class:`hil.runlog.mcap_io.RunData` (and its MCAP file, when ``log`` is given).

    The compiled loop's rows (:meth:`publish_block`) are kept as numpy blocks; the Python
    path's Structs (:meth:`publish`) as they come; each topic's parts in publish order.
    :meth:`run_data` then builds each message's dict as ``orjson.loads`` of msgspec's JSON
    of its Struct gives it (the path before: every message JSON-encoded when published and
    decoded at the end): a row's float fields as floats, a non-finite one as None (JSON's
    ``null``), its int fields as ints; Structs through that very round trip, one list per
    part. No Struct per row and no JSON for them.
    """

    def __init__(self, turbine: str, log: Any = None) -> None:
        from bus_schemas.registry import MESSAGES  # noqa: PLC0415

        self.log = log
        self._key = {mt.message_id: mt.key(turbine) for mt in MESSAGES}
        self._by_id = {mt.message_id: mt for mt in MESSAGES}
        self._suffix = {mt.key(turbine): mt.key_suffix for mt in MESSAGES}
        # per topic: its parts in publish order, each a list of Structs or an array of rows
        self.parts: dict[str, list[list[msgspec.Struct] | np.ndarray]] = {}

    def publish(self, mt: Any, msg: msgspec.Struct) -> None:
        """Keep one message given as a Struct (the Python path's)."""
        parts = self.parts.setdefault(self._key[mt.message_id], [])
        if parts and isinstance(parts[-1], list):
            parts[-1].append(msg)
        else:
            parts.append([msg])
        if self.log is not None:
            self.log.publish(mt, msg)

    def publish_block(self, order: np.ndarray, rows: dict[int, np.ndarray]) -> None:
        """Keep a block of rows (:attr:`bus_schemas.registry.MessageType.row_dtype`),
        copied: the caller reuses its buffers."""
        if self.log is not None:
            self.log.publish_block(order, rows)  # checks order against the rows
        for mid, block in rows.items():
            if len(block):
                self.parts.setdefault(self._key[mid], []).append(block.copy())

    def published(self) -> dict[str, int]:
        """Messages kept so far per key suffix (what the end-of-run reports count)."""
        return {self._suffix[k]: sum(len(p) for p in parts) for k, parts in self.parts.items()}

    def run_data(self, metadata: dict[str, dict[str, str]]) -> Any:
        """The run's :class:`hil.runlog.mcap_io.RunData` (class docstring)."""
        import orjson  # noqa: PLC0415

        from hil.runlog.mcap_io import MessageList, RunData  # noqa: PLC0415

        encode = msgspec.json.encode
        run = RunData(metadata=metadata)
        for key, parts in self.parts.items():
            out: list[dict[str, Any]] = []
            spans: list[tuple[int, int, np.ndarray | None]] = []
            for part in parts:
                start = len(out)
                if isinstance(part, list):
                    out.extend(orjson.loads(encode(part)))
                    spans.append((start, len(out), None))
                else:
                    out.extend(_row_dicts(part))
                    spans.append((start, len(out), part))
            run.messages[key] = MessageList(out, spans)
        return run


def _row_dicts(block: np.ndarray) -> list[dict[str, Any]]:
    """Rows of a ``row_dtype`` as the dicts ``orjson.loads`` makes of their Structs' JSON.

    A float field is a float (a row holds float64; the Struct built from it writes ``0.0``),
    NaN and infinities None (msgspec writes ``null``), an int field an int.
    """
    dtype = block.dtype
    names = dtype.names or ()
    # each row's tuple has the dtype's fields: no strict check per row (~0.3 us each)
    out = [dict(zip(names, r)) for r in block.tolist()]  # noqa: B905
    floats = [n for n in names if dtype[n].kind == "f"]
    if floats:
        values = block.view(np.float64).reshape(len(block), len(names))
        cols = [names.index(n) for n in floats]
        bad = ~np.isfinite(values[:, cols])
        if bad.any():
            for i, j in zip(*np.nonzero(bad), strict=True):
                out[int(i)][floats[int(j)]] = None
    return out


def _inprocess(
    scenario: Scenario,
    mcap_path: Path | None,
    toml_text: str,
    design_dir: str | None,
    faults: list[Any] | None = None,
) -> Any:
    """Run in process; the messages kept in memory (and written to ``mcap_path``).

    ``faults`` gets the controller core's fault, if it faulted
    (:class:`hil.nodes.controller_fault.ControllerFault`; its text also goes beside
    ``mcap_path``).

    The compiled loop hands its messages over as rows (:class:`_RunSink`), the Python
    path's (a scenario the compiled loop does not run, or its cycles that need Python) come
    as Structs.
    """
    from bus_schemas.registry import CONTROLLER_REPORT  # noqa: PLC0415
    from hil.inprocess.run import run_inprocess  # noqa: PLC0415
    from hil.inprocess.trim import operating_point  # noqa: PLC0415
    from hil.nodes.controller_fault import write_fault  # noqa: PLC0415
    from hil.nodes.controller_node import (  # noqa: PLC0415
        ControllerRuntime,
        controller_report,
        publishing_step,
    )
    from hil.nodes.recorder import scenario_metadata  # noqa: PLC0415

    turbine = scenario.turbine_id
    metadata: dict[str, Any] = {
        "scenario": scenario_metadata(scenario, toml_text),
        "run": {
            "mode": "inprocess",
            "speed": "0",
            "transport": "none",
            "duration_s": f"{scenario.duration_s:g}",
            "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "command": "fowt campaign",
        },
    }
    from hil.runlog.writer import InProcessRunLog  # noqa: PLC0415

    log = InProcessRunLog(mcap_path, turbine, metadata) if mcap_path is not None else None
    sink = _RunSink(turbine, log)
    try:
        runtime = ControllerRuntime(
            scenario,
            design_dir=design_dir,
            paced=False,
            operating_point=functools.partial(operating_point, scenario),
        )
        step = publishing_step(runtime, sink.publish)
        run_inprocess(
            scenario,
            sink.publish,
            step,
            runtime=runtime,
            publish_block=sink.publish_block,
            published=sink.published,  # the plant's report follows its final summary
        )
        counts = sink.published()  # the controller's report goes last, as in fowt run
        report = controller_report(
            runtime, counts.get("command", 0), counts.get("controller/status", 0), aborted=False
        )
        sink.publish(CONTROLLER_REPORT, report)
        if runtime.fault is not None:
            if faults is not None:
                faults.append(runtime.fault)
            if mcap_path is not None:
                write_fault(mcap_path.parent, runtime.fault)
    finally:
        if log is not None:
            log.close()
    return sink.run_data(metadata)


def execute_run(payload: dict[str, Any]) -> dict[str, Any]:
    """Run one campaign run; never raises (a failure comes back as ``status = "failed"``).

    Parameters
    ----------
    payload : dict
        ``scenario`` (the full scenario dict), ``mode`` (``inprocess`` | ``lockstep``),
        ``run_dir`` (the run's folder; ``run.mcap`` goes there unless ``record`` is
        ``"none"``), ``record``, ``design_dir`` (or None), ``min_rotor_speed_rad_s`` (the
        campaign's ``discard_s`` is the scenario's ``[review] settle_s`` by then).

    Returns
    -------
    dict
        ``status``, ``error``, ``traceback``, ``summary`` (the review summary),
        ``kpi``, ``psd``, ``wall_s``, ``cpu_s`` (the worker process's CPU time for the
        run), ``worker`` (host:pid).
    """
    t0 = time.monotonic()
    cpu0 = time.process_time()
    out: dict[str, Any] = {
        "status": "failed",
        "error": "",
        "traceback": "",
        "summary": None,
        "kpi": {},
        "psd": {},
        "worker": f"{os.uname().nodename}:{os.getpid()}",
    }
    from hil.nodes.controller_fault import ControllerFaultError  # noqa: PLC0415

    try:
        from hil.review.core import summarize, with_fault_text  # noqa: PLC0415
        from hil.review.outcome import record_outcome  # noqa: PLC0415

        scenario = msgspec.convert(payload["scenario"], Scenario)
        toml_text = to_toml(payload["scenario"])
        run_dir = Path(payload["run_dir"])
        record = payload.get("record", "mcap") == "mcap"
        faults: list[Any] = []
        if payload.get("mode", "inprocess") == "lockstep":
            run_data = _lockstep(scenario, toml_text, run_dir, record, faults)
        else:
            if record:
                run_dir.mkdir(parents=True, exist_ok=True)
            mcap = run_dir / "run.mcap" if record else None
            run_data = _inprocess(scenario, mcap, toml_text, payload.get("design_dir"), faults)
        summary = summarize(run_data)
        if record:
            summary["run"]["source"] = str(run_dir / "run.mcap")
        summary["run"]["mode"] = payload.get("mode", "inprocess")
        # The verdict fowt run would give this run (a core's fault by its text, exit 7).
        with_fault_text(summary, faults[0].to_dict() if faults else None)
        code = record_outcome(summary)
        out["outcome"], out["exit_code"] = code.word, int(code)
        out.update(
            run_kpis_of(
                run_data,
                scenario,
                payload.get("min_rotor_speed_rad_s"),
            )
        )
        out["summary"] = summary
        out["status"] = "ok"
    except ControllerFaultError as exc:  # in the trim's settling run: nothing ran after it
        out["error"] = str(exc)
        out["outcome"], out["exit_code"] = "controller_fault", 7
    except Exception as exc:
        out["error"] = f"{type(exc).__name__}: {exc}"
        out["traceback"] = traceback.format_exc()
    out["wall_s"] = time.monotonic() - t0
    out["cpu_s"] = time.process_time() - cpu0  # this process's CPU time (lockstep: launcher only)
    return out


def _lockstep(
    scenario: Scenario,
    toml_text: str,
    run_dir: Path,
    record: bool,
    faults: list[Any] | None = None,
) -> Any:
    """A lock-step run through :func:`hil.launch.launch` (OS processes over Zenoh).

    ``faults`` gets the controller core's fault, if it faulted; one in the trim's settling
    run raises :class:`hil.nodes.controller_fault.ControllerFaultError` (nothing ran).
    """
    import tempfile  # noqa: PLC0415

    from rich.console import Console  # noqa: PLC0415

    from hil.launch import RunRequest, launch  # noqa: PLC0415
    from hil.nodes.controller_fault import (  # noqa: PLC0415
        ControllerFault,
        ControllerFaultError,
        read_fault,
    )
    from hil.runlog.mcap_io import read_run  # noqa: PLC0415

    with tempfile.TemporaryDirectory(prefix="fowt-campaign-") as tmp:
        work = run_dir if record else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        path = work / "scenario.toml"
        path.write_text(toml_text)
        quiet = Console(file=open(os.devnull, "w"))  # noqa: SIM115 - closed below
        try:
            launch(
                RunRequest(scenario=str(path), mode="lockstep", out_dir=work, plots=False), quiet
            )
        finally:
            quiet.file.close()
        fault = read_fault(work)
        if fault is not None and not (work / "run.mcap").is_file():
            raise ControllerFaultError(ControllerFault(**fault))
        if fault is not None and faults is not None:
            faults.append(ControllerFault(**fault))
        return read_run(work / "run.mcap")


# --------------------------------------------------------------------------- rows, aggregates


def row_of(spec: RunSpec, result: dict[str, Any]) -> dict[str, Any]:
    """The results-table row of a run: identity, status, every KPI (nan when failed)."""
    row: dict[str, Any] = {
        "case": spec.case,
        "probability": spec.probability,
        "controller": spec.controller,
        "waves": spec.waves,
        "seed": spec.seed,
        "scenario_hash": spec.scenario_hash,
        "status": result.get("status", "failed"),
        # the run's verdict, as fowt run gives it (hil.review.outcome; docs/exit-codes.md)
        "outcome": result.get("outcome", "failed"),
        "exit_code": int(result.get("exit_code", 1)),
        "error": result.get("error", ""),
        "wall_s": float(result.get("wall_s", math.nan)),
    }
    kpis = result.get("kpi") or {}
    for name in ck.KPIS:
        v = kpis.get(name)
        row[name] = math.nan if v is None else float(v)
    return row


def sort_rows(rows: list[dict[str, Any]], campaign: Campaign) -> list[dict[str, Any]]:
    """Rows in the campaign's order (case, waves, controller, seed), whatever the finish order."""
    cases = {c.name: i for i, c in enumerate(campaign.spec.cases)}
    ctrls = {c.name: i for i, c in enumerate(campaign.spec.controllers)}
    return sorted(
        rows,
        key=lambda r: (
            cases.get(r["case"], 99),
            r["waves"] != "waves",
            ctrls.get(r["controller"], 99),
            r["seed"],
        ),
    )


def aggregate(rows: Sequence[dict[str, Any]], campaign: Campaign) -> dict[str, Any]:
    """The campaign's aggregates (module :mod:`hil.campaign.kpi` for the definitions).

    Returns
    -------
    dict
        ``per_case[case][waves][controller][kpi] = {mean, spread, n}`` (over the seeds whose
        run succeeded); ``relative[controller][kpi] = {per_case, weibull, weibull_of_cases}``
        vs the baseline with waves; ``normalised`` the same with eq. (5-1) against the
        baseline in still water; ``wave_increment[kpi] = {per_case, weibull, ...}`` baseline
        waves / baseline still; each of the three with ``stats`` = the same figures as
        ``{value, se, status}`` (:mod:`hil.review.kpi_stats`: standard error between paired seeds,
        ``n/m`` for a near-zero denominator, ``noise`` for a change within its noise);
        ``scales[kpi][case or "weibull"]`` (the n/m rule's S); ``noise`` (k, f, seeds,
        the controller whose still-water twins are used); ``probabilities``;
        ``not_available`` (KPIs the plant cannot give, with the reason); ``runs`` counts.
    """
    spec = campaign.spec
    probs = campaign.case_probabilities
    cases = list(probs)
    base = spec.baseline
    per_case: dict[str, Any] = {}
    for case in cases:
        per_case[case] = {}
        for waves in ("waves", "still"):
            block: dict[str, Any] = {}
            for ctrl in [c.name for c in spec.controllers]:
                sel = [
                    r
                    for r in rows
                    if r["case"] == case
                    and r["waves"] == waves
                    and r["controller"] == ctrl
                    and r["status"] == "ok"
                ]
                if not sel and not any(
                    r["case"] == case and r["waves"] == waves and r["controller"] == ctrl
                    for r in rows
                ):
                    continue
                block[ctrl] = {}
                for k in ck.KPIS:
                    m, s, n = ck.mean_and_spread([r[k] for r in sel])
                    block[ctrl][k] = {"mean": m, "spread": s, "n": n}
            if block:
                per_case[case][waves] = block

    def mean_of(case: str, waves: str, ctrl: str, k: str) -> float:
        try:
            return float(per_case[case][waves][ctrl][k]["mean"])
        except KeyError:
            return math.nan

    p = [probs[c] for c in cases]
    by_seed: dict[tuple[str, str, str], dict[int, dict[str, Any]]] = {}
    for r in rows:
        if r["status"] == "ok":
            by_seed.setdefault((r["case"], r["waves"], r["controller"]), {})[r["seed"]] = r

    def paired(case: str, configs: Sequence[tuple[str, str]], k: str) -> list[np.ndarray]:
        """Per config, the KPI of the seeds every config has (ok runs, finite values)."""
        runs = [by_seed.get((case, w, c), {}) for w, c in configs]
        common = sorted(set.intersection(*(set(x) for x in runs))) if runs else []
        common = [i for i in common if all(math.isfinite(float(x[i][k])) for x in runs)]
        return [np.array([float(x[i][k]) for i in common]) for x in runs]

    Side = dict[str, tuple[float, np.ndarray]]  # case -> (mean, paired seed values)

    def ratio_stats(
        k: str, num: Side, den: Side, offset: float, wave_effect: bool = False
    ) -> dict[str, Any]:
        """The ratio's figure per case, Weibull-weighted and Σp· (:mod:`hil.review.kpi_stats`).

        ``wave_effect`` (P_n): a figure whose denominator is within its noise or under
        :data:`hil.campaign.kpi.WAVE_EFFECT_FRACTION` of the scale is
        :data:`hil.campaign.kpi.BASELINE_NOISE`, without a number.
        """
        nums = [num[c] for c in cases]
        dens = [den[c] for c in cases]
        per = {
            c: kst.weighted_ratio([n[0]], [d[0]], [1.0], [n[1]], [d[1]], scales[k][c], offset)
            for c, n, d in zip(cases, nums, dens, strict=True)
        }
        weib = kst.weighted_ratio(
            [n[0] for n in nums],
            [d[0] for d in dens],
            p,
            [n[1] for n in nums],
            [d[1] for d in dens],
            scales[k]["weibull"],
            offset,
        )
        of_cases = kst.weighted_mean_of([per[c] for c in cases], p, offset)
        out: dict[str, Any] = {
            "per_case": {c: r.as_dict() for c, r in per.items()},
            "weibull": weib.as_dict(),
            "weibull_of_cases": of_cases.as_dict(),
        }
        if wave_effect:
            undefined = {"value": math.nan, "se": math.nan, "status": ck.BASELINE_NOISE}
            within = {
                c: ck.baseline_within_noise([d[0]], [d[1]], [1.0], scales[k][c])
                for c, d in zip(cases, dens, strict=True)
            }
            for c, yes in within.items():
                if yes:
                    out["per_case"][c] = dict(undefined)
            if ck.baseline_within_noise(
                [d[0] for d in dens], [d[1] for d in dens], p, scales[k]["weibull"]
            ):
                out["weibull"] = dict(undefined)
            if any(within[c] and pc > 0 for c, pc in zip(cases, p, strict=True)):
                out["weibull_of_cases"] = dict(undefined)
        return out

    def weibull(waves: str, ctrl: str, k: str) -> float:
        return ck.weibull_mean([mean_of(c, waves, ctrl, k) for c in cases], p)

    # S of the n/m rule: per case the largest |mean| over its configurations (waves/still,
    # every controller); Weibull-weighted the largest |X_W| over the configurations
    scales: dict[str, dict[str, float]] = {
        k: {
            c: kst.scale_of([v[k]["mean"] for blk in per_case[c].values() for v in blk.values()])
            for c in cases
        }
        for k in ck.KPIS
    }
    configs = sorted({(str(r["waves"]), str(r["controller"])) for r in rows})
    for k in ck.KPIS:
        scales[k]["weibull"] = kst.scale_of([weibull(w, ctrl, k) for w, ctrl in configs])

    relative: dict[str, Any] = {}
    normalised: dict[str, Any] = {}
    for ctrl in [c.name for c in spec.controllers if c.name != base]:
        relative[ctrl] = {}
        normalised[ctrl] = {}
        for k in ck.KPIS:
            rel_cases = {
                c: ck.relative(mean_of(c, "waves", ctrl, k), mean_of(c, "waves", base, k))
                for c in cases
            }
            pair = {c: paired(c, [("waves", ctrl), ("waves", base)], k) for c in cases}
            relative[ctrl][k] = {
                "per_case": rel_cases,
                "weibull": ck.relative(weibull("waves", ctrl, k), weibull("waves", base, k)),
                "weibull_of_cases": ck.weibull_mean(list(rel_cases.values()), p),
                "stats": ratio_stats(
                    k,
                    {c: (mean_of(c, "waves", ctrl, k), pair[c][0]) for c in cases},
                    {c: (mean_of(c, "waves", base, k), pair[c][1]) for c in cases},
                    1.0,
                ),
            }
            if spec.still_water:
                n_cases = {
                    c: ck.normalised(
                        mean_of(c, "waves", ctrl, k),
                        mean_of(c, "waves", base, k),
                        mean_of(c, "still", base, k),
                    )
                    for c in cases
                }
                trio = {
                    c: paired(c, [("waves", ctrl), ("waves", base), ("still", base)], k)
                    for c in cases
                }
                normalised[ctrl][k] = {
                    "per_case": n_cases,
                    "weibull": ck.normalised(
                        weibull("waves", ctrl, k),
                        weibull("waves", base, k),
                        weibull("still", base, k),
                    ),
                    "weibull_of_cases": ck.weibull_mean(list(n_cases.values()), p),
                    "stats": ratio_stats(
                        k,
                        {
                            c: (
                                mean_of(c, "waves", ctrl, k) - mean_of(c, "still", base, k),
                                trio[c][0] - trio[c][2],
                            )
                            for c in cases
                        },
                        {
                            c: (
                                mean_of(c, "waves", base, k) - mean_of(c, "still", base, k),
                                trio[c][1] - trio[c][2],
                            )
                            for c in cases
                        },
                        0.0,
                        wave_effect=True,
                    ),
                }
    increment: dict[str, Any] = {}
    if spec.still_water:
        for k in ck.KPIS:
            inc_cases = {
                c: ck.increment_ratio(mean_of(c, "waves", base, k), mean_of(c, "still", base, k))
                for c in cases
            }
            twin = {c: paired(c, [("waves", base), ("still", base)], k) for c in cases}
            increment[k] = {
                "per_case": inc_cases,
                "weibull": ck.increment_ratio(weibull("waves", base, k), weibull("still", base, k)),
                "weibull_of_cases": ck.weibull_mean(list(inc_cases.values()), p),
                "stats": ratio_stats(
                    k,
                    {c: (mean_of(c, "waves", base, k), twin[c][0]) for c in cases},
                    {c: (mean_of(c, "still", base, k), twin[c][1]) for c in cases},
                    0.0,
                ),
            }
    weighted = {
        f"{waves}/{ctrl}": {k: weibull(waves, ctrl, k) for k in ck.KPIS}
        for waves in ("waves", "still")
        for ctrl in [c.name for c in spec.controllers]
        if any(r["waves"] == waves and r["controller"] == ctrl for r in rows)
    }
    return {
        "campaign": spec.name,
        "baseline": base,
        "probabilities": probs,
        "kpis": {k: {"unit": u, "better": d, "label": lab} for k, (u, d, lab) in ck.KPIS.items()},
        "not_available": dict(ck.NOT_AVAILABLE),
        "notes": dict(ck.NOTES),
        "runs": {
            "total": len(rows),
            "ok": sum(r["status"] == "ok" for r in rows),
            "failed": sum(r["status"] != "ok" for r in rows),
        },
        "per_case": per_case,
        "scales": scales,
        "noise": {
            "k": kst.NOISE_K,
            "near_zero_fraction": kst.NEAR_ZERO_FRACTION,
            "wave_effect_fraction": ck.WAVE_EFFECT_FRACTION,
            "seeds": spec.seeds,
            "estimable": spec.seeds > 1,
            "still_water_of": base if spec.still_water else None,
        },
        "weibull": weighted,
        "relative": relative,
        "normalised": normalised,
        "wave_increment": increment,
    }


def _json_clean(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _json_clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_json_clean(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _isnan(v: Any) -> bool:
    return isinstance(v, float) and math.isnan(v)


def write_table(rows: Sequence[dict[str, Any]], out: Path) -> tuple[Path, Path]:
    """Write ``results.parquet`` (pyarrow) and ``results.csv``; returns both paths."""
    import csv  # noqa: PLC0415

    import pyarrow as pa  # noqa: PLC0415
    import pyarrow.parquet as pq  # noqa: PLC0415

    columns = list(rows[0]) if rows else ["case"]
    table = pa.table({c: [r.get(c) for r in rows] for c in columns})
    parquet = out / "results.parquet"
    pq.write_table(table, parquet)
    csv_path = out / "results.csv"
    with csv_path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns)
        w.writeheader()
        for r in rows:
            w.writerow(
                {k: ("" if isinstance(v, float) and math.isnan(v) else v) for k, v in r.items()}
            )
    return parquet, csv_path


# --------------------------------------------------------------------------- orchestration


@dataclass
class CampaignResult:
    """What :func:`run_campaign` produced."""

    rows: list[dict[str, Any]]
    aggregates: dict[str, Any]
    out: Path
    skipped: int = 0
    wall_s: float = 0.0
    workers: int = 0
    results: dict[str, dict[str, Any]] = field(default_factory=dict)
    tasks_wall_s: float = 0.0  # from the first submission to the last result (no cluster start)
    simulated_s: float = 0.0  # simulated seconds of the runs this call ran (resumed ones left out)


def _existing(spec: RunSpec, out: Path) -> dict[str, Any] | None:
    path = out / spec.rel_dir / "summary.json"
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except ValueError:
        return None
    c = data.get("campaign") or {}
    if c.get("scenario_hash") == spec.scenario_hash and c.get("status") == "ok":
        return {"status": "ok", "kpi": c.get("kpi", {}), "psd": c.get("psd", {}), "wall_s": 0.0}
    return None


def _write_summary(spec: RunSpec, result: dict[str, Any], out: Path) -> None:
    run_dir = out / spec.rel_dir
    run_dir.mkdir(parents=True, exist_ok=True)
    summary = dict(result.get("summary") or {})
    summary["campaign"] = {
        "case": spec.case,
        "controller": spec.controller,
        "waves": spec.waves,
        "seed": spec.seed,
        "probability": spec.probability,
        "scenario_hash": spec.scenario_hash,
        "status": result.get("status"),
        "error": result.get("error", ""),
        "traceback": result.get("traceback", ""),
        "worker": result.get("worker", ""),
        "wall_s": result.get("wall_s"),
        "kpi": result.get("kpi", {}),
        "psd": result.get("psd", {}),
        "kpi_window": result.get("kpi_window", {}),
        "scenario": spec.scenario,
    }
    text = json.dumps(_json_clean(summary), indent=1, allow_nan=False)
    (run_dir / "summary.json").write_text(text + "\n")


def _client(scheduler: str | None, workers: int | None) -> tuple[Any, Any]:
    """A Dask client: on ``scheduler``, or on a new local cluster bound to 127.0.0.1."""
    import logging  # noqa: PLC0415

    from distributed import Client, LocalCluster  # noqa: PLC0415

    if scheduler:
        return Client(scheduler, timeout="30s"), None
    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        # The scheduler's HTTP server (health routes only, no dashboard) on a free
        # loopback port rather than its default 8787.
        scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
        silence_logs=logging.ERROR,
    )
    return Client(cluster), cluster


def run_campaign(
    campaign: Campaign,
    out: Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    record: Record = "mcap",
    resume: bool = False,
    console: Console | None = None,
    progress: bool = True,
    on_result: Callable[[RunSpec, dict[str, Any]], None] | None = None,
) -> CampaignResult:
    """Run every run of ``campaign`` on Dask, write the per-run summaries and the tables.

    Parameters
    ----------
    campaign : Campaign
        From :func:`load_campaign` (or :func:`select`).
    out : Path
        Output folder (module docstring).
    scheduler : str, optional
        ``tcp://HOST:PORT`` of an existing Dask scheduler; None: a local cluster.
    workers : int, optional
        Local cluster worker processes (default: one per core).
    record : ``"mcap"`` | ``"none"``
        Keep each run's MCAP file, or only its summary.
    resume : bool
        Skip runs whose ``summary.json`` is ``ok`` for the same scenario hash.
    console : rich Console, optional
        Progress and messages.
    progress : bool
        Show the progress bar.
    on_result : callable, optional
        Called with each finished run (spec, result), in finishing order.
    """
    from rich.console import Console  # noqa: PLC0415
    from rich.progress import (  # noqa: PLC0415
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    console = console or Console()
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.monotonic()
    results: dict[str, dict[str, Any]] = {}
    todo: list[RunSpec] = []
    skipped = 0
    for spec in campaign.runs:
        prev = _existing(spec, out) if resume else None
        if prev is not None:
            results[spec.rel_dir] = prev
            skipped += 1
        else:
            todo.append(spec)
    if resume:
        console.print(f"--resume: {skipped} run(s) already done, {len(todo)} to run")
    design_dir = _designs(todo, console) if scheduler is None else None
    n_workers = 0
    tasks_wall = 0.0
    if todo:
        client, cluster = _client(scheduler, workers)
        try:
            n_workers = len(client.scheduler_info()["workers"])
            where = scheduler or "local cluster on 127.0.0.1 (no dashboard)"
            console.print(f"{len(todo)} run(s) on {n_workers} Dask worker(s), {where}")
            t_tasks = time.monotonic()
            _submit_all(
                client,
                campaign,
                todo,
                out,
                record,
                design_dir,
                results,
                console,
                progress,
                on_result,
                (Progress, TextColumn, BarColumn, MofNCompleteColumn),
                (TimeElapsedColumn, TimeRemainingColumn),
            )
            tasks_wall = time.monotonic() - t_tasks
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    rows = sort_rows([row_of(s, results[s.rel_dir]) for s in campaign.runs], campaign)
    agg = aggregate(rows, campaign)
    write_table(rows, out)
    (out / "aggregates.json").write_text(
        json.dumps(_json_clean(agg), indent=1, allow_nan=False) + "\n"
    )
    return CampaignResult(
        rows=rows,
        aggregates=agg,
        out=out,
        skipped=skipped,
        wall_s=time.monotonic() - t_start,
        workers=n_workers,
        results=results,
        tasks_wall_s=tasks_wall,
        simulated_s=sum(float(s.scenario["duration_s"]) for s in todo),
    )


def _designs(todo: Sequence[RunSpec], console: Console) -> str | None:
    """Design missing controller artefacts once, in the client, before any task starts.

    Every kind with a design hook (:attr:`controller.registry.ControllerKind.design`,
    shipped or plug-in) is asked once per distinct design request: its controller section,
    control period, platform, wind and sea (what a design may start from).
    """
    from controller.registry import find_kind  # noqa: PLC0415
    from hil.launch import ensure_designs  # noqa: PLC0415

    seen: set[str] = set()
    found: str | None = None
    for spec in todo:
        sc = spec.scenario
        c = sc["controller"]
        try:
            if find_kind(c["kind"], c.get("core")).kind.design is None:
                continue
        except ValueError:  # validated when the campaign was read; the run says why
            continue
        waves = sc.get("waves") or {}
        key = json.dumps(
            [
                c,
                sc["timing"]["control_period_s"],
                sc.get("platform"),
                (sc.get("wind") or {}).get("speed_m_s"),
                waves.get("hs_m"),
                waves.get("t1_s"),
            ],
            sort_keys=True,
        )
        if key in seen:
            continue
        seen.add(key)
        try:
            d = ensure_designs(msgspec.convert(sc, Scenario), console)
        except Exception as exc:  # the runs of this controller will fail, saying why
            console.print(f"[red]design for {spec.controller} failed: {exc}[/]")
            continue
        if d is not None:
            found = str(d)
    return found


def _submit_all(
    client: Any,
    campaign: Campaign,
    todo: Sequence[RunSpec],
    out: Path,
    record: Record,
    design_dir: str | None,
    results: dict[str, dict[str, Any]],
    console: Console,
    show: bool,
    on_result: Callable[[RunSpec, dict[str, Any]], None] | None,
    cols: tuple[Any, ...],
    time_cols: tuple[Any, ...],
) -> None:
    from distributed import wait  # noqa: PLC0415

    Progress, TextColumn, BarColumn, MofNCompleteColumn = cols
    TimeElapsedColumn, TimeRemainingColumn = time_cols
    futures = {}
    for i, spec in enumerate(todo):
        payload = {
            "scenario": spec.scenario,
            "mode": campaign.spec.mode,
            "run_dir": str((out / spec.rel_dir).resolve()),
            "record": record,
            "design_dir": design_dir,
            "min_rotor_speed_rad_s": campaign.spec.min_rotor_speed_rad_s,
        }
        fut = client.submit(
            execute_run, payload, key=f"fowt-run-{i}-{spec.scenario_hash[:16]}", pure=False
        )
        futures[fut] = spec
    keys = {f.key for f in futures}
    failed = 0
    done = 0
    with Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("running {task.fields[running]}  [red]failed {task.fields[failed]}[/]"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=console,
        disable=not show,
        transient=False,
    ) as bar:
        task = bar.add_task("runs", total=len(futures), running=0, failed=0)
        pending = set(futures)
        while pending:
            try:
                finished, pending = wait(list(pending), timeout=0.5, return_when="FIRST_COMPLETED")
            except TimeoutError:  # nothing finished in this half second
                finished = set()
            for fut in finished:
                spec = futures[fut]
                try:
                    result = fut.result()
                except Exception as exc:  # the worker died or the task could not run
                    result = {
                        "status": "failed",
                        "error": f"{type(exc).__name__}: {exc}",
                        "traceback": traceback.format_exc(),
                    }
                results[spec.rel_dir] = result
                _write_summary(spec, result, out)
                done += 1
                if result.get("status") != "ok":
                    failed += 1
                    console.print(f"[red]failed[/] {spec.label}: {result.get('error')}")
                if on_result is not None:
                    on_result(spec, result)
                fut.release()
            try:
                processing = client.processing()
                running = sum(1 for ks in processing.values() for k in ks if k in keys)
            except Exception:
                running = 0
            bar.update(task, completed=done, running=running, failed=failed)
