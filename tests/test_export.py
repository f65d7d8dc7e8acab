"""`coordarm export`: plain C that builds with `cc -std=c99 -Wall -Wextra -Werror`, whose example loop
agrees with the Python law (compiled: to 1e-12; interpreted: to its rounding sensitivity)."""
import shutil
import subprocess

import numpy as np
import pytest

from coordarm.cli import main as cli_main
from coordarm.generated.build import DEFAULT_FLAGS, find_compiler
from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic.outputs import packed_width, split
from coordarm.generated import compile as compile_controller
from tests.test_generated import ROUNDING_FACTOR, rounding_sensitivity

M, STEPS = 12, 40
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror"]

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="needs make")


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("export")
    assert cli_main(["export", "line", "--links", str(M), "--duration", "0.5", "--out", str(out)]) == 0
    return out


def test_export_writes_the_five_files_with_the_documented_api(exported):
    assert sorted(p.name for p in exported.iterdir()) == ["Makefile", "coordarm_law.c", "coordarm_law.h",
                                                           "example.c", "example_rt.c"]
    header = (exported / "coordarm_law.h").read_text()
    assert "int coordarm_law_sizes(long *n_q, long *n_u, long *n_outputs, long *n_work);" in header
    assert "int coordarm_law(const double *q, double t, double *u, double *outputs, double *work);" in header
    assert "casadi_" not in header and "#include" not in header   # self-contained


