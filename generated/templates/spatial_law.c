/* The spatial law (universal joints, q = (a_1, b_1, ..., a_m, b_m)): every joint angle's cosine and
   sine in vectorised loops, then three O(m) loops over links: the forward kinematics (frames and
   centres, storing each link's geometry), the rates (link pivots and the affine link rates, no
   trigonometry), and after the 2x2 end solve for w_1 = p, the joint rates link by link. Each loop's
   carry is small enough for the registers. */
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

/* scratch: the angles (a_1..a_m, b_1..b_m), their cosines and sines, 1 / cos b_j, and per link (one
   array of CA_M per quantity): xi/2 (W0_j, vec W1_j) (6), the geometry (vec E_j, y^j) (CA_NG), the
   pivot's outputs for the rates (CA_NPV) */
#define CA_LAW_SCRATCH ((13 + CA_NG + CA_NPV) * CA_M)

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
   (vec E_j, y^j) to G[k CA_M + j]. The steps have one call site and are inlined here (flatten; these
   loops are not themselves inlined into ca_law, where gcc would not inline the steps); the carry is
   copied back, not pointer-swapped, so it can stay in registers. */
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
    for (k = 0; k < CA_NG; ++k) G[k * CA_M + j] = c1[CA_NKC - CA_NG + k];
    for (k = 0; k < CA_NKC; ++k) c0[k] = c1[k];
  }
  return 0;
}

/* Links 2..m, independent iterations (vectorised: every argument a pointer into an array per
   quantity, non-null): each link's pivot from its geometry, e^j and the link margin to out,
   the rates step's inputs to Pv[k CA_M + j]. */
CA_FLATTEN CA_NOINLINE CA_NONNULL(1, 2, 3, 4) static int ca_spatial_pivots(
    const casadi_real* restrict G, const casadi_real* restrict wt, casadi_real* restrict Pv,
    casadi_real* restrict out, casadi_int* iw, casadi_real* w) {
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_real inv;
  casadi_int j, k;
  for (j = 1; j < CA_M; ++j) {
    for (k = 0; k < CA_NG; ++k) arg[k] = G + k * CA_M + j;
    arg[CA_NG] = wt; res[0] = &inv;
    if (spatial_link_inv_det(arg, res, iw, w, 0)) return 2;
    arg[CA_NG + 1] = &inv;
    for (k = 0; k < CA_NPV; ++k) res[k] = Pv + k * CA_M + j;
    res[CA_NPV] = out + CA_OUT_E + 2 * (j - 1);
    res[CA_NPV + 1] = out + CA_OUT_E + 2 * (j - 1) + 1;
    res[CA_NPV + 2] = out + CA_OUT_LINK_MARGINS + j - 1;
    if (spatial_link_pivot(arg, res, iw, w, 0)) return 2;
  }
  return 0;
}

/* Links 2..m: the rates carry (A = A0 + A1 p, sum ||W1||) -> after link m; quantity k of
   xi/2 (W0_j, vec W1_j) to W[k CA_M + j]. */
CA_FLATTEN CA_NOINLINE static int ca_spatial_rates(const casadi_real* Pv, casadi_real* carry, casadi_real* W,
                                                   casadi_int* iw, casadi_real* w) {
  casadi_real c0[CA_NRC], c1[CA_NRC];
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j, k;
  for (k = 0; k < CA_NRC; ++k) c0[k] = carry[k];
  for (j = 1; j < CA_M; ++j) {
    arg[0] = c0;
    for (k = 0; k < CA_NPV; ++k) arg[1 + k] = Pv + k * CA_M + j;
    res[0] = c1;
    for (k = 0; k < 6; ++k) res[1 + k] = W + k * CA_M + j;
    if (spatial_rates_step(arg, res, iw, w, 0)) return 2;
    for (k = 0; k < CA_NRC; ++k) c0[k] = c1[k];
  }
  for (k = 0; k < CA_NRC; ++k) carry[k] = c0[k];
  return 0;
}

