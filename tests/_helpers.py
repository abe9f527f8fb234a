"""Helpers shared by several test modules.

Imported as ``from _helpers import ...``: pytest puts ``tests/`` on ``sys.path`` (no package).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Any

import msgspec

from bus_schemas import ActuatorCommand, CycleTiming, PlantState, SensorFrame, TimingSummary
from bus_schemas.auth import KEY_FILE_NAME, create_key_file
from bus_schemas.registry import SENSORS, TRUTH, MessageType
from hil.inprocess.run import run_inprocess
from hil.nodes.bus import free_tcp_endpoint
from hil.nodes.controller_node import ControllerRuntime
from hil.nodes.plant_node import PlantRunResult
from hil.scenario.schema import Scenario

REPO = Path(__file__).resolve().parent.parent

#: The smallest floating scenario (TOML): the IEA 15 MW on the VolturnUS-S, steady 10 m/s
#: wind, every other section as defaulted.
STEADY_FLOATING_SCENARIO = """
name = "t"
turbine = "iea15mw"
platform = "iea15mw_volturnus"
[wind]
kind = "steady"
speed_m_s = 10.0
"""


def python_child(
    code: str, *args: str, check: bool = False, timeout: float = 300.0
) -> subprocess.CompletedProcess[str]:
    """``python -c code args`` in a fresh interpreter on the repository, its output as text
    (a clean environment: the repository on ``PYTHONPATH``, the system's ``PATH``)."""
    return subprocess.run(
        [sys.executable, "-c", code, *args],
        check=check,
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=REPO,
        env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin", "COLUMNS": "120"},
    )


def fowt(
    *args: str,
    timeout: float | None = 180.0,
    cwd: Path | None = None,
    columns: int | None = None,
) -> subprocess.CompletedProcess[str]:
    """The ``fowt`` CLI (``python -m hil ARGS``) in a child process, its output captured.

    The exit code is left to the caller (tests check it). The checkout leads
    ``PYTHONPATH``, so ``cwd`` may be any folder; ``columns`` sets the terminal width rich
    wraps at (None: the environment's).
    """
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
    }
    if columns is not None:
        env["COLUMNS"] = str(columns)
    return subprocess.run(
        [sys.executable, "-m", "hil", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
        env=env,
        cwd=cwd,
    )


def fowt_forked(
    cases: list[tuple[list[str], Path]], *, columns: int = 80, timeout: float = 900.0
) -> list[subprocess.CompletedProcess[str]]:
    """Many ``fowt`` commands, each in its own process forked from one interpreter.

    ``cases``: (arguments, working folder). One ``python tests/_fowt_forked.py`` imports
    the CLI once and forks a child per case that runs the ``fowt`` entry point in that
    folder with its own exit code and streams (``tests/_fowt_forked.py``); the results come
    back as :func:`fowt`'s would. For the many commands that stop at validation, where the
    interpreter's start was nearly all of each command's cost.
    """
    import json
    import tempfile

    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
    }
    with tempfile.TemporaryDirectory(prefix="fowt-forked-") as tmp:
        spec = {
            "columns": columns,
            "cases": [
                {"args": args, "cwd": str(cwd), "out": f"{tmp}/{i}.out", "err": f"{tmp}/{i}.err"}
                for i, (args, cwd) in enumerate(cases)
            ],
        }
        proc = subprocess.run(
            [sys.executable, str(REPO / "tests" / "_fowt_forked.py")],
            input=json.dumps(spec),
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
            env=env,
        )
        assert proc.returncode == 0, proc.stderr
        codes = json.loads(proc.stdout)
        assert len(codes) == len(cases), proc.stdout
        return [
            subprocess.CompletedProcess(
                ["fowt", *args],
                code,
                Path(f"{tmp}/{i}.out").read_text(errors="replace"),
                Path(f"{tmp}/{i}.err").read_text(errors="replace"),
            )
            for i, ((args, _), code) in enumerate(zip(cases, codes, strict=True))
        ]


def can_netns_skip_reason() -> str | None:
    """Why a CAN run (python-can's ``udp_multicast`` bus inside a private network namespace,
    so that nothing leaves the machine) cannot run here, or None."""
    if not sys.platform.startswith("linux"):
        return "network namespaces are Linux only"
    if os.geteuid() != 0:
        return "not root: creating a network namespace (unshare -n) for udp_multicast needs root"
    for tool in ("unshare", "ip"):
        if shutil.which(tool) is None:
            return f"{tool} not found: needed to create the private network namespace"
    if importlib.util.find_spec("msgpack") is None:
        return "msgpack not installed: python-can's udp_multicast bus needs it"
    return None


