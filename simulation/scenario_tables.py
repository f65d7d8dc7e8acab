"""The tables of a scenario file as typed, frozen objects, validated once when read.

:func:`parse_scenario` checks a scenario as read from TOML (or from a log's JSON) in one pass,
field by field, and returns a :class:`ScenarioConfig`; every error is a ConfigError naming the
field (``chain.links``, ``control.speed``, ...). A table keeps its values as the file wrote them
(an integer gain stays an integer), so :meth:`ScenarioConfig.to_dict` gives back the validated
scenario, defaults filled in, exactly as a log stores it. The layout is described in
:mod:`coordarm.simulation.scenario`; the keys of a spatial chain (``[chain] joints = "universal"``)
are checked by :mod:`coordarm.simulation.spatial_tables`.
"""
from __future__ import annotations

import copy
import math
from dataclasses import field
from typing import TYPE_CHECKING, Any

from coordarm.symbolic import ConfigError, Curve, PlanarChain, curve_from_spec, motion_from_spec
from coordarm.symbolic.checks import bounded_motion, is_integer, is_real
from coordarm.symbolic.controller import check_damping
from coordarm.symbolic.errors import shown
from coordarm.symbolic.laws import LAWS, Law
from coordarm.symbolic.records import record

from .limits import RATE_KEYS, check_bounds, check_gain_step, check_links, rate_limits
from .obstacles import Obstacle, obstacles_from_spec
from .run import DEFAULT_THRESHOLDS, check_number
from .spatial_tables import (BEND_LIMIT, base_args, check_curve_kind, check_joints, check_kind_keys, roll_motion,
                             spatial_curve, spatial_start)

if TYPE_CHECKING:   # a universal chain's model and obstacles load with its scenario
    from coordarm.symbolic.spatial_chain import SpatialChain

    from .obstacles3d import Obstacle3D

SECTIONS = {"name", "description", "chain", "curve", "control", "start", "run", "thresholds", "obstacles", "figures"}
KEYS = {"chain": {"links", "link_length", "joint_limit", "clearance", "base", "joints", "radius", *RATE_KEYS},
        "figures": {"stages", "panels"}, "control": {"gain", "speed", "law", "span", "governor", "damping", "roll"},
        "start": {"kind", "beta", "heading", "curve", "axis", "fold", "roll"}, "run": {"duration", "step", "t0"},
        "thresholds": {"link", "longitudinal"}}
START_KINDS = ("zigzag", "projected", "follow")
#: ``[curve] kind`` of a scenario whose curve is a Python object (recorded in logs by class name).
USER_DEFINED = "user-defined"
DEFAULTS = {"start": {"kind": "zigzag", "beta": 1.3, "heading": 0.0},
            "run": {"duration": 20.0, "step": 0.001, "t0": 0.0},
            "control": {"law": Law.STRUCTURED.value, "governor": False}}


def _present(**values: Any) -> dict:
    """The keyword arguments that are not None (an optional key the file left out)."""
    return {k: v for k, v in values.items() if v is not None}


def check_stages(stages: Any, field: str = "figures.stages") -> list[float]:
    """Stage times [s] as a sorted list of finite numbers >= 0 (at least one).

    Parameters
    ----------
    stages : list of float
        The times, as read from the file.
    field : str
        Name used in error messages.

    Returns
    -------
    list of float
        Sorted times [s].

    Raises
    ------
    ConfigError
        Not a non-empty list of finite numbers >= 0.
    """
    if not isinstance(stages, list) or not stages:
        raise ConfigError(f"{field}: expected a non-empty list of times [s], got {shown(stages)}")
    return sorted(check_number(v, f"{field}[{i}]", positive=False) for i, v in enumerate(stages))


