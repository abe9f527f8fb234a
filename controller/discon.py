"""A Bladed-style DISCON shared library (ROSCO's ``libdiscon``, or a user's build) via ctypes.

The Bladed external-controller interface is one C function::

    void DISCON(float *avrSWAP, int *aviFAIL, const char *accINFILE,
                const char *avcOUTNAME, char *avcMSG);

``avrSWAP`` is the *swap array* of single-precision records (record ``n`` of the Bladed
manual, appendix A, is element ``n - 1`` here), ``aviFAIL`` the status the library returns
(0: fine, > 0: fine with a warning in ``avcMSG``, < 0: failure, the simulation must stop
with ``avcMSG`` as the error), ``accINFILE`` the parameter file (ROSCO: DISCON.IN) and
``avcOUTNAME`` the simulation's root name (ROSCO strips its extension and writes
``<root>.RO.dbg``, ``.RO.dbg2``, ``.RO.dbg3``, ``.RO.echo`` there). The lengths of the three
strings, NUL included, travel in records 49 (``avcMSG`` capacity), 50 and 51.

One loaded copy is one controller instance
-------------------------------------------
A DISCON library keeps its state in static memory (ROSCO: ``SAVE`` variables), so two
controllers may not share one loaded library, and ROSCO refuses a second first call
(``iStatus`` = 0) on a library it has initialised ("This ROSCO dynamic library has
already been loaded"). ``dlopen`` returns the already-loaded object for a path (and for a
file it has open under another name), so :class:`DisconLibrary` copies the library into a
fresh private temporary folder and loads the copy: every instance has its own static
memory. The original is loaded once per process first (never called), so the copy's
dependencies that its ``RPATH`` finds relative to the original (``$ORIGIN/../../rosco.libs``
for the PyPI wheel) are already resolved by their soname. The copy is deleted once loaded
(the mapping stays).

Fortran output buffering
------------------------
ROSCO writes its debug files through libgfortran, which buffers them. The bench reads the
newest line after every call (ROSCO's wind-speed estimate and state machine, see
:mod:`controller.rosco`), so after every call it asks libgfortran to flush all its units
(``_gfortran_flush_i4(NULL)``, what Fortran's ``FLUSH`` intrinsic calls), when the library
depends on libgfortran. (libgfortran's ``GFORTRAN_UNBUFFERED_ALL`` would need setting
before that library is first loaded into the process, and numpy or scipy may have loaded
the same libgfortran already.)

This module does no I/O other than loading libraries and has no clock.
"""

from __future__ import annotations

import ctypes
import shutil
import tempfile
import threading
from pathlib import Path

__all__ = [
    "MSG_CAPACITY",
    "SWAP_SIZE",
    "DisconError",
    "DisconLibrary",
    "DisconLoadError",
]

#: Swap-array length (records). Bladed's classic array is 85+ records; OpenFAST's extended
#: interface (ROSCO ``Ext_Interface`` = 1) reads the platform block from record 1001 on and
#: ServoDyn allocates a few thousand, so 3000 holds both.
SWAP_SIZE = 3000
#: Capacity of the message buffer (characters, NUL included), passed in record 49.
MSG_CAPACITY = 1025

_ORIGINALS: dict[str, ctypes.CDLL] = {}
_LOAD_LOCK = threading.Lock()


class DisconError(RuntimeError):
    """A DISCON library failed (``aviFAIL`` < 0) or returned an unusable command.

    Attributes
    ----------
    library : str
        The library's path.
    status : int
        ``aviFAIL`` as returned (0 when the failure is the bench's check of the outputs).
    library_message : str
        The library's ``avcMSG`` (empty if none).
    """

    def __init__(self, message: str, library: str = "", status: int = 0, msg: str = "") -> None:
        super().__init__(message)
        self.library = library
        self.status = status
        self.library_message = msg


class DisconLoadError(DisconError, ValueError):
    """The library cannot be loaded: missing file, not a shared library, no ``DISCON``."""


