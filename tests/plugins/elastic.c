/*
 * geocel's isotropic linear (hypo)elastic soil model as an Abaqus-style UMAT and VUMAT (test plug-in).
 *
 * A port of geocel.materials.elastic.elastic_update, written to give the built-in kernel's numbers to
 * round-off (the same operations in the same order; bit for bit against the built-in compiled without
 * fast-math: geocel's kernels compile it with fast-math flags, FMA contraction among them, a few ulps apart):
 *
 *     Δσ = λ tr(Δε) I + 2μ Δε,   μ = E / (2 (1 + ν)),   λ = E ν / ((1 + ν)(1 − 2ν)),
 *     e ← (1 + e) exp(tr Δε) − 1   (void ratio, kinematic update),
 *
 * and nothing at all (stress and e unchanged) for an exactly zero strain increment, as the built-in.
 *
 *   PROPS  = (E [Pa], ν)           NPROPS = 2 (otherwise: UMAT PNEWDT = 0, VUMAT stressNew = NaN)
 *   STATEV = (e)                   NSTATV >= 1 (state variables beyond the first are passed through)
 *
 * The stress arrives co-rotated by geocel (no tensor-valued state to rotate). Calling convention:
 * tests' plugin spec (all arguments by reference, INTEGER = int32, REAL = double, the hidden length of
 * CMNAME last as size_t). Re-entrant: no static mutable data.
 *
 * Build: cc -O2 -fPIC -shared -o libelastic.so elastic.c -lm
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

#define N_PROPS 2

/* Lamé constants from E and ν (elastic.lame) */
static void lame(const double *props, double *lam, double *mu)
{
    const double E = props[0];
    const double nu = props[1];
    *mu = E / (2.0 * (1.0 + nu));
    *lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
}

/* one increment at one point; s and d in geocel's order 11, 22, 33, 12, 13, 23, tensor shear */
static void elastic_point(double lam, double mu, double *s, double *e, const double *d)
{
    int i;
    double tr;
    if (d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0 && d[3] == 0.0 && d[4] == 0.0 && d[5] == 0.0)
        return; /* zero increment: nothing to do (the built-in's ZERO_INCREMENT rule) */
    tr = d[0] + d[1] + d[2];
    for (i = 0; i < 3; i++)
        s[i] += lam * tr + 2.0 * mu * d[i];
    for (i = 3; i < 6; i++)
        s[i] += 2.0 * mu * d[i];
    *e = (1.0 + *e) * exp(d[0] + d[1] + d[2]) - 1.0;
}

/* isotropic elastic Jacobian for engineering shear, column-major 6x6 */
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
    elastic_point(lam, mu, STRESS, &STATEV[0], d);
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
        elastic_point(lam, mu, s, &e, d);
        for (k = 0; k < 6; k++)
            stressNew[b + (size_t)nb * from_vumat[k]] = s[k];
        stateNew[b] = e;
        for (k = 1; k < nsv; k++)
            stateNew[b + (size_t)nb * k] = stateOld[b + (size_t)nb * k];
    }
}
