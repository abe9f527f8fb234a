"""Settled rotor points kept on disk between processes: a trim's settling run, once.

A trim (:mod:`hil.inprocess.trim`) is a 300 s settling run of the real plant and controller
core: 0.1-0.3 s in the compiled loop, 1.5 s with ROSCO's DISCON library (the Python loop;
20 s at load average 30), paid by every process that starts a trimmed run: each run of a
campaign, the plant process of every bus run (which then also has to load the controller
core). Its result (:data:`VALUES`: the rotor speed, blade pitch and generator torque, and
the platform's surge and pitch there) is a function of the settling scenario
and of the code and data that compute it, so it is kept here and read back by any later
process.

Key: SHA-256 of

- this store's :data:`FORMAT`;
- the settling scenario's JSON (everything in a scenario that can change the steady
  state: :func:`hil.inprocess.trim.settling_scenario`);
- the stat (relative path, size, modification time in ns) of every file of the packages
  that compute it: ``plant``, ``controller``, ``sensors``, ``bus_schemas`` and ``hil``
  (code, presets, hydrodynamic tables), as numba keys its own cache on a source file's
  stat: an edited file is a new key;
- the versions of Python, numpy and numba and the host CPU (the compiled kernels are
  compiled for it, and may round differently elsewhere);
- for a DISCON controller, the stat of its library;
- the stat of the user's design artefacts (``$FOWT_DESIGN_DIR``), which a controller loads
  when the shipped designs lack its control period.

A scenario that names a turbine, platform or controller preset by path, or a DISCON
parameter file, is not stored: such a file may name further files, whose contents are not
all known here; nor is one whose controller kind is a plug-in (its code is the user's).
It is trimmed once per process, as every scenario is without the store.

Entries are JSON, one file per key; floats are written as their shortest repr, which reads
back to the same bits, so a run from a stored trim is the run from a computed one. A write
goes to a temporary file renamed into place (:func:`os.replace`): concurrent processes
either see a whole entry or none. An entry that cannot be read, or holds another key or a
value that is not a finite number, is recomputed and replaced. The store is a cache: a
directory that cannot be written costs the recomputation, never the run.

Location: ``$FOWT_CACHE_DIR/trim``; without that variable ``$XDG_CACHE_HOME/fowt-hil/trim``
(``~/.cache/fowt-hil/trim``). ``FOWT_CACHE_DIR=off`` turns the store off. ``fowt cache``
shows it, ``fowt cache --clear`` empties it. Written by hand: a five-float memo whose key is
the whole point; a general cache library (joblib's Memory, diskcache) would key on the
call's arguments, not on the code and data behind them.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import json
import math
import os
import platform
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import msgspec

from hil.scenario.schema import Scenario

__all__ = [
    "FORMAT",
    "PACKAGES",
    "VALUES",
    "cache_root",
    "clear",
    "code_fingerprint",
    "entries",
    "settled_cached",
    "store_key",
]

#: Version of the entries' layout and of what the key covers; a change is a new key.
FORMAT = 3
#: The packages whose files (code and data) compute a trim.
PACKAGES = ("plant", "controller", "sensors", "bus_schemas", "hil")


def cache_root() -> Path | None:
    """The bench's cache directory (module docstring), or None when turned off."""
    env = os.environ.get("FOWT_CACHE_DIR")
    if env is not None:
        off = env.strip().lower() in ("", "off", "0", "none")
        return None if off else Path(env.strip()).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME", "").strip()
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "fowt-hil"


def _store_dir() -> Path | None:
    root = cache_root()
    return None if root is None else root / "trim"


def tree_fingerprint(root: Path) -> list[tuple[str, int, int]]:
    """(relative path, size B, modification time ns) of every file under ``root``.

    ``__pycache__`` folders are left out (compiled bytecode follows the sources).
    """
    out: list[tuple[str, int, int]] = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(files):
            path = os.path.join(folder, name)
            st = os.stat(path)
            out.append((os.path.relpath(path, root), st.st_size, st.st_mtime_ns))
    return out


@functools.cache
def code_fingerprint() -> str:
    """SHA-256 over the stat of :data:`PACKAGES`' files and the tool versions (hex)."""
    import numba  # noqa: PLC0415 - loaded by the settling run's kernels anyway
    import numpy as np  # noqa: PLC0415
    from llvmlite import binding  # type: ignore[import-untyped]  # noqa: PLC0415

    h = hashlib.sha256()
    for pkg in PACKAGES:
        spec = importlib.util.find_spec(pkg)
        if spec is None or not spec.submodule_search_locations:
            raise RuntimeError(f"trim store: package {pkg!r} not found")
        h.update(pkg.encode())
        for rel, size, mtime in tree_fingerprint(Path(spec.submodule_search_locations[0])):
            h.update(f"{rel}\0{size}\0{mtime}\n".encode())
    tools = (sys.version, np.__version__, numba.__version__, platform.machine())
    h.update(repr((tools, binding.get_host_cpu_name())).encode())
    return h.hexdigest()


