"""Check an HTML report in real headless Chromium and take its screenshot.

Needs Debian's ``chromium`` package (``apt-get update && apt-get install -y chromium``).
Loads the file (a copy with a small probe script appended, which counts the images that
decoded and the tables) with ``--dump-dom``, fails on a console error or an image that did
not render, then writes a full-width screenshot.

    python tools/check_html.py runs/campaign-x/report.html --screenshot docs/campaign-report.png
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

PROBE = """
<script>
window.addEventListener('load', () => {
  const imgs = Array.from(document.images);
  const ok = imgs.filter(i => i.complete && i.naturalWidth > 0).length;
  const d = document.createElement('div');
  d.id = 'render-check';
  d.textContent = 'images ' + ok + '/' + imgs.length + ' tables ' +
    document.querySelectorAll('table').length;
  document.body.appendChild(d);
});
</script>
"""


def chromium_cmd(binary: str, profile: Path, *extra: str) -> list[str]:
    """Chromium headless flags: no sandbox (root), no GPU, no network side traffic."""
    return [
        binary,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={profile}",
        "--enable-logging=stderr",
        "--v=0",
        *extra,
    ]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("html", type=Path)
    ap.add_argument("--screenshot", type=Path, default=None)
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=2400)
    args = ap.parse_args()
    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    if binary is None:
        print("chromium not installed: apt-get update && apt-get install -y chromium")
        return 2
    with tempfile.TemporaryDirectory(prefix="fowt-chromium-") as tmp:
        probe = Path(tmp) / "probe.html"
        probe.write_text(args.html.read_text().replace("</body>", PROBE + "</body>"))
        cmd = chromium_cmd(
            binary, Path(tmp) / "p1", "--virtual-time-budget=5000", "--dump-dom", probe.as_uri()
        )
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=180, check=False)
        m = re.search(r"images (\d+)/(\d+) tables (\d+)", proc.stdout)
        errors = [ln for ln in proc.stderr.splitlines() if "CONSOLE" in ln or "Uncaught" in ln]
        if proc.returncode != 0 or m is None:
            print(f"chromium failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
            return 1
        ok, total, tables = (int(g) for g in m.groups())
        print(f"rendered: {ok}/{total} images decoded, {tables} tables, console errors: {errors}")
        if ok != total or errors:
            return 1
        if args.screenshot is not None:
            args.screenshot.parent.mkdir(parents=True, exist_ok=True)
            cmd = chromium_cmd(
                binary,
                Path(tmp) / "p2",
                "--hide-scrollbars",
                f"--window-size={args.width},{args.height}",
                f"--screenshot={args.screenshot.resolve()}",
                args.html.resolve().as_uri(),
            )
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=180, check=False)
            if proc.returncode != 0 or not args.screenshot.is_file():
                print(f"screenshot failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
                return 1
            print(f"screenshot: {args.screenshot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
