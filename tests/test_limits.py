"""Run limits from the resources: no constant link cap, memory against the machine, ``--yes``."""
from __future__ import annotations

import pytest

from coordarm.simulation import limits
from coordarm.simulation.limits import LAW_BYTES_PER_LINK, check_bounds, check_cost, cost_limits, estimate
from coordarm.symbolic import ConfigError

GIB = 2**30


def test_sixteen_thousand_links_pass_the_bounds_and_the_cost_check_on_a_machine_of_eight_gib(monkeypatch):
    monkeypatch.setattr(limits, "machine_memory", lambda: 8 * GIB)
    check_bounds(16384, 0.1, 1e-3, 1.0, 0.0, 2.0)
    cost = estimate(16384, 1e-3, 1.0)
    assert cost.memory_bytes < 4 * GIB          # measured peak 2.6 GiB (benchmarks/RESULTS.md)
    check_cost(cost)


def test_memory_limit_is_half_the_machine_but_never_below_the_documented_two_gib(monkeypatch):
    monkeypatch.setattr(limits, "machine_memory", lambda: 24 * GIB)
    assert cost_limits()["memory_bytes"] == 12 * GIB
    monkeypatch.setattr(limits, "machine_memory", lambda: 1 * GIB)
    assert cost_limits()["memory_bytes"] == 2 * GIB
    assert cost_limits()["steps"] == limits.COST_LIMITS["steps"]


def test_run_above_half_the_machine_needs_yes_and_above_the_machine_is_refused_even_with_yes(monkeypatch):
    monkeypatch.setattr(limits, "machine_memory", lambda: 4 * GIB)
    half = limits.Cost(10, 10, 3 * GIB)
    with pytest.raises(ConfigError, match="--yes"):
        check_cost(half)
    check_cost(half, confirmed=True)
    over = limits.Cost(10, 10, 5 * GIB)
    with pytest.raises(ConfigError, match="does not lift"):
        check_cost(over, confirmed=True)


def test_a_link_count_beyond_the_machine_is_refused_naming_chain_links(monkeypatch):
    monkeypatch.setattr(limits, "machine_memory", lambda: 1 * GIB)
    with pytest.raises(ConfigError, match=r"^chain\.links: 100000 links"):
        check_bounds(100_000, 0.1, 1e-3, 1.0, 0.0, 2.0)
    assert 100_000 * LAW_BYTES_PER_LINK > GIB


def test_estimate_counts_the_law_per_link_on_top_of_the_arrays():
    a, b = estimate(1000, 1e-3, 0.001), estimate(2000, 1e-3, 0.001)
    row_growth = b.memory_bytes - a.memory_bytes - 1000 * LAW_BYTES_PER_LINK
    assert 0 < row_growth < a.memory_bytes


def test_machine_memory_is_what_psutil_reads_and_psutil_is_the_fallback(monkeypatch):
    """sysconf's pages times page size (no psutil import on the start-up path) equal psutil's total;
    without sysconf the psutil value is used."""
    import os

    psutil = pytest.importorskip("psutil")
    assert limits.machine_memory() == psutil.virtual_memory().total

    def missing(name):
        raise ValueError(name)
    monkeypatch.setattr(os, "sysconf", missing)
    assert limits.machine_memory() == psutil.virtual_memory().total


@pytest.mark.parametrize("preset, duration, keep", [("line", 25.0, None), ("line", 3.0, 500), ("line3d", 3.0, 300)])
def test_the_rows_a_logged_run_keeps_stay_within_kept_capacity(preset, duration, keep):
    """A logged run (every chunk handed on) keeps at least its every-th rows and at most
    :func:`~.limits.kept_capacity` (its extremes per chunk included: the bound the run allocates and the
    memory estimate counts), counted here from the chunks the run handed on."""
    import numpy as np

    from coordarm.simulation.limits import kept_capacity, kept_every
    from coordarm.simulation.log_layout import layout_of_chain
    from coordarm.simulation.run import simulate
    from coordarm.simulation.scenario import load_scenario

    sc = load_scenario(preset).with_overrides(None, duration, None)
    ctrl = sc.controller()
    chunks = []
    run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, sc.t0, chunk=400, keep=keep,
                   on_chunk=lambda part: chunks.append(len(part.t)))
    n_steps = sum(chunks) - 1                      # every step's row and the final state's
    every = kept_every(keep, True, n_steps)
    assert run.info["kept_every"] == every > 1
    margins = len(layout_of_chain(ctrl.chain).margins)
    assert n_steps // every + 1 < len(run.t) <= kept_capacity(n_steps, every, 400, margins)
    assert np.all(np.diff(run.t) > 0)
