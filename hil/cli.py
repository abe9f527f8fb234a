"""The ``fowt`` command: run, plant, controller, record, review, scenarios, analyze, preset,
campaign, compare, report (the last three: :mod:`hil.campaign_cli`)."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, TypeVar

import typer
from rich.console import Console
from rich.table import Table

from hil.scenario import Scenario, ScenarioError, load_scenario, scenario_text, shipped_scenarios

if TYPE_CHECKING:
    from hil.can_bus import CanBusConfig

app = typer.Typer(
    help="fowt-hil: floating-wind controller-in-the-loop bench.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console()

ScenarioArg = Annotated[
    str, typer.Argument(help="Shipped scenario name (see `fowt scenarios`) or a TOML file.")
]
DurationOpt = Annotated[
    float | None, typer.Option("--duration", help="Simulated seconds (overrides the scenario).")
]
ListenOpt = Annotated[
    list[str] | None, typer.Option("--listen", help="Zenoh endpoint to listen on (repeatable).")
]
ConnectOpt = Annotated[
    list[str] | None, typer.Option("--connect", help="Zenoh endpoint to connect to (repeatable).")
]
ZenohConfigOpt = Annotated[
    Path | None,
    typer.Option(
        "--zenoh-config", help="Zenoh JSON5 config for multi-host use (router, TLS, ACL)."
    ),
]


RealtimePriorityOpt = Annotated[
    int,
    typer.Option(
        "--realtime-priority",
        help="SCHED_FIFO priority 1..40 for the plant and controller (root or CAP_SYS_NICE);"
        " 0 = normal scheduling.",
    ),
]
TransportOpt = Annotated[
    str,
    typer.Option(
        "--transport",
        help="zenoh | can: with can, the sensor frame and the command travel on CAN "
        "(python-can), everything else on the loopback Zenoh session.",
    ),
]
CanInterfaceOpt = Annotated[
    str | None,
    typer.Option(
        "--can-interface",
        help="udp_multicast (private network namespace) | socketcan | virtual "
        "(default: the scenario's [can] interface, else udp_multicast).",
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
    typer.Option("--can-fd/--no-can-fd", help="CAN FD frames (default: the scenario's [can])."),
]


def _can_config(
    sc: Scenario, transport: str, interface: str | None, channel: str | None, fd: bool | None
) -> CanBusConfig | None:
    """The node's CAN bus for ``--transport can`` (None for zenoh); exits 2 on a bad option."""
    if transport not in ("zenoh", "can"):
        console.print(f"[red]error:[/] --transport must be zenoh or can, not {transport!r}")
        raise typer.Exit(2)
    if transport == "zenoh":
        return None
    from hil.can_bus import CanBusConfig, CanConfigError

    try:
        return CanBusConfig.for_interface(
            interface or sc.can.interface,
            channel if channel is not None else sc.can.channel,
            sc.can.fd if fd is None else fd,
            sc.turbine_id,
        )
    except CanConfigError as exc:
        console.print(f"[red]error:[/] {exc}")
        raise typer.Exit(2) from exc


def _scenario(ref: str, duration: float | None) -> Scenario:
    try:
        return load_scenario(ref).with_duration(duration)
    except ScenarioError as exc:
        console.print(f"[red]error:[/] {exc}")
        raise typer.Exit(2) from exc


def _realtime(priority: int, who: str) -> None:
    """Switch this node to SCHED_FIFO before it opens its bus (threads inherit the policy)."""
    if priority == 0:
        return
    from hil.rt import RealtimeError, set_realtime_priority

    try:
        console.print(f"{who}: {set_realtime_priority(priority)}")
    except RealtimeError as exc:
        console.print(f"[red]error:[/] {exc}")
        raise typer.Exit(2) from exc


