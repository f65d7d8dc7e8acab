
#if defined(__x86_64__) && defined(__GLIBC__) && defined(__GNUC__) && !defined(__clang__) \
    && __GNUC__ >= 6 && !defined(__FAST_MATH__) && !defined(COORDARM_SCALAR_TRIG)
#if __GLIBC_PREREQ(2, 22)
#define COORDARM_VECTOR_TRIG 1
__attribute__((simd("notinbranch"))) double cos(double);
__attribute__((simd("notinbranch"))) double sin(double);
#endif
#endif

/* alpha_j = q_1 + ... + q_j, summed left to right like alpha_prev + q_j in the recursion */
static void ca_angles(const casadi_real* q, casadi_real* alpha) {
  casadi_int j;
  alpha[0] = q[0];
  for (j = 1; j < CA_M; ++j) alpha[j] = alpha[j - 1] + q[j];
}

/* cos and sin of every link angle: independent iterations. Vectorised (libmvec) as two
   loops, since gcc would fuse one loop's cos and sin into a scalar sincos; else one loop. */
static void ca_trig(const casadi_real* restrict alpha, casadi_real* restrict c, casadi_real* restrict s) {
  casadi_int j;
#ifdef COORDARM_VECTOR_TRIG
  for (j = 0; j < CA_M; ++j) c[j] = cos(alpha[j]);
  for (j = 0; j < CA_M; ++j) s[j] = sin(alpha[j]);
#else
  for (j = 0; j < CA_M; ++j) {
    c[j] = cos(alpha[j]);
    s[j] = sin(alpha[j]);
  }
#endif
}
