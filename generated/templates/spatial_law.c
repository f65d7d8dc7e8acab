/* The spatial law (universal joints, q = (a_1, b_1, ..., a_m, b_m)): every joint angle's cosine and
   sine in vectorised loops, the O(m) recursion over links 2..m (generated per-link step, no
   trigonometry), the 2x2 end solve for w_1 = p, then the joint rates link by link. */
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

/* The law at (q, t): u (2m) to u, every other output to out at its offset. */
static int ca_law(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out, casadi_int* iw,
                  casadi_real* w) {
  casadi_real wt[CA_NW + 1], carry[CA_NC], row[2], rhs, scale, p[2];
  casadi_real *ang = w + CA_SZ_W + CA_RK4_SCRATCH, *c = ang + 2 * CA_M, *s = c + 2 * CA_M, *ic = s + 2 * CA_M;
  casadi_real *W = ic + CA_M;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  arg[0] = &t; res[0] = wt;
  if (spatial_time_features(arg, res, iw, w, 0)) return 2;
  ca_spatial_trig(q, ang, c, s, ic);
  arg[0] = q; arg[1] = &t;
  res[0] = carry; res[1] = out + CA_OUT_ROLL; res[2] = row; res[3] = &rhs; res[4] = &scale;
  if (spatial_frame_head(arg, res, iw, w, 0)) return 2;
  if (ca_spatial_recursion(c, s, wt, carry, out, W, iw, w)) return 2;
  arg[0] = carry; arg[1] = W + 6 * (CA_M - 1); arg[2] = &t; arg[3] = row; arg[4] = &rhs; arg[5] = &scale;
  res[0] = out + CA_OUT_S; res[1] = p; res[2] = out + CA_OUT_END_MARGIN;
  if (spatial_frame_tail(arg, res, iw, w, 0)) return 2;
  return ca_spatial_joints(c, s, ic, W, p, u, out, iw, w);
}
