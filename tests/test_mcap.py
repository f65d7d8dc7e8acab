"""The run log: what the plain ``mcap`` library reads from it, metadata, rates, outcomes."""
import json
import struct

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader

from coordarm.analysis.replay import load
from coordarm.simulation.log_schemas import numeric_channels
from coordarm.simulation.cond_channel import ESTIMATE_RATE
from coordarm.simulation.mcap_writer import COND_KINDS, COND_RATE, RunLogger, code_hash, default_cond_rate
from coordarm.symbolic.cond_estimate import DOCUMENTED_FACTOR
from coordarm.simulation.run import Run, simulate
from coordarm.simulation.scenario import Scenario, load_scenario
from coordarm.symbolic import ConfigError, LogError, SingularityError
from coordarm.generated import compile as compile_controller

LINKS, DURATION = 6, 0.6


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("hole").with_overrides(links=LINKS, duration=DURATION)


@pytest.fixture(scope="module")
def logged(scenario, tmp_path_factory):
    """A short run of the ``hole`` preset (it has walls) logged at every step, and what simulate returned
    (``cond`` at 5 Hz: four values in 0.6 s for the bound test, where the 1 Hz default gives one)."""
    path = tmp_path_factory.mktemp("log") / "hole.mcap"
    ctrl = scenario.controller()
    with RunLogger(path, scenario, ctrl, chunk_size=16 * 1024, command=["test"], cond_rate=5.0) as log:
        run = simulate(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, scenario.t0,
                       chunk=97, on_chunk=log.on_chunk)
    return path, run


def test_load_returns_exactly_what_the_run_computed(logged):
    path, run = logged
    rep = load(path)
    for name in ("t", "q", "u", "e", "s", "v_star", "v_scale", "link_margins", "longitudinal"):
        assert np.array_equal(getattr(rep, name), getattr(run, name)), name
    assert rep.recovered is False and rep.problems == []
    assert rep.outcome == {"status": "completed", "t_end": DURATION, "governed": 0.0}


def test_the_plain_mcap_reader_sees_schemas_channels_metadata_and_statistics(logged):
    path, run = logged
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        topics = {c.topic: c for c in summary.channels.values()}
        assert set(topics) == {"/joint_state", "/task_state", "/margins", "/margins/cond", "/scene", "/scene/fixed",
                               "/tf", "/tracking"}
        schemas = {s.id: s for s in summary.schemas.values()}
        scene = topics["/scene"]
        assert topics["/scene/fixed"].schema_id == scene.schema_id      # one SceneUpdate schema for both
        assert scene.message_encoding == "json"
        assert (schemas[scene.schema_id].name, schemas[scene.schema_id].encoding) == ("foxglove.SceneUpdate",
                                                                                      "jsonschema")
        js = topics["/joint_state"]
        assert (schemas[js.schema_id].encoding, js.message_encoding) == ("ros2msg", "cdr")
        text = schemas[js.schema_id].data.decode()   # each field's unit in a comment, then the fields
        assert text == ("# t [s]: simulated time\n# q [rad]: joint angles (d [m] first on a rail)\n"
                        "# u [rad/s]: control u = B^-1 qdot (joint rates for B = I)\n"
                        f"float64 t\nfloat64[{LINKS}] q\nfloat64[{LINKS}] u\n")
        n = len(run.t)
        counts = {c.topic: summary.statistics.channel_message_counts[c.id] for c in topics.values()}
        assert counts["/joint_state"] == counts["/task_state"] == counts["/margins"] == n
        assert counts["/scene"] == counts["/tf"] == counts["/tracking"] == len(range(0, n, 50))
        assert counts["/scene/fixed"] == 1
        assert counts["/margins/cond"] == len(range(0, n, 200))
        assert {c.compression for c in summary.chunk_indexes} == {"lz4"}      # the default compression
        assert summary.statistics.message_end_time == round(DURATION * 1e9)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    assert set(meta) == {"scenario", "build", "run", "outcome"}
    assert meta["build"]["code_hash"] == code_hash() and meta["build"]["casadi"] == "3.8.2"
    assert json.loads(meta["run"]["command"]) == ["test"]


