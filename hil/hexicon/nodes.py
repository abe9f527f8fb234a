"""Plant and controller processes of the Hexicon H3 family over Zenoh, and their recorder.

Three OS processes: the plant (``python -m hil.hexicon.nodes plant``) listens on its endpoint,
the controller (``... controller``) listens on its own and connects to the plant, and the
recorder (the launching process, :func:`run_over_zenoh`) connects to both and writes every
message to an MCAP file. Keys::

    fowt/<platform>/platform              PlatformFrame (heading, yaw rate, met wind)
    fowt/<platform>/<turbine>/rotor       TurbineFrame (t1, t2, t3)
    fowt/<platform>/<turbine>/rotor/command  TurbineCommand (one controller commands all three)
    fowt/<platform>/platform/status       PlatformControllerStatus
    fowt/<platform>/alive/<node>          liveliness tokens

    fowt/<platform>/platform/truth        PlatformFrame of the true state (recorder only)
    fowt/<platform>/<turbine>/rotor/truth TurbineFrame of the true state (recorder only)

Modes: ``lockstep`` (the plant waits for the three commands answering each cycle; simulated
time runs as fast as the loop) and ``realtime`` (the plant ticks every control period on the
wall clock; commands not in by the next tick are held and counted as deadline misses).

Sensors: the frames carry the preset's sensor channels (:mod:`plant.hexicon.sensors`,
seeded); the truth goes on the ``.../truth`` keys, which only the recorder subscribes to.
The controller subscribes to the four measured keys by name, so it cannot see the truth.

Transport: ``zenoh`` (default) or ``can``: with ``can`` the three frames and the commands
travel as CAN frames (``bus_schemas/fowt.dbc``: TurbineFrame 0x140, PlatformFrame 0x160,
TurbineCommand 0x110, the turbine index in the payload) on a python-can bus
(:class:`hil.nodes.can_bus.CanBus`); truth, status and liveliness stay on the loopback Zenoh
session. ``udp_multicast`` between processes runs in a private network namespace (the
launcher re-runs itself under ``unshare --net``, as ``fowt run --transport can`` does);
``virtual`` connects nodes of one process only (:func:`run_in_threads`, tests).

Identification (``--controller prbs``): the plant's wind is the PRBS wind of a table-5
experiment (:func:`controller.design.hexicon_identify.experiment_wind`) and the controller
process is the PRBS pitch excitation (:class:`controller.hexicon.PrbsExcitation`).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import queue
import subprocess
import sys
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
from hil.nodes.bus import Bus, BusConfig, free_tcp_endpoint
from hil.nodes.rt import set_realtime_priority
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
_NETNS_ENV = "FOWT_HEXICON_IN_NETNS"
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

            self.zenoh.subscribe(mt.key(ident), on_payload)

    def can_rejected(self) -> int:
        return int(sum(self.can.rejected.values())) if self.can is not None else 0

    def close(self) -> None:
        try:
            self.zenoh.close()
        finally:
            if self.can is not None:
                self.can.close()


def _wait_for_peers(bus: Any, platform: str, names: tuple[str, ...], timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        seen = set()
        for reply in bus.session.liveliness().get(f"{KEY_PREFIX}/{platform}/alive/*"):
            ok = getattr(reply, "ok", None)
            if ok is not None:
                seen.add(str(ok.key_expr).rsplit("/", 1)[-1])
        if all(n in seen for n in names):
            return
        time.sleep(0.05)
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
) -> int:
    """The plant process: publish frames each period, integrate with the answering commands.

    ``experiment`` > 0: the PRBS wind of that table-5 experiment (``duration_s`` samples).
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
    bus = PlatformLink(BusConfig(listen=(listen,)), can, platform)
    token = bus.session.liveliness().declare_token(f"{KEY_PREFIX}/{platform}/alive/plant")
    commands: queue.SimpleQueue[TurbineCommand] = queue.SimpleQueue()
    rejected = 0

    def on_cmd(_key: str, msg: Any) -> None:
        nonlocal rejected
        if msg is None:
            rejected += 1
        else:
            commands.put(msg)

    bus.subscribe(TURBINE_COMMAND, tuple(f"{platform}/{t}" for t in TURBINES), on_cmd)
    try:
        _wait_for_peers(bus, platform, ("controller", "recorder"), _STARTUP_TIMEOUT_S)
        time.sleep(0.2)  # let the subscribers' declarations propagate
        x = initial_state(p, wind.speed_m_s(0.0))
        q0 = [torque_law_nm(p.turbine, w) for w in (x[2], x[5], x[8])]
        cmd = HexiconCommand((x[3], x[6], x[9]), (q0[0], q0[1], q0[2]))
        n = round((duration_s or scn.duration_s) / scn.control_period_s)
        period_ns = round(scn.control_period_s * 1e9)
        misses = held = 0
        t0 = time.monotonic_ns()
        for k in range(n + 1):
            t = k * scn.control_period_s
            v, b = wind.speed_m_s(t), wind.direction_rad(t)
            out = outputs(t, x, plant_input(cmd, v, b), p)
            truth = truth_sample(x, v, b, out.powers_w, out.rotor_winds_m_s)
            meas = sensors.measure(k * period_ns, truth)
            now = time.monotonic_ns()
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
            got: dict[int, TurbineCommand] = {}
            deadline = t0 + (k + 1) * period_ns if mode == "realtime" else now + 10 * 10**9
            while len(got) < 3:
                remaining = (deadline - time.monotonic_ns()) / 1e9
                if remaining <= 0:
                    break
                try:
                    c = commands.get(timeout=remaining)
                except queue.Empty:
                    break
                if c.answered_seq == k:
                    got[c.turbine_index] = c
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
            if mode == "realtime":
                sleep_ns = t0 + (k + 1) * period_ns - time.monotonic_ns()
                if sleep_ns > 0:
                    time.sleep(sleep_ns / 1e9)
        print(
            json.dumps(
                {
                    "plant_cycles": n,
                    "deadline_misses": misses,
                    "commands_held": held,
                    "commands_rejected": rejected + bus.can_rejected(),
                    "sensor_seed": sensors.seed,
                    "sensor_noise": sensors.enabled,
                }
            )
        )
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
) -> int:
    """The controller process: one core commanding the three turbines each cycle.

    It subscribes to the measured keys only (never ``.../truth``). ``prbs``: the pitch
    excitation of table-5 experiment ``experiment`` (1-based) over ``samples`` cycles.
    ``identified``: the identified-model artefact of ``mpc_id`` (default: the shipped one).
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
    bus = PlatformLink(BusConfig(listen=(listen,), connect=(connect,)), can, platform)
    inbox: queue.SimpleQueue[tuple[str, Any]] = queue.SimpleQueue()

    def on_platform(_key: str, msg: Any) -> None:
        inbox.put(("platform", msg) if msg is not None else ("rejected", None))

    def on_turbine(_key: str, msg: Any) -> None:
        inbox.put(("turbine", msg) if msg is not None else ("rejected", None))

    bus.subscribe(PLATFORM_FRAME, (platform,), on_platform)
    bus.subscribe(TURBINE_FRAME, tuple(f"{platform}/{t}" for t in TURBINES), on_turbine)
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
        self._log.add_metadata("hexicon_run", metadata)
        self._log.close()


def _netns_rerun(argv: list[str], out: Path) -> dict[str, Any]:
    """Re-run ``python -m hil.hexicon.nodes run ...`` in a private network namespace."""
    from hil.nodes.can_bus import netns_command  # noqa: PLC0415

    env = {**os.environ, _NETNS_ENV: "1"}
    proc = subprocess.run(
        netns_command([sys.executable, "-m", "hil.hexicon.nodes", "run", *argv]),
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    path = out / "launch.json"
    if proc.returncode != 0 or not path.is_file():
        return {
            "plant_rc": None,
            "controller_rc": None,
            "launch_rc": proc.returncode,
            "launch_stderr": proc.stderr[-3000:],
        }
    result: dict[str, Any] = json.loads(path.read_text())
    return result


def run_over_zenoh(
    scenario: str,
    controller: str,
    out: Path,
    *,
    mode: str = "lockstep",
    duration_s: float | None = None,
    platform: str = "h3",
    timeout_s: float = 3600.0,
    realtime_priority: int = 0,
    noise: bool = True,
    experiment: int = 0,
    seed: int = 0,
    transport: str = "zenoh",
    can_interface: str = "udp_multicast",
    can_channel: str = "",
    can_fd: bool = False,
    identified: str | None = None,
    mcap_name: str = "run.mcap",
) -> dict[str, Any]:
    """Run plant and controller as two processes, record to ``out/<mcap_name>``.

    ``experiment`` > 0 with ``controller="prbs"``: table-5 identification experiment
    (``duration_s`` = samples). ``transport="can"``: frames and commands on CAN (module
    docs); ``udp_multicast`` re-runs this in a private network namespace when needed.

    Returns the plant's summary (cycles, deadline misses, held/rejected commands), the
    record count and the MCAP path.
    """
    if transport not in ("zenoh", "can"):
        raise ValueError(f"transport {transport!r}: expected zenoh or can")
    if controller not in NODE_CONTROLLERS:
        raise ValueError(f"controller {controller!r}: expected one of {NODE_CONTROLLERS}")
    if (controller == "prbs") != (experiment > 0):
        raise ValueError("controller prbs goes with an identification experiment (>= 1)")
    can: dict[str, Any] | None = None
    if transport == "can":
        from hil.nodes.can_bus import (  # noqa: PLC0415
            CanBusConfig,
            in_private_netns,
            transport_unavailable_reason,
        )

        cfg = CanBusConfig.for_interface(can_interface, can_channel or None, can_fd, platform)
        if can_interface == "udp_multicast" and not in_private_netns():
            from hil.nodes.can_bus import netns_unavailable_reason  # noqa: PLC0415

            why = netns_unavailable_reason()
            if why:
                raise RuntimeError(why)
            out.mkdir(parents=True, exist_ok=True)
            argv = _cli_argv(
                scenario,
                controller,
                out,
                mode,
                duration_s,
                platform,
                realtime_priority,
                noise,
                experiment,
                seed,
                can_interface,
                can_channel,
                can_fd,
                identified,
                mcap_name,
            )
            return _netns_rerun(argv, out)
        why = transport_unavailable_reason(cfg)
        if why:
            raise RuntimeError(why)
        can = {"interface": can_interface, "channel": cfg.effective_channel, "fd": can_fd}
    scn = load_scenarios()[scenario]
    out.mkdir(parents=True, exist_ok=True)
    plant_ep = free_tcp_endpoint()
    ctrl_ep = free_tcp_endpoint()
    while ctrl_ep == plant_ep:
        ctrl_ep = free_tcp_endpoint()
    py = sys.executable
    dur = [] if duration_s is None else ["--duration", repr(duration_s)]
    rt = ["--realtime-priority", str(realtime_priority)] if realtime_priority else []
    can_args: list[str] = []
    if can is not None:
        can_args = ["--can-interface", can["interface"], "--can-channel", can["channel"]]
        can_args += ["--can-fd"] if can_fd else []
    idf = ["--experiment", str(experiment), "--seed", str(seed)]
    plant = subprocess.Popen(
        [
            py,
            "-m",
            "hil.hexicon.nodes",
            "plant",
            "--scenario",
            scenario,
            "--platform",
            platform,
            "--listen",
            plant_ep,
            "--mode",
            mode,
            *dur,
            *rt,
            *can_args,
            *idf,
            *([] if noise else ["--no-noise"]),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    samples = round(duration_s or scn.duration_s) if experiment else 0
    ctrl = subprocess.Popen(
        [
            py,
            "-m",
            "hil.hexicon.nodes",
            "controller",
            "--controller",
            controller,
            "--platform",
            platform,
            "--listen",
            ctrl_ep,
            "--connect",
            plant_ep,
            "--period",
            repr(scn.control_period_s),
            *rt,
            *can_args,
            *idf,
            "--samples",
            str(samples),
            *(["--identified", identified] if identified else []),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    mcap_path = out / mcap_name
    log = PlatformMcap(mcap_path, platform)
    q: queue.SimpleQueue[tuple[str, Any]] = queue.SimpleQueue()
    rejected = 0

    def on_sample(key: str, payload: bytes) -> None:
        nonlocal rejected
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

    can_bus_rec = None
    if can is not None:
        from hil.nodes.can_bus import CanBus, CanBusConfig  # noqa: PLC0415

        can_bus_rec = CanBus(
            CanBusConfig.for_interface(can["interface"], can["channel"], can_fd, platform)
        )
        for mt in _CAN_TYPES:

            def deliver(msg: Any, mt: MessageType = mt) -> None:
                ident = (
                    f"{platform}/t{msg.turbine_index}"
                    if hasattr(msg, "turbine_index")
                    else platform
                )
                q.put((mt.key(ident), msg))

            can_bus_rec.subscribe_message(mt, deliver)
    bus = Bus(BusConfig(connect=(plant_ep, ctrl_ep)))
    bus.subscribe(f"{KEY_PREFIX}/{platform}/**", on_sample)
    deadline = time.monotonic() + timeout_s
    final = False
    p_out = p_err = c_err = b""
    token = None
    try:
        # The plant starts when it sees the recorder's token, but the commands reach this
        # recorder only over its own link to the controller, which listens only once its
        # core is built: a first connect attempt before that fails and Zenoh retries it
        # seconds later, after a short lock-step run has ended (its commands unrecorded).
        # So the token is declared once the controller is seen on this session.
        _wait_for_peers(bus, platform, ("controller",), _STARTUP_TIMEOUT_S)
        token = bus.session.liveliness().declare_token(f"{KEY_PREFIX}/{platform}/alive/recorder")
        while (time.monotonic() < deadline and plant.poll() is None) or not q.empty():
            try:
                key, msg = q.get(timeout=0.1)
            except queue.Empty:
                if final and plant.poll() is not None:
                    break
                continue
            log.write(key, msg)
            if isinstance(msg, PlatformFrame) and msg.final and not key.endswith(TRUTH):
                final = True
        p_out, p_err = plant.communicate(timeout=30)
        _c_out, c_err = ctrl.communicate(timeout=30)
    finally:
        if token is not None:
            token.undeclare()
        bus.close()
        for proc in (plant, ctrl):
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        can_frames = can_rej = 0
        if can_bus_rec is not None:
            can_frames = can_bus_rec.frames_received
            can_rej = int(sum(can_bus_rec.rejected.values()))
            can_bus_rec.close()
    summary: dict[str, Any] = {}
    lines = [ln for ln in p_out.decode().splitlines() if ln.startswith("{")]
    if lines:
        summary = json.loads(lines[-1])
    summary.update(
        {
            "plant_rc": plant.returncode,
            "controller_rc": ctrl.returncode,
            "records": log.count,
            "recorder_rejected": rejected,
            "final_seen": final,
            "mcap": str(mcap_path),
            "transport": transport,
            "plant_stderr": p_err.decode()[-2000:],
            "controller_stderr": c_err.decode()[-2000:],
        }
    )
    if can is not None:
        summary.update(
            {
                "can_interface": can["interface"],
                "can_frames_received": can_frames,
                "can_rejected": can_rej,
            }
        )
    kind = "identification" if experiment else "run"
    log.close(
        {k: str(v) for k, v in summary.items() if k not in ("plant_stderr", "controller_stderr")}
        | {
            "kind": kind,
            "scenario": scenario,
            "controller": controller,
            "mode": mode,
            "platform": platform,
            "experiment": str(experiment),
            "seed": str(seed),
            "control_period_s": repr(scn.control_period_s),
        }
    )
    return summary


def _cli_argv(
    scenario: str,
    controller: str,
    out: Path,
    mode: str,
    duration_s: float | None,
    platform: str,
    realtime_priority: int,
    noise: bool,
    experiment: int,
    seed: int,
    can_interface: str,
    can_channel: str,
    can_fd: bool,
    identified: str | None,
    mcap_name: str,
) -> list[str]:
    argv = [
        "--scenario",
        scenario,
        "--controller",
        controller,
        "--out",
        str(out.resolve()),
        "--mode",
        mode,
        "--platform",
        platform,
        "--experiment",
        str(experiment),
        "--seed",
        str(seed),
        "--can-interface",
        can_interface,
        "--mcap-name",
        mcap_name,
    ]
    if duration_s is not None:
        argv += ["--duration", repr(duration_s)]
    if realtime_priority:
        argv += ["--realtime-priority", str(realtime_priority)]
    if not noise:
        argv.append("--no-noise")
    if can_channel:
        argv += ["--can-channel", can_channel]
    if can_fd:
        argv.append("--can-fd")
    if identified:
        argv += ["--identified", str(Path(identified).resolve())]
    return argv


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

    def can_opts(sp: argparse.ArgumentParser) -> None:
        sp.add_argument("--can-interface", default=None)
        sp.add_argument("--can-channel", default="")
        sp.add_argument("--can-fd", action="store_true")

    pp = sub.add_parser("plant")
    pp.add_argument("--scenario", required=True)
    pp.add_argument("--platform", default="h3")
    pp.add_argument("--listen", required=True)
    pp.add_argument("--mode", choices=("lockstep", "realtime"), default="lockstep")
    pp.add_argument("--duration", type=float, default=None)
    pp.add_argument("--realtime-priority", type=int, default=0)
    pp.add_argument("--experiment", type=int, default=0)
    pp.add_argument("--seed", type=int, default=0)
    pp.add_argument("--no-noise", action="store_true")
    can_opts(pp)
    cp = sub.add_parser("controller")
    cp.add_argument("--controller", choices=NODE_CONTROLLERS, required=True)
    cp.add_argument("--platform", default="h3")
    cp.add_argument("--listen", required=True)
    cp.add_argument("--connect", required=True)
    cp.add_argument("--period", type=float, default=1.0)
    cp.add_argument("--realtime-priority", type=int, default=0)
    cp.add_argument("--experiment", type=int, default=0)
    cp.add_argument("--samples", type=int, default=0)
    cp.add_argument("--seed", type=int, default=0)
    cp.add_argument("--identified", default=None)
    can_opts(cp)
    rp = sub.add_parser("run")  # the launcher, re-run inside a network namespace
    rp.add_argument("--scenario", required=True)
    rp.add_argument("--controller", required=True)
    rp.add_argument("--out", required=True)
    rp.add_argument("--mode", default="lockstep")
    rp.add_argument("--platform", default="h3")
    rp.add_argument("--duration", type=float, default=None)
    rp.add_argument("--realtime-priority", type=int, default=0)
    rp.add_argument("--experiment", type=int, default=0)
    rp.add_argument("--seed", type=int, default=0)
    rp.add_argument("--no-noise", action="store_true")
    rp.add_argument("--identified", default=None)
    rp.add_argument("--mcap-name", default="run.mcap")
    can_opts(rp)
    a = ap.parse_args(argv)
    if a.node == "run":
        res = run_over_zenoh(
            a.scenario,
            a.controller,
            Path(a.out),
            mode=a.mode,
            duration_s=a.duration,
            platform=a.platform,
            realtime_priority=a.realtime_priority,
            noise=not a.no_noise,
            experiment=a.experiment,
            seed=a.seed,
            transport="can",
            can_interface=a.can_interface or "udp_multicast",
            can_channel=a.can_channel,
            can_fd=a.can_fd,
            identified=a.identified,
            mcap_name=a.mcap_name,
        )
        (Path(a.out) / "launch.json").write_text(json.dumps(res, indent=1) + "\n")
        return 0 if res.get("plant_rc") == 0 and res.get("controller_rc") == 0 else 1
    if a.realtime_priority:
        # before the Zenoh session opens, so its threads inherit the policy (hil/nodes/rt.py)
        print(set_realtime_priority(a.realtime_priority), file=sys.stderr)
    can = None
    if a.can_interface:
        can = {"interface": a.can_interface, "channel": a.can_channel, "fd": a.can_fd}
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
    )


if __name__ == "__main__":
    raise SystemExit(main())
