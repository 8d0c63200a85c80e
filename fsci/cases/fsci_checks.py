"""Fluid-structure-contact verification cases: bodies in fluid that touch and lift off.

* ``lift-off``: an elastic block resting on a rigid slab in fluid (half model, symmetry at
  x = 0), pressed by a dead load ``q`` on its dry top (outside the fluid box), while the
  ambient fluid pressure ``p = p_rate t`` rises on the open side of the box. The contact zone
  under the block is Γ^SC; with the fluid traction extended into it (§4.6) the contact branch
  of (27) gives way to the fluid branch when the contact traction falls to the fluid traction,
  i.e. when ``p`` reaches ``q`` (uniform stress −q in the block): the block lifts off at
  ``p = q``. Without the extension (``fluid.interface.extension = false``) the block's bottom
  sees no fluid at all and never lifts off.
* ``contact-sweep``: quasi-static — an elastic block with a rounded bottom is pushed
  (prescribed displacement of its dry top) through fluid at ambient pressure onto a rigid slab,
  to 1.37 times the initial gap, and pulled back: the FSI -> contact -> lift-off transition,
  whose interface force and residual must vary continuously (steps of ``1/n`` of the push from
  60 % of it).
* ``blocks-film``: an elastic block with a rounded bottom pressed (prescribed displacement of
  its dry top) through a fluid film onto a second elastic block: the film thins, the Navier
  slip of the gap law (40) lets the fluid escape, the bodies touch, the contact zone spreads,
  and the fluid splits into a left and a right part (2D analogue of 4C's two-element FSCI test).
"""

from __future__ import annotations

from typing import Any


def lift_off() -> dict[str, Any]:
    slab = {
        "name": "slab", "rigid": True, "extends_outside": True,
        "material": {"law": "neo_hooke", "E": 1.0, "nu": 0.0},
        "mesh": {"type": "rectangle", "x0": -0.2, "x1": 1.2, "y0": -0.3, "y1": "=y_c", "nx": 28, "ny": 3},
        "dirichlet": [{"boundary": "body", "value": [0.0, 0.0]}],
        "interface": ["top"], "contact": ["top"],
    }
    outline = [
        {"line": [[0.0, "=y_c"], [0.42, "=y_c"]], "name": "bottom"},
        {"line": [[0.42, "=y_c"], [0.42, 0.5]], "name": "wet"},
        {"line": [[0.42, 0.5], [0.42, 0.6]], "name": "dry"},
        {"line": [[0.42, 0.6], [0.0, 0.6]], "name": "top"},
        {"line": [[0.0, 0.6], [0.0, "=y_c"]], "name": "axis"},
    ]
    block = {
        "name": "block", "extends_outside": True,
        "material": {"law": "neo_hooke", "E": 1e4, "nu": 0.3, "rho": 1e-3},
        "mesh": {"type": "outline", "loops": [outline], "h": "=0.42/m"},
        "dirichlet": [{"boundary": "axis", "value": [0.0, "free"]}],
        # above the fluid box the ambient pressure acts as a load: uniform lateral pressure
        "neumann": [{"boundary": "top", "type": "traction", "value": [0.0, "-q"]},
                    {"boundary": "dry", "type": "pressure", "value": "p_rate*t"}],
        "interface": ["bottom", "wet"], "contact": ["bottom"],
    }
    return {
        "name": "lift-off",
        "kind": "fsci",
        "description": "Elastic block on a rigid slab in fluid, dead load q on its dry top, ambient pressure "
                       "rising: lifts off when the pressure reaches q (extension of the fluid traction)",
        "parameters": {"n": 20, "m": 8, "q": 1.0, "p_rate": 1.0, "y_c": 0.0137},
        "verified_at": {"n": 20, "m": 8, "q": 1.0, "p_rate": 1.0, "y_c": 0.0137},
        "bodies": [slab, block],
        "fluid": {
            "rho": 1e-3, "mu": 0.1,
            "grid": {"x": {"start": 0.0, "end": 1.0, "cells": "=n"},
                     "y": {"start": -0.1, "end": 0.5, "cells": "=3*n/5"}},
            "dirichlet": [{"boundary": "left", "value": [0.0, "free"]},
                          {"boundary": "top", "value": [0.0, 0.0]}],
            "neumann": [{"boundary": "right", "type": "pressure", "value": "p_rate*t"}],
        },
        "time": {"type": "transient", "theta": 1.0,
                 "segments": [{"until": 0.9, "dt": 0.05}, {"until": 1.1, "dt": 0.002}]},
        "solver": {"tol_residual": 1e-9, "tol_increment": 1e-10},
        "quantities": [
            {"name": "block", "type": "interface_summary", "body": "block"},
            {"name": "uy_bottom", "type": "point_displacement", "body": "block", "point": [0.2, "=y_c"], "component": 1},
            # lift-off begins when the contact traction falls to the fluid traction: the contact
            # length collapses (fluid then creeps into the opening film, the block follows slowly)
            {"name": "liftoff_pressure", "type": "event", "of": "block_length_contact", "when": "halves",
             "value": "p_rate*t"},
            {"name": "liftoff_pressure_predicted", "type": "value", "value": "=q"},
            {"name": "mass", "type": "mass_balance"},
        ],
        "reference": [{"name": "liftoff_pressure", "value": 1.0, "rtol": 0.02,
                       "source": "equilibrium of the block: lift-off when the ambient pressure equals q"}],
        "output": {"every": 10},
    }


