"""A CasADi Function called through a reused buffer against its plain call, bit for bit: mapped and unmapped,
several inputs and outputs, the geometry Function of a controller, the fallbacks (sparse outputs, other input
shapes), results that later calls leave alone, two threads at once and a pickled copy."""
from __future__ import annotations

import pickle
import threading

import casadi as ca
import numpy as np
import pytest

from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic.function_buffer import BufferedFunction


def plain(function, *inputs):
    return [np.asarray(v) for v in function.call([ca.DM(np.asarray(x, float)) for x in inputs])]


def assert_same(got, want):
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert g.shape == w.shape and g.flags.c_contiguous
        assert g.tobytes() == w.tobytes()


def _functions():
    t, y = ca.SX.sym("t"), ca.SX.sym("y", 2)
    swing = ca.Function("swing", [t], [0.012 + 0.6 * ca.sin(0.2 * t), 0 * t, ca.exp(-t) * ca.cos(3 * t)])
    two = ca.Function("two", [y, t], [ca.atan2(y[1], y[0]) * t, ca.vertcat(y[0] * t, ca.sqrt(y[1] ** 2 + t))])
    return {"swing": (swing, [(1, 1)]), "swing map 40": (swing.map(40), [(1, 40)]),
            "two": (two, [(2, 1), (1, 1)]), "two map 7": (two.map(7), [(2, 7), (1, 7)])}


@pytest.mark.parametrize("name", list(_functions()))
def test_a_buffered_call_is_the_plain_call_bit_for_bit(name, rng):
    function, shapes = _functions()[name]
    buffered = BufferedFunction(function)
    assert buffered.buffered
    first = None
    for _ in range(5):
        inputs = [rng.uniform(-5.0, 5.0, shape) for shape in shapes]
        got = buffered(*inputs)
        assert_same(got, plain(function, *inputs))
        first = first or ([g.copy() for g in got], got)
    assert all(a.tobytes() == b.tobytes() for a, b in zip(*first))      # later calls left the results alone


def test_the_controllers_geometry_through_its_buffer_is_its_plain_call(rng):
    sc = load_scenario("thread").with_overrides(links=8)
    ctrl = sc.controller()
    for n in (8, 16):
        y, t = rng.uniform(-1.0, 1.0, (2, n)), rng.uniform(0.0, 9.0, (1, n))
        assert_same(ctrl.task.buffered("geometry", n)(y, t), plain(ctrl.task.mapped("geometry", n), y, t))
    assert ctrl.task.buffered("speed", 3) is ctrl.task.buffered("speed", 3)


def test_sparse_outputs_and_other_input_shapes_take_the_plain_call():
    t = ca.SX.sym("t")
    sparse = ca.Function("sparse", [t], [ca.sin(t), ca.SX(1, 1)])
    assert not BufferedFunction(sparse).buffered
    assert_same(BufferedFunction(sparse)(np.array([[0.3]])), plain(sparse, np.array([[0.3]])))
    swing, _ = _functions()["swing map 40"]
    times = np.linspace(0.0, 1.0, 40)
    assert_same(BufferedFunction(swing)(times[:, None]), plain(swing, times[:, None]))    # a column: as CasADi takes it


def test_two_threads_each_get_their_own_results():
    function, _ = _functions()["swing map 40"]
    buffered = BufferedFunction(function)
    inputs = [np.linspace(k, k + 1.0, 40)[None, :] for k in range(2)]
    want = [plain(function, x) for x in inputs]
    bad = []

    def work(k):
        for _ in range(300):
            got = buffered(inputs[k])
            if any(g.tobytes() != w.tobytes() for g, w in zip(got, want[k])):
                bad.append(k)
    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert not bad


def test_a_pickled_copy_calls_like_the_original():
    function, _ = _functions()["two map 7"]
    buffered = BufferedFunction(function)
    y, t = np.ones((2, 7)), np.full((1, 7), 0.5)
    buffered(y, t)
    copy = pickle.loads(pickle.dumps(buffered))
    assert_same(copy(y, t), plain(function, y, t))
