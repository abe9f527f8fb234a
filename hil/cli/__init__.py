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
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
