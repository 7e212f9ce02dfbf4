/* The hot loop of a Monte-Carlo block, fused: readings, sensor faults, the bank's
 * recursion and the windowed chi-square statistic of many runs in one pass
 * (geomfdi.simulation.fused).
 *
 * For every run r of the block and sample k of the window s .. s+L-1 (k absolute):
 *
 *   y0n_i(k) = y0c[i, k] + lv[i] z_i(r, k)             (noisy reading; lv NULL: z is v)
 *   y_i(k)   = eta_i(r, k) y0n_i(k) + lam_i(r, k)        (sensor faults, Hou, Wen & Chen
 *                                                        2011 eq. 3-5)
 *   rhoL_i   = y_i(k) - eta_i(k) y0c[i, k]               (the sensor's own drive channels
 *   rhoR_i   = (eta_i(k) y0n_i(k+1) + lam_i(k)) - eta_i(k) y0c[i, k+1]   over the interval)
 *
 * with eta and lam piecewise constant per (sensor, run) (segments: first sample, eta,
 * lam), or lam sampled: where lsp[i R + r] is not NULL it points at lam_i(k) of the run's
 * fault list, k = 0 .. N-1, followed by its left limits lam_i(k-) (the value of the
 * faults active at k-1, a callable bias evaluated at k), and rhoR takes lam_i(k+1-) in
 * place of lam_i(k) (for piecewise constant lam the two are equal); the drive channel c
 * of the bank is one of
 *
 *   kind 0: y_i(k), 1: rhoL_i, 2: rhoR_i, 3: (eta_i(k) - 1) sh[row, k],
 *   kind 4: (eta_i(k) - 1) sh[row, k+1]
 *
 * and the bank is the recursion of compiled_recursion.c, the same operations in the
 * same order:
 *
 *   out[o](k) = (ys[k, o] + sum_c D[o, c] y_{esens[c]}(k)) + sum_t C[o, t] x[ostart[o] + t]
 *   x(k+1)    = (fs[k, :] + sum_c W[:, c] d_c(k)) + A x(k)
 *
 * A residual row j is the output rbeg[j] (one output) or the norm of the outputs
 * rbeg[j] .. rbeg[j+1]-1; with win > 0 the statistic written is the windowed sum of
 * squares, S(k) = c(k) - c(k - win) (c(k) for k < win) with c the running sum of
 * squares, clipped at 0: the sequential sums of numpy's cumsum, bit for bit.  The rows
 * are written to out (when not NULL) and judged by gff_evaluate (when ev is given).
 * Only the runs r0 .. r1-1 of the R runs are computed (the arrays indexed by the
 * absolute run: parts of a block run on different threads).  The states X (nS, R), the
 * running sums cs (nrow, R) and the ring of the last win running sums (win, nrow, R)
 * are carried from one window to the next.  out points at the sample s of run r0 (a
 * block's array, or a window's buffer of the runs r0 .. r1-1), strides ors, oos, ots.
 *
 * Runs go in groups of GFSIM_G lanes (two vectors of the compiler's vector extension),
 * samples in tiles of GFSIM_T; the missing lanes of the last group repeat its last run
 * (computed, never stored).
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#if defined(__AVX512F__)
#define GFSIM_W 8
#elif defined(__AVX__)
#define GFSIM_W 4
#else
#define GFSIM_W 2
#endif
#ifndef GFSIM_NV
#define GFSIM_NV 4 /* vectors per group of runs (independent operations per coefficient) */
#endif
#define GFSIM_G (GFSIM_NV * GFSIM_W)
#define GFSIM_T 64

#if (defined(__GNUC__) || defined(__clang__)) && !defined(GFF_NO_VECTOR_EXT)
#define GFF_VEXT 1
#else
#define GFF_VEXT 0
#endif

#if GFF_VEXT && GFSIM_W == 4 && defined(__AVX__)
#include <immintrin.h>
#define GFF_T4 1 /* the rows scattered four lanes by four samples (a transpose in registers) */
#endif

