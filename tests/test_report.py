"""``coordarm report`` and the workspace map: files written, blow-up predicted by the longitudinal margin."""
import subprocess
import sys

import numpy as np
import pytest

from coordarm.analysis.report_outputs import simulate_scenario
from coordarm.analysis.report import analyse_run, default_samples, simulate_through, write_report
from coordarm.analysis.workspace import curve_zigzag, plot_workspace, workspace_map
from coordarm.cli import main
from coordarm.simulation.run import DEFAULT_THRESHOLDS, simulate
from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic import Arc, CoordinatingController, Line, PlanarChain

FAST_ARC = ('name = "fast"\n[chain]\nlinks = 16\nlink_length = 0.1\n[curve]\nkind = "arc"\nradius = 1.0\n'
            '[control]\ngain = 2.0\nspeed = 0.4\n[start]\nkind = "projected"\n[run]\nduration = 3.0\n')


@pytest.mark.parametrize("preset", ["line", "arc", "hole"])
def test_report_on_each_preset_writes_markdown_and_readable_plots(preset, tmp_path, capsys):
    out = tmp_path / preset
    assert main(["report", preset, "--links", "12", "--duration", "2", "--out", str(out), "--samples", "300"]) == 0
    text = (out / "report.md").read_text()
    for section in ("## Margins", "## Blow-up", "## Linearised error dynamics", "## Sampled-data",
                    "longitudinal margin", "1/cond(M)", "![margins](margins.png)"):
        assert section in text
    for png in ("margins.png", "links.png", "step_responses.png"):
        assert (out / png).stat().st_size > 20_000
    assert str(out / "report.md") in capsys.readouterr().out


def test_blow_up_is_predicted_by_the_longitudinal_margin_not_by_cond(tmp_path):
    toml = tmp_path / "fast.toml"
    toml.write_text(FAST_ARC)
    sc = load_scenario(toml)
    run = simulate_scenario(sc)                     # stop thresholds off: the blow-up happens
    a = analyse_run(sc.controller(), run.t, run.q, run.u, samples=400)
    assert a.blowup_time is not None
    assert np.max(run.u[run.t <= a.blowup_time]) > 0  # sanity
    pred = a.predicted()
    assert pred["longitudinal"] and a.crossings["longitudinal"] < a.blowup_time
    assert a.thresholds["longitudinal"] == DEFAULT_THRESHOLDS["longitudinal"]
    assert not pred["inverse_cond"] and not pred["sigma_min"]
    path = write_report(run, sc, tmp_path / "rep", samples=400)
    text = path.read_text()
    assert "predicted by: longitudinal margin" in text and "**yes**" in text


def test_zoomed_first_crossings_equal_those_of_every_row_and_samples_scale_with_m(tmp_path):
    """Coarse samples + zoom (a few dozen margin evaluations) vs margins at every one of 3001 rows."""
    toml = tmp_path / "fast.toml"
    toml.write_text(FAST_ARC)
    sc = load_scenario(toml)
    ctrl = sc.controller()
    # past the blow-up the path depends on rounding: the interpreted law's run is the reference
    run = simulate_through(ctrl, sc.start(ctrl), sc.duration, sc.step, sc.t0, backend="interpreted")
    every = analyse_run(ctrl, run.t, run.q, run.u, samples=len(run.t))
    zoomed = analyse_run(ctrl, run.t, run.q, run.u, samples=40)
    assert every.crossings["longitudinal"] == zoomed.crossings["longitudinal"] == pytest.approx(2.69)
    for name, first in every.crossings.items():  # samples can miss a crossing, never invent an earlier one
        assert zoomed.crossings[name] is None or zoomed.crossings[name] >= first
    assert len(zoomed.t) < 100 < len(every.t)
    assert default_samples(16) == default_samples(64) == 1200
    assert default_samples(128) == 300 and default_samples(1024) == 100


def test_default_stop_fires_before_u_exceeds_ten_times_nominal(tmp_path):
    toml = tmp_path / "fast.toml"
    toml.write_text(FAST_ARC)
    sc = load_scenario(toml)
    a = analyse_run(sc.controller(), *(lambda r: (r.t, r.q, r.u))(simulate_scenario(sc)), samples=400)
    ctrl = sc.controller()
    from coordarm.symbolic import SingularityError
    with pytest.raises(SingularityError) as info:
        simulate(ctrl, sc.start(ctrl), sc.duration, sc.step)
    assert info.value.kind == "longitudinal" and info.value.time < a.blowup_time
    assert np.max(np.abs(info.value.run.u)) < 10 * a.nominal_u