def test_cdr_messages_decode_field_by_field_with_struct(logged):
    path, run = logged
    m = LINKS
    with open(path, "rb") as f:
        msgs = [(msg.log_time, msg.data) for _, ch, msg in make_reader(f).iter_messages(topics=["/joint_state"])]
    for k in (0, 1, len(run.t) // 2, len(run.t) - 1):
        log_time, data = msgs[k]
        assert data[:4] == b"\x00\x01\x00\x00"
        values = struct.unpack(f"<{1 + 2 * m}d", data[4:])
        assert log_time == round(run.t[k] * 1e9)
        assert values[0] == run.t[k] and list(values[1:1 + m]) == list(run.q[k]) and list(values[1 + m:]) == list(run.u[k])


def test_the_scenario_metadata_alone_rebuilds_the_controller(logged, scenario):
    path, run = logged
    rep = load(path)
    assert rep.scenario.spec == scenario.spec
    assert [o.to_spec() for o in rep.scenario.obstacles] == [o.to_spec() for o in scenario.obstacles]
    ctrl = rep.controller()
    k = len(run.t) // 3
    assert run.info["backend"] == "compiled"   # the rebuilt controller compiles to the very same law
    assert np.array_equal(compile_controller(ctrl).control(rep.q[k], float(rep.t[k])), run.u[k])
    np.testing.assert_allclose(ctrl.control(rep.q[k], float(rep.t[k])), run.u[k], rtol=1e-12, atol=1e-12)


def test_cond_channel_is_a_lower_bound_of_the_1_norm_condition_number_of_the_decoupling_matrix(logged, scenario):
    path, run = logged
    rep = load(path)
    ctrl = scenario.controller()
    assert len(rep.cond) == len(range(0, len(run.t), 200))
    assert rep.run_info["cond"] == COND_KINDS[False]
    for tk, c in zip(rep.cond_t, rep.cond):
        k = int(np.flatnonzero(run.t == tk)[0])
        M = np.asarray(ctrl.decoupling_function()(run.q[k], tk)[0])   # by AD, not the structure the log used
        exact = np.linalg.norm(M, 1) * np.linalg.norm(np.linalg.inv(M), 1)
        assert exact / DOCUMENTED_FACTOR <= c <= exact * (1 + 1e-9)


def test_cond_exact_logs_the_2_norm_condition_number_of_the_decoupling_matrix(scenario, tmp_path):
    ctrl = scenario.controller()
    path = tmp_path / "exact.mcap"
    with RunLogger(path, scenario, ctrl, command=["test"], cond_exact=True, cond_rate=20.0) as log:
        run = simulate(ctrl, scenario.start(ctrl), 0.2, scenario.step, scenario.t0, on_chunk=log.on_chunk)
    rep = load(path)
    assert rep.run_info["cond"] == COND_KINDS[True] and len(rep.cond) >= 2
    for tk, c in zip(rep.cond_t, rep.cond):
        k = int(np.flatnonzero(run.t == tk)[0])
        sv = np.linalg.svd(np.asarray(ctrl.decoupling_function()(run.q[k], tk)[0]), compute_uv=False)
        assert c == pytest.approx(sv[0] / sv[-1], rel=1e-9)


def test_log_rate_keeps_every_kth_step_and_the_last(scenario, tmp_path):
    ctrl = scenario.controller()
    path = tmp_path / "rate.mcap"
    with RunLogger(path, scenario, ctrl, log_rate=150.0) as log:  # 1/(150 * 1 ms) -> every 7th step
        run = simulate(ctrl, scenario.start(ctrl), 0.1, scenario.step, on_chunk=log.on_chunk)
    rep = load(path)
    keep = sorted(set(range(0, len(run.t), 7)) | {len(run.t) - 1})
    np.testing.assert_array_equal(rep.t, run.t[keep])
    np.testing.assert_array_equal(rep.q, run.q[keep])


def test_rate_zero_switches_the_scene_and_cond_channels_off(scenario, tmp_path):
    ctrl = scenario.controller()
    path = tmp_path / "off.mcap"
    with RunLogger(path, scenario, ctrl, scene_rate=0, cond_rate=0) as log:
        run = simulate(ctrl, scenario.start(ctrl), 0.1, scenario.step, on_chunk=log.on_chunk)
    with open(path, "rb") as f:
        topics = [ch.topic for _, ch, _ in make_reader(f).iter_messages()]
    assert len(topics) == 3 * len(run.t) and not {"/scene", "/tf", "/tracking", "/margins/cond"} & set(topics)
    assert len(load(path).cond) == 0


@pytest.mark.parametrize("rate", [0.0, -5.0, float("nan"), "fast"])
def test_bad_log_rate_is_a_config_error_before_the_file_exists(scenario, tmp_path, rate):
    with pytest.raises(ConfigError, match="log_rate"):
        RunLogger(tmp_path / "x.mcap", scenario, log_rate=rate)
    assert not (tmp_path / "x.mcap").exists()


def test_a_singularity_is_recorded_as_the_outcome(tmp_path):
    spec = {"name": "fast", "chain": {"links": 8, "link_length": 0.1}, "curve": {"kind": "line"},
            "control": {"gain": 2.0, "speed": 0.4}, "run": {"duration": 5.0}}
    sc = Scenario.from_dict(spec)
    ctrl = sc.controller()
    path = tmp_path / "fast.mcap"
    with pytest.raises(SingularityError) as info:
        with RunLogger(path, sc, ctrl) as log:
            simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, on_chunk=log.on_chunk)
    rep = load(path)
    err = info.value
    assert rep.outcome["status"] == "singularity" and rep.outcome["time"] == err.time
    assert rep.outcome["kind"] == err.kind and rep.outcome["margin"] == err.margin
    assert rep.t[-1] == err.time and np.array_equal(rep.q, err.run.q)


