"""The O(m) 1-norm condition estimate against dense products, solves and the exact condition number."""
from __future__ import annotations

import numpy as np
import pytest

from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic.chain import PlanarChain, normal
from coordarm.symbolic.cond_estimate import DOCUMENTED_FACTOR, DecouplingOperator, onenorm_estimate


def exact_cond_1(A: np.ndarray) -> float:
    return np.linalg.norm(A, 1) * np.linalg.norm(np.linalg.inv(A), 1)


def operators(ctrl, Q, T):
    """The structured operators and the closed-form dense matrices (NumericAPI) of the same states."""
    M, _ = ctrl.decoupling_matrices(Q, T)
    geo = ctrl.centre_geometry(Q, T)
    m, chain = ctrl.chain.m, ctrl.chain
    rows = np.concatenate([geo["gpsi"][:, m - 1:], geo["gphi"][:, 1:]], axis=1)
    normals = normal(np.cumsum(chain.revolute(Q), axis=-1))
    bd = chain.b_diagonal
    dense = {} if bd is not None else {"B": chain.B}
    rail = chain.rail_direction if chain.rail else None
    ops = [DecouplingOperator(normals[i], rows[i], chain.xi, bd, rail=rail,
                              base_gradient=geo["gpsi"][i, 0] if chain.rail else None, **dense) for i in range(len(Q))]
    return ops, M


CASES = [("line", 5), ("arc", 9), ("thread", 7), ("pipe", 12)]


