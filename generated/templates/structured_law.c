
#ifndef CA_PATH_SCRATCH
#define CA_PATH_SCRATCH 0
#endif
#define CA_LAW_SCRATCH (5 * CA_M + CA_PATH_SCRATCH)

/* One link j: carry `from` -> carry `to`; writes e^j, the link margin and a_j, b_j. On a path
   (CA_PATH) the link's geometry geo (from ca_path_pass) goes into the step common to both kinds. */
#ifdef CA_PATH
#define CA_LINK_CALLS(j, from, to) do { \
    arg[0] = from; arg[1] = q + (j); arg[2] = c + (j); arg[3] = s + (j); arg[4] = geo + 6 * (j); \
    res[0] = to; res[1] = o; \
    if (link_step_piece(arg, res, iw, w, 0)) return 2; \
  } while (0)
#else
#define CA_LINK_CALLS(j, from, to) do { \
    arg[0] = from; arg[1] = q + (j); arg[2] = c + (j); arg[3] = s + (j); arg[4] = wt; \
    res[0] = &inv; \
    if (link_pivot(arg, res, iw, w, 0)) return 2; \
    arg[5] = &inv; res[0] = to; res[1] = o; \
    if (link_step_trig(arg, res, iw, w, 0)) return 2; \
  } while (0)
#endif
#define CA_LINK(j, from, to) do { \
    CA_LINK_CALLS(j, from, to); \
    out[CA_OUT_E + (j) - 1] = o[0]; out[CA_OUT_LINK_MARGINS + (j) - 1] = o[1]; \
    a[j] = o[2]; b[j] = o[3]; \
    repivot |= !(o[1] >= CA_REPIVOT);  /* a small (or NaN) link pivot */ \
  } while (0)

/* The head of the recursion: link 1's carry and, on a rail (CA_RAIL), d_dot (u[0]), the rail margin
   and psi(y^1) (the span is then s - psi_1). A commanded span (CA_SPAN) is computed inside the
   generated head from the end's centre y^m, summed here from the cosines and sines of every link. */
static int ca_head(const casadi_real* q, casadi_real t, const casadi_real* c, const casadi_real* s,
                   casadi_real* carry, casadi_real* u, casadi_real* out, casadi_real* psi1,
                   casadi_int* iw, casadi_real* w) {
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
#if CA_RAIL
#ifdef CA_SPAN
  casadi_real ym[2];
  casadi_int j;
  ym[0] = q[0] * CA_RAIL_C; ym[1] = q[0] * CA_RAIL_S;       /* y^1 = d rail, then eq. 4 */
  for (j = 1; j < CA_M; ++j) {
    ym[0] = ym[0] + CA_HALF_XI * (c[j - 1] + c[j]);
    ym[1] = ym[1] + CA_HALF_XI * (s[j - 1] + s[j]);
  }
  arg[3] = ym;
#else
  casadi_real sigma = 0;               /* a held span: the head does not read it */
  (void)c; (void)s;
  arg[3] = &sigma;
#endif
  arg[0] = q; arg[1] = q + 1; arg[2] = &t;
#ifdef CA_GOVERNED
  arg[4] = out + CA_OUT_V_SCALE;       /* the governor's factor on the commands (1 in the first pass) */
#endif
  res[0] = carry; res[1] = u; res[2] = out + CA_OUT_RAIL_MARGIN; res[3] = psi1;
  return CA_RAIL_HEAD(arg, res, iw, w, 0) ? 2 : 0;
#else
  (void)t; (void)c; (void)s; (void)u; (void)out;
  *psi1 = 0;
  arg[0] = q; res[0] = carry;
  return first_carry(arg, res, iw, w, 0) ? 2 : 0;
#endif
}

/* The recursion over links 2..m (returns 1 if a link pivot is small: see ca_law_repivot); the carry is copied back (not pointer-swapped) and the step has
   a single call site and is inlined (flatten), so the compiler keeps the carry in registers. */