@pytest.mark.parametrize("error", [RuntimeError("solver blew up"), KeyboardInterrupt()])
def test_an_exception_or_ctrl_c_still_leaves_a_closed_log_with_its_outcome(scenario, tmp_path, error):
    ctrl = scenario.controller()
    path = tmp_path / "err.mcap"

    def on_chunk(part):
        log.on_chunk(part)
        if part.t[-1] > 0.05:
            raise error

    with pytest.raises(type(error)):
        with RunLogger(path, scenario, ctrl) as log:
            simulate(ctrl, scenario.start(ctrl), 1.0, scenario.step, chunk=20, on_chunk=on_chunk)
    rep = load(path)
    assert rep.recovered is False and len(rep.t) == 60  # three chunks of 20, the third ends past 0.05 s
    assert rep.outcome["status"] == ("interrupted" if isinstance(error, KeyboardInterrupt) else "error")
    assert rep.outcome["error"] == type(error).__name__


def test_flush_makes_the_samples_so_far_readable_before_the_file_is_closed(scenario, tmp_path):
    ctrl = scenario.controller()
    path = tmp_path / "open.mcap"
    log = RunLogger(path, scenario, ctrl, flush_interval=0.0, threaded=True)
    run = simulate(ctrl, scenario.start(ctrl), 0.2, scenario.step, chunk=50, on_chunk=log.on_chunk)
    log.flush()  # waits for the worker threads' queues
    rep = load(path)  # the writer is still open: no summary, no footer; the file is still the partial one
    assert rep.recovered is True and rep.outcome == {"status": "unknown"} and rep.path == log.writing
    assert log.writing.name == "open.partial.mcap" and not path.exists()
    np.testing.assert_array_equal(rep.q, run.q)
    log.finish()
    assert load(path).recovered is False


def test_stream_reader_of_mcap_reads_the_whole_file_with_crc_checks(logged):
    path, run = logged
    with open(path, "rb") as f:
        n = sum(1 for _ in StreamReader(f, validate_crcs=True).records)
    assert n > 3 * len(run.t)


