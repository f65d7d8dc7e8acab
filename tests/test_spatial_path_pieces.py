"""The compiled spatial law on a 3-D path finds each link's piece first (generated/spatial_path.py): the piece's
index, its kind's formulas and the pivot on its geometry against the selection over every piece (the interpreted
geometry), at centres near the junctions, inside the transitions and at the pieces' ends; the compiled law with and
without the search, bit for bit where the compiler may not fuse multiply-adds differently."""
import casadi as ca
import numpy as np
import pytest

import coordarm.generated.spatial_codegen as spatial_codegen
from coordarm.generated.compiled import CompiledController
from coordarm.generated.spatial_path import (path_kinds, path_pivots, piece_distances, piece_geometry, piece_selector,
                                             piece_tests)
from coordarm.generated.spatial_variants import spatial_link_inv_det, spatial_link_pivot, spatial_time_features
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.paths3d import Path3D, closest_piece3d, closest_piece_index3d, piece_constants, piece_kind
from coordarm.symbolic.piece_formulas3d import kind_formulas3d
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController

AXIS = np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])
SEGMENTS = [("line", 0.6), ("arc", 0.9, 1.2, 0.7), ("line", 0.8), ("arc", 1.1, 1.0, -1.4), ("arc", 2.5, 0.8, 0.9),
            ("line", 3.0)]


def path(transition=None):
    return Path3D((0.0, 0.0, 0.0), AXIS, (0.0, 1.0, 0.0), SEGMENTS, transition=transition)


def centres(p, rng, n=60):
    """Points near the path: at every piece's ends (and a hair either side), inside each piece, beyond both ends,
    offset normally by up to 0.4 of the tube."""
    s = [pc.s0 + d for pc in p.pieces for d in (0.0, 1e-9, -1e-9)]
    s += [pc.s0 + f * pc.length for pc in p.pieces[:-1] for f in rng.uniform(0, 1, 4)]
    s += list(rng.uniform(-0.5, p.length + 0.5, n))
    out = []
    for si in s:
        _, n1, n2 = p.frame_at(si)
        r, a = rng.uniform(0, 0.4 * p.tube_radius), rng.uniform(0, 2 * np.pi)
        out.append(p.point_at(si) + r * (np.cos(a) * n1 + np.sin(a) * n2))
        out.append(p.point_at(si))
    return out


def flat(formulas):
    """``(psi, Phi, frame)`` as one column."""
    psi, Phi, frame = formulas
    return ca.vertcat(psi, Phi, *frame)


@pytest.mark.parametrize("transition", [None, 0.0, 0.35])
def test_the_piece_found_first_gives_the_selection_over_every_piece(transition, rng):
    p = path(transition)
    y = ca.SX.sym("y", 3)
    full = ca.Function("full", [y], [flat(closest_piece3d(p.pieces, y))])
    index = ca.Function("index", [y], [closest_piece_index3d(p.pieces, y)])
    sel = ca.SX.sym("sel", 28)
    kinds = {k: ca.Function(k, [y, sel], [flat(kind_formulas3d(sel, y, k))]) for k in ("line", "arc", "spiral")}
    found = set()
    for yy in centres(p, rng):
        k = int(index(yy))
        pc = p.pieces[k]
        found.add(piece_kind(pc))
        want = np.array(full(yy)).ravel()
        got = np.array(kinds[piece_kind(pc)](yy, piece_constants(pc))).ravel()
        assert np.array_equal(got, want), (k, yy)
    assert found == ({"line", "arc", "spiral"} if transition != 0.0 else {"line", "arc"})


@pytest.mark.parametrize("transition", [None, 0.0])
def test_the_search_of_the_c_finds_the_piece_of_the_selection(transition, rng):
    """The C's search (the tests, then a valid piece's distance, the first smallest kept) against the selection."""
    ctrl = SpatialController(SpatialChain(6, 0.1), path(transition), 2.0, 0.1, roll=0.0)
    select, tests, distances = piece_selector(ctrl), piece_tests(ctrl), piece_distances(ctrl)
    assert len(distances) == len(ctrl.task.curve.pieces)
    far = [np.array([0.0, 0.0, 40.0]), np.array([-30.0, 5.0, 2.0]), np.array([1e3, -1e3, 0.0])]
    for yy in centres(ctrl.task.curve, rng, 40) + far:
        ok = np.array(tests(*yy)).ravel()
        assert set(ok) <= {0.0, 1.0}
        best, k = np.inf, 0
        for i in np.flatnonzero(ok):
            d = float(distances[i](*yy))
            if d < best:
                best, k = d, i
        assert k == int(select(*yy)), yy


def test_the_pivot_on_the_piece_s_geometry_is_the_pivot_over_every_piece(rng):
    ctrl = SpatialController(SpatialChain(6, 0.1), path(), 2.0, 0.1, roll=Sinusoid(0.2, 1.3))
    pivot, inv_det = spatial_link_pivot(ctrl), spatial_link_inv_det(ctrl)
    select, (p_inv, p_pivot, _) = piece_selector(ctrl), path_pivots(ctrl)
    geometry = {k: piece_geometry(k) for k in path_kinds(ctrl)}
    pieces, w = ctrl.task.curve.pieces, np.zeros(int(spatial_time_features(ctrl).numel_out(0)))
    for yy in centres(ctrl.task.curve, rng, 30):
        E = np.linalg.qr(rng.normal(size=(3, 3)))[0][:, :2]
        geo = [*E.ravel(order="F"), *yy]
        want = [float(v) for v in pivot(*geo, w, inv_det(*geo, w))]
        pc = pieces[int(select(*yy))]
        Phi, J = geometry[piece_kind(pc)](yy, piece_constants(pc))
        got = [float(v) for v in p_pivot(*geo, w, p_inv(*geo, J), Phi, J)]
        assert np.array_equal(got, want)


def test_the_compiled_law_with_the_search_is_the_law_over_every_piece(rng, tmp_path, monkeypatch):
    ctrl = SpatialController(SpatialChain(40, 0.1), path(), 2.0, 0.1, roll=Sinusoid(0.2, 1.3))
    flags = ["-O0", "-ffp-contract=off"]      # the same products and sums, not fused differently; a quick build
    searched = CompiledController(ctrl, flags=flags, build_dir=tmp_path)
    monkeypatch.setattr(spatial_codegen, "searched", lambda c: False)
    every = CompiledController(ctrl, flags=flags, build_dir=tmp_path)
    assert searched.library.path != every.library.path
    q0 = ctrl.chain.zigzag(1.0, axis=AXIS, fold=(0.0, 1.0, 0.0))
    for _ in range(10):
        q, t = q0 + rng.normal(0, 0.3, q0.shape), rng.uniform(0, 5)
        a, b = searched.evaluate(q, t), every.evaluate(q, t)
        for name in a:
            assert np.array_equal(np.asarray(a[name]), np.asarray(b[name])), name
