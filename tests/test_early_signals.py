"""Issue 25 item 5: a SIGKILL or Ctrl-C early in a real ``coordarm run`` keeps a log with its scenario.

Each test polls for the moment it is about (the unfinished log appearing), never a fixed delay from
the start of the process.
"""
import signal
import subprocess
import sys
import time

import pytest

from coordarm.analysis.replay import load
from coordarm.simulation.log_layout import partial_path

TOML = """name = "early"
[chain]
links = 8
link_length = 0.1
[curve]
kind = "line"
point = [0.0, 0.0]
angle = { kind = "sinusoid", amplitude = 0.5, omega = 0.5 }
[control]
gain = 2.0
speed = 0.0
[run]
duration = 10000.0
"""


def _start(tmp_path, name):
    toml = tmp_path / f"{name}.toml"
    toml.write_text(TOML)
    out = tmp_path / f"{name}.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "coordarm", "run", str(toml), "--quiet", "--no-figures", "--yes",
                             "--backend", "interpreted", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    return proc, out


def _wait_for_partial(proc, out, timeout=120.0):
    start = time.monotonic()
    while not partial_path(out).exists():
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() - start < timeout, "no log started in time"
        time.sleep(0.001)
    return time.monotonic()


@pytest.mark.parametrize("after", [0.15, 0.3])
def test_a_sigkill_soon_after_the_log_appears_leaves_its_scenario_on_disk(tmp_path, after):
    proc, out = _start(tmp_path, f"k{int(after * 100)}")
    try:
        seen = _wait_for_partial(proc, out)
        while time.monotonic() - seen < after:        # the reproducer's moment, counted from the file
            time.sleep(0.001)
        proc.kill()
        proc.wait(timeout=60)
    finally:
        proc.kill()
    rep = load(out)                                   # reads the unfinished .partial
    assert rep.scenario.config.chain.links == 8 and rep.scenario.name == "early"


def test_a_ctrl_c_as_soon_as_the_log_appears_keeps_a_closed_log_with_outcome_interrupted(tmp_path):
    proc, out = _start(tmp_path, "c")
    try:
        _wait_for_partial(proc, out)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    err = err.decode()
    assert proc.returncode == 130 and "Traceback" not in err, err
    assert out.exists() and not partial_path(out).exists()
    rep = load(out)
    assert rep.outcome["status"] == "interrupted" and rep.problems == [] and not rep.recovered
