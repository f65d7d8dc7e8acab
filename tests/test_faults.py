"""Faults end in one clear line and exit 2, never a traceback: the reproducers of the fault campaign."""
import json
import os
import stat
import sys
from pathlib import Path

import pytest

from coordarm.analysis.replay import load
from coordarm.cli import main
from coordarm.simulation.limits import RK4_LIMIT, estimate, sampled_limit
from coordarm.simulation.log_layout import partial_path
from coordarm.simulation.mcap_file import McapFile
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic import LogError
from coordarm.symbolic.errors import shown

SMALL = ["--links", "6", "--duration", "0.05", "--quiet", "--no-figures"]
TOML = ('name = "t"\n[chain]\nlinks = 6\nlink_length = {length}\n[curve]\nkind = "line"\n'
        '[control]\ngain = {gain}\nspeed = 0.0\n[run]\nduration = 0.05\nstep = {step}\nt0 = {t0}\n')
VALID = {"gain": "2.0", "step": "0.001", "t0": "0.0", "length": "0.1"}


@pytest.fixture(scope="module")
def small_log(tmp_path_factory):
    path = tmp_path_factory.mktemp("faults") / "small.mcap"
    assert main(["run", "line", *SMALL, "--out", str(path)]) == 0
    return path


def one_line_error(capsys, *words):
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "error" in ln]
    assert len(lines) == 1 and "Traceback" not in err, err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


@pytest.mark.parametrize("argv, words", [
    (["run", "line", "--links", "100000"], ["memory", "--yes does not lift"]),
    (["run", "line", "--links", "99999999999999999999"], ["chain.links"]),
    (["run", "line", "--step", "5e-324"], ["run.step"]),
    (["run", "line", "--step", "1e-9", "--duration", "0.05"], ["run.step"]),
    (["run", "line", "--duration", "1e300"], ["run.duration"]),
    (["run", "line", "--step", "1e-6", "--duration", "1000"], ["--yes", "steps"]),
    (["run", "arc", "--law", "dense", "--links", "200"], ["--law dense", "--yes"]),
    (["replay", "LOG", "--fps", "inf"], ["--fps"]),
    (["replay", "LOG", "--fps", "1e-9"], ["--fps"]),
    (["replay", "LOG", "--fps", "1e9"], ["--fps"]),
    (["report", "LOG", "--samples", "-5"], ["--samples"]),
    (["report", "line", "--duration", "1e6"], ["--yes", "memory"]),
    (["replay", "LOG", "--out", "LOG"], ["--out", "is a file"]),
    (["report", "LOG", "--out", "LOG"], ["--out", "is a file"]),
    (["run", "line", *SMALL, "--out", "/dev/full"], ["/dev/full", "not a regular file"]),
    (["run", "line", *SMALL, "--out", "LOG/sub/x.mcap"], ["--out", "directory"]),
    (["run", "line", *SMALL, "--out", "LOG"], ["exists", "--overwrite"]),
])
def test_bad_arguments_give_one_line_naming_the_flag_or_field_and_exit_2(argv, words, small_log, capsys):
    argv = [str(small_log) if a == "LOG" else a.replace("LOG", str(small_log)) for a in argv]
    before = small_log.read_bytes()
    assert main(argv) == 2
    one_line_error(capsys, *words)
    assert small_log.read_bytes() == before  # never clobbered


@pytest.mark.parametrize("fields, words", [
    ({"t0": "1e300"}, ["run.t0"]),
    ({"t0": "1e11"}, ["run.t0"]),
    ({"t0": "1e6", "step": "1e-12"}, ["run.step"]),
    ({"gain": "2800.0"}, ["K h", "2.8", "RK4"]),
    ({"gain": "nan"}, ["control.gain"]),
    ({"length": "1e-300"}, ["chain.link_length"]),
])
def test_numbers_that_would_silently_go_wrong_are_refused(fields, words, tmp_path, capsys):
    toml = tmp_path / "bad.toml"
    toml.write_text(TOML.format(**{**VALID, **fields}))
    assert main(["run", str(toml), "--quiet", "--no-figures", "--out", str(tmp_path / "x.mcap")]) == 2
    one_line_error(capsys, str(toml), *words)
    assert not (tmp_path / "x.mcap").exists()


def test_gain_step_limits_agree_with_the_closed_forms():
    # K h = 2.8 with a 1 ms step: beyond RK4 (2.7853) and the sampled-data limit (2)
    assert sampled_limit(0) == 2.0 and sampled_limit(1) == pytest.approx(1.0)
    assert 2.78 < RK4_LIMIT < 2.79
    r = 1 - RK4_LIMIT + RK4_LIMIT**2 / 2 - RK4_LIMIT**3 / 6 + RK4_LIMIT**4 / 24
    assert r == pytest.approx(1.0, abs=1e-12)


