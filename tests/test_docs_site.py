"""The documentation site: generated references complete, internal links sound, an optional full build.

* The scenario key reference (docs/_ext/scenario_keys.py) has a row for every key the parser
  accepts: each table is probed with an unknown key and the parser's own list of allowed keys
  (its error message) is compared with the reference's rows.
* The API reference documents every public module (so every public class and function, with
  autodoc's ``:members:``) and every name ``import coordarm`` gives.
* The command-line reference has every command and flag of ``coordarm``'s parser.
* Every relative link of the README and the pages points at a file that exists (or that the build
  generates), and every ``#anchor`` at a heading of its page.
* ``COORDARM_DOCS_BUILD=1`` builds the whole site (``sphinx-build -W``, the gallery included: a few
  minutes) and checks the pages and the gallery's figures; off by default to keep CI short.
"""
from __future__ import annotations

import copy
import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "docs" / "_ext"))

import api_reference  # noqa: E402
import cli_reference  # noqa: E402
import scenario_keys  # noqa: E402

PLANAR = {"chain": {"links": 4, "link_length": 0.1}, "curve": {"kind": "line", "point": [0, 0], "angle": 0.0},
          "control": {"gain": 2.0}}
SPATIAL = {"chain": {"links": 4, "link_length": 0.1, "joints": "universal"},
           "curve": {"kind": "line", "point": [0, 0, 0], "direction": [1, 0, 0], "normal": [0, 1, 0]},
           "control": {"gain": 2.0}}


def _refusal(base: dict, change) -> str:
    import coordarm

    data = copy.deepcopy(base)
    change(data)
    with pytest.raises(coordarm.ConfigError) as err:
        coordarm.Scenario.from_dict(data)
    return str(err.value)


def _allowed(message: str) -> set[str]:
    """The keys of the parser's ``allowed: [...]`` list."""
    m = re.search(r"allowed: \[([^\]]*)\]", message)
    assert m, message
    return set(re.findall(r"'([^']+)'", m.group(1)))


def _reference() -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for r in scenario_keys.rows():
        out.setdefault(r.table, set()).add(r.key)
    return out


def _section(name: str):
    return lambda d: d.setdefault(name, {}).update(zz=1)


def test_every_table_and_key_the_parser_accepts_is_in_the_reference():
    ref = _reference()
    top = _allowed(_refusal(PLANAR, lambda d: d.update(zz=1)))
    tables = {k for k in top if k not in ("name", "description")}
    assert {"name", "description"} <= ref[""]
    assert tables == {"chain", "curve", "control", "start", "run", "thresholds", "obstacles", "figures"}
    for sec in ("chain", "control", "start", "run", "thresholds", "figures"):
        assert _allowed(_refusal(PLANAR, _section(sec))) == ref[sec], sec
    assert _allowed(_refusal(PLANAR, lambda d: d["chain"].update(base={"kind": "rail", "zz": 1}))) == ref["chain.base"]


def test_every_curve_kind_and_its_keys_are_in_the_reference():
    ref = _reference()
    for kind in ("line", "circle", "arc", "path", "waypoints"):
        planar = _allowed(_refusal(PLANAR, lambda d, k=kind: d.update(curve={"kind": k, "zz": 1})))
        assert planar == ref[f"curve kind={kind}"], kind
        spatial = _allowed(_refusal(SPATIAL, lambda d, k=kind: d.update(curve={"kind": k, "zz": 1})))
        assert spatial == ref[f"curve kind={kind} spatial"], kind
    message = _refusal(PLANAR, lambda d: d.update(curve={"kind": "nope"}))
    assert set(re.findall(r"'(\w+)'", message.split("expected one of")[1])) - {"nope"} <= \
        {k for k in ("line", "circle", "arc", "path", "waypoints")}
    spatial_path = {"kind": "path", "start": [0, 0, 0], "direction": [1, 0, 0], "normal": [0, 1, 0]}
    for base, curve in ((PLANAR, {"kind": "path", "start": [0, 0], "heading": 0.0}), (SPATIAL, spatial_path)):
        message = _refusal(base, lambda d, c=curve: d.update(curve={**c, "segments": [{"line": 1, "zz": 1}]}))
        keys = set(re.findall(r"(\w+) = ", message.split("got")[0]))
        assert keys and keys <= ref["curve.segments[]"], message


def test_every_motion_kind_and_obstacle_kind_is_in_the_reference():
    from coordarm.simulation.obstacles import KINDS
    from coordarm.simulation.obstacles3d import KINDS3D
    from coordarm.symbolic.motions import KINDS as MOTIONS

    ref = _reference()
    for kind in MOTIONS:
        message = _refusal(PLANAR, lambda d, k=kind: d["control"].update(speed={"kind": k, "zz": 1}))
        assert _allowed(message) == ref[f"motion kind={kind}"], kind
    for kind, keys in KINDS.items():
        assert set(keys) == ref[f"obstacles kind={kind}"]
        message = _refusal(PLANAR, lambda d: d.update(obstacles=[{"zz": 1}]))
        assert all(f"{k} =" in message for k in keys)
    for kind, (need, optional) in KINDS3D.items():
        assert set(need) | set(optional) == ref[f"obstacles kind={kind}"]
        message = _refusal(SPATIAL, lambda d, k=kind: d.update(obstacles=[{"kind": k, "zz": 1}]))
        assert set(re.findall(r"'(\w+)'", message.split("has")[1])) <= ref[f"obstacles kind={kind}"], message
    assert {"name", "kind"} == ref["obstacles"]