def two_endpoints() -> tuple[str, str]:
    """Two different free loopback endpoints: the plant's and the controller's listen."""
    plant_ep, ctrl_ep = free_tcp_endpoint(), free_tcp_endpoint()
    while ctrl_ep == plant_ep:
        ctrl_ep = free_tcp_endpoint()
    return plant_ep, ctrl_ep


def lockstep_node_cmds(
    scenario: str,
    duration_s: float,
    out: Path,
    endpoints: tuple[str, str],
    key: list[str],
    require: str = "controller,recorder",
) -> dict[str, list[str]]:
    """The commands of a lock-step run's nodes started by hand, in start order: the recorder
    (``out/run.mcap``) and the controller connect to the plant, which waits for ``require``.
    ``endpoints``: the plant's and the controller's listen; ``key``: :func:`key_file_args`."""
    plant_ep, ctrl_ep = endpoints

    def node(sub: str, *args: str) -> list[str]:
        return [sys.executable, "-m", "hil", sub, scenario, "--duration", str(duration_s),
                *args, *key]  # fmt: skip

    mcap = str(out / "run.mcap")
    return {
        "recorder": node("record", "--out", mcap, "--connect", plant_ep, "--connect", ctrl_ep),
        # announced once the recorder reaches it, as fowt run starts it (--await-recorder)
        "controller": node(
            "controller", "--listen", ctrl_ep, "--connect", plant_ep, "--await-recorder", "30"
        ),
        "plant": node("plant", "--listen", plant_ep, "--mode", "lockstep", "--require", require),
    }


class NodeProcesses:
    """Processes started by hand, each writing to ``<out>/<name>.log`` (unbuffered); as a
    context manager, every one still running at its end is killed."""

    def __init__(self, out: Path) -> None:
        self.out = out
        self.procs: dict[str, subprocess.Popen[bytes]] = {}
        self._files: list[Any] = []

    def start(self, name: str, cmd: list[str]) -> subprocess.Popen[bytes]:
        fh = open(self.out / f"{name}.log", "wb")  # noqa: SIM115 - closed in __exit__
        self._files.append(fh)
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        self.procs[name] = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, env=env)
        return self.procs[name]

    def wait(self, timeout: float) -> dict[str, int]:
        """Every process's exit code (each waited for up to ``timeout`` s)."""
        return {name: p.wait(timeout=timeout) for name, p in self.procs.items()}

    def logs(self) -> dict[str, str]:
        return {name: (self.out / f"{name}.log").read_text() for name in self.procs}

    def __enter__(self) -> NodeProcesses:
        return self

    def __exit__(
        self, _t: type[BaseException] | None, _e: BaseException | None, _tb: TracebackType | None
    ) -> None:
        for p in self.procs.values():
            if p.poll() is None:
                p.kill()
                p.wait(10)
        for fh in self._files:
            fh.close()


def key_file_args(folder: Path) -> list[str]:
    """``--key-file <folder>/run.key`` for nodes started by hand (the file made once, 0600)."""
    path = folder / KEY_FILE_NAME
    if not path.exists():
        create_key_file(path)
    return ["--key-file", str(path)]


def run_collecting(
    scenario: Scenario,
    answer: Callable[[SensorFrame, ActuatorCommand | None], ActuatorCommand | None] | None = None,
) -> tuple[PlantRunResult, dict[str, list[Any]]]:
    """Run ``scenario`` in process with its controller; collect every message by key suffix.

    ``answer(frame, command)`` may replace the controller's command (e.g. return None to
    simulate a missed deadline). Returns the run result and ``{suffix: [messages]}``.
    """
    log: dict[str, list[Any]] = defaultdict(list)

    def publish(mt: MessageType, msg: msgspec.Struct) -> None:
        log[mt.key_suffix].append(msg)

    runtime = ControllerRuntime(scenario)

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        result = runtime.handle_frame(frame)
        command = None if result is None else result[0]
        return command if answer is None else answer(frame, command)

    return run_inprocess(scenario, publish, step), log


def run_closed_loop(
    scenario: Scenario,
) -> tuple[PlantRunResult, list[PlantState], list[SensorFrame]]:
    """Run ``scenario`` in process with its controller; collect the truth and the sensor frames.

    Checks that every cycle ran; returns the run result (for its timing) and the messages.
    """
    result, log = run_collecting(scenario)
    assert result.cycles == scenario.cycles
    truth, frames = log[TRUTH.key_suffix], log[SENSORS.key_suffix]
    assert all(isinstance(m, PlantState) for m in truth)
    assert all(isinstance(m, SensorFrame) for m in frames)
    return result, truth, frames


