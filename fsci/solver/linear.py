"""Sparse direct solvers behind one small interface.

* :class:`PardisoSolver` (MKL PARDISO through ``pypardiso``): the symbolic analysis (phase 11,
  about as expensive as the numeric factorisation) is reused while the sparsity pattern is
  unchanged; only phase 22 (numeric) and 33 (solve) run. The analysis depends on the pattern
  only (the fill-reducing ordering, :meth:`PardisoSolver.ordering`; value-dependent scaling
  and matching are off), so reusing it or redoing it gives the same factors — a restarted run
  is bit-identical to an uninterrupted one
  (with ``MKL_CBWR=AUTO``, set by ``fsci/__init__.py``). The true residual of every solve is
  checked; an inaccurate solve is repeated once with scaling and matching (robust mode).
* :class:`SuperLUSolver` (scipy): ``permc_spec="MMD_AT_PLUS_A"``, ``SymmetricMode`` and
  ``diag_pivot_thresh=0.01`` — the three options go together (without the others, MMD ordering
  with default pivoting did not finish on a 120k-unknown Oseen matrix).

Factorisation reuse: within one nonlinear solve the matrix changes little between Newton
iterations. After the first factorisation of a step, a new system is first solved by GMRES
right-preconditioned with the last factors (a PARDISO solve with the old matrix;
:func:`right_preconditioned_gmres`, which stops on the true residual); only if that does
not reach the relative true residual asked for (``1e-10``, or Newton's forcing term where that
is larger, :func:`fsci.solver.newton.forcing_term`) within ``max_krylov`` iterations is the new
matrix factorised. At every size this pays: on the coarse stamp (2,076 unknowns, one thread)
a factorisation and solve cost 3.3 ms, a Krylov step with the old factors about 0.35 ms, and
the second and third Newton iterations of a step get there in two or three. The factors are
never carried into the next step, so a restarted run stays bit-identical (Newton's stopping
test is always on the true nonlinear residual).

The interface (``solve(A, b, pattern_key)``) is what a distributed backend (PETSc/MUMPS) would
implement too.
"""

from __future__ import annotations

import ctypes
import os
import time
from typing import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fsci.errors import InputError, SolverError


class LinearSolver:
    """Base class: records per-phase timings in ``self.timings``."""

    name = "base"

    def __init__(self) -> None:
        self.timings = {"analysis": 0.0, "factorization": 0.0, "solve": 0.0}
        self.counts = {"analysis": 0, "factorization": 0, "solve": 0, "chord": 0}  # chord: solves with old factors

    def _tick(self, phase: str, t0: float) -> None:
        self.timings[phase] += time.perf_counter() - t0
        self.counts[phase] += 1

    def solve(self, A: sp.csr_matrix, b: np.ndarray, pattern_key: bytes | None = None,
              rtol: float = 0.0) -> np.ndarray:
        """Solve ``A x = b``. ``pattern_key`` identifies the sparsity pattern (analysis reuse);
        ``rtol`` is the relative residual an iterative solve with reused factors may stop at
        (Newton's forcing term); a new factorisation always solves to round-off."""
        raise NotImplementedError

    def new_system(self) -> None:
        """A new nonlinear solve begins: factors of the previous one are not reused."""

    def has_factors(self) -> bool:
        """Whether this nonlinear solve has factors for :meth:`solve_with_factors`."""
        return False

    def solve_with_factors(self, b: np.ndarray) -> np.ndarray:
        """One solve with the factors of the last matrix factorised in this nonlinear solve (a
        chord step: Newton's increment at an iterate whose residual already passes its test,
        where the increment is only measured, decision 49)."""
        t0 = time.perf_counter()
        x = self._apply_factors(b)
        self._tick("solve", t0)
        self.counts["chord"] += 1
        return x

    def _apply_factors(self, b: np.ndarray) -> np.ndarray:
        """``A⁻¹ b`` with the factors of :meth:`has_factors`."""
        raise NotImplementedError


