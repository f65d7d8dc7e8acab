/* Distances in 3-D from segments (the capsule axes of a spatial chain) to segments, points, boxes and
 * plates with holes, many at once (loaded by coordarm.generated.segment_distance). Hand-written, no
 * placeholders.
 *
 * Every function repeats its numpy reference operation by operation, in the same order
 * (simulation.distance3d: point_segment_distance3_numpy, segment_segment_distance_numpy,
 * segment_box_distance_numpy, plate_search_numpy): compiled without contraction (-ffp-contract=off),
 * their distances are the reference's to the last bit. A sum over x, y, z adds in order, as numpy does
 * along a last axis of three; np.maximum / np.minimum / np.clip keep a NaN, as numpy's do.
 *
 * An operand is n points (stride 3 doubles) or one point for all (stride 0). Sizes are long long
 * (64-bit indices, as numpy's). Nothing here allocates.
 */
#include <math.h>

#define DISTANCE_EXPORT __attribute__((visibility("default")))
/* np.minimum (NaN if either is) and np.clip(x, 0, 1) (NaN stays NaN) */
static inline double MIN(double a, double b) { return (a < b || a != a) ? a : b; }
static inline double CLIP01(double x) { return x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x); }
/* np.maximum(x, 0) */
static inline double POS(double x) { return (x >= 0.0 || x != x) ? x : 0.0; }
/* np.clip(np.nan_to_num(x, nan=0, posinf=0, neginf=0), 0, 1): a segment's parameter where it crosses a plane */
static inline double BREAK(double x) { return isfinite(x) ? CLIP01(x) : 0.0; }
/* np.sign */
static inline double SIGN(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : (x == 0.0 ? 0.0 : x)); }
/* np.sum(u * v, axis=-1) of 3-vectors */
static inline double DOT(const double *u, const double *v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; }