#if GFF_VEXT
typedef double gfsim_vec __attribute__((vector_size(GFSIM_W * sizeof(double)), may_alias));
typedef long long gfsim_ivec __attribute__((vector_size(GFSIM_W * sizeof(long long))));
typedef struct {
    gfsim_vec v[GFSIM_NV];
} gfsim_lane;
static const gfsim_vec gfsim_zero = {0};
#define GFF_NV GFSIM_NV
#define LANE(x, j) ((x).v[(j) / GFSIM_W][(j) % GFSIM_W])
#define SPLAT(s) (gfsim_zero + (s))
/* the lanes of v below zero set to zero (a NaN or -0.0 kept, as numpy.maximum(v, 0)) */
#define CLIP0(x)                                                                     \
    do {                                                                             \
        int u_;                                                                      \
        for (u_ = 0; u_ < GFF_NV; ++u_)                                              \
            (x).v[u_] = (gfsim_vec)((gfsim_ivec)(x).v[u_] & ~((x).v[u_] < gfsim_zero)); \
    } while (0)
#else
/* no vector extension: a lane is GFSIM_G doubles, the same loops over them */
typedef struct {
    double v[GFSIM_G];
} gfsim_lane;
#define GFF_NV GFSIM_G
#define LANE(x, j) ((x).v[j])
#define SPLAT(s) (s)
#define CLIP0(x)                                                             \
    do {                                                                     \
        int u_;                                                              \
        for (u_ = 0; u_ < GFSIM_G; ++u_)                                     \
            if ((x).v[u_] < 0.0) (x).v[u_] = 0.0;                            \
    } while (0)
#endif
/* y += a x, y = s, y = x over the vectors of a lane (vector moves: a structure copy may
   go through narrower moves, which stall the wider loads that follow) */
#define AXPY(y, a, x)                                                        \
    do {                                                                     \
        const double a_ = (a);                                               \
        int u_;                                                              \
        for (u_ = 0; u_ < GFF_NV; ++u_) (y).v[u_] += a_ * (x).v[u_];         \
    } while (0)
#define FILL(y, s)                                                           \
    do {                                                                     \
        const double s_ = (s);                                               \
        int u_;                                                              \
        for (u_ = 0; u_ < GFF_NV; ++u_) (y).v[u_] = SPLAT(s_);               \
    } while (0)
#define COPY(y, x)                                                           \
    do {                                                                     \
        int u_;                                                              \
        for (u_ = 0; u_ < GFF_NV; ++u_) (y).v[u_] = (x).v[u_];               \
    } while (0)
#define EACH for (u = 0; u < GFF_NV; ++u)

/* Dimensions and channel layouts fixed at compile time (GFF_DIMS, set by
   geomfdi.simulation.fused for the plan: loops of known length, unrolled, the layout
   read from constants), else read from the arguments. */
#ifdef GFF_DIMS
#define Q_ ((int64_t)GFF_Q)
#define NS_ ((int64_t)GFF_NS)
#define NZ_ ((int64_t)GFF_NZ)
#define P_ ((int64_t)GFF_P)
#define ND_ ((int64_t)GFF_ND)
#define NROW_ ((int64_t)GFF_NROW)
#define NB_ ((int64_t)GFF_NB)
static const int64_t gff_bs[] = {GFF_BSIZE 0}, gff_ost[] = {GFF_OSTART 0},
                     gff_olen[] = {GFF_OLEN 0}, gff_dk[] = {GFF_DKIND 0},
                     gff_ds[] = {GFF_DSENS 0}, gff_dr[] = {GFF_DROW 0},
                     gff_es[] = {GFF_ESENS 0}, gff_rb[] = {GFF_RBEG 0}, gff_rd[] = {GFF_RDST 0};
#define BS_(i) gff_bs[i]
#define OST_(i) gff_ost[i]
#define OLEN_(i) gff_olen[i]
#define DK_(i) gff_dk[i]
#define DS_(i) gff_ds[i]
#define DR_(i) gff_dr[i]
#define ES_(i) gff_es[i]
#define RB_(i) gff_rb[i]
#define RD_(i) gff_rd[i]
#define GFF_INLINE static inline __attribute__((always_inline))
#else
#define Q_ q
#define NS_ nS
#define NZ_ nz
#define P_ p
#define ND_ nd
#define NROW_ nrow
#define NB_ nb
#define BS_(i) bsize[i]
#define OST_(i) ostart[i]
#define OLEN_(i) olen[i]
#define DK_(i) dkind[i]
#define DS_(i) dsens[i]
#define DR_(i) drow[i]
#define ES_(i) esens[i]
#define RB_(i) rbeg[i]
#define RD_(i) rdst[i]
#define GFF_INLINE static
#endif

