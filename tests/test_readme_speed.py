"""The README's speed section is regenerated from the recorded benchmark numbers, not typed by hand."""
import importlib.util
import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("scale_benchmark", ROOT / "benchmarks" / "scale.py")
scale = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(scale)


def speed_section() -> str:
    text = (ROOT / "README.md").read_text()
    return text.split("## Speed", 1)[1].split("\n## ", 1)[0]


def test_readme_speed_block_is_what_scale_py_writes_from_scale_json():
    data = json.loads((ROOT / "benchmarks" / "scale.json").read_text())
    section = speed_section()
    block = section.split(scale.README_START, 1)[1].split(scale.README_END, 1)[0]
    assert block.strip("\n").splitlines() == scale.readme_block(data)


def test_performance_page_targets_are_what_scale_py_writes_from_scale_json():
    data = json.loads((ROOT / "benchmarks" / "scale.json").read_text())
    page = scale.DOCS_PAGE.read_text()
    block = page.split(scale.DOCS_START, 1)[1].split(scale.DOCS_END, 1)[0]
    assert block.strip("\n").splitlines() == scale.targets_block(data)


def test_readme_speed_figures_outside_the_block_are_in_results():
    section = speed_section()
    prose = re.sub(re.escape(scale.README_START) + ".*?" + re.escape(scale.README_END), "", section, flags=re.S)
    results = (ROOT / "benchmarks" / "RESULTS.md").read_text()
    numbers = re.findall(r"\d+(?:\.\d+)?(?= ?%)", prose)
    assert numbers, "the sweep sentence quotes efficiencies"
    for number in numbers:
        assert re.search(rf"(?<![\d.]){re.escape(number)} ?%", results), f"{number} % is not in RESULTS.md"


def test_replace_block_rewrites_only_between_the_markers(tmp_path):
    path = tmp_path / "x.md"
    path.write_text(f"head\n{scale.README_START}\nold\n{scale.README_END}\ntail\n")
    assert scale.replace_block(path, scale.README_START, scale.README_END, ["new 1", "new 2"])
    assert path.read_text() == f"head\n{scale.README_START}\nnew 1\nnew 2\n{scale.README_END}\ntail\n"
    assert not scale.replace_block(tmp_path / "x.md", "<!-- nothing -->", "<!-- end -->", ["x"])
