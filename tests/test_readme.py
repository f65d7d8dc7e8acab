"""The README's Python examples run as written (durations shortened)."""
import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parent.parent / "README.md"


def test_readme_api_compiled_and_analysis_examples_run():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    examples = [b for b in blocks if "load(" not in b and "sweep(" not in b
                and not b.startswith("# example:")]   # those: tested below
    assert len(examples) == 5
    ns: dict = {}
    exec(compile("\n".join(examples).replace("20.0", "0.05"), str(README), "exec"), ns)
    np.testing.assert_allclose(ns["fast"].control(ns["q"], 0.0), ns["u"], rtol=1e-12, atol=1e-15)
    eig = np.sort(ns["lin"].eigenvalues().real)
    np.testing.assert_allclose(eig, [-2.0] * 63 + [0.0], atol=1e-8)
    assert abs(ns["sampled_limit"](delay=1) - 1.0) < 1e-15
    assert [(c.kind, c.links) for c in ns["contacts"]] == [("self", (1, 3)), ("self", (1, 4)), ("self", (2, 4))]


def test_readme_replay_example_runs_on_a_real_log(tmp_path, monkeypatch):
    from coordarm.cli import main

    block = next(b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S) if "load(" in b)
    monkeypatch.chdir(tmp_path)
    assert main(["run", "line", "--links", "8", "--duration", "0.1", "--quiet", "--no-figures"]) == 0
    ns: dict = {}
    exec(compile(block, str(README), "exec"), ns)
    assert ns["rep"].outcome["status"] == "completed" and ns["ctrl"].chain.m == 8


def test_readme_path_rail_and_user_curve_examples_run():
    blocks = {b.split("\n", 1)[0][len("# example: "):]: b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
              if b.startswith("# example:")}
    assert set(blocks) == {"paths", "rail", "user curve", "run_scenario", "spatial"}
    ns: dict = {}
    exec(compile(blocks["paths"], str(README), "exec"), ns)
    assert ns["fillet"].segments == ns["same"].segments and float(ns["psi"]) > 0
    ns = {}
    exec(compile(blocks["rail"], str(README), "exec"), ns)
    assert abs(ns["out"]["u"][0] - 0.17) < 1e-12 and abs(ns["out"]["rail_margin"] - 1.0) < 1e-12
    ns = {}
    exec(compile(blocks["user curve"], str(README), "exec"), ns)
    run = ns["run"]                  # the zig-zag starts on the tangent: e^j decays like exp(-K t)
    assert run.info["stopped"] == "completed" and np.max(np.abs(run.e[0])) > 1e-3
    np.testing.assert_allclose(run.e[-1], run.e[0] * np.exp(-2.0 * run.t[-1]), rtol=1e-6, atol=1e-12)
def test_readme_sweep_example_runs_and_writes_its_results(tmp_path, monkeypatch):
    block = next(b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S) if "sweep(" in b)
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    exec(compile(block, str(README), "exec"), ns)
    df = ns["df"]
    assert list(df.columns[:3]) == ["control.gain", "links", "run.duration"] and len(df) == 6
    assert set(df["outcome"]) == {"completed"}
    assert (tmp_path / "logs" / "gain_sweep" / "results.parquet").is_file()


def test_readme_run_scenario_example_runs_and_writes_its_log_and_figures(tmp_path, monkeypatch):
    block = next(b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
                 if b.startswith("# example: run_scenario"))
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    exec(compile(block.replace("duration=5.0", "duration=0.2"), str(README), "exec"), ns)
    result = ns["result"]
    assert (result.outcome, result.exit_status, result.stopped) == ("completed", 0, None)
    assert result.log == Path("logs/line.mcap") and (tmp_path / "logs" / "line.mcap").is_file()
    assert len(result.figures) == 2 and all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in result.figures)
    assert len(result.run.t) == 201


def test_readme_spatial_example_runs_and_its_end_point_tracks_v_star():
    block = next(b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
                 if b.startswith("# example: spatial"))
    ns: dict = {}
    exec(compile(block, str(README), "exec"), ns)
    out, run = ns["out"], ns["run"]
    assert out["u"].shape == (24,) and out["e"].shape == (22,) and out["link_margins"].shape == (11,)
    assert run.q.shape == (501, 24) and run.info["stopped"] == "completed"
    np.testing.assert_allclose(run.s - run.s[0], 0.05 * run.t, atol=1e-12)
