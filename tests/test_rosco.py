"""``kind = "rosco"``: a DISCON library through the Bladed swap array.

The real ROSCO (the ``rosco`` wheel's ``libdiscon``, installed by ``make setup``) runs
against the bench plant; a tiny C library built here with gcc checks the swap-array
mapping and the failure paths (``aviFAIL`` < 0, missing library, malformed DISCON.IN),
each of which must end the run with a clear error and leave a reviewable MCAP file.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import textwrap
from pathlib import Path

import numpy as np
import pytest

from bus_schemas import ActuatorCommand, PlantState, SensorFrame
from bus_schemas.messages import VALID_BITS
from controller.discon import DisconError, DisconLoadError
from controller.rosco import make_rosco_controller, read_discon_in, shipped_parameter_files
from hil.inprocess.run import run_inprocess
from hil.launch import RunFailedError, RunRequest, launch
from hil.nodes.controller_node import ControllerRuntime
from hil.review.core import review
from hil.scenario.schema import ScenarioError, parse_scenario

try:
    from controller.rosco import default_library

    ROSCO_LIB: Path | None = default_library()
except DisconLoadError:
    ROSCO_LIB = None
needs_rosco = pytest.mark.skipif(
    ROSCO_LIB is None, reason="the rosco wheel is not installed (make setup installs it)"
)
needs_gcc = pytest.mark.skipif(
    shutil.which("gcc") is None, reason="no gcc to build the test DISCON"
)

# A Bladed-style controller: pitch = measured pitch + 0.01 rad, torque = 2 x measured torque;
# counts its calls in static memory and returns the count in record 120; writes the strings
# it was given next to its root name on the first call; fails (aviFAIL = -1) from t >= FAIL_AT.
_C_SOURCE = r"""
#include <stdio.h>
#include <string.h>
static int calls = 0;
void DISCON(float *sw, int *fail, const char *infile, const char *outname, char *msg) {
    calls++;
    if (calls == 1) {
        char path[2048];
        snprintf(path, sizeof path, "%s.seen", outname);
        FILE *f = fopen(path, "w");
        if (f) {
            fprintf(f, "%s\n%s\n%d %d %d %d\n", infile, outname, (int)sw[0], (int)sw[48],
                    (int)sw[49], (int)sw[50]);
            fclose(f);
        }
    }
    sw[44] = sw[3] + 0.01f;
    sw[46] = 2.0f * sw[22];
    sw[119] = (float)calls;
    if (FAIL_AT >= 0 && sw[1] >= FAIL_AT) {
        *fail = -1;
        strncpy(msg, "test DISCON: deliberate failure", (size_t)sw[48] - 1);
    }
}
"""


def _build(tmp: Path, fail_at: float = -1.0) -> Path:
    src = tmp / "testdiscon.c"
    src.write_text(_C_SOURCE)
    lib = tmp / f"libtestdiscon_{'ok' if fail_at < 0 else 'fail'}.so"
    subprocess.run(
        ["gcc", "-shared", "-fPIC", "-O1", f"-DFAIL_AT={fail_at}", "-o", str(lib), str(src)],
        check=True,
    )
    return lib


def _frame(seq: int, dt_ns: int = 25_000_000, **kw: float) -> SensorFrame:
    values = {
        "generator_speed_measured_rad_s": 100.0,
        "rotor_speed_measured_rad_s": 1.0,
        "blade_pitch_measured_rad": 0.05,
        "generator_torque_measured_nm": 40_000.0,
        "electrical_power_measured_w": 4e6,
        "wind_speed_measured_m_s": 10.0,
        "nacelle_acc_fore_aft_measured_m_s2": 0.1,
        "platform_pitch_measured_rad": 0.02,
        "platform_pitch_rate_measured_rad_s": 0.001 * seq,
        "platform_surge_measured_m": 3.0,
        "wave_elevation_gauge_measured_m": 0.0,
    }
    values.update(kw)
    return SensorFrame(
        seq=seq,
        sample_time_ns=seq * dt_ns,
        publish_time_ns=seq * dt_ns,
        valid_mask=sum(VALID_BITS.values()),
        **values,
    )


@needs_gcc
def test_swap_array_mapping_and_private_instances(tmp_path: Path) -> None:
    """Records in (ServoDyn's numbering) and out (45, 47); two instances never share memory."""
    lib = _build(tmp_path)
    ctrl = make_rosco_controller(
        "nrel5mw", library=str(lib), output_dir=tmp_path / "out"
    )  # the NREL DISCON.IN only supplies limits here
    a, b = ctrl.initial_state(), ctrl.initial_state()
    hold = 40  # start-up phase: 1 s at 40 Hz, actuators held while the first call runs
    for k in range(hold):
        a, out = ctrl.step(a, _frame(k), 0.025)
        assert out.blade_pitch_commanded_rad == pytest.approx(0.05)  # measured, held
        assert out.generator_torque_commanded_nm == pytest.approx(40_000.0)
    for k in range(hold, hold + 2):
        a, out = ctrl.step(a, _frame(k), 0.025)
    assert out.blade_pitch_commanded_rad == pytest.approx(0.06, abs=1e-6)  # record 45
    assert out.generator_torque_commanded_nm == pytest.approx(80_000.0)  # record 47
    sw = a.library.swap
    assert sw[0] == 1.0 and sw[1] == pytest.approx(1.025) and sw[2] == pytest.approx(0.025)
    assert sw[19] == 100.0 and sw[20] == 1.0 and sw[22] == 40_000.0 and sw[26] == 10.0
    assert sw[3] == sw[32] == sw[33] == pytest.approx(0.05)
    assert sw[14] == 4e6 and sw[52] == pytest.approx(0.1) and sw[60] == 3.0
    assert sw[82] == pytest.approx(0.001 / 0.025, rel=1e-5)  # d(pitch rate)/dt
    assert sw[1000] == 3.0 and sw[1004] == pytest.approx(0.02)
    assert sw[119] == 3.0  # this instance was called 3 times: first call, then 2
    for k in range(hold + 1):
        b, _ = ctrl.step(b, _frame(k), 0.025)
    assert b.library.swap[119] == 2.0  # its own static memory
    seen = (tmp_path / "out" / "rosco.SrvD.seen").read_text().splitlines()
    assert seen[0] == str(shipped_parameter_files()["nrel5mw"])
    assert seen[1] == str(tmp_path / "out" / "rosco.SrvD")
    status, msg_len, in_len, out_len = (int(v) for v in seen[2].split())
    assert status == 0 and msg_len == 1025
    assert in_len == len(seen[0]) + 1 and out_len == len(seen[1]) + 1
    assert (tmp_path / "out" / "rosco-2.SrvD.seen").is_file()  # the second instance's files


def _scenario(kind_lines: str, duration: float = 4.0, wind: float = 18.0) -> str:
    return textwrap.dedent(
        f"""
        name = "rosco-test"
        turbine = "nrel5mw"
        duration_s = {duration}
        [timing]
        control_period_s = 0.025
        plant_step_s = 0.0125
        [wind]
        kind = "steady"
        speed_m_s = {wind}
        [controller]
        """
    ) + textwrap.dedent(kind_lines)


def _logged(folder: Path, preset: str = "nrel5mw", level: int = 1) -> str:
    """A ``[controller]`` table of kind rosco with the shipped ``preset``'s DISCON.IN at
    ``LoggingLevel`` = ``level`` (the shipped files log at 0): a copy in ``folder`` naming
    the shipped Cp table by its absolute path. Level 1 gives the status ROSCO's wind-speed
    estimate and the ``.RO.dbg`` file."""
    src = shipped_parameter_files()[preset]
    lines = []
    for line in src.read_text().splitlines():
        if line.rstrip().endswith("! LoggingLevel"):
            lines.append(f"{level:<41d}! LoggingLevel")
        elif line.rstrip().endswith("! PerfFileName"):
            name = line.split("!")[0].strip().strip('"')
            lines.append(f'"{src.parent / name}"   ! PerfFileName')
        else:
            lines.append(line)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{preset}_L{level}_DISCON.IN"
    path.write_text("\n".join(lines) + "\n")
    return f'kind = "rosco"\nparameter_file = "{path}"\n'


def _run_request(tmp: Path, text: str, mode: str) -> RunRequest:
    path = tmp / "scenario.toml"
    path.write_text(text)
    return RunRequest(str(path), mode=mode, out_dir=tmp / "run", plots=False)  # type: ignore[arg-type]


@needs_gcc
@pytest.mark.parametrize("mode", ["inprocess", "lockstep"])
def test_library_failure_is_a_controller_fault(tmp_path: Path, mode: str) -> None:
    """aviFAIL < 0 at t = 1 s: the controller's fault (exit 7) with the library's message,
    the same in both modes; the library is not called again, the plant goes to its safe
    state on the flagged commands and the MCAP reviews whole.

    The run is untrimmed (its start needs no settling run of the library): the failure comes
    in the run. Trimmed, the settling run meets it first: the same verdict at its start."""
    lib = _build(tmp_path, fail_at=1.0)
    kind = f'kind = "rosco"\npreset = "nrel5mw"\nlibrary = "{lib}"\n'
    text = _scenario(kind + "[initial]\ntrim = false\n", duration=3.0)
    summary = launch(_run_request(tmp_path, text, mode))
    assert summary["run"]["outcome"] == "controller_fault", summary["run"]
    assert summary["run"]["exit_code"] == 7
    fault = summary["controller"]["fault"]
    assert fault["kind"] == "raised"
    assert "test DISCON: deliberate failure" in fault["message"]
    assert fault["t_s"] == pytest.approx(1.0, abs=0.05)
    assert "test DISCON: deliberate failure" in summary["run"]["outcome_reasons"][0]
    assert summary["controller"]["fault_commands"] > 0
    assert summary["timing"]["cycles"] == round(3.0 / 0.025)  # the run goes on, safe
    if mode == "inprocess":
        (tmp_path / "trimmed").mkdir()
        trimmed = launch(_run_request(tmp_path / "trimmed", _scenario(kind, duration=3.0), mode))
        assert trimmed["run"]["exit_code"] == 7, trimmed["run"]
        assert "test DISCON: deliberate failure" in trimmed["run"]["outcome_reasons"][0]


@pytest.mark.parametrize("mode", ["inprocess", "lockstep"])
def test_a_missing_library_is_refused_with_the_scenario(tmp_path: Path, mode: str) -> None:
    """A library file that is not there: the scenario itself is refused (bad input, exit 2
    from ``fowt run``) with the path looked for, before any process, file or folder."""
    text = _scenario('kind = "rosco"\npreset = "nrel5mw"\nlibrary = "lib/libdiscon.so"\n')
    with pytest.raises(ScenarioError, match=r"controller\.library = 'lib/libdiscon\.so': file not"):
        launch(_run_request(tmp_path, text, mode))
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    ("lines", "expected", "mode"),
    [
        ("parameter_file = '{bad}'", "parameter 'PC_MaxRat' = 'fast' is not a number", "inprocess"),
    ],
)
def test_malformed_parameter_file(tmp_path: Path, lines: str, expected: str, mode: str) -> None:
    """The launcher's own check, with the file and parameter named; the MCAP reviews
    (``fowt run`` refuses it before the launch: exit 2, tests/test_cli_input.py)."""
    bad = tmp_path / "DISCON.IN"
    good = shipped_parameter_files()["nrel5mw"].read_text()
    bad.write_text(
        good.replace("0.174500000000                           ! PC_MaxRat", "fast ! PC_MaxRat")
    )
    text = _scenario('kind = "rosco"\npreset = "nrel5mw"\n' + lines.format(bad=bad) + "\n")
    with pytest.raises(RunFailedError, match=expected):
        launch(_run_request(tmp_path, text, mode))  # type: ignore[arg-type]
    # The launcher's summary of the failed run says so (hil.review.outcome: failed, exit code 1).
    launched = json.loads((tmp_path / "run" / "summary.json").read_text())["run"]
    assert launched["outcome"] == "failed" and launched["exit_code"] == 1
    assert expected in launched["failed"]
    summary = review(tmp_path / "run" / "run.mcap", plots=False)
    assert summary["timing"]["cycles"] == 0