def test_a_gain_beyond_the_sampled_limit_but_within_rk4_warns_before_the_run(tmp_path, capsys):
    toml = tmp_path / "warn.toml"
    toml.write_text(TOML.format(**{**VALID, "gain": "2500.0"}))   # K h = 2.5
    main(["run", str(toml), "--quiet", "--no-figures", "--out", str(tmp_path / "w.mcap")])
    err = capsys.readouterr().err
    assert err.count("K h = 2.5 >= 2") == 1 and "Traceback" not in err


def test_deeply_nested_toml_and_huge_values_are_config_errors(tmp_path, capsys):
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 2000 + "]" * 2000 + "\n")
    assert main(["run", str(deep)]) == 2
    one_line_error(capsys, str(deep))
    long = tmp_path / "long.toml"
    long.write_text(TOML.format(**{**VALID, "gain": '"' + "x" * 10_000 + '"'}))
    assert main(["run", str(long)]) == 2
    line = one_line_error(capsys, "control.gain")
    assert len(line) < 300   # the value echoed is cut to 80 characters


def test_shown_cuts_values_to_80_characters():
    assert shown("x" * 10) == repr("x" * 10)
    assert len(shown("x" * 1000)) == 80 and shown("x" * 1000).endswith("...")


def test_estimate_counts_steps_and_log_bytes():
    cost = estimate(64, 0.001, 200.0)
    assert cost.steps == 200_000
    # /joint_state (t, q, u), /task_state (t, s, v*, e, v_scale), /margins (t, m-1 links, longitudinal):
    # (1 + 2m) + (4 + m - 1) + (2 + m - 1) = 4m + 5 floats, plus 3 x (23-byte message header + 4 CDR + 9 record)
    assert cost.log_bytes == 200_001 * ((4 * 64 + 5) * 8 + 3 * 35)
    assert estimate(64, 0.001, 200.0, log_rate=100).log_bytes == 20_001 * ((4 * 64 + 5) * 8 + 3 * 35)


def _rewrite_metadata(path: Path, name: str, edit) -> bytes:
    """The log's bytes with one metadata record's JSON edited in place (same length)."""
    data = path.read_bytes()
    rep = load(path)
    old = {"scenario": rep.scenario_dict}.get(name)
    text = json.dumps(old, sort_keys=True).encode()
    assert data.count(text) == 1
    new = edit(text)
    assert len(new) == len(text)
    return data.replace(text, new)


def test_a_flipped_value_in_the_scenario_metadata_is_caught_by_its_sha256(small_log, tmp_path, capsys):
    bad = tmp_path / "flip.mcap"
    bad.write_bytes(_rewrite_metadata(small_log, "scenario", lambda t: t.replace(b'"gain": 2.0', b'"gain": 3.0')))
    with pytest.raises(LogError, match="'scenario' metadata record is damaged"):
        load(bad)
    assert main(["replay", str(bad), "--no-animation"]) == 2
    one_line_error(capsys, "scenario", "SHA-256")


def test_outcome_metadata_that_is_not_json_is_a_log_error(small_log, tmp_path):
    sc = load_scenario("line").with_overrides(links=4, duration=0.01)
    path = tmp_path / "odd.mcap"
    log = RunLogger(path, sc)
    log.finish()
    # a writer that stored a non-JSON outcome with a valid checksum
    f = McapFile(tmp_path / "odd2.mcap")
    for name in ("scenario",):
        f.add_metadata(name, {"json": sc.to_json(), "source": "x"})
    f.add_metadata("outcome", {"status": "{not json"})
    f.close()
    with pytest.raises(LogError, match="'outcome' metadata holds a value that is not JSON"):
        load(tmp_path / "odd2.mcap")
    deep = McapFile(tmp_path / "deep.mcap")   # scenario JSON nested far deeper than the recursion limit
    deep.add_metadata("scenario", {"json": "[" * 100_000 + "]" * 100_000, "source": "x"})
    deep.close()
    with pytest.raises(LogError, match="'scenario' metadata is not a valid scenario"):
        load(tmp_path / "deep.mcap")
    assert partial_path(path).exists() is False


