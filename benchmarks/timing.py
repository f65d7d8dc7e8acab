"""Interleaved timing: every comparison runs in rounds inside one process, each variant timed
once per round, and is reported as the median of the per-round ratios with their min-max.

* :func:`c_interleaved` times generated libraries from C (``bench_driver.c``);
* :func:`py_interleaved` times Python callables;
* :func:`floor_library` builds the cos/sin-only floor of the vectorised law (prefix sum of the
  angles and the trig loops, nothing else) with the same flags as the law.
"""
from __future__ import annotations

import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from coordarm.generated.build import build, find_compiler
from coordarm.generated.codegen import Source
from coordarm.generated.render import render

HERE = Path(__file__).resolve().parent

#: The floor: same API as a law library, but coordarm_law only sums the angles and takes their
#: cosines and sines (coordarm_rk4 does that four times, like the RK4 step's four law calls).
FLOOR = """#include <math.h>
#define casadi_real double
#define casadi_int long long int
#define CA_M {m}
#define API __attribute__((visibility("default")))
""" + render("trig_passes.c") + """
API int coordarm_law(const double* q, double t, double* out, long long* iw, double* w) {
  (void)t; (void)iw;
  ca_angles(q, w); ca_trig(w, out, out + CA_M);
  return 0;
}
API int coordarm_rk4(const double* q, double t, double h, double* qn, double* out, long long* iw, double* w) {
  int k;
  (void)h; (void)qn;
  for (k = 0; k < 4; ++k) coordarm_law(q, t, out, iw, w);
  return 0;
}
API void coordarm_sizes(long long* s) { s[0] = CA_M; s[1] = 3 * CA_M + 1; s[2] = 1; s[3] = CA_M; }
"""


def floor_library(m: int, flags=None) -> Path:
    """The cos/sin-only floor library for ``m`` links, compiled with ``flags`` (default flags if None)."""
    return build(Source(FLOOR.replace("{m}", str(m)), "floor", m), flags=flags).path


def c_driver() -> Path:
    """Compile ``bench_driver.c`` (once per source version) and return the executable."""
    src = HERE / "bench_driver.c"
    exe = Path(tempfile.gettempdir()) / f"coordarm_bench_driver_{os.getuid()}_{int(src.stat().st_mtime)}"
    if not exe.exists():
        subprocess.run([find_compiler(), "-O2", "-o", str(exe), str(src), "-ldl"], check=True)
    return exe


def c_interleaved(libs: list[Path], q: np.ndarray, rounds: int = 21, batch_ms: float = 4.0,
                  t: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """ns per ``coordarm_law`` and per ``coordarm_rk4`` call of each library, per round.

    Returns
    -------
    law, rk4 : (rounds, len(libs)) arrays
    """
    with tempfile.NamedTemporaryFile(suffix=".bin", delete=False) as f:
        np.ascontiguousarray(q, dtype=float).tofile(f)
    try:
        out = subprocess.run([str(c_driver()), f.name, repr(t), str(rounds), str(batch_ms), *map(str, libs)],
                             capture_output=True, text=True, check=True).stdout
    finally:
        os.unlink(f.name)
    rows = np.array([[float(v) for v in line.split()] for line in out.strip().splitlines()])
    return rows[:, :len(libs)], rows[:, len(libs):]


def py_interleaved(fns: list, rounds: int = 21, batch_s: float = 0.002, sub: int = 1) -> np.ndarray:
    """Seconds per call of each of ``fns`` per round, shape (rounds, len(fns)); with ``sub > 1``
    each round runs ``sub`` interleaved batches of each and keeps each one's fastest."""
    def once(fn, number):
        start = time.perf_counter()
        for _ in range(number):
            fn()
        return (time.perf_counter() - start) / number
    numbers = []
    for fn in fns:
        fn()
        numbers.append(max(1, int(batch_s / max(once(fn, 1), 1e-8))))
    rows = []
    for _ in range(rounds):
        batches = [[once(fn, n) for fn, n in zip(fns, numbers)] for _ in range(sub)]
        rows.append(np.min(batches, axis=0))
    return np.array(rows)


def ratio(times: np.ndarray, slow: int, fast: int) -> tuple[float, float, float]:
    """Median, min and max over rounds of ``times[:, slow] / times[:, fast]``."""
    r = times[:, slow] / times[:, fast]
    return float(np.median(r)), float(r.min()), float(r.max())


def fmt_ratio(r: tuple[float, float, float]) -> str:
    """``median (min-max)`` of a :func:`ratio`."""
    return f"{r[0]:.2f}× ({r[1]:.2f}–{r[2]:.2f})"


def median(times: np.ndarray, col: int) -> float:
    """Median over rounds of one column."""
    return float(statistics.median(times[:, col]))
