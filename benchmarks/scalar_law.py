"""The generated law as it was before the vectorised trigonometry (commit 35299a5): the baseline
of the benchmarks. Each link step computes its own sine/cosine pair inside the recursion. The
tail's fifth output (``v_scale``, added later) gets a slot, else the tail writes through an unset pointer.

Benchmark-only; the library's own code is :mod:`coordarm.generated.codegen`.
"""
from __future__ import annotations

from coordarm.generated.codegen import Source, assemble_source
from coordarm.symbolic import CoordinatingController

#: The pre-vectorisation structured law (verbatim from generated/templates.py at 35299a5).
SCALAR_LAW = """
#define CA_LAW_SCRATCH 0
static int ca_law_packed(const casadi_real* q, casadi_real t, casadi_real* out, casadi_int* iw, casadi_real* w) {
  casadi_real wt[CA_NW + 1], c0[CA_NC], c1[CA_NC], o[4], tl[5], a[CA_M], b[CA_M];
  casadi_real *cur = c0, *nxt = c1, *tmp, p, rate, prev;
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j;
  arg[0] = &t; res[0] = wt;
  if (time_features(arg, res, iw, w, 0)) return 2;
  arg[0] = q; res[0] = cur;
  if (first_carry(arg, res, iw, w, 0)) return 2;
  a[0] = 0; b[0] = 1;
  for (j = 1; j < CA_M; ++j) {
    arg[0] = cur; arg[1] = q + j; arg[2] = wt; res[0] = nxt; res[1] = o;
    if (link_step(arg, res, iw, w, 0)) return 2;
    out[CA_M + j - 1] = o[0];          /* e^j */
    out[2 * CA_M + j - 1] = o[1];      /* link margin */
    a[j] = o[2]; b[j] = o[3];
    tmp = cur; cur = nxt; nxt = tmp;
  }
  arg[0] = cur; arg[1] = &t; res[0] = tl; res[1] = tl + 1; res[2] = tl + 2; res[3] = tl + 3;
  res[4] = tl + 4;                     /* v_scale (a tail output since issue 13; not in the old law) */
  if (tail(arg, res, iw, w, 0)) return 2;
  out[2 * CA_M - 1] = tl[0];           /* s */
  out[3 * CA_M - 1] = tl[2];           /* longitudinal margin */
  out[3 * CA_M] = tl[3];               /* longitudinal pivot */
  p = tl[1];                           /* the free rate w_1 */
  prev = 0;
  for (j = 0; j < CA_M; ++j) {         /* w_j = a_j + b_j p, qdot_j = w_j - w_{j-1} */
    rate = a[j] + b[j] * p;
    out[j] = CA_U_FROM_QDOT(j, rate - prev);
    prev = rate;
  }
  return 0;
}

/* today's API: u and the rest in one packed row (the benchmarks only call it that way) */
static int ca_law(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* rest, casadi_int* iw,
                  casadi_real* w) {
  (void)rest;
  return ca_law_packed(q, t, u, iw, w);
}
"""


def scalar_source(ctrl: CoordinatingController) -> Source:
    """The structured law of ``ctrl`` as generated before the vectorised trigonometry."""
    funcs = [ctrl.recursion.time_features(), ctrl.recursion.first_carry(), ctrl.recursion.link_step(),
             ctrl.recursion.tail()]
    return assemble_source(ctrl, funcs, SCALAR_LAW, "structured")
