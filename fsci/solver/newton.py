"""Monolithic damped Newton (paper (42), Sec. 3.4.1-3.4.2).

Damping follows 4C's rule: the factor is 1 at the first iteration of a step, multiplied by
0.75 when the residual norm grew, and otherwise raised again (divided by 0.875, or reset to 1
once above 0.875) unless the last three residual norms are non-monotone. A residual that grew
while every field stayed within ``tol_residual`` at both iterates is round-off and does not damp
(FSI1's last iterations at |R| ≈ 1e-10 took 12 instead of 11 with it).

While the cut follows the iterates (``System.cut_follows``) the update is also relaxed by
Aitken's factor (:func:`aitken_factor`): in contact the Jacobian lacks part of the cut's motion
and the updates can swing back and forth (docs/architecture.md, decision 34).

Convergence is checked per field (displacement, velocity, pressure): every residual norm
``||R_f||_2 <= max(tol_residual, rtol_residual * ||R_f^(0)||_2)`` and every increment norm
``||dx_f||_inf <= tol_increment`` — or, instead of the increments, the residual is at its
round-off floor: within ``tol_residual`` in every field, passing at the last iterate too, and
fallen by less than ``1 - FLOOR_RATE`` since.

At the first iterate of a solve whose residual passes its test but whose last increment does
not, the next increment is only measured: it is solved with the factors Newton already has (a
chord step, no new matrix; decision 49). Its residual is assembled first without the matrix
when the last residual predicts a pass (``|R|² <= tol_residual``: quadratic convergence with a
constant of order one). One chord step per solve: in contact, factors of an earlier iterate
can belong to other contact cases, and repeated chord steps then stalled (the coarse squeezed
body); a residual that grew after it is no reason to damp.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from fsci.errors import SolverError
from fsci.fields import StepContext
from fsci.problem import SolverSettings
from fsci.solver.linear import LinearSolver

DAMP_DOWN = 0.75
DAMP_UP = 0.875
FOLLOWING_RATE = 0.5  # the cut keeps following while each iteration reduces the residual by this
FLOOR_RATE = 0.9  # a passing residual that no longer falls below this fraction is at its round-off floor
BACKTRACK = 4  # halvings of a Newton update whose iterate cannot be evaluated, before the step is cut


@dataclass
class NewtonReport:
    """Outcome of one nonlinear solve."""

    converged: bool
    iterations: int
    residuals: list[float] = field(default_factory=list)
    field_residuals: list[dict[str, float]] = field(default_factory=list)
    reason: str = ""
    on_chord: bool = False  # converged by what its last (chord) solve measured (decision 53)


def _norms(vec: np.ndarray, dofs: dict[str, np.ndarray], kind: str) -> dict[str, float]:
    out = {}
    for name, idx in dofs.items():
        v = vec[idx]
        out[name] = float(np.max(np.abs(v))) if kind == "inf" and len(v) else float(np.linalg.norm(v))
    return out


def _increment_ok(inc_norms: dict[str, float] | None, settings: SolverSettings) -> bool:
    """The increment test of the convergence check: every field's last update is small."""
    return inc_norms is not None and all(v <= settings.tol_increment for v in inc_norms.values())


def _residual_first(settings: SolverSettings, it: int, inc_norms: dict[str, float] | None,
                    layout_changed: bool, res_ok_before: bool, chord_ahead: bool) -> bool:
    """Whether iteration ``it`` assembles its residual without the matrix first: where it will
    probably pass the convergence test (the last update passed the increment test, or the
    residual passed its test at the last iterate already, so that after one more update it is
    tiny or at its round-off floor; not before the minimum iteration count), or where its
    residual will probably pass and its increment be a chord step (``chord_ahead``, decision
    49). Never after a layout change. The matrix is assembled only if the residual says it is
    needed (no complex-step Jacobian of the coupling, no matrix entries: 0.27x the cost on the
    stamp); the residual is the same either way, so the iterates are too.

    Measured on the stamp's falling phase (fine, 50 steps; coarse, 500 steps): the increment
    test alone predicted 7 of 50 and 371 of 500 last iterations, with the passed residual
    29 of 50 and 383 of 500, and none of either failed. A prediction from the residual history
    (the last reduction factor repeated) was tried and dropped: after a re-cut the residual
    stalls near 1e-11 for one iteration, and 12 of 17 such predictions failed (each costing
    a residual assembly). The chord's prediction ``|R_(k-1)|² <= tol_residual``, applied to the
    residual histories of the whole coarse stamp before decision 49 (the norm against
    ``tol_residual``), was right in 2729 of 2730 cases and caught 2729 of the 4267 passing
    residuals at which a solve followed."""
    if layout_changed:
        return False
    if chord_ahead:
        return True
    if it - 1 < settings.min_iterations:
        return False
    return _increment_ok(inc_norms, settings) or res_ok_before


def system_cut_follows(system) -> bool:
    """Whether ``system`` rebuilt its cut at the current iterate (False for systems without one)."""
    return hasattr(system, "cut_follows") and system.cut_follows()


