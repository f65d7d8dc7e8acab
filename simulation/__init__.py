"""Scenarios, the simulation loop and the run logs of coordarm (names load on first use)."""
from __future__ import annotations

from coordarm.symbolic.lazy import lazy_exports

_EXPORTS = {"simulate": "run", "Run": "run", "DEFAULT_THRESHOLDS": "run",
            "SingularityError": "coordarm.symbolic.errors", "ConfigError": "coordarm.symbolic.errors",
            "CoordarmError": "coordarm.symbolic.errors", "LogError": "coordarm.symbolic.errors"}

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
