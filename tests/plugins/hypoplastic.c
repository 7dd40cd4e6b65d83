/*
 * hypoplastic.c -- geocel's built-in hypoplastic soil model (von Wolffersdorff 1996 with the intergranular
 * strain of Niemunis & Herle 1997, geocel's low-stress floor and bounding surface) as an Abaqus-style UMAT and
 * VUMAT, written from src/geocel/materials/hypoplastic.py for the plug-in tests: the test suite compiles it
 * (cc -O2 -fPIC -shared -lm) and compares it with the built-in Numba kernel (model 2 of
 * geocel.materials.kernels.update_point) to 1e-10 relative.
 *
 * The core below follows the built-in's formulas (rate_scalar, floor_tuple, bound_tuple/_project, euler_tuple,
 * _adaptive, volume_ratio), so that the two agree to round-off (the built-in is compiled with fast-math flags:
 * contract, reassoc, arcp, afn, so last-bit differences remain anyway). For speed, rate_scalar arranges them
 * differently where that changes round-off only (see its comment), and exp and log are this file's own (hp_exp,
 * hp_log: within 1 ulp of glibc's).
 *
 * Calling convention: geocel's plug-in convention (docs/own-soil-model.md): Fortran by-reference arguments,
 * int32 INTEGERs, double REALs, a trailing size_t hidden length of CMNAME. Re-entrant: no static mutable
 * state (geocel calls it from several threads at once).
 *
 * PROPS (NPROPS = 22, 1-based as in Abaqus):
 *   PROPS(1..20)  the built-in parameter array, exactly geocel.config.materials.Hypoplastic(...).to_array()
 *                 (the P_* indices of hypoplastic.py, N_PARAMS = 20, derived entries included):
 *                  1 phi_c (rad)   2 h_s (Pa)   3 n      4 e_d0    5 e_c0   6 e_i0   7 alpha   8 beta
 *                  9 m_T          10 m_R       11 R     12 beta_r 13 chi   14 igs (1/0)       15 p_min (Pa)
 *                 16 a            17 f_b constant       18 bound (1/0)     19 f_d(e_i)        20 bound ns2
 *   PROPS(21)     tol: > 0 adaptive Heun-Euler substepping with that local tolerance (update_point with tol > 0),
 *                 <= 0 equal forward-Euler substeps
 *   PROPS(22)     max_sub: the largest substep strain of the Euler path, nsub = max(1, ceil(||deps|| / max_sub))
 *                 capped at 1000 (geocel.euler.lagrange.substeps, tensor-shear norm); <= 0 or inf: nsub = 1
 *   NPROPS != 22 (or fewer than 7 state variables) is an error: PNEWDT = 0 (UMAT), stressNew = NaN (VUMAT).
 *
 * State variables (7, as the built-in's state array, tensor shear):
 *   UMAT  STATEV   = (e, d11, d22, d33, d12, d13, d23)   (the built-in's order; rotated here with DROT)
 *   VUMAT stateOld = (e, d11, d22, d33, d12, d23, d31)   (the VUMAT order; geocel co-rotates the group
 *                                                          starting at state variable 2, named delta_11 … delta_23)
 */

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* Speed (benchmarks/material_throughput.py, an explicit step: one Euler substep per call): the per-point path
 * umat_/vumat_ -> hypo_update -> euler_substeps -> rate_scalar -> stress_direction, floor_stress, bound_stress is
 * inlined into one function, so that the tensors stay in registers; exp and log are inline (a libm call would
 * spill every live register, around each of the ~10 calls of an increment); the rare paths (zero increment,
 * adaptive scheme, bounding-surface projection) are out of line and work on copies, so that taking their
 * arguments' addresses does not keep the hot path's tensors in memory. */
#if defined(__GNUC__) || defined(__clang__)
#define HP_INLINE static inline __attribute__((always_inline))
#define HP_NOINLINE static __attribute__((noinline))
#else
#define HP_INLINE static inline
#define HP_NOINLINE static
#endif

/* parameter array layout (hypoplastic.py P_*) */
enum {
    P_PHI_C = 0,
    P_HS = 1,
    P_N = 2,
    P_ED0 = 3,
    P_EC0 = 4,
    P_EI0 = 5,
    P_ALPHA = 6,
    P_BETA = 7,
    P_MT = 8,
    P_MR = 9,
    P_R = 10,
    P_BETA_R = 11,
    P_CHI = 12,
    P_IGS = 13,
    P_PMIN = 14,
    P_A = 15,
    P_FB_CONST = 16,
    P_BOUND = 17,
    P_FD_MAX = 18,
    P_BOUND_NS2 = 19,
    N_PARAMS = 20
};

#define HP_NPROPS 22 /* N_PARAMS + tol + max_sub */
#define HP_NSTATE 7

/* flags (geocel.materials.flags): kept for fidelity, the plug-in interface has no place for them */
#define FL_LOW_STRESS 1
#define FL_VOID_BELOW_ED 2
#define FL_VOID_ABOVE_EI 4
#define FL_ZERO_INCREMENT 8
#define FL_RHO_CLIPPED 16
#define FL_SUBSTEP_LIMIT 128
#define FL_BOUNDED 256

#define MAX_SUBSTEPS 200000     /* hypoplastic.MAX_SUBSTEPS */
#define MIN_SUBSTEP 1.0e-7      /* hypoplastic.MIN_SUBSTEP */
#define FLOOR_SUBSTEP 1.0e-3    /* hypoplastic.FLOOR_SUBSTEP */
#define MAX_CELL_SUBSTEPS 1000  /* geocel.euler.lagrange.MAX_CELL_SUBSTEPS */

static const double THIRD = 1.0 / 3.0;
static const double SQRT2 = 1.4142135623730951;    /* np.sqrt(2.0) */
static const double SQRT3 = 1.7320508075688772;    /* np.sqrt(3.0) */
static const double SQRT6 = 2.449489742783178;     /* np.sqrt(6.0) */
static const double INV_2SQRT2 = 0.3535533905932738; /* 1 / (2 sqrt 2) */

/* 2^(j/64), j = 0..63, correctly rounded (computed with Python's decimal module, 80 digits) */
static const double hp_exp_tab[64] = {
    0x1.0000000000000p+0, 0x1.02c9a3e778061p+0, 0x1.059b0d3158574p+0, 0x1.0874518759bc8p+0,
    0x1.0b5586cf9890fp+0, 0x1.0e3ec32d3d1a2p+0, 0x1.11301d0125b51p+0, 0x1.1429aaea92de0p+0,
    0x1.172b83c7d517bp+0, 0x1.1a35beb6fcb75p+0, 0x1.1d4873168b9aap+0, 0x1.2063b88628cd6p+0,
    0x1.2387a6e756238p+0, 0x1.26b4565e27cddp+0, 0x1.29e9df51fdee1p+0, 0x1.2d285a6e4030bp+0,
    0x1.306fe0a31b715p+0, 0x1.33c08b26416ffp+0, 0x1.371a7373aa9cbp+0, 0x1.3a7db34e59ff7p+0,
    0x1.3dea64c123422p+0, 0x1.4160a21f72e2ap+0, 0x1.44e086061892dp+0, 0x1.486a2b5c13cd0p+0,
    0x1.4bfdad5362a27p+0, 0x1.4f9b2769d2ca7p+0, 0x1.5342b569d4f82p+0, 0x1.56f4736b527dap+0,
    0x1.5ab07dd485429p+0, 0x1.5e76f15ad2148p+0, 0x1.6247eb03a5585p+0, 0x1.6623882552225p+0,
    0x1.6a09e667f3bcdp+0, 0x1.6dfb23c651a2fp+0, 0x1.71f75e8ec5f74p+0, 0x1.75feb564267c9p+0,
    0x1.7a11473eb0187p+0, 0x1.7e2f336cf4e62p+0, 0x1.82589994cce13p+0, 0x1.868d99b4492edp+0,
    0x1.8ace5422aa0dbp+0, 0x1.8f1ae99157736p+0, 0x1.93737b0cdc5e5p+0, 0x1.97d829fde4e50p+0,
    0x1.9c49182a3f090p+0, 0x1.a0c667b5de565p+0, 0x1.a5503b23e255dp+0, 0x1.a9e6b5579fdbfp+0,
    0x1.ae89f995ad3adp+0, 0x1.b33a2b84f15fbp+0, 0x1.b7f76f2fb5e47p+0, 0x1.bcc1e904bc1d2p+0,
    0x1.c199bdd85529cp+0, 0x1.c67f12e57d14bp+0, 0x1.cb720dcef9069p+0, 0x1.d072d4a07897cp+0,
    0x1.d5818dcfba487p+0, 0x1.da9e603db3285p+0, 0x1.dfc97337b9b5fp+0, 0x1.e502ee78b3ff6p+0,
    0x1.ea4afa2a490dap+0, 0x1.efa1bee615a27p+0, 0x1.f50765b6e4540p+0, 0x1.fa7c1819e90d8p+0,
};
/* (c, 1/c, log c) for subinterval i = 0..127 of [0x1.69555p-1, 0x1.69555p+0) (128 equal steps of the bit pattern,
 * as hp_log indexes it): c its midpoint rounded to a multiple of 2^-10 (so that z - c is exact), 1/c and log c
 * correctly rounded (Python's decimal module, 80 digits); |z/c - 1| <= 0.0042 */