@record(frozen=True)
class ChainTable:
    """``[chain]``: the manipulator.

    Attributes
    ----------
    links : int
        Number of links m >= 2.
    link_length : float
        Length of every link [m] (> 0).
    joint_limit : float or list of float or None
        Joint limit [rad] (one, or one per joint 2..m); None: the chain's default.
    clearance : float or None
        Least distance kept between non-adjacent links [m]; None: 0.
    base : str or dict or None
        ``"fixed"`` or ``{kind = "rail", angle [rad], limits [m]}`` (a universal chain's rail:
        ``{kind = "rail", direction = [x, y, z], limits [m]}``); None: fixed.
    base_args : dict
        ``base`` as chain keyword arguments (``base``, ``rail_angle`` [rad] or ``rail_direction``,
        ``rail_limits`` [m]; :func:`base_args`), checked when read.
    joints : str
        ``"revolute"`` (a planar chain) or ``"universal"`` (a spatial chain, two angles per joint;
        its ``joint_limit`` bounds the bend ``acos(d_{j-1} . d_j)`` between consecutive links).
    radius : float or None
        Capsule radius of a universal chain's links [m]; None: ``link_length / 10``.
    rate_limit : float or None
        Largest ``|u|`` of any joint [rad/s], checked at every step (:mod:`.joint_rates`); None: unchecked.
    accel_limit : float or None
        Largest joint acceleration ``|du/dt|`` [rad/s^2], checked at every step; None: unchecked.
    """

    links: int
    link_length: float
    joint_limit: float | list[float] | None = None
    clearance: float | None = None
    base: str | dict | None = None
    base_args: dict = field(default_factory=lambda: {"base": "fixed"}, compare=False, repr=False)
    joints: str = "revolute"
    radius: float | None = None
    rate_limit: float | None = None
    accel_limit: float | None = None

    @property
    def rates(self) -> tuple[float | None, float | None]:
        """``(rate_limit, accel_limit)`` [rad/s, rad/s^2]."""
        return self.rate_limit, self.accel_limit

    @property
    def universal(self) -> bool:
        """Whether the joints are universal (a spatial chain)."""
        return self.joints == "universal"

    @property
    def bend_limit(self) -> float | list[float]:
        """Bend limit [rad] of a universal chain's joints 2..m (``joint_limit``, default 2.8 rad as planar)."""
        return BEND_LIMIT if self.joint_limit is None else self.joint_limit

    @property
    def rail(self) -> bool:
        """Whether the base slides on a rail."""
        return self.base_args["base"] == "rail"

    def build(self) -> PlanarChain | SpatialChain:
        """The chain this table describes.

        Returns
        -------
        PlanarChain or SpatialChain
            A new chain (clearance 0 when the table leaves it out); a SpatialChain for universal joints.
        """
        if self.universal:
            from coordarm.symbolic.spatial_chain import SpatialChain       # here: a planar run does not load it

            return SpatialChain(self.links, float(self.link_length), **self.base_args)
        return PlanarChain(self.links, float(self.link_length), joint_limit=self.joint_limit,
                           clearance=float(self.clearance or 0.0), **self.base_args)

    def to_dict(self) -> dict:
        """The table as the file writes it (keys left out stay out).

        Returns
        -------
        dict
            ``links``, ``link_length``, and ``joint_limit``, ``clearance``, ``base`` when given
            (and ``joints`` for a universal chain only: a planar scenario's stays as it was).
        """
        return {"links": self.links, "link_length": self.link_length, **_present(**dict(zip(RATE_KEYS, self.rates))),
                **_present(joint_limit=self.joint_limit, clearance=self.clearance, base=self.base,
                           joints=self.joints if self.universal else None, radius=self.radius)}