def test_report_from_a_run_object(tmp_path):
    sc = load_scenario("line").with_overrides(links=8, duration=1.0)
    ctrl = sc.controller()
    run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step)
    path = write_report(run, sc, tmp_path, ctrl=ctrl, samples=200)
    text = path.read_text()
    assert "first |u|_inf > 10 x nominal: never" in text and "no blow-up" in text
    rows = [ln for ln in text.splitlines() if ln.startswith("| 0.") or ln.startswith("| 1.")]
    assert rows and all(float(r.split("|")[2]) < 1e-8 for r in rows)      # linearised = design


def test_report_of_a_logged_run_equals_the_report_of_the_run_itself(tmp_path, capsys):
    from coordarm.analysis.replay import load
    from coordarm.analysis.singularity import run_margins

    log = tmp_path / "line.mcap"
    assert main(["run", "line", "--links", "10", "--duration", "1.0", "--quiet", "--no-figures",
                 "--out", str(log)]) == 0
    assert main(["report", str(log), "--out", str(tmp_path / "from_log"), "--samples", "100"]) == 0
    sc = load_scenario("line").with_overrides(links=10, duration=1.0)
    ctrl = sc.controller()
    run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, backend="compiled")   # as `coordarm run` did
    direct = write_report(run, sc, tmp_path / "direct", ctrl=ctrl, samples=100).read_text()
    logged = (tmp_path / "from_log" / "report.md").read_text()
    body = lambda text: [ln for ln in text.splitlines() if "scenario:" not in ln]   # noqa: E731
    assert body(logged) == body(direct)
    # margins logged by the compiled run == margins recomputed by the analysis module from q
    rep = load(log)
    idx = np.arange(0, len(rep.t), 97)
    mg = run_margins(rep.scenario.controller(), rep.t[idx], rep.q[idx])
    np.testing.assert_allclose(mg["longitudinal"], rep.longitudinal[idx], rtol=1e-10)
    np.testing.assert_allclose(mg["links"], rep.link_margins[idx], rtol=1e-10)


def test_report_of_a_missing_log_is_a_clear_error(tmp_path):
    res = subprocess.run([sys.executable, "-m", "coordarm", "report", str(tmp_path / "missing.mcap")],
                         capture_output=True, text=True)
    assert res.returncode == 2 and "missing.mcap" in res.stderr and "Traceback" not in res.stderr


def test_curve_zigzag_puts_every_centre_on_the_curve():
    for kappa, curve in ((0.0, Line()), (0.8, Arc(radius=1 / 0.8))):
        ctrl = CoordinatingController(PlanarChain(10, 0.1), curve, 1.0, 0.1)
        for beta in (0.1, 0.9, 1.5):
            q = curve_zigzag(10, 0.1, beta, kappa)
            assert np.max(np.abs(ctrl.evaluate(q)["e"])) < 1e-13
    np.testing.assert_allclose(curve_zigzag(6, 0.1, 0.7, 0.0), PlanarChain(6, 0.1).zigzag(0.7), atol=1e-14)


def test_workspace_map_on_a_line_has_the_closed_form_and_is_drawn(tmp_path):
    betas = np.array([0.2, 0.7, 1.2])
    res = workspace_map(links=(4, 8), betas=betas, curvatures=np.array([0.0, 0.5, 1.0]))
    for i, m in enumerate((4, 8)):
        np.testing.assert_allclose(res["longitudinal"][i, 0], (m - 1) / m * np.sin(betas), rtol=1e-12)
        np.testing.assert_allclose(res["smallest_link"][i, 0], np.cos(betas), rtol=1e-12)
    assert np.all(np.isfinite(res["log10_cond"]))
    assert plot_workspace(res, tmp_path / "ws.png").stat().st_size > 20_000


