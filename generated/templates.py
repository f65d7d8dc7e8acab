"""Hand-written C glue around the CasADi-generated Functions (kept apart from the logic).

The glue defines the library's whole API (every other symbol is hidden):

* ``coordarm_law(q, t, out, iw, w)``: the law at ``(q, t)``; ``out`` is the packed output
  vector of :data:`coordarm.symbolic.outputs.LAW_OUTPUTS` (``CA_NOUT`` doubles, each output
  at its offset ``CA_OUT_<NAME>``, macros emitted by :mod:`.codegen` from that table);
* ``coordarm_control(q, t, u, out, iw, w)``: the same with ``u`` written to an array of its own
  (``out`` receives the other outputs at their offsets; its ``u`` part is left alone), so a
  caller's arrays are written without copies;
* ``coordarm_rk4(q, t, h, q_next, out, iw, w)``: one closed-loop RK4 step, ``out`` being
  the law at the step's start;
* ``coordarm_chunk(q0, times, h, n, Q, D, iw, w)``: ``n`` RK4 steps in one call;
* ``coordarm_sizes(sizes)``: ``m``, ``len(out)``, ``len(iw)``, ``len(w)``.

On a chain on a rail (``CA_RAIL`` = 1) the state has ``CA_NQ = CA_M + 1`` joints, ``d`` first:
``q``, ``u`` and the RK4 and chunk states are ``CA_NQ`` long, the recursion starts from the
generated rail head (``d_dot``, the rail margin, ``psi(y^1)``) and the packed outputs end with
``sigma`` and ``rail_margin``; with a fixed base ``CA_NQ = CA_M``.

A law or step call returns 1 when ``q`` or ``t`` is not finite (nothing is computed), 2 when
a generated Function failed, 3 when it produced a non-finite output, 0 otherwise. All
finiteness checks test the IEEE bits, so they hold under ``-ffast-math`` too.
"""
from __future__ import annotations

#: Around CasADi's generated code only: it declares every Function with the full signature
#: ``(arg, res, iw, w, mem)`` whether it uses them or not. The glue below compiles with every warning.
CASADI_BEGIN = """#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
"""
CASADI_END = """#pragma GCC diagnostic pop
"""

#: Preamble: sizes and the exported-symbol marker; formatted with the layout numbers.
HEADER = """
/* ---- coordarm glue (generated/templates.py) ---- */
#define CA_M {m}
#define CA_NQ {nq}
#define CA_HALF_XI {half_xi}   /* half a link [m]: centre to centre is CA_HALF_XI (c_j-1 + c_j) */
#define CA_RAIL {rail}
{layout}#define CA_SZ_ARG {sz_arg}
#define CA_SZ_RES {sz_res}
#define CA_SZ_IW {sz_iw}
#define CA_SZ_W {sz_w}
#define CA_RK4_SCRATCH (5 * CA_NQ + CA_NOUT)
#define COORDARM_API __attribute__((visibility("default")))
#if defined(__GNUC__)
#define CA_FLATTEN __attribute__((flatten))
#else
#define CA_FLATTEN
#endif
{b_diagonal}
#include <stdint.h>
#include <string.h>
typedef char ca_real_is_an_ieee_double[sizeof(casadi_real) == sizeof(uint64_t) ? 1 : -1];
#define CA_EXPONENT 0x7ff0000000000000ULL

/* Finiteness by the IEEE-754 bits (all-ones exponent = inf or NaN), not by isfinite() or x != x,
   which -ffast-math (-ffinite-math-only) lets the compiler fold to "always finite". */
static int ca_all_finite(const casadi_real* x, casadi_int n) {{
  casadi_int j;
  uint64_t bits, bad = 0;
  for (j = 0; j < n; ++j) {{          /* no early exit: the loop vectorises (called per law call) */
    memcpy(&bits, x + j, sizeof bits);
    bad |= (bits & CA_EXPONENT) == CA_EXPONENT;
  }}
  return !bad;
}}

static int ca_finite(const casadi_real* q, casadi_real t) {{
  return ca_all_finite(q, CA_NQ) && ca_all_finite(&t, 1);
}}

/* Quiet NaN written by its bits (under -ffast-math, arithmetic need not produce or keep NaN). */
static void ca_fill_nan(casadi_real* x, casadi_int n) {{
  const uint64_t bits = 0x7ff8000000000000ULL;
  casadi_int j;
  for (j = 0; j < n; ++j) memcpy(x + j, &bits, sizeof bits);
}}
"""

#: ``u = qdot / diag(B)`` and ``k = diag(B) u`` when B is a non-unit diagonal (over all ``CA_NQ``
#: joints: on a rail ``d`` first, with ``qdot_d = u_d``).
B_DIAGONAL = """static const casadi_real ca_bd[CA_NQ] = {{{values}}};
#define CA_U_FROM_QDOT(j, v) ((v) / ca_bd[j])
#define CA_K_FROM_U(j, v) (ca_bd[j] * (v))"""
#: The same for B = I.
B_IDENTITY = """#define CA_U_FROM_QDOT(j, v) (v)
#define CA_K_FROM_U(j, v) (v)"""

