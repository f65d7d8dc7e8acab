"""Opt-in: Foxglove's own TypeScript readers (@mcap/core, @foxglove/rosmsg2-serialization) read each preset's log.

Run with ``COORDARM_NODE_READERS=1`` (needs node and npm; the packages are installed with npm
into ``$COORDARM_NODE_DIR``, default a temporary directory).
"""
import base64
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from coordarm.analysis.replay import load
from coordarm.simulation.log_schemas import PER_STEP, numeric_channels
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario, presets

PACKAGES = ["@mcap/core@2", "@mcap/support@1", "@foxglove/rosmsg@5", "@foxglove/rosmsg2-serialization@3"]
SCRIPT = Path(__file__).resolve().parent / "node" / "read_log.js"
LINKS = 5

pytestmark = pytest.mark.skipif(os.environ.get("COORDARM_NODE_READERS") != "1" or not shutil.which("npm"),
                                reason="opt-in: set COORDARM_NODE_READERS=1 (needs node and npm)")


@pytest.fixture(scope="module")
def node_dir(tmp_path_factory):
    where = Path(os.environ.get("COORDARM_NODE_DIR") or tmp_path_factory.mktemp("node"))
    where.mkdir(parents=True, exist_ok=True)
    if not (where / "node_modules" / "@foxglove" / "rosmsg2-serialization").is_dir():
        subprocess.run(["npm", "install", "--silent", "--no-audit", "--no-fund", *PACKAGES], cwd=where, check=True,
                       timeout=600)
    shutil.copy(SCRIPT, where / SCRIPT.name)
    return where


@pytest.mark.parametrize("name", [p for p in presets() if not load_scenario(p).universal])
def test_foxglove_typescript_readers_decode_each_preset_log_bit_for_bit(name, node_dir, tmp_path):
    scenario = load_scenario(name).with_overrides(links=LINKS, duration=0.4)
    ctrl = scenario.controller()
    path = tmp_path / f"{name}.mcap"
    with RunLogger(path, scenario, ctrl, chunk_size=8 * 1024, cond_rate=20.0) as log:
        simulate(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, backend="interpreted", chunk=61,
                 on_chunk=log.on_chunk)
    done = subprocess.run(["node", SCRIPT.name, str(path)], cwd=node_dir, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    got = json.loads(done.stdout)
    rep = load(path)
    assert got["statistics"] == {t: v["count"] for t, v in got["topics"].items()}
    specs = numeric_channels(LINKS)
    for key in PER_STEP:
        fields = got["topics"][specs[key].topic]["fields"]
        for field, _ in specs[key].fields:
            theirs = np.frombuffer(base64.b64decode(fields[field]), "<f8")
            assert theirs.tobytes() == np.ascontiguousarray(getattr(rep, field)).tobytes(), (key, field)
    cond = got["topics"]["/margins/cond"]["fields"]
    assert np.frombuffer(base64.b64decode(cond["cond"]), "<f8").tobytes() == rep.cond.tobytes()
