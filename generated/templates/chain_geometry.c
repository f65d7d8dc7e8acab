/* The physical checks' geometry of a planar chain, and a spatial chain's link frames, for many samples at
 * once (loaded by coordarm.generated.chain_geometry). Hand-written, no placeholders.
 *
 * The functions repeat the numpy reference operation by operation, in the same order
 * (PlanarChain.joints_np and symbolic.geometry.self_distances): compiled without contraction
 * (-ffp-contract=off) and with the scalar libm, the joints and the distances are the reference's to
 * the last bit; only the sweep's sort key (the principal axis, whose mean and sums numpy adds
 * pairwise) may differ from it in the last bits, which decides nothing but which far pairs are
 * looked at (every pair closer than the clearance is compared either way).
 *
 * Sizes are long long (64-bit indices, as numpy's). Nothing here allocates but the sweep's
 * scratch, which the caller passes in.
 */
#include <math.h>

#define GEOMETRY_EXPORT __attribute__((visibility("default")))
/* np.minimum and np.maximum of finite numbers (fmin and fmax are library calls without -ffast-math) */
static inline double MIN(double a, double b) { return a < b ? a : b; }
static inline double MAX(double a, double b) { return a > b ? a : b; }

/* Link frames of n configurations of a spatial chain, as symbolic.spatial_chain.link_frames: from the
 * joints' cosines and sines ca, sa, cb, sb (each n x m, numpy's), R_1 = J_1 and R_j = R_{j-1} J_j with
 * J = Rz(a) Ry(b) = [[ca cb, -sa, ca sb], [sa cb, ca, sa sb], [-sb, 0, cb]], each entry p0 q0 + p1 q1 + p2 q2
 * added left to right; R is n x m x 3 x 3, row-major. */
GEOMETRY_EXPORT void coordarm_spatial_frames(const double *ca, const double *sa, const double *cb, const double *sb,
                                             long long n, long long m, double *R) {
  for (long long k = 0; k < n * m; ++k) {
    const long long j = k % m;
    const double J[9] = {ca[k] * cb[k], -sa[k], ca[k] * sb[k], sa[k] * cb[k], ca[k], sa[k] * sb[k], -sb[k], 0.0, cb[k]};
    double *Rk = R + 9 * k;
    if (j == 0) {
      for (int e = 0; e < 9; ++e) Rk[e] = J[e];
      continue;
    }
    const double *P = Rk - 9;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        Rk[3 * r + c] = P[3 * r] * J[c] + P[3 * r + 1] * J[3 + c] + P[3 * r + 2] * J[6 + c];
  }
}

/* Link end points of n configurations: angles q (n x m, the revolute joints), base (n x 2, the first
 * central point), link length xi; joints (n x (m+1) x 2). As PlanarChain.joints_np: alpha = cumsum(q),
 * d = (cos alpha, sin alpha), centres y_1 = base, y_{j+1} = base + cumsum(h (d_j + d_{j+1})), h = xi/2,
 * ends y_1 - h d_1, then y_j + h d_j. */
GEOMETRY_EXPORT void coordarm_chain_joints(const double *q, const double *base, long long n, long long m, double xi,
                                           double *dir, double *joints) {
  const double h = 0.5 * xi;
  for (long long k = 0; k < n; ++k) {
    const double *qk = q + k * m;
    double *jk = joints + k * (m + 1) * 2;
    double alpha = 0.0;
    for (long long j = 0; j < m; ++j) {
      alpha = j ? alpha + qk[j] : qk[j];
      dir[2 * j] = cos(alpha);
      dir[2 * j + 1] = sin(alpha);
    }
    const double bx = base[2 * k], by = base[2 * k + 1];
    double sx = 0.0, sy = 0.0;                   /* cumsum of the steps between centres */
    jk[0] = bx - h * dir[0];
    jk[1] = by - h * dir[1];
    jk[2] = bx + h * dir[0];
    jk[3] = by + h * dir[1];
    for (long long j = 1; j < m; ++j) {
      const double stx = h * (dir[2 * (j - 1)] + dir[2 * j]), sty = h * (dir[2 * (j - 1) + 1] + dir[2 * j + 1]);
      sx = j > 1 ? sx + stx : stx;
      sy = j > 1 ? sy + sty : sty;
      const double cx = bx + sx, cy = by + sy;
      jk[2 * (j + 1)] = cx + h * dir[2 * j];
      jk[2 * (j + 1) + 1] = cy + h * dir[2 * j + 1];
    }
  }
}