@pytest.mark.parametrize("name, m", CASES)
def test_structured_products_and_solves_equal_the_dense_closed_form_matrix(name, m):
    ctrl = load_scenario(name).with_overrides(links=m).controller()
    rng = np.random.default_rng(m)
    Q, T = rng.normal(size=(4, ctrl.chain.dof)), rng.uniform(0, 3, 4)
    ops, M = operators(ctrl, Q, T)
    for op, A in zip(ops, M):
        x, y = rng.normal(size=len(A)), rng.normal(size=len(A))
        scale = np.abs(A).max() * np.abs(x).sum()
        assert np.allclose(op.matvec(x), A @ x, rtol=0, atol=1e-13 * scale)
        assert np.allclose(op.rmatvec(y), A.T @ y, rtol=0, atol=1e-13 * np.abs(A).max() * np.abs(y).sum())
        ref = np.linalg.solve(A, x)
        assert np.allclose(op.solve(x), ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
        ref_t = np.linalg.solve(A.T, y)
        assert np.allclose(op.solve_transposed(y), ref_t, rtol=1e-9, atol=1e-9 * np.abs(ref_t).max())


def test_a_non_diagonal_input_matrix_enters_products_and_solves():
    m = 6
    rng = np.random.default_rng(3)
    B = np.eye(m) + 0.3 * rng.normal(size=(m, m))
    sc = load_scenario("line").with_overrides(links=m)
    ctrl = sc.controller()
    ctrl.chain = PlanarChain(m, ctrl.chain.xi, B=B)
    Q, T = rng.normal(size=(3, m)), rng.uniform(0, 2, 3)
    ops, M = operators(ctrl, Q, T)
    for op, A in zip(ops, M):
        x = rng.normal(size=m)
        assert np.allclose(op.matvec(x), A @ x, atol=1e-12)
        assert np.allclose(op.rmatvec(x), A.T @ x, atol=1e-12)
        assert np.allclose(op.solve(x), np.linalg.solve(A, x), rtol=1e-9)
        assert np.allclose(op.solve_transposed(x), np.linalg.solve(A.T, x), rtol=1e-9)
        assert op.cond_estimate() <= exact_cond_1(A) * (1 + 1e-9)


@pytest.mark.parametrize("name", ["line", "arc", "thread", "pipe"])
def test_estimate_is_a_lower_bound_of_the_exact_1_norm_cond_within_the_documented_factor(name):
    worst = np.inf
    for m in (3, 6, 11, 24):
        ctrl = load_scenario(name).with_overrides(links=m).controller()
        rng = np.random.default_rng(100 + m)
        Q, T = rng.normal(size=(25, ctrl.chain.dof)), rng.uniform(0, 3, 25)
        ops, M = operators(ctrl, Q, T)
        ratio = np.array([op.cond_estimate() for op in ops]) / np.array([exact_cond_1(A) for A in M])
        assert np.all(ratio <= 1 + 1e-9)
        worst = min(worst, ratio.min())
    assert worst >= 1 / DOCUMENTED_FACTOR


def test_onenorm_estimate_is_exact_on_a_matrix_whose_largest_column_the_first_sweep_finds():
    A = np.diag([1.0, -7.0, 2.0]) + 0.1
    est = onenorm_estimate(lambda x: A @ x, lambda y: A.T @ y, 3)
    assert est == pytest.approx(np.linalg.norm(A, 1))


def test_a_singular_decoupling_matrix_gives_inf():
    # a straight chain along a line through the base: every link normal is perpendicular to the
    # curve's gradient of psi, the s row is zero
    m = 4
    n = np.tile([0.0, 1.0], (m, 1))
    rows = np.tile([1.0, 0.0], (m, 1))
    op = DecouplingOperator(n, rows, 0.1, np.ones(m))
    assert op.cond_estimate() == np.inf


def test_cond_estimates_is_exact_up_to_the_threshold_and_the_estimator_above(monkeypatch):
    from coordarm.symbolic import numeric
    ctrl = load_scenario("arc").with_overrides(links=10).controller()
    rng = np.random.default_rng(5)
    Q, T = rng.normal(size=(6, 10)), rng.uniform(0, 3, 6)
    ops, M = operators(ctrl, Q, T)
    exact = np.array([exact_cond_1(A) for A in M])
    np.testing.assert_allclose(ctrl.cond_estimates(Q, T), exact, rtol=1e-9)
    monkeypatch.setattr(numeric, "EXACT_COND_DOF", 0)
    np.testing.assert_array_equal(ctrl.cond_estimates(Q, T), [op.cond_estimate() for op in ops])


@pytest.mark.parametrize("extra, kind", [([], False), (["--cond-exact"], True)])
def test_the_run_command_logs_the_1_norm_cond_by_default_and_the_2_norm_with_cond_exact(tmp_path, extra, kind):
    from coordarm.analysis.replay import load
    from coordarm.cli import main
    from coordarm.simulation.mcap_writer import COND_KINDS
    out = tmp_path / "c.mcap"
    assert main(["run", "line", "--links", "6", "--duration", "2", "--quiet", "--no-figures", *extra,
                 "--out", str(out)]) == 0
    rep = load(out)
    assert rep.run_info["cond"] == COND_KINDS[kind] and len(rep.cond) == 3    # 1 Hz: t = 0, 1, 2
    ctrl = rep.controller()
    for tk, c in zip(rep.cond_t, rep.cond):
        k = int(np.flatnonzero(rep.t == tk)[0])
        A = ctrl.decoupling_matrices(rep.q[k:k + 1], [tk])[0][0]
        sv = np.linalg.svd(A, compute_uv=False)
        assert c == pytest.approx(sv[0] / sv[-1] if kind else exact_cond_1(A), rel=1e-9)


def test_estimator_above_the_threshold_bounds_the_exact_cond_of_a_300_link_chain():
    from coordarm.symbolic.numeric import EXACT_COND_DOF
    m = 300
    assert m > EXACT_COND_DOF
    sc = load_scenario("line").with_overrides(links=m)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    rng = np.random.default_rng(11)
    Q = np.stack([q0, q0 + 0.05 * rng.normal(size=q0.shape)])
    T = np.array([0.0, 0.7])
    est = ctrl.cond_estimates(Q, T)
    exact = np.array([exact_cond_1(A) for A in ctrl.decoupling_matrices(Q, T)[0]])
    assert np.all(est <= exact * (1 + 1e-6)) and np.all(est >= exact / DOCUMENTED_FACTOR)


def test_a_run_above_the_exact_threshold_estimates_cond_without_importing_scipy(tmp_path):
    # scipy.sparse.linalg costs ~0.2 s to import, as much as a whole 1024-link, 1 s run (RESULTS.md):
    # the estimate uses CasADi's sparse QR. A real command in a new process, then its modules.
    import subprocess
    import sys
    code = ("import sys; from coordarm.cli import main; "
            f"rc = main(['run', 'line', '--links', '300', '--duration', '0.2', '--quiet', '--no-figures', "
            f"'--cond-rate', '10', '--out', {str(tmp_path / 'c.mcap')!r}]); "
            "print(rc, sorted({n.split('.')[0] for n in sys.modules} & {'scipy'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split("\n")[-2] == "0 []"
    from coordarm.analysis.replay import load
    rep = load(tmp_path / "c.mcap")
    assert len(rep.cond) == 3 and np.all(np.isfinite(rep.cond))    # 10 Hz over 0.2 s: t = 0, 0.1, 0.2