/* What the statistic of a block is judged by (geomfdi.campaign.fused_scoring), per run r
 * and kernel row o (residual rdst[o]):
 *
 *   bad[r]      : a statistic non-finite or above lim[o] (the run diverged; lim[o] the
 *                 largest double for an infinite threshold);
 *   spre, spost : (R, nrow) max of z = S / thr[o] (0 for an infinite threshold) over
 *                 the samples kpre0[r] .. kon[r]-1 and kon[r] .. kpost1[r]-1;
 *   fhit        : (R, nrow) first sample of the second window with z > 1 (-1: none);
 *   codes       : (R, kend) the alarm pattern of each sample k < kend, bit rdst[o] set
 *                 when S > thr[o] and k >= kal0.
 */
#if GFF_VEXT
#define GFF_VECTOR_EVAL 1
typedef struct {
    gfsim_ivec v[GFSIM_NV];
} gfsim_ilane;
#else
#define GFF_VECTOR_EVAL 0
#endif

typedef struct {
    const double *thr, *lim;
    int64_t kal0, kend;
    uint8_t *codes;
    const int64_t *kpre0, *kon, *kpost1;
    double *spre, *spost;
    int64_t *fhit;
    uint8_t *bad;
} gff_eval;

GFF_INLINE void gff_evaluate(const gff_eval *ev, const gfsim_lane *rw, int64_t nrow,
                         const int64_t *rdst, int64_t g0, int64_t gn, int64_t kt, int64_t nt)
{
    int64_t j, t, o;
#if GFF_VECTOR_EVAL
    /* the alarm patterns and the divergence test of all lanes at once (lim: DBL_MAX for
       an infinite threshold, so that only a non-finite statistic fails it) */
    gfsim_ilane cl[GFSIM_T], okl;
    const gfsim_ivec mag = {0}, one = mag + 0x7fffffffffffffffLL;
    int u;
    EACH okl.v[u] = mag - 1;
    for (t = 0; t < nt; ++t) {
        EACH cl[t].v[u] = mag;
        for (o = 0; o < nrow; ++o) {
            const gfsim_lane *sv = rw + t * nrow + o;
            const gfsim_vec th = gfsim_zero + ev->thr[o], li = gfsim_zero + ev->lim[o];
            const gfsim_ivec bit = mag + (1LL << rdst[o]);
            EACH {
                cl[t].v[u] |= (gfsim_ivec)(sv->v[u] > th) & bit;
                okl.v[u] &= (gfsim_ivec)((gfsim_vec)((gfsim_ivec)sv->v[u] & one) <= li);
            }
        }
    }
#endif
    for (j = 0; j < gn; ++j) {
        const int64_t r = g0 + j;
        const int64_t a0 = ev->kpre0[r], a1 = ev->kon[r], a2 = ev->kpost1[r];
        double *spre = ev->spre + r * nrow, *spost = ev->spost + r * nrow;
        int64_t *fh = ev->fhit + r * nrow, lo, hi;
        uint8_t *cd = ev->codes + r * ev->kend;
#if !GFF_VECTOR_EVAL
        int bad = 0;
        /* divergence (lim: DBL_MAX for an infinite threshold, so that only a non-finite
           statistic is caught there) and the alarm patterns */
        for (t = 0; t < nt; ++t) {
            const int64_t k = kt + t;
            unsigned code = 0;
            for (o = 0; o < nrow; ++o) {
                const double sv = LANE(rw[t * nrow + o], j);
                bad |= !(fabs(sv) <= ev->lim[o]);
                code |= (unsigned)(sv > ev->thr[o]) << rdst[o];
            }
            if (k < ev->kend) cd[k] = k >= ev->kal0 ? (uint8_t)code : 0;
        }
        if (bad) ev->bad[r] = 1;
#else
        if (!LANE(okl, j)) ev->bad[r] = 1;
        lo = ev->kal0 > kt ? ev->kal0 - kt : 0;
        hi = ev->kend - kt < nt ? ev->kend - kt : nt;
        for (t = 0; t < lo && t < hi; ++t) cd[kt + t] = 0;
        for (t = lo; t < hi; ++t) cd[kt + t] = (uint8_t)LANE(cl[t], j);
#endif
        /* the scores: the largest statistic of each window divided by the threshold
           (a correctly rounded division by a positive number keeps the order, so this
           is the largest z), the first z > 1 (only where S > thr can z exceed 1) */
        lo = a0 > kt ? a0 - kt : 0;
        hi = a1 - kt < nt ? a1 - kt : nt;
        for (o = 0; o < nrow && lo < hi; ++o) {
            const double th = ev->thr[o];
            double m = LANE(rw[lo * nrow + o], j);
            for (t = lo + 1; t < hi; ++t)
                if (LANE(rw[t * nrow + o], j) > m) m = LANE(rw[t * nrow + o], j);
            m = isfinite(th) ? m / th : 0.0;
            if (m > spre[o]) spre[o] = m;
        }
        lo = a1 > kt ? a1 - kt : 0;
        hi = a2 - kt < nt ? a2 - kt : nt;
        for (o = 0; o < nrow && lo < hi; ++o) {
            const double th = ev->thr[o];
            const int fin = isfinite(th);
            double m = LANE(rw[lo * nrow + o], j);
            for (t = lo; t < hi; ++t) {
                const double sv = LANE(rw[t * nrow + o], j);
                if (sv > m) m = sv;
                if (fin && sv > th && fh[o] < 0 && sv / th > 1.0) fh[o] = kt + t;
            }
            m = fin ? m / th : 0.0;
            if (m > spost[o]) spost[o] = m;
        }
    }
}

