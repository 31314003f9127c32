/* The single-pose path of the closed-form IK, compiled: kr210_sim.robot.ik_scalar's
 * solutions() and nearest_solution() in C, operation for operation (the same floats: build
 * without -ffast-math and with -ffp-contract=off, so no product is fused into a sum).
 *
 * inverse_one(T, g) and nearest_one(T, q_ref, g) take what ik_scalar's functions of the same
 * names take. Anything but a float64 (4, 4) pose and a finite float64 (6,) reference goes to
 * the pure-Python functions given to setup(), as does a pose that fails the quick check (for
 * the exact check and its message). Angles in [rad], lengths in [m].
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <float.h>
#include <math.h>
#include <string.h>

#define PI_ 3.141592653589793
#define TWO_PI_ (2.0 * PI_)
#define HALF_PI_ (PI_ / 2.0)
#define SLACK 1e-9
#define WRIST_SINGULAR 1e-9
#define NEAREST_STRAIGHT 1e-7
#define FAST_TOL 1e-7

typedef struct {
    double dg, d0, h1, a1, a2, L, phi, a2sq, Lsq, den;
    double lo[6], hi[6], lo_s[6], hi_s[6], w[6];
    int wide1, inner2, inner3, wide4, wide5, wide6, inner5, quick;
} Consts;

static PyObject *py_inverse_one, *py_nearest_one, *py_check_flat, *py_constants, *np_empty;
static PyObject *shapes[9];
static PyObject *cached_g; /* the geometry whose constants are in cached (a strong reference) */
static Consts cached;

/* CPython's math.hypot of two floats (its vector_norm: power-of-two scaling, exact squares,
 * compensated sum, one correction of the square root), so that rho and s5 are its floats. */
static void exact_square(double x, double *hi, double *lo)
{
    double p = x * x, c = 134217729.0 * x, xh = c - (c - x), xl = x - xh;
    *hi = p;
    *lo = ((xh * xh - p) + 2.0 * xh * xl) + xl * xl;
}

static double py_hypot(double x, double y)
{
    double v[2], mx, scale, csum = 1.0, f1 = 0.0, f2 = 0.0, h, hi, lo, s, t;
    int e, i;
    x = fabs(x);
    y = fabs(y);
    if (isinf(x) || isinf(y)) return INFINITY;
    if (isnan(x) || isnan(y)) return NAN;
    mx = x > y ? x : y;
    if (mx == 0.0) return mx;
    frexp(mx, &e);
    if (e < -1023) { /* 2^-e would overflow: divide by the larger instead (as CPython 3.11) */
        double oldcsum;
        v[0] = x / mx;
        v[1] = y / mx;
        for (i = 0; i < 2; i++) {
            t = v[i] * v[i];
            oldcsum = csum;
            csum += t;
            f1 += (oldcsum - csum) + t;
        }
        return mx * sqrt(csum - 1.0 + f1);
    }
    scale = ldexp(1.0, -e);
    v[0] = x * scale;
    v[1] = y * scale;
    for (i = 0; i < 2; i++) {
        exact_square(v[i], &hi, &lo);
        s = csum + hi; /* fast two-sum: |csum| >= |hi| */
        t = (csum - s) + hi;
        csum = s;
        f1 += lo;
        f2 += t;
    }
    h = sqrt(csum - 1.0 + (f1 + f2));
    exact_square(h, &hi, &lo);
    hi = -hi;
    lo = -lo;
    s = csum + hi;
    t = (csum - s) + hi;
    csum = s;
    f1 += lo;
    f2 += t;
    x = csum - 1.0 + (f1 + f2);
    h += x / (2.0 * h);
    return h / scale;
}

/* Python's round(x) as a float: half to even, and +0.0 for a zero (an int 0 times 2 pi). */
static inline double py_round(double x) { return nearbyint(x) + 0.0; }

static int wrap_into(double v, double lo, double hi, double *out)
{
    if (-PI_ < v && v <= PI_ && lo - SLACK <= v && v <= hi + SLACK) {
        *out = v;
        return 1;
    }
    v = remainder(v, TWO_PI_);
    if (v < lo - SLACK)
        v += TWO_PI_;
    else if (v > hi + SLACK)
        v -= TWO_PI_;
    if (lo - SLACK <= v && v <= hi + SLACK) {
        *out = v;
        return 1;
    }
    return 0;
}