@record(frozen=True)
class ControlTable:
    """``[control]``: the law.

    Attributes
    ----------
    gain : float
        Error gain K [1/s] (> 0).
    law : str
        Form of the law, a :class:`~coordarm.symbolic.laws.Law` value.
    governor : bool
        Whether the speed governor slows ``v*`` near the longitudinal singularity.
    speed : float or list or dict or None
        Commanded end-point speed [m/s]: a number or a motion (:mod:`coordarm.symbolic.motions`); None: 0.
    span : float or list or dict or None
        Commanded span [m] of a chain on a rail (a motion); None: held.
    damping : dict or None
        ``{kind = "dls", lambda, band}``, or None for none.
    speed_motion : callable
        ``speed`` as a motion of time (built once, when read).
    span_motion : callable or None
        ``span`` as a motion of time.
    roll : float or list or dict or None
        Commanded roll [rad] of a universal chain (a motion); None: held at the start's roll.
    roll_motion : callable or None
        ``roll`` as a motion of time.
    """

    gain: float
    law: str = Law.STRUCTURED.value
    governor: bool = False
    speed: Any = None
    span: Any = None
    damping: dict | None = None
    speed_motion: Any = field(default=None, compare=False, repr=False)
    span_motion: Any = field(default=None, compare=False, repr=False)
    roll: Any = None
    roll_motion: Any = field(default=None, compare=False, repr=False)

    def to_dict(self) -> dict:
        """The table as the file writes it (keys left out stay out).

        Returns
        -------
        dict
            ``gain``, ``law``, ``governor``, and ``speed``, ``span``, ``damping``, ``roll`` when given
            (as given: numbers or motion specs, not the built motions).
        """
        return {"gain": self.gain, "law": self.law, "governor": self.governor,
                **_present(speed=self.speed, span=self.span, damping=self.damping, roll=self.roll)}


@record(frozen=True)
class StartTable:
    """``[start]``: the start configuration.

    Attributes
    ----------
    kind : str
        ``"zigzag"``, ``"projected"`` or ``"follow"``.
    beta : float
        Zig-zag half angle [rad], ``0 < |beta| < pi/2``.
    heading : float or None
        Heading of the zig-zag [rad]; None for a universal chain (which has ``axis`` and ``fold``).
    curve : dict or None
        ``projected``: the curve to project onto instead of the scenario's.
    curve_object : Curve or None
        ``curve`` built (once, when read).
    axis : list of float or None
        Universal chain: the zig-zag's axis (3,); None: the curve's tangent at the base at t0.
    fold : list of float or None
        Universal chain: the fold direction (3,); None: the curve's ``n_1`` there.
    roll : float or None
        Universal chain: turn of the fold direction about the axis [rad]; None: 0.
    """

    kind: str = "zigzag"
    beta: float = 1.3
    heading: float | None = 0.0
    curve: dict | None = None
    curve_object: Curve | None = field(default=None, compare=False, repr=False)
    axis: list[float] | None = None
    fold: list[float] | None = None
    roll: float | None = None

    def to_dict(self) -> dict:
        """The table as the file writes it (keys left out stay out).

        Returns
        -------
        dict
            ``kind``, ``beta`` [rad], ``heading`` [rad] (planar), and ``curve`` (its spec), ``axis``,
            ``fold``, ``roll`` [rad] when given.
        """
        return {"kind": self.kind, "beta": self.beta,
                **_present(heading=self.heading, curve=self.curve, axis=self.axis, fold=self.fold, roll=self.roll)}


@record(frozen=True)
class RunTable:
    """``[run]``: the simulated time.

    Attributes
    ----------
    duration : float
        Simulated duration [s] (> 0).
    step : float
        RK4 step [s] (> 0, at most ``duration``).
    t0 : float
        Start time [s].
    """

    duration: float = 20.0
    step: float = 0.001
    t0: float = 0.0

    def to_dict(self) -> dict:
        """The table as the file writes it.

        Returns
        -------
        dict
            ``duration``, ``step`` and ``t0`` [s].
        """
        return {"duration": self.duration, "step": self.step, "t0": self.t0}


