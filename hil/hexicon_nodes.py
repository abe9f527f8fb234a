"""Plant and controller processes of the Hexicon H3 family over Zenoh, and their recorder.

Three OS processes: the plant (``python -m hil.hexicon_nodes plant``) listens on its endpoint,
the controller (``... controller``) listens on its own and connects to the plant, and the
recorder (the launching process, :func:`run_over_zenoh`) connects to both and writes every
message to an MCAP file. Keys::

    fowt/<platform>/platform              PlatformFrame (heading, yaw rate, met wind)
    fowt/<platform>/<turbine>/rotor       TurbineFrame (t1, t2, t3)
    fowt/<platform>/<turbine>/rotor/command  TurbineCommand (one controller commands all three)
    fowt/<platform>/platform/status       PlatformControllerStatus
    fowt/<platform>/alive/<node>          liveliness tokens

Modes: ``lockstep`` (the plant waits for the three commands answering each cycle; simulated
time runs as fast as the loop) and ``realtime`` (the plant ticks every control period on the
wall clock; commands not in by the next tick are held and counted as deadline misses).
Sensors are the true heading, rate, met wind and rotor speeds (no noise model yet).
"""

from __future__ import annotations

import argparse
import json
import math
import queue
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import msgspec
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

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
)
from controller.hexicon import HexiconCommand, HexiconMeasurement, load_design
from hil.bus import Bus, BusConfig, free_tcp_endpoint
from hil.hexicon import ControllerCore, initial_state, load_scenarios, plant_input
from hil.rt import set_realtime_priority
from plant.hexicon.model import outputs, step_rk4, torque_law_nm

TURBINES = ("t1", "t2", "t3")
_STARTUP_TIMEOUT_S = 30.0


def _wait_for_peers(bus: Bus, platform: str, names: tuple[str, ...], timeout_s: float) -> None:
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


# ------------------------------------------------------------------------------ plant
def run_plant_node(
    scenario: str, platform: str, listen: str, mode: str, duration_s: float | None
) -> int:
    """The plant process: publish frames each period, integrate with the answering commands."""

    scn = load_scenarios()[scenario]
    p = scn.params()
    wind = scn.wind
    bus = Bus(BusConfig(listen=(listen,)))
    token = bus.session.liveliness().declare_token(f"{KEY_PREFIX}/{platform}/alive/plant")
    commands: queue.SimpleQueue[TurbineCommand] = queue.SimpleQueue()
    rejected = 0

    def on_cmd(_key: str, payload: bytes) -> None:
        nonlocal rejected
        try:
            commands.put(TURBINE_COMMAND.codec.decode(payload))
        except DecodeError:
            rejected += 1

    bus.subscribe(f"{KEY_PREFIX}/{platform}/*/{TURBINE_COMMAND.key_suffix}", on_cmd)
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
            now = time.monotonic_ns()
            for i, name in enumerate(TURBINES):
                fr = TurbineFrame(
                    seq=k,
                    sample_time_ns=k * period_ns,
                    publish_time_ns=now,
                    turbine_index=i + 1,
                    rotor_speed_measured_rad_s=x[2 + 3 * i],
                    blade_pitch_measured_rad=x[3 + 3 * i],
                    generator_torque_measured_nm=x[4 + 3 * i],
                    electrical_power_measured_w=out.powers_w[i],
                    wind_speed_measured_m_s=out.rotor_winds_m_s[i],
                )
                bus.put(TURBINE_FRAME.key(f"{platform}/{name}"), TURBINE_FRAME.codec.encode(fr))
            pf = PlatformFrame(
                seq=k,
                sample_time_ns=k * period_ns,
                publish_time_ns=now,
                final=int(k == n),
                platform_heading_measured_rad=x[0],
                platform_yaw_rate_measured_rad_s=x[1],
                wind_direction_measured_rad=b,
                wind_speed_measured_m_s=v,
                platform_power_w=sum(out.powers_w),
            )
            bus.put(PLATFORM_FRAME.key(platform), PLATFORM_FRAME.codec.encode(pf))
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
                    "commands_rejected": rejected,
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
    controller: str, platform: str, listen: str, connect: str, period_s: float
) -> int:
    """The controller process: one core commanding the three turbines each cycle."""

    core = ControllerCore(controller, load_design(), period_s)
    bus = Bus(BusConfig(listen=(listen,), connect=(connect,)))
    inbox: queue.SimpleQueue[tuple[str, Any]] = queue.SimpleQueue()

    def on_any(key: str, payload: bytes) -> None:
        suffix = key.split("/", 2)[2]
        try:
            if suffix == PLATFORM_FRAME.key_suffix:
                inbox.put(("platform", PLATFORM_FRAME.codec.decode(payload)))
            elif suffix.endswith("/" + TURBINE_FRAME.key_suffix):
                inbox.put(("turbine", TURBINE_FRAME.codec.decode(payload)))
        except DecodeError:
            inbox.put(("rejected", None))

    bus.subscribe(f"{KEY_PREFIX}/{platform}/**", on_any)
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
            cmd = core.step(m, period_s)
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
                bus.put(TURBINE_COMMAND.key(f"{platform}/{name}"), TURBINE_COMMAND.codec.encode(tc))
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
                controller=int(controller == "mpc"),
                overruns=core.overruns,
                heading_error_rad=err,
                solve_time_s=core.last_solve_s,
            )
            bus.put(PLATFORM_STATUS.key(platform), PLATFORM_STATUS.codec.encode(st))
            seq_out += 1
    finally:
        token.undeclare()
        bus.close()


