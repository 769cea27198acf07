/*
 * The 8-DOF plant's communication step in C: the same arithmetic as the pure-Python reference
 * (sideslip/plant/dynamics.py PlantModel.held / derivative, sideslip/plant/tires.py, and
 * sideslip/plant/vehicle.py VehiclePlant.step / _outputs_at), operation for operation, so that
 * both give the same doubles (IEEE 754 binary64, no contraction into fused multiply-adds, the same
 * libm).  The equations and their sources are documented in those modules; this file follows
 * their structure line by line and cites the same equations.
 *
 * Plain C with no Python API: loaded with ctypes from any Python version (sideslip/plant/kernel.py),
 * compiled by the FMU build for linux64 and win64 and, for the library, by setuptools (setup.py,
 * with SIDESLIP_PYTHON_EXTENSION defined so that the linker finds the init symbol it requires).
 */
#include <math.h>

#if defined(_WIN32)
#define KERNEL_API __declspec(dllexport)
#else
#define KERNEL_API __attribute__((visibility("default")))
#endif

#define N_STATES 14
#define N_OUTPUTS 24
#define KERNEL_VERSION 5   /* 2: the binary holds the driver's step as well (driver_kernel.c); 3: and the LQR's
                              (sideslip/control/native/lqr_kernel.c); 4: the plant's values in one buffer;
                              5: the plant's wheel-slip control */

/* State indices (sideslip.plant.dynamics.St). */
enum { VX, VY, R, PHI, P, W_FL, W_FR, W_RL, W_RR, X, Y, PSI, AXF, AYF };

/* Magic Formula coefficients of one tire (sideslip.plant.tires.MagicFormula, same order). */
typedef struct {
    double Fz0, pCx1, pDx1, pDx2, pEx1, pCy1, pDy1, pDy2, pEy1, pKy2, rBx1, rBx2, rCx1, rBy1, rBy2, rCy1;
} MagicFormula;

/* Everything constant over a run, in the order sideslip/plant/kernel.py writes it: the derivative's
 * Constants (dynamics.Constants), the torque splits and static loads of PlantModel, the Magic Formula
 * of a front and a rear tire, the sub-step rule and the motors of VehiclePlant. */
typedef struct {
    double m, mshs, g, lf, lr, tf2, tr2, R, inv_iw, c_sigma, kx, kf, kr, cf, cr, lyf, lyr, v_min, omega_eps,
        a00, a01, a02, a10, a11, a12, a20, a21, a22, c_phi, inv_tau, frr_r, drag, eps_v, motor_front, motor_rear,
        slip_max;
    double drive_front, drive_rear, brake_front, brake_rear;          /* splits, per wheel */
    double fz0_front, fz0_rear, mg, mshs_g, k_phi;                     /* static */
    MagicFormula mf_front, mf_rear;
    double radius, stiff_v_min, c_wheel, c_brake, c_slip, inv_z, max_substeps; /* sub-step rule */
    double motor_arm, motor_T_max, motor_tau;
    double tire_model;                                                 /* 0 Dugoff, 1 Magic Formula */
    double gravity;
} Constants;

/* Held inputs of one communication step (dynamics.HeldInputs). */
typedef struct {
    double cd, sd, tq_f, tq_r, tb_f, tb_r, mu, caf, car, fz0f, fz0r, mgsb, roll_k, roll_g, gsb, cb, fw, mw;
} Held;

/* ------------------------------------------------------------------------------------------ tires */
static double friction(double mu, double eps_v, double v_slide)
{   /* Pi 2011 eq 7, floored at 0.1 mu */
    double reduction = 1.0 - eps_v * v_slide;
    return mu * (reduction > 0.1 ? reduction : 0.1);
}

static void theoretical_slip(double v_x, double v_y, double omega, double radius, double v_min,
                             double *s_x, double *s_y)
{
    double rolling = radius * omega;
    double den = rolling > v_min ? rolling : (-rolling > v_min ? -rolling : v_min);
    *s_x = (v_x - rolling) / den;
    *s_y = v_y / den;
}

