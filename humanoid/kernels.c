/* The ground contact's per-step kernels in C (humanoid.constraints.ground's compiled path).
 *
 * A step of the ground contact is a few hundred small NumPy operations (place the candidate
 * points, pick those near the floor, their Jacobian rows, the joint ranges' rows, the Delassus
 * matrix): each costs the interpreter a microsecond or more, the arithmetic a few
 * nanoseconds. Here each is one call:
 *
 *   plan = ground_plan(...)   the model's kinematic tree and the candidate points, copied once
 *   n = ground_select(plan, q, margin)
 *   ground_write(plan, points, joints, local, J, ids)   (arrays of the n contacts, to fill)
 *   ranges = range_plan(...); m = range_rows(ranges, q, margin, hint, has_hint, r, J, ids)
 *   contact_solve(J, Minv, v_free, gap, nc, mu, tol, rho, max_iter, mem, screen, lam, v)
 *   tree_dynamics(plan, n, inertia, gravity, Q, V, A, R, t, w, m, f, tau)   (many states' RNEA)
 *   constraint_rows(plan, q, v, ints, reals, alpha, beta, J, gamma)   (welds' and locks' rows)
 *   held_torques(plan, inertia, gravity, q, v, dv, ints, reals, tau)   (the welded walk's)
 *
 * ground_select places every joint from q (the forward kinematics of the joint kinds below,
 * the same products as Pinocchio's: oMi = oMparent * jointPlacement * jointMotion(q)), places
 * every candidate point and keeps those within the margin of the floor exactly as the NumPy
 * path does (ground.py: Ground._detect); ground_write writes each kept point's world position,
 * joint, local position, its three rows of the contact Jacobian (world axes; v_p = v_O + w x p)
 * and its candidate's id. range_rows is limits.py's JointRanges.rows; contact_solve is the
 * step's conic solve (ADMM on the Delassus matrix, warm-started by the caller).
 *
 * Only the Python C API and the buffer protocol: no NumPy headers, no Pinocchio, so it builds
 * in a second with any C compiler. The NumPy paths stay, and tests/test_kernels.py holds the
 * two to each other.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double PI = 3.14159265358979323846;

/* joint kinds (ground.py: JOINT_KINDS) */
enum { J_FREE = 0, J_BALL = 1, J_REVOLUTE = 2, J_PRISMATIC = 3, J_UNBOUNDED = 4 };
/* candidate kinds: a fixed point, a sphere's centre (lowest point: radius below), a rim's
 * centre (lowest point: radius along the axis' downward normal) */
enum { C_FIXED = 0, C_SPHERE = 1, C_RIM = 2 };

typedef struct {
    Py_ssize_t nj, nq, nv, n; /* n: the last selection's contacts */
    long long *parent, *kind, *iq, *iv;
    double *axis;  /* nj x 3 */
    double *place; /* nj x 12: rotation (row-major), translation */
    double *oR, *ot; /* the placements now: nj x 9, nj x 3 */
    Py_ssize_t nc, nshared, ndirs;
    long long *cjoint, *ckind, *cshape; /* candidates, sorted by (shape, index in the shape) */
    double *clocal, *cradius, *caxis;
    long long *spa, *spb; /* a parent's and a child's candidate that are one point at zero */
    double *dirs;         /* ndirs x 2: the directions of a support polygon's extremes */
    long long max_points;
    double depth_weight, shared;
    double *world; /* nc x 3 scratch */
    unsigned char *keep;
    Py_ssize_t *rows;
} Plan;

static void plan_free(PyObject *capsule) {
    Plan *p = (Plan *)PyCapsule_GetPointer(capsule, "humanoid.ground_plan");
    if (!p) return;
    void *fields[] = {p->parent, p->kind, p->iq, p->iv, p->axis, p->place, p->oR, p->ot,
                      p->cjoint, p->ckind, p->cshape, p->clocal, p->cradius, p->caxis,
                      p->spa, p->spb, p->dirs, p->world, p->keep, p->rows};
    for (size_t k = 0; k < sizeof(fields) / sizeof(fields[0]); ++k) free(fields[k]);
    free(p);
}

/* a copy of a buffer of n items of the given size, or NULL with a ValueError */
static void *copy_buffer(PyObject *obj, Py_ssize_t n, Py_ssize_t itemsize, const char *name) {
    Py_buffer b;
    if (PyObject_GetBuffer(obj, &b, PyBUF_C_CONTIGUOUS) < 0) return NULL;
    if (b.len != n * itemsize) {
        PyErr_Format(PyExc_ValueError, "ground_plan: %s has %zd bytes, expected %zd", name,
                     b.len, n * itemsize);
        PyBuffer_Release(&b);
        return NULL;
    }
    void *out = malloc(n * itemsize > 0 ? n * itemsize : 1);
    if (out) memcpy(out, b.buf, n * itemsize);
    PyBuffer_Release(&b);
    if (!out) PyErr_NoMemory();
    return out;
}

static PyObject *ground_plan(PyObject *self, PyObject *args) {
    Py_ssize_t nj, nq, nv, nc, nshared, ndirs;
    long long max_points;
    double depth_weight, shared;
    PyObject *o[15];
    if (!PyArg_ParseTuple(args, "nnnnnnLddOOOOOOOOOOOOOOO", &nj, &nq, &nv, &nc, &nshared, &ndirs,
                          &max_points, &depth_weight, &shared, &o[0], &o[1], &o[2], &o[3],
                          &o[4], &o[5], &o[6], &o[7], &o[8], &o[9], &o[10], &o[11], &o[12],
                          &o[13], &o[14]))
        return NULL;
    Plan *p = calloc(1, sizeof(Plan));
    if (!p) return PyErr_NoMemory();
    p->nj = nj, p->nq = nq, p->nv = nv, p->nc = nc, p->nshared = nshared, p->ndirs = ndirs;
    p->max_points = max_points, p->depth_weight = depth_weight, p->shared = shared;
    PyObject *capsule = PyCapsule_New(p, "humanoid.ground_plan", plan_free);
    if (!capsule) {
        free(p);
        return NULL;
    }
    const Py_ssize_t L = sizeof(long long), D = sizeof(double);
    if (!(p->parent = copy_buffer(o[0], nj, L, "parent")) ||
        !(p->kind = copy_buffer(o[1], nj, L, "kind")) ||
        !(p->iq = copy_buffer(o[2], nj, L, "iq")) || !(p->iv = copy_buffer(o[3], nj, L, "iv")) ||
        !(p->axis = copy_buffer(o[4], 3 * nj, D, "axis")) ||
        !(p->place = copy_buffer(o[5], 12 * nj, D, "place")) ||
        !(p->cjoint = copy_buffer(o[6], nc, L, "cjoint")) ||
        !(p->ckind = copy_buffer(o[7], nc, L, "ckind")) ||
        !(p->cshape = copy_buffer(o[8], nc, L, "cshape")) ||
        !(p->clocal = copy_buffer(o[9], 3 * nc, D, "clocal")) ||
        !(p->cradius = copy_buffer(o[10], nc, D, "cradius")) ||
        !(p->caxis = copy_buffer(o[11], 3 * nc, D, "caxis")) ||
        !(p->spa = copy_buffer(o[12], nshared, L, "spa")) ||
        !(p->spb = copy_buffer(o[13], nshared, L, "spb")) ||
        !(p->dirs = copy_buffer(o[14], 2 * ndirs, D, "dirs"))) {
        Py_DECREF(capsule);
        return NULL;
    }
    p->oR = malloc(9 * nj * D), p->ot = malloc(3 * nj * D);
    p->world = malloc((3 * nc + 1) * D), p->keep = malloc(nc + 1);
    p->rows = malloc((nc + 1) * sizeof(Py_ssize_t));
    if (!p->oR || !p->ot || !p->world || !p->keep || !p->rows) {
        Py_DECREF(capsule);
        return PyErr_NoMemory();
    }
    return capsule;
}

