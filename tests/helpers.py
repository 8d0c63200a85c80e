"""Shared helpers for tests: Jacobian checks by central finite differences, block by block.

The assembled Jacobian is compared with central differences of the residual separately for
every pair (row field, column field) and relative to the size of that block, so an error in a
block that is small next to the rest of the matrix (a coupling block, the velocity–pressure
block) is not hidden by the global scale. :func:`only_terms` restricts ``System.assemble`` to
some of its terms, so each term's contribution to a block is checked relative to its own size.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from fsci.fields import StepContext

TOL = 1e-6  # default tolerance of the per-block relative error


def dof_fields(system) -> dict[str, np.ndarray]:
    """Global dofs of each field: ``u:<body>`` (displacement of one body, both components),
    ``v`` (fluid velocity, both components) and ``p`` (fluid pressure)."""
    st = system.layout.start
    out = {f"u:{s.name}": np.sort(np.concatenate([st[s.gnode], st[s.gnode] + 1])) for s in system.solids
           if s.has_dofs}
    for name, key in (("v", "velocity"), ("p", "pressure")):
        if key in system.field_dofs:
            out[name] = np.sort(system.field_dofs[key])
    return out


def residual_terms(system) -> dict[str, object]:
    """The objects whose ``assemble`` ``System.assemble`` calls, by name: ``solid:<body>``,
    ``fluid`` and ``term<i>:<class>`` for ``system.extra_terms[i]`` (coupling terms)."""
    terms: dict[str, object] = {f"solid:{s.name}": s for s in system.solids if s.has_dofs}
    if system.fluid is not None:
        terms["fluid"] = system.fluid
    for i, t in enumerate(system.extra_terms):
        terms[f"term{i}:{type(t).__name__}"] = t
    return terms


def coupling_terms(system) -> list[str]:
    """Names (see :func:`residual_terms`) of the coupling terms, i.e. everything that is not a
    single field's own term."""
    return [n for n in residual_terms(system) if n.startswith("term")]


@contextmanager
def only_terms(system, names: Iterable[str] | None) -> Iterator[None]:
    """Within the block, ``system.assemble`` adds only the terms ``names`` (``None``: all).

    The other terms get a no-op ``assemble`` on the instance (whatever its signature), so
    ``System.assemble`` itself, its pattern and its order of terms are used unchanged.
    """
    terms = residual_terms(system)
    keep = set(terms) if names is None else set(names)
    unknown = keep - set(terms)
    if unknown:
        raise KeyError(f"no residual term {sorted(unknown)}; the system has {sorted(terms)}")
    muted = [t for n, t in terms.items() if n not in keep]
    for t in muted:
        t.assemble = lambda *args, **kwargs: None
    try:
        yield
    finally:
        for t in muted:
            del t.assemble


def residual(system, ctx: StepContext, x: np.ndarray, recut: bool = False) -> np.ndarray:
    """Residual at ``x``; with ``recut`` the cut is rebuilt at the bodies' positions first (the
    residual as Newton sees it when the cut follows the iterates)."""
    system.scatter(x)
    if recut and system.fluid is not None and system.solids:
        n = system.layout.n_dofs
        system.update_cut()
        assert system.layout.n_dofs == n, "the ACTIVE set changed under a finite-difference step"
    return system.assemble(ctx, want_matrix=False, dirichlet=False).rhs.copy()


@dataclass
class BlockErrors:
    """Result of :func:`jacobian_blocks`.

    ``errors[(rows, cols)]`` is ``max|J_fd - J| / max(max|J|, max|J_fd|)`` over the block
    (0 if both are exactly zero, 1 if only one of them is), ``size[(rows, cols)]``
    is ``max|J|`` of the block, ``global_error`` the same difference scaled by ``max|J|`` of the
    whole matrix (the scaling of a single global check, kept to show what it hides).
    """

    errors: dict[tuple[str, str], float]
    size: dict[tuple[str, str], float]
    global_error: float
    label: str = ""

    def worst(self) -> tuple[tuple[str, str], float]:
        block = max(self.errors, key=self.errors.get)
        return block, self.errors[block]

    def table(self) -> str:
        lines = [f"Jacobian blocks {self.label} (global-max scaling: {self.global_error:.2e})",
                 f"  {'rows':>12} {'cols':>12} {'max|J_block|':>13} {'rel. error':>11}"]
        for (r, c), e in sorted(self.errors.items()):
            lines.append(f"  {r:>12} {c:>12} {self.size[(r, c)]:13.3e} {e:11.2e}")
        return "\n".join(lines)

    def failure(self, tol: float = TOL) -> str | None:
        """``None`` if every block's relative error is below ``tol``, else a message naming
        the worst block."""
        block, err = self.worst()
        if err < tol:
            return None
        return (f"Jacobian block {block[0]}-{block[1]} {self.label}: relative error {err:.3e} ≥ {tol:g} "
                f"(block max|J| {self.size[block]:.3e})\n{self.table()}")


