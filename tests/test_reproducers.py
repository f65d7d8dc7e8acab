"""The reproducers of issue 25: each ends in one line naming the file, field or flag, or works."""
import re
import sys
from importlib import resources

import numpy as np
import pytest

from coordarm.cli import main
from coordarm.symbolic import ConfigError, SingularityError
from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic.start import check_start


def preset_text(name: str, **subs: str) -> str:
    text = (resources.files("coordarm.simulation") / "presets" / f"{name}.toml").read_text()
    for pattern, repl in subs.items():
        text = re.sub(pattern, repl, text, count=1)
    return text


def one_line_error(capsys, *words):
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "error" in ln]
    assert len(lines) == 1 and "Traceback" not in err, err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


# item 1 ------------------------------------------------------------------------------------------
def test_a_projected_start_on_a_rail_keeps_the_base_at_d_and_puts_every_centre_on_the_curve(tmp_path):
    text = preset_text("arc", **{r"\[chain\]\nlinks = 64": '[chain]\nlinks = 8\n'
                                 'base = { kind = "rail", angle = 0.0, limits = [0.0, 5.0] }'})
    path = tmp_path / "arc_rail.toml"
    path.write_text(text)
    sc = load_scenario(path)
    ctrl = sc.controller()
    q = sc.start(ctrl)
    assert q.shape == (9,) and q[0] == 0.0                  # d first, at the rail's lower limit
    # independent check: the centres from plain trigonometry lie on the arc of radius 2.2 m
    # through the origin with its tangent along x there (centre (0, 2.2))
    alpha = np.cumsum(q[1:])
    half = 0.05 * np.c_[np.cos(alpha), np.sin(alpha)]
    centres = np.r_[[[0.0, 0.0]], np.cumsum(half[:-1] + half[1:], 0)]     # y^1 = the base at d = 0
    radius = np.hypot(centres[1:, 0], centres[1:, 1] - 2.2)
    np.testing.assert_allclose(radius, 2.2, atol=1e-9)
    check_start(ctrl, q)


# item 2 ------------------------------------------------------------------------------------------
SMALL = ["--links", "6", "--duration", "0.05", "--quiet", "--no-figures"]


@pytest.mark.parametrize("flag", ["--log-rate", "--cond-rate"])
@pytest.mark.parametrize("rate", ["nan", "-1", "inf"])
def test_a_log_or_cond_rate_that_is_not_a_positive_number_is_refused_naming_the_flag(flag, rate, tmp_path, capsys):
    out = tmp_path / "r.mcap"
    assert main(["run", "line", *SMALL, "--out", str(out), flag, rate]) == 2
    one_line_error(capsys, flag, "positive")
    assert not out.exists()


@pytest.mark.parametrize("flag", ["--log-rate", "--cond-rate"])
def test_a_tiny_log_rate_runs_and_logs_the_first_and_last_sample(flag, tmp_path):
    from coordarm.analysis.replay import load
    out = tmp_path / "r.mcap"
    assert main(["run", "line", *SMALL, "--out", str(out), flag, "1e-300"]) == 0
    rep = load(out)
    if flag == "--log-rate":
        np.testing.assert_allclose(rep.t, [0.0, 0.05], atol=1e-9)


# item 4 ------------------------------------------------------------------------------------------
STIFF = ('name = "stiff"\n[chain]\nlinks = 6\nlink_length = 0.1\n[curve]\nkind = "line"\n'
         '[control]\ngain = 10000\nspeed = 0.0\n[run]\nduration = 0.01\nstep = 0.001\n')


def test_the_gain_step_check_sees_the_step_of_the_command_line(tmp_path, capsys):
    path = tmp_path / "stiff.toml"
    path.write_text(STIFF)
    out = tmp_path / "stiff.mcap"
    assert main(["run", str(path), "--step", "1e-4", "--quiet", "--no-figures", "--out", str(out)]) == 0
    assert main(["run", str(path), "--step", "3e-4", "--quiet", "--no-figures", "--out", str(out),
                 "--overwrite"]) == 2
    one_line_error(capsys, str(path), "K h = 1e+04 x 0.0003")
    assert load_scenario(path, step=1e-4).step == 1e-4


