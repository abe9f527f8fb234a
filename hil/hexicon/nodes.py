"""Plant, controller and recorder processes of the Hexicon H3 family over Zenoh.

Three OS processes, started, followed and stopped by the bench's one launcher
(``fowt run hexicon-<name>``: :mod:`hil.launch`, :mod:`hil.families`, which takes their
command lines from :func:`node_commands`): the plant (``python -m hil.hexicon.nodes plant``)
listens on its endpoint, the controller (``... controller``) listens on its own and connects
to the plant, and the recorder (``... record``) connects to both and writes every message to
an MCAP file (:func:`run_recorder_node`). With the run's key (``--key-file``) every payload
is signed and checked (docs/security.md). Keys::

    fowt/<platform>/platform              PlatformFrame (heading, yaw rate, met wind)
    fowt/<platform>/<turbine>/rotor       TurbineFrame (t1, t2, t3)
    fowt/<platform>/<turbine>/rotor/command  TurbineCommand (one controller commands all three)
    fowt/<platform>/platform/status       PlatformControllerStatus
    fowt/<platform>/platform/summary      the plant's account at its end (JSON)
    fowt/<platform>/alive/<node>          liveliness tokens

    fowt/<platform>/platform/truth        PlatformFrame of the true state (recorder only)
    fowt/<platform>/<turbine>/rotor/truth TurbineFrame of the true state (recorder only)

Modes: ``lockstep`` (the plant waits for the three commands answering each cycle; simulated
time runs as fast as the loop) and ``realtime`` (the plant ticks every control period on the
wall clock, from the publication of its first frame). In real time a cycle's deadline is one
control period after its frame was published: a cycle whose three commands did not all reach
the plant by then is a deadline miss, its command held (:func:`gather_commands`). This is
the latency the review's histogram shows (frame publication to the last of the three
commands), so a run whose latencies all stay under the period has no miss; the plant's own
work before it publishes a frame (the first cycle's model evaluation) is not the
controller's time. The plant's running count goes out on :func:`progress_key` each cycle
(the launcher's progress bar).

Sensors: the frames carry the preset's sensor channels (:mod:`plant.hexicon.sensors`,
seeded); the truth goes on the ``.../truth`` keys, which only the recorder subscribes to.
The controller subscribes to the four measured keys by name, so it cannot see the truth.

Transport: ``zenoh`` (default) or ``can``: with ``can`` the three frames and the commands
travel as CAN frames (``bus_schemas/fowt.dbc``: TurbineFrame 0x140, PlatformFrame 0x160,
TurbineCommand 0x110, the turbine index in the payload) on a python-can bus
(:class:`hil.nodes.can_bus.CanBus`); truth, status and liveliness stay on the loopback Zenoh
session. ``udp_multicast`` between processes runs in a private network namespace (the
launcher re-runs itself under ``unshare --net``, for either family).

Ending: the plant's final frame (``final`` = 1) ends the controller; the plant's account
(:func:`summary_key`) ends the recorder once the last status is in. SIGTERM (the launcher
stopping a run) ends the plant's loop at the next cycle with its account as usual, and
makes the recorder finish its file.

Identification (``--controller prbs``): the plant's wind is the PRBS wind of a table-5
experiment (:func:`controller.design.hexicon_identify.experiment_wind`) and the controller
process is the PRBS pitch excitation (:class:`controller.hexicon.PrbsExcitation`).
"""

from __future__ import annotations

import argparse
import json
import math
import queue
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any

import msgspec

from bus_schemas.messages import (
    PlatformControllerStatus,
    PlatformFrame,
    TurbineCommand,
    TurbineFrame,
)
from bus_schemas.registry import (
    BY_SUFFIX,
    KEY_PREFIX,
    PLATFORM_FRAME,
    PLATFORM_MESSAGES,
    PLATFORM_STATUS,
    TURBINE_COMMAND,
    TURBINE_FRAME,
    DecodeError,
    MessageType,
)
from controller.hexicon import (
    HexiconCommand,
    HexiconMeasurement,
    PrbsExcitation,
    load_design,
    make_prbs,
    prbs_step,
)
from hil.hexicon.model import (
    ControllerCore,
    HexiconScenario,
    initial_state,
    load_scenarios,
    make_sensors,
    plant_input,
    truth_sample,
)
from hil.nodes.bus import LINK_TIMEOUT_S, Bus, BusConfig, wait_matched
from hil.nodes.rt import set_realtime_priority
from hil.nodes.signals import on_stop_signals
from hil.runlog.mcap_io import RunLog, read_run
from plant.hexicon.environment import SampledWind
from plant.hexicon.model import outputs, step_rk4, torque_law_nm

