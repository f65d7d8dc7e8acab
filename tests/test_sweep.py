"""Parameter sweeps: points, rows against direct runs, resuming, Ctrl-C, figures, the local Dask cluster."""
import io
import math

import numpy as np
import pandas as pd
import pytest

import coordarm
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario
from coordarm.simulation.sweep import RESULTS, SweepProgress, sweep
from coordarm.simulation.sweep_points import (RESULT_COLUMNS, apply_point, grid_points, latin_hypercube_points,
                                              parse_vary)
from coordarm.symbolic import ConfigError, SingularityError

from sweep_helpers import interrupted_after_two

#: 8-link line runs of 2 s: 0.1 m/s completes, 0.5 m/s stretches the chain (longitudinal stop near 1 s).
SMALL = {"links": [8], "speed": [0.1, 0.5], "run.duration": [2.0]}
NUMERIC = ["stop_time", "min_link_margin", "min_longitudinal", "final_max_e", "peak_u"]


def test_parse_vary_reads_lists_and_inclusive_ranges():
    assert parse_vary("links=8,16,32") == ("links", [8, 16, 32])
    assert parse_vary("control.gain=1:4:4") == ("control.gain", [1.0, 2.0, 3.0, 4.0])
    assert parse_vary("control.law=structured,dense") == ("control.law", ["structured", "dense"])
    for bad in ("gain", "gain=", "=1,2", "gain=1:2", "gain=1:2:0", "gain=1:2:2.5", "a..b=1"):
        with pytest.raises(ConfigError):
            parse_vary(bad)


def test_booleans_are_read_as_toml_so_a_switch_can_be_swept():
    assert parse_vary("control.governor=true,false") == ("control.governor", [True, False])
    rows = sweep("line", {"control.governor": [True, False], "run.duration": [0.5], "links": [8]}, client="serial")
    assert list(rows["outcome"]) == ["completed", "completed"]
    with pytest.raises(ConfigError, match="--vary control.governor='True'"):     # refused before any point runs
        sweep("line", {"control.governor": ["True"], "links": [8]}, client="serial")


def test_grid_is_the_cartesian_product_with_the_names_as_given():
    pts = grid_points({"links": [8, 16], "control.gain": [1.0, 2.0, 3.0]})
    assert len(pts) == 6 and pts[0] == {"links": 8, "control.gain": 1.0} and pts[-1] == {"links": 16, "control.gain": 3.0}


def test_latin_hypercube_puts_one_sample_in_each_stratum_of_each_range():
    n = 20
    pts = latin_hypercube_points({"control.gain": [1.0, 5.0], "start.beta": [0.5, 1.5]}, n, seed=7)
    for name, (lo, hi) in (("control.gain", (1.0, 5.0)), ("start.beta", (0.5, 1.5))):
        x = np.array([p[name] for p in pts])
        strata = np.floor((x - lo) / (hi - lo) * n).astype(int)
        assert sorted(strata) == list(range(n))
    assert pts == latin_hypercube_points({"control.gain": [1.0, 5.0], "start.beta": [0.5, 1.5]}, n, seed=7)
    links = latin_hypercube_points({"chain.links": [8, 64]}, 10, seed=1)
    assert all(isinstance(p["chain.links"], int) and 8 <= p["chain.links"] <= 64 for p in links)


def test_apply_point_sets_dotted_fields_and_rejects_unknown_names():
    spec = load_scenario("arc").spec
    sc = apply_point(spec, {"curve.radius": 3.0, "links": 16.0, "gain": 4})
    assert sc.spec["curve"]["radius"] == 3.0 and sc.spec["chain"]["links"] == 16 and sc.spec["control"]["gain"] == 4
    assert isinstance(sc.spec["chain"]["links"], int) and spec["chain"]["links"] == 64
    with pytest.raises(ConfigError, match="not a field"):
        sweep("line", {"curve.nonsense": [1.0]}, client="serial")
    with pytest.raises(ConfigError, match="nothing to vary"):
        sweep("line", {}, client="serial")


