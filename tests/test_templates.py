"""The C templates (``generated/templates``, package data): each one rendered by the code generator or the
export with every placeholder filled, shipped by the package, and the rendered source of a preset
compiling without a warning."""
import re
import tomllib
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

import coordarm
import coordarm.generated.render as render_module
from coordarm.generated.build import build
from coordarm.generated.kernels import FLAGS, kernel_source
from coordarm.generated.codegen import generate_source
from coordarm.generated.export import export_law
from coordarm.generated.spatial_codegen import generate_spatial_source
from coordarm.generated.render import TemplateError, render
from coordarm.symbolic import Circle, CoordinatingController, PlanarChain, SpatialChain, SpatialController
from coordarm.symbolic.curves3d import Line3D

ROOT = Path(__file__).resolve().parent.parent
#: Any leftover ``@name@`` (the renderer's placeholder syntax), written out here independently.
LEFTOVER = re.compile(r"@[A-Za-z_][A-Za-z0-9_]*@")
#: The hand-written kernel libraries (coordarm.generated.kernels).
KERNELS = ("chain_geometry.c", "json_digits.c", "log_records.c", "segment_distance.c")


def template_files() -> set[str]:
    """Every file under the installed ``coordarm.generated`` package's ``templates/``, ``/``-separated."""
    def walk(node, prefix=""):
        for child in node.iterdir():
            if child.is_dir():
                yield from walk(child, prefix + child.name + "/")
            elif child.is_file():
                yield prefix + child.name
    return set(walk(files("coordarm.generated") / "templates"))


def test_a_missing_or_unknown_placeholder_is_an_error_naming_it():
    with pytest.raises(TemplateError, match=r"dense_law\.c: no value for \['law_name'\]"):
        render("dense_law.c", results="  res[0] = u;")
    with pytest.raises(TemplateError, match=r"no placeholder for \['speed'\]"):
        render("dense_law.c", results="", law_name="law", speed=1)
    with pytest.raises(TemplateError, match=r"no placeholder for \['m'\]"):
        render("library_api.c", m=4)          # a template without placeholders takes no value


def test_a_value_is_inserted_verbatim_and_not_scanned_again():
    text = render("b_diagonal.h", values="@values@, {1.0}")
    assert text.startswith("static const casadi_real ca_bd[CA_NQ] = {@values@, {1.0}};\n")


def test_every_template_is_rendered_by_the_generator_or_the_export_with_nothing_left_unfilled(tmp_path,
                                                                                                monkeypatch):
    rendered = set()
    read = render_module.template_text

    def recording(name):
        rendered.add(name)
        return read(name)

    monkeypatch.setattr(render_module, "template_text", recording)
    texts = []
    scenario = coordarm.load_scenario("thread").with_overrides(governor=True)   # rail, span, path, governor
    ctrl = scenario.controller()
    texts.append(generate_source(ctrl, "structured").text)
    diagonal = CoordinatingController(PlanarChain(4, 0.1, np.diag([1.0, 2.0, 0.5, 1.5])), Circle((0.0, 2.0), 2.0),
                                      2.0, 0.05)
    texts.append(generate_source(diagonal, "dense").text)
    spatial = SpatialController(SpatialChain(4, 0.1), Line3D(), 2.0, 0.05, roll=0.0)
    texts.append(generate_spatial_source(spatial, "structured").text)
    texts += [kernel_source(name).text for name in KERNELS]
    spatial_export = export_law(spatial, spatial.chain.zigzag(1.0), tmp_path / "spatial", step=0.01, duration=0.1)
    texts += [f.read_text() for f in spatial_export.files]
    export = export_law(ctrl, scenario.start(ctrl), tmp_path, step=scenario.step, duration=0.1)
    texts += [f.read_text() for f in export.files]
    assert rendered == template_files()
    for text in texts:
        assert not LEFTOVER.search(text), LEFTOVER.search(text).group()


def test_every_template_file_is_package_data_of_coordarm_generated():
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    package = ROOT / "generated"
    shipped = {p for pattern in globs["coordarm.generated"] for p in package.glob(pattern)}   # as setuptools does
    on_disk = {p for p in (package / "templates").rglob("*") if p.is_file()}
    assert {package / "templates" / name for name in template_files()} == on_disk
    assert on_disk and sorted(map(str, on_disk - shipped)) == []


def test_the_rendered_source_of_a_governed_rail_preset_on_a_path_compiles_without_a_warning(tmp_path):
    ctrl = coordarm.load_scenario("thread").with_overrides(governor=True).controller()
    source = generate_source(ctrl)
    for macro in ("CA_RAIL 1", "CA_SPAN 1", "CA_GOVERNED 1", "CA_PATH 1"):
        assert f"#define {macro}\n" in source.text
    lib = build(source, flags="-O2 -Wall -Wextra -Werror", build_dir=tmp_path)
    assert lib.path.is_file() and not lib.cache_hit


@pytest.mark.parametrize("name", KERNELS)
def test_the_kernel_sources_compile_without_a_warning(tmp_path, name):
    lib = build(kernel_source(name), flags=FLAGS + ("-Wall", "-Wextra", "-Werror"), build_dir=tmp_path)
    assert lib.path.is_file() and not lib.cache_hit
