/*
 * SideslipFusion's scalar models in C: the same arithmetic as the pure-Python reference, operation for operation,
 * so that both give the same doubles (IEEE 754 binary64, no contraction into fused multiply-adds, the same libm;
 * Python's x ** y is the C library's pow, its math.remainder CPython's own, written out below).  The functions and
 * the reference each repeats (the equations and their sources are documented there):
 *
 *   sideslip_fusion_kinematic  sideslip/estimators/fusion/models.py kinematic_step
 *   sideslip_fusion_wheel      models.wheel_measurement (with wheel_model)
 *   sideslip_fusion_axles      models.axle_pseudo (with tire_model.axle_slip_values, axle_stiffness,
 *                              lateral_capacity, _fiala)
 *   sideslip_fusion_heading    magnetometer.MagnetometerHeading.measure from its norm gate to its innovation gate
 *                              (with geomagnetic.tilt_compensated_heading)
 *
 * The Kalman algebra stays in NumPy: its products are OpenBLAS's, whose order of operations depends on the CPU.
 * Where the reference raises (a float division by zero, math.exp, ** or math.remainder out of their range), a
 * function returns a code instead and sideslip/plant/kernel.py raises the same exception, which the estimator's
 * guard catches.
 *
 * Plain C with no Python API, in the binary of the plant's, the driver's and the LQR's steps
 * (sideslip/plant/kernel.py loads it with ctypes).
 */
#include <math.h>

#if defined(_WIN32)
#define KERNEL_API __declspec(dllexport)
#else
#define KERNEL_API __attribute__((visibility("default")))
#endif

#define CAPACITY_MIN 0.3    /* tire_model.CAPACITY_MIN */
#define PI 3.141592653589793  /* math.pi */

/* Return codes: what the Python reference raises. */
enum { FUSION_OK = 0, FUSION_ZERO_DIVISION = 1, FUSION_OVERFLOW = 2, FUSION_DOMAIN = 3 };

/* State indices (sideslip.estimators.fusion.state.Fs). */
enum { VX, VY, PSI, B_R, B_AX, B_AY, D_DELTA, LN_CF, LN_CR, LN_MU, E_W, G_Y, K_AY, D_GNSS, B_MAG };

/* What is constant over a run, in the order sideslip/plant/kernel.py FusionKernel writes it: the vehicle file's
 * axles (models.Geometry), the gravity, the sample period, the tire model's utilisation limit, whether the
 * undriven wheels are the front ones, the magnetometer's parameters (SideslipFusionConfig). */
typedef struct {
    double l_f, l_r, c_f, c_r, c_f_lo, c_r_lo, mu_lo, m_f, m_r;
    double gravity, ts, u_max, front_undriven;
    double mag_norm_gate, mag_declination, mag_tilt_std, mag_roll_error, sigma_mag, mag_tilt_correlation_time,
        mag_gate;
} Constants;

/* Python's float division: ZeroDivisionError for a zero divisor, whatever the dividend. */
#define DIV(a, b, out) do { if ((b) == 0.0) return FUSION_ZERO_DIVISION; (out) = (a) / (b); } while (0)
#define TRY(call) do { int rc_ = (call); if (rc_ != FUSION_OK) return rc_; } while (0)

/* math.exp: OverflowError where a finite argument overflows. */
static int py_exp(double x, double *out)
{
    *out = exp(x);
    return isinf(*out) && isfinite(x) ? FUSION_OVERFLOW : FUSION_OK;
}

/* float ** float for a base >= 0 or an integral exponent (CPython's float_pow: 1 ** y and x ** 0 are 1, otherwise
 * the C library's pow; OverflowError where a finite result overflows). */
static int py_pow(double x, double y, double *out)
{
    if (fabs(x) == 1.0 || y == 0.0) {
        *out = (x < 0.0 && fmod(fabs(y), 2.0) == 1.0) ? -1.0 : 1.0;
        return FUSION_OK;
    }
    *out = pow(x, y);
    return isinf(*out) && isfinite(x) && isfinite(y) ? FUSION_OVERFLOW : FUSION_OK;
}

/* math.remainder (CPython's m_remainder: x less the nearest multiple of y, ties to the even one, exactly); a
 * ValueError for an infinite x or a zero y, as math.remainder raises. */
static int py_remainder(double x, double y, double *out)
{
    double absx, absy, m, c, r;

    if (isnan(x) || isnan(y)) {
        *out = isnan(x) ? x : y;
        return FUSION_OK;
    }
    if (isinf(x) || y == 0.0)
        return FUSION_DOMAIN;
    if (isinf(y)) {
        *out = x;
        return FUSION_OK;
    }
    absx = fabs(x);
    absy = fabs(y);
    m = fmod(absx, absy);
    c = absy - m;            /* m against half of absy without computing 0.5 absy (CPython's comment) */
    if (m < c)
        r = m;
    else if (m > c)
        r = -c;
    else                     /* halfway: the even multiple */
        r = m - 2.0 * fmod(0.5 * (absx - m), absy);
    *out = copysign(1.0, x) * r;
    return FUSION_OK;
}

