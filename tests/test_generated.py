"""Generated C: the compiled law, RK4 step and chunk loop agree with interpreted CasADi; the build cache."""
import json
import os
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from coordarm.generated.build import LIBRARY, META, build, cached
from coordarm.generated.codegen import generate_source
from coordarm.generated.compiled import CompiledController
from coordarm.symbolic.outputs import split as split_outputs
from coordarm.cli import main as cli_main
from coordarm.simulation.run import BackendFallbackWarning, simulate
from coordarm.simulation.scenario import load_scenario, presets
from coordarm.symbolic import (
    OUTPUTS,
    BuildError,
    ConfigError,
    CoordinatingController,
    Line,
    PlanarChain,
)
from coordarm.generated import compile as compile_controller
from tests.curves_for_tests import moving_curve

REPO = Path(__file__).resolve().parents[1]


def controller(kind, m, B=None, law="structured"):
    return CoordinatingController(PlanarChain(m, 0.1, B=B), moving_curve(kind), 2.0,
                                  speed=lambda t: 0.1 + 0.05 * ca.sin(t), law=law)


def random_state(chain, rng, spread=0.15):
    return chain.zigzag(rng.uniform(0.5, 1.4), rng.uniform(-0.5, 0.5)) + rng.normal(0, spread, chain.m)


def assert_outputs_agree(a, b, tol=1e-12, rounding=None):
    """``a`` and ``b`` agree to ``tol`` (relative and absolute) plus ``ROUNDING_FACTOR`` times
    the law's own rounding sensitivity ``rounding[name]`` (see :func:`rounding_sensitivity`)."""
    for name in OUTPUTS:
        x, y = np.asarray(a[name], dtype=float), np.asarray(b[name], dtype=float)
        assert x.shape == y.shape, name
        extra = 0.0 if rounding is None else ROUNDING_FACTOR * rounding[name]
        np.testing.assert_allclose(x, y, rtol=tol, atol=tol + extra, err_msg=name)


#: The compiled law computes cos/sin with glibc's vector math library (up to 4 ulp, not the
#: scalar libm's < 1 ulp), contracts products into FMAs under -march=native and regroups the
#: carried P, Q update; on an ill-conditioned state (random zig-zags at m >= 33 move u by up to
#: 1e-6 when q moves by one ulp) no two roundings agree to 1e-12. Measured over 360 random
#: states: the difference is at most 4.7 times the interpreted law's own one-ulp sensitivity.
ROUNDING_FACTOR = 32.0


def rounding_sensitivity(law, q, t, n=8, seed=0):
    """Largest change of each output of ``law(q, t) -> dict`` when every ``q_j`` moves by one
    ulp in a random direction (``n`` draws): how far two correct roundings of the law may differ."""
    rng = np.random.default_rng(seed)
    base = law(q, t)
    sens = {name: 0.0 for name in base}
    for _ in range(n):
        other = law(q * (1 + 2.0 ** -52 * rng.choice([-1.0, 1.0], len(q))), t)
        for name in base:
            d = np.abs(np.atleast_1d(other[name]) - np.atleast_1d(base[name]))
            sens[name] = max(sens[name], float(np.max(d)))
    return sens


COMPILED = {}


def compiled(kind, m, B=None, law="structured"):
    """One controller and its compiled twin per configuration (compiling is the slow part)."""
    key = (kind, m, None if B is None else tuple(B), law)
    if key not in COMPILED:
        ctrl = controller(kind, m, B, law)
        COMPILED[key] = (ctrl, compile_controller(ctrl))
    return COMPILED[key]


