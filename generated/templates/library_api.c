
#define CA_SCRATCH (CA_RK4_SCRATCH + CA_LAW_SCRATCH)

COORDARM_API int coordarm_law(const casadi_real* q, casadi_real t, casadi_real* out, casadi_int* iw,
                              casadi_real* w) {
  int rc;
  if (!ca_finite(q, t)) return 1;
  if ((rc = ca_law(q, t, out + CA_OUT_U, out, iw, w))) return rc;
  return ca_all_finite(out, CA_NOUT) ? 0 : 3;
}

/* The law with u in an array of its own; out gets every other output (its u part is not touched). */
COORDARM_API int coordarm_control(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out,
                                  casadi_int* iw, casadi_real* w) {
  int rc;
  if (!ca_finite(q, t)) return 1;
  if ((rc = ca_law(q, t, u, out, iw, w))) return rc;
  return ca_all_finite(u, CA_NQ) && ca_all_finite(out, CA_OUT_U)
         && ca_all_finite(out + CA_OUT_U + CA_NQ, CA_NOUT - CA_OUT_U - CA_NQ) ? 0 : 3;
}

/* The law of an RK4 step's later stages, of which only u is read: a law may define a leaner one. */
#ifndef CA_LAW_STAGE
#define CA_LAW_STAGE ca_law
#endif

/* Same operation order as CoordinatingController.rk4_step, so both agree to rounding. */
static int ca_rk4(const casadi_real* q, casadi_real t, casadi_real h, casadi_real* q_next,
                  casadi_real* out, casadi_int* iw, casadi_real* w) {
  casadi_real *k1 = w + CA_SZ_W, *k2 = k1 + CA_NQ, *k3 = k2 + CA_NQ, *k4 = k3 + CA_NQ;
  casadi_real *x = k4 + CA_NQ, *o = x + CA_NQ;
  casadi_real h2 = h / 2, h6 = h / 6;
  casadi_int j;
  int rc;
  casadi_real *u = out + CA_OUT_U, *v = o + CA_OUT_U;
  if ((rc = ca_law(q, t, u, out, iw, w))) return rc;
  for (j = 0; j < CA_NQ; ++j) { k1[j] = CA_K_FROM_U(j, u[j]); x[j] = q[j] + h2 * k1[j]; }
  if ((rc = CA_LAW_STAGE(x, t + h2, v, o, iw, w))) return rc;
  for (j = 0; j < CA_NQ; ++j) { k2[j] = CA_K_FROM_U(j, v[j]); x[j] = q[j] + h2 * k2[j]; }
  if ((rc = CA_LAW_STAGE(x, t + h2, v, o, iw, w))) return rc;
  for (j = 0; j < CA_NQ; ++j) { k3[j] = CA_K_FROM_U(j, v[j]); x[j] = q[j] + h * k3[j]; }
  if ((rc = CA_LAW_STAGE(x, t + h, v, o, iw, w))) return rc;
  for (j = 0; j < CA_NQ; ++j) {
    k4[j] = CA_K_FROM_U(j, v[j]);
    q_next[j] = q[j] + h6 * (((k1[j] + 2 * k2[j]) + 2 * k3[j]) + k4[j]);
  }
  return 0;
}

COORDARM_API int coordarm_rk4(const casadi_real* q, casadi_real t, casadi_real h, casadi_real* q_next,
                              casadi_real* out, casadi_int* iw, casadi_real* w) {
  int rc;
  if (!ca_finite(q, t)) return 1;
  if ((rc = ca_rk4(q, t, h, q_next, out, iw, w))) return rc;
  return ca_all_finite(out, CA_NOUT) && ca_all_finite(q_next, CA_NQ) ? 0 : 3;
}

/* n steps: Q[k] is the state after step k, D[k] the law at the start of step k (time times[k]).
   From a non-finite q0, or after a non-finite value, every later value is NaN, as in the
   interpreted loop (where NaN propagates), whatever the flags: the caller's margin check then
   stops the run there. */
COORDARM_API int coordarm_chunk(const casadi_real* q0, const casadi_real* times, casadi_real h, casadi_int n,
                                casadi_real* Q, casadi_real* D, casadi_int* iw, casadi_real* w) {
  const casadi_real* q = q0;
  casadi_int k;
  int rc;
  if (!ca_all_finite(&h, 1)) return 1;
  if (!ca_all_finite(q0, CA_NQ)) {      /* e.g. the previous chunk ended in NaN */
    ca_fill_nan(Q, n * CA_NQ);
    ca_fill_nan(D, n * CA_NOUT);
    return 0;
  }
  for (k = 0; k < n; ++k) {
    if ((rc = ca_rk4(q, times[k], h, Q + k * CA_NQ, D + k * CA_NOUT, iw, w))) return rc;
    if (!ca_all_finite(Q + k * CA_NQ, CA_NQ) || !ca_all_finite(D + k * CA_NOUT, CA_NOUT)) {
      ca_fill_nan(Q + k * CA_NQ, (n - k) * CA_NQ);
      ca_fill_nan(D + (k + 1) * CA_NOUT, (n - k - 1) * CA_NOUT);
      return 0;
    }
    q = Q + k * CA_NQ;
  }
  return 0;
}

COORDARM_API void coordarm_sizes(casadi_int* sizes) {
  sizes[0] = CA_M; sizes[1] = CA_NOUT; sizes[2] = CA_SZ_IW + 1; sizes[3] = CA_SZ_W + CA_SCRATCH;
}