def test_shipped_parameter_files_read() -> None:
    files = shipped_parameter_files()
    assert set(files) == {"nrel5mw", "iea15mw_volturnus"}
    nrel = read_discon_in(files["nrel5mw"])
    assert nrel.pc_max_rat_rad_s == pytest.approx(0.1745) and nrel.we_mode == 2
    iea = read_discon_in(files["iea15mw_volturnus"])
    assert iea.vs_rt_pwr_w == 15e6 and iea.perf_file is not None and iea.perf_file.is_file()
    # no debug files unless a scenario's own DISCON.IN asks (level 2 wrote ~165 MB per 900 s)
    assert nrel.logging_level == 0 and iea.logging_level == 0


@needs_rosco
def test_the_shipped_files_write_no_debug_files(tmp_path: Path) -> None:
    _collect(_scenario('kind = "rosco"\npreset = "nrel5mw"\n', duration=3.0), tmp_path)
    assert not list(tmp_path.glob("*.dbg*"))


def _collect(text: str, run_dir: Path) -> tuple[list[PlantState], list, list[ActuatorCommand]]:
    truth: list[PlantState] = []
    status: list = []
    commands: list[ActuatorCommand] = []
    scenario = parse_scenario(text)
    runtime = ControllerRuntime(scenario, run_dir=run_dir)

    def publish(_mt: object, msg: object) -> None:
        if isinstance(msg, PlantState):
            truth.append(msg)

    def step(frame: SensorFrame) -> ActuatorCommand | None:
        out = runtime.handle_frame(frame)
        if out is None:
            return None
        status.append(out[1])
        commands.append(out[0])
        return out[0]

    run_inprocess(scenario, publish, step)
    return truth, status, commands


