"""``fowt hexicon ...``: the Hexicon H3 multi-turbine platform family's own commands.

A Hexicon run is ``fowt run hexicon-<name>`` (:mod:`hil.families`: the same launcher,
review and exit codes as a single turbine's); ``fowt hexicon run`` is its alias. The
in-process campaign and the identification over the bus are this family's alone.
"""

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


@app.command("scenarios", short_help="List the platform scenarios (table 6, sensitivity).")
def scenarios() -> None:
    """The Hexicon H3 scenarios by the name 'fowt run' takes (hexicon-<name>)."""
    from hil.families import HEXICON  # noqa: PLC0415 - deferred (module comment)

    for name, text in HEXICON.scenarios().items():
        typer.echo(f"{name:36s} {text}")


@app.command(
    "run", short_help="Alias of 'fowt run hexicon-<scenario> --mode lockstep --controller ...'."
)
def run(
    scenario: Annotated[str, typer.Argument(help="table-6 name (s1_step15) or hexicon-<name>")],
    controller: Annotated[
        str, typer.Option(help="bang_bang, mpc (physical model) or mpc_id (identified model)")
    ] = "mpc",
    out: Annotated[
        Path | None, typer.Option(help="output directory (default: runs/<stamp>-hexicon-<name>)")
    ] = None,
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
    plots: Annotated[bool, typer.Option(help="write the review's PNG plot")] = True,
) -> None:
    """The same run as 'fowt run hexicon-<scenario>' (one launcher, review, summary.json and
    exit codes: docs/exit-codes.md), with this command's defaults (lock-step, MPC)."""
    from hil.cli.common import fail  # noqa: PLC0415
    from hil.cli.fowt import run as fowt_run  # noqa: PLC0415 - the one path of 'fowt run'
    from hil.families import HEXICON_PREFIX  # noqa: PLC0415

    if controller not in CONTROLLERS:
        fail(f"--controller {controller!r}: expected one of {', '.join(CONTROLLERS)}")
    if mode not in ("lockstep", "realtime"):
        fail(f"--mode {mode!r}: expected lockstep or realtime")
    if transport not in ("zenoh", "can"):
        fail(f"--transport {transport!r}: expected zenoh or can")
    ref = scenario if scenario.startswith(HEXICON_PREFIX) else f"{HEXICON_PREFIX}{scenario}"
    fowt_run(
        scenario=ref, mode=mode, speed=1.0, duration=duration, transport=transport,
        can_interface=can_interface, can_channel=can_channel or None, can_fd=can_fd, out=out,
        plots=plots, realtime_priority=realtime_priority, loop="auto", controller=controller,
        noise=noise, identified=identified, experiment=0, seed=0,
    )  # fmt: skip


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
    out: Annotated[Path, typer.Option(help="folder of exp<k>/run.mcap, identified.json")] = Path(
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
        record=record_experiment,
    )
    typer.echo(json.dumps(res, indent=1))


def record_experiment(
    experiment: int,
    out: Path,
    *,
    duration_s: float,
    seed: int = 0,
    transport: str = "zenoh",
    scenario: str = "s1_step15",
) -> dict[str, Any]:
    """One table-5 identification experiment through the launcher (lock-step, PRBS
    excitation): ``fowt run hexicon-<scenario> --controller prbs --experiment <k> --mode
    lockstep --no-plots --out <out>``; returns the run's summary."""
    from rich.console import Console  # noqa: PLC0415

    from hil.families import HEXICON_PREFIX, HexiconOptions  # noqa: PLC0415
    from hil.launch import RunRequest, launch  # noqa: PLC0415

    req = RunRequest(
        scenario=f"{HEXICON_PREFIX}{scenario}",
        mode="lockstep",
        duration_s=duration_s,
        transport=transport,
        out_dir=out,
        plots=False,
        hexicon=HexiconOptions(controller="prbs", experiment=experiment, seed=seed),
    )
    return launch(req, Console(stderr=True))
