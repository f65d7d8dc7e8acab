"""Every public module, class and function of coordarm has a docstring."""
import importlib
import inspect
import pkgutil

import pytest

PACKAGES = ["coordarm", "coordarm.commands", "coordarm.symbolic", "coordarm.generated", "coordarm.simulation",
            "coordarm.analysis"]


def public_objects():
    for pkg_name in PACKAGES:
        pkg = importlib.import_module(pkg_name)
        for info in pkgutil.iter_modules(pkg.__path__, pkg_name + "."):
            if info.name.rsplit(".", 1)[-1].startswith("_"):
                continue
            mod = importlib.import_module(info.name)
            yield info.name, mod
            for name, obj in vars(mod).items():
                if name.startswith("_") or getattr(obj, "__module__", None) != mod.__name__:
                    continue
                if inspect.isfunction(obj) or inspect.isclass(obj):
                    yield f"{info.name}.{name}", obj


@pytest.mark.parametrize("name,obj", list(public_objects()), ids=lambda v: v if isinstance(v, str) else "")
def test_public_object_has_a_docstring(name, obj):
    assert inspect.getdoc(obj), f"{name} has no docstring"
