"""CasADi models of coordarm: chain kinematics, curves, and the coordinating law.

Imports nothing else of coordarm. Names load on first use (PEP 562), so importing a light
module such as :mod:`coordarm.symbolic.errors` or :mod:`coordarm.symbolic.outputs` does not
load CasADi.
"""
from __future__ import annotations

from .lazy import lazy_exports

#: Public name -> submodule that defines it.
_EXPORTS = {
    "PlanarChain": "chain",
    "ChainModel": "chain_model", "KinematicChain": "chain_model",
    "SpatialChain": "spatial_chain", "SpatialController": "spatial_controller",
    "CoordinatingController": "controller",
    "LAWS": "laws",
    "OUTPUTS": "outputs", "SCALAR_OUTPUTS": "outputs", "RUN_OUTPUTS": "outputs", "LAW_OUTPUTS": "outputs",
    "RAIL_OUTPUTS": "outputs", "SPATIAL_OUTPUTS": "outputs",
    "Curve": "curves", "Line": "curves", "Circle": "curves", "Arc": "curves", "curve_from_spec": "curve_specs",
    "Path": "paths",
    "Constant": "motions", "Ramp": "motions", "Sinusoid": "motions", "Smoothstep": "motions",
    "motion_from_spec": "motions", "motion_to_spec": "motions",
    "CoordarmError": "errors", "ConfigError": "errors", "BuildError": "errors", "LogError": "errors", "NonFiniteError": "errors",
    "SingularityError": "errors", "TubeError": "errors", "BaseOffPathError": "errors", "CollisionError": "errors",
    "project_onto_curve": "start", "follow_curve": "start",
}

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
