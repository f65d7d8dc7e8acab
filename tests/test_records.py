"""coordarm.symbolic.records.record against dataclasses.dataclass itself: the same text, equality, hash,
frozen errors and dataclass functions, class by class over the options coordarm uses; and cheaper to define."""
import dataclasses
import inspect
import math
import time
from dataclasses import field

import pytest

from coordarm.symbolic.records import record


def define(decorator, **options):
    """A family of classes (plain, with field options, subclass, own methods) under ``decorator``."""
    deco = decorator(**options) if options else decorator

    @deco
    class Point:
        x: float
        y: float = 0.0
        tag: str = field(default="p", compare=False)
        secret: tuple = field(default=(), repr=False)
        weight: float = field(default=1.0, hash=False)

    @deco
    class Point3(Point):
        z: float = 0.0

    @deco
    class Made:
        self: int = 1                                  # a field called self (the generated code renames its own)
        items: list = field(default_factory=list)
        total: float = 0.0

        def __post_init__(self):
            object.__setattr__(self, "total", float(len(self.items)) + self.total)

    @deco
    class Empty:
        pass

    @deco
    class One:
        v: object = None

    @deco
    class OwnEq:
        v: int = 0

        def __eq__(self, other):
            return isinstance(other, OwnEq) and self.v % 2 == other.v % 2

    @deco
    class OwnHash:
        v: int = 0

        def __hash__(self):
            return 7

    @deco
    class OwnRepr:
        v: int = 0

        def __repr__(self):
            return "mine"

    return Point, Point3, Empty, One, OwnEq, OwnHash, OwnRepr, Made


def behaviour(classes):
    """Everything observable of the classes' instances, as plain data (exceptions by type and text)."""
    Point, Point3, Empty, One, OwnEq, OwnHash, OwnRepr, Made = classes
    nan = math.nan

    def attempt(fn):
        try:
            return ("ok", fn())
        except Exception as exc:      # noqa: BLE001 (compared, type and message)
            return (type(exc).__name__, str(exc))

    a, b, c = Point(1.0, 2.0, "a", (1,)), Point(1.0, 2.0, "b", (1,)), Point(1.0, 2.5)
    p3 = Point3(1.0, 2.0)
    same_nan = Point(nan)
    loop = One()
    object.__setattr__(loop, "v", loop) if Point.__dataclass_params__.frozen else setattr(loop, "v", loop)
    out = {
        "repr": [repr(x) for x in (a, c, p3, Empty(), One([1, "x"]), OwnEq(3), OwnHash(2), OwnRepr(1), loop)],
        "eq": [a == b, a == c, a == p3, p3 == a, Point(1.0) == Point(1.0, weight=9.0), Empty() == Empty(),
               One(1) == One(1), One(1) == One(2), Point(1.0, secret=(2,)) == Point(1.0), same_nan == same_nan, Point(nan) == Point(nan),
               OwnEq(1) == OwnEq(3), OwnEq(1) == OwnEq(2), a != b, a != c],
        "ne other": [a.__eq__(1), a.__eq__(p3), Empty().__eq__(object())],
        "hash": [attempt(lambda: "identity" if hash(x) == object.__hash__(x) else hash(x)) for x in (a, b, p3, Empty(), One(1), OwnEq(1), OwnHash(1), OwnRepr(1))],
        "hash equal": attempt(lambda: hash(Point(1.0, weight=2.0)) == hash(Point(1.0, weight=3.0))),
        "hash attr": [type(cls.__dict__.get("__hash__")).__name__ for cls in classes],
        "set": attempt(lambda: setattr(a, "x", 5.0)),
        "set new": attempt(lambda: setattr(a, "other", 5.0)),
        "del": attempt(lambda: delattr(a, "y")),
        "fields": [[(f.name, f.repr, f.compare, f.hash) for f in dataclasses.fields(cls)] for cls in classes],
        "replace": repr(dataclasses.replace(a, y=9.0)),
        "asdict": dataclasses.asdict(p3),
        "astuple": dataclasses.astuple(c),
        "match": [cls.__match_args__ for cls in classes],
        "init errors": [attempt(lambda: Point()), attempt(lambda: Point(1, 2, 3, 4, 5, 6)), attempt(lambda: Point(1, q=2))],
        "is dataclass": [dataclasses.is_dataclass(cls) for cls in classes],
        "params": [[getattr(cls.__dataclass_params__, k) for k in ("init", "repr", "eq", "order", "unsafe_hash", "frozen")]
                   for cls in classes],
        "signature": [str(inspect.signature(cls)) for cls in classes],
        "init annotations": [cls.__init__.__annotations__ for cls in classes],
        "init name": [cls.__init__.__qualname__ for cls in classes],
        "made": [repr(Made()), repr(Made(2, [1, 2], 0.5)), Made() == Made(), attempt(lambda: Made(self=3, items=[]).self),
                 Made().items is not Made().items],
        "made errors": [attempt(lambda: Made(1, [], 0.0, 4)), attempt(lambda: setattr(Made(), "total", 1.0))],
    }
    return out


