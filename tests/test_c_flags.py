"""Generated C under strict and unsafe flags: warning-free with -Wall -Wextra -Werror for every variant,
and its finiteness checks intact under -ffast-math."""
import math
import os
import subprocess
import sys
import warnings
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from coordarm.generated import compile as compile_controller
from coordarm.generated.build import build
from coordarm.generated.compiled import flushes_subnormals
from coordarm.generated.codegen import generate_source
from coordarm.simulation.run import simulate
from coordarm.symbolic import (Arc, Circle, ConfigError, CoordinatingController, Line, NonFiniteError,
                               PlanarChain, SingularityError)

CURVES = {
    ("line", "static"): lambda: Line((0.0, 0.0), 0.3),
    ("line", "moving"): lambda: Line((lambda t: 0.02 * ca.sin(t), 0.0), lambda t: 0.3 * ca.sin(t)),
    ("circle", "static"): lambda: Circle((0.0, 2.0), 2.0),
    ("circle", "moving"): lambda: Circle((lambda t: 0.1 * ca.sin(t), 2.0), lambda t: 2.0 + 0.1 * ca.cos(t)),
    ("arc", "static"): lambda: Arc(angle=0.2, radius=1.5),
    ("arc", "moving"): lambda: Arc(angle=lambda t: 0.3 * ca.sin(t), radius=lambda t: 1.5 + 0.2 * ca.sin(t)),
}
STRICT = "-O2 -Wall -Wextra -Werror"


@pytest.mark.parametrize("form", ["structured", "dense"])
@pytest.mark.parametrize("curve", list(CURVES), ids="-".join)
@pytest.mark.parametrize("B", ["identity", "diagonal"])
def test_every_generated_library_compiles_without_a_warning(form, curve, B, tmp_path):
    chain = PlanarChain(4, 0.1, None if B == "identity" else np.diag([1.0, 2.0, 0.5, 1.5]))
    ctrl = CoordinatingController(chain, CURVES[curve](), 2.0, 0.05, law=form)
    lib = build(generate_source(ctrl, form), flags=STRICT, build_dir=tmp_path)
    assert lib.path.is_file() and not lib.cache_hit
    comp = compile_controller(ctrl, flags=STRICT, build_dir=tmp_path)     # and it computes the law
    q = chain.zigzag(1.0, curve[0] == "line" and 0.3 or 0.0)
    np.testing.assert_allclose(comp.control(q, 0.4), ctrl.control(q, 0.4), rtol=1e-9, atol=1e-12)


def expiring_controller() -> CoordinatingController:
    """A commanded speed ``0.05 sqrt(1 - t)``, NaN after t = 1: the law produces NaN from finite inputs."""
    return CoordinatingController(PlanarChain(6, 0.1), Line((0.0, 0.0), 0.3), 2.0, lambda t: 0.05 * ca.sqrt(1 - t))


def in_a_subprocess(check: str, tmp_path) -> None:
    """Run ``check(tmp_path)`` of this module in a fresh interpreter with ``COORDARM_CFLAGS="-O3 -ffast-math"``.

    A library linked with -ffast-math may switch the whole process to flush-to-zero
    arithmetic when it is loaded (gcc's crtfastmath), which would change every later test.
    """
    code = (f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
            f"import test_c_flags; test_c_flags.{check}({str(tmp_path)!r})")
    env = dict(os.environ, COORDARM_CFLAGS="-O3 -ffast-math", COORDARM_BUILD_DIR=str(tmp_path))
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
    assert res.returncode == 0, res.stderr


def test_fast_math_keeps_the_finiteness_checks(tmp_path):
    in_a_subprocess("fast_math_checks", tmp_path)


def test_a_run_into_nan_stops_at_the_same_step_compiled_with_fast_math_and_interpreted(tmp_path):
    in_a_subprocess("nan_run_checks", tmp_path)


