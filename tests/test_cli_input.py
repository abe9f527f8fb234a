"""Bad input on every command: one line naming the key or option, exit 2, nothing written.

Each case runs ``fowt`` in its own process (forked from one interpreter that imported the
CLI once, ``tests/_fowt_forked.py``; three of them also as ``python -m hil`` processes of
their own) in an empty folder holding only the case's input files and checks the exit
code, that stderr is exactly one ``error: ...`` line containing the expected words (the key
or option and what was expected), that there is no traceback, and that nothing appeared in
the folder (no output folder, no default ``runs/``). Every case fails at validation, before
a process, a bus or a file is opened, so each takes well under a second of CPU.

The rest: the CLI's listings (``fowt scenarios`` never truncates a name, every shipped
scenario has a description, ``fowt presets``), a shipped name winning over a stray folder,
``analyze forecast`` as a table or JSON, and the help texts.
"""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import pytest
from _helpers import fowt, fowt_forked

from hil.scenario.schema import load_scenario, scenario_text, shipped_scenarios

REPO = Path(__file__).resolve().parents[1]

#: Random bytes that are not UTF-8 (0xff never occurs in UTF-8) and hold a NUL.
BINARY = bytes([0xFF, 0xFE, 0x00, 0x81]) + bytes(range(256)) * 4


def _fowt(
    args: list[str], cwd: Path, timeout: float = 120.0, columns: int = 80
) -> subprocess.CompletedProcess[str]:
    return fowt(*args, timeout=timeout, cwd=cwd, columns=columns)


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def _variant(name: str, old: str, new: str) -> str:
    text, _ = scenario_text(name)
    assert old in text, old
    return text.replace(old, new, 1)


#: Scenario files written into the case's folder: file name -> contents.
INPUTS: dict[str, str | bytes] = {
    "binary.toml": BINARY,
    "dur_inf.toml": _variant("nrel5mw-ramp", "duration_s = 60.0", "duration_s = inf"),
    "dur_nan.toml": _variant("nrel5mw-ramp", "duration_s = 60.0", "duration_s = nan"),
    "dur_neg.toml": _variant("nrel5mw-ramp", "duration_s = 60.0", "duration_s = -5.0"),
    "dur_zero.toml": _variant("nrel5mw-ramp", "duration_s = 60.0", "duration_s = 0.0"),
    "dur_str.toml": _variant("nrel5mw-ramp", "duration_s = 60.0", 'duration_s = "60"'),
    "dur_huge.toml": _variant("nrel5mw-ramp", "duration_s = 60.0", "duration_s = 1e12"),
    "hs_inf.toml": _variant("default", "hs_m = 1.7", "hs_m = inf"),
    "hs_nan.toml": _variant("default", "hs_m = 1.7", "hs_m = nan"),
    "hs_neg.toml": _variant("default", "hs_m = 1.7", "hs_m = -1.7"),
    "hs_huge.toml": _variant("default", "hs_m = 1.7", "hs_m = 1e6"),
    "period_zero.toml": _variant(
        "nrel5mw-ramp", "control_period_s = 0.01", "control_period_s = 0.0"
    ),
    "wind_neg.toml": _variant("nrel5mw-ramp", "initial_m_s = 8.0", "initial_m_s = -8.0"),
    "seed_neg.toml": _variant("nrel5mw-ramp", "seed = 7", "seed = -7"),
    "std_nan.toml": _variant(
        "nrel5mw-ramp", "blade_pitch_std_rad = 0.0005", "blade_pitch_std_rad = nan"
    ),
    "channel_inf.toml": _variant(
        "nrel5mw-ramp",
        "[controller]",
        "[sensors.channels.generator_speed_measured_rad_s]\nstd = -inf\n\n[controller]",
    ),
    "fault_inf.toml": _variant(
        "nrel5mw-ramp",
        "[controller]",
        '[[faults]]\nkind = "dropout"\nchannel = "blade_pitch_measured_rad"\nstart_s = inf\n\n'
        "[controller]",
    ),
    "turbine.toml": _variant("nrel5mw-ramp", 'turbine = "nrel5mw"', 'turbine = "nrel5"'),
    "ctl_preset.toml": _variant("nrel5mw-ramp", 'preset = "nrel5mw_baseline"', 'preset = "x"'),
    "kind_preset.toml": _variant(
        "nrel5mw-ramp", 'preset = "nrel5mw_baseline"', 'preset = "iea15mw_advanced"'
    ),
    "platform.toml": _variant("default", 'platform = "iea15mw_volturnus"', 'platform = "p.toml"'),
    "bad.json5": "{ listen: ",
    "wind_kind.toml": _variant("nrel5mw-ramp", 'kind = "ramp"', 'kind = "rmap"'),
    "can_iface.toml": _variant(
        "nrel5mw-ramp", "[controller]", '[can]\ninterface = "socketcn"\n\n[controller]'
    ),
    "rel_preset.toml": _variant(
        "nrel5mw-ramp", 'preset = "nrel5mw_baseline"', 'preset = "presets/mine.toml"'
    ),
    "rosco_lib.toml": _variant(
        "nrel5mw-ramp",
        'kind = "baseline"\npreset = "nrel5mw_baseline"',
        'kind = "rosco"\npreset = "nrel5mw"\nlibrary = "build/libdiscon.so"',
    ),
    "rosco_in.toml": _variant(
        "nrel5mw-ramp",
        'kind = "baseline"\npreset = "nrel5mw_baseline"',
        'kind = "rosco"\npreset = "nrel5mw"\nparameter_file = "bad.json5"',
    ),
}

