"""The command line starts without loading the heavy libraries; library modules keep the user's matplotlib backend."""
import json
import subprocess
import sys
import time
from pathlib import Path

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


@pytest.mark.parametrize("argv", [["run", "line", "--links", "8", "--bogus"], ["run"], ["run", "line", "--links", "x"],
                                  ["run", "--help"], ["run", "line", "--backend", "fast"], ["sweep", "line"],
                                  ["report", "--help"], ["export", "line", "--links", "8"], ["run", "line", "--yes"],
                                  ["replay", "x.mcap", "--fps", "0"]])
def test_a_command_parsed_by_its_own_parser_gives_the_same_result_help_and_errors(argv, capsys):
    """``coordarm CMD ...`` registers CMD alone (the other command modules are not imported): the
    namespace, the help text, the error message and the exit status equal those of the full parser."""
    from coordarm.cli import build_parser

    def parse(parser):
        try:
            ns = vars(parser.parse_args(argv))
            out = (0, {k: v for k, v in ns.items() if k != "func"}, ns["func"].__module__)
        except SystemExit as exc:
            out = (exc.code,)
        text = capsys.readouterr()
        return out, text.out, text.err

    assert parse(build_parser(argv[0])) == parse(build_parser())


#: Modules a cache-hit planar ``coordarm run --no-figures`` without --live does not import.
UNUSED_BY_A_RUN = ('coordarm.simulation.live', 'coordarm.simulation.ws_bridge', 'psutil', 'matplotlib',
                   'coordarm.commands.report', 'coordarm.commands.sweep', 'coordarm.analysis.report_outputs',
                   'numpy.ma', 'fractions', 'coordarm.simulation.spatial_scenario', 'coordarm.symbolic.curve3d_specs',
                   'coordarm.generated.spatial_codegen', 'mcap.writer', 'importlib.metadata',
                   # issue 24, the fixed cost: package data without importlib.resources,
                   # Gauss-Legendre nodes on first need, no spatial controller, the kernel's host name, the cache
                   # directory without platformdirs, and with the recipe's library remembered no code generator,
                   # no compiler process (subprocess), no group database, no temporary file (all memos known)
                   'importlib.resources', 'numpy.polynomial', 'coordarm.symbolic.spatial_controller',
                   'coordarm.symbolic.spatial_dense', 'socket', 'platformdirs', 'coordarm.generated.codegen',
                   'coordarm.generated.link_variants', 'subprocess', 'grp', 'shlex', 'tempfile',
                   # zstandard's version for the build metadata is remembered (an lz4 log does not load it)
                   'zstandard',
                   # a planar run loads no spatial module (scene, obstacles, distances, views, the chain model,
                   # vectors), no dense law (the structured one runs), no path (a line's scenario), no RK4 in
                   # CasADi (the compiled law steps)
                   'coordarm.simulation.scene3d', 'coordarm.simulation.obstacles3d', 'coordarm.simulation.distance3d',
                   'coordarm.simulation.spatial_view', 'coordarm.symbolic.spatial_chain', 'coordarm.symbolic.vectors3d',
                   'coordarm.symbolic.dense', 'coordarm.symbolic.paths', 'coordarm.symbolic.path_pieces',
                   'coordarm.symbolic.transitions', 'coordarm.symbolic.integrator',
                   # SHA-256 by the interpreter's own code, without OpenSSL (~3 ms); ArrayLike for annotations only
                   '_hashlib', 'numpy.typing')


def test_a_run_imports_no_module_it_does_not_use(tmp_path):
    """A cache-hit ``coordarm run --no-figures`` without --live: no live view, no psutil, no matplotlib,
    no other command's module, no numpy.ma (~10 ms to import; ``np.unique`` loads it), no fractions, no
    mcap.writer or importlib.metadata (~25 ms), for a planar chain none of the spatial scenario, 3-D
    curve and spatial code-generation modules, and none of :data:`UNUSED_BY_A_RUN`. The first run fills
    the caches (library, its recipe once the checkout's files are settled, the versions); the second is measured."""
    from coordarm.generated import code_identity
    from coordarm.generated.source_memo import CODE_FOLDERS

    root = Path(code_identity.__file__).resolve().parent.parent
    if not code_identity.files_key(code_identity.package_files(root, CODE_FOLDERS, "", True))[1]:
        time.sleep(code_identity.SETTLE_SECONDS)          # files just written: their recipe is not remembered yet
    code = ("import sys; from coordarm.cli import main; "
            "main(['run', 'line', '--links', '4', '--duration', '0.002', '--no-figures', '--quiet', '--overwrite', "
            "'--out', sys.argv[1]]); "
            f"print(sorted(m for m in {UNUSED_BY_A_RUN!r} if m in sys.modules))")
    for _ in range(2):
        res = subprocess.run([sys.executable, "-c", code, f"{tmp_path}/x.mcap"], capture_output=True, text=True,
                             timeout=300)
        assert res.returncode == 0, res.stderr
    assert res.stdout.strip().splitlines()[-1] == "[]"


