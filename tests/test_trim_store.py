"""The on-disk store of settled rotor points (:mod:`hil.inprocess.trim_store`).

A trim read back must be the trim computed (same bits), in another process too; the key
must change with anything that changes the settling run and stay the same for what does
not (a campaign's seeds); a bad entry is recomputed; a scenario whose inputs are not all
known (a preset given by path) is never stored; an unwritable or disabled store costs the
recomputation, never the run.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import msgspec
import pytest

from hil.inprocess import trim_store
from hil.inprocess.trim import settling_scenario
from hil.scenario.schema import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[1]


def _with(scenario: Scenario, **sections: Any) -> Scenario:
    d = msgspec.to_builtins(scenario)
    d.update(sections)
    return msgspec.convert(d, Scenario)


def _encoded(scenario: Scenario) -> bytes:
    return msgspec.json.encode(settling_scenario(scenario))


class _Compute:
    """A settling run's stand-in that counts its calls (the store's logic, not the physics)."""

    def __init__(
        self,
        values: tuple[float, ...] = (0.5629347521144487, 0.0123, 1.25e7, 14.57, 0.0377),
    ) -> None:
        self.values, self.calls = values, 0

    def __call__(self, _encoded: bytes) -> tuple[float, ...]:
        self.calls += 1
        return self.values


@pytest.fixture
def store(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("FOWT_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache" / "trim"


def test_another_process_reads_the_stored_trim(tmp_path: Path) -> None:
    """A real settling run in one process; a second process gets its bits without one."""
    env = {**os.environ, "FOWT_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(ROOT)}
    settle = (
        "from hil.inprocess.trim import settle_rotor\n"
        "from hil.scenario.schema import load_scenario\n"
        "print(repr(settle_rotor(load_scenario('iea15mw-lc2'))))\n"
    )
    first = subprocess.run(
        [sys.executable, "-c", settle], env=env, capture_output=True, text=True, check=True
    )
    entries = list((tmp_path / "cache" / "trim").glob("*.json"))
    assert len(entries) == 1
    stored = json.loads(entries[0].read_text())
    omega, theta = eval(first.stdout)  # the repr of two floats
    assert (stored["rotor_speed_rad_s"], stored["blade_pitch_rad"]) == (omega, theta)
    assert 0.3 < omega < 0.8  # the IEA 15 MW's rotor, rad/s (3-7.6 rpm)
    # the second process may not settle: its settling run is replaced by a failure
    no_settling = (
        "import hil.inprocess.trim as t\n"
        "def _refuse(encoded):\n"
        "    raise SystemExit('settled again instead of reading the store')\n"
        "t._settled = _refuse\n"
    )
    second = subprocess.run(
        [sys.executable, "-c", no_settling + settle],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    assert second.stdout == first.stdout  # repr: the same bits


def test_a_campaigns_seeds_share_one_key_and_the_wind_does_not() -> None:
    sc = load_scenario("iea15mw-lc2")
    reseeded = _with(sc, name="other", sensors={**msgspec.to_builtins(sc.sensors), "seed": 99})
    key = trim_store.store_key(_encoded(sc))
    assert key is not None
    assert trim_store.store_key(_encoded(reseeded)) == key
    faster = _with(sc, wind={"kind": "steady", "speed_m_s": 11.0})
    assert trim_store.store_key(_encoded(faster)) not in (None, key)
    other_controller = load_scenario("iea15mw-lc2-lqri-ff")
    assert trim_store.store_key(_encoded(other_controller)) not in (None, key)


def test_a_users_design_artefact_changes_the_key(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A controller loads a design from ``$FOWT_DESIGN_DIR`` when none is shipped for its
    period: a design made or replaced there is a new key."""
    monkeypatch.setenv("FOWT_DESIGN_DIR", str(tmp_path / "designs"))
    encoded = _encoded(load_scenario("iea15mw-lc2-lqri-ff"))
    without = trim_store.store_key(encoded)
    (tmp_path / "designs").mkdir()
    (tmp_path / "designs" / "iea15mw_volturnus_dt0p05.json").write_text("{}")
    with_design = trim_store.store_key(encoded)
    assert None not in (without, with_design) and with_design != without


def test_a_file_changed_in_a_package_changes_the_fingerprint(tmp_path: Path) -> None:
    (tmp_path / "pkg" / "__pycache__").mkdir(parents=True)
    source = tmp_path / "pkg" / "model.py"
    source.write_text("GAIN = 1.0\n")
    before = trim_store.tree_fingerprint(tmp_path)
    (tmp_path / "pkg" / "__pycache__" / "model.pyc").write_bytes(b"\0")  # bytecode: left out
    assert trim_store.tree_fingerprint(tmp_path) == before
    st = source.stat()
    os.utime(source, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))  # edited, same size
    assert trim_store.tree_fingerprint(tmp_path) != before


def test_stored_then_read_without_computing(store: Path) -> None:
    encoded = _encoded(load_scenario("iea15mw-lc2"))
    compute = _Compute()
    assert trim_store.settled_cached(encoded, "lc2", compute) == compute.values
    assert trim_store.settled_cached(encoded, "lc2", compute) == compute.values
    assert compute.calls == 1
    (entry,) = store.glob("*.json")
    assert json.loads(entry.read_text())["scenario"] == "lc2"
    assert trim_store.entries() == [entry]


