"""Dry contact cases (no fluid): Hertz (Johnson 1985, ch. 4) and two blocks pressed together
to large strain and released."""

from __future__ import annotations

from typing import Any

HERTZ = "Hertz (Johnson 1985, plane strain) for the applied load"


def hertz() -> dict[str, Any]:
    """Plane-strain cylinder (radius R = 1, Neo-Hooke E = 1, ν = 0.3) pressed onto a rigid flat:
    quarter model (symmetry at x = 0) under displacement control (the flat top of the quarter
    disk moves down by ``delta``; a load-controlled cylinder touching in one point would be
    unsupported). The applied load P per unit length is twice the reaction of the top (the
    cylinder's own residual summed over the prescribed dofs, independent of the contact
    term); the analytic half-width and peak pressure use that P, and ``load_balance`` compares
    the total contact force with it (global equilibrium). ``delta`` = 0.0025 gives P ≈ 0.001
    (small load: a/R ≈ 0.034). Refined to ``h`` near the contact point.

    Reference tolerances ≈ 3× the errors measured at h = 0.002 (a −0.53 %, p0 +0.88 %; the
    ≈ 0.8 % in p0 is Hertz's half-space vs a finite cylinder, docs/validation.md); the
    equilibrium holds to the Newton tolerance (measured 1e-12)."""
    arc = {"arc": {"start": [0.0, 0.0], "center": [0.0, 1.0], "end": [1.0, 1.0]}, "name": "arc"}
    loop = [{"line": [[0.0, 1.0], [0.0, 0.0]], "name": "axis"}, arc, {"line": [[1.0, 1.0], [0.0, 1.0]], "name": "top"}]
    return {
        "name": "hertz",
        "kind": "contact",
        "description": "Hertz contact of an elastic cylinder on a rigid flat (plane strain, quarter model)",
        "parameters": {"delta": 0.0025, "h": 0.002, "E": 1.0, "nu": 0.3},
        "verified_at": {"delta": 0.0025, "h": 0.002, "E": 1.0, "nu": 0.3},
        "bodies": [
            {"name": "cylinder", "material": {"law": "neo_hooke", "E": "=E", "nu": "=nu"},
             "mesh": {"type": "outline", "loops": [loop], "h": 0.08,
                      "refine": [{"point": [0.0, 0.0], "h": "=h", "radius": 0.15}]},
             "dirichlet": [{"boundary": "axis", "value": [0.0, "free"]},
                           {"boundary": "top", "value": ["free", "-delta"], "function": {"type": "ramp", "t0": 0.0, "t1": 1.0}}],
             "contact": ["arc"]},
            {"name": "flat", "rigid": True, "material": {"law": "neo_hooke", "E": 1.0, "nu": 0.3},
             "mesh": {"type": "rectangle", "x0": -0.3, "x1": 1.3, "y0": -0.2, "y1": 0.0, "nx": 16, "ny": 2},
             "dirichlet": [{"boundary": "body", "value": [0.0, 0.0]}], "contact": ["top"]},
        ],
        "contact": {"gamma0": 1.0, "weighting": "harmonic"},
        "time": {"type": "static", "t_end": 1.0, "dt": 0.25},
        "solver": {"tol_residual": 1e-12, "tol_increment": 1e-12, "max_iterations": 40},
        "quantities": [
            {"name": "load", "type": "reaction", "body": "cylinder", "boundary": "top", "component": 1},
            {"name": "contact", "type": "contact_profile", "body": "cylinder", "axis": 0.0},
            {"name": "hertz", "type": "hertz_exact", "P": "load", "factor": 2.0, "contact": "contact", "R": 1.0,
             "E": "=E", "nu": "=nu"},
        ],
        "reference": [
            {"name": "half_width_ratio", "value": 1.0, "rtol": 0.015, "source": HERTZ},
            {"name": "peak_pressure_ratio", "value": 1.0, "rtol": 0.025, "source": HERTZ},
            {"name": "load_balance", "value": 1.0, "rtol": 1e-8, "source": "global equilibrium: contact force = load"},
        ],
        "output": {"every": 0},
    }


def two_blocks() -> dict[str, Any]:
    """A soft block (E = 1) pressed into a stiffer one (E = 3) by a prescribed displacement of
    its top (Neo-Hooke, ν = 0.3), to about 40 % compression of the upper block, then released
    until the bodies separate again. Harmonic weights, two half passes."""
    def block(name, x0, x1, y0, y1, nx, ny, E, extra):
        b = {"name": name, "material": {"law": "neo_hooke", "E": E, "nu": 0.3},
             "mesh": {"type": "rectangle", "x0": x0, "x1": x1, "y0": y0, "y1": y1, "nx": nx, "ny": ny}}
        b.update(extra)
        return b

    lower = block("lower", 0.0, 1.0, 0.0, 1.0, 9, 9, 3.0,
                  {"contact": ["top"], "dirichlet": [{"boundary": "bottom", "value": [0.0, 0.0]}]})
    upper = block("upper", 0.2, 0.8, 1.05, 1.55, 7, 6, 1.0,
                  {"contact": ["bottom"],
                   "dirichlet": [{"boundary": "top", "value": [0.0, "-0.4"],
                                  "function": {"type": "table", "times": [0.0, 1.0, 2.0], "values": [0.0, 1.0, 0.0]}}]})
    return {
        "name": "two-blocks",
        "kind": "contact",
        "description": "Two Neo-Hookean blocks pressed together to large strain and released (dry Nitsche contact)",
        "bodies": [lower, upper],
        "contact": {"gamma0": 1.0, "weighting": "harmonic"},
        "time": {"type": "static", "t_end": 2.0, "dt": 0.1},
        "solver": {"tol_residual": 1e-11, "tol_increment": 1e-11, "max_iterations": 30},
        "quantities": [
            {"name": "uy_upper", "type": "point_displacement", "body": "upper", "point": [0.5, 1.05], "component": 1},
            {"name": "uy_lower", "type": "point_displacement", "body": "lower", "point": [0.5, 1.0], "component": 1},
            {"name": "ux_corner", "type": "point_displacement", "body": "upper", "point": [0.2, 1.05], "component": 0},
            {"name": "contact_upper", "type": "contact_profile", "body": "upper", "axis": 0.5, "prefix": "upper_"},
            {"name": "contact_lower", "type": "contact_profile", "body": "lower", "axis": 0.5, "prefix": "lower_"},
        ],
        "output": {"every": 2},
    }