/* C = A B, 3x3 row-major */
static void mat3(const double *A, const double *B, double *C) {
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* y = A x, 3x3 row-major */
static void mv3(const double *A, const double *x, double *y) {
    for (int i = 0; i < 3; ++i) y[i] = A[3 * i] * x[0] + A[3 * i + 1] * x[1] + A[3 * i + 2] * x[2];
}

/* a unit quaternion (x, y, z, w) as a rotation (Eigen's formula, as Pinocchio's) */
static void quat_rot(const double *q, double *R) {
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    const double tx = 2 * x, ty = 2 * y, tz = 2 * z;
    const double twx = tx * w, twy = ty * w, twz = tz * w, txx = tx * x, txy = ty * x,
                 txz = tz * x, tyy = ty * y, tyz = tz * y, tzz = tz * z;
    R[0] = 1 - (tyy + tzz), R[1] = txy - twz, R[2] = txz + twy;
    R[3] = txy + twz, R[4] = 1 - (txx + tzz), R[5] = tyz - twx;
    R[6] = txz - twy, R[7] = tyz + twx, R[8] = 1 - (txx + tyy);
}

/* the rotation of angle (cos c, sin s) about the unit axis a */
static void axis_rot(const double *a, double c, double s, double *R) {
    const double t = 1 - c;
    R[0] = c + t * a[0] * a[0], R[1] = t * a[0] * a[1] - s * a[2], R[2] = t * a[0] * a[2] + s * a[1];
    R[3] = t * a[0] * a[1] + s * a[2], R[4] = c + t * a[1] * a[1], R[5] = t * a[1] * a[2] - s * a[0];
    R[6] = t * a[0] * a[2] - s * a[1], R[7] = t * a[1] * a[2] + s * a[0], R[8] = c + t * a[2] * a[2];
}

/* every joint's placement from q */
static void kinematics(Plan *p, const double *q) {
    memset(p->oR, 0, 9 * sizeof(double));
    p->oR[0] = p->oR[4] = p->oR[8] = 1.0;
    memset(p->ot, 0, 3 * sizeof(double));
    for (Py_ssize_t j = 1; j < p->nj; ++j) {
        const double *P = p->place + 12 * j, *a = p->axis + 3 * j, *qj = q + p->iq[j];
        const double *Rp = p->oR + 9 * p->parent[j], *tp = p->ot + 3 * p->parent[j];
        double Rl[9], tl[3] = {0, 0, 0}, Rpp[9], tpp[3];
        /* the parent's placement times the joint's placement */
        mat3(Rp, P, Rpp);
        mv3(Rp, P + 9, tpp);
        for (int i = 0; i < 3; ++i) tpp[i] += tp[i];
        switch (p->kind[j]) {
        case J_FREE:
            quat_rot(qj + 3, Rl);
            tl[0] = qj[0], tl[1] = qj[1], tl[2] = qj[2];
            break;
        case J_BALL:
            quat_rot(qj, Rl);
            break;
        case J_REVOLUTE:
            axis_rot(a, cos(qj[0]), sin(qj[0]), Rl);
            break;
        case J_UNBOUNDED:
            axis_rot(a, qj[0], qj[1], Rl);
            break;
        default: /* J_PRISMATIC */
            memset(Rl, 0, sizeof(Rl));
            Rl[0] = Rl[4] = Rl[8] = 1.0;
            tl[0] = a[0] * qj[0], tl[1] = a[1] * qj[0], tl[2] = a[2] * qj[0];
        }
        double *R = p->oR + 9 * j, *t = p->ot + 3 * j, u[3];
        mat3(Rpp, Rl, R);
        mv3(Rpp, tl, u);
        for (int i = 0; i < 3; ++i) t[i] = tpp[i] + u[i];
    }
}

static void cross(const double *a, const double *b, double *c) {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* the three rows (x, y, z) of the velocity of the world point x on joint j: columns of every
 * joint from j to the root; J is (3, nv) row-major, zero on entry */
static void point_rows(const Plan *p, Py_ssize_t j, const double *x, double *J) {
    const Py_ssize_t nv = p->nv;
    for (Py_ssize_t k = j; k > 0; k = p->parent[k]) {
        const double *R = p->oR + 9 * k, *t = p->ot + 3 * k;
        const double r[3] = {x[0] - t[0], x[1] - t[1], x[2] - t[2]};
        const long long v = p->iv[k];
        double a[3], c[3];
        switch (p->kind[k]) {
        case J_FREE: /* the base's linear velocity (its frame), then its angular */
            for (int i = 0; i < 3; ++i) {
                a[0] = R[i], a[1] = R[3 + i], a[2] = R[6 + i];
                J[v + i] = a[0], J[nv + v + i] = a[1], J[2 * nv + v + i] = a[2];
                cross(a, r, c);
                J[v + 3 + i] = c[0], J[nv + v + 3 + i] = c[1], J[2 * nv + v + 3 + i] = c[2];
            }
            break;
        case J_BALL: /* the angular velocity in the joint's frame */
            for (int i = 0; i < 3; ++i) {
                a[0] = R[i], a[1] = R[3 + i], a[2] = R[6 + i];
                cross(a, r, c);
                J[v + i] = c[0], J[nv + v + i] = c[1], J[2 * nv + v + i] = c[2];
            }
            break;
        case J_PRISMATIC:
            mv3(R, p->axis + 3 * k, a);
            J[v] = a[0], J[nv + v] = a[1], J[2 * nv + v] = a[2];
            break;
        default: /* revolute, bounded or not */
            mv3(R, p->axis + 3 * k, a);
            cross(a, r, c);
            J[v] = c[0], J[nv + v] = c[1], J[2 * nv + v] = c[2];
        }
    }
}

/* the kept rows lo..hi (one shape's) reduced to their support polygon's extremes in place
 * (ground.py: _extremes); returns how many are left */
static Py_ssize_t extremes(const Plan *p, Py_ssize_t *rows, Py_ssize_t m) {
    const double *w = p->world;
    Py_ssize_t low = 0;
    for (Py_ssize_t i = 1; i < m; ++i)
        if (w[3 * rows[i] + 2] < w[3 * rows[low] + 2]) low = i;
    const double zmin = w[3 * rows[low] + 2];
    unsigned char pick[m];
    memset(pick, 0, m);
    pick[low] = 1;
    for (Py_ssize_t k = 0; k < p->ndirs; ++k) {
        const double c = p->dirs[2 * k], s = p->dirs[2 * k + 1];
        Py_ssize_t best = 0;
        double top = -INFINITY;
        for (Py_ssize_t i = 0; i < m; ++i) {
            const double *x = w + 3 * rows[i];
            const double score = (x[0] * c + x[1] * s) - p->depth_weight * (x[2] - zmin);
            if (score > top) top = score, best = i;
        }
        pick[best] = 1;
    }
    Py_ssize_t n = 0;
    for (Py_ssize_t i = 0; i < m; ++i)
        if (pick[i]) rows[n++] = rows[i];
    return n;
}

/* which candidates are contacts (in p->rows); returns how many */
static Py_ssize_t select_points(Plan *p, const double *q, double margin) {
    kinematics(p, q);
    double *w = p->world;
    for (Py_ssize_t r = 0; r < p->nc; ++r) {
        const long long j = p->cjoint[r];
        const double *R = p->oR + 9 * j, *t = p->ot + 3 * j;
        double *x = w + 3 * r;
        mv3(R, p->clocal + 3 * r, x);
        for (int i = 0; i < 3; ++i) x[i] += t[i];
        int ok = 1;
        if (p->ckind[r] == C_SPHERE) {
            x[2] -= p->cradius[r];
        } else if (p->ckind[r] == C_RIM) { /* down - (down . axis) axis, down = (0, 0, -1) */
            double a[3], d[3];
            mv3(R, p->caxis + 3 * r, a);
            d[0] = a[2] * a[0], d[1] = a[2] * a[1], d[2] = a[2] * a[2] - 1.0;
            const double norm = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            ok = norm > 1e-9; /* a rim lying flat: its samples are fixed points */
            if (ok)
                for (int i = 0; i < 3; ++i) x[i] += p->cradius[r] / norm * d[i];
        }
        p->keep[r] = ok && x[2] < margin;
    }
    for (Py_ssize_t k = 0; k < p->nshared; ++k) {
        const double *a = w + 3 * p->spa[k], *b = w + 3 * p->spb[k];
        const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
        if (sqrt(dx * dx + dy * dy + dz * dz) < p->shared) p->keep[p->spa[k]] = 0;
    }
    Py_ssize_t n = 0;
    for (Py_ssize_t r = 0; r < p->nc; ++r)
        if (p->keep[r]) p->rows[n++] = r;
    /* a shape with more kept points than max_points keeps its support polygon's extremes
     * (the candidates are sorted by shape: each shape's rows are contiguous) */
    Py_ssize_t out = 0;
    for (Py_ssize_t lo = 0; lo < n;) {
        Py_ssize_t hi = lo;
        while (hi < n && p->cshape[p->rows[hi]] == p->cshape[p->rows[lo]]) ++hi;
        Py_ssize_t m = hi - lo;
        if (m > p->max_points) m = extremes(p, p->rows + lo, m);
        memmove(p->rows + out, p->rows + lo, m * sizeof(Py_ssize_t));
        out += m, lo = hi;
    }
    return out;
}

static int writable(PyObject *obj, Py_buffer *b, Py_ssize_t bytes, const char *name) {
    if (PyObject_GetBuffer(obj, b, PyBUF_C_CONTIGUOUS | PyBUF_WRITABLE) < 0) return 0;
    if (b->len < bytes) {
        PyErr_Format(PyExc_ValueError, "humanoid.kernels: %s has %zd bytes, needs %zd", name,
                     b->len, bytes);
        PyBuffer_Release(b);
        return 0;
    }
    return 1;
}

static PyObject *ground_select(PyObject *self, PyObject *args) {
    PyObject *capsule, *oq;
    double margin;
    if (!PyArg_ParseTuple(args, "OOd", &capsule, &oq, &margin)) return NULL;
    Plan *p = (Plan *)PyCapsule_GetPointer(capsule, "humanoid.ground_plan");
    if (!p) return NULL;
    Py_buffer q;
    if (PyObject_GetBuffer(oq, &q, PyBUF_C_CONTIGUOUS) < 0) return NULL;
    if (q.len < (Py_ssize_t)sizeof(double) * p->nq) {
        PyErr_Format(PyExc_ValueError, "ground_select: q has %zd bytes, needs %zd", q.len,
                     (Py_ssize_t)sizeof(double) * p->nq);
        PyBuffer_Release(&q);
        return NULL;
    }
    p->n = select_points(p, (const double *)q.buf, margin);
    PyBuffer_Release(&q);
    return PyLong_FromSsize_t(p->n);
}

static PyObject *ground_write(PyObject *self, PyObject *args) {
    PyObject *capsule, *opoints, *ojoints, *olocal, *oJ, *oids;
    if (!PyArg_ParseTuple(args, "OOOOOO", &capsule, &opoints, &ojoints, &olocal, &oJ, &oids))
        return NULL;
    Plan *p = (Plan *)PyCapsule_GetPointer(capsule, "humanoid.ground_plan");
    if (!p) return NULL;
    const Py_ssize_t n = p->n, D = sizeof(double);
    Py_buffer points, joints, local, J, ids;
    if (!writable(oids, &ids, n * (Py_ssize_t)sizeof(long long), "ids")) return NULL;
    for (Py_ssize_t i = 0; i < n; ++i) ((long long *)ids.buf)[i] = p->rows[i];
    PyBuffer_Release(&ids);
    if (!writable(opoints, &points, 3 * n * D, "points")) return NULL;
    if (!writable(ojoints, &joints, n * (Py_ssize_t)sizeof(long long), "joints")) {
        PyBuffer_Release(&points);
        return NULL;
    }
    if (!writable(olocal, &local, 3 * n * D, "local")) {
        PyBuffer_Release(&points), PyBuffer_Release(&joints);
        return NULL;
    }
    if (!writable(oJ, &J, 3 * n * p->nv * D, "J")) {
        PyBuffer_Release(&points), PyBuffer_Release(&joints), PyBuffer_Release(&local);
        return NULL;
    }
    double *P = points.buf, *Lc = local.buf, *Jb = J.buf;
    long long *Jt = joints.buf;
    memset(Jb, 0, 3 * n * p->nv * D);
    for (Py_ssize_t i = 0; i < n; ++i) {
        const Py_ssize_t r = p->rows[i];
        const long long j = p->cjoint[r];
        const double *x = p->world + 3 * r, *R = p->oR + 9 * j, *t = p->ot + 3 * j;
        P[3 * i] = x[0], P[3 * i + 1] = x[1], P[3 * i + 2] = x[2];
        Jt[i] = j;
        const double d[3] = {x[0] - t[0], x[1] - t[1], x[2] - t[2]};
        for (int k = 0; k < 3; ++k) Lc[3 * i + k] = R[k] * d[0] + R[3 + k] * d[1] + R[6 + k] * d[2];
        point_rows(p, j, x, Jb + 3 * i * p->nv);
    }
    PyBuffer_Release(&points), PyBuffer_Release(&joints), PyBuffer_Release(&local);
    PyBuffer_Release(&J);
    Py_RETURN_NONE;
}

/* ---- joint ranges (limits.py: JointRanges.rows) ----------------------------------------- */

typedef struct {
    Py_ssize_t nv, nh, nb;
    double lock; /* |cos(middle angle)| below this: the outer angles are undefined */
    Py_ssize_t nq; /* the length of q its rows read */
    long long *hq, *hv, *bq, *bv;
    double *hlo, *hhi;          /* the hinges' limits */
    double *blo, *bhi, *bmid;   /* each ball's triplet angles' limits and their middle: nb x 3 */
    double *W;                  /* nb x 5 x 16: the rotation entries the angles read, from q q^T */
    double *s;                  /* nb: the sign of the triplet's axes' determinant */
    double *GCt;                /* nb x 3 x 3 */
} Ranges;

static void ranges_free(PyObject *capsule) {
    Ranges *p = (Ranges *)PyCapsule_GetPointer(capsule, "humanoid.range_plan");
    if (!p) return;
    void *fields[] = {p->hq, p->hv, p->bq, p->bv, p->hlo, p->hhi, p->blo, p->bhi, p->bmid,
                      p->W, p->s, p->GCt};
    for (size_t k = 0; k < sizeof(fields) / sizeof(fields[0]); ++k) free(fields[k]);
    free(p);
}

static PyObject *range_plan(PyObject *self, PyObject *args) {
    Py_ssize_t nv, nh, nb;
    double lock;
    PyObject *o[12];
    if (!PyArg_ParseTuple(args, "nnndOOOOOOOOOOOO", &nv, &nh, &nb, &lock, &o[0], &o[1], &o[2],
                          &o[3], &o[4], &o[5], &o[6], &o[7], &o[8], &o[9], &o[10], &o[11]))
        return NULL;
    Ranges *p = calloc(1, sizeof(Ranges));
    if (!p) return PyErr_NoMemory();
    p->nv = nv, p->nh = nh, p->nb = nb, p->lock = lock;
    PyObject *capsule = PyCapsule_New(p, "humanoid.range_plan", ranges_free);
    if (!capsule) {
        free(p);
        return NULL;
    }
    const Py_ssize_t L = sizeof(long long), D = sizeof(double);
    if (!(p->hq = copy_buffer(o[0], nh, L, "hq")) || !(p->hv = copy_buffer(o[1], nh, L, "hv")) ||
        !(p->hlo = copy_buffer(o[2], nh, D, "hlo")) ||
        !(p->hhi = copy_buffer(o[3], nh, D, "hhi")) ||
        !(p->bq = copy_buffer(o[4], nb, L, "bq")) || !(p->bv = copy_buffer(o[5], nb, L, "bv")) ||
        !(p->blo = copy_buffer(o[6], 3 * nb, D, "blo")) ||
        !(p->bhi = copy_buffer(o[7], 3 * nb, D, "bhi")) ||
        !(p->bmid = copy_buffer(o[8], 3 * nb, D, "bmid")) ||
        !(p->W = copy_buffer(o[9], 80 * nb, D, "W")) ||
        !(p->s = copy_buffer(o[10], nb, D, "s")) ||
        !(p->GCt = copy_buffer(o[11], 9 * nb, D, "GCt"))) {
        Py_DECREF(capsule);
        return NULL;
    }
    for (Py_ssize_t k = 0; k < nh; ++k)
        if (p->hq[k] + 1 > p->nq) p->nq = p->hq[k] + 1;
    for (Py_ssize_t b = 0; b < nb; ++b)
        if (p->bq[b] + 4 > p->nq) p->nq = p->bq[b] + 4;
    return capsule;
}

/* x wrapped into [-pi, pi), as NumPy's (x + pi) % (2 pi) - pi */
static double wrap(double x) {
    const double m = 2 * PI;
    double r = fmod(x + PI, m);
    if (r != 0 && r < 0) r += m;
    return r - PI;
}

/* one ball's triplet angles th (3) from q, the solution inside its range (limits.py: _angles);
 * hint: the last angles or NULL */
static void ball_angles(const Ranges *p, Py_ssize_t b, const double *q, const double *hint,
                        double *th) {
    const double *x = q + p->bq[b], *W = p->W + 80 * b;
    double qq[16], w[5];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) qq[4 * i + j] = x[i] * x[j];
    for (int e = 0; e < 5; ++e) {
        double acc = 0;
        for (int k = 0; k < 16; ++k) acc += W[16 * e + k] * qq[k];
        w[e] = acc;
    }
    const double w0 = w[0] < -1 ? -1 : (w[0] > 1 ? 1 : w[0]);
    const double abc[3] = {atan2(-w[1], w[2]), asin(w0), atan2(-w[3], w[4])};
    double both[2][3], d[2] = {0.0, 1.0};
    int inside[2] = {1, 1};
    const double *lo = p->blo + 3 * b, *hi = p->bhi + 3 * b, *mid = p->bmid + 3 * b;
    for (int sol = 0; sol < 2; ++sol) {
        if (hint) d[sol] = 0;
        for (int a = 0; a < 3; ++a) {
            const double flip = (sol == 1 && a == 1) ? -1.0 : 1.0, shift = sol ? PI : 0.0;
            double v = p->s[b] * (abc[a] * flip + shift);
            v = mid[a] + wrap(v - mid[a]);
            both[sol][a] = v;
            if (!(v >= lo[a] - 1e-12 && v <= hi[a] + 1e-12)) inside[sol] = 0;
            if (hint) d[sol] += fabs(wrap(v - hint[3 * b + a]));
        }
    }
    const int pick = (inside[1] && !inside[0]) || ((inside[0] == inside[1]) && (d[1] < d[0]));
    for (int a = 0; a < 3; ++a) th[a] = both[pick][a];
}

static PyObject *range_rows(PyObject *self, PyObject *args) {
    PyObject *capsule, *oq, *ohint, *or, *oJ, *oids;
    double margin;
    int has_hint;
    if (!PyArg_ParseTuple(args, "OOdOpOOO", &capsule, &oq, &margin, &ohint, &has_hint, &or, &oJ,
                          &oids))
        return NULL;
    Ranges *p = (Ranges *)PyCapsule_GetPointer(capsule, "humanoid.range_plan");
    if (!p) return NULL;
    const Py_ssize_t nv = p->nv, rows = 2 * p->nh + 6 * p->nb, D = sizeof(double);
    Py_buffer q, hint, r, J, idb;
    if (!writable(oids, &idb, rows * (Py_ssize_t)sizeof(long long), "ids")) return NULL;
    long long *ids = idb.buf;
    if (PyObject_GetBuffer(oq, &q, PyBUF_C_CONTIGUOUS) < 0) {
        PyBuffer_Release(&idb);
        return NULL;
    }
    if (q.len < (Py_ssize_t)sizeof(double) * p->nq) {
        PyErr_SetString(PyExc_ValueError, "range_rows: q is shorter than the model's");
        PyBuffer_Release(&idb), PyBuffer_Release(&q);
        return NULL;
    }
    if (!writable(ohint, &hint, 3 * p->nb * D, "hint")) {
        PyBuffer_Release(&idb), PyBuffer_Release(&q);
        return NULL;
    }
    if (!writable(or, &r, rows * D, "r")) {
        PyBuffer_Release(&idb), PyBuffer_Release(&q), PyBuffer_Release(&hint);
        return NULL;
    }
    if (!writable(oJ, &J, rows * nv * D, "J")) {
        PyBuffer_Release(&idb), PyBuffer_Release(&q), PyBuffer_Release(&hint);
        PyBuffer_Release(&r);
        return NULL;
    }
    const double *x = q.buf;
    double *h = hint.buf, *R = r.buf, *Jb = J.buf;
    Py_ssize_t m = 0;
    for (int side = 0; side < 2; ++side) /* every hinge's lower bound, then every upper */
        for (Py_ssize_t k = 0; k < p->nh; ++k) {
            const double v = side ? -(x[p->hq[k]] - p->hhi[k]) : x[p->hq[k]] - p->hlo[k];
            if (!(v < margin)) continue;
            R[m] = v, ids[m] = side * p->nh + k;
            memset(Jb + m * nv, 0, nv * D);
            Jb[m * nv + p->hv[k]] = side ? -1.0 : 1.0;
            ++m;
        }
    for (Py_ssize_t b = 0; b < p->nb; ++b) {
        double th[3];
        ball_angles(p, b, x, has_hint ? h : NULL, th);
        memcpy(h + 3 * b, th, sizeof(th));
    }
    for (Py_ssize_t b = 0; b < p->nb; ++b) {
        const double *th = h + 3 * b, *lo = p->blo + 3 * b, *hi = p->bhi + 3 * b;
        const int locked = fabs(cos(th[1])) < p->lock;
        const double sb = p->s[b] * th[1], sc_ = p->s[b] * th[2];
        const double cb = locked ? 1.0 : cos(sb), cc = cos(sc_), sc = sin(sc_), tb = sin(sb) / cb;
        const double E[9] = {cc / cb, -sc / cb, 0, sc, cc, 0, -tb * cc, tb * sc, 1.0};
        double rates[9];
        mat3(E, p->GCt + 9 * b, rates);
        for (int i = 0; i < 3; ++i)
            for (int side = 0; side < 2; ++side) {
                const double dist = side ? hi[i] - th[i] : th[i] - lo[i];
                if (!(dist < margin) || (locked && i != 1)) continue;
                const double sgn = side ? -1.0 : 1.0;
                R[m] = dist, ids[m] = 2 * p->nh + 6 * b + 2 * i + side;
                memset(Jb + m * nv, 0, nv * D);
                for (int k = 0; k < 3; ++k) Jb[m * nv + p->bv[b] + k] = sgn * rates[3 * i + k];
                ++m;
            }
    }
    PyBuffer_Release(&q), PyBuffer_Release(&hint), PyBuffer_Release(&r), PyBuffer_Release(&J);
    PyBuffer_Release(&idb);
    return PyLong_FromSsize_t(m);
}

/* ---- the contact solve (ground.py: ContactSolver, solver "compiled") --------------------- */

/* the lower Cholesky factor of the m x m symmetric positive definite A, in place (row-major);
 * 0 if A is not positive definite */
static int cholesky(double *A, Py_ssize_t m) {
    for (Py_ssize_t j = 0; j < m; ++j) {
        double *Aj = A + j * m, s = Aj[j];
        for (Py_ssize_t k = 0; k < j; ++k) s -= Aj[k] * Aj[k];
        if (!(s > 0)) return 0;
        s = sqrt(s);
        Aj[j] = s;
        for (Py_ssize_t i = j + 1; i < m; ++i) {
            double *Ai = A + i * m, t = Ai[j];
            for (Py_ssize_t k = 0; k < j; ++k) t -= Ai[k] * Aj[k];
            Ai[j] = t / s;
        }
    }
    return 1;
}

/* x = (L L^T)^-1 x, in place */
static void cholesky_solve(const double *L, Py_ssize_t m, double *x) {
    for (Py_ssize_t i = 0; i < m; ++i) {
        const double *Li = L + i * m;
        double t = x[i];
        for (Py_ssize_t k = 0; k < i; ++k) t -= Li[k] * x[k];
        x[i] = t / Li[i];
    }
    for (Py_ssize_t i = m - 1; i >= 0; --i) {
        double t = x[i];
        for (Py_ssize_t k = i + 1; k < m; ++k) t -= L[k * m + i] * x[k];
        x[i] = t / L[i * m + i];
    }
}

/* y = A x + b, A m x m row-major */
static void affine(const double *A, const double *x, const double *b, Py_ssize_t m, double *y) {
    for (Py_ssize_t i = 0; i < m; ++i) {
        const double *Ai = A + i * m;
        double t = b[i];
        for (Py_ssize_t k = 0; k < m; ++k) t += Ai[k] * x[k];
        y[i] = t;
    }
}

/* the first nc triplets (tangent x, y, normal) projected on the friction cone |t| <= mu n, the
 * rest on the non-negative orthant */
static void project(double *x, Py_ssize_t m, Py_ssize_t nc, double mu) {
    for (Py_ssize_t c = 0; c < nc; ++c) {
        double *t = x + 3 * c;
        const double tn = sqrt(t[0] * t[0] + t[1] * t[1]), n = t[2];
        if (tn <= mu * n) continue;
        if (mu * tn <= -n) {
            t[0] = t[1] = t[2] = 0.0;
            continue;
        }
        const double beta = (mu * tn + n) / (mu * mu + 1.0);
        t[0] *= mu * beta / tn, t[1] *= mu * beta / tn, t[2] = beta;
    }
    for (Py_ssize_t i = 3 * nc; i < m; ++i)
        if (x[i] < 0) x[i] = 0.0;
}

/* sigma = G z + g, and s: the De Saxce correction mu |sigma_t| on each contact's normal row */
static void velocities(const double *G, const double *g, const double *z, Py_ssize_t m,
                       Py_ssize_t nc, double mu, double *sigma, double *s) {
    affine(G, z, g, m, sigma);
    memset(s, 0, m * sizeof(double));
    for (Py_ssize_t c = 0; c < nc; ++c) {
        const double *t = sigma + 3 * c;
        s[3 * c + 2] = mu * sqrt(t[0] * t[0] + t[1] * t[1]);
    }
}

/* how far z (in the cones) is from solving the problem: the natural residual
 * |z - P_K(z - (sigma + s))|_inf, zero exactly at a solution; on a contact that sticks it is
 * its velocity, on one that slides its impulse's distance from the cone's edge against the
 * slip, on an orthant row min(z, sigma) (the rows are scaled: impulses and velocities alike) */
static double ncp_residual(const double *z, const double *sigma, const double *s, Py_ssize_t m,
                           Py_ssize_t nc, double mu) {
    double worst = 0.0;
    for (Py_ssize_t c = 0; c < nc; ++c) {
        const double *zc = z + 3 * c, *sc = sigma + 3 * c;
        double w[3] = {zc[0] - sc[0], zc[1] - sc[1], zc[2] - (sc[2] + s[3 * c + 2])};
        project(w, 3, 1, mu);
        for (int i = 0; i < 3; ++i)
            if (fabs(zc[i] - w[i]) > worst) worst = fabs(zc[i] - w[i]);
    }
    for (Py_ssize_t i = 3 * nc; i < m; ++i) {
        const double r = fabs(z[i] < sigma[i] ? z[i] : sigma[i]);
        if (r > worst) worst = r;
    }
    return worst;
}

/* L = cholesky(G + rho I) */
static int factor(const double *G, Py_ssize_t m, double rho, double *L) {
    memcpy(L, G, m * m * sizeof(double));
    for (Py_ssize_t i = 0; i < m; ++i) L[i * m + i] += rho;
    return cholesky(L, m);
}

/* ADMM on the nonlinear complementarity problem of the contacts (Coulomb's cones with the De
 * Saxce correction, and orthant rows): lambda in K, sigma = G lambda + g, sigma + s(sigma) in K*
 * and complementary to lambda. Written as the fixed point of w = x + u (the point projected):
 * z = P_K(w), u = w - z, s = s(G z + g), (G + rho I) x = rho (z - u) - g - s, over-relaxed
 * (x <- alpha x + (1 - alpha) z), T(w) = x + u; rho fixed (the rows are scaled to a unit
 * diagonal; balancing rho against the residuals stalled it on the falls), and Anderson
 * acceleration of memory mem on T (0: plain ADMM; its step is thrown away, and the memory,
 * when the fixed-point residual grows tenfold).
 * Stops when z's own residual (ncp_residual) is within tol: a warm start that already solves
 * the problem stops at once, and no other does. Or when the residual has not fallen by a tenth
 * in STALL iterations: then the best z, converged if its residual is within FLOOR tol. (A body
 * at rest on many points with a joint at its limit: rows that depend on each other with gap
 * terms that do not quite agree, a floor no iteration goes below; Pinocchio's ADMM stops
 * there too, by its own residuals.) z: the start (projected first), then the solution.
 * Returns the iterations, negative if it did not converge. */
#define ALPHA 1.6
#define STALL 30
#define FLOOR 100.0
#define MEM_MAX 8

/* Anderson's weights: gamma = argmin |f - dF gamma| (dF: n columns of length m, stored as
 * rows), by the regularised normal equations; 0 if they are singular */
static int anderson_weights(const double *dF, const double *f, Py_ssize_t n, Py_ssize_t m,
                            double *gamma) {
    double A[MEM_MAX * MEM_MAX], trace = 0.0;
    for (Py_ssize_t i = 0; i < n; ++i) {
        double b = 0.0;
        for (Py_ssize_t k = 0; k < m; ++k) b += dF[i * m + k] * f[k];
        gamma[i] = b;
        for (Py_ssize_t j = 0; j <= i; ++j) {
            double a = 0.0;
            for (Py_ssize_t k = 0; k < m; ++k) a += dF[i * m + k] * dF[j * m + k];
            A[i * n + j] = A[j * n + i] = a;
        }
        trace += A[i * n + i];
    }
    for (Py_ssize_t i = 0; i < n; ++i) A[i * n + i] += 1e-10 * trace + 1e-300;
    if (!cholesky(A, n)) return 0;
    cholesky_solve(A, n, gamma);
    return 1;
}

static long admm(const double *G, const double *g, Py_ssize_t m, Py_ssize_t nc, double mu,
                 double tol, long max_iter, double rho, int mem, double *z, double *work,
                 double *residual) {
    double *L = work, *x = L + m * m, *u = x + m, *s = u + m, *sigma = s + m, *best = sigma + m;
    double *w = best + m, *gk = w + m, *f = gk + m, *fp = f + m, *gp = fp + m, *dF = gp + m;
    double *dG = dF + MEM_MAX * m, gamma[MEM_MAX];
    if (mem > MEM_MAX) mem = MEM_MAX;
    project(z, m, nc, mu);
    velocities(G, g, z, m, nc, mu, sigma, s);
    double r = ncp_residual(z, sigma, s, m, nc, mu), rbest = r, rmark = r, fnorm_prev = 0.0;
    *residual = r;
    if (r <= tol) return 0;
    memcpy(best, z, m * sizeof(double));
    for (Py_ssize_t i = 0; i < m; ++i) w[i] = z[i] - (sigma[i] + s[i]) / rho;
    if (!factor(G, m, rho, L)) return -1;
    long k = 1, mark = 0;
    Py_ssize_t stored = 0, next = 0; /* Anderson's columns and the one to overwrite next */
    for (; k <= max_iter; ++k) {
        /* T(w): z, u, s from w; x; the new point */
        memcpy(z, w, m * sizeof(double));
        project(z, m, nc, mu);
        for (Py_ssize_t i = 0; i < m; ++i) u[i] = w[i] - z[i];
        velocities(G, g, z, m, nc, mu, sigma, s);
        if (k > 1) {
            r = ncp_residual(z, sigma, s, m, nc, mu);
            *residual = r;
            if (r <= tol) return k - 1;
            if (r < rbest) rbest = r, memcpy(best, z, m * sizeof(double));
            if (rbest < 0.9 * rmark) rmark = rbest, mark = k;
            if (k - mark >= STALL) break;
        }
        for (Py_ssize_t i = 0; i < m; ++i) x[i] = rho * (z[i] - u[i]) - g[i] - s[i];
        cholesky_solve(L, m, x);
        double fnorm = 0.0;
        for (Py_ssize_t i = 0; i < m; ++i) {
            gk[i] = ALPHA * x[i] + (1.0 - ALPHA) * z[i] + u[i];
            f[i] = gk[i] - w[i];
            if (fabs(f[i]) > fnorm) fnorm = fabs(f[i]);
        }
        if (mem > 0 && k > 1 && fnorm > 10 * fnorm_prev) stored = 0; /* a bad step: restart */
        if (mem > 0 && k > 1) {
            double *cF = dF + next * m, *cG = dG + next * m;
            for (Py_ssize_t i = 0; i < m; ++i) cF[i] = f[i] - fp[i], cG[i] = gk[i] - gp[i];
            next = (next + 1) % mem;
            if (stored < mem) ++stored;
        }
        memcpy(fp, f, m * sizeof(double));
        memcpy(gp, gk, m * sizeof(double));
        fnorm_prev = fnorm;
        memcpy(w, gk, m * sizeof(double));
        if (stored > 0 && anderson_weights(dF, f, stored, m, gamma))
            for (Py_ssize_t j = 0; j < stored; ++j)
                for (Py_ssize_t i = 0; i < m; ++i) w[i] -= gamma[j] * dG[j * m + i];
    }
    memcpy(z, best, m * sizeof(double));
    *residual = rbest;
    if (k <= max_iter && rbest <= FLOOR * tol) return k;
    return -(k > max_iter ? max_iter : k);
}

/* the problem on the rows idx[0 .. mk) of J (the first 3 nck of them the kept contacts'
 * triplets, whole): J Minv and the Delassus matrix over each row's nonzero columns
 * (nz[start[i] .. start[i + 1])), Jacobi scaling (one factor per contact, its cone unchanged),
 * ADMM from lam[idx] (then the impulses there); vo = v_free + Minv J^T lam over those rows.
 * buf: nv mk + 2 mk^2 + (14 + 2 MEM_MAX) mk doubles. Returns admm's count. */
static long solve_rows(const double *Jb, Py_ssize_t nv, const Py_ssize_t *nz,
                       const Py_ssize_t *start, const double *Mb, const double *vf,
                       const double *gall, const Py_ssize_t *idx, Py_ssize_t mk, Py_ssize_t nck,
                       double mu, double tol, long max_iter, double rho, int mem, double *lam,
                       double *vo, double *buf, double *residual) {
    double *JM = buf, *G = JM + nv * mk, *g = G + mk * mk, *d = g + mk, *z = d + mk;
    double *work = z + mk;
    memset(JM, 0, nv * mk * sizeof(double));
    for (Py_ssize_t a = 0; a < mk; ++a) { /* JM = J Minv, its rows contiguous (Minv symmetric) */
        const Py_ssize_t i = idx[a];
        const double *Ji = Jb + i * nv;
        double *JMa = JM + a * nv;
        for (Py_ssize_t c = start[i]; c < start[i + 1]; ++c) {
            const double s = Ji[nz[c]], *Mk = Mb + nz[c] * nv;
            for (Py_ssize_t r = 0; r < nv; ++r) JMa[r] += s * Mk[r];
        }
        g[a] = gall[i];
    }
    for (Py_ssize_t a = 0; a < mk; ++a) {
        const Py_ssize_t i = idx[a];
        const double *Ji = Jb + i * nv;
        for (Py_ssize_t b = 0; b <= a; ++b) {
            const double *JMb = JM + b * nv;
            double t = 0.0;
            for (Py_ssize_t c = start[i]; c < start[i + 1]; ++c) t += Ji[nz[c]] * JMb[nz[c]];
            G[a * mk + b] = G[b * mk + a] = t;
        }
    }
    double dmax = 0.0;
    for (Py_ssize_t a = 0; a < mk; ++a) {
        d[a] = G[a * mk + a];
        if (a < 3 * nck && a % 3 == 2) {
            const double mean = (d[a - 2] + d[a - 1] + d[a]) / 3.0;
            d[a - 2] = d[a - 1] = d[a] = mean;
        }
    }
    for (Py_ssize_t a = 0; a < mk; ++a)
        if (d[a] > dmax) dmax = d[a];
    for (Py_ssize_t a = 0; a < mk; ++a) d[a] = 1.0 / sqrt(d[a] > 1e-12 * dmax ? d[a] : 1e-12 * dmax);
    for (Py_ssize_t a = 0; a < mk; ++a) {
        g[a] *= d[a], z[a] = lam[idx[a]] / d[a];
        for (Py_ssize_t b = 0; b < mk; ++b) G[a * mk + b] *= d[a] * d[b];
    }
    const long k = mk ? admm(G, g, mk, nck, mu, tol, max_iter, rho, mem, z, work, residual) : 0;
    memcpy(vo, vf, nv * sizeof(double));
    for (Py_ssize_t a = 0; a < mk; ++a) {
        const double *JMa = JM + a * nv, s = z[a] * d[a];
        lam[idx[a]] = s;
        for (Py_ssize_t r = 0; r < nv; ++r) vo[r] += JMa[r] * s;
    }
    return k;
}

/* the solve of a step: J (m x nv, the contacts' 3 rows each first, then the orthant rows),
 * Minv, v_free, the rows' constant velocity terms gap; lam (m): the start (the last step's
 * impulses, or zero), then the impulses; v (nv): v_free + Minv J^T lam.
 * A contact whose free motion keeps its point off the floor by more than screen
 * (J_n v_free + gap > screen [m/s]: a speculative point within the margin that the step does
 * not bring down), and an orthant row likewise [rad/s], is left out of the solve with a zero
 * impulse; if the solved velocity then brings one of them through (J v + gap < 0: another
 * contact's impulse pushed it), the step is solved again with every row. A row left out is
 * one the solution does not load: the answer is the whole problem's. Returns (iterations,
 * converged, residual, rows left out, solved again). */
static PyObject *contact_solve(PyObject *self, PyObject *args) {
    PyObject *oJ, *oM, *ov, *ogap, *olam, *oout;
    Py_ssize_t nc;
    double mu, tol, rho;
    long max_iter;
    int mem;
    double screen;
    if (!PyArg_ParseTuple(args, "OOOOndddlidOO", &oJ, &oM, &ov, &ogap, &nc, &mu, &tol, &rho,
                          &max_iter, &mem, &screen, &olam, &oout))
        return NULL;
    Py_buffer J, M, v, gap, lam, out;
    if (PyObject_GetBuffer(oJ, &J, PyBUF_C_CONTIGUOUS) < 0) return NULL;
    if (PyObject_GetBuffer(oM, &M, PyBUF_C_CONTIGUOUS) < 0) {
        PyBuffer_Release(&J);
        return NULL;
    }
    const Py_ssize_t D = sizeof(double), nv = (Py_ssize_t)sqrt((double)(M.len / D) + 0.5);
    const Py_ssize_t m = nv ? J.len / D / nv : 0;
    int ok = PyObject_GetBuffer(ov, &v, PyBUF_C_CONTIGUOUS) == 0;
    ok = ok && (PyObject_GetBuffer(ogap, &gap, PyBUF_C_CONTIGUOUS) == 0 || (PyBuffer_Release(&v), 0));
    ok = ok && (writable(olam, &lam, m * D, "lam") || (PyBuffer_Release(&v), PyBuffer_Release(&gap), 0));
    ok = ok && (writable(oout, &out, nv * D, "v") ||
                (PyBuffer_Release(&v), PyBuffer_Release(&gap), PyBuffer_Release(&lam), 0));
    if (!ok) {
        PyBuffer_Release(&J), PyBuffer_Release(&M);
        return NULL;
    }
    if (v.len != nv * D || gap.len != m * D || 3 * nc > m) {
        PyErr_SetString(PyExc_ValueError, "contact_solve: the sizes of J, Minv, v and gap differ");
        PyBuffer_Release(&J), PyBuffer_Release(&M), PyBuffer_Release(&v);
        PyBuffer_Release(&gap), PyBuffer_Release(&lam), PyBuffer_Release(&out);
        return NULL;
    }
    const double *Jb = J.buf, *Mb = M.buf, *vf = v.buf, *gp = gap.buf;
    double *z = lam.buf, *vo = out.buf;
    double *buf = malloc((nv * m + 2 * m * m + (16 + 2 * MEM_MAX) * m + 1) * D);
    Py_ssize_t *nz = malloc((m * nv + 2 * m + 2) * sizeof(Py_ssize_t));
    if (!buf || !nz) {
        free(buf), free(nz);
        PyBuffer_Release(&J), PyBuffer_Release(&M), PyBuffer_Release(&v);
        PyBuffer_Release(&gap), PyBuffer_Release(&lam), PyBuffer_Release(&out);
        return PyErr_NoMemory();
    }
    /* each row's nonzero columns (a contact's row moves with its joint's path to the root
     * alone), and g = J v_free + gap over them */
    Py_ssize_t *start = nz + m * nv, *idx = start + m + 1;
    double *gall = buf, *rest = gall + m;
    start[0] = 0;
    for (Py_ssize_t i = 0; i < m; ++i) {
        Py_ssize_t c = start[i];
        double t = gp[i];
        for (Py_ssize_t k = 0; k < nv; ++k)
            if (Jb[i * nv + k] != 0.0) nz[c++] = k, t += Jb[i * nv + k] * vf[k];
        start[i + 1] = c, gall[i] = t;
    }
    Py_ssize_t mk = 0, nck = 0;
    for (Py_ssize_t c = 0; c < nc; ++c)
        if (gall[3 * c + 2] <= screen) idx[mk++] = 3 * c, idx[mk++] = 3 * c + 1, idx[mk++] = 3 * c + 2, ++nck;
        else z[3 * c] = z[3 * c + 1] = z[3 * c + 2] = 0.0;
    for (Py_ssize_t i = 3 * nc; i < m; ++i)
        if (gall[i] <= screen) idx[mk++] = i;
        else z[i] = 0.0;
    double residual = 0.0;
    long k = solve_rows(Jb, nv, nz, start, Mb, vf, gall, idx, mk, nck, mu, tol, max_iter, rho,
                        mem, z, vo, rest, &residual);
    int through = 0; /* a row left out that the solved velocity brings through */
    for (Py_ssize_t i = 0; i < m && mk < m && !through; ++i) {
        if ((i < 3 * nc && i % 3 != 2) || gall[i] <= screen) continue; /* a row left out */
        double s = gp[i];
        for (Py_ssize_t c = start[i]; c < start[i + 1]; ++c) s += Jb[i * nv + nz[c]] * vo[nz[c]];
        through = s < 0.0;
    }
    if (through) {
        for (Py_ssize_t i = 0; i < m; ++i) idx[i] = i;
        const long more = solve_rows(Jb, nv, nz, start, Mb, vf, gall, idx, m, nc, mu, tol,
                                     max_iter, rho, mem, z, vo, rest, &residual);
        const long total = labs(k) + labs(more);
        k = more < 0 ? -total : total;
    }
    free(buf), free(nz);
    PyBuffer_Release(&J), PyBuffer_Release(&M), PyBuffer_Release(&v);
    PyBuffer_Release(&gap), PyBuffer_Release(&lam), PyBuffer_Release(&out);
    return Py_BuildValue("(lidii)", k < 0 ? -k : k, k >= 0, residual, (int)(m - mk), through);
}

/* every joint's placement from q, into R (nj x 9) and t (nj x 3): for the tests */
static PyObject *placements(PyObject *self, PyObject *args) {
    PyObject *capsule, *oq, *oR, *ot;
    if (!PyArg_ParseTuple(args, "OOOO", &capsule, &oq, &oR, &ot)) return NULL;
    Plan *p = (Plan *)PyCapsule_GetPointer(capsule, "humanoid.ground_plan");
    if (!p) return NULL;
    Py_buffer q, R, t;
    if (PyObject_GetBuffer(oq, &q, PyBUF_C_CONTIGUOUS) < 0) return NULL;
    kinematics(p, (const double *)q.buf);
    PyBuffer_Release(&q);
    if (!writable(oR, &R, 9 * p->nj * (Py_ssize_t)sizeof(double), "R")) return NULL;
    if (!writable(ot, &t, 3 * p->nj * (Py_ssize_t)sizeof(double), "t")) {
        PyBuffer_Release(&R);
        return NULL;
    }
    memcpy(R.buf, p->oR, 9 * p->nj * sizeof(double));
    memcpy(t.buf, p->ot, 3 * p->nj * sizeof(double));
    PyBuffer_Release(&R), PyBuffer_Release(&t);
    Py_RETURN_NONE;
}

/* a joint's motion subspace in world axes about the world's origin, placed (oR, ot of j):
 * S (6 x nvj, column-major: each column angular then linear), returns nvj */
static int subspace(const Plan *p, Py_ssize_t j, double *S) {
    const double *R = p->oR + 9 * j, *o = p->ot + 3 * j;
    double a[3];
    int n = 0;
    switch (p->kind[j]) {
    case J_FREE: /* the body's twist in its own axes: linear, then angular */
        for (int i = 0; i < 3; ++i, ++n) {
            double *c = S + 6 * n;
            c[0] = c[1] = c[2] = 0.0;
            c[3] = R[i], c[4] = R[3 + i], c[5] = R[6 + i];
        }
        /* the angular columns: a ball's */
        /* fall through */
    case J_BALL:
        for (int i = 0; i < 3; ++i, ++n) {
            double *c = S + 6 * n;
            c[0] = R[i], c[1] = R[3 + i], c[2] = R[6 + i];
            cross(o, c, c + 3); /* the origin's velocity o x w */
        }
        return n;
    case J_PRISMATIC:
        mv3(R, p->axis + 3 * j, a);
        S[0] = S[1] = S[2] = 0.0, S[3] = a[0], S[4] = a[1], S[5] = a[2];
        return 1;
    default: /* revolute, bounded or not */
        mv3(R, p->axis + 3 * j, S);
        cross(o, S, S + 3);
        return 1;
    }
}

/* (w, v) x (w2, v2) for motion vectors, added to out: (w x w2, w x v2 + v x w2) */
static void motion_cross_add(const double *V, const double *U, double *out) {
    double c[3];
    cross(V, U, c);
    out[0] += c[0], out[1] += c[1], out[2] += c[2];
    cross(V, U + 3, c);
    out[3] += c[0], out[4] += c[1], out[5] += c[2];
    cross(V + 3, U, c);
    out[3] += c[0], out[4] += c[1], out[5] += c[2];
}

/* the forward recursion over the tree placed in p, about the origin in world axes: every
 * joint's velocity V (v), its acceleration A at the accelerations a under gravity g (A_0 minus
 * gravity; skipped if A is NULL) and at zero accelerations without gravity A0 (skipped if
 * NULL): V_j = V_parent + S v_j, A_j = A_parent + S a_j + V_j x S v_j */
static void forward(const Plan *p, const double *v, const double *a, const double *g, double *V,
                    double *A, double *A0) {
    double S[36];
    memset(V, 0, 6 * sizeof(double));
    if (A) {
        memset(A, 0, 6 * sizeof(double));
        A[3] = -g[0], A[4] = -g[1], A[5] = -g[2];
    }
    if (A0) memset(A0, 0, 6 * sizeof(double));
    for (Py_ssize_t j = 1; j < p->nj; ++j) {
        const Py_ssize_t par = p->parent[j];
        const long long iv = p->iv[j];
        const int n = subspace(p, j, S);
        double vj[6] = {0, 0, 0, 0, 0, 0}, *Vj = V + 6 * j;
        for (int c = 0; c < n; ++c)
            for (int i = 0; i < 6; ++i) vj[i] += S[6 * c + i] * v[iv + c];
        for (int i = 0; i < 6; ++i) Vj[i] = V[6 * par + i] + vj[i];
        if (A) {
            double *Aj = A + 6 * j;
            for (int i = 0; i < 6; ++i) Aj[i] = A[6 * par + i];
            for (int c = 0; c < n; ++c)
                for (int i = 0; i < 6; ++i) Aj[i] += S[6 * c + i] * a[iv + c];
            motion_cross_add(Vj, vj, Aj);
        }
        if (A0) {
            double *A0j = A0 + 6 * j;
            for (int i = 0; i < 6; ++i) A0j[i] = A0[6 * par + i];
            motion_cross_add(Vj, vj, A0j);
        }
    }
}

/* the joints' forces F (nj x 6, about the origin) summed from the leaves, each joint's share
 * S^T F written into tau (subtract: taken from it) */
static void backward(const Plan *p, double *F, double *tau, int subtract) {
    double S[36];
    for (Py_ssize_t j = p->nj - 1; j > 0; --j) {
        const Py_ssize_t par = p->parent[j];
        const int n = subspace(p, j, S);
        for (int c = 0; c < n; ++c) {
            double s = 0.0;
            for (int i = 0; i < 6; ++i) s += S[6 * c + i] * F[6 * j + i];
            tau[p->iv[j] + c] = subtract ? tau[p->iv[j] + c] - s : s;
        }
        if (par > 0)
            for (int i = 0; i < 6; ++i) F[6 * par + i] += F[6 * j + i];
    }
}

/* the body of joint j (In: mass, centre of mass in the joint's frame, inertia about it in the
 * joint's axes, row-major) placed at (Rj, oj): its mass, centre of mass and rotational inertia
 * about it in world axes */
static void body_world(const double *In, const double *Rj, const double *oj, double *c,
                       double *Ic) {
    double RI[9], RT[9];
    mv3(Rj, In + 1, c);
    c[0] += oj[0], c[1] += oj[1], c[2] += oj[2];
    mat3(Rj, In + 4, RI);
    for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) RT[3 * r + s] = Rj[3 * s + r];
    mat3(RI, RT, Ic);
}