#: A CAN netdevice no host has (socketcan refusals).
NO_CAN = "fowtnocan7"
NO_SOCKETCAN = ["--transport", "can", "--can-interface", "socketcan", "--can-channel", NO_CAN]
#: A lock-step run on CAN (the options of each case follow).
CAN_RUN = ["run", "nrel5mw-ramp", "--mode", "lockstep", "--transport", "can", "--out", "out"]

RUN = ["run", "--mode", "inprocess", "--out", "out"]

#: (case id, arguments, words the one error line must contain).
CASES: list[tuple[str, list[str], list[str]]] = [
    # scenario files
    ("binary-scenario", [*RUN[:1], "binary.toml", *RUN[1:]], ["binary.toml", "UTF-8", "binary"]),
    ("duration-inf", ["run", "dur_inf.toml", *RUN[1:]], ["'duration_s'", "finite", "inf"]),
    ("duration-nan", ["run", "dur_nan.toml", *RUN[1:]], ["'duration_s'", "finite", "nan"]),
    ("duration-negative", ["run", "dur_neg.toml", *RUN[1:]], ["'duration_s'", "> 0"]),
    ("duration-zero", ["run", "dur_zero.toml", *RUN[1:]], ["'duration_s'", "> 0"]),
    ("duration-wrong-type", ["run", "dur_str.toml", *RUN[1:]], ["'duration_s'", "float", "str"]),
    ("duration-too-long", ["run", "dur_huge.toml", *RUN[1:]], ["'duration_s'", "<= 604800"]),
    ("hs-inf", ["run", "hs_inf.toml", *RUN[1:]], ["'waves.hs_m'", "finite", "inf"]),
    ("hs-nan", ["run", "hs_nan.toml", *RUN[1:]], ["'waves.hs_m'", "finite", "nan"]),
    ("hs-negative", ["run", "hs_neg.toml", *RUN[1:]], ["'waves.hs_m'", "> 0"]),
    ("hs-huge", ["run", "hs_huge.toml", *RUN[1:]], ["'waves.hs_m'", "<= 30"]),
    (
        "control-period-zero",
        ["run", "period_zero.toml", *RUN[1:]],
        ["'timing.control_period_s'", ">= 0.001"],
    ),
    ("wind-negative", ["run", "wind_neg.toml", *RUN[1:]], ["'wind.initial_m_s'", ">= 0"]),
    ("seed-negative", ["run", "seed_neg.toml", *RUN[1:]], ["'sensors.seed'", ">= 0"]),
    ("std-nan", ["run", "std_nan.toml", *RUN[1:]], ["'sensors.blade_pitch_std_rad'", "finite"]),
    (
        "channel-table-inf",
        ["run", "channel_inf.toml", *RUN[1:]],
        ["'sensors.channels.generator_speed_measured_rad_s.std'", "finite"],
    ),
    ("fault-start-inf", ["run", "fault_inf.toml", *RUN[1:]], ["'faults[0].start_s'", "finite"]),
    ("turbine-unknown", ["run", "turbine.toml", *RUN[1:]], ["turbine = 'nrel5'", "nrel5mw"]),
    ("controller-preset", ["run", "ctl_preset.toml", *RUN[1:]], ["controller.preset = 'x'"]),
    (
        "controller-preset-of-another-kind",
        ["run", "kind_preset.toml", *RUN[1:]],
        ["controller.preset = 'iea15mw_advanced' for kind 'baseline'"],
    ),
    (
        "platform-file-missing",
        ["run", "platform.toml", *RUN[1:]],
        ["platform = 'p.toml'", "not found", "p.toml", "scenario file's folder"],
    ),
    (
        "preset-file-missing-relative",
        ["run", "rel_preset.toml", *RUN[1:]],
        ["controller.preset = 'presets/mine.toml'", "not found", "/presets/mine.toml"],
    ),
    (
        "rosco-library-missing",
        ["run", "rosco_lib.toml", *RUN[1:]],
        ["controller.library = 'build/libdiscon.so'", "not found", "/build/libdiscon.so"],
    ),
    (
        "rosco-parameter-file-malformed",
        ["run", "rosco_in.toml", *RUN[1:]],
        ["controller.parameter_file", "bad.json5", "kind 'rosco'"],
    ),
    ("scenario-missing", ["run", "nope.toml", *RUN[1:]], ["nope.toml", "does not exist"]),
    (
        "scenario-unknown-name",
        ["run", "no-such-scenario", *RUN[1:]],
        ["no-such-scenario", "'fowt scenarios' lists"],
    ),
    ("scenario-near-miss", ["run", "defualt", *RUN[1:]], ["'defualt'", "did you mean 'default'?"]),
    (
        "hexicon-scenario-near-miss",
        ["run", "hexicon-s1_turbulnt", "--out", "out"],
        ["'hexicon-s1_turbulnt'", "did you mean 'hexicon-s1_turbulent'?"],
    ),
    (
        "enum-near-miss",
        ["run", "wind_kind.toml", *RUN[1:]],
        ["'wind.kind'", "'rmap'", "did you mean 'ramp'?"],
    ),
    (
        "enum-near-miss-can-interface",
        ["run", "can_iface.toml", *RUN[1:]],
        ["'can.interface'", "did you mean 'socketcan'?"],
    ),
    (
        "turbine-near-miss",
        ["run", "turbine.toml", *RUN[1:]],
        ["turbine = 'nrel5'", "did you mean 'nrel5mw'?"],
    ),
    # transport, interface, channel, device: refused before anything starts
    (
        "run-socketcan-no-device",
        [*CAN_RUN, "--can-interface", "socketcan", "--can-channel", NO_CAN],
        [f"socketcan device '{NO_CAN}' does not exist", "use --can-interface udp_multicast"],
    ),
    (
        "run-can-virtual",
        [*CAN_RUN, "--can-interface", "virtual"],
        ["--can-interface virtual", "one process", "udp_multicast"],
    ),
    (
        "run-can-interface-unknown",
        [*CAN_RUN, "--can-interface", "socketcn"],
        ["'socketcn'", "did you mean 'socketcan'?"],
    ),
    (
        "run-can-channel-not-a-group",
        [*CAN_RUN, "--can-interface", "udp_multicast", "--can-channel", "127.0.0.1"],
        ["udp_multicast channel '127.0.0.1'", "multicast group"],
    ),
    (
        "run-can-inprocess",
        ["run", "nrel5mw-ramp", "--transport", "can", *RUN[1:]],
        ["--mode inprocess has no bus", "lockstep or realtime"],
    ),
    (
        "hexicon-socketcan-no-device",
        ["run", "hexicon-s1_step15", *NO_SOCKETCAN, "--out", "out"],
        [f"socketcan device '{NO_CAN}' does not exist", "use --can-interface udp_multicast"],
    ),
    (
        "plant-socketcan-no-device",
        ["plant", "nrel5mw-ramp", "--insecure", *NO_SOCKETCAN],
        [f"socketcan device '{NO_CAN}' does not exist"],
    ),
    (
        "controller-socketcan-no-device",
        ["controller", "nrel5mw-ramp", "--insecure", *NO_SOCKETCAN],
        [f"socketcan device '{NO_CAN}' does not exist"],
    ),
    # campaign options
    (
        "campaign-duration-nan",
        ["campaign", "al2019-iea15mw", "--duration", "nan", "--out", "out"],
        ["'--duration'", "finite", "nan"],
    ),
    (
        "campaign-seeds-negative",
        ["campaign", "al2019-iea15mw", "--seeds", "-1", "--out", "out"],
        ["'--seeds'", "1"],
    ),
    (
        "campaign-workers-zero",
        ["campaign", "al2019-iea15mw", "--workers", "0", "--out", "out"],
        ["'--workers'", "1"],
    ),
    (
        "campaign-record",
        ["campaign", "al2019-iea15mw", "--record", "all", "--out", "out"],
        ["'--record'", "mcap"],
    ),
    # run options
    (
        "run-duration-nan",
        ["run", "nrel5mw-ramp", "--duration", "nan", *RUN[1:]],
        ["'--duration'", "finite", "nan"],
    ),
    (
        "run-duration-inf",
        ["run", "nrel5mw-ramp", "--duration", "inf", *RUN[1:]],
        ["'--duration'", "finite", "inf"],
    ),
    (
        "run-duration-negative",
        ["run", "nrel5mw-ramp", "--duration", "-5", *RUN[1:]],
        ["'--duration'", "> 0", "-5"],
    ),
    (
        "run-duration-zero",
        ["run", "nrel5mw-ramp", "--duration", "0", *RUN[1:]],
        ["'--duration'", "> 0"],
    ),
    (
        "run-duration-text",
        ["run", "nrel5mw-ramp", "--duration", "abc", *RUN[1:]],
        ["'--duration'", "not a valid"],
    ),
    (
        "run-speed-zero",
        ["run", "nrel5mw-ramp", "--speed", "0", "--out", "out"],
        ["'--speed'", "> 0"],
    ),
    (
        "run-speed-nan",
        ["run", "nrel5mw-ramp", "--speed", "nan", "--out", "out"],
        ["'--speed'", "finite"],
    ),
    (
        "run-mode",
        ["run", "nrel5mw-ramp", "--mode", "fast", "--out", "out"],
        ["'--mode'", "lockstep"],
    ),
    (
        "run-transport",
        ["run", "nrel5mw-ramp", "--transport", "udp", "--out", "out"],
        ["'--transport'", "zenoh"],
    ),
    (
        "run-priority",
        ["run", "nrel5mw-ramp", "--realtime-priority", "99", "--out", "out"],
        ["'--realtime-priority'"],
    ),
    (
        "run-out-unwritable",
        ["run", "nrel5mw-ramp", "--mode", "inprocess", "--out", "/proc/fowt-out"],
        ["'--out'", "not writable"],
    ),
    (
        "run-out-under-a-file",
        ["run", "nrel5mw-ramp", "--mode", "inprocess", "--out", "bad.json5/out"],
        ["'--out'", "is a file"],
    ),
    ("run-unknown-option", ["run", "nrel5mw-ramp", "--bogus"], ["--bogus"]),
    # the other process commands
    (
        "plant-wait-timeout",
        ["plant", "nrel5mw-ramp", "--wait-timeout", "-1"],
        ["'--wait-timeout'", ">= 0"],
    ),
    (
        "plant-wait-timeout-nan",
        ["plant", "nrel5mw-ramp", "--wait-timeout", "nan"],
        ["'--wait-timeout'", "finite"],
    ),
    (
        "plant-require",
        ["plant", "nrel5mw-ramp", "--require", "controler"],
        ["'--require'", "controller"],
    ),
    ("plant-duration", ["plant", "dur_nan.toml"], ["'duration_s'", "finite"]),
    (
        "plant-zenoh-config-binary",
        ["plant", "nrel5mw-ramp", "--zenoh-config", "binary.toml"],
        ["'--zenoh-config'", "binary"],
    ),
    (
        "plant-zenoh-config-missing",
        ["plant", "nrel5mw-ramp", "--zenoh-config", "none.json5"],
        ["'--zenoh-config'", "existing file"],
    ),
    (
        "plant-zenoh-config-invalid",
        ["plant", "nrel5mw-ramp", "--zenoh-config", "bad.json5"],
        ["--zenoh-config", "not a valid Zenoh config"],
    ),
    (
        "controller-duration",
        ["controller", "nrel5mw-ramp", "--duration", "inf"],
        ["'--duration'", "finite"],
    ),
    ("controller-scenario", ["controller", "hs_inf.toml"], ["'waves.hs_m'", "finite"]),
    (
        "record-out-unwritable",
        ["record", "nrel5mw-ramp", "--out", "/proc/fowt.mcap"],
        ["'--out'", "not writable"],
    ),
    ("record-out-folder", ["record", "nrel5mw-ramp", "--out", "."], ["'--out'", "is a folder"]),
    (
        "record-run-info-list",
        ["record", "nrel5mw-ramp", "--out", "r.mcap", "--run-info", "[1]"],
        ["'--run-info'", "JSON object"],
    ),
    (
        "record-run-info-invalid",
        ["record", "nrel5mw-ramp", "--out", "r.mcap", "--run-info", "{"],
        ["'--run-info'", "not valid JSON"],
    ),
    # offline commands
    (
        "modes-wind-nan",
        ["analyze", "modes", "iea15mw_volturnus", "--wind", "nan"],
        ["'--wind'", "finite"],
    ),
    (
        "modes-wind-negative",
        ["analyze", "modes", "iea15mw_volturnus", "--wind", "-1"],
        ["'--wind'", ">= 0"],
    ),
    (
        "linear-wind-zero",
        ["analyze", "linear", "iea15mw_volturnus", "--wind", "0"],
        ["'--wind'", "> 0"],
    ),
    ("modes-binary-preset", ["analyze", "modes", "binary.toml"], ["binary.toml"]),
    ("damping-map-binary-preset", ["analyze", "damping-map", "binary.toml"], ["binary.toml"]),
    (
        "linear-wind-inf",
        ["analyze", "linear", "iea15mw_volturnus", "--wind", "inf"],
        ["'--wind'", "finite"],
    ),
    ("forecast-hs-inf", ["analyze", "forecast", "--hs", "inf"], ["'--hs'", "finite"]),
    ("forecast-tp-zero", ["analyze", "forecast", "--tp", "0"], ["'--tp'", "> 0"]),
    (
        "forecast-distance-negative",
        ["analyze", "forecast", "--distance", "-1"],
        ["'--distance'", ">= 0"],
    ),
    (
        "forecast-horizon-nan",
        ["analyze", "forecast", "--horizon", "nan"],
        ["'--horizon'", "finite"],
    ),
    ("run-loop-unknown", [*RUN, "--loop", "fast"], ["'--loop'", "auto, compiled, python"]),
    (
        "run-loop-not-inprocess",
        ["run", "--mode", "lockstep", "--loop", "compiled", "--out", "out"],
        ["--loop compiled", "--mode inprocess"],
    ),
    ("design-period-nan", ["design", "--control-period", "nan"], ["'--control-period'", "finite"]),
    ("design-period-too-long", ["design", "--control-period", "2"], ["'--control-period'", "<= 1"]),
    (
        "design-out-unwritable",
        ["design", "--out", "/proc/fowt-designs"],
        ["'--out'", "not writable"],
    ),
    ("import-binary-deck", ["preset", "import-openfast", "binary.toml"], ["binary"]),
    (
        "import-missing-deck",
        ["preset", "import-openfast", "deck.fst"],
        ["deck.fst", "existing file"],
    ),
    (
        "import-out-unwritable",
        ["preset", "import-openfast", "bad.json5", "--out", "/proc/fowt-presets"],
        ["'--out'", "not writable"],
    ),
]


