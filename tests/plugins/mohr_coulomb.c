/*
 * geocel's linear-elastic perfectly-plastic Mohr–Coulomb model (non-associated flow, tension cut-off) as an
 * Abaqus-style UMAT and VUMAT (test plug-in).
 *
 * A port of geocel.materials.mohr_coulomb.mc_update with the helpers it uses (elastic.lame,
 * principal.principal_values / eigh3 / compose): the same algorithm, the same operations in the same
 * order, so that it gives the built-in kernel's numbers to round-off (bit for bit against the built-in compiled
 * without fast-math; geocel's kernels inherit fast-math flags, FMA contraction among them, and differ from
 * it in the last bits). In short:
 *
 *   1. elastic trial σ_tr = σ + λ tr(Δε) I + 2μ Δε, void ratio e ← (1 + e) exp(tr Δε) − 1
 *      (an exactly zero increment changes nothing);
 *   2. screen with the closed-form principal values; if not clearly elastic, cyclic Jacobi
 *      eigen-decomposition and the exact yield check f <= 1e-10·scale;
 *   3. exact return in principal space (eigenvectors of the trial kept): a table of likely active sets
 *      of the constraints f_13, f_23, f_12, t_1..t_3 and the other sextants' planes, then every set of
 *      size <= 3; each solved by Cramer's rule; the first Kuhn–Tucker-consistent set is taken.
 *
 *   PROPS  = (E [Pa], ν, φ [rad], ψ [rad], c [Pa], σ_t [Pa]) — the built-in array (MohrCoulomb.to_array;
 *            Tresca.to_array: φ = ψ = 0, σ_t = +inf)          NPROPS = 6 (otherwise UMAT PNEWDT = 0,
 *            VUMAT stressNew = NaN)
 *   STATEV = (e)                                              NSTATV >= 1 (the rest passed through)
 *
 * The UMAT returns the isotropic elastic DDSDDE (engineering shear): geocel takes only the P-wave modulus
 * λ + 2μ from it, as the built-in returns. Sign convention: tension positive. Re-entrant: no static
 * mutable data.
 *
 * Build: cc -O2 -fPIC -shared -o libmohr_coulomb.so mohr_coulomb.c -lm
 */

/* IEEE evaluation in source order: keep a*b + c as two roundings (no FMA contraction, also none through
 * GCC's SLP vectoriser, which fuses add/sub pairs even with fp-contract=off where FMA is enabled) */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off", "no-tree-slp-vectorize")
#endif

#include <math.h>
#include <stddef.h>

#define N_PROPS 6
#define P_PHI 2
#define P_PSI 3
#define P_C 4
#define P_SIGMA_T 5

/* relative tolerance on admissibility f <= tol (mohr_coulomb.YIELD_RTOL) */
#define YIELD_RTOL 1.0e-10
/* screening margin for the closed-form principal values */
#define SCREEN_RTOL 1.0e-6
/* relative determinant below which a candidate active set is singular */
#define SINGULAR_RTOL 1.0e-12
#define MAX_SWEEPS 50
#define TWO_PI_3 (2.0 * 3.141592653589793 / 3.0)

/* constraints: MC planes f_ij (i, j principal indices, 0 = σ1, 2 = σ3); j = -1: tension plane on σ_i */
#define N_CON 9
static const int CON_I[N_CON] = {0, 1, 0, 0, 1, 2, 2, 2, 1};
static const int CON_J[N_CON] = {2, 2, 1, -1, -1, -1, 0, 1, 0};
#define N_CAND 13
static const int CANDIDATES[N_CAND][3] = {
    {0, -1, -1}, {0, 1, -1}, {0, 2, -1}, {3, -1, -1}, {0, 3, -1}, {3, 4, -1}, {3, 4, 5},
    {0, 3, 4},   {0, 1, 3},  {0, 1, 4},  {1, 3, 4},   {0, 2, 3},  {0, 1, 2},
};
/* 6-vector slot -> (row, column) */
static const int ROW[6] = {0, 1, 2, 0, 0, 1};
static const int COL[6] = {0, 1, 2, 1, 2, 2};

/* Python's (and Numba's) max(a, b) / min(a, b) */
static double pymax(double a, double b) { return b > a ? b : a; }
static double pymin(double a, double b) { return b < a ? b : a; }

/* ---------------------------------------------------------------- principal.py */

