"""``fowt run``: plant, controller and recorder as separate OS processes, then the review.

Topology on loopback (ports picked free for every run, so runs can go side by side)::

    plant      listens P            recorder  connects P and C
    controller listens C, connects P    launcher  connects P (progress only)

Every node announces itself with a liveliness token once subscribed; the plant starts only
when the controller and the recorder are there, and its final timing summary ends the run
for the others. Each process's output goes to ``DIR/logs/<name>.log``. The in-process mode
runs plant and controller in this process without a bus (fastest; for campaigns) and writes
the same MCAP file directly.

CAN transport (``--transport can``)
-----------------------------------
The sensor frame and the command travel on a CAN bus between the plant and controller
processes (:class:`hil.can_bus.HybridBus`); truth, controller status, timing, liveliness
and the run's end stay on the loopback Zenoh session above, as the bench's side channel.
The recorder joins the CAN bus too and logs the decoded messages and the raw frames.
python-can's ``virtual`` bus does not cross processes, so a process run takes:

* ``udp_multicast``: allowed only inside a private network namespace. Run from the host's
  namespace as root with ``unshare`` and ``ip`` available, the launcher re-executes itself
  (the same ``fowt run`` command) under ``unshare --net`` with ``lo`` brought up with
  multicast and ``224.0.0.0/4`` routed to it (:func:`hil.can_bus.netns_command`); plant,
  controller and recorder (and Zenoh on 127.0.0.1) all run in that namespace, which
  vanishes with the run. Otherwise the run is refused, saying why.
* ``socketcan``: the netdevice (``vcan0``) must exist.
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
from hil.can_bus import (
    CanBusConfig,
    in_private_netns,
    netns_command,
    transport_unavailable_reason,
)
from hil.controller_node import ControllerRuntime
from hil.log_writer import BackgroundRunLog
from hil.plant_node import Mode, run_inprocess
from hil.recorder import scenario_metadata
from hil.review import render_summary, review
from hil.scenario import Scenario, load_scenario, scenario_text

#: Set in the environment of a launcher re-executed in a fresh network namespace.
_NETNS_ENV = "FOWT_NETNS_CHILD"


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
    can: CanBusConfig | None = None
    realtime_priority: int = 0  # SCHED_FIFO for the plant and controller (0: normal)


class RunFailedError(RuntimeError):
    """A process of the run failed; the message names it and its log."""


def default_out_dir(scenario: Scenario) -> Path:
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    return Path("runs") / f"{stamp}-{scenario.name}"


def run_info(req: RunRequest, scenario: Scenario) -> dict[str, str]:
    """The ``run`` metadata record of the MCAP file."""
    info = {
        "mode": req.mode,
        "speed": f"{req.speed:g}",
        "transport": req.transport if req.mode != "inprocess" else "none",
        "duration_s": f"{scenario.duration_s:g}",
        "started_utc": datetime.now(UTC).isoformat(),
        "python": sys.version.split()[0],
        "command": " ".join(sys.argv),
    }
    if req.transport == "can" and req.mode != "inprocess":
        can = can_config(req, scenario)
        info.update(
            can_interface=can.interface,
            can_channel=can.effective_channel,
            can_fd=str(int(can.fd)),
            network_namespace="private" if in_private_netns() else "host",
        )
    return info


def can_config(req: RunRequest, scenario: Scenario) -> CanBusConfig:
    """The run's CAN bus: the request's, else the scenario's ``[can]`` section."""
    if req.can is not None:
        return req.can
    c = scenario.can
    return CanBusConfig.for_interface(c.interface, c.channel, c.fd, scenario.turbine_id)


def _design_preset(scenario: Scenario, name: str) -> str:
    """The plant preset to design ``name`` from: the scenario's platform when its stem is
    ``name`` (a preset file keeps its path), else ``name`` itself (a shipped preset)."""
    platform = scenario.platform
    if platform is not None and Path(platform).stem == name:
        return str(Path(platform).resolve()) if Path(platform).suffix == ".toml" else platform
    return name