def _shipped(scenario: Scenario) -> bool:
    """True when every preset the scenario names is one shipped with the bench."""
    from hil.scenario.schema import (  # noqa: PLC0415
        package_presets,
        shipped_platforms,
        shipped_turbines,
    )

    c = scenario.controller
    if scenario.turbine not in shipped_turbines() or c.parameter_file is not None:
        return False
    if c.settings:  # e.g. an FMU: a file of the user's, not fingerprinted here
        return False
    if scenario.platform is not None and scenario.platform not in shipped_platforms():
        return False
    if c.kind == "rosco":
        shipped = package_presets("controller", "presets", "rosco", suffix="_DISCON.IN")
    elif c.kind in ("baseline", "lqri", "lqri_ff", "lqr_wave"):
        shipped = package_presets("controller", "presets")
    elif c.kind in ("no_control", "base_torque", "lqr_steady", "lqr_finite", "lqr_overlaid"):
        # the casanovas kinds name a design artefact, a bare name
        return "/" not in c.preset and "." not in c.preset
    else:  # a plug-in's kind: its code is not in the store's key (code_fingerprint)
        return False
    return c.preset in shipped


def _library_stat(scenario: Scenario) -> tuple[str, int, int] | None:
    """The DISCON library's (path, size, mtime ns) for kind ``rosco``; None otherwise."""
    if scenario.controller.kind != "rosco":
        return None
    if scenario.controller.library is not None:
        path = Path(scenario.controller.library)
    else:
        from controller.rosco import default_library  # noqa: PLC0415

        path = default_library()
    st = path.resolve().stat()
    return (str(path.resolve()), st.st_size, st.st_mtime_ns)


def _designs() -> list[tuple[str, int, int]]:
    """The stat of the user's design artefacts (a controller loads one from there when the
    shipped designs lack its control period; :func:`controller.lqri.user_design_dir`)."""
    from controller.lqri import user_design_dir  # noqa: PLC0415

    folder = user_design_dir()
    return tree_fingerprint(folder) if folder.is_dir() else []


def store_key(encoded: bytes) -> str | None:
    """The store's key of a settling scenario's JSON (hex), or None when not storable."""
    scenario = msgspec.json.decode(encoded, type=Scenario)
    if not _shipped(scenario):
        return None
    try:
        library = _library_stat(scenario)
        designs = _designs()
    except (OSError, ValueError):  # no library: the settling run says why
        return None
    h = hashlib.sha256()
    h.update(f"fowt-hil trim store {FORMAT}\n".encode())
    h.update(code_fingerprint().encode())
    h.update(repr((library, designs)).encode())
    h.update(encoded)
    return h.hexdigest()


#: The settled point's entries, in the order :func:`settled_cached` returns them.
VALUES = (
    "rotor_speed_rad_s",
    "blade_pitch_rad",
    "generator_torque_nm",
    "platform_surge_m",
    "platform_pitch_rad",
)


def _read(path: Path, key: str) -> tuple[float, ...] | None:
    try:
        entry = json.loads(path.read_text())
        values = tuple(entry[name] for name in VALUES)
        ok = entry["format"] == FORMAT and entry["key"] == key
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if not ok or not all(isinstance(v, float) and math.isfinite(v) for v in values):
        return None
    return values


def _write(path: Path, key: str, name: str, values: tuple[float, ...]) -> None:
    if len(values) != len(VALUES):
        raise ValueError(f"trim store: expected {len(VALUES)} values ({VALUES}), got {values!r}")
    entry = {
        "format": FORMAT,
        "key": key,
        "scenario": name,
        **dict(zip(VALUES, values, strict=True)),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".json", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            json.dump(entry, fh)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def settled_cached(
    encoded: bytes,
    name: str,
    compute: Callable[[bytes], tuple[float, ...]],
    log: Callable[[str], None] | None = None,
) -> tuple[float, ...]:
    """``compute(encoded)``, read from the store when it holds the key, else stored.

    ``name`` (the scenario's) goes into the entry for a reader of the directory; ``log``
    gets one line when the store cannot be written (the run goes on; default: standard
    error, once a process).
    """
    folder = _store_dir()
    key = None if folder is None else store_key(encoded)
    if folder is None or key is None:
        return compute(encoded)
    path = folder / f"{key}.json"
    hit = _read(path, key)
    if hit is not None:
        return hit
    values = compute(encoded)
    try:
        _write(path, key, name, values)
    except OSError as exc:
        line = f"trim store: {folder} not written ({exc}); trims are recomputed"
        if log is not None:
            log(line)
        elif not _warned:
            _warned.append(folder)
            print(line, file=sys.stderr)
    return values


_warned: list[Path] = []  # the stores this process has said it cannot write


def entries() -> list[Path]:
    """The stored entries' files (empty when the store is off or empty)."""
    folder = _store_dir()
    if folder is None or not folder.is_dir():
        return []
    return sorted(folder.glob("*.json"))


def clear() -> int:
    """Remove every stored entry; return how many were removed."""
    removed = 0
    for path in entries():
        path.unlink(missing_ok=True)
        removed += 1
    return removed
