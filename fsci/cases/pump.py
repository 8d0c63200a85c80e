"""Elastic valve pump (paper Sec. 4.2), reconstructed.

The paper's Figure 14 with the geometry is lost. Kept from the text: fluid background grid
240 × 54 on [0, 1.5] × [-0.1755, 0.1755]; a channel through an elastic structure with a
chamber between two valves of two flaps each; the chamber squeezed by the load
``h = -20 A (1 - cos 40πt) n`` on a circular solid boundary Γ^P (zero tangential traction),
A = 1 on [0, 0.15] and A = 1.5 on [0.15, 0.3]; gravity ρ b = (0, -1) on solid and fluid;
hydrostatic Neumann conditions in x at the inflow Γ^in (x = 1.5) and the outflow Γ^out (x = 0),
zero y-velocity there; Neo-Hooke E = 2000, ν = 0.3; harmonic contact weights; κ0 = 0.1;
θ = 1; Δt = 2e-4 on [0, 0.1698], 1e-4 on [0.1698, 0.3]; design flow direction -x.

Chosen here (docs/cases/pump.md, fixed for every run):

* the structure is two bodies, above and below the channel, each reaching out of the fluid
  box (its outer edges are clamped outside the fluid; only channel-facing edges are wetted);
* channel half-height ``C`` = 0.03 at inlet and outlet; chamber x ∈ [0.45, 1.05], half-height
  ``H`` = 0.05, joined to the channel by straight ramps of length 0.06;
* Γ^P: a circular cavity (radius 0.25) in the upper body over the chamber, leaving a wall of
  thickness ``T_WALL`` = 0.015 over it (dry, it does not reach the lower wall at A = 1 and
  touches it at A = 1.5; ``benchmarks/pump_design.py``); the pressure in the cavity pushes the
  wall into the chamber (the body's key ``dry_cavities``: the cavity is not fluid);
* each valve: two flaps (0.035 wide along x, 0.014 thick across, length ≈ 0.07) attached to the channel walls and
  inclined towards -x, their tips 0.006 apart at rest: flow in -x opens them, flow in +x presses
  the tips together (the valve closes by contact); valves at x ≈ 0.3 (outflow side) and 1.25
  (inflow side);
* ρ^S = ρ^F = 1e-3 and μ = 1e-4 (exponents lost in the text; ρ as in the stamp example, μ from
  the paper's velocity scale, docs/cases/pump.md);
* the fluid grid: the paper's 240 × 54 with the valve zones 4 times finer (``r = 4``).
"""

from __future__ import annotations

import math
from typing import Any

C = 0.03  # channel half-height
H = 0.05  # chamber half-height
Y_OUT = 0.65  # outer surface of the structure (outside the box, |y| > 0.1755; above the cavity Γ^P)
X0, X1 = -0.05, 1.55  # ends of the structure (outside the box)
CH0, CH1, RAMP = 0.45, 1.05, 0.06  # chamber and its ramps
VALVES = (0.30, 1.25)  # flap attachments (left end on the wall)
FLAP_W, FLAP_DX, FLAP_TIP = 0.035, 0.06, 0.003  # flap width along x (0.014 across), x-reach, tip |y|
T_WALL = 0.015  # thickness of the wall between the chamber and the cavity Γ^P
R_P = 0.25  # radius of the cavity Γ^P over the chamber


