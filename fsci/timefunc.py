"""Time functions used to scale loads and boundary values.

All functions map time ``t`` to a scalar factor. A time function is described in a case file
by a small table, e.g. ``{type = "ramp", t0 = 0, t1 = 2}``, whose keys are defined in
:data:`fsci.schema.TIME_FUNCTION`; :func:`time_function` turns a validated table into a
callable (the forms and their keys are listed in docs/case-format.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

TimeFunction = Callable[[float], float]


@dataclass(frozen=True)
class _Constant:
    value: float

    def __call__(self, t: float) -> float:
        return self.value


@dataclass(frozen=True)
class _Ramp:
    t0: float
    t1: float

    def __call__(self, t: float) -> float:
        if t <= self.t0:
            return 0.0
        if t >= self.t1:
            return 1.0
        return (t - self.t0) / (self.t1 - self.t0)


@dataclass(frozen=True)
class _Table:
    times: tuple[float, ...]
    values: tuple[float, ...]

    def __call__(self, t: float) -> float:
        return float(np.interp(t, self.times, self.values))


@dataclass(frozen=True)
class _OneMinusCos:
    t0: float
    t1: float | None
    period: float | None
    amplitude: float

    def __call__(self, t: float) -> float:
        if t <= self.t0:
            return 0.0
        if self.period is not None:
            return self.amplitude * (1.0 - math.cos(2.0 * math.pi * (t - self.t0) / self.period))
        assert self.t1 is not None
        if t >= self.t1:
            return self.amplitude
        return self.amplitude * 0.5 * (1.0 - math.cos(math.pi * (t - self.t0) / (self.t1 - self.t0)))


@dataclass(frozen=True)
class _Linear:
    slope: float
    t0: float

    def __call__(self, t: float) -> float:
        return self.slope * (t - self.t0) if t > self.t0 else 0.0


def make_time_function(spec: Any, field: str = "function") -> TimeFunction:
    """Validate a time function's case-file description (:data:`fsci.schema.TIME_FUNCTION`)
    and build it.

    Parameters
    ----------
    spec
        ``None`` (constant 1), a number (constant), or a table with a ``type`` key.
    field
        Dotted name of the key, used in error messages.

    Returns
    -------
    callable
        ``f(t) -> float``.
    """
    from fsci.schema import TIME_FUNCTION, Context

    return time_function(None if spec is None else TIME_FUNCTION.check(spec, field, Context()))


def time_function(spec: float | Mapping[str, Any] | None) -> TimeFunction:
    """The time function of a validated description (``None``, a number or a normalised table)."""
    if spec is None:
        return _Constant(1.0)
    if not isinstance(spec, Mapping):
        return _Constant(float(spec))
    kind = spec["type"]
    if kind == "constant":
        return _Constant(spec["value"])
    if kind == "ramp":
        return _Ramp(spec["t0"], spec["t1"])
    if kind == "table":
        return _Table(tuple(spec["times"]), tuple(spec["values"]))
    if kind == "one_minus_cos":
        return _OneMinusCos(spec["t0"], spec["t1"], spec["period"], spec["amplitude"])
    return _Linear(spec["slope"], spec["t0"])
