"""``fowt hexicon ...``: the Hexicon H3 multi-turbine platform family on the bench."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

# The plant, controller (OSQP) and Zenoh imports are deferred to the commands, so
# ``fowt --help`` and the other commands do not pay for them.
CONTROLLERS = ("bang_bang", "mpc")

app = typer.Typer(
    help="Hexicon H3-18MW: three turbines on one yawing platform (ayotte-2015).",
    no_args_is_help=True,
    rich_markup_mode=None,
)


def _check(scenario: str, controller: str) -> None:
    from hil.hexicon import load_scenarios  # noqa: PLC0415 - deferred (module comment)

    names = load_scenarios()
    if scenario not in names:
        raise typer.BadParameter(f"unknown scenario {scenario!r}; shipped: {', '.join(names)}")
    if controller not in CONTROLLERS:
        raise typer.BadParameter(f"unknown controller {controller!r}; expected {CONTROLLERS}")


@app.command("scenarios", short_help="List the platform scenarios (table 6, sensitivity).")
def scenarios() -> None:
    from hil.hexicon import load_scenarios  # noqa: PLC0415 - deferred (module comment)

    for name, scn in load_scenarios().items():
        typer.echo(f"{name:28s} {scn.duration_s:5.0f} s  {scn.comment}")


@app.command("run", short_help="Plant and controller processes over Zenoh, recorded to MCAP.")
def run(
    scenario: str,
    controller: Annotated[str, typer.Option(help="bang_bang or mpc")] = "mpc",
    out: Annotated[Path, typer.Option(help="output directory (run.mcap, summary.json)")] = Path(
        "runs/hexicon"
    ),
    mode: Annotated[str, typer.Option(help="lockstep or realtime")] = "lockstep",
    duration: Annotated[float | None, typer.Option(help="override the length (s)")] = None,
    realtime_priority: Annotated[
        int, typer.Option(help="SCHED_FIFO priority of plant and controller (0: normal)")
    ] = 0,
) -> None:
    from hil.hexicon_nodes import run_over_zenoh  # noqa: PLC0415 - deferred (module comment)

    _check(scenario, controller)
    if mode not in ("lockstep", "realtime"):
        raise typer.BadParameter(f"--mode {mode!r}: expected lockstep or realtime")
    s = run_over_zenoh(
        scenario,
        controller,
        out,
        mode=mode,
        duration_s=duration,
        realtime_priority=realtime_priority,
    )
    if s.get("plant_rc") != 0 or s.get("controller_rc") != 0:
        typer.echo(json.dumps(s, indent=1), err=True)
        raise typer.Exit(1)
    kpis = kpis_of_mcap(Path(s["mcap"]), scenario)
    s["kpis"] = kpis
    (out / "summary.json").write_text(json.dumps(s, indent=1) + "\n", encoding="utf-8")
    typer.echo(json.dumps({k: v for k, v in s.items() if "stderr" not in k}, indent=1))


def kpis_of_mcap(path: Path, scenario: str) -> dict[str, float]:
    """The review KPIs (:func:`hil.hexicon.compute_kpis`) of a recorded platform run."""
    from hil.hexicon import RunLog, compute_kpis, load_scenarios  # noqa: PLC0415
    from hil.hexicon_nodes import read_platform_run  # noqa: PLC0415

    run = read_platform_run(path)
    frames = [f for f in run.get("fowt/h3/platform", []) if not f["final"]]
    log = RunLog()
    cmds = [run.get(f"fowt/h3/{t}/rotor/command", []) for t in ("t1", "t2", "t3")]
    rot = [run.get(f"fowt/h3/{t}/rotor", []) for t in ("t1", "t2", "t3")]
    status = run.get("fowt/h3/platform/status", [])
    n = min(len(frames), *(len(c) for c in cmds))
    for k in range(n):
        f = frames[k]
        log.t.append(f["sample_time_ns"] / 1e9)
        log.heading.append(f["platform_heading_measured_rad"])
        log.yaw_rate.append(f["platform_yaw_rate_measured_rad_s"])
        log.direction.append(f["wind_direction_measured_rad"])
        log.speed.append(f["wind_speed_measured_m_s"])
        log.power.append(f["platform_power_w"])
        log.pitch_cmd.append(tuple(c[k]["blade_pitch_commanded_rad"] for c in cmds))
        log.pitch.append(tuple(r[k]["blade_pitch_measured_rad"] for r in rot))
        log.solve_s.append(status[k]["solve_time_s"] if k < len(status) else 0.0)
    log.overruns = int(status[-1]["overruns"]) if status else 0
    return compute_kpis(log, load_scenarios()[scenario])


@app.command("campaign", short_help="MPC vs bang-bang on every scenario (in process).")
def campaign(
    out: Annotated[Path, typer.Option(help="JSON file of the KPIs")] = Path(
        "runs/hexicon_campaign.json"
    ),
) -> None:
    from hil.hexicon import compute_kpis, load_scenarios, run_in_process  # noqa: PLC0415

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


@app.command("identify", short_help="PRBS experiments (seed table 5) and an N4SID model.")
def identify(
    duration: Annotated[float, typer.Option(help="seconds per experiment")] = 3000.0,
    block_rows: Annotated[int, typer.Option(help="N4SID block rows")] = 10,
) -> None:
    """Runs the six table-5 experiments in process, fits on 1-5, validates on 6 (JSON)."""
    from controller.design.hexicon_identify import identify as run_identify  # noqa: PLC0415

    typer.echo(json.dumps(run_identify(duration, block_rows), indent=1))
