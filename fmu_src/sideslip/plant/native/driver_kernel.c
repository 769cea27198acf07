/*
 * The maneuver driver's step in C: the path follower and the speed controller of the pure-Python reference
 * (sideslip/plant/driver.py Driver.step and _pure_pursuit, sideslip/plant/paths.py Path.project and
 * Path.point_at), operation for operation, so that both give the same doubles (no contraction into fused
 * multiply-adds, the same libm, Python's own hypot: python_math.h).  The maneuver's schedules (target speed, open-loop
 * handwheel) are Python functions of time and stay there: the caller passes their values of the step.
 *
 * Compiled into the same binary as plant_kernel.c and loaded with ctypes (sideslip/plant/kernel.py).
 */
#include <float.h>
#include <math.h>

#include "python_math.h"

#if defined(_WIN32)
#define KERNEL_API __declspec(dllexport)
#else
#define KERNEL_API __attribute__((visibility("default")))
#endif

/* What a driver's steps share (sideslip/plant/kernel.py DriverPlan writes it, in this order). */
typedef struct {
    const double *x, *y, *s;          /* the path's samples [m] and their stations [m] */
    const double *ex, *ey, *seg2, *seg; /* each segment's direction, squared length and length (the last closes) */
    const double *vlim;               /* curve speed limit per sample [m/s]; NULL: none */
    int n, closed;
    double psi_first, psi_last;       /* the path's heading at its ends [rad] (continued beyond an open path) */
    double preview_time, preview_min, two_l, rate;
    double kp, ki, roll_force, drag, m, f_lo, f_hi, radius, brake_only_from, coast_from, hold_torque;
} DriverPlan;

/* The step's values (sideslip/plant/kernel.py DriverKernel.step). */
enum { IO_H, IO_T, IO_VX, IO_X, IO_Y, IO_YAW, IO_OPEN_LOOP, IO_TARGET, IO_V_PLAN,
       IO_IDX, IO_DELTA, IO_INTEG, IO_V_PREV, IO_T_DRIVE, IO_T_BRAKE, IO_V_REF, IO_SIZE };

static int wrap_index(int j, int n) { j %= n; return j < 0 ? j + n : j; }   /* Python's j % n */

/* Path.project: nearest sample by hill-climbing from the hint, station of the foot point. */
static int project(const DriverPlan *p, double px, double py, int hint, double *station)
{
    const double *xl = p->x, *yl = p->y;
    int n = p->n, i, direction, a, k;
    double dx, dy, d, dj, w;

    i = p->closed ? wrap_index(hint, n) : (hint < 0 ? 0 : (hint > n - 1 ? n - 1 : hint));
    dx = xl[i] - px;
    dy = yl[i] - py;
    d = dx * dx + dy * dy;
    for (direction = 1; direction >= -1; direction -= 2) {
        int moved = 0;
        for (k = 0; k < n; k++) {     /* at most once round a closed path (the reference climbs while closer) */
            int j = i + direction;
            if (p->closed)
                j = wrap_index(j, n);
            else if (!(0 <= j && j < n))
                break;
            dx = xl[j] - px;
            dy = yl[j] - py;
            dj = dx * dx + dy * dy;
            if (dj >= d)
                break;
            i = j;
            d = dj;
            moved = 1;
        }
        if (moved)
            break;
    }
    for (k = 0; k < 2; k++) {         /* the segment after i, else the one before it */
        a = i - k;
        if (p->closed)
            a = wrap_index(a, n);
        else if (a < 0 || a + 1 >= n)
            continue;
        w = ((px - xl[a]) * p->ex[a] + (py - yl[a]) * p->ey[a]) / p->seg2[a];
        if (0.0 <= w && w <= 1.0) {
            *station = p->s[a] + w * p->seg[a];
            return i;
        }
    }
    *station = p->s[i];
    return i;
}

/* Python's float modulo (the result has the divisor's sign). */
static double py_mod(double v, double w)
{
    double m = fmod(v, w);
    if (m != 0.0) {
        if ((w < 0.0) != (m < 0.0))
            m += w;
    } else {
        m = copysign(0.0, w);
    }
    return m;
}

