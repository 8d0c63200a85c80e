"""Built-in cases. Each is a case dictionary (exactly what ``fsci show CASE`` prints as TOML)
built by a function in one of the modules below; ``CASES`` maps the name to a
:class:`BuiltinCase`: a one-line description, the builder and the wall time of the default
run (``fsci run CASE``, no overrides) measured on 2 cores, shown by ``fsci list``.

A case with ``[[reference]]`` checks also has ``verified_at``: the parameter values at which
those checks are verified (equal to its default ``parameters``; ``tests/test_cases.py``
asserts both and runs every such default against its references).
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

from fsci.cases import (cavity, contact_cases, dfg, fsci_checks, moving_cylinder, pump, sinking_disk, squeezed, stamp,
                        turek_hron)


class BuiltinCase(NamedTuple):
    """A built-in case: description, builder, wall time of its default run on 2 cores."""

    description: str
    build: Callable[[], dict[str, Any]]
    wall_time: str


CASES: dict[str, BuiltinCase] = {
    "turek-hron-csm1": BuiltinCase("Turek-Hron CSM1: elastic bar under gravity, static (St. Venant-Kirchhoff)",
                                   turek_hron.csm1, "~6 s"),
    "turek-hron-csm3": BuiltinCase("Turek-Hron CSM3: elastic bar released under gravity, dynamic",
                                   turek_hron.csm3, "~25 s"),
    "turek-hron-fsi1": BuiltinCase("Turek-Hron FSI1: elastic bar behind a cylinder, steady, both embedded (CutFEM)",
                                   turek_hron.fsi1, "~20 s"),
    "stamp": BuiltinCase("Paper Sec. 4.1: rounded elastic stamp falls onto a rigid slab in fluid, rests, lifts off "
                         "(--set variant=navslip|noslip|slip|noslip-incpen|navslip-incpen)", stamp.stamp, "~3 min"),
    "sinking-disk": BuiltinCase("Elastic disk sinking under gravity in quiescent fluid (monolithic FSI)",
                                sinking_disk.sinking_disk, "~45 s"),
    "hertz": BuiltinCase("Hertz contact of a cylinder on a rigid flat (dry Nitsche contact)",
                         contact_cases.hertz, "~7 s"),
    "two-blocks": BuiltinCase("Two Neo-Hookean blocks pressed together to large strain and released (dry contact)",
                              contact_cases.two_blocks, "~7 s"),
    "cavity": BuiltinCase("Lid-driven cavity, steady Navier-Stokes (--set re=100|1000)", cavity.cavity, "~15 s"),
    "dfg-2d-1": BuiltinCase("DFG 2D-1 flow around a cylinder (Re 20), cylinder embedded (CutFEM)",
                            dfg.dfg_2d_1, "~22 s"),
    "dfg-2d-2": BuiltinCase("DFG 2D-2 flow around a cylinder (Re 100, periodic shedding), Crank-Nicolson, cylinder "
                            "embedded (CutFEM)", dfg.dfg_2d_2, "~15 min"),
    "moving-cylinder": BuiltinCase("Cylinder with prescribed oscillation and pulsation, mass balance (45)-(46)",
                                   moving_cylinder.moving_cylinder, "~20 s"),
    "pump": BuiltinCase("Paper Sec. 4.2: elastic valve pump, chamber squeezed periodically, two two-flap valves "
                        "(reconstructed; --set A2=1 for A = 1 throughout; the valve zones 4 times finer than the "
                        "paper's grid, --set r=1 for the paper's grid; about 3.5 s per step on 2 shared cores; the "
                        "inflow valve's openings at A = 1.5 cost a few step cuts, docs/cases/pump.md)", pump.pump,
                        "~2 h"),
    "squeezed": BuiltinCase("Paper Sec. 4.3: elastic body carried by channel flow and squeezed through an elastic "
                            "structure with three barriers (reconstructed; --set n=20 --set hb=0.03 for a coarse grid; "
                            "wall time of the whole run projected from its first 200 steps, docs/cases/squeezed.md)",
                            squeezed.squeezed, "~4 h"),
    "lift-off": BuiltinCase("Elastic block on a slab in fluid lifts off when the ambient pressure reaches its load "
                            "(FSCI, extension)", fsci_checks.lift_off, "~1 min"),
    "contact-sweep": BuiltinCase("Quasi-static push through fluid onto a slab and back: continuity of the FSI -> "
                                 "contact transition (FSCI)", fsci_checks.contact_sweep, "~20 s"),
    "blocks-film": BuiltinCase("Rounded block pressed through a fluid film onto another: contact forms, fluid "
                               "splits (FSCI)", fsci_checks.blocks_film, "~1 min"),
}


def get_case(name: str) -> dict[str, Any]:
    """The case dictionary of a built-in case (a fresh copy)."""
    return CASES[name].build()
