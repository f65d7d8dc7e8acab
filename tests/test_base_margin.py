"""A robot on a rail whose path bends away from the rail's line: the base margin stops the run before |u| blows up."""
import numpy as np
import pytest

from coordarm.simulation import base_margin as bm
from coordarm.simulation.outcome import EXIT_CODES, explain, outcome_of
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import Scenario
from coordarm.symbolic.errors import BaseOffPathError, SingularityError

#: 12 links fed in by a rail along x; the path bends 45 degrees (fillet 1.5 m) at x = 1.5, within the rail's reach.
BEND = {"name": "bend", "chain": {"links": 12, "link_length": 0.1,
                                  "base": {"kind": "rail", "angle": 0.0, "limits": [-0.1, 8.0]}},
        "curve": {"kind": "waypoints", "points": [[-0.5, 0.0], [1.5, 0.0], [5.5, 4.0]], "radius": 1.5},
        "control": {"gain": 2.0, "speed": 0.25}, "start": {"kind": "follow", "beta": 1.1},
        "run": {"duration": 5.0, "step": 0.002}}
NOMINAL_U = 0.25      # |u| on the straight part: the rail feeds at v*, the joints rest


def _run(monkeypatch=None):
    sc = Scenario.from_dict(BEND)
    ctrl = sc.controller()
    try:
        return ctrl, simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, backend="interpreted",
                              thresholds=sc.thresholds), None
    except SingularityError as err:
        return ctrl, err.run, err


def test_the_base_margin_stops_the_run_before_u_passes_ten_times_nominal():
    ctrl, run, err = _run()
    assert isinstance(err, BaseOffPathError), err
    assert np.max(np.abs(run.u)) < 10 * NOMINAL_U
    tangent_point = 1.5 - 1.5 * np.tan(np.pi / 8)          # where the fillet leaves the rail's line
    assert err.d > tangent_point and err.offset > 0
    out = outcome_of(err, float(run.t[-1]))
    assert out["status"] == "base_off_path" and EXIT_CODES["base_off_path"] == 3
    what, advice = explain(err)
    assert "base" in what and "rail" in what and "chain.base.limits" in advice


def test_without_it_u_blows_up_while_every_other_margin_stays_healthy(monkeypatch):
    monkeypatch.setattr("coordarm.simulation.stepping.base_stop", lambda *a, **k: None)
    ctrl, run, err = _run()
    u = np.abs(run.u).max(1)
    assert u.max() > 10 * NOMINAL_U
    first = np.argmax(u > 10 * NOMINAL_U)
    assert run.link_margins[:first + 1].min() > 0.3 and run.longitudinal[:first + 1].min() > 0.15
    margin, _ = bm.base_margins(ctrl, run.t[:first + 1], run.q[:first + 1])
    assert margin[0] == pytest.approx(1.0) and margin[-1] < bm.BASE_THRESHOLD


def test_the_base_margin_is_the_ratio_of_finite_difference_sensitivities(rng):
    ctrl, run, _ = _run()
    chain, geo = ctrl.chain, ctrl.task.geometry
    for i in rng.choice(len(run.t), 5, replace=False):
        t, q = float(run.t[i]), run.q[i].copy()

        def phi2(dq):
            return float(geo(chain.centres_np(q + dq)[1], t)[0])

        eps = 1e-6
        link1 = np.zeros_like(q)
        link1[1], link1[2] = eps, -eps           # link 1 turns, link 2 keeps its direction
        link2 = np.zeros_like(q)
        link2[2] = eps                           # link 2 turns about its joint with link 1
        s1 = (phi2(link1) - phi2(-link1)) / (2 * eps)
        s2 = (phi2(link2) - phi2(-link2)) / (2 * eps)
        margin, offset = bm.base_margins(ctrl, run.t[i:i + 1], run.q[i:i + 1])
        assert margin[0] == pytest.approx(min(1.0, abs(s1) / abs(s2)), rel=1e-6, abs=1e-9)
        assert offset[0] == pytest.approx(abs(float(geo(chain.centres_np(q)[0], t)[0])), abs=1e-12)


def test_a_run_on_the_straight_part_is_never_stopped_by_it():
    spec = {**BEND, "curve": {"kind": "waypoints", "points": [[-0.5, 0.0], [9.0, 0.0], [12.0, 3.0]], "radius": 1.5}}
    sc = Scenario.from_dict(spec)
    ctrl = sc.controller()
    run = simulate(ctrl, sc.start(ctrl), 2.0, sc.step, backend="interpreted", thresholds=sc.thresholds)
    margin, offset = bm.base_margins(ctrl, run.t, run.q)
    np.testing.assert_allclose(margin, 1.0, atol=1e-9)
    assert offset.max() < 1e-12