def test_numeric_channel_layout_matches_its_schema_text():
    ch = numeric_channels(5)["task_state"]
    text = ch.schema_text()
    assert text.endswith("\nfloat64 t\nfloat64 s\nfloat64 v_star\nfloat64[4] e\nfloat64 v_scale\n")
    assert all(line.startswith("# ") for line in text.splitlines()[:-5])   # the comment lines (units) first
    assert ch.width == 8 and ch.size == 4 + 64
    assert ch.slices() == {"t": 0, "s": 1, "v_star": 2, "e": slice(3, 7), "v_scale": 7}


def test_a_failure_on_the_writer_thread_surfaces_as_a_log_error_naming_the_file(scenario, tmp_path):
    path = tmp_path / "bad.mcap"
    log = RunLogger(path, scenario, threaded=True)
    m = LINKS
    bad = Run(np.zeros(3), np.zeros((3, m + 1)), np.zeros((3, m)), np.zeros((3, m - 1)), np.zeros(3),
              np.zeros((3, m - 1)), np.zeros(3), np.zeros(3))
    log.on_chunk(bad)  # q has one column too many: fails on the worker
    with pytest.raises(LogError, match=str(path)):
        log.finish()


def test_lz4_zstd_and_uncompressed_logs_hold_the_same_messages_for_the_plain_reader_and_load(scenario, tmp_path):
    ctrl = scenario.controller()
    paths = {c: tmp_path / f"{c}.mcap" for c in ("zstd", "lz4", "none")}
    for compression, path in paths.items():
        with RunLogger(path, scenario, ctrl, compression=compression, chunk_size=8 * 1024) as log:
            simulate(ctrl, scenario.start(ctrl), 0.3, scenario.step, chunk=64, on_chunk=log.on_chunk)
    seen = {}
    for compression, path in paths.items():
        with open(path, "rb") as f:
            reader = make_reader(f)
            names = {c.compression for c in reader.get_summary().chunk_indexes}
            assert names == {"" if compression == "none" else compression}   # MCAP names no compression ""
            seen[compression] = [(ch.topic, m.log_time, m.data) for _, ch, m in reader.iter_messages()]
    # 3 per step, 7 x (scene, tf, tracking), the fixed scene once, 1 cond (1 Hz: at t = 0 only)
    assert len(seen["lz4"]) == 3 * 301 + 3 * 7 + 1 + 1 and seen["lz4"] == seen["zstd"] == seen["none"]
    assert paths["none"].stat().st_size > paths["zstd"].stat().st_size
    a = load(paths["zstd"])
    for other in ("lz4", "none"):
        b = load(paths[other])
        assert np.array_equal(a.q, b.q) and np.array_equal(a.e, b.e) and np.array_equal(a.cond, b.cond)
    with pytest.raises(ConfigError, match="compression"):
        RunLogger(tmp_path / "x.mcap", scenario, ctrl, compression="gzip")
    assert not (tmp_path / "x.mcap").exists()


def test_exact_cond_rate_defaults_to_1_hz_and_falls_as_one_over_m_squared_past_64_links(tmp_path):
    assert default_cond_rate(8) == default_cond_rate(64) == COND_RATE == 1.0
    assert default_cond_rate(128) == pytest.approx(0.25) and default_cond_rate(1024) == pytest.approx(1 / 256)
    assert default_cond_rate(1025) == default_cond_rate(16384) == 0.0   # an O(m^3) SVD per sample: off
    assert default_cond_rate(256, exact=False) == COND_RATE              # the exact 1-norm: cheap up to 256
    assert default_cond_rate(257, exact=False) == default_cond_rate(16384, exact=False) == ESTIMATE_RATE
    sc = load_scenario("line").with_overrides(links=128)
    with RunLogger(tmp_path / "one.mcap", sc, command=["test"]) as log:   # the 1-norm value: 1 Hz up to 256 links
        assert log.cond_every == round(1 / (COND_RATE * sc.step)) == 1000
    with RunLogger(tmp_path / "big.mcap", sc, command=["test"], cond_exact=True) as log:
        assert log.cond_every == round(1 / (0.25 * sc.step))
        log.on_chunk(Run(*(np.zeros((1, n)) if n else np.zeros(1) for n in (0, 128, 128, 127, 0, 127, 0, 0))))
    assert load(tmp_path / "big.mcap").run_info["cond_every_steps"] == str(log.cond_every)