/* v as a value of joint j inside its limits: v itself where it already is one (or the joint's
   range holds all of (-pi, pi], wide), else wrap_into's; 0 when no 2 pi shift brings it in
   (Python: the inline limit checks of solutions and nearest_solution). */
static inline int fit(double v, int wide, const Consts *c, int j, double *out)
{
    if (wide || (-PI_ < v && c->lo_s[j] <= v && v <= c->hi_s[j])) {
        *out = v;
        return 1;
    }
    return wrap_into(v, c->lo[j], c->hi[j], out);
}

/* The same for joints 2 and 3, whose values come from sums, not atan2 (inner: the joint's range
   lies inside (-pi, pi], so no 2 pi shift brings a value from there into it). */
static inline int fit_arm(double v, int inner, const Consts *c, int j, double *out)
{
    if (c->lo_s[j] <= v && v <= c->hi_s[j] && (inner || (-PI_ < v && v <= PI_))) {
        *out = v;
        return 1;
    }
    if (inner && -PI_ < v && v <= PI_) return 0;
    return wrap_into(v, c->lo[j], c->hi[j], out);
}

/* Swap the two entries of a pair (the two shoulders, the two arms, sorted by cost). */
static inline void swap2(double *a)
{
    double t = a[0];
    a[0] = a[1], a[1] = t;
}

static inline void swap2i(int *a)
{
    int t = a[0];
    a[0] = a[1], a[1] = t;
}

/* Joint 1's rotation taken out of the pose's rotation (row-major p): the entries of
   Rz(q1)^T R that the arm and the wrist need, worked out once a shoulder, when its first arm
   is solved. */
static inline void shoulder_rows(double q1, const double *p, double *t00, double *t01,
                                 double *t02, double *m10, double *m11)
{
    double c1 = cos(q1), s1 = sin(q1);
    *t00 = c1 * p[0] + s1 * p[4];
    *t01 = c1 * p[1] + s1 * p[5];
    *t02 = c1 * p[2] + s1 * p[6];
    *m10 = -s1 * p[0] + c1 * p[4];
    *m11 = -s1 * p[1] + c1 * p[5];
}

/* q4 and q6 of a wrist that is not straight: flip +1 for q5 > 0 as atan2 gives it, -1 for its
   mirror (q5 < 0); m: entries of the wrist's rotation (Python: the two flips written out). */
static inline void wrist_flip(int flip, double m10, double m20, double m01, double m02,
                              double *v4, double *v6)
{
    if (flip > 0) {
        *v4 = atan2(m10, -m20);
        *v6 = atan2(m01, m02);
    } else {
        *v4 = atan2(-m10, m20);
        *v6 = atan2(-m01, -m02);
    }
}

/* The cosine of the elbow's angle for the wrist centre at (x, zz) in the arm's plane [m],
   rounded into [-1, 1] from up to 1e-12 beyond; 0 when the centre is out of the arm's reach. */
static inline int elbow_cos(double x, double zz, const Consts *c, double *cos_d)
{
    double v = (x * x + zz * zz - c->a2sq - c->Lsq) / c->den;
    if (v > 1.0) {
        if (v > 1.0 + 1e-12) return 0;
        v = 1.0;
    } else if (v < -1.0) {
        if (v < -1.0 - 1e-12) return 0;
        v = -1.0;
    }
    *cos_d = v;
    return 1;
}

static double best_twin(double value, double ref, double lo, double hi)
{
    double best = value, best_d = INFINITY, k0, v;
    lo -= SLACK;
    hi += SLACK;
    k0 = py_round((ref - value) / TWO_PI_);
    v = value + (k0 - 1.0) * TWO_PI_;
    if (lo <= v && v <= hi) {
        best = v;
        best_d = fabs(v - ref);
    }
    v = value + k0 * TWO_PI_;
    if (lo <= v && v <= hi && fabs(v - ref) < best_d) {
        best = v;
        best_d = fabs(v - ref);
    }
    v = value + (k0 + 1.0) * TWO_PI_;
    if (lo <= v && v <= hi && fabs(v - ref) < best_d) best = v;
    return best;
}

