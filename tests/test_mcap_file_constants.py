"""What coordarm writes without importing mcap's writer or importlib.metadata (~25 ms of every start-up)
agrees with what those would give."""
from __future__ import annotations

import importlib.metadata
import os
import subprocess
import sys

import mcap.writer

from coordarm.simulation import mcap_file
from coordarm.simulation.mcap_writer import build_info
from coordarm.simulation.scenario import load_scenario


def test_the_magic_and_the_library_field_are_mcap_writers():
    assert mcap_file.MCAP0_MAGIC == mcap.writer.MCAP0_MAGIC
    assert mcap_file.LIBRARY_IDENTIFIER == mcap.writer.LIBRARY_IDENTIFIER


def test_the_build_records_versions_are_the_installed_distributions():
    info = build_info(load_scenario("line"))
    for dist in ("coordarm", "mcap", "zstandard", "lz4"):
        assert info[dist] == importlib.metadata.version(dist), dist


def test_the_version_option_prints_the_installed_distributions_version():
    out = subprocess.run([sys.executable, "-m", "coordarm", "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["coordarm", importlib.metadata.version("coordarm")]


def test_a_version_is_remembered_without_loading_its_module_and_is_the_distributions(tmp_path):
    """In new processes that never load zstandard: its version, asked twice (the second from the memo), is
    importlib.metadata's, and the second time zstandard stays unloaded."""
    code = ("import sys; from coordarm.simulation.host import installed_version; "
            "print(installed_version('zstandard'), installed_version('no_such_module_xyz'), 'zstandard' in sys.modules)")
    env = {**os.environ, "COORDARM_BUILD_DIR": str(tmp_path)}
    first, second = (subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
                     .stdout.split() for _ in range(2))
    expected = importlib.metadata.version("zstandard")
    assert first[:2] == second[:2] == [expected, "unknown"]
    assert (first[2], second[2]) == ("True", "False")     # computed by loading it once, then remembered