def blocks_film() -> dict[str, Any]:
    round_bottom = [
        {"line": [[0.3, 1.2], [0.3, 0.6]], "name": "left"},
        {"arc": {"start": [0.3, 0.6], "center": [0.5, 0.6], "end": [0.5, 0.4]}, "name": "round"},
        {"arc": {"start": [0.5, 0.4], "center": [0.5, 0.6], "end": [0.7, 0.6]}, "name": "round"},
        {"line": [[0.7, 0.6], [0.7, 1.2]], "name": "right"},
        {"line": [[0.7, 1.2], [0.3, 1.2]], "name": "top"},
    ]
    upper = {
        "name": "upper", "extends_outside": True,
        "material": {"law": "neo_hooke", "E": 50.0, "nu": 0.3, "rho": 1e-3},
        "mesh": {"type": "outline", "loops": [round_bottom], "h": "=0.5/n"},
        "dirichlet": [{"boundary": "top", "value": [0.0, "-depth"],
                       "function": {"type": "ramp", "t0": 0.0, "t1": 1.0}}],
        "contact": ["round"], "slip_length": "gap_law",
    }
    lower = {
        "name": "lower", "extends_outside": True,
        "material": {"law": "neo_hooke", "E": 100.0, "nu": 0.3, "rho": 1e-3},
        "mesh": {"type": "rectangle", "x0": -0.1, "x1": 1.1, "y0": -0.2, "y1": 0.35, "nx": "=6*n/5", "ny": "=n/2"},
        "dirichlet": [{"boundary": "bottom", "value": [0.0, 0.0]}],
        "interface": ["top"], "contact": ["top"], "slip_length": "gap_law",
    }
    return {
        "name": "blocks-film",
        "kind": "fsci",
        "description": "A rounded elastic block pressed through a fluid film onto another: the film closes, "
                       "contact forms and spreads, the fluid splits (FSCI)",
        "parameters": {"n": 20, "depth": 0.1},
        "bodies": [lower, upper],
        "fluid": {
            "rho": 1e-3, "mu": 0.01,
            "grid": {"x": {"start": 0.0, "end": 1.0, "cells": "=n"}, "y": {"start": 0.0, "end": 1.0, "cells": "=n"}},
            "dirichlet": [{"boundary": "left", "value": [0.0, 0.0]}, {"boundary": "right", "value": [0.0, 0.0]}],
            # the cut follows the iterates to convergence (no cycling here), so the discrete mass
            # balance holds to solver tolerance in every step
            "interface": {"freeze_cut_after": 25},
        },
        "time": {"type": "transient", "theta": 1.0, "t_end": 1.0, "dt": 0.02},
        "solver": {"tol_residual": 1e-9, "tol_increment": 1e-10, "max_iterations": 40},
        "quantities": [
            {"name": "upper", "type": "interface_summary", "body": "upper"},
            {"name": "pieces", "type": "fluid_pieces"},
            {"name": "first_contact", "type": "event", "of": "case_II", "when": "rises_from_zero"},
            {"name": "mass", "type": "mass_balance"},
        ],
        "output": {"every": 5},
    }


