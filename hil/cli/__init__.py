"""The ``fowt`` command line: one module per command family.

Every command runs with one BLAS thread (``OPENBLAS_NUM_THREADS=1``, unless the user set
it), and so do the processes it starts (they inherit the environment): the bench's matrices
are small (a platform's 4 DOFs and radiation states, observers of a few states), and on a
shared 2-core machine a threaded OpenBLAS made every matrix exponential and triangular
solve of an in-process run's start-up (the controller's observer discretisation) cost
10-20 ms instead of 0.1 ms, about 0.4 s of the start-up, while the threads' wait competed
with the run for the cores. The numbers are the same on one thread (the run's KPIs match
to the last digit). Set here because OpenBLAS reads it once, when numpy first loads it: this
package is imported before any command imports numpy. ``controller.design`` does the same
for the offline design (:data:`controller.design.BLAS_SINGLE_THREAD_ENV`).

Two numpy submodules no command uses, ``numpy.f2py`` (the Fortran wrapper generator) and
``numpy.testing``, are made lazy (:data:`DEFERRED_NUMPY_MODULES`): scipy's array-API layer,
which ``scipy.linalg`` imports and numba's BLAS check imports in turn, touches every name
numpy lists and so imported both, about 60 ms of every ``fowt`` process's start (f2py alone
compiles a few hundred regular expressions). With the standard library's
:class:`importlib.util.LazyLoader` they are modules whose code runs at their first real use.
"""

import importlib.util
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

#: numpy's submodules executed only when something uses them (module docstring).
DEFERRED_NUMPY_MODULES = ("numpy.f2py", "numpy.testing")


def _defer_modules(names: tuple[str, ...]) -> None:
    """Put each of ``names`` (not imported yet) in ``sys.modules`` and on its parent as a
    lazily executed module; a name that cannot be found is left alone."""
    for name in names:
        if name in sys.modules:
            continue
        spec = importlib.util.find_spec(name)  # imports the parent package
        if spec is None or spec.loader is None:
            continue
        spec.loader = importlib.util.LazyLoader(spec.loader)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        parent, _, child = name.rpartition(".")
        setattr(sys.modules[parent], child, module)


_defer_modules(DEFERRED_NUMPY_MODULES)
