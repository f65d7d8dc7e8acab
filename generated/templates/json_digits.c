/* The digits of JSON messages filled from one template (loaded by coordarm.simulation.json_fill through
 * coordarm.generated.kernels). Hand-written, no placeholders.
 *
 * As json_fill.JsonTemplate.fill with numpy: each message is the blank text (spaces in the slots), each
 * integer written right-aligned in its slot, a minus sign just before its digits if negative. The
 * caller checks |v| < 10^18 and that every value fits its slot's width.
 */
#include <string.h>

#define JSON_EXPORT __attribute__((visibility("default")))

/* "00" .. "99": two digits per division by 100. */
static const char PAIRS[201] =
    "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
    "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
    "8081828384858687888990919293949596979899";

/* Write x right-aligned so that its last digit is at end[-1]. */
static inline void put_integer(unsigned char *end, long long x) {
  const int negative = x < 0;
  unsigned long long rest = negative ? 0ULL - (unsigned long long)x : (unsigned long long)x;
  unsigned char *p = end;
  while (rest >= 100) {
    const unsigned long long q = rest / 100;
    const unsigned r = (unsigned)(rest - 100 * q);
    p -= 2;
    p[0] = (unsigned char)PAIRS[2 * r];
    p[1] = (unsigned char)PAIRS[2 * r + 1];
    rest = q;
  }
  if (rest >= 10) {
    p -= 2;
    p[0] = (unsigned char)PAIRS[2 * rest];
    p[1] = (unsigned char)PAIRS[2 * rest + 1];
  } else {
    *--p = (unsigned char)('0' + rest);
  }
  if (negative) *--p = '-';
}

/* out (n x size): n copies of blank (size bytes) with, in slot i (start[i], width[i]), the integer in column
 * column[i] of the message's row of values (n x columns; a column may fill several slots). */
JSON_EXPORT void coordarm_json_fill(const unsigned char *blank, long long size, const long long *start,
                                    const long long *width, const long long *column, long long slots,
                                    const long long *values, long long columns, long long n, unsigned char *out) {
  for (long long k = 0; k < n; ++k) {
    unsigned char *row = out + k * size;
    const long long *v = values + k * columns;
    memcpy(row, blank, (size_t)size);
    for (long long i = 0; i < slots; ++i) put_integer(row + start[i] + width[i], v[column[i]]);
  }
}
