"""Scenario files of spatial chains ([chain] joints = "universal"): keys, defaults, errors, starts and the presets."""
import json
import math
import tomllib
from importlib import resources

import numpy as np
import pytest

import coordarm
from coordarm.simulation.scenario import Scenario, load_scenario, presets
from coordarm.symbolic import ConfigError, SpatialChain, SpatialController
from coordarm.symbolic.params import evaluate

#: The issue's example: the planar ``line`` preset stated in 3-D.
PLANAR_LINE_IN_3D = """
[chain]
links = 64
link_length = 0.1
joints = "universal"
[curve]
kind = "line"
point = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
rotation = { axis = [0.0, 0.0, 1.0], angle = [0.012, { kind = "sinusoid", amplitude = 0.6, omega = 0.2 }] }
[control]
gain = 2.0
speed = 0.1
[start]
kind = "zigzag"
beta = 1.3
axis = [1.0, 0.0, 0.0]
fold = [0.0, 1.0, 0.0]
roll = 0.0
[run]
duration = 20.0
step = 0.001
"""

SPATIAL = ["line3d", "path3d"]


def preset_data(name):
    return tomllib.loads((resources.files("coordarm.simulation") / "presets" / f"{name}.toml").read_text())


def spatial(**tables):
    """A small universal-chain scenario (a static line along x) with some tables replaced or extended."""
    data = {"chain": {"links": 6, "link_length": 0.1, "joints": "universal"},
            "curve": {"kind": "line", "point": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, 0.0],
                      "normal": [0.0, 1.0, 0.0]},
            "control": {"gain": 2.0, "speed": 0.1}, "start": {"kind": "zigzag", "beta": 0.6}}
    for sec, table in tables.items():
        data[sec] = table if sec == "curve" or not isinstance(table, dict) else {**data.get(sec, {}), **table}
    return data


def written(tmp_path, data_text, name="s.toml"):
    path = tmp_path / name
    path.write_text(data_text)
    return path


def rotated(v, axis, angle):
    """Rodrigues' formula, written out here (independent of the code under test)."""
    v, k = np.asarray(v, float), np.asarray(axis, float) / np.linalg.norm(axis)
    return v * math.cos(angle) + np.cross(k, v) * math.sin(angle) + k * np.dot(k, v) * (1 - math.cos(angle))


# ------------------------------------------------------------------------------------------------ keys
def test_the_spatial_presets_are_listed_and_load():
    assert set(SPATIAL) <= set(presets()) and presets() == coordarm.presets()
    for name in SPATIAL:
        sc = coordarm.load_scenario(name)
        assert sc.universal and sc.config.chain.joints == "universal" and sc.spec["description"]
        assert isinstance(sc.chain(), SpatialChain) and sc.chain().dof == 2 * sc.config.chain.links


@pytest.mark.parametrize("name", SPATIAL)
def test_typed_tables_hold_the_keys_of_the_file(name):
    data, config = preset_data(name), load_scenario(name).config
    ch, ctl, st = data["chain"], data["control"], data["start"]
    assert (config.chain.links, config.chain.link_length, config.chain.joints, config.chain.joint_limit) == (
        ch["links"], ch["link_length"], ch["joints"], ch["joint_limit"])
    assert config.curve == data["curve"]
    assert (config.control.gain, config.control.speed, config.control.roll) == (ctl["gain"], ctl["speed"], ctl.get("roll"))
    assert (config.start.kind, config.start.beta) == (st["kind"], st["beta"])
    assert (config.start.axis, config.start.fold, config.start.roll) == (st.get("axis"), st.get("fold"), st.get("roll"))
    assert (config.run.duration, config.run.step) == (data["run"]["duration"], data["run"]["step"])
    spec = load_scenario(name).spec
    assert spec["chain"]["joints"] == "universal" and "heading" not in spec["start"]
    assert {k: spec["start"][k] for k in st} == st and {k: spec["control"][k] for k in ctl} == ctl


@pytest.mark.parametrize("name", SPATIAL)
def test_a_spatial_scenario_round_trips_through_its_json(name):
    sc = load_scenario(name)
    again = Scenario.from_dict(json.loads(sc.to_json()), "<log>")
    assert again.spec == sc.spec and again.to_json() == sc.to_json()


@pytest.mark.parametrize("name", ["line", "arc", "hole", "pipe", "thread"])
def test_planar_specs_gain_no_keys(name):
    spec, data = load_scenario(name).spec, preset_data(name)
    assert set(spec["chain"]) == set(data["chain"]) and "joints" not in spec["chain"]
    assert "roll" not in spec["control"] and set(spec["start"]) == {"kind", "beta", "heading"} | set(data.get("start", {}))
    assert not load_scenario(name).universal


