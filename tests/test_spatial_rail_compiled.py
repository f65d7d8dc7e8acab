"""The spatial law on a rail compiled (the rail head of templates/spatial_law.c): the same outputs as the
interpreted law, held and commanded span, structured and dense, warning-free; the chunk as interpreted RK4."""
import re
import shutil
import subprocess

import numpy as np
import pytest

from coordarm.generated import compile as compile_controller
from coordarm.generated.build import build
from coordarm.generated.export import export_law
from coordarm.generated.spatial_codegen import generate_spatial_source
from coordarm.symbolic.curves3d import Line3D
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.outputs import spatial_packed_width, spatial_split
from coordarm.symbolic.paths3d import Path3D
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController

AXIS = np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])
RAIL = np.array([1.0, 0.3, -0.2]) / np.linalg.norm([1.0, 0.3, -0.2])
STRICT = "-O2 -Wall -Wextra -Werror"
CURVES = {"line": lambda: Line3D((0.0, lambda t: 0.003 * t, 0.002), AXIS, (0.0, 1.0, 0.0),
                                 rotation=((0.0, 0.3, 1.0), Sinusoid(0.3, 0.7))),
          "path": lambda: Path3D((0.0, 0.0, 0.0), AXIS, (0.0, 1.0, 0.0),
                                 [("line", 0.6), ("arc", 0.9, 1.2, 0.7), ("line", 0.8), ("arc", 1.1, 1.0, -1.4),
                                  ("line", 3.0)])}


def controller(m, curve, span=None):
    chain = SpatialChain(m, 0.1, base="rail", rail_direction=RAIL, rail_limits=(-1.0, 3.0))
    return SpatialController(chain, CURVES[curve](), 2.0, Sinusoid(0.05, 0.5, 0.1), roll=Sinusoid(0.2, 1.3),
                             span=span)


def random_state(chain, rng, spread=0.05):
    return chain.zigzag(0.9, axis=AXIS, fold=(0.0, 1.0, 0.0), roll=0.2, d=0.1) + rng.normal(0, spread, chain.dof)


def assert_close(got, want, rtol=1e-11):
    got, want = np.atleast_1d(got), np.atleast_1d(want)
    assert got.shape == want.shape
    scale = max(1.0, float(np.max(np.abs(want))))
    assert float(np.max(np.abs(got - want))) <= rtol * scale, (got, want)


@pytest.mark.parametrize("curve, m, span, form", [("line", 3, None, "structured"),
                                                   ("path", 9, Sinusoid(0.05, 1.0, 0.3), "structured"),
                                                   ("line", 9, Sinusoid(0.05, 1.0, 0.3), "dense")])
def test_the_compiled_rail_law_equals_the_interpreted_law(curve, m, span, form):
    ctrl = controller(m, curve, span)
    rng = np.random.default_rng(m)
    comp = compile_controller(ctrl, form)
    for t in (0.0, 0.37, 2.9):
        q = random_state(ctrl.chain, rng)
        want, got = ctrl.evaluate(q, t, form), comp.evaluate(q, t)
        assert set(got) == set(want) and len(got["u"]) == 2 * m + 1
        for name in want:
            assert_close(got[name], want[name])


def test_the_compiled_rail_chunk_is_repeated_interpreted_rk4_steps():
    ctrl = controller(6, "line", span=0.3)
    comp = compile_controller(ctrl)
    h, times = 0.01, 0.2 + 0.01 * np.arange(5)
    q0 = random_state(ctrl.chain, np.random.default_rng(4))
    Q, D = comp.chunk(q0, times, h)
    assert Q.shape == (5, 13) and D.shape == (5, spatial_packed_width(6, True))
    step, q = ctrl.rk4_step(h), q0
    for k, t in enumerate(times):
        res = step(q, t)
        q = np.asarray(res[0]).ravel()
        assert_close(Q[k], q, rtol=1e-10)
        packed = spatial_split(D[k], 6, True)
        for name, value in zip(ctrl.run_outputs, res[1:]):
            assert_close(packed[name], np.asarray(value).ravel(), rtol=1e-10)


def test_the_spatial_rail_library_compiles_without_a_warning_and_its_code_does_not_grow(tmp_path):
    lib = build(generate_spatial_source(controller(4, "line", 0.3)), flags=STRICT, build_dir=tmp_path)
    assert lib.path.is_file()
    texts = [generate_spatial_source(controller(m, "line", 0.3)).text for m in (4, 400)]
    assert re.sub(r"\d+", "", texts[0]) == re.sub(r"\d+", "", texts[1])  # only the numbers of the sizes differ


@pytest.mark.skipif(shutil.which("make") is None or shutil.which("cc") is None, reason="needs make and cc")
def test_the_export_of_a_spatial_rail_law_builds_warning_free_and_its_example_computes_the_law(tmp_path):
    ctrl = controller(4, "line", span=0.3)
    q0 = random_state(ctrl.chain, np.random.default_rng(3))
    export_law(ctrl, q0, tmp_path, step=0.01, duration=0.05, scenario="test")
    header = (tmp_path / "coordarm_law.h").read_text()
    assert "COORDARM_LAW_OUT_SIGMA" in header and "rail of direction" in header
    subprocess.run(["make", "-C", str(tmp_path), "WARN=-std=c99 -Wall -Wextra -Werror"], check=True,
                   capture_output=True)
    first = subprocess.run([str(tmp_path / "example"), "1"], check=True, capture_output=True, text=True)
    row = np.array(first.stdout.splitlines()[0].split(), dtype=float)   # t, q (9), u (9), outputs
    want = ctrl.evaluate(q0, 0.0)
    assert row[0] == 0.0 and np.array_equal(row[1:10], q0)
    assert_close(row[10:19], want["u"], rtol=1e-10)
    rest = np.concatenate([want["e"], [want["s"], want["roll"]], want["link_margins"], [want["end_margin"]],
                           want["joint_margins"], [want["sigma"], want["rail_margin"]]])
    assert_close(row[19:], rest, rtol=1e-10)