static const double hp_log_tab[128][3] = {
    {0x1.6a80000000000p-1, 0x1.6993f349cc726p+0, -0x1.61965cdb02c1fp-2},
    {0x1.6c80000000000p-1, 0x1.67980e0bf08c7p+0, -0x1.5bf406b543db2p-2},
    {0x1.6e80000000000p-1, 0x1.65a1b3dd13357p+0, -0x1.565995069514cp-2},
    {0x1.7080000000000p-1, 0x1.63b0cda236e1cp+0, -0x1.50c6f1d11b97cp-2},
    {0x1.7280000000000p-1, 0x1.61c544c0161c5p+0, -0x1.4b3c077267e9ap-2},
    {0x1.7480000000000p-1, 0x1.5fdf0317b5c6fp+0, -0x1.45b8c0a17df13p-2},
    {0x1.7680000000000p-1, 0x1.5dfdf303137b6p+0, -0x1.403d086cea79cp-2},
    {0x1.7880000000000p-1, 0x1.5c21ff51ef005p+0, -0x1.3ac8ca38e5c5fp-2},
    {0x1.7a80000000000p-1, 0x1.5a4b1346add2bp+0, -0x1.355bf1bd82c8bp-2},
    {0x1.7c80000000000p-1, 0x1.58791a9357ccep+0, -0x1.2ff66b04ea9d4p-2},
    {0x1.7e80000000000p-1, 0x1.56ac0156ac015p+0, -0x1.2a982269a3dbfp-2},
    {0x1.8080000000000p-1, 0x1.54e3b4194ce66p+0, -0x1.25410494e56c7p-2},
    {0x1.8280000000000p-1, 0x1.53201fcb02fb1p+0, -0x1.1ff0fe7cf47a7p-2},
    {0x1.8480000000000p-1, 0x1.516131c015161p+0, -0x1.1aa7fd638d33fp-2},
    {0x1.8680000000000p-1, 0x1.4fa6d7aeb597cp+0, -0x1.1565eed455fc3p-2},
    {0x1.8880000000000p-1, 0x1.4df0ffac83c01p+0, -0x1.102ac0a35cc1cp-2},
    {0x1.8a80000000000p-1, 0x1.4c3f982c20723p+0, -0x1.0af660eb9e279p-2},
    {0x1.8c80000000000p-1, 0x1.4a928ffad5b5cp+0, -0x1.05c8be0d9635ap-2},
    {0x1.8e80000000000p-1, 0x1.48e9d63e504d1p+0, -0x1.00a1c6adda473p-2},
    {0x1.9080000000000p-1, 0x1.47455a726abf2p+0, -0x1.f702d36777df0p-3},
    {0x1.9280000000000p-1, 0x1.45a50c670938fp+0, -0x1.eccf2c8fe920ap-3},
    {0x1.9480000000000p-1, 0x1.4408dc3e05b22p+0, -0x1.e2a877a6b2c12p-3},
    {0x1.9680000000000p-1, 0x1.4270ba692bc4dp+0, -0x1.d88e93fb2f450p-3},
    {0x1.9880000000000p-1, 0x1.40dc97a843ae8p+0, -0x1.ce816157f1988p-3},
    {0x1.9a80000000000p-1, 0x1.3f4c65072bf74p+0, -0x1.c480c0005ccd1p-3},
    {0x1.9c80000000000p-1, 0x1.3dc013dc013dcp+0, -0x1.ba8c90ae4ad19p-3},
    {0x1.9e80000000000p-1, 0x1.3c3795c553afbp+0, -0x1.b0a4b48fc1b46p-3},
    {0x1.a080000000000p-1, 0x1.3ab2dca869b81p+0, -0x1.a6c90d44b704ep-3},
    {0x1.a280000000000p-1, 0x1.3931daaf8f721p+0, -0x1.9cf97cdce0ec3p-3},
    {0x1.a480000000000p-1, 0x1.37b4824872744p+0, -0x1.9335e5d594989p-3},
    {0x1.a680000000000p-1, 0x1.363ac622898b1p+0, -0x1.897e2b17b19a5p-3},
    {0x1.a880000000000p-1, 0x1.34c4992d87fd9p+0, -0x1.7fd22ff599d4fp-3},
    {0x1.aa80000000000p-1, 0x1.3351ee97dbfc6p+0, -0x1.7631d82935a86p-3},
    {0x1.ac80000000000p-1, 0x1.31e2b9cd37dc2p+0, -0x1.6c9d07d203fc7p-3},
    {0x1.ae80000000000p-1, 0x1.3076ee7525c2cp+0, -0x1.6313a37335d76p-3},
    {0x1.b080000000000p-1, 0x1.2f0e8071a5703p+0, -0x1.59958ff1d52f1p-3},
    {0x1.b280000000000p-1, 0x1.2da963ddd3cfbp+0, -0x1.5022b292f6a45p-3},
    {0x1.b480000000000p-1, 0x1.2c478d0c9c013p+0, -0x1.46baf0f9f5db7p-3},
    {0x1.b680000000000p-1, 0x1.2ae8f087718d0p+0, -0x1.3d5e3126bc27fp-3},
    {0x1.b880000000000p-1, 0x1.298d830d13780p+0, -0x1.340c59741142ep-3},
    {0x1.ba80000000000p-1, 0x1.2835399057efdp+0, -0x1.2ac55095f5c59p-3},
    {0x1.bc80000000000p-1, 0x1.26e009370049cp+0, -0x1.2188fd9807263p-3},
    {0x1.be80000000000p-1, 0x1.258de75895121p+0, -0x1.185747dbecf34p-3},
    {0x1.c080000000000p-1, 0x1.243ec97d49eaep+0, -0x1.0f301717cf0fbp-3},
    {0x1.c280000000000p-1, 0x1.22f2a55ce8fc5p+0, -0x1.06135354d4b18p-3},
    {0x1.c480000000000p-1, 0x1.21a970ddc5ba7p+0, -0x1.fa01c9db57ce2p-4},
    {0x1.c680000000000p-1, 0x1.20632213b6c6dp+0, -0x1.e7f1691a32d3ep-4},
    {0x1.c880000000000p-1, 0x1.1f1faf3f16b64p+0, -0x1.d5f55659210e2p-4},
    {0x1.ca80000000000p-1, 0x1.1ddf0ecbcb841p+0, -0x1.c40d6425a5cb1p-4},
    {0x1.cc80000000000p-1, 0x1.1ca13750547fep+0, -0x1.b23965a52ff00p-4},
    {0x1.ce80000000000p-1, 0x1.1b661f8cde833p+0, -0x1.a0792e9277cacp-4},
    {0x1.d080000000000p-1, 0x1.1a2dbe6a5e3e4p+0, -0x1.8ecc933aeb6e8p-4},
    {0x1.d280000000000p-1, 0x1.18f80af9b06dcp+0, -0x1.7d33687c293c9p-4},
    {0x1.d480000000000p-1, 0x1.17c4fc72bfcb9p+0, -0x1.6bad83c1883b6p-4},
    {0x1.d680000000000p-1, 0x1.16948a33b08fap+0, -0x1.5a3abb01ade25p-4},
    {0x1.d880000000000p-1, 0x1.1566abc011567p+0, -0x1.48dae4bc31018p-4},
    {0x1.da80000000000p-1, 0x1.143b58c01143bp+0, -0x1.378dd7f749714p-4},
    {0x1.dc80000000000p-1, 0x1.131288ffbb3b6p+0, -0x1.26536c3d8c369p-4},
    {0x1.de80000000000p-1, 0x1.11ec346e36092p+0, -0x1.152b799bb3cc9p-4},
    {0x1.e080000000000p-1, 0x1.10c8531d0952ep+0, -0x1.0415d89e74444p-4},
    {0x1.e280000000000p-1, 0x1.0fa6dd3f67322p+0, -0x1.e624c4a0b5e1bp-5},
    {0x1.e480000000000p-1, 0x1.0e87cb297a51ep+0, -0x1.c441e06f72a9ep-5},
    {0x1.e680000000000p-1, 0x1.0d6b154fb86f9p+0, -0x1.a282b8a936171p-5},
    {0x1.e880000000000p-1, 0x1.0c50b446391f3p+0, -0x1.80e7023d8ccc4p-5},
    {0x1.ea80000000000p-1, 0x1.0b38a0c010b39p+0, -0x1.5f6e73078efb8p-5},
    {0x1.ec80000000000p-1, 0x1.0a22d38eaf2bfp+0, -0x1.3e18c1ca0ae92p-5},
    {0x1.ee80000000000p-1, 0x1.090f45a1430aap+0, -0x1.1ce5a62bc353ap-5},
    {0x1.f080000000000p-1, 0x1.07fdf0041ff7cp+0, -0x1.f7a9b16782856p-6},
    {0x1.f280000000000p-1, 0x1.06eecbe029155p+0, -0x1.b5cc258b718e6p-6},
    {0x1.f480000000000p-1, 0x1.05e1d27a3ee9cp+0, -0x1.74321d3d006d3p-6},
    {0x1.f680000000000p-1, 0x1.04d6fd32b0c7bp+0, -0x1.32db0ea132e22p-6},
    {0x1.f880000000000p-1, 0x1.03ce4584b19a0p+0, -0x1.e38ce3033310cp-7},
    {0x1.fa80000000000p-1, 0x1.02c7a505cffbfp+0, -0x1.61e77e8b53fc6p-7},
    {0x1.fc80000000000p-1, 0x1.01c315657186bp+0, -0x1.c189cbb0e27fbp-8},
    {0x1.fe80000000000p-1, 0x1.00c0906c513cfp+0, -0x1.80904828985c0p-9},
    {0x1.0080000000000p+0, 0x1.ff007fc01ff00p-1, 0x1.ff802a9ab10e6p-10},
    {0x1.0240000000000p+0, 0x1.fb8a096acfaccp-1, 0x1.1ebde2d1997e6p-7},
    {0x1.0440000000000p+0, 0x1.f7a388f9da20fp-1, 0x1.0dc4518afcc88p-6},
    {0x1.0640000000000p+0, 0x1.f3cc435b0713cp-1, 0x1.8b31faca9b00ep-6},
    {0x1.0840000000000p+0, 0x1.f003e007c00f8p-1, 0x1.03d5d85e73eefp-5},
    {0x1.0a40000000000p+0, 0x1.ec4a09225fab6p-1, 0x1.419a9095936bap-5},
    {0x1.0c40000000000p+0, 0x1.e89e6b5ccf172p-1, 0x1.7ee8f25cd417cp-5},
    {0x1.0e40000000000p+0, 0x1.e500b5e044342p-1, 0x1.bbc2bfc44f417p-5},
    {0x1.1040000000000p+0, 0x1.e1709a3611655p-1, 0x1.f829b0e783300p-5},
    {0x1.1240000000000p+0, 0x1.ddedcc31791dap-1, 0x1.1a0fba1bf8a52p-4},
    {0x1.1440000000000p+0, 0x1.da7801da7801ep-1, 0x1.37d2d762831d0p-4},
    {0x1.1640000000000p+0, 0x1.d70ef35979370p-1, 0x1.555efe40b50b5p-4},
    {0x1.1840000000000p+0, 0x1.d3b25ae3e929dp-1, 0x1.72b4f842ea8fbp-4},
    {0x1.1a40000000000p+0, 0x1.d061f4a99bc6ep-1, 0x1.8fd58aa8c2113p-4},
    {0x1.1c40000000000p+0, 0x1.cd1d7ec2fbb8ep-1, 0x1.acc17684332acp-4},
    {0x1.1e40000000000p+0, 0x1.c9e4b91ff8d87p-1, 0x1.c97978d78e920p-4},
    {0x1.2040000000000p+0, 0x1.c6b76577ac845p-1, 0x1.e5fe4ab272a05p-4},
    {0x1.2240000000000p+0, 0x1.c3954738ab1b9p-1, 0x1.012850a6dfcafp-3},
    {0x1.2440000000000p+0, 0x1.c07e2379fa4e6p-1, 0x1.0f3897134b12ep-3},
    {0x1.2640000000000p+0, 0x1.bd71c0eca46e8p-1, 0x1.1d304f8c352c9p-3},
    {0x1.2840000000000p+0, 0x1.ba6fe7cde152cp-1, 0x1.2b0fcf3b1a2f0p-3},
    {0x1.2a40000000000p+0, 0x1.b77861d9cdc98p-1, 0x1.38d7699164309p-3},
    {0x1.2c40000000000p+0, 0x1.b48afa3eaaf37p-1, 0x1.468770542f13fp-3},
    {0x1.2e40000000000p+0, 0x1.b1a77d909f3b8p-1, 0x1.542033a7a85a3p-3},
    {0x1.3040000000000p+0, 0x1.aecdb9bdf2f54p-1, 0x1.61a2021a0eeedp-3},
    {0x1.3240000000000p+0, 0x1.abfd7e03c2fa6p-1, 0x1.6f0d28ae56b4cp-3},
    {0x1.3440000000000p+0, 0x1.a9369ae323eb4p-1, 0x1.7c61f2e6736e3p-3},
    {0x1.3640000000000p+0, 0x1.a678e216b0fe2p-1, 0x1.89a0aacd4e703p-3},
    {0x1.3840000000000p+0, 0x1.a3c4268881898p-1, 0x1.96c999006a6a2p-3},
    {0x1.3a40000000000p+0, 0x1.a1183c4880b68p-1, 0x1.a3dd04b93865fp-3},
    {0x1.3c40000000000p+0, 0x1.9e74f8832302ap-1, 0x1.b0db33d620ff7p-3},
    {0x1.3e40000000000p+0, 0x1.9bda317875714p-1, 0x1.bdc46ae344b13p-3},
    {0x1.4040000000000p+0, 0x1.9947be73827f8p-1, 0x1.ca98ed22f5f4bp-3},
    {0x1.4240000000000p+0, 0x1.96bd77c20922cp-1, 0x1.d758fc95efd4cp-3},
    {0x1.4440000000000p+0, 0x1.943b36ac82451p-1, 0x1.e404da034b73cp-3},
    {0x1.4640000000000p+0, 0x1.91c0d56e7162bp-1, 0x1.f09cc50036ed0p-3},
    {0x1.4840000000000p+0, 0x1.8f4e2f2efd135p-1, 0x1.fd20fbf76fdc7p-3},
    {0x1.4a40000000000p+0, 0x1.8ce31ff9cc738p-1, 0x1.04c8de1841e02p-2},
    {0x1.4c40000000000p+0, 0x1.8a7f84b826867p-1, 0x1.0af7a0eb6c27ap-2},
    {0x1.4e40000000000p+0, 0x1.88233b2a50cd4p-1, 0x1.111ce4003ee4dp-2},
    {0x1.5040000000000p+0, 0x1.85ce21e12a71dp-1, 0x1.1738c45a6698ep-2},
    {0x1.5240000000000p+0, 0x1.8380183801838p-1, 0x1.1d4b5e796a245p-2},
    {0x1.5440000000000p+0, 0x1.8138fe4e9fe1ep-1, 0x1.2354ce5bc88a2p-2},
    {0x1.5640000000000p+0, 0x1.7ef8b5038d8ebp-1, 0x1.29552f81ff523p-2},
    {0x1.5840000000000p+0, 0x1.7cbf1dee863a6p-1, 0x1.2f4c9cf17a5c8p-2},
    {0x1.5a40000000000p+0, 0x1.7a8c1b5b1ffa1p-1, 0x1.353b31376decdp-2},
    {0x1.5c40000000000p+0, 0x1.785f9043a12bfp-1, 0x1.3b21066b9bb10p-2},
    {0x1.5e40000000000p+0, 0x1.7639604c03a79p-1, 0x1.40fe363303797p-2},
    {0x1.6040000000000p+0, 0x1.74196fbd236dfp-1, 0x1.46d2d9c280567p-2},
    {0x1.6240000000000p+0, 0x1.71ffa38017200p-1, 0x1.4c9f09e152c3cp-2},
    {0x1.6440000000000p+0, 0x1.6febe119b0985p-1, 0x1.5262deeb98879p-2},
    {0x1.6640000000000p+0, 0x1.6dde0ea624162p-1, 0x1.581e70d4b2e0dp-2},
    {0x1.6840000000000p+0, 0x1.6bd612d4d4798p-1, 0x1.5dd1d7299b9d4p-2},
};