int gffused_run(int64_t R, int64_t r0, int64_t r1, int64_t N, int64_t s, int64_t L, int64_t q,
                const double *y0c,
                const double *const *zp, const int64_t *zts, const double *lv,
                const int64_t *segptr, const int64_t *segk, const double *segeta,
                const double *seglam, const double *const *lsp, int64_t nz,
                const int64_t *dkind, const int64_t *dsens,
                const int64_t *drow, const double *W, const double *sh, const double *fs,
                int64_t nS, int64_t nb, const int64_t *bsize, const double *A, int64_t p,
                const int64_t *ostart, const int64_t *olen, const double *C, int64_t nd,
                const int64_t *esens, const double *D, const double *ys, int64_t nrow,
                const int64_t *rbeg, const int64_t *rdst, int64_t win, double *X, double *cs,
                double *ring, double *out, int64_t ors, int64_t oos, int64_t ots,
                const gff_eval *ev)
{
    const int64_t G = GFSIM_G, T = GFSIM_T;
    /* samples with a step from them: all but the record's last */
    const int64_t steps = s + L < N ? L : L - 1;
    int64_t g0, i, j, k, k0, c, o, t, b, i0, aoff, coff, ks, run[GFSIM_G], cur[64 * GFSIM_G];
    int u, samp[64];
    gfsim_lane *x, *xn, *y0n, *y, *eta, *lam, *lamr, *d, *yo, *rw, *csl, *rg;
    void *raw;
    size_t nl;
#ifdef GFF_DIMS
    if (q != Q_ || nS != NS_ || nz != NZ_ || p != P_ || nd != ND_ || nrow != NROW_ || nb != NB_)
        return -3; /* not the layout this library was built for */
#endif
    if (Q_ > 64) return -2;
    nl = (size_t)(2 * NS_ + 5 * (T + 1) * Q_ + NZ_ + ND_ + P_ + T * NROW_ + NROW_
                  + (win > 0 ? win * NROW_ : 0) + 2);
    raw = malloc(sizeof(gfsim_lane) * (nl + 1));
    if (!raw) return -1;
    x = (gfsim_lane *)(((uintptr_t)raw + sizeof(gfsim_lane) - 1) / sizeof(gfsim_lane)
                       * sizeof(gfsim_lane));
    xn = x + NS_;
    y0n = xn + NS_;
    y = y0n + (T + 1) * Q_;
    eta = y + (T + 1) * Q_;
    lam = eta + (T + 1) * Q_;
    lamr = lam + (T + 1) * Q_; /* lam at the right end of a step (sampled profiles) */
    d = lamr + (T + 1) * Q_;
    yo = d + NZ_;
    rw = yo + P_; /* the tile's residual rows (or statistics), rw[t nrow + j] */
    csl = rw + T * NROW_;
    rg = csl + NROW_; /* ring[(k mod win) nrow + j] */
    for (g0 = r0; g0 < r1; g0 += G) {
        const int64_t gn = r1 - g0 < G ? r1 - g0 : G;
        for (j = 0; j < G; ++j) run[j] = g0 + (j < gn ? j : gn - 1);
        for (i = 0; i < NS_; ++i)
            for (j = 0; j < G; ++j) LANE(x[i], j) = X[i * R + run[j]];
        if (win > 0) {
            for (o = 0; o < NROW_; ++o)
                for (j = 0; j < G; ++j) LANE(csl[o], j) = cs[o * R + run[j]];
            for (t = 0; t < win; ++t)
                for (o = 0; o < NROW_; ++o)
                    for (j = 0; j < G; ++j)
                        LANE(rg[t * NROW_ + o], j) = ring[(t * NROW_ + o) * R + run[j]];
        }
        for (i = 0; i < Q_; ++i) {
            samp[i] = 0;
            for (j = 0; j < G; ++j) {
                cur[i * G + j] = segptr[i * R + run[j]];
                if (lsp && lsp[i * R + run[j]]) samp[i] = 1;
            }
        }
        ks = win > 0 ? s % win : 0; /* the ring's slot of sample k (k mod win) */
        for (k0 = 0; k0 < L; k0 += T) {
            const int64_t nt = L - k0 < T ? L - k0 : T; /* outputs of the tile */
            const int64_t ns = steps - k0 < nt ? steps - k0 : nt; /* steps from them */
            const int64_t nv = ns == nt ? nt + 1 : nt; /* readings needed (k+1 of a step) */
            /* the fault profiles of the tile's samples: lanes filled segment by segment */
            for (i = 0; i < Q_; ++i) {
                /* the usual tile: no lane's profile changes in it (one vector each) */
                gfsim_lane ev, lv_;
                int same = 1;
                for (j = 0; j < G && same; ++j) {
                    const int64_t r = run[j], end = segptr[i * R + r + 1];
                    int64_t sg = cur[i * G + j];
                    k = s + k0;
                    while (sg + 1 < end && segk[sg + 1] <= k) ++sg;
                    cur[i * G + j] = sg;
                    if (sg + 1 < end && segk[sg + 1] < k + nv) same = 0;
                    LANE(ev, j) = segeta[sg];
                    LANE(lv_, j) = seglam[sg];
                }
                if (same) {
                    for (t = 0; t < nv; ++t) {
                        COPY(eta[t * Q_ + i], ev);
                        COPY(lam[t * Q_ + i], lv_);
                    }
                } else
                for (j = 0; j < G; ++j) {
                    const int64_t r = run[j], end = segptr[i * R + r + 1];
                    int64_t sg = cur[i * G + j];
                    t = 0;
                    while (t < nv) {
                        int64_t stop;
                        k = s + k0 + t;
                        while (sg + 1 < end && segk[sg + 1] <= k) ++sg;
                        stop = sg + 1 < end ? segk[sg + 1] - (s + k0) : nv;
                        if (stop > nv) stop = nv;
                        for (; t < stop; ++t) {
                            LANE(eta[t * Q_ + i], j) = segeta[sg];
                            LANE(lam[t * Q_ + i], j) = seglam[sg];
                        }
                    }
                    cur[i * G + j] = sg;
                }
                if (samp[i]) /* sampled lanes: lam and its value at the step's right end */
                    for (j = 0; j < G; ++j) {
                        const double *pl = lsp[i * R + run[j]];
                        if (pl) {
                            const double *pa = pl + s + k0, *pb = pl + N + s + k0 + 1;
                            for (t = 0; t < nv; ++t) LANE(lam[t * Q_ + i], j) = pa[t];
                            for (t = 0; t < ns; ++t) LANE(lamr[t * Q_ + i], j) = pb[t];
                        } else {
                            for (t = 0; t < ns; ++t)
                                LANE(lamr[t * Q_ + i], j) = LANE(lam[t * Q_ + i], j);
                        }
                    }
            }
            /* the noisy and the faulty readings */
            for (i = 0; i < Q_; ++i) {
                const double *yc = y0c + i * N + s + k0;
                for (j = 0; j < G; ++j) {
                    const int64_t r = run[j];
                    const double *src = zp ? zp[r * Q_ + i] + k0 * zts[r * Q_ + i] : NULL;
                    const int64_t ts = zp ? zts[r * Q_ + i] : 0;
                    if (!src) {
                        for (t = 0; t < nv; ++t) LANE(y0n[t * Q_ + i], j) = yc[t];
                    } else if (lv) {
                        const double li = lv[i];
                        for (t = 0; t < nv; ++t) LANE(y0n[t * Q_ + i], j) = yc[t] + li * src[t * ts];
                    } else {
                        for (t = 0; t < nv; ++t) LANE(y0n[t * Q_ + i], j) = yc[t] + src[t * ts];
                    }
#if defined(__GNUC__) || defined(__clang__)
                    /* the next tile's draws (a run's draws may be far from the cache: the
                       streams of 16 runs and several sensors are more than a processor
                       prefetches by itself) */
                    if (src && ts == 1 && k0 + T < L)
                        for (t = T; t < 2 * T + 1 && k0 + t < L; t += 8) __builtin_prefetch(src + t);
#endif
                }
            }
            for (t = 0; t < nv * Q_; ++t) {
                EACH y[t].v[u] = eta[t].v[u] * y0n[t].v[u] + lam[t].v[u];
            }
            for (t = 0; t < nt; ++t) {
                const int64_t kr = k0 + t; /* within the window */
                gfsim_lane *rt = rw + t * NROW_;
                k = s + kr;
                /* outputs of sample k: ys + D y, then C x */
                coff = 0;
                for (o = 0; o < P_; ++o) { /* (each output's sum in registers) */
                    const gfsim_lane *xs = x + OST_(o);
                    gfsim_lane acc;
                    FILL(acc, ys ? ys[k * P_ + o] : 0.0);
                    for (c = 0; c < ND_; ++c) AXPY(acc, D[o * ND_ + c], y[t * Q_ + ES_(c)]);
                    for (i = 0; i < OLEN_(o); ++i) AXPY(acc, C[coff + i], xs[i]);
                    COPY(yo[o], acc);
                    coff += OLEN_(o);
                }
                /* residual rows: one output, or the norm of several */
                for (o = 0; o < NROW_; ++o) {
                    const int64_t a = RB_(o), bnd = RB_(o + 1);
                    if (bnd - a == 1) {
                        COPY(rt[o], yo[a]);
                    } else {
                        gfsim_lane sq;
                        int64_t m;
                        EACH sq.v[u] = yo[a].v[u] * yo[a].v[u];
                        for (m = a + 1; m < bnd; ++m) {
                            EACH sq.v[u] += yo[m].v[u] * yo[m].v[u];
                        }
                        for (j = 0; j < G; ++j) LANE(rt[o], j) = sqrt(LANE(sq, j));
                    }
                }
                if (win > 0) { /* the windowed sum of squares */
                    const int64_t slot = ks * NROW_;
                    for (o = 0; o < NROW_; ++o) {
                        gfsim_lane v, c1;
                        EACH c1.v[u] = csl[o].v[u] + rt[o].v[u] * rt[o].v[u];
                        if (k >= win) {
                            EACH v.v[u] = c1.v[u] - rg[slot + o].v[u];
                        } else {
                            COPY(v, c1);
                        }
                        COPY(csl[o], c1);
                        COPY(rg[slot + o], c1);
                        CLIP0(v);
                        COPY(rt[o], v);
                    }
                    if (++ks == win) ks = 0;
                }
                if (t >= ns) break; /* the record's last sample: no step from it */
                /* the drive samples of step k -> k+1 */
                for (c = 0; c < NZ_; ++c) {
                    const int64_t ii = DS_(c), kind = DK_(c);
                    gfsim_lane et, v;
                    COPY(et, eta[t * Q_ + ii]);
                    if (kind == 0) {
                        COPY(v, y[t * Q_ + ii]);
                    } else if (kind == 1) {
                        const double yc = y0c[ii * N + k];
                        EACH v.v[u] = y[t * Q_ + ii].v[u] - et.v[u] * yc;
                    } else if (kind == 2) {
                        const double yc = y0c[ii * N + k + 1];
                        const gfsim_lane *yr = y0n + (t + 1) * Q_ + ii,
                                         *lm = (samp[ii] ? lamr : lam) + t * Q_ + ii;
                        EACH v.v[u] = (et.v[u] * yr->v[u] + lm->v[u]) - et.v[u] * yc;
                    } else {
                        const double sv = sh[DR_(c) * N + k + (kind == 4)];
                        EACH v.v[u] = (et.v[u] - 1.0) * sv;
                    }
                    COPY(d[c], v);
                }
                /* x(k+1) row by row: fs + W d, then A x (its block's columns in order):
                   the sums of compiled_recursion.c, in registers */
                i0 = 0;
                aoff = 0;
                for (b = 0; b < NB_; ++b) {
                    const int64_t n = BS_(b);
                    for (i = 0; i < n; ++i) {
                        const double *Wi = W + (i0 + i) * NZ_, *Ai = A + aoff + i * n;
                        gfsim_lane acc;
                        FILL(acc, fs ? fs[k * NS_ + i0 + i] : 0.0);
                        for (c = 0; c < NZ_; ++c) AXPY(acc, Wi[c], d[c]);
                        for (c = 0; c < n; ++c) AXPY(acc, Ai[c], x[i0 + c]);
                        COPY(xn[i0 + i], acc);
                    }
                    i0 += n;
                    aoff += n * n;
                }
                { /* the new state is the current one (the buffers swap) */
                    gfsim_lane *sw = x;
                    x = xn;
                    xn = sw;
                }
            }
            /* scatter the tile's rows (when wanted), evaluate them (when asked) */
            if (out)
                for (o = 0; o < NROW_; ++o) {
                    double *row = out + (g0 - r0) * ors + RD_(o) * oos + k0 * ots;
                    j = 0;
#ifdef GFF_T4
                    if (ots == 1) /* lanes j..j+3 of samples t..t+3: four vectors each way */
                        for (; j + 4 <= gn; j += 4) {
                            double *dj = row + j * ors;
                            for (t = 0; t + 4 <= nt; t += 4) {
                                const gfsim_lane *q0 = rw + t * NROW_ + o;
                                const __m256d r0_ = (__m256d)q0[0].v[j / 4],
                                              r1_ = (__m256d)q0[NROW_].v[j / 4],
                                              r2_ = (__m256d)q0[2 * NROW_].v[j / 4],
                                              r3_ = (__m256d)q0[3 * NROW_].v[j / 4];
                                const __m256d a0 = _mm256_unpacklo_pd(r0_, r1_),
                                              a1 = _mm256_unpackhi_pd(r0_, r1_),
                                              a2 = _mm256_unpacklo_pd(r2_, r3_),
                                              a3 = _mm256_unpackhi_pd(r2_, r3_);
                                _mm256_storeu_pd(dj + t, _mm256_permute2f128_pd(a0, a2, 0x20));
                                _mm256_storeu_pd(dj + ors + t, _mm256_permute2f128_pd(a1, a3, 0x20));
                                _mm256_storeu_pd(dj + 2 * ors + t, _mm256_permute2f128_pd(a0, a2, 0x31));
                                _mm256_storeu_pd(dj + 3 * ors + t, _mm256_permute2f128_pd(a1, a3, 0x31));
                            }
                            for (; t < nt; ++t)
                                for (u = 0; u < 4; ++u)
                                    dj[u * ors + t] = LANE(rw[t * NROW_ + o], j + u);
                        }
#endif
                    for (; j < gn; ++j) {
                        double *dst = row + j * ors;
                        for (t = 0; t < nt; ++t) dst[t * ots] = LANE(rw[t * NROW_ + o], j);
                    }
                }
            if (ev) gff_evaluate(ev, rw, NROW_, rdst, g0, gn, s + k0, nt);
        }
        for (i = 0; i < NS_; ++i)
            for (j = 0; j < gn; ++j) X[i * R + g0 + j] = LANE(x[i], j);
        if (win > 0) {
            for (o = 0; o < NROW_; ++o)
                for (j = 0; j < gn; ++j) cs[o * R + g0 + j] = LANE(csl[o], j);
            for (t = 0; t < win; ++t)
                for (o = 0; o < NROW_; ++o)
                    for (j = 0; j < gn; ++j)
                        ring[(t * NROW_ + o) * R + g0 + j] = LANE(rg[t * NROW_ + o], j);
        }
    }
    free(raw);
    return 0;
}