static void dugoff(double mu_fz, double c_sigma, double c_alpha, double s_x, double s_y, double *fx, double *fy)
{   /* Pi 2011 eqs 7-10 */
    double c_x = c_sigma * s_x;
    double c_y = c_alpha * s_y;
    double norm = sqrt(c_x * c_x + c_y * c_y);
    if (norm > 0.0) {
        double lam = mu_fz / (2.0 * norm);
        if (lam < 1.0) {
            double f = (2.0 - lam) * lam;
            *fx = -c_x * f;
            *fy = -c_y * f;
            return;
        }
    }
    *fx = -c_x;
    *fy = -c_y;
}

static void practical_slip(double v_x, double v_y, double omega, double radius, double v_min,
                           double *kappa, double *alpha)
{
    double den = v_x > v_min ? v_x : (-v_x > v_min ? -v_x : v_min);
    *kappa = (radius * omega - v_x) / den;
    *alpha = atan(v_y / den);
}

static void magic_formula(double fz, double mu, double c_sigma, double c_alpha, double kappa, double alpha,
                          const MagicFormula *p, double *fx, double *fy)
{   /* MF 5.2 subset (tires.py module docstring) */
    double fz0, dfz, dx, bx, x, fx0, dy, ky, by, y, fy0, gxa, gyk;
    if (fz <= 0.0) {
        *fx = 0.0;
        *fy = 0.0;
        return;
    }
    fz0 = p->Fz0;
    dfz = (fz - fz0) / fz0;
    dx = mu * (p->pDx1 + p->pDx2 * dfz) * fz;
    bx = c_sigma * fz / fz0 / (p->pCx1 * dx);
    x = bx * kappa;
    fx0 = dx * sin(p->pCx1 * atan(x - p->pEx1 * (x - atan(x))));
    dy = mu * (p->pDy1 + p->pDy2 * dfz) * fz;
    ky = c_alpha * sin(2.0 * atan(fz / (p->pKy2 * fz0))) / sin(2.0 * atan(1.0 / p->pKy2));
    by = ky / (p->pCy1 * dy);
    y = by * alpha;
    fy0 = -dy * sin(p->pCy1 * atan(y - p->pEy1 * (y - atan(y))));
    gxa = cos(p->rCx1 * atan(p->rBx1 * cos(atan(p->rBx2 * kappa)) * alpha));
    gyk = cos(p->rCy1 * atan(p->rBy1 * cos(atan(p->rBy2 * alpha)) * kappa));
    *fx = gxa * fx0;
    *fy = gyk * fy0;
}

/* ------------------------------------------------------------------------------------------ dynamics */
static double positive(double v) { return v > 0.0 ? v : 0.0; }

#define SLIP_CONTROL_SPEED 3.0   /* dynamics.SLIP_CONTROL_SPEED */

/* dynamics.slip_share: share of a torque a wheel's slip control lets through */
static double slip_share(double v_x, double omega, double radius, double slip_max, int driving)
{
    double den = v_x > SLIP_CONTROL_SPEED ? v_x : (-v_x > SLIP_CONTROL_SPEED ? -v_x : SLIP_CONTROL_SPEED);
    double lam = (radius * omega - v_x) / den;
    double x = driving ? (2.0 * slip_max - lam) / slip_max : (lam + 2.0 * slip_max) / slip_max;
    return x <= 0.0 ? 0.0 : (x >= 1.0 ? 1.0 : x);
}


/* State derivative (dynamics.PlantModel.derivative): eqs 1-6 re-derived, 7-14; aux (13 values, the
 * order of dynamics.Aux) when not NULL. */