/* ------------------------------------------------------------------ every branch */
static int solve_all(const double *p, const Consts *c, double *out)
{
    double r00 = p[0], px = p[3], r10 = p[4], py = p[7], r20 = p[8], r21 = p[9], r22 = p[10];
    double pz = p[11];
    double wx = px - c->dg * r00, wy = py - c->dg * r10, wz = pz - c->dg * r20;
    double base_q1 = atan2(wy, wx), rho = py_hypot(wx, wy), zz = wz - c->d0 - c->h1;
    int n = 0, back;
    for (back = 0; back < 2; back++) {
        double q1, x, cos_d, q1w, ac, A, B, t00 = 0, t01 = 0, t02 = 0, m10 = 0, m11 = 0;
        int rows = 0, ie, nel;
        if (back) {
            q1 = base_q1 + PI_;
            x = -rho - c->a1;
        } else {
            q1 = base_q1;
            x = rho - c->a1;
        }
        if (!elbow_cos(x, zz, c, &cos_d)) continue;
        q1w = q1;
        if (!(-PI_ < q1 && q1 <= PI_ && (c->wide1 || (c->lo_s[0] <= q1 && q1 <= c->hi_s[0])))) {
            if (!wrap_into(q1, c->lo[0], c->hi[0], &q1w)) continue;
        }
        ac = acos(cos_d);
        A = atan2(zz, x);
        B = atan2(c->L * sin(ac), c->a2 + c->L * cos(ac));
        nel = (-1.0 < cos_d && cos_d < 1.0) ? 2 : 1;
        for (ie = 0; ie < nel; ie++) {
            double elbow = ie ? -1.0 : 1.0, q2, q2w, q3, q3w, q23, c23, s23, m00, m20, s5;
            q2 = HALF_PI_ - (A - elbow * B);
            if (!fit_arm(q2, c->inner2, c, 1, &q2w)) continue;
            q3 = -(elbow * ac) - c->phi - HALF_PI_;
            if (!fit_arm(q3, c->inner3, c, 2, &q3w)) continue;
            if (!rows) {
                rows = 1;
                shoulder_rows(q1, p, &t00, &t01, &t02, &m10, &m11);
            }
            q23 = q2 + q3;
            c23 = cos(q23);
            s23 = sin(q23);
            m00 = t00 * c23 - r20 * s23;
            m20 = t00 * s23 + r20 * c23;
            s5 = py_hypot(m10, m20);
            if (s5 < WRIST_SINGULAR) {
                double m21 = t01 * s23 + r21 * c23, v4 = 0.0, v5, v6, w;
                if (m00 > 0) {
                    v5 = 0.0;
                    v6 = atan2(m21, m11);
                } else {
                    v5 = PI_;
                    v6 = atan2(-m21, m11);
                }
                if (!fit(v5, c->wide5, c, 4, &v5)) continue;
                if (!fit(v6, c->wide6, c, 5, &v6)) continue;
                if (!(c->wide4 || (c->lo_s[3] <= 0.0 && 0.0 <= c->hi_s[3]))) {
                    if (!wrap_into(0.0, c->lo[3], c->hi[3], &w)) continue;
                    v4 = w;
                }
                out[n++] = q1w, out[n++] = q2w, out[n++] = q3w;
                out[n++] = v4, out[n++] = v5, out[n++] = v6;
                continue;
            }
            {
                double m01 = t01 * c23 - r21 * s23, m02 = t02 * c23 - r22 * s23;
                double q5 = atan2(s5, m00);
                int flip;
                if (c->quick) {
                    if (c->lo_s[4] <= q5 && q5 <= c->hi_s[4]) {
                        out[n++] = q1w, out[n++] = q2w, out[n++] = q3w;
                        out[n++] = atan2(m10, -m20), out[n++] = q5, out[n++] = atan2(m01, m02);
                    }
                    if (c->lo_s[4] <= -q5 && -q5 <= c->hi_s[4]) {
                        out[n++] = q1w, out[n++] = q2w, out[n++] = q3w;
                        out[n++] = atan2(-m10, m20), out[n++] = -q5;
                        out[n++] = atan2(-m01, -m02);
                    }
                    continue;
                }
                for (flip = 0; flip < 2; flip++) {
                    double v4, v5 = flip ? -q5 : q5, v6;
                    if (!fit(v5, c->wide5, c, 4, &v5)) continue;
                    wrist_flip(flip ? -1 : 1, m10, m20, m01, m02, &v4, &v6);
                    if (!fit(v4, c->wide4, c, 3, &v4)) continue;
                    if (!fit(v6, c->wide6, c, 5, &v6)) continue;
                    out[n++] = q1w, out[n++] = q2w, out[n++] = q3w;
                    out[n++] = v4, out[n++] = v5, out[n++] = v6;
                }
            }
        }
    }
    return n / 6;
}