def _case_folder(root: Path) -> Path:
    """An empty folder holding only the cases' input files."""
    root.mkdir(parents=True)
    for name, content in INPUTS.items():
        path = root / name
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content)
    return root


@pytest.fixture(scope="module")
def forked_results(
    tmp_path_factory: pytest.TempPathFactory,
) -> dict[str, tuple[Path, set[str], subprocess.CompletedProcess[str]]]:
    """Every case run once, each in its own forked ``fowt`` process and folder."""
    root = tmp_path_factory.mktemp("cli-cases")
    folders = [_case_folder(root / case[0]) for case in CASES]
    befores = [_tree(f) for f in folders]
    procs = fowt_forked([(case[1], f) for case, f in zip(CASES, folders, strict=True)])
    return {
        case[0]: (f, before, proc)
        for case, f, before, proc in zip(CASES, folders, befores, procs, strict=True)
    }


#: Cases also run as a ``python -m hil`` process of their own (the console path whole).
OWN_PROCESS = ("scenario-missing", "run-duration-nan", "plant-zenoh-config-invalid")


@pytest.mark.parametrize(
    ("case", "words"), [(c[0], c[2]) for c in CASES], ids=[c[0] for c in CASES]
)
def test_bad_input_is_one_line_exit_2_nothing_written(
    forked_results: dict[str, tuple[Path, set[str], subprocess.CompletedProcess[str]]],
    case: str,
    words: list[str],
) -> None:
    folder, before, proc = forked_results[case]
    _check_one_line_exit_2(folder, before, proc, words)