@pytest.mark.parametrize("options", [{}, {"frozen": True}, {"frozen": True, "eq": False}, {"eq": False}])
def test_a_record_behaves_as_the_dataclass_of_the_same_options(options):
    assert behaviour(define(record, **options)) == behaviour(define(dataclasses.dataclass, **options))


def test_a_frozen_record_is_cheaper_to_define_than_its_dataclass():
    """The point of records: less work when the class is defined (median of interleaved rounds)."""
    def cost(decorator):
        start = time.perf_counter()
        define(decorator, frozen=True)
        return time.perf_counter() - start

    rounds = [(cost(record), cost(dataclasses.dataclass)) for _ in range(15)]
    ours, theirs = (sorted(r[i] for r in rounds)[len(rounds) // 2] for i in (0, 1))
    assert ours < 0.85 * theirs


def test_the_layers_a_run_loads_define_records_not_dataclasses():
    """symbolic/, generated/ and simulation/ (what ``coordarm run`` imports) define their dataclasses with
    :func:`record`, so that a new one does not bring back the per-class compilation."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    found = []
    for folder in ("symbolic", "generated", "simulation"):
        for path in sorted((root / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.ClassDef):
                    for deco in node.decorator_list:
                        target = deco.func if isinstance(deco, ast.Call) else deco
                        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
                        if name == "dataclass":
                            found.append(f"{path.relative_to(root)}:{node.lineno} {node.name}")
    assert found == []


@pytest.mark.parametrize("frozen", [False, True])
def test_a_bad_record_fails_as_the_bad_dataclass(frozen):
    """A field without a default after one with it, and a mutable default: the same errors, when defined."""
    def bad(decorator, body):
        try:
            decorator(frozen=frozen)(type("Bad", (), body))
        except (TypeError, ValueError) as exc:
            return type(exc).__name__, str(exc)
        return None

    for body in ({"__annotations__": {"a": "int", "b": "int"}, "a": 1},
                 {"__annotations__": {"a": "list"}, "a": []}):
        assert bad(record, body) == bad(dataclasses.dataclass, body) is not None


def test_a_frozen_record_of_fields_that_are_not_plain_parameters_is_refused():
    with pytest.raises(TypeError, match="plain __init__ parameter"):
        @record(frozen=True)
        class Hidden:
            a: int = field(default=0, init=False)


def test_a_frozen_record_subclass_of_a_frozen_record_is_dataclasses_own():
    @record(frozen=True)
    class Base:
        a: int = 0

    @record(frozen=True)
    class Child(Base):
        b: int = 1

    assert repr(Child(2, 3)) == "test_a_frozen_record_subclass_of_a_frozen_record_is_dataclasses_own.<locals>.Child(a=2, b=3)"
    with pytest.raises(dataclasses.FrozenInstanceError):
        Child().a = 1
    with pytest.raises(TypeError, match="cannot inherit non-frozen dataclass from a frozen one"):
        @record
        class Loose(Base):
            c: int = 2
