"""Every public function and class of the facade (``coordarm.__all__``), and their public methods, have
numpydoc sections: a docstring (GL08), every parameter documented (PR01) and no unknown ones (PR02),
a Returns section when something is returned (RT01). Dataclasses document their fields as Attributes."""
import dataclasses
import inspect

import pytest
from numpydoc.docscrape import ClassDoc
from numpydoc.validate import validate

import coordarm

CHECKS = {"GL08", "PR01", "PR02", "RT01"}


def targets():
    for name in coordarm.__all__:
        obj = getattr(coordarm, name)
        if not (inspect.isclass(obj) or inspect.isfunction(obj)):
            continue
        yield f"{obj.__module__}.{obj.__qualname__}", obj
        if inspect.isclass(obj):
            for member, value in vars(obj).items():
                if not member.startswith("_") and inspect.isfunction(value):
                    yield f"{obj.__module__}.{obj.__qualname__}.{member}", value


@pytest.mark.parametrize("path,obj", sorted(set(targets()), key=lambda x: x[0]), ids=lambda v: v if isinstance(v, str) else "")
def test_numpydoc_sections(path, obj):
    errors = [f"{code}: {msg}" for code, msg in validate(path)["errors"] if code in CHECKS]
    if inspect.isclass(obj) and dataclasses.is_dataclass(obj):
        errors = [e for e in errors if not e.startswith("PR01")]
        documented = {p.name for p in ClassDoc(obj)["Attributes"]} | {
            n.strip() for p in ClassDoc(obj)["Attributes"] for n in p.name.split(",")}
        missing = [f.name for f in dataclasses.fields(obj) if f.init and f.name not in documented]
        errors += [f"dataclass field {m!r} is not in Attributes" for m in missing]
    assert not errors, f"{path}:\n" + "\n".join(errors)