@pytest.mark.parametrize("case", OWN_PROCESS)
def test_bad_input_in_a_process_of_its_own(tmp_path: Path, case: str) -> None:
    """The same as a separate ``python -m hil`` process: the interpreter's start and exit
    paths too."""
    (args, words) = next(c[1:] for c in CASES if c[0] == case)
    folder = _case_folder(tmp_path / "case")
    before = _tree(folder)
    _check_one_line_exit_2(folder, before, _fowt(args, folder), words)


def _check_one_line_exit_2(
    tmp_path: Path, before: set[str], proc: subprocess.CompletedProcess[str], words: list[str]
) -> None:
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr + proc.stdout
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("error: "), lines[0]
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert proc.stdout == ""
    assert _tree(tmp_path) == before  # no output folder, no runs/, no probe file left


@pytest.mark.parametrize("taken", ["run.mcap", "summary.json"])
def test_a_folder_in_the_logs_place_is_refused_before_any_process(
    tmp_path: Path, taken: str
) -> None:
    """A folder where the run writes its log or summary: one line, exit 2, before the
    recorder (whose start-up takes seconds on a loaded machine) would find out."""
    out = tmp_path / "out"
    (out / taken).mkdir(parents=True)
    proc = _fowt(["run", "nrel5mw-ramp", "--mode", "lockstep", "--out", str(out)], tmp_path)
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert f"{out / taken} is a folder" in lines[0]
    assert not (out / "logs").exists()  # no process was started


