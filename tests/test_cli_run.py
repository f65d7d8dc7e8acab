"""``coordarm run`` end to end through the real entry point."""
import subprocess
import sys

from coordarm.cli import main


def test_run_prints_summary_and_writes_figures(tmp_path, capsys):
    out = tmp_path / "line.mcap"
    assert main(["run", "line", "--links", "12", "--duration", "0.5", "--quiet", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    for word in ("final max|e|", "s tracking", "link margin", "longitudinal"):
        assert word in text
    assert (tmp_path / "line_stages.png").stat().st_size > 10_000
    assert (tmp_path / "line_tracking.png").stat().st_size > 10_000


def test_bad_scenario_is_a_clear_error_with_exit_status_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[chain]\nlinks = -3\nlink_length = 0.1\n[curve]\nkind = "line"\n[control]\ngain = 1.0\n')
    assert main(["run", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "chain.links" in err and str(bad) in err and "Traceback" not in err


def test_singularity_exits_3_and_still_writes_figures(tmp_path):
    toml = tmp_path / "fast.toml"
    toml.write_text('name = "fast"\n[chain]\nlinks = 32\nlink_length = 0.1\n[curve]\nkind = "arc"\nradius = 1.0\n'
                    '[control]\ngain = 2.0\nspeed = 0.4\n[start]\nkind = "projected"\n[run]\nduration = 20.0\n')
    res = subprocess.run([sys.executable, "-m", "coordarm", "run", str(toml), "--quiet",
                          "--out", str(tmp_path / "fast.mcap")], capture_output=True, text=True)
    assert res.returncode == 3, res.stderr
    assert "singularity ahead at t = " in res.stderr and "longitudinal margin" in res.stderr
    assert "advice: lower the speed" in res.stderr and f"log: {tmp_path / 'fast.mcap'}" in res.stderr
    assert (tmp_path / "fast_stages.png").exists()


def test_ctrl_c_during_a_run_exits_130_and_leaves_a_closed_log(tmp_path, capsys, monkeypatch):
    """A real SIGINT once blocks are logged, with SIGINT inherited as ignored (a background job):
    the CLI installs its own handler, so it still stops the run."""
    import os
    import signal

    from coordarm.analysis.replay import load
    from coordarm.simulation.mcap_writer import RunLogger

    out = tmp_path / "line.mcap"
    logged, calls = RunLogger.on_chunk, []

    def on_chunk(self, part):      # Ctrl-C once the run is under way (no timer racing the start-up)
        logged(self, part)
        calls.append(len(part.t))
        if len(calls) == 3:
            os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(RunLogger, "on_chunk", on_chunk)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        status = main(["run", "line", "--duration", "100", "--backend", "interpreted",
                       "--quiet", "--no-figures", "--out", str(out)])
    finally:
        signal.signal(signal.SIGINT, previous)
    assert status == 130 and "interrupted" in capsys.readouterr().err
    rep = load(out)
    assert rep.outcome["status"] == "interrupted" and not rep.recovered and len(rep.t) > 0