# found by the campaign ---------------------------------------------------------------------------
@pytest.mark.parametrize("axis", ["[[], 0.0, 0.0]", "[[1.0], 0.0, 0.0]", "[1.0, 0.0]", '"x"'])
def test_a_ragged_or_short_start_axis_of_a_spatial_chain_is_one_config_error(axis, tmp_path):
    from coordarm.symbolic import ConfigError
    path = tmp_path / "s.toml"
    path.write_text(preset_text("line3d", **{r"\naxis = \[[^\n]*\]": f"\naxis = {axis}"}))
    with pytest.raises(ConfigError, match=r"start\.axis: need three finite numbers") as err:
        load_scenario(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


# item 3 ------------------------------------------------------------------------------------------
def test_a_sweep_range_of_a_billion_values_is_refused_at_once_within_a_small_memory_limit():
    import subprocess
    import sys
    code = ("import resource; resource.setrlimit(resource.RLIMIT_AS, (1 << 31, 1 << 31))\n"
            "from coordarm.simulation.sweep_points import parse_vary\n"
            "from coordarm.symbolic import ConfigError\n"
            "try:\n    parse_vary('links=16:32:1000000000')\nexcept ConfigError as e:\n    print(e)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and "1,000,000,000 values" in done.stdout, done.stderr[-500:]


@pytest.fixture
def no_points_run(monkeypatch):
    """The sweep's batches are recorded, not run (a check that comes too late shows as a batch)."""
    from coordarm.simulation import sweep as sweep_module
    ran = []
    monkeypatch.setattr(sweep_module, "run_batch", lambda spec, pts, *a, **k: ran.extend(pts) or [])
    return sweep_module.sweep, ran


def test_a_grid_of_a_million_points_is_refused_before_any_point_runs(no_points_run, capsys):
    sweep, ran = no_points_run
    with pytest.raises(ConfigError, match=r"--vary: a grid of 1,000 x 1,000 = 1,000,000 points"):
        sweep("line", {"links": list(range(4, 1004)), "speed": list(np.linspace(0, 1, 1000))}, client="serial")
    assert ran == []
    assert main(["sweep", "line", "--vary", "links=4:100:1000", "--vary", "speed=0:1:1000", "--quiet"]) == 2
    one_line_error(capsys, "--vary", "1,000,000 points", "100,000")


def test_a_sweep_too_costly_needs_yes(no_points_run):
    sweep, ran = no_points_run
    with pytest.raises(ConfigError, match=r"16,500,000,014 RK4 steps over 30 points.*--yes"):
        sweep("line", {"step": [1e-6], "duration": list(np.linspace(100, 1000, 30))}, client="serial")
    assert ran == []


def test_a_sweep_value_the_scenario_refuses_is_named_before_any_point_runs(tmp_path, capsys):
    out = tmp_path / "sw"
    assert main(["sweep", "line", "--vary", "links=4,6", "--vary", "control.governor=true,false,maybe",
                 "--out", str(out), "--quiet", "--no-figures"]) == 2
    one_line_error(capsys, "--vary control.governor='maybe'", "true or false")
    assert not out.exists()


def test_a_damaged_results_table_is_one_line_naming_it(tmp_path, capsys):
    out = tmp_path / "sw"
    out.mkdir()
    (out / "results.parquet").write_bytes(b"not parquet at all")
    assert main(["sweep", "line", "--vary", "duration=0.01", "--out", str(out), "--quiet", "--no-figures"]) == 2
    one_line_error(capsys, str(out / "results.parquet"), "delete it or choose another --out")


def test_an_unwritable_sweep_out_is_refused_before_any_point_runs(tmp_path, no_points_run):
    from coordarm.symbolic import LogError
    sweep, ran = no_points_run
    (tmp_path / "file").write_text("x")
    with pytest.raises(LogError, match="--out"):
        sweep("line", {"duration": [0.01, 0.02]}, client="serial", out=tmp_path / "file" / "sub")
    assert ran == []


# item 7 ------------------------------------------------------------------------------------------
def test_export_refuses_to_replace_an_earlier_export_unless_overwrite(tmp_path, capsys):
    out = tmp_path / "law"
    assert main(["export", "line", "--links", "4", "--out", str(out)]) == 0
    before = (out / "coordarm_law.c").read_text()
    (out / "coordarm_law.c").write_text("/* edited by hand */")
    capsys.readouterr()
    assert main(["export", "line", "--links", "4", "--out", str(out)]) == 2
    one_line_error(capsys, str(out), "coordarm_law.c exists", "--overwrite")
    assert (out / "coordarm_law.c").read_text() == "/* edited by hand */"
    assert main(["export", "line", "--links", "4", "--out", str(out), "--overwrite"]) == 0
    assert (out / "coordarm_law.c").read_text() == before


def test_export_to_an_empty_out_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["export", "line", "--links", "4", "--out", ""]) == 2
    one_line_error(capsys, "--out", "empty")
    assert list(tmp_path.iterdir()) == []


# item 11 -----------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def two_logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("logs")
    for name in ("line", "a"):
        assert main(["run", "line", *SMALL, "--out", str(folder / f"{name}.mcap")]) == 0
    return folder


def test_report_of_a_log_is_named_after_the_log_not_its_scenario(two_logs, capsys):
    for name in ("line", "a"):
        assert main(["report", str(two_logs / f"{name}.mcap"), "--samples", "5"]) == 0
        assert (two_logs / f"{name}_report" / "report.md").is_file()
    a = (two_logs / "a_report" / "report.md").read_text()
    assert str(two_logs / "a.mcap") in a or "a.mcap" in a


def test_report_into_a_given_out_holding_a_report_needs_overwrite(two_logs, tmp_path, capsys):
    out = tmp_path / "rep"
    log = str(two_logs / "line.mcap")
    assert main(["report", log, "--samples", "5", "--out", str(out)]) == 0
    capsys.readouterr()
    assert main(["report", log, "--samples", "5", "--out", str(out)]) == 2
    one_line_error(capsys, str(out), "--overwrite")
    assert main(["report", log, "--samples", "5", "--out", str(out), "--overwrite"]) == 0


def test_bad_report_arguments_are_refused_before_casadi_or_matplotlib_load(tmp_path):
    import subprocess
    import sys
    code = ("import sys\nfrom coordarm.cli import main\n"
            "codes = [main(['report', 'x.mcap', '--samples', '-5']), main(['report', 'missing.mcap']),\n"
            "         main(['report', 'x.mcap', '--links', '4'])]\n"
            "print(codes, sorted(m for m in ('casadi', 'matplotlib', 'numpy') if m in sys.modules))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.stdout.strip() == "[2, 2, 2] []", (done.stdout, done.stderr[-800:])


def test_a_run_piped_into_a_reader_that_stops_early_completes_quietly(tmp_path):
    import subprocess
    proc = subprocess.Popen([sys.executable, "-m", "coordarm", "run", "line", "--links", "6", "--duration", "0.3",
                             "--no-figures",
                             "--out", str(tmp_path / "p.mcap")], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    first = proc.stdout.readline()
    proc.stdout.close()                       # the reader goes away, like `| head -1`
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0 and first.startswith(b"scenario")
    assert "rror" not in err and "Traceback" not in err, err
    from coordarm.analysis.replay import load
    assert load(tmp_path / "p.mcap").outcome["status"] == "completed"


@pytest.mark.parametrize("preset", ["line", "line3d"])
def test_a_huge_link_count_with_a_joint_limit_is_refused_before_a_chain_is_built(preset, tmp_path):
    path = tmp_path / "s.toml"
    text = preset_text(preset, **{r"links = \d+": "links = 99999999999999999999"})
    if "joint_limit" not in text:
        text = text.replace("link_length = 0.1", "link_length = 0.1\njoint_limit = 2.0", 1)
    path.write_text(text)
    with pytest.raises(ConfigError, match=r"chain\.links: 99999999999999999999 links need at least .* of memory, more than this machine"):
        load_scenario(path)


# item 12 -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("field, extra", [("speed = 1e300", ""), ("speed = 0.1\nspan = [1.0, 1e300]",
                                          'base = { kind = "rail", angle = 0.0, limits = [0.0, 5.0] }\n')])