/* Joint rates from the link rates w_1 = p, w_j = W0_j + W1_j p (W holds W0_j, W1_j times xi/2; the
   angular velocity carried from joint to joint in the link's frame); writes u and the joint margins |cos b_j|. */
CA_FLATTEN CA_NOINLINE static int ca_spatial_joints(const casadi_real* c, const casadi_real* s, const casadi_real* ic,
                                        const casadi_real* W, const casadi_real* p, casadi_real* u, casadi_real* out,
                                        casadi_int* iw, casadi_real* w) {
  casadi_real c0[CA_NJC] = {0}, c1[CA_NJC], x[7], o[3];
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j, k;
  for (j = 0; j < CA_M; ++j) {
    x[0] = c[j]; x[1] = s[j]; x[2] = c[CA_M + j]; x[3] = s[CA_M + j]; x[4] = ic[j];
    if (j == 0) {
      x[5] = p[0]; x[6] = p[1];
    } else {
      x[5] = (W[j] + W[2 * CA_M + j] * p[0] + W[4 * CA_M + j] * p[1]) * (1 / CA_HALF_XI);
      x[6] = (W[CA_M + j] + W[3 * CA_M + j] * p[0] + W[5 * CA_M + j] * p[1]) * (1 / CA_HALF_XI);
    }
    arg[0] = c0; arg[1] = x; res[0] = c1; res[1] = o;
    if (spatial_joint_step_trig(arg, res, iw, w, 0)) return 2;
    u[2 * j] = o[0]; u[2 * j + 1] = o[1];
    out[CA_OUT_JOINT_MARGINS + j] = o[2];
    for (k = 0; k < CA_NJC; ++k) c0[k] = c1[k];
  }
  return 0;
}

/* The law at (q, t): u (2m) to u, every other output to out at its offset. */
static int ca_law(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out, casadi_int* iw,
                  casadi_real* w) {
  casadi_real wt[CA_NW + 1], kin[CA_NKC], carry[CA_NRC], row[2], rhs, scale, p[2], geo[CA_NG], v[6];
  casadi_real *ang = w + CA_SZ_W + CA_RK4_SCRATCH, *c = ang + 2 * CA_M, *s = c + 2 * CA_M, *ic = s + 2 * CA_M;
  casadi_real *W = ic + CA_M, *G = W + 6 * CA_M, *Pv = G + CA_NG * CA_M;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int k;
  arg[0] = &t; res[0] = wt;
  if (spatial_time_features(arg, res, iw, w, 0)) return 2;
  ca_spatial_trig(q, ang, c, s, ic);
  arg[0] = q; arg[1] = &t;
  res[0] = kin; res[1] = carry; res[2] = out + CA_OUT_ROLL; res[3] = row; res[4] = &rhs; res[5] = &scale;
  if (spatial_frame_head(arg, res, iw, w, 0)) return 2;
  if (ca_spatial_kinematics(c, s, kin, G, iw, w)) return 2;
  if (ca_spatial_pivots(G, wt, Pv, out, iw, w)) return 2;
  if (ca_spatial_rates(Pv, carry, W, iw, w)) return 2;
  for (k = 0; k < CA_NG; ++k) geo[k] = G[k * CA_M + CA_M - 1];      /* link m */
  for (k = 0; k < 6; ++k) v[k] = W[k * CA_M + CA_M - 1];
  arg[0] = geo; arg[1] = carry; arg[2] = v; arg[3] = &t; arg[4] = row; arg[5] = &rhs; arg[6] = &scale;
  res[0] = out + CA_OUT_S; res[1] = p; res[2] = out + CA_OUT_END_MARGIN;
  if (spatial_frame_tail(arg, res, iw, w, 0)) return 2;
  return ca_spatial_joints(c, s, ic, W, p, u, out, iw, w);
}
