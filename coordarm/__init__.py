"""coordarm: coordinating control of hyper-redundant manipulators, planar and spatial.

The public face of the package. Names load on first use, so ``import coordarm`` (and the
command line) start at once; CasADi, matplotlib and python-control are imported only by
the parts that need them.

>>> import coordarm
>>> scenario = coordarm.load_scenario("line")          # doctest: +SKIP
>>> ctrl = scenario.controller()                       # doctest: +SKIP
>>> run = coordarm.simulate(ctrl, scenario.start(ctrl), 1.0)   # doctest: +SKIP
>>> result = coordarm.run_scenario("line", duration=1.0, log="line.mcap")   # doctest: +SKIP
>>> result.outcome, result.log, result.figures                 # doctest: +SKIP

Layers (imports flow one way): ``coordarm.symbolic`` <- ``coordarm.generated`` <-
``coordarm.simulation`` <- ``coordarm.analysis`` <- ``coordarm.cli``.
"""
from __future__ import annotations

from typing import Any

from coordarm.version import __version__
from coordarm.symbolic.lazy import lazy_exports

#: Public name -> module that defines it (loaded on first attribute access).
_EXPORTS = {
    "PlanarChain": "coordarm.symbolic.chain",
    "ChainModel": "coordarm.symbolic.chain_model",
    "SpatialChain": "coordarm.symbolic.spatial_chain",
    "SpatialController": "coordarm.symbolic.spatial_controller",
    "Line3D": "coordarm.symbolic.curves3d",
    "Circle3D": "coordarm.symbolic.curves3d",
    "Arc3D": "coordarm.symbolic.curves3d",
    "Path3D": "coordarm.symbolic.paths3d",
    "CoordinatingController": "coordarm.symbolic.controller",
    "Curve": "coordarm.symbolic.curves",
    "Line": "coordarm.symbolic.curves",
    "Circle": "coordarm.symbolic.curves",
    "Arc": "coordarm.symbolic.curves",
    "curve_from_spec": "coordarm.symbolic.curve_specs",
    "Path": "coordarm.symbolic.paths",
    "Constant": "coordarm.symbolic.motions",
    "Ramp": "coordarm.symbolic.motions",
    "Sinusoid": "coordarm.symbolic.motions",
    "Smoothstep": "coordarm.symbolic.motions",
    "motion_from_spec": "coordarm.symbolic.motions",
    "project_onto_curve": "coordarm.symbolic.start",
    "CoordarmError": "coordarm.symbolic.errors",
    "ConfigError": "coordarm.symbolic.errors",
    "SingularityError": "coordarm.symbolic.errors",
    "TubeError": "coordarm.symbolic.errors",
    "BaseOffPathError": "coordarm.symbolic.errors",
    "CollisionError": "coordarm.symbolic.errors",
    "check_configuration": "coordarm.simulation.physical",
    "LogError": "coordarm.symbolic.errors",
    "BuildError": "coordarm.symbolic.errors",
    "NonFiniteError": "coordarm.symbolic.errors",
    "Interrupted": "coordarm.symbolic.interrupts",
    "LAW_OUTPUTS": "coordarm.symbolic.outputs",
    "compile": "coordarm.generated",
    "export_law": "coordarm.generated.export",
    "Scenario": "coordarm.simulation.scenario",
    "load_scenario": "coordarm.simulation.scenario",
    "presets": "coordarm.simulation.scenario",
    "simulate": "coordarm.simulation.run",
    "run_scenario": "coordarm.simulation.session",
    "ScenarioResult": "coordarm.simulation.session",
    "Run": "coordarm.simulation.run",
    "estimate": "coordarm.simulation.limits",
    "sweep": "coordarm.simulation.sweep",
    "Replay": "coordarm.analysis.replay",
    "load_log": "coordarm.analysis.replay",
}
_ALIASES = {"load_log": "load"}

__all__ = sorted(_EXPORTS)


_lazy = lazy_exports(__name__, _EXPORTS, _ALIASES)


def __getattr__(name: str) -> Any:
    """Load a public name from its module on first use (PEP 562)."""
    return _lazy(name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