def test_a_commanded_speed_or_span_beyond_a_million_is_refused(field, extra, tmp_path, capsys):
    path = tmp_path / "fast.toml"
    path.write_text(f'name = "fast"\n[chain]\nlinks = 6\nlink_length = 0.1\n{extra}[curve]\nkind = "line"\n'
                    f'[control]\ngain = 2.0\n{field}\n[run]\nduration = 0.05\nstep = 0.001\n')
    assert main(["run", str(path), "--quiet", "--no-figures", "--out", str(tmp_path / "f.mcap")]) == 2
    line = one_line_error(capsys, str(path), "1e+300 is beyond")
    assert len(line) < 200


def test_a_state_that_turns_non_finite_is_said_so_not_called_a_joint_limit():
    from coordarm import CoordinatingController, Line
    from coordarm.simulation.run import simulate
    sc = load_scenario("line").with_overrides(links=6)
    chain = sc.chain()
    ctrl = CoordinatingController(chain, Line(point=(0, 0), angle=0.0), gain=2.0, speed=1e308)   # (Python: no bound)
    with pytest.raises(SingularityError, match=r"at t = 0.5000 s: .* is nan \(the state is no longer finite"):
        simulate(ctrl, chain.zigzag(1.3), 2.0, 0.5, backend="interpreted",
                 thresholds={"link": 0.0, "longitudinal": 0.0}, physical=sc.physical(chain))