TURBINES = ("t1", "t2", "t3")
#: How long the plant waits for its peers to appear (s). A node's start (interpreter, numba
#: kernels from the cache, Zenoh session) took more than 30 s on a 2-core machine under a load
#: average of ~25; a peer that never comes still fails the run, only later.
_STARTUP_TIMEOUT_S = 120.0
#: PlatformControllerStatus.controller codes.
CONTROLLER_CODES = {"bang_bang": 0, "mpc": 1, "mpc_id": 2, "prbs": 3}
#: Controllers a node runs (``prbs``: the identification excitation).
NODE_CONTROLLERS = tuple(CONTROLLER_CODES)
TRUTH = "truth"
#: The MCAP metadata record of a platform run (the launcher's ``family`` key among them).
RUN_METADATA = "hexicon_run"
_CAN_TYPES = (TURBINE_FRAME, PLATFORM_FRAME, TURBINE_COMMAND)


def truth_key(mt: MessageType, ident: str) -> str:
    """``fowt/<ident>/<suffix>/truth``: the true-state twin of a frame key."""
    return f"{mt.key(ident)}/{TRUTH}"


class PlatformLink:
    """A node's bus: Zenoh for everything, or the frames and commands on CAN (module docs).

    Parameters
    ----------
    zenoh : BusConfig
        The node's loopback Zenoh endpoints.
    can : dict or None
        ``{"interface", "channel", "fd"}`` of the CAN bus, None for Zenoh only.
    platform : str
        The platform id of the keys.
    """

    def __init__(self, zenoh: BusConfig, can: dict[str, Any] | None, platform: str) -> None:
        self.platform = platform
        self.can: Any = None
        if can is not None:
            from hil.nodes.can_bus import CanBus, CanBusConfig  # noqa: PLC0415 - CAN runs only

            cfg = CanBusConfig.for_interface(
                can["interface"], can.get("channel") or None, bool(can.get("fd")), platform
            )
            self.can = CanBus(cfg)
        try:
            self.zenoh = Bus(zenoh)
        except BaseException:
            if self.can is not None:
                self.can.close()
            raise

    @property
    def session(self) -> Any:
        return self.zenoh.session

    def publish(self, mt: MessageType, ident: str, msg: msgspec.Struct) -> None:
        """Send ``msg`` on ``mt.key(ident)`` (CAN when it is a CAN message of a CAN run)."""
        if self.can is not None and mt in _CAN_TYPES:
            self.can.publish(mt, msg)
        else:
            self.zenoh.put(mt.key(ident), mt.codec.encode(msg))

    def put_truth(self, mt: MessageType, ident: str, msg: msgspec.Struct) -> None:
        self.zenoh.put(truth_key(mt, ident), mt.codec.encode(msg))

    def subscribe(self, mt: MessageType, idents: tuple[str, ...], cb: Any) -> None:
        """``cb(key, message)`` for ``mt`` of each ident (on CAN: the turbine index names it)."""
        if self.can is not None and mt in _CAN_TYPES:

            def deliver(msg: Any) -> None:
                ident = (
                    f"{self.platform}/t{msg.turbine_index}"
                    if hasattr(msg, "turbine_index")
                    else self.platform
                )
                cb(mt.key(ident), msg)

            self.can.subscribe_message(mt, deliver)
            return
        for ident in idents:

            def on_payload(key: str, payload: bytes, mt: MessageType = mt) -> None:
                try:
                    msg = mt.codec.decode(payload)
                except DecodeError:
                    cb(key, None)
                    return
                cb(key, msg)

            # a payload failing the run's authentication counts as a rejected one
            key = mt.key(ident)

            def on_reject(_exc: Exception, key: str = key) -> None:
                cb(key, None)

            self.zenoh.subscribe(key, on_payload, on_reject)

    def can_rejected(self) -> int:
        return int(sum(self.can.rejected.values())) if self.can is not None else 0

    def close(self) -> None:
        try:
            self.zenoh.close()
        finally:
            if self.can is not None:
                self.can.close()


def _wait_for_peers(
    bus: Any,
    platform: str,
    names: tuple[str, ...],
    timeout_s: float,
    stop: threading.Event | None = None,
) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and not (stop is not None and stop.is_set()):
        seen = set()
        for reply in bus.session.liveliness().get(f"{KEY_PREFIX}/{platform}/alive/*"):
            ok = getattr(reply, "ok", None)
            if ok is not None:
                seen.add(str(ok.key_expr).rsplit("/", 1)[-1])
        if all(n in seen for n in names):
            return
        time.sleep(0.05)
    if stop is not None and stop.is_set():
        return
    raise TimeoutError(f"peers {names} did not appear within {timeout_s} s")


