"""Scenarios as data: TOML files (or named presets) describing a whole run.

A scenario file is data only: every time-varying quantity is built from the motion
primitives of :mod:`symbolic.motions`; nothing read from a file is evaluated.

Every key with its type, unit, default and an example: the documentation's *Scenario keys* page,
generated from :mod:`coordarm.simulation.scenario_tables` and :mod:`coordarm.simulation.spatial_tables`.
Layout (all tables but ``[chain]``, ``[curve]`` and ``[control]`` optional)::

    name = "line"
    description = "..."
    [chain]     links = 64, link_length = 0.1, joint_limit = 2.8 (or a list of m-1 [rad]),
                clearance = 0.0 [m], base = "fixed" | {kind = "rail", angle = 0.0, limits = [0, 5]},
                joints = "revolute" | "universal"
    [curve]     kind = "line" | "circle" | "arc" | "path" | "waypoints", with its parameters
                (path: start, heading, segments = [{line = L}, {arc = A, radius = R}, ...];
                waypoints: points, radius; both: offset, rotation optional)
    [control]   gain = 2.0, speed = 0.1 (or a motion), law = "structured" | "dense",
                span = motion (rail only: the commanded span; default: held),
                governor = false, damping = { kind = "dls", lambda = 0.01, band = 0.1 }
    [start]     kind = "zigzag" | "projected" | "follow", beta = 1.3, heading = 0.0,
                curve = {...}  (projected: project onto this curve instead;
                follow: a zig-zag laid link by link along the curve, for bent paths)
    [run]       duration = 20.0, step = 0.001, t0 = 0.0
    [thresholds] link = 0.02, longitudinal = 0.15
    [[obstacles]] a = [x, y], b = [x, y]      (wall segment), or center = [x, y], radius = r
                (disc), or points = [[x, y], ...] (closed polygon); name = "..." optional
    [figures]   stages = [0, 4, 8, 12]         (times of the stage figure [s]), or
                panels = [{title = "(a) ...", stages = [0, 2.5, 5]}, ...]  (one labelled panel each)

A spatial chain (``[chain] joints = "universal"``: two angles per joint, q = (a_1, b_1, ...)) reads
``joint_limit`` as the bend limit (default 2.8 rad, as planar) between consecutive links and takes::

    [curve]     kind = "line": point = [x, y, z] (motions), direction, normal, rotation = {axis, angle}
                kind = "arc" | "circle": centre, radius, normal; kind = "path": start, direction,
                normal, segments = [{line = L}, {arc = A, radius = R, bank = b}]; kind = "waypoints"
    [control]   roll = motion [rad] (default: held at the start's roll); span = motion (rail only, as
                planar); no governor, damping
    [start]     kind = "zigzag" | "follow", beta, axis = [x, y, z] (default: the curve's tangent at
                the base), fold = [x, y, z] (default: its n_1), roll = 0.0 [rad]
    [chain]     radius = link_length / 10 [m] (links are capsules), clearance = 0.0 [m] (extra distance),
                base = "fixed" | {kind = "rail", direction = [x, y, z], limits = [lo, hi]} (a feed axis:
                q = (d, a_1, b_1, ...), the base at d along the unit direction)
    [[obstacles]] kind = "plate" | "sphere" | "cylinder" | "box" (keys: :mod:`.obstacles3d`)
"""
from __future__ import annotations

import dataclasses
import json
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from coordarm.symbolic import ConfigError, CoordinatingController, Curve, PlanarChain, follow_curve, project_onto_curve
from coordarm.symbolic.lazy import package_folder
from coordarm.symbolic.records import record
from coordarm.symbolic.start import check_start

from .choices import presets
from .obstacles import Obstacle
from .physical import Physical
from .scenario_tables import USER_DEFINED, ScenarioConfig, check_stages, parse_scenario

if TYPE_CHECKING:   # a spatial chain's modules load when a universal scenario is run
    from coordarm.symbolic import SpatialChain, SpatialController

    from .obstacles3d import Obstacle3D
    from .physical3d import Physical3D


