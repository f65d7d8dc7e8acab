"""Where a Foxglove 3D panel should look: the camera of the shipped layout fitted to a scenario's scene.

The scene of a run spans the chain's poses, the curve where the body goes, the rail and the
obstacles; the layout's camera (``cameraState`` of its 3D panel) is aimed at the centre of their
bounding box from far enough away that the whole box fits the field of view.
"""
from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from coordarm.symbolic.spatial_chain import SpatialChain

from .scenario import Scenario

#: The 3D panel's key in the shipped layout.
THREE_D_PANEL = "3D!coordarm"
#: Polar angle of the fitted camera from the vertical [deg] (a tilted view that still reads as a plan).
FIT_PHI = 35.0
#: Room left around the scene in the fitted view (1 = the box touches the edges).
FIT_MARGIN = 1.5
#: Height of the frame labels (base, tip) in the fitted view [fraction of the radius of the sphere around
#: the scene's box] (the viewers' default, 0.2 m, hides a small scene and is lost in a large one).
LABEL_SIZE = 0.08


def scene_points(scenario: Scenario, poses: np.ndarray | None = None) -> np.ndarray:
    """Points that the scene of ``scenario`` draws [m], shape (k, 3) (z = 0 for a planar scenario).

    The chain at its start and the curve within half a body length of the end point (where it heads),
    or the chain at every row of ``poses``; the rail between its finite limits (cut at 2.2 body
    lengths) and every bounded obstacle.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    poses : ndarray, shape (N, dof), optional
        Joint coordinates of a run (e.g. read from its log); default the start pose.

    Returns
    -------
    ndarray, shape (k, 3)
        The points [m].
    """
    from .scene_fixed import obstacle_outlines, rail_lines
    from .spatial_view import spatial_joints

    ctrl = scenario.controller()
    chain = ctrl.chain
    q = np.atleast_2d(scenario.start(ctrl) if poses is None else np.asarray(poses, float))
    spatial = isinstance(chain, SpatialChain)
    joints = spatial_joints(chain, q) if spatial else chain.joints_np(q)
    pts = [_xyz(joints.reshape(-1, joints.shape[-1]))]
    length = chain.m * chain.xi
    if poses is None:   # the curve where the end point heads: within half a body length of its start
        curve = _xyz(ctrl.curve.sample(scenario.t0, n=400, extent=2.2 * length))
        tip = _xyz(joints[0, -1:])
        pts.append(curve[np.linalg.norm(curve - tip, axis=1) <= 0.5 * length])
    if not spatial:
        pts += [_xyz(p) for p in rail_lines(chain, 2.2 * length)]
        pts += [_xyz(p) for p in obstacle_outlines(scenario.obstacles)]
    else:
        from .obstacles3d import wireframe
        pts += [_xyz(p) for ob in scenario.obstacles for p in wireframe(ob)]
    out = np.concatenate(pts)
    return out[np.all(np.isfinite(out), axis=1) & np.all(np.abs(out) < 1e3 * max(length, 1.0), axis=1)]


def _xyz(p: Any) -> np.ndarray:
    """Points (k, 2) or (k, 3) as (k, 3)."""
    p = np.asarray(p, float).reshape(-1, np.shape(p)[-1])
    return p if p.shape[1] == 3 else np.column_stack([p, np.zeros(len(p))])


def fitted_camera(points: np.ndarray, camera: dict[str, Any]) -> dict[str, Any]:
    """``camera`` (a 3D panel's ``cameraState``) aimed at the centre of ``points``, all of them in view.

    Parameters
    ----------
    points : ndarray, shape (k, 3)
        The scene's points [m].
    camera : dict
        The panel's camera (``fovy`` [deg] is kept; ``target`` is the followed frame's origin).

    Returns
    -------
    dict
        A new camera: ``targetOffset`` the box's centre, ``distance`` at which the sphere around the
        box fills ``1 / FIT_MARGIN`` of the vertical field of view (:data:`FIT_MARGIN`), ``phi``
        :data:`FIT_PHI`, ``thetaOffset`` 0, perspective.
    """
    lo, hi = np.min(points, axis=0), np.max(points, axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * np.maximum(hi - lo, 1e-3)
    fovy = math.radians(float(camera.get("fovy", 45.0)))
    radius = float(np.linalg.norm(half))          # of a sphere holding the box
    distance = FIT_MARGIN * radius / math.tan(0.5 * fovy)
    out = dict(camera)
    out.update(perspective=True, distance=round(distance, 3), phi=FIT_PHI, thetaOffset=0.0,
               targetOffset=[round(float(c), 3) for c in centre], target=[0, 0, 0])
    return out


#: Plot series and panels that draw only in a log of one chain kind: (panel, series path) of the other
#: kind's margin, and the panel of spatial outputs only.
PLANAR_ONLY_SERIES, SPATIAL_ONLY_SERIES = ("Plot!margins", "/margins.longitudinal"), ("Plot!margins", "/margins.end_margin")
SPATIAL_ONLY_PANELS = ("Plot!roll",)


def fitted_layout(layout: dict[str, Any], points: np.ndarray, spatial: bool | None = None) -> dict[str, Any]:
    """A copy of ``layout`` whose 3D panel's camera is :func:`fitted_camera` on ``points`` and whose frame
    labels are :data:`LABEL_SIZE` of the scene's size, and, when the chain kind is given, without the series
    and panels that draw nothing for that kind.

    Parameters
    ----------
    layout : dict
        A Foxglove layout with the panel :data:`THREE_D_PANEL` (the shipped one).
    points : ndarray, shape (k, 3)
        The scene's points [m].
    spatial : bool, optional
        The scene's chain kind: a planar chain drops :data:`SPATIAL_ONLY_SERIES` and
        :data:`SPATIAL_ONLY_PANELS` (an empty plot reads as a fault), a spatial one drops
        :data:`PLANAR_ONLY_SERIES`; None keeps every panel.

    Returns
    -------
    dict
        The new layout.
    """
    out = copy.deepcopy(layout)
    panel = out["configById"][THREE_D_PANEL]
    panel["cameraState"] = fitted_camera(points, panel["cameraState"])
    panel["followMode"], panel["followTf"] = "follow-none", "world"
    radius = 0.5 * float(np.linalg.norm(np.ptp(points, axis=0)))
    panel.setdefault("scene", {}).setdefault("transforms", {})["labelSize"] = round(max(LABEL_SIZE * radius, 0.01), 3)
    if spatial is None:
        return out
    key, path = PLANAR_ONLY_SERIES if spatial else SPATIAL_ONLY_SERIES
    if key in out["configById"]:
        config = out["configById"][key]
        config["paths"] = [s for s in config["paths"] if s["value"] != path]
    for key in () if spatial else SPATIAL_ONLY_PANELS:
        if key in out["configById"]:
            del out["configById"][key]
            out["layout"] = _without_panel(out["layout"], key)
    return out


def _without_panel(tree: Any, key: str) -> Any:
    """A layout tree (a panel key, or a split ``{"first", "second", ...}``) without the panel ``key``: its
    split is replaced by the other side."""
    if not isinstance(tree, dict):
        return tree
    if tree["first"] == key:
        return tree["second"]
    if tree["second"] == key:
        return tree["first"]
    return {**tree, "first": _without_panel(tree["first"], key), "second": _without_panel(tree["second"], key)}
