"""What every ``fowt`` process does before its command: numpy's unused submodules made lazy.

``hil.cli`` defers ``numpy.f2py`` and ``numpy.testing`` (:data:`hil.cli.DEFERRED_NUMPY_MODULES`):
importing ``scipy.linalg`` (as the run path and numba's BLAS check do) no longer executes
them, and a real use still gets the whole module.
"""

from __future__ import annotations

import json
import textwrap

from _helpers import python_child

CHILD = textwrap.dedent(
    """
    import json, sys
    import hil.cli
    import scipy.linalg  # what touched every name numpy lists
    executed = {n: n + "._private.utils" in sys.modules or n + ".crackfortran" in sys.modules
                for n in hil.cli.DEFERRED_NUMPY_MODULES}
    import numpy as np
    np.testing.assert_allclose(np.ones(3), np.ones(3))  # a use loads it whole
    from numpy.testing import assert_array_equal
    assert_array_equal(np.arange(3), [0, 1, 2])
    include = np.f2py.get_include()
    print(json.dumps({"executed_before_use": executed, "f2py_include": include,
                      "testing_loaded": "numpy.testing._private.utils" in sys.modules}))
    """
)


def test_numpys_unused_submodules_run_only_when_used() -> None:
    proc = python_child(CHILD, check=True)
    got = json.loads(proc.stdout)
    assert got["executed_before_use"] == {"numpy.f2py": False, "numpy.testing": False}
    assert got["testing_loaded"]
    assert got["f2py_include"].endswith("src")
