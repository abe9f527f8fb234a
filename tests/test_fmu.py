"""FMI 2.0 co-simulation FMU controllers (``kind = "fmu"``, :mod:`controller.fmu`).

The FMU is built here from ``tests/fmu_src`` (C source and modelDescription.xml) with gcc
against the FMI 2.0 headers fmpy ships, and zipped into an ``.fmu``: a generator-speed PI
on pitch and a K omega^2 torque law, in rpm, deg and kN.m, so the bench's unit conversion
is on the path. The same law written in Python (:class:`PiLaw`) is the reference.
"""

from __future__ import annotations

import math
import shutil
import subprocess
import zipfile
from pathlib import Path

import msgspec
import numpy as np
import pytest
from _helpers import REPO, fowt, sensor_frame

from bus_schemas import SensorFrame
from bus_schemas.messages import VALID_BITS
from controller.fmu import FmuController, FmuError, FmuSettings, FmuStepError, check_fmu
from controller.interface import REGIME_REGION_2, REGIME_REGION_3, ControlOutput
from controller.registry import CONTROLLER_KINDS, make_controller
from hil.runlog.mcap_io import read_run
from hil.scenario.schema import ScenarioError, load_scenario, parse_scenario

fmpy = pytest.importorskip("fmpy")

SRC = REPO / "tests" / "fmu_src"
ALL_VALID = sum(VALID_BITS.values())
DT = 0.025
TOL = 1e-9