static double cross(double ox, double oy, double ax, double ay, double bx, double by) {
  return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox);
}

/* b collinear with o-a (d == 0) and inside its bounding box */
static int on(double ox, double oy, double ax, double ay, double bx, double by, double d) {
  return d == 0 && MIN(ox, ax) <= bx && bx <= MAX(ox, ax) && MIN(oy, ay) <= by && by <= MAX(oy, ay);
}

static double point_segment(double px, double py, double ax, double ay, double bx, double by) {
  const double abx = bx - ax, aby = by - ay;
  const double den = abx * abx + aby * aby;
  double tpar = ((px - ax) * abx + (py - ay) * aby) / (den > 0 ? den : 1.0);
  tpar = tpar < 0.0 ? 0.0 : (tpar > 1.0 ? 1.0 : tpar);
  const double rx = px - (ax + tpar * abx), ry = py - (ay + tpar * aby);
  return sqrt(rx * rx + ry * ry);
}

/* geometry._segment: 0 when the segments cross or touch, else the smallest end-to-segment distance */
static double segment(double p1x, double p1y, double p2x, double p2y, double q1x, double q1y, double q2x, double q2y) {
  const double d1 = cross(q1x, q1y, q2x, q2y, p1x, p1y), d2 = cross(q1x, q1y, q2x, q2y, p2x, p2y);
  const double d3 = cross(p1x, p1y, p2x, p2y, q1x, q1y), d4 = cross(p1x, p1y, p2x, p2y, q2x, q2y);
  if ((d1 * d2 < 0 && d3 * d4 < 0) || on(q1x, q1y, q2x, q2y, p1x, p1y, d1) || on(q1x, q1y, q2x, q2y, p2x, p2y, d2)
      || on(p1x, p1y, p2x, p2y, q1x, q1y, d3) || on(p1x, p1y, p2x, p2y, q2x, q2y, d4))
    return 0.0;
  const double a = MIN(point_segment(p1x, p1y, q1x, q1y, q2x, q2y), point_segment(p2x, p2y, q1x, q1y, q2x, q2y));
  const double b = MIN(point_segment(q1x, q1y, p1x, p1y, p2x, p2y), point_segment(q2x, q2y, p1x, p1y, p2x, p2y));
  return MIN(a, b);
}

/* order[0..m) sorted by key (stable merge sort; tmp holds m more) */
static void merge_sort(const double *key, long long *order, long long *tmp, long long m) {
  for (long long i = 0; i < m; ++i) order[i] = i;
  for (long long width = 1; width < m; width *= 2) {
    for (long long lo = 0; lo < m; lo += 2 * width) {
      long long mid = lo + width < m ? lo + width : m, hi = lo + 2 * width < m ? lo + 2 * width : m;
      long long i = lo, j = mid, o = lo;
      while (i < mid && j < hi) tmp[o++] = key[order[j]] < key[order[i]] ? order[j++] : order[i++];
      while (i < mid) tmp[o++] = order[i++];
      while (j < hi) tmp[o++] = order[j++];
    }
    for (long long i = 0; i < m; ++i) order[i] = tmp[i];
  }
}

/* order[0..m) sorted by key, starting from the order it holds (the previous sample's, nearly sorted for
 * consecutive samples): insertion sort while it moves fewer than 8 m entries, else a merge sort. */
static void sort_by(const double *key, long long *order, long long *tmp, long long m) {
  long long moves = 0;
  for (long long i = 1; i < m; ++i) {
    const long long o = order[i];
    const double v = key[o];
    long long j = i;
    while (j > 0 && v < key[order[j - 1]]) {
      order[j] = order[j - 1];
      --j;
    }
    order[j] = o;
    moves += i - j;
    if (moves > 8 * m) {
      merge_sort(key, order, tmp, m);
      return;
    }
  }
}

/* The pairs of non-adjacent links of n configurations (joints n x (m+1) x 2, all finite) that the
 * sweep compares (symbolic.geometry.self_distances): sorted along the principal axis of the link
 * centres, pairs within reach (longest link + clearance) along it, whose bounding boxes are at most
 * clearance apart. Writes up to cap pairs (sample, link a, link b 1-based with a < b - 1, distance)
 * and returns how many there are (more than cap: call again with room for them). scratch holds
 * 8 m doubles and 2 m long longs (iscratch). */
