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

# numpy's BLAS (OpenBLAS) on one thread: its vector operations in fsci (norms, dot products of
# the Krylov and Newton updates) gain nothing from a second thread, and an idle OpenBLAS worker
# spins at full load on the core PARDISO's second thread needs (fine stamp: analysis 2x,
# factorisation 1.15x dearer, docs/performance.md, "Minimum degree again, and numpy's BLAS
# on one thread"; docs/architecture.md, decision 44). The variable
# covers libraries loaded later, threadpoolctl those loaded already; a value the user set stays.
if "OPENBLAS_NUM_THREADS" not in _os.environ:
    _os.environ["OPENBLAS_NUM_THREADS"] = "1"
    from threadpoolctl import ThreadpoolController as _ThreadpoolController

    _ThreadpoolController().select(internal_api="openblas").limit(limits=1)

# compiled kernels are cached per version of the source (numba alone would keep a kernel compiled
# against an older version of a kernel it calls from another module)
from fsci.kernel_cache import configure as _configure_kernel_cache  # noqa: E402

_configure_kernel_cache(_os.path.dirname(__file__))

__version__ = "0.1.0"