/* The nearest twin of joint j's value to the reference (Python: round, then best_twin). */
static inline double twin(double v, double f, const Consts *c, int j, double *d)
{
    double t = v + py_round((f - v) / TWO_PI_) * TWO_PI_;
    *d = t - f;
    if (!(-(PI_ - 1e-6) < *d && *d < (PI_ - 1e-6) && c->lo_s[j] <= t && t <= c->hi_s[j])) {
        t = best_twin(v, f, c->lo[j], c->hi[j]);
        *d = t - f;
    }
    return t;
}

/* ------------------------------------------------------------------ nearest */
static int solve_nearest(const double *p, const Consts *c, const double *f, double *best)
{
    double r00 = p[0], px = p[3], r10 = p[4], py = p[7], r20 = p[8], r21 = p[9], r22 = p[10];
    double pz = p[11];
    double wx = px - c->dg * r00, wy = py - c->dg * r10, wz = pz - c->dg * r20;
    double base_q1 = atan2(wy, wx), rho = py_hypot(wx, wy), zz = wz - c->d0 - c->h1;
    double sh_bound[2], sh_q1w[2], sh_q1[2], best_cost = INFINITY, d;
    int sh_back[2], ns = 0, found = 0, best_key = 8, back, is;
    for (back = 0; back < 2; back++) {
        double q1 = back ? base_q1 + PI_ : base_q1, q1w = q1;
        if (!(-PI_ < q1 && q1 <= PI_ && (c->wide1 || (c->lo_s[0] <= q1 && q1 <= c->hi_s[0])))) {
            if (!wrap_into(q1, c->lo[0], c->hi[0], &q1w)) continue;
        }
        d = q1w + py_round((f[0] - q1w) / TWO_PI_) * TWO_PI_ - f[0];
        sh_bound[ns] = d * d * c->w[0] * (1.0 - 1e-9);
        sh_back[ns] = back;
        sh_q1w[ns] = q1w;
        sh_q1[ns] = q1;
        ns++;
    }
    if (ns == 2 && sh_bound[1] < sh_bound[0]) {
        swap2(sh_bound), swap2(sh_q1w), swap2(sh_q1), swap2i(sh_back);
    }
    for (is = 0; is < ns; is++) {
        double q1w = sh_q1w[is], q1 = sh_q1[is], t1, cost1, x, cos_d, ac, A, B;
        double arm_cost[2], arm_q2w[2], arm_q3w[2], arm_q23[2];
        double t00 = 0, t01 = 0, t02 = 0, m10 = 0, m11 = 0;
        int arm_lower[2], na = 0, nel, ie, ia, rows = 0;
        back = sh_back[is];
        if (sh_bound[is] > best_cost) break;
        t1 = twin(q1w, f[0], c, 0, &d);
        cost1 = d * d * c->w[0];
        x = back ? -rho - c->a1 : rho - c->a1;
        if (!elbow_cos(x, zz, c, &cos_d)) continue;
        ac = acos(cos_d);
        A = atan2(zz, x);
        B = atan2(c->L * sin(ac), c->a2 + c->L * cos(ac));
        nel = (-1.0 < cos_d && cos_d < 1.0) ? 2 : 1;
        for (ie = 0; ie < nel; ie++) {
            double elbow = ie ? -1.0 : 1.0, q2, q2w, q3, q3w, cost;
            q2 = HALF_PI_ - (A - elbow * B);
            if (!fit_arm(q2, c->inner2, c, 1, &q2w)) continue;
            q3 = -(elbow * ac) - c->phi - HALF_PI_;
            if (!fit_arm(q3, c->inner3, c, 2, &q3w)) continue;
            d = q2w - f[1];
            cost = cost1 + d * d * c->w[1];
            d = q3w - f[2];
            cost += d * d * c->w[2];
            arm_cost[na] = cost;
            arm_lower[na] = elbow < 0.0;
            arm_q2w[na] = q2w;
            arm_q3w[na] = q3w;
            arm_q23[na] = q2 + q3;
            na++;
        }
        if (na == 2 && arm_cost[1] < arm_cost[0]) {
            swap2(arm_cost), swap2(arm_q2w), swap2(arm_q3w), swap2(arm_q23), swap2i(arm_lower);
        }
        for (ia = 0; ia < na; ia++) {
            double cost3 = arm_cost[ia], q2w = arm_q2w[ia], q3w = arm_q3w[ia], q23 = arm_q23[ia];
            double c23, s23, m00, m20, s5, m21 = 0, m01 = 0, m02 = 0, q5 = 0;
            int lower = arm_lower[ia], singular, flips[2], nf, k;
            if (cost3 > best_cost) break;
            if (!rows) {
                rows = 1;
                shoulder_rows(q1, p, &t00, &t01, &t02, &m10, &m11);
            }
            c23 = cos(q23);
            s23 = sin(q23);
            m00 = t00 * c23 - r20 * s23;
            m20 = t00 * s23 + r20 * c23;
            s5 = py_hypot(m10, m20);
            singular = s5 < WRIST_SINGULAR;
            if (singular) {
                m21 = t01 * s23 + r21 * c23;
                flips[0] = 0;
                nf = 1;
            } else {
                m01 = t01 * c23 - r21 * s23;
                m02 = t02 * c23 - r22 * s23;
                q5 = atan2(s5, m00);
                flips[0] = f[4] >= 0.0 ? 1 : -1;
                flips[1] = -flips[0];
                nf = 2;
            }
            for (k = 0; k < nf; k++) {
                int flip = flips[k];
                double v4, v5, v6, w, c5, cost, t, sv5;
                if (flip == 0)
                    v5 = m00 > 0 ? 0.0 : PI_;
                else
                    v5 = flip > 0 ? q5 : -q5;
                if (!(c->wide5 || (c->lo_s[4] <= v5 && v5 <= c->hi_s[4] && (c->inner5 || -PI_ < v5)))) {
                    if (!wrap_into(v5, c->lo[4], c->hi[4], &w)) continue;
                    v5 = w;
                }
                d = v5 - f[4];
                c5 = d * d * c->w[4];
                if (cost3 + c5 > best_cost) continue;
                if (flip == 0) {
                    v4 = 0.0;
                    v6 = m00 > 0 ? atan2(m21, m11) : atan2(-m21, m11);
                } else {
                    wrist_flip(flip, m10, m20, m01, m02, &v4, &v6);
                }
                if (!fit(v4, c->wide4, c, 3, &v4)) continue;
                if (!fit(v6, c->wide6, c, 5, &v6)) continue;
                sv5 = sin(v5);
                if (-NEAREST_STRAIGHT < sv5 && sv5 < NEAREST_STRAIGHT) {
                    double shift = f[3] - v4;
                    v4 = f[3];
                    v6 = cos(v5) > 0 ? v6 - shift : v6 + shift;
                    if (!(c->lo_s[5] <= v6 && v6 <= c->hi_s[5])) {
                        if (!wrap_into(v6, c->lo[5], c->hi[5], &w)) continue;
                        v6 = w;
                    }
                }
                t = twin(v4, f[3], c, 3, &d);
                v4 = t;
                cost = cost3 + d * d * c->w[3] + c5;
                if (cost > best_cost) continue;
                t = twin(v6, f[5], c, 5, &d);
                v6 = t;
                cost += d * d * c->w[5];
                if (cost <= best_cost) {
                    int key = 4 * back + 2 * lower + (flip < 0);
                    if (cost < best_cost || key < best_key) {
                        best_cost = cost;
                        best_key = key;
                        best[0] = t1, best[1] = q2w, best[2] = q3w;
                        best[3] = v4, best[4] = v5, best[5] = v6;
                        found = 1;
                    }
                }
            }
        }
    }
    return found;
}