def identification_scenario(
    experiment: int, samples: int, seed: int = 0, base: str = "s1_step15"
) -> tuple[HexiconScenario, SampledWind]:
    """The scenario (nominal platform, 1 s period) and PRBS wind of a table-5 experiment
    (``experiment`` 1-based) of ``samples`` control periods."""
    from controller.design.hexicon_identify import experiment_wind  # noqa: PLC0415

    scn = load_scenarios()[base]
    speeds, dirs = experiment_wind(experiment - 1, samples, seed)
    return scn, SampledWind(tuple(speeds), tuple(dirs), scn.control_period_s)


# ------------------------------------------------------------------------------ plant
def gather_commands(
    commands: queue.SimpleQueue[tuple[int, TurbineCommand]],
    seq: int,
    deadline_ns: int,
    clock: Any = time.monotonic_ns,
) -> tuple[dict[int, TurbineCommand], int]:
    """The commands answering frame ``seq`` that reached the plant by ``deadline_ns``.

    Waits on ``commands`` (``(arrival_ns, command)`` pairs, stamped on arrival) until the
    three turbines' commands are in or the deadline passes; once it has passed, what already
    arrived is still taken, judged by its arrival stamp, so a plant that looks late does not
    count a command that came in time as missed. Commands answering an earlier frame came
    after that frame's cycle closed: dropped, and counted as late.

    Parameters
    ----------
    commands : queue.SimpleQueue
        The plant's inbox: ``(arrival_ns, TurbineCommand)`` [ns, CLOCK_MONOTONIC].
    seq : int
        The frame the commands must answer.
    deadline_ns : int
        The cycle's deadline [ns, CLOCK_MONOTONIC]: its frame's publication + the period.
    clock : callable
        ``() -> ns`` on the same clock (tests give their own).

    Returns
    -------
    got : dict of int to TurbineCommand
        Turbine index (1-3) -> its command in time; fewer than 3: a deadline miss.
    late : int
        Commands taken that came after their cycle's deadline (this frame's, or an earlier
        one's).
    """
    got: dict[int, TurbineCommand] = {}
    late = 0
    while len(got) < 3:
        remaining_s = (deadline_ns - clock()) / 1e9
        try:
            if remaining_s > 0:
                arrival_ns, c = commands.get(timeout=remaining_s)
            else:
                arrival_ns, c = commands.get_nowait()
        except queue.Empty:
            break
        if c.answered_seq != seq or arrival_ns > deadline_ns:
            late += 1
            continue
        got[c.turbine_index] = c
    return got, late


def progress_key(platform: str) -> str:
    """``fowt/<platform>/platform/progress``: the plant's running account after each cycle
    (JSON ``{"sim_s", "deadline_misses"}``), which the launcher's progress bar shows."""
    return f"{KEY_PREFIX}/{platform}/platform/progress"


