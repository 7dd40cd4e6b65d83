/* geocel's stand-ins for the Abaqus utility routines user subroutines call most (written for geocel).
 *
 * XIT and STDB_ABQERR with LOP = -3 (abort) cannot end the process here: they count the request, keep the
 * message, and return; geocel stops the run after the step (geocel_abort_count, geocel_abort_message).
 * ROTSIG rotates a stress (LSTR = 1, tensor shear) or strain (LSTR = 2, engineering shear) 6-vector.
 */
#include <stddef.h>
#include <string.h>

static volatile int abort_count = 0;
static char abort_message[256];

int geocel_abort_count(void) { return abort_count; }
const char *geocel_abort_message(void) { return abort_message; }
void geocel_abort_reset(void) { abort_count = 0; abort_message[0] = '\0'; }

static void record(const char *text, size_t len) {
    size_t n = len < sizeof(abort_message) - 1 ? len : sizeof(abort_message) - 1;
    if (text != NULL) {
        memcpy(abort_message, text, n);
        abort_message[n] = '\0';
    }
    __sync_fetch_and_add(&abort_count, 1);
}

void xit_(void) { record("XIT called", 10); }
void XIT(void) { xit_(); }

void stdb_abqerr_(const int *lop, const char *string, const int *intv, const double *realv,
                  const char *charv, size_t string_len, size_t charv_len) {
    (void)intv; (void)realv; (void)charv; (void)charv_len;
    if (*lop == -3) record(string, string_len);
}

void rotsig_(const double *s, const double *r, double *sprime, const int *lstr, const int *ndi,
             const int *nshr) {
    /* 3D layout only (ndi = nshr = 3): S' = R S Rᵀ, R column-major */
    double a[3][3], b[3][3];
    double f = (*lstr == 2) ? 0.5 : 1.0;
    (void)ndi; (void)nshr;
    a[0][0] = s[0]; a[1][1] = s[1]; a[2][2] = s[2];
    a[0][1] = a[1][0] = f * s[3];
    a[0][2] = a[2][0] = f * s[4];
    a[1][2] = a[2][1] = f * s[5];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double acc = 0.0;
            for (int k = 0; k < 3; k++)
                for (int l = 0; l < 3; l++) acc += r[i + 3 * k] * a[k][l] * r[j + 3 * l];
            b[i][j] = acc;
        }
    sprime[0] = b[0][0]; sprime[1] = b[1][1]; sprime[2] = b[2][2];
    sprime[3] = b[0][1] / f; sprime[4] = b[0][2] / f; sprime[5] = b[1][2] / f;
}
