"""Point functions for the sweep tests, importable by Dask workers (their PYTHONPATH holds tests/)."""
import os
import time
from pathlib import Path

from coordarm.simulation.sweep_points import run_point


def victim_point(spec, point, log_path=None):
    """Run the point; the first process to get here claims ``MARK_DIR/victim`` and waits to be killed.

    The marker holds the process id; the test kills that worker process with SIGKILL, Dask
    re-runs the task elsewhere (or on the restarted worker), where the claim is taken, so the
    point runs normally. The row records the process that computed it.
    """
    mark = Path(os.environ["COORDARM_SWEEP_MARK_DIR"]) / "victim"
    try:
        fd = os.open(mark, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return {**run_point(spec, point, log_path), "pid": os.getpid()}
    os.write(fd, str(os.getpid()).encode())
    os.close(fd)
    deadline = time.monotonic() + 120.0
    while time.monotonic() < deadline:      # waiting for SIGKILL
        time.sleep(0.05)
    raise RuntimeError("the victim worker was not killed")


def interrupted_after_two(spec, point, log_path=None):
    """Run the point; the third call raises KeyboardInterrupt (like Ctrl-C in a serial sweep)."""
    interrupted_after_two.calls = getattr(interrupted_after_two, "calls", 0) + 1
    if interrupted_after_two.calls == 3:
        raise KeyboardInterrupt
    return run_point(spec, point, log_path)
