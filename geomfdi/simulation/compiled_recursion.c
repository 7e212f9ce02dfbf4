/* The bank recursion of geomfdi's batch simulation, many runs at once.
 *
 * For every run r = 0 .. R-1 and sample k = 0 .. L-1 (geomfdi.simulation.compiled_recursion):
 *
 *     out[o](r, k) = sum_t C[o, t] x[ostart[o] + t](r, k) + sum_c D[o, c] e_c(r, k) + ys[o, k]
 *     x(r, k+1)    = A x(r, k) + sum_c W[:, c] d_c(r, k) + fs[:, k]          (k < L-1)
 *
 * A is block diagonal (nb square blocks, packed row-major one after the other), the
 * outputs read a contiguous range of states each, d_c and e_c are the runs' own drive and
 * feedthrough channels (strided arrays, a scale per sample when given), fs and ys the
 * forcing and feedthrough shared by every run (computed once by the caller).  X holds the
 * states x(r, 0) on entry and x(r, L-1) on return, (nS, R) row-major.
 *
 * The runs are taken in groups of GFSIM_G: every operation acts on a "lane" of the group's
 * GFSIM_G values (two vectors of the compiler's vector extension, else a loop over the
 * group), so the arithmetic runs in SIMD instructions; the signals are gathered and the outputs
 * scattered per tile of GFSIM_T samples.  The last group repeats its last run in the
 * missing lanes (computed, never stored).
 */
#include <stdint.h>
#include <stdlib.h>

/* runs per group: two vector registers of the processor built for (two independent
   operations per coefficient read) */
#if defined(__AVX512F__)
#define GFSIM_W 8
#elif defined(__AVX__)
#define GFSIM_W 4
#else
#define GFSIM_W 2
#endif
#define GFSIM_G (2 * GFSIM_W)
#define GFSIM_T 128 /* samples per tile (signals gathered and outputs scattered per tile) */

#if defined(__GNUC__) || defined(__clang__)
typedef double gfsim_vec __attribute__((vector_size(GFSIM_W * sizeof(double)), may_alias));
typedef struct {
    gfsim_vec v[2];
} gfsim_lane;
static const gfsim_vec gfsim_zero = {0};
#define LANE(x, j) ((x).v[(j) / GFSIM_W][(j) % GFSIM_W])
#define AXPY(y, a, x)                                                        \
    do {                                                                     \
        const double a_ = (a);                                               \
        (y).v[0] += a_ * (x).v[0];                                           \
        (y).v[1] += a_ * (x).v[1];                                           \
    } while (0)
#define FILL(y, s)                                                           \
    do {                                                                     \
        const double s_ = (s);                                               \
        (y).v[0] = gfsim_zero + s_;                                          \
        (y).v[1] = gfsim_zero + s_;                                          \
    } while (0)
#else
typedef struct {
    double v[GFSIM_G];
} gfsim_lane;
#define LANE(x, j) ((x).v[j])
#define AXPY(y, a, x)                                                        \
    do {                                                                     \
        const double a_ = (a);                                               \
        int q_;                                                              \
        for (q_ = 0; q_ < GFSIM_G; ++q_) (y).v[q_] += a_ * (x).v[q_];        \
    } while (0)
#define FILL(y, s)                                                           \
    do {                                                                     \
        const double s_ = (s);                                               \
        int q_;                                                              \
        for (q_ = 0; q_ < GFSIM_G; ++q_) (y).v[q_] = s_;                     \
    } while (0)
#endif

typedef struct {
    const double *p; /* sample (run 0, time 0) */
    int64_t rs, ts;  /* element strides over runs (0: shared) and time */
    const double *sp; /* per-sample scale, or NULL */
    int64_t srs, sts;
} gfsim_chan;

/* out[i] = init[i, k] + sum_c M[i, c] v[c] for the rows i < rows (init NULL: 0), four
   rows at a time: four independent sums in registers */