@pytest.mark.parametrize("kind", ["line", "circle", "arc"])
@pytest.mark.parametrize("m", [2, 7, 33])
@given(seed=st.integers(0, 2**31))
def test_compiled_law_agrees_with_interpreted_to_1e12_on_random_states(kind, m, seed):
    ctrl, comp = compiled(kind, m)
    rng = np.random.default_rng(seed)
    q, t = random_state(ctrl.chain, rng), rng.uniform(0, 10)
    rounding = rounding_sensitivity(ctrl.evaluate, q, t)
    assert_outputs_agree(comp.evaluate(q, t), ctrl.evaluate(q, t), rounding=rounding)
    np.testing.assert_allclose(comp.control(q, t), ctrl.control(q, t), rtol=1e-12,
                               atol=1e-12 + ROUNDING_FACTOR * rounding["u"])


def test_compiled_law_with_a_diagonal_b_agrees(rng):
    B = rng.uniform(0.5, 2.0, 9)
    ctrl, comp = compiled("circle", 9, B=B)
    for _ in range(10):
        q, t = random_state(ctrl.chain, rng), rng.uniform(0, 10)
        # the same bar as the random-state test: 1e-12 plus the state's own one-ulp sensitivity
        assert_outputs_agree(comp.evaluate(q, t), ctrl.evaluate(q, t),
                             rounding=rounding_sensitivity(ctrl.evaluate, q, t))
        h = 1e-3
        np.testing.assert_allclose(comp.step(q, t, h), np.asarray(ctrl.rk4_step(h)(q, t)[0]).ravel(),
                                   rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("kind", ["line", "arc"])
def test_compiled_dense_law_agrees_with_interpreted_dense(kind, rng):
    ctrl, comp = compiled(kind, 6, law="dense")
    for _ in range(10):
        q, t = random_state(ctrl.chain, rng), rng.uniform(0, 10)
        assert_outputs_agree(comp.evaluate(q, t), ctrl.evaluate(q, t, "dense"))


@pytest.mark.parametrize("kind", ["line", "circle"])
def test_compiled_rk4_step_and_chunk_agree_with_the_interpreted_step(kind, rng):
    ctrl, comp = compiled(kind, 7)
    h, q = 2e-3, random_state(ctrl.chain, rng)
    times = 0.5 + h * np.arange(20)
    Q, D = comp.chunk(q, times, h)
    step = ctrl.rk4_step(h)
    x = q
    for k, t in enumerate(times):
        res = [np.asarray(v).ravel() for v in step(x, t)]
        np.testing.assert_allclose(comp.step(x, t, h), res[0], rtol=1e-12, atol=1e-12)
        d = split_outputs(D[k], ctrl.chain.m)
        for name, ref in zip(OUTPUTS[:5], res[1:]):
            np.testing.assert_allclose(np.atleast_1d(d[name]), ref, rtol=1e-12, atol=1e-12, err_msg=name)
        x = res[0]
        np.testing.assert_allclose(Q[k], x, rtol=1e-12, atol=1e-12)
    S, D2 = comp.chunk(q, times, h, with_start=True)     # the start first, then the same states, no copy
    assert S.shape == (len(times) + 1, len(q)) and S[0].tobytes() == np.asarray(q, float).tobytes()
    assert S[1:].tobytes() == Q.tobytes() and D2.tobytes() == D.tobytes()
    assert np.shares_memory(S[:-1], S[1:])


def test_generated_code_does_not_grow_with_the_number_of_links():
    small = generate_source(controller("line", 8)).text
    large = generate_source(controller("line", 1024)).text
    assert abs(len(large) - len(small)) < 100


@pytest.mark.parametrize("name", [p for p in presets() if not load_scenario(p).universal])
def test_compiled_runs_reproduce_interpreted_runs_of_every_preset(name):
    from test_log_readers import held_span      # a rail's commanded span is sized for its own links
    scenario = held_span(load_scenario(name)).with_overrides(12, 0.3, None)
    ctrl = scenario.controller()
    q0 = scenario.start(ctrl)
    args = (ctrl, q0, scenario.duration, scenario.step, scenario.t0)
    a = simulate(*args, backend="compiled", chunk=128)
    b = simulate(*args, backend="interpreted", chunk=128)
    assert a.info["backend"] == "compiled" and b.info["backend"] == "interpreted"
    for field in ("t", "q", "u", "e", "s", "link_margins", "longitudinal", "v_star"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=1e-12, atol=1e-12, err_msg=field)


def test_bad_inputs_to_the_compiled_law_are_clear_errors():
    ctrl, comp = compiled("line", 7)
    q = ctrl.chain.zigzag(1.0)
    with pytest.raises(ConfigError, match="q: need shape"):
        comp.control(q[:-1])
    bad = q.copy()
    bad[3] = np.nan
    with pytest.raises(ConfigError, match="index 3"):
        comp.control(bad)
    with pytest.raises(ConfigError, match="t: must be finite"):
        comp.control(q, float("inf"))


# ------------------------------------------------------------------ build cache
def test_cold_build_then_cache_hit(tmp_path):
    ctrl = controller("line", 5)
    cold = CompiledController(ctrl, build_dir=tmp_path)
    assert not cold.cache_hit and cold.library.path.is_file()
    meta = json.loads((cold.library.path.parent / META).read_text())
    assert meta["key"] == cold.library.key and meta["casadi"] == ca.__version__
    warm = CompiledController(controller("line", 5), build_dir=tmp_path)
    assert warm.cache_hit and warm.library.path == cold.library.path
    q = ctrl.chain.zigzag(1.0)
    np.testing.assert_array_equal(warm.control(q, 1.0), cold.control(q, 1.0))


def test_compile_keeps_one_compiled_controller_per_controller_form_and_options(tmp_path):
    ctrl = controller("line", 5)
    first = compile_controller(ctrl, build_dir=tmp_path)
    assert compile_controller(ctrl, build_dir=tmp_path) is first
    assert compile_controller(ctrl, "structured", build_dir=str(tmp_path)) is first
    forced = compile_controller(ctrl, build_dir=tmp_path, force=True)       # force builds anew, and is kept
    assert forced is not first and not forced.cache_hit
    assert compile_controller(ctrl, build_dir=tmp_path) is forced
    other = compile_controller(controller("line", 5), build_dir=tmp_path)   # another controller: its own
    assert other is not forced and other.cache_hit and other.library.path == forced.library.path


def test_everything_that_determines_the_code_changes_the_key(tmp_path):
    base = generate_source(controller("line", 5))
    key = build(base, build_dir=tmp_path).key
    assert build(base, build_dir=tmp_path, flags=["-O1"]).key != key
    other_gain = CoordinatingController(PlanarChain(5, 0.1), moving_curve("line"), 3.0,
                                        speed=lambda t: 0.1 + 0.05 * ca.sin(t))
    assert build(generate_source(other_gain), build_dir=tmp_path).key != key
    assert build(generate_source(controller("circle", 5)), build_dir=tmp_path).key != key


@pytest.mark.parametrize("damage", ["truncate", "garbage", "no_meta", "stale_meta"])
def test_a_damaged_cache_entry_is_rebuilt_not_loaded(tmp_path, damage):
    source = generate_source(controller("line", 5))
    lib = build(source, build_dir=tmp_path)
    entry = lib.path.parent
    if damage == "truncate":                     # half-written library
        data = lib.path.read_bytes()
        lib.path.write_bytes(data[:len(data) // 2])
    elif damage == "garbage":
        lib.path.write_bytes(b"\x7fELF not really")
    elif damage == "no_meta":
        (entry / META).unlink()
    else:
        meta = json.loads((entry / META).read_text())
        meta["key"] = "0" * 64
        (entry / META).write_text(json.dumps(meta))
    assert not cached(entry, lib.key)
    again = build(source, build_dir=tmp_path)
    assert not again.cache_hit and cached(entry, lib.key)
    assert not list(entry.glob("*.tmp"))


def test_two_processes_building_the_same_key_at_once_both_end_with_a_valid_library(tmp_path):
    script = textwrap.dedent(f"""
        import sys, time
        sys.path.insert(0, {str(REPO)!r})
        import numpy as np
        from coordarm.symbolic import CoordinatingController, Line, PlanarChain
        from coordarm.generated.compiled import CompiledController
        ctrl = CoordinatingController(PlanarChain(40, 0.1), Line(angle=0.2), 2.0, 0.1)
        start = float(sys.argv[1])
        while time.time() < start:
            pass
        comp = CompiledController(ctrl, build_dir={str(tmp_path)!r}, force=True)
        u = comp.control(ctrl.chain.zigzag(1.0), 0.5)
        print(comp.library.key, float(np.abs(u - ctrl.control(ctrl.chain.zigzag(1.0), 0.5)).max()))
        """)
    import time
    start = str(time.time() + 3.0)   # both past their imports, then build at once
    procs = [subprocess.Popen([sys.executable, "-c", script, start], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outs = [p.communicate(timeout=120) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1] for o in outs]
    keys = {o[0].split()[0] for o in outs}
    assert len(keys) == 1 and all(float(o[0].split()[1]) <= 1e-12 for o in outs)
    key = keys.pop()
    entry = tmp_path / key[:16]
    assert cached(entry, key) and not list(entry.glob("*.tmp"))


def test_missing_compiler_auto_falls_back_with_a_warning_and_compiled_is_an_error(monkeypatch):
    monkeypatch.setenv("CC", str(Path("/nonexistent/cc")))
    chain = PlanarChain(6, 0.1)
    ctrl = CoordinatingController(chain, Line(angle=0.1), 2.0, 0.1)
    with pytest.warns(BackendFallbackWarning, match="no C compiler found"):
        run = simulate(ctrl, chain.zigzag(1.0), 0.01)
    assert run.info["backend"] == "interpreted"
    with pytest.raises(BuildError, match="no C compiler found"):
        simulate(CoordinatingController(chain, Line(angle=0.1), 2.0, 0.1), chain.zigzag(1.0), 0.01,
                 backend="compiled")


def test_compiler_failure_is_a_build_error_with_the_compiler_message(tmp_path):
    with pytest.raises(BuildError, match="not-a-flag"):
        build(generate_source(controller("line", 3)), build_dir=tmp_path, flags=["-fnot-a-flag"])


def _processes_reading(path) -> list[int]:
    """Pids of the live processes whose command line names ``path`` (Linux /proc)."""
    pids = []
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and str(path).encode() in (entry / "cmdline").read_bytes():
                pids.append(int(entry.name))
        except OSError:
            pass
    return pids


@pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="needs Linux /proc")
def test_a_compile_over_its_timeout_is_stopped_with_every_compiler_process(tmp_path):
    """gcc is a driver: the timeout must kill cc1 too, not leave it compiling (it did before)."""
    source = generate_source(controller("line", 32), "dense")        # seconds of cc1 (3 s on a Xeon)
    with pytest.raises(BuildError, match="took longer than 0.5 s; stopped"):
        build(source, build_dir=tmp_path, timeout=0.5)
    src = next(tmp_path.rglob("coordarm.c"))
    deadline = time.monotonic() + 1.0   # until reaped; cc1 alone runs ~3 s, so one left compiling is seen
    while _processes_reading(src) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert _processes_reading(src) == []
    assert not list(tmp_path.rglob("*.tmp"))


def test_full_b_is_refused_by_the_compiled_backend_and_auto_falls_back():
    B = np.eye(4) + 0.1 * np.eye(4, k=1)
    chain = PlanarChain(4, 0.1, B=B)
    ctrl = CoordinatingController(chain, Line(angle=0.1), 2.0, 0.1)
    with pytest.raises(BuildError, match="diagonal input matrix B"):
        compile_controller(ctrl)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = simulate(ctrl, chain.zigzag(1.0), 0.01)
    assert run.info["backend"] == "interpreted" and caught


def test_default_backend_is_compiled_and_reports_the_cache():
    chain = PlanarChain(6, 0.1)
    ctrl = CoordinatingController(chain, Line(angle=0.1), 2.0, 0.1)
    run = simulate(ctrl, chain.zigzag(1.0), 0.01)
    assert run.info["backend"] == "compiled" and Path(run.info["library"]).is_file()
    assert isinstance(run.info["cache_hit"], bool)


def test_run_info_reports_a_library_built_now_even_when_the_backend_was_selected_first(tmp_path, monkeypatch):
    from coordarm.simulation.run import select_backend

    monkeypatch.setenv("COORDARM_BUILD_DIR", str(tmp_path))     # empty cache: the library is built now
    chain = PlanarChain(5, 0.1)
    ctrl = CoordinatingController(chain, Line(angle=0.2), 2.0, 0.1)
    name, compiled, info = select_backend(ctrl, "auto")           # what `coordarm run` does before logging
    assert name == "compiled" and info["cache_hit"] is False
    run = simulate(ctrl, chain.zigzag(1.0), 0.01, backend=name)
    assert run.info["cache_hit"] is False and run.info["library"] == str(compiled.library.path)
    again = simulate(CoordinatingController(chain, Line(angle=0.2), 2.0, 0.1), chain.zigzag(1.0), 0.01)
    assert again.info["cache_hit"] is True


# ------------------------------------------------------------------------- CLI
def test_regen_builds_the_named_scenarios_and_clean_empties_the_cache(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("COORDARM_BUILD_DIR", str(tmp_path))
    assert cli_main(["regen", "line", "hole", "--links", "6"]) == 0
    out = capsys.readouterr().out
    assert out.count(LIBRARY) == 2 and "line: structured law, 6 links" in out
    libs = list(tmp_path.glob(f"*/{LIBRARY}"))
    assert len(libs) == 2
    assert cli_main(["regen", "line", "--links", "6", "--law", "dense", "--clean"]) == 0
    out = capsys.readouterr().out
    assert "removed 2 cached libraries" in out and "dense law" in out
    assert len(list(tmp_path.glob(f"*/{LIBRARY}"))) == 1


def test_regen_of_a_bad_scenario_exits_2(tmp_path, capsys):
    assert cli_main(["regen", str(tmp_path / "missing.toml")]) == 2
    assert "missing.toml" in capsys.readouterr().err


def test_run_reports_the_backend_and_the_cache(tmp_path, capsys):
    args = ["run", "line", "--links", "6", "--duration", "0.05", "--quiet", "--no-figures",
            "--out", str(tmp_path / "line.mcap"), "--overwrite"]
    assert cli_main(args + ["--backend", "compiled"]) == 0
    first = capsys.readouterr().out
    assert cli_main(args) == 0
    second = capsys.readouterr().out
    assert "backend compiled" in first and ("built now" in first or "cache hit" in first)
    assert "cache hit" in second
    assert cli_main(args + ["--backend", "interpreted"]) == 0
    assert "backend interpreted" in capsys.readouterr().out


def test_run_without_a_compiler_warns_in_one_line_and_runs_interpreted(tmp_path):
    env = {**os.environ, "CC": "/nonexistent/cc", "COORDARM_BUILD_DIR": str(tmp_path / "build")}
    res = subprocess.run([sys.executable, "-m", "coordarm", "run", "line", "--links", "6", "--duration", "0.05",
                          "--quiet", "--no-figures", "--out", str(tmp_path / "x.mcap")],
                         capture_output=True, text=True, env=env, cwd=REPO)
    assert res.returncode == 0, res.stderr
    assert "coordarm run: warning: compiled backend unavailable" in res.stderr and "Traceback" not in res.stderr
    assert "backend interpreted" in res.stdout and not (tmp_path / "build").exists()


@pytest.mark.parametrize("xdg", [None, "", "   ", "relative/cache", "/abs/cache"])
def test_the_cache_directory_is_the_build_dir_the_variable_or_the_users_linux_cache(xdg, tmp_path, monkeypatch):
    """XDG base directories: an absolute ``$XDG_CACHE_HOME``, else ``~/.cache`` (relative values are ignored)."""
    from coordarm.generated.build import build_root
    if not sys.platform.startswith("linux"):
        pytest.skip("the XDG layout is Linux's")
    monkeypatch.delenv("COORDARM_BUILD_DIR", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    if xdg is None:
        monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    else:
        monkeypatch.setenv("XDG_CACHE_HOME", xdg)
    expected = Path(xdg) if xdg and xdg.startswith("/") else tmp_path / "home" / ".cache"
    assert build_root() == expected / "coordarm"
    assert build_root(tmp_path / "given") == tmp_path / "given"
    monkeypatch.setenv("COORDARM_BUILD_DIR", str(tmp_path / "env"))
    assert build_root() == tmp_path / "env" and build_root(tmp_path / "given") == tmp_path / "given"


@pytest.mark.parametrize("times, h, match", [
    ([0.0, 0.1], float("nan"), r"^h: the step must be a finite number of seconds above 0, got nan$"),
    ([0.0, 0.1], 0.0, r"^h: the step .* got 0.0$"),
    ([0.0, 0.1], "0.01", r"^h: the step .* got '0.01'$"),
    ([0.0, float("nan"), 0.2], 0.01, r"^times\[1\]: each start time must be finite, got nan$"),
    (np.zeros((2, 3)), 0.01, r"^times: need a 1-D sequence of start times \[s\], got shape \(2, 3\)$"),
    (["a", "b"], 0.01, r"^times: need a 1-D sequence"),
])
def test_bad_times_or_step_of_a_compiled_chunk_name_the_argument(times, h, match):
    """Not ``t: must be finite, got <times[0]>`` (a bad h), nor silent NaN or a silently misread grid."""
    ctrl, comp = compiled("line", 7)
    with pytest.raises(ConfigError, match=match):
        comp.chunk(ctrl.chain.zigzag(1.0), times, h)


def cache_entry(root, name, files=(LIBRARY, "coordarm.c", META)):
    """A directory shaped like a build's entry under ``root``."""
    entry = root / name
    entry.mkdir(parents=True)
    for f in files:
        (entry / f).write_text("x")
    return entry


def test_clean_deletes_only_cache_entries_never_a_users_files_or_through_a_link(tmp_path):
    from coordarm.generated.build import clean
    root = tmp_path / "cache"
    root.mkdir(mode=0o700)
    built = [cache_entry(root, "0123456789abcdef"), cache_entry(root, "fedcba9876543210", ("coordarm.c",))]
    users = [cache_entry(root, "my-photos-2024-x", ("a.jpg",)),           # 16 characters, not hex
             cache_entry(root, "00000000aaaaaaaa", ("notes.txt",))]       # hex, but not a build's files
    outside = cache_entry(tmp_path / "elsewhere", "1111111111111111")
    (root / "2222222222222222").symlink_to(outside, target_is_directory=True)
    assert clean(root) == 2
    assert not any(e.exists() for e in built)
    assert all((e / f).exists() for e, f in zip(users, ("a.jpg", "notes.txt")))
    assert (outside / LIBRARY).exists() and (root / "2222222222222222").is_symlink()
    assert clean(tmp_path / "missing") == 0 and not (tmp_path / "missing").exists()


def test_clean_empties_the_private_cache_the_builds_use_not_a_shared_one(tmp_path, monkeypatch):
    from coordarm.generated import build as build_mod
    shared, private = tmp_path / "shared", tmp_path / "private"
    others = cache_entry(shared, "0123456789abcdef")                  # another user's library
    shared.chmod(0o777)
    mine = cache_entry(private, "fedcba9876543210")
    monkeypatch.setattr(build_mod, "_private_fallback", [private])
    with pytest.warns(build_mod.CacheWarning, match="writable by others"):
        assert build_mod.clean(shared) == 1
    assert (others / LIBRARY).exists() and not mine.exists()
