"""Issue 25 item 8: a SIGKILL of the process that compiles takes the compiler (and what it started) with it,
and the next build removes the temporaries the killed one left. Real processes, real SIGKILL; every wait
polls for its condition."""
import os
import signal
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

from coordarm.generated.build import LIBRARY, build
from coordarm.generated.codegen import Source

BUILDER = textwrap.dedent("""
    import sys
    from coordarm.generated.build import build
    from coordarm.generated.codegen import Source
    build(Source(text="int x;\\n", form="structured", m=2), cc=sys.argv[1], build_dir=sys.argv[2])
""")


def _hanging_compiler(tmp_path: Path) -> Path:
    """A fake ``cc``: answers --version, else records its pid and a child's, writes a ``.o``, and hangs."""
    cc = tmp_path / "hang-cc"
    info = tmp_path / "cc.info"
    cc.write_text(f"""#!{sys.executable}
import os, subprocess, sys, time
if "--version" in sys.argv:
    print("hang-cc 1.0")
    sys.exit(0)
open(sys.argv[sys.argv.index("-o") + 1], "w").write("half an object")
child = subprocess.Popen(["sleep", "600"])
open({str(info) + ".tmp"!r}, "w").write(f"{{os.getpid()}} {{child.pid}}")
os.replace({str(info) + ".tmp"!r}, {str(info)!r})
time.sleep(600)
""")
    cc.chmod(cc.stat().st_mode | stat.S_IXUSR)
    return cc


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _poll(condition, timeout: float, what: str) -> None:
    start = time.monotonic()
    while not condition():
        assert time.monotonic() - start < timeout, what
        time.sleep(0.01)


def test_a_sigkill_of_the_building_process_kills_the_compiler_and_its_children(tmp_path):
    cc, cache = _hanging_compiler(tmp_path), tmp_path / "build"
    proc = subprocess.Popen([sys.executable, "-c", BUILDER, str(cc), str(cache)])
    pids = []
    try:
        _poll(lambda: (tmp_path / "cc.info").exists() or proc.poll() is not None, 120, "the compiler never started")
        assert proc.poll() is None
        pids = [int(p) for p in (tmp_path / "cc.info").read_text().split()]
        assert all(_alive(p) for p in pids)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
        _poll(lambda: not any(_alive(p) for p in pids), 20, "the compiler outlived the process that started it")
    finally:
        proc.kill()
        for p in pids:
            try:
                os.kill(p, signal.SIGKILL)
            except ProcessLookupError:
                pass
    stale = sorted(p.name for p in cache.rglob(f"{LIBRARY}.*"))
    assert any(n.endswith(".tmp") for n in stale) and any(n.endswith(".o") for n in stale), stale
    # the next build (a real compiler) removes what the killed one left, and keeps its own library
    lib = build(Source(text="int x;\n", form="structured", m=2), build_dir=cache)
    assert sorted(p.name for p in lib.path.parent.glob(f"{LIBRARY}*")) == [LIBRARY]


def test_the_temporaries_of_a_live_build_are_kept(tmp_path):
    from coordarm.generated.build import remove_stale_temporaries
    mine = tmp_path / f"{LIBRARY}.{os.getpid()}-abc.tmp"
    dead = tmp_path / f"{LIBRARY}.999999999-abc.o"
    other = tmp_path / f"{LIBRARY}.notours.tmp"
    for p in (mine, dead, other):
        p.write_text("x")
    assert remove_stale_temporaries(tmp_path) == 1
    assert mine.exists() and not dead.exists() and other.exists()


def test_a_dense_law_of_many_links_says_that_its_build_can_take_minutes(monkeypatch):
    from coordarm.simulation import session
    said = []
    monkeypatch.setattr(session, "logged_run", lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt))
    sc = session.prepared_scenario("pipe", 40, 0.01, None, "dense", None, None, False)
    try:
        session.simulate_logged(sc, sc.controller(), Path("unused.mcap"), overwrite=True, backend="auto",
                                log_rate=None, cond_rate=None, compression="zstd", live=False, port=0,
                                live_speed=1.0, live_wait=False, allow_contact=False, progress=False,
                                say=said.append, on_warning=print)
    except KeyboardInterrupt:
        pass
    assert said and said[0].startswith("law           dense, 40 links") and "minutes" in said[0]