# ------------------------------------------------------------------------------ recorder
class PlatformMcap:
    """MCAP writer with one JSON channel per key of a platform (per-turbine keys too)."""

    def __init__(self, path: Path, platform: str) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self._stream = open(path, "wb")  # noqa: SIM115 - closed in close()
        self._w = Writer(self._stream, compression=CompressionType.ZSTD)
        self._w.start(profile="", library="fowt-hil hexicon")
        self._channels: dict[str, int] = {}
        self.count = 0
        for mt in PLATFORM_MESSAGES:
            sid = self._w.register_schema(
                name=f"fowt.{mt.name}",
                encoding="jsonschema",
                data=json.dumps(mt.json_schema()).encode(),
            )
            per_turbine = mt in (TURBINE_FRAME, TURBINE_COMMAND)
            for ident in [f"{platform}/{t}" for t in TURBINES] if per_turbine else [platform]:
                key = mt.key(ident)
                self._channels[key] = self._w.register_channel(
                    topic=key,
                    message_encoding="json",
                    schema_id=sid,
                    metadata={"version": str(mt.version), "message_id": str(mt.message_id)},
                )

    def write(self, key: str, msg: Any) -> None:
        cid = self._channels.get(key)
        if cid is None:
            return
        now = time.time_ns()
        self._w.add_message(
            cid,
            log_time=int(msg.sample_time_ns),
            data=msgspec.json.encode(msg),
            publish_time=now,
            sequence=self.count,
        )
        self.count += 1

    def close(self, metadata: dict[str, str]) -> None:
        self._w.add_metadata("hexicon_run", metadata)
        self._w.finish()
        self._stream.close()


