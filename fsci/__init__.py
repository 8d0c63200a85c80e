"""fsci: monolithic fluid-structure-contact interaction in 2D.

The package solves elastic bodies immersed in incompressible viscous flow on a fixed
rectilinear background grid (CutFEM), coupled by Nitsche's method, following
Ager, Seitz, Wall (2019), "A consistent and comprehensive computational approach for
general fluid-structure-contact interaction problems".
"""

import os as _os

# MKL's conditional numerical reproducibility: PARDISO then gives the same bits in every run
# on this machine (needed for bit-identical restarts; no measurable cost, docs/performance.md).
_os.environ.setdefault("MKL_CBWR", "AUTO")

# Three thread pools share the cores: MKL's (PARDISO, Intel OpenMP), numba's (GNU OpenMP) and
# numpy's OpenBLAS. A pool's idle workers spin for a while after each parallel call (Intel's
# 200 ms), and on two cores a spinning worker takes the core another pool's worker or PARDISO
# needs: the fine stamp ran 0.85x the time without the spinning (docs/performance.md, "Idle
# threads that spin"). Idle workers sleep at once instead; numpy's BLAS works on vectors here and
# runs one thread. Read when each library loads, so set before any of them is imported.
_os.environ.setdefault("OMP_WAIT_POLICY", "passive")
_os.environ.setdefault("KMP_BLOCKTIME", "0")
_os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

# compiled kernels are cached per version of the source (numba alone would keep a kernel compiled
# against an older version of a kernel it calls from another module)
from fsci.kernel_cache import configure as _configure_kernel_cache  # noqa: E402

_configure_kernel_cache(_os.path.dirname(__file__))

__version__ = "0.1.0"
