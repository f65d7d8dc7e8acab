"""Objects made once per key (symbolic.lazy.made_once): a curve's CasADi Functions are built once and shared by
the start and the task, without keeping the curve alive, and give what a new build gives."""
import gc
import weakref

import numpy as np

from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic.curves3d import Line3D
from coordarm.symbolic.lazy import made_once
from coordarm.symbolic.spatial_task import spatial_geometry_function


def test_made_once_makes_once_per_key_and_forgets_a_dead_key():
    cache, made = weakref.WeakKeyDictionary(), []

    class Key:
        pass

    def make():
        made.append(object())
        return made[-1]

    a, b = Key(), Key()
    assert made_once(cache, a, make) is made_once(cache, a, make) is made[0]
    assert made_once(cache, b, make) is made[1] and len(made) == 2
    del a
    gc.collect()
    assert len(cache) == 1
    assert made_once(cache, [1, 2], make) is not made_once(cache, [1, 2], make)   # unhashable: made each time


def test_a_curves_functions_are_built_once_and_equal_a_new_build():
    line = Line3D([0.1, 0.0, 0.0], [1.0, 0.2, 0.0], [0.0, 0.0, 1.0])
    f, g = spatial_geometry_function(line), line.functions()
    assert spatial_geometry_function(line) is f and line.functions() is g
    other = Line3D([0.1, 0.0, 0.0], [1.0, 0.2, 0.0], [0.0, 0.0, 1.0])
    assert spatial_geometry_function(other) is not f
    y, t = np.array([0.3, -0.2, 0.5]), 0.7
    for a, b in zip(f(y, t), spatial_geometry_function(other)(y, t)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_the_start_and_the_task_share_the_paths_geometry():
    scenario = load_scenario("path3d")
    ctrl = scenario.controller()                         # the start is placed with the curve's geometry
    assert ctrl.task.geometry is spatial_geometry_function(ctrl.curve)