@pytest.mark.parametrize("case", ["32 links, arc R = 1.0, v* = 0.4", "16 links, swinging line, v* = 0.2"])
def test_threshold_study_cases_stop_before_the_blow_up(case):
    """The two blow-up runs of analysis.threshold_study with the least lead (the others take ~30 s)."""
    from coordarm.analysis.threshold_study import blowup_cases
    from coordarm.symbolic import SingularityError
    ctrl, q0, duration = blowup_cases()[case]
    free = simulate(ctrl, q0, duration, 0.001, thresholds={"link": 0.0, "longitudinal": 0.0})
    a = analyse_run(ctrl, free.t, free.q, free.u, samples=300)
    assert a.blowup_time is not None and a.predicted()["longitudinal"]
    with pytest.raises(SingularityError) as info:
        simulate(ctrl, q0, duration, 0.001)
    assert info.value.kind == "longitudinal" and info.value.time < a.blowup_time - 0.05
    assert np.max(np.abs(info.value.run.u), axis=1).max() < 10 * a.nominal_u


@pytest.mark.parametrize("preset", ["line", "arc", "hole"])
def test_no_preset_raises_a_blow_up_alarm(preset):
    """The old nominal (median over the first second, at rest) made healthy runs look like blow-ups."""
    sc = load_scenario(preset)
    ctrl = sc.controller()
    run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step)
    a = analyse_run(ctrl, run.t, run.q, run.u, samples=100)
    assert a.blowup_time is None and a.blowup_link is None
    assert np.max(a.u_norm) < 10 * a.nominal_u
    # the nominal is at least the commanded motion's joint rate: (max v* + K max|e(0)|) / xi
    vmax = float(np.max(np.abs(ctrl.speeds(run.t))))
    assert a.nominal_u >= (vmax + ctrl.gain * np.max(np.abs(run.e[0]))) / ctrl.chain.xi - 1e-12


def test_report_json_records_margins_blowup_outcome_and_collisions(tmp_path):
    import json
    toml = tmp_path / "fast.toml"
    toml.write_text(FAST_ARC)
    assert main(["report", str(toml), "--out", str(tmp_path / "r"), "--samples", "200"]) == 0
    data = json.loads((tmp_path / "r" / "report.json").read_text())
    assert data["blowup"]["time"] == pytest.approx(2.738) and data["blowup"]["link"] >= 1
    assert data["margins"]["longitudinal"]["first_below"] < data["blowup"]["time"]
    assert data["margins"]["links"]["link"] >= 2 and data["outcome"]["status"] in ("completed", "singularity")
    assert isinstance(data["collisions"], list) and data["clearance"] == {}
    log = tmp_path / "line.mcap"
    assert main(["run", "line", "--links", "10", "--duration", "1.0", "--quiet", "--no-figures",
                 "--out", str(log)]) == 0
    assert main(["report", str(log), "--out", str(tmp_path / "l"), "--samples", "50"]) == 0
    data = json.loads((tmp_path / "l" / "report.json").read_text())
    assert data["blowup"] is None and data["outcome"]["status"] == "completed" and data["collisions"] == []
    assert data["links"] == 10 and data["margins"]["longitudinal"]["value"] > 0.15
    assert main(["report", "hole", "--links", "50", "--duration", "9", "--out", str(tmp_path / "h"),
                 "--samples", "50"]) == 0
    clear = json.loads((tmp_path / "h" / "report.json").read_text())["clearance"]
    assert sorted(clear) == [f"wall {i}" for i in range(1, 6)]
    assert 0 < clear["wall 1"]["distance"] < 0.03 and 1 <= clear["wall 1"]["link"] <= 50   # the hole: ~1 cm


def test_threshold_study_is_a_sweep_whose_lead_is_the_stop_of_a_normal_run():
    """The study's row (a sweep point run without stops) against the stop of the same case run with stops."""
    from coordarm.analysis.threshold_study import blowup_cases, threshold_point
    from coordarm.simulation.scenario import load_scenario
    from coordarm.simulation.sweep import sweep
    from coordarm.symbolic import SingularityError

    case = "32 links, arc R = 1.0, v* = 0.4"
    (row,) = sweep(load_scenario("line"), {"case": [case]}, client="serial", point_fn=threshold_point).to_dict("records")
    ctrl, q0, duration = blowup_cases()[case]
    with pytest.raises(SingularityError) as info:
        simulate(ctrl, q0, duration, 0.001)
    assert row["outcome"] == "singularity" and row["fires_longitudinal"]
    assert row["blowup"] - row["lead_0.15"] == pytest.approx(info.value.time, abs=1e-9)