@record(frozen=True)
class Scenario:
    """A validated scenario; build its parts with :meth:`controller` and :meth:`start`.

    Use :func:`load_scenario` (name or path) or :meth:`from_dict`.

    Attributes
    ----------
    config : ScenarioConfig
        The validated tables (:mod:`coordarm.simulation.scenario_tables`), defaults filled in.
    source : str
        Where it came from (preset name, file path or ``<dict>``), used in error messages.
    curve : Curve or None
        A user-defined curve (``config.curve`` then only names its class), or None.
    """

    config: ScenarioConfig
    source: str = "<dict>"
    #: A user-defined curve (Python object); ``config.curve`` then only names its class.
    curve: Curve | None = None

    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>", curve: Curve | None = None) -> "Scenario":
        """Validate ``data`` (as read from TOML) and fill in defaults; errors name ``source`` and the field.

        ``curve`` is required when ``[curve] kind = "user-defined"`` (a log of a run with a
        user-defined curve): the object itself, which data cannot describe.

        Parameters
        ----------
        data : dict
            The scenario's tables (the layout of this module).
        source : str
            Where it came from, named in error messages.
        curve : Curve, optional
            The user-defined curve of a ``[curve] kind = "user-defined"`` scenario.

        Returns
        -------
        Scenario

        Raises
        ------
        ConfigError
            ``source: field: what is wrong`` for the first invalid field.
        """
        try:
            config = parse_scenario(data, curve)
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None
        return cls(config, source, curve)

    def with_curve(self, curve: Curve) -> "Scenario":
        """A copy that runs the user-defined ``curve``; its spec records only the class name.

        Parameters
        ----------
        curve : Curve
            The user-defined curve.

        Returns
        -------
        Scenario
            The copy; this scenario is unchanged.
        """
        named = {"kind": USER_DEFINED, "class": f"{type(curve).__module__}.{type(curve).__qualname__}"}
        return Scenario(dataclasses.replace(self.config, curve=named, curve_object=None), self.source, curve)

    # -------------------------------------------------------------- accessors
    @property
    def spec(self) -> dict:
        """The validated scenario as plain data, every default filled in (a fresh copy: the TOML layout)."""
        return self.config.to_dict()

    @property
    def obstacles(self) -> list[Obstacle | Obstacle3D]:
        """Named wall segments, discs and polygons (:mod:`coordarm.simulation.obstacles`), or 3-D obstacles."""
        return list(self.config.obstacles)

    @property
    def name(self) -> str:
        """``name``, or the file's stem when the file has none."""
        return self.config.name or Path(self.source).stem

    @property
    def duration(self) -> float:
        """``[run] duration`` [s]."""
        return float(self.config.run.duration)

    @property
    def step(self) -> float:
        """``[run] step`` [s]."""
        return float(self.config.run.step)

    @property
    def t0(self) -> float:
        """``[run] t0`` [s]."""
        return float(self.config.run.t0)

    @property
    def thresholds(self) -> dict[str, float]:
        """``[thresholds]``: ``{"link": .., "longitudinal": ..}`` (dimensionless)."""
        return self.config.thresholds.to_dict()

    def with_overrides(self, links: int | None = None, duration: float | None = None,
                       step: float | None = None, law: str | None = None, governor: bool | None = None,
                       damping: dict | None = None) -> "Scenario":
        """A copy with the chain length, duration, step, form of the law, governor or damping replaced.

        The copy is validated again.

        Parameters
        ----------
        links : int, optional
            Number of links.
        duration : float, optional
            Simulated duration [s].
        step : float, optional
            RK4 step [s].
        law : {"structured", "dense"}, optional
            Form of the law.
        governor : bool, optional
            ``[control] governor``.
        damping : dict, optional
            ``[control] damping`` (``{"kind": "dls", "lambda": .., "band": ..}``).

        Returns
        -------
        Scenario
            The new scenario (``None`` arguments keep their value).

        Raises
        ------
        ConfigError
            An override that is not valid.
        """
        spec = overridden(self.spec, links, duration, step, law, governor, damping)
        return Scenario.from_dict(spec, self.source)

    @property
    def stages(self) -> list[float] | None:
        """Times of the stage figure [s] (``[figures] stages``), sorted, or None for evenly spread ones."""
        st = self.config.figures.stages
        return None if st is None else check_stages(st)

    @property
    def universal(self) -> bool:
        """Whether the chain has universal joints (``[chain] joints = "universal"``: a spatial chain)."""
        return self.config.chain.universal

    def chain(self) -> PlanarChain | SpatialChain:
        """The manipulator this scenario describes (joint limits, clearance, base: fixed or rail).

        Returns
        -------
        PlanarChain or SpatialChain
            A new chain, built from the ``[chain]`` table (a SpatialChain for universal joints).
        """
        return self.config.chain.build()

    def physical(self, chain: PlanarChain | SpatialChain | None = None) -> Physical | Physical3D:
        """What a run checks: the chain's joint limits and clearance, and the obstacles.

        Parameters
        ----------
        chain : PlanarChain or SpatialChain, optional
            The scenario's chain, when the caller has it (built otherwise).

        Returns
        -------
        Physical or Physical3D
            The checks of a run (a universal chain's: bend limits, capsules apart, obstacles in 3-D).
        """
        if self.universal:
            from .spatial_scenario import spatial_physical
            return spatial_physical(self.config, chain or self.chain())
        return Physical(chain or self.chain(), self.obstacles, self.config.chain.rates)

    def controller(self) -> CoordinatingController | SpatialController:
        """The coordinating controller this scenario describes.

        Returns
        -------
        CoordinatingController or SpatialController
            A new controller; its ``governor_threshold`` is the longitudinal stop threshold
            (a universal chain's: a SpatialController, roll held at the start's unless commanded).
            Without a user-defined curve its recipe is the scenario's JSON
            (:meth:`~coordarm.symbolic.law_face.LawFace.set_recipe`).
        """
        c = self.config.control
        curve = self.curve if self.curve is not None else self.config.curve_object
        if self.universal:
            from .spatial_scenario import spatial_controller
            ctrl = spatial_controller(self.config, curve, self.to_json() if self.curve is None else None)
        else:
            ctrl = CoordinatingController(self.chain(), curve, float(c.gain), c.speed_motion, law=c.law,
                                          span=c.span_motion, governor=c.governor,
                                          governor_threshold=float(self.config.thresholds.longitudinal),
                                          damping=c.damping)
        if self.curve is None:      # the data says it all (a user's curve object is code of its own)
            ctrl.set_recipe(f"{type(ctrl).__module__}.{type(ctrl).__qualname__} of scenario {self.to_json()}")
        return ctrl

    def start(self, ctrl: CoordinatingController | SpatialController | None = None) -> np.ndarray:
        """The start configuration ``q0`` (a zig-zag, projected onto a curve if asked).

        Parameters
        ----------
        ctrl : CoordinatingController or SpatialController, optional
            The scenario's controller, when the caller has it (built otherwise).

        Returns
        -------
        ndarray, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail; ``(a_1, b_1, ..., a_m, b_m)`` for
            universal joints).

        Raises
        ------
        ConfigError
            The start breaks a joint limit, folds onto itself or touches an obstacle (the
            joint, links or obstacle are named), or cannot be placed on the curve.
        """
        st = self.config.start
        ctrl = ctrl or self.controller()
        if self.universal:
            from .spatial_scenario import laid_start
            return laid_start(self.config, ctrl)
        d0 = max(ctrl.chain.rail_limits[0], 0.0) if ctrl.chain.rail else 0.0

        def laid() -> np.ndarray:
            if st.kind == "follow":
                return follow_curve(ctrl, float(st.beta), self.t0, d=d0)
            q = ctrl.chain.zigzag(float(st.beta), float(st.heading), d=d0)
            if st.kind == "projected":
                target = ctrl
                if st.curve_object is not None:
                    target = CoordinatingController(ctrl.chain, st.curve_object, ctrl.gain, 0.0)
                q = project_onto_curve(target, q, self.t0)
            return q
        # A start laid along the curve or projected onto it (40-220 ms) is remembered under the controller's
        # recipe (None for a user's curve or a changed controller) and coordarm's code, to the last bit.
        recipe = getattr(ctrl, "recipe", None)
        if recipe is not None and st.kind != "zigzag":
            from coordarm.generated.source_memo import remembered_values
            q = remembered_values("planar start", recipe, laid)
        else:
            q = laid()
        check_start(ctrl, q)
        hits = [c for c in self.physical(ctrl.chain).check(np.array([self.t0]), q[None]) if c.kind == "wall"]
        if hits:
            raise ConfigError(f"start: {hits[0].describe().split(': ', 1)[1]}; move the obstacle or the start")
        return q

    def to_json(self) -> str:
        """The whole scenario as JSON (what a log stores to rebuild the run).

        Returns
        -------
        str
            :attr:`spec` as JSON, keys sorted.
        """
        return json.dumps(self.spec, sort_keys=True)


