"""Dependencies: ranges in pyproject.toml, the tested pins in constraints.txt; lz4 missing is a clear error."""
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement

from coordarm.symbolic import ConfigError

ROOT = Path(__file__).resolve().parent.parent


def pins() -> dict[str, str]:
    lines = [ln.strip() for ln in (ROOT / "constraints.txt").read_text().splitlines() if ln.strip()]
    assert lines == sorted(lines, key=str.lower), "constraints.txt: keep one pin a line, sorted"
    out = {}
    for ln in lines:
        name, version = ln.split("==")
        out[name.lower().replace("_", "-")] = version
    return out


def test_every_declared_dependency_is_a_range_pinned_in_constraints_within_that_range():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["requires-python"] == ">=3.11"      # tomllib, numpy 2.4
    pinned = pins()
    reqs = [Requirement(r) for r in project["dependencies"] + sum(project["optional-dependencies"].values(), [])]
    for req in reqs:
        assert not any(spec.operator == "==" for spec in req.specifier), f"{req}: use a range, pin in constraints.txt"
        name = req.name.lower().replace("_", "-")
        assert name in pinned, f"{req.name} is not pinned in constraints.txt"
        assert req.specifier.contains(pinned[name]), f"{req.name}=={pinned[name]} is outside {req.specifier}"


def test_lz4_compression_without_lz4_installed_is_a_config_error_saying_how_to_install(monkeypatch, tmp_path):
    from coordarm.simulation.mcap_file import McapFile

    monkeypatch.setitem(sys.modules, "lz4", None)          # import lz4.frame now raises ImportError
    monkeypatch.delitem(sys.modules, "lz4.frame", raising=False)
    with pytest.raises(ConfigError, match=r"pip install"):
        McapFile(tmp_path / "x.mcap", compression="lz4")
    assert not (tmp_path / "x.mcap").exists()
    McapFile(tmp_path / "y.mcap", compression="zstd").close()   # zstd does not need it
