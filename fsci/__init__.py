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

# compiled kernels are cached per version of the source (numba alone would keep a kernel compiled
# against an older version of a kernel it calls from another module)
from fsci.kernel_cache import configure as _configure_kernel_cache  # noqa: E402

_configure_kernel_cache(_os.path.dirname(__file__))

__version__ = "0.1.0"
