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


def _blas_kernels() -> str | None:
    """OpenBLAS's kernels for this machine: Haswell's where the CPU has AVX2 and FMA (Linux's
    /proc/cpuinfo), else None (OpenBLAS's own choice)."""
    try:
        with open("/proc/cpuinfo") as cpu:
            flags = next((line.split(":", 1)[1].split() for line in cpu if line.startswith("flags")), [])
    except OSError:
        return None
    return "Haswell" if {"avx2", "fma"} <= set(flags) else None


# One set of BLAS kernels on every x86-64 machine with AVX2, set before numpy loads. OpenBLAS
# picks its kernels by the CPU it loads on, and their sums round differently: SkylakeX's
# AVX-512 kernels on an AMD EPYC with AVX-512, Haswell's or Zen's on an AVX2 machine. Scenes and
# the reference's solves go through it, so the chaotic checks moved with the machine: on the
# AVX-512 machine, 35 tests of the suite's default engines left the bands an AVX2 machine had
# measured (Drake's resting stacks, Lemke's grasp, PyBullet's pair friction, the pairwise Newton
# solver). With Haswell's kernels all four tests sampled held their bands. A user's own
# OPENBLAS_CORETYPE wins.
if (_kernels := _blas_kernels()) is not None:
    os.environ.setdefault("OPENBLAS_CORETYPE", _kernels)