static void derivative(const Constants *k, const Held *u, const double *s, double dT, double *dx, double *aux)
{
    double vx = s[VX], vy = s[VY], r = s[R], phi = s[PHI], p = s[P];
    double w1 = s[W_FL], w2 = s[W_FR], w3 = s[W_RL], w4 = s[W_RR], psi = s[PSI], axf = s[AXF], ayf = s[AYF];
    double dfx, dff, dfr, fz1, fz2, fz3, fz4, vyf, vyr, vxl, vxr, vxt1, vyt1, vxt2, vyt2, vxt3, vxt4;
    double mu1, mu2, mu3, mu4, fx1, fy1, fx2, fy2, fx3, fy3, fx4, fy4;
    double bx1, by1, bx2, by2, fx_sum, fy_tires, fy_sum, mz_sum, roll_rhs, a_lat, dr, dp, ax_spec, ay_spec;
    double s1, s2, s3, s4, cpsi, spsi, m1, m2, m3, m4, b1, b2, b3, b4, share;

    /* quasi-static loads (eqs 11-14 re-derived) */
    dfx = k->kx * axf;
    dff = k->kf * phi + k->cf * p + k->lyf * ayf;
    dfr = k->kr * phi + k->cr * p + k->lyr * ayf;
    fz1 = positive(u->fz0f - dfx - dff);
    fz2 = positive(u->fz0f - dfx + dff);
    fz3 = positive(u->fz0r + dfx - dfr);
    fz4 = positive(u->fz0r + dfx + dfr);

    /* contact-point velocities in wheel axes (eqs 15-18) */
    vyf = vy + k->lf * r;
    vyr = vy - k->lr * r;
    vxl = vx - k->tf2 * r;
    vxr = vx + k->tf2 * r;
    vxt1 = vxl * u->cd + vyf * u->sd;
    vyt1 = vyf * u->cd - vxl * u->sd;
    vxt2 = vxr * u->cd + vyf * u->sd;
    vyt2 = vyf * u->cd - vxr * u->sd;
    vxt3 = vx - k->tr2 * r;
    vxt4 = vx + k->tr2 * r;
    /* friction with the velocity effect of eq 7 */
    if (k->eps_v > 0.0) {
        double sl1 = vxt1 - k->R * w1, sl2 = vxt2 - k->R * w2, sl3 = vxt3 - k->R * w3, sl4 = vxt4 - k->R * w4;
        mu1 = friction(u->mu, k->eps_v, sqrt(sl1 * sl1 + vyt1 * vyt1));
        mu2 = friction(u->mu, k->eps_v, sqrt(sl2 * sl2 + vyt2 * vyt2));
        mu3 = friction(u->mu, k->eps_v, sqrt(sl3 * sl3 + vyr * vyr));
        mu4 = friction(u->mu, k->eps_v, sqrt(sl4 * sl4 + vyr * vyr));
    } else {
        mu1 = mu2 = mu3 = mu4 = u->mu;
    }
    if (k->tire_model == 0.0) {   /* Dugoff forces on theoretical slips (eqs 7-10) */
        double sx, sy;
        theoretical_slip(vxt1, vyt1, w1, k->R, k->v_min, &sx, &sy);
        dugoff(mu1 * fz1, k->c_sigma, u->caf, sx, sy, &fx1, &fy1);
        theoretical_slip(vxt2, vyt2, w2, k->R, k->v_min, &sx, &sy);
        dugoff(mu2 * fz2, k->c_sigma, u->caf, sx, sy, &fx2, &fy2);
        theoretical_slip(vxt3, vyr, w3, k->R, k->v_min, &sx, &sy);
        dugoff(mu3 * fz3, k->c_sigma, u->car, sx, sy, &fx3, &fy3);
        theoretical_slip(vxt4, vyr, w4, k->R, k->v_min, &sx, &sy);
        dugoff(mu4 * fz4, k->c_sigma, u->car, sx, sy, &fx4, &fy4);
    } else {                      /* Magic Formula on practical slips */
        double kappa, alpha;
        practical_slip(vxt1, vyt1, w1, k->R, k->v_min, &kappa, &alpha);
        magic_formula(fz1, mu1, k->c_sigma, u->caf, kappa, alpha, &k->mf_front, &fx1, &fy1);
        practical_slip(vxt2, vyt2, w2, k->R, k->v_min, &kappa, &alpha);
        magic_formula(fz2, mu2, k->c_sigma, u->caf, kappa, alpha, &k->mf_front, &fx2, &fy2);
        practical_slip(vxt3, vyr, w3, k->R, k->v_min, &kappa, &alpha);
        magic_formula(fz3, mu3, k->c_sigma, u->car, kappa, alpha, &k->mf_rear, &fx3, &fy3);
        practical_slip(vxt4, vyr, w4, k->R, k->v_min, &kappa, &alpha);
        magic_formula(fz4, mu4, k->c_sigma, u->car, kappa, alpha, &k->mf_rear, &fx4, &fy4);
    }

    /* body-axis forces and moments */
    bx1 = fx1 * u->cd - fy1 * u->sd;
    by1 = fx1 * u->sd + fy1 * u->cd;
    bx2 = fx2 * u->cd - fy2 * u->sd;
    by2 = fx2 * u->sd + fy2 * u->cd;
    fx_sum = bx1 + bx2 + fx3 + fx4 - k->drag * vx * fabs(vx);
    fy_tires = by1 + by2 + fy3 + fy4 + u->fw;
    fy_sum = fy_tires - u->mgsb - k->mshs * r * r * phi;
    mz_sum = k->lf * (by1 + by2) - k->lr * (fy3 + fy4) + k->tf2 * (bx2 - bx1) + k->tr2 * (fx4 - fx3) + u->mw;
    roll_rhs = u->roll_g + u->roll_k * phi - k->c_phi * p;

    /* eqs 2-4 solved for (dvy + r vx, dr, dp) with the constant mass matrix */
    a_lat = k->a00 * fy_sum + k->a01 * mz_sum + k->a02 * roll_rhs;
    dr = k->a10 * fy_sum + k->a11 * mz_sum + k->a12 * roll_rhs;
    dp = k->a20 * fy_sum + k->a21 * mz_sum + k->a22 * roll_rhs;
    ax_spec = fx_sum / k->m - (k->mshs / k->m) * (dr * phi + 2.0 * r * p);     /* eq 1 */
    ay_spec = a_lat + u->gsb;                                                     /* road axes */

    /* wheel spin (eq 6), sat(w) = w / (|w| + omega_eps) */
    s1 = w1 / ((w1 > 0.0 ? w1 : -w1) + k->omega_eps);
    s2 = w2 / ((w2 > 0.0 ? w2 : -w2) + k->omega_eps);
    s3 = w3 / ((w3 > 0.0 ? w3 : -w3) + k->omega_eps);
    s4 = w4 / ((w4 > 0.0 ? w4 : -w4) + k->omega_eps);
    /* motor torque (+-dT on its axle's right and left wheel) and brake torque per wheel */
    m1 = k->motor_front * dT;
    m2 = k->motor_front * dT;
    m3 = k->motor_rear * dT;
    m4 = k->motor_rear * dT;
    b1 = u->tb_f;
    b2 = u->tb_f;
    b3 = u->tb_r;
    b4 = u->tb_r;
    share = 1.0;
    if (k->slip_max > 0.0) {   /* wheel-slip control: ABS and the motors' slip limit */
        b1 *= slip_share(vxt1, w1, k->R, k->slip_max, 0);
        b2 *= slip_share(vxt2, w2, k->R, k->slip_max, 0);
        b3 *= slip_share(vxt3, w3, k->R, k->slip_max, 0);
        b4 *= slip_share(vxt4, w4, k->R, k->slip_max, 0);
        if (dT != 0.0) {
            m1 *= slip_share(vxt1, w1, k->R, k->slip_max, dT < 0.0);
            m2 *= slip_share(vxt2, w2, k->R, k->slip_max, dT > 0.0);
            m3 *= slip_share(vxt3, w3, k->R, k->slip_max, dT < 0.0);
            m4 *= slip_share(vxt4, w4, k->R, k->slip_max, dT > 0.0);
            share = 0.5 * (k->motor_front != 0.0 ? (m1 + m2) / (k->motor_front * dT)
                                                 : (m3 + m4) / (k->motor_rear * dT));
        }
    }
    cpsi = cos(psi);
    spsi = sin(psi);
    if (aux) {
        aux[0] = ax_spec;
        aux[1] = ay_spec;
        aux[2] = by1 + by2;
        aux[3] = fy3 + fy4;
        aux[4] = fz1;
        aux[5] = fz2;
        aux[6] = fz3;
        aux[7] = fz4;
        aux[8] = atan2(vyt1, fabs(vxt1));
        aux[9] = atan2(vyt2, fabs(vxt2));
        aux[10] = atan2(vyr, fabs(vxt3));
        aux[11] = atan2(vyr, fabs(vxt4));
        aux[12] = share;
    }
    dx[VX] = ax_spec + r * vy;
    dx[VY] = a_lat - r * vx;
    dx[R] = dr;
    dx[PHI] = p;
    dx[P] = dp;
    dx[W_FL] = (u->tq_f - m1 - k->R * fx1 - (b1 + k->frr_r * fz1) * s1) * k->inv_iw;
    dx[W_FR] = (u->tq_f + m2 - k->R * fx2 - (b2 + k->frr_r * fz2) * s2) * k->inv_iw;
    dx[W_RL] = (u->tq_r - m3 - k->R * fx3 - (b3 + k->frr_r * fz3) * s3) * k->inv_iw;
    dx[W_RR] = (u->tq_r + m4 - k->R * fx4 - (b4 + k->frr_r * fz4) * s4) * k->inv_iw;
    dx[X] = vx * cpsi - vy * spsi;
    dx[Y] = vx * spsi + vy * cpsi;
    dx[PSI] = r;
    dx[AXF] = (ax_spec - axf) * k->inv_tau;
    dx[AYF] = (ay_spec - ayf) * k->inv_tau;
}