def _bus(listen: list[str] | None, connect: list[str] | None, zenoh_config: Path | None) -> object:
    from hil.bus import BusConfig, BusConfigError

    try:
        return BusConfig(
            listen=tuple(listen or ()), connect=tuple(connect or ()), config_file=zenoh_config
        )
    except BusConfigError as exc:
        console.print(f"[red]error:[/] {exc}")
        raise typer.Exit(2) from exc


@app.command()
def run(
    scenario: ScenarioArg = "default",
    mode: Annotated[str, typer.Option(help="realtime | lockstep | inprocess")] = "realtime",
    speed: Annotated[float, typer.Option(help="Real-time factor (realtime mode).")] = 1.0,
    duration: DurationOpt = None,
    transport: TransportOpt = "zenoh",
    can_interface: CanInterfaceOpt = None,
    can_channel: CanChannelOpt = None,
    can_fd: CanFdOpt = None,
    out: Annotated[Path | None, typer.Option("--out", help="Output folder.")] = None,
    plots: Annotated[bool, typer.Option(help="Write PNG plots.")] = True,
    realtime_priority: RealtimePriorityOpt = 0,
) -> None:
    """Launch plant, controller and recorder as separate processes, then review the run.

    ``--transport can`` puts the sensor frame and the command on a CAN bus between the
    plant and controller processes (the recorder listens too and logs the raw frames);
    with ``udp_multicast`` the launcher runs the whole bench in a fresh network namespace
    (``unshare -n``, root) unless it already is in a private one.
    """
    from hil.launch import RunFailedError, RunRequest, launch

    if mode not in ("realtime", "lockstep", "inprocess"):
        console.print(
            f"[red]error:[/] --mode must be realtime, lockstep or inprocess, not {mode!r}"
        )
        raise typer.Exit(2)
    if not speed > 0:
        console.print(f"[red]error:[/] --speed must be > 0, got {speed}")
        raise typer.Exit(2)
    sc = _scenario(scenario, duration)  # validate before launching anything
    can = _can_config(sc, transport, can_interface, can_channel, can_fd)
    if can is not None and mode == "inprocess":
        console.print("[red]error:[/] --mode inprocess has no bus: use lockstep or realtime")
        raise typer.Exit(2)
    req = RunRequest(
        scenario=scenario,
        mode=mode,  # type: ignore[arg-type]  # checked just above
        speed=speed,
        duration_s=duration,
        transport=transport,
        out_dir=out,
        plots=plots,
        can=can,
        realtime_priority=realtime_priority,
    )
    try:
        launch(req, console)
    except RunFailedError as exc:
        console.print(f"[red]run failed:[/] {exc}")
        raise typer.Exit(1) from exc


@app.command()
def plant(
    scenario: ScenarioArg = "default",
    mode: Annotated[str, typer.Option(help="realtime | lockstep")] = "realtime",
    speed: Annotated[float, typer.Option(help="Real-time factor.")] = 1.0,
    duration: DurationOpt = None,
    listen: ListenOpt = None,
    connect: ConnectOpt = None,
    zenoh_config: ZenohConfigOpt = None,
    require: Annotated[
        str, typer.Option(help="Comma-separated nodes to wait for before starting.")
    ] = "controller",
    transport: TransportOpt = "zenoh",
    can_interface: CanInterfaceOpt = None,
    can_channel: CanChannelOpt = None,
    can_fd: CanFdOpt = None,
    realtime_priority: RealtimePriorityOpt = 0,
) -> None:
    """Run the plant process alone (the controller runs elsewhere)."""
    from hil.plant_node import run_plant_node

    sc = _scenario(scenario, duration)
    can = _can_config(sc, transport, can_interface, can_channel, can_fd)
    if mode not in ("realtime", "lockstep"):
        console.print(f"[red]error:[/] the plant runs realtime or lockstep, not {mode!r}")
        raise typer.Exit(2)
    bus = _bus(listen or ["tcp/127.0.0.1:7447"], connect, zenoh_config)
    _realtime(realtime_priority, "plant")
    try:
        result = run_plant_node(
            sc,
            bus,  # type: ignore[arg-type]
            mode=mode,  # type: ignore[arg-type]
            speed=speed,
            require=tuple(r for r in require.split(",") if r),
            can=can,
        )
    except TimeoutError as exc:
        console.print(f"[red]error:[/] {exc}")
        raise typer.Exit(1) from exc
    if result.aborted and result.aborted != "stopped by signal":
        raise typer.Exit(1)


