"""Scenarios, the simulation loop and the run logs of coordarm (names load on first use)."""
from __future__ import annotations

from importlib import import_module
from typing import Any

_EXPORTS = {"simulate": "run", "Run": "run", "DEFAULT_THRESHOLDS": "run",
            "SingularityError": "coordarm.symbolic.errors", "ConfigError": "coordarm.symbolic.errors",
            "CoordarmError": "coordarm.symbolic.errors", "LogError": "coordarm.symbolic.errors"}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    """Load a public name from its module on first use."""
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'coordarm.simulation' has no attribute {name!r}") from None
    value = getattr(import_module(module if "." in module else f"{__name__}.{module}"), name)
    globals()[name] = value
    return value
