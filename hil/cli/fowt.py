"""The ``fowt`` command: run, plant, controller, record, router, review, recover, scenarios,
presets, analyze, preset, and campaign, compare, report (:mod:`hil.cli.campaign`).

Bad input on the command line (an option's value, a scenario file) ends the command with one
line on stderr, ``error: ...`` naming the option or the scenario key and what was expected, and
exit code 2, before anything is started or written: every number option is checked by a
callback (:func:`number`), every output path by :func:`writable` (nothing is created by the
check), and a usage error of the parser is turned into the same one line by :func:`main`.
"""

from __future__ import annotations

import atexit
import contextlib
import dataclasses
import functools
import gc
import json
import math
import os
import sys
import threading
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, NoReturn, TypeVar

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from hil.cli.common import choice, fail, number, os_error_text, stderr, text_file, writable
from hil.cli.hexicon import app as hexicon_app
from hil.nodes.bus import BusOpenError
from hil.nodes.rt import startup_gc
from hil.review.outcome import ExitCode
from hil.scenario.schema import (
    MAX_DURATION_S,
    Scenario,
    ScenarioError,
    load_scenario,
    scenario_text,
)

if TYPE_CHECKING:
    from hil.nodes.can_bus import CanBusConfig
    from hil.review.plot_worker import PlotWorker

app = typer.Typer(
    help="fowt-hil: floating-wind controller-in-the-loop bench.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)
console = Console()


def _preset_ref(value: str) -> str:
    """Callback of a preset argument: a shipped name, or a path to a readable text file."""
    if value.endswith(".toml") or "/" in value:
        text_file(Path(value))
    return value


def _forecasters(values: list[str] | None) -> list[str] | None:
    """Callback of ``--forecaster``: names of :mod:`controller.forecast` forecasters."""
    for value in values or ():
        if value not in ("dispersion", "ar", "esprit"):
            raise typer.BadParameter(f"expected dispersion, ar or esprit, got {value!r}")
    return values


#: Nodes the plant can wait for (their liveliness tokens ``fowt/<turbine>/alive/<name>``).
_PEERS = ("controller", "recorder", "launcher", "fuzzer")  # fuzzer: python -m hil.nodes.fuzz


def _require_list(value: str) -> str:
    """Callback of ``--require``: comma-separated node names, or ``none``."""
    names = [v.strip() for v in value.split(",") if v.strip()]
    if names == ["none"]:
        return ""
    bad = [n for n in names if n not in _PEERS]
    if bad:
        raise typer.BadParameter(
            f"expected comma-separated names from {', '.join(_PEERS)} (or none), got {bad[0]!r}"
        )
    return ",".join(names)


def _json_object(value: str) -> str:
    """Callback of ``--run-info``: a JSON object."""
    try:
        obj = json.loads(value)
    except json.JSONDecodeError as exc:
        raise typer.BadParameter(f"expected a JSON object, not valid JSON ({exc.msg})") from exc
    if not isinstance(obj, dict):
        raise typer.BadParameter(f"expected a JSON object, got a JSON {type(obj).__name__}")
    return value


# ----------------------------------------------------------------- shared options

ScenarioArg = Annotated[
    str,
    typer.Argument(
        help="Shipped scenario name (see 'fowt scenarios') or a scenario TOML file.",
        show_default=True,
    ),
]
DurationOpt = Annotated[
    float | None,
    typer.Option(
        "--duration",
        help="Simulated seconds (overrides the scenario's duration_s).",
        callback=number("s", gt=0.0, le=MAX_DURATION_S),
    ),
]
SpeedOpt = Annotated[
    float,
    typer.Option(
        "--speed",
        help="Real-time factor (realtime mode).",
        callback=number("real-time factor", gt=0, le=1000),
    ),
]
ListenOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--listen",
        help="Zenoh endpoint to listen on (repeatable; default: the node's loopback port, or"
        " the --zenoh-config file's endpoints).",
    ),
]
ConnectOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--connect",
        help="Zenoh endpoint to connect to (repeatable; default as for --listen).",
    ),
]
ZenohConfigOpt = Annotated[
    Path | None,
    typer.Option(
        "--zenoh-config",
        help="Zenoh JSON5 config for multi-host use (router, TLS, ACL); its endpoints are"
        " kept unless --listen/--connect are given.",
        callback=text_file,
    ),
]
KeyFileOpt = Annotated[
    Path | None,
    typer.Option(
        "--key-file",
        help="The run's 32-byte secret (mode 0600; fowt run makes one per run as"
        " <run folder>/run.key): every bus payload is signed and verified with it.",
    ),
]
InsecureOpt = Annotated[
    bool,
    typer.Option(
        "--insecure",
        help="Run without --key-file: payloads unsigned and unchecked, so any local process"
        " can command the turbine. For tools and tests only.",
    ),
]
#: Foxglove's default WebSocket port: what a bare ``--live`` serves on (:func:`_bare_live`).
LIVE_DEFAULT_PORT = 8765
LiveOpt = Annotated[
    int | None,
    typer.Option(
        "--live",
        help="Serve the run live to Foxglove on ws://127.0.0.1:PORT (bare --live: 8765;"
        " 0: any free port), read-only; docs/guide/live-view.md.",
        min=0,
        max=65535,
        show_default=False,
    ),
]
RealtimePriorityOpt = Annotated[
    int,
    typer.Option(
        "--realtime-priority",
        help="SCHED_FIFO priority 1..40 for the plant and controller (root or CAP_SYS_NICE);"
        " 0 = normal scheduling.",
        min=0,
        max=40,
    ),
]
TransportOpt = Annotated[
    str,
    typer.Option(
        "--transport",
        help="zenoh | can: with can, the sensor frame and the command travel on CAN "
        "(python-can), everything else on the loopback Zenoh session.",
        callback=choice("zenoh", "can"),
    ),
]
CanInterfaceOpt = Annotated[
    str | None,
    typer.Option(
        "--can-interface",
        help="udp_multicast (private network namespace) | socketcan | virtual "
        "(default: the scenario's can.interface, else udp_multicast).",
    ),
]
CanChannelOpt = Annotated[
    str | None,
    typer.Option(
        "--can-channel",
        help="Multicast group (udp_multicast) or netdevice (socketcan); default per interface.",
    ),
]
CanFdOpt = Annotated[
    bool | None,
    typer.Option(
        "--can-fd/--no-can-fd",
        help="CAN FD frames (default: the scenario's can.fd).",
        show_default=False,
    ),
]


def _can_config(
    sc: Scenario, transport: str, interface: str | None, channel: str | None, fd: bool | None
) -> CanBusConfig | None:
    """The node's CAN bus for ``--transport can`` (None for zenoh); exits 2 on a bad option."""
    if transport == "zenoh":
        return None
    from hil.nodes.can_bus import CanBusConfig, CanConfigError

    try:
        can = CanBusConfig.for_interface(
            interface or sc.can.interface,
            channel if channel is not None else sc.can.channel,
            sc.can.fd if fd is None else fd,
            sc.turbine_id,
        )
    except CanConfigError as exc:
        fail(str(exc))
    _check_can_device(can)
    return can


def _check_can_device(can: CanBusConfig) -> None:
    """Exit 2 when a ``socketcan`` bus's netdevice does not exist (nothing could open it)."""
    from hil.nodes.can_bus import socketcan_available

    if can.interface == "socketcan" and not socketcan_available(can.effective_channel):
        from hil.nodes.can_bus import transport_unavailable_reason

        fail(f"--can-interface socketcan: {transport_unavailable_reason(can)}")


def _check_can_runs_here(can: CanBusConfig | None) -> None:
    """``fowt run``: exit 2 when the CAN bus cannot connect the run's processes on this
    host (:func:`hil.nodes.can_bus.transport_unavailable_reason`), saying what to use."""
    if can is None:
        return
    from hil.nodes.can_bus import transport_unavailable_reason

    reason = transport_unavailable_reason(can)
    if reason is not None:
        fail(f"--transport can --can-interface {can.interface}: {reason}")


