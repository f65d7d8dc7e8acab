"""The numpy baseline of the benchmarks computes the same law as the controller."""
import importlib.util
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from coordarm.symbolic import CoordinatingController, Line, PlanarChain

_spec = importlib.util.spec_from_file_location(
    "numpy_dense", Path(__file__).resolve().parents[1] / "benchmarks" / "numpy_dense.py")
numpy_dense = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(numpy_dense)


@pytest.mark.parametrize("m", [2, 9, 40])
def test_numpy_dense_law_equals_the_controller_on_a_moving_line(m, rng):
    ctrl = CoordinatingController(PlanarChain(m, 0.1), Line(point=(lambda t: 0.02 * ca.sin(t), 0.01),
                                                            angle=lambda t: 0.6 * ca.sin(0.2 * t)), 2.0, 0.1)
    for _ in range(5):
        q = ctrl.chain.zigzag(rng.uniform(0.5, 1.4), rng.uniform(-0.5, 0.5)) + rng.normal(0, 0.15, m)
        t = rng.uniform(0, 10)
        u = numpy_dense.dense_law_line(q, 0.1, 2.0, 0.1, 0.6 * math.sin(0.2 * t), 0.12 * math.cos(0.2 * t),
                                       (0.02 * math.sin(t), 0.01), (0.02 * math.cos(t), 0.0))
        ref = ctrl.evaluate(q, t, "dense")["u"]
        assert np.linalg.norm(u - ref) <= 1e-10 * np.linalg.norm(ref)
