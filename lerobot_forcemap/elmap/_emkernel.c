/* Per-sample work of one elastic-map EM iteration, for lerobot_forcemap.elmap (loaded with ctypes).

   The NumPy path (estep.py, NumpyEMSteps) is the reference; this file does the same arithmetic in
   the same order (sequential sums over samples, distances summed axis by axis, no FMA contraction)
   so that both paths give the same numbers, and only removes the per-call overhead of NumPy on
   arrays of a few thousand elements. Three entry points, all on C-contiguous float64 / int64 arrays:

   fm_assign        exact nearest node of every sample (E-step): the bounds of NearestNodeAssigner
                    (a window of nodes along the map, Hamerly-style bounds loosened by the moves),
                    then Elkan's node-to-node pruning; ties go to the lowest node index, as argmin.
   fm_cluster_sums  W_i = sum of sample weights in cluster i, b_i = sum of weight * sample (M-step data).
   fm_force_sums    relaxed spring lengths of the force points and their raw per-node sums
                    [sum |f| / (k Delta), sum |f| p / (k Delta)] (the rho_max cap is applied in Python).

   It is also a (trivial) Python extension module so that setuptools builds it like any other. */

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>

/* Bumped whenever a signature below changes; kernel.py refuses a library built from another version
   (a stale build in an editable checkout) and falls back to NumPy. */
int64_t fm_abi_version(void) { return 1; }

static double sq_dist(const double *a, const double *b, int64_t d) {
    double s = 0.0;
    for (int64_t q = 0; q < d; q++) {
        double t = b[q] - a[q];
        s += t * t;
    }
    return s;
}

#define WINDOW 3 /* nodes on either side of a sample's centre node, scored before the rest */

/* Row c of the squared node-to-node distances D2 (N x N) and reach[c], the distance from node c to
   the nearest node more than WINDOW places away along the map; computed on first use in a call
   (done[c] != 0 afterwards), since most calls rescan few samples around few nodes. */
static const double *node_row(int64_t c, int64_t N, int64_t d, const double *y, double *D2, double *reach,
                              double *done) {
    double *row = D2 + c * N;
    if (!done[c]) {
        double r = INFINITY;
        for (int64_t j = 0; j < N; j++) {
            row[j] = sq_dist(y + c * d, y + j * d, d);
            if ((j < c - WINDOW || j > c + WINDOW) && row[j] < r) r = row[j];
        }
        reach[c] = sqrt(r);
        done[c] = 1.0;
    }
    return row;
}

static void update_best(double di, int64_t i, double *best, int64_t *bi) {
    if (di < *best || (di == *best && i < *bi)) { /* ties to the lowest index, as numpy.argmin */
        *best = di;
        *bi = i;
    }
}

/* Exact nearest node of sample x around centre node c, with fresh bounds: the window c-WINDOW..c+WINDOW
   first; every node outside it is at least reach[c] - |x - y_c| from x (triangle inequality), so a
   window node nearer than that settles the sample; otherwise the outside nodes are scanned too,
   skipping those with |y_i - y_c| > 2|x - y_c| (farther than y_c itself). */
static void scan(const double *x, int64_t c, int64_t N, int64_t d, const double *y, double *D2,
                 double *reach, double *done, double slack, int64_t *label, double *upper, double *lower_in,
                 double *lower_out) {
    const double *Dc2 = node_row(c, N, d, y, D2, reach, done);
    int64_t lo = c - WINDOW < 0 ? 0 : c - WINDOW, hi = c + WINDOW >= N ? N - 1 : c + WINDOW;
    double dist[2 * WINDOW + 1];
    double best = INFINITY;
    int64_t bi = c;
    for (int64_t i = lo; i <= hi; i++) {
        dist[i - lo] = sqrt(sq_dist(x, y + i * d, d));
        update_best(dist[i - lo], i, &best, &bi);
    }
    double dc = dist[c - lo];
    double outside = reach[c] - dc, outside_best = INFINITY;
    int64_t outside_bi = N; /* none yet: never preferred in a tie, and no index is ever read from it */
    if (!(best + slack < outside)) {
        double far = 2.0 * dc + slack, far2 = far * far, pruned2 = INFINITY, second_out = INFINITY;
        for (int64_t i = 0; i < N; i++) {
            if (i >= lo && i <= hi) continue;
            if (Dc2[i] > far2) {
                if (Dc2[i] < pruned2) pruned2 = Dc2[i];
                continue;
            }
            double di = sqrt(sq_dist(x, y + i * d, d));
            if (di < outside_best || (di == outside_best && i < outside_bi)) {
                second_out = outside_best;
                outside_best = di;
                outside_bi = i;
            } else if (di < second_out) {
                second_out = di;
            }
        }
        double pruned = sqrt(pruned2) - dc;
        if (outside_best < best || (outside_best == best && outside_bi < bi)) {
            /* the nearest node lies outside the window (the path folds back): every window node is
               another node, the outside ones other than it give the outside bound */
            best = outside_best;
            bi = outside_bi;
            outside = second_out < pruned ? second_out : pruned;
        } else {
            outside = outside_best < pruned ? outside_best : pruned;
        }
    }
    double inside = INFINITY;
    for (int64_t i = lo; i <= hi; i++)
        if (i != bi && dist[i - lo] < inside) inside = dist[i - lo];
    *label = bi;
    *upper = best;
    *lower_in = inside;
    *lower_out = outside;
}

