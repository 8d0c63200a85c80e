"""A cylinder with prescribed motion in a box: it oscillates horizontally and pulsates
(its radius changes), with no-slip walls left, right and at the bottom and an open
(do-nothing) top.

Why open and why pulsating: for a rigid body in a fully closed box every flow rate in the
mass balance (paper (44)-(46)) vanishes identically, so nothing would be tested. With a
volume change, the fluid must leave through the top: the discrete mass balance (46) makes the
outflow equal the solid displacement rate ``Φ^S = ∫_Γ^FS ∂u/∂t·n`` up to the solver
tolerance at every step (``mass_err1``); ``mass_err2 = |Φ^S - Φ^F|`` measures the weak
imposition of the interface condition and falls with h.

Motion: ``u(X, t) = A sin(2πt/T) e_x + ε sin(2πt/T) (X - c)``, A = 0.1, ε = 0.1, T = 1.
"""

from __future__ import annotations

from typing import Any

from fsci.cases.dfg import cylinder_body


def moving_cylinder() -> dict[str, Any]:
    body = cylinder_body(center=(0.5, 0.45), radius=0.15, h="=0.5/n", h_max=0.05)
    body["dirichlet"] = [{"boundary": "body",
                          "value": ["A*sin(2*pi*t/T) + eps*sin(2*pi*t/T)*(x - 0.5)", "eps*sin(2*pi*t/T)*(y - 0.45)"]}]
    return {
        "name": "moving-cylinder",
        "kind": "cutfem",
        "description": "Cylinder oscillating and pulsating in a box open at the top (prescribed motion, CutFEM)",
        "parameters": {"n": 40, "A": 0.1, "eps": 0.1, "T": 1.0},
        "bodies": [body],
        "fluid": {
            "rho": 1.0,
            "mu": 0.01,
            "grid": {"x": {"start": 0.0, "end": 1.0, "cells": "=n"}, "y": {"start": 0.0, "end": 1.0, "cells": "=n"}},
            "dirichlet": [{"boundary": s, "value": [0.0, 0.0]} for s in ("left", "right", "bottom")],
        },
        "time": {"type": "transient", "theta": 1.0, "t_end": 1.0, "dt": 0.02},
        "solver": {"tol_residual": 1e-10, "tol_increment": 1e-10},
        "quantities": [
            {"name": "mass", "type": "mass_balance"},
            {"name": "drag", "type": "body_force", "body": "cylinder", "component": 0},
            {"name": "lift", "type": "body_force", "body": "cylinder", "component": 1},
        ],
        "output": {"every": 5},
    }
