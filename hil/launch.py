"""``fowt run``: plant, controller and recorder as separate OS processes, then the review.

Topology on loopback (ports picked free for every run, so runs can go side by side)::

    plant      listens P            recorder  connects P and C
    controller listens C, connects P    launcher  connects P (progress only)

Every node announces itself with a liveliness token once subscribed; the plant starts only
when the controller and the recorder are there, and its final timing summary ends the run
for the others. Each process's output goes to ``DIR/logs/<name>.log``. The in-process mode
runs plant and controller in this process without a bus (fastest; for campaigns) and writes
the same MCAP file directly.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from bus_schemas import ActuatorCommand, SensorFrame
from bus_schemas.registry import COMMAND, CONTROLLER_STATUS, TIMING_SUMMARY
from hil.bus import Bus, BusConfig, free_tcp_endpoint
from hil.controller_node import ControllerRuntime
from hil.log_writer import BackgroundRunLog
from hil.plant_node import Mode, run_inprocess
from hil.recorder import scenario_metadata
from hil.review import render_summary, review
from hil.scenario import Scenario, load_scenario, scenario_text


@dataclass(frozen=True)
class RunRequest:
    """What ``fowt run`` was asked to do."""

    scenario: str = "default"
    mode: Mode = "realtime"
    speed: float = 1.0
    duration_s: float | None = None
    transport: str = "zenoh"
    out_dir: Path | None = None
    plots: bool = True


class RunFailedError(RuntimeError):
    """A process of the run failed; the message names it and its log."""


def default_out_dir(scenario: Scenario) -> Path:
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    return Path("runs") / f"{stamp}-{scenario.name}"


def run_info(req: RunRequest, scenario: Scenario) -> dict[str, str]:
    """The ``run`` metadata record of the MCAP file."""
    return {
        "mode": req.mode,
        "speed": f"{req.speed:g}",
        "transport": req.transport if req.mode != "inprocess" else "none",
        "duration_s": f"{scenario.duration_s:g}",
        "started_utc": datetime.now(UTC).isoformat(),
        "python": sys.version.split()[0],
        "command": " ".join(sys.argv),
    }


def launch(req: RunRequest, console: Console | None = None) -> dict[str, Any]:
    """Run a scenario end to end and review it; returns the summary (also in summary.json)."""
    console = console or Console()
    if req.transport != "zenoh":
        raise ValueError(f"transport {req.transport!r} is not available yet: use zenoh")
    scenario = load_scenario(req.scenario).with_duration(req.duration_s)
    toml_text, _source = scenario_text(req.scenario)
    out = req.out_dir or default_out_dir(scenario)
    out.mkdir(parents=True, exist_ok=True)
    mcap_path = out / "run.mcap"
    info = run_info(req, scenario)
    t0 = time.monotonic()
    if req.mode == "inprocess":
        _run_inprocess(scenario, mcap_path, info, toml_text)
    else:
        _run_processes(req, scenario, out, mcap_path, info, console)
    wall = time.monotonic() - t0
    summary = review(mcap_path, out, plots=req.plots)
    summary.setdefault("run", {})["launcher_wall_s"] = round(wall, 3)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    render_summary(summary, console)
    console.print(f"run log: [bold]{mcap_path}[/]")
    console.print(f"summary: {out / 'summary.json'}")
    for png in sorted(out.glob("*.png")):
        console.print(f"plot:    {png}")
    return summary


def _run_inprocess(
    scenario: Scenario, mcap_path: Path, info: dict[str, str], toml_text: str
) -> None:
    log = BackgroundRunLog(
        mcap_path,
        scenario.turbine_id,
        {"scenario": scenario_metadata(scenario, toml_text), "run": info},
    )
    publish = log.publish
    runtime = ControllerRuntime(scenario)

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        result = runtime.handle_frame(frame)
        if result is None:
            return None
        command, status = result
        publish(COMMAND, command)
        publish(CONTROLLER_STATUS, status)
        return command

    try:
        run_inprocess(scenario, publish, step)
    finally:
        log.close()


def _node_cmd(sub: str, scenario_ref: str, scenario: Scenario, *args: str) -> list[str]:
    return [
        sys.executable,
        "-m",
        "hil",
        sub,
        scenario_ref,
        "--duration",
        repr(scenario.duration_s),
        *args,
    ]


def _run_processes(
    req: RunRequest,
    scenario: Scenario,
    out: Path,
    mcap_path: Path,
    info: dict[str, str],
    console: Console,
) -> None:
    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    while ctrl_ep == plant_ep:
        ctrl_ep = free_tcp_endpoint()
    logs = out / "logs"
    logs.mkdir(exist_ok=True)
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    ref = (
        str(Path(req.scenario).resolve()) if Path(req.scenario).suffix == ".toml" else req.scenario
    )
    cmds = {
        "recorder": _node_cmd(
            "record",
            ref,
            scenario,
            "--out",
            str(mcap_path),
            "--connect",
            plant_ep,
            "--connect",
            ctrl_ep,
            "--run-info",
            json.dumps(info),
        ),
        "controller": _node_cmd(
            "controller", ref, scenario, "--listen", ctrl_ep, "--connect", plant_ep
        ),
        "plant": _node_cmd(
            "plant",
            ref,
            scenario,
            "--listen",
            plant_ep,
            "--mode",
            req.mode,
            "--speed",
            repr(req.speed),
            "--require",
            "controller,recorder",
        ),
    }
    procs: dict[str, subprocess.Popen[bytes]] = {}
    files = []
    try:
        for name in ("recorder", "controller", "plant"):
            fh = open(logs / f"{name}.log", "wb")  # noqa: SIM115 - closed in finally
            files.append(fh)
            procs[name] = subprocess.Popen(cmds[name], stdout=fh, stderr=subprocess.STDOUT, env=env)
        _follow(procs, scenario, plant_ep, console)
        rc = procs["plant"].wait()
        if rc != 0:
            raise RunFailedError(f"plant exited with {rc}; see {logs / 'plant.log'}")
        for name, timeout in (("recorder", 15.0), ("controller", 5.0)):
            try:
                procs[name].wait(timeout)
            except subprocess.TimeoutExpired:
                procs[name].terminate()
                procs[name].wait(5.0)
        if procs["recorder"].returncode != 0:
            raise RunFailedError(
                f"recorder exited with {procs['recorder'].returncode}; see {logs / 'recorder.log'}"
            )
    finally:
        for p in procs.values():
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(5.0)
                except subprocess.TimeoutExpired:
                    p.kill()
        for fh in files:
            fh.close()


def _follow(
    procs: dict[str, subprocess.Popen[bytes]], scenario: Scenario, plant_ep: str, console: Console
) -> None:
    """Show progress (simulated time from the plant's timing summaries) until the plant exits."""
    latest: dict[str, float] = {"sim_s": 0.0, "misses": 0.0}

    def on_summary(_key: str, payload: bytes) -> None:
        try:
            s = TIMING_SUMMARY.codec.decode(payload)
        except Exception:
            return
        latest["sim_s"] = s.sample_time_ns / 1e9
        latest["misses"] = float(s.deadline_misses)

    bus = Bus(BusConfig(connect=(plant_ep,)))
    try:
        bus.subscribe(TIMING_SUMMARY.key(scenario.turbine_id), on_summary)
        with Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            TextColumn("{task.completed:.0f}/{task.total:.0f} s simulated"),
            TextColumn("misses {task.fields[misses]:.0f}"),
            TimeElapsedColumn(),
            console=console,
            transient=False,
        ) as progress:
            task = progress.add_task(scenario.name, total=scenario.duration_s, misses=0)
            while procs["plant"].poll() is None:
                for name in ("controller", "recorder"):
                    rc = procs[name].poll()
                    if rc is not None and rc != 0:
                        raise RunFailedError(f"{name} exited with {rc} during the run")
                progress.update(task, completed=latest["sim_s"], misses=latest["misses"])
                time.sleep(0.1)
            progress.update(task, completed=max(latest["sim_s"], scenario.duration_s))
    finally:
        bus.close()
