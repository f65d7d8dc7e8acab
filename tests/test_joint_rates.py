"""Joint accelerations: the peaks of |du/dt| over every step, and the optional rate/accel limits.

The peaks are checked against plain numpy on the run's own rates (every row kept); the limits stop
the run at the first step beyond them, with their outcome, exit code 5 and a message naming the
joint and the time, in the CLI and in the log.
"""
import subprocess
import sys

import numpy as np
import pytest

from coordarm.analysis.replay import load
from coordarm.simulation.joint_rates import JointRateError, JointRates
from coordarm.symbolic import ConfigError

SHORT = """name = "short"
[chain]
links = 12
link_length = 0.1
{limits}
[curve]
kind = "path"
start = [-0.2, 0.0]
heading = 0.0
segments = [{{ line = 0.3 }}, {{ arc = 1.0, radius = 0.5 }}, {{ line = 1.0 }}]
{transition}
[control]
gain = 2.0
speed = 0.1
[start]
kind = "follow"
beta = 1.1
[run]
duration = 2.0
step = 0.002
"""


def test_peaks_over_chunks_equal_numpy_on_the_whole_run():
    rng = np.random.default_rng(0)
    t = np.arange(50) * 0.01
    u = np.cumsum(rng.normal(size=(50, 4)), axis=0)          # rail rate first, then three joints
    rates = JointRates(rail=True)
    for a, b in ((0, 7), (7, 8), (8, 31), (31, 50)):          # chunks of any length, one of a single row
        assert rates.update(t[a:b], u[a:b]) is None
    acc = np.abs(np.diff(u[:, 1:], axis=0)) / 0.01
    k, j = np.unravel_index(np.argmax(acc), acc.shape)
    assert rates.peaks["du_dt"] == pytest.approx(acc.max(), rel=1e-12)
    assert rates.peaks["du_dt_joint"] == j + 1 and rates.peaks["du_dt_time"] == pytest.approx(t[k + 1])
    assert rates.peaks["rail_accel"] == pytest.approx(np.max(np.abs(np.diff(u[:, 0]))) / 0.01, rel=1e-12)


def test_limits_stop_at_the_first_row_beyond_them_naming_joint_and_time():
    t = np.arange(6) * 0.1
    u = np.zeros((6, 3))
    u[4, 1] = 0.5                                            # joint 2 (column 1) jumps at t = 0.4 (5 rad/s^2)
    fast = JointRates(accel_limit=4.0).update(t, u)
    assert fast[0] == 4 and fast[1].joint == 2 and fast[1].kind == "accel"
    assert "joint accel limit at t = 0.4000 s: joint 2 accelerates at |du/dt| = 5 rad/s^2" in str(fast[1])
    rates = JointRates(rate_limit=0.4)
    assert rates.update(t[:3], u[:3]) is None
    row, err = rates.update(t[3:], u[3:])                    # rows of the second chunk count from 0
    assert row == 1 and err.time == pytest.approx(0.4) and err.kind == "rate" and err.value == 0.5
    assert isinstance(err, JointRateError)


@pytest.mark.parametrize("value", [0, -1.0, True, "fast", float("inf")])
def test_bad_limits_are_refused_naming_the_field(value):
    import tomllib

    from coordarm.simulation.scenario import Scenario
    spec = tomllib.loads(SHORT.format(limits="", transition=""))
    spec["chain"]["accel_limit"] = value
    with pytest.raises(ConfigError, match=r"chain.accel_limit: need a number > 0"):
        Scenario.from_dict(spec)


def run_cli(tmp_path, text, *extra):
    path = tmp_path / "short.toml"
    path.write_text(text)
    out = tmp_path / "short.mcap"
    res = subprocess.run([sys.executable, "-m", "coordarm", "run", str(path), "--quiet", "--no-figures",
                          "--out", str(out), *extra], capture_output=True, text=True, timeout=600)
    return res, out


def test_an_accel_limit_stops_the_g1_path_at_its_junction_and_the_g2_path_passes(tmp_path):
    g1 = SHORT.format(limits="accel_limit = 1.0", transition="transition = 0")   # G1 peak: 1.6 rad/s^2
    res, out = run_cli(tmp_path, g1)
    assert res.returncode == 5, res.stderr
    assert "rate_limit: joint accel limit at t = " in res.stderr and "Traceback" not in res.stderr
    assert "curve.transition" in res.stderr                  # the advice
    rep = load(out)
    o = rep.outcome
    assert o["status"] == "rate_limit" and o["kind"] == "accel" and o["value"] > 1.0
    assert rep.t[-1] == pytest.approx(o["time"]) and o["joint_rates"]["du_dt"] == pytest.approx(o["value"])
    u = rep.u[:, :]                                          # every step is logged: the same from the log
    acc = np.abs(np.diff(u, axis=0)) / np.diff(rep.t)[:, None]
    assert np.max(acc[:-1]) <= 1.0 < np.max(acc[-1])
    assert acc[-1].argmax() + 1 == o["joint"]
    g2 = SHORT.format(limits="accel_limit = 1.0", transition="transition = 0.3")
    res, out = run_cli(tmp_path, g2, "--overwrite")
    assert res.returncode == 0, res.stderr
    peak = load(out).outcome["joint_rates"]["du_dt"]
    assert 0 < peak < 0.15                                   # 0.10 rad/s^2: 16x lower
    assert f"peak |du/dt|  {peak:.4g} rad/s²" in res.stdout
    replay = subprocess.run([sys.executable, "-m", "coordarm", "replay", str(out), "--no-animation"],
                            capture_output=True, text=True, timeout=600)
    assert f"peak |du/dt|  {peak:.4g} rad/s²" in replay.stdout, replay.stderr       # from the log's outcome