def fast_math_checks(tmp: str) -> None:
    """Non-finite inputs and a NaN produced inside the law are errors of the -ffast-math library."""
    tmp_path = Path(tmp)
    ctrl = expiring_controller()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        comp = compile_controller(ctrl, build_dir=tmp_path)
    # gcc < 13 links crtfastmath.o into a library linked with -ffast-math, which flushes subnormals
    # process-wide; the library is linked in a step of its own without it, so nothing changed
    assert not flushes_subnormals() and not any("flush-to-zero" in str(w.message) for w in caught)
    assert "-ffast-math" in (tmp_path / comp.library.key[:16] / "meta.json").read_text()
    q = ctrl.chain.zigzag(1.0, 0.3)
    assert np.all(np.isfinite(comp.control(q, 0.5)))
    bad = q.copy()
    bad[2] = np.nan
    with pytest.raises(ConfigError, match="index 2"):          # a non-finite input
        comp.control(bad, 0.5)
    with pytest.raises(ConfigError, match="t: must be finite"):
        comp.control(q, float("inf"))
    with pytest.raises(NonFiniteError, match="t = 1.5"):       # NaN produced inside the law
        comp.control(q, 1.5)
    with pytest.raises(NonFiniteError):
        comp.step(q, 0.999, 0.01)


def nan_run_checks(tmp: str) -> None:
    """A run into NaN stops at the same step compiled with -ffast-math and interpreted."""
    stops = {}
    for backend in ("compiled", "interpreted"):
        ctrl = expiring_controller()
        q0 = ctrl.chain.zigzag(1.0, 0.3)
        with pytest.raises(SingularityError) as info:
            simulate(ctrl, q0, 0.3, 0.01, t0=0.8, backend=backend, chunk=7,
                     thresholds={"link": 0.0, "longitudinal": 0.0})
        run = info.value.run
        assert run.info["backend"] == backend and not math.isfinite(info.value.margin)
        assert np.all(np.isfinite(run.q[:-1])) and np.all(np.isfinite(run.longitudinal[:-1]))
        stops[backend] = info.value.time
    assert stops["compiled"] == pytest.approx(stops["interpreted"]) and 1.0 <= stops["compiled"] <= 1.02


def _loaded_flushes(lib: Path) -> bool:
    """Whether a fresh interpreter flushes subnormals to zero after loading ``lib``."""
    code = ("import ctypes, sys; import numpy as np; ctypes.CDLL(sys.argv[1]); "
            "print(float(np.float64(2.2250738585072014e-308) / 2.0) == 0.0)")
    res = subprocess.run([sys.executable, "-c", code, str(lib)], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    return res.stdout.strip() == "True"


def test_a_library_built_with_fast_math_leaves_the_process_floating_point_mode_alone(tmp_path):
    from coordarm.generated.build import REQUIRED_FLAGS, compile_and_link, find_compiler
    cc = find_compiler()
    src = tmp_path / "f.c"
    src.write_text("double coordarm_twice(double x) { return 2.0 * x; }\n")
    flags = ("-O3", "-ffast-math")
    one_step = tmp_path / "one.so"           # compiled and linked in one run, as builds were before
    subprocess.run([cc, *REQUIRED_FLAGS, *flags, "-o", str(one_step), str(src)], check=True)
    two_steps = tmp_path / "two.so"
    for cmd in compile_and_link(cc, flags, src, tmp_path / "f.o", two_steps):
        subprocess.run(cmd, check=True)
    assert "-ffast-math" in compile_and_link(cc, flags, src, "o", "so")[0]   # the code is still fast-math
    assert not _loaded_flushes(two_steps)
    specs = subprocess.run([cc, "-dumpspecs"], capture_output=True, text=True).stdout
    version = subprocess.run([cc, "-dumpversion"], capture_output=True, text=True).stdout.strip()
    if "crtfastmath" in specs and int(version.split(".")[0]) < 13:
        assert _loaded_flushes(one_step)      # the one-step library does switch the process: the test can fail


def test_fast_math_libraries_get_new_cache_keys_and_default_ones_keep_theirs(monkeypatch):
    """Entries built before the separate link (with crtfastmath) are never served; default-flag ones stay valid."""
    from coordarm.generated import build as build_mod
    ctrl = expiring_controller()
    src, cc = generate_source(ctrl), build_mod.find_compiler()
    fast, default = ("-O3", "-ffast-math"), build_mod.DEFAULT_FLAGS
    now = build_mod.cache_key(src, cc, fast), build_mod.cache_key(src, cc, default)
    monkeypatch.setattr(build_mod, "PROCESS_MODE_FLAGS", frozenset())     # the key as it was computed before
    before = build_mod.cache_key(src, cc, fast), build_mod.cache_key(src, cc, default)
    assert now[0] != before[0] and now[1] == before[1]
