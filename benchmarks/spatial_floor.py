"""The compiled spatial law against its own vector-trig floors (issue 22: within 1.3x), from C.

Three hand-written floors, compiled with the law's flags:

* **same work** (the fair floor, ``spatial_floor_law.c``): the law's library with its per-link loops
  (forward kinematics, link pivots, rates, joint rates) replaced by the same passes written by hand
  in plain C, for this benchmark's line (the curve's time terms in closed form); the head, the end
  solve and the end margin (once per call) stay the generated ones. Its chunk must give the law's
  states to rounding (checked before timing);

and two lower bounds with the same API as a law library (``coordarm_law``; ``coordarm_rk4``
calls it four times like the RK4 step):

* **trig**: what the planar floor (``timing.FLOOR``) is for the planar law: the spatial law's
  trigonometric passes only (split ``q`` into the ``a`` and ``b`` angles, the cosine and sine of the
  2m angles in vectorised loops, ``1 / cos b_j``);
* **trig + kinematics**: the trig passes plus the forward kinematics every spatial law must run,
  the frame product ``R_j = R_{j-1} Rz(a_j) Ry(b_j)`` and the centres ``y^j`` (the recursion's
  irreducible multiply-adds, about 50 flops per link, on the loop-carried frame).

Timed as in ``benchmarks/spatial_law.py`` (its spatial case): interleaved rounds in one process, each
case once per round, one C loop of RK4 steps (four law calls each, about 131,000 link
evaluations) per case and round; thread CPU time per law call per link, median over rounds; ratios
are medians of the per-round ratios. (``bench_driver.c`` reads m joint angles, not the 2m of a
spatial chain.)

Run: ``python benchmarks/spatial_floor.py [--links 64 256 1024] [--rounds 15]``.
"""
from __future__ import annotations

import argparse
import ctypes
import os
import time
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from coordarm.generated.build import build  # noqa: E402
from coordarm.generated.codegen import Source  # noqa: E402
from coordarm.generated.compiled import CompiledController  # noqa: E402
from coordarm.generated.spatial_codegen import generate_spatial_source  # noqa: E402
from coordarm.symbolic.curves3d import Line3D  # noqa: E402
from coordarm.symbolic.motions import Sinusoid  # noqa: E402
from coordarm.symbolic.spatial_chain import SpatialChain  # noqa: E402
from coordarm.symbolic.spatial_controller import SpatialController  # noqa: E402
from spatial_law import AXIS  # noqa: E402
from spatial_law import per_link_ns  # noqa: E402