def run_over_zenoh(
    scenario: str,
    controller: str,
    out: Path,
    *,
    mode: str = "lockstep",
    duration_s: float | None = None,
    platform: str = "h3",
    timeout_s: float = 600.0,
    realtime_priority: int = 0,
) -> dict[str, Any]:
    """Run plant and controller as two processes over Zenoh, record to ``out/run.mcap``.

    Returns the plant's summary (cycles, deadline misses, held/rejected commands), the
    record count and the MCAP path.
    """

    scn = load_scenarios()[scenario]
    out.mkdir(parents=True, exist_ok=True)
    plant_ep = free_tcp_endpoint()
    ctrl_ep = free_tcp_endpoint()
    while ctrl_ep == plant_ep:
        ctrl_ep = free_tcp_endpoint()
    py = sys.executable
    dur = [] if duration_s is None else ["--duration", repr(duration_s)]
    rt = ["--realtime-priority", str(realtime_priority)] if realtime_priority else []
    plant = subprocess.Popen(
        [
            py,
            "-m",
            "hil.hexicon_nodes",
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
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    ctrl = subprocess.Popen(
        [
            py,
            "-m",
            "hil.hexicon_nodes",
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
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    mcap_path = out / "run.mcap"
    log = PlatformMcap(mcap_path, platform)
    q: queue.SimpleQueue[tuple[str, Any]] = queue.SimpleQueue()
    rejected = 0

    def on_sample(key: str, payload: bytes) -> None:
        nonlocal rejected
        parts = key.split("/")
        if "alive" in parts:
            return
        suffix = "/".join(parts[3:]) if parts[2] in TURBINES else "/".join(parts[2:])
        mt = BY_SUFFIX.get(suffix)
        if mt is None:
            return
        try:
            q.put((key, mt.codec.decode(payload)))
        except DecodeError:
            rejected += 1

    bus = Bus(BusConfig(connect=(plant_ep, ctrl_ep)))
    bus.subscribe(f"{KEY_PREFIX}/{platform}/**", on_sample)
    token = bus.session.liveliness().declare_token(f"{KEY_PREFIX}/{platform}/alive/recorder")
    deadline = time.monotonic() + timeout_s
    final = False
    try:
        while (time.monotonic() < deadline and plant.poll() is None) or not q.empty():
            try:
                key, msg = q.get(timeout=0.1)
            except queue.Empty:
                if final and plant.poll() is not None:
                    break
                continue
            log.write(key, msg)
            if isinstance(msg, PlatformFrame) and msg.final:
                final = True
        p_out, p_err = plant.communicate(timeout=30)
        _c_out, c_err = ctrl.communicate(timeout=30)
    finally:
        token.undeclare()
        bus.close()
        for proc in (plant, ctrl):
            if proc.poll() is None:
                proc.kill()
                proc.wait()
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
            "plant_stderr": p_err.decode()[-2000:],
            "controller_stderr": c_err.decode()[-2000:],
        }
    )
    log.close(
        {k: str(v) for k, v in summary.items() if k not in ("plant_stderr", "controller_stderr")}
        | {"scenario": scenario, "controller": controller, "mode": mode}
    )
    return summary


def read_platform_run(path: Path) -> dict[str, list[Any]]:
    """Decoded messages of a platform MCAP by topic (JSON dicts in log order)."""

    by_topic: dict[str, list[Any]] = {}
    with open(path, "rb") as fh:
        for _schema, channel, message in make_reader(fh).iter_messages(log_time_order=True):
            by_topic.setdefault(channel.topic, []).append(json.loads(message.data))
    return by_topic


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hil.hexicon_nodes")
    sub = ap.add_subparsers(dest="node", required=True)
    pp = sub.add_parser("plant")
    pp.add_argument("--scenario", required=True)
    pp.add_argument("--platform", default="h3")
    pp.add_argument("--listen", required=True)
    pp.add_argument("--mode", choices=("lockstep", "realtime"), default="lockstep")
    pp.add_argument("--duration", type=float, default=None)
    pp.add_argument("--realtime-priority", type=int, default=0)
    cp = sub.add_parser("controller")
    cp.add_argument("--controller", choices=("bang_bang", "mpc"), required=True)
    cp.add_argument("--platform", default="h3")
    cp.add_argument("--listen", required=True)
    cp.add_argument("--connect", required=True)
    cp.add_argument("--period", type=float, default=1.0)
    cp.add_argument("--realtime-priority", type=int, default=0)
    a = ap.parse_args(argv)
    if a.realtime_priority:
        # before the Zenoh session opens, so its threads inherit the policy (hil/rt.py)
        print(set_realtime_priority(a.realtime_priority), file=sys.stderr)
    if a.node == "plant":
        return run_plant_node(a.scenario, a.platform, a.listen, a.mode, a.duration)
    return run_controller_node(a.controller, a.platform, a.listen, a.connect, a.period)


if __name__ == "__main__":
    raise SystemExit(main())
