/* Times generated libraries from C, interleaved: in every round each library's coordarm_law
 * and coordarm_rk4 run one batch of about BATCH_MS milliseconds, so all libraries see the same
 * machine load; Python takes per-round ratios and their median (benchmarks/timing.py).
 * usage: bench_driver Q_FILE T ROUNDS BATCH_MS LIB [LIB ...]
 * Q_FILE holds m doubles (native byte order); every LIB must be for the same m.
 * Prints one line per round: law_ns of each LIB, then rk4_ns of each LIB. */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define SUB 5   /* batches per library per round */

typedef long long ci;
typedef int (*law_t)(const double*, double, double*, ci*, double*);
typedef int (*rk4_t)(const double*, double, double, double*, double*, ci*, double*);
typedef void (*sizes_t)(ci*);

typedef struct {
  law_t law;
  rk4_t rk4;
  double *qn, *out, *w;
  ci* iw;
  long law_calls, rk4_calls;   /* batch sizes, calibrated once */
} lib_t;

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static volatile double sink;

static double time_law(lib_t* L, const double* q, double t, long calls) {
  long i;
  double t0 = now();
  for (i = 0; i < calls; ++i) { L->law(q, t + 1e-9 * i, L->out, L->iw, L->w); sink += L->out[0]; }
  return (now() - t0) / calls * 1e9;
}

static double time_rk4(lib_t* L, const double* q, double t, long calls) {
  long i;
  double t0 = now();
  for (i = 0; i < calls; ++i) { L->rk4(q, t + 1e-9 * i, 1e-3, L->qn, L->out, L->iw, L->w); sink += L->qn[0]; }
  return (now() - t0) / calls * 1e9;
}

/* calls per batch so that one batch lasts about batch_ns (at least 3 calls) */
static long calibrate(double ns_per_call, double batch_ns) {
  long n = (long)(batch_ns / (ns_per_call > 1 ? ns_per_call : 1));
  return n < 3 ? 3 : n;
}

int main(int argc, char** argv) {
  if (argc < 6) { fprintf(stderr, "usage: %s Q_FILE T ROUNDS BATCH_MS LIB [LIB ...]\n", argv[0]); return 2; }
  double t = atof(argv[2]), batch_ns = atof(argv[4]) * 1e6;
  long rounds = atol(argv[3]), nlib = argc - 5, k, r, m = -1;
  lib_t* libs = calloc(nlib, sizeof(lib_t));
  double* q = NULL;
  for (k = 0; k < nlib; ++k) {
    void* h = dlopen(argv[5 + k], RTLD_NOW | RTLD_LOCAL);
    if (!h) { fprintf(stderr, "%s\n", dlerror()); return 2; }
    libs[k].law = (law_t)dlsym(h, "coordarm_law");
    libs[k].rk4 = (rk4_t)dlsym(h, "coordarm_rk4");
    sizes_t sizes = (sizes_t)dlsym(h, "coordarm_sizes");
    if (!libs[k].law || !libs[k].rk4 || !sizes) { fprintf(stderr, "%s: not a coordarm library\n", argv[5 + k]); return 2; }
    ci sz[4];
    sizes(sz);
    if (m >= 0 && sz[0] != m) { fprintf(stderr, "%s: %lld links, not %ld\n", argv[5 + k], sz[0], m); return 2; }
    m = (long)sz[0];
    libs[k].qn = malloc((sz[0] + 1) * sizeof(double));   /* on a rail q has m + 1 values (d first) */
    libs[k].out = malloc(sz[1] * sizeof(double));
    libs[k].iw = malloc((sz[2] + 1) * sizeof(ci));
    libs[k].w = malloc(sz[3] * sizeof(double));
  }
  q = malloc((m + 1) * sizeof(double));
  FILE* f = fopen(argv[1], "rb");
  size_t nq = f ? fread(q, sizeof(double), m + 1, f) : 0;   /* m joints, or d and m joints on a rail */
  if (nq != (size_t)m && nq != (size_t)m + 1) { fprintf(stderr, "bad Q_FILE\n"); return 2; }
  fclose(f);
  for (k = 0; k < nlib; ++k) {      /* warm up (page in, caches), then size the batches */
    time_law(&libs[k], q, t, 3);
    libs[k].law_calls = calibrate(time_law(&libs[k], q, t, 5), batch_ns);
    libs[k].rk4_calls = calibrate(time_rk4(&libs[k], q, t, 3), batch_ns);
  }
  for (r = 0; r < rounds; ++r) {
    /* SUB interleaved batches per library in each round; the round keeps each library's fastest
       batch, so a batch that another process preempted does not count */
    double* row = malloc(2 * nlib * sizeof(double));
    long b;
    for (k = 0; k < 2 * nlib; ++k) row[k] = 1e300;
    for (b = 0; b < SUB; ++b) {
      for (k = 0; k < nlib; ++k) {
        double v = time_law(&libs[k], q, t, libs[k].law_calls);
        if (v < row[k]) row[k] = v;
      }
      for (k = 0; k < nlib; ++k) {
        double v = time_rk4(&libs[k], q, t, libs[k].rk4_calls);
        if (v < row[nlib + k]) row[nlib + k] = v;
      }
    }
    for (k = 0; k < 2 * nlib; ++k) printf(k ? " %.2f" : "%.2f", row[k]);
    printf("\n");
    free(row);
  }
  return 0;
}
