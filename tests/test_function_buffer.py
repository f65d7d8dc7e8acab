"""A CasADi Function called through a reused buffer against its plain call, bit for bit: mapped and unmapped,
several inputs and outputs, the geometry Function of a controller, the fallbacks (sparse outputs, other input
shapes), results that later calls leave alone, two threads at once and a pickled copy; a one-point Function
evaluated a block at a time (PointwiseFunction) against its map over all the points."""
from __future__ import annotations

import pickle
import threading

import casadi as ca
import numpy as np
import pytest

from coordarm.simulation.scenario import load_scenario
from coordarm.simulation.choices import presets
from coordarm.symbolic.function_buffer import BufferedFunction, PointwiseFunction


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


def mapped_call(function, n, *inputs):
    """``function.map(n)`` called as CasADi calls it (DM in, DM out)."""
    return plain(function.map(n) if n > 1 else function, *inputs)


@pytest.mark.parametrize("name", ["swing", "two"])
@pytest.mark.parametrize("n", [1, 2, 7, 255, 256, 257, 2000])
def test_a_pointwise_function_is_its_map_over_every_point_bit_for_bit(name, n, rng):
    """Blocks of 16 points (full, partial, one) and the padded last block give what one map over the n points
    gives, to the last bit, for one and two inputs and outputs of several rows."""
    function, shapes = _functions()[name]
    inputs = [rng.uniform(-3, 3, (rows, n)) for rows, _ in shapes]
    got = PointwiseFunction(function, block=16)(*inputs)
    want = mapped_call(function, n, *inputs)
    assert [g.shape for g in got] == [w.shape for w in want]
    for g, w in zip(got, want):
        assert g.tobytes() == np.ascontiguousarray(w).tobytes()


class Squared(ca.Callback):
    """A Python callback: an operation SX cannot hold (the expanded map calls it)."""

    def __init__(self):
        ca.Callback.__init__(self)
        self.construct("squared", {})

    def get_n_in(self):
        return 1

    def get_n_out(self):
        return 1

    def eval(self, args):
        return [args[0] ** 2]


def test_a_pointwise_function_of_a_python_callback_is_its_map(rng):
    """An MX Function calling a Python callback: its expanded map keeps the call, with the map's results."""
    callback = Squared()
    t = ca.MX.sym("t")
    function = ca.Function("called_back", [t], [callback(t) * 2 + ca.sin(t)])
    times = rng.uniform(0, 10, 37)
    got = PointwiseFunction(function, block=8)(times)[0]
    assert got.tobytes() == np.ascontiguousarray(mapped_call(function, 37, times[None])[0]).tobytes()
    assert PointwiseFunction(function, block=8)(np.empty(0))[0].shape == (1, 0)


@pytest.mark.parametrize("preset", presets())
def test_every_presets_commands_are_their_functions_map(preset):
    """``speeds`` (and a spatial chain's ``roll_targets``) at a chunk's 2000 step times and 1999 middles are the
    command Function mapped over them, bit for bit: the s reference and the log's ``v_star`` do not move."""
    ctrl = load_scenario(preset).controller()
    times = 0.3 + 0.001 * np.arange(2000)
    for points in (times, 0.5 * (times[1:] + times[:-1])):
        if hasattr(ctrl, "roll_targets"):
            pairs = [(ctrl.speeds, ctrl._command_function("speed")), (ctrl.roll_targets, ctrl._command_function("roll"))]
        else:
            pairs = [(ctrl.speeds, ctrl.task.mapped("speed", 1))]
        for evaluate, function in pairs:
            want = np.asarray(mapped_call(function, len(points), points[None])[0]).ravel()
            assert evaluate(points).tobytes() == want.tobytes()


def test_two_outputs_at_two_points_are_the_functions_own_and_a_big_function_is_mapped_unexpanded(rng):
    """``two_point_function`` keeps only two outputs' operations, with the Function's values bit for bit;
    a Function too big to expand (more than POINTWISE_EXPANDED / 256 operations a point) is mapped as it is."""
    from coordarm.symbolic.function_buffer import POINTWISE_EXPANDED, two_point_function
    y, t = ca.SX.sym("y", 2), ca.SX.sym("t")
    big = ca.sin(y[0] * t)
    for k in range(POINTWISE_EXPANDED // 256):          # enough operations a point not to be expanded
        big = ca.cos(big + k * y[1])
    f = ca.Function("f", [y, t], [big, ca.vertcat(y[0] * t, ca.exp(-y[1])), big * y[0]])
    two = two_point_function(f, 0, 1)
    assert two.n_instructions() < f.n_instructions() * 2
    pointwise = PointwiseFunction(two, block=64)
    assert not pointwise._evaluate.function.is_a("SXFunction")       # the map itself, not expanded
    a, b, times = rng.uniform(-1, 1, (2, 70)), rng.uniform(-1, 1, (2, 70)), rng.uniform(0, 2, 70)
    got = pointwise(a, b, times)
    want_a = mapped_call(f, 70, a, times[None])[0]
    want_b = mapped_call(f, 70, b, times[None])[1]
    assert got[0].tobytes() == np.ascontiguousarray(want_a).tobytes()
    assert got[1].tobytes() == np.ascontiguousarray(want_b).tobytes()
