
/* ---- standalone API (coordarm export) ---- */
#include <stdint.h>
#include <string.h>
#include "@header@"

int coordarm_law_sizes(long* n_q, long* n_u, long* n_outputs, long* n_work) {
  if (!n_q || !n_u || !n_outputs || !n_work) return COORDARM_LAW_EINVAL;
  *n_q = CA_NQ;
  *n_u = CA_NQ;
  *n_outputs = CA_NOUT - CA_NQ;
  *n_work = CA_SZ_W + CA_LAW_SCRATCH + CA_NOUT;
  return COORDARM_LAW_OK;
}

int coordarm_law(const double* q, double t, double* u, double* outputs, double* work) {
  casadi_int iw[CA_SZ_IW];
  casadi_real* packed = work + CA_SZ_W + CA_LAW_SCRATCH;   /* the law's packed outputs (u unused) */
  long j;
  if (!q || !u || !outputs || !work) return COORDARM_LAW_EINVAL;
  if (!ca_finite(q, t) || ca_law(q, t, u, packed, iw, work)) {
    ca_fill_nan(u, CA_NQ);                  /* nothing computed: NaN, never stale values */
    ca_fill_nan(outputs, CA_NOUT - CA_NQ);
    return ca_finite(q, t) ? COORDARM_LAW_EFAILED : COORDARM_LAW_ENONFINITE_INPUT;
  }
  /* every output but u, in table order */
  memcpy(outputs, packed, CA_OUT_U * sizeof *outputs);
  memcpy(outputs + CA_OUT_U, packed + CA_OUT_U + CA_NQ, (CA_NOUT - CA_OUT_U - CA_NQ) * sizeof *outputs);
@singular_checks@  if (!ca_all_finite(u, CA_NQ) || !ca_all_finite(outputs, CA_NOUT - CA_NQ)) return COORDARM_LAW_ENONFINITE;
  return COORDARM_LAW_OK;
}