/* ------------------------------------------------------------------ glue */
static int read_doubles(PyObject *seq, double *dst, Py_ssize_t n)
{
    Py_ssize_t i;
    if (!PyTuple_Check(seq) || PyTuple_GET_SIZE(seq) != n) {
        PyErr_SetString(PyExc_TypeError, "_ik_native: constants() gave an unexpected tuple");
        return 0;
    }
    for (i = 0; i < n; i++) {
        dst[i] = PyFloat_AsDouble(PyTuple_GET_ITEM(seq, i));
        if (dst[i] == -1.0 && PyErr_Occurred()) return 0;
    }
    return 1;
}

/* The constants of geometry g (ik_scalar.constants read once per geometry). */
static const Consts *consts_of(PyObject *g)
{
    PyObject *t;
    Consts c;
    double head[10], flags[8];
    PyObject *fl;
    Py_ssize_t i;
    if (g == cached_g) return &cached;
    t = PyObject_CallOneArg(py_constants, g);
    if (t == NULL) return NULL;
    if (!PyTuple_Check(t) || PyTuple_GET_SIZE(t) != 16) {
        Py_DECREF(t);
        PyErr_SetString(PyExc_TypeError, "_ik_native: constants() gave an unexpected tuple");
        return NULL;
    }
    for (i = 0; i < 10; i++) {
        head[i] = PyFloat_AsDouble(PyTuple_GET_ITEM(t, i));
        if (head[i] == -1.0 && PyErr_Occurred()) goto fail;
    }
    c.dg = head[0], c.d0 = head[1], c.h1 = head[2], c.a1 = head[3], c.a2 = head[4];
    c.L = head[5], c.phi = head[6], c.a2sq = head[7], c.Lsq = head[8], c.den = head[9];
    if (!read_doubles(PyTuple_GET_ITEM(t, 10), c.lo, 6) ||
        !read_doubles(PyTuple_GET_ITEM(t, 11), c.hi, 6) ||
        !read_doubles(PyTuple_GET_ITEM(t, 12), c.lo_s, 6) ||
        !read_doubles(PyTuple_GET_ITEM(t, 13), c.hi_s, 6) ||
        !read_doubles(PyTuple_GET_ITEM(t, 15), c.w, 6))
        goto fail;
    fl = PyTuple_GET_ITEM(t, 14);
    if (!PyTuple_Check(fl) || PyTuple_GET_SIZE(fl) != 8) {
        PyErr_SetString(PyExc_TypeError, "_ik_native: constants() gave unexpected flags");
        goto fail;
    }
    for (i = 0; i < 8; i++) {
        int v = PyObject_IsTrue(PyTuple_GET_ITEM(fl, i));
        if (v < 0) goto fail;
        flags[i] = v;
    }
    c.wide1 = flags[0] != 0, c.inner2 = flags[1] != 0, c.inner3 = flags[2] != 0;
    c.wide4 = flags[3] != 0, c.wide5 = flags[4] != 0, c.wide6 = flags[5] != 0;
    c.inner5 = flags[6] != 0, c.quick = flags[7] != 0;
    Py_DECREF(t);
    Py_INCREF(g);
    Py_XSETREF(cached_g, g);
    cached = c;
    return &cached;
fail:
    Py_DECREF(t);
    return NULL;
}

