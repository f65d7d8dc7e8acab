
/* ---- coordarm glue (generated/templates.py) ---- */
#define CA_M @m@
#define CA_NQ @nq@
#define CA_HALF_XI @half_xi@   /* half a link [m]: centre to centre is CA_HALF_XI (c_j-1 + c_j) */
#define CA_RAIL @rail@
@layout@#define CA_SZ_ARG @sz_arg@
#define CA_SZ_RES @sz_res@
#define CA_SZ_IW @sz_iw@
#define CA_SZ_W @sz_w@
#define CA_RK4_SCRATCH (5 * CA_NQ + CA_NOUT)
#define COORDARM_API __attribute__((visibility("default")))
#if defined(__GNUC__)
#define CA_FLATTEN __attribute__((flatten))
#else
#define CA_FLATTEN
#endif
@b_macros@#include <stdint.h>
#include <string.h>
typedef char ca_real_is_an_ieee_double[sizeof(casadi_real) == sizeof(uint64_t) ? 1 : -1];
#define CA_EXPONENT 0x7ff0000000000000ULL

/* Finiteness by the IEEE-754 bits (all-ones exponent = inf or NaN), not by isfinite() or x != x,
   which -ffast-math (-ffinite-math-only) lets the compiler fold to "always finite". */
static int ca_all_finite(const casadi_real* x, casadi_int n) {
  casadi_int j;
  uint64_t bits, bad = 0;
  for (j = 0; j < n; ++j) {          /* no early exit: the loop vectorises (called per law call) */
    memcpy(&bits, x + j, sizeof bits);
    bad |= (bits & CA_EXPONENT) == CA_EXPONENT;
  }
  return !bad;
}

static int ca_finite(const casadi_real* q, casadi_real t) {
  return ca_all_finite(q, CA_NQ) && ca_all_finite(&t, 1);
}

/* Quiet NaN written by its bits (under -ffast-math, arithmetic need not produce or keep NaN). */
static void ca_fill_nan(casadi_real* x, casadi_int n) {
  const uint64_t bits = 0x7ff8000000000000ULL;
  casadi_int j;
  for (j = 0; j < n; ++j) memcpy(x + j, &bits, sizeof bits);
}