def _half(sign: int, thickness: float) -> list[dict[str, Any]]:
    """Closed outline (counter-clockwise) of the upper (sign = 1) or lower (sign = -1) body."""

    def p(x: float, y: float) -> list[float]:
        return [x, sign * y]

    wall: list[list[float]] = [p(X0, C)]
    for xa in VALVES[:1]:
        wall += [p(xa, C), p(xa - FLAP_DX, FLAP_TIP), p(xa - FLAP_DX + FLAP_W, FLAP_TIP), p(xa + FLAP_W, C)]
    wall += [p(CH0 - RAMP, C), p(CH0, H), p(CH1, H), p(CH1 + RAMP, C)]
    for xa in VALVES[1:]:
        wall += [p(xa, C), p(xa - FLAP_DX, FLAP_TIP), p(xa - FLAP_DX + FLAP_W, FLAP_TIP), p(xa + FLAP_W, C)]
    wall += [p(X1, C)]
    if sign < 0:  # the lower body runs along its wall in -x to stay counter-clockwise
        wall = wall[::-1]
    loop = [{"line": [a, b], "name": "wet"} for a, b in zip(wall[:-1], wall[1:])]
    end, start = wall[-1], wall[0]
    if sign > 0:
        loop += [{"line": [end, [X1, Y_OUT]], "name": "outer"},
                 {"line": [[X1, Y_OUT], [X0, Y_OUT]], "name": "outer"},
                 {"line": [[X0, Y_OUT], start], "name": "outer"}]
    else:
        loop += [{"line": [end, [X0, -Y_OUT]], "name": "outer"},
                 {"line": [[X0, -Y_OUT], [X1, -Y_OUT]], "name": "outer"},
                 {"line": [[X1, -Y_OUT], start], "name": "outer"}]
    return loop


def _cavity(thickness: float) -> list[dict[str, Any]]:
    """Γ^P: a circular cavity in the upper body over the chamber (clockwise: a hole), leaving a
    wall of ``thickness`` over the chamber."""
    cx, cy = 0.5 * (CH0 + CH1), H + thickness + R_P
    pts = [[cx + R_P * math.cos(a), cy + R_P * math.sin(a)] for a in (0.0, -0.5 * math.pi, -math.pi, 0.5 * math.pi)]
    return [{"arc": {"start": pts[i], "center": [cx, cy], "end": pts[(i + 1) % 4]}, "name": "load"} for i in range(4)]


def structure(name: str, sign: int, thickness: float, h: str, h_fine: str) -> dict[str, Any]:
    refine = [{"point": [xa - 0.5 * FLAP_DX, sign * 0.5 * (C + FLAP_TIP)], "h": h_fine, "radius": 0.06}
              for xa in VALVES]
    body = {
        "name": name,
        "extends_outside": True,
        "dry_cavities": True,  # the cavity Γ^P holds the driving pressure, not the pumped fluid
        "material": {"law": "neo_hooke", "E": 2000.0, "nu": 0.3, "rho": 1e-3},
        "mesh": {"type": "outline", "loops": [_half(sign, thickness)] + ([_cavity(thickness)] if sign > 0 else []),
                 "h": h, "refine": refine},
        "body_force": [0.0, -1000.0],  # ρ b = (0, -1) with ρ = 1e-3
        "dirichlet": [{"boundary": "outer", "value": [0.0, 0.0]}],
        "interface": ["wet"],
        "contact": ["wet"],
        "slip_length": "gap_law",
    }
    if sign > 0:
        # h = -20 A (1 - cos 40πt) n on Γ^P, A = 1 until t = 0.15, then A2 (1.5 in the paper)
        body["neumann"] = [{"boundary": "load", "type": "pressure", "value": "20*(1-cos(40*pi*t))",
                            "function": {"type": "table", "times": [0.0, 0.15, 0.1500001, 1e3],
                                         "values": [1.0, 1.0, "=A2", "=A2"]}}]
    return body