/* closed-form principal values σ1 >= σ2 >= σ3 (principal.principal_values); screening only */
static void principal_values(const double *a6, double *l1, double *l2, double *l3)
{
    const double p = (a6[0] + a6[1] + a6[2]) / 3.0;
    const double s0 = a6[0] - p;
    const double s1 = a6[1] - p;
    const double s2 = a6[2] - p;
    const double off = a6[3] * a6[3] + a6[4] * a6[4] + a6[5] * a6[5];
    const double j2 = 0.5 * (s0 * s0 + s1 * s1 + s2 * s2) + off;
    double j3, rr, r, theta;
    if (j2 <= 0.0) {
        *l1 = p;
        *l2 = p;
        *l3 = p;
        return;
    }
    j3 = s0 * (s1 * s2 - a6[5] * a6[5]) - a6[3] * (a6[3] * s2 - a6[5] * a6[4]) +
         a6[4] * (a6[3] * a6[5] - s1 * a6[4]);
    rr = sqrt(j2 / 3.0);
    r = j3 / (2.0 * rr * rr * rr);
    r = pymin(1.0, pymax(-1.0, r));
    theta = acos(r) / 3.0;
    *l1 = p + 2.0 * rr * cos(theta);
    *l3 = p + 2.0 * rr * cos(theta + TWO_PI_3);
    *l2 = 3.0 * p - *l1 - *l3;
}

/* (c, s, t) of the Jacobi rotation that annihilates apq (overflow-safe) */
static void jacobi_angle(double app, double aqq, double apq, double *c, double *s, double *t)
{
    const double theta = 0.5 * (aqq - app) / apq;
    double tt;
    if (fabs(theta) > 1.0e150) {
        tt = 0.5 / theta;
    } else {
        tt = 1.0 / (fabs(theta) + sqrt(theta * theta + 1.0));
        if (theta < 0.0)
            tt = -tt;
    }
    *c = 1.0 / sqrt(tt * tt + 1.0);
    *s = tt * *c;
    *t = tt;
}

/* off-diagonal below the round-off of both diagonals */
static int negligible(double apq, double app, double aqq)
{
    const double g = 100.0 * fabs(apq);
    return fabs(app) + g == fabs(app) && fabs(aqq) + g == fabs(aqq);
}

static void rotate_vecs(double vecs[3][3], int p, int q, double c, double s)
{
    int r;
    for (r = 0; r < 3; r++) {
        const double vrp = vecs[r][p];
        const double vrq = vecs[r][q];
        vecs[r][p] = c * vrp - s * vrq;
        vecs[r][q] = s * vrp + c * vrq;
    }
}

/* cyclic Jacobi eigen-decomposition (principal.eigh3): vals ascending, eigenvectors = columns of vecs */
static void eigh3(const double *a6, double vals[3], double vecs[3][3])
{
    double d0 = a6[0], d1 = a6[1], d2 = a6[2];
    double o01 = a6[3], o02 = a6[4], o12 = a6[5];
    double c, s, t, ap, aq, tmp;
    int i, j, r, sweep;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++)
            vecs[i][j] = (i == j) ? 1.0 : 0.0;

    for (sweep = 0; sweep < MAX_SWEEPS; sweep++) {
        if (o01 == 0.0 && o02 == 0.0 && o12 == 0.0)
            break;
        /* pair (0, 1) */
        if (o01 != 0.0) {
            if (negligible(o01, d0, d1)) {
                o01 = 0.0;
            } else {
                jacobi_angle(d0, d1, o01, &c, &s, &t);
                d0 -= t * o01;
                d1 += t * o01;
                o01 = 0.0;
                ap = o02;
                aq = o12;
                o02 = c * ap - s * aq;
                o12 = s * ap + c * aq;
                rotate_vecs(vecs, 0, 1, c, s);
            }
        }
        /* pair (0, 2) */
        if (o02 != 0.0) {
            if (negligible(o02, d0, d2)) {
                o02 = 0.0;
            } else {
                jacobi_angle(d0, d2, o02, &c, &s, &t);
                d0 -= t * o02;
                d2 += t * o02;
                o02 = 0.0;
                ap = o01;
                aq = o12;
                o01 = c * ap - s * aq;
                o12 = s * ap + c * aq;
                rotate_vecs(vecs, 0, 2, c, s);
            }
        }
        /* pair (1, 2) */
        if (o12 != 0.0) {
            if (negligible(o12, d1, d2)) {
                o12 = 0.0;
            } else {
                jacobi_angle(d1, d2, o12, &c, &s, &t);
                d1 -= t * o12;
                d2 += t * o12;
                o12 = 0.0;
                ap = o01;
                aq = o02;
                o01 = c * ap - s * aq;
                o02 = s * ap + c * aq;
                rotate_vecs(vecs, 1, 2, c, s);
            }
        }
    }
    vals[0] = d0;
    vals[1] = d1;
    vals[2] = d2;
    /* insertion sort, eigenvector columns permuted alongside */
    for (i = 1; i < 3; i++) {
        j = i;
        while (j > 0 && vals[j - 1] > vals[j]) {
            tmp = vals[j - 1];
            vals[j - 1] = vals[j];
            vals[j] = tmp;
            for (r = 0; r < 3; r++) {
                tmp = vecs[r][j - 1];
                vecs[r][j - 1] = vecs[r][j];
                vecs[r][j] = tmp;
            }
            j--;
        }
    }
}

