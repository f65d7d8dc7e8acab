"""Real runs driven into every outcome through the CLI, and every preset checked from its log alone.

The geometry here (forward kinematics, segment crossing, joint limits) is written again,
differently from the production code (parametric crossing by Cramer's rule instead of
orientation tests, all pairs instead of sort and sweep).
"""
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from mcap.reader import make_reader

from coordarm.analysis.replay import load

WALL = '''name = "wall"
[chain]
links = 16
link_length = 0.1
[curve]
kind = "line"
angle = 0.0
[control]
gain = 2.0
speed = 0.2
[start]
kind = "zigzag"
beta = 1.3
[run]
duration = 4.0
[[obstacles]]
name = "front wall"
a = [0.9, -0.5]
b = [0.9, 0.5]
[[obstacles]]
center = [0.5, -0.6]
radius = 0.1
[[obstacles]]
points = [[0.2, 0.5], [0.4, 0.5], [0.3, 0.7]]
'''
# 40 links pushed along a circle of radius 0.4 through the base: the end goes round and hits link 1.
FOLD = WALL.split("[[obstacles]]")[0].replace("links = 16", "links = 40").replace(
    'kind = "line"\nangle = 0.0', 'kind = "arc"\nradius = 0.4').replace("speed = 0.2", "speed = 0.3").replace(
    'kind = "zigzag"', 'kind = "projected"').replace("duration = 4.0", "duration = 8.0").replace('"wall"', '"fold"')
# The end point pulled back at 0.02 m/s: the zig-zag closes, 2 beta grows past the 2.8 rad limit.
LIMIT = WALL.split("[[obstacles]]")[0].replace("speed = 0.2", "speed = -0.02").replace(
    "duration = 4.0", "duration = 10.0").replace('"wall"', '"limit"')


def run_cli(tmp_path, name, text, *extra):
    toml = tmp_path / f"{name}.toml"
    toml.write_text(text)
    out = tmp_path / f"{name}.mcap"
    res = subprocess.run([sys.executable, "-m", "coordarm", "run", str(toml), "--quiet", "--out", str(out), *extra],
                         capture_output=True, text=True, timeout=600)
    return res, out


def joints_from_q(q, xi):
    """Link end points (N, m+1, 2): link 1's centre at the origin, angles summed (eq. 5)."""
    alpha = np.cumsum(q, axis=1)
    steps = xi * np.stack([np.cos(alpha), np.sin(alpha)], axis=-1)
    start = -0.5 * steps[:, :1]
    return np.concatenate([start, start + np.cumsum(steps, axis=1)], axis=1)


def crossing_pairs(J):
    """(sample, i, j) of non-adjacent links i < j (1-based) that cross or touch: Cramer's rule + end points."""
    a, b = J[:, :-1], J[:, 1:]
    m = a.shape[1]
    i, j = np.triu_indices(m, k=2)
    p, r = a[:, i], b[:, i] - a[:, i]
    q, s = a[:, j], b[:, j] - a[:, j]
    den = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    qp = q - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[..., 0] * s[..., 1] - qp[..., 1] * s[..., 0]) / den
        u = (qp[..., 0] * r[..., 1] - qp[..., 1] * r[..., 0]) / den
    cross = (den != 0) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)

    def on(pt, o, d):  # distance of pt from the segment o + [0, 1] d is zero
        tt = np.clip(np.sum((pt - o) * d, -1) / np.sum(d * d, -1), 0, 1)
        return np.linalg.norm(pt - (o + tt[..., None] * d), axis=-1) == 0
    touch = on(q, p, r) | on(q + s, p, r) | on(p, q, s) | on(p + r, q, s)
    k, n = np.nonzero(cross | touch)
    return np.column_stack([k, i[n] + 1, j[n] + 1])


def test_independent_crossing_check_sees_a_folded_chain():
    J = joints_from_q(np.array([[0.0, 2.7, 2.7, 2.7, 0.0]]), 0.1)
    assert len(crossing_pairs(J)) > 0
    assert len(crossing_pairs(joints_from_q(np.array([[1.3, -2.6, 2.6, -2.6, 2.6]]), 0.1))) == 0


