"""The elastica behind benchmarks/elastic_gate/static_bound.py: small-load limit and grid order."""
import importlib.util

import numpy as np
import pytest
from conftest import REPO

spec = importlib.util.spec_from_file_location("static_bound", REPO / "benchmarks" / "elastic_gate" / "static_bound.py")
static_bound = importlib.util.module_from_spec(spec)
spec.loader.exec_module(static_bound)


def test_small_load_matches_beam_theory():
    # Water a thousand times lighter: deflections of a few hundredths of a mm, linear regime.
    dx, dy = static_bound.tip_displacement(0.14, 12e6, rho_f=1.0)
    linear = static_bound.linear_tip_deflection(0.14, 12e6, rho_f=1.0)
    assert dx == pytest.approx(linear, rel=1e-4)
    assert abs(dy) < 1e-3 * dx  # the tip rises by O(dx^2 / L)


def test_large_deflection_converges_at_second_order():
    tips = [np.array(static_bound.tip_displacement(0.14, 12e6, segments=n)) for n in (50, 100, 200)]
    coarse, fine = np.linalg.norm(tips[1] - tips[0]), np.linalg.norm(tips[2] - tips[1])
    assert np.log2(coarse / fine) == pytest.approx(2.0, abs=0.2)
    # Geometric stiffening: below small-deflection theory at the full load.
    assert tips[2][0] < static_bound.linear_tip_deflection(0.14, 12e6)
