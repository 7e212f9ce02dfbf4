/* Per-sample decisions of a chunk of runs by the table of alarm patterns (geomfdi).
 *
 * gfdec_table: for every run r and sample t of the chunk
 *     a_i       = |res[r, i, t]| > thr[i]            (alarm of row i)
 *     code      = sum_i a_i 2^i                        (the alarm pattern)
 *     iso[r, t] = table[code]                          (the isolation decision)
 *     any[r, t] = code != 0
 *     peak[r, i] = max_t |res[r, i, t]|
 * in one pass over the residuals; arrays are read and written through their strides
 * (in elements).  Returns 0, or 1 when some |res| is not <= 1e300 (nan, inf or so large
 * that a sum could overflow): the caller then decides by the general path.
 */
#include <stdint.h>
#include <math.h>

int gfdec_table(int64_t R, int64_t n, int64_t L,
                const double *res, int64_t rr, int64_t ri, int64_t rt,
                const double *thr, const int64_t *table,
                uint8_t *al, int64_t ar, int64_t ai, int64_t at,
                int64_t *iso, int64_t ir, int64_t it,
                uint8_t *any, int64_t yr, int64_t yt,
                double *peak, uint32_t *code)
{
    int bad = 0;
    for (int64_t r = 0; r < R; ++r) {
        for (int64_t t = 0; t < L; ++t) code[t] = 0;
        for (int64_t i = 0; i < n; ++i) {
            const double *x = res + r * rr + i * ri;
            uint8_t *a = al + r * ar + i * ai;
            const double v = thr[i];
            double m = 0.0;
            int ok = 1;
            const uint32_t bit = (uint32_t)1 << i;
            if (rt == 1 && at == 1) {
                for (int64_t t = 0; t < L; ++t) {
                    const double y = fabs(x[t]);
                    const uint8_t b = y > v;
                    a[t] = b;
                    code[t] |= b ? bit : 0u;
                    m = y > m ? y : m;
                    ok &= y <= 1e300;
                }
            } else {
                for (int64_t t = 0; t < L; ++t) {
                    const double y = fabs(x[t * rt]);
                    const uint8_t b = y > v;
                    a[t * at] = b;
                    code[t] |= b ? bit : 0u;
                    m = y > m ? y : m;
                    ok &= y <= 1e300;
                }
            }
            peak[r * n + i] = m;
            bad |= !ok;
        }
        int64_t *d = iso + r * ir;
        uint8_t *y = any + r * yr;
        for (int64_t t = 0; t < L; ++t) {
            d[t * it] = table[code[t]];
            y[t * yt] = code[t] != 0;
        }
    }
    return bad;
}