def test_a_closed_log_without_samples_loads_as_an_empty_run(tmp_path, capsys):
    sc = load_scenario("line").with_overrides(links=4, duration=0.01)
    path = tmp_path / "empty.mcap"
    with pytest.raises(KeyboardInterrupt):
        with RunLogger(path, sc):
            raise KeyboardInterrupt
    rep = load(path)
    assert len(rep.t) == 0 and rep.q.shape == (0, 4) and rep.outcome["status"] == "interrupted"
    assert not rep.recovered and not rep.damaged
    assert main(["replay", str(path), "--no-animation"]) == 0
    assert "no samples" in capsys.readouterr().out
    assert main(["report", str(path), "--out", str(tmp_path / "r")]) == 2
    one_line_error(capsys, "no samples")


def test_an_existing_out_is_refused_unless_overwrite_and_the_default_is_replaced(small_log, tmp_path, capsys):
    out = tmp_path / "o.mcap"
    out.write_bytes(b"precious")
    assert main(["run", "line", *SMALL, "--out", str(out)]) == 2
    one_line_error(capsys, str(out), "--overwrite")
    assert out.read_bytes() == b"precious"
    assert main(["run", "line", *SMALL, "--out", str(out), "--overwrite"]) == 0
    assert load(out).outcome["status"] == "completed" and not partial_path(out).exists()


def test_a_second_writer_of_the_same_log_is_refused_while_the_first_holds_it(tmp_path, capsys):
    out = tmp_path / "busy.mcap"
    first = McapFile(partial_path(out))       # another run writing this log (flock on its partial file)
    first.flush()
    try:
        assert main(["run", "line", *SMALL, "--out", str(out)]) == 2
        one_line_error(capsys, str(out), "another process is writing")
        assert partial_path(out).stat().st_size > 0   # the first writer's file was not emptied
    finally:
        first.close()
    assert main(["run", "line", *SMALL, "--out", str(out), "--overwrite"]) == 0   # free again


def test_a_log_directory_that_cannot_be_created_is_a_log_error(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["run", "line", *SMALL, "--out", str(blocker / "logs" / "x.mcap")]) == 2
    one_line_error(capsys, "--out", "cannot create its directory")


