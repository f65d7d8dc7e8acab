"""The compiler's --version, remembered per executable in the build cache: asked again when it changes."""
import json
import os
import shutil
import subprocess

import pytest

from coordarm.generated import build as build_mod
from coordarm.generated.compiler_memo import MEMO, MEMO_ENTRIES, compiler_identity, compiler_version


class Asker:
    """Counts the compiler runs; answers a fixed text per path."""

    def __init__(self):
        self.calls = []

    def __call__(self, path):
        self.calls.append(path)
        return f"version of {path} #{len(self.calls)}"


@pytest.fixture
def binary(tmp_path):
    """A copy of a real executable (not a script), whose metadata the test may change."""
    path = tmp_path / "bin" / "cc"
    path.parent.mkdir()
    shutil.copy2(shutil.which("true"), path)
    return str(path)


def test_an_unchanged_executable_is_asked_once_a_changed_one_again(tmp_path, binary):
    ask, memo = Asker(), tmp_path / "cache"
    memo.mkdir()
    first = compiler_version(binary, ask, memo)
    assert compiler_version(binary, ask, memo) == first and ask.calls == [binary]
    assert json.loads((memo / MEMO).read_text()) == {compiler_identity(binary): first}
    st = os.stat(binary)
    os.utime(binary, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))           # upgraded in place
    assert compiler_version(binary, ask, memo) != first and len(ask.calls) == 2
    replaced = binary + ".new"                                                # switched: another file
    shutil.copy2(binary, replaced)
    os.replace(replaced, binary)
    compiler_version(binary, ask, memo)
    assert len(ask.calls) == 3
    link = tmp_path / "bin" / "gcc"                                          # another name, same file
    link.symlink_to(binary)
    compiler_version(str(link), ask, memo)
    assert len(ask.calls) == 4 and len(json.loads((memo / MEMO).read_text())) == 4


def test_scripts_unreadable_memos_and_no_memo_directory_ask_every_time(tmp_path, binary):
    ask, memo = Asker(), tmp_path / "cache"
    memo.mkdir()
    script = tmp_path / "bin" / "wrapper"
    script.write_text("#!/bin/sh\nexec gcc \"$@\"\n")
    for _ in range(2):
        compiler_version(str(script), ask, memo)
        compiler_version(binary, ask, None)
    assert ask.calls == [str(script), binary] * 2 and not (memo / MEMO).exists()
    (memo / MEMO).write_text("[not json")
    assert compiler_version(binary, ask, memo) == "version of %s #5" % binary
    assert compiler_version(binary, ask, memo) == "version of %s #5" % binary and len(ask.calls) == 5
    (memo / MEMO).write_text('["a list"]')
    compiler_version(binary, ask, memo)
    assert len(ask.calls) == 6


def test_the_memo_keeps_the_most_recently_asked_executables(tmp_path, binary):
    ask, memo = Asker(), tmp_path / "cache"
    memo.mkdir()
    names = []
    for k in range(MEMO_ENTRIES + 3):
        name = tmp_path / "bin" / f"cc{k}"
        shutil.copy2(binary, name)
        names.append(str(name))
        compiler_version(str(name), ask, memo)
    kept = json.loads((memo / MEMO).read_text())
    assert len(kept) == MEMO_ENTRIES and compiler_identity(names[-1]) in kept and compiler_identity(names[0]) not in kept


def test_a_read_only_cache_still_answers(tmp_path, binary, monkeypatch):
    from coordarm.generated import compiler_memo

    def refuse(path, data):
        raise PermissionError(13, "Permission denied", str(path))
    monkeypatch.setattr(compiler_memo, "write_atomic", refuse)
    ask, memo = Asker(), tmp_path / "cache"
    memo.mkdir()
    assert compiler_version(binary, ask, memo) == f"version of {binary} #1"
    assert compiler_version(binary, ask, memo) == f"version of {binary} #2" and not (memo / MEMO).exists()


def test_the_cache_key_is_the_same_with_the_memo_and_a_cache_hit_runs_no_process(tmp_path, monkeypatch):
    """The real compiler: the memoised version is its --version, so every key (and every cached library
    built before the memo) stays the same; once remembered, a cache hit runs no compiler."""
    from coordarm.generated.codegen import generate_source
    from coordarm.symbolic import CoordinatingController, Line, PlanarChain

    src = generate_source(CoordinatingController(PlanarChain(3, 0.1), Line(), 1.0, 0.1))
    cc = build_mod.find_compiler()
    direct = subprocess.run([cc, "--version"], capture_output=True, text=True, check=True).stdout.strip()
    build_mod._compiler_version.cache_clear()
    lib = build_mod.build(src, build_dir=tmp_path)
    root = build_mod.private_root(tmp_path)
    assert json.loads((root / MEMO).read_text()) == {compiler_identity(cc): direct}
    assert lib.key == build_mod.cache_key(src, cc, build_mod.compile_flags())        # no memo: asked
    build_mod._compiler_version.cache_clear()

    def no_process(*args, **kwargs):
        raise AssertionError("a cache hit ran the compiler")
    monkeypatch.setattr(build_mod, "_run_compiler", no_process)
    again = build_mod.build(src, build_dir=tmp_path)
    assert again.cache_hit and again.key == lib.key


def test_clean_forgets_the_versions_but_not_a_link_named_like_the_memo(tmp_path, binary):
    root = tmp_path / "cache"
    root.mkdir(mode=0o700)
    compiler_version(binary, Asker(), root)
    assert (root / MEMO).is_file()
    build_mod.clean(root)
    assert not (root / MEMO).exists()
    target = tmp_path / "users-file.json"
    target.write_text("{}")
    (root / MEMO).symlink_to(target)
    build_mod.clean(root)
    assert (root / MEMO).is_symlink() and target.read_text() == "{}"
