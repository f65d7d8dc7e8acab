"""Reading logs back: a killed run, truncated, bit-flipped and foreign files, ``coordarm replay``."""
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from coordarm.analysis.replay import load
from coordarm.cli import main
from coordarm.simulation.run import simulate
from coordarm.simulation import mcap_writer
from coordarm.simulation.log_layout import partial_path
from coordarm.symbolic import LogError

SWING = """name = "swing"
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
duration = 100000.0
"""


@pytest.fixture(scope="module")
def full_log(tmp_path_factory):
    """A complete log written by ``coordarm run`` (line preset, 8 links, 1.5 s) and its bytes."""
    return _small_run(tmp_path_factory.mktemp("replay") / "line.mcap")


def _small_run(path, *options: str):
    """``coordarm run line`` of 8 links for 1.5 s into ``path``, in several 256 KiB chunks (the default
    1 MiB would make one); the log and its bytes."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(mcap_writer, "CHUNK_SIZE", 256 * 1024)
        assert main(["run", "line", "--links", "8", "--duration", "1.5", "--quiet", "--no-figures", *options,
                     "--out", str(path)]) == 0
    return path, path.read_bytes()


@pytest.fixture(scope="module")
def lz4_log(tmp_path_factory):
    """The same run as ``full_log``, its chunks lz4-compressed, ``cond`` at 2 Hz."""
    return _small_run(tmp_path_factory.mktemp("replay") / "line_lz4.mcap", "--compression", "lz4",
                      "--cond-rate", "2")


def test_the_cli_writes_lz4_chunks_and_cond_at_the_chosen_rate(full_log, lz4_log):
    a, b = load(full_log[0]), load(lz4_log[0])
    assert np.array_equal(a.q, b.q) and np.array_equal(a.u, b.u)
    np.testing.assert_array_equal(b.cond_t, [0.0, 0.5, 1.0, 1.5])
    with open(lz4_log[0], "rb") as f:
        assert {c.compression for c in make_reader(f).get_summary().chunk_indexes} == {"lz4"}


def _start_and_wait_for_flushes(tmp_path):
    """Start ``coordarm run`` on a long scenario; return the process once its unfinished log,
    read back by :func:`load`, holds the scenario and more than 1000 samples (polled: no wall-time
    guess of when the writer flushed, which a loaded machine can delay)."""
    toml = tmp_path / "swing.toml"
    toml.write_text(SWING)
    out = tmp_path / "swing.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "coordarm", "run", str(toml), "--quiet", "--no-figures", "--yes",
                             "--out", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    writing = partial_path(out)  # the log's name until it is closed
    start = time.monotonic()
    while time.monotonic() - start < 120:
        time.sleep(0.1)
        if proc.poll() is not None:
            raise AssertionError(proc.stderr.read().decode())
        if not writing.exists() or writing.stat().st_size < 50_000:
            continue
        try:
            rep = load(out)
        except LogError:  # no complete chunk or no scenario yet
            continue
        if rep.scenario is not None and len(rep.t) > 1000:
            return proc, out
    proc.kill()
    raise AssertionError("the run's log never held 1000 samples within 120 s")


def test_a_run_killed_with_sigkill_leaves_a_log_that_load_recovers(tmp_path):
    proc, out = _start_and_wait_for_flushes(tmp_path)
    try:
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert not out.exists()
    rep = load(out)  # falls back to the partial file, and says so
    assert rep.recovered is True and rep.outcome == {"status": "unknown"} and rep.path == partial_path(out)
    assert "read the unfinished swing.partial.mcap" in rep.problems[0]
    assert len(rep.t) > 1000
    np.testing.assert_allclose(np.diff(rep.t), rep.scenario.step, rtol=1e-6)  # no gap
    assert rep.t[0] == 0.0
    # The recovered samples are those of the same run made again in this process.
    sc = rep.scenario
    ctrl = sc.controller()
    n = len(rep.t) - 1
    run = simulate(ctrl, sc.start(ctrl), n * sc.step, sc.step, sc.t0)
    np.testing.assert_array_equal(rep.t, run.t)
    np.testing.assert_array_equal(rep.q, run.q)
    np.testing.assert_array_equal(rep.e, run.e)


def test_a_log_cut_after_some_chunks_gives_back_exactly_its_complete_samples(full_log, tmp_path):
    path, data = full_log
    full = load(path)
    with open(path, "rb") as f:
        chunks = sorted(make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset)
    assert len(chunks) >= 3
    cut_file = tmp_path / "cut.mcap"
    for cut in (chunks[1].chunk_start_offset + 10,                       # inside the second chunk
                chunks[2].chunk_start_offset,                           # right after the second chunk's index
                len(data) - 3):                                         # only the end magic lost
        cut_file.write_bytes(data[:cut])
        rep = load(cut_file)
        assert rep.recovered is True
        k = len(rep.t)
        assert k > 0 and np.array_equal(rep.t, full.t[:k]) and np.array_equal(rep.q, full.q[:k])
        assert np.array_equal(rep.link_margins, full.link_margins[:k])
    assert k == len(full.t)


@pytest.mark.parametrize("cut", [0, 5, 8, 40, 300])
def test_a_log_cut_before_its_first_sample_is_a_log_error_naming_the_file(full_log, tmp_path, cut):
    path, data = full_log
    bad = tmp_path / "early.mcap"
    bad.write_bytes(data[:cut])
    with pytest.raises(LogError, match=str(bad)):
        load(bad)


@pytest.mark.parametrize("log", ["full_log", "lz4_log"])
def test_a_bit_flip_inside_a_chunk_skips_that_chunk_only_and_reports_it(log, tmp_path, request, capsys):
    path, data = request.getfixturevalue(log)
    full = load(path)
    with open(path, "rb") as f:
        reader = make_reader(f)
        chunks = sorted(reader.get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset)
    for which in (0, 2):
        c = chunks[which]
        flipped = bytearray(data)
        flipped[c.chunk_start_offset + c.chunk_length - 50] ^= 0x10  # inside the compressed records
        bad = tmp_path / f"flip{which}.mcap"
        bad.write_bytes(bytes(flipped))
        rep = load(bad)
        assert rep.damaged and not rep.recovered
        assert len(rep.problems) >= 1 and f"chunk at byte {c.chunk_start_offset} skipped" in rep.problems[0]
        # Exactly the samples of the other chunks remain, unchanged.
        t0, t1 = c.message_start_time / 1e9, c.message_end_time / 1e9
        keep = (full.t < t0 - 1e-12) | (full.t > t1 + 1e-12)
        np.testing.assert_array_equal(rep.t, full.t[keep])
        np.testing.assert_array_equal(rep.q, full.q[keep])
        assert 0 < len(rep.t) < len(full.t)
        # replay and report say so on stderr and still finish
        assert main(["report", str(bad), "--out", str(tmp_path / f"r{which}"), "--samples", "50"]) == 0
        assert "the log is damaged" in capsys.readouterr().err


@pytest.mark.parametrize("content", [b"", b"\x89PNG\r\n\x1a\n" + bytes(200), b"just some text\n" * 20],
                         ids=["empty", "png", "text"])
def test_foreign_files_are_log_errors_and_the_cli_exits_2_without_traceback(tmp_path, capsys, content):
    bad = tmp_path / "foreign.mcap"
    bad.write_bytes(content)
    with pytest.raises(LogError, match=str(bad)):
        load(bad)
    assert main(["replay", str(bad), "--no-animation"]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "Traceback" not in err


def test_an_mcap_file_from_another_tool_is_not_a_coordarm_log(tmp_path):
    other = tmp_path / "other.mcap"
    with open(other, "wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema("x", "jsonschema", b"{}")
        cid = w.register_channel("/x", "json", sid)
        w.add_message(cid, log_time=1, data=b"{}", publish_time=1)
        w.finish()
    with pytest.raises(LogError, match="not a coordarm run log"):
        load(other)


def test_missing_file_is_a_log_error(tmp_path):
    with pytest.raises(LogError, match="no such log file"):
        load(tmp_path / "nope.mcap")


def test_replay_cli_redraws_figures_and_writes_an_animation_from_the_log_alone(full_log, tmp_path, capsys):
    path, _ = full_log
    out = tmp_path / "figs"
    assert main(["replay", str(path), "--out", str(out), "--fps", "4"]) == 0
    text = capsys.readouterr().out
    assert "outcome       completed" in text and "final max|e|" in text
    assert (out / "line_stages.png").stat().st_size > 10_000
    assert (out / "line_tracking.png").stat().st_size > 10_000
    gif = (out / "line.gif").read_bytes()
    assert gif[:6] == b"GIF89a"


def test_animation_frames_show_time_and_progress_and_a_bar_on_stderr(full_log, tmp_path, capsys):
    from PIL import Image

    from coordarm.analysis.animation import animate, frame_indices
    path, _ = full_log
    rep = load(path)
    gif = animate(rep, tmp_path / "a.gif", fps=4)
    err = capsys.readouterr().err
    assert "animation [" in err and "100.0%" in err and "frame" in err
    frames = len(frame_indices(rep.t, 4, 200))
    with Image.open(gif) as im:
        assert im.n_frames == frames
        im.seek(0)
        first = np.asarray(im.convert("RGB")).astype(int)
        im.seek(frames - 1)
        last = np.asarray(im.convert("RGB")).astype(int)
    green = lambda a: np.sum((a[..., 1] > 120) & (a[..., 0] < 90) & (a[..., 2] < 90))  # noqa: E731
    assert green(last) > green(first) + 100          # the progress bar grows along the run


def test_replay_stages_option_draws_the_chosen_times(full_log, tmp_path, capsys):
    path, _ = full_log
    out = tmp_path / "st"
    assert main(["replay", str(path), "--out", str(out), "--no-animation", "--stages", "0,0.5"]) == 0
    assert (out / "line_stages.png").stat().st_size > 10_000
    with pytest.raises(SystemExit) as info:
        main(["replay", str(path), "--stages", "0,x"])
    assert info.value.code == 2 and "--stages" in capsys.readouterr().err


def test_stage_indices_pick_the_samples_nearest_to_the_times():
    from coordarm.simulation.figures import stage_indices
    from coordarm.simulation.run import Run
    t = np.linspace(0, 2, 201)
    z = np.zeros((201, 2))
    run = Run(t, z, z, z[:, :1], t, z[:, :1], t, t)
    np.testing.assert_array_equal(stage_indices(run, times=[0.0, 0.504, 1.5, 7.0]), [0, 50, 150])


def test_replay_cli_reads_a_cut_log_and_says_so(full_log, tmp_path, capsys):
    _, data = full_log
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    assert main(["replay", str(cut), "--no-animation"]) == 0
    assert "the log is cut off" in capsys.readouterr().err


def test_a_lost_chunk_in_the_middle_shows_as_sequence_gaps(tmp_path):
    from coordarm.simulation.mcap_writer import RunLogger
    from coordarm.simulation.scenario import load_scenario
    sc = load_scenario("line").with_overrides(links=4, duration=0.3)
    ctrl = sc.controller()
    path = tmp_path / "gap.mcap"
    log = RunLogger(path, sc, ctrl, chunk_size=4096, threaded=False)
    write, calls = log.file.write_chunk, []

    def drop_the_third(records, index):  # fault injection: the third chunk never reaches the file
        calls.append(1)
        if len(calls) != 3:
            write(records, index)

    log.file.write_chunk = drop_the_third
    with log:
        run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, on_chunk=log.on_chunk)
    rep = load(path)
    lost = len(run.t) - len(rep.t)
    assert lost > 0 and rep.recovered is False
    assert any(p.startswith("/joint_state: ") and f"{lost} message(s) missing" in p for p in rep.problems)


def _red(frame):
    """Pixels of the contact marks' red (#d62728) in a GIF frame."""
    rgb = np.asarray(frame.convert("RGB"), float)
    return np.linalg.norm(rgb - [214, 39, 40], axis=-1) < 40