def pump() -> dict[str, Any]:
    return {
        "name": "pump",
        "kind": "fsci",
        "description": "Elastic valve pump: a chamber between two two-flap valves squeezed periodically "
                       "(paper Sec. 4.2, reconstructed)",
        "parameters": {"A2": 1.5, "r": 4},
        "bodies": [structure("upper", 1, T_WALL, "=0.02", "=0.0065"), structure("lower", -1, T_WALL, "=0.02", "=0.0065")],
        "contact": {"gamma0": 1.0, "weighting": "harmonic"},
        "fluid": {
            "rho": 1e-3,
            "mu": 1e-4,
            "body_force": [0.0, -1000.0],
            # the paper's 240 × 54 grid (h = 0.00625 × 0.0065) for r = 1; r > 1 makes the two valve
            # zones and the channel band r times finer (default r = 4: a shut valve's contact zone
            # then spans more than a cell, so the two fluid pieces share no node)
            "grid": {"x": {"breaks": [0.0, 0.175, 0.3625, 1.1375, 1.325, 1.5], "cells": [28, "=30*r", 124, "=30*r", 28]},
                     "y": {"breaks": [-0.1755, -0.0325, 0.0325, 0.1755], "cells": [22, "=10*r", 22]}},
            "dirichlet": [{"boundary": "left", "value": ["free", 0.0]}, {"boundary": "right", "value": ["free", 0.0]}],
            "neumann": [{"boundary": "left", "type": "pressure", "value": "-y"},
                        {"boundary": "right", "type": "pressure", "value": "-y"}],
            "interface": {"kappa0": 0.1},
            # a flap's edge passing over a grid node would switch the ghost penalty (26) of a whole
            # cell on at once and Newton alternate between two states (docs/architecture.md,
            # decision 33): ramp it in over the first 0.1 % of solid in a cell
            "stabilization": {"ghost_ramp": 1e-3},
        },
        "time": {"type": "transient", "theta": 1.0,
                 "segments": [{"until": 0.1698, "dt": 2e-4}, {"until": 0.3, "dt": 1e-4}]},
        # where a valve opens again Newton converges linearly and a step of 2e-4 fails after 25
        # iterations, one of 1e-4 converges: stay at the cut size for 5 steps before growing back
        "solver": {"tol_residual": 1e-9, "tol_increment": 1e-10, "steps_before_growth": 5},
        "quantities": [
            {"name": "flow_in", "type": "flow_rate", "boundary": "right"},
            {"name": "flow_out", "type": "flow_rate", "boundary": "left"},
            {"name": "mass", "type": "mass_balance"},
            {"name": "upper", "type": "interface_summary", "body": "upper"},
            {"name": "lower", "type": "interface_summary", "body": "lower"},
            # contact per valve and in the chamber, seen from the upper body
            *({"name": where, "type": "interface_summary", "body": "upper", "x_range": xr}
              for where, xr in (("valve_left", [0.2, 0.4]), ("chamber", [0.4, 1.1]), ("valve_right", [1.15, 1.35]))),
            # the chamber walls at mid-chamber: the gap there is 2 H + upper - lower
            *({"name": f"wall_{b}", "type": "point_displacement", "body": b, "component": 1,
               "point": [0.5 * (CH0 + CH1), sgn * H]} for b, sgn in (("upper", 1), ("lower", -1))),
            # pressures against the outlet (x = 0.02): chamber (0.01 above its lower wall: the upper
            # wall comes down past the axis), and in front of / behind each valve
            *({"name": f"p_{where}", "type": "pressure_difference", "points": [[x, y], [0.02, 0.0]]}
              for where, x, y in (("chamber", 0.75, 0.01 - H), ("left_valve_out", 0.20, 0.0),
                                  ("left_valve_chamber", 0.36, 0.0), ("right_valve_chamber", 1.15, 0.0),
                                  ("right_valve_in", 1.32, 0.0))),
            # flap tips: the valve opening is 2 FLAP_TIP + (u_y upper) - (u_y lower); u_x shows a
            # flap that snaps through (its tip swings to +x)
            *({"name": f"tip_{v}_{b}{suffix}", "type": "point_displacement", "body": b, "component": comp,
               "point": [xa - FLAP_DX + 0.5 * FLAP_W, sgn * (FLAP_TIP + 0.0005)]}
              for v, xa in zip(("left", "right"), VALVES) for b, sgn in (("upper", 1), ("lower", -1))
              for suffix, comp in (("", 1), ("_x", 0))),
            {"name": "pieces", "type": "fluid_pieces"},
        ],
        "output": {"every": 50},
    }