def ensure_designs(scenario: Scenario, console: Console | None = None) -> Path | None:
    """Design the advanced controller's artefacts for the scenario's control period if missing.

    Looks the artefacts up as the controller will (:func:`controller.runtime.missing_designs`:
    shipped designs, then the user design cache :func:`controller.lqri.user_design_dir`). For
    each design with an artefact missing, runs ``fowt design PRESET --control-period T_s
    --out CACHE`` in a child process (one BLAS thread, see :mod:`controller.design`; this
    process and the controller process import no design code) and prints what it does and
    how long it took.

    Parameters
    ----------
    scenario : Scenario
        The run's scenario (its controller kind, preset and control period).
    console : Console, optional
        Where the messages go.

    Returns
    -------
    Path or None
        The cache folder designed into (to hand to the controller as ``$FOWT_DESIGN_DIR`` or
        ``design_dir``), or None when nothing was missing or the controller is the baseline.

    Raises
    ------
    RunFailedError
        If the design fails (its output is in the message).
    """
    c = scenario.controller
    if c.kind == "baseline":
        return None
    from controller.design import BLAS_SINGLE_THREAD_ENV  # noqa: PLC0415
    from controller.lqri import DESIGN_DIR_ENV, user_design_dir  # noqa: PLC0415
    from controller.runtime import load_advanced_settings, missing_designs  # noqa: PLC0415

    dt = scenario.timing.control_period_s
    ff = "off" if c.kind == "lqri" else (c.feedforward or "balanced")
    missing = missing_designs(load_advanced_settings(c.preset), dt, ff)
    if not missing:
        return None
    console = console or Console()
    cache = user_design_dir()
    env = {**os.environ, **BLAS_SINGLE_THREAD_ENV, DESIGN_DIR_ENV: str(cache)}
    for name in sorted({m.name for m in missing}):
        kinds = ", ".join(m.kind for m in missing if m.name == name)
        preset = _design_preset(scenario, name)
        console.print(
            f"no {name} controller design ({kinds}) for control period {dt:g} s: "
            f"designing it into {cache} (fowt design {preset} --control-period {dt:g}) ..."
        )
        cmd = [
            sys.executable,
            "-m",
            "hil",
            "design",
            preset,
            "--control-period",
            repr(dt),
            "--out",
            str(cache),
        ]
        t0 = time.monotonic()
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
        if proc.returncode != 0:
            raise RunFailedError(
                f"design of {name} at {dt:g} s failed ({proc.returncode}):\n"
                f"{proc.stdout}{proc.stderr}"
            )
        console.print(f"designed {name} at {dt:g} s in {time.monotonic() - t0:.1f} s")
    still = missing_designs(load_advanced_settings(c.preset), dt, ff, cache)
    if still:
        raise RunFailedError(str(still[0]))
    return cache


def launch(req: RunRequest, console: Console | None = None) -> dict[str, Any]:
    """Run a scenario end to end and review it; returns the summary (also in summary.json).

    The advanced controller's design artefacts for the scenario's control period are
    designed first when missing (:func:`ensure_designs`), and the controller (process or
    in-process runtime) is told where they are.
    """
    console = console or Console()
    if req.transport not in ("zenoh", "can"):
        raise ValueError(f"transport {req.transport!r}: expected zenoh or can")
    scenario = load_scenario(req.scenario).with_duration(req.duration_s)
    toml_text, _source = scenario_text(req.scenario)
    out = req.out_dir or default_out_dir(scenario)
    if req.transport == "can":
        if req.mode == "inprocess":
            raise RunFailedError("--transport can: an in-process run has no bus (use lockstep)")
        can = can_config(req, scenario)
        if can.turbine_id != scenario.turbine_id:
            raise RunFailedError(
                f"CAN bus of turbine {can.turbine_id!r}, scenario turbine {scenario.turbine_id!r}"
            )
        reason = transport_unavailable_reason(can)
        if reason is not None:
            raise RunFailedError(f"--transport can --can-interface {can.interface}: {reason}")
        if can.interface == "udp_multicast" and not in_private_netns():
            if os.environ.get(_NETNS_ENV):  # never re-exec twice
                raise RunFailedError(
                    "re-executed under unshare --net, yet not in a private network namespace"
                )
            return _launch_in_netns(req, can, out)
    out.mkdir(parents=True, exist_ok=True)
    mcap_path = out / "run.mcap"
    info = run_info(req, scenario)
    design_dir = ensure_designs(scenario, console)
    t0 = time.monotonic()
    if req.mode == "inprocess":
        _run_inprocess(scenario, mcap_path, info, toml_text, design_dir)
    else:
        _run_processes(req, scenario, out, mcap_path, info, console, design_dir)
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
    scenario: Scenario,
    mcap_path: Path,
    info: dict[str, str],
    toml_text: str,
    design_dir: Path | None = None,
) -> None:
    log = BackgroundRunLog(
        mcap_path,
        scenario.turbine_id,
        {"scenario": scenario_metadata(scenario, toml_text), "run": info},
    )
    publish = log.publish
    runtime = ControllerRuntime(scenario, design_dir=design_dir)

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