/* exp: x = (64 k' + j) ln2/64 + r, |r| <= ln2/128 (Cody-Waite, ln2/64 in two parts), exp(x) = 2^k' 2^(j/64) (1 + p(r)),
 * p the degree-5 Taylor polynomial of exp(r) - 1 (truncation error < 4e-17); the table-driven scheme of glibc's
 * exp without FMA. Within 1 ulp of glibc's correctly rounded exp. |x| >= 700, inf, NaN: libm. */
HP_INLINE double hp_exp(double x)
{
    const double InvLn2N = 0x1.71547652b82fep+6 /* 64/ln2 */, Shift = 0x1.8p52,
                 Ln2hiN = 0x1.62e42fefa0000p-7 /* ln2/64 to 36 bits: k Ln2hiN is exact */,
                 Ln2loN = 0x1.cf79abc9e3b3ap-46, C2 = 0.5, C3 = 1.0 / 6.0, C4 = 1.0 / 24.0, C5 = 1.0 / 120.0;
    double z, kd, r, r2, p, scale;
    uint64_t ki, sb;
    if (!(fabs(x) < 700.0))
        return exp(x);
    z = x * InvLn2N;
    kd = z + Shift; /* round to nearest: the low bits of kd's pattern are the integer k = 64 k' + j */
    memcpy(&ki, &kd, sizeof ki);
    kd -= Shift;
    r = x - kd * Ln2hiN - kd * Ln2loN;
    memcpy(&sb, &hp_exp_tab[ki & 63], sizeof sb);
    sb += (ki >> 6) << 52; /* times 2^k' (the exponent field; k' < 0 wraps around as it should) */
    memcpy(&scale, &sb, sizeof scale);
    r2 = r * r;
    p = r + r2 * (C2 + r * C3) + r2 * r2 * (C4 + r * C5);
    return scale + scale * p;
}

