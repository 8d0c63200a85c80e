"""Flow-driven squeezing of an elastic body through an elastic structure (paper Sec. 4.3),
reconstructed.

The paper's Figure 18 with the geometry is lost. Kept from the text: fluid background grid
120 × 300 on [-1, 1] × [0, 5]; an initially circular elastic body Ω^S_2 (Neo-Hooke E = 100,
ν = 0.3, 4890 elements) carried by the channel flow through an elastic structure Ω^S_1
(Neo-Hooke E = 200, ν = 0.3, 1562 elements) with constrictions ("barriers"), met first on the
right and then on the left; parabolic inflow ``v = (0, -100 (1 - x²) min(1, 4000 t))`` on the
top Γ^in, zero traction on the bottom Γ^out; γ0^F and γ0^t divided by 7 (35 -> 5); harmonic
contact weighting; κ0 = 0.1; θ = 1; Δt = 2e-5 on [0, 0.0056], 5e-6 on [0.0056, 0.016]. The
paper's events: contact with the right part of Ω^S_1 at t = 0.00324, with the left part at
0.00386 (the fluid splits in two), release 0.00668, recontact (right) 0.00713, two more cycles,
final separation 0.015155.

Chosen here (docs/cases/squeezed.md, fixed for every run):

* the structure is two bodies, ``left`` and ``right``: walls whose channel-facing surface is
  x = ±``W`` (W = 0.75), reaching out of the fluid box to x = ±1.15 where they are clamped (only
  the channel-facing edges are wetted); 45° ramps join them to the box sides at the top
  (y = 4.6 on x = ±1) and the bottom (y = 0.15), so that the inflow and the outflow span the
  whole box width as the parabolic profile requires;
* three barriers: a semicircular bump of radius ``RB`` (0.45, every bump) on each wall, the right
  one ``STAGGER`` (0.3) above the left one, at y = 3.7 / 3.4, 2.5 / 2.2 and 1.3 / 1.0 (right /
  left bump centres); the narrowest passage of a barrier is 0.63 wide, less than the body's
  diameter 0.8, and the body meets the right bump first; between the barriers the passages
  from a left bump to the next right bump (0.85 wide) are the larger constrictions;
* the body: a disk of radius ``R`` = 0.4 centred at (0, ``Y0``), Y0 = 4.4, free (no Dirichlet:
  it is held only by the fluid and by contact);
* ρ^S = ρ^F = μ = 1e-7 (parameter ``rho``; the exponent is unreadable in the text). The value
  is fixed by the physics the paper describes, not by the print: the fluid column (length 5)
  accelerated by the inflow ramp pushes against the compliant solids, an oscillator whose
  period grows as √ρ. With 1e-3 (the stamp's value) the inertia pressure (~10³) exceeds E: the
  solids absorb the inflow and nothing flows out. With 1e-6 the outflow rate oscillates between
  57 and 245 (inflow 133) until first contact; with 1e-7 it overshoots once (183) and settles to
  the inflow by t = 0.0015, before first contact, as the paper's description of the outflow
  rate requires (it departs from the inflow only while the body blocks or squeezes through).
  ν = μ/ρ = 1, channel Reynolds number Ū 2/ν ≈ 130 (Ū = 66.7 the mean inflow velocity);
* ``n`` fluid cells per unit length (60: the paper's 120 × 300); body mesh size ``hb`` = 0.0105
  (4824 quads; paper 4890), wall surface size ``hw`` = 0.05 growing to 3.3 hw inside (818 + 820
  quads; paper 1562 for the structure). Coarse: ``--set n=20 --set hb=0.03`` (40 × 100 cells,
  772 quads in the body).
"""

from __future__ import annotations

from typing import Any

W = 0.75  # half-width of the channel between the walls
X_OUT = 1.15  # clamped outer edges of the walls (outside the box, |x| > 1)
Y_TOP, Y_BOT = 4.35, 0.4  # ends of the straight wall surface x = ±W (ramps of 45° to the box sides)
RAMP = 0.3  # the ramps reach x = ±(W + RAMP) = ±1.05, outside the box
RB = 0.45  # radius of every bump
STAGGER = 0.3  # the right bump of a barrier lies this much above the left one
BARRIERS = (3.7, 2.5, 1.3)  # y of the right bump centres; left ones at y - STAGGER
R = 0.4  # radius of the body
Y0 = 4.4  # initial centre of the body (x = 0)


def bump_centres(side: int) -> list[float]:
    """y of the bump centres on the right (side = 1) or left (side = -1) wall."""
    return [y if side > 0 else y - STAGGER for y in BARRIERS]


