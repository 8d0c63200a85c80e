"""The time loop: steps, Newton with step-size cuts, outputs, quantities and results.

A failing Newton solve restores the state of the step start and retries with a smaller step
(``solver.step_cut_factor``, at most ``solver.max_step_cuts`` times, never below
``solver.dt_min``); after ``solver.steps_before_growth`` converged steps the step grows back
towards the scheduled size. If the step
cannot be completed, the results computed so far are written and
:class:`fsci.errors.SolverError` is raised.

Nothing is lost (docs/reliability.md): history.csv gets each step's row as the step completes;
a checkpoint is written when ``output.checkpoint_minutes`` of wall time passed (and every
``output.checkpoint_every`` steps if set), at every step-size cut, on an interrupt (SIGINT,
SIGTERM: :class:`KeyboardInterrupt`), on failure and at the end; every file is replaced
atomically.
"""

from __future__ import annotations

import json
import math
import shutil
import signal
import threading
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator


from fsci import __version__
from fsci.errors import InputError, SolverError
from fsci.fields import StepContext
from fsci.post.quantities import QuantityEvaluator, relative_mass_error
from fsci.problem import Problem, load_step_ratio
from fsci.solver.linear import make_linear_solver
from fsci.solver.newton import NewtonReport, solve_nonlinear
from fsci.system import HOLD_LEAK, HOLD_LEAK_FALLBACK, System, restore, snapshot

