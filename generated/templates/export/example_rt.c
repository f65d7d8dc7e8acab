/* example_rt.c: the exported law in a fixed-rate loop, as a real-time controller runs it.
 * usage: ./example_rt CYCLES [RATE_HZ]   (default 1000 Hz; COORDARM_RT=0 in the environment skips the
 *        real-time priority and the memory lock, to compare)
 *
 * Every cycle wakes at an absolute time (clock_nanosleep TIMER_ABSTIME on CLOCK_MONOTONIC, so late
 * wake-ups do not accumulate), evaluates the law at the current state and time, and advances the
 * state by one explicit Euler step of qdot = B u over the period (a stand-in for the plant). All
 * memory is allocated and touched before the loop and locked (mlockall); the process asks for
 * SCHED_FIFO priority and, where that is not permitted, says so and runs at normal priority.
 * At the end it prints the median, 99th, 99.9th percentile and largest of the law's time and of the
 * wake-up latency (wake-up time minus the scheduled time), in microseconds. */
#define _GNU_SOURCE
#include <errno.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include "coordarm_law.h"

static const double q0[@n_q@] = {@q0@};
static const double b[@n_q@] = {@b@};   /* diagonal of B@b_rail@ */
#define T0 @t0@
#define RT_PRIORITY 80

static double seconds_between(const struct timespec* a, const struct timespec* b) {
  return (double)(b->tv_sec - a->tv_sec) + 1e-9 * (double)(b->tv_nsec - a->tv_nsec);
}

static void advance(struct timespec* t, long ns) {
  t->tv_nsec += ns;
  while (t->tv_nsec >= 1000000000L) { t->tv_nsec -= 1000000000L; t->tv_sec += 1; }
}

static int by_value(const void* a, const void* b) {
  double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

static void print_percentiles(const char* what, double* v, long n) {
  qsort(v, (size_t)n, sizeof *v, by_value);
  printf("%-13s p50 %10.3f  p99 %10.3f  p99.9 %10.3f  max %10.3f\n", what, 1e6 * v[n / 2],
         1e6 * v[(long)(0.99 * (n - 1))], 1e6 * v[(long)(0.999 * (n - 1))], 1e6 * v[n - 1]);
}

/* Real-time priority and locked memory where permitted; what happened, in words. */
static void go_real_time(char* sched, size_t n_sched, char* lock, size_t n_lock) {
  const char* env = getenv("COORDARM_RT");
  struct sched_param sp;
  if (env && strcmp(env, "0") == 0) {
    snprintf(sched, n_sched, "SCHED_OTHER (COORDARM_RT=0)");
    snprintf(lock, n_lock, "not locked (COORDARM_RT=0)");
    return;
  }
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) snprintf(lock, n_lock, "locked");
  else snprintf(lock, n_lock, "not locked (mlockall: %s; raise ulimit -l)", strerror(errno));
  memset(&sp, 0, sizeof sp);
  sp.sched_priority = RT_PRIORITY < sched_get_priority_max(SCHED_FIFO) ? RT_PRIORITY
                                                                        : sched_get_priority_max(SCHED_FIFO);
  if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0) {
    snprintf(sched, n_sched, "SCHED_FIFO priority %d", sp.sched_priority);
  } else {
    snprintf(sched, n_sched, "SCHED_OTHER (SCHED_FIFO not permitted: %s)", strerror(errno));
    fprintf(stderr, "example_rt: real-time priority not permitted (%s): running at normal priority; "
                    "run as root, grant CAP_SYS_NICE or raise ulimit -r for SCHED_FIFO\n", strerror(errno));
  }
}

int main(int argc, char** argv) {
  long m, n_u, n_out, n_work, k, j, cycles, period_ns, overruns = 0;
  double rate = 1000.0, h, *q, *u, *out, *work, *law_s, *wake_s;
  char sched[160], lock[160], *end;
  struct timespec next, woke, done;
  int rc;
  if (argc < 2 || argc > 3) {
    fprintf(stderr, "usage: %s CYCLES [RATE_HZ]   (default 1000 Hz)\n", argv[0]);
    return 1;
  }
  cycles = strtol(argv[1], &end, 10);
  if (*end || cycles < 1) { fprintf(stderr, "example_rt: CYCLES: need an integer >= 1, got %s\n", argv[1]); return 1; }
  if (argc == 3) {
    rate = strtod(argv[2], &end);
    if (*end || !(rate > 0.0 && rate <= 1e6)) {
      fprintf(stderr, "example_rt: RATE_HZ: need a number in (0, 1e6], got %s\n", argv[2]);
      return 1;
    }
  }
  period_ns = (long)(1e9 / rate + 0.5);
  h = 1e-9 * (double)period_ns;
  if (coordarm_law_sizes(&m, &n_u, &n_out, &n_work) != COORDARM_LAW_OK) return 1;
  go_real_time(sched, sizeof sched, lock, sizeof lock);
  /* all memory up front and touched (calloc + the loop below): no page fault inside the loop */
  q = calloc(m, sizeof *q); u = calloc(n_u, sizeof *u); out = calloc(n_out, sizeof *out);
  work = calloc(n_work, sizeof *work); law_s = calloc(cycles, sizeof *law_s); wake_s = calloc(cycles, sizeof *wake_s);
  if (!q || !u || !out || !work || !law_s || !wake_s) { fprintf(stderr, "example_rt: out of memory\n"); return 1; }
  memset(law_s, 0, cycles * sizeof *law_s); memset(wake_s, 0, cycles * sizeof *wake_s);
  memcpy(q, q0, sizeof q0);
  if ((rc = coordarm_law(q, T0, u, out, work)) != COORDARM_LAW_OK) {   /* warm caches once */
    fprintf(stderr, "example_rt: coordarm_law returned %d at the start\n", rc);
    return 2;
  }
  clock_gettime(CLOCK_MONOTONIC, &next);
  advance(&next, period_ns);
  for (k = 0; k < cycles; ++k) {
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL) == EINTR) {}
    clock_gettime(CLOCK_MONOTONIC, &woke);
    rc = coordarm_law(q, T0 + k * h, u, out, work);
    clock_gettime(CLOCK_MONOTONIC, &done);
    if (rc != COORDARM_LAW_OK) {
      fprintf(stderr, "example_rt: cycle %ld (t = %g s): coordarm_law returned %d\n", k, T0 + k * h, rc);
      return 2;
    }
    for (j = 0; j < m; ++j) q[j] += h * b[j] * u[j];
    law_s[k] = seconds_between(&woke, &done);
    wake_s[k] = seconds_between(&next, &woke);
    if (wake_s[k] > h) ++overruns;
    advance(&next, period_ns);
  }
  printf("example_rt: %ld cycles at %g Hz, %ld joints; %s; memory %s\n", cycles, rate, m, sched, lock);
  print_percentiles("law [us]", law_s, cycles);
  print_percentiles("wake-up [us]", wake_s, cycles);
  printf("late cycles   %ld (woke more than one period late)\n", overruns);
  free(q); free(u); free(out); free(work); free(law_s); free(wake_s);
  return 0;
}
