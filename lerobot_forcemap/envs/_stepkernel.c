/* The force processing of one control step (lerobot_forcemap/envs/forces.py), in C.
 *
 * Each function does the arithmetic of the NumPy path in forces.py in the same order, so the results
 * are the same floats (the module's tests compare the two bit for bit). The NumPy path keeps the two
 * operations whose rounding depends on the machine's NumPy build (a matrix product and an einsum that
 * may use fused multiply-adds): the Python side calls them between these functions.
 * Compiled with -ffp-contract=off: no fused multiply-add here.
 *
 * Arrays are C-contiguous float64 (int64 for column indices); buf is (n, ns): one row of sensordata
 * per physics step.
 */
#include <math.h>
#include <stdint.h>

int64_t fs_abi_version(void) { return 1; }

/* Everything the functions read and write besides the row count: set once per env (pointers, columns)
 * and per episode (payload, tare, limits); the Python side keeps the arrays alive (forces.py, _Plan). */
typedef struct {
    const double *buf;   /* (rows, ns) sensordata rows, one per physics step */
    int64_t ns;          /* sensordata width */
    const int64_t *qcols, *wcols; /* the F/T site quaternion (4) and the raw wrench (6) */
    int64_t npairs;      /* contact sensors */
    const int64_t *ccols, *gate; /* 3 columns per contact sensor; its held-body column, or -1 */
    int64_t nf;          /* fingertips */
    const int64_t *fcols; /* 3 columns per fingertip */
    const double *bias, *limits, *state; /* tare (6); limits (1 + nf); the filter's last output (dim) */
    double *rot, *fsite, *tsite, *tool, *rotated, *out, *norms; /* work and result arrays */
    double mg, fsign, alpha, a1, omalpha; /* payload weight; fingertip sign; filter coefficients */
    double *max_norm, *sum_norm, *max_abs, *sum_abs; /* the episode's ForceStats: (m,), (m,), (m, 3), (m, 3) */
} fs_plan;

/* Entry k of a row-major rotation matrix is 2 (p + s q) (the diagonal: 1 minus that), with p, q the
 * products of quaternion components P[k], P[9 + k] (index 4 i + j for q_i q_j, w x y z), s = S[k]. */
static const int P[18] = {10, 6, 7, 6, 5, 11, 7, 11, 5, 15, 3, 2, 3, 15, 1, 2, 1, 10};
static const double S[9] = {1.0, -1.0, 1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0};

/* Rotation matrices rot (n, 9) of the quaternions in columns qcols of the first n rows (normalised
 * first), and the payload's force in the sensor frame fsite (n, 3) = mg * (third row of rot). */
void fs_rotations(const fs_plan *pl, int64_t n)
{
    const int64_t *qcols = pl->qcols;
    for (int64_t r = 0; r < n; r++) {
        const double *row = pl->buf + r * pl->ns;
        double q[4], p[16];
        double s = 0.0;
        for (int i = 0; i < 4; i++) {
            q[i] = row[qcols[i]];
        }
        s = q[0] * q[0] + q[1] * q[1];
        s = s + q[2] * q[2];
        s = s + q[3] * q[3];
        s = sqrt(s);
        for (int i = 0; i < 4; i++) {
            q[i] = q[i] / s;
        }
        for (int i = 0; i < 4; i++) {
            for (int j = 0; j < 4; j++) {
                p[4 * i + j] = q[i] * q[j];
            }
        }
        double *m = pl->rot + 9 * r;
        for (int k = 0; k < 9; k++) {
            m[k] = (p[P[9 + k]] * S[k] + p[P[k]]) * 2.0;
        }
        m[0] = 1.0 - m[0];
        m[4] = 1.0 - m[4];
        m[8] = 1.0 - m[8];
        for (int i = 0; i < 3; i++) {
            pl->fsite[3 * r + i] = pl->mg * m[6 + i];
        }
    }
}

/* What the tool applies, sensor frame: tool (n, 6) = raw wrench (columns wcols) - [fsite, tsite] - bias,
 * tsite (n, 3) the payload's torque (c x fsite, computed by NumPy between the two calls). */
void fs_tool(const fs_plan *pl, int64_t n)
{
    const int64_t *wcols = pl->wcols;
    const double *bias = pl->bias;
    for (int64_t r = 0; r < n; r++) {
        const double *row = pl->buf + r * pl->ns;
        double *t = pl->tool + 6 * r;
        for (int i = 0; i < 3; i++) {
            t[i] = (row[wcols[i]] - pl->fsite[3 * r + i]) - bias[i];
            t[3 + i] = (row[wcols[3 + i]] - pl->tsite[3 * r + i]) - bias[3 + i];
        }
    }
}

