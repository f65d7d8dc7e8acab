"""Variants of the generated per-link code, timed from C (what each optimisation gave).

Run: ``python benchmarks/experiments_link_step.py [--quick]``; needs a C compiler. Each
variant swaps the controller's link step before code generation, checks that the compiled
law still agrees with the interpreted one to 1e-12, and times ``coordarm_law`` from C
with ``bench_driver.c``. Results are recorded in ``benchmarks/RESULTS.md``.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from coordarm.symbolic import CoordinatingController, Line, PlanarChain  # noqa: E402
from coordarm.generated import compile as compile_controller  # noqa: E402
from run_benchmarks import c_driver, time_from_c  # noqa: E402


def untuned_link(ctrl: CoordinatingController, carried_trig: bool, hoist: bool):
    """The link step with the two optimisations switched on or off."""
    carry, qj, t, new, out = ctrl.recursion.link_expressions()
    if not carried_trig:   # recompute cos/sin of alpha_{j-1} from alpha_{j-1}: two pairs per link
        prev = ca.vertcat(ca.cos(carry[2]), ca.sin(carry[2]))
        new = ca.cse(ca.substitute(new, carry[3:5], prev))
        out = ca.cse(ca.substitute(out, carry[3:5], prev))
    if hoist:
        expr, wsym, wexpr = ca.extract_parametric(ca.vertcat(new, out), t)
        wsym, wexpr = ca.vertcat(*wsym), ca.vertcat(*wexpr)
    else:
        expr, wsym, wexpr = ca.vertcat(new, out), t, t
    n = new.numel()
    return (ca.Function("time_features", [t], [wexpr]),
            ca.Function("link_step", [carry, qj, wsym], [expr[:n], expr[n:]]))


def main() -> None:
    """Time every variant at m = 64 and 1024 and print a Markdown table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    driver = c_driver()
    reps = 5 if args.quick else 41
    variants = [("t per link, 2 sin/cos pairs", False, False, "-O2"),
                ("t per link, 2 sin/cos pairs, no inlining", False, False, "-O3 -fvisibility=default"),
                ("t per link, 2 sin/cos pairs", False, False, "-O3"),
                ("carried trig (1 pair)", True, False, "-O3"),
                ("carried trig + hoisted time terms", True, True, "-O2"),
                ("carried trig + hoisted time terms", True, True, "-O3"),
                ("carried trig + hoisted, default visibility (no inlining)", True, True,
                 "-O3 -fvisibility=default"),
                ("carried trig + hoisted time terms", True, True, "-O3 -march=native"),
                ("carried trig + hoisted time terms", True, True, "-O3 -ffast-math")]
    print("| variant | flags | m = 64 law [us] | m = 1024 law [us] | max rel. diff vs interpreted |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for label, trig, hoist, flags in variants:
            row, worst = [], 0.0
            for m in (64, 1024):
                ctrl = CoordinatingController(PlanarChain(m, 0.1), Line(angle=lambda t: 0.6 * ca.sin(0.2 * t)),
                                              2.0, 0.1)
                ctrl.recursion._cache["hoisted"] = untuned_link(ctrl, trig, hoist)
                comp = compile_controller(ctrl, flags=flags, build_dir=tmp)
                reference = CoordinatingController(PlanarChain(m, 0.1),
                                                   Line(angle=lambda t: 0.6 * ca.sin(0.2 * t)), 2.0, 0.1)
                rng = np.random.default_rng(1)
                for _ in range(20):
                    q = ctrl.chain.zigzag(rng.uniform(0.6, 1.3)) + rng.normal(0, 0.1, m)
                    a, b = comp.control(q, 1.7), reference.control(q, 1.7)
                    worst = max(worst, float(np.max(np.abs(a - b)) / np.max(np.abs(b))))
                law, _ = time_from_c(driver, comp, ctrl.chain.zigzag(1.0), reps)
                row.append(f"{law / 1e3:.2f}")
            print(f"| {label} | `{flags}` | {row[0]} | {row[1]} | {worst:.1e} |")


if __name__ == "__main__":
    main()
