"""Built-in cases against their reference values (tolerances stated per test)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fsci.cases import get_case
from fsci.cli import main
from fsci.config import apply_override, problem_from_dict
from fsci.simulation import Simulation

# Ghia, Ghia & Shin (1982) u(0.5, y) for Re = 100 (selected points)
GHIA_RE100_U = {0.0547: -0.03717, 0.1016: -0.06434, 0.2813: -0.15662, 0.5: -0.20581, 0.7344: 0.00332,
                0.8516: 0.23151, 0.9531: 0.68717}


def _run(name, overrides, out=None):
    case = get_case(name)
    for o in overrides:
        apply_override(case, o)
    sim = Simulation(problem_from_dict(case), out)
    return sim.run()


def test_turek_hron_csm1_within_one_percent(tmp_path):
    """CSM1 tip displacement within 1 % of FeatFlow (level 5+1) on a 320×16 mesh."""
    out = tmp_path / "csm1"
    assert main(["run", "turek-hron-csm1", "--set", "nx=320", "--set", "ny=16", "--out", str(out)]) == 0
    res = json.loads((out / "results.json").read_text())
    assert abs(res["ux_A"] / -7.18767e-3 - 1) < 0.01
    assert abs(res["uy_A"] / -66.1023e-3 - 1) < 0.01
    assert all(c["pass"] for c in res["reference_checks"])


def test_turek_hron_csm3_period_within_two_percent():
    """CSM3 oscillation frequency of uy(A) within 2 % of 1.0995 Hz (160×8, dt = 0.01)."""
    res = _run("turek-hron-csm3", ["nx=160", "ny=8", "time.dt=0.01", "time.t_end=2.5"])
    assert abs(res["uy_A_osc_frequency"] / 1.0995 - 1) < 0.02
    # the mean deflection is close to the static CSM1 value, the amplitude to the reference
    assert abs(res["uy_A_osc_mean"] / -63.607e-3 - 1) < 0.05


@pytest.mark.parametrize("re, ref, tol", [(100, (0.6172, 0.7344), 0.01), (1000, (0.5308, 0.5652), 0.01)])
def test_cavity_vortex_centre(tmp_path, re, ref, tol):
    """Primary vortex centre within 1 % of Ghia et al. (Re 100) / Botella-Peyret (Re 1000) on 64²."""
    out = tmp_path / f"cavity{re}"
    assert main(["run", "cavity", "--set", f"re={re}", "--out", str(out)]) == 0
    res = json.loads((out / "results.json").read_text())
    assert abs(res["vortex_x"] - ref[0]) < tol * ref[0]
    assert abs(res["vortex_y"] - ref[1]) < tol * ref[1]
    prof = np.genfromtxt(out / "profiles.csv", delimiter=",", names=True)
    assert len(prof) == 65
    if re == 100:
        for y, u in GHIA_RE100_U.items():
            ui = np.interp(y, prof["y"], prof["u_at_x_center"])
            assert abs(ui - u) < 0.01, (y, ui, u)
