"""The command line starts without loading the heavy libraries; library modules keep the user's matplotlib backend."""
import json
import subprocess
import sys

import pytest

import coordarm

HEAVY = ("casadi", "matplotlib", "control", "numpy", "scipy", "mcap", "zstandard", "dask", "distributed", "pandas",
         "pyarrow")

PROBE = """
import json, sys
from coordarm.cli import main
try:
    main({argv!r})
except SystemExit as exc:
    code = exc.code
print("\\n" + json.dumps({{"code": code, "loaded": sorted(m for m in {heavy!r} if m in sys.modules)}}))
"""


@pytest.mark.parametrize("argv", [["--help"], ["run", "--help"], ["regen", "--help"], ["replay", "--help"],
                                  ["report", "--help"], ["compare", "--help"], ["sweep", "--help"], ["--version"]])
def test_help_and_version_load_no_heavy_module(argv):
    res = subprocess.run([sys.executable, "-c", PROBE.format(argv=argv, heavy=HEAVY)],
                         capture_output=True, text=True, timeout=60)
    result = json.loads(res.stdout.strip().splitlines()[-1])
    assert result == {"code": 0, "loaded": []}, res.stderr
    if argv == ["--version"]:
        assert res.stdout.startswith(f"coordarm {coordarm.__version__}")
    else:
        assert "usage: coordarm" in res.stdout


def test_help_lists_the_choices_of_their_single_sources():
    from coordarm.simulation.choices import BACKENDS, COMPRESSIONS, presets
    from coordarm.symbolic.laws import LAWS

    res = subprocess.run([sys.executable, "-m", "coordarm", "run", "--help"], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 0
    text = " ".join(res.stdout.split())
    for choices in (BACKENDS, COMPRESSIONS, LAWS):
        assert "{" + ",".join(choices) + "}" in text
    assert set(presets()) == {"line", "arc", "hole", "pipe", "thread", "line3d", "path3d", "port", "pipe3d"} and all(p in text for p in presets())


def test_importing_the_figure_modules_keeps_the_users_matplotlib_backend():
    code = ("import matplotlib; matplotlib.use('svg'); import coordarm.simulation.figures, "
            "coordarm.analysis.report_figures, coordarm.analysis.animation, coordarm.analysis.workspace, "
            "coordarm.analysis.sweep_figures; "
            "print(matplotlib.get_backend())")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "svg"
