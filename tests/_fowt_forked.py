"""Run many ``fowt`` commands in forked children of one interpreter (a test helper).

``python tests/_fowt_forked.py`` reads ``{"columns": N, "cases": [{"args", "cwd", "out",
"err"}, ...]}`` as JSON on stdin, imports the CLI once, and runs each case in a child
process forked from that interpreter: the child changes to the case's folder, sends its
file descriptors 1 and 2 to the case's files and calls the ``fowt`` command's body
(:func:`hil.cli.fowt.main`, which the console script and ``python -m hil`` run through
:func:`hil.cli.fowt.entry`) with the case's arguments, then leaves by ``os._exit`` (the
exit handlers it inherited are the parent's: none runs in the child). It prints the exit
codes as a JSON list. Each child is a real process with its own exit code, streams and
working folder; what it skips is the interpreter's start and the imports (about 1.5 s per
command, 2-3 s on a loaded machine), which made the validation cases of
``tests/test_cli_input.py`` the suite's slowest file.
"""

from __future__ import annotations

import importlib
import json
import os
import sys
import traceback

#: Modules the validation paths import lazily (measured: sys.modules after a case).
PRELOAD = (
    "hil.launch",
    "hil.review.core",
    "hil.runlog.mcap_io",
    "hil.inprocess.trim",
    "hil.families",
    "controller.rosco",
    "bus_schemas.ros2",
    "bus_schemas.can_codec",
    "bus_schemas.can_db",
    "can",
    "cantools",
)


def _child(case: dict[str, object], fowt_main: object) -> int:
    """The child's side: the case's folder and streams, then the command's exit code."""
    os.chdir(str(case["cwd"]))
    for fd, key in ((1, "out"), (2, "err")):
        f = os.open(str(case[key]), os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(f, fd)
        os.close(f)
    try:
        fowt_main(list(case["args"]))  # type: ignore[operator, call-overload]
    except SystemExit as exc:
        if exc.code is None:
            return 0
        if isinstance(exc.code, int):
            return exc.code
        print(exc.code, file=sys.stderr)  # sys.exit("message"), as the interpreter does
        return 1
    except BaseException:  # an uncaught exception: its traceback and exit 1, as Python does
        traceback.print_exc()
        return 1
    return 0


def main() -> None:
    spec = json.load(sys.stdin)
    os.environ["COLUMNS"] = str(spec["columns"])  # before rich's consoles are made
    from hil.cli.fowt import main as fowt_main

    # what the commands import on their first call (the run, review and CAN paths'
    # modules): imported once here, not in every child
    for name in PRELOAD:
        importlib.import_module(name)

    codes = []
    for case in spec["cases"]:
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            code = 1
            try:
                code = _child(case, fowt_main)
            finally:
                sys.stdout.flush()
                sys.stderr.flush()
                os._exit(code)
        _, status = os.waitpid(pid, 0)
        codes.append(os.waitstatus_to_exitcode(status))
    json.dump(codes, sys.stdout)


if __name__ == "__main__":
    main()
