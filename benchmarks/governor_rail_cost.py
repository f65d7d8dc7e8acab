"""Cost of the governor on a rail in the compiled structured law (its second pass of the recursion).

Run: ``python benchmarks/governor_rail_cost.py [M] [PAIRS]`` (default 64 links, 9 pairs). The law
and the RK4 step of two libraries of the same chain on a rail (10 cm links, a line 1 cm beside the
rail, K = 2, v* = 0.1 m/s, a span growing 0.2 m/s), without and with the governor, are timed from
C with ``bench_driver.c`` in interleaved rounds (21 batches of about 2 ms each per round); prints
the medians and the median of the per-round ratios governed / ungoverned. The state is the
zig-zag at beta = 1.0 (v_scale = 1: the second pass runs whatever the factor is).
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from timing import c_interleaved  # noqa: E402
from coordarm.generated.build import build  # noqa: E402
from coordarm.generated.codegen import generate_source  # noqa: E402
from coordarm.symbolic import CoordinatingController, Line, PlanarChain  # noqa: E402
from coordarm.symbolic.motions import Ramp  # noqa: E402


def rail_controller(m: int, governor: bool) -> CoordinatingController:
    """The benchmark case on a rail, with or without the governor."""
    chain = PlanarChain(m, 0.1, base="rail", rail_limits=(-1.0, 50.0))
    return CoordinatingController(chain, Line(point=(0.0, 0.01)), 2.0, 0.1, span=Ramp(0.0, 0.2), governor=governor)


def main() -> None:
    m = int(sys.argv[1]) if len(sys.argv) > 1 else 64
    pairs = int(sys.argv[2]) if len(sys.argv) > 2 else 9
    build_dir = Path(tempfile.mkdtemp(prefix="coordarm_governor_"))
    ctrls = [rail_controller(m, g) for g in (False, True)]
    libs = [build(generate_source(c), build_dir=build_dir).path for c in ctrls]
    q = ctrls[0].chain.zigzag(1.0, d=0.2)
    assert ctrls[1].evaluate(q, 1.0)["v_scale"] == 1.0
    law, rk4 = (np.concatenate(x) for x in zip(*(c_interleaved(libs, q, rounds=21, batch_ms=2.0) for _ in range(pairs))))
    for name, x in (("law", law), ("rk4", rk4)):
        print(f"m = {m} {name}: ungoverned {np.median(x[:, 0]) / 1e3:.3f} µs, governed {np.median(x[:, 1]) / 1e3:.3f} µs, "
              f"median ratio {np.median(x[:, 1] / x[:, 0]):.3f} ({len(x)} interleaved rounds)")


if __name__ == "__main__":
    main()