CA_FLATTEN static int ca_recursion(const casadi_real* q, const casadi_real* c, const casadi_real* s,
                        const casadi_real* wt, const casadi_real* geo, casadi_real* carry, casadi_real* out,
                        casadi_real* a, casadi_real* b, casadi_int* iw, casadi_real* w) {
  casadi_real c0[CA_NC], c1[CA_NC], o[4], inv;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j, k;
  int repivot = 0;
#ifdef CA_PATH
  (void)inv; (void)wt;
#else
  (void)geo;
#endif
  a[0] = 0; b[0] = 1;
  for (k = 0; k < CA_NC; ++k) c0[k] = carry[k];
  for (j = 1; j < CA_M; ++j) {
    CA_LINK(j, c0, c1);
    for (k = 0; k < CA_NC; ++k) c0[k] = c1[k];
  }
  for (k = 0; k < CA_NC; ++k) carry[k] = c0[k];
  return repivot;                      /* 1: some link needs re-pivoting (2 is a failed call) */
}

/* Re-pivoting (rare, out of line): the whole law again with the step that, at a link whose pivot
   is small, solves that link's row for the free rate instead; then the free rate is carried back
   through the re-pivoted links (p_{j-1} = c_j + d_j p_j). */
static __attribute__((noinline, cold)) int ca_law_repivot(const casadi_real* q, casadi_real t,
                                                          const casadi_real* head, casadi_real psi1, casadi_real* u,
                                                          casadi_real* out, casadi_int* iw, casadi_real* w) {
  casadi_real wt[CA_NW_REPIVOT + 1], c0[CA_NC], c1[CA_NC], o[6], tl[5];
  casadi_real a[CA_M], b[CA_M], cc[CA_M], dd[CA_M], rates[CA_M];
  casadi_real *cur = c0, *nxt = c1, *tmp, p, prev;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j;
  arg[0] = &t; res[0] = wt;
  if (time_features_repivot(arg, res, iw, w, 0)) return 2;
  for (j = 0; j < CA_NC; ++j) cur[j] = head[j];
  for (j = 1; j < CA_M; ++j) {
    arg[0] = cur; arg[1] = q + j; arg[2] = wt; res[0] = nxt; res[1] = o;
    if (link_step_repivot(arg, res, iw, w, 0)) return 2;
    out[CA_OUT_E + j - 1] = o[0];
    out[CA_OUT_LINK_MARGINS + j - 1] = o[1];
    a[j] = o[2]; b[j] = o[3]; cc[j] = o[4]; dd[j] = o[5];
    tmp = cur; cur = nxt; nxt = tmp;
  }
  arg[0] = cur; arg[1] = &t; res[0] = tl; res[1] = tl + 1; res[2] = tl + 2; res[3] = tl + 3; res[4] = tl + 4;
  if (tail(arg, res, iw, w, 0)) return 2;
  out[CA_OUT_S] = tl[0];
  out[CA_OUT_LONGITUDINAL] = tl[2];
  out[CA_OUT_LONGITUDINAL_PIVOT] = tl[3];
  out[CA_OUT_V_SCALE] = tl[4];
#if CA_RAIL
  out[CA_OUT_SIGMA] = tl[0] - psi1;
#else
  (void)psi1;
#endif
  p = tl[1];                           /* the free rate after the last link */
  for (j = CA_M - 1; j > 0; --j) {     /* w_j = a_j + b_j p_j, p_{j-1} = c_j + d_j p_j */
    rates[j] = a[j] + b[j] * p;
    p = cc[j] + dd[j] * p;
  }
  rates[0] = p;                        /* w_1 = p_1 */
  prev = 0;
  for (j = 0; j < CA_M; ++j) {         /* qdot_j = w_j - w_{j-1} */
    u[j] = CA_U_FROM_QDOT(CA_RAIL + j, rates[j] - prev);
    prev = rates[j];
  }
  return 0;
}

