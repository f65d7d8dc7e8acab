"""Issue 25 item 6: the log reader checks the metadata against the data and says what is missing."""
import pytest

from coordarm.analysis.replay import load
from coordarm.cli import main
from coordarm.simulation.mcap_file import McapFile
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic import LogError


def _forged(path, metadata_links: int, data_links: int):
    """A log whose scenario record (with a valid checksum) says ``metadata_links`` but whose samples hold ``data_links``."""
    told = load_scenario("line").with_overrides(links=metadata_links, duration=0.02)
    real = load_scenario("line").with_overrides(links=data_links, duration=0.02)
    ctrl = real.controller()
    with RunLogger(path, told, ctrl) as log:
        simulate(ctrl, real.start(ctrl), real.duration, real.step, backend="interpreted", on_chunk=log.on_chunk)
    return path


def test_a_log_whose_scenario_has_fewer_links_than_its_data_is_refused(tmp_path, capsys):
    path = _forged(tmp_path / "forged.mcap", 2, 64)
    with pytest.raises(LogError, match=r"hold 64 joint values but the 'scenario' metadata describes 2 links"):
        load(path)
    assert main(["replay", str(path), "--no-animation"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "forged.mcap" in err and "Traceback" not in err


@pytest.mark.parametrize("record", ["[1, 2, 3]", '"a string"', "42", "null"])
def test_a_scenario_record_that_is_json_but_not_a_table_is_one_log_error(tmp_path, record):
    f = McapFile(tmp_path / "odd.mcap")
    f.add_metadata("scenario", {"json": record, "source": "x"})
    f.close()
    with pytest.raises(LogError, match="'scenario' metadata is not a valid scenario"):
        load(tmp_path / "odd.mcap")


def test_missing_and_garbled_run_build_and_outcome_metadata_are_named(tmp_path):
    sc = load_scenario("line").with_overrides(links=4, duration=0.01)
    f = McapFile(tmp_path / "bare.mcap")
    f.add_metadata("scenario", {"json": sc.to_json(), "source": "x"})
    f.close()
    problems = load(tmp_path / "bare.mcap").problems
    assert any("no 'run' metadata" in p for p in problems)
    assert any("no 'build' metadata" in p for p in problems)
    assert any("no 'outcome' metadata" in p for p in problems)
    g = McapFile(tmp_path / "garbled.mcap")
    g.add_metadata("scenario", {"json": sc.to_json(), "source": "x"})
    g.add_metadata("run", {"log_every_steps": "many"})
    g.add_metadata("build", {"backend": "abacus"})
    g.add_metadata("outcome", {"status": '"splendid"'})
    g.close()
    problems = load(tmp_path / "garbled.mcap").problems
    assert any("'outcome' metadata names no known status" in p and "splendid" in p for p in problems)
    assert any("'run' metadata has no step count" in p for p in problems)
    assert any("'build' metadata names no known backend" in p and "abacus" in p for p in problems)


def test_a_complete_log_has_no_metadata_problems(tmp_path):
    path = tmp_path / "ok.mcap"
    assert main(["run", "line", "--links", "4", "--duration", "0.05", "--quiet", "--no-figures", "--out", str(path)]) == 0
    assert load(path).problems == []


def test_the_report_of_a_cut_off_log_says_so(tmp_path):
    path = tmp_path / "cut.mcap"
    assert main(["run", "line", "--links", "4", "--duration", "0.5", "--quiet", "--no-figures", "--out", str(path)]) == 0
    raw = path.read_bytes()
    cut = tmp_path / "cut2.mcap"
    cut.write_bytes(raw[:len(raw) * 2 // 3])
    assert main(["report", str(cut), "--samples", "5"]) == 0
    text = (tmp_path / "cut2_report" / "report.md").read_text()
    assert "cut off" in text
