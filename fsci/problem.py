"""Validated description of a problem: bodies, fluid, loads, time grid, solver settings.

Instances are produced by :mod:`fsci.config` from a case file (TOML) or built directly in a
Python script. Nothing here discretises anything; :mod:`fsci.system` does.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fsci.expressions import Expression
from fsci.mesh.grid import Grid
from fsci.mesh.quadmesh import QuadMesh
from fsci.timefunc import TimeFunction


@dataclass
class Material:
    """Hyperelastic solid material: ``law`` in {"neo_hooke", "svk"}."""

    law: str
    E: float
    nu: float
    rho: float


@dataclass
class Dirichlet:
    """Prescribed values on a node set: ``values[c]`` is ``None`` for a free component.

    Values are expressions in the reference coordinates ``x, y`` and time ``t``, multiplied by
    the time function."""

    boundary: str
    values: list[Expression | None]
    function: TimeFunction


@dataclass
class Neumann:
    """Load on an edge set: ``kind`` "traction" (vector, per reference length for solids) or
    "pressure" (scalar, acting against the current outward normal)."""

    boundary: str
    kind: str
    values: list[Expression]
    function: TimeFunction


@dataclass
class Body:
    """One elastic (or fully prescribed, "rigid") solid body."""

    name: str
    mesh: QuadMesh
    material: Material
    body_force: list[Expression]  # per unit mass, expressions in reference x, y and t
    body_force_function: TimeFunction
    dirichlet: list[Dirichlet] = field(default_factory=list)
    neumann: list[Neumann] = field(default_factory=list)
    interface: list[str] | None = None  # edge sets coupled to the fluid; None = all not loaded/fixed
    contact: list[str] | None = None  # edge sets that may touch other bodies
    rigid: bool = False  # every dof prescribed
    slip_length: float | Expression | str = 0.0  # Navier slip length κ (inf = free slip; "gap_law": (40))
    interface_velocity: list[Expression] | None = None  # prescribed interface velocity (overrides du/dt)
    extends_outside: bool = False  # the body may cross the fluid box boundary
    dry_cavities: bool = False  # cavities enclosed by the body are not fluid


@dataclass
class Stabilization:
    """Face stabilisation and Nitsche constants (defaults: 4C values for 2D quads, see docs)."""

    gamma_p: float = 0.25
    gamma_u: float = 0.25
    gamma_div: float = 0.00025
    gamma_gp: float = 0.5
    gamma_gp_t: float = 0.001
    ghost_penalty: bool = True  # False drops every face term on faces of cut cells (studies only)
    ghost_ramp: float = 0.0  # solid fraction of a cut cell from which its faces carry the full ghost penalty
    scheme: str = "cip"  # "cip": faces (25) everywhere; "residual": SUPG/PSPG/grad-div cells + faces of cut cells


@dataclass
class InterfaceSettings:
    """Nitsche coupling and cut parameters (defaults: the paper / 4C's FSCI test)."""

    gamma_n: float = 35.0  # gamma_0^F, normal penalty constant (Remark 8)
    gamma_t: float = 35.0  # gamma_0^t, tangential penalty constant (37)
    trace_constant: float = 1.43426  # C_T of Q1 (4C, pseudo-2D)
    adjoint: str = "skew"  # viscous adjoint: "skew" (s_adj = -1) or "symmetric" (+1)
    island_factor: float = 2.0  # islands: bounding-box diagonal < factor * cell diagonal
    trapped_film: float = 0.1  # islands too: enclosed pieces thinner (2 area / perimeter) than this * cell diagonal
    eps_geom: float = 1e-9  # re-cut while the bodies moved more than eps_geom * (smallest cell) since the last cut
    grow_only_after: int = 5  # Newton iterations after which the ACTIVE set may only grow
    freeze_cut_after: int = 8  # Newton iterations after which the cut is kept fixed (paper 3.4.2)
    own_cut_tol: float = 1e-6  # a state converged on a frozen cut is accepted if the bodies moved less (× smallest cell)
    max_layout_changes: int = 5  # ACTIVE-set changes tolerated in one step before growing only
    kappa0: float = 0.1  # dimensionless slip coefficient of the gap law (40)
    slip_h: float = 0.0  # distance h of the gap law (40); 0: the largest background cell side
    case_iii: str = "remark6"  # case III (Γ^FS in contact): "remark6" (35) or "original" (33)
    film_closure: float = 1e-6  # gaps between bodies below 2 × this × smallest cell are closed (not fluid)
    unknowns: str = "per_node"  # fluid unknowns of a node: "per_node" (one set) or "per_fluid_part"
    shape_derivative: bool = True  # Jacobian includes the motion of Γ^FS (cut follows the iterates)
    extension: bool = True  # extend the FSI side into Γ^SC (§4.6); False: it is zero there (studies only)


@dataclass
class Fluid:
    """Incompressible Newtonian fluid on a rectilinear background grid."""

    grid: Grid
    rho: float
    mu: float
    viscous_form: str = "symmetric"  # or "laplace"
    body_force: list[Expression] | None = None  # per unit mass, expressions in x, y, t
    body_force_function: TimeFunction | None = None
    dirichlet: list[Dirichlet] = field(default_factory=list)
    neumann: list[Neumann] = field(default_factory=list)
    pressure_reference: np.ndarray | None = None  # point where p = 0 is imposed, if needed
    stabilization: Stabilization = field(default_factory=Stabilization)
    interface: InterfaceSettings = field(default_factory=InterfaceSettings)


@dataclass
class ContactSettings:
    """Nitsche contact parameters (paper: γ0^S = 1; 4C: harmonic weights)."""

    gamma0: float = 1.0
    weighting: str = "harmonic"  # or "half"
    search_radius: float = 0.0  # 0: twice the longest contact edge
    n_gauss: int = 3  # Gauss points per integration piece
    split: bool = True  # split pieces at projected opposite nodes (Remark 9); else n_fixed sub-intervals
    n_fixed: int = 10
    self_contact: bool = False


@dataclass
class TimeGrid:
    """Time discretisation: ``kind`` "static" (no inertia, steady flow) or "transient"."""

    kind: str
    theta: float
    t_start: float
    segments: list[tuple[float, float]]  # (end time, dt)

    @property
    def t_end(self) -> float:
        return self.segments[-1][0]


@dataclass
class SolverSettings:
    """Newton, linear solver and step-control settings."""

    max_iterations: int = 25
    min_iterations: int = 1
    tol_residual: float = 1e-8
    tol_increment: float = 1e-8
    rtol_residual: float = 1e-10
    damping: bool = True
    relaxation: bool = True  # Aitken relaxation of the Newton update while the cut follows the iterates
    predictor: str = "constant_velocity"  # Newton's start in a time step (or "constant_acceleration")
    linear: str = "auto"
    forcing: float = 0.9  # largest relative residual of a linear solve with reused factors (0: exact)
    max_step_cuts: int = 6
    step_cut_factor: float = 0.5
    dt_min: float = 0.0
    steps_before_growth: int = 1  # after a cut: converged steps at the reduced size before it grows back


@dataclass
class Quantity:
    """A reported scalar (or profile) with its kind and parameters."""

    name: str
    kind: str
    params: dict[str, Any]


@dataclass
class Reference:
    """A reference value the run should reproduce within a relative tolerance."""

    name: str
    value: float
    rtol: float
    source: str = ""


@dataclass
class Verification:
    """The parameter values at which a case's reference checks are verified (the case's
    top-level ``verified_at`` table) and the parameters of this run that differ from them."""

    verified_at: dict[str, float]
    differs: dict[str, Any]  # parameter (or other overridden key) -> value in this run, for those that differ

    def note(self) -> str | None:
        """One line saying that the run is not at the verified setting (None if it is)."""
        if not self.differs:
            return None
        run = ", ".join(f"{k} = {v:g}" if isinstance(v, (int, float)) else f"{k} = {v}" for k, v in self.differs.items())
        ref = ", ".join(f"{k} = {self.verified_at[k]:g}" if k in self.verified_at else f"the case's own {k}"
                        for k in self.differs)
        return f"note: not the verified setting ({run}; verified at {ref}): coarser or different from the tested run"

    def add_overrides(self, settings: dict[str, Any]) -> None:
        """Record ``--set`` overrides of keys other than the case parameters (e.g. a different
        stabilisation scheme): the reference checks were verified with the case's own values."""
        self.differs.update(settings)


@dataclass
class Output:
    """What to write: VTU every ``every`` steps (0 = only the last), figures on/off."""

    every: int = 1
    figures: bool = True
    fields: bool = True
    checkpoint_every: int = 0  # steps between checkpoints (0: by wall time only)
    checkpoint_minutes: float = 5.0  # wall time between checkpoints (0: off); also at step cuts, signals, the end


@dataclass
class Problem:
    """Complete problem description."""

    name: str
    description: str
    bodies: list[Body]
    fluid: Fluid | None
    time: TimeGrid
    solver: SolverSettings
    quantities: list[Quantity]
    references: list[Reference]
    output: Output
    source: dict[str, Any]  # the (overridden) case dictionary it was read from
    contact: ContactSettings = field(default_factory=ContactSettings)
    verification: Verification | None = None  # None: the case makes no verified_at claim


def _load_data(problem: Problem) -> list[tuple[list[Any], TimeFunction | None]]:
    """Every prescribed datum of the problem: its expressions and the time function scaling them."""
    data: list[tuple[list[Any], TimeFunction | None]] = []
    sources = [(b.body_force or [], b.body_force_function, b.dirichlet, b.neumann) for b in problem.bodies]
    if problem.fluid is not None:
        f = problem.fluid
        sources.append((f.body_force or [], f.body_force_function, f.dirichlet, f.neumann))
    for body_force, fn, dirichlet, neumann in sources:
        data.append((list(body_force), fn))
        data += [(list(d.values), d.function) for d in dirichlet]
        data += [(list(n.values), n.function) for n in neumann]
    for b in problem.bodies:
        data.append((list(b.interface_velocity or []) + [b.slip_length], None))
    return data


def load_step_ratio(problem: Problem, t_prev: float, t_old: float, t_new: float) -> float:
    """How the data change over the static step ``t_old → t_new`` compares with their change
    over the last step ``t_prev → t_old``: the factor α with ``f(t_new) − f(t_old) = α (f(t_old)
    − f(t_prev))`` for every time function ``f`` of the problem (1 along a ramp, −1 where a
    table turns back, 0 where the data stop changing). 0 also where there is no such factor: an
    expression depends on ``t``, data change in different proportions, or a datum starts to
    change."""
    alpha = None
    for exprs, fn in _load_data(problem):
        if any(isinstance(e, Expression) and e.uses_time for e in exprs):
            return 0.0
        if fn is None:
            continue
        f0, f1, f2 = fn(t_prev), fn(t_old), fn(t_new)
        tol = 1e-12 * max(1.0, abs(f0), abs(f1), abs(f2))
        before, now = f1 - f0, f2 - f1
        if abs(before) <= tol:
            if abs(now) > tol:
                return 0.0
            continue
        a = now / before
        if alpha is None:
            alpha = a
        elif abs(a - alpha) > 1e-9 * max(1.0, abs(alpha)):
            return 0.0
    return 0.0 if alpha is None else alpha
