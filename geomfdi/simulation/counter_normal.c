/* Counter-based standard normals of geomfdi's simulation noise (generator "counter").
 *
 * The normal of (key, stream, row, sample g) is a pure function of these numbers
 * (geomfdi.simulation.counter_normal, which holds a numpy implementation of the same
 * operations in the same order; docs/guide/simulation.md):
 *
 *   1. Philox4x32-10 (Salmon, Moraes, Dror & Shaw 2011) of the counter
 *      (j mod 2^32, j >> 32, row, tag | stream), j = g >> 1 the sample pair, with the
 *      run's key (k0, k1), gives four 32-bit words x0 .. x3;
 *   2. two uniforms in (0, 1] with 53 bits: u = ((w >> 11) + 1) 2^-53 of the 64-bit
 *      words w = x1 2^32 + x0 (radius) and x3 2^32 + x2 (angle);
 *   3. Box & Muller (1958): z(2j) = rho cos(2 pi v), z(2j+1) = rho sin(2 pi v),
 *      rho = sqrt(-2 log u), with the polynomial log, sin and cos below (a few ulp, no
 *      branch, so that the loops run in SIMD instructions).
 *
 * Every floating-point operation is an IEEE-754 double operation written out in order
 * (+, -, *, /, sqrt: correctly rounded); the library is built without contraction into
 * fused multiply-adds (-ffp-contract=off), so every machine gives the same bits.
 */
#include <stdint.h>
#include <string.h>

#define GFN_T 256 /* sample pairs per tile (its work arrays stay in the L1 cache) */

static const uint64_t M0 = 0xD2511F53u, M1 = 0xCD9E8D57u; /* Philox4x32 multipliers */
static const uint32_t W0 = 0x9E3779B9u, W1 = 0xBB67AE85u; /* its key increments */

/* The polynomials' coefficients and log 2 in two parts come from the Python module
   (geomfdi/simulation/counter_normal.py: LOG_COEFS, SIN_COEFS, COS_COEFS, _LN2_HI,
   _LN2_LO, _SQRT2_MANT), as hexadecimal literals in -D flags of the build: one definition for the
   kernel and its numpy fallback.
   log(1 + f) = f - (f^2/2 - s (f^2/2 + R)), s = f / (2 + f), R = z LG(z), z = s^2;
   sin(pi r / 2) = r SN(r^2), cos(pi r / 2) = 1 + r^2 CS(r^2), |r| <= 1/2 */
static const double LG[7] = {GFN_LOG_COEFS};
static const double SN[7] = {GFN_SIN_COEFS};
static const double CS[7] = {GFN_COS_COEFS};
/* log 2 = LN2_HI + LN2_LO, LN2_HI with 32 trailing zero bits (k LN2_HI exact) */
static const double LN2_HI = GFN_LN2_HI;
static const double LN2_LO = GFN_LN2_LO;

static inline double from_bits(uint64_t b) {
    double d;
    memcpy(&d, &b, sizeof d);
    return d;
}

static inline uint64_t to_bits(double d) {
    uint64_t b;
    memcpy(&b, &d, sizeof b);
    return b;
}

/* Philox4x32-10 of one counter (Salmon et al. 2011): ten rounds, the key bumped between. */
static void philox_one(const uint32_t ctr[4], const uint32_t key[2], uint32_t out[4]) {
    uint32_t x0 = ctr[0], x1 = ctr[1], x2 = ctr[2], x3 = ctr[3], ka = key[0], kb = key[1];
    for (int r = 0; r < 10; r++) {
        uint64_t p0 = M0 * x0, p1 = M1 * x2;
        uint32_t y0 = (uint32_t)(p1 >> 32) ^ x1 ^ ka, y2 = (uint32_t)(p0 >> 32) ^ x3 ^ kb;
        x1 = (uint32_t)p1;
        x3 = (uint32_t)p0;
        x0 = y0;
        x2 = y2;
        ka += W0;
        kb += W1;
    }
    out[0] = x0;
    out[1] = x1;
    out[2] = x2;
    out[3] = x3;
}

/* The words of the pairs j0 + t0 .. j0 + n - 1 one pair at a time (the tail of a tile). */
static void philox_pairs(uint64_t j0, int t0, int n, uint32_t row, uint32_t c3, uint32_t k0,
                         uint32_t k1, uint64_t *restrict a, uint64_t *restrict b) {
    for (int t = t0; t < n; t++) {
        uint32_t ctr[4] = {(uint32_t)(j0 + (uint64_t)t), (uint32_t)((j0 + (uint64_t)t) >> 32), row,
                           c3};
        uint32_t key[2] = {k0, k1}, x[4];
        philox_one(ctr, key, x);
        a[t] = ((uint64_t)x[1] << 32) | x[0];
        b[t] = ((uint64_t)x[3] << 32) | x[2];
    }
}