class SuperLUSolver(LinearSolver):
    name = "superlu"

    def __init__(self) -> None:
        super().__init__()
        self._lu = None

    def new_system(self) -> None:
        self._lu = None

    def has_factors(self) -> bool:
        return self._lu is not None

    def _apply_factors(self, b: np.ndarray) -> np.ndarray:
        return self._lu.solve(b)

    def solve(self, A: sp.csr_matrix, b: np.ndarray, pattern_key: bytes | None = None,
              rtol: float = 0.0) -> np.ndarray:
        t0 = time.perf_counter()
        self._lu = None
        try:
            lu = spla.splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.01,
                           options={"SymmetricMode": True})
        except RuntimeError as exc:
            raise SolverError(f"SuperLU factorisation failed: {exc}") from None
        self._tick("factorization", t0)
        t0 = time.perf_counter()
        x = lu.solve(b)
        self._tick("solve", t0)
        if not np.all(np.isfinite(x)):
            raise SolverError("SuperLU returned non-finite values (singular matrix)")
        self._lu = lu
        return x


def right_preconditioned_gmres(A: sp.csr_matrix, b: np.ndarray, precondition: Callable[[np.ndarray], np.ndarray],
                               tol: float, max_its: int) -> tuple[np.ndarray | None, int]:
    """GMRES with right preconditioning, one cycle of at most ``max_its`` steps, from x0 = 0.

    Right preconditioning (solve ``A M⁻¹ y = b``, ``x = M⁻¹ y``) makes the residual GMRES
    minimises the true residual ``b − A x``, so the stopping test ``|b − A x| ≤ tol |b|`` is the
    one the caller asks for, and each step costs one preconditioner application and one matrix
    product (scipy's left-preconditioned GMRES needs two more applications per solve and stops
    on the preconditioned residual). Modified Gram-Schmidt, Givens rotations (Saad, Iterative
    Methods for Sparse Linear Systems, 2nd ed., Alg. 6.9 and Sec. 9.3.2).

    Returns
    -------
    x, steps
        The iterate (None if the residual estimate did not reach ``tol`` within ``max_its``
        steps) and the number of steps taken.
    """
    beta = float(np.linalg.norm(b))
    if beta == 0.0:
        return np.zeros_like(b), 0
    n = b.shape[0]
    V = np.empty((max_its + 1, n))
    Z = np.empty((max_its, n))
    H = np.zeros((max_its + 1, max_its))
    cs = np.zeros(max_its)
    sn = np.zeros(max_its)
    g = np.zeros(max_its + 1)
    g[0] = beta
    V[0] = b / beta
    for j in range(max_its):
        Z[j] = precondition(V[j])
        w = A @ Z[j]
        for i in range(j + 1):
            H[i, j] = w @ V[i]
            w -= H[i, j] * V[i]
        H[j + 1, j] = np.linalg.norm(w)
        if H[j + 1, j] > 0.0:
            V[j + 1] = w / H[j + 1, j]
        for i in range(j):  # earlier rotations on the new column
            H[i, j], H[i + 1, j] = cs[i] * H[i, j] + sn[i] * H[i + 1, j], -sn[i] * H[i, j] + cs[i] * H[i + 1, j]
        r = np.hypot(H[j, j], H[j + 1, j])
        if r == 0.0:
            return None, j + 1
        cs[j], sn[j] = H[j, j] / r, H[j + 1, j] / r
        H[j, j], H[j + 1, j] = r, 0.0
        g[j + 1] = -sn[j] * g[j]
        g[j] = cs[j] * g[j]
        if abs(g[j + 1]) <= tol * beta:  # |g[j+1]| is the residual norm of the current iterate
            y = np.linalg.solve(np.triu(H[: j + 1, : j + 1]), g[: j + 1])
            return y @ Z[: j + 1], j + 1
    return None, max_its