# ---------------------------------------------------------------------------------------------- errors
@pytest.mark.parametrize("tables, field", [
    ({"chain": {"joints": "ball"}}, "chain.joints"),
    ({"chain": {"joints": 2}}, "chain.joints"),
    ({"curve": {"kind": "line", "point": [0.0, 0.0], "angle": 0.3}}, "curve.angle"),
    ({"curve": {"kind": "path", "start": [0.0, 0.0], "heading": 0.0, "segments": [{"line": 1.0}]}}, "curve.heading"),
    ({"curve": {"kind": "circle", "center": [0.0, 1.0], "radius": 1.0}}, "curve.center"),
    ({"curve": {"kind": "line", "point": [0.0, 0.0], "direction": [1.0, 0.0, 0.0], "normal": [0.0, 1.0, 0.0]}},
     "curve.point"),
    ({"curve": {"kind": "line", "point": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, 0.0], "normal": [0.0, 1.0, 0.0],
                "rotation": 0.3}}, "curve.rotation"),
    ({"control": {"governor": True}}, "control.governor"),
    ({"control": {"damping": {"kind": "dls"}}}, "control.damping"),
    ({"control": {"span": 1.0}}, "control.span"),
    ({"control": {"roll": "x"}}, "control.roll"),
    ({"control": {"law": "sparse"}}, "control.law"),
    ({"chain": {"clearance": -0.01}}, "chain.clearance"),
    ({"chain": {"radius": 0.0}}, "chain.radius"),
    ({"chain": {"base": {"kind": "rail", "angle": 0.0}}}, "chain.base"),
    ({"chain": {"base": {"kind": "rail", "direction": [0.0, 0.0, 0.0]}}}, "chain.base.direction"),
    ({"chain": {"base": {"kind": "rail", "limits": [1.0, 0.0]}}}, "chain.base.limits"),
    ({"chain": {"joint_limit": 4.0}}, "chain.joint_limit"),
    ({"start": {"kind": "projected"}}, "start.kind"),
    ({"start": {"heading": 0.2}}, "start.heading"),
    ({"start": {"axis": [0.0, 0.0, 0.0]}}, "start.axis"),
    ({"start": {"fold": [1.0, "y", 0.0]}}, "start.fold"),
    ({"start": {"roll": math.inf}}, "start.roll"),
    ({"start": {"beta": 1.6}}, "start.beta"),
    ({"obstacles": [{"center": [1.0, 1.0], "radius": 0.1}]}, "obstacles[0].kind"),
])
def test_a_bad_spatial_key_is_an_error_naming_the_file_and_field(tables, field):
    with pytest.raises(ConfigError) as err:
        Scenario.from_dict(spatial(**tables), "bad.toml")
    assert str(err.value).startswith(f"bad.toml: {field}"), str(err.value)


def test_a_bad_key_in_a_spatial_file_names_the_file(tmp_path):
    path = written(tmp_path, PLANAR_LINE_IN_3D.replace('joints = "universal"', 'joints = "ball"'))
    with pytest.raises(ConfigError, match=r"^.*s\.toml: chain\.joints: expected one of \['revolute', 'universal'\]"):
        load_scenario(path)
    path = written(tmp_path, PLANAR_LINE_IN_3D.replace('normal = [0.0, 1.0, 0.0]\n', 'angle = 0.3\n'))
    with pytest.raises(ConfigError, match=r"s\.toml: curve\.angle: a planar curve key"):
        load_scenario(path)


@pytest.mark.parametrize("tables, field", [
    ({"curve": {"kind": "line", "point": [0.0, 0.0], "direction": [1.0, 0.0, 0.0]}}, "curve.direction"),
    ({"curve": {"kind": "path", "start": [0.0, 0.0], "heading": 0.0,
                "segments": [{"line": 1.0}, {"arc": 0.5, "radius": 1.0, "bank": 0.3}]}}, "curve.segments.bank"),
    ({"control": {"roll": 0.3}}, "control.roll"),
    ({"start": {"axis": [1.0, 0.0, 0.0]}}, "start.axis"),
    ({"start": {"fold": [0.0, 1.0, 0.0]}}, "start.fold"),
    ({"start": {"roll": 0.2}}, "start.roll"),
])
def test_a_spatial_key_in_a_planar_scenario_is_an_error_naming_the_field(tables, field):
    data = preset_data("line")
    for sec, table in tables.items():
        data[sec] = table if sec == "curve" else {**data[sec], **table}
    with pytest.raises(ConfigError) as err:
        Scenario.from_dict(data, "planar.toml")
    assert str(err.value).startswith(f"planar.toml: {field}"), str(err.value)