/* the force F (moment about the origin, force; world axes) a body needs for the spatial
 * acceleration A (about the origin) at the velocity V: I A + V x* I V; V NULL: I A alone */
static void body_force(const double *In, const double *Rj, const double *oj, const double *V,
                       const double *A, double *F) {
    const double mass = In[0];
    double c[3], Ic[9], x[3], la[3];
    body_world(In, Rj, oj, c, Ic);
    const double *al = A, *aO = A + 3;
    cross(al, c, x); /* I A: m (aO + alpha x c), Ic alpha + c x it */
    for (int i = 0; i < 3; ++i) la[i] = mass * (aO[i] + x[i]);
    mv3(Ic, al, F);
    cross(c, la, x);
    for (int i = 0; i < 3; ++i) F[i] += x[i], F[3 + i] = la[i];
    if (!V) return;
    const double *wv = V, *vO = V + 3;
    double hl[3], ha[3];
    cross(wv, c, x); /* the momentum: m (vO + w x c), Ic w + c x it */
    for (int i = 0; i < 3; ++i) hl[i] = mass * (vO[i] + x[i]);
    mv3(Ic, wv, ha);
    cross(c, hl, x);
    for (int i = 0; i < 3; ++i) ha[i] += x[i];
    cross(wv, ha, x); /* V x* h: (w x ha + vO x hl, w x hl) */
    for (int i = 0; i < 3; ++i) F[i] += x[i];
    cross(vO, hl, x);
    for (int i = 0; i < 3; ++i) F[i] += x[i];
    cross(wv, hl, x);
    for (int i = 0; i < 3; ++i) F[3 + i] += x[i];
}