@app.command()
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
) -> None:
    """Run the controller process alone (serves until the plant finishes or Ctrl-C).

    With ``--transport can`` it takes the sensor frames from and sends the commands to the
    CAN bus; its status and the plant's timing stay on Zenoh.
    """
    from hil import controller_node

    sc = _scenario(scenario, duration)
    can = _can_config(sc, transport, can_interface, can_channel, can_fd)
    bus = _bus(listen or ["tcp/127.0.0.1:7448"], connect or ["tcp/127.0.0.1:7447"], zenoh_config)
    _realtime(realtime_priority, "controller")
    if can is None:
        controller_node.run_controller_node(sc, bus)  # type: ignore[arg-type]
        return
    from hil.can_bus import hybrid_bus_factory

    # In a CAN run the node's bus is a HybridBus (same surface: the sensor and command keys
    # on CAN, the rest on Zenoh), so its loop, validation and stale-frame handling run
    # unchanged.
    controller_node.run_controller_node(sc, bus, bus_factory=hybrid_bus_factory(can))  # type: ignore[arg-type]


@app.command()
def record(
    scenario: ScenarioArg = "default",
    out: Annotated[Path, typer.Option("--out", help="MCAP file to write.")] = Path("run.mcap"),
    duration: DurationOpt = None,
    listen: ListenOpt = None,
    connect: ConnectOpt = None,
    zenoh_config: ZenohConfigOpt = None,
    run_info: Annotated[str, typer.Option(help="JSON object stored as run metadata.")] = "{}",
    transport: TransportOpt = "zenoh",
    can_interface: CanInterfaceOpt = None,
    can_channel: CanChannelOpt = None,
    can_fd: CanFdOpt = None,
) -> None:
    """Record every fowt/<turbine>/** message to an MCAP file until the run ends.

    With ``--transport can`` it also listens on the CAN bus: the sensor frames and commands
    decoded from it, and every raw frame on ``fowt/<turbine>/can/raw``.
    """
    from hil.recorder import run_recorder_node

    sc = _scenario(scenario, duration)
    can = _can_config(sc, transport, can_interface, can_channel, can_fd)
    bus = _bus(listen, connect or ["tcp/127.0.0.1:7447", "tcp/127.0.0.1:7448"], zenoh_config)
    text, _ = scenario_text(scenario)
    info = {str(k): str(v) for k, v in json.loads(run_info).items()}
    run_recorder_node(
        sc,
        bus,  # type: ignore[arg-type]
        out,
        run_info=info,
        scenario_toml=text,
        can=can,
    )


@app.command("review")
def review_cmd(
    mcap: Annotated[Path, typer.Argument(help="A run's MCAP file.")],
    out: Annotated[Path | None, typer.Option("--out", help="Folder for summary and plots.")] = None,
    plots: Annotated[bool, typer.Option(help="Write PNG plots.")] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
) -> None:
    """Summarise a recorded run: KPIs and timing from the MCAP file alone, plus plots."""
    from hil.review import render_summary, review

    if not mcap.is_file():
        console.print(f"[red]error:[/] {mcap} is not a file")
        raise typer.Exit(2)
    summary = review(mcap, out, plots=plots)
    if as_json:
        sys.stdout.write(json.dumps(summary, indent=2) + "\n")
    else:
        render_summary(summary, console)


@app.command()
def scenarios() -> None:
    """List the shipped scenarios."""
    table = Table("name", "turbine", "platform", "controller", "duration s", "description")
    for name in shipped_scenarios():
        sc = load_scenario(name)
        table.add_row(
            name,
            sc.turbine,
            sc.platform or "-",
            f"{sc.controller.kind}/{sc.controller.preset}",
            f"{sc.duration_s:g}",
            sc.description,
        )
    console.print(table)