/* The law at (q, t); on a rail q = (d, q_1..q_m) and u = (d_dot, u_1..u_m). */
static int ca_law(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out, casadi_int* iw,
                  casadi_real* w) {
  casadi_real wt[CA_NW + 1], head[CA_NC], carry[CA_NC], tl[5], psi1;
  casadi_real *alpha = w + CA_SZ_W + CA_RK4_SCRATCH, *c = alpha + CA_M, *s = c + CA_M;
  casadi_real *a = s + CA_M, *b = a + CA_M;
  casadi_real *geo = b + CA_M;                 /* on a path: every link's geometry (CA_PATH_SCRATCH) */
  casadi_real p, rate, prev;
  const casadi_real* qr = q + CA_RAIL;         /* the revolute joints q_1..q_m */
  casadi_real* ur = u + CA_RAIL;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j;
  int rc;
#ifdef CA_GOVERNED
  int pass = 0;
  out[CA_OUT_V_SCALE] = 1;             /* first pass: the ungoverned rail rate, for the margin only */
#endif
  arg[0] = &t; res[0] = wt;
  if (time_features(arg, res, iw, w, 0)) return 2;
#ifdef CA_PATH
  casadi_real fr[6];
  casadi_int pc[CA_M];
  res[0] = fr; res[1] = fr + 4;        /* the path's frame at t: p = A y + b */
  if (path_frame(arg, res, iw, w, 0)) return 2;
#endif
  ca_angles(qr, alpha);
  ca_trig(alpha, c, s);
  if (ca_head(q, t, c, s, head, u, out, &psi1, iw, w)) return 2;
  for (j = 0; j < CA_NC; ++j) carry[j] = head[j];
#ifdef CA_PATH
  if (ca_path_pass(head, qr, c, s, fr, wt, pc, geo, iw, w)) return 2;
#endif
#ifdef CA_GOVERNED
again:
#endif
  if ((rc = ca_recursion(qr, c, s, wt, geo, carry, out, a, b, iw, w))) {
    if (rc == 2) return 2;
#ifdef CA_GOVERNED
    if (!pass) {                       /* the first pass re-pivoted for v_scale, then the governed head */
      if (ca_law_repivot(qr, t, head, psi1, ur, out, iw, w)) return 2;
      if (ca_head(q, t, c, s, head, u, out, &psi1, iw, w)) return 2;
    }
#endif
    return ca_law_repivot(qr, t, head, psi1, ur, out, iw, w);
  }
  arg[0] = carry; arg[1] = &t; res[0] = tl; res[1] = tl + 1; res[2] = tl + 2; res[3] = tl + 3;
  res[4] = tl + 4;
#ifdef CA_PATH
  arg[2] = ca_pp[pc[CA_M - 1]];        /* the tail by the formulas of y^m's piece */
  if (ca_pk[pc[CA_M - 1]] & 1 ? tail_arc(arg, res, iw, w, 0) : tail_line(arg, res, iw, w, 0)) return 2;
#else
  if (tail(arg, res, iw, w, 0)) return 2;
#endif
  out[CA_OUT_S] = tl[0];
  out[CA_OUT_LONGITUDINAL] = tl[2];
  out[CA_OUT_LONGITUDINAL_PIVOT] = tl[3];
  out[CA_OUT_V_SCALE] = tl[4];
#if CA_RAIL
  out[CA_OUT_SIGMA] = tl[0] - psi1;    /* sigma = psi(y^m) - psi(y^1) */
#endif
#ifdef CA_GOVERNED
  if (!pass++) {                       /* second pass: the head with the governed rail rate (v_scale) */
    if (ca_head(q, t, c, s, head, u, out, &psi1, iw, w)) return 2;
    for (j = 0; j < CA_NC; ++j) carry[j] = head[j];
    goto again;
  }
#endif
  p = tl[1];                           /* the free rate w_1 */
  prev = 0;
  for (j = 0; j < CA_M; ++j) {         /* w_j = a_j + b_j p, qdot_j = w_j - w_{j-1} */
    rate = a[j] + b[j] * p;
    ur[j] = CA_U_FROM_QDOT(CA_RAIL + j, rate - prev);
    prev = rate;
  }
  return 0;
}