def _scenario(ref: str, duration: float | None) -> Scenario:
    """Load and validate the scenario, and its controller preset for the controller kind."""
    try:
        sc = load_scenario(ref).with_duration(duration)
    except ScenarioError as exc:
        fail(str(exc))
    c = sc.controller
    try:  # parsing the preset costs milliseconds and imports no plant
        if c.kind == "baseline":
            from controller.baseline import load_baseline

            load_baseline(c.preset)
        elif c.kind in ("lqri", "lqri_ff"):
            from controller.runtime import load_advanced_settings

            load_advanced_settings(c.preset)
        elif c.kind == "rosco":  # its DISCON.IN and its library: files that must be there
            _check_rosco_files(c.preset, c.parameter_file, c.library)
        # other kinds check their presets when built
    except (ValueError, OSError) as exc:
        key, value = "preset", c.preset
        if c.kind == "rosco" and c.parameter_file is not None:
            key, value = "parameter_file", c.parameter_file
        fail(f"{ref}: controller.{key} = {value!r} for kind {c.kind!r}: {exc}")
    if c.kind == "fmu":  # the archive, its modelDescription.xml and the mapping; no binary
        from controller.fmu import check_fmu
        from controller.registry import settings_for

        try:
            check_fmu(settings_for(c.kind, c.settings), c.base_dir)
        except ValueError as exc:
            fail(f"{ref}: controller kind 'fmu': {exc}")
    return sc


def _check_rosco_files(preset: str, parameter_file: str | None, library: str | None) -> None:
    """ValueError unless a ``rosco`` controller's DISCON.IN reads and its library is there
    (the scenario's own library was checked on load: :func:`hil.scenario.schema.resolve_paths`)."""
    from controller.rosco import default_library, read_discon_in, shipped_parameter_files

    if parameter_file is None:
        shipped = shipped_parameter_files()
        if preset in shipped:  # an unknown name: refused by the scenario's validation
            read_discon_in(shipped[preset])
    else:
        read_discon_in(parameter_file)
    if library is None:
        default_library()


def _realtime(priority: int, who: str) -> None:
    """Switch this node to SCHED_FIFO before it opens its bus (threads inherit the policy)."""
    if priority == 0:
        return
    from hil.nodes.rt import RealtimeError, set_realtime_priority

    try:
        console.print(f"{who}: {set_realtime_priority(priority)}")
    except RealtimeError as exc:
        fail(str(exc))


def _bus(
    listen: list[str] | None,
    connect: list[str] | None,
    zenoh_config: Path | None,
    default_listen: tuple[str, ...] = (),
    default_connect: tuple[str, ...] = (),
    key_file: Path | None = None,
    insecure: bool = False,
) -> object:
    """The node's bus: the options, else the node's loopback defaults.

    With ``--zenoh-config`` the defaults are not applied: the file's endpoints stay unless
    ``--listen``/``--connect`` are given explicitly. Authentication (docs/security.md): a
    node needs ``--key-file`` or, to run unauthenticated, an explicit ``--insecure``; it
    never makes a secret of its own (its peers could not know it).
    """
    import zenoh

    from bus_schemas.auth import KeyFileError, read_key_file
    from hil.nodes.bus import BusConfig, BusConfigError

    if zenoh_config is None:
        listen = listen or list(default_listen)
        connect = connect or list(default_connect)
    try:
        config = BusConfig(
            listen=tuple(listen or ()),
            connect=tuple(connect or ()),
            config_file=zenoh_config,
        )
    except BusConfigError as exc:
        fail(str(exc))
    if zenoh_config is not None:
        try:  # parse it now: a bad file is an input error, not a crash when the node starts
            config.zenoh_config()
        except (zenoh.ZError, ValueError, OSError) as exc:
            fail(f"--zenoh-config {zenoh_config}: not a valid Zenoh config ({exc})")
    auth_key: bytes | None = None
    if key_file is not None and insecure:
        fail("--key-file and --insecure exclude each other")
    if key_file is not None:
        try:
            auth_key = read_key_file(key_file)
        except KeyFileError as exc:
            fail(f"--key-file: {exc}")
    elif not insecure:
        fail(
            "no --key-file: the bus payloads are authenticated with the run's secret "
            "(fowt run makes <run folder>/run.key); pass --key-file FILE, or --insecure to "
            "run unauthenticated"
        )
    else:
        stderr.print(
            Text.assemble(
                ("warning: ", "yellow"),
                "--insecure: this node neither authenticates its Zenoh session nor signs or "
                "checks payloads; any local process can join the bus and command the turbine",
            )
        )
    return dataclasses.replace(config, auth_key=auth_key)


# ----------------------------------------------------------------- commands


@app.command(short_help="Run plant, controller and recorder as processes, then review.")
def run(
    scenario: ScenarioArg = "default",
    mode: Annotated[
        str,
        typer.Option(
            help="realtime | lockstep | inprocess",
            callback=choice("realtime", "lockstep", "inprocess"),
        ),
    ] = "realtime",
    speed: SpeedOpt = 1.0,
    duration: DurationOpt = None,
    transport: TransportOpt = "zenoh",
    can_interface: CanInterfaceOpt = None,
    can_channel: CanChannelOpt = None,
    can_fd: CanFdOpt = None,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out", help="Output folder (default: runs/<scenario>).", callback=writable("folder")
        ),
    ] = None,
    plots: Annotated[bool, typer.Option(help="Write PNG plots.")] = True,
    realtime_priority: RealtimePriorityOpt = 0,
    loop: Annotated[
        str,
        typer.Option(
            help="--mode inprocess: auto | compiled | python (the cycle loop; auto: compiled "
            "where the scenario allows it)",
            callback=choice("auto", "compiled", "python"),
        ),
    ] = "auto",
    controller: Annotated[
        str | None,
        typer.Option(
            help="Hexicon scenarios: bang_bang | mpc (physical model; default) | mpc_id "
            "(identified model) | prbs (with --experiment). A turbine scenario names its "
            "controller in its TOML."
        ),
    ] = None,
    noise: Annotated[
        bool | None,
        typer.Option(
            "--noise/--no-noise",
            help="Hexicon scenarios: the preset's sensor channels (default) or exact sensors.",
            show_default=False,
        ),
    ] = None,
    identified: Annotated[
        Path | None,
        typer.Option(help="Hexicon scenarios, --controller mpc_id: identified-model artefact."),
    ] = None,
    experiment: Annotated[
        int,
        typer.Option(
            help="Hexicon scenarios, --controller prbs: table-5 identification experiment "
            "(1-6) whose PRBS wind the plant runs; --duration is then its number of samples.",
            min=0,
            max=6,
        ),
    ] = 0,
    seed: Annotated[
        int,
        typer.Option(
            help="Hexicon scenarios, --experiment: seed of the PRBS signals.",
            min=0,
        ),
    ] = 0,
    keep_key: Annotated[
        bool,
        typer.Option(
            "--keep-key",
            help="Leave the run's secret (<out>/run.key, mode 0600) in the run folder after "
            "the run (default: removed when the run ends; it signs every payload and is "
            "the Zenoh session credential).",
        ),
    ] = False,
    live: LiveOpt = None,
) -> None:
    """Launch plant, controller and recorder as separate processes, then review the run.

    The scenario is a single-turbine one (a shipped name or a TOML file) or a Hexicon H3
    one (hexicon-<name>; 'fowt scenarios' lists both); options of the other family are
    refused (exit 2). The run, its review and its exit code are the same for both.

    With --transport can the sensor frame and the command travel on a CAN bus between the
    plant and controller processes (the recorder listens too and logs the raw frames); with
    udp_multicast the launcher runs the whole bench in a fresh network namespace (unshare -n,
    root) unless it already is in a private one.

    Ctrl-C, SIGTERM or SIGHUP stops the run: the children are stopped in order (SIGTERM;
    SIGKILL only after a long grace, said when done), the recording is finished and
    reviewed, and summary.json says the run was aborted.

    \b
    Exit codes (the first that applies; docs/exit-codes.md; summary.json run.outcome):
      0  complete and healthy
      1  the run failed (a process died, a write failed: disk full)
      2  bad input, refused before anything started: an option, a scenario key,
         a file or path that is not there, a transport, CAN interface, channel or
         device this host cannot use (one line saying what to use instead)
      3  aborted by a signal (SIGINT, SIGTERM, SIGHUP)
      4  recording incomplete (messages lost, file truncated)
      5  safe state: the plant's safe state or the controller's safe mode, at any time
      6  deadline misses over both [timing] max_deadline_misses and
         max_deadline_miss_fraction of the cycles (default 1 and 0.01 in real
         time, 0 and 0 in lock-step and in process)
      7  controller fault: its core raised, or gave a non-finite or out-of-range
         command (never applied), its estimator diverged, or it was slower than its
         control period in more than a quarter of its cycles; wins over 4, 5 and 6,
         not over 1 and 3

    Paths in a scenario file (presets, platform, library, parameter file) are taken
    from the scenario file's folder.
    """
    # The launcher first (numpy, the run log, the review's streaming core: what the plot
    # worker needs as well, inherited by the fork instead of imported twice: 0.3 s of CPU
    # less), then the worker, so that matplotlib is imported on the other core while the
    # run starts.
    from hil.launch import RunRequest, default_out_dir
    from hil.review.plot_worker import PlotWorker

    worker = PlotWorker.start() if plots else None
    with worker if worker is not None else contextlib.nullcontext():
        from hil.families import TURBINE, HexiconOptions, RunRequestError, resolve

        hexicon_given = (
            controller is not None or noise is not None or identified is not None or experiment > 0
        )
        options: HexiconOptions | None = None  # a turbine scenario takes no family options
        try:
            family = resolve(scenario)
            if family is not TURBINE:
                options = HexiconOptions(
                    controller=controller or ("prbs" if experiment else "mpc"),
                    noise=True if noise is None else noise,
                    identified=identified,
                    experiment=experiment,
                    seed=seed,
                )
                if identified is not None:
                    text_file(identified)
            elif hexicon_given or seed:
                raise RunRequestError(
                    "--controller/--no-noise/--identified/--experiment/--seed: only for a Hexicon "
                    "scenario (hexicon-<name>, 'fowt scenarios'); a turbine scenario names its "
                    "controller and sensors in its TOML"
                )
        except RunRequestError as exc:
            fail(str(exc))
        except typer.BadParameter as exc:
            fail(f"--identified: {exc.message}")

        if options is not None:
            can = _family_can(transport, can_interface, can_channel, can_fd, options.platform)
            _check_can_runs_here(can)
        else:
            sc = _scenario(scenario, duration)  # validate before launching anything
            can = _can_config(sc, transport, can_interface, can_channel, can_fd)
            if can is not None and mode == "inprocess":
                fail("--mode inprocess has no bus: use lockstep or realtime with --transport can")
            _check_can_runs_here(can)
            if loop != "auto" and mode != "inprocess":
                fail(f"--loop {loop}: only with --mode inprocess")
            folder = out
            if out is None:
                folder = default_out_dir(sc)
                try:
                    writable("folder")(folder)
                except typer.BadParameter as exc:
                    fail(f"default output folder: {exc.message} (give --out)")
            _check_run_files(folder)
        if live is not None:
            _check_live(live, options is not None, mode, transport)
        # The same launcher, review and exit codes for every family; the family checks the
        # options that are its own (hil.families).
        req = RunRequest(
            scenario=scenario,
            mode=mode,  # type: ignore[arg-type]  # checked by its callback
            speed=speed,
            duration_s=duration,
            transport=transport,
            out_dir=out,
            plots=plots,
            can=can,
            realtime_priority=realtime_priority,
            inprocess_loop=loop,  # type: ignore[arg-type]  # checked by its callback
            hexicon=options,
            keep_key=keep_key,
            live_port=live,
        )
        _launch_and_exit(req, worker if options is None else None)