/* buffers' checks: each of n objects as a C-contiguous buffer of at least (exactly, if
 * exact[i]) bytes[i] bytes, writable if write[i]; returns how many were acquired (n when all
 * were, the Python error set otherwise) */
static int acquire(const char *who, int n, PyObject **objs, Py_buffer *b, const Py_ssize_t *bytes,
                   const int *exact, const int *write, const char **names) {
    for (int i = 0; i < n; ++i) {
        if (PyObject_GetBuffer(objs[i], &b[i], PyBUF_C_CONTIGUOUS | (write[i] ? PyBUF_WRITABLE : 0)) < 0)
            return i;
        if (exact[i] ? b[i].len != bytes[i] : b[i].len < bytes[i]) {
            PyErr_Format(PyExc_ValueError, "%s: %s has %zd bytes, needs %zd", who, names[i],
                         b[i].len, bytes[i]);
            return i + 1;
        }
    }
    return n;
}

/* every state's kinematics and inverse dynamics (RNEA) in world axes about the world origin:
 * V_j = V_parent + S q', A_j = A_parent + S q'' + V_j x S q' (A_0: minus gravity), the body's
 * force I A + V x* I V (I: its inertia about the origin), summed from the leaves */
static PyObject *tree_dynamics(PyObject *self, PyObject *args) {
    PyObject *capsule, *objs[11];
    Py_ssize_t N;
    if (!PyArg_ParseTuple(args, "OnOOOOOOOOOOO", &capsule, &N, &objs[0], &objs[1], &objs[2],
                          &objs[3], &objs[4], &objs[5], &objs[6], &objs[7], &objs[8], &objs[9],
                          &objs[10]))
        return NULL;
    Plan *p = (Plan *)PyCapsule_GetPointer(capsule, "humanoid.ground_plan");
    if (!p) return NULL;
    const Py_ssize_t nj = p->nj, nq = p->nq, nv = p->nv, D = sizeof(double);
    Py_buffer b[11];
    /* inertia, gravity, Q, V, A (exactly their sizes), then R, t, w, m, f, tau (written) */
    const Py_ssize_t bytes[11] = {13 * nj * D,     3 * D,          N * nq * D,     N * nv * D,
                                  N * nv * D,      N * 9 * nj * D, N * 3 * nj * D, N * 3 * nj * D,
                                  N * 3 * nj * D,  N * 3 * nj * D, N * nv * D};
    const int exact[11] = {1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0},
              write[11] = {0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1};
    const char *names[11] = {"inertia", "gravity", "Q", "V", "A", "R", "t", "w", "m", "f", "tau"};
    const int got = acquire("tree_dynamics", 11, objs, b, bytes, exact, write, names);
    double *scratch = got == 11 ? malloc(18 * nj * D) : NULL;
    if (got == 11 && !scratch) PyErr_NoMemory();
    if (scratch) {
        const double *I = b[0].buf, *g = b[1].buf;
        double *Vs = scratch, *As = scratch + 6 * nj, *Fs = scratch + 12 * nj;
        for (Py_ssize_t k = 0; k < N; ++k) {
            const double *q = (const double *)b[2].buf + k * nq;
            const double *qd = (const double *)b[3].buf + k * nv;
            const double *qdd = (const double *)b[4].buf + k * nv;
            double *R = (double *)b[5].buf + k * 9 * nj, *t = (double *)b[6].buf + k * 3 * nj;
            double *w = (double *)b[7].buf + k * 3 * nj, *m = (double *)b[8].buf + k * 3 * nj;
            double *f = (double *)b[9].buf + k * 3 * nj, *tau = (double *)b[10].buf + k * nv;
            kinematics(p, q);
            forward(p, qd, qdd, g, Vs, As, NULL);
            for (Py_ssize_t j = 1; j < nj; ++j)
                body_force(I + 13 * j, p->oR + 9 * j, p->ot + 3 * j, Vs + 6 * j, As + 6 * j,
                           Fs + 6 * j);
            backward(p, Fs, tau, 0); /* (each joint's F is then its subtree's) */
            for (Py_ssize_t j = 1; j < nj; ++j) {
                const double *F = Fs + 6 * j, *oj = p->ot + 3 * j;
                double x[3];
                cross(oj, F + 3, x); /* the moment about the joint's origin */
                for (int i = 0; i < 3; ++i) {
                    m[3 * j + i] = F[i] - x[i], f[3 * j + i] = F[3 + i];
                    w[3 * j + i] = Vs[6 * j + i];
                }
            }
            memcpy(R, p->oR, 9 * nj * D), memcpy(t, p->ot, 3 * nj * D);
            memset(m, 0, 3 * D), memset(f, 0, 3 * D), memset(w, 0, 3 * D);
        }
        free(scratch);
    }
    for (int i = 0; i < got; ++i) PyBuffer_Release(&b[i]);
    if (PyErr_Occurred()) return NULL;
    Py_RETURN_NONE;
}

