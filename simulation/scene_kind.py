"""The scene builder of a run's chain kind: the planar :class:`~.scene.SceneBuilder`, or for a spatial
chain the :class:`~.scene3d.SpatialSceneBuilder`, whose module (and its 3-D obstacles, distances and
views) a planar run does not load."""
from __future__ import annotations

from typing import Any

from .log_layout import PLANAR, layout_of_chain
from .scene import SceneBuilder


def scene_builder(ctrl: Any, obstacles: Any, radius: float | None = None, frames: str = "ends") -> SceneBuilder:
    """The scene builder of ``ctrl``'s chain kind: :class:`~.scene3d.SpatialSceneBuilder` for a spatial chain.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The controller of the run.
    obstacles : list
        The scenario's obstacles.
    radius : float, optional
        A spatial chain's capsule radius [m] (its links drawn as those capsules); unused for a planar chain.
    frames : {"ends", "all"}
        The frames of ``/tf``: ``base`` and ``tip``, or one per link.

    Returns
    -------
    SceneBuilder
        A planar :class:`~.scene.SceneBuilder` or a :class:`~.scene3d.SpatialSceneBuilder`.
    """
    if layout_of_chain(ctrl.chain) is PLANAR:
        return SceneBuilder(ctrl, obstacles, frames)
    from .scene3d import SpatialSceneBuilder

    return SpatialSceneBuilder(ctrl, obstacles, radius, frames)
