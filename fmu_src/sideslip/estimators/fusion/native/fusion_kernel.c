/*
 * SideslipFusion's tire pseudo-measurements in C: the same arithmetic as the pure-Python reference
 * (sideslip/estimators/fusion/models.py axle_pseudo and sideslip/estimators/fusion/tire_model.py axle_slip_values,
 * axle_stiffness, lateral_capacity, _fiala), operation for operation, so that both give the same doubles (IEEE 754
 * binary64, no contraction into fused multiply-adds, the same libm; Python's x ** y is the C library's pow).  The
 * equations and their sources are documented in those modules.
 *
 * Where the reference raises (a float division by zero, math.exp or ** overflowing), the function returns a code
 * instead and sideslip/plant/kernel.py raises the same exception, which the estimator's guard catches.
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

/* Return codes: what the Python reference raises. */
enum { FUSION_OK = 0, FUSION_ZERO_DIVISION = 1, FUSION_OVERFLOW = 2 };

/* State indices (sideslip.estimators.fusion.state.Fs) of the rows' entries. */
enum { VX, VY, PSI, B_R, B_AX, B_AY, D_DELTA, LN_CF, LN_CR, LN_MU };

/* The vehicle file's axles (models.Geometry, same order). */
typedef struct { double l_f, l_r, c_f, c_r, c_f_lo, c_r_lo, mu_lo, m_f, m_r; } Geometry;

/* io (sideslip/plant/kernel.py FUSION_IO): in, the state's first ten values (VX..LN_MU), the sample's inputs
 * (models.SampleInputs, in its order) and u_max; out, per axle (front, then rear) the residual, the slip angle, the
 * utilisation, the slip at u_max and d ln F_max / d ln mu (models.AxlePseudo). */
enum { IO_X = 0, IO_AX = 10, IO_AY, IO_R_M, IO_DELTA, IO_V_WHEEL, IO_FY_F, IO_FY_R, IO_FZ_F, IO_FZ_R, IO_FX_F, IO_FX_R,
       IO_U_MAX, IO_OUT, IO_SIZE = IO_OUT + 10 };

/* Python's float division: ZeroDivisionError for a zero divisor, whatever the dividend. */
#define DIV(a, b, out) do { if ((b) == 0.0) return FUSION_ZERO_DIVISION; (out) = (a) / (b); } while (0)

/* math.exp: OverflowError where a finite argument overflows. */
static int py_exp(double x, double *out)
{
    *out = exp(x);
    return isinf(*out) && isfinite(x) ? FUSION_OVERFLOW : FUSION_OK;
}

/* float ** float for a base >= 0 or an integral exponent (CPython's float_pow: 1 ** y is 1, otherwise the
 * C library's pow; OverflowError where a finite result overflows). */
static int py_pow(double x, double y, double *out)
{
    if (fabs(x) == 1.0 || y == 0.0) {
        *out = (x < 0.0 && fmod(fabs(y), 2.0) == 1.0) ? -1.0 : 1.0;
        return FUSION_OK;
    }
    *out = pow(x, y);
    return isinf(*out) && isfinite(x) && isfinite(y) ? FUSION_OVERFLOW : FUSION_OK;
}

/* One axle (tire_model.axle_slip_values): the slip angle alpha, its derivatives d_c (stiffness scale) and d_m
 * (friction), the utilisation u, the stiffness c, the lateral capacity f_max, d ln C / d ln mu (k) and
 * d ln F_max / d ln mu (g). */
typedef struct { double alpha, d_c, d_m, u, c, f_max, k, g; } AxleSlip;