def test_rows_match_direct_runs_and_failures_are_rows(tmp_path):
    """Each row against a run simulated here; a start that fails (beta 1.5 breaks the joint limit: a value the
    scenario accepts alone, so not refused before the sweep) is an error row and the sweep goes on."""
    df = coordarm.sweep("line", {**SMALL, "start.beta": [1.3, 1.5]}, client="serial", out=tmp_path)
    assert list(df.columns) == ["links", "speed", "run.duration", "start.beta", *RESULT_COLUMNS]
    assert list(df["outcome"]) == ["completed", "error", "singularity", "error"]
    assert "start.beta" in df["message"][1] and df["message"][0] == ""
    base = load_scenario("line").with_overrides(links=8, duration=2.0)
    for i, v in ((0, 0.1), (2, 0.5)):
        spec = dict(base.spec, control=dict(base.spec["control"], speed=v))
        sc = type(base).from_dict(spec)
        ctrl = sc.controller()
        try:
            run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, thresholds=sc.thresholds)
        except SingularityError as err:
            run = err.run
            assert df["message"][i] == str(err)
        s = run.summary()
        expect = [run.t[-1], s["min_link_margin"], s["min_longitudinal_margin"], s["final_max_abs_e"], s["max_abs_u"]]
        np.testing.assert_allclose(df.loc[i, NUMERIC].to_numpy(float), expect, rtol=1e-12)
    assert df["stop_time"][2] < 2.0 and math.isnan(df["min_clearance"][0])
    saved = pd.read_parquet(tmp_path / RESULTS)
    pd.testing.assert_frame_equal(saved, df)
    csv = pd.read_csv(tmp_path / "results.csv", keep_default_na=False)
    assert list(csv.columns) == list(df.columns) and csv["min_clearance"][0] == ""


def test_a_link_crossing_a_wall_is_a_collision_row():
    wall = {"chain": {"links": 8, "link_length": 0.1}, "curve": {"kind": "line", "point": [0.0, 0.0], "angle": 0.0},
            "control": {"gain": 2.0, "speed": 0.2}, "run": {"duration": 2.0},
            "obstacles": [{"a": [0.45, -1.0], "b": [0.45, 1.0]}]}
    df = sweep(wall, {"speed": [0.01, 0.2]}, client="serial")
    assert list(df["outcome"]) == ["completed", "collision"]
    assert "link 8 touches or crosses 'wall 1'" in df["message"][1]
    assert df["min_clearance"][0] > 0.1 and df["min_clearance"][1] == 0.0     # the run stopped at the contact


def test_rerun_skips_done_points_and_ctrl_c_keeps_finished_rows(tmp_path):
    vary = {"links": [8], "gain": [1.0, 2.0, 3.0, 4.0], "run.duration": [1.0]}
    with pytest.raises(KeyboardInterrupt):
        sweep("line", vary, client="serial", out=tmp_path, point_fn=interrupted_after_two)
    kept = pd.read_parquet(tmp_path / RESULTS)
    assert list(kept["gain"]) == [1.0, 2.0] and set(kept["outcome"]) == {"completed"}
    df = sweep("line", vary, client="serial", out=tmp_path)
    assert list(df["gain"]) == [1.0, 2.0, 3.0, 4.0] and set(df["outcome"]) == {"completed"}
    # the first two rows were read back, not run again (a rerun would measure another wall time)
    np.testing.assert_array_equal(df["wall_time"][:2], kept["wall_time"])
    with pytest.raises(ConfigError, match="different sweep"):
        sweep("arc", vary, client="serial", out=tmp_path)


