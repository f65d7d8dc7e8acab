"""Scenarios as data: TOML files (or named presets) describing a whole run.

A scenario file is data only: every time-varying quantity is built from the motion
primitives of :mod:`symbolic.motions`; nothing read from a file is evaluated.

Layout (all tables but ``[chain]``, ``[curve]`` and ``[control]`` optional)::

    name = "line"
    description = "..."
    [chain]     links = 64, link_length = 0.1, joint_limit = 2.8 (or a list of m-1 [rad]),
                clearance = 0.0 [m], base = "fixed" | {kind = "rail", angle = 0.0, limits = [0, 5]}
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
    [thresholds] link = 0.02, longitudinal = 0.05
    [[obstacles]] a = [x, y], b = [x, y]      (wall segment), or center = [x, y], radius = r
                (disc), or points = [[x, y], ...] (closed polygon); name = "..." optional
    [figures]   stages = [0, 4, 8, 12]         (times of the stage figure [s]), or
                panels = [{title = "(a) ...", stages = [0, 2.5, 5]}, ...]  (one labelled panel each)
"""
from __future__ import annotations

import copy
import json
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from coordarm.symbolic.controller import check_damping
from coordarm.symbolic import (LAWS, ConfigError, CoordinatingController, Curve, PlanarChain, curve_from_spec,
                               follow_curve, motion_from_spec, project_onto_curve)
from coordarm.symbolic.checks import is_integer, is_real
from coordarm.symbolic.errors import shown
from coordarm.symbolic.start import check_start

from .choices import presets
from .limits import check_bounds, check_gain_step
from .obstacles import Obstacle, obstacles_from_spec
from .physical import Physical
from .run import DEFAULT_THRESHOLDS, check_number

SECTIONS = {"name", "description", "chain", "curve", "control", "start", "run", "thresholds",
            "obstacles", "figures"}
KEYS = {"chain": {"links", "link_length", "joint_limit", "clearance", "base"}, "figures": {"stages", "panels"}, "control": {"gain", "speed", "law", "span", "governor", "damping"},
        "start": {"kind", "beta", "heading", "curve"}, "run": {"duration", "step", "t0"},
        "thresholds": {"link", "longitudinal"}}
START_KINDS = ("zigzag", "projected", "follow")
#: ``[curve] kind`` of a scenario whose curve is a Python object (recorded in logs by class name).
USER_DEFINED = "user-defined"
DEFAULTS = {"start": {"kind": "zigzag", "beta": 1.3, "heading": 0.0},
            "run": {"duration": 20.0, "step": 0.001, "t0": 0.0},
            "control": {"law": "structured", "governor": False}}


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