static int axle_slip_values(double force, double f_z, double f_x, double c_hi, double c_lo, double mu_lo,
                            double ln_scale, double mu, double u_max, AxleSlip *s)
{
    double w, c, k, scale, f_max, f2, lat2, limit, uc, a, p;
    int rc;

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
    if ((rc = py_exp(ln_scale, &scale)) != FUSION_OK)
        return rc;
    c *= scale;
    /* lateral_capacity(mu f_z, f_x) */
    f_max = mu * f_z;
    f2 = f_max * f_max;
    lat2 = f2 - f_x * f_x;
    if ((rc = py_pow(CAPACITY_MIN * f_max, 2.0, &limit)) != FUSION_OK)
        return rc;
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
    if ((rc = py_pow(1.0 - uc, 1.0 / 3.0, &w)) != FUSION_OK)
        return rc;
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

KERNEL_API int sideslip_fusion_io_size(void) { return IO_SIZE; }

KERNEL_API int sideslip_fusion_geometry_size(void) { return (int)(sizeof(Geometry) / sizeof(double)); }

/*
 * The two tire pseudo-measurements of a sample (models.axle_pseudo): io as above; rows, the front and the rear
 * row (n values each), of which the function writes the entries the reference sets (the caller keeps the others
 * zero).  Returns FUSION_OK, or what the reference raises.
 */
KERNEL_API int sideslip_fusion_axles(const double *gp, double *io, double *row_f, double *row_r)
{
    const Geometry *g = (const Geometry *)gp;
    const double *x = io + IO_X;
    double vx = x[VX], vy = x[VY], mu, r, steer, k_max, slip_max, q;
    AxleSlip f, rr;
    int rc;

    if ((rc = py_exp(x[LN_MU], &mu)) != FUSION_OK)
        return rc;
    r = io[IO_R_M] - x[B_R];
    if ((rc = axle_slip_values(io[IO_FY_F], io[IO_FZ_F], io[IO_FX_F], g->c_f, g->c_f_lo, g->mu_lo, x[LN_CF], mu,
                               io[IO_U_MAX], &f)) != FUSION_OK)
        return rc;
    if ((rc = axle_slip_values(io[IO_FY_R], io[IO_FZ_R], io[IO_FX_R], g->c_r, g->c_r_lo, g->mu_lo, x[LN_CR], mu,
                               io[IO_U_MAX], &rr)) != FUSION_OK)
        return rc;
    steer = io[IO_DELTA] - x[D_DELTA];
    io[IO_OUT] = vy + g->l_f * r - vx * (steer - f.alpha);
    row_f[VX] = f.alpha - steer;
    row_f[VY] = 1.0;
    row_f[B_R] = -g->l_f;
    row_f[D_DELTA] = vx;
    row_f[LN_CF] = vx * f.d_c;
    row_f[LN_MU] = vx * (f.g * f.d_m + f.k * f.d_c);
    DIV(-vx * g->m_f, f.c, row_f[B_AY]);
    io[IO_OUT + 5] = vy - g->l_r * r + vx * rr.alpha;
    row_r[VX] = rr.alpha;
    row_r[VY] = 1.0;
    row_r[B_R] = g->l_r;
    row_r[LN_CR] = vx * rr.d_c;
    row_r[LN_MU] = vx * (rr.g * rr.d_m + rr.k * rr.d_c);
    DIV(-vx * g->m_r, rr.c, row_r[B_AY]);
    if ((rc = py_pow(1.0 - io[IO_U_MAX], 1.0 / 3.0, &q)) != FUSION_OK)
        return rc;
    k_max = 1.0 - q;     /* the slip at u_max over the full slide's 3 F_max / C */
    DIV(3.0 * k_max * f.f_max, f.c, slip_max);
    io[IO_OUT + 1] = f.alpha;
    io[IO_OUT + 2] = f.u;
    io[IO_OUT + 3] = slip_max;
    io[IO_OUT + 4] = f.g;
    DIV(3.0 * k_max * rr.f_max, rr.c, slip_max);
    io[IO_OUT + 6] = rr.alpha;
    io[IO_OUT + 7] = rr.u;
    io[IO_OUT + 8] = slip_max;
    io[IO_OUT + 9] = rr.g;
    return FUSION_OK;
}