def run_plant_node(
    scenario: str,
    platform: str,
    listen: str,
    mode: str,
    duration_s: float | None,
    *,
    noise: bool = True,
    experiment: int = 0,
    seed: int = 0,
    can: dict[str, Any] | None = None,
    auth_key: bytes | None = None,
) -> int:
    """The plant process: publish frames each period, integrate with the answering commands.

    ``experiment`` > 0: the PRBS wind of that table-5 experiment (``duration_s`` samples).
    SIGTERM ends the loop at the next cycle; the plant's account (cycles, deadline misses,
    held and rejected commands, ``stopped``) then goes out on :func:`summary_key` as at a
    normal end, which ends the controller and the recorder.
    """

    if experiment:
        n_id = round(duration_s or 3000.0)
        scn, wind_any = identification_scenario(experiment, n_id, seed)
        wind: Any = wind_any
        duration_s = float(n_id) * scn.control_period_s
    else:
        scn = load_scenarios()[scenario]
        wind = scn.wind
    p = scn.params()
    sensors = make_sensors(scn, noise)
    bus = PlatformLink(BusConfig(listen=(listen,), auth_key=auth_key), can, platform)
    stop = _stop_on_sigterm()
    token = bus.session.liveliness().declare_token(f"{KEY_PREFIX}/{platform}/alive/plant")
    commands: queue.SimpleQueue[tuple[int, TurbineCommand]] = queue.SimpleQueue()
    rejected = 0

    def on_cmd(_key: str, msg: Any) -> None:
        nonlocal rejected
        if msg is None:
            rejected += 1
        else:
            commands.put((time.monotonic_ns(), msg))

    bus.subscribe(TURBINE_COMMAND, tuple(f"{platform}/{t}" for t in TURBINES), on_cmd)
    try:
        _wait_for_peers(bus, platform, ("controller", "recorder"), _STARTUP_TIMEOUT_S, stop)
        time.sleep(0.2)  # let the subscribers' declarations propagate
        x = initial_state(p, wind.speed_m_s(0.0))
        q0 = [torque_law_nm(p.turbine, w) for w in (x[2], x[5], x[8])]
        cmd = HexiconCommand((x[3], x[6], x[9]), (q0[0], q0[1], q0[2]))
        n = round((duration_s or scn.duration_s) / scn.control_period_s)
        period_ns = round(scn.control_period_s * 1e9)
        misses = held = late = 0
        stopped = False
        t0 = 0  # the wall clock of the run: set when frame 0 goes out
        for k in range(n + 1):
            if stop.is_set():
                stopped = True
                break
            t = k * scn.control_period_s
            v, b = wind.speed_m_s(t), wind.direction_rad(t)
            out = outputs(t, x, plant_input(cmd, v, b), p)
            truth = truth_sample(x, v, b, out.powers_w, out.rotor_winds_m_s)
            meas = sensors.measure(k * period_ns, truth)
            now = time.monotonic_ns()
            if k == 0:
                t0 = now
            for i, name in enumerate(TURBINES):
                for s, sink in ((meas, bus.publish), (truth, bus.put_truth)):
                    tu = s.turbines[i]
                    fr = TurbineFrame(
                        seq=k,
                        sample_time_ns=k * period_ns,
                        publish_time_ns=now,
                        turbine_index=i + 1,
                        rotor_speed_measured_rad_s=tu["rotor_speed"],
                        blade_pitch_measured_rad=tu["pitch"],
                        generator_torque_measured_nm=x[4 + 3 * i],
                        electrical_power_measured_w=tu["power"],
                        wind_speed_measured_m_s=tu["nacelle_wind"],
                    )
                    sink(TURBINE_FRAME, f"{platform}/{name}", fr)
            for s, sink in ((truth, bus.put_truth), (meas, bus.publish)):
                pl = s.platform
                pf = PlatformFrame(
                    seq=k,
                    sample_time_ns=k * period_ns,
                    publish_time_ns=now,
                    final=int(k == n),
                    platform_heading_measured_rad=pl["heading"],
                    platform_yaw_rate_measured_rad_s=pl["yaw_rate"],
                    wind_direction_measured_rad=pl["wind_direction"],
                    wind_speed_measured_m_s=pl["wind_speed"],
                    platform_power_w=sum(tu["power"] for tu in s.turbines),
                )
                sink(PLATFORM_FRAME, platform, pf)
            if k == n:
                break
            # The deadline runs from the frame's publication (`now`, just before it went out).
            deadline = now + (period_ns if mode == "realtime" else 10 * 10**9)
            got, late_k = gather_commands(commands, k, deadline)
            late += late_k
            if len(got) < 3:
                if mode != "realtime":
                    print(f"plant: no commands for cycle {k} within 10 s", file=sys.stderr)
                    return 2
                misses += 1
                held += 1
            else:
                cmd = HexiconCommand(
                    tuple(got[i].blade_pitch_commanded_rad for i in (1, 2, 3)),  # type: ignore[arg-type]
                    tuple(got[i].generator_torque_commanded_nm for i in (1, 2, 3)),  # type: ignore[arg-type]
                )
            for j in range(scn.steps_per_period):
                tj = t + j * scn.plant_dt_s
                x = step_rk4(
                    x,
                    plant_input(cmd, wind.speed_m_s(tj), wind.direction_rad(tj)),
                    scn.plant_dt_s,
                    p,
                )
            progress = {"sim_s": (k + 1) * scn.control_period_s, "deadline_misses": misses}
            bus.zenoh.put(progress_key(platform), json.dumps(progress).encode())
            if mode == "realtime":
                sleep_ns = t0 + (k + 1) * period_ns - time.monotonic_ns()
                if sleep_ns > 0:
                    time.sleep(sleep_ns / 1e9)
        account = json.dumps(
            {
                "plant_cycles": k if stopped else n,
                "deadline_misses": misses,
                "commands_held": held,
                "commands_late": late,
                "commands_rejected": rejected + bus.can_rejected(),
                "sensor_seed": sensors.seed,
                "sensor_noise": sensors.enabled,
                "stopped": stopped,
            }
        )
        print(account, flush=True)
        bus.zenoh.put(summary_key(platform), account.encode())
        time.sleep(0.3)
        return 0
    finally:
        token.undeclare()
        bus.close()