@record(frozen=True)
class Thresholds:
    """``[thresholds]``: the singularity margins below which a run stops (dimensionless, in [0, 1)).

    Attributes
    ----------
    link : float
        Least link margin.
    longitudinal : float
        Least longitudinal margin.
    """

    link: float = DEFAULT_THRESHOLDS["link"]
    longitudinal: float = DEFAULT_THRESHOLDS["longitudinal"]

    def to_dict(self) -> dict:
        """The table as the file writes it.

        Returns
        -------
        dict
            ``link`` and ``longitudinal`` [-].
        """
        return {"link": self.link, "longitudinal": self.longitudinal}


@record(frozen=True)
class Panel:
    """One labelled panel of the stage figure.

    Attributes
    ----------
    title : str
        The panel's title, e.g. ``"(a) ..."``.
    stages : list of float
        Its stage times [s], as the file writes them.
    """

    title: str
    stages: list[float]


@record(frozen=True)
class FiguresTable:
    """``[figures]``: the stage figure.

    Attributes
    ----------
    stages : list of float or None
        Times of the stage figure [s] as written (None: evenly spread).
    panels : list of Panel or None
        One labelled panel each, or None.
    """

    stages: list[float] | None = None
    panels: list[Panel] | None = None

    def to_dict(self) -> dict:
        """The table as the file writes it (keys left out stay out).

        Returns
        -------
        dict
            ``stages`` [s] and ``panels`` (each ``{title, stages}``) when given; may be empty.
        """
        panels = None if self.panels is None else [{"title": p.title, "stages": p.stages} for p in self.panels]
        return _present(stages=self.stages, panels=panels)


@record(frozen=True)
class ScenarioConfig:
    """A whole scenario file, validated: one typed object per table.

    Attributes
    ----------
    name, description : str
        As written ("" when left out).
    chain : ChainTable
    curve : dict
        ``[curve]`` as written (its kinds and parameters: :func:`coordarm.symbolic.curve_from_spec`;
        for a universal chain :func:`coordarm.symbolic.curve3d_specs.curve3d_from_spec`).
    control : ControlTable
    start : StartTable
    run : RunTable
    thresholds : Thresholds
    obstacles : tuple of Obstacle (Obstacle3D for a universal chain)
    figures : FiguresTable
    curve_object : Curve or SpatialCurve or None
        ``curve`` built (once, when read); None for a user-defined curve.
    """

    name: str
    description: str
    chain: ChainTable
    curve: dict
    control: ControlTable
    start: StartTable
    run: RunTable
    thresholds: Thresholds
    obstacles: tuple[Obstacle | Obstacle3D, ...]
    figures: FiguresTable
    curve_object: Curve | None = field(default=None, compare=False, repr=False)

    def to_dict(self) -> dict:
        """The scenario as a log stores it: every table, defaults filled in.

        Returns
        -------
        dict
            Plain data (numbers, strings, lists, tables), a fresh copy.
        """
        return copy.deepcopy({
            "name": self.name, "description": self.description, "chain": self.chain.to_dict(),
            "curve": self.curve, "control": self.control.to_dict(), "start": self.start.to_dict(),
            "run": self.run.to_dict(), "thresholds": self.thresholds.to_dict(),
            "obstacles": [o.to_spec() for o in self.obstacles], "figures": self.figures.to_dict()})


def _tables(data: Any) -> dict:
    """The sections checked for shape (tables, known keys) with defaults filled in, as a fresh dict."""
    if not isinstance(data, dict):
        raise ConfigError("a scenario must be a table")
    unknown = set(data) - SECTIONS
    if unknown:
        raise ConfigError(f"unknown section(s) {sorted(unknown)}; allowed: {sorted(SECTIONS)}")
    spec = copy.deepcopy(data)
    for sec in ("chain", "curve", "control"):
        if not isinstance(spec.get(sec), dict):
            raise ConfigError(f"[{sec}]: missing or not a table")
    for sec, keys in KEYS.items():
        if sec in spec and not isinstance(spec[sec], dict):
            raise ConfigError(f"[{sec}]: not a table")
        spec[sec] = {**DEFAULTS.get(sec, {}), **spec.get(sec, {})}
        bad = set(spec[sec]) - keys
        if bad:
            raise ConfigError(f"[{sec}]: unknown key(s) {sorted(bad)}; allowed: {sorted(keys)}")
    spec["thresholds"] = {**DEFAULT_THRESHOLDS, **spec["thresholds"]}
    for k in ("name", "description"):
        if not isinstance(spec.setdefault(k, ""), str):
            raise ConfigError(f"{k}: expected a string")
    return spec