def test_with_every_stop_off_the_base_margin_does_not_stop_either():
    from coordarm.analysis.report import NO_STOP
    sc = Scenario.from_dict(BEND)
    ctrl = sc.controller()
    try:
        run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, backend="interpreted", thresholds=NO_STOP)
    except SingularityError as err:       # only a non-finite margin stops such a run
        assert not isinstance(err, BaseOffPathError) or not np.isfinite(err.margin)
        run = err.run
    assert np.abs(run.u).max() > 10 * NOMINAL_U          # the blow-up shows, as the report wants


#: The same bend for a spatial chain (two-axis joints): the path climbs 45 degrees (towards +z) at x = 1.5.
BEND3D = {"name": "bend3d", "chain": {"links": 12, "link_length": 0.1, "joints": "universal",
                                      "base": {"kind": "rail", "direction": [1.0, 0.0, 0.0], "limits": [-0.1, 8.0]}},
          "curve": {"kind": "waypoints", "points": [[-0.5, 0.0, 0.0], [1.5, 0.0, 0.0], [5.5, 0.0, 4.0]], "radius": 1.5},
          "control": {"gain": 2.0, "speed": 0.25}, "start": {"kind": "follow", "beta": 0.6},
          "run": {"duration": 5.0, "step": 0.002}}
#: Bends up and to the side, fold angles 0.3 to 0.9, links of 0.05 and 0.1 m.
VARIANTS3D = [({}, {}), ({"points": [[-0.5, 0.0, 0.0], [1.5, 0.0, 0.0], [5.5, 4.0, 0.0]]}, {}),
              ({}, {"beta": 0.9, "links": 20, "link_length": 0.05}), ({"points": [[-0.5, 0.0, 0.0], [1.5, 0.0, 0.0],
                                                                                   [5.5, 4.0, 0.0]]}, {"beta": 0.3})]


def _spatial(curve: dict, other: dict) -> dict:
    chain = {**BEND3D["chain"], **{k: v for k, v in other.items() if k in ("links", "link_length")}}
    start = {**BEND3D["start"], **{k: v for k, v in other.items() if k == "beta"}}
    return {**BEND3D, "chain": chain, "curve": {**BEND3D["curve"], **curve}, "start": start,
            "run": {"duration": 8.0, "step": 0.002}}


def _run3d(spec, thresholds=None):
    sc = Scenario.from_dict(spec)
    ctrl = sc.controller()
    try:
        return ctrl, simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, backend="interpreted",
                              thresholds=sc.thresholds if thresholds is None else thresholds), None
    except SingularityError as err:
        return ctrl, err.run, err


@pytest.mark.parametrize("curve, other", VARIANTS3D)
def test_a_spatial_rail_whose_path_bends_away_is_stopped_before_u_passes_ten_times_nominal(curve, other):
    """Without the base margin these runs pass 10x the nominal |u| with the link margins above 0.6 (link 1
    turns towards the tangent, the roll held from it spins the body); with it they stop as base_off_path."""
    ctrl, run, err = _run3d(_spatial(curve, other))
    assert isinstance(err, BaseOffPathError) and err.spatial, err
    assert np.max(np.abs(run.u)) < 10 * NOMINAL_U
    assert "half of link 2's reach" in str(err) and err.offset > 0
    assert outcome_of(err, float(run.t[-1]))["status"] == "base_off_path"


def test_without_it_a_spatial_run_spins_while_the_link_margins_stay_healthy(monkeypatch):
    monkeypatch.setattr("coordarm.simulation.stepping.base_stop", lambda *a, **k: None)
    ctrl, run, err = _run3d(_spatial({}, {}), thresholds={"link": 0.0, "longitudinal": 0.0})
    u = np.abs(run.u).max(1)
    first = int(np.argmax(u > 10 * NOMINAL_U))
    assert first > 0 and run.link_margins[:first + 1].min() > 0.8
    margin, offset = bm.base_margins(ctrl, run.t[:first + 1], run.q[:first + 1])
    assert margin[0] == 1.0 and offset[0] == 0.0 and margin[-1] < bm.BASE_THRESHOLD


