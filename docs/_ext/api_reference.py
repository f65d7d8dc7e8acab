"""The API reference pages, generated from the package layout: every public module, with autodoc."""
from __future__ import annotations

import importlib
import pkgutil

#: The packages of coordarm, in the order of its layers (the face first).
PACKAGES = {"coordarm": "the public face (``import coordarm``) and the command line",
            "coordarm.commands": "one module per ``coordarm`` sub-command",
            "coordarm.symbolic": "CasADi models: chains, curves, the control law",
            "coordarm.generated": "generated C: code generation, build cache, export",
            "coordarm.simulation": "scenarios, the run loop, physical checks, logs, figures, sweeps",
            "coordarm.analysis": "replay, reports, margins, linearisation, baselines, compare"}


def modules(package: str) -> list[str]:
    """The public modules of one package (names without a leading underscore), the package first.

    Parameters
    ----------
    package : str
        E.g. ``"coordarm.symbolic"``.

    Returns
    -------
    list of str
        Dotted module names, sorted.
    """
    pkg = importlib.import_module(package)
    subs = sorted(i.name for i in pkgutil.iter_modules(pkg.__path__, package + ".")
                  if not i.name.rsplit(".", 1)[-1].startswith("_") and not i.ispkg)
    return [package] + subs


def pages() -> dict[str, str]:
    """File name (under ``docs/api/``) -> reStructuredText, one page per package and an index.

    Returns
    -------
    dict
        ``index.rst`` and ``<package>.rst``.
    """
    out = {}
    index = ["API reference", "=============", "",
             "Generated from the docstrings (numpydoc) of every public module, by layer: imports flow one way,",
             "``coordarm.symbolic`` <- ``coordarm.generated`` <- ``coordarm.simulation`` <- ``coordarm.analysis``",
             "<- ``coordarm.cli`` / ``coordarm.commands``. The names most users need are re-exported by",
             "``import coordarm`` (see :mod:`coordarm`).", "", ".. toctree::", "   :maxdepth: 1", ""]
    for package, what in PACKAGES.items():
        index.append(f"   {package}")
        title = f"``{package}``: {what}"
        lines = [title, "=" * len(title), ""]
        for mod in modules(package):
            if mod != package:
                lines += [f"``{mod}``", "-" * (len(mod) + 4), ""]
            lines += [f".. automodule:: {mod}", "   :members:", "   :ignore-module-all:", "   :show-inheritance:", ""]
            if mod == "coordarm":
                lines += _face()
        out[f"{package}.rst"] = "\n".join(lines)
    out["index.rst"] = "\n".join(index) + "\n"
    return out


def _face() -> list[str]:
    """The names ``import coordarm`` gives, each linked to where it is documented."""
    import coordarm

    lines = ["Public names", "^^^^^^^^^^^^", "", "``import coordarm`` loads these on first use:", ""]
    for name in coordarm.__all__:
        module = coordarm._EXPORTS[name]
        real = coordarm._ALIASES.get(name, name)
        obj = getattr(importlib.import_module(module), real)
        role = "class" if isinstance(obj, type) else "func" if callable(obj) else "data"
        lines.append(f"* ``coordarm.{name}``: :py:{role}:`{module}.{real}`")
    return lines + [""]
