"""Cost of the re-pivoting check in the compiled structured law: this tree against a base commit.

Run: ``python benchmarks/repivot_cost.py SRC_BASE_64.c SRC_BASE_1024.c`` where the two files are
the generated C of the base commit (the line case of ``run_benchmarks.py``, zig-zag beta = 1.0),
e.g. written by ``generate_source(ctrl).text`` in a checkout of 35299a5. The law from C is timed
with ``bench_driver.c`` in interleaved pairs (base, this tree); prints the medians and the median
of the per-pair ratios, and the time of this tree's law at a state with one link exactly across
the line (where it evaluates the law a second time with the re-pivoting step).
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from run_benchmarks import c_driver, line_controller, time_from_c  # noqa: E402
from coordarm.generated.build import build  # noqa: E402
from coordarm.generated.codegen import Source, generate_source  # noqa: E402


def main() -> None:
    base_files = dict(zip((64, 1024), sys.argv[1:3]))
    driver = c_driver()
    build_dir = Path(tempfile.mkdtemp(prefix="coordarm_repivot_"))
    for m, path in base_files.items():
        ctrl = line_controller(m)
        libs = {"base": build(Source(Path(path).read_text(), "structured", m), build_dir=build_dir),
                "this": build(generate_source(ctrl), build_dir=build_dir)}
        t = 1.0
        heading = 0.6 * np.sin(0.2 * t)
        q = ctrl.chain.zigzag(1.0, heading)
        across = q.copy()
        turn = np.pi / 2 + heading - np.cumsum(q)[m // 2]   # link m/2 + 1 across the line at time t
        across[m // 2] += turn
        across[m // 2 + 1] -= turn
        times = {k: [] for k in [*libs, "across"]}
        for _ in range(7):
            for k, lib in libs.items():
                times[k].append(time_from_c(driver, SimpleNamespace(m=m, library=lib), q, 21, t)[0])
            times["across"].append(time_from_c(driver, SimpleNamespace(m=m, library=libs["this"]), across, 21, t)[0])
        ratio = np.median(np.array(times["this"]) / np.array(times["base"]))
        print(f"m = {m}: base {np.median(times['base']) / 1e3:.3f} µs, this {np.median(times['this']) / 1e3:.3f} µs, "
              f"median ratio {ratio:.3f}; one link across the line: {np.median(times['across']) / 1e3:.3f} µs")


if __name__ == "__main__":
    main()