def sensor_frame(
    generator_speed_rad_s: float,
    blade_pitch_rad: float = 0.0,
    generator_torque_nm: float = 0.0,
    *,
    seq: int = 0,
    valid_mask: int = 0,
) -> SensorFrame:
    """A sensor frame with the turbine readings given and every other reading 0.

    ``seq`` is also the frame's sample and publish time (ns).
    """
    return SensorFrame(
        seq=seq,
        sample_time_ns=seq,
        publish_time_ns=seq,
        valid_mask=valid_mask,
        generator_speed_measured_rad_s=generator_speed_rad_s,
        rotor_speed_measured_rad_s=0.0,
        blade_pitch_measured_rad=blade_pitch_rad,
        generator_torque_measured_nm=generator_torque_nm,
        electrical_power_measured_w=0.0,
        wind_speed_measured_m_s=0.0,
        nacelle_acc_fore_aft_measured_m_s2=0.0,
        platform_pitch_measured_rad=0.0,
        platform_pitch_rate_measured_rad_s=0.0,
        platform_surge_measured_m=0.0,
        wave_elevation_gauge_measured_m=0.0,
    )


def plant_report(cycles: int, sample_time_ns: int, **published: int) -> Any:
    """A plant's final :class:`~bus_schemas.messages.PlantReport` of a clean run of ``cycles``.

    Every per-cycle channel counts ``cycles``, one final summary, no rejection; ``published``
    overrides a count (e.g. ``cycle_records_published=0`` for a log without cycle records).
    """
    from bus_schemas.messages import PLANT_REJECT_REASONS, PlantReport, rejection_fields

    counts = {
        "sensor_frames_published": cycles,
        "truth_published": cycles,
        "cycle_records_published": cycles,
        "summaries_published": 1,
        "previews_published": 0,
        "commands_applied": cycles,
        **published,
    }
    return PlantReport(
        seq=0,
        sample_time_ns=sample_time_ns,
        publish_time_ns=0,
        final=1,
        aborted=0,
        cycles=cycles,
        **counts,
        **rejection_fields({}, "commands_rejected", PLANT_REJECT_REASONS),
    )


def controller_report(cycles: int, sample_time_ns: int, **published: int) -> Any:
    """A controller's final :class:`~bus_schemas.messages.ControllerReport` of a clean run:
    ``cycles`` frames stepped on, as many commands and statuses (``published`` overrides)."""
    from bus_schemas.messages import CONTROLLER_REJECT_REASONS, ControllerReport, rejection_fields

    counts = {"commands_published": cycles, "statuses_published": cycles, **published}
    return ControllerReport(
        seq=0,
        sample_time_ns=sample_time_ns,
        publish_time_ns=0,
        final=1,
        aborted=0,
        frames_accepted=cycles,
        safe_mode=0,
        safe_mode_entries=0,
        safe_mode_commands=0,
        safe_mode_first_entry_ns=0,
        frames_missing=0,
        frames_stale=0,
        **counts,
        **rejection_fields({}, "frames_rejected", CONTROLLER_REJECT_REASONS),
    )


def cycle_timing(seq: int, sample_time_ns: int, **fields: int) -> CycleTiming:
    """A cycle's timing record for a synthetic log: published at its sample time, every count
    and duration 0, but ``fields``."""
    base = {
        "seq": seq,
        "sample_time_ns": sample_time_ns,
        "publish_time_ns": sample_time_ns,
        "latency_ns": 0,
        "deadline_missed": 0,
        "command_held": 0,
        "safe_state": 0,
        "plant_compute_ns": 0,
        "tick_lateness_ns": 0,
    }
    return CycleTiming(**(base | fields))


def timing_summary(cycles: int, sample_time_ns: int, **fields: Any) -> TimingSummary:
    """The plant's final timing summary of ``cycles`` cycles for a synthetic log: every count
    0, latencies 0.0 us, speed 1.0, published at 0, but ``fields``."""
    base: dict[str, Any] = {
        "seq": 0,
        "sample_time_ns": sample_time_ns,
        "publish_time_ns": 0,
        "cycles": cycles,
        "deadline_misses": 0,
        "commands_held": 0,
        "commands_rejected": 0,
        "commands_late": 0,
        "safe_state": 0,
        "safe_state_cycles": 0,
        "faults_injected": 0,
        "final": 1,
        "latency_p50_us": 0.0,
        "latency_p99_us": 0.0,
        "latency_p999_us": 0.0,
        "latency_max_us": 0.0,
        "sim_seconds_per_wall_second": 1.0,
    }
    return TimingSummary(**(base | fields))
