"""Every script of the gallery (examples/plot_*.py) runs, with a shorter simulated time, and draws.

The gallery runs the same scripts when the documentation is built (``make docs``); here each
runs in a scratch folder with its ``duration = ...`` (or ``steps = ...``) line shortened, and must
finish without error and leave at least one figure: a PNG under ``logs/`` or an open matplotlib
figure.
"""
from __future__ import annotations

import re
import runpy
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("plot_*.py"))
SHORT = {"duration": "1.0", "steps": "200"}
SETTING = re.compile(r"^(duration|steps) = [0-9.]+", re.M)


def shortened(source: str) -> str:
    """``source`` with its top-level ``duration = X`` and ``steps = N`` lines set to short runs."""
    return SETTING.sub(lambda m: f"{m.group(1)} = {SHORT[m.group(1)]}", source)


def test_there_is_an_example_per_feature():
    names = {p.stem for p in EXAMPLES}
    assert {"plot_preset_run", "plot_user_curve", "plot_composite_path", "plot_rail", "plot_report",
            "plot_comparison", "plot_sweep", "plot_export", "plot_log_analysis", "plot_spatial_line",
            "plot_spatial_path"} <= names
    for p in EXAMPLES:
        text = p.read_text()
        assert text.startswith('"""\n') and "\n====" in text.split('"""')[1], f"{p.name}: needs a titled docstring"
        assert SETTING.search(text), f"{p.name}: needs a `duration = ...` or `steps = ...` line the test can shorten"


@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.stem)
def test_example_runs_and_draws(script: Path, tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.close("all")
    monkeypatch.chdir(tmp_path)
    short = tmp_path / script.name
    short.write_text(shortened(script.read_text()))
    runpy.run_path(str(short), run_name="__main__")
    pngs = list((tmp_path / "logs").rglob("*.png")) if (tmp_path / "logs").is_dir() else []
    assert pngs or plt.get_fignums(), f"{script.name} drew no figure"
    for p in pngs:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    plt.close("all")