#: The spatial floors (``KINEMATICS`` 0: trig only; 1: trig and forward kinematics).
FLOOR = r"""#include <math.h>
#define CA_M {m}
#define KINEMATICS {kin}
#define API __attribute__((visibility("default")))
#if defined(__x86_64__) && defined(__GLIBC__) && defined(__GNUC__) && !defined(__clang__) \
    && __GNUC__ >= 6 && !defined(__FAST_MATH__)
#if __GLIBC_PREREQ(2, 22)
__attribute__((simd("notinbranch"))) double cos(double);
__attribute__((simd("notinbranch"))) double sin(double);
#endif
#endif
static void trig(const double* restrict q, double* restrict ang, double* restrict c, double* restrict s,
                 double* restrict ic) {
  long j;
  for (j = 0; j < CA_M; ++j) { ang[j] = q[2 * j]; ang[CA_M + j] = q[2 * j + 1]; }
  for (j = 0; j < 2 * CA_M; ++j) c[j] = cos(ang[j]);
  for (j = 0; j < 2 * CA_M; ++j) s[j] = sin(ang[j]);
  for (j = 0; j < CA_M; ++j) ic[j] = 1 / c[CA_M + j];
}
/* R <- R Rz(a) Ry(b), y <- y + xi/2 (d_prev + d), link by link; the centres to out */
static void kinematics(const double* restrict c, const double* restrict s, double* restrict out) {
  double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, y[3] = {0, 0, 0}, N[9];
  long j, i;
  for (j = 0; j < CA_M; ++j) {
    double ca = c[j], sa = s[j], cb = c[CA_M + j], sb = s[CA_M + j];
    double z0 = ca * cb, z1 = sa * cb, z2 = -sb, x0 = ca * sb, x1 = sa * sb, x2 = cb;
    for (i = 0; i < 3; ++i) {            /* row i of R times Rz(a) Ry(b); R row-major */
      N[3 * i] = R[3 * i] * z0 + R[3 * i + 1] * z1 + R[3 * i + 2] * z2;
      N[3 * i + 1] = -R[3 * i] * sa + R[3 * i + 1] * ca;
      N[3 * i + 2] = R[3 * i] * x0 + R[3 * i + 1] * x1 + R[3 * i + 2] * x2;
    }
    for (i = 0; i < 3; ++i) {
      y[i] += 0.05 * (R[3 * i] + N[3 * i]);
      out[3 * j + i] = y[i];
    }
    for (i = 0; i < 9; ++i) R[i] = N[i];
  }
}
API int coordarm_law(const double* q, double t, double* out, long long* iw, double* w) {
  (void)t; (void)iw;
  trig(q, w, w + 2 * CA_M, w + 4 * CA_M, w + 6 * CA_M);
  if (KINEMATICS) kinematics(w + 2 * CA_M, w + 4 * CA_M, out);
  else out[0] = w[2 * CA_M] + w[4 * CA_M] + w[6 * CA_M];
  return 0;
}
/* n steps of four law calls each, like the law library's RK4 chunk (out: 3 m, w: 7 m doubles) */
API int floor_chunk(const double* q, long long n, double* out, double* w) {
  long long i;
  int k;
  for (i = 0; i < n; ++i)
    for (k = 0; k < 4; ++k) coordarm_law(q, 1e-4 * i, out, 0, w);
  return 0;
}
"""


#: The benchmark line's turning angle; the same-work floor writes its rate in closed form.
THETA = Sinusoid(0.3, 0.7)
#: Where the law's per-link loops start in the generated source, and where the library API starts.
LOOPS_START, API_START = "/* Links 2..m: frames and centres", "\n#define CA_SCRATCH (CA_RK4_SCRATCH"


def floor_library(m: int, kinematics: bool) -> Path:
    """A spatial floor library for ``m`` links (default flags)."""
    text = FLOOR.replace("{m}", str(m)).replace("{kin}", str(int(kinematics)))
    return build(Source(text, "spatial_floor", m)).path


def floor_timer(m: int, kinematics: bool, q: np.ndarray, steps: int):
    """A callable timing one floor chunk of ``steps`` steps: ns per law call per link."""
    lib = ctypes.CDLL(str(floor_library(m, kinematics)))
    p = ctypes.POINTER(ctypes.c_double)
    lib.floor_chunk.argtypes = [p, ctypes.c_longlong, p, p]
    qc, out, w = np.ascontiguousarray(q, dtype=float), np.zeros(3 * m), np.zeros(7 * m)

    def run() -> float:
        start = time.thread_time()
        lib.floor_chunk(qc.ctypes.data_as(p), steps, out.ctypes.data_as(p), w.ctypes.data_as(p))
        return (time.thread_time() - start) / (4 * steps * m) * 1e9
    return run


def same_work_source(ctrl: SpatialController) -> Source:
    """The law's generated C with its per-link loops replaced by ``spatial_floor_law.c`` (the benchmark's line)."""
    text = generate_spatial_source(ctrl).text
    curve = ctrl.task.curve
    k = np.asarray(curve.axis, dtype=float)
    v = np.column_stack([curve.direction, curve.normal, curve.binormal]).T @ k    # F0^T k
    hand = (Path(__file__).resolve().parent / "spatial_floor_law.c").read_text()
    for key, value in dict(K=ctrl.gain, v0=v[0], v1=v[1], v2=v[2], th_a=THETA.amplitude, th_w=THETA.omega).items():
        hand = hand.replace("{" + key + "}", repr(float(value)))
    start, end = text.index(LOOPS_START), text.index(API_START)
    return Source(text[:start] + hand + text[end:], "spatial_floor_same_work", ctrl.chain.m)