@dataclass
class Scenario:
    """A validated scenario; build its parts with :meth:`controller` and :meth:`start`.

    Use :func:`load_scenario` (name or path) or :meth:`from_dict`.

    Attributes
    ----------
    spec : dict
        The validated scenario with every default filled in (the TOML layout of this module).
    source : str
        Where it came from (preset name, file path or ``<dict>``), used in error messages.
    obstacles : list of Obstacle
        Named wall segments, discs and polygons (:mod:`coordarm.simulation.obstacles`).
    curve : Curve or None
        A user-defined curve (``spec["curve"]`` then only names its class), or None.
    """

    spec: dict
    source: str = "<dict>"
    obstacles: list[Obstacle] = field(default_factory=list)
    #: A user-defined curve (Python object); ``spec["curve"]`` then only names its class.
    curve: Curve | None = None

    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>", curve: Curve | None = None) -> "Scenario":
        """Validate ``data`` (as read from TOML) and fill in defaults; errors name ``source`` and the field.

        ``curve`` is required when ``[curve] kind = "user-defined"`` (a log of a run with a
        user-defined curve): the object itself, which data cannot describe.
        """
        try:
            scenario = cls._from_dict(data, source, curve)
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None
        scenario.curve = curve
        return scenario

    def with_curve(self, curve: Curve) -> "Scenario":
        """A copy that runs the user-defined ``curve``; its spec records only the class name.

        Parameters
        ----------
        curve : Curve
            The user-defined curve.

        Returns
        -------
        Scenario
        """
        spec = copy.deepcopy(self.spec)
        spec["curve"] = {"kind": USER_DEFINED, "class": f"{type(curve).__module__}.{type(curve).__qualname__}"}
        return Scenario(spec, self.source, self.obstacles, curve)

    @classmethod
    def _from_dict(cls, data: Any, source: str, curve: Curve | None = None) -> "Scenario":
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
        ch = spec["chain"]
        for k in ("links", "link_length"):
            if k not in ch:
                raise ConfigError(f"chain.{k}: missing")
        if not is_integer(ch["links"]) or ch["links"] < 2:
            raise ConfigError(f"chain.links: need an integer >= 2, got {shown(ch['links'])}")
        check_number(ch["link_length"], "chain.link_length")
        for k in ("joint_limit", "clearance"):
            if k in ch:
                try:
                    PlanarChain(ch["links"], 1.0, **{k: ch[k]})
                except ConfigError as exc:
                    raise ConfigError(f"chain.{exc}") from None
        base = _base_args(ch.get("base", "fixed"))
        if "span" in spec["control"]:
            if base["base"] != "rail":
                raise ConfigError("control.span: only a chain on a rail (chain.base.kind = 'rail') has a span")
            motion_from_spec(spec["control"]["span"], "control.span")
        if "stages" in spec["figures"]:
            check_stages(spec["figures"]["stages"])
        panels = spec["figures"].get("panels", [])
        if not isinstance(panels, list) or not all(isinstance(p, dict) and set(p) == {"title", "stages"}
                                                    and isinstance(p["title"], str) for p in panels):
            raise ConfigError(f"figures.panels: expected [{{title = \"(a) ...\", stages = [t, ...]}}, ...], got {panels!r}")
        for i, p in enumerate(panels):
            check_stages(p["stages"], f"figures.panels[{i}].stages")
        if "gain" not in spec["control"]:
            raise ConfigError("control.gain: missing")
        check_number(spec["control"]["gain"], "control.gain")
        motion_from_spec(spec["control"].get("speed", 0.0), "control.speed")
        if spec["control"]["law"] not in LAWS:
            raise ConfigError(f"control.law: expected one of {LAWS}, got {shown(spec['control']['law'])}")
        if not isinstance(spec["control"]["governor"], bool):
            raise ConfigError(f"control.governor: expected true or false, got {shown(spec['control']['governor'])}")
        try:
            check_damping(spec["control"].get("damping"))
        except ConfigError as exc:
            raise ConfigError(f"control.{exc}") from None
        if spec["curve"].get("kind") == USER_DEFINED:
            if not isinstance(curve, Curve):
                raise ConfigError(f"curve: the run used a user-defined curve ({spec['curve'].get('class', '?')}), "
                                  f"which data cannot describe: pass the curve object in (curve=...)")
        else:
            curve_from_spec(spec["curve"], "curve")
        st = spec["start"]
        if st["kind"] not in START_KINDS:
            raise ConfigError(f"start.kind: expected one of {START_KINDS}, got {shown(st['kind'])}")
        b = check_number(st["beta"], "start.beta", positive=False)
        if not 0 < abs(b) < math.pi / 2:
            raise ConfigError(f"start.beta: need 0 < |beta| < pi/2, got {b}")
        check_number(st["heading"], "start.heading", positive=False)
        if "curve" in st:
            curve_from_spec(st["curve"], "start.curve")
        r = spec["run"]
        check_number(r["duration"], "run.duration")
        check_number(r["step"], "run.step")
        check_number(r["t0"], "run.t0", positive=False)
        if r["step"] > r["duration"]:
            raise ConfigError(f"run.step: {r['step']} is longer than run.duration {r['duration']}")
        check_bounds(ch["links"], ch["link_length"], r["step"], r["duration"], r["t0"], spec["control"]["gain"])
        check_gain_step(spec["control"]["gain"], r["step"], warn=False)
        for k in ("link", "longitudinal"):
            v = check_number(spec["thresholds"][k], f"thresholds.{k}", positive=False)
            if not 0 <= v < 1:
                raise ConfigError(f"thresholds.{k}: need 0 <= value < 1, got {v}")
        if spec["control"]["governor"] and not spec["thresholds"]["longitudinal"] > 0:
            raise ConfigError("thresholds.longitudinal: the governor slows v* to 0 at this margin; need > 0")
        obstacles = obstacles_from_spec(spec.setdefault("obstacles", []))
        spec["obstacles"] = [o.to_spec() for o in obstacles]
        return cls(spec, source, obstacles)

    # -------------------------------------------------------------- accessors
    @property
    def name(self) -> str:
        return self.spec["name"] or Path(self.source).stem

    @property
    def duration(self) -> float:
        return float(self.spec["run"]["duration"])

    @property
    def step(self) -> float:
        return float(self.spec["run"]["step"])

    @property
    def t0(self) -> float:
        return float(self.spec["run"]["t0"])

    @property
    def thresholds(self) -> dict[str, float]:
        return dict(self.spec["thresholds"])

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
        spec = copy.deepcopy(self.spec)
        if governor is not None:
            spec["control"]["governor"] = governor
        if damping is not None:
            spec["control"]["damping"] = damping
        if law is not None:
            spec["control"]["law"] = law
        if links is not None:
            spec["chain"]["links"] = links
        if duration is not None:
            spec["run"]["duration"] = duration
        if step is not None:
            spec["run"]["step"] = step
        return Scenario.from_dict(spec, self.source)

    @property
    def stages(self) -> list[float] | None:
        """Times of the stage figure [s] (``[figures] stages``), or None for evenly spread ones."""
        st = self.spec["figures"].get("stages")
        return None if st is None else check_stages(st)

    def chain(self) -> PlanarChain:
        """The manipulator this scenario describes (joint limits, clearance, base: fixed or rail).

        Returns
        -------
        PlanarChain
        """
        ch = self.spec["chain"]
        return PlanarChain(ch["links"], float(ch["link_length"]), joint_limit=ch.get("joint_limit"),
                           clearance=float(ch.get("clearance", 0.0)), **_base_args(ch.get("base", "fixed")))

    def physical(self, chain: PlanarChain | None = None) -> Physical:
        """What a run checks: the chain's joint limits and clearance, and the obstacles.

        Parameters
        ----------
        chain : PlanarChain, optional
            The scenario's chain, when the caller has it (built otherwise).

        Returns
        -------
        Physical
        """
        return Physical(chain or self.chain(), self.obstacles)

    def controller(self) -> CoordinatingController:
        """The coordinating controller this scenario describes.

        Returns
        -------
        CoordinatingController
        """
        c = self.spec["control"]
        span = motion_from_spec(c["span"], "control.span") if "span" in c else None
        curve = self.curve if self.curve is not None else curve_from_spec(self.spec["curve"])
        return CoordinatingController(self.chain(), curve, float(c["gain"]),
                                      motion_from_spec(c.get("speed", 0.0), "control.speed"),
                                      law=c["law"], span=span, governor=c["governor"],
                                      governor_threshold=float(self.spec["thresholds"]["longitudinal"]),
                                      damping=c.get("damping"))

    def start(self, ctrl: CoordinatingController | None = None) -> np.ndarray:
        """The start configuration ``q0`` (a zig-zag, projected onto a curve if asked).

        Parameters
        ----------
        ctrl : CoordinatingController, optional
            The scenario's controller, when the caller has it (built otherwise).

        Returns
        -------
        ndarray, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail).

        Raises
        ------
        ConfigError
            The start breaks a joint limit, folds onto itself or touches an obstacle (the
            joint, links or obstacle are named), or cannot be placed on the curve.
        """
        st = self.spec["start"]
        ctrl = ctrl or self.controller()
        d0 = max(ctrl.chain.rail_limits[0], 0.0) if ctrl.chain.rail else 0.0
        if st["kind"] == "follow":
            q = follow_curve(ctrl, float(st["beta"]), self.t0, d=d0)
        else:
            q = ctrl.chain.zigzag(float(st["beta"]), float(st["heading"]), d=d0)
        if st["kind"] == "projected":
            target = ctrl
            if "curve" in st:
                target = CoordinatingController(ctrl.chain, curve_from_spec(st["curve"], "start.curve"),
                                                ctrl.gain, 0.0)
            q = project_onto_curve(target, q, self.t0)
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


