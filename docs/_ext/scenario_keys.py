"""The scenario key reference, generated from the definitions the parser uses (so it cannot drift).

Keys come from the parser's own tables (``scenario_tables.SECTIONS``/``KEYS``, the curve kinds of
``curve_specs``/``curve3d_specs``, the obstacle kinds, the motion classes, the path segments); types,
units and descriptions from the numpydoc docstrings of the frozen dataclasses and classes that hold
them; defaults from the dataclass defaults and ``scenario_tables.DEFAULTS``. :func:`rows` is the
reference as data (the test checks it covers every key the parser accepts), :func:`markdown` the page.
"""
from __future__ import annotations

import dataclasses
import re
from typing import Any, NamedTuple

from numpydoc.docscrape import ClassDoc, FunctionDoc, NumpyDocString

UNIT = re.compile(r"\[(m|rad|s|1/s|m/s|rad/s|m/rad|-)\]")


class Row(NamedTuple):
    """One key of the reference: ``table`` (``chain``, ``curve.kind=line``, ...), ``key``, the rest text."""

    table: str
    key: str
    type: str
    unit: str
    default: str
    description: str
    applies: str = "both"


def _docs(doc: NumpyDocString, section: str) -> dict[str, tuple[str, str]]:
    """name -> (type, description) of a numpydoc section (``a, b : float`` gives both names)."""
    out = {}
    for p in doc[section]:
        for name in (n.strip() for n in p.name.split(",")):
            out[name] = (p.type, " ".join(p.desc))
    return out


def _unit(text: str, typ: str = "") -> str:
    if "float" not in typ and ("dict" in typ or "table" in typ):
        return ""
    m = UNIT.search(text)
    return m.group(1) if m else ""


def _shown(value: Any) -> str:
    if value is dataclasses.MISSING:
        return "required"
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "`true`" if value else "`false`"
    if isinstance(value, str):
        return f'`"{value}"`'
    return f"`{value}`"


def _table_rows(table: str, cls: type, keys: Any, defaults: dict, applies: dict[str, str]) -> list[Row]:
    """Rows of one ``[table]`` held by the frozen dataclass ``cls`` (its Attributes give type and text)."""
    attrs = _docs(ClassDoc(cls), "Attributes")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    rows = []
    for key in sorted(keys):
        typ, text = attrs[key]
        f = fields[key]
        default = defaults.get(key, f.default if f.default is not dataclasses.MISSING else
                               (dataclasses.MISSING if f.default_factory is dataclasses.MISSING else None))
        rows.append(Row(table, key, typ, _unit(text, typ), _shown(default), text, applies.get(key, "both")))
    return rows


def _class_rows(table: str, params: dict[str, tuple[str, str]], required: Any, optional: Any,
                applies: str) -> list[Row]:
    """Rows of a ``kind`` table whose keys are the parameters of a class or function."""
    rows = []
    for key in list(required) + list(optional):
        typ, text = params[key]
        needed = key in required and not typ.endswith(", optional")
        rows.append(Row(table, key, typ.replace(", optional", ""), _unit(text, typ),
                        "required" if needed else "optional", text, applies))
    return rows