/* ---- the welded walk's torques between its QP ticks (controller.py: held_torques) ------- */

/* the rotation log of R (row-major) into w; 0 if its angle is within 0.1 rad of pi, where
 * R - R^T loses the axis' digits (7e-12 of gamma's size at 3.1 rad; the caller falls back to
 * Pinocchio's log) */
static int log3(const double *R, double *w) {
    const double vx = R[7] - R[5], vy = R[2] - R[6], vz = R[3] - R[1];
    const double s = 0.5 * sqrt(vx * vx + vy * vy + vz * vz), c = 0.5 * (R[0] + R[4] + R[8] - 1);
    const double theta = atan2(s, c);
    if (theta > PI - 0.1) return 0;
    const double k = theta < 1e-4 ? 0.5 * (1 + theta * theta / 6) : 0.5 * theta / s;
    w[0] = k * vx, w[1] = k * vy, w[2] = k * vz;
    return 1;
}

/* the SE3 log (linear, then angular) of (R, t); 0 as log3 */
static int log6(const double *R, const double *t, double *e) {
    double *w = e + 3, x[3];
    if (!log3(R, w)) return 0;
    const double th2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2], th = sqrt(th2);
    double a, b; /* V^-1 t = a t - w x t / 2 + b (w . t) w */
    if (th < 1e-4) {
        a = 1 - th2 / 12 - th2 * th2 / 720, b = 1.0 / 12 + th2 / 720;
    } else {
        const double sn = sin(th), cs = cos(th);
        a = th * sn / (2 * (1 - cs)), b = (1 - a) / th2;
    }
    const double wt = w[0] * t[0] + w[1] * t[1] + w[2] * t[2];
    cross(w, t, x);
    for (int i = 0; i < 3; ++i) e[i] = a * t[i] - 0.5 * x[i] + b * wt * w[i];
    return 1;
}

