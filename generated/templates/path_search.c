
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