class PardisoSolver(LinearSolver):
    name = "pardiso"

    RTOL = 1e-10  # relative true residual a reused factorisation must reach through GMRES

    def __init__(self, max_krylov: int = 8) -> None:
        super().__init__()
        import pypardiso

        self._ps = pypardiso.PyPardisoSolver(mtype=11)
        self._key: bytes | None = None
        self._robust = False
        self._set_mode(robust=False)
        self.max_krylov = max_krylov
        self._factored: sp.csr_matrix | None = None  # matrix of the current factors (this solve)
        self._index: tuple | None = None  # (indptr, indices, ia, ja): PARDISO's 1-based indices of a pattern
        self.counts["krylov"] = 0
        self.counts["reused"] = 0

    def new_system(self) -> None:
        self._factored = None

    def has_factors(self) -> bool:
        return self._factored is not None

    def _apply_factors(self, b: np.ndarray) -> np.ndarray:
        """A plain solve (phase 33) with the factors of the last factorised matrix."""
        return self._phase(self._factored, np.asfortranarray(b, dtype=np.float64).reshape(-1, 1), 33).ravel()

    def _reuse(self, A: sp.csr_matrix, b: np.ndarray, pattern_key: bytes | None, rtol: float) -> np.ndarray | None:
        """GMRES on ``A`` preconditioned with the factors of the last factorised matrix, to the
        relative true residual ``max(RTOL, rtol)``; None if there are none for this pattern or
        GMRES does not get there in ``max_krylov`` steps."""
        if self.max_krylov <= 0 or self._factored is None or pattern_key is None or pattern_key != self._key \
                or self._factored.shape != A.shape:
            return None
        t0 = time.perf_counter()
        tol = max(self.RTOL, rtol)
        x, its = right_preconditioned_gmres(A, b, self._apply_factors, tol, self.max_krylov)
        self._tick("solve", t0)
        self.counts["krylov"] += its
        if x is None or not np.all(np.isfinite(x)) or np.linalg.norm(A @ x - b) > tol * max(np.linalg.norm(b), 1e-300):
            return None
        self.counts["reused"] += 1
        return x

    def _set_mode(self, robust: bool) -> None:
        ip = self._ps.iparm
        ip[:] = 0
        ip[0] = 1  # use the values below
        # no iterative refinement unless pivots were perturbed (then MKL does two steps by
        # itself): two steps always tripled the solve phase, and every solve's true residual is
        # checked below anyway
        ip[7] = 0
        ip[9] = 13  # pivot perturbation 1e-13
        ip[10] = 1 if robust else 0  # scaling (value dependent)
        ip[12] = 1 if robust else 0  # weighted matching (value dependent)
        self._robust = robust

    SMALL = 20000  # below this many unknowns one MKL thread is faster (thread start-up dominates)
    LARGE = 100000  # from this many unknowns on, METIS orders for a cheaper factorisation

    @classmethod
    def ordering(cls, n: int) -> int:
        """PARDISO's fill-reducing ordering (``iparm(2)``) for ``n`` unknowns: minimum degree (0)
        below :attr:`LARGE`, METIS nested dissection (2) from there on. On the systems of the
        built-in cases up to 94k unknowns minimum degree analyses in 0.6-0.75x the time and
        factorises in 0.75-1.0x (docs/performance.md, "The ordering"); at 113k and 367k METIS
        factorises faster and the factorisation outweighs the analysis."""
        return 0 if n < cls.LARGE else 2

    @property
    def threads(self) -> int:
        """Threads of a PARDISO call at or above ``SMALL`` unknowns: ``MKL_NUM_THREADS`` if set
        (``fsci sweep`` sets it for runs side by side), else every core."""
        cores = os.cpu_count() or 1
        try:
            return max(1, min(cores, int(os.environ.get("MKL_NUM_THREADS", cores))))
        except ValueError:
            return cores

    def _one_based(self, A: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray]:
        """PARDISO's 1-based int32 ``ia, ja`` of ``A``, kept while the next matrices share its
        pattern arrays (the assembly's matrices do; the arrays are held, so they cannot be
        another pattern's): converting them at every call (the factorisation, its solve, each
        Krylov step) cost 4.8 ms per call at 3.9 million nonzeros."""
        c = self._index
        if c is None or c[0] is not A.indptr or c[1] is not A.indices:
            c = self._index = (A.indptr, A.indices, A.indptr.astype(np.int32) + 1, A.indices.astype(np.int32) + 1)
        return c[2], c[3]

    def _phase(self, A: sp.csr_matrix, b: np.ndarray, phase: int) -> np.ndarray:
        """One PARDISO call (pypardiso's, with the index arrays of :meth:`_one_based`)."""
        ps = self._ps
        threads = 1 if A.shape[0] < self.SMALL else self.threads
        try:
            ps.libmkl.MKL_Set_Num_Threads(ctypes.c_int(threads))
        except AttributeError:
            pass
        ps.set_phase(phase)
        ia, ja = self._one_based(A)
        x = np.zeros_like(b)
        error = ctypes.c_int32(0)
        int_p, double_p = ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(ctypes.c_double)
        ps._mkl_pardiso(ps.pt.ctypes.data_as(ctypes.POINTER(ps._pt_type[0])), ctypes.byref(ctypes.c_int32(1)),
                        ctypes.byref(ctypes.c_int32(1)), ctypes.byref(ctypes.c_int32(ps.mtype)),
                        ctypes.byref(ctypes.c_int32(phase)), ctypes.byref(ctypes.c_int32(A.shape[0])),
                        A.data.ctypes.data_as(double_p), ia.ctypes.data_as(int_p), ja.ctypes.data_as(int_p),
                        ps.perm.ctypes.data_as(int_p), ctypes.byref(ctypes.c_int32(1 if b.ndim == 1 else b.shape[1])),
                        ps.iparm.ctypes.data_as(int_p), ctypes.byref(ctypes.c_int32(ps.msglvl)),
                        b.ctypes.data_as(double_p), x.ctypes.data_as(double_p), ctypes.byref(error))
        if error.value != 0:
            import pypardiso

            raise pypardiso.pardiso_wrapper.PyPardisoError(error.value)
        return np.ascontiguousarray(x)

    def solve(self, A: sp.csr_matrix, b: np.ndarray, pattern_key: bytes | None = None,
              rtol: float = 0.0) -> np.ndarray:
        import pypardiso

        A = A.tocsr()
        if not A.has_sorted_indices:
            A.sort_indices()
        x = self._reuse(A, b, pattern_key, rtol)
        if x is not None:
            return x
        b2 = np.asfortranarray(b.reshape(-1, 1))
        for attempt in range(2):
            if attempt == 1:
                self._set_mode(robust=True)
            elif self._robust:
                self._set_mode(robust=False)
                self._key = None
            try:
                if pattern_key is None or pattern_key != self._key or attempt == 1:
                    t0 = time.perf_counter()
                    self._ps.iparm[1] = self.ordering(A.shape[0])
                    self._phase(A, b2, 11)
                    self._tick("analysis", t0)
                    self._key = pattern_key
                t0 = time.perf_counter()
                self._phase(A, b2, 22)
                self._tick("factorization", t0)
                t0 = time.perf_counter()
                x = self._phase(A, b2, 33).ravel()
                self._tick("solve", t0)
            except pypardiso.pardiso_wrapper.PyPardisoError as exc:
                self._key = None
                if attempt == 1:
                    raise SolverError(f"PARDISO failed: {exc}") from None
                continue
            r = A @ x - b
            bn = np.linalg.norm(b)
            if np.all(np.isfinite(x)) and np.linalg.norm(r) <= 1e-8 * max(bn, 1e-300):
                if self._robust:
                    self._key = None  # the next solve starts again from a pattern-only analysis
                    self._factored = None
                else:
                    self._factored = A
                return x
            self._key = None
        if not np.all(np.isfinite(x)):
            raise SolverError("PARDISO returned non-finite values (singular matrix)")
        return x


def available_backends() -> list[str]:
    """The linear solvers that load here, preferred first."""
    return ["pardiso", "superlu"] if make_linear_solver("auto").name == "pardiso" else ["superlu"]


def make_linear_solver(name: str = "auto") -> LinearSolver:
    """``"auto"``: PARDISO if it loads, else SuperLU."""
    if name == "auto":
        try:  # the solver itself is the probe: every PARDISO instance loads MKL (0.24 s each)
            return PardisoSolver()
        except Exception:  # ImportError or missing MKL runtime
            return SuperLUSolver()
    if name == "pardiso":
        try:
            return PardisoSolver()
        except Exception as exc:
            raise InputError("solver.linear", name, f"pypardiso/MKL is not usable here ({exc}); use 'superlu'") from None
    if name == "superlu":
        return SuperLUSolver()
    raise InputError("solver.linear", name, "one of auto, pardiso, superlu")