def rows() -> list[Row]:
    """Every key a scenario file may hold, one row each.

    Returns
    -------
    list of Row
        In page order: top level, tables, sub-tables, curve kinds, obstacles, motions.
    """
    from coordarm.simulation import obstacles, obstacles3d, scenario_tables as st, spatial_tables as sp
    from coordarm.simulation.run import DEFAULT_THRESHOLDS
    from coordarm.symbolic import curve3d_specs, curve_specs, motions, paths, paths3d
    from coordarm.symbolic.controller import check_damping

    applies = {}
    for sec, keys in sp.PLANAR_ONLY.items():
        applies.update({(sec, k): "planar" for k in keys})
    for sec, keys in sp.SPATIAL_ONLY.items():
        applies.update({(sec, k): "spatial" for k in keys})
    by_sec = {sec: {k: a for (s, k), a in applies.items() if s == sec} for sec in st.KEYS}
    config = _docs(ClassDoc(st.ScenarioConfig), "Attributes")
    out = [Row("", k, config[k][0], "", '`""`', "Shown in messages, logs and figures.") for k in ("name", "description")]
    tables = {"chain": st.ChainTable, "control": st.ControlTable, "start": st.StartTable, "run": st.RunTable,
              "thresholds": st.Thresholds, "figures": st.FiguresTable}
    defaults = {**st.DEFAULTS, "thresholds": DEFAULT_THRESHOLDS}
    for sec in st.KEYS:
        out += _table_rows(sec, tables[sec], st.KEYS[sec], defaults.get(sec, {}), by_sec[sec])
    rail = _docs(FunctionDoc(st.base_args), "Parameters")["spec"][1]
    out += [Row("chain.base", "kind", "str", "", "required", '`"rail"`: the base slides on a rail. ' + rail, "planar"),
            Row("chain.base", "angle", "float", "rad", "`0.0`", "Direction of the rail.", "planar"),
            Row("chain.base", "limits", "[low, high] of float", "m", "unbounded",
                "Travel of the base along the rail, low < high.", "planar")]
    damping = _docs(FunctionDoc(check_damping), "Parameters")["damping"][1]
    out += [Row("control.damping", "kind", "str", "", "required", '`"dls"`: damped least squares. ' + damping, "planar"),
            Row("control.damping", "lambda", "float", "m/rad", "optional", "Largest damping of the DLS solve.", "planar"),
            Row("control.damping", "band", "float in (0, 1]", "", "optional",
                "Margin below which the damping fades in.", "planar")]
    out += [Row("figures.panels[]", "title", "str", "", "required", 'The panel\'s title, e.g. `"(a) ..."`.'),
            Row("figures.panels[]", "stages", "list of float", "s", "required", "Its stage times.")]
    kinds = list(curve_specs.CURVES) + list(curve_specs.PATH_KINDS)
    out.append(Row("curve", "kind", "str", "", "required",
                   "One of " + ", ".join(f'`"{k}"`' for k in kinds) + " (planar: the tables below) or "
                   + ", ".join(f'`"{k}"`' for k in curve3d_specs.CURVE3D_KINDS) + " (spatial); a log of a run with a "
                   f'Python curve records `"{st.USER_DEFINED}"` and its `class`.'))
    for kind, (cls, keys) in curve_specs.CURVES.items():
        out += _class_rows(f"curve kind={kind}", _docs(ClassDoc(cls), "Parameters"), keys, (), "planar")
    path = _docs(ClassDoc(paths.Path), "Parameters")
    waypoints = _docs(FunctionDoc(paths.Path.from_waypoints), "Parameters")
    for kind, keys in curve_specs.PATH_KINDS.items():
        need = keys[:3] if kind == "path" else keys[:2]
        out += _class_rows(f"curve kind={kind}", waypoints if kind == "waypoints" else path, need,
                           [k for k in keys if k not in need], "planar")
    spatial = {"line": ClassDoc(__import__("coordarm.symbolic.curves3d", fromlist=["Line3D"]).Line3D)}
    from coordarm.symbolic.curves3d import Arc3D, Circle3D
    spatial.update(circle=ClassDoc(Circle3D), arc=ClassDoc(Arc3D), path=ClassDoc(paths3d.Path3D),
                   waypoints=FunctionDoc(paths3d.Path3D.from_waypoints))
    for kind, (need, optional) in curve3d_specs.CURVE3D_KINDS.items():
        out += _class_rows(f"curve kind={kind} spatial", _docs(spatial[kind], "Parameters"), need, optional,
                           "spatial")
    out += [Row("curve.segments[]", "line", "float", "m", "—", "A straight piece of this length."),
            Row("curve.segments[]", "arc", "float", "rad", "—", "An arc turning by this angle (planar: + = left)."),
            Row("curve.segments[]", "radius", "float", "m", "required with `arc`", "The arc's radius."),
            Row("curve.segments[]", "bank", "float", "rad", "`0.0`",
                "The arc turns towards `cos(bank) n_1 + sin(bank) n_2`.", "spatial"),
            Row("curve.segments[]", "transition", "float", "m", "the path's",
                "Length of the clothoid transition at the junction before this segment (0: a G1 join).")]
    texts = {"a": "One end of the wall segment [m].", "b": "The other end [m].", "center": "Centre of the disc [m].",
             "radius": "Radius of the disc [m].", "points": "Corners of the closed (solid) polygon [m]."}
    for kind, keys in obstacles.KINDS.items():
        out += [Row(f"obstacles kind={kind}", k, "float" if k == "radius" else "[x, y] list", _unit(texts[k]),
                    "required", texts[k], "planar") for k in keys]
    out.append(Row("obstacles", "name", "str", "", "`wall 1`, `wall 2`, … (spatial: `<kind> <i>`)",
                   "Shown in messages, figures and the outcome."))
    out.append(Row("obstacles", "kind", "str", "", "required (spatial)",
                   "Spatial obstacles: " + ", ".join(f'`"{k}"`' for k in obstacles3d.KINDS3D)
                   + "; planar ones are told apart by their keys.", "spatial"))
    out += _obstacle3d_rows(obstacles3d.KINDS3D)
    for kind, cls in motions.KINDS.items():
        attrs = _docs(ClassDoc(cls), "Attributes")
        for f in dataclasses.fields(cls):
            typ, text = attrs[f.name]
            out.append(Row(f"motion kind={kind}", f.name, typ, _unit(text),
                           "required" if f.default is dataclasses.MISSING else _shown(f.default), text))
    return out