#: The overrides of the command line and the field each replaces.
OVERRIDES = {"links": ("chain", "links"), "duration": ("run", "duration"), "step": ("run", "step"),
             "law": ("control", "law"), "governor": ("control", "governor"), "damping": ("control", "damping")}


def overridden(spec: Any, links: int | None = None, duration: float | None = None, step: float | None = None,
               law: str | None = None, governor: bool | None = None, damping: dict | None = None) -> Any:
    """``spec`` (scenario tables as read, not yet validated) with the given fields replaced, in place.

    Parameters
    ----------
    spec : dict
        The tables; anything else (a malformed file) is returned unchanged for validation to name.
    links, duration, step, law, governor, damping : optional
        ``chain.links``, ``run.duration`` [s], ``run.step`` [s], ``control.law``,
        ``control.governor``, ``control.damping``; None keeps the file's value.

    Returns
    -------
    dict
        ``spec``.
    """
    values = {"links": links, "duration": duration, "step": step, "law": law, "governor": governor,
              "damping": damping}
    for name, value in values.items():
        table, key = OVERRIDES[name]
        if value is None or not isinstance(spec, dict):
            continue
        if table not in spec:
            spec[table] = {}
        if isinstance(spec[table], dict):
            spec[table][key] = value
    return spec


def load_scenario(name_or_path: str | Path, **overrides: Any) -> Scenario:
    """Load a preset by name (``line``, ``arc``, ``hole``) or a TOML file by path.

    The overrides replace the file's fields before it is validated, so that a check of two
    fields together (``control.gain`` x ``run.step``) sees the values the run will use.

    Parameters
    ----------
    name_or_path : str or Path
        A preset name (see :func:`coordarm.simulation.choices.presets`) or a ``.toml`` file.
    **overrides
        ``links``, ``duration``, ``step``, ``law``, ``governor``, ``damping`` (see
        :func:`overridden`); None keeps the file's value.

    Returns
    -------
    Scenario
        The validated scenario; its ``source`` is ``preset '<name>'`` or the path.

    Raises
    ------
    ConfigError
        Unknown preset, unreadable file, malformed TOML or an invalid field (named).
    """
    text = str(name_or_path)
    if text in presets():
        source = f"preset '{text}'"
        data = (package_folder("coordarm.simulation", "presets") / f"{text}.toml").read_text()
    else:
        path = Path(text)
        if not path.is_file():
            raise ConfigError(f"{text}: neither a preset ({', '.join(presets())}) nor a readable file")
        source = str(path)
        try:
            data = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(f"{path}: cannot read: {exc}") from None
    try:
        parsed = tomllib.loads(data)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: not valid TOML: {exc}") from None
    except RecursionError:
        raise ConfigError(f"{source}: not valid TOML: arrays or tables nested too deeply") from None
    return Scenario.from_dict(overridden(parsed, **overrides), source)
