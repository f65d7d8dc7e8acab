"""A real wheel, installed (not editable) into a fresh venv: one import name, usable from any directory.

The wheel is built offline from a copy of the sources (``pip wheel --no-build-isolation``); the
fresh venv gets only the wheel (``--no-deps``), and its third-party dependencies come from the
test environment's site-packages through a ``.pth`` path line (which adds that directory but
not its own ``.pth`` hooks, so the editable install of the test environment stays inactive).
"""
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CLASHING = ("symbolic", "generated", "simulation", "analysis")


def run(cmd, **kw) -> subprocess.CompletedProcess:
    res = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=300, **kw)
    assert res.returncode == 0, f"{cmd}:\n{res.stdout}\n{res.stderr}"
    return res


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    """``(python, site-packages)`` of a fresh venv holding the coordarm wheel only."""
    tmp = tmp_path_factory.mktemp("install")
    src = tmp / "src"
    tool = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = {"coordarm", *tool["package-dir"].values()}
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    for folder in folders:
        shutil.copytree(ROOT / folder, src / folder, ignore=shutil.ignore_patterns("__pycache__", "_build"))
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check"]
    run([*pip, "wheel", "--no-deps", "--no-build-isolation", "--no-index", "-q", "-w", tmp / "dist", src])
    wheel = next((tmp / "dist").glob("coordarm-*.whl"))
    run([sys.executable, "-m", "venv", "--without-pip", tmp / "venv"])
    python = tmp / "venv" / "bin" / "python"
    run([*pip, "--python", python, "install", "--no-deps", "--no-index", "-q", wheel])
    site = Path(run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip())
    (site / "_coordarm_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    return python, site


def env_without_build_dir(cache: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("COORDARM_BUILD_DIR", "PYTHONPATH")}
    return dict(env, XDG_CACHE_HOME=str(cache))


def files(site: Path) -> set:
    return {p.relative_to(site) for p in site.rglob("*") if "__pycache__" not in p.parts}


def test_the_layers_import_only_as_coordarm_subpackages(venv, tmp_path):
    python, site = venv
    probe = ("import importlib, json\nout = {}\nfor name in %r:\n    try:\n        importlib.import_module(name)\n"
             "        out[name] = 'imported'\n    except ModuleNotFoundError:\n        out[name] = 'missing'\n"
             "print(json.dumps(out))") % (CLASHING,)
    res = run([python, "-c", probe], cwd=tmp_path, env=env_without_build_dir(tmp_path / "cache"))
    assert json.loads(res.stdout) == {name: "missing" for name in CLASHING}
    assert {p.parts[0] for p in files(site) if p.suffix == ".py"} == {"coordarm"}


def test_coordarm_works_from_a_directory_with_folders_named_like_its_layers(venv, tmp_path):
    python, site = venv
    for name in CLASHING:   # packages that would break everything if they were imported
        (tmp_path / name).mkdir()
        (tmp_path / name / "__init__.py").write_text(f"raise ImportError('the local folder {name} was imported')\n")
    cache = tmp_path / "cache"
    before = files(site)
    code = """
import json, coordarm
from coordarm import CoordinatingController, Line, PlanarChain
ctrl = CoordinatingController(PlanarChain(4, 0.1), Line((0.0, 0.0), 0.0), 2.0, 0.05)
q = ctrl.chain.zigzag(1.0)
fast = coordarm.compile(ctrl)
print(json.dumps({"module": coordarm.symbolic.__file__, "library": str(fast.library.path),
                  "diff": float(abs(fast.control(q, 0.3) - ctrl.control(q, 0.3)).max())}))
"""
    res = run([python, "-c", code], cwd=tmp_path, env=env_without_build_dir(cache))
    out = json.loads(res.stdout)
    assert Path(out["module"]).is_relative_to(site)
    assert Path(out["library"]).is_relative_to(cache / "coordarm") and out["diff"] < 1e-12
    assert files(site) == before                       # nothing written into the installed package
    cli = [python.parent / "coordarm"]
    assert run([*cli, "regen", "--print-cache-dir"], cwd=tmp_path,
               env=env_without_build_dir(cache)).stdout.strip() == str(cache / "coordarm")
    assert run([*cli, "--version"], cwd=tmp_path).stdout.startswith("coordarm 0.1.0")
    assert "usage: coordarm" in run([python, "-m", "coordarm", "--help"], cwd=tmp_path).stdout