/* ------------------------------------------------------------------------------------------------ time update */

/* kinematic_step: io in, the state's first thirteen values (VX..K_AY), the measured a_x, the roll-compensated a_y
 * and the yaw rate; out, the predicted VX, VY and PSI (the other states are the prior's).  F (n x n, row-major,
 * the identity elsewhere: the caller's) gets the Jacobian's entries off the diagonal. */
enum { KIN_X = 0, KIN_AX = 13, KIN_AY, KIN_R_M, KIN_OUT, KIN_SIZE = KIN_OUT + 3 };

KERNEL_API int sideslip_fusion_kinematic(const double *kp, double *io, double *F, int n)
{
    const Constants *k = (const Constants *)kp;
    const double *x = io + KIN_X;
    double ts = k->ts, vx = x[VX], vy = x[VY], ax = io[KIN_AX], ay = io[KIN_AY];
    double r = io[KIN_R_M] - x[B_R];
    double a_y = ay - x[B_AY] - x[K_AY] * ay - x[G_Y];   /* the specific force minus the bank's gravity term */

    io[KIN_OUT] = vx + ts * (ax - x[B_AX] + r * vy);
    io[KIN_OUT + 1] = vy + ts * (a_y - r * vx);
    io[KIN_OUT + 2] = x[PSI] + ts * r;
    F[VX * n + VY] = ts * r;
    F[VX * n + B_R] = -ts * vy;
    F[VX * n + B_AX] = -ts;
    F[VY * n + VX] = -ts * r;
    F[VY * n + B_R] = ts * vx;
    F[VY * n + B_AY] = -ts;
    F[VY * n + G_Y] = -ts;
    F[VY * n + K_AY] = -ts * ay;
    F[PSI * n + B_R] = -ts;
    return FUSION_OK;
}

/* ------------------------------------------------------------------------------------------------ wheel speeds */

/* wheel_measurement: io in, the state's VX, E_W and LN_MU, the sample's steering, undriven wheels' speed and a_x;
 * out, the innovation and the noise variance.  row (n values) is written whole. */
enum { WHEEL_VX = 0, WHEEL_E_W, WHEEL_LN_MU, WHEEL_DELTA, WHEEL_V, WHEEL_AX, WHEEL_OUT, WHEEL_SIZE = WHEEL_OUT + 2 };

KERNEL_API int sideslip_fusion_wheel(const double *kp, double *io, double *row, int n)
{
    const Constants *k = (const Constants *)kp;
    double vx = io[WHEEL_VX], e_w = io[WHEEL_E_W], vw = io[WHEEL_V], ax = io[WHEEL_AX];
    double h = (1.0 + e_w) * vx, mu, grip, sigma_w;
    int i;

    for (i = 0; i < n; i++)
        row[i] = 0.0;
    row[VX] = 1.0 + e_w;
    row[E_W] = vx;
    if (k->front_undriven != 0.0) {              /* front wheels turn with the steering */
        double c = cos(io[WHEEL_DELTA]);
        h = h * c;
        for (i = 0; i < n; i++)
            row[i] = row[i] * c;
    }
    TRY(py_exp(io[WHEEL_LN_MU], &mu));
    DIV(fabs(ax), mu * k->gravity, grip);
    sigma_w = 0.03 + 0.01 * fabs(vw) + 0.05 * fabs(ax) + 0.2 * fabs(vw) * grip * grip;
    io[WHEEL_OUT] = vw - h;
    io[WHEEL_OUT + 1] = sigma_w * sigma_w;
    return FUSION_OK;
}

/* ------------------------------------------------------------------------------------------------ tire model */

/* One axle (tire_model.axle_slip_values): the slip angle alpha, its derivatives d_c (stiffness scale) and d_m
 * (friction), the utilisation u, the stiffness c, the lateral capacity f_max, d ln C / d ln mu (k) and
 * d ln F_max / d ln mu (g). */
typedef struct { double alpha, d_c, d_m, u, c, f_max, k, g; } AxleSlip;