def test_bad_cflags_and_a_hanging_compiler_are_one_line_build_errors(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COORDARM_CFLAGS", "-O2 '")
    monkeypatch.setenv("COORDARM_BUILD_DIR", str(tmp_path / "build"))
    assert main(["run", "line", *SMALL, "--backend", "compiled", "--out", str(tmp_path / "a.mcap")]) == 2
    one_line_error(capsys, "COORDARM_CFLAGS", "No closing quotation")
    assert main(["run", "line", *SMALL, "--out", str(tmp_path / "b.mcap")]) == 0   # auto: falls back
    assert "COORDARM_CFLAGS" in capsys.readouterr().err


def _hanging_compiler(tmp_path: Path) -> Path:
    """A fake ``cc``: answers --version, else records its process group, TMPDIR and a child, and hangs."""
    cc = tmp_path / "hang-cc"
    cc.write_text(f"""#!{sys.executable}
import os, subprocess, sys, time
if "--version" in sys.argv:
    print("hang-cc 1.0")
    sys.exit(0)
tmp = os.environ["TMPDIR"]
open(os.path.join(tmp, "cc-temp.s"), "w").write("x")
child = subprocess.Popen(["sleep", "600"])
with open({str(tmp_path / "cc.info.tmp")!r}, "w") as f:
    f.write(f"{{os.getpid()}} {{child.pid}} {{os.getpgrp()}} {{tmp}}")
os.replace({str(tmp_path / "cc.info.tmp")!r}, {str(tmp_path / "cc.info")!r})   # appears complete
time.sleep(600)
""")
    cc.chmod(cc.stat().st_mode | stat.S_IXUSR)
    return cc


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[1].split()[0] != "Z"
    except OSError:
        return False


def test_a_hanging_compiler_is_stopped_with_its_children_and_temporary_files(tmp_path, monkeypatch):
    from coordarm.generated.build import build
    from coordarm.generated.codegen import Source
    from coordarm.symbolic import BuildError
    cc = _hanging_compiler(tmp_path)
    monkeypatch.setenv("COORDARM_COMPILE_TIMEOUT", "3")
    source = Source(text="int x;\n", form="structured", m=2)
    with pytest.raises(BuildError, match="took longer than 3 s"):
        build(source, cc=str(cc), build_dir=tmp_path / "build")
    driver, child, group, tmpdir = (tmp_path / "cc.info").read_text().split()
    assert int(group) == os.getpgrp()                      # in this run's process group
    assert not _alive(int(driver)) and not _alive(int(child))
    assert not Path(tmpdir).exists()                       # its temporary files removed
    assert not list((tmp_path / "build").rglob("*.tmp"))   # no half-written library left


def test_a_cache_directory_writable_by_the_users_own_group_is_used(tmp_path, monkeypatch):
    """umask 002 leaves the cache group-writable by the user's private group: used without a warning."""
    import grp
    import warnings
    from coordarm.generated import build as build_mod
    if set(grp.getgrgid(os.getgid()).gr_mem) - {__import__("pwd").getpwuid(os.getuid()).pw_name}:
        pytest.skip("this user's primary group has other members")
    mine = tmp_path / "umask002"
    mine.mkdir()
    mine.chmod(0o775)
    os.chown(mine, -1, os.getgid())
    monkeypatch.setattr(build_mod, "_private_fallback", [])
    with warnings.catch_warnings():
        warnings.simplefilter("error", build_mod.CacheWarning)
        assert build_mod.private_root(mine) == mine
    other = next((g for g in [*os.getgroups(), *range(1, 100)] if g != os.getgid()), None)
    try:
        os.chown(mine, -1, other)                   # the same permissions, another group: refused
    except (OSError, TypeError):
        pytest.skip("cannot give the directory to another group here")
    if os.stat(mine).st_gid == os.getgid():
        pytest.skip("cannot give the directory to another group here")
    with pytest.warns(build_mod.CacheWarning, match=f"writable by group {other}"):
        assert build_mod.private_root(mine) != mine


def test_an_unsafe_cache_directory_is_not_used(tmp_path, monkeypatch, capsys):
    from coordarm.generated import build as build_mod
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    monkeypatch.setattr(build_mod, "_private_fallback", [])
    with pytest.warns(build_mod.CacheWarning, match="writable by others"):
        private = build_mod.private_root(shared)
    assert private != shared and stat.S_IMODE(private.stat().st_mode) == 0o700
    assert build_mod.private_root(tmp_path / "mine") == tmp_path / "mine"
    monkeypatch.setenv("COORDARM_BUILD_DIR", str(shared))
    assert main(["run", "line", *SMALL, "--backend", "compiled", "--out", str(tmp_path / "c.mcap")]) == 0
    captured = capsys.readouterr()
    assert "warning: build cache" in captured.err and str(private) in captured.out
    assert not any(shared.iterdir())


def test_a_replaced_library_with_stale_metadata_is_rebuilt_not_loaded(tmp_path):
    from coordarm.generated.build import LIBRARY, build, cached
    from coordarm.generated.codegen import generate_source
    ctrl = load_scenario("line").with_overrides(links=3).controller()
    lib = build(generate_source(ctrl, "structured"), build_dir=tmp_path)
    data = bytearray(lib.path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    lib.path.write_bytes(bytes(data))   # tampered, meta.json untouched
    assert not cached(lib.path.parent, lib.key)
    again = build(generate_source(ctrl, "structured"), build_dir=tmp_path)
    assert again.cache_hit is False and again.path.name == LIBRARY and cached(again.path.parent, again.key)


def test_ctrl_c_while_the_log_is_being_opened_leaves_a_closed_log_of_no_samples(tmp_path, monkeypatch):
    from coordarm.simulation import mcap_writer

    def interrupted(scenario):
        raise KeyboardInterrupt

    monkeypatch.setattr(mcap_writer, "build_info", interrupted)
    path = tmp_path / "half.mcap"
    with pytest.raises(KeyboardInterrupt):
        RunLogger(path, load_scenario("line").with_overrides(links=4))
    assert not partial_path(path).exists()       # issue 25: a log once started is kept, closed
    rep = load(path)
    assert rep.outcome["status"] == "interrupted" and len(rep.t) == 0 and rep.scenario.config.chain.links == 4


def test_an_error_while_the_log_is_being_opened_leaves_no_half_made_file(tmp_path, monkeypatch):
    from coordarm.simulation import mcap_writer

    def broken(scenario):
        raise RuntimeError("no build info")

    monkeypatch.setattr(mcap_writer, "build_info", broken)
    path = tmp_path / "half.mcap"
    with pytest.raises(RuntimeError):
        RunLogger(path, load_scenario("line").with_overrides(links=4))
    assert not path.exists() and not partial_path(path).exists()


def test_ctrl_c_while_compiling_kills_the_compiler_and_removes_its_files(tmp_path):
    import signal
    import threading
    import time

    from coordarm.generated.build import build
    from coordarm.generated.codegen import Source
    from coordarm.symbolic import interrupts
    cc = _hanging_compiler(tmp_path)
    info = tmp_path / "cc.info"

    def ctrl_c_once_compiling():   # waits for the event: the compiler has started and said so
        deadline = time.monotonic() + 60
        while not info.exists() and time.monotonic() < deadline:
            time.sleep(0.01)
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=ctrl_c_once_compiling, daemon=True).start()
    with pytest.raises(KeyboardInterrupt), interrupts.handled():
        build(Source(text="int y;\n", form="structured", m=2), cc=str(cc), build_dir=tmp_path / "build")
    driver, child, group, tmpdir = info.read_text().split()
    assert not _alive(int(driver)) and not _alive(int(child)) and not Path(tmpdir).exists()
    assert not list((tmp_path / "build").rglob("*.tmp"))


def test_figures_that_cannot_be_written_are_a_one_line_error(small_log, tmp_path, capsys):
    out = tmp_path / "figs"
    (out / "small_stages.png").mkdir(parents=True)   # a directory where the figure should go
    assert main(["replay", str(small_log), "--out", str(out), "--no-animation"]) == 2
    one_line_error(capsys, "small_stages.png")


def test_a_ctrl_c_swallowed_by_a_casadi_call_still_stops_the_run_before_its_first_step(monkeypatch):
    """What CasADi does to 16 of 40 Ctrl-Cs in ``base_offset(s)`` (the start check's mapped call): the
    exception is lost, the call returns."""
    import signal

    from coordarm.simulation.run import simulate
    from coordarm.symbolic import interrupts
    sc = load_scenario("line").with_overrides(links=4, duration=0.2)
    ctrl = sc.controller()
    original, steps = ctrl.base_offsets, []

    def swallowing(T):
        try:
            if not steps:
                steps.append(T)
                os.kill(os.getpid(), signal.SIGINT)
        except KeyboardInterrupt:
            pass   # swallowed, as inside a CasADi call
        return original(T)

    monkeypatch.setattr(ctrl, "base_offsets", swallowing)
    seen = []
    with interrupts.handled():
        with pytest.raises(interrupts.Interrupted, match="SIGINT"):
            simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, backend="interpreted", on_chunk=seen.append)
    assert steps and not seen   # stopped before the first block