/* a motion (angular, linear about the origin; world axes) in a frame's axes at (R, p):
 * Pinocchio's order, linear then angular */
static void motion_local(const double *R, const double *p, const double *U, double *out) {
    double x[3];
    cross(U, p, x);
    for (int i = 0; i < 3; ++i) {
        out[i] = R[i] * (U[3] + x[0]) + R[3 + i] * (U[4] + x[1]) + R[6 + i] * (U[5] + x[2]);
        out[3 + i] = R[i] * U[0] + R[3 + i] * U[1] + R[6 + i] * U[2];
    }
}

/* the rows of welds and joint locks, in their order (constraints/foot.py: Weld, JointLock;
 * solve.py: stack), at the placements in p and the joints' velocities V and accelerations at
 * zero A0 (world axes about the origin): J (m x nv, zero on entry) and gamma = -(J'v +
 * 2 alpha J v + beta^2 e). A constraint is 3 ints (kind: 0 a weld, 1 a lock; a weld's joint;
 * a lock's configuration and velocity index) and its reals (a weld: its frame's placement in
 * its joint and its anchor, 12 each, rotations row-major; a lock: its angle). Returns the rows
 * written, -1 if a weld is turned within 0.1 rad of pi from its anchor (log3). */
static Py_ssize_t constraint_rows(const Plan *p, const double *V, const double *A0,
                                  const double *q, const double *v, long long nc,
                                  const long long *cints, const double *creals, double alpha,
                                  double beta, double *J, double *gamma) {
    const Py_ssize_t nv = p->nv;
    Py_ssize_t m = 0;
    double S[36];
    for (long long i = 0; i < nc; ++i) {
        const long long *c = cints + 3 * i;
        if (c[0] == 1) { /* a lock: its hinge's unit row */
            J[m * nv + c[2]] = 1.0;
            gamma[m++] = -(2 * alpha * v[c[2]] + beta * beta * (q[c[1]] - creals[0]));
            creals += 1;
            continue;
        }
        const long long j = c[1];
        const double *P = creals, *Ra = P + 12, *ta = Ra + 9, *Rj = p->oR + 9 * j;
        double Rf[9], pf[3], RaT[9], Re[9], te[3], d[3], e[6], acc[6], tw[6];
        creals += 24;
        mat3(Rj, P, Rf);
        mv3(Rj, P + 9, pf);
        for (int r = 0; r < 3; ++r) pf[r] += p->ot[3 * j + r];
        for (Py_ssize_t a = j; a > 0; a = p->parent[a]) {
            const int n = subspace(p, a, S);
            for (int col = 0; col < n; ++col) {
                double u[6];
                motion_local(Rf, pf, S + 6 * col, u);
                for (int r = 0; r < 6; ++r) J[(m + r) * nv + p->iv[a] + col] = u[r];
            }
        }
        for (int r = 0; r < 3; ++r)
            for (int s = 0; s < 3; ++s) RaT[3 * r + s] = Ra[3 * s + r];
        mat3(RaT, Rf, Re);
        for (int r = 0; r < 3; ++r) d[r] = pf[r] - ta[r];
        mv3(RaT, d, te);
        if (!log6(Re, te, e)) return -1;
        motion_local(Rf, pf, A0 + 6 * j, acc);
        motion_local(Rf, pf, V + 6 * j, tw);
        for (int r = 0; r < 6; ++r) gamma[m + r] = -(acc[r] + 2 * alpha * tw[r] + beta * beta * e[r]);
        m += 6;
    }
    return m;
}

