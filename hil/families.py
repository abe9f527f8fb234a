"""Plant families: what the launcher needs to know of a kind of plant, in one table.

``fowt run`` starts, follows, stops and reviews the processes of a run the same way for every
family (:mod:`hil.launch`: process start, supervision, signals, ``summary.json``, exit codes).
A family says only what differs:

* its **scenarios**: how they are addressed and listed (``fowt scenarios``). A single-turbine
  scenario is a shipped name or a TOML file (:mod:`hil.scenario`); a Hexicon H3 scenario is
  ``hexicon-<name>`` of ``hil/hexicon/presets/table6.toml`` (the prefix keeps the two name
  spaces apart: no shipped turbine scenario starts with it);
* its **nodes**: the command lines of the recorder, controller and plant processes
  (:meth:`PlantFamily.node_commands`, started in that order) and the key whose messages
  give the run's progress (simulated seconds, deadline misses);
* its **review**: the recorder writes the family's name in the file's metadata (``run`` or
  ``hexicon_run`` record, key ``family``) and :func:`hil.review.core.review` reads it to pick
  the KPIs, plots and report (:func:`hil.review.core.run_family`); ``fowt review`` of any
  run is the same entry point;
* its **in-process runner**, if any (``--mode inprocess``): the turbine has one
  (:mod:`hil.inprocess`), the Hexicon family has none on this path (its cores run in
  process in ``fowt hexicon campaign``, without a run log);
* the **options** of ``fowt run`` that apply to it; any other one given is refused before
  anything starts (:func:`check_request`, :class:`RunRequestError`, exit code 2).
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bus_schemas.registry import TIMING_SUMMARY
from hil.nodes.bus import LINK_TIMEOUT_S

if TYPE_CHECKING:
    from hil.nodes.can_bus import CanBusConfig

__all__ = [
    "FAMILIES",
    "HEXICON",
    "HEXICON_CONTROLLERS",
    "HEXICON_PREFIX",
    "TURBINE",
    "FamilyRun",
    "HexiconOptions",
    "NodeContext",
    "PlantFamily",
    "RunRequestError",
    "check_request",
    "list_scenarios",
    "resolve",
]

#: Address prefix of the Hexicon H3 scenarios (``fowt run hexicon-s1_step15``).
HEXICON_PREFIX = "hexicon-"
#: Controllers of a Hexicon run (``prbs``: the identification excitation, with an experiment).
HEXICON_CONTROLLERS = ("bang_bang", "mpc", "mpc_id", "prbs")


class RunRequestError(ValueError):
    """A run request the family cannot take (an option of another family, an unknown
    scenario); said before anything starts (exit code 2)."""


@dataclass(frozen=True)
class HexiconOptions:
    """The options of a Hexicon H3 run (``fowt run hexicon-<name> --controller ...``).

    Parameters
    ----------
    controller : str
        ``bang_bang``, ``mpc`` (physical model), ``mpc_id`` (identified model) or ``prbs``
        (the table-5 excitation of ``experiment``).
    noise : bool
        The preset's sensor channels (False: the truth, measured exactly).
    identified : Path or None
        The identified-model artefact of ``mpc_id`` (None: the shipped one).
    experiment : int
        Table-5 identification experiment (1-6) whose PRBS wind the plant runs; 0: the
        scenario's wind. With an experiment, the duration is its number of samples.
    seed : int
        Seed of the experiment's PRBS signals.
    platform : str
        The platform's id in the bus keys (``fowt/<platform>/...``).
    """

    controller: str = "mpc"
    noise: bool = True
    identified: Path | None = None
    experiment: int = 0
    seed: int = 0
    platform: str = "h3"

    def __post_init__(self) -> None:
        if self.controller not in HEXICON_CONTROLLERS:
            names = ", ".join(HEXICON_CONTROLLERS)
            raise RunRequestError(f"--controller {self.controller!r}: expected one of {names}")
        if (self.controller == "prbs") != (self.experiment > 0):
            raise RunRequestError(
                "--controller prbs goes with an identification experiment (1-6), and an "
                "experiment with --controller prbs"
            )
        if self.identified is not None and self.controller != "mpc_id":
            raise RunRequestError("--identified: only with --controller mpc_id")


@dataclass(frozen=True)
class NodeContext:
    """What the launcher hands a family to build its nodes' command lines.

    Parameters
    ----------
    scenario : str
        The scenario as the family's nodes take it (a turbine scenario's name or absolute
        path; a Hexicon scenario's name without the prefix).
    duration_s : float
        Simulated seconds.
    mode : str
        ``realtime`` or ``lockstep``.
    speed : float
        Real-time factor (turbine).
    endpoints : tuple of str
        The plant's and the controller's listening endpoints (loopback).
    mcap_path : Path
        The recorder's file.
    run_info : dict of str to str
        The ``run`` metadata record of the file (:func:`hil.launch.run_info`; with ``family``).
    key_file : Path
        The run's secret (docs/security.md), handed to each node by path.
    can : CanBusConfig or None
        The CAN bus of a ``--transport can`` run.
    realtime_priority : int
        SCHED_FIFO priority of plant and controller (0: normal).
    launcher_token : bool
        The plant also waits for the launcher's liveliness token (process faults).
    options : HexiconOptions or None
        A Hexicon run's options.
    """

    scenario: str
    duration_s: float
    mode: str
    speed: float
    endpoints: tuple[str, str]
    mcap_path: Path
    run_info: Mapping[str, str]
    key_file: Path
    can: CanBusConfig | None = None
    realtime_priority: int = 0
    launcher_token: bool = False
    options: HexiconOptions | None = None


@dataclass(frozen=True)
class FamilyRun:
    """A family's scenario resolved for one run: what the shared launcher shows and records.

    Parameters
    ----------
    name : str
        The scenario's address (``hexicon-s1_step15``): progress bar, default run folder.
    scenario : str
        The scenario as the nodes take it (:attr:`NodeContext.scenario`).
    duration_s : float
        Simulated seconds of the run.
    ident : str
        The id in the bus keys (turbine id, platform id).
    metadata : dict of str to str
        What the family adds to the run's metadata (scenario, controller, period, ...).
    """

    name: str
    scenario: str
    duration_s: float
    ident: str
    metadata: Mapping[str, str]


@dataclass(frozen=True)
class PlantFamily:
    """One plant family of the bench (module docstring).

    Parameters
    ----------
    name : str
        Recorded in the run's metadata as ``family``.
    description : str
        One line for ``fowt scenarios``.
    scenarios : callable
        ``() -> {address: one-line description}`` of the shipped scenarios.
    owns : callable
        ``(address) -> bool``: whether an address names this family's scenario.
    node_commands : callable
        ``(NodeContext) -> {"recorder": argv, "controller": argv, "plant": argv}``.
    progress_key : callable
        ``(ident) -> key`` of the messages the launcher follows the run by.
    progress : callable
        ``(payload) -> (simulated s, deadline misses)`` of one such message (None: unreadable).
    run_options : frozenset of str
        The ``fowt run`` options that apply (:func:`check_request`).
    inprocess : bool
        Whether ``--mode inprocess`` runs it (:mod:`hil.inprocess`).
    plan : callable or None
        ``(address, duration_s or None, options) -> FamilyRun``: a scenario resolved for a
        run. None for the single turbine, whose launcher path reads its full
        :class:`hil.scenario.schema.Scenario` (designs, process faults, in-process runner).
    """

    name: str
    description: str
    scenarios: Callable[[], dict[str, str]]
    owns: Callable[[str], bool]
    node_commands: Callable[[NodeContext], dict[str, list[str]]]
    progress_key: Callable[[str], str]
    progress: Callable[[bytes], tuple[float, float] | None]
    run_options: frozenset[str]
    inprocess: bool
    plan: Callable[[str, float | None, Any], FamilyRun] | None = None


# ------------------------------------------------------------------ single turbine
def _turbine_scenarios() -> dict[str, str]:
    from hil.scenario.schema import load_scenario, shipped_scenarios  # noqa: PLC0415

    rows = {}
    for name in shipped_scenarios():
        sc = load_scenario(name)
        plant = f"{sc.turbine} on {sc.platform}" if sc.platform else f"{sc.turbine} fixed"
        details = f"[{plant}; {sc.controller.kind}/{sc.controller.preset}; {sc.duration_s:g} s]"
        rows[name] = f"{sc.description} {details}" if sc.description else details
    return rows


def _turbine_node(sub: str, ctx: NodeContext, *args: str) -> list[str]:
    return [
        sys.executable,
        "-m",
        "hil",
        sub,
        ctx.scenario,
        "--duration",
        repr(ctx.duration_s),
        *args,
    ]


def _turbine_nodes(ctx: NodeContext) -> dict[str, list[str]]:
    """``fowt record``, ``fowt controller`` and ``fowt plant`` (:mod:`hil.cli.fowt`)."""
    plant_ep, ctrl_ep = ctx.endpoints
    key_args = ["--key-file", str(ctx.key_file)]
    # CAN run: the three nodes join the same CAN bus (sensor frame and command on CAN).
    can_args = ctx.can.cli_args() if ctx.can is not None else []
    # Real-time scheduling for the two processes on the control loop; the recorder stays
    # under the normal policy so it only takes the CPU they leave.
    rt_args = ["--realtime-priority", str(ctx.realtime_priority)] if ctx.realtime_priority else []
    return {
        "recorder": _turbine_node(
            "record",
            ctx,
            "--out",
            str(ctx.mcap_path),
            "--connect",
            plant_ep,
            "--connect",
            ctrl_ep,
            "--run-info",
            json.dumps(dict(ctx.run_info)),
            *key_args,
            *can_args,
        ),
        "controller": _turbine_node(
            "controller",
            ctx,
            "--listen",
            ctrl_ep,
            "--connect",
            plant_ep,
            # announced once the recorder's link reaches it: the plant waits for that
            "--await-recorder",
            repr(LINK_TIMEOUT_S),
            *key_args,
            *can_args,
            *rt_args,
        ),
        "plant": _turbine_node(
            "plant",
            ctx,
            "--listen",
            plant_ep,
            "--mode",
            ctx.mode,
            "--speed",
            repr(ctx.speed),
            "--require",
            # With process faults the plant also waits for the launcher's token: the
            # launcher then follows the simulated time from the first cycle on.
            "controller,recorder" + (",launcher" if ctx.launcher_token else ""),
            *key_args,
            *can_args,
            *rt_args,
        ),
    }


def _timing_summary(payload: bytes) -> tuple[float, float] | None:
    try:
        s = TIMING_SUMMARY.codec.decode(payload)
    except Exception:
        return None
    return s.sample_time_ns / 1e9, float(s.deadline_misses)


TURBINE = PlantFamily(
    name="turbine",
    description="one floating (or fixed) turbine: hil/scenario/presets/*.toml or a TOML file",
    scenarios=_turbine_scenarios,
    owns=lambda ref: not ref.startswith(HEXICON_PREFIX),
    node_commands=_turbine_nodes,
    progress_key=TIMING_SUMMARY.key,
    progress=_timing_summary,
    run_options=frozenset({"speed", "loop", "can_channel", "can_fd"}),
    inprocess=True,
)


# ------------------------------------------------------------------ Hexicon H3
def _hexicon_scenarios() -> dict[str, str]:
    from hil.hexicon.model import load_scenarios  # noqa: PLC0415

    return {
        f"{HEXICON_PREFIX}{name}": f"{scn.comment} [Hexicon H3, 3 turbines; {scn.duration_s:g} s]"
        for name, scn in load_scenarios().items()
    }


def _hexicon_nodes(ctx: NodeContext) -> dict[str, list[str]]:
    """``python -m hil.hexicon.nodes record|controller|plant`` (:mod:`hil.hexicon.nodes`)."""
    from hil.hexicon.nodes import node_commands  # noqa: PLC0415

    o = ctx.options or HexiconOptions()
    can = None
    if ctx.can is not None:
        can = {"interface": ctx.can.interface, "channel": ctx.can.effective_channel}
        can["fd"] = "1" if ctx.can.fd else ""
    return node_commands(
        ctx.scenario,
        o.controller,
        o.platform,
        ctx.mode,
        ctx.duration_s,
        float(ctx.run_info["control_period_s"]),
        ctx.endpoints,
        ctx.mcap_path,
        dict(ctx.run_info),
        key_file=ctx.key_file,
        noise=o.noise,
        experiment=o.experiment,
        seed=o.seed,
        identified=str(o.identified.resolve()) if o.identified is not None else None,
        can=can,
        realtime_priority=ctx.realtime_priority,
    )


def _hexicon_progress_key(platform: str) -> str:
    from hil.hexicon.nodes import progress_key  # noqa: PLC0415

    return progress_key(platform)  # on Zenoh even when the frames travel on CAN


def _platform_progress(payload: bytes) -> tuple[float, float] | None:
    """The Hexicon plant's running account (:func:`hil.hexicon.nodes.progress_key`):
    simulated seconds done and deadline misses so far."""
    try:
        got = json.loads(payload)
        return float(got["sim_s"]), float(got["deadline_misses"])
    except (ValueError, TypeError, KeyError):
        return None


HEXICON = PlantFamily(
    name="hexicon",
    description="Hexicon H3: three turbines on one yawing platform (ayotte-2015, table 6)",
    scenarios=_hexicon_scenarios,
    owns=lambda ref: ref.startswith(HEXICON_PREFIX),
    node_commands=_hexicon_nodes,
    progress_key=_hexicon_progress_key,
    progress=_platform_progress,
    run_options=frozenset({"hexicon", "can_channel", "can_fd"}),
    inprocess=False,
    plan=lambda ref, duration_s, options: hexicon_run(
        ref, duration_s, options if options is not None else HexiconOptions()
    ),
)

#: Every family, by name.
FAMILIES: dict[str, PlantFamily] = {f.name: f for f in (TURBINE, HEXICON)}


def list_scenarios() -> dict[str, dict[str, str]]:
    """``{family name: {address: description}}`` of every shipped scenario."""
    return {name: f.scenarios() for name, f in FAMILIES.items()}


def resolve(ref: str) -> PlantFamily:
    """The family of a scenario address; a ``hexicon-`` name that is no Hexicon scenario
    is refused here, naming the closest shipped ones.

    Raises
    ------
    RunRequestError
        An unknown ``hexicon-`` name.
    """
    if HEXICON.owns(ref):
        from hil.scenario.schema import suggestion  # noqa: PLC0415

        names = HEXICON.scenarios()
        if ref not in names:
            hint = suggestion(ref, sorted(names)) or "'fowt scenarios' lists the shipped ones"
            raise RunRequestError(f"unknown Hexicon scenario {ref!r}; {hint}")
        return HEXICON
    return TURBINE


def hexicon_run(ref: str, duration_s: float | None, options: HexiconOptions) -> FamilyRun:
    """A Hexicon scenario address resolved for a run (:class:`FamilyRun`)."""
    from hil.hexicon.model import load_scenarios  # noqa: PLC0415

    name = ref.removeprefix(HEXICON_PREFIX)
    scn = load_scenarios()[name]
    duration = scn.duration_s if duration_s is None else duration_s
    if options.experiment:
        duration = float(round(duration)) * scn.control_period_s  # samples of the PRBS wind
    if not (math.isfinite(duration) and duration >= scn.control_period_s):
        raise RunRequestError(
            f"--duration {duration:g}: a Hexicon run lasts at least one control period "
            f"({scn.control_period_s:g} s)"
        )
    return FamilyRun(
        name=ref,
        scenario=name,
        duration_s=duration,
        ident=options.platform,
        metadata={
            "family": HEXICON.name,
            "kind": "identification" if options.experiment else "run",
            "scenario": name,
            "controller": options.controller,
            "platform": options.platform,
            "experiment": str(options.experiment),
            "seed": str(options.seed),
            "control_period_s": repr(scn.control_period_s),
            "noise": str(options.noise),
        },
    )


#: What each ``fowt run`` option is called on the command line (for the refusals).
_OPTION_TEXT = {
    "speed": "--speed",
    "loop": "--loop",
    "hexicon": "--controller/--no-noise/--identified/--experiment",
    "can_channel": "--can-channel",
    "can_fd": "--can-fd",
}


def check_request(family: PlantFamily, given: Mapping[str, Any], mode: str) -> None:
    """Refuse the options given (non-default) that do not apply to ``family``.

    Parameters
    ----------
    family : PlantFamily
        The scenario's family.
    given : mapping of str to object
        The options given, by :data:`_OPTION_TEXT` name (only those not at their default).
    mode : str
        The run's mode.

    Raises
    ------
    RunRequestError
        Naming the option, the family, and what to do instead.
    """
    if mode == "inprocess" and not family.inprocess:
        raise RunRequestError(
            f"--mode inprocess: the {family.name} family has no in-process run log "
            "(use lockstep or realtime; 'fowt hexicon campaign' runs its cores in process)"
        )
    for name in given:
        if name in family.run_options:
            continue
        text = _OPTION_TEXT.get(name, f"--{name}")
        if family is TURBINE:
            raise RunRequestError(
                f"{text}: only for a Hexicon scenario ({HEXICON_PREFIX}<name>, 'fowt "
                "scenarios'); a turbine scenario names its controller and sensors in its TOML"
            )
        raise RunRequestError(
            f"{text}: not an option of a {family.name} scenario (it applies to single-turbine "
            "scenarios only)"
        )
