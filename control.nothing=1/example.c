/* example.c: a fixed-step closed loop with the exported law (RK4 of qdot = B u).
 * usage: ./example [STEPS]   (default 20000: the scenario's duration)
 * Prints one line per step: t, q[n_q], u[n_u], outputs[n_outputs] (%.17g, exact round trip). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "coordarm_law.h"

static const double q0[4] = {1.3, -2.6, 2.6, -2.6};
static const double b[4] = {1.0, 1.0, 1.0, 1.0};   /* diagonal of B */

static void print_row(double t, const double* q, const double* u, const double* out, long m, long n_out) {
  long j;
  printf("%.17g", t);
  for (j = 0; j < m; ++j) printf(" %.17g", q[j]);
  for (j = 0; j < m; ++j) printf(" %.17g", u[j]);
  for (j = 0; j < n_out; ++j) printf(" %.17g", out[j]);
  printf("\n");
}

int main(int argc, char** argv) {
  long m, n_u, n_out, n_work, k, j, steps = argc > 1 ? atol(argv[1]) : 20000;
  const double h = 0.001, t0 = 0.0;
  double *q, *x, *u, *v, *out, *o, *work, *k1, *k2, *k3, *k4;
  int rc;
  if (coordarm_law_sizes(&m, &n_u, &n_out, &n_work) != COORDARM_LAW_OK) return 1;
  /* all memory up front: the law itself allocates nothing */
  q = malloc(m * sizeof *q); x = malloc(m * sizeof *x); u = malloc(n_u * sizeof *u);
  v = malloc(n_u * sizeof *v); out = malloc(n_out * sizeof *out); o = malloc(n_out * sizeof *o);
  work = malloc(n_work * sizeof *work); k1 = malloc(m * sizeof *k1); k2 = malloc(m * sizeof *k2);
  k3 = malloc(m * sizeof *k3); k4 = malloc(m * sizeof *k4);
  if (!q || !x || !u || !v || !out || !o || !work || !k1 || !k2 || !k3 || !k4) return 1;
  memcpy(q, q0, sizeof q0);
  for (k = 0; k <= steps; ++k) {
    double t = t0 + k * h;
    if ((rc = coordarm_law(q, t, u, out, work)) != COORDARM_LAW_OK) {
      fprintf(stderr, "example: step %ld (t = %g s): coordarm_law returned %d\n", k, t, rc);
      return 2;
    }
    print_row(t, q, u, out, m, n_out);
    if (k == steps) break;
    /* RK4 in the operation order of the coordarm simulator */
    for (j = 0; j < m; ++j) { k1[j] = b[j] * u[j]; x[j] = q[j] + h / 2 * k1[j]; }
    if ((rc = coordarm_law(x, t + h / 2, v, o, work))) return 2;
    for (j = 0; j < m; ++j) { k2[j] = b[j] * v[j]; x[j] = q[j] + h / 2 * k2[j]; }
    if ((rc = coordarm_law(x, t + h / 2, v, o, work))) return 2;
    for (j = 0; j < m; ++j) { k3[j] = b[j] * v[j]; x[j] = q[j] + h * k3[j]; }
    if ((rc = coordarm_law(x, t + h, v, o, work))) return 2;
    for (j = 0; j < m; ++j) {
      k4[j] = b[j] * v[j];
      q[j] = q[j] + h / 6 * (((k1[j] + 2 * k2[j]) + 2 * k3[j]) + k4[j]);
    }
  }
  free(q); free(x); free(u); free(v); free(out); free(o); free(work);
  free(k1); free(k2); free(k3); free(k4);
  return 0;
}
