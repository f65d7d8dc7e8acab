"""Every public function and class of every public module of the installed package, and their public
methods, have numpydoc sections read by numpydoc's own validator: a docstring (GL08), every parameter
documented (PR01), no unknown ones (PR02), each with a type (PR04), and a Returns section when something
is returned (RT01). A class's ``__init__`` parameters are documented in the class docstring (numpydoc
convention); dataclasses document their fields as Attributes."""
import dataclasses
import enum
import importlib
import inspect
import pkgutil

from numpydoc.docscrape import ClassDoc
from numpydoc.validate import validate

# The top-level folders symbolic/, generated/, simulation/, analysis/ install as sub-packages of `coordarm`
# through package-dir, so they are not under `coordarm.__path__`: each is walked from its own __path__.
PACKAGES = ["coordarm", "coordarm.symbolic", "coordarm.generated", "coordarm.simulation", "coordarm.analysis"]

CHECKS = {"GL08", "PR01", "PR02", "PR04", "RT01"}

def unimportable(name):
    """walk_packages ignores a sub-package that fails to import; here that fails the test."""
    raise ImportError(f"cannot import {name}")


def public_modules():
    """Every module of the package whose dotted name has no component starting with ``_``."""
    names = set(PACKAGES)
    for pkg_name in PACKAGES:
        pkg = importlib.import_module(pkg_name)
        names.update(info.name for info in pkgutil.walk_packages(pkg.__path__, pkg_name + ".", onerror=unimportable))
    for name in sorted(names):
        if not any(part.startswith("_") for part in name.split(".")):
            yield importlib.import_module(name)


def routine(value):
    """The plain function behind a function, staticmethod or classmethod, or None for anything else."""
    if isinstance(value, (staticmethod, classmethod)):
        value = value.__func__
    return value if inspect.isfunction(inspect.unwrap(value)) else None


def targets():
    """``(module, dotted path, object)`` for every public function, class and public method defined in a
    public module (names imported from elsewhere are checked where they are defined)."""
    for module in public_modules():
        for name, obj in vars(module).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
                continue
            if not (inspect.isclass(obj) or routine(obj)):
                continue
            path = f"{module.__name__}.{obj.__qualname__}"
            yield module.__name__, path, obj
            if inspect.isclass(obj):
                for member, value in vars(obj).items():
                    if not member.startswith("_") and routine(value):
                        yield module.__name__, f"{path}.{member}", routine(value)


def dataclass_errors(cls):
    """Init fields of a dataclass missing from its Attributes section."""
    attributes = ClassDoc(cls)["Attributes"]
    documented = {n.strip() for p in attributes for n in p.name.split(",")}
    return [f"dataclass field {f.name!r} is not in Attributes"
            for f in dataclasses.fields(cls) if f.init and f.name not in documented]


def numpydoc_errors(path, obj, checks):
    errors = [f"{code}: {msg}" for code, msg in validate(path)["errors"] if code in checks]
    if inspect.isclass(obj) and dataclasses.is_dataclass(obj):
        errors = [e for e in errors if not e.startswith(("PR01", "PR04"))] + dataclass_errors(obj)
    if inspect.isclass(obj) and getattr(obj, "_is_protocol", False):
        # an interface (typing.Protocol) is never constructed: its __init__ is Protocol's (*args, **kwargs)
        errors = [e for e in errors if not e.startswith("PR01")]
    if inspect.isclass(obj) and issubclass(obj, enum.Enum):
        # an enumeration is looked up by value, never constructed: its signature is EnumType.__call__'s
        # functional API (value, names, module, qualname, type, start, boundary)
        errors = [e for e in errors if not e.startswith("PR01")]
    return errors


def test_every_public_module_is_walked():
    names = {module.__name__ for module in public_modules()}
    assert {"coordarm.cli", "coordarm.commands.run", "coordarm.symbolic.chain", "coordarm.generated.path_search",
            "coordarm.simulation.sweep", "coordarm.analysis.workspace", "coordarm.simulation.presets"} <= names
    assert not any(part.startswith("_") for name in names for part in name.split("."))


def test_every_public_function_class_and_method_has_numpydoc_parameters():
    offenders = []
    for module_name, path, obj in targets():
        errors = numpydoc_errors(path, obj, CHECKS)
        if errors:
            qualname = path[len(module_name) + 1:]
            offenders.append(f"{module_name}:{qualname}\n    " + "\n    ".join(errors))
    assert not offenders, f"{len(offenders)} objects with incomplete numpydoc:\n" + "\n".join(offenders)
