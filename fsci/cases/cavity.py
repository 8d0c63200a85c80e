"""Lid-driven cavity on [0, 1]²: lid velocity (1, 0) on top, no-slip elsewhere, rho = 1,
mu = 1/re. Steady Navier-Stokes reached by ramping the lid velocity over four static load
steps (continuation in the Reynolds number).

Reference primary-vortex centres: Ghia, Ghia & Shin (1982): Re = 100 (0.6172, 0.7344),
Re = 1000 (0.5313, 0.5625); Botella & Peyret (1998), Re = 1000: (0.5308, 0.5652).
"""

from __future__ import annotations

from typing import Any


def cavity() -> dict[str, Any]:
    return {
        "name": "cavity",
        "kind": "fluid",
        "description": "Lid-driven cavity, steady incompressible Navier-Stokes, Re = 1/mu",
        "parameters": {"re": 100, "n": 64},
        "fluid": {
            "rho": 1.0,
            "mu": "=1/re",
            "grid": {"x": {"start": 0.0, "end": 1.0, "cells": "=n"}, "y": {"start": 0.0, "end": 1.0, "cells": "=n"}},
            # where two conditions meet the one listed last wins: the lid first, so the walls keep
            # the corner nodes at rest (the lid velocity there would change the vortex by 7 %)
            "dirichlet": [
                {"boundary": "top", "value": [1.0, 0.0], "function": {"type": "ramp", "t0": 0.0, "t1": 1.0}},
                {"boundary": "bottom", "value": [0.0, 0.0]},
                {"boundary": "left", "value": [0.0, 0.0]},
                {"boundary": "right", "value": [0.0, 0.0]},
            ],
        },
        "time": {"type": "static", "t_end": 1.0, "dt": 0.25},
        "solver": {"tol_residual": 1e-9, "tol_increment": 1e-9, "max_iterations": 30},
        "quantities": [
            {"name": "profiles", "type": "centerline_profiles", "x": 0.5, "y": 0.5},
            {"name": "vortex", "type": "vortex_center"},
        ],
        # Re = 100 on 64²: measured 0.30 % and 0.40 % (docs/validation.md)
        "reference": [
            {"name": "vortex_x", "value": 0.6172, "rtol": 0.01, "source": "Ghia, Ghia & Shin (1982), Re = 100"},
            {"name": "vortex_y", "value": 0.7344, "rtol": 0.01, "source": "Ghia, Ghia & Shin (1982), Re = 100"},
        ],
        "verified_at": {"re": 100, "n": 64},
        "output": {"every": 0},
    }