/* E-step. Per sample: labels, centre (the node its window is around), upper (distance to its node),
   lower_in (to the other window nodes), lower_out (to the nodes outside the window), all in/out.
   Between calls the bounds loosen by how far nodes moved: upper by its node's move, lower_in by the
   largest move in its window, lower_out by the largest move overall; a sample is rescanned around its
   node only when they cross. first != 0: no bounds yet, every sample is scanned around the previous
   sample's node (samples come in time order along the path). y0: the nodes at the previous call.
   Returns how many labels changed (M when first). Workspace: D2 (N x N), reach, move, wmax and
   done (N each). */
int64_t fm_assign(int64_t M, int64_t N, int64_t d, const double *x, const double *y, const double *y0,
                  int first, int64_t *labels, int64_t *center, double *upper, double *lower_in,
                  double *lower_out, double slack, double *D2, double *reach, double *move, double *wmax,
                  double *done) {
    double farthest = 0.0;
    for (int64_t i = 0; i < N; i++) done[i] = 0.0;
    if (!first) {
        for (int64_t i = 0; i < N; i++) {
            move[i] = sqrt(sq_dist(y + i * d, y0 + i * d, d));
            if (move[i] > farthest) farthest = move[i];
        }
        for (int64_t c = 0; c < N; c++) {
            double m = 0.0;
            for (int64_t i = c - WINDOW < 0 ? 0 : c - WINDOW; i <= c + WINDOW && i < N; i++)
                if (move[i] > m) m = move[i];
            wmax[c] = m;
        }
    }
    int64_t changed = 0;
    for (int64_t j = 0; j < M; j++) {
        const double *xj = x + j * d;
        int64_t old = labels[j], c;
        if (first) {
            c = j > 0 ? labels[j - 1] : 0;
        } else {
            double u = upper[j] + move[old];
            double li = lower_in[j] - wmax[center[j]], lo = lower_out[j] - farthest;
            double lb = li < lo ? li : lo;
            if (!(u + slack < lb)) u = sqrt(sq_dist(xj, y + old * d, d));
            if (u + slack < lb) {
                upper[j] = u;
                lower_in[j] = li;
                lower_out[j] = lo;
                continue;
            }
            c = old;
        }
        scan(xj, c, N, d, y, D2, reach, done, slack, labels + j, upper + j, lower_in + j, lower_out + j);
        center[j] = c;
        if (first || labels[j] != old) changed++;
    }
    return changed;
}

/* W, b (N x d) from labels (M) and samples x (M x d); w (M x d) per-axis weights or NULL for 1. */
void fm_cluster_sums(int64_t M, int64_t N, int64_t d, const int64_t *labels, const double *x,
                     const double *w, double *W, double *b) {
    for (int64_t k = 0; k < N * d; k++) {
        W[k] = 0.0;
        b[k] = 0.0;
    }
    for (int64_t j = 0; j < M; j++) {
        double *Wl = W + labels[j] * d, *bl = b + labels[j] * d;
        for (int64_t q = 0; q < d; q++) {
            if (w) {
                double wq = w[j * d + q];
                Wl[q] += wq;
                bl[q] += wq * x[j * d + q];
            } else {
                Wl[q] += 1.0;
                bl[q] += x[j * d + q];
            }
        }
    }
}

/* Force points k = 0..K-1: source sample src[k], point p (K x d), moments (K x 2d) = [|f|, |f| * p].
   Spring target max(|p - y_tied|, delta); init != 0 sets spring = target, else
   spring += omega * (target - spring). sums (N x 2d) = per node sum of moments / (stiffness * spring).
   Returns the largest spring change (0 when init). */
double fm_force_sums(int64_t K, int64_t N, int64_t d, const int64_t *src, const int64_t *labels,
                     const double *p, const double *moments, const double *omega, const double *y,
                     double delta, double stiffness, int init, double *spring, double *sums) {
    int64_t width = 2 * d;
    for (int64_t k = 0; k < N * width; k++) sums[k] = 0.0;
    double moved = 0.0;
    for (int64_t k = 0; k < K; k++) {
        int64_t node = labels[src[k]];
        double target = sqrt(sq_dist(p + k * d, y + node * d, d));
        if (target < delta) target = delta;
        double s;
        if (init) {
            s = target;
        } else {
            s = spring[k] + omega[k] * (target - spring[k]);
            double change = fabs(s - spring[k]);
            if (change > moved) moved = change;
        }
        spring[k] = s;
        double inv = 1.0 / (stiffness * s);
        double *row = sums + node * width;
        const double *mk = moments + k * width;
        for (int64_t c = 0; c < width; c++) row[c] += mk[c] * inv;
    }
    return moved;
}

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_emkernel", "C loops for the elastic-map EM; used through ctypes.", -1,
    NULL,                  NULL,        NULL,                                                   NULL,
    NULL};

PyMODINIT_FUNC PyInit__emkernel(void) { return PyModule_Create(&module); }
