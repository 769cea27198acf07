/*
 * SideslipFusion's scalar models in C: the same arithmetic as the pure-Python reference, operation for operation,
 * so that both give the same doubles (IEEE 754 binary64, no contraction into fused multiply-adds, the same libm;
 * Python's x ** y is the C library's pow, its math.hypot and math.remainder CPython's own: python_math.h).  The
 * functions and the reference each repeats (the equations and their sources are documented there):
 *
 *   sideslip_fusion_inputs     sideslip/estimators/fusion/inputs.py InputConditioner.__call__ (with
 *                              sideslip/estimators/roll.py RollCompensator, discrete.lowpass, bicycle.axle_forces)
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

#include "../../../plant/native/python_math.h"

#if defined(_WIN32)
#define KERNEL_API __declspec(dllexport)
#else
#define KERNEL_API __attribute__((visibility("default")))
#endif

#define CAPACITY_MIN 0.3    /* tire_model.CAPACITY_MIN */
#define PI 3.141592653589793  /* math.pi */


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
    /* the input conditioner's (inputs.InputConditioner): the roll model's I, C, K, m_s h_s (roll.RollCompensator),
     * the yaw acceleration's cut-off, the friction floor's bounds, the vehicle's m, I_zz, l_f, l_r, h_cg, l, the
     * axles' static loads, 1.0 for combined slip and the drive and brake splits */
    double roll_i, roll_c, roll_k, roll_mh, yaw_acc_cutoff, mu_min, mu_max, m, I_zz, cg_f, cg_r, h_cg, l,
        fz_static_f, fz_static_r, combined_slip, drive_split_front, brake_split_front;
} Constants;

/* Python's float division: ZeroDivisionError for a zero divisor, whatever the dividend. */
#define DIV(a, b, out) do { if ((b) == 0.0) return PY_ZERO_DIVISION; (out) = (a) / (b); } while (0)
#define TRY(call) do { int rc_ = (call); if (rc_ != PY_OK) return rc_; } while (0)

/* ------------------------------------------------------------------------------------------------ inputs */

/* discrete.lowpass: one step of a first-order low-pass filter (exact discretisation; cutoff in Hz). */
static double lowpass(double prev, double value, double ts, double cutoff)
{
    double a = exp(-2.0 * PI * cutoff * ts);
    return a * prev + (1.0 - a) * value;
}

/* InputConditioner.__call__ with its RollCompensator: io in, the measured a_x, a_y, yaw rate, the filter's offsets
 * b_ax, b_ay and roll gain k_ay, the roll model's phi and phi rate, the last yaw rate (and 1.0 if there is one),
 * the low-passed yaw acceleration and horizontal acceleration; out, the roll-compensated a_y, the axles' lateral
 * forces, loads and longitudinal forces (models.SampleInputs's fy_f, fy_r, fz_f, fz_r, fx_f, fx_r), the new roll
 * model's phi and phi rate, yaw acceleration, horizontal acceleration and log friction floor. */
enum { IN_AX = 0, IN_AY_M, IN_R_M, IN_B_AX, IN_B_AY, IN_K_AY, IN_PHI, IN_PHI_RATE, IN_R_PREV, IN_HAS_R_PREV,
       IN_R_DOT, IN_ACCEL, IN_OUT, IN_SIZE = IN_OUT + 12 };

KERNEL_API int sideslip_fusion_inputs(const double *kp, double *io)
{
    const Constants *k = (const Constants *)kp;
    double ts = k->ts, g = k->gravity, ax = io[IN_AX], r_m = io[IN_R_M], b_ax = io[IN_B_AX], phi = io[IN_PHI];
    double phi_rate = io[IN_PHI_RATE], r_dot = io[IN_R_DOT], ay, b_ay, rate, accel, v, fx, shift, front, fyf, fyr;
    double fzf, fzr, fxf = 0.0, fxr = 0.0, lat;

    /* RollCompensator: a_y = (a_y,m - g sin(phi)) / cos(phi), then the roll model one sample on */
    if (isinf(phi))
        return PY_DOMAIN;                            /* math.sin of an infinity */
    ay = (io[IN_AY_M] - g * sin(phi)) / cos(phi);
    phi_rate += ts * (k->roll_mh * ay - k->roll_k * phi - k->roll_c * phi_rate) / k->roll_i;
    phi = phi + ts * phi_rate;
    b_ay = io[IN_B_AY] + io[IN_K_AY] * ay;       /* not the tires' force: the offset and the roll's gravity */
    if (io[IN_HAS_R_PREV] != 0.0) {
        DIV(r_m - io[IN_R_PREV], ts, rate);
        r_dot = lowpass(r_dot, rate, ts, k->yaw_acc_cutoff);
    }
    accel = lowpass(io[IN_ACCEL], py_hypot(ax - b_ax, ay - b_ay), ts, 1.0);
    v = 0.9 * accel / g;
    v = k->mu_max < v ? k->mu_max : v;                /* Python's min(v, mu_max) and max(mu_min, .) */
    io[IN_OUT + 11] = log(v > k->mu_min ? v : k->mu_min);
    /* bicycle.axle_forces(m, I_zz, l_f, l_r, a_y - b_ay, r_dot) with no yaw moment */
    lat = ay - b_ay;
    fyf = (k->m * k->cg_r * lat + k->I_zz * r_dot - 0.0) / (k->cg_f + k->cg_r);
    fyr = (k->m * k->cg_f * lat - k->I_zz * r_dot + 0.0) / (k->cg_f + k->cg_r);
    fx = k->m * (ax - b_ax);
    shift = fx * k->h_cg / k->l;                      /* longitudinal load transfer */
    fzf = 0.2 * k->fz_static_f > k->fz_static_f - shift ? 0.2 * k->fz_static_f : k->fz_static_f - shift;
    fzr = 0.2 * k->fz_static_r > k->fz_static_r + shift ? 0.2 * k->fz_static_r : k->fz_static_r + shift;
    if (k->combined_slip != 0.0) {
        front = fx > 0.0 ? k->drive_split_front : k->brake_split_front;
        fxf = front * fx;
        fxr = (1.0 - front) * fx;
    }
    io[IN_OUT] = ay;
    io[IN_OUT + 1] = fyf;
    io[IN_OUT + 2] = fyr;
    io[IN_OUT + 3] = fzf;
    io[IN_OUT + 4] = fzr;
    io[IN_OUT + 5] = fxf;
    io[IN_OUT + 6] = fxr;
    io[IN_OUT + 7] = phi;
    io[IN_OUT + 8] = phi_rate;
    io[IN_OUT + 9] = r_dot;
    io[IN_OUT + 10] = accel;
    return PY_OK;
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
    return PY_OK;
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
    return PY_OK;
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
    return PY_OK;
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
    return PY_OK;
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
        return PY_OK;                         /* disturbed (or not a number) */
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
        return PY_OK;                         /* no horizontal field to point with */
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
            return PY_OK;                     /* a disturbance whose norm is near unity: not the heading */
    }
    io[MAG_OUT] = 2.0;
    return PY_OK;
}

KERNEL_API int sideslip_fusion_constants_size(void) { return (int)(sizeof(Constants) / sizeof(double)); }

/* The values of each function's io buffer, in the order inputs, kinematic, wheel, axles, heading. */
KERNEL_API int sideslip_fusion_io_size(int which)
{
    static const int sizes[] = {IN_SIZE, KIN_SIZE, WHEEL_SIZE, AXLE_SIZE, MAG_SIZE};
    return which >= 0 && which < 5 ? sizes[which] : -1;
}