def test_the_spatial_base_margin_is_the_offset_against_link_twos_reach_by_independent_geometry(rng):
    """The base's distance from the path by a bounded search along the path's own points (not its closest-point
    coordinates), the tangent at link 2's centre by central differences of those points."""
    from scipy.optimize import minimize_scalar

    ctrl, run, _ = _run3d(_spatial({}, {}), thresholds={"link": 0.0, "longitudinal": 0.0, "base": 0.0})
    chain, path = ctrl.chain, ctrl.curve
    rows = np.r_[0, rng.choice(len(run.t), 6, replace=False), len(run.t) - 1]

    def closest(y):
        grid = np.linspace(0.0, 6.0, 6001)
        k = int(np.argmin([np.linalg.norm(path.point_at(s) - y) for s in grid]))
        best = minimize_scalar(lambda s: np.linalg.norm(path.point_at(s) - y), bounds=(grid[max(k - 1, 0)], grid[k + 1]),
                               method="bounded", options={"xatol": 1e-12})
        return best.x, best.fun

    for i in rows:
        y, d = chain.centres_np(run.q[i]), chain.directions_np(run.q[i])
        _, offset = closest(y[0])
        s2, _ = closest(y[1])
        h = 1e-6
        tangent = (path.point_at(s2 + h) - path.point_at(s2 - h)) / (2 * h)
        tangent /= np.linalg.norm(tangent)
        across = np.linalg.norm(d[1] - (d[1] @ tangent) * tangent)
        margin, got = bm.base_margins(ctrl, run.t[i:i + 1], run.q[i:i + 1])
        assert got[0] == pytest.approx(offset, abs=1e-8)
        assert margin[0] == pytest.approx(max(0.0, 1 - offset / (0.5 * chain.xi * across)), abs=1e-6)


def test_spatial_rail_presets_keep_their_base_on_the_path():
    """pipe3d and port feed the body from a rail inside the path's first straight part: margin 1 throughout."""
    from coordarm.simulation.scenario import load_scenario

    for name in ("pipe3d", "port"):
        sc = load_scenario(name).with_overrides(None, 2.0, None)
        ctrl = sc.controller()
        run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, backend="compiled", thresholds=sc.thresholds)
        margin, offset = bm.base_margins(ctrl, run.t, run.q)
        assert np.all(margin == 1.0) and np.all(offset < 1e-12), name


def test_a_spatial_rail_beside_the_path_is_not_stopped_though_its_margin_is_low():
    """A rail parallel to the path, 0.02 m beside it: the base margin is about 0.3 (below the threshold) all
    run, but the base does not leave the path, the body settles (joint rates to 0, deviations decaying like
    exp(-K t)) and the run completes; its last row, the final state alone, is not taken as leaving."""
    spec = {**BEND3D, "curve": {"kind": "line", "point": [0.0, 0.0, 0.02], "direction": [1.0, 0.0, 0.0],
                                "normal": [0.0, 1.0, 0.0]},
            "start": {"kind": "zigzag", "beta": 0.6}, "run": {"duration": 6.0, "step": 0.002}}
    ctrl, run, err = _run3d(spec)
    assert err is None and run.t[-1] == pytest.approx(6.0)
    margin, offset = bm.base_margins(ctrl, run.t, run.q)
    assert margin.max() < bm.BASE_THRESHOLD and np.ptp(offset) < 1e-12
    assert np.abs(run.u[-1, 1:]).max() < 1e-3 and np.abs(run.e[-1]).max() < 1e-6


@pytest.mark.parametrize("preset", ["thread", "pipe", "pipe3d", "port"])
def test_the_base_geometry_is_the_curves_geometry_at_the_two_centres_bit_for_bit(preset, rng):
    """The task's two-output evaluation (``base_geometry``) gives the geometry Function's own outputs: its
    distance output at ``y^1`` and its gradient output at ``y^2`` (planar ``grad phi``, spatial ``grad psi``), at
    states around the start, as the Function's ``map`` over every row gives them."""
    from coordarm.simulation.scenario import load_scenario
    ctrl = load_scenario(preset).controller()
    chain = ctrl.chain
    q0 = load_scenario(preset).start(ctrl)
    q = q0 + rng.normal(0, 0.01, (300, len(q0)))
    t = np.linspace(0.0, 5.0, 300)
    y = chain.centres_np(q)
    got_1, got_2 = bm._geometry_at_base(ctrl, y, t)
    whole = ctrl.task.geometry.map(len(t))
    gradient = 1 if y.shape[2] == 2 else 4
    want_1 = np.asarray(whole(y[:, 0, :].T, t[None, :])[0])
    want_2 = np.asarray(whole(y[:, 1, :].T, t[None, :])[gradient])
    assert got_1.tobytes() == np.ascontiguousarray(want_1).tobytes()
    assert got_2.tobytes() == np.ascontiguousarray(want_2).tobytes()