def test_threaded_and_unthreaded_loggers_write_the_same_log(scenario, tmp_path):
    ctrl = scenario.controller()
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    for path, threaded in ((a, True), (b, False)):
        with RunLogger(path, scenario, ctrl, threaded=threaded) as log:
            simulate(ctrl, scenario.start(ctrl), 0.3, scenario.step, chunk=64, on_chunk=log.on_chunk)
    ra, rb = load(a), load(b)
    assert np.array_equal(ra.q, rb.q) and np.array_equal(ra.cond, rb.cond) and ra.messages == rb.messages


def test_coordarm_run_writes_the_log_at_the_chosen_rate_with_a_singularity_outcome(tmp_path, capsys):
    from coordarm.cli import main
    toml = tmp_path / "fast.toml"
    toml.write_text('name = "fast"\n[chain]\nlinks = 8\nlink_length = 0.1\n[curve]\nkind = "line"\n'
                    '[control]\ngain = 2.0\nspeed = 0.4\n[run]\nduration = 5.0\n')
    out = tmp_path / "fast.mcap"
    assert main(["run", str(toml), "--quiet", "--no-figures", "--log-rate", "100", "--out", str(out)]) == 3
    assert f"log           {out}" in capsys.readouterr().out
    rep = load(out)
    assert rep.outcome["status"] == "singularity" and rep.outcome["kind"] == "longitudinal"
    assert rep.t[-1] == rep.outcome["time"]  # the offending state is logged although off the 100 Hz grid
    np.testing.assert_allclose(np.diff(rep.t[:-1]), 0.01, rtol=1e-9)
    assert rep.scenario.spec["control"]["speed"] == 0.4 and rep.run_info["log_every_steps"] == "10"


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_ctrl_c_arriving_while_a_chunk_is_written_is_held_back_until_the_block_is_logged(scenario, tmp_path,
                                                                                         signame):
    import os
    import signal

    from coordarm.symbolic import interrupts
    ctrl = scenario.controller()
    path = tmp_path / "sigint.mcap"
    log = RunLogger(path, scenario, ctrl, chunk_size=4096)
    write = log.file.write_chunk

    def write_then_ctrl_c(records, index):  # a real SIGINT to this process in the middle of on_chunk
        if len(log.file._chunk_indexes) == 2:
            os.kill(os.getpid(), getattr(signal, signame))
        write(records, index)

    log.file.write_chunk = write_then_ctrl_c
    with pytest.raises(KeyboardInterrupt), interrupts.handled():  # also from a job with SIGINT ignored
        with log:
            simulate(ctrl, scenario.start(ctrl), 0.5, scenario.step, chunk=100, on_chunk=log.on_chunk)
    rep = load(path)
    assert rep.outcome["status"] == "interrupted" and rep.problems == [] and rep.recovered is False
    assert rep.t[-1] == rep.outcome["t_end"] and len(rep.t) % 100 == 0  # whole blocks only
    np.testing.assert_allclose(np.diff(rep.t), scenario.step, rtol=1e-9)


def test_every_field_of_every_numeric_channel_says_its_unit_in_the_schema():
    from coordarm.simulation.log_layout import SPATIAL
    from coordarm.simulation.log_schemas import numeric_channels
    for kw in ({}, {"rail": True}, {"layout": SPATIAL}):
        for ch in numeric_channels(5, **kw).values():
            noted = {line[2:].split(" [")[0] for line in ch.schema_text().splitlines() if line.startswith("# ")}
            assert {name for name, _ in ch.fields} <= noted, (kw, ch.topic)
