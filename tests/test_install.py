"""A real wheel, installed (not editable) into a fresh venv: one import name, usable from any directory.

The wheel is built offline from a copy of the sources (``pip wheel --no-build-isolation``); the
fresh venv gets only the wheel (``--no-deps``), and its third-party dependencies come from the
test environment's site-packages through a ``.pth`` path line (which adds those directories but
not their own ``.pth`` hooks, so the editable install of the test environment stays inactive).
The layer folders reach ``coordarm/`` through relative symlinks (``coordarm/symbolic -> ../symbolic``):
the sdist and the wheel must hold real files, and the repository root must stay usable.
"""
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CLASHING = ("symbolic", "generated", "simulation", "analysis")
#: The top-level folders that ``coordarm/`` links to (``coordarm/<layer> -> ../<layer>``).
LAYERS = sorted(p.name for p in (ROOT / "coordarm").iterdir() if p.is_symlink())


def run(cmd, **kw) -> subprocess.CompletedProcess:
    res = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=300, **kw)
    assert res.returncode == 0, f"{cmd}:\n{res.stdout}\n{res.stderr}"
    return res


PIP = [sys.executable, "-m", "pip", "--disable-pip-version-check"]


def copy_sources(dest: Path) -> Path:
    """Copy what a build reads (the layer links kept as links) to ``dest``; return ``dest``."""
    dest.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, dest / name)
    for folder in ("coordarm", *LAYERS):
        shutil.copytree(ROOT / folder, dest / folder, symlinks=True,
                        ignore=shutil.ignore_patterns("__pycache__", "_build"))
    return dest


def venv_with(wheel: Path, where: Path) -> tuple[Path, Path]:
    """``(python, site-packages)`` of a fresh venv holding ``wheel`` and seeing the test environment's dependencies."""
    run([sys.executable, "-m", "venv", "--without-pip", where])
    python = where / "bin" / "python"
    run([*PIP, "--python", python, "install", "--no-deps", "--no-index", "-q", wheel])
    site = Path(run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip())
    deps = [p for p in sys.path if Path(p).name == "site-packages"] or [sysconfig.get_paths()["purelib"]]
    (site / "_coordarm_test_deps.pth").write_text("".join(p + "\n" for p in deps))
    return python, site


@pytest.fixture(scope="module")
def src(tmp_path_factory) -> Path:
    """A copy of the sources to build from."""
    return copy_sources(tmp_path_factory.mktemp("install") / "src")


@pytest.fixture(scope="module")
def venv(src):
    """``(python, site-packages)`` of a fresh venv holding the coordarm wheel only."""
    tmp = src.parent
    run([*PIP, "wheel", "--no-deps", "--no-build-isolation", "--no-index", "-q", "-w", tmp / "dist", src])
    return venv_with(next((tmp / "dist").glob("coordarm-*.whl")), tmp / "venv")


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


def layer_sources() -> set:
    """The package's ``.py`` files as installed (``coordarm/symbolic/chain.py``), read from the top-level folders."""
    out = {p.relative_to(ROOT) for p in (ROOT / "coordarm").rglob("*.py") if "__pycache__" not in p.parts}
    for layer in LAYERS:
        out |= {Path("coordarm", layer, p.name) for p in (ROOT / layer).glob("*.py")}
    return out


def test_the_wheel_installs_real_files_for_every_module_of_the_layer_folders(venv):
    python, site = venv
    installed = files(site)
    assert not [p for p in installed if (site / p).is_symlink()]
    assert {p for p in installed if p.suffix == ".py"} == layer_sources()


def test_the_sdist_holds_real_files_and_builds_the_same_wheel(venv, src, tmp_path):
    python, site = venv
    build = [sys.executable, "-c", "import sys; from setuptools import build_meta; "
             "print(build_meta.build_sdist(sys.argv[1]))"]
    name = run([*build, tmp_path], cwd=src).stdout.strip().splitlines()[-1]
    with tarfile.open(tmp_path / name) as tar:
        members = tar.getmembers()
        assert not [m.name for m in members if m.issym() or m.islnk()]
        tar.extractall(tmp_path / "sdist", filter="data")
    unpacked = next((tmp_path / "sdist").iterdir())
    run([*PIP, "wheel", "--no-deps", "--no-build-isolation", "--no-index", "-q", "-w", tmp_path / "dist", unpacked])
    with zipfile.ZipFile(next((tmp_path / "dist").glob("coordarm-*.whl"))) as whl:
        from_sdist = {Path(n) for n in whl.namelist() if not n.split("/")[0].endswith(".dist-info")}
    assert from_sdist == {p for p in files(site) if p.parts[0] == "coordarm" and (site / p).is_file()}


def test_an_editable_install_imports_the_layers_from_the_top_level_folders(src, tmp_path):
    build = [sys.executable, "-c", "import sys; from setuptools import build_meta; "
             "print(build_meta.build_editable(sys.argv[1]))"]
    name = run([*build, tmp_path / "dist"], cwd=src).stdout.strip().splitlines()[-1]
    python, _ = venv_with(tmp_path / "dist" / name, tmp_path / "venv")
    code = "import coordarm.simulation.run as m, coordarm; print(m.__file__); print(coordarm.__file__)"
    module, face = run([python, "-c", code], cwd=tmp_path).stdout.split()
    assert Path(module).resolve() == (src / "simulation" / "run.py").resolve()
    assert Path(face) == src / "coordarm" / "__init__.py"


def test_python_m_coordarm_works_from_the_repository_root_after_a_non_editable_install(venv):
    python, site = venv
    res = run([python, "-m", "coordarm", "--help"], cwd=ROOT)
    assert res.stdout.startswith("usage: coordarm")
    code = "import coordarm.symbolic.chain as m; print(m.__file__)"
    assert Path(run([python, "-c", code], cwd=ROOT).stdout.strip()).resolve() == ROOT / "symbolic" / "chain.py"