# ------------------------------------------------------------------------------ controller
def run_controller_node(
    controller: str,
    platform: str,
    listen: str,
    connect: str,
    period_s: float,
    *,
    experiment: int = 0,
    samples: int = 0,
    seed: int = 0,
    can: dict[str, Any] | None = None,
    identified: str | None = None,
    auth_key: bytes | None = None,
    await_recorder_s: float = 0.0,
) -> int:
    """The controller process: one core commanding the three turbines each cycle.

    It ends on the plant's final frame or its account (:func:`summary_key`: a plant stopped
    early). It subscribes to the measured keys only (never ``.../truth``). ``prbs``: the pitch
    excitation of table-5 experiment ``experiment`` (1-based) over ``samples`` cycles.
    ``identified``: the identified-model artefact of ``mpc_id`` (default: the shipped one).
    ``await_recorder_s`` > 0: its liveliness token (which the plant waits for) is declared
    once a recorder's subscription reaches its status key, or after that many seconds
    (:func:`hil.nodes.bus.wait_matched`; the launcher sets it).
    """

    design = load_design()
    core: ControllerCore | None = None
    prbs_state = None
    if controller == "prbs":
        from controller.design.hexicon_identify import TABLE5  # noqa: PLC0415

        if not 1 <= experiment <= len(TABLE5):
            raise ValueError(f"--experiment {experiment}: expected 1..{len(TABLE5)}")
        lo, hi = TABLE5[experiment - 1][2]
        prbs_state = make_prbs(PrbsExcitation(lo, hi, max(samples, 1), experiment - 1, seed))
    else:
        model = None
        if controller == "mpc_id" and identified:
            from controller.hexicon import load_identified  # noqa: PLC0415

            model = load_identified(identified)
        core = ControllerCore(controller, design, period_s, model)
    bus = PlatformLink(
        BusConfig(listen=(listen,), connect=(connect,), auth_key=auth_key), can, platform
    )
    inbox: queue.SimpleQueue[tuple[str, Any]] = queue.SimpleQueue()

    def on_platform(_key: str, msg: Any) -> None:
        inbox.put(("platform", msg) if msg is not None else ("rejected", None))

    def on_turbine(_key: str, msg: Any) -> None:
        inbox.put(("turbine", msg) if msg is not None else ("rejected", None))

    bus.subscribe(PLATFORM_FRAME, (platform,), on_platform)
    bus.subscribe(TURBINE_FRAME, tuple(f"{platform}/{t}" for t in TURBINES), on_turbine)
    bus.zenoh.subscribe(summary_key(platform), lambda _k, _p: inbox.put(("end", None)))
    status_pub = bus.zenoh.publisher(PLATFORM_STATUS.key(platform))
    if await_recorder_s > 0 and not wait_matched(status_pub, await_recorder_s):
        print(
            f"controller: no recorder reached its status key within {await_recorder_s:g} s; "
            "announcing itself anyway",
            file=sys.stderr,
        )
    token = bus.session.liveliness().declare_token(f"{KEY_PREFIX}/{platform}/alive/controller")
    frames: dict[int, dict[str, Any]] = {}
    try:
        seq_out = 0
        while True:
            try:
                kind, msg = inbox.get(timeout=60.0)
            except queue.Empty:
                print("controller: no frames for 60 s", file=sys.stderr)
                return 2
            if kind == "end":
                return 0
            if kind == "rejected":
                continue
            slot = frames.setdefault(msg.seq, {})
            if kind == "platform":
                slot["p"] = msg
            else:
                slot[f"t{msg.turbine_index}"] = msg
            pf = slot.get("p")
            if pf is not None and pf.final:
                return 0
            if pf is None or not all(f"t{i}" in slot for i in (1, 2, 3)):
                continue
            del frames[msg.seq]
            t_start = time.perf_counter_ns()
            m = HexiconMeasurement(
                pf.platform_heading_measured_rad,
                pf.platform_yaw_rate_measured_rad_s,
                pf.wind_direction_measured_rad,
                pf.wind_speed_measured_m_s,
                (
                    slot["t1"].rotor_speed_measured_rad_s,
                    slot["t2"].rotor_speed_measured_rad_s,
                    slot["t3"].rotor_speed_measured_rad_s,
                ),
            )
            power_w = sum(slot[f"t{i}"].electrical_power_measured_w for i in (1, 2, 3))
            if core is not None:
                cmd = core.step(m, period_s, power_w)
                overruns, solve_s = core.overruns, core.last_solve_s
            else:
                assert prbs_state is not None
                prbs_state, cmd = prbs_step(prbs_state, m, design)
                overruns, solve_s = 0, 0.0
            now = time.monotonic_ns()
            for i, name in enumerate(TURBINES):
                tc = TurbineCommand(
                    seq=seq_out,
                    answered_seq=pf.seq,
                    sample_time_ns=pf.sample_time_ns,
                    publish_time_ns=now,
                    turbine_index=i + 1,
                    blade_pitch_commanded_rad=cmd.pitch_rad[i],
                    generator_torque_commanded_nm=cmd.torque_nm[i],
                )
                bus.publish(TURBINE_COMMAND, f"{platform}/{name}", tc)
            err = math.atan2(
                math.sin(m.wind_direction_rad - m.heading_rad),
                math.cos(m.wind_direction_rad - m.heading_rad),
            )
            st = PlatformControllerStatus(
                seq=seq_out,
                answered_seq=pf.seq,
                sample_time_ns=pf.sample_time_ns,
                publish_time_ns=time.monotonic_ns(),
                compute_time_ns=time.perf_counter_ns() - t_start,
                controller=CONTROLLER_CODES[controller],
                overruns=overruns,
                heading_error_rad=err,
                solve_time_s=solve_s,
            )
            bus.publish(PLATFORM_STATUS, platform, st)
            seq_out += 1
    finally:
        token.undeclare()
        bus.close()


