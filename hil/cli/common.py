"""Helpers shared by the ``fowt`` sub-commands: one-line errors and option callbacks.

Bad input on the command line ends a command with one line on stderr, ``error: ...``, naming
the option and what was expected, and exit code 2, before anything is started or written:
number options are checked by :func:`number`, output paths by :func:`writable` (nothing is
created by the check), input text files by :func:`text_file`.
"""

from __future__ import annotations

import difflib
import math
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn

import typer
from rich.console import Console
from rich.text import Text

stderr = Console(stderr=True, soft_wrap=True)


def fail(message: str, code: int = 2) -> NoReturn:
    """Print ``error: message`` as one line on stderr and exit with ``code``.

    The message is plain text (a Text, never parsed as markup): brackets in it, e.g. a
    path or a TOML section, are printed as they are.
    """
    stderr.print(Text.assemble(("error: ", "bold red"), message.replace("\n", " ")))
    raise typer.Exit(int(code))


def os_error_text(exc: OSError, path: object = None) -> str:
    """``<file>: <reason>`` of an OSError (``No space left on device``), no errno digits."""
    where = exc.filename if exc.filename is not None else path
    reason = exc.strerror or str(exc)
    return f"{where}: {reason}" if where is not None else reason


# ----------------------------------------------------------------- option checks


def number(
    unit: str,
    *,
    gt: float | None = None,
    ge: float | None = None,
    le: float | None = None,
) -> Callable[[float | None], float | None]:
    """Callback checking a float option: finite and within the bounds, else a usage error.

    The message (printed by :func:`main` as one line) names the option and what was expected,
    e.g. ``Invalid value for '--duration': expected a finite number > 0 and <= 604800 (s),
    got nan``.
    """
    bounds = " and ".join(
        b
        for b in (
            f"> {gt:g}" if gt is not None else "",
            f">= {ge:g}" if ge is not None else "",
            f"<= {le:g}" if le is not None else "",
        )
        if b
    )
    expected = f"expected a finite number {bounds} ({unit})".replace("  ", " ")

    def check(value: float | None) -> float | None:
        if value is None:
            return None
        ok = math.isfinite(value)
        ok = ok and (gt is None or value > gt) and (ge is None or value >= ge)
        ok = ok and (le is None or value <= le)
        if not ok:
            raise typer.BadParameter(f"{expected}, got {value:g}")
        return value

    return check


def _existing_ancestor(path: Path) -> Path:
    """The nearest ancestor of ``path`` (itself included) that exists."""
    p = path.absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def _probe_writable(folder: Path) -> str | None:
    """Why ``folder`` (an existing directory) cannot take a new file, or None if it can.

    Tries for real (a temporary file, removed at once): permission bits say nothing for root,
    nor about read-only or pseudo file systems.
    """
    try:
        fd, name = tempfile.mkstemp(prefix=".fowt-write-check-", dir=folder)
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(fd)
    os.unlink(name)
    return None


def writable(kind: str) -> Callable[[Path | None], Path | None]:
    """Callback checking an output path: ``kind`` is ``"folder"`` or ``"file"``.

    A folder may exist (as a directory) or not (it is made when the run starts, with its
    parents); a file may exist (as a file) or not. Either way the nearest existing ancestor
    must be a directory that takes a new file. Nothing is left behind by the check.
    """

    def check(path: Path | None) -> Path | None:
        if path is None:
            return None
        if path.exists():
            if kind == "folder" and not path.is_dir():
                raise typer.BadParameter(f"expected a folder, {path} is a file")
            if kind == "file" and path.is_dir():
                raise typer.BadParameter(f"expected a file name, {path} is a folder")
        ancestor = _existing_ancestor(path if kind == "folder" else path.parent)
        if not ancestor.is_dir():
            raise typer.BadParameter(f"cannot create {path}: {ancestor} is a file, not a folder")
        why = _probe_writable(ancestor)
        if why is not None:
            raise typer.BadParameter(f"cannot write {path}: {ancestor} is not writable ({why})")
        return path

    return check


def text_file(path: Path | None) -> Path | None:
    """Callback: an input text file that exists and can be read (no NUL byte in its start)."""
    if path is None:
        return None
    if not path.is_file():
        raise typer.BadParameter(f"expected an existing file, {path} is not one")
    try:
        with path.open("rb") as fh:
            head = fh.read(65536)
    except OSError as exc:
        raise typer.BadParameter(f"cannot read {path} ({exc.strerror or exc})") from exc
    try:
        head.decode("utf-8")
        binary = b"\0" in head
    except UnicodeDecodeError as exc:  # a character cut at the end of the head is fine
        binary = exc.start < len(head) - 3
    if binary:
        raise typer.BadParameter(f"expected a UTF-8 text file, {path} holds binary data")
    return path


def choice(*allowed: str) -> Callable[[str], str]:
    """Callback: one of ``allowed`` (a near miss is told the closest: ``did you mean``)."""

    def check(value: str) -> str:
        if value not in allowed:
            close = difflib.get_close_matches(value, allowed, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise typer.BadParameter(f"expected one of {', '.join(allowed)}, got {value!r}{hint}")
        return value

    return check