def _base_args(spec) -> dict:
    """``[chain] base``: ``"fixed"`` or ``{kind = "rail", angle = 0.0, limits = [0.0, 5.0]}`` as PlanarChain arguments."""
    if spec == "fixed":
        return {"base": "fixed"}
    if not isinstance(spec, dict) or spec.get("kind") != "rail":
        raise ConfigError(f"chain.base: expected \"fixed\" or a table {{kind = \"rail\", angle, limits}}, got {spec!r}")
    unknown = set(spec) - {"kind", "angle", "limits"}
    if unknown:
        raise ConfigError(f"chain.base: unknown key(s) {sorted(unknown)}; allowed: ['kind', 'angle', 'limits']")
    angle = check_number(spec.get("angle", 0.0), "chain.base.angle", positive=False)
    limits = spec.get("limits", [-math.inf, math.inf])
    if (not isinstance(limits, list) or len(limits) != 2
            or not all(is_real(v) for v in limits)
            or not limits[0] < limits[1]):
        raise ConfigError(f"chain.base.limits: need [low, high] with low < high [m], got {limits!r}")
    return {"base": "rail", "rail_angle": angle, "rail_limits": tuple(float(v) for v in limits)}


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a preset by name (``line``, ``arc``, ``hole``) or a TOML file by path.

    Parameters
    ----------
    name_or_path : str or Path
        A preset name (see :func:`coordarm.simulation.choices.presets`) or a ``.toml`` file.

    Returns
    -------
    Scenario

    Raises
    ------
    ConfigError
        Unknown preset, unreadable file, malformed TOML or an invalid field (named).
    """
    text = str(name_or_path)
    if text in presets():
        source = f"preset '{text}'"
        data = (resources.files("coordarm.simulation") / "presets" / f"{text}.toml").read_text()
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
    return Scenario.from_dict(parsed, source)
