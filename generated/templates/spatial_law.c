/* The spatial law (universal joints, q = (a_1, b_1, ..., a_m, b_m)): every joint angle's cosine and
   sine in vectorised loops, then O(m) loops over links: the forward kinematics (frames and centres,
   storing each link's geometry), the link pivots (independent, vectorised), the rates (the affine
   link rates, carrying A only), and after the 2x2 end solve for w_1 = p, the joint rates (vectorised
   but for one multiply-add per joint in sequence). Each sequential loop's carry fits the registers.
   On a rail (CA_RAIL = 1, the feed axis) q = (d, a_1, b_1, ...) and u = (d_dot, ...): the heads take d
   (the rates head also the end's centre y^m, for the span), the rest reads the angles at q + 1 and
   writes the rates at u + 1. */
#if defined(__x86_64__) && defined(__GLIBC__) && defined(__GNUC__) && !defined(__clang__) \
    && __GNUC__ >= 6 && !defined(__FAST_MATH__) && !defined(COORDARM_SCALAR_TRIG)
#if __GLIBC_PREREQ(2, 22)
#define COORDARM_VECTOR_TRIG 1
__attribute__((simd("notinbranch"))) double cos(double);
__attribute__((simd("notinbranch"))) double sin(double);
#endif
#endif

#if defined(__GNUC__)
#define CA_NOINLINE __attribute__((noinline))
#else
#define CA_NOINLINE
#endif

#if defined(__GNUC__)
#define CA_NONNULL(...) __attribute__((nonnull(__VA_ARGS__)))
#else
#define CA_NONNULL(...)
#endif

/* Per-link arrays are CA_MS doubles apart: at least CA_M + 1 and an odd number of 64-byte lines, so
   that the arrays a loop reads side by side do not fall into the same L1 sets (CA_M = 1024 would put
   them 8 KiB apart: every one in the same set). */
#define CA_MS ((((CA_M + 8) / 8) | 1) * 8)
/* scratch: the angles (a_1..a_m, b_1..b_m), their cosines and sines (2 arrays each), 1 / cos b_j, and
   per link (one array per quantity): xi/2 (W0_j, vec W1_j) (6), the geometry (vec E_j, y^j) (CA_NG),
   the pivot's outputs for the rates (CA_NPV: 8 on a line, else 12 or 18; after the rates, the joint
   loop's 6 arrays), then the time at which the time features were last evaluated and the features */
#define CA_LAW_SCRATCH ((13 + CA_NG + CA_NPV) * CA_MS + CA_NW + 2)

/* ang = (a_1..a_m, b_1..b_m), then c = cos(ang), s = sin(ang), ic = 1 / cos(b): independent iterations.
   Vectorised (libmvec) as separate loops, since gcc would fuse one loop's cos and sin into a scalar sincos. */
static void ca_spatial_trig(const casadi_real* restrict q, casadi_real* restrict ang, casadi_real* restrict c,
                            casadi_real* restrict s, casadi_real* restrict ic) {
  casadi_int j;
  for (j = 0; j < CA_M; ++j) {
    ang[j] = q[2 * j];
    ang[CA_M + j] = q[2 * j + 1];
  }
#ifdef COORDARM_VECTOR_TRIG
  for (j = 0; j < 2 * CA_M; ++j) c[j] = cos(ang[j]);
  for (j = 0; j < 2 * CA_M; ++j) s[j] = sin(ang[j]);
#else
  for (j = 0; j < 2 * CA_M; ++j) {
    c[j] = cos(ang[j]);
    s[j] = sin(ang[j]);
  }
#endif
  for (j = 0; j < CA_M; ++j) ic[j] = 1 / c[CA_M + j];
}

/* Links 2..m: frames and centres from link 1's carry kin; quantity k of link j's geometry
   (vec E_j, y^j) to G[k CA_MS + j]. With GNU C the frame's columns and the centre are 4-vectors (the
   fourth lane unused), R Rz(a_j) Ry(b_j) and y^j as in spatial_kinematics_step: the carry stays in four
   registers (the scalar step's twelve doubles spill, and its chain through the frame is longer); else
   (or with COORDARM_SCALAR_KINEMATICS) the generated step, inlined, its carry copied back. */
