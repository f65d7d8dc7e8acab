"""The exported law is the compiled law: the same flags, bit-identical ``u``; the real-time example runs."""
from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from coordarm.cli import main as cli_main
from coordarm.generated import compile as compile_controller
from coordarm.generated.build import DEFAULT_FLAGS
from coordarm.simulation.scenario import load_scenario

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
STEPS = 3


def exported_rows(tmp_path, m):
    out = tmp_path / f"line{m}"
    assert cli_main(["export", "line", "--links", str(m), "--duration", "0.5", "--out", str(out)]) == 0
    res = subprocess.run(["make", "-C", str(out), "example"], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr
    run = subprocess.run([str(out / "example"), str(STEPS)], capture_output=True, text=True, check=True)
    return out, np.array([[float(v) for v in line.split()] for line in run.stdout.splitlines()])


def test_the_makefile_compiles_with_the_compiled_laws_flags_in_gnu_mode(tmp_path):
    out = tmp_path / "x"
    assert cli_main(["export", "line", "--links", "4", "--out", str(out)]) == 0
    make = (out / "Makefile").read_text()
    assert re.search(r"^CFLAGS \?= (.*)$", make, re.M).group(1).split() == list(DEFAULT_FLAGS)
    assert re.search(r"^STD +\?= -std=gnu99$", make, re.M)          # ISO -std=c99 turns FMA contraction off
    assert "-std=c99" not in re.search(r"^WARN.*$", make, re.M).group(0)
    assert "-fvisibility=hidden" in re.search(r"^SHARED.*$", make, re.M).group(0)


@pytest.mark.parametrize("m", [8, 64, 1024])
def test_exported_u_is_bit_identical_to_the_law_the_simulation_runs(tmp_path, m):
    _, rows = exported_rows(tmp_path, m)
    scenario = load_scenario("line").with_overrides(m, 0.5, None)
    ctrl = scenario.controller()
    comp = compile_controller(ctrl)
    T, Q, U = rows[:, 0], rows[:, 1:m + 1], rows[:, m + 1:2 * m + 1]
    assert np.array_equal(Q[0], scenario.start(ctrl))
    for k in range(STEPS + 1):
        np.testing.assert_array_equal(U[k], comp.control(Q[k], T[k]))
    # the example's RK4 loop is the simulator's: the compiled chunk gives the very same states
    Qc, _ = comp.chunk(Q[0], T[:-1], scenario.step)
    np.testing.assert_array_equal(Qc, Q[1:])


def test_the_real_time_example_builds_runs_a_few_hundred_cycles_and_prints_percentiles(tmp_path):
    out = tmp_path / "rt"
    assert cli_main(["export", "line", "--links", "16", "--out", str(out)]) == 0
    res = subprocess.run(["make", "-C", str(out), "example_rt", "WARN=-std=c99 -Wall -Wextra -Werror"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr
    for env in ({}, {"COORDARM_RT": "0"}):
        run = subprocess.run([str(out / "example_rt"), "300", "2000"], capture_output=True, text=True, check=True,
                             env={"PATH": "/usr/bin:/bin", **env}, timeout=60)
        text = run.stdout
        assert "300 cycles at 2000 Hz, 16 joints" in text
        if env:
            assert "SCHED_OTHER (COORDARM_RT=0)" in text
        else:   # real-time priority where permitted, else a message and normal priority
            assert ("SCHED_FIFO priority" in text) or ("not permitted" in text and "normal priority" in run.stderr)
        for what in ("law [us]", "wake-up [us]"):
            line = next(ln for ln in text.splitlines() if ln.startswith(what))
            p50, p99, p999, top = (float(v) for v in re.findall(r"(?:p50|p99|p99\.9|max) +([0-9.]+)", line))
            assert 0 <= p50 <= p99 <= p999 <= top
    bad = subprocess.run([str(out / "example_rt")], capture_output=True, text=True)
    assert bad.returncode == 1 and "usage" in bad.stderr
    bad = subprocess.run([str(out / "example_rt"), "10", "-5"], capture_output=True, text=True)
    assert bad.returncode == 1 and "RATE_HZ" in bad.stderr