static void gfsim_gemv(int64_t rows, int64_t cols, const double *M, const gfsim_lane *v,
                       const double *init, int64_t ild, int64_t k, gfsim_lane *out)
{
    int64_t i, c;
    for (i = 0; i + 4 <= rows; i += 4) {
        const double *M0 = M + i * cols, *M1 = M0 + cols, *M2 = M1 + cols, *M3 = M2 + cols;
        gfsim_lane a0, a1, a2, a3;
        FILL(a0, init ? init[i * ild + k] : 0.0);
        FILL(a1, init ? init[(i + 1) * ild + k] : 0.0);
        FILL(a2, init ? init[(i + 2) * ild + k] : 0.0);
        FILL(a3, init ? init[(i + 3) * ild + k] : 0.0);
        for (c = 0; c < cols; ++c) {
            const gfsim_lane vc = v[c];
            AXPY(a0, M0[c], vc);
            AXPY(a1, M1[c], vc);
            AXPY(a2, M2[c], vc);
            AXPY(a3, M3[c], vc);
        }
        out[i] = a0;
        out[i + 1] = a1;
        out[i + 2] = a2;
        out[i + 3] = a3;
    }
    for (; i < rows; ++i) {
        const double *Mi = M + i * cols;
        gfsim_lane a;
        FILL(a, init ? init[i * ild + k] : 0.0);
        for (c = 0; c < cols; ++c) AXPY(a, Mi[c], v[c]);
        out[i] = a;
    }
}

