"""A slipperier road found before an axle slides: the CUSUM of the tire pseudo-measurements' likelihood ratio.

Linearised at its estimate, the friction hardly moves a tire short of sliding, so a road slipperier than
estimated shows only once an axle slides.  Each sample :func:`friction_test` weighs the two tire residuals at a
few lower frictions (:data:`FRICTION_HYPOTHESES`: those more than two std below the estimate under which the more
utilised axle would use 0.5-0.85 of its friction) against the estimate's, with one noise for all (the model error
at utilisation 0.5: the fits are compared, not what each hypothesis claims to know); a CUSUM (Page 1954) of the
best one's log-likelihood ratio beyond the threshold re-initialises the friction there.
"""
from __future__ import annotations

import math

import numpy as np

from ..kalman import KalmanFilter
from .models import Geometry, SampleInputs
from .state import Fs
from .tire_model import axle_slip_values

__all__ = ["FRICTION_HYPOTHESES", "TEST_MODEL_ERROR", "friction_test"]

FRICTION_HYPOTHESES = tuple(math.log(m) for m in (0.8, 0.65, 0.5, 0.4, 0.3, 0.25, 0.2, 0.15))
"""The log frictions weighed against the estimate."""
TEST_MODEL_ERROR = 0.25
"""The tire model's relative error in the likelihoods: ``slip_model_error`` at utilisation 0.5."""

_VX, _LN_CF, _LN_CR, _LN_MU = int(Fs.VX), int(Fs.LN_CF), int(Fs.LN_CR), int(Fs.LN_MU)


def friction_test(mode, kf: KalmanFilter, x0: np.ndarray, axles: tuple, inp: SampleInputs, vx_ref: float, cfg,
                  geometry: Geometry, correlation: float) -> bool:
    """One sample of the test (module docstring) on one filter; returns True if it re-initialised the friction.

    Parameters
    ----------
    mode : Mode
        The filter's mode, whose ``friction_llr`` holds the CUSUM.
    kf : KalmanFilter
        Its filter; on a detection its friction is set to the best hypothesis with the prior's std
        (``cfg.mu_std0``) and no correlation.
    x0 : ndarray
        The state ``axles`` were computed at.
    axles : tuple of AxlePseudo
        The sample's tire pseudo-measurements.
    inp : SampleInputs
        The sample's inputs.
    vx_ref : float
        The speed the pseudo-measurements are scaled with [m/s].
    cfg : SideslipFusionConfig
        ``friction_test`` (the threshold), ``sigma_slip``, ``slip_model_error``, ``utilisation_max``, ``mu_std0``.
    geometry : Geometry
        The vehicle file's axles.
    correlation : float
        The pseudo-measurements' correlation factor (their noise's multiple).
    """
    ln_mu = x0.item(_LN_MU)
    top = ln_mu - 2.0 * math.sqrt(kf.P.item(_LN_MU, _LN_MU))
    util = max(axles[0].utilisation, axles[1].utilisation)
    best, best_ln, weights = 0.0, 0.0, None
    g, vx, u_max = geometry, x0.item(_VX), cfg.utilisation_max
    ln_cf, ln_cr = x0.item(_LN_CF), x0.item(_LN_CR)
    for ln_c in FRICTION_HYPOTHESES:
        # apart from the estimate only where its tire is nonlinear, and informative only short of saturation
        if ln_c > top or not 0.5 <= util * math.exp(ln_mu - ln_c) <= 0.85:
            continue
        if weights is None:
            weights = []
            for axle in axles:
                s = (cfg.sigma_slip + TEST_MODEL_ERROR * cfg.slip_model_error * abs(axle.slip)) * vx_ref
                weights.append(0.5 / (float(axle.row.dot(kf.P.dot(axle.row))) + s * s * correlation))
        # a residual moves with its axle's slip angle times v_x (axle_pseudo)
        mu_c, llr = math.exp(ln_c), 0.0
        for axle, w, force, f_z, f_x, c_hi, c_lo, ln_s in zip(
                axles, weights, (inp.fy_f, inp.fy_r), (inp.fz_f, inp.fz_r), (inp.fx_f, inp.fx_r), (g.c_f, g.c_r),
                (g.c_f_lo, g.c_r_lo), (ln_cf, ln_cr)):
            h = axle.residual
            h_c = h + vx * (axle_slip_values(force, f_z, f_x, c_hi, c_lo, g.mu_lo, ln_s, mu_c, u_max)[0] - axle.slip)
            llr += w * (h * h - h_c * h_c)
        if llr > best:
            best, best_ln = llr, ln_c
    if best <= 0.0:
        mode.friction_llr = 0.0
        return False
    mode.friction_llr += best
    if mode.friction_llr < cfg.friction_test:
        return False
    mode.friction_llr = 0.0
    kf.x[_LN_MU] = best_ln
    kf.P[_LN_MU, :] = 0.0
    kf.P[:, _LN_MU] = 0.0
    kf.P[_LN_MU, _LN_MU] = cfg.mu_std0 ** 2
    return True
