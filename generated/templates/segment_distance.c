/* Distances in 3-D between segments (the capsule axes of a spatial chain and its obstacles) and from
 * points to segments, many at once (loaded by coordarm.generated.segment_distance). Hand-written, no
 * placeholders.
 *
 * Both functions repeat the numpy reference operation by operation, in the same order
 * (simulation.distance3d: point_segment_distance3_numpy and segment_segment_distance_numpy):
 * compiled without contraction (-ffp-contract=off), their distances are the reference's to the last
 * bit. A sum over x, y, z adds in order, as numpy does along a last axis of three.
 *
 * An operand is n points (stride 3 doubles) or one point for all (stride 0). Sizes are long long
 * (64-bit indices, as numpy's). Nothing here allocates.
 */
#include <math.h>

#define DISTANCE_EXPORT __attribute__((visibility("default")))
/* np.minimum (NaN if either is) and np.clip(x, 0, 1) (NaN stays NaN) */
static inline double MIN(double a, double b) { return (a < b || a != a) ? a : b; }
static inline double CLIP01(double x) { return x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x); }
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