/* how many rows and reals the constraints of cints have (-1: a kind that is not 0 or 1) */
static Py_ssize_t constraint_sizes(long long nc, const long long *cints, Py_ssize_t *nreals) {
    Py_ssize_t m = 0;
    *nreals = 0;
    for (long long i = 0; i < nc; ++i) {
        const long long kind = cints[3 * i];
        if (kind != 0 && kind != 1) return -1;
        m += kind ? 1 : 6, *nreals += kind ? 1 : 24;
    }
    return m;
}

/* tau (nv) from the packed holds (see held_torques' docstring in controller.py): 0 done, 1 the
 * rows' Gram matrix is not positive definite, 2 a weld turned by about pi (the caller falls
 * back to Pinocchio) */
static int held(Plan *p, const double *I, const double *g, const double *q,
                const double *v, const double *dv, const long long *ints, const double *reals,
                double *tau, double *work) {
    const Py_ssize_t nj = p->nj, nv = p->nv;
    const long long k = ints[0], nc = ints[1], nh = ints[2], nr = ints[3];
    const long long *ljoint = ints + 5, *cints = ljoint + k, *hinge = cints + 3 * nc;
    Py_ssize_t ncr;
    const Py_ssize_t mc0 = constraint_sizes(nc, cints, &ncr);
    const double *loads = reals, *creals = loads + 6 * k, *hreal = creals + ncr,
                 *Jr = hreal + 4 * nh, *sc = Jr + nr * nv;
    const double alpha = sc[0], beta = sc[1], scale = sc[2], rtime = sc[3], ridge = sc[4];
    double *V = work, *A = V + 6 * nj, *A0 = A + 6 * nj, *F = A0 + 6 * nj, *C = F + 6 * nj;
    double *rows = C + 16 * nj, S[36];
    kinematics(p, q);
    /* velocities, accelerations at dv (gravity as the root's) and at 0; each body's force */
    forward(p, v, dv, g, V, A, A0);
    for (Py_ssize_t j = 1; j < nj; ++j) {
        body_force(I + 13 * j, p->oR + 9 * j, p->ot + 3 * j, V + 6 * j, A + 6 * j, F + 6 * j);
        /* the body's inertia about the origin for the composite: mass, m c, I_O (row-major) */
        double c[3], Ic[9], *Cj = C + 16 * j;
        const double m = I[13 * j];
        body_world(I + 13 * j, p->oR + 9 * j, p->ot + 3 * j, c, Ic);
        const double cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
        Cj[0] = m;
        for (int i = 0; i < 3; ++i) Cj[1 + i] = m * c[i];
        for (int r = 0; r < 3; ++r)
            for (int s = 0; s < 3; ++s)
                Cj[4 + 3 * r + s] = Ic[3 * r + s] + m * ((r == s) * cc - c[r] * c[s]);
    }
    /* the held forces at their points (both in their joints' axes), as wrenches about the
     * origin */
    for (long long i = 0; i < k; ++i) {
        const long long j = ljoint[i];
        const double *L = loads + 6 * i;
        double x[3], pw[3], f[3];
        mv3(p->oR + 9 * j, L, pw);
        mv3(p->oR + 9 * j, L + 3, f);
        for (int r = 0; r < 3; ++r) pw[r] += p->ot[3 * j + r];
        cross(pw, f, x);
        for (int r = 0; r < 3; ++r) F[6 * j + r] -= x[r], F[6 * j + 3 + r] -= f[r];
    }
    /* the backward pass: tau = M dv + h - J^T f, and the composite inertias */
    backward(p, F, tau, 0);
    for (Py_ssize_t j = nj - 1; j > 0; --j)
        if (p->parent[j] > 0)
            for (int i = 0; i < 13; ++i) C[16 * p->parent[j] + i] += C[16 * j + i];
    /* the rows: the base's six of M, the welds' six, the locks', the range rows held, the
     * hinges that would cross their damper */
    const Py_ssize_t cap = 6 + mc0 + nr + nh;
    double *Ar = rows, *rhs = rows + cap * nv, *G = rhs + cap, *dd = G + cap * cap;
    memset(Ar, 0, cap * nv * sizeof(double));
    Py_ssize_t m = 0;
    {
        double Sb[36];
        const int nb = subspace(p, 1, Sb);
        for (Py_ssize_t j = 1; j < nj; ++j) {
            const int n = subspace(p, j, S);
            const double *Cj = C + 16 * j, mass = Cj[0], *h = Cj + 1, *IO = Cj + 4;
            for (int c = 0; c < n; ++c) {
                const double *al = S + 6 * c, *aO = al + 3;
                double Fc[6], x[3]; /* the composite's force for the column: spatial inertia */
                mv3(IO, al, Fc);
                cross(h, aO, x);
                for (int i = 0; i < 3; ++i) Fc[i] += x[i];
                cross(al, h, x);
                for (int i = 0; i < 3; ++i) Fc[3 + i] = mass * aO[i] + x[i];
                for (int b = 0; b < nb; ++b) {
                    double s = 0.0;
                    for (int i = 0; i < 6; ++i) s += Sb[6 * b + i] * Fc[i];
                    Ar[b * nv + p->iv[j] + c] = s;
                }
            }
        }
        for (int b = 0; b < 6; ++b) rhs[b] = tau[b];
        m = 6;
    }
    {
        const Py_ssize_t mc = constraint_rows(p, V, A0, q, v, nc, cints, creals, alpha, beta,
                                              Ar + m * nv, rhs + m);
        if (mc < 0) return 2;
        for (Py_ssize_t r = m; r < m + mc; ++r) { /* J dv - gamma */
            double s = 0.0;
            for (Py_ssize_t c = 0; c < nv; ++c) s += Ar[r * nv + c] * dv[c];
            rhs[r] = s - rhs[r];
        }
        m += mc;
    }
    if (nr) memcpy(Ar + m * nv, Jr, nr * nv * sizeof(double));
    for (long long i = 0; i < nr; ++i) rhs[m++] = 0.0;
    for (long long i = 0; i < nh; ++i) {
        const long long iq = hinge[2 * i], iv = hinge[2 * i + 1];
        const double *H = hreal + 4 * i, bound = H[0], hsign = H[1], sign = H[2], Jdv = H[3];
        const double r = hsign * (q[iq] - bound);
        const double floor = (-r / rtime - sign * v[iv]) * scale;
        if (Jdv < floor) {
            Ar[m * nv + iv] = sign;
            rhs[m++] = Jdv - floor;
        }
    }
    /* d = A^T (A A^T + ridge trace / m)^-1 rhs, the smallest change; tau -= M d */
    double tr = 0.0;
    for (Py_ssize_t a = 0; a < m; ++a)
        for (Py_ssize_t b = 0; b <= a; ++b) {
            double s = 0.0;
            for (Py_ssize_t c = 0; c < nv; ++c) s += Ar[a * nv + c] * Ar[b * nv + c];
            G[a * m + b] = G[b * m + a] = s;
            if (a == b) tr += s;
        }
    for (Py_ssize_t a = 0; a < m; ++a) G[a * m + a] += ridge * tr / m;
    if (!cholesky(G, m)) return 1;
    cholesky_solve(G, m, rhs);
    for (Py_ssize_t c = 0; c < nv; ++c) {
        double s = 0.0;
        for (Py_ssize_t a = 0; a < m; ++a) s += Ar[a * nv + c] * rhs[a];
        dd[c] = s;
    }
    /* M d: the accelerations S d down the tree, the bodies' forces I A^d summed up it */
    memset(A, 0, 6 * sizeof(double));
    for (Py_ssize_t j = 1; j < nj; ++j) {
        const int n = subspace(p, j, S);
        double *Aj = A + 6 * j;
        for (int i = 0; i < 6; ++i) Aj[i] = A[6 * p->parent[j] + i];
        for (int c = 0; c < n; ++c)
            for (int i = 0; i < 6; ++i) Aj[i] += S[6 * c + i] * dd[p->iv[j] + c];
        body_force(I + 13 * j, p->oR + 9 * j, p->ot + 3 * j, NULL, Aj, F + 6 * j);
    }
    backward(p, F, tau, 1);
    for (int i = 0; i < 6; ++i) tau[i] = 0.0;
    return 0;
}

