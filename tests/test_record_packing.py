"""The log's per-step records packed by the C kernel (simulation.record_packing) against the numpy path, byte for
byte: planar and spatial chains, with and without a rail, sequence numbers across 2^32, thinned rows, and a
whole log written either way."""
import numpy as np
import pytest

from coordarm.simulation import record_packing
from coordarm.simulation.log_schemas import PER_STEP
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario
from coordarm.simulation.session import run_scenario

pytestmark = pytest.mark.skipif(record_packing.packing_kernel() is None, reason="no working C compiler")


def numpy_path(monkeypatch):
    """Make the packer take its numpy path (as without a C compiler)."""
    monkeypatch.setattr(record_packing, "packing_kernel", lambda: None)


def block(preset, steps=300):
    """A logger's packer and sample dtype, and one block of a short run of ``preset``."""
    sc = load_scenario(preset)
    ctrl = sc.controller()
    parts = []
    simulate(ctrl, sc.start(ctrl), steps * sc.step, sc.step, sc.t0, backend="compiled", on_chunk=parts.append)
    return sc, ctrl, parts[0]


def packed(packer, part, rows, sequences, times):
    out = np.zeros(len(part.t[rows]), packer.dtype)
    packer.pack(out, part, rows, sequences, times)
    return out.tobytes()


@pytest.mark.parametrize("preset", ["line", "thread", "path3d", "pipe3d"])
def test_the_kernel_packs_the_numpy_paths_bytes(preset, tmp_path, monkeypatch):
    sc, ctrl, part = block(preset)
    with RunLogger(tmp_path / "a.mcap", sc, ctrl, command=["test"], threaded=False) as log:
        packer = record_packing.RecordPacker(log.sample_dtype, log.channels, PER_STEP)
    n = len(part.t)
    times = np.arange(n, dtype=np.uint64) * np.uint64(1_000_000) + np.uint64(7)
    for rows, sequences in ((slice(0, n), [0, 5, 9]), (slice(3, n - 1), [2**32 - 4, 2**32 - 1, 2**32 + 17])):
        count = len(part.t[rows])
        kernel = packed(packer, part, rows, sequences, times[:count])
        with monkeypatch.context() as m:
            numpy_path(m)
            assert kernel == packed(packer, part, rows, sequences, times[:count])
        heads = np.frombuffer(kernel, packer.dtype)[PER_STEP[1] + "_hdr"]
        assert heads["sequence"].tolist() == [(sequences[1] + k) % 2**32 for k in range(count)]   # wraps at 2^32
        assert (heads["log_time"] == times[:count]).all() and (heads["publish_time"] == times[:count]).all()
    fields = np.frombuffer(packed(packer, part, slice(0, n), [0, 0, 0], times), packer.dtype)
    np.testing.assert_array_equal(fields["joint_state"][:, 1:1 + part.q.shape[1]], part.q)   # q after t, as written


def test_thinned_rows_take_the_numpy_path_with_the_same_bytes(tmp_path, monkeypatch):
    sc, ctrl, part = block("line")
    with RunLogger(tmp_path / "a.mcap", sc, ctrl, command=["test"], threaded=False) as log:
        packer = record_packing.RecordPacker(log.sample_dtype, log.channels, PER_STEP)
    rows = np.array([0, 2, 5, 11, 200])
    times = np.arange(len(rows), dtype=np.uint64)
    got = packed(packer, part, rows, [1, 2, 3], times)
    numpy_path(monkeypatch)
    assert got == packed(packer, part, rows, [1, 2, 3], times)


def test_a_log_packed_by_the_kernel_holds_the_messages_of_one_packed_by_numpy(tmp_path, monkeypatch):
    from mcap.reader import make_reader
    run_scenario("line", duration=2.0, log=tmp_path / "kernel.mcap", figures=False)
    numpy_path(monkeypatch)
    run_scenario("line", duration=2.0, log=tmp_path / "numpy.mcap", figures=False)
    with open(tmp_path / "kernel.mcap", "rb") as a, open(tmp_path / "numpy.mcap", "rb") as b:
        got = [(c.topic, m.sequence, m.log_time, m.data) for _, c, m in make_reader(a).iter_messages()]
        want = [(c.topic, m.sequence, m.log_time, m.data) for _, c, m in make_reader(b).iter_messages()]
    assert len(got) > 6000 and got == want