def _check_run_files(folder: Path | None) -> None:
    """The files a run writes in its folder (``run.mcap``, ``summary.json``, ``logs/``) can be
    written: checked here, before anything starts, so a folder in the log's place is one line
    and exit 2 at once, not a recorder failing seconds into the run (its start-up is slow
    on a loaded machine)."""
    if folder is None:
        return
    for name in ("run.mcap", "summary.json"):
        if (folder / name).is_dir():
            fail(f"--out: expected a file name, {folder / name} is a folder")
    if (folder / "logs").exists() and not (folder / "logs").is_dir():
        fail(f"--out: expected a folder, {folder / 'logs'} is a file")


def _check_live(port: int, hexicon: bool, mode: str, transport: str) -> None:
    """``--live PORT``: a single-turbine run over Zenoh in real time or lock-step, on a port
    that is free on 127.0.0.1 (else exit 2 before anything starts)."""
    import socket

    if hexicon or mode == "inprocess" or transport != "zenoh":
        fail("--live: a single-turbine scenario over Zenoh in --mode realtime or lockstep only")
    if port:
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError as exc:
                fail(f"--live {port}: 127.0.0.1:{port} is not free ({exc.strerror or exc})")


def _launch_and_exit(req: Any, worker: PlotWorker | None = None) -> None:
    """``fowt run``'s launch (:func:`hil.launch.launch`, drawing in ``worker``) and exit
    code, any family."""
    from hil.families import RunRequestError
    from hil.launch import ProcessFaultError, RunAbortedError, RunFailedError, launch

    try:
        summary = launch(req, console, worker)
    except RunRequestError as exc:  # an option the scenario's family does not take
        fail(str(exc), code=ExitCode.USAGE)
    except RunAbortedError as exc:  # stopped before anything was recorded
        fail(str(exc), code=ExitCode.ABORTED)
    except ProcessFaultError as exc:  # the scenario's process faults and the mode disagree
        fail(str(exc), code=ExitCode.USAGE)
    except RunFailedError as exc:
        fail(f"run failed: {exc}", code=ExitCode.FAILED)
    except OSError as exc:  # e.g. the disk filled up while the summary or a plot was written
        fail(os_error_text(exc), code=ExitCode.FAILED)
    except ValueError as exc:  # a model refusing the scenario as built (e.g. its length)
        fail(f"run failed: {exc}", code=ExitCode.FAILED)
    raise typer.Exit(int(summary.get("run", {}).get("exit_code", ExitCode.OK)))


def _family_can(
    transport: str,
    can_interface: str | None,
    can_channel: str | None,
    can_fd: bool | None,
    ident: str,
) -> Any:
    """The CAN bus of a run of another family than the single turbine (None: Zenoh)."""
    if transport != "can":
        return None
    from hil.nodes.can_bus import CanBusConfig, CanConfigError

    try:
        can = CanBusConfig.for_interface(
            can_interface or "udp_multicast", can_channel, bool(can_fd), ident
        )
    except CanConfigError as exc:
        fail(str(exc))
    _check_can_device(can)
    return can


@app.command(short_help="Run the plant process alone.")
def plant(
    scenario: ScenarioArg = "default",
    mode: Annotated[
        str, typer.Option(help="realtime | lockstep", callback=choice("realtime", "lockstep"))
    ] = "realtime",
    speed: SpeedOpt = 1.0,
    duration: DurationOpt = None,
    listen: ListenOpt = None,
    connect: ConnectOpt = None,
    zenoh_config: ZenohConfigOpt = None,
    require: Annotated[
        str,
        typer.Option(
            help="Comma-separated nodes to wait for before the first cycle (controller,"
            " recorder, launcher), or none. The default waits for the recorder too, so the run"
            " is recorded from cycle 0.",
            callback=_require_list,
        ),
    ] = "controller,recorder",
    wait_timeout: Annotated[
        float,
        typer.Option(
            "--wait-timeout",
            help="Seconds to wait for the required nodes before giving up (exit 1); 0 waits"
            " until they come or Ctrl-C.",
            callback=number("s", ge=0.0, le=MAX_DURATION_S),
        ),
    ] = 120.0,
    transport: TransportOpt = "zenoh",
    can_interface: CanInterfaceOpt = None,
    can_channel: CanChannelOpt = None,
    can_fd: CanFdOpt = None,
    realtime_priority: RealtimePriorityOpt = 0,
    key_file: KeyFileOpt = None,
    insecure: InsecureOpt = False,
) -> None:
    """Run the plant process alone (the controller and the recorder run elsewhere).

    The plant waits for the nodes of --require, then runs the scenario. Ctrl-C or SIGTERM
    ends it at once, while it waits (exit 130 / 143, nothing ran) or runs (the run is
    closed with its final timing summary, exit 0).
    """
    sc = _scenario(scenario, duration)
    can = _can_config(sc, transport, can_interface, can_channel, can_fd)
    bus = _bus(
        listen,
        connect,
        zenoh_config,
        default_listen=("tcp/127.0.0.1:7447",),
        key_file=key_file,
        insecure=insecure,
    )
    from controller.discon import DisconError
    from hil.inprocess.trim import initial_condition
    from hil.nodes.plant_node import PeerWaitInterruptedError, run_plant_node

    try:  # the trim's settling run, before any peer waits
        initial = initial_condition(sc)
    except (ValueError, DisconError) as exc:  # e.g. a DISCON library or DISCON.IN
        fail(f"controller {sc.controller.kind!r}: {exc}", code=1)
    _realtime(realtime_priority, "plant")
    try:
        result = run_plant_node(
            sc,
            bus,  # type: ignore[arg-type]
            mode=mode,  # type: ignore[arg-type]
            speed=speed,
            require=tuple(r for r in require.split(",") if r),
            peer_timeout_s=wait_timeout if wait_timeout > 0 else math.inf,
            can=can,
            initial=initial,
        )
    except PeerWaitInterruptedError as exc:
        stderr.print(f"plant: {exc}", markup=False)
        sys.stdout.flush()
        sys.stderr.flush()
        # Nothing is left to clean up (the session is closed, nothing was written), and the
        # interpreter's normal teardown of the imported scipy stack takes 1-3 s on a loaded
        # 2-core machine: end the process now, as Ctrl-C asks.
        os._exit(128 + exc.signum)
    except TimeoutError as exc:
        fail(str(exc), code=1)
    if result.aborted and result.aborted != "stopped by signal":
        raise typer.Exit(1)