def jacobian_blocks(system, ctx: StepContext, x0: np.ndarray, h: float = 1e-6,
                    h_field: Mapping[str, float] | None = None, dofs: Sequence[int] | None = None,
                    terms: Iterable[str] | None = None, label: str = "", recut: bool = False) -> BlockErrors:
    """Compare the assembled Jacobian with central differences of the residual, per field block.

    Parameters
    ----------
    system : System
        With its step begun (cut, frozen parameters) at ``ctx``.
    x0 : ndarray
        State at which the Jacobian is checked; restored on return.
    h : float
        Finite-difference step.
    h_field : mapping, optional
        Steps for the columns of some fields (names from :func:`dof_fields`), overriding ``h``.
        The round-off error of a column is about ``eps |R_row| / h`` for every row; where the
        residual is linear in a field (pressure) a large step removes it without truncation
        error, which matters when stiff rows (``E ~ 1e6``) meet a small block.
    dofs : sequence of int, optional
        Columns to check (all by default); blocks without a checked column are left out.
    terms : iterable of str, optional
        Residual terms to assemble (names from :func:`residual_terms`; all by default).
    label : str
        Shown in the table and assertion message.
    recut : bool
        Rebuild the cut for every residual evaluation, so that the differences include the
        dependence of the cut (fluid domain, interface pieces) on the displacements; without
        it the cut stays frozen at ``x0``.
    """
    fields = dof_fields(system)
    field_of = np.empty(len(x0), dtype=object)
    for name, d in fields.items():
        field_of[d] = name
    cols = np.arange(len(x0)) if dofs is None else np.asarray(dofs)
    step = np.full(len(x0), h)
    for name, hf in (h_field or {}).items():
        step[fields[name]] = hf
    with only_terms(system, terms):
        system.scatter(x0)
        if recut and system.fluid is not None and system.solids:
            system.update_cut()
        J = system.assemble(ctx, want_matrix=True, dirichlet=False).matrix().toarray()
        fd = np.empty((len(x0), len(cols)))
        for k, j in enumerate(cols):
            xp = x0.copy()
            xp[j] += step[j]
            xm = x0.copy()
            xm[j] -= step[j]
            fd[:, k] = (residual(system, ctx, xp, recut) - residual(system, ctx, xm, recut)) / (2 * step[j])
    system.scatter(x0)
    if recut and system.fluid is not None and system.solids:
        system.update_cut()
    Jc = J[:, cols]
    diff = np.abs(fd - Jc)
    errors, size = {}, {}
    col_field = field_of[cols]
    for rname, rows in fields.items():
        for cname in fields:
            ck = np.nonzero(col_field == cname)[0]
            if len(ck) == 0:
                continue
            an = float(np.max(np.abs(Jc[np.ix_(rows, ck)])))
            num = float(np.max(np.abs(fd[np.ix_(rows, ck)])))
            d = float(np.max(diff[np.ix_(rows, ck)]))
            errors[(rname, cname)] = 0.0 if d == 0.0 else d / max(an, num)
            size[(rname, cname)] = an
    scale, d_max = float(np.max(np.abs(J))), float(np.max(diff))
    glob = d_max / scale if scale > 0 else (np.inf if d_max > 0 else 0.0)
    return BlockErrors(errors, size, glob, label)


def check_jacobian(system, ctx: StepContext, x0: np.ndarray, h: float = 1e-6,
                   h_field: Mapping[str, float] | None = None, dofs: Sequence[int] | None = None,
                   tol: float = TOL, label: str = "", recut: bool = False) -> dict[str, BlockErrors]:
    """Per-block Jacobian check of all terms together and of every term on its own.

    Each term alone is checked so that a small term's error is measured against that term's
    own block size, not against the other terms added into the same block (the interface
    term's share of the solid-solid block, say). Arguments as in :func:`jacobian_blocks`; with
    ``recut`` only all terms together are compared (the cut's motion changes the fluid term's
    residual, whose Jacobian with respect to it comes from the coupling term).

    Returns
    -------
    dict
        ``"all"`` and every term name of :func:`residual_terms` → :class:`BlockErrors`
        (only ``"all"`` if the system has a single term).
    """
    names = list(residual_terms(system))
    runs = {"all": None} | ({n: [n] for n in names} if len(names) > 1 and not recut else {})
    out = {run: jacobian_blocks(system, ctx, x0, h, h_field, dofs, terms, f"[{label} {run}]".replace("[ ", "["),
                                recut) for run, terms in runs.items()}
    for res in out.values():
        print(res.table())
    failures = [m for m in (res.failure(tol) for res in out.values()) if m is not None]
    assert not failures, "\n".join(failures)
    return out
