"""A controller built from a scenario finds its library by its recipe, without generating the C, and never a stale one."""
import json
import os

import pytest

from coordarm.generated import build as build_mod
from coordarm.generated import code_identity, source_memo
from coordarm.generated.compiled import CompiledController, controller_source
from coordarm.generated.compiler_memo import SOURCES
from coordarm.generated.source_memo import recipe_key
from coordarm.simulation.choices import presets
from coordarm.simulation.scenario import Scenario, load_scenario
from coordarm.symbolic import PlanarChain

#: Links of each preset in these tests (small: the C of a path preset is generated in a fraction of a second).
LINKS = 6


def small(name, **overrides):
    return load_scenario(name, links=overrides.pop("links", LINKS), **overrides)


@pytest.mark.parametrize("name", sorted(presets()))
def test_the_scenario_json_determines_the_generated_c_of_every_preset(name):
    """The recipe is the scenario's JSON: a scenario read back from it gives the same C, bit for bit
    (so equal recipes, with equal code, mean equal sources), and the same recipe key."""
    sc = small(name)
    again = Scenario.from_dict(json.loads(sc.to_json()))
    a, b = sc.controller(), again.controller()
    assert a.recipe is not None and a.recipe == b.recipe
    assert recipe_key(a, a.law_form, True) == recipe_key(b, b.law_form, True)
    assert controller_source(a, a.law_form).text == controller_source(b, b.law_form).text


def test_every_preset_and_each_changed_parameter_has_a_key_of_its_own_and_a_source_of_its_own():
    variants = [small(name) for name in sorted(presets())]
    variants += [small("line", links=LINKS + 1), small("line", governor=True), small("line", law="dense")]
    for field, value in (("gain", 2.5), ("speed", 0.21), ("link_length", 0.31)):
        spec = small("line").spec
        section = "chain" if field == "link_length" else "control"
        spec[section][field] = value
        variants.append(Scenario.from_dict(spec))
    ctrls = [sc.controller() for sc in variants]
    keys = [recipe_key(c, c.law_form, True)[0] for c in ctrls]
    sources = [controller_source(c, c.law_form).text for c in ctrls]
    assert len(set(keys)) == len(keys) == len(set(sources))
    c = ctrls[0]
    assert recipe_key(c, c.law_form, False)[0] != keys[0] or c.law_form != "structured"
    assert recipe_key(c, "dense", True)[0] != recipe_key(c, "structured", True)[0]


def test_a_changed_controller_or_a_user_curve_has_no_recipe():
    sc = small("line")
    ctrl = sc.controller()
    assert ctrl.recipe is not None
    ctrl.gain = 2.0
    assert ctrl.recipe is None and recipe_key(ctrl, "structured", True) is None
    ctrl = sc.controller()
    ctrl.chain = PlanarChain(LINKS, ctrl.chain.xi)
    assert ctrl.recipe is None
    ctrl = sc.controller()
    ctrl.curve.angle = ctrl.curve.angle          # the same object again: still the recipe's
    assert ctrl.recipe is not None
    ctrl.chain.joint_limits[0] -= 0.1
    assert ctrl.recipe is None                      # an array changed in place
    assert sc.with_curve(sc.controller().curve).controller().recipe is None


def test_a_file_of_the_code_replaced_with_the_same_size_and_time_changes_the_key(tmp_path):
    """The key holds each file's identity: new content of the same size, its modification time set back,
    still changes it (the inode of a replaced file, the change time of one written in place)."""
    folder = tmp_path / "symbolic"
    folder.mkdir()
    f = folder / "a.py"
    f.write_text("x = 1\n")
    st = os.stat(f)
    files = code_identity.package_files(tmp_path, ("symbolic",))
    key, _ = code_identity.files_key(files)
    new = folder / "a.new"
    new.write_text("x = 2\n")
    os.utime(new, ns=(st.st_atime_ns, st.st_mtime_ns))
    os.replace(new, f)
    assert os.stat(f).st_size == st.st_size and os.stat(f).st_mtime_ns == st.st_mtime_ns
    assert code_identity.files_key(files)[0] != key
    (folder / "b.py").write_text("")
    assert code_identity.files_key(code_identity.package_files(tmp_path, ("symbolic",)))[0] != key
    assert code_identity.files_key(files, "casadi 3.8")[0] != code_identity.files_key(files, "casadi 3.9")[0]