@app.command(short_help="Run the controller process alone.")
def controller(
    scenario: ScenarioArg = "default",
    duration: DurationOpt = None,
    listen: ListenOpt = None,
    connect: ConnectOpt = None,
    zenoh_config: ZenohConfigOpt = None,
    transport: TransportOpt = "zenoh",
    can_interface: CanInterfaceOpt = None,
    can_channel: CanChannelOpt = None,
    can_fd: CanFdOpt = None,
    realtime_priority: RealtimePriorityOpt = 0,
    key_file: KeyFileOpt = None,
    insecure: InsecureOpt = False,
    await_recorder: Annotated[
        float,
        typer.Option(
            "--await-recorder",
            min=0.0,
            help="Announce this controller (the liveliness token a plant waits for) only "
            "once a recorder's subscription reaches its status, waiting at most this many "
            "seconds (0: at once). fowt run sets it.",
        ),
    ] = 0.0,
) -> None:
    """Run the controller process alone (serves until the plant finishes or Ctrl-C).

    With --transport can it takes the sensor frames from and sends the commands to the CAN
    bus; its status and the plant's timing stay on Zenoh. With a recorder on the bus,
    --await-recorder keeps a plant from starting before the recorder can get this
    controller's messages.
    """
    sc = _scenario(scenario, duration)
    can = _can_config(sc, transport, can_interface, can_channel, can_fd)
    bus = _bus(
        listen,
        connect,
        zenoh_config,
        default_listen=("tcp/127.0.0.1:7448",),
        default_connect=("tcp/127.0.0.1:7447",),
        key_file=key_file,
        insecure=insecure,
    )
    _realtime(realtime_priority, "controller")
    from hil.inprocess.trim import operating_point
    from hil.nodes import controller_node

    trim = functools.partial(operating_point, sc)  # a trimmed run: the core's steady state
    if can is None:
        controller_node.run_controller_node(
            sc,
            bus,  # type: ignore[arg-type]
            await_recorder_s=await_recorder,
            operating_point=trim,
        )
        return
    from hil.nodes.can_bus import hybrid_bus_factory

    # In a CAN run the node's bus is a HybridBus (same surface: the sensor and command keys
    # on CAN, the rest on Zenoh), so its loop, validation and stale-frame handling run
    # unchanged.
    controller_node.run_controller_node(
        sc,
        bus,  # type: ignore[arg-type]
        bus_factory=hybrid_bus_factory(can),
        await_recorder_s=await_recorder,
        operating_point=trim,
    )


@app.command(short_help="Record a run to an MCAP file.")
def record(
    scenario: ScenarioArg = "default",
    out: Annotated[
        Path, typer.Option("--out", help="MCAP file to write.", callback=writable("file"))
    ] = Path("run.mcap"),
    duration: DurationOpt = None,
    listen: ListenOpt = None,
    connect: ConnectOpt = None,
    zenoh_config: ZenohConfigOpt = None,
    run_info: Annotated[
        str, typer.Option(help="JSON object stored as run metadata.", callback=_json_object)
    ] = "{}",
    transport: TransportOpt = "zenoh",
    can_interface: CanInterfaceOpt = None,
    can_channel: CanChannelOpt = None,
    can_fd: CanFdOpt = None,
    key_file: KeyFileOpt = None,
    insecure: InsecureOpt = False,
    live_forward: Annotated[
        bool,
        typer.Option(
            "--live-forward",
            help="Also put what is written on fowt/<turbine>/recorder/live for the live view"
            " (fowt run --live; hil.nodes.live_feed).",
            hidden=True,
        ),
    ] = False,
) -> None:
    """Record every fowt/<turbine>/** message to an MCAP file until the run ends.

    With --transport can it also listens on the CAN bus: the sensor frames and commands
    decoded from it, and every raw frame on fowt/<turbine>/can/raw.
    """
    sc = _scenario(scenario, duration)
    can = _can_config(sc, transport, can_interface, can_channel, can_fd)
    from hil.nodes.recorder import run_recorder_node

    bus = _bus(
        listen,
        connect,
        zenoh_config,
        default_connect=("tcp/127.0.0.1:7447", "tcp/127.0.0.1:7448"),
        key_file=key_file,
        insecure=insecure,
    )
    text, _ = scenario_text(scenario)
    info = {str(k): str(v) for k, v in json.loads(run_info).items()}
    try:
        run_recorder_node(
            sc,
            bus,  # type: ignore[arg-type]
            out,
            run_info=info,
            scenario_toml=text,
            can=can,
            live_forward=live_forward,
        )
    except OSError as exc:  # disk full, file too large: the file is readable up to it
        fail(f"recorder: writing failed: {os_error_text(exc, out)}", code=ExitCode.FAILED)


@app.command("live-node", hidden=True)
def live_node(
    scenario: ScenarioArg = "default",
    duration: DurationOpt = None,
    listen: ListenOpt = None,
    connect: ConnectOpt = None,
    zenoh_config: ZenohConfigOpt = None,
    key_file: KeyFileOpt = None,
    insecure: InsecureOpt = False,
    port: Annotated[int, typer.Option(help="TCP port on 127.0.0.1 (0: any).", min=0)] = 8765,
    summary: Annotated[
        Path | None, typer.Option(help="Write the counts here (JSON).", callback=writable("file"))
    ] = None,
) -> None:
    """Serve a run on its bus to Foxglove (fowt run --live starts it; hil.live.node)."""
    sc = _scenario(scenario, duration)
    from hil.live.node import run_live_node

    bus = _bus(
        listen,
        connect,
        zenoh_config,
        default_connect=("tcp/127.0.0.1:7447", "tcp/127.0.0.1:7448"),
        key_file=key_file,
        insecure=insecure,
    )
    try:
        run_live_node(sc, bus, port, summary)  # type: ignore[arg-type]
    except RuntimeError as exc:  # the port in use: the sdk's error, one line
        fail(f"live view: {exc}", code=ExitCode.FAILED)
    _exit_past_viewers()


