"""Built-in cases. Each is a case dictionary (exactly what ``fsci show CASE`` prints as TOML)
built by a function in one of the modules below; ``CASES`` maps the name to a one-line
description and the builder."""

from __future__ import annotations

from typing import Any, Callable

from fsci.cases import cavity, contact_cases, dfg, moving_cylinder, sinking_disk, stamp, turek_hron

CASES: dict[str, tuple[str, Callable[[], dict[str, Any]]]] = {
    "turek-hron-csm1": ("Turek-Hron CSM1: elastic bar under gravity, static (St. Venant-Kirchhoff)", turek_hron.csm1),
    "turek-hron-csm3": ("Turek-Hron CSM3: elastic bar released under gravity, dynamic", turek_hron.csm3),
    "turek-hron-fsi1": ("Turek-Hron FSI1: elastic bar behind a cylinder, steady, both embedded (CutFEM)",
                        turek_hron.fsi1),
    "stamp-falling": ("Paper Sec. 4.1: rounded elastic stamp falling onto a rigid slab (until just before contact)",
                      stamp.stamp_falling),
    "sinking-disk": ("Elastic disk sinking under gravity in quiescent fluid (monolithic FSI)",
                     sinking_disk.sinking_disk),
    "hertz": ("Hertz contact of a cylinder on a rigid flat (dry Nitsche contact)", contact_cases.hertz),
    "two-blocks": ("Two Neo-Hookean blocks pressed together to large strain and released (dry contact)",
                   contact_cases.two_blocks),
    "cavity": ("Lid-driven cavity, steady Navier-Stokes (--set re=100|1000)", cavity.cavity),
    "dfg-2d-1": ("DFG 2D-1 flow around a cylinder (Re 20), cylinder embedded (CutFEM)", dfg.dfg_2d_1),
    "moving-cylinder": ("Cylinder with prescribed oscillation and pulsation, mass balance (45)-(46)",
                        moving_cylinder.moving_cylinder),
}


def get_case(name: str) -> dict[str, Any]:
    """The case dictionary of a built-in case (a fresh copy)."""
    return CASES[name][1]()
