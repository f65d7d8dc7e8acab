"""The layers as tools see them: the import-linter contract, no import cycle, no private name across modules.

``coordarm/symbolic`` etc. are relative symlinks to the top-level folders, so a checkout has the
installed layout: ``lint-imports`` (grimp) runs on it as is.
"""
import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import grimp
import pytest

ROOT = Path(__file__).resolve().parent.parent
LINT = Path(sys.executable).with_name("lint-imports")
#: The top-level folders that ``coordarm/`` links to (``coordarm/<layer> -> ../<layer>``).
LAYERS = sorted(p.name for p in (ROOT / "coordarm").iterdir() if p.is_symlink())



def lint(cwd: Path, pythonpath: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = str(pythonpath)
    return subprocess.run([str(LINT), "--config", str(ROOT / "pyproject.toml"), "--no-cache"], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_layer_contracts_hold_in_the_checkout_as_it_is():
    res = lint(ROOT)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Contracts: 1 kept, 0 broken" in res.stdout


def test_an_upward_import_breaks_the_contract(tmp_path):
    for folder in ("coordarm", *LAYERS):
        shutil.copytree(ROOT / folder, tmp_path / folder, symlinks=True, ignore=shutil.ignore_patterns("__pycache__"))
    bad = tmp_path / "symbolic" / "chain.py"
    bad.write_text(bad.read_text() + "\nfrom coordarm.analysis import replay  # noqa\n")
    res = lint(tmp_path, pythonpath=tmp_path)
    assert res.returncode != 0 and "coordarm.symbolic.chain -> coordarm.analysis.replay" in res.stdout


# --- no import cycle ------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def graph() -> grimp.ImportGraph:
    """The import graph of every module of the package, TYPE_CHECKING and call-time imports included."""
    import coordarm

    assert Path(coordarm.__file__).parent == ROOT / "coordarm"      # the graph of this checkout
    return grimp.build_graph("coordarm", cache_dir=None)


def imports(g: grimp.ImportGraph) -> set[tuple[str, str]]:
    return {(a, b) for a in g.modules for b in g.find_modules_directly_imported_by(a)}


def cycles(g: grimp.ImportGraph) -> list[tuple[str, ...]]:
    """One cycle through each import ``a -> b`` that has a way back ``b -> ... -> a``."""
    return [(a, *g.find_shortest_chain(importer=b, imported=a)) for a, b in sorted(imports(g))
            if g.chain_exists(importer=b, imported=a)]


def test_the_graph_covers_every_module_of_every_layer(graph):
    assert graph.modules == set(package_modules())


def test_no_import_cycle_between_modules(graph):
    assert cycles(graph) == []


def test_no_import_cycle_between_the_children_of_any_package(graph):
    packages = sorted(m for m in graph.modules if graph.find_children(m))
    assert {p: graph.nominate_cycle_breakers(p) for p in packages} == {p: set() for p in packages}


def test_a_cycle_is_found():
    g = grimp.ImportGraph()
    for m in ("pkg", "pkg.a", "pkg.b", "pkg.c"):
        g.add_module(m)
    g.add_import(importer="pkg.a", imported="pkg.b")
    g.add_import(importer="pkg.b", imported="pkg.c")
    assert cycles(g) == []
    g.add_import(importer="pkg.c", imported="pkg.a")
    assert cycles(g) == [("pkg.a", "pkg.b", "pkg.c", "pkg.a"), ("pkg.b", "pkg.c", "pkg.a", "pkg.b"),
                         ("pkg.c", "pkg.a", "pkg.b", "pkg.c")]
    assert g.nominate_cycle_breakers("pkg")


# --- no private name across modules ---------------------------------------------------------------

def is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def package_modules() -> dict[str, Path]:
    """Module name -> source file, for every module of the package (the layers read through their links)."""
    out = {}
    for folder, pkg in [("coordarm", "coordarm"), *((layer, f"coordarm.{layer}") for layer in LAYERS)]:
        for path in sorted((ROOT / folder).rglob("*.py")):       # rglob does not follow the links
            if "__pycache__" not in path.parts:
                parts = path.relative_to(ROOT / folder).with_suffix("").parts
                out[".".join([pkg, *parts[:-1]] + ([] if parts[-1] == "__init__" else [parts[-1]]))] = path
    return out


def private_definitions(tree: ast.AST) -> set[str]:
    """Private names a module defines: functions, classes, variables, attributes it assigns, arguments."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
        elif isinstance(node, ast.alias) and node.asname:
            names.add(node.asname)
    return {n for n in names if is_private(n)}


def imported_from(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The absolute name of the module ``node`` imports from."""
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[:len(base) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


def private_uses(modules: dict[str, Path]) -> set[tuple[str, str, int]]:
    """``(module, name, line)`` of every private name a module imports from, or reads off, another module's code.

    ``from coordarm.x import _y`` counts, and so does ``anything._y`` when ``_y`` is defined by
    another module of the package and not by this one.
    """
    trees = {m: ast.parse(p.read_text(), str(p)) for m, p in modules.items()}
    defined = {m: private_definitions(t) for m, t in trees.items()}
    found = set()
    for module, tree in trees.items():
        elsewhere = set().union(*(d for m, d in defined.items() if m != module))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                source = imported_from(module, modules[module].stem == "__init__", node)
                if source.split(".")[0] == "coordarm" and source != module:
                    found |= {(module, a.name, node.lineno) for a in node.names if is_private(a.name)}
                    if any(is_private(part) for part in source.split(".")):
                        found.add((module, source, node.lineno))
            elif isinstance(node, ast.Import):
                found |= {(module, a.name, node.lineno) for a in node.names
                          if a.name.split(".")[0] == "coordarm" and any(is_private(p) for p in a.name.split("."))}
            elif (isinstance(node, ast.Attribute) and is_private(node.attr) and node.attr not in defined[module]
                  and node.attr in elsewhere):
                found.add((module, node.attr, node.lineno))
    return found


def test_no_private_name_is_used_across_modules():
    found = private_uses(package_modules())
    assert sorted(found) == []


def test_private_uses_are_found(tmp_path):
    (tmp_path / "a.py").write_text("def _helper():\n    pass\n\n\nclass A:\n    def __init__(self):\n"
                                   "        self._state = 1\n        self.__dict__.clear()\n")
    (tmp_path / "b.py").write_text("from coordarm.a import A, _helper\nfrom . import a as _a\nimport sys\n\n"
                                   "def f(x, _unused=0):\n    sys._getframe()\n    return A()._state, _a.A\n")
    (tmp_path / "c.py").write_text("import coordarm._secret\n")
    found = private_uses({"coordarm.a": tmp_path / "a.py", "coordarm.b": tmp_path / "b.py",
                          "coordarm.c": tmp_path / "c.py"})
    assert found == {("coordarm.b", "_helper", 1), ("coordarm.b", "_state", 7), ("coordarm.c", "coordarm._secret", 1)}
