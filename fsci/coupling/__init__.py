"""Coupling of body boundaries to what lies beyond them: fluid (FSI), another body (contact), or
both (FSCI) — one term, one per-point traction (paper (27)), cases I-IV."""

from fsci.coupling.term import CouplingTerm

__all__ = ["CouplingTerm"]