# ------------------------------------------------------------------------------ recorder
class PlatformMcap:
    """A platform's run log: :class:`hil.runlog.mcap_io.RunLog` with one CDR channel per key of
    the platform (per-turbine and truth keys). ``log_time`` is the message's simulated
    ``sample_time_ns`` itself (start 0); sequence numbers count per channel."""

    def __init__(self, path: Path, platform: str) -> None:
        self._log = RunLog(path, None, start_unix_ns=0, profile="", library="fowt-hil hexicon")
        for mt in PLATFORM_MESSAGES:
            per_turbine = mt in (TURBINE_FRAME, TURBINE_COMMAND)
            for ident in [f"{platform}/{t}" for t in TURBINES] if per_turbine else [platform]:
                self._log.add_channel(mt.key(ident), mt)
                if mt in (TURBINE_FRAME, PLATFORM_FRAME):
                    self._log.add_channel(truth_key(mt, ident), mt)

    @property
    def count(self) -> int:
        """Messages written so far."""
        return self._log.count

    def write(self, key: str, msg: Any) -> None:
        """Write one message under its key (a key of no channel is ignored)."""
        if self._log.channel_for(key) is not None:
            self._log.write(key, msg)

    def close(self, metadata: dict[str, str]) -> None:
        """Add the run's metadata, finish the file."""
        self._log.add_metadata(RUN_METADATA, metadata)
        self._log.close()


def summary_key(platform: str) -> str:
    """``fowt/<platform>/platform/summary``: the plant's end-of-run account (JSON object:
    ``plant_cycles``, ``deadline_misses``, ``commands_held``, ``commands_late`` (commands
    that came after their cycle's deadline), ``commands_rejected``, ``sensor_seed``,
    ``sensor_noise``, ``stopped``); the recorder stores it in the file's
    metadata, the controller ends on it."""
    return f"{KEY_PREFIX}/{platform}/platform/summary"


def _stop_on_sigterm() -> threading.Event:
    """An event set by SIGTERM (the launcher stopping the run), in the main thread only."""
    stop = threading.Event()
    if threading.current_thread() is threading.main_thread():
        on_stop_signals(lambda _signum: stop.set(), (signal.SIGTERM,))
    return stop


#: After the plant's account, how long the recorder waits for the last statuses (s of quiet).
_END_QUIET_S = 2.0