/* The rest of the first n rows, into out (n, dim), dim = 9 + 3 nf, and norms (n, 1 + nf):
 *  - columns 0..5: the reaction wrench, minus rotated (n, 6) (the tool's wrench in the base frame);
 *  - 6..8: the summed contact force of npairs sensors (columns ccols, 3 each); a pair with gate[k] >= 0
 *    counts only where that column is > 0 (a held body touching the robot);
 *  - 9..: the fingertip forces (columns fcols) times fsign;
 *  - all filtered along the rows from the filter's last output state: y = z + alpha x, z = 0 x - a1 y,
 *    z starting at omalpha * state (scipy's lfilter of b = [alpha], a = [1, a1]); dim <= 64;
 *  - norms of the filtered contact force and of each fingertip force.
 * Returns the first row where a norm exceeds its limit (limits, 1 + nf), or -1. */
int64_t fs_block(const fs_plan *pl, int64_t n)
{
    const int64_t nf = pl->nf, npairs = pl->npairs, dim = 9 + 3 * nf, nn = 1 + nf;
    const int64_t *ccols = pl->ccols, *gate = pl->gate, *fcols = pl->fcols;
    const double *rotated = pl->rotated, alpha = pl->alpha, a1 = pl->a1;
    int64_t stop = -1;
    double z[64]; /* the filter's delay, per column */
    for (int64_t j = 0; j < dim; j++) {
        z[j] = pl->omalpha * pl->state[j];
    }
    for (int64_t r = 0; r < n; r++) {
        const double *row = pl->buf + r * pl->ns;
        double x[64];
        double *y = pl->out + dim * r;
        for (int i = 0; i < 6; i++) {
            x[i] = -rotated[6 * r + i];
        }
        for (int64_t k = 0; k < npairs; k++) {
            double g = gate[k] >= 0 ? (row[gate[k]] > 0 ? 1.0 : 0.0) : 1.0;
            for (int i = 0; i < 3; i++) {
                double v = gate[k] >= 0 ? row[ccols[3 * k + i]] * g : row[ccols[3 * k + i]];
                x[6 + i] = k == 0 ? v : x[6 + i] + v;
            }
        }
        for (int64_t i = 0; i < 3 * nf; i++) {
            x[9 + i] = row[fcols[i]] * pl->fsign;
        }
        for (int64_t j = 0; j < dim; j++) {
            y[j] = z[j] + alpha * x[j];
            z[j] = x[j] * 0.0 - y[j] * a1;
        }
        int over = 0;
        for (int64_t k = 0; k < nn; k++) {
            const double *f = y + 6 + 3 * k;
            double s = f[0] * f[0] + f[1] * f[1];
            s = sqrt(s + f[2] * f[2]);
            pl->norms[nn * r + k] = s;
            over |= s > pl->limits[k];
        }
        if (over && stop < 0) {
            stop = r;
        }
    }
    return stop;
}

/* NumPy's pairwise sum of n doubles with a stride (its add.reduce of a contiguous row): 8 partial sums
 * for blocks of up to 128, halves above. */
static double pairwise_sum(const double *a, int64_t n, int64_t stride)
{
    if (n < 8) {
        double res = 0.0;
        for (int64_t i = 0; i < n; i++) {
            res += a[i * stride];
        }
        return res;
    }
    if (n <= 128) {
        double r[8];
        int64_t i;
        for (int j = 0; j < 8; j++) {
            r[j] = a[j * stride];
        }
        for (i = 8; i < n - (n % 8); i += 8) {
            for (int j = 0; j < 8; j++) {
                r[j] += a[(i + j) * stride];
            }
        }
        double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++) {
            res += a[i * stride];
        }
        return res;
    }
    int64_t n2 = n / 2;
    n2 -= n2 % 8;
    return pairwise_sum(a, n2, stride) + pairwise_sum(a + n2 * stride, n - n2, stride);
}

/* NaN-propagating maximum (np.maximum, ndarray.max). */
static double nan_max(double a, double b) { return (a != a || a > b) ? a : (b != b ? b : (a >= b ? a : b)); }

/* ForceStats.update of the first n rows of out (columns 6..: m = 1 + nf signals of 3) and norms:
 * maxima, the norms' sums (pairwise, per signal) and the absolute components' sums (row by row). */
void fs_stats(const fs_plan *pl, int64_t n)
{
    const int64_t m = 1 + pl->nf, dim = 9 + 3 * pl->nf;
    for (int64_t k = 0; k < m; k++) {
        double top = pl->norms[k];
        for (int64_t r = 1; r < n; r++) {
            top = nan_max(top, pl->norms[m * r + k]);
        }
        pl->max_norm[k] = nan_max(pl->max_norm[k], top);
        pl->sum_norm[k] = pl->sum_norm[k] + pairwise_sum(pl->norms + k, n, m);
        for (int i = 0; i < 3; i++) {
            const double *f = pl->out + 6 + 3 * k + i;
            double big = fabs(f[0]), sum = fabs(f[0]);
            for (int64_t r = 1; r < n; r++) {
                big = nan_max(big, fabs(f[dim * r]));
                sum = sum + fabs(f[dim * r]);
            }
            pl->max_abs[3 * k + i] = nan_max(pl->max_abs[3 * k + i], big);
            pl->sum_abs[3 * k + i] = pl->sum_abs[3 * k + i] + sum;
        }
    }
}