analyze_app = typer.Typer(help="Offline analysis of plant presets.", no_args_is_help=True)
preset_app = typer.Typer(help="Plant presets: import from other tools.", no_args_is_help=True)
app.add_typer(analyze_app, name="analyze")
app.add_typer(preset_app, name="preset")


T = TypeVar("T")


def _analysis(fn: Callable[[str, float], T], preset: str, wind: float) -> T:
    """Run an analysis of ``preset`` at ``wind`` (m/s); bad input exits 2 with the reason."""
    if not wind > 0:
        console.print(f"[red]error:[/] --wind must be > 0 m/s, got {wind}")
        raise typer.Exit(2)
    try:
        return fn(preset, wind)
    except (ValueError, OSError) as exc:
        console.print(f"[red]error:[/] {exc}")
        raise typer.Exit(2) from exc


@analyze_app.command("modes")
def analyze_modes(
    preset: Annotated[str, typer.Argument(help="Floating preset name or preset .toml path.")],
    wind: Annotated[
        float, typer.Option("--wind", help="Steady hub-height wind of the linearisation, m/s.")
    ] = 5.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the modes as JSON.")] = False,
) -> None:
    """Damped natural periods and damping ratios of surge, heave, pitch and tower fore-aft.

    Linearises the floating model about its steady operating point at ``--wind``
    (:func:`plant.modes.natural_modes`): period T = 2π/ω_d, damping ratio ζ = −Re λ/|λ|.
    """
    from plant.modes import natural_modes

    modes = _analysis(natural_modes, preset, wind)
    if as_json:
        out = {"preset": preset, "wind_m_s": wind, "modes": [m.as_dict() for m in modes]}
        sys.stdout.write(json.dumps(out, indent=2) + "\n")
        return
    table = Table(title=f"Natural modes of {preset} at {wind:g} m/s")
    table.add_column("mode")
    table.add_column("damped period [s]", justify="right")
    table.add_column("damping ratio [-]", justify="right")
    for m in modes:
        table.add_row(m.name, f"{m.period_s:.2f}", f"{m.damping_ratio:.4f}")
    console.print(table)


@app.command("design")
def design_cmd(
    preset: Annotated[
        str, typer.Argument(help="Floating preset name or preset .toml path.")
    ] = "iea15mw_volturnus",
    control_period: Annotated[
        float,
        typer.Option(
            "--control-period", help="Control period of the discrete gains and filters, s."
        ),
    ] = 0.025,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Folder for the artefacts (default: the shipped designs)."),
    ] = None,
) -> None:
    """Offline controller design: LQRI gain schedule, wave-FF filters, platform observer.

    Calls :func:`controller.design.design_all`: ``<preset>_lqri_dt<T>.npz/.json``,
    ``<preset>_waveff_dt<T>.npz/.json`` (discrete at ``--control-period``) and
    ``<preset>_observer.npz/.json`` (continuous). ``fowt run`` looks in the shipped designs,
    then in ``$FOWT_DESIGN_DIR`` (default ``~/.cache/fowt-hil/designs``).
    """
    import os
    import time

    from controller.design import BLAS_SINGLE_THREAD_ENV, design_all

    if "numpy" not in sys.modules:  # one BLAS thread: see controller.design's docstring
        for var, value in BLAS_SINGLE_THREAD_ENV.items():
            os.environ.setdefault(var, value)

    if not 0.0 < control_period <= 1.0:
        console.print(f"[red]error:[/] --control-period must be in (0, 1] s, got {control_period}")
        raise typer.Exit(2)
    t0 = time.perf_counter()
    try:
        paths = design_all(preset, control_period, out)
    except (ValueError, OSError) as exc:
        console.print(f"[red]error:[/] {exc}")
        raise typer.Exit(2) from exc
    for key, path in paths.items():
        console.print(f"{key}: {path}")
    console.print(f"designed in {time.perf_counter() - t0:.1f} s")