def test_plain_cc_strict_compiles_the_law(exported, tmp_path):
    res = subprocess.run([find_compiler(), *STRICT, *DEFAULT_FLAGS, "-c", "-o", str(tmp_path / "law.o"),
                          str(exported / "coordarm_law.c")], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    nm = shutil.which("nm")
    if nm:   # every external symbol is namespaced, so the library links into any program
        syms = subprocess.run([nm, "-g", "--defined-only", str(tmp_path / "law.o")], capture_output=True,
                              text=True).stdout.split()[2::3]
        assert syms and all(s.startswith("coordarm_law") for s in syms), syms


@pytest.fixture(scope="module")
def example_rows(exported):
    res = subprocess.run(["make", "-C", str(exported), f"WARN={' '.join(STRICT)}", "libcoordarm_law.a", "example"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr
    assert (exported / "libcoordarm_law.a").exists()
    run = subprocess.run([str(exported / "example"), str(STEPS)], capture_output=True, text=True, check=True)
    return np.array([[float(v) for v in line.split()] for line in run.stdout.splitlines()])


def test_example_loop_agrees_with_the_python_law(example_rows):
    scenario = load_scenario("line").with_overrides(M, 0.5, None)
    ctrl = scenario.controller()
    comp = compile_controller(ctrl)
    rows = example_rows
    assert rows.shape == (STEPS + 1, 1 + M + packed_width(M))
    T, Q, U, OUT = rows[:, 0], rows[:, 1:M + 1], rows[:, M + 1:2 * M + 1], rows[:, 2 * M + 1:]
    np.testing.assert_array_equal(Q[0], scenario.start(ctrl))
    np.testing.assert_allclose(T, scenario.t0 + scenario.step * np.arange(STEPS + 1), rtol=0, atol=1e-15)
    for k in range(0, STEPS + 1, 5):
        packed = np.concatenate([U[k], OUT[k]])
        ref = np.empty(packed_width(M))
        comp.evaluate(Q[k], T[k], out=ref)
        np.testing.assert_allclose(packed, ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))
        interp = ctrl.evaluate(Q[k], T[k])
        sens = rounding_sensitivity(ctrl.evaluate, Q[k], T[k])
        np.testing.assert_allclose(U[k], interp["u"], rtol=1e-12, atol=1e-12 + ROUNDING_FACTOR * sens["u"])
        np.testing.assert_allclose(OUT[k, :M - 1], interp["e"], rtol=1e-12, atol=1e-12 + ROUNDING_FACTOR * sens["e"])
        np.testing.assert_allclose(OUT[k, M:2 * M - 1], interp["link_margins"], rtol=1e-12,
                                   atol=1e-12 + ROUNDING_FACTOR * sens["link_margins"])
    # the example's RK4 loop is the simulator's: the compiled chunk reproduces its trajectory
    Qc, _ = comp.chunk(Q[0], T[:-1], scenario.step)
    np.testing.assert_allclose(Qc, Q[1:], rtol=1e-12, atol=1e-12)


ERRORS = r"""
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "coordarm_law.h"
int main(void) {
  long n_q, n_u, n_out, n_work, j;
  double *q, *u, *out, *w;
  if (coordarm_law_sizes(&n_q, &n_u, &n_out, &n_work) || coordarm_law_sizes(NULL, &n_u, &n_out, &n_work) != -1)
    return 9;
  q = calloc(n_q, sizeof *q); u = calloc(n_u, sizeof *u); out = calloc(n_out, sizeof *out);
  w = calloc(n_work, sizeof *w);
  for (j = 0; j < n_q; ++j) q[j] = j % 2 ? -0.6 : 0.6;
  printf("%ld %ld %ld %d", n_q, n_out, n_work, coordarm_law(q, 0.0, u, out, w));
  printf(" %d", coordarm_law(q, 0.0, NULL, out, w));
  printf(" %d", coordarm_law(q, INFINITY, u, out, w));
  q[3] = NAN;
  printf(" %d", coordarm_law(q, 0.0, u, out, w));
  printf(" %d\n", isnan(u[0]) && isnan(out[n_out - 1]));
  return 0;
}
"""


def test_error_codes_of_the_exported_api(exported, example_rows, tmp_path):
    (tmp_path / "errors.c").write_text(ERRORS)
    exe = tmp_path / "errors"
    subprocess.run([find_compiler(), *STRICT, f"-I{exported}", "-o", str(exe), str(tmp_path / "errors.c"),
                    str(exported / "libcoordarm_law.a"), "-lm"], check=True)
    n_q, n_out, n_work, ok, null, inf_t, nan_q, nan_out = subprocess.run(
        [str(exe)], capture_output=True, text=True, check=True).stdout.split()
    assert (int(n_q), int(n_out), int(n_work) > 0) == (M, packed_width(M) - M, True)
    assert (int(ok), int(null), int(inf_t), int(nan_q), int(nan_out)) == (0, -1, -2, -2, 1)


def test_a_rail_scenario_exports_and_its_example_loop_agrees_with_the_compiled_law(tmp_path):
    """`thread` (a rail, a commanded span): q and u carry d first, outputs end with sigma and the rail margin."""
    out = tmp_path / "thread"
    assert cli_main(["export", "thread", "--links", str(M), "--duration", "0.5", "--out", str(out)]) == 0
    header = (out / "coordarm_law.h").read_text()
    assert f"#define COORDARM_LAW_N_Q {M + 1}L" in header and "sigma [m]" in header and "rail_margin" in header
    res = subprocess.run(["make", "-C", str(out), f"WARN={' '.join(STRICT)}", "example"], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr
    run = subprocess.run([str(out / "example"), str(STEPS)], capture_output=True, text=True, check=True)
    rows = np.array([[float(v) for v in line.split()] for line in run.stdout.splitlines()])
    n, width = M + 1, packed_width(M, rail=True)
    assert rows.shape == (STEPS + 1, 1 + n + width)
    scenario = load_scenario("thread").with_overrides(M, 0.5, None)
    ctrl = scenario.controller()
    comp = compile_controller(ctrl)
    T, Q, packed = rows[:, 0], rows[:, 1:n + 1], rows[:, n + 1:]
    np.testing.assert_array_equal(Q[0], scenario.start(ctrl))
    for k in range(0, STEPS + 1, 5):
        ref = np.empty(width)
        comp.evaluate(Q[k], T[k], out=ref)
        np.testing.assert_allclose(packed[k], ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))
        interp = ctrl.evaluate(Q[k], T[k])
        for name in ("u", "sigma", "rail_margin", "s"):
            np.testing.assert_allclose(split(packed[k], M, rail=True)[name], interp[name], rtol=1e-11, atol=1e-12,
                                       err_msg=name)
    assert Q[-1, 0] != Q[0, 0]                                    # the rail moved
    Qc, _ = comp.chunk(Q[0], T[:-1], scenario.step)
    np.testing.assert_allclose(Qc, Q[1:], rtol=1e-12, atol=1e-12)


GOVERNED_RAIL = """name = "pushed"
[chain]
links = 10
link_length = 0.1
base = { kind = "rail", angle = 0.0, limits = [-1.0, 5.0] }
[curve]
kind = "line"
point = [0.0, 0.01]
[control]
gain = 2.0
speed = 0.1
span = { kind = "ramp", start = 0.878, rate = 0.2 }   # from the zig-zag's span, growing
governor = true
[start]
kind = "zigzag"
beta = 0.22
[run]
duration = 0.2
step = 0.002
[thresholds]
longitudinal = 0.15
"""


def test_a_governed_rail_scenario_exports_and_its_example_loop_agrees_with_the_laws(tmp_path):
    """The governor on a rail (two passes of the recursion in the C), started slowed (v_scale < 1)."""
    toml, out = tmp_path / "pushed.toml", tmp_path / "pushed"
    toml.write_text(GOVERNED_RAIL)
    assert cli_main(["export", str(toml), "--out", str(out)]) == 0
    res = subprocess.run(["make", "-C", str(out), f"WARN={' '.join(STRICT)}", "example"], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr
    run = subprocess.run([str(out / "example"), "100"], capture_output=True, text=True, check=True)
    rows = np.array([[float(v) for v in line.split()] for line in run.stdout.splitlines()])
    m, n = 10, 11
    width = packed_width(m, rail=True)
    scenario = load_scenario(str(toml))
    ctrl = scenario.controller()
    assert ctrl.governor and ctrl.chain.rail
    comp = compile_controller(ctrl)
    T, Q, packed = rows[:, 0], rows[:, 1:n + 1], rows[:, n + 1:]
    scales = [split(p, m, rail=True)["v_scale"] for p in packed]
    assert 0 < min(scales) and max(scales) < 0.1 and scales[-1] < scales[0]   # slowed all along, more and more
    for k in range(0, len(T), 10):
        ref = np.empty(width)
        comp.evaluate(Q[k], T[k], out=ref)
        np.testing.assert_allclose(packed[k], ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))
        interp = ctrl.evaluate(Q[k], T[k])
        sens = rounding_sensitivity(ctrl.evaluate, Q[k], T[k])
        for name in ("u", "v_scale", "sigma", "rail_margin", "s", "longitudinal"):
            np.testing.assert_allclose(split(packed[k], m, rail=True)[name], interp[name], rtol=1e-11,
                                       atol=1e-12 + ROUNDING_FACTOR * sens[name], err_msg=name)
    Qc, _ = comp.chunk(Q[0], T[:-1], scenario.step)
    np.testing.assert_allclose(Qc, Q[1:], rtol=1e-12, atol=1e-12)
