/*
 * The LQR yaw-moment controller's samples in C: the law of the pure-Python reference
 * (sideslip/control/base.py YawMomentController.step, _sample, _learn_steer_offset, _integrate, _accumulate, _limiter,
 * _command, Ramp and smoothstep; sideslip/control/reference.py ReferenceModel.step; sideslip/control/schedule.py
 * SpeedTable; sideslip/control/dyc.py LqrDycController._law without the feed-forward), operation for operation, so
 * that both give the same doubles (no contraction into fused multiply-adds; nothing but arithmetic and comparisons).
 * Which friction the design follows (friction_source = 1) stays in Python: the caller passes the design in use.
 *
 * Compiled into the same binary as the plant's and the driver's steps and loaded with ctypes
 * (sideslip/plant/kernel.py).
 */
#include <math.h>

#if defined(_WIN32)
#define KERNEL_API __declspec(dllexport)
#else
#define KERNEL_API __attribute__((visibility("default")))
#endif

/* What does not change while the controller runs (sideslip/plant/kernel.py LqrLaw writes it, in this order). */
typedef struct {
    int shaped, valid_gate, hold_limit, band, first;
    double clock_rounding, v_min, v_fade, v_max, dv, dmz, Mz_max, k_offset, beta_std_ref, ramp_rate, a_beta, a_gamma,
           gravity, deadband, k_integral, bleed, k_understeer, understeer_bleed, Ts, K_beta, straight_yaw_rate,
           straight_steer, steer_offset_max, t_beta_lead, a_rate, beta_rate_tau;
} LqrLaw;

/* What depends on the design's friction (LqrDesign): the bicycle model's steady-state gains, the reference's
 * friction, the limiter's bound and the LQR gain schedule (rows of (g_beta, g_gamma) on an increasing speed grid). */
typedef struct {
    const double *grid, *rows;
    int n;
    double l, understeer_gradient, l_r, m, l_f, C_r, mu, beta_limit;
} LqrDesign;

/* One step's values (sideslip/plant/kernel.py LqrKernel.step): the step and the inputs, then the sample clock (the
 * samples run, the step's samples) and the state in and out. */
enum { IO_H, IO_DELTA, IO_VX, IO_BETA_HAT, IO_YAW_RATE, IO_BETA_VALID, IO_ENABLE, IO_BETA_STD,
       IO_CLOCK_T, IO_CLOCK_BASE, IO_CLOCK_N, IO_CLOCK_H, IO_SAMPLES_DONE, IO_SAMPLES,
       IO_V_SCHEDULE, IO_ENABLED, IO_BETA_WEIGHT, IO_STEER_OFFSET, IO_INTEGRAL, IO_MZ, IO_REF_BETA, IO_REF_GAMMA,
       IO_PART_FF, IO_PART_FB, IO_BETA_LOWPASS, IO_UNDERSTEER, IO_SIZE };

/* Python's max(a, b) and min(a, b): the first unless the second compares greater (less). */
static double py_max(double a, double b) { return b > a ? b : a; }
static double py_min(double a, double b) { return b < a ? b : a; }

static double smoothstep(double x)
{
    if (x <= 0.0)
        return 0.0;
    if (x >= 1.0)
        return 1.0;
    return x * x * (3.0 - 2.0 * x);
}

static double ramp(double *value, double rate, int on)
{
    double v = on ? *value + rate : *value - rate;
    *value = v > 1.0 ? 1.0 : (v < 0.0 ? 0.0 : v);
    return *value;
}

static double dead_zone(double e, double width)
{
    return e > width ? e - width : (e < -width ? e + width : 0.0);
}

/* BicycleModel.steady_state_gains: (beta / delta, r / delta). */
static void steady_state_gains(const LqrDesign *d, double vx, double *k_beta, double *k_gamma)
{
    double den = d->l + d->understeer_gradient * vx * vx;
    *k_beta = (d->l_r - d->m * d->l_f * vx * vx / (d->l * d->C_r)) / den;
    *k_gamma = vx / den;
}

/* SpeedTable.__call__ of the gain schedule, clamped at the grid's ends. */
static void gains(const LqrDesign *d, double vx, double *g_beta, double *g_gamma)
{
    const double *grid = d->grid, *lo, *hi;
    int n = d->n, a, b;
    double w;

    if (vx <= grid[0]) {
        *g_beta = d->rows[0];
        *g_gamma = d->rows[1];
        return;
    }
    if (vx >= grid[n - 1]) {
        *g_beta = d->rows[2 * (n - 1)];
        *g_gamma = d->rows[2 * (n - 1) + 1];
        return;
    }
    a = 0;                            /* bisect_right - 1: the last grid speed <= vx */
    b = n;
    while (a < b) {
        int mid = (a + b) / 2;
        if (vx < grid[mid])
            b = mid;
        else
            a = mid + 1;
    }
    a -= 1;
    w = (vx - grid[a]) / (grid[a + 1] - grid[a]);
    lo = d->rows + 2 * a;
    hi = lo + 2;
    *g_beta = lo[0] + w * (hi[0] - lo[0]);
    *g_gamma = lo[1] + w * (hi[1] - lo[1]);
}