#if defined(__GNUC__) && !defined(COORDARM_SCALAR_KINEMATICS)
typedef casadi_real ca_v4 __attribute__((vector_size(4 * sizeof(casadi_real))));
CA_NOINLINE static int ca_spatial_kinematics(const casadi_real* restrict c, const casadi_real* restrict s,
                                             const casadi_real* restrict kin, casadi_real* restrict G,
                                             casadi_int* iw, casadi_real* w) {
  ca_v4 r0 = {kin[0], kin[1], kin[2], 0}, r1 = {kin[3], kin[4], kin[5], 0}, r2 = {kin[6], kin[7], kin[8], 0};
  ca_v4 y = {kin[9], kin[10], kin[11], 0}, a, n0, n1, n2;
  casadi_int j;
  (void)iw; (void)w;
  for (j = 1; j < CA_M; ++j) {
    const casadi_real ca = c[j], sa = s[j], cb = c[CA_M + j], sb = s[CA_M + j];
    a = ca * r0 + sa * r1;             /* R Rz(a) = (a, n1, r2) */
    n1 = ca * r1 - sa * r0;
    n0 = cb * a - sb * r2;             /* then Ry(b) = (n0, n1, n2) */
    n2 = sb * a + cb * r2;
    y = y + CA_HALF_XI * (r0 + n0);
    G[j] = n1[0]; G[CA_MS + j] = n1[1]; G[2 * CA_MS + j] = n1[2];
    G[3 * CA_MS + j] = n2[0]; G[4 * CA_MS + j] = n2[1]; G[5 * CA_MS + j] = n2[2];
    G[6 * CA_MS + j] = y[0]; G[7 * CA_MS + j] = y[1]; G[8 * CA_MS + j] = y[2];
    r0 = n0; r1 = n1; r2 = n2;
  }
  return 0;
}
#else
CA_FLATTEN CA_NOINLINE static int ca_spatial_kinematics(const casadi_real* c, const casadi_real* s,
                                                        const casadi_real* kin, casadi_real* G, casadi_int* iw,
                                                        casadi_real* w) {
  casadi_real c0[CA_NKC], c1[CA_NKC];
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j, k;
  for (k = 0; k < CA_NKC; ++k) c0[k] = kin[k];
  for (j = 1; j < CA_M; ++j) {
    arg[0] = c0; arg[1] = c + j; arg[2] = s + j; arg[3] = c + CA_M + j; arg[4] = s + CA_M + j;
    res[0] = c1;
    if (spatial_kinematics_step(arg, res, iw, w, 0)) return 2;
    for (k = 0; k < CA_NG; ++k) G[k * CA_MS + j] = c1[CA_NKC - CA_NG + k];
    for (k = 0; k < CA_NKC; ++k) c0[k] = c1[k];
  }
  return 0;
}
#endif

/* Links 2..m, independent iterations (vectorised: every argument a pointer into an array per
   quantity, non-null): each link's pivot from its geometry, e^j and the link margin to out,
   the rates step's inputs to Pv[k CA_MS + j]. */
CA_FLATTEN CA_NOINLINE CA_NONNULL(1, 2, 3, 4) static int ca_spatial_pivots(
    const casadi_real* restrict G, const casadi_real* restrict wt, casadi_real* restrict Pv,
    casadi_real* restrict out, casadi_int* iw, casadi_real* w) {
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_real inv;
  casadi_int j, k;
  for (j = 1; j < CA_M; ++j) {
    for (k = 0; k < CA_NG; ++k) arg[k] = G + k * CA_MS + j;
    arg[CA_NG] = wt; res[0] = &inv;
    if (spatial_link_inv_det(arg, res, iw, w, 0)) return 2;
    arg[CA_NG + 1] = &inv;
    for (k = 0; k < CA_NPV; ++k) res[k] = Pv + k * CA_MS + j;
    res[CA_NPV] = out + CA_OUT_E + 2 * (j - 1);
    res[CA_NPV + 1] = out + CA_OUT_E + 2 * (j - 1) + 1;
    res[CA_NPV + 2] = out + CA_OUT_LINK_MARGINS + j - 1;
    if (spatial_link_pivot(arg, res, iw, w, 0)) return 2;
  }
  return 0;
}

/* Links 2..m as ca_spatial_pivots, only the rates step's inputs (spatial_link_pivot_rates: the same
   arithmetic without e^j and the link margin, which the later stages of an RK4 step do not read). */
CA_FLATTEN CA_NOINLINE CA_NONNULL(1, 2, 3) static int ca_spatial_pivot_rates(
    const casadi_real* restrict G, const casadi_real* restrict wt, casadi_real* restrict Pv, casadi_int* iw,
    casadi_real* w) {
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_real inv;
  casadi_int j, k;
  for (j = 1; j < CA_M; ++j) {
    for (k = 0; k < CA_NG; ++k) arg[k] = G + k * CA_MS + j;
    arg[CA_NG] = wt; res[0] = &inv;
    if (spatial_link_inv_det(arg, res, iw, w, 0)) return 2;
    arg[CA_NG + 1] = &inv;
    for (k = 0; k < CA_NPV; ++k) res[k] = Pv + k * CA_MS + j;
    if (spatial_link_pivot_rates(arg, res, iw, w, 0)) return 2;
  }
  return 0;
}

