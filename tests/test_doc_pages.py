"""Every code block of the README and of the documentation pages runs (or parses) as written.

Blocks are found in the files themselves (tests/doc_blocks.py): ``python`` blocks are executed,
one namespace per page in page order, in a scratch folder that holds ``logs/line.mcap`` of a
short run; ``sh`` blocks run line by line in a shell with the project's ``coordarm`` first on
PATH, each ``coordarm`` command shortened (``--duration 1`` unless it sets a duration) and its
exit status checked (0, or 2 for a line marked ``refused``); ``toml`` and ``json`` blocks are
parsed, a whole scenario validated. Besides, the examples of the former README keep their own
checks of what they print (the rail's ``d_dot = v*``, the decay of a user-defined curve, ...).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from doc_blocks import ROOT, Block, blocks, commands, fast, pages, runnable

BIN = str(Path(sys.executable).parent)
BY_PAGE: dict[Path, list[Block]] = defaultdict(list)
for _b in runnable():
    BY_PAGE[_b.page].append(_b)


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    """A folder with ``logs/line.mcap`` of a short ``line`` run (blocks that read a log use it)."""
    from coordarm.cli import main

    folder = tmp_path_factory.mktemp("doc_blocks")
    old = os.getcwd()
    os.chdir(folder)
    try:
        assert main(["run", "line", "--links", "16", "--duration", "0.5", "--quiet", "--no-figures"]) == 0
    finally:
        os.chdir(old)
    return folder


def _shell(command: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PATH=BIN + os.pathsep + os.environ["PATH"], MPLBACKEND="Agg")
    return subprocess.run(["bash", "-c", command], cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


def _scenario_files(page: Path, cwd: Path) -> None:
    """The page's whole scenarios (toml blocks with a ``name``) as ``NAME.toml`` in ``cwd``, for its commands."""
    for b in blocks(page):
        if b.lang == "toml":
            data = tomllib.loads(b.text)
            if {"chain", "curve", "control", "name"} <= set(data):
                (cwd / f"{data['name']}.toml").write_text(b.text)


