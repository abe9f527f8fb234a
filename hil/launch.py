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
processes (:class:`hil.nodes.can_bus.HybridBus`); truth, controller status, timing, liveliness
and the run's end stay on the loopback Zenoh session above, as the bench's side channel.
The recorder joins the CAN bus too and logs the decoded messages and the raw frames.
python-can's ``virtual`` bus does not cross processes, so a process run takes:

* ``udp_multicast``: allowed only inside a private network namespace. Run from the host's
  namespace as root with ``unshare`` and ``ip`` available, the launcher re-executes itself
  (the same ``fowt run`` command) under ``unshare --net`` with ``lo`` brought up with
  multicast and ``224.0.0.0/4`` routed to it (:func:`hil.nodes.can_bus.netns_command`); plant,
  controller and recorder (and Zenoh on 127.0.0.1) all run in that namespace, which
  vanishes with the run. Otherwise the run is refused, saying why.
* ``socketcan``: the netdevice (``vcan0``) must exist.

Process faults (``[[faults]]`` kinds ``controller_kill`` and ``plant_kill``)
-----------------------------------------------------------------------------
The launcher owns the processes, so it injects these (:class:`ProcessFaultDriver`). It
follows the plant's ``timing/cycle`` records (the plant waits for the launcher's liveliness
token too, so none is missed); the simulated time is the end of the newest
cycle the plant has reported, and when it reaches a fault's ``start_s`` the launcher sends
SIGKILL (within milliseconds in real time; a lock-step plant, running faster than real
time, may be a few cycles further by then: the record gives the time the launcher saw):

* ``controller_kill``: the controller process dies; the plant misses its deadlines and,
  after ``timing.watchdog_misses`` of them, enters its safe state. With
  ``restart_after_s`` the launcher starts a new controller process that many wall-clock
  seconds after the kill, with the same command line (it listens on the same port and
  connects to the plant again; its log is appended to ``logs/controller.log``); the plant
  hands control back after ``timing.watchdog_recover_cycles`` on-time commands (K = 0:
  latched, it stays safe). Real-time runs only: in lock-step the plant waits for every
  command and would abort on its lock-step timeout, so such a scenario is refused
  (:class:`ProcessFaultError`) before anything starts, as is any process fault in an
  in-process run (no processes).
