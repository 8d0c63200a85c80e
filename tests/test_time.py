"""Time accuracy of the one-step-θ scheme: θ ∈ [0.5, 1] in the case file, the order of the
step's predictors, the period analysis of periodic signals, and the temporal order of convergence on a moving body in fluid and with
contact held closed (docs/validation.md, "Time accuracy").

Temporal order is measured on one grid: the errors of Δt, Δt/2, Δt/4 against a Δt/16
reference, as the maximum over the common time levels (the steps of Δt) and over the observed
values, so that the phase of an error wave at one instant does not decide the rate. Nothing
non-smooth may happen during the runs (a background cell changing state, a body vertex
crossing a grid line, a contact point switching case): such an event is not resolved by a
smaller step and would pollute the rate, so each study asserts that it does not occur.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from fsci.cases import get_case
from fsci.config import problem_from_dict
from fsci.errors import InputError
from fsci.post.quantities import oscillation
from fsci.simulation import Simulation

# smooth start: position, velocity and acceleration vanish at t = 0, so the data are compatible
# with the body and the fluid at rest (an impulsive start is not, and Crank-Nicolson does not
# damp the error it causes)
SMOOTH_START = "sin(pi*t/2)**4"


class OrderBelowExpected(Exception):
    """A measured temporal order is below the asserted one."""


# --------------------------------------------------------------------------- θ bounds
def test_theta_half_is_allowed_and_below_half_rejected():
    """θ = 0.5 (Crank-Nicolson) and θ = 1 are accepted; θ < 0.5 (unstable) and θ > 1 are one
    clear error naming the key."""
    case = pressed_blocks_case(0.5, 0.1)
    assert problem_from_dict(case).time.theta == 0.5
    for bad in (0.49, 1.01):
        case["time"]["theta"] = bad
        with pytest.raises(InputError) as e:
            problem_from_dict(case)
        assert "time.theta" in str(e.value)


# --------------------------------------------------------------------------- predictors
def _start_distance(dt: float, predictor: str, t_star: float = 0.3) -> tuple[float, float]:
    """Distance from the start of the sinking disk's step t* → t* + Δt to its solution: the
    largest displacement difference of the disk and the rms velocity difference of the fluid
    at the nodes ACTIVE at both."""
    case = get_case("sinking-disk")
    case["time"] = {"type": "transient", "theta": 1.0, "segments": [{"until": t_star + dt, "dt": dt}]}
    case["solver"]["predictor"] = predictor
    case["output"] = {"every": 0, "figures": False, "fields": False}
    sim = Simulation(problem_from_dict(case))
    disk, fluid = sim.system.solids[0], sim.system.fluid
    start = []
    begin = sim.system.begin_step
    sim.system.begin_step = lambda ctx, **kw: (begin(ctx, **kw),
                                               start.append((disk.U.copy(), fluid.V.copy(), fluid.active.copy())))
    sim.run()
    U0, V0, active = start[-1]
    both = active & fluid.active
    return float(np.abs(disk.U - U0).max()), float(np.sqrt(np.mean((fluid.V - V0)[both] ** 2)))


def test_the_constant_acceleration_predictor_starts_a_step_one_order_closer():
    """A time step starts from the last velocities (``constant_velocity``: the start is O(Δt²)
    from the step's displacement and O(Δt) from its velocity) or from the velocities and the
    pressure extrapolated from the last two steps (``constant_acceleration``: one order closer
    in both, solid and fluid alike). Measured on the sinking disk at t = 0.3 with Δt = 0.01 and
    0.005: displacement rate 1.97 and 3.26, fluid velocity rate 1.02 and 2.55."""
    for predictor, (lo_u, hi_u), (lo_v, hi_v) in [("constant_velocity", (1.7, 2.3), (0.8, 1.4)),
                                                  ("constant_acceleration", (2.7, 4.0), (2.2, 3.5))]:
        (u1, v1), (u2, v2) = (_start_distance(dt, predictor) for dt in (0.01, 0.005))
        assert lo_u < np.log2(u1 / u2) < hi_u, (predictor, u1, u2)
        assert lo_v < np.log2(v1 / v2) < hi_v, (predictor, v1, v2)


# --------------------------------------------------------------------------- period analysis
def _old_local_maxima_period(t: np.ndarray, y: np.ndarray) -> float:
    """The period from the last two plain local maxima (the analysis before prominence)."""
    idx = [i for i in range(1, len(y) - 1) if y[i] > y[i - 1] and y[i] >= y[i + 1]]
    return float(t[idx[-1]] - t[idx[-2]])


def test_oscillation_ignores_wiggles_near_a_maximum():
    """A signal with small high-frequency wiggles near its maxima (like ux(A) of CSM3, where
    the frequency came out as 17.9 Hz instead of 2.2 Hz): the period is the signal's, not the
    wiggles'. Frequency within 0.1 %, extremes within 3 % of the wiggle amplitude."""
    f, dt = 2.2, 0.005
    t = np.arange(0.0, 3.0, dt)
    near_max = np.cos(2 * np.pi * f * t) > 0.95
    y = -0.012 + 0.011 * np.cos(2 * np.pi * f * t) + 4e-4 * np.sin(2 * np.pi * 15 * f * t) * near_max
    assert abs(1.0 / _old_local_maxima_period(t, y) - f) > 10 * f  # the wiggles fooled the old analysis
    r = oscillation(t, y)
    assert r["frequency"] == pytest.approx(f, rel=1e-3)
    assert r["max"] == pytest.approx(-0.001, abs=4e-4) and r["min"] == pytest.approx(-0.023, abs=1e-6)
    assert r["mean"] == pytest.approx(0.5 * (r["max"] + r["min"]))
    assert r["amplitude"] == pytest.approx(0.5 * (r["max"] - r["min"]))


def test_oscillation_of_a_growing_then_periodic_signal():
    """Vortex-shedding-like signal: growing from small values, then periodic with a mean and an
    overtone; the last full period gives frequency, max and min to the sampling accuracy, also
    when the record ends just after a maximum (whose descent is not seen: not counted). A
    record without two prominent maxima gives NaN."""
    f, dt = 3.0, 0.002
    t = np.arange(0.0, 6.0, dt)

    def periodic(t: np.ndarray) -> np.ndarray:
        return 0.01 + np.sin(2 * np.pi * f * t) + 0.05 * np.sin(4 * np.pi * f * t)

    y = (periodic(t) - 0.01) / (1.0 + np.exp(-4.0 * (t - 2.0))) + 0.01
    fine = periodic(np.linspace(0.0, 1.0 / f, 100001))
    for end in (6.0, 5.0 + 0.25 / f + 2 * dt):  # the second ends just after a maximum
        r = oscillation(t[t < end], y[t < end])
        assert r["frequency"] == pytest.approx(f, rel=1e-4)
        assert r["max"] == pytest.approx(fine.max(), abs=1e-4) and r["min"] == pytest.approx(fine.min(), abs=1e-4)
    one_period = t < 1.0 / f
    assert all(np.isnan(v) for v in oscillation(t[one_period], periodic(t[one_period])).values())
    assert all(np.isnan(v) for v in oscillation(t, np.zeros_like(t)).values())


# --------------------------------------------------------------------------- order studies
def temporal_errors(build: Callable[[float, float], dict[str, Any]], theta: float, dts: tuple[float, ...],
                    observe: Callable[[Simulation], dict[str, np.ndarray]],
                    signature: Callable[[Simulation], Any], ref_factor: int = 16) -> tuple[dict[str, np.ndarray], set]:
    """Errors of the runs with ``dts`` against one with ``dts[0]/ref_factor``.

    ``build(theta, dt)`` returns the case; ``observe(sim)`` the observed values after a step
    (named groups); ``signature(sim)`` a hashable description of everything that must not
    change (cut, case counts). Returns, per group, the errors (max over the steps of
    ``dts[0]`` and over the group's values) and the set of signatures seen in all runs and
    steps."""
    seen: set = set()

    def run(dt: float) -> dict[int, dict[str, np.ndarray]]:
        sim = Simulation(problem_from_dict(build(theta, dt)))
        out: dict[int, dict[str, np.ndarray]] = {}

        def hook(s: Simulation, ctx, rep) -> None:
            seen.add(signature(s))
            k = round(s.t / dts[0])
            if abs(s.t - k * dts[0]) < 1e-9:
                out[k] = {name: np.array(v, dtype=float) for name, v in observe(s).items()}

        sim.step_hooks.append(hook)
        sim.run()
        return out

    ref = run(dts[0] / ref_factor)
    errors: dict[str, list[float]] = {}
    for dt in dts:
        got = run(dt)
        assert got.keys() == ref.keys()
        for name in ref[min(ref)]:
            errors.setdefault(name, []).append(max(float(np.abs(got[k][name] - ref[k][name]).max()) for k in ref))
    return {name: np.array(e) for name, e in errors.items()}, seen


def rates_of(errors: np.ndarray) -> np.ndarray:
    """Observed orders between successive step sizes (each half the previous)."""
    return np.log2(errors[:-1] / errors[1:])


def check_order(errors: dict[str, np.ndarray], theta: float) -> None:
    """θ = 0.5: every rate ≥ 1.8; θ = 1: every rate within [0.8, 1.3] (against a Δt/16
    reference, order 1 shows as 1.10 and 1.22, order 2 as 2.02 and 2.09)."""
    for name, e in errors.items():
        r = rates_of(e)
        ok = np.all(r >= 1.8) if theta == 0.5 else np.all((r >= 0.8) & (r <= 1.3))
        if not ok:
            raise OrderBelowExpected(f"θ = {theta}, {name}: errors {e}, rates {np.round(r, 2)}")


# a rigid block moving in a closed box
def moving_block_case(theta: float, dt: float, n: int = 16, amplitude: float = 0.2,
                      t_end: float = 0.5) -> dict[str, Any]:
    """A rigid 4 × 4-element block in a closed box of n × n cells (ρ = 1, μ = 0.05), moved by
    ``amplitude`` h (sin(πt/2))⁴ along (1, 1/2). Its corners sit 0.35 h and 0.4 h from the
    grid lines, so for amplitude < 0.35 no corner crosses a grid line and no cell changes
    state: the cut moves smoothly."""
    h = 1.0 / n
    a = amplitude * h
    block = {"name": "block", "rigid": True,
             "material": {"law": "neo_hooke", "E": 1.0, "nu": 0.3},
             "mesh": {"type": "rectangle", "x0": 6.35 * h, "x1": 9.65 * h, "y0": 6.4 * h, "y1": 9.6 * h,
                      "nx": 4, "ny": 4},
             "dirichlet": [{"boundary": "body", "value": [f"{a}*{SMOOTH_START}", f"{0.5 * a}*{SMOOTH_START}"]}]}
    return {"name": "moving-block", "kind": "cutfem", "bodies": [block],
            "fluid": {"rho": 1.0, "mu": 0.05,
                      "grid": {"x": {"start": 0.0, "end": 1.0, "cells": n}, "y": {"start": 0.0, "end": 1.0, "cells": n}},
                      "dirichlet": [{"boundary": s, "value": [0.0, 0.0]} for s in ("left", "right", "bottom", "top")]},
            "time": {"type": "transient", "theta": theta, "t_end": t_end, "dt": dt},
            "solver": {"tol_residual": 1e-12, "tol_increment": 1e-12},
            "output": {"every": 0, "figures": False, "fields": False}}


def fluid_nodes_off_the_block(sim: Simulation, amplitude: float = 0.2) -> np.ndarray:
    """Background nodes that stay in the fluid during the whole motion."""
    f = sim.system.fluid
    s = sim.system.solids[0]
    h = f.grid.cell_size.max()
    lo, hi = s.X.min(axis=0) - amplitude * h, s.X.max(axis=0) + amplitude * h
    X = f.grid.nodes
    return ~np.all((X >= lo) & (X <= hi), axis=1)


def cut_signature(sim: Simulation) -> tuple:
    """The cell states, the ACTIVE nodes and the cell of every interface piece."""
    cut = sim.system.cut
    return (cut.state.tobytes(), sim.system.fluid.active.tobytes(), cut.segments.cell.tobytes())


@pytest.mark.parametrize("theta", [0.5, 1.0])
@pytest.mark.xfail(strict=True, raises=OrderBelowExpected,
                   reason="the fluid is not consistent in time: Δt in the stabilisation parameters, face terms "
                          "not θ-weighted, pressure face terms at the n+θ pressure, lagged stabilisation "
                          "velocity, old bulk level on the new domain (docs/validation.md, Time accuracy)")
def test_temporal_order_on_a_moving_body(theta):
    """Fluid velocity around a rigid block moved smoothly inside one cell (no cell changes
    state, the cut moves smoothly: asserted): order 2 for θ = 0.5, 1 for θ = 1. Measured today
    0.14, 0.30 (θ = 0.5) and 0.46, 0.50 (θ = 1): the errors hardly fall. With the five causes
    removed in an experiment (docs/validation.md) 2.00, 2.06 and 1.10, 1.22; then this test
    passes and the xfail marker must go (strict)."""
    mask: dict[str, np.ndarray] = {}

    def observe(sim: Simulation) -> dict[str, np.ndarray]:
        if "fluid" not in mask:
            mask["fluid"] = fluid_nodes_off_the_block(sim)
        return {"fluid velocity": sim.system.fluid.V[mask["fluid"]]}

    errors, seen = temporal_errors(moving_block_case, theta, (0.05, 0.025, 0.0125), observe, cut_signature)
    print({name: (e, rates_of(e)) for name, e in errors.items()})
    assert len(seen) == 1  # the same cut topology in every step of every run
    check_order(errors, theta)


# two blocks pressed together (dry contact, dynamics)
def pressed_blocks_case(theta: float, dt: float, t_end: float = 0.5) -> dict[str, Any]:
    """The two-blocks geometry in dynamics with the contact closed from the first step: the
    upper block (ρ = 0.1) touches the lower one and is pressed by a body force and a prescribed
    displacement of its top, both ramped by (sin(πt/2))⁴; non-matching meshes whose nodes stay
    ≥ 0.013 apart along the interface, so no projected node crosses a node (no change of the
    split integration)."""
    c = get_case("two-blocks")
    lower, upper = c["bodies"]
    for b in (lower, upper):
        b["material"]["rho"] = 0.1
    upper["mesh"].update(y0=1.0, y1=1.5)
    upper["dirichlet"] = [{"boundary": "top", "value": [0.0, f"-0.1*{SMOOTH_START}"]}]
    # the body force presses the bottom from the first step (the top's push arrives later)
    upper["body_force"] = [0.0, f"-5*{SMOOTH_START}"]
    c["time"] = {"type": "transient", "theta": theta, "t_end": t_end, "dt": dt}
    c["quantities"] = [
        {"name": "uy", "type": "point_displacement", "body": "upper", "point": [0.5, 1.0], "component": 1},
        {"name": "contact_upper", "type": "contact_profile", "body": "upper", "axis": 0.5, "prefix": "upper_"}]
    c["output"] = {"every": 0, "figures": False, "fields": False}
    return c


def test_temporal_order_with_contact_closed():
    """Displacements of both blocks and the contact force with θ = 0.5, contact closed in every
    step of every run (the same case counts throughout): order 2 (measured 1.96, 2.06 on the
    displacements, 1.88, 1.99 on the force; asserted ≥ 1.8)."""
    theta = 0.5

    def observe(sim: Simulation) -> dict[str, np.ndarray]:
        return {"displacements": np.concatenate([s.U.ravel() for s in sim.system.solids]),
                "contact force": sim.history[-1]["upper_contact_force_y"]}

    def case_counts(sim: Simulation) -> tuple[int, ...]:
        return tuple(sim.history[-1][f"case_{c}"] for c in ("I", "II", "III", "IV"))

    errors, seen = temporal_errors(pressed_blocks_case, theta, (0.05, 0.025, 0.0125), observe, case_counts)
    print({name: (e, rates_of(e)) for name, e in errors.items()}, "case counts", seen)
    assert len(seen) == 1 and next(iter(seen))[1] > 0  # the same points in contact in every step of every run
    check_order(errors, theta)
