"""Every numba kernel a real-time run uses is loaded before its first cycle.

In a fresh process (numba loads a kernel from its on-disk cache on the kernel's first call
in a process), the plant is built and warmed as the real-time plant node does
(``PlantSimulator.warm_up``) and the controller built as the controller node does
(``ControllerRuntime``); then the cycles run. No kernel of ``plant``, ``sensors`` or
``controller`` may get its first signature during the cycles: that load (tens of ms, more
under load) would fall into a paced cycle and miss its deadline.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = r"""
import json, sys
from numba.core.registry import CPUDispatcher
from hil.nodes.controller_node import ControllerRuntime
from hil.nodes.plant_node import PlantLoop
from hil.scenario.schema import load_scenario

def signatures():
    out = {}
    for name, mod in list(sys.modules.items()):
        if name.split(".")[0] not in ("plant", "sensors", "controller"):
            continue
        for value in vars(mod).values():
            if isinstance(value, CPUDispatcher):
                key = f"{value.py_func.__module__}.{value.py_func.__qualname__}"
                out[key] = len(value.signatures)
    return out

scenario = load_scenario(sys.argv[1]).with_duration(float(sys.argv[2]))
plant = PlantLoop(scenario, lambda _mt, _m: None)
plant.sim.warm_up(plant.x, plant.applied)
runtime = ControllerRuntime(scenario)
before = signatures()
for _ in range(scenario.cycles):
    frame = plant.sample()
    result = runtime.handle_frame(frame)
    plant.finish_cycle(None if result is None else result[0], 1000, at_arrival=True)
after = signatures()
print(json.dumps({
    "loaded_before": sum(1 for n in before.values() if n),
    "loaded_in_cycles": {k: n for k, n in after.items() if n != before.get(k, 0)},
}))
"""


@pytest.mark.parametrize(
    ("scenario", "seconds"),
    [("default", 2.0), ("iea15mw-lc2-lqri-ff", 2.0), ("oc3-hywind-tp10-lqr2", 3.0)],
)
def test_no_kernel_is_first_called_in_a_cycle(scenario: str, seconds: float) -> None:
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT, scenario, str(seconds)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=600,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["loaded_before"] > 0  # the set-up loaded the kernels ...
    assert out["loaded_in_cycles"] == {}  # ... and no cycle had to
