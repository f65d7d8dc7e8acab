"""Dataclasses that cost less to define: :func:`record` is :func:`dataclasses.dataclass` whose
``__repr__``, ``__eq__`` and ``__hash__`` are shared functions of the field names instead of
methods compiled for each class.

Python 3.11 compiles every method a dataclass generates from source text when the class is
defined: a frozen class of ten fields costs about 0.9 ms, of which 0.3 ms for ``__repr__``,
``__eq__`` and ``__hash__``, and a run defines some thirty records before it starts. The shared
methods behave as the generated ones (the same text, equality of the tuples of the compared fields
between instances of the very same class, else ``NotImplemented``, the hash of that tuple, ``...``
for a record inside itself); ``__init__`` and a frozen record's ``__setattr__`` and
``__delattr__`` stay those of :mod:`dataclasses`, and :func:`dataclasses.fields`,
:func:`~dataclasses.replace` and :func:`~dataclasses.asdict` work as on any dataclass.
"""
from __future__ import annotations

import dataclasses
import reprlib
from operator import attrgetter
from typing import Any, Callable, TypeVar

T = TypeVar("T", bound=type)


def record(target: T | None = None, *, frozen: bool = False, eq: bool = True) -> Any:
    """:func:`dataclasses.dataclass` (``init``, ``repr`` and ``match_args`` on, no ordering) with
    ``__repr__``, ``__eq__`` and ``__hash__`` shared rather than compiled for the class.

    Parameters
    ----------
    target : type, optional
        The class (``@record``); omitted for ``@record(frozen=True)``.
    frozen : bool
        As :func:`dataclasses.dataclass`: assigning a field raises
        :class:`dataclasses.FrozenInstanceError`; with ``eq`` the record is hashable.
    eq : bool
        As :func:`dataclasses.dataclass`: equal when of the same class with equal compared fields
        (a class that defines ``__eq__`` keeps its own).

    Returns
    -------
    type or callable
        The dataclass, or the decorator that makes it.
    """
    def wrap(cls: T) -> T:
        own = cls.__dict__
        own_hash = own.get("__hash__", dataclasses.MISSING)
        explicit_hash = not (own_hash is dataclasses.MISSING or (own_hash is None and "__eq__" in own))
        define_repr, define_eq = "__repr__" not in own, eq and "__eq__" not in own
        cls = dataclasses.dataclass(cls, repr=False, eq=False, frozen=frozen)
        fields = dataclasses.fields(cls)
        if define_repr:
            _attach(cls, _repr_of(tuple(f.name for f in fields if f.repr)))
        if define_eq:
            _attach(cls, _eq_of(_key_of(tuple(f.name for f in fields if f.compare))))
        if eq and not explicit_hash:      # dataclasses' rule: frozen and eq hash the fields, eq alone unhashable
            if frozen:
                _attach(cls, _hash_of(_key_of(tuple(f.name for f in fields if (f.compare if f.hash is None else f.hash)))))
            else:
                cls.__hash__ = None
        return cls

    return wrap if target is None else wrap(target)


def _attach(cls: type, fn: Callable) -> Callable:
    """Set ``fn`` on ``cls`` under its name, qualified with the class's (as dataclasses does)."""
    fn.__qualname__ = f"{cls.__qualname__}.{fn.__name__}"
    setattr(cls, fn.__name__, fn)
    return fn


def _key_of(names: tuple[str, ...]) -> Callable[[Any], tuple]:
    """``obj -> (obj.a, obj.b, ...)`` of ``names``, always a tuple (empty for no name)."""
    if len(names) >= 2:
        return attrgetter(*names)
    if names:
        name = names[0]
        return lambda obj: (getattr(obj, name),)
    return lambda obj: ()


def _repr_of(names: tuple[str, ...]) -> Callable[[Any], str]:
    """``Class(a=..., b=...)`` of the fields ``names`` (qualified class name, ``...`` when recursive)."""
    @reprlib.recursive_repr()
    def __repr__(self: Any) -> str:
        return f"{self.__class__.__qualname__}({', '.join(f'{n}={getattr(self, n)!r}' for n in names)})"
    return __repr__


def _eq_of(key: Callable[[Any], tuple]) -> Callable[[Any, Any], Any]:
    """Equality of the ``key`` tuples between instances of the same class, else ``NotImplemented``."""
    def __eq__(self: Any, other: Any) -> Any:
        if other.__class__ is self.__class__:
            return key(self) == key(other)
        return NotImplemented
    return __eq__


def _hash_of(key: Callable[[Any], tuple]) -> Callable[[Any], int]:
    """The hash of the ``key`` tuple."""
    def __hash__(self: Any) -> int:
        return hash(key(self))
    return __hash__