/* YawMomentController._accumulate: the integral io[at] advanced by one sample of e. */
static void accumulate(const LqrLaw *c, double *io, int at, double e, int grow, double bleed)
{
    double lim = c->Mz_max, mz = io[IO_MZ];
    if (!grow)
        io[at] *= bleed;
    else if (!((mz >= lim && e > 0.0) || (mz <= -lim && e < 0.0)))
        io[at] += e * c->Ts;
}

/* One sample with finite inputs: the unsaturated command (YawMomentController._sample with LqrDycController._law). */
static double sample(const LqrLaw *c, const LqrDesign *d, double *io)
{
    double delta = io[IO_DELTA], vx_hat = io[IO_VX], beta_hat = io[IO_BETA_HAT], yaw_rate = io[IO_YAW_RATE];
    double vs, w, w_beta, v, k_beta, k_gamma, lim, clipped, beta_ref, gamma_ref, g_beta, g_gamma, e_beta, e_gamma;
    double n_fb;

    if (c->shaped) {
        if (io[IO_V_SCHEDULE] != io[IO_V_SCHEDULE])              /* the first sample */
            io[IO_V_SCHEDULE] = vx_hat;
        io[IO_V_SCHEDULE] += py_min(py_max(vx_hat - io[IO_V_SCHEDULE], -c->dv), c->dv);
        vs = io[IO_V_SCHEDULE];
        w = smoothstep((vs - c->v_min) / c->v_fade);
        w = w * ramp(&io[IO_ENABLED], c->ramp_rate, io[IO_ENABLE] != 0.0);
        w_beta = ramp(&io[IO_BETA_WEIGHT], c->ramp_rate, io[IO_BETA_VALID] != 0.0 || !c->valid_gate);
        /* _learn_steer_offset */
        {
            double off = io[IO_STEER_OFFSET];
            if (c->k_offset != 0.0 && vs > c->v_min && fabs(yaw_rate) < c->straight_yaw_rate
                    && fabs(delta - off) < c->straight_steer) {
                steady_state_gains(d, vs, &k_beta, &k_gamma);
                off += c->k_offset * (delta - yaw_rate / k_gamma - off);
                off = py_min(py_max(off, -c->steer_offset_max), c->steer_offset_max);
                io[IO_STEER_OFFSET] = off;
            }
            delta = delta - off;
        }
    } else {
        vs = io[IO_V_SCHEDULE] = vx_hat;
        w = io[IO_ENABLE] != 0.0 && vx_hat >= c->v_min ? 1.0 : 0.0;
        w_beta = 1.0;
    }
    if (c->beta_std_ref > 0.0) {
        double ref2 = c->beta_std_ref * c->beta_std_ref, std = io[IO_BETA_STD];
        w_beta *= ref2 / (ref2 + std * std);
    }
    v = py_min(py_max(vs, c->v_min), c->v_max);

    /* ReferenceModel.step: eqs 21-22, friction-limited */
    steady_state_gains(d, v, &k_beta, &k_gamma);
    lim = d->mu * c->gravity / (v * fabs(k_gamma));
    clipped = delta > lim ? lim : (delta < -lim ? -lim : delta);
    beta_ref = c->a_beta * io[IO_REF_BETA] + (1.0 - c->a_beta) * (k_beta * clipped);
    gamma_ref = c->a_gamma * io[IO_REF_GAMMA] + (1.0 - c->a_gamma) * (k_gamma * clipped);
    if (c->hold_limit) {
        double b_max = fabs(k_beta) * lim, g_max = fabs(k_gamma) * lim;
        beta_ref = beta_ref > b_max ? b_max : (beta_ref < -b_max ? -b_max : beta_ref);
        gamma_ref = gamma_ref > g_max ? g_max : (gamma_ref < -g_max ? -g_max : gamma_ref);
    }
    io[IO_REF_BETA] = beta_ref;
    io[IO_REF_GAMMA] = gamma_ref;

    /* LqrDycController._law without the feed-forward: eq 25 and the drivable profile's additions */
    gains(d, v, &g_beta, &g_gamma);
    e_beta = beta_ref - beta_hat;
    if (c->band == 1) {
        e_beta = dead_zone(e_beta - 0.5 * beta_ref, 0.5 * fabs(beta_ref));
    } else if (c->band == 2) {
        double lo = beta_ref < 0.0 ? beta_ref : 0.0, hi = beta_ref < 0.0 ? 0.0 : beta_ref;
        double inside = beta_hat < lo ? lo : (beta_hat > hi ? hi : beta_hat);
        e_beta = beta_ref - inside;
        if (g_beta * (inside - beta_hat) * beta_hat > 0.0)
            e_beta += inside - beta_hat;
    }
    e_gamma = dead_zone(gamma_ref - yaw_rate, c->deadband);
    n_fb = w_beta * g_beta * e_beta + g_gamma * e_gamma;                              /* eq 25 */
    if (c->k_integral != 0.0) {                                                      /* _integrate */
        accumulate(c, io, IO_INTEGRAL, e_gamma, e_gamma != 0.0, c->bleed);
        n_fb += g_gamma * c->k_integral * io[IO_INTEGRAL];
    }
    if (c->k_understeer != 0.0) {                                      /* the understeer integral */
        accumulate(c, io, IO_UNDERSTEER, e_gamma,
                   e_gamma * gamma_ref > 0.0 && yaw_rate * gamma_ref > 0.0 && beta_hat * gamma_ref >= 0.0,
                   c->understeer_bleed);
        n_fb += g_gamma * c->k_understeer * io[IO_UNDERSTEER];
    }
    if (c->K_beta != 0.0) {                                                          /* _limiter */
        double b = beta_hat, over;
        if (c->t_beta_lead > 0.0) {                                   /* the sideslip ahead (t_beta_lead) */
            double lp = io[IO_BETA_LOWPASS], rate;
            if (lp != lp)
                lp = beta_hat;
            rate = (beta_hat - lp) / c->beta_rate_tau;
            io[IO_BETA_LOWPASS] = lp + c->a_rate * (beta_hat - lp);
            b = beta_hat + c->t_beta_lead * rate;
        }
        over = fabs(b) - d->beta_limit;
        n_fb += over > 0.0 ? w_beta * c->K_beta * copysign(over, b) : 0.0;
    }
    if (c->first && w_beta > 0.5) {
        if ((beta_hat < beta_ref && beta_hat < 0.0 && n_fb > 0.0)
                || (beta_hat > beta_ref && beta_hat > 0.0 && 0.0 > n_fb))
            n_fb = 0.0;
    }
    io[IO_PART_FF] = w * 0.0;
    io[IO_PART_FB] = w * n_fb;
    return w * (0.0 + n_fb);
}

