"""CasADi models of coordarm: chain kinematics, curves, and the coordinating law.

Imports nothing else of coordarm.
"""
from .chain import PlanarChain
from .controller import LAWS, OUTPUTS, RAIL_OUTPUTS, SCALAR_OUTPUTS, CoordinatingController
from .curves import Arc, Circle, Curve, Line, curve_from_spec
from .paths import Path
from .errors import BuildError, CollisionError, ConfigError, CoordarmError, LogError, SingularityError, TubeError
from .start import follow_curve, project_onto_curve
from .motions import Constant, Ramp, Sinusoid, Smoothstep, motion_from_spec, motion_to_spec

__all__ = ["PlanarChain", "CoordinatingController", "LAWS", "OUTPUTS", "RAIL_OUTPUTS", "SCALAR_OUTPUTS", "Curve", "Line", "Circle", "Arc", "Path",
           "curve_from_spec", "Constant", "Ramp", "Sinusoid", "Smoothstep", "motion_from_spec",
           "motion_to_spec", "CoordarmError", "ConfigError", "BuildError", "LogError",
           "SingularityError", "TubeError", "CollisionError", "project_onto_curve", "follow_curve"]