@pytest.mark.parametrize("page", sorted(BY_PAGE), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_block_of_the_page_runs(page: Path, scratch: Path, monkeypatch, tmp_path):
    import shutil

    shutil.copytree(scratch / "logs", tmp_path / "logs")
    monkeypatch.chdir(tmp_path)
    _scenario_files(page, tmp_path)
    namespace: dict = {"__name__": "__doc_block__"}
    for b in BY_PAGE[page]:
        if b.skip:
            continue
        if b.lang == "python":
            exec(compile(b.text, b.id, "exec"), namespace)
        elif b.lang == "toml":
            data = tomllib.loads(b.text)
            if {"chain", "curve", "control"} <= set(data):
                import coordarm

                coordarm.Scenario.from_dict(data, source=b.id)
        elif b.lang == "json":
            json.loads(b.text)
        elif b.lang == "sh":
            for command, status in commands(b.text):
                done = _shell(fast(command), tmp_path)
                assert done.returncode == status, (f"{b.id}: {command!r} exited {done.returncode}, expected "
                                                   f"{status}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")


def test_most_blocks_run_and_every_skip_says_why():
    runs = runnable()
    skipped = [b for b in runs if b.skip]
    assert len(runs) >= 25 and len(skipped) <= len(runs) // 5, [b.id for b in skipped]
    for b in skipped:
        before = b.page.read_text().splitlines()[b.line - 2]
        assert "no-test:" in before and len(before.split("no-test:")[1].strip(" ->")) > 5, b.id


def test_blocks_are_found_with_their_language():
    found = {(b.page.name, b.lang) for p in pages() for b in blocks(p)}
    assert ("README.md", "python") in found and ("README.md", "sh") in found
    assert ("scenarios.md", "toml") in found


def test_fast_keeps_a_commands_own_duration_and_shortens_the_rest():
    assert fast("coordarm run line") == "coordarm run line --duration 1"
    assert fast("coordarm run pipe --duration 6") == "coordarm run pipe --duration 6"
    assert fast("coordarm run line --step 1e-5 --duration 1000 --yes").endswith("--yes --duration 0.01")
    assert fast("make demo") == "true"
    assert commands("coordarm run x   # refused: too big\ncoordarm run y  # exit 3\n# a comment\n") == [
        ("coordarm run x", 2), ("coordarm run y", 3)]


def _example(name: str) -> str:
    for p in pages():
        for b in blocks(p):
            if b.lang == "python" and b.text.startswith(f"# example: {name}\n"):
                return b.text
    raise AssertionError(f"no block '# example: {name}'")


def test_the_rail_example_gives_d_dot_equal_v_star():
    ns: dict = {}
    exec(_example("rail"), ns)
    assert abs(ns["out"]["u"][0] - 0.17) < 1e-12 and abs(ns["out"]["rail_margin"] - 1.0) < 1e-12


def test_the_user_curve_example_decays_like_exp_minus_k_t():
    ns: dict = {}
    exec(_example("user curve"), ns)
    run = ns["run"]                  # the zig-zag starts on the tangent: e^j decays like exp(-K t)
    assert run.info["stopped"] == "completed" and np.max(np.abs(run.e[0])) > 1e-3
    np.testing.assert_allclose(run.e[-1], run.e[0] * np.exp(-2.0 * run.t[-1]), rtol=1e-6, atol=1e-12)


def test_the_paths_example_builds_the_same_path_from_data():
    ns: dict = {}
    exec(_example("paths"), ns)
    assert ns["fillet"].segments == ns["same"].segments and float(ns["psi"]) > 0


def test_the_spatial_example_tracks_v_star():
    ns: dict = {}
    exec(_example("spatial"), ns)
    out, run = ns["out"], ns["run"]
    assert out["u"].shape == (24,) and out["e"].shape == (22,) and out["link_margins"].shape == (11,)
    assert run.q.shape == (501, 24) and run.info["stopped"] == "completed"
    np.testing.assert_allclose(run.s - run.s[0], 0.05 * run.t, atol=1e-12)


def test_the_run_scenario_example_writes_its_log_and_figures(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    exec(_example("run_scenario").replace("duration=5.0", "duration=0.2"), ns)
    result = ns["result"]
    assert (result.outcome, result.exit_status, result.stopped) == ("completed", 0, None)
    assert result.log == Path("logs/line.mcap") and (tmp_path / "logs" / "line.mcap").is_file()
    assert len(result.figures) == 2 and all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in result.figures)


def test_the_analysis_block_gives_the_designed_eigenvalues():
    block = next(b for b in runnable() if b.page.name == "analysis.md" and b.lang == "python")
    ns: dict = {}
    exec(block.text, ns)
    eig = np.sort(ns["lin"].eigenvalues().real)
    np.testing.assert_allclose(eig, [-2.0] * 63 + [0.0], atol=1e-8)
    assert abs(ns["sampled_limit"](delay=1) - 1.0) < 1e-15


def test_the_compiled_block_agrees_with_the_interpreted_law():
    block = next(b for b in runnable() if b.page.name == "compiled.md" and b.lang == "python")
    ns: dict = {}
    exec(block.text.replace("20.0", "0.05"), ns)
    np.testing.assert_allclose(ns["fast"].control(ns["q"], 0.0), ns["ctrl"].control(ns["q"], 0.0),
                               rtol=1e-12, atol=1e-15)


def test_the_validity_block_finds_the_self_contacts():
    block = next(b for b in runnable() if b.page.name == "validity.md" and b.lang == "python")
    ns: dict = {}
    exec(block.text, ns)
    assert [(c.kind, c.links) for c in ns["contacts"]] == [("self", (1, 3)), ("self", (1, 4)), ("self", (2, 4))]


def test_the_getting_started_transcript_is_what_make_demo_prints(tmp_path):
    """The summary shown on the getting-started page is the command's output, line for line (the library's
    cache folder, which differs per machine, stands as ``~/.cache/coordarm/<key>``)."""
    import re

    page = (ROOT / "docs" / "getting-started.md").read_text()
    shown = re.search(r"```text\n(scenario      line .*?)```", page, re.S).group(1).splitlines()
    out = subprocess.run([os.path.join(BIN, "coordarm"), "run", "line", "--out", "logs/line.mcap", "--overwrite"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    printed = [re.sub(r"/\S*/[0-9a-f]{16}/libcoordarm\.so \([^)]*\)",      # (tests build into their own cache)
                      "~/.cache/coordarm/<key>/libcoordarm.so (cache hit)", line) for line in out.stdout.splitlines()]
    assert printed == shown