/* The first isolation decision of each run from its alarm codes (geomfdi.campaign.
 * fused_scoring), as geomfdi.campaign.scoring.isolate_runs decides it:
 *
 *   trivial (no rule):  pattern = the raw alarms, decision lut[pattern];
 *   otherwise:          confirmed_i(j) = #{raw_i(j-d), d < n, j-d >= 0} >= k,
 *                       pattern = the confirmed alarms held over the episode (latch;
 *                       an episode ends after reset quiet samples, reset < 0: never) or
 *                       the confirmed alarms, decision lut[pattern], settled (k-of-n
 *                       samples with the same decision) unless k = n = 1.
 *
 * For run r, over its window kon[r] .. kpost1[r]-1: first[r] the first sample with a
 * decision (a fault index or MULTIPLE, -4), dec[r] that decision, right[r] the first
 * sample whose decision is the truth (truth[r] >= 0; MULTIPLE with rl[r, pattern] set),
 * -1 for none.  Samples k < kend, codes (R, kend).
 */
#define GFF_NO_ALARM (-1)
#define GFF_UNEXPLAINED (-2)
#define GFF_AMBIGUOUS (-3)
#define GFF_MULTIPLE (-4)
#define GFF_NEVER (INT64_MIN / 4)

int gffused_isolate(int64_t R, int64_t kend, int64_t nres, const uint8_t *codes,
                    const int64_t *lut, int64_t trivial, int64_t k, int64_t n, int64_t latch,
                    int64_t reset, int64_t nf, const int64_t *kon, const int64_t *kpost1,
                    const int64_t *truth, const uint8_t *rl, int64_t *first, int64_t *dec,
                    int64_t *right)
{
    int64_t r, j, i, d;
    const int64_t ncode = (int64_t)1 << nres;
    const int settle = !trivial && !(k == 1 && n == 1);
    int64_t *hist = (int64_t *)malloc(sizeof(int64_t) * (size_t)(n > 0 ? n : 1));
    uint8_t *ring = (uint8_t *)malloc((size_t)(n > 0 ? n : 1));
    if (!hist || !ring) {
        free(hist);
        free(ring);
        return -1;
    }
    for (r = 0; r < R; ++r) {
        const uint8_t *cd = codes + r * kend;
        const int64_t w0 = kon[r], w1 = kpost1[r] < kend ? kpost1[r] : kend, tr = truth[r];
        int64_t cnt[8] = {0}, last_res[8], last_any = GFF_NEVER, ep = GFF_NEVER;
        unsigned held = 0;
        first[r] = -1;
        dec[r] = GFF_NO_ALARM;
        right[r] = -1;
        for (i = 0; i < 8; ++i) last_res[i] = GFF_NEVER;
        /* before the first alarm every state is at rest (no counts, nothing held, the
           decision of the empty pattern): start there */
        for (j = 0; j < w1 && !cd[j]; ++j) {
        }
        for (d = 0; d < n; ++d) {
            ring[d] = 0;
            hist[d] = lut[0];
        }
        if (lut[0] != GFF_NO_ALARM) j = 0; /* (a decision without alarms: from the start) */
        for (; j < w1; ++j) {
            const unsigned raw = cd[j];
            unsigned pat;
            int64_t dj;
            if (trivial) {
                pat = raw;
            } else {
                unsigned conf = 0;
                /* k of the last n raw alarms (a ring of the last n codes) */
                for (i = 0; i < nres; ++i) {
                    cnt[i] += (raw >> i) & 1u;
                    if (j >= n) cnt[i] -= (ring[j % n] >> i) & 1u;
                    if (cnt[i] >= k) conf |= 1u << i;
                }
                ring[j % n] = (uint8_t)raw;
                if (!latch) {
                    pat = conf;
                } else if (reset < 0) {
                    held |= conf;
                    pat = held;
                } else {
                    const int64_t prev = last_any;
                    if (conf) {
                        last_any = j;
                        if (prev == GFF_NEVER || j - prev - 1 >= reset) ep = j;
                    }
                    for (i = 0; i < nres; ++i)
                        if ((conf >> i) & 1u) last_res[i] = j;
                    pat = 0;
                    if (ep > GFF_NEVER && j - last_any < reset)
                        for (i = 0; i < nres; ++i)
                            if (last_res[i] >= ep) pat |= 1u << i;
                }
            }
            dj = lut[pat];
            if (settle) {
                int64_t same = 1;
                const int64_t raw_dec = dj;
                for (d = 1; d < n && d <= j; ++d) same += hist[(j - d) % n] == raw_dec;
                hist[j % n] = raw_dec;
                if (raw_dec == GFF_NO_ALARM || raw_dec == GFF_AMBIGUOUS) {
                    dj = raw_dec;
                } else if (same >= k && ((raw_dec >= 0 && raw_dec < nf) || raw_dec == GFF_MULTIPLE)) {
                    dj = raw_dec;
                } else {
                    dj = GFF_UNEXPLAINED;
                }
            }
            if (j < w0) continue;
            if (first[r] < 0 && (dj >= 0 || dj == GFF_MULTIPLE)) {
                first[r] = j;
                dec[r] = dj;
            }
            if (right[r] < 0
                && ((tr >= 0 && dj == tr)
                    || (tr == GFF_MULTIPLE && dj == GFF_MULTIPLE && rl && rl[r * ncode + pat]))) {
                right[r] = j;
            }
            if (first[r] >= 0 && right[r] >= 0) break;
        }
    }
    free(hist);
    free(ring);
    return 0;
}

/* Runs per group of lanes of this build (geomfdi.simulation.fused cuts its parts at
   multiples of it). */
int64_t gffused_group(void) { return GFSIM_G; }
