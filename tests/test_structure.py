"""The sizes the structure keeps (issue 21): a thin controller face, small modules, short functions.

Counted on the source files (each layer's folder), not on anything generated: a module a newcomer can
hold in their head is a few hundred lines, and a function that does one thing fits on a screen.
"""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
LAYERS = ("symbolic", "generated", "simulation", "analysis")
SHORT_FUNCTIONS = ("symbolic", "generated", "simulation")


def modules(folders):
    """Every Python source file of the ``folders`` (the ``coordarm/`` face and its commands too)."""
    files = [p for folder in folders for p in sorted((ROOT / folder).rglob("*.py"))]
    return [p for p in files if "__pycache__" not in p.parts]


def long_functions(path: Path, limit: int) -> list[str]:
    """``path:name (lines)`` of every function or method longer than ``limit`` lines (docstring included)."""
    tree = ast.parse(path.read_text(), str(path))
    return [f"{path.name}:{node.name} ({node.end_lineno - node.lineno + 1} lines)"
            for node in ast.walk(tree) if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > limit]


def test_the_controller_is_a_thin_face_under_400_lines():
    assert len((ROOT / "symbolic" / "controller.py").read_text().splitlines()) < 400


def test_no_module_is_over_600_lines():
    long = {str(p.relative_to(ROOT)): n for p in modules(LAYERS + ("coordarm",))
            if (n := len(p.read_text().splitlines())) > 600}
    assert long == {}


@pytest.mark.parametrize("folder", SHORT_FUNCTIONS)
def test_no_function_is_over_80_lines(folder):
    assert [f for p in modules((folder,)) for f in long_functions(p, 80)] == []


def test_the_size_checks_see_every_layer_and_catch_a_long_function(tmp_path):
    assert {p.parent.name for p in modules(LAYERS)} >= set(LAYERS)
    src = tmp_path / "big.py"
    src.write_text("class A:\n    def f(self):\n" + "        x = 1\n" * 80 + "\n\ndef g():\n    pass\n")
    assert long_functions(src, 80) == ["big.py:f (81 lines)"]