GEOMETRY_EXPORT long long coordarm_self_distances(const double *joints, long long n, long long m, double clearance,
                                                  long long cap, long long *sample, long long *link_a,
                                                  long long *link_b, double *dist, double *scratch,
                                                  long long *iscratch) {
  if (n <= 0 || m < 3) return 0;
  double longest = 0.0;
  for (long long s = 0; s < n; ++s) {          /* the longest link over every sample, as numpy's max */
    const double *J = joints + s * (m + 1) * 2;
    for (long long j = 0; j < m; ++j) {
      const double dx = J[2 * j + 2] - J[2 * j], dy = J[2 * j + 3] - J[2 * j + 1], l2 = dx * dx + dy * dy;
      longest = l2 > longest ? l2 : longest;
    }
  }
  const double reach = sqrt(longest) + clearance;
  double *cx = scratch, *cy = scratch + m, *x = scratch + 2 * m, *xs = scratch + 3 * m;
  double *lox = scratch + 4 * m, *hix = scratch + 5 * m, *loy = scratch + 6 * m, *hiy = scratch + 7 * m;
  long long *order = iscratch, *tmp = iscratch + m, found = 0;
  for (long long i = 0; i < m; ++i) order[i] = i;
  for (long long s = 0; s < n; ++s) {
    const double *J = joints + s * (m + 1) * 2;
    double mx = 0.0, my = 0.0;
    for (long long j = 0; j < m; ++j) {
      cx[j] = 0.5 * (J[2 * j] + J[2 * j + 2]);
      cy[j] = 0.5 * (J[2 * j + 1] + J[2 * j + 3]);
      mx += cx[j];
      my += cy[j];
    }
    mx /= (double)m;
    my /= (double)m;
    double sxx = 0.0, syy = 0.0, sxy = 0.0;
    for (long long j = 0; j < m; ++j) {
      const double ux = cx[j] - mx, uy = cy[j] - my;
      sxx += ux * ux;
      syy += uy * uy;
      sxy += ux * uy;
    }
    const double th = 0.5 * atan2(2 * sxy, sxx - syy), c = cos(th), sn = sin(th);
    for (long long j = 0; j < m; ++j) x[j] = (cx[j] - mx) * c + (cy[j] - my) * sn;
    sort_by(x, order, tmp, m);
    for (long long i = 0; i < m; ++i) {
      const long long o = order[i];
      const double *a = J + 2 * o;
      xs[i] = x[o];
      lox[i] = MIN(a[0], a[2]);
      hix[i] = MAX(a[0], a[2]);
      loy[i] = MIN(a[1], a[3]);
      hiy[i] = MAX(a[1], a[3]);
    }
    for (long long i = 0; i < m; ++i) {
      for (long long j = i + 1; j < m && xs[j] - xs[i] <= reach; ++j) {
        const long long a = order[i] < order[j] ? order[i] : order[j], b = order[i] < order[j] ? order[j] : order[i];
        if (b - a < 2) continue;
        const double gap = MAX(MAX(lox[j] - hix[i], lox[i] - hix[j]), MAX(loy[j] - hiy[i], loy[i] - hiy[j]));
        if (!(gap <= clearance)) continue;
        if (found < cap) {
          const double *p = J + 2 * a, *q = J + 2 * b;
          sample[found] = s;
          link_a[found] = a + 1;
          link_b[found] = b + 1;
          dist[found] = segment(p[0], p[1], p[2], p[3], q[0], q[1], q[2], q[3]);
        }
        ++found;
      }
    }
  }
  return found;
}

/* The pairs of non-adjacent links of n configurations of a spatial chain whose axis-aligned boxes (lo, hi:
 * n x m x 3, all finite) come within reach of each other along all three axes, the set
 * simulation.physical3d.close_pairs_numpy finds (the same comparisons; here in the order of a sweep along the
 * axis of the body's largest extent). Writes up to cap pairs (sample, link a, link b, 0-based, a < b - 1) and
 * returns how many there are (more than cap: call again with room for them). scratch holds m doubles,
 * iscratch 2 m long longs. */