/* The 16 entries of a float64 (4, 4) pose, row by row: 1, or 0 when T is anything else (no
 * error set: the caller takes the pure-Python path). */
static int read_pose(PyObject *T, double *p)
{
    Py_buffer v;
    int i, j, ok;
    if (PyObject_GetBuffer(T, &v, PyBUF_RECORDS_RO) < 0) {
        PyErr_Clear();
        return 0;
    }
    ok = v.ndim == 2 && v.shape[0] == 4 && v.shape[1] == 4 && v.itemsize == 8 && v.format &&
         (strcmp(v.format, "d") == 0 || strcmp(v.format, "=d") == 0);
    if (ok)
        for (i = 0; i < 4; i++)
            for (j = 0; j < 4; j++)
                memcpy(p + 4 * i + j, (char *)v.buf + i * v.strides[0] + j * v.strides[1], 8);
    PyBuffer_Release(&v);
    return ok;
}

/* check_pose_flat's quick test; a pose that fails it takes the exact checks in Python (which
 * raise with their message, or pass it). 1: passed, 0: an error is set. */
static int check_pose(const double *v)
{
    double a = v[0], b = v[1], c = v[2], d = v[4], e = v[5], f = v[6], g = v[8], h = v[9];
    double k = v[10], t;
    PyObject *lst, *r;
    int i;
    t = a * a + d * d + g * g - 1.0;
    if (!(-FAST_TOL <= t && t <= FAST_TOL)) goto slow;
    t = b * b + e * e + h * h - 1.0;
    if (!(-FAST_TOL <= t && t <= FAST_TOL)) goto slow;
    t = a * b + d * e + g * h;
    if (!(-FAST_TOL <= t && t <= FAST_TOL)) goto slow;
    t = c - (d * h - g * e);
    if (!(-FAST_TOL <= t && t <= FAST_TOL)) goto slow;
    t = f - (g * b - a * h);
    if (!(-FAST_TOL <= t && t <= FAST_TOL)) goto slow;
    t = k - (a * e - d * b);
    if (!(-FAST_TOL <= t && t <= FAST_TOL)) goto slow;
    if (v[12] == 0.0 && v[13] == 0.0 && v[14] == 0.0 && v[15] == 1.0 && isfinite(v[3] + v[7] + v[11]))
        return 1;
slow:
    lst = PyList_New(16);
    if (lst == NULL) return 0;
    for (i = 0; i < 16; i++) {
        PyObject *x = PyFloat_FromDouble(v[i]);
        if (x == NULL) {
            Py_DECREF(lst);
            return 0;
        }
        PyList_SET_ITEM(lst, i, x);
    }
    r = PyObject_CallOneArg(py_check_flat, lst);
    Py_DECREF(lst);
    if (r == NULL) return 0;
    Py_DECREF(r);
    return 1;
}