/* dynamics.PlantModel.held with the cornering stiffness (caf, car) given */
static void held_inputs(const Constants *k, const double *in, double caf, double car, Held *u)
{
    double delta_f = in[0], T_drive = in[1], T_brake = in[2], mu = in[4], bank = in[5];
    double tb = T_brake > 0.0 ? T_brake : 0.0;
    double cb = cos(bank), sb = sin(bank);
    u->cd = cos(delta_f);
    u->sd = sin(delta_f);
    u->tq_f = k->drive_front * T_drive;
    u->tq_r = k->drive_rear * T_drive;
    u->tb_f = k->brake_front * tb;
    u->tb_r = k->brake_rear * tb;
    u->mu = mu;
    u->caf = caf;
    u->car = car;
    u->fz0f = k->fz0_front * cb;
    u->fz0r = k->fz0_rear * cb;
    u->mgsb = k->mg * sb;
    u->roll_k = k->mshs_g * cb - k->k_phi;
    u->roll_g = k->mshs_g * sb;
    u->gsb = k->gravity * sb;
    u->cb = cb;
    u->fw = in[6];
    u->mw = in[7];
}

/* Python's float modulo (the sign of the divisor) and units.wrap_angle: (-pi, pi] */
static double py_mod(double a, double b)
{
    double mod = fmod(a, b);
    if (mod != 0.0) {
        if ((b < 0.0) != (mod < 0.0))
            mod += b;
    } else {
        mod = copysign(0.0, b);
    }
    return mod;
}