/* log: x = 2^k z, z in [0x1.69555p-1, 0x1.69555p+0), log x = k ln2 + log c + log(1 + r), r = (z - c)/c for the
 * table's c nearest z, log(1 + r) by its degree-6 Taylor polynomial (|r| <= 0.0042: truncation error < 4e-18),
 * k ln2 + log c + r summed with compensation; the table-driven scheme of glibc's log without FMA. Within 1 ulp
 * (or 1.1e-16 absolute, near x = 1) of glibc's log. Zero, subnormal, negative, inf, NaN: libm. */
HP_INLINE double hp_log(double x)
{
    const double Ln2hi = 0x1.62e42fefa3800p-1 /* ln2 to 42 bits */, Ln2lo = 0x1.ef35793c76730p-45;
    const uint64_t OFF = 0x3fe6955500000000ULL; /* the bit pattern of 0x1.69555p-1 */
    uint64_t ix, tmp, iz;
    int64_t k;
    int i;
    double z, c, invc, logc, kd, r, r2, w, hi, lo, A, B, P;
    memcpy(&ix, &x, sizeof ix);
    if (ix - 0x0010000000000000ULL >= 0x7fe0000000000000ULL) /* zero, subnormal, negative, inf, NaN */
        return log(x);
    tmp = ix - OFF;
    i = (int)((tmp >> 45) & 127); /* z = x 2^-k, the subinterval of z */
    k = (int64_t)tmp >> 52;
    iz = ix - (tmp & 0xfff0000000000000ULL);
    memcpy(&z, &iz, sizeof z);
    c = hp_log_tab[i][0];
    invc = hp_log_tab[i][1];
    logc = hp_log_tab[i][2];
    kd = (double)k;
    r = (z - c) * invc; /* z - c exact (Sterbenz) */
    w = kd * Ln2hi + logc;
    hi = w + r;
    lo = w - hi + r + kd * Ln2lo;
    r2 = r * r;
    A = -0.5 + r * (1.0 / 3.0);
    B = -0.25 + r * 0.2;
    P = r2 * (A + r2 * (B + r2 * (-1.0 / 6.0)));
    return lo + P + hi;
}

/* a:b of two symmetric tensors (shear counted twice), the built-in's _dot6 */
HP_INLINE double dot6(double a0, double a1, double a2, double a3, double a4, double a5, double b0, double b1,
                      double b2, double b3, double b4, double b5)
{
    return a0 * b0 + a1 * b1 + a2 * b2 + 2.0 * (a3 * b3 + a4 * b4 + a5 * b5);
}

HP_INLINE double dotv(const double *a, const double *b)
{
    return dot6(a[0], a[1], a[2], a[3], a[4], a[5], b[0], b[1], b[2], b[3], b[4], b[5]);
}

HP_INLINE double fmin2(double a, double b) { return b < a ? b : a; }
HP_INLINE double fmax2(double a, double b) { return b > a ? b : a; }

/* low-stress rule (floor_tuple), in place: T <- -p_min I when p < p_min or a principal stress is not
 * compressive; returns LOW_STRESS when it fired. i2/i3 are written exactly as the built-in writes them. */
HP_INLINE int floor_stress(double pmin, double *T)
{
    double t0 = T[0], t1 = T[1], t2 = T[2], t3 = T[3], t4 = T[4], t5 = T[5];
    double p = -(t0 + t1 + t2) * THIRD;
    double b0 = -t0, b1 = -t1, b2 = -t2;
    double i2 = b0 * b1 + b1 * b2 + b0 * b2 - t3 * t3 - t4 * t4 - t5 * t5;
    double i3 = b0 * (b1 * b2 - t5 * t5) - t3 * (t3 * b2 + t5 * t4) - t4 * (t3 * t5 + b1 * t4);
    if (p >= pmin && i2 > 0.0 && i3 > 0.0)
        return 0;
    T[0] = -pmin;
    T[1] = -pmin;
    T[2] = -pmin;
    T[3] = 0.0;
    T[4] = 0.0;
    T[5] = 0.0;
    return FL_LOW_STRESS;
}

/* _stress_direction: T^ = T / tr T (h), T^:T^ and von Wolffersdorff's F (tan psi = sqrt 3 ||T^*||: one square
 * root for both) */
HP_INLINE void stress_direction(const double *T, double *h, double *TT, double *F)
{
    double inv = 1.0 / (T[0] + T[1] + T[2]);
    double h0 = T[0] * inv, h1 = T[1] * inv, h2 = T[2] * inv, h3 = T[3] * inv, h4 = T[4] * inv, h5 = T[5] * inv;
    double s0, s1, s2, ns2, rs, tanpsi, cos3t, t2p;
    h[0] = h0;
    h[1] = h1;
    h[2] = h2;
    h[3] = h3;
    h[4] = h4;
    h[5] = h5;
    *TT = dot6(h0, h1, h2, h3, h4, h5, h0, h1, h2, h3, h4, h5);
    s0 = h0 - THIRD;
    s1 = h1 - THIRD;
    s2 = h2 - THIRD;
    ns2 = dot6(s0, s1, s2, h3, h4, h5, s0, s1, s2, h3, h4, h5);
    rs = sqrt(ns2);
    tanpsi = SQRT3 * rs;
    cos3t = -1.0;
    if (ns2 > 1.0e-24) {
        double dets = s0 * (s1 * s2 - h5 * h5) - h3 * (h3 * s2 - h5 * h4) + h4 * (h3 * h5 - s1 * h4);
        cos3t = -SQRT6 * 3.0 * dets / (ns2 * rs);
        cos3t = fmin2(1.0, fmax2(-1.0, cos3t));
    }
    t2p = tanpsi * tanpsi;
    *F = sqrt(t2p * 0.125 + (2.0 - t2p) / (2.0 + SQRT2 * tanpsi * cos3t)) - tanpsi * INV_2SQRT2;
}

