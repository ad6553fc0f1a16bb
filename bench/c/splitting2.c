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
 * Built by step_cost with the system's `cc -O3 -march=native -ffp-contract=off -shared
 * -fPIC ... -lm` (hardware fma, no other contraction: liebody's arithmetic) in a temporary
 * folder and called through ctypes:
 *   splitting2(state[7] = (q, m) in/out, order[3], moments[3], h, n steps).
 */
#include <math.h>

/* fdlibm's __kernel_sin / __kernel_cos coefficients (liebody._kernels.trig) */
static const double S1 = -1.66666666666666324348e-01, S2 = 8.33333333332248946124e-03,
    S3 = -1.98412698298579493134e-04, S4 = 2.75573137070700676789e-06,
    S5 = -2.50507602534068634195e-08, S6 = 1.58969099521155010221e-10;
static const double C1 = 4.16666666666666019037e-02, C2 = -1.38888888888741095749e-03,
    C3 = 2.48015872894767294178e-05, C4 = -2.75573143513906633035e-07,
    C5 = 2.08757232129817482790e-09, C6 = -1.13596475577881948265e-11;

/* exact flow of T_k = m_k^2/(2 I_k) for time tau: m <- R_k(theta)^T m, q <- q (c, s e_k).
 * In increment form, x + ((cos - 1) x + sin y), as liebody's flows.axis_flow: a small
 * turn (half^2 < 0.01) with sin and cos - 1 from the polynomials, a larger one from libm. */
static inline void axis_flow(double *q, double *m, int k, double rate, double tau) {
    double half = 0.5 * tau * rate * m[k];
    int i = (k + 1) % 3, j = (k + 2) % 3;
    double mi = m[i], mj = m[j];
    double w = q[0], x = q[1], y = q[2], z = q[3];
    double s2, c2, cm2;
    if (half * half < 0.01) {
        /* the polynomials in Estrin's scheme, as liebody's trig.sincos_turn */
        double z2 = half * half, z4 = z2 * z2;
        double sp = fma(z4, fma(z4, fma(z2, S6, S5), fma(z2, S4, S3)), fma(z2, S2, S1));
        double cp = fma(z4, fma(z4, fma(z2, C6, C5), fma(z2, C4, C3)), fma(z2, C2, C1));
        s2 = fma(half, z2 * sp, half);
        cm2 = z2 * fma(z2, cp, -0.5);
        c2 = 1.0 + cm2;
    } else {
        s2 = sin(half);
        c2 = cos(half);
        cm2 = c2 - 1.0;
    }
    double cm = -2.0 * s2 * s2, s = 2.0 * s2 * c2;
    m[i] = mi + (cm * mi + s * mj);
    m[j] = mj + (cm * mj - s * mi);
    double vx = k == 0 ? s2 : 0.0, vy = k == 1 ? s2 : 0.0, vz = k == 2 ? s2 : 0.0;
    q[0] = w + (cm2 * w - x * vx - y * vy - z * vz);
    q[1] = x + (cm2 * x + w * vx + y * vz - z * vy);
    q[2] = y + (cm2 * y + w * vy + z * vx - x * vz);
    q[3] = z + (cm2 * z + w * vz + x * vy - y * vx);
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