/* Path.point_at. */
static void point_at(const DriverPlan *p, double station, double *tx, double *ty)
{
    const double *sl = p->s, *xl = p->x, *yl = p->y;
    int n = p->n, lo, hi, i;
    double w;

    if (p->closed) {
        station = py_mod(station, sl[n - 1]);
    } else if (station > sl[n - 1] || station < 0.0) {
        double psi, over;
        i = station > 0.0 ? n - 1 : 0;
        psi = station > 0.0 ? p->psi_last : p->psi_first;
        over = station - sl[i];
        *tx = xl[i] + over * cos(psi);
        *ty = yl[i] + over * sin(psi);
        return;
    }
    lo = 0;                           /* bisect_right */
    hi = n;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (station < sl[mid])
            hi = mid;
        else
            lo = mid + 1;
    }
    i = lo - 1;
    i = i < 0 ? 0 : (i > n - 2 ? n - 2 : i);
    w = (station - sl[i]) / (sl[i + 1] - sl[i]);
    *tx = xl[i] + w * (xl[i + 1] - xl[i]);
    *ty = yl[i] + w * (yl[i + 1] - yl[i]);
}

/* Driver._pure_pursuit: the road-wheel angle toward the look-ahead point (updates the sample index). */
static double pure_pursuit(const DriverPlan *p, double vx, double px, double py, double yaw, int *idx)
{
    double station, look, tx, ty, dx, dy, c, s, lx, ly;

    *idx = project(p, px, py, *idx, &station);
    look = p->preview_time * (vx > 0.0 ? vx : -vx);
    if (look < p->preview_min)
        look = p->preview_min;
    point_at(p, station + look, &tx, &ty);
    dx = tx - px;
    dy = ty - py;
    c = cos(yaw);
    s = sin(yaw);
    lx = c * dx + s * dy;
    ly = -s * dx + c * dy;
    return atan(p->two_l * sin(atan2(ly, lx)) / py_hypot(lx, ly));
}

/* Driver.step after its clock and the maneuver's schedules: steering (path or open-loop target, rate limit,
 * +-0.7 rad) and the speed controller.  Reads and writes ``io`` (IO_* order). */
KERNEL_API void sideslip_driver_step(const DriverPlan *p, double *io)
{
    double h = io[IO_H], t = io[IO_T], vx = io[IO_VX];
    double max_step, change, delta, v_ref, dv_ref, speed, err, a_cmd, f_res, f_hi, force, torque;
    int idx = (int)io[IO_IDX];

    /* ---- steering */
    double target = io[IO_OPEN_LOOP] != 0.0 ? io[IO_TARGET]
                                            : pure_pursuit(p, vx, io[IO_X], io[IO_Y], io[IO_YAW], &idx);
    max_step = p->rate * h;
    change = target - io[IO_DELTA];
    change = change > max_step ? max_step : (change < -max_step ? -max_step : change);
    delta = io[IO_DELTA] + change;
    delta = delta > 0.7 ? 0.7 : (delta < -0.7 ? -0.7 : delta);
    io[IO_IDX] = idx;
    io[IO_DELTA] = delta;

    /* ---- speed */
    v_ref = io[IO_V_PLAN];
    if (p->vlim != 0 && p->vlim[idx] < v_ref)
        v_ref = p->vlim[idx];
    dv_ref = (v_ref - io[IO_V_PREV]) / h;
    io[IO_V_PREV] = v_ref;
    io[IO_V_REF] = v_ref;
    speed = vx >= 0 ? vx : -vx;
    if (v_ref <= 0.05 && speed < 0.3) {   /* at a standstill with no target: the brake holds the car */
        io[IO_INTEG] = 0.0;
        io[IO_T_DRIVE] = 0.0;
        io[IO_T_BRAKE] = p->hold_torque;
        return;
    }
    err = v_ref - vx;
    a_cmd = dv_ref + p->kp * err + p->ki * io[IO_INTEG];
    f_res = p->roll_force * (vx >= 0 ? 1.0 : -1.0) + p->drag * vx * speed;
    f_hi = t >= p->brake_only_from ? 0.0 : p->f_hi;
    force = p->m * a_cmd + f_res;
    if (p->f_lo < force && force < f_hi)
        io[IO_INTEG] += err * h;          /* no wind-up while saturated */
    else
        force = force <= p->f_lo ? p->f_lo : f_hi;
    torque = t < p->coast_from ? force * p->radius : 0.0;
    io[IO_T_DRIVE] = 0.0 > torque ? 0.0 : torque;
    io[IO_T_BRAKE] = 0.0 > -torque ? 0.0 : -torque;
}

/* The layout the Python side checks before it trusts the binary. */
KERNEL_API int sideslip_driver_io_size(void) { return IO_SIZE; }
KERNEL_API int sideslip_driver_plan_size(void) { return (int)sizeof(DriverPlan); }