/* Links 2..m: the rates carry (A = A0 + A1 p, sum ||W1||) -> after link m; quantity k of
   xi/2 (W0_j, vec W1_j) to W[k CA_MS + j]. */
CA_FLATTEN CA_NOINLINE static int ca_spatial_rates(const casadi_real* Pv, casadi_real* carry, casadi_real* W,
                                                   casadi_int* iw, casadi_real* w) {
  casadi_real c0[CA_NRC], c1[CA_NRC];
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j, k;
  for (k = 0; k < CA_NRC; ++k) c0[k] = carry[k];
  for (j = 1; j < CA_M; ++j) {
    arg[0] = c0;
    for (k = 0; k < CA_NPV; ++k) arg[1 + k] = Pv + k * CA_MS + j;
    res[0] = c1;
    for (k = 0; k < 6; ++k) res[1 + k] = W + k * CA_MS + j;
    if (spatial_rates_step(arg, res, iw, w, 0)) return 2;
    for (k = 0; k < CA_NRC; ++k) c0[k] = c1[k];
  }
  for (k = 0; k < CA_NRC; ++k) carry[k] = c0[k];
  return 0;
}

/* Joint rates from the link rates w_1 = p, w_j = W0_j + W1_j p (W holds W0_j, W1_j times xi/2), and
   the end margin's sum ||W1_j|| (total, from the head's 1). Only the spin about each link is carried
   (x_j = alpha_j x_{j-1} + beta_j, see spatial_joints.py); the other loops have independent iterations
   (vectorised); the spin runs two joints per step, x_{j+2} = (alpha_{j+1} alpha_j) x_j +
   (alpha_{j+1} beta_j + beta_{j+1}), the two products off its chain. Scratch J, one array of CA_MS each:
   w_1, w_2 (index 0 before link 1), alpha, beta, the norms ||W1_j||, x (index 0 before link 1).
   Writes u and the joint margins |cos b_j|. Not full (RK4's later stages): no norms, total untouched. */
