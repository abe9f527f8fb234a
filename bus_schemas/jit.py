"""The compile options every numba kernel of the bench is built with, in one place.

Why here: the plant's, the sensors' and the controller's kernels (and the in-process loop in
:mod:`hil` that composes them) must be compiled alike. Their numbers meet on the bus: a
truth record the plant computes, a measurement the sensors compute from it and a command the
controller computes from that are compared to the last bit by the golden runs, so the
floating-point contract (IEEE operations in the written order, no ``fastmath``) is as much a
shared agreement as a message layout. :mod:`bus_schemas` is the one package every other
package may import without breaking the layering (``plant`` and ``controller`` never import
each other or :mod:`hil`), and this module imports nothing of the bench, so it adds no edge
between them. It declares no message; it is the bench's one place for the options.

Options
-------
* :func:`njit`: ``numba.njit(cache=True)``: compiled on first call, the machine code cached
  on disk beside the source (``__pycache__``) and loaded by every later process.
* :func:`njit_nogil`: the same with ``nogil=True`` (the controller's kernels, which a node may
  call from a thread while another one holds the interpreter).

No ``fastmath``, no ``parallel``: results are bit-for-bit those of the Python expressions the
kernels replace where the order is written out.

Cache keys
----------
numba keys a cached function by its own source file only. A kernel's machine code also
depends on these options (here, in another file) and, for a kernel that composes others
(:func:`hil.inprocess.kernels.run_cycles`), on their files; a change there would leave stale
machine code in use. So every file whose functions are compiled through this module gets a
cache key that also holds the content of this file and of the files named by
:func:`key_cache_by` (SHA-256 of their bytes), through numba's cache locators
(``CacheImpl._locator_classes``): each standard locator is wrapped, placed ahead of the
standard ones in the same order, so ``NUMBA_CACHE_DIR`` and the rest behave as usual.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar, cast

import numba
from numba.core.caching import CacheImpl

__all__ = ["cache_key_files", "key_cache_by", "njit", "njit_nogil"]

_F = TypeVar("_F", bound=Callable[..., Any])

_OWN = Path(__file__).resolve()
#: Source file of compiled functions -> the further files its cache key holds.
_KEYED: dict[Path, tuple[Path, ...]] = {}


def cache_key_files(py_file: str | Path) -> tuple[Path, ...]:
    """The files (beyond ``py_file`` itself) whose content keys the cache of its kernels."""
    return _KEYED.get(Path(py_file).resolve(), ())


def key_cache_by(py_file: str | Path, files: Iterable[Path]) -> None:
    """Key the cache of the kernels defined in ``py_file`` also by the content of ``files``.

    Call it at the top of the module, before its first decorated function.
    """
    _KEYED[Path(py_file).resolve()] = (_OWN, *(Path(f).resolve() for f in files))


def _register(fn: Callable[..., Any]) -> None:
    _KEYED.setdefault(Path(fn.__code__.co_filename).resolve(), (_OWN,))


def njit(fn: _F) -> _F:
    """``numba.njit(cache=True)`` (no fastmath), typed as ``fn``."""
    _register(fn)
    return cast(_F, numba.njit(cache=True)(fn))


def njit_nogil(fn: _F) -> _F:
    """``numba.njit(cache=True, nogil=True)`` (no fastmath), typed as ``fn``."""
    _register(fn)
    return cast(_F, numba.njit(cache=True, nogil=True)(fn))


@functools.cache
def _files_hash(files: tuple[Path, ...]) -> bytes:
    """SHA-256 over the files' bytes (read once a process: sources do not change under it)."""
    h = hashlib.sha256()
    for path in files:
        h.update(path.read_bytes())
    return h.digest()


def _keyed(base: Any) -> Any:
    """``base`` (a numba cache locator) for the registered files only, its source stamp
    extended by the hash of the files their key holds."""

    class _Locator(base):
        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if Path(py_file).resolve() not in _KEYED:
                return None
            return super().from_function(py_func, py_file)

        def get_source_stamp(self) -> Any:
            return (super().get_source_stamp(), _files_hash(cache_key_files(self._py_file)))

    _Locator.__name__ = f"Keyed{base.__name__}"
    _Locator._fowt_keyed = True
    return _Locator


def _install() -> None:
    classes = CacheImpl._locator_classes
    if any(getattr(c, "_fowt_keyed", False) for c in classes):
        return
    classes[:0] = [_keyed(c) for c in classes]


_install()