def _load(path: Path) -> ctypes.CDLL:
    """Load a private copy of ``path`` (module docstring); raise DisconLoadError if unusable."""
    key = str(path)
    with _LOAD_LOCK:
        if key not in _ORIGINALS:
            try:
                _ORIGINALS[key] = ctypes.CDLL(key)
            except OSError as exc:
                raise DisconLoadError(
                    f"DISCON library {path} cannot be loaded: {exc}", library=key
                ) from exc
        folder = Path(tempfile.mkdtemp(prefix="fowt-discon-"))
        copy = folder / path.name
        try:
            shutil.copyfile(path, copy)
            return ctypes.CDLL(str(copy))
        except OSError as exc:
            raise DisconLoadError(
                f"DISCON library {path}: its private copy cannot be loaded: {exc}", library=key
            ) from exc
        finally:
            shutil.rmtree(folder, ignore_errors=True)


class DisconLibrary:
    """One instance of a DISCON library: a private loaded copy, its swap array and strings.

    Parameters
    ----------
    library : str or Path
        Path of the shared library (``.so``).
    infile : str or Path
        Parameter file passed as ``accINFILE`` (made absolute).
    outname : str or Path
        Root name passed as ``avcOUTNAME`` (made absolute; ROSCO strips the extension and
        writes its files next to it).

    Raises
    ------
    DisconLoadError
        If the library file is missing, cannot be loaded or has no ``DISCON`` symbol.
    """

    def __init__(self, library: str | Path, infile: str | Path, outname: str | Path) -> None:
        path = Path(library).expanduser().resolve()
        if not path.is_file():
            raise DisconLoadError(f"DISCON library not found: {path}", library=str(path))
        self.path = path
        self._lib = _load(path)
        try:
            fn = self._lib.DISCON
        except AttributeError as exc:
            raise DisconLoadError(
                f"{path} has no DISCON function (not a Bladed-style controller library)",
                library=str(path),
            ) from exc
        fn.restype = None
        fn.argtypes = [
            ctypes.POINTER(ctypes.c_float),
            ctypes.POINTER(ctypes.c_int),
            ctypes.c_char_p,
            ctypes.c_char_p,
            ctypes.c_char_p,
        ]
        self._fn = fn
        flush = getattr(self._lib, "_gfortran_flush_i4", None)  # None: not a gfortran build
        if flush is not None:
            flush.restype = None
            flush.argtypes = [ctypes.c_void_p]
        self._flush = flush
        self.swap = (ctypes.c_float * SWAP_SIZE)()
        self._fail = ctypes.c_int(0)
        self.infile = str(Path(infile).expanduser().resolve()).encode()
        self.outname = str(Path(outname).expanduser().resolve()).encode()
        self._infile_z = self.infile + b"\0"
        self._outname_z = self.outname + b"\0"
        self._msg = ctypes.create_string_buffer(MSG_CAPACITY)
        self.calls = 0

    def call(self) -> tuple[int, str]:
        """Call ``DISCON`` once with the swap array as it is now.

        Records 49-51 (string lengths, NUL included) and 129 (array length) are set here;
        the caller fills the others. ``aviFAIL`` is reset to 0 before the call.

        Returns
        -------
        (int, str)
            ``aviFAIL`` and the library's message (empty when none).
        """
        sw = self.swap
        sw[48] = MSG_CAPACITY
        sw[49] = len(self._infile_z)
        sw[50] = len(self._outname_z)
        sw[128] = SWAP_SIZE
        self._fail.value = 0
        self._msg[0] = b"\0"
        self._fn(sw, ctypes.byref(self._fail), self._infile_z, self._outname_z, self._msg)
        if self._flush is not None:
            self._flush(None)  # every Fortran unit written out (module docstring)
        self.calls += 1
        status = self._fail.value
        msg = "" if status == 0 else self._msg.value.decode("utf-8", "replace").strip()
        return status, msg