def test_every_reference_row_has_a_type_a_default_and_a_description():
    for r in scenario_keys.rows():
        assert r.type and r.default and len(r.description) > 5, r
    page = scenario_keys.markdown()
    assert "| `longitudinal` | float |  | `0.15` |" in page      # the default the parser uses
    assert page.count("\n## ") >= 25


def test_the_api_reference_documents_every_public_module_and_name():
    import coordarm

    pages = api_reference.pages()
    documented = set(re.findall(r"^\.\. automodule:: (\S+)$", "\n".join(pages.values()), re.M))
    for package in api_reference.PACKAGES:
        pkg = importlib.import_module(package)
        import pkgutil

        public = {i.name for i in pkgutil.iter_modules(pkg.__path__, package + ".")
                  if not i.name.rsplit(".", 1)[-1].startswith("_") and not i.ispkg}
        assert public | {package} <= documented, public - documented
    face = pages["coordarm.rst"]
    for name in coordarm.__all__:
        assert f"``coordarm.{name}``" in face, name


def test_the_cli_reference_has_every_command_and_flag():
    page = cli_reference.markdown()
    commands = cli_reference.commands()
    assert set(commands) >= {"run", "regen", "replay", "report", "compare", "sweep", "layout", "export"}
    for name, parser in commands.items():
        assert f"## `coordarm {name}`" in page
        for action in cli_reference.flags(parser):
            for option in action.option_strings:
                assert f"`{option}`" in page, (name, option)


GENERATED = {"docs/reference/scenario-keys.md", "docs/reference/cli.md", "docs/api/index.rst",
             "docs/auto_examples/index.rst"}
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")


def _slug(heading: str) -> str:
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower().replace("`", ""))
    return text.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.S | re.M)
    return {_slug(m.group(1)) for m in re.finditer(r"^#{1,3} (.+)$", text, re.M)}


def _pages() -> list[Path]:
    from doc_blocks import pages

    return pages()


@pytest.mark.parametrize("page", _pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_point_at_files_and_headings_that_exist(page: Path):
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.S | re.M)
    for m in LINK.finditer(text):
        target = m.group(1) or m.group(2)
        if re.match(r"[a-z]+:", target):
            continue
        path, _, anchor = target.partition("#")
        file = (page.parent / path).resolve() if path else page
        rel = file.relative_to(ROOT).as_posix() if file.is_relative_to(ROOT) else str(file)
        assert file.exists() or rel in GENERATED, f"{page.name}: link to {target}: no such file"
        assert "shared" not in Path(rel).parts, f"{page.name}: links outside the repository: {target}"
        if anchor and file.suffix == ".md" and file.exists():
            assert anchor in _anchors(file), f"{page.name}: link to {target}: no such heading"


@pytest.mark.skipif(os.environ.get("COORDARM_DOCS_BUILD") != "1", reason="set COORDARM_DOCS_BUILD=1 (a few minutes)")
def test_the_site_builds_without_a_warning(tmp_path):
    out = tmp_path / "html"
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           str(ROOT / "docs"), str(out)], capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, done.stderr[-5000:]
    for page in ("index.html", "getting-started.html", "model.html", "guide/scenarios.html",
                 "reference/scenario-keys.html", "reference/cli.html", "api/coordarm.symbolic.html",
                 "auto_examples/index.html", "auto_examples/plot_preset_run.html"):
        assert (out / page).is_file(), page
    for example in sorted((ROOT / "examples").glob("plot_*.py")):
        assert list((out / "_images").glob(f"sphx_glr_{example.stem}_*.png")), f"{example.name} drew no figure"


def test_the_scenario_module_docstring_states_the_defaults_the_parser_uses():
    from coordarm.simulation import scenario
    from coordarm.simulation.run import DEFAULT_THRESHOLDS
    from coordarm.simulation.scenario_tables import RunTable

    doc = scenario.__doc__
    thresholds = re.search(r"\[thresholds\] link = ([\d.]+), longitudinal = ([\d.]+)", doc)
    assert (float(thresholds.group(1)), float(thresholds.group(2))) == (DEFAULT_THRESHOLDS["link"],
                                                                          DEFAULT_THRESHOLDS["longitudinal"])
    run = re.search(r"\[run\]\s+duration = ([\d.]+), step = ([\d.]+), t0 = ([\d.]+)", doc)
    assert tuple(map(float, run.groups())) == (RunTable().duration, RunTable().step, RunTable().t0)