def run_recorder_node(
    out: Path,
    platform: str,
    connect: tuple[str, ...],
    metadata: dict[str, str],
    *,
    can: dict[str, Any] | None = None,
    auth_key: bytes | None = None,
) -> int:
    """The recorder process: every message of the platform into ``out`` (:class:`PlatformMcap`).

    It connects to the plant and the controller, announces itself once the controller is seen
    on its session (the commands reach it only over that link), and records until the plant's
    account (:func:`summary_key`) is in and the controller's status answering the last cycle
    (or :data:`_END_QUIET_S` without a message), or until SIGTERM. The file's
    ``hexicon_run`` metadata: ``metadata`` (the launcher's: family, scenario, controller,
    mode, ...), the plant's account, ``records``, ``recorder_rejected``, ``final_seen``
    (the plant's final measured frame was recorded) and, on CAN, ``can_frames_received`` and
    ``can_rejected``.
    """
    log = PlatformMcap(out, platform)
    q: queue.SimpleQueue[tuple[str, Any]] = queue.SimpleQueue()
    skey = summary_key(platform)
    rejected = 0
    stop = _stop_on_sigterm()

    def on_sample(key: str, payload: bytes) -> None:
        nonlocal rejected
        if key == skey:
            try:
                q.put((key, json.loads(payload)))
            except ValueError:
                rejected += 1
            return
        parts = key.split("/")
        if "alive" in parts:
            return
        rest = parts[3:] if parts[2] in TURBINES else parts[2:]
        if rest and rest[-1] == TRUTH:
            rest = rest[:-1]
        mt = BY_SUFFIX.get("/".join(rest))
        if mt is None:
            return
        try:
            q.put((key, mt.codec.decode(payload)))
        except DecodeError:
            rejected += 1

    def on_reject(_exc: Exception) -> None:
        nonlocal rejected
        rejected += 1

    can_bus = None
    bus = None
    token = None
    account: dict[str, Any] = {}
    final = False
    try:
        if can is not None:
            from hil.nodes.can_bus import CanBus, CanBusConfig  # noqa: PLC0415 - CAN runs only

            can_bus = CanBus(
                CanBusConfig.for_interface(
                    can["interface"], can.get("channel") or None, bool(can.get("fd")), platform
                )
            )
            for mt in _CAN_TYPES:

                def deliver(msg: Any, mt: MessageType = mt) -> None:
                    ident = (
                        f"{platform}/t{msg.turbine_index}"
                        if hasattr(msg, "turbine_index")
                        else platform
                    )
                    q.put((mt.key(ident), msg))

                can_bus.subscribe_message(mt, deliver)
        bus = Bus(BusConfig(connect=connect, auth_key=auth_key))
        bus.subscribe(f"{KEY_PREFIX}/{platform}/**", on_sample, on_reject)
        # The plant starts when it sees this recorder's token, but the commands reach the
        # recorder only over its own link to the controller, which listens only once its
        # core is built: a first connect attempt before that fails and Zenoh retries it
        # seconds later, after a short lock-step run has ended (its commands unrecorded).
        # So the token is declared once the controller is seen on this session.
        _wait_for_peers(bus, platform, ("controller",), _STARTUP_TIMEOUT_S, stop)
        token = bus.session.liveliness().declare_token(f"{KEY_PREFIX}/{platform}/alive/recorder")
        last_status = -1
        quiet_since = time.monotonic()
        while True:
            try:
                key, msg = q.get(timeout=0.1)
            except queue.Empty:
                quiet = time.monotonic() - quiet_since
                cycles = int(account.get("plant_cycles", -1))
                if account and (last_status >= cycles - 1 or quiet > _END_QUIET_S):
                    break
                if stop.is_set() and quiet > 0.5:  # stopped: what was in flight is in
                    break
                continue
            quiet_since = time.monotonic()
            if key == skey:
                account = msg
                continue
            log.write(key, msg)
            if isinstance(msg, PlatformFrame) and msg.final and not key.endswith(TRUTH):
                final = True
            elif isinstance(msg, PlatformControllerStatus):
                last_status = max(last_status, msg.answered_seq)
    finally:
        if token is not None:
            token.undeclare()
        if bus is not None:
            bus.close()
        meta = dict(metadata)
        meta.update({k: str(v) for k, v in account.items()})
        meta.update(records=str(log.count), recorder_rejected=str(rejected), final_seen=str(final))
        if can_bus is not None:
            meta.update(
                can_frames_received=str(can_bus.frames_received),
                can_rejected=str(int(sum(can_bus.rejected.values()))),
            )
            can_bus.close()
        log.close(meta)
    return 0


# ------------------------------------------------------------------------------ launcher's view
def node_commands(
    scenario: str,
    controller: str,
    platform: str,
    mode: str,
    duration_s: float,
    control_period_s: float,
    endpoints: tuple[str, str],
    mcap_path: Path,
    metadata: dict[str, str],
    *,
    key_file: Path | None = None,
    noise: bool = True,
    experiment: int = 0,
    seed: int = 0,
    identified: str | None = None,
    can: dict[str, Any] | None = None,
    realtime_priority: int = 0,
) -> dict[str, list[str]]:
    """The command lines of the recorder, controller and plant processes of a platform run
    (:func:`main`), for the launcher (:mod:`hil.launch`) to start in that order.

    ``endpoints``: the plant's and the controller's listening endpoints.
    """
    plant_ep, ctrl_ep = endpoints
    base = [sys.executable, "-m", "hil.hexicon.nodes"]
    common = ["--platform", platform]
    if key_file is not None:
        common += ["--key-file", str(key_file)]
    if can is not None:
        common += ["--can-interface", can["interface"], "--can-channel", can.get("channel") or ""]
        common += ["--can-fd"] if can.get("fd") else []
    rt = ["--realtime-priority", str(realtime_priority)] if realtime_priority else []
    idf = ["--experiment", str(experiment), "--seed", str(seed)]
    return {
        "recorder": [
            *base,
            "record",
            *common,
            "--out",
            str(mcap_path),
            "--connect",
            plant_ep,
            "--connect",
            ctrl_ep,
            "--metadata",
            json.dumps(metadata),
        ],
        "controller": [
            *base,
            "controller",
            *common,
            "--controller",
            controller,
            "--listen",
            ctrl_ep,
            "--connect",
            plant_ep,
            "--period",
            repr(control_period_s),
            # announced once the recorder's link reaches it: the plant waits for that
            "--await-recorder",
            repr(LINK_TIMEOUT_S),
            "--samples",
            str(round(duration_s) if experiment else 0),
            *idf,
            *rt,
            *(["--identified", identified] if identified else []),
        ],
        "plant": [
            *base,
            "plant",
            *common,
            "--scenario",
            scenario,
            "--listen",
            plant_ep,
            "--mode",
            mode,
            "--duration",
            repr(duration_s),
            *idf,
            *rt,
            *([] if noise else ["--no-noise"]),
        ],
    }