static int axle_slip_values(double force, double f_z, double f_x, double c_hi, double c_lo, double mu_lo,
                            double ln_scale, double mu, double u_max, AxleSlip *s)
{
    double w, c, k, scale, f_max, f2, lat2, limit, uc, a, p;

    /* axle_stiffness */
    DIV(mu - mu_lo, 1.0 - mu_lo, w);
    if (w >= 1.0) {
        c = c_hi;
        k = 0.0;
    } else if (w <= 0.0) {
        c = c_lo;
        k = 0.0;
    } else {
        c = c_lo + w * (c_hi - c_lo);
        DIV(mu * (c_hi - c_lo), (1.0 - mu_lo) * c, k);
    }
    TRY(py_exp(ln_scale, &scale));
    c *= scale;
    /* lateral_capacity(mu f_z, f_x) */
    f_max = mu * f_z;
    f2 = f_max * f_max;
    lat2 = f2 - f_x * f_x;
    TRY(py_pow(CAPACITY_MIN * f_max, 2.0, &limit));
    if (lat2 <= limit) {
        f_max = CAPACITY_MIN * f_max;
        s->g = 1.0;
    } else {
        DIV(f2, lat2, s->g);
        f_max = sqrt(lat2);
    }
    /* _fiala(force, c, f_max, u_max) */
    DIV(fabs(force), f_max, s->u);
    uc = s->u < u_max ? s->u : u_max;
    TRY(py_pow(1.0 - uc, 1.0 / 3.0, &w));
    DIV(3.0 * f_max, c, a);
    s->alpha = copysign(a * (1.0 - w), force);
    s->d_c = -s->alpha;
    DIV(uc, 3.0 * w * w, p);
    s->d_m = a * ((1.0 - w) - p);
    if (force < 0.0)
        s->d_m = -s->d_m;
    s->c = c;
    s->f_max = f_max;
    s->k = k;
    return FUSION_OK;
}

/* axle_pseudo: io in, the state's first ten values (VX..LN_MU) and the sample's inputs (models.SampleInputs, in its
 * order); out, per axle (front, then rear) the residual, the slip angle, the utilisation, the slip at u_max and
 * d ln F_max / d ln mu (models.AxlePseudo).  Of the rows (n values each) the function writes the entries the
 * reference sets; the caller keeps the others zero. */
enum { AXLE_X = 0, AXLE_AX = 10, AXLE_AY, AXLE_R_M, AXLE_DELTA, AXLE_V_WHEEL, AXLE_FY_F, AXLE_FY_R, AXLE_FZ_F,
       AXLE_FZ_R, AXLE_FX_F, AXLE_FX_R, AXLE_OUT, AXLE_SIZE = AXLE_OUT + 10 };

KERNEL_API int sideslip_fusion_axles(const double *kp, double *io, double *row_f, double *row_r)
{
    const Constants *k = (const Constants *)kp;
    const double *x = io + AXLE_X;
    double vx = x[VX], vy = x[VY], u_max = k->u_max, mu, r, steer, q, k_max, slip_max;
    AxleSlip f, rr;

    TRY(py_exp(x[LN_MU], &mu));
    r = io[AXLE_R_M] - x[B_R];
    TRY(axle_slip_values(io[AXLE_FY_F], io[AXLE_FZ_F], io[AXLE_FX_F], k->c_f, k->c_f_lo, k->mu_lo, x[LN_CF], mu,
                         u_max, &f));
    TRY(axle_slip_values(io[AXLE_FY_R], io[AXLE_FZ_R], io[AXLE_FX_R], k->c_r, k->c_r_lo, k->mu_lo, x[LN_CR], mu,
                         u_max, &rr));
    steer = io[AXLE_DELTA] - x[D_DELTA];
    io[AXLE_OUT] = vy + k->l_f * r - vx * (steer - f.alpha);
    row_f[VX] = f.alpha - steer;
    row_f[VY] = 1.0;
    row_f[B_R] = -k->l_f;
    row_f[D_DELTA] = vx;
    row_f[LN_CF] = vx * f.d_c;
    row_f[LN_MU] = vx * (f.g * f.d_m + f.k * f.d_c);
    DIV(-vx * k->m_f, f.c, row_f[B_AY]);
    io[AXLE_OUT + 5] = vy - k->l_r * r + vx * rr.alpha;
    row_r[VX] = rr.alpha;
    row_r[VY] = 1.0;
    row_r[B_R] = k->l_r;
    row_r[LN_CR] = vx * rr.d_c;
    row_r[LN_MU] = vx * (rr.g * rr.d_m + rr.k * rr.d_c);
    DIV(-vx * k->m_r, rr.c, row_r[B_AY]);
    TRY(py_pow(1.0 - u_max, 1.0 / 3.0, &q));
    k_max = 1.0 - q;     /* the slip at u_max over the full slide's 3 F_max / C */
    DIV(3.0 * k_max * f.f_max, f.c, slip_max);
    io[AXLE_OUT + 1] = f.alpha;
    io[AXLE_OUT + 2] = f.u;
    io[AXLE_OUT + 3] = slip_max;
    io[AXLE_OUT + 4] = f.g;
    DIV(3.0 * k_max * rr.f_max, rr.c, slip_max);
    io[AXLE_OUT + 6] = rr.alpha;
    io[AXLE_OUT + 7] = rr.u;
    io[AXLE_OUT + 8] = slip_max;
    io[AXLE_OUT + 9] = rr.g;
    return FUSION_OK;
}