def test_a_fold_parallel_to_the_axis_and_a_bend_beyond_the_limit_are_named():
    sc = Scenario.from_dict(spatial(start={"axis": [1.0, 0.0, 0.0], "fold": [2.0, 0.0, 0.0]}, control={"roll": 0.0}))
    with pytest.raises(ConfigError, match="start.fold: must not be parallel"):
        sc.start()
    sc = Scenario.from_dict(spatial(chain={"joint_limit": 1.0}, start={"beta": 0.6}, control={"roll": 0.0}))
    with pytest.raises(ConfigError, match=r"start: joint 2 \(between links 1 and 2\) bends by 1.200 rad"):
        sc.start()


# -------------------------------------------------------------------------------------------- defaults
def test_defaults_zigzag_along_the_curve_frame_and_roll_held_at_the_start():
    u, n = np.array([1.0, 1.0, 0.0]) / math.sqrt(2), np.array([0.0, 0.0, 1.0])
    beta, roll = 0.5, 0.3
    sc = Scenario.from_dict(spatial(curve={"kind": "line", "point": [0.0, 0.0, 0.0], "direction": list(u),
                                           "normal": list(n)}, start={"kind": "zigzag", "beta": beta, "roll": roll}))
    cfg = sc.config
    assert (cfg.start.axis, cfg.start.fold, cfg.control.roll, cfg.control.law) == (None, None, None, "structured")
    assert sc.physical().limit == 2.8 and sc.spec["start"] == {"kind": "zigzag", "beta": beta, "roll": roll}
    ctrl = sc.controller()
    assert isinstance(ctrl, SpatialController)
    q0 = sc.start(ctrl)
    assert q0.shape == (12,)
    fold = rotated(n, u, roll)
    want = np.array([math.cos(beta) * u + (-1) ** j * math.sin(beta) * fold for j in range(6)])
    np.testing.assert_allclose(ctrl.chain.directions_np(q0), want, atol=1e-14)
    assert abs(evaluate(ctrl.roll_target, 5.0) - roll) < 1e-14           # held at the start's roll
    assert abs(ctrl.evaluate(q0, 0.0)["roll"] - roll) < 1e-14
    data = spatial()
    del data["start"]
    default = Scenario.from_dict(data).config.start
    assert (default.kind, default.beta, default.axis, default.fold, default.roll) == ("zigzag", 1.3, None, None, None)


def test_a_commanded_roll_is_the_controllers_target():
    motion = {"kind": "smoothstep", "start": 0.0, "end": 0.4, "t0": 1.0, "t1": 8.0}
    ctrl = Scenario.from_dict(spatial(control={"roll": motion})).controller()
    for t in (0.0, 1.0, 4.5, 8.0, 9.0):
        x = min(max((t - 1.0) / 7.0, 0.0), 1.0)
        assert abs(evaluate(ctrl.roll_target, t) - 0.4 * x * x * (3 - 2 * x)) < 1e-14


def test_the_dense_law_is_allowed_and_agrees():
    sc = load_scenario("line3d").with_overrides(links=8)
    dense = sc.with_overrides(law="dense")
    c1, c2 = sc.controller(), dense.controller()
    q0 = sc.start(c1)
    assert c2.law_form == "dense"
    np.testing.assert_allclose(c1.evaluate(q0, 0.3)["u"], c2.evaluate(q0, 0.3)["u"], rtol=1e-10, atol=1e-12)
    with pytest.raises(ConfigError, match="control.governor"):
        sc.with_overrides(governor=True)


def test_bend_limits_report_the_joint_bent_too_far():
    sc = Scenario.from_dict(spatial(chain={"joint_limit": 1.0}, control={"roll": 0.0}))
    chain = sc.chain()
    q = np.zeros(12)
    q[4:6] = 0.9, 0.6                                          # joint 3: Rz(0.9) Ry(0.6): cos(bend) = cos 0.9 cos 0.6
    contacts = sc.physical(chain).check(np.array([0.0, 1.0]), np.stack([np.zeros(12), q]))
    assert [(c.kind, c.time, c.links, c.threshold) for c in contacts] == [("joint_limit", 1.0, (2, 3), 1.0)]
    assert abs(contacts[0].value - math.acos(math.cos(0.9) * math.cos(0.6))) < 1e-14
    assert sc.physical(chain).clearances(q[None], np.array([0.0])) == {}


