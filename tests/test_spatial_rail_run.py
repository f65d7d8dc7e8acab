"""A spatial chain on a rail as a user runs it: the scenario keys, the start, the physical checks (rail limit,
capsules from the base), runs and logs, the summary, the report's linearisation, the stage figure, the
Foxglove scene, sweeps and the presets port and pipe3d (short runs)."""
import json
import math

import numpy as np
import pytest

from coordarm.analysis.linearise import linearise
from coordarm.analysis.replay import load
from coordarm import sweep
from coordarm.cli import main
from coordarm.simulation.figures3d import plot_spatial_tracking, stage_scene, tracking_series
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.physical3d import link_ends
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import Scenario, load_scenario
from coordarm.simulation.scene3d import SpatialSceneBuilder
from coordarm.simulation.spatial_view import span_command
from coordarm.simulation.summary import summary_lines
from coordarm.simulation.sweep_points import run_point
from coordarm.symbolic import ConfigError, SingularityError, SpatialChain
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.spatial_controller import SpatialController

RAIL = [1.0, 0.5, 0.0]


def rail_scenario(**tables):
    """A 10-link universal chain on a rail along (1, 0.5, 0) and a static line along the rail."""
    data = {"chain": {"links": 10, "link_length": 0.05, "joints": "universal", "joint_limit": 1.4,
                      "base": {"kind": "rail", "direction": RAIL, "limits": [0.1, 1.0]}},
            "curve": {"kind": "line", "point": [0.0, 0.0, 0.003], "direction": RAIL, "normal": [0.0, 0.0, 1.0]},
            "control": {"gain": 2.0, "speed": 0.1}, "start": {"kind": "zigzag", "beta": 0.6, "roll": 0.2},
            "run": {"duration": 0.4, "step": 0.004}}
    for sec, table in tables.items():
        data[sec] = {**data.get(sec, {}), **table}
    return data


@pytest.fixture(scope="module")
def scenario():
    return Scenario.from_dict(rail_scenario(), "rail.toml")


@pytest.fixture(scope="module")
def logged(scenario, tmp_path_factory):
    ctrl = scenario.controller()
    q0 = scenario.start(ctrl)
    path = tmp_path_factory.mktemp("rail") / "rail.mcap"
    with RunLogger(path, scenario, ctrl, command=["test"]) as log:
        run = simulate(ctrl, q0, scenario.duration, scenario.step, physical=scenario.physical(ctrl.chain),
                       backend="interpreted", on_chunk=log.on_chunk)
    return scenario, ctrl, run, path


def test_the_rail_keys_build_a_spatial_chain_on_a_rail(scenario):
    chain = scenario.chain()
    assert isinstance(chain, SpatialChain) and chain.rail and chain.dof == 21
    np.testing.assert_allclose(chain.rail_direction, np.array(RAIL) / np.linalg.norm(RAIL), atol=1e-15)
    assert chain.rail_limits == (0.1, 1.0)
    assert scenario.spec["chain"]["base"] == {"kind": "rail", "direction": RAIL, "limits": [0.1, 1.0]}


@pytest.mark.parametrize("chain, control, field", [
    ({"base": {"kind": "rail", "angle": 0.2}}, {}, "chain.base"),
    ({"base": {"kind": "rail", "direction": [1.0, 0.0]}}, {}, "chain.base.direction"),
    ({"base": {"kind": "rail", "direction": [1.0, 0.0, 0.0], "limits": [0.5]}}, {}, "chain.base.limits"),
    ({"base": "drum"}, {}, "chain.base"),
    ({"base": "fixed"}, {"span": 0.3}, "control.span"),
])
def test_a_bad_rail_key_is_an_error_naming_the_file_and_field(chain, control, field):
    with pytest.raises(ConfigError) as err:
        Scenario.from_dict(rail_scenario(chain=chain, control=control), "bad.toml")
    assert str(err.value).startswith(f"bad.toml: {field}"), str(err.value)


def test_a_planar_rail_refuses_a_direction():
    data = rail_scenario(chain={"joints": "revolute", "joint_limit": 2.8,
                                "base": {"kind": "rail", "direction": RAIL}},
                         curve={"kind": "line"}, start={"kind": "zigzag", "beta": 0.6})
    data["curve"] = {"kind": "line"}
    data["start"] = {"kind": "zigzag", "beta": 0.6}
    with pytest.raises(ConfigError, match="^p.toml: chain.base: unknown key"):
        Scenario.from_dict(data, "p.toml")


def test_the_start_lies_on_the_rail_at_its_low_limit_with_the_centres_on_the_line(scenario):
    ctrl = scenario.controller()
    q0 = scenario.start(ctrl)
    assert q0[0] == 0.1
    centres = ctrl.chain.centres_np(q0)
    np.testing.assert_allclose(centres[0], 0.1 * ctrl.chain.rail_direction, atol=1e-15)
    line = np.array(RAIL) / np.linalg.norm(RAIL)
    offsets = centres - centres[0]
    np.testing.assert_allclose(offsets - np.outer(offsets @ line, line), 0.0, atol=1e-14)


