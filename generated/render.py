"""Fill the C templates of :mod:`coordarm.generated`: the files under ``templates/`` (package data).

A template is plain C (or a header, or a Makefile) whose placeholders are written ``@name@``, ``name``
a lower-case identifier. No C, preprocessor or Makefile text of the templates has that form (C has
no ``@``; a Makefile's ``$@`` is never followed by a name and an ``@``), so the braces of C need no
escaping. A value is inserted as ``format(value)`` and is not scanned again. A placeholder that
stands for whole lines (a value ending in a newline) is written at the start of the line after them.

Templates (``name`` relative to ``templates/``): ``casadi.c`` wraps CasADi's generated Functions,
``prelude.c`` holds the sizes and the finiteness helpers (with ``b_identity.h`` or
``b_diagonal.h``), ``trig_passes.c``, ``structured_law.c`` and ``path_search.c`` the structured
law, ``spatial_law.c`` the structured law of a spatial chain, ``dense_law.c`` the dense one,
``library_api.c`` the library's entry points; ``export/`` holds the files of ``coordarm export``
(``export/singular_planar.c`` or ``export/singular_spatial.c`` fill its singularity checks).
"""
from __future__ import annotations

import re
from functools import cache

from coordarm.symbolic.lazy import package_folder

#: A placeholder: ``@name@``.
PLACEHOLDER = re.compile(r"@([a-z_][a-z0-9_]*)@")
#: The folder of the templates inside this package.
FOLDER = "templates"


class TemplateError(ValueError):
    """A template rendered with a placeholder left without a value, or with a value it has no place for."""


@cache
def template_text(name: str) -> str:
    """The text of template ``name`` as stored (placeholders unfilled).

    Parameters
    ----------
    name : str
        Path relative to ``templates/``, ``/``-separated (e.g. ``"export/api.c"``).

    Returns
    -------
    str
        The file's text.

    Raises
    ------
    FileNotFoundError
        No such template.
    """
    return package_folder(__package__, FOLDER).joinpath(*name.split("/")).read_text(encoding="utf-8")


def placeholders(name: str) -> frozenset[str]:
    """The placeholder names of template ``name``.

    Parameters
    ----------
    name : str
        See :func:`template_text`.

    Returns
    -------
    frozenset of str
        Every ``name`` written ``@name@`` in the template.
    """
    return frozenset(PLACEHOLDER.findall(template_text(name)))


def render(name: str, **values: object) -> str:
    """Template ``name`` with every placeholder replaced by its value.

    Parameters
    ----------
    name : str
        See :func:`template_text`.
    **values
        One value per placeholder, inserted as ``format(value)``.

    Returns
    -------
    str
        The filled text.

    Raises
    ------
    TemplateError
        A placeholder of the template has no value, or a value has no placeholder.
    """
    wanted = placeholders(name)
    missing, unknown = sorted(wanted - values.keys()), sorted(values.keys() - wanted)
    if missing or unknown:
        raise TemplateError(f"template {name}: no value for {missing}, no placeholder for {unknown}")
    return PLACEHOLDER.sub(lambda match: format(values[match.group(1)]), template_text(name))