GEOMETRY_EXPORT long long coordarm_close_pairs3d(const double *lo, const double *hi, long long n, long long m,
                                                 double reach, long long cap, long long *sample, long long *link_a,
                                                 long long *link_b, double *scratch, long long *iscratch) {
  double *key = scratch;
  long long *order = iscratch, *tmp = iscratch + m, found = 0;
  for (long long i = 0; i < m; ++i) order[i] = i;
  for (long long s = 0; s < n; ++s) {
    const double *L = lo + s * m * 3, *H = hi + s * m * 3;
    double bl[3] = {L[0], L[1], L[2]}, bh[3] = {H[0], H[1], H[2]};
    for (long long j = 1; j < m; ++j)
      for (int c = 0; c < 3; ++c) {
        bl[c] = MIN(bl[c], L[3 * j + c]);
        bh[c] = MAX(bh[c], H[3 * j + c]);
      }
    int ax = 0;
    for (int c = 1; c < 3; ++c)
      if (bh[c] - bl[c] > bh[ax] - bl[ax]) ax = c;
    for (long long j = 0; j < m; ++j) key[j] = L[3 * j + ax];
    sort_by(key, order, tmp, m);                 /* (the order of the sample before: nearly sorted) */
    for (long long i = 0; i < m; ++i) {
      const long long oi = order[i];
      const double *Li = L + 3 * oi, *Hi = H + 3 * oi;
      for (long long jj = i + 1; jj < m && key[order[jj]] <= Hi[ax] + reach; ++jj) {
        const long long oj = order[jj], a = oi < oj ? oi : oj, b = oi < oj ? oj : oi;
        if (b - a < 2) continue;
        const double *Lj = L + 3 * oj, *Hj = H + 3 * oj;
        if (!(Lj[0] <= Hi[0] + reach && Li[0] <= Hj[0] + reach && Lj[1] <= Hi[1] + reach && Li[1] <= Hj[1] + reach
              && Lj[2] <= Hi[2] + reach && Li[2] <= Hj[2] + reach))
          continue;
        if (found < cap) {
          sample[found] = s;
          link_a[found] = a;
          link_b[found] = b;
        }
        ++found;
      }
    }
  }
  return found;
}

/* Distance from every link of n configurations of a planar chain (joints n x (m+1) x 2, all finite) to the
 * nearest of e edges (edges e x 2 x 2), as simulation.obstacles.link_distances: the smallest
 * geometry._segment distance over the edges (an edge whose box is farther from the link's box than the
 * smallest distance so far, by a margin far above rounding, is skipped: it cannot be nearer), then 0 where the link's first end lies inside the
 * polygon poly (k corners; k = 0: no polygon), by the same ray casting as obstacles.inside_polygon. out is
 * n x m. */
GEOMETRY_EXPORT void coordarm_edge_distances(const double *joints, long long n, long long m, const double *edges,
                                             long long e, const double *poly, long long k, double *out) {
  for (long long s = 0; s < n; ++s) {
    const double *J = joints + s * (m + 1) * 2;
    for (long long j = 0; j < m; ++j) {
      const double *a = J + 2 * j, *b = a + 2;
      const double lox = MIN(a[0], b[0]), hix = MAX(a[0], b[0]), loy = MIN(a[1], b[1]), hiy = MAX(a[1], b[1]);
      double d = INFINITY;
      for (long long i = 0; i < e; ++i) {
        const double *p = edges + 4 * i, *q = p + 2;
        const double gx = MAX(MAX(MIN(p[0], q[0]) - hix, lox - MAX(p[0], q[0])), 0.0);
        const double gy = MAX(MAX(MIN(p[1], q[1]) - hiy, loy - MAX(p[1], q[1])), 0.0);
        if (gx * gx + gy * gy > d * d * (1 + 1e-9)) continue;   /* its box is farther than d: so is the edge */
        const double di = segment(a[0], a[1], b[0], b[1], p[0], p[1], q[0], q[1]);
        d = di < d ? di : d;
      }
      if (k > 0) {
        int inside = 0;
        const double x = a[0], y = a[1];
        for (long long c = 0; c < k; ++c) {
          const double x1 = poly[2 * c], y1 = poly[2 * c + 1];
          const double x2 = poly[2 * ((c + 1) % k)], y2 = poly[2 * ((c + 1) % k) + 1];
          if (y1 == y2) continue;
          const int crosses = (y1 > y) != (y2 > y);
          const double xint = x1 + (y - y1) * (x2 - x1) / (y2 - y1);
          inside ^= crosses & (x < xint);
        }
        if (inside) d = 0.0;
      }
      out[s * m + j] = d;
    }
  }
}
