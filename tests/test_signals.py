"""Ctrl-C, SIGTERM and SIGKILL against real ``coordarm run`` processes; peak memory of long runs.

Every test waits for the event it is about (a logged block, a marker line), never a fixed delay,
and starts its children with SIGINT ignored, as a shell does for a background job.
"""
import os
import random
import resource
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from coordarm.analysis.replay import load
from coordarm.simulation.log_layout import partial_path
from coordarm.symbolic import LogError

SWING = """name = "swing"
[chain]
links = {links}
link_length = 0.1
[curve]
kind = "line"
point = [0.0, 0.0]
angle = {{ kind = "sinusoid", amplitude = 0.5, omega = 0.5 }}
[control]
gain = 2.0
speed = 0.0
[run]
duration = {duration}
"""


def _ignore_sigint():
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # what a shell does to a background job


def _start(tmp_path: Path, *extra: str, links: int = 8, duration: float = 10000.0, name: str = "swing"):
    toml = tmp_path / f"{name}.toml"
    toml.write_text(SWING.format(links=links, duration=duration))
    out = tmp_path / f"{name}.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "coordarm", "run", str(toml), "--quiet", "--no-figures", "--yes",
                             "--out", str(out), *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=_ignore_sigint)
    return proc, out


def _wait_for_handlers(proc, timeout: float = 60.0) -> None:
    """Until ``proc`` catches SIGTERM (``SigCgt`` in /proc): the command line's handlers are installed."""
    start = time.monotonic()
    while time.monotonic() - start < timeout:
        try:
            with open(f"/proc/{proc.pid}/status") as f:
                caught = next(int(ln.split()[1], 16) for ln in f if ln.startswith("SigCgt:"))
        except (OSError, StopIteration):
            caught = 0
        if caught >> (signal.SIGTERM - 1) & 1:
            return
        assert proc.poll() is None, proc.stderr.read().decode()
        time.sleep(0.002)
    raise AssertionError("the signal handlers were not installed in time")


def _wait_for_first_block(proc, out: Path, timeout: float = 120.0) -> None:
    """Until the partial log holds a complete sample (the first logged block reached the file)."""
    writing, start = partial_path(out), time.monotonic()
    while time.monotonic() - start < timeout:
        if proc.poll() is not None:
            raise AssertionError(proc.stderr.read().decode())
        try:
            if writing.exists() and len(load(writing).t):
                return
        except LogError:   # header and metadata only, so far
            pass
        time.sleep(0.05)
    raise AssertionError("no block logged in time")


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_after_the_first_block_ends_the_run_with_130_and_a_closed_log(tmp_path, signum):
    proc, out = _start(tmp_path)
    try:
        _wait_for_first_block(proc, out)
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    err = err.decode()
    assert proc.returncode == 130, err
    assert "interrupted" in err and signal.Signals(signum).name in err and "Traceback" not in err
    rep = load(out)
    assert not partial_path(out).exists() and rep.path == out
    assert rep.outcome["status"] == "interrupted" and not rep.recovered and len(rep.t) > 0 and rep.problems == []


def test_ctrl_c_at_random_moments_always_exits_130_with_a_readable_log_or_none(tmp_path):
    """From process start: imports, scenario, CasADi building the controller, compiling, logging."""
    rng = random.Random(17)
    for i in range(6):
        proc, out = _start(tmp_path, "--backend", "interpreted" if i % 2 else "auto", name=f"r{i}")
        delay = rng.uniform(0.0, 3.0)
        try:
            _wait_for_handlers(proc)   # the process can be interrupted at all (Python itself has started)
            deadline = time.monotonic() + delay
            while time.monotonic() < deadline and proc.poll() is None:
                time.sleep(0.01)
            proc.send_signal(signal.SIGTERM if i == 5 else signal.SIGINT)
            _, err = proc.communicate(timeout=120)
        finally:
            proc.kill()
        err = err.decode()
        assert proc.returncode == 130, (delay, err)
        assert "Traceback" not in err and "interrupted" in err, err
        if out.exists():
            assert load(out).outcome["status"] == "interrupted"
        assert not partial_path(out).exists()


KILLED_RUN = textwrap.dedent("""
    import sys, time
    from coordarm.simulation.mcap_writer import RunLogger
    from coordarm.simulation.run import simulate
    from coordarm.simulation.scenario import load_scenario
    sc = load_scenario(sys.argv[1])
    ctrl = sc.controller()
    marks = open(sys.argv[3], "w", buffering=1)
    with RunLogger(sys.argv[2], sc, ctrl, threaded=sys.argv[4] == "1") as log:
        def on_chunk(part):
            log.on_chunk(part)
            marks.write(f"{time.time()!r} {float(part.t[-1])!r}\\n")   # this block is complete now
        simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, backend="compiled", chunk=500, on_chunk=on_chunk)
""")