/* |p - (a + s ab)|, s = clip((p - a).ab / (ab.ab or 1), 0, 1): point_segment_distance3_numpy */
static double point_segment(const double *p, const double *a, const double *b) {
  const double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double pa[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
  const double den = DOT(ab, ab);
  const double s = CLIP01(DOT(pa, ab) / (den > 0 ? den : 1.0));
  const double w[3] = {p[0] - (a[0] + s * ab[0]), p[1] - (a[1] + s * ab[1]), p[2] - (a[2] + s * ab[2])};
  return sqrt(DOT(w, w));
}

/* segment_segment_distance_numpy: the lines' closest parameters clamped (s, then t, then s again), that
 * pair's distance, and the four end-to-segment distances */
static double segment_segment(const double *p1, const double *p2, const double *q1, const double *q2) {
  const double d1[3] = {p2[0] - p1[0], p2[1] - p1[1], p2[2] - p1[2]};
  const double d2[3] = {q2[0] - q1[0], q2[1] - q1[1], q2[2] - q1[2]};
  const double r[3] = {p1[0] - q1[0], p1[1] - q1[1], p1[2] - q1[2]};
  const double a = DOT(d1, d1), e = DOT(d2, d2), b = DOT(d1, d2), c = DOT(d1, r), f = DOT(d2, r);
  const double a1 = a > 0 ? a : 1.0, e1 = e > 0 ? e : 1.0;
  const double den = a * e - b * b;
  const int ok = den > 1e-14 * a * e;
  double s = ok ? CLIP01((b * f - c * e) / den) : 0.0;
  const double t = (b * s + f) / e1;
  s = t < 0 ? CLIP01(-c / a1) : (t > 1 ? CLIP01((b - c) / a1) : s);
  const double tc = CLIP01(t);
  const double w[3] = {r[0] + s * d1[0] - tc * d2[0], r[1] + s * d1[1] - tc * d2[1], r[2] + s * d1[2] - tc * d2[2]};
  const double inner = sqrt(DOT(w, w));
  const double ends = MIN(MIN(point_segment(p1, q1, q2), point_segment(p2, q1, q2)),
                          MIN(point_segment(q1, p1, p2), point_segment(q2, p1, p2)));
  return MIN(inner, ends);
}

/* out[k] = distance between segments p1p2 and q1q2 of item k (strides in doubles: 3, or 0 for one point) */
DISTANCE_EXPORT void coordarm_segment_segment(long long n, const double *p1, long long s1, const double *p2,
                                              long long s2, const double *q1, long long s3, const double *q2,
                                              long long s4, double *out) {
  for (long long k = 0; k < n; ++k)
    out[k] = segment_segment(p1 + k * s1, p2 + k * s2, q1 + k * s3, q2 + k * s4);
}

/* out[k] = distance from point p to segment ab of item k (strides as above) */
DISTANCE_EXPORT void coordarm_point_segment(long long n, const double *p, long long sp, const double *a, long long sa,
                                            const double *b, long long sb, double *out) {
  for (long long k = 0; k < n; ++k)
    out[k] = point_segment(p + k * sp, a + k * sa, b + k * sb);
}

/* ascending, in place (a handful of values: insertion sort; no NaN here, so np.sort's order) */
static void sort_small(double *x, long long n) {
  for (long long i = 1; i < n; ++i) {
    const double v = x[i];
    long long j = i - 1;
    while (j >= 0 && x[j] > v) { x[j + 1] = x[j]; --j; }
    x[j + 1] = v;
  }
}

/* segment_box_distance_numpy from the ends in the box's frame: pa = a - centre and pd = b - a, both along the
 * box's axes, half = the half edges. The squared distance along the segment is a convex piecewise quadratic
 * whose pieces end where a coordinate crosses +-half; each piece's vertex (clipped to it), its middle when
 * flat, and the breaks are the candidates. */
static double segment_box(const double *pa, const double *pd, const double *h) {
  double S[8], cand[15];
  S[0] = 0.0;
  S[1] = 1.0;
  for (int k = 0; k < 3; ++k) {
    S[2 + k] = BREAK((h[k] - pa[k]) / pd[k]);
    S[5 + k] = BREAK((-h[k] - pa[k]) / pd[k]);
  }
  sort_small(S, 8);
  for (int i = 0; i < 8; ++i) cand[i] = S[i];
  for (int i = 0; i < 7; ++i) {
    const double lo = S[i], hi = S[i + 1], mid = 0.5 * (lo + hi);
    double t[3], d[3];
    for (int k = 0; k < 3; ++k) {
      const double pm = pa[k] + mid * pd[k];
      const int out = fabs(pm) > h[k];
      t[k] = out ? pd[k] * (pa[k] - SIGN(pm) * h[k]) : 0.0;
      d[k] = out ? pd[k] * pd[k] : 0.0;
    }
    const double num = t[0] + t[1] + t[2], den = d[0] + d[1] + d[2];
    double vertex = -num / (den > 0 ? den : 1.0);
    vertex = vertex < lo ? lo : (vertex > hi ? hi : vertex);           /* np.clip(vertex, lo, hi) */
    cand[8 + i] = den > 0 ? vertex : mid;
  }
  double best = 0.0;
  for (int i = 0; i < 15; ++i) {
    double g[3];
    for (int k = 0; k < 3; ++k) {
      const double e = POS(fabs(pa[k] + cand[i] * pd[k]) - h[k]);
      g[k] = e * e;
    }
    const double gi = g[0] + g[1] + g[2];
    best = i == 0 ? gi : MIN(best, gi);
  }
  return sqrt(best);
}

/* out[k] = distance from segment k (pa, pd in the box's frame, n x 3) to the box of half edges half */
DISTANCE_EXPORT void coordarm_segment_box(long long n, const double *pa, const double *pd, const double *half,
                                          double *out) {
  for (long long k = 0; k < n; ++k) out[k] = segment_box(pa + 3 * k, pd + 3 * k, half);
}

/* A plate in its frame (u, v in plane, w along the normal): the slab |w| <= ht, the square |u|, |v| <= ext
 * (ext = inf: the whole plane), minus holes: kind 0 a circle (cu, cv, radius, -), 1 a rectangle
 * (cu, cv, half width, half height), 4 numbers each in hole. */
typedef struct {
  double ht, ext;
  long long holes;
  const long long *kind;
  const double *hole;
} plate;

/* plate_point_distance of the point pa + s pd */
static double plate_point(const plate *P, const double *pa, const double *pd, double s) {
  const double u = pa[0] + s * pd[0], v = pa[1] + s * pd[1], w = pa[2] + s * pd[2];
  const double dw = POS(fabs(w) - P->ht);
  double delta = isfinite(P->ext) ? hypot(POS(fabs(u) - P->ext), POS(fabs(v) - P->ext)) : 0.0;
  for (long long i = 0; i < P->holes; ++i) {
    const double *c = P->hole + 4 * i;
    const double du = u - c[0], dv = v - c[1];
    if (P->kind[i] == 0) {
      delta = delta + POS(c[2] - hypot(du, dv));
    } else {
      delta = delta + POS(MIN(c[2] - fabs(du), c[3] - fabs(dv)));
    }
  }
  return hypot(delta, dw);
}

/* _plate_breaks: where the segment crosses the slab's faces, the square's edges, a rectangle's edges and
 * diagonals and a circle's rim, into S (how many: see plate_break_count in segment_distance.py) */
static long long plate_breaks(const plate *P, const double *pa, const double *pd, double *S) {
  long long n = 0;
  S[n++] = BREAK((P->ht - pa[2]) / pd[2]);
  S[n++] = BREAK((-P->ht - pa[2]) / pd[2]);
  if (isfinite(P->ext)) {
    S[n++] = BREAK((P->ext - pa[0]) / pd[0]);
    S[n++] = BREAK((-P->ext - pa[0]) / pd[0]);
    S[n++] = BREAK((P->ext - pa[1]) / pd[1]);
    S[n++] = BREAK((-P->ext - pa[1]) / pd[1]);
  }
  for (long long i = 0; i < P->holes; ++i) {
    const double *c = P->hole + 4 * i;
    if (P->kind[i] == 0) {
      const double ou = pa[0] - c[0], ov = pa[1] - c[1];
      const double A = pd[0] * pd[0] + pd[1] * pd[1];
      const double B = 2 * (ou * pd[0] + ov * pd[1]);
      const double C = ou * ou + ov * ov - c[2] * c[2];
      const double root = sqrt(POS(B * B - 4 * A * C));
      S[n++] = BREAK((-B - root) / (2 * A));
      S[n++] = BREAK((-B + root) / (2 * A));
    } else {
      S[n++] = BREAK(((c[0] + c[2]) - pa[0]) / pd[0]);
      S[n++] = BREAK(((c[0] - c[2]) - pa[0]) / pd[0]);
      S[n++] = BREAK(((c[1] + c[3]) - pa[1]) / pd[1]);
      S[n++] = BREAK(((c[1] - c[3]) - pa[1]) / pd[1]);
      const double du = pa[0] - c[0], dv = pa[1] - c[1];
      for (int j = 0; j < 2; ++j) {
        const double sv = j == 0 ? 1.0 : -1.0;
        S[n++] = BREAK(((c[2] - c[3]) - du + sv * dv) / (pd[0] - sv * pd[1]));
        S[n++] = BREAK(((c[3] - c[2]) - du + sv * dv) / (pd[0] - sv * pd[1]));
      }
    }
  }
  return n;
}

/* plate_search_numpy for one segment: the distance at the ends of every piece between breaks and a
 * golden-section minimum inside each; S holds 2 + the breaks' count */
static double plate_search(const plate *P, const double *pa, const double *pd, long long steps, double *S) {
  const double g = 0.5 * (sqrt(5.0) - 1.0);
  S[0] = 0.0;
  S[1] = 1.0;
  const long long n = 2 + plate_breaks(P, pa, pd, S + 2);
  sort_small(S, n);
  double best = plate_point(P, pa, pd, S[0]);
  for (long long i = 1; i < n; ++i) best = MIN(best, plate_point(P, pa, pd, S[i]));
  double inner = 0.0;
  for (long long i = 0; i + 1 < n; ++i) {
    double lo = S[i], hi = S[i + 1];
    double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    double f1 = plate_point(P, pa, pd, x1), f2 = plate_point(P, pa, pd, x2);
    for (long long k = 0; k < steps; ++k) {
      if (f1 <= f2) hi = x2; else lo = x1;
      x1 = hi - g * (hi - lo);
      x2 = lo + g * (hi - lo);
      f1 = plate_point(P, pa, pd, x1);
      f2 = plate_point(P, pa, pd, x2);
    }
    inner = i == 0 ? MIN(f1, f2) : MIN(inner, MIN(f1, f2));
  }
  return MIN(best, inner);
}

/* out[k] = distance from segment k (pa, pd in the plate's frame, n x 3) to the plate; work holds
 * 2 + the breaks' count doubles */
DISTANCE_EXPORT void coordarm_segment_plate(long long n, const double *pa, const double *pd, double half_thickness,
                                            double extent, long long holes, const long long *kind,
                                            const double *hole, long long steps, double *work, double *out) {
  const plate P = {half_thickness, extent, holes, kind, hole};
  for (long long k = 0; k < n; ++k) out[k] = plate_search(&P, pa + 3 * k, pd + 3 * k, steps, work);
}
