/* Times the generated library from C: coordarm_law and coordarm_rk4 (median ns per call).
 * usage: bench_driver LIB Q_FILE T CALLS REPEATS
 * Q_FILE holds m doubles (native byte order). Prints "law_ns rk4_ns". */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

typedef long long ci;
typedef int (*law_t)(const double*, double, double*, ci*, double*);
typedef int (*rk4_t)(const double*, double, double, double*, double*, ci*, double*);
typedef void (*sizes_t)(ci*);

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static int cmp(const void* a, const void* b) {
  double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

int main(int argc, char** argv) {
  if (argc != 6) { fprintf(stderr, "usage: %s LIB Q_FILE T CALLS REPEATS\n", argv[0]); return 2; }
  void* h = dlopen(argv[1], RTLD_NOW);
  if (!h) { fprintf(stderr, "%s\n", dlerror()); return 2; }
  law_t law = (law_t)dlsym(h, "coordarm_law");
  rk4_t rk4 = (rk4_t)dlsym(h, "coordarm_rk4");
  sizes_t sizes = (sizes_t)dlsym(h, "coordarm_sizes");
  ci sz[4];
  sizes(sz);
  double* q = malloc(sz[0] * sizeof(double));
  double* qn = malloc(sz[0] * sizeof(double));
  double* out = malloc(sz[1] * sizeof(double));
  ci* iw = malloc(sz[2] * sizeof(ci));
  double* w = malloc(sz[3] * sizeof(double));
  FILE* f = fopen(argv[2], "rb");
  if (!f || fread(q, sizeof(double), sz[0], f) != (size_t)sz[0]) { fprintf(stderr, "bad Q_FILE\n"); return 2; }
  fclose(f);
  double t = atof(argv[3]);
  long calls = atol(argv[4]), reps = atol(argv[5]), i, r;
  double* law_ns = malloc(reps * sizeof(double));
  double* rk4_ns = malloc(reps * sizeof(double));
  volatile double sink = 0;
  for (r = 0; r < reps; ++r) {
    double t0 = now();
    for (i = 0; i < calls; ++i) { law(q, t + 1e-9 * i, out, iw, w); sink += out[0]; }
    law_ns[r] = (now() - t0) / calls * 1e9;
    t0 = now();
    for (i = 0; i < calls / 4 + 1; ++i) { rk4(q, t, 1e-3, qn, out, iw, w); sink += qn[0]; }
    rk4_ns[r] = (now() - t0) / (calls / 4 + 1) * 1e9;
  }
  qsort(law_ns, reps, sizeof(double), cmp);
  qsort(rk4_ns, reps, sizeof(double), cmp);
  printf("%.1f %.1f\n", law_ns[reps / 2], rk4_ns[reps / 2]);
  return sink == 12345.678;
}