/* the rows and reals of the nc constraints whose triples are cints (constraint_sizes); -1,
 * the Python error set, if a kind is unknown */
static Py_ssize_t constraint_counts(const char *who, long long nc, const long long *cints,
                                    Py_ssize_t *nreals) {
    const Py_ssize_t m = constraint_sizes(nc, cints, nreals);
    if (m < 0) PyErr_Format(PyExc_ValueError, "%s: a constraint of an unknown kind", who);
    return m;
}

static PyObject *held_torques(PyObject *self, PyObject *args) {
    PyObject *capsule, *objs[8];
    if (!PyArg_ParseTuple(args, "OOOOOOOOO", &capsule, &objs[0], &objs[1], &objs[2], &objs[3],
                          &objs[4], &objs[5], &objs[6], &objs[7]))
        return NULL;
    Plan *p = (Plan *)PyCapsule_GetPointer(capsule, "humanoid.ground_plan");
    if (!p) return NULL;
    const Py_ssize_t nj = p->nj, nv = p->nv, D = sizeof(double), L = sizeof(long long);
    /* inertia, gravity, q, v, dv, ints, reals, tau (written): ints first, whose counts size
     * the reals */
    Py_buffer b[8];
    const char *names[8] = {"inertia", "gravity", "q", "v", "dv", "ints", "reals", "tau"};
    Py_ssize_t bytes[8] = {13 * nj * D, 3 * D, p->nq * D, nv * D, nv * D, 5 * L, 0, nv * D};
    const int exact[8] = {0, 0, 0, 0, 0, 0, 1, 0}, write[8] = {0, 0, 0, 0, 0, 0, 0, 1};
    int got = acquire("held_torques", 6, objs, b, bytes, exact, write, names);
    Py_ssize_t mc = -1, ncr = 0;
    if (got == 6) {
        const long long *n = b[5].buf;
        const Py_ssize_t want = (5 + n[0] + 3 * n[1] + 2 * n[2]) * L;
        if (b[5].len != want)
            PyErr_Format(PyExc_ValueError, "held_torques: ints has %zd bytes, expected %zd",
                         b[5].len, want);
        else
            mc = constraint_counts("held_torques", n[1], n + 5 + n[0], &ncr);
        if (mc >= 0) {
            bytes[6] = (6 * n[0] + ncr + 4 * n[2] + n[3] * nv + 5) * D;
            got = 6 + acquire("held_torques", 2, objs + 6, b + 6, bytes + 6, exact + 6,
                              write + 6, names + 6);
        }
    }
    long status = -1;
    if (got == 8) {
        const long long *n = b[5].buf;
        const Py_ssize_t cap = 6 + mc + n[3] + n[2];
        double *work = malloc((40 * nj + cap * nv + cap + cap * cap + nv) * D);
        if (!work)
            PyErr_NoMemory();
        else
            status = held(p, b[0].buf, b[1].buf, b[2].buf, b[3].buf, b[4].buf, n, b[6].buf,
                          b[7].buf, work);
        free(work);
    }
    for (int i = 0; i < got; ++i) PyBuffer_Release(&b[i]);
    if (PyErr_Occurred()) return NULL;
    return PyLong_FromLong(status);
}

/* constraint_rows(plan, q, v, ints, reals, alpha, beta, J, gamma): the rows of welds and locks
 * (ints: their count, then their triples) into J (m x nv) and gamma (m); returns m, or -1 when
 * a weld is turned within 0.1 rad of pi (the caller stacks them itself) */
static PyObject *constraint_rows_py(PyObject *self, PyObject *args) {
    PyObject *capsule, *objs[6];
    double alpha, beta;
    if (!PyArg_ParseTuple(args, "OOOOOddOO", &capsule, &objs[0], &objs[1], &objs[2], &objs[3],
                          &alpha, &beta, &objs[4], &objs[5]))
        return NULL;
    Plan *p = (Plan *)PyCapsule_GetPointer(capsule, "humanoid.ground_plan");
    if (!p) return NULL;
    const Py_ssize_t nv = p->nv, D = sizeof(double), L = sizeof(long long);
    Py_buffer b[6];
    const char *names[6] = {"q", "v", "ints", "reals", "J", "gamma"};
    Py_ssize_t bytes[6] = {p->nq * D, nv * D, L, 0, 0, 0};
    const int exact[6] = {0, 0, 0, 1, 0, 0}, write[6] = {0, 0, 0, 0, 1, 1};
    int got = acquire("constraint_rows", 3, objs, b, bytes, exact, write, names);
    Py_ssize_t m = -1, ncr = 0;
    if (got == 3) {
        const long long *n = b[2].buf;
        if (b[2].len != (1 + 3 * n[0]) * L)
            PyErr_Format(PyExc_ValueError, "constraint_rows: ints has %zd bytes, expected %zd",
                         b[2].len, (1 + 3 * n[0]) * L);
        else
            m = constraint_counts("constraint_rows", n[0], n + 1, &ncr);
        if (m >= 0) {
            bytes[3] = ncr * D, bytes[4] = m * nv * D, bytes[5] = m * D;
            got = 3 + acquire("constraint_rows", 3, objs + 3, b + 3, bytes + 3, exact + 3,
                              write + 3, names + 3);
        }
    }
    Py_ssize_t out = -2;
    if (got == 6) {
        double *work = malloc(12 * p->nj * D);
        if (!work) {
            PyErr_NoMemory();
        } else {
            const long long *n = b[2].buf;
            kinematics(p, b[0].buf);
            forward(p, b[1].buf, NULL, NULL, work, NULL, work + 6 * p->nj);
            memset(b[4].buf, 0, m * nv * D);
            out = constraint_rows(p, work, work + 6 * p->nj, b[0].buf, b[1].buf, n[0], n + 1,
                                  b[3].buf, alpha, beta, b[4].buf, b[5].buf);
            free(work);
        }
    }
    for (int i = 0; i < got; ++i) PyBuffer_Release(&b[i]);
    if (PyErr_Occurred()) return NULL;
    return PyLong_FromSsize_t(out);
}

static PyMethodDef methods[] = {
    {"ground_plan", ground_plan, METH_VARARGS, "The model's tree and the candidate points."},
    {"ground_select", ground_select, METH_VARARGS,
     "Which candidates are contacts at q (the joints placed); returns how many."},
    {"ground_write", ground_write, METH_VARARGS,
     "The last selection's points, joints, local points and Jacobian rows."},
    {"range_plan", range_plan, METH_VARARGS, "The hinges' and the ball joints' ranges."},
    {"range_rows", range_rows, METH_VARARGS,
     "The range rows within the margin at q (r, J, the angles kept as the next hint)."},
    {"contact_solve", contact_solve, METH_VARARGS,
     "A step's contact impulses and velocity (ADMM); returns (iterations, converged)."},
    {"placements", placements, METH_VARARGS, "Every joint's placement at q (for the tests)."},
    {"tree_dynamics", tree_dynamics, METH_VARARGS,
     "States' joint placements, angular velocities, joint forces and torques (RNEA)."},
    {"constraint_rows", constraint_rows_py, METH_VARARGS,
     "The rows and gamma of welds and joint locks at (q, v); returns how many rows."},
    {"held_torques", held_torques, METH_VARARGS,
     "The welded walk's torques between QP ticks; returns 0, or why the caller falls back."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "kernels",
                                    "The ground contact's per-step kernels in C.", -1, methods};

PyMODINIT_FUNC PyInit_kernels(void) { return PyModule_Create(&module); }
