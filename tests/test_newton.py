"""Newton while the cut follows the iterates: Aitken relaxation (docs/architecture.md,
decision 34) on a linear residual whose Jacobian is too soft, as in contact where the Jacobian
lacks part of the cut's motion, and the cut kept following while Newton converges (decision
35)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fsci.fields import StepContext
from fsci.problem import SolverSettings
from fsci.solver.linear import make_linear_solver
from fsci.solver.newton import aitken_factor, solve_nonlinear


class _Residual:
    """What Newton reads of an assembly."""

    def __init__(self, rhs: np.ndarray, matrix: sp.csr_matrix) -> None:
        self.rhs = rhs
        self.want_matrix = True
        self._matrix = matrix
        self.pattern = type("Pattern", (), {"key": None})()

    def matrix(self) -> sp.csr_matrix:
        return self._matrix


class OvershootingSystem:
    """``R(x) = A x − b`` (A symmetric positive definite) whose Jacobian is ``A / overshoot``: a
    full Newton update goes ``overshoot`` times too far, and the error changes by the factor
    ``1 − overshoot`` per iteration (−0.9 for 1.9: the iterates swing about the solution)."""

    def __init__(self, n: int, overshoot: float, follows: bool) -> None:
        rng = np.random.default_rng(2)
        m = rng.standard_normal((n, n))
        self.A = m @ m.T + n * np.eye(n)
        self.b = rng.standard_normal(n)
        self.x = np.zeros(n)
        self.overshoot = overshoot
        self.follows = follows
        self.kept: list[int] = []  # iterations up to which Newton asked the cut to keep following
        self.field_dofs = {"displacement": np.arange(n)}
        self.layout = object()

    def gather(self) -> np.ndarray:
        return self.x.copy()

    def scatter(self, x: np.ndarray) -> None:
        self.x = x.copy()

    def cut_follows(self) -> bool:
        return self.follows

    def keep_following(self, it: int) -> None:
        self.kept.append(it)

    def assemble(self, ctx: StepContext, want_matrix: bool = True) -> _Residual:
        return _Residual(self.A @ self.x - self.b, sp.csr_matrix(self.A / self.overshoot))

    def solution(self) -> np.ndarray:
        return np.linalg.solve(self.A, self.b)


def _solve(system: OvershootingSystem, relaxation: bool, static: bool = True):
    settings = SolverSettings(max_iterations=25, tol_residual=1e-10, tol_increment=1e-10, relaxation=relaxation)
    return solve_nonlinear(system, StepContext(0.0, 1.0, 1.0, 1.0, static), settings, make_linear_solver("superlu"))


def test_aitken_factor_halves_a_swing_and_leaves_quadratic_convergence_alone():
    """Updates that reverse (dx = −0.9 dx_prev after a full update): ω = 1 / 1.9, the factor
    that lands on the solution of a linear swing; updates that shrink 1000-fold: ω stays 1."""
    v = np.array([1.0, -2.0, 0.5])
    assert aitken_factor(-0.9 * v, v, 1.0) == pytest.approx(1.0 / 1.9, rel=1e-14)
    assert aitken_factor(1e-3 * v, v, 1.0) == 1.0


def test_relaxation_ends_the_swing_where_the_cut_follows():
    """A Jacobian 1.9 times too soft: Newton's error swings with factor −0.9 per iteration, and
    25 iterations do not reach the tolerance (the damping rule does not act: the residual falls
    every iteration); with Aitken relaxation the second update lands on the solution (measured:
    3 iterations, residual 2.4, 1.9, 4e-16). Where the cut is frozen (its Jacobian exact) nothing is relaxed."""
    plain = _solve(OvershootingSystem(6, 1.9, follows=True), relaxation=False)
    assert not plain.converged and plain.residuals[-1] > 1e-3
    system = OvershootingSystem(6, 1.9, follows=True)
    relaxed = _solve(system, relaxation=True)
    print(relaxed.iterations, relaxed.residuals)
    assert relaxed.converged and relaxed.iterations <= 4
    np.testing.assert_allclose(system.x, system.solution(), rtol=0, atol=1e-10)
    frozen = _solve(OvershootingSystem(6, 1.9, follows=False), relaxation=True)
    assert not frozen.converged


def test_the_cut_keeps_following_while_newton_converges():
    """Newton asks the cut to keep following for the next iteration whenever an iteration
    reduced the residual at least twofold (a Jacobian 1.2 times too soft: error factor −0.2 per
    iteration), and not while it creeps (factor −0.9: 1.9 times too soft, no relaxation)."""
    fast = OvershootingSystem(6, 1.2, follows=True)
    rep = _solve(fast, relaxation=False)
    assert rep.converged and len(fast.kept) >= 3
    assert fast.kept == list(range(3, 3 + len(fast.kept)))  # from iteration 2 on, every iteration
    slow = OvershootingSystem(6, 1.9, follows=True)
    _solve(slow, relaxation=False)
    assert slow.kept == []


class NoisySystem(OvershootingSystem):
    """``R(x) = A x − b + e`` with ``A`` of eigenvalues 1 … 1e-5 and a fresh round-off ``e`` of
    size 1e-12 at every assembly: below the residual tolerance 1e-10, but its solve moves ``x`` by
    up to 1e-7, far above the increment tolerance 1e-10. ``own_after``: the state is its cut's own
    only once :meth:`follow_cut_again` was called (a frozen cut the bodies moved away from)."""

    def __init__(self, n: int, own_after_recut: bool = False) -> None:
        super().__init__(n, 1.0, follows=False)
        q, _ = np.linalg.qr(np.random.default_rng(3).standard_normal((n, n)))
        self.A = q @ np.diag(np.geomspace(1.0, 1e-5, n)) @ q.T
        self.noise = np.random.default_rng(4)
        self.own = not own_after_recut
        self.recut_at: list[int] = []
        self.iteration = 0

    def before_iteration(self, it: int) -> bool:
        self.iteration = it
        return False

    def cut_is_own(self) -> bool:
        return self.own

    def follow_cut_again(self, it: int) -> None:
        self.recut_at.append(it)
        self.own = True

    def assemble(self, ctx: StepContext, want_matrix: bool = True) -> _Residual:
        r = self.A @ self.x - self.b + 1e-12 * self.noise.standard_normal(len(self.x))
        return _Residual(r, sp.csr_matrix(self.A))


def test_newton_stops_at_the_round_off_floor():
    """A residual at its round-off floor (below the tolerance, no longer falling) ends Newton
    although the solves of that round-off keep moving the state by more than the increment
    tolerance (decision 38): converged within a few iterates of the first whose residual passes
    (without the rule: not in 25 iterations), within the round-off's reach of the solution, in
    a time step and in steady flow. A frozen cut that is not the state's own is left for a re-cut at the first iterate whose
    residual passes, not after the increments pass too."""
    system = NoisySystem(6)
    rep = _solve(system, relaxation=False, static=False)
    print(rep.iterations, rep.residuals)
    passed = [k for k, r in enumerate(rep.residuals) if r <= 1e-10]
    assert rep.converged and rep.iterations <= passed[0] + 4
    np.testing.assert_allclose(system.x, system.solution(), rtol=0, atol=1e-5)
    steady = NoisySystem(6)
    rep = _solve(steady, relaxation=False, static=True)
    assert rep.converged and rep.iterations <= passed[0] + 4
    np.testing.assert_allclose(steady.x, steady.solution(), rtol=0, atol=1e-5)
    recut = NoisySystem(6, own_after_recut=True)
    rep = _solve(recut, relaxation=False, static=False)
    assert rep.converged and recut.recut_at == [passed[0] + 1]


def test_a_steady_flow_step_starts_from_the_secant_predictor():
    """The flow of a static (load) step starts from ``x_n + Δ (x_n − x_(n−1)) / Δ_n``: the
    distance from the start of the cavity's step 0.5 → 0.5 + Δ (after a step of Δ) to its
    solution falls as Δ² (it fell as Δ from the last solution)."""
    from fsci.cases import get_case
    from fsci.config import apply_override, problem_from_dict
    from fsci.simulation import Simulation

    def distance(d: float) -> float:
        case = get_case("cavity")
        apply_override(case, "n=8")
        case["time"] = {"type": "static", "segments": [{"until": 0.5 - d, "dt": 0.5 - d}, {"until": 0.5 + d, "dt": d}]}
        case["output"] = {"every": 0, "figures": False, "fields": False}
        sim = Simulation(problem_from_dict(case))
        f = sim.system.fluid
        start = []
        begin = sim.system.begin_step
        sim.system.begin_step = lambda ctx, **kw: (begin(ctx, **kw), start.append(np.concatenate([f.V.ravel(), f.P])))
        sim.run()
        return float(np.max(np.abs(np.concatenate([f.V.ravel(), f.P]) - start[-1])))

    e = [distance(d) for d in (0.1, 0.05)]
    assert np.log2(e[0] / e[1]) > 1.8


def test_load_step_ratio():
    """The ratio of a step's data change to the last step's: 1 along a ramp, −1 where a table
    turns back, the step ratio at a change of step size, and 0 (no prediction) where a datum
    stops or starts to change or an expression depends on t."""
    from fsci.cases import get_case
    from fsci.config import problem_from_dict
    from fsci.problem import load_step_ratio

    blocks = problem_from_dict(get_case("two-blocks"))  # a table 0 → 1 → 0 at t = 0, 1, 2
    assert load_step_ratio(blocks, 0.3, 0.4, 0.5) == pytest.approx(1.0)
    assert load_step_ratio(blocks, 0.3, 0.4, 0.6) == pytest.approx(2.0)
    assert load_step_ratio(blocks, 0.9, 1.0, 1.1) == pytest.approx(-1.0)
    fsi1 = get_case("turek-hron-fsi1")  # a ramp to t = 1
    assert load_step_ratio(problem_from_dict(fsi1), 0.0, 0.5, 1.0) == pytest.approx(1.0)
    assert load_step_ratio(problem_from_dict(fsi1), 0.5, 1.0, 1.5) == 0.0  # constant after the ramp
    fsi1["fluid"]["dirichlet"][0]["function"] = {"type": "ramp", "t0": 0.5, "t1": 1.0}
    assert load_step_ratio(problem_from_dict(fsi1), 0.0, 0.5, 1.0) == 0.0  # the inflow starts now
    fsi1["fluid"]["dirichlet"][0]["value"][0] = "6*U*y*(H-y)/H**2*t"
    assert load_step_ratio(problem_from_dict(fsi1), 0.0, 0.5, 1.0) == 0.0


def test_convergence_is_predicted_from_the_increment_or_a_passed_residual():
    """The matrix is left out of an assembly (``_residual_first``) where the last update
    passed the increment test or the last residual passed its test, or a chord step is ahead;
    not after a layout change, before the minimum iteration count (unless a chord step is
    ahead), or with none of these."""
    from fsci.solver.newton import _residual_first

    settings = SolverSettings()
    small = {"velocity": 0.1 * settings.tol_increment}
    large = {"velocity": 10.0 * settings.tol_increment}
    assert _residual_first(settings, 3, small, False, False, False)
    assert _residual_first(settings, 3, large, False, True, False)
    assert _residual_first(settings, 3, large, False, False, True)
    assert _residual_first(settings, settings.min_iterations, large, False, False, True)
    assert not _residual_first(settings, 3, large, False, False, False)
    assert not _residual_first(settings, 3, None, False, False, False)
    assert not _residual_first(settings, 3, small, True, True, True)
    assert not _residual_first(settings, settings.min_iterations, small, False, True, False)


class RoundOffSystem(OvershootingSystem):
    """``R(x) = A x − b`` plus round-off-sized noise (1e-12 and 5e-12 in turn, below
    ``tol_residual``): past the first solve the residual grows and falls within its tolerance."""

    def __init__(self) -> None:
        super().__init__(4, 1.0, follows=False)
        self.calls = 0

    def assemble(self, ctx: StepContext, want_matrix: bool = True) -> _Residual:
        self.calls += 1
        noise = (1e-12 if self.calls % 2 else 5e-12) * np.ones(len(self.x)) / 2.0
        return _Residual(self.A @ self.x - self.b + noise, sp.csr_matrix(self.A))


def test_round_off_growth_of_a_residual_within_tolerance_does_not_damp():
    """4C's damping rule multiplies the update by 0.75 when the residual grows; a residual that
    stays within tol_residual at both iterates and grows is round-off, so the factor stays 1
    (it slowed FSI1's last iterations)."""
    system = RoundOffSystem()
    lams: list[float] = []
    # at least six solves: the residual grows and falls within its tolerance several times
    settings = SolverSettings(max_iterations=25, tol_residual=1e-10, tol_increment=1e-30, min_iterations=6)
    rep = solve_nonlinear(system, StepContext(0.0, 1.0, 1.0, 1.0, True), settings, make_linear_solver("superlu"),
                          monitor=lambda it, res, lam: lams.append(lam))
    assert rep.converged and rep.iterations >= 5
    grew = [i for i in range(1, len(rep.residuals)) if rep.residuals[i] > rep.residuals[i - 1]]
    assert grew  # the noise made the residual grow at least once
    assert lams == [1.0] * len(lams)


class CubicSystem(OvershootingSystem):
    """``R(x) = A x + x³ − b`` (componentwise cube): Newton converges quadratically with the
    exact Jacobian ``A + 3 diag(x²)``. Counts the assemblies with and without the matrix."""

    def __init__(self) -> None:
        super().__init__(8, 1.0, follows=False)
        self.b = 10.0 * self.b
        self.with_matrix = 0
        self.without = 0

    def assemble(self, ctx: StepContext, want_matrix: bool = True) -> _Residual:
        self.with_matrix += want_matrix
        self.without += not want_matrix
        res = _Residual(self.A @ self.x + self.x ** 3 - self.b, sp.csr_matrix(self.A + np.diag(3.0 * self.x ** 2)))
        res.want_matrix = want_matrix
        return res


def test_the_increment_at_a_passing_residual_is_measured_with_the_factors_at_hand():
    """Where the residual passes its test and only the last increment does not, the next
    increment is solved with the factors Newton already has (a chord step, decision 49): no
    matrix is assembled for it, and the residual ahead of it is assembled without one when the
    last residual predicts a pass. The iterations are the same in number as without it (the
    chord step takes the residual from 1.2e-7 to 1.2e-11, Newton's to 4e-15: both end the
    solve), with either linear solver."""
    settings = SolverSettings(max_iterations=25, tol_residual=1e-5, tol_increment=1e-12)
    runs = {}
    for name in ("superlu", "pardiso"):
        try:
            linear = make_linear_solver(name)
        except Exception:  # PARDISO not loadable here
            continue
        system = CubicSystem()
        rep = solve_nonlinear(system, StepContext(0.0, 1.0, 1.0, 1.0, True), settings, linear)
        print(name, rep.iterations, rep.residuals, linear.counts, system.with_matrix, system.without)
        assert rep.converged
        x = system.x
        assert np.linalg.norm(system.A @ x + x ** 3 - system.b) <= 1e-3 * settings.tol_residual  # measured 1.2e-11
        passed = [k for k, r in enumerate(rep.residuals) if r <= settings.tol_residual]
        assert linear.counts["chord"] >= 1 and linear.counts["chord"] == rep.iterations - passed[0]
        # one matrix per solve with a matrix, none for a chord step
        assert system.with_matrix == rep.iterations - linear.counts["chord"]
        runs[name] = rep.iterations
    assert runs and len(set(runs.values())) == 1


def test_a_chord_step_within_the_increment_tolerance_ends_the_solve():
    """Where the chord step of decision 49 measures an increment within its tolerance, the
    iterate it was measured at is converged (decision 53): the solve ends there, with that
    iterate's own residual checked, and the correction is neither applied nor checked by
    another residual. So every iterate Newton reaches is assembled once, and none after the
    last solve (without the rule: one assembly more, at the corrected iterate)."""
    settings = SolverSettings(max_iterations=25, tol_residual=1e-5, tol_increment=1e-6)
    linear = make_linear_solver("superlu")
    system = CubicSystem()
    rep = solve_nonlinear(system, StepContext(0.0, 1.0, 1.0, 1.0, True), settings, linear)
    assert rep.converged and rep.on_chord
    assert linear.counts["chord"] == 1
    assert system.with_matrix + system.without == rep.iterations
    x = system.x  # the iterate the chord step was measured at (residual 1.2e-7), not corrected
    r = np.linalg.norm(system.A @ x + x ** 3 - system.b)
    assert abs(r - rep.residuals[-1]) <= 1e-12 * r and r <= settings.tol_residual