@needs_rosco
def test_rosco_and_baseline_agree_in_region_3(tmp_path: Path) -> None:
    """NREL 5 MW at 18 m/s: both hold rated speed and power, and the Cp table sets the
    pitch: ROSCO's settled pitch within 0.1 deg of the baseline's (last 5 s of 30 s)."""
    res = {}
    for kind, preset in (("rosco", "nrel5mw"), ("baseline", "nrel5mw_baseline")):
        table = (
            _logged(tmp_path / "in")  # LoggingLevel 1: the status gets ROSCO's estimate
            if kind == "rosco"
            else f'kind = "{kind}"\npreset = "{preset}"\n'
        )
        truth, status, _ = _collect(_scenario(table, duration=30.0), tmp_path / kind)
        last = truth[-200:]
        res[kind] = (
            np.mean([s.rotor_speed_rad_s for s in last]) * 30 / np.pi,
            np.mean([s.electrical_power_w for s in last]),
            np.degrees(np.mean([s.blade_pitch_rad for s in last])),
        )
        if kind == "rosco":
            assert {s.regime for s in status[-200:]} == {4}  # ROSCO's rule: region 3
            we = [s.wind_speed_estimated_m_s for s in status[-200:]]
            assert np.mean(we) == pytest.approx(18.0, rel=0.05)  # its EKF, Cp matched
    (rpm_r, p_r, th_r), (rpm_b, p_b, th_b) = res["rosco"], res["baseline"]
    assert rpm_r == pytest.approx(12.1, rel=0.005) and rpm_b == pytest.approx(12.1, rel=0.005)
    assert p_r == pytest.approx(5e6, rel=0.005) and p_b == pytest.approx(5e6, rel=0.005)
    assert abs(th_r - th_b) < 0.1
    assert (tmp_path / "rosco" / "rosco.RO.dbg").is_file()  # ROSCO's file in the run folder