def test_logs_keeps_one_readable_log_per_point(tmp_path):
    from coordarm.analysis.replay import load

    df = sweep("line", {"links": [8], "gain": [1.0, 3.0], "run.duration": [0.5]}, client="serial", out=tmp_path,
               logs=True)
    logs = sorted((tmp_path / "logs").glob("*.mcap"))
    assert len(logs) == 2 and "gain=3.0" in logs[1].name
    rep = load(logs[1])
    assert rep.outcome["status"] == "completed"
    np.testing.assert_allclose(np.max(np.abs(rep.e[-1])), df["final_max_e"][1], rtol=1e-9)
    with pytest.raises(ConfigError, match="--logs needs --out"):
        sweep("line", {"gain": [1.0]}, client="serial", logs=True)


def test_latin_hypercube_sweep_rows_lie_in_the_ranges_and_resume_with_the_same_seed(tmp_path):
    vary = {"gain": [1, 4], "links": [6, 12], "run.duration": [0.5]}
    df = sweep("line", vary, client="serial", samples=4, seed=3, out=tmp_path)
    assert len(df) == 4 and df["gain"].between(1.0, 4.0).all() and df["links"].between(6, 12).all()
    # control.gain is a float field (drawn as floats even from int bounds), chain.links an int field
    assert df["gain"].nunique() == 4 and (df["gain"] % 1 != 0).all() and (df["links"] % 1 == 0).all()
    assert set(df["outcome"]) == {"completed"}
    again = sweep("line", vary, client="serial", samples=4, seed=3, out=tmp_path)
    np.testing.assert_array_equal(again["wall_time"], df["wall_time"])    # read back, not run again


def test_progress_shows_points_done_and_time_left():
    buf = io.StringIO()
    bar = SweepProgress(10, already=2, stream=buf)
    bar.update(6)
    assert "6/10 points" in buf.getvalue() and "ETA" in buf.getvalue()


