"""Property-based fault injection: mutated scenario TOML and damaged MCAP logs.

Each case ends in a clear error (ConfigError / LogError, one line) or a correct result, never
another exception or a hang. ``COORDARM_FUZZ_EXAMPLES`` sets the cases per test (default 200;
e.g. ``COORDARM_FUZZ_EXAMPLES=5000 make test`` for a long run).
"""
import os
import re
import tomllib
from importlib import resources

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from coordarm.analysis.replay import load
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario, presets
from coordarm.symbolic import ConfigError, LogError, NonFiniteError, SingularityError

EXAMPLES = int(os.environ.get("COORDARM_FUZZ_EXAMPLES", "200"))
FUZZ = settings(max_examples=EXAMPLES, deadline=20_000, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                       HealthCheck.data_too_large])

#: The presets with 6 links (so that valid mutants are cheap to build and run).
BASES = [re.sub(r"links = \d+", "links = 6",
                (resources.files("coordarm.simulation") / "presets" / f"{p}.toml").read_text()) for p in presets()]
NUMBERS = ["1e308", "-1e308", "inf", "-inf", "nan", "0", "-0.0", "5e-324", "1e-300", "99999999999999999999",
           "-1", "1e6", "2800.0", '"x"', "[]", "{}", "true", '"' + "y" * 500 + '"']


def _clear(exc: Exception, path=None) -> None:
    """A clear error: one line, not huge, naming the file if given."""
    text = str(exc)
    assert "\n" not in text and len(text) < 1000, text
    assert path is None or str(path) in text, text


@st.composite
def mutated_toml(draw, bases: list[str] = BASES) -> str:
    text = draw(st.sampled_from(bases))
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["flip", "cut", "number", "nest", "dup", "delete"]))
        if op == "flip" and text:
            i = draw(st.integers(0, len(text) - 1))
            text = text[:i] + chr(ord(text[i]) ^ (1 << draw(st.integers(0, 6)))) + text[i + 1:]
        elif op == "cut":
            text = text[:draw(st.integers(0, len(text)))]
        elif op == "number":
            spans = [m.span() for m in re.finditer(r"-?\d+(\.\d+)?(e-?\d+)?", text)]
            if spans:
                a, b = draw(st.sampled_from(spans))
                text = text[:a] + draw(st.sampled_from(NUMBERS)) + text[b:]
        elif op == "nest":
            depth = draw(st.integers(1, 3000))
            text += f"\nextra = {'[' * depth}{']' * depth}\n"
        elif op == "dup":
            lines = text.splitlines()
            if lines:
                k = draw(st.integers(0, len(lines) - 1))
                text = "\n".join(lines[:k + 1] + [lines[k]] + lines[k + 1:])
        elif op == "delete":
            lines = text.splitlines()
            if lines:
                k = draw(st.integers(0, len(lines) - 1))
                text = "\n".join(lines[:k] + lines[k + 1:])
    return text


def _written(text: str, factory):
    path = factory.mktemp("toml", numbered=True) / "s.toml"
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    return path


@FUZZ
@given(text=mutated_toml())
def test_a_mutated_scenario_loads_or_is_one_config_error(text, tmp_path_factory):
    path = _written(text, tmp_path_factory)
    try:
        sc = load_scenario(path)
    except ConfigError as exc:
        _clear(exc, path)
        return
    # a correct result: what the file says, within bounds
    data = tomllib.loads(text)
    assert sc.spec["chain"]["links"] == data["chain"]["links"]
    assert 1e-6 <= sc.step <= 1.0 and abs(sc.t0) <= 1e6


@settings(FUZZ, max_examples=max(10, EXAMPLES // 8))
@given(text=mutated_toml())
def test_a_mutated_scenario_that_loads_runs_or_stops_clearly(text, tmp_path_factory):
    path = _written(text, tmp_path_factory)
    try:
        sc = load_scenario(path)
        if sc.spec["chain"]["links"] > 8 or sc.universal:     # runs of a spatial chain: test_spatial_scenario
            return
        ctrl = sc.controller()
        run = simulate(ctrl, sc.start(ctrl), min(sc.duration, 20 * sc.step), sc.step, sc.t0,
                       backend="interpreted", thresholds=sc.thresholds)
    except (ConfigError, SingularityError, NonFiniteError) as exc:   # a diverging state is said so
        _clear(exc)
        return
    assert np.all(np.isfinite(run.q)) and np.all(np.diff(run.t) > 0)


@pytest.fixture(scope="module")
def small_log(tmp_path_factory):
    sc = load_scenario("hole").with_overrides(links=4, duration=0.1)
    path = tmp_path_factory.mktemp("fuzzlog") / "hole.mcap"
    with RunLogger(path, sc, chunk_size=2048, command=["fuzz"]) as log:
        simulate(sc.controller(), sc.start(), sc.duration, sc.step, chunk=10, on_chunk=log.on_chunk)
    return path.read_bytes(), load(path)


@st.composite
def damage(draw, size: int):
    ops = []
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["flip", "cut", "garbage", "zero", "repeat"]))
        a = draw(st.integers(0, size - 1))
        ops.append((op, a, draw(st.integers(1, 64)), draw(st.integers(0, 7)), draw(st.binary(min_size=1, max_size=64))))
    return ops


def _apply(data: bytes, ops) -> bytes:
    buf = bytearray(data)
    for op, a, n, bit, junk in ops:
        a = min(a, max(0, len(buf) - 1))
        if op == "flip" and buf:
            buf[a] ^= 1 << bit
        elif op == "cut":
            del buf[a:]
        elif op == "garbage":
            buf[a:a + len(junk)] = junk
        elif op == "zero":
            buf[a:a + n] = bytes(len(buf[a:a + n]))
        elif op == "repeat":
            buf[a:a] = buf[a:a + n]
    return bytes(buf)


@FUZZ
@given(data=st.data())
def test_a_damaged_log_loads_what_is_intact_or_is_one_log_error(small_log, data, tmp_path_factory):
    raw, full = small_log
    ops = data.draw(damage(len(raw)))
    path = tmp_path_factory.mktemp("mcap", numbered=True) / "bad.mcap"
    path.write_bytes(_apply(raw, ops))
    try:
        rep = load(path)
    except LogError as exc:
        _clear(exc, path)
        return
    # a correct result: every sample kept is one of the run's own, in time order, all fields aligned
    n = len(rep.t)
    assert rep.q.shape == (n, 4) and rep.e.shape == (n, 3) and rep.link_margins.shape == (n, 3)
    assert np.all(np.diff(rep.t) > 0)
    rows = np.searchsorted(full.t, rep.t)
    assert np.all(rows < len(full.t)) and np.array_equal(full.t[rows], rep.t)
    intact = ~rep.damaged and not rep.problems
    if intact:
        np.testing.assert_array_equal(rep.q, full.q[rows])