@needs_rosco
def test_rosco_lockstep_equals_inprocess(tmp_path: Path) -> None:
    """Deterministic: the lock-step run over Zenoh (two processes) gives the in-process
    run's KPIs exactly."""
    text = _scenario(_logged(tmp_path / "in"), duration=5.0, wind=14.0)
    out = {}
    for mode in ("inprocess", "lockstep"):
        d = tmp_path / mode
        d.mkdir()
        out[mode] = launch(_run_request(d, text, mode))["kpi"]
        assert (d / "run" / "rosco.RO.dbg").is_file()
    for key in ("mean_power_w", "rotor_speed_mean_rad_s", "pitch_travel_rad_s"):
        if key in out["inprocess"]:
            assert out["lockstep"][key] == out["inprocess"][key]


def test_library_error_is_a_value_error() -> None:
    with pytest.raises(DisconLoadError, match="not found"):
        make_rosco_controller("nrel5mw", library="/nonexistent/lib.so")
    assert issubclass(DisconLoadError, ValueError) and issubclass(DisconLoadError, DisconError)


@needs_rosco
def test_watchdog_restart_loads_a_fresh_rosco(tmp_path: Path) -> None:
    """Frames missing -> safe mode; after K healthy frames the core restarts: a new private
    copy of the library (first call again, its files rosco-2.RO.*), rate-limited transfer."""
    text = _scenario(_logged(tmp_path / "in"), duration=10.0).replace(
        "[timing]\n", "[timing]\nwatchdog_misses = 3\nwatchdog_recover_cycles = 5\n"
    )
    scenario = parse_scenario(text)
    runtime = ControllerRuntime(scenario, run_dir=tmp_path, paced=False)
    limits = runtime.limits
    assert limits.pitch_max_rad == pytest.approx(1.57) and limits.pitch_rate_max_rad_s == 0.1745
    modes = []
    for k in [*range(60), *range(64, 140)]:  # frames 60..63 lost: 4 misses > 3
        frame = _frame(
            k,
            generator_speed_measured_rad_s=122.9,
            rotor_speed_measured_rad_s=1.267,
            wind_speed_measured_m_s=18.0,
            blade_pitch_measured_rad=0.26,
            generator_torque_measured_nm=43_000.0,
        )
        out = runtime.handle_frame(frame)
        assert out is not None
        modes.append(out[0].mode)
    assert runtime.safe_entries == 1 and 2 in modes and modes[-1] in (0, 1)
    assert (tmp_path / "rosco.RO.dbg").is_file() and (tmp_path / "rosco-2.RO.dbg").is_file()
    assert runtime.state.instance == 2


@needs_rosco
def test_rosco_tracks_its_tip_speed_ratio_in_region_2(tmp_path: Path) -> None:
    """NREL 5 MW at 8 m/s: ROSCO's torque law (VS_ControlMode 2) tracks VS_TSRopt = 7.5
    through its own wind-speed estimate (settled TSR within 0.5 %, last 10 s of 60 s)."""
    truth, status, _ = _collect(
        _scenario('kind = "rosco"\npreset = "nrel5mw"\n', duration=60.0, wind=8.0), tmp_path
    )
    tsr = np.mean([s.tip_speed_ratio for s in truth[-400:]])
    assert tsr == pytest.approx(7.5, rel=0.005)
    assert {s.regime for s in status[-400:]} == {2}
