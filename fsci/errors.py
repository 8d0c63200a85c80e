"""Error types shared by the whole package.

`InputError` is what a user sees for bad input: one line naming the field, the value and
what is allowed. The command line turns it into exit status 2.
"""

from __future__ import annotations

from typing import Any

MAX_VALUE_TEXT = 80  # characters of a value quoted in an error message


class InputError(ValueError):
    """Invalid user input (case file, command-line override, mesh).

    Parameters
    ----------
    field
        Dotted path of the offending key, e.g. ``bodies[0].material.nu``.
    value
        The value that was given.
    allowed
        Human-readable description of what is allowed.
    """

    def __init__(self, field: str, value: Any, allowed: str) -> None:
        self.field = field
        self.value = value
        self.allowed = allowed
        text = repr(value)
        if len(text) > MAX_VALUE_TEXT:  # a whole table or a long list: its start identifies it
            text = text[:MAX_VALUE_TEXT - 3] + "..."
        super().__init__(f"{field} = {text}: {allowed}")

    def __reduce__(self):
        # rebuilt from the three parts (the default would pass the message as ``field`` alone),
        # so that the error survives pickling, e.g. out of the meshing process
        return type(self), (self.field, self.value, self.allowed)


class SolverError(RuntimeError):
    """A nonlinear or linear solve failed (the time loop may retry with a smaller step)."""


class MeshError(ValueError):
    """A mesh is unusable (inverted or degenerate cells, unknown set names)."""


class GeometryError(SolverError):
    """The current geometry cannot be cut (self-intersecting or escaping outline).

    During a run this fails the Newton solve (the step is retried with a smaller step); for the
    initial geometry it is reported as an input error."""


class FsciWarning(UserWarning):
    """Something the user should know about but that does not stop the run."""
