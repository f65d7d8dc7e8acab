"""A log that replaces a file: the rename is the same atomic step whether the old file's storage is freed
at once or on a background thread (``free_replaced_later``, what ``coordarm run`` asks for)."""
import os
import threading

import pytest

import coordarm
from coordarm.simulation.mcap_file import McapFile, replace_in_background, wait_released

from test_session import read_log


def _open_fds() -> set[str]:
    return set(os.listdir("/proc/self/fd"))


def _releasing() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "coordarm-release"]


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
@pytest.mark.parametrize("old", [b"old log " * 100_000, None])
def test_replace_in_background_renames_at_once_and_frees_the_old_file_on_a_thread(tmp_path, old):
    src, dst = tmp_path / "new.partial", tmp_path / "new"
    src.write_bytes(b"new log")
    if old is not None:
        dst.write_bytes(old)
        inode = os.stat(dst).st_ino
    before = _open_fds()
    replace_in_background(src, dst)
    assert dst.read_bytes() == b"new log" and not src.exists()      # renamed before the call returns
    if old is not None:
        assert os.stat(dst).st_ino != inode
    wait_released()
    assert _releasing() == [] and _open_fds() == before             # the old file's descriptor is closed


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
def test_a_failed_replace_raises_like_os_replace_and_keeps_the_old_file_and_no_descriptor(tmp_path):
    dst = tmp_path / "kept"
    dst.write_bytes(b"keep me")
    before = _open_fds()
    with pytest.raises(FileNotFoundError):
        replace_in_background(tmp_path / "missing", dst)
    assert dst.read_bytes() == b"keep me" and _open_fds() == before and _releasing() == []


@pytest.mark.parametrize("later", [False, True])
def test_a_closed_mcap_file_replacing_a_log_is_the_same_file_either_way(tmp_path, later):
    out = tmp_path / f"x{later}.mcap"
    out.write_bytes(b"an older log")
    f = McapFile(tmp_path / "x.partial.mcap")
    f.add_metadata("note", {"k": "v"})
    f.close(rename_to=out, free_replaced_later=later)
    wait_released()
    assert out.read_bytes().startswith(b"\x89MCAP0\r\n") and not (tmp_path / "x.partial.mcap").exists()
    assert f.path == out and _releasing() == []


def test_run_scenario_over_an_existing_log_leaves_the_new_log_and_no_thread(tmp_path):
    log = tmp_path / "again.mcap"
    first = coordarm.run_scenario("line", links=4, duration=0.05, log=log, figures=False)
    size = log.stat().st_size
    second = coordarm.run_scenario("line", links=4, duration=0.1, log=log, overwrite=True, figures=False)
    meta, states = read_log(log)
    assert first.exit_status == second.exit_status == 0 and log.stat().st_size > size
    assert abs(states[-1][0] - 0.1) < 1e-9 and meta["outcome"]["status"] == '"completed"'
    assert _releasing() == []