/* The words of Philox4x32-10 for pairs j0 .. j0 + n - 1: a = x1 2^32 + x0, b = x3 2^32 + x2.
   The words live in the low halves of 64-bit lanes (the high halves are ignored: a
   product reads the low halves only). */
#if defined(__AVX2__)
#include <immintrin.h>
/* Rounds r0 .. 9 of four groups of four pairs, then their words stored at a and b. */
static inline __attribute__((always_inline)) void philox_finish(
    __m256i x0[4], __m256i x1[4], __m256i x2[4], __m256i x3[4], int r0, const __m256i *ka,
    const __m256i *kb, __m256i m0, __m256i m1, uint64_t *restrict a, uint64_t *restrict b) {
#pragma GCC unroll 10
    for (int r = r0; r < 10; r++) {
        for (int g = 0; g < 4; g++) {
            __m256i p0 = _mm256_mul_epu32(x0[g], m0), p1 = _mm256_mul_epu32(x2[g], m1);
            /* hi(M1 x2) ^ x1 ^ k0 and hi(M0 x0) ^ x3 ^ k1 (the key's xor first: off the
               multiplication's path) */
            x0[g] = _mm256_xor_si256(_mm256_srli_epi64(p1, 32), _mm256_xor_si256(x1[g], ka[r]));
            x2[g] = _mm256_xor_si256(_mm256_srli_epi64(p0, 32), _mm256_xor_si256(x3[g], kb[r]));
            x1[g] = p1;
            x3[g] = p0;
        }
    }
    for (int g = 0; g < 4; g++) { /* low half from x0 (x2), high half from x1 (x3) */
        _mm256_storeu_si256((__m256i *)(a + 4 * g),
                            _mm256_blend_epi32(x0[g], _mm256_slli_epi64(x1[g], 32), 0xAA));
        _mm256_storeu_si256((__m256i *)(b + 4 * g),
                            _mm256_blend_epi32(x2[g], _mm256_slli_epi64(x3[g], 32), 0xAA));
    }
}

static void philox_tile(uint64_t j0, int n, uint32_t row, uint32_t c3, uint32_t k0, uint32_t k1,
                        uint64_t *restrict a, uint64_t *restrict b) {
    __m256i ka[10], kb[10];
    uint32_t ua = k0, ub = k1;
    for (int r = 0; r < 10; r++) {
        ka[r] = _mm256_set1_epi64x((int64_t)ua);
        kb[r] = _mm256_set1_epi64x((int64_t)ub);
        ua += W0;
        ub += W1;
    }
    const __m256i m0 = _mm256_set1_epi64x((int64_t)M0), m1 = _mm256_set1_epi64x((int64_t)M1);
    const __m256i vrow = _mm256_set1_epi64x(row), vc3 = _mm256_set1_epi64x(c3);
    int t = 0;
    /* in a tile whose pairs share j >> 32 (every tile of a record under 2^33 samples),
       the first round's product M1 x2 = M1 row and the second round's M0 x0 do not
       depend on the pair: computed once (the same words) */
    const int same_hi = (j0 >> 32) == ((j0 + (uint64_t)n) >> 32);
    const uint64_t p1c = M1 * (uint64_t)row;
    const uint32_t x0c = (uint32_t)(p1c >> 32) ^ (uint32_t)(j0 >> 32) ^ k0;
    const uint64_t p0c = M0 * (uint64_t)x0c;
    const __m256i c2a = _mm256_set1_epi64x((int64_t)(c3 ^ k1));                     /* round 1 */
    const __m256i c0b = _mm256_set1_epi64x((int64_t)((uint32_t)p1c ^ (k0 + W0)));     /* round 2 */
    const __m256i c2b = _mm256_set1_epi64x((int64_t)((uint32_t)(p0c >> 32) ^ (k1 + W1)));
    const __m256i lo2 = _mm256_set1_epi64x((int64_t)(uint32_t)p0c);
    /* the pairs' indices, four lanes per group, stepped by 16 (only their low words are
       multiplied) */
    __m256i jv = _mm256_add_epi64(_mm256_set1_epi64x((int64_t)j0), _mm256_set_epi64x(3, 2, 1, 0));
    const __m256i four = _mm256_set1_epi64x(4);
    for (; same_hi && t + 16 <= n; t += 16) {
        __m256i x0[4], x1[4], x2[4], x3[4];
        for (int g = 0; g < 4; g++) {
            __m256i p0 = _mm256_mul_epu32(jv, m0);
            jv = _mm256_add_epi64(jv, four);
            /* after round 1: (x0c, lo(M1 row), hi(p0) ^ c3 ^ k1, lo(p0)) */
            __m256i y2 = _mm256_xor_si256(_mm256_srli_epi64(p0, 32), c2a);
            /* round 2: x0 = hi(M1 y2) ^ lo(M1 row) ^ k0', x2 = hi(M0 x0c) ^ lo(p0) ^ k1' */
            __m256i p1 = _mm256_mul_epu32(y2, m1);
            x0[g] = _mm256_xor_si256(_mm256_srli_epi64(p1, 32), c0b);
            x2[g] = _mm256_xor_si256(p0, c2b);
            x1[g] = p1;
            x3[g] = lo2;
        }
        philox_finish(x0, x1, x2, x3, 2, ka, kb, m0, m1, a + t, b + t);
    }
    for (; t + 16 <= n; t += 16) { /* four groups of four pairs, interleaved */
        __m256i x0[4], x1[4], x2[4], x3[4];
        for (int g = 0; g < 4; g++) {
            int64_t j = (int64_t)(j0 + (uint64_t)(t + 4 * g));
            x0[g] = _mm256_set_epi64x(j + 3, j + 2, j + 1, j);
            x1[g] = _mm256_srli_epi64(x0[g], 32);
            x2[g] = vrow;
            x3[g] = vc3;
        }
        philox_finish(x0, x1, x2, x3, 0, ka, kb, m0, m1, a + t, b + t);
    }
    philox_pairs(j0, t, n, row, c3, k0, k1, a, b);
}
#else
static void philox_tile(uint64_t j0, int n, uint32_t row, uint32_t c3, uint32_t k0, uint32_t k1,
                        uint64_t *restrict a, uint64_t *restrict b) {
    philox_pairs(j0, 0, n, row, c3, k0, k1, a, b);
}
#endif

