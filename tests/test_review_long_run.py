"""The streaming review of a day-long run: memory that does not grow with the run's length.

Synthetic run logs (written with the bench's own MCAP writer, :class:`hil.runlog.mcap_io.RunLog`,
CDR channels) of 2 h and of 24 h at 5 Hz hold a truth channel with sinusoidal rotor speed
and thrust and a cycle channel with latencies; each is reviewed with its plots in a child
process, which reports its peak resident set. The 24 h file (432 000 cycles, 864 000
messages) must review with a peak under 300 MB and at most 15 MB above the 2 h file's (what
the review keeps whole: one latency per cycle, 8 bytes, 3.2 MB for the extra 22 h; the
rainflow of the DELs, the spectra and the plots' min/max columns are streamed). The KPIs are
checked against the signals' analytic mean, standard deviation, maximum and DEL over the
KPI window.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bus_schemas.registry import CYCLE_TIMING, TRUTH
from hil.runlog.mcap_io import RunLog

RATE_HZ = 5.0
#: Rotor speed 0.7 + 0.05 sin(2π t / 50 s) [rad/s], thrust 1.2e6 + 2e5 sin(2π t / 8 s) [N]
#: (the thrust's peaks and troughs fall on samples at 5 Hz).
W0, W1, T_W = 0.7, 0.05, 50.0
F0, F1, T_F = 1.2e6, 2e5, 8.0
#: The two lengths reviewed [s], and how much more the longer may peak at [MB].
SHORT_S, LONG_S, MARGIN_MB = 2 * 3600.0, 24 * 3600.0, 15.0


def write_log(path: Path, duration_s: float) -> None:
    """A run log of ``duration_s`` at :data:`RATE_HZ`, written in blocks of 8192 cycles
    (CDR channels, rows of the messages' ``row_dtype``; unset fields 0)."""
    n = round(duration_s * RATE_HZ)
    log = RunLog(path, "t1", start_unix_ns=0)
    log.add_metadata("run", {"mode": "inprocess"})
    rng = np.random.default_rng(7)
    truth_id = int(log.channel_of_message_id[TRUTH.message_id])
    cycle_id = int(log.channel_of_message_id[CYCLE_TIMING.message_id])
    for a in range(0, n, 8192):
        k = np.arange(a, min(a + 8192, n))
        t = k / RATE_HZ
        t_ns = k * round(1e9 / RATE_HZ)
        f = F0 + F1 * np.sin(2 * math.pi * t / T_F)
        truth = np.zeros(k.size, TRUTH.row_dtype)
        truth["seq"], truth["sample_time_ns"] = k, t_ns
        truth["rotor_speed_rad_s"] = W0 + W1 * np.sin(2 * math.pi * t / T_W)
        truth["rotor_thrust_n"] = f
        truth["electrical_power_w"], truth["generator_torque_nm"] = 1.0e7, 2.0e4
        truth["blade_pitch_rad"], truth["shaft_torque_nm"] = 0.1, 1e3 * f
        truth["tower_base_moment_nm"], truth["floating"] = 1e2 * f, 1
        truth["platform_pitch_rad"], truth["platform_surge_m"] = 0.01, 5.0
        cycle = np.zeros(k.size, CYCLE_TIMING.row_dtype)
        cycle["seq"], cycle["sample_time_ns"], cycle["publish_time_ns"] = k, t_ns, t_ns
        cycle["latency_ns"] = rng.integers(5_000, 20_000, size=k.size)
        log.write_rows(truth_id, truth, t_ns)
        log.write_rows(cycle_id, cycle, t_ns)
        log.flush()
    log.close()


CHILD = r"""
import json, sys
from pathlib import Path
def hwm():
    # VmHWM: this process's peak resident set [MB]; ru_maxrss would keep the parent's
    # peak across fork and exec.
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
from hil.review.core import review
plots = len(sys.argv) > 2
out = Path(sys.argv[2]) if plots else None
s = review(Path(sys.argv[1]), out, plots=plots, write_summary=False)
peak = hwm()
print(json.dumps({"peak_mb": peak, "kpi": s["kpi"], "window": s["kpi_window"],
                  "cycles": s["timing"]["latency_cycles"]}))
"""


def _review_child(path: Path, plots_dir: Path | None = None) -> dict:
    root = Path(__file__).resolve().parents[1]
    extra = [str(plots_dir)] if plots_dir is not None else []
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, str(path), *extra], capture_output=True, text=True,
        check=True, cwd=root,
    )  # fmt: skip
    out: dict = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


@pytest.fixture(scope="module")
def reviews(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, dict, Path]:
    """A 2 h and a 24 h run log, each reviewed with its plots (once for the module's tests)."""
    d = tmp_path_factory.mktemp("long_run")
    out = []
    for name, duration in (("short", SHORT_S), ("long", LONG_S)):
        path = d / f"{name}.mcap"
        write_log(path, duration)
        out.append(_review_child(path, d / name))
        path.unlink()  # 60 MB for the day
    return out[0], out[1], d


def test_day_long_review_memory_does_not_grow(reviews: tuple[dict, dict, Path]) -> None:
    """The review with plots peaks under 300 MB, the day's at most MARGIN_MB above the 2 h's."""
    a, b, _d = reviews
    assert b["cycles"] == LONG_S * RATE_HZ
    assert a["cycles"] == SHORT_S * RATE_HZ
    assert b["peak_mb"] < 300.0, b["peak_mb"]
    assert b["peak_mb"] - a["peak_mb"] < MARGIN_MB, (a["peak_mb"], b["peak_mb"])


def test_day_long_review_kpis(reviews: tuple[dict, dict, Path]) -> None:
    # KPIs over t = 40 s (the default settle time) to the end: not whole periods of the 50 s
    # sine, so the mean of the window's sine is bounded by its ends.
    _a, b, _d = reviews
    k = b["kpi"]
    assert b["window"]["from_s"] == 40.0
    span = LONG_S - 1 / RATE_HZ - 40.0
    assert k["rotor_speed_mean_rad_s"] == pytest.approx(W0, abs=W1 * T_W / (math.pi * span))
    assert k["rotor_speed_std_rad_s"] == pytest.approx(W1 / math.sqrt(2), rel=1e-3)
    assert k["thrust_mean_n"] == pytest.approx(F0, abs=F1 * T_F / (math.pi * span))
    assert k["thrust_max_n"] == pytest.approx(F0 + F1, rel=1e-6)
    # DEL of a sine of range 2 F1, one cycle per T_F, at 1 Hz and m = 4: 2 F1 (1/T_F)^(1/4)
    assert k["thrust_del_n"] == pytest.approx(2 * F1 * (1 / T_F) ** 0.25, rel=1e-3)


def test_day_long_plots(reviews: tuple[dict, dict, Path]) -> None:
    """The day's plots, drawn in min/max pixel columns from a second pass over the file."""
    _a, _b, d = reviews
    for name in ("timeseries.png", "timing.png", "psd.png"):
        png = d / "long" / name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
