"""An elastic disk released from rest in quiescent fluid under gravity.

Box [0, 1] × [0, 1.5], no-slip walls on the sides and the bottom, open top; gravity g = 10
on fluid and solid. Disk radius 0.1 centred at (0.5, 1.0), Neo-Hooke E = 1e4, ν = 0.3,
ρ_s = 2, fluid ρ = 1, μ = 0.05. The disk sinks (buoyancy-corrected weight (ρ_s - ρ_f) g π r²)
and does not reach a wall in the simulated time. Used to check that the interface traction
is free of spurious oscillations when cells change from cut to fluid or solid as the body
moves through the grid.
"""

from __future__ import annotations

from typing import Any


def sinking_disk() -> dict[str, Any]:
    return {
        "name": "sinking-disk",
        "kind": "fsi",
        "description": "Elastic disk sinking under gravity in quiescent fluid (monolithic CutFEM FSI)",
        "parameters": {"n": 32, "g": 10.0},
        "bodies": [{
            "name": "disk",
            "material": {"law": "neo_hooke", "E": 1.0e4, "nu": 0.3, "rho": 2.0},
            "mesh": {"type": "disk", "center": [0.5, 1.0], "radius": 0.1, "h": "=0.4/n", "name": "surface"},
            "body_force": [0.0, "-g"],
        }],
        "fluid": {
            "rho": 1.0,
            "mu": 0.05,
            "grid": {"x": {"start": 0.0, "end": 1.0, "cells": "=n"}, "y": {"start": 0.0, "end": 1.5, "cells": "=3*n/2"}},
            "body_force": [0.0, "-g"],
            "dirichlet": [{"boundary": s, "value": [0.0, 0.0]} for s in ("left", "right", "bottom")],
        },
        "time": {"type": "transient", "theta": 1.0, "t_end": 0.6, "dt": 0.01},
        # a smooth fall: Newton starts from the extrapolated velocities (128 Newton iterations
        # instead of 209, the same results to 2e-10; docs/architecture.md, decision 50)
        "solver": {"tol_residual": 1e-8, "tol_increment": 1e-10, "predictor": "constant_acceleration"},
        "quantities": [
            {"name": "uy_center", "type": "point_displacement", "body": "disk", "point": [0.5, 1.0], "component": 1},
            {"name": "force_y", "type": "body_force", "body": "disk", "component": 1},
            {"name": "force_y_traction", "type": "body_force", "body": "disk", "component": 1, "method": "traction"},
            {"name": "mass", "type": "mass_balance"},
        ],
        "output": {"every": 10},
    }