def wall_outline(side: int) -> list[dict[str, Any]]:
    """Closed outline of the right (side = 1) or left (side = -1) wall: the wetted channel
    surface (``wet``: ramps, straight parts, bumps) and the dry parts outside the box
    (``outer``: clamped)."""
    s = float(side)

    def p(x: float, y: float) -> list[float]:
        return [s * x, y]

    # the channel surface from the top ramp down to the bottom ramp
    wet: list[dict[str, Any]] = [{"line": [p(W + RAMP, Y_TOP + RAMP), p(W, Y_TOP)], "name": "wet"}]
    y = Y_TOP
    for yc in sorted(bump_centres(side), reverse=True):
        wet.append({"line": [p(W, y), p(W, yc + RB)], "name": "wet"})
        # semicircle bulging into the channel, as two quarter arcs
        wet.append({"arc": {"start": p(W, yc + RB), "center": p(W, yc), "end": p(W - RB, yc)}, "name": "wet"})
        wet.append({"arc": {"start": p(W - RB, yc), "center": p(W, yc), "end": p(W, yc - RB)}, "name": "wet"})
        y = yc - RB
    wet.append({"line": [p(W, y), p(W, Y_BOT)], "name": "wet"})
    wet.append({"line": [p(W, Y_BOT), p(W + RAMP, Y_BOT - RAMP)], "name": "wet"})
    outer = [
        {"line": [p(W + RAMP, Y_BOT - RAMP), p(X_OUT, Y_BOT - RAMP)], "name": "outer"},
        {"line": [p(X_OUT, Y_BOT - RAMP), p(X_OUT, Y_TOP + RAMP)], "name": "outer"},
        {"line": [p(X_OUT, Y_TOP + RAMP), p(W + RAMP, Y_TOP + RAMP)], "name": "outer"},
    ]
    return wet + outer  # gmsh orients the loop


def wall(name: str, side: int) -> dict[str, Any]:
    return {
        "name": name,
        "extends_outside": True,
        "material": {"law": "neo_hooke", "E": 200.0, "nu": 0.3, "rho": "=rho"},
        "mesh": {"type": "outline", "loops": [wall_outline(side)], "h": "=hw", "h_max": "=10/3*hw"},
        "dirichlet": [{"boundary": "outer", "value": [0.0, 0.0]}],
        "interface": ["wet"],
        "contact": ["wet"],
        "slip_length": "gap_law",
    }


def body() -> dict[str, Any]:
    return {
        "name": "body",
        "material": {"law": "neo_hooke", "E": 100.0, "nu": 0.3, "rho": "=rho"},
        "mesh": {"type": "disk", "center": [0.0, Y0], "radius": R, "h": "=hb", "name": "surface"},
        "contact": ["surface"],
        "slip_length": "gap_law",
    }


def squeezed() -> dict[str, Any]:
    return {
        "name": "squeezed",
        "kind": "fsci",
        "description": "Flow-driven squeezing of an elastic body through an elastic structure with three "
                       "barriers (paper Sec. 4.3, reconstructed)",
        # n: fluid cells per unit length; hb, hw: body and wall mesh sizes; rho: ρ^S = ρ^F = μ
        "parameters": {"n": 60, "hb": 0.0105, "hw": 0.05, "rho": 1e-7},
        "bodies": [wall("right", 1), wall("left", -1), body()],
        "contact": {"gamma0": 1.0, "weighting": "harmonic"},
        "fluid": {
            "rho": "=rho",
            "mu": "=rho",
            "grid": {"x": {"start": -1.0, "end": 1.0, "cells": "=2*n"}, "y": {"start": 0.0, "end": 5.0, "cells": "=5*n"}},
            # no-slip box sides (above and below the walls); the parabolic inflow, ramped over
            # t ≤ 0.00025 (4000 t), listed last (it is zero at the corners anyway); the bottom is
            # traction free
            "dirichlet": [{"boundary": "left", "value": [0.0, 0.0]}, {"boundary": "right", "value": [0.0, 0.0]},
                          {"boundary": "top", "value": [0.0, "-100*(1-x**2)"],
                           "function": {"type": "ramp", "t0": 0.0, "t1": 0.00025}}],
            # γ0^F and γ0^t divided by 7 from the defaults 35 (paper Remark 8)
            "interface": {"gamma_n": 5.0, "gamma_t": 5.0, "kappa0": 0.1},
        },
        "time": {"type": "transient", "theta": 1.0,
                 "segments": [{"until": 0.0056, "dt": 2e-5}, {"until": 0.016, "dt": 5e-6}]},
        # with ρ = μ = 1e-7 the fluid rows are 1e-7 times the solid rows: in contact the residual reaches
        # its round-off floor (~3e-12) before the increments fall below 1e-10 (docs/cases/squeezed.md)
        "solver": {"tol_residual": 1e-9, "tol_increment": 1e-8},
        "quantities": [
            # outward fluxes: the inflow rate in -y is -flow_in, the outflow rate flow_out
            {"name": "flow_in", "type": "flow_rate", "boundary": "top"},
            {"name": "flow_out", "type": "flow_rate", "boundary": "bottom"},
            {"name": "mass", "type": "mass_balance"},
            {"name": "right", "type": "interface_summary", "body": "right"},
            {"name": "left", "type": "interface_summary", "body": "left"},
            {"name": "body", "type": "interface_summary", "body": "body"},
            {"name": "pieces", "type": "fluid_pieces"},
            {"name": "centroid", "type": "body_centroid", "body": "body"},
            {"name": "energy", "type": "elastic_energy", "body": "body"},
            {"name": "energy_walls", "type": "elastic_energy", "body": ["left", "right"]},
            {"name": "contact_right", "type": "event", "of": "right_length_contact", "when": "rises_from_zero"},
            {"name": "contact_left", "type": "event", "of": "left_length_contact", "when": "rises_from_zero"},
            {"name": "release", "type": "event", "of": "body_length_contact", "when": "falls_to_zero"},
        ],
        "output": {"every": 50},
    }
