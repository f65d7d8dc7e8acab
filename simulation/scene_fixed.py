"""What does not move in a scene, and how a scene writes its literal lengths: the obstacles' outlines and a
rail robot's rail as polylines, the one ``/scene/fixed`` message that draws them (planar and spatial scenes
alike), and the rounding of sizes and fixed points to the micrometre."""
from __future__ import annotations

from typing import Any

import numpy as np

from .obstacles import outline

#: Decimal places of the lengths a scene writes as literal text [m] (sizes, the curve's depth, the 3-D
#: walls' corners): micrometres, as its position slots; a sphere of 0.45 x 0.05 m is written 0.0225, not
#: 0.022500000000000003.
LENGTH_DECIMALS = 6


def length_literal(x: float) -> float:
    """A length as a scene writes it as text: rounded to :data:`LENGTH_DECIMALS` places (its shortest repr).

    Parameters
    ----------
    x : float
        The length [m].

    Returns
    -------
    float
        ``round(x, LENGTH_DECIMALS)`` [m].
    """
    return round(float(x), LENGTH_DECIMALS)


def obstacle_outlines(obstacles: Any) -> list[np.ndarray]:
    """Each obstacle as the polyline drawn for it [m], a list of (k, 2) arrays.

    The scene draws what :func:`coordarm.simulation.obstacles.outline` gives (as do the
    figures and the animation): a wall segment is its two ends, a disc and a polygon are
    closed (they repeat their first point).

    Parameters
    ----------
    obstacles : sequence of Obstacle
        The scenario's obstacles.

    Returns
    -------
    list of ndarray, each shape (k, 2)
        The polylines [m].
    """
    return [outline(ob) for ob in obstacles]


def rail_lines(chain: Any, reach: float) -> list[np.ndarray]:
    """The rail of a rail robot as polylines [m]: the rail between its limits (cut to ``reach`` where a
    limit is infinite) and a short stop across it at each finite limit; none on a fixed base.

    Parameters
    ----------
    chain : PlanarChain
        The chain (``rail``, ``rail_angle``, ``rail_limits``, ``xi``).
    reach : float
        Half-length drawn of an unbounded rail [m].

    Returns
    -------
    list of ndarray, each shape (2, 2)
        The rail, then the stops.
    """
    if not getattr(chain, "rail", False) or len(chain.rail_direction) != 2:
        return []    # a fixed base; a spatial chain's rail is drawn by scene3d.SpatialSceneBuilder
    u = chain.rail_direction
    n = np.array([-u[1], u[0]])
    low, high = (max(chain.rail_limits[0], -reach), min(chain.rail_limits[1], reach))
    out = [np.array([low * u, high * u])]
    for d, limit in zip((low, high), chain.rail_limits):
        if np.isfinite(limit):
            out.append(np.array([d * u - 1.5 * chain.xi * n, d * u + 1.5 * chain.xi * n]))
    return out


def fixed_update(ns: int, lines: list[str] | tuple[str, ...]) -> bytes:
    """The ``/scene/fixed`` message: a ``foxglove.SceneUpdate`` of one entity ``"fixed"`` (frame ``world``, kept
    until replaced) holding ``lines``, the JSON texts of the ``foxglove.LinePrimitive`` s that do not move.

    Parameters
    ----------
    ns : int
        Its time stamp [ns].
    lines : sequence of str
        The lines' JSON texts (the rail, the obstacles).

    Returns
    -------
    bytes
        The message.
    """
    return ('{"deletions":[],"entities":[{"timestamp":{"sec":%d,"nsec":%d},"frame_id":"world","id":"fixed",'
            '"lifetime":{"sec":0,"nsec":0},"frame_locked":false,"metadata":[],"arrows":[],"cubes":[],"spheres":[],'
            '"cylinders":[],"lines":[%s],"triangles":[],"texts":[],"models":[]}]}'
            % (ns // 10**9, ns % 10**9, ",".join(lines))).encode()
