"""The spatial law compiled (generated/spatial_codegen.py, templates/spatial_law.c): the same outputs as the
interpreted law at random states on a moving line, a tilted circle and a banked 3-D path; the C chunk loop as
repeated interpreted RK4 steps; warning-free C; the build cache; the packed layout."""
import shutil
import subprocess

import numpy as np
import pytest

from coordarm.generated import compile as compile_controller
from coordarm.generated.build import build
from coordarm.generated.compiled import CompiledController
from coordarm.generated.export import export_law
from coordarm.generated.spatial_codegen import generate_spatial_source
from coordarm.symbolic import ConfigError
from coordarm.symbolic.curves3d import Circle3D, Line3D
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.outputs import SPATIAL_RUN_OUTPUTS, spatial_offsets, spatial_packed_width, spatial_split
from coordarm.symbolic.paths3d import Path3D
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController

AXIS = np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])
STRICT = "-O2 -Wall -Wextra -Werror"


def moving_line():
    """A line through (near) the base that drifts and turns about a tilted axis."""
    return Line3D((0.0, lambda t: 0.003 * t, 0.002), AXIS, (0.0, 1.0, 0.0),
                  rotation=((0.0, 0.3, 1.0), Sinusoid(0.3, 0.7)))


def tilted_circle():
    """A circle of radius 1.5 through (near) the base, tangent ~ AXIS there, its plane tilted out of xy."""
    w = np.array([0.1, -0.4, 1.0]) / np.linalg.norm([0.1, -0.4, 1.0])
    inward = np.cross(w, AXIS) / np.linalg.norm(np.cross(w, AXIS))
    return Circle3D(1.5 * inward + np.array([0.0, 0.0, 0.005]), 1.5, w, -inward)


def banked_path():
    """Lines and arcs whose turns lie in different planes (a corkscrew-like path)."""
    return Path3D((0.0, 0.0, 0.0), AXIS, (0.0, 1.0, 0.0),
                  [("line", 0.6), ("arc", 0.9, 1.2, 0.7), ("line", 0.8), ("arc", 1.1, 1.0, -1.4), ("line", 3.0)])


CURVES = {"line": moving_line, "circle": tilted_circle, "path": banked_path}


def controller(m, curve, roll=Sinusoid(0.2, 1.3)):
    return SpatialController(SpatialChain(m, 0.1), CURVES[curve](), 2.0, Sinusoid(0.05, 0.5, 0.1), roll=roll)


def random_state(chain, rng, spread=0.05):
    """A zig-zag along the curve's start direction, every angle perturbed."""
    return chain.zigzag(0.9, axis=AXIS, fold=(0.0, 1.0, 0.0), roll=0.2) + rng.normal(0, spread, chain.dof)


def assert_close(got, want, rtol=1e-11):
    """Equal up to rounding relative to the vector's size."""
    got, want = np.atleast_1d(got), np.atleast_1d(want)
    assert got.shape == want.shape
    scale = max(1.0, float(np.max(np.abs(want))))
    assert float(np.max(np.abs(got - want))) <= rtol * scale, (got, want)


@pytest.mark.parametrize("m", [3, 8, 33])
@pytest.mark.parametrize("curve", sorted(CURVES))
def test_compiled_outputs_equal_the_interpreted_law_at_random_states(m, curve):
    ctrl = controller(m, curve)
    comp = compile_controller(ctrl)
    rng = np.random.default_rng(m)
    for t in (0.0, 0.37, 2.9):
        q = random_state(ctrl.chain, rng)
        want = ctrl.evaluate(q, t)
        got = comp.evaluate(q, t)
        assert set(got) == set(want)
        for name in want:
            assert_close(got[name], want[name])
        assert_close(comp.control(q, t), want["u"])
        u = np.empty(ctrl.chain.dof)
        assert comp.control(q, t, out=u) is u
        assert_close(u, want["u"])