def test_a_near_miss_names_the_closest_names_not_every_name(tmp_path: Path) -> None:
    """``fowt run defualt``: the closest shipped names (1-3), never the whole list."""
    for args, meant in (
        (["run", "defualt", "--out", "out"], "default"),
        (["run", "iea15mw-lc", "--out", "out"], "iea15mw-lc7"),
        (["run", "hexicon-s1_step1", "--out", "out"], "hexicon-s1_step15"),
    ):
        proc = _fowt(args, tmp_path)
        assert proc.returncode == 2, proc.stderr
        line = proc.stderr.strip()
        assert "did you mean" in line and f"'{meant}'" in line, line
        names = re.findall(r"'([^']+)'", line.split("did you mean", 1)[1])
        assert 1 <= len(names) <= 3, line
        assert "nrel5mw-tlp" not in line and "casanovas" not in line  # not the whole list


def test_cases_cover_every_command() -> None:
    """The table has a case for each command that takes input (review: its own tests)."""
    commands = {" ".join(a[:2]) if a[0] in ("analyze", "preset") else a[0] for _, a, _ in CASES}
    assert commands >= {
        "run",
        "plant",
        "controller",
        "record",
        "design",
        "analyze modes",
        "analyze linear",
        "analyze forecast",
        "analyze damping-map",
        "preset import-openfast",
    }


