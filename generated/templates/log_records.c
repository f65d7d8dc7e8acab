/* The per-step message records of a log, packed in one pass (loaded by coordarm.simulation.record_packing
 * through coordarm.generated.kernels). Hand-written, no placeholders.
 *
 * As RunLogger's numpy path: each of n records (size bytes apart in out) gets, for each of its messages,
 * the sequence number (seq0 + k, modulo 2^32) and the log and publish times, and the bytes of each field
 * copied from its source row k. Nothing is computed: the same bytes. ctypes releases the GIL during the
 * call, so the simulation's thread goes on meanwhile.
 */
#include <stdint.h>
#include <string.h>

#define RECORDS_EXPORT __attribute__((visibility("default")))

/* out: n records of size bytes. copies fields: from address src[c] + k src_step[c] (bytes), bytes[c] bytes,
 * to dst[c] in record k. headers messages: the header at hdr_at[h] in each record, its sequence number at
 * seq_at (uint32), log and publish times at log_at and pub_at (uint64, times[k], the same for every message). */
RECORDS_EXPORT void coordarm_pack_records(unsigned char *out, long long n, long long size, long long copies,
                                          const long long *src, const long long *src_step, const long long *dst,
                                          const long long *bytes, long long headers, const long long *hdr_at,
                                          const long long *seq0, const uint64_t *times, long long seq_at,
                                          long long log_at, long long pub_at) {
  for (long long k = 0; k < n; ++k) {
    unsigned char *record = out + k * size;
    for (long long h = 0; h < headers; ++h) {
      unsigned char *head = record + hdr_at[h];
      const uint32_t sequence = (uint32_t)((uint64_t)seq0[h] + (uint64_t)k);
      memcpy(head + seq_at, &sequence, 4);
      memcpy(head + log_at, times + k, 8);
      memcpy(head + pub_at, times + k, 8);
    }
    for (long long c = 0; c < copies; ++c)
      memcpy(record + dst[c], (const unsigned char *)(intptr_t)src[c] + k * src_step[c], (size_t)bytes[c]);
  }
}
