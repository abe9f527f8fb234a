"""How a ``fowt`` process ends (:func:`hil.cli.fowt.entry`): its exit handlers run, its
output is whole, its exit code is the command's, and the interpreter's teardown is skipped;
where that would change the outcome (a thread still running, an exit with a message) the
interpreter exits as usual.

Each case is a real child interpreter; the same command through :func:`hil.cli.fowt.main`
with the interpreter's own exit is the reference.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

from _helpers import python_child

#: A child that sets a probe up, then runs ``fowt <argv>`` through ``how`` (entry or main).
CHILD = textwrap.dedent(
    """
    import atexit, sys, threading, time
    from pathlib import Path
    from hil.cli import fowt

    how, probe, thread, *argv = sys.argv[1:]
    atexit.register(lambda: Path(probe, "atexit").write_text("ran"))

    class Teardown:  # what it needs kept on itself: the teardown clears module globals
        def __init__(self, path):
            self.path, self.open = path, open

        def __del__(self):
            with self.open(self.path, "w") as f:
                f.write("ran")

    KEEP = Teardown(str(Path(probe, "teardown")))  # freed only by the interpreter's teardown
    if thread == "thread":
        def late():
            time.sleep(0.5)
            Path(probe, "thread").write_text("ran")
        threading.Thread(target=late).start()
    sys.argv = ["fowt", *argv]
    if how == "entry":
        fowt.entry()
    else:
        fowt.main()
    """
)


def _fowt(tmp: Path, how: str, *argv: str, thread: bool = False) -> tuple[int, str, str, set[str]]:
    """Exit code, stdout, stderr and the probes that ran, of ``fowt argv`` through ``how``."""
    probe = tmp / how
    probe.mkdir()
    proc = python_child(CHILD, how, str(probe), "thread" if thread else "-", *argv)
    ran = {p.name for p in probe.iterdir()}
    return proc.returncode, proc.stdout, proc.stderr, ran


def test_a_command_ends_with_its_output_code_and_exit_handlers_but_no_teardown(
    tmp_path: Path,
) -> None:
    code, out, err, ran = _fowt(tmp_path, "entry", "scenarios")
    ref_code, ref_out, ref_err, ref_ran = _fowt(tmp_path, "main", "scenarios")
    assert (code, out, err) == (ref_code, ref_out, ref_err)
    assert code == 0 and "iea15mw-lc2-lqri-ff" in out  # the whole listing, flushed
    assert ran == {"atexit"}  # exit handlers ran; the teardown's finalizer did not
    assert ref_ran == {"atexit", "teardown"}  # the interpreter's own exit runs both


def test_a_usage_error_keeps_its_code_and_message(tmp_path: Path) -> None:
    code, out, err, ran = _fowt(tmp_path, "entry", "run", "default", "--duration", "-1")
    ref = _fowt(tmp_path, "main", "run", "default", "--duration", "-1")
    assert (code, out, err) == ref[:3]
    assert code == 2 and err.startswith("error: ")
    assert ran == {"atexit"}


def test_a_thread_still_running_is_waited_for(tmp_path: Path) -> None:
    """The interpreter's exit waits for a non-daemon thread: so does the command's."""
    code, _, _, ran = _fowt(tmp_path, "entry", "scenarios", thread=True)
    assert code == 0
    assert ran == {"atexit", "thread", "teardown"}  # the interpreter's own exit, whole


def test_an_exit_with_a_message_is_the_interpreters(tmp_path: Path) -> None:
    child = "from hil.cli.fowt import _leave\n_leave(SystemExit('stopped: a message'))\n"
    proc = python_child(child)
    assert proc.returncode == 1
    assert proc.stderr.strip().endswith("stopped: a message")
