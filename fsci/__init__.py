"""fsci: monolithic fluid-structure-contact interaction in 2D.

The package solves elastic bodies immersed in incompressible viscous flow on a fixed
rectilinear background grid (CutFEM), coupled by Nitsche's method, following
Ager, Seitz, Wall (2019), "A consistent and comprehensive computational approach for
general fluid-structure-contact interaction problems".
"""

import ctypes as _ctypes
import os as _os

# MKL's conditional numerical reproducibility: PARDISO then gives the same bits in every run
# on this machine (needed for bit-identical restarts; no measurable cost, docs/performance.md).
_os.environ.setdefault("MKL_CBWR", "AUTO")

# Thread pools share the cores: MKL's (PARDISO) runs on Intel OpenMP unless told otherwise, numba's
# kernels on GNU OpenMP, numpy's BLAS on OpenBLAS. An idle worker of one pool spins for a while
# (Intel's for 200 ms) and on two cores takes the core another pool's worker needs. MKL on GNU
# OpenMP shares one pool with numba: the fine stamp runs in 0.85x the time, the coarse stamp
# and FSI1 as before (docs/performance.md, "Thread pools"). numpy's BLAS works on vectors here:
# one thread. Read when each library loads, so set before any of them is imported; only where
# the GNU runtime exists (else MKL would not load and PARDISO would be lost).
try:
    _ctypes.CDLL("libgomp.so.1")
    _os.environ.setdefault("MKL_THREADING_LAYER", "GNU")
except OSError:
    pass
_os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

# compiled kernels are cached per version of the source (numba alone would keep a kernel compiled
# against an older version of a kernel it calls from another module)
from fsci.kernel_cache import configure as _configure_kernel_cache  # noqa: E402

_configure_kernel_cache(_os.path.dirname(__file__))

__version__ = "0.1.0"