@pytest.mark.parametrize("preset", ["line", "arc", "hole"])
def test_every_preset_completes_physically_valid_as_read_from_its_log(preset, tmp_path):
    out = tmp_path / f"{preset}.mcap"
    res = subprocess.run([sys.executable, "-m", "coordarm", "run", preset, "--quiet", "--no-figures",
                          "--log-rate", "100", "--out", str(out)], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    with open(out, "rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    spec = json.loads(meta["scenario"]["json"])
    assert json.loads(meta["outcome"]["status"]) == "completed"
    rep = load(out)
    xi = spec["chain"]["link_length"]
    assert rep.q.shape[1] == spec["chain"]["links"] and rep.t[-1] == pytest.approx(spec["run"]["duration"])
    assert np.max(np.abs(rep.q[:, 1:])) <= 2.8                     # default joint limit, every logged sample
    J = joints_from_q(rep.q, xi)
    assert len(crossing_pairs(J)) == 0                              # no two non-adjacent links cross or touch
    for wall in spec["obstacles"]:                                  # the presets' obstacles are segments
        w0, w1 = np.array(wall["a"], float), np.array(wall["b"], float)
        seg = np.broadcast_to(np.stack([w0, w1]), (len(J), 2, 2))
        both = np.concatenate([J, seg], axis=1)                     # chain + the wall as one more "link"
        hits = crossing_pairs(both)
        assert not np.any(hits[:, 2] == J.shape[1] + 1), wall["name"]
    # s is continuous (at most v* dt between logged samples, no 2 pi R jump)
    assert np.max(np.abs(np.diff(rep.s))) < 0.01


def test_a_wall_across_the_path_stops_the_run_with_exit_4_naming_the_wall(tmp_path):
    res, out = run_cli(tmp_path, "wall", WALL)
    assert res.returncode == 4, res.stderr
    assert "link 16 touches or crosses 'front wall'" in res.stderr and "advice:" in res.stderr
    assert str(out) in res.stderr and "wall_stages.png" in res.stderr and "Traceback" not in res.stderr
    assert (tmp_path / "wall_stages.png").exists() and (tmp_path / "wall_tracking.png").exists()
    rep = load(out)
    o = rep.outcome
    assert o["status"] == "collision" and o["kind"] == "wall" and o["obstacle"] == "front wall"
    assert o["links"] == [16] and rep.t[-1] == o["time"]
    # independently: the body reaches x = 0.9 for the first time at the stop (every step is logged)
    J = joints_from_q(rep.q, 0.1)
    assert np.all(J[:-1, :, 0].max(axis=1) < 0.9) and J[-1, :, 0].max() >= 0.9 - 1e-9


def test_allow_contact_keeps_going_and_records_every_contact(tmp_path):
    res, out = run_cli(tmp_path, "wall", WALL, "--allow-contact", "--no-figures")
    assert res.returncode == 0, res.stderr
    rep = load(out)
    assert rep.outcome["status"] == "completed" and rep.t[-1] == pytest.approx(4.0)
    contacts = rep.outcome["contacts"]
    assert contacts[0]["kind"] == "wall" and contacts[0]["links"] == [16]
    assert {c["obstacle"] for c in contacts} == {"front wall"}
    assert len({tuple(c["links"]) for c in contacts}) == len(contacts) > 1      # more links reach it later
    assert "contacts      " in res.stdout


def test_a_chain_folded_onto_itself_stops_with_a_self_collision(tmp_path):
    res, out = run_cli(tmp_path, "fold", FOLD, "--log-rate", "100")
    assert res.returncode == 4, res.stderr
    assert "self-collision at t = " in res.stderr and "links 1 and 40" in res.stderr
    rep = load(out)
    o = rep.outcome
    assert o["status"] == "collision" and o["kind"] == "self" and o["links"] == [1, 40]
    J = joints_from_q(rep.q, 0.1)
    assert len(crossing_pairs(J[:-1])) == 0 and [1, 40] in crossing_pairs(J[-1:])[:, 1:].tolist()
    assert np.all(np.abs(rep.q[:, 1:]) <= 2.8)
    # the end went round the circle past the branch cut of atan2 (s = pi R): s stayed continuous and true
    R = 0.4
    assert rep.s[0] < math.pi * R < rep.s[-1]
    np.testing.assert_allclose(rep.s, rep.s[0] + 0.3 * (rep.t - rep.t[0]), atol=1e-9)


def test_a_joint_pushed_past_its_limit_stops_the_run(tmp_path):
    res, out = run_cli(tmp_path, "limit", LIMIT, "--no-figures")
    assert res.returncode == 4, res.stderr
    assert "joint limit at t = " in res.stderr and "beyond its limit ±2.8000 rad" in res.stderr
    rep = load(out)
    o = rep.outcome
    assert o["status"] == "collision" and o["kind"] == "joint_limit" and o["threshold"] == 2.8
    assert o["links"][1] == o["links"][0] + 1
    assert abs(o["value"]) > 2.8 and np.all(np.abs(rep.q[:-1, 1:]) <= 2.8)
    # closed form: the centres stay on the line, spaced xi cos(beta); the body shrinks at 0.02 m/s,
    # so 2 beta reaches 2.8 when cos(1.4) = cos(1.3) - 0.02 t / (15 xi)
    assert o["time"] == pytest.approx((math.cos(1.3) - math.cos(1.4)) * 15 * 0.1 / 0.02, abs=2e-3)


def test_singularity_and_collision_have_their_exit_codes_and_bad_input_2(tmp_path):
    bad = WALL.replace("radius = 0.1", "radius = -0.1")
    res, _ = run_cli(tmp_path, "bad", bad, "--no-figures")
    assert res.returncode == 2 and "obstacles[1].radius" in res.stderr and "Traceback" not in res.stderr
    inside = WALL.replace("center = [0.5, -0.6]", "center = [0.3, 0.0]")
    res, _ = run_cli(tmp_path, "inside", inside, "--no-figures")
    assert res.returncode == 2 and "start:" in res.stderr and "'wall 2'" in res.stderr
