/* The digits of JSON messages filled from one template (loaded by coordarm.simulation.json_fill through
 * coordarm.generated.kernels). Hand-written, no placeholders.
 *
 * As json_fill.JsonTemplate.fill with numpy: each message is the blank text (spaces in the slots), each
 * integer written right-aligned in its slot, a minus sign just before its digits if negative. The
 * caller checks |v| < 10^18 and that every value fits its slot's width.
 */
#define JSON_EXPORT __attribute__((visibility("default")))

/* out (n x size): n copies of blank (size bytes) with values (n x slots) written into the slots
 * (start[i], width[i]). */
JSON_EXPORT void coordarm_json_fill(const unsigned char *blank, long long size, const long long *start,
                                    const long long *width, long long slots, const long long *values, long long n,
                                    unsigned char *out) {
  for (long long k = 0; k < n; ++k) {
    unsigned char *row = out + k * size;
    const long long *v = values + k * slots;
    for (long long b = 0; b < size; ++b) row[b] = blank[b];
    for (long long i = 0; i < slots; ++i) {
      long long x = v[i];
      const int negative = x < 0;
      unsigned long long rest = negative ? (unsigned long long)(-x) : (unsigned long long)x;
      unsigned char *p = row + start[i] + width[i] - 1;
      do {
        *p-- = (unsigned char)('0' + rest % 10);
        rest /= 10;
      } while (rest);
      if (negative) *p = '-';
    }
  }
}
