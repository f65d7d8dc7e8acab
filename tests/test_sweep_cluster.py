"""Sweeps on a real external Dask cluster: a `dask scheduler` and two `dask worker` processes.

Each worker has its own empty build cache (like a fresh machine): the compiled controller
is never shipped, every worker builds it. Readiness is polled on the scheduler, never slept.
"""
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from coordarm.simulation.sweep import RESULTS, sweep

from sweep_helpers import victim_point

BIN = Path(sys.executable).parent
TESTS = Path(__file__).parent
NUMERIC = ["stop_time", "min_link_margin", "min_longitudinal", "final_max_e", "peak_u"]


def _poll(predicate, timeout: float, what: str):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.05)
    raise TimeoutError(f"{what} not ready after {timeout} s")


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """``(address, worker build dirs, marker dir)`` of a scheduler and two single-threaded workers."""
    from distributed import Client

    root = tmp_path_factory.mktemp("dask_cluster")
    sched_file, marks = root / "scheduler.json", root / "marks"
    marks.mkdir()
    path = os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")])   # the scheduler unpickles tasks too
    procs = [subprocess.Popen([str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
                               "--no-dashboard", "--scheduler-file", str(sched_file)],
                              env=dict(os.environ, PYTHONPATH=path),
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    builds = []
    try:
        _poll(lambda: sched_file.is_file() and sched_file.stat().st_size > 0, 60, "scheduler file")
        address = json.loads(sched_file.read_text())["address"]
        for i in range(2):
            builds.append(root / f"build{i}")
            env = dict(os.environ, COORDARM_BUILD_DIR=str(builds[-1]), COORDARM_SWEEP_MARK_DIR=str(marks),
                       PYTHONPATH=path)
            procs.append(subprocess.Popen([str(BIN / "dask"), "worker", address, "--nthreads", "1",
                                           "--nworkers", "1", "--no-dashboard", "--name", f"w{i}",
                                           "--local-directory", str(root / f"work{i}")],
                                          env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)   # polls the scheduler
        yield address, builds, marks
    finally:
        for p in reversed(procs):
            p.send_signal(signal.SIGTERM)
        for p in reversed(procs):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def test_cli_sweep_on_an_external_scheduler_gives_the_serial_rows(cluster, tmp_path):
    address, builds, _ = cluster
    args = ["--vary", "links=8,12", "--vary", "control.gain=1,3", "--vary", "run.duration=1", "--batch", "1"]
    res = subprocess.run([sys.executable, "-m", "coordarm", "sweep", "line", *args, "--scheduler", address,
                          "--out", str(tmp_path), "--quiet"], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert "4 points, 4 completed" in res.stdout
    remote = pd.read_parquet(tmp_path / RESULTS)
    serial = sweep("line", {"links": [8, 12], "control.gain": [1, 3], "run.duration": [1]}, client="serial")
    cols = ["links", "control.gain", "run.duration", "outcome", "message"] + NUMERIC
    pd.testing.assert_frame_equal(remote[cols], serial[cols], check_dtype=False, rtol=1e-12)
    assert all(w.startswith("tcp://127.0.0.1:") for w in remote["worker"])
    assert (tmp_path / "sweep_links__control.gain.png").stat().st_size > 10_000
    # the workers compiled the controllers in their own caches (nothing compiled was shipped)
    built = [list(b.glob("*/libcoordarm.so")) for b in builds if b.is_dir()]
    assert sum(len(x) for x in built) >= 2


def test_points_of_a_killed_worker_are_run_elsewhere(cluster):
    """SIGKILL the worker process running a point: Dask re-runs it, every point gets a completed row."""
    from distributed import Client

    address, _, marks = cluster
    victim = marks / "victim"
    killed = []

    def killer():
        pid = int(_poll(lambda: victim.is_file() and victim.read_text(), 120, "victim marker"))
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)

    thread = threading.Thread(target=killer, daemon=True)
    thread.start()
    with Client(address, timeout=60) as client:
        df = sweep("line", {"links": [8], "gain": [1.0, 2.0, 3.0, 4.0], "run.duration": [0.5]}, client=client,
                   batch=1, point_fn=victim_point)
    thread.join(timeout=5)
    assert killed, f"the victim was never killed: {df['message'].tolist()}"
    assert list(df["outcome"]) == ["completed"] * 4, df["message"].tolist()
    assert killed[0] not in set(df["pid"])
    np.testing.assert_array_equal(df["gain"], [1.0, 2.0, 3.0, 4.0])