def test_the_chunk_is_repeated_interpreted_rk4_steps_and_packs_the_run_outputs():
    ctrl = controller(8, "line")
    comp = compile_controller(ctrl)
    h, times = 0.01, 0.2 + 0.01 * np.arange(6)
    q0 = random_state(ctrl.chain, np.random.default_rng(4))
    Q, D = comp.chunk(q0, times, h)
    assert Q.shape == (6, 16) and D.shape == (6, spatial_packed_width(8))
    step, q = ctrl.rk4_step(h), q0
    for k, t in enumerate(times):
        res = step(q, t)
        q = np.asarray(res[0]).ravel()
        assert_close(Q[k], q, rtol=1e-10)
        assert_close(comp.step(Q[k - 1] if k else q0, t, h), q, rtol=1e-10)
        packed = spatial_split(D[k], 8)
        for name, value in zip(SPATIAL_RUN_OUTPUTS, res[1:]):
            assert_close(packed[name], np.asarray(value).ravel(), rtol=1e-10)


def test_the_packed_layout_is_the_table_order_with_its_widths():
    m = 5                                       # widths written out: 2m, 2(m-1), 1, 1, m-1, 1, m
    expected = {"u": (0, 10), "e": (10, 8), "s": (18, 1), "roll": (19, 1), "link_margins": (20, 4),
                "end_margin": (24, 1), "joint_margins": (25, 5)}
    assert spatial_offsets(m) == expected and spatial_packed_width(m) == 30
    split = spatial_split(np.arange(30.0), m)
    assert split["roll"] == 19.0 and list(split["joint_margins"]) == [25, 26, 27, 28, 29]


@pytest.mark.parametrize("form", ["structured", "dense"])
def test_the_spatial_library_compiles_without_a_warning(form, tmp_path):
    ctrl = controller(4, "line")
    lib = build(generate_spatial_source(ctrl, form), flags=STRICT, build_dir=tmp_path)
    assert lib.path.is_file() and not lib.cache_hit
    comp = CompiledController(ctrl, form, flags=STRICT, build_dir=tmp_path)
    assert comp.cache_hit
    q = random_state(ctrl.chain, np.random.default_rng(1))
    assert_close(comp.control(q, 0.4), ctrl.evaluate(q, 0.4, form)["u"], rtol=1e-10)


def test_a_second_build_of_the_same_law_hits_the_cache_and_code_size_does_not_grow(tmp_path):
    first = CompiledController(controller(6, "circle", roll=0.3), build_dir=tmp_path)
    again = CompiledController(controller(6, "circle", roll=0.3), build_dir=tmp_path)
    assert not first.cache_hit and again.cache_hit and again.library.path == first.library.path
    other = CompiledController(controller(7, "circle", roll=0.3), build_dir=tmp_path)
    assert not other.cache_hit
    sizes = [len(generate_spatial_source(controller(m, "line")).text) for m in (4, 400)]
    assert abs(sizes[1] - sizes[0]) < 20            # only the numbers of the sizes' macros differ


def test_a_non_finite_state_is_refused():
    ctrl = controller(3, "line")
    comp = compile_controller(ctrl)
    q = random_state(ctrl.chain, np.random.default_rng(2))
    q[3] = np.nan
    with pytest.raises(ConfigError):
        comp.control(q, 0.0)
    with pytest.raises(ConfigError):
        comp.control(q[:5], 0.0)


@pytest.mark.skipif(shutil.which("make") is None or shutil.which("cc") is None, reason="needs make and cc")
def test_the_export_of_a_spatial_law_builds_warning_free_and_its_example_computes_the_law(tmp_path):
    ctrl = controller(5, "line")
    q0 = random_state(ctrl.chain, np.random.default_rng(3))
    export_law(ctrl, q0, tmp_path, step=0.01, duration=0.05, scenario="test")
    header = (tmp_path / "coordarm_law.h").read_text()
    assert "spatial chain (universal joints)" in header and "COORDARM_LAW_OUT_JOINT_MARGINS" in header
    subprocess.run(["make", "-C", str(tmp_path), "WARN=-std=c99 -Wall -Wextra -Werror"], check=True,
                   capture_output=True)
    first = subprocess.run([str(tmp_path / "example"), "1"], check=True, capture_output=True, text=True)
    row = np.array(first.stdout.splitlines()[0].split(), dtype=float)   # t, q (10), u (10), outputs
    want = ctrl.evaluate(q0, 0.0)
    assert row[0] == 0.0 and np.array_equal(row[1:11], q0)
    assert_close(row[11:21], want["u"], rtol=1e-10)
    rest = np.concatenate([want["e"], [want["s"], want["roll"]], want["link_margins"], [want["end_margin"]],
                           want["joint_margins"]])
    assert_close(row[21:], rest, rtol=1e-10)