EPS_T = 1e-12


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM during :meth:`Simulation.run` (``signum`` says which)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def interruption_in(exc: BaseException) -> KeyboardInterrupt | None:
    """The interrupt (Ctrl-C, or SIGINT/SIGTERM through the run's handler) inside ``exc``'s
    chain of causes, if any: numba's dispatcher turns an exception raised while it loads or
    compiles a kernel into a ``SystemError`` whose cause is that exception."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


class Simulation:
    """Runs a :class:`Problem` and writes its outputs into ``out_dir`` (if given)."""

    def __init__(self, problem: Problem, out_dir: Path | None = None, monitor=None,
                 base_dir: Path | None = None) -> None:
        self.problem = problem
        self.base_dir = base_dir
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self.system = System(problem)
        self.linear = make_linear_solver(problem.solver.linear)
        self.quantities = QuantityEvaluator(problem, self.system)
        self.monitor = monitor
        self.history: list[dict[str, float]] = []
        self.t = problem.time.t_start
        self.step = 0
        self.newton_total = 0
        self.dt_current: float | None = None
        self.steps_at_dt = 0  # converged steps at the current reduced size (solver.steps_before_growth)
        self.wall_start = time.perf_counter()
        self.last_checkpoint = self.wall_start
        self.writer = None
        self.history_file = None
        self.stop_signal: int | None = None  # a signal received outside a Newton solve, acted on after the step
        self._in_solve = False
        self.step_hooks: list[Callable[["Simulation", StepContext, NewtonReport], None]] = []
        # wall time, per-phase timings and counts of the processes before a resume
        self.carried: dict = {"wall_time": 0.0, "timings": {}, "counts": {}}

    @classmethod
    def resume(cls, out_dir: Path, overrides: list[str] | None = None, monitor=None,
               first_dt: float | None = None) -> "Simulation":
        """Continue the run whose checkpoint and case.toml are in ``out_dir``; ``overrides``
        (``--set``) change the case from here on and are written into its case.toml.
        ``first_dt`` (``fsci resume --dt``) replaces the step size the run stopped with (after
        a failed step, its last cut): the next step takes it (at most the scheduled one), and
        later steps grow back to the schedule as after a step cut."""
        from fsci.config import apply_override, load_toml, problem_from_dict
        from fsci.io.checkpoint import read_checkpoint, stored_meshes
        from fsci.io.vtk import VTKWriter

        out_dir = Path(out_dir)
        state, meta = read_checkpoint(out_dir)
        case = load_toml(out_dir / "case.toml")
        for o in overrides or []:
            apply_override(case, o)
        base = Path(meta["base_dir"]) if meta.get("base_dir") else None
        problem = problem_from_dict(case, base)
        for b, mesh in stored_meshes(state).items():  # the meshes the run ran on (gmsh may differ)
            problem.bodies[b].mesh = mesh
        sim = cls(problem, out_dir, monitor, base_dir=base)
        restore(sim.system, state)
        sim.t = meta["t"]
        sim.step = meta["step"]
        sim.newton_total = meta["newton_total"]
        sim.dt_current = meta["dt_current"]
        sim.steps_at_dt = meta.get("steps_at_dt", 0)
        if first_dt is not None:
            if not first_dt > 0.0:
                raise InputError("--dt", first_dt, "a positive step size")
            sim.dt_current = first_dt if first_dt < sim.nominal_dt(sim.t)[0] else None
            sim.steps_at_dt = 0
        sim.history = meta["history"]
        sim.carried = meta.get("run_totals", sim.carried)
        if meta.get("writer") is not None and sim.problem.output.fields:
            sim.writer = VTKWriter(out_dir)
            sim.writer.count = meta["writer"]["count"]
            # field outputs of the run so far, less any whose file is gone (a run directory
            # carried on without its vtu/ folder): fields.pvd lists only files that exist
            sim.writer.entries = [tuple(e) for e in meta["writer"]["entries"] if (out_dir / e[-1]).exists()]
        if overrides:  # the folder describes the case that runs on: a later resume continues it
            import tomli_w

            from fsci.io.atomic import write_text

            write_text(out_dir / "case.toml", tomli_w.dumps(case))
            sim.checkpoint()  # the same state, recorded with the new case.toml's digest
        return sim

    # ----------------------------------------------------------------- stepping
    def nominal_dt(self, t: float) -> tuple[float, float]:
        """Scheduled step size at time ``t`` and the end of its segment."""
        for end, dt in self.problem.time.segments:
            if t < end - EPS_T * max(1.0, abs(end)):
                return dt, end
        end, dt = self.problem.time.segments[-1]
        return dt, end

    def next_dt(self) -> float:
        dt_nom, seg_end = self.nominal_dt(self.t)
        dt = dt_nom if self.dt_current is None else min(dt_nom, self.dt_current)
        remaining = seg_end - self.t
        if abs(remaining - dt) <= 1e-9 * dt:
            return dt  # lands on the segment end up to round-off: keep the scheduled step exactly
        if dt > remaining or remaining - dt < 1e-6 * dt_nom:
            dt = remaining
        return dt

    def solve_step(self, ctx: StepContext) -> NewtonReport:
        """Newton for one step (steady flow: the frozen stabilisation velocity is lagged inside
        Newton, see :meth:`fsci.system.System.before_iteration`)."""
        return solve_nonlinear(self.system, ctx, self.problem.solver, self.linear, self._newton_monitor(ctx))

    def _newton_monitor(self, ctx: StepContext):
        if self.monitor is None:
            return None
        return lambda it, res, lam: self.monitor.iteration(self, ctx, it, res, lam)

    def advance(self) -> StepContext:
        """Take one step (with retries); returns the completed step's context."""
        p = self.problem
        static = p.time.kind == "static"
        dt = self.next_dt()
        cuts = 0
        hold = False  # contact that swings is held (decision 38)
        hold_pockets = True  # a pocket that opens and shuts is held dry (decision 36)
        leak_bound = HOLD_LEAK  # a held state that loses more is solved again without the hold
        refused_leak = None  # the error of the held state refused at this step size
        while True:
            saved = snapshot(self.system)
            lead = self._load_lead(dt) if static else (dt if p.solver.predictor == "constant_acceleration" else 0.0)
            ctx = StepContext(self.t, self.t + dt, dt, p.time.theta, static, lead)
            try:
                self._in_solve = True  # a signal now stops at once: the step start is restored
                try:
                    self.system.begin_step(ctx, hold_swings=hold, hold_pockets=hold_pockets)
                except SolverError as exc:  # the predicted start cannot be cut: a smaller step predicts less
                    rep = NewtonReport(False, 0, reason=f"step start cannot be evaluated: {exc}")
                else:
                    rep = self.solve_step(ctx)
            except KeyboardInterrupt:
                restore(self.system, saved)  # back to the last completed step for the checkpoint
                raise
            except SystemError as exc:
                # a signal that arrives while numba loads or compiles a kernel reaches us wrapped
                stop = interruption_in(exc)
                if stop is None:
                    raise
                restore(self.system, saved)
                raise stop from None
            finally:
                self._in_solve = False
            self.newton_total += rep.iterations
            if rep.converged:
                self.system.finish_step(ctx)
                leak = relative_mass_error(self.system) if self.system.holds_pocket() else 0.0
                if leak <= leak_bound:
                    break
                # fluid flowed through the held region's edge: the same step without the hold
                restore(self.system, saved)
                hold_pockets = False
                refused_leak = leak
                self._report_retry(f"the state with a pocket held dry loses {leak:.2g} of the flux; "
                                   f"repeated without the hold")
                continue
            restore(self.system, saved)
            if refused_leak is not None and refused_leak <= HOLD_LEAK_FALLBACK and leak_bound < HOLD_LEAK_FALLBACK:
                # it fails without the hold: the held state it refused, solved again, is accepted
                # rather than the step cut (decision 51)
                leak_bound = HOLD_LEAK_FALLBACK
                hold_pockets = True
                self._report_retry(f"{rep.reason} without the hold; the held state (loss {refused_leak:.2g} "
                                   f"of the flux) is solved again and kept")
                continue
            if not hold and dt < self.nominal_dt(self.t)[0] and self.system.contact_swung():
                # a step already cut below the schedule in which contact swung back and forth: a
                # smaller one does not help (the residual's round-off floor rises as 1/Δt), the
                # same one with that contact held does (decision 38)
                hold = True
                self._report_retry(f"{rep.reason}; repeated with the contact that swung held")
                continue
            cuts += 1
            new_dt = dt * p.solver.step_cut_factor
            self._report_retry(f"{rep.reason}; retrying with dt={new_dt:.4g}")
            if self.out_dir is not None:  # the last completed step, before a risky retry or the stop
                self.checkpoint()
            if cuts > p.solver.max_step_cuts or new_dt < p.solver.dt_min:
                if self.system.fluid is not None and self.system.solids:
                    self.system.update_cut(keep_nodes=self.system.fluid.node_active)  # consistent outputs
                raise SolverError(f"step {self.step + 1} at t = {self.t:.6g} failed after {cuts - 1} step cuts "
                                  f"(dt = {dt:.4g}): {rep.reason}")
            dt = new_dt
            hold_pockets = True
            leak_bound, refused_leak = HOLD_LEAK, None
        row_values = self.quantities.step_values()
        self.system.end_step(ctx)
        self.t = ctx.t_new
        self.step += 1
        dt_nom, _ = self.nominal_dt(self.t - 0.5 * dt)
        if cuts or self.dt_current is not None:  # off the scheduled size: grow back step by step
            d, self.steps_at_dt = self._after_reduced_step(dt, 0 if cuts else self.steps_at_dt, dt_nom)
            self.dt_current = None if d >= dt_nom else d
        row = {"time": self.t, "step": self.step, "dt": dt, "newton_iterations": rep.iterations}
        row.update(row_values)
        self.history.append(row)
        for hook in self.step_hooks:
            hook(self, ctx, rep)
        return ctx

    def _report_retry(self, what: str) -> None:
        """Tell the monitor why the step being solved is tried again, and how."""
        if self.monitor is not None:
            self.monitor.message(f"step {self.step + 1} at t={self.t:.6g}: {what}")

    def _load_lead(self, dt: float) -> float:
        """``lead`` of a static step of size ``dt`` from now (:class:`StepContext`): the ratio of
        its data change to the last step's, times the last step's length (0 at the first step)."""
        if not self.history:
            return 0.0
        dt_last = float(self.history[-1]["dt"])
        return load_step_ratio(self.problem, self.t - dt_last, self.t, self.t + dt) * dt_last

    def _after_reduced_step(self, dt: float, k: int, dt_nom: float) -> tuple[float, int]:
        """Step size and count of converged steps at it after one more converged step of the
        reduced size ``dt`` (``k`` before it): grown by 1/step_cut_factor (up to ``dt_nom``)
        after ``solver.steps_before_growth`` such steps."""
        k += 1
        if k >= self.problem.solver.steps_before_growth:
            return min(dt_nom, dt / self.problem.solver.step_cut_factor), 0
        return dt, k

    def remaining_steps(self) -> int:
        """Steps left on the time grid: each segment at its scheduled step size; after a
        step-size cut the current step grows back as :meth:`advance` lets it."""
        t, n, d, k = self.t, 0, self.dt_current, self.steps_at_dt
        for end, dt in self.problem.time.segments:
            if t >= end - EPS_T * max(1.0, abs(end)):
                continue
            while d is not None and d < dt and t < end:
                t, n = t + d, n + 1
                d, k = self._after_reduced_step(d, k, dt)
            if t < end:
                n += math.ceil((end - t) / dt - 1e-9)
                t = end
            d = None
        return n

    def finished(self) -> bool:
        t_end = self.problem.time.t_end
        return self.t >= t_end - EPS_T * max(1.0, abs(t_end))

    # ----------------------------------------------------------------- run
    def run(self) -> dict:
        """Run to the end time and write all outputs; returns the results dictionary."""
        from fsci.io.history import HistoryFile
        from fsci.io.vtk import VTKWriter

        if self.out_dir is not None:
            self.out_dir.mkdir(parents=True, exist_ok=True)
            self.history_file = HistoryFile(self.out_dir / "history.csv")
            if self.history:  # resumed: the file may hold rows written after the checkpoint
                self.history_file.rewrite(self.history)
            if self.problem.output.fields and self.writer is None:
                self.writer = VTKWriter(self.out_dir)
                if self.step == 0:
                    self.writer.write(self.system, self.t)
        if self.monitor is not None:
            self.monitor.start(self)
        every = self.problem.output.every
        try:
            with self._signals():
                self._loop(every)
        except KeyboardInterrupt:
            if self.out_dir is not None:
                self.checkpoint()  # the last completed step
            raise
        finally:
            if self.monitor is not None:
                self.monitor.stop(self)
        if self.writer is not None and (every == 0 or self.step % every != 0):
            self.writer.write(self.system, self.t)
        if self.out_dir is not None:
            self.checkpoint()
        return self.finalize()

    @contextmanager
    def _signals(self) -> Iterator[None]:
        """SIGINT and SIGTERM stop the run cleanly: inside a Newton solve at once (the step is
        undone), otherwise after the current step and its outputs are complete."""
        if threading.current_thread() is not threading.main_thread():
            yield
            return

        def handler(signum: int, frame) -> None:
            self.stop_signal = signum
            if self._in_solve:
                raise Interrupted(signum)

        previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield
        finally:
            for s, h in previous.items():
                signal.signal(s, h)

    def checkpoint(self) -> None:
        """Write a checkpoint of the current (completed) step."""
        from fsci.io.checkpoint import write_checkpoint

        write_checkpoint(self, self.out_dir)
        self.last_checkpoint = time.perf_counter()

    def _loop(self, every: int) -> None:
        """Steps to the end time with history rows, field output and periodic checkpoints."""
        o = self.problem.output
        while not self.finished():
            self.advance()
            if self.history_file is not None:
                self.history_file.sync(self.history)
            if self.monitor is not None:
                self.monitor.step_done(self)
            if self.writer is not None and every > 0 and self.step % every == 0:
                self.writer.write(self.system, self.t)
            if self.out_dir is not None and self._checkpoint_due(o):
                self.checkpoint()
            if self.stop_signal is not None:
                raise Interrupted(self.stop_signal)

    def _checkpoint_due(self, o) -> bool:
        by_steps = o.checkpoint_every > 0 and self.step % o.checkpoint_every == 0
        by_time = o.checkpoint_minutes > 0 and time.perf_counter() - self.last_checkpoint >= 60.0 * o.checkpoint_minutes
        return by_steps or by_time

    def results(self) -> dict:
        values = self.quantities.final_values(self.history, self.out_dir)
        res: dict = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in values.items()}
        checks = []
        for r in self.problem.references:
            got = res.get(r.name)
            ok = got is not None and abs(got - r.value) <= r.rtol * abs(r.value)
            checks.append({"name": r.name, "value": got, "reference": r.value, "rtol": r.rtol,
                           "rel_error": None if got is None else abs(got - r.value) / abs(r.value),
                           "pass": bool(ok), "source": r.source})
        if checks:
            res["reference_checks"] = checks
        res["run"] = {
            "version": __version__,
            "case": self.problem.name,
            "steps": self.step,
            "newton_iterations": self.newton_total,
            "linear_solver": self.linear.name,
            "unknowns": self.system.layout.n_dofs,
            "final_time": self.t,
            **self.run_totals(),
        }
        return res

    def run_totals(self) -> dict:
        """Wall time, per-phase timings and counts of the whole run, the processes before a
        resume included (carried in the checkpoint)."""
        c = self.carried
        timings = {**self.system.timings, **self.linear.timings}
        counts = {**self.system.counts, **self.linear.counts}
        return {"wall_time": c["wall_time"] + time.perf_counter() - self.wall_start,
                "timings": {k: round(c["timings"].get(k, 0.0) + timings.get(k, 0.0), 3)
                            for k in dict.fromkeys([*timings, *c["timings"]])},
                "counts": {k: c["counts"].get(k, 0) + counts.get(k, 0) for k in dict.fromkeys([*counts, *c["counts"]])}}

    def finalize(self) -> dict:
        """Results dictionary; with an output folder also results.json and the figures (drawn
        into a temporary folder and moved in, so a failed figure leaves no partial file)."""
        from fsci.io.atomic import write_text

        res = self.results()
        if self.out_dir is not None:
            write_text(self.out_dir / "results.json", json.dumps(res, indent=2) + "\n")
            if self.problem.output.figures:
                from fsci.post.figures import history_figures, state_figure

                fig_dir = self.out_dir / "figures"
                tmp = self.out_dir / ".figures.tmp"
                shutil.rmtree(tmp, ignore_errors=True)
                try:
                    history_figures(self.history, tmp)
                    state_figure(self.system, tmp / "final_state.png", f"{self.problem.name}, t = {self.t:.4g}")
                    for hook in getattr(self.problem, "figure_hooks", None) or []:
                        hook(self, tmp)
                    fig_dir.mkdir(exist_ok=True)
                    for f in sorted(tmp.iterdir()):
                        f.replace(fig_dir / f.name)
                finally:
                    shutil.rmtree(tmp, ignore_errors=True)
        return res
