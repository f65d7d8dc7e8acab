
#define CA_LAW_SCRATCH 0
static int ca_law(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out, casadi_int* iw,
                  casadi_real* w) {
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  arg[0] = q; arg[1] = &t;
@results@
  return @law_name@(arg, res, iw, w, 0) ? 2 : 0;
}