# ---------------------------------------------------------------------------------------------- starts
def test_follow_on_a_straight_line_is_the_uniform_zigzag():
    zig = Scenario.from_dict(spatial(start={"kind": "zigzag", "beta": 0.6, "roll": 0.4}, control={"roll": 0.0}))
    fol = Scenario.from_dict(spatial(start={"kind": "follow", "beta": 0.6, "roll": 0.4}, control={"roll": 0.0}))
    np.testing.assert_allclose(fol.start(), zig.start(), atol=1e-12)


def test_follow_lays_every_centre_on_a_3d_path_going_forward():
    sc = load_scenario("path3d")
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    y, f = ctrl.chain.centres_np(q0), ctrl.curve.functions()
    vals = [f(p, sc.t0) for p in y]
    assert max(float(np.max(np.abs(np.asarray(v[1])))) for v in vals[1:]) < 1e-9
    assert np.all(np.diff([float(v[0]) for v in vals]) > 0)
    d = ctrl.chain.directions_np(q0)
    bends = np.degrees(np.arccos(np.clip(np.sum(d[:-1] * d[1:], axis=1), -1, 1)))
    assert bends.max() <= np.degrees(1.4)
    # the fold side alternates: consecutive links lie on opposite sides of the local tangent
    tangents = [np.asarray(f(y[j] + 0.5 * ctrl.chain.xi * d[j], sc.t0)[2]).ravel() for j in range(len(d) - 1)]
    side = [np.dot(np.cross(t, d[j]), np.cross(t, d[j + 1])) for j, t in enumerate(tangents)]
    assert max(side) < 0


def test_follow_on_a_planar_path_in_3d_is_the_planar_follow():
    planar = Scenario.from_dict({"chain": {"links": 30, "link_length": 0.05},
                                 "curve": {"kind": "path", "start": [-0.2, 0.0], "heading": 0.0,
                                           "segments": [{"line": 0.5}, {"arc": 0.8, "radius": 1.0}, {"line": 1.0}]},
                                 "control": {"gain": 2.0}, "start": {"kind": "follow", "beta": 0.6}})
    space = Scenario.from_dict(spatial(chain={"links": 30, "link_length": 0.05},
                                       curve={"kind": "path", "start": [-0.2, 0.0, 0.0], "direction": [1.0, 0.0, 0.0],
                                              "normal": [0.0, 1.0, 0.0],
                                              "segments": [{"line": 0.5}, {"arc": 0.8, "radius": 1.0, "bank": 0.0},
                                                           {"line": 1.0}]},
                                       start={"kind": "follow", "beta": 0.6}))
    q2, q3 = planar.start(), space.start()
    np.testing.assert_allclose(q3[0::2], q2, atol=1e-9)
    np.testing.assert_allclose(q3[1::2], 0.0, atol=1e-12)


# ------------------------------------------------------------------------------------ runs of the law
def closed_loop(sc, steps, every=50):
    """``steps`` interpreted RK4 steps of the scenario's law: (times, evaluations) every ``every`` steps."""
    ctrl = sc.controller()
    q, t = sc.start(ctrl), sc.t0
    f = ctrl.rk4_step(sc.step)
    times, evs = [t], [ctrl.evaluate(q, t)]
    for k in range(1, steps + 1):
        q = np.asarray(f(q, t)[0]).ravel()
        t = sc.t0 + k * sc.step
        if k % every == 0:
            times.append(t)
            evs.append(ctrl.evaluate(q, t))
    return ctrl, q, np.array(times), evs