def same_work_timer(ctrl: SpatialController, law: CompiledController, q: np.ndarray, steps: int):
    """A callable timing the same-work floor's chunk (ns per law call per link), checked against the law first."""
    m = ctrl.chain.m
    lib = ctypes.CDLL(str(build(same_work_source(ctrl)).path))
    p, ip = ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_longlong)
    sizes = (ctypes.c_longlong * 4)()
    lib.coordarm_sizes(sizes)
    T = np.arange(steps) * 1e-4
    Q, D = np.zeros((steps, 2 * m)), np.zeros((steps, sizes[1]))
    iw, w = np.zeros(sizes[2], dtype=np.int64), np.zeros(sizes[3])

    def chunk() -> None:
        rc = lib.coordarm_chunk(q.ctypes.data_as(p), T.ctypes.data_as(p), ctypes.c_double(1e-4),
                                ctypes.c_longlong(steps), Q.ctypes.data_as(p), D.ctypes.data_as(p),
                                iw.ctypes.data_as(ip), w.ctypes.data_as(p))
        if rc:
            raise RuntimeError(f"same-work floor: chunk returned {rc}")
    chunk()
    want_Q, want_D = law.chunk(q, T, 1e-4)
    for got, want in ((Q, want_Q), (D, want_D)):
        diff = float(np.max(np.abs(got - want)) / max(1.0, float(np.max(np.abs(want)))))
        if not diff <= 1e-9:
            raise RuntimeError(f"same-work floor differs from the law by {diff:.2e} (relative)")

    def run() -> float:
        start = time.thread_time()
        chunk()
        return (time.thread_time() - start) / (4 * steps * m) * 1e9
    return run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--links", type=int, nargs="+", default=[64, 256, 1024])
    ap.add_argument("--rounds", type=int, default=15)
    args = ap.parse_args()
    print(f"# {os.cpu_count()} CPUs, load {os.getloadavg()}")
    print("| m | law [ns/link] | same-work floor | trig floor | trig + kinematics floor | law / same work: median "
          "(min-max) | law / trig | law / (trig + kinematics) |")
    print("|---|---|---|---|---|---|---|---|")
    for m in args.links:
        chain = SpatialChain(m, 0.1)
        curve = Line3D((0.0, 0.0, 0.0), AXIS, (0.0, 1.0, 0.0), rotation=((0.0, 0.3, 1.0), THETA))
        ctrl = SpatialController(chain, curve, 2.0, 0.1, roll=Sinusoid(0.2, 1.3))
        law = CompiledController(ctrl)
        q = chain.zigzag(1.0, axis=AXIS, fold=(0.0, 1.0, 0.0))
        steps = max(8, 131072 // (4 * m))
        timers = [lambda: per_link_ns(law, q, steps, m), same_work_timer(ctrl, law, q, steps),
                  floor_timer(m, False, q, steps), floor_timer(m, True, q, steps)]
        times = np.array([[timer() for timer in timers] for _ in range(args.rounds)])
        per = np.median(times, axis=0)
        same = times[:, 0] / times[:, 1]
        r2, r3 = np.median(times[:, 0] / times[:, 2]), np.median(times[:, 0] / times[:, 3])
        print(f"| {m} | {per[0]:.1f} | {per[1]:.1f} | {per[2]:.1f} | {per[3]:.1f} | {np.median(same):.2f} "
              f"({same.min():.2f}-{same.max():.2f}) | {r2:.2f} | {r3:.2f} |", flush=True)
    print(f"# load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