def test_a_fresh_file_is_not_remembered(tmp_path):
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "a.py").write_text("")
    key, settled = code_identity.files_key(code_identity.package_files(tmp_path, ("p",)))
    assert not settled
    os.utime(tmp_path / "p" / "a.py", (0, 0))    # the change time stays new
    assert not code_identity.files_key(code_identity.package_files(tmp_path, ("p",)))[1]


def test_the_second_controller_of_a_scenario_loads_the_library_without_generating_its_c(tmp_path, monkeypatch):
    monkeypatch.setattr(code_identity, "SETTLE_SECONDS", -1e9)     # this checkout's files count as settled
    sc = small("line", links=4)
    first = CompiledController(sc.controller(), build_dir=tmp_path)
    assert first.generate_seconds > 0
    memo = json.loads((tmp_path / SOURCES).read_text())
    assert list(memo.values()) == [first.library.key]

    generated = []
    monkeypatch.setattr(source_memo, "build", lambda *a, **k: generated.append(a) or build_mod.build(*a, **k))
    ctrl = sc.controller()
    second = CompiledController(ctrl, build_dir=tmp_path)
    assert second.cache_hit and second.generate_seconds == 0 and not generated
    src = controller_source(ctrl, "structured")
    assert second.library.key == first.library.key == build_mod.cache_key(
        src, build_mod.find_compiler(None), build_mod.compile_flags(None), tmp_path)
    q = sc.start(ctrl)
    assert (second.control(q, 0.1) == first.control(q, 0.1)).all()

    other = small("line", links=5).controller()                    # another recipe: generated
    assert CompiledController(other, build_dir=tmp_path).generate_seconds > 0 and generated


def test_a_remembered_key_whose_library_is_gone_or_stale_is_built_again(tmp_path, monkeypatch):
    monkeypatch.setattr(code_identity, "SETTLE_SECONDS", -1e9)
    sc = small("line", links=4)
    first = CompiledController(sc.controller(), build_dir=tmp_path)
    (first.library.path.parent / build_mod.META).write_text(json.dumps({"key": first.library.key, "sha256": "0"}))
    again = CompiledController(sc.controller(), build_dir=tmp_path)
    assert not again.cache_hit and again.generate_seconds > 0 and again.library.key == first.library.key
    forced = CompiledController(sc.controller(), build_dir=tmp_path, force=True)
    assert not forced.cache_hit and forced.generate_seconds > 0


def test_the_compiled_law_at_hand_is_never_compiled_for_it(tmp_path, monkeypatch):
    """``compiled_at_hand`` (the start check's law when no C need be generated): None for an unknown recipe,
    without generating or compiling anything; the remembered library or the one ``compile`` kept otherwise."""
    from coordarm.generated import compile as compile_law
    from coordarm.generated import compiled_at_hand

    monkeypatch.setattr(code_identity, "SETTLE_SECONDS", -1e9)
    sc = small("line", links=4)
    real_build = build_mod.build
    monkeypatch.setattr(source_memo, "build", lambda *a, **k: pytest.fail("compiled"))
    assert compiled_at_hand(sc.controller(), build_dir=tmp_path) is None
    assert not (tmp_path / SOURCES).exists()
    monkeypatch.setattr(source_memo, "build", real_build)
    ctrl = sc.controller()
    kept = compile_law(ctrl, build_dir=tmp_path)
    assert compiled_at_hand(ctrl, build_dir=tmp_path) is kept
    monkeypatch.setattr(source_memo, "build", lambda *a, **k: pytest.fail("compiled"))
    other = sc.controller()
    found = compiled_at_hand(other, build_dir=tmp_path)
    assert found is not None and found.library.key == kept.library.key and found.generate_seconds == 0
    assert compile_law(other, build_dir=tmp_path) is found
    q = sc.start(other)
    assert found.evaluate(q, 0.0).keys() >= {"e", "link_margins", "longitudinal"}