def test_the_planar_line_in_3d_runs_as_the_planar_line():
    space = Scenario.from_dict(tomllib.loads(PLANAR_LINE_IN_3D), "example.toml")
    planar = load_scenario("line")
    c3, c2 = space.controller(), planar.controller()
    q3, q2 = space.start(c3), planar.start(c2)
    np.testing.assert_array_equal(q3[0::2], q2)
    f3, f2 = c3.rk4_step(space.step), c2.rk4_step(planar.step)
    for k in range(200):
        t = k * space.step
        q3, q2 = np.asarray(f3(q3, t)[0]).ravel(), np.asarray(f2(q2, t)[0]).ravel()
    np.testing.assert_allclose(q3[0::2], q2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(q3[1::2], 0.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name, steps", [("line3d", 400), ("path3d", 300)])
def test_each_spatial_preset_is_valid_and_tracks(name, steps):
    sc = load_scenario(name)
    ctrl, _, t, evs = closed_loop(sc, steps)
    first = evs[0]
    assert all(np.all(np.isfinite(np.atleast_1d(v))) for v in first.values())
    K = ctrl.gain
    for tk, ev in zip(t, evs):
        assert ev["link_margins"].min() > 0.2 and ev["end_margin"] > 0.1 and ev["joint_margins"].min() > 0.2
        decay = math.exp(-K * (tk - sc.t0))
        np.testing.assert_allclose(ev["e"], first["e"] * decay, rtol=1e-6, atol=1e-9)
        grid = np.linspace(sc.t0, tk, 4001)
        travelled = np.trapezoid(np.asarray(ctrl.speed(grid), float).ravel(), grid)
        assert abs(ev["s"] - first["s"] - travelled) < 1e-6
        roll_error = first["roll"] - evaluate(ctrl.roll_target, sc.t0)
        assert abs(ev["roll"] - evaluate(ctrl.roll_target, tk) - roll_error * decay) < 1e-6
    assert np.max(np.abs(evs[-1]["e"])) <= np.max(np.abs(first["e"])) + 1e-9


@pytest.mark.parametrize("name", ["path3d", "port"])
def test_the_start_laid_for_the_controller_is_the_start_laid_anew_and_laid_once(name, monkeypatch):
    """A controller holding the start's roll (these presets command none) lays the start; the scenario's
    start for that controller is the same configuration laid again from scratch (a new array each time),
    without laying it twice."""
    from coordarm.simulation import spatial_scenario

    sc = load_scenario(name)
    laid = []
    original = spatial_scenario.spatial_start
    monkeypatch.setattr(spatial_scenario, "spatial_start", lambda *a: laid.append(a) or original(*a))
    ctrl = sc.controller()
    first = sc.start(ctrl)
    assert len(laid) == 1
    again = original(sc.config, ctrl.chain, ctrl.curve)
    np.testing.assert_array_equal(first, again)
    first[:] = 0.0
    np.testing.assert_array_equal(sc.start(ctrl), again)
    other = load_scenario(name)                 # another scenario (an equal one): laid for itself
    np.testing.assert_array_equal(other.start(ctrl), again)
    assert len(laid) == 2


def test_with_a_commanded_roll_the_start_is_laid_when_asked(monkeypatch):
    from coordarm.simulation import spatial_scenario

    sc = load_scenario("line3d")
    assert sc.config.control.roll_motion is not None
    laid = []
    original = spatial_scenario.spatial_start
    monkeypatch.setattr(spatial_scenario, "spatial_start", lambda *a: laid.append(a) or original(*a))
    ctrl = sc.controller()
    assert laid == []
    np.testing.assert_array_equal(sc.start(ctrl), original(sc.config, ctrl.chain, ctrl.curve))
    assert len(laid) == 1


def test_a_built_in_curves_geometry_is_built_on_first_use_and_a_user_curves_at_once():
    """coordarm's 3-D curves: the task's geometry and roll Functions are made when first asked for (a compiled
    run never asks), equal to those made directly; a user's curve (here a subclass) gets them with the
    controller, so that its errors surface there."""
    import casadi as ca

    from coordarm.symbolic.curves3d import Line3D
    from coordarm.symbolic.spatial_task import SpatialTask, is_built_in3d, roll_function, spatial_geometry_function

    line = Line3D([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    task = SpatialTask(line, lambda t: 0.1, 1.0, lambda t: 0.0)
    assert is_built_in3d(line) and task._cache == {}
    y, d, t = [0.3, 0.2, -0.1], [0.0, 1.0, 0.0], 0.7
    assert [np.asarray(v).tolist() for v in task.geometry(y, t)] == \
        [np.asarray(v).tolist() for v in spatial_geometry_function(line)(y, t)]
    assert [np.asarray(v).tolist() for v in task.roll_geometry(y, d, t)] == \
        [np.asarray(v).tolist() for v in roll_function(line)(y, d, t)]
    assert task.geometry is task.geometry

    class Bent(Line3D):
        def Phi(self, y, t):
            return ca.vertcat(y[0], y[1], y[2])

    assert not is_built_in3d(Bent([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]))
    with pytest.raises(ConfigError, match="Phi must be a 2-vector"):
        SpatialController(SpatialChain(4, 0.1), Bent([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]), 1.0, 0.1, roll=0.0)