@pytest.mark.parametrize(
    "content",
    [
        "{not json",
        "",
        '{"format": 3, "key": "another", "rotor_speed_rad_s": 0.5, "blade_pitch_rad": 0.0, '
        '"generator_torque_nm": 1.0, "platform_surge_m": 14.0, "platform_pitch_rad": 0.03}',
        '{"format": 3, "key": "KEY", "rotor_speed_rad_s": 0.5, "blade_pitch_rad": 0.0, '
        '"generator_torque_nm": 1.0, "platform_surge_m": NaN, "platform_pitch_rad": 0.03}',
        '{"format": 3, "key": "KEY", "rotor_speed_rad_s": "0.5", "blade_pitch_rad": 0.0, '
        '"generator_torque_nm": 1.0, "platform_surge_m": 14.0, "platform_pitch_rad": 0.03}',
        '{"format": 1, "key": "KEY", "rotor_speed_rad_s": 0.5, "blade_pitch_rad": 0.0}',
        # the format before the platform's surge and pitch were kept
        '{"format": 2, "key": "KEY", "rotor_speed_rad_s": 0.5, "blade_pitch_rad": 0.0, '
        '"generator_torque_nm": 1.0}',
        '{"format": 3, "key": "KEY", "rotor_speed_rad_s": 0.5, "blade_pitch_rad": 0.0, '
        '"generator_torque_nm": 1.0}',
        '{"format": 3, "key": "KEY"}',
        "[1, 2]",
    ],
)
def test_a_bad_entry_is_recomputed_and_replaced(store: Path, content: str) -> None:
    encoded = _encoded(load_scenario("iea15mw-lc2"))
    key = trim_store.store_key(encoded)
    assert key is not None
    store.mkdir(parents=True)
    (store / f"{key}.json").write_text(content.replace("KEY", key))
    compute = _Compute()
    assert trim_store.settled_cached(encoded, "lc2", compute) == compute.values
    assert compute.calls == 1
    entry = json.loads((store / f"{key}.json").read_text())
    assert tuple(entry[name] for name in trim_store.VALUES) == compute.values


def test_a_preset_given_by_path_is_not_stored(store: Path, tmp_path: Path) -> None:
    turbine = tmp_path / "my_turbine.toml"
    turbine.write_text((ROOT / "plant" / "presets" / "iea15mw.toml").read_text())
    sc = _with(load_scenario("iea15mw-lc2"), turbine=str(turbine))
    assert trim_store.store_key(_encoded(sc)) is None
    compute = _Compute()
    trim_store.settled_cached(_encoded(sc), "mine", compute)
    trim_store.settled_cached(_encoded(sc), "mine", compute)
    assert compute.calls == 2
    assert not store.exists()


def test_off_computes_every_time_and_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FOWT_CACHE_DIR", "off")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert trim_store.cache_root() is None
    compute = _Compute()
    encoded = _encoded(load_scenario("iea15mw-lc2"))
    trim_store.settled_cached(encoded, "lc2", compute)
    trim_store.settled_cached(encoded, "lc2", compute)
    assert compute.calls == 2
    assert list(tmp_path.iterdir()) == []
    assert trim_store.entries() == []


def test_the_default_location_follows_xdg(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("FOWT_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert trim_store.cache_root() == tmp_path / "fowt-hil"


def test_an_unwritable_store_costs_the_recomputation_not_the_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("FOWT_CACHE_DIR", str(blocker))
    said: list[str] = []
    compute = _Compute()
    encoded = _encoded(load_scenario("iea15mw-lc2"))
    assert trim_store.settled_cached(encoded, "lc2", compute, log=said.append) == compute.values
    assert compute.calls == 1
    assert len(said) == 1 and "not written" in said[0] and str(blocker) in said[0]


def test_fowt_cache_shows_and_clears(tmp_path: Path) -> None:
    env = {
        **os.environ,
        "FOWT_CACHE_DIR": str(tmp_path / "c"),
        "FOWT_DESIGN_DIR": str(tmp_path / "d"),
        "PYTHONPATH": str(ROOT),
    }
    folder = tmp_path / "c" / "trim"
    folder.mkdir(parents=True)
    for name in ("a", "b"):
        (folder / f"{name}.json").write_text("{}")
    fowt = [sys.executable, "-m", "hil"]
    shown = subprocess.run([*fowt, "cache"], env=env, capture_output=True, text=True, check=True)
    assert shown.stdout.splitlines() == [
        f"trim store: {folder}: 2 entries, 4 B",
        f"design artefacts made on first use: {tmp_path / 'd'}: 0 (FOWT_DESIGN_DIR; not "
        "cleared by --clear)",
    ]
    cleared = subprocess.run(
        [*fowt, "cache", "--clear"], env=env, capture_output=True, text=True, check=True
    )
    assert cleared.stdout == f"trim store: {folder}: 2 entries removed\n"
    assert list(folder.iterdir()) == []