# ----------------------------------------------------------------- listings and names


def test_scenarios_lists_every_name_whole_with_a_description(tmp_path: Path) -> None:
    from hil.hexicon.model import load_scenarios as load_hexicon_scenarios

    proc = _fowt(["scenarios"], tmp_path, columns=40)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    names = shipped_scenarios()
    # the single-turbine scenarios, then the Hexicon H3 ones (hexicon-<name>, hil.families)
    platform = [f"hexicon-{n}" for n in load_hexicon_scenarios()]
    assert len(lines) == len(names) + len(platform)  # one line each, whatever the width
    for name, line in zip(names, lines, strict=False):
        assert line.split()[0] == name  # never truncated
        assert load_scenario(name).description.strip(), f"{name} has no description"
        assert load_scenario(name).description in line
    for name, line in zip(platform, lines[len(names) :], strict=True):
        assert line.split()[0] == name and "Hexicon H3" in line
    assert "nrel5mw-tlp" in names


def test_presets_lists_turbines_platforms_and_controllers(tmp_path: Path) -> None:
    proc = _fowt(["presets"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    listed = {ln.split()[0] for ln in proc.stdout.splitlines() if ln.startswith("  ")}
    assert {
        "iea15mw",
        "nrel5mw",
        "iea15mw_volturnus",
        "nrel5mw_tlp",
        "nrel5mw_baseline",
        "iea15mw_baseline",
        "iea15mw_advanced",
    } <= listed
    for preset in ("iea15mw_volturnus", "nrel5mw_tlp"):  # listed names are usable as such
        load_scenario("nrel5mw-tlp")  # the TLP preset has a scenario that loads
        assert preset in proc.stdout


def test_shipped_name_wins_over_a_stray_folder(tmp_path: Path) -> None:
    (tmp_path / "nrel5mw-ramp").mkdir()  # e.g. the output folder of an earlier run
    proc = _fowt(["run", "nrel5mw-ramp", "--duration", "nan"], tmp_path)
    # the scenario resolved (the shipped one): the error is about the option, not the folder
    assert "'--duration'" in proc.stderr and "directory" not in proc.stderr
    (tmp_path / "my-scenario").mkdir()
    proc = _fowt(["run", "my-scenario", "--out", "o"], tmp_path)
    assert proc.returncode == 2
    assert "is a directory" in proc.stderr and "no shipped scenario" in proc.stderr


def test_analyze_forecast_prints_a_table_or_json(tmp_path: Path) -> None:
    args = ["analyze", "forecast", "--horizon", "5", "--duration", "60"]
    args += ["--forecaster", "dispersion"]  # the FIR only: a second or so
    table = _fowt(args, tmp_path, timeout=300, columns=120)
    assert table.returncode == 0, table.stderr
    assert not table.stdout.lstrip().startswith("{")
    for word in ("dispersion", "up-wave gauge", "VAF [%]", "horizon [s]"):
        assert word in table.stdout
    as_json = _fowt([*args, "--json"], tmp_path, timeout=300)
    assert as_json.returncode == 0, as_json.stderr
    report = json.loads(as_json.stdout)
    vaf = report["forecasters"]["dispersion"]["vaf_percent"]
    # the same seeded sea: the table shows the JSON's figure, to one decimal
    assert f"{vaf:.1f}" in table.stdout


def test_modes_table_has_units(tmp_path: Path) -> None:
    proc = _fowt(["analyze", "modes", "nrel5mw_tlp"], tmp_path, columns=120)
    assert proc.returncode == 0, proc.stderr
    assert "damped period [s]" in proc.stdout and "damping ratio [-]" in proc.stdout


COMMANDS = [
    [],
    ["run"],
    ["plant"],
    ["controller"],
    ["record"],
    ["router"],
    ["review"],
    ["recover"],
    ["scenarios"],
    ["presets"],
    ["design"],
    ["campaign"],
    ["compare"],
    ["report"],
    ["analyze"],
    ["analyze", "modes"],
    ["analyze", "linear"],
    ["analyze", "forecast"],
    ["analyze", "damping-map"],
    ["preset", "import-openfast"],
    ["hexicon"],
    ["hexicon", "run"],
    ["hexicon", "campaign"],
    ["hexicon", "identify"],
]


@pytest.mark.parametrize("cmd", COMMANDS, ids=[" ".join(c) or "fowt" for c in COMMANDS])
def test_help_texts_are_clean(cmd: list[str]) -> None:
    from typer.testing import CliRunner  # in process: only the help text is under test

    from hil.cli.fowt import app

    result = CliRunner().invoke(app, [*cmd, "--help"], env={"COLUMNS": "80"})
    assert result.exit_code == 0, result.output
    text = result.output
    assert "``" not in text  # no raw reStructuredText
    assert "<bool>" not in text  # no type shown for flags
    # no cut command summaries (a variadic argument's "runs..." is click's, not a cut)
    summaries = text.split("Commands:")[1] if "Commands:" in text else ""
    assert not [ln for ln in summaries.splitlines() if ln.rstrip().endswith("...")]
    # no markup eaten from the text ("the scenario's [can] interface" once lost "[can]")
    assert "scenario's  " not in text and "scenario's )" not in text


@pytest.mark.parametrize(
    ("why", "said"),
    [
        ("not root", "this process is not root: run it as root, or use --transport zenoh"),
        ("no ip", "ip not found on PATH: install util-linux and iproute2, or use --transport"),
    ],
)
def test_udp_multicast_without_a_namespace_is_refused_exit_2(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, why: str, said: str
) -> None:
    """``--transport can`` on ``udp_multicast`` where no private network namespace can be
    made (not root; ``unshare``/``ip`` missing): one line, exit 2, saying what to use, and
    nothing started or written. In process (CliRunner) to stand in for such a host."""
    from typer.testing import CliRunner

    from hil.cli.fowt import app
    from hil.nodes import can_bus

    monkeypatch.setattr(can_bus, "in_private_netns", lambda: False)
    if why == "not root":
        monkeypatch.setattr(can_bus.os, "geteuid", lambda: 1000)
    else:
        monkeypatch.setattr(can_bus.os, "geteuid", lambda: 0)
        monkeypatch.setattr(can_bus.shutil, "which", lambda tool: None if tool == "ip" else tool)
    monkeypatch.chdir(tmp_path)
    args = ["run", "nrel5mw-ramp", "--mode", "lockstep", "--transport", "can", "--out", "out"]
    for scenario in ("nrel5mw-ramp", "hexicon-s1_step15"):
        args[1] = scenario
        result = CliRunner().invoke(app, args, env={"COLUMNS": "400"})
        assert result.exit_code == 2, result.output
        assert "--can-interface udp_multicast" in result.output and said in result.output
        assert "Traceback" not in result.output
    assert list(tmp_path.iterdir()) == []


def test_run_help_says_refusals_are_exit_2() -> None:
    from typer.testing import CliRunner

    from hil.cli.fowt import app

    text = " ".join(CliRunner().invoke(app, ["run", "--help"]).output.split())
    assert "2 bad input, refused before anything started" in text
    assert "a transport, CAN interface, channel or device this host cannot use" in text
    assert "max_deadline_misses" in text and "scenario file's folder" in text


def test_plant_wait_timeout_default_in_help(tmp_path: Path) -> None:
    proc = _fowt(["plant", "--help"], tmp_path)
    text = " ".join(proc.stdout.split())
    assert re.search(r"--wait-timeout <float> [^\[]*\[default: 120\.0\]", text), text
    assert re.search(r"--require <str> [^\[]*\[default: controller,recorder\]", text), text


# ----------------------------------------------------------------- Zenoh config endpoints


@pytest.mark.parametrize(
    ("command_defaults", "options", "listen", "connect"),
    [
        # no options: the file's endpoints stay (the node's loopback defaults are not applied)
        (
            {"default_listen": ("tcp/127.0.0.1:7447",)},
            {},
            ["tcp/127.0.0.1:17001"],
            ["tcp/127.0.0.1:17002"],
        ),
        (
            {"default_listen": ("tcp/127.0.0.1:7448",), "default_connect": ("tcp/127.0.0.1:7447",)},
            {},
            ["tcp/127.0.0.1:17001"],
            ["tcp/127.0.0.1:17002"],
        ),
        # explicit options replace the file's endpoints
        (
            {"default_listen": ("tcp/127.0.0.1:7447",)},
            {"listen": ["tcp/127.0.0.1:17003"], "connect": ["tcp/127.0.0.1:17004"]},
            ["tcp/127.0.0.1:17003"],
            ["tcp/127.0.0.1:17004"],
        ),
    ],
)
def test_zenoh_config_endpoints_are_kept_unless_given(
    tmp_path: Path,
    command_defaults: dict[str, tuple[str, ...]],
    options: dict[str, list[str]],
    listen: list[str],
    connect: list[str],
) -> None:
    from hil.cli.fowt import _bus
    from hil.nodes.bus import BusConfig

    path = tmp_path / "zenoh.json5"
    path.write_text(
        '{ mode: "peer", listen: { endpoints: ["tcp/127.0.0.1:17001"] },'
        ' connect: { endpoints: ["tcp/127.0.0.1:17002"] },'
        " scouting: { multicast: { enabled: false } } }"
    )
    bus = _bus(
        options.get("listen"), options.get("connect"), path, insecure=True, **command_defaults
    )
    assert isinstance(bus, BusConfig)
    conf = bus.zenoh_config()
    assert json.loads(conf.get_json("listen/endpoints")) == listen
    assert json.loads(conf.get_json("connect/endpoints")) == connect


def test_without_zenoh_config_the_loopback_defaults_apply() -> None:
    from hil.cli.fowt import _bus
    from hil.nodes.bus import BusConfig

    bus = _bus(
        None,
        None,
        None,
        default_listen=("tcp/127.0.0.1:7448",),
        default_connect=("tcp/127.0.0.1:7447",),
        insecure=True,
    )
    assert isinstance(bus, BusConfig)
    assert bus.listen == ("tcp/127.0.0.1:7448",) and bus.connect == ("tcp/127.0.0.1:7447",)


def test_refused_zenoh_session_is_one_line(tmp_path: Path) -> None:
    """A node whose Zenoh session cannot open (here: a client whose only endpoint, a closed
    loopback port, refuses it) ends with one ``error:`` line and exit 1, not a traceback."""
    from hil.nodes.bus import free_tcp_endpoint

    closed = free_tcp_endpoint()  # nothing listens there once the probe socket is closed
    cfg = tmp_path / "client.json5"
    cfg.write_text(
        '{ mode: "client", connect: { endpoints: ["' + closed + '"], timeout_ms: 500,'
        " exit_on_failure: true }, scouting: { multicast: { enabled: false },"
        " gossip: { enabled: false } } }"
    )
    proc = _fowt(["controller", "nrel5mw-ramp", "--zenoh-config", str(cfg), "--insecure"], tmp_path)
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and "Zenoh session did not open" in lines[0], proc.stderr
