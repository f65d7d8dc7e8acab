/* The spatial law (universal joints, q = (a_1, b_1, ..., a_m, b_m)): every joint angle's cosine and
   sine in vectorised loops, the O(m) recursion over links 2..m (generated per-link step, no
   trigonometry), the 2x2 end solve for w_1 = p, then the joint rates link by link.
   On a rail (CA_RAIL = 1, the feed axis) q = (d, a_1, b_1, ...) and u = (d_dot, ...): the head is
   ca_spatial_rail_head (below), the rest reads the angles at q + 1 and writes the rates at u + 1. */
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

/* scratch: the angles (a_1..a_m, b_1..b_m), their cosines and sines, 1 / cos b_j, each link's
   xi/2 (W0_j, vec W1_j) */
#define CA_LAW_SCRATCH (13 * CA_M)

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

/* Links 2..m: carry -> carry_m; writes e^j and the link margins to out and xi/2 (W0_j, vec W1_j) to W + 6 j.
   The step has one call site and is inlined here (flatten; this function is not itself inlined into
   ca_law, where gcc would not inline the large step). The carry (31 doubles, more than the registers)
   alternates between two arrays: copying it back would be a memcpy call per link. */
CA_FLATTEN CA_NOINLINE static int ca_spatial_recursion(const casadi_real* c, const casadi_real* s, const casadi_real* wt,
                                           casadi_real* carry, casadi_real* out, casadi_real* W, casadi_int* iw,
                                           casadi_real* w) {
  casadi_real c0[CA_NC], c1[CA_NC], o[9], inv;
  casadi_real *cur = c0, *nxt = c1, *tmp;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j, k;
  for (k = 0; k < CA_NC; ++k) c0[k] = carry[k];
  for (j = 1; j < CA_M; ++j) {
    arg[0] = cur; arg[1] = c + j; arg[2] = s + j; arg[3] = c + CA_M + j; arg[4] = s + CA_M + j; arg[5] = wt;
    res[0] = &inv;
    if (spatial_link_inv_det(arg, res, iw, w, 0)) return 2;
    arg[6] = &inv; res[0] = nxt; res[1] = o;
    if (spatial_link_step_trig(arg, res, iw, w, 0)) return 2;
    out[CA_OUT_E + 2 * (j - 1)] = o[0];
    out[CA_OUT_E + 2 * (j - 1) + 1] = o[1];
    out[CA_OUT_LINK_MARGINS + j - 1] = o[2];
    for (k = 0; k < 6; ++k) W[6 * j + k] = o[3 + k];
    tmp = cur; cur = nxt; nxt = tmp;
  }
  for (k = 0; k < CA_NC; ++k) carry[k] = cur[k];
  return 0;
}

/* Joint rates from the link rates w_1 = p, w_j = W0_j + W1_j p (W holds W0_j, W1_j times xi/2; the
   frame and the angular velocity carried from joint to joint); writes u and the joint margins |cos b_j|. */
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
      x[5] = (W[6 * j] + W[6 * j + 2] * p[0] + W[6 * j + 4] * p[1]) * (1 / CA_HALF_XI);
      x[6] = (W[6 * j + 1] + W[6 * j + 3] * p[0] + W[6 * j + 5] * p[1]) * (1 / CA_HALF_XI);
    }
    arg[0] = c0; arg[1] = x; res[0] = c1; res[1] = o;
    if (spatial_joint_step_trig(arg, res, iw, w, 0)) return 2;
    u[2 * j] = o[0]; u[2 * j + 1] = o[1];
    out[CA_OUT_JOINT_MARGINS + j] = o[2];
    for (k = 0; k < CA_NJC; ++k) c0[k] = c1[k];
  }
  return 0;
}

#if CA_RAIL
/* The head on a rail: d_dot (u[0]) from the span row, the rail margin and psi(y^1), and link 1's carry
   and roll row (generated spatial_rail_head). A commanded span (CA_SPAN) is computed inside the generated
   head from the end's centre y^m, which this loop sums from the cosines and sines (R_j = R_{j-1} Rz Ry). */