def forcing_term(totals: list[float], largest: float) -> float:
    """Relative residual the linear solve of this iteration may stop at (inexact Newton,
    Eisenstat & Walker 1996, choice 2 with γ = 0.9, α = 2): ``0.9 (|R_k| / |R_(k-1)|)²``, at most
    ``largest``. Where Newton converges quadratically the term is tiny and the solve exact; where
    it converges linearly (rate q, the Jacobian incomplete in contact) a solve to 0.9 q² loses
    nothing, and GMRES with the factors of an earlier iteration gets there without a new
    factorisation. 0 at the first iteration of a step or after a restart."""
    if largest <= 0.0 or len(totals) < 2 or totals[-2] <= 0.0:
        return 0.0
    return min(largest, 0.9 * (totals[-1] / totals[-2]) ** 2)


def aitken_factor(dx: np.ndarray, dx_prev: np.ndarray, omega_prev: float) -> float:
    """Relaxation factor of the update ``dx`` after the update ``dx_prev`` relaxed by
    ``omega_prev`` (Irons and Tuck 1969; Küttler and Wall 2008 for partitioned FSI):
    ``ω = −ω_prev dx_prev·(dx − dx_prev) / |dx − dx_prev|²``, kept in [0.1, 1]. Where Newton
    converges quadratically dx ≪ dx_prev and ω stays 1; where the updates swing back and forth
    (dx ≈ q dx_prev, q → −1) ω ≈ 1 / (1 − q) ≈ 1/2 takes the midpoint at once."""
    d = dx - dx_prev
    dd = float(d @ d)
    if dd <= 0.0:
        return omega_prev
    return min(1.0, max(0.1, -omega_prev * float(dx_prev @ d) / dd))