static int ready(void)
{
    if (np_empty == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "_ik_native: setup() was not called");
        return 0;
    }
    return 1;
}

PyDoc_STRVAR(inverse_one_doc,
"inverse_one(T, g)\n--\n\n"
"Every solution of one pose inside the limits: (k, 6) float64 [rad], k = 0 ... 8, in the\n"
"branch order of ik_scalar.solutions (T a (4, 4) pose [m], g a Geometry).");

static PyObject *inverse_one(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double p[16], out[48];
    const Consts *c;
    PyObject *arr;
    Py_buffer v;
    int k;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "inverse_one(T, g) takes 2 arguments");
        return NULL;
    }
    if (!ready()) return NULL;
    if (!read_pose(args[0], p)) return PyObject_Vectorcall(py_inverse_one, args, 2, NULL);
    if (!check_pose(p)) return NULL;
    c = consts_of(args[1]);
    if (c == NULL) return NULL;
    k = solve_all(p, c, out);
    arr = PyObject_CallOneArg(np_empty, shapes[k]);
    if (arr == NULL) return NULL;
    if (k) {
        if (PyObject_GetBuffer(arr, &v, PyBUF_CONTIG) < 0) {
            Py_DECREF(arr);
            return NULL;
        }
        memcpy(v.buf, out, (size_t)k * 6 * sizeof(double));
        PyBuffer_Release(&v);
    }
    return arr;
}

PyDoc_STRVAR(nearest_one_doc,
"nearest_one(T, q_ref, g)\n--\n\n"
"The solution of one pose closest in time to q_ref: a list of six floats [rad], empty when\n"
"none lies inside the limits (ik_scalar.nearest_solution's search).");