/* a6 <- V diag(vals) V^T (principal.compose) */
static void compose(const double vals[3], double vecs[3][3], double *a6)
{
    int k;
    for (k = 0; k < 6; k++) {
        const int i = ROW[k];
        const int j = COL[k];
        a6[k] = vals[0] * vecs[i][0] * vecs[j][0] + vals[1] * vecs[i][1] * vecs[j][1] +
                vals[2] * vecs[i][2] * vecs[j][2];
    }
}

/* ---------------------------------------------------------------- return mapping */

/* n_i . D_p m_j */
static double adm(double w[N_CON][8], int i, int j)
{
    return w[i][0] * w[j][3] + w[i][1] * w[j][4] + w[i][2] * w[j][5];
}

/* active set (i0, i1, i2)[:m]: returns the violation (<= 0: Kuhn–Tucker-consistent; inf: singular),
 * the returned principal stresses in o[3] (the trial where singular) */
static double try_set(double w[N_CON][8], int i0, int i1, int i2, int m, double s1, double s2, double s3,
                      double ltol, double ftol, double o[3])
{
    double d0 = 0.0, d1 = 0.0, d2 = 0.0, viol;
    double o1, o2, o3;
    int k;
    o[0] = s1;
    o[1] = s2;
    o[2] = s3;
    if (m == 1) {
        const double a00 = adm(w, i0, i0);
        if (!(fabs(a00) > 0.0))
            return INFINITY;
        d0 = w[i0][7] / a00;
    } else if (m == 2) {
        const double a00 = adm(w, i0, i0);
        const double a01 = adm(w, i0, i1);
        const double a10 = adm(w, i1, i0);
        const double a11 = adm(w, i1, i1);
        const double det = a00 * a11 - a01 * a10;
        if (!(fabs(det) > SINGULAR_RTOL * hypot(a00, a01) * hypot(a10, a11)))
            return INFINITY;
        d0 = (w[i0][7] * a11 - a01 * w[i1][7]) / det;
        d1 = (a00 * w[i1][7] - w[i0][7] * a10) / det;
    } else {
        const double a00 = adm(w, i0, i0);
        const double a01 = adm(w, i0, i1);
        const double a02 = adm(w, i0, i2);
        const double a10 = adm(w, i1, i0);
        const double a11 = adm(w, i1, i1);
        const double a12 = adm(w, i1, i2);
        const double a20 = adm(w, i2, i0);
        const double a21 = adm(w, i2, i1);
        const double a22 = adm(w, i2, i2);
        const double c00 = a11 * a22 - a12 * a21;
        const double c01 = a12 * a20 - a10 * a22;
        const double c02 = a10 * a21 - a11 * a20;
        const double det = a00 * c00 + a01 * c01 + a02 * c02;
        const double rn = sqrt(a00 * a00 + a01 * a01 + a02 * a02) * sqrt(a10 * a10 + a11 * a11 + a12 * a12) *
                          sqrt(a20 * a20 + a21 * a21 + a22 * a22);
        double r0, r1, r2;
        if (!(fabs(det) > SINGULAR_RTOL * rn))
            return INFINITY;
        r0 = w[i0][7];
        r1 = w[i1][7];
        r2 = w[i2][7];
        d0 = (c00 * r0 + (a02 * a21 - a01 * a22) * r1 + (a01 * a12 - a02 * a11) * r2) / det;
        d1 = (c01 * r0 + (a00 * a22 - a02 * a20) * r1 + (a02 * a10 - a00 * a12) * r2) / det;
        d2 = (c02 * r0 + (a01 * a20 - a00 * a21) * r1 + (a00 * a11 - a01 * a10) * r2) / det;
    }
    if (!(isfinite(d0) && isfinite(d1) && isfinite(d2)))
        return INFINITY;
    o1 = s1 - d0 * w[i0][3];
    o2 = s2 - d0 * w[i0][4];
    o3 = s3 - d0 * w[i0][5];
    viol = (-d0 - ltol) * (ftol / ltol);
    if (m >= 2) {
        o1 -= d1 * w[i1][3];
        o2 -= d1 * w[i1][4];
        o3 -= d1 * w[i1][5];
        viol = pymax(viol, (-d1 - ltol) * (ftol / ltol));
    }
    if (m == 3) {
        o1 -= d2 * w[i2][3];
        o2 -= d2 * w[i2][4];
        o3 -= d2 * w[i2][5];
        viol = pymax(viol, (-d2 - ltol) * (ftol / ltol));
    }
    for (k = 0; k < N_CON; k++)
        viol = pymax(viol, w[k][0] * o1 + w[k][1] * o2 + w[k][2] * o3 - w[k][6] - ftol);
    o[0] = o1;
    o[1] = o2;
    o[2] = o3;
    return viol;
}