/* c[0] + c[1] x + ... + c[6] x^6 by Estrin's scheme (pairs, then the powers x^2 and x^4:
   a short chain of dependent operations) */
static inline double estrin7(const double *c, double x) {
    double x2 = x * x, x4 = x2 * x2;
    double p01 = c[0] + c[1] * x, p23 = c[2] + c[3] * x, p45 = c[4] + c[5] * x;
    double p03 = p01 + x2 * p23, p46 = p45 + x2 * c[6];
    return p03 + x4 * p46;
}

/* u = ((w >> 11) + 1) 2^-53, exact: 1 + (w >> 12) 2^-52 through the exponent of 1 (52
   bits), minus 1 (exact), plus 2^-53 (1 + the 53rd bit) (exact: a multiple of 2^-53 below
   1 + 2^-53) -- no 64-bit integer conversion instruction needed */
static inline double uniform53(uint64_t w) {
    double a = from_bits(0x3ff0000000000000u | (w >> 12)) - 1.0;
    return a + from_bits(0x3ca0000000000000u + (((w >> 11) & 1u) << 52));
}

/* Box & Muller (1958) for n pairs: z[2t] = rho cos(2 pi v), z[2t + 1] = rho sin(2 pi v),
   rho = sqrt(-2 log u), in three loops of short chains of dependent operations (more of
   them in flight):
   1. u = 2^k m, m in [sqrt(2)/2, sqrt(2)), f = m - 1, s = f / (2 + f); the quarter turn
      q and the rest r of 4 v;
   2. log u = k log 2 + f - (f^2/2 - s (f^2/2 + R)), R = z LG(z), z = s^2;
   3. sin and cos of pi r / 2, turned by q, times rho. */
