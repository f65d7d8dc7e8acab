"""Cost of the per-step finiteness checks of the compiled chunk loop (IEEE bit tests, issue 10).

Builds the same generated source twice, as generated and with the per-step check of
``coordarm_chunk`` cut out, and times ``CompiledController.chunk`` over 1000 RK4 steps of
the benchmark line (``run_benchmarks.line_controller``) in interleaved pairs, at 64 and 1024
links. Run: ``python benchmarks/finite_checks.py``; results in ``RESULTS.md``.
"""
from __future__ import annotations

import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from run_benchmarks import line_controller, machine  # noqa: E402

from coordarm.generated.build import build  # noqa: E402
from coordarm.generated.codegen import generate_source  # noqa: E402
from coordarm.generated.compiled import CompiledController, load_library  # noqa: E402
from coordarm.generated import compile as compile_controller  # noqa: E402

CHECK = "    if (!ca_all_finite(Q + k * CA_M, CA_M) || !ca_all_finite(D + k * CA_NOUT, CA_NOUT)) {"


def unchecked(comp: CompiledController, build_dir: str) -> CompiledController:
    """A copy of ``comp`` whose library lacks the per-step check (the same source otherwise)."""
    source = generate_source(comp.ctrl, comp.form)
    assert CHECK in source.text
    lib = build(replace(source, text=source.text.replace(CHECK, "    if (0) {")), build_dir=build_dir)
    other = CompiledController(comp.ctrl, comp.form, build_dir=build_dir)
    other.library, other._lib = lib, load_library(lib.path)
    other._chunk_c = other._lib.coordarm_chunk
    return other


def main() -> None:
    """Print the Markdown table of per-step times and their median paired ratio."""
    print("\n".join(machine()))
    print("\n| links | checked [us/step] | unchecked [us/step] | median ratio checked/unchecked (31 pairs) |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for m in (64, 1024):
            ctrl = line_controller(m)
            a = compile_controller(ctrl, build_dir=tmp)
            b = unchecked(a, tmp)
            q, h = ctrl.chain.zigzag(1.0), 1e-3
            times = 1.0 + h * np.arange(1000)
            Qa, Da = a.chunk(q, times, h)
            Qb, Db = b.chunk(q, times, h)
            assert np.array_equal(Qa, Qb) and np.array_equal(Da, Db)
            ta, tb, ratios = [], [], []
            for _ in range(31):
                s = time.perf_counter()
                a.chunk(q, times, h)
                x = time.perf_counter() - s
                s = time.perf_counter()
                b.chunk(q, times, h)
                y = time.perf_counter() - s
                ta.append(x)
                tb.append(y)
                ratios.append(x / y)
            print(f"| {m} | {statistics.median(ta) * 1e3:.2f} | {statistics.median(tb) * 1e3:.2f} | "
                  f"{statistics.median(ratios):.3f} |")


if __name__ == "__main__":
    main()