int gfsim_run(int64_t nS, int64_t R, int64_t L, int64_t nb, const int64_t *bsize,
              const double *A, int64_t nz, const double *W, const gfsim_chan *dch,
              const double *fs, int64_t fsld, int64_t p, const int64_t *ostart,
              const int64_t *olen, const double *C, int64_t nd, const double *D,
              const gfsim_chan *ech, const double *ys, int64_t ysld, const gfsim_chan *och,
              double *X)
{
    const int64_t G = GFSIM_G, T = GFSIM_T;
    int64_t g0, i, j, k, k0, c, o, t, b, i0, aoff, coff, run[GFSIM_G];
    gfsim_lane *x, *xn, *d, *e, *y;
    double *dv, *ev, *yv;
    const double **dp, **sp, **ep;
    double **op;
    void *raw, *ptrs;
    size_t nl = (size_t)(2 * nS + T * (nz + nd + p) + 1);

    raw = malloc(sizeof(gfsim_lane) * (nl + 1));
    ptrs = malloc(sizeof(double *) * (size_t)((2 * nz + nd + p) * G + 1));
    if (!raw || !ptrs) {
        free(raw);
        free(ptrs);
        return -1;
    }
    /* lanes aligned for the vector instructions: the states, then per tile the drive
       samples d[tt nz + c], the feedthrough samples e[tt nd + c], the outputs y[tt p + o] */
    x = (gfsim_lane *)(((uintptr_t)raw + sizeof(gfsim_lane) - 1)
                       / sizeof(gfsim_lane) * sizeof(gfsim_lane));
    xn = x + nS;
    d = xn + nS;
    e = d + T * nz;
    y = e + T * nd;
    dv = (double *)d;
    ev = (double *)e;
    yv = (double *)y;
    dp = (const double **)ptrs;
    sp = dp + nz * G;
    ep = sp + nz * G;
    op = (double **)(ep + nd * G);
    for (g0 = 0; g0 < R; g0 += G) {
        int64_t gn = R - g0 < G ? R - g0 : G;
        for (j = 0; j < G; ++j) run[j] = g0 + (j < gn ? j : gn - 1);
        for (c = 0; c < nz; ++c)
            for (j = 0; j < G; ++j) {
                dp[c * G + j] = dch[c].p + run[j] * dch[c].rs;
                sp[c * G + j] = dch[c].sp ? dch[c].sp + run[j] * dch[c].srs : NULL;
            }
        for (c = 0; c < nd; ++c)
            for (j = 0; j < G; ++j) ep[c * G + j] = ech[c].p + run[j] * ech[c].rs;
        for (o = 0; o < p; ++o)
            for (j = 0; j < G; ++j) op[o * G + j] = (double *)och[o].p + run[j] * och[o].rs;
        for (i = 0; i < nS; ++i)
            for (j = 0; j < G; ++j) LANE(x[i], j) = X[i * R + run[j]];
        for (k0 = 0; k0 < L; k0 += T) {
            const int64_t nt = L - k0 < T ? L - k0 : T;     /* samples k0 .. k0+nt-1 */
            const int64_t ns = L - 1 - k0 < nt ? L - 1 - k0 : nt; /* steps from them */
            /* gather the tile's samples of every run of the group */
            for (c = 0; c < nd; ++c) {
                const int64_t ts = ech[c].ts;
                for (j = 0; j < G; ++j) {
                    const double *src = ep[c * G + j] + k0 * ts;
                    for (t = 0; t < nt; ++t) ev[(t * nd + c) * G + j] = src[t * ts];
                }
            }
            for (c = 0; c < nz; ++c) {
                const int64_t ts = dch[c].ts, sts = dch[c].sts;
                for (j = 0; j < G; ++j) {
                    const double *src = dp[c * G + j] + k0 * ts;
                    if (sp[c * G + j]) {
                        const double *sc = sp[c * G + j] + k0 * sts;
                        for (t = 0; t < ns; ++t) dv[(t * nz + c) * G + j] = sc[t * sts] * src[t * ts];
                    } else {
                        for (t = 0; t < ns; ++t) dv[(t * nz + c) * G + j] = src[t * ts];
                    }
                }
            }
            for (t = 0; t < nt; ++t) {
                gfsim_lane *yt = y + t * p;
                const gfsim_lane *et = e + t * nd, *dt = d + t * nz;
                k = k0 + t;
                /* outputs of sample k: ys + D e, then C x */
                gfsim_gemv(p, nd, D, et, ys, ysld, k, yt);
                coff = 0;
                for (o = 0; o < p; ++o) {
                    const gfsim_lane *xs = x + ostart[o];
                    for (i = 0; i < olen[o]; ++i) AXPY(yt[o], C[coff + i], xs[i]);
                    coff += olen[o];
                }
                if (t >= ns) break; /* the last sample: no step from it */
                /* the state update of step k -> k+1: fs + W d, then A x block by block
                   (column by column: the rows' sums are independent) */
                gfsim_gemv(nS, nz, W, dt, fs, fsld, k, xn);
                i0 = 0;
                aoff = 0;
                for (b = 0; b < nb; ++b) {
                    const int64_t n = bsize[b];
                    for (c = 0; c < n; ++c)
                        for (i = 0; i < n; ++i) AXPY(xn[i0 + i], A[aoff + i * n + c], x[i0 + c]);
                    i0 += n;
                    aoff += n * n;
                }
                for (i = 0; i < nS; ++i) x[i] = xn[i];
            }
            /* scatter the tile's outputs */
            for (o = 0; o < p; ++o) {
                const int64_t ts = och[o].ts;
                for (j = 0; j < gn; ++j) {
                    double *dst = op[o * G + j] + k0 * ts;
                    for (t = 0; t < nt; ++t) dst[t * ts] = yv[(t * p + o) * G + j];
                }
            }
        }
        for (i = 0; i < nS; ++i)
            for (j = 0; j < gn; ++j) X[i * R + g0 + j] = LANE(x[i], j);
    }
    free(raw);
    free(ptrs);
    return 0;
}

/* ------------------------------------------------------------------------------------
 * One run (geomfdi.simulation.compiled_single): the states in the layout
 *
 *     z = [real modes (nr) | real parts of the complex pairs (nc) | their imaginary
 *          parts (nc) | dense blocks (sizes bsize, packed column-major in Apk)]
 *
 * and for k = 0 .. L-1
 *
 *     out[o](k) = ys[o, k] + sum over the output's segments of coef * z(k)
 *     z(k+1)    = T z(k) + sum_c V[c, :] d_c(k)                          (k < L-1)
 *
 * with T diagonal on the real modes (ar), the rotation [[ca, cb], [-cb, ca]] on each
 * pair and the dense blocks.  Output row o reads the segments seg[sptr[o] .. sptr[o+1]-1]
 * (start and length each) of z, its coefficients packed in coef in that order; or, with
 * ilp > 0 (real modes interleaved: mode j of output o at j ilp + o, ilp a multiple of
 * 4), out[o] = sum over j of ilc[j ilp + o] z[j ilp + o], four outputs per vector; or,
 * with ilp < 0, out[o] = z[o] (the outputs are the state, in its own coordinates).
 * Vectorised over the states, four at a time; z holds z(0) on entry and z(L-1) on
 * return.
 */
