"""The one table of the law's packed outputs agrees with the CasADi law, the C library and the log."""
import numpy as np
import pytest

from coordarm.generated.codegen import generate_source, layout_macros
from coordarm.simulation import log_schemas
from coordarm.simulation.run import ARRAYS, Run, simulate
from coordarm.symbolic import CoordinatingController, Line, PlanarChain
from coordarm.symbolic.outputs import LAW_OUTPUTS, OUTPUTS, RUN_OUTPUTS, Output, offsets, packed_width, split


@pytest.mark.parametrize("m", [2, 3, 7])
def test_table_widths_and_names_are_those_of_the_casadi_law(m):
    ctrl = CoordinatingController(PlanarChain(m, 0.1), Line((0.0, 0.0), 0.0), 2.0, 0.05)
    for form in ("structured", "dense"):
        law = ctrl.law(form)
        assert [law.name_out(i) for i in range(law.n_out())] == list(OUTPUTS)
        assert [law.numel_out(i) for i in range(law.n_out())] == [o.width(m) for o in LAW_OUTPUTS]
    assert packed_width(m) == sum(ctrl.law().numel_out(i) for i in range(len(OUTPUTS))) == 3 * m + 1
    step = ctrl.rk4_step(0.01)
    assert [step.name_out(i) for i in range(step.n_out())] == ["q_next", *RUN_OUTPUTS]


def test_offsets_tile_the_packed_vector_and_split_inverts_packing():
    m = 5
    spans = list(offsets(m).values())
    assert spans[0][0] == 0 and all(a[0] + a[1] == b[0] for a, b in zip(spans, spans[1:]))
    assert spans[-1][0] + spans[-1][1] == packed_width(m)
    rng = np.random.default_rng(3)
    parts = {o.name: rng.standard_normal(o.width(m)) for o in LAW_OUTPUTS}
    packed = np.concatenate([parts[n] for n in OUTPUTS])
    back = split(packed, m)
    for o in LAW_OUTPUTS:
        assert np.array_equal(np.atleast_1d(back[o.name]), parts[o.name])
        assert isinstance(back[o.name], float) == o.scalar
    block = split(np.vstack([packed, 2 * packed]), m)
    assert block["s"].shape == (2,) and block["e"].shape == (2, m - 1)
    with pytest.raises(ValueError, match="expected"):
        split(packed[:-1], m)


def test_the_c_source_takes_its_offsets_from_the_table():
    m = 4
    macros = layout_macros(m)
    for name, (start, _) in offsets(m).items():
        assert f"#define CA_OUT_{name.upper()} {start}\n" in macros
    ctrl = CoordinatingController(PlanarChain(m, 0.1), Line((0.0, 0.0), 0.0), 2.0, 0.05)
    for form in ("structured", "dense"):
        text = generate_source(ctrl, form).text
        assert f"#define CA_NOUT {packed_width(m)}" in text and "3 * CA_M" not in text


def test_log_fields_are_the_run_arrays_named_as_in_the_table():
    chans = log_schemas.numeric_channels(6)
    logged = {name for key in log_schemas.PER_STEP for name, _ in chans[key].fields}
    assert logged == set(ARRAYS)
    assert chans["margins"].fields == (("t", 0), ("link_margins", 5), ("longitudinal", 0))
    for o in LAW_OUTPUTS:
        if o.channel:
            assert (o.name, 0 if o.scalar else o.width(6)) in chans[o.channel].fields


def test_a_new_table_row_with_a_channel_is_appended_to_that_channel_and_kept_by_run(monkeypatch):
    extra = Output("v_scale", 0, 1, "-", "task_state", "speed governor scale")
    monkeypatch.setattr(log_schemas, "LAW_OUTPUTS", LAW_OUTPUTS + (extra,))
    monkeypatch.setattr(log_schemas, "by_name", lambda n: extra if n == "v_scale" else
                        {o.name: o for o in LAW_OUTPUTS}[n])
    task = log_schemas.numeric_channels(4)["task_state"]
    assert task.fields[-1] == ("v_scale", 0) and task.slices()["v_scale"] == task.width - 1
    arrays = {a: np.zeros(3) for a in ARRAYS}
    run = Run.from_arrays(dict(arrays, v_scale=np.ones(3)))
    assert not hasattr(run, "v_scale")            # not a run output of the real table
    run = Run(**{a: arrays[a] for a in ARRAYS}, extra={"v_scale": np.ones(3)})
    assert np.array_equal(run.v_scale, np.ones(3))