def read_platform_run(path: Path) -> dict[str, list[Any]]:
    """Decoded messages of a platform MCAP by topic (dicts in log time order; the CDR
    channels and the JSON ones of older files alike, :func:`hil.runlog.mcap_io.read_run`)."""
    run = read_run(path)
    if run.error and not run.messages:
        raise ValueError(f"{path}: {run.error}")
    return {
        topic: sorted(msgs, key=lambda m: m["sample_time_ns"])
        for topic, msgs in run.messages.items()
        if msgs
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hil.hexicon.nodes")
    sub = ap.add_subparsers(dest="node", required=True)

    def common(sp: argparse.ArgumentParser) -> None:
        sp.add_argument("--platform", default="h3")
        sp.add_argument("--key-file", default=None, help="the run's secret (docs/security.md)")
        sp.add_argument("--can-interface", default=None)
        sp.add_argument("--can-channel", default="")
        sp.add_argument("--can-fd", action="store_true")

    pp = sub.add_parser("plant")
    common(pp)
    pp.add_argument("--scenario", required=True)
    pp.add_argument("--listen", required=True)
    pp.add_argument("--mode", choices=("lockstep", "realtime"), default="lockstep")
    pp.add_argument("--duration", type=float, default=None)
    pp.add_argument("--realtime-priority", type=int, default=0)
    pp.add_argument("--experiment", type=int, default=0)
    pp.add_argument("--seed", type=int, default=0)
    pp.add_argument("--no-noise", action="store_true")
    cp = sub.add_parser("controller")
    common(cp)
    cp.add_argument("--controller", choices=NODE_CONTROLLERS, required=True)
    cp.add_argument("--listen", required=True)
    cp.add_argument("--connect", required=True)
    cp.add_argument("--period", type=float, default=1.0)
    cp.add_argument("--realtime-priority", type=int, default=0)
    cp.add_argument("--experiment", type=int, default=0)
    cp.add_argument("--samples", type=int, default=0)
    cp.add_argument("--seed", type=int, default=0)
    cp.add_argument("--identified", default=None)
    cp.add_argument("--await-recorder", type=float, default=0.0)
    rp = sub.add_parser("record")
    common(rp)
    rp.add_argument("--out", required=True)
    rp.add_argument("--connect", action="append", required=True)
    rp.add_argument("--metadata", default="{}", help="JSON object of strings for the file")
    a = ap.parse_args(argv)
    auth_key = None
    if a.key_file:
        from bus_schemas.auth import read_key_file  # noqa: PLC0415

        auth_key = read_key_file(Path(a.key_file))
    if getattr(a, "realtime_priority", 0):
        # before the Zenoh session opens, so its threads inherit the policy (hil/nodes/rt.py)
        print(set_realtime_priority(a.realtime_priority), file=sys.stderr)
    can = None
    if a.can_interface:
        can = {"interface": a.can_interface, "channel": a.can_channel, "fd": a.can_fd}
    if a.node == "record":
        meta = json.loads(a.metadata)
        return run_recorder_node(
            Path(a.out),
            a.platform,
            tuple(a.connect),
            {str(k): str(v) for k, v in meta.items()},
            can=can,
            auth_key=auth_key,
        )
    if a.node == "plant":
        return run_plant_node(
            a.scenario,
            a.platform,
            a.listen,
            a.mode,
            a.duration,
            noise=not a.no_noise,
            experiment=a.experiment,
            seed=a.seed,
            can=can,
            auth_key=auth_key,
        )
    return run_controller_node(
        a.controller,
        a.platform,
        a.listen,
        a.connect,
        a.period,
        experiment=a.experiment,
        samples=a.samples,
        seed=a.seed,
        can=can,
        identified=a.identified,
        auth_key=auth_key,
        await_recorder_s=a.await_recorder,
    )


if __name__ == "__main__":
    raise SystemExit(main())