static PyObject *nearest_one(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double p[16], f[6], best[6];
    const Consts *c;
    Py_buffer v;
    PyObject *lst;
    int ok, i;
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "nearest_one(T, q_ref, g) takes 3 arguments");
        return NULL;
    }
    if (!ready()) return NULL;
    if (!read_pose(args[0], p)) return PyObject_Vectorcall(py_nearest_one, args, 3, NULL);
    if (PyObject_GetBuffer(args[1], &v, PyBUF_RECORDS_RO) < 0) {
        PyErr_Clear();
        return PyObject_Vectorcall(py_nearest_one, args, 3, NULL);
    }
    ok = v.ndim == 1 && v.shape[0] == 6 && v.itemsize == 8 && v.format &&
         (strcmp(v.format, "d") == 0 || strcmp(v.format, "=d") == 0);
    if (ok)
        for (i = 0; i < 6; i++) {
            memcpy(f + i, (char *)v.buf + i * v.strides[0], 8);
            ok = ok && isfinite(f[i]);
        }
    PyBuffer_Release(&v);
    if (!ok) return PyObject_Vectorcall(py_nearest_one, args, 3, NULL); /* its checks, its errors */
    if (!check_pose(p)) return NULL;
    c = consts_of(args[2]);
    if (c == NULL) return NULL;
    if (!solve_nearest(p, c, f, best)) return PyList_New(0);
    lst = PyList_New(6);
    if (lst == NULL) return NULL;
    for (i = 0; i < 6; i++) {
        PyObject *x = PyFloat_FromDouble(best[i]);
        if (x == NULL) {
            Py_DECREF(lst);
            return NULL;
        }
        PyList_SET_ITEM(lst, i, x);
    }
    return lst;
}

PyDoc_STRVAR(hypot_doc,
"hypot(x, y)\n--\n\n"
"The native path's hypot of two floats, meant to equal Python's math.hypot (for tests).");

static PyObject *hypot_(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double x, y;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "hypot(x, y) takes 2 arguments");
        return NULL;
    }
    x = PyFloat_AsDouble(args[0]);
    if (x == -1.0 && PyErr_Occurred()) return NULL;
    y = PyFloat_AsDouble(args[1]);
    if (y == -1.0 && PyErr_Occurred()) return NULL;
    return PyFloat_FromDouble(py_hypot(x, y));
}

PyDoc_STRVAR(setup_doc,
"setup(inverse_one, nearest_one, check_pose_flat, constants, empty)\n--\n\n"
"The pure-Python functions the native ones fall back on, and numpy.empty.");

static PyObject *setup(PyObject *self, PyObject *args)
{
    PyObject *a, *b, *c, *d, *e;
    int k;
    if (!PyArg_ParseTuple(args, "OOOOO", &a, &b, &c, &d, &e)) return NULL;
    for (k = 0; k < 9; k++) {
        if (shapes[k] == NULL) {
            shapes[k] = Py_BuildValue("(ii)", k, 6);
            if (shapes[k] == NULL) return NULL;
        }
    }
    Py_INCREF(a);
    Py_XSETREF(py_inverse_one, a);
    Py_INCREF(b);
    Py_XSETREF(py_nearest_one, b);
    Py_INCREF(c);
    Py_XSETREF(py_check_flat, c);
    Py_INCREF(d);
    Py_XSETREF(py_constants, d);
    Py_INCREF(e);
    Py_XSETREF(np_empty, e);
    Py_CLEAR(cached_g);
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"inverse_one", (PyCFunction)(void (*)(void))inverse_one, METH_FASTCALL, inverse_one_doc},
    {"nearest_one", (PyCFunction)(void (*)(void))nearest_one, METH_FASTCALL, nearest_one_doc},
    {"hypot", (PyCFunction)(void (*)(void))hypot_, METH_FASTCALL, hypot_doc},
    {"setup", setup, METH_VARARGS, setup_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_ik_native",
    "The single-pose closed-form IK of kr210_sim.robot.ik_scalar, compiled.", -1, methods,
};

PyMODINIT_FUNC PyInit__ik_native(void) { return PyModule_Create(&module); }