def test_the_gif_marks_a_recorded_contact_from_its_time_on_and_reddens_the_body_in_its_frame(full_log, tmp_path):
    from PIL import Image

    from coordarm.analysis.animation import animate, frame_contacts, frame_indices
    path, _ = full_log
    rep = load(path)
    rows = frame_indices(rep.t, 4, 200)
    when = float(rep.t[rows[3]]) - 0.01                  # between frames 2 and 3
    rep.outcome = dict(rep.outcome, contacts=[{"kind": "wall", "time": when, "links": [4], "obstacle": "wall X"}])
    gif = animate(rep, tmp_path / "c.gif", fps=4, progress=False)
    with Image.open(gif) as im:
        red = []
        for k in range(im.n_frames):
            im.seek(k)
            red.append(_red(im))
    legend = red[0]                                      # the legend's ring, in every frame
    assert 0 < legend.sum() < 200 and (red[2] == legend).all()        # nothing else before the contact
    red = [r & ~legend for r in red]
    assert red[3].sum() > 3 * red[4].sum() > 0           # its frame: the ring and the whole body red; then the ring
    ring = [np.argwhere(r).mean(axis=0) for r in red[4:]]
    assert np.ptp(ring, axis=0).max() < 1.0              # the ring stays where the link touched
    assert frame_contacts(np.array([when]), rep.t[rows], 2) == (slice(0, 0), "")
    assert frame_contacts(np.array([when]), rep.t[rows], 3) == (slice(0, 1), ", contacts: 1 so far (contact)")
    assert frame_contacts(np.array([when]), rep.t[rows], 4) == (slice(0, 1), ", contacts: 1 so far")
