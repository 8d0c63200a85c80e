"""Live progress display: simulated time, step, Newton iteration, residual and ETA.

On a terminal a single ``rich`` status line is redrawn; otherwise (logs, CI) about a hundred
plain lines are printed over the run."""

from __future__ import annotations

import sys
import time


def _fmt_eta(seconds: float) -> str:
    if seconds != seconds or seconds == float("inf"):
        return "--"
    seconds = int(seconds)
    h, rem = divmod(seconds, 3600)
    m, s = divmod(rem, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m:d}:{s:02d}"


class Monitor:
    """Progress reporter used by :class:`fsci.simulation.Simulation`."""

    def __init__(self, stream=None, live: bool | None = None) -> None:
        self.stream = stream or sys.stdout
        self.live = self.stream.isatty() if live is None else live
        self._status = None
        self._console = None
        self._t0 = time.perf_counter()
        self._last_print = 0.0
        self._it = 0
        self._res = 0.0

    def _line(self, sim, extra: str = "") -> str:
        t0, t1 = sim.problem.time.t_start, sim.problem.time.t_end
        frac = (sim.t - t0) / (t1 - t0) if t1 > t0 else 1.0
        el = time.perf_counter() - self._t0
        eta = el * (1 - frac) / frac if frac > 0 else float("inf")
        return (f"t = {sim.t:.6g}/{t1:.6g}  step {sim.step}  Newton {self._it}  |R| = {self._res:.2e}  "
                f"ETA {_fmt_eta(eta)}{extra}")

    def start(self, sim) -> None:
        self._t0 = time.perf_counter()
        if self.live:
            from rich.console import Console

            self._console = Console(file=self.stream)
            self._status = self._console.status(self._line(sim))
            self._status.start()
        else:
            print(f"fsci: running '{sim.problem.name}' ({sim.system.layout.n_dofs} unknowns, "
                  f"linear solver {sim.linear.name})", file=self.stream, flush=True)

    def iteration(self, sim, ctx, it: int, res: float, lam: float) -> None:
        self._it = it - 1
        self._res = res
        if self._status is not None:
            self._status.update(self._line(sim, f"  (step to t = {ctx.t_new:.6g}, damping {lam:.2f})"))

    def step_done(self, sim) -> None:
        if self._status is not None:
            self._status.update(self._line(sim))
            return
        t0, t1 = sim.problem.time.t_start, sim.problem.time.t_end
        now = time.perf_counter()
        frac = (sim.t - t0) / (t1 - t0) if t1 > t0 else 1.0
        if now - self._last_print > 5.0 or frac >= 1.0 or sim.step == 1:
            self._last_print = now
            print(self._line(sim), file=self.stream, flush=True)

    def message(self, text: str) -> None:
        if self._console is not None:
            self._console.log(text)
        else:
            print(text, file=self.stream, flush=True)

    def stop(self, sim) -> None:
        if self._status is not None:
            self._status.stop()
            self._status = None
            print(self._line(sim), file=self.stream, flush=True)
