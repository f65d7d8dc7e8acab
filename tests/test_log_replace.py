"""A log that replaces a file: the rename is the same atomic step whether the old file's storage is freed
at once or on a background thread (``free_replaced_later``, what ``coordarm run`` asks for)."""
import os
import threading

import pytest

import coordarm
from coordarm.simulation.file_replace import exchange, replace, wait_released
from coordarm.simulation.mcap_file import McapFile, open_locked

from test_session import read_log


def _open_fds() -> set[str]:
    return set(os.listdir("/proc/self/fd"))


def _releasing() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "coordarm-release"]


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
@pytest.mark.parametrize("old", [b"old log " * 100_000, None])
def test_a_replace_freeing_later_renames_at_once_and_frees_the_old_file_on_a_thread(tmp_path, old):
    src, dst = tmp_path / "new.partial", tmp_path / "new"
    src.write_bytes(b"new log")
    if old is not None:
        dst.write_bytes(old)
        inode = os.stat(dst).st_ino
    before = _open_fds()
    replace(src, dst, free_later=True)
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
        replace(tmp_path / "missing", dst, free_later=True)
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


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
@pytest.mark.parametrize("later", [False, True])
def test_a_regular_file_is_swapped_in_then_its_old_name_removed_with_no_rename_over_it(tmp_path, monkeypatch, later):
    """On Linux the new log is swapped with the old one (no ``os.replace``, whose rename over a file makes
    ext4 write the new one out first); the old file is unlinked and freed with its last descriptor."""
    src, dst = tmp_path / "new.partial", tmp_path / "new"
    src.write_bytes(b"new log")
    dst.write_bytes(b"old log " * 10_000)
    new_inode = os.stat(src).st_ino
    held = os.open(dst, os.O_RDONLY)                 # our own view of the old file
    if exchange_supported(tmp_path):
        def no_rename(*args):
            raise AssertionError("os.replace called although the swap works here")
        monkeypatch.setattr(os, "replace", no_rename)
    before = _open_fds()
    try:
        replace(src, dst, free_later=later)
        assert dst.read_bytes() == b"new log" and os.stat(dst).st_ino == new_inode and not src.exists()
        assert os.fstat(held).st_nlink == 0 and os.pread(held, 7, 0) == b"old log"   # unlinked, still readable
        wait_released()
        assert _releasing() == [] and _open_fds() == before
    finally:
        os.close(held)


def test_a_new_log_is_not_truncated_and_a_left_over_one_is_emptied(tmp_path, monkeypatch):
    """A new file is opened as it is (a truncation makes ext4 write the whole log out when it is closed); the
    partial file a killed run left behind is emptied under the lock before anything is written."""
    left = tmp_path / "left.partial"
    left.write_bytes(b"a killed run's records " * 1000)
    with open_locked(left) as f:
        assert os.fstat(f.fileno()).st_size == 0
        f.write(b"new")
    assert left.read_bytes() == b"new"

    def no_truncate(*args):
        raise AssertionError("a new, empty file truncated")
    monkeypatch.setattr(os, "ftruncate", no_truncate)
    with open_locked(tmp_path / "new.partial") as f:
        f.write(b"new")
    assert (tmp_path / "new.partial").read_bytes() == b"new"


def exchange_supported(folder) -> bool:
    """Whether ``renameat2(RENAME_EXCHANGE)`` swaps two files in ``folder`` (checked on two files of its own)."""
    a, b = folder / "probe_a", folder / "probe_b"
    a.write_bytes(b"a")
    b.write_bytes(b"b")
    try:
        return exchange(a, b) and a.read_bytes() == b"b" and b.read_bytes() == b"a"
    finally:
        a.unlink()
        b.unlink()


@pytest.mark.parametrize("later", [False, True])
def test_a_directory_or_a_symbolic_link_at_the_name_is_treated_as_os_replace_treats_it(tmp_path, later):
    src = tmp_path / "new.partial"
    src.write_bytes(b"new log")
    folder = tmp_path / "folder"
    folder.mkdir()
    with pytest.raises(IsADirectoryError):
        replace(src, folder, free_later=later)
    assert folder.is_dir() and src.read_bytes() == b"new log"
    target, link = tmp_path / "target", tmp_path / "link"
    target.write_bytes(b"the link's target")
    link.symlink_to(target)
    replace(src, link, free_later=later)                 # the link itself is replaced, not its target
    wait_released()
    assert not link.is_symlink() and link.read_bytes() == b"new log" and target.read_bytes() == b"the link's target"


def test_without_the_swap_a_replace_is_os_replace(tmp_path, monkeypatch):
    import coordarm.simulation.file_replace as file_replace

    monkeypatch.setattr(file_replace, "_renameat2", lambda: None)     # a system without renameat2
    src, dst = tmp_path / "new.partial", tmp_path / "new"
    src.write_bytes(b"new log")
    dst.write_bytes(b"old log")
    assert not exchange(src, dst)
    replace(src, dst)
    assert dst.read_bytes() == b"new log" and not src.exists()