def _obstacle3d_rows(kinds: dict) -> list[Row]:
    """The keys of the spatial obstacles (their texts follow :mod:`coordarm.simulation.obstacles3d`)."""
    texts = {"point": ("[x, y, z]", "A point of the plate's mid-plane [m]."),
             "normal": ("[x, y, z]", "The plate's normal (any non-zero length)."),
             "thickness": ("float", "Thickness of the slab about its mid-plane [m]."),
             "extent": ("float", "Half-size of a square plate in its plane [m]; default unbounded."),
             "holes": ("list of tables", "`{centre, radius}` (circle) or `{centre, size = [w, h]}` (rectangle "
                       "along the plate's `u = v x n` and `v`, `e_z` projected onto the plate) [m]."),
             "centre": ("[x, y, z]", "Centre of the sphere or box [m]."),
             "radius": ("float", "Radius of the sphere or cylinder [m]."),
             "a": ("[x, y, z]", "One end of the cylinder's axis [m]."), "b": ("[x, y, z]", "The other end [m]."),
             "caps": ("str", '`"round"`: a capsule (the only kind).'),
             "size": ("[x, y, z]", "Full edges of the box along x, y, z [m]."),
             "rotation": ("table", "`{axis = [x, y, z], angle}`: the box turned by angle [rad] about axis.")}
    return [Row(f"obstacles kind={kind}", k, texts[k][0], _unit(texts[k][1]),
                "required" if k in need else "optional", texts[k][1], "spatial")
            for kind, (need, optional) in kinds.items() for k in list(need) + list(optional)]


ROLE = re.compile(r":[a-z]+:`~?([^`]*)`")


def _cell(text: str) -> str:
    """One table cell: reST markup (``x``, :class:`~a.B`) as Markdown, pipes escaped, on one line."""
    text = ROLE.sub(lambda m: f"`{m.group(1).rsplit('.', 1)[-1]}`", str(text)).replace("``", "`")
    return " ".join(text.split()).replace("|", "\\|")


def _presets() -> dict[str, dict]:
    """The shipped presets as written (name -> TOML tables)."""
    import tomllib
    from importlib import resources

    folder = resources.files("coordarm.simulation") / "presets"
    return {p.name[:-5]: tomllib.loads(p.read_text()) for p in folder.iterdir() if p.name.endswith(".toml")}


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)


def _tables_of(row: Row, data: dict) -> list[dict]:
    """The tables of one preset where ``row``'s key may appear."""
    t = row.table
    if t == "":
        return [data]
    if t == "curve":
        return [data.get("curve", {})]
    if t in ("chain", "control", "start", "run", "thresholds", "figures"):
        return [data.get(t, {})]
    if t in ("chain.base", "control.damping"):
        sec, key = t.split(".")
        v = data.get(sec, {}).get(key)
        return [v] if isinstance(v, dict) else []
    if t.startswith("curve kind="):
        c = data.get("curve", {})
        spatial = data.get("chain", {}).get("joints") == "universal"
        same_kind = (row.applies == "spatial") == spatial
        return [c] if c.get("kind") == t.split("=")[1].split()[0] and same_kind else []
    if t in ("figures.panels[]", "curve.segments[]"):
        sec, key = t[:-2].split(".")
        return [v for v in data.get(sec, {}).get(key, []) if isinstance(v, dict)]
    if t.startswith("obstacles"):
        kind = t.split("=")[1] if "=" in t else None
        return [o for o in data.get("obstacles", []) if kind is None or o.get("kind", kind) == kind
                and (("kind" in o) == (row.applies == "spatial"))]
    return []