/* exact perfect-plasticity return of the principal trial stresses s1 >= s2 >= s3 into out[3];
 * returns the mask of the active constraints */
static int return_principal(double s1, double s2, double s3, double lam, double mu, double phi, double psi,
                            double c, double sigma_t, double scale, double out[3])
{
    const double sphi = sin(phi);
    const double spsi = sin(psi);
    const double kc = 2.0 * c * cos(phi);
    double w[N_CON][8];
    double ftol, ltol, best, viol, o[3];
    int k, q, m, i0, i1, i2, bmask;

    for (k = 0; k < N_CON; k++) {
        const int i = CON_I[k];
        const int j = CON_J[k];
        double m0, m1, m2, vm;
        int l;
        for (l = 0; l < 8; l++)
            w[k][l] = 0.0;
        if (j >= 0) {
            const double mi = 1.0 + spsi;
            const double mj = -(1.0 - spsi);
            w[k][i] = 1.0 + sphi;
            w[k][j] = -(1.0 - sphi);
            w[k][6] = kc;
            m0 = i == 0 ? mi : (j == 0 ? mj : 0.0);
            m1 = i == 1 ? mi : (j == 1 ? mj : 0.0);
            m2 = i == 2 ? mi : (j == 2 ? mj : 0.0);
        } else {
            w[k][i] = 1.0; /* associated cut-off */
            w[k][6] = sigma_t;
            m0 = i == 0 ? 1.0 : 0.0;
            m1 = i == 1 ? 1.0 : 0.0;
            m2 = i == 2 ? 1.0 : 0.0;
        }
        vm = lam * (m0 + m1 + m2); /* D_p m = λ (m·1) 1 + 2μ m */
        w[k][3] = vm + 2.0 * mu * m0;
        w[k][4] = vm + 2.0 * mu * m1;
        w[k][5] = vm + 2.0 * mu * m2;
        w[k][7] = w[k][0] * s1 + w[k][1] * s2 + w[k][2] * s3 - w[k][6];
    }

    ftol = YIELD_RTOL * scale;
    ltol = ftol / (lam + 2.0 * mu);
    best = INFINITY;
    out[0] = s1;
    out[1] = s2;
    out[2] = s3;
    bmask = 0;
    for (q = 0; q < N_CAND; q++) {
        i0 = CANDIDATES[q][0];
        i1 = CANDIDATES[q][1];
        i2 = CANDIDATES[q][2];
        m = i1 < 0 ? 1 : (i2 < 0 ? 2 : 3);
        viol = try_set(w, i0, i1, i2, m, s1, s2, s3, ltol, ftol, o);
        if (viol < best) {
            best = viol;
            out[0] = o[0];
            out[1] = o[1];
            out[2] = o[2];
            bmask = (1 << i0) | (m >= 2 ? (1 << i1) : 0) | (m == 3 ? (1 << i2) : 0);
            if (best <= 0.0)
                return bmask;
        }
    }
    /* exhaustive search over all sets of size 1..3 */
    for (m = 1; m < 4; m++) {
        for (i0 = 0; i0 < N_CON; i0++) {
            for (i1 = i0 + 1; i1 < (m >= 2 ? N_CON : i0 + 2); i1++) {
                for (i2 = i1 + 1; i2 < (m == 3 ? N_CON : i1 + 2); i2++) {
                    viol = try_set(w, i0, i1, i2, m, s1, s2, s3, ltol, ftol, o);
                    if (viol < best) {
                        best = viol;
                        out[0] = o[0];
                        out[1] = o[1];
                        out[2] = o[2];
                        bmask = (1 << i0) | (m >= 2 ? (1 << i1) : 0) | (m == 3 ? (1 << i2) : 0);
                        if (best <= 0.0)
                            return bmask;
                    }
                }
            }
        }
    }
    /* no exactly consistent set (round-off only): the least violating one */
    return bmask;
}