/* rate_scalar: dT = T°(D), ddl = delta°(D) and the P-wave modulus bound M; returns the flags. nl multiplies
 * the nonlinear term (the non-local factor; 1 here). T must be admissible.
 *
 * The built-in's formulas, arranged for speed (the time of an increment is mostly the latency of its chain of
 * dependent exp/log and its count of instructions):
 *  - the chain p -> (3p/h_s)^n -> exp(-x) -> f_d is started first; f_e = (e_c/e)^beta = exp(beta (log(e_c0/e) - x))
 *    and rho^chi come from logs of the inputs, off that chain; f_b f_e / T^:T^ takes one division;
 *  - dT is collected as A D + B T^ + C delta - E I (the built-in's L:D, N, (L:u)(u:D) terms expanded: no
 *    intermediate tensors), ||N|| = |cN| sqrt(4 T^:T^ - 1) (tr T^ = 1).
 * Each differs from the built-in's arithmetic by round-off only: a few ulp of dT, which is small beside T. */
HP_INLINE int rate_scalar(const double *prm, const double *T, double e, const double *dl, const double *D, double nl,
                          double *dT, double *ddl, double *Mout)
{
    int flags = 0, igs = prm[P_IGS] != 0.0;
    double h[6], TT, F;
    double d0 = D[0], d1 = D[1], d2 = D[2], d3 = D[3], d4 = D[4], d5 = D[5];
    double p = -(T[0] + T[1] + T[2]) * THIRD;
    double a, hs, n, r, x, ex, ei, ec, ed, ee, lc, fe, fd, c1, cF, ca, TD, cN, normN, g0, g1, g2, g, lam;
    double q0, q1, q2, q3, q4, q5, nd = 0.0, rho = 0.0, rc, lrho, A, B, C, E;

    /* the pressure chain first */
    hs = prm[P_HS];
    n = prm[P_N];
    r = 3.0 * p / hs;
    x = hp_exp(n * hp_log(r)); /* (3p/h_s)^n */
    lc = hp_log(prm[P_EC0] / e); /* (e > 0; used only when e is not clipped) */
    ex = hp_exp(-x);
    fe = hp_exp(prm[P_BETA] * (lc - x)); /* (e_c/e)^beta, e_c = e_c0 exp(-x) */

    /* rho^chi of the intergranular strain, independent of the stress */
    lrho = 0.0;
    rc = 0.0;
    q0 = dl[0];
    q1 = dl[1];
    q2 = dl[2];
    q3 = dl[3];
    q4 = dl[4];
    q5 = dl[5];
    if (igs) {
        nd = sqrt(dot6(q0, q1, q2, q3, q4, q5, q0, q1, q2, q3, q4, q5));
        rho = fmin2(nd / prm[P_R], 1.0);
        if (nd > 0.0) {
            rc = 1.0;
            if (rho < 1.0) { /* rho = 1 (fully mobilised): no powers needed */
                lrho = hp_log(rho);
                rc = hp_exp(prm[P_CHI] * lrho);
            }
        }
    }

    ei = prm[P_EI0] * ex;
    ec = prm[P_EC0] * ex;
    ed = prm[P_ED0] * ex;
    ee = e;
    if (ee < ed || ee > ei) { /* e clipped into [e_d, e_i]: f_e of the clipped e, as the built-in */
        if (ee < ed) {
            ee = ed;
            flags |= FL_VOID_BELOW_ED;
        } else {
            ee = ei;
            flags |= FL_VOID_ABOVE_EI;
        }
        fe = hp_exp(prm[P_BETA] * hp_log(ec / ee));
    }
    fd = 0.0;
    if (ee > ed) /* ((e - e_d)/(e_c - e_d))^alpha */
        fd = hp_exp(prm[P_ALPHA] * hp_log((ee - ed) / (ec - ed)));

    stress_direction(T, h, &TT, &F);
    a = prm[P_A];
    /* c1 = f_b f_e / T^:T^ with f_b = fbconst (h_s/n) ((1 + e_i)/e_i) (r/x) */
    c1 = prm[P_FB_CONST] * hs * (1.0 + ei) * r / (n * ei * x * TT) * fe;
    cF = c1 * F * F;
    ca = c1 * a * a;
    TD = dot6(h[0], h[1], h[2], h[3], h[4], h[5], d0, d1, d2, d3, d4, d5);
    cN = c1 * a * F * fd;                  /* N = cN (T^ + T^*) = cN (2 T^ - I/3) */
    normN = fabs(cN) * sqrt(4.0 * TT - 1.0); /* ||2 T^ - I/3||^2 = 4 T^:T^ - 4/3 tr T^ + 1/3 */

    /* stiffness bound for the time step (Gershgorin bound g of the largest principal value of T^) */
    g0 = h[0] + fabs(h[3]) + fabs(h[4]);
    g1 = h[1] + fabs(h[3]) + fabs(h[5]);
    g2 = h[2] + fabs(h[4]) + fabs(h[5]);
    g = fmin2(1.0, fmax2(g0, fmax2(g1, g2)));
    lam = cF + ca * g * g;

    if (!igs) { /* L:D + N ||D|| */
        double nD = sqrt(dot6(d0, d1, d2, d3, d4, d5, d0, d1, d2, d3, d4, d5)) * nl;
        A = cF;
        B = ca * TD + 2.0 * cN * nD;
        E = cN * nD * THIRD;
        dT[0] = A * d0 + B * h[0] - E;
        dT[1] = A * d1 + B * h[1] - E;
        dT[2] = A * d2 + B * h[2] - E;
        dT[3] = A * d3 + B * h[3];
        dT[4] = A * d4 + B * h[4];
        dT[5] = A * d5 + B * h[5];
        ddl[0] = 0.0;
        ddl[1] = 0.0;
        ddl[2] = 0.0;
        ddl[3] = 0.0;
        ddl[4] = 0.0;
        ddl[5] = 0.0;
        *Mout = lam + normN;
        return flags;
    }
    {
        /* loading (u:D > 0, u = delta/||delta||): M:D = fac L:D + rho^chi (1 - m_T) (L:u)(u:D) + rho^chi N (u:D),
         * delta° = D - rho^beta_r u (u:D); reversal or neutral: M:D = fac L:D + rho^chi (m_R - m_T) (L:u)(u:D),
         * delta° = D. One formula for both, without a branch (the sign of u:D is a coin toss in an explicit
         * run): s = 1 or 0 multiplies exactly. */
        double mT = prm[P_MT], mR = prm[P_MR], ind = 0.0, dd = 0.0, hu = 0.0, fac, s, rbr = 1.0, c_l, c_n, k;
        if (nd > 0.0) {
            ind = 1.0 / nd;
            dd = dot6(q0, q1, q2, q3, q4, q5, d0, d1, d2, d3, d4, d5) * ind;
            hu = dot6(h[0], h[1], h[2], h[3], h[4], h[5], q0, q1, q2, q3, q4, q5) * ind;
        }
        fac = rc * mT + (1.0 - rc) * mR;
        *Mout = fmax2(mR * lam, lam + normN);
        s = (double)(dd > 0.0);
        if (rho < 1.0)
            rbr = hp_exp(prm[P_BETA_R] * lrho);
        c_l = rc * ((1.0 - mT) * s + (mR - mT) * (1.0 - s)) * dd;
        c_n = rc * dd * nl * s;
        k = rbr * dd * s * ind;
        A = fac * cF;
        B = fac * ca * TD + c_l * ca * hu + 2.0 * c_n * cN;
        C = c_l * cF * ind;
        E = c_n * cN * THIRD;
        dT[0] = A * d0 + B * h[0] + C * q0 - E;
        dT[1] = A * d1 + B * h[1] + C * q1 - E;
        dT[2] = A * d2 + B * h[2] + C * q2 - E;
        dT[3] = A * d3 + B * h[3] + C * q3;
        dT[4] = A * d4 + B * h[4] + C * q4;
        dT[5] = A * d5 + B * h[5] + C * q5;
        ddl[0] = d0 - k * q0;
        ddl[1] = d1 - k * q1;
        ddl[2] = d2 - k * q2;
        ddl[3] = d3 - k * q3;
        ddl[4] = d4 - k * q4;
        ddl[5] = d5 - k * q5;
    }
    return flags;
}

