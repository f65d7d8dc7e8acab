"""Imports flow one way (symbolic <- generated <- simulation <- analysis <- cli), checked by import-linter.

import-linter (grimp) finds a package's modules by walking the root package's directory, so in a
source checkout (or an editable install) with setuptools' ``package-dir`` mapping it sees only
``coordarm/`` and ``coordarm/commands/``. The test therefore lays the sources out as a wheel
installs them (the mapping read from ``pyproject.toml``) and lints that copy with the contracts of
``pyproject.toml``.
"""
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LINT = Path(sys.executable).with_name("lint-imports")


def installed_layout(dest: Path) -> Path:
    """Copy the package as installed (``coordarm/symbolic/...``) under ``dest``; return ``dest``."""
    tool = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    mapping = tool.get("package-dir", {})
    for package in tool["packages"]:
        src = ROOT / mapping.get(package, package.replace(".", "/"))
        target = dest / package.replace(".", "/")
        target.mkdir(parents=True, exist_ok=True)
        for f in src.glob("*.py"):
            shutil.copy2(f, target / f.name)
    return dest


def lint(tree: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(tree))
    return subprocess.run([str(LINT), "--config", str(ROOT / "pyproject.toml"), "--no-cache"], cwd=tree, env=env,
                          capture_output=True, text=True, timeout=300)


def test_layer_contracts_hold(tmp_path):
    res = lint(installed_layout(tmp_path))
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Contracts: 1 kept, 0 broken" in res.stdout


def test_an_upward_import_breaks_the_contract(tmp_path):
    tree = installed_layout(tmp_path)
    bad = tree / "coordarm" / "symbolic" / "chain.py"
    bad.write_text(bad.read_text() + "\nfrom coordarm.analysis import replay  # noqa\n")
    res = lint(tree)
    assert res.returncode != 0 and "coordarm.symbolic.chain -> coordarm.analysis.replay" in res.stdout