* ``plant_kill``: the plant dies; the controller and the recorder must end by themselves
  (the plant's liveliness token goes) within :data:`PLANT_KILL_EXIT_TIMEOUT_S`, the
  recorder closing its file, which the review then reads (its timing is incomplete).

A fault whose ``start_s`` the run never reaches, or one that finds its process already
dead, is reported as not injected; a restart not yet due when the run ends is not done.
Every event (what was killed, when in simulated and wall time, restarted when, how the
plant's watchdog answered, how the others exited) is printed and stored in ``summary.json``
under ``run.process_faults``. The run succeeds (``fowt run`` exits 0) when the killed
processes are the only ones that died; any other death, or a process that does not exit by
itself after a ``plant_kill``, fails it (a summary is still written in the latter case).
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import gc
import json
import math
import os
import select
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, Literal

import msgspec
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from bus_schemas.auth import KEY_FILE_NAME, create_key_file
from bus_schemas.registry import (
    COMMAND,
    CONTROLLER_REPORT,
    CONTROLLER_STATUS,
    CYCLE_TIMING,
    WAVE_PREVIEW_PERFECT,
    MessageType,
)
from controller.discon import DisconError
from controller.rosco import RUN_DIR_ENV
from hil.families import (
    TURBINE,
    HexiconOptions,
    NodeContext,
    PlantFamily,
    RunRequestError,
    check_request,
    resolve,
)
from hil.inprocess.run import run_inprocess
from hil.inprocess.trim import initial_condition, operating_point
from hil.nodes.bus import (
    PLANT_BATCH_SUFFIX,
    Bus,
    BusConfig,
    batch_key,
    free_tcp_endpoint,
    unbatching,
)
from hil.nodes.controller_fault import FAULT_FILE, ControllerFaultError, write_fault
from hil.nodes.controller_node import (
    ControllerRuntime,
    controller_report,
    feedforward_notice,
    publishing_step,
)
from hil.nodes.plant_node import Mode
from hil.nodes.recorder import (
    scenario_metadata,
    scenario_recording_metadata,
    scenario_truth_every,
)
from hil.nodes.rt import steady_gc
from hil.review.core import render_summary, review
from hil.review.outcome import outcome_line, record_outcome
from hil.runlog.writer import BackgroundRunLog, LogWriteError
from hil.scenario.schema import ProcessFault, Scenario, load_scenario, scenario_text

if TYPE_CHECKING:
    from hil.nodes.can_bus import CanBusConfig
    from hil.review.plot_worker import PlotWorker

#: Set in the environment of a launcher re-executed in a fresh network namespace.
_NETNS_ENV = "FOWT_NETNS_CHILD"
#: Niceness of the recorder process (log only; bench/lockstep_speed.py measured the effect).
RECORDER_NICE = int(os.environ.get("FOWT_RECORDER_NICE", "10"))


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
    inprocess_loop: Literal["auto", "compiled", "python"] = "auto"  # see run_inprocess
    hexicon: HexiconOptions | None = None  # a Hexicon scenario's options (hil.families)
    keep_key: bool = False  # leave run.key in the run folder after the run (--keep-key)
    live_port: int | None = None  # serve the run to Foxglove on this port (hil.live)

    def given(self) -> dict[str, bool]:
        """The options set to other than their defaults that only some families take
        (:func:`hil.families.check_request`)."""
        given = {
            "speed": self.speed != 1.0,
            "loop": self.inprocess_loop != "auto",
            "hexicon": self.hexicon is not None,
        }
        return {k: v for k, v in given.items() if v}


class RunFailedError(RuntimeError):
    """A process of the run failed; the message names it and its log.

    ``process``: which one (``"plant"``, ``"controller"``, ``"recorder"``; None: not one
    process), written to ``summary.json`` as ``run.failed_process``.
    """

    def __init__(self, message: str, process: str | None = None) -> None:
        super().__init__(message)
        self.process = process


class ProcessFaultError(RunFailedError):
    """A scenario's process fault cannot act in this run's mode; said before anything starts."""


class RunAbortedError(Exception):
    """The run was stopped by a signal (SIGINT, SIGTERM, SIGHUP) to the launcher.

    Parameters
    ----------
    signum : int
        The signal.
    sim_s : float or None
        Simulated seconds reached when the run was stopped (None: not known).
    started : bool
        Whether the run had started (False: stopped before anything was written).
    """

    def __init__(self, signum: int, sim_s: float | None = None, started: bool = True) -> None:
        self.signum = signum
        self.sim_s = sim_s
        self.started = started
        self.signal_name = signal.Signals(signum).name
        when = "before the run started" if not started else "during the run"
        super().__init__(f"aborted by {self.signal_name} {when}")


#: Signals that stop a run: the launcher stops its children, finishes the file and reviews.
ABORT_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class AbortSignals:
    """Context manager catching :data:`ABORT_SIGNALS` while a run goes on.

    The handler only records the signal and writes a byte to a pipe of its own; the
    launcher's loops look at it (:meth:`is_set`, :meth:`wait`) and stop the run in order
    (children first, then the file, then the review). The handler takes no lock: a Python
    handler runs in the main thread between two bytecodes, wherever that thread is, so one
    that set a :class:`threading.Event` would wait for ever on the event's lock when the
    main thread held it (inside ``Event.wait``, or inside a first handler when a second
    signal comes), as :mod:`hil.nodes.signals` explains for the nodes. The handlers are
    installed in the main thread only (Python's rule): elsewhere, e.g. a campaign's worker
    thread, this does nothing. The previous handlers come back on exit.

    Attributes
    ----------
    signum : int or None
        The first signal received.
    """

    def __init__(self) -> None:
        self.signum: int | None = None
        self._previous: dict[int, Any] = {}
        self._read, self._write = os.pipe()
        os.set_blocking(self._write, False)  # a handler must never block on a full pipe

    def _on_signal(self, signum: int, _frame: Any) -> None:
        if self.signum is None:
            self.signum = signum
        with contextlib.suppress(OSError):  # full: a byte is waiting already
            os.write(self._write, b"\0")

    def is_set(self) -> bool:
        """Whether a signal came (the in-process loop's stop test)."""
        return self.signum is not None

    def wait(self, timeout_s: float) -> bool:
        """Wait up to ``timeout_s`` for a signal (woken at once by one); whether one came."""
        if self.signum is None:
            with contextlib.suppress(InterruptedError):
                select.select([self._read], [], [], timeout_s)
        return self.signum is not None

    def __enter__(self) -> AbortSignals:
        if threading.current_thread() is threading.main_thread():
            for sig in ABORT_SIGNALS:
                self._previous[sig] = signal.signal(sig, self._on_signal)
        return self

    def __exit__(self, *_exc: object) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous.clear()
        os.close(self._read)
        os.close(self._write)

    def check(self, sim_s: float | None = None, started: bool = True) -> None:
        """Raise :class:`RunAbortedError` if a signal came."""
        if self.signum is not None:
            raise RunAbortedError(self.signum, sim_s, started)


#: Wall seconds the controller and the recorder get to exit by themselves after a plant_kill.
PLANT_KILL_EXIT_TIMEOUT_S: dict[str, float] = {"controller": 10.0, "recorder": 15.0}


def check_process_faults(scenario: Scenario, mode: Mode) -> tuple[ProcessFault, ...]:
    """The scenario's process faults, refused where the run's mode cannot act on them.

    Parameters
    ----------
    scenario : Scenario
        The run's scenario.
    mode : str
        ``realtime``, ``lockstep`` or ``inprocess``.

    Returns
    -------
    tuple of ProcessFault
        The process faults by start time (empty when there are none).

    Raises
    ------
    ProcessFaultError
        In-process mode with any process fault (there are no processes), or lock-step mode
        with a ``controller_kill`` (the plant would wait for the dead controller's command
        until its lock-step timeout aborted the run).
    """
    faults = scenario.process_faults()
    for f in faults:
        if mode == "inprocess":
            raise ProcessFaultError(
                f"scenario {scenario.name!r} {f.label}: kind {f.kind!r} needs plant and "
                "controller processes; an in-process run has none (use --mode realtime)"
            )
        if mode == "lockstep" and f.kind == "controller_kill":
            raise ProcessFaultError(
                f"scenario {scenario.name!r} {f.label}: kind 'controller_kill' needs "
                "--mode realtime: in lock-step the plant waits for every command and would "
                "abort on its lock-step timeout once the controller is killed"
            )
    return faults


def default_out_dir(scenario: Scenario) -> Path:
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    return Path("runs") / f"{stamp}-{scenario.name}"


def run_info(req: RunRequest, scenario: Scenario) -> dict[str, str]:
    """The ``run`` metadata record of the MCAP file."""
    info = {
        "family": TURBINE.name,
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
            network_namespace="private" if _in_private_netns() else "host",
        )
    return info


def _in_private_netns() -> bool:
    from hil.nodes.can_bus import in_private_netns  # noqa: PLC0415 - python-can: CAN runs only

    return in_private_netns()


def can_config(req: RunRequest, scenario: Scenario) -> CanBusConfig:
    """The run's CAN bus: the request's, else the scenario's ``[can]`` section."""
    if req.can is not None:
        return req.can
    from hil.nodes.can_bus import CanBusConfig  # noqa: PLC0415 - python-can: CAN runs only

    c = scenario.can
    return CanBusConfig.for_interface(c.interface, c.channel, c.fd, scenario.turbine_id)


def ensure_designs(scenario: Scenario, console: Console | None = None) -> Path | None:
    """Make the design artefacts the scenario's controller needs, if missing.

    The controller registry knows which kinds load design artefacts and how to make them
    (:func:`controller.registry.ensure_design`); this hands it the scenario's controller,
    period, platform, wind and sea. A design runs in a child process (this process and the
    controller process import no design code) and prints what it does and how long it took.

    Parameters
    ----------
    scenario : Scenario
        The run's scenario.
    console : Console, optional
        Where the messages go.

    Returns
    -------
    Path or None
        The cache folder designed into (to hand to the controller as ``$FOWT_DESIGN_DIR`` or
        ``design_dir``), or None when nothing was missing or the kind loads no design.

    Raises
    ------
    RunFailedError
        If the design fails (its output is in the message).
    """
    from controller.design.on_demand import DesignFailedError  # noqa: PLC0415
    from controller.registry import DesignRequest, ensure_design  # noqa: PLC0415

    c = scenario.controller
    request = DesignRequest(
        kind=c.kind,
        preset=c.preset,
        control_period_s=scenario.timing.control_period_s,
        feedforward=c.feedforward,
        platform=scenario.platform,
        wind_speed_m_s=getattr(scenario.wind, "speed_m_s", None),
        hs_m=getattr(scenario.waves, "hs_m", None),
        t1_s=getattr(scenario.waves, "t1_s", None),
        core=c.core,
        settings=c.settings,
        base_dir=c.base_dir,
    )
    try:
        return ensure_design(request, (console or Console()).print)
    except DesignFailedError as exc:
        raise RunFailedError(str(exc)) from exc


def launch(
    req: RunRequest, console: Console | None = None, worker: PlotWorker | None = None
) -> dict[str, Any]:
    """Run a scenario end to end and review it; returns the summary (also in summary.json).

    ``worker``: a drawing process the caller started with the command
    (:class:`hil.review.plot_worker.PlotWorker`, ``fowt run``'s first step), where a
    single-turbine run's plots are drawn; None: drawn in this process. The caller closes it.

    The advanced controller's design artefacts for the scenario's control period are
    designed first when missing (:func:`ensure_designs`), and the controller (process or
    in-process runtime) is told where they are. The scenario's process faults are checked
    against the mode first (:func:`check_process_faults`), injected during the run
    (:class:`ProcessFaultDriver`) and reported in the summary's ``run.process_faults``.

    Raises
    ------
    ProcessFaultError
        When the mode cannot act on a process fault (nothing is started).
    RunFailedError
        When a process fails; also, after the summary is written, when a process fault run
        has a problem (:attr:`ProcessFaultDriver.problems`).
    """
    console = console or Console()
    if req.transport not in ("zenoh", "can"):
        raise ValueError(f"transport {req.transport!r}: expected zenoh or can")
    family = resolve(req.scenario)
    check_request(family, req.given(), req.mode)
    with AbortSignals() as abort:
        if family is not TURBINE:
            return _launch_family(req, family, console, abort)
        return _launch(req, console, abort, worker)


def _launch(
    req: RunRequest, console: Console, abort: AbortSignals, worker: PlotWorker | None = None
) -> dict[str, Any]:
    """:func:`launch` with the run's signal handlers in place."""
    scenario = load_scenario(req.scenario).with_duration(req.duration_s)
    process_faults = check_process_faults(scenario, req.mode)
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
        in_netns = _can_ready(req, can, out, abort)
        if in_netns is not None:
            return in_netns
    out.mkdir(parents=True, exist_ok=True)
    (out / FAULT_FILE).unlink(missing_ok=True)  # an earlier run's, in the same folder
    mcap_path = out / "run.mcap"
    info = run_info(req, scenario)
    design_dir = ensure_designs(scenario, console)
    abort.check(started=False)  # a signal during the design: nothing ran, nothing to review
    if req.mode != "inprocess":
        # A bus run's trimmed start settles here, in the launcher, before any node starts:
        # a core that faults in it is the controller's fault (exit 7), not the plant
        # process's exit status; the plant process then reads the settled point from the
        # trim store. (An in-process run settles in this process anyway: below.)
        try:
            initial_condition(scenario)
        except ControllerFaultError as exc:
            return _trim_fault(exc, req, scenario, out, info, console)
        except Exception:  # reported by the nodes, as it always was
            # A core that cannot be built, a DISCON library that refuses: the nodes start,
            # fail the same way and say so, and their recording is reviewed.
            pass
        abort.check(started=False)
    for level, line in feedforward_notice(scenario):
        console.print(
            f"[yellow]warning:[/] {escape(line)}" if level == "warning" else line,
            markup=level == "warning",
        )
    t0 = time.monotonic()
    phases: dict[str, float] = {}
    driver: ProcessFaultDriver | None = None
    loop_ran = ""
    aborted: RunAbortedError | None = None
    try:
        if req.mode == "inprocess":
            loop_ran = _run_inprocess(
                scenario,
                mcap_path,
                info,
                toml_text,
                design_dir,
                req.inprocess_loop,
                abort,
                phases,
                progress=lambda line: console.print(line, markup=False),
            )
            console.print(f"in-process loop: {loop_ran}")
        else:
            if process_faults:
                driver = ProcessFaultDriver(process_faults, scenario.timing.control_period_s)
            _run_processes(req, scenario, out, mcap_path, info, console, design_dir, driver, abort)
    except ControllerFaultError as exc:  # in process: the core faulted in the trim
        return _trim_fault(exc, req, scenario, out, info, console)
    except RunAbortedError as exc:
        if not mcap_path.is_file():  # stopped before the recorder opened its file
            raise RunAbortedError(exc.signum, exc.sim_s, started=False) from None
        aborted = exc
        if driver is not None:  # close the fault records as at a run's end
            driver.finish(console, how=str(exc))
        console.print(
            f"[yellow]{exc.signal_name}:[/] run stopped"
            + (f" at {exc.sim_s:.2f} s simulated" if exc.sim_s is not None else "")
            + "; reviewing what was recorded"
        )
    except RunFailedError as exc:
        _failed_summary(mcap_path, out, exc)
        raise
    wall = time.monotonic() - t0
    phases.setdefault("log_end", time.monotonic())
    summary = review(mcap_path, out, plots=req.plots, worker=worker)
    if req.live_port is not None:
        _live_summary(summary, out, console)
    phases["review_end"] = time.monotonic()
    summary.setdefault("run", {})["launcher_wall_s"] = round(wall, 3)
    speed = (
        speed_line(summary, phases, float(scenario.duration_s)) if req.mode == "inprocess" else None
    )
    summary["run"]["aborted"] = aborted is not None
    if aborted is not None:
        summary["run"]["abort_signal"] = aborted.signal_name
        summary["run"]["aborted_at_s"] = aborted.sim_s
    if loop_ran:
        summary["run"]["inprocess_loop"] = loop_ran
    if scenario.review.power_metric == "quadratic_linear" and aborted is None:
        from dataclasses import asdict  # noqa: PLC0415

        from hil.review.casanovas_linear import run_linear  # noqa: PLC0415

        summary["casanovas_quadratic_linear"] = asdict(run_linear(scenario))
    if driver is not None:
        summary["run"]["process_faults"] = driver.records
        summary["run"]["plant_killed"] = driver.plant_killed
        if driver.problems:
            summary["run"]["process_fault_problems"] = list(driver.problems)
    _conclude(
        summary, out, mcap_path, console, driver.render if driver is not None else None, speed
    )
    if driver is not None and driver.problems:
        raise RunFailedError("; ".join(driver.problems))
    return summary


def _live_summary(summary: dict[str, Any], out: Path, console: Console) -> None:
    """The live view's counts (its ``live.json``) into ``run.live_view``, and one line.

    A batch lost on the way shows as a gap before the next one, but the recorder's last
    batches (put as its session closes) or a first one before the live view listened have
    no batch after or before them to show it: ``never_received`` counts the run log's
    messages that reached neither the viewers nor the live view's counts (the log's
    messages minus those offered to the server and those lost in gaps), and ``dropped``
    includes them.
    """
    from hil.live.node import LIVE_JSON  # noqa: PLC0415

    try:
        live = json.loads((out / LIVE_JSON).read_text())
    except (OSError, ValueError):
        live = {"error": f"no {LIVE_JSON}: the live view did not finish (logs/live.log)"}
    topics = (summary.get("recording") or {}).get("topics") or {}
    logged = sum(int(t.get("recorded") or 0) for t in topics.values())
    if "error" not in live and logged:
        seen = int(live.get("offered", 0)) + int(live.get("lost_in_feed", 0))
        live["never_received"] = max(0, logged - seen)
        live["dropped"] = int(live.get("dropped", 0)) + live["never_received"]
    summary.setdefault("run", {})["live_view"] = live
    console.print(
        f"live view: {live.get('published', 0)} messages published, "
        f"{live.get('dropped', 0)} dropped for the viewers, "
        f"{live.get('outbox_full', 0)} viewer outbox overflows (the run log is unaffected)",
        markup=False,
    )


def _conclude(
    summary: dict[str, Any],
    out: Path,
    mcap_path: Path,
    console: Console,
    more: Callable[[Console], None] | None = None,
    speed: str | None = None,
) -> None:
    """The end of every run: the verdict (exit code), ``summary.json``, the report, where
    the files are, the outcome line. ``more`` prints what the run adds to the report."""
    code = record_outcome(summary)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    render_summary(summary, console)
    if more is not None:
        more(console)
    # Paths and messages are the user's text: escaped, so brackets in them are printed.
    console.print(f"run log: [bold]{escape(str(mcap_path))}[/]")
    console.print(f"summary: {escape(str(out / 'summary.json'))}")
    for png in sorted(out.glob("*.png")):
        console.print(f"plot:    {escape(str(png))}")
    if speed:
        console.print(speed, markup=False, soft_wrap=True)
    console.print(
        outcome_line(code, summary["run"]["outcome_reasons"]), markup=False, soft_wrap=True
    )


def _launch_family(
    req: RunRequest, family: PlantFamily, console: Console, abort: AbortSignals
) -> dict[str, Any]:
    """:func:`launch` of another family than the single turbine (:mod:`hil.families`): its
    nodes go through the same process start, supervision, stop, abort handling, review,
    ``summary.json`` and exit codes as a turbine run's; what differs comes from ``family``."""
    if family.plan is None:
        raise RunRequestError(f"family {family.name!r}: no launcher plan")
    options = req.hexicon
    plan = family.plan(req.scenario, req.duration_s, options)
    out = req.out_dir or Path("runs") / (
        f"{datetime.now(UTC).strftime('%Y%m%dT%H%M%SZ')}-{plan.name}"
    )
    can: CanBusConfig | None = None
    if req.transport == "can":
        from hil.nodes.can_bus import CanBusConfig  # noqa: PLC0415 - python-can: CAN runs only

        can = req.can or CanBusConfig.for_interface("udp_multicast", None, False, plan.ident)
        in_netns = _can_ready(req, can, out, abort)
        if in_netns is not None:
            return in_netns
    out.mkdir(parents=True, exist_ok=True)
    mcap_path = out / "run.mcap"
    info = {
        **plan.metadata,
        "mode": req.mode,
        "transport": req.transport,
        "duration_s": f"{plan.duration_s:g}",
        "started_utc": datetime.now(UTC).isoformat(),
        "python": sys.version.split()[0],
        "command": " ".join(sys.argv),
    }
    if can is not None:
        info.update(can_interface=can.interface, can_channel=can.effective_channel)
    t0 = time.monotonic()
    aborted: RunAbortedError | None = None
    try:
        _start_nodes(
            family, req, out, mcap_path, info, console, scenario=plan.scenario,
            duration_s=plan.duration_s, name=plan.name, ident=plan.ident, can=can,
            env=_node_env(out), options=options, abort=abort,
        )  # fmt: skip
    except RunAbortedError as exc:
        if not mcap_path.is_file():
            raise RunAbortedError(exc.signum, exc.sim_s, started=False) from None
        aborted = exc
        console.print(f"[yellow]{exc.signal_name}:[/] run stopped; reviewing what was recorded")
    except RunFailedError as exc:
        _failed_summary(mcap_path, out, exc)
        raise
    wall = time.monotonic() - t0
    summary = review(mcap_path, out, plots=req.plots)
    summary.setdefault("run", {})["launcher_wall_s"] = round(wall, 3)
    summary["run"]["aborted"] = aborted is not None
    if aborted is not None:
        summary["run"]["abort_signal"] = aborted.signal_name
        summary["run"]["aborted_at_s"] = aborted.sim_s
    _conclude(summary, out, mcap_path, console)
    return summary


def _trim_fault(
    exc: ControllerFaultError,
    req: RunRequest,
    scenario: Scenario,
    out: Path,
    info: dict[str, str],
    console: Console,
) -> dict[str, Any]:
    """The verdict of a run whose controller faulted in the trim's settling run: no cycle
    of the run was recorded; ``summary.json`` says which process and why, exit 7."""
    summary: dict[str, Any] = {
        "run": {**info, "mode": req.mode, "failed_process": "controller", "aborted": False},
        "scenario": {"name": scenario.name},
        "controller": {"fault": exc.fault.to_dict()},
    }
    code = record_outcome(summary)
    write_fault(out, exc.fault)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    console.print(f"summary: {escape(str(out / 'summary.json'))}")
    console.print(
        outcome_line(code, summary["run"]["outcome_reasons"]), markup=False, soft_wrap=True
    )
    return summary


def _failed_summary(mcap_path: Path, out: Path, exc: RunFailedError) -> None:
    """Best effort: a failed run's ``summary.json`` from what was recorded, outcome
    ``failed`` and why. Nothing when there is no file or it cannot be read or written
    (the disk that filled up): the run's error is what is reported, not this."""
    if not mcap_path.is_file():
        return
    with contextlib.suppress(Exception):  # any failure here would only hide the run's own
        summary = review(mcap_path, out, plots=False, write_summary=False)
        summary.setdefault("run", {})["failed"] = str(exc)
        if exc.process is not None:
            summary["run"]["failed_process"] = exc.process
        record_outcome(summary)
        path = out / "summary.json"
        try:
            path.write_text(json.dumps(summary, indent=2))
        except OSError:
            path.unlink(missing_ok=True)  # no half-written summary left behind
            raise


def _run_inprocess(
    scenario: Scenario,
    mcap_path: Path,
    info: dict[str, str],
    toml_text: str,
    design_dir: Path | None = None,
    loop: Literal["auto", "compiled", "python"] = "auto",
    abort: AbortSignals | None = None,
    phases: dict[str, float] | None = None,
    progress: Callable[[str], None] | None = None,
) -> str:
    """Run in process into ``mcap_path``; return which loop ran (``compiled``, ``python``).

    ``progress`` gets a line on how far a long run is every ten seconds of wall time
    (:class:`hil.inprocess.run.Progress`).

    ``phases`` gets the monotonic times [s] the loop started (``loop_start``) and ended
    (``loop_end``) and the log was closed (``log_end``), for :func:`speed_line`.

    A signal (``abort``) stops the loop at the next cycle (compiled: at the next batch's
    start); the plant's final summary is written and the file closed, then
    :class:`RunAbortedError` is raised. A write that fails (disk full) ends the run with
    :class:`RunFailedError` saying so; the file stays readable up to the failure.
    """
    log = BackgroundRunLog(
        mcap_path,
        scenario.turbine_id,
        {
            "scenario": scenario_metadata(scenario, toml_text),
            "recording": scenario_recording_metadata(scenario),
            "run": info,
        },
        truth_every=scenario_truth_every(scenario),
    )
    # A core that cannot be built closes the log (its writer would keep the process alive)
    # and the run fails with the reason; the MCAP file stays reviewable.
    try:
        runtime = ControllerRuntime(
            scenario,
            design_dir=design_dir,
            run_dir=mcap_path.parent,
            operating_point=functools.partial(operating_point, scenario),
        )
    except BaseException as exc:
        log.close()
        if isinstance(exc, ValueError | DisconError):  # e.g. a DISCON library or DISCON.IN
            raise RunFailedError(
                f"controller {scenario.controller.kind!r}: {exc}", process="controller"
            ) from exc
        raise

    def publish_with_preview(mt: MessageType, msg: msgspec.Struct) -> None:
        if mt is WAVE_PREVIEW_PERFECT:  # the bench oracle reaches the core as over the bus
            runtime.handle_preview(msg)
        log.publish(mt, msg)

    # Without the perfect preview every message goes straight to the log (one call less).
    publish = publish_with_preview if scenario.controller.preview == "perfect" else log.publish
    step = publishing_step(runtime, publish)
    marks: dict[str, float] = phases if phases is not None else {}

    def before_loop() -> None:
        log.wait_ready()
        # What start-up built (imports, kernels, tables) stays for the run: out of the
        # collector's reach, full collections in the run walk only what is new (given back
        # after the run: a process that launches again must be able to free this run).
        gc.freeze()
        steady_gc()
        marks["loop_start"] = time.monotonic()

    try:
        try:
            result = run_inprocess(
                scenario,
                publish,
                step,
                before_loop=before_loop,
                runtime=runtime,
                loop=loop,
                publish_block=log.publish_block,
                published=log.published,  # the plant's report follows its final summary
                stop=abort,
                progress=progress,
            )
            marks["loop_end"] = time.monotonic()
            if runtime.fault is not None:  # its text beside the file (the review reads it)
                write_fault(mcap_path.parent, runtime.fault)
            # The controller stops with the plant: its report goes last, as a process's would.
            counts = log.published()
            log.publish(
                CONTROLLER_REPORT,
                controller_report(
                    runtime,
                    counts[COMMAND.key_suffix],
                    counts[CONTROLLER_STATUS.key_suffix],
                    aborted=bool(result.aborted),
                ),
            )
        except ValueError as exc:
            if str(exc).startswith("loop='compiled'"):  # asked for, not supported: say why
                raise RunFailedError(f"--loop compiled: {exc}") from exc
            raise
        except DisconError as exc:  # aviFAIL < 0: the run ends; the log so far stays readable
            raise RunFailedError(
                f"controller failed: {exc}; the run up to it: {mcap_path}", process="controller"
            ) from exc
        finally:
            # The writer that failed has said why (LogWriteError); a second account of the
            # same failure from close() would only hide the first.
            failing = sys.exc_info()[1]
            gc.unfreeze()
            try:
                log.close()
            except LogWriteError:
                if failing is None:
                    raise
            marks["log_end"] = time.monotonic()
    except LogWriteError as exc:
        raise RunFailedError(f"{exc} (the file is readable up to the failure)") from None
    if result.aborted and abort is not None and abort.signum is not None:
        raise RunAbortedError(abort.signum, result.sim_s)
    return result.loop


def process_start_monotonic() -> float | None:
    """When this process started, on the :func:`time.monotonic` clock [s] (None: unknown).

    From the start time in ``/proc/self/stat`` (clock ticks since boot) and ``/proc/uptime``:
    the interpreter's own start-up (before any module of the bench ran) is then counted.
    """
    try:
        stat = Path("/proc/self/stat").read_text()
        uptime = float(Path("/proc/uptime").read_text().split()[0])
        ticks = int(stat.rsplit(")", 1)[1].split()[19])  # field 22: starttime
        age = uptime - ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None
    return time.monotonic() - age


def speed_line(summary: dict[str, Any], phases: dict[str, float], sim_s: float) -> str | None:
    """``speed: loop 1150x real time, whole command 420x (start-up 0.4 s, ...)``.

    The loop's figure is the plant's own (its final summary's simulated seconds per wall
    second, the cycle loop alone); the whole command's is the simulated time over the
    command's wall time so far, from the process's start (interpreter included) through the
    review: start-up (imports, scenario, designs, controller and log writer up to the
    loop's first cycle), run (the loop), log (the writer finishing the file) and review.
    Also stored in ``summary["run"]["wall_phases_s"]``. None without the loop's times.
    """
    start = process_start_monotonic()
    if start is None or "loop_start" not in phases or "loop_end" not in phases:
        return None
    now = phases.get("review_end", time.monotonic())
    parts = {
        "start_up": phases["loop_start"] - start,
        "run": phases["loop_end"] - phases["loop_start"],
        "log": phases.get("log_end", phases["loop_end"]) - phases["loop_end"],
        "review": now - phases.get("log_end", phases["loop_end"]),
        "whole": now - start,
    }
    summary.setdefault("run", {})["wall_phases_s"] = {k: round(v, 3) for k, v in parts.items()}
    loop = summary.get("timing", {}).get("sim_seconds_per_wall_second")
    loop_text = f"loop {loop:.0f}x real time" if isinstance(loop, int | float) else "loop -"
    return (
        f"speed: {loop_text}, whole command {sim_s / parts['whole']:.0f}x "
        f"(start-up {parts['start_up']:.2f} s, run {parts['run']:.2f} s, "
        f"log {parts['log']:.2f} s, review {parts['review']:.2f} s)"
    )


def _scenario_ref(ref: str) -> str:
    """A scenario reference another process (another cwd) resolves the same way."""
    return str(Path(ref).resolve()) if Path(ref).suffix == ".toml" else ref


def _hexicon_args(o: HexiconOptions) -> list[str]:
    """The ``fowt run`` options of a Hexicon run's :class:`HexiconOptions`."""
    args = ["--controller", o.controller, "--noise" if o.noise else "--no-noise"]
    if o.identified is not None:
        args += ["--identified", str(o.identified.resolve())]
    if o.experiment:
        args += ["--experiment", str(o.experiment), "--seed", str(o.seed)]
    return args


def _can_ready(
    req: RunRequest, can: CanBusConfig, out: Path, abort: AbortSignals
) -> dict[str, Any] | None:
    """Check that ``can`` can run here; a virtual bus outside a private network namespace
    re-runs this launch inside one (its summary returned), else None: go on here."""
    from hil.nodes.can_bus import in_private_netns, transport_unavailable_reason  # noqa: PLC0415

    reason = transport_unavailable_reason(can)
    if reason is not None:  # refused before anything started: bad input (exit 2)
        raise RunRequestError(f"--transport can --can-interface {can.interface}: {reason}")
    if can.interface == "udp_multicast" and not in_private_netns():
        if os.environ.get(_NETNS_ENV):  # never re-exec twice
            raise RunFailedError(
                "re-executed under unshare --net, yet not in a private network namespace"
            )
        return _launch_in_netns(req, can, out, abort)
    return None


def _launch_in_netns(
    req: RunRequest, can: CanBusConfig, out: Path, abort: AbortSignals | None = None
) -> dict[str, Any]:
    """Re-run this ``fowt run`` in a fresh network namespace; return its summary.

    The child launcher (same Python, same options, ``--out`` resolved) runs plant,
    controller and recorder inside the namespace (:func:`hil.nodes.can_bus.netns_command`) and
    prints its own progress and summary to this process's terminal.

    A signal to this launcher is passed on to the child launcher (SIGTERM), which stops its
    run as its own; the child's summary says so, and its outcome is this run's.

    Raises
    ------
    RunFailedError
        If the namespaced run fails (its exit status, no outcome in its summary), or wrote
        no summary.
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
    if req.realtime_priority:  # the child's plant and controller need it as much
        cmd += ["--realtime-priority", str(req.realtime_priority)]
    if req.hexicon is not None:
        cmd += _hexicon_args(req.hexicon)
    env = {**os.environ, _NETNS_ENV: "1"}
    from hil.nodes.can_bus import netns_command  # noqa: PLC0415

    child = subprocess.Popen(netns_command(cmd), env=env)
    try:
        passed_on = False
        while child.poll() is None:
            if abort is not None and abort.wait(0.2) and not passed_on:
                child.send_signal(signal.SIGTERM)  # `exec` made the launcher unshare's pid
                passed_on = True
            elif abort is None:
                time.sleep(0.2)
    finally:
        if child.poll() is None:
            _stop_child("launcher", child, Console(stderr=True))
    rc = child.returncode
    summary_path = out / "summary.json"
    summary: dict[str, Any] = {}
    if summary_path.is_file():
        summary = json.loads(summary_path.read_text())
    judged = summary.get("run", {}).get("exit_code")
    if rc not in (0, judged):  # not an outcome the child judged: its run failed
        raise RunFailedError(
            f"the run in a private network namespace (unshare --net) exited with {rc}; "
            f"see its output above and {out / 'logs'}"
        )
    if not summary:
        raise RunFailedError(f"the namespaced run wrote no {summary_path}")
    return summary


# How long a failed run's launcher waits for a starting recorder to open its MCAP (s).
_RECORDER_OPEN_S = 30.0


@dataclass(frozen=True)
class _Feed:
    """What the launcher follows a run by: its name and length (progress bar), the id in
    the bus keys, and the family whose progress messages it reads."""

    name: str
    duration_s: float
    ident: str
    family: PlantFamily


def _endpoints() -> tuple[str, str]:
    """Two distinct free loopback endpoints: the plant's and the controller's."""
    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    while ctrl_ep == plant_ep:
        ctrl_ep = free_tcp_endpoint()
    return plant_ep, ctrl_ep


def _run_key(out: Path) -> tuple[Path, bytes]:
    """The run's secret (docs/security.md): fresh for every run, readable by this user only,
    handed to each node by path (never on a command line, which other users can read)."""
    key_path = out / KEY_FILE_NAME
    key_path.unlink(missing_ok=True)  # a folder reused from an earlier run: never reuse a key
    return key_path, create_key_file(key_path)


def _node_env(out: Path) -> dict[str, str]:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env[RUN_DIR_ENV] = str(out.resolve())  # a DISCON library's files go to the run's folder
    return env


def _run_processes(
    req: RunRequest,
    scenario: Scenario,
    out: Path,
    mcap_path: Path,
    info: dict[str, str],
    console: Console,
    design_dir: Path | None = None,
    driver: ProcessFaultDriver | None = None,
    abort: AbortSignals | None = None,
) -> None:
    """A single-turbine run's nodes (:data:`hil.families.TURBINE`), through :func:`_supervise`."""
    env = _node_env(out)
    if design_dir is not None:  # the controller process finds the designs there
        from controller.lqri import DESIGN_DIR_ENV  # noqa: PLC0415

        env[DESIGN_DIR_ENV] = str(design_dir)
    _start_nodes(
        TURBINE, req, out, mcap_path, info, console, scenario=_scenario_ref(req.scenario),
        duration_s=scenario.duration_s, name=scenario.name, ident=scenario.turbine_id,
        can=can_config(req, scenario) if req.transport == "can" else None, env=env,
        driver=driver, abort=abort,
    )  # fmt: skip


def _start_nodes(
    family: PlantFamily,
    req: RunRequest,
    out: Path,
    mcap_path: Path,
    info: dict[str, str],
    console: Console,
    *,
    scenario: str,
    duration_s: float,
    name: str,
    ident: str,
    can: CanBusConfig | None,
    env: dict[str, str],
    options: HexiconOptions | None = None,
    driver: ProcessFaultDriver | None = None,
    abort: AbortSignals | None = None,
) -> None:
    """Start ``family``'s nodes on fresh endpoints with the run's key and supervise them.

    ``scenario``: the reference the nodes are given; ``name``, ``ident``: the progress
    line's scenario and the key ident it follows. The recorder is niced unless the run is
    on CAN.
    """
    endpoints = _endpoints()
    key_path, auth_key = _run_key(out)
    ctx = NodeContext(
        scenario=scenario,
        duration_s=duration_s,
        mode=req.mode,
        speed=req.speed,
        endpoints=endpoints,
        mcap_path=mcap_path,
        run_info=info,
        key_file=key_path,
        can=can,
        realtime_priority=req.realtime_priority,
        launcher_token=driver is not None,
        options=options,
    )
    feed = _Feed(name, duration_s, ident, family)
    cmds = family.node_commands(ctx)
    if req.live_port is not None:  # the live view: a process of its own (hil.live.node)
        from hil.live.node import LIVE_JSON, live_node_command  # noqa: PLC0415

        # fed by the recorder on a link of their own (hil.nodes.live_feed): no third subscriber
        # of the frames and commands that pace the run
        live_ep = free_tcp_endpoint()
        while live_ep in endpoints:
            live_ep = free_tcp_endpoint()
        (out / LIVE_JSON).unlink(missing_ok=True)
        cmds["recorder"] = [*cmds["recorder"], "--connect", live_ep, "--live-forward"]
        cmds["live"] = live_node_command(
            scenario, duration_s, live_ep, endpoints[0], key_path, req.live_port, out / LIVE_JSON
        )
    try:
        _supervise(
            cmds, env, out, mcap_path, feed, endpoints[0], console,
            nice_recorder=can is None, driver=driver, abort=abort, auth_key=auth_key,
        )  # fmt: skip
    finally:
        # Every node has exited (_supervise stops them all): the secret signs nothing more,
        # and a copy of the folder must not carry the credential of a run's bus.
        if not req.keep_key:
            key_path.unlink(missing_ok=True)


def _supervise(
    cmds: dict[str, list[str]],
    env: dict[str, str],
    out: Path,
    mcap_path: Path,
    feed: _Feed,
    plant_ep: str,
    console: Console,
    *,
    nice_recorder: bool = True,
    driver: ProcessFaultDriver | None = None,
    abort: AbortSignals | None = None,
    auth_key: bytes | None = None,
) -> None:
    """Start recorder, controller and plant (``cmds``, any family), follow the run, and
    always stop them; each process's output goes to ``out/logs/<name>.log``.

    Each child runs in a session of its own (a terminal's Ctrl-C reaches the launcher
    only, which decides how the run ends) and gets SIGTERM if the launcher dies
    (``PR_SET_PDEATHSIG``). Whatever ends the run (its end, a signal, a failure, an
    exception here), no child outlives this function (:func:`_stop_children`).

    Raises
    ------
    RunAbortedError
        A signal stopped the run (``abort``); the children were stopped in order first.
    RunFailedError
        A process failed.
    """
    logs = out / "logs"
    logs.mkdir(exist_ok=True)
    procs: dict[str, subprocess.Popen[bytes]] = {}
    files: list[IO[bytes]] = []

    def start(name: str) -> subprocess.Popen[bytes]:
        """Start (or, for a process fault's restart, start again) the process ``name``."""
        again = name in procs
        fh = open(logs / f"{name}.log", "ab" if again else "wb")  # noqa: SIM115 - closed below
        files.append(fh)
        if again:
            fh.write(f"\n--- {name} restarted by the launcher at {_utc()} ---\n".encode())
            fh.flush()
        # The recorder only logs and the live view only shows: they run niced
        # (RECORDER_NICE) so the plant and controller, whose exchange paces the run, get the
        # CPU first when it is scarce (the viewer's queue is bounded, its drops its own).
        # Not the recorder on CAN: its udp_multicast frames have no flow control, a starved
        # recorder would lose some.
        nice = RECORDER_NICE if (name == "recorder" and nice_recorder) or name == "live" else 0
        proc = subprocess.Popen(
            cmds[name],
            stdout=fh,
            stderr=subprocess.STDOUT,
            env=env,
            start_new_session=True,
            preexec_fn=_child_setup(nice),  # noqa: PLW1509
        )
        procs[name] = proc
        return proc

    try:
        # The live view first (when asked for): subscribed before the plant's first cycle.
        for name in ("live", "recorder", "controller", "plant"):
            if name in cmds:
                start(name)
        if driver is not None:
            driver.start_clock()
        _follow(procs, feed, plant_ep, console, driver, start, logs, abort, auth_key)
        rc = procs["plant"].wait()
        if driver is not None and driver.expected(procs["plant"]):
            driver.wait_for_others(procs, console)
        else:
            if rc != 0:
                raise RunFailedError(
                    f"plant exited with {rc}{_last_error(logs, 'plant')}", process="plant"
                )
            _wait_for_recorder(procs["recorder"], mcap_path, console)
            _stop(procs["controller"], 5.0)
            if procs["recorder"].returncode != 0:
                raise RunFailedError(  # its own last error line says why (a full disk)
                    f"recorder exited with {procs['recorder'].returncode}"
                    f"{_last_error(logs, 'recorder')}",
                    process="recorder",
                )
        if driver is not None:
            driver.finish(console)
    finally:
        rec = procs.get("recorder")
        if rec is not None and rec.poll() is None:
            # A run that fails at its start (a controller refusing its DISCON library) still
            # leaves a reviewable log: a recorder still starting up (importing, niced) gets
            # the time to open its MCAP before it is asked to stop.
            opened_by = time.monotonic() + _RECORDER_OPEN_S
            while not mcap_path.exists() and rec.poll() is None and time.monotonic() < opened_by:
                time.sleep(0.05)
        _stop_children(procs, console)
        for fh in files:
            fh.close()


#: Wall seconds the launcher waits for a recorder that shows no progress (its MCAP file does
#: not grow and it uses no CPU) after the plant's end before it stops it; more than the
#: recorder's own END_IDLE_S, after which it stops short by itself and says so.
RECORDER_STALL_S = 60.0


def _cpu_ticks(pid: int) -> int:
    """User + system CPU clock ticks of process ``pid`` so far (-1 where unknown)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return int(fields[11]) + int(fields[12])
    except (OSError, IndexError, ValueError):
        return -1


def _file_size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return -1


def _stop(proc: subprocess.Popen[bytes], timeout_s: float) -> None:
    """Wait ``timeout_s`` for ``proc`` to exit, then SIGTERM it, then SIGKILL it."""
    for action in (None, proc.terminate, proc.kill):
        if action is not None:
            action()
        try:
            proc.wait(timeout_s)
            return
        except subprocess.TimeoutExpired:
            continue


def _wait_for_recorder(
    proc: subprocess.Popen[bytes],
    mcap_path: Path,
    console: Console,
    stall_s: float = RECORDER_STALL_S,
) -> None:
    """Wait for the recorder to finish the run's file after the plant's end.

    No fixed timeout: a recorder behind the run (niced, under load) writes what it still
    holds and records until the nodes' reports are in (:mod:`hil.nodes.recorder`), which takes as
    long as it takes. The wait goes on while it makes progress (its MCAP file grows or it
    uses CPU); only after ``stall_s`` [s] without any is it stopped (SIGTERM: it finishes
    the file; SIGKILL 30 s later), with a warning; the review then says what is missing.
    """
    last = (_file_size(mcap_path), _cpu_ticks(proc.pid))
    progress_at = time.monotonic()
    told = False
    while True:
        try:
            proc.wait(1.0)
            return
        except subprocess.TimeoutExpired:
            pass
        now_state = (_file_size(mcap_path), _cpu_ticks(proc.pid))
        now = time.monotonic()
        if now_state != last:
            last, progress_at = now_state, now
        elif now - progress_at > stall_s:
            console.print(
                f"[red]warning:[/] the recorder made no progress for {stall_s:g} s after the "
                "plant's end: stopping it (the review says what the file lacks)"
            )
            _stop(proc, 30.0)
            return
        if not told:
            console.print(
                "waiting for the recorder to write the rest of the run "
                f"({max(0, last[0]) / 1e6:.1f} MB so far) ..."
            )
            told = True


#: Wall seconds a child gets to exit after SIGTERM before the launcher sends SIGKILL (the
#: recorder finishes its file then: its last chunk, the summary section and the footer).
STOP_GRACE_S: dict[str, float] = {"plant": 20.0, "controller": 20.0, "recorder": 60.0}
#: Wall seconds the controller and the recorder get to end by themselves once the plant has
#: stopped (its final summary ends their runs) before they are sent SIGTERM.
STOP_BY_ITSELF_S = 10.0

_PR_SET_PDEATHSIG = 1


def _child_setup(nice: int) -> Callable[[], None]:
    """The ``preexec_fn`` of a node process: SIGTERM when the launcher dies, niceness.

    The parent-death signal makes the launcher's own death (even SIGKILL, which no handler
    sees) stop its children: they close their files as on any SIGTERM.
    """
    libc = ctypes.CDLL(None, use_errno=True) if sys.platform.startswith("linux") else None

    def setup() -> None:
        if libc is not None:
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
        if nice:
            os.nice(nice)

    return setup


def _stop_child(name: str, proc: subprocess.Popen[bytes], console: Console) -> None:
    """SIGTERM ``proc`` and wait :data:`STOP_GRACE_S`; SIGKILL it (and say so) after that."""
    if proc.poll() is not None:
        return
    proc.terminate()
    grace = STOP_GRACE_S.get(name, 20.0)
    try:
        proc.wait(grace)
    except subprocess.TimeoutExpired:
        console.print(
            f"[yellow]warning:[/] {name} (pid {proc.pid}) did not exit within {grace:g} s of "
            "SIGTERM: sent SIGKILL"
            + (" (its file may be truncated)" if name == "recorder" else ""),
        )
        proc.kill()
        proc.wait()


def _stop_children(procs: dict[str, subprocess.Popen[bytes]], console: Console) -> None:
    """Stop every child still running, in the order that keeps the recording whole.

    The plant first (SIGTERM: it ends its loop and publishes its final summary), then the
    controller and the recorder are given :data:`STOP_BY_ITSELF_S` to end on that summary
    as at a run's normal end (the recorder drains and finishes its file), then SIGTERM,
    and SIGKILL only after :data:`STOP_GRACE_S`.
    """
    order: list[str] = [n for n in ("plant", "controller", "recorder") if n in procs]
    order += [n for n in procs if n not in order]
    if "plant" in procs:
        _stop_child("plant", procs["plant"], console)
    until = time.monotonic() + STOP_BY_ITSELF_S
    while time.monotonic() < until and any(procs[n].poll() is None for n in order):
        time.sleep(0.05)
    for name in order:
        _stop_child(name, procs[name], console)


def _follow(
    procs: dict[str, subprocess.Popen[bytes]],
    feed: _Feed,
    plant_ep: str,
    console: Console,
    driver: ProcessFaultDriver | None = None,
    start: Callable[[str], subprocess.Popen[bytes]] | None = None,
    logs: Path | None = None,
    abort: AbortSignals | None = None,
    auth_key: bytes | None = None,
) -> None:
    """Show progress (simulated time from the family's progress messages: a turbine plant's
    timing summaries, a platform's frames) until the plant exits.

    With a ``driver`` the plant's ``timing/cycle`` records are followed too (the launcher
    announces itself with the liveliness token ``fowt/<turbine>/alive/launcher``, which the
    plant then waits for), and the scenario's process faults are injected as their time
    comes (``start`` restarts a process); a process the driver killed is not a failure.

    A signal (``abort``) stops the children in order (:func:`_stop_children`); the
    progress bar then shows the simulated time reached, not the run's length.

    Raises
    ------
    RunFailedError
        When the controller or the recorder exits with a nonzero status it was not killed
        with by a process fault.
    RunAbortedError
        When a signal stopped the run.
    """
    latest: dict[str, float] = {"sim_s": 0.0, "misses": 0.0}

    def on_progress(_key: str, payload: bytes) -> None:
        got = feed.family.progress(payload)
        if got is not None:
            latest["sim_s"], latest["misses"] = got

    bus = Bus(BusConfig(connect=(plant_ep,), auth_key=auth_key))
    token: Any = None  # kept referenced: a dropped liveliness token is undeclared
    try:
        bus.subscribe(feed.family.progress_key(feed.ident), on_progress)
        if driver is not None:
            tid = feed.ident
            bus.subscribe(CYCLE_TIMING.key(tid), driver.on_cycle)
            # The plant's node puts its cycle records in log batches (hil.nodes.bus.LogBatcher).
            batches = unbatching(CYCLE_TIMING, driver.on_cycle, tid)
            bus.subscribe(batch_key(tid, PLANT_BATCH_SUFFIX), batches)
            # The plant waits for this token (``--require ...,launcher``), so no cycle passes
            # unseen, however fast a lock-step run goes.
            token = bus.session.liveliness().declare_token(f"fowt/{tid}/alive/launcher")
        # The progress bar of a bus run only: an in-process run does not load it (~50 ms).
        from rich.progress import (  # noqa: PLC0415
            BarColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
        )

        with Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            TextColumn("{task.completed:.0f}/{task.total:.0f} s simulated"),
            TextColumn("misses {task.fields[misses]:.0f}"),
            TimeElapsedColumn(),
            console=console,
            transient=False,
        ) as progress:
            task = progress.add_task(feed.name, total=feed.duration_s, misses=0)
            while procs["plant"].poll() is None:
                if abort is not None and abort.signum is not None:
                    name = signal.Signals(abort.signum).name
                    progress.update(
                        task,
                        completed=latest["sim_s"],
                        misses=latest["misses"],
                        description=f"{feed.name} ({name}: stopping)",
                    )
                    _stop_children(procs, console)
                    progress.update(
                        task,
                        completed=latest["sim_s"],
                        description=f"{feed.name} (aborted by {name})",
                    )
                    abort.check(latest["sim_s"])
                for name in ("controller", "recorder"):
                    proc = procs[name]
                    rc = proc.poll()
                    if rc is not None and rc != 0 and not (driver and driver.expected(proc)):
                        raise RunFailedError(
                            f"{name} exited with {rc} during the run{_last_error(logs, name)}",
                            process=name,
                        )
                if driver is not None and start is not None:
                    driver.step(procs, start, console)
                progress.update(task, completed=latest["sim_s"], misses=latest["misses"])
                if driver is not None:
                    driver.due.wait(driver.wait_s(0.1))
                elif abort is not None:
                    abort.wait(0.1)
                else:
                    time.sleep(0.1)
            # The plant's last running summary may precede its end by up to a second: a
            # plant that ended well ran the whole duration; any other end shows how far it got.
            whole = procs["plant"].returncode == 0 and not (driver and driver.plant_killed)
            done = max(latest["sim_s"], feed.duration_s) if whole else latest["sim_s"]
            progress.update(task, completed=done)
    finally:
        if token is not None:
            with contextlib.suppress(Exception):  # the session may already be going away
                token.undeclare()
        bus.close()


def _last_error(logs: Path | None, name: str) -> str:
    """``": <the last 'error:' line of its log>"``, or "" (for a failed process's message)."""
    if logs is None:
        return ""
    with contextlib.suppress(OSError):
        text = (logs / f"{name}.log").read_text(errors="replace")
        lines = [ln.strip() for ln in text.splitlines() if ln.startswith("error:")]
        if lines:
            return f": {lines[-1].removeprefix('error:').strip()} (log: {logs / f'{name}.log'})"
        return f" (log: {logs / f'{name}.log'})"
    return ""


def _utc() -> str:
    """Now, UTC, ISO 8601 to the millisecond."""
    return datetime.now(UTC).isoformat(timespec="milliseconds")


class ProcessFaultDriver:
    """Injects a run's process faults and keeps their record (module docstring).

    Parameters
    ----------
    faults : sequence of ProcessFault
        The scenario's process faults (:func:`check_process_faults`).
    control_period_s : float
        The plant's control period T [s]: the ``timing/cycle`` record of cycle k (sample
        time t_k) says the simulated time has reached t_k + T.

    Attributes
    ----------
    records : list of dict
        One JSON-able record per fault, by start time: ``fault`` (``faults[i]``), ``kind``,
        ``start_s``, ``restart_after_s``, ``outcome`` (a sentence), ``killed`` and
        ``restarted`` (None, or ``pid``, ``sim_s`` [s simulated: the end of the newest cycle
        the plant had reported], ``wall_s`` [s since the processes were started], ``utc``);
        for ``controller_kill`` also ``plant_safe_state`` (``entered_sim_s``: sample time of
        the first ``timing/cycle`` with the safe state on from the kill's cycle on;
        ``left_sim_s``: the first one after that with it off; None when not seen); for
        ``plant_kill`` also ``others`` (per process: ``exit_code``, ``exited_after_s``
        [wall s after the kill], ``by_itself``).
    problems : list of str
        What fails the run although only the processes asked for were killed.
    plant_killed : bool
        True once a ``plant_kill`` killed the plant.
    due : threading.Event
        Set (from Zenoh's thread) when the simulated time reaches the next fault's start.
    """

    def __init__(self, faults: Sequence[ProcessFault], control_period_s: float) -> None:
        self.period_ns = round(control_period_s * 1e9)
        self._pending = sorted(faults, key=lambda f: (f.start_s, f.index))
        self.records: list[dict[str, Any]] = [
            {
                "fault": f.label,
                "kind": f.kind,
                "start_s": f.start_s,
                "restart_after_s": f.restart_after_s,
                "outcome": "not injected",
                "killed": None,
                "restarted": None,
            }
            for f in self._pending
        ]
        self._by_index = {f.index: r for f, r in zip(self._pending, self.records, strict=True)}
        self.problems: list[str] = []
        self.plant_killed = False
        self._plant_killed_at: float | None = None  # monotonic
        self.due = threading.Event()
        self._lock = threading.Lock()
        self._sim_ns = 0  # end of the newest cycle the plant reported
        self._safe = 0
        self._safe_changes: list[tuple[int, int]] = []  # (cycle sample time ns, new state)
        self._killed: list[subprocess.Popen[bytes]] = []
        self._restarts: list[tuple[float, ProcessFault]] = []  # (monotonic due, fault)
        self._t0 = time.monotonic()
        self._next_due_ns = self._due_ns()

    def _due_ns(self) -> float:
        return round(self._pending[0].start_s * 1e9) if self._pending else math.inf

    def start_clock(self) -> None:
        """Take now as the wall-clock origin of the records' ``wall_s`` (processes started)."""
        self._t0 = time.monotonic()

    def on_cycle(self, _key: str, payload: bytes) -> None:
        """``timing/cycle`` callback (Zenoh's thread): simulated time and safe state."""
        try:
            c = CYCLE_TIMING.codec.decode(payload)
        except Exception:
            return
        with self._lock:
            self._sim_ns = max(self._sim_ns, c.sample_time_ns + self.period_ns)
            if c.safe_state != self._safe:
                self._safe = c.safe_state
                self._safe_changes.append((c.sample_time_ns, c.safe_state))
            sim_ns = self._sim_ns
        if sim_ns >= self._next_due_ns:
            self.due.set()

    def expected(self, proc: subprocess.Popen[bytes]) -> bool:
        """True when ``proc`` died because a process fault killed it."""
        return any(p is proc for p in self._killed)

    def wait_s(self, default: float) -> float:
        """How long the follow loop may sleep: ``default``, less when a restart is due."""
        if not self._restarts:
            return default
        soonest = min(at for at, _ in self._restarts)
        return max(0.0, min(default, soonest - time.monotonic()))

    def _stamp(self, pid: int, sim_ns: int, at: float) -> dict[str, Any]:
        return {
            "pid": pid,
            "sim_s": round(sim_ns / 1e9, 3),
            "wall_s": round(at - self._t0, 3),
            "utc": _utc(),
        }

    def step(
        self,
        procs: dict[str, subprocess.Popen[bytes]],
        start: Callable[[str], subprocess.Popen[bytes]],
        console: Console,
    ) -> None:
        """Kill what the simulated time has reached, restart what is due (main thread).

        Parameters
        ----------
        procs : dict of str to Popen
            The run's processes by name; a restart replaces ``procs["controller"]``.
        start : callable
            ``start(name)`` starts the process ``name`` again and returns it.
        console : Console
            Where the events are printed.
        """
        self.due.clear()
        with self._lock:
            sim_ns = self._sim_ns
        while self._pending and round(self._pending[0].start_s * 1e9) <= sim_ns:
            fault = self._pending.pop(0)
            self._next_due_ns = self._due_ns()
            self._kill(fault, procs, sim_ns, console)
        now = time.monotonic()
        for item in [r for r in self._restarts if r[0] <= now]:
            self._restarts.remove(item)
            self._restart(item[1], procs, start, console)

    def _kill(
        self,
        fault: ProcessFault,
        procs: dict[str, subprocess.Popen[bytes]],
        sim_ns: int,
        console: Console,
    ) -> None:
        rec = self._by_index[fault.index]
        name = fault.process
        proc = procs[name]
        if proc.poll() is not None:
            rec["outcome"] = (
                f"not injected: no {name} process was running at {sim_ns / 1e9:.3f} s "
                f"simulated (the last one exited with {proc.returncode})"
            )
            console.print(
                f"[yellow]process fault[/] {fault.label} {fault.kind}: {escape(rec['outcome'])}"
            )
            return
        proc.send_signal(signal.SIGKILL)
        killed_at = time.monotonic()
        self._killed.append(proc)
        with contextlib.suppress(subprocess.TimeoutExpired):  # SIGKILL cannot be ignored
            proc.wait(5.0)
        rec["killed"] = self._stamp(proc.pid, sim_ns, killed_at)
        if fault.kind == "plant_kill":
            self.plant_killed = True
            self._plant_killed_at = killed_at
            rec["outcome"] = "plant killed"
        elif fault.restart_after_s is not None:
            self._restarts.append((killed_at + fault.restart_after_s, fault))
            rec["outcome"] = "controller killed; restart pending"
        else:
            rec["outcome"] = "controller killed, not restarted (no restart_after_s)"
        console.print(
            f"[yellow]process fault[/] {fault.label} {fault.kind}: SIGKILL {name} "
            f"(pid {proc.pid}) at {sim_ns / 1e9:.3f} s simulated, "
            f"{rec['killed']['wall_s']:.2f} s wall"
            + (
                f"; restart in {fault.restart_after_s:g} s"
                if fault.restart_after_s is not None
                else ""
            )
        )

    def _restart(
        self,
        fault: ProcessFault,
        procs: dict[str, subprocess.Popen[bytes]],
        start: Callable[[str], subprocess.Popen[bytes]],
        console: Console,
    ) -> None:
        rec = self._by_index[fault.index]
        if procs["plant"].poll() is not None:
            rec["outcome"] = "controller killed; not restarted: the plant had ended"
            return
        try:
            proc = start(fault.process)
        except OSError as exc:
            raise RunFailedError(f"{fault.label}: restarting the controller failed: {exc}") from exc
        with self._lock:
            sim_ns = self._sim_ns
        rec["restarted"] = self._stamp(proc.pid, sim_ns, time.monotonic())
        rec["outcome"] = "controller killed and restarted"
        console.print(
            f"[yellow]process fault[/] {fault.label} controller_kill: controller restarted "
            f"(pid {proc.pid}) at {sim_ns / 1e9:.3f} s simulated, "
            f"{rec['restarted']['wall_s']:.2f} s wall"
        )

    def wait_for_others(self, procs: dict[str, subprocess.Popen[bytes]], console: Console) -> None:
        """After a ``plant_kill``: wait for the controller and the recorder to exit by
        themselves (:data:`PLANT_KILL_EXIT_TIMEOUT_S`), record how, terminate a laggard.

        A process that does not exit in time, or exits with a nonzero status, is a problem
        (:attr:`problems`); a controller already killed by a ``controller_kill`` and not
        restarted is left out.
        """
        killed_at = self._plant_killed_at if self._plant_killed_at is not None else time.monotonic()
        waiting = {n: procs[n] for n in ("controller", "recorder") if not self.expected(procs[n])}
        exits: dict[str, dict[str, Any]] = {}
        while waiting:
            now = time.monotonic()
            for name, proc in list(waiting.items()):
                rc = proc.poll()
                if rc is not None:
                    exits[name] = {
                        "exit_code": rc,
                        "exited_after_s": round(now - killed_at, 3),
                        "by_itself": True,
                    }
                    del waiting[name]
                elif now - killed_at > PLANT_KILL_EXIT_TIMEOUT_S[name]:
                    proc.terminate()
                    try:
                        proc.wait(5.0)
                    except subprocess.TimeoutExpired:
                        proc.kill()
                        proc.wait(5.0)
                    exits[name] = {
                        "exit_code": proc.returncode,
                        "exited_after_s": None,
                        "by_itself": False,
                    }
                    del waiting[name]
            time.sleep(0.02)
        for name, e in exits.items():
            if not e["by_itself"]:
                self.problems.append(
                    f"{name} did not exit by itself within "
                    f"{PLANT_KILL_EXIT_TIMEOUT_S[name]:g} s of the plant's kill (terminated)"
                )
            elif e["exit_code"] != 0:
                self.problems.append(
                    f"{name} exited with {e['exit_code']} after the plant's kill; see its log"
                )
            else:
                console.print(
                    f"[yellow]process fault[/] plant_kill: {name} exited by itself "
                    f"{e['exited_after_s']:.2f} s after the plant's kill"
                )
        for rec in self.records:
            if rec["kind"] == "plant_kill" and rec["killed"] is not None:
                rec["others"] = exits

    def finish(self, console: Console, how: str | None = None) -> None:
        """Close the records at the end of the run (faults and restarts never reached, the
        plant's safe state around each controller kill); ``how`` the run ended, if not by
        itself (e.g. ``aborted by SIGTERM``)."""
        with self._lock:
            sim_ns = self._sim_ns
            changes = list(self._safe_changes)
        ended = how or ("plant killed" if self.plant_killed else "run complete")
        for f in self._pending:
            self._by_index[f.index]["outcome"] = (
                f"not injected: the run ended ({ended}) at {sim_ns / 1e9:.3f} s simulated, "
                f"before start_s = {f.start_s:g} s"
            )
        for _, f in self._restarts:
            self._by_index[f.index]["outcome"] = (
                "controller killed; not restarted: the run ended before the restart was due"
            )
        self._pending, self._restarts = [], []
        for rec in self.records:
            if rec["kind"] != "controller_kill" or rec["killed"] is None:
                continue
            kill_ns = round(rec["killed"]["sim_s"] * 1e9) - self.period_ns
            entered = next((t for t, on in changes if on and t >= kill_ns), None)
            left = (
                next((t for t, on in changes if not on and t > entered), None)
                if entered is not None
                else None
            )
            rec["plant_safe_state"] = {
                "entered_sim_s": None if entered is None else round(entered / 1e9, 3),
                "left_sim_s": None if left is None else round(left / 1e9, 3),
            }

    def render(self, console: Console) -> None:
        """Print the records as a table, and the problems."""
        table = Table(title="Process faults")
        table.add_column("fault")
        table.add_column("kind", overflow="fold")
        table.add_column("killed (sim s / wall s)")
        table.add_column("restarted (sim s / wall s)")
        table.add_column("outcome", ratio=1)

        def when(stamp: dict[str, Any] | None) -> str:
            return "-" if stamp is None else f"{stamp['sim_s']:.3f} / {stamp['wall_s']:.2f}"

        for rec in self.records:
            outcome = rec["outcome"]
            safe = rec.get("plant_safe_state")
            if safe is not None:
                if safe["entered_sim_s"] is None:
                    outcome += "; plant safe state not entered"
                else:
                    left = safe["left_sim_s"]
                    outcome += f"; plant safe state from {safe['entered_sim_s']} s " + (
                        "to the end" if left is None else f"to {left} s"
                    )
            for name, e in rec.get("others", {}).items():
                outcome += (
                    f"; {name} exited by itself ({e['exit_code']}) after {e['exited_after_s']} s"
                    if e["by_itself"]
                    else f"; {name} terminated"
                )
            table.add_row(
                rec["fault"], rec["kind"], when(rec["killed"]), when(rec["restarted"]), outcome
            )
        console.print(table)
        for problem in self.problems:
            console.print(f"[red]process fault problem:[/] {escape(problem)}")
