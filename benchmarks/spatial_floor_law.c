/* The same-work floor of the compiled spatial law (benchmarks/spatial_floor.py): the per-link loops of
   generated/templates/spatial_law.c written by hand, the same passes, data layout and arithmetic
   (forward kinematics, link pivots, rates, joints), for the benchmark's line: through the origin,
   turning about the fixed axis k by theta(t) = TH_A sin(TH_W t), so that in the line's frame the rate
   of Phi at a fixed point is -theta' (v2 y0 - v0 y2, v0 y1 - v1 y0) with the constant v = F0^T k.
   The time features, the heads, the end solve and the end margin (once per call) are the generated ones;
   as in the law, the later stages of an RK4 step (CA_LAW_STAGE) skip e^j and the margins. {NAME} are
   filled in by spatial_floor.py. */
#define FL_K {K}
#define FL_V0 {v0}
#define FL_V1 {v1}
#define FL_V2 {v2}
#define FL_TH_A {th_a}
#define FL_TH_W {th_w}

typedef double fl_v4 __attribute__((vector_size(32)));
static void fl_kinematics(const double* restrict c, const double* restrict s, const double* restrict kin,
                          double* restrict G) {
  fl_v4 r0 = {kin[0], kin[1], kin[2], 0}, r1 = {kin[3], kin[4], kin[5], 0}, r2 = {kin[6], kin[7], kin[8], 0};
  fl_v4 y = {kin[9], kin[10], kin[11], 0};
  long long j;
  for (j = 1; j < CA_M; ++j) {
    double ca = c[j], sa = s[j], cb = c[CA_M + j], sb = s[CA_M + j];
    fl_v4 a = ca * r0 + sa * r1, n1 = ca * r1 - sa * r0;                  /* R Rz(a) = (a, n1, r2) */
    fl_v4 n0 = cb * a - sb * r2, n2 = sb * a + cb * r2;                   /* then Ry(b) */
    y += CA_HALF_XI * (r0 + n0);
    G[j] = n1[0]; G[CA_MS + j] = n1[1]; G[2 * CA_MS + j] = n1[2];
    G[3 * CA_MS + j] = n2[0]; G[4 * CA_MS + j] = n2[1]; G[5 * CA_MS + j] = n2[2];
    G[6 * CA_MS + j] = y[0]; G[7 * CA_MS + j] = y[1]; G[8 * CA_MS + j] = y[2];
    r0 = n0; r1 = n1; r2 = n2;
  }
}

static double fl_sigma(double a, double b, double c, double d, int largest) {
  double F = a * a + b * b + c * c + d * d, D = fabs(a * d - b * c), gap = F - 2 * D;
  double plus = sqrt(F + 2 * D), minus = sqrt(0.5 * (gap + fabs(gap)));
  return largest ? 0.5 * (plus + minus) : 0.5 * (plus - minus);
}

static inline __attribute__((always_inline)) void fl_pivots(const double* restrict G, double thd,
                                                             double* restrict Pv, double* restrict out,
                                                             const int full) {
  long long j;
  for (j = 1; j < CA_M; ++j) {
    double e00 = G[j], p00 = G[CA_MS + j], p10 = G[2 * CA_MS + j];
    double e01 = G[3 * CA_MS + j], p01 = G[4 * CA_MS + j], p11 = G[5 * CA_MS + j];
    double y0 = G[6 * CA_MS + j], y1 = G[7 * CA_MS + j], y2 = G[8 * CA_MS + j];
    double inv = 1 / (p00 * p11 - p01 * p10);
    double n00 = -p11 * inv, n01 = p01 * inv, n10 = p10 * inv, n11 = -p00 * inv;          /* -P^-1 */
    Pv[j] = FL_K * y1 - thd * (FL_V2 * y0 - FL_V0 * y2);
    Pv[CA_MS + j] = FL_K * y2 - thd * (FL_V0 * y1 - FL_V1 * y0);
    Pv[2 * CA_MS + j] = n00; Pv[3 * CA_MS + j] = n10; Pv[4 * CA_MS + j] = n01; Pv[5 * CA_MS + j] = n11;
    Pv[6 * CA_MS + j] = 2 * (e00 * n00 + e01 * n10); Pv[7 * CA_MS + j] = 2 * (e00 * n01 + e01 * n11);
    if (full) {
      out[CA_OUT_E + 2 * (j - 1)] = y1; out[CA_OUT_E + 2 * (j - 1) + 1] = y2;
      out[CA_OUT_LINK_MARGINS + j - 1] = fl_sigma(p00, p10, p01, p11, 0);
    }
  }
}