def test_a_huge_joint_value_is_shown_in_a_few_characters():
    from coordarm.simulation.physical import Contact
    text = Contact("joint_limit", 0.001, (1, 2), -3.9e297, 2.8).describe()
    assert "-3.9e+297 rad" in text and len(text) < 200


def _full_disk(*args, **kwargs):
    import errno
    raise OSError(errno.ENOSPC, "No space left on device")      # as a write() on a full disk: no file name


def test_a_full_disk_while_writing_a_report_names_the_report(two_logs, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("coordarm.analysis.report.markdown", _full_disk)
    out = tmp_path / "rep"
    assert main(["report", str(two_logs / "line.mcap"), "--samples", "5", "--out", str(out)]) == 2
    one_line_error(capsys, str(out / "report.md"), "No space left on device")


def test_a_full_disk_while_writing_sweep_results_names_the_table(tmp_path, monkeypatch):
    from coordarm.simulation import sweep as sweep_module
    from coordarm.symbolic import LogError
    monkeypatch.setattr(sweep_module.ResultsTable, "_write_files", _full_disk)
    with pytest.raises(LogError, match=r"results\.parquet: cannot write it: No space left on device"):
        sweep_module.sweep("line", {"links": [4], "duration": [0.01]}, client="serial", out=tmp_path / "sw")


def test_a_full_disk_with_no_file_named_still_says_where_to_look(monkeypatch, capsys):
    from coordarm.commands import layout
    monkeypatch.setattr(layout, "main", _full_disk)
    assert main(["layout", "--out", "x.json"]) == 2
    one_line_error(capsys, "No space left on device", "--out")
