"""Dataclasses that cost less to define: :func:`record` is :func:`dataclasses.dataclass` whose
``__repr__``, ``__eq__`` and ``__hash__`` (and a frozen record's ``__setattr__`` and ``__delattr__``)
are shared functions of the field names instead of methods compiled for each class.

Python 3.11 compiles every method a dataclass generates from source text when the class is
defined: a frozen class of ten fields costs about 0.9 ms, of which 0.3 ms for ``__repr__``,
``__eq__`` and ``__hash__`` and 0.3 ms for ``__setattr__`` and ``__delattr__``, and a run defines
some thirty records before it starts. The shared methods behave as the generated ones (the same
text, equality of the tuples of the compared fields between instances of the very same class, else
``NotImplemented``, the hash of that tuple, ``...`` for a record inside itself, FrozenInstanceError
with the same message); ``__init__`` is compiled from the text dataclasses writes (by dataclasses
itself for a record that is not frozen), and :func:`dataclasses.fields`, :func:`~dataclasses.replace`,
:func:`~dataclasses.asdict` and ``__dataclass_params__`` work and read as on any dataclass.
"""
from __future__ import annotations

import dataclasses
import reprlib
import sys
from operator import attrgetter
from typing import Any, Callable, TypeVar

T = TypeVar("T", bound=type)


def record(target: T | None = None, *, frozen: bool = False, eq: bool = True) -> Any:
    """:func:`dataclasses.dataclass` (``init``, ``repr`` and ``match_args`` on, no ordering) with
    ``__repr__``, ``__eq__`` and ``__hash__`` shared rather than compiled for the class, and for a
    frozen record without a dataclass base ``__setattr__`` and ``__delattr__`` shared too (its fields
    then plain ``__init__`` parameters: no ``init=False``, keyword-only, ``InitVar`` or ``ClassVar``).

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

    Raises
    ------
    TypeError
        As :func:`dataclasses.dataclass` (a parameter without a default after one with), or a frozen
        record's field that is not a plain ``__init__`` parameter.
    """
    def wrap(cls: T) -> T:
        own = cls.__dict__
        own_hash = own.get("__hash__", dataclasses.MISSING)
        explicit_hash = not (own_hash is dataclasses.MISSING or (own_hash is None and "__eq__" in own))
        define_repr, define_eq = "__repr__" not in own, eq and "__eq__" not in own
        if frozen and _plain(cls):
            cls = _frozen(cls)
        else:
            cls = dataclasses.dataclass(cls, repr=False, eq=False, frozen=frozen)
        fields = dataclasses.fields(cls)
        params = cls.__dataclass_params__                # what the record is, as dataclass() would say
        params.repr, params.eq = True, eq
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


def _plain(cls: type) -> bool:
    """Whether a frozen record's methods can be shared: no dataclass base, no ``__setattr__``,
    ``__delattr__`` or ``__init__`` of its own (else :mod:`dataclasses` makes it, with its checks)."""
    own = cls.__dict__
    return (not any(hasattr(base, "__dataclass_fields__") for base in cls.__mro__[1:])
            and not {"__setattr__", "__delattr__", "__init__"} & set(own))


def _frozen(cls: type) -> type:
    """:func:`dataclasses.dataclass` ``(frozen=True)`` of a plain class (:func:`_plain`) with ``__init__``
    compiled as dataclasses writes it and ``__setattr__``, ``__delattr__`` shared. Every field must be a
    plain ``__init__`` parameter (no ``init=False``, keyword-only, ``InitVar`` or ``ClassVar``): TypeError."""
    made = dataclasses.dataclass(cls, init=False, repr=False, eq=False)
    fields = dataclasses.fields(made)
    if len(fields) != len(made.__dataclass_fields__) or not all(f.init and not f.kw_only for f in fields):
        raise TypeError(f"record(frozen=True) {cls.__qualname__}: every field must be a plain __init__ parameter "
                        "(no init=False, kw_only, InitVar or ClassVar); use dataclasses.dataclass")
    _attach(made, _frozen_init(made, fields))
    names = tuple(f.name for f in fields)
    for fn in _frozen_setters(made, names):
        _attach(made, fn)
    made.__dataclass_params__.init = made.__dataclass_params__.frozen = True
    return made


class _Factory:
    """The default shown for a field made by a factory (``<factory>``, as dataclasses shows it)."""

    def __repr__(self) -> str:
        return "<factory>"


_FACTORY = _Factory()


def _frozen_init(cls: type, fields: tuple) -> Callable:
    """``__init__`` of a frozen dataclass, the text :mod:`dataclasses` compiles: each parameter (annotated
    with its field's type; a default, or a factory called when left out) set by ``object.__setattr__``,
    then ``__post_init__``; a default before a parameter without one raises its TypeError."""
    me = "__dataclass_self__" if "self" in {f.name for f in fields} else "self"
    local: dict[str, Any] = {"__dataclass_builtins_object__": object, "_HAS_DEFAULT_FACTORY": _FACTORY}
    params, body, seen_default = [me], [], False
    for f in fields:
        local[f"_type_{f.name}"] = f.type
        value, default = f.name, ""
        if f.default_factory is not dataclasses.MISSING:
            local[f"_dflt_{f.name}"] = f.default_factory
            value, default = f"_dflt_{f.name}() if {f.name} is _HAS_DEFAULT_FACTORY else {f.name}", "=_HAS_DEFAULT_FACTORY"
        elif f.default is not dataclasses.MISSING:
            local[f"_dflt_{f.name}"] = f.default
            default = f"=_dflt_{f.name}"
        elif seen_default:
            raise TypeError(f"non-default argument {f.name!r} follows default argument")
        seen_default = seen_default or bool(default)
        params.append(f"{f.name}:_type_{f.name}{default}")
        body.append(f"__dataclass_builtins_object__.__setattr__({me},{f.name!r},{value})")
    if hasattr(cls, "__post_init__"):
        body.append(f"{me}.__post_init__()")
    local["_return_type"] = None
    text = (f"def __create_fn__({', '.join(local)}):\n def __init__({','.join(params)})->_return_type:\n"
            + "\n".join(f"  {line}" for line in body or ["pass"]) + "\n return __init__")
    namespace: dict[str, Any] = {}
    module = sys.modules.get(cls.__module__)
    code = compile(text, "<string>", "exec", dont_inherit=True)   # not this module's postponed annotations
    exec(code, vars(module) if module is not None else {}, namespace)   # noqa: S102 (the text above, as dataclasses)
    return namespace["__create_fn__"](**local)


def _frozen_setters(cls: type, names: tuple[str, ...]) -> tuple[Callable, Callable]:
    """``__setattr__`` and ``__delattr__`` of a frozen dataclass: FrozenInstanceError for a field, or for
    any name on the class itself (a subclass may set its own attributes)."""
    def __setattr__(self: Any, name: str, value: Any) -> None:
        if type(self) is cls or name in names:
            raise dataclasses.FrozenInstanceError(f"cannot assign to field {name!r}")
        super(cls, self).__setattr__(name, value)

    def __delattr__(self: Any, name: str) -> None:
        if type(self) is cls or name in names:
            raise dataclasses.FrozenInstanceError(f"cannot delete field {name!r}")
        super(cls, self).__delattr__(name)

    return __setattr__, __delattr__


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