# ----------------------------------------------------------------------------- the FMUs
@pytest.fixture(scope="session")
def fmu_binary(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The test FMU's shared library by FMI version ("2.0", "3.0"), compiled once a session."""
    if shutil.which("gcc") is None:
        pytest.skip("gcc not found: the test FMU is compiled from C")
    headers = Path(fmpy.__file__).parent / "c-code"
    folder = tmp_path_factory.mktemp("fmu-build")
    sources = {"2.0": ["pi_controller.c"], "3.0": ["pi_controller3.c", "fmi3_stubs.c"]}
    out = {}
    for version, files in sources.items():
        lib = folder / f"pi_controller{version[0]}.so"
        cmd = ["gcc", "-O2", "-shared", "-fPIC", f"-I{headers}"]
        cmd += [str(SRC / f) for f in files] + ["-o", str(lib), "-lm"]
        subprocess.run(cmd, check=True, capture_output=True)
        out[version] = lib
    return out


def make_fmu(
    path: Path,
    binaries: dict[str, Path],
    *,
    version: str = "2.0",
    interface: str = "CoSimulation",
    with_binary: bool = True,
    xml: str | None = None,
) -> Path:
    """Zip an ``.fmu``: modelDescription.xml (from the version's template unless ``xml``)
    and the version's binary under ``binaries/<platform>/``."""
    if version == "3.0":
        text = (SRC / "modelDescription3.xml").read_text()
        platform = fmpy.platform_tuple
    else:
        text = (SRC / "modelDescription.xml").read_text()
        text = text.replace("@FMI_VERSION@", version).replace("@INTERFACE@", interface)
        platform = fmpy.platform
    if interface != "CoSimulation":
        text = text.replace(' canHandleVariableCommunicationStepSize="true"', "")
    binary = binaries["3.0" if version == "3.0" else "2.0"]
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("modelDescription.xml", text if xml is None else xml)
        if with_binary:
            zf.write(binary, f"binaries/{platform}/pi_controller{fmpy.sharedLibraryExtension}")
    return path


@pytest.fixture(scope="session")
def pi_fmus(
    fmu_binary: dict[str, Path], tmp_path_factory: pytest.TempPathFactory
) -> dict[str, Path]:
    """The test FMU by FMI version."""
    folder = tmp_path_factory.mktemp("fmu")
    return {
        v: make_fmu(folder / f"pi_controller{v[0]}.fmu", fmu_binary, version=v)
        for v in ("2.0", "3.0")
    }


@pytest.fixture(scope="session")
def pi_fmu(pi_fmus: dict[str, Path]) -> Path:
    """The FMI 2.0 test FMU."""
    return pi_fmus["2.0"]


SETTINGS = {
    "inputs": {"generator_speed_measured_rad_s": "GenSpeed", "wind_speed_measured_m_s": "Wind"},
    "outputs": {
        "blade_pitch_commanded_rad": "PitchCmd",
        "generator_torque_commanded_nm": "TorqueCmd",
        "generator_speed_filtered_rad_s": "SpeedFilt",
        "pitch_integrator_rad": "PitchInt",
        "regime": "Regime",
    },
    "units": {"Wind": "m/s"},
}


def settings(fmu: Path, **changes: object) -> FmuSettings:
    return msgspec.convert({"fmu": str(fmu), **SETTINGS, **changes}, FmuSettings)


# ----------------------------------------------------------------------------- the law
class PiLaw:
    """The test FMU's law as a Python core (SI units; tests/fmu_src/pi_controller.c)."""

    def __init__(
        self,
        kp: float = 0.01882681,
        ki: float = 0.008068634,
        speed_ref: float = 122.9096,
        kopt: float = 2.332287,
        torque_max: float = 43093.55,
        pitch_min: float = 0.0,
        pitch_max: float = 1.5707963,
    ) -> None:
        self.kp, self.ki, self.speed_ref, self.kopt = kp, ki, speed_ref, kopt
        self.torque_max, self.pitch_min, self.pitch_max = torque_max, pitch_min, pitch_max

    def initial_state(self) -> float:
        return 0.0

    def step(self, integ: float, m: SensorFrame, dt_s: float) -> tuple[float, ControlOutput]:
        w = m.generator_speed_measured_rad_s
        e = w - self.speed_ref
        integ = min(max(integ + self.ki * e * dt_s, self.pitch_min), self.pitch_max)
        pitch = min(max(self.kp * e + integ, self.pitch_min), self.pitch_max)
        torque = min(self.kopt * w * w, self.torque_max)
        regime = REGIME_REGION_3 if pitch > self.pitch_min + 0.01 else REGIME_REGION_2
        return integ, ControlOutput(pitch, torque, regime, w, integ, 1.0)


def frames(n: int, seed: int = 7) -> list[SensorFrame]:
    """Generator speed swinging +-30 rad/s about rated, plus seeded noise: pitch and its
    integral are at their lower clamp half the time."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    speed = 122.9 + 30.0 * np.sin(2.0 * np.pi * k / 400.0) + rng.normal(0.0, 1.0, n)
    return [
        msgspec.structs.replace(
            sensor_frame(float(w), seq=k, valid_mask=ALL_VALID),
            sample_time_ns=k * round(DT * 1e9),
            wind_speed_measured_m_s=16.0,
        )
        for k, w in enumerate(speed)
    ]


def run_core(core: object, fs: list[SensorFrame]) -> np.ndarray:
    state = core.initial_state()  # type: ignore[attr-defined]
    rows = []
    for f in fs:
        state, out = core.step(state, f, DT)  # type: ignore[attr-defined]
        rows.append(
            (
                out.blade_pitch_commanded_rad,
                out.generator_torque_commanded_nm,
                out.regime,
                out.generator_speed_filtered_rad_s,
                out.pitch_integrator_rad,
            )
        )
    return np.array(rows)


# ----------------------------------------------------------------------------- stepping
@pytest.mark.parametrize("version", ["2.0", "3.0"])
def test_fmu_equals_python_law_and_resets(version: str, pi_fmus: dict[str, Path]) -> None:
    """(a) The FMU (FMI 2.0 and 3.0) stepped directly equals the Python law to 1e-9 over 800
    frames (units converted: rpm in, deg and kN.m out); a second run after initial_state() is
    identical."""
    fmu = FmuController(settings(pi_fmus[version]), DT)
    assert fmu.model.fmi_version == version
    fs = frames(800)
    got = run_core(fmu, fs)
    want = run_core(PiLaw(), fs)
    assert np.max(np.abs(got - want)) < TOL
    assert want[:, 0].max() > 0.05 and want[:, 0].min() == 0.0  # both regions visited
    assert set(want[:, 2]) == {REGIME_REGION_2, REGIME_REGION_3}
    again = run_core(fmu, fs)
    np.testing.assert_array_equal(again, got)  # reset: bit-identical
    fmu.close()


def test_registry_builds_it_with_start_values(pi_fmu: Path, tmp_path: Path) -> None:
    """The registry's "fmu" kind takes a settings dict and a base folder; start values
    (parameters) reach the FMU before its initialisation."""
    assert CONTROLLER_KINDS["fmu"].settings is FmuSettings
    assert CONTROLLER_KINDS["fmu"].description
    shutil.copy(pi_fmu, tmp_path / "c.fmu")
    core = make_controller(
        "fmu",
        "",
        control_period_s=DT,
        settings={**SETTINGS, "fmu": "c.fmu", "start_values": {"Kp": 0.03, "SpeedRef": 120.0}},
        base_dir=str(tmp_path),
    )
    fs = frames(200, seed=3)
    got = run_core(core, fs)
    want = run_core(PiLaw(kp=0.03, speed_ref=120.0), fs)
    assert np.max(np.abs(got - want)) < TOL


def test_fmi3_types_are_checked(pi_fmus: dict[str, Path]) -> None:
    """FMI 3.0 variables map by their own types: Float64 for floats, Int32 for the regime."""
    outputs = {**SETTINGS["outputs"], "regime": "PitchInt"}
    with pytest.raises(FmuError, match="is Float64, expected Int32"):
        check_fmu(settings(pi_fmus["3.0"], outputs=outputs))
    with pytest.raises(FmuError, match="is Float64, expected a value of that type"):
        check_fmu(settings(pi_fmus["3.0"], start_values={"Kp": True}))


def test_dropout_holds_the_last_valid_input(pi_fmu: Path) -> None:
    """A mapped input whose valid bit is cleared is held at its last valid value."""
    fmu = FmuController(settings(pi_fmu), DT)
    state = fmu.initial_state()
    state, a = fmu.step(state, sensor_frame(125.0, seq=0, valid_mask=ALL_VALID), DT)
    assert a.estimator_degraded == 0
    state, b = fmu.step(state, sensor_frame(0.0, seq=1, valid_mask=0), DT)
    assert b.estimator_degraded == 1
    assert b.generator_speed_filtered_rad_s == pytest.approx(125.0, abs=TOL)
    fmu.close()


@pytest.mark.parametrize("version", ["2.0", "3.0"])
def test_dostep_failure_names_fmu_time_and_status(
    version: str, fmu_binary: dict[str, Path], tmp_path: Path
) -> None:
    path = make_fmu(tmp_path / "f.fmu", fmu_binary, version=version)
    fmu = FmuController(settings(path, start_values={"FailTime": 0.1}), DT)
    state = fmu.initial_state()
    with pytest.raises(FmuStepError) as err:
        for f in frames(10):
            state, _ = fmu.step(state, f, DT)
    msg = str(err.value)
    call = f"fmi{version[0]}DoStep"
    assert f"FMU f.fmu: {call} failed at t = 0.100 s: status 3 (error)" == msg
    fmu.close()


# ----------------------------------------------------------------------------- validation
def _broken(kind: str, binary: dict[str, Path], d: Path) -> Path:
    p = d / f"{kind}.fmu"
    if kind == "not_a_zip":
        p.write_text("no archive")
    elif kind == "no_model_description":
        with zipfile.ZipFile(p, "w") as zf:
            zf.writestr("readme.txt", "")
    elif kind == "malformed_xml":
        make_fmu(p, binary, xml="<fmiModelDescription fmiVersion='2.0'")
    elif kind == "model_exchange":
        make_fmu(p, binary, interface="ModelExchange")
    elif kind == "no_binary":
        make_fmu(p, binary, with_binary=False)
    elif kind == "fmi1":
        make_fmu(p, binary, version="1.0")
    elif kind == "no_binary_fmi3":
        make_fmu(p, binary, version="3.0", with_binary=False)
    return p


@pytest.mark.parametrize(
    ("kind", "expected"),
    [
        ("missing", "FMU file not found"),
        ("not_a_zip", "not a zip archive"),
        ("no_model_description", "no modelDescription.xml"),
        ("malformed_xml", "malformed modelDescription.xml"),
        ("model_exchange", "no co-simulation interface"),
        ("no_binary", "no binary for this platform"),
        ("fmi1", "FMI version '1.0' is not supported"),
        ("no_binary_fmi3", f"expected binaries/{fmpy.platform_tuple}/pi_controller"),
    ],
)
def test_unusable_fmu_is_one_line(
    kind: str, expected: str, fmu_binary: dict[str, Path], tmp_path: Path
) -> None:
    path = _broken(kind, fmu_binary, tmp_path)
    with pytest.raises(FmuError) as err:
        check_fmu(settings(path))
    assert expected in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"inputs": {"generator_speed_rad_s": "GenSpeed"}}, "no such SensorFrame field"),
        ({"inputs": {"generator_speed_measured_rad_s": "GenSped"}}, "did you mean 'GenSpeed'"),
        ({"inputs": {"generator_speed_measured_rad_s": "PitchCmd"}}, "expected 'input'"),
        ({"inputs": {"wind_speed_measured_m_s": "GenSpeed"}}, "unit 'rpm'"),
        ({"inputs": {"wind_speed_measured_m_s": "Wind"}, "units": {}}, "declares no unit"),
        (
            {"outputs": {"blade_pitch_commanded_rad": "PitchCmd"}},
            "generator_torque_commanded_nm missing",
        ),
        ({"outputs": {**SETTINGS["outputs"], "regime": "PitchInt"}}, "expected Integer"),  # type: ignore[dict-item]
        (
            {"outputs": {**SETTINGS["outputs"], "pitch_integrator_rad": "GenSpeed"}},
            "expected 'output'",
        ),  # type: ignore[dict-item]
        ({"start_values": {"Kp": "fast"}}, "is Real, expected a value"),
        ({"start_values": {"PitchCmd": 1.0}}, "cannot be set"),
    ],
)
def test_wrong_mapping_is_one_line(change: dict, expected: str, pi_fmu: Path) -> None:
    with pytest.raises(FmuError) as err:
        check_fmu(settings(pi_fmu, **change))
    assert expected in str(err.value) and "\n" not in str(err.value)


def _scenario_text(fmu: str, extra: str = "") -> str:
    """The example scenario (tests/fmu_src/fmu-pi.toml) with another FMU path and more
    ``[controller.settings]`` tables after its last one."""
    text = (SRC / "fmu-pi.toml").read_text()
    return text.replace('fmu = "pi_controller.fmu"', f'fmu = "{fmu}"') + "\n" + extra


def test_scenario_settings_validate_and_paths_resolve(pi_fmu: Path, tmp_path: Path) -> None:
    """Settings are validated where the scenario is read; a relative fmu path is taken from
    the scenario file's folder."""
    (tmp_path / "sub").mkdir()
    shutil.copy(pi_fmu, tmp_path / "sub" / "pi.fmu")
    path = tmp_path / "sub" / "s.toml"
    path.write_text(_scenario_text("pi.fmu"))
    sc = load_scenario(str(path))
    assert sc.controller.base_dir == str(tmp_path / "sub")
    with pytest.raises(ScenarioError, match=r"controller\.settings"):
        parse_scenario(
            _scenario_text("pi.fmu").replace(
                "[controller.settings.inputs]", "[controller.settings.bogus]"
            )
        )
    with pytest.raises(ScenarioError, match="takes no settings"):
        parse_scenario(
            'name = "x"\nturbine = "nrel5mw"\n[wind]\nkind = "steady"\nspeed_m_s = 8.0\n'
            '[controller.settings]\nfmu = "a.fmu"\n'
        )


# ----------------------------------------------------------------------------- runs
def _sensors_rows(sensors: list[dict]) -> list[SensorFrame]:
    return [SensorFrame(**{k: m[k] for k in SensorFrame.__struct_fields__}) for m in sensors]


@pytest.mark.e2e
@pytest.mark.parametrize(
    ("version", "mode"), [("2.0", "lockstep"), ("2.0", "inprocess"), ("3.0", "lockstep")]
)
def test_run_equals_python_law_replayed(
    version: str, mode: str, pi_fmus: dict[str, Path], tmp_path: Path
) -> None:
    """(b) A 20 s run with a trimmed start (lock-step: plant, FMU controller and recorder
    processes over Zenoh; in-process: the settling run and the run in one process): every
    recorded command equals the Python law replayed on the recorded sensor frames to 1e-9."""
    shutil.copy(pi_fmus[version], tmp_path / "pi.fmu")
    scenario = tmp_path / "fmu-pi.toml"
    scenario.write_text(_scenario_text("pi.fmu"))
    out = tmp_path / "run"
    args = ["--mode", mode, "--duration", "20", "--out", str(out), "--no-plots"]
    r = fowt("run", str(scenario), *args, cwd=REPO, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    run = read_run(out / "run.mcap")
    sensors = _sensors_rows(run.topic("sensors"))
    commands = run.topic("command")
    dt = load_scenario(str(scenario)).timing.control_period_s
    assert len(sensors) == len(commands) == round(20 / dt)
    law = PiLaw()
    state = law.initial_state()
    for f, c in zip(sensors, commands, strict=True):
        assert c["answered_seq"] == f.seq
        state, o = law.step(state, f, dt)
        assert abs(c["blade_pitch_commanded_rad"] - o.blade_pitch_commanded_rad) < TOL
        assert abs(c["generator_torque_commanded_nm"] - o.generator_torque_commanded_nm) < TOL
    pitch = [c["blade_pitch_commanded_rad"] for c in commands]
    assert max(pitch) > 0.05  # region 3 at 16 m/s: the PI is working


@pytest.mark.e2e
def test_fowt_run_refuses_bad_fmu_and_mapping_before_start(
    fmu_binary: dict[str, Path], tmp_path: Path
) -> None:
    """A malformed FMU and a wrong mapping: one line on stderr, exit 2, no run folder."""
    _broken("no_model_description", fmu_binary, tmp_path)
    make_fmu(tmp_path / "good.fmu", fmu_binary)
    cases = {
        "bad.toml": (_scenario_text("no_model_description.fmu"), "no modelDescription.xml"),
        "map.toml": (
            _scenario_text("good.fmu").replace('"GenSpeed"', '"GenSpeedX"'),
            "FMU has no variable 'GenSpeedX'",
        ),
    }
    for name, (text, expected) in cases.items():
        (tmp_path / name).write_text(text)
        out = tmp_path / f"out-{name}"
        r = fowt("run", str(tmp_path / name), "--mode", "lockstep", "--out", str(out), cwd=REPO)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert r.returncode == 2, r.stderr
        assert len(lines) == 1 and expected in lines[0] and "kind 'fmu'" in lines[0], r.stderr
        assert not out.exists()


@pytest.mark.e2e
def test_fowt_run_ends_when_dostep_fails(fmu_binary: dict[str, Path], tmp_path: Path) -> None:
    """An FMU whose doStep returns fmi2Error at t >= 2 s is a controller fault (exit 7) of a
    lock-step run, and the verdict names the FMU, the time and the status. (Untrimmed
    start: the failure comes in the controller process's run, not in a settling run.)"""
    make_fmu(tmp_path / "pi.fmu", fmu_binary)
    scenario = tmp_path / "fail.toml"
    extra = "[controller.settings.start_values]\nFailTime = 2.0\n[initial]\ntrim = false\n"
    scenario.write_text(_scenario_text("pi.fmu", extra))
    r = fowt(
        "run",
        str(scenario),
        "--mode",
        "lockstep",
        "--duration",
        "10",
        "--out",
        str(tmp_path / "run"),
        "--no-plots",
        cwd=REPO,
        timeout=600,
    )
    assert r.returncode == 7, (r.stdout + r.stderr)[-3000:]
    text = r.stdout + r.stderr
    assert "controller_fault (exit 7): controller raised FmuStepError(" in text, text[-3000:]
    assert "FMU pi.fmu: fmi2DoStep failed at t = 2.000 s: status 3 (error)" in text, text[-3000:]


def test_no_plant_import() -> None:
    """The FMU core is a controller module: it never imports the plant."""
    src = (REPO / "controller" / "fmu.py").read_text()
    assert "import plant" not in src and "from plant" not in src
    assert math.isfinite(DT)
