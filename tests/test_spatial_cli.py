"""The command line on spatial scenarios: a run logs and draws, a report is written; ftl without a rail says so (exit 2)."""
import json

from mcap.reader import make_reader

from coordarm.cli import main


def test_run_line3d_logs_a_universal_chain_and_writes_both_figures(tmp_path, capsys):
    out = tmp_path / "l3.mcap"
    assert main(["run", "line3d", "--links", "12", "--duration", "0.2", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "12 links, universal joints" in text and "roll tracking" in text
    with open(out, "rb") as f:
        reader = make_reader(f)
        meta = {r.name: dict(r.metadata) for r in reader.iter_metadata()}
        topics = {c.topic for c in reader.get_summary().channels.values()}
    assert meta["run"]["chain_kind"] == "universal" and json.loads(meta["outcome"]["status"]) == "completed"
    assert {"/joint_state", "/task_state", "/margins", "/scene", "/tf", "/tracking"} <= topics
    for name in ("l3_stages.png", "l3_tracking.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_compare_refuses_ftl_on_a_fixed_base_spatial_scenario_and_report_writes_one(tmp_path, capsys):
    assert main(["compare", "line3d", "--methods", "ftl", "--duration", "0.1"]) == 2
    assert "ftl: follow-the-leader needs a robot on a rail" in capsys.readouterr().err
    out = tmp_path / "report"
    assert main(["report", "line3d", "--links", "8", "--duration", "0.2", "--out", str(out)]) == 0
    assert str(out / "report.md") in capsys.readouterr().out
    assert "universal joints" in (out / "report.md").read_text()