def example(row: Row, presets: dict[str, dict]) -> str:
    """``key = value`` as the first preset that sets this key writes it (``—`` when none does).

    Parameters
    ----------
    row : Row
        The key.
    presets : dict
        Preset name -> its tables as written.

    Returns
    -------
    str
        Markdown, e.g. a backquoted ``links = 64`` and the preset's name.
    """
    for name in sorted(presets):
        for table in _tables_of(row, presets[name]):
            if row.key in table:
                text = _toml(table[row.key])
                if len(text) > 60:
                    text = text[:57] + "..."
                return f"`{row.key} = {text}` ({name})"
    return "—"


INTRO = """\
(scenario-keys)=
# Scenario keys

<!-- Generated by docs/_ext/scenario_keys.py from the scenario definitions; do not edit. -->

Every key a scenario file (TOML) may hold, generated when the documentation is built from the
tables, frozen dataclasses and docstrings that the parser itself uses, so it cannot drift from the
code, with an example from a shipped preset where one sets the key. Keys marked *planar only*
belong to revolute chains, *spatial only* to chains with `[chain] joints = "universal"`; the other
kind refuses them with a one-line error (exit status 2). A value marked
*motion* is a number, a motion table (`{{ kind = "sinusoid", amplitude = 0.6, omega = 0.2 }}`) or a
list of them (summed): see [Motions](#motions). Tables other than `[chain]`, `[curve]` and
`[control]` are optional. The presets (`{presets}`) are complete examples: `coordarm run NAME` runs
one, and the files ship in `coordarm/simulation/presets/`.
"""

TITLES = {"": "Top level", "chain": "`[chain]`", "control": "`[control]`", "start": "`[start]`",
          "run": "`[run]`", "thresholds": "`[thresholds]`", "figures": "`[figures]`",
          "chain.base": "`[chain] base` (a rail)", "control.damping": "`[control] damping`",
          "figures.panels[]": "`[figures] panels` entries", "curve.segments[]": "`[curve] segments` entries",
          "obstacles": "`[[obstacles]]`", "curve": "`[curve]`"}


def _title(table: str) -> str:
    if table.startswith("curve kind="):
        kind, *spatial = table.split("=")[1].split()
        return f'`[curve] kind = "{kind}"`' + (" (spatial)" if spatial else "")
    if table.startswith("obstacles kind="):
        return f'`[[obstacles]]` {table.split("=")[1]}'
    if table.startswith("motion kind="):
        return f'`kind = "{table.split("=")[1]}"`'
    return TITLES[table]


def markdown() -> str:
    """The reference page (MyST Markdown).

    Returns
    -------
    str
        One table per scenario table and kind.
    """
    presets = _presets()
    groups: dict[str, list[Row]] = {}
    for r in rows():
        groups.setdefault(r.table, []).append(r)
    lines = [INTRO.format(presets="`, `".join(sorted(presets)))]
    motions_started = False
    for table, rs in groups.items():
        if table.startswith("motion kind=") and not motions_started:
            lines += ["## Motions", "",
                      "A time-varying value: a number (constant), one of these tables, or a list of them (summed).",
                      "Nothing in a file is evaluated.", ""]
            motions_started = True
        by_kind = sorted({r.applies for r in rs})
        level = "###" if motions_started else "##"
        lines += [f"{level} {_title(table)}", ""]
        if by_kind != ["both"] and len(by_kind) == 1:
            lines += [f"*{by_kind[0]} chains*", ""]
        lines += ["| key | type | unit | default | description | example |", "|---|---|---|---|---|---|"]
        lines += [f"| `{r.key}` | {_cell(r.type)} | {_cell(r.unit)} | {_cell(r.default)} | {_cell(r.description)} "
                  f"{'' if r.applies in ('both', by_kind[0]) else '(' + r.applies + ' only) '}"
                  f"| {_cell(example(r, presets))} |" for r in rs]
        lines.append("")
    return "\n".join(lines)