def test_figures_one_line_plot_or_one_heat_map_per_pair(tmp_path):
    from coordarm.analysis.sweep_figures import plot_sweep, smallest_margin

    df = pd.DataFrame({"a": [1, 1, 2, 2], "b": [0.1, 0.2, 0.1, 0.2], "c": ["x", "y"] * 2, "d": [5] * 4,
                       "outcome": ["completed", "singularity", "error", "completed"],
                       "min_link_margin": [0.5, 0.3, np.nan, 0.2], "min_longitudinal": [0.4, 0.1, np.nan, 0.6]})
    np.testing.assert_array_equal(smallest_margin(df), [0.4, 0.1, np.nan, 0.2])
    paths = plot_sweep(df, ["a", "b", "c", "d"], tmp_path)     # d is held at one value: no axis
    assert [p.name for p in paths] == ["sweep_a__b.png", "sweep_a__c.png", "sweep_b__c.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)
    (line,) = plot_sweep(df, ["b"], tmp_path)
    assert line.name == "sweep_b.png" and line.stat().st_size > 10_000


def test_sweep_figure_axes_carry_the_units_of_the_varied_names(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    from coordarm.analysis.sweep_figures import axis_label, plot_sweep

    assert axis_label("gain") == "gain [1/s]" and axis_label("control.speed") == "control.speed [m/s]"
    assert axis_label("links") == "links [-]" and axis_label("curve.kind") == "curve.kind"
    seen = []
    monkeypatch.setattr(Figure, "savefig", lambda fig, *a, **k: seen.append(fig))
    df = pd.DataFrame({"gain": [1.0, 1.0, 2.0, 2.0], "speed": [0.1, 0.2, 0.1, 0.2], "outcome": ["completed"] * 4,
                       "min_link_margin": [0.5, 0.3, 0.4, 0.2], "min_longitudinal": [0.4, 0.1, 0.3, 0.6]})
    plot_sweep(df, ["gain", "speed"], tmp_path)
    plot_sweep(df, ["gain"], tmp_path)
    pair, line = seen
    assert [(ax.get_xlabel(), ax.get_ylabel()) for ax in pair.axes[:2]] == [("gain [1/s]", "speed [m/s]")] * 2
    ax = line.axes[0]
    assert ax.get_xlabel() == "gain [1/s]"
    line.canvas.draw()
    assert ax.get_legend().get_window_extent().x0 >= ax.get_window_extent().x1     # the legend off the data


def test_default_local_cluster_gives_the_serial_rows(tmp_path):
    vary = {"links": [8, 12], "gain": [1.0, 3.0], "run.duration": [1.0]}
    local = sweep("line", vary, workers=2, out=tmp_path)
    serial = sweep("line", vary, client="serial")
    cols = ["links", "gain", "outcome", "message"] + NUMERIC
    pd.testing.assert_frame_equal(local[cols], serial[cols], rtol=1e-12)
    assert all(w.startswith("tcp://") for w in local["worker"])


def test_ctrl_c_on_the_command_line_exits_130_and_keeps_the_finished_rows(tmp_path):
    """SIGINT to the process group of a real `coordarm sweep` on a LocalCluster (as a terminal's Ctrl-C does:
    the workers get it too) once a point is done (seen on its progress bar)."""
    import os
    import signal
    import subprocess
    import sys

    cmd = [sys.executable, "-m", "coordarm", "sweep", "line", "--vary", "gain=1:4:40", "--vary", "run.duration=10",
           "--workers", "2", "--batch", "1", "--out", str(tmp_path), "--no-figures"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        for line in proc.stderr:          # off a terminal the bar prints at the first point, then every 10 %
            if "points" in line:
                break
        os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "interrupted" in err
    kept = pd.read_parquet(tmp_path / RESULTS)
    assert 1 <= len(kept) < 40 and set(kept["outcome"]) == {"completed"}


def _sync_interrupted_before_the_call_started() -> list:
    """Reproduce distributed's ``sync`` race for real: a SIGINT reaches the main thread while it waits in
    ``sync`` and the client's loop thread has not yet started the call; returns what tornado logged."""
    import asyncio
    import logging
    import signal
    import sys
    import threading
    import time

    from distributed.utils import LoopRunner, sync

    records = []

    class Keep(logging.Handler):
        def emit(self, record):
            records.append(record)

    log = logging.getLogger("tornado.application")
    keep = Keep()
    log.addHandler(keep)
    runner = LoopRunner(asynchronous=False)
    runner.start()
    gate = threading.Event()
    main = threading.main_thread()

    def interrupt_when_waiting():  # polls the main thread's stack: no sleep racing the start-up
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            frame = sys._current_frames().get(main.ident)
            while frame is not None and not (frame.f_code.co_name == "wait"
                                             and frame.f_code.co_filename.endswith("distributed/utils.py")):
                frame = frame.f_back
            if frame is not None:
                signal.pthread_kill(main.ident, signal.SIGINT)
                return
            time.sleep(0.001)

    # Ctrl-C must raise here even when this process was started with SIGINT ignored (a background job of a
    # non-interactive shell), else `sync` would wait forever for the blocked loop.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        runner.loop.add_callback(gate.wait)           # the loop thread is busy: `sync` cannot start its call
        threading.Thread(target=interrupt_when_waiting, daemon=True).start()
        with pytest.raises(KeyboardInterrupt):
            sync(runner.loop, asyncio.sleep, 0)
        gate.set()
        sync(runner.loop, asyncio.sleep, 0)           # queued after the first call and its `cancel`
    finally:
        gate.set()
        signal.signal(signal.SIGINT, previous)
        runner.stop()
        log.removeHandler(keep)
    return records


def test_the_sync_cancel_race_of_distributed_is_real_and_only_its_record_is_dropped():
    import logging

    from coordarm.simulation.sweep_plugin import SyncCancelRace, drop_sync_cancel_race

    log = logging.getLogger("tornado.application")
    saved = list(log.filters)
    try:
        for f in saved:
            log.removeFilter(f)
        records = _sync_interrupted_before_the_call_started()
        if not records:
            pytest.skip("this distributed no longer logs the sync/cancel race")
        (record,) = records
        assert isinstance(record.exc_info[1], NameError) and "future" in str(record.exc_info[1])
        assert SyncCancelRace().filter(record) is False
        try:                                           # another NameError in a callback still shows
            undefined_name  # noqa: F821
        except NameError:
            import sys
            other = logging.LogRecord("tornado.application", logging.ERROR, __file__, 1, "x", (), sys.exc_info())
        assert SyncCancelRace().filter(other) is True
        drop_sync_cancel_race()
        drop_sync_cancel_race()                        # installed once
        assert sum(isinstance(f, SyncCancelRace) for f in log.filters) == 1
        assert _sync_interrupted_before_the_call_started() == []
    finally:
        for f in list(log.filters):
            log.removeFilter(f)
        for f in saved:
            log.addFilter(f)


def test_a_bad_scheduler_address_is_a_config_error_and_writes_nothing(tmp_path):
    with pytest.raises(ConfigError, match="--scheduler nonsense: cannot connect"):
        sweep("line", {"gain": [1.0]}, client="nonsense", out=tmp_path / "out")
    assert not (tmp_path / "out").exists()


def _heartbeat_to_a_gone_scheduler() -> list:
    """A real worker's heartbeat when nothing listens at its scheduler's address any more (as when the sweep's
    process has closed its scheduler first); returns the records of ``distributed.worker`` at WARNING or above."""
    import asyncio
    import logging
    import socket

    import dask
    from distributed import Scheduler, Worker

    records = []

    class Keep(logging.Handler):
        def emit(self, record):
            if record.levelno >= logging.WARNING:
                records.append(record)

    with socket.socket() as s:                        # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        gone = f"tcp://127.0.0.1:{s.getsockname()[1]}"

    async def beat():
        with dask.config.set({"distributed.comm.timeouts.connect": "0.3s"}):
            async with Scheduler(dashboard_address=None, port=0, host="127.0.0.1") as s:
                async with Worker(s.address, nthreads=1, heartbeat_interval="1h") as w:
                    w.scheduler = w.rpc(gone)
                    await w.heartbeat()

    log = logging.getLogger("distributed.worker")
    keep = Keep()
    log.addHandler(keep)
    try:
        asyncio.run(beat())
    finally:
        log.removeHandler(keep)
    return records


def test_a_local_worker_drops_only_the_heartbeat_record_of_a_gone_scheduler():
    """The record a worker logs when its heartbeat finds the scheduler closed (a loaded machine's Ctrl-C) is dropped
    by the plugin's filter; other records of the worker, and the same message without a lost connection, pass."""
    import logging
    import signal

    from distributed.diagnostics.plugin import WorkerPlugin

    from coordarm.simulation.sweep_plugin import QuietLocalWorker, SchedulerGone

    log = logging.getLogger("distributed.worker")
    saved, sigint = list(log.filters), signal.getsignal(signal.SIGINT)
    try:
        for f in saved:
            log.removeFilter(f)
        records = _heartbeat_to_a_gone_scheduler()
        beats = [r for r in records if r.getMessage().startswith(SchedulerGone.MESSAGE)]
        assert len(beats) == 1 and isinstance(beats[0].exc_info[1], OSError), [r.getMessage() for r in records]
        assert SchedulerGone().filter(beats[0]) is False
        other = logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, "Compute failed", (), None)
        same_text = logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, SchedulerGone.MESSAGE, (), None)
        assert SchedulerGone().filter(other) is True and SchedulerGone().filter(same_text) is True
        plugin = QuietLocalWorker()
        assert isinstance(plugin, WorkerPlugin)
        plugin.setup(None)
        plugin.setup(None)                             # installed once
        assert sum(isinstance(f, SchedulerGone) for f in log.filters) == 1
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        assert not [r for r in _heartbeat_to_a_gone_scheduler() if r.getMessage().startswith(SchedulerGone.MESSAGE)]
    finally:
        signal.signal(signal.SIGINT, sigint)
        for f in list(log.filters):
            log.removeFilter(f)
        for f in saved:
            log.addFilter(f)
