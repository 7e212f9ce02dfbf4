/* Per-sample decisions of a chunk of runs by the table of alarm patterns (geomfdi).
 *
 * gfdec_table: for every run r and sample t of the chunk
 *     a_i       = |res[r, i, t]| > thr[i]            (alarm of row i)
 *     code      = sum_i a_i 2^i                        (the alarm pattern)
 *     iso[r, t] = table[code]                          (the isolation decision)
 *     any[r, t] = code != 0
 *     peak[r, i] = max_t |res[r, i, t]|
 * in one pass over the residuals; arrays are read and written through their strides
 * (in elements), contiguous rows four samples at a time in the vector extension of GCC
 * and clang (the same values: comparisons and maxima are exact).  code: the work array
 * of the patterns (L).  Returns 0, or 1 when some |res| is not <= 1e300 (nan, inf or so large
 * that a sum could overflow): the caller then decides by the general path.
 */
#include <stdint.h>
#include <string.h>
#include <math.h>
#if (defined(__GNUC__) || defined(__clang__)) && !defined(GFD_NO_VECTOR_EXT)
typedef double gfd_v4 __attribute__((vector_size(32)));
typedef int64_t gfd_l4 __attribute__((vector_size(32)));
typedef int8_t gfd_b4 __attribute__((vector_size(4)));
#define GFD_VEXT 1
#endif

int gfdec_table(int64_t R, int64_t n, int64_t L,
                const double *res, int64_t rr, int64_t ri, int64_t rt,
                const double *thr, const int64_t *table,
                uint8_t *al, int64_t ar, int64_t ai, int64_t at,
                int64_t *iso, int64_t ir, int64_t it,
                uint8_t *any, int64_t yr, int64_t yt,
                double *peak, int64_t *code)
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
            int64_t t = 0;
#ifdef GFD_VEXT
            if (rt == 1 && at == 1) {
                const gfd_l4 absmask = {INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX};
                const gfd_l4 bitv = {(int64_t)bit, (int64_t)bit, (int64_t)bit, (int64_t)bit};
                const gfd_v4 vv = {v, v, v, v}, lim = {1e300, 1e300, 1e300, 1e300};
                gfd_v4 mx = {0.0, 0.0, 0.0, 0.0};
                gfd_l4 okm = {-1, -1, -1, -1};
                for (; t + 4 <= L; t += 4) {
                    gfd_v4 y;
                    gfd_l4 b, gt;
                    gfd_b4 bq;
                    memcpy(&y, x + t, sizeof y);
                    y = (gfd_v4)((gfd_l4)y & absmask);
                    b = y > vv;
                    gt = y > mx;
                    mx = (gfd_v4)(((gfd_l4)y & gt) | ((gfd_l4)mx & ~gt));
                    okm &= y <= lim;
                    bq = __builtin_convertvector(-b, gfd_b4);
                    memcpy(a + t, &bq, 4);
                    {
                        gfd_l4 c;
                        memcpy(&c, code + t, sizeof c);
                        c |= b & bitv;
                        memcpy(code + t, &c, sizeof c);
                    }
                }
                for (int j = 0; j < 4; ++j) {
                    m = mx[j] > m ? mx[j] : m;
                    ok &= okm[j] != 0;
                }
            }
#endif
            if (rt == 1 && at == 1) {
                for (; t < L; ++t) {
                    const double y = fabs(x[t]);
                    const uint8_t b = y > v;
                    a[t] = b;
                    code[t] |= b ? (int64_t)bit : 0;
                    m = y > m ? y : m;
                    ok &= y <= 1e300;
                }
            } else {
                for (; t < L; ++t) {
                    const double y = fabs(x[t * rt]);
                    const uint8_t b = y > v;
                    a[t * at] = b;
                    code[t] |= b ? (int64_t)bit : 0;
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
