"""Time functions used to scale loads and boundary values.

All functions map time ``t`` to a scalar factor. A time function is described in a case file
by a small table, e.g. ``{type = "ramp", t0 = 0, t1 = 2}``; :func:`make_time_function`
turns that table into a callable and validates it.

Types
-----
constant      f(t) = value (default 1)
ramp          linear from 0 at t0 to 1 at t1, constant afterwards (and 0 before t0)
table         piecewise-linear interpolation of ``times``/``values``; constant outside
one_minus_cos ``0.5 (1 - cos(pi (t - t0)/(t1 - t0)))`` on [t0, t1], 1 after, 0 before
              (Turek-Hron inflow ramp); with ``period`` instead of t1 the function is
              periodic: ``1 - cos(2 pi (t - t0)/period)`` (the pump load of the paper, Sec. 4.2)
linear        f(t) = slope * (t - t0) for t > t0, 0 before (the stamp's lifting load)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

from fsci.errors import InputError

TimeFunction = Callable[[float], float]

_TYPES = ("constant", "ramp", "table", "one_minus_cos", "linear")


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


def _number(spec: Mapping[str, Any], key: str, field: str, default: float | None = None) -> float:
    if key not in spec:
        if default is None:
            raise InputError(f"{field}.{key}", None, "required number is missing")
        return default
    value = spec[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{field}.{key}", value, "a finite number is required")
    return float(value)


def make_time_function(spec: Any, field: str = "function") -> TimeFunction:
    """Build a time function from its case-file description.

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
    if spec is None:
        return _Constant(1.0)
    if isinstance(spec, (int, float)) and not isinstance(spec, bool):
        return _Constant(float(spec))
    if not isinstance(spec, Mapping):
        raise InputError(field, spec, "a number or a table with 'type' in " + ", ".join(_TYPES))
    kind = spec.get("type")
    if kind not in _TYPES:
        raise InputError(f"{field}.type", kind, "one of " + ", ".join(_TYPES))
    if kind == "constant":
        return _Constant(_number(spec, "value", field, 1.0))
    if kind == "ramp":
        t0 = _number(spec, "t0", field, 0.0)
        t1 = _number(spec, "t1", field)
        if t1 <= t0:
            raise InputError(f"{field}.t1", t1, f"must be greater than t0 = {t0}")
        return _Ramp(t0, t1)
    if kind == "table":
        times = spec.get("times")
        values = spec.get("values")
        if not isinstance(times, list) or not isinstance(values, list) or len(times) != len(values) or len(times) < 1:
            raise InputError(f"{field}.times", times, "two lists 'times' and 'values' of equal, non-zero length")
        t = np.asarray(times, dtype=float)
        if np.any(np.diff(t) <= 0):
            raise InputError(f"{field}.times", times, "strictly increasing times")
        return _Table(tuple(float(x) for x in times), tuple(float(x) for x in values))
    if kind == "one_minus_cos":
        t0 = _number(spec, "t0", field, 0.0)
        amp = _number(spec, "amplitude", field, 1.0)
        if "period" in spec:
            period = _number(spec, "period", field)
            if period <= 0:
                raise InputError(f"{field}.period", period, "must be positive")
            return _OneMinusCos(t0, None, period, amp)
        t1 = _number(spec, "t1", field)
        if t1 <= t0:
            raise InputError(f"{field}.t1", t1, f"must be greater than t0 = {t0}")
        return _OneMinusCos(t0, t1, None, amp)
    # linear
    return _Linear(_number(spec, "slope", field, 1.0), _number(spec, "t0", field, 0.0))