def test_the_capsules_start_at_the_base_and_a_rail_limit_is_a_contact(scenario):
    chain, phys = scenario.chain(), scenario.physical()
    q = np.stack([chain.zigzag(0.6, RAIL, (0, 0, 1), d=d) for d in (0.05, 0.5, 1.2)])
    a, b, d = link_ends(chain, q)
    y, dirs = chain.centres_np(q), chain.directions_np(q)                 # independently: centre -+ xi/2 d
    np.testing.assert_allclose(a, y - 0.025 * dirs, atol=1e-15)
    np.testing.assert_allclose(b, y + 0.025 * dirs, atol=1e-15)
    hits = phys.check(np.array([0.0, 1.0, 2.0]), q)
    assert [(c.kind, c.time, c.value, c.threshold) for c in hits] == [("rail_limit", 0.0, 0.05, 0.1),
                                                                        ("rail_limit", 2.0, 1.2, 1.0)]
    assert "rail position d = +1.2000 m is beyond its limit +1.0000 m" in hits[1].describe()


def test_a_run_feeds_the_rail_holds_the_span_and_logs_d_first(logged):
    scenario, ctrl, run, path = logged
    assert run.info["stopped"] == "completed" and run.q.shape[1] == 21 and run.u.shape[1] == 21
    np.testing.assert_allclose(run.sigma, run.sigma[0], atol=1e-12)
    np.testing.assert_allclose(run.s - run.sigma, run.q[:, 0] - run.q[0, 0] + run.s[0] - run.sigma[0], atol=1e-10)
    back = load(path)
    for name in ("t", "q", "u", "e", "s", "roll", "sigma", "rail_margin"):
        np.testing.assert_array_equal(getattr(back, name), getattr(run, name))
    text = "\n".join(summary_lines(back.to_run(), back.scenario))
    assert "universal joints on a rail" in text and "rail          d from 0.1000 to 0.1400 m" in text
    assert "bends         max bend/limit" in text


def test_the_linearised_rail_loop_is_the_design(logged):
    _, ctrl, run, _ = logged
    lin = linearise(ctrl, run.q[-1], float(run.t[-1]))
    assert lin.free == 2 and lin.deviation_from_design(ctrl.gain) < 1e-9
    ev = np.sort(np.abs(lin.eigenvalues()))
    np.testing.assert_allclose(ev[:2], 0.0, atol=1e-9)
    np.testing.assert_allclose(ev[2:], ctrl.gain, atol=1e-9)
    commanded = SpatialController(ctrl.chain, ctrl.curve, 2.0, 0.1, roll=0.2, span=0.5)
    lin = linearise(commanded, run.q[-1], float(run.t[-1]))
    assert lin.free == 1 and lin.deviation_from_design(2.0) < 1e-9


def test_the_tracking_figure_shows_the_span_error_and_the_rail_margin(logged, tmp_path):
    _, ctrl, run, _ = logged
    ser = tracking_series(run, ctrl)
    np.testing.assert_array_equal(ser["span_err"], run.sigma - run.sigma[0])
    np.testing.assert_array_equal(ser["rail"], run.rail_margin)
    commanded = SpatialController(ctrl.chain, ctrl.curve, 2.0, 0.1, roll=0.2, span=Sinusoid(0.1, 2.0, 0.5))
    np.testing.assert_allclose(span_command(commanded, run.t), 0.5 + 0.1 * np.sin(2.0 * run.t), atol=1e-15)
    assert span_command(ctrl, run.t) is None
    assert plot_spatial_tracking(run, ctrl, tmp_path / "t.png").read_bytes()[:4] == b"\x89PNG"


def test_the_stage_figure_and_the_scene_draw_the_rail_and_the_base_on_it(logged):
    scenario, ctrl, run, _ = logged
    idx = np.array([0, len(run.t) - 1])
    scene = stage_scene(run, ctrl, idx)
    np.testing.assert_allclose(scene["bases"], run.q[idx, :1] * ctrl.chain.rail_direction, atol=1e-15)
    finite = scene["rail"][np.all(np.isfinite(scene["rail"]), axis=1)]
    np.testing.assert_allclose(np.cross(finite, ctrl.chain.rail_direction), 0.0, atol=1e-12)   # on the rail
    assert 0.1 - 1e-12 <= np.min(finite @ ctrl.chain.rail_direction) and np.max(finite @ ctrl.chain.rail_direction) <= 1 + 1e-12
    builder = SpatialSceneBuilder(ctrl, [])
    builder.advance(run)
    ks = np.array([0, len(run.t) - 1])
    msgs = builder.messages(run, ks, (run.t[ks] * 1e9).round().astype(np.int64))
    scenes = [json.loads(data)["entities"][0] for key, _, data in msgs if key == "scene"]
    micrometre = 0.5e-6 * (1 + 1e-9)      # positions in the scene: micrometres
    for entity, k in zip(scenes, ks):
        base = entity["cubes"][0]["pose"]["position"]
        np.testing.assert_allclose([base["x"], base["y"], base["z"]], run.q[k, 0] * ctrl.chain.rail_direction,
                                   rtol=0, atol=micrometre)
    fixed = json.loads(next(data for key, _, data in msgs if key == "fixed"))["entities"][0]    # the rail, once
    ends = [[p["x"], p["y"], p["z"]] for p in fixed["lines"][0]["points"]]
    np.testing.assert_allclose(ends, np.outer([0.1, 1.0], ctrl.chain.rail_direction), rtol=0, atol=micrometre)
    # with the capsule radius the links are drawn as the checked capsules: cylinders and caps of that radius
    r = scenario.physical(ctrl.chain).radius
    capsules = SpatialSceneBuilder(ctrl, [], r)
    capsules.advance(run)
    entity = json.loads(next(d for key, _, d in capsules.messages(run, ks[:1], np.array([0])) if key == "scene"))["entities"][0]
    assert r == 0.005 and {c["size"]["x"] for c in entity["cylinders"]} == {2 * r}
    assert {s["size"]["x"] for s in entity["spheres"][:-1]} == {2 * r}