def solve_nonlinear(system, ctx: StepContext, settings: SolverSettings, linear: LinearSolver,
                    monitor: Callable[[int, float, float], None] | None = None) -> NewtonReport:
    """Solve ``R(x) = 0`` for the current step; the system's state holds the result.

    Returns a report; on failure (no convergence, non-finite values, singular matrix) the
    state is left as it is and ``converged`` is False — the caller restores and retries.
    """
    x = system.gather()
    lam = 1.0
    report = NewtonReport(False, 0)
    linear.new_system()
    r0: dict[str, float] | None = None
    inc_norms: dict[str, float] | None = None
    totals: list[float] = []
    last: tuple[np.ndarray, np.ndarray, float] | None = None  # state before the last update, update, length
    last_layout = None  # the dof layout ``last`` belongs to
    relaxed: tuple[np.ndarray, float] | None = None  # last update and its Aitken factor, while the cut follows
    res_ok_before = False  # the residual test passed at the last iterate (since the last restart)
    small_before = False  # every field's residual was within tol_residual there
    matrix_layout = None  # the dof layout of the last solve with a matrix: the linear solver's factors are of it
    chorded = False  # a chord step was taken in this solve
    last_chord = False  # the last update was one

    def factors_at_hand() -> bool:
        """The linear solver has factors of a matrix of the current dof layout."""
        return matrix_layout is system.layout and linear.has_factors()

    for it in range(1, settings.max_iterations + 2):
        for halving in range(BACKTRACK + 1):
            try:
                layout_changed = system.before_iteration(it) if hasattr(system, "before_iteration") else False
                chord_ahead = (not chorded and factors_at_hand() and bool(totals)
                               and totals[-1] ** 2 <= settings.tol_residual)
                asm = system.assemble(ctx, want_matrix=not _residual_first(settings, it, inc_norms, layout_changed,
                                                                            res_ok_before, chord_ahead))
                break
            except (SolverError, ArithmeticError) as exc:
                # an iterate the model cannot evaluate (an outline crossing itself or leaving the
                # box, a degenerate element): go back half the last update (a thin flap swung
                # through itself by a full Newton step); if that does not help, a failed solve,
                # which the time loop retries with a smaller step
                if last is None or halving == BACKTRACK or last_layout is not system.layout:
                    report.reason = f"iterate {it} cannot be evaluated: {exc}"
                    report.iterations = it - 1
                    return report
                x_old, dx_old, lam = last[0], last[1], 0.5 * last[2]
                last = (x_old, dx_old, lam)
                x = x_old + lam * dx_old
                system.scatter(x)
                inc_norms = _norms(lam * dx_old, system.field_dofs, "inf")
        if layout_changed:
            # the ACTIVE set changed: state transferred, Newton restarted (damping and residual
            # history reset, as 4C's outer loop); the iteration count goes on
            x = system.gather()
            lam = 1.0
            totals = []
            r0 = None
            inc_norms = None
            res_ok_before = small_before = False
        R = asm.rhs
        if not np.all(np.isfinite(R)):
            report.reason = "non-finite residual"
            return report
        norms = _norms(R, system.field_dofs, "l2")
        total = float(np.linalg.norm(R))
        report.residuals.append(total)
        report.field_residuals.append(norms)
        if monitor is not None:
            monitor(it, total, lam)
        if r0 is None:
            r0 = norms
        res_ok = all(norms[f] <= max(settings.tol_residual, settings.rtol_residual * r0[f]) for f in norms)
        inc_ok = _increment_ok(inc_norms, settings)
        tiny = all(norms[f] <= 1e-3 * settings.tol_residual for f in norms)
        # at the round-off floor: the residual is within the absolute tolerance, passed its test
        # at the last iterate as well and no longer falls, so the increments are the round-off of
        # the solves (the pressure's, with an absolute tolerance, can stay above it for good) and
        # need not pass theirs (decision 38). Not on the relative test: where Newton converges
        # linearly (in contact) a residual that passes it can still be creeping
        small = all(v <= settings.tol_residual for v in norms.values())
        floor = res_ok_before and bool(totals) and total > FLOOR_RATE * totals[-1] and small
        solves = it - 1
        recut = False
        own_checked = False  # the iterate passed every test but the increment's, on its own cut
        if res_ok and solves >= settings.min_iterations and not layout_changed:
            if not hasattr(system, "cut_is_own") or system.cut_is_own():
                if inc_ok or tiny or floor:
                    report.converged = True
                    report.iterations = solves
                    return report
                own_checked = True
            else:
                # the cut follows again (the jump of the re-cut residual is no reason to damp), at
                # once: the increments need not pass their test on a cut that is not the state's
                # own, and near round-off they can take several iterations to (decision 38)
                recut = True
        if it > settings.max_iterations:
            break
        if totals and total < FOLLOWING_RATE * totals[-1] and system_cut_follows(system):
            # converging with the cut following: no reason to freeze it (decision 35)
            system.keep_following(it + 1)
        if settings.damping and totals:
            if total > totals[-1] and not (small and small_before) and not last_chord:
                # (a residual within the absolute tolerance at both iterates that grew is
                # round-off, no sign of divergence: damping only slows the last iterations; nor
                # is the growth after a chord step, which was no Newton update)
                lam *= DAMP_DOWN
            elif len(totals) >= 2 and not (totals[-2] >= totals[-1] >= total):
                pass  # non-monotone history: keep the factor
            else:
                lam = lam / DAMP_UP if lam < DAMP_UP else 1.0
        totals.append(total)
        # the residual passes, only the increment is still to be measured: a chord step with the
        # factors at hand, once per solve (decision 49)
        chord = res_ok and not chorded and not recut and not layout_changed and factors_at_hand()
        chorded |= chord
        if not asm.want_matrix and not chord:  # predicted convergence did not happen: the same state with its matrix
            try:
                asm = system.assemble(ctx, want_matrix=True)
            except (SolverError, ArithmeticError) as exc:
                report.reason = f"Jacobian of iterate {it} cannot be evaluated: {exc}"
                report.iterations = solves
                return report
        res_ok_before, small_before = res_ok, small
        if recut:
            system.follow_cut_again(it)  # after the matrix: it is the frozen cut's, as the residual
            totals, lam, res_ok_before, small_before = [], 1.0, False, False
        try:
            if chord:
                dx = linear.solve_with_factors(-R)
            else:
                dx = linear.solve(asm.matrix(), -R, asm.pattern.key, forcing_term(totals, settings.forcing))
                matrix_layout = system.layout
        except SolverError as exc:
            report.reason = str(exc)
            report.iterations = solves
            return report
        if not np.all(np.isfinite(dx)):
            report.reason = "non-finite Newton increment"
            report.iterations = solves
            return report
        if chord and own_checked and _increment_ok(_norms(dx, system.field_dofs, "inf"), settings):
            # what the chord step measured is within the increment tolerance: the iterate is
            # converged, and stays as it is, with its own cut and its residual checked; the
            # correction is not applied (it would only need another cut and residual to check,
            # decision 53)
            report.converged = report.on_chord = True
            report.iterations = solves + 1
            return report
        if hasattr(system, "keep_pattern") and not chord:
            system.keep_pattern(asm.pattern)
        # while the cut follows the iterates in contact the Jacobian lacks part of the cut's
        # motion and the updates can swing back and forth: Aitken relaxation (decision 34)
        omega = 1.0
        if settings.relaxation and it >= 2 and not recut and not layout_changed and not chord \
                and system_cut_follows(system):
            if relaxed is not None:  # reset at every re-cut restart and ACTIVE-set change
                omega = aitken_factor(dx, *relaxed)
            relaxed = (dx, lam * omega)  # the factor applied, damping included
        else:
            relaxed = None
        last, last_layout = (x, dx, lam * omega), system.layout
        x = x + lam * omega * dx
        system.scatter(x)
        inc_norms = _norms(lam * omega * dx, system.field_dofs, "inf")
        last_chord = chord
        report.iterations = solves + 1
    report.reason = f"no convergence in {settings.max_iterations} iterations (residual {report.residuals[-1]:.3e})"
    return report
