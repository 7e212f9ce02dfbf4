/* numpy's standard normals of a PCG64 generator, drawn in a compiled loop: the same bits
 * and the same final state as numpy.random.Generator.standard_normal
 * (geomfdi.simulation.pcg64_normal; docs/guide/performance.md).
 *
 * numpy draws a standard normal with a ziggurat of 256 layers (Marsaglia & Tsang 2000)
 * from one 64-bit output r of its bit generator:
 *
 *   i = r & 255,  s = (r >> 8) & 1,  m = (r >> 9) & (2^52 - 1),
 *   x = (-1)^s m w[i],  returned when m < k[i]  (98.5 % of the draws);
 *
 * otherwise it runs a rejection step (the wedge, or the tail for i = 0) that draws more
 * outputs.  PCG64 (O'Neill 2014) is a 128-bit linear congruential state, stepped before
 * each output, s <- s M + c, and the output XSL-RR: the two halves of the state xor-ed,
 * rotated right by the state's top six bits.
 *
 * gfpcg_fill steps PCG64 inline and takes the accepted draws itself; every other draw is
 * handed to numpy's own random_standard_normal (a function pointer of the running numpy)
 * with a bit generator that replays the draw's output first, then continues the state:
 * the rejection steps are numpy's code, the values and the state numpy's by construction.
 * gfpcg_probe reads w and k from that same function: w[i] is the normal of m = 1 (exact,
 * 1 w[i] = w[i]), k[i] the first m it rejects (bisection on whether it asked for a second
 * output); a layer that rejects m = 1 (numpy's layer 1, k[1] = 0) gets k[i] = 0, all
 * its draws handed to numpy.
 */
#include <stdint.h>
#include <string.h>

/* numpy's bit generator interface (numpy/random/bitgen.h, its public C API) */
typedef struct gfpcg_bitgen {
    void *state;
    uint64_t (*next_uint64)(void *st);
    uint32_t (*next_uint32)(void *st);
    double (*next_double)(void *st);
    uint64_t (*next_raw)(void *st);
} gfpcg_bitgen;
typedef double (*gfpcg_normal)(gfpcg_bitgen *);

typedef unsigned __int128 u128;
/* PCG's default 128-bit multiplier */
#define GFPCG_MULT ((((u128)2549297995355413924ULL) << 64) | 4865540595714422341ULL)
#define GFPCG_MANT 0x000fffffffffffffULL

static double W[256];
static uint64_t K[256];

static inline uint64_t pcg_next(u128 *s, u128 inc) {
    *s = *s * GFPCG_MULT + inc;
    uint64_t x = (uint64_t)(*s >> 64) ^ (uint64_t)*s;
    unsigned rot = (unsigned)(*s >> 122);
    return (x >> rot) | (x << ((-rot) & 63));
}

/* The bit generator handed to numpy: the pending output first, then the state stepped
   (calls counts the outputs asked for: the probe's rejection test). */
typedef struct {
    u128 s, inc;
    int pending;
    uint64_t raw;
    int64_t calls;
} replay;

static uint64_t replay_u64(void *p) {
    replay *r = p;
    r->calls++;
    if (r->pending) {
        r->pending = 0;
        return r->raw;
    }
    return pcg_next(&r->s, r->inc);
}
static uint32_t replay_u32(void *p) { return (uint32_t)replay_u64(p); } /* (not used by normals) */
static double replay_double(void *p) {
    return (double)(replay_u64(p) >> 11) * (1.0 / 9007199254740992.0);  /* numpy's 53-bit double */
}

static double call(gfpcg_normal f, replay *r, uint64_t raw) {
    gfpcg_bitgen bg = {r, replay_u64, replay_u32, replay_double, replay_u64};
    r->pending = 1;
    r->raw = raw;
    r->calls = 0;
    return f(&bg);
}

/* W and K from numpy's function f; returns 0, or -1 when more than 8 layers accept no m
   (not the ziggurat this kernel knows). */
int gfpcg_probe(gfpcg_normal f) {
    replay r;
    int none = 0;
    for (int i = 0; i < 256; ++i) {
        r.s = 0x853c49e6748fea9bULL; /* any state: only rejections draw from it */
        r.inc = 0xda3e39cb94b95bdbULL;
        double x = call(f, &r, (1ULL << 9) | (uint64_t)i);
        if (r.calls != 1) { /* m = 1 rejected (numpy's layer 1): every draw of the layer */
            W[i] = 0.0;     /* goes to numpy's function */
            K[i] = 0;
            if (++none > 8) return -1;
            continue;
        }
        W[i] = x;
        uint64_t lo = 1, hi = GFPCG_MANT + 1; /* accepted at lo; hi: rejected, or past the end */
        while (hi - lo > 1) {
            uint64_t mid = lo + (hi - lo) / 2;
            double y = call(f, &r, (mid << 9) | (uint64_t)i);
            if (r.calls == 1 && y == (double)mid * W[i])
                lo = mid;
            else
                hi = mid;
        }
        K[i] = hi;
    }
    return 0;
}

/* n normals into out, from the state st = {state low, state high, increment low,
   increment high} (updated); returns the number of draws numpy's function made. */
int64_t gfpcg_fill(gfpcg_normal f, uint64_t *st, int64_t n, double *out) {
    u128 s = ((u128)st[1] << 64) | st[0];
    const u128 inc = ((u128)st[3] << 64) | st[2];
    int64_t slow = 0;
    for (int64_t k = 0; k < n; ++k) {
        const uint64_t raw = pcg_next(&s, inc);
        const unsigned i = (unsigned)(raw & 255);
        const uint64_t m = (raw >> 9) & GFPCG_MANT;
        uint64_t bits;
        const double x = (double)m * W[i];
        memcpy(&bits, &x, sizeof bits);
        bits ^= ((raw >> 8) & 1) << 63; /* the sign, without a branch */
        if (__builtin_expect(m < K[i], 1)) {
            memcpy(out + k, &bits, sizeof bits);
            continue;
        }
        replay r = {s, inc, 0, 0, 0};
        out[k] = call(f, &r, raw);
        s = r.s;
        ++slow;
    }
    st[0] = (uint64_t)s;
    st[1] = (uint64_t)(s >> 64);
    return slow;
}
