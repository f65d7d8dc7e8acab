"""Runs and logs of a spatial chain (universal joints): simulate, its stops, the log and replay.

Checked against independent computations: a hand loop of the controller's RK4 step, the closed
forms of the closed loop (``e(t) = e(0) exp(-K t)``, ``s = s0 + v* t``, roll held), the geometry
of the line computed here with numpy, ``|cos b_j|`` from the joint angles, and the plain ``mcap``
reader for the log.
"""
import json
import struct
import warnings

import numpy as np
import pytest
from mcap.reader import make_reader

from coordarm.analysis.replay import load
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.run import BackendFallbackWarning, simulate
from coordarm.simulation.scenario import load_scenario
from coordarm.simulation.summary import summary_lines
from coordarm.symbolic import ConfigError, SingularityError
from coordarm.symbolic.curves3d import Circle3D, Line3D
from coordarm.symbolic.paths3d import Path3D
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController

LINKS, XI, K, SPEED, STEP = 12, 0.1, 2.0, 0.1, 0.005
DIRECTION, NORMAL = np.array([1.0, 0.2, -0.1]), np.array([0.0, 1.0, 0.3])


def line_frame():
    """The line's (t, n_1, n_2) computed here: unit direction, normal orthogonalised, t x n_1."""
    t = DIRECTION / np.linalg.norm(DIRECTION)
    n1 = NORMAL - (NORMAL @ t) * t
    n1 /= np.linalg.norm(n1)
    return t, n1, np.cross(t, n1)


@pytest.fixture(scope="module")
def setup():
    chain = SpatialChain(LINKS, XI)
    curve = Line3D((0.0, 0.0, 0.0), DIRECTION, NORMAL)
    q0 = chain.zigzag(1.0, DIRECTION, NORMAL, 0.3) + 0.02 * np.random.default_rng(0).standard_normal(2 * LINKS)
    return chain, curve, q0, SpatialController(chain, curve, K, SPEED, start=q0)


@pytest.fixture(scope="module")
def run(setup):
    _, _, q0, ctrl = setup
    return simulate(ctrl, q0, 0.5, STEP, backend="interpreted", chunk=37)


def test_the_run_holds_the_spatial_arrays(run):
    n = len(run.t)
    assert n == 101 and run.q.shape == (n, 2 * LINKS) and run.u.shape == (n, 2 * LINKS)
    assert run.e.shape == (n, 2 * (LINKS - 1)) and run.link_margins.shape == (n, LINKS - 1)
    assert run.joint_margins.shape == (n, LINKS) and run.s.shape == run.roll.shape == run.end_margin.shape == (n,)
    assert run.longitudinal is None and run.info["stopped"] == "completed"
    assert np.allclose(run.v_star, SPEED)
    assert run.array_names() == ("t", "q", "u", "e", "s", "roll", "link_margins", "end_margin", "joint_margins",
                                 "v_star", "roll_star")


def test_q_equals_a_hand_loop_of_the_rk4_step(setup, run):
    _, _, q0, ctrl = setup
    step = ctrl.rk4_step(STEP)
    q = np.array(q0, float)
    for k in range(len(run.t)):
        assert np.allclose(run.q[k], q, rtol=0, atol=1e-13), k
        q_next, u, e, *_ = step(q, run.t[k])
        assert np.allclose(run.u[k], np.asarray(u).ravel(), rtol=0, atol=1e-12)
        assert np.allclose(run.e[k], np.asarray(e).ravel(), rtol=0, atol=1e-13)
        q = np.asarray(q_next).ravel()


def test_outputs_are_the_geometry_of_the_line(setup, run):
    """e^j = (n_1.y^j, n_2.y^j) pairs in order e^2_1, e^2_2, e^3_1, ...; s = t.y^m; roll = atan2(n_2.d_1, n_1.d_1)."""
    chain = setup[0]
    t, n1, n2 = line_frame()
    for k in (0, 37, 100):
        y, d = chain.centres_np(run.q[k]), chain.directions_np(run.q[k])
        expected_e = np.column_stack([y[1:] @ n1, y[1:] @ n2]).ravel()
        assert np.allclose(run.e[k], expected_e, rtol=0, atol=1e-13)
        assert run.s[k] == pytest.approx(y[-1] @ t, abs=1e-13)
        assert run.roll[k] == pytest.approx(np.arctan2(d[0] @ n2, d[0] @ n1), abs=1e-13)
        assert np.allclose(run.joint_margins[k], np.abs(np.cos(run.q[k, 1::2])), rtol=0, atol=1e-14)


