"""Property-based fault injection for the newer surfaces (issue 25): spatial scenarios with 3-D obstacles,
and the arguments of ``sweep``, ``export``, ``compare`` and ``run --live``.

Each case ends in a correct result or one clear line (exit 2), never a traceback or a hang.
``COORDARM_FUZZ_EXAMPLES`` scales the cases (the argument cases, which may run a command, are 1/20 of it).
"""
import contextlib
import re
from importlib import resources

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from test_fuzz import EXAMPLES, FUZZ, NUMBERS, _clear, _written, mutated_toml

from coordarm.cli import main
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic import ConfigError, NonFiniteError, SingularityError

OBSTACLES_3D = """
[[obstacles]]
kind = "sphere"
centre = [0.3, 1.5, 0.0]
radius = 0.2
[[obstacles]]
name = "casing"
kind = "plate"
point = [5.0, 0.0, 0.0]
normal = [1.0, 0.0, 0.0]
thickness = 0.02
extent = 1.0
holes = [ { centre = [5.0, 0.0, 0.0], radius = 0.3 }, { centre = [5.0, 0.5, 0.5], size = [0.2, 0.1] } ]
[[obstacles]]
kind = "cylinder"
a = [0.0, -1.0, -1.0]
b = [1.0, -1.0, -1.0]
radius = 0.05
[[obstacles]]
kind = "box"
centre = [0.0, 0.0, 2.0]
size = [0.4, 0.2, 0.1]
rotation = { axis = [0.0, 0.0, 1.0], angle = 0.3 }
"""
#: The spatial presets with 6 links (joints, 3-D curves, roll), each also with 3-D obstacles.
SPATIAL = [re.sub(r"links = \d+", "links = 6", (resources.files("coordarm.simulation") / "presets" / f"{p}.toml")
                  .read_text()) for p in ("line3d", "path3d")]
SPATIAL += [text + OBSTACLES_3D for text in SPATIAL]


@FUZZ
@given(text=mutated_toml(SPATIAL))
def test_a_mutated_spatial_scenario_loads_and_runs_or_is_one_clear_error(text, tmp_path_factory):
    path = _written(text, tmp_path_factory)
    try:
        sc = load_scenario(path)
    except ConfigError as exc:
        _clear(exc, path)
        return
    if sc.spec["chain"]["links"] > 8:
        return
    try:
        ctrl = sc.controller()
        q0 = sc.start(ctrl)
        run = simulate(ctrl, q0, min(sc.duration, 10 * sc.step), sc.step, sc.t0, backend="interpreted",
                       thresholds=sc.thresholds)
    except (ConfigError, SingularityError, NonFiniteError) as exc:   # a diverging state is said so
        _clear(exc)
        return
    assert np.all(np.isfinite(run.q)) and np.all(np.diff(run.t) > 0)


#: Values tried in place of an argument's (numbers, words, paths, nothing).
VALUES = NUMBERS + ["", " ", "-", "--", "x" * 300, "a=b", "links=", "=1", "links=1:2:0", "links=1:2:3:4",
                    "speed=1,,2", "control.nothing=1", "links=4:8:1000000000", "/dev/null", "/proc/x/y", ".",
                    "coordinating,coordinating", "pinv,nope", "interpreted", "compiled", "-5", "65536", "0",
                    "1e-300", "8765", "tcp://127.0.0.1:1", "serial"]


def _cases(out: str) -> dict[str, tuple[list[str], list[str]]]:
    """Per command: a cheap valid argv, and the flags whose values are fuzzed."""
    return {
        "sweep": (["sweep", "line", "--vary", "duration=0.01", "--vary", "links=4", "--out", out + "/sw",
                   "--quiet", "--no-figures", "--scheduler", "serial"],
                  ["--vary", "--samples", "--random", "--out", "--batch", "--workers", "--scheduler"]),
        "export": (["export", "line", "--links", "4", "--out", out + "/law", "--overwrite"],
                   ["--links", "--duration", "--step", "--out"]),
        "compare": (["compare", "line", "--duration", "0.02", "--methods", "coordinating",
                     "--backend", "interpreted", "--out", out + "/cmp"],
                    ["--methods", "--duration", "--backend", "--out"]),
        "live": (["run", "line", "--links", "4", "--duration", "0.02", "--quiet", "--no-figures", "--live",
                  "--port", "0", "--out", out + "/live.mcap", "--overwrite"],
                 ["--port", "--live-speed", "--duration", "--links"]),
    }


@settings(FUZZ, max_examples=max(10, EXAMPLES // 20))
@given(data=st.data())
def test_bad_arguments_of_the_newer_commands_are_one_line_naming_the_flag(data, tmp_path_factory, capsys):
    out = str(tmp_path_factory.mktemp("args", numbered=True))
    command = data.draw(st.sampled_from(sorted(_cases(out))))
    argv, flags = _cases(out)[command]
    argv = list(argv)
    for _ in range(data.draw(st.integers(1, 2))):
        flag, value = data.draw(st.sampled_from(flags)), data.draw(st.sampled_from(VALUES))
        if flag in argv and data.draw(st.booleans()):
            argv[argv.index(flag) + 1] = value          # replace the valid value
        else:
            argv += [flag, value]                       # or add the flag (repeated flags: the last wins)
    capsys.readouterr()
    try:
        with contextlib.chdir(out):     # a fuzzed relative --out lands in the case's own directory
            status = main(argv)
    except SystemExit as exc:       # argparse: usage, then one "error:" line naming the argument
        status = exc.code
    err = capsys.readouterr().err
    assert "Traceback" not in err, (argv, err)
    assert status in (0, 2, 3, 4), (argv, status, err)
    if status == 2:
        lines = [ln for ln in err.splitlines() if ": error: " in ln]
        assert len(lines) == 1 and len(lines[0]) < 1000, (argv, err)
