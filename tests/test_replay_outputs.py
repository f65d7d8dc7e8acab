"""``replay_log``: ``coordarm replay`` as a library call, checked against the run that wrote the log."""
import coordarm
from coordarm.analysis.replay_outputs import replay_log


def test_replay_log_prints_nothing_and_redraws_the_run_from_its_log(tmp_path, capsys):
    made = coordarm.run_scenario("line", links=6, duration=0.2, backend="interpreted", log=tmp_path / "l.mcap",
                                 figures=False)
    problems = []
    out = replay_log(made.log, tmp_path / "again", fps=5, on_problem=problems.append)
    assert capsys.readouterr() == ("", "") and problems == []
    summary = [line for line in made.lines if not line.startswith(("log ", "library "))]
    assert out.lines[0] == f"scenario      line ({made.log} (scenario metadata)), 6 links"
    assert list(out.lines[1:len(summary)]) == summary[1:]     # the same summary, read back from the log
    assert out.lines[len(summary)] == "outcome       completed"
    assert [p.name for p in out.figures] == ["l_stages.png", "l_tracking.png"]
    assert all(p.parent == tmp_path / "again" and p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in out.figures)
    assert out.animation.read_bytes()[:6] == b"GIF89a"