/* _bound_geometry: ||L^-1:N|| / f_d of the stress T (its p in *p) */
HP_NOINLINE double bound_geometry(const double *prm, const double *T, double *p)
{
    double h[6], TT, F, a, y0, y1, y2, y3, y4, y5, c, z0, z1, z2, z3, z4, z5;
    stress_direction(T, h, &TT, &F);
    a = prm[P_A];
    y0 = 2.0 * h[0] - THIRD;
    y1 = 2.0 * h[1] - THIRD;
    y2 = 2.0 * h[2] - THIRD;
    y3 = 2.0 * h[3];
    y4 = 2.0 * h[4];
    y5 = 2.0 * h[5];
    c = a * a * dot6(h[0], h[1], h[2], h[3], h[4], h[5], y0, y1, y2, y3, y4, y5) / (F * F + a * a * TT);
    z0 = y0 - c * h[0];
    z1 = y1 - c * h[1];
    z2 = y2 - c * h[2];
    z3 = y3 - c * h[3];
    z4 = y4 - c * h[4];
    z5 = y5 - c * h[5];
    if (p)
        *p = -(T[0] + T[1] + T[2]) * THIRD;
    return a / F * sqrt(dot6(z0, z1, z2, z3, z4, z5, z0, z1, z2, z3, z4, z5));
}

/* _density_factor: f_d at (e, p) with e clipped into [e_d, e_i] */
static double density_factor(const double *prm, double e, double p)
{
    double ex = hp_exp(-hp_exp(prm[P_N] * hp_log(3.0 * p / prm[P_HS])));
    double ed = prm[P_ED0] * ex;
    double ee = fmin2(fmax2(e, ed), prm[P_EI0] * ex);
    if (ee <= ed)
        return 0.0;
    return hp_exp(prm[P_ALPHA] * hp_log((ee - ed) / (prm[P_EC0] * ex - ed)));
}

/* _project: the deviator of T scaled back onto B = 1 (Illinois regula falsi on the scale s in [0, 1]), in place */
HP_NOINLINE int project(const double *prm, double *T, double e)
{
    double p, g1, fd, target, m, d0, d1, d2, t3, t4, t5, lo, flo, hi, fhi, s, Ti[6];
    int side = 0;
    g1 = bound_geometry(prm, T, &p);
    if (g1 * prm[P_FD_MAX] <= 1.0)
        return 0;
    fd = density_factor(prm, e, p);
    if (g1 * fd <= 1.0)
        return 0;
    target = 1.0 / fd;
    m = (T[0] + T[1] + T[2]) * THIRD;
    d0 = T[0] - m;
    d1 = T[1] - m;
    d2 = T[2] - m;
    t3 = T[3];
    t4 = T[4];
    t5 = T[5];
    Ti[0] = m;
    Ti[1] = m;
    Ti[2] = m;
    Ti[3] = 0.0;
    Ti[4] = 0.0;
    Ti[5] = 0.0;
    lo = 0.0;
    flo = bound_geometry(prm, Ti, NULL) - target;
    hi = 1.0;
    fhi = g1 - target;
    s = lo;
    for (int it = 0; it < 60; it++) {
        double f;
        s = (lo * fhi - hi * flo) / (fhi - flo);
        Ti[0] = m + s * d0;
        Ti[1] = m + s * d1;
        Ti[2] = m + s * d2;
        Ti[3] = s * t3;
        Ti[4] = s * t4;
        Ti[5] = s * t5;
        f = bound_geometry(prm, Ti, NULL) - target;
        if (fabs(f) <= 1.0e-13 * target || hi - lo <= 1.0e-15)
            break;
        if (f > 0.0) {
            hi = s;
            fhi = f;
            if (side == 1)
                flo *= 0.5;
            side = 1;
        } else {
            lo = s;
            flo = f;
            if (side == -1)
                fhi *= 0.5;
            side = -1;
        }
    }
    T[0] = m + s * d0;
    T[1] = m + s * d1;
    T[2] = m + s * d2;
    T[3] = s * t3;
    T[4] = s * t4;
    T[5] = s * t5;
    return FL_BOUNDED;
}

/* bound_tuple, in place: the quick exit on the obliquity, else project */
HP_INLINE int bound_stress(const double *prm, double *T, double e)
{
    double m = (T[0] + T[1] + T[2]) * THIRD;
    double d0 = T[0] - m, d1 = T[1] - m, d2 = T[2] - m;
    if (m >= 0.0 ||
        dot6(d0, d1, d2, T[3], T[4], T[5], d0, d1, d2, T[3], T[4], T[5]) <= prm[P_BOUND_NS2] * 9.0 * m * m)
        return 0;
    return project(prm, T, e);
}

/* clip_intergranular: delta scaled back to ||delta|| = R */
HP_INLINE int clip_intergranular(const double *prm, double *delta)
{
    double nd = sqrt(dotv(delta, delta));
    double R = prm[P_R];
    if (nd > R) {
        double s = R / nd;
        for (int i = 0; i < 6; i++)
            delta[i] *= s;
        return FL_RHO_CLIPPED;
    }
    return 0;
}

/* volume_ratio: exp(x), a 5-term series below 1e-4 */
HP_INLINE double volume_ratio(double x)
{
    if (fabs(x) < 1.0e-4)
        return 1.0 + x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0))));
    return hp_exp(x);
}

/* euler_tuple: nsub equal forward-Euler substeps, T, *e, q in place; returns the flags, M in *Mout */
HP_INLINE int euler_substeps(const double *prm, double *T, double *e, double *q, const double *deps, int nsub,
                             double nl, double *Mout)
{
    double pmin = prm[P_PMIN];
    int flags = floor_stress(pmin, T);
    double D[6], dT[6], dq[6], ev = *e, M = 0.0, vol, R = prm[P_R];
    int igs = prm[P_IGS] != 0.0;
    int bound = prm[P_BOUND] != 0.0;
    int f;
    if (nsub == 1) { /* (the usual explicit step: deps * (1/1) is deps) */
        D[0] = deps[0];
        D[1] = deps[1];
        D[2] = deps[2];
        D[3] = deps[3];
        D[4] = deps[4];
        D[5] = deps[5];
    } else {
        double inv = 1.0 / nsub;
        D[0] = deps[0] * inv;
        D[1] = deps[1] * inv;
        D[2] = deps[2] * inv;
        D[3] = deps[3] * inv;
        D[4] = deps[4] * inv;
        D[5] = deps[5] * inv;
    }
    vol = volume_ratio(D[0] + D[1] + D[2]);
    for (int k = 0; k < nsub; k++) {
        if (k > 0)
            flags |= floor_stress(pmin, T);
        flags |= rate_scalar(prm, T, ev, q, D, nl, dT, dq, &M);
        T[0] = T[0] + dT[0];
        T[1] = T[1] + dT[1];
        T[2] = T[2] + dT[2];
        T[3] = T[3] + dT[3];
        T[4] = T[4] + dT[4];
        T[5] = T[5] + dT[5];
        ev = (1.0 + ev) * vol - 1.0;
        if (igs) {
            double q0 = q[0] + dq[0], q1 = q[1] + dq[1], q2 = q[2] + dq[2];
            double q3 = q[3] + dq[3], q4 = q[4] + dq[4], q5 = q[5] + dq[5];
            double nq = sqrt(dot6(q0, q1, q2, q3, q4, q5, q0, q1, q2, q3, q4, q5));
            if (nq > R) { /* (rare: no multiplication by 1 otherwise) */
                double s = R / nq;
                q0 *= s;
                q1 *= s;
                q2 *= s;
                q3 *= s;
                q4 *= s;
                q5 *= s;
                flags |= FL_RHO_CLIPPED;
            }
            q[0] = q0;
            q[1] = q1;
            q[2] = q2;
            q[3] = q3;
            q[4] = q4;
            q[5] = q5;
        }
    }
    f = floor_stress(pmin, T);
    flags |= f;
    if (bound && f == 0) /* once per increment, as the built-in */
        flags |= bound_stress(prm, T, ev);
    *e = ev;
    *Mout = M;
    return flags;
}