#if defined(__GNUC__) || defined(__clang__)
typedef double gfs_v4 __attribute__((vector_size(4 * sizeof(double))));
static inline gfs_v4 gfs_load(const double *p)
{
    gfs_v4 v;
    __builtin_memcpy(&v, p, sizeof v);
    return v;
}
static inline void gfs_store(double *p, gfs_v4 v) { __builtin_memcpy(p, &v, sizeof v); }
#define GFS_VEC 1
#endif

static inline double gfsim_dot(const double *c, const double *x, int64_t n)
{
    int64_t i = 0;
    double s;
    if (n == 1) return c[0] * x[0];
#ifdef GFS_VEC
    if (n >= 4) {
        gfs_v4 a = gfs_load(c) * gfs_load(x);
        for (i = 4; i + 4 <= n; i += 4) a += gfs_load(c + i) * gfs_load(x + i);
        s = (a[0] + a[1]) + (a[2] + a[3]);
    } else {
        s = 0.0;
    }
#else
    double s1 = 0.0, s2 = 0.0, s3 = 0.0;
    s = 0.0;
    for (; i + 4 <= n; i += 4) {
        s += c[i] * x[i];
        s1 += c[i + 1] * x[i + 1];
        s2 += c[i + 2] * x[i + 2];
        s3 += c[i + 3] * x[i + 3];
    }
    s = (s + s1) + (s2 + s3);
#endif
    for (; i < n; ++i) s += c[i] * x[i];
    return s;
}

/* g[i] = (init ? init[i] * z[i] : 0) + sum_c V[c, i] dv[c] for i0 <= i < i1, written to
   out (which may be z itself: each element is read before it is written) */
static void gfsim_force(int64_t i0, int64_t i1, int64_t nS, int64_t nz, const double *V,
                        const double *dv, const double *init, const double *z, double *out)
{
    int64_t i = i0, c;
#ifdef GFS_VEC
    for (; i + 16 <= i1; i += 16) { /* sixteen states: four independent sums */
        gfs_v4 a0, a1, a2, a3;
        if (init) {
            a0 = gfs_load(init + i) * gfs_load(z + i);
            a1 = gfs_load(init + i + 4) * gfs_load(z + i + 4);
            a2 = gfs_load(init + i + 8) * gfs_load(z + i + 8);
            a3 = gfs_load(init + i + 12) * gfs_load(z + i + 12);
        } else {
            a0 = (gfs_v4){0.0, 0.0, 0.0, 0.0};
            a1 = a0;
            a2 = a0;
            a3 = a0;
        }
        for (c = 0; c < nz; ++c) {
            const double *Vc = V + c * nS + i;
            const double dc = dv[c];
            a0 += gfs_load(Vc) * dc;
            a1 += gfs_load(Vc + 4) * dc;
            a2 += gfs_load(Vc + 8) * dc;
            a3 += gfs_load(Vc + 12) * dc;
        }
        gfs_store(out + i, a0);
        gfs_store(out + i + 4, a1);
        gfs_store(out + i + 8, a2);
        gfs_store(out + i + 12, a3);
    }
    for (; i + 8 <= i1; i += 8) {
        gfs_v4 a0, a1;
        if (init) {
            a0 = gfs_load(init + i) * gfs_load(z + i);
            a1 = gfs_load(init + i + 4) * gfs_load(z + i + 4);
        } else {
            a0 = (gfs_v4){0.0, 0.0, 0.0, 0.0};
            a1 = a0;
        }
        for (c = 0; c < nz; ++c) {
            const double *Vc = V + c * nS + i;
            const double dc = dv[c];
            a0 += gfs_load(Vc) * dc;
            a1 += gfs_load(Vc + 4) * dc;
        }
        gfs_store(out + i, a0);
        gfs_store(out + i + 4, a1);
    }
    for (; i + 4 <= i1; i += 4) {
        gfs_v4 a0 = init ? gfs_load(init + i) * gfs_load(z + i) : (gfs_v4){0.0, 0.0, 0.0, 0.0};
        for (c = 0; c < nz; ++c) a0 += gfs_load(V + c * nS + i) * dv[c];
        gfs_store(out + i, a0);
    }
#endif
    for (; i < i1; ++i) {
        double a = init ? init[i] * z[i] : 0.0;
        for (c = 0; c < nz; ++c) a += V[c * nS + i] * dv[c];
        out[i] = a;
    }
}