@analyze_app.command("linear")
def analyze_linear(
    preset: Annotated[str, typer.Argument(help="Floating preset name or preset .toml path.")],
    wind: Annotated[float, typer.Option("--wind", help="Steady wind of the model, m/s.")] = 15.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the report as JSON.")] = False,
) -> None:
    """Design-model poles (with their modes) and the LQRI closed-loop poles at ``--wind``."""
    from controller.design import linear_report

    report = _analysis(linear_report, preset, wind)
    if as_json:
        sys.stdout.write(json.dumps(report, indent=2) + "\n")
        return
    table = Table(title=f"Design model of {preset} at {wind:g} m/s")
    table.add_column("mode")
    table.add_column("damped period [s]", justify="right")
    table.add_column("damping ratio [-]", justify="right")
    for m in report["modes"]:  # type: ignore[attr-defined]
        table.add_row(str(m["name"]), f"{m['period_s']:.2f}", f"{m['damping_ratio']:.4f}")
    console.print(table)
    console.print(
        f"closed-loop spectral radius (z): {report['closed_loop_spectral_radius']:.5f}; "
        f"rotor pole {report['rotor_pole_1_s']:.4f} 1/s"
    )


@analyze_app.command("forecast")
def analyze_forecast(
    hs: Annotated[float, typer.Option("--hs", help="JONSWAP significant height, m.")] = 2.2,
    tp: Annotated[float, typer.Option("--tp", help="JONSWAP peak period, s.")] = 8.0,
    distance: Annotated[
        float, typer.Option("--distance", help="Gauge distance up-wave, m.")
    ] = 450.0,
    horizon: Annotated[float, typer.Option("--horizon", help="Forecast horizon, s.")] = 10.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the report as JSON.")] = False,
) -> None:
    """VAF of each wave forecaster (dispersion, AR, ESPRIT) on a seeded sea, runtime code."""
    from hil.analyze_forecast import forecast_report

    try:
        report = forecast_report(hs_m=hs, tp_s=tp, distance_m=distance, horizon_s=horizon)
    except ValueError as exc:
        console.print(f"[red]error:[/] {exc}")
        raise typer.Exit(2) from exc
    if as_json:
        sys.stdout.write(json.dumps(report, indent=2, default=str) + "\n")
    else:
        console.print_json(json.dumps(report, default=str))


@preset_app.command("import-openfast")
def preset_import_openfast(
    fst_file: Annotated[Path, typer.Argument(help="The OpenFAST deck's .fst file.")],
    out: Annotated[Path, typer.Option("--out", help="Folder for the preset files.")] = Path(
        "presets"
    ),
    name: Annotated[
        str | None, typer.Option("--name", help="File stem / preset name (default: deck title).")
    ] = None,
    turbine: Annotated[
        str, typer.Option("--turbine", help="Turbine preset the platform carries.")
    ] = "iea15mw",
) -> None:
    """Import a floating OpenFAST deck as a platform preset (TOML + hydro, mooring data)."""
    from plant.openfast_import import import_openfast, write_preset

    if not fst_file.is_file():
        console.print(f"[red]error:[/] {fst_file} is not a file")
        raise typer.Exit(2)
    try:
        deck = import_openfast(fst_file, turbine=turbine, name=name)
        path = write_preset(deck, out, stem=name)
    except (ValueError, OSError) as exc:
        console.print(f"[red]error:[/] {exc}")
        raise typer.Exit(2) from exc
    console.print(f'wrote {path} (use it as `platform = "{path}"` in a scenario)')


def _register_campaign_commands() -> None:
    from hil.campaign_cli import register

    register(app, console)


_register_campaign_commands()


def main() -> None:
    """Entry point of ``python -m hil``."""
    app()
