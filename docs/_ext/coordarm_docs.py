"""Sphinx extension of the coordarm site: writes the generated pages before the build reads the sources.

* ``reference/scenario-keys.md`` from the scenario definitions (:mod:`scenario_keys`),
* ``reference/cli.md`` from the command-line parser (:mod:`cli_reference`),
* ``api/*.rst`` from the package layout (:mod:`api_reference`).

A page is rewritten only when its text changes, so an incremental build stays incremental.
"""
from __future__ import annotations

from pathlib import Path

import api_reference
import cli_reference
import scenario_keys


def write_if_changed(path: Path, text: str) -> bool:
    """Write ``text`` to ``path`` unless it already holds it; True when written."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_file() and path.read_text() == text:
        return False
    path.write_text(text)
    return True


def generate(srcdir: Path) -> list[Path]:
    """Write every generated page under ``srcdir`` (the ``docs/`` folder).

    Returns
    -------
    list of Path
        The generated files.
    """
    pages = {srcdir / "reference" / "scenario-keys.md": scenario_keys.markdown(),
             srcdir / "reference" / "cli.md": cli_reference.markdown()}
    pages.update({srcdir / "api" / name: text for name, text in api_reference.pages().items()})
    for path, text in pages.items():
        write_if_changed(path, text if text.endswith("\n") else text + "\n")
    return list(pages)


def skip_member(app, what: str, name: str, obj, skip: bool, options) -> bool | None:
    """Leave type variables out of the API reference (numpydoc cannot read their docstring)."""
    import typing

    if isinstance(obj, typing.TypeVar):
        return True
    return None


def _builder_inited(app) -> None:
    generate(Path(app.srcdir))


def setup(app) -> dict:
    """Register the generator with Sphinx."""
    app.connect("builder-inited", _builder_inited)
    app.connect("autodoc-skip-member", skip_member)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