int gfsim_single(int64_t L, int64_t nr, const double *ar, int64_t nc, const double *ca,
                 const double *cb, int64_t nb, const int64_t *bsize, const double *Apk,
                 int64_t nz, const double *V, const gfsim_chan *dch, int64_t p,
                 const int64_t *sptr, const int64_t *seg, const double *coef, int64_t ilp,
                 const double *ilc, const double *ys, int64_t ysld, const gfsim_chan *och,
                 double *z)
{
    const int64_t T = GFSIM_T, pw = ilp > p ? ilp : p; /* values per sample in the tile */
    int64_t nS = nr + 2 * nc, nmax = 1, i, c, o, b, k, q, t;
    double *g, *xn, *dv, *yb;
    for (b = 0; b < nb; ++b) {
        nS += bsize[b];
        if (bsize[b] > nmax) nmax = bsize[b];
    }
    g = (double *)malloc(sizeof(double) * (size_t)(nS + nmax + nz + T * pw + 1));
    if (!g) return -1;
    xn = g + nS;
    dv = xn + nmax;
    yb = dv + nz; /* the outputs of a tile of T samples, sample-major */
    for (k = 0; k < L; ++k) {
        /* outputs of sample k (into the tile, scattered to the rows when it is full) */
        const double *cf = coef;
        double *yt = yb + (k % T) * pw;
        if (ilp < 0) { /* the outputs are the state itself: out[o] = z[o] */
            i = 0;
#ifdef GFS_VEC
            for (; i + 4 <= p; i += 4) gfs_store(yt + i, gfs_load(z + i));
#endif
            for (; i < p; ++i) yt[i] = z[i];
            if (ys)
                for (o = 0; o < p; ++o) yt[o] += ys[o * ysld + k];
        } else if (ilp) { /* interleaved modes: output b = sum over j of ilc z at j ilp + b */
            for (o = 0; o < ilp; o += 4) {
                i = o;
#ifdef GFS_VEC
                gfs_v4 a = gfs_load(ilc + i) * gfs_load(z + i);
                for (i += ilp; i < nr; i += ilp) a += gfs_load(ilc + i) * gfs_load(z + i);
                gfs_store(yt + o, a);
#else
                double a0 = ilc[i] * z[i], a1 = ilc[i + 1] * z[i + 1];
                double a2 = ilc[i + 2] * z[i + 2], a3 = ilc[i + 3] * z[i + 3];
                for (i += ilp; i < nr; i += ilp) {
                    a0 += ilc[i] * z[i];
                    a1 += ilc[i + 1] * z[i + 1];
                    a2 += ilc[i + 2] * z[i + 2];
                    a3 += ilc[i + 3] * z[i + 3];
                }
                yt[o] = a0;
                yt[o + 1] = a1;
                yt[o + 2] = a2;
                yt[o + 3] = a3;
#endif
            }
            if (ys)
                for (o = 0; o < p; ++o) yt[o] += ys[o * ysld + k];
        }
        for (o = 0; o < p && ilp == 0; ++o) {
            const int64_t q0 = sptr[o], q1 = sptr[o + 1];
            double s;
            if (q1 == q0 + 1 && seg[2 * q0 + 1] == 1) { /* one coefficient (a state) */
                s = cf[0] * z[seg[2 * q0]];
                cf += 1;
            } else {
                s = 0.0;
                for (q = q0; q < q1; ++q) {
                    const int64_t len = seg[2 * q + 1];
                    s += gfsim_dot(cf, z + seg[2 * q], len);
                    cf += len;
                }
            }
            yt[o] = ys ? ys[o * ysld + k] + s : s;
        }
        if (k % T == T - 1 || k == L - 1) {
            const int64_t k0 = k - k % T, nt = k % T + 1;
            for (o = 0; o < p; ++o) {
                double *dst = (double *)och[o].p + k0 * och[o].ts;
                const int64_t ts = och[o].ts;
                for (t = 0; t < nt; ++t) dst[t * ts] = yb[t * pw + o];
            }
        }
        if (k == L - 1) break;
        /* the drive samples of step k -> k+1 */
        for (c = 0; c < nz; ++c) {
            const double *src = dch[c].p + k * dch[c].ts;
            dv[c] = dch[c].sp ? dch[c].sp[k * dch[c].sts] * src[0] : src[0];
        }
        /* real modes in place: z = ar z + V d; the forcing of the others into g */
        gfsim_force(0, nr, nS, nz, V, dv, ar, z, z);
        gfsim_force(nr, nS, nS, nz, V, dv, NULL, z, g);
        {
            double *zr = z + nr, *zi = zr + nc;
            const double *gr = g + nr, *gi = gr + nc;
            for (i = 0; i < nc; ++i) {
                const double re = zr[i], im = zi[i];
                zr[i] = (ca[i] * re + cb[i] * im) + gr[i];
                zi[i] = (ca[i] * im - cb[i] * re) + gi[i];
            }
        }
        {
            int64_t i0 = nr + 2 * nc, aoff = 0, n, j;
            for (b = 0; b < nb; ++b) {
                const double *zb = z + i0;
                n = bsize[b];
                i = 0;
#ifdef GFS_VEC
                for (; i + 8 <= n; i += 8) { /* eight rows in registers over the columns */
                    gfs_v4 a0 = gfs_load(g + i0 + i), a1 = gfs_load(g + i0 + i + 4);
                    gfs_v4 b0 = {0.0, 0.0, 0.0, 0.0}, b1 = b0; /* odd columns: shorter chains */
                    for (j = 0; j + 2 <= n; j += 2) {
                        const double *Aj = Apk + aoff + j * n + i, *Ak = Aj + n;
                        a0 += gfs_load(Aj) * zb[j];
                        a1 += gfs_load(Aj + 4) * zb[j];
                        b0 += gfs_load(Ak) * zb[j + 1];
                        b1 += gfs_load(Ak + 4) * zb[j + 1];
                    }
                    if (j < n) {
                        const double *Aj = Apk + aoff + j * n + i;
                        a0 += gfs_load(Aj) * zb[j];
                        a1 += gfs_load(Aj + 4) * zb[j];
                    }
                    gfs_store(xn + i, a0 + b0);
                    gfs_store(xn + i + 4, a1 + b1);
                }
                for (; i + 4 <= n; i += 4) {
                    gfs_v4 a0 = gfs_load(g + i0 + i), b0 = {0.0, 0.0, 0.0, 0.0};
                    for (j = 0; j + 2 <= n; j += 2) {
                        a0 += gfs_load(Apk + aoff + j * n + i) * zb[j];
                        b0 += gfs_load(Apk + aoff + (j + 1) * n + i) * zb[j + 1];
                    }
                    if (j < n) a0 += gfs_load(Apk + aoff + j * n + i) * zb[j];
                    gfs_store(xn + i, a0 + b0);
                }
#endif
                for (; i < n; ++i) {
                    double a = g[i0 + i];
                    for (j = 0; j < n; ++j) a += Apk[aoff + j * n + i] * zb[j];
                    xn[i] = a;
                }
                i = 0;
#ifdef GFS_VEC
                for (; i + 4 <= n; i += 4) gfs_store(z + i0 + i, gfs_load(xn + i));
#endif
                for (; i < n; ++i) z[i0 + i] = xn[i];
                i0 += n;
                aoff += n * n;
            }
        }
    }
    free(g);
    return 0;
}