def test_the_closed_loop_is_the_law(run):
    decay = np.exp(-K * (run.t - run.t[0]))[:, None]
    assert np.abs(run.e[0]).max() > 5e-3
    assert np.max(np.abs(run.e - run.e[0] * decay)) < 1e-9
    assert np.max(np.abs(run.s - (run.s[0] + SPEED * (run.t - run.t[0])))) < 1e-9
    assert np.max(np.abs(run.roll - run.roll[0])) < 1e-9
    assert np.allclose(run.roll_star, run.roll[0], rtol=0, atol=1e-12)   # held at the start's roll


def test_auto_runs_the_same_closed_loop(setup, run):
    """``auto``: the compiled spatial law when it exists, else interpreted with the fallback warning."""
    _, _, q0, ctrl = setup
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BackendFallbackWarning)
        auto = simulate(ctrl, q0, 0.5, STEP, backend="auto")
    assert auto.info["backend"] in ("compiled", "interpreted")
    for name in run.array_names():
        assert np.allclose(getattr(auto, name), getattr(run, name), rtol=0, atol=1e-10), name


def rolling():
    """A zig-zag whose fold plane is commanded to roll at 2 rad/s: the joints' b_j grow towards 2 beta."""
    chain = SpatialChain(LINKS, XI)
    curve = Line3D((0.0, 0.0, 0.0), DIRECTION, NORMAL)
    return SpatialController(chain, curve, K, SPEED, roll=lambda t: 2.0 * t), chain.zigzag(1.0, DIRECTION, NORMAL)


def test_a_joint_margin_below_the_link_threshold_stops_the_run():
    ctrl, q0 = rolling()
    ref = simulate(ctrl, q0, 1.0, 0.01, backend="interpreted")
    cos_b = np.abs(np.cos(ref.q[:, 1::2]))               # |cos b_j| from the joint angles themselves
    thr = 0.5
    row = int(np.argmax(cos_b.min(axis=1) < thr))
    assert row > 0 and ref.link_margins[:row + 1].min() > thr and ref.end_margin[:row + 1].min() > 0.15
    with pytest.raises(SingularityError) as info:
        simulate(ctrl, q0, 1.0, 0.01, backend="interpreted", thresholds={"link": thr})
    err = info.value
    assert (err.kind, err.link, err.threshold) == ("joint", int(np.argmin(cos_b[row])) + 1, thr)
    assert err.time == pytest.approx(ref.t[row], abs=1e-12)
    assert err.margin == pytest.approx(cos_b[row].min(), abs=1e-12)
    assert "joint margin of joint" in str(err)
    assert err.run.t[-1] == err.time and np.array_equal(err.run.q, ref.q[:row + 1])


def test_the_end_margin_below_the_longitudinal_threshold_stops_the_run():
    ctrl, q0 = rolling()
    ref = simulate(ctrl, q0, 1.0, 0.01, backend="interpreted")
    thr = 0.5
    row = int(np.argmax(ref.end_margin < thr))
    assert row > 0 and ref.link_margins[:row + 1].min() > 0.02 and ref.joint_margins[:row + 1].min() > 0.02
    with pytest.raises(SingularityError) as info:
        simulate(ctrl, q0, 1.0, 0.01, backend="interpreted", thresholds={"longitudinal": thr})
    err = info.value
    assert (err.kind, err.link, err.threshold) == ("end", None, thr)
    assert err.time == pytest.approx(ref.t[row], abs=1e-12)
    assert err.margin == ref.end_margin[row]