/* _adaptive: Heun-Euler pair with local error control over pseudo-time [0, 1]; T, *e, delta in place */
HP_NOINLINE int adaptive(const double *prm, double *T, double *e, double *delta, const double *deps, double tol,
                         double *Mout)
{
    int flags = 0, count = 0;
    int igs = prm[P_IGS] != 0.0;
    double R = prm[P_R], pmin = prm[P_PMIN];
    double D[6], k1[6], q1[6], k2[6], q2[6], T1[6], d1[6];
    double tk = 0.0, h = 1.0, M = 0.0, M2;
    while (tk < 1.0) {
        double vol, e1, err_t = 0.0, err_d = 0.0, scale, err;
        int f0, f1, f, floor_ok;
        h = fmin2(h, 1.0 - tk);
        for (int i = 0; i < 6; i++)
            D[i] = deps[i] * h;
        vol = hp_exp(D[0] + D[1] + D[2]);
        f0 = floor_stress(pmin, T);
        flags |= f0;
        f = rate_scalar(prm, T, *e, delta, D, 1.0, k1, q1, &M);
        flags |= f;
        for (int i = 0; i < 6; i++) {
            T1[i] = T[i] + k1[i];
            d1[i] = delta[i] + q1[i];
        }
        e1 = (1.0 + *e) * vol - 1.0;
        f1 = floor_stress(pmin, T1);
        if (igs)
            clip_intergranular(prm, d1);
        f = rate_scalar(prm, T1, e1, d1, D, 1.0, k2, q2, &M2);
        for (int i = 0; i < 6; i++) {
            double w0 = k2[i] - k1[i];
            double w1 = q2[i] - q1[i];
            double m = i < 3 ? 1.0 : 2.0;
            err_t += m * w0 * w0;
            err_d += m * w1 * w1;
        }
        scale = fmax2(sqrt(dotv(T, T)), pmin);
        err = 0.5 * sqrt(err_t) / scale;
        if (igs)
            err = fmax2(err, 0.5 * sqrt(err_d) / R);
        count += 1;
        /* a predictor pushed through the floor means the step is too large, unless the stress already sits
         * at the floor or the step is already tiny */
        floor_ok = f1 == 0 || f0 != 0 || h <= FLOOR_SUBSTEP;
        if (!floor_ok)
            err = fmax2(err, 100.0 * tol);
        if ((err <= tol && floor_ok) || h <= MIN_SUBSTEP || count >= MAX_SUBSTEPS || (f1 != 0 && floor_ok)) {
            if (err > tol)
                flags |= FL_SUBSTEP_LIMIT;
            flags |= f;
            for (int i = 0; i < 6; i++) {
                T[i] += 0.5 * (k1[i] + k2[i]);
                delta[i] += 0.5 * (q1[i] + q2[i]);
            }
            *e = e1;
            if (igs)
                flags |= clip_intergranular(prm, delta);
            if (prm[P_BOUND] != 0.0)
                flags |= bound_stress(prm, T, e1);
            tk += h;
        }
        if (err == 0.0)
            h *= 2.0;
        else
            h *= fmin2(2.0, fmax2(0.2, 0.9 * sqrt(tol / err)));
        h = fmax2(h, MIN_SUBSTEP);
    }
    flags |= floor_stress(pmin, T);
    *Mout = M;
    return flags;
}

/* the zero increment: only the floor, and the modulus of the current state (stiffness) */
HP_NOINLINE int zero_increment(const double *prm, double *T, double e, const double *q, double *M)
{
    double D[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0}, dT[6], dq[6];
    int flags = FL_ZERO_INCREMENT | floor_stress(prm[P_PMIN], T);
    rate_scalar(prm, T, e, q, D, 1.0, dT, dq, M);
    return flags;
}

/* lagrange.substeps: equal Euler substeps so that none exceeds the strain max_sub (tensor-shear norm) */
HP_INLINE int substeps(const double *D, double max_sub)
{
    double n2, n;
    if (!(max_sub > 0.0) || isinf(max_sub))
        return 1;
    n2 = D[0] * D[0] + D[1] * D[1] + D[2] * D[2] + 2.0 * (D[3] * D[3] + D[4] * D[4] + D[5] * D[5]);
    n = ceil(sqrt(n2) / max_sub);
    if (!(n > 1.0)) /* n <= 1 (or NaN: the stress is NaN anyway) */
        return 1;
    return n < (double)MAX_CELL_SUBSTEPS ? (int)n : MAX_CELL_SUBSTEPS;
}

/* the rare paths out of line, on copies: T, e, q, deps and M stay in registers on the Euler path (an array whose
 * address reaches a function that is not inlined lives in memory throughout) */
HP_NOINLINE int rare_update(const double *prm, double *Tio, double *eio, double *qio, const double *dio, double tol,
                            double *Mio)
{
    double T[6], q[6], deps[6], e = *eio, M;
    int flags;
    for (int i = 0; i < 6; i++) {
        T[i] = Tio[i];
        q[i] = qio[i];
        deps[i] = dio[i];
    }
    if (tol > 0.0)
        flags = adaptive(prm, T, &e, q, deps, tol, &M);
    else
        flags = zero_increment(prm, T, e, q, &M);
    for (int i = 0; i < 6; i++) {
        Tio[i] = T[i];
        qio[i] = q[i];
    }
    *eio = e;
    *Mio = M;
    return flags;
}

/* hypoplastic_update after the co-rotation: T (6), *e, q (6, intergranular strain) in the built-in's order
 * 11, 22, 33, 12, 13, 23, tensor shear; deps tensor shear. Returns the flags, the modulus bound in *M. */
HP_INLINE int hypo_update(const double *props, double *T, double *e, double *q, const double *deps, double *M)
{
    const double *prm = props;
    double tol = props[N_PARAMS];
    double max_sub = props[N_PARAMS + 1];
    int zero = deps[0] == 0.0 && deps[1] == 0.0 && deps[2] == 0.0 && deps[3] == 0.0 && deps[4] == 0.0 && deps[5] == 0.0;
    if (zero || tol > 0.0) { /* the zero increment: the floor and the modulus of the current state; or adaptive */
        double Tc[6], qc[6], dc[6], ec = *e, Mc;
        int flags;
        for (int i = 0; i < 6; i++) {
            Tc[i] = T[i];
            qc[i] = q[i];
            dc[i] = deps[i];
        }
        flags = rare_update(prm, Tc, &ec, qc, dc, zero ? 0.0 : tol, &Mc);
        for (int i = 0; i < 6; i++) {
            T[i] = Tc[i];
            q[i] = qc[i];
        }
        *e = ec;
        *M = Mc;
        return flags;
    }
    return euler_substeps(prm, T, e, q, deps, substeps(deps, max_sub), 1.0, M);
}

/* x <- Q x Q^T for a symmetric tensor x (built-in order 11,22,33,12,13,23), Q column-major (DROT), written as
 * the built-in's co_rotate_tuple */
HP_INLINE void rotate_tensor(const double *Q, double *a)
{
#define QQ(i, j) Q[(i) + 3 * (j)]
    double q00 = QQ(0, 0), q01 = QQ(0, 1), q02 = QQ(0, 2);
    double q10 = QQ(1, 0), q11 = QQ(1, 1), q12 = QQ(1, 2);
    double q20 = QQ(2, 0), q21 = QQ(2, 1), q22 = QQ(2, 2);
#undef QQ
    double m00 = a[0], m11 = a[1], m22 = a[2], m01 = a[3], m02 = a[4], m12 = a[5];
    double r00 = q00 * m00 + q01 * m01 + q02 * m02;
    double r01 = q00 * m01 + q01 * m11 + q02 * m12;
    double r02 = q00 * m02 + q01 * m12 + q02 * m22;
    double r10 = q10 * m00 + q11 * m01 + q12 * m02;
    double r11 = q10 * m01 + q11 * m11 + q12 * m12;
    double r12 = q10 * m02 + q11 * m12 + q12 * m22;
    double r20 = q20 * m00 + q21 * m01 + q22 * m02;
    double r21 = q20 * m01 + q21 * m11 + q22 * m12;
    double r22 = q20 * m02 + q21 * m12 + q22 * m22;
    a[0] = r00 * q00 + r01 * q01 + r02 * q02;
    a[1] = r10 * q10 + r11 * q11 + r12 * q12;
    a[2] = r20 * q20 + r21 * q21 + r22 * q22;
    a[3] = r00 * q10 + r01 * q11 + r02 * q12;
    a[4] = r00 * q20 + r01 * q21 + r02 * q22;
    a[5] = r10 * q20 + r11 * q21 + r12 * q22;
}

