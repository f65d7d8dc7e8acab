"""Scenarios, the simulation loop, logs and the command line of coordarm."""
from coordarm.symbolic.errors import ConfigError, CoordarmError, LogError, SingularityError

from .run import DEFAULT_THRESHOLDS, Run, simulate

__all__ = ["simulate", "Run", "DEFAULT_THRESHOLDS", "SingularityError", "ConfigError",
           "CoordarmError", "LogError"]