static void fl_rates(const double* restrict Pv, double* restrict A, double* restrict W) {
  double a0 = A[0], b00 = A[1], b01 = A[2], a1 = A[3], b10 = A[4], b11 = A[5], a2 = A[6], b20 = A[7], b21 = A[8];
  long long j;
  for (j = 1; j < CA_M; ++j) {
    double r0 = Pv[j], r1 = Pv[CA_MS + j], n00 = Pv[2 * CA_MS + j], n10 = Pv[3 * CA_MS + j];
    double n01 = Pv[4 * CA_MS + j], n11 = Pv[5 * CA_MS + j], m0 = Pv[6 * CA_MS + j], m1 = Pv[7 * CA_MS + j];
    double g00 = b00 + r0, g01 = b01 + r1;
    W[j] = n00 * g00 + n01 * g01; W[CA_MS + j] = n10 * g00 + n11 * g01;
    W[2 * CA_MS + j] = n00 * b10 + n01 * b11; W[3 * CA_MS + j] = n10 * b10 + n11 * b11;
    W[4 * CA_MS + j] = n00 * b20 + n01 * b21; W[5 * CA_MS + j] = n10 * b20 + n11 * b21;
    a0 += m0 * g00 + m1 * g01; a1 += m0 * b10 + m1 * b11; a2 += m0 * b20 + m1 * b21;
    b00 = -b00 - 2 * r0; b01 = -b01 - 2 * r1; b10 = -b10; b11 = -b11; b20 = -b20; b21 = -b21;
  }
  A[0] = a0; A[1] = b00; A[2] = b01; A[3] = a1; A[4] = b10; A[5] = b11; A[6] = a2; A[7] = b20; A[8] = b21;
}

static void fl_joints(const double* restrict c, const double* restrict s, const double* restrict ic,
                      const double* restrict W, const double* restrict p, double* restrict total,
                      double* restrict u, double* restrict out, double* restrict J, int full) {
  double *w1 = J, *w2 = w1 + CA_MS, *al = w2 + CA_MS, *be = al + CA_MS, *nrm = be + CA_MS, *x = nrm + CA_MS;
  double sum = *total;
  long long j;
  w1[0] = 0; w2[0] = 0; w1[1] = p[0]; w2[1] = p[1]; nrm[0] = 0;
  for (j = 1; j < CA_M; ++j) {
    w1[j + 1] = (W[j] + W[2 * CA_MS + j] * p[0] + W[4 * CA_MS + j] * p[1]) * (1 / CA_HALF_XI);
    w2[j + 1] = (W[CA_MS + j] + W[3 * CA_MS + j] * p[0] + W[5 * CA_MS + j] * p[1]) * (1 / CA_HALF_XI);
  }
  for (j = 1; full && j < CA_M; ++j)
    nrm[j] = fl_sigma(W[2 * CA_MS + j], W[3 * CA_MS + j], W[4 * CA_MS + j], W[5 * CA_MS + j], 1) * (1 / CA_HALF_XI);
  for (j = 0; j < CA_M; ++j) {
    al[j] = ic[j] * c[j];
    be[j] = ic[j] * (s[j] * -w2[j] - s[CA_M + j] * w1[j + 1]);
  }
  x[0] = 0;
  if (full) {
    for (j = 0; j + 1 < CA_M; j += 2) {
      x[j + 1] = al[j] * x[j] + be[j];
      x[j + 2] = (al[j + 1] * al[j]) * x[j] + (al[j + 1] * be[j] + be[j + 1]);
      sum += nrm[j] + nrm[j + 1];
    }
    if (j < CA_M) {
      x[j + 1] = al[j] * x[j] + be[j];
      sum += nrm[j];
    }
    *total = sum;
  } else {
    for (j = 0; j + 1 < CA_M; j += 2) {
      x[j + 1] = al[j] * x[j] + be[j];
      x[j + 2] = (al[j + 1] * al[j]) * x[j] + (al[j + 1] * be[j] + be[j + 1]);
    }
    if (j < CA_M) x[j + 1] = al[j] * x[j] + be[j];
  }
  for (j = 0; j < CA_M; ++j) {
    double ca = c[j], sa = s[j], cb = c[CA_M + j], sb = s[CA_M + j];
    double v0 = ca * x[j] - sa * w2[j], v1 = -ca * w2[j] - sa * x[j];
    u[2 * j + 1] = -w2[j + 1] - v1;
    u[2 * j] = (w1[j + 1] - (sb * v0 + cb * w1[j])) * ic[j];
    out[CA_OUT_JOINT_MARGINS + j] = fabs(cb);
  }
}

