"""The command costs what its work costs: no plotting library unless figures are drawn, an O(m)
set-up for a diagonal B."""
import subprocess
import sys

import numpy as np
import pytest

from coordarm.symbolic import ConfigError, PlanarChain

SCRIPT = """
import sys
from coordarm.cli import main
rc = main(sys.argv[1:])
print("matplotlib" in sys.modules, rc)
"""


@pytest.mark.parametrize("figures", [False, True])
def test_run_imports_matplotlib_only_when_it_draws_figures(tmp_path, figures):
    args = ["run", "line", "--links", "8", "--duration", "0.05", "--quiet", "--out", str(tmp_path / "l.mcap")]
    if not figures:
        args.append("--no-figures")
    res = subprocess.run([sys.executable, "-c", SCRIPT, *args], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert res.stdout.split()[-2:] == [str(figures), "0"]
    assert (tmp_path / "l_stages.png").exists() == figures


def test_a_diagonal_b_is_a_vector_and_a_large_chain_builds_in_o_m():
    import tracemalloc

    tracemalloc.start()
    try:
        chain = PlanarChain(16384, 0.01, B=np.linspace(1, 2, 16384))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 * 2**20     # O(m) memory: one m x m array (a dense B, or its cond's SVD) would be 2 GiB
    assert chain.b_diagonal.shape == (16384,)
    np.testing.assert_array_equal(chain.apply_B(np.ones(16384)), np.linspace(1, 2, 16384))


def test_b_given_as_a_diagonal_matrix_or_a_full_matrix():
    B = np.diag([1.0, 2.0, 3.0])
    chain = PlanarChain(3, 0.1, B=B)
    np.testing.assert_array_equal(chain.b_diagonal, [1, 2, 3])
    np.testing.assert_array_equal(chain.B, B)
    full = B + 0.1
    chain = PlanarChain(3, 0.1, B=full)
    assert chain.b_diagonal is None
    u = np.array([[1.0, -2.0, 0.5], [0.0, 1.0, 1.0]])
    np.testing.assert_allclose(chain.apply_B(u), u @ full.T)
    for bad in ([1.0, 0.0, 1.0], [1.0, 1e-13, 1.0], np.ones((3, 3))):
        with pytest.raises(ConfigError, match="singular"):
            PlanarChain(3, 0.1, B=bad)


def test_envelope_indices_keep_every_extreme_of_every_line():
    from coordarm.simulation.figures import envelope_indices
    rng = np.random.default_rng(3)
    Y = np.cumsum(rng.normal(size=(30001, 3)), axis=0)
    Y[12345, 1] = 1e6                      # a one-sample spike
    keep = envelope_indices(Y, points=2000)
    assert len(keep) <= 3 * 2000 + 2 and keep[0] == 0 and keep[-1] == 30000
    assert np.all(np.diff(keep) > 0) and 12345 in keep
    for col in Y.T:                        # the kept samples reach the same extremes
        assert col[keep].max() == col.max() and col[keep].min() == col.min()
    np.testing.assert_array_equal(envelope_indices(Y[:500]), np.arange(500))