def _chain(ch: dict) -> ChainTable:
    for k in ("links", "link_length"):
        if k not in ch:
            raise ConfigError(f"chain.{k}: missing")
    if not is_integer(ch["links"]) or ch["links"] < 2:
        raise ConfigError(f"chain.links: need an integer >= 2, got {shown(ch['links'])}")
    check_links(ch["links"])         # before a chain of that size is built to check the joint limits
    check_number(ch["link_length"], "chain.link_length")
    for k in ("joint_limit", "clearance"):
        if k in ch:
            try:
                PlanarChain(ch["links"], 1.0, **{k: ch[k]})
            except ConfigError as exc:
                raise ConfigError(f"chain.{exc}") from None
    if "radius" in ch:
        check_number(ch["radius"], "chain.radius")
    joints = check_joints(ch.get("joints", "revolute"))
    return ChainTable(ch["links"], ch["link_length"], ch.get("joint_limit"), ch.get("clearance"), ch.get("base"),
                      base_args(ch.get("base", "fixed"), joints == "universal"), joints, ch.get("radius"),
                      *rate_limits(ch))


def _span(control: dict, chain: ChainTable) -> Any:
    """``[control] span`` as a motion (None when left out); only a chain on a rail has one."""
    if "span" not in control:
        return None
    if not chain.rail:
        raise ConfigError("control.span: only a chain on a rail (chain.base.kind = 'rail') has a span")
    return motion_from_spec(bounded_motion(control["span"], "control.span"), "control.span")


def _figures(fig: dict) -> FiguresTable:
    if "stages" in fig:
        check_stages(fig["stages"])
    panels = fig.get("panels", [])
    if not isinstance(panels, list) or not all(isinstance(p, dict) and set(p) == {"title", "stages"}
                                                and isinstance(p["title"], str) for p in panels):
        raise ConfigError(f"figures.panels: expected [{{title = \"(a) ...\", stages = [t, ...]}}, ...], got {panels!r}")
    for i, p in enumerate(panels):
        check_stages(p["stages"], f"figures.panels[{i}].stages")
    return FiguresTable(fig.get("stages"),
                        None if "panels" not in fig else [Panel(p["title"], p["stages"]) for p in panels])


def _control(c: dict, span_motion: Any) -> ControlTable:
    if "gain" not in c:
        raise ConfigError("control.gain: missing")
    check_number(c["gain"], "control.gain")
    speed_motion = motion_from_spec(bounded_motion(c.get("speed", 0.0), "control.speed"), "control.speed")
    if c["law"] not in LAWS:
        raise ConfigError(f"control.law: expected one of {LAWS}, got {shown(c['law'])}")
    if not isinstance(c["governor"], bool):
        raise ConfigError(f"control.governor: expected true or false, got {shown(c['governor'])}")
    try:
        check_damping(c.get("damping"))
    except ConfigError as exc:
        raise ConfigError(f"control.{exc}") from None
    return ControlTable(c["gain"], c["law"], c["governor"], c.get("speed"), c.get("span"), c.get("damping"),
                        speed_motion, span_motion, c.get("roll"), roll_motion(c))


