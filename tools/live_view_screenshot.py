"""A real-time run watched in Lichtblick: the live view checked in an open-source viewer.

Lichtblick (the open-source continuation of Foxglove Studio) is a web app; this drives a
build of it in headless Chromium (Debian's ``chromium``, through ``playwright-core``:
``tools/lichtblick/screenshot.mjs``) against ``fowt run SCENARIO --mode realtime --live PORT``:

1. serves the Lichtblick build (``--web``: its ``web/.webpack`` folder) on a free loopback
   port;
2. starts the run with its live view on another free loopback port and waits until the
   live server accepts connections;
3. opens Lichtblick with the Foxglove WebSocket data source on that port and the shipped
   layout (``docs/foxglove-layout.json``), lets data flow ``--wait`` seconds, takes a
   1600x1000 screenshot (``--out``) and reads the panels back: topics and schemas as the app
   lists them, every panel of the layout on screen, each plot's current value, the 3-D
   panel's pixels, the panels' own logs and the app's alerts;
4. waits for the run to end and adds its exit code and the live view's counts.

It prints the evidence as one JSON object (``--json`` also writes it to a file) and exits
with the run's exit code, or 3 when the viewer did not connect. Only loopback addresses are
used: the page's every other host name resolves to nothing and any other request is aborted.

Lichtblick is not a Python package and its build is not part of this repository: build it
from its own repository (``yarn install`` and ``yarn web:build:prod``, release 1.28 or newer:
the first to accept the ``foxglove.sdk.v1`` subprotocol the live server speaks), then::

    npm --prefix tools/lichtblick install        # playwright-core (no browser download)
    python tools/live_view_screenshot.py --web PATH/TO/lichtblick/web/.webpack \\
        --out docs/live-view.png

``tests/test_lichtblick.py`` runs the same check where ``FOWT_LICHTBLICK_WEB`` names a build.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import http.server
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
SCRIPT = REPO / "tools" / "lichtblick" / "screenshot.mjs"
LAYOUT = REPO / "docs" / "foxglove-layout.json"
#: Seconds the live server gets to listen after the run starts (a cold start compiles nothing:
#: the kernels are cached by the set-up; the trim may run once).
LISTEN_TIMEOUT_S = 300.0


def missing(web: Path | None) -> str | None:
    """Why the check cannot run here (None: it can)."""
    if web is None or not (web / "index.html").is_file():
        return "no Lichtblick web build (its web/.webpack folder with index.html)"
    if shutil.which("node") is None:
        return "no node"
    chromium = os.environ.get("CHROMIUM_PATH", "/usr/bin/chromium")
    if not Path(chromium).is_file():
        return f"no Chromium at {chromium} (apt-get install chromium)"
    if not (SCRIPT.parent / "node_modules" / "playwright-core").is_dir():
        return "no playwright-core (npm --prefix tools/lichtblick install)"
    return None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: Any) -> None:
        """No access log on the console."""


@contextlib.contextmanager
def _serving(folder: Path) -> Iterator[int]:
    """``folder`` served on 127.0.0.1 (a free port, yielded) for the block."""
    handler = functools.partial(_Quiet, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, name="lichtblick-web", daemon=True)
    thread.start()
    try:
        yield int(server.server_address[1])
    finally:
        server.shutdown()
        server.server_close()


def _listening(port: int, proc: subprocess.Popen[str], timeout_s: float) -> bool:
    """Wait until 127.0.0.1:``port`` accepts a connection (False: the run ended or timed out)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), 0.5):
            return True
        time.sleep(0.2)
    return False


def check(
    web: Path,
    out_png: Path,
    scenario: str = "default",
    duration_s: float = 60.0,
    wait_s: float = 20.0,
    run_dir: Path | None = None,
) -> dict[str, Any]:
    """Run the check (module docstring); the evidence, with ``run_exit_code`` and ``live_view``."""
    live_port = _free_port()
    with contextlib.ExitStack() as stack:
        if run_dir is None:
            run_dir = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="fowt-lb-")))
        path = os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])
        env = {**os.environ, "PYTHONPATH": path, "COLUMNS": "120"}
        cmd = [sys.executable, "-m", "hil", "run", scenario, "--mode", "realtime"]
        cmd += ["--duration", str(duration_s), "--out", str(run_dir), "--no-plots"]
        cmd += ["--live", str(live_port)]
        log = stack.enter_context(tempfile.TemporaryFile("w+"))  # the launcher's console
        run = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, text=True, env=env)
        try:
            web_port = stack.enter_context(_serving(web))
            evidence: dict[str, Any] = {"connected": False}
            if _listening(live_port, run, LISTEN_TIMEOUT_S):
                shot = subprocess.run(
                    ["node", str(SCRIPT), f"http://127.0.0.1:{web_port}/",
                     f"ws://127.0.0.1:{live_port}", str(LAYOUT), str(out_png), str(wait_s),
                     "--console", str(out_png.with_suffix(".console.log"))],
                    capture_output=True, text=True, timeout=600, check=False,
                )  # fmt: skip
                try:
                    evidence = json.loads(shot.stdout)
                except json.JSONDecodeError:
                    evidence = {"connected": False, "error": shot.stderr[-2000:]}
            evidence["run_exit_code"] = run.wait(timeout=duration_s + 600)
            log.seek(0)
            evidence["run_console_tail"] = log.read()[-3000:].splitlines()[-12:]
        finally:
            if run.poll() is None:
                run.terminate()
                run.wait(timeout=60)
        summary = run_dir / "summary.json"
        if summary.is_file():
            evidence["live_view"] = json.loads(summary.read_text())["run"].get("live_view")
    return evidence


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--web", type=Path, required=True, help="the Lichtblick web build's folder")
    ap.add_argument("--out", type=Path, default=Path("live-view.png"), help="the screenshot")
    ap.add_argument("--scenario", default="default")
    ap.add_argument("--duration", type=float, default=60.0, help="the run's simulated seconds")
    ap.add_argument("--wait", type=float, default=20.0, help="seconds of data before the shot")
    ap.add_argument("--json", type=Path, default=None, help="also write the evidence here")
    args = ap.parse_args()
    why = missing(args.web)
    if why is not None:
        raise SystemExit(f"cannot run the check: {why}")
    evidence = check(args.web, args.out.resolve(), args.scenario, args.duration, args.wait)
    text = json.dumps(evidence, indent=2)
    print(text)
    if args.json is not None:
        args.json.write_text(text + "\n")
    code = int(evidence.get("run_exit_code", 1))
    raise SystemExit(3 if not evidence.get("connected") else code)


if __name__ == "__main__":
    main()