static double wrap_angle(double angle)
{
    const double pi = 3.141592653589793;
    return pi - py_mod(pi - angle, 2.0 * pi);
}

/* vehicle.VehiclePlant._substeps */
static int substeps(const Constants *k, const double *s, double h, double tb, double t_motor)
{
    double den, stiff, n, v_slip = 0.5 * fabs(s[VX]);
    double a = fabs(s[W_FL]), b = fabs(s[W_FR]), c = fabs(s[W_RL]), d = fabs(s[W_RR]);
    double least = a;
    if (b < least) least = b;
    if (c < least) least = c;
    if (d < least) least = d;
    den = k->radius * least;
    stiff = k->c_wheel / (den > k->stiff_v_min ? den : k->stiff_v_min) + k->c_brake * tb
        + k->c_slip * (tb + t_motor) / (v_slip > SLIP_CONTROL_SPEED ? v_slip : SLIP_CONTROL_SPEED);
    n = ceil(h * stiff * k->inv_z - 1e-12);
    if (!(n >= 1.0)) return 1;
    if (n > k->max_substeps) return (int)k->max_substeps;
    return (int)n;
}

/* Outputs of the plant (vehicle.VehiclePlant._outputs_at, order sideslip.signals.PLANT_OUTPUTS) */
static void outputs(const Constants *k, const Held *u, const double *s, double dT, double *out)
{
    double dx[N_STATES], aux[13];
    double bank, ay_body, phi = s[PHI];
    derivative(k, u, s, dT, dx, aux);
    bank = atan2(u->gsb, k->gravity * u->cb);
    ay_body = cos(phi) * aux[1] + sin(phi) * k->gravity * u->cb;
    out[0] = s[VX];
    out[1] = s[VY];
    out[2] = s[R];
    out[3] = atan2(s[VY], s[VX]);
    out[4] = s[PSI];
    out[5] = bank + phi;
    out[6] = s[P];
    out[7] = aux[0];
    out[8] = ay_body;
    out[9] = s[X];
    out[10] = s[Y];
    out[11] = s[W_FL];
    out[12] = s[W_FR];
    out[13] = s[W_RL];
    out[14] = s[W_RR];
    out[15] = aux[2];
    out[16] = aux[3];
    out[17] = aux[4];
    out[18] = aux[5];
    out[19] = aux[6];
    out[20] = aux[7];
    out[21] = 0.5 * (aux[8] + aux[9]);
    out[22] = 0.5 * (aux[10] + aux[11]);
    out[23] = k->motor_arm * dT * aux[12];
}