static int fl_law_mode(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out, casadi_int* iw,
                       casadi_real* w, int full) {
  casadi_real wt[CA_NW + 1], kin[CA_NKC], carry[CA_NRC], total, row[2], rhs, scale, p[2], geo[CA_NG], v[6], srow[2];
  casadi_real *ang = w + CA_SZ_W + CA_RK4_SCRATCH, *c = ang + 2 * CA_MS, *s = c + 2 * CA_MS, *ic = s + 2 * CA_MS;
  casadi_real *W = ic + CA_MS, *G = W + 6 * CA_MS, *Pv = G + CA_NG * CA_MS, *memo = Pv + CA_NPV * CA_MS;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int k;
  if (full || memcmp(&t, memo, sizeof t) != 0) {      /* as the law: the third stage reuses the second's */
    arg[0] = &t; res[0] = memo + 1;
    if (spatial_time_features(arg, res, iw, w, 0)) return 2;
    memo[0] = t;
  }
  for (k = 0; k < CA_NW; ++k) wt[k] = memo[k + 1];
  ca_spatial_trig(q, ang, c, s, ic);
  arg[0] = c; arg[1] = s; arg[2] = c + CA_M; arg[3] = s + CA_M; arg[4] = wt; res[0] = kin;
  if (spatial_kinematics_head(arg, res, iw, w, 0)) return 2;
  fl_kinematics(c, s, kin, G);
  res[0] = carry; res[1] = &total; res[2] = out + CA_OUT_ROLL; res[3] = row; res[4] = &rhs; res[5] = &scale;
  if (spatial_rates_head(arg, res, iw, w, 0)) return 2;
  if (full) fl_pivots(G, FL_TH_A * FL_TH_W * cos(FL_TH_W * t), Pv, out, 1);
  else fl_pivots(G, FL_TH_A * FL_TH_W * cos(FL_TH_W * t), Pv, out, 0);
  fl_rates(Pv, carry, W);
  for (k = 0; k < CA_NG; ++k) geo[k] = G[k * CA_MS + CA_M - 1];
  for (k = 0; k < 6; ++k) v[k] = W[k * CA_MS + CA_M - 1];
  arg[0] = geo; arg[1] = carry; arg[2] = v; arg[3] = wt; arg[4] = row; arg[5] = &rhs;
  res[0] = out + CA_OUT_S; res[1] = p; res[2] = srow;
  if (spatial_frame_tail(arg, res, iw, w, 0)) return 2;
  fl_joints(c, s, ic, W, p, &total, u, out, Pv, full);
  if (!full) return 0;
  arg[0] = srow; arg[1] = row; arg[2] = &scale; arg[3] = &total; res[0] = out + CA_OUT_END_MARGIN;
  return spatial_end_margin(arg, res, iw, w, 0) ? 2 : 0;
}

static int ca_law(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out, casadi_int* iw,
                  casadi_real* w) {
  return fl_law_mode(q, t, u, out, iw, w, 1);
}

static inline int ca_law_stage(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out,
                               casadi_int* iw, casadi_real* w) {
  return fl_law_mode(q, t, u, out, iw, w, 0);
}
#define CA_LAW_STAGE ca_law_stage
