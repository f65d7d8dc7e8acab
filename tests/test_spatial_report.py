"""``coordarm report`` and ``coordarm sweep`` on a spatial chain (universal joints), against independent computations."""
import json
import math

import numpy as np
import pytest

import coordarm
from coordarm.analysis.linearise import linearise
from coordarm.analysis.replay import load
from coordarm.cli import main

PNG = b"\x89PNG\r\n\x1a\n"
LINKS = 12


@pytest.fixture(scope="module")
def reported(tmp_path_factory):
    """A short line3d log of 12 links and its report (the command line, as a user runs them)."""
    d = tmp_path_factory.mktemp("spatial_report")
    log = d / "l3.mcap"
    assert main(["run", "line3d", "--links", str(LINKS), "--duration", "1", "--out", str(log), "--no-figures"]) == 0
    assert main(["report", str(log), "--out", str(d / "report")]) == 0
    return log, d / "report"


def test_report_of_a_spatial_log_writes_markdown_json_and_pngs(reported):
    _, out = reported
    text = (out / "report.md").read_text()
    for section in ("## Margins", "## Blow-up and conditioning", "## Linearised error dynamics", "## Sampled-data",
                    "universal joints", "link_margins", "end_margin", "joint_margins", "![links](links.png)"):
        assert section in text
    for png in ("margins.png", "links.png", "step_responses.png"):
        data = (out / png).read_bytes()
        assert data[:8] == PNG and len(data) > 20_000
    summary = json.loads((out / "report.json").read_text())
    assert summary["chain_kind"] == "universal" and summary["links"] == LINKS


def _table_row(text: str, field: str) -> list[str]:
    row = next(line for line in text.splitlines() if f"(`{field}`)" in line)
    return [c.strip() for c in row.strip().strip("|").split("|")]


def test_margin_minima_in_the_report_are_those_of_the_logged_arrays(reported):
    log, out = reported
    run = load(log)                                 # read independently of the report
    text = (out / "report.md").read_text()
    for field, first, what in (("link_margins", 2, "link"), ("end_margin", None, None),
                               ("joint_margins", 1, "joint")):
        values = np.asarray(getattr(run, field), float)
        cells = _table_row(text, field)
        assert float(cells[2]) == pytest.approx(np.min(values), rel=1e-8)
        k = np.unravel_index(np.argmin(values), values.shape)
        assert float(cells[3].removesuffix(" s")) == pytest.approx(run.t[k[0]], abs=5e-4)
        assert cells[4] == ("-" if first is None else f"{what} {k[1] + first}")


def _fd_task_matrix(ctrl, q, t, eps_flow=1e-4, eps_q=1e-3):
    """d(z')/dz by nested central differences of the task map z = (s, roll, e) along the closed loop q' = u."""
    def h(x, s):
        o = ctrl.evaluate(x, s)
        return np.concatenate([[o["s"], o["roll"]], o["e"]])

    def diff(a, b):            # z(a) - z(b), the roll wrapped to (-pi, pi]
        d = a - b
        d[1] = math.remainder(d[1], 2 * math.pi)
        return d

    def rate(x):               # z' along the flow (q', t') = (u, 1)
        f = ctrl.control(x, t)
        return diff(h(x + eps_flow * f, t + eps_flow), h(x - eps_flow * f, t - eps_flow)) / (2 * eps_flow)

    n = len(q)
    H = np.empty((n, n))
    J = np.empty((n, n))
    for i in range(n):
        dq = np.zeros(n)
        dq[i] = eps_q
        H[:, i] = diff(h(q + dq, t), h(q - dq, t)) / (2 * eps_q)
        J[:, i] = (rate(q + dq) - rate(q - dq)) / (2 * eps_q)
    return J @ np.linalg.inv(H)


def test_linearised_error_dynamics_have_eigenvalues_minus_k_and_match_finite_differences(reported):
    log, _ = reported
    run = load(log)
    ctrl = run.scenario.with_overrides(links=LINKS).controller()
    K = ctrl.gain
    for k in (0, len(run.t) // 2, len(run.t) - 1):
        q, t = np.asarray(run.q[k], float), float(run.t[k])
        L = linearise(ctrl, q, t)
        ev = np.sort(L.eigenvalues().real)
        assert np.max(np.abs(L.eigenvalues().imag)) < 1e-6
        np.testing.assert_allclose(ev[:-1], -K, atol=1e-6)           # roll and the 2(m-1) deviations
        assert abs(ev[-1]) < 1e-6                                     # s: s' = v*, no feedback
        A = _fd_task_matrix(ctrl, q, t)
        design = np.diag([0.0] + [-K] * (2 * LINKS - 1))
        assert np.max(np.abs(A - design)) < 1e-5                      # the independent Jacobian agrees
        np.testing.assert_allclose(A, L.task_matrix, atol=1e-5)
        fd_ev = np.sort(np.linalg.eigvals(A).real)
        np.testing.assert_allclose(fd_ev[:-1], -K, atol=1e-5)


def test_report_of_the_linearisation_in_markdown_says_minus_k(reported):
    _, out = reported
    summary = json.loads((out / "report.json").read_text())
    assert len(summary["linearisation"]) == 4
    for point in summary["linearisation"]:
        ev = sorted(point["eigenvalues"])
        np.testing.assert_allclose(ev[:-1], -2.0, atol=1e-6)
        assert point["deviation"] < 1e-6


def test_two_point_sweep_of_line3d_gives_completed_rows_with_the_spatial_margins(tmp_path):
    df = coordarm.sweep("line3d", {"links": [12, 16], "run.duration": [0.4]}, client="serial", out=tmp_path)
    assert list(df["outcome"]) == ["completed", "completed"] and list(df["message"]) == ["", ""]
    for i, m in enumerate((12, 16)):
        sc = coordarm.load_scenario("line3d").with_overrides(links=m, duration=0.4)
        ctrl = sc.controller()
        run = coordarm.simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, thresholds=sc.thresholds)
        row = df.loc[i]
        assert row["stop_time"] == pytest.approx(0.4)
        assert row["min_link_margin"] == pytest.approx(np.min(run.link_margins), rel=1e-9)
        assert row["min_end_margin"] == pytest.approx(np.min(run.end_margin), rel=1e-9)
        assert row["min_longitudinal"] == row["min_end_margin"]
        assert row["min_joint_margin"] == pytest.approx(np.min(np.abs(np.cos(run.q[:, 1::2]))), rel=1e-9)
        e = np.asarray(run.e[-1]).reshape(-1, 2)
        assert row["final_max_e"] == pytest.approx(np.max(np.hypot(e[:, 0], e[:, 1])), rel=1e-9)
        assert 0 < row["min_end_margin"] <= 1 and 0 < row["min_link_margin"] <= 1
