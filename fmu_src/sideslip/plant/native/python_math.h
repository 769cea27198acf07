/*
 * Python's float semantics in C, for the compiled steps that must give the same doubles as their Python reference
 * (sideslip/plant/native/driver_kernel.c, sideslip/estimators/fusion/native/fusion_kernel.c): math.hypot,
 * math.remainder and float ** float as CPython computes them, and the exceptions it raises as return codes.
 */
#ifndef SIDESLIP_PYTHON_MATH_H
#define SIDESLIP_PYTHON_MATH_H

#include <float.h>
#include <math.h>

/* What the Python reference raises, as a return code (sideslip/plant/kernel.py raises it again). */
enum { PY_OK = 0, PY_ZERO_DIVISION = 1, PY_OVERFLOW = 2, PY_DOMAIN = 3 };

/* Python's math.hypot of two coordinates (CPython's vector_norm, not libm's hypot, which differs in the last bit
 * now and then): scaled by a power of two, squared and summed as double-length numbers, a square root and one
 * differential correction.  The exact product uses Dekker's split, so that no fused multiply-add is needed. */
typedef struct { double hi, lo; } Double2;

static inline Double2 sum_ordered(double a, double b)     /* |a| >= |b|: a + b exactly as hi + lo */
{
    Double2 r;
    r.hi = a + b;
    r.lo = b - (r.hi - a);
    return r;
}

static inline Double2 product(double x, double y)         /* x y exactly as hi + lo (Dekker) */
{
    double tx = x * 134217729.0, ty = y * 134217729.0;  /* 2^27 + 1 */
    double xh = tx - (tx - x), xl = x - xh, yh = ty - (ty - y), yl = y - yh;
    double p = xh * yh, q = xh * yl + xl * yh;
    Double2 r;
    r.hi = p + q;
    r.lo = p - r.hi + q + xl * yl;
    return r;
}

static inline double py_hypot(double a, double b)
{
    double v[2], largest, scale, csum = 1.0, frac1 = 0.0, frac2 = 0.0, h, x;
    Double2 pr, sm;
    int i, e;

    v[0] = fabs(a);
    v[1] = fabs(b);
    largest = v[0] > v[1] ? v[0] : v[1];
    if (isinf(v[0]) || isinf(v[1]))
        return INFINITY;
    if (isnan(a) || isnan(b))
        return NAN;
    if (largest == 0.0)
        return 0.0;
    frexp(largest, &e);
    if (e < -1023)                    /* subnormal: normalised first, as CPython does */
        return DBL_MIN * py_hypot(v[0] / DBL_MIN, v[1] / DBL_MIN);
    scale = ldexp(1.0, -e);
    for (i = 0; i < 2; i++) {
        x = v[i] * scale;
        pr = product(x, x);
        sm = sum_ordered(csum, pr.hi);
        csum = sm.hi;
        frac1 += pr.lo;
        frac2 += sm.lo;
    }
    h = sqrt(csum - 1.0 + (frac1 + frac2));
    pr = product(-h, h);
    sm = sum_ordered(csum, pr.hi);
    csum = sm.hi;
    frac1 += pr.lo;
    frac2 += sm.lo;
    x = csum - 1.0 + (frac1 + frac2);
    h += x / (2.0 * h);
    return h / scale;
}

/* math.exp: OverflowError where a finite argument overflows. */
static inline int py_exp(double x, double *out)
{
    *out = exp(x);
    return isinf(*out) && isfinite(x) ? PY_OVERFLOW : PY_OK;
}

/* float ** float for a base >= 0 or an integral exponent (CPython's float_pow: 1 ** y and x ** 0 are 1, otherwise
 * the C library's pow; OverflowError where a finite result overflows). */
static inline int py_pow(double x, double y, double *out)
{
    /* the library's pow itself: a compiler that sees a constant exponent turns pow(x, 2.0) into x * x, which the C
     * library's pow (Python's) does not always equal in the last bit */
    double (*volatile library_pow)(double, double) = pow;

    if (fabs(x) == 1.0 || y == 0.0) {
        *out = (x < 0.0 && fmod(fabs(y), 2.0) == 1.0) ? -1.0 : 1.0;
        return PY_OK;
    }
    *out = library_pow(x, y);
    return isinf(*out) && isfinite(x) && isfinite(y) ? PY_OVERFLOW : PY_OK;
}

/* math.remainder (CPython's m_remainder: x less the nearest multiple of y, ties to the even one, exactly); a
 * ValueError for an infinite x or a zero y, as math.remainder raises. */
static inline int py_remainder(double x, double y, double *out)
{
    double absx, absy, m, c, r;

    if (isnan(x) || isnan(y)) {
        *out = isnan(x) ? x : y;
        return PY_OK;
    }
    if (isinf(x) || y == 0.0)
        return PY_DOMAIN;
    if (isinf(y)) {
        *out = x;
        return PY_OK;
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
    return PY_OK;
}

#endif