KERNEL_API int sideslip_plant_kernel_version(void) { return KERNEL_VERSION; }

KERNEL_API int sideslip_plant_constants_size(void) { return (int)(sizeof(Constants) / sizeof(double)); }

/* The values of one step (sideslip/plant/kernel.py PLANT_IO): the state (the plant's N_STATES states, then the
 * motors' torque difference dT_motor), advanced in place; the plant's inputs delta_f, T_drive, T_brake, Mz_dyc, mu,
 * bank_angle, F_wind_y, M_wind_z; the tires' cornering stiffness on this friction (front, rear:
 * VehicleParams.cornering_stiffness); the communication step h [s] (> 0); the N_OUTPUTS outputs at the end of the
 * step, written.  One buffer, so that the call passes two pointers (the cheapest ctypes call). */
enum { IO_STATE = 0, IO_IN = N_STATES + 1, IO_CAF = IO_IN + 8, IO_CAR, IO_H, IO_OUT, IO_SIZE = IO_OUT + N_OUTPUTS };

KERNEL_API int sideslip_plant_io_size(void) { return IO_SIZE; }

/* One communication step of VehiclePlant.step after its input check and clock tick: constants k (Constants),
 * io as above.  Returns the number of RK4 sub-steps taken. */
KERNEL_API int sideslip_plant_step(const double *kp, double *io)
{
    const Constants *k = (const Constants *)kp;
    double *state = io + IO_STATE, *out = io + IO_OUT;
    const double *in = io + IO_IN;
    double caf = io[IO_CAF], car = io[IO_CAR], h = io[IO_H];
    Held u;
    double x[N_STATES], k1[N_STATES], k2[N_STATES], k3[N_STATES], k4[N_STATES], tmp[N_STATES];
    double lim = k->motor_T_max, dT_cmd = in[3] / k->motor_arm, dT = state[N_STATES];
    double hs, half, h6, decay_half;
    int i, j, n;

    held_inputs(k, in, caf, car, &u);
    /* in-wheel motors: Mz = (t / R) dT, saturated, first-order lag (exact) */
    dT_cmd = dT_cmd > lim ? lim : (dT_cmd < -lim ? -lim : dT_cmd);
    for (i = 0; i < N_STATES; i++)
        x[i] = state[i];
    n = substeps(k, x, h, u.tb_f > u.tb_r ? u.tb_f : u.tb_r, fabs(dT) > fabs(dT_cmd) ? fabs(dT) : fabs(dT_cmd));
    hs = h / n;
    half = 0.5 * hs;
    h6 = hs / 6.0;
    decay_half = k->motor_tau > 0.0 ? exp(-half / k->motor_tau) : 0.0;
    for (j = 0; j < n; j++) {   /* classical RK4 */
        double dT_mid = dT_cmd + (dT - dT_cmd) * decay_half;
        double dT_end = dT_cmd + (dT_mid - dT_cmd) * decay_half;
        derivative(k, &u, x, dT, k1, 0);
        for (i = 0; i < N_STATES; i++) tmp[i] = x[i] + half * k1[i];
        derivative(k, &u, tmp, dT_mid, k2, 0);
        for (i = 0; i < N_STATES; i++) tmp[i] = x[i] + half * k2[i];
        derivative(k, &u, tmp, dT_mid, k3, 0);
        for (i = 0; i < N_STATES; i++) tmp[i] = x[i] + hs * k3[i];
        derivative(k, &u, tmp, dT_end, k4, 0);
        for (i = 0; i < N_STATES; i++) x[i] = x[i] + h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
        dT = dT_end;
    }
    x[PSI] = wrap_angle(x[PSI]);
    for (i = 0; i < N_STATES; i++)
        state[i] = x[i];
    state[N_STATES] = dT;
    outputs(k, &u, x, dT, out);
    return n;
}

#ifdef SIDESLIP_PYTHON_EXTENSION
/* Built by setuptools as an extension module, whose linker asks for an init function; the library loads this
 * file with ctypes and never imports it (an import fails: the function returns NULL).  Declared without Python.h,
 * so that an install needs no Python headers. */
KERNEL_API void *PyInit__plant_kernel(void) { return 0; }
#endif
