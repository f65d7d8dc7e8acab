"""``--set NAME=VALUE``: override any field of a scenario on the command line.

A setting is parsed as one value of ``coordarm sweep --vary`` (:func:`~.sweep_points.parse_vary`:
an int, a float, ``true``/``false`` or a string; dotted TOML names such as ``control.speed`` or the
sweep's short aliases such as ``links``) and applied as a sweep point (:func:`~.sweep_points.apply_point`:
the value replaces the field whole, and the scenario is validated again).
"""
from __future__ import annotations

from typing import Any, Sequence

from coordarm.symbolic import ConfigError

from .scenario import Scenario
from .sweep_points import apply_point, check_names, parse_vary


def _as_set(err: ConfigError) -> ConfigError:
    """The sweep parser's error, naming ``--set`` instead of ``--vary`` (or the sweep point)."""
    return ConfigError(str(err).replace("--vary", "--set").replace("sweep point:", "--set:"))


def parse_setting(text: str) -> tuple[str, Any]:
    """Parse one ``NAME=VALUE``.

    Parameters
    ----------
    text : str
        The argument, e.g. ``control.speed=0.05``.

    Returns
    -------
    (str, value)
        The name as given and its value (int, float, bool or str).

    Raises
    ------
    ConfigError
        No ``=``, no name or value, a bad name, or more than one value (a list or a range).
    """
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise ConfigError(f"--set {text!r}: expected NAME=VALUE, e.g. control.speed=0.05")
    try:
        name, values = parse_vary(text)
    except ConfigError as err:
        raise _as_set(err) from None
    if len(values) != 1 or ":" in text.partition("=")[2]:
        raise ConfigError(f"--set {text!r}: one value per setting (NAME=VALUE); lists and ranges are for "
                          "coordarm sweep --vary")
    return name, values[0]


def with_settings(scenario: Scenario, settings: Sequence[str]) -> Scenario:
    """``scenario`` with every ``NAME=VALUE`` of ``settings`` applied, in order (a later one wins).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    settings : sequence of str
        The ``--set`` arguments.

    Returns
    -------
    Scenario
        The new scenario (the same object when ``settings`` is empty).

    Raises
    ------
    ConfigError
        A bad setting, a name that is not a field of the scenario, or a value the scenario refuses.
    """
    if not settings:
        return scenario
    point = dict(parse_setting(text) for text in settings)
    try:
        check_names(scenario.spec, list(point))
        applied = apply_point(scenario.spec, point)
    except ConfigError as err:
        raise _as_set(err) from None
    spec = dict(applied.spec, name=scenario.name)     # the name stays the file's or the preset's
    return Scenario.from_dict(spec, f"{scenario.source} with --set {' '.join(settings)}")