def contact_sweep() -> dict[str, Any]:
    slab = {"name": "slab", "rigid": True, "extends_outside": True,
            "material": {"law": "neo_hooke", "E": 1.0, "nu": 0.0},
            "mesh": {"type": "rectangle", "x0": -0.2, "x1": 1.2, "y0": -0.3, "y1": 0.0137, "nx": 28, "ny": 3},
            "dirichlet": [{"boundary": "body", "value": [0.0, 0.0]}], "interface": ["top"], "contact": ["top"],
            "slip_length": "gap_law"}
    round_bottom = [
        {"line": [[0.3, 0.6], [0.3, 0.25]], "name": "left"},
        {"arc": {"start": [0.3, 0.25], "center": [0.5, 0.25], "end": [0.5, 0.05]}, "name": "round"},
        {"arc": {"start": [0.5, 0.05], "center": [0.5, 0.25], "end": [0.7, 0.25]}, "name": "round"},
        {"line": [[0.7, 0.25], [0.7, 0.6]], "name": "right"},
        {"line": [[0.7, 0.6], [0.3, 0.6]], "name": "top"},
    ]
    block = {"name": "block", "extends_outside": True,
             "material": {"law": "neo_hooke", "E": 100.0, "nu": 0.3},
             "mesh": {"type": "outline", "loops": [round_bottom], "h": 0.04},
             "dirichlet": [{"boundary": "top", "value": [0.0, "-1.37*(0.05-0.0137)"],
                            "function": {"type": "table", "times": [0.0, 1.0, 2.0], "values": [0.0, 1.0, 0.0]}}],
             "interface": ["round", "left", "right"], "contact": ["round"], "slip_length": "gap_law"}
    return {
        "name": "contact-sweep",
        "kind": "fsci",
        "description": "Quasi-static push of a rounded block through fluid onto a slab and back: continuity of "
                       "the traction (27) through FSI -> contact -> lift-off",
        "parameters": {"n": 40},
        "bodies": [slab, block],
        "fluid": {"rho": 1.0, "mu": 1.0,
                  "grid": {"x": {"start": 0.0, "end": 1.0, "cells": 20}, "y": {"start": -0.1, "end": 0.5, "cells": 12}},
                  "dirichlet": [{"boundary": "top", "value": [0.0, 0.0]}],
                  "interface": {"freeze_cut_after": 40},
                  "neumann": [{"boundary": "left", "type": "pressure", "value": 1.0},
                              {"boundary": "right", "type": "pressure", "value": 1.0}]},
        # one step to 60 % of the push (still clear of the slab), then steps of 1/n of it
        "time": {"type": "static", "segments": [{"until": 0.6, "dt": 0.6}, {"until": 1.4, "dt": "=1/n"}]},
        "solver": {"tol_residual": 1e-10, "tol_increment": 1e-11, "max_iterations": 60},
        "quantities": [{"name": "block", "type": "interface_summary", "body": "block"},
                       {"name": "uy_tip", "type": "point_displacement", "body": "block", "point": [0.5, 0.05],
                        "component": 1}],
        "output": {"every": 0},
    }