def test_a_singular_start_is_refused_alike_with_the_compiled_law_at_hand(tmp_path, monkeypatch):
    """The start check with the compiled law gives the interpreted check's error, the margin in it included
    (the compiled law says 2.5e-19 where the controller's says 0: a margin near its threshold, or a
    non-finite output, leaves the decision and the message to the controller's own evaluation)."""
    import numpy as np

    from coordarm.generated import compile as compile_law
    from coordarm.simulation.run import simulate
    from coordarm.symbolic import ConfigError

    from coordarm.generated import compiled_at_hand

    sc = small("line", links=4)
    ctrl = sc.controller()
    kept = compile_law(ctrl)                              # in the session's cache, where simulate() looks
    assert compiled_at_hand(ctrl) is kept
    q = np.zeros(4)                                      # stretched straight: the longitudinal margin is 0
    errors = []
    for backend in ("auto", "interpreted"):
        with pytest.raises(ConfigError) as err:
            simulate(ctrl, q, 0.01, backend=backend)
        errors.append(str(err.value))
    assert errors[0] == errors[1] and "singular" in errors[0]


# ------------------------------------------------------------------------------ values a recipe determines
def test_remembered_values_are_computed_once_with_their_exact_bits(tmp_path, monkeypatch):
    import numpy as np

    monkeypatch.setenv("COORDARM_BUILD_DIR", str(tmp_path))
    monkeypatch.setattr(code_identity, "SETTLE_SECONDS", -1e9)
    calls = []

    def compute(x):
        calls.append(x)
        return np.array([x, -0.0, 1 / 3, np.nextafter(1.0, 2.0)])

    first = source_memo.remembered_values("test", "recipe a", lambda: compute(0.1))
    again = source_memo.remembered_values("test", "recipe a", lambda: compute(0.2))
    assert calls == [0.1] and again.tobytes() == first.tobytes()      # -0.0 and the last ulp kept
    assert source_memo.remembered_values("test", "recipe b", lambda: compute(0.3))[0] == 0.3
    assert source_memo.remembered_values("other", "recipe a", lambda: compute(0.4))[0] == 0.4
    memo = tmp_path / "values.json"
    memo.write_text(json.dumps({k: "zz" for k in json.loads(memo.read_text())}))   # damaged entries
    assert source_memo.remembered_values("test", "recipe a", lambda: compute(0.5))[0] == 0.5
    monkeypatch.setattr(code_identity, "SETTLE_SECONDS", 1e9)                       # files just changed
    source_memo.remembered_values("test", "recipe c", lambda: compute(0.6))
    source_memo.remembered_values("test", "recipe c", lambda: compute(0.7))
    assert calls[-2:] == [0.6, 0.7]
    build_mod.clean(tmp_path)                                                       # regen --clean forgets them
    assert not memo.exists()


@pytest.mark.parametrize("name, layer", [("path3d", "coordarm.simulation.spatial_scenario.follow_curve3d"),
                                         ("thread", "coordarm.simulation.scenario.follow_curve"),
                                         ("arc", "coordarm.simulation.scenario.project_onto_curve")])
def test_a_start_along_or_onto_the_curve_is_laid_once_and_is_the_one_laid_anew(tmp_path, monkeypatch, name, layer):
    """A remembered start is the start laid anew (a cache of its own), to the last bit; the second controller of
    the scenario does not lay it; another scenario does."""
    monkeypatch.setattr(code_identity, "SETTLE_SECONDS", -1e9)
    sc = small(name, links=12)
    monkeypatch.setenv("COORDARM_BUILD_DIR", str(tmp_path / "fresh"))
    (tmp_path / "fresh").mkdir(mode=0o700)
    laid = sc.start(sc.controller())
    monkeypatch.setenv("COORDARM_BUILD_DIR", str(tmp_path))
    first = sc.start(sc.controller())
    assert first.tobytes() == laid.tobytes()

    def lay_again(*args, **kwargs):
        raise RuntimeError("laid again")
    monkeypatch.setattr(layer, lay_again)
    assert sc.start(sc.controller()).tobytes() == laid.tobytes()
    with pytest.raises(RuntimeError, match="laid again"):              # another scenario: laid
        other = small(name, links=13)
        other.start(other.controller())
