/* A plain C splitting2 for the free rigid body: the reference that bench/step_cost.py
 * times beside liebody's integrate(method="splitting2").
 *
 * The symmetric 5-rotation splitting T = T_a + T_b + T_c (kinetic energy split by
 * principal axis): a(h/2) b(h/2) c(h) b(h/2) a(h/2), each sub-flow the exact rotation
 * about one body axis, applied to the body angular momentum m and the scalar-first
 * quaternion q (body -> space); the trailing a(h/2) is merged into the next step's
 * leading one. The axis ordering (a, b, c) is the one integrate() chose (its
 * Trajectory.info["axis_ordering"]), so both compute the same thing; step_cost checks
 * that they agree (bit for bit where the compiler keeps the order of operations).
 *
 * Built by step_cost with the system's `cc -O3 -shared -fPIC ... -lm` in a temporary
 * folder and called through ctypes:
 *   splitting2(state[7] = (q, m) in/out, order[3], moments[3], h, n steps).
 */
#include <math.h>

/* exact flow of T_k = m_k^2/(2 I_k) for time tau: m <- R_k(theta)^T m, q <- q (c, s e_k) */
static inline void axis_flow(double *q, double *m, int k, double rate, double tau) {
    double half = 0.5 * tau * rate * m[k];
    double s2 = sin(half), c2 = cos(half);
    double c = 1.0 - 2.0 * s2 * s2, s = 2.0 * s2 * c2;
    int i = (k + 1) % 3, j = (k + 2) % 3;
    double mi = m[i], mj = m[j];
    m[i] = c * mi + s * mj;
    m[j] = c * mj - s * mi;
    double w = q[0], x = q[1], y = q[2], z = q[3];
    if (k == 0) {
        q[0] = c2 * w - s2 * x; q[1] = c2 * x + s2 * w;
        q[2] = c2 * y + s2 * z; q[3] = c2 * z - s2 * y;
    } else if (k == 1) {
        q[0] = c2 * w - s2 * y; q[1] = c2 * x - s2 * z;
        q[2] = c2 * y + s2 * w; q[3] = c2 * z + s2 * x;
    } else {
        q[0] = c2 * w - s2 * z; q[1] = c2 * x + s2 * y;
        q[2] = c2 * y - s2 * x; q[3] = c2 * z + s2 * w;
    }
}

/* n steps of a-b-c-b-a with the trailing a(h/2) merged into the next leading a(h/2) */
void splitting2(double *state, const int *order, const double *moments, double h, long n) {
    double q[4] = {state[0], state[1], state[2], state[3]};
    double m[3] = {state[4], state[5], state[6]};
    int a = order[0], b = order[1], c = order[2];
    double ra = 1.0 / moments[a], rb = 1.0 / moments[b], rc = 1.0 / moments[c];
    axis_flow(q, m, a, ra, 0.5 * h);
    for (long s = 0; s < n; ++s) {
        axis_flow(q, m, b, rb, 0.5 * h);
        axis_flow(q, m, c, rc, h);
        axis_flow(q, m, b, rb, 0.5 * h);
        axis_flow(q, m, a, ra, s == n - 1 ? 0.5 * h : h);
    }
    for (int i = 0; i < 4; ++i) state[i] = q[i];
    for (int i = 0; i < 3; ++i) state[4 + i] = m[i];
}