def _exit_past_viewers() -> None:
    """Exit 0 now: everything is written, and the Foxglove sdk's exit hook would wait for
    every viewer's socket to close, which a viewer that does not read never does
    (:meth:`hil.live.server.LiveServer.close`)."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


@app.command(short_help="Replay a run log to Foxglove (the live view, no plant).")
def view(
    mcap: Annotated[Path, typer.Argument(help="Run log (MCAP) to replay.")],
    speed: Annotated[
        float,
        typer.Option(help="Times the recorded pace (0: as fast as it goes).", min=0.0),
    ] = 1.0,
    port: Annotated[
        int, typer.Option(help="TCP port on 127.0.0.1 (0: any free one).", min=0, max=65535)
    ] = LIVE_DEFAULT_PORT,
) -> None:
    """Serve a recorded run log on ws://127.0.0.1:PORT as 'fowt run --live' serves a run.

    Same channels, schemas, frame transforms and 3-D scene (docs/guide/live-view.md);
    paced by the file's log times. Ends at the file's end or on Ctrl-C.
    """
    import signal
    import threading

    from hil.live.replay import ReplayError, replay

    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())  # Ctrl-C ends the replay cleanly
    if not mcap.is_file():
        fail(f"{mcap}: no such file")
    try:
        stats = replay(
            mcap,
            port,
            speed,
            stop,
            on_ready=lambda p: console.print(
                f"serving {escape(str(mcap))} on ws://127.0.0.1:{p} (Foxglove: Open connection)"
            ),
        )
    except (ReplayError, ValueError) as exc:
        fail(str(exc))
    except RuntimeError as exc:  # the port in use
        fail(f"fowt view: {exc}", code=ExitCode.FAILED)
    console.print(f"replayed {stats.published} messages")
    _exit_past_viewers()


@app.command(short_help="Run the Zenoh router of a two-host bench.")
def router(
    zenoh_config: Annotated[
        Path,
        typer.Option(
            "--zenoh-config",
            help="Zenoh JSON5 config with mode router (config/zenoh-router.json5).",
        ),
    ],
) -> None:
    """Run the Zenoh router of a two-host bench (TLS, access control) until Ctrl-C.

    The same router as zenohd -c FILE of the same Zenoh version; see docs/multi-host.md.
    """
    from hil.nodes.router import RouterConfigError, run_router, zenoh_error_text

    try:
        run_router(zenoh_config, echo=console.print)
    except RouterConfigError as exc:
        fail(str(exc))
    except Exception as exc:  # zenoh.ZError: certificate file, port in use
        fail(f"router session did not open: {zenoh_error_text(exc)}", code=1)


#: ``summary["run"]`` keys only the launcher writes (:func:`hil.launch.launch`): a review of
#: the run's file keeps them in the summary.json it writes over the launcher's.
_LAUNCHER_RUN_KEYS = (
    "aborted",
    "abort_signal",
    "aborted_at_s",
    "failed",
    "failed_process",
    "launcher_wall_s",
    "inprocess_loop",
    "process_faults",
    "plant_killed",
    "process_fault_problems",
)


@app.command("review", short_help="Review a recorded run: KPIs, timing and plots.")
def review_cmd(
    mcap: Annotated[Path, typer.Argument(help="A run's MCAP file.")],
    out: Annotated[Path | None, typer.Option("--out", help="Folder for summary and plots.")] = None,
    plots: Annotated[
        bool | None,
        typer.Option(
            "--plots/--no-plots", help="Write PNG plots (default: yes, but no with --json)."
        ),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
    strict: Annotated[
        bool,
        typer.Option(
            "--strict",
            help="Exit non-zero unless the run is complete and healthy: 1 when the file is "
            "truncated, damaged or inconsistent or lacks the plant's final timing summary, "
            "else the code 'fowt run' gives the run (3 aborted, 4 recording incomplete, 5 "
            "safe state, 6 deadline misses; docs/exit-codes.md).",
        ),
    ] = False,
) -> None:
    """Review a recorded run: KPIs, timing and plots.

    Everything comes from the MCAP file alone. The summary and the plots are written into
    --out (default: the file's folder, over what the run wrote there), each file named as
    written; the last line is the verdict 'fowt run' gives the run, 'outcome: <word> (exit
    <code>): <reasons>' (on stderr with --json). The exit code is 0 unless --strict.
    """
    from hil.review.core import (
        NotRunLogError,
        render_summary,
        review,
        review_problems,
        truncation_note,
    )
    from hil.review.outcome import outcome_line, record_outcome, run_outcome
    from hil.review.plot_worker import PlotWorker
    from hil.runlog.mcap_io import NotMcapError

    if not mcap.is_file():
        fail(f"{mcap} is not a file")
    # What only the launcher knew (aborted, failed, process faults, its verdict) is in the
    # run's summary.json beside the file: read it before the review writes its own there,
    # and keep it in that one.
    beside = mcap.parent / "summary.json"
    launched: dict[str, Any] = {}
    with contextlib.suppress(OSError, ValueError, AttributeError):
        if beside.is_file():
            launched = {
                k: v
                for k, v in json.loads(beside.read_text()).get("run", {}).items()
                if k in _LAUNCHER_RUN_KEYS
            }
    written: list[Path] = []
    draw = (not as_json) if plots is None else plots
    # matplotlib imported on the other core while the file is read (hil.review.plot_worker)
    worker = PlotWorker.start() if draw else None
    try:
        summary = review(mcap, out, plots=draw, written=written, worker=worker)
    except (NotMcapError, NotRunLogError) as exc:
        fail(str(exc))
    except OSError as exc:
        fail(os_error_text(exc, mcap))
    finally:
        if worker is not None:
            worker.close()
    for key, value in launched.items():
        summary["run"].setdefault(key, value)
    if launched:
        record_outcome(summary)
        again = (out if out is not None else mcap.parent) / "summary.json"
        try:
            again.write_text(json.dumps(summary, indent=2) + "\n")
        except OSError as exc:
            fail(os_error_text(exc, again), code=ExitCode.FAILED)
        written.append(again)
    note = truncation_note(summary)
    # With --json stdout is the summary alone: what was written and the verdict go to stderr.
    tell = stderr if as_json else console
    if as_json:
        sys.stdout.write(json.dumps(summary, indent=2) + "\n")
        if note:
            stderr.print(Text.assemble(("warning: ", "yellow"), f"{mcap}: {note}"))
    else:
        render_summary(summary, console)
    problems = review_problems(summary)
    if note is not None or problems or summary["run"].get("statistics_ok") is False:
        # the file cannot be judged as a run: the review's own failure (exit 1)
        reason = "; ".join(([note] if note else []) + problems) or str(summary["run"].get("error"))
        code, reasons = ExitCode.FAILED, [reason]
    else:
        code, reasons = run_outcome(summary)  # the verdict 'fowt run' gave (hil.review.outcome)
    failing = strict and code != ExitCode.OK
    if not (as_json and failing):  # a failing --json --strict says one line, the error
        for path in dict.fromkeys(written):  # summary.json is written twice with launcher keys
            kind = "summary:" if path.suffix == ".json" else "plot:   "
            tell.print(f"{kind} {path}", markup=False, soft_wrap=True)
    if failing:
        fail(f"--strict: {mcap}: {outcome_line(code, reasons)}", code=code)
    # the verdict 'fowt run' ends with; exit 0 here all the same (--strict: exit with it)
    tell.print(outcome_line(code, reasons), markup=False, soft_wrap=True)


@app.command("recover", short_help="Make a truncated MCAP file complete.")
def recover_cmd(
    mcap: Annotated[Path, typer.Argument(help="A truncated MCAP file (e.g. recorder killed).")],
    out: Annotated[
        Path | None, typer.Option("--out", help="Output file (default: <name>.recovered.mcap).")
    ] = None,
) -> None:
    """Make a truncated or damaged MCAP file complete.

    The new file holds every message that can be read, with summary and footer: a damaged
    chunk is skipped and the chunks after it kept. One line per lost range says how many
    messages it held (from the input's chunk indexes or message indexes; "unknown number"
    when they cannot say), its bytes and log times. Exit 0 only when every message of the
    input is known to be in the new file, 4 (recording incomplete) otherwise.
    """
    from hil.runlog.mcap_io import NotMcapError, recover_report

    if not mcap.is_file():
        fail(f"{mcap} is not a file")
    target = out if out is not None else mcap.with_suffix(".recovered.mcap")
    if target.resolve() == mcap.resolve():
        fail("--out must differ from the input file")
    try:
        result = recover_report(mcap, target)
    except NotMcapError as exc:
        fail(str(exc))
    except OSError as exc:
        fail(os_error_text(exc, target))
    for r in result.lost:  # plain lines: never wrapped, one per range
        sys.stdout.write(f"{r.lost_line()}\n")
    of = "" if result.expected is None else f" of {result.expected}"
    console.print(f"recovered {result.kept}{of} messages into {target}", markup=False)
    if not result.complete:
        n = result.lost_count
        what = "an unknown number of messages" if n is None else f"{n} messages"
        stderr.print(
            f"warning: {what} lost in {len(result.lost)} range(s); the new file lacks them",
            markup=False,
        )
        raise typer.Exit(int(ExitCode.RECORDING_INCOMPLETE))


def _write_rows(rows: list[tuple[str, str]], indent: str = "") -> None:
    """Name and text columns, one line each, never truncated (long lines wrap in the terminal)."""
    width = max((len(name) for name, _ in rows), default=0)
    for name, text in rows:
        sys.stdout.write(f"{indent}{name:<{width}}  {text}".rstrip() + "\n")


@app.command(short_help="List the shipped scenarios (every plant family).")
def scenarios() -> None:
    """List the shipped scenarios that 'fowt run' takes: single turbine (name, description,
    plant, controller, duration), then Hexicon H3 (hexicon-<name>)."""
    from hil.families import list_scenarios

    rows = [row for names in list_scenarios().values() for row in names.items()]
    _write_rows(rows)


def _preset_rows(package: str, folder: str = "") -> list[tuple[str, str]]:
    """(name, first comment line) of every ``*.toml`` preset of ``package``/``folder``."""
    root = resources.files(package)
    if folder:
        root = root / folder
    rows = []
    for entry in sorted(root.iterdir(), key=lambda e: e.name):
        if not entry.name.endswith(".toml"):
            continue
        first = next(
            (ln.lstrip("# ").strip() for ln in entry.read_text().splitlines() if ln.strip()), ""
        )
        rows.append((entry.name.removesuffix(".toml"), first if first else "-"))
    return rows


@app.command(short_help="List the shipped presets.")
def presets() -> None:
    """List the shipped presets: turbines, floating platforms and controllers.

    A scenario names them with turbine = "<name>", platform = "<name>" and, in its
    [controller] table, preset = "<name>". The text is each preset file's first line.
    """
    sections = (
        ('turbine presets (turbine = "<name>")', _preset_rows("plant.presets")),
        (
            'floating platform presets (platform = "<name>")',
            _preset_rows("plant.presets", "floating"),
        ),
        ('controller presets ([controller] preset = "<name>")', _preset_rows("controller.presets")),
    )
    for i, (title, rows) in enumerate(sections):
        sys.stdout.write(("\n" if i else "") + title + "\n")
        _write_rows(rows, indent="  ")


@app.command("cache", short_help="Show or clear the stored trims.")
def cache_cmd(
    clear: Annotated[bool, typer.Option("--clear", help="Remove every stored trim.")] = False,
) -> None:
    """Show where the settled rotor points of trimmed starts are stored, and how many (and
    where the controller design artefacts made on first use are).

    A trimmed run reads its steady rotor point from there when an earlier process settled
    the same scenario with the same code, instead of a settling run (FOWT_CACHE_DIR sets
    the directory, FOWT_CACHE_DIR=off turns the store off).
    """
    from hil.inprocess import trim_store

    root = trim_store.cache_root()
    if root is None:
        sys.stdout.write("trim store: off (FOWT_CACHE_DIR=off)\n")
        return
    if clear:
        try:
            removed = trim_store.clear()
        except OSError as exc:
            fail(f"trim store: {os_error_text(exc)}")
        sys.stdout.write(f"trim store: {root / 'trim'}: {removed} entries removed\n")
        return
    found = trim_store.entries()
    size = sum(p.stat().st_size for p in found if p.exists())
    sys.stdout.write(f"trim store: {root / 'trim'}: {len(found)} entries, {size} B\n")
    from controller.lqri import user_design_dir

    designs = user_design_dir()
    made = sorted(designs.glob("*.json")) if designs.is_dir() else []
    sys.stdout.write(
        f"design artefacts made on first use: {designs}: {len(made)} "
        "(FOWT_DESIGN_DIR; not cleared by --clear)\n"
    )


analyze_app = typer.Typer(
    help="Offline analysis: platform modes, design model, wave forecasters.",
    short_help="Offline analysis: modes, design model, forecasters.",
    no_args_is_help=True,
    rich_markup_mode=None,
)
preset_app = typer.Typer(
    help="Import plant presets from other tools (list the shipped ones: fowt presets).",
    short_help="Import plant presets from other tools.",
    no_args_is_help=True,
    rich_markup_mode=None,
)
app.add_typer(analyze_app, name="analyze")
app.add_typer(preset_app, name="preset")
app.add_typer(
    hexicon_app, name="hexicon", short_help="The Hexicon H3 multi-turbine platform family."
)


T = TypeVar("T")

WindOpt = Annotated[
    float,
    typer.Option(
        "--wind",
        help="Steady hub-height wind of the model, m/s.",
        callback=number("m/s", gt=0.0, le=70.0),
    ),
]

#: ``analyze modes`` also takes 0 m/s: parked in still air, no aerodynamic damping.
ModesWindOpt = Annotated[
    float,
    typer.Option(
        "--wind",
        help="Steady hub-height wind of the model, m/s (0: parked, no aerodynamic damping).",
        callback=number("m/s", ge=0.0, le=70.0),
    ),
]


def _analysis(fn: Callable[[str, float], T], preset: str, wind: float) -> T:
    """Run an analysis of ``preset`` at ``wind`` (m/s); bad input exits 2 with the reason."""
    try:
        return fn(preset, wind)
    except (ValueError, OSError) as exc:
        fail(str(exc))


@analyze_app.command("modes", short_help="Natural periods and damping of the platform modes.")
def analyze_modes(
    preset: Annotated[
        str, typer.Argument(help="Floating preset name or preset .toml path.", callback=_preset_ref)
    ],
    wind: ModesWindOpt = 5.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the modes as JSON.")] = False,
    torque_slope: Annotated[
        float,
        typer.Option(
            "--torque-slope",
            help="Generator-torque law in the loop, dT/domega in N m s/rad (default 0: open loop).",
            callback=number("N m s/rad", ge=0.0),
        ),
    ] = 0.0,
) -> None:
    """Damped natural periods and damping ratios of surge, heave, pitch and tower fore-aft.

    Linearises the floating model about its steady operating point at --wind
    (plant.modes.natural_modes): period T = 2 pi / omega_d [s], damping ratio
    zeta = -Re(lambda) / |lambda| [-]. Open loop: no controller; blade pitch and generator
    torque held at the operating point, rotor speed free (the case of OpenFAST
    linearisations above rated).
    """
    from plant.modes import OPEN_LOOP_CASE, modal_analysis

    modes, free = _analysis(
        lambda p, w: modal_analysis(p, w, torque_slope_nm_s_rad=torque_slope), preset, wind
    )
    case = (
        "parked in still air: rotor at rest, no aerodynamic forces and no aerodynamic "
        "damping (hydrodynamic, mooring and structural damping only)"
        if wind == 0.0
        else OPEN_LOOP_CASE
        if torque_slope == 0.0
        else f"generator-torque law in the loop (dT/domega = {torque_slope:g} N m s/rad), "
        "blade pitch held, rotor speed free; rotor aerodynamics quasi-steady from the Cp/Ct/Cq "
        "table (equilibrium wake)"
    )
    if as_json:
        out = {
            "preset": preset,
            "wind_m_s": wind,
            "case": case,
            "modes": [m.as_dict() for m in modes],
            "no_restoring": free,
        }
        sys.stdout.write(json.dumps(out, indent=2) + "\n")
        return
    table = Table(title=f"Natural modes of {escape(preset)} at {wind:g} m/s")
    table.add_column("mode")
    table.add_column(escape("damped period [s]"), justify="right")
    table.add_column(escape("damping ratio [-]"), justify="right")
    for m in modes:
        table.add_row(m.name, f"{m.period_s:.2f}", f"{m.damping_ratio:.4f}")
    table.caption = case
    console.print(table)
    for name in free:
        console.print(
            f"no restoring in {name}: no natural mode (nothing pulls it back, e.g. no mooring)",
            markup=False,
        )


@app.command("design", short_help="Offline controller design: LQRI, wave FF, observer.")
def design_cmd(
    preset: Annotated[
        str, typer.Argument(help="Floating preset name or preset .toml path.", callback=_preset_ref)
    ] = "iea15mw_volturnus",
    control_period: Annotated[
        float,
        typer.Option(
            "--control-period",
            help="Control period of the discrete gains and filters, s.",
            callback=number("s", ge=0.001, le=1.0),
        ),
    ] = 0.025,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="Folder for the artefacts (default: the shipped designs).",
            callback=writable("folder"),
        ),
    ] = None,
    lqr_wave: Annotated[
        str | None,
        typer.Option(
            "--lqr-wave",
            help="Design the lqr_wave gain table instead: variant lqr1 or lqr2 (christiansen).",
        ),
    ] = None,
    decoupled: Annotated[
        bool,
        typer.Option(
            "--decoupled",
            help="With --lqr-wave: gains on the seed's model without surge-pitch coupling "
            "(same file name: give --out a folder of its own).",
        ),
    ] = False,
    published_weights: Annotated[
        bool,
        typer.Option(
            "--published-weights",
            help="With --lqr-wave: the seed's published Bryson weights only (no rotor-speed "
            "weight; same file name: give --out a folder of its own).",
        ),
    ] = False,
) -> None:
    """Offline controller design: LQRI gain schedule, wave-FF filters, platform observer.

    Calls controller.design.design_all: <preset>_lqri_dt<T>.npz/.json,
    <preset>_waveff_dt<T>.npz/.json (discrete at --control-period) and
    <preset>_observer.npz/.json (continuous). 'fowt run' looks in the shipped designs, then
    in $FOWT_DESIGN_DIR (default ~/.cache/fowt-hil/designs).
    """
    import time

    from controller.design import BLAS_SINGLE_THREAD_ENV, design_all

    if "numpy" not in sys.modules:  # one BLAS thread: see controller.design's docstring
        for var, value in BLAS_SINGLE_THREAD_ENV.items():
            os.environ.setdefault(var, value)

    t0 = time.perf_counter()
    if (decoupled or published_weights) and lqr_wave is None:
        fail("--decoupled and --published-weights go with --lqr-wave")
    if lqr_wave is not None:
        from controller.design.lqr_wave import LqrWaveSettings, design_lqr_wave

        try:
            settings = LqrWaveSettings(
                variant=lqr_wave,
                decoupled=decoupled,
                **({"rotor_speed_max_rad_s": 0.0} if published_weights else {}),
            )
            npz = design_lqr_wave(preset, control_period, settings, out)
        except (ValueError, OSError) as exc:
            fail(str(exc))
        console.print(f"lqr_wave: {npz}", markup=False)
        console.print(f"designed in {time.perf_counter() - t0:.1f} s")
        return
    try:
        paths = design_all(preset, control_period, out)
    except (ValueError, OSError) as exc:
        fail(str(exc))
    for key, path in paths.items():
        console.print(f"{key}: {path}", markup=False)
    console.print(f"designed in {time.perf_counter() - t0:.1f} s")


@analyze_app.command(
    "linear", short_help="Design-model poles, LQRI and baseline closed-loop modes."
)
def analyze_linear(
    preset: Annotated[
        str, typer.Argument(help="Floating preset name or preset .toml path.", callback=_preset_ref)
    ],
    wind: WindOpt = 15.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the report as JSON.")] = False,
) -> None:
    """Design-model modes and poles, open loop, with the LQRI's gains and with the baseline
    controller, at --wind."""
    from controller.design import linear_report

    report = _analysis(linear_report, preset, wind)
    if as_json:
        sys.stdout.write(json.dumps(report, indent=2) + "\n")
        return
    table = Table(title=f"Design model of {escape(preset)} at {wind:g} m/s")
    table.add_column("mode")
    table.add_column(escape("damped period [s]"), justify="right")
    table.add_column(escape("damping ratio [-]"), justify="right")
    table.add_column(escape("with LQRI: period [s]"), justify="right")
    table.add_column(escape("with LQRI: damping [-]"), justify="right")
    table.add_column(escape("baseline: period [s]"), justify="right")
    table.add_column(escape("baseline: damping [-]"), justify="right")
    closed = {m["name"]: m for m in report["closed_loop_modes"]}  # type: ignore[attr-defined]
    base = {m["name"]: m for m in report["baseline_closed_loop_modes"]}  # type: ignore[attr-defined]
    for m in report["modes"]:  # type: ignore[attr-defined]
        c = closed.get(m["name"])
        b = base.get(m["name"])
        table.add_row(
            str(m["name"]),
            f"{m['period_s']:.2f}",
            f"{m['damping_ratio']:.4f}",
            f"{c['period_s']:.2f}" if c else "-",
            f"{c['damping_ratio']:.4f}" if c else "-",
            f"{b['period_s']:.2f}" if b else "-",
            f"{b['damping_ratio']:.4f}" if b else "-",
        )
    console.print(table)
    console.print(
        "with LQRI: the design model with the LQRI's gains at this wind (full state feedback,"
        " no observer); heave is not in the LQRI's model"
    )
    console.print(
        f"closed-loop spectral radius (z): {report['closed_loop_spectral_radius']:.5f}; "
        f"rotor pole {report['rotor_pole_1_s']:.4f} 1/s"
    )
    console.print(
        "baseline: the plant with the baseline controller's own step linearised about their"
        " steady state (discrete at 0.025 s, no sensor noise); "
        + escape(str(report["baseline_closed_loop_case"]))
    )


@analyze_app.command("damping-map", short_help="Open-loop platform-pitch damping over wind, waves.")
def analyze_damping_map(
    preset: Annotated[
        str, typer.Argument(help="Floating preset name or preset .toml path.", callback=_preset_ref)
    ] = "nrel5mw_oc3_hywind",
    as_json: Annotated[bool, typer.Option("--json", help="Print the whole map as JSON.")] = False,
    decoupled: Annotated[
        bool,
        typer.Option(
            "--decoupled",
            help="On the seed's model: surge-pitch coupling removed from mass, added mass, "
            "damping and stiffness (christiansen-2013 sect. 2.1).",
        ),
    ] = False,
) -> None:
    """Open-loop damping ratio of the platform-pitch mode over wind speed (3-25 m/s) and wave
    frequency (0.05-3 rad/s), christiansen-2013 sect. 2.9 (controller.design.lqr_wave)."""
    from controller.design.lqr_wave import damping_map

    try:
        report = damping_map(preset, decoupled=decoupled)
    except (ValueError, OSError) as exc:
        fail(str(exc))
    if as_json:
        sys.stdout.write(json.dumps(report) + "\n")
        return
    console.print(
        f"platform-pitch damping ratio: max {report['max_damping_ratio']:.4f} at "
        f"{report['max_at_wind_m_s']:g} m/s, wave {report['max_at_wave_omega_rad_s']:g} rad/s "
        f"({report['max_at_wave_hz']:.3f} Hz); {report['seed_max']}"
    )


@analyze_app.command("forecast", short_help="VAF of each wave forecaster on a seeded sea.")
def analyze_forecast(
    hs: Annotated[
        float,
        typer.Option(
            "--hs", help="JONSWAP significant height, m.", callback=number("m", gt=0.0, le=30.0)
        ),
    ] = 2.2,
    tp: Annotated[
        float,
        typer.Option("--tp", help="JONSWAP peak period, s.", callback=number("s", gt=0.0, le=40.0)),
    ] = 8.0,
    distance: Annotated[
        float,
        typer.Option(
            "--distance",
            help="Gauge distance up-wave, m.",
            callback=number("m", ge=0.0, le=10_000.0),
        ),
    ] = 450.0,
    horizon: Annotated[
        float,
        typer.Option(
            "--horizon", help="Forecast horizon, s.", callback=number("s", gt=0.0, le=120.0)
        ),
    ] = 10.0,
    duration: Annotated[
        float,
        typer.Option(
            "--duration",
            help="Evaluated seconds of the seeded sea (after the dispersion filter fills).",
            callback=number("s", gt=0.0, le=36_000.0),
        ),
    ] = 600.0,
    forecaster: Annotated[
        list[str] | None,
        typer.Option(
            "--forecaster",
            help="dispersion | ar | esprit (repeatable; default: all three).",
            callback=_forecasters,
        ),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the report as JSON.")] = False,
    grid: Annotated[
        bool,
        typer.Option(
            "--grid",
            help="VAF table over Hs 1-8 m x Tp 6-14 s with 0.02 m sensor noise (--hs/--tp unused).",
        ),
    ] = False,
) -> None:
    """VAF of each wave forecaster (dispersion, AR, ESPRIT) on a seeded sea, runtime code."""
    from hil.review.forecast import forecast_grid, forecast_report

    kinds = tuple(forecaster) if forecaster else ("dispersion", "ar", "esprit")
    try:
        if grid:
            report = forecast_grid(distance_m=distance, horizon_s=horizon)
        else:
            report = forecast_report(
                hs_m=hs,
                tp_s=tp,
                distance_m=distance,
                horizon_s=horizon,
                duration_s=duration,
                kinds=kinds,
            )
    except ValueError as exc:
        fail(str(exc))
    if as_json:
        sys.stdout.write(json.dumps(report, indent=2, default=str) + "\n")
        return
    if grid:
        table = Table(title=f"forecast VAF (%), gauge {distance:g} m, horizon {horizon:g} s")
        for col in ("Hs m", "Tp s", "dispersion", "AR", "ESPRIT", "AR/ESPRIT stabilised fits"):
            table.add_column(col, justify="right")
        for row in report["rows"]:
            d, a, e = row["dispersion"], row["ar"], row["esprit"]
            table.add_row(
                f"{row['hs_m']:g}",
                f"{row['tp_s']:g}",
                f"{d['vaf_percent']:.1f}",
                f"{a['vaf_percent']:.1f}",
                f"{e['vaf_percent']:.1f}",
                f"{a['unstable_fits']}/{a['trainings']}, {e['unstable_fits']}/{e['trainings']}",
            )
        console.print(table)
        return
    sea = report["sea_state"]
    table = Table(
        title=escape(
            f"Wave forecast VAF, JONSWAP Hs {sea['hs_m']:g} m, Tp {sea['tp_s']:g} s, "
            f"gauge {sea['distance_m']:g} m up-wave, seed {sea['seed']}, "
            f"{sea['duration_s']:g} s evaluated"
        )
    )
    table.add_column("forecaster")
    table.add_column("input")
    table.add_column(escape("horizon [s]"), justify="right")
    table.add_column(escape("VAF [%]"), justify="right")
    table.add_column(escape("model period [s]"), justify="right")
    table.add_column(escape("mean step [us]"), justify="right")
    for kind, entry in report["forecasters"].items():
        vaf = entry["vaf_percent"]
        table.add_row(
            kind,
            escape(str(entry["input"])),
            f"{entry['horizon_s']:g}",
            "-" if not math.isfinite(vaf) else f"{vaf:.1f}",
            f"{entry['sample_period_s']:g}",
            f"{entry['mean_step_us']:.1f}",
        )
    console.print(table)


@preset_app.command("import-openfast", short_help="Import a floating OpenFAST deck as a preset.")
def preset_import_openfast(
    fst_file: Annotated[
        Path, typer.Argument(help="The OpenFAST deck's .fst file.", callback=text_file)
    ],
    out: Annotated[
        Path,
        typer.Option("--out", help="Folder for the preset files.", callback=writable("folder")),
    ] = Path("presets"),
    name: Annotated[
        str | None, typer.Option("--name", help="File stem / preset name (default: deck title).")
    ] = None,
    turbine: Annotated[
        str, typer.Option("--turbine", help="Turbine preset the platform carries.")
    ] = "iea15mw",
    no_mooring: Annotated[
        bool,
        typer.Option(
            "--no-mooring",
            help="Import without the mooring (no MoorDyn file needed): the preset then has "
            "zero mooring force and stiffness, so surge has no restoring stiffness.",
        ),
    ] = False,
    radiation_omega_max: Annotated[
        float,
        typer.Option(
            "--radiation-omega-max",
            help="Upper end of the radiation fit band, rad/s (0: the whole band of the data).",
            callback=number("rad/s", ge=0.0, le=100.0),
        ),
    ] = 2.0,
    drop_duplicate_addclin: Annotated[
        bool,
        typer.Option(
            "--drop-duplicate-addclin",
            help="Drop the diagonal AddCLin entries that repeat a restoring the import already "
            "models (the fill groups' ballast gravity, the strip-theory members' hydrostatics); "
            "without it they are kept and a warning names them.",
        ),
    ] = False,
) -> None:
    """Import a floating OpenFAST deck as a platform preset (TOML + hydro, mooring data).

    Prints the mass budget (platform structure, filled-member ballast, tower, rotor-nacelle
    assembly) and the derived figures; see docs/openfast-import.md.
    """
    from plant.openfast_import import import_openfast, write_preset

    try:
        deck = import_openfast(
            fst_file,
            turbine=turbine,
            name=name,
            mooring=not no_mooring,
            radiation_omega_max_rad_s=radiation_omega_max,
            drop_duplicate_addclin=drop_duplicate_addclin,
        )
        path = write_preset(deck, out, stem=name)
    except (ValueError, OSError) as exc:
        fail(str(exc))
    for item, kg in deck.mass_budget:
        console.print(f"mass {item}: {kg:.6g} kg", markup=False)
    for note in deck.notes:
        if note.startswith("stiffness budget "):
            console.print(note, markup=False)
    for warning in deck.warnings:
        console.print(f"warning: {warning}", markup=False)
    p = deck.preset
    console.print(
        f"platform (structure and ballast): mass {p.platform_mass_kg:.6g} kg, CM x "
        f"{p.platform_cm_x_m:.6g} m, z {p.platform_cm_z_m:.6g} m, pitch inertia about its CM "
        f"{p.platform_pitch_inertia_kg_m2:.6g} kg m^2",
        markup=False,
    )
    if deck.members is not None:
        m = deck.members
        console.print(
            f"strip-theory members (PropPot = FALSE): {m.count}, submerged volume "
            f"{m.volume_m3:.6g} m^3, buoyancy {m.force_n[2]:.6g} N, waterplane area "
            f"{m.waterplane_area_m2:.6g} m^2 (added to the WAMIT body's PtfmVol0 "
            f"{p.displaced_volume_m3:.6g} m^3)",
            markup=False,
        )
    if no_mooring:
        console.print(
            "imported without mooring: the preset has zero mooring force and stiffness "
            "(surge has no restoring stiffness; add a mooring before running it)",
            markup=False,
        )
    for line in _radiation_lines(path):
        console.print(line, markup=False)
    console.print(f'wrote {path} (use it as `platform = "{path}"` in a scenario)', markup=False)


def _radiation_lines(preset_toml: Path) -> list[str]:
    """The radiation fit the import chose (order, band, error per DOF and DOF pair)."""
    import msgspec

    from plant.hydro.radiation import RadiationModel
    from plant.openfast_import import radiation_report

    name = msgspec.toml.decode(preset_toml.read_bytes()).get("radiation_file", "")
    if not name:
        return []
    return radiation_report(RadiationModel.load_npz(preset_toml.parent / name))


def _register_campaign_commands() -> None:
    from hil.cli.campaign import register
    from hil.cli.controllers import register as register_controllers

    register(app, console)
    register_controllers(app, console)
    from hil.cli.analyze_decay import register as register_decay

    register_decay(analyze_app, console)


_register_campaign_commands()


def _click_base(name: str) -> type[Exception]:
    """The parser's exception class ``name`` (typer's own copy of click, or click)."""
    return next(c for c in typer.BadParameter.__mro__ if c.__name__ == name)


def _bare_live(args: list[str]) -> list[str]:
    """``--live`` without a port (the next word not a number) means ``--live 8765``."""
    out = list(args)
    for i, a in enumerate(out):
        if a == "--live" and (i + 1 == len(out) or not out[i + 1].isdigit()):
            out[i] = f"--live={LIVE_DEFAULT_PORT}"
    return out


def entry() -> NoReturn:
    """The console script ``fowt`` and ``python -m hil``: :func:`main`, then the process ends
    without the interpreter's teardown.

    What :func:`main` raises as its exit (``SystemExit`` with a code) is ended by
    :func:`_leave`. Kept apart from :func:`main`, which only raises ``SystemExit``, so that
    a caller in the same interpreter (a test, a forked helper) gets its exception back.
    """
    try:
        main()
    except SystemExit as exc:
        _leave(exc)
    _leave(SystemExit(0))


def _leave(exc: SystemExit) -> NoReturn:
    """End the process with ``exc``'s code: the exit handlers, the streams flushed, then
    :func:`os._exit`, without the interpreter's teardown.

    The teardown frees every module's objects one by one (numba's typing tables, LLVM's
    modules, matplotlib's: hundreds of thousands): about 0.05 s of every command's exit,
    measured after a ``fowt run``, for memory the operating system takes back at once.
    What the command needs of an exit still happens: the exit handlers run (:mod:`atexit`:
    multiprocessing's, logging's, temporary folders' finalizers), standard output and error
    are flushed, and the commands close their own files. :mod:`multiprocessing`'s children
    end the same way. Where it would change the outcome the interpreter exits as usual: another
    Python thread still running (the interpreter would wait for it), or an exit that carries
    a message instead of a code (the interpreter prints it).
    """
    code = exc.code
    if threading.active_count() > 1 or not (code is None or isinstance(code, int)):
        raise exc
    atexit._run_exitfuncs()  # the interpreter's own runner of them (private, in typeshed)
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):  # a reader that left: nothing more to say
            stream.flush()
    os._exit(code or 0)


def main(argv: list[str] | None = None) -> None:
    """The ``fowt`` command's body (:func:`entry` is the console script): ends by
    ``SystemExit`` with the command's exit code.

    Runs the app with the parser's own error printing off, so that a usage error (a bad
    option value, an unknown option, a missing argument) is one line, ``error: ...``, on
    stderr with exit code 2, like every other bad input; no arguments print the help.
    """
    args = _bare_live(sys.argv[1:] if argv is None else list(argv))
    # Where the interpreter's own exit runs (a caller of main(), a thread left running:
    # _leave), its last full collection would walk every object the imports and numba's
    # kernels made (millions) only to free memory the OS takes back anyway: 0.3-0.8 s,
    # measured. Frozen objects are skipped (files are closed by the commands themselves, not
    # by finalizers).
    atexit.register(gc.freeze)
    startup_gc()  # until the command's steady work (hil.nodes.rt.steady_gc)
    usage_error = _click_base("UsageError")
    click_error = _click_base("ClickException")
    try:
        rv: Any = app(args=args, prog_name="fowt", standalone_mode=False)
    except usage_error as exc:
        if type(exc).__name__ == "NoArgsIsHelpError":  # "fowt analyze": show that group's help
            app(args=[*args, "--help"], prog_name="fowt")
        text = exc.format_message()  # type: ignore[attr-defined]
        ctx = getattr(exc, "ctx", None)
        where = f" (see '{ctx.command_path} --help')" if ctx is not None else ""
        stderr.print(Text.assemble(("error: ", "bold red"), f"{text}{where}"))
        sys.exit(2)
    except click_error as exc:
        stderr.print(Text.assemble(("error: ", "bold red"), exc.format_message()))  # type: ignore[attr-defined]
        sys.exit(getattr(exc, "exit_code", 1))
    except typer.Abort:
        sys.exit(130)
    except BusOpenError as exc:  # a node whose session was refused: one line, not a traceback
        stderr.print(Text.assemble(("error: ", "bold red"), str(exc)))
        sys.exit(1)
    except OSError as exc:  # disk full, a folder gone read-only: the system's reason, one line
        stderr.print(Text.assemble(("error: ", "bold red"), os_error_text(exc)))
        sys.exit(1)
    except KeyboardInterrupt:  # Ctrl-C in a command that does not handle it itself
        stderr.print(Text.assemble(("error: ", "bold red"), "interrupted (SIGINT)"))
        sys.exit(130)
    sys.exit(rv if isinstance(rv, int) else 0)