/* One communication step of h > 0 (YawMomentController.step): the clock (StepClock.tick, the step's length NaN
 * before the first; SampledModel._samples_due), then the samples due (io[IO_SAMPLES] of them), each followed by the
 * rate limit and saturation. */
KERNEL_API void sideslip_lqr_step(const LqrLaw *c, const LqrDesign *d, double *io)
{
    int k, samples = 0;
    int finite = isfinite(io[IO_DELTA] + io[IO_VX] + io[IO_BETA_HAT] + io[IO_YAW_RATE]);
    double h = io[IO_H], h_clock = io[IO_CLOCK_H], t;

    if (h_clock != h_clock || fabs(h - h_clock) > c->clock_rounding * h_clock) {   /* a new step length */
        io[IO_CLOCK_BASE] = io[IO_CLOCK_T];
        io[IO_CLOCK_N] = 0.0;
        io[IO_CLOCK_H] = h_clock = h;
    }
    io[IO_CLOCK_N] += 1.0;
    io[IO_CLOCK_T] = t = io[IO_CLOCK_BASE] + io[IO_CLOCK_N] * h_clock;
    while ((io[IO_SAMPLES_DONE] + 1.0) * c->Ts <= t + 1e-9 * c->Ts) {
        io[IO_SAMPLES_DONE] += 1.0;
        samples++;
    }
    io[IO_SAMPLES] = samples;
    for (k = 0; k < samples; k++) {
        double n, lim = c->Mz_max;
        if (finite) {
            n = sample(c, d, io);
        } else {
            n = io[IO_PART_FF] = io[IO_PART_FB] = 0.0;
        }
        if (c->shaped)                                                               /* _command */
            n = io[IO_MZ] + py_min(py_max(n - io[IO_MZ], -c->dmz), c->dmz);
        io[IO_MZ] = n > lim ? lim : (n < -lim ? -lim : n);
    }
}

KERNEL_API int sideslip_lqr_io_size(void) { return IO_SIZE; }
KERNEL_API int sideslip_lqr_law_size(void) { return (int)sizeof(LqrLaw); }
KERNEL_API int sideslip_lqr_design_size(void) { return (int)sizeof(LqrDesign); }