def _curve(spec: dict, curve: Curve | None, chain: ChainTable) -> Curve | None:
    """``[curve]`` built (None for a user-defined curve, which must then be given as ``curve``)."""
    if chain.universal:
        return spatial_curve(spec, curve)
    if spec.get("kind") == USER_DEFINED:
        if not isinstance(curve, Curve):
            raise ConfigError(f"curve: the run used a user-defined curve ({spec.get('class', '?')}), "
                              f"which data cannot describe: pass the curve object in (curve=...)")
        return None
    check_curve_kind(spec, chain.joints)
    return curve_from_spec(spec, "curve")


def _start(st: dict, chain: ChainTable) -> StartTable:
    if chain.universal:
        b = check_number(st["beta"], "start.beta", positive=False)
        if not 0 < abs(b) < math.pi / 2:
            raise ConfigError(f"start.beta: need 0 < |beta| < pi/2, got {b}")
        return StartTable(st["kind"], st["beta"], None, **spatial_start(st))
    if st["kind"] not in START_KINDS:
        raise ConfigError(f"start.kind: expected one of {START_KINDS}, got {shown(st['kind'])}")
    b = check_number(st["beta"], "start.beta", positive=False)
    if not 0 < abs(b) < math.pi / 2:
        raise ConfigError(f"start.beta: need 0 < |beta| < pi/2, got {b}")
    check_number(st["heading"], "start.heading", positive=False)
    curve = curve_from_spec(st["curve"], "start.curve") if "curve" in st else None
    return StartTable(st["kind"], st["beta"], st["heading"], st.get("curve"), curve)


def _run(r: dict, chain: ChainTable, control: ControlTable) -> RunTable:
    check_number(r["duration"], "run.duration")
    check_number(r["step"], "run.step")
    check_number(r["t0"], "run.t0", positive=False)
    if r["step"] > r["duration"]:
        raise ConfigError(f"run.step: {r['step']} is longer than run.duration {r['duration']}")
    check_bounds(chain.links, chain.link_length, r["step"], r["duration"], r["t0"], control.gain)
    check_gain_step(control.gain, r["step"], warn=False)
    return RunTable(r["duration"], r["step"], r["t0"])


def _thresholds(thr: dict, control: ControlTable) -> Thresholds:
    for k in ("link", "longitudinal"):
        v = check_number(thr[k], f"thresholds.{k}", positive=False)
        if not 0 <= v < 1:
            raise ConfigError(f"thresholds.{k}: need 0 <= value < 1, got {v}")
    if control.governor and not thr["longitudinal"] > 0:
        raise ConfigError("thresholds.longitudinal: the governor slows v* to 0 at this margin; need > 0")
    return Thresholds(thr["link"], thr["longitudinal"])


def parse_scenario(data: Any, curve: Curve | None = None) -> ScenarioConfig:
    """Validate a scenario as read from TOML (or a log's JSON), once, field by field.

    Parameters
    ----------
    data : dict
        The scenario's tables (layout: :mod:`coordarm.simulation.scenario`).
    curve : Curve, optional
        The user-defined curve, required when ``[curve] kind = "user-defined"``.

    Returns
    -------
    ScenarioConfig
        The typed tables, defaults filled in.

    Raises
    ------
    ConfigError
        The first invalid field, named (``chain.links: ...``); the caller adds the file.
    """
    spec = _tables(data)
    check_kind_keys(data, check_joints(spec["chain"].get("joints", "revolute")))
    chain = _chain(spec["chain"])
    span_motion = _span(spec["control"], chain)
    figures = _figures(spec["figures"])
    control = _control(spec["control"], span_motion)
    curve_object = _curve(spec["curve"], curve, chain)
    start = _start(spec["start"], chain)
    run = _run(spec["run"], chain, control)
    thresholds = _thresholds(spec["thresholds"], control)
    if chain.universal:
        from .obstacles3d import obstacles3d_from_spec as read
    else:
        read = obstacles_from_spec
    obstacles = tuple(read(spec.setdefault("obstacles", [])))
    return ScenarioConfig(spec["name"], spec["description"], chain, spec["curve"], control, start, run,
                          thresholds, obstacles, figures, curve_object)