CONSOLE = """
import atexit, sys
class Witness:
    def __del__(self):
        print("teardown", flush=True)
witness = Witness()
if sys.argv[1] == "atexit":
    atexit.register(print, "atexit ran")
from coordarm.cli import console
console(sys.argv[2:])
"""


@pytest.mark.parametrize("cleanup", ["none", "atexit"])
def test_the_console_skips_the_teardown_only_when_nothing_is_registered_and_keeps_status_output_and_log(cleanup, tmp_path):
    """``coordarm`` (``console``) ends with ``os._exit`` when no atexit callback and no other thread is
    left: the interpreter's teardown (here a witness object's ``__del__``) does not run, yet every
    line is on standard output, the status is main's and the log is complete. With an atexit
    callback registered the usual exit runs it (and the teardown)."""
    from mcap.reader import make_reader

    log = tmp_path / "x.mcap"
    argv = [sys.executable, "-c", CONSOLE, cleanup, "run", "line", "--links", "4", "--duration", "0.05",
            "--no-figures", "--quiet", "--out", str(log)]
    res = subprocess.run(argv, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stdout.splitlines()[0].startswith("scenario") and f"log           {log}" in res.stdout
    assert ("teardown" in res.stdout) == ("atexit ran" in res.stdout) == (cleanup == "atexit")
    with open(log, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics.message_count > 50
    again = subprocess.run(argv, capture_output=True, text=True, timeout=300)        # exists: refused, status 2
    assert again.returncode == 2 and "exists" in again.stderr


LOGGING = """
import sys
class Witness:
    def __del__(self):
        print("teardown", flush=True)
witness = Witness()
if sys.argv[1] in ("logging", "handler"):
    import logging
    if sys.argv[1] == "handler":
        logging.getLogger("user").addHandler(logging.StreamHandler(sys.stdout))
from coordarm.cli import console
console(sys.argv[2:])
"""


@pytest.mark.parametrize("case", ["bar", "logging", "handler"])
def test_an_imported_logging_without_handlers_keeps_the_short_exit_and_a_handler_the_usual_one(case, tmp_path):
    """``import logging`` registers ``logging.shutdown`` with atexit (a caller or a library may import
    it): without a handler on any logger the console still ends with ``os._exit`` (no teardown),
    the progress bar and the summary complete; a handler on a logger keeps the usual exit (teardown)."""
    log = tmp_path / "x.mcap"
    res = subprocess.run([sys.executable, "-c", LOGGING, case, "run", "line", "--links", "4", "--duration", "0.05",
                          "--no-figures", "--out", str(log)], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert "100.0%" in res.stderr and f"log           {log}" in res.stdout
    assert ("teardown" in res.stdout) == (case == "handler")


def test_python_m_cprofile_of_the_command_still_writes_its_profile(tmp_path):
    """A profiler outlives the command (it writes after the module returns): then the usual exit."""
    import pstats

    out = tmp_path / "run.prof"
    res = subprocess.run([sys.executable, "-m", "cProfile", "-o", str(out), "-m", "coordarm", "run", "line", "--links", "4",
                          "--duration", "0.02", "--no-figures", "--quiet", "--out", str(tmp_path / "x.mcap")],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert any(name == "run_scenario" for _, _, name in pstats.Stats(str(out)).stats)



BLAS = """
import json, os, sys
seen = {}
class Witness:
    # records OPENBLAS_NUM_THREADS when numpy is first imported: OpenBLAS reads it as numpy loads it
    def find_spec(self, name, path=None, target=None):
        if name == "numpy" and "at numpy import" not in seen:
            seen["at numpy import"] = os.environ.get("OPENBLAS_NUM_THREADS")
        return None
sys.meta_path.insert(0, Witness())
import atexit
atexit.register(lambda: print(json.dumps(seen), flush=True))
from coordarm.cli import console
console(["run", "line", "--links", "4", "--duration", "0.002", "--no-figures", "--quiet", "--out", sys.argv[1]])
"""


@pytest.mark.parametrize("preset", [None, "2"])
def test_the_console_runs_numpy_on_one_blas_thread_unless_the_environment_says_otherwise(preset, tmp_path):
    """Small matrices on a shared machine: ``OPENBLAS_NUM_THREADS`` is 1 when numpy loads (an import hook
    reads it at that moment), unless the user's environment sets it."""
    import os

    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if preset:
        env["OPENBLAS_NUM_THREADS"] = preset
    res = subprocess.run([sys.executable, "-c", BLAS, str(tmp_path / "x.mcap")], capture_output=True, text=True,
                         timeout=300, env=env)
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout.strip().splitlines()[-1]) == {"at numpy import": preset or "1"}