def test_a_start_below_a_joint_threshold_is_refused():
    """A zig-zag folded out of the line's plane: |cos b_j| = |cos 2 beta| (j >= 2), |cos 2| = 0.416 < 0.5 < cos 1 (the links)."""
    chain = SpatialChain(LINKS, XI)
    q0 = chain.zigzag(1.0, (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    assert np.allclose(np.abs(np.cos(q0[3::2])), abs(np.cos(2.0)))
    ctrl = SpatialController(chain, Line3D((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), K, SPEED, start=q0)
    with pytest.raises(ConfigError, match=r"joint margin of joint 2 is 0\.416 < 0\.5"):
        simulate(ctrl, q0, 0.1, 0.01, backend="interpreted", thresholds={"link": 0.5})


def test_s_is_unwrapped_on_a_circle():
    """A circle through the base whose branch cut (opposite its reference) lies 2 cm ahead of the end point:
    s runs on past pi R (where psi jumps to -pi R), growing by v* h at every step, across chunks."""
    radius, speed = 0.5, 0.25
    chain = SpatialChain(4, XI)
    q0 = chain.zigzag(1.0, (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    end_angle = -np.pi / 2 + chain.centres_np(q0)[-1, 0] / radius      # the end point's angle about the centre
    cut = end_angle + 0.02 / radius
    reference = (np.cos(cut - np.pi), np.sin(cut - np.pi), 0.0)
    curve = Circle3D((0.0, radius, 0.0), radius, (0.0, 0.0, 1.0), reference=reference)
    ctrl = SpatialController(chain, curve, K, speed, start=q0)
    run = simulate(ctrl, q0, 0.4, 0.01, backend="interpreted", chunk=7)
    assert run.s[0] < np.pi * radius < run.s[-1] - 0.05
    assert np.allclose(np.diff(run.s), speed * 0.01, rtol=0, atol=1e-5)


def test_a_start_outside_a_paths_tube_is_refused():
    """A straight zig-zag past a banked arc of radius 0.1 m: the first centre 0.1 m or more from the path
    (brute force over dense samples of it) is named."""
    chain = SpatialChain(LINKS, XI)
    path = Path3D((0, 0, 0), (1, 0, 0), (0, 1, 0), [("line", 0.3), ("arc", np.pi / 2, 0.1, np.pi / 2)], transition=0)
    q0 = chain.zigzag(1.0, (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    points = path.sample(0.0, 20001, extent=1.0)
    y = chain.centres_np(q0)
    dist = np.min(np.linalg.norm(y[:, None, :] - points[None], axis=2), axis=1)
    j = int(np.argmax(dist >= path.tube_radius))
    assert path.tube_radius == 0.1 and j > 1
    ctrl = SpatialController(chain, path, K, SPEED, start=q0)
    with pytest.raises(ConfigError, match=rf"central point of link {j + 1} is {dist[j]:.3f}\d* m from the path"):
        simulate(ctrl, q0, 0.1, 0.01, backend="interpreted")


@pytest.fixture(scope="module")
def logged(setup, tmp_path_factory):
    """The run logged by a RunLogger at every step (the scenario metadata: the line3d preset with as many links;
    the controller is the fixture's own spatial one)."""
    _, _, q0, ctrl = setup
    scenario = load_scenario("line3d").with_overrides(links=LINKS, duration=0.5, step=STEP)
    path = tmp_path_factory.mktemp("spatial") / "spatial.mcap"
    with RunLogger(path, scenario, ctrl, chunk_size=8 * 1024, command=["test"]) as log:
        run = simulate(ctrl, q0, 0.5, STEP, backend="interpreted", chunk=37, on_chunk=log.on_chunk)
    return path, run, scenario


def test_replay_gives_back_the_run_bit_for_bit(logged):
    path, run, scenario = logged
    rep = load(path)
    assert rep.problems == [] and rep.recovered is False and rep.longitudinal is None
    for name in run.array_names():
        assert np.array_equal(getattr(rep, name), getattr(run, name)), name
    back = rep.to_run()
    assert back.array_names() == run.array_names()
    assert back.summary() == {**run.summary(), "steps": len(run.t) - 1}
    assert rep.outcome["status"] == "completed"
    lines = summary_lines(back, scenario)
    assert any(line.startswith("roll tracking") for line in lines)
    assert any(line.startswith("joint margin") for line in lines)


def test_the_plain_mcap_reader_sees_the_spatial_channels_and_metadata(logged):
    path, run, _ = logged
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        topics = {c.topic: c for c in summary.channels.values()}
        schemas = {s.id: s for s in summary.schemas.values()}
        # the 3-D scene (/scene, /tf, /tracking) is drawn; /margins/cond declared, off (no message)
        assert set(topics) == {"/joint_state", "/task_state", "/margins", "/margins/cond", "/scene", "/scene/fixed",
                               "/tf", "/tracking"}
        assert summary.statistics.channel_message_counts.get(topics["/margins/cond"].id, 0) == 0
        assert summary.statistics.channel_message_counts[topics["/scene/fixed"].id] == 1
        assert summary.statistics.channel_message_counts[topics["/scene"].id] > 0
        tracking = schemas[topics["/tracking"].schema_id].data.decode()
        assert [x.split()[1] for x in tracking.splitlines() if x and not x.startswith("#")] == [
            "t", "s", "s_target", "target_x", "target_y", "target_z", "max_abs_e", "min_link_margin", "norm_u",
            "roll", "roll_target", "log10_max_abs_e", "s_error", "log10_abs_s_error"]
        text = {t: schemas[c.schema_id].data.decode() for t, c in topics.items()
                if t in ("/joint_state", "/task_state", "/margins")}
        body = {t: "".join(x + "\n" for x in s.splitlines() if not x.startswith("#")) for t, s in text.items()}
        m, n = LINKS, 2 * LINKS
        assert body["/joint_state"] == f"float64 t\nfloat64[{n}] q\nfloat64[{n}] u\n"
        assert body["/task_state"] == (f"float64 t\nfloat64 s\nfloat64 v_star\nfloat64[{2 * (m - 1)}] e\n"
                                       "float64 roll\nfloat64 roll_star\n")
        assert body["/margins"] == (f"float64 t\nfloat64[{m - 1}] link_margins\nfloat64 end_margin\n"
                                    f"float64[{m}] joint_margins\n")
        assert "e^2_1, e^2_2, e^3_1" in text["/task_state"]
        meta = {r.name: dict(r.metadata) for r in reader.iter_metadata()}
        assert meta["run"]["chain_kind"] == "universal"
        assert json.loads(meta["outcome"]["status"]) == "completed"
        task = [msg for _, ch, msg in reader.iter_messages(topics=["/task_state"])]
    assert len(task) == len(run.t)
    k = 41
    values = struct.unpack(f"<4x{5 + 2 * (m - 1)}d", task[k].data)
    assert values[:3] == (run.t[k], run.s[k], run.v_star[k])
    assert np.array_equal(values[3:3 + 2 * (m - 1)], run.e[k])
    assert values[-2:] == (run.roll[k], run.roll_star[k])
    assert task[k].log_time == round(run.t[k] * 1e9)


def test_a_planar_log_has_no_chain_kind(tmp_path):
    scenario = load_scenario("line").with_overrides(links=4, duration=0.05)
    ctrl = scenario.controller()
    path = tmp_path / "planar.mcap"
    with RunLogger(path, scenario, ctrl, scene_rate=0, cond_rate=0) as log:
        simulate(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, backend="interpreted",
                 on_chunk=log.on_chunk)
    with open(path, "rb") as f:
        meta = {r.name: dict(r.metadata) for r in make_reader(f).iter_metadata()}
    assert "chain_kind" not in meta["run"]
    assert load(path).longitudinal is not None


def test_a_logged_stop_at_a_joint_margin_is_the_logs_outcome(tmp_path):
    from coordarm.simulation.outcome import explain

    ctrl, q0 = rolling()
    scenario = load_scenario("line3d").with_overrides(links=LINKS, duration=1.0, step=0.01)
    path = tmp_path / "stop.mcap"
    with pytest.raises(SingularityError) as info:
        with RunLogger(path, scenario, ctrl, cond_rate=10.0) as log:
            simulate(ctrl, q0, 1.0, 0.01, backend="interpreted", thresholds={"link": 0.5}, on_chunk=log.on_chunk)
    err = info.value
    rep = load(path)
    assert (rep.outcome["status"], rep.outcome["kind"], rep.outcome["link"]) == ("singularity", "joint", err.link)
    for name in err.run.array_names():
        assert np.array_equal(getattr(rep, name), getattr(err.run, name)), name
    assert len(rep.cond) == 1 + int(err.time / 0.1 + 1e-9) and np.all(np.isfinite(rep.cond)) and np.all(rep.cond >= 1)
    assert f"joint margin |cos b| of joint {err.link}" in explain(err)[0]