def test_a_ctrl_c_that_casadi_turns_into_a_type_error_is_an_interruption(monkeypatch, tmp_path, capsys):
    """What CasADi did to 1 of 200 Ctrl-Cs at random moments of a run: SWIG loses the KeyboardInterrupt
    inside a mapped Function call, tries the symbolic overload, and numpy then fails on the SX result."""
    import signal

    from coordarm.symbolic.controller import CoordinatingController
    original, calls = CoordinatingController.speeds, []

    def signal_then_type_error(self, times):
        if calls:
            return original(self, times)
        calls.append(times)
        try:
            os.kill(os.getpid(), signal.SIGINT)
        except KeyboardInterrupt:
            pass   # lost inside the C++ call
        raise TypeError("Implicit conversion of symbolic CasADi type to numeric matrix not supported.")

    monkeypatch.setattr(CoordinatingController, "speeds", signal_then_type_error)
    out = tmp_path / "run.mcap"
    code = main(["run", "line", "--links", "4", "--duration", "0.2", "--backend", "interpreted", "--no-figures",
                 "--quiet", "--out", str(out)])
    err = capsys.readouterr().err
    assert calls and code == 130 and err.strip() == "coordarm run: interrupted by SIGINT", err
    assert load(out).outcome["status"] == "interrupted"


def test_an_error_without_a_signal_is_not_an_interruption():
    import signal

    from coordarm.symbolic import interrupts
    with interrupts.handled():
        assert interrupts.interruption(TypeError("x")) is None
        assert interrupts.interruption(KeyboardInterrupt()) == signal.SIGINT
        assert interrupts.interruption(interrupts.Interrupted(signal.SIGTERM)) == signal.SIGTERM
        cause = SystemError("returned a result with an exception set")
        cause.__cause__ = KeyboardInterrupt()
        assert interrupts.interruption(cause) == signal.SIGINT


def test_a_build_started_while_an_exception_is_handled_keeps_its_library(tmp_path):
    """(A sweep worker compiles inside an ``except`` block of Dask's: the library must survive.)"""
    from coordarm.generated.build import build, cached
    from coordarm.generated.codegen import generate_source
    ctrl = load_scenario("line").with_overrides(links=3).controller()
    try:
        raise RuntimeError("being handled")
    except RuntimeError:
        lib = build(generate_source(ctrl, "structured"), build_dir=tmp_path, force=True)
    assert lib.path.is_file() and cached(lib.path.parent, lib.key)
    assert not list(tmp_path.rglob("*.tmp"))