def test_a_sweep_over_the_start_roll_and_the_links_holds_each_points_roll():
    spec = Scenario.from_dict(rail_scenario(run={"duration": 0.1, "step": 0.005}), "rail.toml").spec
    rows = [run_point(spec, {"start.roll": r, "chain.links": m}) for r in (0.0, 0.4) for m in (8, 10)]
    assert [r["outcome"] for r in rows] == ["completed"] * 4, [r["message"] for r in rows]
    assert max(r["max_roll_error"] for r in rows) < 1e-9


def test_a_sweep_of_the_port_preset_over_the_start_roll(tmp_path):
    df = sweep("port", {"start.roll": [0.0, 0.3], "run.duration": [0.1]}, client="serial", out=tmp_path)
    assert list(df["outcome"]) == ["completed"] * 2, list(df["message"])
    assert df["max_roll_error"].max() < 1e-9 and (df["min_clearance"] > 0.02).all()
    assert (df["min_end_margin"] > 0.15).all() and (df["min_joint_margin"] > 0.9).all()


def test_port_and_pipe3d_start_valid_and_run_on_the_command_line(tmp_path, capsys):
    assert main(["run", "port", "--duration", "0.3", "--out", str(tmp_path / "port.mcap"), "--no-figures"]) == 0
    text = capsys.readouterr().out
    assert "universal joints on a rail" in text and "(completed" in text and "clearance     'casing wall'" in text
    assert main(["run", "pipe3d", "--duration", "0.2", "--out", str(tmp_path / "pipe3d.mcap"), "--no-figures"]) == 0
    text = capsys.readouterr().out
    assert "(completed" in text and "more obstacles, each at least" in text
    for name in ("port", "pipe3d"):
        sc = load_scenario(name)
        assert sc.config.chain.joint_limit == 1.4 and sc.chain().rail and math.isclose(sc.chain().rail_direction[0], 1.0)
    port = load_scenario("port").spec["obstacles"][0]
    assert port["kind"] == "plate" and port["holes"] == [{"centre": [1.65, 0.0, 0.0], "radius": 0.05}]     # 0.1 m


def test_a_rail_margin_below_the_link_threshold_stops_the_run_as_a_singularity():
    data = rail_scenario(chain={"base": {"kind": "rail", "direction": [0.3, 1.0, 0.0], "limits": [0.1, 1.0]}},
                         thresholds={"link": 0.5})
    data["curve"].update(direction=[1.0, 0.0, 0.0], normal=[0.0, 1.0, 0.0])
    data["start"] = {"kind": "zigzag", "beta": 0.6, "axis": [1.0, 0.0, 0.0], "fold": [0.0, 1.0, 0.0]}
    sc = Scenario.from_dict(data, "across.toml")
    ctrl = sc.controller()
    with pytest.raises(SingularityError) as err:
        simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, thresholds=sc.thresholds, backend="interpreted")
    assert err.value.kind == "rail" and err.value.margin == pytest.approx(0.3 / math.hypot(0.3, 1.0), abs=1e-12)
    assert err.value.run.info["stopped"] == "singularity"


def test_a_commanded_span_in_the_scenario_decays_to_its_command_like_exp_minus_K_t():
    sc = Scenario.from_dict(rail_scenario(control={"span": [0.4, {"kind": "ramp", "rate": 0.02}]}), "span.toml")
    ctrl = sc.controller()
    run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, backend="interpreted")
    target = 0.4 + 0.02 * run.t
    np.testing.assert_allclose(run.sigma - target, (run.sigma[0] - 0.4) * np.exp(-2.0 * run.t), rtol=0, atol=1e-9)
    assert abs(run.sigma[0] - 0.4) > 1e-2                  # not vacuous: the start's span is not the command
    np.testing.assert_allclose(run.s, run.s[0] + 0.1 * run.t, rtol=0, atol=1e-9)
