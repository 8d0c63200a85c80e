"""Live progress display: simulated time, step, Newton iteration, residual, ETA and, with
contact, the number of interface points in each case I-IV.

A header line names the case, its size and the linear solver. On a terminal a single ``rich``
status line is redrawn; otherwise (logs, CI) a line is printed about every 5 s. Every line
fits 80 columns.

The ETA is the number of steps left on the time grid (the segments' scheduled step sizes, or
the current reduced step after a step-size cut) times the measured wall time per step (an
exponential average over roughly the last 20 steps; the first step, which may compile
kernels, is left out once later ones exist).
"""

from __future__ import annotations

import math
import sys
import threading
import time
from typing import TextIO

WIDTH = 79  # characters of a progress line (a terminal of 80 columns does not wrap it)
COMPILE_NOTICE = 3.0  # seconds without progress before saying that kernels are being compiled
CASES = ("case_I", "case_II", "case_III", "case_IV")


def fmt_duration(seconds: float) -> str:
    """``h:mm:ss`` or ``m:ss``; ``--`` when unknown."""
    if not math.isfinite(seconds):
        return "--"
    seconds = int(round(seconds))
    h, rem = divmod(seconds, 3600)
    m, s = divmod(rem, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m:d}:{s:02d}"


def fit(parts: list[str], width: int = WIDTH) -> str:
    """Join ``parts`` with two spaces, or one if that is too long; cut at ``width``."""
    line = "  ".join(p for p in parts if p)
    if len(line) > width:
        line = " ".join(p for p in parts if p)
    return line[:width]


class Notice:
    """Print ``text`` once if :meth:`cancel` is not called within ``delay`` seconds (from a
    timer thread: the main thread is busy in compiled code)."""

    def __init__(self, text: str, emit, delay: float = COMPILE_NOTICE) -> None:
        self._timer = threading.Timer(delay, emit, args=(text,))
        self._timer.daemon = True
        self._timer.start()

    def cancel(self) -> None:
        self._timer.cancel()


class StepClock:
    """Measured wall time per step: an exponential average (weight ``alpha`` of the newest)."""

    def __init__(self, alpha: float = 0.1) -> None:
        self.alpha = alpha
        self.per_step = math.nan
        self.first = math.nan
        self.steps = 0
        self._last = time.perf_counter()

    def restart(self) -> None:
        self._last = time.perf_counter()

    def tick(self) -> None:
        now = time.perf_counter()
        dt, self._last = now - self._last, now
        self.steps += 1
        if self.steps == 1:
            self.first = dt  # may include compiling the kernels
        elif self.steps == 2:
            self.per_step = dt
        else:
            self.per_step += self.alpha * (dt - self.per_step)

    def seconds_per_step(self) -> float:
        return self.first if self.steps == 1 else self.per_step


class Monitor:
    """Progress reporter used by :class:`fsci.simulation.Simulation`."""

    def __init__(self, stream: TextIO | None = None, live: bool | None = None) -> None:
        self.stream = stream or sys.stdout
        self.live = self.stream.isatty() if live is None else live
        self._status = None
        self._console = None
        self._last_print = 0.0
        self._it = 0
        self._res = math.nan
        self.clock = StepClock()
        self._notice: Notice | None = None

    # ----------------------------------------------------------------- text
    def eta(self, sim) -> float:
        """Seconds to the end: steps left on the time grid × measured seconds per step."""
        return sim.remaining_steps() * self.clock.seconds_per_step()

    def line(self, sim) -> str:
        """The progress line (≤ 79 characters)."""
        t1 = sim.problem.time.t_end
        row = sim.history[-1] if sim.history else {}
        cases = "I-IV " + "/".join(str(int(row[c])) for c in CASES) if all(c in row for c in CASES) else ""
        res = "" if math.isnan(self._res) else f"|R| {self._res:.1e}"
        return fit([f"t {sim.t:.5g}/{t1:.5g}", f"step {sim.step}", f"it {self._it}", res,
                    f"ETA {fmt_duration(self.eta(sim))}", cases])

    def header(self, sim) -> str:
        return fit([f"fsci: '{sim.problem.name}'", f"{sim.system.layout.n_dofs} unknowns",
                    f"{sim.remaining_steps()} steps", f"linear solver {sim.linear.name}"])

    def _print(self, text: str) -> None:
        if self._console is not None:
            self._console.print(text, highlight=False, soft_wrap=True)
        else:
            print(text, file=self.stream, flush=True)

    # ----------------------------------------------------------------- events
    def start(self, sim) -> None:
        self.clock.restart()
        if self.live:
            from rich.console import Console

            self._console = Console(file=self.stream, width=WIDTH + 1)
            self._print(self.header(sim))
            self._status = self._console.status(self.line(sim))
            self._status.start()
        else:
            self._print(self.header(sim))
        if sim.step == 0:
            self._notice = Notice("  (first use: compiling numerical kernels, cached for later runs)", self.message)

    def iteration(self, sim, ctx, it: int, res: float, lam: float) -> None:
        if self._notice is not None:
            self._notice.cancel()
            self._notice = None
        self._it = it - 1
        self._res = res
        if self._status is not None:
            self._status.update(self.line(sim))

    def step_done(self, sim) -> None:
        self.clock.tick()
        if self._status is not None:
            self._status.update(self.line(sim))
            return
        now = time.perf_counter()
        if now - self._last_print > 5.0 or sim.finished() or sim.step == 1:
            self._last_print = now
            self._print(self.line(sim))

    def message(self, text: str) -> None:
        if self._console is not None:
            self._console.log(text[:WIDTH - 12])
        else:
            print(text, file=self.stream, flush=True)

    def stop(self, sim) -> None:
        if self._notice is not None:
            self._notice.cancel()
            self._notice = None
        if self._status is not None:
            self._status.stop()
            self._status = None
            self._print(self.line(sim))