static void box_muller_tile(int n, const uint64_t *restrict a, const uint64_t *restrict b,
                            double *restrict z) {
    double f[GFN_T], k[GFN_T], s[GFN_T], lg[GFN_T], r[GFN_T];
    uint64_t qs[GFN_T];
    for (int t = 0; t < n; t++) {
        uint64_t bits = to_bits(uniform53(a[t]));
        int64_t mant = (int64_t)(bits & 0x000fffffffffffffu);
        int64_t big = mant > GFN_SQRT2_MANT; /* the mantissa bits of sqrt(2) */
        double m = from_bits((uint64_t)mant | ((uint64_t)(0x3ff - big) << 52));
        /* k = e + big, exact, through the exponent of 2^52 */
        k[t] = from_bits(0x4330000000000000u | ((bits >> 52) + (uint64_t)big)) -
               0x1.00000000003ffp52;
        f[t] = m - 1.0;
        s[t] = f[t] / (2.0 + f[t]);
        /* 4 v = N 2^-51, N = (b >> 11) + 1 in [1, 2^53]: the nearest quarter turn
           q = (N + 2^50) >> 51 (a half rounds up) and r = 4 v - q, both exact */
        uint64_t N = (b[t] >> 11) + 1;
        uint64_t q = (N + ((uint64_t)1 << 50)) >> 51;
        uint64_t kq = N - (q << 51); /* in [-2^50, 2^50) modulo 2^64 */
        r[t] = (from_bits(0x4338000000000000u + kq) - 0x1.8p52) * 0x1p-51;
        qs[t] = q;
    }
    for (int t = 0; t < n; t++) {
        double zz = s[t] * s[t];
        double R = zz * estrin7(LG, zz);
        double hfsq = 0.5 * f[t] * f[t];
        lg[t] = k[t] * LN2_HI - ((hfsq - (s[t] * (hfsq + R) + k[t] * LN2_LO)) - f[t]);
    }
    for (int t = 0; t < n; t++) {
        uint64_t q = qs[t];
        double r2 = r[t] * r[t];
        double S = estrin7(SN, r2), C = estrin7(CS, r2);
        S = r[t] * S;
        C = 1.0 + r2 * C;
        /* the angle is q pi/2 + pi r/2: swap on odd q, signs from q's low bits */
        uint64_t cosb = to_bits((q & 1) ? S : C), sinb = to_bits((q & 1) ? C : S);
        double rho = __builtin_sqrt(-2.0 * lg[t]); /* the divider beside the polynomials */
        z[2 * t] = rho * from_bits(cosb ^ ((uint64_t)((q + 1) & 2) << 62));
        z[2 * t + 1] = rho * from_bits(sinb ^ ((uint64_t)(q & 2) << 62));
    }
}

/* out[r * rstride + i * istride + k] = z(key r, stream, row row0 + i, sample s + k),
   r < R, i < rows, k < L; keys (R, 3): k0, k1, tag (the high 30 bits of the counter's
   last word; its low 2 bits are the stream). */
int gfn_fill(int64_t R, int64_t rows, int64_t row0, int64_t stream, int64_t s, int64_t L,
             const uint32_t *keys, double *out, int64_t rstride, int64_t istride) {
    uint64_t a[GFN_T], b[GFN_T];
    double z[2 * GFN_T];
    if (L <= 0) return 0;
    int64_t jfirst = s >> 1, jlast = (s + L - 1) >> 1;
    for (int64_t r = 0; r < R; r++) {
        uint32_t k0 = keys[3 * r], k1 = keys[3 * r + 1];
        uint32_t c3 = (keys[3 * r + 2] << 2) | ((uint32_t)stream & 3u);
        for (int64_t i = 0; i < rows; i++) {
            double *o = out + r * rstride + i * istride - s; /* o[g]: sample g */
            uint32_t row = (uint32_t)(row0 + i);
            for (int64_t j0 = jfirst; j0 <= jlast; j0 += GFN_T) {
                int n = (int)((jlast - j0 + 1) < GFN_T ? (jlast - j0 + 1) : GFN_T);
                philox_tile((uint64_t)j0, n, row, c3, k0, k1, a, b);
                /* samples 2 j0 .. 2 (j0 + n) - 1, of which s .. s + L - 1 are wanted */
                int64_t g0 = 2 * j0 > s ? 2 * j0 : s;
                int64_t g1 = 2 * (j0 + n) < s + L ? 2 * (j0 + n) : s + L;
                if (g0 == 2 * j0 && g1 == 2 * (j0 + n)) {
                    box_muller_tile(n, a, b, o + 2 * j0); /* straight into the output */
                } else {
                    box_muller_tile(n, a, b, z);
                    for (int64_t g = g0; g < g1; g++) o[g] = z[g - 2 * j0];
                }
            }
        }
    }
    return 0;
}

/* The raw Philox4x32-10 words of n (counter, key) pairs (known-answer tests):
   ctr (n, 4), key (n, 2), out (n, 4). */
void gfn_philox(int64_t n, const uint32_t *ctr, const uint32_t *key, uint32_t *out) {
    for (int64_t t = 0; t < n; t++) philox_one(ctr + 4 * t, key + 2 * t, out + 4 * t);
}
