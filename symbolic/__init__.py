"""CasADi models of coordarm: chain kinematics, curves, and the coordinating law.

Imports nothing else of coordarm.
"""
from .chain import PlanarChain
from .controller import LAWS, OUTPUTS, SCALAR_OUTPUTS, STEP_OUTPUTS, CoordinatingController
from .curves import Arc, Circle, Curve, Line, curve_from_spec
from .errors import BuildError, ConfigError, CoordarmError, LogError, SingularityError
from .start import project_onto_curve
from .motions import Constant, Ramp, Sinusoid, Smoothstep, motion_from_spec, motion_to_spec

__all__ = ["PlanarChain", "CoordinatingController", "LAWS", "OUTPUTS", "SCALAR_OUTPUTS", "STEP_OUTPUTS", "Curve", "Line", "Circle", "Arc",
           "curve_from_spec", "Constant", "Ramp", "Sinusoid", "Smoothstep", "motion_from_spec",
           "motion_to_spec", "CoordarmError", "ConfigError", "BuildError", "LogError",
           "SingularityError", "project_onto_curve"]