#: Vector cosine and sine: glibc's libmvec on x86-64, declared here so that the trig loop
#: vectorises under ``-O3 -fno-math-errno`` without ``-ffast-math`` (which glibc's own
#: declarations need, and which would break the non-finite checks). Elsewhere (another C
#: library or architecture, clang, or ``-DCOORDARM_SCALAR_TRIG``) the loop stays scalar.
VECTOR_TRIG = """
#if defined(__x86_64__) && defined(__GLIBC__) && defined(__GNUC__) && !defined(__clang__) \\
    && __GNUC__ >= 6 && !defined(__FAST_MATH__) && !defined(COORDARM_SCALAR_TRIG)
#if __GLIBC_PREREQ(2, 22)
#define COORDARM_VECTOR_TRIG 1
__attribute__((simd("notinbranch"))) double cos(double);
__attribute__((simd("notinbranch"))) double sin(double);
#endif
#endif
"""

#: The first two passes of the structured law: link angles (prefix sum, in the order of the
#: symbolic law), then all cosines and sines in loops without loop-carried dependence.
TRIG_PASSES = VECTOR_TRIG + """
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
"""

#: The search of a path's closest piece (see :mod:`.path_search`, whose tables it reads): junction
#: tests and ``|phi|`` by the same formulas as :func:`coordarm.symbolic.paths.closest_piece_formulas`.
PATH_SEARCH = """
/* Whether p lies in piece j's closest-point range (its junction tests, and an arc's wedge); *dist = |phi_j|,
   g[0] and g[1] the junction tests at its start and end (those it has). */
static int ca_piece_ok(casadi_int j, const casadi_real* p, casadi_real* dist, casadi_real* g) {
  const casadi_real* f = ca_pf[j];
  casadi_real rx, ry;
  if (!(ca_pk[j] & 2)) {
    g[0] = ca_pj[j][0] * p[0] + ca_pj[j][1] * p[1] - ca_pj[j][2];
    if (!(g[0] >= 0)) return 0;
  }
  if (!(ca_pk[j] & 4)) {
    g[1] = ca_pj[j + 1][0] * p[0] + ca_pj[j + 1][1] * p[1] - ca_pj[j + 1][2];
    if (!(g[1] <= 0)) return 0;
  }
  if (ca_pk[j] & 1) {
    rx = p[0] - f[0]; ry = p[1] - f[1];
    if (!(f[3] * rx + f[4] * ry > 0)) return 0;
    *dist = fabs(sqrt(rx * rx + ry * ry) - f[2]);
  } else {
    *dist = fabs(f[0] * p[0] + f[1] * p[1] - f[2]);
  }
  return 1;
}

/* The closest piece to p, the same as the full selection: the first candidate found from `guess`
   outwards has |phi| = delta; a piece k can be closer only if its lower-bound distance to that
   one is at most 2 delta (+ slack), and each piece lists the others in that order. Among the
   pieces that may be closer the first (in order) of the smallest |phi| wins, as in the full
   selection; with no candidate at all it keeps piece 0, as the full selection does. A neighbour
   shares a junction test with piece i, of the opposite sign: it is a candidate only where that
   test is 0, so it is skipped where the test is clearly (beyond rounding) not. */
static casadi_int ca_closest_piece(const casadi_real* p, casadi_int guess) {
  casadi_real delta = 0, dist = 0, limit, g[2] = {0, 0}, h[2];
  casadi_int i = -1, k, j, best;
  for (k = 0; k < CA_NP && i < 0; ++k) {
    if (guess + k < CA_NP && ca_piece_ok(guess + k, p, &delta, g)) i = guess + k;
    else if (k > 0 && guess - k >= 0 && ca_piece_ok(guess - k, p, &delta, g)) i = guess - k;
  }
  if (i < 0) return 0;
  best = i;
  limit = 2 * delta + CA_PATH_EPS;
  for (k = ca_nb_start[i]; k < ca_nb_start[i + 1] && ca_nb_lb[k] <= limit; ++k) {
    j = ca_nb_j[k];
    if ((j == i + 1 && g[1] < -CA_PATH_EPS) || (j == i - 1 && g[0] > CA_PATH_EPS)) continue;
    if (ca_piece_ok(j, p, &dist, h) && (dist < delta || (dist == delta && j < best))) {
      delta = dist;
      best = j;
    }
  }
  return best;
}

/* Before the recursion and apart from it (the centres do not depend on the rates): the closest
   piece pc[j] of every central point y^j (j = 0..m-1, 0-based), each search starting from the
   previous link's piece, and each link's geometry geo[6 j .. 6 j + 5] by the formulas of its
   piece's kind (line or arc). The centres are summed from y^1 (the head's) like the steps do. */
CA_FLATTEN static int ca_path_pass(const casadi_real* head, const casadi_real* q, const casadi_real* c,
                                   const casadi_real* s, const casadi_real* fr, const casadi_real* wt,
                                   casadi_int* pc, casadi_real* geo, casadi_int* iw, casadi_real* w) {
  casadi_real cy[CA_NC], y0 = head[0], y1 = head[1], pp[2];
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  casadi_int j, k;
  for (k = 0; k < CA_NC; ++k) cy[k] = head[k];     /* the geometry reads y^{j-1} and d_{j-1} */
  pp[0] = fr[0] * y0 + fr[2] * y1 + fr[4];
  pp[1] = fr[1] * y0 + fr[3] * y1 + fr[5];
  k = pc[0] = ca_closest_piece(pp, 0);
  for (j = 1; j < CA_M; ++j) {
    y0 = y0 + CA_HALF_XI * (c[j - 1] + c[j]);
    y1 = y1 + CA_HALF_XI * (s[j - 1] + s[j]);
    pp[0] = fr[0] * y0 + fr[2] * y1 + fr[4];
    pp[1] = fr[1] * y0 + fr[3] * y1 + fr[5];
    k = pc[j] = ca_closest_piece(pp, k);
    arg[0] = cy; arg[1] = q + j; arg[2] = c + j; arg[3] = s + j; arg[4] = wt; arg[5] = ca_pp[k];
    res[0] = geo + 6 * j;
    if (ca_pk[k] & 1 ? link_geometry_arc(arg, res, iw, w, 0) : link_geometry_line(arg, res, iw, w, 0)) return 2;
    cy[0] = y0; cy[1] = y1; cy[3] = c[j]; cy[4] = s[j];
  }
  return 0;
}
"""

