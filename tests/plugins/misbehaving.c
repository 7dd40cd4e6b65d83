/* Subroutines that misbehave on purpose, one way each, for geocel's tests of how a plug-in's failure is
 * reported (tests/test_plugins.py). Elastic (PROPS = E, nu) until they misbehave. Written for geocel. */
#include <math.h>
#include <stddef.h>

extern void xit_(void);

#define UMAT_ARGS                                                                                          \
    double *STRESS, double *STATEV, double *DDSDDE, double *SSE, double *SPD, double *SCD, double *RPL,   \
        double *DDSDDT, double *DRPLDE, double *DRPLDT, double *STRAN, double *DSTRAN, double *TIME,       \
        double *DTIME, double *TEMP, double *DTEMP, double *PREDEF, double *DPRED, char *CMNAME, int *NDI, \
        int *NSHR, int *NTENS, int *NSTATV, double *PROPS, int *NPROPS, double *COORDS, double *DROT,      \
        double *PNEWDT, double *CELENT, double *DFGRD0, double *DFGRD1, int *NOEL, int *NPT, int *LAYER,   \
        int *KSPT, int *KSTEP, int *KINC, size_t cmname_len

static void elastic(const double *props, const double *dstran, double *stress, double *ddsdde) {
    double E = props[0], nu = props[1];
    double mu = E / (2.0 * (1.0 + nu)), lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    for (int k = 0; k < 36; k++) ddsdde[k] = 0.0;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) ddsdde[i + 6 * j] = lam;
        ddsdde[i + 6 * i] += 2.0 * mu;
        ddsdde[(i + 3) * 7] = mu;
    }
    for (int i = 0; i < 6; i++) {
        double s = 0.0;
        for (int j = 0; j < 6; j++) s += ddsdde[i + 6 * j] * dstran[j];
        stress[i] += s;
    }
}

/* reads PROPS(3): NaN when the scenario gives two props (geocel pads PROPS with NaN) */
void umat_reads_props3_(UMAT_ARGS) {
    double p[2] = {PROPS[0], PROPS[1] * (1.0 + PROPS[2])};
    elastic(p, DSTRAN, STRESS, DDSDDE);
}

/* returns a NaN stress once a compressive strain increment arrives */
void umat_nan_(UMAT_ARGS) {
    elastic(PROPS, DSTRAN, STRESS, DDSDDE);
    if (DSTRAN[2] < 0.0) STRESS[2] = NAN;
}

/* asks for a smaller step */
void umat_cutback_(UMAT_ARGS) {
    elastic(PROPS, DSTRAN, STRESS, DDSDDE);
    if (DSTRAN[2] < 0.0) *PNEWDT = 0.5;
}

/* calls XIT */
void umat_xit_(UMAT_ARGS) {
    elastic(PROPS, DSTRAN, STRESS, DDSDDE);
    if (DSTRAN[2] < 0.0) xit_();
}

/* a VUMAT that writes the stress but forgets its second state variable */
void vumat_forgets_state_(int *nblock, int *ndir, int *nshr, int *nstatev, int *nfieldv, int *nprops,
                          int *lanneal, double *stepTime, double *totalTime, double *dt, char *cmname,
                          double *coordMp, double *charLength, double *props, double *density,
                          double *strainInc, double *relSpinInc, double *tempOld, double *stretchOld,
                          double *defgradOld, double *fieldOld, double *stressOld, double *stateOld,
                          double *enerInternOld, double *enerInelasOld, double *tempNew, double *stretchNew,
                          double *defgradNew, double *fieldNew, double *stressNew, double *stateNew,
                          double *enerInternNew, double *enerInelasNew, size_t cmname_len) {
    int n = *nblock;
    double E = props[0], nu = props[1];
    double mu = E / (2.0 * (1.0 + nu)), lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    for (int b = 0; b < n; b++) {
        double tr = strainInc[b] + strainInc[b + n] + strainInc[b + 2 * n];
        for (int k = 0; k < 6; k++)
            stressNew[b + n * k] = stressOld[b + n * k] + 2.0 * mu * strainInc[b + n * k] + (k < 3 ? lam * tr : 0.0);
        stateNew[b] = stateOld[b];
    }
}