def test_a_log_written_before_the_link_margins_rename_is_read_by_position():
    """``tests/data/line_before_link_margins_rename.mcap``: 4 links, 0.01 s of the line preset, written by
    coordarm 0.1.0 whose /margins field was called ``link``; its margins equal the law's at the logged states."""
    from pathlib import Path

    from coordarm.analysis.replay import load

    path = Path(__file__).parent / "data" / "line_before_link_margins_rename.mcap"
    with open(path, "rb") as f:
        assert b"float64[3] link\n" in f.read()          # the old field name in the stored schema
    rep = load(path)
    assert rep.outcome["status"] == "completed" and not rep.problems and len(rep.t) == 11
    ctrl = rep.controller()
    for k in range(len(rep.t)):
        out = ctrl.evaluate(rep.q[k], rep.t[k])
        np.testing.assert_allclose(rep.link_margins[k], out["link_margins"], rtol=1e-12)
        assert rep.longitudinal[k] == pytest.approx(out["longitudinal"], rel=1e-12)


def test_a_field_added_after_a_log_was_written_reads_as_nan_and_is_reported(monkeypatch):
    """Replay decodes each channel by the schema stored in the file, so a log from before a new
    output (here a made-up ``v_scale`` on /task_state) still loads, the new field NaN."""
    from pathlib import Path

    from coordarm.analysis import replay
    from coordarm.simulation.log_schemas import NumericChannel

    real = replay.numeric_channels

    def with_v_scale(m):
        chans = real(m)
        ts = chans["task_state"]
        chans["task_state"] = NumericChannel(ts.topic, ts.schema_name, ts.fields + (("v_scale", 0),))
        return chans

    monkeypatch.setattr(replay, "numeric_channels", with_v_scale)
    rep = replay.load(Path(__file__).parent / "data" / "line_before_link_margins_rename.mcap")
    assert rep.v_scale.shape == (11,) and np.isnan(rep.v_scale).all()
    assert any("v_scale" in p and "NaN" in p for p in rep.problems)
    assert np.isfinite(rep.e).all() and np.isfinite(rep.link_margins).all()


def test_stored_schemas_parse_back_to_the_channel_fields():
    for ch in log_schemas.numeric_channels(5).values():
        assert log_schemas.fields_from_schema(ch.schema_text()) == ch.fields
    assert log_schemas.fields_from_schema("float64 t\nfloat64[4] link\n") == (("t", 0), ("link_margins", 4))
    with pytest.raises(ValueError, match="int32"):
        log_schemas.fields_from_schema("float64 t\nint32 n\n")


def test_a_new_output_row_is_logged_and_read_back_with_no_other_change(monkeypatch, tmp_path):
    """End to end through the real writer and reader: a made-up output row ``v_scale`` on /task_state
    (its values carried by the Run) lands in the log's schema and messages and comes back from replay."""
    from coordarm.analysis.replay import load
    from coordarm.simulation.mcap_writer import RunLogger
    from coordarm.simulation.scenario import load_scenario

    extra = Output("v_scale", 0, 1, "-", "task_state", "speed governor scale")
    table = {o.name: o for o in LAW_OUTPUTS + (extra,)}
    monkeypatch.setattr(log_schemas, "LAW_OUTPUTS", LAW_OUTPUTS + (extra,))
    monkeypatch.setattr(log_schemas, "by_name", table.__getitem__)
    sc = load_scenario("line").with_overrides(links=5, duration=0.02)
    ctrl = sc.controller()
    run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, backend="interpreted")
    v_scale = np.linspace(1.0, 0.5, len(run.t))
    run = Run.from_arrays({a: getattr(run, a) for a in ARRAYS}, run.info)
    run.extra["v_scale"] = v_scale
    path = tmp_path / "v.mcap"
    with RunLogger(path, sc, ctrl) as log:
        log.on_chunk(run)
    with open(path, "rb") as f:
        assert b"float64 v_scale\n" in f.read()
    rep = load(path)
    assert not rep.problems
    np.testing.assert_array_equal(rep.v_scale, v_scale)
    np.testing.assert_array_equal(rep.e, run.e)