def test_sigkill_at_random_moments_loses_no_block_completed_more_than_a_second_earlier(tmp_path):
    toml = tmp_path / "swing.toml"
    toml.write_text(SWING.format(links=32, duration=10000.0))
    script = tmp_path / "killed_run.py"
    script.write_text(KILLED_RUN)
    rng = random.Random(1717)
    worst = []
    for i in range(10):
        out, marks = tmp_path / f"k{i}.mcap", tmp_path / f"k{i}.marks"
        proc = subprocess.Popen([sys.executable, str(script), str(toml), str(out), str(marks), str(i % 2)],
                                stderr=subprocess.PIPE, preexec_fn=_ignore_sigint)
        try:
            start = time.monotonic()
            while not (marks.exists() and marks.read_text().count("\n") >= 1):   # the first block is done
                assert proc.poll() is None, proc.stderr.read().decode()
                assert time.monotonic() - start < 120
                time.sleep(0.01)
            time.sleep(rng.uniform(0.0, 3.0))   # a random moment of the run (not racing a start-up)
            killed_at = time.time()
            proc.kill()
            proc.wait()
        finally:
            proc.kill()
        assert proc.returncode == -signal.SIGKILL
        done = np.array([[float(x) for x in ln.split()] for ln in marks.read_text().splitlines() if ln.count(" ")])
        must_have = done[done[:, 0] <= killed_at - 1.0, 1]
        rep = load(out)   # reads the partial file the killed run left
        assert rep.recovered and rep.path == partial_path(out)
        if len(must_have):
            assert rep.t[-1] >= must_have.max() - 1e-9, (i, rep.t[-1], must_have.max())
        lost = done[done[:, 1] > rep.t[-1] + 1e-9, 0] if len(rep.t) else done[:, 0]
        worst.append(killed_at - lost.min() if len(lost) else 0.0)
        np.testing.assert_allclose(np.diff(rep.t), rep.scenario.step, rtol=1e-6)   # no gap
    print("wall time lost per kill [s]:", [round(float(w), 3) for w in worst])
    assert max(worst) <= 1.0, worst


def _peak_rss_kib(tmp_path: Path, duration: float) -> tuple[int, str]:
    toml = tmp_path / f"long{duration:g}.toml"
    toml.write_text(SWING.format(links=16, duration=duration))
    code = ("import resource, sys; from coordarm.cli import main; status = main(sys.argv[1:]); "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss); sys.exit(status)")
    res = subprocess.run([sys.executable, "-c", code, "run", str(toml), "--quiet", "--no-figures",
                          "--out", str(tmp_path / f"long{duration:g}.mcap")], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return int(res.stdout.split()[-1]), res.stdout


def test_peak_memory_of_a_logged_200_s_run_is_within_1_3_times_that_of_a_20_s_run(tmp_path):
    (short, _), (long, summary) = _peak_rss_kib(tmp_path, 20.0), _peak_rss_kib(tmp_path, 200.0)
    assert long <= 1.3 * short, (short, long)
    assert "simulated     200.000 s in 200000 steps (completed" in summary   # counted, not the rows kept
    assert len(load(tmp_path / "long200.mcap").t) == 200_001   # everything reached the log


IMPORT_HOOK = textwrap.dedent("""
    import os, signal, sys
    class SignalOnCasadiImport:   # the event: the command line starts importing its heavy modules
        def find_spec(self, name, path=None, target=None):
            if name == "casadi":
                os.kill(os.getpid(), getattr(signal, sys.argv[1]))
            return None
    sys.meta_path.insert(0, SignalOnCasadiImport())
    from coordarm.cli import main
    sys.exit(main(["run", "line", "--quiet", "--no-figures", "--out", sys.argv[2]]))
""")


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_a_signal_while_the_command_line_imports_casadi_exits_130_without_a_traceback(tmp_path, signame):
    res = subprocess.run([sys.executable, "-c", IMPORT_HOOK, signame, str(tmp_path / "x.mcap")],
                         capture_output=True, text=True, timeout=120, preexec_fn=_ignore_sigint)
    assert res.returncode == 130, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("coordarm") and "interrupted" in lines[0], res.stderr
    assert not (tmp_path / "x.mcap").exists()
