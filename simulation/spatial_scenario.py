"""The parts of a scenario with a universal chain: its controller, its start and its physical checks.

:class:`~coordarm.simulation.scenario.Scenario` calls these when ``[chain] joints = "universal"``:
:func:`spatial_start` lays the zig-zag (``[start] kind = "zigzag"`` or ``"follow"``, with ``axis``,
``fold`` and ``roll``), :func:`spatial_controller` builds the :class:`~coordarm.symbolic.SpatialController`
(the roll held at the start's when ``[control] roll`` is left out) and :func:`spatial_physical` gives
what a run checks (:class:`~coordarm.simulation.physical3d.Physical3D`: bend limits, capsules of
``[chain] radius`` apart and clear of the obstacles by ``[chain] clearance``).
"""
from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from coordarm.generated.source_memo import remembered_values
from coordarm.symbolic import ConfigError, SpatialChain, SpatialController
from coordarm.symbolic.start3d import check_bends, follow_curve3d, zigzag_start

from .physical3d import Physical3D
from .scenario_tables import ScenarioConfig

#: Controller -> (scenario, chain, curve, start) of the start :func:`spatial_controller` laid for it (its roll
#: held at the start's): :func:`laid_start` gives it again instead of laying it twice (0.17 s for path3d).
_LAID: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def spatial_start(config: ScenarioConfig, chain: SpatialChain, curve: Any, recipe: str | None = None) -> np.ndarray:
    """The start configuration ``q0`` of a universal chain, checked against the bend limit.

    Parameters
    ----------
    config : ScenarioConfig
        The scenario (``[start]``, ``[run] t0`` and the bend limit ``[chain] joint_limit``).
    chain : SpatialChain
        The manipulator.
    curve : SpatialCurve
        The goal curve.
    recipe : str, optional
        The scenario's JSON when it says all (its chain and curve built from it): a start laid along the
        curve (``kind = "follow"``, 60-110 ms of CasADi on a path) is then remembered under it and coordarm's
        code (:func:`~coordarm.generated.source_memo.remembered_values`), its exact bits; checked as a new one.

    Returns
    -------
    ndarray, shape (dof,)
        Joint coordinates ``(a_1, b_1, ..., a_m, b_m)`` [rad]; on a rail ``d`` first, at ``max(low, 0)`` of
        the rail's limits (as the planar rail), the zig-zag laid from the base there.

    Raises
    ------
    ConfigError
        A vector out of range, a link that cannot be laid on the curve, a bend beyond the limit, two
        links' capsules overlapping or a capsule touching an obstacle (the links and obstacle named).
    """
    st, t0 = config.start, float(config.run.t0)
    lay = follow_curve3d if st.kind == "follow" else zigzag_start
    d0 = max(chain.rail_limits[0], 0.0) if chain.rail else 0.0
    def laid() -> np.ndarray:
        return lay(chain, curve, float(st.beta), t0, st.axis, st.fold, float(st.roll or 0.0), d=d0)
    q = remembered_values("spatial start", recipe, laid) if recipe is not None and st.kind == "follow" else laid()
    check_bends(chain, q, config.chain.bend_limit)
    hits = spatial_physical(config, chain).check(np.array([t0]), q[None])
    if hits:
        raise ConfigError(f"start: {hits[0].describe().split(': ', 1)[1]}; move the obstacle or the start")
    return q


def laid_start(config: ScenarioConfig, ctrl: SpatialController) -> np.ndarray:
    """:func:`spatial_start` of ``config`` for ``ctrl``'s chain and curve: the start :func:`spatial_controller`
    laid while building ``ctrl`` from the same ``config`` (a copy), else laid now.

    Parameters
    ----------
    config : ScenarioConfig
        The scenario.
    ctrl : SpatialController
        Its controller.

    Returns
    -------
    ndarray, shape (dof,)
        As :func:`spatial_start` returns it (a new array).

    Raises
    ------
    ConfigError
        See :func:`spatial_start`.
    """
    laid = _LAID.get(ctrl)
    if laid is not None and laid[0] is config and laid[1] is ctrl.chain and laid[2] is ctrl.curve:
        return laid[3].copy()
    return spatial_start(config, ctrl.chain, ctrl.curve)


def spatial_physical(config: ScenarioConfig, chain: SpatialChain) -> Physical3D:
    """What a run of a universal chain checks: bend limits, self-collision of the capsules, the obstacles.

    Parameters
    ----------
    config : ScenarioConfig
        The scenario (``[chain] joint_limit``, ``radius``, ``clearance`` and ``[[obstacles]]``).
    chain : SpatialChain
        The manipulator.

    Returns
    -------
    Physical3D
        The checks (capsule radius ``link_length / 10`` and clearance 0 when left out).
    """
    ch = config.chain
    radius = float(ch.link_length) / 10 if ch.radius is None else float(ch.radius)
    return Physical3D(chain, ch.bend_limit, radius, float(ch.clearance or 0.0), list(config.obstacles), ch.rates)


def spatial_controller(config: ScenarioConfig, curve: Any, recipe: str | None = None) -> SpatialController:
    """The spatial coordinating controller of a scenario with ``[chain] joints = "universal"``.

    Parameters
    ----------
    config : ScenarioConfig
        The scenario.
    curve : SpatialCurve
        The goal curve.
    recipe : str, optional
        The scenario's JSON when it says all (see :func:`spatial_start`).

    Returns
    -------
    SpatialController
        Its roll command is ``[control] roll``, or held at the start's roll at ``[run] t0``.

    Raises
    ------
    ConfigError
        The start cannot be laid (see :func:`spatial_start`).
    """
    chain, c = config.chain.build(), config.control
    q0 = spatial_start(config, chain, curve, recipe) if c.roll_motion is None else None
    ctrl = SpatialController(chain, curve, float(c.gain), c.speed_motion, roll=c.roll_motion, law=c.law,
                             start=q0, t0=float(config.run.t0), span=c.span_motion)
    if q0 is not None:
        _LAID[ctrl] = (config, chain, curve, q0.copy())
    return ctrl