/* ---------------------------------------------------------------- the point update */

static void lame(const double *props, double *lam, double *mu)
{
    const double E = props[0];
    const double nu = props[1];
    *mu = E / (2.0 * (1.0 + nu));
    *lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
}

/* one increment (mohr_coulomb.mc_update after its co-rotation): stress s and strain increment d in
 * geocel's order 11, 22, 33, 12, 13, 23, tensor shear; e the void ratio */
static void mc_point(const double *props, double lam, double mu, double *s, double *e, const double *d)
{
    double tr, ltr, phi, c, sigma_t, sphi, kc, l1, l2, l3, scale, s1, s3, vals[3], vecs[3][3], o[3];
    int k;
    if (d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0 && d[3] == 0.0 && d[4] == 0.0 && d[5] == 0.0)
        return; /* zero increment: nothing to do (the built-in's ZERO_INCREMENT rule) */

    tr = d[0] + d[1] + d[2];
    *e = (1.0 + *e) * exp(tr) - 1.0;
    ltr = lam * tr;
    for (k = 0; k < 3; k++)
        s[k] += ltr + 2.0 * mu * d[k];
    for (k = 3; k < 6; k++)
        s[k] += 2.0 * mu * d[k];

    phi = props[P_PHI];
    c = props[P_C];
    sigma_t = props[P_SIGMA_T];
    sphi = sin(phi);
    kc = 2.0 * c * cos(phi);

    /* cheap screen: clearly inside -> elastic */
    principal_values(s, &l1, &l2, &l3);
    scale = pymax(pymax(pymax(fabs(l1), fabs(l3)), c), 1e-300);
    if (pymax((l1 - l3) + (l1 + l3) * sphi - kc, l1 - sigma_t) <= -SCREEN_RTOL * scale)
        return;

    eigh3(s, vals, vecs);
    s1 = vals[2];
    s3 = vals[0];
    scale = pymax(pymax(pymax(fabs(s1), fabs(s3)), c), 1e-300);
    if (pymax((s1 - s3) + (s1 + s3) * sphi - kc, s1 - sigma_t) <= YIELD_RTOL * scale)
        return;

    return_principal(s1, vals[1], s3, lam, mu, phi, props[P_PSI], c, sigma_t, scale, o);
    vals[2] = o[0];
    vals[1] = o[1];
    vals[0] = o[2];
    compose(vals, vecs, s);
}

/* isotropic elastic Jacobian for engineering shear, column-major 6x6 (P-wave modulus λ + 2μ) */
static void elastic_jacobian(double lam, double mu, double *ddsdde)
{
    int i, j;
    const double pw = lam + 2.0 * mu;
    for (j = 0; j < 6; j++)
        for (i = 0; i < 6; i++)
            ddsdde[i + 6 * j] = 0.0;
    for (j = 0; j < 3; j++)
        for (i = 0; i < 3; i++)
            ddsdde[i + 6 * j] = (i == j) ? pw : lam;
    for (i = 3; i < 6; i++)
        ddsdde[i + 6 * i] = mu;
}