def _scenario_ref(ref: str) -> str:
    """A scenario reference another process (another cwd) resolves the same way."""
    return str(Path(ref).resolve()) if Path(ref).suffix == ".toml" else ref


def _launch_in_netns(req: RunRequest, can: CanBusConfig, out: Path) -> dict[str, Any]:
    """Re-run this ``fowt run`` in a fresh network namespace; return its summary.

    The child launcher (same Python, same options, ``--out`` resolved) runs plant,
    controller and recorder inside the namespace (:func:`hil.can_bus.netns_command`) and
    prints its own progress and summary to this process's terminal.

    Raises
    ------
    RunFailedError
        If the namespaced run fails (its exit status), or wrote no summary.
    """
    out = out.resolve()
    cmd = [
        sys.executable,
        "-m",
        "hil",
        "run",
        _scenario_ref(req.scenario),
        "--mode",
        req.mode,
        "--speed",
        repr(req.speed),
        "--out",
        str(out),
        *can.cli_args(),
    ]
    if req.duration_s is not None:
        cmd += ["--duration", repr(req.duration_s)]
    if not req.plots:
        cmd.append("--no-plots")
    env = {**os.environ, _NETNS_ENV: "1"}
    rc = subprocess.run(netns_command(cmd), check=False, env=env).returncode
    if rc != 0:
        raise RunFailedError(
            f"the run in a private network namespace (unshare --net) exited with {rc}; "
            f"see its output above and {out / 'logs'}"
        )
    summary_path = out / "summary.json"
    if not summary_path.is_file():
        raise RunFailedError(f"the namespaced run wrote no {summary_path}")
    summary: dict[str, Any] = json.loads(summary_path.read_text())
    return summary


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
    design_dir: Path | None = None,
) -> None:
    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    while ctrl_ep == plant_ep:
        ctrl_ep = free_tcp_endpoint()
    logs = out / "logs"
    logs.mkdir(exist_ok=True)
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    if design_dir is not None:  # the controller process finds the designs there
        from controller.lqri import DESIGN_DIR_ENV  # noqa: PLC0415

        env[DESIGN_DIR_ENV] = str(design_dir)
    ref = _scenario_ref(req.scenario)
    # CAN run: the three nodes join the same CAN bus (sensor frame and command on CAN).
    can_args = can_config(req, scenario).cli_args() if req.transport == "can" else []
    # Real-time scheduling for the two processes on the control loop; the recorder stays
    # under the normal policy so it only takes the CPU they leave.
    rt_args = ["--realtime-priority", str(req.realtime_priority)] if req.realtime_priority else []
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
            *can_args,
        ),
        "controller": _node_cmd(
            "controller",
            ref,
            scenario,
            "--listen",
            ctrl_ep,
            "--connect",
            plant_ep,
            *can_args,
            *rt_args,
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
            *can_args,
            *rt_args,
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