/* ------------------------------------------------------------------------------------------------ magnetometer */

/* MagnetometerHeading.measure of a new reading: io in, the reading (x, y, z), the roll model's roll, the state's
 * G_Y, PSI and B_MAG, the covariance's (G_Y, G_Y), (PSI, PSI), (B_MAG, B_MAG) and (PSI, B_MAG), the reading's age
 * [samples]; out, what it gave (0: nothing, the field's norm or its horizontal part failed; 1: its NIS only, the
 * innovation gate failed; 2: a heading), the heading, its variance and the NIS for the consistency window. */
enum { MAG_M = 0, MAG_PHI = 3, MAG_G_Y, MAG_PSI, MAG_B_MAG, MAG_P_GG, MAG_P_PP, MAG_P_BB, MAG_P_PB, MAG_AGE,
       MAG_OUT, MAG_SIZE = MAG_OUT + 4 };

KERNEL_API int sideslip_fusion_heading(const double *kp, double *io)
{
    const Constants *k = (const Constants *)kp;
    double mx = io[MAG_M], my = io[MAG_M + 1], mz = io[MAG_M + 2], phi = io[MAG_PHI], g = k->gravity;
    double p0, p1, p2, v, bank, tilt, c, s, by, up, h2, psi_m, dpsi, t, g2, tilt_var, s2, d2, corr, r, prior, y,
        nis, gate2;

    io[MAG_OUT] = 0.0;
    TRY(py_pow(mx, 2.0, &p0));
    TRY(py_pow(my, 2.0, &p1));
    TRY(py_pow(mz, 2.0, &p2));
    if (!(fabs(sqrt(p0 + p1 + p2) - 1.0) <= k->mag_norm_gate))
        return FUSION_OK;                         /* disturbed (or not a number) */
    v = io[MAG_G_Y] / g;
    v = 0.5 < v ? 0.5 : v;                        /* Python's min(v, 0.5) and max(-0.5, .), NaN as they treat it */
    bank = asin(v > -0.5 ? v : -0.5);
    /* tilt_compensated_heading(mag, phi + bank, declination) */
    tilt = phi + bank;
    c = cos(tilt);
    s = sin(tilt);
    by = c * my - s * mz;
    up = s * my + c * mz;
    h2 = mx * mx + by * by;
    psi_m = atan2(mx, by) - k->mag_declination;
    dpsi = 0.0;
    if (h2 > 0.0)
        dpsi = mx * up / h2;
    if (h2 < 1e-4)
        return FUSION_OK;                         /* no horizontal field to point with */
    TRY(py_pow(k->mag_tilt_std + k->mag_roll_error * fabs(phi), 2.0, &t));
    TRY(py_pow(g, 2.0, &g2));
    tilt_var = t + io[MAG_P_GG] / g2;
    TRY(py_pow(k->sigma_mag, 2.0, &s2));
    TRY(py_pow(dpsi, 2.0, &d2));
    DIV(k->mag_tilt_correlation_time, io[MAG_AGE] * k->ts, corr);
    r = s2 / h2 + d2 * tilt_var * (1.0 > corr ? 1.0 : corr);
    prior = io[MAG_P_PP] + io[MAG_P_BB] + 2.0 * io[MAG_P_PB];
    TRY(py_remainder(psi_m - (io[MAG_PSI] + io[MAG_B_MAG]), 2.0 * PI, &y));
    DIV(y * y, prior + s2 / h2 + d2 * tilt_var, nis);
    io[MAG_OUT + 1] = psi_m;
    io[MAG_OUT + 2] = r;
    io[MAG_OUT + 3] = nis;
    io[MAG_OUT] = 1.0;
    if (k->mag_gate > 0.0) {
        TRY(py_pow(k->mag_gate, 2.0, &gate2));
        if (y * y > gate2 * (prior + r))
            return FUSION_OK;                     /* a disturbance whose norm is near unity: not the heading */
    }
    io[MAG_OUT] = 2.0;
    return FUSION_OK;
}

KERNEL_API int sideslip_fusion_constants_size(void) { return (int)(sizeof(Constants) / sizeof(double)); }

/* The values of each function's io buffer, in the order kinematic, wheel, axles, heading. */
KERNEL_API int sideslip_fusion_io_size(int which)
{
    static const int sizes[] = {KIN_SIZE, WHEEL_SIZE, AXLE_SIZE, MAG_SIZE};
    return which >= 0 && which < 4 ? sizes[which] : -1;
}