void umat_(double *STRESS, double *STATEV, double *DDSDDE, double *SSE, double *SPD, double *SCD,
           double *RPL, double *DDSDDT, double *DRPLDE, double *DRPLDT, double *STRAN, double *DSTRAN,
           double *TIME, double *DTIME, double *TEMP, double *DTEMP, double *PREDEF, double *DPRED,
           char *CMNAME, int *NDI, int *NSHR, int *NTENS, int *NSTATV, double *PROPS, int *NPROPS,
           double *COORDS, double *DROT, double *PNEWDT, double *CELENT, double *DFGRD0, double *DFGRD1,
           int *NOEL, int *NPT, int *LAYER, int *KSPT, int *KSTEP, int *KINC, size_t cmname_len)
{
    double lam, mu, d[6];
    int i;
    (void)SSE; (void)SPD; (void)SCD; (void)RPL; (void)DDSDDT; (void)DRPLDE; (void)DRPLDT; (void)STRAN;
    (void)TIME; (void)DTIME; (void)TEMP; (void)DTEMP; (void)PREDEF; (void)DPRED; (void)CMNAME;
    (void)NDI; (void)NSHR; (void)COORDS; (void)DROT; (void)CELENT; (void)DFGRD0; (void)DFGRD1;
    (void)NOEL; (void)NPT; (void)LAYER; (void)KSPT; (void)KSTEP; (void)KINC; (void)cmname_len;

    if (*NPROPS != N_PROPS || *NSTATV < 1 || *NTENS != 6) {
        *PNEWDT = 0.0; /* wrong layout: geocel reports it */
        return;
    }
    lame(PROPS, &lam, &mu);
    elastic_jacobian(lam, mu, DDSDDE);
    for (i = 0; i < 3; i++)
        d[i] = DSTRAN[i];
    for (i = 3; i < 6; i++)
        d[i] = 0.5 * DSTRAN[i]; /* engineering -> tensor shear */
    mc_point(PROPS, lam, mu, STRESS, &STATEV[0], d);
}

void vumat_(int *nblock, int *ndir, int *nshr, int *nstatev, int *nfieldv, int *nprops, int *lanneal,
            double *stepTime, double *totalTime, double *dt, char *cmname, double *coordMp,
            double *charLength, double *props, double *density, double *strainInc, double *relSpinInc,
            double *tempOld, double *stretchOld, double *defgradOld, double *fieldOld,
            double *stressOld, double *stateOld, double *enerInternOld, double *enerInelasOld,
            double *tempNew, double *stretchNew, double *defgradNew, double *fieldNew,
            double *stressNew, double *stateNew, double *enerInternNew, double *enerInelasNew,
            size_t cmname_len)
{
    /* VUMAT order 11, 22, 33, 12, 23, 31 <-> geocel's 11, 22, 33, 12, 13, 23 */
    static const int from_vumat[6] = {0, 1, 2, 3, 5, 4};
    const int nb = *nblock;
    const int nsv = *nstatev;
    double lam, mu, s[6], d[6], e;
    int b, k;
    (void)nfieldv; (void)lanneal; (void)stepTime; (void)totalTime; (void)dt; (void)cmname; (void)coordMp;
    (void)charLength; (void)density; (void)relSpinInc; (void)tempOld; (void)stretchOld; (void)defgradOld;
    (void)fieldOld; (void)enerInternOld; (void)enerInelasOld; (void)tempNew; (void)stretchNew;
    (void)defgradNew; (void)fieldNew; (void)enerInternNew; (void)enerInelasNew; (void)cmname_len;

    if (*nprops != N_PROPS || nsv < 1 || *ndir != 3 || *nshr != 3) {
        for (b = 0; b < nb; b++) {
            for (k = 0; k < 6; k++)
                stressNew[b + (size_t)nb * k] = NAN; /* wrong layout: geocel reports it */
            for (k = 0; k < nsv; k++)
                stateNew[b + (size_t)nb * k] = NAN;
        }
        return;
    }
    lame(props, &lam, &mu);
    for (b = 0; b < nb; b++) {
        for (k = 0; k < 6; k++) {
            s[k] = stressOld[b + (size_t)nb * from_vumat[k]];
            d[k] = strainInc[b + (size_t)nb * from_vumat[k]]; /* tensor shear already */
        }
        e = stateOld[b];
        mc_point(props, lam, mu, s, &e, d);
        for (k = 0; k < 6; k++)
            stressNew[b + (size_t)nb * from_vumat[k]] = s[k];
        stateNew[b] = e;
        for (k = 1; k < nsv; k++)
            stateNew[b + (size_t)nb * k] = stateOld[b + (size_t)nb * k];
    }
}