CA_FLATTEN CA_NOINLINE CA_NONNULL(1, 2, 3, 4, 5, 6, 7, 8, 9) static int ca_spatial_joints(
    const casadi_real* restrict c, const casadi_real* restrict s, const casadi_real* restrict ic,
    const casadi_real* restrict W, const casadi_real* restrict p, casadi_real* restrict total,
    casadi_real* restrict u, casadi_real* restrict out, casadi_real* restrict J, casadi_int* iw, casadi_real* w,
    int full) {
  casadi_real *w1 = J, *w2 = w1 + CA_MS, *al = w2 + CA_MS, *be = al + CA_MS, *nrm = be + CA_MS;
  casadi_real *x = nrm + CA_MS, sum = *total;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j;
  w1[0] = 0; w2[0] = 0; w1[1] = p[0]; w2[1] = p[1]; nrm[0] = 0;
  for (j = 1; j < CA_M; ++j) {
    w1[j + 1] = (W[j] + W[2 * CA_MS + j] * p[0] + W[4 * CA_MS + j] * p[1]) * (1 / CA_HALF_XI);
    w2[j + 1] = (W[CA_MS + j] + W[3 * CA_MS + j] * p[0] + W[5 * CA_MS + j] * p[1]) * (1 / CA_HALF_XI);
  }
  for (j = 1; full && j < CA_M; ++j) {
    arg[0] = W + 2 * CA_MS + j; arg[1] = W + 3 * CA_MS + j; arg[2] = W + 4 * CA_MS + j; arg[3] = W + 5 * CA_MS + j;
    res[0] = nrm + j;
    if (spatial_rate_norm(arg, res, iw, w, 0)) return 2;
  }
  for (j = 0; j < CA_M; ++j) {
    arg[0] = c + j; arg[1] = s + j; arg[2] = s + CA_M + j; arg[3] = ic + j; arg[4] = w1 + j + 1; arg[5] = w2 + j;
    res[0] = al + j; res[1] = be + j;
    if (spatial_joint_prep(arg, res, iw, w, 0)) return 2;
  }
  x[0] = 0;
  if (full) {
    for (j = 0; j + 1 < CA_M; j += 2) {   /* the only sequential part: the spin, two joints a step, and the norms' sum */
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
    arg[0] = c + j; arg[1] = s + j; arg[2] = c + CA_M + j; arg[3] = s + CA_M + j; arg[4] = ic + j;
    arg[5] = x + j; arg[6] = w1 + j; arg[7] = w2 + j; arg[8] = w1 + j + 1; arg[9] = w2 + j + 1;
    res[0] = u + 2 * j; res[1] = u + 2 * j + 1; res[2] = out + CA_OUT_JOINT_MARGINS + j;
    if (spatial_joint_rates(arg, res, iw, w, 0)) return 2;
  }
  return 0;
}

/* The law at (q, t): u (2m, d_dot first on a rail) to u, every other output to out at its offset; not full
   (the later stages of an RK4 step, which read u only), without e^j and the margins. */
static int ca_law_mode(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out, casadi_int* iw,
                       casadi_real* w, int full) {
  casadi_real wt[CA_NW + 1], kin[CA_NKC], carry[CA_NRC], total, row[2], rhs, scale, p[2], geo[CA_NG], v[6], srow[2];
  casadi_real *ang = w + CA_SZ_W + CA_RK4_SCRATCH, *c = ang + 2 * CA_MS, *s = c + 2 * CA_MS, *ic = s + 2 * CA_MS;
  casadi_real *W = ic + CA_MS, *G = W + 6 * CA_MS, *Pv = G + CA_NG * CA_MS, *memo = Pv + CA_NPV * CA_MS;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int k;
#if CA_RAIL
  casadi_real psi1, ym[3];
#endif
  /* The time features at t; the later stages of an RK4 step reuse the previous call's at the same time (the
     second and third stage, both at t + h/2). A full call always evaluates them, and every RK4 step starts
     with one, so a stage never reads features it did not see computed (whatever the work array held). */
  if (full || memcmp(&t, memo, sizeof t) != 0) {
    arg[0] = &t; res[0] = memo + 1;
    if (spatial_time_features(arg, res, iw, w, 0)) return 2;
    memo[0] = t;
  }
  for (k = 0; k < CA_NW; ++k) wt[k] = memo[k + 1];     /* on the stack: the loops see it apart from w */
  ca_spatial_trig(q + CA_RAIL, ang, c, s, ic);
  /* ([d,] cos a_1, sin a_1, cos b_1, sin b_1, w): link 1's trigonometry from the passes, the time features */
  arg[CA_RAIL] = c; arg[CA_RAIL + 1] = s; arg[CA_RAIL + 2] = c + CA_M; arg[CA_RAIL + 3] = s + CA_M; arg[CA_RAIL + 4] = wt;
#if CA_RAIL
  arg[0] = q;
#endif
  res[0] = kin;
  if (spatial_kinematics_head(arg, res, iw, w, 0)) return 2;
  if (ca_spatial_kinematics(c, s, kin, G, iw, w)) return 2;
  res[0] = carry; res[1] = &total; res[2] = out + CA_OUT_ROLL; res[3] = row; res[4] = &rhs; res[5] = &scale;
#if CA_RAIL
  for (k = 0; k < 3; ++k) ym[k] = G[(6 + k) * CA_MS + CA_M - 1];      /* y^m (m >= 2) */
  arg[6] = ym;
  res[6] = u; res[7] = out + CA_OUT_RAIL_MARGIN; res[8] = &psi1;     /* d_dot, rail margin, psi(y^1) */
#endif
  if (spatial_rates_head(arg, res, iw, w, 0)) return 2;
  if (full ? ca_spatial_pivots(G, wt, Pv, out, iw, w) : ca_spatial_pivot_rates(G, wt, Pv, iw, w)) return 2;
  if (ca_spatial_rates(Pv, carry, W, iw, w)) return 2;
  for (k = 0; k < CA_NG; ++k) geo[k] = G[k * CA_MS + CA_M - 1];      /* link m */
  for (k = 0; k < 6; ++k) v[k] = W[k * CA_MS + CA_M - 1];
  arg[0] = geo; arg[1] = carry; arg[2] = v; arg[3] = wt; arg[4] = row; arg[5] = &rhs;
  res[0] = out + CA_OUT_S; res[1] = p; res[2] = srow;
  if (spatial_frame_tail(arg, res, iw, w, 0)) return 2;
#if CA_RAIL
  out[CA_OUT_SIGMA] = out[CA_OUT_S] - psi1;          /* sigma = psi(y^m) - psi(y^1) */
#endif
  if (ca_spatial_joints(c, s, ic, W, p, &total, u + CA_RAIL, out, Pv, iw, w, full)) return 2;   /* Pv is free again */
  if (!full) return 0;
  arg[0] = srow; arg[1] = row; arg[2] = &scale; arg[3] = &total; res[0] = out + CA_OUT_END_MARGIN;
  return spatial_end_margin(arg, res, iw, w, 0) ? 2 : 0;
}

static int ca_law(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out, casadi_int* iw,
                  casadi_real* w) {
  return ca_law_mode(q, t, u, out, iw, w, 1);
}

/* u alone (out gets some outputs, not all): the later stages of an RK4 step (library_api.c, CA_LAW_STAGE) */
static inline int ca_law_stage(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out,
                               casadi_int* iw, casadi_real* w) {
  return ca_law_mode(q, t, u, out, iw, w, 0);
}
#define CA_LAW_STAGE ca_law_stage