/* Q == I exactly (no spin: the rotation is skipped); the off-diagonal entries first, one of which is nonzero
 * whenever there is a spin */
HP_INLINE int is_identity(const double *Q)
{
    if (Q[3] != 0.0 || Q[6] != 0.0 || Q[7] != 0.0 || Q[1] != 0.0 || Q[2] != 0.0 || Q[5] != 0.0)
        return 0;
    return Q[0] == 1.0 && Q[4] == 1.0 && Q[8] == 1.0;
}

void umat_(double *STRESS, double *STATEV, double *DDSDDE, double *SSE, double *SPD, double *SCD, double *RPL,
           double *DDSDDT, double *DRPLDE, double *DRPLDT, double *STRAN, double *DSTRAN, double *TIME, double *DTIME,
           double *TEMP, double *DTEMP, double *PREDEF, double *DPRED, char *CMNAME, int *NDI, int *NSHR, int *NTENS,
           int *NSTATV, double *PROPS, int *NPROPS, double *COORDS, double *DROT, double *PNEWDT, double *CELENT,
           double *DFGRD0, double *DFGRD1, int *NOEL, int *NPT, int *LAYER, int *KSPT, int *KSTEP, int *KINC,
           size_t cmname_len)
{
    double T[6], q[6], deps[6], e, M, lam;
    double *C = DDSDDE;
    (void)SSE, (void)SPD, (void)SCD, (void)RPL, (void)DDSDDT, (void)DRPLDE, (void)DRPLDT, (void)STRAN, (void)TIME;
    (void)DTIME, (void)TEMP, (void)DTEMP, (void)PREDEF, (void)DPRED, (void)CMNAME, (void)NDI, (void)NSHR;
    (void)NTENS, (void)COORDS, (void)CELENT, (void)DFGRD0, (void)DFGRD1, (void)NOEL, (void)NPT, (void)LAYER;
    (void)KSPT, (void)KSTEP, (void)KINC, (void)cmname_len;

    if (*NPROPS != HP_NPROPS || *NSTATV < HP_NSTATE) {
        *PNEWDT = 0.0; /* geocel reports PNEWDT < 1 as an error */
        return;
    }
    T[0] = STRESS[0]; /* already co-rotated by geocel */
    T[1] = STRESS[1];
    T[2] = STRESS[2];
    T[3] = STRESS[3];
    T[4] = STRESS[4];
    T[5] = STRESS[5];
    e = STATEV[0];
    q[0] = STATEV[1];
    q[1] = STATEV[2];
    q[2] = STATEV[3];
    q[3] = STATEV[4];
    q[4] = STATEV[5];
    q[5] = STATEV[6];
    if (PROPS[P_IGS] != 0.0 && !is_identity(DROT))
        rotate_tensor(DROT, q); /* the built-in co-rotates delta with the stress */
    deps[0] = DSTRAN[0];
    deps[1] = DSTRAN[1];
    deps[2] = DSTRAN[2];
    deps[3] = 0.5 * DSTRAN[3]; /* engineering -> tensor shear */
    deps[4] = 0.5 * DSTRAN[4];
    deps[5] = 0.5 * DSTRAN[5];

    hypo_update(PROPS, T, &e, q, deps, &M);

    STRESS[0] = T[0];
    STRESS[1] = T[1];
    STRESS[2] = T[2];
    STRESS[3] = T[3];
    STRESS[4] = T[4];
    STRESS[5] = T[5];
    STATEV[0] = e;
    STATEV[1] = q[0];
    STATEV[2] = q[1];
    STATEV[3] = q[2];
    STATEV[4] = q[3];
    STATEV[5] = q[4];
    STATEV[6] = q[5];

    /* DDSDDE: NOT the hypoplastic tangent. geocel uses DDSDDE only for the stable time step (the largest P-wave
     * modulus e(n)^T DDSDDE e(n) over 13 directions n), and this test plug-in exists to hand geocel the
     * built-in's modulus bound M: an isotropic matrix with lambda = mu = M/3, whose P-wave modulus
     * lambda + 2 mu is M along every direction (the diagonal is set to M itself, exact along the axes).
     * Column-major, written entry by entry (a loop of 36 becomes a slow 'rep stos'). */
    lam = M / 3.0;
    C[0] = M, C[1] = lam, C[2] = lam, C[3] = 0.0, C[4] = 0.0, C[5] = 0.0;
    C[6] = lam, C[7] = M, C[8] = lam, C[9] = 0.0, C[10] = 0.0, C[11] = 0.0;
    C[12] = lam, C[13] = lam, C[14] = M, C[15] = 0.0, C[16] = 0.0, C[17] = 0.0;
    C[18] = 0.0, C[19] = 0.0, C[20] = 0.0, C[21] = lam, C[22] = 0.0, C[23] = 0.0; /* mu, engineering shear */
    C[24] = 0.0, C[25] = 0.0, C[26] = 0.0, C[27] = 0.0, C[28] = lam, C[29] = 0.0;
    C[30] = 0.0, C[31] = 0.0, C[32] = 0.0, C[33] = 0.0, C[34] = 0.0, C[35] = lam;
}

/* component k (0-based) of point b (0-based) of a (nblock, k) column-major VUMAT array */
static inline size_t at(int b, int nblock, int k) { return (size_t)b + (size_t)nblock * (size_t)k; }

void vumat_(int *nblock, int *ndir, int *nshr, int *nstatev, int *nfieldv, int *nprops, int *lanneal,
            double *stepTime, double *totalTime, double *dt, char *cmname, double *coordMp, double *charLength,
            double *props, double *density, double *strainInc, double *relSpinInc, double *tempOld,
            double *stretchOld, double *defgradOld, double *fieldOld, double *stressOld, double *stateOld,
            double *enerInternOld, double *enerInelasOld, double *tempNew, double *stretchNew, double *defgradNew,
            double *fieldNew, double *stressNew, double *stateNew, double *enerInternNew, double *enerInelasNew,
            size_t cmname_len)
{
    /* VUMAT order 11, 22, 33, 12, 23, 31 <-> the built-in's 11, 22, 33, 12, 13, 23 */
    static const int vu[6] = {0, 1, 2, 3, 5, 4}; /* built-in component i is VUMAT component vu[i] */
    int nb = *nblock, ns = *nstatev;
    (void)ndir, (void)nshr, (void)nfieldv, (void)lanneal, (void)stepTime, (void)totalTime, (void)dt, (void)cmname;
    (void)coordMp, (void)charLength, (void)density, (void)relSpinInc, (void)tempOld, (void)stretchOld;
    (void)defgradOld, (void)fieldOld, (void)enerInternOld, (void)enerInelasOld, (void)tempNew, (void)stretchNew;
    (void)defgradNew, (void)fieldNew, (void)enerInternNew, (void)enerInelasNew, (void)cmname_len;

    if (*nprops != HP_NPROPS || ns < HP_NSTATE) {
        for (int b = 0; b < nb; b++) {
            for (int k = 0; k < 6; k++)
                stressNew[at(b, nb, k)] = NAN; /* geocel reports the NaN stress */
            for (int k = 0; k < ns; k++)
                stateNew[at(b, nb, k)] = NAN;
        }
        return;
    }
    for (int b = 0; b < nb; b++) {
        double T[6], q[6], deps[6], e, M;
        for (int i = 0; i < 6; i++) {
            T[i] = stressOld[at(b, nb, vu[i])];        /* co-rotated by geocel */
            deps[i] = strainInc[at(b, nb, vu[i])];     /* tensor shear */
            q[i] = stateOld[at(b, nb, 1 + vu[i])];     /* co-rotated by geocel (a tensor group by its names) */
        }
        e = stateOld[at(b, nb, 0)];
        hypo_update(props, T, &e, q, deps, &M); /* M: geocel estimates it, or reads it from STATEV(8) */
        for (int i = 0; i < 6; i++) {
            stressNew[at(b, nb, vu[i])] = T[i];
            stateNew[at(b, nb, 1 + vu[i])] = q[i];
        }
        stateNew[at(b, nb, 0)] = e;
        if (ns > HP_NSTATE) /* STATEV(8), if there: M, for geocel's wave_modulus_state */
            stateNew[at(b, nb, HP_NSTATE)] = M;
        for (int k = HP_NSTATE + 1; k < ns; k++) /* any further state variables: unchanged */
            stateNew[at(b, nb, k)] = stateOld[at(b, nb, k)];
    }
}