#: The structured law: :data:`TRIG_PASSES`, then the O(m) recursion calling the generated
#: per-link step (which has no trigonometry), then the tail and the rates. If some link's pivot
#: is small (margin below ``CA_REPIVOT`` or NaN) the recursion only raises a flag and the whole
#: law is evaluated again, out of line, with the re-pivoting step (``ca_law_repivot``).
#: The ``#ifdef CA_GOVERNED`` blocks (the governor on a rail: a second pass of head, recursion and
#: tail with the governed rail rate) are kept only for that law (see :func:`.codegen.structured_law`).
STRUCTURED_LAW = TRIG_PASSES + """
#ifndef CA_PATH_SCRATCH
#define CA_PATH_SCRATCH 0
#endif
#define CA_LAW_SCRATCH (5 * CA_M + CA_PATH_SCRATCH)

/* One link j: carry `from` -> carry `to`; writes e^j, the link margin and a_j, b_j. On a path
   (CA_PATH) the link's geometry geo (from ca_path_pass) goes into the step common to both kinds. */
#ifdef CA_PATH
#define CA_LINK_CALLS(j, from, to) do { \\
    arg[0] = from; arg[1] = q + (j); arg[2] = c + (j); arg[3] = s + (j); arg[4] = geo + 6 * (j); \\
    res[0] = to; res[1] = o; \\
    if (link_step_piece(arg, res, iw, w, 0)) return 2; \\
  } while (0)
#else
#define CA_LINK_CALLS(j, from, to) do { \\
    arg[0] = from; arg[1] = q + (j); arg[2] = c + (j); arg[3] = s + (j); arg[4] = wt; \\
    res[0] = &inv; \\
    if (link_pivot(arg, res, iw, w, 0)) return 2; \\
    arg[5] = &inv; res[0] = to; res[1] = o; \\
    if (link_step_trig(arg, res, iw, w, 0)) return 2; \\
  } while (0)
#endif
#define CA_LINK(j, from, to) do { \\
    CA_LINK_CALLS(j, from, to); \\
    out[CA_OUT_E + (j) - 1] = o[0]; out[CA_OUT_LINK_MARGINS + (j) - 1] = o[1]; \\
    a[j] = o[2]; b[j] = o[3]; \\
    repivot |= !(o[1] >= CA_REPIVOT);  /* a small (or NaN) link pivot */ \\
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
"""

#: The dense law: one call of the generated eq. 27 Function, whose outputs are written in place
#: (``{results}``: one ``res[i] = out + CA_OUT_<NAME>;`` per output, from the table; ``u`` to ``u``).
DENSE_LAW = """
#define CA_LAW_SCRATCH 0
static int ca_law(const casadi_real* q, casadi_real t, casadi_real* u, casadi_real* out, casadi_int* iw,
                  casadi_real* w) {
  const casadi_real* arg[CA_SZ_ARG];
  casadi_real* res[CA_SZ_RES];
  arg[0] = q; arg[1] = &t;
{results}
  return {law_name}(arg, res, iw, w, 0) ? 2 : 0;
}
"""

#: RK4 step, chunk loop and sizes: shared by both law forms.
LOOP = """
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
  if ((rc = ca_law(x, t + h2, v, o, iw, w))) return rc;
  for (j = 0; j < CA_NQ; ++j) { k2[j] = CA_K_FROM_U(j, v[j]); x[j] = q[j] + h2 * k2[j]; }
  if ((rc = ca_law(x, t + h2, v, o, iw, w))) return rc;
  for (j = 0; j < CA_NQ; ++j) { k3[j] = CA_K_FROM_U(j, v[j]); x[j] = q[j] + h * k3[j]; }
  if ((rc = ca_law(x, t + h, v, o, iw, w))) return rc;
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
"""
