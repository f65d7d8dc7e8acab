"""What coordarm writes without importing mcap's writer or importlib.metadata (~25 ms of every start-up)
agrees with what those would give."""
from __future__ import annotations

import importlib.metadata
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
