"""Case dictionaries for CutFEM tests: a fluid disk inside a solid (box minus disk), a rotated
channel between two walls, a rigid step for ghost-penalty conditioning."""

from __future__ import annotations

import math

import numpy as np

CENTER = (0.5 + 1e-3, 0.5 + math.sqrt(2) * 1e-3)  # irrational offset: no symmetric cuts
RADIUS = 0.45


def box_minus_disk(h_s: float = 0.01, center=CENTER, radius=RADIUS, **extra) -> dict:
    """A solid covering the box except a disk: the fluid lives in the disk."""
    c = list(center)
    pts = [[c[0] + radius * math.cos(a), c[1] + radius * math.sin(a)] for a in (0, math.pi / 2, math.pi, 1.5 * math.pi)]
    circle = [{"arc": {"start": pts[i], "center": c, "end": pts[(i + 1) % 4]}, "name": "circle"} for i in range(4)]
    a, b = -0.05, 1.05
    outer = [{"line": [[a, a], [b, a]], "name": "outer"}, {"line": [[b, a], [b, b]], "name": "outer"},
             {"line": [[b, b], [a, b]], "name": "outer"}, {"line": [[a, b], [a, a]], "name": "outer"}]
    body = {"name": "wall", "rigid": True, "extends_outside": True, "interface": ["circle"],
            "material": {"law": "neo_hooke", "E": 1.0, "nu": 0.3},
            "mesh": {"type": "outline", "loops": [outer, circle], "h": h_s, "h_max": 0.1},
            "dirichlet": [{"boundary": "body", "value": [0.0, 0.0]}]}
    body.update(extra)
    return body


def rotated_wall(name: str, angle: float, center, offset: float, side: int, **extra) -> dict:
    """A wall occupying {y' < offset} (side=-1) or {y' > offset} (side=+1) in coordinates rotated
    by ``angle`` about ``center``; its edge facing the channel is the edge set "face"."""
    t = np.array([math.cos(angle), math.sin(angle)])
    m = np.array([-math.sin(angle), math.cos(angle)])
    c = np.asarray(center)
    L, D = 3.0, 2.0
    p = lambda s, d: (c + s * t + d * m).tolist()  # noqa: E731
    if side < 0:
        bl, br, tr, tl = p(-L, offset - D), p(L, offset - D), p(L, offset), p(-L, offset)
        sides = {"bottom": {"line": [bl, br]}, "right": {"line": [br, tr]}, "top": {"line": [tl, tr]},
                 "left": {"line": [bl, tl]}}
        face = "top"
    else:
        bl, br, tr, tl = p(-L, offset), p(L, offset), p(L, offset + D), p(-L, offset + D)
        sides = {"bottom": {"line": [bl, br]}, "right": {"line": [br, tr]}, "top": {"line": [tl, tr]},
                 "left": {"line": [bl, tl]}}
        face = "bottom"
    body = {"name": name, "rigid": True, "extends_outside": True, "interface": [face],
            "material": {"law": "neo_hooke", "E": 1.0, "nu": 0.3},
            "mesh": {"type": "mapped", "nx": 60, "ny": 2, "sides": sides},
            "dirichlet": [{"boundary": "body", "value": [0.0, 0.0]}]}
    body.update(extra)
    return body


def fluid_box(n: int, mu: float = 1.0, rho: float = 1.0, **extra) -> dict:
    f = {"rho": rho, "mu": mu, "grid": {"x": {"start": 0.0, "end": 1.0, "cells": n},
                                        "y": {"start": 0.0, "end": 1.0, "cells": n}}}
    f.update(extra)
    return f


def static_case(bodies, fluid, **solver) -> dict:
    s = {"tol_residual": 1e-11, "tol_increment": 1e-11}
    s.update(solver)
    return {"name": "t", "time": {"type": "static", "t_end": 1.0, "dt": 1.0}, "solver": s, "bodies": bodies,
            "fluid": fluid, "output": {"every": 0, "figures": False}}
