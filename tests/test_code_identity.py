"""Values remembered under the identity of files: the log's code hash and platform, the cache directory, the
one-off evaluation of the law at the start; each equal to what it replaces."""
import hashlib
import json
import os
import platform
import socket
from pathlib import Path

import numpy as np
import pytest

from coordarm.generated import code_identity
from coordarm.generated.cache_dir import user_cache_dir
from coordarm.generated.code_identity import sources_digest
from coordarm.generated.compiler_memo import DIGESTS
from coordarm.simulation.choices import presets
from coordarm.simulation.host import host_name, host_platform
from coordarm.simulation.mcap_writer import code_hash
from coordarm.simulation.scenario import load_scenario

ROOT = Path(code_hash.__code__.co_filename).resolve().parent.parent


def direct_code_hash(root: Path) -> str:
    """The log's code hash as it was computed before it was remembered: every file read."""
    digest = hashlib.sha256()
    for pkg in ("symbolic", "simulation"):
        for path in sorted((root / pkg).glob("*.py")):
            digest.update(f"{pkg}/{path.name}\0".encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def test_the_code_hash_equals_the_hash_of_every_file_remembered_or_not(monkeypatch):
    assert code_hash() == direct_code_hash(ROOT)
    monkeypatch.setattr(code_identity, "SETTLE_SECONDS", -1e9)
    assert code_hash() == code_hash() == direct_code_hash(ROOT)


def test_a_remembered_digest_reads_no_file_and_a_changed_file_is_read_again(tmp_path, monkeypatch, build_dir):
    monkeypatch.setattr(code_identity, "SETTLE_SECONDS", -1e9)
    for pkg in ("symbolic", "simulation"):
        (tmp_path / pkg).mkdir()
        (tmp_path / pkg / "a.py").write_text(f"# {pkg}\n")
    first = sources_digest(tmp_path, ("symbolic", "simulation"))
    assert first == direct_code_hash(tmp_path)
    assert any(k.startswith("sources ") for k in json.loads((build_dir / DIGESTS).read_text()))
    real_open = open
    monkeypatch.setattr("builtins.open", lambda *a, **k: pytest.fail(f"read {a[0]}") if str(a[0]).endswith(".py")
                        else real_open(*a, **k))
    assert sources_digest(tmp_path, ("symbolic", "simulation")) == first
    monkeypatch.setattr("builtins.open", real_open)
    new = tmp_path / "symbolic" / "a.new"
    new.write_text("# changed\n"[:len("# symbolic\n")].ljust(len("# symbolic\n")))
    os.replace(new, tmp_path / "symbolic" / "a.py")
    assert sources_digest(tmp_path, ("symbolic", "simulation")) == direct_code_hash(tmp_path) != first


def test_the_platform_and_host_are_those_the_standard_library_gives(monkeypatch):
    monkeypatch.setattr(code_identity, "SETTLE_SECONDS", -1e9)
    platform._platform_cache.clear()
    assert host_platform() == platform.platform()
    platform._platform_cache.clear()
    assert host_platform() == platform.platform()        # remembered this time
    assert host_name() == socket.gethostname()


@pytest.mark.parametrize("env", [{"XDG_CACHE_HOME": "/x/cache", "HOME": "/home/u"}, {"XDG_CACHE_HOME": "rel", "HOME": "/h/"},
                                 {"XDG_CACHE_HOME": "", "HOME": "/"}, {"HOME": "/home/u"}, {"HOME": "relative"}, {}])
def test_the_cache_directory_is_platformdirs_answer(env, monkeypatch):
    from platformdirs import user_cache_dir as platform_cache_dir

    for name in ("XDG_CACHE_HOME", "HOME"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    try:
        expected = platform_cache_dir("coordarm", appauthor=False)
    except RuntimeError as exc:               # no home: both refuse alike
        with pytest.raises(RuntimeError, match=str(exc)[:20]):
            user_cache_dir("coordarm")
        return
    assert user_cache_dir("coordarm") == expected


@pytest.mark.parametrize("name", sorted(presets()))
def test_the_one_off_evaluation_gives_the_fast_laws_numbers_bit_for_bit(name):
    """``evaluate(once=True)`` (the start check's) evaluates the law as built, not expanded: the same
    numbers as the expanded law at the start and at states around it, without building the expansion."""
    sc = load_scenario(name, links=12)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    rng = np.random.default_rng(5)
    states = [q0] + [q0 + 0.05 * rng.standard_normal(q0.shape) for _ in range(3)]
    once = [ctrl.evaluate(q, 0.2, once=True) for q in states]
    assert ("fast", ctrl.law_form) not in ctrl._cache
    fast = [ctrl.evaluate(q, 0.2) for q in states]
    for a, b in zip(once, fast):
        assert a.keys() == b.keys()
        for k in a:
            assert np.array_equal(np.asarray(a[k]), np.asarray(b[k]), equal_nan=True), (name, k)
