"""``fowt hexicon ...``: the Hexicon H3 multi-turbine platform family on the bench."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

# The plant, controller (OSQP) and Zenoh imports are deferred to the commands, so
# ``fowt --help`` and the other commands do not pay for them.
CONTROLLERS = ("bang_bang", "mpc", "mpc_id")

app = typer.Typer(
    help="Hexicon H3-18MW: three turbines on one yawing platform (ayotte-2015).",
    no_args_is_help=True,
    rich_markup_mode=None,
)


def _check(scenario: str, controller: str) -> None:
    from hil.hexicon.model import load_scenarios  # noqa: PLC0415 - deferred (module comment)

    names = load_scenarios()
    if scenario not in names:
        raise typer.BadParameter(f"unknown scenario {scenario!r}; shipped: {', '.join(names)}")
    if controller not in CONTROLLERS:
        raise typer.BadParameter(f"unknown controller {controller!r}; expected {CONTROLLERS}")


@app.command("scenarios", short_help="List the platform scenarios (table 6, sensitivity).")
def scenarios() -> None:
    from hil.hexicon.model import load_scenarios  # noqa: PLC0415 - deferred (module comment)

    for name, scn in load_scenarios().items():
        typer.echo(f"{name:28s} {scn.duration_s:5.0f} s  {scn.comment}")


@app.command("run", short_help="Plant and controller processes over Zenoh, recorded to MCAP.")
def run(
    scenario: str,
    controller: Annotated[
        str, typer.Option(help="bang_bang, mpc (physical model) or mpc_id (identified model)")
    ] = "mpc",
    out: Annotated[Path, typer.Option(help="output directory (run.mcap, summary.json)")] = Path(
        "runs/hexicon"
    ),
    mode: Annotated[str, typer.Option(help="lockstep or realtime")] = "lockstep",
    duration: Annotated[float | None, typer.Option(help="override the length (s)")] = None,
    realtime_priority: Annotated[
        int, typer.Option(help="SCHED_FIFO priority of plant and controller (0: normal)")
    ] = 0,
    transport: Annotated[str, typer.Option(help="zenoh or can")] = "zenoh",
    can_interface: Annotated[
        str, typer.Option(help="udp_multicast (private netns) or socketcan")
    ] = "udp_multicast",
    can_channel: Annotated[str, typer.Option(help="CAN channel (default per interface)")] = "",
    can_fd: Annotated[bool, typer.Option(help="one CAN FD frame per message")] = False,
    noise: Annotated[bool, typer.Option(help="sensor channels of the preset")] = True,
    identified: Annotated[
        Path | None, typer.Option(help="identified-model artefact of mpc_id")
    ] = None,
) -> None:
    from hil.hexicon.nodes import run_over_zenoh  # noqa: PLC0415 - deferred (module comment)

    _check(scenario, controller)
    if mode not in ("lockstep", "realtime"):
        raise typer.BadParameter(f"--mode {mode!r}: expected lockstep or realtime")
    if transport not in ("zenoh", "can"):
        raise typer.BadParameter(f"--transport {transport!r}: expected zenoh or can")
    try:
        s = run_over_zenoh(
            scenario,
            controller,
            out,
            mode=mode,
            duration_s=duration,
            realtime_priority=realtime_priority,
            noise=noise,
            transport=transport,
            can_interface=can_interface,
            can_channel=can_channel,
            can_fd=can_fd,
            identified=str(identified) if identified else None,
        )
    except (RuntimeError, ValueError) as exc:
        typer.echo(f"error: {' '.join(str(exc).split())}", err=True)
        raise typer.Exit(2) from exc
    if s.get("plant_rc") != 0 or s.get("controller_rc") != 0:
        # One line on stderr; the nodes' own output goes to the summary file for the details.
        out.mkdir(parents=True, exist_ok=True)
        (out / "summary.json").write_text(json.dumps(s, indent=1) + "\n", encoding="utf-8")
        typer.echo(
            f"error: run failed: plant exited with {s.get('plant_rc')}, controller with "
            f"{s.get('controller_rc')}; their output: {out / 'summary.json'}",
            err=True,
        )
        raise typer.Exit(1)
    kpis = kpis_of_mcap(Path(s["mcap"]), scenario)
    s["kpis"] = kpis
    (out / "summary.json").write_text(json.dumps(s, indent=1) + "\n", encoding="utf-8")
    typer.echo(json.dumps({k: v for k, v in s.items() if "stderr" not in k}, indent=1))


def kpis_of_mcap(path: Path, scenario: str) -> dict[str, float]:
    """The review KPIs (:func:`hil.hexicon.model.compute_kpis`) of a recorded platform run."""
    from hil.hexicon.model import compute_kpis, load_scenarios  # noqa: PLC0415
    from hil.hexicon.nodes import read_platform_run  # noqa: PLC0415
    from hil.hexicon.review import run_log  # noqa: PLC0415

    log = run_log(read_platform_run(path))
    return compute_kpis(log, load_scenarios()[scenario])


@app.command("campaign", short_help="MPC vs bang-bang on every scenario (in process).")
def campaign(
    out: Annotated[Path, typer.Option(help="JSON file of the KPIs")] = Path(
        "runs/hexicon_campaign.json"
    ),
) -> None:
    from hil.hexicon.model import compute_kpis, load_scenarios, run_in_process  # noqa: PLC0415

    res: dict[str, dict[str, dict[str, Any]]] = {}
    for name, scn in load_scenarios().items():
        res[name] = {c: compute_kpis(run_in_process(scn, c), scn) for c in CONTROLLERS}
        for c in CONTROLLERS:
            k = res[name][c]
            typer.echo(
                f"{name:28s} {c:9s} rms {k['heading_rms_deg']:5.2f} deg  "
                f"settle {k['settling_time_s']:5.0f} s  E/E0 {k['energy_ratio']:.3f}  "
                f"travel {k['pitch_travel_deg']:5.0f} deg  viol {k['constraint_violations']:.0f}"
            )
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=1) + "\n", encoding="utf-8")


@app.command("identify", short_help="PRBS experiments (seed table 5) over the bus, N4SID.")
def identify(
    duration: Annotated[float, typer.Option(help="samples (s) per experiment")] = 3000.0,
    block_rows: Annotated[int, typer.Option(help="N4SID block rows")] = 10,
    out: Annotated[Path, typer.Option(help="folder of exp<k>.mcap, identified.json")] = Path(
        "runs/hexicon_identify"
    ),
    seed: Annotated[int, typer.Option(help="PRBS seed")] = 0,
    transport: Annotated[str, typer.Option(help="zenoh or can")] = "zenoh",
    write_preset: Annotated[
        bool, typer.Option(help="also write controller/presets/hexicon_h3_identified.json")
    ] = False,
    reuse: Annotated[bool, typer.Option(help="fit the MCAP files already in --out")] = False,
) -> None:
    """Runs the six table-5 experiments as plant, excitation and recorder processes, merges
    the recorded MCAP data, fits on 1-5, validates on 6 (JSON)."""
    from hil.hexicon.identify import identify_over_bus  # noqa: PLC0415

    if transport not in ("zenoh", "can"):
        raise typer.BadParameter(f"--transport {transport!r}: expected zenoh or can")
    res = identify_over_bus(
        out,
        duration,
        block_rows,
        seed,
        write_preset=write_preset,
        transport=transport,
        reuse=reuse,
    )
    typer.echo(json.dumps(res, indent=1))
