"""physval: the harness that drives cases through adapters into verdicts and reports.

Data flows one way: case -> scene -> adapter -> trajectory and contact forces ->
observables -> verdict rows -> CSV, markdown, plots.
"""
import os

__version__ = "0.1.0"

# One BLAS thread, set before numpy or scipy is loaded (their OpenBLAS reads it then). The
# reference's compiled step calls BLAS (numba sends np.dot and np.linalg to scipy's
# OpenBLAS), whose sums split across as many threads as the machine has cores, so a job's
# rows depended on the machine (Lemke's pinch grasp at 2 mu F / m g = 0.8: a sliding
# acceleration of 2.7505 m/s^2 on 2 threads, 2.7631 on 1); and physval's workers, one per
# core, each with a thread per core, oversubscribed the cores (the same job 3.4 s alone,
# 136 s beside another). physval runs jobs side by side instead.
os.environ["OPENBLAS_NUM_THREADS"] = "1"
