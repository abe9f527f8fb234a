"""``fowt analyze decay`` and ``fowt analyze closed-loop``: platform periods and damping from
the time-domain plant.

Registered on the ``analyze`` group of the ``fowt`` app by :func:`register`.

* ``decay``: a free decay of the parked platform from an offset (:func:`plant.decay.
  free_decay`): period and log decrement per cycle.
* ``closed-loop``: the surge and pitch modes with the controller in the loop at several
  steady winds (:func:`hil.inprocess.closed_loop.closed_loop_decay`), beside the open-loop
  linear modes (:func:`plant.modes.natural_modes`).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from hil.cli.common import choice, fail, number, text_file

__all__ = ["CONTROLLER_SCENARIOS", "register"]

#: ``--controller`` -> the shipped IEA 15 MW VolturnUS-S scenario whose controller is used.
CONTROLLER_SCENARIOS = {
    "baseline": "iea15mw-still-water",
    "lqri": "iea15mw-lc2-lqri",
    "lqri_ff": "iea15mw-lc2-lqri-ff",
    "rosco": "iea15mw-lc2-rosco",
}


def _preset(value: str) -> str:
    """Callback of a preset argument: a shipped name, or a path to a readable text file."""
    if value.endswith(".toml") or "/" in value:
        text_file(Path(value))
    return value


def _winds(value: str) -> str:
    """Callback of ``--winds``: comma-separated speeds, each in (0, 40] m/s."""
    try:
        speeds = [float(v) for v in value.split(",") if v.strip()]
    except ValueError:
        raise typer.BadParameter(
            f"expected comma-separated wind speeds in m/s, e.g. 5,8,11, got {value!r}"
        ) from None
    if not speeds or not all(math.isfinite(s) and 0.0 < s <= 40.0 for s in speeds):
        raise typer.BadParameter(f"expected wind speeds in (0, 40] m/s, got {value!r}")
    return value


def _dofs(value: str) -> str:
    """Callback of ``--dof`` (closed loop): surge, pitch or both, comma-separated."""
    parts = [v.strip() for v in value.split(",") if v.strip()]
    if not parts or any(p not in ("surge", "pitch") for p in parts):
        raise typer.BadParameter(f"expected surge, pitch or surge,pitch, got {value!r}")
    return value


@contextlib.contextmanager
def _stdout_to_stderr() -> Iterator[None]:
    """File descriptor 1 sent to stderr meanwhile: a compiled controller (ROSCO's DISCON)
    prints its banner to the process's stdout, which must hold only the table or JSON."""
    sys.stdout.flush()
    saved = os.dup(1)
    os.dup2(2, 1)
    try:
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def _fmt(v: float | None, spec: str) -> str:
    return "-" if v is None or not math.isfinite(v) else format(v, spec)


def register(analyze_app: typer.Typer, console: Console) -> None:
    """Add ``decay`` and ``closed-loop`` to the ``analyze`` group."""

    @analyze_app.command("decay", short_help="Free decay of the parked platform from an offset.")
    def analyze_decay(
        preset: Annotated[
            str, typer.Argument(help="Floating preset name or preset .toml path.", callback=_preset)
        ],
        dof: Annotated[
            str,
            typer.Option(
                "--dof", help="surge, heave or pitch.", callback=choice("surge", "heave", "pitch")
            ),
        ] = "surge",
        offset: Annotated[
            float,
            typer.Option(
                "--offset",
                help="Initial displacement from the equilibrium: m (surge, heave), deg (pitch).",
                callback=number("m or deg", ge=-60.0, le=60.0),
            ),
        ] = 1.0,
        duration: Annotated[
            float | None,
            typer.Option(
                "--duration",
                help="Simulated time, s (default: surge 800, heave 200, pitch 250).",
                callback=number("s", gt=0.0, le=20000.0),
            ),
        ] = None,
        step: Annotated[
            float,
            typer.Option("--step", help="RK4 plant step, s.", callback=number("s", gt=0.0, le=0.1)),
        ] = 0.0125,
        no_radiation: Annotated[
            bool,
            typer.Option(
                "--no-radiation",
                help="Without the radiation memory: infinite-frequency added mass alone.",
            ),
        ] = False,
        as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
    ) -> None:
        """Free decay of the parked platform: period and damping per cycle.

        Runs the time-domain plant (nonlinear mooring table, radiation memory, quadratic
        drag, flexible tower) parked in still air and still water: rotor aerodynamics off,
        rotor at rest, no waves. The platform starts at rest at its static equilibrium with
        --dof displaced by --offset. A cycle runs from one extremum on the offset's side to
        the next: period T [s], log decrement delta = ln(a_k/a_k+1), damping ratio
        zeta = delta / sqrt(4 pi^2 + delta^2) (plant.decay).
        """
        from plant.decay import free_decay  # noqa: PLC0415  (keeps `fowt --help` fast)

        if offset == 0.0:
            fail("--offset: expected a non-zero displacement")
        try:
            result = free_decay(
                preset, dof, offset, duration, plant_step_s=step, radiation=not no_radiation
            )
        except (ValueError, OSError) as exc:
            fail(str(exc))
        if as_json:
            sys.stdout.write(json.dumps(result.as_dict(), indent=2) + "\n")
            return
        unit = result.unit
        table = Table(
            title=f"Free decay of {escape(preset)}: {dof} from {offset:g} {unit} "
            f"(equilibrium {result.equilibrium:.4g} {unit})"
        )
        for col in (
            "cycle",
            "start [s]",
            f"amplitude [{unit}]",
            "period [s]",
            "log decrement",
            "damping ratio",
        ):
            table.add_column(escape(col), justify="right")
        for c in result.cycles:
            table.add_row(
                str(c.index),
                f"{c.start_s:.1f}",
                f"{c.amplitude:.4g}",
                f"{c.period_s:.2f}",
                f"{c.log_decrement:.4f}",
                f"{c.damping_ratio:.4f}",
            )
        table.caption = result.case + ("" if result.radiation else "; no radiation memory")
        console.print(table)
        if not result.cycles:
            console.print("no whole cycle: over-damped, or --duration too short", markup=False)

    @analyze_app.command(
        "closed-loop", short_help="Surge and pitch damping with the controller in the loop."
    )
    def analyze_closed_loop(
        scenario: Annotated[
            str | None,
            typer.Argument(
                help="Scenario whose turbine, platform and controller are used (default: "
                "the IEA 15 MW VolturnUS-S scenario of --controller)."
            ),
        ] = None,
        controller: Annotated[
            str | None,
            typer.Option(
                "--controller",
                help="baseline, lqri, lqri_ff or rosco: the shipped IEA 15 MW scenario with it "
                f"({', '.join(f'{k}: {v}' for k, v in CONTROLLER_SCENARIOS.items())}).",
                callback=lambda v: v if v is None else choice(*CONTROLLER_SCENARIOS)(v),
            ),
        ] = None,
        winds: Annotated[
            str,
            typer.Option("--winds", help="Steady winds, m/s, comma-separated.", callback=_winds),
        ] = "5,8,11,15,20",
        dof: Annotated[
            str, typer.Option("--dof", help="surge, pitch or surge,pitch.", callback=_dofs)
        ] = "surge,pitch",
        surge_offset: Annotated[
            float,
            typer.Option(
                "--surge-offset",
                help="Surge release offset, m.",
                callback=number("m", gt=0.0, le=20.0),
            ),
        ] = 2.0,
        pitch_offset: Annotated[
            float,
            typer.Option(
                "--pitch-offset",
                help="Pitch release offset, deg.",
                callback=number("deg", gt=0.0, le=10.0),
            ),
        ] = 1.0,
        duration: Annotated[
            float,
            typer.Option(
                "--duration",
                help="Simulated time of each decay, s.",
                callback=number("s", ge=60.0, le=7200.0),
            ),
        ] = 600.0,
        as_json: Annotated[bool, typer.Option("--json", help="Print the results as JSON.")] = False,
    ) -> None:
        """Damping ratio and period of the surge and pitch modes with the controller in the
        loop, at each steady wind of --winds.

        Identified from a small free decay of the time-domain plant with the scenario's own
        controller core (baseline, LQRI, ROSCO's DISCON, ...) in the loop: steady wind, still
        water, sensor noise off, trimmed start, the platform released from --surge-offset
        or --pitch-offset (hil.inprocess.closed_loop). Beside it the open-loop linear modes
        at the same wind (blade pitch and torque held: fowt analyze modes). A negative
        damping ratio is a mode that grows.
        """
        from hil.inprocess.closed_loop import (  # noqa: PLC0415  (imported when used)
            CLOSED_LOOP_CASE,
            closed_loop_decay,
        )
        from hil.scenario.schema import ScenarioError, load_scenario  # noqa: PLC0415
        from plant.modes import natural_modes  # noqa: PLC0415

        if scenario is not None and controller is not None:
            fail("give a SCENARIO or --controller, not both")
        ref = scenario if scenario is not None else CONTROLLER_SCENARIOS[controller or "baseline"]
        try:
            sc = load_scenario(ref)
        except ScenarioError as exc:
            fail(str(exc))
        if sc.platform is None:
            fail(f"{ref}: closed-loop platform damping needs a floating scenario (platform = ...)")
        speeds = [float(v) for v in winds.split(",") if v.strip()]
        dofs = [v.strip() for v in dof.split(",") if v.strip()]
        rows: list[dict[str, object]] = []
        for u in speeds:
            try:
                open_loop = {m.name: m for m in natural_modes(sc.platform, u)}
            except (ValueError, OSError) as exc:
                fail(f"{ref}: open-loop modes at {u:g} m/s: {exc}")
            for d in dofs:
                off = surge_offset if d == "surge" else pitch_offset
                try:
                    with _stdout_to_stderr():
                        res = closed_loop_decay(sc, u, d, off, duration)
                except (ValueError, OSError) as exc:
                    fail(f"{ref}: closed loop at {u:g} m/s: {exc}")
                ol = open_loop.get(d)
                row = res.as_dict()
                row["open_loop_period_s"] = round(ol.period_s, 3) if ol else None
                row["open_loop_damping_ratio"] = round(ol.damping_ratio, 5) if ol else None
                rows.append(row)
        kind = sc.controller.kind
        if as_json:
            out = {
                "scenario": ref,
                "controller": kind,
                "controller_preset": sc.controller.preset,
                "case": CLOSED_LOOP_CASE,
                "open_loop_case": "fowt analyze modes at the same wind (pitch, torque held)",
                "modes": rows,
            }
            sys.stdout.write(json.dumps(out, indent=2) + "\n")
            return
        table = Table(title=f"Closed-loop platform modes of {escape(ref)} (controller {kind})")
        for col in (
            "wind [m/s]",
            "mode",
            "offset",
            "period [s]",
            "damping ratio",
            "cycles",
            "open-loop period [s]",
            "open-loop damping",
        ):
            table.add_column(escape(col), justify="right")
        for r in rows:
            table.add_row(
                f"{r['wind_m_s']:g}",
                str(r["dof"]),
                f"{r['offset']:g} {r['unit']}",
                _fmt(r["period_s"], ".2f"),  # type: ignore[arg-type]
                _fmt(r["damping_ratio"], ".4f"),  # type: ignore[arg-type]
                str(len(r["cycles"])),  # type: ignore[arg-type]
                _fmt(r["open_loop_period_s"], ".2f"),  # type: ignore[arg-type]
                _fmt(r["open_loop_damping_ratio"], ".4f"),  # type: ignore[arg-type]
            )
        table.caption = CLOSED_LOOP_CASE
        console.print(table)