static int ca_spatial_rail_head(const casadi_real* q, casadi_real t, const casadi_real* c, const casadi_real* s,
                                casadi_real* carry, casadi_real* roll, casadi_real* row, casadi_real* rhs,
                                casadi_real* scale, casadi_real* u, casadi_real* out, casadi_real* psi1,
                                casadi_int* iw, casadi_real* w) {
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
#ifdef CA_SPAN
  casadi_real R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, N[9], J[9], ym[3], prev[3];
  casadi_int j, r, k;
  ym[0] = q[0] * CA_RAIL_X; ym[1] = q[0] * CA_RAIL_Y; ym[2] = q[0] * CA_RAIL_Z;      /* y^1 = d rail */
  for (j = 0; j < CA_M; ++j) {
    casadi_real ca_ = c[j], sa = s[j], cb = c[CA_M + j], sb = s[CA_M + j];
    J[0] = ca_ * cb; J[1] = -sa; J[2] = ca_ * sb;       /* Rz(a) Ry(b), row-major */
    J[3] = sa * cb;  J[4] = ca_; J[5] = sa * sb;
    J[6] = -sb;      J[7] = 0;   J[8] = cb;
    for (r = 0; r < 3; ++r)
      for (k = 0; k < 3; ++k) N[3 * r + k] = R[3 * r] * J[k] + R[3 * r + 1] * J[3 + k] + R[3 * r + 2] * J[6 + k];
    for (r = 0; r < 3; ++r) {
      if (j > 0) ym[r] += CA_HALF_XI * (prev[r] + N[3 * r]);        /* y^j = y^{j-1} + xi/2 (d_{j-1} + d_j) */
      prev[r] = N[3 * r];
    }
    for (k = 0; k < 9; ++k) R[k] = N[k];
  }
  arg[3] = ym;
#else
  casadi_real sigma = 0;               /* a held span: the head does not read it */
  (void)c; (void)s;
  arg[3] = &sigma;
#endif
  arg[0] = q; arg[1] = q + 1; arg[2] = &t;
  res[0] = carry; res[1] = roll; res[2] = row; res[3] = rhs; res[4] = scale;
  res[5] = u; res[6] = out + CA_OUT_RAIL_MARGIN; res[7] = psi1;
  return CA_RAIL_HEAD(arg, res, iw, w, 0) ? 2 : 0;
}
#endif

/* The law at (q, t): u (2m, d_dot first on a rail) to u, every other output to out at its offset. */
static int ca_law(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out, casadi_int* iw,
                  casadi_real* w) {
  casadi_real wt[CA_NW + 1], carry[CA_NC], row[2], rhs, scale, p[2];
#if CA_RAIL
  casadi_real psi1;
#endif
  casadi_real *ang = w + CA_SZ_W + CA_RK4_SCRATCH, *c = ang + 2 * CA_M, *s = c + 2 * CA_M, *ic = s + 2 * CA_M;
  casadi_real *W = ic + CA_M;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  arg[0] = &t; res[0] = wt;
  if (spatial_time_features(arg, res, iw, w, 0)) return 2;
  ca_spatial_trig(q + CA_RAIL, ang, c, s, ic);
#if CA_RAIL
  if (ca_spatial_rail_head(q, t, c, s, carry, out + CA_OUT_ROLL, row, &rhs, &scale, u, out, &psi1, iw, w)) return 2;
#else
  arg[0] = q; arg[1] = &t;
  res[0] = carry; res[1] = out + CA_OUT_ROLL; res[2] = row; res[3] = &rhs; res[4] = &scale;
  if (spatial_head(arg, res, iw, w, 0)) return 2;
#endif
  if (ca_spatial_recursion(c, s, wt, carry, out, W, iw, w)) return 2;
  arg[0] = carry; arg[1] = &t; arg[2] = row; arg[3] = &rhs; arg[4] = &scale;
  res[0] = out + CA_OUT_S; res[1] = p; res[2] = out + CA_OUT_END_MARGIN;
  if (spatial_tail(arg, res, iw, w, 0)) return 2;
#if CA_RAIL
  out[CA_OUT_SIGMA] = out[CA_OUT_S] - psi1;
#endif
  return ca_spatial_joints(c, s, ic, W, p, u + CA_RAIL, out, iw, w);
}
