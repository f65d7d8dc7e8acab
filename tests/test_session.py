"""``coordarm.run_scenario``: the library form of ``coordarm run``, checked against its log read back
with the plain ``mcap`` reader (CDR decoded by hand), the PNG signature of its figures and the stop
reasons of real runs driven into a wall and towards a singularity."""
import json
import struct

import numpy as np
import pytest
from mcap.reader import make_reader

import coordarm
from coordarm.symbolic import CollisionError, LogError, SingularityError

from test_outcomes import WALL

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# 16 links pushed round an arc too fast: the longitudinal margin falls below its threshold.
FAST_ARC = ('name = "fast"\n[chain]\nlinks = 16\nlink_length = 0.1\n[curve]\nkind = "arc"\nradius = 1.0\n'
            '[control]\ngain = 2.0\nspeed = 0.4\n[start]\nkind = "projected"\n[run]\nduration = 3.0\n')


def read_log(path):
    """(metadata by name, decoded /joint_state messages as (t, q) pairs) of an MCAP file."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        states = []
        for _, _, msg in reader.iter_messages(topics=["/joint_state"]):
            m = (len(msg.data) - 4) // 16                     # CDR header, then float64 t, q[m], u[m]
            values = struct.unpack(f"<{1 + 2 * m}d", msg.data[4:])
            states.append((values[0], np.array(values[1:1 + m])))
    return meta, states


def test_run_scenario_returns_the_run_its_log_and_figures_without_printing(tmp_path, capsys):
    lines = []
    result = coordarm.run_scenario("line", links=6, duration=0.2, backend="interpreted", log=tmp_path / "l.mcap",
                                   echo=lines.append)
    assert capsys.readouterr() == ("", "")                  # nothing printed: the lines went to echo
    assert (result.outcome, result.exit_status, result.stopped) == ("completed", 0, None)
    assert result.log == tmp_path / "l.mcap" and result.backend == "interpreted" and result.library is None
    meta, states = read_log(result.log)
    assert json.loads(meta["outcome"]["status"]) == "completed"
    step = json.loads(meta["scenario"]["json"])["run"]["step"]
    assert len(states) == round(0.2 / step) + 1 == len(result.run.t)   # every step logged, and the start
    t_last, q_last = states[-1]
    assert t_last == pytest.approx(0.2) and np.array_equal(q_last, result.run.q[-1])
    assert [p.name for p in result.figures] == ["l_stages.png", "l_tracking.png"]
    for png in result.figures:
        assert png.read_bytes()[:8] == PNG_SIGNATURE
    assert list(result.lines) == lines and lines[0].startswith("scenario      line")
    assert lines[-3:] == [f"log           {result.log}"] + [f"figure        {p}" for p in result.figures]
    assert result.summary["steps"] == len(states) - 1 and result.contacts == []


def test_a_wall_stop_is_a_result_with_outcome_collision_and_exit_status_4(tmp_path):
    toml = tmp_path / "wall.toml"
    toml.write_text(WALL)
    result = coordarm.run_scenario(toml, backend="interpreted", log=tmp_path / "wall.mcap", figures=False)
    assert (result.outcome, result.exit_status, result.figures) == ("collision", 4, ())
    assert isinstance(result.stopped, CollisionError)
    meta, states = read_log(result.log)
    outcome = meta["outcome"]
    assert json.loads(outcome["status"]) == "collision" and json.loads(outcome["obstacle"]) == "front wall"
    assert states[-1][0] == json.loads(outcome["time"]) == result.run.t[-1]
    assert result.stop_message().startswith(f"collision: collision at t = {result.run.t[-1]:.3f} s: link 16 "
                                            "touches or crosses 'front wall'")
    assert f"\nlog: {result.log}" in result.stop_message()


def test_a_singularity_stop_is_a_result_with_exit_status_3_and_figures(tmp_path):
    toml = tmp_path / "fast.toml"
    toml.write_text(FAST_ARC)
    result = coordarm.run_scenario(toml, backend="interpreted", log=tmp_path / "fast.mcap")
    assert (result.outcome, result.exit_status) == ("singularity", 3)
    assert isinstance(result.stopped, SingularityError) and result.stopped.kind == "longitudinal"
    meta, states = read_log(result.log)
    assert json.loads(meta["outcome"]["status"]) == "singularity"
    assert states[-1][0] == pytest.approx(result.stopped.time) and result.run.t[-1] < 3.0
    assert all(p.read_bytes()[:8] == PNG_SIGNATURE for p in result.figures) and len(result.figures) == 2


def test_an_existing_log_is_refused_before_anything_runs_unless_overwrite(tmp_path):
    log = tmp_path / "taken.mcap"
    log.write_bytes(b"keep me")
    with pytest.raises(LogError, match="exists; choose another file or pass --overwrite"):
        coordarm.run_scenario("line", links=6, duration=0.05, log=log)
    assert log.read_bytes() == b"keep me"
